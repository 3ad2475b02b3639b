//! SDO information, complete access and domain streaming against the generated standard
//! profile, byte-exact per ETG.1000.6 §5.6.2/§5.6.3. Requests and responses start at the CoE
//! header (`00 20` SDO request, `00 30` SDO response, `00 80` SDO information).

extern crate std;

use std::boxed::Box;
use std::vec;
use std::vec::Vec;

use hal::esc::AlState;

use super::{CoeServer, RamDomain};
use crate::od::storable::is_storable;
use crate::od::{Dictionary, Profile};
use crate::test_profiles::standard;

const MAILBOX: usize = 256;
const MBX_HEADER: usize = 6;
const INFO: [u8; 2] = [0x00, 0x80];
const SDO_REQ: [u8; 2] = [0x00, 0x20];
const SDO_RESP: [u8; 2] = [0x00, 0x30];
const DOMAIN_INDEX: u16 = 0x2FF0;
const DOMAIN_CAP: usize = 4096;

fn profile() -> &'static Profile {
    &standard::PROFILE
}

struct Bench {
    ram: Vec<u8>,
    coe: CoeServer,
    domain: Box<RamDomain<DOMAIN_CAP>>,
}

impl Bench {
    fn new() -> Self {
        Self {
            ram: standard::DEFAULTS.to_vec(),
            coe: CoeServer::new(),
            domain: Box::new(RamDomain::new()),
        }
    }

    fn call_in(&mut self, state: AlState, mailbox: usize, req: &[u8]) -> Vec<u8> {
        let mut od = Dictionary::new(profile(), &mut self.ram);
        let mut resp = [0xEEu8; MAILBOX];
        let resp = &mut resp[..mailbox - MBX_HEADER];
        let n = self
            .coe
            .handle_domains(&mut od, state, req, resp, &mut *self.domain)
            .expect("valid CoE request");
        resp[..n].to_vec()
    }

    fn call(&mut self, req: &[u8]) -> Vec<u8> {
        self.call_in(AlState::PreOp, MAILBOX, req)
    }

    fn fragment(&mut self, mailbox: usize) -> Option<Vec<u8>> {
        let mut resp = [0xEEu8; MAILBOX];
        let resp = &mut resp[..mailbox - MBX_HEADER];
        let n = self.coe.pending_fragment(resp)?;
        Some(resp[..n].to_vec())
    }

    fn u32_of(&mut self, index: u16, subindex: u8) -> u32 {
        let od = Dictionary::new(profile(), &mut self.ram);
        od.read_u32(index, subindex).expect("entry")
    }
}

fn cat(parts: &[&[u8]]) -> Vec<u8> {
    parts.concat()
}

fn le16(v: u16) -> [u8; 2] {
    v.to_le_bytes()
}

fn od_list_request(list_type: u16) -> Vec<u8> {
    cat(&[&INFO, &[0x01, 0, 0, 0], &le16(list_type)])
}

fn info_error(code: u32) -> Vec<u8> {
    cat(&[&INFO, &[0x07, 0, 0, 0], &code.to_le_bytes()])
}

fn indices(pred: impl Fn(&crate::od::Object) -> bool) -> Vec<u16> {
    profile()
        .objects
        .iter()
        .filter(|o| pred(o))
        .map(|o| o.index)
        .collect()
}

fn words(v: &[u16]) -> Vec<u8> {
    v.iter().flat_map(|w| w.to_le_bytes()).collect()
}

// ---------------------------------------------------------------------------------------------
// SDO information
// ---------------------------------------------------------------------------------------------

#[test]
fn od_list_type_0_answers_the_count_of_each_list_type() {
    let all = profile().objects.len() as u16;
    let rx = indices(|o| o.entries.iter().any(|e| e.pdo.rx())).len() as u16;
    let tx = indices(|o| o.entries.iter().any(|e| e.pdo.tx())).len() as u16;
    let backup = indices(|o| {
        o.entries
            .iter()
            .any(|e| is_storable(&profile().storage, o, e))
    })
    .len() as u16;
    let settings = profile().device.settings.len() as u16;
    assert!(backup > 0 && settings > 0);
    let expected = cat(&[
        &INFO,
        &[0x02, 0, 0, 0],
        &le16(0),
        &words(&[all, rx, tx, backup, settings]),
    ]);
    assert_eq!(Bench::new().call(&od_list_request(0)), expected);
}

#[test]
fn od_list_types_1_to_3_list_the_matching_objects_in_index_order() {
    let mut b = Bench::new();
    let all = indices(|_| true);
    assert!(all.contains(&DOMAIN_INDEX) && all.windows(2).all(|w| w[0] < w[1]));
    let rx = indices(|o| o.entries.iter().any(|e| e.pdo.rx()));
    let tx = indices(|o| o.entries.iter().any(|e| e.pdo.tx()));
    assert!(rx.contains(&0x6040) && !rx.contains(&0x6041));
    assert!(tx.contains(&0x6041) && !tx.contains(&0x6040));
    for (t, list) in [(1u16, all), (2, rx), (3, tx)] {
        let expected = cat(&[&INFO, &[0x02, 0, 0, 0], &le16(t), &words(&list)]);
        assert_eq!(b.call(&od_list_request(t)), expected, "list type {t}");
    }
}

#[test]
fn od_list_type_4_lists_the_objects_the_parameter_storage_stores() {
    let mut b = Bench::new();
    // The storable objects of the standard profile (params::is_storable): 10F1h, 10F3h, the PDO
    // mapping and assignment, 2100h (commissioned motor data), 2F00h, the stop option codes
    // 605Ah-605Eh, 6076h (motor rated torque), and the PDO-mappable parameters the profile lists
    // in stored_pdo_mappable: the target-reached windows 6067h/6068h/606Dh-6070h, the profile
    // velocities 607Fh/6081h, the ramps 6083h-6085h, the torque slope 6087h, homing (607Ch,
    // 6098h-609Ah), the following-error limits 6065h/6066h, the software limits 607Dh, the
    // polarity 607Eh, the torque limits 6072h, 60E0h, 60E1h, and the interpolation period 60C2h;
    // not 1010h/1011h, 1C32h/1C33h or process data.
    let backup = [
        0x10F1, 0x10F3, 0x1600, 0x1A00, 0x1C12, 0x1C13, 0x2100, 0x2F00, 0x605A, 0x605B, 0x605C,
        0x605D, 0x605E, 0x6065, 0x6066, 0x6067, 0x6068, 0x606D, 0x606E, 0x606F, 0x6070, 0x6072,
        0x6076, 0x607C, 0x607D, 0x607E, 0x607F, 0x6081, 0x6083, 0x6084, 0x6085, 0x6087, 0x6098,
        0x6099, 0x609A, 0x60C2, 0x60E0, 0x60E1,
    ];
    assert_eq!(
        indices(|o| o
            .entries
            .iter()
            .any(|e| is_storable(&profile().storage, o, e))),
        backup
    );
    let expected = cat(&[&INFO, &[0x02, 0, 0, 0], &le16(4), &words(&backup)]);
    assert_eq!(b.call(&od_list_request(4)), expected);
}

#[test]
fn od_list_type_5_lists_the_profiles_startup_parameters() {
    let mut b = Bench::new();
    // standard.toml: `setting = true` on 2F00h, 6060h and 6076h.
    let expected = cat(&[
        &INFO,
        &[0x02, 0, 0, 0],
        &le16(5),
        &words(&[0x2F00, 0x6060, 0x6076]),
    ]);
    assert_eq!(b.call(&od_list_request(5)), expected);
}

#[test]
fn entry_description_carries_backup_and_setting_bits() {
    let mut b = Bench::new();
    let access = |b: &mut Bench, index: u16| {
        let r = b.call(&cat(&[&INFO, &[0x05, 0, 0, 0], &le16(index), &[0, 0]]));
        // CoE 2 + info header 4 + index 2 + subindex/value info 2 + type 2 + bit length 2.
        u16::from_le_bytes([r[14], r[15]])
    };
    const BACKUP: u16 = 1 << 8;
    const SETTING: u16 = 1 << 9;
    // 2F00h: RW, stored, startup parameter.
    assert_eq!(access(&mut b, 0x2F00), 0x003F | BACKUP | SETTING);
    // 6060h: RW, RxPDO-mappable (process data: not stored), startup parameter.
    assert_eq!(access(&mut b, 0x6060), 0x003F | 0x0040 | SETTING);
    // 6040h: neither.
    assert_eq!(access(&mut b, 0x6040), 0x003F | 0x0040);
}

#[test]
fn od_list_of_unknown_type_is_an_sdo_info_error() {
    assert_eq!(
        Bench::new().call(&od_list_request(6)),
        info_error(0x0601_0000)
    );
}

#[test]
fn object_description_of_identity_record() {
    let o = profile().object(0x1018).expect("1018h");
    let req = cat(&[&INFO, &[0x03, 0, 0, 0], &le16(0x1018)]);
    let expected = cat(&[
        &INFO,
        &[0x04, 0, 0, 0],
        &le16(0x1018),
        &le16(0x0023), // IDENTITY
        &[4, 0x09],    // max subindex, RECORD
        o.name.as_bytes(),
    ]);
    assert_eq!(Bench::new().call(&req), expected);
}

#[test]
fn object_description_of_var_array_and_domain() {
    let mut b = Bench::new();
    let req = |i: u16| cat(&[&INFO, &[0x03, 0, 0, 0], &le16(i)]);
    // VAR 6040h: UNSIGNED16, max subindex 0, object code 7.
    let r = b.call(&req(0x6040));
    assert_eq!(
        &r[..12],
        &cat(&[&INFO, &[4, 0, 0, 0], &le16(0x6040), &le16(6), &[0, 7]])[..]
    );
    assert_eq!(&r[12..], b"Controlword");
    // ARRAY 1C12h: element type UNSIGNED16, object code 8.
    let r = b.call(&req(0x1C12));
    assert_eq!((u16::from_le_bytes([r[8], r[9]]), r[11]), (6, 8));
    // DOMAIN 2FF0h: type 0x000F.
    let r = b.call(&req(DOMAIN_INDEX));
    assert_eq!(u16::from_le_bytes([r[8], r[9]]), 0x000F);
    assert_eq!(&r[12..], b"Test domain");
    // Missing object.
    assert_eq!(b.call(&req(0x2FFF)), info_error(0x0602_0000));
}

#[test]
fn entry_description_with_value_info_unit_default_min_max() {
    let mut b = Bench::new();
    // 6040h:00 controlword, RW, RxPDO-mappable, default 0, no min/max.
    let req = cat(&[&INFO, &[0x05, 0, 0, 0], &le16(0x6040), &[0, 0x78]]);
    let expected = cat(&[
        &INFO,
        &[0x06, 0, 0, 0],
        &le16(0x6040),
        &[0x00, 0x18], // value info served: unit type + default (no min, no max)
        &le16(0x0006),
        &le16(16),
        &le16(0x003F | 0x0040), // RW in all states, RxPDO mappable
        &le16(0),               // unit type
        &[0, 0],                // default
        b"Controlword",
    ]);
    assert_eq!(b.call(&req), expected);
    // 1C32h:02 cycle time has min and max: UNSIGNED32 default, min, max in that order.
    let e = profile()
        .object(0x1C32)
        .and_then(|o| o.entry(2))
        .expect("1C32h:02");
    let req = cat(&[&INFO, &[0x05, 0, 0, 0], &le16(0x1C32), &[2, 0x70]]);
    let r = b.call(&req);
    assert_eq!(r[9], 0x70);
    assert_eq!(&r[16..28], &cat(&[e.default, e.min, e.max])[..]);
    assert_eq!(&r[28..], e.name.as_bytes());
    // SOEM asks with value info 0x07: only the fixed part and the name.
    let req = cat(&[&INFO, &[0x05, 0, 0, 0], &le16(0x6041), &[0, 0x07]]);
    let r = b.call(&req);
    assert_eq!(r[9], 0);
    assert_eq!(u16::from_le_bytes([r[14], r[15]]), 0x0007 | 0x0080);
    assert_eq!(&r[16..], b"Statusword");
}

#[test]
fn entry_description_errors_name_missing_object_and_subindex() {
    let mut b = Bench::new();
    let req = |i: u16, s: u8| cat(&[&INFO, &[0x05, 0, 0, 0], &le16(i), &[s, 0]]);
    assert_eq!(b.call(&req(0x6040, 1)), info_error(0x0609_0011));
    assert_eq!(b.call(&req(0x2FFF, 0)), info_error(0x0602_0000));
}

#[test]
fn unknown_info_opcode_is_an_sdo_info_error() {
    let req = cat(&[&INFO, &[0x09, 0, 0, 0], &[0, 0]]);
    assert_eq!(Bench::new().call(&req), info_error(0x0504_0001));
}

#[test]
fn long_od_list_is_fragmented_one_fragment_per_call() {
    // 32-byte mailbox: 6 bytes mailbox header, 2 CoE header, 4 SDO-information header, so 20
    // data bytes per fragment.
    const SMALL: usize = 32;
    const DATA_PER_FRAGMENT: usize = SMALL - 6 - 2 - 4;
    let mut b = Bench::new();
    let all = indices(|_| true);
    let total = 2 + 2 * all.len();
    let frags = total.div_ceil(DATA_PER_FRAGMENT);
    assert!(frags > 2, "test needs several fragments");
    let mut data = Vec::new();
    let mut frame = b.call_in(AlState::PreOp, SMALL, &od_list_request(1));
    for k in 0..frags {
        let left = (frags - 1 - k) as u16;
        let incomplete = if left > 0 { 0x80 } else { 0 };
        assert_eq!(&frame[..2], &INFO);
        assert_eq!(frame[2], 0x02 | incomplete, "fragment {k}");
        assert_eq!(u16::from_le_bytes([frame[4], frame[5]]), left);
        data.extend_from_slice(&frame[6..]);
        match b.fragment(SMALL) {
            Some(f) => frame = f,
            None => assert_eq!(left, 0),
        }
    }
    assert_eq!(data, cat(&[&le16(1), &words(&all)]));
    assert!(!b.coe.fragment_pending());
}

/// A dictionary of `n` objects after the standard profile's (indices 0x3000.., UINT constants):
/// the size the issue asks SDO information to handle (300+ objects).
fn large_profile(n: u16) -> &'static Profile {
    use crate::od::{Access, DataType, Entry, Object, ObjectCode, PdoMappable, Value};
    let base = profile();
    let entry: &'static [Entry] = Box::leak(Box::new([Entry {
        subindex: 0,
        name: "Parameter",
        data_type: DataType::Unsigned16,
        bit_len: 16,
        access: Access::RO,
        pdo: PdoMappable::No,
        value: Value::Const(&[0x34, 0x12]),
        default: &[],
        min: &[],
        max: &[],
    }]));
    let mut objects: Vec<Object> = base.objects.to_vec();
    objects.extend((0..n).map(|i| Object {
        index: 0x3000 + i,
        code: ObjectCode::Var,
        name: "Parameter",
        entries: entry,
    }));
    objects.sort_by_key(|o| o.index);
    Box::leak(Box::new(Profile {
        objects: Box::leak(objects.into_boxed_slice()),
        ..*base
    }))
}

/// SOEM's way: the object list (type 1) through a 128-byte mailbox, fragment after fragment
/// (ETG.1000.6 §5.6.3.2: "incomplete" bit 7 and the fragments left), reassembled: every index,
/// in order.
#[test]
fn an_od_list_of_more_than_300_objects_comes_whole_in_fragments() {
    const MAILBOX_128: usize = 128;
    let p = large_profile(320);
    assert!(p.objects.len() > 300);
    let mut ram = p.defaults.to_vec();
    let mut coe = CoeServer::new();
    let mut domain = Box::new(RamDomain::<DOMAIN_CAP>::new());
    let mut resp = [0u8; MAILBOX_128 - MBX_HEADER];
    let n = {
        let mut od = Dictionary::new(p, &mut ram);
        coe.handle_domains(
            &mut od,
            AlState::PreOp,
            &od_list_request(1),
            &mut resp,
            &mut *domain,
        )
        .expect("answer")
    };
    let mut frames = vec![resp[..n].to_vec()];
    while let Some(n) = coe.pending_fragment(&mut resp) {
        frames.push(resp[..n].to_vec());
    }
    let last = frames.len() - 1;
    let mut data = Vec::new();
    for (k, f) in frames.iter().enumerate() {
        let incomplete = if k < last { 0x80 } else { 0 };
        assert_eq!(f[2], 0x02 | incomplete, "fragment {k}");
        assert_eq!(
            usize::from(u16::from_le_bytes([f[4], f[5]])),
            last - k,
            "fragments left"
        );
        data.extend_from_slice(&f[6..]);
    }
    assert!(frames.len() > 5, "{} fragments", frames.len());
    let all: Vec<u16> = p.objects.iter().map(|o| o.index).collect();
    assert_eq!(data, cat(&[&le16(1), &words(&all)]));
}

#[test]
fn a_new_request_drops_the_remaining_fragments() {
    let mut b = Bench::new();
    b.call_in(AlState::PreOp, 32, &od_list_request(1));
    assert!(b.coe.fragment_pending());
    b.call(&cat(&[&SDO_REQ, &[0x40], &le16(0x6041), &[0, 0, 0, 0, 0]]));
    assert!(!b.coe.fragment_pending());
    assert_eq!(b.fragment(32), None);
}

// ---------------------------------------------------------------------------------------------
// Complete access
// ---------------------------------------------------------------------------------------------

fn ca_upload(index: u16, subindex: u8) -> Vec<u8> {
    cat(&[&SDO_REQ, &[0x50], &le16(index), &[subindex, 0, 0, 0, 0]])
}

fn ca_download(index: u16, subindex: u8, stream: &[u8]) -> Vec<u8> {
    let size = (stream.len() as u32).to_le_bytes();
    cat(&[&SDO_REQ, &[0x31], &le16(index), &[subindex], &size, stream])
}

fn normal_upload_response(index: u16, subindex: u8, data: &[u8]) -> Vec<u8> {
    let size = (data.len() as u32).to_le_bytes();
    cat(&[&SDO_RESP, &[0x41], &le16(index), &[subindex], &size, data])
}

fn download_ok(index: u16, subindex: u8) -> Vec<u8> {
    cat(&[&SDO_RESP, &[0x60], &le16(index), &[subindex, 0, 0, 0, 0]])
}

fn abort(index: u16, subindex: u8, code: u32) -> Vec<u8> {
    cat(&[
        &SDO_REQ,
        &[0x80],
        &le16(index),
        &[subindex],
        &code.to_le_bytes(),
    ])
}

#[test]
fn ca_upload_of_1c12_from_si0_pads_si0_to_16_bits() {
    // SOEM's ec_PDOassignt { uint8 n; uint8 nu1; uint16 index[] }.
    let stream = [1, 0, 0x00, 0x16];
    assert_eq!(
        Bench::new().call(&ca_upload(0x1C12, 0)),
        normal_upload_response(0x1C12, 0, &stream)
    );
}

#[test]
fn ca_upload_of_1a00_si0_included_and_excluded() {
    let mut b = Bench::new();
    let n = b.u32_of(0x1A00, 0) as u8;
    let entries: Vec<u8> = (1..=n)
        .flat_map(|si| b.u32_of(0x1A00, si).to_le_bytes())
        .collect();
    assert_eq!(n, 3);
    assert_eq!(&entries[..4], &0x6041_0010u32.to_le_bytes());
    let with_si0 = cat(&[&[n, 0], &entries]);
    assert_eq!(
        b.call(&ca_upload(0x1A00, 0)),
        normal_upload_response(0x1A00, 0, &with_si0)
    );
    assert_eq!(
        b.call(&ca_upload(0x1A00, 1)),
        normal_upload_response(0x1A00, 1, &entries)
    );
}

#[test]
fn ca_upload_of_a_var_is_its_value_and_subindex_1_does_not_exist() {
    let mut b = Bench::new();
    let value = b.u32_of(0x1000, 0).to_le_bytes();
    assert_eq!(
        b.call(&ca_upload(0x1000, 0)),
        normal_upload_response(0x1000, 0, &value)
    );
    assert_eq!(b.call(&ca_upload(0x1000, 1)), abort(0x1000, 1, 0x0609_0011));
    assert_eq!(b.call(&ca_upload(0x1018, 2)), abort(0x1018, 2, 0x0601_0000));
    assert_eq!(b.call(&ca_upload(0x2FFF, 0)), abort(0x2FFF, 0, 0x0602_0000));
    assert_eq!(
        b.call(&ca_upload(DOMAIN_INDEX, 0)),
        abort(DOMAIN_INDEX, 0, 0x0601_0004)
    );
}

#[test]
fn ca_download_replaces_a_mapping_atomically() {
    let mut b = Bench::new();
    let stream = cat(&[
        &[2, 0],
        &0x6041_0010u32.to_le_bytes(),
        &0x6064_0020u32.to_le_bytes(),
    ]);
    assert_eq!(
        b.call(&ca_download(0x1A00, 0, &stream)),
        download_ok(0x1A00, 0)
    );
    assert_eq!(b.u32_of(0x1A00, 0), 2);
    assert_eq!(b.u32_of(0x1A00, 2), 0x6064_0020);
    assert_eq!(
        b.call(&ca_upload(0x1A00, 0)),
        normal_upload_response(0x1A00, 0, &stream)
    );
    assert_eq!(b.coe.last_write(), None, "an upload writes nothing");
}

#[test]
fn ca_download_violating_the_pdo_rules_leaves_the_old_mapping() {
    let mut b = Bench::new();
    let before = b.call(&ca_upload(0x1A00, 0));
    // 6040h is RxPDO-only: not mappable into a TxPDO.
    let stream = cat(&[
        &[2, 0],
        &0x6041_0010u32.to_le_bytes(),
        &0x6040_0010u32.to_le_bytes(),
    ]);
    assert_eq!(
        b.call(&ca_download(0x1A00, 0, &stream)),
        abort(0x1A00, 0, 0x0604_0041)
    );
    assert_eq!(b.call(&ca_upload(0x1A00, 0)), before);
    // More entries than the device allows (SI0 above the highest subindex).
    let too_many = [0x40, 0];
    assert_eq!(
        b.call(&ca_download(0x1A00, 0, &too_many)),
        abort(0x1A00, 0, 0x0609_0031)
    );
    // Assignment of a TxPDO to SM2.
    let stream = [1, 0, 0x00, 0x1A];
    assert_eq!(
        b.call(&ca_download(0x1C12, 0, &stream)),
        abort(0x1C12, 0, 0x0609_0030)
    );
    assert_eq!(b.u32_of(0x1C12, 1), 0x1600);
    assert_eq!(b.call(&ca_upload(0x1A00, 0)), before);
}

#[test]
fn ca_download_length_and_state_rules() {
    let mut b = Bench::new();
    // Announces 2 entries but carries 1.
    let short = cat(&[&[2, 0], &0x6041_0010u32.to_le_bytes()]);
    assert_eq!(
        b.call(&ca_download(0x1A00, 0, &short)),
        abort(0x1A00, 0, 0x0607_0013)
    );
    // Not writable in SAFEOP.
    let stream = cat(&[&[1, 0], &0x6041_0010u32.to_le_bytes()]);
    assert_eq!(
        b.call_in(AlState::SafeOp, MAILBOX, &ca_download(0x1A00, 0, &stream)),
        abort(0x1A00, 0, 0x0800_0022)
    );
    // Read-only record: writing back the uploaded identity is accepted, a change is not.
    let id = b.call(&ca_upload(0x1018, 0));
    let stream = id[10..].to_vec();
    assert_eq!(
        b.call(&ca_download(0x1018, 0, &stream)),
        download_ok(0x1018, 0)
    );
    let mut changed = stream.clone();
    changed[2] ^= 1;
    assert_eq!(
        b.call(&ca_download(0x1018, 0, &changed)),
        abort(0x1018, 0, 0x0601_0002)
    );
}

#[test]
fn ca_download_from_si1_keeps_si0_and_revalidates() {
    let mut b = Bench::new();
    let n = b.u32_of(0x1600, 0);
    let mut stream = Vec::new();
    for si in 1..=n as u8 {
        stream.extend_from_slice(&b.u32_of(0x1600, si).to_le_bytes());
    }
    stream[..4].copy_from_slice(&0x6040_0010u32.to_le_bytes());
    assert_eq!(
        b.call(&ca_download(0x1600, 1, &stream)),
        download_ok(0x1600, 1)
    );
    assert_eq!(b.u32_of(0x1600, 0), n);
}

#[test]
fn segmented_ca_download_commits_after_the_last_segment() {
    const SMALL: usize = 32; // 16 bytes in the init frame, 23 per segment
    let mut b = Bench::new();
    let stream = cat(&[
        &[4, 0],
        &0x6040_0010u32.to_le_bytes(),
        &0x607A_0020u32.to_le_bytes(),
        &0x6060_0008u32.to_le_bytes(),
        &0x0000_0008u32.to_le_bytes(), // 8 bits padding
    ]);
    let size = (stream.len() as u32).to_le_bytes();
    let init = cat(&[&SDO_REQ, &[0x31], &le16(0x1600), &[0], &size, &stream[..16]]);
    assert_eq!(
        b.call_in(AlState::PreOp, SMALL, &init),
        download_ok(0x1600, 0)
    );
    assert_eq!(
        b.u32_of(0x1600, 0),
        3,
        "not committed before the last segment"
    );
    let rest = &stream[16..];
    let mut padded = rest.to_vec();
    padded.resize(7, 0);
    let seg = cat(&[&SDO_REQ, &[0x01 | ((7 - rest.len() as u8) << 1)], &padded]);
    let r = b.call_in(AlState::PreOp, SMALL, &seg);
    assert_eq!(&r[..3], &[0x00, 0x30, 0x20]);
    assert_eq!(b.u32_of(0x1600, 0), 4);
    assert_eq!(b.u32_of(0x1600, 4), 0x0000_0008);
}

// ---------------------------------------------------------------------------------------------
// Domains
// ---------------------------------------------------------------------------------------------

fn pattern(len: usize, seed: u8) -> Vec<u8> {
    (0..len)
        .map(|i| (i as u8).wrapping_mul(31) ^ seed)
        .collect()
}

/// Downloads `data` to the test domain in segments; returns the responses.
fn domain_download(b: &mut Bench, data: &[u8]) -> Vec<Vec<u8>> {
    let room_init = MAILBOX - MBX_HEADER - 10;
    let room_seg = MAILBOX - MBX_HEADER - 3;
    let size = (data.len() as u32).to_le_bytes();
    let first = &data[..room_init.min(data.len())];
    let init = cat(&[&SDO_REQ, &[0x21], &le16(DOMAIN_INDEX), &[0], &size, first]);
    let mut out = vec![b.call(&init)];
    let mut sent = first.len();
    let mut toggle = 0u8;
    while sent < data.len() {
        let chunk = &data[sent..(sent + room_seg).min(data.len())];
        sent += chunk.len();
        let last = if sent == data.len() { 1 } else { 0 };
        let seg = cat(&[&SDO_REQ, &[toggle | last], chunk]);
        out.push(b.call(&seg));
        toggle ^= 0x10;
    }
    out
}

/// Uploads the test domain segment by segment.
fn domain_upload(b: &mut Bench) -> Vec<u8> {
    let r = b.call(&cat(&[
        &SDO_REQ,
        &[0x40],
        &le16(DOMAIN_INDEX),
        &[0, 0, 0, 0, 0],
    ]));
    assert_eq!(r[2], 0x41, "normal upload response: {r:02x?}");
    let total = u32::from_le_bytes([r[6], r[7], r[8], r[9]]) as usize;
    let mut data = r[10..].to_vec();
    let mut toggle = 0u8;
    while data.len() < total {
        let r = b.call(&cat(&[&SDO_REQ, &[0x60 | toggle], &[0; 7]]));
        assert_eq!(r[2] & 0xE0, 0, "upload segment response");
        assert_eq!(r[2] & 0x10, toggle);
        let mut chunk = &r[3..];
        if chunk.len() == 7 {
            chunk = &chunk[..7 - usize::from((r[2] >> 1) & 7)];
        }
        data.extend_from_slice(chunk);
        assert_eq!(r[2] & 1 == 1, data.len() == total);
        toggle ^= 0x10;
    }
    data
}

#[test]
fn domain_download_and_upload_stream_through_the_store() {
    let mut b = Bench::new();
    let data = pattern(3000, 0x5A);
    for r in domain_download(&mut b, &data) {
        assert_eq!(&r[..2], &SDO_RESP, "{r:02x?}");
    }
    assert_eq!(b.domain.content(), &data[..]);
    assert_eq!(b.coe.last_write(), Some((DOMAIN_INDEX, 0)));
    assert_eq!(domain_upload(&mut b), data);
}

#[test]
fn domain_download_with_toggle_error_keeps_the_old_content() {
    let mut b = Bench::new();
    let old = pattern(500, 1);
    domain_download(&mut b, &old);
    let size = 2000u32.to_le_bytes();
    let init = cat(&[
        &SDO_REQ,
        &[0x21],
        &le16(DOMAIN_INDEX),
        &[0],
        &size,
        &[7; 240],
    ]);
    assert_eq!(b.call(&init), download_ok(DOMAIN_INDEX, 0));
    assert!(b.domain.writing());
    // The first segment must carry toggle 0.
    let seg = cat(&[&SDO_REQ, &[0x10], &[9; 247]]);
    assert_eq!(b.call(&seg), abort(DOMAIN_INDEX, 0, 0x0503_0000));
    assert!(!b.domain.writing());
    assert_eq!(b.domain.content(), &old[..]);
}

#[test]
fn master_abort_or_new_request_mid_download_keeps_the_old_content() {
    let mut b = Bench::new();
    let old = pattern(300, 2);
    domain_download(&mut b, &old);
    let size = 1000u32.to_le_bytes();
    let init = cat(&[
        &SDO_REQ,
        &[0x21],
        &le16(DOMAIN_INDEX),
        &[0],
        &size,
        &[7; 240],
    ]);
    b.call(&init);
    let master_abort = cat(&[&SDO_REQ, &[0x80], &le16(DOMAIN_INDEX), &[0], &[0, 0, 4, 5]]);
    assert_eq!(
        b.call_in(AlState::PreOp, MAILBOX, &master_abort),
        Vec::<u8>::new()
    );
    assert!(!b.domain.writing());
    b.call(&init);
    b.call(&cat(&[&SDO_REQ, &[0x40], &le16(0x6041), &[0, 0, 0, 0, 0]]));
    assert!(!b.domain.writing());
    assert_eq!(b.domain.content(), &old[..]);
    // Too long for the store: refused at the init request.
    let size = (DOMAIN_CAP as u32 + 1).to_le_bytes();
    let init = cat(&[
        &SDO_REQ,
        &[0x21],
        &le16(DOMAIN_INDEX),
        &[0],
        &size,
        &[7; 240],
    ]);
    assert_eq!(b.call(&init), abort(DOMAIN_INDEX, 0, 0x0607_0012));
}

#[test]
fn domain_last_segment_short_of_the_announced_size_aborts_0x06070013() {
    let mut b = Bench::new();
    let size = 300u32.to_le_bytes();
    let init = cat(&[
        &SDO_REQ,
        &[0x21],
        &le16(DOMAIN_INDEX),
        &[0],
        &size,
        &[7; 240],
    ]);
    b.call(&init);
    let seg = cat(&[&SDO_REQ, &[0x01], &[1; 10]]);
    assert_eq!(b.call(&seg), abort(DOMAIN_INDEX, 0, 0x0607_0013));
    assert_eq!(b.domain.content(), &[] as &[u8]);
}

#[test]
fn without_a_domain_store_domains_are_refused() {
    let mut ram = standard::DEFAULTS.to_vec();
    let mut od = Dictionary::new(profile(), &mut ram);
    let mut coe = CoeServer::new();
    let mut resp = [0u8; MAILBOX - MBX_HEADER];
    let req = cat(&[&SDO_REQ, &[0x40], &le16(DOMAIN_INDEX), &[0, 0, 0, 0, 0]]);
    let n = coe
        .handle(&mut od, AlState::PreOp, &req, &mut resp)
        .unwrap();
    assert_eq!(resp[..n], abort(DOMAIN_INDEX, 0, 0x0601_0000)[..]);
    let req = cat(&[
        &SDO_REQ,
        &[0x21],
        &le16(DOMAIN_INDEX),
        &[0],
        &[4, 0, 0, 0],
        &[1, 2, 3, 4],
    ]);
    let n = coe
        .handle(&mut od, AlState::PreOp, &req, &mut resp)
        .unwrap();
    assert_eq!(resp[..n], abort(DOMAIN_INDEX, 0, 0x0800_0020)[..]);
}

#[test]
fn never_panics_on_arbitrary_info_and_ca_requests() {
    let mut b = Bench::new();
    let mut seed = 0x1234_5678u32;
    for len in 0..64usize {
        for _ in 0..64 {
            let mut req: Vec<u8> = (0..len)
                .map(|_| {
                    seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                    (seed >> 24) as u8
                })
                .collect();
            if req.len() >= 3 {
                req[1] = if seed & 1 == 0 { 0x80 } else { 0x20 };
                req[2] |= if seed & 2 == 0 { 0x10 } else { 0 };
            }
            let mut od = Dictionary::new(profile(), &mut b.ram);
            let mut resp = [0u8; 64];
            let _ = b
                .coe
                .handle_domains(&mut od, AlState::PreOp, &req, &mut resp, &mut *b.domain);
            let _ = b.coe.pending_fragment(&mut resp);
        }
    }
}
