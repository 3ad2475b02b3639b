//! SyncManagers: mailbox and 3-buffer semantics, events, repeat, PDI deactivate.

use super::*;
use hal::esc::{regs, AlEvent, SmStatus};
use hal::pdi::EscPdi;

const MBX_OUT: u16 = 0x1000;
const MBX_IN: u16 = 0x1100;
const MBX_LEN: u16 = 16;
const OUT: u16 = 0x1200;
const IN: u16 = 0x1300;
const PD_LEN: u16 = 4;

/// One ESC with SM0/SM1 mailboxes and SM2/SM3 3-buffer process data.
fn configured() -> Vec<Et1100> {
    let mut escs = ring(1);
    let mut w = Vec::new();
    w.extend_from_slice(&sm_bytes(MBX_OUT, MBX_LEN, 0x26, 1));
    w.extend_from_slice(&sm_bytes(MBX_IN, MBX_LEN, 0x22, 1));
    w.extend_from_slice(&sm_bytes(OUT, PD_LEN, 0x64, 1));
    w.extend_from_slice(&sm_bytes(IN, PD_LEN, 0x20, 1));
    assert_eq!(fpwr(&mut escs, 0, regs::sm(0).addr, &w), 1);
    escs
}

fn status(escs: &mut [Et1100], n: u8) -> u8 {
    fprd(escs, 0, regs::sm(n).addr + regs::sm_offset::STATUS, 1).0[0]
}

#[test]
fn mailbox_becomes_full_when_last_byte_written_and_raises_sm_event() {
    let mut escs = configured();
    assert_eq!(fpwr(&mut escs, 0, MBX_OUT, &[1; 8]), 1);
    assert_eq!(
        status(&mut escs, 0) & SmStatus::MAILBOX_FULL,
        0,
        "last byte not yet written"
    );
    assert_eq!(fpwr(&mut escs, 0, MBX_OUT + 8, &[2; 8]), 1);
    assert_ne!(status(&mut escs, 0) & SmStatus::MAILBOX_FULL, 0);
    assert!(escs[0].al_event_request().any(AlEvent::sm(0)));
}

#[test]
fn mailbox_ecat_write_to_full_sm_gets_no_wkc() {
    let mut escs = configured();
    assert_eq!(fpwr(&mut escs, 0, MBX_OUT, &[7; 16]), 1);
    assert_eq!(
        fpwr(&mut escs, 0, MBX_OUT, &[9; 16]),
        0,
        "full mailbox: not executed"
    );
    let mut b = [0; 16];
    escs[0].read(MBX_OUT, &mut b).unwrap();
    assert_eq!(b, [7; 16], "first mail kept");
    assert_eq!(
        status(&mut escs, 0) & SmStatus::MAILBOX_FULL,
        0,
        "PDI read of last byte empties"
    );
    assert!(
        !escs[0].al_event_request().any(AlEvent::sm(0)),
        "PDI opening the buffer clears the event"
    );
    assert_eq!(fpwr(&mut escs, 0, MBX_OUT, &[9; 16]), 1);
}

#[test]
fn mailbox_ecat_read_of_empty_sm_gets_no_wkc_and_leaves_data() {
    let mut escs = configured();
    let (data, wkc) = send1(&mut escs, FPRD, station(0), MBX_IN, &[0xEE; 16]);
    assert_eq!((data, wkc), (vec![0xEE; 16], 0));
    escs[0].write(MBX_IN, &[3; 16]).unwrap();
    assert_ne!(status(&mut escs, 1) & SmStatus::MAILBOX_FULL, 0);
    let (data, wkc) = fprd(&mut escs, 0, MBX_IN, 16);
    assert_eq!((data, wkc), (vec![3; 16], 1));
    assert_eq!(
        status(&mut escs, 1) & SmStatus::MAILBOX_FULL,
        0,
        "emptied at the end of the frame"
    );
    assert!(
        escs[0].al_event_request().any(AlEvent::sm(1)),
        "read completely: SM1 event to the PDI"
    );
    escs[0].write(MBX_IN, &[4]).unwrap();
    assert!(
        !escs[0].al_event_request().any(AlEvent::sm(1)),
        "PDI opening the buffer clears it"
    );
}

#[test]
fn pdi_write_to_full_mailbox_is_ignored() {
    let mut escs = configured();
    escs[0].write(MBX_IN, &[5; 16]).unwrap();
    escs[0].write(MBX_IN, &[6; 16]).unwrap();
    assert_eq!(fprd(&mut escs, 0, MBX_IN, 16).0, vec![5; 16]);
}

#[test]
fn pdi_read_of_empty_mailbox_returns_zeros() {
    let mut escs = configured();
    let mut b = [0xAA; 4];
    escs[0].read(MBX_OUT, &mut b).unwrap();
    assert_eq!(b, [0; 4]);
}

#[test]
fn ecat_cannot_read_its_own_write_mailbox() {
    let mut escs = configured();
    fpwr(&mut escs, 0, MBX_OUT, &[1; 16]);
    assert_eq!(fprd(&mut escs, 0, MBX_OUT, 16).1, 0);
}

#[test]
fn repeat_request_raises_activation_event_and_pdi_acks_at_plus_7() {
    // SOEM toggles SM1 activate bit 1, then polls 0x080F bit 1 (ethercat-slave.md §2.3).
    let mut escs = configured();
    let act = regs::sm(1).addr + regs::sm_offset::ACTIVATE;
    let pdi = regs::sm(1).addr + regs::sm_offset::PDI_CONTROL;
    for n in 0..4 {
        // Ack the activations from the configuration (one flag per SM).
        escs[0]
            .read_u8(regs::sm(n).addr + regs::sm_offset::ACTIVATE)
            .unwrap();
    }
    assert!(!escs[0].al_event_request().any(AlEvent::SM_ACTIVATION));
    assert_eq!(fpwr(&mut escs, 0, act, &[0x03]), 1);
    assert!(escs[0].al_event_request().any(AlEvent::SM_ACTIVATION));
    assert_eq!(escs[0].read_u8(act).unwrap(), 0x03);
    assert!(!escs[0].al_event_request().any(AlEvent::SM_ACTIVATION));
    assert_eq!(fpwr(&mut escs, 0, pdi, &[0x02]), 1);
    assert_eq!(
        fprd(&mut escs, 0, pdi, 1).0,
        vec![0],
        "+7 is read-only for ECAT"
    );
    escs[0].write_u8(pdi, 0x02).unwrap();
    assert_eq!(fprd(&mut escs, 0, pdi, 1).0, vec![0x02]);
}

#[test]
fn pdi_deactivate_resets_and_locks_the_sm() {
    let mut escs = configured();
    fpwr(&mut escs, 0, MBX_OUT, &[1; 16]);
    let pdi = regs::sm(0).addr + regs::sm_offset::PDI_CONTROL;
    escs[0].write_u8(pdi, 0x01).unwrap();
    assert_eq!(status(&mut escs, 0) & SmStatus::MAILBOX_FULL, 0);
    assert_eq!(fpwr(&mut escs, 0, MBX_OUT, &[2; 16]), 0, "locked for ECAT");
    escs[0].write_u8(pdi, 0x00).unwrap();
    assert_eq!(fpwr(&mut escs, 0, MBX_OUT, &[2; 16]), 1);
}

#[test]
fn disabling_an_sm_resets_its_buffer_state() {
    let mut escs = configured();
    fpwr(&mut escs, 0, MBX_OUT, &[1; 16]);
    let act = regs::sm(0).addr + regs::sm_offset::ACTIVATE;
    fpwr(&mut escs, 0, act, &[0]);
    fpwr(&mut escs, 0, act, &[1]);
    assert_eq!(status(&mut escs, 0) & SmStatus::MAILBOX_FULL, 0);
    assert_eq!(fpwr(&mut escs, 0, MBX_OUT, &[2; 16]), 1);
}

#[test]
fn three_buffer_swaps_only_after_complete_write() {
    let mut escs = configured();
    let mut b = [0u8; 4];
    assert_eq!(fpwr(&mut escs, 0, OUT, &[1, 2]), 1);
    escs[0].read(OUT, &mut b).unwrap();
    assert_eq!(b, [0; 4], "no complete buffer yet");
    assert_eq!(
        status(&mut escs, 2) >> SmStatus::BUFFER_STATE_SHIFT & 3,
        3,
        "nothing written"
    );
    assert_eq!(fpwr(&mut escs, 0, OUT + 2, &[3, 4]), 1);
    assert!(escs[0].al_event_request().any(AlEvent::sm(2)));
    escs[0].read(OUT, &mut b).unwrap();
    assert_eq!(b, [1, 2, 3, 4]);
    assert!(!escs[0].al_event_request().any(AlEvent::sm(2)));
    assert_eq!(
        status(&mut escs, 2) >> SmStatus::BUFFER_STATE_SHIFT & 3,
        0,
        "buffer 0 written last"
    );
}

#[test]
fn three_buffer_reader_keeps_latched_buffer_until_it_reads_the_first_byte() {
    let mut escs = configured();
    fpwr(&mut escs, 0, OUT, &[1, 1, 1, 1]);
    let mut b = [0u8; 4];
    escs[0].read(OUT, &mut b).unwrap(); // latches [1;4]
    fpwr(&mut escs, 0, OUT, &[2, 2, 2, 2]);
    fpwr(&mut escs, 0, OUT, &[3, 3, 3, 3]);
    let mut tail = [0u8; 2];
    escs[0].read(OUT + 2, &mut tail).unwrap();
    assert_eq!(tail, [1, 1], "no torn read: still the latched buffer");
    escs[0].read(OUT, &mut b).unwrap();
    assert_eq!(
        b,
        [3, 3, 3, 3],
        "first byte latches the newest complete buffer"
    );
    escs[0].read(OUT, &mut b).unwrap();
    assert_eq!(b, [3, 3, 3, 3], "3-buffer reads never fail");
}

#[test]
fn three_buffer_ecat_write_commits_at_end_of_frame() {
    let mut escs = configured();
    let st = regs::sm(2).addr + regs::sm_offset::STATUS;
    let r = send(
        &mut escs,
        &[
            dg(FPWR, station(0), OUT, &[9; 4]),
            dg(FPRD, station(0), st, &[0]),
        ],
    );
    assert_eq!(
        r[1].data[0] >> SmStatus::BUFFER_STATE_SHIFT & 3,
        3,
        "not yet exchanged inside the frame"
    );
    assert_eq!(status(&mut escs, 2) >> SmStatus::BUFFER_STATE_SHIFT & 3, 0);
}

#[test]
fn three_buffer_inputs_written_by_pdi_are_read_by_ecat_and_raise_sm3_event() {
    let mut escs = configured();
    escs[0].write(IN, &[4, 3, 2, 1]).unwrap();
    escs[0].write(IN, &[5, 6, 7, 8]).unwrap();
    assert_eq!(fprd(&mut escs, 0, IN, 4), (vec![5, 6, 7, 8], 1));
    assert!(
        escs[0].al_event_request().any(AlEvent::sm(3)),
        "ECAT read completely: SM3 event"
    );
}

#[test]
fn memory_not_covered_by_an_sm_is_plain_ram() {
    let mut escs = configured();
    assert_eq!(fpwr(&mut escs, 0, 0x2000, &[1, 2, 3]), 1);
    let mut b = [0; 3];
    escs[0].read(0x2000, &mut b).unwrap();
    assert_eq!(b, [1, 2, 3]);
}
