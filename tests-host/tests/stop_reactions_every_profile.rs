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

use board_sim::inproc::InProcess;
use ethercrab::MainDevice;
use od_gen::Profile;
use tests_host::cia402::{
    self, FAULT, OPERATION_ENABLED, QUICK_STOP_ACTIVE, READY_TO_SWITCH_ON, SWITCHED_ON,
    SWITCH_ON_DISABLED,
};
use tests_host::stops::{self, Sample, Stop};
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
/// A stop at the current or voltage limit: at least twice the steepest ramp.
const AT_LIMIT: Stop = Stop::Limit(2.0 * QUICK_STOP_RAMP_REV_S2);
/// Cycles watched after the command: the slowest ramp takes 0.5 s.
const STOP_CYCLES: usize = 800;

/// CiA402 controlwords (Table 5) and the halt bit.
const SHUTDOWN: u16 = 0x06;
const DISABLE_OPERATION: u16 = 0x07;
const ENABLE_OPERATION: u16 = 0x0F;
const QUICK_STOP: u16 = 0x02;
const HALT: u16 = 0x0100;

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
        (Cause::Halt, 3 | 4) => (AT_LIMIT, true),
        (Cause::Halt, _) => (None, true),
        (_, 0) => (Coast, false),
        (_, 1) => (Ramp(PROFILE_RAMP_REV_S2), false),
        (Cause::QuickStop | Cause::Fault, 2) => (Ramp(QUICK_STOP_RAMP_REV_S2), false),
        (Cause::QuickStop | Cause::Fault, 3 | 4) => (AT_LIMIT, false),
        (Cause::QuickStop, 5) => (Ramp(PROFILE_RAMP_REV_S2), true),
        (Cause::QuickStop, 6) => (Ramp(QUICK_STOP_RAMP_REV_S2), true),
        (Cause::QuickStop, 7 | 8) => (AT_LIMIT, true),
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

async fn cycle(
    m: &InProcess,
    md: &MainDevice<'_>,
    group: &DcGroup,
    axis: usize,
    (cw, velocity): (u16, i32),
) -> Sample {
    let inputs = vendor::exchange_dc_command(m, md, group, (cw, CSV, velocity), CYCLE_NS).await;
    Sample::of(m, axis, vendor::u16_at(&inputs, 0))
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
                    .and_then(|samples| {
                        stops::check(&samples, (stop_kind, end, via), (SPEED_REV_S, CYCLE_S))
                    });
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
