//! Write rules for the PDO mapping (1600h–17FFh, 1A00h–1BFFh) and PDO assignment (1C12h, 1C13h)
//! objects (ETG.1000.6 §5.6.7.4 and the "SI0 = 0, edit, SI0 = n" procedure).
//!
//! - An entry n ≥ 1 may be written only while subindex 0 is 0 (else abort 0x06010003).
//! - A mapping entry (`index << 16 | subindex << 8 | bit length`) must name an entry that exists,
//!   is mappable in the object's direction and has exactly that bit length (else 0x06040041);
//!   index 0000h is padding of any length, indices 0001h–0007h are the CiA 301 dummy entries of
//!   the standard types (with the type's length).
//! - Writing SI0 = n of a mapping object re-checks entries 1..=n, their number against
//!   [`DeviceInfo::max_pdo_entries`](crate::od::DeviceInfo::max_pdo_entries) and their total size
//!   against [`DeviceInfo::max_pdo_bytes`](crate::od::DeviceInfo::max_pdo_bytes), at most
//!   [`MAX_PDO_BYTES`] (0x06040042).
//! - An assignment entry must name an existing mapping object of the matching direction (1C12h →
//!   16xxh/17xxh, 1C13h → 1Axxh/1Bxxh), else 0x06090030; writing SI0 = n re-checks entries 1..=n.
//!
//! The generic checks (access rights per state, length, SI0 ≤ highest subindex) run before these.
//!
//! One more rule guards the process data (`check_rx_mapped`): in SAFEOP and OP, a download to
//! an entry that a PDO assigned in 1C12h maps is refused with 0x06010006 "object mapped to
//! RxPDO, SDO download blocked" when the profile says so
//! ([`RxMappedWrite::Blocked`]).

use hal::esc::AlState;

use crate::od::model::{Entry, Value};
use crate::od::value::as_u32;
use crate::od::AbortCode;
use crate::od::{Dictionary, RxMappedWrite};

pub use crate::od::index::{RX_ASSIGN, RX_MAPPING, TX_ASSIGN, TX_MAPPING};
/// Largest byte length one PDO may have: the whole image of one direction
/// ([`hal::esc::MAX_FIRMWARE_PROCESS_IMAGE`]); a mapping whose entries add up to more is refused
/// with 0x06040042.
pub const MAX_PDO_BYTES: usize = hal::esc::MAX_FIRMWARE_PROCESS_IMAGE as usize;

/// Index of padding entries in a mapping ("gap", any bit length).
const PADDING_INDEX: u16 = 0x0000;
/// Bit lengths of the CiA 301 dummy-mapping entries 0001h–0007h (BOOLEAN, INTEGER8, INTEGER16,
/// INTEGER32, UNSIGNED8, UNSIGNED16, UNSIGNED32), indexed by `index - 1`.
const DUMMY_BIT_LENGTHS: [u16; 7] = [1, 8, 16, 32, 8, 16, 32];
/// Bits per byte.
const BITS_PER_BYTE: usize = 8;

/// Direction of a PDO.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Direction {
    /// RxPDO: outputs, master → slave.
    Rx,
    /// TxPDO: inputs, slave → master.
    Tx,
}

/// What kind of PDO configuration object an index is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum PdoObject {
    /// A PDO mapping object (16xxh/17xxh or 1Axxh/1Bxxh).
    Mapping(Direction),
    /// A PDO assignment object (1C12h or 1C13h).
    Assignment(Direction),
}

impl PdoObject {
    /// Classifies `index`; `None` for any other object.
    fn of(index: u16) -> Option<Self> {
        match index {
            i if RX_MAPPING.contains(&i) => Some(Self::Mapping(Direction::Rx)),
            i if TX_MAPPING.contains(&i) => Some(Self::Mapping(Direction::Tx)),
            RX_ASSIGN => Some(Self::Assignment(Direction::Rx)),
            TX_ASSIGN => Some(Self::Assignment(Direction::Tx)),
            _ => None,
        }
    }
}

/// A decoded mapping entry value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct MappingEntry {
    index: u16,
    subindex: u8,
    bit_len: u8,
}

impl MappingEntry {
    /// Decodes `index << 16 | subindex << 8 | bit length`.
    fn from_u32(v: u32) -> Self {
        let [bit_len, subindex, index_lo, index_hi] = v.to_le_bytes();
        Self {
            index: u16::from_le_bytes([index_lo, index_hi]),
            subindex,
            bit_len,
        }
    }
}

/// Whether `index` names a PDO configuration object these rules apply to.
pub fn applies_to(index: u16) -> bool {
    PdoObject::of(index).is_some()
}

/// Checks a download of `data` to `index:subindex` against the PDO rules; `Ok` for objects the
/// rules do not cover. `data` has already passed the generic length check.
pub(crate) fn check_write(
    od: &Dictionary<'_>,
    index: u16,
    subindex: u8,
    data: &[u8],
) -> Result<(), AbortCode> {
    let Some(kind) = PdoObject::of(index) else {
        return Ok(());
    };
    let value = as_u32(data).ok_or(AbortCode::LengthTooHigh)?;
    if subindex == 0 {
        return check_count(od, kind, index, value);
    }
    if od.read_u32(index, 0) != Some(0) {
        return Err(AbortCode::SubindexNotWritableSi0NonZero);
    }
    match kind {
        PdoObject::Mapping(dir) => check_mapping_entry(od, dir, value).map(|_| ()),
        PdoObject::Assignment(dir) => check_assignment_entry(od, dir, value),
    }
}

/// Checks SI0 = `count` of a mapping or assignment object against its current entries.
fn check_count(
    od: &Dictionary<'_>,
    kind: PdoObject,
    index: u16,
    count: u32,
) -> Result<(), AbortCode> {
    let count = u8::try_from(count).map_err(|_| AbortCode::ValueTooHigh)?;
    match kind {
        PdoObject::Mapping(dir) => check_mapping(od, dir, index, count),
        PdoObject::Assignment(dir) => (1..=count).try_for_each(|si| {
            let value = od.read_u32(index, si).ok_or(AbortCode::ValueTooHigh)?;
            check_assignment_entry(od, dir, value)
        }),
    }
}

/// Checks entries 1..=`count` of mapping object `index`: each valid, their number and total
/// length within bounds.
fn check_mapping(
    od: &Dictionary<'_>,
    dir: Direction,
    index: u16,
    count: u8,
) -> Result<(), AbortCode> {
    if count > od.profile().device.max_pdo_entries {
        return Err(AbortCode::PdoLengthExceeded);
    }
    let mut total_bits = 0usize;
    for si in 1..=count {
        let value = od.read_u32(index, si).ok_or(AbortCode::ValueTooHigh)?;
        // At most 255 entries of at most 255 bits: never saturates.
        total_bits = total_bits.saturating_add(usize::from(check_mapping_entry(od, dir, value)?));
    }
    let max_bytes = usize::from(od.profile().device.max_pdo_bytes).min(MAX_PDO_BYTES);
    if total_bits.div_ceil(BITS_PER_BYTE) > max_bytes {
        return Err(AbortCode::PdoLengthExceeded);
    }
    Ok(())
}

/// Checks one mapping entry value; returns its bit length.
fn check_mapping_entry(od: &Dictionary<'_>, dir: Direction, value: u32) -> Result<u8, AbortCode> {
    let m = MappingEntry::from_u32(value);
    if m.index == PADDING_INDEX {
        return Ok(m.bit_len);
    }
    let dummy = usize::from(m.index)
        .checked_sub(1)
        .and_then(|i| DUMMY_BIT_LENGTHS.get(i));
    if let Some(&dummy_bits) = dummy {
        return if u16::from(m.bit_len) == dummy_bits {
            Ok(m.bit_len)
        } else {
            Err(AbortCode::NotMappable)
        };
    }
    let entry = od
        .entry(m.index, m.subindex)
        .ok_or(AbortCode::NotMappable)?;
    let mappable = match dir {
        Direction::Rx => entry.pdo.rx(),
        Direction::Tx => entry.pdo.tx(),
    };
    if !mappable || entry.bit_len != u16::from(m.bit_len) {
        return Err(AbortCode::NotMappable);
    }
    Ok(m.bit_len)
}

/// Checks one assignment entry: it must name an existing mapping object of direction `dir`.
fn check_assignment_entry(
    od: &Dictionary<'_>,
    dir: Direction,
    value: u32,
) -> Result<(), AbortCode> {
    let range = match dir {
        Direction::Rx => RX_MAPPING,
        Direction::Tx => TX_MAPPING,
    };
    match u16::try_from(value) {
        Ok(pdo) if range.contains(&pdo) && od.object(pdo).is_some() => Ok(()),
        _ => Err(AbortCode::ValueRange),
    }
}

/// Whether `index:subindex` is mapped by a PDO assigned in 1C12h: the active RxPDO mapping
/// (fixed from PREOP → SAFEOP on, because 1C12h and 16xxh are writable in PREOP only). Each
/// object is looked up once and its entries read in place.
pub fn is_rx_mapped(od: &Dictionary<'_>, index: u16, subindex: u8) -> bool {
    let Some(assignment) = od.object(RX_ASSIGN) else {
        return false;
    };
    let assigned = assignment
        .entry(0)
        .and_then(|e| od.entry_u32(e))
        .unwrap_or(0);
    (1..=assigned).any(|a| {
        let pdo = u8::try_from(a)
            .ok()
            .and_then(|a| assignment.entry(a))
            .and_then(|e| od.entry_u32(e))
            .and_then(|v| u16::try_from(v).ok())
            .filter(|p| RX_MAPPING.contains(p))
            .and_then(|p| od.object(p));
        let Some(pdo) = pdo else {
            return false;
        };
        let count = pdo.entry(0).and_then(|e| od.entry_u32(e)).unwrap_or(0);
        (1..=count).any(|si| {
            u8::try_from(si)
                .ok()
                .and_then(|si| pdo.entry(si))
                .and_then(|e| od.entry_u32(e))
                .map(MappingEntry::from_u32)
                .is_some_and(|m| m.index == index && m.subindex == subindex)
        })
    })
}

/// ETG.1000.6 Table 41, 0x06010006: in SAFEOP and OP, with the profile's
/// `pdo.sdo_write_to_rx_mapped = "blocked"`, a download to an entry of the active RxPDO mapping
/// is refused (the next process-data cycle would overwrite it). PREOP (no PDO runs) and
/// `"allowed"` profiles pass.
///
/// `entry` is `index:subindex`'s: an entry that cannot be mapped into an RxPDO is not in the
/// active mapping (the plan built at PREOP → SAFEOP refused any such mapping), so the mapping is
/// searched for RxPDO-mappable entries only.
pub(crate) fn check_rx_mapped(
    od: &Dictionary<'_>,
    state: AlState,
    entry: &Entry,
    index: u16,
    subindex: u8,
) -> Result<(), AbortCode> {
    let blocked = od.profile().device.sdo_write_to_rx_mapped == RxMappedWrite::Blocked
        && matches!(state, AlState::SafeOp | AlState::Op)
        && entry.pdo.rx();
    // The plan's OD RAM ranges where the owner gave them (the slave's mailbox side does), else
    // a search of the mapping objects.
    let mapped = || match (od.rx_outputs(), entry.value) {
        (Some(ranges), Value::Ram(offset)) => {
            let len = u16::try_from(entry.byte_len()).unwrap_or(u16::MAX);
            super::overlaps(ranges, offset, len)
        }
        // Only OD RAM variables are RxPDO destinations.
        (Some(_), Value::Const(_) | Value::Domain(_)) => false,
        (None, _) => is_rx_mapped(od, index, subindex),
    };
    if blocked && mapped() {
        Err(AbortCode::MappedToRxPdo)
    } else {
        Ok(())
    }
}
