//! SDO Information service (ETG.1000.6 §5.6.3; CoE service 8).
//!
//! Every frame after the 2-byte CoE header starts with the 4-byte SDO information header:
//!
//! | byte 0 | byte 1 | bytes 2..4 |
//! |---|---|---|
//! | opcode (bits 0..6), incomplete (bit 7) | reserved | fragments left (u16) |
//!
//! | opcode | request data | response data |
//! |---|---|---|
//! | 1/2 Get OD List | list type u16 | list type u16, then u16 indices (type 0: five u16 counts) |
//! | 3/4 Get Object Description | index u16 | index u16, data type u16, max subindex u8, object code u8, name |
//! | 5/6 Get Entry Description | index u16, subindex u8, value info u8 | index u16, subindex u8, value info u8, data type u16, bit length u16, ObjAccess u16, (unit type u16), (default), (minimum), (maximum), name |
//! | 7 SDO Info Error | — | abort code u32 |
//!
//! A response longer than the mailbox is sent in fragments: each but the last has the
//! incomplete bit set, and "fragments left" counts the frames still to come. The list type of an
//! OD List response is sent once, at the start of the first fragment. The server produces one
//! fragment per call: the first from `InfoServer::handle`, the next ones from
//! `InfoServer::next_fragment` (the mailbox layer calls it each time SM1 is free again). The
//! response is regenerated from the static dictionary for each fragment, so no buffer holds it.
//!
//! List 4 (stored for device replacement, "backup") holds the objects with an entry the
//! parameter storage stores ([`crate::od::storable::is_storable`], the one rule for 1010h and for
//! this list); list 5 (startup parameters, "settings") the objects with an entry the profile
//! marks `setting = true` ([`crate::od::DeviceInfo::settings`]). The same entries carry
//! ObjAccess bit 8 (backup) and bit 9 (setting) in their entry description.
//!
//! The data type of an object description is the entry type for VAR and ARRAY; for RECORD it is
//! the CiA 301 complex type where one applies (0x0023 IDENTITY for 1018h, 0x0021 PDO_MAPPING for
//! 16xxh/1Axxh), else the type of subindex 1.

use super::CoeError;
use crate::od::index::IDENTITY;
use crate::od::storable::is_storable;
use crate::od::AbortCode;
use crate::od::{Entry, Object, ObjectCode, PdoMappable, Profile};
use crate::pdo::rules::{RX_MAPPING, TX_MAPPING};

/// Length of the SDO information header.
pub const INFO_HEADER_LEN: usize = 4;

/// SDO information opcodes (ETG.1000.6 Table 43).
mod opcode {
    /// Get OD List request.
    pub const OD_LIST_REQ: u8 = 0x01;
    /// Get OD List response.
    pub const OD_LIST_RESP: u8 = 0x02;
    /// Get Object Description request.
    pub const OBJ_DESC_REQ: u8 = 0x03;
    /// Get Object Description response.
    pub const OBJ_DESC_RESP: u8 = 0x04;
    /// Get Entry Description request.
    pub const ENTRY_DESC_REQ: u8 = 0x05;
    /// Get Entry Description response.
    pub const ENTRY_DESC_RESP: u8 = 0x06;
    /// SDO Info Error request.
    pub const ERROR_REQ: u8 = 0x07;
    /// Mask of the opcode in header byte 0.
    pub const MASK: u8 = 0x7F;
    /// Incomplete (more fragments follow) bit in header byte 0.
    pub const INCOMPLETE: u8 = 0x80;
}

/// OD list types (ETG.1000.6 §5.6.3.3.1).
mod list {
    /// Number of objects of each of the list types 1..=5.
    pub const COUNTS: u16 = 0;
    /// All objects.
    pub const ALL: u16 = 1;
    /// Objects with an RxPDO-mappable entry.
    pub const RX_MAPPABLE: u16 = 2;
    /// Objects with a TxPDO-mappable entry.
    pub const TX_MAPPABLE: u16 = 3;
    /// Objects stored for device replacement (backup).
    pub const BACKUP: u16 = 4;
    /// Startup parameters (settings).
    pub const STARTUP: u16 = 5;
}

/// Value info bits of the entry description (ETG.1000.6 §5.6.3.5.1).
mod value_info {
    /// Unit type present.
    pub const UNIT_TYPE: u8 = 0x08;
    /// Default value present.
    pub const DEFAULT: u8 = 0x10;
    /// Minimum value present.
    pub const MINIMUM: u8 = 0x20;
    /// Maximum value present.
    pub const MAXIMUM: u8 = 0x40;
}

/// ObjAccess bits of the entry description beyond the per-state access bits 0..5 (ETG.1000.6
/// §5.6.3.5.2).
mod obj_access {
    /// Mappable into an RxPDO.
    pub const RX_PDO: u16 = 1 << 6;
    /// Mappable into a TxPDO.
    pub const TX_PDO: u16 = 1 << 7;
    /// Stored for device replacement (backup).
    pub const BACKUP: u16 = 1 << 8;
    /// Startup parameter (setting).
    pub const SETTING: u16 = 1 << 9;
}

/// CiA 301 complex data types used as object data types of records.
mod complex_type {
    /// PDO_MAPPING.
    pub const PDO_MAPPING: u16 = 0x0021;
    /// IDENTITY.
    pub const IDENTITY: u16 = 0x0023;
}

/// Unit type reported when requested (no units in the model).
const NO_UNIT: u16 = 0;

/// What a response describes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Reply {
    /// Get OD List response of a list type.
    OdList(u16),
    /// Get Object Description response.
    Object(&'static Object),
    /// Get Entry Description response with the value info to send.
    Entry(u16, &'static Entry, u8),
}

impl Reply {
    fn opcode(self) -> u8 {
        match self {
            Self::OdList(_) => opcode::OD_LIST_RESP,
            Self::Object(_) => opcode::OBJ_DESC_RESP,
            Self::Entry(..) => opcode::ENTRY_DESC_RESP,
        }
    }
}

/// A fragmented response being sent.
#[derive(Clone, Copy, Debug)]
struct Pending {
    profile: &'static Profile,
    reply: Reply,
    /// Payload bytes already sent.
    sent: usize,
}

/// The SDO information server: the fragmented response in progress, if any.
#[derive(Debug, Default)]
pub(super) struct InfoServer {
    pending: Option<Pending>,
}

impl InfoServer {
    /// Idle.
    pub(super) const fn new() -> Self {
        Self { pending: None }
    }

    /// Drops a fragmented response in progress.
    pub(super) fn reset(&mut self) {
        self.pending = None;
    }

    /// Whether more fragments of a response are to be sent.
    pub(super) fn fragment_pending(&self) -> bool {
        self.pending.is_some()
    }

    /// Handles one request `req` (after the CoE header) and writes the first (or only) response
    /// frame after the CoE header to `resp`; returns its length. A new request drops the
    /// fragments of the previous one.
    pub(super) fn handle(
        &mut self,
        profile: &'static Profile,
        req: &[u8],
        resp: &mut [u8],
    ) -> Result<usize, CoeError> {
        self.pending = None;
        let Some(&[op, _reserved, _f0, _f1]) = req.first_chunk::<INFO_HEADER_LEN>() else {
            return Err(CoeError::SizeTooShort);
        };
        if resp.len() <= INFO_HEADER_LEN {
            return Err(CoeError::NoMoreMemory);
        }
        let data = req.get(INFO_HEADER_LEN..).unwrap_or_default();
        match parse(profile, op & opcode::MASK, data)? {
            Ok(reply) => {
                let pending = Pending {
                    profile,
                    reply,
                    sent: 0,
                };
                Ok(self.emit(pending, resp))
            }
            Err(code) => Ok(write_error(resp, code)),
        }
    }

    /// Writes the next fragment of the pending response to `resp` (after the CoE header);
    /// `None` if nothing is pending.
    pub(super) fn next_fragment(&mut self, resp: &mut [u8]) -> Option<usize> {
        let pending = self.pending.take()?;
        Some(self.emit(pending, resp))
    }

    /// Writes the fragment of `pending` that starts at `pending.sent` and keeps the rest
    /// pending.
    fn emit(&mut self, pending: Pending, resp: &mut [u8]) -> usize {
        let (header, body) = resp.split_at_mut(INFO_HEADER_LEN.min(resp.len()));
        // Fragments carry whole u16 words (SOEM counts OD List indices as (length - 6) / 2).
        let even = body.len() & !1;
        let body = body.get_mut(..even).unwrap_or_default();
        let room = body.len().max(1);
        let total = payload(pending.profile, pending.reply, &mut Sink::discard());
        let mut sink = Sink::new(body, pending.sent);
        payload(pending.profile, pending.reply, &mut sink);
        let chunk = sink.written();
        // Both count bytes of one payload of at most `total` bytes: never saturates.
        let sent = pending.sent.saturating_add(chunk);
        let left = total.saturating_sub(sent).div_ceil(room);
        let left = u16::try_from(left).unwrap_or(u16::MAX);
        let mut op = pending.reply.opcode();
        if left > 0 && chunk > 0 {
            op |= opcode::INCOMPLETE;
            self.pending = Some(Pending { sent, ..pending });
        }
        let [l0, l1] = left.to_le_bytes();
        if let Some(h) = header.first_chunk_mut::<INFO_HEADER_LEN>() {
            *h = [op, 0, l0, l1];
        }
        // `chunk` bytes were written after the header in `resp`: never saturates.
        INFO_HEADER_LEN.saturating_add(chunk)
    }
}

/// Parses a request: `Err` for a malformed request (mailbox error), `Ok(Err(code))` for a
/// request answered with an SDO Info Error.
fn parse(
    profile: &'static Profile,
    op: u8,
    data: &[u8],
) -> Result<Result<Reply, AbortCode>, CoeError> {
    let u16_at = |at: usize| {
        data.get(at..)
            .and_then(|b| b.first_chunk::<2>())
            .map(|b| u16::from_le_bytes(*b))
            .ok_or(CoeError::SizeTooShort)
    };
    Ok(match op {
        opcode::OD_LIST_REQ => match u16_at(0)? {
            t if t <= list::STARTUP => Ok(Reply::OdList(t)),
            _ => Err(AbortCode::UnsupportedAccess),
        },
        opcode::OBJ_DESC_REQ => profile
            .object(u16_at(0)?)
            .map(Reply::Object)
            .ok_or(AbortCode::ObjectNotFound),
        opcode::ENTRY_DESC_REQ => {
            let index = u16_at(0)?;
            let (Some(&subindex), Some(&info)) = (data.get(2), data.get(3)) else {
                return Err(CoeError::SizeTooShort);
            };
            match profile.object(index) {
                None => Err(AbortCode::ObjectNotFound),
                Some(o) => o
                    .entry(subindex)
                    .map(|e| Reply::Entry(index, e, served_value_info(e, info)))
                    .ok_or(AbortCode::SubindexNotFound),
            }
        }
        _ => Err(AbortCode::InvalidCommand),
    })
}

/// The value-info bits of a request that the entry can serve.
fn served_value_info(e: &Entry, requested: u8) -> u8 {
    let mut present = value_info::UNIT_TYPE;
    for (bit, value) in [
        (value_info::DEFAULT, e.default),
        (value_info::MINIMUM, e.min),
        (value_info::MAXIMUM, e.max),
    ] {
        if !value.is_empty() {
            present |= bit;
        }
    }
    requested & present
}

/// Writes an SDO Info Error frame (after the CoE header); returns its length.
fn write_error(resp: &mut [u8], code: AbortCode) -> usize {
    const LEN: usize = INFO_HEADER_LEN + 4;
    let [c0, c1, c2, c3] = code.code().to_le_bytes();
    match resp.get_mut(..LEN) {
        Some(frame) => {
            frame.copy_from_slice(&[opcode::ERROR_REQ, 0, 0, 0, c0, c1, c2, c3]);
            LEN
        }
        None => 0,
    }
}

/// A writer over the logical payload that keeps the bytes `skip..skip + out.len()` and counts
/// the rest.
struct Sink<'a> {
    out: &'a mut [u8],
    skip: usize,
    pos: usize,
}

impl<'a> Sink<'a> {
    fn new(out: &'a mut [u8], skip: usize) -> Self {
        Self { out, skip, pos: 0 }
    }
    /// Keeps nothing, only counts.
    fn discard() -> Sink<'static> {
        Sink {
            out: &mut [],
            skip: 0,
            pos: 0,
        }
    }
    fn put(&mut self, bytes: &[u8]) {
        for &b in bytes {
            if let Some(slot) = self
                .pos
                .checked_sub(self.skip)
                .and_then(|i| self.out.get_mut(i))
            {
                *slot = b;
            }
            // Counts the bytes of one payload built from the profile: never saturates.
            self.pos = self.pos.saturating_add(1);
        }
    }
    fn u16(&mut self, v: u16) {
        self.put(&v.to_le_bytes());
    }
    /// Bytes kept.
    fn written(&self) -> usize {
        self.pos.saturating_sub(self.skip).min(self.out.len())
    }
}

/// Generates the whole payload of `reply` into `sink`; returns its length.
fn payload(profile: &'static Profile, reply: Reply, sink: &mut Sink<'_>) -> usize {
    match reply {
        Reply::OdList(t) => od_list(profile, t, sink),
        Reply::Object(o) => object_description(o, sink),
        Reply::Entry(index, e, info) => entry_description(profile, index, e, info, sink),
    }
    sink.pos
}

fn od_list(profile: &Profile, list_type: u16, sink: &mut Sink<'_>) {
    sink.u16(list_type);
    if list_type == list::COUNTS {
        for t in list::ALL..=list::STARTUP {
            let n = profile
                .objects
                .iter()
                .filter(|o| in_list(profile, o, t))
                .count();
            sink.u16(u16::try_from(n).unwrap_or(u16::MAX));
        }
        return;
    }
    for o in profile
        .objects
        .iter()
        .filter(|o| in_list(profile, o, list_type))
    {
        sink.u16(o.index);
    }
}

/// Whether object `o` belongs to OD list `list_type` (1..=5).
fn in_list(profile: &Profile, o: &Object, list_type: u16) -> bool {
    let any = |f: fn(PdoMappable) -> bool| o.entries.iter().any(|e| f(e.pdo));
    match list_type {
        list::ALL => true,
        list::RX_MAPPABLE => any(PdoMappable::rx),
        list::TX_MAPPABLE => any(PdoMappable::tx),
        list::BACKUP => o
            .entries
            .iter()
            .any(|e| is_storable(&profile.storage, o, e)),
        list::STARTUP => o
            .entries
            .iter()
            .any(|e| profile.device.is_setting(o.index, e.subindex)),
        _ => false,
    }
}

fn object_description(o: &Object, sink: &mut Sink<'_>) {
    sink.u16(o.index);
    sink.u16(object_data_type(o));
    sink.put(&[max_subindex(o), o.code as u8]);
    sink.put(o.name.as_bytes());
}

/// The highest subindex of an object (0 for a VAR).
pub(super) fn max_subindex(o: &Object) -> u8 {
    o.entries.last().map_or(0, |e| e.subindex)
}

/// The data type of an object description (see the module documentation).
fn object_data_type(o: &Object) -> u16 {
    let first = |si| o.entry(si).map_or(0, |e| e.data_type.code());
    match o.code {
        ObjectCode::Var => first(0),
        ObjectCode::Array => first(1),
        ObjectCode::Record if o.index == IDENTITY => complex_type::IDENTITY,
        ObjectCode::Record if RX_MAPPING.contains(&o.index) || TX_MAPPING.contains(&o.index) => {
            complex_type::PDO_MAPPING
        }
        ObjectCode::Record => first(1),
    }
}

fn entry_description(profile: &Profile, index: u16, e: &Entry, info: u8, sink: &mut Sink<'_>) {
    sink.u16(index);
    sink.put(&[e.subindex, info]);
    sink.u16(e.data_type.code());
    sink.u16(e.bit_len);
    sink.u16(entry_access(profile, index, e));
    if info & value_info::UNIT_TYPE != 0 {
        sink.u16(NO_UNIT);
    }
    for (bit, value) in [
        (value_info::DEFAULT, e.default),
        (value_info::MINIMUM, e.min),
        (value_info::MAXIMUM, e.max),
    ] {
        if info & bit != 0 {
            sink.put(value);
        }
    }
    sink.put(e.name.as_bytes());
}

/// ObjAccess: the per-state access bits, the PDO mapping bits, backup and setting.
fn entry_access(profile: &Profile, index: u16, e: &Entry) -> u16 {
    let mut access = u16::from(e.access.0);
    if e.pdo.rx() {
        access |= obj_access::RX_PDO;
    }
    if e.pdo.tx() {
        access |= obj_access::TX_PDO;
    }
    if profile
        .object(index)
        .is_some_and(|o| is_storable(&profile.storage, o, e))
    {
        access |= obj_access::BACKUP;
    }
    if profile.device.is_setting(index, e.subindex) {
        access |= obj_access::SETTING;
    }
    access
}
