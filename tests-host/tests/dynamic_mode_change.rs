//! A mode change into profile position or homing with controlword bit 4 already set,
//! end to end (ethercrab, DC SYNC0 at 1 ms; 1600h: 6040h, 6060h, 607Ah; 1A00h: 6041h, 6064h):
//! the drive runs profile velocity at rest with controlword 0x1F, then the master selects the
//! new mode in the same frame as before.
//!
//! - CiA402 (the standard profile, the GHA-E, the RSE, the SDV3-E): a set-point or a homing run
//!   starts on a rising edge of bit 4, so the level carried into the mode starts nothing; the
//!   next edge does.
//! - The Σ-V-SD (§3.2 "Dynamic Mode Change"): "Profile Position mode: Controlword bit4 = 1: New
//!   positioning will be started immediately", "Homing mode: ... Homing will be started
//!   immediately".

use board_sim::Segment;
use ethercrab::MainDevice;
use tests_host::vendor::{self, DcDrive, Sdo, POSITION_MAPPING};
use tests_host::{block_on, cia402, master_for, units};

const CYCLE_NS: u64 = 1_000_000;
const PP: i8 = 1;
const PV: i8 = 3;
const HOMING: i8 = cia402::HOMING;
/// 6098h: the current position is the home.
const HOME_HERE: i8 = 35;
/// Enable operation with bit 4 (new set-point / homing start).
const ENABLE_BIT4: u16 = vendor::ENABLE_OPERATION | cia402::HOMING_START;
/// The profile-position move: a turn at 2 rev/s, 20 rev/s² ramps.
const MOVE_REV: f64 = 1.0;
const SPEED_REV_S: f64 = 2.0;
const RAMP_REV_S2: f64 = 20.0;
/// Long enough for the move (0.6 s) and the settling.
const MOVE_CYCLES: usize = 1_500;
/// How close to its target the motor ends, rev.
const AT_TARGET_REV: f64 = 0.01;

struct Drive<'a> {
    bus: DcDrive<'a>,
    units_per_rev: f64,
}

impl Drive<'_> {
    /// `n` cycles of (cw, mode, 607Ah); the last statusword and 6064h in rev.
    async fn hold(&self, command: (u16, i8, i32), n: usize) -> (u16, f64) {
        let inputs = self.bus.hold(command, n).await;
        (
            vendor::u16_at(&inputs, 0),
            f64::from(vendor::i32_at(&inputs, 2)) / self.units_per_rev,
        )
    }
}

/// What happened after the mode change with bit 4 set, and after a new edge of bit 4.
#[derive(Clone, Copy, Debug)]
struct Outcome {
    /// The position after the change, rev (the move's target is [`MOVE_REV`]).
    after_change_rev: f64,
    /// Homing: statusword bits 13/12/10 after the change.
    homing_after_change: u16,
    /// The position after a new edge of bit 4, rev.
    after_edge_rev: f64,
}

/// PV at rest with 0x1F, then PP with 607Ah = one turn (absolute; CiA402 bit 6 = 0, the
/// SDV3-E's bit 6 = 1), then a new edge; and the same into homing method 35.
fn change(name: &str) -> Outcome {
    let profile = od_gen::builtin(name).expect("profile");
    let units_per_rev = units::COUNTS_PER_REV / units::increments_per_unit(&profile);
    // Where bit 6 set means absolute (the SDV3-E, §7.4), the set-points carry it.
    let absolute = if name == "sdv3-e" { 1 << 6 } else { 0 };
    block_on(async {
        let (m, transport) = master_for(Segment::new(name, 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let mut sdos = vendor::mapping(&POSITION_MAPPING.0, &POSITION_MAPPING.1);
        let ramp = units::acceleration(&profile, RAMP_REV_S2);
        sdos.extend([
            Sdo::U32(0x6081, 0, units::velocity(&profile, SPEED_REV_S)),
            Sdo::U32(0x607F, 0, units::velocity(&profile, 2.0 * SPEED_REV_S)),
            Sdo::U32(0x6083, 0, ramp),
            Sdo::U32(0x6084, 0, ramp),
            Sdo::I8(0x6098, 0, HOME_HERE),
        ]);
        let group = vendor::into_op_dc(&m, md, &sdos, CYCLE_NS).await;
        let d = Drive {
            bus: DcDrive {
                m: &m,
                md,
                group,
                cycle_ns: CYCLE_NS,
            },
            units_per_rev,
        };
        d.hold((0, PV, 0), vendor::SYNC0_START_CYCLES).await;
        for cw in vendor::enable_sequence(20) {
            d.hold((cw | absolute, PV, 0), 1).await;
        }
        let (sw, start) = d.hold((ENABLE_BIT4 | absolute, PV, 0), 20).await;
        assert!(
            cia402::is(sw, cia402::OPERATION_ENABLED),
            "{name}: {sw:#06x}"
        );
        assert!(start.abs() < AT_TARGET_REV, "{name}: at rest at 0: {start}");
        let target = (MOVE_REV * units_per_rev).round() as i32;
        // Into PP with bit 4 held.
        let (_, after_change_rev) = d
            .hold((ENABLE_BIT4 | absolute, PP, target), MOVE_CYCLES)
            .await;
        // A new edge.
        d.hold((vendor::ENABLE_OPERATION | absolute, PP, target), 5)
            .await;
        let (_, after_edge_rev) = d
            .hold((ENABLE_BIT4 | absolute, PP, target), MOVE_CYCLES)
            .await;
        // Back to PV, then into homing with bit 4 held.
        d.hold((ENABLE_BIT4 | absolute, PV, 0), 20).await;
        let (sw, _) = d.hold((ENABLE_BIT4 | absolute, HOMING, 0), 10).await;
        Outcome {
            after_change_rev,
            homing_after_change: sw & cia402::HOMING_BITS,
            after_edge_rev,
        }
    })
}

#[test]
fn cia402_profiles_wait_for_a_new_edge_of_bit_4_after_a_mode_change() {
    for name in ["standard", "gha-e", "rse", "sdv3-e"] {
        let o = change(name);
        assert!(
            o.after_change_rev.abs() < AT_TARGET_REV,
            "{name}: PP started without an edge: {o:?}"
        );
        assert!(
            (o.after_edge_rev - MOVE_REV).abs() < AT_TARGET_REV,
            "{name}: the edge moves: {o:?}"
        );
        assert_eq!(
            o.homing_after_change,
            cia402::TARGET_REACHED,
            "{name}: homing not started: {o:?}"
        );
    }
}

#[test]
fn sigma_v_sd_starts_positioning_and_homing_at_the_mode_change() {
    let o = change("sigma-v-sd");
    assert!(
        (o.after_change_rev - MOVE_REV).abs() < AT_TARGET_REV,
        "PP started at the change: {o:?}"
    );
    assert_eq!(
        o.homing_after_change & cia402::HOMING_ATTAINED,
        cia402::HOMING_ATTAINED,
        "homing started at the change: {o:?}"
    );
}
