//! STM32G4 peripheral register settings computed from physical quantities.
//!
//! The values the drivers of `boards/stm32g474` write into timer, ADC, SPI and watchdog
//! registers are computed here, not typed: a PWM frequency becomes a prescaler and an
//! auto-reload value, a dead time in nanoseconds becomes the DTG code, and so on. Each function cites the
//! formula of the reference manual (RM0440 rev 9, "STM32G4 Series advanced Arm-based 32-bit
//! MCUs") it inverts, rounds on the safe side (a dead time is never shorter than asked, a
//! clock never faster than allowed), reports what it achieved, and refuses what the
//! peripheral cannot do instead of wrapping a field. The crate has no dependency and builds on
//! the host, where its tests check worked examples. Every function is a `const fn`: a board
//! computes its settings at compile time, where a request the peripheral cannot meet is a build
//! error. `FACTS.md` beside this crate lists the
//! sources of every formula and what is still unconfirmed.
//!
//! | module | peripheral | computes |
//! |---|---|---|
//! | [`pwm`] | advanced timer (TIM1/TIM8/TIM20) | centre-aligned period (PSC, ARR), repetition counter |
//! | [`dead_time`] | advanced timer BDTR | `DTG[7:0]` from nanoseconds and the clock division CKD |
//! | [`adc`] | ADC | synchronous clock mode, sampling-time code SMP from nanoseconds |
//! | [`input_filter`] | timer input capture / encoder | ICxF code from the shortest valid pulse |
//! | [`spi`] | SPI | baud-rate code BR from the fastest allowed clock |
//! | [`iwdg`] | independent watchdog | prescaler PR and reload RL from a timeout |

#![no_std]
// Firmware never panics on input: outside tests no unwrap/expect/panic and no unchecked
// indexing or integer arithmetic; each exception states why it cannot fail where it stands.
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::unreachable,
        clippy::todo,
        clippy::unimplemented,
        clippy::indexing_slicing,
        clippy::arithmetic_side_effects
    )
)]

pub mod adc;
pub mod dead_time;
pub mod input_filter;
pub mod iwdg;
pub mod pwm;
pub mod spi;

/// A setting the peripheral cannot make.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SettingError {
    /// A clock or a requested quantity is zero.
    Zero,
    /// The request needs more than the register field holds: `max` is the largest the
    /// peripheral can do, in the request's unit.
    TooLarge {
        /// The largest value the peripheral can do (Hz, ns, µs: the request's unit).
        max: u64,
    },
    /// The request is below what the peripheral can do: `min` is the smallest it can do, in
    /// the request's unit.
    TooSmall {
        /// The smallest value the peripheral can do (the request's unit).
        min: u64,
    },
}

/// Nanoseconds per second.
pub(crate) const NS_PER_S: u64 = 1_000_000_000;

#[cfg(test)]
mod tests {
    use super::*;

    // Computed at compile time, as a board does.
    const PWM: Result<pwm::CentreAligned, SettingError> =
        pwm::CentreAligned::new(170_000_000, 40_000);
    const DEAD_TIME: Result<dead_time::DeadTime, SettingError> =
        dead_time::DeadTime::at_least(170_000_000, dead_time::ClockDivision::Div1, 1_000);
    const ADC_CLOCK: Result<adc::SynchronousClock, SettingError> =
        adc::SynchronousClock::at_most(170_000_000, 60_000_000);
    const SAMPLE: Result<adc::SampleTime, SettingError> =
        adc::SampleTime::at_least(42_500_000, 250);
    const FILTER: Result<input_filter::InputFilter, SettingError> =
        input_filter::InputFilter::passing(170_000_000, dead_time::ClockDivision::Div1, 1_000);
    const SPI: Result<spi::BaudRate, SettingError> =
        spi::BaudRate::at_most(170_000_000, 30_000_000);
    const WATCHDOG: Result<iwdg::Watchdog, SettingError> = iwdg::Watchdog::at_least(32_000, 10_000);

    #[test]
    fn every_setting_can_be_computed_at_compile_time() {
        assert_eq!(PWM.map(|p| p.auto_reload), Ok(2125));
        assert_eq!(DEAD_TIME.map(|d| d.dtg), Ok(0x95));
        assert_eq!(ADC_CLOCK.map(|c| c.ckmode), Ok(0b11));
        assert_eq!(SAMPLE.map(|s| s.code), Ok(2));
        assert_eq!(FILTER.map(|f| f.code), Ok(0b1101));
        assert_eq!(SPI.map(|b| b.br), Ok(0b010));
        assert_eq!(WATCHDOG.map(|w| w.reload), Ok(79));
    }
}
