//! The slave: owns the stack state and the OD RAM; boards call its entry points.
//!
//! | entry point | called from (target) | called from (sim) |
//! |---|---|---|
//! | [`Slave::on_esc_event`] | ESC IRQ (AL event) task, and periodically from thread mode | after every frame the ESC processed |
//! | [`Slave::on_cycle`] | SYNC0 EXTI (DC), SM2 event (SM-synchronous) or a local timer (free-run) | at each simulated SYNC0 / cycle |

use hal::esc::AlState;
use hal::pdi::EscPdi;

use crate::od::{Dictionary, Profile};

/// How the process-data cycle is triggered (1C32h:01 semantics).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SyncMode {
    /// Not synchronised: the board runs [`Slave::on_cycle`] from a local timer.
    FreeRun,
    /// Synchronous with the SM2 event.
    SmSynchronous,
    /// DC SYNC0: the board runs [`Slave::on_cycle`] from the SYNC0 interrupt.
    DcSync0,
    /// DC SYNC0 with SYNC1.
    DcSync1,
}

/// The EtherCAT slave with its object dictionary. `RAM` is the profile's OD RAM size
/// (`profiles::<name>::RAM_SIZE`).
pub struct Slave<const RAM: usize> {
    profile: &'static Profile,
    ram: [u8; RAM],
    state: AlState,
    sync_mode: SyncMode,
}

impl<const RAM: usize> Slave<RAM> {
    /// A slave in INIT with every object at its default.
    pub fn new(profile: &'static Profile) -> Self {
        let mut slave = Self { profile, ram: [0; RAM], state: AlState::Init, sync_mode: SyncMode::FreeRun };
        slave.dictionary().load_defaults();
        slave
    }

    /// The object dictionary.
    pub fn dictionary(&mut self) -> Dictionary<'_> {
        Dictionary::new(self.profile, &mut self.ram)
    }

    /// The current EtherCAT state.
    pub fn al_state(&self) -> AlState {
        self.state
    }

    /// The active synchronisation mode.
    pub fn sync_mode(&self) -> SyncMode {
        self.sync_mode
    }

    /// Handles pending AL events: state change requests, SM (de)activation, mailbox traffic.
    /// `now_ns` is the board's monotonic time.
    pub fn on_esc_event<P: EscPdi>(&mut self, _pdi: &mut P, _now_ns: u64) -> Result<(), P::Error> {
        Ok(())
    }

    /// Runs one process-data cycle: read outputs (SM2), run the application, write inputs (SM3).
    pub fn on_cycle<P: EscPdi>(&mut self, _pdi: &mut P, _now_ns: u64) -> Result<(), P::Error> {
        Ok(())
    }
}
