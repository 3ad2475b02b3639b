//! The current loop (field-oriented control), run once per PWM period in the control interrupt.
//!
//! ```text
//!  ia ib ic ─ Clarke ─ Park(θ) ─ id,iq ─┬─ PI d ─(+ vd_ff)─┬─ circle ─ inverse Park(θ + 1.5·ω·Ts)
//!                                       └─ PI q ─(+ vq_ff)─┘  limiter        ─ SVPWM ─ dead time
//! ```
//!
//! * Clarke from all three measured currents (amplitude-invariant): i_α = (2ia − ib − ic)/3,
//!   i_β = (ib − ic)/√3. A common-mode error (the same offset in all three shunts) cancels.
//! * PI per axis tuned by pole-zero cancellation: kp = L·ωc, ki = R·ωc. The PI zero cancels the
//!   winding's pole R/L, so the closed loop is first order with the bandwidth ωc = 2π·bandwidth
//!   (plus the delay below).
//! * Decoupling feed-forward (optional): the dq model is
//!   vd = R·id + Ld·did/dt − ω·Lq·iq, vq = R·iq + Lq·diq/dt + ω·(Ld·id + ψ); the speed-dependent
//!   terms are added to the PI outputs so that each PI sees a plain R-L load.
//! * Voltage-circle limiter: |v| ≤ vmax = max_modulation·Vbus/√3, d-axis first (it holds the
//!   field: flux weakening and stability at speed need it), q gets what is left. Each PI is
//!   limited to its share, feed-forward included, and integrates conditionally by the rule of
//!   [`Pi::update_limited`](super::pi::Pi::update_limited) (hold while the output is pinned at
//!   the limit and the error pushes further), so a saturated integrator does not wind up.
//! * Latency: the currents are sampled at the start of a period, the voltage computed from them
//!   is loaded into the timer for the next period and is on average applied half a period into
//!   it: 1.5 periods after the sampling instant. The rotor turns by δ = ω·1.5·Ts meanwhile, so the
//!   inverse Park transformation uses θ + δ.
//! * Then [`svpwm::modulate`] (with over-modulation when `max_modulation` > 1) and
//!   [`svpwm::compensate_dead_time`].

use super::math::{sin_cos, sqrt_unguarded, INV_SQRT3, TAU, TWO_INV_SQRT3};
use super::pi::PiGains;
use super::svpwm;
use super::{Duties, ElectricalAngle};
use hal::power::PhaseCurrents;

/// Highest current-loop bandwidth as a fraction of the PWM frequency. With the 1.5-period delay
/// the phase margin of the cancelled loop is 90° − ωc·1.5·Ts: 56° at f_pwm/8. Above that the
/// discrete closed loop rings, and near f_pwm/4 it is unstable.
pub const MAX_BANDWIDTH_FRACTION: f32 = 1.0 / 8.0;
/// Largest `max_modulation`: 2/√3 of the inscribed circle is the hexagon's corner (2/3·Vbus).
pub const MAX_MODULATION_LIMIT: f32 = TWO_INV_SQRT3;
/// Largest dead time as a fraction of the PWM period: more is a configuration error (a gate
/// driver with a dead time of a tenth of the period is not a working inverter).
pub const MAX_DEAD_TIME_DUTY: f32 = 0.1;
/// Periods between the sampling instant and the mean instant the resulting voltage is applied:
/// one for computation and the timer's preload, half for the zero-order hold of the PWM period.
pub const LATENCY_PERIODS: f32 = 1.5;
/// 1/3, the Clarke transformation's weight.
const ONE_THIRD: f32 = 1.0 / 3.0;
/// 1/6: the cubic term of sin δ ≈ δ·(1 − δ²/6).
const SIXTH: f32 = 1.0 / 6.0;

/// A configuration value the current loop (or a calibration) cannot work with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ConfigError {
    /// The name of the offending configuration field.
    pub parameter: &'static str,
    /// What is wrong with it and what is expected.
    pub reason: &'static str,
}

impl core::fmt::Display for ConfigError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "{}: {}", self.parameter, self.reason)
    }
}

/// The motor and inverter parameters the current loop is designed from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CurrentLoopConfig {
    /// Phase (star-equivalent) resistance in Ω.
    pub resistance_ohm: f32,
    /// d-axis inductance in H.
    pub ld_h: f32,
    /// q-axis inductance in H.
    pub lq_h: f32,
    /// Permanent-magnet flux linkage (peak, per phase) in Wb = V·s/rad electrical; 0 for a motor
    /// without magnets (or while identifying R and L).
    pub flux_wb: f32,
    /// PWM (= current-loop) frequency in Hz.
    pub pwm_hz: f32,
    /// Closed-loop current bandwidth in Hz; below `pwm_hz`/8.
    pub bandwidth_hz: f32,
    /// Fraction of the hexagon-inscribed circle Vbus/√3 the PI may use, e.g. 0.95; values above 1
    /// (up to 2/√3, the hexagon's corners) allow over-modulation.
    pub max_modulation: f32,
    /// Inverter dead time in s (0 disables the compensation).
    pub dead_time_s: f32,
    /// Current band in A around zero within which the dead-time compensation ramps linearly.
    pub dead_time_band_a: f32,
    /// Whether to feed forward the speed-dependent cross-coupling and back-EMF terms.
    pub decoupling: bool,
}

/// The measurements and references of one period.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CurrentLoopInput {
    /// Phase currents, offset-corrected, in A (positive out of the inverter into the motor).
    pub currents: PhaseCurrents,
    /// Electrical angle at the current-sampling instant.
    pub angle: ElectricalAngle,
    /// Electrical angular speed in rad/s.
    pub omega_e: f32,
    /// DC-bus voltage in V.
    pub vbus: f32,
    /// 1/`vbus` in 1/V (the caller has it from the bus-voltage filter; no division here).
    pub inv_vbus: f32,
    /// d-axis current reference in A.
    pub id_ref: f32,
    /// q-axis current reference in A.
    pub iq_ref: f32,
}

/// The result of one period.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CurrentLoopOutput {
    /// PWM duties for the next period.
    pub duties: Duties,
    /// Measured d-axis current in A.
    pub id: f32,
    /// Measured q-axis current in A.
    pub iq: f32,
    /// Commanded d-axis voltage in V (after the limiter, feed-forward included).
    pub vd: f32,
    /// Commanded q-axis voltage in V (after the limiter, feed-forward included).
    pub vq: f32,
    /// The voltage circle limited the PI outputs, or the vector had to be over-modulated.
    pub voltage_limited: bool,
}

/// The d/q current controllers and everything precomputed from the configuration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CurrentLoop {
    pi_d: AxisPi,
    pi_q: AxisPi,
    /// Feed-forward coefficients: Ld, Lq, ψ, or all 0 without decoupling (no branch in `step`).
    ff_ld: f32,
    ff_lq: f32,
    ff_flux: f32,
    /// max_modulation/√3: vmax = this · Vbus.
    vmax_per_vbus: f32,
    /// 1.5·Ts in s.
    latency_s: f32,
    dead_time_duty: f32,
    current_band_inv: f32,
}

/// The PI of one axis: parallel form, u = kp·e + I + ff limited to ±limit, I ← I + ki·Ts·e
/// unless the output is pinned at the limit and e pushes further out — the anti-windup rule of
/// [`Pi::update_limited`](super::pi::Pi::update_limited). Why not that function itself: it also
/// clamps the integrator into the union of its static and the dynamic limits, four more
/// compare-selects per call; with two of them the current loop measured 291 instructions under
/// QEMU against its budget of 250. Here the caller decides inside/outside with one compare and
/// calls [`linear`](Self::linear) (integrate) or [`limited`](Self::limited) (the limit with the
/// output's sign, and the hold test: the output's excess over the limit has the sign of e
/// exactly when e pushes further out). The test is written as "integrate if excess·e ≤ 0" so
/// that a NaN or infinite error holds the integrator: it stays finite whatever the measurements.
#[derive(Clone, Copy, Debug, PartialEq)]
struct AxisPi {
    gains: PiGains,
    integral: f32,
}

impl AxisPi {
    /// The integrator after this period's error, and the output before limiting.
    ///
    /// Timing: 3 instructions (2 multiply-adds, 1 addition).
    #[inline(always)]
    fn unlimited(&self, e: f32, ff: f32) -> (f32, f32) {
        let candidate = self.integral + self.gains.ki_ts * e;
        (candidate, self.gains.kp * e + candidate + ff)
    }

    /// Integrates (`candidate`) and passes `unlimited` on: the output is inside its limit.
    ///
    /// Timing: 1 store.
    #[inline(always)]
    fn linear(&mut self, candidate: f32, unlimited: f32) -> f32 {
        self.integral = candidate;
        unlimited
    }

    /// The output `unlimited` lies beyond ±`limit` (or is NaN): returns the limit with its
    /// sign, and integrates (`candidate`) only if the error `e` pulls the output back in.
    ///
    /// Timing: about 10 instructions (copysign 3, the hold test 5, a store).
    #[inline(always)]
    fn limited(&mut self, e: f32, candidate: f32, unlimited: f32, limit: f32) -> f32 {
        let out = limit.copysign(unlimited);
        // The excess (unlimited − out) has the sign of e exactly when e pushes further out;
        // NaN (a NaN error or output) compares false and holds.
        if (unlimited - out) * e <= 0.0 {
            self.integral = candidate;
        }
        out
    }
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

/// `value` if it is zero or positive and finite.
fn non_negative(parameter: &'static str, value: f32) -> Result<f32, ConfigError> {
    if (0.0..f32::INFINITY).contains(&value) {
        Ok(value)
    } else {
        Err(ConfigError {
            parameter,
            reason: "must be zero or positive and finite",
        })
    }
}

impl CurrentLoop {
    /// Validates `cfg` and designs the controllers (integrators empty).
    pub fn new(cfg: &CurrentLoopConfig) -> Result<Self, ConfigError> {
        let r = positive("resistance_ohm", cfg.resistance_ohm)?;
        let ld = positive("ld_h", cfg.ld_h)?;
        let lq = positive("lq_h", cfg.lq_h)?;
        let flux = non_negative("flux_wb", cfg.flux_wb)?;
        let pwm_hz = positive("pwm_hz", cfg.pwm_hz)?;
        let bandwidth_hz = positive("bandwidth_hz", cfg.bandwidth_hz)?;
        if bandwidth_hz >= pwm_hz * MAX_BANDWIDTH_FRACTION {
            return Err(ConfigError {
                parameter: "bandwidth_hz",
                reason: "must be below pwm_hz/8: the voltage lags the sample by 1.5 PWM periods \
                         (computation + PWM hold), a faster closed-loop pole cannot be placed",
            });
        }
        let max_modulation = positive("max_modulation", cfg.max_modulation)?;
        if max_modulation > MAX_MODULATION_LIMIT {
            return Err(ConfigError {
                parameter: "max_modulation",
                reason: "must be at most 2/√3 (1.1547): the hexagon's corners are the largest \
                         voltage the inverter can make",
            });
        }
        let dead_time_s = non_negative("dead_time_s", cfg.dead_time_s)?;
        let dead_time_duty = dead_time_s * pwm_hz;
        if dead_time_duty > MAX_DEAD_TIME_DUTY {
            return Err(ConfigError {
                parameter: "dead_time_s",
                reason: "must be at most a tenth of the PWM period",
            });
        }
        let band = positive("dead_time_band_a", cfg.dead_time_band_a)?;

        let omega_c = TAU * bandwidth_hz;
        let ts = 1.0 / pwm_hz;
        let gains = |l: f32| PiGains {
            kp: l * omega_c,
            ki_ts: r * omega_c * ts,
            // No static limits: the output limits are the voltage circle of the present bus
            // voltage, applied every period.
            out_min: f32::NEG_INFINITY,
            out_max: f32::INFINITY,
        };
        let (ff_ld, ff_lq, ff_flux) = if cfg.decoupling {
            (ld, lq, flux)
        } else {
            (0.0, 0.0, 0.0)
        };
        Ok(Self {
            pi_d: AxisPi {
                gains: gains(ld),
                integral: 0.0,
            },
            pi_q: AxisPi {
                gains: gains(lq),
                integral: 0.0,
            },
            ff_ld,
            ff_lq,
            ff_flux,
            vmax_per_vbus: max_modulation * INV_SQRT3,
            latency_s: LATENCY_PERIODS * ts,
            dead_time_duty,
            current_band_inv: 1.0 / band,
        })
    }

    /// Empties both integrators (at enable, so the first period starts from zero voltage).
    pub fn reset(&mut self) {
        self.pi_d.integral = 0.0;
        self.pi_q.integral = 0.0;
    }

    /// The d- and q-axis PI gains (the output limits are dynamic, shown as ±∞).
    pub fn gains(&self) -> (PiGains, PiGains) {
        (self.pi_d.gains, self.pi_q.gains)
    }

    /// The d- and q-axis integrators in V (for display and tests).
    pub fn integrals(&self) -> (f32, f32) {
        (self.pi_d.integral, self.pi_q.integral)
    }

    /// One period: measured currents and references in, duties for the next period out.
    ///
    /// Timing (`benchmarks/REPORT.md`, `foc-step`): 212 instructions on a Cortex-M4F in the
    /// linear range, 237 at most (the d output at the circle, which also cuts q: the square
    /// root). Clarke 5, sin/cos 40, Park 4, feed-forward 4, each PI 5 inside its limit (about 12
    /// at it), circle test 4, latency rotation 9, inverse Park 4, dead-time compensation 30,
    /// SVPWM 35 (over-modulation: three VDIV), loads, stores and the flag about 40. No library
    /// call.
    #[inline]
    pub fn step(&mut self, input: &CurrentLoopInput) -> CurrentLoopOutput {
        let i = input.currents;
        let i_alpha = (2.0 * i.a - i.b - i.c) * ONE_THIRD;
        let i_beta = (i.b - i.c) * INV_SQRT3;

        let (s, c) = sin_cos(input.angle);
        let id = i_alpha * c + i_beta * s;
        let iq = i_beta * c - i_alpha * s;

        let w = input.omega_e;
        let vd_ff = -w * self.ff_lq * iq;
        let vq_ff = w * (self.ff_ld * id + self.ff_flux);

        // Voltage circle, d first: vd within ±vmax, vq within what is left of the circle.
        let vmax = self.vmax_per_vbus * input.vbus;
        let ed = input.id_ref - id;
        let (candidate_d, unlimited_d) = self.pi_d.unlimited(ed, vd_ff);
        // Inside the limit: integrate and pass on (the common case: a compare and a store).
        // Outside it, or NaN (which fails the compare): the limit, conditional integration.
        let d_inside = unlimited_d.abs() <= vmax;
        let vd = if d_inside {
            self.pi_d.linear(candidate_d, unlimited_d)
        } else {
            self.pi_d.limited(ed, candidate_d, unlimited_d, vmax)
        };
        let eq = input.iq_ref - iq;
        let (candidate_q, unlimited_q) = self.pi_q.unlimited(eq, vq_ff);
        // What the d output leaves of the circle, squared. Never negative: |vd| ≤ vmax, and
        // rounding is monotonic (a NaN vmax gives NaN, which the modulator turns into the zero
        // vector).
        let vq_room2 = vmax * vmax - vd * vd;
        // Compared squared, so the radius (a square root) is only taken when the limit binds.
        let q_inside = unlimited_q * unlimited_q <= vq_room2;
        let vq = if q_inside {
            self.pi_q.linear(candidate_q, unlimited_q)
        } else {
            self.pi_q
                .limited(eq, candidate_q, unlimited_q, sqrt_unguarded(vq_room2))
        };

        // Rotate the sampled (sin, cos) forward by δ = ω·1.5·Ts with truncated series
        // cos δ ≈ 1 − δ²/2, sin δ ≈ δ·(1 − δ²/6) instead of a second sin_cos: the rotation's
        // gain is 1 − δ⁴/24 (never above 1, so the limited vector stays inside the circle) and
        // its angle error ≈ δ⁵/30. δ = 3π·f_e/f_pwm; at f_e = f_pwm/20 (δ = 0.47 rad, e.g.
        // 800 Hz electrical at 16 kHz PWM): gain −0.19 %, angle +0.75 mrad; at f_pwm/50:
        // −5e-5 and 8e-6 rad. (The first-order s + δ·c would be +10.5 % / −31 mrad at f_pwm/20.)
        let delta = w * self.latency_s;
        let delta2 = delta * delta;
        let kc = 1.0 - 0.5 * delta2;
        let ks = delta * (1.0 - SIXTH * delta2);
        let s_out = s * kc + c * ks;
        let c_out = c * kc - s * ks;

        // Dead-time compensation as a voltage added before the modulator (the line-to-line
        // equivalent of `svpwm::compensate_dead_time`, see `svpwm::dead_time_voltage`): the
        // modulator then keeps the duties in range, no clamp afterwards.
        let (comp_alpha, comp_beta) =
            svpwm::dead_time_voltage(i, self.dead_time_duty * input.vbus, self.current_band_inv);
        let v_alpha = vd * c_out - vq * s_out + comp_alpha;
        let v_beta = vd * s_out + vq * c_out + comp_beta;

        let modulation = svpwm::modulate(v_alpha, v_beta, input.inv_vbus);
        CurrentLoopOutput {
            duties: modulation.duties,
            id,
            iq,
            vd,
            vq,
            voltage_limited: !(d_inside && q_inside) || modulation.overmodulated,
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::math::angle_from_radians;
    use std::f64::consts::TAU as TAU64;
    use std::vec::Vec;

    const PWM_HZ: f64 = 16_000.0;
    const TS: f64 = 1.0 / PWM_HZ;
    const VBUS: f64 = 325.0;
    const R: f64 = 1.2;
    const LD: f64 = 6e-3;
    const LQ: f64 = 8e-3;
    const PSI: f64 = 0.12;
    const MAX_MODULATION: f64 = 0.95;
    /// The limiter's bound in V.
    fn vmax() -> f64 {
        MAX_MODULATION * VBUS / 3f64.sqrt()
    }

    fn config(bandwidth_hz: f32, decoupling: bool) -> CurrentLoopConfig {
        CurrentLoopConfig {
            resistance_ohm: R as f32,
            ld_h: LD as f32,
            lq_h: LQ as f32,
            flux_wb: PSI as f32,
            pwm_hz: PWM_HZ as f32,
            bandwidth_hz,
            max_modulation: MAX_MODULATION as f32,
            dead_time_s: 0.0,
            dead_time_band_a: 0.5,
            decoupling,
        }
    }

    type M2 = [[f64; 2]; 2];

    fn mul(a: M2, b: M2) -> M2 {
        let mut r = [[0.0; 2]; 2];
        for i in 0..2 {
            for j in 0..2 {
                r[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j];
            }
        }
        r
    }

    /// The dq model of a PMSM, discretised exactly (zero-order hold) in f64:
    /// x' = A·x + B·(v + [0, −ωψ]), A = [[−R/Ld, ωLq/Ld], [−ωLd/Lq, −R/Lq]], B = diag(1/Ld, 1/Lq);
    /// x(k+1) = Φ·x(k) + Γ·(v + [0, −ωψ]) with Φ = e^{A·Ts}, Γ = ∫₀^Ts e^{Aτ} dτ · B (series
    /// to 30 terms: ‖A·Ts‖ < 0.1 here, so the truncation is far below f64 rounding).
    struct Plant {
        phi: M2,
        gamma: M2,
        omega: f64,
        /// id, iq at the sampling instant in A.
        x: [f64; 2],
        /// Rotor electrical angle at the sampling instant in rad.
        theta: f64,
        /// The α/β voltage the inverter applies during the present period (computed one period
        /// earlier: the board's one-period delay).
        v_applied: (f64, f64),
    }

    impl Plant {
        fn new(omega: f64) -> Self {
            let a = [[-R / LD, omega * LQ / LD], [-omega * LD / LQ, -R / LQ]];
            let mut phi = [[1.0, 0.0], [0.0, 1.0]];
            let mut integral = [[TS, 0.0], [0.0, TS]];
            let mut term = [[1.0, 0.0], [0.0, 1.0]]; // (A·Ts)^n / n!
            for n in 1..30 {
                term = mul(term, a);
                for row in term.iter_mut() {
                    for x in row.iter_mut() {
                        *x *= TS / n as f64;
                    }
                }
                for i in 0..2 {
                    for j in 0..2 {
                        phi[i][j] += term[i][j];
                        integral[i][j] += term[i][j] * TS / (n + 1) as f64;
                    }
                }
            }
            let gamma = mul(integral, [[1.0 / LD, 0.0], [0.0, 1.0 / LQ]]);
            Self {
                phi,
                gamma,
                omega,
                x: [0.0; 2],
                theta: 0.3,
                v_applied: (0.0, 0.0),
            }
        }

        /// The phase currents at the sampling instant.
        fn currents(&self) -> PhaseCurrents {
            let (s, c) = self.theta.sin_cos();
            let i_alpha = self.x[0] * c - self.x[1] * s;
            let i_beta = self.x[0] * s + self.x[1] * c;
            let b = -0.5 * i_alpha + 3f64.sqrt() / 2.0 * i_beta;
            PhaseCurrents {
                a: i_alpha as f32,
                b: b as f32,
                c: (-i_alpha - b) as f32,
            }
        }

        /// One period: the controller runs at the sampling instant, the plant advances over the
        /// period with the voltage computed one period earlier.
        fn step(&mut self, ctl: &mut CurrentLoop, id_ref: f64, iq_ref: f64) -> CurrentLoopOutput {
            let out = ctl.step(&CurrentLoopInput {
                currents: self.currents(),
                angle: angle_from_radians(self.theta.rem_euclid(TAU64) as f32),
                omega_e: self.omega as f32,
                vbus: VBUS as f32,
                inv_vbus: (1.0 / VBUS) as f32,
                id_ref: id_ref as f32,
                iq_ref: iq_ref as f32,
            });
            let vmax = vmax() * (1.0 + 1e-4);
            let (vd, vq) = (out.vd as f64, out.vq as f64);
            assert!(
                (vd * vd + vq * vq).sqrt() <= vmax,
                "|vdq| above vmax: {out:?}"
            );
            let (va, vb) = alpha_beta(out.duties);
            assert!(
                (va * va + vb * vb).sqrt() <= vmax,
                "|vαβ| above vmax: {out:?}"
            );

            // The αβ voltage, constant over the period, seen in the rotor frame at the mean
            // angle of the period (the rotor turns ω·Ts = 0.04 rad per period at most here: the
            // averaging error of the rotating vector, 1 − sinc, is below 1e-4).
            let (s, c) = (self.theta + 0.5 * self.omega * TS).sin_cos();
            let (va, vb) = self.v_applied;
            let v = [va * c + vb * s, vb * c - va * s - self.omega * PSI];
            let x = self.x;
            for i in 0..2 {
                self.x[i] = self.phi[i][0] * x[0]
                    + self.phi[i][1] * x[1]
                    + self.gamma[i][0] * v[0]
                    + self.gamma[i][1] * v[1];
            }
            self.theta += self.omega * TS;
            self.v_applied = alpha_beta(out.duties);
            out
        }
    }

    /// The α/β voltage of the duties (from the line-to-line voltages).
    fn alpha_beta(d: Duties) -> (f64, f64) {
        let (a, b, c) = (d.a as f64, d.b as f64, d.c as f64);
        (VBUS * (2.0 * a - b - c) / 3.0, VBUS * (b - c) / 3f64.sqrt())
    }

    /// The time in s from the step until `trace` (one value per period, starting at the step)
    /// first reaches `level`, linearly interpolated between samples.
    fn time_to_reach(trace: &[f64], level: f64) -> f64 {
        for k in 1..trace.len() {
            if trace[k] >= level {
                let fraction = (level - trace[k - 1]) / (trace[k] - trace[k - 1]);
                return (k as f64 - 1.0 + fraction) * TS;
            }
        }
        f64::INFINITY
    }

    #[test]
    fn clarke_park_of_a_balanced_set_and_common_mode_rejection() {
        let mut ctl = CurrentLoop::new(&config(1000.0, false)).unwrap();
        let (id, iq) = (1.5f64, -4.0f64);
        for k in 0..64 {
            let theta = k as f64 * TAU64 / 64.0;
            let (s, c) = theta.sin_cos();
            let (ia, ib) = (id * c - iq * s, id * s + iq * c);
            let b = -0.5 * ia + 3f64.sqrt() / 2.0 * ib;
            for common in [0.0f64, 0.7] {
                ctl.reset();
                let out = ctl.step(&CurrentLoopInput {
                    currents: PhaseCurrents {
                        a: (ia + common) as f32,
                        b: (b + common) as f32,
                        c: (-ia - b + common) as f32,
                    },
                    angle: angle_from_radians(theta as f32),
                    omega_e: 0.0,
                    vbus: VBUS as f32,
                    inv_vbus: (1.0 / VBUS) as f32,
                    id_ref: 0.0,
                    iq_ref: 0.0,
                });
                assert!((out.id as f64 - id).abs() < 1e-4, "{theta}: id {}", out.id);
                assert!((out.iq as f64 - iq).abs() < 1e-4, "{theta}: iq {}", out.iq);
            }
        }
    }

    #[test]
    fn gains_are_placed_by_pole_zero_cancellation() {
        let ctl = CurrentLoop::new(&config(1000.0, true)).unwrap();
        let (d, q) = ctl.gains();
        let omega_c = TAU64 * 1000.0;
        let close = |a: f32, b: f64| ((a as f64) / b - 1.0).abs() < 1e-5;
        assert!(close(d.kp, LD * omega_c) && close(q.kp, LQ * omega_c));
        assert!(close(d.ki_ts, R * omega_c / PWM_HZ) && close(q.ki_ts, R * omega_c / PWM_HZ));
    }

    /// The iq step response at standstill: t63 within the first-order design value 1/ωc plus the
    /// 1.5-period delay, no steady-state error, id untouched.
    #[test]
    fn iq_step_reaches_63_percent_in_time_and_settles_exactly() {
        const STEP_A: f64 = 2.0;
        // Discrete-time effects (the sampled PI, the delay inside a loop that is not exactly
        // first order) move t63 by a fraction of a period: allowed 10 %.
        const TOLERANCE: f64 = 0.10;
        for bandwidth_hz in [300.0f64, 1000.0, 1900.0] {
            let mut ctl = CurrentLoop::new(&config(bandwidth_hz as f32, true)).unwrap();
            let mut plant = Plant::new(0.0);
            let mut iq = Vec::new();
            let mut id_worst = 0.0f64;
            for _ in 0..1600 {
                iq.push(plant.x[1]);
                id_worst = id_worst.max(plant.x[0].abs());
                plant.step(&mut ctl, 0.0, STEP_A);
            }
            let bound = 1.0 / (TAU64 * bandwidth_hz) + 1.5 * TS;
            let t63 = time_to_reach(&iq, (1.0 - (-1.0f64).exp()) * STEP_A);
            assert!(
                t63 <= bound * (1.0 + TOLERANCE),
                "{bandwidth_hz} Hz: t63 {t63} s, bound {bound} s"
            );
            // Causality: nothing moves before the first voltage is applied one period later.
            assert!(t63 > TS, "{bandwidth_hz} Hz: t63 {t63} s");
            let last = *iq.last().unwrap();
            assert!((last - STEP_A).abs() < 1e-3 * STEP_A, "steady state {last}");
            assert!(id_worst < 1e-3, "id disturbed at standstill: {id_worst}");
        }
    }

    /// Runs at speed: settle at iq = 0, then step iq; returns the largest |id| after the step
    /// and the final iq.
    fn id_disturbance_at_speed(bandwidth_hz: f32, decoupling: bool) -> (f64, f64) {
        const STEP_A: f64 = 1.0;
        let mut ctl = CurrentLoop::new(&config(bandwidth_hz, decoupling)).unwrap();
        // 100 Hz electrical: 75 V back-EMF, ω·Lq·iq = 5 V per A of cross-coupling.
        let mut plant = Plant::new(TAU64 * 100.0);
        for _ in 0..3000 {
            plant.step(&mut ctl, 0.0, 0.0);
        }
        assert!(
            plant.x[0].abs() < 1e-3 && plant.x[1].abs() < 1e-3,
            "settled"
        );
        let mut worst = 0.0f64;
        for _ in 0..800 {
            plant.step(&mut ctl, 0.0, STEP_A);
            worst = worst.max(plant.x[0].abs());
        }
        (worst, plant.x[1])
    }

    #[test]
    fn decoupling_keeps_an_iq_step_out_of_id_at_speed() {
        for bandwidth_hz in [300.0f32, 1000.0] {
            let (with, iq_with) = id_disturbance_at_speed(bandwidth_hz, true);
            let (without, iq_without) = id_disturbance_at_speed(bandwidth_hz, false);
            // Without feed-forward the d PI alone rejects the voltage step ω·Lq·Δiq: the id
            // excursion is about ω·Lq·Δiq/(Ld·ωc). The feed-forward uses the measured iq, which
            // lags the current during the voltage's application by 1.5 periods, so what remains
            // is the voltage-time area ω·Lq·Δiq·1.5·Ts: id ≈ ω·Lq·Δiq·1.5·Ts/Ld. The ratio is
            // about 1.5·Ts·ωc (0.18 at 300 Hz, 0.59 at 1 kHz with 16 kHz PWM).
            let omega_c = TAU64 * bandwidth_hz as f64;
            let bound = 1.5 * TS * omega_c;
            assert!(without > 0.1, "the test must disturb: {without}");
            assert!(
                with < bound * without,
                "{bandwidth_hz} Hz: with {with} A, without {without} A, ratio bound {bound}"
            );
            for iq in [iq_with, iq_without] {
                assert!((iq - 1.0).abs() < 1e-3, "iq {iq}");
            }
        }
        // At a moderate bandwidth the feed-forward removes most of the coupling.
        let (with, _) = id_disturbance_at_speed(300.0, true);
        let (without, _) = id_disturbance_at_speed(300.0, false);
        assert!(with < 0.25 * without, "with {with} A, without {without} A");
    }

    #[test]
    fn at_speed_the_step_response_meets_the_same_bound() {
        let mut ctl = CurrentLoop::new(&config(1000.0, true)).unwrap();
        let mut plant = Plant::new(TAU64 * 100.0);
        for _ in 0..3000 {
            plant.step(&mut ctl, 0.0, 0.0);
        }
        let mut iq = Vec::new();
        for _ in 0..400 {
            iq.push(plant.x[1]);
            plant.step(&mut ctl, 0.0, 1.0);
        }
        let bound = 1.0 / (TAU64 * 1000.0) + 1.5 * TS;
        let t63 = time_to_reach(&iq, 1.0 - (-1.0f64).exp());
        assert!(t63 <= bound * 1.1, "t63 {t63} s, bound {bound} s");
        assert!((iq.last().unwrap() - 1.0).abs() < 1e-3);
    }

    #[test]
    fn a_saturated_loop_does_not_wind_up() {
        const HUGE_A: f64 = 1e4;
        const AFTER_A: f64 = 2.0;
        let mut ctl = CurrentLoop::new(&config(1000.0, true)).unwrap();
        let mut plant = Plant::new(0.0);
        let mut limited = 0;
        for _ in 0..800 {
            if plant.step(&mut ctl, 0.0, HUGE_A).voltage_limited {
                limited += 1;
            }
        }
        assert!(limited > 790, "the limiter must be active: {limited}");
        // Locked rotor, full voltage on q: the current approaches vmax/R.
        let i0 = plant.x[1];
        assert!(i0 > 0.98 * vmax() / R, "i0 {i0}");
        let mut trace = Vec::new();
        for _ in 0..800 {
            trace.push(plant.x[1]);
            plant.step(&mut ctl, 0.0, AFTER_A);
        }
        // The fastest possible fall, with −vmax applied from the step on:
        // t = L/R·ln((vmax + R·i0)/(vmax + R·i1)); plus the delay and a few closed-loop time
        // constants to settle within 5 %. (The integrator held at its value from before the
        // saturation lacks R·i1 when the loop takes over; the PI zero cancels the plant pole
        // R/L, so that residual, R·i1/(L·ωc) = 2.4 % of i1 here, decays with L/R = 6.7 ms.)
        let v = vmax();
        let omega_c = TAU64 * 1000.0;
        let t_fall = LQ / R * ((v + R * i0) / (v + R * AFTER_A)).ln();
        let allowed = t_fall + 1.5 * TS + 6.0 / omega_c;
        let settled_after = trace
            .iter()
            .rposition(|i| (i - AFTER_A).abs() > 0.05 * AFTER_A)
            .map_or(0, |k| k + 1) as f64
            * TS;
        assert!(
            settled_after <= allowed,
            "settled after {settled_after} s, allowed {allowed} s"
        );
        let residual_bound = AFTER_A * R / (LQ * omega_c) * 1.2;
        let at_allowed = trace[(allowed / TS) as usize + 1];
        assert!(
            (at_allowed - AFTER_A).abs() <= residual_bound,
            "{at_allowed} A"
        );
        let last = *trace.last().unwrap();
        assert!((last - AFTER_A).abs() < 1e-3 * AFTER_A, "final {last} A");
        // No wound-up integrator driving the current far through the new reference.
        let lowest = trace.iter().cloned().fold(f64::INFINITY, f64::min);
        assert!(lowest > 0.0, "undershoot to {lowest} A");
    }

    #[test]
    fn latency_compensation_rotates_the_voltage_ahead() {
        let mut ctl = CurrentLoop::new(&config(1000.0, false)).unwrap();
        // δ = 0.3 rad of rotation during the 1.5 periods.
        let omega = 0.3 / (1.5 * TS);
        let theta = 1.0f64;
        let out = ctl.step(&CurrentLoopInput {
            currents: PhaseCurrents::default(),
            angle: angle_from_radians(theta as f32),
            omega_e: omega as f32,
            vbus: VBUS as f32,
            inv_vbus: (1.0 / VBUS) as f32,
            id_ref: 0.3,
            iq_ref: 0.5,
        });
        let (va, vb) = alpha_beta(out.duties);
        let expected = theta + 0.3 + (out.vq as f64).atan2(out.vd as f64);
        let error = (vb.atan2(va) - expected + std::f64::consts::PI).rem_euclid(TAU64)
            - std::f64::consts::PI;
        assert!(error.abs() < 5e-4, "angle error {error} rad");
        let magnitude = (va * va + vb * vb).sqrt();
        let requested = (out.vd as f64).hypot(out.vq as f64);
        assert!(
            (magnitude / requested - 1.0).abs() < 1e-3,
            "{magnitude} vs {requested}"
        );
    }

    #[test]
    fn over_modulation_is_flagged_and_duties_stay_in_range() {
        let mut cfg = config(1000.0, true);
        cfg.max_modulation = MAX_MODULATION_LIMIT;
        let mut ctl = CurrentLoop::new(&cfg).unwrap();
        let mut flagged = 0;
        for _ in 0..100 {
            // Locked rotor at 0: the q axis points along β, the centre of a hexagon edge, where
            // the circle of radius 2/3·Vbus the PI may use lies outside the hexagon.
            let out = ctl.step(&CurrentLoopInput {
                currents: PhaseCurrents::default(),
                angle: angle_from_radians(0.0),
                omega_e: 0.0,
                vbus: VBUS as f32,
                inv_vbus: (1.0 / VBUS) as f32,
                id_ref: 0.0,
                iq_ref: 1e4,
            });
            for d in [out.duties.a, out.duties.b, out.duties.c] {
                assert!((0.0..=1.0).contains(&d));
            }
            flagged += out.voltage_limited as u32;
        }
        assert_eq!(flagged, 100);
    }

    #[test]
    fn bad_configurations_are_rejected_by_name() {
        let good = config(1000.0, true);
        assert!(CurrentLoop::new(&good).is_ok());
        type Breaker = fn(&mut CurrentLoopConfig);
        let cases: [(&str, Breaker); 12] = [
            ("resistance_ohm", |c| c.resistance_ohm = 0.0),
            ("resistance_ohm", |c| c.resistance_ohm = f32::NAN),
            ("ld_h", |c| c.ld_h = -1e-3),
            ("lq_h", |c| c.lq_h = f32::INFINITY),
            ("flux_wb", |c| c.flux_wb = -0.1),
            ("pwm_hz", |c| c.pwm_hz = 0.0),
            ("bandwidth_hz", |c| c.bandwidth_hz = 2000.0), // = 16 kHz / 8
            ("bandwidth_hz", |c| c.bandwidth_hz = 0.0),
            ("max_modulation", |c| c.max_modulation = 1.2),
            ("max_modulation", |c| c.max_modulation = 0.0),
            ("dead_time_s", |c| c.dead_time_s = 1e-5), // 16 % of the period
            ("dead_time_band_a", |c| c.dead_time_band_a = 0.0),
        ];
        for (parameter, break_it) in cases {
            let mut cfg = good;
            break_it(&mut cfg);
            let err = CurrentLoop::new(&cfg).unwrap_err();
            assert_eq!(err.parameter, parameter);
            assert!(!err.reason.is_empty());
        }
        let mut cfg = good;
        cfg.bandwidth_hz = 2500.0;
        let err = CurrentLoop::new(&cfg).unwrap_err();
        assert!(err.reason.contains("1.5 PWM periods"), "{err}");
    }

    #[test]
    fn garbage_measurements_give_zero_voltage_not_a_panic() {
        let mut ctl = CurrentLoop::new(&config(1000.0, true)).unwrap();
        let out = ctl.step(&CurrentLoopInput {
            currents: PhaseCurrents {
                a: f32::NAN,
                b: 0.0,
                c: 0.0,
            },
            angle: angle_from_radians(0.0),
            omega_e: 100.0,
            vbus: 0.0,
            inv_vbus: f32::INFINITY,
            id_ref: 0.0,
            iq_ref: 1.0,
        });
        for d in [out.duties.a, out.duties.b, out.duties.c] {
            assert!((0.0..=1.0).contains(&d));
        }
        assert!(out.voltage_limited);
    }
}
