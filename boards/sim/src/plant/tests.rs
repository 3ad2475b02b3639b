//! Plant-level tests: each asserts a physical law or a sensor property computed independently
//! of the implementation (closed-form expectations from the parameters).

use super::*;
use std::f64::consts::TAU;

/// Both fidelities: the physical laws below hold for each (module doc, "Fidelity").
const FIDELITIES: [Fidelity; 2] = [Fidelity::PwmResolved, Fidelity::Averaged];

/// The default servo at the given fidelity.
fn servo_at(fidelity: Fidelity) -> PlantConfig {
    PlantConfig {
        fidelity,
        ..PlantConfig::servo_400w()
    }
}

/// [`ideal`] at the given fidelity.
fn ideal_at(fidelity: Fidelity) -> PlantConfig {
    PlantConfig {
        fidelity,
        ..ideal()
    }
}

/// The default servo with every non-ideality that would blur an exact check removed.
fn ideal() -> PlantConfig {
    let mut c = PlantConfig::servo_400w();
    c.inverter.dead_time_s = 0.0;
    c.inverter.device_drop_v = 0.0;
    c.sensing.noise_a_rms = 0.0;
    c.sensing.offset_a = [0.0; 3];
    c.mechanics.coulomb_nm = 0.0;
    c.mechanics.viscous_nm_per_rad_s = 0.0;
    c
}

fn plant(c: PlantConfig) -> Plant {
    Plant::new(c).expect("valid config")
}

/// Duties that synthesise the rotor-frame voltage (vd, vq) at the present electrical angle:
/// `d_k = 1/2 + v_k/Vbus`, so the phase-to-neutral voltage is `v_k` (the 1/2 is zero sequence).
fn duties_for(p: &Plant, vd: f64, vq: f64) -> [f32; 3] {
    let (a, b) = inverse_park(vd, vq, p.electrical_angle_rad());
    inverse_clarke(a, b).map(|v| (0.5 + v / p.bus_voltage_v()) as f32)
}

fn run(p: &mut Plant, duties: [f32; 3], gates: bool, periods: usize) {
    for _ in 0..periods {
        p.run_period(duties, gates);
    }
}

/// Runs for `seconds` (rounded to whole periods).
fn run_s(p: &mut Plant, duties: [f32; 3], gates: bool, seconds: f64) {
    let n = periods_for(p, seconds);
    run(p, duties, gates, n);
}

fn periods_for(p: &Plant, seconds: f64) -> usize {
    (seconds / p.period_s()).round() as usize
}

/// Rotor-frame currents computed from the phase currents and the true angle.
fn measured_dq(p: &Plant) -> (f64, f64) {
    let (a, b) = clarke(p.phase_currents());
    park(a, b, p.electrical_angle_rad())
}

#[test]
fn locked_rotor_steady_state_current_is_v_over_r() {
    for fidelity in FIDELITIES {
        let c = ideal_at(fidelity);
        let r = c.motor.r_ohm;
        let mut p = plant(c);
        p.set_driven_speed(Some(0.0));
        p.set_rotor_position(0.3); // an arbitrary, non-aligned angle
        let (vd, vq) = (1.2, -0.6);
        let duties = duties_for(&p, vd, vq);
        let n = periods_for(&p, 0.15); // ≈ 40 electrical time constants
        run(&mut p, duties, true, n);
        let (id, iq) = measured_dq(&p);
        // Only the PWM ripple (sampled at its centre) and the f32 duties separate the sample from
        // the average; both are far below 1e-4 relative.
        assert!((id - vd / r).abs() < 1e-4 * (vd / r), "id {id}");
        assert!((iq - vq / r).abs() < 1e-4 * (vd / r), "iq {iq}");
    }
}

/// Time at which `values` (one per period from t = 0) first reach `level`, interpolated.
fn crossing_time(values: &[f64], level: f64, ts: f64) -> f64 {
    for k in 1..values.len() {
        if values[k] >= level {
            let frac = (level - values[k - 1]) / (values[k] - values[k - 1]);
            return (k as f64 - 1.0 + frac) * ts;
        }
    }
    f64::NAN
}

#[test]
fn current_step_response_has_time_constant_l_over_r() {
    for fidelity in FIDELITIES {
        for axis in ["d", "q"] {
            let c = ideal_at(fidelity);
            let (r, l) = if axis == "d" {
                (c.motor.r_ohm, c.motor.ld_h)
            } else {
                (c.motor.r_ohm, c.motor.lq_h)
            };
            let mut p = plant(c);
            p.set_driven_speed(Some(0.0));
            let v = 1.0;
            let duties = if axis == "d" {
                duties_for(&p, v, 0.0)
            } else {
                duties_for(&p, 0.0, v)
            };
            let mut values = vec![0.0];
            let n = periods_for(&p, 5.0 * l / r);
            for _ in 0..n {
                p.run_period(duties, true);
                let (id, iq) = measured_dq(&p);
                values.push(if axis == "d" { id } else { iq });
            }
            let tau = crossing_time(&values, (1.0 - (-1.0f64).exp()) * v / r, p.period_s());
            assert!(
                (tau - l / r).abs() < 0.02 * l / r,
                "{axis}: tau {tau} vs {}",
                l / r
            );
        }
    }
}

#[test]
fn short_circuit_current_at_speed_matches_back_emf_and_cross_coupling() {
    for fidelity in FIDELITIES {
        // All low sides on (duty 0) = three-phase short: vd = vq = 0 in the voltage equations,
        // so the steady state is set by the back-EMF ωe·ψ and the ωe·L cross-coupling only.
        let c = ideal_at(fidelity);
        let m = c.motor;
        let mut p = plant(c);
        let omega_m = 100.0;
        p.set_driven_speed(Some(omega_m));
        run_s(&mut p, [0.0; 3], true, 0.08);
        let we = f64::from(m.pole_pairs) * omega_m;
        let den = m.r_ohm * m.r_ohm + we * we * m.ld_h * m.lq_h;
        let iq_expected = -we * m.flux_wb * m.r_ohm / den;
        let id_expected = -we * we * m.lq_h * m.flux_wb / den;
        let (id, iq) = measured_dq(&p);
        assert!(
            (id - id_expected).abs() < 1e-3 * id_expected.abs(),
            "id {id} vs {id_expected}"
        );
        assert!(
            (iq - iq_expected).abs() < 1e-3 * iq_expected.abs(),
            "iq {iq} vs {iq_expected}"
        );
        // Power balance, with saliency (id ≠ 0): the shaft power is all dissipated in the copper.
        let p_mech = p.electromagnetic_torque_nm() * omega_m;
        let p_cu = 1.5 * m.r_ohm * (id * id + iq * iq);
        assert!((p_mech + p_cu).abs() < 1e-3 * p_cu, "{p_mech} vs {p_cu}");
    }
}

#[test]
fn gates_off_no_current_below_the_rectifier_threshold_braking_above() {
    for fidelity in FIDELITIES {
        let c = servo_at(fidelity);
        let m = c.motor;
        let threshold_we =
            (c.inverter.bus_voltage_v + 2.0 * c.inverter.device_drop_v) / (3f64.sqrt() * m.flux_wb);
        let threshold_wm = threshold_we / f64::from(m.pole_pairs);

        let mut below = plant(c.clone());
        below.set_driven_speed(Some(0.97 * threshold_wm));
        for _ in 0..periods_for(&below, 0.02) {
            below.run_period([0.0; 3], false);
            assert_eq!(below.phase_currents(), [0.0; 3]);
            assert_eq!(below.electromagnetic_torque_nm(), 0.0);
        }

        let mut above = plant(c);
        above.set_driven_speed(Some(1.1 * threshold_wm));
        let mut torque_sum = 0.0;
        let mut one_floating = 0;
        let n = periods_for(&above, 0.02);
        for _ in 0..n {
            above.run_period([0.0; 3], false);
            torque_sum += above.electromagnetic_torque_nm();
            let i = above.phase_currents();
            assert!((i[0] + i[1] + i[2]).abs() < 1e-9);
            if i.iter().filter(|&&x| x == 0.0).count() == 1 {
                one_floating += 1;
            }
        }
        assert!(torque_sum / (n as f64) < -0.01, "rectifier must brake");
        assert!(
            one_floating > 0,
            "diode bridge commutates through one-phase-open intervals"
        );
    }
}

#[test]
fn gates_off_currents_decay_to_exactly_zero_without_oscillation() {
    for fidelity in FIDELITIES {
        for speed in [0.0, 150.0] {
            let mut p = plant(servo_at(fidelity));
            p.set_driven_speed(Some(speed));
            // Build up about 10 A (the default motor at standstill: 1.2 V / 0.12 Ω).
            for _ in 0..periods_for(&p, 0.03) {
                let d = duties_for(&p, 1.2, 0.8);
                p.run_period(d, true);
            }
            let mut prev = p.phase_currents();
            assert!(prev.iter().any(|i| i.abs() > 5.0));
            let mut zero_from = None;
            for k in 0..400 {
                p.run_period([0.5; 3], false);
                let i = p.phase_currents();
                for ph in 0..3 {
                    // Never changes sign, never grows: diodes only let it decay.
                    assert!(i[ph] * prev[ph] >= 0.0, "phase {ph} reversed at {k}");
                    assert!(
                        i[ph].abs() <= prev[ph].abs() + 1e-9,
                        "phase {ph} grew at {k}"
                    );
                }
                if i == [0.0; 3] && zero_from.is_none() {
                    zero_from = Some(k);
                }
                if zero_from.is_some() {
                    assert_eq!(i, [0.0; 3], "stays exactly zero");
                }
                prev = i;
            }
            // L·i/V ≈ 0.46 mH·10 A / 48 V ≈ 0.1 ms ≈ 4 periods; allow some margin.
            assert!(zero_from.is_some_and(|k| k < 20), "{zero_from:?}");
        }
    }
}

/// Releases a locked rotor carrying (id, iq) and compares J·Δω with ∫Te dt from the measured
/// phase currents.
fn measured_vs_formula_torque(fidelity: Fidelity, id_ref: f64, iq_ref: f64) -> (f64, f64, f64) {
    let c = ideal_at(fidelity);
    let m = c.motor;
    let j = c.motor.rotor_inertia_kgm2 + c.mechanics.load_inertia_kgm2;
    let mut p = plant(c);
    p.set_driven_speed(Some(0.0));
    let duties = duties_for(&p, m.r_ohm * id_ref, m.r_ohm * iq_ref);
    run_s(&mut p, duties, true, 0.1);
    p.set_driven_speed(None);
    let kp = 1.5 * f64::from(m.pole_pairs);
    let full = |(id, iq): (f64, f64)| kp * (m.flux_wb * iq + (m.ld_h - m.lq_h) * id * iq);
    let magnet = |(_, iq): (f64, f64)| kp * m.flux_wb * iq;
    let (mut int_full, mut int_magnet) = (0.0, 0.0);
    let mut prev = measured_dq(&p);
    for _ in 0..8 {
        p.run_period(duties, true);
        let now = measured_dq(&p);
        int_full += 0.5 * (full(prev) + full(now)) * p.period_s();
        int_magnet += 0.5 * (magnet(prev) + magnet(now)) * p.period_s();
        prev = now;
    }
    (j * p.mech_speed_rad_s(), int_full, int_magnet)
}

#[test]
fn torque_is_kt_times_iq_and_shows_the_reluctance_term() {
    for fidelity in FIDELITIES {
        let (impulse, full, magnet) = measured_vs_formula_torque(fidelity, 0.0, 8.0);
        assert!(
            (impulse - magnet).abs() < 5e-3 * magnet,
            "{impulse} vs {magnet}"
        );
        assert!(
            (full - magnet).abs() < 1e-3 * magnet,
            "id ≈ 0: no reluctance torque"
        );

        // Ld < Lq and id < 0: the reluctance term adds ≈ 3.6 % here.
        let (impulse, full, magnet) = measured_vs_formula_torque(fidelity, -8.0, 6.0);
        assert!((impulse - full).abs() < 5e-3 * full, "{impulse} vs {full}");
        assert!(
            impulse - magnet > 0.02 * magnet,
            "reluctance torque missing"
        );
    }
}

#[test]
fn load_torque_accelerates_at_t_over_j() {
    for fidelity in FIDELITIES {
        let c = ideal_at(fidelity);
        let j = c.motor.rotor_inertia_kgm2 + c.mechanics.load_inertia_kgm2;
        let mut p = plant(c);
        p.set_load_torque(-0.1);
        run_s(&mut p, [0.0; 3], false, 0.1);
        let expected = 0.1 / j * p.time_s();
        assert!((p.mech_speed_rad_s() - expected).abs() < 1e-9 * expected);
    }
}

#[test]
fn coulomb_stiction_holds_below_breakaway_and_moves_above() {
    for fidelity in FIDELITIES {
        let mut c = ideal_at(fidelity);
        c.mechanics.coulomb_nm = 0.02;
        let j = c.motor.rotor_inertia_kgm2 + c.mechanics.load_inertia_kgm2;
        let mut p = plant(c.clone());
        p.set_load_torque(-0.019);
        run(&mut p, [0.0; 3], false, 2000);
        assert_eq!(p.mech_angle_rad(), 0.0);
        assert_eq!(p.mech_speed_rad_s(), 0.0);

        let mut p = plant(c);
        p.set_load_torque(-0.03);
        run(&mut p, [0.0; 3], false, 2000);
        let expected = 0.01 / j * p.time_s();
        assert!((p.mech_speed_rad_s() - expected).abs() < 1e-9 * expected);
    }
}

#[test]
fn viscous_friction_decays_with_time_constant_j_over_b() {
    for fidelity in FIDELITIES {
        let mut c = ideal_at(fidelity);
        c.mechanics.viscous_nm_per_rad_s = 5e-4;
        let tau = (c.motor.rotor_inertia_kgm2 + c.mechanics.load_inertia_kgm2)
            / c.mechanics.viscous_nm_per_rad_s;
        let mut p = plant(c);
        p.set_driven_speed(Some(100.0));
        p.set_driven_speed(None);
        run_s(&mut p, [0.0; 3], false, tau);
        let expected = 100.0 * (-1.0f64).exp();
        assert!((p.mech_speed_rad_s() - expected).abs() < 1e-6 * expected);
    }
}

#[test]
fn end_stop_stops_the_rotor_and_the_motor_cannot_push_through() {
    for fidelity in FIDELITIES {
        let mut c = ideal_at(fidelity);
        c.mechanics.end_stops_rad = Some((-0.5, 0.5));
        let mut p = plant(c);
        p.set_load_torque(-0.05);
        run_s(&mut p, [0.0; 3], false, 0.1);
        assert_eq!(p.mech_angle_rad(), 0.5);
        assert_eq!(p.mech_speed_rad_s(), 0.0);
        // Motor torque pushing into the stop (about 0.5 N·m): it stays there.
        p.set_load_torque(0.0);
        for _ in 0..periods_for(&p, 0.02) {
            let d = duties_for(&p, 0.0, 0.8);
            p.run_period(d, true);
            assert_eq!(p.mech_angle_rad(), 0.5);
        }
        assert!(p.electromagnetic_torque_nm() > 0.3);
    }
}

#[test]
fn dead_time_shifts_the_mean_phase_voltage_by_bus_td_over_ts() {
    for fidelity in FIDELITIES {
        // At θe = 0 with id > 0: ia > 0, ib = ic < 0. Each leg loses sign(i)·Vbus·td/Ts, so
        // v_an loses (4/3)·Vbus·td/Ts and so does vd: id = (vd − (4/3)·Vbus·td/Ts)/R.
        let mut c = ideal_at(fidelity);
        c.inverter.dead_time_s = 200e-9;
        let (r, bus, ts) = (
            c.motor.r_ohm,
            c.inverter.bus_voltage_v,
            1.0 / c.inverter.pwm_hz,
        );
        let err = bus * c.inverter.dead_time_s / ts;
        let mut p = plant(c);
        p.set_driven_speed(Some(0.0));
        let vd = 1.2;
        let d = duties_for(&p, vd, 0.0);
        run_s(&mut p, d, true, 0.1);
        let expected = (vd - 4.0 / 3.0 * err) / r;
        let (id, iq) = measured_dq(&p);
        assert!(
            (id - expected).abs() < 1e-3 * expected,
            "id {id} vs {expected}"
        );
        assert!(iq.abs() < 1e-3);
        // Same law for the device drop: every leg loses sign(i)·Vdrop.
        let mut c = ideal_at(fidelity);
        c.inverter.device_drop_v = 0.3;
        let mut p = plant(c);
        p.set_driven_speed(Some(0.0));
        let d = duties_for(&p, vd, 0.0);
        run_s(&mut p, d, true, 0.1);
        let expected = (vd - 4.0 / 3.0 * 0.3) / r;
        assert!((p.currents_dq().0 - expected).abs() < 1e-3 * expected);
    }
}

#[test]
fn sensing_offset_noise_and_bus_statistics() {
    let c = PlantConfig::servo_400w();
    let s = c.sensing;
    let mut p = plant(c);
    let n = 20_000;
    let mut sum = [0.0; 3];
    let mut sum2 = [0.0; 3];
    for _ in 0..n {
        let smp = p.sample();
        assert_eq!(
            smp.bus_voltage_counts,
            (48.0 / s.bus_volts_per_count).round() as u16
        );
        for k in 0..3 {
            let x = f64::from(smp.phase_current_counts[k]) - f64::from(s.zero_count);
            sum[k] += x;
            sum2[k] += x * x;
        }
    }
    for k in 0..3 {
        let mean = sum[k] / n as f64;
        let var = sum2[k] / n as f64 - mean * mean;
        let expected_mean = s.offset_a[k] / s.amps_per_count;
        // Gaussian noise plus the uniform quantisation error of one count (variance 1/12).
        let sigma = s.noise_a_rms / s.amps_per_count;
        let expected_rms = (sigma * sigma + 1.0 / 12.0).sqrt();
        // Standard error of the mean: σ/√n ≈ 0.009 counts.
        assert!(
            (mean - expected_mean).abs() < 0.05,
            "phase {k}: mean {mean}"
        );
        assert!(
            (var.sqrt() - expected_rms).abs() < 0.03 * expected_rms,
            "phase {k}: rms {}",
            var.sqrt()
        );
    }
}

#[test]
fn sensing_reads_the_true_current_and_saturates() {
    let mut c = ideal();
    c.sensing.offset_a = [0.0; 3];
    let apc = c.sensing.amps_per_count;
    let mut p = plant(c);
    p.set_driven_speed(Some(0.0));
    let d = duties_for(&p, 1.2, 0.0);
    run_s(&mut p, d, true, 0.1);
    let i = p.phase_currents();
    let s = p.sample();
    for (counts, current) in s.phase_current_counts.iter().zip(i) {
        assert_eq!(f64::from(*counts), 2048.0 + (current / apc).round());
    }
    // A near-short (R/100) with the same command: the current rises at ≈ V/Ld = 3 kA/s
    // (time constant 0.33 s) and runs far out of the ADC range (±51 A).
    p.set_phase_resistance_scale(0.01);
    let d = duties_for(&p, 1.2, 0.0);
    run_s(&mut p, d, true, 0.03);
    assert!(p.phase_currents()[0] > 60.0);
    assert_eq!(p.sample().phase_current_counts[0], 4095);
}

fn incremental(cpr: u32, index: f64) -> PlantConfig {
    let mut c = ideal();
    c.encoder = EncoderParams::Incremental {
        counts_per_rev: cpr,
        index_at_rad: index,
    };
    c
}

fn inc(s: Sample) -> (u32, Option<u32>, bool) {
    match s.encoder {
        EncoderSample::Incremental {
            count,
            index_count,
            signal_ok,
        } => (count, index_count, signal_ok),
        EncoderSample::Serial { .. } => panic!("expected an incremental sample"),
    }
}

#[test]
fn incremental_counts_per_rev_and_one_index_per_revolution() {
    let cpr = 10_000;
    let mut p = plant(incremental(cpr, 1.0));
    let speed = TAU * 10.0; // 10 rev/s
    p.set_driven_speed(Some(speed));
    let (c0, _, ok) = inc(p.sample());
    assert!(ok);
    let mut latches = Vec::new();
    let revs = 3.1;
    for _ in 0..periods_for(&p, revs / 10.0) {
        p.run_period([0.0; 3], false);
        if let (_, Some(idx), _) = inc(p.sample()) {
            latches.push(idx);
        }
    }
    let (c1, _, _) = inc(p.sample());
    let expected = (p.mech_angle_rad() * f64::from(cpr) / TAU).floor() as u32;
    assert_eq!(c1.wrapping_sub(c0), expected);
    assert!((f64::from(c1.wrapping_sub(c0)) - revs * f64::from(cpr)).abs() <= 1.0);
    // Index at 1 rad: floor(1·CPR/2π) = 1591, then once per revolution.
    assert_eq!(latches, vec![1591, 11_591, 21_591]);

    // Backwards: the same index positions latch again in reverse order, down through zero.
    p.set_driven_speed(Some(-speed));
    latches.clear();
    for _ in 0..periods_for(&p, 2.0 * revs / 10.0) {
        p.run_period([0.0; 3], false);
        if let (_, Some(idx), _) = inc(p.sample()) {
            latches.push(idx);
        }
    }
    let expected: Vec<u32> = [2i64, 1, 0, -1, -2, -3]
        .iter()
        .map(|k| (1591 + k * i64::from(cpr)) as u32)
        .collect();
    assert_eq!(latches, expected);
    // The counter wraps below zero.
    assert!(p.mech_angle_rad() < 0.0);
    let expected = (p.mech_angle_rad() * f64::from(cpr) / TAU).floor() as i64;
    assert!(expected < 0);
    assert_eq!(inc(p.sample()).0, expected as u32);
}

#[test]
fn incremental_signal_loss_stops_the_counter_and_jump_shifts_it() {
    let cpr = 4096;
    let mut p = plant(incremental(cpr, 0.5));
    p.set_driven_speed(Some(10.0));
    run(&mut p, [0.0; 3], false, 100);
    let (before, _, _) = inc(p.sample());
    p.set_encoder_fault(Some(EncoderFaultInjection::SignalLoss));
    let theta_lost = p.mech_angle_rad();
    run(&mut p, [0.0; 3], false, 4000); // crosses the index at 0.5 rad: not latched
    let (c, idx, ok) = inc(p.sample());
    assert_eq!((c, idx, ok), (before, None, false));
    p.set_encoder_fault(None);
    let resumed_at = p.mech_angle_rad();
    run(&mut p, [0.0; 3], false, 100);
    let (after, _, ok) = inc(p.sample());
    assert!(ok);
    let moved = ((p.mech_angle_rad() - resumed_at) * f64::from(cpr) / TAU) as i64;
    assert!((i64::from(after.wrapping_sub(before)) - moved).abs() <= 1);
    assert!(theta_lost < 0.5 && resumed_at > 0.5);

    p.set_driven_speed(Some(0.0));
    let (c0, _, _) = inc(p.sample());
    p.set_encoder_fault(Some(EncoderFaultInjection::Jump { counts: -1000 }));
    run(&mut p, [0.0; 3], false, 10);
    let (c1, _, ok) = inc(p.sample());
    assert!(ok);
    assert_eq!(c1, c0.wrapping_sub(1000));
}

fn serial(s: Sample) -> [u8; 8] {
    match s.encoder {
        EncoderSample::Serial { frame, len } => {
            assert_eq!(usize::from(len), SERIAL_FRAME_LEN);
            frame
        }
        EncoderSample::Incremental { .. } => panic!("expected a serial sample"),
    }
}

/// Decoded multi-turn angle in rad (multi-turn taken as signed 16-bit).
fn serial_angle(frame: &[u8; 8], st_bits: u8) -> f64 {
    let pos = decode_serial_frame(&frame[..SERIAL_FRAME_LEN], st_bits, 16).expect("valid frame");
    let turns = f64::from(pos.multi_turn as i16);
    (turns + f64::from(pos.single_turn) / f64::from(1u32 << st_bits)) * TAU
}

#[test]
fn absolute_encoder_lags_by_speed_times_delay() {
    for delay in [1e-6, 30e-6, 200e-6] {
        let mut c = ideal();
        c.encoder = EncoderParams::Absolute {
            single_turn_bits: 20,
            multi_turn_bits: 16,
            sample_delay_s: delay,
        };
        let mut p = plant(c);
        let omega = 100.0;
        p.set_driven_speed(Some(omega));
        let lsb = TAU / f64::from(1u32 << 20);
        for _ in 0..50 {
            p.run_period([0.0; 3], false);
            let read = serial_angle(&serial(p.sample()), 20);
            let expected = p.mech_angle_rad() - omega * delay;
            // Floor quantisation: reading in (expected − 1 LSB, expected].
            assert!(
                read <= expected + 1e-9 && read > expected - lsb - 1e-9,
                "delay {delay}: {read} vs {expected}"
            );
        }
    }
}

#[test]
fn absolute_multi_turn_wraps_and_single_turn_encoder_reports_zero_turns() {
    let mut p = plant(ideal());
    p.set_rotor_position(TAU * 65_536.0 - 0.05);
    p.set_driven_speed(Some(50.0));
    let mut turns = Vec::new();
    for _ in 0..200 {
        p.run_period([0.0; 3], false);
        let f = serial(p.sample());
        let pos = decode_serial_frame(&f[..SERIAL_FRAME_LEN], 20, 16).expect("valid");
        if turns.last() != Some(&pos.multi_turn) {
            turns.push(pos.multi_turn);
        }
    }
    assert_eq!(turns, vec![65_535, 0]);

    let mut c = ideal();
    c.encoder = EncoderParams::Absolute {
        single_turn_bits: 17,
        multi_turn_bits: 0,
        sample_delay_s: 0.0,
    };
    let mut p = plant(c);
    // Half a turn plus a quarter LSB (so the floor is not decided by rounding).
    p.set_rotor_position((5.5 + 0.25 / f64::from(1u32 << 17)) * TAU);
    let f = serial(p.sample());
    let pos = decode_serial_frame(&f[..SERIAL_FRAME_LEN], 17, 0).expect("valid");
    assert_eq!(pos.multi_turn, 0);
    assert_eq!(pos.single_turn, 1 << 16); // half a turn
}

#[test]
fn absolute_encoder_faults() {
    let mut p = plant(ideal());
    p.set_rotor_position(1.0);
    let decode =
        |p: &mut Plant| decode_serial_frame(&serial(p.sample())[..SERIAL_FRAME_LEN], 20, 16);
    let good = decode(&mut p).expect("valid");
    p.set_encoder_fault(Some(EncoderFaultInjection::CrcErrors));
    assert_eq!(decode(&mut p), Err(SerialFrameError::Crc));
    assert_eq!(decode(&mut p), Err(SerialFrameError::Crc));
    p.set_encoder_fault(Some(EncoderFaultInjection::SignalLoss));
    assert_eq!(serial(p.sample()), [0; 8]);
    assert_eq!(decode(&mut p), Err(SerialFrameError::Crc));
    p.set_encoder_fault(Some(EncoderFaultInjection::StatusError));
    assert_eq!(decode(&mut p), Err(SerialFrameError::Status));
    p.set_encoder_fault(None);
    assert_eq!(decode(&mut p), Ok(good));
    p.set_encoder_fault(Some(EncoderFaultInjection::Jump { counts: 5000 }));
    let jumped = decode(&mut p).expect("a jump is not a frame error");
    assert_eq!(jumped.single_turn, good.single_turn + 5000);
}

#[test]
fn switches_follow_the_true_angle() {
    let mut c = ideal();
    c.switches = SwitchParams {
        limit_neg_rad: Some(-1.0),
        limit_pos_rad: Some(1.0),
        home_rad: Some(0.2),
        home_end_rad: None,
        probes: [None; 2],
    };
    let mut p = plant(c);
    let s = p.sample();
    assert!(!s.limit_neg && !s.limit_pos && !s.home);
    p.set_rotor_position(0.5);
    let s = p.sample();
    assert!(!s.limit_neg && !s.limit_pos && s.home);
    p.set_rotor_position(1.5);
    assert!(p.sample().limit_pos);
    p.set_rotor_position(-1.5);
    let s = p.sample();
    assert!(s.limit_neg && !s.home);
    p.set_drive_temperature(71.5);
    p.set_motor_overtemp_input(true);
    let s = p.sample();
    assert_eq!(s.drive_temperature_c, 71.5);
    assert!(s.motor_overtemp_input);
}

/// A fixed excitation sequence; returns the samples and the final truth bits.
fn record(seed: u64) -> (Vec<Sample>, [u64; 4]) {
    let mut c = PlantConfig::servo_400w();
    c.seed = seed;
    let mut p = plant(c);
    let mut out = Vec::new();
    for k in 0..400 {
        out.push(p.sample());
        let d = duties_for(&p, 2.0, 3.0);
        p.run_period(d, k < 300);
        if k == 100 {
            p.set_load_torque(0.05);
        }
    }
    let (id, iq) = p.currents_dq();
    (
        out,
        [
            id.to_bits(),
            iq.to_bits(),
            p.mech_angle_rad().to_bits(),
            p.mech_speed_rad_s().to_bits(),
        ],
    )
}

#[test]
fn same_seed_is_bit_identical_and_other_seed_changes_the_noise() {
    let (a, ta) = record(1);
    let (b, tb) = record(1);
    assert_eq!(a, b);
    assert_eq!(ta, tb);
    let (c, tc) = record(2);
    assert_eq!(ta, tc, "the noise does not feed back into the physics");
    let differing = a
        .iter()
        .zip(&c)
        .filter(|(x, y)| x.phase_current_counts != y.phase_current_counts)
        .count();
    assert!(differing > 100, "{differing}");
}

#[test]
fn configuration_is_validated() {
    let ok = PlantConfig::servo_400w();
    assert!(Plant::new(ok.clone()).is_ok());
    let with = |f: &dyn Fn(&mut PlantConfig)| {
        let mut c = ok.clone();
        f(&mut c);
        Plant::new(c).err()
    };
    assert_eq!(
        with(&|c| c.substeps_per_period = 9),
        Some(PlantError::TooFewSubsteps(9))
    );
    assert_eq!(with(&|c| c.substeps_per_period = 10), None);
    assert_eq!(
        with(&|c| c.substeps_per_period = MAX_SUBSTEPS + 1),
        Some(PlantError::TooManySubsteps(MAX_SUBSTEPS + 1))
    );
    let invalid: [&dyn Fn(&mut PlantConfig); 12] = [
        &|c| c.motor.r_ohm = 0.0,
        &|c| c.motor.ld_h = f64::NAN,
        &|c| c.motor.pole_pairs = 0,
        &|c| c.inverter.pwm_hz = -1.0,
        &|c| c.inverter.dead_time_s = 12.5e-6,
        &|c| c.sensing.adc_bits = 17,
        &|c| c.sensing.zero_count = 4096,
        &|c| c.sensing.amps_per_count = 0.0,
        &|c| {
            c.encoder = EncoderParams::Absolute {
                single_turn_bits: 16,
                multi_turn_bits: 16,
                sample_delay_s: 0.0,
            }
        },
        &|c| {
            c.encoder = EncoderParams::Absolute {
                single_turn_bits: 20,
                multi_turn_bits: 12,
                sample_delay_s: 0.0,
            }
        },
        &|c| {
            c.encoder = EncoderParams::Incremental {
                counts_per_rev: 0,
                index_at_rad: 0.0,
            }
        },
        &|c| c.mechanics.end_stops_rad = Some((1.0, -1.0)),
    ];
    for (k, f) in invalid.iter().enumerate() {
        assert!(
            matches!(with(*f), Some(PlantError::InvalidParameter(_))),
            "case {k}"
        );
    }
}
