//! The profile's storage rules (`od::StorageRules`, od-gen `[storage]`) executed by the
//! parameter storage: group scopes replacing the CiA 301 defaults, exclusions, PDO-mappable
//! parameters that are stored, the write condition on 1010h/1011h (0x08000022) and the automatic
//! storage of SDO downloads with its suspending entry. The fixture mirrors the vendor rules
//! (Σ-V-SD scopes and exclusions, RSE stored PDO-mappable parameters, GHA-E auto-store) on a
//! handful of objects.

extern crate std;

use std::boxed::Box;
use std::vec::Vec;

use hal::esc::AlState;

use super::tests::{
    array, download, entry, var, Device, TestStorage, CMD, RESTORE_CMD, U16, U32, U8,
};
use super::*;
use crate::mailbox::coe::CoeServer;
use crate::od::{
    Access, AutoStore, Entry, EntryRange, EntryTest, Object, ObjectCode, PdoMappable, Profile,
    StorageGroup, StorageRules, Value, WriteCondition,
};
use crate::test_profiles as profiles;

/// Statusword of the fixture: CiA402 "Switch On Disabled" (bit 6, low bits 0) and "Ready to
/// Switch On" (bits 0 and 5), and the mask the Σ-V-SD condition compares (CiA402 Table 30).
const SWITCH_ON_DISABLED: u16 = 0x0240;
const READY_TO_SWITCH_ON: u16 = 0x0221;
const STATE_MASK: u32 = 0x004F;
const STATE_SWITCH_ON_DISABLED: u32 = 0x0040;
/// "Do not store SDO downloads" value of the suspending entry (GHA-E Pn046 = 1).
const DO_NOT_STORE: u32 = 1;

const fn rx(e: Entry) -> Entry {
    Entry {
        pdo: PdoMappable::Rx,
        ..e
    }
}

/// 2000h: manufacturer parameter in the Σ-V-SD sub 4 scope.
const PARAMETER: [Entry; 1] = [entry(0, U32, 32, Access::RW, Value::Ram(32))];
/// 2004h: "store SDO downloads of 2005h?" (GHA-E Pn046), stored, not auto-stored.
const STORE_SELECTION: [Entry; 1] = [entry(0, U16, 16, Access::RW, Value::Ram(36))];
/// 2005h: PDO-mappable parameter, stored and auto-stored unless 2004h = 1 (GHA-E Pn group).
const PN: [Entry; 1] = [Entry {
    pdo: PdoMappable::RxTx,
    ..entry(0, U16, 16, Access::RW, Value::Ram(38))
}];
/// 2300h: writable command object, not stored (Σ-V-SD).
const COMMAND: [Entry; 1] = [entry(0, U32, 32, Access::RW, Value::Ram(40))];
/// 2301h: parameter in the Σ-V-SD sub 3 scope (23xxh and 6xxxh).
const USER_UNIT: [Entry; 1] = [entry(0, U32, 32, Access::RW, Value::Ram(44))];
/// 6041h: statusword, read-only process data: the write condition's entry.
const STATUSWORD: [Entry; 1] = [Entry {
    pdo: PdoMappable::Tx,
    ..entry(0, U16, 16, Access::RO, Value::Ram(48))
}];
/// 6065h: RxPDO-mappable parameter stored by the rules (RSE).
const WINDOW: [Entry; 1] = [rx(entry(0, U32, 32, Access::RW, Value::Ram(52)))];
/// 607Ah: RxPDO-mappable command the rules do not name: never stored.
const TARGET: [Entry; 1] = [rx(entry(0, U32, 32, Access::RW, Value::Ram(56)))];
/// 607Dh: RxPDO-mappable limits, stored and auto-stored on SDO download (GHA-E).
const LIMITS: [Entry; 3] = [
    entry(0, U8, 8, Access::RO, Value::Const(&[2])),
    rx(entry(1, U32, 32, Access::RW, Value::Ram(60))),
    rx(entry(2, U32, 32, Access::RW, Value::Ram(64))),
];
const RAM_SIZE: usize = 68;

static OBJECTS: [Object; 11] = [
    array(STORE_PARAMETERS, &CMD),
    array(RESTORE_DEFAULTS, &RESTORE_CMD),
    var(0x2000, &PARAMETER),
    var(0x2004, &STORE_SELECTION),
    var(0x2005, &PN),
    var(0x2300, &COMMAND),
    var(0x2301, &USER_UNIT),
    var(0x6041, &STATUSWORD),
    var(0x6065, &WINDOW),
    var(0x607A, &TARGET),
    Object {
        code: ObjectCode::Record,
        ..var(0x607D, &LIMITS)
    },
];

const GROUP_3: [EntryRange; 2] = [
    EntryRange::objects(0x2300, 0x23FF),
    EntryRange::objects(0x6000, 0x6FFF),
];
const GROUP_4: [EntryRange; 1] = [EntryRange::objects(0x2000, 0x22FF)];

const RULES: StorageRules = StorageRules {
    stored_pdo_mappable: &[
        EntryRange::objects(0x2005, 0x2005),
        EntryRange::entry(0x6065, 0),
        EntryRange::objects(0x607D, 0x607D),
    ],
    not_stored: &[EntryRange::objects(0x2300, 0x2300)],
    groups: &[
        StorageGroup {
            subindex: 2,
            ranges: &[EntryRange::objects(0x1000, 0x1FFF)],
        },
        StorageGroup {
            subindex: 3,
            ranges: &GROUP_3,
        },
        StorageGroup {
            subindex: 4,
            ranges: &GROUP_4,
        },
    ],
    auto_store: &[
        AutoStore {
            entries: &[EntryRange::objects(0x607D, 0x607D)],
            unless: None,
        },
        AutoStore {
            entries: &[EntryRange::objects(0x2005, 0x2005)],
            unless: Some(EntryTest {
                index: 0x2004,
                subindex: 0,
                mask: 0xFFFF,
                value: DO_NOT_STORE,
            }),
        },
    ],
    write_condition: Some(WriteCondition {
        test: EntryTest {
            index: 0x6041,
            subindex: 0,
            mask: STATE_MASK,
            value: STATE_SWITCH_ON_DISABLED,
        },
        subindexes: &[1, 4],
    }),
};

/// Defaults: 1010h:n the capabilities of the rules, 1011h:n 1, statusword Switch On Disabled,
/// every parameter 0x11 in its low byte.
static DEFAULTS: [u8; RAM_SIZE] = {
    let mut d = [0u8; RAM_SIZE];
    let mut sub = 1;
    while sub <= 4 {
        d[(sub - 1) * 4] = store_capabilities(&RULES, sub as u8) as u8;
        d[16 + (sub - 1) * 4] = RESTORE_CAPABILITIES as u8;
        sub += 1;
    }
    let [s0, s1] = SWITCH_ON_DISABLED.to_le_bytes();
    d[48] = s0;
    d[49] = s1;
    let parameters = [32, 38, 40, 44, 52, 56, 60, 64];
    let mut i = 0;
    while i < parameters.len() {
        d[parameters[i]] = 0x11;
        i += 1;
    }
    d
};

/// The fixture: the objects above with [`RULES`], the rest from the standard profile.
fn fixture() -> &'static Profile {
    let base = &profiles::standard::PROFILE;
    Box::leak(Box::new(Profile {
        objects: &OBJECTS,
        defaults: &DEFAULTS,
        value_lists: &[],
        storage: RULES,
        ..*base
    }))
}

/// Every parameter of the fixture written with `tag` (the statusword is left alone).
const WRITABLE: [(u16, u8); 9] = [
    (0x2000, 0),
    (0x2004, 0),
    (0x2005, 0),
    (0x2300, 0),
    (0x2301, 0),
    (0x6065, 0),
    (0x607A, 0),
    (0x607D, 1),
    (0x607D, 2),
];

fn set_all(dev: &mut Device, tag: u8) {
    for (index, sub) in WRITABLE {
        dev.set(index, sub, &[tag, 0]);
    }
}

/// Which of [`WRITABLE`] a power-on over `storage` shows changed from the default.
fn loaded(profile: &'static Profile, storage: &TestStorage) -> Vec<(u16, u8)> {
    let (mut dev, _) = Device::power_on(profile, storage);
    let mut fresh = Device::new(profile);
    WRITABLE
        .into_iter()
        .filter(|&(i, s)| dev.get(i, s) != fresh.get(i, s))
        .collect()
}

fn storable(index: u16, subindex: u8) -> bool {
    let p = fixture();
    let o = p.object(index).unwrap();
    is_storable(&p.storage, o, o.entry(subindex).unwrap())
}

#[test]
fn rules_add_pdo_mappable_parameters_and_remove_exclusions() {
    for (index, sub) in [(0x2000, 0), (0x2004, 0), (0x2301, 0)] {
        assert!(storable(index, sub), "{index:#06x}: plain parameter");
    }
    for (index, sub) in [(0x2005, 0), (0x6065, 0), (0x607D, 1), (0x607D, 2)] {
        assert!(storable(index, sub), "{index:#06x}: stored_pdo_mappable");
    }
    assert!(!storable(0x2300, 0), "not_stored");
    assert!(!storable(0x607A, 0), "PDO-mappable and not listed");
    assert!(!storable(0x6041, 0), "read-only");
    assert!(!storable(0x607D, 0), "constant");
    // Without the rules the PDO-mappable ones fall back to process data, 2300h to a parameter.
    let o = |i| fixture().object(i).unwrap();
    assert!(!is_storable(&StorageRules::NONE, o(0x6065), &WINDOW[0]));
    assert!(is_storable(&StorageRules::NONE, o(0x2300), &COMMAND[0]));
}

#[test]
fn store_all_keeps_stored_entries_over_a_power_cycle_and_never_the_excluded_ones() {
    let profile = fixture();
    let mut store: ParamStore<TestStorage> = ParamStore::new(TestStorage::new());
    let mut dev = Device::new(profile);
    set_all(&mut dev, 0x42);
    assert_eq!(
        download(&mut store, &mut dev, STORE_PARAMETERS, 1, SIGNATURE_SAVE),
        Ok(())
    );
    assert_eq!(
        loaded(profile, store.storage()),
        [
            (0x2000, 0),
            (0x2004, 0),
            (0x2005, 0),
            (0x2301, 0),
            (0x6065, 0),
            (0x607D, 1),
            (0x607D, 2)
        ]
    );
    assert_eq!(
        max_record_len(profile),
        record::HEADER_LEN + 7 * record::ENTRY_HEAD_LEN + 5 * 4 + 2 * 2 + record::CRC_LEN
    );
}

#[test]
fn profile_groups_replace_the_cia_301_scopes() {
    let profile = fixture();
    let mut dev = Device::new(profile);
    set_all(&mut dev, 0x42);
    // Sub 4 = 2000h–22FFh: the parameters, not 23xxh, not 6xxxh.
    let mut store: ParamStore<TestStorage> = ParamStore::new(TestStorage::new());
    assert_eq!(
        download(&mut store, &mut dev, STORE_PARAMETERS, 4, SIGNATURE_SAVE),
        Ok(())
    );
    assert_eq!(
        loaded(profile, store.storage()),
        [(0x2000, 0), (0x2004, 0), (0x2005, 0)]
    );
    // Sub 3 = 23xxh and 6xxxh (2300h is not stored at all).
    let mut store: ParamStore<TestStorage> = ParamStore::new(TestStorage::new());
    assert_eq!(
        download(&mut store, &mut dev, STORE_PARAMETERS, 3, SIGNATURE_SAVE),
        Ok(())
    );
    assert_eq!(
        loaded(profile, store.storage()),
        [(0x2301, 0), (0x6065, 0), (0x607D, 1), (0x607D, 2)]
    );
    // Restoring sub 3 leaves sub 4's stored values.
    assert_eq!(
        download(&mut store, &mut dev, STORE_PARAMETERS, 4, SIGNATURE_SAVE),
        Ok(())
    );
    assert_eq!(
        download(&mut store, &mut dev, RESTORE_DEFAULTS, 3, SIGNATURE_LOAD),
        Ok(())
    );
    assert_eq!(
        loaded(profile, store.storage()),
        [(0x2000, 0), (0x2004, 0), (0x2005, 0)]
    );
    assert_eq!(Group::of(&RULES, 5), None);
    assert!(!Group::of(&RULES, 4).unwrap().contains(0x2300, 0));
    assert!(Group::of(&RULES, 3).unwrap().contains(0x2301, 0));
}

#[test]
fn write_condition_refuses_sub_1_and_4_with_0x08000022_and_writes_nothing() {
    let profile = fixture();
    let mut store: ParamStore<TestStorage> = ParamStore::new(TestStorage::new());
    let mut dev = Device::new(profile);
    set_all(&mut dev, 0x42);
    dev.set(0x6041, 0, &READY_TO_SWITCH_ON.to_le_bytes());
    for (index, sub, signature) in [
        (STORE_PARAMETERS, 1, SIGNATURE_SAVE),
        (STORE_PARAMETERS, 4, SIGNATURE_SAVE),
        (RESTORE_DEFAULTS, 1, SIGNATURE_LOAD),
        (RESTORE_DEFAULTS, 4, SIGNATURE_LOAD),
        // Before the signature check: a wrong signature in the wrong state is the state's abort.
        (STORE_PARAMETERS, 1, 0),
    ] {
        let r = download(&mut store, &mut dev, index, sub, signature);
        assert_eq!(
            r,
            Err(AbortCode::DataNotStoredDeviceState),
            "{index:#06x}:{sub}"
        );
        let capabilities = if index == STORE_PARAMETERS {
            store_capabilities(&RULES, sub)
        } else {
            RESTORE_CAPABILITIES
        };
        assert_eq!(dev.get(index, sub), capabilities, "reads the capabilities");
    }
    assert_eq!(AbortCode::DataNotStoredDeviceState.code(), 0x0800_0022);
    assert_eq!(store.storage().writes, 0, "nothing written");
    // Sub 2 and 3 are not guarded.
    assert_eq!(
        download(&mut store, &mut dev, STORE_PARAMETERS, 3, SIGNATURE_SAVE),
        Ok(())
    );
    assert_eq!(store.storage().writes, 1);
    // In Switch On Disabled sub 1 stores.
    dev.set(0x6041, 0, &SWITCH_ON_DISABLED.to_le_bytes());
    assert_eq!(
        download(&mut store, &mut dev, STORE_PARAMETERS, 1, SIGNATURE_SAVE),
        Ok(())
    );
    assert_eq!(store.storage().writes, 2);
}

#[test]
fn capabilities_report_autonomous_saving_for_groups_with_auto_stored_entries() {
    assert_eq!(
        store_capabilities(&RULES, 1),
        SAVES_ON_COMMAND | SAVES_AUTONOMOUSLY
    );
    assert_eq!(store_capabilities(&RULES, 2), SAVES_ON_COMMAND);
    assert_eq!(
        store_capabilities(&RULES, 3),
        SAVES_ON_COMMAND | SAVES_AUTONOMOUSLY
    );
    assert_eq!(
        store_capabilities(&RULES, 4),
        SAVES_ON_COMMAND | SAVES_AUTONOMOUSLY
    );
    assert_eq!(store_capabilities(&StorageRules::NONE, 1), SAVES_ON_COMMAND);
    assert_eq!(SAVES_AUTONOMOUSLY, 1 << 1, "CiA 301 §7.5.2.13 bit 1");
}

/// Expedited download initiate, size indicated (CiA 301 / ETG.1000.6 §5.6.2.1): `0x23` with the
/// number of unused bytes of the 4-byte data field in bits 2..3.
const EXPEDITED_DOWNLOAD: u8 = 0x23;
const UNUSED_SHIFT: u8 = 2;
const EXPEDITED_DATA_LEN: usize = 4;

/// One expedited download of `value` (as long as the entry) through the CoE server with the
/// parameter hook; returns the CoE response.
fn write(
    coe: &mut CoeServer,
    store: &mut ParamStore<TestStorage>,
    dev: &mut Device,
    index: u16,
    sub: u8,
    value: u32,
) -> Vec<u8> {
    let len = dev.od().entry(index, sub).unwrap().byte_len();
    let unused = (EXPEDITED_DATA_LEN - len) as u8;
    let [i0, i1] = index.to_le_bytes();
    let [v0, v1, v2, v3] = value.to_le_bytes();
    let cmd = EXPEDITED_DOWNLOAD | unused << UNUSED_SHIFT;
    let request = [0x00, 0x20, cmd, i0, i1, sub, v0, v1, v2, v3];
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

/// The download response frame (CoE header, SCS 3) for `index:sub`.
fn download_response(index: u16, sub: u8) -> [u8; 10] {
    let [i0, i1] = index.to_le_bytes();
    [0x00, 0x30, 0x60, i0, i1, sub, 0, 0, 0, 0]
}

#[test]
fn an_sdo_download_to_an_auto_stored_entry_is_stored_before_the_response() {
    let profile = fixture();
    let mut coe = CoeServer::new();
    let mut store: ParamStore<TestStorage> = ParamStore::new(TestStorage::new());
    let mut dev = Device::new(profile);
    // A PDO write (straight into the OD RAM, no SDO) stores nothing.
    dev.set(0x607D, 2, &[0x77, 0, 0, 0]);
    // A parameter that is not auto-stored: nothing written.
    let r = write(&mut coe, &mut store, &mut dev, 0x2000, 0, 0x55);
    assert_eq!(r, download_response(0x2000, 0));
    assert_eq!(store.storage().writes, 0);
    // 607Dh:01 by SDO: stored at once, without 1010h; 607Dh:02 (written by "PDO") is not.
    let r = write(&mut coe, &mut store, &mut dev, 0x607D, 1, 0x1234);
    assert_eq!(r, download_response(0x607D, 1));
    assert_eq!(store.storage().writes, 1);
    assert_eq!(loaded(profile, store.storage()), [(0x607D, 1)]);
    let (mut after, _) = Device::power_on(profile, store.storage());
    assert_eq!(after.get(0x607D, 1), 0x1234);
    // Another download keeps what the earlier one stored.
    let r = write(&mut coe, &mut store, &mut dev, 0x2005, 0, 0x99);
    assert_eq!(r, download_response(0x2005, 0));
    assert_eq!(loaded(profile, store.storage()), [(0x2005, 0), (0x607D, 1)]);
}

#[test]
fn the_unless_entry_suspends_automatic_storage() {
    let profile = fixture();
    let mut coe = CoeServer::new();
    let mut store: ParamStore<TestStorage> = ParamStore::new(TestStorage::new());
    let mut dev = Device::new(profile);
    write(&mut coe, &mut store, &mut dev, 0x2004, 0, DO_NOT_STORE);
    write(&mut coe, &mut store, &mut dev, 0x2005, 0, 0x99);
    assert_eq!(store.storage().writes, 0, "2004h = 1: 2005h not stored");
    // The other rule is not suspended.
    write(&mut coe, &mut store, &mut dev, 0x607D, 2, 0x88);
    assert_eq!(loaded(profile, store.storage()), [(0x607D, 2)]);
    write(&mut coe, &mut store, &mut dev, 0x2004, 0, 0);
    write(&mut coe, &mut store, &mut dev, 0x2005, 0, 0x98);
    assert_eq!(loaded(profile, store.storage()), [(0x2005, 0), (0x607D, 2)]);
}

#[test]
fn an_auto_store_failure_answers_0x06060000() {
    let profile = fixture();
    let mut coe = CoeServer::new();
    let mut store: ParamStore<TestStorage> = ParamStore::new(TestStorage::new());
    let mut dev = Device::new(profile);
    store.storage_mut().fail = true;
    let r = write(&mut coe, &mut store, &mut dev, 0x607D, 1, 0x1234);
    assert_eq!(
        r,
        [0x00, 0x20, 0x80, 0x7D, 0x60, 0x01, 0x00, 0x00, 0x06, 0x06]
    );
    assert_eq!(dev.get(0x607D, 1), 0x1234, "written, only not stored");
}

#[test]
fn a_complete_access_download_stores_the_auto_stored_entries_it_wrote() {
    let profile = fixture();
    let mut coe = CoeServer::new();
    let mut store: ParamStore<TestStorage> = ParamStore::new(TestStorage::new());
    let mut dev = Device::new(profile);
    // Download initiate, complete access (bit 4), size indicated, not expedited: 607Dh from
    // subindex 1, entries 1 and 2 (8 bytes).
    const CA_DOWNLOAD: u8 = 0x20 | 0x10 | 0x01;
    let mut request = Vec::from([0x00, 0x20, CA_DOWNLOAD, 0x7D, 0x60, 0x01, 8, 0, 0, 0]);
    request.extend_from_slice(&0x0101_0101u32.to_le_bytes());
    request.extend_from_slice(&0x0202_0202u32.to_le_bytes());
    let mut response = [0u8; 64];
    let n = coe
        .handle_with(
            &mut dev.od(),
            AlState::PreOp,
            &request,
            &mut response,
            &mut store,
        )
        .unwrap();
    assert_eq!(
        response[2] >> 5,
        3,
        "download response: {:02x?}",
        &response[..n]
    );
    assert_eq!(store.storage().writes, 1);
    let (mut after, _) = Device::power_on(profile, store.storage());
    assert_eq!(after.get(0x607D, 1), 0x0101_0101);
    assert_eq!(after.get(0x607D, 2), 0x0202_0202);
}

/// What the store's download hook reads beyond the downloaded object, which the slave's mailbox
/// side then loads with it: every parameter for 1010h/1011h; for an automatic store, the
/// entry its rule is tested on, where that lies in another object (the GHA-E stores 2000h-2005h
/// unless 2000h:2Fh = 1; 607Dh, 607Eh, 6091h without a test).
#[test]
fn the_hook_says_which_downloads_read_beyond_their_object() {
    let store: ParamStore<TestStorage> = ParamStore::new(TestStorage::new());
    let beyond = |profile: &Profile, index| store.reaches_beyond_object(profile, index);
    for profile in profiles::ALL {
        assert!(beyond(profile, 0x1010));
        assert!(beyond(profile, 0x1011));
    }
    let gha_e = &profiles::gha_e::PROFILE;
    for index in [0x2001, 0x2003, 0x2005] {
        assert!(beyond(gha_e, index), "{index:04X}");
    }
    // Tested on itself, or not tested.
    for index in [0x2000, 0x607D, 0x607E, 0x6091, 0x6081, 0x2006] {
        assert!(!beyond(gha_e, index), "{index:04X}");
    }
    // No automatic storage.
    let standard = &profiles::standard::PROFILE;
    for index in [0x2000, 0x2F00, 0x6081, 0x607D] {
        assert!(!beyond(standard, index), "{index:04X}");
    }
}
