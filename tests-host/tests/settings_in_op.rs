//! Settings written while the drive runs take effect at once: the drive keeps its settings
//! (limits, ramps, windows) in drive units and reads them again when their objects are written,
//! by an SDO download (before the next cycle) or, where the master maps them into its RxPDO, in
//! the cycle the RxPDO changes one (the slave's plan compares the mapped settings as it copies
//! them). (`limits.rs`, `profile_modes.rs` and `stop_reactions.rs` also change settings
//! by SDO in OP.)
//!
//! Standard profile, ethercrab, DC SYNC0 at 1 ms:
//! - the RxPDO 1600h carries 6040h, 6060h, 60FFh and the max profile velocity 607Fh, the TxPDO
//!   1A00h 6041h and 606Ch. In profile velocity the target velocity 60FFh (1500 rpm) is above
//!   607Fh, so the motor runs at 607Fh (CiA402: 607Fh limits the profile velocity): each new
//!   607Fh value the master streams is the new speed;
//! - the profile velocity 6081h written by SDO in OP is the speed of the very next
//!   profile-position set-point.

use board_sim::Segment;
use ethercrab::MainDevice;
use tests_host::vendor::{self, enable_sequence, i32_at, motor, u16_at, ENABLE_OPERATION};
use tests_host::{block_on, master_for};

const CYCLE_NS: u64 = 1_000_000;
/// Increments per revolution of the simulated servo's encoder (the standard profile's position
/// unit is the increment, its velocity unit increments/s).
const CPR: f64 = (1u32 << 20) as f64;
const STATE_MASK: u16 = 0x6F;
const OPERATION_ENABLED: u16 = 0x27;
/// 6060h: profile velocity.
const PV: i8 = 3;

/// 6060h: profile position.
const PP: i8 = 1;
/// Controlword bit 4: new set-point.
const NEW_SET_POINT: u16 = 1 << 4;

/// RxPDO layout (byte offsets): 6040h, 6060h, 60FFh, 607Fh.
const RX_CW: usize = 0;
const RX_MODE: usize = 2;
const RX_TARGET_VELOCITY: usize = 3;
const RX_MAX_PROFILE_VELOCITY: usize = 7;
/// TxPDO layout: 6041h, 606Ch.
const TX_SW: usize = 0;
const TX_VELOCITY: usize = 2;

fn increments_per_s(rpm: f64) -> i32 {
    (rpm / 60.0 * CPR) as i32
}

/// One cycle's outputs: controlword, 60FFh and 607Fh in rpm.
async fn cycle(
    m: &board_sim::inproc::InProcess,
    md: &MainDevice<'_>,
    group: &vendor::DcGroup,
    cw: u16,
    (target_rpm, max_rpm): (f64, f64),
) -> (u16, i32) {
    let cw = cw.to_le_bytes();
    let target = increments_per_s(target_rpm).to_le_bytes();
    let max = increments_per_s(max_rpm).to_le_bytes();
    let inputs = vendor::exchange_dc(
        m,
        md,
        group,
        &[
            (RX_CW, &cw),
            (RX_MODE, &[PV as u8]),
            (RX_TARGET_VELOCITY, &target),
            (RX_MAX_PROFILE_VELOCITY, &max),
        ],
        CYCLE_NS,
    )
    .await;
    (u16_at(&inputs, TX_SW), i32_at(&inputs, TX_VELOCITY))
}

#[test]
fn standard_a_mapped_max_profile_velocity_limits_each_cycle() {
    block_on(async {
        let (m, transport) = master_for(Segment::new("standard", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let outputs = [
            (0x6040, 0, 16),
            (0x6060, 0, 8),
            (0x60FF, 0, 32),
            (0x607F, 0, 32),
        ];
        let inputs = [(0x6041, 0, 16), (0x606C, 0, 32)];
        let group = vendor::into_op_dc_mapped(&m, md, (&outputs, &inputs), CYCLE_NS).await;
        let mut sw = 0;
        for cw in std::iter::repeat_n(0u16, 40).chain(enable_sequence(30)) {
            (sw, _) = cycle(&m, md, &group, cw, (0.0, 500.0)).await;
        }
        assert_eq!(sw & STATE_MASK, OPERATION_ENABLED, "{sw:#06x}");

        // 60FFh = 1500 rpm under 607Fh = 500, then 1000, then 300 rpm, streamed by PDO: the
        // motor settles at each (the standard profile's 6083h/6084h reach 3000 rpm in 0.5 s).
        for max_rpm in [500.0, 1000.0, 300.0] {
            let mut actual = 0;
            for _ in 0..400 {
                (sw, actual) = cycle(&m, md, &group, ENABLE_OPERATION, (1500.0, max_rpm)).await;
            }
            assert_eq!(sw & STATE_MASK, OPERATION_ENABLED, "{sw:#06x}");
            let actual_rpm = f64::from(actual) / CPR * 60.0;
            let (motor_rpm, _) = motor(&m);
            for rpm in [actual_rpm, motor_rpm] {
                assert!(
                    (rpm - max_rpm).abs() < 0.02 * max_rpm,
                    "607Fh = {max_rpm} rpm: 606Ch {actual_rpm:.1} rpm, motor {motor_rpm:.1} rpm"
                );
            }
        }
    });
}

#[test]
fn standard_profile_velocity_by_sdo_in_op_is_the_speed_of_the_next_set_point() {
    block_on(async {
        let (m, transport) = master_for(Segment::new("standard", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        // 1600h: 6040h, 6060h, 607Ah; 1A00h: 6041h, 606Ch.
        let outputs = [(0x6040, 0, 16), (0x6060, 0, 8), (0x607A, 0, 32)];
        let inputs = [(0x6041, 0, 16), (0x606C, 0, 32)];
        let group = vendor::into_op_dc_mapped(&m, md, (&outputs, &inputs), CYCLE_NS).await;
        let sd = group.subdevice(md, 0).expect("drive");
        let pp_cycle = |cw: u16, target: i32| {
            let (m, group) = (&m, &group);
            async move {
                let inputs =
                    vendor::exchange_dc_command(m, md, group, (cw, PP, target), CYCLE_NS).await;
                (u16_at(&inputs, TX_SW), i32_at(&inputs, TX_VELOCITY))
            }
        };
        let mut sw = 0;
        for cw in std::iter::repeat_n(0u16, 40).chain(enable_sequence(30)) {
            (sw, _) = pp_cycle(cw, 0).await;
        }
        assert_eq!(sw & STATE_MASK, OPERATION_ENABLED, "{sw:#06x}");
        let start: i32 = sd.sdo_read(0x6064, 0).await.expect("6064h");

        // 300 rpm instead of the default 1000, written in OP; the set-point follows at once.
        let slow = increments_per_s(300.0);
        sd.sdo_write(0x6081, 0, slow as u32).await.expect("6081h");
        let target = start + 5 * CPR as i32;
        let mut fastest: i32 = 0;
        for k in 0..1500 {
            let cw = if k < 5 {
                ENABLE_OPERATION | NEW_SET_POINT
            } else {
                ENABLE_OPERATION
            };
            let (sw, velocity) = pp_cycle(cw, target).await;
            assert_eq!(sw & STATE_MASK, OPERATION_ENABLED, "{sw:#06x}");
            fastest = fastest.max(velocity);
        }
        let fastest_rpm = f64::from(fastest) / CPR * 60.0;
        assert!(
            (fastest_rpm - 300.0).abs() < 6.0,
            "the move ran at {fastest_rpm:.1} rpm, 6081h says 300"
        );
        let (motor_rpm, rev) = motor(&m);
        assert!(
            motor_rpm.abs() < 5.0,
            "at rest after the move: {motor_rpm:.1} rpm"
        );
        let moved = rev * CPR - f64::from(start);
        assert!(
            (moved - 5.0 * CPR).abs() < 0.01 * CPR,
            "moved {:.3} revolutions of 5",
            moved / CPR
        );
    });
}
