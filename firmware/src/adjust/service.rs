//! The adjusting service's sequence (Σ-V-SD §4.5 (8) "How to Send a Command for Adjustment") as
//! a decision function: a request (or the passing of time, or the end of an action) and the
//! current [`Phase`] give the next phase, the status and reply to publish and the action to
//! start. It knows no objects and no axis: [`super::AdjustingService`] binds it to both.
//!
//! | step | request (CCMD = 01h write, CSIZE = 2) | accepted in | then |
//! |---|---|---|---|
//! | 1 | CADDRESS 2000h, CDATA = request code | any phase but executing | selected |
//! | 2 | CADDRESS 2001h, CDATA 0002h (prepare) | selected, if the adjustment needs it | prepared |
//! | 3 | CADDRESS 2001h, CDATA 0001h (execute) | selected (no preparation needed) or prepared, and the adjustment's conditions hold | executing |
//! | 4 | CADDRESS 2000h, CDATA 0000h (abort) | any phase | idle |
//!
//! An accepted step answers status 1 (completed, no error, with the echo as response data);
//! anything else answers status 2 (error, no response data) and leaves the phase as it was, except
//! during an execution, which a request other than abort does not disturb (status stays 255,
//! "executing"). The execution ends with status 1, or 2 when the action failed or did not end
//! within the time limit (5 s); a selection with no request for the abort time (10 s) is
//! aborted ("if no command can be received in 10 seconds after step 1").

use super::frame::{self, status, Ccmd, Request, FRAME_LEN};
use super::{Action, CommandSpec, ServiceSpec};

/// CADDRESS of step 1 and 4: the request code (0 aborts).
pub const ADDRESS_REQUEST_CODE: u32 = 0x2000;
/// CADDRESS of steps 2 and 3: the execution control.
pub const ADDRESS_EXECUTION: u32 = 0x2001;
/// CDATA at [`ADDRESS_REQUEST_CODE`]: abort.
pub const DATA_ABORT: u32 = 0x0000;
/// CDATA at [`ADDRESS_EXECUTION`]: execute.
pub const DATA_EXECUTE: u32 = 0x0001;
/// CDATA at [`ADDRESS_EXECUTION`]: prepare.
pub const DATA_PREPARE: u32 = 0x0002;

/// Where the sequence stands.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Phase {
    /// No adjustment selected.
    #[default]
    Idle,
    /// Step 1 done (and step 2 when `prepared`), at `last_ms`: waiting for the next step.
    Selected {
        /// The selected adjustment (index into the service's commands).
        command: usize,
        /// Step 2 done.
        prepared: bool,
        /// When the last step was accepted (board time, ms).
        last_ms: u64,
    },
    /// Step 3 done at `started_ms`: the action runs.
    Executing {
        /// The running adjustment.
        command: usize,
        /// When it started (board time, ms).
        started_ms: u64,
    },
}

/// What the service publishes and starts after a decision.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Decision {
    /// The next phase.
    pub phase: Phase,
    /// The new status and reply (`None`: unchanged).
    pub reply: Option<(u8, [u8; FRAME_LEN])>,
    /// The action to start.
    pub start: Option<Action>,
}

impl Decision {
    fn keep(phase: Phase) -> Self {
        Self {
            phase,
            reply: None,
            start: None,
        }
    }

    fn refused(phase: Phase) -> Self {
        Self {
            phase,
            reply: Some((status::ERROR, frame::reply(status::ERROR, None, &[]))),
            start: None,
        }
    }

    fn accepted(phase: Phase, request: &Request) -> Self {
        Self {
            phase,
            reply: Some((
                status::DONE_WITH_DATA,
                frame::reply(status::DONE_WITH_DATA, Some(request), &[]),
            )),
            start: None,
        }
    }
}

/// Why an adjustment cannot be executed now (its conditions, §4.5 (8) "Execution Conditions").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Refusal {
    /// The servo is ON (CiA402 Operation Enabled, or the axis is powered).
    ServoOn,
    /// The main circuit power supply is OFF (bus under-voltage).
    MainPowerOff,
    /// The servomotor is running.
    MotorRunning,
    /// No axis is attached for this service.
    NoAxis,
    /// The axis holds a fault (the adjustment cannot run until it is reset).
    Alarm,
    /// Another adjustment is running on the drive (one at a time).
    Busy,
    /// The drive cannot perform this adjustment (see the profile's decision).
    NotSupported,
}

/// The decision on a request frame written to the command entry at `now_ms`; `check` tells
/// whether an adjustment's execution conditions hold now.
pub fn on_request(
    phase: Phase,
    spec: &ServiceSpec,
    frame_bytes: &[u8],
    now_ms: u64,
    check: impl FnOnce(Action) -> Result<(), Refusal>,
) -> Decision {
    let Ok(request) = Request::parse(frame_bytes) else {
        return match phase {
            Phase::Executing { .. } => Decision::keep(phase),
            _ => Decision::refused(phase),
        };
    };
    let abort = request.command == Ccmd::Write
        && request.address == ADDRESS_REQUEST_CODE
        && request.data == DATA_ABORT;
    if abort {
        // Step 4, in every phase (a running action is left to end by itself; its result is
        // no longer reported).
        return Decision::accepted(Phase::Idle, &request);
    }
    if let Phase::Executing { .. } = phase {
        return Decision::keep(phase);
    }
    if request.command != Ccmd::Write {
        // The manual documents write requests only.
        return Decision::refused(phase);
    }
    match (request.address, phase) {
        (ADDRESS_REQUEST_CODE, _) => match find(spec.commands, request.data) {
            Some(command) => Decision::accepted(
                Phase::Selected {
                    command,
                    prepared: false,
                    last_ms: now_ms,
                },
                &request,
            ),
            None => Decision::refused(phase),
        },
        (
            ADDRESS_EXECUTION,
            Phase::Selected {
                command, prepared, ..
            },
        ) => {
            let Some(c) = spec.commands.get(command) else {
                return Decision::refused(Phase::Idle);
            };
            match request.data {
                DATA_PREPARE if c.preparation && !prepared => Decision::accepted(
                    Phase::Selected {
                        command,
                        prepared: true,
                        last_ms: now_ms,
                    },
                    &request,
                ),
                DATA_EXECUTE if prepared || !c.preparation => match check(c.action) {
                    Ok(()) => Decision {
                        phase: Phase::Executing {
                            command,
                            started_ms: now_ms,
                        },
                        reply: Some((
                            status::EXECUTING,
                            frame::reply(status::EXECUTING, Some(&request), &[]),
                        )),
                        start: Some(c.action),
                    },
                    Err(_) => Decision::refused(phase),
                },
                _ => Decision::refused(phase),
            }
        }
        _ => Decision::refused(phase),
    }
}

/// How a started action stands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Progress {
    /// Still running.
    Running,
    /// Finished successfully.
    Done,
    /// Finished with an error (a fault, the conditions ceased to hold).
    Failed,
}

/// The decision at `now_ms` without a request: the running action's end (from `progress`) or
/// time limit, the abort of a selection nobody followed up.
pub fn on_time(phase: Phase, spec: &ServiceSpec, now_ms: u64, progress: Progress) -> Decision {
    match phase {
        Phase::Idle => Decision::keep(phase),
        Phase::Selected { last_ms, .. } => {
            if now_ms.saturating_sub(last_ms) > u64::from(spec.abort_after_ms) {
                // Aborted automatically: the status of the last step stays.
                Decision::keep(Phase::Idle)
            } else {
                Decision::keep(phase)
            }
        }
        Phase::Executing { started_ms, .. } => {
            let over_time = now_ms.saturating_sub(started_ms) > u64::from(spec.time_limit_ms);
            let ended = match progress {
                Progress::Done => status::DONE_WITH_DATA,
                Progress::Failed => status::ERROR,
                Progress::Running if over_time => status::ERROR,
                Progress::Running => return Decision::keep(phase),
            };
            let request = Request {
                command: Ccmd::Write,
                address: ADDRESS_EXECUTION,
                data: DATA_EXECUTE,
            };
            let echo = (ended == status::DONE_WITH_DATA).then_some(&request);
            Decision {
                phase: Phase::Idle,
                reply: Some((ended, frame::reply(ended, echo, &[]))),
                start: None,
            }
        }
    }
}

/// The index of the command with request code `code`.
fn find(commands: &[CommandSpec], code: u32) -> Option<usize> {
    commands.iter().position(|c| u32::from(c.code) == code)
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::vec::Vec;

    use super::*;

    const COMMANDS: &[CommandSpec] = &[
        CommandSpec {
            code: 0x100E,
            action: Action::CurrentOffsetCalibration,
            preparation: false,
        },
        CommandSpec {
            code: 0x1008,
            action: Action::MultiTurnReset,
            preparation: true,
        },
    ];
    const SPEC: ServiceSpec = ServiceSpec {
        object: 0x2310,
        axis: 1,
        command_at: 0,
        status_at: 16,
        reply_at: 17,
        abort_after_ms: 10_000,
        time_limit_ms: 5_000,
        commands: COMMANDS,
    };

    fn write(address: u32, data: u32) -> [u8; FRAME_LEN] {
        Request {
            command: Ccmd::Write,
            address,
            data,
        }
        .frame(2)
    }

    fn ok(_: Action) -> Result<(), Refusal> {
        Ok(())
    }

    fn status_of(d: &Decision) -> Option<u8> {
        d.reply.map(|(s, f)| {
            assert_eq!(f[0], s, "reply byte 0 repeats the status");
            s
        })
    }

    /// Runs `steps` (address, data) from idle at 1 ms intervals; returns every decision.
    fn run(steps: &[(u32, u32)]) -> Vec<Decision> {
        let mut phase = Phase::Idle;
        steps
            .iter()
            .enumerate()
            .map(|(t, &(a, d))| {
                let decision = on_request(phase, &SPEC, &write(a, d), t as u64, ok);
                phase = decision.phase;
                decision
            })
            .collect()
    }

    #[test]
    fn offset_adjustment_needs_no_preparation() {
        let d = run(&[(0x2000, 0x100E), (0x2001, 1)]);
        assert_eq!(status_of(&d[0]), Some(1), "step 1 accepted");
        assert_eq!(status_of(&d[1]), Some(255), "executing");
        assert_eq!(d[1].start, Some(Action::CurrentOffsetCalibration));
        let done = on_time(d[1].phase, &SPEC, 100, Progress::Done);
        assert_eq!((done.phase, status_of(&done)), (Phase::Idle, Some(1)));
    }

    #[test]
    fn preparation_is_required_where_the_table_says_so_and_refused_elsewhere() {
        let d = run(&[(0x2000, 0x1008), (0x2001, 1)]);
        assert_eq!(status_of(&d[1]), Some(2), "execute before prepare");
        assert_eq!(d[1].start, None);
        let d = run(&[(0x2000, 0x1008), (0x2001, 2), (0x2001, 1)]);
        assert_eq!(
            d.iter().map(status_of).collect::<Vec<_>>(),
            [Some(1), Some(1), Some(255)]
        );
        assert_eq!(d[2].start, Some(Action::MultiTurnReset));
        let d = run(&[(0x2000, 0x100E), (0x2001, 2)]);
        assert_eq!(status_of(&d[1]), Some(2), "100EH has no preparation step");
    }

    #[test]
    fn unknown_codes_and_out_of_sequence_steps_are_errors() {
        let d = run(&[(0x2000, 0x1234), (0x2001, 1), (0x2002, 1), (0x2001, 7)]);
        assert!(d
            .iter()
            .all(|d| status_of(d) == Some(2) && d.start.is_none()));
        assert!(d.iter().all(|d| d.phase == Phase::Idle));
        let read = Request {
            command: Ccmd::Read,
            address: 0x2000,
            data: 0,
        }
        .frame(2);
        let d = on_request(Phase::Idle, &SPEC, &read, 0, ok);
        assert_eq!(status_of(&d), Some(2), "read requests are not documented");
        let d = on_request(Phase::Idle, &SPEC, &[0xFF; 16], 0, ok);
        assert_eq!(status_of(&d), Some(2), "malformed frame");
    }

    #[test]
    fn conditions_are_checked_at_execution() {
        let selected = run(&[(0x2000, 0x100E)])[0].phase;
        let d = on_request(selected, &SPEC, &write(0x2001, 1), 5, |_| {
            Err(Refusal::ServoOn)
        });
        assert_eq!((status_of(&d), d.start), (Some(2), None));
        assert_eq!(d.phase, selected, "the selection stays for a later try");
    }

    #[test]
    fn abort_works_in_every_phase() {
        for steps in [
            &[(0x2000, 0x100E)][..],
            &[(0x2000, 0x1008), (0x2001, 2)],
            &[(0x2000, 0x100E), (0x2001, 1)],
            &[],
        ] {
            let mut all = steps.to_vec();
            all.push((0x2000, 0));
            let d = run(&all);
            let last = d.last().unwrap();
            assert_eq!((last.phase, status_of(last)), (Phase::Idle, Some(1)));
        }
    }

    #[test]
    fn requests_during_execution_do_not_disturb_it() {
        let executing = run(&[(0x2000, 0x100E), (0x2001, 1)])[1].phase;
        for frame in [write(0x2000, 0x1008), write(0x2001, 1), [0xFF; 16]] {
            let d = on_request(executing, &SPEC, &frame, 10, ok);
            assert_eq!(d, Decision::keep(executing));
        }
    }

    #[test]
    fn a_selection_is_aborted_after_10_s_without_a_request() {
        let selected = run(&[(0x2000, 0x1008), (0x2001, 2)])[1].phase;
        assert_eq!(
            on_time(selected, &SPEC, 1 + 10_000, Progress::Running).phase,
            selected
        );
        let d = on_time(selected, &SPEC, 1 + 10_001, Progress::Running);
        assert_eq!((d.phase, d.reply), (Phase::Idle, None));
        let d = on_request(d.phase, &SPEC, &write(0x2001, 1), 10_002, ok);
        assert_eq!(status_of(&d), Some(2), "execute after the automatic abort");
    }

    #[test]
    fn an_execution_ends_in_error_on_failure_or_after_the_time_limit() {
        let executing = run(&[(0x2000, 0x100E), (0x2001, 1)])[1].phase;
        assert_eq!(
            on_time(executing, &SPEC, 1 + 5_000, Progress::Running),
            Decision::keep(executing)
        );
        let d = on_time(executing, &SPEC, 1 + 5_001, Progress::Running);
        assert_eq!((d.phase, status_of(&d)), (Phase::Idle, Some(2)));
        let d = on_time(executing, &SPEC, 2, Progress::Failed);
        assert_eq!((d.phase, status_of(&d)), (Phase::Idle, Some(2)));
    }
}
