//! Distributed-clock registers (0x0900..0x09FF, Beckhoff ESC datasheet Section II 0x0900 ff.):
//! typed contents and the reset values and limits of the drift-control registers.

/// Reset value of the speed counter start 0x0930.
pub const SPEED_COUNTER_START_RESET: u16 = 0x1000;
/// Smallest legal speed counter start 0x0930 (Section II 0x0930: 0x0080..0x3FFF).
pub const SPEED_COUNTER_START_MIN: u16 = 0x0080;
/// The speed counter diff 0x0932 ranges ±(speed counter start − this) (Section II 0x0932): the
/// period between two 1 ns corrections of the local time can shrink to this many ticks.
pub const SPEED_COUNTER_DIFF_MARGIN: u16 = 0x7F;
/// One speed-counter step of the DC unit, in ns (the ET1100 DC unit runs on a 100 MHz clock).
pub const SPEED_COUNTER_TICK_NS: u32 = 10;
/// Reset value of the system time difference filter depth 0x0934.
pub const TIME_FILTER_DEPTH_RESET: u8 = 4;
/// Reset value of the speed counter filter depth 0x0935.
pub const SPEED_FILTER_DEPTH_RESET: u8 = 12;
/// The filter depths 0x0934 / 0x0935 use bits 0..3.
pub const FILTER_DEPTH_MASK: u8 = 0x0F;

/// The SYNC0 cycles a device runs: the one rule the slave stack applies at PREOP → SAFEOP
/// (`ethercat_slave::slave::esm::sync::SyncConfig::check`, with a profile's `[sync]` limits)
/// and od-gen applies to every cycle a profile declares (its minimum, maximum and default
/// cycle, an op mode's fixed SYNC0 cycle), so that a profile never advertises a cycle its
/// firmware refuses. Defined here because both depend on `hal`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DcCycleRule<'a> {
    /// Shortest cycle, ns.
    pub min_ns: u32,
    /// Longest cycle, ns.
    pub max_ns: u32,
    /// Granularity, ns: a cycle is a whole multiple of it (0 or 1: any cycle in range).
    pub step_ns: u32,
    /// The only cycles, when the device has a fixed set; empty: every multiple of `step_ns`.
    pub allowed_ns: &'a [u32],
}

impl DcCycleRule<'_> {
    /// `Ok` for a SYNC0 cycle of `cycle_ns` the device runs, else the AL status code it
    /// refuses it with (ETG.1000.6 Table 11): 0x0035 outside `min_ns..=max_ns` (every cycle
    /// when `min_ns > max_ns`), 0x0036 in range but no whole multiple of `step_ns` or not one
    /// of `allowed_ns`.
    pub fn check(&self, cycle_ns: u32) -> Result<(), super::AlStatusCode> {
        use super::AlStatusCode;
        if cycle_ns < self.min_ns || cycle_ns > self.max_ns {
            Err(AlStatusCode::DcInvalidSyncCycleTime)
        } else if (self.step_ns > 1 && cycle_ns.checked_rem(self.step_ns) != Some(0))
            || (!self.allowed_ns.is_empty() && !self.allowed_ns.contains(&cycle_ns))
        {
            Err(AlStatusCode::DcSync0CycleTime)
        } else {
            Ok(())
        }
    }
}

/// The free-run cycles (1C32h:02, the local timer's period) a device runs: `Ok` within
/// `min_ns..=max_ns`, else 0x0035, the one rule of the slave stack's PREOP → SAFEOP check and
/// od-gen's check of a profile's free-run default.
pub fn check_free_run_cycle(
    cycle_ns: u32,
    min_ns: u32,
    max_ns: u32,
) -> Result<(), super::AlStatusCode> {
    if (min_ns..=max_ns).contains(&cycle_ns) {
        Ok(())
    } else {
        Err(super::AlStatusCode::DcInvalidSyncCycleTime)
    }
}

/// System time difference register 0x092C: sign-magnitude, bits 0..30 the mean difference
/// between the local copy of the system time and the received system time.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DcSystemTimeDiff(pub u32);

impl DcSystemTimeDiff {
    /// Bit 31: set when the local copy of the system time is ≥ the received system time.
    pub const LOCAL_GE_RECEIVED: u32 = 1 << 31;
    /// Bits 0..30: magnitude in ns.
    pub const MAGNITUDE_MASK: u32 = 0x7FFF_FFFF;

    /// Encodes `local - received` in ns, saturating the magnitude at [`Self::MAGNITUDE_MASK`].
    pub const fn encode(diff: i64) -> Self {
        let abs = diff.unsigned_abs();
        let mag = if abs > Self::MAGNITUDE_MASK as u64 {
            Self::MAGNITUDE_MASK
        } else {
            abs as u32
        };
        if diff >= 0 {
            Self(mag | Self::LOCAL_GE_RECEIVED)
        } else {
            Self(mag)
        }
    }
}

/// Cyclic unit control register 0x0980: which side owns the SYNC and latch units.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DcCyclicUnitControl(pub u8);

impl DcCyclicUnitControl {
    /// Bit 0: SYNC out unit assigned to the PDI (0 = ECAT writes 0x0981, 0x0990, 0x09A0 ff.).
    pub const SYNC_UNIT_PDI: u8 = 1 << 0;
    /// Bit 4: latch in unit 0 assigned to the PDI.
    pub const LATCH0_PDI: u8 = 1 << 4;
    /// Bit 5: latch in unit 1 assigned to the PDI.
    pub const LATCH1_PDI: u8 = 1 << 5;

    /// Whether the PDI owns the SYNC out unit.
    pub const fn sync_unit_pdi(self) -> bool {
        self.0 & Self::SYNC_UNIT_PDI != 0
    }
}

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

/// DC activation status register 0x0984.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DcActivationStatus(pub u8);

impl DcActivationStatus {
    /// Bit 0: first SYNC0 pulse pending (not yet generated).
    pub const SYNC0_PENDING: u8 = 1 << 0;
    /// Bit 1: first SYNC1 pulse pending (not yet generated).
    pub const SYNC1_PENDING: u8 = 1 << 1;
    /// Bit 2: the start time 0x0990 failed the plausibility check at activation (not in the
    /// near future).
    pub const START_TIME_IMPLAUSIBLE: u8 = 1 << 2;
}

/// SYNC0 / SYNC1 status registers 0x098E / 0x098F.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DcSyncStatus(pub u8);

impl DcSyncStatus {
    /// Bit 0: a SYNC pulse happened (acknowledge mode: cleared by a PDI read of the register).
    pub const ACTIVE: u8 = 1 << 0;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn system_time_diff_is_sign_magnitude_and_saturates() {
        assert_eq!(DcSystemTimeDiff::encode(5).0, 0x8000_0005);
        assert_eq!(DcSystemTimeDiff::encode(0).0, 0x8000_0000);
        assert_eq!(DcSystemTimeDiff::encode(-5).0, 0x0000_0005);
        assert_eq!(DcSystemTimeDiff::encode(i64::MIN).0, 0x7FFF_FFFF);
    }

    #[test]
    fn cycle_rule_refuses_out_of_range_with_0x35_and_off_grid_with_0x36() {
        let code = |r: Result<(), crate::esc::AlStatusCode>| r.map_err(|c| c.code());
        let rule = DcCycleRule {
            min_ns: 250_000,
            max_ns: 4_000_000,
            step_ns: 250_000,
            allowed_ns: &[],
        };
        assert_eq!(code(rule.check(250_000)), Ok(()));
        assert_eq!(code(rule.check(4_000_000)), Ok(()));
        assert_eq!(code(rule.check(125_000)), Err(0x0035));
        assert_eq!(code(rule.check(4_250_000)), Err(0x0035));
        assert_eq!(code(rule.check(300_000)), Err(0x0036));
        let set = DcCycleRule {
            allowed_ns: &[250_000, 1_000_000],
            ..rule
        };
        assert_eq!(code(set.check(500_000)), Err(0x0036));
        let empty = DcCycleRule {
            min_ns: 2,
            max_ns: 1,
            ..rule
        };
        assert!(empty.check(1).is_err() && empty.check(2).is_err());
        assert_eq!(code(check_free_run_cycle(5, 1, 4)), Err(0x0035));
        assert_eq!(code(check_free_run_cycle(4, 1, 4)), Ok(()));
    }
}
