//! SyncManagers (0x0800 + 8n): mailbox (single buffer) and buffered (3-buffer) mode.
//!
//! Rules (Section I §8, reference ethercat-slave.md §2.3):
//! - mailbox: the writer owns the buffer until it writes the last byte (start + len - 1); the
//!   buffer is then full (status bit 3) and the reader may read it; reading the last byte empties
//!   it. A write to a full or a read of an empty mailbox is not executed (no working counter).
//! - 3-buffer: three buffers at start, start + len, start + 2 len; both sides address only the
//!   first. A writer's buffer becomes "last consistently written" when its last byte is written
//!   (ECAT side: at the end of the frame); a reader latches the newest complete buffer when it
//!   reads the first byte.
//! - status bit 0 (written completely) / bit 1 (read completely) mirror into AL event bit 8+n
//!   (the PDI side's event) and ECAT event bit 4+n (the master's event) when enabled in control.

use hal::esc::{
    regs, AlEvent, EcatEvent, SmActivate, SmConfig, SmControl, SmDirection, SmMode, SmPdiControl,
    SmStatus,
};

use super::access::Side;
use super::Et1100;

/// SyncManagers an ET1100 implements.
pub(crate) const SM_COUNT: usize = regs::ET1100_SMS as usize;
/// Activate bits ECAT may write (enable, repeat request, latch events).
const ACTIVATE_WRITABLE: u8 = SmActivate::ENABLE
    | SmActivate::REPEAT_REQUEST
    | SmActivate::LATCH_ECAT
    | SmActivate::LATCH_PDI;
/// PDI control bits the PDI may write.
const PDI_CONTROL_WRITABLE: u8 = SmPdiControl::DEACTIVATE | SmPdiControl::REPEAT_ACK;

/// Internal buffer state of one SyncManager.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct SmState {
    /// Mailbox: buffer full.
    full: bool,
    /// 3-buffer: buffer the writer writes into.
    write_buf: u8,
    /// 3-buffer: buffer the reader latched.
    read_buf: u8,
    /// 3-buffer: the third buffer (newest complete when `has_new`, else free).
    spare_buf: u8,
    /// 3-buffer: `spare_buf` holds data newer than `read_buf`.
    has_new: bool,
    /// 3-buffer: index of the last completely written buffer.
    last_written: Option<u8>,
    /// Status bit 0: buffer written completely (cleared when the reader opens it).
    irq_write: bool,
    /// Status bit 1: buffer read completely (cleared when the writer opens it).
    irq_read: bool,
    /// Status bit 6.
    read_open: bool,
    /// Status bit 7.
    write_open: bool,
    /// ECAT wrote the last byte in the current frame (completes at the end of the frame).
    pending_write: bool,
    /// ECAT read the last byte in the current frame (completes at the end of the frame).
    pending_read: bool,
}

impl Default for SmState {
    fn default() -> Self {
        Self {
            full: false,
            write_buf: 0,
            spare_buf: 1,
            read_buf: 2,
            has_new: false,
            last_written: None,
            irq_write: false,
            irq_read: false,
            read_open: false,
            write_open: false,
            pending_write: false,
            pending_read: false,
        }
    }
}

impl SmState {
    fn status_byte(&self, mode: SmMode) -> u8 {
        let mut s = 0u8;
        if self.irq_write {
            s |= SmStatus::IRQ_WRITE;
        }
        if self.irq_read {
            s |= SmStatus::IRQ_READ;
        }
        match mode {
            SmMode::Mailbox => {
                if self.full {
                    s |= SmStatus::MAILBOX_FULL;
                }
            }
            _ => {
                let state = self.last_written.unwrap_or(SmStatus::BUFFER_STATE_NONE);
                s |= state << SmStatus::BUFFER_STATE_SHIFT;
            }
        }
        if self.read_open {
            s |= SmStatus::READ_OPEN;
        }
        if self.write_open {
            s |= SmStatus::WRITE_OPEN;
        }
        s
    }
}

/// Which SM and which offset inside its 8-byte block an address names.
pub(crate) fn sm_register(addr: u16) -> Option<(usize, u16)> {
    let rel = addr.checked_sub(regs::SM_BASE)?;
    let n = usize::from(rel / regs::SM_LEN);
    (n < SM_COUNT).then_some((n, rel % regs::SM_LEN))
}

impl Et1100 {
    pub(crate) fn sm_config(&self, n: usize) -> SmConfig {
        SmConfig::from_bytes(self.bytes_at(regs::sm(n as u8).addr))
    }

    /// The memory window `(start, len)` of SM `n` if ECAT enabled it with a non-zero length.
    pub(crate) fn sm_window(&self, n: usize) -> Option<(u32, u32)> {
        let c = self.sm_config(n);
        (c.activate.enabled() && c.length > 0).then_some((u32::from(c.start), u32::from(c.length)))
    }

    /// Resets the buffer state of SM `n` (disable, enable, PDI deactivate).
    pub(crate) fn sm_reset(&mut self, n: usize) {
        if let Some(st) = self.sm.get_mut(n) {
            *st = SmState::default();
        }
        self.sm_sync_status(n);
    }

    /// Rewrites status byte +5 and the SM's AL/ECAT event bits from the internal state.
    pub(crate) fn sm_sync_status(&mut self, n: usize) {
        let Some(st) = self.sm.get(n).copied() else {
            return;
        };
        let c = self.sm_config(n);
        let status = st.status_byte(c.control.mode());
        self.set_u8(regs::sm(n as u8).addr + regs::sm_offset::STATUS, status);
        let (pdi_event, ecat_ev) = match c.control.direction() {
            SmDirection::EcatWrite => (st.irq_write, st.irq_read),
            _ => (st.irq_read, st.irq_write),
        };
        let al_on = pdi_event && c.control.0 & SmControl::PDI_IRQ != 0;
        self.set_al_event_bits(AlEvent::sm(n as u8), al_on);
        let ecat_on = ecat_ev && c.control.0 & SmControl::ECAT_IRQ != 0;
        self.set_ecat_event_bits(EcatEvent::sm(n as u8), ecat_on);
    }

    fn sm_is_writer(c: SmConfig, side: Side) -> bool {
        matches!(
            (c.control.direction(), side),
            (SmDirection::EcatWrite, Side::Ecat) | (SmDirection::EcatRead, Side::Pdi)
        )
    }

    fn sm_is_reader(c: SmConfig, side: Side) -> bool {
        matches!(
            (c.control.direction(), side),
            (SmDirection::EcatRead, Side::Ecat) | (SmDirection::EcatWrite, Side::Pdi)
        )
    }

    /// Physical address of offset `off` in buffer `buf` of SM `c`.
    fn sm_phys(c: SmConfig, buf: u8, off: u16) -> usize {
        usize::from(c.start) + usize::from(buf) * usize::from(c.length) + usize::from(off)
    }

    /// Writes `data` at offset `off` inside SM `n`'s window. Returns whether it was executed.
    pub(crate) fn sm_write(
        &mut self,
        side: Side,
        n: usize,
        off: u16,
        data: &[u8],
        mask: Option<&[u8]>,
    ) -> bool {
        let c = self.sm_config(n);
        let Some(st) = self.sm.get(n).copied() else {
            return false;
        };
        if c.pdi_control.0 & SmPdiControl::DEACTIVATE != 0 {
            // Deactivated by the PDI: ECAT access is locked, the PDI sees plain memory.
            return side == Side::Pdi
                && self.plain_write(usize::from(c.start) + usize::from(off), data, mask);
        }
        if !Self::sm_is_writer(c, side) {
            return false;
        }
        let buf = match c.control.mode() {
            SmMode::Mailbox => {
                if st.full || st.pending_write {
                    return false;
                }
                0
            }
            SmMode::Buffered => st.write_buf,
            SmMode::Reserved => return false,
        };
        self.plain_write(Self::sm_phys(c, buf, off), data, mask);
        let touches_last = usize::from(off) + data.len() >= usize::from(c.length);
        if let Some(st) = self.sm.get_mut(n) {
            if off == 0 {
                st.write_open = true;
                st.irq_read = false;
            }
            if touches_last && side == Side::Ecat {
                st.pending_write = true;
            }
        }
        if side == Side::Ecat && c.control.watchdog_trigger() {
            self.watchdog_pd_trigger();
        }
        if touches_last && side == Side::Pdi {
            self.sm_complete_write(n);
        } else {
            self.sm_sync_status(n);
        }
        true
    }

    /// Reads `buf.len()` bytes at offset `off` inside SM `n`'s window. Returns whether it was
    /// executed.
    pub(crate) fn sm_read(&mut self, side: Side, n: usize, off: u16, buf: &mut [u8]) -> bool {
        let c = self.sm_config(n);
        let Some(st) = self.sm.get(n).copied() else {
            return false;
        };
        if c.pdi_control.0 & SmPdiControl::DEACTIVATE != 0 {
            return side == Side::Pdi
                && self.plain_read(usize::from(c.start) + usize::from(off), buf);
        }
        if !Self::sm_is_reader(c, side) {
            return false;
        }
        let src = match c.control.mode() {
            SmMode::Mailbox => {
                if !st.full || st.pending_read {
                    return false;
                }
                0
            }
            SmMode::Buffered => {
                if off == 0 {
                    if let Some(st) = self.sm.get_mut(n) {
                        if st.has_new {
                            core::mem::swap(&mut st.read_buf, &mut st.spare_buf);
                            st.has_new = false;
                        }
                    }
                }
                self.sm.get(n).map_or(0, |s| s.read_buf)
            }
            SmMode::Reserved => return false,
        };
        self.plain_read(Self::sm_phys(c, src, off), buf);
        let touches_last = usize::from(off) + buf.len() >= usize::from(c.length);
        if let Some(st) = self.sm.get_mut(n) {
            if off == 0 {
                st.read_open = true;
                st.irq_write = false;
            }
            if touches_last && side == Side::Ecat {
                st.pending_read = true;
            }
        }
        if touches_last && side == Side::Pdi {
            self.sm_complete_read(n);
        } else {
            self.sm_sync_status(n);
        }
        true
    }

    fn plain_write(&mut self, phys: usize, data: &[u8], mask: Option<&[u8]>) -> bool {
        for (i, v) in data.iter().enumerate() {
            let m = mask.and_then(|m| m.get(i)).copied().unwrap_or(0xFF);
            if let Some(b) = phys.checked_add(i).and_then(|a| self.mem.get_mut(a)) {
                *b = (*b & !m) | (v & m);
            }
        }
        true
    }

    fn plain_read(&self, phys: usize, buf: &mut [u8]) -> bool {
        for (i, b) in buf.iter_mut().enumerate() {
            *b = phys
                .checked_add(i)
                .and_then(|a| self.mem.get(a))
                .copied()
                .unwrap_or(0);
        }
        true
    }

    fn sm_complete_write(&mut self, n: usize) {
        let mode = self.sm_config(n).control.mode();
        if let Some(st) = self.sm.get_mut(n) {
            match mode {
                SmMode::Mailbox => st.full = true,
                _ => {
                    st.last_written = Some(st.write_buf);
                    core::mem::swap(&mut st.write_buf, &mut st.spare_buf);
                    st.has_new = true;
                }
            }
            st.irq_write = true;
            st.write_open = false;
            st.pending_write = false;
        }
        self.sm_sync_status(n);
    }

    fn sm_complete_read(&mut self, n: usize) {
        let mode = self.sm_config(n).control.mode();
        if let Some(st) = self.sm.get_mut(n) {
            if mode == SmMode::Mailbox {
                st.full = false;
            }
            st.irq_read = true;
            st.read_open = false;
            st.pending_read = false;
        }
        self.sm_sync_status(n);
    }

    /// End of a frame that passed this ESC without error: ECAT-side completions take effect.
    pub(crate) fn sm_end_of_frame(&mut self) {
        for n in 0..SM_COUNT {
            let Some(st) = self.sm.get(n).copied() else {
                continue;
            };
            if st.pending_write {
                self.sm_complete_write(n);
            }
            if st.pending_read {
                self.sm_complete_read(n);
            }
        }
    }

    /// ECAT write of one byte of SM `n`'s register block.
    pub(crate) fn sm_register_ecat_write(&mut self, n: usize, off: u16, v: u8) {
        let base = regs::sm(n as u8).addr;
        let old = self.sm_config(n);
        match off {
            // PSA, length and control are writable only while the SM is disabled.
            regs::sm_offset::START..=regs::sm_offset::CONTROL if !old.activate.enabled() => {
                self.set_u8(base + off, v);
            }
            regs::sm_offset::ACTIVATE => {
                let new = v & ACTIVATE_WRITABLE;
                self.set_u8(base + off, new);
                self.sm_activation_changed |= 1 << n;
                self.set_al_event_bits(AlEvent::SM_ACTIVATION, true);
                if (old.activate.0 ^ new) & SmActivate::ENABLE != 0 {
                    self.sm_reset(n);
                }
            }
            // Status (+5) and PDI control (+7) are read-only for ECAT.
            _ => {}
        }
    }

    /// PDI write of one byte of SM `n`'s register block (only the PDI control byte).
    pub(crate) fn sm_register_pdi_write(&mut self, n: usize, off: u16, v: u8) {
        if off != regs::sm_offset::PDI_CONTROL {
            return;
        }
        let base = regs::sm(n as u8).addr;
        let old = self.u8_at(base + off);
        let new = v & PDI_CONTROL_WRITABLE;
        self.set_u8(base + off, new);
        if (old ^ new) & SmPdiControl::DEACTIVATE != 0 {
            self.sm_reset(n);
        }
    }

    /// PDI read of one byte of SM `n`'s register block: reading the activate byte acknowledges
    /// the "SM activation changed" event for that SM.
    pub(crate) fn sm_register_pdi_read(&mut self, n: usize, off: u16) {
        if off == regs::sm_offset::ACTIVATE {
            self.sm_activation_changed &= !(1u8 << n);
            if self.sm_activation_changed == 0 {
                self.set_al_event_bits(AlEvent::SM_ACTIVATION, false);
            }
        }
    }
}
