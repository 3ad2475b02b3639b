//! A cycle whose frame the master lost: the SYNC0 comes, no new outputs do (the SM2 buffer
//! holds the previous target). Cyclic synchronous position, ethercrab, DC SYNC0 at 1 ms
//! (1600h: 6040h, 6060h, 607Ah; 1A00h: 6041h, 6062h), a ramp of the target:
//!
//! - the SDV3-E with P4.04 = 1 (its default, §2.4 "update the position command with the last
//!   interpolation data increment value"): the position demand 6062h of the lost cycle is the
//!   last target plus the last step, and the ramp goes on from the next frame;
//! - the standard profile (CiA402 states nothing): the last target holds for that cycle.

use board_sim::Segment;
use ethercrab::MainDevice;
use tests_host::vendor::{self, enable_sequence, i32_at, u16_at, ENABLE_OPERATION};
use tests_host::{block_on, master_for};

const CYCLE_NS: u64 = 1_000_000;
const STATE_MASK: u16 = 0x6F;
const OPERATION_ENABLED: u16 = 0x27;
/// 6060h: cyclic synchronous position.
const CSP: i8 = 8;
/// Image layouts (byte offsets).
const TX_SW: usize = 0;
const TX_DEMAND: usize = 2;
/// The ramp: position units per cycle.
const STEP: i32 = 200;

/// The position demand 6062h of the cycle in which the master's frame was lost, and the last
/// target before it.
fn demand_of_a_lost_cycle(profile: &str) -> (i32, i32) {
    block_on(async {
        let (m, transport) = master_for(Segment::new(profile, 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let outputs = [(0x6040, 0, 16), (0x6060, 0, 8), (0x607A, 0, 32)];
        let inputs = [(0x6041, 0, 16), (0x6062, 0, 32)];
        let group = vendor::into_op_dc_mapped(&m, md, (&outputs, &inputs), CYCLE_NS).await;
        let sd = group.subdevice(md, 0).expect("drive");
        let start: i32 = sd.sdo_read(0x6064, 0).await.expect("6064h");
        let cycle = |cw: u16, target: i32| {
            let (m, group) = (&m, &group);
            async move {
                let inputs =
                    vendor::exchange_dc_command(m, md, group, (cw, CSP, target), CYCLE_NS).await;
                (u16_at(&inputs, TX_SW), i32_at(&inputs, TX_DEMAND))
            }
        };
        let mut sw = 0;
        for cw in std::iter::repeat_n(0u16, 40).chain(enable_sequence(30)) {
            (sw, _) = cycle(cw, start).await;
        }
        assert_eq!(sw & STATE_MASK, OPERATION_ENABLED, "{profile}: {sw:#06x}");
        // The ramp; each exchange returns the values of the SYNC0 before it.
        let mut target = start;
        for _ in 0..50 {
            target += STEP;
            cycle(ENABLE_OPERATION, target).await;
        }
        let last_target = target;
        // The frame of the next cycle is lost: its SYNC0 comes all the same.
        m.shared.advance(CYCLE_NS);
        target += STEP;
        // The next frame (the master's ramp went on) returns the lost cycle's values.
        target += STEP;
        let (sw, lost_demand) = cycle(ENABLE_OPERATION, target).await;
        assert_eq!(sw & STATE_MASK, OPERATION_ENABLED, "{profile}: {sw:#06x}");
        // And the ramp goes on from the master's targets.
        target += STEP;
        let (_, demand) = cycle(ENABLE_OPERATION, target).await;
        assert_eq!(
            demand,
            target - STEP,
            "{profile}: the master's target again"
        );
        (lost_demand, last_target)
    })
}

#[test]
fn sdv3_e_csp_goes_on_with_the_last_increment_over_a_lost_cycle() {
    let (demand, last_target) = demand_of_a_lost_cycle("sdv3-e");
    assert_eq!(demand, last_target + STEP, "P4.04 = 1: extrapolated");
}

#[test]
fn standard_csp_holds_the_last_target_over_a_lost_cycle() {
    let (demand, last_target) = demand_of_a_lost_cycle("standard");
    assert_eq!(demand, last_target, "held");
}
