//! Interpolated position mode (6060h = 7, CiA402 §13 / IEC 61800-7-201) on every profile that
//! lists it in 6502h (the standard profile and the Σ-V-SD, §3.3.2, §4.11), commanded by ethercrab
//! in DC at 1 ms over 1600h = [6040h, 60C1h:01]:
//!
//! - in a DC mode the drive shows the SYNC0 cycle in 60C2h (1 ms = 100 × 10^-5 s);
//! - with controlword bit 4 "enable ip mode" set the motor follows the absolute set-points
//!   60C1h:01, interpolated over the period, and statusword bit 12 "ip mode active" is set;
//! - bit 10 "target reached" once the set-point stops changing and the motor is inside 6067h;
//! - with bit 4 clear a set-point is not taken, the motor holds and bit 12 clears (Σ-V-SD §4.7
//!   (2)/(3), CiA402 6040h/6041h of the mode).

use ethercrab::MainDevice;
use tests_host::vendor::{self, Sdo};
use tests_host::{block_on, master_for};

const CPR: f64 = (1u32 << 20) as f64;
const CYCLE_NS: u64 = 1_000_000;
const ENABLE_OPERATION: u16 = 0x0F;
const STATE_MASK: u16 = 0x6F;
const OPERATION_ENABLED: u16 = 0x27;
const TARGET_REACHED: u16 = 1 << 10;

fn interpolated_position_follows_the_interpolation_data(name: &str) {
    use std::f64::consts::TAU;
    const IP: i8 = 7;
    const ENABLE_INTERPOLATION: u16 = 1 << 4;
    const IP_MODE_ACTIVE: u16 = 1 << 12;
    block_on(async {
        let (m, transport) = master_for(board_sim::Segment::new(name, 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        // RxPDO 1600h: controlword and the interpolation data record; the default TxPDO
        // (6041h, 6064h first on both profiles).
        let mut setup = vendor::remap(0x1600, 0x1C12, &[(0x6040, 0, 16), (0x60C1, 1, 32)]);
        setup.push(Sdo::I8(0x6060, 0, IP));
        let group = vendor::into_op_dc(&m, md, &setup, CYCLE_NS).await;
        let cycle = |cw: u16, target: i32| {
            let (m, group) = (&m, &group);
            async move {
                let outputs: [(usize, &[u8]); 2] =
                    [(0, &cw.to_le_bytes()), (2, &target.to_le_bytes())];
                let inputs = vendor::exchange_dc(m, md, group, &outputs, CYCLE_NS).await;
                let rev = m.shared.segment().drives()[0].servos[0]
                    .plant
                    .mech_angle_rad()
                    / TAU;
                (vendor::u16_at(&inputs, 0), vendor::i32_at(&inputs, 2), rev)
            }
        };
        let mut s = (0, 0, 0.0);
        // The slave enters OP at the first SYNC0 after the request with outputs (the first
        // cycles may still be SAFEOP's).
        for cw in [0x06u16; 50]
            .into_iter()
            .chain([0x07; 10])
            .chain([ENABLE_OPERATION; 40])
        {
            s = cycle(cw, 0).await;
        }
        assert_eq!(s.0 & STATE_MASK, OPERATION_ENABLED, "{:#06x}", s.0);
        assert_eq!(s.0 & IP_MODE_ACTIVE, 0, "bit 4 clear: interpolation off");
        let sd = group.subdevice(md, 0).expect("drive");
        assert_eq!(sd.sdo_read::<u8>(0x60C2, 1).await.expect("60C2h:01"), 100);
        assert_eq!(sd.sdo_read::<i8>(0x60C2, 2).await.expect("60C2h:02"), -5);

        // Bit 4 clear: a set-point is not taken, the motor holds.
        for _ in 0..50 {
            s = cycle(ENABLE_OPERATION, (CPR * 0.5) as i32).await;
        }
        assert!(s.2.abs() < 1e-3, "held at {} rev", s.2);
        // Bit 4 set: 2 revolutions in 500 set-points (1 ms each, 240 rpm).
        let ramp = |k: i32| (2.0 * CPR * f64::from(k.min(500)) / 500.0) as i32;
        let mut active = true;
        for k in 0..=500 {
            s = cycle(ENABLE_OPERATION | ENABLE_INTERPOLATION, ramp(k)).await;
            active &= k < 3 || s.0 & IP_MODE_ACTIVE != 0;
            if k == 250 {
                assert!(
                    (s.2 - 1.0).abs() < 0.02,
                    "following the set-points: {} rev",
                    s.2
                );
                assert_eq!(s.0 & TARGET_REACHED, 0, "moving: bit 10 clear");
            }
        }
        assert!(active, "bit 12 while interpolating");
        for _ in 0..100 {
            s = cycle(ENABLE_OPERATION | ENABLE_INTERPOLATION, ramp(500)).await;
        }
        assert!((s.2 - 2.0).abs() < 1e-3, "at {} rev", s.2);
        assert!((f64::from(s.1) - 2.0 * CPR).abs() < 50.0, "6064h {}", s.1);
        assert_ne!(s.0 & TARGET_REACHED, 0, "bit 10 at the set-point");
        // Bit 4 cleared again: bit 12 clears, the motor holds where it is.
        for _ in 0..50 {
            s = cycle(ENABLE_OPERATION, 0).await;
        }
        assert_eq!(s.0 & IP_MODE_ACTIVE, 0);
        assert!((s.2 - 2.0).abs() < 1e-3, "held at {} rev", s.2);
    });
}

#[test]
fn standard_interpolated_position_follows_the_interpolation_data() {
    interpolated_position_follows_the_interpolation_data("standard");
}

#[test]
fn sigma_v_sd_interpolated_position_follows_the_interpolation_data() {
    interpolated_position_follows_the_interpolation_data("sigma-v-sd");
}
