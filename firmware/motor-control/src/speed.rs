//! The speed loop: PI from velocity error to torque, acceleration and torque feed-forward, the
//! torque-reference filters and the torque limit.
//!
//! τ = filters(PI(v_ref − v) + J·a_ff + τ_ff), limited to ±τ_max. The PI gets the limit through
//! [`Pi::update_limited`], so its integrator holds while the output is pinned at the limit
//! (CiA402 6072h may change that limit at any time: [`SpeedLoop::set_torque_limit`]).
//!
//! # Gains from a bandwidth
//! On a rigid inertia J the open loop is L(s) = (kp·s + ki)/(J·s²). [`gains_for_bandwidth`]
//! picks kp = J·ωs (|L| ≈ 1 at ωs) and ki = kp·ωs/4 (the PI zero a factor 4 below the
//! crossover). Then:
//! * phase margin: 180° − 180° + atan(4) = 76° without delays; the computation and PWM delay
//!   (about 1.5 samples) takes ωs·1.5·Ts from it (5° at 100 Hz / 10 kHz), leaving > 60° for
//!   ωs·Ts up to 0.1;
//! * closed loop: (ωs·s + ωs²/4)/(s + ωs/2)²: a double pole at ωs/2, so the response is
//!   1 − (1 − pt)·e^(−pt) with p = ωs/2: 13.5 % overshoot (e^−2) at t = 2/p, within ±2 % after
//!   t = 5.4/p;
//! * a load-torque step τ_L moves the velocity by −(τ_L/J)·t·e^(−pt): peak τ_L/(J·p·e) at t = 1/p,
//!   back within 1 % of that peak after t = 7.6/p.
//!
//! A zero placed closer to the crossover (factor 2 to 3) rejects loads faster but overshoots
//! more and loses phase margin to the delays; 4 keeps the double real pole (no oscillatory
//! mode) and the margin above 60° with the delays.

use super::filters::{FilterError, TorqueFilterConfig, TorqueFilters};
use super::math::{clamp, TAU};
use super::pi::{Pi, PiGains};

/// Ratio of the crossover frequency to the PI zero used by [`gains_for_bandwidth`].
pub const ZERO_BELOW_CROSSOVER: f32 = 4.0;

/// The speed loop's configuration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpeedLoopConfig {
    /// Proportional gain, N·m per (increment/s).
    pub kp: f32,
    /// Integral gain, N·m per increment (N·m per (increment/s) per second).
    pub ki: f32,
    /// Acceleration feed-forward gain: the inertia J in N·m per (increment/s²).
    pub inertia_nm_per_inc_s2: f32,
    /// Torque limit (N·m), symmetric.
    pub torque_limit_nm: f32,
    /// Rate at which [`SpeedLoop::step`] is called, Hz.
    pub sample_hz: f32,
    /// The torque-reference filters.
    pub filters: TorqueFilterConfig,
}

/// Why a [`SpeedLoopConfig`] was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SpeedLoopError {
    /// A gain, the inertia or the torque limit is negative, NaN or infinite.
    InvalidGain,
    /// The sample rate is not a positive finite number.
    InvalidSampleRate,
    /// A torque filter could not be designed.
    Filter(FilterError),
}

impl From<FilterError> for SpeedLoopError {
    fn from(e: FilterError) -> Self {
        SpeedLoopError::Filter(e)
    }
}

/// `(kp, ki)` for a crossover of `bandwidth_hz` on the inertia `inertia_nm_per_inc_s2`:
/// kp = J·ωs, ki = kp·ωs/4 (see the module documentation for the resulting margins and
/// responses).
pub fn gains_for_bandwidth(bandwidth_hz: f32, inertia_nm_per_inc_s2: f32) -> (f32, f32) {
    let omega = TAU * bandwidth_hz;
    let kp = inertia_nm_per_inc_s2 * omega;
    (kp, kp * omega * (1.0 / ZERO_BELOW_CROSSOVER))
}

/// The speed loop's state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpeedLoop {
    pi: Pi,
    inertia: f32,
    /// Torque limit in the positive direction, N·m (≥ 0).
    limit: f32,
    /// Torque limit in the negative direction (its magnitude), N·m.
    limit_negative: f32,
    filters: TorqueFilters,
}

/// `x` when finite, else 0: a NaN must not reach the integrator or the filter states (it would
/// stay there), an infinity not the limiter's input.
///
/// Timing: about 3 instructions.
#[inline]
fn finite_or_zero(x: f32) -> f32 {
    // `is_finite` is an integer compare of the exponent bits: no library call.
    if x.is_finite() {
        x
    } else {
        0.0
    }
}

/// A limit as given if finite and ≥ 0; NaN → 0, +∞ → `f32::MAX`, negative → 0.
fn sanitise_limit(nm: f32) -> f32 {
    clamp(nm, 0.0, f32::MAX)
}

impl SpeedLoop {
    /// A loop for `config`, integrator and filters empty.
    pub fn new(config: &SpeedLoopConfig) -> Result<Self, SpeedLoopError> {
        let fs = config.sample_hz;
        if !(fs.is_finite() && fs > 0.0) {
            return Err(SpeedLoopError::InvalidSampleRate);
        }
        for x in [
            config.kp,
            config.ki,
            config.inertia_nm_per_inc_s2,
            config.torque_limit_nm,
        ] {
            if !(x.is_finite() && x >= 0.0) {
                return Err(SpeedLoopError::InvalidGain);
            }
        }
        let filters = TorqueFilters::new(&config.filters, fs)?;
        let limit = config.torque_limit_nm;
        Ok(Self {
            pi: Pi::new(PiGains {
                kp: config.kp,
                ki_ts: config.ki * (1.0 / fs),
                out_min: -limit,
                out_max: limit,
            }),
            inertia: config.inertia_nm_per_inc_s2,
            limit,
            limit_negative: limit,
            filters,
        })
    }

    /// One step: the torque command (N·m) for the velocity reference `velocity_ref` and the
    /// measured `velocity` (increments/s), the acceleration feed-forward `accel_ff`
    /// (increments/s², multiplied by J) and the torque feed-forward `torque_ff` (N·m, e.g. 60B2h
    /// or a gravity/friction model). Non-finite inputs count as 0.
    ///
    /// Timing: about 65 instructions on a Cortex-M4F with the filters off (measured on
    /// thumbv7em: input checks 10, PI with its limits and anti-windup 40, output limiter 10),
    /// plus about 20 per enabled filter section. No library calls.
    #[inline]
    pub fn step(&mut self, velocity_ref: f32, velocity: f32, accel_ff: f32, torque_ff: f32) -> f32 {
        let error = finite_or_zero(velocity_ref - velocity);
        let ff = finite_or_zero(self.inertia * accel_ff + torque_ff);
        let torque = self
            .pi
            .update_limited(error, ff, -self.limit_negative, self.limit);
        clamp(
            self.filters.update(torque),
            -self.limit_negative,
            self.limit,
        )
    }

    /// Changes the torque limit (N·m; negative or NaN → 0, +∞ → `f32::MAX`). The integrator is
    /// pulled inside the new limit at once.
    pub fn set_torque_limit(&mut self, nm: f32) {
        self.set_torque_limits(nm, nm);
    }

    /// Changes the torque limits in the positive and the negative direction separately
    /// (CiA402 60E0h/60E1h; magnitudes in N·m, sanitised as in [`Self::set_torque_limit`]).
    pub fn set_torque_limits(&mut self, positive_nm: f32, negative_nm: f32) {
        self.limit = sanitise_limit(positive_nm);
        self.limit_negative = sanitise_limit(negative_nm);
        self.pi.gains.out_min = -self.limit_negative;
        self.pi.gains.out_max = self.limit;
        self.pi.set_integral(self.pi.integral());
    }

    /// The torque limit in the positive direction (N·m).
    pub fn torque_limit(&self) -> f32 {
        self.limit
    }

    /// Whether `torque` (N·m) is at or beyond a torque limit.
    pub fn at_torque_limit(&self, torque: f32) -> bool {
        torque >= self.limit || torque <= -self.limit_negative
    }

    /// The integrator (N·m): the torque the loop holds against a constant load.
    pub fn integral(&self) -> f32 {
        self.pi.integral()
    }

    /// Presets the integrator to `torque` (bumpless start against a known load, e.g. a brake
    /// releasing on a vertical axis) and the filters to its steady state.
    pub fn preset(&mut self, torque: f32) {
        let torque = finite_or_zero(torque);
        self.pi.set_integral(torque);
        self.filters.reset(self.pi.integral());
    }

    /// Empties the integrator and the filters.
    pub fn reset(&mut self) {
        self.pi.reset();
        self.filters.reset(0.0);
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::filters::{LowPassConfig, NotchConfig};

    const FS: f32 = 10_000.0;
    const TS: f64 = 1.0 / FS as f64;
    /// A motor of 1e-4 kg·m² with 2^20 increments per turn: J = 1e-4·2π/2^20 N·m/(inc/s²).
    const J: f32 = 1e-4 * TAU / 1_048_576.0;
    const BW: f32 = 100.0;

    fn p() -> f64 {
        TAU as f64 * BW as f64 / 2.0
    }

    fn config(limit: f32) -> SpeedLoopConfig {
        let (kp, ki) = gains_for_bandwidth(BW, J);
        SpeedLoopConfig {
            kp,
            ki,
            inertia_nm_per_inc_s2: J,
            torque_limit_nm: limit,
            sample_hz: FS,
            filters: TorqueFilterConfig::OFF,
        }
    }

    /// Rigid inertia J with a load torque, the loop's command applied one sample after it is
    /// computed (computation and PWM delay), the velocity measured exactly.
    struct Plant {
        velocity: f64,
        pending: f64,
    }

    impl Plant {
        fn new() -> Self {
            Self {
                velocity: 0.0,
                pending: 0.0,
            }
        }

        /// Applies the previous command for one sample and queues `command`.
        fn advance(&mut self, command: f32, load: f64) {
            self.velocity += TS * (self.pending - load) / J as f64;
            self.pending = command as f64;
        }
    }

    /// 1 − (1 − x)e^(−x) is within ±2 % for good once (x − 1)e^(−x) < 0.02.
    fn step_settling_x() -> f64 {
        let mut x = 3.0f64;
        while (x - 1.0) * (-x).exp() > 0.02 {
            x += 1e-4;
        }
        x
    }

    #[test]
    fn step_response_overshoot_and_settling_match_the_double_pole_design() {
        let mut sl = SpeedLoop::new(&config(1.0)).unwrap();
        let mut plant = Plant::new();
        let r = 10_000.0f32; // small step: 2πJ·ωs·r ≈ 4 mN·m, far from the limit
        let mut peak = 0.0f64;
        let mut last_outside = 0.0;
        for k in 0..5_000 {
            let v = plant.velocity;
            peak = peak.max(v);
            if (v - r as f64).abs() > 0.02 * r as f64 {
                last_outside = k as f64 * TS;
            }
            let cmd = sl.step(r, v as f32, 0.0, 0.0);
            assert!(cmd.abs() < 1.0, "saturated: {cmd}");
            plant.advance(cmd, 0.0);
        }
        let overshoot = peak / r as f64 - 1.0;
        let analytic = (-2.0f64).exp();
        // The 1.5-sample delay costs 5° of the 76° margin: a little more overshoot.
        assert!(
            overshoot > analytic - 0.01 && overshoot < analytic + 0.04,
            "overshoot {overshoot}, analytic {analytic}"
        );
        let settle = step_settling_x() / p();
        assert!(
            last_outside < 1.2 * settle && last_outside > 0.8 * settle,
            "settled at {last_outside} s, analytic {settle} s"
        );
        assert!((plant.velocity - r as f64).abs() < 1e-3 * r as f64);
    }

    #[test]
    fn load_step_is_rejected_in_the_analytic_time() {
        let mut sl = SpeedLoop::new(&config(1.0)).unwrap();
        let mut plant = Plant::new();
        let r = 50_000.0f32;
        for _ in 0..5_000 {
            let cmd = sl.step(r, plant.velocity as f32, 0.0, 0.0);
            plant.advance(cmd, 0.0);
        }
        let load = 5e-3f64; // N·m
        let analytic_peak = load / (J as f64 * p() * core::f64::consts::E);
        let mut peak = 0.0f64;
        let mut errors = std::vec::Vec::new();
        for _ in 0..5_000 {
            let cmd = sl.step(r, plant.velocity as f32, 0.0, 0.0);
            plant.advance(cmd, load);
            let e = r as f64 - plant.velocity;
            peak = peak.max(e);
            errors.push(e);
        }
        assert!(
            (peak - analytic_peak).abs() < 0.15 * analytic_peak,
            "peak {peak}, analytic {analytic_peak}"
        );
        // t·e^(−pt) falls below 1 % of its peak 1/(p·e) for good at pt = 7.6 (x·e^(−x) = 0.01/e).
        let x_recover = {
            let mut x = 1.0f64;
            while x * (-x).exp() > 0.01 / core::f64::consts::E {
                x += 1e-4;
            }
            x
        };
        let last_outside = errors
            .iter()
            .rposition(|e| e.abs() > 0.01 * peak)
            .unwrap_or(0) as f64
            * TS;
        let expected = x_recover / p();
        assert!(
            last_outside < 1.2 * expected && last_outside > 0.8 * expected,
            "recovered after {last_outside} s, analytic {expected} s"
        );
        // The integrator now holds the load.
        assert!((sl.integral() as f64 - load).abs() < 0.01 * load);
    }

    #[test]
    fn acceleration_feed_forward_shrinks_the_ramp_tracking_error() {
        // A ramp of a = 10^7 increments/s² (J·a = 6 mN·m). Without feed-forward the error is
        // a·t·e^(−pt), peak a/(p·e); with it only the one-sample delay of the torque remains,
        // an error of about a·Ts that the PI removes.
        let a = 1e7f64;
        let run = |ff: bool| {
            let mut sl = SpeedLoop::new(&config(1.0)).unwrap();
            let mut plant = Plant::new();
            let mut worst = 0.0f64;
            for k in 0..3_000 {
                let r = a * k as f64 * TS;
                let e = r - plant.velocity;
                worst = worst.max(e.abs());
                let acc = if ff { a as f32 } else { 0.0 };
                let cmd = sl.step(r as f32, plant.velocity as f32, acc, 0.0);
                plant.advance(cmd, 0.0);
            }
            worst
        };
        let without = run(false);
        let with = run(true);
        let analytic = a / (p() * core::f64::consts::E);
        assert!(
            (without - analytic).abs() < 0.15 * analytic,
            "{without} vs {analytic}"
        );
        assert!(with < 2.0 * a * TS, "with feed-forward {with}");
        assert!(without / with > 5.0, "ratio {}", without / with);
    }

    #[test]
    fn no_windup_after_a_long_saturated_phase() {
        // Torque limit 10 mN·m, a step of 3·10^6 increments/s: about 190 ms at the limit. The
        // loop leaves saturation at the error e0 = τmax/kp with the integrator still empty and
        // the plant accelerating at τmax/J; from there e(t) = e0·(1 − pt)·e^(−pt), whose
        // undershoot is e0·e^(−2) (13.5 % of e0), independent of how long it was saturated.
        let limit = 0.01f32;
        let mut sl = SpeedLoop::new(&config(limit)).unwrap();
        let mut plant = Plant::new();
        let r = 3.0e6f64;
        let mut saturated = 0;
        let mut peak = 0.0f64;
        for _ in 0..10_000 {
            let cmd = sl.step(r as f32, plant.velocity as f32, 0.0, 0.0);
            assert!(cmd.abs() <= limit);
            if cmd == limit {
                saturated += 1;
            }
            plant.advance(cmd, 0.0);
            peak = peak.max(plant.velocity);
        }
        let saturated_s = saturated as f64 * TS;
        let expected_s = r * J as f64 / limit as f64;
        assert!(
            saturated_s > 0.9 * expected_s,
            "{saturated_s} s at the limit"
        );
        let (kp, _) = gains_for_bandwidth(BW, J);
        let e0 = limit as f64 / kp as f64;
        let overshoot = peak - r;
        assert!(
            overshoot < 1.3 * (-2.0f64).exp() * e0,
            "overshoot {overshoot}, analytic {}",
            (-2.0f64).exp() * e0
        );
        assert!((plant.velocity - r).abs() < 1e-3 * r);
    }

    #[test]
    fn positive_and_negative_torque_limits_are_separate() {
        let mut sl = SpeedLoop::new(&SpeedLoopConfig {
            sample_hz: 10_000.0,
            kp: 1.0,
            ki: 0.0,
            inertia_nm_per_inc_s2: 0.0,
            torque_limit_nm: 5.0,
            filters: Default::default(),
        })
        .expect("valid");
        sl.set_torque_limits(2.0, 0.5);
        assert_eq!(sl.step(1e6, 0.0, 0.0, 0.0), 2.0, "positive limit");
        assert_eq!(sl.step(-1e6, 0.0, 0.0, 0.0), -0.5, "negative limit");
        assert!(sl.at_torque_limit(2.0) && sl.at_torque_limit(-0.5) && !sl.at_torque_limit(1.0));
    }

    #[test]
    fn torque_limit_changes_at_runtime_and_garbage_is_harmless() {
        let mut sl = SpeedLoop::new(&config(1.0)).unwrap();
        for _ in 0..100 {
            assert_eq!(sl.step(1e9, 0.0, 0.0, 0.0), 1.0);
        }
        sl.set_torque_limit(0.25);
        assert_eq!(sl.step(1e9, 0.0, 0.0, 0.0), 0.25);
        assert!(sl.integral() <= 0.25);
        sl.set_torque_limit(f32::NAN);
        assert_eq!(sl.step(1e9, 0.0, 0.0, 0.0), 0.0);
        sl.set_torque_limit(1.0);
        sl.reset();
        assert_eq!(sl.step(f32::NAN, 0.0, f32::INFINITY, f32::NAN), 0.0);
        assert_eq!(sl.integral(), 0.0);
        let mut bad = config(1.0);
        bad.kp = -1.0;
        assert_eq!(SpeedLoop::new(&bad), Err(SpeedLoopError::InvalidGain));
        bad = config(1.0);
        bad.sample_hz = 0.0;
        assert_eq!(SpeedLoop::new(&bad), Err(SpeedLoopError::InvalidSampleRate));
        bad = config(1.0);
        bad.filters.low_pass = LowPassConfig::FirstOrder { cutoff_hz: 6e3 };
        assert_eq!(
            SpeedLoop::new(&bad),
            Err(SpeedLoopError::Filter(FilterError::AboveNyquist))
        );
    }

    #[test]
    fn filtered_loop_stays_stable_and_settles() {
        // A 1 kHz first-order low-pass and a notch at 800 Hz (resonance suppression) well above
        // the 100 Hz crossover: the step still settles without steady-state error.
        let mut cfg = config(1.0);
        cfg.filters = TorqueFilterConfig {
            low_pass: LowPassConfig::FirstOrder { cutoff_hz: 1_000.0 },
            notches: [
                Some(NotchConfig {
                    center_hz: 800.0,
                    bandwidth_hz: 200.0,
                    depth: 0.0,
                }),
                None,
            ],
        };
        let mut sl = SpeedLoop::new(&cfg).unwrap();
        let mut plant = Plant::new();
        let r = 10_000.0f32;
        let mut peak = 0.0f64;
        for _ in 0..10_000 {
            let cmd = sl.step(r, plant.velocity as f32, 0.0, 0.0);
            plant.advance(cmd, 0.0);
            peak = peak.max(plant.velocity);
        }
        assert!((plant.velocity - r as f64).abs() < 1e-3 * r as f64);
        assert!(peak < 1.3 * r as f64, "peak {peak}");
    }
}
