//! STM32G4 peripheral register settings computed from physical quantities.
//!
//! The values the drivers of `boards/stm32g474` write into timer, ADC, SPI and watchdog
//! registers are computed here, not typed: a PWM frequency becomes a prescaler and an
//! auto-reload value, a dead time in nanoseconds becomes the DTG code, and so on. Each function cites the
//! formula of the reference manual (RM0440 rev 9, "STM32G4 Series advanced Arm-based 32-bit
//! MCUs") it inverts, rounds on the safe side (a dead time is never shorter than asked, a
//! clock never faster than allowed), reports what it achieved, and refuses what the
//! peripheral cannot do instead of wrapping a field. The crate has no dependency and builds on
//! the host, where its tests check worked examples. `FACTS.md` beside this crate lists the
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
