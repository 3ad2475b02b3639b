//! The oracle on the EtherCAT state machine, as the master sees it: the drive never reports a
//! state it did not accept (ETG.1000.6 §6.4, Figure 14).

use crate::bench::Status;
use crate::coe::Violation;
use crate::spec::{self, state};

/// Follows the AL status between master actions.
pub struct EsmWatch {
    last: Status,
    /// States the master requested since the state last changed: a request stays in the AL
    /// control register and may complete later (SAFEOP → OP waits for outputs and SYNC0,
    /// ETG.1000.6 §6.4.1), so it counts until the state changes.
    requested: Vec<u8>,
}

impl EsmWatch {
    /// Starts from what the master read, with the master's last request (`pending`, the AL
    /// control value, which may not have completed yet).
    pub fn new(first: Status, pending: Option<u16>) -> Self {
        Self {
            last: first,
            requested: pending.map(|c| (c & 0x0F) as u8).into_iter().collect(),
        }
    }

    /// The master wrote `control` to AL control (0x0120).
    pub fn requested(&mut self, control: u16) {
        self.requested.push((control & 0x0F) as u8);
    }

    /// The last status observed.
    pub fn last(&self) -> Status {
        self.last
    }

    /// The master read `now`; checks it against the last observation and the requests made
    /// since the state last changed.
    pub fn observe(&mut self, now: Status) -> Result<(), Violation> {
        let valid = [
            state::INIT,
            state::PREOP,
            state::BOOT,
            state::SAFEOP,
            state::OP,
        ];
        if !valid.contains(&now.state) {
            return Err(Violation(format!("AL status state {:#x}", now.state)));
        }
        if now.error && !spec::is_al_status_code(now.code) {
            return Err(Violation(format!(
                "AL status code {:#06x} not in ETG.1000.6 Table 11",
                now.code
            )));
        }
        if now.error && now.code == 0 {
            return Err(Violation("error indication with AL status code 0".into()));
        }
        let from = self.last.state;
        if now.state != from && spec::rank(now.state) >= spec::rank(from) {
            // Upwards (or sideways PREOP <-> BOOT, which only goes through INIT): only the one
            // step the master asked for.
            if !spec::is_upward_transition(from, now.state) {
                return Err(Violation(format!(
                    "state {from:#x} -> {:#x} is no transition of Figure 14",
                    now.state
                )));
            }
            if !self.requested.contains(&now.state) {
                return Err(Violation(format!(
                    "state {from:#x} -> {:#x} without a request (requested {:x?})",
                    now.state, self.requested
                )));
            }
            if now.error {
                return Err(Violation(format!(
                    "entered {:#x} with the error indication set ({:#06x})",
                    now.state, now.code
                )));
            }
        }
        if now.state != self.last.state {
            self.requested.clear();
        }
        self.last = now;
        Ok(())
    }
}
