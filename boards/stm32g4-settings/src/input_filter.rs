//! Digital filter of a timer input (capture, encoder, external trigger): `TIMx_CCMRx.ICxF[3:0]`,
//! `TIMx_SMCR.ETF[3:0]` (RM0440 §29.6.7, §29.6.3).
//!
//! A transition is taken after N consecutive equal samples at f_SAMPLING; the filter delays
//! every edge by N / f_SAMPLING and rejects shorter pulses. f_DTS is the timer clock divided by
//! TIMx_CR1.CKD ([`ClockDivision`]).
//!
//! | code | f_SAMPLING | N | code | f_SAMPLING | N |
//! |---|---|---|---|---|---|
//! | 0000 | no filter | – | 1000 | f_DTS / 8 | 6 |
//! | 0001 | f_TIM | 2 | 1001 | f_DTS / 8 | 8 |
//! | 0010 | f_TIM | 4 | 1010 | f_DTS / 16 | 5 |
//! | 0011 | f_TIM | 8 | 1011 | f_DTS / 16 | 6 |
//! | 0100 | f_DTS / 2 | 6 | 1100 | f_DTS / 16 | 8 |
//! | 0101 | f_DTS / 2 | 8 | 1101 | f_DTS / 32 | 5 |
//! | 0110 | f_DTS / 4 | 6 | 1110 | f_DTS / 32 | 6 |
//! | 0111 | f_DTS / 4 | 8 | 1111 | f_DTS / 32 | 8 |

use crate::dead_time::ClockDivision;
use crate::{SettingError, NS_PER_S};

/// Codes 1–15: (code, sampling clock divider, N), the divider counted in timer clocks for
/// codes 1–3 and in t_DTS for the others ([`FROM_DTS`]).
const FILTERS: [(u8, u64, u64); 15] = [
    (0b0001, 1, 2),
    (0b0010, 1, 4),
    (0b0011, 1, 8),
    (0b0100, 2, 6),
    (0b0101, 2, 8),
    (0b0110, 4, 6),
    (0b0111, 4, 8),
    (0b1000, 8, 6),
    (0b1001, 8, 8),
    (0b1010, 16, 5),
    (0b1011, 16, 6),
    (0b1100, 16, 8),
    (0b1101, 32, 5),
    (0b1110, 32, 6),
    (0b1111, 32, 8),
];

/// The first code whose sampling clock derives from f_DTS.
const FROM_DTS: u8 = 4;

/// An input filter as ICxF encodes it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct InputFilter {
    /// `ICxF[3:0]` (0: no filter).
    pub code: u8,
    /// The delay it adds to every edge, and the longest pulse it rejects, in timer clocks.
    pub delay_ticks: u64,
}

impl InputFilter {
    /// The strongest filter that still passes a pulse of `shortest_pulse_ns` (the shortest
    /// time between two edges of the valid signal, e.g. a quarter of an encoder line period at
    /// the top speed): the longest delay not above it, for a timer clocked at `timer_hz` with
    /// clock division `ckd`. No filter when even the weakest is too slow.
    // Overflow-free for every input: shortest_pulse_ns × timer_hz is a product of two u32, and a
    // filter's delay is at most 32 × 4 × 8 timer clocks.
    #[allow(clippy::arithmetic_side_effects)]
    pub const fn passing(
        timer_hz: u32,
        ckd: ClockDivision,
        shortest_pulse_ns: u32,
    ) -> Result<Self, SettingError> {
        if timer_hz == 0 {
            return Err(SettingError::Zero);
        }
        let limit_ticks = shortest_pulse_ns as u64 * timer_hz as u64 / NS_PER_S;
        let mut best = Self {
            code: 0,
            delay_ticks: 0,
        };
        let mut filters: &[(u8, u64, u64)] = &FILTERS;
        while let [(code, divider, n), rest @ ..] = filters {
            let clocks = if *code >= FROM_DTS {
                *divider * ckd.divider()
            } else {
                *divider
            };
            let delay_ticks = clocks * *n;
            // The longest delay that passes; among equal ones the later code (more samples).
            if delay_ticks <= limit_ticks && delay_ticks >= best.delay_ticks {
                best = Self {
                    code: *code,
                    delay_ticks,
                };
            }
            filters = rest;
        }
        Ok(best)
    }

    /// The filter's delay in ns for a timer clocked at `timer_hz` (rounded up).
    pub const fn delay_ns(&self, timer_hz: u32) -> u64 {
        match timer_hz {
            0 => 0,
            // Saturated for a delay no filter has (they reach 1024 clocks).
            hz => self
                .delay_ticks
                .saturating_mul(NS_PER_S)
                .div_ceil(hz as u64),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TIM_HZ: u32 = 170_000_000;

    #[test]
    fn an_encoder_at_top_speed_gets_the_strongest_filter_its_edges_survive() {
        // 2500 lines at 6000 rpm: 250 kHz lines, edges every 1 µs (x4) = 170 timer clocks.
        // The longest delay not above that: f_DTS / 32 with N = 5, 160 clocks (code 1101).
        let f = InputFilter::passing(TIM_HZ, ClockDivision::Div1, 1_000).unwrap();
        assert_eq!((f.code, f.delay_ticks), (0b1101, 160));
        assert_eq!(f.delay_ns(TIM_HZ), 942);
        // A limit switch with 100 µs pulses at the minimum: the strongest filter of all.
        let f = InputFilter::passing(TIM_HZ, ClockDivision::Div1, 100_000).unwrap();
        assert_eq!((f.code, f.delay_ticks), (0b1111, 256));
        // With CKD = 4 the f_DTS codes are four times slower: 32 × 4 × 8 = 1024 clocks.
        let f = InputFilter::passing(TIM_HZ, ClockDivision::Div4, 100_000).unwrap();
        assert_eq!((f.code, f.delay_ticks), (0b1111, 1024));
    }

    #[test]
    fn fast_signals_get_a_short_filter_or_none() {
        // 30 ns = 5.1 clocks: N = 4 at f_TIM (code 0010).
        let f = InputFilter::passing(TIM_HZ, ClockDivision::Div1, 30).unwrap();
        assert_eq!((f.code, f.delay_ticks), (0b0010, 4));
        // Below two clocks: no filter.
        let f = InputFilter::passing(TIM_HZ, ClockDivision::Div1, 10).unwrap();
        assert_eq!((f.code, f.delay_ticks), (0, 0));
        assert_eq!(
            InputFilter::passing(0, ClockDivision::Div1, 10),
            Err(SettingError::Zero)
        );
        // A delay no filter has saturates.
        let f = InputFilter {
            code: 0b1111,
            delay_ticks: u64::MAX,
        };
        assert_eq!(f.delay_ns(1), u64::MAX);
    }
}
