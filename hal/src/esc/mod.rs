//! The EtherCAT slave controller: register map and typed register contents.
//!
//! # For firmware
//! Decode what you read with the types here (`AlControl::from_bits(..)`) and encode what you
//! write (`AlStatus { .. }.bits()`); never test or build register bits by hand.
//!
//! # For boards
//! A simulated ESC uses the same types to give registers their semantics, so the stack and the
//! simulation cannot disagree about a bit position.

pub mod dc;
pub mod regs;
pub mod sii;
pub mod watchdog;

mod al;
mod config;
mod eeprom;
mod fmmu;
mod sm;

pub use al::{
    AlControl, AlEvent, AlState, AlStatus, AlStatusCode, DlControl, DlStatus, EcatEvent,
    EscFeatures,
};
pub use config::{EscConfig, PortDescriptor, SyncLatchConfig};
pub use dc::{
    DcActivation, DcActivationStatus, DcCycleRule, DcCyclicUnitControl, DcSyncStatus,
    DcSystemTimeDiff,
};
pub use eeprom::{EepromCommand, EepromConfig, EepromControl, EepromPdiAccess};
pub use fmmu::{FmmuConfig, FmmuType};
pub use sm::{
    SmActivate, SmConfig, SmControl, SmDirection, SmMode, SmPdiControl, SmStatus,
    MAX_FIRMWARE_MAILBOX, MAX_FIRMWARE_MAPPED_ENTRIES, MAX_FIRMWARE_PROCESS_IMAGE,
};

/// Mailbox protocol bits of SII word 0x1C (ETG.1000.6 Table 18 / ETG.2010).
pub mod mailbox_protocols {
    /// ADS over EtherCAT.
    pub const AOE: u16 = 0x0001;
    /// Ethernet over EtherCAT.
    pub const EOE: u16 = 0x0002;
    /// CANopen over EtherCAT.
    pub const COE: u16 = 0x0004;
    /// File access over EtherCAT.
    pub const FOE: u16 = 0x0008;
    /// Servo profile over EtherCAT.
    pub const SOE: u16 = 0x0010;
    /// Vendor specific over EtherCAT.
    pub const VOE: u16 = 0x0020;
}
