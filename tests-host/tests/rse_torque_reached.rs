//! The RSE's "target torque reached" (statusword bit 10 in profile torque and cyclic
//! synchronous torque, 7.2 mode table; 7.5 CST "Target reached uses the torque-reached logic"):
//! with A = 2008h:0Ah (reference value), B = 2008h:0Bh (effective value), C = 2008h:0Ch
//! (invalid value), bit 10 = 1 once the actual torque exceeds A + B and 0 once it is below
//! A + C; in between it keeps its value. End to end (ethercrab, DC SYNC0 at 1 ms; 1600h:
//! 6040h, 6060h, 6071h; 1A00h: 6041h, 6077h) on a locked rotor, so that the actual torque is
//! the command.

use board_sim::Segment;
use ethercrab::MainDevice;
use tests_host::vendor::{self, Sdo};
use tests_host::{block_on, cia402, master_for};

const CYCLE_NS: u64 = 1_000_000;
const PT: i8 = 4;
const CST: i8 = 10;
/// Statusword bit 10.
const TARGET_REACHED: u16 = 1 << 10;
/// A, B, C in 0.1 % of the rated torque: on above 12 %, off below 10 %.
const A: u16 = 100;
const B: u16 = 20;
const C: u16 = 0;
/// 6087h torque slope for PT, 0.1 %/s: 10 %/ms, each step within a few cycles.
const SLOPE: u32 = 100_000;

/// Bit 10 after each torque command of `steps` (0.1 %, 200 cycles each) in `mode`.
fn bit_10(mode: i8, steps: &[i16]) -> Vec<bool> {
    block_on(async {
        let (m, transport) = master_for(Segment::new("rse", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let mut sdos = vendor::mapping(
            &[(0x6040, 0, 16), (0x6060, 0, 8), (0x6071, 0, 16)],
            &[(0x6041, 0, 16), (0x6077, 0, 16)],
        );
        sdos.extend([
            Sdo::U16(0x2008, 0x0A, A),
            Sdo::U16(0x2008, 0x0B, B),
            Sdo::U16(0x2008, 0x0C, C),
            Sdo::U32(0x6087, 0, SLOPE),
        ]);
        let group = vendor::into_op_dc(&m, md, &sdos, CYCLE_NS).await;
        m.shared.segment().drives_mut()[0].servos[0]
            .plant
            .set_driven_speed(Some(0.0));
        let cycle = |cw: u16, torque: i16| {
            let (m, group) = (&m, &group);
            async move {
                let [c0, c1] = cw.to_le_bytes();
                let [t0, t1] = torque.to_le_bytes();
                let image = [c0, c1, mode as u8, t0, t1];
                let inputs = vendor::exchange_dc(m, md, group, &[(0, &image)], CYCLE_NS).await;
                vendor::u16_at(&inputs, 0)
            }
        };
        for _ in 0..vendor::SYNC0_START_CYCLES {
            cycle(0, 0).await;
        }
        let mut sw = 0;
        for cw in vendor::enable_sequence(20) {
            sw = cycle(cw, 0).await;
        }
        assert!(cia402::is(sw, cia402::OPERATION_ENABLED), "{sw:#06x}");
        let mut out = Vec::new();
        for &torque in steps {
            for _ in 0..200 {
                sw = cycle(vendor::ENABLE_OPERATION, torque).await;
            }
            out.push(sw & TARGET_REACHED != 0);
        }
        out
    })
}

/// Up through the band, above it, back into it, below it, into it again.
const STEPS: [i16; 5] = [50, 150, 110, 80, 110];
/// 5 % below A + C: 0; 15 % above A + B: 1; 11 % in the band: kept (1); 8 %: 0; 11 %: kept (0).
const EXPECTED: [bool; 5] = [false, true, true, false, false];

#[test]
fn rse_cst_target_torque_reached_with_hysteresis() {
    assert_eq!(bit_10(CST, &STEPS), EXPECTED);
}

#[test]
fn rse_pt_target_torque_reached_with_hysteresis() {
    assert_eq!(bit_10(PT, &STEPS), EXPECTED);
}

#[test]
fn rse_torque_reached_works_in_both_directions() {
    let negative = STEPS.map(|t| -t);
    assert_eq!(bit_10(CST, &negative), EXPECTED);
}
