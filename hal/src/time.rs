//! Free-running time base.

/// A free-running counter used to measure execution times (1C32h/1C33h) and intervals.
///
/// # For boards
/// On Cortex-M this is DWT CYCCNT; in the simulation it is the simulated time.
pub trait CycleCounter {
    /// Counter frequency in Hz.
    fn frequency_hz(&self) -> u32;
    /// Current counter value (wraps).
    fn now(&self) -> u32;
}
