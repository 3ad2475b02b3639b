//! Phase lock of the PWM to the DC SYNC0 events: the PWM period is trimmed so that SYNC0
//! always falls at the same point of the PWM period, and the control loop's ticks keep a fixed
//! phase to the bus cycle (the interpolation between set-points depends on it).
//!
//! # Measurement
//! A timer reset by TIM1's update event (the PWM valley) and captured by the SYNC0 edge gives,
//! in hardware, the ticks from the last valley to SYNC0: the phase of SYNC0 in the PWM period.
//!
//! # Pattern
//! A DC cycle need not be a whole number of PWM periods: 31.25 µs is 1.25 periods of 40 kHz.
//! The lock then holds a repeating pattern: `k` cycles are exactly `m` periods (4 cycles = 5
//! periods), and at the `j`-th SYNC0 the expected phase is `target + j × cycle (mod period)`.
//! [`PhaseLock::new`] finds the smallest `k ≤` [`MAX_PATTERN`] and refuses a cycle without one.
//!
//! # Control
//! With the auto-reload trimmed by `d` ticks, every PWM period lasts `2d` ticks longer, and the
//! measured phase falls by `2d` per period, `2d × cycle/period` per cycle. A proportional term
//! corrects a quarter of the phase error per cycle; an integral term takes up the constant frequency
//! offset between the ESC's clock and the MCU's crystal (±100 ppm: up to 17 ticks per 1 ms
//! cycle). The trim is limited to ±[`MAX_TRIM_PERMILLE`] ‰ of the period, so the loops' idea of
//! the PWM frequency stays right within that.
//!
//! # Lock state
//! Locked after [`LOCK_COUNT`] SYNC0 events in a row within [`LOCK_WINDOW_NS`] of the expected
//! phase; lost (the drive reports AL status 0x0032) after [`LOSS_COUNT`] in a row further than
//! [`LOSS_WINDOW_FACTOR`] windows once locked, or when no lock came within [`ACQUIRE_LIMIT`]
//! cycles.

use core::num::{NonZeroU32, NonZeroU64};
use core::sync::atomic::{AtomicI32, Ordering};

/// Largest number of DC cycles in the repeating pattern.
pub const MAX_PATTERN: u32 = 16;
/// Largest trim of the auto-reload, ‰ of its nominal value.
pub const MAX_TRIM_PERMILLE: u32 = 10;
/// Largest phase error of a locked SYNC0, ns.
pub const LOCK_WINDOW_NS: u32 = 1_000;
/// SYNC0 events in a row within the window that make the lock.
pub const LOCK_COUNT: u32 = 8;
/// A locked SYNC0 is lost further than this many lock windows from the expected phase
/// (hysteresis: a lock made while the phase settles is not lost by its last overshoot).
pub const LOSS_WINDOW_FACTOR: i32 = 5;
/// SYNC0 events in a row outside the loss window that lose the lock.
pub const LOSS_COUNT: u32 = 3;
/// DC cycles allowed to acquire the lock.
pub const ACQUIRE_LIMIT: u32 = 1_000;

/// The integral gain: 1/N of the proportional one per cycle.
const INTEGRAL_DIVISOR: i32 = 16;
/// Fraction bits of the fixed-point tick values (1/256 tick).
const FRAC_BITS: u32 = 8;
const ONE: i64 = 1 << FRAC_BITS;
/// The fraction of a fixed-point value (the bits below [`FRAC_BITS`]).
const FRAC_MASK: i32 = (1 << FRAC_BITS) - 1;
const NS_PER_S: u64 = 1_000_000_000;
/// 10⁹ / 256: a cycle in ns × the timer clock in Hz over this is the cycle in 1/256 ticks.
const NS_PER_S_Q8: u64 = NS_PER_S / ONE as u64;
const _: () = assert!(NS_PER_S % ONE as u64 == 0, "10⁹ is a multiple of 256");

/// The auto-reload of each PWM period for a trim in 1/256 ticks: a first-order sigma-delta,
/// so that the periods average the trim exactly (a whole-tick trim would move the phase by
/// 2 × periods-per-cycle ticks per cycle: 4.7 µs in a 10 ms cycle).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PeriodDither {
    nominal_q8: i32,
    residual: i32,
}

impl PeriodDither {
    /// Periods of `nominal_arr`, no trim yet.
    pub const fn new(nominal_arr: u16) -> Self {
        Self {
            // At most 65535 × 256 < 2^24: an i32 holds it and the sums below.
            nominal_q8: (nominal_arr as i32) << FRAC_BITS,
            residual: 0,
        }
    }

    /// The auto-reload of the next period at `trim_q8` (1/256 ticks, clamped to ±1/2 of the
    /// nominal value).
    ///
    /// Timing: control interrupt, every PWM period; a dozen instructions, no division.
    #[inline]
    pub fn next_arr(&mut self, trim_q8: i32) -> u16 {
        let limit = self.nominal_q8 / 2;
        // Overflow-free: nominal_q8 < 2^24 (`new`), the trim is clamped to ±nominal_q8 / 2 and
        // the residual lies in 0..256: the sum is below 3/2 × 2^24 + 2^8.
        #[allow(clippy::arithmetic_side_effects)]
        // max/min rather than `clamp`, whose bound check would be a panic path in the
        // control interrupt (`panic-paths`).
        let total = self.nominal_q8 + trim_q8.max(-limit).min(limit) + self.residual;
        let arr = total >> FRAC_BITS;
        // The fraction left over (total − arr × 256) goes to the next period.
        self.residual = total & FRAC_MASK;
        // Between 1/2 and 3/2 of a u16 nominal ARR, which exceeds u16 only for a nominal
        // above 43,690: saturate there.
        u16::try_from(arr).unwrap_or(u16::MAX)
    }
}

/// The trim handed from the SYNC0 context (writer) to the control interrupt (reader, which
/// sets each period's auto-reload with a [`PeriodDither`]), 1/256 ticks.
#[derive(Debug, Default)]
pub struct PeriodTrim(AtomicI32);

impl PeriodTrim {
    /// No trim.
    pub const fn new() -> Self {
        Self(AtomicI32::new(0))
    }

    /// Sets the trim (SYNC0 context).
    pub fn set(&self, trim_q8: i32) {
        self.0.store(trim_q8, Ordering::Relaxed);
    }

    /// The trim (control interrupt).
    pub fn get(&self) -> i32 {
        self.0.load(Ordering::Relaxed)
    }
}

/// Why a lock cannot be made.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PhaseLockError {
    /// A clock, the period or the cycle is zero.
    Zero,
    /// The cycle is no multiple of 1/256 timer tick.
    CycleResolution,
    /// No pattern of at most [`MAX_PATTERN`] cycles is a whole number of PWM periods.
    NoPattern,
}

/// Where the lock stands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LockState {
    /// Pulling in.
    Acquiring,
    /// Within the window.
    Locked,
    /// Lost, or never made in time: the drive cannot follow this SYNC0.
    Lost,
}

/// The phase-lock loop (one per PWM timer).
#[derive(Clone, Copy, Debug)]
pub struct PhaseLock {
    /// Nominal auto-reload.
    nominal_arr: u16,
    /// The nominal PWM period, 1/256 ticks (at most 2 × 65535 × 256 < 2^25).
    period: i32,
    /// The DC cycle modulo the period, 1/256 ticks.
    cycle_mod: i32,
    /// Cycles in the repeating pattern.
    pattern: u32,
    /// The proportional gain 1 / (8 × periods per cycle), × 2^24.
    gain_q24: i32,
    /// The expected phase of the next SYNC0, 1/256 ticks, in `0..period`.
    expected: i32,
    /// The window, 1/256 ticks.
    window: i32,
    /// Integral of the phase error, 1/256 ticks.
    integral: i32,
    /// Largest trim, 1/256 ticks.
    limit: i32,
    state: LockState,
    /// SYNC0 events in a row inside (acquiring) or outside (locked) the window.
    run: u32,
    /// Cycles since the lock started.
    cycles: u32,
    last_error: i32,
    max_error_locked: i32,
    trim: i32,
}

impl PhaseLock {
    /// A lock of a centre-aligned PWM whose nominal auto-reload is `nominal_arr` (period
    /// 2 × ARR ticks) on a timer clocked at `timer_hz`, to DC cycles of `cycle_ns`.
    // Overflow-free for every input: cycle_ns × timer_hz is a product of two u32, so the cycle
    // is below 2^64 / 3,906,250 < 2^43 (1/256 ticks) and 16 × or 256 × it fits an i64; the
    // period is 512..2^25 (a non-zero u16 nominal), gain_den ≥ 8, the rest are constants.
    #[allow(clippy::arithmetic_side_effects)]
    pub fn new(timer_hz: u32, nominal_arr: u16, cycle_ns: u32) -> Result<Self, PhaseLockError> {
        if timer_hz == 0 || nominal_arr == 0 || cycle_ns == 0 {
            return Err(PhaseLockError::Zero);
        }
        // The cycle in 1/256 ticks, exactly: cycle_ns × timer_hz × 256 / 10⁹, the 256 taken
        // out of the 10⁹ first so that the product stays within 64 bits.
        let cycle_ns_hz = u64::from(cycle_ns) * u64::from(timer_hz);
        if cycle_ns_hz % NS_PER_S_Q8 != 0 {
            return Err(PhaseLockError::CycleResolution);
        }
        let cycle = (cycle_ns_hz / NS_PER_S_Q8) as i64;
        let period = 2 * i64::from(nominal_arr) * ONE;
        let pattern = (1..=MAX_PATTERN)
            .find(|&k| (i64::from(k) * cycle) % period == 0)
            .ok_or(PhaseLockError::NoPattern)?;
        let window = (i64::from(LOCK_WINDOW_NS) * i64::from(timer_hz) / NS_PER_S as i64) * ONE;
        let max_trim = (i64::from(nominal_arr) * i64::from(MAX_TRIM_PERMILLE) / 1000).max(1);
        // A trim of d ticks moves the phase by 2·d·(periods per cycle) per cycle; the
        // proportional trim e / (8 · periods per cycle) corrects a quarter of the error e.
        let gain_den = 8 * (cycle * ONE / period).max(1);
        let gain_q24 = ((1i64 << 32) / gain_den).max(1);
        let narrow = |v: i64| i32::try_from(v).map_err(|_| PhaseLockError::NoPattern);
        Ok(Self {
            nominal_arr,
            period: narrow(period)?,
            cycle_mod: narrow(cycle % period)?,
            pattern,
            gain_q24: narrow(gain_q24)?,
            expected: narrow(period / 2)?,
            window: narrow(window)?,
            integral: 0,
            limit: narrow(max_trim * ONE)?,
            state: LockState::Acquiring,
            run: 0,
            cycles: 0,
            last_error: 0,
            max_error_locked: 0,
            trim: 0,
        })
    }

    /// Cycles in the repeating pattern of SYNC0 phases.
    pub fn pattern(&self) -> u32 {
        self.pattern
    }

    /// One SYNC0: `phase_ticks` after the last PWM valley, `cycles` DC cycles after the previous
    /// SYNC0 (1, or more when events were missed). Returns the trim of the auto-reload for the
    /// next periods, 1/256 ticks ([`PeriodDither`] spreads its fraction over the periods).
    ///
    /// Timing: cycle context, at every SYNC0; 32-bit arithmetic (hardware divisions) but for
    /// one 32 × 32 → 64-bit multiplication.
    // Overflow-free: the fields keep the bounds `new` gave them (period 512..2^25, cycle_mod
    // and expected in 0..period, pattern 1..=16, gain_q24 ≤ 2^29, limit < 2^18): k × cycle_mod
    // < 2^29, phase differences stay within ±2^25, and an i32 × gain_q24 fits an i64.
    #[allow(clippy::arithmetic_side_effects)]
    pub fn update(&mut self, phase_ticks: u16, cycles: u32) -> i32 {
        let cycles = cycles.max(1);
        // Advance the expected phase by the cycles passed, exactly: the pattern repeats after
        // `pattern` cycles (k < 16, cycle_mod < 2^25: no overflow).
        let k = (cycles % self.pattern.max(1)) as i32;
        let advance = self.cycle_mod * k;
        // checked_rem_euclid: `rem_euclid`'s zero-divisor check would be a panic path in the
        // cycle interrupt; period ≥ 512 here, so the fallback never applies.
        self.expected = (self.expected + advance)
            .checked_rem_euclid(self.period)
            .unwrap_or(0);
        let measured = i32::from(phase_ticks) << FRAC_BITS;
        // The error, wrapped into (−period/2, period/2]: positive = SYNC0 later in the period
        // than expected = the PWM runs fast.
        let mut error = (measured - self.expected)
            .checked_rem_euclid(self.period)
            .unwrap_or(0);
        if error > self.period / 2 {
            error -= self.period;
        }
        self.last_error = error;
        self.cycles = self.cycles.saturating_add(cycles);
        self.judge(error);
        // A positive error (PWM fast) lengthens the period, by a quarter of the error per cycle
        // (slow enough that SYNC0's jitter moves the PWM by a fraction of itself only).
        // Anti-windup: the integral grows only while the trim it would give is not at its
        // limit (it would otherwise overshoot the phase after a long pull-in).
        let integral = self.integral.saturating_add(error / INTEGRAL_DIVISOR);
        let proportional = |sum: i32| (i64::from(sum) * i64::from(self.gain_q24)) >> 24;
        if proportional(error.saturating_add(integral)).abs() <= i64::from(self.limit) {
            self.integral = integral;
        }
        // max/min: no bound check that could panic (see `next_arr`).
        let trim = proportional(error.saturating_add(self.integral))
            .max(-i64::from(self.limit))
            .min(i64::from(self.limit));
        // Within ±limit, an i32.
        self.trim = trim as i32;
        self.trim
    }

    // Overflow-free: `run` counts to LOCK_COUNT (then starts again) while acquiring and to
    // LOSS_COUNT (then Lost, which counts no more) while locked.
    #[allow(clippy::arithmetic_side_effects)]
    fn judge(&mut self, error: i32) {
        match self.state {
            LockState::Acquiring => {
                let inside = error.abs() <= self.window;
                self.run = if inside { self.run + 1 } else { 0 };
                if self.run >= LOCK_COUNT {
                    self.state = LockState::Locked;
                    self.run = 0;
                    self.max_error_locked = 0;
                } else if self.cycles > ACQUIRE_LIMIT {
                    self.state = LockState::Lost;
                }
            }
            LockState::Locked => {
                let outside = error.abs() > self.window.saturating_mul(LOSS_WINDOW_FACTOR);
                self.run = if outside { self.run + 1 } else { 0 };
                self.max_error_locked = self.max_error_locked.max(error.abs());
                if self.run >= LOSS_COUNT {
                    self.state = LockState::Lost;
                }
            }
            LockState::Lost => {}
        }
    }

    /// The lock state.
    pub fn state(&self) -> LockState {
        self.state
    }

    /// The phase error at the last SYNC0, ns (positive: SYNC0 later than expected).
    pub fn last_error_ns(&self, timer_hz: u32) -> i64 {
        ticks_q8_to_ns(self.last_error, timer_hz)
    }

    /// The largest phase error since the lock was made, ns.
    pub fn max_error_locked_ns(&self, timer_hz: u32) -> i64 {
        ticks_q8_to_ns(self.max_error_locked, timer_hz)
    }

    /// The trim of the auto-reload last returned, 1/256 ticks.
    pub fn trim(&self) -> i32 {
        self.trim
    }

    /// The nominal auto-reload.
    pub fn nominal_arr(&self) -> u16 {
        self.nominal_arr
    }
}

/// What the SYNC0 context does after a SYNC0 ([`Sync0Lock::on_sync0`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sync0Outcome {
    /// The period trim for the control interrupt ([`PeriodTrim::set`]), 1/256 ticks.
    pub trim_q8: i32,
    /// Report the lock lost to the slave (AL status 0x0032).
    pub report_lost: bool,
}

/// The phase lock over the slave's life: made when DC cycles start, made anew when the cycle
/// changes or after a loss was reported, dropped outside SAFEOP/OP of a DC mode.
#[derive(Clone, Copy, Debug)]
pub struct Sync0Lock {
    timer_hz: u32,
    nominal_arr: u16,
    lock: Option<PhaseLock>,
    /// The DC cycle the lock (or the refusal) is for.
    cycle_ns: u32,
    /// Time of the previous SYNC0 in this lock, ns.
    last_ns: Option<u64>,
    /// The cycle cannot be locked to and that was reported.
    refused: bool,
}

impl Sync0Lock {
    /// No lock yet, for a PWM of `nominal_arr` on a timer clocked at `timer_hz`.
    pub const fn new(timer_hz: u32, nominal_arr: u16) -> Self {
        Self {
            timer_hz,
            nominal_arr,
            lock: None,
            cycle_ns: 0,
            last_ns: None,
            refused: false,
        }
    }

    /// A SYNC0 edge at `now_ns`, `phase_ticks` after the last PWM valley. `cycle_ns`: the DC
    /// cycle while the slave runs synchronous cycles (SAFEOP/OP of a DC mode), `None` otherwise.
    pub fn on_sync0(
        &mut self,
        cycle_ns: Option<u32>,
        now_ns: u64,
        phase_ticks: u16,
    ) -> Sync0Outcome {
        let idle = Sync0Outcome {
            trim_q8: 0,
            report_lost: false,
        };
        let Some(cycle_ns) = cycle_ns.and_then(NonZeroU32::new) else {
            self.lock = None;
            self.refused = false;
            self.last_ns = None;
            return idle;
        };
        if cycle_ns.get() != self.cycle_ns {
            self.cycle_ns = cycle_ns.get();
            self.lock = None;
            self.refused = false;
        }
        if self.lock.is_none() {
            if self.refused {
                return idle;
            }
            match PhaseLock::new(self.timer_hz, self.nominal_arr, cycle_ns.get()) {
                Ok(lock) => {
                    self.lock = Some(lock);
                    self.last_ns = None;
                }
                Err(_) => {
                    // Reported once for this cycle; the nominal PWM runs on unlocked.
                    self.refused = true;
                    return Sync0Outcome {
                        trim_q8: 0,
                        report_lost: true,
                    };
                }
            }
        }
        // The cycles since the previous SYNC0, rounded (missed events count).
        let cycles = self.last_ns.map_or(1, |last| {
            let elapsed = now_ns.saturating_sub(last);
            // Rounded; in 32 bits (a hardware division) unless SYNC0 was away for seconds.
            match u32::try_from(elapsed)
                .ok()
                .and_then(|e| e.checked_add(cycle_ns.get() / 2))
            {
                Some(e) => e / cycle_ns,
                None => {
                    let cycle = NonZeroU64::from(cycle_ns);
                    u32::try_from(elapsed.saturating_add(cycle.get() / 2) / cycle)
                        .unwrap_or(u32::MAX)
                }
            }
        });
        self.last_ns = Some(now_ns);
        let Some(lock) = self.lock.as_mut() else {
            return idle;
        };
        let trim_q8 = lock.update(phase_ticks, cycles);
        if lock.state() == LockState::Lost {
            // Reported once; the next SYNC0 starts a new acquisition.
            self.lock = None;
            return Sync0Outcome {
                trim_q8: 0,
                report_lost: true,
            };
        }
        Sync0Outcome {
            trim_q8,
            report_lost: false,
        }
    }

    /// The lock in use, if any.
    pub fn lock(&self) -> Option<&PhaseLock> {
        self.lock.as_ref()
    }
}

/// `ticks_q8` (1/256 ticks) of a timer at `timer_hz` in ns (0 without a clock).
fn ticks_q8_to_ns(ticks_q8: i32, timer_hz: u32) -> i64 {
    // An i32 × 10⁹ < 2^61: the product never fails.
    i64::from(ticks_q8)
        .checked_mul(NS_PER_S as i64)
        .and_then(|scaled| (scaled / ONE).checked_div(i64::from(timer_hz)))
        .unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    const TIMER_HZ: u32 = 170_000_000;
    /// 40 kHz.
    const ARR: u16 = 2125;

    /// A PWM timer whose clock is off by `ppm` against the ESC's, with SYNC0 every `cycle_ns`
    /// of the ESC's clock, starting at phase `start` ticks; jitter of ±`jitter` ticks.
    struct Bench {
        lock: PhaseLock,
        /// PWM time of the next valley and the present ARR, in PWM ticks (f64).
        next_valley: f64,
        last_valley: f64,
        dither: PeriodDither,
        trim: i32,
        tick_scale: f64,
        cycle_ticks: f64,
        sync0: f64,
        jitter: f64,
        seed: u64,
    }

    impl Bench {
        fn new(cycle_ns: u32, ppm: f64, start: f64, jitter: f64) -> Self {
            let lock = PhaseLock::new(TIMER_HZ, ARR, cycle_ns).unwrap();
            Self {
                lock,
                last_valley: 0.0,
                next_valley: 2.0 * f64::from(ARR),
                dither: PeriodDither::new(ARR),
                trim: 0,
                tick_scale: 1.0 + ppm * 1e-6,
                cycle_ticks: f64::from(cycle_ns) * 1e-9 * f64::from(TIMER_HZ),
                sync0: start,
                jitter,
                seed: 0x1234_5678,
            }
        }

        fn noise(&mut self) -> f64 {
            self.seed = self
                .seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((self.seed >> 33) as f64 / (1u64 << 31) as f64 - 0.5) * 2.0 * self.jitter
        }

        /// The next SYNC0 (after `skip` missed ones): the capture, then the lock's new trim,
        /// which each following period's ARR takes (the control interrupt writes the ARR of
        /// the period after the present one).
        fn step(&mut self, skip: u32) -> i64 {
            self.sync0 += self.cycle_ticks * f64::from(skip + 1);
            let at = (self.sync0 + self.noise()) * self.tick_scale;
            while self.next_valley <= at {
                self.last_valley = self.next_valley;
                let arr = self.dither.next_arr(self.trim);
                self.next_valley += 2.0 * f64::from(arr);
            }
            let phase = (at - self.last_valley).floor() as u16;
            self.trim = self.lock.update(phase, skip + 1);
            self.lock.last_error_ns(TIMER_HZ)
        }
    }

    #[test]
    fn the_dither_averages_the_trim_exactly() {
        let mut d = PeriodDither::new(ARR);
        // +0.3 ticks per period: 256 periods gain exactly 76.8 × ... = 0.3 × 256 ticks.
        let sum: u64 = (0..256).map(|_| u64::from(d.next_arr(77))).sum();
        assert_eq!(sum, 256 * u64::from(ARR) + 77);
        // Every period is within one tick of the target.
        for _ in 0..100 {
            let arr = d.next_arr(-3 * 256 - 128);
            assert!(arr == ARR - 4 || arr == ARR - 3, "{arr}");
        }
        // Clamped to half the nominal value.
        assert_eq!(PeriodDither::new(ARR).next_arr(i32::MAX), ARR + ARR / 2);
        assert_eq!(PeriodDither::new(u16::MAX).next_arr(i32::MAX), u16::MAX);
        let trim = PeriodTrim::new();
        trim.set(-5);
        assert_eq!(trim.get(), -5);
    }

    #[test]
    fn cycles_find_their_pattern_or_are_refused() {
        let pattern = |ns| PhaseLock::new(TIMER_HZ, ARR, ns).map(|l| l.pattern());
        assert_eq!(pattern(1_000_000), Ok(1)); // 40 periods
        assert_eq!(pattern(31_250), Ok(4)); // 4 cycles = 5 periods
        assert_eq!(pattern(62_500), Ok(2)); // 2 cycles = 5 periods
        assert_eq!(pattern(125_000), Ok(1));
        assert_eq!(pattern(10_000_000), Ok(1));
        // 33 µs = 5610 ticks: 1.32 periods, 25 cycles for a whole number of them.
        assert_eq!(pattern(33_000), Err(PhaseLockError::NoPattern));
        assert_eq!(
            PhaseLock::new(0, ARR, 1_000).err(),
            Some(PhaseLockError::Zero)
        );
        assert_eq!(
            PhaseLock::new(TIMER_HZ, 0, 1_000).err(),
            Some(PhaseLockError::Zero)
        );
        assert_eq!(
            PhaseLock::new(TIMER_HZ, ARR, 0).err(),
            Some(PhaseLockError::Zero)
        );
        // 1 ns at 3 Hz is 3e-9 ticks: not representable.
        assert_eq!(
            PhaseLock::new(3, 1, 1).err(),
            Some(PhaseLockError::CycleResolution)
        );
        // Long cycles are computed exactly (cycle × clock × 256 exceeds 64 bits): 1 s and 4 s
        // are 40,000 and 160,000 periods.
        assert_eq!(pattern(1_000_000_000), Ok(1));
        assert_eq!(pattern(4_000_000_000), Ok(1));
        assert_eq!(
            PhaseLock::new(TIMER_HZ, ARR, u32::MAX).err(),
            Some(PhaseLockError::CycleResolution)
        );
    }

    #[test]
    fn the_lock_pulls_in_and_holds_against_clock_offset_and_jitter() {
        // Jitter of SYNC0 against the PWM clock: none, and ±100 ns (17 ticks; an ET1100's
        // SYNC0 output is specified far tighter, this covers the capture path too).
        for (jitter, bound_ns) in [(0.0, 20), (17.0, 250)] {
            pulls_in_and_holds(jitter, bound_ns);
        }
    }

    fn pulls_in_and_holds(jitter: f64, bound_ns: i64) {
        for cycle_ns in [31_250, 62_500, 125_000, 1_000_000, 10_000_000] {
            for ppm in [-100.0, 0.0, 100.0] {
                for start in [0.0, 1_000.0, 2_125.0, 4_000.0] {
                    let mut bench = Bench::new(cycle_ns, ppm, start, jitter);
                    let mut locked_at = None;
                    // The error held once settled: over the second half of the run.
                    let mut held = 0;
                    for i in 0..ACQUIRE_LIMIT {
                        let error = bench.step(0);
                        if locked_at.is_none() && bench.lock.state() == LockState::Locked {
                            locked_at = Some(i);
                        }
                        if i >= ACQUIRE_LIMIT / 2 {
                            held = held.max(error.abs());
                        }
                    }
                    let case = format!("{cycle_ns} ns, {ppm} ppm, start {start}, jitter {jitter}");
                    let locked_at = locked_at.unwrap_or_else(|| panic!("no lock: {case}"));
                    assert!(locked_at < 200, "{case}: locked at {locked_at}");
                    assert_eq!(bench.lock.state(), LockState::Locked, "{case}");
                    // The held error: the jitter plus the trim's quantisation.
                    assert!(held <= bound_ns, "{case}: {held} ns");
                    let since_lock = bench.lock.max_error_locked_ns(TIMER_HZ);
                    assert!(
                        since_lock <= 2 * i64::from(LOCK_WINDOW_NS),
                        "{case}: {since_lock} ns"
                    );
                    assert!(bench.lock.trim().unsigned_abs() <= 21 * 256, "{case}");
                }
            }
        }
    }

    #[test]
    fn missed_sync0_events_keep_the_pattern() {
        let mut bench = Bench::new(31_250, 50.0, 500.0, 0.0);
        for _ in 0..300 {
            bench.step(0);
        }
        assert_eq!(bench.lock.state(), LockState::Locked);
        // One, two and three events missed: the expected phase advances by as many cycles.
        for skip in [1, 2, 3, 0, 0] {
            let error = bench.step(skip);
            assert!(error.abs() <= 100, "skip {skip}: {error} ns");
        }
        assert_eq!(bench.lock.state(), LockState::Locked);
    }

    #[test]
    fn a_sync0_at_another_period_loses_the_lock() {
        let mut bench = Bench::new(1_000_000, 0.0, 0.0, 0.0);
        for _ in 0..100 {
            bench.step(0);
        }
        assert_eq!(bench.lock.state(), LockState::Locked);
        // The master's SYNC0 moves to 1.03 ms: beyond the ±1 % trim.
        bench.cycle_ticks *= 1.03;
        let mut lost_after = None;
        for i in 0..50 {
            bench.step(0);
            if bench.lock.state() == LockState::Lost {
                lost_after = Some(i);
                break;
            }
        }
        let lost_after = lost_after.expect("lost");
        assert!(lost_after < 20, "{lost_after}");
        // Lost stays lost (a new lock is a new `PhaseLock`, at the next SAFEOP).
        bench.cycle_ticks /= 1.03;
        for _ in 0..100 {
            bench.step(0);
        }
        assert_eq!(bench.lock.state(), LockState::Lost);
    }

    #[test]
    fn the_sync0_lock_follows_the_slave_and_reports_a_loss_once() {
        const CYCLE: u32 = 1_000_000;
        let mut s = Sync0Lock::new(TIMER_HZ, ARR);
        // Not synchronous: no lock, no trim.
        let idle = Sync0Outcome {
            trim_q8: 0,
            report_lost: false,
        };
        assert_eq!(s.on_sync0(None, 0, 17), idle);
        assert!(s.lock().is_none());
        // DC cycles: SYNC0 always at the target phase (the middle of the period).
        let mut t = 0;
        for _ in 0..20 {
            t += u64::from(CYCLE);
            let out = s.on_sync0(Some(CYCLE), t, ARR);
            assert!(!out.report_lost);
        }
        assert_eq!(s.lock().map(PhaseLock::state), Some(LockState::Locked));
        // A missed SYNC0 is one more cycle, not a phase jump (1 ms = 40 whole periods).
        t += 2 * u64::from(CYCLE);
        assert!(!s.on_sync0(Some(CYCLE), t, ARR).report_lost);
        assert_eq!(s.lock().map(|l| l.last_error_ns(TIMER_HZ)), Some(0));
        // SYNC0 jumps by a quarter period for good: lost after LOSS_COUNT, reported once.
        let mut reports = 0;
        for _ in 0..LOSS_COUNT + 2 {
            t += u64::from(CYCLE);
            reports += u32::from(s.on_sync0(Some(CYCLE), t, ARR / 2).report_lost);
        }
        assert_eq!(reports, 1);
        // A cycle without a pattern is refused, reported once, and runs unlocked.
        let outs: [Sync0Outcome; 3] =
            core::array::from_fn(|i| s.on_sync0(Some(33_000), t + i as u64, 0));
        assert_eq!(outs.map(|o| o.report_lost), [true, false, false]);
        assert_eq!(outs.map(|o| o.trim_q8), [0; 3]);
        // Back out of the synchronous states: dropped.
        s.on_sync0(None, t, 0);
        assert!(s.lock().is_none());
        // A clock that jumps to the end of its range: as many cycles as a u32 counts (no
        // overflow), far past the acquisition limit.
        s.on_sync0(Some(CYCLE), 0, ARR);
        assert!(s.on_sync0(Some(CYCLE), u64::MAX, ARR).report_lost);
    }

    #[test]
    fn no_lock_within_the_limit_is_lost() {
        // SYNC0 phases all over the place (a free-running clock far off): never locked.
        let mut lock = PhaseLock::new(TIMER_HZ, ARR, 1_000_000).unwrap();
        let mut phase = 0u16;
        for _ in 0..=ACQUIRE_LIMIT {
            phase = (phase + 1_700) % 4_250;
            lock.update(phase, 1);
        }
        assert_eq!(lock.state(), LockState::Lost);
    }
}
