//! Centre-aligned PWM of an advanced timer (TIM1/TIM8/TIM20): prescaler, auto-reload and the
//! repetition counter.
//!
//! RM0440 §29.3.4 "Center-aligned mode (up/down counting)": the counter counts from 0 up to
//! ARR − 1, then from ARR down to 1, so one PWM period is 2 × ARR counter ticks and
//!
//! ```text
//! f_PWM = f_TIM / ((PSC + 1) × 2 × ARR)
//! ```
//!
//! with PSC and ARR 16-bit (TIMx_PSC, TIMx_ARR). RM0440 §29.3.5 / §29.6.15: in centre-aligned
//! mode the repetition counter counts *half* periods (it decrements at every overflow and every
//! underflow), and the update event comes when it reaches 0: REP = 2 × n − 1 gives one update
//! every n periods, always at the same turning point.

use crate::SettingError;

/// The largest value of a 16-bit timer register.
const REGISTER_MAX: u64 = u16::MAX as u64;

/// PSC and ARR of a centre-aligned PWM.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CentreAligned {
    /// TIMx_PSC: the counter runs at f_TIM / (PSC + 1).
    pub prescaler: u16,
    /// TIMx_ARR: the counter's turning point; a compare value of ARR is a duty of 100 %.
    pub auto_reload: u16,
}

impl CentreAligned {
    /// The PSC/ARR whose frequency is nearest to `pwm_hz` with the finest resolution (the
    /// smallest prescaler that lets ARR fit 16 bits), for a timer clocked at `timer_hz`.
    // Overflow-free for every input: timer and pwm are u32 (2 × pwm < 2³³, and ≤ timer past
    // the first check, so timer / (2 × pwm) ≥ 1 and divider ≥ 1); divider ≤ 65 536, so
    // 2 × divider × pwm < 2⁴⁹ and timer + divider × pwm < 2⁵⁰.
    #[allow(clippy::arithmetic_side_effects)]
    pub const fn new(timer_hz: u32, pwm_hz: u32) -> Result<Self, SettingError> {
        if timer_hz == 0 || pwm_hz == 0 {
            return Err(SettingError::Zero);
        }
        let (timer, pwm) = (timer_hz as u64, pwm_hz as u64);
        // ARR = 1 without prescaler is the fastest: f_TIM / 2.
        if 2 * pwm > timer {
            return Err(SettingError::TooLarge { max: timer / 2 });
        }
        // The smallest divider (PSC + 1) that brings ARR into 16 bits.
        let mut divider = (timer / (2 * pwm)).div_ceil(REGISTER_MAX);
        if divider == 0 {
            divider = 1;
        }
        if divider > REGISTER_MAX + 1 {
            let min = timer.div_ceil(2 * (REGISTER_MAX + 1) * REGISTER_MAX);
            return Err(SettingError::TooSmall { min });
        }
        // ARR: half a period in counter ticks, rounded to the nearest, within 1..=65535.
        let mut arr = (timer + divider * pwm) / (2 * divider * pwm);
        if arr < 1 {
            arr = 1;
        }
        if arr > REGISTER_MAX {
            arr = REGISTER_MAX;
        }
        Ok(Self {
            prescaler: (divider - 1) as u16,
            auto_reload: arr as u16,
        })
    }

    /// Counter ticks of one PWM period, at the timer clock (before the prescaler).
    // Overflow-free for every input: (65 535 + 1) × 2 × 65 535 < 2³³.
    #[allow(clippy::arithmetic_side_effects)]
    pub const fn period_ticks(&self) -> u64 {
        (self.prescaler as u64 + 1) * 2 * self.auto_reload as u64
    }

    /// The frequency achieved, in mHz, for a timer clocked at `timer_hz` (rounded down).
    // Overflow-free for every input: a u32 clock × 1000 < 2⁴², and ticks is not 0 in its arm.
    #[allow(clippy::arithmetic_side_effects)]
    pub const fn frequency_mhz(&self, timer_hz: u32) -> u64 {
        match self.period_ticks() {
            0 => 0,
            ticks => timer_hz as u64 * 1000 / ticks,
        }
    }
}

/// TIMx_RCR for one update event every `periods` PWM periods in centre-aligned mode (the
/// repetition counter counts half periods): 2 × `periods` − 1.
// Overflow-free for every input: periods ≥ 1 past the first check, and twice a u32 fits a u64.
#[allow(clippy::arithmetic_side_effects)]
pub const fn repetition_counter(periods: u32) -> Result<u16, SettingError> {
    if periods == 0 {
        return Err(SettingError::Zero);
    }
    let rep = 2 * periods as u64 - 1;
    if rep > REGISTER_MAX {
        return Err(SettingError::TooLarge {
            max: REGISTER_MAX.div_ceil(2),
        });
    }
    Ok(rep as u16)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn forty_khz_at_170_mhz_is_arr_2125_without_prescaler() {
        // f = 170 MHz / (1 × 2 × 2125) = 40 kHz exactly.
        let p = CentreAligned::new(170_000_000, 40_000).unwrap();
        assert_eq!((p.prescaler, p.auto_reload), (0, 2125));
        assert_eq!(p.frequency_mhz(170_000_000), 40_000_000);
        // 20 kHz: ARR 4250.
        let p = CentreAligned::new(170_000_000, 20_000).unwrap();
        assert_eq!((p.prescaler, p.auto_reload), (0, 4250));
    }

    #[test]
    fn a_frequency_between_two_arr_values_takes_the_nearest() {
        // 170 MHz / (2 × 16 kHz) = 5312.5: 5313 gives 15 998.5 Hz, 5312 gives 16 001.5 Hz;
        // the rounding of the half tick goes up (the lower frequency).
        let p = CentreAligned::new(170_000_000, 16_000).unwrap();
        assert_eq!((p.prescaler, p.auto_reload), (0, 5313));
        // 24 kHz: 3541.67 → 3542 (23 997.7 Hz).
        let p = CentreAligned::new(170_000_000, 24_000).unwrap();
        assert_eq!(p.auto_reload, 3542);
        assert_eq!(p.frequency_mhz(170_000_000), 23_997_741);
    }

    #[test]
    fn a_slow_pwm_uses_the_prescaler() {
        // 100 Hz: 850 000 ticks per half period → divider 13 (ARR 65 385 ≤ 65 535).
        let p = CentreAligned::new(170_000_000, 100).unwrap();
        assert_eq!(p.prescaler, 12);
        assert_eq!(p.auto_reload, 65_385);
        let f = p.frequency_mhz(170_000_000);
        assert!((99_990..=100_010).contains(&f), "{f} mHz");
    }

    #[test]
    fn impossible_frequencies_are_refused() {
        assert_eq!(CentreAligned::new(0, 40_000), Err(SettingError::Zero));
        assert_eq!(CentreAligned::new(170_000_000, 0), Err(SettingError::Zero));
        assert_eq!(
            CentreAligned::new(170_000_000, 170_000_000),
            Err(SettingError::TooLarge { max: 85_000_000 })
        );
        // Below f_TIM / (2 × 65536 × 65535) ≈ 0.02 Hz there is no setting; 1 Hz works.
        assert!(CentreAligned::new(170_000_000, 1).is_ok());
    }

    #[test]
    fn the_repetition_counter_counts_half_periods() {
        // One update per period: REP = 1; the ODrive-style current loop at every third
        // period: REP = 5.
        assert_eq!(repetition_counter(1), Ok(1));
        assert_eq!(repetition_counter(3), Ok(5));
        assert_eq!(repetition_counter(32_768), Ok(65_535));
        assert_eq!(
            repetition_counter(32_769),
            Err(SettingError::TooLarge { max: 32_768 })
        );
        assert_eq!(repetition_counter(0), Err(SettingError::Zero));
    }
}
