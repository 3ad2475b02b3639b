//! Watchdog registers (0x0400..0x0443, Beckhoff ESC datasheet Section II 0x0400 ff.).
//!
//! One watchdog tick is (divider 0x0400 + 2) × 40 ns; the PDI watchdog 0x0410 and the
//! process-data watchdog 0x0420 count in ticks (0 = disabled).

/// Process-data watchdog status 0x0440 bit 0: 1 = running or disabled, 0 = expired. Reading
/// 0x0440 from the PDI clears AL event bit 6 ([`super::AlEvent::WATCHDOG_PD`]).
pub const PD_STATUS_OK: u16 = 1 << 0;
/// Reset value of the watchdog divider 0x0400: (0x09C2 + 2) × 40 ns = 100 µs per tick.
pub const DIVIDER_RESET: u16 = 0x09C2;
/// Reset value of the PDI (0x0410) and process-data (0x0420) watchdog times, in ticks (100 ms at
/// the reset divider).
pub const TIME_RESET: u16 = 1000;
/// Period of the watchdog base clock (25 MHz), in ns.
pub const CLOCK_NS: u64 = 40;
/// The divider counts `divider + DIVIDER_EXTRA` base clocks per tick.
pub const DIVIDER_EXTRA: u64 = 2;

/// Length of one watchdog tick in ns for the divider value `divider` (0x0400).
// Cannot overflow: at most (65535 + 2) × 40.
#[allow(clippy::arithmetic_side_effects)]
pub const fn tick_ns(divider: u16) -> u64 {
    (divider as u64 + DIVIDER_EXTRA) * CLOCK_NS
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reset_divider_gives_100_us_ticks() {
        assert_eq!(tick_ns(DIVIDER_RESET), 100_000);
    }
}
