//! A mode of operation a profile does not support (not in its 6502h) is not taken, in every
//! profile: ethercrab runs the drive in cyclic synchronous velocity (DC SYNC0 at 1 ms; 6040h,
//! 6060h, 60FFh / 6041h, 6061h, 606Ch mapped) and writes each CiA402 mode 1–10 the profile's
//! 6502h leaves out into 6060h by PDO: 6061h keeps showing the mode the drive runs, the drive
//! stays in Operation Enabled without a fault, and the motor keeps following 60FFh (the
//! Σ-V-SD's 6060h text: "2 and others reserved (keep last mode)"; the other manuals list their
//! modes and say nothing else, so the drive keeps running as CiA402 leaves it). A supported mode
//! written afterwards is taken.

use std::f64::consts::TAU;

use board_sim::inproc::InProcess;
use ethercrab::MainDevice;
use tests_host::vendor::{self, DcGroup};
use tests_host::{block_on, cia402, master_for, units};

const CYCLE_NS: u64 = 1_000_000;
const CSV: i8 = cia402::CYCLIC_SYNCHRONOUS_VELOCITY;
const PROFILE_VELOCITY: i8 = 3;
const FAULT_BIT: u16 = 1 << 3;
const SPEED_REV_S: f64 = 2.0;

/// Statusword and 6061h of one cycle.
async fn cycle(
    m: &InProcess,
    md: &MainDevice<'_>,
    group: &DcGroup,
    (mode, velocity): (i8, i32),
) -> (u16, i8) {
    let inputs = vendor::exchange_dc_command(
        m,
        md,
        group,
        (vendor::ENABLE_OPERATION, mode, velocity),
        CYCLE_NS,
    )
    .await;
    (vendor::u16_at(&inputs, 0), inputs[2] as i8)
}

fn motor_rev_s(m: &InProcess) -> f64 {
    m.shared.segment().drives()[0].servos[0]
        .plant
        .mech_speed_rad_s()
        / TAU
}

fn unsupported_modes_are_not_taken(name: &str) {
    let profile = od_gen::builtin(name).expect("profile");
    let supported = cia402::supported_modes(&profile);
    // 6502h bit n-1 is mode n (CiA402: bit 0 PP ... bit 9 CST).
    let unsupported: Vec<i8> = (1..=10i8)
        .filter(|mode| supported & (1 << (mode - 1)) == 0)
        .collect();
    assert!(!unsupported.is_empty(), "{name}: every mode supported");
    block_on(async {
        let (m, transport) = master_for(board_sim::Segment::new(name, 1).expect("profile"));
        tokio::task::spawn_local(transport);
        let md: &MainDevice<'_> = &m.maindevice;
        let group = vendor::into_op_dc_velocity(&m, md, (0, &[]), CSV, CYCLE_NS).await;
        for cw in vendor::enable_sequence(20) {
            vendor::exchange_dc_command(&m, md, &group, (cw, CSV, 0), CYCLE_NS).await;
        }
        let velocity = units::target_velocity(&profile, SPEED_REV_S);
        let mut s = (0, 0);
        for _ in 0..300 {
            s = cycle(&m, md, &group, (CSV, velocity)).await;
        }
        assert!(
            cia402::is(s.0, cia402::OPERATION_ENABLED),
            "{name}: {:#06x}",
            s.0
        );
        for mode in unsupported {
            for _ in 0..20 {
                s = cycle(&m, md, &group, (mode, velocity)).await;
            }
            assert_eq!(s.1, CSV, "{name}: 6060h = {mode} not taken, 6061h");
            assert!(
                cia402::is(s.0, cia402::OPERATION_ENABLED) && s.0 & FAULT_BIT == 0,
                "{name}: 6060h = {mode}: still Operation Enabled, no fault: {:#06x}",
                s.0
            );
            let speed = motor_rev_s(&m);
            assert!(
                (speed - SPEED_REV_S).abs() < 0.1,
                "{name}: 6060h = {mode}: the motor follows 60FFh: {speed:.2} rev/s"
            );
        }
        for _ in 0..20 {
            s = cycle(&m, md, &group, (PROFILE_VELOCITY, velocity)).await;
        }
        assert_eq!(s.1, PROFILE_VELOCITY, "{name}: a supported mode is taken");
    });
}

#[test]
fn standard_unsupported_modes_are_not_taken() {
    unsupported_modes_are_not_taken("standard");
}

#[test]
fn gha_e_unsupported_modes_are_not_taken() {
    unsupported_modes_are_not_taken("gha-e");
}

#[test]
fn rse_unsupported_modes_are_not_taken() {
    unsupported_modes_are_not_taken("rse");
}

#[test]
fn sdv3_e_unsupported_modes_are_not_taken() {
    unsupported_modes_are_not_taken("sdv3-e");
}

#[test]
fn osd_g_e_unsupported_modes_are_not_taken() {
    unsupported_modes_are_not_taken("osd-g-e");
}

#[test]
fn sigma_v_sd_unsupported_modes_are_not_taken() {
    unsupported_modes_are_not_taken("sigma-v-sd");
}
