//! Faults the slave detects by itself: SM reconfiguration, the process-data watchdog, SYNC0
//! supervision; each drops the state with its AL status code (ETG.1000.6 Table 11).

use super::super::*;
use crate::od::{DeviceInfo, LostOutputsRule};
use hal::esc::DlStatus;

/// The ESC port that faces the master (ETG.1000.4: frames enter at port 0).
const INPUT_PORT: u8 = 0;

impl<const RAM: usize, A: Application> SlaveCore<RAM, A> {
    /// SM activation changed: the master rewrote an SM. In PREOP and above the mailbox SMs must
    /// still match (else INIT + 0x0016, as on INIT → PREOP); in SAFEOP and OP also SM2/SM3, with
    /// the resulting states of ETG.1000.6 Table 11: 0x001D → SAFEOP + error, 0x001E → PREOP +
    /// error. Returns how many SMs, from SM0 on, it read (reading them acknowledged their
    /// activation change, see [`Self::acknowledge_sm_activation`]).
    pub(in crate::slave) fn revalidate_sms<P: EscPdi>(
        &mut self,
        pdi: &mut P,
    ) -> Result<u8, P::Error> {
        // SMs read: the mailbox pair SM0/SM1 (all before SM_OUTPUTS), then SM2/SM3 as well.
        const MAILBOX_SMS: u8 = SM_OUTPUTS;
        const ALL_SMS: u8 = SM_INPUTS + 1;
        let state = self.status.state;
        let device = self.profile.device;
        if esm::state_rank(state) < 1 || state == AlState::Boot {
            return Ok(0);
        }
        let sm0 = read_sm(pdi, 0)?;
        let sm1 = read_sm(pdi, 1)?;
        if let Err(code) = sm_check::check_mailbox(sm0, sm1, &device) {
            self.raise_fault(
                pdi,
                AlState::Init,
                code,
                ErrorIndication::InvalidConfiguration,
            )?;
            return Ok(MAILBOX_SMS);
        }
        if esm::state_rank(state) < 2 {
            return Ok(MAILBOX_SMS);
        }
        let Err(code) = self.process_data_sms(pdi)? else {
            return Ok(ALL_SMS);
        };
        self.raise_fault(
            pdi,
            esm::sm_fault_state(code),
            code,
            ErrorIndication::InvalidConfiguration,
        )?;
        Ok(ALL_SMS)
    }

    /// Acknowledges the SM-activation event (AL event bit 4) for the SMs the slave does not
    /// use: the ESC clears the event only when the activate byte of every SM the master wrote
    /// has been read (ET1100 datasheet, 0x0220 bit 4), and a master's start-up clears all of
    /// them (SOEM and ethercrab write zeros over the SM block). Left pending, the event would
    /// hold the IRQ line asserted for good: an edge-triggered board would see no later event,
    /// a level-triggered one would run event rounds back to back. `from`: the SMs before it
    /// were read already ([`Self::revalidate_sms`] reads SM0..SM3 only in the states where they
    /// matter), so a round in OP reads the four the slave does not use, one byte each.
    pub(in crate::slave) fn acknowledge_sm_activation<P: EscPdi>(
        &mut self,
        pdi: &mut P,
        from: u8,
    ) -> Result<(), P::Error> {
        for n in from..self.esc_sms {
            pdi.read_u8(regs::sm_activate(n))?;
        }
        Ok(())
    }

    /// Profile rule (`[esm] link_loss_error`): the input port (port 0, DL status 0x0110) lost
    /// its link in PREOP or above: the application raises the profile's error (603Fh; its EMCY
    /// cannot reach the master) and the slave goes to INIT with AL status code 0x0000.
    pub(in crate::slave) fn supervise_link<P: EscPdi>(
        &mut self,
        pdi: &mut P,
    ) -> Result<(), P::Error> {
        let Some(report) = self.profile.device.esm.link_loss_error else {
            return Ok(());
        };
        let from = self.status.state;
        if from == AlState::Init {
            return Ok(());
        }
        let dl_status = pdi.read_u16(regs::DL_STATUS.addr)?;
        if dl_status & DlStatus::link(INPUT_PORT) != 0 {
            return Ok(());
        }
        self.drop_to_init_with(pdi, from, report, ErrorIndication::InvalidConfiguration)
    }

    /// Profile rule (`[esm] pdi_error`): the ESC counted a PDI access error (0x030D, e.g. an SPI
    /// frame with a wrong number of clocks): the application raises the profile's error, the
    /// slave goes to INIT with AL status code 0x0000 and the ERR LED on (the SDV3-E's Hr, §5.2
    /// 1: "ECAT hardware error; PDI interface access error", in every state). The master may
    /// clear the counter (a write to the error counters); only an increase counts.
    pub(in crate::slave) fn supervise_pdi<P: EscPdi>(
        &mut self,
        pdi: &mut P,
    ) -> Result<(), P::Error> {
        let Some(report) = self.profile.device.esm.pdi_error else {
            return Ok(());
        };
        let count = pdi.read_u8(regs::PDI_ERROR_COUNTER.addr)?;
        let seen = core::mem::replace(&mut self.pdi_errors_seen, count);
        // The counter saturates at 0xFF and is cleared by the master: any rise is a new error.
        if count <= seen {
            return Ok(());
        }
        let from = self.status.state;
        self.drop_to_init_with(
            pdi,
            from,
            report,
            ErrorIndication::ApplicationControllerFailure,
        )
    }

    /// A profile's fault that drops to INIT with AL status code 0x0000 (link loss, PDI error):
    /// the application raises `report` and the ERR LED shows `indication` although the AL
    /// status has no error flag. The error stays in 1001h until the drive's fault reset; its
    /// EMCY is dropped with the mailbox in INIT (nobody could receive it).
    fn drop_to_init_with<P: EscPdi>(
        &mut self,
        pdi: &mut P,
        from: AlState,
        report: ErrorReport,
        indication: ErrorIndication,
    ) -> Result<(), P::Error> {
        self.raise_app_error(report);
        self.pending_op = None;
        self.error_indication = indication;
        self.error_without_flag = true;
        self.apply(pdi, from, esm::dropped_to_init(self.status))
    }

    /// Profile rule (`[esm] lost_outputs`): the cycle counted the limit of SYNC0 events in a row
    /// without new outputs while the supervised entry held one of its values: SAFEOP with the
    /// rule's AL status code, reported as the rule's error (the SDV3-E's cSD, 0x002C).
    pub(in crate::slave) fn trip_lost_outputs<P: EscPdi>(
        &mut self,
        pdi: &mut P,
        rule: LostOutputsRule,
    ) -> Result<(), P::Error> {
        self.lost_outputs.restart();
        if self.status.error {
            return Ok(());
        }
        self.fault_error = Some(rule.error);
        // od-gen allows the two sync error codes of ETG.1000.6 Table 11.
        let code = if rule.al_status_code == AlStatusCode::FatalSyncError.code() {
            AlStatusCode::FatalSyncError
        } else {
            AlStatusCode::SyncError
        };
        self.raise_fault(pdi, AlState::SafeOp, code, ErrorIndication::LocalError)
    }

    /// Process-data watchdog (0x0440 bit 0 cleared by the ESC when SM2 was not written within
    /// the watchdog time): in OP the slave drops to SAFEOP with 0x001B (ETG.1000.6 Table 11).
    /// Reading 0x0440 acknowledges the AL event.
    pub(in crate::slave) fn check_watchdog<P: EscPdi>(
        &mut self,
        pdi: &mut P,
    ) -> Result<(), P::Error> {
        let status = pdi.read_u16(regs::WATCHDOG_STATUS_PD.addr)?;
        if status & hal::esc::watchdog::PD_STATUS_OK == 0 && self.status.state == AlState::Op {
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
    /// counter passes 10F1h:02 (with the profile's rules: SYNC0 events without new outputs
    /// count too, the limit may trip on reaching it); mirrors 1C32h:0B (missed) and 1C32h:20
    /// (sync error).
    pub(in crate::slave) fn supervise_sync<P: EscPdi>(
        &mut self,
        pdi: &mut P,
        now_ns: u64,
    ) -> Result<(), P::Error> {
        let dc = matches!(self.sync.mode, Mode::DcSync0 | Mode::DcSync1);
        if !dc || !matches!(self.status.state, AlState::SafeOp | AlState::Op) {
            return Ok(());
        }
        if let Some(timeout) = self.profile.device.esm.sync_lock_timeout_ns() {
            // Profile rule: SYNC0 must start within the lock timeout of entering SAFEOP or of the
            // master's last change of the synchronisation (ETG.1000.6 Table 11: 0x002D "no sync
            // error"; the SDV3-E falls back to PREOP).
            let waited = now_ns.saturating_sub(self.sync_lock_since_ns);
            let waiting = self.status.state == AlState::SafeOp && !self.sync_supervisor.running();
            if waiting && waited > timeout && !self.status.error {
                return self.raise_fault(
                    pdi,
                    AlState::PreOp,
                    AlStatusCode::NoSyncError,
                    ErrorIndication::LocalError,
                );
            }
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
        self.sync_supervisor.check(now_ns, self.sync.cycle_ns);
        let Some(missed) = self.sync_supervisor.missed_update() else {
            return Ok(());
        };
        // 0: the profile's 1C32h has no missed-event counter (counted, not published).
        let counter = self.profile.device.sync.sm_event_missed_subindex;
        if counter != 0 {
            // Both SMs are synchronised to the same SYNC0: each object that has the counter.
            for index in [SM_OUTPUT_PARAMETER, SM_INPUT_PARAMETER] {
                self.write_od(index, counter, &missed.to_le_bytes());
            }
        }
        let limit = self
            .dictionary()
            .read_u32(ERROR_SETTINGS, SUB_SYNC_ERROR_LIMIT)
            .map_or(DEFAULT_COUNTER_LIMIT, |v| v as u16);
        let at_limit = self.profile.device.sync.sync_error_at_limit;
        if self.sync_supervisor.tripped(limit, at_limit) && !self.status.error {
            let flag = self.profile.device.sync.sync_error_flag(true, true);
            self.publish_sync_error_flag(flag);
            self.sync_supervisor.reset();
            // ETG.1000.6 Table 11 (OP → SAFEOP + error): pulses missed while the SYNC unit still
            // runs are a synchronization error (0x001A); a SYNC unit the master switched off
            // (0x0981) will not bring SYNC0 back: fatal sync error (0x002C).
            // A profile may report the counted error as fatal too (`[esm] sync_error_al_code`).
            let unit = DcActivation(pdi.read_u8(regs::DC_ACTIVATION.addr)?);
            let counted_as_fatal =
                self.profile.device.esm.sync_error_al_code == AlStatusCode::FatalSyncError.code();
            let code = if unit.sync0_active() && !counted_as_fatal {
                AlStatusCode::SyncError
            } else {
                AlStatusCode::FatalSyncError
            };
            self.raise_fault(pdi, AlState::SafeOp, code, ErrorIndication::LocalError)?;
        }
        Ok(())
    }

    /// Leaves the current state for `fallback` (if lower) with the error flag and `code`.
    pub(in crate::slave) fn raise_fault<P: EscPdi>(
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
}

/// SM2 and SM3 as the master configured them against the process data of `rx_len` and
/// `tx_len` bytes: 0x001D for a wrong output SM, 0x001E for a wrong input SM.
pub(in crate::slave) fn check_process_data_sms<P: EscPdi>(
    pdi: &mut P,
    device: &DeviceInfo,
    rx_len: usize,
    tx_len: usize,
) -> Result<Result<(), AlStatusCode>, P::Error> {
    let sm2 = read_sm(pdi, SM_OUTPUTS)?;
    let sm3 = read_sm(pdi, SM_INPUTS)?;
    Ok(sm_check::check_process_data(
        sm2,
        &device.outputs,
        SmDirection::EcatWrite,
        rx_len as u16,
        AlStatusCode::InvalidOutputConfig,
    )
    .and(sm_check::check_process_data(
        sm3,
        &device.inputs,
        SmDirection::EcatRead,
        tx_len as u16,
        AlStatusCode::InvalidInputConfig,
    )))
}
