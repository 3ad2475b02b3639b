//! Current and bus-voltage sensing: an ADC sampled at the PWM period boundary.
//!
//! Phase current: `counts = zero_count + round((i + offset + noise) / amps_per_count)`,
//! saturating at `0 ..= 2^bits − 1`; the noise is Gaussian with `noise_a_rms` from the plant's
//! seeded PRNG. Bus voltage: `counts = round(V / bus_volts_per_count)`, saturating.

/// ADC and sensor scaling.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensingParams {
    /// ADC resolution in bits (1..=16).
    pub adc_bits: u32,
    /// Current per ADC count in A (positive: current out of the leg reads above `zero_count`).
    pub amps_per_count: f64,
    /// ADC reading at zero current (nominally mid-scale, e.g. 2048 for 12 bits).
    pub zero_count: u16,
    /// True offset error of each phase's current sensor, in A.
    pub offset_a: [f64; 3],
    /// RMS of the Gaussian noise on each current reading, in A.
    pub noise_a_rms: f64,
    /// Bus voltage per ADC count in V.
    pub bus_volts_per_count: f64,
}

/// Highest ADC code for a given resolution (`bits` already validated to 1..=16).
pub fn full_scale(bits: u32) -> f64 {
    ((1u32 << bits) - 1) as f64
}

/// `x.round()` (to nearest, halves away from zero), without the library call that `round`
/// is on the x86-64 baseline (no SSE4.1): the simulation quantises four ADC readings every PWM
/// period of every axis. The same result for every `x` but the sign of a zero.
fn round_to_nearest(x: f64) -> f64 {
    /// From 2^52 on every `f64` is a whole number.
    const WHOLE_FROM: f64 = 4_503_599_627_370_496.0;
    if x.is_nan() || x.abs() >= WHOLE_FROM {
        return x;
    }
    // Truncation toward zero; x − t is exact (t has x's sign and at most its exponent).
    let t = x as i64 as f64;
    let fraction = x - t;
    if fraction >= 0.5 {
        t + 1.0
    } else if fraction <= -0.5 {
        t - 1.0
    } else {
        t
    }
}

/// Quantises `value / per_count + zero` to an ADC code, rounding to nearest and saturating.
pub fn quantise(value: f64, per_count: f64, zero: u16, bits: u32) -> u16 {
    let code = round_to_nearest(f64::from(zero) + value / per_count);
    if code.is_nan() {
        return zero; // not reachable with validated parameters; never panic
    }
    // Saturating float→int cast after the clamp; the range fits u16 since bits <= 16.
    code.clamp(0.0, full_scale(bits)) as u16
}

impl SensingParams {
    /// ADC code of phase `phase` for true current `current_a` and noise sample `noise_a`.
    pub fn current_counts(&self, phase: usize, current_a: f64, noise_a: f64) -> u16 {
        quantise(
            current_a + self.offset_a[phase] + noise_a,
            self.amps_per_count,
            self.zero_count,
            self.adc_bits,
        )
    }

    /// ADC code of the bus voltage.
    pub fn bus_counts(&self, bus_v: f64) -> u16 {
        quantise(bus_v, self.bus_volts_per_count, 0, self.adc_bits)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> SensingParams {
        SensingParams {
            adc_bits: 12,
            amps_per_count: 0.02,
            zero_count: 2048,
            offset_a: [0.0; 3],
            noise_a_rms: 0.0,
            bus_volts_per_count: 0.02,
        }
    }

    #[test]
    fn quantisation_step_is_one_count_per_amps_per_count() {
        let p = params();
        for k in -100i32..=100 {
            let i = f64::from(k) * p.amps_per_count;
            let expected = (2048 + k) as u16;
            assert_eq!(p.current_counts(0, i, 0.0), expected);
            // Anything within ±0.49 LSB maps to the same code.
            assert_eq!(p.current_counts(0, i + 0.49 * 0.02, 0.0), expected);
            assert_eq!(p.current_counts(0, i - 0.49 * 0.02, 0.0), expected);
        }
        assert_eq!(p.current_counts(0, 0.51 * 0.02, 0.0), 2049);
    }

    #[test]
    fn rounding_is_that_of_f64_round() {
        let mut x = 0x9E37_79B9_7F4A_7C15u64;
        let mut values = vec![
            0.5,
            -0.5,
            1.5,
            -2.5,
            0.499_999_999_999_999_94,
            -0.499_999_999_999_999_94,
            4_503_599_627_370_495.5,
            4_503_599_627_370_496.0,
            -9.1e18,
            1e300,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MIN_POSITIVE,
        ];
        for _ in 0..100_000 {
            // xorshift64: bit patterns of every magnitude, and values near halves.
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            values.push(f64::from_bits(x));
            values.push((x % 100_000) as f64 * 0.5 - 25_000.0);
            values.push((x % 1_000_000) as f64 * 1e-3 - 500.0);
        }
        for v in values.into_iter().filter(|v| !v.is_nan()) {
            assert_eq!(round_to_nearest(v), v.round(), "{v:e}");
        }
        assert!(round_to_nearest(f64::NAN).is_nan());
    }

    #[test]
    fn saturates_at_the_adc_range() {
        let p = params();
        assert_eq!(p.current_counts(1, 1e6, 0.0), 4095);
        assert_eq!(p.current_counts(1, -1e6, 0.0), 0);
        assert_eq!(p.bus_counts(1e6), 4095);
        assert_eq!(p.bus_counts(-5.0), 0);
        assert_eq!(p.bus_counts(48.0), 2400);
    }

    #[test]
    fn offset_is_added_per_phase() {
        let p = SensingParams {
            offset_a: [0.1, -0.2, 0.0],
            ..params()
        };
        assert_eq!(p.current_counts(0, 0.0, 0.0), 2053);
        assert_eq!(p.current_counts(1, 0.0, 0.0), 2038);
        assert_eq!(p.current_counts(2, 0.0, 0.0), 2048);
    }
}
