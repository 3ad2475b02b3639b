//! Supervision of the synchronisation (ETG.1020 §5.1 sync error counter with the 10F1h limit)
//! and of a delayed SAFEOP → OP transition.
//!
//! Missed SYNC0 events are detected from time: every entry point passes the board's clock, and
//! a SYNC0 that has not come half a cycle after it was due counts as missed. Each missed event
//! adds [`MISSED_WEIGHT`] to the counter, each SYNC0 subtracts 1; above the limit the slave
//! leaves OP/SAFEOP with AL status code 0x001A (ETG.1020 "Sync Error Counter Limit").

use core::num::NonZeroU64;

/// Counter increment per missed sync event (ETG.1020: "+3 for every missed event").
pub const MISSED_WEIGHT: u16 = 3;
/// Counter decrement per good sync event (ETG.1020: "−1 for every correct cycle").
pub const GOOD_WEIGHT: u16 = 1;
/// A SYNC0 interval may differ from a whole number of cycles by this fraction (1/N) of the cycle
/// and still be "on time": the control loop's PLL follows SYNC0 jitter of a few µs, not a
/// different period.
pub const PLL_TOLERANCE_DIVISOR: u64 = 10;
/// Consecutive SYNC0 intervals off the configured period after which the PLL is declared
/// unable to lock (AL status code 0x0032).
pub const PLL_LOSS_COUNT: u8 = 3;

/// 10F1h:02 default when the profile has no 10F1h (Beckhoff drives ship 4: two misses in a row
/// trip, a single one does not).
pub const DEFAULT_COUNTER_LIMIT: u16 = 4;

/// SYNC0 supervision state.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SyncSupervisor {
    counter: u16,
    /// When the next SYNC0 is due (ns, board clock); `None` before the first SYNC0.
    next_due_ns: Option<u64>,
    /// Sync events missed since supervision started (1C32h:0B).
    missed_total: u16,
    /// Time of the last SYNC0 (board clock, ns).
    last_sync0_ns: Option<u64>,
    /// Consecutive SYNC0 intervals that were not a whole number of cycles.
    off_period: u8,
    /// [`Self::missed_total`] when [`Self::missed_update`] last returned it.
    missed_published: u16,
    /// The board reported that its control loop could not phase-lock to SYNC0.
    phase_lock_lost: bool,
}

impl SyncSupervisor {
    /// Forgets everything (on leaving SAFEOP, on a new DC configuration).
    pub fn reset(&mut self) {
        *self = Self::default();
    }

    /// Clears the sync error counter only (on SAFEOP → OP: events missed in SAFEOP do not count
    /// against OP; the Σ-V-SD manual §4.4 (4) says so, ETG.1020 leaves it open). The SYNC0
    /// schedule and the missed-event total stay.
    pub fn restart_counter(&mut self) {
        self.counter = 0;
    }

    /// A SYNC0 arrived at `now_ns`; the next one is due one `cycle_ns` later. `outputs`:
    /// whether the master wrote the outputs since the previous SYNC0, where that is supervised
    /// (`None`: not supervised); a SYNC0 without them counts as a missed event.
    pub fn on_sync0(&mut self, now_ns: u64, cycle_ns: u32, outputs: Option<bool>) {
        if outputs == Some(false) {
            self.counter = self.counter.saturating_add(MISSED_WEIGHT);
            self.missed_total = self.missed_total.saturating_add(1);
        } else {
            self.counter = self.counter.saturating_sub(GOOD_WEIGHT);
        }
        self.next_due_ns = Some(now_ns.saturating_add(u64::from(cycle_ns)));
        if let Some(last) = self.last_sync0_ns {
            if on_period(now_ns.saturating_sub(last), u64::from(cycle_ns)) {
                self.off_period = 0;
            } else {
                self.off_period = self.off_period.saturating_add(1);
            }
        }
        self.last_sync0_ns = Some(now_ns);
    }

    /// The board's phase lock of its control loop to SYNC0 was lost or never made (e.g. its
    /// PWM cannot be trimmed far enough to follow the ESC's clock): a PLL loss like a SYNC0 at
    /// another period. Forgotten at [`Self::reset`].
    pub fn report_phase_lock_lost(&mut self) {
        self.phase_lock_lost = true;
    }

    /// Whether SYNC0 has come at a period other than the configured cycle
    /// [`PLL_LOSS_COUNT`] times in a row, or the board reported its phase lock lost: the
    /// control loop cannot phase-lock to it.
    pub fn pll_lost(&self) -> bool {
        self.off_period >= PLL_LOSS_COUNT || self.phase_lock_lost
    }

    /// Counts the SYNC0 events that should have arrived by `now_ns` but did not. Returns the
    /// number newly counted. Nothing is counted before the first SYNC0.
    pub fn check(&mut self, now_ns: u64, cycle_ns: u32) -> u16 {
        let (Some(due), Some(cycle)) = (self.next_due_ns, NonZeroU64::new(u64::from(cycle_ns)))
        else {
            return 0;
        };
        let late_after = due.saturating_add(cycle.get() / 2);
        let Some(late_by) = now_ns.checked_sub(late_after).filter(|&d| d > 0) else {
            return 0;
        };
        // The late event and every whole cycle since; counts and times clamp at their top.
        let missed = (late_by / cycle).saturating_add(1);
        let missed = u16::try_from(missed).unwrap_or(u16::MAX);
        self.next_due_ns = Some(due.saturating_add(u64::from(missed).saturating_mul(cycle.get())));
        self.counter = self
            .counter
            .saturating_add(missed.saturating_mul(MISSED_WEIGHT));
        self.missed_total = self.missed_total.saturating_add(missed);
        missed
    }

    /// Whether the counter is above `limit` (ETG.1020), or with `at_limit` has reached it (the
    /// Σ-V-SD's rule, `SyncSupport::sync_error_at_limit`); a limit of 0 disables supervision.
    pub fn tripped(&self, limit: u16, at_limit: bool) -> bool {
        limit != 0 && (self.counter > limit || (at_limit && self.counter == limit))
    }

    /// Whether SYNC0 events come and the counter holds no error (it is 0: every missed event
    /// has been paid back by good ones).
    pub fn in_sync(&self) -> bool {
        self.running() && self.counter == 0
    }

    /// Whether a SYNC0 has been seen since the last reset.
    pub fn running(&self) -> bool {
        self.next_due_ns.is_some()
    }

    /// Sync events missed since the last reset.
    pub fn missed_total(&self) -> u16 {
        self.missed_total
    }

    /// [`Self::missed_total`] if it changed since the last call (for 1C32h:0B).
    pub fn missed_update(&mut self) -> Option<u16> {
        (self.missed_total != self.missed_published).then(|| {
            self.missed_published = self.missed_total;
            self.missed_total
        })
    }
}

/// Consecutive SYNC0 events without new outputs, for a profile's `[esm] lost_outputs` rule
/// (the SDV3-E's cSD: "valid data not received within the specified time in cycle
/// synchronization mode", P4.03 times in a row).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LostOutputsCounter {
    /// Lost cycles in a row that trip; 0 = not supervised.
    limit: u16,
    /// Lost cycles in a row so far.
    run: u16,
}

impl LostOutputsCounter {
    /// Sets the limit (read from the profile's parameter at power-on); 0 switches it off.
    pub fn set_limit(&mut self, limit: u16) {
        self.limit = limit;
        self.run = 0;
    }

    /// Whether the outputs are supervised at all.
    pub fn enabled(&self) -> bool {
        self.limit != 0
    }

    /// A supervised SYNC0: `fresh` = the master wrote the outputs since the previous one.
    pub fn on_sync0(&mut self, fresh: bool) {
        self.run = if fresh { 0 } else { self.run.saturating_add(1) };
    }

    /// Starts the count afresh (OP entered, supervision paused, after a trip).
    pub fn restart(&mut self) {
        self.run = 0;
    }

    /// Whether the limit was reached.
    pub fn tripped(&self) -> bool {
        self.limit != 0 && self.run >= self.limit
    }
}

/// Whether `interval` is a whole number (≥ 1) of `cycle`s within the PLL tolerance (missed
/// pulses are the sync error counter's business, not a period change).
fn on_period(interval: u64, cycle: u64) -> bool {
    let Some(divisor) = NonZeroU64::new(cycle) else {
        return true;
    };
    // The usual case, one cycle (k = 1 below), without the 64-bit division (a library call on
    // the Cortex-M4): within the tolerance of one cycle, the nearest whole number is 1.
    if interval.abs_diff(cycle) <= cycle / PLL_TOLERANCE_DIVISOR {
        return true;
    }
    // The nearest whole number of cycles; saturation only for intervals near 2^64 ns, far
    // off any period anyway.
    let k = (interval.saturating_add(cycle / 2) / divisor).max(1);
    interval.abs_diff(k.saturating_mul(cycle)) <= cycle / PLL_TOLERANCE_DIVISOR
}

#[cfg(test)]
mod tests {
    use super::*;

    const CYCLE: u32 = 1_000_000;

    #[test]
    fn lost_outputs_trip_only_after_the_limit_in_a_row() {
        let mut c = LostOutputsCounter::default();
        c.set_limit(3);
        // Two lost, one fresh, two lost: never three in a row.
        for fresh in [false, false, true, false, false] {
            c.on_sync0(fresh);
            assert!(!c.tripped());
        }
        c.on_sync0(false);
        assert!(c.tripped(), "third lost cycle in a row");
        c.restart();
        assert!(!c.tripped());
    }

    #[test]
    fn lost_outputs_limit_zero_is_no_supervision() {
        let mut c = LostOutputsCounter::default();
        assert!(!c.enabled());
        for _ in 0..1000 {
            c.on_sync0(false);
        }
        assert!(!c.tripped());
    }

    #[test]
    fn nothing_is_missed_before_the_first_sync0() {
        let mut s = SyncSupervisor::default();
        assert_eq!(s.check(50_000_000, CYCLE), 0);
        assert!(!s.running());
    }

    #[test]
    fn in_sync_until_a_missed_event_and_again_once_it_is_paid_back() {
        let mut s = SyncSupervisor::default();
        assert!(!s.in_sync(), "no SYNC0 yet");
        s.on_sync0(0, CYCLE, None);
        assert!(s.in_sync());
        // One SYNC0 missed: +3, then −1 per good event (ETG.1020): out of sync for three.
        assert_eq!(s.check(1_600_000, CYCLE), 1);
        assert!(!s.in_sync());
        for k in 2..5u64 {
            s.on_sync0(k * 1_000_000, CYCLE, None);
            assert_eq!(s.in_sync(), k == 4, "SYNC0 {k}");
        }
    }

    #[test]
    fn regular_sync0_never_trips() {
        let mut s = SyncSupervisor::default();
        for k in 0..1000u64 {
            s.on_sync0(k * 1_000_000, CYCLE, None);
            assert_eq!(s.check(k * 1_000_000 + 900_000, CYCLE), 0);
        }
        assert!(!s.tripped(DEFAULT_COUNTER_LIMIT, false));
    }

    #[test]
    fn one_miss_does_not_trip_but_misses_one_good_cycle_apart_do() {
        let mut s = SyncSupervisor::default();
        s.on_sync0(0, CYCLE, None);
        // SYNC0 due at 1 ms is late after 1.5 ms.
        assert_eq!(s.check(1_400_000, CYCLE), 0);
        assert_eq!(s.check(1_600_000, CYCLE), 1);
        assert!(!s.tripped(4, false), "counter 3");
        assert!(s.tripped(3, true), "counter 3 reaches a limit of 3");
        assert!(!s.tripped(3, false), "but does not exceed it");
        s.on_sync0(2_000_000, CYCLE, None);
        assert_eq!(s.check(3_600_000, CYCLE), 1);
        assert!(s.tripped(4, false), "counter 3 - 1 + 3 = 5 > 4");
    }

    #[test]
    fn loss_of_sync0_trips_after_two_cycles() {
        let mut s = SyncSupervisor::default();
        s.on_sync0(0, CYCLE, None);
        assert_eq!(s.check(2_600_000, CYCLE), 2);
        assert!(s.tripped(4, false));
        assert_eq!(s.missed_total(), 2);
        assert!(!s.tripped(0, false), "limit 0 disables supervision");
        assert!(!s.tripped(0, true), "also when tripping at the limit");
    }

    #[test]
    fn sync0_without_new_outputs_counts_as_missed_where_supervised() {
        // Σ-V-SD §4.4 (4) worked example: outputs missing at every other SYNC0:
        // 0, 3, 2, 5, 4, 7, 6, 9 → the limit 9 is reached at the 8th event (4th miss).
        let mut s = SyncSupervisor::default();
        let mut counters = [0u16; 8];
        for (k, (fresh, counter)) in [true, false, true, false, true, false, true, false]
            .into_iter()
            .zip(counters.iter_mut())
            .enumerate()
        {
            s.on_sync0(k as u64 * 1_000_000, CYCLE, Some(fresh));
            *counter = s.counter;
        }
        assert_eq!(counters, [0, 3, 2, 5, 4, 7, 6, 9]);
        assert!(s.tripped(9, true));
        assert!(!s.tripped(9, false));
        assert_eq!(s.missed_total(), 4);
        // SAFEOP → OP starts the counter afresh.
        s.restart_counter();
        assert_eq!((s.counter, s.missed_total()), (0, 4));
        // Unsupervised (`None`) a SYNC0 is always a good event.
        let mut s = SyncSupervisor::default();
        s.on_sync0(0, CYCLE, None);
        assert_eq!((s.counter, s.missed_total()), (0, 0));
    }

    #[test]
    fn long_outage_is_counted_without_looping_per_cycle() {
        let mut s = SyncSupervisor::default();
        s.on_sync0(0, 31_250, None);
        assert_eq!(s.check(10_000_000_000, 31_250), u16::MAX);
    }

    #[test]
    fn pll_is_lost_when_sync0_comes_at_another_period() {
        let mut s = SyncSupervisor::default();
        for k in 0..5u64 {
            s.on_sync0(k * 1_000_000 + (k % 2) * 50_000, CYCLE, None); // 50 µs jitter: locked
        }
        assert!(!s.pll_lost());
        let mut t = 4_000_000;
        for _ in 0..3 {
            t += 1_500_000; // the master changed 0x09A0 to 1.5 ms
            s.on_sync0(t, CYCLE, None);
        }
        assert!(s.pll_lost());
    }

    #[test]
    fn a_phase_lock_the_board_lost_is_a_pll_loss_until_reset() {
        let mut s = SyncSupervisor::default();
        for k in 0..5u64 {
            s.on_sync0(k * 1_000_000, CYCLE, None);
        }
        assert!(!s.pll_lost());
        s.report_phase_lock_lost();
        assert!(s.pll_lost());
        s.on_sync0(5_000_000, CYCLE, None);
        assert!(s.pll_lost(), "good SYNC0 events do not clear it");
        s.reset();
        assert!(!s.pll_lost());
    }

    #[test]
    fn an_interval_is_on_period_within_a_tenth_of_a_cycle_of_a_whole_number() {
        let c = u64::from(CYCLE);
        let tolerance = c / PLL_TOLERANCE_DIVISOR;
        for k in 1..=3 {
            for (interval, on) in [
                (k * c, true),
                (k * c - tolerance, true),
                (k * c + tolerance, true),
                (k * c - tolerance - 1, false),
                (k * c + tolerance + 1, false),
            ] {
                assert_eq!(on_period(interval, c), on, "{interval} ns, k = {k}");
            }
        }
        assert!(!on_period(c / 2, c), "half a cycle");
        assert!(!on_period(0, c));
        assert!(on_period(12_345, 0), "no cycle: nothing to compare");
    }

    #[test]
    fn missed_pulses_are_not_a_period_change() {
        let mut s = SyncSupervisor::default();
        for t in [0, 1_000_000, 3_000_000, 4_000_000, 7_000_000] {
            s.on_sync0(t, CYCLE, None);
        }
        assert!(!s.pll_lost());
    }
}
