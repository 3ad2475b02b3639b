//! Parameter storage: 1010h "Store parameters" and 1011h "Restore default parameters"
//! (CiA 301 §7.5.2.13 and §7.5.2.14) on a power-loss-safe record store over
//! [`hal::storage::NvStorage`], and the profile's automatic storage of SDO downloads.
//!
//! Everything that differs between devices is data of the profile ([`StorageRules`], od-gen's
//! `[storage]` section, `Profile::storage`); this module executes it and knows no device.
//!
//! # Objects
//!
//! Both objects are ARRAYs of UNSIGNED32 with sub 0 = highest subindex. The subindex selects a
//! parameter group ([`Group`]): 1 all parameters; 2 and above the profile's
//! [`StorageGroup`](crate::od::StorageGroup)s, each a list of entry ranges. Without
//! `[[storage.group]]` od-gen gives the CiA 301 scopes: 2 communication parameters
//! (1000h–1FFFh), 3 application parameters (6000h–9FFFh), 4 manufacturer parameters
//! (2000h–5FFFh; CiA 301 leaves sub 4..7Fh to the manufacturer). A vendor's scopes replace them
//! (e.g. the Σ-V-SD: sub 3 = 23xxh and 6xxxh, sub 4 = 2000h–22FFh).
//!
//! - Writing the signature `"save"` = 0x6576_6173 to 1010h:n stores the group's current values;
//!   `"load"` = 0x6461_6F6C to 1011h:n makes the group's defaults apply again from the next
//!   power-on (CiA 301: "the default values shall be set valid after the device is reset or
//!   power cycled"); the current values do not change. The SDO response is sent after the
//!   storage write completed and was verified.
//! - Another value: abort 0x0800_0020 "data cannot be stored" (CiA 301 specifies 0800 002xh for a
//!   wrong signature), nothing is written. A storage failure: abort 0x0606_0000 "hardware error".
//! - A [`WriteCondition`](crate::od::WriteCondition) of the profile (an entry, a mask, a value,
//!   the subindexes it guards) that does not hold on the current OD: abort 0x0800_0022 "data
//!   cannot be transferred or stored because of the present device state", nothing is written
//!   (checked before the signature). The Σ-V-SD allows sub 1 and sub 4 only in CiA402 Switch
//!   On Disabled, i.e. statusword 6041h & 004Fh = 0040h; the stack reads the entry, not the
//!   state machine.
//! - Reading returns the capabilities ([`store_capabilities`]): 1010h bit 0 = saves on command;
//!   bit 1 = saves autonomously, set on the subindexes whose group holds an entry of an
//!   auto-store rule (CiA 301: the device saves those parameters itself; bit 1 states that it
//!   may, so it does not change with the value of an `unless` entry); 1011h bit 0 = restores
//!   defaults. They read so in every state, also after a write (the hook puts the value back);
//!   od-gen checks that the profile's defaults of 1010h are these values, and the generated
//!   dictionary asserts it at compile time.
//!
//! The objects are writable in PREOP, SAFEOP and OP (SDOs are not served in INIT). CiA 301 sets
//! no state restriction; the store runs from the mailbox handler, never from the process-data
//! cycle, so on a board whose flash stalls the CPU during erase/program the cycle may be
//! delayed while a store runs in OP (a board can defer that by refusing in OP in its storage).
//!
//! # What is stored
//!
//! An entry is stored ([`is_storable`]) if it is an OD RAM variable, writable over SDO in some
//! state, not one of [`NOT_STORED`] (1010h/1011h themselves and the SM parameters
//! 1C32h/1C33h, which the stack overwrites with the active synchronisation; except
//! [`STORED_SM_PARAMETER`], a writable input shift time), not named by the
//! profile's `not_stored`, and either not PDO-mappable or named by the profile's
//! `stored_pdo_mappable`.
//!
//! So by default the PDO mapping (16xxh/1Axxh) and assignment (1C12h/1C13h) ARE stored: CiA 301
//! counts them among the communication parameters. They load at power-on in INIT, before the
//! first PREOP → SAFEOP transition builds the copy plan, i.e. a stored mapping behaves exactly
//! like the profile's default mapping (checked against SM2/SM3 at that transition; a master that
//! relies on the SII default must write its mapping, as ETG masters do from the ESI).
//! PDO-mappable entries (controlword, target position, modes of operation, ...) are process
//! data, not parameters: storing a controlword would re-enable a drive at power-on. A drive
//! whose parameters are PDO-mappable too (the RSE's tuning objects, the GHA-E's Pn groups)
//! lists them in `stored_pdo_mappable`, an explicit list of objects and entries; od-gen
//! refuses one that names an entry with a process-data role (controlword, modes of operation,
//! target position/velocity/torque). Writable entries that are commands or live values (the
//! Σ-V-SD's 2300h, 2310h:01, 23E0h, 60C2h) are listed in `not_stored`.
//!
//! # Automatic storage
//!
//! An SDO download (expedited, normal, segmented or complete access; never a PDO write) to an
//! entry named by an [`AutoStore`] rule of the profile is stored at once,
//! unless the rule's `unless` test holds on the values after the download (e.g. the GHA-E's
//! Pn046 = 1 "do not save SDO writes": writing Pn046 = 1 is then itself not saved, writing 0
//! is). The new record holds the downloaded entries' current values and keeps everything else
//! the newest record holds, like a group store. The download response is sent after the record was written and
//! verified; a storage failure answers 0x0606_0000 (the value stays written in the OD RAM:
//! the device uses it, it is only not stored). od-gen checks that every auto-stored entry is a
//! stored parameter. A complete-access download stores the auto-stored entries of the object
//! from its first written subindex on.
//!
//! # Power-loss safety
//!
//! Two slots (0 and 1 of the storage), each holding at most one [`record`] with a CRC-32.
//! Every store and every restore writes one complete new record, with the sequence number of
//! the newest valid record + 1, into the slot that does NOT hold the newest valid record; at
//! power-on the valid record with the highest sequence number (wrap-aware) is loaded. A write
//! interrupted at any byte can only damage the slot being written, and a damaged record fails
//! the length or CRC check, so the load falls back to the untouched newest record: the old
//! values. Once the write completed, the new record is the newest: the new values. A record is
//! applied only after it was fully validated, so a load never mixes two records.
//!
//! Restore writes a record too, instead of erasing: the new record holds the entries of the
//! other groups (copied from the newest record) and omits the restored group, whose entries
//! then load their defaults. "Restore all" writes an empty, valid record. Erasing the slots
//! instead would need two writes and a torn state between them ("slot 1 erased, slot 0 still
//! has the old record" would bring back values older than the newest).
//! Storing one group (or auto-storing one entry) likewise copies the other entries from the
//! newest record, so a store never loses what an earlier store saved.

pub mod record;

#[cfg(test)]
pub(crate) mod tests;
#[cfg(test)]
mod tests_rules;

use core::ops::RangeInclusive;

use hal::storage::{NvStorage, StorageError};

pub use crate::od::index::{RESTORE_DEFAULTS, STORE_PARAMETERS};
use crate::od::storable::{any_contains, AutoStore, EntryRange, StorageRules};
pub use crate::od::storable::{is_storable, NOT_STORED, STORED_SM_PARAMETER};
use crate::od::value::{check_range, check_value_list};
use crate::od::{AbortCode, DownloadHook};
use crate::od::{Dictionary, Profile, StoreError};

use record::{Identity, Record, RecordError, Writer};

/// Signature that triggers a store: ASCII `"save"` as a little-endian u32 (CiA 301: MSB 'e'
/// 65h, 'v' 76h, 'a' 61h, LSB 's' 73h).
pub const SIGNATURE_SAVE: u32 = u32::from_le_bytes(*b"save");
/// Signature that triggers a restore: ASCII `"load"` (MSB 'd' 64h, 'a' 61h, 'o' 6Fh, LSB 'l' 6Ch).
pub const SIGNATURE_LOAD: u32 = u32::from_le_bytes(*b"load");
/// 1010h read value bit 0: the device saves parameters on command (CiA 301 Figure "storage read
/// access structure").
pub const SAVES_ON_COMMAND: u32 = 1 << 0;
/// 1010h read value bit 1: the device saves parameters autonomously.
pub const SAVES_AUTONOMOUSLY: u32 = 1 << 1;
/// What 1011h:n reads: bit 0 = the device restores default parameters (CiA 301 §7.5.2.14).
pub const RESTORE_CAPABILITIES: u32 = 1 << 0;
/// The subindex of 1010h/1011h that stores/restores every parameter (CiA 301).
pub const ALL_PARAMETERS: u8 = 1;
/// The two storage slots the records alternate between.
pub const SLOTS: [usize; 2] = [0, 1];
/// Default capacity of one record buffer; [`ParamStore`] holds two. Enough for every built-in
/// profile with full PDO mapping objects (the vendor profiles store a few hundred parameters,
/// SDV3-E ≈ 4.5 KiB; [`max_record_len`] is checked against it in the tests). A board that
/// compiles one profile sizes its store for that profile and its flash pages.
pub const DEFAULT_RECORD_CAPACITY: usize = 8192;
/// Sequence number of the first record written to empty storage.
const FIRST_SEQUENCE: u32 = 1;

/// What 1010h:`subindex` reads (CiA 301 §7.5.2.13): saves on command, and saves autonomously
/// when the subindex's group holds an entry of one of the profile's auto-store rules (sub 1:
/// when the profile has any). The default of 1010h:n in the profile equals it (od-gen checks,
/// the generated dictionary asserts).
pub const fn store_capabilities(rules: &StorageRules, subindex: u8) -> u32 {
    let autonomous = if subindex == ALL_PARAMETERS {
        !rules.auto_store.is_empty()
    } else {
        let mut rest = rules.groups;
        let mut found = false;
        while let [group, tail @ ..] = rest {
            if group.subindex == subindex && rules.auto_stores_in(group.ranges) {
                found = true;
            }
            rest = tail;
        }
        found
    };
    if autonomous {
        SAVES_ON_COMMAND | SAVES_AUTONOMOUSLY
    } else {
        SAVES_ON_COMMAND
    }
}

/// A parameter group, selected by the subindex of 1010h/1011h (CiA 301 §7.5.2.13).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Group {
    /// Sub 1: all stored parameters.
    All,
    /// Sub 2 and above: the stored parameters in these ranges (the profile's
    /// [`StorageGroup`](crate::od::StorageGroup)).
    Ranges(&'static [EntryRange]),
}

impl Group {
    /// The group of 1010h/1011h subindex `subindex` under `rules`; `None` for sub 0 and for a
    /// subindex the profile gives no group.
    pub fn of(rules: &StorageRules, subindex: u8) -> Option<Self> {
        if subindex == ALL_PARAMETERS {
            return Some(Self::All);
        }
        rules.group(subindex).map(|g| Self::Ranges(g.ranges))
    }

    /// Whether entry `index:subindex` belongs to the group.
    pub const fn contains(self, index: u16, subindex: u8) -> bool {
        match self {
            Self::All => true,
            Self::Ranges(ranges) => any_contains(ranges, index, subindex),
        }
    }
}

/// Why parameters could not be loaded, stored or restored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ParamError {
    /// The storage has fewer than two slots.
    TooFewSlots,
    /// The storage failed.
    Storage(StorageError),
    /// The record does not fit the record buffer or a slot.
    TooLarge,
    /// The written record did not read back identically.
    Verify,
    /// The OD RAM does not hold a value of the profile (a build error).
    Dictionary(StoreError),
    /// Loading was requested outside INIT.
    NotInInit,
}

impl From<StorageError> for ParamError {
    fn from(e: StorageError) -> Self {
        Self::Storage(e)
    }
}

/// What [`ParamStore::load`] applied.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Loaded {
    /// Slot the record came from.
    pub slot: usize,
    /// Its sequence number.
    pub sequence: u32,
    /// Entries written into the OD RAM.
    pub applied: u16,
    /// Entries skipped because the OD has no such storable entry of that length (an OD layout
    /// change within one revision).
    pub skipped: u16,
}

/// What a new record does to the selected group.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Action {
    /// Store the current values.
    Store,
    /// Leave the entries out, so they load their defaults.
    Restore,
}

/// Storage that does not exist: every access fails with [`StorageError::OutOfRange`]. For
/// boards without parameter storage; 1010h/1011h then answer 0x0606_0000.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoStorage;

impl NvStorage for NoStorage {
    fn slots(&self) -> usize {
        0
    }
    fn slot_size(&self) -> usize {
        0
    }
    fn read(&mut self, _: usize, _: &mut [u8]) -> Result<(), StorageError> {
        Err(StorageError::OutOfRange)
    }
    fn write(&mut self, _: usize, _: &[u8]) -> Result<(), StorageError> {
        Err(StorageError::OutOfRange)
    }
}

/// The parameter store: the board's storage plus two record buffers of `CAP` bytes (the newest
/// record and the one being built). The board owns it (a `static` on target) and hands it to
/// [`crate::slave::SlaveCore::load_parameters`] at start-up and to
/// [`crate::slave::Slave::on_esc_event_with`] for the 1010h/1011h commands.
pub struct ParamStore<S, const CAP: usize = DEFAULT_RECORD_CAPACITY> {
    storage: S,
    bufs: [[u8; CAP]; 2],
}

impl<S: NvStorage, const CAP: usize> ParamStore<S, CAP> {
    /// A store over `storage` (slots 0 and 1 are used).
    pub const fn new(storage: S) -> Self {
        Self {
            storage,
            bufs: [[0; CAP]; 2],
        }
    }

    /// The storage.
    pub fn storage(&self) -> &S {
        &self.storage
    }

    /// The storage, mutable (fault injection in tests).
    pub fn storage_mut(&mut self) -> &mut S {
        &mut self.storage
    }

    /// Gives the storage back.
    pub fn into_storage(self) -> S {
        self.storage
    }

    /// Applies the newest valid record over the current OD RAM (which holds the defaults after
    /// [`crate::slave::Slave::new`]). `Ok(None)`: no valid record, the defaults stay.
    pub fn load(&mut self, od: &mut Dictionary<'_>) -> Result<Option<Loaded>, ParamError> {
        let identity = identity(od.profile());
        let Some((slot, sequence)) = self.newest(&identity)? else {
            return Ok(None);
        };
        let [b0, b1] = &self.bufs;
        let buf: &[u8] = if slot == 0 { b0 } else { b1 };
        let Ok(record) = Record::parse(buf, &identity) else {
            return Ok(None); // validated by `newest`; unreachable in practice
        };
        let mut loaded = Loaded {
            slot,
            sequence,
            applied: 0,
            skipped: 0,
        };
        for stored in record.entries() {
            let entry = od
                .object(stored.index)
                .and_then(|o| {
                    o.entry(stored.subindex)
                        .filter(|e| is_storable(&od.profile().storage, o, e))
                })
                .filter(|e| e.byte_len() == stored.value.len())
                // A value an SDO download would refuse is not loaded either (a record of the
                // same identity from a firmware with other ranges, or a bit error the CRC
                // missed): the entry keeps its default.
                .filter(|e| {
                    check_range(e, stored.value).is_ok()
                        && check_value_list(
                            od.profile().value_list(stored.index, stored.subindex),
                            e,
                            stored.value,
                        )
                        .is_ok()
                });
            match entry.map(|e| od.set_value(e, stored.value)) {
                Some(Ok(())) => loaded.applied = loaded.applied.saturating_add(1),
                _ => loaded.skipped = loaded.skipped.saturating_add(1),
            }
        }
        Ok(Some(loaded))
    }

    /// Stores the current values of `group` (1010h); other groups keep what the newest record
    /// holds. Returns the new record's sequence number.
    pub fn store(&mut self, od: &Dictionary<'_>, group: Group) -> Result<u32, ParamError> {
        self.write_record(od, |i, s| group.contains(i, s), Action::Store)
    }

    /// Makes `group` load its defaults from the next power-on (1011h); the current values do not
    /// change. Returns the new record's sequence number.
    pub fn restore_defaults(
        &mut self,
        od: &Dictionary<'_>,
        group: Group,
    ) -> Result<u32, ParamError> {
        self.write_record(od, |i, s| group.contains(i, s), Action::Restore)
    }

    /// The automatic storage of an SDO download to `index`, subindexes `subindexes` (one entry,
    /// or a complete access): stores the current values of those of them an auto-store rule of
    /// the profile names and does not suspend now (its `unless` test does not hold); everything
    /// else keeps what the newest record holds. `Ok(None)`: nothing to store, nothing written.
    pub fn store_downloaded(
        &mut self,
        od: &Dictionary<'_>,
        index: u16,
        subindexes: RangeInclusive<u8>,
    ) -> Result<Option<u32>, ParamError> {
        let rules = &od.profile().storage;
        let stores_now = |i: u16, s: u8| {
            i == index
                && subindexes.contains(&s)
                && rules
                    .auto_store_of(i, s)
                    .is_some_and(|a| !a.unless.is_some_and(|t| t.holds(od)))
        };
        let any = od.object(index).is_some_and(|o| {
            o.entries
                .iter()
                .any(|e| stores_now(index, e.subindex) && is_storable(rules, o, e))
        });
        if !any {
            return Ok(None);
        }
        self.write_record(od, stores_now, Action::Store).map(Some)
    }

    /// The slot and sequence number of the newest valid record; each slot's content is left in
    /// the buffer of the same number.
    fn newest(&mut self, identity: &Identity) -> Result<Option<(usize, u32)>, ParamError> {
        if self.storage.slots() < SLOTS.len() {
            return Err(ParamError::TooFewSlots);
        }
        let s0 = self.read_slot(0, identity)?;
        let s1 = self.read_slot(1, identity)?;
        Ok(match (s0, s1) {
            (Some(a), Some(b)) if record::is_newer(b, a) => Some((1, b)),
            (Some(a), _) => Some((0, a)),
            (None, Some(b)) => Some((1, b)),
            (None, None) => None,
        })
    }

    /// Reads the record in `slot` into buffer `slot`; its sequence number if it is valid.
    fn read_slot(&mut self, slot: usize, identity: &Identity) -> Result<Option<u32>, ParamError> {
        let limit = CAP.min(self.storage.slot_size());
        let Some(buf) = self.bufs.get_mut(slot) else {
            return Ok(None);
        };
        let Some(header) = buf.get_mut(..record::HEADER_LEN.min(limit)) else {
            return Ok(None);
        };
        if header.len() < record::HEADER_LEN {
            return Ok(None);
        }
        self.storage.read(slot, header)?;
        let Ok(total) = record::announced_len(header, identity) else {
            return Ok(None);
        };
        let Some(bytes) = buf.get_mut(..total).filter(|b| b.len() <= limit) else {
            return Ok(None);
        };
        self.storage.read(slot, bytes)?;
        Ok(Record::parse(bytes, identity).ok().map(|r| r.sequence()))
    }

    /// Builds the next record and writes it to the slot not holding the newest valid one, then
    /// reads it back. `selected` entries get `action`, the others keep the newest record's
    /// values.
    fn write_record(
        &mut self,
        od: &Dictionary<'_>,
        selected: impl Fn(u16, u8) -> bool,
        action: Action,
    ) -> Result<u32, ParamError> {
        let profile = od.profile();
        let identity = identity(profile);
        let newest = self.newest(&identity)?;
        let (target, sequence) = match newest {
            // The other slot; sequence numbers wrap (serial-number arithmetic, `is_newer`).
            Some((slot, seq)) => (usize::from(slot == 0), seq.wrapping_add(1)),
            None => (0, FIRST_SEQUENCE),
        };
        let [b0, b1] = &mut self.bufs;
        let (new_buf, old_buf) = if target == 0 { (b0, b1) } else { (b1, b0) };
        let old = newest.and_then(|_| Record::parse(&old_buf[..], &identity).ok());
        let len = build(
            od,
            &selected,
            action,
            old.as_ref(),
            new_buf,
            &identity,
            sequence,
        )?;
        if len > self.storage.slot_size() {
            return Err(ParamError::TooLarge);
        }
        let data = new_buf.get(..len).ok_or(ParamError::TooLarge)?;
        self.storage.write(target, data)?;
        // Read back into the other buffer (its old record is no longer needed).
        let check = old_buf.get_mut(..len).ok_or(ParamError::TooLarge)?;
        self.storage.read(target, check)?;
        if check != data {
            return Err(ParamError::Verify);
        }
        Ok(sequence)
    }
}

/// Writes the record for `action` on the `selected` entries into `buf` (the other stored
/// entries from `old`); returns its length.
fn build(
    od: &Dictionary<'_>,
    selected: &dyn Fn(u16, u8) -> bool,
    action: Action,
    old: Option<&Record<'_>>,
    buf: &mut [u8],
    identity: &Identity,
    sequence: u32,
) -> Result<usize, ParamError> {
    let capacity = |_: RecordError| ParamError::TooLarge;
    let profile = od.profile();
    let mut writer = Writer::new(buf).map_err(capacity)?;
    for object in profile.objects {
        let stored = object
            .entries
            .iter()
            .filter(|e| is_storable(&profile.storage, object, e));
        for entry in stored {
            let value = if selected(object.index, entry.subindex) {
                match action {
                    Action::Store => Some(od.value(entry).map_err(ParamError::Dictionary)?),
                    Action::Restore => None,
                }
            } else {
                old.and_then(|r| r.find(object.index, entry.subindex))
                    .filter(|v| v.len() == entry.byte_len())
            };
            if let Some(v) = value {
                writer
                    .push(object.index, entry.subindex, v)
                    .map_err(capacity)?;
            }
        }
    }
    Ok(writer.finish(identity, sequence))
}

/// Length of the record that stores every storable entry of `profile` (the largest record the
/// profile can produce; saturated at `usize::MAX`, which no storage holds).
pub fn max_record_len(profile: &Profile) -> usize {
    profile
        .objects
        .iter()
        .flat_map(|o| o.entries.iter().map(move |e| (o, e)))
        .filter(|(o, e)| is_storable(&profile.storage, o, e))
        .map(|(_, e)| record::ENTRY_HEAD_LEN.saturating_add(e.byte_len()))
        .fold(record::HEADER_LEN + record::CRC_LEN, usize::saturating_add)
}

/// The identity a profile's records carry (1018h:01..03).
pub fn identity(profile: &Profile) -> Identity {
    Identity {
        vendor_id: profile.device.vendor_id,
        product_code: profile.device.product_code,
        revision: profile.device.revision,
    }
}

/// The 1010h/1011h commands (CiA 301 §7.5.2.13/14) and the automatic storage of the profile on
/// a committed SDO download (see the module documentation).
impl<S: NvStorage, const CAP: usize> DownloadHook for ParamStore<S, CAP> {
    fn downloaded(
        &mut self,
        od: &mut Dictionary<'_>,
        index: u16,
        subindex: u8,
    ) -> Result<(), AbortCode> {
        match index {
            STORE_PARAMETERS | RESTORE_DEFAULTS => self.command(od, index, subindex),
            _ => self.auto_store(od, index, subindex..=subindex),
        }
    }

    fn downloaded_complete(
        &mut self,
        od: &mut Dictionary<'_>,
        index: u16,
        first_subindex: u8,
    ) -> Result<(), AbortCode> {
        match index {
            STORE_PARAMETERS | RESTORE_DEFAULTS => self.command(od, index, first_subindex),
            _ => self.auto_store(od, index, first_subindex..=u8::MAX),
        }
    }

    /// The 1010h/1011h commands store or restore every parameter. An automatic store reads
    /// the downloaded object (the rest of its record comes from the stored one) and the test
    /// of its rule, which may name another object.
    fn reaches_beyond_object(&self, profile: &Profile, index: u16) -> bool {
        let tested_elsewhere = |rule: &AutoStore| {
            rule.unless.is_some_and(|test| test.index != index)
                && rule.entries.iter().any(|r| r.touches_object(index))
        };
        matches!(index, STORE_PARAMETERS | RESTORE_DEFAULTS)
            || profile.storage.auto_store.iter().any(tested_elsewhere)
    }
}

impl<S: NvStorage, const CAP: usize> ParamStore<S, CAP> {
    /// A write to 1010h:`subindex` or 1011h:`subindex`: puts the capability value back, checks
    /// the profile's write condition (0x0800_0022) and the signature (0x0800_0020), runs the
    /// store or restore (0x0606_0000 if it fails).
    fn command(
        &mut self,
        od: &mut Dictionary<'_>,
        index: u16,
        subindex: u8,
    ) -> Result<(), AbortCode> {
        let rules = &od.profile().storage;
        let (signature, capabilities) = if index == STORE_PARAMETERS {
            (SIGNATURE_SAVE, store_capabilities(rules, subindex))
        } else {
            (SIGNATURE_LOAD, RESTORE_CAPABILITIES)
        };
        let Some(entry) = od.entry(index, subindex) else {
            return Ok(());
        };
        let written = od
            .value(entry)
            .ok()
            .and_then(|v| v.first_chunk::<4>().copied())
            .map(u32::from_le_bytes);
        let cap = capabilities.to_le_bytes();
        let _ = od.set_value(
            entry,
            cap.get(..entry.byte_len().min(4)).unwrap_or_default(),
        );
        let refused_now = rules
            .write_condition
            .is_some_and(|c| c.applies_to(subindex) && !c.test.holds(od));
        if refused_now {
            return Err(AbortCode::DataNotStoredDeviceState);
        }
        // A subindex without a group (od-gen gives every one a group) cannot store anything.
        let group = Group::of(rules, subindex).ok_or(AbortCode::DataNotStored)?;
        if written != Some(signature) {
            return Err(AbortCode::DataNotStored);
        }
        let result = if index == STORE_PARAMETERS {
            self.store(od, group)
        } else {
            self.restore_defaults(od, group)
        };
        result.map(drop).map_err(|_| AbortCode::HardwareError)
    }

    /// The automatic storage of a download to `index`, `subindexes` (0x0606_0000 if the store
    /// fails).
    fn auto_store(
        &mut self,
        od: &Dictionary<'_>,
        index: u16,
        subindexes: RangeInclusive<u8>,
    ) -> Result<(), AbortCode> {
        if od.profile().storage.auto_store.is_empty() {
            return Ok(());
        }
        self.store_downloaded(od, index, subindexes)
            .map(drop)
            .map_err(|_| AbortCode::HardwareError)
    }
}
