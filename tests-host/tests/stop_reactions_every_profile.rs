//! Every stop reaction of every profile, end to end: for each option-code object 605Ah–605Eh a
//! profile has, and each value its manual allows, ethercrab runs the simulated motor at 600 rpm
//! in cyclic synchronous velocity (DC SYNC0 at 1 ms; 6040h, 6060h, 60FFh / 6041h, 6061h, 606Ch
//! mapped), sets the code, the slow-down ramp 6084h and the quick-stop ramp 6085h in the
//! profile's units, then commands the stop: quick stop (605Ah), shutdown (605Bh), disable
//! operation (605Ch), halt (605Dh) or a fault, the power stage over its temperature (605Eh).
//!
//! The expected reaction is CiA402's (IEC 61800-7-201 §6.3.4–6.3.8), written here from its
//! option-code tables, with each manual's deviations:
//!
//! | profile | deviation | manual |
//! |---|---|---|
//! | gha-e | 605Bh = 2 and 605Ch = 2 stop on 6085h; a fault stops by its type whatever 605Eh (every fault here: at once) | §5.7.2 |
//! | sigma-v-sd, sigma-v-sd-2axis | shutdown and disable operation end in Switch On Disabled | §4.7 (5), (6) |
//!
//! A code CiA402 reserves and the manual does not define disables the drive function (the motor
//! coasts), as a drive without the object does; for a halt it is no stop at all.
//!
//! Each run checks the deceleration the motor actually had (from 80 % to 20 % of the speed,
//! within 15 % of the ramp; at the current or voltage limit at least twice the steepest ramp;
//! coasting: the power stage off at once and the motor still turning), the power stage during
//! and after the stop, and the state the drive ends in.

use std::f64::consts::TAU;

use board_sim::inproc::InProcess;
use ethercrab::MainDevice;
use od_gen::Profile;
use tests_host::cia402::{
    self, FAULT, OPERATION_ENABLED, QUICK_STOP_ACTIVE, READY_TO_SWITCH_ON, SWITCHED_ON,
    SWITCH_ON_DISABLED,
};
use tests_host::vendor::{self, DcGroup, Sdo};
use tests_host::{block_on, master_for, units};

const CYCLE_NS: u64 = 1_000_000;
const CYCLE_S: f64 = 1e-3;
const CSV: i8 = cia402::CYCLIC_SYNCHRONOUS_VELOCITY;
/// The speed the motor runs at when the stop comes.
const SPEED_REV_S: f64 = 10.0;
/// The slow-down ramp 6084h and the quick-stop ramp 6085h.
const PROFILE_RAMP_REV_S2: f64 = 20.0;
const QUICK_STOP_RAMP_REV_S2: f64 = 40.0;
/// A measured deceleration within this fraction of its ramp.
const RAMP_TOLERANCE: f64 = 0.15;
/// The drive's standstill level, rev/s (20 rpm).
const STANDSTILL_REV_S: f64 = 20.0 / 60.0;
/// Cycles watched after the command: the slowest ramp takes 0.5 s.
const STOP_CYCLES: usize = 800;

/// CiA402 controlwords (Table 5) and the halt bit.
const SHUTDOWN: u16 = 0x06;
const DISABLE_OPERATION: u16 = 0x07;
const ENABLE_OPERATION: u16 = 0x0F;
const QUICK_STOP: u16 = 0x02;
const HALT: u16 = 0x0100;

/// What brings the motor to rest.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Stop {
    /// The power stage off at once.
    Coast,
    /// Along a ramp, rev/s².
    Ramp(f64),
    /// At the current or the voltage limit.
    Limit,
    /// No stop (a halt code without a meaning).
    None,
}

/// The stop commands, one per option-code object.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Cause {
    QuickStop,
    Shutdown,
    DisableOperation,
    Halt,
    Fault,
}

impl Cause {
    const ALL: [(u16, Cause); 5] = [
        (0x605A, Cause::QuickStop),
        (0x605B, Cause::Shutdown),
        (0x605C, Cause::DisableOperation),
        (0x605D, Cause::Halt),
        (0x605E, Cause::Fault),
    ];

    /// The controlword that commands it (a fault runs on enable operation).
    fn controlword(self) -> u16 {
        match self {
            Cause::QuickStop => QUICK_STOP,
            Cause::Shutdown => SHUTDOWN,
            Cause::DisableOperation => DISABLE_OPERATION,
            Cause::Halt => ENABLE_OPERATION | HALT,
            Cause::Fault => ENABLE_OPERATION,
        }
    }
}

/// A manual's deviations from CiA402's stops.
#[derive(Clone, Copy, Debug, Default)]
struct Deviations {
    /// (object, code, ramp rev/s²) the manual defines where CiA402 reserves the code.
    codes: &'static [(u16, i16, f64)],
    /// A fault stops at once whatever 605Eh.
    fault_ignores_605e: bool,
    /// Shutdown and disable operation end in Switch On Disabled.
    stops_end_switched_off: bool,
}

/// The expected reaction: how the motor stops, and the state the drive ends in.
fn expected(cause: Cause, code: i16, d: &Deviations) -> (Stop, (u16, u16)) {
    use Stop::*;
    let object = Cause::ALL
        .iter()
        .find(|(_, c)| *c == cause)
        .map(|(o, _)| *o);
    let vendor = d
        .codes
        .iter()
        .find(|(o, c, _)| Some(*o) == object && *c == code)
        .map(|(_, _, ramp)| Ramp(*ramp));
    // CiA402's option-code tables.
    let (cia402, hold) = match (cause, code) {
        (Cause::Halt, 1) => (Ramp(PROFILE_RAMP_REV_S2), true),
        (Cause::Halt, 2) => (Ramp(QUICK_STOP_RAMP_REV_S2), true),
        (Cause::Halt, 3 | 4) => (Limit, true),
        (Cause::Halt, _) => (None, true),
        (_, 0) => (Coast, false),
        (_, 1) => (Ramp(PROFILE_RAMP_REV_S2), false),
        (Cause::QuickStop | Cause::Fault, 2) => (Ramp(QUICK_STOP_RAMP_REV_S2), false),
        (Cause::QuickStop | Cause::Fault, 3 | 4) => (Limit, false),
        (Cause::QuickStop, 5) => (Ramp(PROFILE_RAMP_REV_S2), true),
        (Cause::QuickStop, 6) => (Ramp(QUICK_STOP_RAMP_REV_S2), true),
        (Cause::QuickStop, 7 | 8) => (Limit, true),
        // Reserved: the drive function is disabled.
        _ => (Coast, false),
    };
    let stop = match cause {
        Cause::Fault if d.fault_ignores_605e => Coast,
        _ => vendor.unwrap_or(cia402),
    };
    let end = match cause {
        Cause::QuickStop if hold && stop != Coast => QUICK_STOP_ACTIVE,
        Cause::QuickStop => SWITCH_ON_DISABLED,
        // From Switch On Disabled the shutdown command the master holds is transition 2.
        Cause::Shutdown if d.stops_end_switched_off => READY_TO_SWITCH_ON,
        Cause::DisableOperation if d.stops_end_switched_off => SWITCH_ON_DISABLED,
        Cause::Shutdown => READY_TO_SWITCH_ON,
        Cause::DisableOperation => SWITCHED_ON,
        Cause::Halt => OPERATION_ENABLED,
        Cause::Fault => FAULT,
    };
    (stop, end)
}

/// A profile under test.
struct Case {
    profile: &'static str,
    axis: usize,
    deviations: Deviations,
}

impl Case {
    /// Axis 1's object `index` on the axis under test.
    fn object(&self, index: u16) -> u16 {
        vendor::axis_object(index, self.axis)
    }
}

/// What one cycle brought back, and the motor and power stage of the axis.
#[derive(Clone, Copy, Debug)]
struct Sample {
    statusword: u16,
    rev_s: f64,
    gates: bool,
}

impl Sample {
    fn is(&self, state: cia402::State) -> bool {
        cia402::is(self.statusword, state)
    }
}

async fn cycle(
    m: &InProcess,
    md: &MainDevice<'_>,
    group: &DcGroup,
    axis: usize,
    (cw, velocity): (u16, i32),
) -> Sample {
    let inputs = vendor::exchange_dc_command(m, md, group, (cw, CSV, velocity), CYCLE_NS).await;
    let segment = m.shared.segment();
    let servo = &segment.drives()[0].servos[axis];
    Sample {
        statusword: vendor::u16_at(&inputs, 0),
        rev_s: servo.plant.mech_speed_rad_s() / TAU,
        gates: servo.latched().gates,
    }
}

/// The ramps and the code (after the PDOs of [`vendor::into_op_dc_velocity`]).
fn setup(case: &Case, profile: &Profile, object: u16, code: i16) -> Vec<Sdo> {
    let o = |index| case.object(index);
    let mut sdos = Vec::new();
    for (index, ramp) in [
        (0x6084, PROFILE_RAMP_REV_S2),
        (0x6085, QUICK_STOP_RAMP_REV_S2),
    ] {
        if profile.entry(o(index), 0).is_some() {
            sdos.push(Sdo::U32(o(index), 0, units::acceleration(profile, ramp)));
        }
    }
    sdos.push(Sdo::I16(o(object), 0, code));
    sdos
}

/// One stop: the motor brought to speed, then `cause` with `code`; the samples from the
/// command on, or what went wrong before it.
async fn stop(
    case: &Case,
    profile: &Profile,
    cause: Cause,
    code: i16,
) -> Result<Vec<Sample>, String> {
    let object = Cause::ALL
        .iter()
        .find(|(_, c)| *c == cause)
        .map_or(0, |(o, _)| *o);
    let (m, transport) = master_for(board_sim::Segment::new(case.profile, 1).expect("profile"));
    tokio::task::spawn_local(transport);
    let md: &MainDevice<'_> = &m.maindevice;
    let axis = case.axis;
    let setup = setup(case, profile, object, code);
    let group = vendor::into_op_dc_velocity(&m, md, (axis, &setup), CSV, CYCLE_NS).await;
    let mut s = cycle(&m, md, &group, axis, (0, 0)).await;
    for cw in vendor::enable_sequence(20) {
        s = cycle(&m, md, &group, axis, (cw, 0)).await;
    }
    if !s.is(OPERATION_ENABLED) {
        return Err(format!("not enabled: {:#06x}", s.statusword));
    }
    // Up to speed in 0.25 s, then 0.1 s there.
    let full = units::velocity(profile, SPEED_REV_S) as f64;
    for k in 0..350 {
        let v = full * (f64::from(k).min(250.0) / 250.0);
        s = cycle(&m, md, &group, axis, (ENABLE_OPERATION, v as i32)).await;
    }
    if (s.rev_s - SPEED_REV_S).abs() > 0.3 {
        return Err(format!("running at {:.2} rev/s", s.rev_s));
    }
    if cause == Cause::Fault {
        vendor::overheat_power_stage(&m, axis);
    }
    let command = (cause.controlword(), full as i32);
    let mut samples = Vec::with_capacity(STOP_CYCLES);
    for _ in 0..STOP_CYCLES {
        samples.push(cycle(&m, md, &group, axis, command).await);
    }
    Ok(samples)
}

/// The deceleration from 80 % to 20 % of the speed, rev/s², or how far it got.
fn deceleration(samples: &[Sample]) -> Result<f64, String> {
    let at = |fraction: f64| {
        samples
            .iter()
            .position(|s| s.rev_s <= fraction * SPEED_REV_S)
            .ok_or_else(|| {
                format!(
                    "never below {:.0} % of the speed (ends at {:.2} rev/s)",
                    fraction * 100.0,
                    samples.last().map_or(0.0, |s| s.rev_s)
                )
            })
    };
    let (high, low) = (at(0.8)?, at(0.2)?);
    let seconds = ((low - high).max(1)) as f64 * CYCLE_S;
    Ok(0.6 * SPEED_REV_S / seconds)
}

/// What is wrong with a stop, if anything.
fn check(
    samples: &[Sample],
    stop: Stop,
    end: (u16, u16),
    via: Option<(u16, u16)>,
) -> Result<(), String> {
    let last = samples.last().ok_or("no samples")?;
    if let Some(state) = via {
        if !samples.iter().any(|s| s.is(state)) {
            return Err(format!("never in {:#06x} under {:#06x}", state.1, state.0));
        }
    }
    match stop {
        Stop::None => {
            if (last.rev_s - SPEED_REV_S).abs() > 0.3 || !last.gates {
                return Err(format!("stopped: {:.2} rev/s", last.rev_s));
            }
        }
        Stop::Coast => {
            // The power stage off in the cycle the drive leaves Operation Enabled (a command at
            // once, a fault when it trips), and from then on; friction only.
            let left = samples
                .iter()
                .position(|s| !s.is(OPERATION_ENABLED))
                .ok_or("never left Operation Enabled")?;
            if samples.iter().skip(left + 1).any(|s| s.gates) {
                return Err("the power stage stays on".into());
            }
            let later = samples[(left + 100).min(samples.len() - 1)].rev_s;
            if later < 0.3 * SPEED_REV_S {
                return Err(format!("braked to {later:.2} rev/s in 0.1 s: not coasting"));
            }
        }
        Stop::Ramp(ramp) => {
            let d = deceleration(samples)?;
            if (d - ramp).abs() > RAMP_TOLERANCE * ramp {
                return Err(format!("decelerated at {d:.1} rev/s², the ramp is {ramp}"));
            }
        }
        Stop::Limit => {
            let d = deceleration(samples)?;
            if d < 2.0 * QUICK_STOP_RAMP_REV_S2 {
                return Err(format!("decelerated at only {d:.1} rev/s² at the limit"));
            }
        }
    }
    if stop != Stop::Coast && stop != Stop::None {
        // Under power until at rest.
        if let Some(s) = samples
            .iter()
            .find(|s| !s.gates && s.rev_s.abs() > STANDSTILL_REV_S * 2.0)
        {
            return Err(format!("power stage off at {:.2} rev/s", s.rev_s));
        }
        if last.rev_s.abs() > STANDSTILL_REV_S {
            return Err(format!("not at rest: {:.2} rev/s", last.rev_s));
        }
        // Held (quick stop 5-8, halt) or disabled.
        let held = end == QUICK_STOP_ACTIVE || end == OPERATION_ENABLED;
        if last.gates != held {
            return Err(format!(
                "power stage {} at rest",
                if last.gates { "on" } else { "off" }
            ));
        }
    }
    if !last.is(end) {
        return Err(format!(
            "ends in statusword {:#06x}, expected {:#06x} under {:#06x}",
            last.statusword, end.1, end.0
        ));
    }
    Ok(())
}

/// Every value each option-code object of the profile allows (its range, or its list).
fn codes(profile: &Profile, index: u16) -> Vec<i16> {
    let Some(entry) = profile.entry(index, 0) else {
        return Vec::new();
    };
    if !entry.allowed.is_empty() {
        return entry.allowed.iter().map(|v| *v as i16).collect();
    }
    let bound = |bytes: &[u8], none: i16| {
        bytes
            .get(..2)
            .map_or(none, |b| i16::from_le_bytes([b[0], b[1]]))
    };
    let (min, max) = (bound(&entry.min, -1), bound(&entry.max, 8));
    // CiA402 defines at most -1..8; manufacturer codes below 0 are beyond this test.
    (min.max(0)..=max.min(8)).collect()
}

fn every_stop(case: Case) {
    let profile = od_gen::builtin(case.profile).expect("profile");
    let mut failures = Vec::new();
    let mut runs = 0;
    block_on(async {
        for (index, cause) in Cause::ALL {
            for code in codes(&profile, case.object(index)) {
                runs += 1;
                let (stop_kind, end) = expected(cause, code, &case.deviations);
                // The Σ-V-SD's shutdown passes Switch On Disabled.
                let via = (cause == Cause::Shutdown && case.deviations.stops_end_switched_off)
                    .then_some(SWITCH_ON_DISABLED);
                let result = stop(&case, &profile, cause, code)
                    .await
                    .and_then(|samples| check(&samples, stop_kind, end, via));
                if let Err(e) = result {
                    failures.push(format!("{index:04X}h = {code} ({stop_kind:?}): {e}"));
                }
            }
        }
    });
    assert!(runs > 0, "{}: no option-code object", case.profile);
    assert!(
        failures.is_empty(),
        "{}: {} of {runs} stops failed:\n{}",
        case.profile,
        failures.len(),
        failures.join("\n")
    );
}

#[test]
fn standard_every_stop_reaction() {
    every_stop(Case {
        profile: "standard",
        axis: 0,
        deviations: Deviations::default(),
    });
}

#[test]
fn gha_e_every_stop_reaction() {
    every_stop(Case {
        profile: "gha-e",
        axis: 0,
        deviations: Deviations {
            codes: &[
                (0x605B, 2, QUICK_STOP_RAMP_REV_S2),
                (0x605C, 2, QUICK_STOP_RAMP_REV_S2),
            ],
            fault_ignores_605e: true,
            ..Deviations::default()
        },
    });
}

#[test]
fn rse_every_stop_reaction() {
    every_stop(Case {
        profile: "rse",
        axis: 0,
        deviations: Deviations::default(),
    });
}

#[test]
fn sdv3_e_every_stop_reaction() {
    every_stop(Case {
        profile: "sdv3-e",
        axis: 0,
        deviations: Deviations::default(),
    });
}

#[test]
fn osd_g_e_every_stop_reaction() {
    every_stop(Case {
        profile: "osd-g-e",
        axis: 0,
        deviations: Deviations::default(),
    });
}

const SIGMA_V_SD: Deviations = Deviations {
    codes: &[],
    fault_ignores_605e: false,
    stops_end_switched_off: true,
};

#[test]
fn sigma_v_sd_every_stop_reaction() {
    every_stop(Case {
        profile: "sigma-v-sd",
        axis: 0,
        deviations: SIGMA_V_SD,
    });
}

#[test]
fn sigma_v_sd_2axis_axis_2_every_stop_reaction() {
    every_stop(Case {
        profile: "sigma-v-sd-2axis",
        axis: 1,
        deviations: SIGMA_V_SD,
    });
}
