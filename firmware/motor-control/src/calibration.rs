//! Calibrations run at enable: phase-current offsets, the electrical angle from the encoder
//! ([`Commutation`]) and the commutation-angle alignment for incremental encoders.
//!
//! All three run in the control interrupt (one call per PWM period), so the per-call paths have
//! no division and no library call; everything that needs one is computed at construction.

use super::foc::ConfigError;
use super::{ElectricalAngle, MotorFault};
use hal::power::PhaseCurrents;

/// A quarter electrical turn in [`ElectricalAngle`] bits.
const QUARTER_TURN_BITS: u32 = 1 << 30;
/// The fewest encoder counts a quarter electrical turn may have: fewer and the alignment check
/// (and the angle resolution, 90° per count) is meaningless.
pub const MIN_COUNTS_PER_QUARTER_ELECTRICAL_TURN: u32 = 4;

// ---------------------------------------------------------------------------------------------
// Phase-current offsets
// ---------------------------------------------------------------------------------------------

/// Averages phase-current samples taken with the gates off (at enable, before the first PWM
/// period): with no current flowing, the mean reading is the amplifier/ADC offset.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OffsetCalibration {
    samples: u32,
    inv_samples: f32,
    max_offset_a: f32,
    collected: u32,
    sum: PhaseCurrents,
    result: Option<Result<PhaseCurrents, MotorFault>>,
}

impl OffsetCalibration {
    /// A calibration averaging `samples` samples (0 is taken as 1) that rejects an offset above
    /// `max_offset_a` in magnitude (a broken amplifier, a missing reference or current actually
    /// flowing). A NaN `max_offset_a` rejects every result.
    pub fn new(samples: u32, max_offset_a: f32) -> Self {
        let samples = samples.max(1);
        Self {
            samples,
            inv_samples: 1.0 / samples as f32,
            max_offset_a,
            collected: 0,
            sum: PhaseCurrents::default(),
            result: None,
        }
    }

    /// Starts over (discards the samples and any result).
    pub fn restart(&mut self) {
        *self = Self::new(self.samples, self.max_offset_a);
    }

    /// Adds one raw sample. `None` while collecting; then the per-phase offsets, or
    /// `Err(MotorFault::CurrentOffset)` if one is implausible (or not a number). Once finished,
    /// further samples are ignored and the same result is returned.
    ///
    /// The sums are `f32`: for N samples the accumulated rounding is below N·2^-24 of the summed
    /// magnitude (1e-4 relative for 1,000 samples), far below any ADC's resolution.
    ///
    /// Timing: about 15 instructions while collecting, 30 on the last sample.
    pub fn add(&mut self, raw: PhaseCurrents) -> Option<Result<PhaseCurrents, MotorFault>> {
        if self.result.is_some() {
            return self.result;
        }
        self.sum.a += raw.a;
        self.sum.b += raw.b;
        self.sum.c += raw.c;
        // Stops at `samples`: the result returns early from then on.
        self.collected = self.collected.saturating_add(1);
        if self.collected < self.samples {
            return None;
        }
        let offsets = PhaseCurrents {
            a: self.sum.a * self.inv_samples,
            b: self.sum.b * self.inv_samples,
            c: self.sum.c * self.inv_samples,
        };
        // Written as "not within" so that a NaN offset (or limit) is rejected.
        let plausible = |x: f32| x.abs() <= self.max_offset_a;
        let result = if plausible(offsets.a) && plausible(offsets.b) && plausible(offsets.c) {
            Ok(offsets)
        } else {
            Err(MotorFault::CurrentOffset)
        };
        self.result = Some(result);
        self.result
    }

    /// The offset-corrected currents: `raw − offsets` per phase.
    ///
    /// Timing: 3 subtractions (about 6 instructions with loads and stores).
    #[inline]
    pub fn apply(offsets: PhaseCurrents, raw: PhaseCurrents) -> PhaseCurrents {
        PhaseCurrents {
            a: raw.a - offsets.a,
            b: raw.b - offsets.b,
            c: raw.c - offsets.c,
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Commutation angle
// ---------------------------------------------------------------------------------------------

/// The electrical angle from the multi-turn encoder position.
///
/// θ = (position − offset)·p/CPR, taken modulo one electrical turn. The division by CPR and the
/// modulo are 64-bit library calls on the Cortex-M4, so the per-period path keeps instead the
/// single-turn count t = (position − offset) mod CPR, updated by the position delta with one
/// conditional add or subtract of CPR, and scales it with the precomputed 64-bit factor
/// K = round(p·2^64/CPR): angle bits = (t·K mod 2^64) >> 32 (the wrapping keeps exactly the
/// fraction of an electrical turn).
///
/// Accuracy: for a power-of-two CPR, K is exact and the result is the exact angle truncated to
/// 2^-32 turn. Otherwise K is off by at most ½·2^-64, times t < CPR < 2^32 gives less than
/// 2^-33 turn, plus the truncation: the error is below 1.5·2^-32 electrical turn (3.5e-10).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Commutation {
    counts_per_rev: i64,
    scale: u64,
    offset_counts: i64,
    last_position: i64,
    /// (last_position − offset_counts) mod counts_per_rev, in 0..counts_per_rev.
    turn_count: i64,
}

impl Commutation {
    /// Commutation for an encoder with `counts_per_rev` counts per mechanical revolution, a motor
    /// with `pole_pairs` pole pairs, and the encoder position `offset_counts` at which the
    /// electrical angle is 0 (d axis on phase a).
    // Overflow-free: pole_pairs and counts_per_rev are u32 (products in u64, the shifts of
    // values below 2^32 in 64 bits) and counts_per_rev ≥ 16 is checked before it divides.
    #[allow(clippy::arithmetic_side_effects)]
    pub fn new(
        counts_per_rev: u32,
        pole_pairs: u32,
        offset_counts: i64,
    ) -> Result<Self, ConfigError> {
        if pole_pairs == 0 {
            return Err(ConfigError {
                parameter: "pole_pairs",
                reason: "must be at least 1",
            });
        }
        if (counts_per_rev as u64)
            < 4 * MIN_COUNTS_PER_QUARTER_ELECTRICAL_TURN as u64 * pole_pairs as u64
        {
            return Err(ConfigError {
                parameter: "counts_per_rev",
                reason: "must be at least 16 counts per electrical turn (counts_per_rev >= \
                         16 * pole_pairs)",
            });
        }
        // K = round(p·2^64/CPR); p ≤ CPR/16 here, so K < 2^60. Long division in two 32-bit
        // digits (64-bit divisions: a 128-bit one links some 700 bytes of library code):
        // p·2^32 = q1·CPR + r1, then r1·2^32 = q0·CPR + r0 (r1 < CPR ≤ 2^32 - 1, so r1·2^32
        // fits), and p·2^64 = (q1·2^32 + q0)·CPR + r0; rounded half up by r0.
        let cpr = counts_per_rev as u64;
        let high = (pole_pairs as u64) << 32;
        let (q1, r1) = (high / cpr, high % cpr);
        let (q0, r0) = ((r1 << 32) / cpr, (r1 << 32) % cpr);
        let scale = (q1 << 32) + q0 + u64::from(r0 >= cpr - cpr / 2);
        let mut commutation = Self {
            counts_per_rev: counts_per_rev as i64,
            scale,
            offset_counts,
            last_position: offset_counts,
            turn_count: 0,
        };
        commutation.turn_count = commutation.turn_count_of(offset_counts);
        Ok(commutation)
    }

    /// The encoder position at which the electrical angle is 0.
    pub fn offset(&self) -> i64 {
        self.offset_counts
    }

    /// Sets the encoder position at which the electrical angle is 0 (after an alignment).
    pub fn set_offset(&mut self, offset_counts: i64) {
        self.offset_counts = offset_counts;
        self.turn_count = self.turn_count_of(self.last_position);
    }

    /// (position − offset) mod CPR by a true modulo: the slow path, for construction, offset
    /// changes and position jumps of a turn or more. Each position is reduced on its own
    /// (64-bit divisions; the difference of two i64 would need 128 bits, whose library division
    /// costs nearly 3 KiB of flash), then the two residues are subtracted and brought back into
    /// 0..CPR.
    // Overflow-free: both residues are in 0..CPR ≤ u32::MAX, so their difference and the one
    // correction stay within ±CPR.
    #[allow(clippy::arithmetic_side_effects)]
    #[cold]
    #[inline(never)]
    fn turn_count_of(&self, position: i64) -> i64 {
        let cpr = self.counts_per_rev;
        // `counts_per_rev` ≥ 16 (`new`), so the remainders exist (checked all the same:
        // `rem_euclid`'s zero check would be a panic path in the control interrupt).
        let residue = |x: i64| x.checked_rem_euclid(cpr).unwrap_or(0);
        let difference = residue(position) - residue(self.offset_counts);
        if difference < 0 {
            difference + cpr
        } else {
            difference
        }
    }

    /// The electrical angle at the encoder `position`.
    ///
    /// Timing: about 25 instructions (64-bit subtract and compares, one conditional add or
    /// subtract, a 64×64 multiply of 3 `UMULL`/`MLA`). A position jump of a full turn or more
    /// since the last call (only the very first call or an encoder fault) takes the slow path,
    /// two 64-bit modulo library calls (some hundred instructions, once).
    #[inline]
    // Overflow-free: |delta| < CPR ≤ u32::MAX and 0 ≤ turn_count < CPR (the guard below), so
    // every sum stays within ±2·CPR; the fast-path multiply wraps by design (mod 2^64 is the
    // angle's modulo, see `scale`).
    #[allow(clippy::arithmetic_side_effects)]
    pub fn angle(&mut self, position: i64) -> ElectricalAngle {
        let cpr = self.counts_per_rev;
        self.turn_count = match position.checked_sub(self.last_position) {
            Some(delta) if delta > -cpr && delta < cpr => {
                // turn_count + delta ∈ (−CPR, 2·CPR): one correction brings it to 0..CPR.
                let t = self.turn_count + delta;
                if t >= cpr {
                    t - cpr
                } else if t < 0 {
                    t + cpr
                } else {
                    t
                }
            }
            _ => self.turn_count_of(position),
        };
        self.last_position = position;
        let bits = (self.turn_count as u64).wrapping_mul(self.scale) >> 32;
        ElectricalAngle::from_bits(bits as u32)
    }

    /// The mechanical position within one revolution relative to the offset, as a fraction
    /// 0..1 of a turn (for display; `f32`).
    pub fn mech_turn_fraction(&self) -> f32 {
        self.turn_count as f32 / self.counts_per_rev as f32
    }
}

// ---------------------------------------------------------------------------------------------
// Alignment
// ---------------------------------------------------------------------------------------------

/// Parameters of the commutation-angle [`Alignment`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AlignmentConfig {
    /// d-axis current in A that pulls the rotor into line (enough to overcome friction and
    /// cogging, typically the rated current).
    pub current_a: f32,
    /// Time in s to ramp the current from 0 (a step would make the rotor jump and oscillate).
    pub ramp_s: f32,
    /// Time in s to hold the current at each of the two angles until the rotor stands still.
    pub settle_s: f32,
    /// Time in s to turn the commanded angle by a quarter electrical turn.
    pub rotate_s: f32,
    /// Accepted deviation of the measured quarter-turn movement from the expected one, as a
    /// fraction (e.g. 0.25), in 0..1.
    pub tolerance: f32,
}

/// What the axis does in this period during an [`Alignment`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AlignStep {
    /// Run the current loop at the fixed electrical `angle` with the d-axis reference `id_ref`
    /// (A) and a q-axis reference of 0.
    Drive {
        /// The commanded electrical angle.
        angle: ElectricalAngle,
        /// d-axis current reference in A.
        id_ref: f32,
    },
    /// Finished: the encoder position at which the electrical angle is 0 (for
    /// [`Commutation::set_offset`]) or [`MotorFault::Alignment`] when the rotor did not follow
    /// (phase order reversed against the encoder, wrong pole-pair count, rotor blocked).
    Done(Result<i64, MotorFault>),
}

/// Where an [`Alignment`] is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Stage {
    Ramp,
    Settle,
    Rotate,
    Hold,
    Done(Result<i64, MotorFault>),
}

/// Commutation-angle alignment for incremental encoders, a step machine run once per period at
/// enable before closed-loop operation.
///
/// 1. Ramp id to `current_a` at electrical angle 0 over `ramp_s`, hold it for `settle_s`: the
///    rotor's d axis lines up with phase a. Record the position p0.
/// 2. Turn the commanded angle slowly by +¼ electrical turn over `rotate_s`, hold for
///    `settle_s`, record p1. The rotor must have followed: p1 − p0 = +CPR/(4·p) within
///    `tolerance`. The wrong direction (phase order against the encoder), a wrong distance
///    (pole-pair count) or no movement (blocked rotor, no current) is
///    [`MotorFault::Alignment`].
/// 3. The offset is the mean of the two estimates of the zero, p0 and p1 − CPR/(4·p).
///
/// Limitation of every d-axis alignment: a rotor that starts exactly half an electrical turn
/// away feels no torque at angle 0; it then moves during the rotation by the wrong amount and
/// the check reports the fault (run the alignment again).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Alignment {
    current_a: f32,
    ramp_increment_a: f32,
    ramp_periods: u32,
    settle_periods: u32,
    rotate_periods: u32,
    /// A quarter turn per `rotate_periods` in 2^-32 angle bits (32.32 fixed point, so that the
    /// ramp ends within one bit of the quarter turn without a division per period).
    angle_increment: u64,
    expected_counts: i64,
    tolerance_counts: i64,
    stage: Stage,
    /// Periods spent in the present stage.
    count: u32,
    p0: i64,
}

/// `value` if it is positive and finite.
fn positive(parameter: &'static str, value: f32) -> Result<f32, ConfigError> {
    if value > 0.0 && value < f32::INFINITY {
        Ok(value)
    } else {
        Err(ConfigError {
            parameter,
            reason: "must be positive and finite",
        })
    }
}

/// The number of periods of `seconds` at `period_s`, at least 1 (saturating for absurd values).
fn periods(parameter: &'static str, seconds: f32, period_s: f32) -> Result<u32, ConfigError> {
    if !(0.0..f32::INFINITY).contains(&seconds) {
        return Err(ConfigError {
            parameter,
            reason: "must be zero or positive and finite",
        });
    }
    // `as u32` saturates; + 0.5 rounds.
    Ok(((seconds / period_s + 0.5) as u32).max(1))
}

impl Alignment {
    /// Validates `cfg` and converts its durations to periods of `sample_time_s` (the interval
    /// between two calls of [`Alignment::step`], the PWM period), for an encoder with
    /// `counts_per_rev` counts per revolution on a motor with `pole_pairs` pole pairs.
    // Overflow-free: `periods` returns at least 1, so the angle increment's divisor is not 0.
    #[allow(clippy::arithmetic_side_effects)]
    pub fn new(
        cfg: &AlignmentConfig,
        counts_per_rev: u32,
        pole_pairs: u32,
        sample_time_s: f32,
    ) -> Result<Self, ConfigError> {
        // The same encoder/motor constraints as the commutation it calibrates.
        Commutation::new(counts_per_rev, pole_pairs, 0)?;
        let current_a = positive("current_a", cfg.current_a)?;
        let ts = positive("sample_time_s", sample_time_s)?;
        let ramp_periods = periods("ramp_s", cfg.ramp_s, ts)?;
        let settle_periods = periods("settle_s", cfg.settle_s, ts)?;
        let rotate_periods = periods("rotate_s", cfg.rotate_s, ts)?;
        if !(cfg.tolerance > 0.0 && cfg.tolerance < 1.0) {
            return Err(ConfigError {
                parameter: "tolerance",
                reason: "must be a fraction between 0 and 1 (exclusive)",
            });
        }
        // A quarter electrical turn in counts, CPR / (4·p), rounded (in integers: p ≥ 1 and
        // CPR ≥ 16·p, checked by the commutation above); its tolerance in single precision
        // (exact to 1 part in 2^24, which is plenty for a tolerance; a double would link the
        // soft-float library on this single-precision FPU).
        let quarter_divisor = 4 * u64::from(pole_pairs);
        let expected_counts = (u64::from(counts_per_rev) + quarter_divisor / 2) / quarter_divisor;
        let quarter = counts_per_rev as f32 / quarter_divisor as f32;
        Ok(Self {
            current_a,
            ramp_increment_a: current_a / ramp_periods as f32,
            ramp_periods,
            settle_periods,
            rotate_periods,
            angle_increment: ((QUARTER_TURN_BITS as u64) << 32) / rotate_periods as u64,
            expected_counts: expected_counts as i64,
            tolerance_counts: ((quarter * cfg.tolerance + 0.5) as i64).max(1),
            stage: Stage::Ramp,
            count: 0,
            p0: 0,
        })
    }

    /// Starts over (stage 1).
    pub fn restart(&mut self) {
        self.stage = Stage::Ramp;
        self.count = 0;
        self.p0 = 0;
    }

    /// Whether the alignment has finished (successfully or not).
    pub fn is_done(&self) -> bool {
        matches!(self.stage, Stage::Done(_))
    }

    /// One period: the present encoder `position` in, what to drive (or the result) out. After
    /// `Done` every further call returns the same `Done`.
    ///
    /// Timing: about 20 instructions (a stage match, a counter, one multiply for the ramp or
    /// the angle); the final check adds some 64-bit compares. No division.
    // Overflow-free: the period counter stops at the stage lengths (u32 from `new`), and
    // n < rotate_periods keeps angle_increment · n below a quarter turn · 2^32.
    #[allow(clippy::arithmetic_side_effects)]
    pub fn step(&mut self, position: i64) -> AlignStep {
        self.count = self.count.saturating_add(1);
        let n = self.count;
        match self.stage {
            Stage::Ramp => {
                let id_ref = if n >= self.ramp_periods {
                    self.next_stage(Stage::Settle);
                    self.current_a
                } else {
                    self.ramp_increment_a * n as f32
                };
                self.drive(0, id_ref)
            }
            Stage::Settle => {
                if n >= self.settle_periods {
                    self.p0 = position;
                    self.next_stage(Stage::Rotate);
                }
                self.drive(0, self.current_a)
            }
            Stage::Rotate => {
                let bits = if n >= self.rotate_periods {
                    self.next_stage(Stage::Hold);
                    QUARTER_TURN_BITS
                } else {
                    // n < rotate_periods, so the product stays below a quarter turn · 2^32.
                    ((self.angle_increment * n as u64) >> 32) as u32
                };
                self.drive(bits, self.current_a)
            }
            Stage::Hold => {
                if n >= self.settle_periods {
                    let result = self.evaluate(position);
                    self.stage = Stage::Done(result);
                    AlignStep::Done(result)
                } else {
                    self.drive(QUARTER_TURN_BITS, self.current_a)
                }
            }
            Stage::Done(result) => AlignStep::Done(result),
        }
    }

    fn next_stage(&mut self, stage: Stage) {
        self.stage = stage;
        self.count = 0;
    }

    fn drive(&self, angle_bits: u32, id_ref: f32) -> AlignStep {
        AlignStep::Drive {
            angle: ElectricalAngle::from_bits(angle_bits),
            id_ref,
        }
    }

    /// The check of step 2 and the offset of step 3.
    fn evaluate(&self, p1: i64) -> Result<i64, MotorFault> {
        // Checked arithmetic: a garbage position must give the fault, not an overflow panic.
        let error = p1
            .checked_sub(self.p0)
            .and_then(|moved| moved.checked_sub(self.expected_counts))
            .ok_or(MotorFault::Alignment)?;
        if error
            .checked_abs()
            .is_none_or(|e| e > self.tolerance_counts)
        {
            return Err(MotorFault::Alignment);
        }
        // Mean of p0 and p1 − expected = p0 + error/2 (a shift: no library division).
        Ok(self.p0.saturating_add(error / 2))
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::f64::consts::TAU;

    // --- offsets -----------------------------------------------------------------------------

    /// A deterministic pseudo-random sequence in −1..1 (xorshift), for noise.
    struct Noise(u64);
    impl Noise {
        fn next(&mut self) -> f32 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 11) as f32 / (1u64 << 53) as f32 * 2.0 - 1.0
        }
    }

    #[test]
    fn offsets_are_the_mean_of_noisy_samples() {
        const N: u32 = 1024;
        const TRUE: PhaseCurrents = PhaseCurrents {
            a: 0.12,
            b: -0.08,
            c: 0.03,
        };
        // ±0.2 A uniform noise: the mean of 1024 samples has σ = 0.2/√3/32 = 3.6 mA.
        const NOISE_A: f32 = 0.2;
        let mut noise = Noise(0x1234_5678_9abc_def1);
        let mut cal = OffsetCalibration::new(N, 0.5);
        let mut result = None;
        for k in 0..N {
            let sample = PhaseCurrents {
                a: TRUE.a + NOISE_A * noise.next(),
                b: TRUE.b + NOISE_A * noise.next(),
                c: TRUE.c + NOISE_A * noise.next(),
            };
            result = cal.add(sample);
            assert_eq!(
                result.is_some(),
                k == N - 1,
                "collecting until the last sample"
            );
        }
        let offsets = result.unwrap().unwrap();
        // 5 σ.
        for (got, want) in [
            (offsets.a, TRUE.a),
            (offsets.b, TRUE.b),
            (offsets.c, TRUE.c),
        ] {
            assert!((got - want).abs() < 0.018, "{got} vs {want}");
        }
        // Applying them to a raw sample of the true offsets gives zero current.
        let corrected = OffsetCalibration::apply(offsets, TRUE);
        assert!(corrected.a.abs() < 0.018 && corrected.b.abs() < 0.018);
        // Finished: further samples do not change the result.
        assert_eq!(
            cal.add(PhaseCurrents {
                a: 100.0,
                b: 0.0,
                c: 0.0
            }),
            Some(Ok(offsets))
        );
        cal.restart();
        assert_eq!(cal.add(TRUE), None);
    }

    #[test]
    fn an_implausible_offset_is_a_fault() {
        let mut cal = OffsetCalibration::new(4, 0.5);
        let mut result = None;
        for _ in 0..4 {
            result = cal.add(PhaseCurrents {
                a: 0.1,
                b: -0.7,
                c: 0.1,
            });
        }
        assert_eq!(result, Some(Err(MotorFault::CurrentOffset)));
        let mut cal = OffsetCalibration::new(1, 0.5);
        assert_eq!(
            cal.add(PhaseCurrents {
                a: f32::NAN,
                b: 0.0,
                c: 0.0
            }),
            Some(Err(MotorFault::CurrentOffset))
        );
        // Zero samples is one sample, not a division by zero.
        let mut cal = OffsetCalibration::new(0, 0.5);
        assert!(matches!(cal.add(PhaseCurrents::default()), Some(Ok(_))));
    }

    // --- commutation -------------------------------------------------------------------------

    /// Walks the encoder over ±`turns` mechanical turns with steps of varying size (and some
    /// jumps of more than a turn), checking every angle against `check`.
    fn walk(cpr: u32, pole_pairs: u32, offset: i64, turns: i64, check: impl Fn(i64, u32)) {
        let mut c = Commutation::new(cpr, pole_pairs, offset).unwrap();
        let cpr = cpr as i64;
        let mut position = offset - 3 * cpr / 7;
        let mut noise = Noise(0xdead_beef_cafe_f00d);
        // Forward to +turns, back to −turns, forward to 0; step sizes up to 0.37 turn, every
        // 97th step a jump of a few turns.
        let targets = [offset + turns * cpr, offset - turns * cpr, offset];
        let mut calls = 0u32;
        for target in targets {
            while (target - position).abs() > cpr {
                let direction = (target - position).signum();
                let size = ((noise.next().abs() * 0.37 * cpr as f32) as i64).max(1);
                calls += 1;
                let step = if calls % 97 == 0 {
                    3 * cpr + size
                } else {
                    size
                };
                position += direction * step;
                check(position, c.angle(position).to_bits());
            }
        }
        assert!(calls > 1000);
    }

    #[test]
    fn commutation_is_exact_for_a_power_of_two_resolution() {
        const CPR: u32 = 1 << 20;
        const P: u32 = 4;
        const OFFSET: i64 = 123_457;
        walk(CPR, P, OFFSET, 3000, |position, bits| {
            // θ·2^32 = (position − offset)·p·2^32/2^20, modulo 2^32: exact in integers.
            let expected = ((position - OFFSET) * P as i64 * (1 << 12)).rem_euclid(1 << 32);
            assert_eq!(bits as i64, expected, "position {position}");
        });
    }

    #[test]
    fn commutation_matches_the_reference_for_other_resolutions() {
        for (cpr, p) in [(10_000u32, 5u32), (10_000, 4), (4_000, 50), (131_071, 7)] {
            let offset: i64 = -987_654;
            walk(cpr, p, offset, 2000, |position, bits| {
                let reference =
                    ((position - offset) as f64 * p as f64 / cpr as f64).rem_euclid(1.0);
                let got = bits as f64 / 4_294_967_296.0;
                let error = (got - reference + 0.5).rem_euclid(1.0) - 0.5;
                assert!(
                    error.abs() < 1e-6,
                    "cpr {cpr}, p {p}, position {position}: {error}"
                );
                // Much better than asked: the documented bound 1.5·2^-32 (plus the f64 reference).
                assert!(error.abs() < 1.5 / 4_294_967_296.0 + 1e-12, "{error}");
            });
        }
    }

    /// The angle scale K = round(p·2^64 / CPR), computed in 64-bit digits, equals the exact
    /// 128-bit quotient for resolutions and pole pairs across their range.
    #[test]
    fn the_angle_scale_is_the_exact_rounded_quotient() {
        for cpr in [
            16u32,
            17,
            1000,
            4096,
            10_000,
            131_071,
            1 << 20,
            0x7FFF_FFFF,
            u32::MAX,
        ] {
            for p in [1u32, 2, 3, 4, 5, 7, 50, 1000] {
                let Ok(c) = Commutation::new(cpr, p, 0) else {
                    assert!(
                        u64::from(cpr) < 16 * u64::from(p),
                        "cpr {cpr}, p {p} refused"
                    );
                    continue;
                };
                let exact = ((u128::from(p) << 64) + u128::from(cpr / 2)) / u128::from(cpr);
                assert_eq!(u128::from(c.scale), exact, "cpr {cpr}, p {p}");
            }
        }
    }

    /// The slow path (a jump of a turn or more) for positions and offsets at the ends of the
    /// i64 range, against the exact modulo of the difference in 128 bits.
    #[test]
    fn a_jump_anywhere_in_the_position_range_lands_on_the_exact_turn_count() {
        let positions = [
            i64::MIN,
            i64::MIN + 1,
            -4_294_967_297,
            -1,
            0,
            1,
            123_456_789_012,
            i64::MAX - 1,
            i64::MAX,
        ];
        for cpr in [16u32, 10_000, 131_071, u32::MAX] {
            for offset in [i64::MIN, -987_654, 0, 5, i64::MAX] {
                let mut c = Commutation::new(cpr, 1, offset).unwrap();
                for position in positions {
                    c.angle(position);
                    let exact =
                        (i128::from(position) - i128::from(offset)).rem_euclid(i128::from(cpr));
                    assert_eq!(
                        i128::from(c.turn_count),
                        exact,
                        "cpr {cpr}, offset {offset}, position {position}"
                    );
                }
            }
        }
    }

    #[test]
    fn set_offset_moves_the_zero() {
        let mut c = Commutation::new(10_000, 5, 0).unwrap();
        c.angle(2_000);
        // 2000 counts = one electrical turn at 5 pole pairs and 10000 counts.
        assert_eq!(c.angle(2_000).to_bits(), 0);
        c.set_offset(1_500);
        // 500 counts past the new zero: a quarter electrical turn.
        assert_eq!(c.angle(2_000).to_bits(), 1 << 30);
        assert_eq!(c.offset(), 1_500);
        assert!((c.mech_turn_fraction() - 0.05).abs() < 1e-6);
    }

    #[test]
    fn commutation_rejects_impossible_encoders() {
        assert_eq!(
            Commutation::new(1000, 0, 0).unwrap_err().parameter,
            "pole_pairs"
        );
        assert_eq!(
            Commutation::new(100, 10, 0).unwrap_err().parameter,
            "counts_per_rev"
        );
        assert!(Commutation::new(160, 10, 0).is_ok());
        assert!(Commutation::new(u32::MAX, 1, 0).is_ok());
    }

    // --- alignment ---------------------------------------------------------------------------

    const TS: f32 = 1e-4;
    const CPR: u32 = 10_000;
    const P: u32 = 4;
    const CURRENT_A: f32 = 3.0;

    fn alignment_config() -> AlignmentConfig {
        AlignmentConfig {
            current_a: CURRENT_A,
            ramp_s: 0.1,
            settle_s: 0.3,
            rotate_s: 0.5,
            tolerance: 0.25,
        }
    }

    fn alignment() -> Alignment {
        Alignment::new(&alignment_config(), CPR, P, TS).unwrap()
    }

    /// How the synthetic rotor reacts.
    #[derive(Clone, Copy)]
    enum Rotor {
        /// Follows the field; the encoder counts up with the electrical angle.
        Follows,
        /// Follows the field, but the phases are connected in the wrong order: the encoder
        /// counts down when the electrical angle advances.
        Reversed,
        /// Does not move.
        Blocked,
        /// Follows the field, but the motor has twice the configured pole pairs.
        DoublePolePairs,
    }

    /// Runs the alignment against a rotor that is pulled towards the commanded electrical angle
    /// by a torque ∝ id·sin(θ_cmd − θ_rotor) (overdamped: the electrical angle moves by
    /// 0.01·id/I·sin(…) rad per period). The encoder reads `zero` where the rotor's electrical
    /// angle is 0. Returns the result and the trace of commands.
    fn align(
        rotor: Rotor,
        zero: i64,
        start_electrical_rad: f64,
    ) -> (Result<i64, MotorFault>, usize) {
        let mut alignment = alignment();
        let mut theta = start_electrical_rad;
        let pole_pairs = match rotor {
            Rotor::DoublePolePairs => 2.0 * P as f64,
            _ => P as f64,
        };
        let counts_per_electrical_rad = CPR as f64 / pole_pairs / TAU;
        let mut periods = 0;
        loop {
            let counts = (theta * counts_per_electrical_rad).round() as i64;
            let position = match rotor {
                Rotor::Reversed => zero - counts,
                _ => zero + counts,
            };
            periods += 1;
            match alignment.step(position) {
                AlignStep::Drive { angle, id_ref } => {
                    assert!((0.0..=CURRENT_A).contains(&id_ref));
                    let commanded = angle.to_bits() as f64 / 4_294_967_296.0 * TAU;
                    if !matches!(rotor, Rotor::Blocked) {
                        theta += 0.01 * (id_ref / CURRENT_A) as f64 * (commanded - theta).sin();
                    }
                }
                AlignStep::Done(result) => {
                    assert!(alignment.is_done());
                    assert_eq!(
                        alignment.step(position),
                        AlignStep::Done(result),
                        "stays done"
                    );
                    return (result, periods);
                }
            }
            assert!(periods < 100_000, "never finishes");
        }
    }

    /// The distance the check expects is a quarter electrical turn, CPR / (4·p), rounded to
    /// the nearest count (halves up), for every encoder resolution.
    #[test]
    fn the_expected_quarter_turn_is_rounded_to_the_nearest_count() {
        for (cpr, p, expected) in [
            (10_000u32, 3u32, 833i64),
            (10_002, 3, 834),
            (1 << 20, 4, 65_536),
            (u32::MAX, 1, 1_073_741_824),
        ] {
            let a = Alignment::new(&alignment_config(), cpr, p, 25e-6).unwrap();
            assert_eq!(a.expected_counts, expected, "cpr {cpr}, p {p}");
            assert!(a.tolerance_counts >= 1);
        }
    }

    #[test]
    fn alignment_finds_the_zero_of_a_following_rotor() {
        let zero = 7_777_777i64;
        for start in [-2.5f64, -1.0, 0.0, 0.4, 2.0, 2.9] {
            let (result, periods) = align(Rotor::Follows, zero, start);
            let offset = result.unwrap_or_else(|e| panic!("start {start}: {e:?}"));
            // Any electrical zero will do: they are CPR/p = 2500 counts apart.
            let electrical_period = (CPR / P) as i64;
            let error = (offset - zero + electrical_period / 2).rem_euclid(electrical_period)
                - electrical_period / 2;
            assert!(
                error.abs() <= 2,
                "start {start}: offset off by {error} counts"
            );
            // 0.1 + 0.3 + 0.5 + 0.3 s.
            assert_eq!(periods, 12_000);
            // The commutation built on it reads angle 0 at the rotor's d axis.
            let mut c = Commutation::new(CPR, P, offset).unwrap();
            let angle = c.angle(zero).to_bits() as i32 as f64 / 4_294_967_296.0;
            assert!(angle.abs() < 1e-3, "{angle} turn");
        }
    }

    #[test]
    fn alignment_fails_on_reversed_blocked_or_wrong_pole_pairs() {
        for rotor in [Rotor::Reversed, Rotor::Blocked, Rotor::DoublePolePairs] {
            let (result, _) = align(rotor, 1000, 0.7);
            assert_eq!(result, Err(MotorFault::Alignment));
        }
    }

    #[test]
    fn alignment_commands_a_ramp_then_a_slow_quarter_turn() {
        let mut alignment = alignment();
        let mut previous = (0u32, 0.0f32);
        for k in 1..=12_000 {
            match alignment.step(0) {
                AlignStep::Drive { angle, id_ref } => {
                    let bits = angle.to_bits();
                    // Monotonic, no jumps: at most one ramp or rotation increment per period.
                    assert!(
                        id_ref >= previous.1 && id_ref - previous.1 <= CURRENT_A / 1000.0 + 1e-6
                    );
                    assert!(bits >= previous.0 && bits - previous.0 <= (1 << 30) / 5000 + 1);
                    if k <= 4000 {
                        assert_eq!(bits, 0, "angle 0 during ramp and settle");
                    }
                    if k == 1000 {
                        assert_eq!(id_ref, CURRENT_A, "ramp complete");
                    }
                    if k > 9000 {
                        assert_eq!(bits, 1 << 30, "a quarter turn at the end");
                    }
                    previous = (bits, id_ref);
                }
                AlignStep::Done(result) => {
                    assert_eq!(k, 12_000);
                    assert_eq!(result, Err(MotorFault::Alignment), "the rotor never moved");
                }
            }
        }
        alignment.restart();
        assert!(!alignment.is_done());
        assert!(matches!(alignment.step(0), AlignStep::Drive { id_ref, .. } if id_ref < 0.01));
    }

    #[test]
    fn alignment_rejects_bad_configurations() {
        let good = alignment_config();
        for (parameter, break_it) in [
            (
                "current_a",
                (|c| c.current_a = 0.0) as fn(&mut AlignmentConfig),
            ),
            ("ramp_s", |c| c.ramp_s = -1.0),
            ("settle_s", |c| c.settle_s = f32::INFINITY),
            ("tolerance", |c| c.tolerance = 1.0),
            ("tolerance", |c| c.tolerance = f32::NAN),
        ] {
            let mut cfg = good;
            break_it(&mut cfg);
            assert_eq!(
                Alignment::new(&cfg, CPR, P, TS).unwrap_err().parameter,
                parameter
            );
        }
        let error = |cpr, p, ts| Alignment::new(&good, cpr, p, ts).unwrap_err().parameter;
        assert_eq!(error(CPR, P, f32::NAN), "sample_time_s");
        assert_eq!(error(CPR, 0, TS), "pole_pairs");
        assert_eq!(error(8, P, TS), "counts_per_rev");
    }
}
