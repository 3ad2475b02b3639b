//! Datagram processing in one ESC (ETG.1000.4 §5.4): addressing, commands, working counter.
//!
//! | command | addressed when | action | WKC |
//! |---|---|---|---|
//! | APxx, ARMW | ADP = 0 on arrival (every ESC increments ADP) | read / write / read+write | +1 read, +1 write (+2 write for APRW) |
//! | FPxx, FRMW | ADP = station address (or alias when 0x0103 bit 0) | as above | as above |
//! | Bxx | always (ADP incremented) | BRD/BRW OR the read data into the frame | as above |
//! | Lxx | through the FMMUs | see `fmmu` | LRD/LWR +1, LRW +1 read +2 write |
//!
//! ARMW/FRMW: the addressed slave reads (+1), every other slave writes (+1). Each ESC ORs its
//! ECAT event request & mask (0x0210 & 0x0200) into every datagram's IRQ field.

use hal::esc::{regs, DlControl};

use super::access::{Effects, FrameTiming, Side};
use super::frame::{DG_HEADER_LEN, DG_LEN_MASK};
use super::Et1100;

/// EtherCAT commands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Command {
    Nop,
    Aprd,
    Apwr,
    Aprw,
    Fprd,
    Fpwr,
    Fprw,
    Brd,
    Bwr,
    Brw,
    Lrd,
    Lwr,
    Lrw,
    Armw,
    Frmw,
}

impl Command {
    pub(crate) fn from_code(c: u8) -> Option<Self> {
        Some(match c {
            0 => Self::Nop,
            1 => Self::Aprd,
            2 => Self::Apwr,
            3 => Self::Aprw,
            4 => Self::Fprd,
            5 => Self::Fpwr,
            6 => Self::Fprw,
            7 => Self::Brd,
            8 => Self::Bwr,
            9 => Self::Brw,
            10 => Self::Lrd,
            11 => Self::Lwr,
            12 => Self::Lrw,
            13 => Self::Armw,
            14 => Self::Frmw,
            _ => return None,
        })
    }
}

/// How a physically addressed command acts on the addressed slave.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Action {
    Read,
    Write,
    ReadWrite,
    /// BRD: OR the read data into the frame.
    ReadOr,
    /// BRW: OR the read data into the frame and write the arriving data.
    ReadOrWrite,
}

/// Offsets inside a datagram.
const CMD: usize = 0;
const ADP: usize = 2;
const ADO: usize = 4;
const LEN: usize = 6;
const IRQ: usize = 8;

fn le16(d: &[u8], at: usize) -> u16 {
    u16::from_le_bytes([
        d.get(at).copied().unwrap_or(0),
        d.get(at + 1).copied().unwrap_or(0),
    ])
}

fn put16(d: &mut [u8], at: usize, v: u16) {
    for (i, b) in v.to_le_bytes().into_iter().enumerate() {
        if let Some(x) = d.get_mut(at + i) {
            *x = b;
        }
    }
}

impl Et1100 {
    fn fp_addressed(&self, adp: u16) -> bool {
        adp == self.u16_at(regs::STATION_ADDRESS.addr)
            || (DlControl(self.u32_at(regs::DL_CONTROL.addr)).station_alias()
                && adp == self.u16_at(regs::STATION_ALIAS.addr))
    }

    /// Processes one datagram `dg` (header, data, working counter; its length was checked by the
    /// frame parser). Unknown commands pass unchanged.
    pub(crate) fn process_datagram(&mut self, dg: &mut [u8], timing: FrameTiming) {
        let Some(cmd) = dg.get(CMD).copied().and_then(Command::from_code) else {
            return;
        };
        let len = usize::from(le16(dg, LEN) & DG_LEN_MASK);
        let adp = le16(dg, ADP);
        let ado = le16(dg, ADO);
        let laddr = u32::from(adp) | (u32::from(ado) << 16);
        let irq = le16(dg, IRQ) | (self.ecat_event() & self.u16_at(regs::ECAT_EVENT_MASK.addr));
        put16(dg, IRQ, irq);
        let wkc_at = DG_HEADER_LEN + len;
        let wkc = le16(dg, wkc_at);
        let Some(data) = dg.get_mut(DG_HEADER_LEN..wkc_at) else {
            return;
        };
        let mut fx = Effects::in_frame(timing);

        let (action, next_adp) = match cmd {
            Command::Nop => return,
            Command::Aprd | Command::Apwr | Command::Aprw | Command::Armw => {
                let action = match (cmd, adp == 0) {
                    (Command::Aprd, true) => Some(Action::Read),
                    (Command::Apwr, true) => Some(Action::Write),
                    (Command::Aprw, true) => Some(Action::ReadWrite),
                    (Command::Armw, true) => Some(Action::Read),
                    (Command::Armw, false) => Some(Action::Write),
                    _ => None,
                };
                (action, Some(adp.wrapping_add(1)))
            }
            Command::Fprd | Command::Fpwr | Command::Fprw | Command::Frmw => {
                let hit = self.fp_addressed(adp);
                let action = match (cmd, hit) {
                    (Command::Fprd, true) => Some(Action::Read),
                    (Command::Fpwr, true) => Some(Action::Write),
                    (Command::Fprw, true) => Some(Action::ReadWrite),
                    (Command::Frmw, true) => Some(Action::Read),
                    (Command::Frmw, false) => Some(Action::Write),
                    _ => None,
                };
                (action, None)
            }
            Command::Brd => (Some(Action::ReadOr), Some(adp.wrapping_add(1))),
            Command::Bwr => (Some(Action::Write), Some(adp.wrapping_add(1))),
            Command::Brw => (Some(Action::ReadOrWrite), Some(adp.wrapping_add(1))),
            Command::Lrd | Command::Lwr | Command::Lrw => {
                let read = matches!(cmd, Command::Lrd | Command::Lrw);
                let write = matches!(cmd, Command::Lwr | Command::Lrw);
                let inc = self.logical(read, write, laddr, data, &mut fx);
                put16(dg, wkc_at, wkc.wrapping_add(inc));
                return;
            }
        };
        let rw_weight = if matches!(cmd, Command::Aprw | Command::Fprw | Command::Brw) {
            2
        } else {
            1
        };
        let inc = match action {
            Some(a) => self.physical(a, u32::from(ado), data, rw_weight, &mut fx),
            None => 0,
        };
        if let Some(next) = next_adp {
            put16(dg, ADP, next);
        }
        put16(dg, wkc_at, wkc.wrapping_add(inc));
    }

    /// Executes a physically addressed action; returns the working counter increment.
    fn physical(
        &mut self,
        action: Action,
        ado: u32,
        data: &mut [u8],
        write_weight: u16,
        fx: &mut Effects,
    ) -> u16 {
        match action {
            Action::Read => u16::from(self.read_range(Side::Ecat, ado, data, fx)),
            Action::Write => {
                let ok = self.write_range(Side::Ecat, ado, data, None, fx);
                self.finish_write(Side::Ecat, fx);
                u16::from(ok)
            }
            Action::ReadOr | Action::ReadWrite | Action::ReadOrWrite => {
                let mut buf = core::mem::take(&mut self.scratch);
                buf.clear();
                buf.resize(data.len(), 0);
                let read_ok = self.read_range(Side::Ecat, ado, &mut buf, fx);
                let write_ok = if action == Action::ReadOr {
                    false
                } else {
                    let ok = self.write_range(Side::Ecat, ado, data, None, fx);
                    self.finish_write(Side::Ecat, fx);
                    ok
                };
                if read_ok {
                    for (d, r) in data.iter_mut().zip(buf.iter()) {
                        if action == Action::ReadWrite {
                            *d = *r;
                        } else {
                            *d |= *r;
                        }
                    }
                }
                self.scratch = buf;
                u16::from(read_ok) + write_weight * u16::from(write_ok)
            }
        }
    }
}
