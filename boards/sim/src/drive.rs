//! One simulated drive: a software ET1100 and the firmware core running against it.

use firmware::od::Profile;
use firmware::profiles;
use firmware::slave::{Slave, SlaveError, SyncMode};
use hal::pdi::EscSignals;

use crate::esc::Et1100;

/// OD RAM size of the simulated firmware: large enough for every built-in profile, so the
/// profile can be chosen by name at run time.
pub const SIM_RAM: usize = profiles::MAX_RAM_SIZE;

/// Free-run cycle of the simulated board's local timer (the target uses a hardware timer).
pub const FREE_RUN_PERIOD_NS: u64 = 1_000_000;

/// A drive: ESC + firmware.
pub struct SimDrive {
    /// The simulated ESC.
    pub esc: Et1100,
    /// The firmware core.
    pub slave: Box<Slave<SIM_RAM>>,
    next_free_run_ns: u64,
}

impl SimDrive {
    /// A drive running `profile` with the SII image `sii` in its EEPROM.
    pub fn new(profile: &'static Profile, sii: &[u8]) -> Result<Self, SlaveError> {
        let mut esc = Et1100::new(sii);
        let mut slave = Box::new(Slave::new(profile)?);
        // The simulated PDI never fails (its error type only reports out-of-range accesses,
        // which the firmware does not make); a failure here would be a firmware bug.
        let _ = slave.start(&mut esc);
        Ok(Self {
            esc,
            slave,
            next_free_run_ns: FREE_RUN_PERIOD_NS,
        })
    }

    /// Earliest simulated time at which the drive has something to do.
    pub fn next_event_ns(&self) -> Option<u64> {
        let free_run = self.free_running().then_some(self.next_free_run_ns);
        match (self.esc.next_event_ns(), free_run) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    fn free_running(&self) -> bool {
        self.slave.sync_mode() == SyncMode::FreeRun
            && matches!(
                self.slave.al_state(),
                hal::esc::AlState::SafeOp | hal::esc::AlState::Op
            )
    }

    /// Moves the drive to simulated time `now_ns` and runs the firmware handlers that are due:
    /// SYNC0 → cycle, free-run tick → cycle, IRQ line → ESC event handler.
    pub fn run_until(&mut self, now_ns: u64) {
        self.esc.advance_to(now_ns);
        if self.esc.take_sync0() {
            let _ = self.slave.on_cycle(&mut self.esc, now_ns);
        }
        if self.free_running() && now_ns >= self.next_free_run_ns {
            let _ = self.slave.on_cycle(&mut self.esc, now_ns);
        }
        while self.next_free_run_ns <= now_ns {
            self.next_free_run_ns += FREE_RUN_PERIOD_NS;
        }
        self.service_irq(now_ns);
    }

    /// Runs the ESC event handler while the IRQ line is asserted (bounded: the handler clears
    /// what it serves; a stuck line is left for the next call).
    pub fn service_irq(&mut self, now_ns: u64) {
        const MAX_ROUNDS: usize = 4;
        for _ in 0..MAX_ROUNDS {
            if !self.esc.irq_asserted() {
                break;
            }
            let _ = self.slave.on_esc_event(&mut self.esc, now_ns);
        }
    }
}
