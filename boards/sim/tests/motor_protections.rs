//! Motor protections end to end on the simulated 48 V / 400 W servo: each fault injected into the
//! plant trips its own [`MotorFault`] with the gates off, at the time its configured level and
//! confirmation predict (every expectation is computed from the [`AxisConfig`], none is copied
//! from a run); a latched fault holds the gates off until a rising `fault_reset` with the cause
//! gone; and an aggressive but normal move trips nothing.

mod motor;

use std::f64::consts::TAU;

use board_sim::plant::{EncoderFaultInjection, EncoderParams, PlantConfig};
use board_sim::servo::{axis_config, SimServo, Tuning};
use firmware::motor::axis::{AxisCommand, AxisConfig, AxisState, ControlMode};
use firmware::motor::protection::{
    confirmation_samples, max_increments_per_sample, I2tConfig, ProtectionConfig,
};
use firmware::motor::MotorFault;
use motor::{rpm_to_counts, running_servo, CPR, PERIODS_PER_CYCLE};

// ---- set-up ------------------------------------------------------------------------------------

/// The 400 W servo with the board's configuration, edited by `edit`.
fn servo_with(plant: PlantConfig, edit: impl FnOnce(&mut AxisConfig)) -> SimServo {
    let mut cfg = axis_config(&plant, &Tuning::default());
    edit(&mut cfg);
    SimServo::new(plant, cfg).expect("valid configuration")
}

/// Enables `servo` in `mode` (zero set-points) and runs until it is `Running`.
fn start(servo: &mut SimServo, mode: ControlMode) {
    for _ in 0..1_000 {
        let c = AxisCommand {
            enable: true,
            mode,
            position: servo.feedback().position,
            ..Default::default()
        };
        servo.publish(c);
        servo.run_periods(PERIODS_PER_CYCLE);
        if servo.axis.state() == AxisState::Running {
            return;
        }
        assert_eq!(servo.axis.fault(), None, "fault while starting");
    }
    panic!("the axis did not start: {:?}", servo.feedback());
}

/// The default servo running in `mode`.
fn running(mode: ControlMode) -> SimServo {
    running_servo(PlantConfig::servo_400w(), &Tuning::default(), mode)
}

fn cfg(servo: &SimServo) -> AxisConfig {
    *servo.axis.config()
}

fn prot(servo: &SimServo) -> ProtectionConfig {
    servo.axis.config().protection
}

/// Loop (protection) sample time, s.
fn loop_dt(servo: &SimServo) -> f64 {
    let c = cfg(servo);
    f64::from(c.loop_divider) / f64::from(c.pwm_hz)
}

/// PWM periods per loop sample.
fn divider(servo: &SimServo) -> u64 {
    u64::from(cfg(servo).loop_divider)
}

/// A command in `mode` holding the present position.
fn hold(servo: &SimServo, mode: ControlMode) -> AxisCommand {
    AxisCommand {
        enable: true,
        mode,
        position: servo.feedback().position,
        ..Default::default()
    }
}

/// Publishes `command` once per bus cycle and runs period by period until the axis reports a
/// fault or `max_periods` passed; returns the number of periods run until (and including) the
/// one whose control step tripped, or `None`. Checks that a fault that cuts the gates did so in
/// that period, and that one that allows a controlled stop (the thermal faults, a following
/// error: `MotorFault::allows_controlled_stop`) left a running axis running with its gates on,
/// for the drive's fault reaction ([`end_fault_reaction`]).
fn run_until_fault(servo: &mut SimServo, command: AxisCommand, max_periods: u64) -> Option<u64> {
    for k in 0..max_periods {
        if k % PERIODS_PER_CYCLE == 0 {
            servo.publish(command);
        }
        let was_running = servo.axis.state() == AxisState::Running;
        servo.period();
        if let Some(fault) = servo.axis.fault() {
            if fault.allows_controlled_stop() && was_running {
                assert_eq!(servo.axis.state(), AxisState::Running, "under control");
                assert!(servo.latched().gates, "gates on for the fault reaction");
            } else {
                assert_eq!(servo.axis.state(), AxisState::Faulted);
                assert!(!servo.latched().gates, "gates on in the tripping period");
            }
            return Some(k + 1);
        }
    }
    None
}

/// The drive's fault reaction ends (its ramp done, or none): `command` without the enable for
/// one bus cycle. The axis holding a fault is `Faulted` with its gates off.
fn end_fault_reaction(servo: &mut SimServo, command: AxisCommand) {
    servo.publish(AxisCommand {
        enable: false,
        ..command
    });
    servo.run_periods(PERIODS_PER_CYCLE);
    assert_eq!(servo.axis.state(), AxisState::Faulted);
    assert!(!servo.latched().gates, "gates off");
}

/// Runs on with `command` for `periods`, asserting that the axis stays faulted with `fault` and
/// the gates stay off.
fn stays_faulted(servo: &mut SimServo, command: AxisCommand, fault: MotorFault, periods: u64) {
    for k in 0..periods {
        if k % PERIODS_PER_CYCLE == 0 {
            servo.publish(command);
        }
        servo.period();
        assert_eq!(servo.axis.state(), AxisState::Faulted);
        assert_eq!(servo.axis.fault(), Some(fault));
        assert!(!servo.latched().gates, "gates on while faulted");
    }
    assert_eq!(servo.feedback().fault, Some(fault));
    assert_eq!(servo.feedback().state, AxisState::Faulted);
}

/// Asserts a trip of `fault` between `lo` and `hi` periods (inclusive) after the fault was
/// injected.
fn assert_trip(servo: &SimServo, tripped: Option<u64>, fault: MotorFault, lo: u64, hi: u64) {
    let n = tripped.unwrap_or_else(|| panic!("no trip, expected {fault:?}"));
    assert_eq!(servo.axis.fault(), Some(fault), "wrong fault");
    assert!(
        (lo..=hi).contains(&n),
        "{fault:?} after {n} periods, expected {lo}..={hi}"
    );
}

/// Sets the motor's thermal switch of the running `servo` and runs `command` until
/// `MotorOverTemperature` trips, asserting it does after the confirmation time; returns the
/// confirmation in loop samples and the PWM periods per loop sample.
fn thermal_switch_trip(servo: &mut SimServo, command: AxisCommand) -> (u64, u64) {
    let p = prot(servo);
    let n = u64::from(confirmation_samples(
        p.motor_over_temperature_confirm_s,
        loop_dt(servo) as f32,
    ));
    let d = divider(servo);
    servo.plant.set_motor_overtemp_input(true);
    let tripped = run_until_fault(servo, command, 2 * n * d);
    assert_trip(
        servo,
        tripped,
        MotorFault::MotorOverTemperature,
        (n - 1) * d + 1,
        n * d,
    );
    (n, d)
}

/// Largest magnitude of the three measured phase currents of the last sample, with the sensors'
/// true offsets removed (the firmware's calibrated offsets agree within a few mA).
fn measured_peak(servo: &SimServo) -> f64 {
    let s = servo.last_sample().expect("a period ran");
    let off = servo.plant.config().sensing.offset_a;
    let c = s.currents;
    [
        f64::from(c.a) - off[0],
        f64::from(c.b) - off[1],
        f64::from(c.c) - off[2],
    ]
    .iter()
    .fold(0.0, |m, x| m.max(x.abs()))
}

fn true_peak(servo: &SimServo) -> f64 {
    servo
        .plant
        .phase_currents()
        .iter()
        .fold(0.0, |m, x| m.max(x.abs()))
}

/// Torque (N·m) for a q current (A).
fn torque_for(servo: &SimServo, amps: f64) -> f32 {
    (amps * f64::from(cfg(servo).motor.torque_constant())) as f32
}

/// I²t trip time from cold at a constant current `i`: (I_p² − I_c²)·t_p / (i² − I_c²).
fn i2t_time(c: &I2tConfig, i: f64) -> f64 {
    let (ip, ic) = (f64::from(c.peak_a), f64::from(c.continuous_a));
    (ip * ip - ic * ic) * f64::from(c.peak_time_s) / (i * i - ic * ic)
}

// ---- over-current ------------------------------------------------------------------------------

/// Runs period by period until the over-current trip, checking the "same period" rule against
/// the measured samples; returns (true current at the tripping sample, periods run).
fn over_current_trip(servo: &mut SimServo, command: AxisCommand, max_periods: u64) -> (f64, u64) {
    let level = f64::from(prot(servo).over_current_a);
    // The firmware's offsets come from 256 noisy samples (σ ≈ 2 mA); the measured value used
    // here differs from the firmware's by less than this.
    let tolerance = 0.02;
    for k in 0..max_periods {
        if k % PERIODS_PER_CYCLE == 0 {
            servo.publish(command);
        }
        let at_sample = true_peak(servo);
        servo.period();
        let measured = measured_peak(servo);
        if servo.axis.state() == AxisState::Faulted {
            assert_eq!(servo.axis.fault(), Some(MotorFault::OverCurrent));
            assert!(
                measured > level - tolerance,
                "tripped on a sample of {measured} A (level {level} A)"
            );
            // Gates off in this very period: the decision the firmware returned for the period
            // that sampled the over-current.
            assert!(!servo.latched().gates);
            return (at_sample, k + 1);
        }
        assert!(
            measured <= level + tolerance,
            "a sample of {measured} A did not trip (level {level} A)"
        );
    }
    panic!(
        "no over-current within {max_periods} periods: {:?}",
        servo.feedback()
    );
}

/// After the trip the currents only decay (diodes against the bus) and reach zero.
fn currents_decay(servo: &mut SimServo, command: AxisCommand, peak_at_trip: f64) {
    let mut peak_after = 0.0f64;
    for _ in 0..2 * PERIODS_PER_CYCLE {
        servo.publish(command);
        servo.period();
        peak_after = peak_after.max(true_peak(servo));
        assert!(!servo.latched().gates);
    }
    assert!(
        peak_after <= peak_at_trip + 0.1,
        "current rose after the trip: {peak_after} A > {peak_at_trip} A"
    );
    assert_eq!(
        true_peak(servo),
        0.0,
        "current still flowing 2 ms after the trip"
    );
    assert_eq!(servo.feedback().fault, Some(MotorFault::OverCurrent));
}

/// A winding near-short (R × 0.005) during the open-loop voltage stage of commissioning (the
/// inductance measurement holds the bias voltage of the resistance measurement): the current
/// ramps with nothing regulating it and the over-current trips on the first sample above the
/// level, gates off in that period.
#[test]
fn over_current_near_short_in_open_loop_trips_in_the_same_period() {
    let mut servo = servo_with(PlantConfig::servo_400w(), |_| {});
    let command = AxisCommand {
        enable: true,
        identify: true,
        ..Default::default()
    };
    // Into the electrical identification, then past its resistance stage (two points of
    // settle + average time, `ElectricalIdentConfig::small_servo`).
    let ident = firmware::motor::commissioning::ElectricalIdentConfig::small_servo(40_000.0);
    let resistance_stage = 2.0 * f64::from(ident.settle_s + ident.average_s);
    let mut k = 0u64;
    while servo.axis.state() != AxisState::IdentifyingElectrical {
        servo.publish(command);
        servo.run_periods(PERIODS_PER_CYCLE);
        k += 1;
        assert!(k < 100, "identification did not start");
    }
    let periods = ((resistance_stage + 0.002) / servo.plant.period_s()) as u64;
    servo.publish(command);
    servo.run_periods(periods);
    assert_eq!(servo.axis.state(), AxisState::IdentifyingElectrical);
    servo.plant.set_phase_resistance_scale(0.005);
    let (at_trip, _) = over_current_trip(&mut servo, command, 8_000);
    let level = f64::from(prot(&servo).over_current_a);
    assert!(
        at_trip < level + 0.5,
        "true current {at_trip} A at the trip"
    );
    currents_decay(&mut servo, command, at_trip);
}

/// A current command above the trip level (a current limit, and the I²t models' peak that caps
/// it, set above the over-current level):
/// the current loop drives the current up at almost full voltage; the trip still acts on the
/// first sample above the level, and the true current never exceeds the level by more than one
/// period's rise.
#[test]
fn over_current_from_a_fast_current_rise_trips_in_the_same_period() {
    let mut servo = servo_with(PlantConfig::servo_400w(), |c| {
        c.current_limit_a = 60.0;
        c.protection.motor_i2t.peak_a = 60.0;
        c.protection.drive_i2t.peak_a = 60.0;
    });
    start(&mut servo, ControlMode::Torque);
    servo.plant.set_driven_speed(Some(0.0));
    let command = AxisCommand {
        torque: torque_for(&servo, 55.0),
        ..hold(&servo, ControlMode::Torque)
    };
    let (at_trip, n) = over_current_trip(&mut servo, command, 400);
    // The rise takes a few current-loop time constants, not longer.
    assert!(n < 200, "took {n} periods");
    // One PWM period of full bus voltage across L: the largest step between two samples.
    let m = &servo.plant.config().motor;
    let rise =
        servo.plant.config().inverter.bus_voltage_v * servo.plant.period_s() / m.ld_h.min(m.lq_h);
    let level = f64::from(prot(&servo).over_current_a);
    assert!(
        at_trip <= level + rise,
        "{at_trip} A at the trip, level {level} A"
    );
    currents_decay(&mut servo, command, at_trip);
}

/// The same near-short while the closed current loop runs: the loop keeps the current at its
/// reference (its PI does not depend on R), so nothing trips and the current stays bounded.
#[test]
fn near_short_under_closed_loop_current_control_stays_regulated() {
    let mut servo = running(ControlMode::Torque);
    servo.plant.set_driven_speed(Some(0.0));
    let amps = 20.0;
    let command = AxisCommand {
        torque: torque_for(&servo, amps),
        ..hold(&servo, ControlMode::Torque)
    };
    servo.publish(command);
    servo.run_periods(20 * PERIODS_PER_CYCLE);
    servo.plant.set_phase_resistance_scale(0.005);
    let mut peak = 0.0f64;
    for _ in 0..100 {
        servo.publish(command);
        for _ in 0..PERIODS_PER_CYCLE {
            servo.period();
            peak = peak.max(servo.plant.currents_dq().1.abs());
        }
    }
    assert_eq!(servo.feedback().fault, None);
    assert!(peak < amps + 1.0, "q current peaked at {peak} A");
}

// ---- I²t ---------------------------------------------------------------------------------------

/// Locked rotor at `amps` in torque mode; returns the trip time (s) from the command.
fn locked_rotor_trip(servo: &mut SimServo, amps: f64, expected: MotorFault, max_s: f64) -> f64 {
    servo.plant.set_driven_speed(Some(0.0));
    let command = AxisCommand {
        torque: torque_for(servo, amps),
        ..hold(servo, ControlMode::Torque)
    };
    let max = (max_s / servo.plant.period_s()) as u64;
    let n = run_until_fault(servo, command, max).unwrap_or_else(|| panic!("no trip"));
    assert_eq!(servo.axis.fault(), Some(expected));
    n as f64 * servo.plant.period_s()
}

/// The 400 W servo with the I²t foldback switched off (`foldback_start` 1.0): the models trip.
fn running_without_foldback(mode: ControlMode) -> SimServo {
    let mut servo = servo_with(PlantConfig::servo_400w(), |c| {
        c.protection.motor_i2t.foldback_start = 1.0;
        c.protection.drive_i2t.foldback_start = 1.0;
    });
    start(&mut servo, mode);
    servo
}

/// Motor I²t: with the board's levels the motor's model is the first to trip at any current
/// between the continuous and peak levels; at 28 A it trips at the analytic time within 2 %
/// (the foldback off: with it the drive derates instead, see
/// `i2t_foldback_derates_to_the_continuous_current_instead_of_tripping`).
#[test]
fn motor_i2t_trips_at_the_analytic_time() {
    let mut servo = running_without_foldback(ControlMode::Torque);
    let p = prot(&servo);
    let amps = 28.0;
    assert!(amps > f64::from(p.motor_i2t.continuous_a) && amps < f64::from(p.motor_i2t.peak_a));
    let t_motor = i2t_time(&p.motor_i2t, amps);
    let t_drive = i2t_time(&p.drive_i2t, amps);
    assert!(t_motor < t_drive, "motor {t_motor} s, drive {t_drive} s");
    let t = locked_rotor_trip(&mut servo, amps, MotorFault::MotorOverload, 1.5 * t_motor);
    println!("motor I²t: {t:.4} s, analytic {t_motor:.4} s");
    assert!((t / t_motor - 1.0).abs() < 0.02, "{t} s vs {t_motor} s");
    // A thermal fault: the axis runs on for the drive's fault reaction, then stays faulted
    // (enabled again, it does not run).
    let command = hold(&servo, ControlMode::Torque);
    end_fault_reaction(&mut servo, command);
    stays_faulted(&mut servo, command, MotorFault::MotorOverload, 400);
}

/// Drive I²t: a configuration in which the drive's model is the first (a motor rated above the
/// test current, a drive with a 0.5 s peak time) trips `DriveOverload` at the analytic time.
#[test]
fn drive_i2t_trips_at_the_analytic_time() {
    let amps = 28.0;
    let mut servo = servo_with(PlantConfig::servo_400w(), |c| {
        c.protection.motor_i2t.continuous_a = 29.0;
        c.protection.drive_i2t.peak_time_s = 0.5;
        c.protection.drive_i2t.foldback_start = 1.0;
    });
    start(&mut servo, ControlMode::Torque);
    let p = prot(&servo);
    let t_drive = i2t_time(&p.drive_i2t, amps);
    assert!(amps < f64::from(p.motor_i2t.continuous_a));
    let t = locked_rotor_trip(&mut servo, amps, MotorFault::DriveOverload, 1.5 * t_drive);
    println!("drive I²t: {t:.4} s, analytic {t_drive:.4} s");
    assert!((t / t_drive - 1.0).abs() < 0.02, "{t} s vs {t_drive} s");
    let command = hold(&servo, ControlMode::Torque);
    end_fault_reaction(&mut servo, command);
    stays_faulted(&mut servo, command, MotorFault::DriveOverload, 400);
}

/// I²t foldback (the board's default: from 80 % of the trip level): a locked rotor asked for
/// 28 A gets it at first, then the current limit folds back so that the motor's I²t settles at
/// `FOLDBACK_FULL_LOAD` of its trip level with the q current at the continuous current, and the
/// axis never trips; meanwhile it reports the torque demand at its limit (CiA402 bit 11).
#[test]
fn i2t_foldback_derates_to_the_continuous_current_instead_of_tripping() {
    let mut servo = running(ControlMode::Torque);
    let p = prot(&servo);
    let amps = 28.0;
    let t_motor = i2t_time(&p.motor_i2t, amps);
    servo.plant.set_driven_speed(Some(0.0));
    let command = AxisCommand {
        torque: torque_for(&servo, amps),
        ..hold(&servo, ControlMode::Torque)
    };
    let cycles = (3.0 * t_motor / (PERIODS_PER_CYCLE as f64 * servo.plant.period_s())) as u64;
    let mut first = 0.0f64;
    let mut limited = false;
    for k in 0..cycles {
        servo.publish(command);
        servo.run_periods(PERIODS_PER_CYCLE);
        let iq = servo.plant.currents_dq().1.abs();
        if k == 10 {
            first = iq;
        }
        limited |= servo.feedback().current_limited;
        assert_eq!(servo.feedback().fault, None, "no trip at {k}");
    }
    assert!((first - amps).abs() < 1.5, "28 A at first: {first:.2} A");
    let iq = servo.plant.currents_dq().1.abs();
    let ic = f64::from(p.motor_i2t.continuous_a);
    assert!((iq - ic).abs() < 0.3, "derated to I_c = {ic} A: {iq:.2} A");
    let load = f64::from(servo.axis.protections().motor_load());
    assert!(
        (load - f64::from(firmware::motor::protection::FOLDBACK_FULL_LOAD)).abs() < 0.02,
        "I²t settles at the foldback's full load: {load:.3}"
    );
    assert!(limited, "the torque demand at its limit (bit 11)");
}

// ---- bus voltage -------------------------------------------------------------------------------

/// Bus over-voltage trips after the confirmation time (not before, not more than one loop sample
/// later); a spike shorter than the confirmation does not.
#[test]
fn bus_over_voltage_trips_after_the_confirmation_time() {
    let mut servo = running(ControlMode::Torque);
    let p = prot(&servo);
    let n = u64::from(confirmation_samples(
        p.bus_confirm_s,
        loop_dt(&servo) as f32,
    ));
    let d = divider(&servo);
    let command = hold(&servo, ControlMode::Torque);
    let high = f64::from(p.bus_over_voltage_v) + 2.0;
    // A spike of one sample less than the confirmation.
    servo.plant.set_bus_voltage(high);
    assert_eq!(run_until_fault(&mut servo, command, (n - 1) * d), None);
    servo.plant.set_bus_voltage(48.0);
    assert_eq!(run_until_fault(&mut servo, command, 20 * d), None);
    // A lasting over-voltage.
    servo.plant.set_bus_voltage(high);
    let tripped = run_until_fault(&mut servo, command, 10 * n * d);
    assert_trip(
        &servo,
        tripped,
        MotorFault::BusOverVoltage,
        (n - 1) * d + 1,
        n * d,
    );
    stays_faulted(&mut servo, command, MotorFault::BusOverVoltage, 400);
}

/// Bus under-voltage: not armed while disabled; enabled, it trips after the confirmation time,
/// and a dip shorter than the confirmation does not trip.
#[test]
fn bus_under_voltage_trips_only_while_enabled() {
    let mut servo = servo_with(PlantConfig::servo_400w(), |_| {});
    let p = prot(&servo);
    let low = f64::from(p.bus_under_voltage_v) - 6.0;
    // Disabled with a low bus for 20 ms: no fault.
    servo.plant.set_bus_voltage(low);
    let disabled = AxisCommand::default();
    assert_eq!(run_until_fault(&mut servo, disabled, 800), None);
    assert_eq!(servo.axis.state(), AxisState::Disabled);
    servo.plant.set_bus_voltage(48.0);
    start(&mut servo, ControlMode::Torque);
    let n = u64::from(confirmation_samples(
        p.bus_confirm_s,
        loop_dt(&servo) as f32,
    ));
    let d = divider(&servo);
    let command = hold(&servo, ControlMode::Torque);
    servo.plant.set_bus_voltage(low);
    assert_eq!(run_until_fault(&mut servo, command, (n - 1) * d), None);
    servo.plant.set_bus_voltage(48.0);
    assert_eq!(run_until_fault(&mut servo, command, 20 * d), None);
    servo.plant.set_bus_voltage(low);
    let tripped = run_until_fault(&mut servo, command, 10 * n * d);
    assert_trip(
        &servo,
        tripped,
        MotorFault::BusUnderVoltage,
        (n - 1) * d + 1,
        n * d,
    );
    stays_faulted(&mut servo, command, MotorFault::BusUnderVoltage, 400);
}

// ---- over-speed --------------------------------------------------------------------------------

/// A dynamometer drives the rotor up through the over-speed level while the axis runs in torque
/// mode with zero torque: `OverSpeed` once the speed is above the level for the confirmation
/// time, not before.
///
/// On a 58 V bus (below the over-voltage level): at 48 V the back-EMF (ψ·ωe = 30.5 V at
/// 5400 rpm) exceeds what the modulator can apply (0.95·48/√3 = 26.3 V) from about 4650 rpm on,
/// and with zero current references and no flux weakening the current loop loses control there
/// (its d-first voltage limiter) and the over-current trips first, at about 4970 rpm.
#[test]
fn over_speed_trips_when_a_load_drives_the_rotor_above_the_level() {
    let mut plant = PlantConfig::servo_400w();
    plant.inverter.bus_voltage_v = 58.0;
    let mut servo = servo_with(plant, |_| {});
    start(&mut servo, ControlMode::Torque);
    let p = prot(&servo);
    let level_rad_s = f64::from(p.over_speed) / CPR * TAU;
    let command = hold(&servo, ControlMode::Torque);
    // A 10 000 rpm/s ramp from standstill (the speed of a driven load changes physically: a
    // speed step would leave the back-EMF feed-forward of the current loop behind).
    let ramp = 10_000.0 / 60.0 * TAU;
    let start_speed = 0.0;
    let ts = servo.plant.period_s();
    let mut k = 0u64;
    let tripped_at = loop {
        let w = start_speed + ramp * k as f64 * ts;
        servo.plant.set_driven_speed(Some(w));
        if k % PERIODS_PER_CYCLE == 0 {
            servo.publish(command);
        }
        servo.period();
        k += 1;
        if servo.axis.state() == AxisState::Faulted {
            break w;
        }
        assert!(w < 1.2 * level_rad_s, "no over-speed trip at {w} rad/s");
    };
    assert_eq!(servo.axis.fault(), Some(MotorFault::OverSpeed));
    // Above the level, by at most what the ramp adds during the confirmation, the velocity
    // estimator's lag (2a/ω) and a margin of one sample.
    let confirm = f64::from(p.over_speed_confirm_s) + 2.0 * loop_dt(&servo);
    let lag = 2.0 * ramp / (TAU * f64::from(cfg(&servo).velocity_bandwidth_hz));
    let slack = ramp * confirm + lag;
    println!(
        "over-speed at {:.1} rpm (level {:.1} rpm)",
        tripped_at * 60.0 / TAU,
        level_rad_s * 60.0 / TAU
    );
    assert!(tripped_at > level_rad_s, "tripped below the level");
    assert!(
        tripped_at < level_rad_s + slack,
        "{tripped_at} rad/s, level {level_rad_s} rad/s"
    );
}

// ---- encoder -----------------------------------------------------------------------------------

/// An incremental encoder losing its signal: `EncoderSignalLoss` at the next loop sample.
#[test]
fn encoder_signal_loss_trips_at_the_next_loop_sample() {
    let mut plant = PlantConfig::servo_400w();
    plant.encoder = EncoderParams::Incremental {
        counts_per_rev: 1 << 20,
        index_at_rad: 0.0,
    };
    let mut servo = servo_with(plant, |_| {});
    start(&mut servo, ControlMode::Torque);
    let d = divider(&servo);
    let command = hold(&servo, ControlMode::Torque);
    servo
        .plant
        .set_encoder_fault(Some(EncoderFaultInjection::SignalLoss));
    let tripped = run_until_fault(&mut servo, command, 10 * d);
    assert_trip(&servo, tripped, MotorFault::EncoderSignalLoss, 1, d);
    stays_faulted(&mut servo, command, MotorFault::EncoderSignalLoss, 200);
}

/// A fault that cuts the gates ends a controlled stop at once: the motor's thermal switch trips
/// (the axis runs on for the drive's fault reaction), then the encoder signal is lost during
/// that reaction: `EncoderSignalLoss` replaces the thermal fault as a new trip (the drive sees
/// it) and the gates go off at the next loop sample, whatever the command.
#[test]
fn a_fault_that_cuts_the_gates_ends_a_controlled_stop() {
    let mut plant = PlantConfig::servo_400w();
    plant.encoder = EncoderParams::Incremental {
        counts_per_rev: 1 << 20,
        index_at_rad: 0.0,
    };
    let mut servo = servo_with(plant, |_| {});
    start(&mut servo, ControlMode::Torque);
    let command = hold(&servo, ControlMode::Torque);
    let (_, d) = thermal_switch_trip(&mut servo, command);
    let trips = servo.feedback().trips;
    // The fault reaction runs (the axis stays enabled); the encoder goes.
    servo
        .plant
        .set_encoder_fault(Some(EncoderFaultInjection::SignalLoss));
    let mut cut_after = None;
    for k in 0..10 * d {
        if k % PERIODS_PER_CYCLE == 0 {
            servo.publish(command);
        }
        servo.period();
        if servo.axis.state() == AxisState::Faulted {
            assert!(!servo.latched().gates, "gates off");
            cut_after = Some(k + 1);
            break;
        }
    }
    let k = cut_after.expect("the encoder loss did not cut the gates");
    assert!(
        k <= d,
        "gates cut {k} periods after the loss, one loop sample is {d}"
    );
    assert_eq!(servo.axis.fault(), Some(MotorFault::EncoderSignalLoss));
    servo.run_periods(d);
    assert_eq!(servo.feedback().trips, trips.wrapping_add(1), "a new trip");
    stays_faulted(&mut servo, command, MotorFault::EncoderSignalLoss, 200);
}

/// Serial frames failing their CRC: `EncoderCrc` at the bad loop sample that brings the error
/// counter (+weight per bad frame) to the trip level. The absolute encoder's signal loss (an
/// all-zero frame, which fails the CRC) trips the same way.
#[test]
fn encoder_crc_errors_trip_after_the_counter_threshold() {
    for fault in [
        EncoderFaultInjection::CrcErrors,
        EncoderFaultInjection::SignalLoss,
    ] {
        let mut servo = running(ControlMode::Torque);
        let p = prot(&servo);
        let frames = u64::from(p.encoder_crc_trip.div_ceil(p.encoder_crc_weight));
        let d = divider(&servo);
        let command = hold(&servo, ControlMode::Torque);
        servo.plant.set_encoder_fault(Some(fault));
        let tripped = run_until_fault(&mut servo, command, 10 * frames * d);
        assert_trip(
            &servo,
            tripped,
            MotorFault::EncoderCrc,
            (frames - 1) * d + 1,
            frames * d,
        );
    }
}

/// A position jump larger than the over-speed level allows in one loop sample: `EncoderJump` at
/// the next loop sample.
#[test]
fn encoder_jump_trips_at_the_next_loop_sample() {
    let mut servo = running(ControlMode::Torque);
    let p = prot(&servo);
    let max_step =
        max_increments_per_sample(p.over_speed, loop_dt(&servo) as f32, p.encoder_jump_margin);
    let d = divider(&servo);
    let command = hold(&servo, ControlMode::Torque);
    servo
        .plant
        .set_encoder_fault(Some(EncoderFaultInjection::Jump {
            counts: 2 * max_step as i64,
        }));
    let tripped = run_until_fault(&mut servo, command, 10 * d);
    assert_trip(&servo, tripped, MotorFault::EncoderJump, 1, d);
    stays_faulted(&mut servo, command, MotorFault::EncoderJump, 200);
}

// ---- temperatures ------------------------------------------------------------------------------

/// Power stage above its level: `DriveOverTemperature` after the confirmation time; exactly at
/// the level (the comparison is strict) it does not trip.
#[test]
fn drive_over_temperature_trips_after_the_confirmation_time() {
    let mut servo = running(ControlMode::Torque);
    let p = prot(&servo);
    let n = u64::from(confirmation_samples(
        p.drive_temperature_confirm_s,
        loop_dt(&servo) as f32,
    ));
    let d = divider(&servo);
    let command = hold(&servo, ControlMode::Torque);
    servo
        .plant
        .set_drive_temperature(f64::from(p.drive_over_temperature_c));
    assert_eq!(run_until_fault(&mut servo, command, 2 * n * d), None);
    servo
        .plant
        .set_drive_temperature(f64::from(p.drive_over_temperature_c) + 5.0);
    let tripped = run_until_fault(&mut servo, command, 2 * n * d);
    assert_trip(
        &servo,
        tripped,
        MotorFault::DriveOverTemperature,
        (n - 1) * d + 1,
        n * d,
    );
}

/// Motor thermal-switch input: `MotorOverTemperature` after its confirmation; a pulse one loop
/// sample shorter (EMI on the wires) does not trip.
#[test]
fn motor_over_temperature_input_trips_after_the_confirmation_time() {
    let mut servo = running(ControlMode::Torque);
    let p = prot(&servo);
    let n = u64::from(confirmation_samples(
        p.motor_over_temperature_confirm_s,
        loop_dt(&servo) as f32,
    ));
    let d = divider(&servo);
    let command = hold(&servo, ControlMode::Torque);
    servo.plant.set_motor_overtemp_input(true);
    assert_eq!(run_until_fault(&mut servo, command, (n - 1) * d), None);
    servo.plant.set_motor_overtemp_input(false);
    assert_eq!(run_until_fault(&mut servo, command, 10 * d), None);
    servo.plant.set_motor_overtemp_input(true);
    let tripped = run_until_fault(&mut servo, command, 2 * n * d);
    assert_trip(
        &servo,
        tripped,
        MotorFault::MotorOverTemperature,
        (n - 1) * d + 1,
        n * d,
    );
}

// ---- following error ---------------------------------------------------------------------------

/// A CSP move into a hard end stop: the following error grows past the window and
/// `FollowingError` is reported once it has stayed above the window for longer than the
/// timeout. The motor is still under control (`MotorFault::allows_controlled_stop`): the axis
/// keeps running for the drive's fault reaction, and goes to `Faulted` with the gates off when
/// the command drops the enable.
#[test]
fn following_error_trips_at_a_hard_end_stop() {
    let stop_rad = 1.0;
    let mut plant = PlantConfig::servo_400w();
    plant.mechanics.end_stops_rad = Some((-10.0, stop_rad));
    let mut servo = servo_with(plant, |_| {});
    start(&mut servo, ControlMode::Position);
    let p = prot(&servo);
    let window = i64::from(p.following_error_window);
    let timeout_samples =
        (f64::from(p.following_error_timeout_ms) * 1e-3 / loop_dt(&servo)).round() as u64;
    let d = divider(&servo);
    // 600 rpm towards the stop and on, set-points per bus cycle.
    let speed = f64::from(rpm_to_counts(600.0));
    let start_pos = servo.feedback().position as f64;
    let mut first_above: Option<u64> = None;
    let mut k = 0u64;
    loop {
        if k % PERIODS_PER_CYCLE == 0 {
            let t = (k / PERIODS_PER_CYCLE + 1) as f64 * 1e-3;
            servo.publish(AxisCommand {
                enable: true,
                mode: ControlMode::Position,
                position: (start_pos + speed * t) as i64,
                velocity: speed as f32,
                ..Default::default()
            });
        }
        servo.period();
        k += 1;
        if servo.feedback().fault.is_some() {
            break;
        }
        if first_above.is_none() && servo.feedback().following_error.abs() > window {
            first_above = Some(k);
        }
        assert!(k < 40_000, "no trip: {:?}", servo.feedback());
    }
    assert_eq!(servo.axis.fault(), Some(MotorFault::FollowingError));
    assert_eq!(
        servo.axis.state(),
        AxisState::Running,
        "still under control"
    );
    assert!(servo.latched().gates, "gates on for the fault reaction");
    let above = first_above.expect("the error exceeded the window before the trip");
    // Feedback is published per loop sample: the first sample above the window is seen in the
    // period after it. The trip comes at the (timeout + 1)-th sample above.
    let periods = k - above;
    println!("following error: {periods} periods above the window before the trip");
    assert!(
        ((timeout_samples - 1) * d..=(timeout_samples + 1) * d).contains(&periods),
        "{periods} periods above the window, timeout {timeout_samples} samples"
    );
    let rad = servo.plant.mech_angle_rad();
    assert!(
        (rad - stop_rad).abs() < 1e-9,
        "rotor at {rad} rad, not at the stop"
    );
    // The drive's reaction ends with the enable dropped: Faulted, gates off, until a reset.
    let off = AxisCommand {
        enable: false,
        ..hold(&servo, ControlMode::Position)
    };
    servo.publish(off);
    servo.run_periods(PERIODS_PER_CYCLE);
    assert_eq!(servo.axis.state(), AxisState::Faulted);
    stays_faulted(&mut servo, off, MotorFault::FollowingError, 200);
}

// ---- latching and reset ------------------------------------------------------------------------

/// A latched fault holds the gates off until a rising `fault_reset` edge with the cause gone;
/// a reset edge while the cause persists is used up without effect; after a good reset the axis
/// re-enables through the offset calibration into `Running`.
#[test]
fn a_fault_latches_until_a_reset_with_the_cause_gone() {
    let mut servo = running(ControlMode::Torque);
    let command = hold(&servo, ControlMode::Torque);
    thermal_switch_trip(&mut servo, command);
    // The drive's fault reaction ends; then, enabled and commanding torque: stays faulted,
    // gates off.
    end_fault_reaction(&mut servo, command);
    let torque = AxisCommand {
        torque: 1.0,
        ..command
    };
    stays_faulted(&mut servo, torque, MotorFault::MotorOverTemperature, 4_000);
    // The cause goes away: still latched without a reset.
    servo.plant.set_motor_overtemp_input(false);
    stays_faulted(&mut servo, command, MotorFault::MotorOverTemperature, 4_000);

    // A reset while the cause is back is used up (CiA402 transition 15 "if no fault exists
    // currently"): the axis stays faulted, gates off.
    servo.plant.set_motor_overtemp_input(true);
    let reset = AxisCommand {
        fault_reset: true,
        ..command
    };
    stays_faulted(&mut servo, reset, MotorFault::MotorOverTemperature, 4_000);
    // Holding fault_reset high is no new edge: the cause gone, it stays latched.
    servo.plant.set_motor_overtemp_input(false);
    stays_faulted(&mut servo, reset, MotorFault::MotorOverTemperature, 4_000);
    // Falling, then rising edge with the cause gone: Disabled → CalibratingOffsets → Running.
    stays_faulted(
        &mut servo,
        command,
        MotorFault::MotorOverTemperature,
        2 * PERIODS_PER_CYCLE,
    );
    let mut seen = vec![AxisState::Faulted];
    for cycle in 0..200 {
        servo.publish(if cycle == 0 { reset } else { command });
        for _ in 0..PERIODS_PER_CYCLE {
            servo.period();
            let s = servo.axis.state();
            if seen.last() != Some(&s) {
                seen.push(s);
            }
            if s != AxisState::Faulted {
                assert_eq!(servo.axis.fault(), None);
            }
        }
        if servo.axis.state() == AxisState::Running {
            break;
        }
    }
    assert_eq!(
        seen,
        [
            AxisState::Faulted,
            AxisState::Disabled,
            AxisState::CalibratingOffsets,
            AxisState::Running
        ]
    );
    // And it works again: torque moves the rotor.
    let before = servo.feedback().position;
    for _ in 0..20 {
        servo.publish(AxisCommand {
            torque: 0.2,
            ..command
        });
        servo.run_periods(PERIODS_PER_CYCLE);
    }
    assert!(servo.feedback().position > before + 1_000);
    assert_eq!(servo.feedback().fault, None);
}

// ---- no false trips ----------------------------------------------------------------------------

/// Jerk-limited (S-curve) point-to-point profile: acceleration ramps at `jerk` to `accel`,
/// holds, ramps down to reach `v_max`; cruise; the mirror image to stop at `distance`. Positions
/// (same unit as the arguments) at the times `t` (s).
struct SCurve {
    /// Time step of the numeric integration, s.
    samples: Vec<(f64, f64, f64)>,
    dt: f64,
}

impl SCurve {
    fn new(distance: f64, v_max: f64, accel: f64, jerk: f64) -> Self {
        let tj = accel / jerk;
        let ta = v_max / accel + tj; // acceleration phase
        let accel_at = |tau: f64| -> f64 {
            if tau < 0.0 || tau > ta {
                0.0
            } else if tau < tj {
                jerk * tau
            } else if tau < ta - tj {
                accel
            } else {
                jerk * (ta - tau)
            }
        };
        let d_accel = v_max * ta / 2.0;
        assert!(2.0 * d_accel < distance, "the profile reaches v_max");
        let tc = (distance - 2.0 * d_accel) / v_max;
        let total = 2.0 * ta + tc;
        let dt = 1e-6;
        let (mut p, mut v, mut t) = (0.0f64, 0.0f64, 0.0f64);
        let mut samples = vec![(0.0, 0.0, 0.0)];
        while t < total + 0.05 {
            let a = |t: f64| accel_at(t) - accel_at(t - ta - tc);
            let a0 = a(t);
            let a1 = a(t + dt);
            let v1 = v + 0.5 * (a0 + a1) * dt;
            p += 0.5 * (v + v1) * dt;
            v = v1;
            t += dt;
            samples.push((p, v, a1));
        }
        Self { samples, dt }
    }

    /// (position, velocity, acceleration) at `t`.
    fn at(&self, t: f64) -> (f64, f64, f64) {
        let i = ((t / self.dt).round() as usize).min(self.samples.len() - 1);
        self.samples[i]
    }

    fn duration(&self) -> f64 {
        self.samples.len() as f64 * self.dt
    }
}

/// The largest acceleration the peak torque allows at `speed_rad_s` after friction, rad/s².
fn accel_capability(servo: &SimServo, speed_rad_s: f64) -> f64 {
    let c = servo.plant.config();
    let j = c.motor.rotor_inertia_kgm2 + c.mechanics.load_inertia_kgm2;
    let torque = f64::from(cfg(servo).speed_loop.torque_limit_nm);
    (torque - c.mechanics.coulomb_nm - c.mechanics.viscous_nm_per_rad_s * speed_rad_s) / j
}

/// A CSP S-curve move of 20 revolutions at up to 4000 rpm with 75 % of the peak-torque
/// acceleration, a 0.8 N·m load step during the cruise, ends at its target with no fault at any
/// time.
#[test]
fn no_false_trip_on_an_aggressive_csp_move_with_a_load_step() {
    let mut servo = running(ControlMode::Position);
    let v_max = 4_000.0 / 60.0 * TAU;
    let accel = 0.75 * accel_capability(&servo, v_max);
    let profile = SCurve::new(20.0 * TAU, v_max, accel, accel / 0.005);
    let counts_per_rad = CPR / TAU;
    let start_pos = servo.feedback().position;
    let cycles = (profile.duration() / 1e-3).ceil() as u64 + 200;
    let load_at = 150;
    let mut max_fe = 0i64;
    for cycle in 0..cycles {
        if cycle == load_at {
            servo.plant.set_load_torque(0.8);
        }
        // The set-point for the end of this bus cycle.
        let (p, v, _) = profile.at((cycle + 1) as f64 * 1e-3);
        servo.publish(AxisCommand {
            enable: true,
            mode: ControlMode::Position,
            position: start_pos + (p * counts_per_rad).round() as i64,
            velocity: (v * counts_per_rad) as f32,
            ..Default::default()
        });
        for _ in 0..PERIODS_PER_CYCLE {
            servo.period();
            assert_eq!(servo.axis.fault(), None, "fault at cycle {cycle}");
        }
        let fb = servo.feedback();
        assert_eq!(fb.fault, None);
        assert_eq!(fb.state, AxisState::Running);
        max_fe = max_fe.max(fb.following_error.abs());
    }
    let target = start_pos + (20.0 * CPR) as i64;
    let fb = servo.feedback();
    println!(
        "CSP: accel {accel:.0} rad/s², max following error {max_fe} increments, end error {}",
        fb.position - target
    );
    assert!(
        (fb.position - target).abs() < 200,
        "ended at {} vs {target}",
        fb.position
    );
    assert!(max_fe < i64::from(prot(&servo).following_error_window) / 4);
}

/// A CSV reversal +3000 rpm → −3000 rpm → 0 with 75 % of the peak-torque acceleration: no fault,
/// and the speed reaches each target.
#[test]
fn no_false_trip_on_a_csv_speed_reversal() {
    let mut servo = running(ControlMode::Velocity);
    let v_target = 3_000.0 / 60.0 * TAU;
    let accel = 0.75 * accel_capability(&servo, v_target);
    let counts_per_rad = CPR / TAU;
    // (target rad/s, hold cycles) in sequence.
    let legs = [(v_target, 100u64), (-v_target, 100), (0.0, 100)];
    let mut v = 0.0f64;
    for (target, hold_cycles) in legs {
        let ramp_cycles = ((target - v).abs() / accel / 1e-3).ceil() as u64;
        let step = (target - v) / ramp_cycles as f64;
        for cycle in 0..ramp_cycles + hold_cycles {
            if cycle < ramp_cycles {
                v += step;
            } else {
                v = target;
            }
            servo.publish(AxisCommand {
                enable: true,
                mode: ControlMode::Velocity,
                velocity: (v * counts_per_rad) as f32,
                ..Default::default()
            });
            for _ in 0..PERIODS_PER_CYCLE {
                servo.period();
                assert_eq!(servo.axis.fault(), None, "fault");
            }
            assert_eq!(servo.feedback().fault, None);
        }
        let speed = servo.plant.mech_speed_rad_s();
        assert!(
            (speed - target).abs() < 0.01 * v_target,
            "speed {speed} rad/s, target {target} rad/s"
        );
    }
}
