//! Adjusting services: a vendor's request/reply channel for maintenance adjustments, as the
//! profile declares it (`[[adjusting]]`; the Σ-V-SD's 2310h "SERVOPACK Adjusting Command",
//! §4.5 (8)). The object is a RECORD with :01 command (STRING(16), RW; a write executes it),
//! :02 status (USINT, RO; 255 while executing) and :03 reply (STRING(16), RO).
//!
//! | module | what |
//! |---|---|
//! | [`frame`] | the 16-byte request and reply layouts, status values |
//! | [`service`] | the sequence (select, prepare, execute, abort; 10 s abort, 5 s limit) as a decision function |
//!
//! [`AdjustingService`] binds one declared object to the OD RAM; the drive
//! ([`crate::drive::Drive`]) feeds it the downloads and the time, checks each adjustment's
//! conditions and runs the action on its axis.

pub mod frame;
pub mod service;

use frame::FRAME_LEN;
use service::{Decision, Phase, Progress, Refusal};

/// What an adjustment does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Action {
    /// Measures the current-sensor offsets again (Σ-V-SD 100EH "automatic offset adjustment of
    /// motor current detection signals"; not with the main power off, the servo on or the
    /// motor running).
    CurrentOffsetCalibration,
    /// Clears the absolute encoder's multi-turn data (Σ-V-SD 1008H "absolute encoder reset").
    MultiTurnReset,
    /// Writes the multi-turn limit into the encoder (Σ-V-SD 1013H "multiturn limit setting").
    MultiTurnLimitSetting,
}

/// One adjustment the service offers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CommandSpec {
    /// Its request code (CDATA of step 1).
    pub code: u16,
    /// What it does.
    pub action: Action,
    /// It needs the preparation step (CADDRESS 2001h, CDATA 0002h) before execution.
    pub preparation: bool,
}

/// One declared adjusting-service object.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ServiceSpec {
    /// The object's index.
    pub object: u16,
    /// The axis it adjusts (1 = the first).
    pub axis: u8,
    /// OD RAM offsets of :01 (16 bytes), :02 (1 byte) and :03 (16 bytes).
    pub command_at: u16,
    /// See [`Self::command_at`].
    pub status_at: u16,
    /// See [`Self::command_at`].
    pub reply_at: u16,
    /// A selection without a further request for this long is aborted, ms.
    pub abort_after_ms: u32,
    /// An execution that has not ended after this long ends in error, ms.
    pub time_limit_ms: u32,
    /// The adjustments, by request code.
    pub commands: &'static [CommandSpec],
}

/// The command subindex (a write of it is a request).
pub const SUB_COMMAND: u8 = 1;

/// One adjusting-service object at run time.
#[derive(Clone, Copy, Debug)]
pub struct AdjustingService {
    spec: &'static ServiceSpec,
    phase: Phase,
}

impl AdjustingService {
    /// The service of `spec`, idle.
    pub const fn new(spec: &'static ServiceSpec) -> Self {
        Self {
            spec,
            phase: Phase::Idle,
        }
    }

    /// The declaration.
    pub fn spec(&self) -> &'static ServiceSpec {
        self.spec
    }

    /// Whether an SDO download of `index:subindex` is a request to this service (a complete
    /// access from subindex 0 or 1 writes :01 too).
    pub fn is_request(&self, index: u16, subindex: u8) -> bool {
        index == self.spec.object && subindex <= SUB_COMMAND
    }

    /// Whether the service waits for a request (no time limit runs: [`Self::on_time`] has
    /// nothing to do).
    pub fn idle(&self) -> bool {
        matches!(self.phase, Phase::Idle)
    }

    /// The adjustment running now, if any.
    pub fn running(&self) -> Option<Action> {
        match self.phase {
            Phase::Executing { command, .. } => self.spec.commands.get(command).map(|c| c.action),
            _ => None,
        }
    }

    /// A request was written to :01 at `now_ms`: decides with the adjustments' conditions
    /// (`check`), publishes :02/:03 in `ram` and returns the action to start.
    pub fn on_request(
        &mut self,
        ram: &mut [u8],
        now_ms: u64,
        check: impl FnOnce(Action) -> Result<(), Refusal>,
    ) -> Option<Action> {
        let at = usize::from(self.spec.command_at);
        let frame = ram.get(at..at + FRAME_LEN).unwrap_or(&[]);
        let decision = service::on_request(self.phase, self.spec, frame, now_ms, check);
        self.apply(ram, decision)
    }

    /// Time passed (`now_ms`) and the running action stands at `progress`: ends or aborts what
    /// is due, publishing :02/:03.
    pub fn on_time(&mut self, ram: &mut [u8], now_ms: u64, progress: Progress) {
        let decision = service::on_time(self.phase, self.spec, now_ms, progress);
        self.apply(ram, decision);
    }

    fn apply(&mut self, ram: &mut [u8], decision: Decision) -> Option<Action> {
        self.phase = decision.phase;
        if let Some((status, reply)) = decision.reply {
            if let Some(b) = ram.get_mut(usize::from(self.spec.status_at)) {
                *b = status;
            }
            let at = usize::from(self.spec.reply_at);
            if let Some(r) = ram.get_mut(at..at + FRAME_LEN) {
                r.copy_from_slice(&reply);
            }
        }
        decision.start
    }
}
