//! Distributed-clock registers.

/// DC activation register 0x0981.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DcActivation(pub u8);

impl DcActivation {
    /// Bit 0: activate cyclic operation.
    pub const CYCLIC: u8 = 1 << 0;
    /// Bit 1: activate SYNC0.
    pub const SYNC0: u8 = 1 << 1;
    /// Bit 2: activate SYNC1.
    pub const SYNC1: u8 = 1 << 2;
    /// Bit 3: auto-activate on a write of the start time.
    pub const AUTO_ACTIVATE: u8 = 1 << 3;
    /// Bit 4: extend a 32-bit start time to 64 bits.
    pub const START_TIME_EXTENSION: u8 = 1 << 4;
    /// Bit 5: start time plausibility check.
    pub const PLAUSIBILITY_CHECK: u8 = 1 << 5;
    /// Bit 6: near-future configuration.
    pub const NEAR_FUTURE: u8 = 1 << 6;
    /// Bit 7: SYNC debug pulse.
    pub const DEBUG_PULSE: u8 = 1 << 7;

    /// Cyclic operation and SYNC0 both active.
    pub const fn sync0_active(self) -> bool {
        self.0 & (Self::CYCLIC | Self::SYNC0) == Self::CYCLIC | Self::SYNC0
    }
    /// Cyclic operation and SYNC1 both active.
    pub const fn sync1_active(self) -> bool {
        self.0 & (Self::CYCLIC | Self::SYNC1) == Self::CYCLIC | Self::SYNC1
    }
}
