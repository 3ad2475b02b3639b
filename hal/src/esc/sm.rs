//! SyncManager channel registers (0x0800 + 8·n).

/// The longest mailbox SyncManager the firmware serves, bytes: the slave stack's mailbox
/// buffers are this long (`ethercat_slave::mailbox::MAX_MAILBOX`), a longer SM0/SM1 is
/// refused at INIT → PREOP with AL status code 0x0016, and od-gen refuses a profile that
/// declares one. Defined here because both depend on `hal`.
pub const MAX_FIRMWARE_MAILBOX: u16 = 512;

/// The largest process-data image of one direction the firmware maps, bytes (the SM2 or SM3
/// length; also the largest single PDO): the slave stack's image buffers are this long
/// (`ethercat_slave::pdo::MAX_IMAGE`), a longer assignment is refused at PREOP → SAFEOP with AL
/// status code 0x0025 (outputs) / 0x0024 (inputs), and od-gen refuses a profile whose default
/// assignment, or one of whose PDOs, needs more. Defined here because both depend on `hal`.
pub const MAX_FIRMWARE_PROCESS_IMAGE: u16 = 256;

/// The most entries (padding excluded) the firmware maps in one direction, all assigned PDOs
/// of SM2 (or of SM3) together: the slave stack's copy plan holds this many
/// (`ethercat_slave::pdo::MAX_MAPPED_ENTRIES`), more are refused at PREOP → SAFEOP with 0x0025
/// / 0x0024, and od-gen refuses a profile whose default assignment, or one of whose PDOs, maps
/// more.
pub const MAX_FIRMWARE_MAPPED_ENTRIES: u8 = 64;

/// Operation mode, control bits 0..1.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SmMode {
    /// 00: buffered (3-buffer) mode, used for process data.
    Buffered,
    /// 10: mailbox (single buffer) mode.
    Mailbox,
    /// 01 / 11: reserved codes.
    Reserved,
}

/// Direction, control bits 2..3.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SmDirection {
    /// 00: ECAT reads, PDI writes (slave → master: inputs, mailbox in).
    EcatRead,
    /// 01: ECAT writes, PDI reads (master → slave: outputs, mailbox out).
    EcatWrite,
    /// 10 / 11: reserved codes.
    Reserved,
}

/// Control byte (offset 4).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SmControl(pub u8);

impl SmControl {
    /// Bit 4: ECAT event enable.
    pub const ECAT_IRQ: u8 = 1 << 4;
    /// Bit 5: AL (PDI) event enable.
    pub const PDI_IRQ: u8 = 1 << 5;
    /// Bit 6: the SM triggers the process-data watchdog when written.
    pub const WATCHDOG: u8 = 1 << 6;

    /// Operation mode.
    pub const fn mode(self) -> SmMode {
        match self.0 & 0x03 {
            0b00 => SmMode::Buffered,
            0b10 => SmMode::Mailbox,
            _ => SmMode::Reserved,
        }
    }
    /// Direction.
    pub const fn direction(self) -> SmDirection {
        match (self.0 >> 2) & 0x03 {
            0b00 => SmDirection::EcatRead,
            0b01 => SmDirection::EcatWrite,
            _ => SmDirection::Reserved,
        }
    }
    /// Whether writing this SM triggers the process-data watchdog.
    pub const fn watchdog_trigger(self) -> bool {
        self.0 & Self::WATCHDOG != 0
    }
}

/// Status byte (offset 5, read-only for ECAT).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SmStatus(pub u8);

impl SmStatus {
    /// Bit 0: interrupt write (buffer written by the writer side).
    pub const IRQ_WRITE: u8 = 1 << 0;
    /// Bit 1: interrupt read (buffer read by the reader side).
    pub const IRQ_READ: u8 = 1 << 1;
    /// Bit 3: mailbox full (mailbox mode).
    pub const MAILBOX_FULL: u8 = 1 << 3;
    /// Bits 4..5: 3-buffer state (last written buffer: 0, 1, 2; 3 = none written).
    pub const BUFFER_STATE_SHIFT: u8 = 4;
    /// 3-buffer state value: no buffer written yet.
    pub const BUFFER_STATE_NONE: u8 = 3;
    /// Bit 6: read buffer open.
    pub const READ_OPEN: u8 = 1 << 6;
    /// Bit 7: write buffer open.
    pub const WRITE_OPEN: u8 = 1 << 7;

    /// Whether the mailbox is full.
    pub const fn mailbox_full(self) -> bool {
        self.0 & Self::MAILBOX_FULL != 0
    }
}

/// Activate byte (offset 6, written by ECAT).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SmActivate(pub u8);

impl SmActivate {
    /// Bit 0: SM enable.
    pub const ENABLE: u8 = 1 << 0;
    /// Bit 1: repeat request (mailbox).
    pub const REPEAT_REQUEST: u8 = 1 << 1;
    /// Bit 6: latch event ECAT.
    pub const LATCH_ECAT: u8 = 1 << 6;
    /// Bit 7: latch event PDI.
    pub const LATCH_PDI: u8 = 1 << 7;

    /// Whether the SM is enabled.
    pub const fn enabled(self) -> bool {
        self.0 & Self::ENABLE != 0
    }
    /// The repeat request toggle.
    pub const fn repeat_request(self) -> bool {
        self.0 & Self::REPEAT_REQUEST != 0
    }
}

/// PDI control byte (offset 7, written by the PDI).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SmPdiControl(pub u8);

impl SmPdiControl {
    /// Bit 0: deactivate the SM from the PDI side.
    pub const DEACTIVATE: u8 = 1 << 0;
    /// Bit 1: repeat acknowledge (mailbox).
    pub const REPEAT_ACK: u8 = 1 << 1;
}

/// The 8 bytes of one SyncManager channel.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SmConfig {
    /// Physical start address.
    pub start: u16,
    /// Length in bytes (0 = channel disabled).
    pub length: u16,
    /// Control byte.
    pub control: SmControl,
    /// Status byte.
    pub status: SmStatus,
    /// Activate byte.
    pub activate: SmActivate,
    /// PDI control byte.
    pub pdi_control: SmPdiControl,
}

impl SmConfig {
    /// Size of the register block.
    pub const LEN: usize = 8;

    /// Decodes the 8-byte register block.
    pub const fn from_bytes(b: [u8; 8]) -> Self {
        Self {
            start: u16::from_le_bytes([b[0], b[1]]),
            length: u16::from_le_bytes([b[2], b[3]]),
            control: SmControl(b[4]),
            status: SmStatus(b[5]),
            activate: SmActivate(b[6]),
            pdi_control: SmPdiControl(b[7]),
        }
    }
    /// Encodes the 8-byte register block.
    pub const fn to_bytes(self) -> [u8; 8] {
        let s = self.start.to_le_bytes();
        let l = self.length.to_le_bytes();
        [
            s[0],
            s[1],
            l[0],
            l[1],
            self.control.0,
            self.status.0,
            self.activate.0,
            self.pdi_control.0,
        ]
    }
    /// Enabled by the master and not deactivated by the PDI, with a non-zero length.
    pub const fn active(self) -> bool {
        self.activate.enabled()
            && self.pdi_control.0 & SmPdiControl::DEACTIVATE == 0
            && self.length > 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mailbox_out_control_0x26_is_mailbox_ecat_write_with_pdi_irq() {
        let c = SmControl(0x26);
        assert_eq!(c.mode(), SmMode::Mailbox);
        assert_eq!(c.direction(), SmDirection::EcatWrite);
        assert!(c.0 & SmControl::PDI_IRQ != 0);
    }

    #[test]
    fn outputs_control_0x64_is_buffered_ecat_write_with_watchdog() {
        let c = SmControl(0x64);
        assert_eq!(c.mode(), SmMode::Buffered);
        assert_eq!(c.direction(), SmDirection::EcatWrite);
        assert!(c.watchdog_trigger());
    }

    #[test]
    fn sm_config_round_trips_through_bytes() {
        let b = [0x00, 0x10, 0x80, 0x00, 0x26, 0x00, 0x01, 0x00];
        let c = SmConfig::from_bytes(b);
        assert_eq!(c.start, 0x1000);
        assert_eq!(c.length, 0x80);
        assert!(c.active());
        assert_eq!(c.to_bytes(), b);
    }
}
