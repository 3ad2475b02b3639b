//! The deceleration ramp of a stop (a CiA402 quick stop, halt, shutdown or fault reaction with
//! a slow-down or quick-stop ramp): the velocity reference falls linearly from the velocity at
//! the start of the stop to rest and stays there. Runs at the loop rate in the control
//! interrupt, so the ramp does not depend on the bus cycle.
//!
//! Timing: a compare, a multiply and an add per loop tick; no division.

use crate::math;

/// A deceleration ramp to rest.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StopRamp {
    velocity: f32,
    /// Velocity drop per loop tick, increments/s (> 0; `f32::INFINITY` = at once).
    step: f32,
    /// The deceleration, increments/s² (0 for a stop at once).
    deceleration: f32,
}

impl StopRamp {
    /// A ramp from `velocity` (increments/s) at `deceleration` (increments/s², its magnitude)
    /// with loop ticks of `dt_s`. A deceleration of 0 or one that is not finite stops at once:
    /// the speed loop brakes at the current limit.
    pub fn new(velocity: f32, deceleration: f32, dt_s: f32) -> Self {
        let velocity = if velocity.is_finite() { velocity } else { 0.0 };
        let step = deceleration.abs() * dt_s;
        let (step, deceleration) = if step.is_finite() && step > 0.0 {
            (step, deceleration.abs())
        } else {
            (f32::INFINITY, 0.0)
        };
        Self {
            velocity,
            step,
            deceleration,
        }
    }

    /// The velocity reference of the next loop tick.
    pub fn tick(&mut self) -> f32 {
        let magnitude = math::max(self.velocity.abs() - self.step, 0.0);
        self.velocity = if self.velocity < 0.0 {
            -magnitude
        } else {
            magnitude
        };
        self.velocity
    }

    /// The acceleration feed-forward of the ramp (increments/s², opposite to the velocity while
    /// it falls, 0 at rest or for a stop at once).
    pub fn acceleration(&self) -> f32 {
        if self.velocity > 0.0 {
            -self.deceleration
        } else if self.velocity < 0.0 {
            self.deceleration
        } else {
            0.0
        }
    }

    /// Whether the reference has reached 0.
    pub fn done(&self) -> bool {
        self.velocity == 0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn falls_linearly_to_zero_from_either_sign_and_stays() {
        let mut r = StopRamp::new(1_000.0, 4_000.0, 0.1);
        assert_eq!(r.acceleration(), -4_000.0);
        assert_eq!(r.tick(), 600.0);
        assert_eq!(r.tick(), 200.0);
        assert_eq!(r.tick(), 0.0, "no overshoot below zero");
        assert!(r.done());
        assert_eq!((r.tick(), r.acceleration()), (0.0, 0.0));
        let mut r = StopRamp::new(-1_000.0, 4_000.0, 0.1);
        assert_eq!(r.acceleration(), 4_000.0);
        assert_eq!(r.tick(), -600.0);
    }

    #[test]
    fn zero_or_invalid_deceleration_stops_at_once() {
        for (v, a) in [
            (1_000.0, 0.0),
            (1_000.0, f32::NAN),
            (f32::NAN, 1.0),
            (5.0, f32::INFINITY),
        ] {
            let mut r = StopRamp::new(v, a, 0.001);
            assert_eq!(r.tick(), 0.0, "{v} {a}");
            assert!(r.done());
        }
    }
}
