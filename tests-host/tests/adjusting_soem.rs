//! SOEM (pysoem) runs the Σ-V-SD's adjusting service 2310h (§4.5 (8)) on the simulated drive:
//! the 16-byte requests as normal SDO downloads, the status polled until the execution ends.
//! The in-process tests (`adjusting_service.rs`) cover the conditions and timeouts.

use serde_json::Value;
use tests_host::soem::run_script;

/// Status values (§4.5 (8)): accepted / done, error, executing.
const ACCEPTED: u64 = 1;
const ERROR: u64 = 2;
const EXECUTING: u64 = 255;

fn u(v: &Value) -> u64 {
    v.as_u64().unwrap_or_else(|| panic!("not a number: {v}"))
}

#[test]
fn soem_runs_the_sigma_v_sd_offset_adjustment_through_2310h() {
    let (r, log) =
        run_script("adjusting_scenario.py", "sigma-v-sd", 1, &[]).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(u(&r["slave_count"]), 1, "{log}");
    assert_eq!(u(&r["unknown_code"]), ERROR, "unknown request code");
    assert_eq!(u(&r["select_1008"]), ACCEPTED);
    assert_eq!(
        u(&r["execute_unprepared"]),
        ERROR,
        "1008H needs its preparation step"
    );
    assert_eq!(u(&r["abort"]), ACCEPTED);
    assert_eq!(u(&r["select_100e"]), ACCEPTED);
    // Reply: status 1, reserved, RCMD 01h, RSIZE 0, RADDRESS 2000h, no data.
    assert_eq!(
        r["select_reply"].as_str(),
        Some("01000100002000000000000000000000"),
        "reply frame of step 1"
    );
    // Executing, then done within the 5 s limit.
    assert_eq!(u(&r["execute"]), EXECUTING);
    let polled: Vec<u64> = r["polled"]
        .as_array()
        .expect("polled")
        .iter()
        .map(u)
        .collect();
    let (last, before) = polled.split_last().expect("polled at least once");
    assert_eq!(*last, ACCEPTED, "done without error: {polled:?}");
    assert!(before.iter().all(|s| *s == EXECUTING), "{polled:?}");
    assert_eq!(
        r["final_reply"].as_str(),
        Some("01000100012000000000000000000000"),
        "reply of the finished execution: RADDRESS 2001h"
    );
}
