//! The Σ-V-SD SERVOPACK for two axes (CACR-JUM, `sigma-v-sd-2axis`): two independent axes in one
//! slave, each with its own motor in the simulated drive, commanded by ethercrab over the
//! default PDOs of both axes (§2.4: axis 2's CiA402 objects at +800h; §4.4 (2): 1C12h/1C13h
//! assign 1600h + 1610h and 1A00h + 1A10h by default), in free run at 1 ms.
//!
//! Each axis runs its own state machine, mode of operation, homing and faults: axis 1 follows a
//! cyclic synchronous position stream while axis 2 is still disabled, then homes, then moves in
//! profile position; a fault of axis 2 (its drive over-temperature) is reported in axis 2's
//! 683Fh and in an EMCY carrying axis number 2 in byte 7 (§2.7), and axis 1 runs on. Both axes
//! also follow CSP streams at the same time, and a fault of axis 1 leaves axis 2's motion
//! undisturbed.

use std::f64::consts::TAU;

use board_sim::inproc::InProcess;
use board_sim::Segment;
use ethercrab::subdevice_group::Op;
use ethercrab::{Command, DefaultLock, MainDevice, SubDeviceGroup};
use tests_host::{block_on, master_for, FIRST_STATION};

const CYCLE_NS: u64 = 1_000_000;
/// Increments per revolution of the simulated servo's encoder (2301h = 1/1: 1 Pos. unit = 1 inc).
const CPR: f64 = (1u32 << 20) as f64;
const SHUTDOWN: u16 = 0x06;
const SWITCH_ON: u16 = 0x07;
const ENABLE_OPERATION: u16 = 0x0F;
const NEW_SET_POINT: u16 = 1 << 4;
const STATE_MASK: u16 = 0x6F;
const OPERATION_ENABLED: u16 = 0x27;
const SWITCH_ON_DISABLED_MASK: u16 = 0x4F;
const SWITCH_ON_DISABLED: u16 = 0x40;
const FAULT_BIT: u16 = 0x08;
const TARGET_REACHED: u16 = 1 << 10;
/// Homing: bits 13-12-10 = 011 "homing procedure is completed successfully" (§4.7 (3)).
const HOMING_BITS: u16 = 0x3400;
const HOMING_DONE: u16 = 0x1400;
/// Axis 2's objects: axis 1's + 800h (§2.4).
const AXIS_2: u16 = 0x800;
/// Byte offsets of axis 2's PDOs in the process images: 1600h is 16 bytes (6040h, 607Ah,
/// 60B1h, 60B2h, 60B8h, 23C8h:01), 1A00h 20 bytes (6041h, 6064h, 606Ch, 6077h, 60B9h, 60BAh,
/// 23C8h:02).
const RX_AXIS_2: usize = 16;
const TX_AXIS_2: usize = 20;
/// 6060h values.
const PP: i8 = 1;
const HM: i8 = 6;
const CSP: i8 = 8;
/// Drive over-temperature: the firmware's protection trips above its limit.
const HOT_C: f64 = 120.0;
/// 603Fh of the drive over-temperature on the Σ-V-SD ([motor_faults]).
const DRIVE_OVER_TEMPERATURE: u16 = 0x4210;
/// SM1 status register, bit 3 "mailbox full"; the mailbox header; CoE type and EMCY service.
const SM1_STATUS: u16 = 0x080D;
const MAILBOX_FULL: u8 = 0x08;
const MAILBOX_HEADER: usize = 6;
const COE_EMERGENCY: u16 = 1;

type OpGroup = SubDeviceGroup<4, 128, DefaultLock, Op>;

/// What one cycle brought back of both axes, and the two motors' true angles.
#[derive(Clone, Copy, Debug)]
struct Both {
    statusword: [u16; 2],
    position: [i32; 2],
    revolutions: [f64; 2],
}

/// One phase-locked cycle with controlword and target position for each axis.
async fn cycle(
    m: &InProcess,
    md: &MainDevice<'_>,
    group: &OpGroup,
    cw: [u16; 2],
    target: [i32; 2],
) -> Both {
    let sd = group.subdevice(md, 0).expect("drive");
    {
        let mut out = sd.outputs_raw_mut();
        for (axis, at) in [0, RX_AXIS_2].into_iter().enumerate() {
            out[at..at + 2].copy_from_slice(&cw[axis].to_le_bytes());
            out[at + 2..at + 6].copy_from_slice(&target[axis].to_le_bytes());
        }
    }
    let since = m.shared.clock().now();
    group.tx_rx(md).await.expect("tx/rx");
    m.shared.finish_cycle(since, CYCLE_NS);
    let inp = sd.inputs_raw();
    let at = |a: usize| {
        (
            u16::from_le_bytes([inp[a], inp[a + 1]]),
            i32::from_le_bytes([inp[a + 2], inp[a + 3], inp[a + 4], inp[a + 5]]),
        )
    };
    let (s1, p1) = at(0);
    let (s2, p2) = at(TX_AXIS_2);
    let segment = m.shared.segment();
    let rev = |axis: usize| segment.drives()[0].servos[axis].plant.mech_angle_rad() / TAU;
    Both {
        statusword: [s1, s2],
        position: [p1, p2],
        revolutions: [rev(0), rev(1)],
    }
}

/// INIT → OP in free run with axis 1 in `mode_1` and axis 2 in `mode_2` (6060h/6860h by SDO in
/// PREOP) and axis 2's homing and profile parameters.
async fn into_op(m: &InProcess, md: &MainDevice<'_>, mode_1: i8, mode_2: i8) -> OpGroup {
    let group = md
        .init_single_group::<4, 128>(m.shared.clock().now_fn())
        .await
        .expect("init");
    {
        let sd = group.subdevice(md, 0).expect("drive");
        sd.sdo_write(0x6060, 0, mode_1).await.expect("6060h");
        sd.sdo_write(0x6060 + AXIS_2, 0, mode_2)
            .await
            .expect("6860h");
        // Axis 2: homing on the index (method 34, positive direction) at 1 rev/s search and
        // 0.5 rev/s approach; profile moves at 10 rev/s with 100 rev/s² (Vel. unit = 1 inc/s,
        // Acc. unit = 10^4 inc/s² by default, §6.7).
        sd.sdo_write(0x6098 + AXIS_2, 0, 34i8).await.expect("6898h");
        sd.sdo_write(0x6099 + AXIS_2, 1, CPR as u32)
            .await
            .expect("6899h:01");
        sd.sdo_write(0x6099 + AXIS_2, 2, (CPR * 0.5) as u32)
            .await
            .expect("6899h:02");
        sd.sdo_write(0x609A + AXIS_2, 0, (CPR * 100.0 / 1e4) as u32)
            .await
            .expect("689Ah");
        sd.sdo_write(0x6081 + AXIS_2, 0, (CPR * 10.0) as u32)
            .await
            .expect("6881h");
        for index in [0x6083, 0x6084] {
            sd.sdo_write(index + AXIS_2, 0, (CPR * 100.0 / 1e4) as u32)
                .await
                .expect("6883h/6884h");
        }
    }
    group
        .into_safe_op(md)
        .await
        .expect("SAFE-OP")
        .request_into_op(md)
        .await
        .expect("OP")
}

/// Both axes through shutdown, switch on and enable operation, targets at 0: Operation Enabled.
async fn enable_both(m: &InProcess, md: &MainDevice<'_>, group: &OpGroup) -> Both {
    let mut s = cycle(m, md, group, [0, 0], [0, 0]).await;
    for cw in [SHUTDOWN; 5]
        .into_iter()
        .chain([SWITCH_ON; 5])
        .chain([ENABLE_OPERATION; 30])
    {
        s = cycle(m, md, group, [cw, cw], [0, 0]).await;
    }
    assert_eq!(s.statusword.map(|w| w & STATE_MASK), [OPERATION_ENABLED; 2]);
    s
}

/// Where the profile's SM1 (mailbox in) starts.
fn sm1_start() -> u16 {
    od_gen::builtin("sigma-v-sd-2axis")
        .expect("profile")
        .sm
        .mailbox_in
        .start
}

/// Waits (cycling both axes with `cw`/`target`) for an emergency in SM1 and returns its CoE
/// part: CoE header, EMCY code, 1001h, manufacturer field (bytes 3–7).
async fn emergency(
    m: &InProcess,
    md: &MainDevice<'_>,
    group: &OpGroup,
    cw: [u16; 2],
    target: [i32; 2],
    sm1_start: u16,
) -> Vec<u8> {
    for _ in 0..50 {
        let status: u8 = Command::fprd(FIRST_STATION, SM1_STATUS)
            .receive(md)
            .await
            .expect("SM1 status");
        if status & MAILBOX_FULL != 0 {
            let data: [u8; 256] = Command::fprd(FIRST_STATION, sm1_start)
                .receive(md)
                .await
                .expect("SM1");
            let coe = data[MAILBOX_HEADER..MAILBOX_HEADER + 10].to_vec();
            assert_eq!(u16::from_le_bytes([coe[0], coe[1]]) >> 12, COE_EMERGENCY);
            return coe;
        }
        cycle(m, md, group, cw, target).await;
    }
    panic!("no emergency in SM1");
}

#[test]
fn sigma_v_sd_2axis_moves_both_axes_independently() {
    block_on(async {
        let (m, transport) = master_for(Segment::new("sigma-v-sd-2axis", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        assert_eq!(m.shared.segment().drives()[0].servos.len(), 2, "two motors");
        let group = into_op(&m, md, CSP, HM).await;

        // Axis 1 enabled, axis 2 left in Switch On Disabled (controlword 0).
        let mut s = cycle(&m, md, &group, [0, 0], [0, 0]).await;
        for cw in [SHUTDOWN; 5]
            .into_iter()
            .chain([SWITCH_ON; 5])
            .chain([ENABLE_OPERATION; 30])
        {
            s = cycle(&m, md, &group, [cw, 0], [0, 0]).await;
        }
        assert_eq!(s.statusword[0] & STATE_MASK, OPERATION_ENABLED, "axis 1");
        assert_eq!(
            s.statusword[1] & SWITCH_ON_DISABLED_MASK,
            SWITCH_ON_DISABLED,
            "axis 2 keeps its own state: {:#06x}",
            s.statusword[1]
        );

        // Axis 1: a CSP ramp to +2 rev in 1 s; axis 2 still off and its motor at rest.
        let ramp = |k: i64| ((2.0 * CPR) as i64 * k.min(1000) / 1000) as i32;
        for k in 0..=1200 {
            s = cycle(&m, md, &group, [ENABLE_OPERATION, 0], [ramp(k), 0]).await;
        }
        assert!(
            (s.revolutions[0] - 2.0).abs() < 1e-3,
            "axis 1 at {} rev",
            s.revolutions[0]
        );
        assert!(
            s.revolutions[1].abs() < 1e-3,
            "axis 2 did not move: {}",
            s.revolutions[1]
        );
        assert!(
            (f64::from(s.position[0]) - 2.0 * CPR).abs() < 50.0,
            "6064h {}",
            s.position[0]
        );

        // Axis 2: enabled and homed on the index (method 34) while axis 1 holds +2 rev.
        let hold = ramp(1000);
        for cw in [SHUTDOWN; 5]
            .into_iter()
            .chain([SWITCH_ON; 5])
            .chain([ENABLE_OPERATION; 30])
        {
            s = cycle(&m, md, &group, [ENABLE_OPERATION, cw], [hold, 0]).await;
        }
        assert_eq!(s.statusword[1] & STATE_MASK, OPERATION_ENABLED, "axis 2");
        let mut homed = false;
        for k in 0..5_000 {
            s = cycle(
                &m,
                md,
                &group,
                [ENABLE_OPERATION, ENABLE_OPERATION | NEW_SET_POINT],
                [hold, 0],
            )
            .await;
            if k > 5 && s.statusword[1] & HOMING_BITS == HOMING_DONE {
                homed = true;
                break;
            }
        }
        assert!(homed, "axis 2 homing completed: {:#06x}", s.statusword[1]);
        for _ in 0..50 {
            s = cycle(
                &m,
                md,
                &group,
                [ENABLE_OPERATION, ENABLE_OPERATION],
                [hold, 0],
            )
            .await;
        }
        // The index is the single-turn zero: the first one ahead of the start (0 rev) is 1 rev
        // (or 0 itself); 6864h reads the home offset 687Ch = 0 there.
        let home = s.revolutions[1];
        assert!(
            (home - home.round()).abs() < 1e-3 && home.round() >= 0.0,
            "home at {home} rev"
        );
        let off = (home - home.round()) * CPR;
        assert!(
            (f64::from(s.position[1]) - off).abs() < 60.0,
            "6864h {} at the home",
            s.position[1]
        );
        assert!(
            (s.revolutions[0] - 2.0).abs() < 1e-3,
            "axis 1 held: {}",
            s.revolutions[0]
        );

        // Axis 2 switches to profile position (6860h by SDO) and moves to −3 rev absolute.
        group
            .subdevice(md, 0)
            .expect("drive")
            .sdo_write(0x6060 + AXIS_2, 0, PP)
            .await
            .expect("6860h = PP");
        let target = (-3.0 * CPR) as i32;
        for _ in 0..3 {
            cycle(
                &m,
                md,
                &group,
                [ENABLE_OPERATION, ENABLE_OPERATION | NEW_SET_POINT],
                [hold, target],
            )
            .await;
        }
        for _ in 0..1_500 {
            s = cycle(
                &m,
                md,
                &group,
                [ENABLE_OPERATION, ENABLE_OPERATION],
                [hold, target],
            )
            .await;
        }
        let moved = home.round() - 3.0;
        assert!(
            (s.revolutions[1] - moved).abs() < 1e-3,
            "axis 2 at {} rev, expected {moved}",
            s.revolutions[1]
        );
        assert!(
            (f64::from(s.position[1]) - f64::from(target)).abs() < 60.0,
            "6864h {}",
            s.position[1]
        );
        assert_ne!(s.statusword[1] & TARGET_REACHED, 0, "axis 2 target reached");
        assert!(
            (s.revolutions[0] - 2.0).abs() < 1e-3,
            "axis 1 held: {}",
            s.revolutions[0]
        );

        // Each axis shows its own mode of operation.
        let sd = group.subdevice(md, 0).expect("drive");
        assert_eq!(sd.sdo_read::<i8>(0x6061, 0).await.expect("6061h"), CSP);
        assert_eq!(
            sd.sdo_read::<i8>(0x6061 + AXIS_2, 0).await.expect("6861h"),
            PP
        );
    });
}

#[test]
fn sigma_v_sd_2axis_a_fault_of_axis_2_is_its_own() {
    let sm1_start = sm1_start();
    block_on(async {
        let (m, transport) = master_for(Segment::new("sigma-v-sd-2axis", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = into_op(&m, md, CSP, CSP).await;
        let mut s = enable_both(&m, md, &group).await;

        m.shared.segment().drives_mut()[0].servos[1]
            .plant
            .set_drive_temperature(HOT_C);
        let mut faulted = false;
        for _ in 0..300 {
            s = cycle(&m, md, &group, [ENABLE_OPERATION; 2], [0, 0]).await;
            if s.statusword[1] & FAULT_BIT != 0 {
                faulted = true;
                break;
            }
        }
        assert!(faulted, "axis 2 faults");
        assert_eq!(
            s.statusword[0] & STATE_MASK,
            OPERATION_ENABLED,
            "axis 1 runs on"
        );
        let coe = emergency(&m, md, &group, [ENABLE_OPERATION; 2], [0, 0], sm1_start).await;
        // §2.7: code FF00h always, the error's code in bytes 4-5.
        assert_eq!(u16::from_le_bytes([coe[2], coe[3]]), 0xFF00, "EMCY code");
        assert_eq!(
            u16::from_le_bytes([coe[6], coe[7]]),
            DRIVE_OVER_TEMPERATURE,
            "EMCY bytes 4-5"
        );
        assert_eq!(coe[4], 0x01, "1001h: generic error only (§4.2)");
        assert_eq!(coe[9], 2, "§2.7: byte 7 = axis number 2");
        let sd = group.subdevice(md, 0).expect("drive");
        assert_eq!(
            sd.sdo_read::<u16>(0x603F + AXIS_2, 0).await.expect("683Fh"),
            DRIVE_OVER_TEMPERATURE
        );
        assert_eq!(
            sd.sdo_read::<u16>(0x603F, 0).await.expect("603Fh"),
            0,
            "axis 1 has no error"
        );

        // Cooled down, a fault reset on axis 2 (bit 7 rising) clears it; axis 1 never stopped.
        m.shared.segment().drives_mut()[0].servos[1]
            .plant
            .set_drive_temperature(40.0);
        for cw in [0x80u16; 3]
            .into_iter()
            .chain([SHUTDOWN; 5])
            .chain([SWITCH_ON; 5])
            .chain([ENABLE_OPERATION; 30])
        {
            s = cycle(&m, md, &group, [ENABLE_OPERATION, cw], [0, 0]).await;
        }
        assert_eq!(s.statusword.map(|w| w & STATE_MASK), [OPERATION_ENABLED; 2]);
        let sd = group.subdevice(md, 0).expect("drive");
        assert_eq!(
            sd.sdo_read::<u16>(0x603F + AXIS_2, 0).await.expect("683Fh"),
            0
        );
        assert_eq!(
            sd.sdo_read::<u8>(0x1001, 0).await.expect("1001h"),
            0,
            "no error left"
        );
    });
}

/// Both axes follow their own CSP streams at the same time (axis 1 out to +2 rev while axis 2
/// goes to −3 rev); then axis 1's power stage overheats while axis 2 moves back to 0: axis 1
/// faults with its own 603Fh and an EMCY for axis 1 (§2.7 byte 7 = 1), and axis 2's motion
/// goes on undisturbed to its target.
#[test]
fn sigma_v_sd_2axis_both_axes_move_at_once_and_a_fault_of_axis_1_leaves_axis_2_running() {
    let sm1_start = sm1_start();
    block_on(async {
        let (m, transport) = master_for(Segment::new("sigma-v-sd-2axis", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = into_op(&m, md, CSP, CSP).await;
        let mut s = enable_both(&m, md, &group).await;

        // Ramps over 1 s: +2 rev and −3 rev, halfway and at the end both where commanded.
        let ramp = |to: f64, k: i64| ((to * CPR) as i64 * k.min(1000) / 1000) as i32;
        for k in 0..=1200 {
            s = cycle(
                &m,
                md,
                &group,
                [ENABLE_OPERATION; 2],
                [ramp(2.0, k), ramp(-3.0, k)],
            )
            .await;
            if k == 500 {
                // One cycle of lag at most: 2 rev/s and 3 rev/s are 2 and 3 mrev per ms.
                assert!((s.revolutions[0] - 1.0).abs() < 5e-3, "{:?}", s.revolutions);
                assert!((s.revolutions[1] + 1.5).abs() < 5e-3, "{:?}", s.revolutions);
            }
        }
        assert!((s.revolutions[0] - 2.0).abs() < 1e-3, "{:?}", s.revolutions);
        assert!((s.revolutions[1] + 3.0).abs() < 1e-3, "{:?}", s.revolutions);

        // Axis 1 overheats while axis 2 ramps back to 0.
        m.shared.segment().drives_mut()[0].servos[0]
            .plant
            .set_drive_temperature(HOT_C);
        let back = |k: i64| ((-3.0 * CPR) as i64 * (1000 - k.min(1000)) / 1000) as i32;
        let mut faulted_at = None;
        for k in 0..=1200 {
            s = cycle(
                &m,
                md,
                &group,
                [ENABLE_OPERATION; 2],
                [ramp(2.0, 1000), back(k)],
            )
            .await;
            if faulted_at.is_none() && s.statusword[0] & FAULT_BIT != 0 {
                faulted_at = Some(k);
            }
            assert_eq!(
                s.statusword[1] & STATE_MASK,
                OPERATION_ENABLED,
                "axis 2 runs on (cycle {k})"
            );
        }
        assert!(faulted_at.is_some(), "axis 1 faults");
        assert!(
            s.revolutions[1].abs() < 1e-3,
            "axis 2 at 0: {:?}",
            s.revolutions
        );
        let coe = emergency(&m, md, &group, [ENABLE_OPERATION; 2], [0, 0], sm1_start).await;
        assert_eq!(u16::from_le_bytes([coe[2], coe[3]]), 0xFF00, "§2.7: FF00h");
        assert_eq!(u16::from_le_bytes([coe[6], coe[7]]), DRIVE_OVER_TEMPERATURE);
        assert_eq!(coe[9], 1, "§2.7: byte 7 = axis number 1");
        let sd = group.subdevice(md, 0).expect("drive");
        assert_eq!(
            sd.sdo_read::<u16>(0x603F, 0).await.expect("603Fh"),
            DRIVE_OVER_TEMPERATURE
        );
        assert_eq!(
            sd.sdo_read::<u16>(0x603F + AXIS_2, 0).await.expect("683Fh"),
            0,
            "axis 2 has no error"
        );
    });
}
