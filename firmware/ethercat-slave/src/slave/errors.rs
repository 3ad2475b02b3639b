//! Errors the slave reports to the master: EMCY messages, the error register 1001h and the
//! diagnosis history 10F3h (CiA 301, ETG.1020).

use super::*;

/// Emergencies, the error register 1001h and the diagnosis history 10F3h
/// ([`crate::mailbox::emcy`], [`crate::diag`]).
impl<const RAM: usize, A: Application> SlaveCore<RAM, A> {
    /// A profile rule raises `report` as one of the application's errors (a drive: 603Fh,
    /// Fault) and sends its emergency. A full EMCY queue or a stopped mailbox loses only the
    /// EMCY; 1001h and the application hold the error until its fault reset.
    pub(super) fn raise_app_error(&mut self, report: ErrorReport) {
        self.app.raise_error(report, &mut self.ram);
        let _ = self.report_error(
            report.emcy_code,
            emcy::register::DEVICE_PROFILE,
            report.emcy_data,
            None,
            self.now_ns,
        );
    }

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
        self.report_error_as(code, code, extra_register_bits, data, diag, now_ns)
    }

    /// [`Self::report_error`] with the error tracked in 1001h under `code` and the emergency
    /// sent with `emcy_code` (a profile's own code for an error the stack knows by ETG's).
    fn report_error_as(
        &mut self,
        code: u16,
        emcy_code: u16,
        extra_register_bits: u8,
        data: [u8; 5],
        diag: Option<&DiagMessage>,
        now_ns: u64,
    ) -> Result<(), Emergency> {
        self.errors.raise(code, extra_register_bits);
        let register = self.register_bits();
        self.publish_error_register();
        if let Some(msg) = diag {
            let mut od = Dictionary::new(self.profile, &mut self.ram);
            // The emergency goes out below in any case; bit 0 of 10F3h:05 adds nothing here.
            let _ = self.diag.report(&mut od, msg, now_ns, register);
        }
        self.post_emcy(Emergency::new(emcy_code, register, data))
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
        let register = self.register_bits();
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
            AlState::PreOp | AlState::SafeOp | AlState::Op => self.emcy_out.push_back(emcy),
            AlState::Init | AlState::Boot => Err(emcy),
        }
    }

    /// The error register 1001h.
    pub fn error_register(&self) -> u8 {
        self.register_bits()
    }

    /// 1001h from the active errors, limited to the bits the profile uses.
    fn register_bits(&self) -> u8 {
        self.errors.register() & self.profile.device.emcy.register_mask
    }

    /// Emergencies waiting for the mailbox.
    pub fn pending_emcys(&self) -> usize {
        self.emcy_out.len()
    }

    /// Mirrors the active errors into 1001h.
    pub(super) fn publish_error_register(&mut self) {
        let register = self.register_bits();
        self.write_od(crate::od::index::ERROR_REGISTER, 0, &[register]);
    }

    /// Called by [`Self::apply`] with the status before and the outcome: a new AL error (error
    /// flag set, or a different code) raises [`emcy::code::ESM_TRANSITION`] with data
    /// `[state before, AL status code (LE), state after, 0]` (SOEM's `ec_emcyt` view: `bData` =
    /// state before, `w1` = AL status code, `w2` = state after) and the 10F3h message
    /// `0xA000_E800` (error, parameters: AL status code u16, state before u8, state after u8);
    /// the master's error acknowledge clears it.
    ///
    /// An AL status code the profile lists in `[esm] al_error_alarms` is also one of the
    /// drive's errors: the application raises it (603Fh, PDS Fault) and its emergency (code and
    /// manufacturer bytes from the profile) goes out instead of the ESM transition emergency;
    /// the 10F3h message is the same. The application's fault reset clears it. A fault that
    /// named its own error (`fault_error`, e.g. the SDV3-E's cSD under 0x002C) reports that one.
    pub(super) fn track_al_error(
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
            let now = self.now_ns;
            let alarm = self
                .fault_error
                .take()
                .or_else(|| self.profile.device.esm.al_error_alarm(al));
            let _ = match alarm {
                Some(report) => {
                    self.app.raise_error(report, &mut self.ram);
                    self.report_error(
                        report.emcy_code,
                        emcy::register::DEVICE_PROFILE,
                        report.emcy_data,
                        Some(&msg),
                        now,
                    )
                }
                None => {
                    // Tracked under ETG's code (cleared by the acknowledge below), sent with the
                    // profile's emergency code (ETG's 0xA000 unless the profile says otherwise).
                    let emcy_code = self.profile.device.emcy.al_error_code;
                    self.report_error_as(code, emcy_code, 0, [f, c0, c1, t, 0], Some(&msg), now)
                }
            };
        } else if was.error && !outcome.status.error {
            let _ = self.clear_error(code);
        }
    }
}
