//! The checks every SDO access runs, shared by single-entry transfers ([`super::sdo`]) and
//! complete access ([`super::complete_access`]): existence, access rights per state, the PDO
//! rules, length, subindex 0 and range, then the store.

use hal::esc::AlState;

use crate::od::index::sm_parameter::SUB_SHIFT_TIME;
use crate::od::index::SM_INPUT_PARAMETER;
use crate::od::value::{as_u32, check_length, check_range, check_value_list};
use crate::od::{
    AbortCode, Access, DataType, Dictionary, Entry, Object, ObjectCode, StoreError, Value,
};
use crate::pdo::rules as pdo_rules;

/// Kind of access.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum AccessKind {
    /// Upload.
    Read,
    /// Download.
    Write,
}

/// Complete access is served only when the profile advertises it (SII CoE details, ESI
/// `CompleteAccess`); else 0x06010000.
pub(crate) fn check_complete_access(od: &Dictionary<'_>) -> Result<(), AbortCode> {
    if od.profile().device.coe.complete_access {
        Ok(())
    } else {
        Err(AbortCode::UnsupportedAccess)
    }
}

/// The entry `index:subindex`: 0x06020000 if the object is missing, 0x06090011 if the subindex.
#[inline]
pub(crate) fn find_entry(
    od: &Dictionary<'_>,
    index: u16,
    subindex: u8,
) -> Result<&'static Entry, AbortCode> {
    find_object_entry(od, index, subindex).map(|(_, entry)| entry)
}

/// [`find_entry`] with the object it is in.
#[inline]
fn find_object_entry(
    od: &Dictionary<'_>,
    index: u16,
    subindex: u8,
) -> Result<(&'static Object, &'static Entry), AbortCode> {
    let object = od.object(index).ok_or(AbortCode::ObjectNotFound)?;
    let entry = object.entry(subindex).ok_or(AbortCode::SubindexNotFound)?;
    Ok((object, entry))
}

/// The object and entry of a download request, if the entry exists and may be written now
/// (the object is handed on to [`write_found`]: one search of the dictionary per request).
pub(crate) fn find_writable(
    od: &Dictionary<'_>,
    state: AlState,
    index: u16,
    subindex: u8,
) -> Result<(&'static Object, &'static Entry), AbortCode> {
    let (object, entry) = find_object_entry(od, index, subindex)?;
    check_access(entry.access, state, AccessKind::Write)?;
    pdo_rules::check_rx_mapped(od, state, entry, index, subindex)?;
    Ok((object, entry))
}

/// Checks the entry's access rights: never readable/writable gives 0x06010001/0x06010002, not in
/// the current state 0x08000022.
pub(crate) fn check_access(
    access: Access,
    state: AlState,
    kind: AccessKind,
) -> Result<(), AbortCode> {
    let (any, none_code) = match kind {
        AccessKind::Read => (access.readable(), AbortCode::WriteOnlyRead),
        AccessKind::Write => (access.writable(), AbortCode::ReadOnlyWrite),
    };
    if !any {
        return Err(none_code);
    }
    if access.0 & state_bit(state, kind) == 0 {
        return Err(AbortCode::DataNotStoredDeviceState);
    }
    Ok(())
}

/// The [`Access`] bit for `kind` in `state` (none in INIT and BOOT, where no SDO is served).
fn state_bit(state: AlState, kind: AccessKind) -> u8 {
    match (state, kind) {
        (AlState::PreOp, AccessKind::Read) => Access::READ_PREOP,
        (AlState::SafeOp, AccessKind::Read) => Access::READ_SAFEOP,
        (AlState::Op, AccessKind::Read) => Access::READ_OP,
        (AlState::PreOp, AccessKind::Write) => Access::WRITE_PREOP,
        (AlState::SafeOp, AccessKind::Write) => Access::WRITE_SAFEOP,
        (AlState::Op, AccessKind::Write) => Access::WRITE_OP,
        (AlState::Init | AlState::Boot, _) => 0,
    }
}

/// Runs every download check on `data` and stores it: access, RxPDO-mapped (0x06010006),
/// length, subindex 0 count, PDO rules, range, the profile's list of accepted values.
pub(crate) fn write_entry(
    od: &mut Dictionary<'_>,
    state: AlState,
    index: u16,
    subindex: u8,
    data: &[u8],
) -> Result<(), AbortCode> {
    let (object, entry) = find_writable(od, state, index, subindex)?;
    write_found(od, (object, entry), index, subindex, data)
}

/// The checks of [`write_entry`] that follow [`find_writable`], and the store: for a request
/// whose entry `find_writable` has just returned in the same state (an expedited or
/// single-frame download), so that access and RxPDO mapping are not checked twice.
pub(crate) fn write_found(
    od: &mut Dictionary<'_>,
    (object, entry): (&Object, &Entry),
    index: u16,
    subindex: u8,
    data: &[u8],
) -> Result<(), AbortCode> {
    check_length(entry, data.len())?;
    check_subindex0(object, subindex, data)?;
    pdo_rules::check_write(od, index, subindex, data)?;
    check_range(entry, data)?;
    check_value_list(od.profile().value_list(index, subindex), entry, data)?;
    check_input_shift_step(od, index, subindex, data)?;
    od.set_value(entry, data).map_err(store_abort)
}

/// The input shift time 1C33h:03, where the profile lets the master write it, takes whole
/// multiples of the profile's step only (0x06090030 otherwise).
fn check_input_shift_step(
    od: &Dictionary<'_>,
    index: u16,
    subindex: u8,
    data: &[u8],
) -> Result<(), AbortCode> {
    if (index, subindex) != (SM_INPUT_PARAMETER, SUB_SHIFT_TIME) {
        return Ok(());
    }
    let support = &od.profile().device.sync;
    match as_u32(data) {
        Some(shift) if support.input_shift_on_step(shift) => Ok(()),
        _ => Err(AbortCode::ValueRange),
    }
}

/// Subindex 0 of an ARRAY or RECORD may not exceed the highest existing subindex (0x06090031).
fn check_subindex0(object: &Object, subindex: u8, data: &[u8]) -> Result<(), AbortCode> {
    if subindex != 0 || object.code == ObjectCode::Var {
        return Ok(());
    }
    let highest = object.entries.last().map_or(0, |e| e.subindex);
    match as_u32(data) {
        Some(count) if count <= u32::from(highest) => Ok(()),
        _ => Err(AbortCode::ValueTooHigh),
    }
}

/// The abort for a storage failure.
pub(crate) fn store_abort(e: StoreError) -> AbortCode {
    match e {
        StoreError::ReadOnly => AbortCode::ReadOnlyWrite,
        StoreError::Length => AbortCode::LengthTooHigh,
        StoreError::Layout => AbortCode::General,
        StoreError::Domain => AbortCode::UnsupportedAccess,
    }
}

/// The bytes an upload sends: a VISIBLE_STRING variable the master writes up to its first NUL
/// (CiA 301 §7.1.6.3: a visible string may be shorter than its object; the master's text comes
/// back, not the padding), anything else whole (a string the device fills may carry bytes
/// after a NUL: the Σ-V-SD's 2310h:03 reply frame is a "STRING[16]" of binary fields).
pub(crate) fn upload_value<'a>(
    od: &'a Dictionary<'_>,
    entry: &Entry,
) -> Result<&'a [u8], AbortCode> {
    let bytes = od.value(entry).map_err(store_abort)?;
    let is_written_text = entry.data_type == DataType::VisibleString
        && matches!(entry.value, Value::Ram(_))
        && entry.access.writable();
    if !is_written_text {
        return Ok(bytes);
    }
    let len = bytes.iter().position(|&b| b == 0).unwrap_or(bytes.len());
    Ok(bytes.get(..len).unwrap_or_default())
}
