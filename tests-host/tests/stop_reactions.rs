//! CiA402 stop reactions (IEC 61800-7-201 §6.3.4–6.3.8) on the simulated servo, commanded by
//! ethercrab over the standard profile's default PDOs (6040h, 607Ah, 6060h / 6041h, 6064h,
//! 6061h) in CSP, the option codes and ramps set by SDO:
//!
//! - quick stop with 605Ah = 2: Quick Stop Active while the motor decelerates along the
//!   quick-stop ramp 6085h, then Switch On Disabled; with 605Ah = 0 it coasts instead;
//! - 605Ah = 6: Quick Stop Active holds the motor at rest until enable operation (16);
//! - 605Ah = 3: the stop brakes at the current limit, statusword bit 11 "internal limit
//!   active" meanwhile;
//! - disable operation with 605Ch = 1: Operation Enabled while decelerating on 6084h, then
//!   Switched On;
//! - halt (bit 8) with 605Dh = 1: decelerates on 6084h in Operation Enabled (statusword bit 10
//!   "target reached" once at rest) and resumes;
//! - a profile precondition: the SDV3-E refuses enable operation with no mode (oPE);
//! - a profile end state: the Σ-V-SD's disable operation ends in Switch On Disabled;
//! - a profile precondition: the Σ-V-SD switches on only with the main power (statusword bit 4).
//!
//! Decelerations are checked on the plant's true speed against the ramp the objects set.

use std::f64::consts::TAU;

use ethercrab::MainDevice;
use tests_host::{block_on, csp, master};

/// Simulated time per cycle (free run).
const CYCLE_NS: u64 = 1_000_000;
const CYCLE_S: f64 = 1e-3;
/// Increments per revolution of the simulated servo's encoder.
const CPR: f64 = (1u64 << 20) as f64;
/// CiA402 controlwords (Table 5), the halt bit, statusword state patterns (Table 30).
const SHUTDOWN: u16 = 0x06;
const SWITCH_ON: u16 = 0x07;
const ENABLE_OPERATION: u16 = 0x0F;
const QUICK_STOP: u16 = 0x02;
const HALT: u16 = 0x0100;
const TARGET_REACHED: u16 = 0x0400;
const STATE_MASK: u16 = 0x6F;
const OPERATION_ENABLED: u16 = 0x27;
const SWITCHED_ON: u16 = 0x23;
const QUICK_STOP_ACTIVE: u16 = 0x07;
const SWITCH_ON_DISABLED_MASK: u16 = 0x4F;
const SWITCH_ON_DISABLED: u16 = 0x40;
/// Modes of operation 6060h: cyclic synchronous position.
const MODE_CSP: u8 = 8;
/// Option codes and ramps (CiA402).
const QUICK_STOP_OPTION: u16 = 0x605A;
const HALT_OPTION: u16 = 0x605D;
const PROFILE_DECELERATION: u16 = 0x6084;
const QUICK_STOP_DECELERATION: u16 = 0x6085;
/// The speed the tests move at: 1000 rpm, in increments per cycle.
const SPEED_RPM: f64 = 1000.0;
/// The drive's standstill level (firmware `STANDSTILL_RPM`).
const STANDSTILL_RPM: f64 = 20.0;

fn speed_counts_per_s(rpm: f64) -> f64 {
    rpm / 60.0 * CPR
}

/// One cycle with controlword `cw`, target `target`; evaluates to (statusword, position actual,
/// the plant's true speed in rpm).
macro_rules! cycle {
    ($m:expr, $md:expr, $group:expr, $cw:expr, $target:expr) => {{
        let sd = $group.subdevice($md, 0).expect("drive");
        {
            let mut out = sd.outputs_raw_mut();
            out[0..2].copy_from_slice(&($cw as u16).to_le_bytes());
            out[2..6].copy_from_slice(&($target as i32).to_le_bytes());
            out[6] = MODE_CSP;
        }
        // One frame per drive cycle: the frame's wire time is part of the cycle, so that the
        // master's cycle stays in phase with the drive's free-run timer (a drifting master
        // would now and then send no new target in a cycle: a CSP hold).
        let since = $m.shared.clock().now();
        $group.tx_rx($md).await.expect("tx/rx");
        $m.shared.finish_cycle(since, CYCLE_NS);
        let inp = sd.inputs_raw();
        let rpm = $m.shared.segment().drives()[0].servos[0]
            .plant
            .mech_speed_rad_s()
            / TAU
            * 60.0;
        (
            u16::from_le_bytes([inp[0], inp[1]]),
            i32::from_le_bytes([inp[2], inp[3], inp[4], inp[5]]),
            rpm,
        )
    }};
}

/// INIT → OP (free run), enable in CSP and move at [`SPEED_RPM`] for 0.3 s. Evaluates to
/// (group, the target position reached).
macro_rules! moving {
    ($m:expr, $md:expr, $writes:expr) => {{
        let group = $md
            .init_single_group::<4, 64>($m.shared.clock().now_fn())
            .await
            .expect("init");
        {
            let sd = group.subdevice($md, 0).expect("drive");
            for &(index, value) in $writes {
                let value: u32 = value;
                if index == PROFILE_DECELERATION || index == QUICK_STOP_DECELERATION {
                    sd.sdo_write(index, 0, value).await.expect("SDO");
                } else {
                    sd.sdo_write(index, 0, value as i16).await.expect("SDO");
                }
            }
        }
        let group = group
            .into_safe_op($md)
            .await
            .expect("SAFE-OP")
            .request_into_op($md)
            .await
            .expect("request OP");
        let mut sw = 0;
        for cw in [SHUTDOWN; 5]
            .into_iter()
            .chain([SWITCH_ON; 5])
            .chain([ENABLE_OPERATION; 40])
        {
            (sw, _, _) = cycle!($m, $md, group, cw, 0);
        }
        assert_eq!(sw & STATE_MASK, OPERATION_ENABLED, "enabled");
        let step = speed_counts_per_s(SPEED_RPM) * CYCLE_S;
        let mut target = 0.0;
        let mut rpm = 0.0;
        for _ in 0..300 {
            target += step;
            (_, _, rpm) = cycle!($m, $md, group, ENABLE_OPERATION, target as i32);
        }
        assert!((rpm - SPEED_RPM).abs() < 20.0, "moving at {rpm:.0} rpm");
        (group, target)
    }};
}

/// Runs cycles with controlword `cw` (target held at `target`) until the state pattern leaves
/// `while_state` (or `max` cycles); returns the speeds seen (rpm, one per cycle) and the last
/// statusword.
macro_rules! while_state {
    ($m:expr, $md:expr, $group:expr, $cw:expr, $target:expr, $mask:expr, $while_state:expr, $max:expr) => {{
        let mut speeds = Vec::new();
        let mut sw = 0;
        let mut entered = false;
        for k in 0..$max {
            let rpm;
            (sw, _, rpm) = cycle!($m, $md, $group, $cw, $target as i32);
            let inside = sw & $mask == $while_state;
            // The command's effect shows in the next frame's statusword.
            if !inside && (entered || k >= 2) {
                break;
            }
            entered |= inside;
            if entered {
                speeds.push(rpm);
            }
        }
        (speeds, sw)
    }};
}

/// The deceleration (rpm/s) that takes the motor from [`SPEED_RPM`] to standstill in
/// `cycles` cycles.
fn deceleration_rpm_per_s(counts_per_s2: f64) -> f64 {
    counts_per_s2 / CPR * 60.0
}

/// Asserts that `speeds` (rpm, one per cycle while the drive was in `state`) came down from
/// [`SPEED_RPM`] along `ramp` (6084h/6085h, increments/s²): as many cycles as the ramp takes,
/// and half the speed half-way in time.
fn assert_on_ramp(speeds: &[f64], ramp: u32, state: &str) {
    let expected_s = SPEED_RPM / deceleration_rpm_per_s(f64::from(ramp));
    let took_s = speeds.len() as f64 * CYCLE_S;
    assert!(
        (took_s - expected_s).abs() < 0.03,
        "{state} for {took_s:.3} s, the ramp takes {expected_s:.3} s"
    );
    let mid = speeds[speeds.len() / 2];
    assert!(
        (mid - SPEED_RPM / 2.0).abs() < 100.0,
        "{mid:.0} rpm half-way: {speeds:?}"
    );
}

#[test]
fn quick_stop_decelerates_on_6085h_in_quick_stop_active_then_disables() {
    // 605Ah = 2 (the standard profile's default): quick-stop ramp, then Switch On Disabled.
    const RAMP: u32 = 104_857_600; // 6000 rpm/s: 1000 rpm in 1/6 s
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let (group, target) = moving!(m, md, &[(QUICK_STOP_DECELERATION, RAMP)]);
        let (speeds, sw) = while_state!(
            m,
            md,
            group,
            QUICK_STOP,
            target,
            STATE_MASK,
            QUICK_STOP_ACTIVE,
            1_000
        );
        assert_on_ramp(&speeds, RAMP, "Quick Stop Active");
        assert_eq!(
            sw & SWITCH_ON_DISABLED_MASK,
            SWITCH_ON_DISABLED,
            "then Switch On Disabled"
        );
        let last = *speeds.last().expect("speeds");
        assert!(last.abs() <= STANDSTILL_RPM, "at rest: {last:.1} rpm");
        let gates = m.shared.segment().drives()[0].servos[0].latched().gates;
        assert!(!gates, "power stage off");
    });
}

#[test]
fn quick_stop_with_605ah_0_disables_at_once_and_the_motor_coasts() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let (group, target) = moving!(m, md, &[(QUICK_STOP_OPTION, 0)]);
        // The statusword of the cycle that took the command is the next frame's.
        let mut sw = 0;
        for _ in 0..2 {
            (sw, _, _) = cycle!(m, md, group, QUICK_STOP, target as i32);
        }
        assert_eq!(sw & SWITCH_ON_DISABLED_MASK, SWITCH_ON_DISABLED, "at once");
        let gates = m.shared.segment().drives()[0].servos[0].latched().gates;
        assert!(!gates, "power stage off");
        let mut rpm = 0.0;
        for _ in 0..100 {
            (_, _, rpm) = cycle!(m, md, group, QUICK_STOP, target as i32);
        }
        // No braking: after 0.1 s the motor still turns, slowed by friction only; the
        // standard profile's quick-stop ramp (6085h, 30000 rpm/s) would have stopped it
        // after 1/30 s.
        assert!(rpm > 0.3 * SPEED_RPM, "coasting at {rpm:.0} rpm");
    });
}

#[test]
fn quick_stop_at_the_current_limit_is_quicker_than_a_ramp_and_shows_internal_limit_active() {
    // 605Ah = 3: slow down on the current limit, then Switch On Disabled; statusword bit 11
    // "internal limit active" while the torque demand is at its limit, clear while moving
    // steadily.
    const INTERNAL_LIMIT_ACTIVE: u16 = 0x0800;
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let (group, target) = moving!(m, md, &[(QUICK_STOP_OPTION, 3)]);
        let (sw, _, _) = cycle!(m, md, group, ENABLE_OPERATION, target as i32);
        assert_eq!(sw & INTERNAL_LIMIT_ACTIVE, 0, "steady speed: no limit");
        let mut limited = 0;
        let mut cycles = 0;
        let mut sw = 0;
        for k in 0..200 {
            (sw, _, _) = cycle!(m, md, group, QUICK_STOP, target as i32);
            if sw & INTERNAL_LIMIT_ACTIVE != 0 {
                limited += 1;
            }
            if k > 2 && sw & STATE_MASK != QUICK_STOP_ACTIVE {
                cycles = k;
                break;
            }
        }
        assert_eq!(
            sw & SWITCH_ON_DISABLED_MASK,
            SWITCH_ON_DISABLED,
            "then Switch On Disabled"
        );
        // The standard profile's quick-stop ramp (6085h, 30000 rpm/s) takes 33 ms from 1000
        // rpm; the current limit needs less.
        assert!(cycles < 33, "at rest after {cycles} ms");
        assert!(limited > 0, "bit 11 while braking at the limit");
    });
}

#[test]
fn quick_stop_with_605ah_6_holds_at_rest_until_enable_operation() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let (group, target) = moving!(m, md, &[(QUICK_STOP_OPTION, 6)]);
        let mut sw = 0;
        let mut rpm = 0.0;
        for _ in 0..500 {
            (sw, _, rpm) = cycle!(m, md, group, QUICK_STOP, target as i32);
        }
        assert_eq!(
            sw & STATE_MASK,
            QUICK_STOP_ACTIVE,
            "stays in Quick Stop Active"
        );
        assert!(rpm.abs() <= STANDSTILL_RPM, "at rest: {rpm:.1} rpm");
        let gates = m.shared.segment().drives()[0].servos[0].latched().gates;
        assert!(gates, "holding: the power stage stays on");
        // Transition 16 back to Operation Enabled, at the position it holds.
        let (_, actual, _) = cycle!(m, md, group, QUICK_STOP, target as i32);
        for _ in 0..2 {
            (sw, _, _) = cycle!(m, md, group, ENABLE_OPERATION, actual);
        }
        assert_eq!(sw & STATE_MASK, OPERATION_ENABLED, "transition 16");
    });
}

#[test]
fn disable_operation_decelerates_on_6084h_in_operation_enabled_then_switches_off() {
    // The standard profile's 605Ch = 1: slow-down ramp 6084h, then transition 5.
    const RAMP: u32 = 52_428_800; // 3000 rpm/s: 1000 rpm in 1/3 s
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let (group, target) = moving!(m, md, &[(PROFILE_DECELERATION, RAMP)]);
        let (speeds, sw) = while_state!(
            m,
            md,
            group,
            SWITCH_ON,
            target,
            STATE_MASK,
            OPERATION_ENABLED,
            1_000
        );
        let expected_s = SPEED_RPM / deceleration_rpm_per_s(f64::from(RAMP));
        let took_s = speeds.len() as f64 * CYCLE_S;
        assert!(
            (took_s - expected_s).abs() < 0.04,
            "Operation Enabled for {took_s:.3} s while stopping, the ramp takes {expected_s:.3} s"
        );
        assert_eq!(sw & STATE_MASK, SWITCHED_ON, "then Switched On");
    });
}

#[test]
fn halt_decelerates_on_605dh_and_resumes_when_released() {
    // 605Dh = 1 (default): slow-down ramp 6084h, Operation Enabled throughout.
    const RAMP: u32 = 52_428_800; // 3000 rpm/s
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let (group, target) = moving!(m, md, &[(PROFILE_DECELERATION, RAMP), (HALT_OPTION, 1)]);
        let mut sw = 0;
        let mut rpm = 0.0;
        let mut actual = 0;
        let ramp_cycles = (SPEED_RPM / deceleration_rpm_per_s(f64::from(RAMP)) / CYCLE_S) as usize;
        for k in 0..ramp_cycles + 100 {
            (sw, actual, rpm) = cycle!(m, md, group, ENABLE_OPERATION | HALT, target as i32);
            assert_eq!(
                sw & STATE_MASK,
                OPERATION_ENABLED,
                "halt keeps Operation Enabled"
            );
            if k > 1 && k < ramp_cycles / 2 {
                assert_eq!(sw & TARGET_REACHED, 0, "bit 10 clear while decelerating");
            }
            if k == ramp_cycles / 2 {
                assert!(
                    (rpm - SPEED_RPM / 2.0).abs() < 100.0,
                    "half the speed half-way: {rpm:.0} rpm"
                );
            }
        }
        assert!(rpm.abs() <= STANDSTILL_RPM, "halted: {rpm:.1} rpm");
        assert_ne!(
            sw & TARGET_REACHED,
            0,
            "statusword bit 10 with halt: at rest"
        );
        // Released with the target at the halted position: the drive follows the master again.
        let step = speed_counts_per_s(SPEED_RPM) * CYCLE_S;
        let mut target = f64::from(actual);
        for _ in 0..300 {
            target += step;
            (sw, _, rpm) = cycle!(m, md, group, ENABLE_OPERATION, target as i32);
        }
        assert_eq!(sw & STATE_MASK, OPERATION_ENABLED);
        assert!(
            (rpm - SPEED_RPM).abs() < 20.0,
            "moving again at {rpm:.0} rpm"
        );
    });
}

#[test]
fn sdv3e_enable_operation_without_a_mode_is_ope() {
    // SDV3-E §5.2 9): switching to Operation Enabled while 6061h = 0 raises oPE (8800h); the
    // ESM stays in OP with AL status code 0. With a mode (8) the same sequence enables.
    // RxPDO1 (1600h): 6040h, 607Ah, 60FFh, 6071h, 6060h at byte 12; TxPDO1 starts with 6041h.
    const MODE_BYTE: usize = 12;
    const FAULT_RESET: u16 = 0x80;
    const FAULT_BIT: u16 = 0x08;
    let p = od_gen::builtin("sdv3-e").expect("profile");
    let ope = p
        .alarms
        .iter()
        .find(|a| a.display == "oPE")
        .expect("alarm oPE");
    block_on(async {
        let (m, transport) =
            tests_host::master_for(board_sim::Segment::new("sdv3-e", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = md
            .init_single_group::<4, 64>(m.shared.clock().now_fn())
            .await
            .expect("init")
            .into_safe_op(md)
            .await
            .expect("SAFE-OP")
            .request_into_op(md)
            .await
            .expect("request OP");
        let run = |cws: Vec<u16>, mode: u8| {
            let group = &group;
            let m = &m;
            async move {
                let mut sw = 0;
                for cw in cws {
                    let sd = group.subdevice(md, 0).expect("drive");
                    {
                        let mut out = sd.outputs_raw_mut();
                        out[0..2].copy_from_slice(&cw.to_le_bytes());
                        out[MODE_BYTE] = mode;
                    }
                    group.tx_rx(md).await.expect("tx/rx");
                    m.shared.advance(CYCLE_NS);
                    let inp = sd.inputs_raw();
                    sw = u16::from_le_bytes([inp[0], inp[1]]);
                }
                sw
            }
        };
        let enable = || {
            [SHUTDOWN; 5]
                .into_iter()
                .chain([SWITCH_ON; 5])
                .chain([ENABLE_OPERATION; 20])
                .collect::<Vec<u16>>()
        };
        let sw = run(enable(), 0).await;
        assert_ne!(sw & FAULT_BIT, 0, "Fault, not Operation Enabled: {sw:#06x}");
        let sd = group.subdevice(md, 0).expect("drive");
        let code: u16 = sd.sdo_read(0x603F, 0).await.expect("603Fh");
        assert_eq!(code, ope.error_code, "603Fh = oPE");
        assert_eq!(
            tests_host::al_status(md).await,
            (0x08, 0),
            "ESM stays in OP, AL status code 0"
        );
        // Fault reset, then with CSP selected the drive enables.
        run(vec![0, FAULT_RESET, FAULT_RESET, 0], 8).await;
        let sw = run(enable(), 8).await;
        assert_eq!(sw & STATE_MASK, OPERATION_ENABLED, "{sw:#06x}");
    });
}

#[test]
fn sigma_v_sd_disable_operation_ends_in_switch_on_disabled() {
    // Σ-V-SD §4.7 (5)/(6): 605Ch = 1 "slow down on slow down ramp", then Switch On Disabled
    // (CiA402 would end in Switched On).
    block_on(async {
        let (m, transport) =
            tests_host::master_for(board_sim::Segment::new("sigma-v-sd", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = csp::into_op_with_mode(&m, md, MODE_CSP as i8).await;
        let cws = [SHUTDOWN; 5]
            .into_iter()
            .chain([SWITCH_ON; 5])
            .chain([ENABLE_OPERATION; 60])
            .chain([SWITCH_ON; 60]);
        let (sw, states) = csp::hold_through(&m, md, &group, cws, STATE_MASK).await;
        assert!(states.contains(&OPERATION_ENABLED), "{states:02x?}");
        assert_eq!(
            sw & SWITCH_ON_DISABLED_MASK,
            SWITCH_ON_DISABLED,
            "disable operation ends in Switch On Disabled: {states:02x?}"
        );
        assert!(
            !states.contains(&SWITCHED_ON)
                || states.iter().position(|s| *s == SWITCHED_ON)
                    < states.iter().position(|s| *s == OPERATION_ENABLED),
            "never Switched On after Operation Enabled: {states:02x?}"
        );
    });
}

#[test]
fn sigma_v_sd_switched_on_needs_the_main_power() {
    // Σ-V-SD §3.1 *3: Ready to Switch On → Switched On only with main power on; *2/*4: main
    // power off in Switched On / Operation Enabled → Switch On Disabled. Statusword bit 4
    // "voltage enabled" shows the main power (§4.7 (2)).
    const READY_TO_SWITCH_ON: u16 = 0x21;
    const VOLTAGE_ENABLED: u16 = 0x10;
    const FAULT_BIT: u16 = 0x08;
    block_on(async {
        let (m, transport) =
            tests_host::master_for(board_sim::Segment::new("sigma-v-sd", 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = csp::into_op_with_mode(&m, md, MODE_CSP as i8).await;
        let bus = |v: f64| {
            m.shared.segment().drives_mut()[0].servos[0]
                .plant
                .set_bus_voltage(v)
        };
        let run = |cws: Vec<u16>| {
            let (m, group) = (&m, &group);
            async move { csp::hold_through(m, md, group, cws, STATE_MASK).await.0 }
        };
        bus(0.0);
        let sw = run([vec![SHUTDOWN; 10], vec![SWITCH_ON; 20]].concat()).await;
        assert_eq!(
            sw & STATE_MASK,
            READY_TO_SWITCH_ON,
            "no main power: {sw:#06x}"
        );
        assert_eq!(sw & VOLTAGE_ENABLED, 0, "bit 4 clear without main power");
        bus(48.0);
        let sw = run(vec![SWITCH_ON; 10]).await;
        assert_eq!(sw & STATE_MASK, SWITCHED_ON, "main power on: {sw:#06x}");
        assert_ne!(sw & VOLTAGE_ENABLED, 0, "bit 4 set");
        let sw = run(vec![ENABLE_OPERATION; 60]).await;
        assert_eq!(sw & STATE_MASK, OPERATION_ENABLED, "{sw:#06x}");
        bus(0.0);
        let sw = run(vec![ENABLE_OPERATION; 10]).await;
        assert_eq!(
            sw & SWITCH_ON_DISABLED_MASK,
            SWITCH_ON_DISABLED,
            "main power off: Switch On Disabled, {sw:#06x}"
        );
        assert_eq!(sw & FAULT_BIT, 0, "not a fault");
    });
}

/// The fault reaction option code object and the ramp the fault-reaction scenarios run on.
const FAULT_REACTION_OPTION: u16 = 0x605E;
const FAULT_REACTION_RAMP: u32 = 104_857_600; // 6000 rpm/s

/// Runs the moving drive on (the CSP target advancing at [`SPEED_RPM`]) through a fault until
/// its fault reaction ends; asserts Fault Reaction Active (the power stage on for the ramp) and
/// then Fault, the reaction as long as the ramp from [`SPEED_RPM`] on 6085h takes and half the
/// speed half-way, and the power stage off at the end; evaluates to 603Fh.
macro_rules! fault_reaction_ramp {
    ($m:expr, $md:expr, $group:expr, $target:expr) => {{
        const FAULT_REACTION_ACTIVE: u16 = 0x0F;
        const FAULT: u16 = 0x08;
        let step = speed_counts_per_s(SPEED_RPM) * CYCLE_S;
        let mut target = $target;
        let mut speeds = Vec::new();
        let mut sw = 0;
        let mut entered = false;
        for _ in 0..1_000 {
            target += step;
            let rpm;
            (sw, _, rpm) = cycle!($m, $md, $group, ENABLE_OPERATION, target as i32);
            let reacting = sw & SWITCH_ON_DISABLED_MASK == FAULT_REACTION_ACTIVE;
            if entered && !reacting {
                break;
            }
            if reacting && !entered {
                let gates = $m.shared.segment().drives()[0].servos[0].latched().gates;
                assert!(gates, "the power stage runs the ramp");
            }
            entered |= reacting;
            if entered {
                speeds.push(rpm);
            }
        }
        assert!(entered, "Fault Reaction Active: {sw:#06x}");
        assert_eq!(sw & SWITCH_ON_DISABLED_MASK, FAULT, "then Fault: {sw:#06x}");
        assert_on_ramp(&speeds, FAULT_REACTION_RAMP, "Fault Reaction Active");
        let gates = $m.shared.segment().drives()[0].servos[0].latched().gates;
        assert!(!gates, "power stage off");
        let sd = $group.subdevice($md, 0).expect("drive");
        sd.sdo_read::<u16>(0x603F, 0).await.expect("603Fh")
    }};
}

/// CiA402 fault reaction (605Eh = 2, quick-stop ramp) on a following error: the motor is still
/// under control, so the drive stays in Fault Reaction Active while it decelerates along 6085h,
/// then Fault (603Fh = 8611h) with the power stage off. (A fault of the power stage or the
/// sensors cuts the gates at once instead.)
#[test]
fn a_following_error_fault_decelerates_on_the_fault_reaction_ramp() {
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let (group, target) = moving!(
            m,
            md,
            &[
                (QUICK_STOP_DECELERATION, FAULT_REACTION_RAMP),
                (FAULT_REACTION_OPTION, 2)
            ]
        );
        // A following-error window of one increment with no timeout: the next lag trips it.
        let sd = group.subdevice(md, 0).expect("drive");
        sd.sdo_write(0x6066, 0, 0u16).await.expect("6066h");
        sd.sdo_write(0x6065, 0, 1u32).await.expect("6065h");
        assert_eq!(fault_reaction_ramp!(m, md, group, target), 0x8611);
    });
}

/// CiA402 fault reaction (605Eh = 2, quick-stop ramp) on a thermal fault: the power stage
/// over its temperature (`drive_over_temperature`, 603Fh = 4210h) leaves the motor under
/// control (heat builds over seconds), so the drive decelerates it along 6085h in Fault
/// Reaction Active and then goes to Fault with the power stage off, as on a following error.
#[test]
fn a_drive_over_temperature_fault_decelerates_on_the_fault_reaction_ramp() {
    /// The standard profile's `drive_over_temperature` code: "excess temperature device".
    const DRIVE_OVER_TEMPERATURE: u16 = 0x4210;
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let (group, target) = moving!(
            m,
            md,
            &[
                (QUICK_STOP_DECELERATION, FAULT_REACTION_RAMP),
                (FAULT_REACTION_OPTION, 2)
            ]
        );
        tests_host::vendor::overheat_power_stage(&m, 0);
        assert_eq!(
            fault_reaction_ramp!(m, md, group, target),
            DRIVE_OVER_TEMPERATURE
        );
    });
}
