//! Long sequences of relative moves do not drift where a position unit is not a whole number of
//! encoder increments: the GHA-E's default gear ratio 6091h = 131072 / 10000 (§5, "6064h =
//! 6063h / (6091h:01 / 6091h:02)") makes one instruction unit 13.1072 increments.
//!
//! Ethercrab (DC SYNC0 at 1 ms; 6040h, 6060h, 607Ah / 6041h, 6061h, 6064h mapped) gives the
//! drive a hundred relative profile-position set-points (controlword bit 6, CiA402 polarity on
//! the GHA-E) of the same odd distance, each after the previous one is reached. Every target
//! adds to the previous target in user units (IEC 61800-7-201 profile position, relative), so
//! the position demand 6062h ends exactly a hundred steps on, and the motor within a few
//! increments of the same distance converted once: a conversion per move that rounded to whole
//! increments would have lost 0.384 increments per move, 38 over the run.

use std::f64::consts::TAU;

use board_sim::inproc::InProcess;
use ethercrab::MainDevice;
use tests_host::vendor::{self, DcGroup, MappedEntry, Sdo};
use tests_host::{block_on, cia402, master_for, units};

const CYCLE_NS: u64 = 1_000_000;
const PP: i8 = 1;
const NEW_SET_POINT: u16 = 1 << 4;
const RELATIVE: u16 = 1 << 6;
const SET_POINT_ACKNOWLEDGE: u16 = 1 << 12;
const OUTPUTS: [MappedEntry; 3] = [(0x6040, 0, 16), (0x6060, 0, 8), (0x607A, 0, 32)];
const INPUTS: [MappedEntry; 3] = [(0x6041, 0, 16), (0x6061, 0, 8), (0x6064, 0, 32)];
/// One move, instruction units: 161 808.384 increments at 13.1072 per unit.
const STEP: i32 = 12_345;
const MOVES: i32 = 100;
/// Profile velocity and acceleration of the moves.
const SPEED_REV_S: f64 = 5.0;
const ACCELERATION_REV_S2: f64 = 100.0;
/// The motor at rest on the last target: the position loop's error, increments.
const AT_REST_INC: f64 = 3.0;

/// One cycle: (cw, PP, 607Ah) out; the statusword and the rotor (rev) back.
async fn cycle(m: &InProcess, md: &MainDevice<'_>, group: &DcGroup, cw: u16) -> (u16, f64) {
    let inputs = vendor::exchange_dc_command(m, md, group, (cw, PP, STEP), CYCLE_NS).await;
    let rev = m.shared.segment().drives()[0].servos[0]
        .plant
        .mech_angle_rad()
        / TAU;
    (vendor::u16_at(&inputs, 0), rev)
}

#[test]
fn gha_e_relative_moves_do_not_drift_on_a_fractional_gear_ratio() {
    let profile = od_gen::builtin("gha-e").expect("profile");
    let per_unit = units::increments_per_unit(&profile);
    assert!(
        (per_unit - 13.1072).abs() < 1e-9,
        "the default 6091h: {per_unit}"
    );
    block_on(async {
        let (m, transport) = master_for(board_sim::Segment::new("gha-e", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let mut setup = vendor::remap(0x1600, 0x1C12, &OUTPUTS);
        setup.extend(vendor::remap(0x1A00, 0x1C13, &INPUTS));
        let speed = units::velocity(&profile, SPEED_REV_S);
        let acceleration = units::acceleration(&profile, ACCELERATION_REV_S2);
        setup.extend([
            Sdo::U32(0x607F, 0, 2 * speed),
            Sdo::U32(0x6081, 0, speed),
            Sdo::U32(0x6083, 0, acceleration),
            Sdo::U32(0x6084, 0, acceleration),
        ]);
        let group = vendor::into_op_dc(&m, md, &setup, CYCLE_NS).await;
        for _ in 0..vendor::SYNC0_START_CYCLES {
            cycle(&m, md, &group, 0).await;
        }
        let mut s = (0, 0.0);
        for cw in vendor::enable_sequence(20) {
            s = cycle(&m, md, &group, cw).await;
        }
        assert!(cia402::is(s.0, cia402::OPERATION_ENABLED), "{:#06x}", s.0);
        let sd = group.subdevice(md, 0).expect("drive");
        let demand_before: i32 = sd.sdo_read(0x6062, 0).await.expect("6062h");
        let rev_before = s.1;
        let moving = vendor::ENABLE_OPERATION | RELATIVE;
        for n in 1..=MOVES {
            // The handshake: bit 4 until bit 12, then bit 4 down.
            let mut acknowledged = false;
            for _ in 0..20 {
                s = cycle(&m, md, &group, moving | NEW_SET_POINT).await;
                if s.0 & SET_POINT_ACKNOWLEDGE != 0 {
                    acknowledged = true;
                    break;
                }
            }
            assert!(acknowledged, "move {n}: not acknowledged ({:#06x})", s.0);
            let mut reached = false;
            for _ in 0..1_000 {
                s = cycle(&m, md, &group, moving).await;
                if s.0 & cia402::TARGET_REACHED != 0 && s.0 & SET_POINT_ACKNOWLEDGE == 0 {
                    reached = true;
                    break;
                }
            }
            assert!(reached, "move {n}: target not reached ({:#06x})", s.0);
        }
        for _ in 0..50 {
            s = cycle(&m, md, &group, moving).await;
        }
        let demand: i32 = sd.sdo_read(0x6062, 0).await.expect("6062h");
        assert_eq!(
            demand - demand_before,
            STEP * MOVES,
            "6062h: each target adds to the previous one in instruction units"
        );
        let moved_inc = (s.1 - rev_before) * units::COUNTS_PER_REV;
        let expected_inc = f64::from(STEP * MOVES) * per_unit;
        assert!(
            (moved_inc - expected_inc).abs() <= AT_REST_INC,
            "the motor moved {moved_inc:.1} increments, {expected_inc:.1} expected"
        );
    });
}
