//! SOEM (the pysoem wheel from PyPI) drives the simulated drive over a veth pair inside
//! `unshare --user --map-root-user --net`, the simulator attached with the documented
//! `sim-drive attach` command.

use serde_json::Value;
use tests_host::expected_identity;
use tests_host::soem::run_scenario;

const SAFEOP: u64 = 0x04;
const OP: u64 = 0x08;
const INIT: u64 = 0x01;
const STATE_MASK: u64 = 0x006F;

fn u(v: &Value) -> u64 {
    v.as_u64().unwrap_or_else(|| panic!("not a number: {v}"))
}

#[test]
fn soem_discovers_maps_syncs_and_cycles_the_drive() {
    let (r, log) = run_scenario("standard", 1).unwrap_or_else(|e| panic!("{e}"));
    let ((vendor, product, revision, serial), name) = expected_identity("standard");

    assert_eq!(u(&r["slave_count"]), 1, "config_init finds one slave");
    let s = &r["slaves"][0];
    assert_eq!(
        s["name"].as_str(),
        Some(name.as_str()),
        "SOEM names the slave by SII string #1"
    );
    assert_eq!(
        (u(&s["man"]), u(&s["id"]), u(&s["rev"])),
        (vendor as u64, product as u64, revision as u64)
    );

    // SDO upload of 1018h:01..04 and 1008h.
    let sdo: Vec<u64> = r["sdo_identity"]
        .as_array()
        .expect("array")
        .iter()
        .map(u)
        .collect();
    assert_eq!(
        sdo,
        vec![
            vendor as u64,
            product as u64,
            revision as u64,
            serial as u64
        ]
    );
    assert_eq!(r["sdo_device_name"].as_str(), Some(name.as_str()));
    assert_eq!(
        u(&r["missing_object_abort"]),
        0x0602_0000,
        "abort code for a missing object"
    );

    // config_map reads 1C00h, 1C12h/1C13h and the mapping via CoE; 7 bytes out + 7 bytes in.
    assert_eq!(u(&r["iomap_size"]), 14);
    assert_eq!(u(&r["safeop"]), SAFEOP);
    assert_eq!(u(&r["dc"]), 1, "config_dc finds the DC-capable slave");
    assert_eq!(u(&r["op"]), OP, "all slaves in OP; sim log:\n{log}");

    let expected_wkc = u(&r["expected_wkc"]);
    assert_eq!(expected_wkc, 3);
    let samples = r["samples"].as_array().expect("samples");
    assert!(samples.len() >= 1000);
    for (k, smp) in samples.iter().enumerate() {
        assert_eq!(u(&smp[0]), expected_wkc, "working counter of cycle {k}");
    }
    let sw = |k: usize| u(&samples[k][3]) & STATE_MASK;
    let last = samples.len() - 1;
    let (shutdown_until, switch_on_until) =
        (u(&r["phases"][0]) as usize, u(&r["phases"][1]) as usize);
    // CiA402 Table 30: ready to switch on 0x21, switched on 0x23, operation enabled 0x27.
    assert_eq!(sw(shutdown_until - 1), 0x21, "after shutdown");
    assert_eq!(sw(switch_on_until - 1), 0x23, "after switch on");
    assert_eq!(
        u(&samples[switch_on_until - 1][4]),
        0,
        "position does not follow before operation is enabled"
    );
    assert_eq!(
        sw(last),
        0x27,
        "operation enabled after shutdown, switch on, enable operation"
    );
    // Once enabled, the motor (CSP) follows the target ramp. SOEM's loop runs on the wall clock
    // and is not phase-locked to SYNC0, so the lag varies with the host's load: the actual
    // position must lie within the span of the last 50 targets sent (up to the following
    // error, a few increments), and must have moved since enabling.
    let actual = samples[last][4].as_i64().expect("actual");
    let recent: Vec<i64> = samples[last - 50..=last]
        .iter()
        .map(|s| s[2].as_i64().expect("target"))
        .collect();
    let (lowest, highest) = (
        recent.iter().copied().min().unwrap_or(0),
        recent.iter().copied().max().unwrap_or(0),
    );
    assert!(
        (lowest - 25..=highest + 25).contains(&actual),
        "position actual {actual} within the last 50 targets {lowest}..={highest}"
    );
    let at_enable = samples[switch_on_until + 50][4].as_i64().expect("actual");
    assert!(
        actual > at_enable,
        "the position follows the ramp ({at_enable} -> {actual})"
    );
    // Mode display mirrors the requested mode (8 = cyclic synchronous position).
    assert_eq!(u(&samples[last][5]), 8);
    assert_eq!(u(&r["init"]), INIT);

    // Wrong SM2 length: PRE-OP + error flag, AL status code 0x001D; acknowledged INIT works.
    assert_eq!(u(&r["bad_sm2"]["al_status"]), 0x12);
    assert_eq!(u(&r["bad_sm2"]["al_status_code"]), 0x1D);
    assert_eq!(u(&r["after_ack"]), 0x01);
}
