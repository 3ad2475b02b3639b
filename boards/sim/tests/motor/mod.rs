//! Shared set-up of the motor-control tests: the 400 W servo plant with the firmware's axis.

#![allow(dead_code)]

use board_sim::plant::PlantConfig;
use board_sim::servo::{axis_config, SimServo, Tuning};
use firmware::motor::axis::{AxisCommand, AxisState, ControlMode};

/// PWM periods per 1 ms bus cycle at 40 kHz.
pub const PERIODS_PER_CYCLE: u64 = 40;

/// Increments per revolution of the servo's 20-bit encoder.
pub const CPR: f64 = 1_048_576.0;

/// The servo with `tuning`, enabled in `mode` and running (offsets calibrated).
pub fn running_servo(plant: PlantConfig, tuning: &Tuning, mode: ControlMode) -> SimServo {
    let cfg = axis_config(&plant, tuning);
    let mut servo = SimServo::new(plant, cfg).expect("valid configuration");
    let command = AxisCommand {
        enable: true,
        mode,
        ..Default::default()
    };
    for _ in 0..50 {
        let mut c = command;
        c.position = servo.feedback().position;
        servo.publish(c);
        servo.run_periods(PERIODS_PER_CYCLE);
        if servo.axis.state() == AxisState::Running {
            return servo;
        }
    }
    panic!("the axis did not start: {:?}", servo.feedback());
}

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
