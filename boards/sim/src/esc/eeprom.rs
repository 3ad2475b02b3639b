//! SII EEPROM: power-on load of the configuration area and the EEPROM interface 0x0500..0x050F.
//!
//! - 0x0500 bit 0 offers the interface to the PDI, 0x0501 bit 0 is the PDI taking it; ECAT owns
//!   it unless both are set. Bit 1 of 0x0500 (force ECAT) clears 0x0501.
//! - 0x0502 control/status: the writer sets write enable (bit 0) and the command (bits 8..10);
//!   the command runs once the whole access (address bytes included) is done. Read returns 8
//!   bytes (bit 6 reads 1: the ET1100 reads 8 bytes) at the word address 0x0504 into 0x0508;
//!   write stores 0x0508..0x0509 at the word address and needs write enable in the same access
//!   (else bit 14); reload reloads the configuration words (not the alias); an unknown command
//!   sets bit 13; command 0 clears the error bits. Busy (bit 15) lasts [`EEPROM_BUSY_NS`] of
//!   simulated time or [`EEPROM_BUSY_FRAMES`] further frames, whichever ends first; writes to
//!   0x0502..0x050F while busy are ignored.

use hal::esc::sii::{self, word};
use hal::esc::{regs, EepromCommand, EepromConfig, EepromControl, EepromPdiAccess};

use super::access::Side;
use super::consts::{EEPROM_BUSY_FRAMES, EEPROM_BUSY_NS, EEPROM_ERASED, EEPROM_MAX_BYTES};
use super::Et1100;

/// Bytes returned by one read command: the ET1100 always reads 8 bytes (0x0502 bit 6 reads 1).
const EEPROM_READ_BYTES: usize = EepromControl::READ_LEN_8;
/// Bytes written by one write command.
const EEPROM_WRITE_BYTES: usize = EepromControl::WRITE_LEN;

/// A command in progress.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Busy {
    command: EepromCommand,
    started_ns: u64,
    frames_seen: u8,
}

/// State of the EEPROM interface beyond its registers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct EepromUnit {
    busy: Option<Busy>,
}

impl Et1100 {
    /// Word `w` of the SII image (erased value beyond the image).
    fn sii_word(&self, w: usize) -> u16 {
        let byte = |i: usize| self.sii.get(i).copied().unwrap_or(EEPROM_ERASED);
        u16::from_le_bytes([byte(2 * w), byte(2 * w + 1)])
    }

    /// Reset value of the EEPROM control register: 8-byte reads, 2-byte addressing.
    pub(crate) fn eeprom_power_on(&mut self) {
        self.set_u16(
            regs::EEPROM_CONTROL.addr,
            EepromControl::READ_8_BYTES | EepromControl::TWO_BYTE_ADDRESS,
        );
    }

    /// Loads the configuration area (words 0..3, and the alias at power-on) if its CRC is good.
    pub(crate) fn load_sii_config(&mut self, power_on: bool) {
        let mut head = [EEPROM_ERASED; sii::CRC_COVERED];
        for (i, b) in head.iter_mut().enumerate() {
            if let Some(v) = self.sii.get(i) {
                *b = *v;
            }
        }
        let stored = self.sii.get(sii::CRC_OFFSET).copied();
        let good = stored == Some(sii::crc8(&head));
        let mut ctl = self.u16_at(regs::EEPROM_CONTROL.addr);
        if good {
            self.set_u16(regs::PDI_CONTROL.addr, self.sii_word(word::PDI_CONTROL));
            self.set_u16(regs::PDI_CONFIG.addr, self.sii_word(word::PDI_CONFIG));
            self.set_u16(regs::DC_PULSE_LENGTH.addr, self.sii_word(word::SYNC_PULSE));
            self.set_u16(
                regs::PDI_CONFIG_EXT.addr,
                self.sii_word(word::PDI_CONFIG_EXT),
            );
            if power_on {
                self.set_u16(regs::STATION_ALIAS.addr, self.sii_word(word::ALIAS));
            }
            ctl &= !(EepromControl::CHECKSUM_ERROR | EepromControl::NOT_LOADED);
        } else {
            ctl |= EepromControl::CHECKSUM_ERROR | EepromControl::NOT_LOADED;
        }
        self.set_u16(regs::EEPROM_CONTROL.addr, ctl);
        self.pdi_operational = good;
        self.update_dl_status();
    }

    fn pdi_owns_eeprom(&self) -> bool {
        self.u8_at(regs::EEPROM_CONFIG.addr) & EepromConfig::OFFER_PDI != 0
            && self.u8_at(regs::EEPROM_PDI_ACCESS.addr) & EepromPdiAccess::PDI_OWNS != 0
    }

    /// Whether `addr` is one of the interface registers 0x0502..0x050F.
    pub(crate) fn eeprom_interface_reg(&self, addr: u16) -> bool {
        addr >= regs::EEPROM_CONTROL.addr && addr < regs::EEPROM_DATA.end()
    }

    /// ECAT write of 0x0500.
    pub(crate) fn eeprom_config_ecat_write(&mut self, v: u8) {
        let v = v & (EepromConfig::OFFER_PDI | EepromConfig::FORCE_ECAT);
        self.set_u8(regs::EEPROM_CONFIG.addr, v);
        if v & EepromConfig::FORCE_ECAT != 0 || v & EepromConfig::OFFER_PDI == 0 {
            self.set_u8(regs::EEPROM_PDI_ACCESS.addr, 0);
        }
    }

    /// PDI write of 0x0501: the PDI takes or releases the interface (only when offered).
    pub(crate) fn eeprom_pdi_access_write(&mut self, v: u8) {
        let cfg = self.u8_at(regs::EEPROM_CONFIG.addr);
        let take = v & EepromPdiAccess::PDI_OWNS != 0;
        if !take || (cfg & EepromConfig::OFFER_PDI != 0 && cfg & EepromConfig::FORCE_ECAT == 0) {
            self.set_u8(regs::EEPROM_PDI_ACCESS.addr, v & EepromPdiAccess::PDI_OWNS);
        }
    }

    /// Write of one byte of 0x0502..0x050F by `side`.
    pub(crate) fn eeprom_register_write(
        &mut self,
        side: Side,
        addr: u16,
        v: u8,
        fx: &mut super::access::Effects,
    ) {
        let owner = if self.pdi_owns_eeprom() {
            Side::Pdi
        } else {
            Side::Ecat
        };
        if side != owner || self.eeprom.busy.is_some() {
            return;
        }
        let ctl = regs::EEPROM_CONTROL.addr;
        if addr == ctl || addr == ctl + 1 {
            let shift = 8 * (addr - ctl);
            let writable = (EepromControl::WRITABLE >> shift) as u8;
            let old = self.u8_at(addr);
            self.set_u8(addr, (old & !writable) | (v & writable));
            if addr == ctl {
                fx.eeprom_write_enable = v & (EepromControl::WRITE_ENABLE as u8) != 0;
            } else {
                fx.eeprom_command_written = true;
            }
        } else {
            self.set_u8(addr, v);
        }
    }

    /// Starts the command just written to 0x0502.
    pub(crate) fn eeprom_execute(&mut self, _side: Side, write_enable: bool) {
        let mut ctl = EepromControl(self.u16_at(regs::EEPROM_CONTROL.addr));
        let command = ctl.command();
        ctl.0 &= !EepromControl::WRITE_ENABLE;
        match command {
            EepromCommand::Idle => {
                ctl.0 &= !(EepromControl::ACK_ERROR | EepromControl::WRITE_ENABLE_ERROR);
            }
            EepromCommand::Invalid(_) => {
                ctl.0 |= EepromControl::ACK_ERROR;
                ctl.0 &= !EepromControl::COMMAND_MASK;
            }
            EepromCommand::Write if !write_enable => {
                ctl.0 |= EepromControl::WRITE_ENABLE_ERROR;
                ctl.0 &= !EepromControl::COMMAND_MASK;
            }
            EepromCommand::Read | EepromCommand::Write | EepromCommand::Reload => {
                ctl.0 &= !(EepromControl::ACK_ERROR | EepromControl::WRITE_ENABLE_ERROR);
                ctl.0 |= EepromControl::BUSY;
                self.eeprom.busy = Some(Busy {
                    command,
                    started_ns: self.now,
                    frames_seen: 0,
                });
            }
        }
        self.set_u16(regs::EEPROM_CONTROL.addr, ctl.0);
    }

    /// Finishes the command in progress.
    fn eeprom_complete(&mut self) {
        let Some(busy) = self.eeprom.busy.take() else {
            return;
        };
        let word = self.u32_at(regs::EEPROM_ADDRESS.addr) as usize;
        let mut ctl = self.u16_at(regs::EEPROM_CONTROL.addr);
        match busy.command {
            EepromCommand::Read => {
                let mut data = [EEPROM_ERASED; EEPROM_READ_BYTES];
                for (i, b) in data.iter_mut().enumerate() {
                    if let Some(v) = word
                        .checked_mul(2)
                        .and_then(|a| a.checked_add(i))
                        .and_then(|a| self.sii.get(a))
                    {
                        *b = *v;
                    }
                }
                self.set_bytes(regs::EEPROM_DATA.addr, &data);
            }
            EepromCommand::Write => {
                let data: [u8; EEPROM_WRITE_BYTES] = self.bytes_at(regs::EEPROM_DATA.addr);
                let start = word.saturating_mul(2);
                let end = start.saturating_add(EEPROM_WRITE_BYTES);
                if end <= EEPROM_MAX_BYTES {
                    if self.sii.len() < end {
                        self.sii.resize(end, EEPROM_ERASED);
                    }
                    if let Some(dst) = self.sii.get_mut(start..end) {
                        dst.copy_from_slice(&data);
                    }
                } else {
                    ctl |= EepromControl::ACK_ERROR;
                }
            }
            EepromCommand::Reload => {
                self.set_u16(regs::EEPROM_CONTROL.addr, ctl & !EepromControl::BUSY);
                self.load_sii_config(false);
                ctl = self.u16_at(regs::EEPROM_CONTROL.addr);
            }
            EepromCommand::Idle | EepromCommand::Invalid(_) => {}
        }
        ctl &= !(EepromControl::BUSY | EepromControl::COMMAND_MASK);
        self.set_u16(regs::EEPROM_CONTROL.addr, ctl);
    }

    /// At the start of a frame: complete a command that has seen enough frames.
    pub(crate) fn eeprom_poll_frame_start(&mut self) {
        if self
            .eeprom
            .busy
            .is_some_and(|b| b.frames_seen >= EEPROM_BUSY_FRAMES)
        {
            self.eeprom_complete();
        }
    }

    /// At the end of a frame: count it for a command in progress.
    pub(crate) fn eeprom_count_frame(&mut self) {
        if let Some(b) = self.eeprom.busy.as_mut() {
            b.frames_seen = b.frames_seen.saturating_add(1);
        }
    }

    /// When time advances: complete a command whose busy time is over.
    pub(crate) fn eeprom_poll_time(&mut self) {
        if self
            .eeprom
            .busy
            .is_some_and(|b| self.now >= b.started_ns.saturating_add(EEPROM_BUSY_NS))
        {
            self.eeprom_complete();
        }
    }

    /// Global time at which the command in progress completes.
    pub(crate) fn eeprom_next_event(&self) -> Option<u64> {
        self.eeprom
            .busy
            .map(|b| b.started_ns.saturating_add(EEPROM_BUSY_NS))
    }
}
