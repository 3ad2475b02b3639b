//! Ethernet frames through a ring of ESCs.
//!
//! A frame is checked completely before any ESC sees it (a frame with a bad structure would fail
//! the FCS check of real hardware and have no effect); then each ESC in ring order processes all
//! datagrams and commits its end-of-frame SM state. The first ESC sets the locally administered
//! bit of the source MAC, as real ESCs do (ethercrab drops replies whose source MAC is its own).
//!
//! Timing (for the DC latches and the system time): the frame enters ESC k's port 0 at
//! `t0 + k x (forward + cable)`, with `t0` the first ESC's current time; the last ESC loops it back
//! through its closed port 1; it re-enters ESC k's port 1 at `t0 + (2n - 2 - k) x (forward +
//! cable)`. Forward and return delays are equal, so a master's propagation-delay estimate is
//! exact.

use hal::esc::regs;

use super::access::FrameTiming;
use super::consts::{CABLE_DELAY_NS, PORT_FORWARD_DELAY_NS};
use super::Et1100;

// ----- frame format (ETG.1000.4 §5: Ethernet II + EtherCAT header + datagrams) -----
/// EtherType of EtherCAT.
const ETHERTYPE_ETHERCAT: u16 = 0x88A4;
/// Ethernet II header: destination, source, EtherType.
const ETH_HEADER_LEN: usize = 14;
/// Offset of the EtherType.
const ETHERTYPE_OFFSET: usize = 12;
/// Offset of the first source MAC byte.
const SRC_MAC_OFFSET: usize = 6;
/// Locally administered (U/L) bit of a MAC's first byte; the first ESC sets it on the way back.
const MAC_LOCALLY_ADMINISTERED: u8 = 0x02;
/// EtherCAT header length.
const ECAT_HEADER_LEN: usize = 2;
/// EtherCAT header: length bits.
const ECAT_LEN_MASK: u16 = 0x07FF;
/// EtherCAT header: type shift.
const ECAT_TYPE_SHIFT: u16 = 12;
/// EtherCAT header type of DLPDUs (datagrams).
const ECAT_TYPE_DLPDU: u16 = 1;
/// Datagram header length.
pub(crate) const DG_HEADER_LEN: usize = 10;
/// Working counter length.
const DG_WKC_LEN: usize = 2;
/// Datagram length field: length bits.
pub(crate) const DG_LEN_MASK: u16 = 0x07FF;
/// Datagram length field: more datagrams follow.
const DG_MORE_FOLLOWS: u16 = 0x8000;

/// Why a frame was not processed. The caller drops such frames.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameError {
    /// Shorter than an Ethernet header plus an EtherCAT header.
    TooShort,
    /// The EtherType is not EtherCAT (0x88A4).
    NotEtherCat {
        /// The EtherType found.
        ethertype: u16,
    },
    /// The EtherCAT header names a type other than 1 (DLPDUs).
    UnsupportedType {
        /// The type found.
        ecat_type: u8,
    },
    /// The EtherCAT header's length exceeds the frame.
    LengthMismatch {
        /// Length in the EtherCAT header.
        declared: usize,
        /// Bytes available after the header.
        available: usize,
    },
    /// Datagram `index` does not fit in the EtherCAT payload.
    DatagramOverrun {
        /// Position of the datagram in the frame (0-based).
        index: usize,
    },
}

impl core::fmt::Display for FrameError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::TooShort => write!(f, "frame too short"),
            Self::NotEtherCat { ethertype } => {
                write!(f, "not EtherCAT (EtherType {ethertype:#06x})")
            }
            Self::UnsupportedType { ecat_type } => {
                write!(f, "unsupported EtherCAT type {ecat_type}")
            }
            Self::LengthMismatch {
                declared,
                available,
            } => {
                write!(
                    f,
                    "EtherCAT length {declared} exceeds the {available} bytes present"
                )
            }
            Self::DatagramOverrun { index } => write!(f, "datagram {index} overruns the frame"),
        }
    }
}

impl std::error::Error for FrameError {}

/// Checks the frame; returns the byte range of the datagrams.
fn validate(frame: &[u8]) -> Result<core::ops::Range<usize>, FrameError> {
    let header_end = ETH_HEADER_LEN + ECAT_HEADER_LEN;
    if frame.len() < header_end {
        return Err(FrameError::TooShort);
    }
    let be = |at: usize| {
        u16::from_be_bytes([
            frame.get(at).copied().unwrap_or(0),
            frame.get(at + 1).copied().unwrap_or(0),
        ])
    };
    let le = |at: usize| {
        u16::from_le_bytes([
            frame.get(at).copied().unwrap_or(0),
            frame.get(at + 1).copied().unwrap_or(0),
        ])
    };
    let ethertype = be(ETHERTYPE_OFFSET);
    if ethertype != ETHERTYPE_ETHERCAT {
        return Err(FrameError::NotEtherCat { ethertype });
    }
    let h = le(ETH_HEADER_LEN);
    let ecat_type = h >> ECAT_TYPE_SHIFT;
    if ecat_type != ECAT_TYPE_DLPDU {
        return Err(FrameError::UnsupportedType {
            ecat_type: ecat_type as u8,
        });
    }
    let declared = usize::from(h & ECAT_LEN_MASK);
    let available = frame.len() - header_end;
    if declared > available {
        return Err(FrameError::LengthMismatch {
            declared,
            available,
        });
    }
    let end = header_end + declared;
    let mut at = header_end;
    let mut index = 0;
    loop {
        if at + DG_HEADER_LEN > end {
            return Err(FrameError::DatagramOverrun { index });
        }
        let lf = le(at + LEN_FIELD);
        let total = DG_HEADER_LEN + usize::from(lf & DG_LEN_MASK) + DG_WKC_LEN;
        if at + total > end {
            return Err(FrameError::DatagramOverrun { index });
        }
        at += total;
        index += 1;
        if lf & DG_MORE_FOLLOWS == 0 {
            break;
        }
    }
    Ok(header_end..at)
}

/// Offset of the length field inside a datagram header.
const LEN_FIELD: usize = 6;

/// Calls `f` with every datagram of a validated payload.
fn for_each_datagram(payload: &mut [u8], mut f: impl FnMut(&mut [u8])) {
    let mut at = 0;
    while let Some(&[lo, hi]) = payload.get(at + LEN_FIELD..at + LEN_FIELD + 2) {
        let lf = u16::from_le_bytes([lo, hi]);
        let total = DG_HEADER_LEN + usize::from(lf & DG_LEN_MASK) + DG_WKC_LEN;
        let Some(dg) = payload.get_mut(at..at + total) else {
            return;
        };
        f(dg);
        at += total;
        if lf & DG_MORE_FOLLOWS == 0 {
            return;
        }
    }
}

/// Passes one Ethernet frame through the ESCs of `chain` in ring order, in place.
///
/// Port 1 of every ESC but the last is marked connected (DL status topology bits). The frame
/// enters the ring at the first ESC's current time ([`Et1100::now`]). On success the frame is the
/// one returning to the master, with the locally administered bit set in the source MAC. A
/// non-EtherCAT or malformed frame is left untouched and `Err` is returned (the caller drops it).
/// An empty chain returns the frame with only the MAC bit set.
pub fn process_frame<'a>(
    frame: &mut [u8],
    chain: impl IntoIterator<Item = &'a mut Et1100>,
) -> Result<(), FrameError> {
    let range = match validate(frame) {
        Ok(r) => r,
        Err(e) => {
            // A broken EtherCAT structure counts in the processing unit error counter of the first
            // ESC (Section II 0x030C); foreign frames are not errors.
            if matches!(
                e,
                FrameError::LengthMismatch { .. } | FrameError::DatagramOverrun { .. }
            ) {
                if let Some(first) = chain.into_iter().next() {
                    first.count_pu_error();
                }
            }
            return Err(e);
        }
    };
    let mut escs: Vec<&'a mut Et1100> = chain.into_iter().collect();
    let n = escs.len() as u64;
    let hop = PORT_FORWARD_DELAY_NS + CABLE_DELAY_NS;
    let t0 = escs.first().map_or(0, |e| e.now);
    if let Some(payload) = frame.get_mut(range) {
        for (k, esc) in escs.iter_mut().enumerate() {
            let k = k as u64;
            let last = k + 1 == n;
            esc.set_port_connected(1, !last);
            esc.default_clock_for_position(k as usize);
            let timing = FrameTiming {
                port0: t0 + k * hop,
                port1: (!last).then(|| t0 + (2 * n - 2 - k) * hop),
            };
            esc.process_ecat_payload(payload, timing);
        }
    }
    if let Some(b) = frame.get_mut(SRC_MAC_OFFSET) {
        *b |= MAC_LOCALLY_ADMINISTERED;
    }
    Ok(())
}

impl Et1100 {
    /// Counts a frame with a broken EtherCAT structure (0x030C, saturating).
    fn count_pu_error(&mut self) {
        let addr = regs::ECAT_PU_ERROR_COUNTER.addr;
        let c = self.u8_at(addr).saturating_add(1);
        self.set_u8(addr, c);
    }

    /// All datagrams of a validated frame through this ESC, then the end-of-frame commit.
    fn process_ecat_payload(&mut self, payload: &mut [u8], timing: FrameTiming) {
        self.eeprom_poll_frame_start();
        for_each_datagram(payload, |dg| self.process_datagram(dg, timing));
        self.sm_end_of_frame();
        self.eeprom_count_frame();
    }
}

/// A line of ESCs (port 0 towards the master, port 1 to the next) that owns its ESCs.
#[derive(Debug, Default)]
pub struct Segment {
    escs: Vec<Et1100>,
}

impl Segment {
    /// A segment of `escs` in ring order. Marks port 1 of all but the last ESC connected.
    pub fn new(escs: Vec<Et1100>) -> Self {
        let mut s = Self { escs };
        let n = s.escs.len();
        for (k, e) in s.escs.iter_mut().enumerate() {
            e.set_port_connected(1, k + 1 < n);
        }
        s
    }

    /// Passes a frame through all ESCs (see [`process_frame`]).
    pub fn process(&mut self, frame: &mut [u8]) -> Result<(), FrameError> {
        process_frame(frame, self.escs.iter_mut())
    }

    /// Advances every ESC to global time `now_ns`.
    pub fn advance_to(&mut self, now_ns: u64) {
        for e in &mut self.escs {
            e.advance_to(now_ns);
        }
    }

    /// The earliest next event of any ESC.
    pub fn next_event_ns(&self) -> Option<u64> {
        self.escs.iter().filter_map(Et1100::next_event_ns).min()
    }

    /// The ESCs in ring order.
    pub fn escs(&self) -> &[Et1100] {
        &self.escs
    }

    /// The ESCs in ring order, mutable (e.g. for PDI access by a drive).
    pub fn escs_mut(&mut self) -> &mut [Et1100] {
        &mut self.escs
    }
}

/// What a datagram of a frame says, for observers outside the ESC (fault injection, logs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DatagramSummary {
    /// Command code (ETG.1000.4 Table 20: 4 = FPRD, ...).
    pub command: u8,
    /// Address field: ADP in the low 16 bits and ADO in the high 16 bits for physical
    /// addressing, the logical address for LRD/LWR/LRW.
    pub address: u32,
    /// Data length.
    pub len: usize,
    /// Working counter.
    pub wkc: u16,
}

/// The datagrams of an EtherCAT frame in order; empty for a frame that is not a valid one.
pub fn datagrams(frame: &[u8]) -> Vec<DatagramSummary> {
    let Ok(range) = validate(frame) else {
        return Vec::new();
    };
    let mut payload = frame.get(range).unwrap_or(&[]).to_vec();
    let mut out = Vec::new();
    for_each_datagram(&mut payload, |dg| {
        let get = |at: usize| dg.get(at).copied().unwrap_or(0);
        let len = dg.len().saturating_sub(DG_HEADER_LEN + DG_WKC_LEN);
        out.push(DatagramSummary {
            command: get(0),
            address: u32::from_le_bytes([get(2), get(3), get(4), get(5)]),
            len,
            wkc: u16::from_le_bytes([get(dg.len().wrapping_sub(2)), get(dg.len().wrapping_sub(1))]),
        });
    });
    out
}
