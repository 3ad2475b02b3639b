//! ADC clock and sampling time (RM0440 §21).
//!
//! - Clock (§21.4.3, ADCx_CCR.CKMODE): 01, 10, 11 clock the ADC synchronously from HCLK / 1,
//!   / 2, / 4 (no jitter between the timer trigger and the start of the sampling: what a
//!   PWM-synchronous current sample needs); 00 selects the asynchronous clock.
//! - Sampling time (§21.4.12, ADC_SMPR1/2.`SMPx[2:0]`): 2.5, 6.5, 12.5, 24.5, 47.5, 92.5, 247.5
//!   or 640.5 ADC clock cycles.
//! - Conversion (§21.4.16): the sampling time plus 12.5 cycles at 12-bit resolution.

use crate::{SettingError, NS_PER_S};

/// The SMP codes 0–7 and their sampling times in half ADC clock cycles, shortest first.
const SAMPLE_TIMES: [(u8, u64); 8] = [
    (0b000, 5),
    (0b001, 13),
    (0b010, 25),
    (0b011, 49),
    (0b100, 95),
    (0b101, 185),
    (0b110, 495),
    (0b111, LONGEST_SAMPLE_HALF_CYCLES),
];
/// The longest sampling time (SMP = 111), in half cycles.
const LONGEST_SAMPLE_HALF_CYCLES: u64 = 1281;
/// The longest sampling time in ns × the ADC clock in Hz: 640.5 cycles × 10⁹.
const LONGEST_SAMPLE_NS_HZ: u64 = LONGEST_SAMPLE_HALF_CYCLES * NS_PER_S / 2;

/// The successive-approximation time of a 12-bit conversion, in half cycles.
const CONVERSION_12_BIT_HALF_CYCLES: u64 = 25;

/// A synchronous ADC clock: HCLK divided by 1, 2 or 4.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SynchronousClock {
    /// ADCx_CCR.CKMODE (01, 10 or 11).
    pub ckmode: u8,
    /// The ADC clock, Hz.
    pub adc_hz: u32,
}

impl SynchronousClock {
    /// The fastest synchronous clock from `hclk_hz` that does not exceed `max_adc_hz` (the
    /// device's limit, from its datasheet).
    pub const fn at_most(hclk_hz: u32, max_adc_hz: u32) -> Result<Self, SettingError> {
        if hclk_hz == 0 || max_adc_hz == 0 {
            return Err(SettingError::Zero);
        }
        // CKMODE 01, 10, 11: HCLK / 1, / 2, / 4, each half the one before.
        let mut modes: &[u8] = &[0b01, 0b10, 0b11];
        let mut adc_hz = hclk_hz;
        while let [ckmode, rest @ ..] = modes {
            if adc_hz <= max_adc_hz {
                return Ok(Self {
                    ckmode: *ckmode,
                    adc_hz,
                });
            }
            adc_hz >>= 1;
            modes = rest;
        }
        Err(SettingError::TooSmall {
            min: (hclk_hz / 4) as u64,
        })
    }
}

/// A sampling time as ADC_SMPRx.SMPx encodes it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SampleTime {
    /// `SMPx[2:0]`.
    pub code: u8,
    /// The sampling time, in half ADC clock cycles.
    pub half_cycles: u16,
}

impl SampleTime {
    /// The shortest sampling time of at least `min_ns` (what the source impedance and the
    /// sampling capacitor need, from the datasheet's formula) at an ADC clock of `adc_hz`.
    pub const fn at_least(adc_hz: u32, min_ns: u32) -> Result<Self, SettingError> {
        // The longest sampling time at this clock, ns (rounded down); a zero clock has none.
        let Some(longest_ns) = LONGEST_SAMPLE_NS_HZ.checked_div(adc_hz as u64) else {
            return Err(SettingError::Zero);
        };
        // half_cycles / (2 f) ≥ t ⇔ half_cycles ≥ 2 f t / 10⁹, rounded up. f t is a product of
        // two u32; doubled it saturates only far beyond the longest sampling time (refused
        // below, as it should be).
        let needed = (adc_hz as u64)
            .saturating_mul(min_ns as u64)
            .saturating_mul(2)
            .div_ceil(NS_PER_S);
        let mut times: &[(u8, u64)] = &SAMPLE_TIMES;
        while let [(code, half), rest @ ..] = times {
            if *half >= needed {
                return Ok(Self {
                    code: *code,
                    half_cycles: *half as u16,
                });
            }
            times = rest;
        }
        Err(SettingError::TooLarge { max: longest_ns })
    }

    /// The time from the start of the sampling to the end of a 12-bit conversion, in ns
    /// (rounded up), at an ADC clock of `adc_hz`.
    // Overflow-free for every input: (65 535 + 25) half cycles × 10⁹ < 2⁴⁷, twice a u32 clock
    // < 2³³, and the divisor is not 0 in its arm.
    #[allow(clippy::arithmetic_side_effects)]
    pub const fn conversion_ns(&self, adc_hz: u32) -> u64 {
        let half = self.half_cycles as u64 + CONVERSION_12_BIT_HALF_CYCLES;
        match adc_hz {
            0 => 0,
            hz => (half * NS_PER_S).div_ceil(2 * hz as u64),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fastest_synchronous_clock_within_the_limit() {
        // 170 MHz HCLK and a 60 MHz limit: HCLK / 4 = 42.5 MHz (CKMODE 11).
        assert_eq!(
            SynchronousClock::at_most(170_000_000, 60_000_000),
            Ok(SynchronousClock {
                ckmode: 0b11,
                adc_hz: 42_500_000
            })
        );
        // 100 MHz: HCLK / 2.
        assert_eq!(
            SynchronousClock::at_most(100_000_000, 60_000_000).map(|c| c.ckmode),
            Ok(0b10)
        );
        assert_eq!(
            SynchronousClock::at_most(170_000_000, 10_000_000),
            Err(SettingError::TooSmall { min: 42_500_000 })
        );
    }

    #[test]
    fn the_shortest_sampling_time_that_is_long_enough() {
        // 42.5 MHz: one cycle is 23.5 ns. 100 ns needs 4.25 cycles → 6.5 cycles (code 1).
        let s = SampleTime::at_least(42_500_000, 100).unwrap();
        assert_eq!((s.code, s.half_cycles), (1, 13));
        // A shunt amplifier's 250 ns: 10.6 cycles → 12.5 (code 2); with the 12.5-cycle
        // conversion: 25 cycles = 588.2 ns.
        let s = SampleTime::at_least(42_500_000, 250).unwrap();
        assert_eq!(s.code, 2);
        assert_eq!(s.conversion_ns(42_500_000), 589);
        // Exactly 2.5 cycles (58.8 ns) is code 0; a nanosecond more is code 1.
        assert_eq!(SampleTime::at_least(42_500_000, 58).unwrap().code, 0);
        assert_eq!(SampleTime::at_least(42_500_000, 59).unwrap().code, 1);
        // Beyond 640.5 cycles (15.07 µs) there is no code.
        assert_eq!(
            SampleTime::at_least(42_500_000, 20_000),
            Err(SettingError::TooLarge { max: 15_070 })
        );
        // 2 f t beyond 64 bits is refused, not wrapped.
        assert_eq!(
            SampleTime::at_least(u32::MAX, u32::MAX),
            Err(SettingError::TooLarge { max: 149 })
        );
        assert_eq!(SampleTime::at_least(0, 100), Err(SettingError::Zero));
    }
}
