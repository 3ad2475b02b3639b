//! The device application the slave runs in every process-data cycle: what makes the slave a
//! drive, an I/O module or anything else. The stack knows nothing about it beyond this trait.

use crate::od::{ErrorReport, Object};
use crate::pdo::PdoPlan;

/// What happened to the application's error state during a cycle: the slave turns it into the
/// EMCY, 1001h and 10F3h bookkeeping of CiA 301 / ETG.1020.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AppEvent {
    /// Nothing to report.
    None,
    /// The application raised an error: the EMCY error code (a drive's 603Fh, or the profile's
    /// EMCY code for the alarm) and the manufacturer-specific field of the EMCY (bytes 3–7).
    ErrorRaised {
        /// EMCY error code.
        code: u16,
        /// EMCY bytes 3–7.
        data: [u8; 5],
    },
    /// The error with this EMCY code is gone (a drive's fault reset).
    ErrorCleared(u16),
}

/// The most events one cycle reports: a fault and a warning raised or cleared on each of two
/// channels (a two-axis drive).
pub const MAX_APP_EVENTS: usize = 8;

/// What the application reports of one cycle, in order (events past [`MAX_APP_EVENTS`] are not
/// taken: the application's own state still holds the error).
pub type AppEvents = heapless::Vec<AppEvent, MAX_APP_EVENTS>;

/// The per-cycle application behind the object dictionary.
///
/// The slave calls it with the OD RAM (`ram`, laid out by the profile's generated dictionary):
/// outputs the master wrote are already unpacked into it, inputs are packed from it afterwards.
pub trait Application {
    /// One process-data cycle (SAFEOP and OP; also once on entering SAFEOP so that the first
    /// inputs are valid). `cycle_ns` is the SYNC0 cycle (1C32h:02), 0 when not synchronised.
    /// Puts what happened to its errors into `events`, which comes empty (an application with
    /// several channels, such as a two-axis drive, may raise and clear errors on each; an
    /// out-parameter, so that the cycle does not copy the whole list back).
    fn cycle(&mut self, ram: &mut [u8], cycle_ns: u32, events: &mut AppEvents);

    /// The EtherCAT state leaves OP: put everything the master's outputs drive into its safe
    /// state at once (no further cycle runs that would do it). Returns whether the application
    /// was active (a drive: Operation Enabled), for the profile rule
    /// `EsmRules::op_exit_while_enabled_error`. `cycle_ns` is the cycle that was running.
    fn outputs_safe(&mut self, ram: &mut [u8], cycle_ns: u32) -> bool;

    /// The slave raises an application error (a profile rule such as
    /// `op_exit_while_enabled_error`): the application holds `report.error_code` and, when the
    /// error clears, announces it with `report.emcy_code` (`AppEvent::ErrorCleared`); the slave
    /// sends the raising EMCY itself.
    fn raise_error(&mut self, report: ErrorReport, ram: &mut [u8]);

    /// Power-on, after the stored parameters were loaded (`SlaveCore::start`): the
    /// application's own initialisation (a drive: CiA402 transition 1 to Switch On Disabled,
    /// which does not wait for the bus). Default: nothing.
    fn power_on(&mut self, ram: &mut [u8]) {
        let _ = ram;
    }

    /// An SDO download to `index:subindex` was committed to the OD RAM (`ram` holds the new
    /// value; a complete-access download names its first subindex), at board time `now_ns`.
    /// Runs in the ESC-event context when the mailbox round hands its writes back, before the
    /// next mailbox request is served, in PREOP, SAFEOP and OP: for objects whose writes are
    /// commands (a service request), not values. Must be short (bounded, no I/O). Default:
    /// nothing.
    fn downloaded(&mut self, ram: &mut [u8], index: u16, subindex: u8, now_ns: u64) {
        let _ = (ram, index, subindex, now_ns);
    }

    /// Whether the application needs to know which SYNC0 cycles brought no new outputs (a
    /// position mode that extrapolates over a lost cycle, a statusword bit that shows the
    /// synchronisation): the slave then reads the SM2 event
    /// at every SYNC0 in OP (DC) and calls [`Self::outputs_missed`]. Default: no.
    fn watches_missed_outputs(&self) -> bool {
        false
    }

    /// The SYNC0 of the cycle that follows came without new outputs from the master (DC, OP;
    /// only when [`Self::watches_missed_outputs`]): the image it unpacks is the previous one.
    /// Called before that [`Self::cycle`]. Default: nothing.
    fn outputs_missed(&mut self) {}

    /// Whether the cycle that follows runs in sync (called before every [`Self::cycle`] of the
    /// process-data cycle): OP on the DC SYNC0 (or SYNC1) with no sync error in the counter
    /// (ETG.1020 §5.1, so for a few cycles after a missed event) and, where a profile rule
    /// watches the SM2 event, new outputs from the master for this SYNC0. A drive shows it in its
    /// statusword where the profile has a bit for it. Default: nothing.
    fn synchronisation(&mut self, in_sync: bool) {
        let _ = in_sync;
    }

    /// The RxPDO mapping changed: `outputs` is the plan the cycles unpack from now on (built at
    /// PREOP → SAFEOP; the empty plan when the state falls below SAFEOP). An application that
    /// keeps settings read from the OD RAM learns here which of them the master's outputs may
    /// change in every cycle ([`PdoPlan::writes_ram`]). Default: nothing.
    fn outputs_mapped(&mut self, outputs: &PdoPlan) {
        let _ = outputs;
    }

    /// The TxPDO mapping changed: `inputs` is the plan the cycles pack from now on (built at
    /// PREOP → SAFEOP; the empty plan when the state falls below SAFEOP). An application that
    /// shows some values only on demand ([`Self::before_upload`]) learns here which of them
    /// every cycle must write because a TxPDO carries them ([`PdoPlan::writes_ram`]). Default:
    /// nothing.
    fn inputs_mapped(&mut self, inputs: &PdoPlan) {
        let _ = inputs;
    }

    /// A mailbox request is about to read the OD RAM entries of `object` (an SDO upload): the
    /// application writes the values of the object that it shows on demand rather than in
    /// every cycle (a drive's demand values, which no TxPDO carries: converting them to user
    /// units each cycle would be work nobody reads). Bounded; called with the core, before
    /// the entries are copied for the answer. Default: nothing (every value is written in the
    /// cycle).
    fn before_upload(&mut self, ram: &mut [u8], object: &Object) {
        let _ = (ram, object);
    }

    /// Whether the application keeps something converted from the `len` OD RAM bytes from
    /// offset `at` (a setting) and must learn when an RxPDO changes them
    /// ([`Self::watched_outputs_changed`]). Asked for each mapped entry when the RxPDO plan is
    /// built (PREOP → SAFEOP). Default: nothing is watched.
    fn watches_outputs(&self, at: u16, len: u16) -> bool {
        let _ = (at, len);
        false
    }

    /// In OP, the RxPDO just unpacked changed OD RAM bytes the application watches
    /// ([`Self::watches_outputs`]): called in the cycle, before [`Self::cycle`]. Default:
    /// nothing.
    fn watched_outputs_changed(&mut self) {}

    /// Called at the start of every ESC-event round, in every EtherCAT state (on a board at
    /// least every few ms, also without bus traffic): work that is not tied to the
    /// process-data cycle, e.g. a service that runs across several mailbox requests. Must be
    /// short (bounded, no I/O). Default: nothing.
    fn background(&mut self, ram: &mut [u8], now_ns: u64) {
        let _ = (ram, now_ns);
    }
}

/// A slave without an application: process data are copied to and from the OD and nothing else
/// happens (enough for a device whose objects are plain variables).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NoApplication;

impl Application for NoApplication {
    fn cycle(&mut self, _: &mut [u8], _: u32, _: &mut AppEvents) {}

    fn outputs_safe(&mut self, _: &mut [u8], _: u32) -> bool {
        false
    }

    fn raise_error(&mut self, _: ErrorReport, _: &mut [u8]) {}
}
