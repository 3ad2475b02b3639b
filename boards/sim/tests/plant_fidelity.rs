//! The averaged plant ([`Fidelity::Averaged`]: one step per PWM period with the period's
//! average leg voltages) under the firmware's closed loops behaves as the PWM-resolved plant
//! does, to within what the current ripple it leaves out can change. The plant-level laws
//! (time constants, back-EMF, rectifier braking, dead time) are checked for both fidelities in
//! the plant's own tests; these check the servo as a master sees it: a speed step and a
//! load-torque step, the figures the speed-loop tests assert on.
//!
//! Bound: 0.5 % of the step at every sample of the trace (measured: 0.03 %), 2 % of the dip. The ripple of the PWM-resolved plant
//! is sampled at its centre, where it averages out, so the loops see the same currents up to
//! the ADC's noise and quantisation (0.03 A rms, 25 mA per count against 15 A of acceleration
//! current) and the step's discretisation.

use board_sim::experiments::{load_step_of, velocity_step_of};
use board_sim::plant::{Fidelity, PlantConfig};

fn servo(fidelity: Fidelity) -> PlantConfig {
    PlantConfig {
        fidelity,
        ..PlantConfig::servo_400w()
    }
}

#[test]
fn a_speed_step_is_the_same_on_the_averaged_plant() {
    let rpm = 1000.0;
    let pwm = velocity_step_of(servo(Fidelity::PwmResolved), rpm);
    let averaged = velocity_step_of(servo(Fidelity::Averaged), rpm);
    assert_eq!(pwm.trace.len(), averaged.trace.len());
    let worst = pwm
        .trace
        .iter()
        .zip(&averaged.trace)
        .map(|(a, b)| (a.1 - b.1).abs())
        .fold(0.0, f64::max);
    println!(
        "largest difference {worst:.2} rpm; overshoot {:.2} % vs {:.2} %, settled {:.2} vs {:.2} ms",
        pwm.overshoot * 100.0,
        averaged.overshoot * 100.0,
        pwm.settling_s * 1e3,
        averaged.settling_s * 1e3
    );
    assert!(worst < 0.005 * rpm, "speeds differ by {worst} rpm");
    assert!((pwm.overshoot - averaged.overshoot).abs() < 0.01);
    assert!((pwm.settling_s - averaged.settling_s).abs() < 0.5e-3);
}

#[test]
fn a_load_step_is_rejected_the_same_on_the_averaged_plant() {
    let (rpm, load) = (1000.0, 1.0);
    let pwm = load_step_of(servo(Fidelity::PwmResolved), rpm, load);
    let averaged = load_step_of(servo(Fidelity::Averaged), rpm, load);
    println!(
        "dip {:.1} vs {:.1} rpm at {:.2} vs {:.2} ms",
        pwm.dip_rpm,
        averaged.dip_rpm,
        pwm.dip_at_s * 1e3,
        averaged.dip_at_s * 1e3
    );
    assert!((pwm.speed_rpm - averaged.speed_rpm).abs() < 0.005 * rpm);
    assert!((pwm.dip_rpm - averaged.dip_rpm).abs() < 0.02 * pwm.dip_rpm);
    assert!((pwm.dip_at_s - averaged.dip_at_s).abs() < 0.5e-3);
}
