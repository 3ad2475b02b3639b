//! A servo (drive + motor + encoder) as plain data, its tuning, and the [`AxisConfig`] derived
//! from them: the one place where the commissioned configuration of an axis is computed.
//!
//! [`SERVO_400W`] is the reference servo of this repository: a 48 V / 400 W / 3000 rpm PMSM
//! with 4 pole pairs and a 20-bit absolute encoder on a 40 kHz inverter. The simulated board
//! (`boards/sim`: its plant takes the motor, inverter and encoder numbers from here, its
//! `servo::axis_config` overrides them with the plant's) and the Cortex-M4 benchmarks
//! (`boards/qemu-m4`) both derive their axis configuration with [`axis_config`].
//!
//! # Units and types
//! The motor's physical parameters (resistance, inductances, flux, inertia) and the inverter's
//! PWM frequency, dead time and bus voltage are `f64` in SI units: they are commissioning data
//! that [`axis_config`] uses once, when a configuration is built (never in the control
//! interrupt), and a simulation uses them unrounded. Limits and settings are `f32` in the units
//! of [`AxisConfig`]. Nothing here needs `std` or `libm`.

use super::axis::{AxisConfig, MotorData};
use super::calibration::AlignmentConfig;
use super::field_weakening::FieldWeakeningConfig;
use super::filters::TorqueFilterConfig;
use super::foc::CurrentLoopConfig;
use super::math::TAU;
use super::protection::{I2tConfig, ProtectionConfig};
use super::speed::{gains_for_bandwidth, SpeedLoopConfig};

/// The tuning of an axis: what commissioning sets (see [`super::commissioning`]) and the rates
/// the application runs it at.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tuning {
    /// Current-loop design bandwidth, Hz.
    pub current_hz: f32,
    /// Speed-loop design bandwidth, Hz.
    pub speed_hz: f32,
    /// Velocity-estimator bandwidth, Hz.
    pub velocity_estimator_hz: f32,
    /// PWM periods per position/speed-loop tick.
    pub loop_divider: u32,
    /// Bus cycle of the set-points, s.
    pub bus_cycle_s: f32,
}

impl Tuning {
    /// The reference tuning: 2 kHz current loop, 150 Hz speed loop, 1 kHz velocity estimator,
    /// position/speed loops every 2nd PWM period (20 kHz at 40 kHz PWM), 1 ms bus cycle.
    pub const DEFAULT: Self = Self {
        current_hz: 2_000.0,
        speed_hz: 150.0,
        velocity_estimator_hz: 1_000.0,
        loop_divider: 2,
        bus_cycle_s: 1e-3,
    };
}

impl Default for Tuning {
    /// [`Tuning::DEFAULT`]: 2 kHz current loop at 40 kHz PWM, 20 kHz position/speed loops,
    /// 1 ms bus cycle.
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The motor: electrical parameters, rotor inertia, current and speed ratings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotorSpec {
    /// Phase resistance, Ω.
    pub resistance_ohm: f64,
    /// d-axis inductance, H.
    pub ld_h: f64,
    /// q-axis inductance, H.
    pub lq_h: f64,
    /// Permanent-magnet flux linkage, Wb (peak, per phase).
    pub flux_wb: f64,
    /// Pole pairs.
    pub pole_pairs: u32,
    /// Rotor inertia, kg·m².
    pub rotor_inertia_kgm2: f64,
    /// Rated (continuous) current, A: the motor's I²t continuous level.
    pub rated_current_a: f32,
    /// Peak current, A: the axis current limit, the speed loop's torque limit (through
    /// 1.5·p·ψ) and the peak of both I²t integrals.
    pub peak_current_a: f32,
    /// How long the motor may carry its peak current, s (motor I²t).
    pub peak_time_s: f32,
    /// Highest commanded speed, rpm: the velocity limit of the position loop.
    pub max_speed_rpm: f32,
}

/// The position encoder.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EncoderSpec {
    /// Incremental (quadrature ABZ): the commutation angle is found by alignment at every
    /// enable.
    Incremental {
        /// Counts per mechanical revolution (after x4 decoding).
        counts_per_rev: u32,
    },
    /// Absolute (serial).
    Absolute {
        /// Single-turn resolution, bits.
        single_turn_bits: u8,
        /// Multi-turn counter, bits (0: single-turn).
        multi_turn_bits: u8,
        /// The position where the electrical angle is zero, if commissioned (`None`: align at
        /// every enable as with an incremental encoder).
        commutation_offset: Option<i64>,
    },
}

impl EncoderSpec {
    /// Increments per mechanical revolution (an absolute encoder's single-turn range, at most
    /// 2^31).
    pub const fn counts_per_rev(&self) -> u32 {
        match *self {
            EncoderSpec::Incremental { counts_per_rev } => counts_per_rev,
            EncoderSpec::Absolute {
                single_turn_bits, ..
            } => {
                let bits = if single_turn_bits > 31 {
                    31
                } else {
                    single_turn_bits
                };
                1u32 << bits
            }
        }
    }

    /// Whether the encoder is absolute.
    pub const fn is_absolute(&self) -> bool {
        matches!(self, EncoderSpec::Absolute { .. })
    }

    /// The known commutation offset (commissioned absolute encoders only).
    pub const fn commutation_offset(&self) -> Option<i64> {
        match *self {
            EncoderSpec::Incremental { .. } => None,
            EncoderSpec::Absolute {
                commutation_offset, ..
            } => commutation_offset,
        }
    }
}

/// The drive's power stage and its sensing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InverterSpec {
    /// PWM frequency = current-loop rate, Hz.
    pub pwm_hz: f64,
    /// Dead time of the gate drivers, s.
    pub dead_time_s: f64,
    /// Nominal DC-bus voltage, V.
    pub bus_voltage_v: f64,
    /// Largest modulation index the current loop may use (the rest of the period is needed
    /// for the current sampling and the bootstrap supplies).
    pub max_modulation: f32,
    /// Current below which the dead-time compensation ramps through zero, A (about ten times
    /// the current-measurement noise).
    pub dead_time_band_a: f32,
    /// Phase-current trip level, A.
    pub over_current_a: f32,
    /// Continuous current of the power stage, A (drive I²t).
    pub continuous_current_a: f32,
    /// How long the power stage may carry the peak current, s (drive I²t).
    pub peak_time_s: f32,
    /// DC-bus over-voltage trip, V.
    pub bus_over_voltage_v: f32,
    /// DC-bus under-voltage trip, V.
    pub bus_under_voltage_v: f32,
}

/// Protection settings that are neither motor nor power-stage ratings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProtectionSpec {
    /// Fraction of both I²t limits where the current fold-back starts.
    pub i2t_foldback_start: f32,
    /// Time a bus-voltage violation must persist, s.
    pub bus_confirm_s: f32,
    /// Over-speed trip, rpm.
    pub over_speed_rpm: f32,
    /// Time an over-speed must persist, s.
    pub over_speed_confirm_s: f32,
    /// The following-error window is `counts_per_rev / following_error_window_div`
    /// increments (4: a quarter turn; 0 counts as 1, a whole turn).
    pub following_error_window_div: u32,
    /// Time the following error may stay outside its window, ms.
    pub following_error_timeout_ms: u16,
}

/// Calibration at enable: current-sensor offsets and the commutation-angle alignment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CalibrationSpec {
    /// Samples of the offset calibration.
    pub offset_samples: u32,
    /// Largest plausible current-sensor offset, A.
    pub max_offset_a: f32,
    /// Alignment (encoders without a known commutation offset).
    pub alignment: AlignmentConfig,
}

/// A servo axis as plain data: motor, load, encoder, power stage, protections, calibration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ServoSpec {
    /// The motor.
    pub motor: MotorSpec,
    /// Load inertia on the motor shaft, kg·m² (added to the rotor's for the speed loop).
    pub load_inertia_kgm2: f64,
    /// The position encoder.
    pub encoder: EncoderSpec,
    /// The power stage.
    pub inverter: InverterSpec,
    /// Protection settings.
    pub protection: ProtectionSpec,
    /// Calibration settings.
    pub calibration: CalibrationSpec,
}

/// Field weakening starts at this fraction of the current loop's voltage circle: enough
/// headroom for the current loop to correct a disturbance without saturating.
const FIELD_WEAKENING_VOLTAGE_FRACTION: f32 = 0.95;
/// Field-weakening integrator gain, A per loop tick and unit of normalised squared voltage
/// error: a ~3 ms time constant on the 400 W servo (see `field_weakening`).
const FIELD_WEAKENING_GAIN_A: f32 = 1.0;

/// The reference servo: a 400 W, 3000 rpm (rated torque 1.27 N·m at 15.7 A) PMSM with 4 pole
/// pairs on a **48 V** bus, 40 kHz PWM with 200 ns dead time, a 20-bit single-turn + 16-bit
/// multi-turn absolute encoder with a commissioned commutation offset of 0, and a load of the
/// rotor's inertia (1:1). Peak current 30 A (about twice the rated torque), trip at 40 A;
/// bus limits 36–60 V; speed limit 4500 rpm, over-speed trip at 5400 rpm.
pub const SERVO_400W: ServoSpec = ServoSpec {
    motor: MotorSpec {
        resistance_ohm: 0.12,
        ld_h: 0.40e-3,
        lq_h: 0.46e-3,
        flux_wb: 0.0135,
        pole_pairs: 4,
        rotor_inertia_kgm2: 2.6e-5,
        rated_current_a: 15.7,
        peak_current_a: 30.0,
        peak_time_s: 3.0,
        max_speed_rpm: 4_500.0,
    },
    // 1:1 load-to-rotor inertia ratio.
    load_inertia_kgm2: 2.6e-5,
    encoder: EncoderSpec::Absolute {
        single_turn_bits: 20,
        multi_turn_bits: 16,
        commutation_offset: Some(0),
    },
    inverter: InverterSpec {
        pwm_hz: 40_000.0,
        dead_time_s: 200e-9,
        bus_voltage_v: 48.0,
        max_modulation: 0.95,
        // Ten times the current noise: the compensation ramps through zero there.
        dead_time_band_a: 0.3,
        over_current_a: 40.0,
        continuous_current_a: 18.0,
        peak_time_s: 5.0,
        bus_over_voltage_v: 60.0,
        bus_under_voltage_v: 36.0,
    },
    protection: ProtectionSpec {
        i2t_foldback_start: 0.8,
        bus_confirm_s: 1e-3,
        over_speed_rpm: 5_400.0,
        over_speed_confirm_s: 1e-3,
        following_error_window_div: 4,
        following_error_timeout_ms: 20,
    },
    calibration: CalibrationSpec {
        offset_samples: 256,
        max_offset_a: 1.0,
        alignment: AlignmentConfig {
            current_a: 10.0,
            ramp_s: 0.05,
            settle_s: 0.15,
            rotate_s: 0.1,
            tolerance: 0.25,
        },
    },
};

/// The axis configuration of `spec` at `tuning`: motor data as given, the current loop at
/// `tuning.current_hz` with decoupling and dead-time compensation, the speed loop's gains for
/// `tuning.speed_hz` on the rotor + load inertia with a torque limit of 1.5·p·ψ·peak current,
/// position gain `2π·speed_hz/4`, protections from the motor and power-stage ratings. A
/// configuration-time computation (uses `f64`; no `libm`).
pub fn axis_config(spec: &ServoSpec, tuning: &Tuning) -> AxisConfig {
    let m = &spec.motor;
    let inv = &spec.inverter;
    let prot = &spec.protection;
    let cpr = spec.encoder.counts_per_rev();
    let rad_per_count = core::f64::consts::TAU / f64::from(cpr);
    let inertia_kgm2 = m.rotor_inertia_kgm2 + spec.load_inertia_kgm2;
    // N·m per (increment/s²).
    let inertia = (inertia_kgm2 * rad_per_count) as f32;
    let pwm_hz = inv.pwm_hz as f32;
    let loop_hz = pwm_hz / tuning.loop_divider as f32;
    let (kp, ki) = gains_for_bandwidth(tuning.speed_hz, inertia);
    let kt = 1.5 * f64::from(m.pole_pairs) * m.flux_wb;
    let peak_a = m.peak_current_a;
    let counts_per_s_at_rpm = |rpm: f32| rpm / 60.0 * cpr as f32;
    let i2t = |continuous_a: f32, peak_time_s: f32| I2tConfig {
        continuous_a,
        peak_a,
        peak_time_s,
        foldback_start: prot.i2t_foldback_start,
    };
    AxisConfig {
        motor: MotorData {
            resistance_ohm: m.resistance_ohm as f32,
            ld_h: m.ld_h as f32,
            lq_h: m.lq_h as f32,
            flux_wb: m.flux_wb as f32,
            pole_pairs: m.pole_pairs,
            counts_per_rev: cpr,
            commutation_offset: spec.encoder.commutation_offset(),
        },
        pwm_hz,
        loop_divider: tuning.loop_divider,
        current_loop: CurrentLoopConfig {
            resistance_ohm: m.resistance_ohm as f32,
            ld_h: m.ld_h as f32,
            lq_h: m.lq_h as f32,
            flux_wb: m.flux_wb as f32,
            pwm_hz,
            bandwidth_hz: tuning.current_hz,
            max_modulation: inv.max_modulation,
            dead_time_s: inv.dead_time_s as f32,
            dead_time_band_a: inv.dead_time_band_a,
            decoupling: true,
        },
        speed_loop: SpeedLoopConfig {
            kp,
            ki,
            inertia_nm_per_inc_s2: inertia,
            torque_limit_nm: (kt as f32) * peak_a,
            sample_hz: loop_hz,
            filters: TorqueFilterConfig::OFF,
        },
        field_weakening: FieldWeakeningConfig {
            voltage_fraction: FIELD_WEAKENING_VOLTAGE_FRACTION,
            gain_a: FIELD_WEAKENING_GAIN_A,
            // The d current never exceeds the rated current (demagnetisation margin, and the
            // current vector leaves q at least √(I_p² − I_rated²)).
            max_d_current_a: m.rated_current_a,
        },
        position_kp: TAU * tuning.speed_hz / 4.0,
        velocity_limit: counts_per_s_at_rpm(m.max_speed_rpm),
        velocity_bandwidth_hz: tuning.velocity_estimator_hz,
        protection: ProtectionConfig {
            over_current_a: inv.over_current_a,
            motor_i2t: i2t(m.rated_current_a, m.peak_time_s),
            drive_i2t: i2t(inv.continuous_current_a, inv.peak_time_s),
            bus_over_voltage_v: inv.bus_over_voltage_v,
            bus_under_voltage_v: inv.bus_under_voltage_v,
            bus_confirm_s: prot.bus_confirm_s,
            over_speed: counts_per_s_at_rpm(prot.over_speed_rpm),
            over_speed_confirm_s: prot.over_speed_confirm_s,
            following_error_window: cpr
                .checked_div(prot.following_error_window_div)
                .unwrap_or(cpr),
            following_error_timeout_ms: prot.following_error_timeout_ms,
            ..ProtectionConfig::default()
        },
        current_limit_a: peak_a,
        offset_samples: spec.calibration.offset_samples,
        max_offset_a: spec.calibration.max_offset_a,
        alignment: spec.calibration.alignment,
        bus_cycle_s: tuning.bus_cycle_s,
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use crate::axis::Axis;

    fn close(a: f32, b: f64, rel: f64) -> bool {
        (f64::from(a) - b).abs() <= rel * b.abs()
    }

    #[test]
    fn reference_servo_has_the_documented_key_values() {
        let cfg = axis_config(&SERVO_400W, &Tuning::default());
        let cpr: u32 = 1 << 20;
        // 1.5 · p · ψ · peak = 1.5 · 4 · 0.0135 Wb · 30 A = 2.43 N·m.
        assert!(close(cfg.speed_loop.torque_limit_nm, 2.43, 1e-6));
        // (2.6e-5 + 2.6e-5) kg·m² · 2π / 2^20 N·m per (increment/s²).
        let inertia = 5.2e-5 * std::f64::consts::TAU / 1_048_576.0;
        assert!(close(cfg.speed_loop.inertia_nm_per_inc_s2, inertia, 1e-6));
        assert_eq!(cfg.motor.counts_per_rev, cpr);
        assert_eq!(cfg.protection.following_error_window, 262_144);
        // 5400 rpm = 90 rev/s = 90 · 2^20 increments/s (exact in f32).
        assert_eq!(cfg.protection.over_speed, 94_371_840.0);
        // 4500 rpm = 75 rev/s.
        assert_eq!(cfg.velocity_limit, 78_643_200.0);
        assert_eq!(cfg.motor.commutation_offset, Some(0));
        assert_eq!(cfg.motor.pole_pairs, 4);
        assert_eq!(cfg.pwm_hz, 40_000.0);
        assert_eq!(cfg.speed_loop.sample_hz, 20_000.0);
        assert_eq!(cfg.current_limit_a, 30.0);
        assert_eq!(cfg.protection.over_current_a, 40.0);
        assert_eq!(cfg.protection.motor_i2t.continuous_a, 15.7);
        assert_eq!(cfg.protection.motor_i2t.peak_a, 30.0);
        assert_eq!(cfg.protection.drive_i2t.continuous_a, 18.0);
        assert_eq!(cfg.protection.drive_i2t.peak_a, 30.0);
        assert_eq!(cfg.protection.bus_over_voltage_v, 60.0);
        assert_eq!(cfg.protection.bus_under_voltage_v, 36.0);
        assert_eq!(cfg.current_loop.bandwidth_hz, 2_000.0);
        assert_eq!(cfg.current_loop.resistance_ohm, 0.12);
        assert_eq!(cfg.current_loop.dead_time_s, 200e-9);
        assert!(close(
            cfg.position_kp,
            2.0 * std::f64::consts::PI * 150.0 / 4.0,
            1e-6
        ));
        assert_eq!(cfg.bus_cycle_s, 1e-3);
        // The speed-loop gains are those of the 150 Hz design on that inertia.
        assert_eq!(
            (cfg.speed_loop.kp, cfg.speed_loop.ki),
            gains_for_bandwidth(150.0, cfg.speed_loop.inertia_nm_per_inc_s2)
        );
        assert!(Axis::new(cfg).is_ok());
    }

    #[test]
    fn tuning_fields_reach_the_configuration() {
        let tuning = Tuning {
            loop_divider: 1,
            bus_cycle_s: 25e-6,
            ..Tuning::DEFAULT
        };
        let cfg = axis_config(&SERVO_400W, &tuning);
        assert_eq!(cfg.loop_divider, 1);
        assert_eq!(cfg.speed_loop.sample_hz, 40_000.0);
        assert_eq!(cfg.bus_cycle_s, 25e-6);
        assert_eq!(Tuning::default(), Tuning::DEFAULT);
    }

    #[test]
    fn incremental_encoders_align_and_use_their_counts() {
        let spec = ServoSpec {
            encoder: EncoderSpec::Incremental {
                counts_per_rev: 10_000,
            },
            ..SERVO_400W
        };
        let cfg = axis_config(&spec, &Tuning::default());
        assert_eq!(cfg.motor.commutation_offset, None);
        assert_eq!(cfg.motor.counts_per_rev, 10_000);
        assert_eq!(cfg.protection.following_error_window, 2_500);
        assert!(!spec.encoder.is_absolute());
        assert!(SERVO_400W.encoder.is_absolute());
    }
}
