//! FMMUs (0x0600 + 16n): bit-exact mapping of logical addresses onto physical memory.
//!
//! An active FMMU maps the logical bits from (logical start, start bit) to (logical start +
//! length - 1, end bit) onto consecutive physical bits from (physical start, start bit). A logical
//! datagram touches every active FMMU of the matching direction (type bit 0 read, bit 1 write)
//! that overlaps its range; the physical side goes through the normal ECAT access path, so SM
//! windows keep their mailbox / 3-buffer semantics. Working counter (ETG.1000.4): LRD +1 and LWR
//! +1 when this slave read / wrote anything, LRW +1 for a read and +2 for a write.

use hal::esc::{regs, FmmuConfig};

use super::access::{Effects, Side};
use super::Et1100;

const BITS: u64 = 8;

/// The overlap of one FMMU with one datagram, in logical bits, and the bit shift to physical.
#[derive(Clone, Copy, Debug)]
struct Overlap {
    /// First overlapping logical bit.
    first: u64,
    /// Last overlapping logical bit (inclusive).
    last: u64,
    /// physical bit = logical bit + shift.
    shift: i64,
}

impl Overlap {
    fn of(f: &FmmuConfig, laddr: u32, len: usize) -> Option<Self> {
        if !f.active || f.length == 0 || len == 0 {
            return None;
        }
        let lb0 = u64::from(f.logical_start) * BITS + u64::from(f.logical_start_bit);
        let lb1 = (u64::from(f.logical_start) + u64::from(f.length) - 1) * BITS
            + u64::from(f.logical_end_bit);
        let db0 = u64::from(laddr) * BITS;
        let db1 = (u64::from(laddr) + len as u64) * BITS - 1;
        let first = lb0.max(db0);
        let last = lb1.min(db1);
        if first > last {
            return None;
        }
        let pb0 = u64::from(f.physical_start) * BITS + u64::from(f.physical_start_bit);
        Some(Self {
            first,
            last,
            shift: pb0 as i64 - lb0 as i64,
        })
    }

    fn phys(&self, l: u64) -> u64 {
        (l as i64 + self.shift) as u64
    }

    /// Physical byte range touched: (first byte, byte count).
    fn phys_bytes(&self) -> (u64, usize) {
        let p0 = self.phys(self.first) / BITS;
        let p1 = self.phys(self.last) / BITS;
        (p0, (p1 - p0 + 1) as usize)
    }
}

impl Et1100 {
    fn fmmu_config(&self, n: u8) -> FmmuConfig {
        FmmuConfig::from_bytes(self.bytes_at(regs::fmmu(n).addr))
    }

    /// Executes a logical datagram on this slave; returns its working counter increment.
    pub(crate) fn logical(
        &mut self,
        read: bool,
        write: bool,
        laddr: u32,
        data: &mut [u8],
        fx: &mut Effects,
    ) -> u16 {
        let mut wrote = false;
        let mut was_read = false;
        // Writes first: they carry the data as it arrived; reads then replace frame bits.
        if write {
            for n in 0..regs::ET1100_FMMUS {
                let f = self.fmmu_config(n);
                if !f.kind.write() {
                    continue;
                }
                if let Some(o) = Overlap::of(&f, laddr, data.len()) {
                    wrote |= self.fmmu_write(&o, laddr, data, fx);
                }
            }
        }
        if read {
            for n in 0..regs::ET1100_FMMUS {
                let f = self.fmmu_config(n);
                if !f.kind.read() {
                    continue;
                }
                if let Some(o) = Overlap::of(&f, laddr, data.len()) {
                    was_read |= self.fmmu_read(&o, laddr, data, fx);
                }
            }
        }
        match (read, write) {
            (true, true) => u16::from(was_read) + 2 * u16::from(wrote),
            (true, false) => u16::from(was_read),
            (false, true) => u16::from(wrote),
            (false, false) => 0,
        }
    }

    fn fmmu_write(&mut self, o: &Overlap, laddr: u32, data: &[u8], fx: &mut Effects) -> bool {
        let (p0, count) = o.phys_bytes();
        let Ok(p0) = u32::try_from(p0) else {
            return false;
        };
        let mut buf = core::mem::take(&mut self.scratch);
        let mut mask = core::mem::take(&mut self.scratch_mask);
        buf.clear();
        buf.resize(count, 0);
        mask.clear();
        mask.resize(count, 0);
        let base = u64::from(laddr) * BITS;
        for l in o.first..=o.last {
            let li = l - base;
            let bit = data
                .get((li / BITS) as usize)
                .is_some_and(|b| b & (1 << (li % BITS)) != 0);
            let p = o.phys(l) - u64::from(p0) * BITS;
            let (pi, pb) = ((p / BITS) as usize, p % BITS);
            if let (Some(d), Some(m)) = (buf.get_mut(pi), mask.get_mut(pi)) {
                *m |= 1 << pb;
                if bit {
                    *d |= 1 << pb;
                }
            }
        }
        let ok = self.write_range(Side::Ecat, p0, &buf, Some(&mask), fx);
        self.finish_write(Side::Ecat, fx);
        self.scratch = buf;
        self.scratch_mask = mask;
        ok
    }

    fn fmmu_read(&mut self, o: &Overlap, laddr: u32, data: &mut [u8], fx: &mut Effects) -> bool {
        let (p0, count) = o.phys_bytes();
        let Ok(p0) = u32::try_from(p0) else {
            return false;
        };
        let mut buf = core::mem::take(&mut self.scratch);
        buf.clear();
        buf.resize(count, 0);
        let ok = self.read_range(Side::Ecat, p0, &mut buf, fx);
        if ok {
            let base = u64::from(laddr) * BITS;
            for l in o.first..=o.last {
                let p = o.phys(l) - u64::from(p0) * BITS;
                let bit = buf
                    .get((p / BITS) as usize)
                    .is_some_and(|b| b & (1 << (p % BITS)) != 0);
                let li = l - base;
                if let Some(d) = data.get_mut((li / BITS) as usize) {
                    let m = 1u8 << (li % BITS);
                    if bit {
                        *d |= m;
                    } else {
                        *d &= !m;
                    }
                }
            }
        }
        self.scratch = buf;
        ok
    }
}
