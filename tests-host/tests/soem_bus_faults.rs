//! Faults on the bus as a master developer injects them with `sim-drive attach` (SOEM over a
//! veth pair): every 10th cyclic frame lost, then the cable pulled for 300 ms.
//!
//! - With one cyclic frame in ten lost the master counts working-counter errors (ETG.1000.4:
//!   no frame, no working counter) in about one cycle in ten, and the drive stays in OP: two
//!   cycles between outputs are far inside the process-data watchdog (100 ms).
//! - With the cable out longer than the watchdog the drive drops to SAFE-OP with the error
//!   indication and 0x001B (ETG.1000.6 Table 11).
//! - The master acknowledges and requests OP: the drive is in OP again.
//! - Then the drive's MCU stops for 300 ms: the ESC answers on with the AL status as last
//!   written, its PDI watchdog (100 ms) expires (DL status 0x0110 bit 1 clear, 0x0443 = 1); the
//!   MCU restarts with the ESC as it was: INIT with the error indication and 0x0060 "slave
//!   restarted locally" (ETG.1000.6 Table 11); the master's start-up brings it to OP again.
//! - Then the master's interface goes down for 0.5 s: `attach` sees its own end of the veth
//!   lose the carrier and pulls the cable of the first drive, which drops to SAFE-OP with
//!   0x001B; acknowledged, it is in OP again.

use tests_host::soem::run_script;

/// AL status (ETG.1000.6 Table 9).
const OP: u64 = 0x08;
const SAFEOP_ERROR: u64 = 0x14;
const SAFEOP: u64 = 0x04;
const SM_WATCHDOG: u64 = 0x001B;
const INIT_ERROR: u64 = 0x11;
const RESTARTED_LOCALLY: u64 = 0x0060;

#[test]
fn soem_sees_lost_frames_a_pulled_cable_a_stopped_mcu_and_its_interface_down_and_recovers() {
    let (r, log) = run_script(
        "bus_fault_scenario.py",
        "standard",
        1,
        &[
            "--lose-every",
            "10",
            "--pull-cable-at-ms",
            "6000",
            "--pull-cable-for-ms",
            "300",
            "--halt-mcu-at-ms",
            "9000",
            "--halt-mcu-for-ms",
            "300",
        ],
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(r["op"], true, "OP with lost frames: {r}");
    assert!(log.contains("cable to drive 0 pulled"), "{log}");
    assert!(log.contains("cable to drive 0 plugged in"), "{log}");
    let cycles = r["cycles_before_pull"].as_u64().expect("cycles");
    let errors = r["wkc_errors_before_pull"].as_u64().expect("errors");
    assert!(cycles > 500, "ran before the pull: {r}");
    let share = errors as f64 / cycles as f64;
    assert!(
        (0.05..=0.2).contains(&share),
        "working-counter errors in {errors} of {cycles} cycles"
    );
    let states: Vec<(u64, u64)> = r["states_while_losing"]
        .as_array()
        .expect("states")
        .iter()
        .map(|s| (s[0].as_u64().expect("u16"), s[1].as_u64().expect("u16")))
        .collect();
    assert_eq!(states, [(OP, 0)], "OP throughout the frame loss");
    assert_eq!(r["cable_pulled_seen"], true, "{r}");
    assert_eq!(r["after_pull"][0], SAFEOP_ERROR, "{r}");
    assert_eq!(r["after_pull"][1], SM_WATCHDOG, "{r}");
    assert_eq!(r["after_ack"][0], SAFEOP, "{r}");
    assert_eq!(r["recovered"], true, "{r}");
    assert_eq!(r["final"][0], OP, "{r}");

    assert!(log.contains("drive 0's MCU stopped"), "{log}");
    assert_eq!(r["pdi_expired_seen"], true, "{r}");
    assert_eq!(r["al_while_halted"][0], OP, "{r}");
    assert_eq!(r["pdi_expiries"], 1, "{r}");
    assert_eq!(r["after_restart"][0], INIT_ERROR, "{r}");
    assert_eq!(r["after_restart"][1], RESTARTED_LOCALLY, "{r}");
    assert_eq!(r["slave_count_again"], 1, "{r}");
    assert_eq!(r["op_again"], true, "{r}");
    assert_eq!(r["final_again"][0], OP, "{r}");

    assert_eq!(
        log.matches("cable to drive 0 pulled").count(),
        2,
        "the interface going down is a pulled cable: {log}"
    );
    assert_eq!(r["after_interface_down"][0], SAFEOP_ERROR, "{r}");
    assert_eq!(r["after_interface_down"][1], SM_WATCHDOG, "{r}");
    assert_eq!(r["op_after_interface_down"], true, "{r}");
    assert_eq!(r["final_after_interface_down"][0], OP, "{r}");
}
