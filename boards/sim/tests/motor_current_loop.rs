//! Current loop on the simulated 400 W servo, measured like a drive's frequency-response tool
//! ([`board_sim::experiments::current_loop_point`]): a sine injected into the q-current
//! reference one frequency at a time, the true q current fitted by correlation.
//!
//! Requirement (DESIGN.md §6, issue 4): closed-loop bandwidth (−3 dB) ≥ 2 kHz and phase margin
//! ≥ 45° at 40 kHz PWM. The phase margin comes from the measured closed loop T: the open loop is
//! L = T/(1 − T); at |L| = 1, PM = 180° + ∠L.

use std::f64::consts::TAU;

use board_sim::experiments::{current_loop_sweep, loop_figures};

/// PWM (= current-loop) frequency of the servo.
const PWM_HZ: f64 = 40_000.0;
/// The current loop's design crossover (Tuning::default).
const DESIGN_CROSSOVER_HZ: f64 = 2_000.0;
/// Delay from sampling to the voltage's centre of gravity: one period of computation and
/// reload, half a period of zero-order hold.
const DELAY_PERIODS: f64 = 1.5;

#[test]
fn current_loop_bandwidth_and_phase_margin() {
    let points = current_loop_sweep();
    for p in &points {
        println!(
            "{:8.1} Hz  |T| {:6.3}  ∠T {:7.1}°",
            p.hz,
            p.gain(),
            p.phase_deg()
        );
    }
    // Unity gain at low frequency: the loop has an integrator.
    assert!(
        (points[0].gain() - 1.0).abs() < 0.02,
        "|T| at {} Hz: {}",
        points[0].hz,
        points[0].gain()
    );
    let f = loop_figures(&points).expect("the sweep reaches −3 dB and the crossover");
    println!("{f:?}");
    assert!(
        f.bandwidth_hz >= 2_000.0,
        "−3 dB bandwidth {:.0} Hz < 2 kHz",
        f.bandwidth_hz
    );
    assert!(
        f.phase_margin_deg >= 45.0,
        "phase margin {:.1}° < 45°",
        f.phase_margin_deg
    );
    // The design (pole-zero cancellation: L = ωc·e^(−s·Td)/s) predicts the crossover at the
    // requested frequency and PM = 90° − ωc·Td. The measurement must agree, or the plots and
    // the figures above would describe a different loop than the one designed.
    let predicted_margin = 90.0 - (TAU * f.crossover_hz * DELAY_PERIODS / PWM_HZ).to_degrees();
    assert!(
        (f.crossover_hz / DESIGN_CROSSOVER_HZ - 1.0).abs() < 0.05,
        "crossover {:.0} Hz vs the {DESIGN_CROSSOVER_HZ} Hz design",
        f.crossover_hz
    );
    assert!(
        (f.phase_margin_deg - predicted_margin).abs() < 3.0,
        "phase margin {:.1}° vs {predicted_margin:.1}° predicted",
        f.phase_margin_deg
    );
}
