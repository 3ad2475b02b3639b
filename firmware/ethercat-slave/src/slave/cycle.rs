//! The process-data cycle: what the SYNC0 (or free-run timer, or SM2 event) context runs.
//!
//! [`SlaveCore::on_cycle`] is the whole cycle for any device; a board that wants the stages apart
//! (the drive's `firmware::sync0`) calls [`SlaveCore::cycle_begin`], its application and
//! [`SlaveCore::cycle_end`], then [`SlaveCore::cycle_finished`] with the time the cycle ended.

use super::*;
use crate::od::LostOutputsRule;

impl<const RAM: usize, A: Application> SlaveCore<RAM, A> {
    /// Runs one process-data cycle: [`Self::cycle_begin`], the application, [`Self::cycle_end`].
    /// Does nothing below SAFEOP. Outputs are applied only in OP.
    pub fn on_cycle<P: EscPdi>(&mut self, pdi: &mut P, now_ns: u64) -> Result<(), P::Error> {
        let Some(cycle_ns) = self.cycle_begin(pdi, now_ns)? else {
            return Ok(());
        };
        let mut events = AppEvents::new();
        self.app.cycle(&mut self.ram, cycle_ns, &mut events);
        self.cycle_end(pdi, &events, now_ns)
    }

    /// First part of a process-data cycle (SAFEOP and OP; `None` below, when no cycle runs):
    /// SYNC0 supervision, the outputs read from SM2 and, in OP, unpacked into the OD RAM.
    /// Returns the cycle time (1C32h:02, ns; 0 when not synchronised) for the application.
    pub fn cycle_begin<P: EscPdi>(
        &mut self,
        pdi: &mut P,
        now_ns: u64,
    ) -> Result<Option<u32>, P::Error> {
        if !matches!(self.status.state, AlState::SafeOp | AlState::Op) {
            return Ok(None);
        }
        self.cycle_started_ns = now_ns;
        let dc = matches!(self.sync.mode, Mode::DcSync0 | Mode::DcSync1);
        let fresh = if dc {
            self.supervise_outputs(pdi, now_ns)?
        } else {
            None
        };
        // The supervision may have left OP.
        let state = self.status.state;
        // In sync: OP on SYNC0, no sync error in the counter, and this cycle's outputs new
        // where they are watched.
        self.app.synchronisation(
            dc && state == AlState::Op && self.sync_supervisor.in_sync() && fresh != Some(false),
        );
        let device = &self.profile.device;
        let rx_len = self.rx_plan.byte_len();
        if rx_len > 0 {
            if let Some(image) = self.rx_image.get_mut(..rx_len) {
                pdi.read(device.outputs.start, image)?;
            }
            if state == AlState::Op {
                // Only a plan with watched entries compares (the default mappings have none).
                if !self.rx_plan.watches() {
                    self.rx_plan.unpack(&self.rx_image, &mut self.ram);
                } else if self.rx_plan.unpack_watching(&self.rx_image, &mut self.ram) {
                    self.app.watched_outputs_changed();
                }
            }
        }
        Ok(Some(self.sync.cycle_ns))
    }

    /// A SYNC0 in a DC mode: the sync supervision counts it, and in OP the profile's rules on
    /// outputs the master did not write since the previous SYNC0 (the SM2 event stays pending
    /// until the buffer is read): as a missed event (`[sync] sync_error_on_missed_outputs`), as
    /// a lost cycle in a row (`[esm] lost_outputs`, which trips here, in the cycle that
    /// reached the limit). Returns whether the master wrote the outputs since the previous
    /// SYNC0, where a rule watches it (`None`: not read).
    fn supervise_outputs<P: EscPdi>(
        &mut self,
        pdi: &mut P,
        now_ns: u64,
    ) -> Result<Option<bool>, P::Error> {
        let device = self.profile.device;
        let op = self.status.state == AlState::Op;
        let lost_rule = device
            .esm
            .lost_outputs
            .filter(|rule| op && self.lost_outputs.enabled() && self.rule_holds(rule));
        let watched = op && self.app.watches_missed_outputs();
        let fresh =
            if op && (device.sync.sync_error_on_missed_outputs || lost_rule.is_some() || watched) {
                let events = AlEvent(pdi.read_u32(regs::AL_EVENT_REQUEST.addr)?);
                Some(events.any(AlEvent::sm(SM_OUTPUTS)))
            } else {
                None
            };
        if watched && fresh == Some(false) {
            self.app.outputs_missed();
        }
        let counted = fresh.filter(|_| device.sync.sync_error_on_missed_outputs);
        self.sync_supervisor
            .on_sync0(now_ns, self.sync.cycle_ns, counted);
        let (Some(rule), Some(fresh)) = (lost_rule, fresh) else {
            // Not supervised now (another mode, not OP): the count starts afresh.
            self.lost_outputs.restart();
            return Ok(fresh);
        };
        self.lost_outputs.on_sync0(fresh);
        if self.lost_outputs.tripped() {
            self.trip_lost_outputs(pdi, rule)?;
        }
        Ok(Some(fresh))
    }

    /// Whether the entry a [`LostOutputsRule`] watches holds one of its values.
    fn rule_holds(&mut self, rule: &LostOutputsRule) -> bool {
        let (index, subindex) = rule.while_entry;
        self.dictionary()
            .read_u32(index, subindex)
            .is_some_and(|v| rule.while_values.contains(&v))
    }

    /// Last part of a process-data cycle, after the application ran on the OD RAM: what it
    /// reported about its errors becomes EMCY/1001h/10F3h, the inputs are packed and written to
    /// SM3.
    pub fn cycle_end<P: EscPdi>(
        &mut self,
        pdi: &mut P,
        events: &[AppEvent],
        now_ns: u64,
    ) -> Result<(), P::Error> {
        for &event in events {
            self.report_app_event(event, now_ns);
        }
        self.write_inputs(pdi)?;
        self.cycles = self.cycles.wrapping_add(1);
        Ok(())
    }

    /// Runs the application's cycle outside the process-data cycle (entering SAFEOP, so that the
    /// first inputs are valid) and reports its errors.
    pub(super) fn run_application(&mut self, now_ns: u64) {
        let mut events = AppEvents::new();
        self.app
            .cycle(&mut self.ram, self.sync.cycle_ns, &mut events);
        // By reference: heapless' by-value iterator slices its rest when dropped, a panic
        // path the cycle interrupt must not have (`panic-paths`).
        for &event in events.iter() {
            self.report_app_event(event, now_ns);
        }
    }

    /// What the application said about its errors → EMCY, 1001h, 10F3h.
    fn report_app_event(&mut self, event: AppEvent, now_ns: u64) {
        match event {
            AppEvent::ErrorCleared(code) => {
                // The error leaves 1001h; the last one clears with an error-reset EMCY
                // (CiA 301). A full queue only loses that notification.
                let _ = self.clear_error(code);
            }
            AppEvent::ErrorRaised { code, data } => {
                // An application error (a drive: protection, encoder, ...): 1001h, the EMCY
                // and its 10F3h message (ETG.1020: the emergency's code in the diag code, the
                // error's type). A full EMCY queue loses only the emergency; 1001h, 10F3h and
                // the application hold the error.
                let msg = DiagMessage::new(diag_code_for_emcy(code), DiagType::Error, 0);
                let register = emcy::register::DEVICE_PROFILE;
                let _ = self.report_error(code, register, data, Some(&msg), now_ns);
            }
            AppEvent::None => {}
        }
    }

    pub(super) fn write_inputs<P: EscPdi>(&mut self, pdi: &mut P) -> Result<(), P::Error> {
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

    /// Tells the slave when the process-data cycle started by the last [`Self::on_cycle`] ended
    /// (board clock, ns; on target right after `on_cycle` returns). The duration is the
    /// measured "calc and copy time" (ETG.1020 1C32h/1C33h:06, the longest since SAFEOP) and
    /// the delay until outputs are valid for the control loop (:09, and :03 shift for SM2);
    /// :05 (minimum cycle time) becomes the larger of the profile's limit and that duration; a
    /// cycle longer than the SYNC0 cycle counts in :0C ("cycle time too small").
    pub fn cycle_finished(&mut self, now_ns: u64) {
        if !matches!(self.status.state, AlState::SafeOp | AlState::Op) {
            return;
        }
        let elapsed = now_ns.saturating_sub(self.cycle_started_ns);
        let elapsed = u32::try_from(elapsed).unwrap_or(u32::MAX);
        if elapsed > self.calc_and_copy_max_ns {
            self.calc_and_copy_max_ns = elapsed;
            let bytes = elapsed.to_le_bytes();
            // The cycle cannot be shorter than the longest processing seen, nor than the
            // profile's limit (:05); outputs are valid for the control loop `elapsed` after
            // SYNC0 (:03 shift for SM2).
            let min_cycle = elapsed
                .max(self.profile.device.sync.min_cycle_ns)
                .to_le_bytes();
            self.write_od(SM_OUTPUT_PARAMETER, SUB_SHIFT_TIME, &bytes);
            for index in [SM_OUTPUT_PARAMETER, SM_INPUT_PARAMETER] {
                self.write_od(index, SUB_CALC_AND_COPY_TIME, &bytes);
                self.write_od(index, SUB_DELAY_TIME, &bytes);
                self.write_od(index, SUB_MIN_CYCLE_TIME, &min_cycle);
            }
        }
        // A profile that counts missed events at :0C (Σ-V-SD) has no "cycle time too small".
        let counter_at_0c =
            self.profile.device.sync.sm_event_missed_subindex == SUB_CYCLE_TIME_TOO_SMALL;
        if self.sync.cycle_ns != 0 && elapsed > self.sync.cycle_ns && !counter_at_0c {
            self.cycle_too_small = self.cycle_too_small.saturating_add(1);
            let count = self.cycle_too_small.to_le_bytes();
            // Both SMs run on the same cycle: the count goes to each object that has it.
            for index in [SM_OUTPUT_PARAMETER, SM_INPUT_PARAMETER] {
                self.write_od(index, SUB_CYCLE_TIME_TOO_SMALL, &count);
            }
        }
    }
}
