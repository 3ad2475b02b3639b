//! [`Slave`]: the core and the mailbox side together, for a board (or the simulation) that runs
//! the ESC-event handler in one piece. A board that lets the SYNC0 interrupt preempt mailbox
//! traffic keeps the two apart instead ([`Slave::split`], [`MailboxSide`]).

use core::ops::{Deref, DerefMut};

use hal::pdi::EscPdi;
use hal::storage::NvStorage;

use super::{Application, MailboxSide, NoApplication, SlaveCore, SlaveError};
use crate::od::{DomainStore, NoDomains, Profile, WithDomains};
use crate::params::{NoStorage, ParamStore};

/// The EtherCAT slave with its object dictionary and its application `A`: a [`SlaveCore`]
/// (reached through `Deref`) and its [`MailboxSide`].
pub struct Slave<const RAM: usize, A: Application = NoApplication> {
    core: SlaveCore<RAM, A>,
    mailbox: MailboxSide<RAM>,
}

impl<const RAM: usize, A: Application> Slave<RAM, A> {
    /// A slave in INIT with every object at its default, running `app`.
    pub fn new(profile: &'static Profile, app: A) -> Result<Self, SlaveError> {
        Ok(Self {
            core: SlaveCore::new(profile, app)?,
            mailbox: MailboxSide::new(profile),
        })
    }

    /// The core (SYNC0 / cycle context, plus the short event steps) and the mailbox side
    /// (ESC-event context), to be used apart.
    pub fn split(&mut self) -> (&mut SlaveCore<RAM, A>, &mut MailboxSide<RAM>) {
        (&mut self.core, &mut self.mailbox)
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
    /// RAM (`Value::Domain`, streamed by segmented SDO; see [`crate::od::domain`]).
    pub fn on_esc_event_full<P: EscPdi, S: NvStorage, const CAP: usize>(
        &mut self,
        pdi: &mut P,
        params: &mut ParamStore<S, CAP>,
        domains: &mut dyn DomainStore,
        now_ns: u64,
    ) -> Result<(), P::Error> {
        self.event_round(pdi, params, domains, now_ns, |_, _, _| {})
    }

    /// One ESC-event round (see [`MailboxSide`]): `core.event_begin`, `mailbox.load`,
    /// `mailbox.serve` (receive, the OD RAM copied for a request, answer), then `between`, then
    /// `mailbox.store` and `core.event_end`. `between` runs where a board's SYNC0 may preempt
    /// the round: after the mailbox was served on its copy, before its writes go back (the
    /// simulation injects a cycle there).
    pub fn event_round<P: EscPdi, S: NvStorage, const CAP: usize>(
        &mut self,
        pdi: &mut P,
        params: &mut ParamStore<S, CAP>,
        domains: &mut dyn DomainStore,
        now_ns: u64,
        between: impl FnOnce(&mut SlaveCore<RAM, A>, &MailboxSide<RAM>, &mut P),
    ) -> Result<(), P::Error> {
        let job = self.core.event_begin(pdi, now_ns)?;
        self.mailbox.load(&mut self.core);
        let served = self.mailbox.serve(
            &mut self.core,
            pdi,
            job,
            &mut WithDomains {
                hook: params,
                domains,
            },
        );
        between(&mut self.core, &self.mailbox, pdi);
        self.mailbox.store(&mut self.core);
        served?;
        self.core.event_end(pdi, job, now_ns)
    }

    /// Emergencies waiting to be sent: raised but not yet taken by the mailbox, and queued in it.
    pub fn pending_emcys(&self) -> usize {
        // Two bounded queues: never saturates.
        self.core
            .pending_emcys()
            .saturating_add(self.mailbox.pending_emcys())
    }
}

impl<const RAM: usize, A: Application> Deref for Slave<RAM, A> {
    type Target = SlaveCore<RAM, A>;

    fn deref(&self) -> &Self::Target {
        &self.core
    }
}

impl<const RAM: usize, A: Application> DerefMut for Slave<RAM, A> {
    fn deref_mut(&mut self) -> &mut Self::Target {
        &mut self.core
    }
}
