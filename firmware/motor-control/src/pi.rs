//! PI controller in the parallel form with output limits and anti-windup by conditional
//! integration (clamping).
//!
//! u = kp·e + I, I ← I + ki·Ts·e. The integrator stops when the output is saturated and the
//! error would drive it further into saturation, and it is itself kept inside the output
//! limits, so it never winds up and the loop recovers as soon as the error changes sign. The
//! caller may also tell the controller that a stage after it saturated
//! ([`Pi::update_limited`]), e.g. the voltage-circle limiter of the current loop.

use super::math::{clamp, max, min};

/// Gains and limits of a [`Pi`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PiGains {
    /// Proportional gain (output unit per error unit).
    pub kp: f32,
    /// Integral gain times the sample time, `ki·Ts` (output unit per error unit and sample).
    pub ki_ts: f32,
    /// Lower output limit.
    pub out_min: f32,
    /// Upper output limit.
    pub out_max: f32,
}

/// A PI controller's state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pi {
    /// Gains and limits.
    pub gains: PiGains,
    integral: f32,
}

impl Pi {
    /// A controller with `gains` and an empty integrator.
    pub const fn new(gains: PiGains) -> Self {
        Self {
            gains,
            integral: 0.0,
        }
    }

    /// The integrator.
    pub fn integral(&self) -> f32 {
        self.integral
    }

    /// Presets the integrator (bumpless transfer), limited to the output range.
    pub fn set_integral(&mut self, value: f32) {
        self.integral = clamp(value, self.gains.out_min, self.gains.out_max);
    }

    /// Empties the integrator.
    pub fn reset(&mut self) {
        self.integral = 0.0;
    }

    /// One step: the limited output for error `e`.
    ///
    /// Timing: about 15 instructions.
    #[inline]
    pub fn update(&mut self, e: f32) -> f32 {
        self.update_limited(e, 0.0, self.gains.out_min, self.gains.out_max)
    }

    /// One step with a feed-forward term `ff` added to the output and limits `lo..=hi` that may
    /// be tighter than the configured ones (a downstream limiter's share). The integrator holds
    /// while the output is pinned at a limit and `e` pushes further out.
    ///
    /// Timing: about 20 instructions.
    #[inline]
    pub fn update_limited(&mut self, e: f32, ff: f32, lo: f32, hi: f32) -> f32 {
        let candidate = self.integral + self.gains.ki_ts * e;
        let unclamped = self.gains.kp * e + candidate + ff;
        let pushing_up = unclamped > hi && e > 0.0;
        let pushing_down = unclamped < lo && e < 0.0;
        if !(pushing_up || pushing_down) {
            self.integral = clamp(
                candidate,
                min(lo, self.gains.out_min),
                max(hi, self.gains.out_max),
            );
        }
        clamp(self.gains.kp * e + self.integral + ff, lo, hi)
    }

    /// Tells the controller that its last output was cut down to `applied` by a later stage:
    /// the integrator is pulled back so that output and integrator agree (back-calculation with
    /// unit gain), and holds no charge the plant could not take.
    #[inline]
    pub fn back_calculate(&mut self, output: f32, applied: f32) {
        let excess = output - applied;
        if (excess > 0.0 && self.integral > 0.0) || (excess < 0.0 && self.integral < 0.0) {
            let pulled = self.integral - excess;
            // Never pull the integrator through zero: that would reverse the output.
            self.integral = if self.integral > 0.0 {
                max(pulled, 0.0)
            } else {
                min(pulled, 0.0)
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GAINS: PiGains = PiGains {
        kp: 2.0,
        ki_ts: 0.1,
        out_min: -10.0,
        out_max: 10.0,
    };

    #[test]
    fn proportional_and_integral_action() {
        let mut pi = Pi::new(GAINS);
        assert!((pi.update(1.0) - 2.1).abs() < 1e-6);
        assert!((pi.update(1.0) - 2.2).abs() < 1e-6);
        assert!((pi.integral() - 0.2).abs() < 1e-6);
    }

    #[test]
    fn a_first_order_plant_settles_without_steady_state_error() {
        // y(k+1) = 0.9 y + 0.1 u: unit DC gain. The PI must remove the static error.
        let mut pi = Pi::new(GAINS);
        let mut y = 0.0f32;
        for _ in 0..500 {
            let u = pi.update(1.0 - y);
            y = 0.9 * y + 0.1 * u;
        }
        assert!((y - 1.0).abs() < 1e-4, "y = {y}");
    }

    #[test]
    fn integrator_does_not_wind_up_while_saturated() {
        let mut pi = Pi::new(GAINS);
        for _ in 0..10_000 {
            assert_eq!(pi.update(100.0), 10.0);
        }
        assert!(pi.integral() <= 10.0);
        // The error reverses: the output leaves saturation at once (a wound-up integrator would
        // hold it for thousands of steps).
        let out = pi.update(-1.0);
        assert!(out < 10.0, "out = {out}");
    }

    #[test]
    fn tighter_downstream_limits_stop_integration_in_their_direction() {
        let mut pi = Pi::new(GAINS);
        let mut out = 0.0;
        for _ in 0..1_000 {
            out = pi.update_limited(1.0, 0.0, -3.0, 3.0);
        }
        assert_eq!(out, 3.0);
        // The integrator stopped once kp·e + I reached the limit (3 − 2 = 1, plus one step).
        assert!(
            pi.integral() <= 1.0 + GAINS.ki_ts,
            "integral {}",
            pi.integral()
        );
        // Integration away from the limit continues.
        let before = pi.integral();
        pi.update_limited(-1.0, 0.0, -3.0, 3.0);
        assert!(pi.integral() < before);
    }

    #[test]
    fn back_calculation_pulls_the_integrator_towards_the_applied_output() {
        let mut pi = Pi::new(GAINS);
        pi.set_integral(8.0);
        pi.back_calculate(9.0, 6.0);
        assert!((pi.integral() - 5.0).abs() < 1e-6);
        pi.back_calculate(9.0, -20.0);
        assert_eq!(pi.integral(), 0.0, "never through zero");
    }
}
