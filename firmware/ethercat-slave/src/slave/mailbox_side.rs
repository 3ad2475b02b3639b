//! The mailbox side of the slave: what the ESC-event context owns alone, so that mailbox traffic
//! never holds what the SYNC0 context needs.
//!
//! The mailbox data-link layer and its CoE server work on a *copy* of the OD RAM. One event
//! round is these steps; those with the [`SlaveCore`] each take a bounded time that does not
//! depend on the mailbox traffic (on a board: under the lock the SYNC0 interrupt shares, as its
//! priority ceiling):
//!
//! 1. [`MailboxSide::load`] (with the core): take the emergencies the core raised and a pending
//!    mailbox reset;
//! 2. [`MailboxSide::receive`] (no lock): the transfers that need no dictionary (a repeat
//!    request, a response or fragment waiting for SM1, an emergency when idle) and a request
//!    in SM0 read into the inbox;
//! 3. only when there is a request, [`MailboxSide::load_dictionary`] (with the core): copy the
//!    OD RAM the answer reads or writes — the entries of the object an SDO request names; the
//!    whole OD RAM (RAM size bytes) for a download whose hook reaches beyond its object
//!    (1010h/1011h, which store or restore every parameter; an automatic store tested on
//!    another object) and for an object of many entries; nothing for a request that reads no
//!    value (an upload segment, SDO information) — and, when the core's RxPDO plan changed,
//!    the OD RAM ranges it writes. A round with nothing to answer (in DC mode the SM2/SM3
//!    events start one every cycle) copies nothing. The rest of the copy keeps older values,
//!    which no answer reads and step 5 never writes back;
//! 4. [`MailboxSide::answer`] (no lock): the SDO services on the copy, the response posted —
//!    as long as they take: the cycle runs meanwhile;
//! 5. [`MailboxSide::store`] (with the core): copy back exactly the entries the SDO services
//!    wrote (a [`DirtyMap`] records them), whole entries at a time.
//!
//! An entry that both an SDO download and the cycle write in the same round ends with the SDO
//! value, as if the download came last. Values the cycle writes (statusword, actual values) are
//! uploaded as they were at step 3. The committed downloads of the round are handed to the
//! application in step 5 too ([`Application::downloaded`]), after their values are in place.

use hal::esc::AlState;
use hal::pdi::EscPdi;

#[cfg(test)]
mod tests;

use super::{EventJob, SlaveCore};
use crate::mailbox::{DictionaryScope, Mailbox, Request};
use heapless::Vec;

use crate::od::{
    AbortCode, Dictionary, DirtyMap, DomainStore, DownloadHook, Object, Profile, Value,
};
use crate::pdo::RamRanges;
use crate::slave::Application;

/// Committed downloads one round can record: a round serves one mailbox request, which
/// commits at most one download (one entry, or one object by complete access); the margin
/// covers a repeated request served in the same round.
const DOWNLOADS_PER_ROUND: usize = 4;

/// Most entries of an object that step 3 copies one by one ([`load_scope`]);
/// for an object with more (a large array) it copies the whole OD RAM, which then costs no
/// more than the entries' copies.
const MOST_ENTRIES_LOADED_ALONE: usize = 32;

/// A request read from SM0 in step 2, waiting for the dictionary (step 3).
#[derive(Debug)]
#[must_use]
pub struct ReceivedRequest(Request);

/// A request with the dictionary loaded for it (step 3), to answer in step 4.
#[derive(Debug)]
#[must_use]
pub struct LoadedRequest(Request);

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

    /// Step 1 (bounded, with the core): the emergencies to send, a mailbox reset after INIT.
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
        self.dirty.clear();
        self.downloads.clear();
    }

    /// Step 2 (no lock): the transfers that need no dictionary, and a request in SM0 read
    /// (nothing in INIT and BOOT). A request goes on to [`Self::load_dictionary`].
    pub fn receive<P: EscPdi>(
        &mut self,
        pdi: &mut P,
        job: EventJob,
    ) -> Result<Option<ReceivedRequest>, P::Error> {
        if matches!(job.state, AlState::Init | AlState::Boot) {
            return Ok(None);
        }
        let request = self
            .mailbox
            .receive(pdi, &self.profile.device, job.events)?;
        Ok(request.map(ReceivedRequest))
    }

    /// Step 3 (bounded, with the core), for a request to answer: the OD RAM the answer reads
    /// or writes as it is now ([`Mailbox::scope`], [`load_scope`]: the entries of the object a
    /// request names, all of it where `hook`, the download hook [`Self::answer`] runs, reaches
    /// beyond the object, none for a request that reads no value) and the OD RAM the core's
    /// RxPDO plan writes. Before an upload's entries are copied, the application writes the
    /// values of the object it shows on demand ([`Application::before_upload`]).
    pub fn load_dictionary<A: Application, H: DownloadHook + ?Sized>(
        &mut self,
        core: &mut SlaveCore<RAM, A>,
        request: ReceivedRequest,
        hook: &H,
    ) -> LoadedRequest {
        let (loaded, upload) = loaded_for(self.profile, self.mailbox.scope(&request.0), hook);
        if let Some(object) = upload {
            core.app.before_upload(&mut core.ram, object);
        }
        match loaded {
            Loaded::Nothing => {}
            // A copy between the fields is a word copy (through references the library's
            // copy goes byte by byte: some 40 % more for a store command).
            Loaded::Whole => self.ram = core.ram,
            Loaded::Entries(object) => copy_entries(object, &core.ram, &mut self.ram),
        }
        if self.rx_generation != Some(core.rx_plan_generation) {
            self.rx_outputs = core.rx_plan.ram_ranges();
            self.rx_generation = Some(core.rx_plan_generation);
        }
        LoadedRequest(request.0)
    }

    /// Step 4 (no lock): answers the request loaded in step 3, if any, on the working copy
    /// (SDO downloads go to it; `hook` runs on each committed download: parameter storage,
    /// domains), and ends the mailbox's round. Called in every round.
    pub fn answer<P: EscPdi, H: DownloadHook + ?Sized>(
        &mut self,
        pdi: &mut P,
        job: EventJob,
        request: Option<LoadedRequest>,
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
        self.mailbox.answer(
            pdi,
            &self.profile.device,
            &mut od,
            job.state,
            request.map(|l| l.0),
            &mut recording,
        )
    }

    /// Steps 2 to 4 in one, for a caller that holds the core throughout (no lock between).
    pub fn serve<P: EscPdi, A: Application, H: DownloadHook + ?Sized>(
        &mut self,
        core: &mut SlaveCore<RAM, A>,
        pdi: &mut P,
        job: EventJob,
        hook: &mut H,
    ) -> Result<(), P::Error> {
        let received = self.receive(pdi, job)?;
        let loaded = received.map(|r| self.load_dictionary(core, r, hook));
        self.answer(pdi, job, loaded, hook)
    }

    /// Step 5 (bounded, with the core): the entries the SDO services wrote go back to the core's
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

/// Copies from `core_ram` into `ram` what the answer to a request of `scope` reads or writes
/// (step 3): the OD RAM entries of the object it names (nothing for an object `profile` does
/// not have: the answer is an abort), or the whole OD RAM where the download `hook` that
/// follows the answer reaches beyond the object, or for an object of many entries (a large
/// array, whose entries' copies would cost more); nothing for [`DictionaryScope::Nothing`].
pub fn load_scope<const RAM: usize, H: DownloadHook + ?Sized>(
    profile: &Profile,
    scope: DictionaryScope,
    hook: &H,
    core_ram: &[u8; RAM],
    ram: &mut [u8; RAM],
) {
    match loaded_for(profile, scope, hook).0 {
        Loaded::Nothing => {}
        Loaded::Whole => *ram = *core_ram,
        Loaded::Entries(object) => copy_entries(object, core_ram, ram),
    }
}

/// What step 3 copies of the OD RAM for a request.
#[derive(Clone, Copy, Debug)]
enum Loaded<'p> {
    /// Nothing.
    Nothing,
    /// All of it.
    Whole,
    /// The entries of the object.
    Entries(&'p Object),
}

/// What the answer to a request of `scope` reads or writes (the rule of [`load_scope`], which
/// `MailboxSide::load_dictionary` shares through this), and the object an upload reads (whose
/// values the application may write first, [`Application::before_upload`]).
fn loaded_for<'p, H: DownloadHook + ?Sized>(
    profile: &'p Profile,
    scope: DictionaryScope,
    hook: &H,
) -> (Loaded<'p>, Option<&'p Object>) {
    let DictionaryScope::Object { index, download } = scope else {
        return (Loaded::Nothing, None);
    };
    if download && hook.reaches_beyond_object(profile, index) {
        return (Loaded::Whole, None);
    }
    let Some(object) = profile.object(index) else {
        return (Loaded::Nothing, None);
    };
    let upload = (!download).then_some(object);
    if object.entries.len() > MOST_ENTRIES_LOADED_ALONE {
        (Loaded::Whole, upload)
    } else {
        (Loaded::Entries(object), upload)
    }
}

/// Copies the OD RAM entries of `object` from `core_ram` into `ram`.
#[inline(always)]
fn copy_entries<const RAM: usize>(object: &Object, core_ram: &[u8; RAM], ram: &mut [u8; RAM]) {
    for entry in object.entries {
        if let Value::Ram(at) = entry.value {
            let at = usize::from(at);
            let bytes = at..at.saturating_add(entry.byte_len());
            if let (Some(to), Some(from)) = (ram.get_mut(bytes.clone()), core_ram.get(bytes)) {
                to.copy_from_slice(from);
            }
        }
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

    fn reaches_beyond_object(&self, profile: &Profile, index: u16) -> bool {
        self.hook.reaches_beyond_object(profile, index)
    }
}
