//! The CiA402 demand values in user units (IEC 61800-7-201): 6062h position demand value, 606Bh
//! velocity demand value and 6074h torque demand show what the drive commands its loops in the
//! cycle. They read the same whether a TxPDO carries them, written in every cycle, or an SDO
//! upload reads them, for which the drive writes them (converting them in every cycle when no
//! PDO carries them would be work that nobody reads).
//!
//! The GHA-E with its fractional gear ratio 6091h = 131072 / 10000 and the polarity 607Eh = 224
//! (position, velocity and torque inverted, §4.3) is commanded by ethercrab over PDOs with DC
//! SYNC0: a CSP ramp to a target, then CSV at a target velocity, then CST at a target torque.
//! Each demand value equals the command in the objects' units, read by SDO with and without the
//! TxPDO carrying it; carried, it follows the ramp cycle by cycle.

use board_sim::inproc::InProcess;
use ethercrab::MainDevice;
use tests_host::vendor::{self, Command, DcGroup, MappedEntry, Sdo};
use tests_host::{block_on, cia402, master_for};

const CYCLE_NS: u64 = 1_000_000;
/// 6060h: cyclic synchronous position, velocity, torque.
const CSP: i8 = 8;
const CSV: i8 = 9;
const CST: i8 = 10;
/// 607Eh: position, velocity and torque polarity inverted (bits 7, 6, 5).
const ALL_INVERTED: u8 = 0xE0;
/// Inputs: 6041h, 6064h, then (when carried) the demand values.
const INPUTS: [MappedEntry; 2] = [(0x6041, 0, 16), (0x6064, 0, 32)];
const DEMANDS: [MappedEntry; 3] = [(0x6062, 0, 32), (0x606B, 0, 32), (0x6074, 0, 16)];
/// Byte offsets of the carried 6062h, 606Bh and 6074h in the input image.
const POSITION_DEMAND_AT: usize = 6;
const VELOCITY_DEMAND_AT: usize = 10;
const TORQUE_DEMAND_AT: usize = 14;
/// The CSP ramp: instruction units per cycle (131 increments per ms: 0.125 rev/s) and the
/// target it ends on.
const RAMP_STEP: i32 = 10;
const TARGET: i32 = 5_000;
/// CSV: instruction units/s (26 214 increments/s, 1.5 rpm).
const TARGET_VELOCITY: i32 = 2_000;
/// CST: 0.1 % of the rated torque.
const TARGET_TORQUE: i16 = 30;

/// One DC cycle of `c`; the inputs it brought back.
async fn cycle(m: &InProcess, md: &MainDevice<'_>, group: &DcGroup, c: Command) -> Vec<u8> {
    vendor::exchange_dc(m, md, group, &[(0, &c.image())], CYCLE_NS).await
}

/// The demand values of the drive by SDO upload: 6062h, 606Bh, 6074h.
async fn uploaded(md: &MainDevice<'_>, group: &DcGroup) -> (i32, i32, i16) {
    let sd = group.subdevice(md, 0).expect("drive");
    let position: i32 = sd.sdo_read(0x6062, 0).await.expect("6062h");
    let velocity: i32 = sd.sdo_read(0x606B, 0).await.expect("606Bh");
    let torque: i16 = sd.sdo_read(0x6074, 0).await.expect("6074h");
    (position, velocity, torque)
}

/// The demand values a TxPDO carries in `inputs`.
fn carried(inputs: &[u8]) -> (i32, i32, i16) {
    let torque = i16::from_le_bytes([inputs[TORQUE_DEMAND_AT], inputs[TORQUE_DEMAND_AT + 1]]);
    (
        vendor::i32_at(inputs, POSITION_DEMAND_AT),
        vendor::i32_at(inputs, VELOCITY_DEMAND_AT),
        torque,
    )
}

/// The scenario, with the demand values in the TxPDO or not (`carry`).
fn demand_values_read_the_command(carry: bool) {
    block_on(async {
        let (m, transport) = master_for(board_sim::Segment::new("gha-e", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let mut inputs = INPUTS.to_vec();
        if carry {
            inputs.extend(DEMANDS);
        }
        let mut setup = vendor::mapping(&vendor::COMMAND_OUTPUTS, &inputs);
        setup.push(Sdo::U8(0x607E, 0, ALL_INVERTED));
        let group = vendor::into_op_dc(&m, md, &setup, CYCLE_NS).await;
        let mut command = Command {
            cw: 0,
            mode: CSP,
            position: 0,
            velocity: 0,
            torque: 0,
        };
        for _ in 0..vendor::SYNC0_START_CYCLES {
            cycle(&m, md, &group, command).await;
        }
        let mut image = Vec::new();
        for cw in vendor::enable_sequence(20) {
            command.cw = cw;
            image = cycle(&m, md, &group, command).await;
        }
        let sw = vendor::u16_at(&image, 0);
        assert!(cia402::is(sw, cia402::OPERATION_ENABLED), "{sw:#06x}");

        // CSP: a ramp to the target. Carried, 6062h follows it cycle by cycle (one step per
        // cycle, the inputs a cycle behind the outputs at most).
        let mut last_carried = None;
        while command.position < TARGET {
            command.position += RAMP_STEP;
            image = cycle(&m, md, &group, command).await;
            if carry {
                let (demand, _, _) = carried(&image);
                if let Some(last) = last_carried {
                    assert!(
                        demand == last + RAMP_STEP,
                        "6062h carried: {demand} after {last} (target {})",
                        command.position
                    );
                }
                if demand > 0 {
                    last_carried = Some(demand);
                }
            }
        }
        assert!(!carry || last_carried.is_some(), "6062h never followed");
        for _ in 0..200 {
            image = cycle(&m, md, &group, command).await;
        }
        let sw = vendor::u16_at(&image, 0);
        assert!(cia402::is(sw, cia402::OPERATION_ENABLED), "{sw:#06x}");
        assert_eq!(
            vendor::i32_at(&image, 2),
            TARGET,
            "6064h at rest on the target"
        );
        let (position, _, _) = uploaded(md, &group).await;
        assert_eq!(position, TARGET, "6062h uploaded in CSP");
        if carry {
            assert_eq!(carried(&image).0, TARGET, "6062h carried in CSP");
        }

        // CSV at a target velocity.
        command.mode = CSV;
        command.velocity = TARGET_VELOCITY;
        for _ in 0..20 {
            image = cycle(&m, md, &group, command).await;
        }
        let (_, velocity, _) = uploaded(md, &group).await;
        assert_eq!(velocity, TARGET_VELOCITY, "606Bh uploaded in CSV");
        if carry {
            assert_eq!(carried(&image).1, TARGET_VELOCITY, "606Bh carried in CSV");
        }

        // CST at a target torque.
        command.mode = CST;
        command.torque = TARGET_TORQUE;
        for _ in 0..5 {
            image = cycle(&m, md, &group, command).await;
        }
        let (_, _, torque) = uploaded(md, &group).await;
        assert_eq!(torque, TARGET_TORQUE, "6074h uploaded in CST");
        if carry {
            assert_eq!(carried(&image).2, TARGET_TORQUE, "6074h carried in CST");
        }
        let sw = vendor::u16_at(&image, 0);
        assert!(cia402::is(sw, cia402::OPERATION_ENABLED), "{sw:#06x}");
    });
}

#[test]
fn demand_values_uploaded_without_a_txpdo_read_the_command() {
    demand_values_read_the_command(false);
}

#[test]
fn demand_values_carried_by_the_txpdo_read_the_command_in_every_cycle() {
    demand_values_read_the_command(true);
}
