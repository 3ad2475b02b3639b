//! SOEM (pysoem) homes the simulated drive of every profile with one of its homing methods and
//! runs a profile-position move over the profile's default PDOs with DC SYNC0 at 1 ms
//! (`tests-host/soem/motion_scenario.py`, which holds each profile's units and PDO layout):
//! homing in progress (a search method) then completed (statusword bits 13/12/10 = 0/0/0, then
//! 0/1/1), 6064h = 607Ch at the home, then the set-point acknowledged (bit 12) and the target
//! reached (bit 10) with 6064h on the absolute target within the drive's position window 6067h.
//! Positions are compared in each profile's position unit (`[units] position`, its defaults).
//!
//! | profile | method | machine (`sim-drive attach`) | position unit |
//! |---|---|---|---|
//! | standard | 34 index, positive | — | 1 inc |
//! | sdv3-e | 20 home switch rising edge | home switch at 0.4 rev | 6093h = 16 inc |
//! | osd-g-e | 20 home switch rising edge | home switch at 0.4 rev | 6093h = 16 inc |
//! | rse | 20 home switch rising edge | home switch at 0.4 rev | 6091h = 1 inc |
//! | gha-e | 3 home switch, then index | home switch at 0.4 rev | 6091h = 13.1072 inc |
//! | sigma-v-sd | 1 negative limit, then index | limits at −0.7 / +3 rev | 2301h = 1 inc |
//! | sigma-v-sd-2axis (axis 1) | 34 index, positive | — | 2301h = 1 inc |
//!
//! The SDV3-E and OSD-G-E have no 609Ah (homing acceleration): they home on their profile
//! acceleration 6083h.
//!
//! The in-process tests (`homing_methods.rs`: every method of every profile; `homing.rs`,
//! `profile_modes.rs`, `vendor_modes.rs`) cover the methods
//! and handshakes in detail. The scenarios run one at a time: each one is a wall-clock master
//! next to a real-time simulator.

use std::sync::{Mutex, PoisonError};

use serde_json::Value;
use tests_host::soem::run_script;
use tests_host::units::increments_per_unit;

const STATE_MASK: u64 = 0x6F;
const OPERATION_ENABLED: u64 = 0x27;
const HOMING_BITS: u64 = 0x3400;
const HOMING_COMPLETED: u64 = 0x1400;
const TARGET_REACHED: u64 = 0x0400;
const SET_POINT_ACKNOWLEDGE: u64 = 0x1000;
/// Controlword bit 6 in profile position: absolute/relative.
const BIT6: u64 = 0x40;
/// 6061h values.
const HM: i64 = 6;
const PP: i64 = 1;
/// 6064h at the home within this many increments of 607Ch (in each profile's position units).
const HOME_TOLERANCE_INC: f64 = 100.0;
/// The homing method that takes the current position as the home (no search, done at once).
const CURRENT_POSITION: i64 = 35;

/// The SOEM scenarios of this file run one after the other.
static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());

fn u(v: &Value) -> u64 {
    v.as_u64().unwrap_or_else(|| panic!("not a number: {v}"))
}

fn i(v: &Value) -> i64 {
    v.as_i64().unwrap_or_else(|| panic!("not a number: {v}"))
}

/// Runs the scenario on a drive of `profile` attached with the switches of `machine`, checks
/// that it homed with `method`, then homing and the profile-position move.
fn run(profile: &str, machine: &[&str], method: i64) {
    let _guard = ONE_AT_A_TIME.lock().unwrap_or_else(PoisonError::into_inner);
    let p = od_gen::builtin(profile).expect("profile");
    let (r, log) =
        run_script("motion_scenario.py", profile, 1, machine).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(u(&r["slave_count"]), 1, "{log}");
    assert_eq!(r["profile"].as_str(), Some(profile), "{r}");
    assert_eq!(i(&r["method"]), method, "{r}");
    assert_eq!(
        u(&r["enabled_statusword"]) & STATE_MASK,
        OPERATION_ENABLED,
        "{r}\n{log}"
    );
    assert_homed(&r, method != CURRENT_POSITION, increments_per_unit(&p));
    assert_profile_position(&r, p.cia402.pp_bit6_absolute);
}

/// Homing: 6061h = 6, not started 0/0/1, in progress 0/0/0 (when `searches`), completed 0/1/1
/// (bits 13/12/10), 6064h = 607Ch at the home.
fn assert_homed(r: &Value, searches: bool, increments_per_unit: f64) {
    assert_eq!(i(&r["homing_display"]), HM, "6061h shows homing: {r}");
    assert_eq!(
        u(&r["homing_not_started"]) & HOMING_BITS,
        TARGET_REACHED,
        "not started: 0/0/1: {r}"
    );
    if searches {
        assert_eq!(r["homing_in_progress_seen"], Value::Bool(true), "{r}");
    }
    assert_eq!(
        u(&r["homing_statusword"]) & HOMING_BITS,
        HOMING_COMPLETED,
        "{r}"
    );
    let tolerance = (HOME_TOLERANCE_INC / increments_per_unit).ceil() as i64;
    assert!(
        (i(&r["homed_actual"]) - i(&r["home_offset"])).abs() <= tolerance,
        "6064h = 607Ch at the home (±{tolerance} units): {r}"
    );
}

/// Profile position: 6061h = 1, the absolute set-point acknowledged (bit 12), moving with bit 10
/// clear, then target reached with bit 12 clear and 6064h within 6067h of the target.
fn assert_profile_position(r: &Value, bit6_absolute: bool) {
    assert_eq!(i(&r["pp_display"]), PP, "6061h shows profile position: {r}");
    let absolute = if bit6_absolute { BIT6 } else { 0 };
    assert_eq!(
        u(&r["pp_controlword"]) & BIT6,
        absolute,
        "bit 6 of an absolute move: {r}"
    );
    assert_eq!(r["pp_acknowledged"], Value::Bool(true), "{r}");
    assert_eq!(r["pp_moving_not_reached_seen"], Value::Bool(true), "{r}");
    let sw = u(&r["pp_statusword"]);
    assert_eq!(sw & TARGET_REACHED, TARGET_REACHED, "{r}");
    assert_eq!(sw & SET_POINT_ACKNOWLEDGE, 0, "{r}");
    // The target is absolute: a relative move from the home would end 607Ch = 1000 units
    // further on, outside the SDV3-E's window of 100 units (bit 6 polarity).
    assert!(
        (i(&r["pp_actual"]) - i(&r["pp_target"])).abs() <= i(&r["position_window"]),
        "6064h on the target within 6067h: {r}"
    );
}

#[test]
fn soem_homes_the_standard_drive_and_runs_a_profile_position_move() {
    run("standard", &[], 34);
}

#[test]
fn soem_sdv3_e_homing_method_20_home_switch_and_profile_position_bit6_absolute() {
    run("sdv3-e", &["--home-switch-rev", "0.4"], 20);
}

#[test]
fn soem_osd_g_e_homing_method_20_home_switch_and_profile_position_bit6_absolute() {
    run("osd-g-e", &["--home-switch-rev", "0.4"], 20);
}

#[test]
fn soem_rse_homing_method_20_home_switch_and_profile_position() {
    run("rse", &["--home-switch-rev", "0.4"], 20);
}

#[test]
fn soem_gha_e_homing_method_3_home_switch_and_index_and_profile_position() {
    run("gha-e", &["--home-switch-rev", "0.4"], 3);
}

#[test]
fn soem_sigma_v_sd_homing_method_1_negative_limit_and_index_and_profile_position() {
    run("sigma-v-sd", &["--limit-switches-rev", "-0.7,3"], 1);
}

#[test]
fn soem_sigma_v_sd_2axis_axis_1_homing_method_34_index_and_profile_position() {
    run("sigma-v-sd-2axis", &[], 34);
}
