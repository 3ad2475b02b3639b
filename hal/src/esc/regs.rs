//! ESC register addresses (ET1100 / Beckhoff IP core register map).
//!
//! Source: Beckhoff "EtherCAT Slave Controller Section II (Register Description)" and ETG.1000.4
//! (Table 31 ff.). Widths are in bytes. Repeated blocks (FMMU, SyncManager) are reached through
//! [`fmmu`] and [`sm`]. Neither the stack nor the simulated ESC uses a bare address: every access
//! names one of these constants.

/// A register (or register group) of the ESC: start address and width in bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Reg {
    /// Byte address in the ESC address space.
    pub addr: u16,
    /// Width in bytes.
    pub len: u16,
}

impl Reg {
    /// A register at `addr` that is `len` bytes wide.
    pub const fn new(addr: u16, len: u16) -> Self {
        Self { addr, len }
    }
    /// First address after the register (saturated at the top of the 64 KiB address space,
    /// where no register lies).
    pub const fn end(self) -> u16 {
        self.addr.saturating_add(self.len)
    }
    /// Whether `addr` falls inside the register (below `addr` the distance wraps to beyond
    /// `len`).
    pub const fn contains(self, addr: u16) -> bool {
        addr.wrapping_sub(self.addr) < self.len
    }
}

// ----- 0x0000..0x000F: information -----
/// ESC type (ET1100 = [`ET1100_TYPE`]).
pub const TYPE: Reg = Reg::new(0x0000, 1);
/// Value of [`TYPE`] on an ET1100 (Section II 0x0000).
pub const ET1100_TYPE: u8 = 0x11;
/// ESC revision.
pub const REVISION: Reg = Reg::new(0x0001, 1);
/// ESC build, u16.
pub const BUILD: Reg = Reg::new(0x0002, 2);
/// Number of FMMUs supported.
pub const FMMU_COUNT: Reg = Reg::new(0x0004, 1);
/// Number of SyncManager channels supported.
pub const SM_COUNT: Reg = Reg::new(0x0005, 1);
/// Process RAM size in KiB.
pub const RAM_SIZE: Reg = Reg::new(0x0006, 1);
/// Port descriptor, 2 bits per port (see [`super::PortDescriptor`]).
pub const PORT_DESCRIPTOR: Reg = Reg::new(0x0007, 1);
/// Number of physical ports an ET1100 has (0..3).
pub const ET1100_PORTS: u8 = 4;
/// ESC features supported, u16 (see [`super::EscFeatures`]).
pub const FEATURES: Reg = Reg::new(0x0008, 2);

// ----- 0x0010..: station address -----
/// Configured station address, u16 (written by the master).
pub const STATION_ADDRESS: Reg = Reg::new(0x0010, 2);
/// Configured station alias, u16 (loaded from SII word 4 at power-on, PDI-writable).
pub const STATION_ALIAS: Reg = Reg::new(0x0012, 2);

// ----- 0x0020..: write protection, reset -----
/// Register write enable.
pub const WRITE_REG_ENABLE: Reg = Reg::new(0x0020, 1);
/// Register write protection.
pub const WRITE_REG_PROTECTION: Reg = Reg::new(0x0021, 1);
/// ESC write enable.
pub const ESC_WRITE_ENABLE: Reg = Reg::new(0x0030, 1);
/// ESC write protection.
pub const ESC_WRITE_PROTECTION: Reg = Reg::new(0x0031, 1);
/// ESC reset from the EtherCAT side.
pub const RESET_ECAT: Reg = Reg::new(0x0040, 1);
/// ESC reset from the PDI side.
pub const RESET_PDI: Reg = Reg::new(0x0041, 1);

// ----- 0x0100..: data link layer -----
/// DL control, u32 (see [`super::DlControl`]).
pub const DL_CONTROL: Reg = Reg::new(0x0100, 4);
/// DL control byte 3 (0x0103), bit 0: use the station alias for FPxx addressing.
pub const DL_CONTROL_ALIAS: Reg = Reg::new(0x0103, 1);
/// Physical read/write offset, u16.
pub const PHYSICAL_RW_OFFSET: Reg = Reg::new(0x0108, 2);
/// DL status, u16 (see [`super::DlStatus`]).
pub const DL_STATUS: Reg = Reg::new(0x0110, 2);

// ----- 0x0120..: application layer -----
/// AL control, u16: written by the master, read by the PDI (see [`super::AlControl`]).
pub const AL_CONTROL: Reg = Reg::new(0x0120, 2);
/// AL status, u16: written by the PDI, read by the master (see [`super::AlStatus`]).
pub const AL_STATUS: Reg = Reg::new(0x0130, 2);
/// AL status code, u16 (ETG.1000.6 Table 11).
pub const AL_STATUS_CODE: Reg = Reg::new(0x0134, 2);
/// RUN LED override.
pub const RUN_LED_OVERRIDE: Reg = Reg::new(0x0138, 1);
/// ERR LED override.
pub const ERR_LED_OVERRIDE: Reg = Reg::new(0x0139, 1);

// ----- 0x0140..: PDI -----
/// PDI control (PDI type), loaded from SII word 0 low byte.
pub const PDI_CONTROL: Reg = Reg::new(0x0140, 1);
/// ESC configuration, loaded from SII word 0 high byte (see [`super::EscConfig`]).
pub const ESC_CONFIG: Reg = Reg::new(0x0141, 1);
/// PDI configuration, loaded from SII word 1 (low byte: PDI specific, high byte:
/// [`SYNC_LATCH_CONFIG`]).
pub const PDI_CONFIG: Reg = Reg::new(0x0150, 2);
/// SYNC/LATCH PDI configuration, the high byte of [`PDI_CONFIG`] (see
/// [`super::SyncLatchConfig`]).
pub const SYNC_LATCH_CONFIG: Reg = Reg::new(0x0151, 1);
/// Extended PDI configuration, loaded from SII word 3.
pub const PDI_CONFIG_EXT: Reg = Reg::new(0x0152, 2);

// ----- 0x0200..: interrupts -----
/// ECAT event mask, u16.
pub const ECAT_EVENT_MASK: Reg = Reg::new(0x0200, 2);
/// AL event mask, u32: AL event request bits that drive the PDI IRQ line (reset value
/// [`super::AlEvent::MASK_RESET`]).
pub const AL_EVENT_MASK: Reg = Reg::new(0x0204, 4);
/// ECAT event request, u16 (see [`super::EcatEvent`]; mirrored into every datagram's IRQ field).
pub const ECAT_EVENT_REQUEST: Reg = Reg::new(0x0210, 2);
/// AL event request, u32 (see [`super::AlEvent`]).
pub const AL_EVENT_REQUEST: Reg = Reg::new(0x0220, 4);

// ----- 0x0300..: error counters -----
/// RX error counters, ports 0..3 (invalid frame, RX error), 2 bytes each.
pub const RX_ERROR_COUNTERS: Reg = Reg::new(0x0300, 8);
/// Forwarded RX error counters, ports 0..3.
pub const FORWARDED_RX_ERROR_COUNTERS: Reg = Reg::new(0x0308, 4);
/// ECAT processing unit error counter.
pub const ECAT_PU_ERROR_COUNTER: Reg = Reg::new(0x030C, 1);
/// PDI error counter.
pub const PDI_ERROR_COUNTER: Reg = Reg::new(0x030D, 1);
/// PDI error code.
pub const PDI_ERROR_CODE: Reg = Reg::new(0x030E, 1);
/// Lost link counters, ports 0..3.
pub const LOST_LINK_COUNTERS: Reg = Reg::new(0x0310, 4);

// ----- 0x0400..: watchdogs -----
/// Watchdog divider, u16: one watchdog tick = (divider + 2) × 40 ns (see [`super::watchdog`]).
pub const WATCHDOG_DIVIDER: Reg = Reg::new(0x0400, 2);
/// PDI watchdog time, u16 in ticks (0 = disabled).
pub const WATCHDOG_TIME_PDI: Reg = Reg::new(0x0410, 2);
/// Process-data (SM) watchdog time, u16 in ticks (0 = disabled).
pub const WATCHDOG_TIME_PD: Reg = Reg::new(0x0420, 2);
/// Process-data watchdog status: bit 0 ([`super::watchdog::PD_STATUS_OK`]) = 1 active or
/// disabled, 0 = expired.
pub const WATCHDOG_STATUS_PD: Reg = Reg::new(0x0440, 2);
/// Process-data watchdog expiry counter (saturating).
pub const WATCHDOG_COUNTER_PD: Reg = Reg::new(0x0442, 1);
/// PDI watchdog expiry counter (saturating).
pub const WATCHDOG_COUNTER_PDI: Reg = Reg::new(0x0443, 1);

// ----- 0x0500..: SII EEPROM interface -----
/// EEPROM configuration (see [`super::EepromConfig`]).
pub const EEPROM_CONFIG: Reg = Reg::new(0x0500, 1);
/// EEPROM PDI access state (see [`super::EepromPdiAccess`]).
pub const EEPROM_PDI_ACCESS: Reg = Reg::new(0x0501, 1);
/// EEPROM control/status, u16 (see [`super::EepromControl`]).
pub const EEPROM_CONTROL: Reg = Reg::new(0x0502, 2);
/// EEPROM address (in 16-bit words), u32.
pub const EEPROM_ADDRESS: Reg = Reg::new(0x0504, 4);
/// EEPROM data: 4 or 8 bytes read, 2 bytes written.
pub const EEPROM_DATA: Reg = Reg::new(0x0508, 8);

// ----- 0x0510..: MII management -----
/// MII management control/status and registers.
pub const MII_MANAGEMENT: Reg = Reg::new(0x0510, 12);

// ----- 0x0600..: FMMUs, 0x0800..: SyncManagers -----
/// Number of FMMUs an ET1100 implements.
pub const ET1100_FMMUS: u8 = 8;
/// Number of SyncManagers an ET1100 implements.
pub const ET1100_SMS: u8 = 8;
/// Most SyncManagers an ESC has room for (0x0800–0x087F, ETG.1000.4 Table 59); an ESC reports
/// how many it implements in [`SM_COUNT`].
pub const MAX_SMS: u8 = 16;
/// Start of the FMMU block (16 bytes per FMMU).
pub const FMMU_BASE: u16 = 0x0600;
/// Size of one FMMU register block.
pub const FMMU_LEN: u16 = 16;
/// Start of the SyncManager block (8 bytes per SM).
pub const SM_BASE: u16 = 0x0800;
/// Size of one SyncManager register block.
pub const SM_LEN: u16 = 8;

/// Register block of FMMU `n`.
// Cannot overflow: at most 0x0600 + 16 × 255 = 0x15F0.
#[allow(clippy::arithmetic_side_effects)]
pub const fn fmmu(n: u8) -> Reg {
    Reg::new(FMMU_BASE + FMMU_LEN * n as u16, FMMU_LEN)
}

/// Register block of SyncManager `n`.
// Cannot overflow: at most 0x0800 + 8 × 255 = 0x0FF8.
#[allow(clippy::arithmetic_side_effects)]
pub const fn sm(n: u8) -> Reg {
    Reg::new(SM_BASE + SM_LEN * n as u16, SM_LEN)
}

/// Activate byte of SyncManager `n` (reading it acknowledges the SM-activation event for it).
// Cannot overflow: at most 0x0800 + 8 × 255 + 6 = 0x0FFE.
#[allow(clippy::arithmetic_side_effects)]
pub const fn sm_activate(n: u8) -> u16 {
    sm(n).addr + sm_offset::ACTIVATE
}

/// Byte offsets inside one SyncManager block.
pub mod sm_offset {
    /// Physical start address, u16.
    pub const START: u16 = 0;
    /// Length, u16.
    pub const LENGTH: u16 = 2;
    /// Control byte.
    pub const CONTROL: u16 = 4;
    /// Status byte (read-only for ECAT).
    pub const STATUS: u16 = 5;
    /// Activate byte.
    pub const ACTIVATE: u16 = 6;
    /// PDI control byte (read-only for ECAT).
    pub const PDI_CONTROL: u16 = 7;
}

/// Byte offsets inside one FMMU block.
pub mod fmmu_offset {
    /// Logical start address, u32.
    pub const LOGICAL_START: u16 = 0;
    /// Length in bytes, u16.
    pub const LENGTH: u16 = 4;
    /// Logical start bit (0..7).
    pub const LOGICAL_START_BIT: u16 = 6;
    /// Logical end bit (0..7).
    pub const LOGICAL_END_BIT: u16 = 7;
    /// Physical start address, u16.
    pub const PHYSICAL_START: u16 = 8;
    /// Physical start bit (0..7).
    pub const PHYSICAL_START_BIT: u16 = 10;
    /// Type: bit 0 read, bit 1 write.
    pub const TYPE: u16 = 11;
    /// Activate: bit 0.
    pub const ACTIVATE: u16 = 12;
}

// ----- 0x0900..: distributed clocks -----
/// Receive time port 0, u32 (a write here latches the receive times of all ports).
pub const DC_RECEIVE_TIME_PORT0: Reg = Reg::new(0x0900, 4);
/// Receive time port 1, u32.
pub const DC_RECEIVE_TIME_PORT1: Reg = Reg::new(0x0904, 4);
/// Receive time port 2, u32.
pub const DC_RECEIVE_TIME_PORT2: Reg = Reg::new(0x0908, 4);
/// Receive time port 3, u32.
pub const DC_RECEIVE_TIME_PORT3: Reg = Reg::new(0x090C, 4);
/// System time, u64 (read: local time + offset; write: feeds the drift control loop).
pub const DC_SYSTEM_TIME: Reg = Reg::new(0x0910, 8);
/// Local time of the processing unit at the latch frame, u64.
pub const DC_RECEIVE_TIME_PU: Reg = Reg::new(0x0918, 8);
/// System time offset, u64 (two's complement in practice).
pub const DC_SYSTEM_TIME_OFFSET: Reg = Reg::new(0x0920, 8);
/// System time delay (propagation delay from the reference clock), u32.
pub const DC_SYSTEM_TIME_DELAY: Reg = Reg::new(0x0928, 4);
/// System time difference, u32 sign-magnitude (see [`super::dc::DcSystemTimeDiff`]).
pub const DC_SYSTEM_TIME_DIFF: Reg = Reg::new(0x092C, 4);
/// Speed counter start, u16 (a write resets the drift filter; see [`super::dc`]).
pub const DC_SPEED_COUNTER_START: Reg = Reg::new(0x0930, 2);
/// Speed counter difference, i16.
pub const DC_SPEED_COUNTER_DIFF: Reg = Reg::new(0x0932, 2);
/// System time difference filter depth.
pub const DC_TIME_FILTER_DEPTH: Reg = Reg::new(0x0934, 1);
/// Speed counter filter depth.
pub const DC_SPEED_FILTER_DEPTH: Reg = Reg::new(0x0935, 1);
/// Cyclic unit control (see [`super::dc::DcCyclicUnitControl`]).
pub const DC_CYCLIC_UNIT_CONTROL: Reg = Reg::new(0x0980, 1);
/// Activation register (see [`super::DcActivation`]).
pub const DC_ACTIVATION: Reg = Reg::new(0x0981, 1);
/// SYNC signal pulse length, u16 in 10 ns (0 = acknowledge mode).
pub const DC_PULSE_LENGTH: Reg = Reg::new(0x0982, 2);
/// Activation status (see [`super::dc::DcActivationStatus`]).
pub const DC_ACTIVATION_STATUS: Reg = Reg::new(0x0984, 1);
/// SYNC0 status (see [`super::dc::DcSyncStatus`]; a PDI read clears it and AL event bit 2 in
/// acknowledge mode).
pub const DC_SYNC0_STATUS: Reg = Reg::new(0x098E, 1);
/// SYNC1 status.
pub const DC_SYNC1_STATUS: Reg = Reg::new(0x098F, 1);
/// Start time of cyclic operation, u64 (system time).
pub const DC_START_TIME: Reg = Reg::new(0x0990, 8);
/// Next SYNC1 pulse, u64.
pub const DC_NEXT_SYNC1: Reg = Reg::new(0x0998, 8);
/// SYNC0 cycle time, u32 in ns (0 = single shot).
pub const DC_SYNC0_CYCLE: Reg = Reg::new(0x09A0, 4);
/// SYNC1 cycle time, u32 in ns (delay after SYNC0).
pub const DC_SYNC1_CYCLE: Reg = Reg::new(0x09A4, 4);
/// Latch0 control (0x09A8) and latch1 control (0x09A9): bit 0 positive edge single event, bit 1
/// negative edge single event.
pub const DC_LATCH_CONTROL: Reg = Reg::new(0x09A8, 2);
/// Time of the last SM buffer change on the ECAT side, u64.
pub const DC_ECAT_BUFFER_CHANGE_TIME: Reg = Reg::new(0x09F0, 8);
/// Time of the last SM buffer change on the PDI side, u64.
pub const DC_PDI_BUFFER_CHANGE_TIME: Reg = Reg::new(0x09F8, 8);

// ----- memory -----
/// User RAM (not write-protected).
pub const USER_RAM: Reg = Reg::new(0x0F80, 0x80);
/// First address of process RAM.
pub const PROCESS_RAM_START: u16 = 0x1000;
/// Process RAM of an ET1100: 8 KiB.
pub const ET1100_PROCESS_RAM: Reg = Reg::new(PROCESS_RAM_START, 0x2000);
/// Value of [`RAM_SIZE`] on an ET1100: the process RAM in KiB.
pub const ET1100_RAM_SIZE_KIB: u8 = (ET1100_PROCESS_RAM.len / 1024) as u8;
