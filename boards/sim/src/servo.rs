//! One simulated servo axis: the plant ([`crate::plant`]) wired to the firmware's control
//! interrupt ([`firmware::motor::axis::Axis`]) through what the real board does in between:
//! ADC counts → amperes with the nominal gain and zero (the true offsets stay unknown to the
//! firmware, which calibrates them), the encoder interface (32-bit counter extension, serial
//! frame decoding with its CRC), and the PWM shadow registers (duties computed in period k take
//! effect at the start of period k+1).
//!
//! The SYNC0 side is played by the caller: [`SimServo::publish`] once per bus cycle.

use firmware::motor::axis::{
    Axis, AxisCommand, AxisConfig, AxisConfigError, AxisFeedback, AxisLink, MotorData, Output,
    Sample,
};
use firmware::motor::calibration::AlignmentConfig;
use firmware::motor::filters::TorqueFilterConfig;
use firmware::motor::foc::CurrentLoopConfig;
use firmware::motor::protection::{I2tConfig, ProtectionConfig};
use firmware::motor::speed::{gains_for_bandwidth, SpeedLoopConfig};
use firmware::motor::Duties;
use hal::encoder::EncoderFault;
use hal::power::PhaseCurrents;

use crate::plant::{
    decode_serial_frame, EncoderParams, EncoderSample, Plant, PlantConfig, PlantError,
    SerialFrameError,
};

/// The board's tuning of the simulated servo: what commissioning sets (see
/// [`firmware::motor::commissioning`]).
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

impl Default for Tuning {
    /// 2 kHz current loop at 40 kHz PWM, 20 kHz position/speed loops, 1 ms bus cycle.
    fn default() -> Self {
        Self {
            current_hz: 2_000.0,
            speed_hz: 150.0,
            velocity_estimator_hz: 1_000.0,
            loop_divider: 2,
            bus_cycle_s: 1e-3,
        }
    }
}

/// Increments per mechanical revolution of an encoder.
pub fn counts_per_rev(encoder: &EncoderParams) -> u32 {
    match *encoder {
        EncoderParams::Incremental { counts_per_rev, .. } => counts_per_rev,
        EncoderParams::Absolute {
            single_turn_bits, ..
        } => 1u32 << single_turn_bits.min(31),
    }
}

/// The firmware configuration of an axis driving `plant`: motor data as commissioning found
/// it (the plant's nameplate values), gains from `tuning`, protections for the 48 V / 400 W
/// servo of [`PlantConfig::servo_400w`] (scaled by its rated current otherwise).
///
/// Absolute encoders get their commutation offset (0: the plant's encoder reads 0 where the
/// electrical angle is 0); incremental ones align at every enable.
pub fn axis_config(plant: &PlantConfig, tuning: &Tuning) -> AxisConfig {
    let m = &plant.motor;
    let cpr = counts_per_rev(&plant.encoder);
    let rad_per_count = std::f64::consts::TAU / f64::from(cpr);
    let inertia_kgm2 = m.rotor_inertia_kgm2 + plant.mechanics.load_inertia_kgm2;
    // N·m per (increment/s²).
    let inertia = (inertia_kgm2 * rad_per_count) as f32;
    let loop_hz = plant.inverter.pwm_hz as f32 / tuning.loop_divider as f32;
    let (kp, ki) = gains_for_bandwidth(tuning.speed_hz, inertia);
    let kt = 1.5 * f64::from(m.pole_pairs) * m.flux_wb;
    // Rated torque of the 400 W / 3000 rpm servo is 1.27 N·m (15.7 A); peak about twice.
    let rated_a = 15.7_f32;
    let peak_a = 30.0_f32;
    let counts_per_s_at_rpm = |rpm: f32| rpm / 60.0 * cpr as f32;
    let commutation_offset = match plant.encoder {
        EncoderParams::Absolute { .. } => Some(0),
        EncoderParams::Incremental { .. } => None,
    };
    AxisConfig {
        motor: MotorData {
            resistance_ohm: m.r_ohm as f32,
            ld_h: m.ld_h as f32,
            lq_h: m.lq_h as f32,
            flux_wb: m.flux_wb as f32,
            pole_pairs: m.pole_pairs,
            counts_per_rev: cpr,
            commutation_offset,
        },
        pwm_hz: plant.inverter.pwm_hz as f32,
        loop_divider: tuning.loop_divider,
        current_loop: CurrentLoopConfig {
            resistance_ohm: m.r_ohm as f32,
            ld_h: m.ld_h as f32,
            lq_h: m.lq_h as f32,
            flux_wb: m.flux_wb as f32,
            pwm_hz: plant.inverter.pwm_hz as f32,
            bandwidth_hz: tuning.current_hz,
            max_modulation: 0.95,
            dead_time_s: plant.inverter.dead_time_s as f32,
            // Ten times the current noise: the compensation ramps through zero there.
            dead_time_band_a: 0.3,
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
        position_kp: std::f32::consts::TAU * tuning.speed_hz / 4.0,
        velocity_limit: counts_per_s_at_rpm(4_500.0),
        velocity_bandwidth_hz: tuning.velocity_estimator_hz,
        protection: ProtectionConfig {
            over_current_a: 40.0,
            motor_i2t: I2tConfig {
                continuous_a: rated_a,
                peak_a,
                peak_time_s: 3.0,
                foldback_start: 0.8,
            },
            drive_i2t: I2tConfig {
                continuous_a: 18.0,
                peak_a,
                peak_time_s: 5.0,
                foldback_start: 0.8,
            },
            bus_over_voltage_v: 60.0,
            bus_under_voltage_v: 36.0,
            bus_confirm_s: 1e-3,
            over_speed: counts_per_s_at_rpm(5_400.0),
            over_speed_confirm_s: 1e-3,
            following_error_window: cpr / 4,
            following_error_timeout_ms: 20,
            ..ProtectionConfig::default()
        },
        current_limit_a: peak_a,
        offset_samples: 256,
        max_offset_a: 1.0,
        alignment: AlignmentConfig {
            current_a: 10.0,
            ramp_s: 0.05,
            settle_s: 0.15,
            rotate_s: 0.1,
            tolerance: 0.25,
        },
        bus_cycle_s: tuning.bus_cycle_s,
    }
}

/// Why a servo could not be built.
#[derive(Debug)]
pub enum ServoError {
    /// The plant configuration is invalid.
    Plant(PlantError),
    /// The firmware refused the axis configuration.
    Axis(AxisConfigError),
}

/// Extends a wrapping hardware position (32-bit counter, or a multi-turn value of `bits` bits)
/// to a 64-bit position, as the board's encoder driver does.
#[derive(Clone, Copy, Debug, Default)]
struct PositionExtender {
    last: Option<u64>,
    position: i64,
}

impl PositionExtender {
    /// Feeds the raw value (modulo 2^bits) and returns the extended position.
    fn update(&mut self, raw: u64, bits: u32) -> i64 {
        let modulus = 1u128 << bits;
        let position = match self.last {
            None => {
                // First value: interpret it as signed around zero.
                let half = (modulus / 2) as u64;
                if raw >= half {
                    raw as i64 - modulus as i64
                } else {
                    raw as i64
                }
            }
            Some(last) => {
                let delta = ((raw as u128 + modulus - last as u128) % modulus) as i64;
                let half = (modulus / 2) as i64;
                let delta = if delta >= half {
                    delta - modulus as i64
                } else {
                    delta
                };
                self.position + delta
            }
        };
        self.last = Some(raw);
        self.position = position;
        position
    }
}

/// One axis of the simulated board.
pub struct SimServo {
    /// The motor, inverter and sensors.
    pub plant: Plant,
    /// The firmware's control interrupt.
    pub axis: Axis,
    /// The SYNC0 ↔ control-interrupt mailboxes. `'static` because on a board they are a
    /// `static` shared by two interrupts (and the slave's application keeps a reference);
    /// here each servo leaks one (a few hundred bytes per servo, for the life of the process).
    link: &'static AxisLink,
    latched: Output,
    extender: PositionExtender,
    last_sample: Option<Sample>,
    periods: u64,
}

impl SimServo {
    /// A servo from a plant and an axis configuration.
    pub fn new(plant: PlantConfig, axis: AxisConfig) -> Result<Self, ServoError> {
        Ok(Self {
            plant: Plant::new(plant).map_err(ServoError::Plant)?,
            axis: Axis::new(axis).map_err(ServoError::Axis)?,
            // SAFETY: the simulation runs the SYNC0 side (`publish`, `feedback`, or the slave's
            // application holding `link()`) and the control interrupt (`period`) on one thread,
            // one after the other: they never overlap. `AxisLink` is not `Send`-restricted, but
            // the simulated drive that owns this servo is driven from one thread at a time.
            link: Box::leak(Box::new(unsafe { AxisLink::new() })),
            latched: Output {
                gates: false,
                duties: Duties::CENTRED,
            },
            extender: PositionExtender::default(),
            last_sample: None,
            periods: 0,
        })
    }

    /// Restarts the firmware side (a power cycle of the board): a new axis in its power-on
    /// state with a new link; the plant (the motor's physical state) goes on.
    pub fn restart_firmware(&mut self) {
        let cfg = *self.axis.config();
        if let Ok(axis) = Axis::new(cfg) {
            self.axis = axis;
        }
        // SAFETY: as in `new`.
        self.link = Box::leak(Box::new(unsafe { AxisLink::new() }));
        self.latched = Output {
            gates: false,
            duties: Duties::CENTRED,
        };
        self.extender = PositionExtender::default();
    }

    /// The PWM period, ns.
    pub fn period_ns(&self) -> u64 {
        (self.plant.period_s() * 1e9).round() as u64
    }

    /// Runs PWM periods until the plant's time reaches `now_ns` (the boards's clock).
    pub fn advance_to(&mut self, now_ns: u64) {
        let period = self.period_ns().max(1);
        while (self.periods + 1) * period <= now_ns {
            self.period();
        }
    }

    /// The SYNC0 side: hands over a command.
    pub fn publish(&mut self, command: AxisCommand) {
        self.link.publish(command);
    }

    /// The link, for the slave's application ([`firmware::slave::Slave::attach_axis`]). Only
    /// one context may publish: a servo whose link is attached is commanded by the slave, not
    /// by [`SimServo::publish`].
    pub fn link(&self) -> &'static AxisLink {
        self.link
    }

    /// The SYNC0 side: the latest feedback.
    pub fn feedback(&self) -> AxisFeedback {
        self.link.feedback()
    }

    /// PWM periods run so far.
    pub fn periods(&self) -> u64 {
        self.periods
    }

    /// The sample the firmware saw in the last period.
    pub fn last_sample(&self) -> Option<&Sample> {
        self.last_sample.as_ref()
    }

    /// The output the firmware computed in the last period (applied in the next).
    pub fn latched(&self) -> Output {
        self.latched
    }

    /// One PWM period: sample at the boundary, run the control interrupt, integrate the plant
    /// over the period with the duties latched at its start.
    pub fn period(&mut self) {
        let sample = self.board_sample();
        let next = self.axis.control_step(&sample, self.link);
        let applied = self.latched;
        // A gate-off decision acts at once (the board's disable is immediate), duties at the
        // next period boundary.
        let gates = applied.gates && next.gates;
        let duties = applied.duties;
        self.plant.run_period([duties.a, duties.b, duties.c], gates);
        self.latched = next;
        self.last_sample = Some(sample);
        self.periods += 1;
    }

    /// Runs `n` PWM periods.
    pub fn run_periods(&mut self, n: u64) {
        for _ in 0..n {
            self.period();
        }
    }

    /// What the board reads at a period boundary.
    fn board_sample(&mut self) -> Sample {
        let s = self.plant.sample();
        let cfg = self.plant.config();
        let sensing = &cfg.sensing;
        let amps = |count: u16| {
            (f64::from(count) - f64::from(sensing.zero_count)) * sensing.amps_per_count
        };
        let currents = PhaseCurrents {
            a: amps(s.phase_current_counts[0]) as f32,
            b: amps(s.phase_current_counts[1]) as f32,
            c: amps(s.phase_current_counts[2]) as f32,
        };
        let bus_voltage = (f64::from(s.bus_voltage_counts) * sensing.bus_volts_per_count) as f32;
        let position = match (s.encoder, cfg.encoder) {
            (
                EncoderSample::Incremental {
                    count, signal_ok, ..
                },
                _,
            ) => {
                if signal_ok {
                    Ok(self.extender.update(u64::from(count), 32))
                } else {
                    Err(EncoderFault::SignalLoss)
                }
            }
            (
                EncoderSample::Serial { frame, len },
                EncoderParams::Absolute {
                    single_turn_bits,
                    multi_turn_bits,
                    ..
                },
            ) => {
                let bytes = frame.get(..usize::from(len)).unwrap_or(&[]);
                match decode_serial_frame(bytes, single_turn_bits, multi_turn_bits) {
                    Ok(p) => {
                        let raw = (u64::from(p.multi_turn) << single_turn_bits)
                            | u64::from(p.single_turn);
                        let bits = u32::from(single_turn_bits) + u32::from(multi_turn_bits);
                        Ok(self.extender.update(raw, bits))
                    }
                    Err(SerialFrameError::Crc) => Err(EncoderFault::Crc),
                    Err(_) => Err(EncoderFault::SignalLoss),
                }
            }
            (EncoderSample::Serial { .. }, EncoderParams::Incremental { .. }) => {
                Err(EncoderFault::SignalLoss)
            }
        };
        Sample {
            currents,
            bus_voltage,
            temperature: s.drive_temperature_c,
            motor_overtemp: s.motor_overtemp_input,
            position,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn position_extender_follows_wraps_both_ways() {
        let mut e = PositionExtender::default();
        assert_eq!(e.update(u64::from(u32::MAX - 1), 32), -2);
        assert_eq!(e.update(3, 32), 3);
        assert_eq!(e.update(u64::from(u32::MAX), 32), -1);
        let mut m = PositionExtender::default();
        let bits = 20 + 16;
        let top = (1u64 << bits) - 5;
        assert_eq!(m.update(10, bits), 10);
        assert_eq!(m.update(top, bits), -5);
        assert_eq!(m.update(7, bits), 7);
    }
}
