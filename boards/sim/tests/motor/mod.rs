//! Shared set-up of the motor-control tests: the 400 W servo plant with the firmware's axis.

#![allow(dead_code)]

pub use board_sim::experiments::{running_servo, PERIODS_PER_CYCLE};

/// Increments per revolution of the servo's 20-bit encoder.
pub const CPR: f64 = 1_048_576.0;

/// Mechanical rad/s → increments/s.
pub fn rad_s_to_counts(rad_s: f64) -> f32 {
    (rad_s * CPR / std::f64::consts::TAU) as f32
}

/// rpm → increments/s.
pub fn rpm_to_counts(rpm: f64) -> f32 {
    (rpm / 60.0 * CPR) as f32
}

/// Increments → mechanical rad.
pub fn counts_to_rad(counts: f64) -> f64 {
    counts * std::f64::consts::TAU / CPR
}

/// The output directory of the response plots (under the target directory, so tests never
/// write into the source tree).
pub fn plot_dir() -> std::path::PathBuf {
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| {
            std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../target")
        });
    target.join("motor-plots")
}
