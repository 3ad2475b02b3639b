//! Step 3 loads only what an answer reads or writes ([`load_scope`]). Checked against the plain
//! rule, a copy of the whole OD RAM: for every entry of every profile, uploads, downloads of the
//! present and of another value and complete accesses, in PRE-OP and OP, are answered on a copy
//! that holds other values everywhere else, after loading the request's scope; the response, the
//! OD RAM after step 5 (the written bytes copied back) and the stored parameters must be what
//! the same request gives on a copy of all of it.

extern crate std;

use std::vec::Vec;

use hal::esc::AlState;

use super::load_scope;
use crate::mailbox::coe::CoeServer;
use crate::od::{Dictionary, DirtyMap, Entry, Object, Profile, Value};
use crate::params::tests::TestStorage;
use crate::params::ParamStore;
use crate::pdo::{Direction, PdoPlan, RamRanges};
use crate::test_profiles::{ALL, MAX_RAM_SIZE};

const RAM: usize = MAX_RAM_SIZE;
/// Record capacity of the parameter store (the board's).
const RECORD_CAPACITY: usize = 64;
/// A response buffer larger than any mailbox.
const RESPONSE_LEN: usize = 1024;
/// Request frame bytes before the data of an init request: CoE header, command, index,
/// subindex (ETG.1000.6 §5.6.2).
const INIT_HEADER_LEN: usize = 6;
/// Size field of a normal init frame.
const SIZE_LEN: usize = 4;
/// Command bytes (ETG.1000.6 §5.6.2.1, §5.6.2.4): ccs in bits 5..=7, complete access bit 4,
/// `e` bit 1, `s` bit 0.
const UPLOAD_INIT: u8 = 2 << 5;
const DOWNLOAD_INIT_SIZED: u8 = (1 << 5) | 1;
const COMPLETE_ACCESS: u8 = 1 << 4;
/// A normal (not expedited) upload response with the size indicated.
const UPLOAD_RESPONSE_SIZED: u8 = (2 << 5) | 1;
/// The store and restore commands and their signatures (CiA 301 §7.5.2.13/14: "save", "load").
const STORE_PARAMETERS: u16 = 0x1010;
const RESTORE_DEFAULTS: u16 = 0x1011;
const SAVE: &[u8; 4] = b"save";
const LOAD: &[u8; 4] = b"load";

/// What answering one request left behind.
#[derive(Debug, PartialEq)]
struct Outcome {
    response: Vec<u8>,
    ram: Vec<u8>,
    storage: Vec<Vec<u8>>,
}

/// Pseudo-random bytes (xorshift64).
struct Noise(u64);

impl Noise {
    fn byte(&mut self) -> u8 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 24) as u8
    }
}

/// Whether `index` is a PDO mapping or assignment object (kept at its defaults in the core's
/// OD RAM, so that the RxPDO plan, which the mailbox side is always given, builds).
fn is_pdo_object(index: u16) -> bool {
    matches!(index, 0x1600..=0x17FF | 0x1A00..=0x1BFF | 0x1C12 | 0x1C13)
}

/// The profile's defaults with every OD RAM entry filled with noise, but for the PDO objects
/// unless `pdo_objects` too.
fn filled(profile: &'static Profile, noise: &mut Noise, pdo_objects: bool) -> [u8; RAM] {
    let mut ram = [0; RAM];
    let mut od = Dictionary::new(profile, &mut ram);
    od.load_defaults();
    for object in profile
        .objects
        .iter()
        .filter(|o| pdo_objects || !is_pdo_object(o.index))
    {
        for entry in object.entries {
            if let Value::Ram(_) = entry.value {
                let bytes: Vec<u8> = (0..entry.byte_len()).map(|_| noise.byte()).collect();
                od.set_value(entry, &bytes).expect("an OD RAM entry");
            }
        }
    }
    ram
}

/// Makes every test of the profile's storage rules (an automatic store's `unless`, the
/// condition on 1010h/1011h) hold in `ram`, or fail: an answer that read such a test from the
/// wrong copy then stores otherwise.
fn set_storage_tests(profile: &'static Profile, ram: &mut [u8; RAM], hold: bool) {
    let rules = &profile.storage;
    let tests = rules
        .auto_store
        .iter()
        .filter_map(|rule| rule.unless)
        .chain(rules.write_condition.map(|c| c.test));
    let mut od = Dictionary::new(profile, ram);
    for test in tests {
        let entry = od.entry(test.index, test.subindex).expect("a tested entry");
        let present = od.entry_u32(entry).unwrap_or(0) & !test.mask;
        let bits = if hold {
            test.value
        } else {
            (test.value ^ test.mask) & test.mask
        };
        let value = (present | bits).to_le_bytes();
        od.set_value(entry, &value[..entry.byte_len()])
            .expect("an OD RAM entry");
    }
}

/// The OD RAM ranges the RxPDO plan of `ram` writes (what the mailbox side copies from the
/// core).
fn rx_outputs(profile: &'static Profile, ram: &[u8; RAM]) -> RamRanges {
    let mut ram = *ram;
    PdoPlan::build(&Dictionary::new(profile, &mut ram), Direction::Rx)
        .map(|plan| plan.ram_ranges())
        .unwrap_or_default()
}

/// Answers `request` in `state` on `ram` as the mailbox side does (`Some(dirty)`: tracked),
/// with the board's parameter store as the download hook.
fn answer(
    profile: &'static Profile,
    ram: &mut [u8; RAM],
    dirty: Option<&mut DirtyMap>,
    (state, request, outputs): (AlState, &[u8], &RamRanges),
) -> (Vec<u8>, Vec<Vec<u8>>) {
    let mut store: ParamStore<TestStorage, RECORD_CAPACITY> = ParamStore::new(TestStorage::new());
    let od = match dirty {
        Some(dirty) => Dictionary::tracked(profile, ram, dirty),
        None => Dictionary::new(profile, ram),
    };
    let mut od = od.with_rx_outputs(outputs);
    let mut response = [0u8; RESPONSE_LEN];
    let n = CoeServer::new()
        .handle_with(&mut od, state, request, &mut response, &mut store)
        .expect("a CoE request");
    (response[..n].to_vec(), store.storage().slots.clone())
}

/// `request` answered on a copy of all of `core` and on `stale` with the request's scope
/// loaded from `core`.
fn both(
    profile: &'static Profile,
    (core, stale): (&[u8; RAM], &[u8; RAM]),
    state: AlState,
    request: &[u8],
) -> (Outcome, Outcome) {
    let outputs = rx_outputs(profile, core);
    let mut whole = *core;
    let (response, storage) = answer(profile, &mut whole, None, (state, request, &outputs));
    let reference = Outcome {
        response,
        ram: whole.to_vec(),
        storage,
    };
    let mut copy = *stale;
    let scope = CoeServer::new().scope(request);
    let hook: ParamStore<TestStorage, RECORD_CAPACITY> = ParamStore::new(TestStorage::new());
    load_scope(profile, scope, &hook, core, &mut copy);
    let mut dirty = DirtyMap::new();
    let (response, storage) = answer(
        profile,
        &mut copy,
        Some(&mut dirty),
        (state, request, &outputs),
    );
    // Step 5: the written bytes go back to the core.
    let mut after = *core;
    dirty.copy_marked(&copy, &mut after);
    let partial = Outcome {
        response,
        ram: after.to_vec(),
        storage,
    };
    (reference, partial)
}

/// An init request: `command`, the entry, then `data`.
fn init(command: u8, (index, subindex): (u16, u8), data: &[u8]) -> Vec<u8> {
    let [lo, hi] = index.to_le_bytes();
    let mut frame = std::vec![0x00, 0x20, command, lo, hi, subindex];
    frame.extend_from_slice(data);
    // An SDO frame is at least 8 bytes after the CoE header.
    frame.resize(frame.len().max(INIT_HEADER_LEN + SIZE_LEN), 0);
    frame
}

/// A normal download of `value` (the size, then the data).
fn download(command: u8, at: (u16, u8), value: &[u8]) -> Vec<u8> {
    let size = u32::try_from(value.len())
        .expect("a small value")
        .to_le_bytes();
    init(command, at, &[&size[..], value].concat())
}

/// The value of `entry` in `ram`.
fn value_in(profile: &'static Profile, ram: &[u8; RAM], entry: &Entry) -> Vec<u8> {
    let mut ram = *ram;
    let od = Dictionary::new(profile, &mut ram);
    od.value(entry).map(|v| v.to_vec()).unwrap_or_default()
}

/// The requests of one object: per entry an upload, a download of its present value and one
/// of the stale copy's (and of the command's signature to 1010h/1011h); a complete-access
/// upload and a download of what it read where the profile serves complete access.
fn requests(
    profile: &'static Profile,
    object: &Object,
    (core, stale): (&[u8; RAM], &[u8; RAM]),
    reference_upload: &dyn Fn(&[u8]) -> Vec<u8>,
) -> Vec<Vec<u8>> {
    let mut out = Vec::new();
    for entry in object.entries {
        let at = (object.index, entry.subindex);
        out.push(init(UPLOAD_INIT, at, &[]));
        for ram in [core, stale] {
            out.push(download(
                DOWNLOAD_INIT_SIZED,
                at,
                &value_in(profile, ram, entry),
            ));
        }
        match object.index {
            STORE_PARAMETERS => out.push(download(DOWNLOAD_INIT_SIZED, at, SAVE)),
            RESTORE_DEFAULTS => out.push(download(DOWNLOAD_INIT_SIZED, at, LOAD)),
            _ => {}
        }
    }
    if profile.device.coe.complete_access {
        let upload = init(UPLOAD_INIT | COMPLETE_ACCESS, (object.index, 0), &[]);
        let response = reference_upload(&upload);
        // A normal upload response: CoE header, command, index, subindex, size, the stream.
        if response.get(2) == Some(&UPLOAD_RESPONSE_SIZED) {
            let stream = response
                .get(INIT_HEADER_LEN + SIZE_LEN..)
                .unwrap_or_default();
            out.push(download(
                DOWNLOAD_INIT_SIZED | COMPLETE_ACCESS,
                (object.index, 0),
                stream,
            ));
        }
        out.push(upload);
    }
    out
}

#[test]
fn an_answer_on_the_loaded_scope_is_the_answer_on_the_whole_od_ram() {
    let mut noise = Noise(0x2545_F491_4F6C_DD1D);
    let mut requests_checked = 0usize;
    let mut writes_checked = 0usize;
    let mut stores_checked = 0usize;
    let unwritten = TestStorage::new().slots;
    for profile in ALL {
        // The core's PDO objects as the defaults leave them (the plan builds), the copy's
        // other values everywhere.
        let mut core = filled(profile, &mut noise, false);
        let mut stale = filled(profile, &mut noise, true);
        set_storage_tests(profile, &mut core, true);
        set_storage_tests(profile, &mut stale, false);
        for object in profile.objects {
            for state in [AlState::PreOp, AlState::Op] {
                let reference_upload =
                    |request: &[u8]| both(profile, (&core, &stale), state, request).0.response;
                for request in requests(profile, object, (&core, &stale), &reference_upload) {
                    let (reference, partial) = both(profile, (&core, &stale), state, &request);
                    assert_eq!(
                        partial, reference,
                        "{:04X} in {state:?}: {request:02X?}",
                        object.index
                    );
                    requests_checked += 1;
                    writes_checked += usize::from(reference.ram[..] != core[..]);
                    stores_checked += usize::from(reference.storage != unwritten);
                }
            }
        }
    }
    // Every entry of every profile was asked for, and many downloads changed the OD RAM.
    std::println!("{requests_checked} {writes_checked} {stores_checked}");
    assert!(requests_checked > 5_000, "{requests_checked}");
    assert!(writes_checked > 1_000, "{writes_checked}");
    // Parameters were stored: by 1010h in every profile, and automatically on downloads.
    assert!(stores_checked > ALL.len(), "{stores_checked}");
}
