//! The axis' stop ramp (`ControlMode::Stop`) on the simulated 400 W servo: from a speed, the
//! motor decelerates along the commanded ramp (the plant's true speed follows the reference
//! within the speed loop's lag) and holds zero speed; a deceleration of 0 stops at the current
//! limit, much faster than any ramp.

use board_sim::experiments::{running_servo, PERIODS_PER_CYCLE};
use board_sim::plant::PlantConfig;
use board_sim::servo::{SimServo, Tuning};
use firmware::motor::axis::{AxisCommand, ControlMode};

const CPR: f64 = 1_048_576.0;
const RPM: f64 = 1_000.0;

fn counts_per_s(rpm: f64) -> f32 {
    (rpm / 60.0 * CPR) as f32
}

fn rpm(servo: &SimServo) -> f64 {
    servo.plant.mech_speed_rad_s() / std::f64::consts::TAU * 60.0
}

/// The servo at [`RPM`] in velocity mode.
fn spinning() -> SimServo {
    let mut servo = running_servo(
        PlantConfig::servo_400w(),
        &Tuning::default(),
        ControlMode::Velocity,
    );
    let command = AxisCommand {
        enable: true,
        mode: ControlMode::Velocity,
        velocity: counts_per_s(RPM),
        ..Default::default()
    };
    for _ in 0..400 {
        servo.publish(command);
        servo.run_periods(PERIODS_PER_CYCLE);
    }
    assert!((rpm(&servo) - RPM).abs() < 10.0, "{}", rpm(&servo));
    servo
}

/// Stops with `deceleration` (increments/s²); the speed after every 1 ms cycle (rpm).
fn stop(servo: &mut SimServo, deceleration: f32, cycles: usize) -> Vec<f64> {
    let command = AxisCommand {
        enable: true,
        mode: ControlMode::Stop,
        deceleration,
        ..Default::default()
    };
    (0..cycles)
        .map(|_| {
            servo.publish(command);
            servo.run_periods(PERIODS_PER_CYCLE);
            rpm(servo)
        })
        .collect()
}

#[test]
fn the_motor_follows_the_stop_ramp_and_holds_zero_speed() {
    let mut servo = spinning();
    // 6000 rpm/s: from 1000 rpm in 1/6 s.
    let speeds = stop(&mut servo, counts_per_s(6_000.0), 300);
    for (k, v) in speeds.iter().enumerate().take(150) {
        let expected = RPM - 6_000.0 * (k + 1) as f64 * 1e-3;
        assert!(
            (v - expected).abs() < 30.0,
            "{k} ms: {v:.0} rpm, the ramp {expected:.0}: {speeds:?}"
        );
    }
    assert!(
        speeds[200..].iter().all(|v| v.abs() < 5.0),
        "held at rest: {:?}",
        &speeds[200..]
    );
    assert!(!servo.feedback().stopping);
    assert!(servo.latched().gates, "powered while holding");
}

#[test]
fn a_stop_at_once_brakes_at_the_current_limit() {
    let mut servo = spinning();
    assert!(
        !servo.feedback().current_limited,
        "steady speed: below the limit"
    );
    let command = AxisCommand {
        enable: true,
        mode: ControlMode::Stop,
        ..Default::default()
    };
    servo.publish(command);
    servo.run_periods(PERIODS_PER_CYCLE);
    assert!(servo.feedback().current_limited, "braking at the limit");
    let speeds = stop(&mut servo, 0.0, 100);
    let to_rest = speeds.iter().position(|v| v.abs() < 20.0).expect("stops");
    // The quickest ramp of the tests (6000 rpm/s) needs 167 ms; the current limit far less.
    assert!(to_rest < 40, "at rest after {to_rest} ms: {speeds:?}");
}
