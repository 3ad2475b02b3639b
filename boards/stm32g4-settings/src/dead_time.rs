//! Dead time of the complementary outputs of an advanced timer: `TIMx_BDTR.DTG[7:0]`.
//!
//! RM0440 §29.6.20 (TIMx_BDTR), with t_DTS the dead-time clock period set by TIMx_CR1.CKD
//! (t_DTS = 1, 2 or 4 timer clock periods):
//!
//! | `DTG[7:5]` | dead time | range in t_DTS |
//! |---|---|---|
//! | 0xx | `DTG[7:0]` × t_DTS | 0–127 in steps of 1 |
//! | 10x | (64 + `DTG[5:0]`) × 2 t_DTS | 128–254 in steps of 2 |
//! | 110 | (32 + `DTG[4:0]`) × 8 t_DTS | 256–504 in steps of 8 |
//! | 111 | (32 + `DTG[4:0]`) × 16 t_DTS | 512–1008 in steps of 16 |
//!
//! The code is rounded up: the dead time is never shorter than asked (a shorter one risks a
//! shoot-through of the half-bridge). ST's `__LL_TIM_CALC_DEADTIME` rounds down and returns 0
//! (no dead time) beyond the range; here that is an error.

use crate::{SettingError, NS_PER_S};

/// TIMx_CR1.CKD: the dead-time and digital-filter clock f_DTS as a division of the timer clock.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ClockDivision {
    /// t_DTS = t_TIM (CKD = 00).
    Div1,
    /// t_DTS = 2 t_TIM (CKD = 01).
    Div2,
    /// t_DTS = 4 t_TIM (CKD = 10).
    Div4,
}

impl ClockDivision {
    /// The CKD field value.
    pub const fn bits(self) -> u8 {
        match self {
            Self::Div1 => 0b00,
            Self::Div2 => 0b01,
            Self::Div4 => 0b10,
        }
    }

    /// Timer clock periods per t_DTS.
    pub const fn divider(self) -> u64 {
        match self {
            Self::Div1 => 1,
            Self::Div2 => 2,
            Self::Div4 => 4,
        }
    }
}

/// The longest dead time, in t_DTS.
const MAX_TICKS: u64 = 1008;

/// A dead time as TIMx_BDTR.DTG encodes it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DeadTime {
    /// `DTG[7:0]`.
    pub dtg: u8,
    /// The dead time it gives, in t_DTS.
    pub ticks: u16,
}

impl DeadTime {
    /// The shortest DTG code whose dead time is at least `dead_time_ns`, for a timer clocked at
    /// `timer_hz` with clock division `ckd`.
    // Overflow-free for every input: dead_time_ns × dts_hz is a product of two u32; `steps`
    // lies in 64..=127 (the 2 t_DTS arm) or 32..=63 (the others), so the subtractions stay
    // ≥ 0 and the products ≤ 1008; the last arm has needed > 1008, so dts_hz is not 0 there.
    #[allow(clippy::arithmetic_side_effects)]
    pub const fn at_least(
        timer_hz: u32,
        ckd: ClockDivision,
        dead_time_ns: u32,
    ) -> Result<Self, SettingError> {
        if timer_hz == 0 {
            return Err(SettingError::Zero);
        }
        let dts_hz = timer_hz as u64 / ckd.divider();
        let needed = (dead_time_ns as u64 * dts_hz).div_ceil(NS_PER_S);
        let (dtg, ticks) = match needed {
            0..=127 => (needed, needed),
            128..=254 => {
                let steps = needed.div_ceil(2);
                (0x80 | (steps - 64), steps * 2)
            }
            255..=504 => {
                let steps = needed.div_ceil(8);
                (0xC0 | (steps - 32), steps * 8)
            }
            505..=MAX_TICKS => {
                let steps = needed.div_ceil(16);
                (0xE0 | (steps - 32), steps * 16)
            }
            _ => {
                return Err(SettingError::TooLarge {
                    max: MAX_TICKS * NS_PER_S / dts_hz,
                })
            }
        };
        Ok(Self {
            dtg: dtg as u8,
            ticks: ticks as u16,
        })
    }

    /// The dead time in ns for a timer clocked at `timer_hz` with clock division `ckd`
    /// (rounded down).
    // Overflow-free for every input: the divider is 1, 2 or 4, a u16 of ticks × 10⁹ < 2⁴⁶, and
    // dts_hz is not 0 in its arm.
    #[allow(clippy::arithmetic_side_effects)]
    pub const fn nanoseconds(&self, timer_hz: u32, ckd: ClockDivision) -> u64 {
        match timer_hz as u64 / ckd.divider() {
            0 => 0,
            dts_hz => self.ticks as u64 * NS_PER_S / dts_hz,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TIM_HZ: u32 = 170_000_000;

    /// The dead time a DTG code gives, in t_DTS, decoded as RM0440 prints it.
    fn decode(dtg: u8) -> u64 {
        let d = u64::from(dtg);
        match dtg >> 5 {
            0..=3 => d,
            4 | 5 => (64 + (d & 0x3F)) * 2,
            6 => (32 + (d & 0x1F)) * 8,
            _ => (32 + (d & 0x1F)) * 16,
        }
    }

    #[test]
    fn worked_examples_at_170_mhz() {
        // t_DTS = 5.88 ns. 100 ns = 17 t_DTS (100.0 ns).
        let d = DeadTime::at_least(TIM_HZ, ClockDivision::Div1, 100).unwrap();
        assert_eq!((d.dtg, d.ticks), (17, 17));
        assert_eq!(d.nanoseconds(TIM_HZ, ClockDivision::Div1), 100);
        // 1 µs = 170 t_DTS: the 2 t_DTS range, (64 + 21) × 2 → DTG = 0b1001_0101.
        let d = DeadTime::at_least(TIM_HZ, ClockDivision::Div1, 1_000).unwrap();
        assert_eq!((d.dtg, d.ticks), (0x95, 170));
        // 2 µs = 340 t_DTS: the 8 t_DTS range, 43 × 8 = 344 → DTG = 0xC0 | 11.
        let d = DeadTime::at_least(TIM_HZ, ClockDivision::Div1, 2_000).unwrap();
        assert_eq!((d.dtg, d.ticks), (0xCB, 344));
        // 5 µs = 850 t_DTS: the 16 t_DTS range, 54 × 16 = 864 → DTG = 0xE0 | 22.
        let d = DeadTime::at_least(TIM_HZ, ClockDivision::Div1, 5_000).unwrap();
        assert_eq!((d.dtg, d.ticks), (0xF6, 864));
    }

    #[test]
    fn never_shorter_than_asked_and_the_shortest_code_that_does_it() {
        for ns in 0..=5_929 {
            let d = DeadTime::at_least(TIM_HZ, ClockDivision::Div1, ns).unwrap();
            assert_eq!(
                decode(d.dtg),
                u64::from(d.ticks),
                "{ns} ns: DTG {:#04x}",
                d.dtg
            );
            let exact = u64::from(d.ticks) * NS_PER_S;
            assert!(exact >= u64::from(ns) * u64::from(TIM_HZ), "{ns} ns: short");
            // No code gives a dead time between the request and the one chosen.
            let shorter = (0..=255u8)
                .map(decode)
                .filter(|&t| t * NS_PER_S >= u64::from(ns) * u64::from(TIM_HZ))
                .min();
            assert_eq!(shorter, Some(u64::from(d.ticks)), "{ns} ns");
        }
    }

    #[test]
    fn the_clock_division_stretches_the_range() {
        // 10 µs needs t_DTS = 4 t_TIM: 1700 / 4 = 425 → 54 × 8 = 432.
        assert_eq!(
            DeadTime::at_least(TIM_HZ, ClockDivision::Div1, 10_000),
            Err(SettingError::TooLarge { max: 5_929 })
        );
        let d = DeadTime::at_least(TIM_HZ, ClockDivision::Div4, 10_000).unwrap();
        assert_eq!(d.ticks, 432);
        assert_eq!(d.nanoseconds(TIM_HZ, ClockDivision::Div4), 10_164);
        assert_eq!(ClockDivision::Div4.bits(), 0b10);
        assert_eq!(
            DeadTime::at_least(0, ClockDivision::Div1, 100),
            Err(SettingError::Zero)
        );
    }
}
