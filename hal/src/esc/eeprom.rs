//! SII EEPROM interface registers (0x0500..0x050F, Section II 0x0500 ff.).

/// EEPROM configuration register 0x0500 (written by ECAT).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EepromConfig(pub u8);

impl EepromConfig {
    /// Bit 0: EEPROM control is offered to the PDI.
    pub const OFFER_PDI: u8 = 1 << 0;
    /// Bit 1: force ECAT access (clears [`EepromPdiAccess::PDI_OWNS`]).
    pub const FORCE_ECAT: u8 = 1 << 1;
}

/// EEPROM PDI access state register 0x0501 (written by the PDI).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EepromPdiAccess(pub u8);

impl EepromPdiAccess {
    /// Bit 0: the PDI holds the EEPROM interface (only while offered by 0x0500).
    pub const PDI_OWNS: u8 = 1 << 0;
}

/// EEPROM command, control bits 8..10.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EepromCommand {
    /// 000: idle / clear error bits.
    Idle,
    /// 001: read.
    Read,
    /// 010: write.
    Write,
    /// 100: reload.
    Reload,
    /// Any other code: invalid (sets the command error bit).
    Invalid(u8),
}

/// EEPROM control/status register 0x0502.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EepromControl(pub u16);

impl EepromControl {
    /// Bit 0: write enable (self-clearing).
    pub const WRITE_ENABLE: u16 = 1 << 0;
    /// Bit 5: EEPROM emulation by the PDI.
    pub const EMULATION: u16 = 1 << 5;
    /// Bit 6: read size: 0 = 4 bytes, 1 = 8 bytes.
    pub const READ_8_BYTES: u16 = 1 << 6;
    /// Bit 7: 2-byte (word) addressing.
    pub const TWO_BYTE_ADDRESS: u16 = 1 << 7;
    /// Bits 8..10: command.
    pub const COMMAND_MASK: u16 = 0x0700;
    /// Command code "read".
    pub const CMD_READ: u16 = 0x0100;
    /// Command code "write".
    pub const CMD_WRITE: u16 = 0x0200;
    /// Command code "reload".
    pub const CMD_RELOAD: u16 = 0x0400;
    /// Bit 11: checksum error in the configuration area.
    pub const CHECKSUM_ERROR: u16 = 1 << 11;
    /// Bit 12: device information (EEPROM) loading status: 1 = not loaded.
    pub const NOT_LOADED: u16 = 1 << 12;
    /// Bit 13: acknowledge / command error.
    pub const ACK_ERROR: u16 = 1 << 13;
    /// Bit 14: write enable error.
    pub const WRITE_ENABLE_ERROR: u16 = 1 << 14;
    /// Bit 15: busy.
    pub const BUSY: u16 = 1 << 15;
    /// Bits the register's owner may write: write enable and command (the rest is status).
    pub const WRITABLE: u16 = Self::WRITE_ENABLE | Self::COMMAND_MASK;
    /// Bytes one read command delivers into 0x0508 with [`Self::READ_8_BYTES`] set.
    pub const READ_LEN_8: usize = 8;
    /// Bytes one read command delivers into 0x0508 with [`Self::READ_8_BYTES`] clear.
    pub const READ_LEN_4: usize = 4;
    /// Bytes one write command stores (0x0508..0x0509).
    pub const WRITE_LEN: usize = 2;

    /// The command bits.
    pub const fn command(self) -> EepromCommand {
        match (self.0 & Self::COMMAND_MASK) >> 8 {
            0 => EepromCommand::Idle,
            1 => EepromCommand::Read,
            2 => EepromCommand::Write,
            4 => EepromCommand::Reload,
            other => EepromCommand::Invalid(other as u8),
        }
    }
    /// Whether the interface is busy.
    pub const fn busy(self) -> bool {
        self.0 & Self::BUSY != 0
    }
}
