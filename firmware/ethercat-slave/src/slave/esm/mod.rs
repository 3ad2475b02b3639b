//! EtherCAT state machine (ETG.1000.6 §6.4), all of it: the pure decision function, the checks
//! and supervision its transitions rest on, and the slave's side of it (requests, the entry and
//! exit work of the states, the faults that drop the state).
//!
//! | module | what |
//! |---|---|
//! | this module | [`decide`]: `(AlStatus, code, AlControl, Checks) -> Outcome` |
//! | [`sm_check`] | SM0/SM1 against the mailbox layout (0x0016), SM2/SM3 against the mapped sizes (0x001D/0x001E) |
//! | [`sync`] | free-run / SM-synchronous / DC SYNC0 from 0x0981, 0x09A0 and 1C32h:01; accepted per profile |
//! | [`supervision`] | ETG.1020 sync error counter, SYNC0 period check |
//! | `transitions` | the slave's state change requests: checks a transition needs, the delayed SAFEOP → OP gate, applying an outcome |
//! | `faults` | faults the slave detects by itself (SM re-validation, PD watchdog, SYNC0 supervision) and the state they drop to |
//!
//! The caller reads AL control once, evaluates the [`Checks`] of the configuration the master
//! wrote, calls [`decide`], and then applies the [`Outcome`]: it writes the AL status code first
//! and AL status second (a master that sees the error flag reads a valid code), and runs the
//! entry/exit work of the states it left and entered.

use hal::esc::{AlControl, AlState, AlStatus, AlStatusCode};

pub(super) mod faults;
pub mod sm_check;
pub mod supervision;
pub mod sync;
pub(super) mod transitions;

/// Results of the configuration checks a transition may need. Each is `Ok` or carries the AL
/// status code the transition must be refused with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Checks {
    /// SM0/SM1 match the device's mailbox layout (INIT → PREOP).
    pub mailbox: Result<(), AlStatusCode>,
    /// SM2/SM3 and the PDO mapping agree (PREOP → SAFEOP; SAFEOP → OP and an acknowledge
    /// that stays in SAFEOP or OP: the SMs as the master left them).
    pub process_data: Result<(), AlStatusCode>,
    /// The synchronisation the master configured is supported (PREOP → SAFEOP, SAFEOP → OP).
    pub sync: Result<(), AlStatusCode>,
    /// Whether the device supports BOOT (a bootstrap mailbox is declared).
    pub boot_supported: bool,
    /// SM0/SM1 match the bootstrap mailbox layout (INIT → BOOT).
    pub boot_mailbox: Result<(), AlStatusCode>,
}

impl Checks {
    /// Every check passes (BOOT unsupported).
    pub const ALL_OK: Self = Self {
        mailbox: Ok(()),
        process_data: Ok(()),
        sync: Ok(()),
        boot_supported: false,
        boot_mailbox: Ok(()),
    };
}

/// What the ESM decided.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Outcome {
    /// The new AL status.
    pub status: AlStatus,
    /// The new AL status code (`NoError` when the error flag is clear).
    pub code: AlStatusCode,
}

impl Outcome {
    fn ok(state: AlState) -> Self {
        Self {
            status: AlStatus {
                state,
                error: false,
                id_loaded: false,
            },
            code: AlStatusCode::NoError,
        }
    }
    fn refused(state: AlState, code: AlStatusCode) -> Self {
        Self {
            status: AlStatus {
                state,
                error: true,
                id_loaded: false,
            },
            code,
        }
    }
}

/// Decides the reaction to AL control `control` in status `status` with status code `code`.
///
/// Rules (ETG.1000.6 §6.4.1, Table 10/11):
/// - while the error flag is set, a request without the acknowledge bit changes nothing;
/// - an acknowledged request clears the error flag and is then handled like any request;
/// - a request for the current state changes nothing else;
/// - downward transitions always succeed; upward transitions run their check and, if it fails,
///   stay in the current state (INIT → PREOP failing stays in INIT, ...) with the error flag;
/// - transitions the ESM does not have give 0x0011, state codes that name no state 0x0012.
pub fn decide(
    status: AlStatus,
    code: AlStatusCode,
    control: AlControl,
    checks: &Checks,
) -> Outcome {
    let current = status.state;
    if status.error && !control.ack {
        return Outcome {
            status: AlStatus {
                id_loaded: false,
                ..status
            },
            code,
        };
    }
    let Some(requested) = control.requested() else {
        return Outcome::refused(current, AlStatusCode::UnknownState);
    };
    use AlState::*;
    if requested == current {
        // Staying in SAFEOP or OP (an acknowledge) needs the process-data SMs still right:
        // a wrong one keeps its error (ETG.1000.6 Table 11), it is not acknowledged away.
        return match (current, checks.process_data) {
            (SafeOp | Op, Err(code)) => fault(current, sm_fault_state(code), code),
            _ => Outcome::ok(current),
        };
    }
    match (current, requested) {
        // Downward: always allowed.
        (PreOp | SafeOp | Op | Boot, Init) | (SafeOp | Op, PreOp) | (Op, SafeOp) => {
            Outcome::ok(requested)
        }
        (Init, PreOp) => match checks.mailbox {
            Ok(()) => Outcome::ok(PreOp),
            Err(code) => Outcome::refused(Init, code),
        },
        (Init, Boot) if checks.boot_supported => match checks.boot_mailbox {
            Ok(()) => Outcome::ok(Boot),
            Err(code) => Outcome::refused(Init, code),
        },
        (Init, Boot) => Outcome::refused(Init, AlStatusCode::BootstrapNotSupported),
        (PreOp, SafeOp) => match checks.process_data.and(checks.sync) {
            Ok(()) => Outcome::ok(SafeOp),
            Err(code) => Outcome::refused(PreOp, code),
        },
        (SafeOp, Op) => match (checks.process_data, checks.sync) {
            (Err(code), _) => fault(SafeOp, sm_fault_state(code), code),
            (Ok(()), Err(code)) => Outcome::refused(SafeOp, code),
            (Ok(()), Ok(())) => Outcome::ok(Op),
        },
        _ => Outcome::refused(current, AlStatusCode::InvalidStateChange),
    }
}

/// A profile's fault that drops to INIT without error indication and AL status code 0x0000
/// (the input port lost its link, the PDI failed: nothing for the master to acknowledge, it
/// could not see the transition); from INIT nothing changes.
pub fn dropped_to_init(current: AlStatus) -> Outcome {
    if current.state == AlState::Init {
        Outcome {
            status: current,
            code: AlStatusCode::NoError,
        }
    } else {
        Outcome::ok(AlState::Init)
    }
}

/// Outcome of an asynchronous error (watchdog, sync loss, mailbox SM deactivated) detected in
/// `current`: the state drops to `fallback` if that is lower, with the error flag and `code`.
pub fn fault(current: AlState, fallback: AlState, code: AlStatusCode) -> Outcome {
    let state = if state_rank(fallback) < state_rank(current) {
        fallback
    } else {
        current
    };
    Outcome::refused(state, code)
}

/// The state a wrong process-data SM leaves the slave in (ETG.1000.6 Table 11): SAFEOP for
/// the outputs (0x001D), PREOP for the inputs (0x001E) and for any other code.
pub fn sm_fault_state(code: AlStatusCode) -> AlState {
    if code == AlStatusCode::InvalidOutputConfig {
        AlState::SafeOp
    } else {
        AlState::PreOp
    }
}

/// Orders states INIT < PREOP < SAFEOP < OP; BOOT ranks with PREOP (it is entered from INIT only).
pub const fn state_rank(state: AlState) -> u8 {
    match state {
        AlState::Init => 0,
        AlState::PreOp | AlState::Boot => 1,
        AlState::SafeOp => 2,
        AlState::Op => 3,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use AlState::*;

    #[test]
    fn link_loss_drops_to_init_without_error() {
        for from in [PreOp, SafeOp, Op] {
            let o = dropped_to_init(st(from));
            assert_eq!(
                (o.status.state, o.status.error, o.code),
                (Init, false, AlStatusCode::NoError)
            );
        }
        let o = dropped_to_init(st(Init));
        assert_eq!(o.status.state, Init);
    }

    fn st(state: AlState) -> AlStatus {
        AlStatus {
            state,
            error: false,
            id_loaded: false,
        }
    }
    fn err(state: AlState) -> AlStatus {
        AlStatus {
            state,
            error: true,
            id_loaded: false,
        }
    }
    fn req(state: AlState) -> AlControl {
        AlControl {
            state_bits: state.bits(),
            ack: false,
            id_request: false,
        }
    }
    fn ack(state: AlState) -> AlControl {
        AlControl {
            state_bits: state.bits(),
            ack: true,
            id_request: false,
        }
    }
    const OK: AlStatusCode = AlStatusCode::NoError;

    /// ETG.1000.6 Table 11: a wrong output SM (0x001D) leaves SAFEOP + error, a wrong input SM
    /// (0x001E) PREOP + error; an acknowledge that would stay in SAFEOP or OP with the SM still
    /// wrong keeps the error (the fuzzed ESM found SAFEOP without error and SM2 disabled after
    /// an acknowledge), and SAFEOP → OP is refused alike.
    #[test]
    fn a_wrong_process_data_sm_is_not_acknowledged_away() {
        let with = |code| Checks {
            process_data: Err(code),
            ..Checks::ALL_OK
        };
        let outputs = with(AlStatusCode::InvalidOutputConfig);
        let inputs = with(AlStatusCode::InvalidInputConfig);
        for from in [SafeOp, Op] {
            let o = decide(
                err(from),
                AlStatusCode::InvalidOutputConfig,
                ack(from),
                &outputs,
            );
            assert_eq!((o.status, o.code.code()), (err(SafeOp), 0x001D), "{from:?}");
            let o = decide(
                err(from),
                AlStatusCode::InvalidInputConfig,
                ack(from),
                &inputs,
            );
            assert_eq!((o.status, o.code.code()), (err(PreOp), 0x001E), "{from:?}");
            // The SMs right again: the acknowledge clears the error.
            let o = decide(
                err(from),
                AlStatusCode::InvalidOutputConfig,
                ack(from),
                &Checks::ALL_OK,
            );
            assert_eq!(o, Outcome::ok(from));
        }
        let o = decide(st(SafeOp), OK, req(Op), &outputs);
        assert_eq!((o.status, o.code.code()), (err(SafeOp), 0x001D));
        let o = decide(st(SafeOp), OK, req(Op), &inputs);
        assert_eq!((o.status, o.code.code()), (err(PreOp), 0x001E));
        // A synchronisation the device does not support stays SAFEOP + error, as before.
        let sync = Checks {
            sync: Err(AlStatusCode::SyncNotSupported),
            ..Checks::ALL_OK
        };
        let o = decide(st(SafeOp), OK, req(Op), &sync);
        assert_eq!(o.status, err(SafeOp));
    }

    #[test]
    fn esm_init_to_preop_with_valid_mailbox() {
        let o = decide(st(Init), OK, req(PreOp), &Checks::ALL_OK);
        assert_eq!(o, Outcome::ok(PreOp));
    }

    #[test]
    fn esm_init_to_preop_refused_0x16_stays_init_with_error() {
        let checks = Checks {
            mailbox: Err(AlStatusCode::InvalidMailboxConfig),
            ..Checks::ALL_OK
        };
        let o = decide(st(Init), OK, ack(PreOp), &checks);
        assert_eq!(o.status, err(Init));
        assert_eq!(o.code.code(), 0x0016);
    }

    #[test]
    fn esm_preop_to_safeop_refused_0x1d_on_bad_outputs() {
        let checks = Checks {
            process_data: Err(AlStatusCode::InvalidOutputConfig),
            ..Checks::ALL_OK
        };
        let o = decide(st(PreOp), OK, req(SafeOp), &checks);
        assert_eq!(o.status, err(PreOp));
        assert_eq!(o.code.code(), 0x001D);
    }

    #[test]
    fn esm_preop_to_safeop_refused_on_sync_config() {
        let checks = Checks {
            sync: Err(AlStatusCode::DcInvalidSyncCycleTime),
            ..Checks::ALL_OK
        };
        let o = decide(st(PreOp), OK, req(SafeOp), &checks);
        assert_eq!(o.status, err(PreOp));
        assert_eq!(o.code.code(), 0x0035);
    }

    #[test]
    fn esm_safeop_to_op_and_back_down_to_init() {
        assert_eq!(
            decide(st(SafeOp), OK, req(Op), &Checks::ALL_OK),
            Outcome::ok(Op)
        );
        assert_eq!(
            decide(st(Op), OK, req(SafeOp), &Checks::ALL_OK),
            Outcome::ok(SafeOp)
        );
        assert_eq!(
            decide(st(Op), OK, req(PreOp), &Checks::ALL_OK),
            Outcome::ok(PreOp)
        );
        assert_eq!(
            decide(st(Op), OK, req(Init), &Checks::ALL_OK),
            Outcome::ok(Init)
        );
        assert_eq!(
            decide(st(SafeOp), OK, req(Init), &Checks::ALL_OK),
            Outcome::ok(Init)
        );
    }

    #[test]
    fn esm_skipping_states_upward_is_0x11() {
        for (from, to) in [
            (Init, SafeOp),
            (Init, Op),
            (PreOp, Op),
            (PreOp, Boot),
            (SafeOp, Boot),
            (Op, Boot),
            (Boot, PreOp),
        ] {
            let o = decide(st(from), OK, req(to), &Checks::ALL_OK);
            assert_eq!(o.status, err(from), "{from:?} -> {to:?}");
            assert_eq!(o.code.code(), 0x0011, "{from:?} -> {to:?}");
        }
    }

    #[test]
    fn esm_unknown_state_code_is_0x12() {
        let ctl = AlControl {
            state_bits: 0x05,
            ack: false,
            id_request: false,
        };
        let o = decide(st(PreOp), OK, ctl, &Checks::ALL_OK);
        assert_eq!(o.status, err(PreOp));
        assert_eq!(o.code.code(), 0x0012);
    }

    #[test]
    fn esm_boot_without_bootstrap_mailbox_is_0x13() {
        let o = decide(st(Init), OK, req(Boot), &Checks::ALL_OK);
        assert_eq!(o.status, err(Init));
        assert_eq!(o.code.code(), 0x0013);
        let boot = Checks {
            boot_supported: true,
            ..Checks::ALL_OK
        };
        assert_eq!(decide(st(Init), OK, req(Boot), &boot), Outcome::ok(Boot));
        assert_eq!(decide(st(Boot), OK, req(Init), &boot), Outcome::ok(Init));
        let bad = Checks {
            boot_mailbox: Err(AlStatusCode::InvalidBootMailboxConfig),
            ..boot
        };
        let o = decide(st(Init), OK, req(Boot), &bad);
        assert_eq!(o.status, err(Init));
        assert_eq!(o.code.code(), 0x0015);
    }

    #[test]
    fn esm_error_is_held_until_acknowledged() {
        let code = AlStatusCode::InvalidOutputConfig;
        // Without ack: nothing changes, not even a downward request.
        let o = decide(err(PreOp), code, req(Init), &Checks::ALL_OK);
        assert_eq!(
            o,
            Outcome {
                status: err(PreOp),
                code
            }
        );
        let o = decide(err(PreOp), code, req(SafeOp), &Checks::ALL_OK);
        assert_eq!(
            o,
            Outcome {
                status: err(PreOp),
                code
            }
        );
        // With ack for the current state: error cleared.
        assert_eq!(
            decide(err(PreOp), code, ack(PreOp), &Checks::ALL_OK),
            Outcome::ok(PreOp)
        );
        // With ack and a new state: cleared and performed.
        assert_eq!(
            decide(err(PreOp), code, ack(SafeOp), &Checks::ALL_OK),
            Outcome::ok(SafeOp)
        );
        assert_eq!(
            decide(err(SafeOp), code, ack(Init), &Checks::ALL_OK),
            Outcome::ok(Init)
        );
    }

    #[test]
    fn esm_fault_drops_op_to_safeop_but_never_raises_state() {
        let o = fault(Op, SafeOp, AlStatusCode::SmWatchdog);
        assert_eq!(o.status, err(SafeOp));
        assert_eq!(o.code.code(), 0x001B);
        let o = fault(PreOp, SafeOp, AlStatusCode::SyncError);
        assert_eq!(o.status, err(PreOp));
    }
}
