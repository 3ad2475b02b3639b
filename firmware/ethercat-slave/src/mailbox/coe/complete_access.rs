//! SDO complete access (ETG.1000.6 §5.6.2.1.1/§5.6.2.4.1: the CA bit, bit 4 of the init
//! command): one upload or download carries a whole object.
//!
//! Stream layout (byte-exact with what SOEM's `ecx_readPDOassignCA`/`ecx_readPDOmapCA` read
//! into `{ uint8 n; uint8 nu1; uint16/uint32 entries[] }`, with the ESI's array BitSize
//! `16 + n × element` and with the Beckhoff SSC):
//!
//! - ARRAY and RECORD, request subindex 0 ("subindex 0 included"): subindex 0 first, transferred
//!   as **16 bits** (its u8 value, then a 0 byte), then entries 1..=n.
//! - Request subindex 1 ("subindex 0 excluded"): entries 1..=n only. Any other subindex is
//!   refused with 0x06010000.
//! - n is the current value of subindex 0 for an upload (clamped to the highest subindex). Gaps
//!   in the subindexes take no room. Entries whose bit length is a multiple of 8 start on a byte
//!   boundary; BOOLEAN/BITn entries are packed bit by bit after the previous entry.
//! - VAR (SOES issue #166): complete access at subindex 0 transfers the value itself, exactly as
//!   a plain access would (there is no subindex-0 count); subindex 1 does not exist (0x06090011).
//! - A DOMAIN (data outside the OD RAM) cannot be part of a complete access: 0x06010004.
//!
//! Upload: every entry sent must be readable in the current state (0x06010001 / 0x08000022).
//!
//! Download: the stream must cover subindex 0 (if included) and entries 1..=n, n being the new
//! subindex 0 value (if included) or the current one; it may cover further entries up to the
//! highest subindex, each completely (else 0x06070013 too short / 0x06070012 too long). A
//! read-only entry in the stream must carry its current value (so that an uploaded object can
//! be written back), else 0x06010002. The write is atomic: every entry goes through the same
//! checks as a single download (access, range, PDO rules); for a PDO mapping or assignment
//! object subindex 0 is set to 0 first and to n last, which re-validates the whole mapping
//! (0x06040041/0x06040042/0x06090030). On any failure the object's previous RAM content is
//! restored, so the master sees either the whole new object or the old one.

use hal::esc::AlState;

use super::access::{check_access, write_entry, AccessKind};
use crate::od::AbortCode;
use crate::od::{Dictionary, Entry, Object, ObjectCode, Value};
use crate::pdo::rules as pdo_rules;

/// Bits subindex 0 occupies in a complete-access stream (ETG.1000.6; SOEM `uint8 n; uint8 nu1`).
pub const SI0_STREAM_BITS: usize = 16;
/// Largest RAM footprint of an object a complete-access download can restore on failure (and
/// of the stream buffers): the SDV3-E's parameter groups 3000h–3003h hold 397 bytes each; every
/// built-in profile's objects are checked against it (`firmware` crate tests).
pub const UNDO_CAPACITY: usize = 512;
/// Bits per byte.
const BITS_PER_BYTE: usize = 8;

/// Where a complete-access stream starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Start {
    /// A VAR's value.
    Var,
    /// Subindex 0 included.
    Si0,
    /// Subindex 0 excluded.
    Si1,
}

impl Start {
    /// The start for a request at `subindex` of `object`.
    fn of(object: &Object, subindex: u8) -> Result<Self, AbortCode> {
        match (object.code, subindex) {
            (ObjectCode::Var, 0) => Ok(Self::Var),
            (ObjectCode::Var, _) => Err(AbortCode::SubindexNotFound),
            (_, 0) => Ok(Self::Si0),
            (_, 1) => Ok(Self::Si1),
            _ => Err(AbortCode::UnsupportedAccess),
        }
    }
}

/// One entry's place in the stream.
#[derive(Clone, Copy, Debug)]
struct Slot {
    entry: &'static Entry,
    /// First bit in the stream.
    bit: usize,
    /// Bits in the stream.
    bits: usize,
}

impl Slot {
    /// The bit after the slot (saturated: such a slot lies beyond any stream).
    fn end(&self) -> usize {
        self.bit.saturating_add(self.bits)
    }
    /// Whether `data` holds the whole slot.
    fn within(&self, data: &[u8]) -> bool {
        self.end().div_ceil(BITS_PER_BYTE) <= data.len()
    }
}

/// Walks the slots of the stream of `object` from `start` up to subindex `last`, calling `f` for
/// each; returns the stream length in bits (0x08000000 for an object whose stream length
/// would not fit a `usize`).
fn walk(
    object: &'static Object,
    start: Start,
    last: u8,
    mut f: impl FnMut(Slot) -> Result<(), AbortCode>,
) -> Result<usize, AbortCode> {
    let mut bit = 0usize;
    for entry in object.entries.iter() {
        if matches!(entry.value, Value::Domain(_)) {
            return Err(AbortCode::CompleteAccessVariableLength);
        }
        let bits = match (start, entry.subindex) {
            (Start::Var, _) => usize::from(entry.bit_len),
            (Start::Si0, 0) => SI0_STREAM_BITS,
            (Start::Si1, 0) => continue,
            (_, si) if si > last => break,
            _ => usize::from(entry.bit_len),
        };
        if bits % BITS_PER_BYTE == 0 {
            bit = bit
                .checked_next_multiple_of(BITS_PER_BYTE)
                .ok_or(AbortCode::General)?;
        }
        f(Slot { entry, bit, bits })?;
        bit = bit.checked_add(bits).ok_or(AbortCode::General)?;
    }
    Ok(bit)
}

/// The current subindex-0 value of an ARRAY/RECORD, clamped to its highest subindex.
fn current_count(od: &Dictionary<'_>, object: &Object) -> u8 {
    let highest = object.entries.last().map_or(0, |e| e.subindex);
    let n = od.read_u32(object.index, 0).unwrap_or(0);
    u8::try_from(n).unwrap_or(u8::MAX).min(highest)
}

/// Serialises `object` for a complete-access upload at `subindex` into `out`; returns the
/// stream length in bytes (0x05040005 if `out` is too small).
pub(super) fn upload(
    od: &Dictionary<'_>,
    state: AlState,
    object: &'static Object,
    subindex: u8,
    out: &mut [u8],
) -> Result<usize, AbortCode> {
    let start = Start::of(object, subindex)?;
    let last = current_count(od, object);
    // Size and access first: nothing is written for a refused upload.
    let bits = walk(object, start, last, |slot| {
        check_access(slot.entry.access, state, AccessKind::Read)
    })?;
    let len = bits.div_ceil(BITS_PER_BYTE);
    let out = out.get_mut(..len).ok_or(AbortCode::OutOfMemory)?;
    out.fill(0);
    walk(object, start, last, |slot| {
        let value = od.value(slot.entry).map_err(|_| AbortCode::General)?;
        put_bits(out, slot, value);
        Ok(())
    })?;
    Ok(len)
}

/// Writes `value` (little-endian, at least `slot.bits` wide or shorter) into the stream.
fn put_bits(out: &mut [u8], slot: Slot, value: &[u8]) {
    if slot.bit % BITS_PER_BYTE == 0 && slot.bits % BITS_PER_BYTE == 0 {
        let at = slot.bit / BITS_PER_BYTE;
        let n = value.len().min(slot.bits / BITS_PER_BYTE);
        let dst = out.get_mut(at..).and_then(|o| o.get_mut(..n));
        if let (Some(dst), Some(src)) = (dst, value.get(..n)) {
            dst.copy_from_slice(src);
        }
        return;
    }
    for (i, pos) in (slot.bit..slot.end()).enumerate() {
        let set = value
            .get(i / BITS_PER_BYTE)
            .is_some_and(|b| b >> (i % BITS_PER_BYTE) & 1 != 0);
        if let Some(b) = out.get_mut(pos / BITS_PER_BYTE) {
            if set {
                *b |= 1 << (pos % BITS_PER_BYTE);
            }
        }
    }
}

/// Reads the value of `slot` from the stream into `buf`; returns its byte length.
fn get_bits(data: &[u8], slot: Slot, buf: &mut [u8]) -> Result<usize, AbortCode> {
    let len = slot.bits.div_ceil(BITS_PER_BYTE);
    let dst = buf.get_mut(..len).ok_or(AbortCode::OutOfMemory)?;
    dst.fill(0);
    if slot.bit % BITS_PER_BYTE == 0 && slot.bits % BITS_PER_BYTE == 0 {
        let at = slot.bit / BITS_PER_BYTE;
        let src = data
            .get(at..)
            .and_then(|d| d.get(..len))
            .ok_or(AbortCode::LengthTooLow)?;
        dst.copy_from_slice(src);
        return Ok(len);
    }
    for (i, pos) in (slot.bit..slot.end()).enumerate() {
        let byte = data
            .get(pos / BITS_PER_BYTE)
            .ok_or(AbortCode::LengthTooLow)?;
        if byte >> (pos % BITS_PER_BYTE) & 1 != 0 {
            if let Some(b) = dst.get_mut(i / BITS_PER_BYTE) {
                *b |= 1 << (i % BITS_PER_BYTE);
            }
        }
    }
    Ok(len)
}

/// Writes a complete-access download of `data` at `subindex` of `object` (see the module
/// documentation for the rules).
pub(super) fn download(
    od: &mut Dictionary<'_>,
    state: AlState,
    object: &'static Object,
    subindex: u8,
    data: &[u8],
) -> Result<(), AbortCode> {
    let start = Start::of(object, subindex)?;
    if start == Start::Var {
        return write_entry(od, state, object.index, 0, data);
    }
    let highest = object.entries.last().map_or(0, |e| e.subindex);
    let count = match start {
        Start::Si0 => {
            let n = *data.first().ok_or(AbortCode::LengthTooLow)?;
            if n > highest {
                return Err(AbortCode::ValueTooHigh);
            }
            n
        }
        _ => current_count(od, object),
    };
    check_stream_length(object, start, count, highest, data.len())?;
    // Access of every covered entry before anything is written.
    walk(object, start, highest, |slot| {
        if slot.within(data) {
            check_writable(od, state, slot, data)?;
        }
        Ok(())
    })?;
    let mut undo = [0u8; UNDO_CAPACITY];
    let saved = snapshot(od, object, &mut undo)?;
    let result = write_all(od, state, object, start, count, data);
    if result.is_err() {
        restore(od, object, undo.get(..saved).unwrap_or_default());
    }
    result
}

/// The stream must cover entries up to `count` and may cover up to `highest`.
fn check_stream_length(
    object: &'static Object,
    start: Start,
    count: u8,
    highest: u8,
    len: usize,
) -> Result<(), AbortCode> {
    let needed = walk(object, start, count, |_| Ok(()))?.div_ceil(BITS_PER_BYTE);
    let full = walk(object, start, highest, |_| Ok(()))?.div_ceil(BITS_PER_BYTE);
    if len < needed {
        return Err(AbortCode::LengthTooLow);
    }
    if len > full {
        return Err(AbortCode::LengthTooHigh);
    }
    Ok(())
}

/// An entry in the stream must be writable now, or read-only and unchanged.
fn check_writable(
    od: &Dictionary<'_>,
    state: AlState,
    slot: Slot,
    data: &[u8],
) -> Result<(), AbortCode> {
    if slot.entry.access.writable() {
        return check_access(slot.entry.access, state, AccessKind::Write);
    }
    if unchanged(od, slot, data)? {
        Ok(())
    } else {
        Err(AbortCode::ReadOnlyWrite)
    }
}

/// Whether the stream carries the entry's current value.
fn unchanged(od: &Dictionary<'_>, slot: Slot, data: &[u8]) -> Result<bool, AbortCode> {
    let mut buf = [0u8; UNDO_CAPACITY];
    let n = get_bits(data, slot, &mut buf)?;
    let current = od.value(slot.entry).map_err(|_| AbortCode::General)?;
    // Subindex 0 travels as 16 bits: its padding byte must be 0.
    let stream = buf.get(..n).unwrap_or_default();
    let (head, padding) = stream.split_at(current.len().min(stream.len()));
    Ok(head == current.get(..head.len()).unwrap_or_default() && padding.iter().all(|&b| b == 0))
}

/// Writes the entries of the stream, subindex 0 last (PDO objects: 0 first, then n last).
fn write_all(
    od: &mut Dictionary<'_>,
    state: AlState,
    object: &'static Object,
    start: Start,
    count: u8,
    data: &[u8],
) -> Result<(), AbortCode> {
    let index = object.index;
    let pdo = pdo_rules::applies_to(index);
    let si0 = object.entry(0);
    if pdo {
        if let Some(e) = si0 {
            od.set_value(e, &[0]).map_err(|_| AbortCode::General)?;
        }
    }
    walk(object, start, u8::MAX, |slot| {
        let skip = slot.entry.subindex == 0 || !slot.within(data) || !slot.entry.access.writable();
        if skip {
            return Ok(());
        }
        let mut buf = [0u8; UNDO_CAPACITY];
        let n = get_bits(data, slot, &mut buf)?;
        let value = buf.get(..n).unwrap_or_default();
        write_entry(od, state, index, slot.entry.subindex, value)
    })?;
    let si0_writable = si0.is_some_and(|e| e.access.writable());
    if si0_writable && (start == Start::Si0 || pdo) {
        write_entry(od, state, index, 0, &[count])?;
    }
    Ok(())
}

/// Copies the RAM values of `object` into `undo`; returns the bytes used (0x05040005 if the
/// object does not fit).
fn snapshot(od: &Dictionary<'_>, object: &Object, undo: &mut [u8]) -> Result<usize, AbortCode> {
    let mut at = 0usize;
    for e in object.entries.iter() {
        if !matches!(e.value, Value::Ram(_)) {
            continue;
        }
        let value = od.value(e).map_err(|_| AbortCode::General)?;
        let end = at.checked_add(value.len()).ok_or(AbortCode::OutOfMemory)?;
        let dst = undo.get_mut(at..end).ok_or(AbortCode::OutOfMemory)?;
        dst.copy_from_slice(value);
        at = end;
    }
    Ok(at)
}

/// Writes back what [`snapshot`] saved.
fn restore(od: &mut Dictionary<'_>, object: &Object, undo: &[u8]) {
    let mut at = 0usize;
    for e in object.entries.iter() {
        if !matches!(e.value, Value::Ram(_)) {
            continue;
        }
        let Some(end) = at.checked_add(e.byte_len()) else {
            return; // snapshot saved no more than fits
        };
        if let Some(value) = undo.get(at..end) {
            let _ = od.set_value(e, value);
        }
        at = end;
    }
}
