//! The position loop: a proportional controller from position error to velocity command, with
//! velocity feed-forward and a velocity limit.
//!
//! v_cmd = clamp(kp·(p_ref − p) + v_ff, ±v_max). With an ideal velocity follower the loop is
//! a first-order lag of time constant 1/kp: a ramp of velocity v is followed with the constant
//! error v/kp, which the feed-forward of the ramp's velocity removes. The integral action sits
//! in the speed loop; a P position loop on top of a PI speed loop is the usual cascade and has
//! no overshoot for kp well below the speed-loop bandwidth (kp ≤ ωs/4 is a common choice).

use super::math::clamp_symmetric;

/// `x` as `f32`, saturated to ±2^31 first: an `i64 → f32` conversion is a library call on a
/// Cortex-M4 (about 30 instructions), `i32 → f32` one instruction. Differences of positions
/// beyond ±2^31 increments only ever feed limiters, so the saturation changes nothing.
///
/// Timing: about 6 instructions.
#[inline]
pub fn saturating_to_f32(x: i64) -> f32 {
    let limited = if x > i32::MAX as i64 {
        i32::MAX
    } else if x < i32::MIN as i64 {
        i32::MIN
    } else {
        x as i32
    };
    limited as f32
}

/// The position loop's state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PositionLoop {
    kp: f32,
    velocity_limit: f32,
    following_error: i64,
}

/// A gain or limit as given when finite and non-negative, else 0 (a loop that commands nothing
/// rather than garbage).
fn non_negative(x: f32) -> f32 {
    if x.is_finite() && x > 0.0 {
        x
    } else {
        0.0
    }
}

impl PositionLoop {
    /// A loop with gain `kp` (1/s: increments/s of velocity command per increment of error) and
    /// velocity limit `velocity_limit` (increments/s). NaN, infinite or negative values become 0.
    pub fn new(kp: f32, velocity_limit: f32) -> Self {
        Self {
            kp: non_negative(kp),
            velocity_limit: non_negative(velocity_limit),
            following_error: 0,
        }
    }

    /// One step: the velocity command (increments/s) for the reference `position_ref`, the
    /// measured `position` and the velocity feed-forward `velocity_ff` (increments/s). The error
    /// is taken in `i64` (saturating) and converted to `f32` saturated to ±2^31 increments.
    ///
    /// Timing: about 40 instructions on a Cortex-M4F (measured on thumbv7em: i64 saturating
    /// subtract 8, saturate to i32 and convert 10, multiply-add, the limiter 10, stores). No
    /// library calls.
    #[inline]
    pub fn step(&mut self, position_ref: i64, position: i64, velocity_ff: f32) -> f32 {
        let error = position_ref.saturating_sub(position);
        self.following_error = error;
        clamp_symmetric(
            self.kp * saturating_to_f32(error) + velocity_ff,
            self.velocity_limit,
        )
    }

    /// The last position error `position_ref − position` (increments), for the following-error
    /// supervision (6065h/6066h) and 60F4h.
    pub fn following_error(&self) -> i64 {
        self.following_error
    }

    /// The gain (1/s).
    pub fn kp(&self) -> f32 {
        self.kp
    }

    /// Changes the gain; NaN, infinite or negative values become 0.
    pub fn set_kp(&mut self, kp: f32) {
        self.kp = non_negative(kp);
    }

    /// The velocity limit (increments/s).
    pub fn velocity_limit(&self) -> f32 {
        self.velocity_limit
    }

    /// Changes the velocity limit; NaN, infinite or negative values become 0.
    pub fn set_velocity_limit(&mut self, velocity_limit: f32) {
        self.velocity_limit = non_negative(velocity_limit);
    }

    /// Forgets the last error.
    pub fn reset(&mut self) {
        self.following_error = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const FS: f64 = 10_000.0;
    const KP: f32 = 50.0;

    /// Runs the loop on an ideal velocity follower (the position integrates the command exactly,
    /// measured rounded to whole increments) along the ramp p_ref = v·t, and returns the
    /// following error averaged over the last 1,000 samples.
    fn ramp_following_error(v: f64, feed_forward: bool) -> f64 {
        let mut lp = PositionLoop::new(KP, 1e9);
        let mut p = 0.0f64;
        let mut sum = 0.0;
        let n = 20_000;
        for k in 0..n {
            let p_ref = (v * k as f64 / FS).round() as i64;
            let ff = if feed_forward { v as f32 } else { 0.0 };
            let cmd = lp.step(p_ref, p.round() as i64, ff);
            if k >= n - 1_000 {
                sum += lp.following_error() as f64;
            }
            p += cmd as f64 / FS;
        }
        sum / 1_000.0
    }

    #[test]
    fn ramp_following_error_is_v_over_kp_without_feed_forward() {
        // Steady state of p[k+1] = p[k] + kp·e·Ts along a ramp: the increment v·Ts equals
        // kp·e·Ts, so e = v/kp exactly; the measurement rounding adds at most ±1 increment.
        for v in [10_000.0f64, 250_000.0] {
            let e = ramp_following_error(v, false);
            let expected = v / KP as f64;
            assert!((e - expected).abs() <= 1.0, "v {v}: {e} vs {expected}");
        }
    }

    #[test]
    fn velocity_feed_forward_removes_the_ramp_following_error() {
        for v in [10_000.0f64, 250_000.0] {
            let e = ramp_following_error(v, true);
            assert!(e.abs() <= 1.0, "v {v}: {e}");
        }
    }

    #[test]
    fn command_is_limited_and_extreme_positions_do_not_overflow() {
        let mut lp = PositionLoop::new(KP, 1_000.0);
        assert_eq!(lp.step(1_000_000, 0, 0.0), 1_000.0);
        assert_eq!(lp.step(-1_000_000, 0, 0.0), -1_000.0);
        assert_eq!(lp.step(i64::MAX, i64::MIN, 0.0), 1_000.0);
        assert_eq!(lp.following_error(), i64::MAX);
        assert_eq!(lp.step(i64::MIN, i64::MAX, 0.0), -1_000.0);
        assert_eq!(
            lp.step(5, 5, f32::NAN),
            -1_000.0,
            "NaN never passes the limiter"
        );
        let mut bad = PositionLoop::new(f32::NAN, -5.0);
        assert_eq!(bad.step(100, 0, 0.0), 0.0);
    }

    #[test]
    fn saturating_conversion() {
        assert_eq!(saturating_to_f32(-123), -123.0);
        assert_eq!(saturating_to_f32(1 << 40), i32::MAX as f32);
        assert_eq!(saturating_to_f32(i64::MIN), i32::MIN as f32);
    }
}
