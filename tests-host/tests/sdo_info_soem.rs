//! SOEM (pysoem, over a veth pair) reads the whole object dictionary of every vendor profile
//! through SDO information — the object list is fragmented for dictionaries this large
//! (ETG.1000.6 §5.6.3.3) — and finds the names, object codes, data types, bit lengths and
//! access rights (ObjAccess: per-state access, PDO mapping, backup, setting) of the profile file;
//! then it uploads every object with complete access and finds its defaults.

use od_gen::model::{Entry, Object, ObjectCode, Profile};
use serde_json::Value;
use tests_host::soem::run_script;

/// ETG.1000.6 Table 48 ObjAccess bits beyond the per-state access (bits 0..5).
const RX_PDO: u64 = 1 << 6;
const TX_PDO: u64 = 1 << 7;
const BACKUP: u64 = 1 << 8;
const SETTING: u64 = 1 << 9;

/// SOEM keeps at most `EC_MAXNAME` = 40 bytes of a name (ethercattype.h); the script decodes
/// them as ASCII with U+FFFD for other bytes.
const SOEM_MAX_NAME: usize = 40;

fn soem_name(name: &str) -> String {
    name.bytes()
        .take(SOEM_MAX_NAME)
        .map(|b| {
            if b.is_ascii() {
                char::from(b)
            } else {
                '\u{FFFD}'
            }
        })
        .collect()
}

fn u(v: &Value) -> u64 {
    v.as_u64().unwrap_or_else(|| panic!("not a number: {v}"))
}

fn obj_access(p: &Profile, o: &Object, e: &Entry) -> u64 {
    let mut bits = u64::from(e.access.0);
    if e.pdo.rx() {
        bits |= RX_PDO;
    }
    if e.pdo.tx() {
        bits |= TX_PDO;
    }
    if p.is_backup(o, e) {
        bits |= BACKUP;
    }
    if e.setting {
        bits |= SETTING;
    }
    bits
}

fn code(o: &Object) -> u64 {
    match o.code {
        ObjectCode::Var => 7,
        ObjectCode::Array => 8,
        ObjectCode::Record => 9,
    }
}

fn check(p: &Profile, r: &Value) {
    let name = &p.name;
    assert_eq!(u(&r["slave_count"]), 1, "{name}");
    let od = r["od"].as_array().expect("od");
    let seen: Vec<u64> = od.iter().map(|o| u(&o["index"])).collect();
    let expected: Vec<u64> = p.objects.iter().map(|o| u64::from(o.index)).collect();
    assert_eq!(seen, expected, "{name}: OD list (all objects, index order)");
    for (o, po) in od.iter().zip(&p.objects) {
        let at = format!("{name} {:#06x}", po.index);
        assert_eq!(
            o["name"].as_str(),
            Some(soem_name(&po.name).as_str()),
            "{at} name"
        );
        assert_eq!(u(&o["object_code"]), code(po), "{at} object code");
        if po.code == ObjectCode::Var {
            let e = &po.entries[0];
            assert_eq!(
                u(&o["data_type"]),
                u64::from(e.data_type.code()),
                "{at} type"
            );
            if !o["bit_length"].is_null() {
                assert_eq!(u(&o["bit_length"]), u64::from(e.bit_len), "{at} bits");
                assert_eq!(u(&o["obj_access"]), obj_access(p, po, e), "{at} access");
            }
            continue;
        }
        let entries = o["entries"]
            .as_array()
            .unwrap_or_else(|| panic!("{at}: no entries: {o}"));
        // SOEM asks for subindex 0..=highest and stops at the first missing subindex.
        let dense = po
            .entries
            .iter()
            .take_while(|e| usize::from(e.subindex) < po.entries.len())
            .enumerate()
            .take_while(|(i, e)| usize::from(e.subindex) == *i)
            .count();
        assert!(entries.len() >= dense.min(1), "{at}: {o}");
        for (e, pe) in entries.iter().zip(&po.entries).take(dense) {
            let at = format!("{at}:{:02x}", pe.subindex);
            assert_eq!(
                e["name"].as_str(),
                Some(soem_name(&pe.name).as_str()),
                "{at} name"
            );
            assert_eq!(
                u(&e["data_type"]),
                u64::from(pe.data_type.code()),
                "{at} type"
            );
            assert_eq!(u(&e["bit_length"]), u64::from(pe.bit_len), "{at} bits");
            assert_eq!(u(&e["obj_access"]), obj_access(p, po, pe), "{at} access");
        }
    }
}

/// Entries whose value the running drive produces (see `vendor_profiles.rs`): compared by
/// length only.
fn is_live(p: &Profile, o: &Object) -> bool {
    // A role's entry, or a further axis' copy of one (the firmware binds axis 2 to 68xxh).
    let live_role = o
        .entries
        .iter()
        .any(|e| p.role_of(o.index, e.subindex).is_some() && e.pdo.tx() && !e.pdo.rx());
    matches!(o.index, 0x1C32 | 0x1C33 | 0x10F3 | 0x1018) || live_role
}

/// The complete-access upload stream of `o` with its defaults (ETG.1000.6 §5.6.2.1.1; layout in
/// ethercat_slave::mailbox::coe::complete_access): a VAR's value as a plain upload sends it; an
/// ARRAY/RECORD's subindex 0 as 16 bits, then entries 1..=n. `None` for objects with bit-packed
/// entries (not compared byte-wise here).
fn ca_stream(o: &Object) -> Option<Vec<u8>> {
    if o.entries.iter().any(|e| e.bit_len % 8 != 0) {
        return None;
    }
    if o.code == ObjectCode::Var {
        let e = &o.entries[0];
        let mut v = e.initial_bytes();
        if e.data_type == od_gen::model::DataType::VisibleString
            && e.storage == od_gen::model::Storage::Ram
        {
            if let Some(nul) = v.iter().position(|b| *b == 0) {
                v.truncate(nul);
            }
        }
        return Some(v);
    }
    let n = *o.entries[0].initial_bytes().first()?;
    let mut v = vec![n, 0];
    for e in o.entries.iter().skip(1).filter(|e| e.subindex <= n) {
        v.extend(e.initial_bytes());
    }
    Some(v)
}

fn unhex(s: &str) -> Vec<u8> {
    (0..s.len() / 2)
        .map(|i| u8::from_str_radix(&s[2 * i..2 * i + 2], 16).expect("hex"))
        .collect()
}

/// Complete access reaches every object: each readable object uploads whole, equal to its
/// defaults (values the drive produces: the length only).
fn check_complete_access(p: &Profile, r: &Value) {
    let ca = r["ca"].as_object().expect("ca");
    for o in &p.objects {
        let at = format!("{} {:#06x}", p.name, o.index);
        let got = &ca[&format!("{:04x}", o.index)];
        let readable = o.entries.iter().all(|e| e.access.readable());
        let domain = o
            .entries
            .iter()
            .any(|e| e.data_type == od_gen::model::DataType::Domain);
        if !readable || domain {
            assert!(got.get("abort").is_some(), "{at}: {got}");
            continue;
        }
        let bytes = unhex(got.as_str().unwrap_or_else(|| panic!("{at}: {got}")));
        let Some(expected) = ca_stream(o) else {
            continue;
        };
        if is_live(p, o) {
            assert_eq!(bytes.len(), expected.len(), "{at}: length");
        } else {
            assert_eq!(bytes, expected, "{at}");
        }
    }
}

#[test]
fn soem_reads_every_vendor_dictionary_through_sdo_information() {
    for p in od_gen::builtin_profiles().expect("profiles") {
        if p.name == "standard" {
            continue; // coe_soem.rs
        }
        let (r, log) = run_script("od_scenario.py", &p.name, 1, &[])
            .unwrap_or_else(|e| panic!("{}: {e}", p.name));
        let _ = log;
        check(&p, &r);
        check_complete_access(&p, &r);
    }
}
