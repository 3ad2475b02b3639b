//! Position limits of a drive (CiA402 607Dh software position limits, the limit switches)
//! and the digital inputs object 60FDh: which motions are allowed, as pure functions.
//!
//! - A software limit pair with min < max is enabled (min ≥ max, e.g. the 0/0 default,
//!   disables it: the Σ-V-SD's rule, §6.8); position targets are limited to the range.
//! - An actuated limit switch, or the actual position at or beyond a software limit, blocks
//!   motion further in that direction; motion away from it is free. The drive stops a blocked
//!   motion on the quick-stop ramp and holds (statusword bit 11 "internal limit active").

/// 60FDh bit 0: negative limit switch.
pub const DI_NEGATIVE_LIMIT: u32 = 1 << 0;
/// 60FDh bit 1: positive limit switch.
pub const DI_POSITIVE_LIMIT: u32 = 1 << 1;
/// 60FDh bit 2: home switch.
pub const DI_HOME_SWITCH: u32 = 1 << 2;
/// 60FDh bit 3: interlock, set while the drive's enable input withholds operation (like the
/// limit-switch bits, 1 = the input blocks the drive).
pub const DI_INTERLOCK: u32 = 1 << 3;

/// Enabled software position limits, in drive increments.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SoftwareLimits {
    min: i64,
    max: i64,
}

impl SoftwareLimits {
    /// The limits `min..=max`; `None` (disabled) when `min >= max`.
    pub fn new(min: i64, max: i64) -> Option<Self> {
        (min < max).then_some(Self { min, max })
    }

    /// `target` limited to the range, and whether it was limited.
    pub fn clamp(&self, target: i64) -> (i64, bool) {
        // max/min rather than `clamp` (min < max holds by construction, but `clamp`'s check of
        // it would still be a panic path in the cycle).
        let limited = target.max(self.min).min(self.max);
        (limited, limited != target)
    }
}

/// The directions in which motion is blocked.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Blocked {
    /// Motion in the positive direction is blocked.
    pub positive: bool,
    /// Motion in the negative direction is blocked.
    pub negative: bool,
}

impl Blocked {
    /// What the switches and the software limits block at `actual`.
    pub fn at(
        negative_switch: bool,
        positive_switch: bool,
        limits: Option<SoftwareLimits>,
        actual: i64,
    ) -> Self {
        Self {
            positive: positive_switch || limits.is_some_and(|l| actual >= l.max),
            negative: negative_switch || limits.is_some_and(|l| actual <= l.min),
        }
    }

    /// Whether a motion in `direction` (its sign; 0 = none) is blocked.
    pub fn stops(&self, direction: f32) -> bool {
        (direction > 0.0 && self.positive) || (direction < 0.0 && self.negative)
    }

    /// Whether anything is blocked.
    pub fn any(&self) -> bool {
        self.positive || self.negative
    }
}

/// The inputs that 60FDh bits 0–3 show (`true` = active).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct InputLevels {
    /// The negative limit switch is actuated.
    pub negative_limit: bool,
    /// The positive limit switch is actuated.
    pub positive_limit: bool,
    /// The home switch is actuated.
    pub home: bool,
    /// The enable input withholds operation.
    pub interlock: bool,
}

/// How a profile lays out 60FDh bits 0–3.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct InputLayout {
    /// Bit 0 is the positive and bit 1 the negative limit switch (CiA402: the reverse).
    pub limits_swapped: bool,
    /// Bit 3 (interlock) is not supported: it stays 0.
    pub without_interlock: bool,
}

/// 60FDh bits 0–3 from the input levels, in the profile's layout.
pub fn digital_inputs(levels: InputLevels, layout: InputLayout) -> u32 {
    let (bit_negative, bit_positive) = if layout.limits_swapped {
        (DI_POSITIVE_LIMIT, DI_NEGATIVE_LIMIT)
    } else {
        (DI_NEGATIVE_LIMIT, DI_POSITIVE_LIMIT)
    };
    let bit = |on: bool, b: u32| if on { b } else { 0 };
    bit(levels.negative_limit, bit_negative)
        | bit(levels.positive_limit, bit_positive)
        | bit(levels.home, DI_HOME_SWITCH)
        | bit(levels.interlock && !layout.without_interlock, DI_INTERLOCK)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn software_limits_are_off_unless_min_is_below_max_and_clamp_targets() {
        assert_eq!(SoftwareLimits::new(0, 0), None, "the 0/0 default");
        assert_eq!(SoftwareLimits::new(5, -5), None);
        let l = SoftwareLimits::new(-100, 200).expect("enabled");
        assert_eq!(l.clamp(50), (50, false));
        assert_eq!(l.clamp(300), (200, true));
        assert_eq!(l.clamp(i64::MIN), (-100, true));
    }

    #[test]
    fn switches_and_limits_block_motion_outward_only() {
        let l = SoftwareLimits::new(-100, 200);
        let free = Blocked::at(false, false, l, 0);
        assert!(!free.any() && !free.stops(1.0) && !free.stops(-1.0));
        let at_max = Blocked::at(false, false, l, 200);
        assert!(at_max.stops(5.0) && !at_max.stops(-5.0) && !at_max.stops(0.0));
        let neg_switch = Blocked::at(true, false, None, 0);
        assert!(neg_switch.stops(-1.0) && !neg_switch.stops(1.0));
        assert!(Blocked::at(false, true, None, 0).stops(1.0));
    }

    #[test]
    fn digital_inputs_follow_cia402_or_the_profiles_layout() {
        let cia402 = InputLayout::default();
        let levels = |negative_limit, positive_limit, home, interlock| InputLevels {
            negative_limit,
            positive_limit,
            home,
            interlock,
        };
        assert_eq!(
            digital_inputs(levels(true, false, true, false), cia402),
            0b101
        );
        assert_eq!(
            digital_inputs(levels(false, true, false, false), cia402),
            0b010
        );
        assert_eq!(
            digital_inputs(levels(false, false, false, true), cia402),
            0b1000,
            "bit 3: interlock"
        );
        let rse = InputLayout {
            limits_swapped: true,
            without_interlock: true,
        };
        assert_eq!(
            digital_inputs(levels(true, false, false, false), rse),
            0b010,
            "RSE: negative in bit 1"
        );
        assert_eq!(
            digital_inputs(levels(false, true, false, false), rse),
            0b001
        );
        assert_eq!(
            digital_inputs(levels(false, false, false, true), rse),
            0,
            "no interlock bit"
        );
    }
}
