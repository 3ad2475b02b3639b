//! Object indices of the communication area (CiA 301 §7.5, ETG.1000.6 Table 67, ETG.1020) that
//! the stack itself serves or maintains: defined here once, used by every module.

use core::ops::RangeInclusive;

/// Error register (CiA 301 §7.5.2.2).
pub const ERROR_REGISTER: u16 = 0x1001;
/// Store parameters (CiA 301 §7.5.2.13).
pub const STORE_PARAMETERS: u16 = 0x1010;
/// Restore default parameters (CiA 301 §7.5.2.14).
pub const RESTORE_DEFAULTS: u16 = 0x1011;
/// Identity object (CiA 301 §7.5.2.19).
pub const IDENTITY: u16 = 0x1018;
/// Error settings (ETG.1020 §5.1): :02 sync error counter limit.
pub const ERROR_SETTINGS: u16 = 0x10F1;
/// Diagnosis history (ETG.1020 §13).
pub const DIAG_HISTORY: u16 = 0x10F3;
/// RxPDO mapping objects (outputs, master → slave), ETG.1000.6 Table 67.
pub const RX_MAPPING: RangeInclusive<u16> = 0x1600..=0x17FF;
/// TxPDO mapping objects (inputs, slave → master), ETG.1000.6 Table 67.
pub const TX_MAPPING: RangeInclusive<u16> = 0x1A00..=0x1BFF;
/// Sync manager 2 (outputs) PDO assignment, ETG.1000.6 Table 67.
pub const RX_ASSIGN: u16 = 0x1C12;
/// Sync manager 3 (inputs) PDO assignment, ETG.1000.6 Table 67.
pub const TX_ASSIGN: u16 = 0x1C13;
/// Sync manager 2 (outputs) parameter (ETG.1020 §5.1).
pub const SM_OUTPUT_PARAMETER: u16 = 0x1C32;
/// Sync manager 3 (inputs) parameter (ETG.1020 §5.1).
pub const SM_INPUT_PARAMETER: u16 = 0x1C33;

/// Subindices of the SM parameters 1C32h/1C33h (ETG.1020 §5.1).
pub mod sm_parameter {
    /// Synchronization type (0 free run, 1 SM-synchronous, 2 DC SYNC0, 3 DC SYNC1).
    pub const SUB_SYNC_TYPE: u8 = 0x01;
    /// Cycle time, ns.
    pub const SUB_CYCLE_TIME: u8 = 0x02;
    /// Shift time, ns (1C32h: outputs valid after SYNC0; 1C33h: inputs latched after SYNC0).
    pub const SUB_SHIFT_TIME: u8 = 0x03;
    /// Minimum cycle time, ns.
    pub const SUB_MIN_CYCLE_TIME: u8 = 0x05;
    /// Calc and copy time, ns.
    pub const SUB_CALC_AND_COPY_TIME: u8 = 0x06;
    /// Delay time, ns.
    pub const SUB_DELAY_TIME: u8 = 0x09;
    /// Sync0 cycle time, ns (the SYNC0 cycle the master configured in the ESC).
    pub const SUB_SYNC0_CYCLE_TIME: u8 = 0x0A;
    /// SM-event missed counter (ETG.1020; a profile may place it elsewhere:
    /// `SyncSupport::sm_event_missed_subindex`).
    pub const SUB_SM_EVENT_MISSED: u8 = 0x0B;
    /// Cycle time too small counter.
    pub const SUB_CYCLE_TIME_TOO_SMALL: u8 = 0x0C;
    /// Sync error.
    pub const SUB_SYNC_ERROR: u8 = 0x20;
}
