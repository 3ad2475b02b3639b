//! State change requests: the checks a transition needs, the delayed SAFEOP → OP gate, and
//! applying an ESM outcome (AL status code before AL status, entry/exit work of the states).

use super::super::*;
use super::*;

impl<const RAM: usize, A: Application> SlaveCore<RAM, A> {
    pub(in crate::slave) fn handle_al_control<P: EscPdi>(
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
    pub(in crate::slave) fn checks_for<P: EscPdi>(
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
            (AlState::PreOp, Some(AlState::SafeOp)) | (AlState::SafeOp, Some(AlState::Op)) => {
                checks.process_data = if from == AlState::PreOp {
                    self.prepare_process_data(pdi)?
                } else {
                    self.process_data_sms(pdi)?
                };
                let sync = self.read_sync(pdi)?;
                let shift = self.input_shift_ns();
                checks.sync = sync
                    .check(&device.sync)
                    .and_then(|()| sync.check_input_shift(shift, &device.sync));
                self.sync = sync;
            }
            // Staying in SAFEOP or OP (an acknowledge): the SMs as the master left them.
            (AlState::SafeOp, Some(AlState::SafeOp)) | (AlState::Op, Some(AlState::Op)) => {
                checks.process_data = self.process_data_sms(pdi)?;
            }
            _ => {}
        }
        Ok(checks)
    }

    /// SM2/SM3 as the master left them against the copy plans in force.
    pub(in crate::slave) fn process_data_sms<P: EscPdi>(
        &self,
        pdi: &mut P,
    ) -> Result<Result<(), AlStatusCode>, P::Error> {
        let device = self.profile.device;
        let (rx_len, tx_len) = (self.rx_plan.byte_len(), self.tx_plan.byte_len());
        faults::check_process_data_sms(pdi, &device, rx_len, tx_len)
    }

    /// Builds both copy plans from the OD and checks SM2/SM3 against them.
    pub(in crate::slave) fn prepare_process_data<P: EscPdi>(
        &mut self,
        pdi: &mut P,
    ) -> Result<Result<(), AlStatusCode>, P::Error> {
        let device = self.profile.device;
        let od = Dictionary::new(self.profile, &mut self.ram);
        let app = &self.app;
        let rx =
            PdoPlan::build_watching(&od, Direction::Rx, &|at, len| app.watches_outputs(at, len));
        let tx = PdoPlan::build(&od, Direction::Tx);
        let (rx, tx) = match (rx, tx) {
            (Ok(rx), Ok(tx)) => (rx, tx),
            (Err(code), _) | (_, Err(code)) => return Ok(Err(code)),
        };
        let result = faults::check_process_data_sms(pdi, &device, rx.byte_len(), tx.byte_len())?;
        if result.is_ok() {
            self.set_rx_plan(rx);
            self.set_tx_plan(tx);
        }
        Ok(result)
    }

    /// Writes the outcome (code first, then status, each only if changed) and runs the work of
    /// the states left and entered.
    pub(in crate::slave) fn apply<P: EscPdi>(
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
        if outcome.status.error {
            // Profile rule: the manual's ERR LED pattern for this AL error.
            if let Some(led) = self.profile.device.esm.al_error_led(outcome.code.code()) {
                self.error_indication = ErrorIndication::showing(led);
            }
        }
        let previous = (self.status, self.code);
        self.status = outcome.status;
        self.code = outcome.code;
        // Every AL error (refused transition, watchdog, sync error, SM re-validation) passes
        // here: EMCY + 10F3h message + 1001h; the acknowledged error clears (EMCY 0x0000).
        self.track_al_error(from, previous, outcome);
        Ok(())
    }

    /// Puts `plan` in place as the RxPDO plan: the application learns the mapped outputs, the
    /// mailbox side the OD RAM it writes (at its next load).
    fn set_rx_plan(&mut self, plan: PdoPlan) {
        self.rx_plan = plan;
        self.rx_plan_generation = self.rx_plan_generation.wrapping_add(1);
        self.app.outputs_mapped(&self.rx_plan);
    }

    /// Puts `plan` in place as the TxPDO plan: the application learns the mapped inputs.
    fn set_tx_plan(&mut self, plan: PdoPlan) {
        self.tx_plan = plan;
        self.app.inputs_mapped(&self.tx_plan);
    }

    pub(in crate::slave) fn leave_and_enter<P: EscPdi>(
        &mut self,
        pdi: &mut P,
        from: AlState,
        to: AlState,
    ) -> Result<(), P::Error> {
        let rank_from = esm::state_rank(from);
        let rank_to = esm::state_rank(to);
        if from == AlState::Op {
            // Leaving OP: the application puts its outputs into their safe state (a drive:
            // controlword 0 = disable voltage).
            let was_enabled = self.app.outputs_safe(&mut self.ram, self.sync.cycle_ns);
            // Profile rule (`[esm] op_exit_while_enabled_error`): leaving OP while the
            // application was active is an application error (a drive: Operation Enabled →
            // 603Fh, EMCY, PDS Fault).
            if let Some(report) = self
                .profile
                .device
                .esm
                .op_exit_while_enabled_error
                .filter(|_| was_enabled)
            {
                self.raise_app_error(report);
            }
        }
        if rank_to < 2 && rank_from >= 2 {
            self.set_rx_plan(PdoPlan::default());
            self.set_tx_plan(PdoPlan::default());
            self.sync = SyncConfig {
                mode: Mode::FreeRun,
                cycle_ns: 0,
            };
        }
        if to == AlState::Init {
            // The mailbox side starts afresh; emergencies not yet sent are dropped with it.
            self.mailbox_reset = true;
            self.emcy_out.clear();
        }
        if from == AlState::SafeOp && to == AlState::Op {
            self.sync_supervisor.restart_counter();
        }
        if rank_to <= 2 && to != from {
            // Entering or returning to SAFEOP or below: supervision and the OP gate restart.
            self.sync_supervisor.reset();
            self.outputs_received = false;
            self.calc_and_copy_max_ns = 0;
        }
        if from == AlState::PreOp && to == AlState::SafeOp {
            self.sync_lock_since_ns = self.now_ns;
            let dc = matches!(self.sync.mode, Mode::DcSync0 | Mode::DcSync1);
            let flag = self.profile.device.sync.sync_error_flag(false, dc);
            self.publish_sync_error_flag(flag);
            self.publish_sync_parameters();
            // Inputs are valid from SAFEOP on: write them once before the master reads SM3.
            self.run_application(self.now_ns);
            self.write_inputs(pdi)?;
        }
        Ok(())
    }

    /// Writes the sync error flag (:20) of both SM parameter objects (ETG.1020 has it in each;
    /// a profile's layout may lack it in either).
    pub(in crate::slave) fn publish_sync_error_flag(&mut self, flag: u8) {
        for index in [SM_OUTPUT_PARAMETER, SM_INPUT_PARAMETER] {
            self.write_od(index, SUB_SYNC_ERROR, &[flag]);
        }
    }

    /// Mirrors the active synchronisation into 1C32h/1C33h (:01 sync type, :02 cycle time, and
    /// :0A Sync0 cycle time where the profile has it: the SYNC0 cycle, 0 without DC).
    pub(in crate::slave) fn publish_sync_parameters(&mut self) {
        let mode = self.sync.mode as u16;
        let cycle = self.sync.cycle_ns;
        let dc = matches!(self.sync.mode, Mode::DcSync0 | Mode::DcSync1);
        let sync0_cycle = if dc { cycle } else { 0 };
        let mut od = Dictionary::new(self.profile, &mut self.ram);
        for index in [SM_OUTPUT_PARAMETER, SM_INPUT_PARAMETER] {
            if let Some(e) = od.entry(index, SUB_SYNC_TYPE) {
                let _ = od.set_value(e, le_prefix(&mode.to_le_bytes(), e.byte_len()));
            }
            if cycle != 0 {
                if let Some(e) = od.entry(index, SUB_CYCLE_TIME) {
                    let _ = od.set_value(e, le_prefix(&cycle.to_le_bytes(), e.byte_len()));
                }
            }
            if let Some(e) = od.entry(index, SUB_SYNC0_CYCLE_TIME) {
                let _ = od.set_value(e, le_prefix(&sync0_cycle.to_le_bytes(), e.byte_len()));
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
pub(in crate::slave) fn read_sm<P: EscPdi>(pdi: &mut P, n: u8) -> Result<SmConfig, P::Error> {
    let mut b = [0u8; SmConfig::LEN];
    pdi.read(regs::sm(n).addr, &mut b)?;
    Ok(SmConfig::from_bytes(b))
}

/// The first `len` bytes of a little-endian value (all of them if the entry is longer): what an
/// entry of `len` bytes holds of it.
fn le_prefix(bytes: &[u8], len: usize) -> &[u8] {
    bytes.get(..len).unwrap_or(bytes)
}
