//! Byte-range access to the ESC address space from either side, with per-byte register
//! semantics, SyncManager windows in process RAM, and the hooks that run after a whole access.

use super::consts::{ADDRESS_SPACE, REGISTER_END};
use super::Et1100;

/// Which port of the ESC an access comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Side {
    /// The EtherCAT side (a datagram from the master).
    Ecat,
    /// The process data interface (the MCU).
    Pdi,
}

/// Timing of the frame an ECAT access belongs to (global ns).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct FrameTiming {
    /// The frame's first bit entered port 0 (and the processing unit).
    pub port0: u64,
    /// The frame came back into port 1 (when port 1 is open).
    pub port1: Option<u64>,
}

/// Side effects collected during one access, run once the whole byte range is done.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Effects {
    /// Global time at which the access happens.
    pub time: u64,
    /// Frame timing (ECAT side only).
    pub frame: FrameTiming,
    /// System time snapshot for reads of 0x0910 (computed once per access).
    pub system_time: Option<u64>,
    /// Bytes of 0x0910..0x0917 written (bit i = byte i).
    pub systime_mask: u8,
    /// Values written to 0x0910..0x0917.
    pub systime_bytes: [u8; 8],
    /// 0x0900 was written (latch receive times).
    pub dc_latch: bool,
    /// 0x0981 was written.
    pub activation_written: bool,
    /// 0x0930 was written (reset the drift loop).
    pub speed_counter_written: bool,
    /// 0x0120 was written by ECAT.
    pub al_control_written: bool,
    /// The command byte 0x0503 was written.
    pub eeprom_command_written: bool,
    /// Write enable (0x0502 bit 0) was written as 1 in this access.
    pub eeprom_write_enable: bool,
}

impl Effects {
    /// Effects of an access at global time `time` outside a frame (PDI).
    pub fn at(time: u64) -> Self {
        Self {
            time,
            frame: FrameTiming {
                port0: time,
                port1: None,
            },
            ..Self::default()
        }
    }

    /// Effects of an ECAT access inside a frame.
    pub fn in_frame(frame: FrameTiming) -> Self {
        Self {
            time: frame.port0,
            frame,
            ..Self::default()
        }
    }
}

/// The chunk of the address space a byte position falls into.
enum Region {
    /// Register area up to the given end.
    Registers { end: u32 },
    /// Window of SyncManager `n` starting at `start`, up to `end`.
    Sm { n: usize, start: u32, end: u32 },
    /// Plain process RAM up to `end`.
    Ram { end: u32 },
    /// Beyond the address space.
    Nowhere,
}

impl Et1100 {
    fn region(&self, pos: u32) -> Region {
        if pos < REGISTER_END {
            return Region::Registers { end: REGISTER_END };
        }
        let space_end = ADDRESS_SPACE as u32;
        if pos >= space_end {
            return Region::Nowhere;
        }
        let mut next_start = space_end;
        for n in 0..super::sm::SM_COUNT {
            let Some((start, len)) = self.sm_window(n) else {
                continue;
            };
            let end = start + len;
            if pos >= start && pos < end {
                return Region::Sm {
                    n,
                    start,
                    end: end.min(space_end),
                };
            }
            if start > pos {
                next_start = next_start.min(start);
            }
        }
        Region::Ram { end: next_start }
    }

    /// Reads `buf.len()` bytes at `addr` with the semantics of `side`. Bytes that are not
    /// executed (refused SM access, beyond the address space) are left untouched. Returns
    /// whether at least one byte was accessed (working counter rule).
    pub(crate) fn read_range(
        &mut self,
        side: Side,
        addr: u32,
        buf: &mut [u8],
        fx: &mut Effects,
    ) -> bool {
        let mut any = false;
        let end = addr.saturating_add(buf.len() as u32);
        let mut pos = addr;
        while pos < end {
            let idx = (pos - addr) as usize;
            let (chunk_end, ok) = match self.region(pos) {
                Region::Registers { end: r_end } => {
                    let chunk_end = end.min(r_end);
                    for a in pos..chunk_end {
                        let v = self.read_register(side, a as u16, fx);
                        if let Some(b) = buf.get_mut((a - addr) as usize) {
                            *b = v;
                        }
                    }
                    (chunk_end, true)
                }
                Region::Sm {
                    n,
                    start,
                    end: s_end,
                } => {
                    let chunk_end = end.min(s_end);
                    let len = (chunk_end - pos) as usize;
                    let ok = match buf.get_mut(idx..idx + len) {
                        Some(chunk) => self.sm_read(side, n, (pos - start) as u16, chunk),
                        None => false,
                    };
                    (chunk_end, ok)
                }
                Region::Ram { end: r_end } => {
                    let chunk_end = end.min(r_end);
                    let len = (chunk_end - pos) as usize;
                    if let (Some(src), Some(dst)) = (
                        self.mem.get(pos as usize..chunk_end as usize),
                        buf.get_mut(idx..idx + len),
                    ) {
                        dst.copy_from_slice(src);
                    }
                    (chunk_end, true)
                }
                Region::Nowhere => break,
            };
            any |= ok;
            pos = chunk_end;
        }
        any
    }

    /// Writes `data` at `addr` with the semantics of `side`. With `mask`, only the set bits of
    /// each byte are written (FMMU bit mapping); the other bits keep their value. The caller
    /// runs [`Et1100::finish_write`] afterwards. Returns whether at least one byte was accessed.
    pub(crate) fn write_range(
        &mut self,
        side: Side,
        addr: u32,
        data: &[u8],
        mask: Option<&[u8]>,
        fx: &mut Effects,
    ) -> bool {
        let mut any = false;
        let end = addr.saturating_add(data.len() as u32);
        let mut pos = addr;
        while pos < end {
            let idx = (pos - addr) as usize;
            let (chunk_end, ok) = match self.region(pos) {
                Region::Registers { end: r_end } => {
                    let chunk_end = end.min(r_end);
                    for a in pos..chunk_end {
                        let i = (a - addr) as usize;
                        let v = data.get(i).copied().unwrap_or(0);
                        let m = mask.and_then(|m| m.get(i)).copied().unwrap_or(0xFF);
                        let merged = (self.u8_at(a as u16) & !m) | (v & m);
                        self.write_register(side, a as u16, merged, fx);
                    }
                    (chunk_end, true)
                }
                Region::Sm {
                    n,
                    start,
                    end: s_end,
                } => {
                    let chunk_end = end.min(s_end);
                    let range = idx..idx + (chunk_end - pos) as usize;
                    let ok = match data.get(range.clone()) {
                        Some(chunk) => {
                            let m = mask.and_then(|m| m.get(range));
                            self.sm_write(side, n, (pos - start) as u16, chunk, m)
                        }
                        None => false,
                    };
                    (chunk_end, ok)
                }
                Region::Ram { end: r_end } => {
                    let chunk_end = end.min(r_end);
                    for a in pos..chunk_end {
                        let i = (a - addr) as usize;
                        let v = data.get(i).copied().unwrap_or(0);
                        let m = mask.and_then(|m| m.get(i)).copied().unwrap_or(0xFF);
                        if let Some(b) = self.mem.get_mut(a as usize) {
                            *b = (*b & !m) | (v & m);
                        }
                    }
                    (chunk_end, true)
                }
                Region::Nowhere => break,
            };
            any |= ok;
            pos = chunk_end;
        }
        any
    }
}
