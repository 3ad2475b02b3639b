//! Unit tests of the simulated ET1100, one file per register block, plus shared helpers: a tiny
//! SII image builder (header words + CRC) and an EtherCAT frame builder.

mod datagram;
mod dc;
mod eeprom;
mod fmmu;
mod frame;
mod pdi;
mod sm;
mod watchdog;

use super::{process_frame, sii_crc8, Et1100};

pub(super) const NOP: u8 = 0;
pub(super) const APRD: u8 = 1;
pub(super) const APWR: u8 = 2;
pub(super) const APRW: u8 = 3;
pub(super) const FPRD: u8 = 4;
pub(super) const FPWR: u8 = 5;
pub(super) const FPRW: u8 = 6;
pub(super) const BRD: u8 = 7;
pub(super) const BWR: u8 = 8;
pub(super) const LRD: u8 = 10;
pub(super) const LWR: u8 = 11;
pub(super) const LRW: u8 = 12;
pub(super) const ARMW: u8 = 13;
pub(super) const FRMW: u8 = 14;

/// Configuration words the test SII carries.
pub(super) const W0_PDI_CONTROL: u16 = 0x0005; // SPI PDI, no device emulation
pub(super) const W1_PDI_CONFIG: u16 = 0xCC00; // SYNC0/1 outputs, both mapped to AL event
pub(super) const W2_PULSE: u16 = 100; // 1 us
pub(super) const W3_PDI_EXT: u16 = 0x0000;
pub(super) const W4_ALIAS: u16 = 0x0A11;
pub(super) const VENDOR: u32 = 0x00AB_CDEF;

/// A 256-byte SII image: configuration words, CRC, vendor id at word 8, and bytes = their
/// index from word 0x40 on (so reads can be checked).
pub(super) fn sii_with(w1: u16) -> Vec<u8> {
    let mut img = vec![0u8; 256];
    for (w, v) in [W0_PDI_CONTROL, w1, W2_PULSE, W3_PDI_EXT, W4_ALIAS]
        .into_iter()
        .enumerate()
    {
        img[2 * w..2 * w + 2].copy_from_slice(&v.to_le_bytes());
    }
    img[14] = sii_crc8(&img[..14]);
    img[16..20].copy_from_slice(&VENDOR.to_le_bytes());
    for (i, b) in img.iter_mut().enumerate().skip(0x80) {
        *b = i as u8;
    }
    img
}

pub(super) fn sii() -> Vec<u8> {
    sii_with(W1_PDI_CONFIG)
}

pub(super) fn esc() -> Et1100 {
    Et1100::new(&sii())
}

/// A datagram to put in a frame.
pub(super) struct Dg {
    pub cmd: u8,
    pub adp: u16,
    pub ado: u16,
    pub data: Vec<u8>,
}

pub(super) fn dg(cmd: u8, adp: u16, ado: u16, data: &[u8]) -> Dg {
    Dg {
        cmd,
        adp,
        ado,
        data: data.to_vec(),
    }
}

/// Logical datagram at logical address `laddr`.
pub(super) fn ldg(cmd: u8, laddr: u32, data: &[u8]) -> Dg {
    dg(cmd, laddr as u16, (laddr >> 16) as u16, data)
}

pub(super) const MASTER_MAC: [u8; 6] = [0x10; 6];

pub(super) fn build_frame(dgs: &[Dg]) -> Vec<u8> {
    let mut body = Vec::new();
    for (i, d) in dgs.iter().enumerate() {
        body.push(d.cmd);
        body.push(i as u8);
        body.extend_from_slice(&d.adp.to_le_bytes());
        body.extend_from_slice(&d.ado.to_le_bytes());
        let more = if i + 1 < dgs.len() { 0x8000 } else { 0 };
        body.extend_from_slice(&(d.data.len() as u16 | more).to_le_bytes());
        body.extend_from_slice(&[0, 0]);
        body.extend_from_slice(&d.data);
        body.extend_from_slice(&[0, 0]);
    }
    let mut f = vec![0xFF; 6];
    f.extend_from_slice(&MASTER_MAC);
    f.extend_from_slice(&[0x88, 0xA4]);
    f.extend_from_slice(&((body.len() as u16) | 0x1000).to_le_bytes());
    f.extend_from_slice(&body);
    f
}

/// A datagram as it came back.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) struct Reply {
    pub adp: u16,
    pub irq: u16,
    pub data: Vec<u8>,
    pub wkc: u16,
}

pub(super) fn parse_replies(f: &[u8]) -> Vec<Reply> {
    let mut out = Vec::new();
    let mut at = 16;
    loop {
        let len = (u16::from_le_bytes([f[at + 6], f[at + 7]]) & 0x7FF) as usize;
        let more = u16::from_le_bytes([f[at + 6], f[at + 7]]) & 0x8000 != 0;
        out.push(Reply {
            adp: u16::from_le_bytes([f[at + 2], f[at + 3]]),
            irq: u16::from_le_bytes([f[at + 8], f[at + 9]]),
            data: f[at + 10..at + 10 + len].to_vec(),
            wkc: u16::from_le_bytes([f[at + 10 + len], f[at + 11 + len]]),
        });
        at += 12 + len;
        if !more {
            return out;
        }
    }
}

/// Sends one frame with `dgs` through `escs`; returns the datagrams as they came back.
pub(super) fn send(escs: &mut [Et1100], dgs: &[Dg]) -> Vec<Reply> {
    let mut f = build_frame(dgs);
    process_frame(&mut f, escs.iter_mut()).expect("valid frame");
    parse_replies(&f)
}

/// Sends a single datagram; returns (data, wkc).
pub(super) fn send1(
    escs: &mut [Et1100],
    cmd: u8,
    adp: u16,
    ado: u16,
    data: &[u8],
) -> (Vec<u8>, u16) {
    let r = send(escs, &[dg(cmd, adp, ado, data)]).remove(0);
    (r.data, r.wkc)
}

/// `n` ESCs with station addresses 0x1000 + k, all at global time 0.
pub(super) fn ring(n: usize) -> Vec<Et1100> {
    let mut escs: Vec<Et1100> = (0..n).map(|_| esc()).collect();
    for k in 0..n {
        let adp = (k as u16).wrapping_neg();
        let (_, wkc) = send1(
            &mut escs,
            APWR,
            adp,
            hal::esc::regs::STATION_ADDRESS.addr,
            &(0x1000 + k as u16).to_le_bytes(),
        );
        assert_eq!(wkc, 1);
    }
    escs
}

pub(super) fn station(k: usize) -> u16 {
    0x1000 + k as u16
}

/// FPRD of `len` bytes from ESC `k`.
pub(super) fn fprd(escs: &mut [Et1100], k: usize, ado: u16, len: usize) -> (Vec<u8>, u16) {
    send1(escs, FPRD, station(k), ado, &vec![0; len])
}

/// FPWR to ESC `k`; returns the working counter.
pub(super) fn fpwr(escs: &mut [Et1100], k: usize, ado: u16, data: &[u8]) -> u16 {
    send1(escs, FPWR, station(k), ado, data).1
}

pub(super) fn u16le(b: &[u8]) -> u16 {
    u16::from_le_bytes([b[0], b[1]])
}

pub(super) fn u32le(b: &[u8]) -> u32 {
    u32::from_le_bytes([b[0], b[1], b[2], b[3]])
}

pub(super) fn u64le(b: &[u8]) -> u64 {
    u64::from_le_bytes(b[..8].try_into().unwrap())
}

/// SM register block bytes.
pub(super) fn sm_bytes(start: u16, len: u16, control: u8, activate: u8) -> [u8; 8] {
    let s = start.to_le_bytes();
    let l = len.to_le_bytes();
    [s[0], s[1], l[0], l[1], control, 0, activate, 0]
}
