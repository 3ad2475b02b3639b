//! The slave: owns the stack state and the OD RAM; boards call its entry points.
//!
//! | entry point | called from (target) | called from (sim) |
//! |---|---|---|
//! | [`Slave::on_esc_event`] | ESC IRQ (AL event) task, and periodically from thread mode | after every frame the ESC processed |
//! | [`Slave::on_cycle`] | SYNC0 EXTI (DC), or a local timer (free-run) | at each simulated SYNC0 / free-run tick |
//!
//! In SM-synchronous mode the cycle runs from [`Slave::on_esc_event`] on the SM2 event.

use hal::esc::{regs, AlControl, AlEvent, AlState, AlStatus, AlStatusCode, SmConfig, SmDirection};
use hal::pdi::EscPdi;
use hal::storage::NvStorage;

use crate::app::Application;
use crate::cia402::pds::PdsState;
use crate::diag::{diag_code_for_emcy, DiagError, DiagMessage, DiagParam, DiagType, Diagnosis};
use crate::esm::{self, Checks, Outcome};
use crate::leds::{self, ErrorIndication};
use crate::mailbox::coe::{DomainStore, NoDomains, WithDomains};
use crate::mailbox::emcy::{self, ActiveErrors, Emergency};
use crate::mailbox::Mailbox;
use crate::od::{Dictionary, Profile};
use crate::params::{Loaded, NoStorage, ParamError, ParamStore};
use crate::pdo::{Direction, PdoPlan, MAX_IMAGE};
use crate::sm_check;
use crate::supervision::{SyncSupervisor, DEFAULT_COUNTER_LIMIT};
pub use crate::sync::SyncMode;
use crate::sync::{SyncConfig, SyncMode as Mode};

/// SM channel of the process-data outputs.
const SM_OUTPUTS: u8 = 2;
/// SM channel of the process-data inputs.
const SM_INPUTS: u8 = 3;
/// Sync manager parameter objects (ETG.1020 §5.1): outputs (SM2) and inputs (SM3).
const SM_OUTPUT_PARAMETER: u16 = 0x1C32;
const SM_INPUT_PARAMETER: u16 = 0x1C33;
/// 1C32h/1C33h subindices the stack maintains.
const SUB_SYNC_TYPE: u8 = 0x01;
const SUB_CYCLE_TIME: u8 = 0x02;
const SUB_CALC_AND_COPY_TIME: u8 = 0x06;
const SUB_DELAY_TIME: u8 = 0x09;
const SUB_SM_EVENT_MISSED: u8 = 0x0B;
const SUB_CYCLE_TIME_TOO_SMALL: u8 = 0x0C;
const SUB_SYNC_ERROR: u8 = 0x20;
/// Error settings object (ETG.1020 §5.1): :02 sync error counter limit.
const ERROR_SETTINGS: u16 = 0x10F1;
const SUB_SYNC_ERROR_LIMIT: u8 = 0x02;
/// Process-data watchdog status 0x0440 bit 0: 1 = running or disabled, 0 = expired.
const WATCHDOG_PD_OK: u16 = 1 << 0;

/// The EtherCAT slave with its object dictionary. `RAM` is the OD RAM size
/// (`profiles::<name>::RAM_SIZE`, or `profiles::MAX_RAM_SIZE` to choose the profile at run time).
pub struct Slave<const RAM: usize> {
    profile: &'static Profile,
    ram: [u8; RAM],
    status: AlStatus,
    code: AlStatusCode,
    mailbox: Mailbox,
    rx_plan: PdoPlan,
    tx_plan: PdoPlan,
    sync: SyncConfig,
    rx_image: [u8; MAX_IMAGE],
    tx_image: [u8; MAX_IMAGE],
    app: Application,
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
    /// Start of the running process-data cycle (board clock, ns).
    cycle_started_ns: u64,
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
}

impl<const RAM: usize> Slave<RAM> {
    /// A slave in INIT with every object at its default.
    pub fn new(profile: &'static Profile) -> Result<Self, SlaveError> {
        if profile.ram_size() > RAM {
            return Err(SlaveError::RamTooSmall {
                needed: profile.ram_size(),
                available: RAM,
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
            mailbox: Mailbox::new(),
            rx_plan: PdoPlan::default(),
            tx_plan: PdoPlan::default(),
            sync: SyncConfig {
                mode: Mode::FreeRun,
                cycle_ns: 0,
            },
            rx_image: [0; MAX_IMAGE],
            tx_image: [0; MAX_IMAGE],
            app: Application::new(),
            cycles: 0,
            id_value: 0,
            sync_supervisor: SyncSupervisor::default(),
            pending_op: None,
            outputs_received: false,
            error_indication: ErrorIndication::None,
            cycle_started_ns: 0,
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
    /// SM-synchronous cycles, process-data watchdog).
    pub fn start<P: EscPdi>(&mut self, pdi: &mut P) -> Result<(), P::Error> {
        let mask = AlEvent::AL_CONTROL
            | AlEvent::SM_ACTIVATION
            | AlEvent::WATCHDOG_PD
            | AlEvent::sm(0)
            | AlEvent::sm(1)
            | AlEvent::sm(SM_OUTPUTS);
        pdi.write_u32(regs::AL_EVENT_MASK.addr, mask)?;
        pdi.write_u16(regs::AL_STATUS_CODE.addr, AlStatusCode::NoError.code())?;
        pdi.write_u16(regs::AL_STATUS.addr, self.status.bits())
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

    /// The SYNC0 cycle in ns in DC mode, else 0.
    pub fn cycle_ns(&self) -> u32 {
        self.sync.cycle_ns
    }

    /// Process-data cycles run since power-on.
    pub fn cycles(&self) -> u32 {
        self.cycles
    }

    /// Handles pending AL events: state change requests, mailbox traffic, the SM2 event in
    /// SM-synchronous mode. Safe to call at any time (it polls what it needs).
    /// Without parameter storage: "save" to 1010h / "load" to 1011h are answered with SDO abort
    /// 0x0606_0000 (see [`Self::on_esc_event_with`]).
    pub fn on_esc_event<P: EscPdi>(&mut self, pdi: &mut P, now_ns: u64) -> Result<(), P::Error> {
        self.on_esc_event_with(pdi, &mut ParamStore::<NoStorage, 0>::new(NoStorage), now_ns)
    }

    /// [`Self::on_esc_event`] with the board's parameter storage: an SDO download of "save" to
    /// 1010h or "load" to 1011h runs the store/restore on `params` before the SDO response is
    /// sent (CiA 301 §7.5.2.13/14, see [`crate::params`]).
    pub fn on_esc_event_with<P: EscPdi, S: NvStorage, const CAP: usize>(
        &mut self,
        pdi: &mut P,
        params: &mut ParamStore<S, CAP>,
        now_ns: u64,
    ) -> Result<(), P::Error> {
        self.on_esc_event_full(pdi, params, &mut NoDomains, now_ns)
    }

    /// [`Self::on_esc_event_with`] with the board's store of DOMAIN objects kept outside the OD
    /// RAM (`Value::Domain`, streamed by segmented SDO; see [`crate::mailbox::coe::domain`]).
    pub fn on_esc_event_full<P: EscPdi, S: NvStorage, const CAP: usize>(
        &mut self,
        pdi: &mut P,
        params: &mut ParamStore<S, CAP>,
        domains: &mut dyn DomainStore,
        now_ns: u64,
    ) -> Result<(), P::Error> {
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
            self.handle_al_control(pdi, control, now_ns)?;
        } else if let Some((control, _)) = self.pending_op {
            self.handle_al_control(pdi, control, now_ns)?;
        }
        if events.any(AlEvent::SM_ACTIVATION) {
            self.revalidate_sms(pdi)?;
        }
        if events.any(AlEvent::WATCHDOG_PD) {
            self.check_watchdog(pdi)?;
        }
        self.supervise_sync(pdi, now_ns)?;
        let state = self.status.state;
        if state != AlState::Init && state != AlState::Boot {
            let mut od = Dictionary::new(self.profile, &mut self.ram);
            self.mailbox.service_with(
                pdi,
                &self.profile.device,
                &mut od,
                state,
                events,
                &mut WithDomains {
                    hook: params,
                    domains,
                },
            )?;
            // The master acknowledges diagnosis messages by writing 10F3h:03.
            let _ = self.diag.poll(&mut od);
        }
        if state == AlState::SafeOp {
            // Masters may activate SYNC0 only after SAFEOP was reached (SOEM's dc_sync).
            let sync = SyncConfig::read(pdi, self.sm_sync_requested())?;
            if sync != self.sync {
                self.sync_supervisor.reset();
            }
            self.sync = sync;
            self.publish_sync_parameters();
        }
        if self.sync.mode == Mode::SmSynchronous && events.any(AlEvent::sm(SM_OUTPUTS)) {
            self.on_cycle(pdi, now_ns)?;
        }
        Ok(())
    }

    /// Tells the slave when the process-data cycle started by the last [`Self::on_cycle`] ended
    /// (board clock, ns; on target right after `on_cycle` returns). The duration is the
    /// measured "calc and copy time" (ETG.1020 1C32h/1C33h:06, the longest since SAFEOP) and
    /// the delay until outputs are valid for the control loop (:09); a cycle longer than the
    /// SYNC0 cycle counts in :0C ("cycle time too small").
    pub fn cycle_finished(&mut self, now_ns: u64) {
        if !matches!(self.status.state, AlState::SafeOp | AlState::Op) {
            return;
        }
        let elapsed = now_ns.saturating_sub(self.cycle_started_ns);
        let elapsed = u32::try_from(elapsed).unwrap_or(u32::MAX);
        if elapsed > self.calc_and_copy_max_ns {
            self.calc_and_copy_max_ns = elapsed;
            let bytes = elapsed.to_le_bytes();
            for index in [SM_OUTPUT_PARAMETER, SM_INPUT_PARAMETER] {
                self.write_od(index, SUB_CALC_AND_COPY_TIME, &bytes);
                self.write_od(index, SUB_DELAY_TIME, &bytes);
            }
        }
        if self.sync.cycle_ns != 0 && elapsed > self.sync.cycle_ns {
            self.cycle_too_small = self.cycle_too_small.saturating_add(1);
            let count = self.cycle_too_small.to_le_bytes();
            self.write_od(SM_OUTPUT_PARAMETER, SUB_CYCLE_TIME_TOO_SMALL, &count);
        }
    }

    /// The RUN and ERR LED states at `now_ns` (ETG.1300 patterns); boards switch their LEDs
    /// with it every few ms.
    pub fn leds(&self, now_ns: u64) -> (bool, bool) {
        const NS_PER_MS: u64 = 1_000_000;
        let t_ms = now_ns / NS_PER_MS;
        let error = if self.status.error {
            self.error_indication
        } else {
            ErrorIndication::None
        };
        (
            leds::run_pattern(self.status.state).lit_at(t_ms),
            leds::err_pattern(error).lit_at(t_ms),
        )
    }

    /// SM activation changed: the master rewrote an SM. In PREOP and above the mailbox SMs must
    /// still match (else INIT + 0x0016), in SAFEOP and OP also SM2/SM3 (else PREOP +
    /// 0x001D/0x001E), as on the original transition (ETG.1000.6 §6.4.2).
    fn revalidate_sms<P: EscPdi>(&mut self, pdi: &mut P) -> Result<(), P::Error> {
        let state = self.status.state;
        let device = self.profile.device;
        if esm::state_rank(state) < 1 || state == AlState::Boot {
            return Ok(());
        }
        let sm0 = read_sm(pdi, 0)?;
        let sm1 = read_sm(pdi, 1)?;
        if let Err(code) = sm_check::check_mailbox(sm0, sm1, &device) {
            return self.raise_fault(
                pdi,
                AlState::Init,
                code,
                ErrorIndication::InvalidConfiguration,
            );
        }
        if esm::state_rank(state) < 2 {
            return Ok(());
        }
        let sm2 = read_sm(pdi, SM_OUTPUTS)?;
        let sm3 = read_sm(pdi, SM_INPUTS)?;
        let result = sm_check::check_process_data(
            sm2,
            &device.outputs,
            SmDirection::EcatWrite,
            self.rx_plan.byte_len() as u16,
            AlStatusCode::InvalidOutputConfig,
        )
        .and(sm_check::check_process_data(
            sm3,
            &device.inputs,
            SmDirection::EcatRead,
            self.tx_plan.byte_len() as u16,
            AlStatusCode::InvalidInputConfig,
        ));
        match result {
            Ok(()) => Ok(()),
            Err(code) => self.raise_fault(
                pdi,
                AlState::PreOp,
                code,
                ErrorIndication::InvalidConfiguration,
            ),
        }
    }

    /// Process-data watchdog (0x0440 bit 0 cleared by the ESC when SM2 was not written within
    /// the watchdog time): in OP the drive drops to SAFEOP with 0x001B (ETG.1000.6 Table 11).
    /// Reading 0x0440 acknowledges the AL event.
    fn check_watchdog<P: EscPdi>(&mut self, pdi: &mut P) -> Result<(), P::Error> {
        let status = pdi.read_u16(regs::WATCHDOG_STATUS_PD.addr)?;
        if status & WATCHDOG_PD_OK == 0 && self.status.state == AlState::Op {
            self.raise_fault(
                pdi,
                AlState::SafeOp,
                AlStatusCode::SmWatchdog,
                ErrorIndication::WatchdogTimeout,
            )?;
        }
        Ok(())
    }

    /// Counts missed SYNC0 events in DC modes (SAFEOP, OP) and leaves OP with 0x001A when the
    /// counter passes 10F1h:02; mirrors 1C32h:0B (missed) and 1C32h:20 (sync error).
    fn supervise_sync<P: EscPdi>(&mut self, pdi: &mut P, now_ns: u64) -> Result<(), P::Error> {
        let dc = matches!(self.sync.mode, Mode::DcSync0 | Mode::DcSync1);
        if !dc || !matches!(self.status.state, AlState::SafeOp | AlState::Op) {
            return Ok(());
        }
        if self.sync_supervisor.pll_lost() && !self.status.error {
            // The control loop phase-locks to SYNC0; a SYNC0 at another period than the one
            // configured for SAFEOP cannot be followed (ETG.1000.6 Table 11: 0x0032 PLL error).
            self.sync_supervisor.reset();
            return self.raise_fault(
                pdi,
                AlState::SafeOp,
                AlStatusCode::PllError,
                ErrorIndication::LocalError,
            );
        }
        if self.sync_supervisor.check(now_ns, self.sync.cycle_ns) == 0 {
            return Ok(());
        }
        let missed = self.sync_supervisor.missed_total();
        self.write_od(
            SM_OUTPUT_PARAMETER,
            SUB_SM_EVENT_MISSED,
            &missed.to_le_bytes(),
        );
        let limit = self
            .dictionary()
            .read_u32(ERROR_SETTINGS, SUB_SYNC_ERROR_LIMIT)
            .map_or(DEFAULT_COUNTER_LIMIT, |v| v as u16);
        if self.sync_supervisor.tripped(limit) && !self.status.error {
            self.write_od(SM_OUTPUT_PARAMETER, SUB_SYNC_ERROR, &[1]);
            self.sync_supervisor.reset();
            self.raise_fault(
                pdi,
                AlState::SafeOp,
                AlStatusCode::SyncError,
                ErrorIndication::LocalError,
            )?;
        }
        Ok(())
    }

    /// Leaves the current state for `fallback` (if lower) with the error flag and `code`.
    fn raise_fault<P: EscPdi>(
        &mut self,
        pdi: &mut P,
        fallback: AlState,
        code: AlStatusCode,
        indication: ErrorIndication,
    ) -> Result<(), P::Error> {
        let from = self.status.state;
        self.pending_op = None;
        self.error_indication = indication;
        self.apply(pdi, from, esm::fault(from, fallback, code))
    }

    /// Writes an entry of the OD if the profile has it (counters and flags the stack mirrors).
    fn write_od(&mut self, index: u16, subindex: u8, bytes: &[u8]) {
        let mut od = self.dictionary();
        if let Some(e) = od.entry(index, subindex) {
            let n = e.byte_len().min(bytes.len());
            let _ = od.set_value(e, bytes.get(..n).unwrap_or(&[]));
        }
    }

    /// Runs one process-data cycle: read outputs (SM2), run the application, write inputs (SM3).
    /// Does nothing below SAFEOP. Outputs are applied only in OP.
    pub fn on_cycle<P: EscPdi>(&mut self, pdi: &mut P, now_ns: u64) -> Result<(), P::Error> {
        let state = self.status.state;
        if state != AlState::SafeOp && state != AlState::Op {
            return Ok(());
        }
        self.cycle_started_ns = now_ns;
        if matches!(self.sync.mode, Mode::DcSync0 | Mode::DcSync1) {
            self.sync_supervisor.on_sync0(now_ns, self.sync.cycle_ns);
        }
        let device = &self.profile.device;
        let rx_len = self.rx_plan.byte_len();
        if rx_len > 0 {
            if let Some(image) = self.rx_image.get_mut(..rx_len) {
                pdi.read(device.outputs.start, image)?;
            }
            if state == AlState::Op {
                self.rx_plan.unpack(&self.rx_image, &mut self.ram);
            }
        }
        let fault_before = self.app.fault_code();
        self.app.step(&self.profile.vars, &mut self.ram);
        if let (Some(code), None) = (fault_before, self.app.fault_code()) {
            // Fault reset (CiA402): the error leaves 1001h; the last one clears with an
            // error-reset EMCY (CiA 301). A full queue only loses that notification.
            let _ = self.clear_error(code);
        }
        self.write_inputs(pdi)?;
        self.cycles = self.cycles.wrapping_add(1);
        Ok(())
    }

    fn write_inputs<P: EscPdi>(&mut self, pdi: &mut P) -> Result<(), P::Error> {
        let tx_len = self.tx_plan.byte_len();
        if tx_len == 0 {
            return Ok(());
        }
        self.tx_plan.pack(&self.ram, &mut self.tx_image);
        if let Some(image) = self.tx_image.get(..tx_len) {
            pdi.write(self.profile.device.inputs.start, image)?;
        }
        Ok(())
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

    fn handle_al_control<P: EscPdi>(
        &mut self,
        pdi: &mut P,
        control: AlControl,
        now_ns: u64,
    ) -> Result<(), P::Error> {
        let from = self.status.state;
        let checks = self.checks_for(pdi, from, control)?;
        let mut outcome = esm::decide(self.status, self.code, control, &checks);
        if from == AlState::SafeOp && outcome.status.state == AlState::Op {
            match self.op_gate(now_ns) {
                OpGate::Open => self.pending_op = None,
                OpGate::Wait => {
                    // Stay in SAFEOP without error; re-evaluated on every event.
                    self.pending_op.get_or_insert((control, now_ns));
                    return Ok(());
                }
                OpGate::Refuse(code) => {
                    self.pending_op = None;
                    outcome = esm::fault(from, from, code);
                }
            }
        }
        if outcome.status.error && (outcome.code != self.code || !self.status.error) {
            self.error_indication = ErrorIndication::InvalidConfiguration;
        }
        if control.id_request && !outcome.status.error {
            // Device identification (ETG.1000.6 §6.4.1.2): the station alias goes into the
            // AL status code, flagged by AL status bit 5.
            self.id_value = pdi.read_u16(regs::STATION_ALIAS.addr)?;
            outcome.status.id_loaded = true;
        }
        self.apply(pdi, from, outcome)
    }

    /// Whether a SAFEOP → OP transition that passed its checks may complete now: in DC modes
    /// only after the first SYNC0 (else 0x002D "no sync error" after the timeout), and only
    /// after the master wrote outputs once (else 0x0019 "no valid outputs").
    fn op_gate(&self, now_ns: u64) -> OpGate {
        let waited = self
            .pending_op
            .map_or(0, |(_, since)| now_ns.saturating_sub(since));
        // Profile rules (`[esm]`): the SAFEOP → OP timeout and whether outputs are required.
        let rules = &self.profile.device.esm;
        let timed_out = waited > rules.safeop_op_timeout_ns();
        let dc = matches!(self.sync.mode, Mode::DcSync0 | Mode::DcSync1);
        if dc && !self.sync_supervisor.running() {
            return if timed_out {
                OpGate::Refuse(AlStatusCode::NoSyncError)
            } else {
                OpGate::Wait
            };
        }
        if rules.op_requires_outputs && self.rx_plan.byte_len() > 0 && !self.outputs_received {
            return if timed_out {
                OpGate::Refuse(AlStatusCode::NoValidOutputs)
            } else {
                OpGate::Wait
            };
        }
        OpGate::Open
    }

    /// Evaluates only the checks the requested transition needs.
    fn checks_for<P: EscPdi>(
        &mut self,
        pdi: &mut P,
        from: AlState,
        control: AlControl,
    ) -> Result<Checks, P::Error> {
        let device = &self.profile.device;
        let mut checks = Checks {
            boot_supported: device.boot_mailbox_out.is_some() && device.boot_mailbox_in.is_some(),
            ..Checks::ALL_OK
        };
        match (from, control.requested()) {
            (AlState::Init, Some(AlState::PreOp)) => {
                let sm0 = read_sm(pdi, 0)?;
                let sm1 = read_sm(pdi, 1)?;
                checks.mailbox = sm_check::check_mailbox(sm0, sm1, device);
            }
            (AlState::Init, Some(AlState::Boot)) if checks.boot_supported => {
                let sm0 = read_sm(pdi, 0)?;
                let sm1 = read_sm(pdi, 1)?;
                checks.boot_mailbox = sm_check::check_boot_mailbox(sm0, sm1, device);
            }
            (AlState::PreOp, Some(AlState::SafeOp)) => {
                checks.process_data = self.prepare_process_data(pdi)?;
                let sync = SyncConfig::read(pdi, self.sm_sync_requested())?;
                checks.sync = sync.check(&device.sync);
                self.sync = sync;
            }
            (AlState::SafeOp, Some(AlState::Op)) => {
                let sync = SyncConfig::read(pdi, self.sm_sync_requested())?;
                checks.sync = sync.check(&device.sync);
                self.sync = sync;
            }
            _ => {}
        }
        Ok(checks)
    }

    /// Builds both copy plans from the OD and checks SM2/SM3 against them.
    fn prepare_process_data<P: EscPdi>(
        &mut self,
        pdi: &mut P,
    ) -> Result<Result<(), AlStatusCode>, P::Error> {
        let device = self.profile.device;
        let od = Dictionary::new(self.profile, &mut self.ram);
        let rx = PdoPlan::build(&od, Direction::Rx);
        let tx = PdoPlan::build(&od, Direction::Tx);
        let (rx, tx) = match (rx, tx) {
            (Ok(rx), Ok(tx)) => (rx, tx),
            (Err(code), _) | (_, Err(code)) => return Ok(Err(code)),
        };
        let sm2 = read_sm(pdi, SM_OUTPUTS)?;
        let sm3 = read_sm(pdi, SM_INPUTS)?;
        let result = sm_check::check_process_data(
            sm2,
            &device.outputs,
            SmDirection::EcatWrite,
            rx.byte_len() as u16,
            AlStatusCode::InvalidOutputConfig,
        )
        .and(sm_check::check_process_data(
            sm3,
            &device.inputs,
            SmDirection::EcatRead,
            tx.byte_len() as u16,
            AlStatusCode::InvalidInputConfig,
        ));
        if result.is_ok() {
            self.rx_plan = rx;
            self.tx_plan = tx;
        }
        Ok(result)
    }

    /// Writes the outcome (code first, then status, each only if changed) and runs the work of
    /// the states left and entered.
    fn apply<P: EscPdi>(
        &mut self,
        pdi: &mut P,
        from: AlState,
        outcome: Outcome,
    ) -> Result<(), P::Error> {
        let to = outcome.status.state;
        if to != from {
            self.leave_and_enter(pdi, from, to)?;
        }
        if outcome.code != self.code || outcome.status != self.status {
            let code_register = if outcome.status.id_loaded {
                self.id_value
            } else {
                outcome.code.code()
            };
            pdi.write_u16(regs::AL_STATUS_CODE.addr, code_register)?;
            pdi.write_u16(regs::AL_STATUS.addr, outcome.status.bits())?;
        }
        let previous = (self.status, self.code);
        self.status = outcome.status;
        self.code = outcome.code;
        // Every AL error (refused transition, watchdog, sync error, SM re-validation) passes
        // here: EMCY + 10F3h message + 1001h; the acknowledged error clears (EMCY 0x0000).
        self.track_al_error(from, previous, outcome);
        Ok(())
    }

    fn leave_and_enter<P: EscPdi>(
        &mut self,
        pdi: &mut P,
        from: AlState,
        to: AlState,
    ) -> Result<(), P::Error> {
        let rank_from = esm::state_rank(from);
        let rank_to = esm::state_rank(to);
        if from == AlState::Op {
            // Leaving OP: outputs go to their safe state (controlword 0 = disable voltage).
            let was_enabled = self.app.pds_state() == PdsState::OperationEnabled;
            self.app.safe_outputs(&self.profile.vars, &mut self.ram);
            // Profile rule (`[esm] op_exit_while_enabled_error`): leaving OP while the drive
            // was in Operation Enabled is a fault: 603Fh, EMCY, PDS Fault.
            if let Some(code) = self
                .profile
                .device
                .esm
                .op_exit_while_enabled_error
                .filter(|_| was_enabled)
            {
                self.app.fault(code, &self.profile.vars, &mut self.ram);
                // A full EMCY queue or a stopped mailbox loses only the EMCY; 1001h/603Fh hold.
                let _ = self.report_error(
                    code,
                    emcy::register::DEVICE_PROFILE,
                    [0; 5],
                    None,
                    self.now_ns,
                );
            }
        }
        if rank_to < 2 && rank_from >= 2 {
            self.rx_plan = PdoPlan::default();
            self.tx_plan = PdoPlan::default();
            self.sync = SyncConfig {
                mode: Mode::FreeRun,
                cycle_ns: 0,
            };
        }
        if to == AlState::Init {
            self.mailbox.reset();
        }
        if rank_to <= 2 && to != from {
            // Entering or returning to SAFEOP or below: supervision and the OP gate restart.
            self.sync_supervisor.reset();
            self.outputs_received = false;
            self.calc_and_copy_max_ns = 0;
        }
        if from == AlState::PreOp && to == AlState::SafeOp {
            self.write_od(SM_OUTPUT_PARAMETER, SUB_SYNC_ERROR, &[0]);
            self.publish_sync_parameters();
            // Inputs are valid from SAFEOP on: write them once before the master reads SM3.
            self.app.step(&self.profile.vars, &mut self.ram);
            self.write_inputs(pdi)?;
        }
        Ok(())
    }

    /// Mirrors the active synchronisation into 1C32h/1C33h (:01 sync type, :02 cycle time).
    fn publish_sync_parameters(&mut self) {
        let mode = self.sync.mode as u16;
        let cycle = self.sync.cycle_ns;
        let mut od = Dictionary::new(self.profile, &mut self.ram);
        for index in [SM_OUTPUT_PARAMETER, SM_INPUT_PARAMETER] {
            if let Some(e) = od.entry(index, SUB_SYNC_TYPE) {
                let _ = od.set_value(e, &mode.to_le_bytes()[..e.byte_len().min(2)]);
            }
            if cycle != 0 {
                if let Some(e) = od.entry(index, SUB_CYCLE_TIME) {
                    let _ = od.set_value(e, &cycle.to_le_bytes()[..e.byte_len().min(4)]);
                }
            }
        }
    }
}

/// Decision on a SAFEOP → OP request whose checks passed.
enum OpGate {
    /// Go to OP.
    Open,
    /// Stay in SAFEOP for now.
    Wait,
    /// Refuse with this code.
    Refuse(AlStatusCode),
}

/// Reads the 8 register bytes of SM `n`.
fn read_sm<P: EscPdi>(pdi: &mut P, n: u8) -> Result<SmConfig, P::Error> {
    let mut b = [0u8; SmConfig::LEN];
    pdi.read(regs::sm(n).addr, &mut b)?;
    Ok(SmConfig::from_bytes(b))
}

/// Emergencies, the error register 1001h and the diagnosis history 10F3h
/// ([`crate::mailbox::emcy`], [`crate::diag`]).
impl<const RAM: usize> Slave<RAM> {
    /// Reports an error that is now active: marks `code` active in 1001h (bits from its
    /// CiA 301 class, plus `extra_register_bits`, e.g. [`emcy::register::DEVICE_PROFILE`]),
    /// stores `diag` in 10F3h if given (time stamp `now_ns`), and queues the emergency
    /// `code` / 1001h / `data`. `Err` hands the emergency back if it could not be queued
    /// (queue full, or the mailbox is not running: INIT, BOOT); 1001h and 10F3h are updated
    /// regardless.
    pub fn report_error(
        &mut self,
        code: u16,
        extra_register_bits: u8,
        data: [u8; 5],
        diag: Option<&DiagMessage>,
        now_ns: u64,
    ) -> Result<(), Emergency> {
        self.errors.raise(code, extra_register_bits);
        let register = self.errors.register();
        self.publish_error_register();
        if let Some(msg) = diag {
            let mut od = Dictionary::new(self.profile, &mut self.ram);
            // The emergency goes out below in any case; bit 0 of 10F3h:05 adds nothing here.
            let _ = self.diag.report(&mut od, msg, now_ns, register);
        }
        self.post_emcy(Emergency::new(code, register, data))
    }

    /// The error `code` is gone: clears it from 1001h; when it was the last active error,
    /// queues the "error reset" emergency (code 0x0000, register 0, CiA 301 §7.2.7.1).
    pub fn clear_error(&mut self, code: u16) -> Result<(), Emergency> {
        if !self.errors.clear(code) {
            return Ok(());
        }
        self.publish_error_register();
        if self.errors.is_empty() {
            self.post_emcy(Emergency::new(emcy::code::ERROR_RESET, 0, [0; 5]))
        } else {
            Ok(())
        }
    }

    /// Stores a diagnosis message (info, warning or an error that needs no 1001h bit) in
    /// 10F3h; sends it as an emergency too when 10F3h:05 bit 0 asks for it.
    pub fn report_diag(&mut self, msg: &DiagMessage, now_ns: u64) -> Result<(), DiagError> {
        let register = self.errors.register();
        let mut od = Dictionary::new(self.profile, &mut self.ram);
        if let Some(e) = self.diag.report(&mut od, msg, now_ns, register)? {
            let _ = self.post_emcy(e);
        }
        Ok(())
    }

    /// Queues an emergency for the master (sent when the mailbox is idle, never in place of
    /// an SDO response). `Err` hands it back when the queue is full or the mailbox is not
    /// running (INIT, BOOT).
    pub fn post_emcy(&mut self, emcy: Emergency) -> Result<(), Emergency> {
        match self.status.state {
            AlState::PreOp | AlState::SafeOp | AlState::Op => self.mailbox.post_emcy(emcy),
            AlState::Init | AlState::Boot => Err(emcy),
        }
    }

    /// The error register 1001h.
    pub fn error_register(&self) -> u8 {
        self.errors.register()
    }

    /// Emergencies waiting for the mailbox.
    pub fn pending_emcys(&self) -> usize {
        self.mailbox.pending_emcys()
    }

    /// Mirrors the active errors into 1001h.
    fn publish_error_register(&mut self) {
        const ERROR_REGISTER: u16 = 0x1001;
        let register = self.errors.register();
        self.write_od(ERROR_REGISTER, 0, &[register]);
    }

    /// Called by [`Self::apply`] with the status before and the outcome: a new AL error (error
    /// flag set, or a different code) raises [`emcy::code::ESM_TRANSITION`] with data
    /// `[state before, AL status code (LE), state after, 0]` (SOEM's `ec_emcyt` view: `bData` =
    /// state before, `w1` = AL status code, `w2` = state after) and the 10F3h message
    /// `0xA000_E800` (error, parameters: AL status code u16, state before u8, state after u8);
    /// the master's error acknowledge clears it.
    fn track_al_error(
        &mut self,
        from: AlState,
        previous: (AlStatus, AlStatusCode),
        outcome: Outcome,
    ) {
        let (was, was_code) = previous;
        let code = emcy::code::ESM_TRANSITION;
        if outcome.status.error && (!was.error || outcome.code != was_code) {
            let al = outcome.code.code();
            let [c0, c1] = al.to_le_bytes();
            let (f, t) = (from as u8, outcome.status.state as u8);
            let msg = DiagMessage::new(diag_code_for_emcy(code), DiagType::Error, 0)
                .with(DiagParam::U16(al))
                .with(DiagParam::U8(f))
                .with(DiagParam::U8(t));
            let _ = self.report_error(code, 0, [f, c0, c1, t, 0], Some(&msg), self.now_ns);
        } else if was.error && !outcome.status.error {
            let _ = self.clear_error(code);
        }
    }
}
