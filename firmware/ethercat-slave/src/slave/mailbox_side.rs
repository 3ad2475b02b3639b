//! The mailbox side of the slave: what the ESC-event context owns alone, so that mailbox traffic
//! never holds what the SYNC0 context needs.
//!
//! The mailbox data-link layer and its CoE server work on a *copy* of the OD RAM. One event
//! round is three steps; only the first and the last touch the [`SlaveCore`], each for a bounded
//! time that does not depend on the mailbox traffic (on a board: under the lock the SYNC0
//! interrupt shares, as its priority ceiling):
//!
//! 1. [`MailboxSide::load`]: copy the OD RAM (RAM size bytes) and, when the core's RxPDO plan
//!    changed, the OD RAM ranges it writes; take the emergencies the core raised and a pending
//!    mailbox reset;
//! 2. [`MailboxSide::serve`]: the mailbox transfers over the PDI and the SDO services, on the
//!    copy — as long as they take, with no lock: the cycle runs meanwhile;
//! 3. [`MailboxSide::store`]: copy back exactly the entries the SDO services wrote (a
//!    [`DirtyMap`] records them), whole entries at a time.
//!
//! An entry that both an SDO download and the cycle write in the same round ends with the SDO
//! value, as if the download came last. Values the cycle writes (statusword, actual values) are
//! uploaded as they were at step 1. The committed downloads of the round are handed to the
//! application in step 3 too ([`Application::downloaded`]), after their values are in place.

use hal::esc::AlState;
use hal::pdi::EscPdi;

use super::{EventJob, SlaveCore};
use crate::mailbox::Mailbox;
use heapless::Vec;

use crate::od::{AbortCode, Dictionary, DirtyMap, DomainStore, DownloadHook, Profile};
use crate::pdo::RamRanges;
use crate::slave::Application;

/// Committed downloads one round can record: a round serves one mailbox request, which
/// commits at most one download (one entry, or one object by complete access); the margin
/// covers a repeated request served in the same round.
const DOWNLOADS_PER_ROUND: usize = 4;

/// The mailbox with its CoE server and the working copy of the OD RAM.
pub struct MailboxSide<const RAM: usize> {
    profile: &'static Profile,
    mailbox: Mailbox,
    ram: [u8; RAM],
    dirty: DirtyMap,
    /// Downloads committed in this round (index, subindex), for the application.
    downloads: Vec<(u16, u8), DOWNLOADS_PER_ROUND>,
    /// The OD RAM the core's RxPDO plan writes (the SDO server's "mapped to an RxPDO" check),
    /// and the plan generation it was copied at.
    rx_outputs: RamRanges,
    rx_generation: Option<u32>,
}

impl<const RAM: usize> MailboxSide<RAM> {
    /// The mailbox side of a slave of `profile` (its RAM is checked by [`SlaveCore::new`]).
    pub fn new(profile: &'static Profile) -> Self {
        Self {
            profile,
            mailbox: Mailbox::new(),
            ram: [0; RAM],
            dirty: DirtyMap::new(),
            downloads: Vec::new(),
            rx_outputs: RamRanges::new(),
            rx_generation: None,
        }
    }

    /// Step 1 (bounded, with the core): the OD RAM as it is now, the emergencies to send, a
    /// mailbox reset after INIT.
    pub fn load<A: Application>(&mut self, core: &mut SlaveCore<RAM, A>) {
        if core.mailbox_reset {
            core.mailbox_reset = false;
            self.mailbox.reset();
        }
        while let Some(emcy) = core.emcy_out.front().copied() {
            if self.mailbox.post_emcy(emcy).is_err() {
                break; // the mailbox queue is full: the rest waits in the core
            }
            core.emcy_out.pop_front();
        }
        self.ram = core.ram;
        if self.rx_generation != Some(core.rx_plan_generation) {
            self.rx_outputs = core.rx_plan.ram_ranges();
            self.rx_generation = Some(core.rx_plan_generation);
        }
        self.dirty.clear();
        self.downloads.clear();
    }

    /// Step 2 (no lock): serves the mailbox in `job.state` (nothing in INIT and BOOT): repeat
    /// requests, pending responses, a new request in SM0, emergencies when idle. SDO downloads
    /// go to the working copy; `hook` runs on each committed download (parameter storage,
    /// domains).
    pub fn serve<P: EscPdi, H: DownloadHook + ?Sized>(
        &mut self,
        pdi: &mut P,
        job: EventJob,
        hook: &mut H,
    ) -> Result<(), P::Error> {
        if matches!(job.state, AlState::Init | AlState::Boot) {
            return Ok(());
        }
        let mut od = Dictionary::tracked(self.profile, &mut self.ram, &mut self.dirty)
            .with_rx_outputs(&self.rx_outputs);
        let mut recording = Recording {
            hook,
            downloads: &mut self.downloads,
        };
        self.mailbox.service_with(
            pdi,
            &self.profile.device,
            &mut od,
            job.state,
            job.events,
            &mut recording,
        )
    }

    /// Step 3 (bounded, with the core): the entries the SDO services wrote go back to the core's
    /// OD RAM, then the application learns which downloads were committed.
    pub fn store<A: Application>(&mut self, core: &mut SlaveCore<RAM, A>) {
        self.dirty.copy_marked(&self.ram, &mut core.ram);
        for (index, subindex) in self.downloads.iter().copied() {
            core.app
                .downloaded(&mut core.ram, index, subindex, core.now_ns);
        }
        self.downloads.clear();
    }

    /// Emergencies queued in the mailbox, waiting for SM1.
    pub fn pending_emcys(&self) -> usize {
        self.mailbox.pending_emcys()
    }

    /// Whether an SDO transfer (segmented download or upload, fragmented SDO information)
    /// spans mailbox rounds right now.
    pub fn transfer_in_progress(&self) -> bool {
        self.mailbox.transfer_in_progress()
    }
}

/// The board's download hook, recording each download it accepted for
/// [`Application::downloaded`].
struct Recording<'a, H: ?Sized> {
    hook: &'a mut H,
    downloads: &'a mut Vec<(u16, u8), DOWNLOADS_PER_ROUND>,
}

impl<H: DownloadHook + ?Sized> Recording<'_, H> {
    fn record(
        &mut self,
        done: Result<(), AbortCode>,
        index: u16,
        subindex: u8,
    ) -> Result<(), AbortCode> {
        if done.is_ok() {
            // Cannot overflow (one request per round, see DOWNLOADS_PER_ROUND); were it full,
            // the value is written all the same and only the notification is dropped.
            let _ = self.downloads.push((index, subindex));
        }
        done
    }
}

impl<H: DownloadHook + ?Sized> DownloadHook for Recording<'_, H> {
    fn downloaded(
        &mut self,
        od: &mut Dictionary<'_>,
        index: u16,
        subindex: u8,
    ) -> Result<(), AbortCode> {
        let done = self.hook.downloaded(od, index, subindex);
        self.record(done, index, subindex)
    }

    fn downloaded_complete(
        &mut self,
        od: &mut Dictionary<'_>,
        index: u16,
        first_subindex: u8,
    ) -> Result<(), AbortCode> {
        let done = self.hook.downloaded_complete(od, index, first_subindex);
        self.record(done, index, first_subindex)
    }

    fn domains(&mut self) -> Option<&mut dyn DomainStore> {
        self.hook.domains()
    }
}
