//! The CiA402 state machine of every profile (IEC 61800-7-201 §6.2, transitions 1–16), commanded
//! by ethercrab over PDOs (6040h, 6060h, 60FFh / 6041h, 6061h, 606Ch; DC SYNC0 at 1 ms) in
//! cyclic synchronous velocity. After each controlword the statusword's bits 0–9 must be the
//! state's pattern of CiA402 Table 30 with bit 4 "voltage enabled" (the simulated main power is
//! on) and bit 9 "remote" (the controlword is processed in OP): 0250h Switch On Disabled, 0231h
//! Ready to Switch On, 0233h Switched On, 0237h Operation Enabled, 0217h Quick Stop Active,
//! 021Fh Fault Reaction Active, 0218h Fault (the RSE's manual prints exactly these, 6.2).
//!
//! Each manual's deviations:
//!
//! | profile | deviation | manual |
//! |---|---|---|
//! | sigma-v-sd | disable operation (5) and shutdown (8) end in Switch On Disabled | §4.7 (5), (6) |
//! | gha-e, sigma-v-sd | no quick stop option that stays in Quick Stop Active: no transition 16 | GHA-E §5.7.2; Σ-V-SD §6.4 |
//! | sdv3-e, osd-g-e | quick stop options 0, 1, 5 (5 stays in Quick Stop Active) | Table 6-2 |
//! | standard, rse | the fault reaction on the quick-stop ramp (605Eh = 2): Fault Reaction Active while the motor decelerates | CiA402; 7.3 |
//!
//! Fault reset (15) takes a rising edge of bit 7: a reset held high while the fault is active,
//! and still held when its cause is gone, leaves the drive in Fault until the next rising edge.

use board_sim::inproc::InProcess;
use ethercrab::MainDevice;
use od_gen::Profile;
use tests_host::vendor::{self, DcDrive, Sdo, ENABLE_OPERATION, SHUTDOWN, SWITCH_ON};
use tests_host::{block_on, cia402, master_for, units};

const CYCLE_NS: u64 = 1_000_000;
const CSV: i8 = cia402::CYCLIC_SYNCHRONOUS_VELOCITY;
/// 6041h bits 0–9.
const STATE_BITS: u16 = 0x03FF;
const SWITCH_ON_DISABLED: u16 = 0x0250;
const READY_TO_SWITCH_ON: u16 = 0x0231;
const SWITCHED_ON: u16 = 0x0233;
const OPERATION_ENABLED: u16 = 0x0237;
const QUICK_STOP_ACTIVE: u16 = 0x0217;
const FAULT_REACTION_ACTIVE: u16 = 0x021F;
const FAULT: u16 = 0x0218;
/// CiA402 Table 5 controlwords.
const DISABLE_VOLTAGE: u16 = 0x0000;
const QUICK_STOP: u16 = 0x0002;
const FAULT_RESET: u16 = 0x0080;
const SPEED_REV_S: f64 = 5.0;
const RAMP_REV_S2: f64 = 20.0;

/// A profile and its manual's deviations.
struct Manual {
    name: &'static str,
    /// Disable operation and shutdown end in Switch On Disabled.
    stops_end_switched_off: bool,
    /// A 605Ah code that ends in Switch On Disabled after a ramp, and one that stays in Quick
    /// Stop Active (`None`: the manual has none).
    quick_stop_codes: (i16, Option<i16>),
    /// 605Eh = 2 (quick-stop ramp) is an option: Fault Reaction Active lasts the deceleration.
    fault_reaction_ramp: bool,
}

struct Drive<'a> {
    bus: DcDrive<'a>,
    name: &'static str,
    velocity: i32,
}

impl Drive<'_> {
    /// `cycles` cycles with controlword `cw`; the last statusword.
    async fn hold(&self, cw: u16, cycles: usize) -> u16 {
        self.bus
            .hold_statusword((cw, CSV, self.velocity), cycles)
            .await
    }

    /// Controlword `cw` until the state settles; asserts bits 0–9 for `transition`.
    async fn transition(&self, transition: u8, cw: u16, expected: u16) {
        let sw = self.hold(cw, 5).await;
        assert_eq!(
            sw & STATE_BITS,
            expected,
            "{}: transition {transition} (controlword {cw:#06x}): 6041h {sw:#06x}, expected {expected:#06x}",
            self.name
        );
    }

    /// Each controlword for a few cycles.
    async fn through(&self, controlwords: &[u16]) {
        for &cw in controlwords {
            self.hold(cw, 5).await;
        }
    }

    fn motor_rev_s(&self) -> f64 {
        let segment = self.bus.m.shared.segment();
        segment.drives()[0].servos[0].plant.mech_speed_rad_s() / std::f64::consts::TAU
    }
}

/// INIT → OP with 605Ah = `quick_stop`, 605Eh = 2 where the manual has it, the ramps set.
async fn into_op<'a>(
    m: &'a InProcess,
    md: &'a MainDevice<'a>,
    manual: &Manual,
    quick_stop: i16,
) -> Drive<'a> {
    let profile: Profile = od_gen::builtin(manual.name).expect("profile");
    let mut setup = vec![Sdo::I16(0x605A, 0, quick_stop)];
    for index in [0x6084, 0x6085] {
        if profile.entry(index, 0).is_some() {
            setup.push(Sdo::U32(
                index,
                0,
                units::acceleration(&profile, RAMP_REV_S2),
            ));
        }
    }
    if manual.fault_reaction_ramp {
        setup.push(Sdo::I16(0x605E, 0, 2));
    }
    let group = vendor::into_op_dc_velocity(m, md, (0, &setup), CSV, CYCLE_NS).await;
    Drive {
        bus: DcDrive {
            m,
            md,
            group,
            cycle_ns: CYCLE_NS,
        },
        name: manual.name,
        velocity: 0,
    }
}

fn transitions(manual: Manual) {
    let profile = od_gen::builtin(manual.name).expect("profile");
    let speed = units::target_velocity(&profile, SPEED_REV_S);
    let (disabling, holding) = manual.quick_stop_codes;
    // The stops of disable operation and shutdown, and where they end.
    let (after_5, after_8) = if manual.stops_end_switched_off {
        // 8: Switch On Disabled, then the shutdown the master holds is transition 2.
        (SWITCH_ON_DISABLED, READY_TO_SWITCH_ON)
    } else {
        (SWITCHED_ON, READY_TO_SWITCH_ON)
    };
    block_on(async {
        let (m, transport) = master_for(board_sim::Segment::new(manual.name, 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let mut d = into_op(&m, md, &manual, disabling).await;
        d.transition(1, DISABLE_VOLTAGE, SWITCH_ON_DISABLED).await;
        d.transition(2, SHUTDOWN, READY_TO_SWITCH_ON).await;
        d.transition(3, SWITCH_ON, SWITCHED_ON).await;
        d.transition(4, ENABLE_OPERATION, OPERATION_ENABLED).await;
        d.transition(5, SWITCH_ON, after_5).await;
        d.through(&[SHUTDOWN, SWITCH_ON]).await;
        d.transition(6, SHUTDOWN, READY_TO_SWITCH_ON).await;
        d.transition(7, DISABLE_VOLTAGE, SWITCH_ON_DISABLED).await;
        d.through(&[SHUTDOWN, SWITCH_ON, ENABLE_OPERATION]).await;
        d.transition(8, SHUTDOWN, after_8).await;
        d.through(&[SHUTDOWN, SWITCH_ON, ENABLE_OPERATION]).await;
        d.transition(9, DISABLE_VOLTAGE, SWITCH_ON_DISABLED).await;
        d.through(&[SHUTDOWN, SWITCH_ON]).await;
        d.transition(10, DISABLE_VOLTAGE, SWITCH_ON_DISABLED).await;
        // 11 then 12: the motor at speed decelerates in Quick Stop Active, then the drive goes
        // on to Switch On Disabled.
        d.velocity = speed;
        d.through(&[SHUTDOWN, SWITCH_ON]).await;
        d.hold(ENABLE_OPERATION, 300).await;
        d.transition(11, QUICK_STOP, QUICK_STOP_ACTIVE).await;
        d.hold(QUICK_STOP, 500).await;
        d.transition(12, QUICK_STOP, SWITCH_ON_DISABLED).await;
        assert!(d.motor_rev_s().abs() < 0.5, "{}: at rest", manual.name);

        // 13, 14: the power stage over its temperature while the motor turns.
        d.through(&[SHUTDOWN, SWITCH_ON]).await;
        d.hold(ENABLE_OPERATION, 300).await;
        vendor::overheat_power_stage(&m, 0);
        let mut seen = Vec::new();
        for _ in 0..1_000 {
            let sw = d.hold(ENABLE_OPERATION, 1).await & STATE_BITS;
            if seen.last() != Some(&sw) {
                seen.push(sw);
            }
            if sw == FAULT {
                break;
            }
        }
        let expected: &[u16] = if manual.fault_reaction_ramp {
            &[FAULT_REACTION_ACTIVE, FAULT]
        } else {
            &[FAULT]
        };
        assert!(
            seen.ends_with(expected),
            "{}: transitions 13, 14: 6041h went {seen:04x?}, expected to end {expected:04x?}",
            manual.name
        );
        // 15 needs a rising edge: a reset held high while the cause is there, and after it is
        // gone, leaves the drive in Fault.
        d.velocity = 0;
        let sw = d.hold(FAULT_RESET, 50).await;
        assert_eq!(sw & STATE_BITS, FAULT, "{}: reset while hot", manual.name);
        m.shared.segment().drives_mut()[0].servos[0]
            .plant
            .set_drive_temperature(25.0);
        let sw = d.hold(FAULT_RESET, 50).await;
        assert_eq!(
            sw & STATE_BITS,
            FAULT,
            "{}: bit 7 held high since before the cause went: no edge, no reset",
            manual.name
        );
        d.hold(DISABLE_VOLTAGE, 5).await;
        d.transition(15, FAULT_RESET, SWITCH_ON_DISABLED).await;
    });

    // 16: Quick Stop Active → Operation Enabled, where an option stays in Quick Stop Active.
    if let Some(holding) = holding {
        block_on(async {
            let (m, transport) =
                master_for(board_sim::Segment::new(manual.name, 1).expect("profile"));
            tokio::task::spawn_local(transport);
            let md: &MainDevice<'_> = &m.maindevice;
            let d = into_op(&m, md, &manual, holding).await;
            d.through(&[DISABLE_VOLTAGE, SHUTDOWN, SWITCH_ON, ENABLE_OPERATION])
                .await;
            d.transition(11, QUICK_STOP, QUICK_STOP_ACTIVE).await;
            d.hold(QUICK_STOP, 50).await;
            d.transition(11, QUICK_STOP, QUICK_STOP_ACTIVE).await;
            d.transition(16, ENABLE_OPERATION, OPERATION_ENABLED).await;
        });
    }
}

#[test]
fn standard_transitions() {
    transitions(Manual {
        name: "standard",
        stops_end_switched_off: false,
        quick_stop_codes: (2, Some(6)),
        fault_reaction_ramp: true,
    });
}

#[test]
fn gha_e_transitions() {
    transitions(Manual {
        name: "gha-e",
        stops_end_switched_off: false,
        quick_stop_codes: (2, None),
        fault_reaction_ramp: false,
    });
}

#[test]
fn rse_transitions_with_the_manuals_values() {
    transitions(Manual {
        name: "rse",
        stops_end_switched_off: false,
        quick_stop_codes: (2, Some(6)),
        fault_reaction_ramp: true,
    });
}

#[test]
fn sdv3_e_transitions() {
    transitions(Manual {
        name: "sdv3-e",
        stops_end_switched_off: false,
        quick_stop_codes: (1, Some(5)),
        fault_reaction_ramp: false,
    });
}

#[test]
fn osd_g_e_transitions() {
    transitions(Manual {
        name: "osd-g-e",
        stops_end_switched_off: false,
        quick_stop_codes: (1, Some(5)),
        fault_reaction_ramp: false,
    });
}

#[test]
fn sigma_v_sd_transitions() {
    transitions(Manual {
        name: "sigma-v-sd",
        stops_end_switched_off: true,
        quick_stop_codes: (2, None),
        fault_reaction_ramp: false,
    });
}
