//! Motion profiles generated at the bus-cycle rate (the SYNC0 context) for the profile modes of
//! a drive: a point-to-point move with a trapezoidal velocity (profile position), a velocity
//! ramp (profile velocity) and a slew-rate limit (the torque slope of profile torque). The
//! control interrupt interpolates between the positions generated here as it does between
//! cyclic synchronous targets.
//!
//! Positions are exact: the generator keeps an `i64` position plus a fraction in `[0, 1)`, so a
//! move ends on its target increment and long moves do not drift. The braking distance is that
//! of the discrete ramp (one velocity step of `deceleration · dt` per cycle), so a move from
//! rest never overshoots its target.
//!
//! Timing: one square root ([`math::sqrt`]) and about 30 floating-point operations per step,
//! no division.

use crate::math;

/// Rates below this (increments/s²) count as this: a ramp of 0 would never move or never
/// stop; CiA402 ranges exclude it, but a master can write it.
const MIN_RATE: f32 = 1.0;

/// The limits of a move.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Limits {
    /// Speed limit, increments/s (≥ 0).
    pub velocity: f32,
    /// Acceleration (speed rising), increments/s².
    pub acceleration: f32,
    /// Deceleration (speed falling), increments/s².
    pub deceleration: f32,
}

/// [`Limits`] made fit for the generators ([`Limits::sane`]): what they take, so that the
/// check runs once when a setting changes rather than in every cycle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SaneLimits(Limits);

impl SaneLimits {
    /// At rest: no speed, the gentlest rates.
    pub const REST: Self = Self(Limits {
        velocity: 0.0,
        acceleration: MIN_RATE,
        deceleration: MIN_RATE,
    });

    /// The limits.
    pub fn get(self) -> Limits {
        self.0
    }
}

impl Default for SaneLimits {
    fn default() -> Self {
        Self::REST
    }
}

impl Limits {
    /// The limits with every rate at least 1 increment/s² (`MIN_RATE`: a ramp of 0 would never
    /// move or never stop) and a finite, non-negative speed.
    pub fn sane(self) -> SaneLimits {
        let rate = |r: f32| {
            if r.is_finite() {
                math::max(r.abs(), MIN_RATE)
            } else {
                MIN_RATE
            }
        };
        SaneLimits(Self {
            velocity: if self.velocity.is_finite() {
                self.velocity.abs()
            } else {
                0.0
            },
            acceleration: rate(self.acceleration),
            deceleration: rate(self.deceleration),
        })
    }
}

/// The demand of a profile mode: position (increments) and velocity (increments/s).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Trajectory {
    position: i64,
    /// The position's fraction of an increment, `0 ≤ fraction < 1`.
    fraction: f32,
    velocity: f32,
}

impl Trajectory {
    /// A trajectory at `position` moving at `velocity` (the axis' actual values when a profile
    /// mode takes over).
    pub const fn at(position: i64, velocity: f32) -> Self {
        Self {
            position,
            fraction: 0.0,
            velocity: if velocity.is_finite() { velocity } else { 0.0 },
        }
    }

    /// The demand position, increments (rounded down).
    pub fn position(&self) -> i64 {
        self.position
    }

    /// The demand velocity, increments/s.
    pub fn velocity(&self) -> f32 {
        self.velocity
    }

    /// One cycle of `dt_s` toward `target`, to pass it at `end_speed` (increments/s, in the
    /// direction of travel; 0 = stop on it). Returns `true` in the cycle the demand reaches
    /// the target: it is then exactly on it at rest or, with an end speed, past it by the rest of
    /// the cycle's travel, moving on at the speed reached.
    pub fn move_to(&mut self, target: i64, end_speed: f32, limits: SaneLimits, dt_s: f32) -> bool {
        let limits = limits.0;
        let end_speed = math::clamp(end_speed, 0.0, limits.velocity);
        // Beyond 2^31 increments the distance only has to be long enough to need no braking.
        let remaining = math::saturating_f32(target.wrapping_sub(self.position)) - self.fraction;
        let direction = math::sign(remaining);
        let distance = remaining.abs();
        // Speed toward the target (negative while moving away from it).
        let speed = self.velocity * direction;
        let braking = braking_speed(distance, end_speed, limits.deceleration, dt_s);
        let wanted = math::min(limits.velocity, braking);
        let new_speed = if speed < wanted {
            // Speeding up toward the target, or braking a motion away from it.
            let rate = if speed >= 0.0 {
                limits.acceleration
            } else {
                limits.deceleration
            };
            math::min(speed + rate * dt_s, wanted)
        } else {
            math::max(speed - limits.deceleration * dt_s, wanted)
        };
        let travel = new_speed * dt_s;
        // A speed the ramp takes to rest in one step (slack for the rounding of the root).
        let one_step = limits.deceleration * dt_s * 1.001 + MIN_RATE;
        let slow = new_speed <= one_step;
        if end_speed > 0.0 && travel >= distance {
            // Passing the target: through it, moving on by the rest of this cycle's travel
            // (the next move continues in the same direction).
            self.land_on(target, new_speed * direction);
            self.advance((travel - distance) * direction);
            return true;
        }
        if end_speed == 0.0 && slow && (travel >= distance || distance < 0.5) {
            if speed.abs() <= one_step {
                // The last step of the ramp: at rest on the target.
                self.land_on(target, 0.0);
                return true;
            }
            // On the target this cycle; rest in the next (one velocity step at a time).
            self.land_on(target, new_speed * direction);
            return false;
        }
        self.velocity = new_speed * direction;
        self.advance(self.velocity * dt_s);
        false
    }

    /// One cycle of `dt_s` of a velocity ramp toward `velocity` (limited to the speed limit):
    /// speeding up at the acceleration, slowing down (and through zero) at the deceleration.
    pub fn run_at(&mut self, velocity: f32, limits: SaneLimits, dt_s: f32) {
        let limits = limits.0;
        let target = math::clamp_symmetric(velocity, limits.velocity);
        let v = self.velocity;
        let slowing = v != 0.0 && (target * v < 0.0 || target.abs() < v.abs());
        let rate = if slowing {
            limits.deceleration
        } else {
            limits.acceleration
        };
        let mut next = slew(v, target, rate * dt_s);
        if slowing && next * v < 0.0 {
            // Through zero: rest first, then the acceleration applies.
            next = 0.0;
        }
        self.velocity = next;
        self.advance(next * dt_s);
    }

    /// Puts the demand exactly on `target`, moving at `velocity`.
    fn land_on(&mut self, target: i64, velocity: f32) {
        self.position = target;
        self.fraction = 0.0;
        self.velocity = velocity;
    }

    /// Moves the demand position by `distance` increments, keeping the fraction.
    fn advance(&mut self, distance: f32) {
        let total = self.fraction + distance;
        let whole = floor(total);
        self.position = self.position.saturating_add(whole);
        self.fraction = math::clamp(total - math::saturating_f32(whole), 0.0, 0.999_999_94);
    }
}

/// The highest speed from which the discrete ramp (velocity steps of `deceleration · dt_s`,
/// one per cycle) still comes down to `end_speed` within `distance`: with h = a·dt/2,
/// v = √(h² + 2·a·d + v_end²) − h (for v_end = 0, k steps of a·dt cover a·dt²·k(k+1)/2).
pub fn braking_speed(distance: f32, end_speed: f32, deceleration: f32, dt_s: f32) -> f32 {
    let half_step = 0.5 * deceleration * dt_s;
    math::sqrt(half_step * half_step + 2.0 * deceleration * distance + end_speed * end_speed)
        - half_step
}

/// `value` moved toward `target` by at most `step` (≥ 0).
pub fn slew(value: f32, target: f32, step: f32) -> f32 {
    value + math::clamp_symmetric(target - value, step)
}

/// ⌊x⌋ as an integer, saturating at the i32 range (`core` has no `f32::floor`; one cycle's
/// travel is far inside it, and 32-bit conversions are single FPU instructions).
fn floor(x: f32) -> i64 {
    let t = x as i32;
    i64::from(if (t as f32) > x {
        t.saturating_sub(1)
    } else {
        t
    })
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::vec::Vec;

    const DT: f32 = 1e-3;
    /// 3000 rpm of a 2^20-count encoder, and ramps of 0.1 s to that speed.
    const FAST: Limits = Limits {
        velocity: 52_428_800.0,
        acceleration: 524_288_000.0,
        deceleration: 524_288_000.0,
    };

    /// Runs a move to `target` until it arrives; the demand positions of every cycle.
    fn run_move(from: Trajectory, target: i64, limits: Limits) -> Vec<(i64, f32)> {
        let mut t = from;
        let mut path = Vec::new();
        for _ in 0..1_000_000 {
            let arrived = t.move_to(target, 0.0, limits.sane(), DT);
            path.push((t.position(), t.velocity()));
            if arrived {
                return path;
            }
        }
        panic!("no arrival at {target}: at {:?}", t);
    }

    fn check_limits(path: &[(i64, f32)], start_v: f32, limits: Limits) {
        let mut v = start_v;
        for (i, &(_, nv)) in path.iter().enumerate() {
            let context = &path[i.saturating_sub(3)..(i + 3).min(path.len())];
            assert!(nv.abs() <= limits.velocity * 1.0001 + 1.0, "speed {nv}");
            let rate = limits.acceleration.max(limits.deceleration);
            assert!(
                (nv - v).abs() <= rate * DT * 1.001 + 1.0,
                "velocity step {} > {} at {context:?}",
                nv - v,
                rate * DT
            );
            v = nv;
        }
    }

    #[test]
    fn moves_from_rest_end_exactly_on_target_without_overshoot() {
        let limits = Limits {
            velocity: 1_000_000.0,
            acceleration: 20_000_000.0,
            deceleration: 5_000_000.0,
        };
        for target in [1, 7, 1_000, 123_457, 10_000_001, -3, -987_654_321] {
            let path = run_move(Trajectory::at(0, 0.0), target, limits);
            let (last, v) = *path.last().unwrap();
            assert_eq!((last, v), (target, 0.0));
            check_limits(&path, 0.0, limits);
            for w in path.windows(2) {
                // Monotonic toward the target: no overshoot, no step back.
                assert!(
                    (w[1].0 - w[0].0) * target.signum() >= 0,
                    "step back at {w:?}"
                );
                assert!(
                    (w[1].0 - target) * target.signum() <= 0,
                    "overshoot at {w:?}"
                );
            }
        }
    }

    #[test]
    fn a_long_move_reaches_its_speed_and_takes_the_trapezoid_time() {
        // 10 revolutions at 3000 rpm: 0.1 s up, 0.1 s down, the rest at speed: 10/50 s + 0.1 s.
        let target = 10 << 20;
        let path = run_move(Trajectory::at(0, 0.0), target, FAST);
        let peak = path.iter().map(|p| p.1).fold(0.0, f32::max);
        assert!((peak - FAST.velocity).abs() < 1.0, "peak {peak}");
        let expected_cycles = (0.2 + 0.1) / DT;
        assert!(
            (path.len() as f32 - expected_cycles).abs() <= 3.0,
            "{} cycles, expected {expected_cycles}",
            path.len()
        );
    }

    #[test]
    fn a_move_against_the_motion_brakes_then_returns() {
        // Moving at +1000 inc/s... to a target behind: decelerate, reverse, arrive.
        let limits = Limits {
            velocity: 50_000.0,
            acceleration: 100_000.0,
            deceleration: 200_000.0,
        };
        let start = Trajectory::at(0, 40_000.0);
        let path = run_move(start, -5_000, limits);
        assert_eq!(*path.last().unwrap(), (-5_000, 0.0));
        check_limits(&path, 40_000.0, limits);
        let furthest = path.iter().map(|p| p.0).max().unwrap();
        // v²/(2a) = 4000 increments of braking distance (± one step).
        assert!((3_900..=4_100).contains(&furthest), "braked at {furthest}");
    }

    #[test]
    fn a_target_too_close_to_stop_before_is_overshot_and_then_reached() {
        let limits = Limits {
            velocity: 50_000.0,
            acceleration: 100_000.0,
            deceleration: 100_000.0,
        };
        let path = run_move(Trajectory::at(0, 50_000.0), 1_000, limits);
        assert_eq!(*path.last().unwrap(), (1_000, 0.0));
        assert!(path.iter().any(|p| p.0 > 1_000), "overshoot expected");
        check_limits(&path, 50_000.0, limits);
    }

    #[test]
    fn an_end_speed_passes_the_target_moving() {
        let limits = Limits {
            velocity: 100_000.0,
            acceleration: 1_000_000.0,
            deceleration: 1_000_000.0,
        };
        let mut t = Trajectory::at(0, 0.0);
        let mut arrived = false;
        for _ in 0..10_000 {
            if t.move_to(20_000, 60_000.0, limits.sane(), DT) {
                arrived = true;
                break;
            }
        }
        assert!(arrived);
        // Through the target by the rest of the cycle's travel (at most one cycle's worth).
        assert!(
            (20_000..=20_000 + 60).contains(&t.position()),
            "{}",
            t.position()
        );
        assert!(
            (t.velocity() - 60_000.0).abs() <= 1_000.0,
            "{}",
            t.velocity()
        );
    }

    #[test]
    fn velocity_ramps_use_acceleration_up_and_deceleration_down_through_zero() {
        let limits = Limits {
            velocity: 10_000.0,
            acceleration: 100_000.0,
            deceleration: 400_000.0,
        };
        let mut t = Trajectory::at(0, 0.0);
        let mut cycles = 0;
        while t.velocity() < 10_000.0 {
            t.run_at(50_000.0, limits.sane(), DT); // limited to 10 000
            cycles += 1;
        }
        assert_eq!(cycles, 100, "0.1 s at 100 000 inc/s²");
        let mut down = 0;
        while t.velocity() > 0.0 {
            t.run_at(-10_000.0, limits.sane(), DT);
            down += 1;
        }
        assert_eq!(
            (down, t.velocity()),
            (25, 0.0),
            "rest first, at the deceleration"
        );
        t.run_at(-10_000.0, limits.sane(), DT);
        assert!((t.velocity() + 100.0).abs() < 1e-3, "then the acceleration");
        // The position integrates the velocity: 0.1 s ramp (500) + 25 ms down (125) - 0.1.
        assert!((t.position() - 625).abs() <= 1, "{}", t.position());
    }

    #[test]
    fn degenerate_limits_neither_panic_nor_stall_forever() {
        let zero = Limits::default();
        let mut t = Trajectory::at(5, f32::NAN);
        assert_eq!(t.velocity(), 0.0);
        assert!(
            !t.move_to(100, 0.0, zero.sane(), DT),
            "no speed allowed: no motion"
        );
        assert_eq!(t.position(), 5);
        let nan = Limits {
            velocity: f32::NAN,
            acceleration: f32::INFINITY,
            deceleration: -3.0,
        };
        t.move_to(i64::MAX, f32::NAN, nan.sane(), DT);
        t.run_at(f32::INFINITY, nan.sane(), DT);
        let mut far = Trajectory::at(i64::MAX - 2, 1e30);
        far.run_at(1e30, FAST.sane(), DT);
        assert_eq!(far.position(), i64::MAX, "saturates");
        assert!(
            Trajectory::at(3, 0.0).move_to(3, 0.0, FAST.sane(), DT),
            "already there"
        );
    }

    #[test]
    fn random_moves_arrive_exactly_within_their_limits() {
        // Fixed-seed LCG: start velocities either way, targets either side, speeds 10^2..10^7.
        let mut seed = 0x2545_F491_4F6C_DD1Du64;
        let mut next = |range: f64| {
            seed = seed
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 * range
        };
        for _ in 0..2_000 {
            let velocity = 10f64.powf(2.0 + next(5.0)) as f32;
            let limits = Limits {
                velocity,
                // Full speed within 1 s .. 1 ms.
                acceleration: velocity * 10f64.powf(next(3.0)) as f32,
                deceleration: velocity * 10f64.powf(next(3.0)) as f32,
            };
            let start_v = (next(2.0) - 1.0) as f32 * velocity;
            let target = (next(2.0) - 1.0) * f64::from(velocity) * 2.0;
            let path = run_move(Trajectory::at(0, start_v), target as i64, limits);
            assert_eq!(*path.last().unwrap(), (target as i64, 0.0), "{limits:?}");
            check_limits(&path, start_v, limits);
        }
    }

    #[test]
    fn slew_and_floor() {
        assert_eq!(slew(0.0, 10.0, 3.0), 3.0);
        assert_eq!(slew(0.0, -10.0, 3.0), -3.0);
        assert_eq!(slew(9.0, 10.0, 3.0), 10.0);
        assert_eq!(floor(-0.5), -1);
        assert_eq!(floor(2.0), 2);
        assert_eq!(floor(-2.0), -2);
        assert_eq!(
            floor(1e30),
            i64::from(i32::MAX),
            "saturates at the i32 range"
        );
        assert_eq!(floor(-1e30), i64::from(i32::MIN));
    }
}
