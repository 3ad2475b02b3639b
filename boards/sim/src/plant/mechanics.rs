//! Rigid single-mass mechanics with viscous and Coulomb friction, stiction, hard end stops,
//! and the limit/home switches.
//!
//! `J·dω/dt = T − B·ω − Tc·sign(ω)` with `T = Te − T_load` and `J = J_rotor + J_load`.
//!
//! Integration per substep `h`, torque `T` held constant (the caller passes the mean of the
//! substep's start and end electromagnetic torque):
//! * moving (`ω ≠ 0`) or breaking away (`|T| > Tc`): the friction direction is fixed for the
//!   step and the linear ODE is solved exactly,
//!   `Δω = (T − Tc·dir − B·ω)·(h/J)·φ(hB/J)` with `φ(x) = (1 − e^{−x})/x` (so `B = 0` is exact
//!   too); the angle advances by the trapezoid `h·(ω0 + ω1)/2`;
//! * if Coulomb friction would reverse the motion within the step, the rotor stops exactly
//!   (`ω = 0`), and then
//! * stiction: at `ω = 0` the rotor stays stuck while `|T| ≤ Tc` — no chattering around zero.
//!
//! End stops are inelastic: the angle is clamped to the stop and the speed component into the
//! stop is removed; a motor pushing against the stop stays there, pulling away is free.

/// Load and friction of the axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MechParams {
    /// Load inertia reflected to the motor shaft, kg·m² (added to the rotor inertia).
    pub load_inertia_kgm2: f64,
    /// Viscous friction coefficient `B` in N·m/(rad/s).
    pub viscous_nm_per_rad_s: f64,
    /// Coulomb (dry) friction torque `Tc` in N·m; also the breakaway (stiction) torque.
    pub coulomb_nm: f64,
    /// Hard end stops `(low, high)` as mechanical angles in rad, or `None` for free rotation.
    pub end_stops_rad: Option<(f64, f64)>,
}

/// Limit and home switches, evaluated on the true (unwrapped) mechanical angle.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SwitchParams {
    /// Negative limit switch, active for positions `<= limit_neg_rad`.
    pub limit_neg_rad: Option<f64>,
    /// Positive limit switch, active for positions `>= limit_pos_rad`.
    pub limit_pos_rad: Option<f64>,
    /// Home switch, active for positions `>= home_rad` (up to `home_end_rad`).
    pub home_rad: Option<f64>,
    /// The end of a home cam: with it, the home switch is active for
    /// `home_rad <= θ <= home_end_rad` only.
    pub home_end_rad: Option<f64>,
    /// Touch-probe sensors 1 and 2: input n is active for `a <= θ <= b` (a mark passing a
    /// sensor); their edges are timed within the integration substep.
    pub probes: [Option<(f64, f64)>; 2],
}

/// States of the three switches (`true` = actuated).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SwitchStates {
    /// Negative limit switch actuated.
    pub limit_neg: bool,
    /// Positive limit switch actuated.
    pub limit_pos: bool,
    /// Home switch actuated.
    pub home: bool,
}

impl SwitchParams {
    /// Switch states at mechanical angle `theta_rad`.
    pub fn evaluate(&self, theta_rad: f64) -> SwitchStates {
        SwitchStates {
            limit_neg: self.limit_neg_rad.is_some_and(|l| theta_rad <= l),
            limit_pos: self.limit_pos_rad.is_some_and(|l| theta_rad >= l),
            home: self.home_rad.is_some_and(|l| theta_rad >= l)
                && self.home_end_rad.is_none_or(|e| theta_rad <= e),
        }
    }

    /// Whether touch-probe input `n` is active at `theta_rad`.
    pub fn probe_active(&self, n: usize, theta_rad: f64) -> bool {
        self.probes
            .get(n)
            .copied()
            .flatten()
            .is_some_and(|(a, b)| theta_rad >= a && theta_rad <= b)
    }

    /// The angle at which probe `n`'s input changed to `active` while the rotor moved from
    /// `from` to `to` (the window edge crossed), `None` if it has no window.
    pub fn probe_edge(&self, n: usize, active: bool, from: f64, to: f64) -> Option<f64> {
        let (a, b) = self.probes.get(n).copied().flatten()?;
        let upward = to >= from;
        Some(match (active, upward) {
            (true, true) | (false, false) => a,
            (true, false) | (false, true) => b,
        })
    }
}

/// Mechanical state: unwrapped angle and speed.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MechState {
    /// Mechanical angle in rad (multi-turn).
    pub theta_rad: f64,
    /// Mechanical speed in rad/s.
    pub omega_rad_s: f64,
}

/// Below this `hB/J` the series of `φ(x) = (1 − e^{−x})/x` is used (avoids 0/0).
const PHI_SERIES_LIMIT: f64 = 1e-9;

/// `φ(x) = (1 − e^{−x})/x`, with `φ(0) = 1`.
fn phi(x: f64) -> f64 {
    if x < PHI_SERIES_LIMIT {
        1.0 - 0.5 * x
    } else {
        -(-x).exp_m1() / x
    }
}

/// The parts of a mechanical step that depend only on its length, the inertia and the viscous
/// friction: a plant whose steps repeat computes them once ([`MechParams::step_by`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MechStep {
    /// Step length `h`, s.
    pub h: f64,
    /// `h/J`.
    pub h_over_j: f64,
    /// `φ(hB/J)`, the exact speed update's factor.
    pub phi: f64,
}

impl MechStep {
    /// The step of length `h` with total inertia `inertia_kgm2` under `params`' friction.
    pub fn new(params: &MechParams, inertia_kgm2: f64, h: f64) -> Self {
        let h_over_j = h / inertia_kgm2;
        Self {
            h,
            h_over_j,
            phi: phi(h_over_j * params.viscous_nm_per_rad_s),
        }
    }
}

impl MechParams {
    /// Advances `s` by `h` seconds under the net external torque `torque_nm` (`Te − T_load`)
    /// with total inertia `inertia_kgm2`.
    pub fn step(&self, s: MechState, torque_nm: f64, inertia_kgm2: f64, h: f64) -> MechState {
        self.step_by(s, torque_nm, &MechStep::new(self, inertia_kgm2, h))
    }

    /// [`Self::step`] with the step's constants computed beforehand (`step` made them with
    /// these parameters' viscous friction).
    pub fn step_by(&self, s: MechState, torque_nm: f64, step: &MechStep) -> MechState {
        let MechStep { h, h_over_j, phi } = *step;
        let w0 = s.omega_rad_s;
        if w0 == 0.0 && torque_nm.abs() <= self.coulomb_nm {
            return s; // stiction
        }
        let dir = if w0 != 0.0 {
            w0.signum()
        } else {
            torque_nm.signum()
        };
        let b = self.viscous_nm_per_rad_s;
        let net = torque_nm - self.coulomb_nm * dir - b * w0;
        let mut w1 = w0 + net * h_over_j * phi;
        if w1 * dir < 0.0 {
            // Friction cannot reverse the motion: the rotor stops within this step.
            w1 = 0.0;
        }
        let mut theta = s.theta_rad + 0.5 * h * (w0 + w1);
        if let Some((lo, hi)) = self.end_stops_rad {
            if theta <= lo {
                theta = lo;
                w1 = w1.max(0.0);
            } else if theta >= hi {
                theta = hi;
                w1 = w1.min(0.0);
            }
        }
        MechState {
            theta_rad: theta,
            omega_rad_s: w1,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const J: f64 = 2e-4;
    const H: f64 = 1e-5;

    fn free() -> MechParams {
        MechParams {
            load_inertia_kgm2: 0.0,
            viscous_nm_per_rad_s: 0.0,
            coulomb_nm: 0.0,
            end_stops_rad: None,
        }
    }

    fn run(m: &MechParams, mut s: MechState, torque: f64, t: f64) -> MechState {
        let n = (t / H).round() as usize;
        for _ in 0..n {
            s = m.step(s, torque, J, H);
        }
        s
    }

    #[test]
    fn constant_torque_accelerates_at_t_over_j() {
        let s = run(&free(), MechState::default(), 0.5, 0.1);
        let alpha = 0.5 / J;
        assert!((s.omega_rad_s - alpha * 0.1).abs() < 1e-9 * alpha);
        // θ = α t²/2 (the trapezoid is exact for constant acceleration).
        assert!((s.theta_rad - 0.5 * alpha * 0.01).abs() < 1e-9 * alpha);
    }

    #[test]
    fn viscous_decay_has_time_constant_j_over_b() {
        let m = MechParams {
            viscous_nm_per_rad_s: 1e-3,
            ..free()
        };
        let tau = J / m.viscous_nm_per_rad_s;
        let s0 = MechState {
            theta_rad: 0.0,
            omega_rad_s: 100.0,
        };
        let s = run(&m, s0, 0.0, tau);
        assert!((s.omega_rad_s - 100.0 * (-1.0f64).exp()).abs() < 1e-9);
    }

    #[test]
    fn stiction_holds_below_breakaway_and_moves_above() {
        let m = MechParams {
            coulomb_nm: 0.1,
            ..free()
        };
        let held = run(&m, MechState::default(), 0.099, 0.05);
        assert_eq!(held, MechState::default());
        let held_neg = run(&m, MechState::default(), -0.1, 0.05);
        assert_eq!(held_neg, MechState::default());
        let moved = run(&m, MechState::default(), 0.15, 0.05);
        let expected = (0.15 - 0.1) / J * 0.05;
        assert!((moved.omega_rad_s - expected).abs() < 1e-9 * expected);
    }

    #[test]
    fn coulomb_friction_stops_the_rotor_without_chattering() {
        let m = MechParams {
            coulomb_nm: 0.1,
            ..free()
        };
        let mut s = MechState {
            theta_rad: 0.0,
            omega_rad_s: 10.0,
        };
        // Decelerates at Tc/J = 500 rad/s²: stops after 20 ms, travels ω0²/(2a) = 0.1 rad.
        s = run(&m, s, 0.0, 0.03);
        assert_eq!(s.omega_rad_s, 0.0);
        assert!((s.theta_rad - 0.1).abs() < 1e-4, "{}", s.theta_rad);
        let later = run(&m, s, 0.05, 0.05);
        assert_eq!(later, s, "stuck rotor must not creep or chatter");
    }

    #[test]
    fn end_stop_stops_the_rotor_and_holds_it() {
        let m = MechParams {
            end_stops_rad: Some((-1.0, 1.0)),
            ..free()
        };
        let s = run(&m, MechState::default(), 0.2, 0.5);
        assert_eq!(s.theta_rad, 1.0);
        assert_eq!(s.omega_rad_s, 0.0);
        // Pulling away from the stop is free.
        let back = run(&m, s, -0.2, 0.01);
        assert!(back.theta_rad < 1.0 && back.omega_rad_s < 0.0);
    }

    #[test]
    fn switches_follow_the_angle() {
        let sw = SwitchParams {
            limit_neg_rad: Some(-2.0),
            limit_pos_rad: Some(2.0),
            home_rad: Some(0.5),
            home_end_rad: None,
            probes: [None; 2],
        };
        assert_eq!(
            sw.evaluate(0.0),
            SwitchStates {
                limit_neg: false,
                limit_pos: false,
                home: false
            }
        );
        assert!(sw.evaluate(-2.0).limit_neg);
        assert!(sw.evaluate(2.5).limit_pos && sw.evaluate(2.5).home);
        assert!(sw.evaluate(0.5).home);
        // A home cam: active between its two edges only.
        let cam = SwitchParams {
            home_end_rad: Some(1.0),
            ..sw
        };
        assert!(!cam.evaluate(0.4).home && cam.evaluate(0.7).home && cam.evaluate(1.0).home);
        assert!(!cam.evaluate(1.1).home);
        assert_eq!(
            SwitchParams::default().evaluate(1e9),
            SwitchStates::default()
        );
    }
}
