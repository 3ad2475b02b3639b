//! Commissioning on the simulated 400 W servo: the axis identifies R, Ld, Lq and the inertia
//! on the plant (with its dead time, device drops, ADC offsets, noise and quantisation, and
//! friction), the results match the plant's true values, the gains computed from them match the
//! bandwidth rules applied to the true values, and an open winding ends in
//! `MotorFault::Identification` with the gates off. The current-sensor offsets can be measured
//! on request with the drive disabled (an adjusting service's "automatic offset adjustment").

// The shared helpers re-export more than this file uses.
#[allow(unused_imports)]
mod motor;

use std::f64::consts::TAU;

use board_sim::plant::{EncoderParams, PlantConfig};
use board_sim::servo::{axis_config, counts_per_rev, SimServo, Tuning};
use firmware::motor::axis::{AxisCommand, AxisState, Identification};
use firmware::motor::commissioning::{tune, Bandwidths, Identified};
use firmware::motor::MotorFault;
use motor::PERIODS_PER_CYCLE;

/// Runs the identification on `plant` until it finishes (or faults); returns the servo and the
/// sequence of states it went through.
fn identify(plant: PlantConfig) -> (SimServo, Vec<AxisState>) {
    let cfg = axis_config(&plant, &Tuning::default());
    let mut servo = SimServo::new(plant, cfg).expect("valid configuration");
    let command = AxisCommand {
        enable: true,
        identify: true,
        ..Default::default()
    };
    let mut states = vec![servo.axis.state()];
    for _ in 0..3_000 {
        servo.publish(command);
        for _ in 0..PERIODS_PER_CYCLE {
            servo.period();
            let s = servo.axis.state();
            if states.last() != Some(&s) {
                states.push(s);
            }
            if matches!(s, AxisState::Identified | AxisState::Faulted) {
                assert!(!servo.latched().gates, "gates on in {s:?}");
            }
        }
        if matches!(
            servo.axis.state(),
            AxisState::Identified | AxisState::Faulted
        ) {
            // Gates stay off while the enable stays on.
            servo.publish(command);
            for _ in 0..4 * PERIODS_PER_CYCLE {
                servo.period();
                assert!(!servo.latched().gates);
            }
            return (servo, states);
        }
    }
    panic!("the identification did not finish: {:?}", servo.feedback());
}

fn relative_error(measured: f32, truth: f64) -> f64 {
    (f64::from(measured) / truth - 1.0).abs()
}

/// True values of the plant: (R, Ld, Lq, inertia in N·m per increment/s²).
fn truth(plant: &PlantConfig) -> (f64, f64, f64, f64) {
    let m = &plant.motor;
    let cpr = f64::from(counts_per_rev(&plant.encoder));
    let j = (m.rotor_inertia_kgm2 + plant.mechanics.load_inertia_kgm2) * TAU / cpr;
    (m.r_ohm, m.ld_h, m.lq_h, j)
}

fn check(id: &Identification, plant: &PlantConfig) {
    let (r, ld, lq, j) = truth(plant);
    println!(
        "R {:.5} Ω ({:+.2} %), Ld {:.4e} H ({:+.2} %), Lq {:.4e} H ({:+.2} %), J {:.4e} ({:+.2} %)",
        id.resistance_ohm,
        (f64::from(id.resistance_ohm) / r - 1.0) * 100.0,
        id.ld_h,
        (f64::from(id.ld_h) / ld - 1.0) * 100.0,
        id.lq_h,
        (f64::from(id.lq_h) / lq - 1.0) * 100.0,
        id.inertia,
        (f64::from(id.inertia) / j - 1.0) * 100.0,
    );
    assert!(
        relative_error(id.resistance_ohm, r) < 0.05,
        "R {}",
        id.resistance_ohm
    );
    assert!(relative_error(id.ld_h, ld) < 0.10, "Ld {}", id.ld_h);
    assert!(relative_error(id.lq_h, lq) < 0.10, "Lq {}", id.lq_h);
    assert!(relative_error(id.inertia, j) < 0.10, "J {}", id.inertia);
}

/// Absolute encoder (commutation offset known): offsets → R, L → inertia → identified; the
/// values are within 5 % (R) and 10 % (L, J) of the plant's, and so are the gains computed from
/// them against the bandwidth rules applied to the true values.
#[test]
fn identifies_r_l_and_inertia_of_the_plant() {
    let plant = PlantConfig::servo_400w();
    let (servo, states) = identify(plant.clone());
    assert_eq!(
        states,
        [
            AxisState::Disabled,
            AxisState::CalibratingOffsets,
            AxisState::IdentifyingElectrical,
            AxisState::IdentifyingInertia,
            AxisState::Identified,
        ]
    );
    let fb = servo.feedback();
    assert_eq!(fb.fault, None);
    let id = servo
        .link()
        .identification()
        .expect("identification results");
    check(&id, &plant);

    let bw = Bandwidths {
        current_hz: 2_000.0,
        speed_hz: 150.0,
    };
    let (r, ld, lq, j) = truth(&plant);
    let gains = tune(
        &Identified {
            resistance_ohm: id.resistance_ohm,
            ld_h: id.ld_h,
            lq_h: id.lq_h,
        },
        id.inertia,
        &bw,
    );
    let wc = TAU * f64::from(bw.current_hz);
    let ws = TAU * f64::from(bw.speed_hz);
    // The rules: kp = L·ωc, ki = R·ωc; speed kp = J·ωs, ki = kp·ωs/4; position kp = ωs/4.
    assert!(relative_error(gains.current_kp_d, ld * wc) < 0.10);
    assert!(relative_error(gains.current_kp_q, lq * wc) < 0.10);
    assert!(relative_error(gains.current_ki, r * wc) < 0.05);
    assert!(relative_error(gains.speed_kp, j * ws) < 0.10);
    assert!(relative_error(gains.speed_ki, j * ws * ws / 4.0) < 0.10);
    assert!(relative_error(gains.position_kp, ws / 4.0) < 1e-6);
}

/// Incremental encoder (commutation offset unknown): the inertia test aligns first; the results
/// are as accurate.
#[test]
fn identifies_with_an_incremental_encoder_after_alignment() {
    let mut plant = PlantConfig::servo_400w();
    plant.encoder = EncoderParams::Incremental {
        counts_per_rev: 1 << 20,
        index_at_rad: 0.0,
    };
    let (servo, states) = identify(plant.clone());
    assert_eq!(states.last(), Some(&AxisState::Identified), "{states:?}");
    let fb = servo.feedback();
    assert_eq!(fb.fault, None);
    check(
        &servo
            .link()
            .identification()
            .expect("identification results"),
        &plant,
    );
}

/// An open winding (resistance × 1000, 120 Ω: the 2 A test current cannot flow within the
/// 12 V limit, both resistance points end at the limit): `MotorFault::Identification`, gates
/// off, no results. (Not × 10⁴: the plant's explicit Heun step of the currents is unstable for
/// R·h/L above 2, i.e. R above about 640 Ω with this motor's inductance.)
#[test]
fn an_open_winding_fails_the_identification() {
    let mut plant = PlantConfig::servo_400w();
    plant.seed ^= 0x0FE1;
    let cfg = axis_config(&plant, &Tuning::default());
    let mut servo = SimServo::new(plant, cfg).expect("valid configuration");
    servo.plant.set_phase_resistance_scale(1e3);
    let command = AxisCommand {
        enable: true,
        identify: true,
        ..Default::default()
    };
    let mut faulted = false;
    for _ in 0..2_000 {
        servo.publish(command);
        servo.run_periods(PERIODS_PER_CYCLE);
        if servo.axis.state() == AxisState::Faulted {
            faulted = true;
            break;
        }
    }
    assert!(faulted, "no fault: {:?}", servo.feedback());
    assert_eq!(servo.axis.fault(), Some(MotorFault::Identification));
    for _ in 0..4 * PERIODS_PER_CYCLE {
        servo.publish(command);
        servo.period();
        assert!(!servo.latched().gates);
    }
    let fb = servo.feedback();
    assert_eq!(fb.fault, Some(MotorFault::Identification));
    assert_eq!(servo.link().identification(), None);
}

#[test]
fn offsets_are_measured_on_request_with_the_gates_off_and_the_axis_stays_disabled() {
    let plant = PlantConfig::servo_400w();
    let true_offsets = plant.sensing.offset_a;
    let cfg = axis_config(&plant, &Tuning::default());
    let mut servo = SimServo::new(plant, cfg).expect("valid configuration");
    // Before: nothing measured (the axis has not been enabled).
    let before = servo.axis.current_offsets();
    assert_eq!((before.a, before.b, before.c), (0.0, 0.0, 0.0));
    assert_eq!(servo.feedback().offset_calibrations, 0);
    let request = AxisCommand {
        calibrate_offsets: true,
        ..Default::default()
    };
    let mut states = vec![servo.axis.state()];
    for _ in 0..200 {
        servo.publish(request);
        for _ in 0..PERIODS_PER_CYCLE {
            servo.period();
            assert!(!servo.latched().gates, "gates on while calibrating");
            let s = servo.axis.state();
            if states.last() != Some(&s) {
                states.push(s);
            }
        }
    }
    assert_eq!(
        states,
        [
            AxisState::Disabled,
            AxisState::CalibratingOffsets,
            AxisState::Disabled
        ],
        "one calibration, back to Disabled without an enable"
    );
    assert_eq!(servo.feedback().offset_calibrations, 1);
    assert!(servo.feedback().main_power, "48 V bus");
    let got = servo.axis.current_offsets();
    // The plant's ADC offsets, within the noise averaged over the calibration samples and
    // one ADC count.
    let tolerance = 0.01;
    for (g, t) in [got.a, got.b, got.c].into_iter().zip(true_offsets) {
        assert!((f64::from(g) - t).abs() < tolerance, "offset {g} vs {t}");
    }
    // Holding the request does not repeat it; a new rising edge does.
    servo.publish(AxisCommand::default());
    servo.run_periods(PERIODS_PER_CYCLE);
    servo.publish(request);
    servo.run_periods(200 * PERIODS_PER_CYCLE);
    assert_eq!(servo.feedback().offset_calibrations, 2);
    assert_eq!(servo.axis.state(), AxisState::Disabled);
}
