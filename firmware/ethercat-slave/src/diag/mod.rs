//! Diagnosis history, object 10F3h (ETG.1020 §13 "Diagnosis handling").
//!
//! Object layout (ETG.1020 §13; as Beckhoff devices document it, e.g. EL3773 "Index 10F3
//! Diagnosis History", and the SSC's `TOBJ10F3`):
//!
//! | sub | name | type | access |
//! |---|---|---|---|
//! | 1 | Maximum messages | UNSIGNED8 | RO |
//! | 2 | Newest message (its subindex, 0 = none) | UNSIGNED8 | RO |
//! | 3 | Newest acknowledged message (subindex; write 0 = clear history) | UNSIGNED8 | RW |
//! | 4 | New messages available | BOOLEAN | RO |
//! | 5 | Flags ([`flags`]) | UNSIGNED16 | RW |
//! | 6.. | Diagnosis message 1..n | OCTET_STRING | RO |
//!
//! Message layout (ETG.1020 §13; Beckhoff "DiagMessages": diag code 4 bytes, flags 2, text ID
//! 2, time stamp 8, then the parameters; SSC `TDIAGMESSAGE`), little-endian:
//!
//! | bytes | 0..4 | 4..6 | 6..8 | 8..16 | 16.. |
//! |---|---|---|---|---|---|
//! | field | diag code | flags | text ID | time stamp (ns) | parameters |
//!
//! Message flags: bits 0..=3 type ([`DiagType`]), bit 4 "time stamp is local" (not DC system
//! time), bits 8..=15 number of parameters. Each parameter is a u16 parameter flags word
//! (bits 12..=15 = 0 "data", bits 0..=11 = CoE data type code) followed by the value.
//! Diag codes: 0xE000..=0xE7FF in bits 0..=15 are manufacturer specific; 0xE800 in bits 0..=15
//! means bits 16..=31 hold a CiA 301 emergency error code (SSC `DIAG_CODE_EMCY`).
//!
//! Overwrite mode (flags bit 4 = 0): a new message replaces the oldest when the ring is full
//! and sets flags bit 5. Acknowledge mode (bit 4 = 1): a new message may only replace an
//! acknowledged one; when every slot holds an unacknowledged message the new one is discarded
//! and bit 5 is set. The master acknowledges up to a message by writing its subindex to :03
//! (which also clears bit 5); writing 0 clears the history (the SSC's `Write0x10F3` does the
//! same). :04 is true while messages newer than the newest acknowledged one exist.
//!
//! The history lives in the OD RAM (entries declared by the profile); this module keeps only
//! the ring position. 10F3h:03 is written by SDO like any RW entry; [`Diagnosis::poll`] picks the
//! new value up (and, if it names no stored message, restores the previous one).

use heapless::Vec;

use crate::mailbox::emcy::Emergency;
use crate::od::{DataType, Dictionary, StoreError};

pub use crate::od::index::DIAG_HISTORY;

/// Subindices of 10F3h.
pub mod sub {
    /// Maximum messages.
    pub const MAX_MESSAGES: u8 = 1;
    /// Newest message.
    pub const NEWEST: u8 = 2;
    /// Newest acknowledged message.
    pub const NEWEST_ACKNOWLEDGED: u8 = 3;
    /// New messages available.
    pub const NEW_MESSAGES: u8 = 4;
    /// Flags.
    pub const FLAGS: u8 = 5;
    /// First diagnosis message.
    pub const FIRST_MESSAGE: u8 = 6;
}

/// Bits of 10F3h:05 (ETG.1020 §13; SSC `DIAG_SEND_AS_EMCY` .. `DIAG_OVERWRITE_DISCARD`;
/// Beckhoff `ST_CoE_DiagHistory_Info` lists the same flags).
pub mod flags {
    /// Send every new message also as an emergency.
    pub const SEND_AS_EMERGENCY: u16 = 1 << 0;
    /// Do not store info messages.
    pub const DISABLE_INFO: u16 = 1 << 1;
    /// Do not store warnings.
    pub const DISABLE_WARNING: u16 = 1 << 2;
    /// Do not store errors.
    pub const DISABLE_ERROR: u16 = 1 << 3;
    /// 0 = overwrite mode, 1 = acknowledge mode.
    pub const ACKNOWLEDGE_MODE: u16 = 1 << 4;
    /// Messages were overwritten (overwrite mode) or discarded (acknowledge mode).
    pub const OVERWRITTEN_OR_DISCARDED: u16 = 1 << 5;
}

/// Bytes of a message before its parameters (diag code, flags, text ID, time stamp).
pub const MESSAGE_HEADER_LEN: usize = 16;
/// Parameters one message can carry.
pub const MAX_PARAMS: usize = 4;
/// Most message slots the ring handles (the profile declares how many exist).
pub const MAX_MESSAGES: usize = 250;
/// Bits 0..=15 of a diag code that carries an emergency error code in bits 16..=31.
pub const DIAG_CODE_EMCY: u16 = 0xE800;
/// Message flags bit 4: the time stamp is the device's local time, not DC system time.
pub const MSG_FLAG_LOCAL_TIME: u16 = 1 << 4;
/// Message flags: shift of the number of parameters.
const MSG_PARAM_COUNT_SHIFT: u16 = 8;
/// Bytes of a parameter's flags word (before its value).
const PARAM_FLAGS_LEN: usize = 2;

/// The diag code of a message about emergency error code `code` (SSC `DIAG_CODE_EMCY`).
pub const fn diag_code_for_emcy(code: u16) -> u32 {
    ((code as u32) << 16) | DIAG_CODE_EMCY as u32
}

/// Message type (message flags bits 0..=3).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum DiagType {
    /// Information.
    Info = 0,
    /// Warning.
    Warning = 1,
    /// Error.
    Error = 2,
}

impl DiagType {
    /// The 10F3h:05 bit that suppresses this type.
    const fn disable_flag(self) -> u16 {
        match self {
            Self::Info => flags::DISABLE_INFO,
            Self::Warning => flags::DISABLE_WARNING,
            Self::Error => flags::DISABLE_ERROR,
        }
    }
}

/// One message parameter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DiagParam {
    /// UNSIGNED8.
    U8(u8),
    /// UNSIGNED16.
    U16(u16),
    /// UNSIGNED32.
    U32(u32),
}

impl DiagParam {
    /// The CoE data type code and the little-endian value bytes (`n` of the 4 are used).
    const fn parts(self) -> (DataType, [u8; 4], usize) {
        match self {
            Self::U8(v) => (DataType::Unsigned8, [v, 0, 0, 0], 1),
            Self::U16(v) => {
                let [a, b] = v.to_le_bytes();
                (DataType::Unsigned16, [a, b, 0, 0], 2)
            }
            Self::U32(v) => (DataType::Unsigned32, v.to_le_bytes(), 4),
        }
    }

    /// Writes the parameter flags (type "data" = 0 in bits 12..=15, CoE data type in bits
    /// 0..=11) and the value to `out`; returns the length, 0 if `out` is too short.
    fn encode(self, out: &mut [u8]) -> usize {
        let (ty, value, n) = self.parts();
        let (Some(len), Some(src)) = (PARAM_FLAGS_LEN.checked_add(n), value.get(..n)) else {
            return 0;
        };
        let Some((flags, dst)) = out
            .get_mut(..len)
            .and_then(|d| d.split_first_chunk_mut::<PARAM_FLAGS_LEN>())
        else {
            return 0;
        };
        *flags = ty.code().to_le_bytes();
        dst.copy_from_slice(src);
        len
    }
}

/// A diagnosis message to report.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DiagMessage {
    /// Diag code (see [`diag_code_for_emcy`]; 0xE000..=0xE7FF manufacturer specific).
    pub code: u32,
    /// Type.
    pub kind: DiagType,
    /// Text ID (ESI `DiagMessages`; 0 = none).
    pub text_id: u16,
    /// Parameters.
    pub params: Vec<DiagParam, MAX_PARAMS>,
}

impl DiagMessage {
    /// A message without parameters.
    pub const fn new(code: u32, kind: DiagType, text_id: u16) -> Self {
        Self {
            code,
            kind,
            text_id,
            params: Vec::new(),
        }
    }

    /// Adds a parameter (ignored beyond [`MAX_PARAMS`]).
    pub fn with(mut self, param: DiagParam) -> Self {
        let _ = self.params.push(param);
        self
    }

    /// Encodes the message with time stamp `now_ns` into `out` (the whole entry; unused bytes
    /// are zeroed, parameters that do not fit are left out and not counted).
    pub fn encode(&self, now_ns: u64, out: &mut [u8]) {
        out.fill(0);
        let (header_out, mut rest) = out.split_at_mut(MESSAGE_HEADER_LEN.min(out.len()));
        let mut count: u16 = 0;
        for p in &self.params {
            let n = p.encode(rest);
            if n == 0 {
                break;
            }
            rest = core::mem::take(&mut rest).get_mut(n..).unwrap_or_default();
            // At most MAX_PARAMS: never saturates.
            count = count.saturating_add(1);
        }
        let msg_flags = (self.kind as u16) | MSG_FLAG_LOCAL_TIME | (count << MSG_PARAM_COUNT_SHIFT);
        let c = self.code.to_le_bytes();
        let f = msg_flags.to_le_bytes();
        let t = self.text_id.to_le_bytes();
        let s = now_ns.to_le_bytes();
        let header = [
            c[0], c[1], c[2], c[3], f[0], f[1], t[0], t[1], s[0], s[1], s[2], s[3], s[4], s[5],
            s[6], s[7],
        ];
        if let Some(h) = header_out.first_chunk_mut::<MESSAGE_HEADER_LEN>() {
            *h = header;
        }
    }

    /// The emergency to send for this message when 10F3h:05 bit 0 is set: the emergency code
    /// from an 0xE800 diag code (else generic error 0x1000 for errors, none for info and
    /// warnings), the given error register, the first parameter bytes as data.
    pub fn emergency(&self, register: u8) -> Option<Emergency> {
        let code = if self.code as u16 == DIAG_CODE_EMCY {
            (self.code >> 16) as u16
        } else if self.kind == DiagType::Error {
            crate::mailbox::emcy::code::GENERIC
        } else {
            return None;
        };
        let mut data = [0u8; 5];
        let mut rest = data.as_mut_slice();
        for p in &self.params {
            let (_, bytes, n) = p.parts();
            let (Some((dst, tail)), Some(src)) = (
                core::mem::take(&mut rest).split_at_mut_checked(n),
                bytes.get(..n),
            ) else {
                break;
            };
            dst.copy_from_slice(src);
            rest = tail;
        }
        Some(Emergency::new(code, register, data))
    }
}

/// Why a message was not stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DiagError {
    /// The profile has no (usable) 10F3h.
    NoHistory,
    /// 10F3h:05 disables messages of this type.
    Suppressed,
    /// Acknowledge mode and every slot holds an unacknowledged message: discarded.
    Discarded,
    /// The OD store refused a value (a profile/layout error).
    Store(StoreError),
}

impl From<StoreError> for DiagError {
    fn from(e: StoreError) -> Self {
        Self::Store(e)
    }
}

/// The ring state of the diagnosis history (the messages themselves are in the OD RAM).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Diagnosis {
    /// Messages stored (≤ slots).
    stored: u8,
    /// Ring index (0-based) of the newest message.
    newest: u8,
    /// Messages newer than the newest acknowledged one.
    unacknowledged: u8,
    /// 10F3h:03 as this module last wrote it (to notice the master's writes).
    ack_subindex: u8,
}

impl Diagnosis {
    /// An empty history.
    pub const fn new() -> Self {
        Self {
            stored: 0,
            newest: 0,
            unacknowledged: 0,
            ack_subindex: 0,
        }
    }

    /// Number of message slots: 10F3h:01, limited to the message entries the profile declares.
    pub fn slots(od: &Dictionary<'_>) -> u8 {
        let Some(obj) = od.object(DIAG_HISTORY) else {
            return 0;
        };
        let declared = obj
            .entries
            .iter()
            .filter(|e| e.subindex >= sub::FIRST_MESSAGE && e.data_type == DataType::OctetString)
            .count()
            .min(MAX_MESSAGES);
        let max = read_u8(od, sub::MAX_MESSAGES).unwrap_or(0) as usize;
        max.min(declared) as u8
    }

    /// 10F3h:05.
    pub fn flags(od: &Dictionary<'_>) -> u16 {
        od.entry(DIAG_HISTORY, sub::FLAGS)
            .and_then(|e| od.value(e).ok())
            .and_then(|v| v.first_chunk::<2>())
            .map_or(0, |b| u16::from_le_bytes(*b))
    }

    /// Stores `msg` with time stamp `now_ns`; returns the emergency to send if 10F3h:05 bit 0
    /// asks for it (`register` is the current 1001h).
    pub fn report(
        &mut self,
        od: &mut Dictionary<'_>,
        msg: &DiagMessage,
        now_ns: u64,
        register: u8,
    ) -> Result<Option<Emergency>, DiagError> {
        let slots = Self::slots(od);
        if slots == 0 {
            return Err(DiagError::NoHistory);
        }
        let mut fl = Self::flags(od);
        if fl & msg.kind.disable_flag() != 0 {
            return Err(DiagError::Suppressed);
        }
        let full = self.stored >= slots;
        if fl & flags::ACKNOWLEDGE_MODE != 0 && self.unacknowledged >= slots {
            self.set_flags(od, fl | flags::OVERWRITTEN_OR_DISCARDED)?;
            return Err(DiagError::Discarded);
        }
        if full && fl & flags::ACKNOWLEDGE_MODE == 0 {
            fl |= flags::OVERWRITTEN_OR_DISCARDED;
        }
        let slot = if self.stored == 0 {
            0
        } else {
            next_slot(self.newest, slots)
        };
        let subindex = message_subindex(slot).ok_or(DiagError::NoHistory)?;
        let entry = od
            .entry(DIAG_HISTORY, subindex)
            .ok_or(DiagError::NoHistory)?;
        let mut buf = [0u8; 256];
        let len = entry.byte_len().min(buf.len());
        let bytes = buf.get_mut(..len).ok_or(DiagError::NoHistory)?;
        msg.encode(now_ns, bytes);
        od.set_value(entry, bytes)?;
        self.newest = slot;
        // Both stay ≤ slots (≤ MAX_MESSAGES): the saturation never takes effect.
        self.stored = self.stored.saturating_add(1).min(slots);
        self.unacknowledged = self.unacknowledged.saturating_add(1).min(slots);
        // An acknowledged message that was just overwritten can no longer be the newest
        // acknowledged one.
        if self.unacknowledged >= slots && self.ack_subindex != 0 {
            self.ack_subindex = 0;
            write_u8(od, sub::NEWEST_ACKNOWLEDGED, 0)?;
        }
        write_u8(od, sub::NEWEST, subindex)?;
        write_u8(od, sub::NEW_MESSAGES, 1)?;
        self.set_flags(od, fl)?;
        Ok(if fl & flags::SEND_AS_EMERGENCY != 0 {
            msg.emergency(register)
        } else {
            None
        })
    }

    /// Picks up a master write to 10F3h:03 (call after every mailbox service): a stored
    /// message's subindex acknowledges it and every older one; 0 clears the history; anything
    /// else is undone.
    pub fn poll(&mut self, od: &mut Dictionary<'_>) -> Result<(), DiagError> {
        let Some(value) = read_u8(od, sub::NEWEST_ACKNOWLEDGED) else {
            return Ok(());
        };
        if value == self.ack_subindex {
            return Ok(());
        }
        self.acknowledge(od, value)
    }

    /// Applies a write of `value` to 10F3h:03 (for a download hook; [`Self::poll`] calls it).
    pub fn acknowledge(&mut self, od: &mut Dictionary<'_>, value: u8) -> Result<(), DiagError> {
        let slots = Self::slots(od);
        if value == 0 {
            return self.clear(od);
        }
        let stored = value
            .checked_sub(sub::FIRST_MESSAGE)
            .filter(|&slot| slot < self.stored && slots > 0);
        let Some(acked) = stored else {
            return write_u8(od, sub::NEWEST_ACKNOWLEDGED, self.ack_subindex);
        };
        self.unacknowledged = newer_than(self.newest, acked, slots);
        self.ack_subindex = value;
        write_u8(od, sub::NEWEST_ACKNOWLEDGED, value)?;
        write_u8(od, sub::NEW_MESSAGES, u8::from(self.unacknowledged > 0))?;
        let fl = Self::flags(od);
        self.set_flags(od, fl & !flags::OVERWRITTEN_OR_DISCARDED)
    }

    /// Deletes every message.
    pub fn clear(&mut self, od: &mut Dictionary<'_>) -> Result<(), DiagError> {
        let slots = Self::slots(od);
        for subindex in (sub::FIRST_MESSAGE..=u8::MAX).take(usize::from(slots)) {
            if let Some(e) = od.entry(DIAG_HISTORY, subindex) {
                let mut buf = [0u8; 256];
                if let Some(z) = buf.get_mut(..e.byte_len().min(256)) {
                    od.set_value(e, z)?;
                }
            }
        }
        *self = Self::new();
        write_u8(od, sub::NEWEST, 0)?;
        write_u8(od, sub::NEWEST_ACKNOWLEDGED, 0)?;
        write_u8(od, sub::NEW_MESSAGES, 0)?;
        let fl = Self::flags(od);
        self.set_flags(od, fl & !flags::OVERWRITTEN_OR_DISCARDED)
    }

    /// Messages stored.
    pub fn stored(&self) -> u8 {
        self.stored
    }

    fn set_flags(&mut self, od: &mut Dictionary<'_>, value: u16) -> Result<(), DiagError> {
        if let Some(e) = od.entry(DIAG_HISTORY, sub::FLAGS) {
            od.set_value(e, &value.to_le_bytes())?;
        }
        Ok(())
    }
}

/// The subindex of the message in ring slot `slot` (`None` beyond subindex 255, where no
/// slot lies: [`MAX_MESSAGES`] = 256 − [`sub::FIRST_MESSAGE`]).
fn message_subindex(slot: u8) -> Option<u8> {
    sub::FIRST_MESSAGE.checked_add(slot)
}

/// The ring slot after `slot` in a ring of `slots` slots (wraps to 0 after the last one).
fn next_slot(slot: u8, slots: u8) -> u8 {
    match slot.checked_add(1) {
        Some(next) if next < slots => next,
        _ => 0,
    }
}

/// Messages newer than the one in ring slot `acked` when the newest is in ring slot `newest`
/// (both below `slots`): `(newest − acked) mod slots`, computed without the `u8` overflow of
/// `newest + slots − acked` for rings of more than 128 slots.
fn newer_than(newest: u8, acked: u8, slots: u8) -> u8 {
    match newest.checked_sub(acked) {
        Some(newer) => newer,
        // The ring wrapped between them: `slots − (acked − newest)`, with 0 < acked − newest
        // < slots.
        None => slots.saturating_sub(acked.abs_diff(newest)),
    }
}

fn read_u8(od: &Dictionary<'_>, subindex: u8) -> Option<u8> {
    let e = od.entry(DIAG_HISTORY, subindex)?;
    od.value(e).ok()?.first().copied()
}

fn write_u8(od: &mut Dictionary<'_>, subindex: u8, value: u8) -> Result<(), DiagError> {
    if let Some(e) = od.entry(DIAG_HISTORY, subindex) {
        od.set_value(e, &[value])?;
    }
    Ok(())
}

#[cfg(test)]
mod tests;
