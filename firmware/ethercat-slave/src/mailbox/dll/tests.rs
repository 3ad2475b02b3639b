//! The outbound queue against a mock ESC with mailbox SM semantics: SDO responses first,
//! emergencies only into an idle mailbox, withdrawn when a request arrives behind them.

use core::convert::Infallible;

use hal::esc::{regs, AlEvent, AlState, SmActivate, SmPdiControl, SmStatus};
use hal::pdi::EscPdi;

use super::Mailbox;
use crate::mailbox::emcy::{Emergency, EMCY_QUEUE_LEN};
use crate::mailbox::header::{MailboxHeader, HEADER_LEN};
use crate::mailbox::DictionaryScope;
use crate::od::Dictionary;
use crate::test_profiles::standard;

const MEM: usize = 0x1400;

/// ESC memory with the two mailbox SMs of the standard profile (SM0 0x1000, SM1 0x1100).
struct MockEsc {
    mem: [u8; MEM],
    sm0_full: bool,
    sm1_full: bool,
    sm1_activate: u8,
    sm1_pdi_control: u8,
    /// Reads from the SM0 buffer and the bytes they moved.
    sm0_reads: usize,
    sm0_bytes_read: usize,
}

const SM0_STATUS: u16 = regs::sm(0).addr + regs::sm_offset::STATUS;
const SM1_STATUS: u16 = regs::sm(1).addr + regs::sm_offset::STATUS;
const SM1_ACTIVATE: u16 = regs::sm(1).addr + regs::sm_offset::ACTIVATE;
const SM1_PDI_CONTROL: u16 = regs::sm(1).addr + regs::sm_offset::PDI_CONTROL;

impl MockEsc {
    fn new() -> Self {
        Self {
            mem: [0; MEM],
            sm0_full: false,
            sm1_full: false,
            sm1_activate: SmActivate::ENABLE,
            sm1_pdi_control: 0,
            sm0_reads: 0,
            sm0_bytes_read: 0,
        }
    }
    fn out_start() -> usize {
        standard::PROFILE.device.mailbox_out.start as usize
    }
    fn out_last() -> usize {
        Self::out_start() + standard::PROFILE.device.mailbox_out.length as usize - 1
    }
    fn in_start() -> usize {
        standard::PROFILE.device.mailbox_in.start as usize
    }
    fn in_last() -> usize {
        Self::in_start() + standard::PROFILE.device.mailbox_in.length as usize - 1
    }

    /// The master writes a request to SM0.
    fn master_writes(&mut self, frame: &[u8]) {
        assert!(!self.sm0_full);
        let s = Self::out_start();
        self.mem[s..s + frame.len()].copy_from_slice(frame);
        self.sm0_full = true;
    }

    /// The master reads SM1: the frame's header and payload, if SM1 is full.
    fn master_reads(&mut self) -> Option<(MailboxHeader, [u8; 32])> {
        if !self.sm1_full {
            return None;
        }
        self.sm1_full = false;
        let s = Self::in_start();
        let h = MailboxHeader::parse(&self.mem[s..]).expect("header");
        let mut p = [0u8; 32];
        let n = (h.length as usize).min(32);
        p[..n].copy_from_slice(&self.mem[s + HEADER_LEN..s + HEADER_LEN + n]);
        Some((h, p))
    }
}

impl EscPdi for MockEsc {
    type Error = Infallible;

    fn read(&mut self, addr: u16, buf: &mut [u8]) -> Result<AlEvent, Infallible> {
        let a = addr as usize;
        match addr {
            SM0_STATUS => {
                buf[0] = if self.sm0_full {
                    SmStatus::MAILBOX_FULL
                } else {
                    0
                }
            }
            SM1_STATUS => {
                buf[0] = if self.sm1_full {
                    SmStatus::MAILBOX_FULL
                } else {
                    0
                }
            }
            SM1_ACTIVATE => buf[0] = self.sm1_activate,
            _ => {
                buf.copy_from_slice(&self.mem[a..a + buf.len()]);
                if (Self::out_start()..=Self::out_last()).contains(&a) {
                    self.sm0_reads += 1;
                    self.sm0_bytes_read += buf.len();
                }
                if a <= Self::out_last() && Self::out_last() < a + buf.len() {
                    self.sm0_full = false;
                }
            }
        }
        Ok(AlEvent(0))
    }

    fn write(&mut self, addr: u16, data: &[u8]) -> Result<AlEvent, Infallible> {
        let a = addr as usize;
        if addr == SM1_PDI_CONTROL {
            self.sm1_pdi_control = data[0];
            if data[0] & SmPdiControl::DEACTIVATE != 0 {
                self.sm1_full = false;
            }
            return Ok(AlEvent(0));
        }
        assert!(
            !(self.sm1_full && a >= Self::in_start() && a <= Self::in_last()),
            "firmware wrote SM1 while it was full"
        );
        self.mem[a..a + data.len()].copy_from_slice(data);
        if a <= Self::in_last() && Self::in_last() < a + data.len() {
            self.sm1_full = true;
        }
        Ok(AlEvent(0))
    }
}

/// SDO upload request of 1018h:01 with mailbox counter `counter`.
fn upload_request(counter: u8) -> [u8; 16] {
    [
        10,
        0,
        0,
        0,
        0,
        0x03 | (counter << 4), // mailbox header: 10 bytes CoE
        0x00,
        0x20, // CoE header: SDO request
        0x40,
        0x18,
        0x10,
        0x01,
        0,
        0,
        0,
        0, // initiate upload 1018h:01
    ]
}

const COE_SDO_RESPONSE: [u8; 2] = [0x00, 0x30];
const COE_EMERGENCY: [u8; 2] = [0x00, 0x10];

struct Bench {
    esc: MockEsc,
    mbx: Mailbox,
    ram: [u8; standard::RAM_SIZE],
}

impl Bench {
    fn new() -> Self {
        let mut b = Self {
            esc: MockEsc::new(),
            mbx: Mailbox::new(),
            ram: [0; standard::RAM_SIZE],
        };
        Dictionary::new(&standard::PROFILE, &mut b.ram).load_defaults();
        b
    }
    fn service(&mut self, events: AlEvent) {
        let mut od = Dictionary::new(&standard::PROFILE, &mut self.ram);
        let Ok(()) = self.mbx.service(
            &mut self.esc,
            &standard::PROFILE.device,
            &mut od,
            AlState::PreOp,
            events,
        );
    }
}

fn emcy(code: u16) -> Emergency {
    Emergency::new(code, 0x11, [1, 2, 3, 4, 5])
}

#[test]
fn the_sdo_response_goes_out_before_a_queued_emergency() {
    let mut b = Bench::new();
    b.esc.master_writes(&upload_request(1));
    b.mbx.post_emcy(emcy(0xA000)).expect("room");
    b.service(AlEvent(0));
    let (h, p) = b.esc.master_reads().expect("a frame in SM1");
    assert_eq!(p[..2], COE_SDO_RESPONSE, "the SDO response comes first");
    assert_eq!(h.counter, 1);
    b.service(AlEvent(0));
    let (h, p) = b.esc.master_reads().expect("then the emergency");
    assert_eq!(h.length, 10);
    assert_eq!(h.kind, 3, "CoE");
    assert_eq!(h.counter, 2);
    assert_eq!(
        p[..10],
        [0x00, 0x10, 0x00, 0xA0, 0x11, 1, 2, 3, 4, 5],
        "CoE service 1, code, register, data"
    );
    b.service(AlEvent(0));
    assert!(b.esc.master_reads().is_none());
}

#[test]
fn an_unread_emergency_is_withdrawn_when_a_request_arrives() {
    let mut b = Bench::new();
    b.mbx.post_emcy(emcy(0x8130)).expect("room");
    b.service(AlEvent(0));
    assert!(b.esc.sm1_full, "idle mailbox: the emergency is posted");
    // The master checked SM1 before the emergency arrived and now sends its request.
    b.esc.master_writes(&upload_request(1));
    b.service(AlEvent(0));
    let (h, p) = b.esc.master_reads().expect("answer");
    assert_eq!(
        p[..2],
        COE_SDO_RESPONSE,
        "the answer to the request, not the emergency"
    );
    assert_eq!(
        h.counter, 1,
        "the withdrawn emergency gave its counter back"
    );
    assert_eq!(b.mbx.pending_emcys(), 1);
    b.service(AlEvent(0));
    let (h, p) = b.esc.master_reads().expect("emergency again");
    assert_eq!(p[..2], COE_EMERGENCY);
    assert_eq!(h.counter, 2);
    assert_eq!(b.mbx.pending_emcys(), 0);
}

#[test]
fn emergencies_are_never_lost_while_the_queue_has_room() {
    let mut b = Bench::new();
    for i in 0..EMCY_QUEUE_LEN as u16 {
        b.mbx.post_emcy(emcy(0x1000 + i)).expect("room");
    }
    let extra = emcy(0xFFFF);
    assert_eq!(b.mbx.post_emcy(extra), Err(extra), "full: handed back");
    // Requests interleave with the emergencies; every one arrives, in order.
    let mut codes = [0u16; EMCY_QUEUE_LEN];
    let mut n = 0;
    let mut counter = 1;
    for round in 0..4 * EMCY_QUEUE_LEN {
        if round % 3 == 1 && !b.esc.sm0_full {
            b.esc.master_writes(&upload_request(counter));
            counter = counter % 7 + 1;
        }
        b.service(AlEvent(0));
        if let Some((_, p)) = b.esc.master_reads() {
            if p[..2] == COE_EMERGENCY {
                codes[n] = u16::from_le_bytes([p[2], p[3]]);
                n += 1;
            }
        }
    }
    assert_eq!(n, EMCY_QUEUE_LEN);
    for (i, c) in codes.iter().enumerate() {
        assert_eq!(*c, 0x1000 + i as u16);
    }
}

#[test]
fn a_repeat_request_reposts_the_last_frame_posted_even_an_emergency() {
    let mut b = Bench::new();
    b.esc.master_writes(&upload_request(1));
    b.service(AlEvent(0));
    b.esc.master_reads().expect("response");
    b.mbx.post_emcy(emcy(0x3210)).expect("room");
    b.service(AlEvent(0));
    let (_, first) = b.esc.master_reads().expect("emergency");
    assert_eq!(first[..2], COE_EMERGENCY);
    // The master lost it on the way back and toggles the repeat request.
    b.esc.sm1_activate ^= SmActivate::REPEAT_REQUEST;
    b.service(AlEvent(AlEvent::SM_ACTIVATION));
    assert_ne!(
        b.esc.sm1_pdi_control & SmPdiControl::REPEAT_ACK,
        0,
        "acknowledged"
    );
    let (_, again) = b.esc.master_reads().expect("backup re-posted");
    assert_eq!(again, first);
}

/// What of the OD RAM a received request names: its SDO object; nothing for a retry of the
/// request served last (the same counter: not served again), a protocol the slave does not
/// serve, or a frame whose mailbox header is malformed (each answered without the dictionary).
#[test]
fn a_received_request_names_the_od_ram_its_answer_needs() {
    let mut b = Bench::new();
    let device = &standard::PROFILE.device;
    let scope_of = |b: &mut Bench, frame: &[u8]| {
        b.esc.master_writes(frame);
        let request = b
            .mbx
            .receive(&mut b.esc, device, AlEvent(0))
            .expect("infallible")
            .expect("a request in SM0");
        let scope = b.mbx.scope(&request);
        let mut od = Dictionary::new(&standard::PROFILE, &mut b.ram);
        let Ok(()) = b.mbx.answer(
            &mut b.esc,
            device,
            &mut od,
            AlState::PreOp,
            Some(request),
            &mut (),
        );
        b.esc.master_reads();
        scope
    };
    let identity = DictionaryScope::Object {
        index: 0x1018,
        download: false,
    };
    assert_eq!(scope_of(&mut b, &upload_request(1)), identity);
    assert_eq!(
        scope_of(&mut b, &upload_request(1)),
        DictionaryScope::Nothing
    );
    assert_eq!(scope_of(&mut b, &upload_request(2)), identity);
    // Counter 0: the master does not count, every request is new.
    assert_eq!(scope_of(&mut b, &upload_request(0)), identity);
    assert_eq!(scope_of(&mut b, &upload_request(0)), identity);
    // FoE (type 4) is not served.
    let mut foe = upload_request(3);
    foe[5] = 0x04 | (3 << 4);
    assert_eq!(scope_of(&mut b, &foe), DictionaryScope::Nothing);
    // A length beyond what SM0 holds.
    let mut oversized = upload_request(4);
    oversized[0..2].copy_from_slice(&0x0FFFu16.to_le_bytes());
    assert_eq!(scope_of(&mut b, &oversized), DictionaryScope::Nothing);
}

/// A request is read as its mailbox header announces it, and then SM0's last byte, which hands
/// the buffer back (ETG.1000.4 mailbox mode): not the whole buffer, whose every byte costs SPI
/// bus time. A frame that fills SM0 needs no extra read of the last byte.
#[test]
fn a_request_is_read_to_its_length_and_the_last_byte_of_sm0() {
    let size = standard::PROFILE.device.mailbox_out.length as usize;
    let mut b = Bench::new();
    let frame = upload_request(1);
    b.esc.master_writes(&frame);
    b.service(AlEvent(0));
    assert!(!b.esc.sm0_full, "SM0 handed back to the master");
    let (h, p) = b.esc.master_reads().expect("answered");
    assert_eq!((h.counter, p[..2].to_vec()), (1, COE_SDO_RESPONSE.to_vec()));
    assert_eq!(
        (b.esc.sm0_reads, b.esc.sm0_bytes_read),
        (3, frame.len() + 1),
        "header, the rest of the frame, the last byte"
    );
    // A frame as long as SM0 (the CoE request padded with zeros): the frame's end is the
    // buffer's last byte.
    let mut full = [0u8; MEM];
    full[..frame.len()].copy_from_slice(&upload_request(2));
    let length = (size - HEADER_LEN) as u16;
    full[..2].copy_from_slice(&length.to_le_bytes());
    (b.esc.sm0_reads, b.esc.sm0_bytes_read) = (0, 0);
    b.esc.master_writes(&full[..size]);
    b.service(AlEvent(0));
    assert!(!b.esc.sm0_full);
    assert!(b.esc.master_reads().is_some(), "answered");
    assert_eq!((b.esc.sm0_reads, b.esc.sm0_bytes_read), (2, size));
}

/// A header that announces more than SM0 holds: the whole buffer is read (SM0 handed back)
/// and the request refused with the mailbox error "invalid size" (ETG.1000.4 Table 30, 0x0008).
#[test]
fn a_request_longer_than_sm0_reads_the_buffer_and_is_refused() {
    let size = standard::PROFILE.device.mailbox_out.length as usize;
    let mut b = Bench::new();
    let mut frame = upload_request(1);
    frame[0..2].copy_from_slice(&(size as u16).to_le_bytes());
    b.esc.master_writes(&frame);
    b.service(AlEvent(0));
    assert!(!b.esc.sm0_full, "SM0 handed back to the master");
    assert_eq!(b.esc.sm0_bytes_read, size);
    let (h, p) = b.esc.master_reads().expect("a mailbox error");
    assert_eq!(h.kind, 0, "mailbox error service");
    assert_eq!(u16::from_le_bytes([p[2], p[3]]), 0x0008, "invalid size");
}
