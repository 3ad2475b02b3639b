//! CoE server tests: byte-exact SDO frames (ETG.1000.6 §5.6.2) against a small hand-written
//! profile. Request frames start at the CoE header (`00 20` = SDO request), response frames too
//! (`00 30` = SDO response).

extern crate std;

use std::vec::Vec;

use hal::esc::AlState;

use super::{CoeError, CoeServer};
use crate::od::{
    Access, CoeDetails, DataType, DeviceInfo, Dictionary, Entry, Object, ObjectCode, PdoMappable,
    Profile, SmLayout, SyncSupport, Value,
};

// ---------------------------------------------------------------------------------------------
// Fixture profile
// ---------------------------------------------------------------------------------------------

/// OD RAM offsets.
const OFF_2000: u16 = 0; // u16 RW
const OFF_2001: u16 = 2; // i16 RW, -100..=100
const OFF_2002: u16 = 4; // u32 WO
const OFF_2003: u16 = 8; // u8 RW in PREOP only
const OFF_2008: u16 = 9; // RECORD: u8 SI0, u16, u32 (9, 10, 12)
const OFF_2004: u16 = 16; // VISIBLE_STRING[64]
const STRING_LEN: usize = 64;
const OFF_2005: u16 = 80; // DOMAIN[600]: larger than the SDO segment buffer
const DOMAIN_LEN: usize = 600;
const OFF_2006: u16 = 680; // u64 RW
const OFF_6040: u16 = 688; // u16 RW, RxPDO
const OFF_6041: u16 = 690; // u16 RO, TxPDO
const OFF_607A: u16 = 692; // i32 RW, RxPDO
const OFF_6064: u16 = 696; // i32 RO, TxPDO
const OFF_1600: u16 = 700; // u8 + 4 × u32
const OFF_1A00: u16 = 717; // u8 + 4 × u32
const OFF_1C12: u16 = 734; // u8 + 2 × u16
const OFF_1C13: u16 = 739; // u8 + 2 × u16
const OFF_2009: u16 = 744; // BOOLEAN
const OFF_200A: u16 = 745; // REAL32, 0.0..=10.0
const OFF_1601: u16 = 749; // u8 + 6 × u32
const RAM_SIZE: usize = 774;

const fn entry(
    subindex: u8,
    data_type: DataType,
    bit_len: u16,
    access: Access,
    value: Value,
) -> Entry {
    Entry {
        subindex,
        name: "",
        data_type,
        bit_len,
        access,
        pdo: PdoMappable::No,
        value,
        default: &[],
        min: &[],
        max: &[],
    }
}

const fn ram(offset: u16) -> Value {
    Value::Ram(offset)
}

const U8: DataType = DataType::Unsigned8;
const U16: DataType = DataType::Unsigned16;
const U32: DataType = DataType::Unsigned32;

/// Entries 1..=n of a mapping object, each u32 RW in PREOP at `base + 1 + 4 (i - 1)`.
macro_rules! mapping_entries {
    ($base:expr; $($si:literal),*) => {
        [
            entry(0, U8, 8, Access::RW_PREOP, ram($base)),
            $(entry($si, U32, 32, Access::RW_PREOP, ram($base + 1 + 4 * ($si - 1))),)*
        ]
    };
}

static E_1000: [Entry; 1] = [entry(
    0,
    U32,
    32,
    Access::RO,
    Value::Const(&[0x92, 0x01, 0x02, 0x00]),
)];
static E_1008: [Entry; 1] = [entry(
    0,
    DataType::VisibleString,
    16 * 8,
    Access::RO,
    Value::Const(b"Test servo drive"),
)];
static E_1600: [Entry; 5] = mapping_entries!(OFF_1600; 1, 2, 3, 4);
static E_1601: [Entry; 7] = mapping_entries!(OFF_1601; 1, 2, 3, 4, 5, 6);
static E_1A00: [Entry; 5] = mapping_entries!(OFF_1A00; 1, 2, 3, 4);
static E_1C12: [Entry; 3] = [
    entry(0, U8, 8, Access::RW_PREOP, ram(OFF_1C12)),
    entry(1, U16, 16, Access::RW_PREOP, ram(OFF_1C12 + 1)),
    entry(2, U16, 16, Access::RW_PREOP, ram(OFF_1C12 + 3)),
];
static E_1C13: [Entry; 3] = [
    entry(0, U8, 8, Access::RW_PREOP, ram(OFF_1C13)),
    entry(1, U16, 16, Access::RW_PREOP, ram(OFF_1C13 + 1)),
    entry(2, U16, 16, Access::RW_PREOP, ram(OFF_1C13 + 3)),
];
static E_2000: [Entry; 1] = [entry(0, U16, 16, Access::RW, ram(OFF_2000))];
static E_2001: [Entry; 1] = [Entry {
    min: &(-100i16).to_le_bytes(),
    max: &100i16.to_le_bytes(),
    ..entry(0, DataType::Integer16, 16, Access::RW, ram(OFF_2001))
}];
static E_2002: [Entry; 1] = [entry(0, U32, 32, Access::WO, ram(OFF_2002))];
static E_2003: [Entry; 1] = [entry(0, U8, 8, Access::RW_PREOP, ram(OFF_2003))];
static E_2004: [Entry; 1] = [entry(
    0,
    DataType::VisibleString,
    STRING_LEN as u16 * 8,
    Access::RW,
    ram(OFF_2004),
)];
static E_2005: [Entry; 1] = [entry(
    0,
    DataType::Domain,
    DOMAIN_LEN as u16 * 8,
    Access::RW,
    ram(OFF_2005),
)];
static E_2006: [Entry; 1] = [entry(
    0,
    DataType::Unsigned64,
    64,
    Access::RW,
    ram(OFF_2006),
)];
static E_2008: [Entry; 3] = [
    entry(0, U8, 8, Access::RW, ram(OFF_2008)),
    entry(1, U16, 16, Access::RW, ram(OFF_2008 + 1)),
    entry(2, U32, 32, Access::RW, ram(OFF_2008 + 3)),
];
static E_2009: [Entry; 1] = [entry(0, DataType::Boolean, 1, Access::RW, ram(OFF_2009))];
static E_200A: [Entry; 1] = [Entry {
    min: &0.0f32.to_le_bytes(),
    max: &10.0f32.to_le_bytes(),
    ..entry(0, DataType::Real32, 32, Access::RW, ram(OFF_200A))
}];
static E_6040: [Entry; 1] = [Entry {
    pdo: PdoMappable::Rx,
    ..entry(0, U16, 16, Access::RW, ram(OFF_6040))
}];
static E_6041: [Entry; 1] = [Entry {
    pdo: PdoMappable::Tx,
    ..entry(0, U16, 16, Access::RO, ram(OFF_6041))
}];
static E_607A: [Entry; 1] = [Entry {
    pdo: PdoMappable::Rx,
    ..entry(0, DataType::Integer32, 32, Access::RW, ram(OFF_607A))
}];
static E_6064: [Entry; 1] = [Entry {
    pdo: PdoMappable::Tx,
    ..entry(0, DataType::Integer32, 32, Access::RO, ram(OFF_6064))
}];

const fn obj(index: u16, code: ObjectCode, entries: &'static [Entry]) -> Object {
    Object {
        index,
        code,
        name: "",
        entries,
    }
}

static OBJECTS: [Object; 21] = [
    obj(0x1000, ObjectCode::Var, &E_1000),
    obj(0x1008, ObjectCode::Var, &E_1008),
    obj(0x1600, ObjectCode::Record, &E_1600),
    obj(0x1601, ObjectCode::Record, &E_1601),
    obj(0x1A00, ObjectCode::Record, &E_1A00),
    obj(0x1C12, ObjectCode::Array, &E_1C12),
    obj(0x1C13, ObjectCode::Array, &E_1C13),
    obj(0x2000, ObjectCode::Var, &E_2000),
    obj(0x2001, ObjectCode::Var, &E_2001),
    obj(0x2002, ObjectCode::Var, &E_2002),
    obj(0x2003, ObjectCode::Var, &E_2003),
    obj(0x2004, ObjectCode::Var, &E_2004),
    obj(0x2005, ObjectCode::Var, &E_2005),
    obj(0x2006, ObjectCode::Var, &E_2006),
    obj(0x2008, ObjectCode::Record, &E_2008),
    obj(0x2009, ObjectCode::Var, &E_2009),
    obj(0x200A, ObjectCode::Var, &E_200A),
    obj(0x6040, ObjectCode::Var, &E_6040),
    obj(0x6041, ObjectCode::Var, &E_6041),
    obj(0x6064, ObjectCode::Var, &E_6064),
    obj(0x607A, ObjectCode::Var, &E_607A),
];

const fn put(mut ram: [u8; RAM_SIZE], offset: u16, bytes: &[u8]) -> [u8; RAM_SIZE] {
    let mut i = 0;
    while i < bytes.len() {
        ram[offset as usize + i] = bytes[i];
        i += 1;
    }
    ram
}

static DEFAULTS: [u8; RAM_SIZE] = {
    let d = [0u8; RAM_SIZE];
    let d = put(d, OFF_2000, &0x1234u16.to_le_bytes());
    let d = put(d, OFF_2008, &[2]);
    let d = put(d, OFF_2004, b"hello world");
    let d = put(d, OFF_6041, &0x0237u16.to_le_bytes());
    let d = put(d, OFF_1600, &[1]);
    let d = put(d, OFF_1600 + 1, &0x6040_0010u32.to_le_bytes());
    let d = put(d, OFF_1A00, &[1]);
    let d = put(d, OFF_1A00 + 1, &0x6041_0010u32.to_le_bytes());
    let d = put(d, OFF_1C12, &[1]);
    let d = put(d, OFF_1C12 + 1, &0x1600u16.to_le_bytes());
    let d = put(d, OFF_1C13, &[1]);
    put(d, OFF_1C13 + 1, &0x1A00u16.to_le_bytes())
};

/// SII mailbox protocol bit of CoE.
const COE_PROTOCOL: u16 = 0x04;

const SM: SmLayout = SmLayout {
    start: 0x1000,
    length: 128,
    control: 0x26,
};

static PROFILE: Profile = Profile {
    device: DeviceInfo {
        profile: "coe-test",
        name: "Test servo drive",
        vendor_id: 0x1234,
        product_code: 1,
        revision: 1,
        mailbox_out: SM,
        mailbox_in: SmLayout {
            start: 0x1080,
            length: 128,
            control: 0x22,
        },
        boot_mailbox_out: None,
        boot_mailbox_in: None,
        outputs: SmLayout {
            start: 0x1100,
            length: 0,
            control: 0x64,
        },
        inputs: SmLayout {
            start: 0x1400,
            length: 0,
            control: 0x20,
        },
        sync: SyncSupport {
            free_run: true,
            sm_synchronous: false,
            dc_sync0: false,
            dc_sync1: false,
            min_cycle_ns: 1_000_000,
            max_cycle_ns: 10_000_000,
            cycle_step_ns: 1,
            allowed_cycles_ns: &[],
            sync_flag_in_sync: false,
            free_run_min_cycle_ns: 1000000,
            free_run_max_cycle_ns: 10000000,
            input_shift_step_ns: 0,
            input_shift_reserve_ns: 0,
            input_shift_parameter: None,
            sync_error_at_limit: false,
            sync_error_on_missed_outputs: false,
            sm_event_missed_subindex: 0x0B,
        },
        max_pdo_entries: 4,
        max_pdo_bytes: 256,
        max_process_bytes: 256,
        mailbox_protocols: COE_PROTOCOL,
        coe: CoeDetails {
            sdo: true,
            sdo_info: false,
            pdo_assign: true,
            pdo_config: true,
            upload_at_startup: false,
            complete_access: false,
        },
        esm: crate::od::test_device().esm,
        sdo_write_to_rx_mapped: crate::od::RxMappedWrite::Allowed,
        station_alias_parameter: None,
        station_alias_selector: None,
        emcy: crate::od::EmcyRules::CIA301,
        settings: &[],
    },
    objects: &OBJECTS,
    defaults: &DEFAULTS,
    value_lists: &[],
    storage: crate::od::StorageRules::NONE,
};

// ---------------------------------------------------------------------------------------------
// Bench
// ---------------------------------------------------------------------------------------------

/// Mailbox size (SM0/SM1 length) of most tests.
const MAILBOX: usize = 128;
/// A small mailbox that forces segmented transfers: 26-byte CoE payloads, 16 bytes of data in a
/// normal init frame, 23 in a segment.
const SMALL_MAILBOX: usize = 32;
/// Mailbox header length.
const MBX_HEADER: usize = 6;
/// 42 bytes: 16 + 23 + 3 in a small mailbox.
const TEXT: &[u8; 42] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnop";

struct Bench {
    ram: [u8; RAM_SIZE],
    coe: CoeServer,
    profile: &'static Profile,
}

impl Bench {
    fn new() -> Self {
        Self::with_profile(&PROFILE)
    }

    fn with_profile(profile: &'static Profile) -> Self {
        Self {
            ram: DEFAULTS,
            coe: CoeServer::new(),
            profile,
        }
    }

    /// One request with a response buffer of `mailbox − 6` bytes.
    fn call(
        &mut self,
        state: AlState,
        mailbox: usize,
        request: &[u8],
    ) -> Result<Vec<u8>, CoeError> {
        let mut od = Dictionary::new(self.profile, &mut self.ram);
        let mut response = [0xEEu8; MAILBOX];
        let response = &mut response[..mailbox - MBX_HEADER];
        let n = self.coe.handle(&mut od, state, request, response)?;
        Ok(response[..n].to_vec())
    }

    fn preop(&mut self, request: &[u8]) -> Vec<u8> {
        self.call(AlState::PreOp, MAILBOX, request)
            .expect("CoE-valid request")
    }

    fn in_state(&mut self, state: AlState, request: &[u8]) -> Vec<u8> {
        self.call(state, MAILBOX, request)
            .expect("CoE-valid request")
    }

    fn small(&mut self, request: &[u8]) -> Vec<u8> {
        self.call(AlState::PreOp, SMALL_MAILBOX, request)
            .expect("CoE-valid request")
    }

    fn value(&mut self, index: u16, subindex: u8) -> Vec<u8> {
        let od = Dictionary::new(self.profile, &mut self.ram);
        let e = od.entry(index, subindex).expect("entry");
        od.value(e).expect("value").to_vec()
    }

    fn set(&mut self, index: u16, subindex: u8, data: &[u8]) {
        let mut od = Dictionary::new(self.profile, &mut self.ram);
        let e = od.entry(index, subindex).expect("entry");
        od.set_value(e, data).expect("set");
    }
}

/// Upload request (ccs 2).
fn upload(index: u16, subindex: u8) -> [u8; 10] {
    let [lo, hi] = index.to_le_bytes();
    [0x00, 0x20, 0x40, lo, hi, subindex, 0, 0, 0, 0]
}

/// Init download request with command `cmd` and 4 data bytes.
fn download(cmd: u8, index: u16, subindex: u8, data: [u8; 4]) -> [u8; 10] {
    let [lo, hi] = index.to_le_bytes();
    let [d0, d1, d2, d3] = data;
    [0x00, 0x20, cmd, lo, hi, subindex, d0, d1, d2, d3]
}

/// Expedited 4-byte download (0x23).
fn download_u32(index: u16, subindex: u8, v: u32) -> [u8; 10] {
    download(0x23, index, subindex, v.to_le_bytes())
}

/// Expedited 2-byte download (0x2B).
fn download_u16(index: u16, subindex: u8, v: u16) -> [u8; 10] {
    let [a, b] = v.to_le_bytes();
    download(0x2B, index, subindex, [a, b, 0, 0])
}

/// Expedited 1-byte download (0x2F).
fn download_u8(index: u16, subindex: u8, v: u8) -> [u8; 10] {
    download(0x2F, index, subindex, [v, 0, 0, 0])
}

/// Download init response (scs 3).
fn download_ok(index: u16, subindex: u8) -> Vec<u8> {
    let [lo, hi] = index.to_le_bytes();
    [0x00, 0x30, 0x60, lo, hi, subindex, 0, 0, 0, 0].to_vec()
}

/// Abort frame (0x80) with the code as a number, independent of the implementation's enum. The
/// CoE header carries service 2 (SDO request): ETG.1000.6 §5.6.2.7.
fn abort(index: u16, subindex: u8, code: u32) -> Vec<u8> {
    let [lo, hi] = index.to_le_bytes();
    let [c0, c1, c2, c3] = code.to_le_bytes();
    [0x00, 0x20, 0x80, lo, hi, subindex, c0, c1, c2, c3].to_vec()
}

fn cat(parts: &[&[u8]]) -> Vec<u8> {
    parts.concat()
}

// ---------------------------------------------------------------------------------------------
// Upload
// ---------------------------------------------------------------------------------------------

#[test]
fn expedited_upload_of_u16_answers_0x4b_with_value() {
    let mut b = Bench::new();
    assert_eq!(
        b.preop(&[0x00, 0x20, 0x40, 0x00, 0x20, 0x00, 0, 0, 0, 0]),
        [0x00, 0x30, 0x4B, 0x00, 0x20, 0x00, 0x34, 0x12, 0x00, 0x00]
    );
}

#[test]
fn expedited_upload_of_u32_const_answers_0x43_with_value() {
    let mut b = Bench::new();
    assert_eq!(
        b.preop(&upload(0x1000, 0)),
        [0x00, 0x30, 0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x02, 0x00]
    );
}

#[test]
fn expedited_upload_of_u8_subindex_0_answers_0x4f() {
    let mut b = Bench::new();
    assert_eq!(
        b.preop(&upload(0x2008, 0)),
        [0x00, 0x30, 0x4F, 0x08, 0x20, 0x00, 0x02, 0x00, 0x00, 0x00]
    );
}

#[test]
fn normal_upload_of_const_string_carries_size_and_all_bytes() {
    let mut b = Bench::new();
    let expected = cat(&[
        &[0x00, 0x30, 0x41, 0x08, 0x10, 0x00, 16, 0, 0, 0],
        b"Test servo drive",
    ]);
    assert_eq!(b.preop(&upload(0x1008, 0)), expected);
}

#[test]
fn upload_of_ram_string_stops_at_first_nul() {
    let mut b = Bench::new();
    let expected = cat(&[
        &[0x00, 0x30, 0x41, 0x04, 0x20, 0x00, 11, 0, 0, 0],
        b"hello world",
    ]);
    assert_eq!(b.preop(&upload(0x2004, 0)), expected);
}

#[test]
fn upload_of_u64_is_normal_not_expedited() {
    let mut b = Bench::new();
    b.set(0x2006, 0, &0x0102_0304_0506_0708u64.to_le_bytes());
    assert_eq!(
        b.preop(&upload(0x2006, 0)),
        [0x00, 0x30, 0x41, 0x06, 0x20, 0x00, 8, 0, 0, 0, 8, 7, 6, 5, 4, 3, 2, 1]
    );
}

#[test]
fn upload_of_missing_object_aborts_0x06020000() {
    let mut b = Bench::new();
    assert_eq!(
        b.preop(&upload(0x3000, 0)),
        [0x00, 0x20, 0x80, 0x00, 0x30, 0x00, 0x00, 0x00, 0x02, 0x06]
    );
}

#[test]
fn upload_of_missing_subindex_aborts_0x06090011() {
    let mut b = Bench::new();
    assert_eq!(b.preop(&upload(0x2008, 5)), abort(0x2008, 5, 0x0609_0011));
}

#[test]
fn upload_of_write_only_entry_aborts_0x06010001() {
    let mut b = Bench::new();
    assert_eq!(b.preop(&upload(0x2002, 0)), abort(0x2002, 0, 0x0601_0001));
}

#[test]
fn segmented_upload_toggles_and_sets_last_bit() {
    let mut b = Bench::new();
    b.set(0x2004, 0, TEXT);
    // Init: normal response, complete size 42, first 16 bytes.
    assert_eq!(
        b.small(&upload(0x2004, 0)),
        cat(&[
            &[0x00, 0x30, 0x41, 0x04, 0x20, 0x00, 42, 0, 0, 0],
            &TEXT[..16]
        ])
    );
    // Segment 1, toggle 0: 23 bytes, more follow (c = 0).
    assert_eq!(
        b.small(&[0x00, 0x20, 0x60, 0, 0, 0, 0, 0, 0, 0]),
        cat(&[&[0x00, 0x30, 0x00], &TEXT[16..39]])
    );
    // Segment 2, toggle 1: last 3 bytes padded to 7, n = 4 unused, c = 1 → 0x10 | 4 << 1 | 1.
    assert_eq!(
        b.small(&[0x00, 0x20, 0x70, 0, 0, 0, 0, 0, 0, 0]),
        [0x00, 0x30, 0x19, b'n', b'o', b'p', 0, 0, 0, 0]
    );
    // The transfer is over.
    assert_eq!(
        b.small(&[0x00, 0x20, 0x60, 0, 0, 0, 0, 0, 0, 0]),
        abort(0, 0, 0x0504_0001)
    );
}

#[test]
fn segmented_upload_serves_a_snapshot_of_the_value() {
    let mut b = Bench::new();
    b.set(0x2004, 0, TEXT);
    b.small(&upload(0x2004, 0));
    b.set(
        0x2004,
        0,
        b"changed meanwhile, must not show up in the transfer",
    );
    assert_eq!(
        b.small(&[0x00, 0x20, 0x60, 0, 0, 0, 0, 0, 0, 0]),
        cat(&[&[0x00, 0x30, 0x00], &TEXT[16..39]])
    );
}

#[test]
fn segmented_upload_with_wrong_toggle_aborts_0x05030000() {
    let mut b = Bench::new();
    b.set(0x2004, 0, TEXT);
    b.small(&upload(0x2004, 0));
    assert_eq!(
        b.small(&[0x00, 0x20, 0x70, 0, 0, 0, 0, 0, 0, 0]),
        abort(0x2004, 0, 0x0503_0000)
    );
}

#[test]
fn upload_segment_without_transfer_aborts_0x05040001() {
    let mut b = Bench::new();
    assert_eq!(
        b.preop(&[0x00, 0x20, 0x60, 0, 0, 0, 0, 0, 0, 0]),
        abort(0, 0, 0x0504_0001)
    );
}

#[test]
fn upload_in_op_of_entry_readable_in_all_states_succeeds() {
    let mut b = Bench::new();
    assert_eq!(
        b.in_state(AlState::Op, &upload(0x2003, 0)),
        [0x00, 0x30, 0x4F, 0x03, 0x20, 0x00, 0x00, 0, 0, 0]
    );
}

// ---------------------------------------------------------------------------------------------
// Download
// ---------------------------------------------------------------------------------------------

#[test]
fn expedited_download_of_u16_answers_0x60_and_reports_the_write() {
    let mut b = Bench::new();
    assert_eq!(
        b.preop(&[0x00, 0x20, 0x2B, 0x00, 0x20, 0x00, 0x78, 0x56, 0x00, 0x00]),
        [0x00, 0x30, 0x60, 0x00, 0x20, 0x00, 0, 0, 0, 0]
    );
    assert_eq!(b.value(0x2000, 0), [0x78, 0x56]);
    assert_eq!(b.coe.last_write(), Some((0x2000, 0)));
    b.preop(&upload(0x2000, 0));
    assert_eq!(b.coe.last_write(), None);
}

#[test]
fn expedited_download_without_size_indicated_uses_the_entry_length() {
    let mut b = Bench::new();
    assert_eq!(
        b.preop(&download(0x22, 0x2000, 0, [0x11, 0x22, 0x33, 0x44])),
        download_ok(0x2000, 0)
    );
    assert_eq!(b.value(0x2000, 0), [0x11, 0x22]);
}

#[test]
fn expedited_download_of_one_byte_to_u16_aborts_0x06070013() {
    let mut b = Bench::new();
    assert_eq!(
        b.preop(&download_u8(0x2000, 0, 1)),
        abort(0x2000, 0, 0x0607_0013)
    );
    assert_eq!(b.value(0x2000, 0), [0x34, 0x12]);
}

#[test]
fn expedited_download_of_four_bytes_to_u16_aborts_0x06070012() {
    let mut b = Bench::new();
    assert_eq!(
        b.preop(&download_u32(0x2000, 0, 1)),
        abort(0x2000, 0, 0x0607_0012)
    );
}

#[test]
fn write_to_read_only_entry_aborts_0x06010002() {
    let mut b = Bench::new();
    assert_eq!(
        b.preop(&download_u16(0x6041, 0, 1)),
        abort(0x6041, 0, 0x0601_0002)
    );
    assert_eq!(
        b.preop(&download_u32(0x1000, 0, 1)),
        abort(0x1000, 0, 0x0601_0002)
    );
}

#[test]
fn write_to_missing_object_aborts_0x06020000() {
    let mut b = Bench::new();
    assert_eq!(
        b.preop(&download_u16(0x3000, 0, 1)),
        abort(0x3000, 0, 0x0602_0000)
    );
}

#[test]
fn write_in_safeop_to_preop_only_object_aborts_0x08000022() {
    let mut b = Bench::new();
    assert_eq!(
        b.in_state(AlState::SafeOp, &download_u8(0x2003, 0, 7)),
        [0x00, 0x20, 0x80, 0x03, 0x20, 0x00, 0x22, 0x00, 0x00, 0x08]
    );
    assert_eq!(b.value(0x2003, 0), [0]);
    assert_eq!(b.preop(&download_u8(0x2003, 0, 7)), download_ok(0x2003, 0));
    assert_eq!(b.value(0x2003, 0), [7]);
}

#[test]
fn value_above_max_aborts_0x06090031() {
    let mut b = Bench::new();
    assert_eq!(
        b.preop(&download_u16(0x2001, 0, 101)),
        abort(0x2001, 0, 0x0609_0031)
    );
    assert_eq!(
        b.preop(&download_u16(0x2001, 0, 100)),
        download_ok(0x2001, 0)
    );
}

#[test]
fn value_below_signed_min_aborts_0x06090032() {
    let mut b = Bench::new();
    let v = (-101i16).to_le_bytes();
    assert_eq!(
        b.preop(&download(0x2B, 0x2001, 0, [v[0], v[1], 0, 0])),
        abort(0x2001, 0, 0x0609_0032)
    );
}

#[test]
fn negative_value_within_signed_limits_is_accepted() {
    let mut b = Bench::new();
    let v = (-50i16).to_le_bytes();
    assert_eq!(
        b.preop(&download(0x2B, 0x2001, 0, [v[0], v[1], 0, 0])),
        download_ok(0x2001, 0)
    );
    assert_eq!(b.value(0x2001, 0), v);
}

#[test]
fn real32_above_max_aborts_0x06090031_and_nan_aborts_0x06090030() {
    let mut b = Bench::new();
    let eleven = 11.0f32.to_bits();
    assert_eq!(
        b.preop(&download_u32(0x200A, 0, eleven)),
        abort(0x200A, 0, 0x0609_0031)
    );
    assert_eq!(
        b.preop(&download_u32(0x200A, 0, 0x7FC0_0000)),
        abort(0x200A, 0, 0x0609_0030)
    );
    assert_eq!(
        b.preop(&download_u32(0x200A, 0, 2.5f32.to_bits())),
        download_ok(0x200A, 0)
    );
}

#[test]
fn boolean_value_2_aborts_0x06090031() {
    let mut b = Bench::new();
    assert_eq!(
        b.preop(&download_u8(0x2009, 0, 2)),
        abort(0x2009, 0, 0x0609_0031)
    );
    assert_eq!(b.preop(&download_u8(0x2009, 0, 1)), download_ok(0x2009, 0));
}

#[test]
fn normal_download_with_all_data_in_init_frame_commits() {
    let mut b = Bench::new();
    let req = [
        0x00, 0x20, 0x21, 0x06, 0x20, 0x00, 8, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8,
    ];
    assert_eq!(b.preop(&req), download_ok(0x2006, 0));
    assert_eq!(b.value(0x2006, 0), [1, 2, 3, 4, 5, 6, 7, 8]);
    assert_eq!(b.coe.last_write(), Some((0x2006, 0)));
}

#[test]
fn normal_download_of_shorter_string_zero_fills_the_rest() {
    let mut b = Bench::new();
    let req = cat(&[&[0x00, 0x20, 0x21, 0x04, 0x20, 0x00, 2, 0, 0, 0], b"hi"]);
    assert_eq!(b.preop(&req), download_ok(0x2004, 0));
    let v = b.value(0x2004, 0);
    assert_eq!(&v[..3], b"hi\0");
    assert!(v.iter().skip(2).all(|&x| x == 0));
}

#[test]
fn download_announcing_more_than_the_entry_aborts_0x06070012() {
    let mut b = Bench::new();
    let req = [0x00, 0x20, 0x21, 0x04, 0x20, 0x00, 65, 0, 0, 0, b'x'];
    assert_eq!(b.preop(&req), abort(0x2004, 0, 0x0607_0012));
}

#[test]
fn normal_download_of_fixed_type_with_wrong_size_aborts_0x06070013() {
    let mut b = Bench::new();
    let req = [
        0x00, 0x20, 0x21, 0x06, 0x20, 0x00, 6, 0, 0, 0, 1, 2, 3, 4, 5, 6,
    ];
    assert_eq!(b.preop(&req), abort(0x2006, 0, 0x0607_0013));
}

/// The three frames of a 42-byte segmented download of 2004h in a 32-byte mailbox.
fn segmented_text_download() -> [Vec<u8>; 3] {
    [
        cat(&[
            &[0x00, 0x20, 0x21, 0x04, 0x20, 0x00, 42, 0, 0, 0],
            &TEXT[..16],
        ]),
        cat(&[&[0x00, 0x20, 0x00], &TEXT[16..39]]),
        // toggle 1, n = 4 unused, c = 1
        [0x00, 0x20, 0x19, b'n', b'o', b'p', 0, 0, 0, 0].to_vec(),
    ]
}

#[test]
fn segmented_download_commits_only_after_last_segment() {
    let mut b = Bench::new();
    let before = b.value(0x2004, 0);
    let [init, seg1, seg2] = segmented_text_download();
    assert_eq!(b.small(&init), download_ok(0x2004, 0));
    assert_eq!(b.coe.last_write(), None);
    assert_eq!(b.value(0x2004, 0), before);
    assert_eq!(b.small(&seg1), [0x00, 0x30, 0x20, 0, 0, 0, 0, 0, 0, 0]);
    assert_eq!(b.coe.last_write(), None);
    assert_eq!(b.value(0x2004, 0), before);
    assert_eq!(b.small(&seg2), [0x00, 0x30, 0x30, 0, 0, 0, 0, 0, 0, 0]);
    assert_eq!(b.coe.last_write(), Some((0x2004, 0)));
    assert_eq!(&b.value(0x2004, 0)[..42], TEXT);
}

#[test]
fn segmented_download_with_wrong_toggle_aborts_0x05030000() {
    let mut b = Bench::new();
    let before = b.value(0x2004, 0);
    let [init, mut seg1, seg2] = segmented_text_download();
    b.small(&init);
    seg1[2] = 0x10; // toggle 1 where 0 is due
    assert_eq!(b.small(&seg1), abort(0x2004, 0, 0x0503_0000));
    assert_eq!(b.value(0x2004, 0), before);
    // The transfer is dropped.
    assert_eq!(b.small(&seg2), abort(0, 0, 0x0504_0001));
}

#[test]
fn segmented_download_longer_than_announced_aborts_0x06070012() {
    let mut b = Bench::new();
    let before = b.value(0x2004, 0);
    let [mut init, seg1, _] = segmented_text_download();
    init[6] = 30; // announce 30 bytes, send 16 + 23
    assert_eq!(b.small(&init), download_ok(0x2004, 0));
    assert_eq!(b.small(&seg1), abort(0x2004, 0, 0x0607_0012));
    assert_eq!(b.value(0x2004, 0), before);
}

#[test]
fn segmented_download_shorter_than_announced_aborts_0x06070013() {
    let mut b = Bench::new();
    let before = b.value(0x2004, 0);
    let [mut init, _, _] = segmented_text_download();
    init[6] = 50; // announce 50 bytes, send 16 + 7
    assert_eq!(b.small(&init), download_ok(0x2004, 0));
    let last = [0x00, 0x20, 0x01, 1, 2, 3, 4, 5, 6, 7];
    assert_eq!(b.small(&last), abort(0x2004, 0, 0x0607_0013));
    assert_eq!(b.value(0x2004, 0), before);
}

#[test]
fn segmented_download_larger_than_buffer_aborts_0x05040005() {
    let mut b = Bench::new();
    let size = (super::SEGMENT_BUFFER_CAPACITY as u32 + 1).to_le_bytes();
    let req = cat(&[&[0x00, 0x20, 0x21, 0x05, 0x20, 0x00], &size, &[0; 16]]);
    assert_eq!(b.small(&req), abort(0x2005, 0, 0x0504_0005));
}

#[test]
fn download_segment_without_transfer_aborts_0x05040001() {
    let mut b = Bench::new();
    assert_eq!(
        b.preop(&[0x00, 0x20, 0x01, 1, 2, 3, 4, 5, 6, 7]),
        abort(0, 0, 0x0504_0001)
    );
}

#[test]
fn master_abort_drops_the_transfer_and_sends_nothing() {
    let mut b = Bench::new();
    let [init, seg1, _] = segmented_text_download();
    b.small(&init);
    let master_abort = [0x00, 0x20, 0x80, 0x04, 0x20, 0x00, 0x00, 0x00, 0x04, 0x05];
    assert!(b.small(&master_abort).is_empty());
    assert_eq!(b.small(&seg1), abort(0, 0, 0x0504_0001));
}

#[test]
fn reset_drops_the_segmented_transfer() {
    let mut b = Bench::new();
    let [init, seg1, _] = segmented_text_download();
    b.small(&init);
    b.coe.reset();
    assert_eq!(b.small(&seg1), abort(0, 0, 0x0504_0001));
}

#[test]
fn new_init_request_replaces_the_transfer_in_progress() {
    let mut b = Bench::new();
    let [init, seg1, _] = segmented_text_download();
    b.small(&init);
    assert_eq!(b.small(&upload(0x2000, 0))[2], 0x4B);
    assert_eq!(b.small(&seg1), abort(0, 0, 0x0504_0001));
}

// ---------------------------------------------------------------------------------------------
// Subindex 0 of ARRAY/RECORD
// ---------------------------------------------------------------------------------------------

#[test]
fn write_to_si0_of_record_above_highest_subindex_aborts_0x06090031() {
    let mut b = Bench::new();
    assert_eq!(
        b.preop(&download_u8(0x2008, 0, 3)),
        abort(0x2008, 0, 0x0609_0031)
    );
    assert_eq!(b.preop(&download_u8(0x2008, 0, 1)), download_ok(0x2008, 0));
    assert_eq!(b.value(0x2008, 0), [1]);
}

// ---------------------------------------------------------------------------------------------
// PDO mapping and assignment
// ---------------------------------------------------------------------------------------------

#[test]
fn write_to_mapping_entry_with_si0_nonzero_aborts_0x06010003() {
    let mut b = Bench::new();
    assert_eq!(
        b.preop(&download_u32(0x1600, 1, 0x607A_0020)),
        [0x00, 0x20, 0x80, 0x00, 0x16, 0x01, 0x03, 0x00, 0x01, 0x06]
    );
    assert_eq!(b.value(0x1600, 1), 0x6040_0010u32.to_le_bytes());
}

#[test]
fn write_to_assignment_entry_with_si0_nonzero_aborts_0x06010003() {
    let mut b = Bench::new();
    assert_eq!(
        b.preop(&download_u16(0x1C12, 1, 0x1601)),
        abort(0x1C12, 1, 0x0601_0003)
    );
}

#[test]
fn mapping_edit_sequence_si0_zero_edit_si0_n_succeeds() {
    let mut b = Bench::new();
    assert_eq!(b.preop(&download_u8(0x1600, 0, 0)), download_ok(0x1600, 0));
    assert_eq!(
        b.preop(&download_u32(0x1600, 1, 0x607A_0020)),
        download_ok(0x1600, 1)
    );
    assert_eq!(
        b.preop(&download_u32(0x1600, 2, 0x6040_0010)),
        download_ok(0x1600, 2)
    );
    assert_eq!(b.preop(&download_u8(0x1600, 0, 2)), download_ok(0x1600, 0));
    assert_eq!(b.value(0x1600, 0), [2]);
    assert_eq!(b.value(0x1600, 1), 0x607A_0020u32.to_le_bytes());
    assert_eq!(b.value(0x1600, 2), 0x6040_0010u32.to_le_bytes());
}

#[test]
fn mapping_entry_with_wrong_bit_length_aborts_0x06040041() {
    let mut b = Bench::new();
    b.preop(&download_u8(0x1600, 0, 0));
    assert_eq!(
        b.preop(&download_u32(0x1600, 1, 0x6040_0020)),
        [0x00, 0x20, 0x80, 0x00, 0x16, 0x01, 0x41, 0x00, 0x04, 0x06]
    );
}

#[test]
fn mapping_entry_of_tx_only_object_in_rxpdo_aborts_0x06040041() {
    let mut b = Bench::new();
    b.preop(&download_u8(0x1600, 0, 0));
    assert_eq!(
        b.preop(&download_u32(0x1600, 1, 0x6041_0010)),
        abort(0x1600, 1, 0x0604_0041)
    );
    b.preop(&download_u8(0x1A00, 0, 0));
    assert_eq!(
        b.preop(&download_u32(0x1A00, 1, 0x6064_0020)),
        download_ok(0x1A00, 1)
    );
}

#[test]
fn mapping_entry_of_missing_object_or_unmappable_entry_aborts_0x06040041() {
    let mut b = Bench::new();
    b.preop(&download_u8(0x1600, 0, 0));
    assert_eq!(
        b.preop(&download_u32(0x1600, 1, 0x3000_0010)),
        abort(0x1600, 1, 0x0604_0041)
    );
    assert_eq!(
        b.preop(&download_u32(0x1600, 1, 0x2000_0010)),
        abort(0x1600, 1, 0x0604_0041)
    );
}

#[test]
fn padding_and_dummy_mapping_entries_are_accepted_with_their_length() {
    let mut b = Bench::new();
    b.preop(&download_u8(0x1600, 0, 0));
    assert_eq!(
        b.preop(&download_u32(0x1600, 1, 0x0000_0005)),
        download_ok(0x1600, 1)
    );
    assert_eq!(
        b.preop(&download_u32(0x1600, 2, 0x0005_0008)),
        download_ok(0x1600, 2)
    );
    assert_eq!(
        b.preop(&download_u32(0x1600, 3, 0x0006_0008)),
        abort(0x1600, 3, 0x0604_0041)
    );
}

#[test]
fn mapping_si0_above_highest_subindex_aborts_0x06090031() {
    let mut b = Bench::new();
    assert_eq!(
        b.preop(&download_u8(0x1600, 0, 5)),
        abort(0x1600, 0, 0x0609_0031)
    );
}

#[test]
fn mapping_with_more_entries_than_the_device_allows_aborts_0x06040042() {
    let mut b = Bench::new();
    assert_eq!(b.preop(&download_u8(0x1601, 0, 4)), download_ok(0x1601, 0));
    assert_eq!(
        b.preop(&download_u8(0x1601, 0, 5)),
        abort(0x1601, 0, 0x0604_0042)
    );
}

#[test]
fn mapping_si0_rechecks_the_entries() {
    let mut b = Bench::new();
    b.set(0x1601, 1, &0x6041_0010u32.to_le_bytes()); // TxPDO entry in an RxPDO
    assert_eq!(
        b.preop(&download_u8(0x1601, 0, 1)),
        abort(0x1601, 0, 0x0604_0041)
    );
}

#[test]
fn mapping_objects_are_not_writable_in_safeop_0x08000022() {
    let mut b = Bench::new();
    assert_eq!(
        b.in_state(AlState::SafeOp, &download_u8(0x1600, 0, 0)),
        abort(0x1600, 0, 0x0800_0022)
    );
}

#[test]
fn assignment_of_txpdo_to_rxpdo_assign_aborts_0x06090030() {
    let mut b = Bench::new();
    b.preop(&download_u8(0x1C12, 0, 0));
    assert_eq!(
        b.preop(&download_u16(0x1C12, 1, 0x1A00)),
        abort(0x1C12, 1, 0x0609_0030)
    );
    assert_eq!(
        b.preop(&download_u16(0x1C12, 1, 0x1602)),
        abort(0x1C12, 1, 0x0609_0030)
    );
}

#[test]
fn assignment_edit_sequence_succeeds() {
    let mut b = Bench::new();
    assert_eq!(b.preop(&download_u8(0x1C12, 0, 0)), download_ok(0x1C12, 0));
    assert_eq!(
        b.preop(&download_u16(0x1C12, 2, 0x1601)),
        download_ok(0x1C12, 2)
    );
    assert_eq!(b.preop(&download_u8(0x1C12, 0, 2)), download_ok(0x1C12, 0));
    assert_eq!(b.value(0x1C12, 2), [0x01, 0x16]);
}

#[test]
fn assignment_si0_rechecks_the_entries_0x06090030() {
    let mut b = Bench::new();
    b.preop(&download_u8(0x1C13, 0, 0));
    // 1C13:02 is 0 (no PDO): counting it is refused.
    assert_eq!(
        b.preop(&download_u8(0x1C13, 0, 2)),
        abort(0x1C13, 0, 0x0609_0030)
    );
}

// ---------------------------------------------------------------------------------------------
// Unsupported and malformed requests
// ---------------------------------------------------------------------------------------------

#[test]
fn complete_access_aborts_0x06010000() {
    let mut b = Bench::new();
    // Upload with CA (0x40 | 0x10) of 1600h from SI0.
    assert_eq!(
        b.preop(&[0x00, 0x20, 0x50, 0x00, 0x16, 0x00, 0, 0, 0, 0]),
        [0x00, 0x20, 0x80, 0x00, 0x16, 0x00, 0x00, 0x00, 0x01, 0x06]
    );
    // Download with CA (0x21 | 0x10).
    let req = [0x00, 0x20, 0x31, 0x00, 0x16, 0x00, 1, 0, 0, 0, 0];
    assert_eq!(b.preop(&req), abort(0x1600, 0, 0x0601_0000));
}

#[test]
fn unknown_command_specifier_aborts_0x05040001() {
    let mut b = Bench::new();
    assert_eq!(
        b.preop(&[0x00, 0x20, 0xA0, 0x00, 0x20, 0x00, 0, 0, 0, 0]),
        abort(0x2000, 0, 0x0504_0001)
    );
}

#[test]
fn truncated_request_is_size_too_short() {
    let mut b = Bench::new();
    let e = b.call(
        AlState::PreOp,
        MAILBOX,
        &[0x00, 0x20, 0x40, 0x00, 0x20, 0x00, 0, 0, 0],
    );
    assert_eq!(e, Err(CoeError::SizeTooShort));
    assert_eq!(CoeError::SizeTooShort.mailbox_error_code(), 0x0006);
    assert_eq!(
        b.call(AlState::PreOp, MAILBOX, &[0x00]),
        Err(CoeError::SizeTooShort)
    );
}

#[test]
fn sdo_information_request_is_service_not_supported() {
    let mut b = Bench::new();
    let req = [0x00, 0x80, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00];
    assert_eq!(
        b.call(AlState::PreOp, MAILBOX, &req),
        Err(CoeError::ServiceNotSupported)
    );
    assert_eq!(CoeError::ServiceNotSupported.mailbox_error_code(), 0x0004);
}

#[test]
fn emergency_from_master_is_service_not_supported() {
    let mut b = Bench::new();
    let req = [0x00, 0x10, 0, 0, 0, 0, 0, 0, 0, 0];
    assert_eq!(
        b.call(AlState::PreOp, MAILBOX, &req),
        Err(CoeError::ServiceNotSupported)
    );
}

#[test]
fn reserved_coe_service_is_invalid_header() {
    let mut b = Bench::new();
    let req = [0x00, 0x90, 0x40, 0x00, 0x20, 0x00, 0, 0, 0, 0];
    assert_eq!(
        b.call(AlState::PreOp, MAILBOX, &req),
        Err(CoeError::InvalidHeader)
    );
    assert_eq!(CoeError::InvalidHeader.mailbox_error_code(), 0x0005);
}

#[test]
fn response_buffer_smaller_than_an_sdo_frame_is_no_more_memory() {
    let mut b = Bench::new();
    let e = b.call(AlState::PreOp, MBX_HEADER + 9, &upload(0x2000, 0));
    assert_eq!(e, Err(CoeError::NoMoreMemory));
    assert_eq!(CoeError::NoMoreMemory.mailbox_error_code(), 0x0007);
}

#[test]
fn never_panics_on_arbitrary_requests() {
    let mut b = Bench::new();
    let mut seed: u32 = 0x1234_5678;
    let mut next = || {
        seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (seed >> 24) as u8
    };
    let states = [
        AlState::Init,
        AlState::PreOp,
        AlState::Boot,
        AlState::SafeOp,
        AlState::Op,
    ];
    let indices = [
        0x1600u16, 0x1C12, 0x1C13, 0x1A00, 0x2004, 0x2005, 0x2008, 0x2001, 0x1008,
    ];
    for round in 0..20_000usize {
        let len = usize::from(next()) % 40;
        let mut req: Vec<u8> = (0..len).map(|_| next()).collect();
        // Mostly well-formed SDO requests on interesting objects, so the deep paths run too.
        if len >= 6 && round % 4 != 0 {
            req[0] = 0;
            req[1] = 0x20;
            let [lo, hi] = indices[usize::from(next()) % indices.len()].to_le_bytes();
            req[3] = lo;
            req[4] = hi;
            req[5] &= 0x07;
        }
        let mailbox = [
            MBX_HEADER,
            MBX_HEADER + 9,
            MBX_HEADER + 10,
            SMALL_MAILBOX,
            MAILBOX,
        ][round % 5];
        let state = states[usize::from(next()) % states.len()];
        let _ = b.call(state, mailbox, &req);
    }
}

// ---------------------------------------------------------------------------------------------
// RxPDO-mapped entries (profile rule `pdo.sdo_write_to_rx_mapped`)
// ---------------------------------------------------------------------------------------------

/// ETG.1000.6 Table 41: object mapped to RxPDO, SDO download blocked.
const MAPPED_TO_RX_PDO: u32 = 0x0601_0006;

/// The fixture profile with `sdo_write_to_rx_mapped = "blocked"`.
fn blocking_profile() -> &'static Profile {
    std::boxed::Box::leak(std::boxed::Box::new(Profile {
        device: DeviceInfo {
            sdo_write_to_rx_mapped: crate::od::RxMappedWrite::Blocked,
            ..PROFILE.device
        },
        ..PROFILE
    }))
}

#[test]
fn download_to_rx_mapped_entry_is_blocked_in_safeop_and_op_only() {
    // 1C12h:01 = 1600h, 1600h:01 = 6040:00/16.
    let mut b = Bench::with_profile(blocking_profile());
    for state in [AlState::SafeOp, AlState::Op] {
        assert_eq!(
            b.in_state(state, &download_u16(0x6040, 0, 0x000F)),
            abort(0x6040, 0, MAPPED_TO_RX_PDO),
            "{state:?}"
        );
        assert_eq!(b.value(0x6040, 0), [0, 0], "value untouched");
        // Normal (non-expedited) download, 2 bytes announced.
        let normal = [0x00, 0x20, 0x21, 0x40, 0x60, 0x00, 2, 0, 0, 0, 0x0F, 0x00];
        assert_eq!(
            b.in_state(state, &normal),
            abort(0x6040, 0, MAPPED_TO_RX_PDO)
        );
        // Mappable but not mapped: served.
        assert_eq!(
            b.in_state(state, &download_u32(0x607A, 0, 7)),
            download_ok(0x607A, 0)
        );
    }
    assert_eq!(
        b.preop(&download_u16(0x6040, 0, 0x0006)),
        download_ok(0x6040, 0)
    );
    assert_eq!(b.value(0x6040, 0), [0x06, 0]);
}

#[test]
fn the_active_mapping_decides_what_is_blocked() {
    let mut b = Bench::with_profile(blocking_profile());
    // Remap 1600h:01 to 607A:00/32 (as PREOP editing would leave it).
    b.set(0x1600, 1, &0x607A_0020u32.to_le_bytes());
    assert_eq!(
        b.in_state(AlState::Op, &download_u16(0x6040, 0, 1)),
        download_ok(0x6040, 0)
    );
    assert_eq!(
        b.in_state(AlState::Op, &download_u32(0x607A, 0, 1)),
        abort(0x607A, 0, MAPPED_TO_RX_PDO)
    );
    // Nothing assigned: nothing blocked.
    b.set(0x1C12, 0, &[0]);
    assert_eq!(
        b.in_state(AlState::Op, &download_u32(0x607A, 0, 2)),
        download_ok(0x607A, 0)
    );
}

#[test]
fn allowed_profile_serves_download_to_rx_mapped_entry_in_op() {
    let mut b = Bench::new();
    assert_eq!(
        b.in_state(AlState::Op, &download_u16(0x6040, 0, 0x000F)),
        download_ok(0x6040, 0)
    );
    assert_eq!(b.value(0x6040, 0), [0x0F, 0]);
}

// ---------------------------------------------------------------------------------------------
// What of the OD RAM a request reads or writes (the slave's mailbox side loads that much)
// ---------------------------------------------------------------------------------------------

use crate::mailbox::DictionaryScope;

#[test]
fn an_upload_or_download_names_its_object() {
    let b = Bench::new();
    let object = |index, download| DictionaryScope::Object { index, download };
    assert_eq!(b.coe.scope(&upload(0x2000, 0)), object(0x2000, false));
    assert_eq!(b.coe.scope(&upload(0x2008, 2)), object(0x2008, false));
    assert_eq!(
        b.coe.scope(&download_u16(0x2000, 0, 5)),
        object(0x2000, true)
    );
    // Complete access (CA bit) covers the object too.
    assert_eq!(
        b.coe.scope(&download(0x31, 0x2008, 0, [4, 0, 0, 0])),
        object(0x2008, true)
    );
    // A mapping or assignment download is checked on the object itself and the profile's
    // tables (which entries exist and are mappable).
    for index in [0x1600, 0x1601, 0x1A00, 0x1C12, 0x1C13] {
        assert_eq!(b.coe.scope(&download_u8(index, 0, 0)), object(index, true));
        assert_eq!(b.coe.scope(&upload(index, 1)), object(index, false));
    }
}

#[test]
fn a_request_that_reads_no_value_names_nothing() {
    let b = Bench::new();
    // The master's abort, an upload segment (served from the transfer's snapshot), a download
    // segment with no transfer (answered with an abort).
    let abort_request = [0x00, 0x20, 0x80, 0x00, 0x20, 0x00, 0, 0, 0, 0];
    let upload_segment = [0x00, 0x20, 0x60, 0, 0, 0, 0, 0, 0, 0];
    let download_segment = [0x00, 0x20, 0x00, 1, 2, 3, 4, 5, 6, 7];
    // SDO information (service 8), an emergency (service 1), a frame shorter than an SDO.
    let info = [0x00, 0x80, 0x01, 0x00, 0x00, 0x00, 0x01, 0x00];
    let emergency = [0x00, 0x10, 0, 0, 0, 0, 0, 0, 0, 0];
    let short = [0x00, 0x20, 0x40, 0x00, 0x20];
    for request in [
        &abort_request[..],
        &upload_segment,
        &download_segment,
        &info,
        &emergency,
        &short,
        &[],
    ] {
        assert_eq!(
            b.coe.scope(request),
            DictionaryScope::Nothing,
            "{request:02X?}"
        );
    }
}

#[test]
fn a_download_segment_names_the_object_its_transfer_began_on() {
    let mut b = Bench::new();
    let [init, seg1, seg2] = segmented_text_download();
    assert_eq!(b.coe.scope(&seg1), DictionaryScope::Nothing);
    assert_eq!(b.small(&init), download_ok(0x2004, 0));
    let text = DictionaryScope::Object {
        index: 0x2004,
        download: true,
    };
    assert_eq!(b.coe.scope(&seg1), text);
    b.small(&seg1);
    assert_eq!(b.coe.scope(&seg2), text);
    b.small(&seg2);
    // Committed: no transfer any more.
    assert_eq!(b.coe.scope(&seg2), DictionaryScope::Nothing);
}
