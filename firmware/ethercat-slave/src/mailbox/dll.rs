//! Mailbox data-link layer (ETG.1000.4 §5.6, ETG.1000.6 §5.5) over SM0 (master → slave) and
//! SM1 (slave → master).
//!
//! - A request is read when SM0 is full, and only when the previous response has been posted to
//!   SM1: the master's next request then waits in SM0 (back-pressure instead of a drop).
//! - A response is posted when SM1 is empty; the posted frame stays in `outbox` as the backup
//!   for a repeat request.
//! - Repeat (SM1 activate bit 1 toggled by the master): the backup is re-posted *before* the
//!   repeat-ack bit (SM1 PDI control bit 1) is toggled, so a master that sees the ack always
//!   finds the repeated frame.
//! - A request whose counter equals the previous one is a retry of a frame already handled and
//!   is dropped (counter 0 means "no counter" and is never treated as a duplicate).
//!
//! Outbound queue (issue 3: "an EMCY never displaces a pending SDO response"): the response to
//! the request just served has priority; emergencies ([`super::emcy`]) wait in an
//! [`EmcyQueue`] and one is posted only when SM0 holds no request, no response is waiting and
//! SM1 is empty. A master sends its request after checking that SM1 is empty (ethercrab clears
//! SM1 first and then asserts that the answer to its SDO request is not an emergency; SOEM reads
//! SM1 with timeout 0 first), so an emergency posted in the gap between that check and the
//! request would be taken for the answer. Hence, when a request arrives while a posted
//! emergency still sits unread in SM1, the emergency is withdrawn (SM1 deactivated and
//! re-activated from the PDI side, as for a repeat), put back at the head of the queue with its
//! counter, and the response goes out first. The repeat backup is always the last frame
//! actually posted (an emergency too) and is dropped only together with a withdrawn emergency.
//!
//! SM1's event (AL event bit 9, "the master read SM1") stays pending until the next frame is
//! written to SM1, so it is in the AL event mask only while a frame waits for SM1 to empty (a
//! response, the next fragment, an emergency): an idle mailbox releases the IRQ line, and the
//! next event (a request in SM0, AL control, SM2) gives it a new edge.

use hal::esc::{regs, AlEvent, AlState, SmActivate, SmPdiControl, SmStatus};
use hal::pdi::EscPdi;

use super::coe::{CoeServer, DownloadHook};
use super::emcy::{EmcyQueue, Emergency, EMCY_PAYLOAD_LEN};
use super::header::{
    next_counter, MailboxErrorCode, MailboxHeader, MailboxType, HEADER_LEN, MAILBOX_ERROR_COMMAND,
};
use super::{DictionaryScope, MAX_MAILBOX};
use crate::od::{DeviceInfo, Dictionary, SmLayout};

/// SyncManager channel of the master → slave mailbox.
pub(crate) const SM_MAILBOX_OUT: u8 = 0;
/// SyncManager channel of the slave → master mailbox.
const SM_MAILBOX_IN: u8 = 1;
/// Status register of SM0.
const SM0_STATUS: u16 = regs::sm(SM_MAILBOX_OUT).addr + regs::sm_offset::STATUS;
/// Status register of SM1.
const SM1_STATUS: u16 = regs::sm(SM_MAILBOX_IN).addr + regs::sm_offset::STATUS;
/// Activate register of SM1.
const SM1_ACTIVATE: u16 = regs::sm(SM_MAILBOX_IN).addr + regs::sm_offset::ACTIVATE;
/// PDI control register of SM1.
const SM1_PDI_CONTROL: u16 = regs::sm(SM_MAILBOX_IN).addr + regs::sm_offset::PDI_CONTROL;

/// Reads the request frame in the `len`-byte SM0 buffer at `start` into `inbox`: the mailbox
/// header, then as much of the frame as the header announces, then the buffer's last byte if
/// the frame ends before it. Reading the last byte hands SM0 back to the master (ETG.1000.4
/// §6.7.1 mailbox mode; SOES's `ESC_readmbx` reads the same three parts); the bytes between
/// the frame and the last byte are none of the request, and an ET1100 SPI read costs the bus
/// time of every byte (an expedited SDO request of 16 bytes in a 256-byte SM0: 22 bytes
/// instead of 256). A header that announces more than the buffer holds reads the whole buffer
/// (the request is then refused as too long). Bytes of `inbox` beyond those read keep older
/// contents: a request is read from its header's length alone.
fn read_frame<P: EscPdi>(
    pdi: &mut P,
    start: u16,
    inbox: &mut [u8; MAX_MAILBOX],
    len: usize,
) -> Result<(), P::Error> {
    let head = len.min(HEADER_LEN);
    if let Some(header) = inbox.get_mut(..head) {
        pdi.read(start, header)?;
    }
    let announced = MailboxHeader::parse(inbox).map_or(0, |h| usize::from(h.length));
    let frame = HEADER_LEN.saturating_add(announced).min(len);
    // The SM0 buffer lies in the ESC's 16-bit address space (its layout checked at start):
    // offsets within it fit a u16; were they not, the part is skipped.
    let at = |offset: usize| {
        u16::try_from(offset)
            .ok()
            .and_then(|o| start.checked_add(o))
    };
    if let (Some(rest), Some(addr)) = (inbox.get_mut(head..frame), at(head)) {
        if !rest.is_empty() {
            pdi.read(addr, rest)?;
        }
    }
    let last = len.wrapping_sub(1);
    if frame < len {
        if let (Some(byte), Some(addr)) = (inbox.get_mut(last..len), at(last)) {
            pdi.read(addr, byte)?;
        }
    }
    Ok(())
}

/// A request [`Mailbox::receive`] read from SM0 into the inbox, to be answered with the
/// dictionary ([`Mailbox::answer`]).
#[derive(Debug, PartialEq, Eq)]
#[must_use]
pub struct Request {
    /// Bytes read (the SM0 buffer, at most the inbox).
    len: usize,
}

/// A received request as its mailbox header classifies it.
enum Received {
    /// Answered with this mailbox error.
    Malformed(MailboxErrorCode),
    /// A retry of the request served last (the same counter): not served again.
    Repeated,
    /// A protocol this slave does not serve (a mailbox error answers it).
    Unsupported { counter: u8 },
    /// A CoE request whose payload ends at inbox byte `payload_end`.
    Coe { counter: u8, payload_end: usize },
}

/// The mailbox state of one slave.
pub struct Mailbox {
    inbox: [u8; MAX_MAILBOX],
    outbox: [u8; MAX_MAILBOX],
    /// Length of the frame in `outbox` (header + payload); 0 = nothing to send or repeat.
    out_len: usize,
    /// `outbox` has been written to SM1 (and is now the repeat backup).
    out_posted: bool,
    last_rx_counter: u8,
    tx_counter: u8,
    repeat_ack: bool,
    coe: CoeServer,
    /// Emergencies waiting for an idle mailbox.
    emcy: EmcyQueue,
    /// The emergency posted last while SM1 may still hold it unread, with the send counter
    /// before it (to withdraw it when a request arrives).
    emcy_in_sm1: Option<(Emergency, u8)>,
    /// SM1's event is in the AL event mask (`SlaveCore::start` leaves it out).
    sm1_event_enabled: bool,
}

impl Default for Mailbox {
    fn default() -> Self {
        Self::new()
    }
}

impl Mailbox {
    /// An idle mailbox.
    pub const fn new() -> Self {
        Self {
            inbox: [0; MAX_MAILBOX],
            outbox: [0; MAX_MAILBOX],
            out_len: 0,
            out_posted: false,
            last_rx_counter: 0,
            tx_counter: 0,
            repeat_ack: false,
            coe: CoeServer::new(),
            emcy: EmcyQueue::new(),
            emcy_in_sm1: None,
            sm1_event_enabled: false,
        }
    }

    /// Forgets every transfer and counter (on the way back to INIT).
    pub fn reset(&mut self) {
        self.out_len = 0;
        self.out_posted = false;
        self.last_rx_counter = 0;
        self.tx_counter = 0;
        self.repeat_ack = false;
        self.coe.reset();
        self.emcy.clear();
        self.emcy_in_sm1 = None;
    }

    /// Queues an emergency for the master; hands it back when the queue is full.
    pub fn post_emcy(&mut self, emcy: Emergency) -> Result<(), Emergency> {
        self.emcy.post(emcy)
    }

    /// Whether an SDO transfer spans mailbox rounds right now (segmented up/download, SDO
    /// information fragments).
    pub fn transfer_in_progress(&self) -> bool {
        self.coe.transfer_in_progress()
    }

    /// Emergencies waiting to be posted.
    pub fn pending_emcys(&self) -> usize {
        self.emcy.len()
    }

    /// Serves the mailbox: repeat requests, pending responses, a new request in SM0.
    pub fn service<P: EscPdi>(
        &mut self,
        pdi: &mut P,
        device: &DeviceInfo,
        od: &mut Dictionary<'_>,
        state: AlState,
        events: AlEvent,
    ) -> Result<(), P::Error> {
        self.service_with(pdi, device, od, state, events, &mut ())
    }

    /// [`Self::service`] with a hook run on every committed SDO download before its response
    /// is posted (see [`CoeServer::handle_with`]).
    pub fn service_with<P: EscPdi, H: DownloadHook + ?Sized>(
        &mut self,
        pdi: &mut P,
        device: &DeviceInfo,
        od: &mut Dictionary<'_>,
        state: AlState,
        events: AlEvent,
        hook: &mut H,
    ) -> Result<(), P::Error> {
        let request = self.receive(pdi, device, events)?;
        self.answer(pdi, device, od, state, request, hook)
    }

    /// The transfers of a round that need no object dictionary: a repeat request, a response
    /// waiting for SM1, the next fragment of a fragmented one, an emergency when idle; then a
    /// request in SM0 read into the inbox (which hands SM0 back to the master). Returns the
    /// request if there is one: [`Self::answer`] answers it with the dictionary and ends the
    /// round (it must be called in every round, with `None` when there is no request).
    pub fn receive<P: EscPdi>(
        &mut self,
        pdi: &mut P,
        device: &DeviceInfo,
        events: AlEvent,
    ) -> Result<Option<Request>, P::Error> {
        let out = &device.mailbox_out;
        let inp = &device.mailbox_in;
        if events.any(AlEvent::SM_ACTIVATION) {
            self.serve_repeat(pdi, inp)?;
        }
        if self.out_len > 0 && !self.out_posted && !self.post(pdi, inp)? {
            return Ok(None); // SM1 still full: keep the request waiting in SM0
        }
        self.post_fragment(pdi, inp)?;
        let sm0_status = SmStatus(pdi.read_u8(SM0_STATUS)?);
        if !sm0_status.mailbox_full() {
            // Idle: no request, no response waiting. Time for an emergency.
            self.send_emcy(pdi, inp)?;
            return Ok(None);
        }
        self.withdraw_emcy(pdi)?;
        // At most the inbox: `read_frame` reads within it.
        let len = (out.length as usize).min(MAX_MAILBOX);
        read_frame(pdi, out.start, &mut self.inbox, len)?;
        Ok(Some(Request { len }))
    }

    /// Answers the `request` [`Self::receive`] read (with `od`, in `state`; `hook` runs on each
    /// committed download) and posts the response, then ends the round: SM1's event in the
    /// mask while a frame waits for SM1.
    pub fn answer<P: EscPdi, H: DownloadHook + ?Sized>(
        &mut self,
        pdi: &mut P,
        device: &DeviceInfo,
        od: &mut Dictionary<'_>,
        state: AlState,
        request: Option<Request>,
        hook: &mut H,
    ) -> Result<(), P::Error> {
        if let Some(Request { len }) = request {
            let inp = &device.mailbox_in;
            if self.process(len, inp.length as usize, od, state, hook) {
                self.post(pdi, inp)?;
            }
        }
        self.update_sm1_event(pdi)
    }

    /// Whether a frame waits for SM1 to empty: a response not yet posted, the next fragment of
    /// a fragmented one, a queued emergency.
    fn waits_for_sm1(&self) -> bool {
        (self.out_len > 0 && !self.out_posted)
            || (self.out_posted && self.coe.fragment_pending())
            || !self.emcy.is_empty()
    }

    /// Puts SM1's event in the AL event mask while a frame waits for SM1, takes it out when
    /// none does (a read-modify-write of 0x0204 on each change only; no other context writes
    /// the mask after start-up).
    fn update_sm1_event<P: EscPdi>(&mut self, pdi: &mut P) -> Result<(), P::Error> {
        let wanted = self.waits_for_sm1();
        if wanted == self.sm1_event_enabled {
            return Ok(());
        }
        let mask = pdi.read_u32(regs::AL_EVENT_MASK.addr)?;
        let bit = AlEvent::sm(SM_MAILBOX_IN);
        let mask = if wanted { mask | bit } else { mask & !bit };
        pdi.write_u32(regs::AL_EVENT_MASK.addr, mask)?;
        self.sm1_event_enabled = wanted;
        Ok(())
    }

    /// Handles the request in `inbox[..len]`; returns whether a response was put in `outbox`.
    fn process<H: DownloadHook + ?Sized>(
        &mut self,
        len: usize,
        out_capacity: usize,
        od: &mut Dictionary<'_>,
        state: AlState,
        hook: &mut H,
    ) -> bool {
        let capacity = out_capacity.min(MAX_MAILBOX);
        let payload_end = match self.classify(len) {
            Received::Malformed(code) => return self.error_reply(code, capacity),
            Received::Repeated => return false,
            Received::Unsupported { counter } => {
                self.take_counter(counter);
                return self.error_reply(MailboxErrorCode::UnsupportedProtocol, capacity);
            }
            Received::Coe {
                counter,
                payload_end,
            } => {
                self.take_counter(counter);
                payload_end
            }
        };
        let (Some(request), Some(response)) = (
            self.inbox.get(HEADER_LEN..payload_end),
            self.outbox.get_mut(HEADER_LEN..capacity),
        ) else {
            return self.error_reply(MailboxErrorCode::InvalidSize, capacity);
        };
        match self.coe.handle_with(od, state, request, response, hook) {
            Ok(0) => false,
            Ok(n) => self.frame(MailboxType::Coe, n),
            Err(e) => {
                let code = e.mailbox_error_code();
                self.error_reply_code(code, capacity)
            }
        }
    }

    /// What the `len`-byte request in the inbox is, from its mailbox header (nothing changes).
    fn classify(&self, len: usize) -> Received {
        let Some(header) = MailboxHeader::parse(&self.inbox) else {
            return Received::Malformed(MailboxErrorCode::Syntax);
        };
        let payload_end = HEADER_LEN
            .checked_add(usize::from(header.length))
            .filter(|&end| end <= len);
        let Some(payload_end) = payload_end else {
            return Received::Malformed(MailboxErrorCode::InvalidSize);
        };
        if header.counter != 0 && header.counter == self.last_rx_counter {
            return Received::Repeated;
        }
        if header.kind != MailboxType::Coe as u8 {
            return Received::Unsupported {
                counter: header.counter,
            };
        }
        Received::Coe {
            counter: header.counter,
            payload_end,
        }
    }

    /// Remembers a served request's counter (0: the master does not count).
    fn take_counter(&mut self, counter: u8) {
        if counter != 0 {
            self.last_rx_counter = counter;
        }
    }

    /// What of the OD RAM answering `request` (received, not yet answered) reads or writes.
    pub fn scope(&self, request: &Request) -> DictionaryScope {
        match self.classify(request.len) {
            Received::Coe { payload_end, .. } => self
                .inbox
                .get(HEADER_LEN..payload_end)
                .map_or(DictionaryScope::Nothing, |payload| self.coe.scope(payload)),
            // Answered with a mailbox error, or not at all.
            Received::Malformed(_) | Received::Repeated | Received::Unsupported { .. } => {
                DictionaryScope::Nothing
            }
        }
    }

    fn error_reply(&mut self, code: MailboxErrorCode, capacity: usize) -> bool {
        self.error_reply_code(code as u16, capacity)
    }

    /// Puts a mailbox error reply (type 0: command 0x0001, detail code) in `outbox`.
    fn error_reply_code(&mut self, code: u16, capacity: usize) -> bool {
        const ERROR_PAYLOAD_LEN: usize = 4;
        if capacity < HEADER_LEN + ERROR_PAYLOAD_LEN {
            return false;
        }
        let c = MAILBOX_ERROR_COMMAND.to_le_bytes();
        let d = code.to_le_bytes();
        if let Some(p) = self
            .outbox
            .get_mut(HEADER_LEN..HEADER_LEN + ERROR_PAYLOAD_LEN)
        {
            p.copy_from_slice(&[c[0], c[1], d[0], d[1]]);
        }
        self.frame(MailboxType::Error, ERROR_PAYLOAD_LEN)
    }

    /// Writes the header of a `payload_len` response of type `kind` into `outbox`.
    fn frame(&mut self, kind: MailboxType, payload_len: usize) -> bool {
        // The payload was written into `outbox` after the header: the sum always fits.
        let Some(out_len) = HEADER_LEN.checked_add(payload_len) else {
            return false;
        };
        self.tx_counter = next_counter(self.tx_counter);
        let header = MailboxHeader {
            length: payload_len as u16,
            address: 0,
            channel: 0,
            priority: 0,
            kind: kind as u8,
            counter: self.tx_counter,
        };
        if let Some(h) = self.outbox.get_mut(..HEADER_LEN) {
            h.copy_from_slice(&header.to_bytes());
        }
        self.out_len = out_len;
        self.out_posted = false;
        true
    }

    /// Posts the next fragment of a fragmented CoE response (SDO information) once the master
    /// has read the previous one from SM1 (ETG.1000.6 §5.6.3: one fragment per mailbox frame).
    fn post_fragment<P: EscPdi>(&mut self, pdi: &mut P, sm1: &SmLayout) -> Result<(), P::Error> {
        if !self.out_posted || !self.coe.fragment_pending() || sm1_full(pdi)? {
            return Ok(());
        }
        let capacity = (sm1.length as usize).min(MAX_MAILBOX);
        let Some(response) = self.outbox.get_mut(HEADER_LEN..capacity) else {
            return Ok(());
        };
        if let Some(n) = self.coe.pending_fragment(response) {
            self.frame(MailboxType::Coe, n);
            self.post(pdi, sm1)?;
        }
        Ok(())
    }

    /// Writes `outbox` to SM1 if SM1 is empty; returns whether it was posted.
    fn post<P: EscPdi>(&mut self, pdi: &mut P, sm1: &SmLayout) -> Result<bool, P::Error> {
        if sm1_full(pdi)? {
            return Ok(false);
        }
        self.write_outbox(pdi, sm1)?;
        self.out_posted = true;
        self.emcy_in_sm1 = None;
        Ok(true)
    }

    /// Posts the oldest queued emergency if SM1 is empty and no response waits. The outbox
    /// (the repeat backup) is overwritten only once SM1 is known to be empty, i.e. once the
    /// master has read the previous frame.
    fn send_emcy<P: EscPdi>(&mut self, pdi: &mut P, sm1: &SmLayout) -> Result<(), P::Error> {
        let response_waiting = self.out_len > 0 && !self.out_posted;
        let capacity = (sm1.length as usize).min(MAX_MAILBOX);
        if response_waiting || self.emcy.is_empty() || capacity < HEADER_LEN + EMCY_PAYLOAD_LEN {
            return Ok(());
        }
        if sm1_full(pdi)? {
            return Ok(());
        }
        let Some(emcy) = self.emcy.pop() else {
            return Ok(());
        };
        let counter_before = self.tx_counter;
        if let Some(p) = self
            .outbox
            .get_mut(HEADER_LEN..HEADER_LEN + EMCY_PAYLOAD_LEN)
        {
            p.copy_from_slice(&emcy.to_payload());
        }
        self.frame(MailboxType::Coe, EMCY_PAYLOAD_LEN);
        self.write_outbox(pdi, sm1)?;
        self.out_posted = true;
        self.emcy_in_sm1 = Some((emcy, counter_before));
        Ok(())
    }

    /// A request is waiting in SM0: if the emergency posted last is still unread in SM1, the
    /// master sent the request after it last looked at SM1, so it would take the emergency for
    /// the answer. Withdraw it (flush SM1) and queue it again at the head.
    fn withdraw_emcy<P: EscPdi>(&mut self, pdi: &mut P) -> Result<(), P::Error> {
        let Some((emcy, counter_before)) = self.emcy_in_sm1.take() else {
            return Ok(());
        };
        if !sm1_full(pdi)? {
            return Ok(()); // the master has read it
        }
        self.flush_sm1(pdi)?;
        // The queue had room for it before it was popped unless a new one was posted since;
        // then the newest waits behind it and, with the queue full, the withdrawn one is lost.
        let _ = self.emcy.requeue(emcy);
        self.tx_counter = counter_before;
        self.out_len = 0;
        self.out_posted = false;
        Ok(())
    }

    /// Empties SM1 from the PDI side: deactivate and re-activate the SM (SM PDI control bit 0).
    fn flush_sm1<P: EscPdi>(&mut self, pdi: &mut P) -> Result<(), P::Error> {
        pdi.write_u8(SM1_PDI_CONTROL, self.pdi_control(SmPdiControl::DEACTIVATE))?;
        pdi.write_u8(SM1_PDI_CONTROL, self.pdi_control(0))
    }

    /// Writes the frame and, if it is shorter than the SM, the SM's last byte: the ESC marks the
    /// mailbox full only when its last byte is written.
    fn write_outbox<P: EscPdi>(&mut self, pdi: &mut P, sm1: &SmLayout) -> Result<(), P::Error> {
        let sm_len = (sm1.length as usize).min(MAX_MAILBOX);
        let len = self.out_len.min(sm_len);
        if let Some(frame) = self.outbox.get(..len) {
            pdi.write(sm1.start, frame)?;
        }
        if len < sm_len {
            // The SM's last byte; an SM the profile places past the top of the 64 KiB address
            // space has none to write.
            let last = sm_len
                .checked_sub(1)
                .and_then(|offset| u16::try_from(offset).ok())
                .and_then(|offset| sm1.start.checked_add(offset));
            if let Some(last) = last {
                pdi.write(last, &[0])?;
            }
        }
        Ok(())
    }

    /// Re-posts the backup if the master toggled the repeat request, then acknowledges it.
    fn serve_repeat<P: EscPdi>(&mut self, pdi: &mut P, sm1: &SmLayout) -> Result<(), P::Error> {
        // Reading the activate byte also acknowledges the SM-activation event.
        let activate = SmActivate(pdi.read_u8(SM1_ACTIVATE)?);
        let requested = activate.repeat_request();
        if requested == self.repeat_ack {
            return Ok(());
        }
        if self.out_len > 0 && self.out_posted {
            if sm1_full(pdi)? {
                // Flush the unread frame before re-posting the backup.
                self.flush_sm1(pdi)?;
            }
            self.write_outbox(pdi, sm1)?;
        }
        self.repeat_ack = requested;
        pdi.write_u8(SM1_PDI_CONTROL, self.pdi_control(0))
    }

    fn pdi_control(&self, extra: u8) -> u8 {
        extra
            | if self.repeat_ack {
                SmPdiControl::REPEAT_ACK
            } else {
                0
            }
    }
}

/// Whether SM1 (slave → master) holds a frame the master has not read yet.
fn sm1_full<P: EscPdi>(pdi: &mut P) -> Result<bool, P::Error> {
    let status = SmStatus(pdi.read_u8(SM1_STATUS)?);
    Ok(status.mailbox_full())
}

#[cfg(test)]
mod tests;
