//! Position limits and monitoring (CiA402 607Dh software position limits, limit switches,
//! 60FDh digital inputs, 6065h/6066h following error) on the simulated servo of the standard
//! profile, commanded by ethercrab over the default PDOs (6040h, 607Ah, 6060h / 6041h, 6064h,
//! 6061h) in free run:
//!
//! - a profile-position target beyond 607Dh:02 ends at the limit, statusword bit 11 set;
//! - profile velocity into an actuated limit switch stops on the quick-stop ramp and holds
//!   (bit 11, 60FDh bit 1), moving away is allowed;
//! - a motor blocked by a hard stop while CSP moves on: the following error passes 6065h for
//!   longer than 6066h, the drive faults with 0x8611 (the standard profile's following_error).

use std::f64::consts::TAU;

use board_sim::plant::SwitchParams;
use ethercrab::MainDevice;
use tests_host::csp::{self, Sample};
use tests_host::{block_on, master};

const CPR: f64 = (1u32 << 20) as f64;
const ENABLE_OPERATION: u16 = 0x0F;
const NEW_SET_POINT: u16 = 1 << 4;
const STATE_MASK: u16 = 0x6F;
const OPERATION_ENABLED: u16 = 0x27;
const FAULT_STATE: u16 = 0x08;
const INTERNAL_LIMIT: u16 = 1 << 11;
const PP: i8 = 1;
const PV: i8 = 3;
const CSP: i8 = 8;

macro_rules! enabled {
    ($m:expr, $md:expr, $mode:expr) => {{
        let group = csp::into_op_with_mode(&$m, $md, $mode).await;
        let mut s = csp::phase_locked(&$m, $md, &group, 0, 0, $mode).await;
        for cw in [0x06u16; 5]
            .into_iter()
            .chain([0x07; 5])
            .chain([ENABLE_OPERATION; 10])
        {
            s = csp::phase_locked(&$m, $md, &group, cw, s.position, $mode).await;
        }
        assert_eq!(s.statusword & STATE_MASK, OPERATION_ENABLED);
        group
    }};
}

macro_rules! run {
    ($m:expr, $md:expr, $group:expr, $cw:expr, $target:expr, $mode:expr, $n:expr) => {{
        let mut v: Vec<Sample> = Vec::new();
        for _ in 0..$n {
            v.push(csp::phase_locked(&$m, $md, &$group, $cw, $target, $mode).await);
        }
        v
    }};
}

#[test]
fn standard_software_limit_ends_a_profile_position_move_at_607dh() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = enabled!(m, md, PP);
        let sd = group.subdevice(md, 0).expect("drive");
        sd.sdo_write(0x607D, 1, (-CPR) as i32)
            .await
            .expect("607Dh:01");
        sd.sdo_write(0x607D, 2, (2.0 * CPR) as i32)
            .await
            .expect("607Dh:02");
        let beyond = (5.0 * CPR) as i32;
        run!(
            m,
            md,
            group,
            ENABLE_OPERATION | NEW_SET_POINT,
            beyond,
            PP,
            3
        );
        let s = run!(m, md, group, ENABLE_OPERATION, beyond, PP, 1_000);
        let last = s.last().unwrap();
        assert!(
            (last.revolutions - 2.0).abs() < 1e-3,
            "stopped at the limit: {} rev",
            last.revolutions
        );
        assert!(
            s.iter().all(|s| s.revolutions < 2.0 + 1e-3),
            "never beyond it"
        );
        assert_ne!(last.statusword & INTERNAL_LIMIT, 0, "bit 11: at the limit");
    });
}

#[test]
fn standard_limit_switch_stops_motion_into_it_and_frees_motion_away() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        m.shared.segment().drives_mut()[0].servos[0]
            .plant
            .set_switches(SwitchParams {
                limit_pos_rad: Some(0.5 * TAU),
                ..SwitchParams::default()
            });
        let group = enabled!(m, md, PV);
        let sd = group.subdevice(md, 0).expect("drive");
        let rpm = |r: f64| (r / 60.0 * CPR) as i32;
        sd.sdo_write(0x60FF, 0, rpm(300.0)).await.expect("60FFh");
        let s = run!(m, md, group, ENABLE_OPERATION, 0, PV, 400);
        let last = s.last().unwrap();
        assert!(last.rpm.abs() < 2.0, "stopped: {:.1} rpm", last.rpm);
        // 300 rpm on the quick-stop ramp (6085h: 3000 rpm in 0.1 s) takes 10 ms: 0.025 rev.
        assert!(
            (0.5..0.53).contains(&last.revolutions),
            "stopped just past the switch: {} rev",
            last.revolutions
        );
        assert_ne!(last.statusword & INTERNAL_LIMIT, 0, "bit 11");
        assert_eq!(last.statusword & STATE_MASK, OPERATION_ENABLED, "no fault");
        let inputs: u32 = sd.sdo_read(0x60FD, 0).await.expect("60FDh");
        assert_eq!(inputs & 0b111, 0b010, "60FDh bit 1: positive limit switch");
        // Away from it: free.
        sd.sdo_write(0x60FF, 0, rpm(-300.0)).await.expect("60FFh");
        let s = run!(m, md, group, ENABLE_OPERATION, 0, PV, 300);
        let last = s.last().unwrap();
        assert!(
            (last.rpm + 300.0).abs() < 5.0,
            "moving away: {:.1} rpm",
            last.rpm
        );
        assert_eq!(last.statusword & INTERNAL_LIMIT, 0, "off the switch");
        let inputs: u32 = sd.sdo_read(0x60FD, 0).await.expect("60FDh");
        assert_eq!(inputs & 0b111, 0);
    });
}

#[test]
fn standard_following_error_beyond_6065h_for_6066h_is_fault_0x8611() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        // A hard stop at 0.2 rev that the CSP motion runs into.
        m.shared.segment().drives_mut()[0].servos[0]
            .plant
            .set_end_stops(Some((-TAU, 0.2 * TAU)));
        let group = enabled!(m, md, CSP);
        let sd = group.subdevice(md, 0).expect("drive");
        sd.sdo_write(0x6065, 0, 20_000u32).await.expect("6065h");
        sd.sdo_write(0x6066, 0, 50u16).await.expect("6066h");
        // 100 rpm: 1748 increments per cycle.
        let mut target = 0.0;
        let mut samples = Vec::new();
        for _ in 0..500 {
            target += 100.0 / 60.0 * CPR * 1e-3;
            let s = csp::phase_locked(&m, md, &group, ENABLE_OPERATION, target as i32, CSP).await;
            samples.push(s);
            if s.statusword & STATE_MASK == FAULT_STATE {
                break;
            }
        }
        let last = samples.last().unwrap();
        assert_eq!(last.statusword & STATE_MASK, FAULT_STATE, "faulted");
        let code: u16 = sd.sdo_read(0x603F, 0).await.expect("603Fh");
        assert_eq!(code, 0x8611, "603Fh following error");
        // The motor hit the stop at 0.2 rev (120 ms); the error passes 20 000 increments about
        // 11 ms later, the fault follows 50 ms after that.
        let hit = samples
            .iter()
            .position(|s| s.revolutions > 0.199)
            .expect("hit the stop");
        let fault = samples.len() - 1;
        assert!(
            (55..=75).contains(&(fault - hit)),
            "fault {} cycles after the stop",
            fault - hit
        );
    });
}

#[test]
fn standard_torque_limits_cap_a_torque_set_point_and_the_speed_loop() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        // Profile torque asks 100 % of the rated torque; 6072h allows 20 %.
        let group = enabled!(m, md, 4);
        let sd = group.subdevice(md, 0).expect("drive");
        sd.sdo_write(0x6087, 0, 0u32)
            .await
            .expect("6087h: no slope");
        sd.sdo_write(0x6072, 0, 200u16).await.expect("6072h");
        sd.sdo_write(0x6071, 0, 1000i16).await.expect("6071h");
        let s = run!(m, md, group, ENABLE_OPERATION, 0, 4, 50);
        let demand: i16 = sd.sdo_read(0x6074, 0).await.expect("6074h");
        assert_eq!(demand, 200, "6074h limited to 6072h");
        assert_ne!(s.last().unwrap().statusword & INTERNAL_LIMIT, 0, "bit 11");
        let actual: i16 = sd.sdo_read(0x6077, 0).await.expect("6077h");
        assert!((actual - 200).abs() <= 20, "6077h {actual}‰");
        sd.sdo_write(0x6071, 0, 0i16).await.expect("6071h");
        run!(m, md, group, ENABLE_OPERATION, 0, 4, 200);
    });
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        // Profile velocity to 1000 rpm with 60E0h = 2 %: the acceleration is torque-limited
        // (statusword bit 11), the torque never above 2 %.
        let group = enabled!(m, md, PV);
        let sd = group.subdevice(md, 0).expect("drive");
        sd.sdo_write(0x60E0, 0, 20u16).await.expect("60E0h");
        sd.sdo_write(0x60FF, 0, (1000.0 / 60.0 * CPR) as i32)
            .await
            .expect("60FFh");
        let mut limited = false;
        for _ in 0..100 {
            let s = csp::phase_locked(&m, md, &group, ENABLE_OPERATION, 0, PV).await;
            limited |= s.statusword & INTERNAL_LIMIT != 0;
        }
        let torque: i16 = sd.sdo_read(0x6077, 0).await.expect("6077h");
        assert!(
            torque <= 22 && torque > 10,
            "6077h {torque}‰ at the 60E0h limit"
        );
        assert!(limited, "bit 11 while limited");
    });
}

/// The standard profile's I²t warning (`[warnings] motor_overload`, CiA402 2351h "load level
/// warning"): a locked rotor asked for 28 A in cyclic synchronous torque heats the motor's I²t
/// model; from 80 % of its trip level statusword bit 7 is set and 603Fh shows 2351h while the
/// drive stays in Operation Enabled (the current folds back instead of tripping); with the
/// torque removed the model cools and both clear.
#[test]
fn standard_motor_overload_warning_in_bit_7_and_603fh() {
    const CST: i8 = 10;
    const WARNING: u16 = 1 << 7;
    const LOAD_LEVEL_WARNING: u16 = 0x2351;
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = enabled!(m, md, CST);
        m.shared.segment().drives_mut()[0].servos[0]
            .plant
            .set_driven_speed(Some(0.0));
        let sd = group.subdevice(md, 0).expect("drive");
        // 6071h in ‰ of 6076h (1.27 N·m = 15.7 A): 28 A = 1783 ‰.
        sd.sdo_write(0x6071, 0, 1783i16).await.expect("6071h");
        let mut warned = None;
        for k in 0..5_000 {
            let s = csp::phase_locked(&m, md, &group, ENABLE_OPERATION, 0, CST).await;
            assert_eq!(
                s.statusword & STATE_MASK,
                OPERATION_ENABLED,
                "no trip at {k}"
            );
            if s.statusword & WARNING != 0 {
                warned = Some(k);
                break;
            }
        }
        // From cold at 28 A the trip level is reached after (30² − 15.7²)·3 s / (28² − 15.7²)
        // = 3.65 s: 80 % of it after 2.92 s.
        let k = warned.expect("bit 7") as f64 * 1e-3;
        assert!((k - 2.92).abs() < 0.15, "warning after {k:.2} s");
        let sd = group.subdevice(md, 0).expect("drive");
        assert_eq!(
            sd.sdo_read::<u16>(0x603F, 0).await.expect("603Fh"),
            LOAD_LEVEL_WARNING
        );
        sd.sdo_write(0x6071, 0, 0i16).await.expect("6071h");
        let mut cleared = false;
        for _ in 0..5_000 {
            let s = csp::phase_locked(&m, md, &group, ENABLE_OPERATION, 0, CST).await;
            if s.statusword & WARNING == 0 {
                cleared = true;
                break;
            }
        }
        assert!(cleared, "the model cools below 80 %");
        let sd = group.subdevice(md, 0).expect("drive");
        assert_eq!(sd.sdo_read::<u16>(0x603F, 0).await.expect("603Fh"), 0);
    });
}
