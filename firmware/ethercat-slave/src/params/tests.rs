//! Parameter storage tests: record format, power cuts at every byte, corrupt and foreign
//! records, sequence wrap-around, group store/restore, 1010h/1011h signature handling (also
//! through the CoE server).

extern crate std;

use std::boxed::Box;
use std::vec;
use std::vec::Vec;

use hal::esc::AlState;
use hal::storage::{NvStorage, StorageError};

use super::record::{self, crc32, Identity, Record, RecordError, Writer};
use super::*;
use crate::mailbox::coe::CoeServer;
use crate::od::{
    Access, DataType, Dictionary, Entry, Object, ObjectCode, PdoMappable, Profile, Value,
};
use crate::test_profiles as profiles;

// ---------------------------------------------------------------------------------------------
// Storage with power cuts
// ---------------------------------------------------------------------------------------------

/// Value of an erased byte (NOR flash).
const ERASED: u8 = 0xFF;
/// Slot size of the test storage.
const SLOT_SIZE: usize = 2048;

/// Two-slot RAM storage; a write can be cut after a number of bytes (the rest of the slot stays
/// erased, the write reports a device error as the board would never see it return).
#[derive(Clone)]
pub(crate) struct TestStorage {
    pub(crate) slots: Vec<Vec<u8>>,
    pub(super) cut_after: Option<usize>,
    pub(super) fail: bool,
    pub(super) writes: usize,
}

impl TestStorage {
    pub(crate) fn new() -> Self {
        Self {
            slots: vec![vec![ERASED; SLOT_SIZE]; 2],
            cut_after: None,
            fail: false,
            writes: 0,
        }
    }
}

impl NvStorage for TestStorage {
    fn slots(&self) -> usize {
        self.slots.len()
    }
    fn slot_size(&self) -> usize {
        SLOT_SIZE
    }
    fn read(&mut self, slot: usize, buf: &mut [u8]) -> Result<(), StorageError> {
        if self.fail {
            return Err(StorageError::Device);
        }
        let src = self.slots.get(slot).ok_or(StorageError::OutOfRange)?;
        let src = src.get(..buf.len()).ok_or(StorageError::OutOfRange)?;
        buf.copy_from_slice(src);
        Ok(())
    }
    fn write(&mut self, slot: usize, data: &[u8]) -> Result<(), StorageError> {
        if self.fail {
            return Err(StorageError::Device);
        }
        let dst = self.slots.get_mut(slot).ok_or(StorageError::OutOfRange)?;
        if data.len() > dst.len() {
            return Err(StorageError::OutOfRange);
        }
        self.writes += 1;
        dst.fill(ERASED);
        let n = self
            .cut_after
            .take()
            .map_or(data.len(), |k| k.min(data.len()));
        dst[..n].copy_from_slice(&data[..n]);
        if n < data.len() {
            return Err(StorageError::Device);
        }
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------
// Fixture profile: one storable entry per group plus entries that must never be stored
// ---------------------------------------------------------------------------------------------

pub(super) const U8: DataType = DataType::Unsigned8;
pub(super) const U16: DataType = DataType::Unsigned16;
pub(super) const U32: DataType = DataType::Unsigned32;

pub(super) const fn entry(
    subindex: u8,
    data_type: DataType,
    bits: u16,
    access: Access,
    value: Value,
) -> Entry {
    Entry {
        subindex,
        name: "",
        data_type,
        bit_len: bits,
        access,
        pdo: PdoMappable::No,
        value,
        default: &[],
        min: &[],
        max: &[],
    }
}

pub(super) const fn var(index: u16, e: &'static [Entry]) -> Object {
    Object {
        index,
        code: ObjectCode::Var,
        name: "",
        entries: e,
    }
}

pub(super) const fn array(index: u16, e: &'static [Entry]) -> Object {
    Object {
        index,
        code: ObjectCode::Array,
        name: "",
        entries: e,
    }
}

pub(super) const CMD: [Entry; 5] = [
    entry(0, U8, 8, Access::RO, Value::Const(&[4])),
    entry(1, U32, 32, Access::RW, Value::Ram(0)),
    entry(2, U32, 32, Access::RW, Value::Ram(4)),
    entry(3, U32, 32, Access::RW, Value::Ram(8)),
    entry(4, U32, 32, Access::RW, Value::Ram(12)),
];
pub(super) const RESTORE_CMD: [Entry; 5] = [
    entry(0, U8, 8, Access::RO, Value::Const(&[4])),
    entry(1, U32, 32, Access::RW, Value::Ram(16)),
    entry(2, U32, 32, Access::RW, Value::Ram(20)),
    entry(3, U32, 32, Access::RW, Value::Ram(24)),
    entry(4, U32, 32, Access::RW, Value::Ram(28)),
];
/// 1600h: communication parameter (PDO mapping), stored.
const MAPPING: [Entry; 2] = [
    entry(0, U8, 8, Access::RW_PREOP, Value::Ram(32)),
    entry(1, U32, 32, Access::RW_PREOP, Value::Ram(33)),
];
/// 1C32h:01: maintained by the stack, never stored.
const SM_PARAMETER: [Entry; 2] = [
    entry(0, U8, 8, Access::RO, Value::Const(&[1])),
    entry(1, U16, 16, Access::RW_PREOP, Value::Ram(37)),
];
/// 2000h: manufacturer parameter, stored.
const MANUFACTURER: [Entry; 1] = [entry(0, U32, 32, Access::RW, Value::Ram(39))];
/// 2001h: read-only RAM value, never stored.
const READ_ONLY: [Entry; 1] = [entry(0, U16, 16, Access::RO, Value::Ram(43))];
/// 6040h: RxPDO-mappable process data, never stored.
const PROCESS_DATA: [Entry; 1] = [Entry {
    pdo: PdoMappable::Rx,
    ..entry(0, U16, 16, Access::RW, Value::Ram(45))
}];
/// 6065h: application parameter, stored.
const APPLICATION: [Entry; 1] = [entry(0, U32, 32, Access::RW, Value::Ram(47))];
const RAM_SIZE: usize = 51;

static OBJECTS: [Object; 9] = [
    array(STORE_PARAMETERS, &CMD),
    array(RESTORE_DEFAULTS, &RESTORE_CMD),
    Object {
        code: ObjectCode::Record,
        ..var(0x1600, &MAPPING)
    },
    Object {
        code: ObjectCode::Record,
        ..var(0x1C32, &SM_PARAMETER)
    },
    var(0x2000, &MANUFACTURER),
    var(0x2001, &READ_ONLY),
    var(0x6040, &PROCESS_DATA),
    var(0x6065, &APPLICATION),
    var(0x6502, &[]),
];

/// Defaults: 1010h/1011h read 1, 1600h = 1 entry 0x6040_0010, everything else 0 / 0x11.
static DEFAULTS: [u8; RAM_SIZE] = {
    let mut d = [0u8; RAM_SIZE];
    let mut i = 0;
    while i < 8 {
        d[i * 4] = 1;
        i += 1;
    }
    d[32] = 1;
    d[33] = 0x10;
    d[35] = 0x40;
    d[36] = 0x60;
    d[39] = 0x11;
    d[47] = 0x11;
    d
};

/// The fixture with revision `revision` (identity check), everything else from the standard
/// profile so that new `DeviceInfo`/`Profile` fields need no change here.
#[allow(clippy::needless_update)]
fn fixture(revision: u32) -> &'static Profile {
    let base = &profiles::standard::PROFILE;
    Box::leak(Box::new(Profile {
        device: crate::od::DeviceInfo {
            revision,
            ..base.device
        },
        objects: &OBJECTS,
        defaults: &DEFAULTS,
        value_lists: &[],
        ..*base
    }))
}

/// The group of 1010h/1011h subindex `subindex` in the standard profile (and the fixture, which
/// takes its storage rules).
fn group(subindex: u8) -> Group {
    Group::of(&profiles::standard::PROFILE.storage, subindex).unwrap()
}

/// A device: profile + OD RAM at defaults.
pub(super) struct Device {
    profile: &'static Profile,
    ram: Vec<u8>,
}

impl Device {
    pub(super) fn new(profile: &'static Profile) -> Self {
        let mut ram = vec![0u8; profile.ram_size()];
        Dictionary::new(profile, &mut ram).load_defaults();
        Self { profile, ram }
    }
    pub(super) fn od(&mut self) -> Dictionary<'_> {
        Dictionary::new(self.profile, &mut self.ram)
    }
    pub(super) fn set(&mut self, index: u16, subindex: u8, value: &[u8]) {
        let mut od = self.od();
        let e = od.entry(index, subindex).unwrap();
        od.set_value(e, value).unwrap();
    }
    pub(super) fn get(&mut self, index: u16, subindex: u8) -> u32 {
        self.od().read_u32(index, subindex).unwrap()
    }
    /// The values of every entry of the profile, in OD order (what a power-on shows).
    pub(super) fn snapshot(&mut self) -> Vec<u8> {
        self.ram.clone()
    }
    /// Powers on over `storage`: defaults, then the stored parameters.
    pub(super) fn power_on(
        profile: &'static Profile,
        storage: &TestStorage,
    ) -> (Self, Option<Loaded>) {
        let mut dev = Self::new(profile);
        let mut store: ParamStore<TestStorage> = ParamStore::new(storage.clone());
        let loaded = store.load(&mut dev.od()).unwrap();
        (dev, loaded)
    }
}

/// Sets the three storable parameters to values derived from `tag`.
fn set_all(dev: &mut Device, tag: u8) {
    dev.set(0x1600, 1, &[tag, 0, 0x40, 0x60]);
    dev.set(0x2000, 0, &[tag, tag, 0, 0]);
    dev.set(0x6065, 0, &[0, tag, tag, 0]);
    // Never stored: changed here, must come back at defaults.
    dev.set(0x1C32, 1, &[tag, 0]);
    dev.set(0x2001, 0, &[tag, 0]);
    dev.set(0x6040, 0, &[tag, 0]);
}

/// The snapshot a power-on shows after storing the values of `tag`.
fn expected_after_store(profile: &'static Profile, tag: u8) -> Vec<u8> {
    let mut dev = Device::new(profile);
    dev.set(0x1600, 1, &[tag, 0, 0x40, 0x60]);
    dev.set(0x2000, 0, &[tag, tag, 0, 0]);
    dev.set(0x6065, 0, &[0, tag, tag, 0]);
    dev.snapshot()
}

// ---------------------------------------------------------------------------------------------
// Record format
// ---------------------------------------------------------------------------------------------

#[test]
fn crc32_is_the_ieee_802_3_crc() {
    // The standard check value of CRC-32 (zlib, Ethernet FCS).
    assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
    assert_eq!(crc32(b""), 0);
}

#[test]
fn signatures_are_the_cia_301_ascii_values() {
    assert_eq!(SIGNATURE_SAVE, 0x6576_6173);
    assert_eq!(SIGNATURE_LOAD, 0x6461_6F6C);
    assert_eq!(store_capabilities(&StorageRules::NONE, ALL_PARAMETERS), 1);
    assert_eq!(RESTORE_CAPABILITIES, 1);
}

const ID: Identity = Identity {
    vendor_id: 0x1234,
    product_code: 0x402,
    revision: 7,
};

#[test]
fn record_round_trip_and_layout() {
    let mut buf = [0u8; 64];
    let mut w = Writer::new(&mut buf).unwrap();
    w.push(0x2000, 0, &[1, 2, 3, 4]).unwrap();
    w.push(0x1600, 1, &[9]).unwrap();
    let len = w.finish(&ID, 0x0102_0304);
    assert_eq!(
        len,
        record::HEADER_LEN + 2 * record::ENTRY_HEAD_LEN + 5 + record::CRC_LEN
    );
    assert_eq!(&buf[0..4], b"OCSP");
    assert_eq!(&buf[4..6], &[1, 0]); // format version
    assert_eq!(&buf[6..8], &[2, 0]); // entries
    assert_eq!(&buf[8..12], &0x1234u32.to_le_bytes());
    assert_eq!(&buf[20..24], &[4, 3, 2, 1]); // sequence
    assert_eq!(&buf[24..28], &[15, 0, 0, 0]); // payload length
    assert_eq!(&buf[28..37], &[0x00, 0x20, 0, 4, 0, 1, 2, 3, 4]);
    let crc = crc32(&buf[..len - 4]);
    assert_eq!(&buf[len - 4..len], &crc.to_le_bytes());
    let r = Record::parse(&buf, &ID).unwrap();
    assert_eq!(r.sequence(), 0x0102_0304);
    assert_eq!(r.len(), 2);
    assert_eq!(r.find(0x2000, 0), Some(&[1, 2, 3, 4][..]));
    assert_eq!(r.find(0x1600, 1), Some(&[9][..]));
    assert_eq!(r.find(0x1600, 2), None);
}

#[test]
fn every_single_byte_corruption_and_truncation_is_rejected() {
    let mut buf = [0u8; 64];
    let mut w = Writer::new(&mut buf).unwrap();
    w.push(0x2000, 0, &[1, 2, 3, 4]).unwrap();
    let len = w.finish(&ID, 5);
    for i in 0..len {
        for flip in [0x01u8, 0x80, 0xFF] {
            let mut bad = buf;
            bad[i] ^= flip;
            assert!(
                Record::parse(&bad[..len], &ID).is_err(),
                "byte {i} ^ {flip:#x}"
            );
        }
    }
    for k in 0..len {
        assert_eq!(
            Record::parse(&buf[..k], &ID).unwrap_err(),
            RecordError::Truncated
        );
    }
}

#[test]
fn a_record_of_another_identity_or_version_is_rejected() {
    let mut buf = [0u8; 64];
    let len = Writer::new(&mut buf).unwrap().finish(&ID, 1);
    for other in [
        Identity { vendor_id: 1, ..ID },
        Identity {
            product_code: 1,
            ..ID
        },
        Identity { revision: 8, ..ID },
    ] {
        assert_eq!(
            Record::parse(&buf[..len], &other).unwrap_err(),
            RecordError::Identity
        );
    }
    buf[4] = 2; // version 2
    assert_eq!(
        Record::parse(&buf[..len], &ID).unwrap_err(),
        RecordError::Version
    );
    assert_eq!(
        Record::parse(&[ERASED; 64], &ID).unwrap_err(),
        RecordError::Magic
    );
}

#[test]
fn a_crc_valid_record_with_a_bad_structure_is_rejected() {
    // Hand-made record whose only entry announces more bytes than the payload holds.
    let mut buf = [0u8; 64];
    let mut w = Writer::new(&mut buf).unwrap();
    w.push(0x2000, 0, &[1, 2]).unwrap();
    let len = w.finish(&ID, 1);
    buf[31] = 3; // entry length 2 → 3
    let crc = crc32(&buf[..len - 4]);
    buf[len - 4..len].copy_from_slice(&crc.to_le_bytes());
    assert_eq!(
        Record::parse(&buf[..len], &ID).unwrap_err(),
        RecordError::Structure
    );
    // Entry count in the header differs from the entries.
    let mut buf = [0u8; 64];
    let len = Writer::new(&mut buf).unwrap().finish(&ID, 1);
    buf[6] = 1;
    let crc = crc32(&buf[..len - 4]);
    buf[len - 4..len].copy_from_slice(&crc.to_le_bytes());
    assert_eq!(
        Record::parse(&buf[..len], &ID).unwrap_err(),
        RecordError::Structure
    );
}

#[test]
fn writer_refuses_what_does_not_fit() {
    let mut small = [0u8; record::HEADER_LEN + record::CRC_LEN - 1];
    assert!(Writer::new(&mut small).is_err());
    let mut buf = [0u8; record::HEADER_LEN + record::CRC_LEN + 6];
    let mut w = Writer::new(&mut buf).unwrap();
    assert_eq!(w.push(1, 0, &[0; 2]), Err(RecordError::Capacity));
    w.push(1, 0, &[0; 1]).unwrap();
}

#[test]
fn sequence_comparison_wraps() {
    assert!(record::is_newer(1, 0));
    assert!(record::is_newer(0, 0xFFFF_FFFF));
    assert!(record::is_newer(5, 0xFFFF_FFF0));
    assert!(!record::is_newer(0xFFFF_FFFF, 0));
    assert!(!record::is_newer(7, 7));
}

// ---------------------------------------------------------------------------------------------
// Store and load
// ---------------------------------------------------------------------------------------------

#[test]
fn empty_storage_loads_nothing_and_keeps_the_defaults() {
    let profile = fixture(1);
    let (mut dev, loaded) = Device::power_on(profile, &TestStorage::new());
    assert_eq!(loaded, None);
    assert_eq!(dev.snapshot(), Device::new(profile).snapshot());
}

#[test]
fn a_stored_value_outside_its_range_is_not_loaded() {
    // The standard profile's 605Ah (quick stop option code) is stored, INT16 in 0..=8; 6065h
    // (following error window) is stored and has no maximum.
    let profile = &profiles::standard::PROFILE;
    let id = identity(profile);
    let mut storage = TestStorage::new();
    let mut buf = vec![0u8; 256];
    let mut w = Writer::new(&mut buf).unwrap();
    w.push(0x605A, 0, &9i16.to_le_bytes()).unwrap();
    w.push(0x6065, 0, &1234u32.to_le_bytes()).unwrap();
    let len = w.finish(&id, 1);
    storage.write(0, &buf[..len]).unwrap();
    let (mut dev, loaded) = Device::power_on(profile, &storage);
    let loaded = loaded.unwrap();
    assert_eq!((loaded.applied, loaded.skipped), (1, 1));
    assert_eq!(dev.get(0x6065, 0), 1234);
    assert_eq!(dev.get(0x605A, 0), Device::new(profile).get(0x605A, 0));
}

#[test]
fn store_then_power_on_loads_exactly_the_storable_entries() {
    let profile = fixture(1);
    let mut store: ParamStore<TestStorage> = ParamStore::new(TestStorage::new());
    let mut dev = Device::new(profile);
    set_all(&mut dev, 0x5A);
    assert_eq!(store.store(&dev.od(), Group::All), Ok(FIRST_SEQUENCE));
    let (mut after, loaded) = Device::power_on(profile, store.storage());
    assert_eq!(
        loaded,
        Some(Loaded {
            slot: 0,
            sequence: 1,
            applied: 4, // 1600:00, 1600:01, 2000, 6065
            skipped: 0,
        })
    );
    assert_eq!(after.snapshot(), expected_after_store(profile, 0x5A));
    assert_eq!(after.get(0x6040, 0), 0); // process data not stored
    assert_eq!(after.get(0x1C32, 1), 0); // SM parameter not stored
    assert_eq!(after.get(0x2001, 0), 0); // read-only not stored
}

#[test]
fn stores_alternate_slots_with_increasing_sequence() {
    let profile = fixture(1);
    let mut store: ParamStore<TestStorage> = ParamStore::new(TestStorage::new());
    let mut dev = Device::new(profile);
    for (i, tag) in [1u8, 2, 3, 4].into_iter().enumerate() {
        set_all(&mut dev, tag);
        assert_eq!(store.store(&dev.od(), Group::All), Ok(i as u32 + 1));
        let (mut after, loaded) = Device::power_on(profile, store.storage());
        let loaded = loaded.unwrap();
        assert_eq!((loaded.slot, loaded.sequence), (i % 2, i as u32 + 1));
        assert_eq!(after.snapshot(), expected_after_store(profile, tag));
    }
}

/// Power-on view after storing `tags` one after the other (all complete).
fn storage_after(profile: &'static Profile, tags: &[u8]) -> TestStorage {
    let mut store: ParamStore<TestStorage> = ParamStore::new(TestStorage::new());
    let mut dev = Device::new(profile);
    for &tag in tags {
        set_all(&mut dev, tag);
        store.store(&dev.od(), Group::All).unwrap();
    }
    store.into_storage()
}

/// Cuts the power after every byte `k` of one more store (or restore) and checks that the
/// power-on shows the complete old or the complete new values, and the new ones once the
/// write completed.
fn sweep_power_cuts(prior: &[u8], restore: bool) {
    let profile = fixture(1);
    let before = storage_after(profile, prior);
    let old = match prior.last() {
        Some(&tag) => expected_after_store(profile, tag),
        None => Device::new(profile).snapshot(),
    };
    let new = if restore {
        Device::new(profile).snapshot()
    } else {
        expected_after_store(profile, 0xC3)
    };
    // The length of the record the operation writes.
    let full = {
        let mut store: ParamStore<TestStorage> = ParamStore::new(before.clone());
        let mut dev = Device::new(profile);
        set_all(&mut dev, 0xC3);
        if restore {
            store.restore_defaults(&dev.od(), Group::All).unwrap();
        } else {
            store.store(&dev.od(), Group::All).unwrap();
        }
        let target = prior.len() % 2;
        let r = Record::parse(&store.storage().slots[target], &super::identity(profile)).unwrap();
        record::HEADER_LEN + r.entries().map(|e| 5 + e.value.len()).sum::<usize>() + 4
    };
    let mut saw_old = 0;
    let mut saw_new = 0;
    for k in 0..=full {
        let mut storage = before.clone();
        storage.cut_after = Some(k);
        let mut store: ParamStore<TestStorage> = ParamStore::new(storage);
        let mut dev = Device::new(profile);
        set_all(&mut dev, 0xC3);
        let result = if restore {
            store.restore_defaults(&dev.od(), Group::All)
        } else {
            store.store(&dev.od(), Group::All)
        };
        assert_eq!(result.is_ok(), k == full, "cut after {k} of {full}");
        // Power-on over what the cut left.
        let (mut after, _) = Device::power_on(profile, store.storage());
        let seen = after.snapshot();
        if seen == old {
            saw_old += 1;
        } else if seen == new {
            saw_new += 1;
        } else {
            panic!("cut after {k} of {full} bytes: a mix of old and new values");
        }
        if k == full {
            assert_eq!(seen, new, "complete write must load the new values");
        }
        // A later store still works and goes to a slot that does not hold the newest record.
        let mut store: ParamStore<TestStorage> = ParamStore::new(store.into_storage());
        set_all(&mut dev, 0x77);
        store.store(&dev.od(), Group::All).unwrap();
        let (mut later, _) = Device::power_on(profile, store.storage());
        assert_eq!(later.snapshot(), expected_after_store(profile, 0x77));
    }
    // Every incomplete write showed the old values, except a prefix that already equals the
    // complete record (a CRC ending in erased-looking 0xFF bytes).
    assert!(
        saw_old + 4 >= full,
        "{saw_old} of {full} cuts kept the old values"
    );
    assert!(saw_new >= 1);
}

#[test]
fn power_cut_at_every_byte_of_the_first_store() {
    sweep_power_cuts(&[], false);
}

#[test]
fn power_cut_at_every_byte_of_a_store_into_slot_1() {
    sweep_power_cuts(&[0x11], false);
}

#[test]
fn power_cut_at_every_byte_of_a_store_into_slot_0() {
    sweep_power_cuts(&[0x11, 0x22], false);
}

#[test]
fn power_cut_at_every_byte_of_a_restore() {
    sweep_power_cuts(&[0x11], true);
    sweep_power_cuts(&[0x11, 0x22], true);
}

#[test]
fn a_corrupt_newest_record_falls_back_to_the_older_one() {
    let profile = fixture(1);
    let mut storage = storage_after(profile, &[0x11, 0x22]);
    // Newest (seq 2) is in slot 1: flip a payload byte.
    storage.slots[1][record::HEADER_LEN + 6] ^= 0x04;
    let (mut dev, loaded) = Device::power_on(profile, &storage);
    assert_eq!(loaded.map(|l| (l.slot, l.sequence)), Some((0, 1)));
    assert_eq!(dev.snapshot(), expected_after_store(profile, 0x11));
    // The next store overwrites the corrupt slot, not the good one.
    let mut store: ParamStore<TestStorage> = ParamStore::new(storage);
    let mut d = Device::new(profile);
    set_all(&mut d, 0x33);
    assert_eq!(store.store(&d.od(), Group::All), Ok(2));
    assert_eq!(store.storage().slots[0][20], 1); // slot 0 still holds seq 1
                                                 // Both corrupt: defaults.
    let mut storage = storage_after(profile, &[0x11, 0x22]);
    storage.slots[0][3] ^= 1;
    let len = storage.slots[1].iter().rposition(|&b| b != ERASED).unwrap();
    storage.slots[1][len] ^= 1; // CRC byte
    let (mut dev, loaded) = Device::power_on(profile, &storage);
    assert_eq!(loaded, None);
    assert_eq!(dev.snapshot(), Device::new(profile).snapshot());
}

#[test]
fn a_record_of_another_revision_is_never_loaded() {
    let storage = storage_after(fixture(1), &[0x11]);
    let other = fixture(2);
    let (mut dev, loaded) = Device::power_on(other, &storage);
    assert_eq!(loaded, None);
    assert_eq!(dev.snapshot(), Device::new(other).snapshot());
}

#[test]
fn entries_the_od_no_longer_has_are_skipped() {
    let profile = fixture(1);
    let id = super::identity(profile);
    let mut storage = TestStorage::new();
    let mut buf = [0u8; 128];
    let mut w = Writer::new(&mut buf).unwrap();
    w.push(0x2000, 0, &[1, 2, 3, 4]).unwrap(); // ok
    w.push(0x2000, 1, &[1, 2, 3, 4]).unwrap(); // no such subindex
    w.push(0x6065, 0, &[1, 2]).unwrap(); // wrong length
    w.push(0x6040, 0, &[1, 2]).unwrap(); // process data: not storable
    w.push(0x1010, 1, &[0x73, 0x61, 0x76, 0x65]).unwrap(); // command object: not storable
    w.push(0x3000, 0, &[1]).unwrap(); // no such object
    let len = w.finish(&id, 9);
    storage.slots[1][..len].copy_from_slice(&buf[..len]);
    let (mut dev, loaded) = Device::power_on(profile, &storage);
    assert_eq!(
        loaded,
        Some(Loaded {
            slot: 1,
            sequence: 9,
            applied: 1,
            skipped: 5
        })
    );
    assert_eq!(dev.get(0x2000, 0), 0x0403_0201);
    assert_eq!(dev.get(0x6065, 0), 0x11);
    assert_eq!(dev.get(0x1010, 1), 1);
}

#[test]
fn sequence_wraps_around() {
    let profile = fixture(1);
    let id = super::identity(profile);
    let mut storage = TestStorage::new();
    for (slot, seq, v) in [(0usize, 0xFFFF_FFFFu32, 0xAAu8), (1, 0, 0xBB)] {
        let mut buf = [0u8; 64];
        let mut w = Writer::new(&mut buf).unwrap();
        w.push(0x2000, 0, &[v, 0, 0, 0]).unwrap();
        let len = w.finish(&id, seq);
        storage.slots[slot][..len].copy_from_slice(&buf[..len]);
    }
    let (mut dev, loaded) = Device::power_on(profile, &storage);
    assert_eq!(loaded.map(|l| (l.slot, l.sequence)), Some((1, 0)));
    assert_eq!(dev.get(0x2000, 0), 0xBB);
    // The next store goes to slot 0 with sequence 1 and wins.
    let mut store: ParamStore<TestStorage> = ParamStore::new(storage);
    dev.set(0x2000, 0, &[0xCC, 0, 0, 0]);
    assert_eq!(store.store(&dev.od(), Group::All), Ok(1));
    let (mut after, loaded) = Device::power_on(profile, store.storage());
    assert_eq!(loaded.map(|l| (l.slot, l.sequence)), Some((0, 1)));
    assert_eq!(after.get(0x2000, 0), 0xCC);
}

// ---------------------------------------------------------------------------------------------
// Groups
// ---------------------------------------------------------------------------------------------

#[test]
fn group_ranges_follow_cia_301() {
    // The standard profile gives no [[storage.group]]: od-gen's CiA 301 scopes.
    let rules = &profiles::standard::PROFILE.storage;
    assert_eq!(Group::of(rules, 0), None);
    assert_eq!(Group::of(rules, 5), None);
    assert_eq!(Group::of(rules, ALL_PARAMETERS), Some(Group::All));
    assert!(group(2).contains(0x1000, 1) && group(2).contains(0x1FFF, 0));
    assert!(!group(2).contains(0x2000, 0));
    assert!(group(4).contains(0x2000, 0) && group(4).contains(0x5FFF, 0));
    assert!(group(3).contains(0x6000, 0) && group(3).contains(0x9FFF, 0));
    assert!(!group(3).contains(0xA000, 0));
    assert!(Group::All.contains(0xA000, 0));
}

#[test]
fn storing_one_group_keeps_the_other_groups_stored_values() {
    let profile = fixture(1);
    let mut store: ParamStore<TestStorage> = ParamStore::new(TestStorage::new());
    let mut dev = Device::new(profile);
    set_all(&mut dev, 0x11);
    store.store(&dev.od(), Group::All).unwrap();
    set_all(&mut dev, 0x22);
    store.store(&dev.od(), group(4)).unwrap();
    let (mut after, _) = Device::power_on(profile, store.storage());
    assert_eq!(after.get(0x2000, 0), 0x2222);
    assert_eq!(after.get(0x6065, 0), 0x0011_1100);
    assert_eq!(after.get(0x1600, 1), 0x6040_0011);
    store.store(&dev.od(), group(3)).unwrap();
    store.store(&dev.od(), group(2)).unwrap();
    let (mut after, _) = Device::power_on(profile, store.storage());
    assert_eq!(after.snapshot(), expected_after_store(profile, 0x22));
}

#[test]
fn restore_is_effective_at_the_next_power_on_only() {
    let profile = fixture(1);
    let mut store: ParamStore<TestStorage> = ParamStore::new(TestStorage::new());
    let mut dev = Device::new(profile);
    set_all(&mut dev, 0x11);
    store.store(&dev.od(), Group::All).unwrap();
    let before = dev.snapshot();
    store.restore_defaults(&dev.od(), group(2)).unwrap();
    assert_eq!(dev.snapshot(), before, "current values unchanged");
    let (mut after, loaded) = Device::power_on(profile, store.storage());
    assert_eq!(loaded.map(|l| l.applied), Some(2));
    assert_eq!(after.get(0x1600, 1), 0x6040_0010); // default
    assert_eq!(after.get(0x2000, 0), 0x1111);
    store.restore_defaults(&dev.od(), Group::All).unwrap();
    let (mut after, loaded) = Device::power_on(profile, store.storage());
    assert_eq!(loaded.map(|l| (l.applied, l.sequence)), Some((0, 3)));
    assert_eq!(after.snapshot(), Device::new(profile).snapshot());
}

// ---------------------------------------------------------------------------------------------
// Failures
// ---------------------------------------------------------------------------------------------

#[test]
fn storage_failures_are_reported_not_panicked() {
    let profile = fixture(1);
    let mut dev = Device::new(profile);
    let mut none: ParamStore<NoStorage, 0> = ParamStore::new(NoStorage);
    assert_eq!(
        none.store(&dev.od(), Group::All),
        Err(ParamError::TooFewSlots)
    );
    assert_eq!(none.load(&mut dev.od()), Err(ParamError::TooFewSlots));
    let mut broken = TestStorage::new();
    broken.fail = true;
    let mut store: ParamStore<TestStorage> = ParamStore::new(broken);
    assert_eq!(
        store.store(&dev.od(), Group::All),
        Err(ParamError::Storage(StorageError::Device))
    );
    // Record buffers too small for the record.
    let mut tiny: ParamStore<TestStorage, 40> = ParamStore::new(TestStorage::new());
    assert_eq!(tiny.store(&dev.od(), Group::All), Err(ParamError::TooLarge));
    assert_eq!(tiny.storage().writes, 0);
}

#[test]
fn garbage_in_both_slots_never_panics() {
    let profile = fixture(1);
    let id = super::identity(profile);
    let mut seed = 0x1234_5678u32;
    for _ in 0..200 {
        let mut storage = TestStorage::new();
        for slot in 0..2 {
            for b in storage.slots[slot].iter_mut().take(200) {
                seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                *b = (seed >> 24) as u8;
            }
            // A valid-looking header with a huge or random length.
            storage.slots[slot][..4].copy_from_slice(b"OCSP");
            storage.slots[slot][4..6].copy_from_slice(&1u16.to_le_bytes());
            storage.slots[slot][8..12].copy_from_slice(&id.vendor_id.to_le_bytes());
            storage.slots[slot][12..16].copy_from_slice(&id.product_code.to_le_bytes());
            storage.slots[slot][16..20].copy_from_slice(&id.revision.to_le_bytes());
        }
        let (mut dev, loaded) = Device::power_on(profile, &storage);
        assert_eq!(loaded, None);
        assert_eq!(dev.snapshot(), Device::new(profile).snapshot());
    }
}

#[test]
fn every_built_in_profile_fits_the_default_record_buffer() {
    for p in profiles::ALL {
        let n = max_record_len(p);
        assert!(
            n <= DEFAULT_RECORD_CAPACITY,
            "{}: {n} bytes",
            p.device.profile
        );
    }
    // The standard profile stores its PDO configuration and the user parameter 2F00h.
    let p = &profiles::standard::PROFILE;
    let stored = |index: u16| {
        p.object(index)
            .is_some_and(|o| o.entries.iter().any(|e| is_storable(&p.storage, o, e)))
    };
    for index in [0x1600, 0x1A00, 0x1C12, 0x1C13, 0x2F00] {
        assert!(stored(index), "{index:#06x}");
    }
    for index in [0x1010, 0x1011, 0x1C32, 0x1C33, 0x6040, 0x607A, 0x6060] {
        assert!(!stored(index), "{index:#06x}");
    }
}

#[test]
fn standard_profile_objects_have_the_cia_301_layout() {
    let p = &profiles::standard::PROFILE;
    for (index, capabilities) in [
        (STORE_PARAMETERS, SAVES_ON_COMMAND),
        (RESTORE_DEFAULTS, RESTORE_CAPABILITIES),
    ] {
        let o = p.object(index).unwrap();
        assert_eq!(o.code, ObjectCode::Array);
        assert_eq!(o.entries[0].value, Value::Const(&[4]));
        for sub in 1..=4 {
            let e = o.entry(sub).unwrap();
            assert_eq!(e.data_type, DataType::Unsigned32);
            assert_eq!(e.access, Access::RW);
            assert_eq!(e.default, &capabilities.to_le_bytes());
        }
    }
}

// ---------------------------------------------------------------------------------------------
// 1010h/1011h through the download hook and the CoE server
// ---------------------------------------------------------------------------------------------

/// Writes `value` to `index:subindex` as the SDO server would, then runs the hook.
pub(super) fn download(
    store: &mut impl DownloadHook,
    dev: &mut Device,
    index: u16,
    subindex: u8,
    value: u32,
) -> Result<(), AbortCode> {
    dev.set(index, subindex, &value.to_le_bytes());
    store.downloaded(&mut dev.od(), index, subindex)
}

#[test]
fn wrong_signature_is_refused_with_0x08000020_and_stores_nothing() {
    let profile = fixture(1);
    let mut store: ParamStore<TestStorage> = ParamStore::new(TestStorage::new());
    let mut dev = Device::new(profile);
    for (index, wrong) in [
        (STORE_PARAMETERS, SIGNATURE_LOAD),
        (STORE_PARAMETERS, 0x6576_6174),
        (STORE_PARAMETERS, SIGNATURE_SAVE.swap_bytes()),
        (RESTORE_DEFAULTS, SIGNATURE_SAVE),
        (RESTORE_DEFAULTS, 0),
    ] {
        for sub in 1..=4 {
            let r = download(&mut store, &mut dev, index, sub, wrong);
            assert_eq!(r, Err(AbortCode::DataNotStored));
            assert_eq!(AbortCode::DataNotStored.code(), 0x0800_0020);
            assert_eq!(dev.get(index, sub), 1, "reads the capabilities again");
        }
    }
    assert_eq!(store.storage().writes, 0);
}

#[test]
fn save_and_load_signatures_store_and_restore() {
    let profile = fixture(1);
    let mut store: ParamStore<TestStorage> = ParamStore::new(TestStorage::new());
    let mut dev = Device::new(profile);
    set_all(&mut dev, 0x42);
    assert_eq!(
        download(&mut store, &mut dev, STORE_PARAMETERS, 1, SIGNATURE_SAVE),
        Ok(())
    );
    assert_eq!(dev.get(STORE_PARAMETERS, 1), SAVES_ON_COMMAND);
    let (mut after, _) = Device::power_on(profile, store.storage());
    assert_eq!(after.snapshot(), expected_after_store(profile, 0x42));
    assert_eq!(
        download(&mut store, &mut dev, RESTORE_DEFAULTS, 1, SIGNATURE_LOAD),
        Ok(())
    );
    assert_eq!(dev.get(RESTORE_DEFAULTS, 1), RESTORE_CAPABILITIES);
    assert_eq!(
        dev.get(0x2000, 0),
        0x4242,
        "current values unchanged until power-on"
    );
    let (mut after, _) = Device::power_on(profile, store.storage());
    assert_eq!(after.snapshot(), Device::new(profile).snapshot());
    // Other entries pass untouched.
    assert_eq!(download(&mut store, &mut dev, 0x2000, 0, 5), Ok(()));
    assert_eq!(dev.get(0x2000, 0), 5);
}

#[test]
fn storage_failure_answers_0x06060000() {
    let profile = fixture(1);
    let mut dev = Device::new(profile);
    let mut none: ParamStore<NoStorage, 0> = ParamStore::new(NoStorage);
    let r = download(&mut none, &mut dev, STORE_PARAMETERS, 1, SIGNATURE_SAVE);
    assert_eq!(r, Err(AbortCode::HardwareError));
    assert_eq!(AbortCode::HardwareError.code(), 0x0606_0000);
    let mut cut = TestStorage::new();
    cut.cut_after = Some(10);
    let mut store: ParamStore<TestStorage> = ParamStore::new(cut);
    let r = download(&mut store, &mut dev, RESTORE_DEFAULTS, 2, SIGNATURE_LOAD);
    assert_eq!(r, Err(AbortCode::HardwareError));
}

/// One expedited SDO download of `value` to `index:subindex` through the CoE server with the
/// parameter hook; returns the CoE response.
fn sdo_download(
    coe: &mut CoeServer,
    store: &mut ParamStore<TestStorage>,
    dev: &mut Device,
    index: u16,
    subindex: u8,
    value: u32,
) -> Vec<u8> {
    let [i0, i1] = index.to_le_bytes();
    let [v0, v1, v2, v3] = value.to_le_bytes();
    // CoE header (SDO request), download initiate expedited, 4 bytes (0x23).
    let request = [0x00, 0x20, 0x23, i0, i1, subindex, v0, v1, v2, v3];
    let mut response = [0u8; 64];
    let n = coe
        .handle_with(
            &mut dev.od(),
            AlState::PreOp,
            &request,
            &mut response,
            store,
        )
        .unwrap();
    response[..n].to_vec()
}

#[test]
fn sdo_download_of_signatures_through_the_coe_server() {
    let profile = fixture(1);
    let mut coe = CoeServer::new();
    let mut store: ParamStore<TestStorage> = ParamStore::new(TestStorage::new());
    let mut dev = Device::new(profile);
    // Wrong signature: abort frame 0x80, 1010h:01, code 0x08000020 (ETG.1000.6 §5.6.2.7).
    let r = sdo_download(&mut coe, &mut store, &mut dev, 0x1010, 1, 0x1234_5678);
    assert_eq!(
        r,
        [0x00, 0x20, 0x80, 0x10, 0x10, 0x01, 0x20, 0x00, 0x00, 0x08]
    );
    assert_eq!(store.storage().writes, 0);
    // "save": download response.
    let r = sdo_download(&mut coe, &mut store, &mut dev, 0x1010, 1, SIGNATURE_SAVE);
    assert_eq!(r, [0x00, 0x30, 0x60, 0x10, 0x10, 0x01, 0, 0, 0, 0]);
    assert_eq!(store.storage().writes, 1);
    // "load" to 1011h:03.
    let r = sdo_download(&mut coe, &mut store, &mut dev, 0x1011, 3, SIGNATURE_LOAD);
    assert_eq!(r, [0x00, 0x30, 0x60, 0x11, 0x10, 0x03, 0, 0, 0, 0]);
    // A hardware failure.
    store.storage_mut().fail = true;
    let r = sdo_download(&mut coe, &mut store, &mut dev, 0x1010, 4, SIGNATURE_SAVE);
    assert_eq!(
        r,
        [0x00, 0x20, 0x80, 0x10, 0x10, 0x04, 0x00, 0x00, 0x06, 0x06]
    );
    // Sub 0 is read-only (checked by the SDO server before any hook).
    let r = sdo_download(&mut coe, &mut store, &mut dev, 0x1010, 0, SIGNATURE_SAVE);
    assert_eq!(&r[2..6], &[0x80, 0x10, 0x10, 0x00]);
    assert_eq!(&r[6..10], &0x0601_0002u32.to_le_bytes());
}
