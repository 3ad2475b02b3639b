//! The RSE's state machine with the exact statusword values its manual prints (6.2, table of
//! transitions 0–16: 6041h bits 0–9 after each controlword), commanded by ethercrab over PDOs
//! (6040h, 6060h, 60FFh / 6041h, 6061h, 606Ch; DC SYNC0 at 1 ms) in cyclic synchronous velocity.
//! Bits 4 (voltage enabled) and 9 (remote) are set in every state but Not Ready to Switch On.
//! Transition 16 (Quick Stop Active → Operation Enabled with 0x0F "when the shutdown is
//! complete") needs a quick stop that stays in Quick Stop Active (605Ah = 6); with the default
//! 605Ah = 2 the drive goes on to Switch On Disabled (12). The fault is the power stage over its
//! temperature while the motor turns, with the fault reaction 605Eh = 2 (the quick-stop ramp), so
//! that Fault Reaction Active (13) lasts while the motor decelerates.

use std::f64::consts::TAU;

use board_sim::inproc::InProcess;
use ethercrab::MainDevice;
use tests_host::vendor::{self, DcGroup, Sdo};
use tests_host::{block_on, cia402, master_for, units};

const CYCLE_NS: u64 = 1_000_000;
const CSV: i8 = cia402::CYCLIC_SYNCHRONOUS_VELOCITY;
/// 6041h bits 0–9: the part of the statusword the manual's table gives.
const TABLE_BITS: u16 = 0x03FF;
/// The manual's statusword values (6.2).
const SWITCH_ON_DISABLED: u16 = 0x0250;
const READY_TO_SWITCH_ON: u16 = 0x0231;
const SWITCHED_ON: u16 = 0x0233;
const OPERATION_ENABLED: u16 = 0x0237;
const QUICK_STOP_ACTIVE: u16 = 0x0217;
const FAULT_REACTION_ACTIVE: u16 = 0x021F;
const FAULT: u16 = 0x0218;
/// The manual's controlwords.
const SHUTDOWN: u16 = 0x0006;
const SWITCH_ON: u16 = 0x0007;
const ENABLE_OPERATION: u16 = 0x000F;
const DISABLE_VOLTAGE: u16 = 0x0000;
const QUICK_STOP: u16 = 0x0002;
const FAULT_RESET: u16 = 0x0080;

struct Drive<'a> {
    m: &'a InProcess,
    md: &'a MainDevice<'a>,
    group: DcGroup,
    velocity: i32,
}

impl Drive<'_> {
    /// `cycles` cycles with controlword `cw`; the last statusword.
    async fn hold(&self, cw: u16, cycles: usize) -> u16 {
        let mut sw = 0;
        for _ in 0..cycles {
            let inputs = vendor::exchange_dc_command(
                self.m,
                self.md,
                &self.group,
                (cw, CSV, self.velocity),
                CYCLE_NS,
            )
            .await;
            sw = vendor::u16_at(&inputs, 0);
        }
        sw
    }

    /// Controlword `cw` until the state settles; asserts the manual's value for transition
    /// `transition`.
    async fn transition(&self, transition: u8, cw: u16, expected: u16) {
        let sw = self.hold(cw, 5).await;
        assert_eq!(
            sw & TABLE_BITS,
            expected,
            "transition {transition} (controlword {cw:#06x}): 6041h {sw:#06x}, the manual prints {expected:#06x}"
        );
    }
}

/// INIT → OP with the quick-stop option `quick_stop_option` and 605Eh = 2 (quick-stop ramp).
async fn into_op<'a>(
    m: &'a InProcess,
    md: &'a MainDevice<'a>,
    quick_stop_option: i16,
) -> Drive<'a> {
    let profile = od_gen::builtin("rse").expect("rse");
    let setup = [
        Sdo::I16(0x605A, 0, quick_stop_option),
        Sdo::I16(0x605E, 0, 2),
        Sdo::U32(0x6085, 0, units::acceleration(&profile, 20.0)),
    ];
    let group = vendor::into_op_dc_velocity(m, md, (0, &setup), CSV, CYCLE_NS).await;
    Drive {
        m,
        md,
        group,
        velocity: 0,
    }
}

#[test]
fn rse_state_machine_shows_the_manuals_exact_statusword_values() {
    block_on(async {
        let (m, transport) = master_for(board_sim::Segment::new("rse", 1).expect("rse"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let mut d = into_op(&m, md, 2).await;
        // 1: after initialisation, Switch On Disabled.
        d.transition(1, DISABLE_VOLTAGE, SWITCH_ON_DISABLED).await;
        d.transition(2, SHUTDOWN, READY_TO_SWITCH_ON).await;
        d.transition(3, SWITCH_ON, SWITCHED_ON).await;
        d.transition(4, ENABLE_OPERATION, OPERATION_ENABLED).await;
        d.transition(5, SWITCH_ON, SWITCHED_ON).await;
        d.transition(6, SHUTDOWN, READY_TO_SWITCH_ON).await;
        d.transition(7, DISABLE_VOLTAGE, SWITCH_ON_DISABLED).await;
        for (transition, cw, expected) in [
            (8, SHUTDOWN, READY_TO_SWITCH_ON),
            (9, DISABLE_VOLTAGE, SWITCH_ON_DISABLED),
        ] {
            for step in [SHUTDOWN, SWITCH_ON, ENABLE_OPERATION] {
                d.hold(step, 5).await;
            }
            d.transition(transition, cw, expected).await;
        }
        for step in [SHUTDOWN, SWITCH_ON] {
            d.hold(step, 5).await;
        }
        d.transition(10, DISABLE_VOLTAGE, SWITCH_ON_DISABLED).await;
        // 11 then 12: with the motor at 300 rpm, 605Ah = 2 decelerates on 6085h in Quick Stop
        // Active, then goes on to Switch On Disabled.
        let profile = od_gen::builtin("rse").expect("rse");
        d.velocity = units::target_velocity(&profile, 5.0);
        for step in [SHUTDOWN, SWITCH_ON] {
            d.hold(step, 5).await;
        }
        d.hold(ENABLE_OPERATION, 300).await;
        d.transition(11, QUICK_STOP, QUICK_STOP_ACTIVE).await;
        d.hold(QUICK_STOP, 400).await;
        d.transition(12, QUICK_STOP, SWITCH_ON_DISABLED).await;
    });
}

#[test]
fn rse_quick_stop_active_back_to_operation_enabled_and_fault_values() {
    block_on(async {
        let (m, transport) = master_for(board_sim::Segment::new("rse", 1).expect("rse"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        // 605Ah = 6: stop on 6085h and stay in Quick Stop Active.
        let mut d = into_op(&m, md, 6).await;
        for step in [SHUTDOWN, SWITCH_ON, ENABLE_OPERATION] {
            d.hold(step, 5).await;
        }
        d.transition(11, QUICK_STOP, QUICK_STOP_ACTIVE).await;
        d.transition(16, ENABLE_OPERATION, OPERATION_ENABLED).await;
        // The motor at 300 rpm, then the power stage over its temperature: Fault Reaction
        // Active while it decelerates on 6085h (13), then Fault (14); fault reset (15).
        let profile = od_gen::builtin("rse").expect("rse");
        d.velocity = units::target_velocity(&profile, 5.0);
        d.hold(ENABLE_OPERATION, 300).await;
        vendor::overheat_power_stage(&m, 0);
        let mut seen = Vec::new();
        for _ in 0..1_000 {
            let sw = d.hold(ENABLE_OPERATION, 1).await & TABLE_BITS;
            if seen.last() != Some(&sw) {
                seen.push(sw);
            }
            if sw == FAULT {
                break;
            }
        }
        assert!(
            seen.ends_with(&[FAULT_REACTION_ACTIVE, FAULT]),
            "transitions 13, 14: 6041h went {seen:04x?}, the manual prints {FAULT_REACTION_ACTIVE:#06x} then {FAULT:#06x}"
        );
        let speed = m.shared.segment().drives()[0].servos[0]
            .plant
            .mech_speed_rad_s()
            / TAU;
        assert!(speed.abs() < 0.5, "at rest in Fault: {speed:.2} rev/s");
        m.shared.segment().drives_mut()[0].servos[0]
            .plant
            .set_drive_temperature(25.0);
        d.velocity = 0;
        d.hold(0, 5).await;
        d.transition(15, FAULT_RESET, SWITCH_ON_DISABLED).await;
    });
}
