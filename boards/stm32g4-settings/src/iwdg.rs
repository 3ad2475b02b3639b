//! Independent watchdog: `IWDG_PR.PR[2:0]` and `IWDG_RLR.RL[11:0]` (RM0440 §42.4):
//!
//! ```text
//! t_timeout = 4 × 2^PR × (RL + 1) / f_LSI
//! ```
//!
//! PR = 0–6 (dividers 4 to 256; 7 is also 256), RL = 0–4095, f_LSI = 32 kHz typical (RM0440
//! §7.2.6; the datasheet gives its spread, which the caller's timeout must allow for).

use crate::SettingError;

/// The largest reload value (12 bits).
const RELOAD_MAX: u64 = 0xFFF;
/// The largest prescaler code with its own divider.
const PR_MAX: u8 = 6;
/// Microseconds per second.
const US_PER_S: u64 = 1_000_000;

/// A watchdog setting.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Watchdog {
    /// `IWDG_PR.PR[2:0]`.
    pub prescaler: u8,
    /// `IWDG_RLR.RL[11:0]`.
    pub reload: u16,
}

impl Watchdog {
    /// The finest setting whose timeout is at least `timeout_us` at an LSI of `lsi_hz` (the
    /// smallest prescaler that fits the reload into 12 bits; the reload rounded up, so the
    /// watchdog never fires before the time the caller allowed).
    // Overflow-free for every input: timeout_us × lsi_hz is a product of two u32, the divider
    // is at most 256 (prescaler 0..=6), counts ≥ 1, and lsi_hz is not 0 past the first check.
    #[allow(clippy::arithmetic_side_effects)]
    pub const fn at_least(lsi_hz: u32, timeout_us: u32) -> Result<Self, SettingError> {
        if lsi_hz == 0 || timeout_us == 0 {
            return Err(SettingError::Zero);
        }
        let lsi_ticks = timeout_us as u64 * lsi_hz as u64;
        let mut prescaler = 0;
        while prescaler <= PR_MAX {
            let divider = 4u64 << prescaler;
            // At least one count: the shortest timeout is one divided LSI period.
            let counts = lsi_ticks.div_ceil(divider * US_PER_S);
            let counts = if counts == 0 { 1 } else { counts };
            if counts <= RELOAD_MAX + 1 {
                return Ok(Self {
                    prescaler,
                    reload: (counts - 1) as u16,
                });
            }
            prescaler += 1;
        }
        Err(SettingError::TooLarge {
            max: (4u64 << PR_MAX) * (RELOAD_MAX + 1) * US_PER_S / lsi_hz as u64,
        })
    }

    /// The timeout in µs at an LSI of `lsi_hz` (rounded down).
    // Overflow-free for every input: 256 × (65 535 + 1) × 10⁶ < 2⁴⁵ (the prescaler clamped to 6,
    // the reload a u16), and hz is not 0 in its arm.
    #[allow(clippy::arithmetic_side_effects)]
    pub const fn timeout_us(&self, lsi_hz: u32) -> u64 {
        let prescaler = if self.prescaler > PR_MAX {
            PR_MAX
        } else {
            self.prescaler
        };
        let divider = 4u64 << prescaler;
        match lsi_hz {
            0 => 0,
            hz => divider * (self.reload as u64 + 1) * US_PER_S / hz as u64,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const LSI_HZ: u32 = 32_000;

    #[test]
    fn worked_examples_at_32_khz() {
        // 10 ms: 320 LSI ticks → ÷4, 80 counts → RL = 79 (exactly 10 ms).
        let w = Watchdog::at_least(LSI_HZ, 10_000).unwrap();
        assert_eq!((w.prescaler, w.reload), (0, 79));
        assert_eq!(w.timeout_us(LSI_HZ), 10_000);
        // 1 s: 32 000 ticks → ÷8 (4000 counts ≤ 4096), RL = 3999.
        let w = Watchdog::at_least(LSI_HZ, 1_000_000).unwrap();
        assert_eq!((w.prescaler, w.reload), (1, 3999));
        // The shortest: 125 µs = one count at ÷4.
        let w = Watchdog::at_least(LSI_HZ, 1).unwrap();
        assert_eq!((w.prescaler, w.reload), (0, 0));
        assert_eq!(w.timeout_us(LSI_HZ), 125);
    }

    #[test]
    fn never_earlier_than_asked_and_refused_beyond_the_range() {
        for us in (100..32_768_000).step_by(9_973) {
            let w = Watchdog::at_least(LSI_HZ, us).unwrap();
            assert!(w.timeout_us(LSI_HZ) >= u64::from(us), "{us} µs: {w:?}");
        }
        // 4 × 64 × 4096 / 32 kHz = 32.768 s.
        assert_eq!(
            Watchdog::at_least(LSI_HZ, 40_000_000),
            Err(SettingError::TooLarge { max: 32_768_000 })
        );
        assert_eq!(Watchdog::at_least(0, 10), Err(SettingError::Zero));
    }
}
