//! The slave: owns the stack state and the OD RAM; boards call its entry points. The SYNC0
//! context needs only the [`SlaveCore`]; mailbox traffic runs on the [`MailboxSide`] with its own
//! copy of the OD RAM and touches the core only in short steps (see `mailbox_side`).
//!
//! | entry point | called from (target) | called from (sim) |
//! |---|---|---|
//! | [`Slave::on_esc_event`] | ESC IRQ (AL event) task, and periodically from thread mode | after every frame the ESC processed |
//! | [`SlaveCore::on_cycle`] (or its stages [`SlaveCore::cycle_begin`], the application, [`SlaveCore::cycle_end`]), then [`SlaveCore::cycle_finished`] | SYNC0 EXTI (DC), or a local timer (free-run) | at each simulated SYNC0 / free-run tick |
//!
//! In SM-synchronous mode the cycle runs from [`Slave::on_esc_event`] on the SM2 event.
//!
//! | module | what |
//! |---|---|
//! | this module | [`SlaveCore`], construction, the ESC-event steps of the core |
//! | `composite` | [`Slave`]: core and mailbox side together, a whole ESC-event round |
//! | `mailbox_side` | [`MailboxSide`]: the mailbox and CoE on a copy of the OD RAM (load / receive / load the dictionary for a request / answer / store) |
//! | `cycle` | the process-data cycle (cycle context) |
//! | [`esm`] | the EtherCAT state machine |
//! | `errors` | EMCY, 1001h and 10F3h bookkeeping of AL and application errors |
//! | `application` | the [`Application`] trait, [`NoApplication`] |

use hal::esc::{
    regs, AlControl, AlEvent, AlState, AlStatus, AlStatusCode, DcActivation, SmConfig, SmDirection,
};
use hal::pdi::EscPdi;
use hal::storage::NvStorage;

use crate::diag::{diag_code_for_emcy, DiagError, DiagMessage, DiagParam, DiagType, Diagnosis};
use crate::leds::{self, ErrorIndication};
use crate::mailbox::emcy::EMCY_QUEUE_LEN;
use crate::mailbox::emcy::{self, ActiveErrors, Emergency};
use crate::od::dirty::MAX_TRACKED_RAM;
use crate::od::index::{ERROR_SETTINGS, SM_INPUT_PARAMETER, SM_OUTPUT_PARAMETER};
use crate::od::{Dictionary, ErrorReport, Profile};
use crate::params::{Loaded, ParamError, ParamStore};
use crate::pdo::{Direction, PdoPlan, MAX_IMAGE};
use crate::slave::esm::sm_check;
use crate::slave::esm::supervision::{LostOutputsCounter, SyncSupervisor, DEFAULT_COUNTER_LIMIT};
pub use crate::slave::esm::sync::SyncMode;
use esm::Outcome;
use heapless::Deque;

mod application;
mod composite;
mod cycle;
mod errors;
pub mod esm;
mod mailbox_side;

use crate::mailbox::dll::SM_MAILBOX_OUT;
use crate::slave::esm::sync::{SyncConfig, SyncMode as Mode};
pub use application::{AppEvent, AppEvents, Application, NoApplication, MAX_APP_EVENTS};
pub use composite::Slave;
use esm::transitions::read_sm;
pub use mailbox_side::{load_scope, LoadedRequest, MailboxSide, ReceivedRequest};

/// SM channel of the process-data outputs.
pub const SM_OUTPUTS: u8 = 2;
/// SM channel of the process-data inputs.
const SM_INPUTS: u8 = 3;
use crate::od::index::sm_parameter::{
    SUB_CALC_AND_COPY_TIME, SUB_CYCLE_TIME, SUB_CYCLE_TIME_TOO_SMALL, SUB_DELAY_TIME,
    SUB_MIN_CYCLE_TIME, SUB_SHIFT_TIME, SUB_SYNC0_CYCLE_TIME, SUB_SYNC_ERROR, SUB_SYNC_TYPE,
};
/// 10F1h (error settings, ETG.1020 §5.1) :02 sync error counter limit.
const SUB_SYNC_ERROR_LIMIT: u8 = 0x02;

/// What the slave's process-data side owns: the ESM, the process data, the application and the
/// OD RAM; the ESC-event context touches it only in short, bounded calls (the mailbox and its
/// SDO services work on their own copy, [`MailboxSide`]). `RAM` is the OD RAM size (the
/// generated `<profile>::RAM_SIZE`, or the largest of several profiles to choose one at run
/// time).
#[derive(Clone)]
pub struct SlaveCore<const RAM: usize, A: Application = NoApplication> {
    profile: &'static Profile,
    ram: [u8; RAM],
    status: AlStatus,
    code: AlStatusCode,
    /// Emergencies waiting for the mailbox side to take them (raised by the ESM, the cycle or
    /// the board).
    emcy_out: Deque<Emergency, EMCY_QUEUE_LEN>,
    /// The mailbox must start afresh (INIT was entered); the mailbox side takes it.
    mailbox_reset: bool,
    /// SyncManagers the ESC implements (its register 0x0005, read at [`Self::start`]; at most
    /// [`regs::MAX_SMS`]): an SM-activation event is acknowledged by reading each one's
    /// activate byte.
    esc_sms: u8,
    rx_plan: PdoPlan,
    /// Counts the changes of [`Self::rx_plan`], so that the mailbox side copies its OD RAM
    /// ranges only when they change.
    rx_plan_generation: u32,
    tx_plan: PdoPlan,
    sync: SyncConfig,
    rx_image: [u8; MAX_IMAGE],
    tx_image: [u8; MAX_IMAGE],
    app: A,
    cycles: u32,
    /// Device identification value shown in the AL status code while AL status bit 5 is set.
    id_value: u16,
    /// SYNC0 supervision (DC modes).
    sync_supervisor: SyncSupervisor,
    /// A SAFEOP → OP request waiting for the first SYNC0 / outputs, and since when.
    pending_op: Option<(AlControl, u64)>,
    /// The master has written SM2 since SAFEOP was entered.
    outputs_received: bool,
    /// What the ERR LED shows.
    error_indication: ErrorIndication,
    /// The ERR LED shows [`Self::error_indication`] although the AL status has no error flag
    /// (a profile's fault that drops to INIT with AL status code 0x0000, e.g. the SDV3-E's LL
    /// and Hr), until the master's next state request.
    error_without_flag: bool,
    /// Consecutive cycles without new outputs (`[esm] lost_outputs`).
    lost_outputs: LostOutputsCounter,
    /// The ESC's PDI error counter (0x030D) when last read (`[esm] pdi_error`).
    pdi_errors_seen: u8,
    /// The drive error that the next AL error reports instead of the profile's alarm for its
    /// AL status code (a fault whose code several causes share, e.g. the SDV3-E's cS and cSD
    /// both 0x002C).
    fault_error: Option<ErrorReport>,
    /// Start of the running process-data cycle (board clock, ns).
    cycle_started_ns: u64,
    /// When SAFEOP was entered from PREOP or the master changed the synchronisation in SAFEOP
    /// (board clock, ns): the start of the profile's SYNC0 lock timeout.
    sync_lock_since_ns: u64,
    /// Longest process-data cycle since SAFEOP was entered (1C32h/1C33h:06), ns.
    calc_and_copy_max_ns: u32,
    /// Cycles that did not fit into the SYNC0 cycle (1C32h:0C).
    cycle_too_small: u16,
    /// Active errors: the source of 1001h.
    errors: ActiveErrors,
    /// Diagnosis history 10F3h ring state.
    diag: Diagnosis,
    /// Board time of the event being handled (time stamps of diagnosis messages).
    now_ns: u64,
}

/// What [`SlaveCore::event_begin`] found, for the mailbox side and [`SlaveCore::event_end`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EventJob {
    /// The AL event register as read.
    pub events: AlEvent,
    /// The EtherCAT state after the requests were handled.
    pub state: AlState,
}

/// Why the slave could not be created.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SlaveError {
    /// The OD RAM is smaller than the profile needs.
    RamTooSmall {
        /// Bytes the profile needs.
        needed: usize,
        /// Bytes available.
        available: usize,
    },
    /// The OD RAM is larger than the mailbox side can track writes to.
    RamTooLarge {
        /// Bytes of OD RAM.
        size: usize,
        /// The largest trackable OD RAM ([`MAX_TRACKED_RAM`]).
        max: usize,
    },
}

impl<const RAM: usize, A: Application> SlaveCore<RAM, A> {
    /// A slave core in INIT with every object at its default, running `app`.
    pub fn new(profile: &'static Profile, app: A) -> Result<Self, SlaveError> {
        if profile.ram_size() > RAM {
            return Err(SlaveError::RamTooSmall {
                needed: profile.ram_size(),
                available: RAM,
            });
        }
        if RAM > MAX_TRACKED_RAM {
            return Err(SlaveError::RamTooLarge {
                size: RAM,
                max: MAX_TRACKED_RAM,
            });
        }
        let mut slave = Self {
            profile,
            ram: [0; RAM],
            status: AlStatus {
                state: AlState::Init,
                error: false,
                id_loaded: false,
            },
            code: AlStatusCode::NoError,
            emcy_out: Deque::new(),
            mailbox_reset: false,
            esc_sms: regs::MAX_SMS,
            rx_plan: PdoPlan::default(),
            rx_plan_generation: 0,
            tx_plan: PdoPlan::default(),
            sync: SyncConfig {
                mode: Mode::FreeRun,
                cycle_ns: 0,
            },
            rx_image: [0; MAX_IMAGE],
            tx_image: [0; MAX_IMAGE],
            app,
            cycles: 0,
            id_value: 0,
            sync_supervisor: SyncSupervisor::default(),
            pending_op: None,
            outputs_received: false,
            error_indication: ErrorIndication::None,
            error_without_flag: false,
            lost_outputs: LostOutputsCounter::default(),
            pdi_errors_seen: 0,
            fault_error: None,
            cycle_started_ns: 0,
            sync_lock_since_ns: 0,
            calc_and_copy_max_ns: 0,
            cycle_too_small: 0,
            errors: ActiveErrors::new(),
            diag: Diagnosis::new(),
            now_ns: 0,
        };
        slave.dictionary().load_defaults();
        Ok(slave)
    }

    /// Brings the ESC interface up after power-on: AL status INIT without error, and the AL
    /// event mask that drives the IRQ line (AL control, SM activation, mailbox SM0/SM1, SM2 for
    /// SM-synchronous cycles, process-data watchdog), and the station alias from the profile's
    /// alias parameter if it has one and it is not 0 (call after [`Self::load_parameters`]).
    /// If the ESC still shows a state above INIT (the MCU restarted without the ESC), INIT with
    /// the error indication and 0x0060 instead.
    pub fn start<P: EscPdi>(&mut self, pdi: &mut P) -> Result<(), P::Error> {
        // SM1's event (the master read the slave's mailbox) is enabled by the mailbox side only
        // while it has a frame waiting for SM1 (`mailbox::dll`): otherwise it would hold the
        // IRQ line asserted from one mailbox exchange to the next.
        let mask = AlEvent::AL_CONTROL
            | AlEvent::SM_ACTIVATION
            | AlEvent::WATCHDOG_PD
            | AlEvent::sm(0)
            | AlEvent::sm(SM_OUTPUTS);
        pdi.write_u32(regs::AL_EVENT_MASK.addr, mask)?;
        self.esc_sms = pdi.read_u8(regs::SM_COUNT.addr)?.min(regs::MAX_SMS);
        if let Some(alias) = self.alias_from_parameter() {
            // The ESC loaded SII word 4 into 0x0012 before; the PDI may overwrite the register.
            pdi.write_u16(regs::STATION_ALIAS.addr, alias)?;
        }
        self.apply_input_shift_parameter();
        self.apply_lost_outputs_parameter();
        if self.profile.device.esm.pdi_error.is_some() {
            // Errors counted before the firmware ran (the ESC counts from its reset) are not
            // this run's PDI failures.
            self.pdi_errors_seen = pdi.read_u8(regs::PDI_ERROR_COUNTER.addr)?;
        }
        self.app.power_on(&mut self.ram);
        // The ESC is not reset with the MCU (the board's watchdog, a crash, the MCU's supply
        // alone): an ESC still showing a state above INIT had this slave running for a master,
        // which must learn that it restarted and lost its configuration.
        let esc_state = AlStatus::from_bits(pdi.read_u16(regs::AL_STATUS.addr)?)
            .map_or(AlState::Init, |s| s.state);
        pdi.write_u16(regs::AL_STATUS_CODE.addr, AlStatusCode::NoError.code())?;
        pdi.write_u16(regs::AL_STATUS.addr, self.status.bits())?;
        if esc_state != AlState::Init {
            self.restarted_locally(pdi, esc_state)?;
        }
        Ok(())
    }

    /// INIT with the error indication and 0x0060 "slave restarted locally" (ETG.1000.6 Table 11,
    /// any state → INIT), with the emergency, 10F3h message and 1001h of every AL error; the
    /// message names `was`, the state the ESC still showed.
    fn restarted_locally<P: EscPdi>(&mut self, pdi: &mut P, was: AlState) -> Result<(), P::Error> {
        let previous = (self.status, self.code);
        let outcome = esm::fault(AlState::Init, AlState::Init, AlStatusCode::RestartedLocally);
        pdi.write_u16(regs::AL_STATUS_CODE.addr, outcome.code.code())?;
        pdi.write_u16(regs::AL_STATUS.addr, outcome.status.bits())?;
        self.status = outcome.status;
        self.code = outcome.code;
        // The profile's ERR LED for this error, else ETG.1300's for a local error.
        self.error_indication = match self.profile.device.esm.al_error_led(outcome.code.code()) {
            Some(led) => ErrorIndication::showing(led),
            None => ErrorIndication::LocalError,
        };
        self.track_al_error(was, previous, outcome);
        Ok(())
    }

    /// The object dictionary.
    pub fn dictionary(&mut self) -> Dictionary<'_> {
        Dictionary::new(self.profile, &mut self.ram)
    }

    /// Loads the stored parameters (1010h) over the defaults. Call once at power-on, after
    /// [`Self::new`] and before [`Self::start`]: only in INIT, so a stored PDO mapping or
    /// assignment is in place before the first PREOP → SAFEOP transition builds the copy plan.
    /// `Ok(None)`: nothing valid stored, the defaults stay; `Err`: storage failure, the
    /// defaults stay.
    pub fn load_parameters<S: NvStorage, const CAP: usize>(
        &mut self,
        params: &mut ParamStore<S, CAP>,
    ) -> Result<Option<Loaded>, ParamError> {
        if self.status.state != AlState::Init {
            return Err(ParamError::NotInInit);
        }
        params.load(&mut self.dictionary())
    }

    /// The application and the OD RAM it works on (for set-up the board does between cycles,
    /// e.g. connecting a motor, and for tests).
    pub fn application(&mut self) -> (&mut A, &mut [u8]) {
        (&mut self.app, &mut self.ram)
    }

    /// The application.
    pub fn app(&self) -> &A {
        &self.app
    }

    /// The profile.
    pub fn profile(&self) -> &'static Profile {
        self.profile
    }

    /// The current EtherCAT state.
    pub fn al_state(&self) -> AlState {
        self.status.state
    }

    /// The current AL status and status code.
    pub fn al_status(&self) -> (AlStatus, AlStatusCode) {
        (self.status, self.code)
    }

    /// The synchronisation in use (valid from SAFEOP on).
    pub fn sync_mode(&self) -> SyncMode {
        self.sync.mode
    }

    /// The cycle in ns (valid from SAFEOP on): the SYNC0 cycle in DC modes, the free-run
    /// period (1C32h:02) in free run, 0 when SM-synchronous.
    pub fn cycle_ns(&self) -> u32 {
        self.sync.cycle_ns
    }

    /// The board reports that its control loop lost (or could not make) its phase lock to
    /// SYNC0: in SAFEOP/OP of a DC mode the slave goes to SAFEOP with AL status 0x0032 "PLL
    /// error" at its next check (ETG.1000.6 Table 11), as for a SYNC0 at another period. The
    /// sync supervision looks at it only there, and forgets it whenever it starts anew (on
    /// entering SAFEOP, on a new DC configuration), so a report outside has no effect.
    pub fn report_phase_lock_lost(&mut self) {
        self.sync_supervisor.report_phase_lock_lost();
    }

    /// Process-data cycles run since power-on.
    pub fn cycles(&self) -> u32 {
        self.cycles
    }

    /// First part of the ESC-event handler (bounded, no mailbox traffic): reads the AL event
    /// register; handles state change requests, SM (re)activation, the process-data watchdog and
    /// SYNC0 supervision. Returns the events and the state the mailbox side works with.
    pub fn event_begin<P: EscPdi>(
        &mut self,
        pdi: &mut P,
        now_ns: u64,
    ) -> Result<EventJob, P::Error> {
        let events = AlEvent(pdi.read_u32(regs::AL_EVENT_REQUEST.addr)?);
        self.now_ns = now_ns;
        if events.any(AlEvent::sm(SM_OUTPUTS))
            && matches!(self.status.state, AlState::SafeOp | AlState::Op)
        {
            self.outputs_received = true;
        }
        if events.any(AlEvent::AL_CONTROL) {
            // Reading AL control clears the event; a new request replaces a waiting one.
            let control = AlControl::from_bits(pdi.read_u16(regs::AL_CONTROL.addr)?);
            self.pending_op = None;
            // The master acts again: an error it could not see in the AL status is history.
            self.error_without_flag = false;
            self.handle_al_control(pdi, control, now_ns)?;
        } else if let Some((control, _)) = self.pending_op {
            self.handle_al_control(pdi, control, now_ns)?;
        }
        if events.any(AlEvent::SM_ACTIVATION) {
            let read = self.revalidate_sms(pdi)?;
            self.acknowledge_sm_activation(pdi, read)?;
        }
        if events.any(AlEvent::WATCHDOG_PD) {
            self.check_watchdog(pdi)?;
        }
        self.supervise_link(pdi)?;
        self.supervise_pdi(pdi)?;
        self.supervise_sync(pdi, now_ns)?;
        self.app.background(&mut self.ram, now_ns);
        Ok(EventJob {
            events,
            state: self.status.state,
        })
    }

    /// Last part of the ESC-event handler (bounded), after the mailbox side handed its writes
    /// back: diagnosis acknowledgements, the synchronisation the master set up in SAFEOP, and
    /// the SM-synchronous cycle on the SM2 event.
    pub fn event_end<P: EscPdi>(
        &mut self,
        pdi: &mut P,
        job: EventJob,
        now_ns: u64,
    ) -> Result<(), P::Error> {
        // The master acknowledges diagnosis messages by writing 10F3h:03, with an SDO
        // download: a request in SM0 (whose event is set until its buffer is read, which this
        // round did), served in the round that reads it. A round without one (a cycle's SM2
        // event, a timer) has nothing to pick up.
        let request = job.events.any(AlEvent::sm(SM_MAILBOX_OUT));
        if request && job.state != AlState::Init && job.state != AlState::Boot {
            let _ = self
                .diag
                .poll(&mut Dictionary::new(self.profile, &mut self.ram));
        }
        if job.state == AlState::SafeOp {
            // Masters may activate SYNC0 only after SAFEOP was reached (SOEM's dc_sync).
            let sync = self.read_sync(pdi)?;
            if sync != self.sync {
                self.sync_supervisor.reset();
                self.sync_lock_since_ns = now_ns;
            }
            self.sync = sync;
            self.publish_sync_parameters();
        }
        if self.sync.mode == Mode::SmSynchronous && job.events.any(AlEvent::sm(SM_OUTPUTS)) {
            self.on_cycle(pdi, now_ns)?;
        }
        Ok(())
    }

    /// The RUN and ERR LED states at `now_ns` (ETG.1300 patterns); boards switch their LEDs
    /// with it every few ms.
    pub fn leds(&self, now_ns: u64) -> (bool, bool) {
        const NS_PER_MS: u64 = 1_000_000;
        let t_ms = now_ns / NS_PER_MS;
        let error = if self.status.error || self.error_without_flag {
            self.error_indication
        } else {
            ErrorIndication::None
        };
        (
            leds::run_pattern(self.status.state).lit_at(t_ms),
            leds::err_pattern(error).lit_at(t_ms),
        )
    }

    /// Writes an entry of the OD if the profile has it (counters and flags the stack mirrors).
    fn write_od(&mut self, index: u16, subindex: u8, bytes: &[u8]) {
        let mut od = self.dictionary();
        if let Some(e) = od.entry(index, subindex) {
            let n = e.byte_len().min(bytes.len());
            let _ = od.set_value(e, bytes.get(..n).unwrap_or(&[]));
        }
    }

    /// Profile rule: the station alias a parameter sets at power-on (GHA-E Pn-410 when not 0,
    /// SDV3-E P4.01 while P4.02 = 1); `None`: the SII's alias stays. A value outside
    /// 1..=65535 (a signed parameter's negative value included) is ignored.
    fn alias_from_parameter(&mut self) -> Option<u16> {
        let device = &self.profile.device;
        let (index, subindex) = device.station_alias_parameter?;
        let selector = device.station_alias_selector;
        let od = self.dictionary();
        if let Some((s_index, s_subindex, value)) = selector {
            if od.read_u32(s_index, s_subindex) != Some(value) {
                return None;
            }
        }
        let alias = od.read_u32(index, subindex)?;
        u16::try_from(alias).ok().filter(|a| *a != 0)
    }

    /// Profile rule: a parameter sets the input shift time 1C33h:03 at power-on, in steps of
    /// `input_shift_step_ns` (SDV3-E P4.09 × 62500 ns); a value whose shift is outside the
    /// entry's range is ignored (1C33h:03 keeps its default).
    fn apply_input_shift_parameter(&mut self) {
        let sync = self.profile.device.sync;
        let Some((index, subindex)) = sync.input_shift_parameter else {
            return;
        };
        let mut od = self.dictionary();
        let Some(steps) = od.read_u32(index, subindex) else {
            return;
        };
        let Some(shift) = steps.checked_mul(sync.input_shift_step_ns) else {
            return;
        };
        if let Some(entry) = od.entry(SM_INPUT_PARAMETER, SUB_SHIFT_TIME) {
            let bytes = shift.to_le_bytes();
            if crate::od::value::check_range(entry, &bytes).is_ok() {
                let _ = od.set_value(entry, &bytes);
            }
        }
    }

    /// Profile rule (`[esm] lost_outputs`): the number of lost cycles in a row that trips is a
    /// parameter read at power-on (the SDV3-E's P4.03 takes effect after a power cycle); a
    /// value that does not fit 16 bits is the largest count.
    fn apply_lost_outputs_parameter(&mut self) {
        let Some(rule) = self.profile.device.esm.lost_outputs else {
            return;
        };
        let (index, subindex) = rule.limit_parameter;
        let limit = self.dictionary().read_u32(index, subindex).unwrap_or(0);
        self.lost_outputs
            .set_limit(u16::try_from(limit).unwrap_or(u16::MAX));
    }

    /// The synchronisation the master configured: DC registers, 1C32h:01 and (free run)
    /// 1C32h:02.
    fn read_sync<P: EscPdi>(&mut self, pdi: &mut P) -> Result<SyncConfig, P::Error> {
        let sm_sync = self.sm_sync_requested();
        let free_run_cycle_ns = self
            .dictionary()
            .read_u32(SM_OUTPUT_PARAMETER, SUB_CYCLE_TIME)
            .unwrap_or(0);
        SyncConfig::read(pdi, sm_sync, free_run_cycle_ns)
    }

    /// 1C33h:03, the input shift time the master set (0 if the profile has none).
    fn input_shift_ns(&mut self) -> u32 {
        self.dictionary()
            .read_u32(SM_INPUT_PARAMETER, SUB_SHIFT_TIME)
            .unwrap_or(0)
    }

    fn sm_sync_requested(&self) -> bool {
        let ram = &self.ram;
        let od = self.profile;
        od.object(SM_OUTPUT_PARAMETER)
            .and_then(|o| o.entry(SUB_SYNC_TYPE))
            .and_then(|e| match e.value {
                crate::od::Value::Ram(off) => ram.get(off as usize).copied(),
                crate::od::Value::Const(b) => b.first().copied(),
                crate::od::Value::Domain(_) => None,
            })
            == Some(Mode::SmSynchronous as u8)
    }
}
