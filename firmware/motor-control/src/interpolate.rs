//! Set-points between SYNC0 events, at the control-loop rate.
//!
//! The master sends one set-point per bus cycle T; the SYNC0 handler hands it over (see
//! [`handoff`](super::handoff)) and the control interrupt [`push`](Interpolator::push_position)es
//! it before its next [`tick`](Interpolator::tick). Between set-points the interpolator runs
//! by time, not by counting ticks: T·f_loop may be non-integer (62.5 µs at 40 kHz = 2.5 ticks),
//! so the ticks of a cycle vary.
//!
//! # Latency
//! Like every CSP drive, the output lags the set-point stream by one bus cycle: during the
//! cycle after target k arrives the position moves from target k−1 to target k, so a target
//! is reached when the next one arrives. The output at time t is the master's trajectory at
//! t − T.
//!
//! # Time keeping
//! The phase, the time since the start of the current segment, is an integer in units of
//! 2^-20 tick ([`TICK_UNITS`]); a segment lasts `cycle_units` = round(T·f_loop·2^20). When a
//! set-point arrives the phase goes back by one cycle, so a segment starts at the time its
//! SYNC0 event happened even if the set-point is seen a tick later; exact for ratios that are
//! a multiple of 2^-20 tick, no rounding accumulates. The result is kept within
//! [0, 1 tick]: this absorbs the jitter of when the handler completes and any drift between the
//! PWM clock and the DC clock (bounded phase error, at most one tick). A set-point more than a
//! tick early or late re-anchors: a new segment starts from the current output.
//!
//! # CSP (cyclic synchronous position)
//! Cubic Hermite interpolation from the previous target to the newest one. The start velocity
//! is the end velocity of the previous segment (the velocity is continuous at the cycle
//! boundaries); the end velocity is the velocity offset 60B1h when the master sends one, else
//! the second-order backward difference of the last three targets,
//! `(3·p[k] − 4·p[k−1] + p[k−2]) / 2T`, exact for a constant acceleration; so a parabolic stream
//! is reproduced exactly. (While only two targets of a stream are known, the secant.)
//!
//! The first set-point after [`reset`](Interpolator::reset) (and one after a hold) starts a
//! segment from the current output at rest to the target at rest; the stream's velocity is
//! picked up over the next two cycles (start-up transient). Velocity and acceleration feed-forward are the polynomial's
//! derivatives.
//!
//! Positions: the polynomial is evaluated every tick as an `f32` offset from the segment's
//! `i64` start (never accumulated), so there is no drift and the resolution depends only on
//! the distance moved in one cycle (2^-24 of it: 0.1 increment at 1.7·10^6 increments per
//! cycle), however far the axis has travelled. This replaces the fixed-point accumulator
//! (e.g. `I48F16`) an incremental interpolator would need.
//!
//! # CSV / CST
//! Linear interpolation from the previous set-point to the newest one (velocity: the slope is
//! the acceleration feed-forward; torque: a ramp instead of a step keeps the torque reference
//! free of bus-cycle steps), with the same one-cycle latency.
//!
//! # Missed set-points
//! When no set-point arrives at the end of a segment, CSP extrapolates at the end velocity for
//! one more cycle, then holds the position (velocity and acceleration 0); CSV and CST hold the
//! last set-point. The SYNC supervision of the slave counts the missed cycles and raises the
//! error; the interpolator only has to stay sensible meanwhile. When set-points resume the
//! interpolator re-anchors at its current output.

use super::position::saturating_to_f32;
use super::velocity::floor_i32;

/// Phase units per control tick.
pub const TICK_UNITS: i32 = 1 << TICK_UNIT_BITS;
/// log2 of [`TICK_UNITS`].
const TICK_UNIT_BITS: i32 = 20;
/// The most control ticks per bus cycle accepted (the phase must hold two cycles and a tick in
/// an `i32`).
pub const MAX_TICKS_PER_CYCLE: i32 = 1_000;

/// Why an interpolator could not be configured.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum InterpolateError {
    /// The cycle time or the loop rate is not a positive finite number.
    InvalidTiming,
    /// The bus cycle is shorter than one control tick.
    CycleShorterThanTick,
    /// The bus cycle is longer than [`MAX_TICKS_PER_CYCLE`] ticks.
    CycleTooLong,
}

/// The set-points for one control tick.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Interpolated {
    /// Position reference (increments); CSP, else the last CSP/reset position.
    pub position: i64,
    /// Velocity reference or feed-forward (increments/s); CSP and CSV, 0 in CST.
    pub velocity: f32,
    /// Acceleration feed-forward (increments/s²); CSP and CSV, 0 in CST.
    pub acceleration: f32,
    /// Torque reference (N·m); CST, 0 otherwise.
    pub torque: f32,
}

/// Which kind of set-point is being interpolated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum InterpolationMode {
    /// Nothing yet since the last reset: the output holds.
    Hold,
    /// Cyclic synchronous position.
    Position,
    /// Cyclic synchronous velocity.
    Velocity,
    /// Cyclic synchronous torque.
    Torque,
}

/// The interpolator's configuration and state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interpolator {
    cycle_units: i32,
    inv_cycle_units: f32,
    cycle_s: f32,
    inv_cycle_s: f32,
    inv_cycle_s2: f32,
    /// Time since the start of the segment, in [`TICK_UNITS`] per tick.
    phase: i32,
    /// Where the phase stops growing: in the hold region.
    phase_cap: i32,
    mode: InterpolationMode,

    // CSP segment: offset(s) = ((c3·s + c2)·s + c1)·s + c0 increments from `anchor`, s ∈ [0, 1].
    anchor: i64,
    c: [f32; 4],
    /// velocity(s) = (v2·s + v1)·s + v0.
    v: [f32; 3],
    /// acceleration(s) = a1·s + a0.
    a: [f32; 2],
    /// Offset of the segment's end (the newest target) from `anchor`.
    end_offset: f32,
    /// End slope, increments per cycle (m1 = v_end·T).
    end_slope: f32,
    /// End velocity, increments/s.
    end_velocity: f32,
    /// The newest target.
    target: i64,
    /// The newest target minus the one before (increments, for the backward difference).
    last_step: f32,
    /// Whether `last_step` is a step between two targets of the stream (not a re-anchor).
    step_known: bool,

    // CSV/CST: value(s) = start + delta·s.
    lin_start: f32,
    lin_delta: f32,
    lin_slope: f32,
    lin_target: f32,

    out: Interpolated,
    out_whole: i64,
    out_fraction: f32,
}

/// `x` if finite, else 0.
/// `a · b` in [`TICK_UNITS`] (a, b positive and finite) rounded to the nearest (halves up),
/// computed exactly: each f32 is an integer mantissa below 2^24 times a power of two, so the
/// product is an integer below 2^48 times a power of two. (A double product would be exact
/// too, but on a single-precision FPU it links the soft-float library.) `None` if the result
/// exceeds the i32 range or an argument is not positive and finite.
fn product_in_tick_units(a: f32, b: f32) -> Option<i32> {
    let (ma, ea) = mantissa_exponent(a)?;
    let (mb, eb) = mantissa_exponent(b)?;
    // Both mantissas < 2^24: the product < 2^48, no overflow.
    let product = ma.checked_mul(mb)?;
    let shift = ea.checked_add(eb)?.checked_add(TICK_UNIT_BITS)?;
    let scaled = if shift >= 0 {
        // `checked_shl` checks the shift amount only, not the bits shifted out.
        let left = u32::try_from(shift).ok()?;
        if left > product.leading_zeros() {
            return None;
        }
        product << left
    } else {
        // Right by −shift with halves rounded up; beyond 63 bits the result is 0.
        let right = shift.unsigned_abs();
        let half = 1u64.checked_shl(right.checked_sub(1)?).unwrap_or(0);
        product.checked_add(half)?.checked_shr(right).unwrap_or(0)
    };
    i32::try_from(scaled).ok()
}

/// A positive finite `x` as `mantissa · 2^exponent` with an integer mantissa below 2^24
/// (IEEE 754 binary32: implicit leading one for normal numbers, exponent bias 127 plus the 23
/// fraction bits); `None` for zero, negative, infinite and NaN values.
fn mantissa_exponent(x: f32) -> Option<(u64, i32)> {
    const FRACTION_BITS: u32 = 23;
    const EXPONENT_MASK: u32 = 0xFF;
    // Bias 127 plus the fraction's 23 bits.
    const EXPONENT_OFFSET: i32 = 150;
    if !(x > 0.0 && x < f32::INFINITY) {
        return None;
    }
    let bits = x.to_bits();
    let fraction = bits & ((1 << FRACTION_BITS) - 1);
    let biased = (bits >> FRACTION_BITS) & EXPONENT_MASK;
    let (mantissa, biased) = if biased == 0 {
        // Subnormal: no implicit one, the exponent of the smallest normal.
        (fraction, 1)
    } else {
        (fraction | (1 << FRACTION_BITS), biased)
    };
    // biased ≤ 254: the difference fits.
    Some((
        u64::from(mantissa),
        (biased as i32).wrapping_sub(EXPONENT_OFFSET),
    ))
}

fn finite_or_zero(x: f32) -> f32 {
    if x.is_finite() {
        x
    } else {
        0.0
    }
}

impl Interpolator {
    /// An interpolator for set-points every `cycle_s` seconds and ticks at `loop_hz`, holding
    /// position 0.
    // Overflow-free: cycle_units ≤ MAX_TICKS_PER_CYCLE · TICK_UNITS ≈ 2^30 (checked first), so
    // phase_cap = 2 · cycle_units + TICK_UNITS < 2^31 − TICK_UNITS.
    #[allow(clippy::arithmetic_side_effects)]
    pub fn new(cycle_s: f32, loop_hz: f32) -> Result<Self, InterpolateError> {
        if !(cycle_s.is_finite() && cycle_s > 0.0 && loop_hz.is_finite() && loop_hz > 0.0) {
            return Err(InterpolateError::InvalidTiming);
        }
        // Exact, then judged in whole tick units: a cycle given in ns converts to seconds with
        // a rounding error (31 250 ns is 3.1249998e-5 s in f32), and the rounded product of a
        // 31.25 µs cycle and a 32 kHz loop is 0.99999994 tick, which must count as the one tick
        // it is.
        let cycle_units =
            product_in_tick_units(cycle_s, loop_hz).ok_or(InterpolateError::CycleTooLong)?;
        if cycle_units < TICK_UNITS {
            return Err(InterpolateError::CycleShorterThanTick);
        }
        if cycle_units > MAX_TICKS_PER_CYCLE * TICK_UNITS {
            return Err(InterpolateError::CycleTooLong);
        }
        let inv = 1.0 / cycle_s;
        let mut interpolator = Self {
            cycle_units,
            inv_cycle_units: 1.0 / cycle_units as f32,
            cycle_s,
            inv_cycle_s: inv,
            inv_cycle_s2: inv * inv,
            phase: 0,
            phase_cap: 2 * cycle_units + TICK_UNITS,
            mode: InterpolationMode::Hold,
            anchor: 0,
            c: [0.0; 4],
            v: [0.0; 3],
            a: [0.0; 2],
            end_offset: 0.0,
            end_slope: 0.0,
            end_velocity: 0.0,
            target: 0,
            last_step: 0.0,
            step_known: false,
            lin_start: 0.0,
            lin_delta: 0.0,
            lin_slope: 0.0,
            lin_target: 0.0,
            out: Interpolated::default(),
            out_whole: 0,
            out_fraction: 0.0,
        };
        interpolator.reset(0);
        Ok(interpolator)
    }

    /// The bus cycle, s.
    pub fn cycle_s(&self) -> f32 {
        self.cycle_s
    }

    /// Control ticks per bus cycle (may be non-integer).
    pub fn ticks_per_cycle(&self) -> f32 {
        self.cycle_units as f32 * (1.0 / TICK_UNITS as f32)
    }

    /// The mode of the last set-point.
    pub fn mode(&self) -> InterpolationMode {
        self.mode
    }

    /// Holds `position` at rest and forgets the set-point history: call it when a cyclic mode
    /// is entered (with the actual position) so the first set-point starts from there.
    pub fn reset(&mut self, position: i64) {
        self.mode = InterpolationMode::Hold;
        self.phase = self.phase_cap;
        self.anchor = position;
        self.c = [0.0; 4];
        self.v = [0.0; 3];
        self.a = [0.0; 2];
        self.end_offset = 0.0;
        self.end_slope = 0.0;
        self.end_velocity = 0.0;
        self.target = position;
        self.last_step = 0.0;
        self.step_known = false;
        self.lin_start = 0.0;
        self.lin_delta = 0.0;
        self.lin_slope = 0.0;
        self.lin_target = 0.0;
        self.out = Interpolated {
            position,
            ..Interpolated::default()
        };
        self.out_whole = position;
        self.out_fraction = 0.0;
    }

    /// [`Self::reset`] at `position` for a motor moving at `velocity` (increments/s): the next
    /// position set-point starts a segment with that slope and ends it on the secant, so a
    /// position stream that takes over a moving motor (a change into CSP) does not stop it
    /// first.
    pub fn reset_moving(&mut self, position: i64, velocity: f32) {
        self.reset(position);
        if velocity.is_finite() {
            self.out.velocity = velocity;
        }
    }

    /// Starts the next segment's time base if a set-point of `mode` arrives about one cycle
    /// after the previous one (true); else (first set-point, other mode, more than a tick
    /// early or late) restarts the time base for a re-anchored segment (false).
    ///
    /// Timing: about 10 instructions.
    #[inline]
    // Overflow-free: 0 ≤ phase ≤ phase_cap and 0 < cycle_units (see `new`).
    #[allow(clippy::arithmetic_side_effects)]
    fn next_segment(&mut self, mode: InterpolationMode) -> bool {
        let new_phase = self.phase - self.cycle_units;
        let continuous = self.mode == mode && (-TICK_UNITS..=2 * TICK_UNITS).contains(&new_phase);
        self.phase = if continuous {
            min_i32(new_phase, TICK_UNITS).max(0)
        } else {
            0
        };
        self.mode = mode;
        continuous
    }

    /// A new CSP target (increments) with the master's velocity offset 60B1h (increments/s) if
    /// it sends one: used as the end velocity instead of the backward difference.
    ///
    /// Timing: about 60 instructions on a Cortex-M4F (once per bus cycle, not per tick).
    pub fn push_position(&mut self, target: i64, velocity_offset: Option<f32>) {
        let continuous = self.next_segment(InterpolationMode::Position);
        let t = self.cycle_s;
        let (step, start_slope, end_guess) = if continuous {
            // From the previous target with the previous end slope (C¹ at the boundary).
            self.anchor = self.target;
            self.c[0] = 0.0;
            let step = saturating_to_f32(target.wrapping_sub(self.target));
            let guess = if self.step_known {
                // Second-order backward difference, exact for a constant acceleration.
                1.5 * step - 0.5 * self.last_step
            } else {
                // Only one step of the stream known: the secant.
                step
            };
            self.step_known = true;
            (step, self.end_slope, guess)
        } else {
            // From the current output. Moving (a set-point more than a tick early or late): end
            // on the secant. At rest (after a reset or a hold): end at rest, so that a stream
            // that resumes far away is caught up with one S-shaped move, never backwards.
            self.anchor = self.out_whole;
            self.c[0] = self.out_fraction;
            let step = saturating_to_f32(target.wrapping_sub(self.out_whole)) - self.out_fraction;
            let moving = self.out.velocity != 0.0;
            self.step_known = false;
            (step, self.out.velocity * t, if moving { step } else { 0.0 })
        };
        let end_slope = match velocity_offset {
            Some(v) if v.is_finite() => v * t,
            _ => end_guess,
        };
        let (d, m0, m1) = (step, start_slope, end_slope);
        let c2 = 3.0 * d - 2.0 * m0 - m1;
        let c3 = m0 + m1 - 2.0 * d;
        self.c[1] = m0;
        self.c[2] = c2;
        self.c[3] = c3;
        self.v = [
            m0 * self.inv_cycle_s,
            2.0 * c2 * self.inv_cycle_s,
            3.0 * c3 * self.inv_cycle_s,
        ];
        self.a = [2.0 * c2 * self.inv_cycle_s2, 6.0 * c3 * self.inv_cycle_s2];
        self.end_offset = self.c[0] + d;
        self.end_slope = m1;
        self.end_velocity = m1 * self.inv_cycle_s;
        self.last_step = step;
        self.target = target;
        self.out.torque = 0.0;
    }

    /// A new CSV velocity set-point (increments/s; NaN or infinite → 0).
    ///
    /// Timing: about 20 instructions.
    pub fn push_velocity(&mut self, velocity: f32) {
        let start = self.out.velocity;
        self.push_linear(InterpolationMode::Velocity, velocity, start);
        self.out.torque = 0.0;
    }

    /// A new CST torque set-point (N·m; NaN or infinite → 0).
    ///
    /// Timing: about 20 instructions.
    pub fn push_torque(&mut self, torque: f32) {
        let start = self.out.torque;
        self.push_linear(InterpolationMode::Torque, torque, start);
        self.out.velocity = 0.0;
        self.out.acceleration = 0.0;
    }

    fn push_linear(&mut self, mode: InterpolationMode, value: f32, current: f32) {
        let value = finite_or_zero(value);
        let continuous = self.next_segment(mode);
        self.lin_start = if continuous { self.lin_target } else { current };
        self.lin_delta = value - self.lin_start;
        self.lin_slope = self.lin_delta * self.inv_cycle_s;
        self.lin_target = value;
    }

    /// The set-points for this control tick; advances the time by one tick.
    ///
    /// Timing: about 60 instructions on a Cortex-M4F in CSP (measured: 98 in the whole function,
    /// of which the CSP in-segment path runs about 60: phase to s 3, region select 6, three
    /// Horner polynomials 9, floor and i64 add 12, rounding 6, stores and the copy-out 20, phase
    /// update 5), about 35 in CSV/CST. No library calls.
    #[inline]
    // Overflow-free: phase ≤ phase_cap, and phase_cap + TICK_UNITS fits an i32 (see `new`).
    #[allow(clippy::arithmetic_side_effects)]
    pub fn tick(&mut self) -> Interpolated {
        let phase = self.phase;
        let s = phase as f32 * self.inv_cycle_units;
        let inside = phase < self.cycle_units;
        match self.mode {
            InterpolationMode::Hold => {}
            InterpolationMode::Position => {
                let (offset, velocity, acceleration) = if inside {
                    let [c0, c1, c2, c3] = self.c;
                    let [v0, v1, v2] = self.v;
                    let [a0, a1] = self.a;
                    (
                        ((c3 * s + c2) * s + c1) * s + c0,
                        (v2 * s + v1) * s + v0,
                        a1 * s + a0,
                    )
                } else if phase <= 2 * self.cycle_units {
                    // Missed set-point: one cycle at the end velocity.
                    (
                        self.end_offset + self.end_slope * (s - 1.0),
                        self.end_velocity,
                        0.0,
                    )
                } else {
                    (self.end_offset + self.end_slope, 0.0, 0.0)
                };
                let whole = floor_i32(offset);
                self.out_whole = self.anchor.wrapping_add(whole as i64);
                self.out_fraction = offset - whole as f32;
                self.out.position = self
                    .out_whole
                    .wrapping_add((self.out_fraction >= 0.5) as i64);
                self.out.velocity = velocity;
                self.out.acceleration = acceleration;
            }
            InterpolationMode::Velocity | InterpolationMode::Torque => {
                let (value, slope) = if inside {
                    (self.lin_start + self.lin_delta * s, self.lin_slope)
                } else {
                    (self.lin_target, 0.0)
                };
                if self.mode == InterpolationMode::Velocity {
                    self.out.velocity = value;
                    self.out.acceleration = slope;
                } else {
                    self.out.torque = value;
                }
            }
        }
        // Saturates in the hold region; phase_cap + TICK_UNITS fits an i32.
        self.phase = min_i32(phase + TICK_UNITS, self.phase_cap);
        self.out
    }

    /// The last CSP output position with its fraction: whole increments and `[0, 1)`.
    pub fn position_fine(&self) -> (i64, f32) {
        (self.out_whole, self.out_fraction)
    }
}

/// The smaller of two `i32` (no `Ord::min` panic path concerns, plain compare-select).
#[inline]
fn min_i32(a: i32, b: i32) -> i32 {
    if a < b {
        a
    } else {
        b
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;

    /// The segment length in tick units is the exact product cycle · f_loop · 2^20, rounded to
    /// the nearest (halves up): against the host's double product (exact for two f32), over
    /// the bus cycles and loop rates drives run and pseudo-random pairs across the range.
    #[test]
    fn the_segment_length_is_the_exact_product_rounded() {
        let reference = |a: f32, b: f32| {
            let exact = f64::from(a) * f64::from(b) * f64::from(TICK_UNITS);
            (exact + 0.5).floor()
        };
        let mut pairs = std::vec::Vec::new();
        for cycle in [
            31.25e-6f32,
            62.5e-6,
            125e-6,
            250e-6,
            1e-3,
            2e-3,
            4e-3,
            10e-3,
        ] {
            for hz in [8_000.0f32, 10_000.0, 16_000.0, 20_000.0, 40_000.0] {
                pairs.push((cycle, hz));
            }
        }
        let mut seed = 0x9E37_79B9_7F4A_7C15u64;
        for _ in 0..20_000 {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            let cycle = f32::from_bits(0x3800_0000 + (seed as u32 % 0x0200_0000));
            let hz = f32::from_bits(0x4500_0000 + ((seed >> 32) as u32 % 0x0180_0000));
            pairs.push((cycle, hz));
        }
        let mut checked = 0;
        for (cycle, hz) in pairs {
            let Ok(ip) = Interpolator::new(cycle, hz) else {
                continue;
            };
            assert_eq!(
                f64::from(ip.cycle_units),
                reference(cycle, hz),
                "{cycle:e} s at {hz} Hz"
            );
            checked += 1;
        }
        assert!(checked > 5_000, "{checked}");
        // Halves round up; zero, negatives, infinities and NaN have no product.
        assert_eq!(product_in_tick_units(0.5, 2.0f32.powi(-20)), Some(1));
        assert_eq!(product_in_tick_units(0.25, 2.0f32.powi(-20)), Some(0));
        assert_eq!(product_in_tick_units(0.75, 2.0f32.powi(-20)), Some(1));
        assert_eq!(product_in_tick_units(2048.0, 1.0), None);
        for bad in [0.0, -1.0, f32::INFINITY, f32::NAN] {
            assert_eq!(product_in_tick_units(bad, 1.0), None);
            assert_eq!(product_in_tick_units(1.0, bad), None);
        }
        assert_eq!(product_in_tick_units(f32::from_bits(1), 1.0), Some(0));
    }
    use std::vec::Vec;

    /// One run: SYNC0 events at k·T deliver `target(k)` (unless `delivered(k)` is false), the
    /// control ticks at n/f_loop; ticks per cycle = p/q exactly (so the test decides "has SYNC0
    /// k happened by tick n" as k·p ≤ n·q in integers). Returns, per tick, the time in bus
    /// cycles and the output.
    struct Run {
        cycle_s: f32,
        loop_hz: f32,
        ratio: (u64, u64),
        cycles: u64,
    }

    impl Run {
        fn go(
            &self,
            start: i64,
            mut push: impl FnMut(&mut Interpolator, u64),
            delivered: impl Fn(u64) -> bool,
        ) -> Vec<(f64, Interpolated, (i64, f32))> {
            let mut ip = Interpolator::new(self.cycle_s, self.loop_hz).unwrap();
            ip.reset(start);
            let (p, q) = self.ratio;
            let mut next = 0u64;
            let mut out = Vec::new();
            let ticks = self.cycles * p / q;
            for n in 0..ticks {
                while next * p <= n * q {
                    if delivered(next) {
                        push(&mut ip, next);
                    }
                    next += 1;
                }
                let o = ip.tick();
                out.push((n as f64 * q as f64 / p as f64, o, ip.position_fine()));
            }
            out
        }
    }

    /// The timings of the tests: integer and non-integer ticks per cycle.
    const TIMINGS: [(f32, f32, (u64, u64)); 5] = [
        (1e-3, 10_000.0, (10, 1)),
        (62.5e-6, 40_000.0, (5, 2)),
        (3e-3, 10_000.0, (30, 1)),
        (250e-6, 14_000.0, (7, 2)),
        (1.0 / 3_000.0, 10_000.0, (10, 3)),
    ];

    /// Time (cycles) after which the start-up transient (first segment from rest, the
    /// backward difference filling up) is over.
    const SETTLED: f64 = 4.0;

    #[test]
    fn constant_velocity_stream_is_interpolated_exactly() {
        // Targets p0 + D·k: the output at time t (cycles) is p0 + D·(t − 1) (one cycle of
        // latency), at constant velocity D/T and zero acceleration.
        let (p0, d) = (-1_000_000i64, 12_345i64);
        for (cycle_s, loop_hz, ratio) in TIMINGS {
            let run = Run {
                cycle_s,
                loop_hz,
                ratio,
                cycles: 60,
            };
            let out = run.go(
                p0,
                |ip, k| ip.push_position(p0 + d * k as i64, None),
                |_| true,
            );
            let v = d as f64 / cycle_s as f64;
            for (t, o, (whole, frac)) in out.into_iter().filter(|x| x.0 >= SETTLED) {
                let exact = p0 as f64 + d as f64 * (t - 1.0);
                let fine = whole as f64 + frac as f64;
                // 0.1: with 10/3 ticks per cycle, not a multiple of 2^-20 tick, the phase drifts
                // by 1/3 unit per cycle (3·10^-7 tick) until the [0, 1 tick] clamp bounds it;
                // over this run that is below 10^-5 cycle, 0.1 increment at 12,345 per cycle.
                assert!(
                    (fine - exact).abs() < 0.1,
                    "{cycle_s} s at t {t}: {fine} vs {exact}"
                );
                assert!(
                    (o.position as f64 - exact).abs() <= 0.51,
                    "{cycle_s} s at t {t}"
                );
                assert!((o.velocity as f64 - v).abs() < 1e-6 * v, "{}", o.velocity);
                assert!((o.acceleration.abs() as f64) < 1e-6 * v / cycle_s as f64);
            }
        }
    }

    #[test]
    fn parabolic_stream_has_continuous_velocity_and_the_right_acceleration() {
        // Targets k² (a·T²/2 = 1 increment): a = 2/T². The cubic reproduces the parabola, so
        // the velocity changes by a·T_loop from tick to tick, across the cycle boundaries too.
        for (cycle_s, loop_hz, ratio) in TIMINGS {
            let run = Run {
                cycle_s,
                loop_hz,
                ratio,
                cycles: 80,
            };
            let out = run.go(0, |ip, k| ip.push_position((k * k) as i64, None), |_| true);
            let t_cycle = cycle_s as f64;
            let a = 2.0 / (t_cycle * t_cycle);
            let dv = a / loop_hz as f64;
            let settled: Vec<_> = out.into_iter().filter(|x| x.0 >= SETTLED).collect();
            for w in settled.windows(2) {
                let step = (w[1].1.velocity - w[0].1.velocity) as f64;
                assert!(
                    (step - dv).abs() < 0.01 * dv,
                    "{cycle_s} s at {}: {step} vs {dv}",
                    w[1].0
                );
            }
            for (t, o, (whole, frac)) in settled {
                let x = t - 1.0;
                assert!(((whole as f64 + frac as f64) - x * x).abs() < 0.01, "t {t}");
                assert!((o.velocity as f64 - 2.0 * x / t_cycle).abs() < 1e-5 * a * t_cycle * t);
                assert!(
                    (o.acceleration as f64 - a).abs() < 1e-3 * a,
                    "{}",
                    o.acceleration
                );
            }
        }
    }

    #[test]
    fn velocity_offset_makes_a_cubic_stream_exact() {
        // Targets k³ with the master's velocity offset 3k²/T: the Hermite cubic with exact end
        // slopes is the trajectory itself; acceleration 6x/T².
        let (cycle_s, loop_hz, ratio) = TIMINGS[0];
        let run = Run {
            cycle_s,
            loop_hz,
            ratio,
            cycles: 40,
        };
        let t_cycle = cycle_s as f64;
        let out = run.go(
            0,
            |ip, k| {
                let v = (3 * k * k) as f32 / cycle_s;
                ip.push_position((k * k * k) as i64, Some(v))
            },
            |_| true,
        );
        for (t, o, (whole, frac)) in out.into_iter().filter(|x| x.0 >= 2.0) {
            let x = t - 1.0;
            assert!(
                ((whole as f64 + frac as f64) - x * x * x).abs() < 0.02,
                "t {t}"
            );
            let acc = 6.0 * x / (t_cycle * t_cycle);
            assert!((o.acceleration as f64 - acc).abs() < 1e-4 * acc, "t {t}");
        }
    }

    #[test]
    fn long_moves_keep_sub_increment_accuracy() {
        // (1) The parabola of the test above, 2^40 increments away from zero: an f32 position
        // would have a resolution of 2^17 increments there.
        let (cycle_s, loop_hz, ratio) = TIMINGS[0];
        let base = 1i64 << 40;
        let run = Run {
            cycle_s,
            loop_hz,
            ratio,
            cycles: 40,
        };
        let out = run.go(
            base,
            |ip, k| ip.push_position(base + (k * k) as i64, None),
            |_| true,
        );
        for (t, _, (whole, frac)) in out.into_iter().filter(|x| x.0 >= SETTLED) {
            let x = t - 1.0;
            let got = (whole - base) as f64 + frac as f64;
            assert!((got - x * x).abs() < 0.01, "t {t}: {got}");
        }
        // (2) 2^40 increments of travel at 1,677,722 increments per 1 ms cycle (6,000 rpm of a
        // 24-bit encoder): every tick within the f32 resolution of one cycle's distance
        // (2^-24 · 1.7·10^6 = 0.1 increment), the rounded position within half an increment.
        let d = 1_677_722i64;
        let cycles = (1u64 << 40) / d as u64 + 2;
        let run = Run {
            cycle_s,
            loop_hz,
            ratio,
            cycles,
        };
        let mut ip = Interpolator::new(run.cycle_s, run.loop_hz).unwrap();
        ip.reset(0);
        let mut worst = 0.0f64;
        let mut last = 0;
        for k in 0..cycles {
            ip.push_position(d * k as i64, None);
            for j in 0..10 {
                let o = ip.tick();
                if k >= 4 {
                    let exact = d as f64 * (k as f64 - 1.0 + j as f64 / 10.0);
                    let (whole, frac) = ip.position_fine();
                    worst = worst.max((whole as f64 + frac as f64 - exact).abs());
                    assert!((o.position as f64 - exact).abs() <= 0.5 + 0.13);
                }
                last = o.position;
            }
        }
        assert!(last > 1i64 << 40);
        assert!(worst < 0.13, "worst {worst}");
    }

    #[test]
    fn late_handler_by_a_tick_does_not_disturb_the_stream() {
        // The SYNC0 handler sometimes completes after the tick that follows the event: the
        // set-point is seen one tick late. The phase keeps the true time, the extra tick is the
        // constant-velocity extrapolation: the output stays exactly linear.
        let mut ip = Interpolator::new(1e-3, 10_000.0).unwrap();
        let d = 777i64;
        ip.reset(0);
        let mut n = 0u64;
        for k in 0..100u64 {
            let late = k % 3 == 1;
            // Cycle k spans ticks 10k .. 10k + 9; a late set-point is pushed at tick 10k + 1.
            for j in 0..10 {
                if j == (late as u64) {
                    ip.push_position(d * k as i64, None);
                }
                let o = ip.tick();
                let t = n as f64 / 10.0;
                if t >= SETTLED {
                    let exact = d as f64 * (t - 1.0);
                    assert!(
                        (o.position as f64 - exact).abs() <= 0.51,
                        "t {t}: {}",
                        o.position
                    );
                }
                n += 1;
            }
        }
    }

    #[test]
    fn missed_set_point_extrapolates_one_cycle_then_holds() {
        let d = 1_000i64;
        let (cycle_s, loop_hz, ratio) = TIMINGS[0];
        let run = Run {
            cycle_s,
            loop_hz,
            ratio,
            cycles: 30,
        };
        let v = d as f64 / cycle_s as f64;
        // Set-point 10 lost: the cycle after target 9 is extrapolated at constant velocity:
        // exactly the positions the stream would have given.
        let out = run.go(0, |ip, k| ip.push_position(d * k as i64, None), |k| k != 10);
        for (t, o, _) in out.iter().filter(|x| x.0 >= SETTLED && x.0 < 11.0) {
            let exact = d as f64 * (t - 1.0);
            assert!((o.position as f64 - exact).abs() <= 0.51, "t {t}");
            assert!((o.velocity as f64 - v).abs() < 1e-6 * v);
        }
        // Set-points 10 to 14 lost: extrapolation during cycle 10 (time 10..11), then hold at
        // target 9 + D (time 11..15) with zero velocity.
        let out = run.go(
            0,
            |ip, k| ip.push_position(d * k as i64, None),
            |k| !(10..15).contains(&k),
        );
        for (t, o, _) in out.iter().filter(|x| x.0 >= 11.05 && x.0 < 15.0) {
            assert_eq!(o.position, 10 * d, "t {t}");
            assert_eq!((o.velocity, o.acceleration), (0.0, 0.0));
        }
        // Resuming at 15 (target 15·D, 5·D ahead of the held position): one S-shaped catch-up
        // from rest to rest over a cycle, whose peak speed is 1.5 × the mean, then the
        // stream's velocity is picked up: never backwards, never faster than that peak.
        let peak_per_tick = 1.5 * 5.0 * d as f64 / 10.0;
        for w in out.windows(2).filter(|w| w[0].0 >= 14.0) {
            let step = (w[1].1.position - w[0].1.position) as f64;
            assert!(step >= 0.0, "backwards {step} at t {}", w[1].0);
            assert!(
                step <= peak_per_tick + 1.0,
                "jump of {step} at t {}",
                w[1].0
            );
        }
        let (t_end, o_end, _) = out.last().copied().unwrap();
        assert!((o_end.position as f64 - d as f64 * (t_end - 1.0)).abs() <= 0.51);
    }

    #[test]
    fn csv_and_cst_interpolate_linearly_and_hold() {
        let mut ip = Interpolator::new(1e-3, 10_000.0).unwrap();
        ip.reset(42);
        ip.push_velocity(1_000.0);
        // From rest to 1,000 increments/s in one cycle: slope 10^6 increments/s².
        for j in 0..10 {
            let o = ip.tick();
            assert!((o.velocity - 100.0 * j as f32).abs() < 1e-3);
            assert!((o.acceleration - 1e6).abs() < 1.0);
            assert_eq!(o.position, 42);
        }
        ip.push_velocity(-1_000.0);
        for j in 0..10 {
            let o = ip.tick();
            assert!((o.velocity - (1_000.0 - 200.0 * j as f32)).abs() < 1e-2);
            assert!((o.acceleration + 2e6).abs() < 1.0);
        }
        // Missed: hold the last set-point.
        for _ in 0..30 {
            let o = ip.tick();
            assert_eq!((o.velocity, o.acceleration), (-1_000.0, 0.0));
        }
        ip.reset(0);
        ip.push_torque(0.5);
        for j in 0..10 {
            let o = ip.tick();
            assert!((o.torque - 0.05 * j as f32).abs() < 1e-6);
            assert_eq!(o.velocity, 0.0);
        }
        // A NaN set-point counts as 0: ramp from 0.5 down to 0 over the cycle, then hold 0.
        ip.push_torque(f32::NAN);
        for j in 0..10 {
            let o = ip.tick();
            assert!((o.torque - (0.5 - 0.05 * j as f32)).abs() < 1e-6);
        }
        for _ in 0..20 {
            assert_eq!(ip.tick().torque, 0.0);
        }
    }

    #[test]
    fn timing_is_validated() {
        assert_eq!(
            Interpolator::new(62.5e-6, 10_000.0),
            Err(InterpolateError::CycleShorterThanTick)
        );
        assert_eq!(
            Interpolator::new(f32::NAN, 10_000.0),
            Err(InterpolateError::InvalidTiming)
        );
        assert_eq!(
            Interpolator::new(1.0, 40_000.0),
            Err(InterpolateError::CycleTooLong)
        );
        let ip = Interpolator::new(62.5e-6, 40_000.0).unwrap();
        assert_eq!(ip.ticks_per_cycle(), 2.5);
        // The shortest DC cycle at the 32 kHz loop, converted from ns as the axis does
        // (3.1249998e-5 s: a rounded product of 0.99999994 tick), is one tick; one 2^-20 tick
        // less is shorter than a tick, and 1000 ticks is the longest cycle.
        let ip = Interpolator::new(31_250.0 * 1e-9, 32_000.0).unwrap();
        assert_eq!(ip.ticks_per_cycle(), 1.0);
        assert_eq!(
            Interpolator::new((1.0 - 1.0 / 1_048_576.0) / 32_000.0, 32_000.0),
            Err(InterpolateError::CycleShorterThanTick)
        );
        assert!(Interpolator::new(1000.0 / 32_000.0, 32_000.0).is_ok());
        assert_eq!(
            Interpolator::new(1000.01 / 32_000.0, 32_000.0),
            Err(InterpolateError::CycleTooLong)
        );
        // Garbage targets do not panic.
        let mut ip = Interpolator::new(1e-3, 10_000.0).unwrap();
        ip.push_position(i64::MAX, Some(f32::INFINITY));
        ip.tick();
        ip.push_position(i64::MIN, None);
        for _ in 0..50 {
            ip.tick();
        }
    }
}
