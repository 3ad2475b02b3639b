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

use crate::app::Application;
use crate::esm::{self, Checks, Outcome};
use crate::mailbox::Mailbox;
use crate::od::{Dictionary, Profile};
use crate::pdo::{Direction, PdoPlan, MAX_IMAGE};
use crate::sm_check;
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
    pub fn on_esc_event<P: EscPdi>(&mut self, pdi: &mut P, now_ns: u64) -> Result<(), P::Error> {
        let events = AlEvent(pdi.read_u32(regs::AL_EVENT_REQUEST.addr)?);
        if events.any(AlEvent::AL_CONTROL) {
            // Reading AL control clears the event.
            let control = AlControl::from_bits(pdi.read_u16(regs::AL_CONTROL.addr)?);
            self.handle_al_control(pdi, control)?;
        }
        let state = self.status.state;
        if state != AlState::Init && state != AlState::Boot {
            let mut od = Dictionary::new(self.profile, &mut self.ram);
            self.mailbox
                .service(pdi, &self.profile.device, &mut od, state, events)?;
        }
        if state == AlState::SafeOp {
            // Masters may activate SYNC0 only after SAFEOP was reached (SOEM's dc_sync).
            self.sync = SyncConfig::read(pdi, self.sm_sync_requested())?;
            self.publish_sync_parameters();
        }
        if self.sync.mode == Mode::SmSynchronous && events.any(AlEvent::sm(SM_OUTPUTS)) {
            self.on_cycle(pdi, now_ns)?;
        }
        Ok(())
    }

    /// Runs one process-data cycle: read outputs (SM2), run the application, write inputs (SM3).
    /// Does nothing below SAFEOP. Outputs are applied only in OP.
    pub fn on_cycle<P: EscPdi>(&mut self, pdi: &mut P, _now_ns: u64) -> Result<(), P::Error> {
        let state = self.status.state;
        if state != AlState::SafeOp && state != AlState::Op {
            return Ok(());
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
        self.app.step(&self.profile.vars, &mut self.ram);
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
            })
            == Some(Mode::SmSynchronous as u8)
    }

    fn handle_al_control<P: EscPdi>(
        &mut self,
        pdi: &mut P,
        control: AlControl,
    ) -> Result<(), P::Error> {
        let from = self.status.state;
        let checks = self.checks_for(pdi, from, control)?;
        let mut outcome = esm::decide(self.status, self.code, control, &checks);
        if control.id_request && !outcome.status.error {
            // Device identification (ETG.1000.6 §6.4.1.2): the station alias goes into the
            // AL status code, flagged by AL status bit 5.
            self.id_value = pdi.read_u16(regs::STATION_ALIAS.addr)?;
            outcome.status.id_loaded = true;
        }
        self.apply(pdi, from, outcome)
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
        self.status = outcome.status;
        self.code = outcome.code;
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
            self.app.safe_outputs(&self.profile.vars, &mut self.ram);
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
        if from == AlState::PreOp && to == AlState::SafeOp {
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

/// Reads the 8 register bytes of SM `n`.
fn read_sm<P: EscPdi>(pdi: &mut P, n: u8) -> Result<SmConfig, P::Error> {
    let mut b = [0u8; SmConfig::LEN];
    pdi.read(regs::sm(n).addr, &mut b)?;
    Ok(SmConfig::from_bytes(b))
}
