//! Permanent-magnet synchronous motor in rotor (dq) coordinates, star-connected, balanced.
//!
//! Transforms are amplitude-invariant: `i_α = i_a` for zero-sequence-free currents,
//! `[α, β] = 2/3·[a − (b+c)/2, (√3/2)(b − c)]`, `d + jq = (α + jβ)·e^{−jθe}`.
//! The d axis is aligned with the magnet flux; `θe = p·θm` (electrical zero at mechanical zero).
//!
//! Voltage equations (phase-to-neutral voltages, phase resistance `R`):
//! `vd = R·id + Ld·did/dt − ωe·Lq·iq`, `vq = R·iq + Lq·diq/dt + ωe·(Ld·id + ψ)`;
//! torque `Te = 1.5·p·(ψ·iq + (Ld − Lq)·id·iq)`. Phase flux of the magnet: `ψ·cos(θe − k·2π/3)`,
//! so the open-circuit phase back-EMF is `e_k = −ψ·ωe·sin(θe − k·2π/3)`.
//!
//! Single-loop mode (inverter off, one phase floating): the current `i` flows into phase `p`
//! and out of phase `n`; its αβ image is `i·w` with `w = Clarke(e_p − e_n)`. Projecting the
//! αβ voltage equation on `w` (power-conjugate: `v_pn = 1.5·w·v_αβ`) gives a scalar ODE in the
//! loop flux `Λ = w·λ_αβ = L_w(θ)·i + ψ·w_d(θ)`, with `L_w = Ld·w_d² + Lq·w_q²` and
//! `(w_d, w_q)` the rotor-frame image of `w`:  `dΛ/dt = (2/3)·v_pn − R·|w|²·i`.

use std::f64::consts::FRAC_PI_3;

/// √3/2, the β weight of phases b and c in the Clarke transform.
const SQRT3_2: f64 = 0.866_025_403_784_438_6;
/// Electrical angle between adjacent phases (2π/3).
const PHASE_SHIFT: f64 = 2.0 * FRAC_PI_3;

/// Electrical and inertial parameters of the motor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotorParams {
    /// Phase (line-to-neutral) resistance in Ω.
    pub r_ohm: f64,
    /// d-axis inductance in H.
    pub ld_h: f64,
    /// q-axis inductance in H.
    pub lq_h: f64,
    /// Permanent-magnet flux linkage in Wb (peak, per phase).
    pub flux_wb: f64,
    /// Number of pole pairs `p`.
    pub pole_pairs: u32,
    /// Rotor inertia in kg·m².
    pub rotor_inertia_kgm2: f64,
}

/// Amplitude-invariant Clarke transform of three phase quantities (zero sequence discarded).
pub fn clarke(abc: [f64; 3]) -> (f64, f64) {
    let [a, b, c] = abc;
    (
        (2.0 / 3.0) * (a - 0.5 * (b + c)),
        (2.0 / 3.0) * SQRT3_2 * (b - c),
    )
}

/// Inverse amplitude-invariant Clarke transform (zero-sequence-free result).
pub fn inverse_clarke(alpha: f64, beta: f64) -> [f64; 3] {
    let b = -0.5 * alpha + SQRT3_2 * beta;
    // c = −a − b keeps the sum exactly zero.
    [alpha, b, -alpha - b]
}

/// Park transform: stationary αβ to rotor dq at electrical angle `theta_e`.
pub fn park(alpha: f64, beta: f64, theta_e: f64) -> (f64, f64) {
    park_at(alpha, beta, theta_e.sin_cos())
}

/// [`park`] at the angle whose sine and cosine are `(s, c)`.
pub fn park_at(alpha: f64, beta: f64, (s, c): (f64, f64)) -> (f64, f64) {
    (alpha * c + beta * s, -alpha * s + beta * c)
}

/// Inverse Park transform: rotor dq to stationary αβ.
pub fn inverse_park(d: f64, q: f64, theta_e: f64) -> (f64, f64) {
    inverse_park_at(d, q, theta_e.sin_cos())
}

/// [`inverse_park`] at the angle whose sine and cosine are `(s, c)`.
pub fn inverse_park_at(d: f64, q: f64, (s, c): (f64, f64)) -> (f64, f64) {
    (d * c - q * s, d * s + q * c)
}

/// The sine and cosine of `θ + δ` from those of `θ`, `(s, c)`: for the small angles a plant
/// substep turns (|δ| ≤ 0.01 rad) by the Taylor series of sin δ and cos δ to δ⁵ and δ⁶ (the
/// terms left out are below 2·10⁻¹⁸), else by `sin_cos`. Saves the second `sin_cos` of a
/// substep, the simulation's largest single cost. The series' coefficients are multiplied, not
/// divided by: a division is the longest instruction on the substep's dependency chain.
pub fn rotated((s, c): (f64, f64), delta: f64) -> (f64, f64) {
    const SERIES_LIMIT: f64 = 0.01;
    // 1/3!, 1/5! and 1/2!, 1/4!, 1/6!.
    const SIN_3: f64 = 1.0 / 6.0;
    const SIN_5: f64 = 1.0 / 120.0;
    const COS_2: f64 = 0.5;
    const COS_4: f64 = 1.0 / 24.0;
    const COS_6: f64 = 1.0 / 720.0;
    let (sd, cd) = if delta.abs() <= SERIES_LIMIT {
        let d2 = delta * delta;
        (
            delta * (1.0 - d2 * (SIN_3 - d2 * SIN_5)),
            1.0 - d2 * (COS_2 - d2 * (COS_4 - d2 * COS_6)),
        )
    } else {
        delta.sin_cos()
    };
    (s * cd + c * sd, c * cd - s * sd)
}

/// A current loop through two phases with the third floating (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CurrentLoop {
    /// αβ image `w` of a unit loop current (into phase `p`, out of phase `n`).
    pub w: (f64, f64),
    /// Loop voltage: leg `p` minus leg `n`, in V.
    pub v_pn: f64,
}

impl CurrentLoop {
    /// The loop through phases `p` (current in) and `n` (current out) driven by `v_pn`.
    pub fn new(p: usize, n: usize, v_pn: f64) -> Self {
        let mut abc = [0.0; 3];
        abc[p] = 1.0;
        abc[n] = -1.0;
        CurrentLoop {
            w: clarke(abc),
            v_pn,
        }
    }
}

impl MotorParams {
    /// Electromagnetic torque in N·m for the given dq currents.
    pub fn torque_nm(&self, id: f64, iq: f64) -> f64 {
        1.5 * f64::from(self.pole_pairs) * (self.flux_wb * iq + (self.ld_h - self.lq_h) * id * iq)
    }

    /// Open-circuit phase back-EMFs `e_k = −ψ·ωe·sin(θe − k·2π/3)` in V.
    pub fn back_emf(&self, theta_e: f64, omega_e: f64) -> [f64; 3] {
        let mut e = [0.0; 3];
        for (k, ek) in e.iter_mut().enumerate() {
            *ek = -self.flux_wb * omega_e * (theta_e - k as f64 * PHASE_SHIFT).sin();
        }
        e
    }

    /// dq current derivatives for phase resistance `r_ohm`, dq voltages and electrical speed.
    /// `inverse_l`: 1/Ld and 1/Lq (the caller divides once for both stages of a step).
    fn current_derivative(
        &self,
        r_ohm: f64,
        (id, iq): (f64, f64),
        (vd, vq): (f64, f64),
        omega_e: f64,
        (inv_ld, inv_lq): (f64, f64),
    ) -> (f64, f64) {
        let did = (vd - r_ohm * id + omega_e * self.lq_h * iq) * inv_ld;
        let diq = (vq - r_ohm * iq - omega_e * (self.ld_h * id + self.flux_wb)) * inv_lq;
        (did, diq)
    }

    /// `(1/Ld, 1/Lq)`, for [`Self::step_dq`].
    pub fn inverse_inductances(&self) -> (f64, f64) {
        (1.0 / self.ld_h, 1.0 / self.lq_h)
    }

    /// One Heun (RK2) step of length `h` of the dq currents with constant dq voltages and speed;
    /// `inverse_l` from [`Self::inverse_inductances`] (a plant divides once, not every step).
    pub fn step_dq(
        &self,
        r_ohm: f64,
        i: (f64, f64),
        v: (f64, f64),
        omega_e: f64,
        h: f64,
        inverse_l: (f64, f64),
    ) -> (f64, f64) {
        let k1 = self.current_derivative(r_ohm, i, v, omega_e, inverse_l);
        let ip = (i.0 + h * k1.0, i.1 + h * k1.1);
        let k2 = self.current_derivative(r_ohm, ip, v, omega_e, inverse_l);
        (i.0 + 0.5 * h * (k1.0 + k2.0), i.1 + 0.5 * h * (k1.1 + k2.1))
    }

    /// Loop inductance `L_w` and the rotor-frame image `(w_d, w_q)` of the loop direction `w`.
    fn loop_inductance(&self, w: (f64, f64), theta_e: f64) -> (f64, f64, f64) {
        let (wd, wq) = park(w.0, w.1, theta_e);
        (self.ld_h * wd * wd + self.lq_h * wq * wq, wd, wq)
    }

    /// One Heun step of the single-loop current `i` (see the module doc) through loop `lp`, from electrical angle `theta_e` at
    /// constant speed `omega_e`. Returns the new loop current.
    pub fn step_loop(
        &self,
        r_ohm: f64,
        i: f64,
        lp: &CurrentLoop,
        theta_e: f64,
        omega_e: f64,
        h: f64,
    ) -> f64 {
        let CurrentLoop { w, v_pn } = *lp;
        let w2 = w.0 * w.0 + w.1 * w.1;
        let flux_of = |i: f64, th: f64| {
            let (lw, wd, _) = self.loop_inductance(w, th);
            lw * i + self.flux_wb * wd
        };
        let current_of = |lambda: f64, th: f64| {
            let (lw, wd, _) = self.loop_inductance(w, th);
            (lambda - self.flux_wb * wd) / lw
        };
        let dlambda = |i: f64| (2.0 / 3.0) * v_pn - r_ohm * w2 * i;
        let theta_end = theta_e + omega_e * h;
        let lambda0 = flux_of(i, theta_e);
        let k1 = dlambda(i);
        let k2 = dlambda(current_of(lambda0 + h * k1, theta_end));
        current_of(lambda0 + 0.5 * h * (k1 + k2), theta_end)
    }

    /// Phase-to-neutral voltages in single-loop mode (used to find the floating phase's
    /// terminal voltage): the full αβ voltage equation evaluated with `di/dt` from the loop ODE.
    pub fn loop_phase_voltages(
        &self,
        r_ohm: f64,
        i: f64,
        lp: &CurrentLoop,
        theta_e: f64,
        omega_e: f64,
    ) -> [f64; 3] {
        let CurrentLoop { w, v_pn } = *lp;
        let w2 = w.0 * w.0 + w.1 * w.1;
        let (lw, wd, wq) = self.loop_inductance(w, theta_e);
        let dlambda = (2.0 / 3.0) * v_pn - r_ohm * w2 * i;
        let dlw = 2.0 * omega_e * wd * wq * (self.ld_h - self.lq_h);
        let di = (dlambda - i * dlw - self.flux_wb * omega_e * wq) / lw;
        let (id, iq) = (i * wd, i * wq);
        let did = di * wd + i * omega_e * wq;
        let diq = di * wq - i * omega_e * wd;
        let vd = r_ohm * id + self.ld_h * did - omega_e * self.lq_h * iq;
        let vq = r_ohm * iq + self.lq_h * diq + omega_e * (self.ld_h * id + self.flux_wb);
        let (va, vb) = inverse_park(vd, vq, theta_e);
        inverse_clarke(va, vb)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Turning a sine/cosine pair by δ equals `sin_cos(θ + δ)` to the last bits, on the series
    /// path (|δ| ≤ 0.01, a substep's turn) and beyond it, at angles around the circle.
    #[test]
    fn rotated_matches_sin_cos_of_the_sum() {
        for k in 0..64 {
            let theta = -7.0 + 0.23 * f64::from(k);
            for delta in [0.0, 1e-9, -3e-6, 1.2e-3, -0.0099, 0.01, 0.0101, -0.3, 2.5] {
                let (s, c) = rotated(theta.sin_cos(), delta);
                let (s_ref, c_ref) = (theta + delta).sin_cos();
                assert!(
                    (s - s_ref).abs() < 1e-15 && (c - c_ref).abs() < 1e-15,
                    "θ {theta}, δ {delta}: ({s}, {c}) against ({s_ref}, {c_ref})"
                );
            }
        }
    }

    fn motor() -> MotorParams {
        MotorParams {
            r_ohm: 0.5,
            ld_h: 1e-3,
            lq_h: 1.4e-3,
            flux_wb: 0.02,
            pole_pairs: 4,
            rotor_inertia_kgm2: 1e-4,
        }
    }

    #[test]
    fn transforms_round_trip_and_are_amplitude_invariant() {
        let theta: f64 = 0.7;
        // A balanced set of amplitude 3 at angle theta maps to a dq vector of length 3 on d.
        let abc = inverse_clarke(3.0 * theta.cos(), 3.0 * theta.sin());
        assert!((abc[0] - 3.0 * theta.cos()).abs() < 1e-12);
        assert!((abc[1] - 3.0 * (theta - PHASE_SHIFT).cos()).abs() < 1e-12);
        let (a, b) = clarke(abc);
        let (d, q) = park(a, b, theta);
        assert!((d - 3.0).abs() < 1e-12 && q.abs() < 1e-12);
        let (a2, b2) = inverse_park(d, q, theta);
        assert!((a2 - a).abs() < 1e-12 && (b2 - b).abs() < 1e-12);
    }

    #[test]
    fn back_emf_is_derivative_of_magnet_flux() {
        let m = motor();
        let (theta, omega, h) = (0.3, 500.0, 1e-7);
        let e = m.back_emf(theta, omega);
        for (k, ek) in e.iter().enumerate() {
            let flux = |th: f64| m.flux_wb * (th - k as f64 * PHASE_SHIFT).cos();
            let numeric = (flux(theta + omega * h) - flux(theta - omega * h)) / (2.0 * h);
            assert!((ek - numeric).abs() < 1e-6, "{ek} vs {numeric}");
        }
    }

    #[test]
    fn loop_phase_voltages_are_consistent_with_the_loop_voltage() {
        let m = motor();
        let lp = CurrentLoop::new(0, 2, -30.0);
        let v = m.loop_phase_voltages(m.r_ohm, 2.0, &lp, 1.1, 800.0);
        assert!(((v[0] - v[2]) - (-30.0)).abs() < 1e-9, "{v:?}");
        assert!((v[0] + v[1] + v[2]).abs() < 1e-9);
    }

    #[test]
    fn loop_mode_matches_two_phases_in_series_at_standstill() {
        // Non-salient, ωe = 0: the loop is 2R in series with 2L.
        let m = MotorParams {
            lq_h: 1e-3,
            ..motor()
        };
        let lp = CurrentLoop::new(1, 2, 10.0);
        let h = 1e-6;
        let mut i = 0.0;
        for _ in 0..1000 {
            i = m.step_loop(m.r_ohm, i, &lp, 0.4, 0.0, h);
        }
        let tau = m.ld_h / m.r_ohm;
        let expected = 10.0 / (2.0 * m.r_ohm) * (1.0 - (-1e-3 / tau).exp());
        assert!(
            (i - expected).abs() < 1e-6 * expected.abs(),
            "{i} vs {expected}"
        );
    }
}
