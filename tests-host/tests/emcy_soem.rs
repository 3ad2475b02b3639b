//! SOEM (pysoem 1.1.13) receives the drive's emergencies and reads the diagnosis history:
//! `tests-host/soem/emcy_scenario.py` over a veth pair in a private namespace.

use serde_json::Value;
use tests_host::soem::run_script;

fn u(v: &Value) -> u64 {
    v.as_u64().unwrap_or_else(|| panic!("not a number: {v}"))
}

/// ETG.1000.6 / SSC `EMCY_SM_ERRORCODE`: EtherCAT state machine error.
const ESM_ERROR: u64 = 0xA000;
/// 1001h: generic (bit 0) + communication (bit 4).
const REGISTER_COMM: u64 = 0x11;
const PREOP: u64 = 0x02;

#[test]
fn soem_receives_the_emergency_of_a_refused_safeop_and_reads_10f3h() {
    let (r, log) =
        run_script("emcy_scenario.py", "standard", 1, &[]).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(u(&r["slave_count"]), 1);
    assert_eq!(u(&r["preop"]), PREOP, "sim log:\n{log}");
    assert_eq!(u(&r["register_before"]), 0, "no error active");
    assert_eq!(u(&r["emergencies_before"]), 0);

    assert_eq!(u(&r["al_status"]), 0x12, "PRE-OP + error");
    assert_eq!(u(&r["al_status_code"]), 0x1D);
    let e = &r["emergencies_after_refusal"];
    assert_eq!(e.as_array().map(Vec::len), Some(1), "one emergency: {e}");
    let e = &e[0];
    assert_eq!(u(&e["code"]), ESM_ERROR);
    assert_eq!(u(&e["register"]), REGISTER_COMM);
    // Data [state before, AL status code LE, state after, 0] as SOEM's ec_emcyt splits it.
    assert_eq!(u(&e["b1"]), PREOP, "state before");
    assert_eq!(u(&e["w1"]), 0x001D, "AL status code");
    assert_eq!(u(&e["w2"]), PREOP, "state after");

    assert_eq!(u(&r["register"]), REGISTER_COMM, "1001h by SDO");
    assert_eq!(u(&r["newest"]), 6, "10F3h:02 names the first message slot");
    assert_eq!(u(&r["new_messages"]), 1);
    let msg: Vec<u64> = r["message"]
        .as_array()
        .expect("bytes")
        .iter()
        .map(u)
        .collect();
    assert_eq!(msg.len(), 28);
    assert_eq!(
        msg[..4],
        [0x00, 0xE8, 0x00, 0xA0],
        "diag code 0xA000_E800 (emergency 0xA000)"
    );
    assert_eq!(
        msg[4..6],
        [0x12, 0x03],
        "error, local time stamp, 3 parameters"
    );
    assert_eq!(msg[16..20], [0x06, 0x00, 0x1D, 0x00], "UNSIGNED16 0x001D");
    assert_eq!(u(&r["newest_acknowledged"]), 6);
    assert_eq!(u(&r["new_messages_after_ack"]), 0);

    assert_eq!(u(&r["al_status_after_ack"]), PREOP, "error acknowledged");
    assert_eq!(u(&r["register_after_ack"]), 0);
    let all = r["emergencies"].as_array().expect("list");
    let codes: Vec<u64> = all.iter().map(|e| u(&e["code"])).collect();
    assert_eq!(
        codes,
        vec![ESM_ERROR, 0x0000],
        "the error, then the error reset"
    );
    assert_eq!(u(&all[1]["register"]), 0);
}
