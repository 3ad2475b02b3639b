//! Simulated plant of one drive axis: PMSM in dq axes ([`pmsm`]), voltage-source inverter with
//! centre-aligned PWM, dead time and device drops ([`inverter`]), current and bus-voltage ADC
//! ([`sensing`]), incremental or absolute serial encoder ([`encoder`]), rigid mechanics with
//! friction and end stops plus limit/home switches ([`mechanics`]), and a seeded PRNG for the
//! sensor noise (xoshiro256** + Box–Muller, private module `rng`). Each axis is an independent [`Plant`]; there is no global state.
//!
//! # Timing
//!
//! One call of [`Plant::run_period`] integrates one PWM period `Ts = 1/pwm_hz`, from the period
//! boundary `t_k` to `t_k + Ts`, with the duties latched at `t_k`. [`Plant::sample`] returns what
//! the ADC and the encoder interface latch at the present boundary (all low sides on):
//!
//! ```text
//! loop {
//!     let s = plant.sample();               // at t_k
//!     let next = control_step(s);           // computed during period k
//!     plant.run_period(latched, gates_on);  // [t_k, t_k + Ts) with the duties latched at t_k
//!     latched = next;
//! }
//! ```
//!
//! # Model and integration
//!
//! The equations are in the sub-module docs: dq voltage and torque equations in [`pmsm`],
//! PWM/dead-time leg voltages in [`inverter`], friction/stiction/end stops in [`mechanics`].
//! Each period is split into `substeps_per_period` equal substeps `h` (default 20, at least
//! 10). Per substep:
//!
//! 1. the exact average of each leg voltage over the substep is computed from the overlap of
//!    the substep with the switch on-windows (dead-time intervals resolved with the phase
//!    current's sign at the start of the substep);
//! 2. the phase-to-neutral voltages of the star-connected motor are
//!    `v_an = v_a0 − (v_a0 + v_b0 + v_c0)/3`; the amplitude-invariant Clarke transform discards
//!    exactly that zero sequence, and the Park transform uses the electrical angle at the
//!    middle of the substep;
//! 3. the dq currents advance by one Heun (RK2) step at constant speed. At the default
//!    parameters the largest `|λ|·h` of the current dynamics is about
//!    `(R/L + ωe)·h ≈ (300 + 2500 s⁻¹)·1.25 µs ≈ 0.004` even at 6000 rpm, far inside RK2's
//!    stability region, with a local error of order `(|λ|h)³/6 ≈ 1e−8` relative; the steady
//!    state of the linear step is exactly that of the ODE;
//! 4. the mechanics advance with the mean of the start and end electromagnetic torque.
//!
//! Gates disabled: all switches are off and each phase conducts through a diode chosen by its
//! current's direction until that current reaches zero, where it is clamped to exactly zero and
//! the phase floats. With one phase floating the two others form a single current loop,
//! integrated as a scalar ODE in the loop flux ([`pmsm`]), so the floating phase carries exactly
//! zero current; the loop ends when its current reaches zero. A floating phase (or, from rest,
//! a pair of phases) starts conducting again only when the back-EMF drives its terminal beyond
//! the DC rails by a diode drop: below `√3·ψ·ωe = Vbus + 2·Vdrop` the currents stay at zero;
//! above, the motor brakes through the diode rectifier.
//!
//! # Fidelity
//!
//! [`Fidelity::PwmResolved`] (the default) is the model above. [`Fidelity::Averaged`] takes one
//! step per PWM period, that is one per run of the control loop, with each leg's voltage
//! averaged over the whole period (dead time included, resolved with the current's sign at
//! the period's start): the same dq equations, mechanics, sensors and diode states, without
//! the current ripple within a period. The step is then `h = Ts` (25 µs at 40 kHz), where
//! `|λ|·h ≈ (300 + 2500 s⁻¹)·25 µs ≈ 0.07` at 6000 rpm: still well inside Heun's stability
//! region, with a relative local error of order `0.07³/6 ≈ 6e−5` per step. It costs a
//! twentieth of the default plant's arithmetic, for lines of many simulated drives where the
//! bus behaviour matters more than the PWM ripple.
//!
//! Everything is deterministic: the same configuration, seed and call sequence give
//! bit-identical results.

pub mod encoder;
pub mod inverter;
pub mod mechanics;
pub mod pmsm;
mod rng;
pub mod sensing;

pub use encoder::{
    crc8, decode_serial_frame, encode_serial_frame, EncoderFaultInjection, EncoderParams,
    EncoderSample, SerialFrameError, SerialPosition, MULTI_TURN_BITS, SERIAL_FRAME_LEN,
    SINGLE_TURN_BITS, STATUS_ERROR,
};
pub use inverter::InverterParams;
pub use mechanics::{MechParams, SwitchParams};
pub use pmsm::MotorParams;
pub use sensing::SensingParams;

use encoder::EncoderModel;
use firmware::motor::servo::{EncoderSpec, SERVO_400W};
use inverter::LegTiming;
use mechanics::{MechState, MechStep};
use pmsm::{
    clarke, inverse_clarke, inverse_park, inverse_park_at, park, park_at, rotated, CurrentLoop,
};
use rng::Rng;

/// Fewest substeps per PWM period the plant accepts (coarser steps cannot resolve the PWM
/// pulses' effect on the current ripple well enough).
pub const MIN_SUBSTEPS: u32 = 10;
/// Most substeps per PWM period the plant accepts (bounds the work and the encoder history).
pub const MAX_SUBSTEPS: u32 = 10_000;
/// Substeps per period of [`PlantConfig::servo_400w`].
pub const DEFAULT_SUBSTEPS: u32 = 20;
/// Highest supported ADC resolution (the readings are `u16`).
pub const MAX_ADC_BITS: u32 = 16;
/// Drive temperature reported until [`Plant::set_drive_temperature`] is called, in °C.
pub const DEFAULT_DRIVE_TEMPERATURE_C: f64 = 25.0;
/// Periods of angle history kept for the absolute encoder's latch delay.
const ENCODER_HISTORY_PERIODS: usize = 2;

/// How finely the plant resolves the inverter (module doc, "Fidelity").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Fidelity {
    /// `substeps_per_period` steps per PWM period, the leg voltages from the switching
    /// instants: the current ripple and the dead time's effect within a period.
    #[default]
    PwmResolved,
    /// One step per PWM period with the period's average leg voltages.
    Averaged,
}

impl Fidelity {
    /// The names `sim-drive` accepts (`--plant NAME`), with each fidelity.
    pub const NAMES: [(&'static str, Fidelity); 2] = [
        ("pwm", Fidelity::PwmResolved),
        ("averaged", Fidelity::Averaged),
    ];

    /// The fidelity's name in [`Self::NAMES`].
    pub fn name(self) -> &'static str {
        Self::NAMES
            .iter()
            .find(|(_, f)| *f == self)
            .map_or("", |(n, _)| n)
    }

    /// The fidelity called `name` in [`Self::NAMES`].
    pub fn by_name(name: &str) -> Option<Fidelity> {
        Self::NAMES
            .iter()
            .find(|(n, _)| *n == name)
            .map(|&(_, fidelity)| fidelity)
    }
}

/// Complete configuration of one simulated axis.
#[derive(Debug, Clone, PartialEq)]
pub struct PlantConfig {
    /// Motor electrical parameters and rotor inertia.
    pub motor: MotorParams,
    /// Power stage.
    pub inverter: InverterParams,
    /// Current and bus-voltage sensing.
    pub sensing: SensingParams,
    /// Position encoder.
    pub encoder: EncoderParams,
    /// Load, friction and end stops.
    pub mechanics: MechParams,
    /// Limit and home switches.
    pub switches: SwitchParams,
    /// Integration substeps per PWM period (`MIN_SUBSTEPS..=MAX_SUBSTEPS`) of the
    /// [`Fidelity::PwmResolved`] plant.
    pub substeps_per_period: u32,
    /// How finely the inverter is resolved.
    pub fidelity: Fidelity,
    /// Seed of the noise generator.
    pub seed: u64,
}

impl PlantConfig {
    /// A realistic low-voltage servo axis: 400 W, 3000 rpm (rated torque 1.27 N·m), 4 pole
    /// pairs, on a **48 V** bus.
    ///
    /// Consistency at the rated point (ωe = 4·314 = 1257 rad/s): `Kt = 1.5·p·ψ = 0.081 N·m/A`
    /// (peak) → 15.7 A peak; back-EMF `ψ·ωe = 17.0 V`, `vq = R·iq + ψ·ωe = 18.9 V`,
    /// `vd = −ωe·Lq·iq = −9.1 V`, `|v| = 21 V` < `48/√3 = 27.7 V` (linear SVPWM limit).
    /// Copper loss `1.5·R·i² = 44 W`. Electrical time constants `Ld/R = 3.3 ms`, `Lq/R = 3.8 ms`.
    /// Current ADC ±51 A (12 bit, 25 mA/count) covers a 3× peak torque; 40 kHz PWM with 200 ns
    /// dead time (0.8 % of the period, i.e. 0.38 V of leg-voltage error); 20-bit single-turn
    /// plus 16-bit multi-turn absolute encoder.
    ///
    /// The motor, inverter, encoder and load-inertia numbers are those of the firmware's
    /// reference servo [`SERVO_400W`] (defined once there); the device drop, sensing, encoder
    /// latch delay, friction and noise are the plant's own.
    pub fn servo_400w() -> Self {
        let spec = &SERVO_400W;
        let encoder = match spec.encoder {
            EncoderSpec::Absolute {
                single_turn_bits,
                multi_turn_bits,
                ..
            } => EncoderParams::Absolute {
                single_turn_bits,
                multi_turn_bits,
                sample_delay_s: 1e-6,
            },
            EncoderSpec::Incremental { counts_per_rev } => EncoderParams::Incremental {
                counts_per_rev,
                index_at_rad: 0.0,
            },
        };
        PlantConfig {
            motor: MotorParams {
                r_ohm: spec.motor.resistance_ohm,
                ld_h: spec.motor.ld_h,
                lq_h: spec.motor.lq_h,
                flux_wb: spec.motor.flux_wb,
                pole_pairs: spec.motor.pole_pairs,
                rotor_inertia_kgm2: spec.motor.rotor_inertia_kgm2,
            },
            inverter: InverterParams {
                bus_voltage_v: spec.inverter.bus_voltage_v,
                pwm_hz: spec.inverter.pwm_hz,
                dead_time_s: spec.inverter.dead_time_s,
                device_drop_v: 0.05,
            },
            sensing: SensingParams {
                adc_bits: 12,
                amps_per_count: 0.025,
                zero_count: 2048,
                offset_a: [0.06, -0.04, 0.02],
                noise_a_rms: 0.03,
                bus_volts_per_count: 0.025,
            },
            encoder,
            mechanics: MechParams {
                // 1:1 load-to-rotor inertia ratio.
                load_inertia_kgm2: spec.load_inertia_kgm2,
                viscous_nm_per_rad_s: 2e-5,
                coulomb_nm: 0.02,
                end_stops_rad: None,
            },
            switches: SwitchParams::default(),
            substeps_per_period: DEFAULT_SUBSTEPS,
            fidelity: Fidelity::PwmResolved,
            seed: 0x5EED_0001,
        }
    }

    /// Checks every parameter; the first problem found is returned.
    pub fn validate(&self) -> Result<(), PlantError> {
        let n = self.substeps_per_period;
        if n < MIN_SUBSTEPS {
            return Err(PlantError::TooFewSubsteps(n));
        }
        if n > MAX_SUBSTEPS {
            return Err(PlantError::TooManySubsteps(n));
        }
        let positive = |v: f64| v.is_finite() && v > 0.0;
        let non_negative = |v: f64| v.is_finite() && v >= 0.0;
        let check = |ok: bool, what: &'static str| {
            if ok {
                Ok(())
            } else {
                Err(PlantError::InvalidParameter(what))
            }
        };
        let m = &self.motor;
        check(positive(m.r_ohm), "motor r_ohm must be > 0")?;
        check(positive(m.ld_h), "motor ld_h must be > 0")?;
        check(positive(m.lq_h), "motor lq_h must be > 0")?;
        check(positive(m.flux_wb), "motor flux_wb must be > 0")?;
        check(m.pole_pairs > 0, "motor pole_pairs must be > 0")?;
        check(
            positive(m.rotor_inertia_kgm2),
            "motor rotor_inertia_kgm2 must be > 0",
        )?;
        let inv = &self.inverter;
        check(
            positive(inv.bus_voltage_v),
            "inverter bus_voltage_v must be > 0",
        )?;
        check(positive(inv.pwm_hz), "inverter pwm_hz must be > 0")?;
        check(
            non_negative(inv.dead_time_s) && inv.dead_time_s * inv.pwm_hz < 0.5,
            "inverter dead_time_s must be >= 0 and below half the PWM period",
        )?;
        check(
            non_negative(inv.device_drop_v),
            "inverter device_drop_v must be >= 0",
        )?;
        let s = &self.sensing;
        check(
            (1..=MAX_ADC_BITS).contains(&s.adc_bits),
            "sensing adc_bits must be 1..=16",
        )?;
        check(
            u32::from(s.zero_count) < (1u32 << s.adc_bits),
            "sensing zero_count must be inside the ADC range",
        )?;
        check(
            positive(s.amps_per_count),
            "sensing amps_per_count must be > 0",
        )?;
        check(
            s.offset_a.iter().all(|o| o.is_finite()),
            "sensing offset_a must be finite",
        )?;
        check(
            non_negative(s.noise_a_rms),
            "sensing noise_a_rms must be >= 0",
        )?;
        check(
            positive(s.bus_volts_per_count),
            "sensing bus_volts_per_count must be > 0",
        )?;
        if let Some(msg) = EncoderModel::params_error(&self.encoder) {
            return Err(PlantError::InvalidParameter(msg));
        }
        let mech = &self.mechanics;
        check(
            non_negative(mech.load_inertia_kgm2),
            "mechanics load_inertia_kgm2 must be >= 0",
        )?;
        check(
            non_negative(mech.viscous_nm_per_rad_s),
            "mechanics viscous_nm_per_rad_s must be >= 0",
        )?;
        check(
            non_negative(mech.coulomb_nm),
            "mechanics coulomb_nm must be >= 0",
        )?;
        if let Some((lo, hi)) = mech.end_stops_rad {
            check(
                lo.is_finite() && hi.is_finite() && lo < hi,
                "mechanics end_stops_rad must be finite with low < high",
            )?;
            check(
                lo <= 0.0 && 0.0 <= hi,
                "mechanics end_stops_rad must contain the start angle 0",
            )?;
        }
        let sw = &self.switches;
        check(
            [sw.limit_neg_rad, sw.limit_pos_rad, sw.home_rad]
                .iter()
                .flatten()
                .all(|v| v.is_finite()),
            "switch positions must be finite",
        )?;
        Ok(())
    }
}

/// Why a configuration was rejected.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum PlantError {
    /// `substeps_per_period` below [`MIN_SUBSTEPS`].
    TooFewSubsteps(u32),
    /// `substeps_per_period` above [`MAX_SUBSTEPS`].
    TooManySubsteps(u32),
    /// A parameter is out of range; the text names it.
    InvalidParameter(&'static str),
}

impl std::fmt::Display for PlantError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PlantError::TooFewSubsteps(n) => {
                write!(f, "substeps_per_period {n} < {MIN_SUBSTEPS}")
            }
            PlantError::TooManySubsteps(n) => {
                write!(f, "substeps_per_period {n} > {MAX_SUBSTEPS}")
            }
            PlantError::InvalidParameter(what) => f.write_str(what),
        }
    }
}

impl std::error::Error for PlantError {}

/// What the board's ADC and encoder interface latch at a period boundary.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Phase current ADC codes: `zero_count + (i + offset + noise)/amps_per_count`, rounded,
    /// saturating at `0 ..= 2^bits − 1`. Positive current (out of the leg) reads high.
    pub phase_current_counts: [u16; 3],
    /// Bus voltage ADC code: `V/bus_volts_per_count`, rounded, saturating.
    pub bus_voltage_counts: u16,
    /// Power-stage temperature in °C.
    pub drive_temperature_c: f32,
    /// Motor over-temperature input (thermal switch) active.
    pub motor_overtemp_input: bool,
    /// The safe-torque-off channels (`true` = closed).
    pub safe_torque_off_channels: [bool; 2],
    /// The drive's enable input (`true` = operation permitted).
    pub enable_input: bool,
    /// Encoder reading.
    pub encoder: EncoderSample,
    /// Negative limit switch actuated.
    pub limit_neg: bool,
    /// Positive limit switch actuated.
    pub limit_pos: bool,
    /// Home switch actuated.
    pub home: bool,
    /// Touch-probe inputs 1 and 2.
    pub probes: [ProbeReading; 2],
}

/// A touch-probe input at a sample: its level and when it last changed since the previous
/// sample.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ProbeReading {
    /// Active now.
    pub active: bool,
    /// Time (s, plant clock) of the last edge since the previous sample.
    pub last_edge_s: Option<f64>,
}

/// Conduction state of the power stage.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Conduction {
    /// Gates enabled: the legs switch.
    Switching,
    /// Gates off, no phase conducts: all currents exactly zero.
    Idle,
    /// Gates off, current `i > 0` flows into phase `p` (lower diode) and out of phase `n`
    /// (upper diode); the third phase floats.
    Loop { p: usize, n: usize, i: f64 },
    /// Gates off, all three phases conduct through the diodes in direction `dirs`
    /// (`+1`: current out of the leg, lower diode; `−1`: into the leg, upper diode).
    Diodes { dirs: [i8; 3] },
}

/// One substep of a PWM period and the constants that depend only on its length.
#[derive(Debug, Clone, Copy)]
struct Substep {
    /// Start and end, s from the period's start.
    t0: f64,
    t1: f64,
    /// `1 / (t1 − t0)`.
    inverse_span: f64,
    /// The mechanics' step over it.
    mech: MechStep,
}

impl Substep {
    /// The `steps` substeps of a period `ts` (the last one ends exactly at `ts`) for total
    /// inertia `inertia` under the friction of `mechanics`.
    fn of_period(ts: f64, steps: u32, mechanics: &MechParams, inertia: f64) -> Vec<Substep> {
        let h = ts / f64::from(steps);
        (0..steps)
            .map(|j| {
                let t0 = f64::from(j) * h;
                let t1 = if j + 1 == steps {
                    ts
                } else {
                    f64::from(j + 1) * h
                };
                Substep {
                    t0,
                    t1,
                    inverse_span: 1.0 / (t1 - t0),
                    mech: MechStep::new(mechanics, inertia, t1 - t0),
                }
            })
            .collect()
    }

    fn h(&self) -> f64 {
        self.mech.h
    }
}

/// The phase of `[0, 1, 2]` that is neither `a` nor `b`.
fn third_phase(a: usize, b: usize) -> usize {
    3 - a - b
}

/// One simulated drive axis.
#[derive(Debug, Clone)]
pub struct Plant {
    cfg: PlantConfig,
    rng: Rng,
    encoder: EncoderModel,
    /// Completed PWM periods (time = periods·Ts, exact at boundaries).
    periods: u64,
    /// PWM period, s.
    ts: f64,
    /// The substeps of a period (the fidelity's number), with what depends only on their
    /// lengths and the inertia (computed once).
    substeps: Vec<Substep>,
    /// `(1/Ld, 1/Lq)` of the motor.
    inverse_l: (f64, f64),
    /// Rotor-frame currents, A.
    id: f64,
    iq: f64,
    conduction: Conduction,
    mech: MechState,
    /// Prescribed mechanical speed (dynamometer), overriding the torque balance.
    driven_speed: Option<f64>,
    load_torque_nm: f64,
    bus_v: f64,
    drive_temperature_c: f64,
    motor_overtemp: bool,
    safe_torque_off_channels: [bool; 2],
    enable_input: bool,
    resistance_scale: f64,
    /// Touch-probe inputs as of the last substep, with their edges since the last sample.
    probes: [ProbeReading; 2],
    /// The last electrical angle whose sine and cosine were taken, with them: the sample at a
    /// period boundary and the first substep after it need the same pair, and each substep
    /// carries it to the next ([`Plant::carry_trig`]).
    trig: (f64, (f64, f64)),
}

impl Plant {
    /// A plant at rest at angle 0 with zero current, after validating `cfg`.
    pub fn new(cfg: PlantConfig) -> Result<Plant, PlantError> {
        cfg.validate()?;
        let ts = 1.0 / cfg.inverter.pwm_hz;
        let steps = match cfg.fidelity {
            Fidelity::PwmResolved => cfg.substeps_per_period,
            Fidelity::Averaged => 1,
        };
        let history = ENCODER_HISTORY_PERIODS * steps as usize + 1;
        let inertia = cfg.motor.rotor_inertia_kgm2 + cfg.mechanics.load_inertia_kgm2;
        Ok(Plant {
            rng: Rng::new(cfg.seed),
            encoder: EncoderModel::new(cfg.encoder, history, 0.0, 0.0),
            periods: 0,
            ts,
            substeps: Substep::of_period(ts, steps, &cfg.mechanics, inertia),
            inverse_l: cfg.motor.inverse_inductances(),
            id: 0.0,
            iq: 0.0,
            conduction: Conduction::Idle,
            mech: MechState::default(),
            driven_speed: None,
            load_torque_nm: 0.0,
            bus_v: cfg.inverter.bus_voltage_v,
            drive_temperature_c: DEFAULT_DRIVE_TEMPERATURE_C,
            motor_overtemp: false,
            safe_torque_off_channels: [true; 2],
            enable_input: true,
            resistance_scale: 1.0,
            probes: [ProbeReading::default(); 2],
            trig: (0.0, 0.0f64.sin_cos()),
            cfg,
        })
    }

    /// Integrates one PWM period with the given duties (fraction of the period the high side is
    /// commanded on; clamped to [0, 1], NaN = 0) or, with `gates_enabled == false` or safe
    /// torque off holding ([`Self::set_safe_torque_off_channels`]), with all switches off.
    pub fn run_period(&mut self, duties: [f32; 3], gates_enabled: bool) {
        // Safe torque off removes the gate drive in hardware, whatever the firmware commands.
        let gates_enabled = gates_enabled && !self.safe_torque_off();
        let duties = duties.map(|d| inverter::clamp_duty(f64::from(d)));
        if gates_enabled {
            self.conduction = Conduction::Switching;
        } else if self.conduction == Conduction::Switching {
            self.conduction = self.freewheel_start();
        }
        let t_start = self.time_s();
        // The torque at a substep's end is the next one's start torque: the currents do not
        // change in between.
        let mut te0 = self.electromagnetic_torque_nm();
        for j in 0..self.substeps.len() {
            let Some(&sub) = self.substeps.get(j) else {
                break;
            };
            if self.conduction == Conduction::Switching {
                self.switching_substep(duties, &sub);
            } else {
                self.freewheel_substep(sub.h());
            }
            let te1 = self.electromagnetic_torque_nm();
            let theta_prev = self.mech.theta_rad;
            self.mech_substep(0.5 * (te0 + te1), &sub.mech);
            te0 = te1;
            self.carry_trig(theta_prev);
            self.encoder
                .record(t_start + sub.t1, theta_prev, self.mech.theta_rad);
            self.time_probe_edges(t_start + sub.t0, t_start + sub.t1, theta_prev);
        }
        self.periods += 1;
    }

    /// Records the touch-probe edges of the substep from `t0` to `t1` (the rotor moved from
    /// `theta0` to the present angle): the time the window edge was crossed, interpolated
    /// linearly within the substep.
    fn time_probe_edges(&mut self, t0: f64, t1: f64, theta0: f64) {
        let theta1 = self.mech.theta_rad;
        for n in 0..self.probes.len() {
            let active = self.cfg.switches.probe_active(n, theta1);
            let Some(reading) = self.probes.get_mut(n) else {
                continue;
            };
            if active == reading.active {
                continue;
            }
            reading.active = active;
            let edge = self.cfg.switches.probe_edge(n, active, theta0, theta1);
            let span = theta1 - theta0;
            let fraction = match edge {
                Some(at) if span != 0.0 => ((at - theta0) / span).clamp(0.0, 1.0),
                _ => 1.0,
            };
            reading.last_edge_s = Some(t0 + fraction * (t1 - t0));
        }
    }

    /// Effective phase resistance.
    fn r(&self) -> f64 {
        self.cfg.motor.r_ohm * self.resistance_scale
    }

    fn leg_timing(&self) -> LegTiming {
        LegTiming {
            period_s: self.ts,
            dead_time_s: self.cfg.inverter.dead_time_s,
            bus_v: self.bus_v,
            drop_v: self.cfg.inverter.device_drop_v,
        }
    }

    /// Carries the cached sine and cosine of the electrical angle from a substep's start
    /// (mechanical angle `theta_prev`) to its end: the rotor turned a small angle, [`rotated`]
    /// instead of a `sin_cos`. The sample at each period boundary takes them afresh, so the
    /// rounding of at most a period's substeps accumulates.
    fn carry_trig(&mut self, theta_prev: f64) {
        let pole_pairs = f64::from(self.cfg.motor.pole_pairs);
        let (from, to) = (pole_pairs * theta_prev, self.electrical_angle_rad());
        if self.trig.0 == from && to != from {
            self.trig = (to, rotated(self.trig.1, to - from));
        }
    }

    /// The sine and cosine of the present electrical angle, exact (and cached in `trig`).
    fn exact_sin_cos(&mut self) -> (f64, f64) {
        let theta = self.electrical_angle_rad();
        self.trig = (theta, theta.sin_cos());
        self.trig.1
    }

    /// The sine and cosine of the present electrical angle (cached in `trig`).
    fn electrical_sin_cos(&mut self) -> (f64, f64) {
        if self.electrical_angle_rad() != self.trig.0 {
            return self.exact_sin_cos();
        }
        self.trig.1
    }

    fn omega_e(&self) -> f64 {
        f64::from(self.cfg.motor.pole_pairs) * self.mech.omega_rad_s
    }

    /// Advances the dq currents by one substep of length `h` with the given average leg
    /// voltages; `start`: the sine and cosine of the electrical angle at the substep's start
    /// (the voltages act at its middle, the start angle turned by half the substep,
    /// [`rotated`]).
    fn step_with_leg_voltages(&mut self, legs: [f64; 3], h: f64, start: (f64, f64)) {
        let omega_e = self.omega_e();
        // Clarke discards the zero sequence: this is v_an = v_a0 − mean(v_x0).
        let (va, vb) = clarke(legs);
        let v = park_at(va, vb, rotated(start, 0.5 * omega_e * h));
        (self.id, self.iq) =
            self.cfg
                .motor
                .step_dq(self.r(), (self.id, self.iq), v, omega_e, h, self.inverse_l);
    }

    /// A switching substep with one `sin_cos` (or none, [`Self::carry_trig`]): the phase
    /// currents at the substep's start angle decide the dead-time intervals of the legs'
    /// average voltages, which then drive [`Self::step_with_leg_voltages`].
    fn switching_substep(&mut self, duties: [f64; 3], sub: &Substep) {
        let start = self.electrical_sin_cos();
        let (alpha, beta) = inverse_park_at(self.id, self.iq, start);
        let currents = inverse_clarke(alpha, beta);
        let legs = self.leg_timing().average_voltages_over(
            duties,
            (sub.t0, sub.t1, sub.inverse_span),
            currents,
        );
        self.step_with_leg_voltages(legs, sub.h(), start);
    }

    /// Conduction state when the gates turn off: every phase with current keeps it flowing
    /// through its diode.
    fn freewheel_start(&mut self) -> Conduction {
        let i = self.phase_currents();
        let dirs = i.map(|x| {
            if x > 0.0 {
                1i8
            } else if x < 0.0 {
                -1
            } else {
                0
            }
        });
        let conducting = dirs.iter().filter(|&&d| d != 0).count();
        match conducting {
            3 => Conduction::Diodes { dirs },
            2 => {
                let p = dirs.iter().position(|&d| d > 0);
                let n = dirs.iter().position(|&d| d < 0);
                match (p, n) {
                    (Some(p), Some(n)) => self.enter_loop(p, n, i[p]),
                    _ => self.enter_idle(),
                }
            }
            _ => self.enter_idle(),
        }
    }

    fn enter_idle(&mut self) -> Conduction {
        self.id = 0.0;
        self.iq = 0.0;
        Conduction::Idle
    }

    /// Loop state with current `i` (into `p`, out of `n`), or idle if `i` is not positive.
    fn enter_loop(&mut self, p: usize, n: usize, i: f64) -> Conduction {
        if i > 0.0 {
            self.set_loop_current(p, n, i, self.electrical_angle_rad());
            Conduction::Loop { p, n, i }
        } else {
            self.enter_idle()
        }
    }

    fn set_loop_current(&mut self, p: usize, n: usize, i: f64, theta_e: f64) {
        let w = CurrentLoop::new(p, n, 0.0).w;
        (self.id, self.iq) = park(w.0 * i, w.1 * i, theta_e);
    }

    fn freewheel_substep(&mut self, h: f64) {
        let omega_e = self.omega_e();
        let theta_e = self.electrical_angle_rad();
        let bus = self.bus_v;
        let drop = self.cfg.inverter.device_drop_v;
        if self.conduction == Conduction::Idle {
            // From rest, current starts when the line back-EMF exceeds the bus plus two drops.
            // The largest line back-EMF at any angle is √3·ψ·|ωe|: below the threshold there
            // is nothing to evaluate (a drive standing with its gates off, the common case).
            let peak_line_emf = 3f64.sqrt() * self.cfg.motor.flux_wb * omega_e.abs();
            if peak_line_emf <= bus + 2.0 * drop {
                self.enter_idle();
                return;
            }
            let e = self.cfg.motor.back_emf(theta_e, omega_e);
            let (mut hi, mut lo) = (0, 0);
            for k in 1..3 {
                if e[k] > e[hi] {
                    hi = k;
                }
                if e[k] < e[lo] {
                    lo = k;
                }
            }
            if e[hi] - e[lo] > bus + 2.0 * drop {
                self.conduction = Conduction::Loop {
                    p: lo,
                    n: hi,
                    i: 0.0,
                };
            } else {
                self.enter_idle();
                return;
            }
        }
        match self.conduction {
            Conduction::Loop { p, n, i } => self.loop_substep(p, n, i, h),
            Conduction::Diodes { dirs } => self.diodes_substep(dirs, h),
            Conduction::Idle | Conduction::Switching => {}
        }
    }

    fn loop_substep(&mut self, p: usize, n: usize, i: f64, h: f64) {
        let omega_e = self.omega_e();
        let theta_e = self.electrical_angle_rad();
        let bus = self.bus_v;
        let drop = self.cfg.inverter.device_drop_v;
        let v_p0 = inverter::diode_leg_voltage(1, bus, drop);
        let v_n0 = inverter::diode_leg_voltage(-1, bus, drop);
        let lp = CurrentLoop::new(p, n, v_p0 - v_n0);
        let motor = &self.cfg.motor;
        let r = self.r();
        let i1 = motor.step_loop(r, i, &lp, theta_e, omega_e, h);
        if i1 <= 0.0 {
            self.conduction = self.enter_idle();
            return;
        }
        let theta_end = theta_e + omega_e * h;
        // Terminal voltage of the floating phase: its phase voltage plus the neutral's
        // potential, which the conducting phase p fixes.
        let v = motor.loop_phase_voltages(r, i1, &lp, theta_end, omega_e);
        let x = third_phase(p, n);
        let v_x0 = v[x] + (v_p0 - v[p]);
        self.set_loop_current(p, n, i1, theta_end);
        let mut dirs = [0i8; 3];
        dirs[p] = 1;
        dirs[n] = -1;
        self.conduction = if v_x0 > bus + drop {
            dirs[x] = -1;
            Conduction::Diodes { dirs }
        } else if v_x0 < -drop {
            dirs[x] = 1;
            Conduction::Diodes { dirs }
        } else {
            Conduction::Loop { p, n, i: i1 }
        };
    }

    fn diodes_substep(&mut self, dirs: [i8; 3], h: f64) {
        let bus = self.bus_v;
        let drop = self.cfg.inverter.device_drop_v;
        let legs = dirs.map(|d| inverter::diode_leg_voltage(d, bus, drop));
        let theta_end = self.electrical_angle_rad() + self.omega_e() * h;
        let start = self.electrical_sin_cos();
        self.step_with_leg_voltages(legs, h, start);
        let (a, b) = inverse_park(self.id, self.iq, theta_end);
        let i = inverse_clarke(a, b);
        let ended: Vec<usize> = (0..3)
            .filter(|&k| i[k] * f64::from(dirs[k]) <= 0.0)
            .collect();
        self.conduction = match ended.as_slice() {
            [] => Conduction::Diodes { dirs },
            &[x] => {
                // Phase x reached zero: it floats, the two others carry ±i (least-squares
                // projection of their currents onto i_y = −i_z).
                let (y, z) = ((x + 1) % 3, (x + 2) % 3);
                let (p, n) = if dirs[y] > 0 { (y, z) } else { (z, y) };
                if dirs[p] > 0 && dirs[n] < 0 {
                    let i_loop = 0.5 * (i[p] - i[n]);
                    if i_loop > 0.0 {
                        self.set_loop_current(p, n, i_loop, theta_end);
                        Conduction::Loop { p, n, i: i_loop }
                    } else {
                        self.enter_idle()
                    }
                } else {
                    self.enter_idle()
                }
            }
            _ => self.enter_idle(),
        };
    }

    fn mech_substep(&mut self, te: f64, step: &MechStep) {
        if let Some(w) = self.driven_speed {
            self.mech.theta_rad += w * step.h;
            self.mech.omega_rad_s = w;
            return;
        }
        let torque = te - self.load_torque_nm;
        self.mech = self.cfg.mechanics.step_by(self.mech, torque, step);
    }

    /// What the ADC and encoder interface latch at the present period boundary. Draws three
    /// Gaussian noise values from the PRNG (one per phase) on every call.
    pub fn sample(&mut self) -> Sample {
        let trig = self.exact_sin_cos();
        let i = self.phase_currents_at(trig);
        let noise_rms = self.cfg.sensing.noise_a_rms;
        let mut counts = [0u16; 3];
        for (k, c) in counts.iter_mut().enumerate() {
            let noise = noise_rms * self.rng.normal();
            *c = self.cfg.sensing.current_counts(k, i[k], noise);
        }
        let sw = self.cfg.switches.evaluate(self.mech.theta_rad);
        Sample {
            phase_current_counts: counts,
            bus_voltage_counts: self.cfg.sensing.bus_counts(self.bus_v),
            drive_temperature_c: self.drive_temperature_c as f32,
            motor_overtemp_input: self.motor_overtemp,
            safe_torque_off_channels: self.safe_torque_off_channels,
            enable_input: self.enable_input,
            encoder: self
                .encoder
                .sample(self.time_s(), self.mech.theta_rad, self.mech.omega_rad_s),
            limit_neg: sw.limit_neg,
            limit_pos: sw.limit_pos,
            home: sw.home,
            probes: self.take_probe_readings(),
        }
    }

    /// The probe readings of this sample; the edges are reported once.
    fn take_probe_readings(&mut self) -> [ProbeReading; 2] {
        let readings = self.probes;
        for p in &mut self.probes {
            p.last_edge_s = None;
        }
        readings
    }

    /// Load torque in N·m, opposing positive rotation (`J·dω/dt = Te − … − T_load`).
    /// Non-finite values are ignored.
    pub fn set_load_torque(&mut self, nm: f64) {
        if nm.is_finite() {
            self.load_torque_nm = nm;
        }
    }

    /// Actual DC-link voltage in V (the configured value is the initial one). Values that are
    /// negative or not finite are ignored.
    pub fn set_bus_voltage(&mut self, v: f64) {
        if v.is_finite() && v >= 0.0 {
            self.bus_v = v;
        }
    }

    /// Power-stage temperature reported in the samples, °C.
    pub fn set_drive_temperature(&mut self, c: f64) {
        self.drive_temperature_c = c;
    }

    /// State of the motor's over-temperature input.
    pub fn set_motor_overtemp_input(&mut self, active: bool) {
        self.motor_overtemp = active;
    }

    /// The safe-torque-off channels 1 and 2 (`true` = closed, torque allowed). An open channel
    /// cuts the gate drive at once, in hardware: the inverter applies no voltage whatever the
    /// firmware commands (the bridge is off, the motor coasts).
    pub fn set_safe_torque_off_channels(&mut self, closed: [bool; 2]) {
        self.safe_torque_off_channels = closed;
    }

    /// The drive's enable input (`true` = operation permitted; the default). A functional
    /// input: unlike safe torque off nothing in the power stage follows it, the firmware does.
    pub fn set_enable_input(&mut self, permitted: bool) {
        self.enable_input = permitted;
    }

    /// Whether safe torque off cuts the gate drive (a channel is open).
    pub fn safe_torque_off(&self) -> bool {
        !(self.safe_torque_off_channels[0] && self.safe_torque_off_channels[1])
    }

    /// Injects (`Some`) or clears (`None`) an encoder fault; see [`EncoderFaultInjection`]
    /// (a `Jump` is applied once and also clears any active fault).
    pub fn set_encoder_fault(&mut self, fault: Option<EncoderFaultInjection>) {
        self.encoder.set_fault(fault, self.mech.theta_rad);
    }

    /// Scales the phase resistance (winding fault injection): e.g. 0.01 models a near-short,
    /// so a normal voltage command drives a large over-current. Values that are not finite
    /// and positive are ignored.
    pub fn set_phase_resistance_scale(&mut self, scale: f64) {
        if scale.is_finite() && scale > 0.0 {
            self.resistance_scale = scale;
        }
    }

    /// Drives the rotor at a prescribed mechanical speed (a dynamometer; `Some(0.0)` locks
    /// the rotor), ignoring torques, friction and end stops; `None` releases it (it keeps its
    /// present speed). Non-finite speeds are ignored.
    pub fn set_driven_speed(&mut self, rad_s: Option<f64>) {
        match rad_s {
            Some(w) if w.is_finite() => {
                self.driven_speed = Some(w);
                self.mech.omega_rad_s = w;
            }
            Some(_) => {}
            None => self.driven_speed = None,
        }
    }

    /// Places hard end stops at `(low, high)` mechanical angles (rad), or removes them; ignored
    /// unless finite with low < high and the rotor between them.
    pub fn set_end_stops(&mut self, stops: Option<(f64, f64)>) {
        let valid = stops.is_none_or(|(lo, hi)| {
            lo.is_finite() && hi.is_finite() && lo < hi && (lo..=hi).contains(&self.mech.theta_rad)
        });
        if valid {
            self.cfg.mechanics.end_stops_rad = stops;
        }
    }

    /// Places the limit and home switches (the machine around the motor).
    pub fn set_switches(&mut self, switches: SwitchParams) {
        self.cfg.switches = switches;
        self.settle_probes();
    }

    /// The probe inputs at the present angle, without edges (a new setup, not a motion).
    fn settle_probes(&mut self) {
        for (n, p) in self.probes.iter_mut().enumerate() {
            *p = ProbeReading {
                active: self.cfg.switches.probe_active(n, self.mech.theta_rad),
                last_edge_s: None,
            };
        }
    }

    /// Moves the rotor to `theta_rad` (mechanical, multi-turn) at rest, e.g. to start a test
    /// at a given position. The encoders read the new position as if it had always been there
    /// (no index latch, no history). Non-finite values are ignored.
    pub fn set_rotor_position(&mut self, theta_rad: f64) {
        if theta_rad.is_finite() {
            self.mech = MechState {
                theta_rad,
                omega_rad_s: self.driven_speed.unwrap_or(0.0),
            };
            self.encoder.reset_history(self.time_s(), theta_rad);
            self.settle_probes();
        }
    }

    /// Simulated time in s (at the present period boundary).
    pub fn time_s(&self) -> f64 {
        self.periods as f64 * self.ts
    }

    /// PWM period `Ts` in s.
    pub fn period_s(&self) -> f64 {
        self.ts
    }

    /// True mechanical angle in rad (unwrapped, multi-turn).
    pub fn mech_angle_rad(&self) -> f64 {
        self.mech.theta_rad
    }

    /// True mechanical speed in rad/s.
    pub fn mech_speed_rad_s(&self) -> f64 {
        self.mech.omega_rad_s
    }

    /// True electrical angle `p·θm` in rad (unwrapped).
    pub fn electrical_angle_rad(&self) -> f64 {
        f64::from(self.cfg.motor.pole_pairs) * self.mech.theta_rad
    }

    /// True rotor-frame currents `(id, iq)` in A.
    pub fn currents_dq(&self) -> (f64, f64) {
        (self.id, self.iq)
    }

    /// True phase currents in A (positive out of the inverter leg into the motor); exactly
    /// zero in a phase that does not conduct.
    pub fn phase_currents(&self) -> [f64; 3] {
        self.phase_currents_at(self.electrical_angle_rad().sin_cos())
    }

    /// [`Self::phase_currents`] with the sine and cosine of the present electrical angle.
    fn phase_currents_at(&self, trig: (f64, f64)) -> [f64; 3] {
        match self.conduction {
            Conduction::Idle => [0.0; 3],
            Conduction::Loop { p, n, i } => {
                let mut abc = [0.0; 3];
                abc[p] = i;
                abc[n] = -i;
                abc
            }
            Conduction::Switching | Conduction::Diodes { .. } => {
                let (a, b) = inverse_park_at(self.id, self.iq, trig);
                inverse_clarke(a, b)
            }
        }
    }

    /// Electromagnetic torque `1.5·p·(ψ·iq + (Ld − Lq)·id·iq)` in N·m.
    pub fn electromagnetic_torque_nm(&self) -> f64 {
        self.cfg.motor.torque_nm(self.id, self.iq)
    }

    /// Present DC-link voltage in V.
    pub fn bus_voltage_v(&self) -> f64 {
        self.bus_v
    }

    /// The configuration the plant was built with.
    pub fn config(&self) -> &PlantConfig {
        &self.cfg
    }
}

#[cfg(test)]
mod tests;
