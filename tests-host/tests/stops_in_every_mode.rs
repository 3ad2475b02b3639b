//! Stops outside cyclic synchronous velocity, end to end (ethercrab, DC SYNC0 at 1 ms; 6040h,
//! 6060h, 60FFh / 6041h, 6061h, 606Ch mapped): the motor is brought to 10 rev/s in CSV, handed to
//! the mode under test (profile position and homing take over with their own move at that
//! speed; profile velocity runs to the same target; the torque modes command the torque the
//! speed loop held, so the motor runs on), then the stop is commanded in that mode. The deceleration the motor had, the
//! power stage and the end state must be CiA402's with each manual's deviations:
//!
//! | profile | stop | modes | expected | source |
//! |---|---|---|---|---|
//! | standard | quick stop, 605Ah = 2 | PP, PV, HM, PT, CST | quick-stop ramp 6085h, Switch On Disabled | CiA402 §6.3.4 |
//! | standard | halt, 605Dh = 1 | PP, PV | slow-down ramp 6084h, Operation Enabled | CiA402 §6.3.7 |
//! | standard, sigma-v-sd | halt, 605Dh = 1 | HM | the homing acceleration 609Ah (the slow-down ramp of homing) | CiA402; Σ-V-SD §6.4 |
//! | sigma-v-sd | quick stop, 605Ah = 2 | PT, CST | the power stage off at once ("always code 0") | §6.4 |
//! | sigma-v-sd | quick stop, 605Ah = 2 | PV | quick-stop ramp 6085h | §6.4 |
//! | sigma-v-sd | halt, 605Dh = 1 | CST | the torque demand to zero: powered, the motor runs out under its friction (faster than the slow-down ramp), Operation Enabled | §6.4 |
//! | rse | halt without 605Dh | PV, CSV | as 605Dh = 1: slow-down ramp 6084h, Operation Enabled | 6.2 |
//! | gha-e, sdv3-e | halt | CSV | ignored: the motor runs on | GHA-E §5.3.2 "this bit is invalid"; SDV3-E §7.2 bit 8 reserved |

use board_sim::inproc::InProcess;
use ethercrab::MainDevice;
use od_gen::Profile;
use tests_host::cia402::{self, OPERATION_ENABLED, SWITCH_ON_DISABLED};
use tests_host::stops::{self, Sample, Stop};
use tests_host::vendor::{self, DcGroup, Sdo, ENABLE_OPERATION};
use tests_host::{block_on, master_for, units};

const CYCLE_NS: u64 = 1_000_000;
const CYCLE_S: f64 = 1e-3;
const PP: i8 = 1;
const PV: i8 = 3;
const PT: i8 = 4;
const HM: i8 = cia402::HOMING;
const CSV: i8 = cia402::CYCLIC_SYNCHRONOUS_VELOCITY;
const CST: i8 = 10;
const SPEED_REV_S: f64 = 10.0;
/// 6084h, 6085h and 609Ah: three different ramps, so that the one taken shows.
const PROFILE_RAMP_REV_S2: f64 = 20.0;
const QUICK_STOP_RAMP_REV_S2: f64 = 40.0;
const HOMING_RAMP_REV_S2: f64 = 60.0;
/// Homing method 2 (positive limit switch and index pulse): with no switch on the simulated
/// axis the search runs on at 6099h:01.
const SEARCH_POSITIVE: i8 = 2;
/// A profile-position target 1000 revolutions away.
const FAR_REV: f64 = 1000.0;
/// Cycles watched after the command: the slowest ramp takes 0.5 s.
const STOP_CYCLES: usize = 800;

const QUICK_STOP: u16 = 0x02;
const HALT: u16 = 0x0100;
/// Profile position "new set-point", homing "start".
const BIT_4: u16 = 1 << 4;

/// A stop to command and what the manual says it does.
struct Case {
    profile: &'static str,
    mode: i8,
    /// The option code to set (object, code), if any.
    code: Option<(u16, i16)>,
    /// Quick stop or halt.
    controlword: u16,
    stop: Stop,
    end: cia402::State,
}

async fn cycle(
    m: &InProcess,
    md: &MainDevice<'_>,
    group: &DcGroup,
    command: (u16, i8, i32),
) -> Sample {
    let inputs = vendor::exchange_dc_command(m, md, group, command, CYCLE_NS).await;
    Sample::of(m, 0, vendor::u16_at(&inputs, 0))
}

/// The ramps, the mode's move and the option code, in the profile's units (the objects it has).
fn setup(profile: &Profile, case: &Case) -> Vec<Sdo> {
    let has = |index| profile.entry(index, 0).is_some();
    let speed = units::velocity(profile, SPEED_REV_S);
    let mut sdos = Vec::new();
    for (index, ramp) in [
        (0x6083, 4.0 * PROFILE_RAMP_REV_S2),
        (0x6084, PROFILE_RAMP_REV_S2),
        (0x6085, QUICK_STOP_RAMP_REV_S2),
        (0x609A, HOMING_RAMP_REV_S2),
    ] {
        if has(index) {
            sdos.push(Sdo::U32(index, 0, units::acceleration(profile, ramp)));
        }
    }
    if has(0x607F) {
        sdos.push(Sdo::U32(0x607F, 0, 2 * speed));
    }
    match case.mode {
        PP => {
            let far = FAR_REV * units::COUNTS_PER_REV / units::increments_per_unit(profile);
            sdos.push(Sdo::I32(0x607A, 0, far as i32));
            sdos.push(Sdo::U32(0x6081, 0, speed));
        }
        HM => {
            sdos.push(Sdo::I8(0x6098, 0, SEARCH_POSITIVE));
            sdos.push(Sdo::U32(0x6099, 1, speed));
        }
        _ => {}
    }
    if let Some((object, code)) = case.code {
        sdos.push(Sdo::I16(object, 0, code));
    }
    sdos
}

/// The motor at speed in CSV, handed to the case's mode, then the stop: the speed when it was
/// commanded and the samples from then on.
async fn run(profile: &Profile, case: &Case) -> Result<(f64, Vec<Sample>), String> {
    let (m, transport) = master_for(board_sim::Segment::new(case.profile, 1).expect("profile"));
    tokio::task::spawn_local(transport);
    let md: &MainDevice<'_> = &m.maindevice;
    let group =
        vendor::into_op_dc_velocity(&m, md, (0, &setup(profile, case)), CSV, CYCLE_NS).await;
    let mut s = cycle(&m, md, &group, (0, CSV, 0)).await;
    for cw in vendor::enable_sequence(20) {
        s = cycle(&m, md, &group, (cw, CSV, 0)).await;
    }
    if !s.is(OPERATION_ENABLED) {
        return Err(format!("not enabled: {:#06x}", s.statusword));
    }
    let full = units::target_velocity(profile, SPEED_REV_S);
    for k in 0..350 {
        let v = f64::from(full) * (f64::from(k).min(250.0) / 250.0);
        cycle(&m, md, &group, (ENABLE_OPERATION, CSV, v as i32)).await;
    }
    let mode = case.mode;
    if mode == PT || mode == CST {
        // The torque the speed loop holds at speed (the plant's friction) becomes the target
        // torque, so that the motor runs on in the torque mode.
        let sd = group.subdevice(md, 0).expect("drive");
        let torque: i16 = sd
            .sdo_read(0x6077, 0)
            .await
            .map_err(|e| format!("6077h: {e}"))?;
        sd.sdo_write(0x6071, 0, torque)
            .await
            .map_err(|e| format!("6071h: {e}"))?;
    }
    // The mode takes over (its set-point handshake or start with bit 4 set).
    let running = match mode {
        PP | HM => ENABLE_OPERATION | BIT_4,
        _ => ENABLE_OPERATION,
    };
    let value = if mode == PV || mode == CSV { full } else { 0 };
    for _ in 0..100 {
        s = cycle(&m, md, &group, (running, mode, value)).await;
    }
    if s.rev_s.abs() < 0.8 * SPEED_REV_S || !s.is(OPERATION_ENABLED) {
        return Err(format!(
            "mode {mode} not running: {:.2} rev/s, {:#06x}",
            s.rev_s, s.statusword
        ));
    }
    let speed = s.rev_s.abs();
    let command = (running & !ENABLE_OPERATION | case.controlword, mode, value);
    let mut samples = Vec::with_capacity(STOP_CYCLES);
    for _ in 0..STOP_CYCLES {
        samples.push(cycle(&m, md, &group, command).await);
    }
    Ok((speed, samples))
}

fn stops(cases: &[Case]) {
    let mut failures = Vec::new();
    block_on(async {
        for case in cases {
            let profile = od_gen::builtin(case.profile).expect("profile");
            let result = run(&profile, case).await.and_then(|(speed, samples)| {
                stops::check(&samples, (case.stop, case.end, None), (speed, CYCLE_S))
            });
            if let Err(e) = result {
                failures.push(format!(
                    "{} mode {} cw {:#06x} ({:?}): {e}",
                    case.profile, case.mode, case.controlword, case.stop
                ));
            }
        }
    });
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// A quick stop with 605Ah = 2.
fn quick_stop(profile: &'static str, mode: i8, stop: Stop) -> Case {
    Case {
        profile,
        mode,
        code: Some((0x605A, 2)),
        controlword: QUICK_STOP,
        stop,
        end: SWITCH_ON_DISABLED,
    }
}

/// A halt (bit 8 with enable operation), with 605Dh = 1 where the profile has it.
fn halt(profile: &'static str, mode: i8, stop: Stop) -> Case {
    let has_605d = od_gen::builtin(profile)
        .expect("profile")
        .entry(0x605D, 0)
        .is_some();
    Case {
        profile,
        mode,
        code: has_605d.then_some((0x605D, 1)),
        controlword: ENABLE_OPERATION | HALT,
        stop,
        end: OPERATION_ENABLED,
    }
}

#[test]
fn standard_quick_stop_ramps_on_6085h_in_every_mode() {
    let ramp = Stop::Ramp(QUICK_STOP_RAMP_REV_S2);
    stops(&[PP, PV, HM, PT, CST].map(|mode| quick_stop("standard", mode, ramp)));
}

#[test]
fn standard_halt_ramps_on_6084h_and_in_homing_on_609ah() {
    stops(&[
        halt("standard", PP, Stop::Ramp(PROFILE_RAMP_REV_S2)),
        halt("standard", PV, Stop::Ramp(PROFILE_RAMP_REV_S2)),
        halt("standard", HM, Stop::Ramp(HOMING_RAMP_REV_S2)),
    ]);
}

#[test]
fn sigma_v_sd_torque_modes_stop_at_once_and_halt_in_homing_on_609ah() {
    stops(&[
        quick_stop("sigma-v-sd", PT, Stop::Coast),
        quick_stop("sigma-v-sd", CST, Stop::Coast),
        quick_stop("sigma-v-sd", PV, Stop::Ramp(QUICK_STOP_RAMP_REV_S2)),
        // Zero torque: the plant's friction decelerates the motor faster than 6084h would.
        halt("sigma-v-sd", CST, Stop::Limit(2.0 * PROFILE_RAMP_REV_S2)),
        halt("sigma-v-sd", HM, Stop::Ramp(HOMING_RAMP_REV_S2)),
    ]);
}

#[test]
fn rse_halts_on_6084h_without_605dh() {
    stops(&[
        halt("rse", PV, Stop::Ramp(PROFILE_RAMP_REV_S2)),
        halt("rse", CSV, Stop::Ramp(PROFILE_RAMP_REV_S2)),
    ]);
}

#[test]
fn gha_e_and_sdv3_e_ignore_halt() {
    stops(&[
        halt("gha-e", CSV, Stop::None),
        halt("sdv3-e", CSV, Stop::None),
    ]);
}
