//! The profile modes of the vendor profiles on the simulated servo, commanded by ethercrab over
//! each profile's own default PDOs, in each manual's units:
//!
//! - SDV3-E §7.4: profile position with controlword bit 6 "ABS/INC" (1 = absolute, the reverse
//!   of CiA402), the position factor 6093h (16 increments per unit by default), the profile
//!   velocity 6081h in 0.1 rpm and the ramps 6083h/6084h as the time in ms from 0 to 2000 rpm;
//! - RSE 7.11: homing method 19 on a home switch, 6064h = 607Ch at the home.
//! - Σ-V-SD §4.7 bit 11: a CSP target beyond the over-interpolation speed is ignored.
//! - GHA-E §5.4.3: a homing run that finds no home signal is alarm GOH.

use ethercrab::MainDevice;
use tests_host::vendor::{self, Sdo};
use tests_host::{block_on, master_for};

const CPR: f64 = (1u32 << 20) as f64;
const CYCLE_NS: u64 = 1_000_000;
const ENABLE_OPERATION: u16 = 0x0F;
const NEW_SET_POINT: u16 = 1 << 4;
const BIT6: u16 = 1 << 6;
const STATE_MASK: u16 = 0x6F;
const OPERATION_ENABLED: u16 = 0x27;
const TARGET_REACHED: u16 = 1 << 10;
const SET_POINT_ACKNOWLEDGE: u16 = 1 << 12;
const PP: u8 = 1;

/// One SDV3-E cycle over its default PDOs: outputs 6040h, 607Ah, 60FFh, 6071h, 6060h; inputs
/// 6041h, 6064h, ...; evaluates to (statusword, 6064h, rotor revolutions, rotor rpm).
macro_rules! sdv3_cycle {
    ($m:expr, $md:expr, $group:expr, $cw:expr, $target:expr) => {{
        let sd = $group.subdevice($md, 0).expect("drive");
        {
            let mut out = sd.outputs_raw_mut();
            out[0..2].copy_from_slice(&($cw as u16).to_le_bytes());
            out[2..6].copy_from_slice(&($target as i32).to_le_bytes());
            out[12] = PP;
        }
        let since = $m.shared.clock().now();
        $group.tx_rx($md).await.expect("tx/rx");
        $m.shared.finish_cycle(since, CYCLE_NS);
        let inp = sd.inputs_raw();
        let segment = $m.shared.segment();
        let plant = &segment.drives()[0].servos[0].plant;
        (
            u16::from_le_bytes([inp[0], inp[1]]),
            i32::from_le_bytes([inp[2], inp[3], inp[4], inp[5]]),
            plant.mech_angle_rad() / std::f64::consts::TAU,
            plant.mech_speed_rad_s() / std::f64::consts::TAU * 60.0,
        )
    }};
}

#[test]
fn sdv3_e_profile_position_bit6_absolute_in_manual_units() {
    block_on(async {
        let (m, transport) = master_for(board_sim::Segment::new("sdv3-e", 1).expect("sdv3-e"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = md
            .init_single_group::<4, 64>(m.shared.clock().now_fn())
            .await
            .expect("init");
        {
            let sd = group.subdevice(md, 0).expect("drive");
            sd.sdo_write(0x6060, 0, PP as i8).await.expect("6060h");
            // 1000.0 rpm, 0 → 2000 rpm in 333 ms (6000 rpm/s) both ways.
            sd.sdo_write(0x6081, 0, 10_000u32).await.expect("6081h");
            sd.sdo_write(0x6083, 0, 333u32).await.expect("6083h");
            sd.sdo_write(0x6084, 0, 333u32).await.expect("6084h");
        }
        let group = group
            .into_safe_op(md)
            .await
            .expect("SAFE-OP")
            .request_into_op(md)
            .await
            .expect("OP");
        let mut sw = 0;
        for cw in [0x06u16; 5]
            .into_iter()
            .chain([0x07; 5])
            .chain([ENABLE_OPERATION; 20])
        {
            (sw, _, _, _) = sdv3_cycle!(m, md, group, cw, 0);
        }
        assert_eq!(sw & STATE_MASK, OPERATION_ENABLED);
        // 6093h = 16/1: 65 536 units per revolution.
        let units_per_rev = CPR / 16.0;
        // Bit 6 = 1: absolute, 5 revolutions.
        let five = (5.0 * units_per_rev) as i32;
        let cw = ENABLE_OPERATION | BIT6;
        let mut acknowledged = false;
        for _ in 0..3 {
            (sw, _, _, _) = sdv3_cycle!(m, md, group, cw | NEW_SET_POINT, five);
            acknowledged |= sw & SET_POINT_ACKNOWLEDGE != 0;
        }
        assert!(acknowledged, "bit 12");
        let mut peak = 0.0f64;
        let mut arrived = None;
        let (mut position, mut rev) = (0, 0.0);
        for k in 0..800 {
            let rpm;
            (sw, position, rev, rpm) = sdv3_cycle!(m, md, group, cw, five);
            peak = peak.max(rpm.abs());
            if arrived.is_none() && (rev - 5.0).abs() < 1e-3 && rpm.abs() < 20.0 {
                arrived = Some(k);
            }
        }
        assert!((rev - 5.0).abs() < 1e-3, "absolute: at {rev} rev");
        assert!((position - five).abs() <= 10, "6064h {position} units");
        assert_ne!(sw & TARGET_REACHED, 0);
        assert!(
            (peak - 1000.0).abs() < 30.0,
            "6081h in 0.1 rpm: peak {peak:.0} rpm"
        );
        // 5 rev at 1000 rpm with 6000 rpm/s ramps: 0.467 s.
        let took = arrived.expect("arrived") as f64 * 1e-3;
        assert!(
            (took - 0.467).abs() < 0.04,
            "6083h/6084h in ms to 2000 rpm: {took:.3} s"
        );
        // Bit 6 = 0: incremental, +1 revolution.
        let one = units_per_rev as i32;
        for _ in 0..3 {
            sdv3_cycle!(m, md, group, ENABLE_OPERATION | NEW_SET_POINT, one);
        }
        for _ in 0..600 {
            (sw, position, rev, _) = sdv3_cycle!(m, md, group, ENABLE_OPERATION, one);
        }
        assert!((rev - 6.0).abs() < 1e-3, "incremental: at {rev} rev");
        assert!((position - 6 * one).abs() <= 10, "6064h {position}");
        assert_ne!(sw & TARGET_REACHED, 0);
    });
}

/// RSE 7.11: homing method 19 (the home switch's edge, approached moving negative; no index
/// methods in this drive) over its default PDOs (outputs 6040h, 607Ah, 60B8h; inputs 603Fh,
/// 6041h, 6061h, 6064h, ...), 6060h = 6 by SDO (1600h maps no mode), speeds and acceleration in
/// command units (6091h 1:1 by default); after homing 6064h = 607Ch at the home (7.11 "the stop
/// position is the mechanical origin and its coordinate equals 607Ch").
#[test]
fn rse_homing_method_19_home_switch_edge() {
    use board_sim::plant::SwitchParams;
    use std::f64::consts::TAU;
    block_on(async {
        let (m, transport) = master_for(board_sim::Segment::new("rse", 1).expect("rse"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        m.shared.segment().drives_mut()[0].servos[0]
            .plant
            .set_switches(SwitchParams {
                home_rad: Some(0.4 * TAU),
                limit_pos_rad: Some(3.0 * TAU),
                limit_neg_rad: Some(-3.0 * TAU),
                ..SwitchParams::default()
            });
        let group = md
            .init_single_group::<4, 64>(m.shared.clock().now_fn())
            .await
            .expect("init");
        {
            let sd = group.subdevice(md, 0).expect("drive");
            sd.sdo_write(0x6060, 0, 6i8).await.expect("6060h");
            sd.sdo_write(0x6098, 0, 19i8).await.expect("6098h");
            sd.sdo_write(0x607C, 0, 1000i32).await.expect("607Ch");
            // 300 rpm and 30 rpm in command units/s, 6000 rpm/s.
            sd.sdo_write(0x6099, 1, (CPR * 5.0) as u32)
                .await
                .expect("6099h:01");
            sd.sdo_write(0x6099, 2, (CPR * 0.5) as u32)
                .await
                .expect("6099h:02");
            sd.sdo_write(0x609A, 0, (CPR * 100.0) as u32)
                .await
                .expect("609Ah");
        }
        let group = group
            .into_safe_op(md)
            .await
            .expect("SAFE-OP")
            .request_into_op(md)
            .await
            .expect("OP");
        let cycle = |cw: u16| {
            let sd = group.subdevice(md, 0).expect("drive");
            sd.outputs_raw_mut()[0..2].copy_from_slice(&cw.to_le_bytes());
            let m = &m;
            let group = &group;
            async move {
                let since = m.shared.clock().now();
                group.tx_rx(md).await.expect("tx/rx");
                m.shared.finish_cycle(since, CYCLE_NS);
                let sd = group.subdevice(md, 0).expect("drive");
                let inp = sd.inputs_raw();
                let rev = m.shared.segment().drives()[0].servos[0]
                    .plant
                    .mech_angle_rad()
                    / TAU;
                (
                    u16::from_le_bytes([inp[2], inp[3]]),
                    inp[4] as i8,
                    i32::from_le_bytes([inp[5], inp[6], inp[7], inp[8]]),
                    rev,
                )
            }
        };
        let mut s = (0, 0, 0, 0.0);
        for cw in [0x06u16; 5]
            .into_iter()
            .chain([0x07; 5])
            .chain([ENABLE_OPERATION; 20])
        {
            s = cycle(cw).await;
        }
        assert_eq!(s.0 & STATE_MASK, OPERATION_ENABLED);
        assert_eq!(s.1, 6, "6061h: homing");
        let mut done = None;
        for k in 0..5_000 {
            s = cycle(ENABLE_OPERATION | NEW_SET_POINT).await;
            if k > 5 && s.0 & 0x3400 == 0x1400 {
                done = Some(k);
                break;
            }
        }
        assert!(
            done.is_some(),
            "homing attained + target reached: {:#06x}",
            s.0
        );
        for _ in 0..20 {
            s = cycle(ENABLE_OPERATION | NEW_SET_POINT).await;
        }
        assert!(
            (s.3 - 0.4).abs() < 1e-3,
            "home at the switch edge: {} rev",
            s.3
        );
        // 6064h reads 607Ch at the home, plus the rotor's offset from it.
        let off = (s.3 - 0.4) * CPR;
        assert!(
            (f64::from(s.2) - 1000.0 - off).abs() <= 60.0,
            "6064h = 607Ch = 1000 at the home: {} with the rotor {off:.0} increments off",
            s.2
        );
    });
}

/// SDV3-E default PDOs (Table 6-5): 6040h at byte 0, 60FFh at byte 6, 6060h at byte 12 of the
/// outputs; 6041h at byte 0, 6061h at byte 12 of the inputs.
const SDV3_CW: usize = 0;
const SDV3_TARGET_VELOCITY: usize = 6;
const SDV3_MODE: usize = 12;

/// One SDV3-E cycle with controlword `cw`, target velocity `rpm` and mode `mode`; evaluates to
/// (statusword, 6061h, the motor's speed in rpm).
async fn sdv3_cycle(
    m: &board_sim::inproc::InProcess,
    md: &MainDevice<'_>,
    group: &vendor::Group,
    cw: u16,
    rpm: f64,
    mode: u8,
) -> (u16, u8, f64) {
    let velocity = ((rpm * 10.0) as i32).to_le_bytes();
    let inputs = vendor::exchange(
        m,
        md,
        group,
        &[
            (SDV3_CW, &cw.to_le_bytes()),
            (SDV3_TARGET_VELOCITY, &velocity),
            (SDV3_MODE, &[mode]),
        ],
        CYCLE_NS,
    )
    .await;
    (
        vendor::u16_at(&inputs, 0),
        inputs[SDV3_MODE],
        vendor::motor(m).0,
    )
}

/// SDV3-E 6080h "Maximal Motor Speed" (0.1 rpm, default 3000.0 rpm): a CSV target of 4000 rpm
/// over the default PDOs runs the motor at 3000 rpm; a target below it is followed exactly. In
/// CSV statusword bit 11 is "speed zero" (§7.8), not the limiter (§7.11: PP/CSP only): it stays
/// clear while the motor turns, limited or not.
#[test]
fn sdv3_e_max_motor_speed_limits_csv() {
    const CSV: u8 = 9;
    const SPEED_ZERO: u16 = 1 << 11;
    block_on(async {
        let (m, transport) = master_for(board_sim::Segment::new("sdv3-e", 1).expect("sdv3-e"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = vendor::into_op(&m, md, &[]).await;
        let mut s = (0, 0, 0.0);
        for cw in vendor::enable_sequence(20) {
            s = sdv3_cycle(&m, md, &group, cw, 0.0, CSV).await;
        }
        assert_eq!(s.0 & STATE_MASK, OPERATION_ENABLED);
        // A ramp to 4000 rpm in 1 s, then 0.3 s there.
        for k in 0..1300 {
            let rpm = 4000.0 * f64::from(k.min(1000)) / 1000.0;
            s = sdv3_cycle(&m, md, &group, ENABLE_OPERATION, rpm, CSV).await;
        }
        assert!((s.2 - 3000.0).abs() < 15.0, "held at 6080h: {:.0} rpm", s.2);
        assert_eq!(s.0 & SPEED_ZERO, 0, "bit 11 (speed zero) while limited");
        for _ in 0..500 {
            s = sdv3_cycle(&m, md, &group, ENABLE_OPERATION, 2500.0, CSV).await;
        }
        assert!((s.2 - 2500.0).abs() < 15.0, "below 6080h: {:.0} rpm", s.2);
        assert_eq!(s.0 & SPEED_ZERO, 0, "bit 11 (speed zero) below 6080h");
    });
}

/// SDV3-E Table 6-2: the velocity window 606Dh counts whole rpm (default 50), the velocities
/// 0.1 rpm. In profile velocity to 1000 rpm (60FFh = 10000), statusword bit 10 "speed arrival"
/// comes on when the motor is within 50 rpm of the target, not within 5.
#[test]
fn sdv3_e_velocity_window_in_whole_rpm() {
    const PV: u8 = 3;
    block_on(async {
        let (m, transport) = master_for(board_sim::Segment::new("sdv3-e", 1).expect("sdv3-e"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        // 0 → 2000 rpm in 2000 ms: 1000 rpm/s, 1 rpm per 1 ms cycle.
        let setup = [Sdo::U32(0x6083, 0, 2000), Sdo::U32(0x6084, 0, 2000)];
        let group = vendor::into_op(&m, md, &setup).await;
        let mut s = (0, 0, 0.0);
        for cw in vendor::enable_sequence(20) {
            s = sdv3_cycle(&m, md, &group, cw, 0.0, PV).await;
        }
        assert_eq!(s.0 & STATE_MASK, OPERATION_ENABLED);
        let mut arrived_at = None;
        let mut left = false;
        for _ in 0..1_500 {
            s = sdv3_cycle(&m, md, &group, ENABLE_OPERATION, 1000.0, PV).await;
            // At rest on the old target 0 bit 10 is set; it clears with the new target.
            left |= s.0 & TARGET_REACHED == 0;
            if left && s.0 & TARGET_REACHED != 0 {
                arrived_at = Some(s.2);
                break;
            }
        }
        // The statusword is the previous cycle's: the motor gained up to 2 rpm since.
        let rpm = arrived_at.expect("bit 10 during the ramp");
        assert!(
            (948.0..=956.0).contains(&rpm),
            "bit 10 at {rpm:.1} rpm: within 50 rpm (606Dh in rpm)"
        );
    });
}

/// RSE App A P03.45 (2006h:03): the homing time limit. Method 19 on a machine without a home
/// switch searches until the limit (300 ms), then the run ends in a homing error (6041h bits
/// 13/12 = 1/0) and the drive shows warning AL.420 (bit 7, 603Fh = its code) while enabled.
#[test]
fn rse_homing_time_limit_ends_in_a_homing_error_and_al_420() {
    const HOMING_ERROR: u16 = 1 << 13;
    const HOMING_ATTAINED: u16 = 1 << 12;
    const WARNING: u16 = 1 << 7;
    // 7.2: 1C32h:02 factory setting 4 ms, the free-run cycle.
    const RSE_CYCLE_NS: u64 = 4_000_000;
    let p = od_gen::builtin("rse").expect("profile");
    let al420 = p
        .alarms
        .iter()
        .find(|a| a.display == "AL.420")
        .expect("AL.420");
    block_on(async {
        let (m, transport) = master_for(board_sim::Segment::new("rse", 1).expect("rse"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let setup = [
            Sdo::I8(0x6060, 0, 6),
            Sdo::I8(0x6098, 0, 19),
            Sdo::U16(0x2006, 3, 300),
            Sdo::U32(0x6099, 1, CPR as u32),
            Sdo::U32(0x609A, 0, (CPR * 100.0) as u32),
        ];
        let group = vendor::into_op(&m, md, &setup).await;
        // RSE 1600h: 6040h first; 1A00h: 603Fh, 6041h.
        let cycle = |cw: u16| {
            let (m, group) = (&m, &group);
            async move {
                let inputs =
                    vendor::exchange(m, md, group, &[(0, &cw.to_le_bytes())], RSE_CYCLE_NS).await;
                (vendor::u16_at(&inputs, 0), vendor::u16_at(&inputs, 2))
            }
        };
        let mut s = (0, 0);
        for cw in vendor::enable_sequence(10) {
            s = cycle(cw).await;
        }
        assert_eq!(s.1 & STATE_MASK, OPERATION_ENABLED);
        let mut error_after = None;
        for k in 0..200 {
            s = cycle(ENABLE_OPERATION | NEW_SET_POINT).await;
            if s.1 & HOMING_ERROR != 0 {
                error_after = Some(k);
                break;
            }
        }
        // 4 ms cycles: the limit after 75 cycles, seen one cycle later.
        let k = error_after.expect("homing error");
        assert!((74..=78).contains(&k), "homing error after {k} cycles");
        assert_eq!(s.1 & HOMING_ATTAINED, 0);
        for _ in 0..3 {
            s = cycle(ENABLE_OPERATION | NEW_SET_POINT).await;
        }
        assert_ne!(s.1 & WARNING, 0, "AL.420 is a warning: bit 7");
        assert_eq!(s.0, al420.error_code, "603Fh = AL.420");
        assert_eq!(s.1 & STATE_MASK, OPERATION_ENABLED, "still enabled");
    });
}

/// SDV3-E §5.2 9: changing 6060h while homing runs raises oPE (603Fh 8800h): the drive faults,
/// 6061h never shows the new mode during the run, and the motor stops.
#[test]
fn sdv3_e_a_mode_change_while_homing_is_ope() {
    use board_sim::plant::SwitchParams;
    const HM: u8 = 6;
    const CSP: u8 = 8;
    const FAULT: u16 = 0x08;
    const OPE: u16 = 0x8800;
    block_on(async {
        let (m, transport) = master_for(board_sim::Segment::new("sdv3-e", 1).expect("sdv3-e"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        // A home switch far away: the search goes on.
        m.shared.segment().drives_mut()[0].servos[0]
            .plant
            .set_switches(SwitchParams {
                home_rad: Some(50.0),
                ..SwitchParams::default()
            });
        // Method 20 at 60 rpm (6099h:01 in 0.1 rpm).
        let setup = [Sdo::I8(0x6098, 0, 20), Sdo::U32(0x6099, 1, 600)];
        let group = vendor::into_op(&m, md, &setup).await;
        let mut s = (0, 0, 0.0);
        for cw in vendor::enable_sequence(20) {
            s = sdv3_cycle(&m, md, &group, cw, 0.0, HM).await;
        }
        assert_eq!(s.0 & STATE_MASK, OPERATION_ENABLED);
        for _ in 0..100 {
            s = sdv3_cycle(&m, md, &group, ENABLE_OPERATION | NEW_SET_POINT, 0.0, HM).await;
        }
        assert_eq!(s.0 & 0x3400, 0, "homing in progress: {:#06x}", s.0);
        let mut seen_modes = Vec::new();
        for _ in 0..20 {
            s = sdv3_cycle(&m, md, &group, ENABLE_OPERATION | NEW_SET_POINT, 0.0, CSP).await;
            seen_modes.push(s.1);
            if s.0 & FAULT != 0 {
                break;
            }
        }
        assert_ne!(s.0 & FAULT, 0, "oPE: {:#06x}", s.0);
        // Up to the cycle that refused it (and faulted), 6061h shows homing.
        assert!(
            seen_modes.iter().all(|m| *m == HM),
            "6061h did not take CSP during the run: {seen_modes:?}"
        );
        let sd = group.subdevice(md, 0).expect("drive");
        assert_eq!(sd.sdo_read::<u16>(0x603F, 0).await.expect("603Fh"), OPE);
    });
}

/// Σ-V-SD §4.7 statusword bit 11: in CSP (and IP) the target must move the position demand by
/// less than 4194304 inc/ms (2301h 1:1 by default: user units are increments), else "the
/// target position is ignored". Over its default PDOs (1600h: 6040h, 607Ah, ...; 1A00h: 6041h,
/// 6064h, ...) a step of 5 revolutions in one 1 ms cycle is ignored (the demand 6062h and the
/// motor stay, bit 11 set); a step of 1000 increments is taken and bit 11 clears.
#[test]
fn sigma_v_sd_csp_target_beyond_the_interpolation_speed_is_ignored() {
    const CSP: i8 = 8;
    const INTERNAL_LIMIT: u16 = 1 << 11;
    // The Σ-V-SD's free-run cycle (1C32h:02 default).
    const SIGMA_CYCLE_NS: u64 = 1_000_000;
    block_on(async {
        let (m, transport) =
            master_for(board_sim::Segment::new("sigma-v-sd", 1).expect("sigma-v-sd"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = vendor::into_op(&m, md, &[Sdo::I8(0x6060, 0, CSP)]).await;
        let sd = group.subdevice(md, 0).expect("drive");
        let cycle = |cw: u16, target: i32| {
            let (m, group) = (&m, &group);
            async move {
                let inputs = vendor::exchange(
                    m,
                    md,
                    group,
                    &[(0, &cw.to_le_bytes()), (2, &target.to_le_bytes())],
                    SIGMA_CYCLE_NS,
                )
                .await;
                (vendor::u16_at(&inputs, 0), vendor::i32_at(&inputs, 2))
            }
        };
        // Enable on the actual position.
        let (_, start) = cycle(0, 0).await;
        let mut s = (0, start);
        for cw in vendor::enable_sequence(20) {
            s = cycle(cw, start).await;
        }
        assert_eq!(s.0 & STATE_MASK, OPERATION_ENABLED, "{:#06x}", s.0);
        assert_eq!(s.0 & INTERNAL_LIMIT, 0);
        // 5 revolutions (5 × 2^20 increments) in 1 ms: ignored.
        let jump = start.wrapping_add(5 << 20);
        for _ in 0..10 {
            s = cycle(ENABLE_OPERATION, jump).await;
        }
        assert_ne!(s.0 & INTERNAL_LIMIT, 0, "bit 11: {:#06x}", s.0);
        assert_eq!(s.0 & STATE_MASK, OPERATION_ENABLED, "no fault");
        let demand: i32 = sd.sdo_read(0x6062, 0).await.expect("6062h");
        assert_eq!(demand, start, "the demand stays");
        assert!((s.1 - start).abs() < 100, "the motor stays: 6064h {}", s.1);
        // A plausible step is taken.
        let near = start.wrapping_add(1000);
        for _ in 0..50 {
            s = cycle(ENABLE_OPERATION, near).await;
        }
        assert_eq!(s.0 & INTERNAL_LIMIT, 0, "bit 11 clear: {:#06x}", s.0);
        let demand: i32 = sd.sdo_read(0x6062, 0).await.expect("6062h");
        assert_eq!(demand, near);
        assert!((s.1 - near).abs() < 100, "6064h {} follows", s.1);
    });
}

/// GHA-E §5.4.3: a homing run that does not find its home signal ends with statusword bit 13
/// (homing error) and alarm GOH "Back to zero failure" (603Fh 8613h, Fault). Method 7 (home
/// switch, positive first) on a machine with limit switches at ±0.5 rev and no home switch:
/// the search reverses at the positive limit and fails at the negative one.
#[test]
fn gha_e_homing_that_finds_no_home_signal_is_goh() {
    use board_sim::plant::SwitchParams;
    use std::f64::consts::TAU;
    const HM: i8 = 6;
    const HOMING_ERROR: u16 = 1 << 13;
    const FAULT_BIT: u16 = 0x08;
    const GOH: u16 = 0x8613;
    // 6091h default 131072:10000: 80000 units per revolution; the GHA-E runs in DC only (1 ms).
    const UNITS_PER_REV: f64 = 80_000.0;
    const GHA_CYCLE_NS: u64 = 1_000_000;
    block_on(async {
        let (m, transport) = master_for(board_sim::Segment::new("gha-e", 1).expect("gha-e"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        m.shared.segment().drives_mut()[0].servos[0]
            .plant
            .set_switches(SwitchParams {
                limit_pos_rad: Some(0.5 * TAU),
                limit_neg_rad: Some(-0.5 * TAU),
                ..SwitchParams::default()
            });
        let group = vendor::into_op_dc(
            &m,
            md,
            &[
                Sdo::I8(0x6098, 0, 7),
                // 60 rpm searching, 6 rpm creeping, 10 rev/s² (user units).
                Sdo::U32(0x6099, 1, UNITS_PER_REV as u32),
                Sdo::U32(0x6099, 2, (UNITS_PER_REV / 10.0) as u32),
                Sdo::U32(0x609A, 0, (10.0 * UNITS_PER_REV) as u32),
            ],
            GHA_CYCLE_NS,
        )
        .await;
        let sd = group.subdevice(md, 0).expect("drive");
        // GHA-E 1600h: 6040h at byte 0, 607Ah at 2, 6060h at 6; 1A00h: 6041h first.
        let cycle = |cw: u16| {
            let (m, group) = (&m, &group);
            async move {
                let inputs = vendor::exchange_dc(
                    m,
                    md,
                    group,
                    &[(0, &cw.to_le_bytes()), (6, &[HM as u8])],
                    GHA_CYCLE_NS,
                )
                .await;
                vendor::u16_at(&inputs, 0)
            }
        };
        // Past the SYNC0 start delay, then the enable sequence.
        for _ in 0..20 {
            cycle(0).await;
        }
        let mut sw = 0;
        for cw in vendor::enable_sequence(20) {
            sw = cycle(cw).await;
        }
        assert_eq!(sw & STATE_MASK, OPERATION_ENABLED, "{sw:#06x}");
        // Start homing (bit 4) and run until the drive faults.
        let mut k = 0;
        while sw & FAULT_BIT == 0 {
            k += 1;
            assert!(k < 10_000, "no end of the search: {sw:#06x}");
            sw = cycle(ENABLE_OPERATION | NEW_SET_POINT).await;
            // GOH comes in the cycle the error does.
            assert!(
                sw & HOMING_ERROR == 0 || sw & FAULT_BIT != 0,
                "homing error without GOH: {sw:#06x}"
            );
        }
        let error: u16 = sd.sdo_read(0x603F, 0).await.expect("603Fh");
        assert_eq!(error, GOH);
        let (_, rev) = vendor::motor(&m);
        assert!(rev < -0.3, "failed at the negative limit: {rev:.2} rev");
        sw = cycle(ENABLE_OPERATION | NEW_SET_POINT).await;
        assert_ne!(sw & HOMING_ERROR, 0, "bit 13 in Fault: {sw:#06x}");
    });
}
