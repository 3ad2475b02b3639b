//! Commissioning: identification of the phase resistance, the d- and q-axis inductances and the
//! inertia, and control gains calculated from requested bandwidths.
//!
//! Each identification is a step machine the axis calls once per PWM period in its
//! commissioning mode: it gets the measured currents (and velocity) and returns what to apply
//! next. Nothing here runs in normal operation, so it may divide; it still never panics and
//! never returns a non-finite result (an implausible one becomes [`MotorFault::Identification`]).
//!
//! # Methods
//! - **Resistance**, two-point: a voltage vector at the fixed electrical angle 0 is regulated by a
//!   slow integrator until the d-current reaches I₁ = ½·I_test, then I₂ = I_test; after each
//!   settles, voltage and current are averaged. R = (V₂ − V₁)/(I₂ − I₁). The inverter's dead-time
//!   and device-drop error is an almost constant voltage while the phase currents keep their
//!   signs, so it cancels in the difference (a one-point V/I would read it as resistance).
//! - **Inductance**, square-wave injection on top of the I₂ bias: the d (then q) voltage toggles
//!   by ±V_ac every period; the current change over a period is ±V_ac·Ts/L. The command applied
//!   during period k+1 was computed at step k, so the sign that caused the change observed at
//!   step k is the one issued at step k−2; the step machine keeps that bookkeeping.
//!   L = V_ac·Ts / mean(s·Δi). The bias holds the rotor aligned on the d axis and keeps every
//!   phase current's sign, so the dead-time error again cancels; the q injection's torque
//!   alternates at half the PWM frequency and does not move the rotor measurably.
//! - **Inertia**, torque pulses on the closed current loop: +I_q for n₁ samples, until the speed
//!   reaches `max_speed` (or `max_time_s` passed), zero current for c samples
//!   ([`INERTIA_COAST_S`]), −I_q for n₂ = n₁/2 samples, zero current for c samples. The
//!   velocity is read only at the ends of the coasts: there the estimate has settled from its
//!   lag behind the pulse (2a/ω of a tracking observer of bandwidth ω: on a small servo the
//!   pulse to `max_speed` lasts about a millisecond, the same order as the lag, and velocities
//!   read at the pulse edges gave three times the true inertia). With friction g = f/J (same
//!   sign throughout, the rotor keeps turning forward) the two velocity changes are
//!   Δv₁ = (T/J)·n₁T_s − g·(n₁ + c)·T_s and Δv₂ = −(T/J)·n₂T_s − g·(n₂ + c)·T_s; solved for J,
//!   J = T·T_s·(n₁(n₂ + c) + n₂(n₁ + c)) / (Δv₁(n₂ + c) − Δv₂(n₁ + c)): friction cancels (for
//!   c = 0 this is the familiar J = 2T/(a₊ − a₋)).
//!
//! Gains ([`tune`]): current loop kp = L·ωc, ki = R·ωc (pole-zero cancellation); speed loop
//! kp = J·ωs, ki = kp·ωs/4; position loop kp = ωs/4 (a quarter of the speed bandwidth keeps the
//! cascade from interacting).

use super::math::{clamp, TAU};
use super::{ElectricalAngle, MotorFault};

/// What an identification step asks the axis to apply during the next PWM period.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum IdentCommand {
    /// Open-loop voltage vector (volts, d and q at the fixed electrical angle `angle`).
    Voltage {
        /// Electrical angle of the d axis.
        angle: ElectricalAngle,
        /// d voltage, V.
        vd: f32,
        /// q voltage, V.
        vq: f32,
    },
    /// Finished.
    Done(Result<Identified, MotorFault>),
}

/// What the axis measured at the start of the period (the sample the command reacts to).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct IdentMeasurement {
    /// d current at the commanded angle, A.
    pub id: f32,
    /// q current at the commanded angle, A.
    pub iq: f32,
    /// Velocity estimate, increments/s.
    pub velocity: f32,
}

/// Identified motor parameters.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Identified {
    /// Phase resistance (line-to-neutral), Ω.
    pub resistance_ohm: f32,
    /// d-axis inductance, H.
    pub ld_h: f32,
    /// q-axis inductance, H.
    pub lq_h: f32,
}

/// Settings of the electrical identification.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ElectricalIdentConfig {
    /// PWM frequency, Hz (one step per period).
    pub pwm_hz: f32,
    /// Test current I_test, A (I₂; I₁ is half of it).
    pub test_current_a: f32,
    /// Highest voltage the resistance regulator may apply, V (protects a motor whose R is far
    /// below the expected).
    pub max_voltage_v: f32,
    /// Integral gain of the resistance regulator, V/(A·s).
    pub voltage_gain_v_per_as: f32,
    /// Time for each resistance point to settle, s.
    pub settle_s: f32,
    /// Averaging time at the end of each resistance point, s.
    pub average_s: f32,
    /// Square-wave amplitude of the inductance measurement, V.
    pub injection_v: f32,
    /// Duration of each inductance measurement (d, then q), s.
    pub injection_s: f32,
}

impl ElectricalIdentConfig {
    /// Settings for a small servo motor (0.1–10 Ω, 0.1–20 mH) at `pwm_hz`.
    pub fn small_servo(pwm_hz: f32) -> Self {
        Self {
            pwm_hz,
            test_current_a: 2.0,
            max_voltage_v: 12.0,
            voltage_gain_v_per_as: 200.0,
            settle_s: 0.15,
            average_s: 0.05,
            injection_v: 2.0,
            injection_s: 0.05,
        }
    }
}

/// Plausible parameter ranges: results outside are a failed measurement, not a motor.
const RESISTANCE_RANGE_OHM: (f32, f32) = (1e-3, 100.0);
const INDUCTANCE_RANGE_H: (f32, f32) = (1e-6, 1.0);
const INERTIA_MIN: f32 = 0.0;

#[derive(Clone, Copy, Debug, PartialEq)]
enum ElectricalStage {
    Resistance { point: u8 },
    Inductance { q_axis: bool },
}

/// Resistance and inductance identification (see the module documentation).
#[derive(Clone, Debug)]
pub struct ElectricalIdentification {
    cfg: ElectricalIdentConfig,
    ts: f32,
    stage: ElectricalStage,
    /// Steps spent in the current stage.
    steps: u32,
    settle_steps: u32,
    average_steps: u32,
    injection_steps: u32,
    /// The regulated d voltage (resistance stage) / the bias (inductance stage).
    v_bias: f32,
    sum_v: f32,
    sum_i: f32,
    /// (V, I) of the first resistance point.
    point1: (f32, f32),
    resistance: f32,
    ld: f32,
    /// Signs of the injection issued at the last two steps (index 0 = previous step).
    issued: [f32; 2],
    previous_current: f32,
    sum_signed_delta: f32,
    deltas: u32,
}

impl ElectricalIdentification {
    /// A new identification; fails if the settings are not positive and finite.
    pub fn new(cfg: ElectricalIdentConfig) -> Result<Self, MotorFault> {
        let positive = [
            cfg.pwm_hz,
            cfg.test_current_a,
            cfg.max_voltage_v,
            cfg.voltage_gain_v_per_as,
            cfg.settle_s,
            cfg.average_s,
            cfg.injection_v,
            cfg.injection_s,
        ];
        if positive.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
            return Err(MotorFault::Identification);
        }
        let steps = |s: f32| ((s * cfg.pwm_hz) as u32).max(1);
        Ok(Self {
            ts: 1.0 / cfg.pwm_hz,
            settle_steps: steps(cfg.settle_s),
            average_steps: steps(cfg.average_s),
            injection_steps: steps(cfg.injection_s),
            cfg,
            stage: ElectricalStage::Resistance { point: 0 },
            steps: 0,
            v_bias: 0.0,
            sum_v: 0.0,
            sum_i: 0.0,
            point1: (0.0, 0.0),
            resistance: 0.0,
            ld: 0.0,
            issued: [0.0; 2],
            previous_current: 0.0,
            sum_signed_delta: 0.0,
            deltas: 0,
        })
    }

    /// One PWM period: the measurement taken at its start → the command for the next.
    pub fn step(&mut self, m: &IdentMeasurement) -> IdentCommand {
        if !(m.id.is_finite() && m.iq.is_finite()) {
            return IdentCommand::Done(Err(MotorFault::Identification));
        }
        self.steps = self.steps.saturating_add(1);
        match self.stage {
            ElectricalStage::Resistance { point } => self.resistance_step(point, m),
            ElectricalStage::Inductance { q_axis } => self.inductance_step(q_axis, m),
        }
    }

    fn resistance_step(&mut self, point: u8, m: &IdentMeasurement) -> IdentCommand {
        let target = if point == 0 {
            0.5 * self.cfg.test_current_a
        } else {
            self.cfg.test_current_a
        };
        let limit = self.cfg.max_voltage_v;
        let v = self.v_bias + self.cfg.voltage_gain_v_per_as * (target - m.id) * self.ts;
        self.v_bias = clamp(v, -limit, limit);
        if self.steps > self.settle_steps {
            self.sum_v += self.v_bias;
            self.sum_i += m.id;
        }
        if self.steps >= self.settle_steps.saturating_add(self.average_steps) {
            let n = self.average_steps as f32;
            let (v_mean, i_mean) = (self.sum_v / n, self.sum_i / n);
            (self.sum_v, self.sum_i) = (0.0, 0.0);
            self.steps = 0;
            if point == 0 {
                self.point1 = (v_mean, i_mean);
                self.stage = ElectricalStage::Resistance { point: 1 };
            } else {
                let (v1, i1) = self.point1;
                let r = (v_mean - v1) / (i_mean - i1);
                if !in_range(r, RESISTANCE_RANGE_OHM) {
                    return IdentCommand::Done(Err(MotorFault::Identification));
                }
                self.resistance = r;
                self.start_injection(false, m.id);
            }
        }
        self.voltage(0.0)
    }

    fn start_injection(&mut self, q_axis: bool, current: f32) {
        self.stage = ElectricalStage::Inductance { q_axis };
        self.steps = 0;
        self.issued = [0.0; 2];
        self.previous_current = current;
        self.sum_signed_delta = 0.0;
        self.deltas = 0;
    }

    fn inductance_step(&mut self, q_axis: bool, m: &IdentMeasurement) -> IdentCommand {
        let current = if q_axis { m.iq } else { m.id };
        let delta = current - self.previous_current;
        self.previous_current = current;
        // The change seen now was caused by the sign issued two steps ago.
        let cause = self.issued[1];
        if cause != 0.0 {
            self.sum_signed_delta += cause * delta;
            self.deltas = self.deltas.saturating_add(1);
        }
        let sign = if self.steps % 2 == 0 { 1.0 } else { -1.0 };
        self.issued = [sign, self.issued[0]];
        if self.steps >= self.injection_steps {
            let mean = self.sum_signed_delta / self.deltas.max(1) as f32;
            let l = self.cfg.injection_v * self.ts / mean;
            if !in_range(l, INDUCTANCE_RANGE_H) {
                return IdentCommand::Done(Err(MotorFault::Identification));
            }
            if q_axis {
                return IdentCommand::Done(Ok(Identified {
                    resistance_ohm: self.resistance,
                    ld_h: self.ld,
                    lq_h: l,
                }));
            }
            self.ld = l;
            self.start_injection(true, m.iq);
            return self.voltage(0.0);
        }
        let injection = sign * self.cfg.injection_v;
        if q_axis {
            IdentCommand::Voltage {
                angle: ElectricalAngle::ZERO,
                vd: self.v_bias,
                vq: injection,
            }
        } else {
            self.voltage(injection)
        }
    }

    fn voltage(&self, extra_d: f32) -> IdentCommand {
        IdentCommand::Voltage {
            angle: ElectricalAngle::ZERO,
            vd: self.v_bias + extra_d,
            vq: 0.0,
        }
    }
}

/// Settings of the inertia identification.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InertiaIdentConfig {
    /// Rate of the calls (the loop rate the velocity estimate is updated at), Hz.
    pub sample_hz: f32,
    /// q current of the torque steps, A.
    pub current_a: f32,
    /// Torque constant, N·m/A (1.5·p·ψ).
    pub torque_constant_nm_per_a: f32,
    /// The acceleration half ends at this speed, increments/s (keeps the test inside the travel).
    pub max_speed: f32,
    /// The acceleration half ends after this time at the latest, s.
    pub max_time_s: f32,
}

/// How long the current is held at zero after each torque pulse before the velocity is read, s:
/// the velocity estimate settles from its lag behind the pulse's acceleration (2a/ω, and the
/// transient of the step in acceleration) within about 6/ω, 5 ms for an estimator of 200 Hz.
pub const INERTIA_COAST_S: f32 = 0.005;

#[derive(Clone, Copy, Debug, PartialEq)]
enum InertiaPhase {
    Accelerating,
    CoastAfterAcceleration,
    Braking,
    CoastAfterBraking,
}

/// Inertia identification (see the module documentation). Result: J in N·m per
/// (increment/s²), the unit of the speed loop's acceleration feed-forward.
#[derive(Clone, Debug)]
pub struct InertiaIdentification {
    cfg: InertiaIdentConfig,
    ts: f32,
    max_steps: u32,
    coast_steps: u32,
    steps: u32,
    phase: InertiaPhase,
    accel_steps: u32,
    brake_steps: u32,
    v_start: f32,
    /// Velocity at the end of the coast after the acceleration.
    v_turn: f32,
}

impl InertiaIdentification {
    /// A new identification; fails if the settings are not positive and finite.
    pub fn new(cfg: InertiaIdentConfig) -> Result<Self, MotorFault> {
        let positive = [
            cfg.sample_hz,
            cfg.current_a,
            cfg.torque_constant_nm_per_a,
            cfg.max_speed,
            cfg.max_time_s,
        ];
        if positive.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
            return Err(MotorFault::Identification);
        }
        Ok(Self {
            ts: 1.0 / cfg.sample_hz,
            max_steps: ((cfg.max_time_s * cfg.sample_hz) as u32).max(2),
            coast_steps: ((INERTIA_COAST_S * cfg.sample_hz) as u32).max(1),
            cfg,
            steps: 0,
            phase: InertiaPhase::Accelerating,
            accel_steps: 0,
            brake_steps: 0,
            v_start: f32::NAN,
            v_turn: 0.0,
        })
    }

    /// One loop sample → the q current to apply until the next, or the result.
    pub fn step(&mut self, m: &IdentMeasurement) -> InertiaStep {
        if !m.velocity.is_finite() {
            return InertiaStep::Done(Err(MotorFault::Identification));
        }
        if self.v_start.is_nan() {
            self.v_start = m.velocity;
        }
        self.steps = self.steps.saturating_add(1);
        let i = self.cfg.current_a;
        match self.phase {
            InertiaPhase::Accelerating => {
                if m.velocity - self.v_start >= self.cfg.max_speed || self.steps >= self.max_steps {
                    self.phase = InertiaPhase::CoastAfterAcceleration;
                    self.accel_steps = self.steps;
                    self.steps = 0;
                    return InertiaStep::Current { iq_ref: 0.0 };
                }
                InertiaStep::Current { iq_ref: i }
            }
            InertiaPhase::CoastAfterAcceleration => {
                if self.steps < self.coast_steps {
                    return InertiaStep::Current { iq_ref: 0.0 };
                }
                self.v_turn = m.velocity;
                self.phase = InertiaPhase::Braking;
                // Braking lasts half the acceleration time, so the rotor is still turning
                // forward at the end and the friction has kept its sign (braking is faster
                // than accelerating).
                self.brake_steps = (self.accel_steps / 2).max(1);
                self.steps = 0;
                InertiaStep::Current { iq_ref: -i }
            }
            InertiaPhase::Braking => {
                if self.steps < self.brake_steps {
                    return InertiaStep::Current { iq_ref: -i };
                }
                self.phase = InertiaPhase::CoastAfterBraking;
                self.steps = 0;
                InertiaStep::Current { iq_ref: 0.0 }
            }
            InertiaPhase::CoastAfterBraking => {
                if self.steps < self.coast_steps {
                    return InertiaStep::Current { iq_ref: 0.0 };
                }
                InertiaStep::Done(self.result(m.velocity))
            }
        }
    }

    /// J from the two velocity changes, each over a pulse and the coast after it (see the
    /// module documentation).
    fn result(&self, v_end: f32) -> Result<f32, MotorFault> {
        // The rotor must still turn forward, or the friction changed its sign (or stuck).
        let forward = (v_end - self.v_start) * self.cfg.max_speed.signum() > 0.0;
        let (n1, n2, c) = (
            self.accel_steps as f32,
            self.brake_steps as f32,
            self.coast_steps as f32,
        );
        let dv1 = self.v_turn - self.v_start;
        let dv2 = v_end - self.v_turn;
        let torque = self.cfg.torque_constant_nm_per_a * self.cfg.current_a;
        let j =
            torque * self.ts * (n1 * (n2 + c) + n2 * (n1 + c)) / (dv1 * (n2 + c) - dv2 * (n1 + c));
        if forward && j.is_finite() && j > INERTIA_MIN {
            Ok(j)
        } else {
            Err(MotorFault::Identification)
        }
    }
}

/// What an inertia identification step asks for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum InertiaStep {
    /// Closed current loop at the encoder angle with this q current (A), d current 0.
    Current {
        /// q current, A.
        iq_ref: f32,
    },
    /// Finished: the inertia in N·m per (increment/s²).
    Done(Result<f32, MotorFault>),
}

fn in_range(x: f32, (lo, hi): (f32, f32)) -> bool {
    x.is_finite() && x >= lo && x <= hi
}

/// Requested bandwidths of the cascade.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bandwidths {
    /// Current loop, Hz.
    pub current_hz: f32,
    /// Speed loop, Hz.
    pub speed_hz: f32,
}

/// Gains of the cascade.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tuning {
    /// Current loop d axis: V/A.
    pub current_kp_d: f32,
    /// Current loop q axis: V/A.
    pub current_kp_q: f32,
    /// Current loop integral gain: V/(A·s) (R·ωc, the same for both axes).
    pub current_ki: f32,
    /// Speed loop proportional gain, N·m per (increment/s).
    pub speed_kp: f32,
    /// Speed loop integral gain, N·m per increment.
    pub speed_ki: f32,
    /// Position loop gain, 1/s.
    pub position_kp: f32,
}

/// Gains from identified parameters, inertia (N·m per increment/s²) and bandwidths.
pub fn tune(motor: &Identified, inertia: f32, bw: &Bandwidths) -> Tuning {
    let wc = TAU * bw.current_hz;
    let ws = TAU * bw.speed_hz;
    let speed_kp = inertia * ws;
    Tuning {
        current_kp_d: motor.ld_h * wc,
        current_kp_q: motor.lq_h * wc,
        current_ki: motor.resistance_ohm * wc,
        speed_kp,
        speed_ki: speed_kp * ws / 4.0,
        position_kp: ws / 4.0,
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;

    /// A locked-rotor RL motor in the d/q frame of angle 0, with the board's one-period delay
    /// (the command computed at step k acts during period k+1) and a constant inverter voltage
    /// error (dead time + device drop while the phase currents keep their signs).
    struct LockedRotor {
        r: f64,
        ld: f64,
        lq: f64,
        ts: f64,
        voltage_error: f64,
        i: (f64, f64),
        pending: (f64, f64),
    }

    impl LockedRotor {
        fn period(&mut self, command: (f32, f32)) {
            let (vd, vq) = self.pending;
            self.pending = (command.0 as f64, command.1 as f64);
            // Exact zero-order-hold solution of L di/dt = v − R i over one period.
            let step = |i: f64, v: f64, l: f64| {
                let a = (-self.r * self.ts / l).exp();
                i * a + (v / self.r) * (1.0 - a)
            };
            self.i = (
                step(self.i.0, vd - self.voltage_error, self.ld),
                step(self.i.1, vq, self.lq),
            );
        }
    }

    fn identify(r: f64, ld: f64, lq: f64, voltage_error: f64) -> Identified {
        let cfg = ElectricalIdentConfig::small_servo(40_000.0);
        let mut ident = ElectricalIdentification::new(cfg).unwrap();
        let mut motor = LockedRotor {
            r,
            ld,
            lq,
            ts: 1.0 / 40_000.0,
            voltage_error,
            i: (0.0, 0.0),
            pending: (0.0, 0.0),
        };
        for _ in 0..200_000 {
            let m = IdentMeasurement {
                id: motor.i.0 as f32,
                iq: motor.i.1 as f32,
                velocity: 0.0,
            };
            match ident.step(&m) {
                IdentCommand::Voltage { vd, vq, .. } => motor.period((vd, vq)),
                IdentCommand::Done(result) => return result.unwrap(),
            }
        }
        panic!("identification did not finish");
    }

    fn assert_close(what: &str, measured: f32, truth: f64, tolerance: f64) {
        let rel = (measured as f64 / truth - 1.0).abs();
        assert!(rel < tolerance, "{what}: {measured} vs {truth} ({rel:.4})");
    }

    #[test]
    fn resistance_and_inductances_of_a_salient_motor() {
        let id = identify(0.9, 2.6e-3, 2.9e-3, 0.0);
        assert_close("R", id.resistance_ohm, 0.9, 0.005);
        assert_close("Ld", id.ld_h, 2.6e-3, 0.02);
        assert_close("Lq", id.lq_h, 2.9e-3, 0.02);
    }

    #[test]
    fn the_inverter_voltage_error_does_not_bias_the_resistance() {
        // 0.5 V of dead-time/drop error would read as +0.25 Ω at 2 A with a one-point V/I.
        let id = identify(0.9, 2.6e-3, 2.9e-3, 0.5);
        assert_close("R", id.resistance_ohm, 0.9, 0.005);
        assert_close("Ld", id.ld_h, 2.6e-3, 0.02);
    }

    #[test]
    fn low_resistance_low_inductance_motor() {
        let id = identify(0.05, 60e-6, 60e-6, 0.2);
        assert_close("R", id.resistance_ohm, 0.05, 0.01);
        assert_close("Ld", id.ld_h, 60e-6, 0.03);
        assert_close("Lq", id.lq_h, 60e-6, 0.03);
    }

    #[test]
    fn an_open_phase_is_an_identification_fault() {
        let cfg = ElectricalIdentConfig::small_servo(40_000.0);
        let mut ident = ElectricalIdentification::new(cfg).unwrap();
        for _ in 0..100_000 {
            // No current ever flows: the regulator hits its voltage limit, R = ΔV/ΔI is 0/0.
            if let IdentCommand::Done(result) = ident.step(&IdentMeasurement::default()) {
                assert_eq!(result, Err(MotorFault::Identification));
                return;
            }
        }
        panic!("did not finish");
    }

    #[test]
    fn inertia_with_friction_cancels_the_friction() {
        // Rigid rotor: J (N·m per increment/s²), Coulomb + viscous friction.
        let j = 2.0e-9;
        let kt = 0.08;
        let cfg = InertiaIdentConfig {
            sample_hz: 10_000.0,
            current_a: 2.0,
            torque_constant_nm_per_a: kt,
            max_speed: 2.0e6,
            max_time_s: 0.25,
        };
        let mut ident = InertiaIdentification::new(cfg).unwrap();
        let mut v = 0.0f64;
        let dt = 1.0 / 10_000.0;
        for _ in 0..100_000 {
            let m = IdentMeasurement {
                velocity: v as f32,
                ..Default::default()
            };
            let iq = match ident.step(&m) {
                InertiaStep::Current { iq_ref } => f64::from(iq_ref),
                InertiaStep::Done(result) => {
                    assert_close("J", result.unwrap(), j, 0.02);
                    return;
                }
            };
            let friction = 0.01 + 1e-9 * v;
            v += (kt as f64 * iq - friction) / j * dt;
        }
        panic!("did not finish");
    }

    #[test]
    fn inertia_of_a_fast_servo_through_a_lagging_velocity_estimate() {
        // The 400 W servo: 7.5 A reach 2 rev/s within about a millisecond, the order of the lag
        // of a 1 kHz velocity observer; Coulomb friction 0.02 N·m.
        let (fs, cpr, kt) = (20_000.0f32, 1_048_576.0f64, 0.081f64);
        let j = 5.2e-5 * TAU as f64 / cpr;
        let cfg = InertiaIdentConfig {
            sample_hz: fs,
            current_a: 7.5,
            torque_constant_nm_per_a: kt as f32,
            max_speed: 2.0 * cpr as f32,
            max_time_s: 0.25,
        };
        let mut ident = InertiaIdentification::new(cfg).unwrap();
        let mut estimator = crate::velocity::VelocityEstimator::new(1_000.0, fs).unwrap();
        let (mut p, mut v) = (0.0f64, 0.0f64);
        let substeps = 20;
        let h = 1.0 / (fs as f64 * substeps as f64);
        for _ in 0..100_000 {
            let m = IdentMeasurement {
                velocity: estimator.update(p.floor() as i64),
                ..Default::default()
            };
            let iq = match ident.step(&m) {
                InertiaStep::Current { iq_ref } => f64::from(iq_ref),
                InertiaStep::Done(result) => {
                    assert_close("J", result.unwrap(), j, 0.02);
                    return;
                }
            };
            for _ in 0..substeps {
                let friction = if v > 0.0 { 0.02 } else { 0.0 };
                v += (kt * iq - friction) / j * h;
                p += v * h;
            }
        }
        panic!("did not finish");
    }

    #[test]
    fn tuning_follows_the_bandwidth_rules() {
        let motor = Identified {
            resistance_ohm: 1.0,
            ld_h: 1e-3,
            lq_h: 2e-3,
        };
        let t = tune(
            &motor,
            1e-8,
            &Bandwidths {
                current_hz: 2_000.0,
                speed_hz: 200.0,
            },
        );
        let wc = TAU * 2_000.0;
        assert!((t.current_kp_d - 1e-3 * wc).abs() < 1e-3);
        assert!((t.current_kp_q - 2e-3 * wc).abs() < 1e-3);
        assert!((t.current_ki - wc).abs() < 1e-2);
        assert!((t.speed_kp / (1e-8 * TAU * 200.0) - 1.0).abs() < 1e-5);
    }
}
