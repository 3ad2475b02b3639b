//! Mailbox repeat after a dropped reply (ETG.1000.4 §5.6): SOEM repeats, the drive re-posts the
//! response it already handed over, and the SDO upload completes with the right value.

use tests_host::expected_identity;
use tests_host::soem::run_script;

#[test]
fn soem_recovers_a_dropped_mailbox_response_with_repeat_request() {
    let (r, log) = run_script(
        "repeat_scenario.py",
        "standard",
        1,
        &["--drop-mailbox-read", "1"],
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert!(
        log.contains("dropped the reply to mailbox read 1"),
        "the fault was injected:\n{log}"
    );
    let ((vendor, product, revision, serial), name) = expected_identity("standard");
    let identity: Vec<u64> = r["identity"]
        .as_array()
        .expect("identity")
        .iter()
        .map(|v| v.as_u64().expect("u32"))
        .collect();
    assert_eq!(
        identity,
        vec![
            vendor as u64,
            product as u64,
            revision as u64,
            serial as u64
        ]
    );
    assert_eq!(r["device_name"].as_str(), Some(name.as_str()));
    assert_eq!(
        r["sm1_repeat_request"], 1,
        "SOEM toggled the repeat request once"
    );
    assert_eq!(
        r["sm1_repeat_ack"], 1,
        "the drive acknowledged it after re-posting"
    );
}
