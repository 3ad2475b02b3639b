//! Every mode of operation of every profile moves the simulated motor, commanded by ethercrab
//! over one PDO layout each drive accepts (1600h: 6040h, 6060h, 607Ah, 60FFh, 6071h; 1A00h:
//! 6041h, 6061h, 6064h, 606Ch, 6077h; every manual allows 1600h/1A00h to be remapped in PREOP)
//! with DC SYNC0 at 1 ms, in each profile's own units (its `[units]` with their defaults):
//!
//! - cyclic synchronous position: a ramp of one revolution, the motor follows;
//! - profile position: an absolute set-point two revolutions on (controlword bit 6 with the
//!   profile's polarity), acknowledged (bit 12), then target reached (bit 10) on the target;
//! - profile velocity and cyclic synchronous velocity: the motor turns at the target speed;
//! - cyclic synchronous torque and profile torque: a torque the motor accelerates with.
//!
//! The mode changes while the drive stays in Operation Enabled; 6061h shows each mode. The
//! two-axis Σ-V-SD runs the same on its second axis (its objects 6840h.., PDOs 1610h/1A10h),
//! the first axis left off. Homing is
//! covered per profile by `homing_methods.rs` (every method), `homing.rs`, `vendor_modes.rs`,
//! `two_axes.rs` and `motion_soem.rs`.

use board_sim::inproc::InProcess;
use board_sim::Segment;
use ethercrab::MainDevice;
use od_gen::model::Profile;
use tests_host::vendor::{
    self, axis_object, enable_sequence, i32_at, motor_of_axis, u16_at, Command, DcGroup as Group,
    Sdo, ENABLE_OPERATION,
};
use tests_host::{block_on, master_for, units};

const CYCLE_NS: u64 = 1_000_000;
/// Increments per revolution of the simulated servo's encoder.
const CPR: f64 = (1u32 << 20) as f64;
const STATE_MASK: u16 = 0x6F;
const OPERATION_ENABLED: u16 = 0x27;
const NEW_SET_POINT: u16 = 1 << 4;
const ABS_REL: u16 = 1 << 6;
const TARGET_REACHED: u16 = 1 << 10;
const SET_POINT_ACKNOWLEDGE: u16 = 1 << 12;
/// 6060h values (CiA402).
const PP: i8 = 1;
const PV: i8 = 3;
const PT: i8 = 4;
const CSP: i8 = 8;
const CSV: i8 = 9;
const CST: i8 = 10;
/// Motion of the scenario: rev/s, rev/s², ‰ of the rated torque.
const PROFILE_SPEED: f64 = 10.0;
const ACCELERATION: f64 = 100.0;
const TORQUE_PERMILLE: i16 = 50;

/// The process images' layout: the outputs [`vendor::COMMAND_OUTPUTS`], these inputs.
const TX: [(u16, u8); 5] = [
    (0x6041, 16),
    (0x6061, 8),
    (0x6064, 32),
    (0x606C, 32),
    (0x6077, 16),
];
const TX_SW: usize = 0;
const TX_MODE: usize = 2;
const TX_POSITION: usize = 3;

/// INIT → OP with DC SYNC0 at 1 ms, the layout of axis `axis` (0 = the first: its objects and
/// its PDOs 1600h/1A00h plus 10h per axis, assigned alone) mapped and its profile-mode objects
/// set.
async fn into_op(m: &InProcess, md: &MainDevice<'_>, p: &Profile, axis: usize) -> Group {
    let on_axis = |(index, sub, bits): (u16, u8, u8)| (axis_object(index, axis), sub, bits);
    let outputs: Vec<_> = vendor::COMMAND_OUTPUTS.into_iter().map(on_axis).collect();
    let inputs: Vec<_> = TX
        .iter()
        .map(|&(index, bits)| on_axis((index, 0, bits)))
        .collect();
    let pdo_offset = 0x10 * axis as u16;
    let mut setup = vendor::remap(0x1600 + pdo_offset, 0x1C12, &outputs);
    setup.extend(vendor::remap(0x1A00 + pdo_offset, 0x1C13, &inputs));
    let speed = units::velocity(p, PROFILE_SPEED);
    let accel = units::acceleration(p, ACCELERATION);
    for (index, value) in [
        (0x607F, 2 * speed),
        (0x6081, speed),
        (0x6083, accel),
        (0x6084, accel),
        (0x6087, 10_000),
    ] {
        // Only the objects the profile has (the SDV3-E has no 6087h).
        if p.entry(index, 0).is_some() {
            setup.push(Sdo::U32(axis_object(index, axis), 0, value));
        }
    }
    // A position window of 0 (the GHA-E's default) asks for the exact increment: 1/1000
    // revolution instead.
    let window = p.entry(0x6067, 0).map(|e| e.initial_bytes());
    if window.is_some_and(|b| b.iter().all(|x| *x == 0)) {
        let window = (CPR / 1000.0 / units::increments_per_unit(p)).ceil() as u32;
        setup.push(Sdo::U32(axis_object(0x6067, axis), 0, window));
    }
    vendor::into_op_dc(m, md, &setup, CYCLE_NS).await
}

/// What one cycle brought back: statusword, 6061h, 6064h, and the motor's speed (rpm) and
/// angle (revolutions).
#[derive(Clone, Copy, Debug)]
struct Sample {
    sw: u16,
    mode: i8,
    position: i32,
    rpm: f64,
    rev: f64,
}

/// The axis a scenario drives (0 = the first).
#[derive(Clone, Copy)]
struct Axis(usize);

async fn cycle(
    m: &InProcess,
    md: &MainDevice<'_>,
    (group, axis): (&Group, Axis),
    c: Command,
) -> Sample {
    let sd = group.subdevice(md, 0).expect("drive");
    sd.outputs_raw_mut()[..vendor::COMMAND_IMAGE_LEN].copy_from_slice(&c.image());
    group.tx_rx_dc(md).await.expect("tx/rx");
    m.shared.advance(CYCLE_NS);
    let inp = sd.inputs_raw();
    let (rpm, rev) = motor_of_axis(m, axis.0);
    Sample {
        sw: u16_at(&inp, TX_SW),
        mode: inp[TX_MODE] as i8,
        position: i32_at(&inp, TX_POSITION),
        rpm,
        rev,
    }
}

/// Runs `n` cycles of `c`; the last sample.
async fn run(
    m: &InProcess,
    md: &MainDevice<'_>,
    group: (&Group, Axis),
    c: Command,
    n: usize,
) -> Sample {
    let mut s = None;
    for _ in 0..n {
        s = Some(cycle(m, md, group, c).await);
    }
    s.expect("at least one cycle")
}

fn every_mode_moves_the_motor(name: &str) {
    every_mode_moves_the_motor_of_axis(name, 0);
}

fn every_mode_moves_the_motor_of_axis(name: &str, axis: usize) {
    let p = od_gen::builtin(name).expect("profile");
    let rpm_to_object = |rpm: f64| units::target_velocity(&p, rpm / 60.0);
    block_on(async {
        let (m, transport) = master_for(Segment::new(name, 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = into_op(&m, md, &p, axis).await;
        let group = (&group, Axis(axis));
        let mut s = cycle(&m, md, group, Command::default()).await;
        // The first SYNC0s after the request: hold the enable sequence long enough.
        for cw in std::iter::repeat_n(0u16, 40).chain(enable_sequence(30)) {
            let c = Command {
                cw,
                mode: CSP,
                position: s.position,
                ..Command::default()
            };
            s = cycle(&m, md, group, c).await;
        }
        assert_eq!(
            s.sw & STATE_MASK,
            OPERATION_ENABLED,
            "{name}: {:#06x}",
            s.sw
        );

        // CSP: one revolution in 500 ms.
        let (start, rev0) = (s.position, s.rev);
        let one_rev = (CPR / units::increments_per_unit(&p)) as i32;
        for k in 0..=600 {
            let c = Command {
                cw: ENABLE_OPERATION,
                mode: CSP,
                position: start + one_rev * k.min(500) / 500,
                ..Command::default()
            };
            s = cycle(&m, md, group, c).await;
        }
        assert_eq!(s.mode, CSP, "{name}: 6061h");
        assert!(
            (s.rev - rev0 - 1.0).abs() < 2e-3,
            "{name} CSP: {} rev",
            s.rev - rev0
        );

        // PP: two revolutions on, absolute.
        let (from, rev0) = (s.position, s.rev);
        let target = from + 2 * one_rev;
        let absolute = if p.cia402.pp_bit6_absolute {
            ABS_REL
        } else {
            0
        };
        let pp = |cw| Command {
            cw: ENABLE_OPERATION | absolute | cw,
            mode: PP,
            position: target,
            ..Command::default()
        };
        let mut acknowledged = false;
        for _ in 0..10 {
            s = cycle(&m, md, group, pp(NEW_SET_POINT)).await;
            acknowledged |= s.sw & SET_POINT_ACKNOWLEDGE != 0;
        }
        assert!(acknowledged, "{name} PP: bit 12");
        let mut reached = None;
        for k in 0..2_000 {
            s = cycle(&m, md, group, pp(0)).await;
            if k > 20 && s.sw & TARGET_REACHED != 0 {
                reached = Some(k);
                break;
            }
        }
        s = run(&m, md, group, pp(0), 50).await;
        assert_eq!(s.mode, PP, "{name}: 6061h");
        assert!(reached.is_some(), "{name} PP: bit 10: {:#06x}", s.sw);
        assert!(
            (s.rev - rev0 - 2.0).abs() < 2e-3,
            "{name} PP: {} rev",
            s.rev - rev0
        );

        // PV 300 rpm, then CSV 600 rpm.
        let pv = Command {
            cw: ENABLE_OPERATION,
            mode: PV,
            velocity: rpm_to_object(300.0),
            ..Command::default()
        };
        s = run(&m, md, group, pv, 600).await;
        assert_eq!(s.mode, PV, "{name}: 6061h");
        assert!((s.rpm - 300.0).abs() < 10.0, "{name} PV: {:.0} rpm", s.rpm);
        let csv = Command {
            mode: CSV,
            velocity: rpm_to_object(600.0),
            ..pv
        };
        for k in 0..=400 {
            let ramp = 300.0 + 300.0 * f64::from(k.min(200)) / 200.0;
            let c = Command {
                velocity: rpm_to_object(ramp),
                ..csv
            };
            s = cycle(&m, md, group, c).await;
        }
        assert_eq!(s.mode, CSV, "{name}: 6061h");
        assert!((s.rpm - 600.0).abs() < 10.0, "{name} CSV: {:.0} rpm", s.rpm);
        // Back to rest in CSV.
        for k in 0..=400 {
            let ramp = 600.0 * (1.0 - f64::from(k.min(300)) / 300.0);
            let c = Command {
                velocity: rpm_to_object(ramp),
                ..csv
            };
            s = cycle(&m, md, group, c).await;
        }
        assert!(s.rpm.abs() < 10.0, "{name}: at rest, {:.0} rpm", s.rpm);

        // CST and PT: 5 % of the rated torque accelerates the free motor.
        for mode in [CST, PT] {
            let torque = Command {
                cw: ENABLE_OPERATION,
                mode,
                torque: TORQUE_PERMILLE,
                ..Command::default()
            };
            let before = s.rpm;
            s = run(&m, md, group, torque, 100).await;
            assert_eq!(s.mode, mode, "{name}: 6061h");
            assert!(
                s.rpm > before + 100.0,
                "{name} mode {mode}: {:.0} rpm",
                s.rpm
            );
            // Stop again in CSV.
            let top = s.rpm.max(0.0);
            for k in 0..=600 {
                let ramp = top * (1.0 - f64::from(k.min(500)) / 500.0);
                let c = Command {
                    velocity: rpm_to_object(ramp),
                    ..csv
                };
                s = cycle(&m, md, group, c).await;
            }
            assert!(s.rpm.abs() < 10.0, "{name}: at rest, {:.0} rpm", s.rpm);
        }
        assert_eq!(
            s.sw & STATE_MASK,
            OPERATION_ENABLED,
            "{name}: {:#06x}",
            s.sw
        );
    });
}

#[test]
fn standard_every_mode_moves_the_motor() {
    every_mode_moves_the_motor("standard");
}

#[test]
fn sdv3_e_every_mode_moves_the_motor() {
    every_mode_moves_the_motor("sdv3-e");
}

#[test]
fn osd_g_e_every_mode_moves_the_motor() {
    every_mode_moves_the_motor("osd-g-e");
}

#[test]
fn rse_every_mode_moves_the_motor() {
    every_mode_moves_the_motor("rse");
}

#[test]
fn gha_e_every_mode_moves_the_motor() {
    every_mode_moves_the_motor("gha-e");
}

#[test]
fn sigma_v_sd_every_mode_moves_the_motor() {
    every_mode_moves_the_motor("sigma-v-sd");
}

#[test]
fn sigma_v_sd_2axis_every_mode_moves_the_second_motor() {
    every_mode_moves_the_motor_of_axis("sigma-v-sd-2axis", 1);
}
