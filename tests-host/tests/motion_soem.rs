//! SOEM (pysoem) homes the simulated standard drive (method 34, the index pulse in the positive
//! direction) and runs a profile-position move over the default PDOs with DC SYNC0
//! (`tests-host/soem/motion_scenario.py`): homing in progress then attained (statusword bits
//! 13/12/10), 6064h = 607Ch at the home, then the set-point acknowledged (bit 12) and the
//! target reached (bit 10) with 6064h on the target. The in-process tests (`homing.rs`,
//! `profile_modes.rs`) cover the methods and handshakes in detail.

use serde_json::Value;
use tests_host::soem::run_script;

const STATE_MASK: u64 = 0x6F;
const OPERATION_ENABLED: u64 = 0x27;
const HOMING_BITS: u64 = 0x3400;
const HOMING_COMPLETED: u64 = 0x1400;
const TARGET_REACHED: u64 = 0x0400;
const SET_POINT_ACKNOWLEDGE: u64 = 0x1000;
/// Within this many increments of the target (the standard position window 6067h is 1000).
const WINDOW: i64 = 1000;

fn u(v: &Value) -> u64 {
    v.as_u64().unwrap_or_else(|| panic!("not a number: {v}"))
}

fn i(v: &Value) -> i64 {
    v.as_i64().unwrap_or_else(|| panic!("not a number: {v}"))
}

#[test]
fn soem_homes_the_standard_drive_and_runs_a_profile_position_move() {
    let (r, log) =
        run_script("motion_scenario.py", "standard", 1, &[]).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(u(&r["slave_count"]), 1, "{log}");
    assert_eq!(
        u(&r["enabled_statusword"]) & STATE_MASK,
        OPERATION_ENABLED,
        "{r}"
    );
    assert_eq!(i(&r["homing_display"]), 6, "6061h shows homing");
    assert_eq!(
        u(&r["homing_not_started"]) & HOMING_BITS,
        TARGET_REACHED,
        "not started: 0/0/1"
    );
    assert_eq!(r["homing_in_progress_seen"], Value::Bool(true), "{r}");
    assert_eq!(
        u(&r["homing_statusword"]) & HOMING_BITS,
        HOMING_COMPLETED,
        "{r}"
    );
    let offset = i(&r["home_offset"]);
    assert!(
        (i(&r["homed_actual"]) - offset).abs() <= 100,
        "6064h = 607Ch at the home: {r}"
    );
    assert_eq!(i(&r["pp_display"]), 1, "6061h shows profile position");
    assert_eq!(r["pp_acknowledged"], Value::Bool(true), "{r}");
    assert_eq!(r["pp_moving_not_reached_seen"], Value::Bool(true), "{r}");
    let sw = u(&r["pp_statusword"]);
    assert_eq!(sw & TARGET_REACHED, TARGET_REACHED, "{r}");
    assert_eq!(sw & SET_POINT_ACKNOWLEDGE, 0, "{r}");
    assert!(
        (i(&r["pp_actual"]) - i(&r["pp_target"])).abs() <= WINDOW,
        "6064h on the target: {r}"
    );
}
