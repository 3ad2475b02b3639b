//! The CiA402 profile modes (IEC 61800-7-201 §12 profile position, §14 profile velocity, §16
//! profile torque) on the simulated servo, commanded by ethercrab over the standard profile's
//! default PDOs (6040h, 607Ah, 6060h / 6041h, 6064h, 6061h) in free run; 60FFh, 6071h and the
//! profile objects by SDO. Checked on the plant's true motion against the objects:
//!
//! - a single set-point: the set-point acknowledge handshake (bit 4 → bit 12), the move at the
//!   profile velocity 6081h with the ramps 6083h/6084h, arrival on the target, target reached
//!   (bit 10) after the position window time;
//! - a set of set-points: the second waits in the buffer (bit 12 stays set) and starts after
//!   the motor stopped on the first; with change on set-point (bit 9) the motor passes the
//!   first target without stopping;
//! - change set immediately with relative targets: the new increment adds to the unfinished
//!   one;
//! - halt stops the move on 6084h and the move resumes when halt is released;
//! - profile velocity: the ramp to 60FFh on 6083h, target reached (606Dh), speed zero (bit 12,
//!   606Fh), 607Fh limiting 60FFh;
//! - profile torque: the torque ramp at the slope 6087h, target reached at the end of it;
//! - the offsets of the cyclic modes: 60B0h shifts the CSP target, 60B1h drives CSV, 60B2h
//!   is the CST torque demand.

use ethercrab::MainDevice;
use tests_host::csp::{self, Sample};
use tests_host::{block_on, master};

/// Increments per revolution of the simulated servo's encoder.
const CPR: i32 = 1 << 20;
const CYCLE_S: f64 = 1e-3;
/// CiA402 controlwords (Table 5) and the profile-position bits.
const SHUTDOWN: u16 = 0x06;
const SWITCH_ON: u16 = 0x07;
const ENABLE_OPERATION: u16 = 0x0F;
const NEW_SET_POINT: u16 = 1 << 4;
const CHANGE_SET_IMMEDIATELY: u16 = 1 << 5;
const RELATIVE: u16 = 1 << 6;
const HALT: u16 = 1 << 8;
const CHANGE_ON_SET_POINT: u16 = 1 << 9;
/// Statusword: state pattern, target reached, bit 12 (set-point acknowledge / speed zero).
const STATE_MASK: u16 = 0x6F;
const OPERATION_ENABLED: u16 = 0x27;
const TARGET_REACHED: u16 = 1 << 10;
const BIT12: u16 = 1 << 12;
/// Modes of operation.
const PP: i8 = 1;
const PV: i8 = 3;
const PT: i8 = 4;
/// The standard profile's defaults: 6081h 1000 rpm, 6083h = 6084h = 6000 rpm/s, 6067h 1000
/// increments for 6068h 10 ms.
const PROFILE_RPM: f64 = 1000.0;
const RAMP_RPM_PER_S: f64 = 6000.0;
const POSITION_WINDOW: i32 = 1000;
const POSITION_WINDOW_MS: usize = 10;

fn counts_per_s(rpm: f64) -> i32 {
    (rpm / 60.0 * f64::from(CPR)) as i32
}

/// INIT → OP in free run with 6060h = `mode`, the SDO writes `writes` in PREOP, then enabled.
macro_rules! enabled {
    ($m:expr, $md:expr, $mode:expr, $writes:expr) => {{
        let group = $md
            .init_single_group::<4, 64>($m.shared.clock().now_fn())
            .await
            .expect("init");
        {
            let sd = group.subdevice($md, 0).expect("drive");
            sd.sdo_write(0x6060, 0, $mode).await.expect("6060h");
            for &(index, value) in $writes {
                let value: i32 = value;
                sd.sdo_write(index, 0, value).await.expect("SDO");
            }
        }
        let group = group
            .into_safe_op($md)
            .await
            .expect("SAFE-OP")
            .request_into_op($md)
            .await
            .expect("request OP");
        let mut s = csp::phase_locked(&$m, $md, &group, 0, 0, $mode).await;
        for cw in [SHUTDOWN; 5]
            .into_iter()
            .chain([SWITCH_ON; 5])
            .chain([ENABLE_OPERATION; 20])
        {
            s = csp::phase_locked(&$m, $md, &group, cw, 0, $mode).await;
        }
        assert_eq!(s.statusword & STATE_MASK, OPERATION_ENABLED, "enabled");
        assert_eq!(s.mode_display, $mode, "6061h shows the mode");
        group
    }};
}

/// Runs `n` cycles with `cw`/`target`; the samples.
macro_rules! run {
    ($m:expr, $md:expr, $group:expr, $cw:expr, $target:expr, $mode:expr, $n:expr) => {{
        let mut samples: Vec<Sample> = Vec::new();
        for _ in 0..$n {
            samples.push(csp::phase_locked(&$m, $md, &$group, $cw, $target, $mode).await);
        }
        samples
    }};
}

/// Asserts the rotor ended within 1/1000 revolution of `rev`.
fn assert_rotor_at(s: &Sample, rev: f64) {
    assert!(
        (s.revolutions - rev).abs() < 1e-3,
        "rotor at {} rev, expected {rev}",
        s.revolutions
    );
}

fn peak_rpm(samples: &[Sample]) -> f64 {
    samples.iter().map(|s| s.rpm.abs()).fold(0.0, f64::max)
}

/// The time (s) a trapezoidal move of `revolutions` takes at [`PROFILE_RPM`] and
/// [`RAMP_RPM_PER_S`].
fn trapezoid_s(revolutions: f64) -> f64 {
    let v = PROFILE_RPM / 60.0;
    let a = RAMP_RPM_PER_S / 60.0;
    let ramps = v * v / a;
    if revolutions >= ramps {
        2.0 * v / a + (revolutions - ramps) / v
    } else {
        2.0 * (revolutions / a).sqrt()
    }
}

#[test]
fn standard_profile_position_single_set_point() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = enabled!(m, md, PP, &[]);
        let target = 5 * CPR;
        // Handshake: bit 4 up → bit 12 up; bit 4 down → bit 12 down.
        let s = run!(
            m,
            md,
            group,
            ENABLE_OPERATION | NEW_SET_POINT,
            target,
            PP,
            3
        );
        assert_ne!(s[2].statusword & BIT12, 0, "set-point acknowledged");
        assert_eq!(s[2].statusword & TARGET_REACHED, 0, "moving: not reached");
        let mut samples = s;
        samples.extend(run!(m, md, group, ENABLE_OPERATION, target, PP, 700));
        assert_eq!(samples[5].statusword & BIT12, 0, "bit 4 fell: buffer free");

        // The move: at the profile velocity, no faster, on the trapezoid's schedule.
        let peak = peak_rpm(&samples);
        assert!(
            (peak - PROFILE_RPM).abs() < 30.0,
            "peak {peak:.0} rpm, 6081h = {PROFILE_RPM} rpm"
        );
        let arrived = samples
            .iter()
            .position(|s| (s.position - target).abs() <= POSITION_WINDOW && s.rpm.abs() < 20.0)
            .expect("arrived");
        let expected = trapezoid_s(5.0);
        let took = arrived as f64 * CYCLE_S;
        assert!(
            (took - expected).abs() < 0.03,
            "arrived after {took:.3} s, the trapezoid takes {expected:.3} s"
        );
        // Bit 10 after the window time, and the motor stays on the target.
        // (The first frames carry the statusword from before the set-point.)
        let reached = samples
            .iter()
            .enumerate()
            .skip(3)
            .find(|(_, s)| s.statusword & TARGET_REACHED != 0)
            .expect("target reached")
            .0;
        assert!(
            reached >= arrived.saturating_sub(20) && reached <= arrived + POSITION_WINDOW_MS + 20,
            "bit 10 at cycle {reached}, arrival at {arrived}"
        );
        let last = samples.last().unwrap();
        assert!(
            (last.position - target).abs() <= 50,
            "6064h {}",
            last.position
        );
        assert_rotor_at(last, 5.0);
        assert_ne!(last.statusword & TARGET_REACHED, 0);
    });
}

#[test]
fn standard_profile_position_set_of_set_points_stops_between_moves() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = enabled!(m, md, PP, &[]);
        let (first, second) = (2 * CPR, 4 * CPR);
        let mut samples = run!(m, md, group, ENABLE_OPERATION | NEW_SET_POINT, first, PP, 2);
        samples.extend(run!(m, md, group, ENABLE_OPERATION, first, PP, 50));
        // The second set-point while the first runs: buffered, bit 12 stays set.
        samples.extend(run!(
            m,
            md,
            group,
            ENABLE_OPERATION | NEW_SET_POINT,
            second,
            PP,
            2
        ));
        let buffered = run!(m, md, group, ENABLE_OPERATION, second, PP, 50);
        assert!(
            buffered.iter().all(|s| s.statusword & BIT12 != 0),
            "buffer full while the first move runs"
        );
        samples.extend(buffered);
        samples.extend(run!(m, md, group, ENABLE_OPERATION, second, PP, 1000));
        // The motor stopped on the first target, then went on.
        let at_first = samples
            .iter()
            .filter(|s| (s.revolutions - 2.0).abs() < 0.01)
            .map(|s| s.rpm.abs())
            .fold(f64::MAX, f64::min);
        assert!(at_first < 30.0, "{at_first:.0} rpm at the first target");
        let last = samples.last().unwrap();
        assert_rotor_at(last, 4.0);
        assert_eq!(last.statusword & BIT12, 0, "buffer empty");
        assert_ne!(last.statusword & TARGET_REACHED, 0);
    });
}

#[test]
fn standard_profile_position_change_on_set_point_passes_the_first_target() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = enabled!(m, md, PP, &[]);
        let (first, second) = (2 * CPR, 4 * CPR);
        let mut samples = run!(m, md, group, ENABLE_OPERATION | NEW_SET_POINT, first, PP, 2);
        samples.extend(run!(m, md, group, ENABLE_OPERATION, first, PP, 50));
        let cw = ENABLE_OPERATION | CHANGE_ON_SET_POINT;
        samples.extend(run!(m, md, group, cw | NEW_SET_POINT, second, PP, 2));
        samples.extend(run!(m, md, group, cw, second, PP, 1000));
        let at_first = samples
            .iter()
            .filter(|s| (s.revolutions - 2.0).abs() < 0.02)
            .map(|s| s.rpm.abs())
            .fold(f64::MAX, f64::min);
        assert!(
            at_first > 0.9 * PROFILE_RPM,
            "{at_first:.0} rpm at the first target: bit 9 passes it at speed"
        );
        // One trapezoid over both moves.
        let arrived = samples
            .iter()
            .position(|s| (s.revolutions - 4.0).abs() < 1e-3 && s.rpm.abs() < 20.0)
            .expect("arrived");
        let expected = trapezoid_s(4.0);
        assert!(
            (arrived as f64 * CYCLE_S - expected).abs() < 0.03,
            "{arrived} ms, expected {expected:.3} s"
        );
    });
}

#[test]
fn standard_profile_position_relative_change_immediately_accumulates() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = enabled!(m, md, PP, &[]);
        let cw = ENABLE_OPERATION | RELATIVE | CHANGE_SET_IMMEDIATELY;
        run!(m, md, group, cw | NEW_SET_POINT, 3 * CPR, PP, 2);
        run!(m, md, group, cw, 0, PP, 100);
        // +1 revolution on top of the unfinished 3.
        run!(m, md, group, cw | NEW_SET_POINT, CPR, PP, 2);
        let samples = run!(m, md, group, cw, 0, PP, 1000);
        let last = samples.last().unwrap();
        assert_rotor_at(last, 4.0);
        assert!((last.position - 4 * CPR).abs() <= 50);
    });
}

#[test]
fn standard_profile_position_halt_stops_and_resumes() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = enabled!(m, md, PP, &[]);
        let target = 6 * CPR;
        run!(
            m,
            md,
            group,
            ENABLE_OPERATION | NEW_SET_POINT,
            target,
            PP,
            2
        );
        run!(m, md, group, ENABLE_OPERATION, target, PP, 200);
        let halted = run!(m, md, group, ENABLE_OPERATION | HALT, target, PP, 300);
        let last = halted.last().unwrap();
        assert!(last.rpm.abs() < 5.0, "halted: {:.1} rpm", last.rpm);
        assert!(
            last.revolutions < 5.0,
            "stopped short at {} rev",
            last.revolutions
        );
        assert_ne!(
            last.statusword & TARGET_REACHED,
            0,
            "bit 10 with halt: at rest"
        );
        let resumed = run!(m, md, group, ENABLE_OPERATION, target, PP, 1000);
        let last = resumed.last().unwrap();
        assert_rotor_at(last, 6.0);
        assert_ne!(last.statusword & TARGET_REACHED, 0);
    });
}

#[test]
fn standard_profile_velocity_ramps_to_60ffh_and_reports_speed_zero() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = enabled!(m, md, PV, &[]);
        let s = run!(m, md, group, ENABLE_OPERATION, 0, PV, 20);
        let last = s.last().unwrap();
        assert_eq!(
            last.statusword & (TARGET_REACHED | BIT12),
            TARGET_REACHED | BIT12,
            "at rest with 60FFh = 0: reached, speed zero"
        );
        let sd = group.subdevice(md, 0).expect("drive");
        sd.sdo_write(0x60FF, 0, counts_per_s(500.0))
            .await
            .expect("60FFh");
        let up = run!(m, md, group, ENABLE_OPERATION, 0, PV, 300);
        // 500 rpm at 6000 rpm/s: 83 ms.
        let at_speed = up.iter().position(|s| s.rpm > 495.0).expect("at speed");
        assert!(
            (75..=100).contains(&at_speed),
            "500 rpm after {at_speed} ms"
        );
        assert!(up[40].statusword & (TARGET_REACHED | BIT12) == 0, "ramping");
        let last = up.last().unwrap();
        assert!((last.rpm - 500.0).abs() < 5.0, "{:.1} rpm", last.rpm);
        assert_eq!(last.statusword & (TARGET_REACHED | BIT12), TARGET_REACHED);
        // 607Fh limits 60FFh.
        sd.sdo_write(0x607F, 0, counts_per_s(700.0))
            .await
            .expect("607Fh");
        sd.sdo_write(0x60FF, 0, counts_per_s(2000.0))
            .await
            .expect("60FFh");
        let limited = run!(m, md, group, ENABLE_OPERATION, 0, PV, 200);
        let peak = peak_rpm(&limited);
        assert!((peak - 700.0).abs() < 10.0, "limited to {peak:.0} rpm");
        assert_eq!(
            limited.last().unwrap().statusword & TARGET_REACHED,
            0,
            "60FFh not reached"
        );
        // Back to 0 on 6084h; speed zero again.
        sd.sdo_write(0x60FF, 0, 0i32).await.expect("60FFh");
        let down = run!(m, md, group, ENABLE_OPERATION, 0, PV, 300);
        let stopped = down
            .iter()
            .position(|s| s.rpm.abs() < 5.0)
            .expect("stopped");
        assert!(
            (105..=135).contains(&stopped),
            "stopped after {stopped} ms (700 rpm / 6000 rpm/s)"
        );
        assert_eq!(
            down.last().unwrap().statusword & (TARGET_REACHED | BIT12),
            TARGET_REACHED | BIT12
        );
    });
}

#[test]
fn standard_profile_torque_ramps_at_the_torque_slope() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        // 6087h = 1000 ‰/s: 50 ‰ (5 % of the rated torque) in 50 ms.
        let group = enabled!(m, md, PT, &[(0x6087, 1000)]);
        let sd = group.subdevice(md, 0).expect("drive");
        sd.sdo_write(0x6071, 0, 50i16).await.expect("6071h");
        let mut demands = Vec::new();
        let mut statuswords = Vec::new();
        for _ in 0..8 {
            let s = run!(m, md, group, ENABLE_OPERATION, 0, PT, 10);
            statuswords.push(s.last().unwrap().statusword);
            let demand: i16 = sd.sdo_read(0x6074, 0).await.expect("6074h");
            demands.push(demand);
        }
        // Every 10 ms (plus the SDO's own cycles) the demand rises by about 10 ‰, up to 50.
        assert!(demands[0] > 0 && demands[0] < 25, "{demands:?}");
        assert!(demands.windows(2).all(|w| w[1] >= w[0]), "{demands:?}");
        assert_eq!(*demands.last().unwrap(), 50, "{demands:?}");
        assert_eq!(statuswords[0] & TARGET_REACHED, 0);
        assert_ne!(statuswords.last().unwrap() & TARGET_REACHED, 0);
        let s = run!(m, md, group, ENABLE_OPERATION, 0, PT, 100);
        assert!(
            s.last().unwrap().rpm > s[0].rpm + 10.0,
            "the torque accelerates the free motor"
        );
    });
}

#[test]
fn standard_csp_offsets_shift_the_target_and_feed_forward() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        const CSP: i8 = 8;
        let group = enabled!(m, md, CSP, &[]);
        let sd = group.subdevice(md, 0).expect("drive");
        // 60B0h: the motor goes to 607Ah + 60B0h.
        sd.sdo_write(0x60B0, 0, CPR / 2).await.expect("60B0h");
        let s = run!(m, md, group, ENABLE_OPERATION, 0, CSP, 500);
        let last = s.last().unwrap();
        assert!(
            (last.revolutions - 0.5).abs() < 1e-3,
            "at {} rev",
            last.revolutions
        );
        // CSV with 60FFh = 0: 60B1h alone turns the motor.
        sd.sdo_write(0x60B1, 0, (300.0 / 60.0 * f64::from(CPR)) as i32)
            .await
            .expect("60B1h");
        let s = run!(m, md, group, ENABLE_OPERATION, 0, 9, 200);
        assert!((s.last().unwrap().rpm - 300.0).abs() < 5.0, "60B1h in CSV");
        sd.sdo_write(0x60B1, 0, 0i32).await.expect("60B1h");
        run!(m, md, group, ENABLE_OPERATION, 0, 9, 200);
        // CST with 6071h = 0: 60B2h alone is the torque demand.
        sd.sdo_write(0x60B2, 0, 50i16).await.expect("60B2h");
        let s = run!(m, md, group, ENABLE_OPERATION, 0, 10, 3);
        let demand: i16 = sd.sdo_read(0x6074, 0).await.expect("6074h");
        assert_eq!(demand, 50, "60B2h in CST");
        assert_eq!(s.last().unwrap().statusword & STATE_MASK, OPERATION_ENABLED);
    });
}

#[test]
fn standard_unsupported_mode_is_not_taken() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        // 6060h = 5 (reserved) is not in the standard's 6502h: refused by SDO (0x06090030)
        // and, written by PDO, not taken: 6061h keeps the mode the drive runs.
        let group = enabled!(m, md, PV, &[]);
        let sd = group.subdevice(md, 0).expect("drive");
        assert!(sd.sdo_write(0x6060, 0, 5i8).await.is_err(), "SDO refuses 5");
        let s = run!(m, md, group, ENABLE_OPERATION, 0, 5, 5);
        assert_eq!(s.last().unwrap().mode_display, PV, "6061h stays 3");
        let s = run!(m, md, group, ENABLE_OPERATION, 0, PP, 5);
        assert_eq!(
            s.last().unwrap().mode_display,
            PP,
            "a supported mode is taken"
        );
    });
}

/// CiA402 §6.2: the mode of operation may change while the motor moves. Profile velocity at
/// 600 rpm, then cyclic synchronous velocity with the same 60FFh, then cyclic synchronous
/// position with targets that go on at 600 rpm from where the motor is: 6061h follows each
/// change and the speed holds (no stop, no jump) through both switches.
#[test]
fn standard_switches_mode_while_moving() {
    const CSV: i8 = 9;
    const CSP: i8 = 8;
    const RPM: f64 = 600.0;
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = enabled!(m, md, PV, &[(0x60FF, counts_per_s(RPM))]);
        let s = run!(m, md, group, ENABLE_OPERATION, 0, PV, 400);
        let last = *s.last().expect("samples");
        assert!((last.rpm - RPM).abs() < 10.0, "PV at {:.0} rpm", last.rpm);
        let s = run!(m, md, group, ENABLE_OPERATION, 0, CSV, 200);
        assert_eq!(s.last().expect("samples").mode_display, CSV, "6061h = 9");
        let slowest = s.iter().map(|x| x.rpm).fold(f64::MAX, f64::min);
        let fastest = s.iter().map(|x| x.rpm).fold(f64::MIN, f64::max);
        assert!(
            slowest > RPM - 15.0 && fastest < RPM + 15.0,
            "PV → CSV: {slowest:.0}..{fastest:.0} rpm"
        );
        // CSP: the target goes on from the position the drive reports, at the same speed. 6064h
        // is the previous cycle's and a target takes effect a cycle after it arrives: the
        // stream starts three cycles ahead of it.
        let step = f64::from(counts_per_s(RPM)) * CYCLE_S;
        let mut target = f64::from(s.last().expect("samples").position) + 3.0 * step;
        let mut samples = Vec::new();
        for _ in 0..300 {
            samples.push(
                csp::phase_locked(&m, md, &group, ENABLE_OPERATION, target as i32, CSP).await,
            );
            target += step;
        }
        assert_eq!(
            samples.last().expect("samples").mode_display,
            CSP,
            "6061h = 8"
        );
        let slowest = samples.iter().map(|x| x.rpm).fold(f64::MAX, f64::min);
        let fastest = samples.iter().map(|x| x.rpm).fold(f64::MIN, f64::max);
        // The drive takes over the moving motor: no stop, less than 50 rpm of disturbance.
        assert!(
            slowest > RPM - 50.0 && fastest < RPM + 50.0,
            "CSV → CSP: {slowest:.0}..{fastest:.0} rpm"
        );
        assert!(
            samples
                .iter()
                .all(|x| x.statusword & STATE_MASK == OPERATION_ENABLED),
            "Operation Enabled throughout"
        );
    });
}
