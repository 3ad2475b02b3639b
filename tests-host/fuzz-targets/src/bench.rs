//! The master's side of a fuzz run: one simulated drive (ESC + firmware + servo) in a segment,
//! reached with whole EtherCAT frames exactly as ethercrab and SOEM reach it, plus the few
//! master routines the targets need to get the drive into a state (mailbox set-up, state
//! requests, process-data SMs).

use std::sync::OnceLock;

use board_sim::drive::SimDrive;
use board_sim::Segment;
use firmware::od::Dictionary;
use firmware::pdo::{Direction, PdoPlan};
use firmware::profile::DriveProfile;
use hal::esc::regs::{self, sm_offset};
use hal::esc::{SmActivate, SmStatus};

use crate::spec::state;

/// A built-in profile with what a master reads from its SII and ESI.
pub struct Loaded {
    /// Profile name (`od-gen list`).
    pub name: &'static str,
    /// The profile compiled into the firmware.
    pub fw: &'static DriveProfile,
    /// The SII EEPROM image od-gen makes of it.
    pub sii: Vec<u8>,
    /// Bytes of the default RxPDO image (SM2 length).
    pub outputs_len: u16,
    /// Bytes of the default TxPDO image (SM3 length).
    pub inputs_len: u16,
}

/// Every built-in profile, loaded once per process.
pub fn profiles() -> &'static [Loaded] {
    static LOADED: OnceLock<Vec<Loaded>> = OnceLock::new();
    LOADED.get_or_init(|| {
        od_gen::builtin_names()
            .into_iter()
            .filter_map(|name| {
                let fw = firmware::profiles::by_name(name)?;
                let sii = od_gen::builtin(name).ok()?.sii_image();
                let mut ram = vec![0u8; firmware::profiles::MAX_RAM_SIZE];
                let mut od = Dictionary::new(&fw.od, &mut ram);
                od.load_defaults();
                let len = |dir| {
                    PdoPlan::build(&od, dir)
                        .map(|p| u16::try_from(p.byte_len()).unwrap_or(0))
                        .unwrap_or(0)
                };
                Some(Loaded {
                    name,
                    fw,
                    sii,
                    outputs_len: len(Direction::Rx),
                    inputs_len: len(Direction::Tx),
                })
            })
            .collect()
    })
}

/// A profile chosen by one byte of the input.
pub fn profile_of(selector: u8) -> &'static Loaded {
    let all = profiles();
    &all[usize::from(selector) % all.len()]
}

// ----- EtherCAT frames (ETG.1000.4 §5.3) -----

/// Datagram commands (ETG.1000.4 Table 14).
pub mod cmd {
    /// Auto-increment physical read.
    pub const APRD: u8 = 1;
    /// Auto-increment physical write.
    pub const APWR: u8 = 2;
    /// Auto-increment physical read-write.
    pub const APRW: u8 = 3;
    /// Configured-address physical read.
    pub const FPRD: u8 = 4;
    /// Configured-address physical write.
    pub const FPWR: u8 = 5;
    /// Configured-address physical read-write.
    pub const FPRW: u8 = 6;
    /// Broadcast read.
    pub const BRD: u8 = 7;
    /// Broadcast write.
    pub const BWR: u8 = 8;
    /// Broadcast read-write.
    pub const BRW: u8 = 9;
    /// Logical read.
    pub const LRD: u8 = 10;
    /// Logical write.
    pub const LWR: u8 = 11;
    /// Logical read-write.
    pub const LRW: u8 = 12;
    /// Auto-increment read, multiple write.
    pub const ARMW: u8 = 13;
    /// Configured-address read, multiple write.
    pub const FRMW: u8 = 14;
    /// Every command (0 is NOP).
    pub const ALL: [u8; 15] = [
        0, APRD, APWR, APRW, FPRD, FPWR, FPRW, BRD, BWR, BRW, LRD, LWR, LRW, ARMW, FRMW,
    ];
}

/// Ethernet II header length (destination, source, EtherType).
const ETH_HEADER_LEN: usize = 14;
/// EtherType of EtherCAT.
pub const ETHERTYPE_ETHERCAT: u16 = 0x88A4;
/// EtherCAT header: length in bits 0..10, type 1 (DLPDU) in bits 12..15.
const ECAT_TYPE_DLPDU: u16 = 1 << 12;
/// Datagram header and working counter lengths.
const DG_HEADER_LEN: usize = 10;
const DG_WKC_LEN: usize = 2;
/// Datagram length field: "more datagrams follow".
const DG_MORE: u16 = 0x8000;
/// Longest datagram data (11-bit length field, one Ethernet frame).
pub const MAX_DATAGRAM_DATA: usize = 1486;
/// The master's MAC (locally administered).
const MASTER_MAC: [u8; 6] = [0x02, 0, 0, 0, 0, 1];

/// One datagram as the master sends it.
#[derive(Clone, Debug)]
pub struct Datagram {
    /// Command.
    pub cmd: u8,
    /// Address: position/station (ADP) and register offset (ADO); for logical commands the
    /// two halves of the 32-bit logical address.
    pub adp: u16,
    /// See `adp`.
    pub ado: u16,
    /// Data (written, or the room for what is read).
    pub data: Vec<u8>,
}

/// The Ethernet frame carrying `datagrams`.
pub fn frame(datagrams: &[Datagram]) -> Vec<u8> {
    let mut f = Vec::with_capacity(64);
    f.extend_from_slice(&[0xFF; 6]);
    f.extend_from_slice(&MASTER_MAC);
    f.extend_from_slice(&ETHERTYPE_ETHERCAT.to_be_bytes());
    f.extend_from_slice(&[0, 0]);
    for (i, dg) in datagrams.iter().enumerate() {
        let len = dg.data.len().min(MAX_DATAGRAM_DATA);
        let more = if i + 1 < datagrams.len() { DG_MORE } else { 0 };
        f.push(dg.cmd);
        f.push(i as u8);
        f.extend_from_slice(&dg.adp.to_le_bytes());
        f.extend_from_slice(&dg.ado.to_le_bytes());
        f.extend_from_slice(&(len as u16 | more).to_le_bytes());
        f.extend_from_slice(&[0, 0]);
        f.extend_from_slice(&dg.data[..len]);
        f.extend_from_slice(&[0, 0]);
    }
    let ecat_len = (f.len() - ETH_HEADER_LEN - 2) as u16 & 0x07FF;
    f[ETH_HEADER_LEN..ETH_HEADER_LEN + 2]
        .copy_from_slice(&(ecat_len | ECAT_TYPE_DLPDU).to_le_bytes());
    f
}

/// The datagrams of a returned frame: data and working counter of each (`None` if the frame
/// is not one the master could parse).
pub fn replies(frame: &[u8]) -> Option<Vec<(Vec<u8>, u16)>> {
    let header = frame.get(ETH_HEADER_LEN..ETH_HEADER_LEN + 2)?;
    let ecat_len = usize::from(u16::from_le_bytes([header[0], header[1]]) & 0x07FF);
    let mut rest = frame.get(ETH_HEADER_LEN + 2..ETH_HEADER_LEN + 2 + ecat_len)?;
    let mut out = Vec::new();
    loop {
        let h = rest.get(..DG_HEADER_LEN)?;
        let len_field = u16::from_le_bytes([h[6], h[7]]);
        let len = usize::from(len_field & 0x07FF);
        let data = rest.get(DG_HEADER_LEN..DG_HEADER_LEN + len)?.to_vec();
        let wkc = rest.get(DG_HEADER_LEN + len..DG_HEADER_LEN + len + DG_WKC_LEN)?;
        out.push((data, u16::from_le_bytes([wkc[0], wkc[1]])));
        rest = &rest[DG_HEADER_LEN + len + DG_WKC_LEN..];
        if len_field & DG_MORE == 0 {
            return Some(out);
        }
    }
}

/// What the master sees of the AL status.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Status {
    /// State bits (0x0130 bits 0..3).
    pub state: u8,
    /// Error indication (0x0130 bit 4).
    pub error: bool,
    /// AL status code (0x0134).
    pub code: u16,
}

/// One drive on a segment, and the master's view of it.
pub struct Bench {
    /// The segment (one drive).
    pub segment: Segment,
    /// Its profile.
    pub profile: &'static Loaded,
    /// The next mailbox counter (1..=7).
    counter: u8,
    /// The last value written to AL control (a request that may still be pending).
    pub last_request: Option<u16>,
}

impl Bench {
    /// A drive of `profile`, just powered on (INIT).
    pub fn new(profile: &'static Loaded) -> Self {
        let drive = match SimDrive::new(profile.fw, &profile.sii) {
            Ok(d) => d,
            Err(e) => panic!(
                "the built-in profile {} does not start: {e:?}",
                profile.name
            ),
        };
        Self {
            segment: Segment::from_devices(vec![drive]),
            profile,
            counter: 1,
            last_request: None,
        }
    }

    /// Sends one frame, returns the datagrams' data and working counters (`None`: no frame came
    /// back).
    pub fn exchange(&mut self, datagrams: &[Datagram]) -> Option<Vec<(Vec<u8>, u16)>> {
        let reply = self.segment.process_frame(&frame(datagrams))?;
        replies(&reply)
    }

    /// Writes `data` at ESC address `addr` of the first drive (APWR); the working counter.
    pub fn write(&mut self, addr: u16, data: &[u8]) -> u16 {
        let dg = Datagram {
            cmd: cmd::APWR,
            adp: 0,
            ado: addr,
            data: data.to_vec(),
        };
        self.exchange(&[dg])
            .and_then(|r| r.first().map(|(_, wkc)| *wkc))
            .unwrap_or(0)
    }

    /// Reads `len` bytes at `addr` (APRD); `None` without a working counter.
    pub fn read(&mut self, addr: u16, len: usize) -> Option<Vec<u8>> {
        let dg = Datagram {
            cmd: cmd::APRD,
            adp: 0,
            ado: addr,
            data: vec![0; len],
        };
        let r = self.exchange(&[dg])?;
        let (data, wkc) = r.into_iter().next()?;
        (wkc == 1).then_some(data)
    }

    /// The AL status as the master reads it (status and code in one frame).
    pub fn status(&mut self) -> Option<Status> {
        let read = |addr: u16| Datagram {
            cmd: cmd::APRD,
            adp: 0,
            ado: addr,
            data: vec![0; 2],
        };
        let r = self.exchange(&[read(regs::AL_STATUS.addr), read(regs::AL_STATUS_CODE.addr)])?;
        let [(s, 1), (c, 1)] = &r[..] else {
            return None;
        };
        Some(Status {
            state: s[0] & 0x0F,
            error: s[0] & 0x10 != 0,
            code: u16::from_le_bytes([c[0], c[1]]),
        })
    }

    /// Requests `state` (AL control, error acknowledge set as masters do after an error).
    pub fn request(&mut self, control: u16) -> u16 {
        self.last_request = Some(control);
        self.write(regs::AL_CONTROL.addr, &control.to_le_bytes())
    }

    /// Writes SyncManager `n`'s start, length and control, then enables it.
    pub fn configure_sm(&mut self, n: u8, start: u16, length: u16, control: u8) {
        let base = regs::sm(n).addr;
        let mut block = [0u8; 8];
        block[0..2].copy_from_slice(&start.to_le_bytes());
        block[2..4].copy_from_slice(&length.to_le_bytes());
        block[usize::from(sm_offset::CONTROL)] = control;
        block[usize::from(sm_offset::ACTIVATE)] = SmActivate::ENABLE;
        self.write(base, &block);
    }

    /// SM0/SM1 as the SII's mailbox layout says (what every master does before PREOP).
    pub fn configure_mailbox(&mut self) {
        let d = &self.profile.fw.od.device;
        self.configure_sm(
            0,
            d.mailbox_out.start,
            d.mailbox_out.length,
            d.mailbox_out.control,
        );
        self.configure_sm(
            1,
            d.mailbox_in.start,
            d.mailbox_in.length,
            d.mailbox_in.control,
        );
    }

    /// SM2/SM3 for the default process data.
    pub fn configure_process_data(&mut self) {
        let d = &self.profile.fw.od.device;
        let (out_len, in_len) = (self.profile.outputs_len, self.profile.inputs_len);
        if out_len > 0 {
            self.configure_sm(2, d.outputs.start, out_len, d.outputs.control);
        }
        if in_len > 0 {
            self.configure_sm(3, d.inputs.start, in_len, d.inputs.control);
        }
    }

    /// The mailbox size master → slave.
    pub fn mailbox_out_len(&self) -> usize {
        usize::from(self.profile.fw.od.device.mailbox_out.length)
    }

    /// Writes one mailbox (padded to the SM0 length, as masters write the whole buffer); the
    /// working counter.
    pub fn mailbox_write(&mut self, mailbox: &[u8]) -> u16 {
        let mut buf = vec![0u8; self.mailbox_out_len()];
        let n = mailbox.len().min(buf.len());
        buf[..n].copy_from_slice(&mailbox[..n]);
        let start = self.profile.fw.od.device.mailbox_out.start;
        self.write(start, &buf)
    }

    /// Reads SM1 if the slave filled it.
    pub fn mailbox_read(&mut self) -> Option<Vec<u8>> {
        let d = self.profile.fw.od.device.mailbox_in;
        let status = self.read(regs::sm(1).addr + sm_offset::STATUS, 1)?;
        if status[0] & SmStatus::MAILBOX_FULL == 0 {
            return None;
        }
        self.read(d.start, usize::from(d.length))
    }

    /// The next mailbox counter (1..=7, ETG.1000.4 §5.6).
    pub fn next_counter(&mut self) -> u8 {
        let c = self.counter;
        self.counter = if c >= 7 { 1 } else { c + 1 };
        c
    }

    /// Brings the drive towards `target` as a master does (mailbox SMs, free run, process-data
    /// SMs, outputs); where the profile refuses a step the drive stays lower.
    pub fn bring_to(&mut self, target: u8) {
        if target == state::INIT {
            return;
        }
        self.configure_mailbox();
        self.request(u16::from(state::PREOP));
        if crate::spec::rank(target) < crate::spec::rank(state::SAFEOP) {
            return;
        }
        // Free run (1C32h:01 = 0) where the profile has it: needs no DC set-up.
        let counter = self.next_counter();
        let mbx = crate::coe::sdo_download_expedited(counter, 0x1C32, 1, &[0, 0]);
        self.mailbox_write(&mbx);
        let _ = self.mailbox_read();
        self.configure_process_data();
        self.request(u16::from(state::SAFEOP));
        if target != state::OP {
            return;
        }
        let out_len = usize::from(self.profile.outputs_len);
        if out_len > 0 {
            let start = self.profile.fw.od.device.outputs.start;
            self.write(start, &vec![0; out_len]);
        }
        self.request(u16::from(state::OP));
        self.segment.advance(1_000_000);
    }
}
