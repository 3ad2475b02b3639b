//! Frame level: Ethernet/EtherCAT framing, MAC U/L bit, robustness against malformed input.

use super::*;
use crate::esc::{FrameError, Segment};
use hal::esc::regs;

#[test]
fn returned_frame_has_locally_administered_source_mac() {
    // ethercrab drops replies whose source MAC equals its own 10:10:10:10:10:10 (masters.md 1.2).
    let mut escs = ring(1);
    let mut f = build_frame(&[dg(BRD, 0, 0, &[0])]);
    process_frame(&mut f, escs.iter_mut()).unwrap();
    assert_eq!(f[6], 0x12);
    assert_eq!(&f[7..12], &MASTER_MAC[1..]);
}

#[test]
fn non_ethercat_frame_is_rejected_and_left_untouched() {
    let mut escs = ring(1);
    let mut f = build_frame(&[dg(BRD, 0, 0, &[0])]);
    f[12] = 0x08;
    f[13] = 0x00;
    let before = f.clone();
    assert_eq!(
        process_frame(&mut f, escs.iter_mut()),
        Err(FrameError::NotEtherCat { ethertype: 0x0800 })
    );
    assert_eq!(f, before);
}

#[test]
fn overrunning_datagram_rejects_the_whole_frame_without_side_effects() {
    // A frame whose structure is broken would fail the FCS: no datagram of it takes effect.
    let mut escs = ring(1);
    let mut f = build_frame(&[
        dg(FPWR, station(0), regs::USER_RAM.addr, &[0xAA]),
        dg(BRD, 0, 0, &[0]),
    ]);
    let n = f.len();
    f.truncate(n - 1);
    let len = u16::from_le_bytes([f[14], f[15]]) & 0x7FF;
    f[14..16].copy_from_slice(&((len - 1) | 0x1000).to_le_bytes());
    assert_eq!(
        process_frame(&mut f, escs.iter_mut()),
        Err(FrameError::DatagramOverrun { index: 1 })
    );
    assert_eq!(fprd(&mut escs, 0, regs::USER_RAM.addr, 1).0, vec![0]);
}

#[test]
fn ethercat_length_beyond_frame_is_rejected() {
    let mut escs = ring(1);
    let mut f = build_frame(&[dg(BRD, 0, 0, &[0])]);
    f[14..16].copy_from_slice(&(0x7FF_u16 | 0x1000).to_le_bytes());
    assert!(matches!(
        process_frame(&mut f, escs.iter_mut()),
        Err(FrameError::LengthMismatch { .. })
    ));
}

#[test]
fn padded_frame_is_processed() {
    // Real masters' frames come padded to 60 bytes; padding after the EtherCAT payload is ignored.
    let mut escs = ring(1);
    let mut f = build_frame(&[dg(BRD, 0, 0, &[0])]);
    f.resize(60, 0);
    process_frame(&mut f, escs.iter_mut()).unwrap();
    assert_eq!(parse_replies(&f)[0].wkc, 1);
}

/// xorshift64: deterministic pseudo-random bytes.
fn rng(state: &mut u64) -> u64 {
    *state ^= *state << 13;
    *state ^= *state >> 7;
    *state ^= *state << 17;
    *state
}

#[test]
fn random_and_malformed_frames_never_panic() {
    let mut seg = Segment::new((0..3).map(|_| esc()).collect());
    let mut s = 0x1234_5678_9ABC_DEF0_u64;
    for i in 0..20_000u64 {
        let len = (rng(&mut s) % 200) as usize;
        let mut f: Vec<u8> = (0..len).map(|_| rng(&mut s) as u8).collect();
        if i % 2 == 0 && f.len() >= 16 {
            // Valid-looking headers so that the datagram paths run on random content.
            f[12] = 0x88;
            f[13] = 0xA4;
            let body = (f.len() - 16) as u16;
            let claimed = if i % 4 == 0 {
                body
            } else {
                (rng(&mut s) as u16) & 0x7FF
            };
            f[14..16].copy_from_slice(&(claimed | 0x1000).to_le_bytes());
        }
        let _ = seg.process(&mut f);
        seg.advance_to(i * 1000);
    }
}

#[test]
fn structurally_valid_random_datagrams_never_panic() {
    let mut seg = Segment::new((0..3).map(|_| esc()).collect());
    let mut s = 0xDEAD_BEEF_u64;
    for i in 0..20_000u64 {
        let cmd = (rng(&mut s) % 16) as u8;
        let adp = rng(&mut s) as u16;
        let ado = match i % 3 {
            0 => (rng(&mut s) % 0x3100) as u16,
            1 => regs::EEPROM_CONFIG.addr + (rng(&mut s) % 0x500) as u16,
            _ => rng(&mut s) as u16,
        };
        let len = (rng(&mut s) % 80) as usize;
        let data: Vec<u8> = (0..len).map(|_| rng(&mut s) as u8).collect();
        let mut f = build_frame(&[dg(cmd, adp, ado, &data)]);
        seg.process(&mut f).unwrap();
        seg.advance_to(i * 10_000);
    }
}

#[test]
fn nop_passes_unchanged() {
    let mut escs = ring(2);
    let r = send(&mut escs, &[dg(NOP, 0x1234, 0x0000, &[1, 2])]).remove(0);
    assert_eq!((r.adp, r.data, r.wkc), (0x1234, vec![1, 2], 0));
}

#[test]
fn segment_marks_topology_and_reports_the_earliest_event() {
    use hal::esc::{regs, DlStatus};
    let seg = Segment::new((0..3).map(|_| esc()).collect());
    let mut b = [0u8; 2];
    seg.escs()[1].peek(regs::DL_STATUS.addr, &mut b);
    assert_ne!(u16::from_le_bytes(b) & DlStatus::communication(1), 0);
    seg.escs()[2].peek(regs::DL_STATUS.addr, &mut b);
    assert_ne!(u16::from_le_bytes(b) & DlStatus::loop_closed(1), 0);
    // Only the PDI watchdogs (1000 ticks of 100 us after power-on) are scheduled.
    assert_eq!(seg.next_event_ns(), Some(100_000_000));
}
