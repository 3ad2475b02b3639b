//! Watchdogs: process-data (SM) watchdog and PDI watchdog, timed by simulated time.

use super::*;
use hal::esc::{regs, AlEvent, DlStatus};
use hal::pdi::EscPdi;

const TICK_NS: u64 = 100_000; // (0x09C2 + 2) x 40 ns

#[test]
fn sm_watchdog_expires_after_configured_time() {
    let mut escs = ring(1);
    fpwr(
        &mut escs,
        0,
        regs::sm(2).addr,
        &sm_bytes(0x1200, 2, 0x64, 1),
    );
    fpwr(
        &mut escs,
        0,
        regs::WATCHDOG_TIME_PD.addr,
        &100u16.to_le_bytes(),
    );
    escs[0].advance_to(1_000_000);
    assert_eq!(fpwr(&mut escs, 0, 0x1200, &[1, 2]), 1); // trigger at 1 ms
    let deadline = 1_000_000 + 100 * TICK_NS;
    assert_eq!(escs[0].next_event_ns(), Some(deadline));
    escs[0].advance_to(deadline - 1);
    assert_eq!(
        fprd(&mut escs, 0, regs::WATCHDOG_STATUS_PD.addr, 2).0,
        vec![1, 0]
    );
    escs[0].advance_to(deadline);
    assert_eq!(
        fprd(&mut escs, 0, regs::WATCHDOG_STATUS_PD.addr, 2).0,
        vec![0, 0]
    );
    assert_eq!(
        fprd(&mut escs, 0, regs::WATCHDOG_COUNTER_PD.addr, 1).0,
        vec![1]
    );
    assert!(escs[0].al_event_request().any(AlEvent::WATCHDOG_PD));
    escs[0].read_u16(regs::WATCHDOG_STATUS_PD.addr).unwrap();
    assert!(
        !escs[0].al_event_request().any(AlEvent::WATCHDOG_PD),
        "PDI read of 0x0440 acks"
    );
    fpwr(&mut escs, 0, 0x1200, &[1, 2]);
    assert_eq!(
        fprd(&mut escs, 0, regs::WATCHDOG_STATUS_PD.addr, 1).0,
        vec![1],
        "retriggered"
    );
    fpwr(&mut escs, 0, regs::WATCHDOG_COUNTER_PD.addr, &[0]);
    assert_eq!(
        fprd(&mut escs, 0, regs::WATCHDOG_COUNTER_PD.addr, 1).0,
        vec![0],
        "ECAT write clears"
    );
}

#[test]
fn sm_watchdog_ignores_sms_without_trigger_bit_and_zero_disables() {
    let mut escs = ring(1);
    fpwr(
        &mut escs,
        0,
        regs::sm(2).addr,
        &sm_bytes(0x1200, 2, 0x24, 1),
    );
    fpwr(&mut escs, 0, 0x1200, &[1, 2]);
    escs[0].advance_to(500_000_000);
    assert_eq!(
        fprd(&mut escs, 0, regs::WATCHDOG_STATUS_PD.addr, 1).0,
        vec![1]
    );
    let mut escs = ring(1);
    fpwr(
        &mut escs,
        0,
        regs::sm(2).addr,
        &sm_bytes(0x1200, 2, 0x64, 1),
    );
    fpwr(&mut escs, 0, regs::WATCHDOG_TIME_PD.addr, &[0, 0]);
    fpwr(&mut escs, 0, 0x1200, &[1, 2]);
    escs[0].advance_to(500_000_000);
    assert_eq!(
        fprd(&mut escs, 0, regs::WATCHDOG_STATUS_PD.addr, 1).0,
        vec![1]
    );
}

#[test]
fn watchdog_divider_scales_the_tick() {
    let mut escs = ring(1);
    fpwr(
        &mut escs,
        0,
        regs::sm(2).addr,
        &sm_bytes(0x1200, 2, 0x64, 1),
    );
    fpwr(
        &mut escs,
        0,
        regs::WATCHDOG_DIVIDER.addr,
        &23u16.to_le_bytes(),
    ); // 1 us tick
    fpwr(
        &mut escs,
        0,
        regs::WATCHDOG_TIME_PD.addr,
        &50u16.to_le_bytes(),
    );
    fpwr(&mut escs, 0, 0x1200, &[1, 2]);
    escs[0].advance_to(50_000);
    assert_eq!(
        fprd(&mut escs, 0, regs::WATCHDOG_STATUS_PD.addr, 1).0,
        vec![0]
    );
}

#[test]
fn pdi_watchdog_expires_without_pdi_access_and_recovers_on_access() {
    let mut escs = ring(1);
    fpwr(
        &mut escs,
        0,
        regs::WATCHDOG_TIME_PDI.addr,
        &10u16.to_le_bytes(),
    );
    escs[0].read_u8(0).unwrap(); // trigger at 0
    escs[0].advance_to(10 * TICK_NS - 1);
    let dl = |escs: &mut Vec<Et1100>| u16le(&fprd(escs, 0, regs::DL_STATUS.addr, 2).0);
    assert_ne!(dl(&mut escs) & DlStatus::PDI_WATCHDOG_OK, 0);
    escs[0].advance_to(10 * TICK_NS);
    assert_eq!(dl(&mut escs) & DlStatus::PDI_WATCHDOG_OK, 0);
    assert_eq!(
        fprd(&mut escs, 0, regs::WATCHDOG_COUNTER_PDI.addr, 1).0,
        vec![1]
    );
    escs[0].read_u8(0).unwrap();
    assert_ne!(dl(&mut escs) & DlStatus::PDI_WATCHDOG_OK, 0);
}
