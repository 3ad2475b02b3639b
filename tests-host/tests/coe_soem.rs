//! SOEM (pysoem) uses the CoE services beyond plain SDO against the simulated drive: SDO
//! information (`slave.od`), complete access (reads of 1C12h/1A00h, a mapping written in one
//! go, config_map with complete access) and a 64 KiB segmented round trip to the test domain.

use serde_json::Value;
use tests_host::soem::run_script;

fn u(v: &Value) -> u64 {
    v.as_u64().unwrap_or_else(|| panic!("not a number: {v}"))
}

fn hex(words: &[(u64, usize)]) -> String {
    words
        .iter()
        .map(|&(v, bytes)| {
            (0..bytes)
                .map(|i| format!("{:02x}", (v >> (8 * i)) & 0xFF))
                .collect::<String>()
        })
        .collect()
}

#[test]
fn soem_uses_sdo_info_complete_access_and_the_test_domain() {
    let (r, log) =
        run_script("coe_scenario.py", "standard", 1, &[]).unwrap_or_else(|e| panic!("{e}"));
    let p = od_gen::builtin("standard").expect("standard profile");
    assert_eq!(u(&r["slave_count"]), 1);

    // SDO information: every object with its name, object code and entries.
    let od = r["od"].as_array().expect("od");
    let seen: Vec<u64> = od.iter().map(|o| u(&o["index"])).collect();
    let expected: Vec<u64> = p.objects.iter().map(|o| u64::from(o.index)).collect();
    assert_eq!(seen, expected, "OD list (type 1) in index order");
    for (o, po) in od.iter().zip(&p.objects) {
        let idx = po.index;
        assert_eq!(
            o["name"].as_str(),
            Some(po.name.as_str()),
            "{idx:#06x} name"
        );
        let code = match po.code {
            od_gen::model::ObjectCode::Var => 7,
            od_gen::model::ObjectCode::Array => 8,
            od_gen::model::ObjectCode::Record => 9,
        };
        assert_eq!(u(&o["object_code"]), code, "{idx:#06x} object code");
        if po.code == od_gen::model::ObjectCode::Var {
            // pysoem lists no entries for a VAR; its type is the object's data type.
            let e = &po.entries[0];
            assert_eq!(
                u(&o["data_type"]),
                u64::from(e.data_type.code()),
                "{idx:#06x}"
            );
            continue;
        }
        let Some(entries) = o["entries"].as_array() else {
            continue; // objects with subindex gaps: SOEM stops at the first missing one
        };
        let dense = po
            .entries
            .iter()
            .enumerate()
            .all(|(i, e)| usize::from(e.subindex) == i);
        if !dense {
            continue;
        }
        assert_eq!(entries.len(), po.entries.len(), "{idx:#06x} entries: {o}");
        for (e, pe) in entries.iter().zip(&po.entries) {
            assert_eq!(
                e["name"].as_str(),
                Some(pe.name.as_str()),
                "{idx:#06x}:{}",
                pe.subindex
            );
            assert_eq!(u(&e["data_type"]), u64::from(pe.data_type.code()));
            assert_eq!(u(&e["bit_length"]), u64::from(pe.bit_len));
        }
    }

    // Complete access: SI0 as 16 bits, then the entries (SOEM's ec_PDOassignt/ec_PDOdesct).
    assert_eq!(
        r["ca_1c12"].as_str(),
        Some(hex(&[(1, 2), (0x1600, 2)]).as_str())
    );
    let map_1a00 = hex(&[(3, 2), (0x6041_0010, 4), (0x6064_0020, 4), (0x6061_0008, 4)]);
    assert_eq!(r["ca_1a00"].as_str(), Some(map_1a00.as_str()));
    assert_eq!(r["ca_1a00_si1"].as_str(), Some(&map_1a00[4..]));
    let new_map = hex(&[(2, 2), (0x6041_0010, 4), (0x6064_0020, 4)]);
    assert_eq!(r["ca_1a00_after_write"].as_str(), Some(new_map.as_str()));
    assert_eq!(u(&r["1a00_si0_after_write"]), 2);
    assert_eq!(u(&r["ca_bad_map_abort"]), 0x0604_0041, "not mappable");
    assert_eq!(r["ca_1a00_after_bad"].as_str(), Some(new_map.as_str()));

    // 64 KiB through the test domain.
    assert_eq!(u(&r["domain_len"]), 64 * 1024);
    assert_eq!(r["domain_equal"].as_bool(), Some(true));

    // config_map with complete access still finds 7 + 7 bytes; SAFEOP reached.
    assert_eq!(u(&r["iomap_size"]), 14);
    assert_eq!(u(&r["safeop"]), 0x04, "sim log:\n{log}");
    assert_eq!(u(&r["init"]), 0x01);
}
