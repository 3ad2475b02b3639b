//! Distributed clocks: receive-time latch, system time, drift loop, SYNC0/SYNC1.

use super::*;
use hal::esc::{regs, AlEvent};
use hal::pdi::{EscPdi, EscSignals};

const HOP_NS: u64 = 310; // forward delay + cable of the sim

/// What a master does at DC init: latch, compute delays and offsets so that every system time
/// follows ESC 0 (the reference). Returns the delays.
fn dc_init(escs: &mut [Et1100]) -> Vec<u64> {
    let n = escs.len();
    send1(escs, BWR, 0, regs::DC_RECEIVE_TIME_PORT0.addr, &[0; 4]);
    let mut rx0 = Vec::new();
    let mut rx1 = Vec::new();
    let mut pu = Vec::new();
    for k in 0..n {
        let (r, _) = fprd(escs, k, regs::DC_RECEIVE_TIME_PORT0.addr, 8);
        rx0.push(u32le(&r));
        rx1.push(u32le(&r[4..]));
        pu.push(u64le(&fprd(escs, k, regs::DC_RECEIVE_TIME_PU.addr, 8).0));
    }
    let loop_time = |k: usize| {
        if k + 1 < n {
            u64::from(rx1[k].wrapping_sub(rx0[k]))
        } else {
            0
        }
    };
    let mut delays = vec![0u64];
    for k in 1..n {
        delays.push(delays[k - 1] + (loop_time(k - 1) - loop_time(k)) / 2);
    }
    for k in 0..n {
        let offset = pu[0].wrapping_add(delays[k]).wrapping_sub(pu[k]);
        fpwr(
            escs,
            k,
            regs::DC_SYSTEM_TIME_OFFSET.addr,
            &offset.to_le_bytes(),
        );
        fpwr(
            escs,
            k,
            regs::DC_SYSTEM_TIME_DELAY.addr,
            &(delays[k] as u32).to_le_bytes(),
        );
    }
    delays
}

fn clocked_ring() -> Vec<Et1100> {
    let mut escs = ring(3);
    escs[0].set_clock(5_000_000_000, 3.0);
    escs[1].set_clock(1_234_567, -4.0);
    escs[2].set_clock(987_654_321_000, 8.0);
    escs
}

#[test]
fn dc_latch_gives_sane_propagation_delays_for_three_slaves() {
    let mut escs = clocked_ring();
    let delays = dc_init(&mut escs);
    // Symmetric hops: the master's estimate equals the forward delay, within clock rounding.
    assert_eq!(delays, vec![0, HOP_NS, 2 * HOP_NS]);
    for k in 0..3 {
        let r = fprd(&mut escs, k, regs::DC_RECEIVE_TIME_PORT0.addr, 4).0;
        let pu = fprd(&mut escs, k, regs::DC_RECEIVE_TIME_PU.addr, 8).0;
        assert_eq!(u32le(&r), u32le(&pu), "0x0918 latches with 0x0900");
    }
}

#[test]
fn dc_latch_of_single_slave_has_no_port1_loop() {
    let mut escs = ring(1);
    let t = escs[0].local_time_at(0);
    send1(&mut escs, BWR, 0, regs::DC_RECEIVE_TIME_PORT0.addr, &[0; 4]);
    let r = fprd(&mut escs, 0, regs::DC_RECEIVE_TIME_PORT0.addr, 8).0;
    assert_eq!((u32le(&r), u32le(&r[4..])), (t as u32, 0));
}

#[test]
fn system_time_read_is_local_time_plus_offset() {
    let mut escs = ring(1);
    escs[0].set_clock(1_000, 0.0);
    escs[0].advance_to(5_000);
    fpwr(
        &mut escs,
        0,
        regs::DC_SYSTEM_TIME_OFFSET.addr,
        &1_000_000u64.to_le_bytes(),
    );
    let (r, wkc) = fprd(&mut escs, 0, regs::DC_SYSTEM_TIME.addr, 8);
    assert_eq!((u64le(&r), wkc), (1_000 + 5_000 + 1_000_000, 1));
}

#[test]
fn frmw_drift_loop_converges() {
    let mut escs = clocked_ring();
    dc_init(&mut escs);
    // Disturb ESC 1 by 2 us and let the cyclic FRMW 0x0910 (SOEM style, 1 ms) pull it back.
    let off = u64le(&fprd(&mut escs, 1, regs::DC_SYSTEM_TIME_OFFSET.addr, 8).0);
    fpwr(
        &mut escs,
        1,
        regs::DC_SYSTEM_TIME_OFFSET.addr,
        &(off + 2_000).to_le_bytes(),
    );
    let diff_ns = |escs: &mut Vec<Et1100>, k: usize| {
        let v = u32le(&fprd(escs, k, regs::DC_SYSTEM_TIME_DIFF.addr, 4).0);
        v & 0x7FFF_FFFF
    };
    let mut first = None;
    for i in 1..=400u64 {
        for e in escs.iter_mut() {
            e.advance_to(i * 1_000_000);
        }
        let (_, wkc) = send1(
            &mut escs,
            FRMW,
            station(0),
            regs::DC_SYSTEM_TIME.addr,
            &[0; 8],
        );
        assert_eq!(wkc, 3);
        first.get_or_insert(diff_ns(&mut escs, 1));
    }
    assert!(
        (1_900..2_100).contains(&first.unwrap()),
        "first diff {first:?}"
    );
    let t = escs[0].now();
    for k in 1..3 {
        assert!(
            diff_ns(&mut escs, k) < 100,
            "ESC {k} diff {}",
            diff_ns(&mut escs, k)
        );
        let skew = escs[k].system_time_at(t) as i64 - escs[0].system_time_at(t) as i64;
        assert!(skew.abs() < 100, "ESC {k} skew {skew} ns");
    }
}

/// `n` cycles of 1 ms, each distributing the reference's system time with FRMW 0x0910 (the
/// masters' drift compensation).
fn frmw_cycles(escs: &mut [Et1100], n: u64) {
    let start = escs.first().map_or(0, Et1100::now);
    for i in 1..=n {
        for e in escs.iter_mut() {
            e.advance_to(start + i * 1_000_000);
        }
        send1(escs, FRMW, station(0), regs::DC_SYSTEM_TIME.addr, &[0; 8]);
    }
}

#[test]
fn crystals_at_opposite_tolerance_limits_lock() {
    // ET1100 crystals: 25 MHz ± 25 ppm, so two ESCs may run 50 ppm apart; the time control loop
    // (0x0930 at its reset value, as masters write it) must hold them together.
    let mut escs = clocked_ring();
    escs[0].set_clock(5_000_000_000, 25.0);
    escs[1].set_clock(1_234_567, -25.0);
    dc_init(&mut escs);
    frmw_cycles(&mut escs, 2_000);
    let t = escs[0].now();
    let skew = escs[1].system_time_at(t) as i64 - escs[0].system_time_at(t) as i64;
    assert!(skew.abs() < 100, "skew {skew} ns after 2 s");
}

#[test]
fn speed_counter_write_resets_the_loop() {
    let mut escs = ring(1);
    escs[0].set_clock(1_000_000, 0.0);
    let span = |e: &Et1100| e.local_time_at(1_000_000_000) - e.local_time_at(0);
    // A blanking write of 0 to 0x0910 (masters' reset) is a large difference: the loop slews...
    send1(&mut escs, BWR, 0, regs::DC_SYSTEM_TIME.addr, &[0; 8]);
    assert!(span(&escs[0]) < 1_000_000_000);
    // ... until the write of 0x0930 that follows resets it.
    send1(
        &mut escs,
        BWR,
        0,
        regs::DC_SPEED_COUNTER_START.addr,
        &0x1000u16.to_le_bytes(),
    );
    assert_eq!(span(&escs[0]), 1_000_000_000);
}

/// Activates SYNC0 (and SYNC1 with `sync1` > 0) with the first pulse `lead` ns of system time
/// after now. Returns the start time.
fn activate(escs: &mut [Et1100], lead: i64, cycle0: u32, sync1: u32) -> u64 {
    let s = u64le(&fprd(escs, 0, regs::DC_SYSTEM_TIME.addr, 8).0);
    let start = s.wrapping_add_signed(lead);
    fpwr(escs, 0, regs::DC_ACTIVATION.addr, &[0]);
    fpwr(escs, 0, regs::DC_START_TIME.addr, &start.to_le_bytes());
    let mut cyc = cycle0.to_le_bytes().to_vec();
    cyc.extend_from_slice(&sync1.to_le_bytes());
    fpwr(escs, 0, regs::DC_SYNC0_CYCLE.addr, &cyc);
    let act = if sync1 > 0 { 0x07 } else { 0x03 };
    fpwr(escs, 0, regs::DC_ACTIVATION.addr, &[act]);
    start
}

#[test]
fn sync0_fires_at_start_time_then_every_cycle() {
    let mut escs = ring(1);
    escs[0].advance_to(10_000);
    let start = activate(&mut escs, 1_000_000, 250_000, 0);
    assert_eq!(
        u64le(&fprd(&mut escs, 0, regs::DC_START_TIME.addr, 8).0),
        start
    );
    let t1 = escs[0].next_event_ns().unwrap();
    escs[0].advance_to(t1 - 10);
    assert!(!escs[0].take_sync0());
    escs[0].advance_to(t1);
    assert!(escs[0].take_sync0());
    assert!(escs[0].al_event_request().any(AlEvent::SYNC0));
    assert_eq!(escs[0].read_u8(regs::DC_SYNC0_STATUS.addr).unwrap(), 1);
    assert!(
        !escs[0].al_event_request().any(AlEvent::SYNC0),
        "PDI read of 0x098E acknowledges"
    );
    let sys = escs[0].system_time_at(t1);
    assert!(
        sys >= start && sys - start < 5,
        "first pulse at start time: {}",
        sys - start
    );
    for k in 1..=8u64 {
        let t = escs[0].next_event_ns().unwrap();
        escs[0].advance_to(t);
        assert!(escs[0].take_sync0());
        let sys = escs[0].system_time_at(t);
        let want = start + k * 250_000;
        assert!(
            sys >= want && sys - want < 5,
            "pulse {k} off by {}",
            sys - want
        );
        let next = u64le(&fprd(&mut escs, 0, regs::DC_START_TIME.addr, 8).0);
        assert_eq!(next, want + 250_000, "0x0990 reads the next SYNC0 time");
    }
}

#[test]
fn sync1_follows_each_sync0_by_its_cycle_time() {
    let mut escs = ring(1);
    let start = activate(&mut escs, 100_000, 250_000, 100_000);
    let mut seen = Vec::new();
    for _ in 0..6 {
        let t = escs[0].next_event_ns().unwrap();
        escs[0].advance_to(t);
        let (s0, s1) = (escs[0].take_sync0(), escs[0].take_sync1());
        seen.push((
            s0,
            s1,
            escs[0].system_time_at(t).saturating_sub(start) / 1000,
        ));
    }
    assert_eq!(
        seen,
        vec![
            (true, false, 0),
            (false, true, 100),
            (true, false, 250),
            (false, true, 350),
            (true, false, 500),
            (false, true, 600)
        ]
    );
}

#[test]
fn sync1_cycle_multiple_of_sync0_fires_with_every_nth_sync0() {
    let mut escs = ring(1);
    let start = activate(&mut escs, 100_000, 250_000, 500_000);
    let mut sync1_at = Vec::new();
    // SYNC0 every 250 us; SYNC1 coincides with every 2nd one (same event): 9 events to 2 ms.
    for _ in 0..9 {
        let t = escs[0].next_event_ns().unwrap();
        escs[0].advance_to(t);
        escs[0].take_sync0();
        if escs[0].take_sync1() {
            sync1_at.push(escs[0].system_time_at(t).saturating_sub(start) / 1000);
        }
    }
    assert_eq!(sync1_at, vec![500, 1000, 1500, 2000]);
}

#[test]
fn start_time_in_the_past_sets_status_and_fires_on_next_aligned_cycle() {
    let mut escs = ring(1);
    escs[0].advance_to(1_000_000);
    let start = activate(&mut escs, -10_000, 250_000, 0);
    let st = fprd(&mut escs, 0, regs::DC_ACTIVATION_STATUS.addr, 1).0[0];
    assert_eq!(st & 0x04, 0x04);
    let t = escs[0].next_event_ns().unwrap();
    escs[0].advance_to(t);
    assert!(escs[0].take_sync0());
    let sys = escs[0].system_time_at(t);
    assert!(sys >= start + 250_000 && sys - (start + 250_000) < 5);
}

#[test]
fn sync_pin_and_event_need_the_sync_configuration_of_0x0151() {
    let mut escs = vec![Et1100::new(&sii_with(0))];
    send1(
        &mut escs,
        APWR,
        0,
        regs::STATION_ADDRESS.addr,
        &station(0).to_le_bytes(),
    );
    activate(&mut escs, 1_000, 250_000, 0);
    let t = escs[0].next_event_ns().unwrap();
    escs[0].advance_to(t);
    assert!(!escs[0].take_sync0());
    assert!(!escs[0].al_event_request().any(AlEvent::SYNC0));
    assert_eq!(
        escs[0].read_u8(regs::DC_SYNC0_STATUS.addr).unwrap(),
        1,
        "status still set"
    );
}

#[test]
fn deactivating_cyclic_operation_stops_pulses() {
    let mut escs = ring(1);
    activate(&mut escs, 1_000, 250_000, 0);
    fpwr(&mut escs, 0, regs::DC_ACTIVATION.addr, &[0]);
    escs[0].advance_to(10_000_000);
    assert!(!escs[0].take_sync0());
}

#[test]
fn fresh_escs_get_distinct_clocks_by_ring_position() {
    let escs = ring(3);
    let rate =
        |e: &Et1100| e.local_time_at(2_000_000_000) as i64 - e.local_time_at(1_000_000_000) as i64;
    let rates: Vec<i64> = escs.iter().map(rate).collect();
    assert_eq!(rates, vec![1_000_003_000, 999_998_000, 1_000_004_500]);
    assert_eq!(
        escs[2].local_time_at(0) - escs[0].local_time_at(0),
        2 * 1_234_567
    );
}

#[test]
fn frmw_loop_converges_with_default_ring_clocks() {
    let mut escs = ring(3);
    dc_init(&mut escs);
    frmw_cycles(&mut escs, 300);
    let t = escs[0].now();
    for k in 1..3 {
        let skew = escs[k].system_time_at(t) as i64 - escs[0].system_time_at(t) as i64;
        assert!(skew.abs() < 100, "ESC {k} skew {skew} ns");
    }
}
