//! The whole control interrupt of one axis: sensing → protections → commutation → (at the loop
//! sub-rate) interpolation, position and speed loops → current loop → PWM.
//!
//! # Contexts
//! [`Axis::control_step`] is the body of the highest-priority interrupt (PWM/ADC, every PWM
//! period). The EtherCAT SYNC0 handler talks to it only through an [`AxisLink`]: it publishes an
//! [`AxisCommand`] per bus cycle ([`AxisLink::publish`]) and reads the latest [`AxisFeedback`]
//! ([`AxisLink::feedback`]); neither side ever waits for the other (see [`handoff`](crate::handoff)).
//!
//! # Sequence at enable
//! Disabled (gates off) → phase-current offset calibration (gates off, N samples) → commutation
//! alignment (incremental encoders without a known offset) → running. Any protection trip turns
//! the gates off in the same period and latches the fault until a rising `fault_reset`.
//!
//! # Board side
//! Around each [`Axis::control_step`] the board's interrupt reads a [`Sample`] through its `hal`
//! drivers ([`Sample::read`]) and hands the [`Output`] to its inverter ([`Output::apply`]).
//!
//! Timing budget (whole interrupt, Cortex-M4F, measured under QEMU): ≤ 1,500 instructions in the
//! worst period (the one running the position and speed loops); the current loop alone ≤ 250.

use core::sync::atomic::{AtomicU32, Ordering};

use hal::encoder::{Encoder, EncoderFault};
use hal::io::{DigitalInputs, ProbeCapture, TouchProbe};
use hal::power::{BusSense, CurrentSense, Inverter, PhaseCurrents};

use super::calibration::{AlignStep, Alignment, AlignmentConfig, Commutation, OffsetCalibration};
use super::capture::{Captures, Switches};
use super::commissioning::{
    ElectricalIdentConfig, ElectricalIdentification, IdentCommand, IdentMeasurement,
    InertiaIdentConfig, InertiaIdentification, InertiaStep,
};
use super::field_weakening::{FieldWeakening, FieldWeakeningConfig};
use super::foc::{CurrentLoop, CurrentLoopConfig, CurrentLoopInput};
use super::handoff::{FeedbackHandoff, SetpointHandoff};
use super::interpolate::{InterpolateError, Interpolator};
use super::math::{self, TAU};
use super::position::PositionLoop;
use super::protection::{ProtectionConfig, ProtectionInputs, Protections};
use super::ramp::StopRamp;
use super::speed::{self, SpeedLoop, SpeedLoopConfig};
use super::svpwm;
use super::velocity::VelocityEstimator;
use super::{Duties, ElectricalAngle, MotorFault};

/// The bus voltage the modulator assumes at least (a lower reading would make 1/Vbus explode;
/// the under-voltage protection trips long before).
const MIN_BUS_VOLTAGE: f32 = 1.0;

/// Motor nameplate and encoder data.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotorData {
    /// Phase resistance, Ω.
    pub resistance_ohm: f32,
    /// d-axis inductance, H.
    pub ld_h: f32,
    /// q-axis inductance, H.
    pub lq_h: f32,
    /// Permanent-magnet flux linkage, Wb (peak, per phase).
    pub flux_wb: f32,
    /// Pole pairs.
    pub pole_pairs: u32,
    /// Encoder increments per mechanical revolution.
    pub counts_per_rev: u32,
    /// The encoder position where the electrical angle is zero, if known (absolute encoders
    /// after commissioning); `None` runs the alignment at every enable.
    pub commutation_offset: Option<i64>,
}

impl MotorData {
    /// Torque constant 1.5·p·ψ, N·m per A of q current (amplitude-invariant transform).
    pub fn torque_constant(&self) -> f32 {
        1.5 * self.pole_pairs as f32 * self.flux_wb
    }
}

/// Everything an axis needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisConfig {
    /// Motor and encoder.
    pub motor: MotorData,
    /// PWM frequency = current-loop rate, Hz.
    pub pwm_hz: f32,
    /// The position and speed loops run every `loop_divider`-th PWM period.
    pub loop_divider: u32,
    /// Current loop (its `pwm_hz` and motor fields are overwritten from the above).
    pub current_loop: CurrentLoopConfig,
    /// Speed loop (its `sample_hz` is overwritten).
    pub speed_loop: SpeedLoopConfig,
    /// Position loop gain, 1/s.
    pub position_kp: f32,
    /// Velocity limit of the position loop, increments/s.
    pub velocity_limit: f32,
    /// Velocity estimator bandwidth, Hz.
    pub velocity_bandwidth_hz: f32,
    /// Protections.
    pub protection: ProtectionConfig,
    /// Current limit (peak, vector magnitude), A.
    pub current_limit_a: f32,
    /// Samples of the offset calibration.
    pub offset_samples: u32,
    /// Largest plausible current-sensor offset, A.
    pub max_offset_a: f32,
    /// Alignment (incremental encoders).
    pub alignment: AlignmentConfig,
    /// Bus cycle of the set-points, s (for the interpolator).
    pub bus_cycle_s: f32,
    /// Field weakening near the voltage limit.
    pub field_weakening: FieldWeakeningConfig,
}

/// Why a configuration was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AxisConfigError {
    /// A rate, divider or gain is zero, negative or not finite.
    Rates,
    /// The current loop refused its configuration.
    CurrentLoop,
    /// The speed loop refused its configuration.
    SpeedLoop,
    /// The commutation (encoder resolution / pole pairs) is not usable.
    Commutation,
    /// The interpolator refused the bus cycle.
    Interpolator,
    /// The alignment settings are not usable.
    Alignment,
    /// The velocity-estimator bandwidth is not usable at the loop rate.
    VelocityEstimator,
}

/// The control mode of the cascade.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ControlMode {
    /// Torque set-point (CST).
    #[default]
    Torque,
    /// Velocity set-point (CSV).
    Velocity,
    /// Position set-point (CSP).
    Position,
    /// Decelerate from the present velocity to rest along a ramp
    /// ([`AxisCommand::deceleration`]) and hold zero speed: a CiA402 stop reaction.
    Stop,
}

/// What the SYNC0 side asks for, once per bus cycle.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AxisCommand {
    /// Power the motor (CiA402 "operation enabled").
    pub enable: bool,
    /// Rising edge clears a latched fault (CiA402 fault reset).
    pub fault_reset: bool,
    /// Run the identification (commissioning) instead of the cascade when enabled.
    pub identify: bool,
    /// While disabled: a rising edge measures the current-sensor offsets again (gates off)
    /// and keeps them; the axis returns to Disabled (an adjusting service's "automatic offset
    /// adjustment of the motor current detection signals"). Falling before the end cancels it.
    pub calibrate_offsets: bool,
    /// Mode.
    pub mode: ControlMode,
    /// Target position, increments.
    pub position: i64,
    /// Target velocity (CSV) or, with the position, the velocity at it (CSP's 60B1h, a
    /// profile generator's demand; 0 = none, the interpolator derives it), increments/s.
    pub velocity: f32,
    /// Target torque (CST) or torque offset (CSP/CSV), N·m.
    pub torque: f32,
    /// [`ControlMode::Stop`]: the ramp's deceleration, increments/s² (0: at once, the speed
    /// loop brakes at the current limit). Taken when the stop starts.
    pub deceleration: f32,
    /// The bus cycle the set-points come at, ns (0: unchanged). A change re-times the
    /// interpolator (a configuration-time computation, once per change).
    pub bus_cycle_ns: u32,
    /// Following-error window (increments; `u32::MAX` = off) and timeout (ms), CiA402
    /// 6065h/6066h; `None` keeps the configured ones. Applied when they change.
    pub following_error_limits: Option<(u32, u16)>,
    /// Torque limits in the positive and the negative direction (magnitudes, N·m; CiA402
    /// 6072h, 60E0h, 60E1h), never above the configured limit; `None`: the configured limit.
    /// Applied when they change.
    pub torque_limits: Option<(f32, f32)>,
}

/// The state of the axis.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AxisState {
    /// Gates off, waiting for enable.
    #[default]
    Disabled,
    /// Measuring the current-sensor offsets (gates off).
    CalibratingOffsets,
    /// Finding the commutation offset.
    Aligning,
    /// Closed loop.
    Running,
    /// Identifying R and L (open-loop voltages).
    IdentifyingElectrical,
    /// Identifying the inertia (torque steps).
    IdentifyingInertia,
    /// Identification finished (results in the feedback); gates off until enable falls.
    Identified,
    /// Gates off until a fault reset.
    Faulted,
}

/// What the control interrupt reports back, once per loop tick.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AxisFeedback {
    /// State.
    pub state: AxisState,
    /// The latched fault, if any.
    pub fault: Option<MotorFault>,
    /// Position, increments.
    pub position: i64,
    /// Velocity estimate, increments/s.
    pub velocity: f32,
    /// Torque (from the measured q current), N·m.
    pub torque: f32,
    /// Position following error, increments.
    pub following_error: i64,
    /// Faults latched so far (wrapping): a change tells the SYNC0 side that a new fault
    /// occurred, even when a reset and a new trip of the same fault fall between two reads.
    pub trips: u32,
    /// Current-sensor offset calibrations completed so far (wrapping), at enable or on request
    /// ([`AxisCommand::calibrate_offsets`]).
    pub offset_calibrations: u32,
    /// The main circuit is powered: the bus voltage is at or above the under-voltage level.
    pub main_power: bool,
    /// The DC-link voltage, V.
    pub bus_voltage: f32,
    /// The motor's I²t load, 0..=1 of its trip level.
    pub motor_load: f32,
    /// The power stage's I²t load, 0..=1 of its trip level.
    pub drive_load: f32,
    /// A stop's deceleration ramp ([`ControlMode::Stop`]) has not reached zero yet.
    pub stopping: bool,
    /// The limit and home switches at the last sample.
    pub switches: Switches,
    /// The safe-torque-off channels at the last sample, `true` = closed.
    pub safe_torque_off_channels: [bool; 2],
    /// What withholds the permission to run: safe torque off, the enable input (the axis
    /// drives nothing, as if disabled, while either holds).
    pub withheld: Withheld,
    /// The torque demand is at the torque or current limit (CiA402 statusword bit 11
    /// "internal limit active").
    pub current_limited: bool,
    /// The cause of the latched fault is still there: a fault reset is refused meanwhile
    /// ([`crate::protection::Protections::cause_present`]).
    pub fault_cause_present: bool,
}

/// Results of a commissioning run.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Identification {
    /// Phase resistance, Ω.
    pub resistance_ohm: f32,
    /// d inductance, H.
    pub ld_h: f32,
    /// q inductance, H.
    pub lq_h: f32,
    /// Inertia, N·m per (increment/s²).
    pub inertia: f32,
    /// The same inertia in kg·m².
    pub inertia_kgm2: f32,
}

/// Motor parameters from commissioning (stored as parameters), handed to the axis to replace
/// those of its configuration: the current loop and the speed loop are re-tuned for them at
/// the same bandwidths. A value of 0 keeps the configured one.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MotorModel {
    /// Phase resistance, Ω.
    pub resistance_ohm: f32,
    /// d-axis inductance, H.
    pub ld_h: f32,
    /// q-axis inductance, H.
    pub lq_h: f32,
    /// Rotor + load inertia, kg·m².
    pub inertia_kgm2: f32,
}

/// One PWM period's measurements, as the board read them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Phase currents, A, as measured (offsets not yet removed).
    pub currents: PhaseCurrents,
    /// DC-bus voltage, V.
    pub bus_voltage: f32,
    /// Power-stage temperature, °C.
    pub temperature: f32,
    /// Motor over-temperature input.
    pub motor_overtemp: bool,
    /// Multi-turn encoder position, increments.
    pub position: Result<i64, EncoderFault>,
    /// Limit and home switches.
    pub switches: Switches,
    /// Position of an encoder index pulse since the last sample.
    pub index: Option<i64>,
    /// Touch-probe inputs 1 and 2 with their edge times.
    pub probes: [ProbeCapture; 2],
    /// The safe-torque-off channels, `true` = closed (torque allowed; both must be).
    pub safe_torque_off_channels: [bool; 2],
    /// The enable input, `true` = operation permitted ([`DigitalInputs::enable_input`]).
    pub enable_input: bool,
    /// The power stage's hardware protection switched the gates off since the last sample
    /// ([`Inverter::take_hardware_trip`]).
    pub power_stage_trip: bool,
}

/// What the board applies during the next PWM period.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Output {
    /// Gate drivers on.
    pub gates: bool,
    /// Duties (meaningful when `gates`).
    pub duties: Duties,
}

/// What withholds an axis' permission to run, one bit per cause (a byte, so that the
/// feedback the control interrupt publishes every period stays small).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Withheld(u8);

impl Withheld {
    /// Nothing withholds it.
    pub const NONE: Self = Self(0);
    /// A safe-torque-off channel is open (or was).
    const SAFE_TORQUE_OFF: u8 = 1 << 0;
    /// The enable input is open (or was).
    const ENABLE_INPUT: u8 = 1 << 1;

    /// Safe torque off holds: a channel is open, or was since the enable was last taken back.
    pub fn safe_torque_off(self) -> bool {
        self.0 & Self::SAFE_TORQUE_OFF != 0
    }

    /// The enable input withholds operation: it is open, or was since the enable was last
    /// taken back (nothing cuts the gates in hardware; the axis does).
    pub fn interlocked(self) -> bool {
        self.0 & Self::ENABLE_INPUT != 0
    }
}

impl Sample {
    /// The measurements of the present PWM period through the board's drivers: phase
    /// currents, bus voltage and power-stage temperature, the motor's thermal switch, the
    /// encoder position (each as latched at the PWM-synchronous sample), and whether the power
    /// stage's hardware protection tripped.
    pub fn read(
        power: &mut impl Inverter,
        currents: &mut impl CurrentSense,
        bus: &mut impl BusSense,
        encoder: &mut impl Encoder,
        inputs: &mut impl DigitalInputs,
    ) -> Self {
        Self {
            currents: currents.phase_currents(),
            bus_voltage: bus.bus_voltage(),
            temperature: bus.temperature(),
            motor_overtemp: inputs.motor_over_temperature(),
            position: encoder.position(),
            switches: Switches {
                positive_limit: inputs.positive_limit(),
                negative_limit: inputs.negative_limit(),
                home: inputs.home_switch(),
            },
            index: encoder.take_index(),
            probes: [
                inputs.touch_probe(TouchProbe::One),
                inputs.touch_probe(TouchProbe::Two),
            ],
            safe_torque_off_channels: inputs.safe_torque_off_channels(),
            enable_input: inputs.enable_input(),
            power_stage_trip: power.take_hardware_trip(),
        }
    }
}

impl Output {
    const OFF: Self = Self {
        gates: false,
        duties: Duties::CENTRED,
    };

    /// Hands the output to the board's inverter: gates off at once; otherwise the duties for
    /// the next period, with the gates enabled from that period on if they were off.
    pub fn apply(&self, inverter: &mut impl Inverter) {
        if !self.gates {
            inverter.disable();
        }
        inverter.set_duties(self.duties.a, self.duties.b, self.duties.c);
        if self.gates && !inverter.is_enabled() {
            inverter.enable();
        }
    }
}

/// The mailboxes between the SYNC0 handler and the control interrupt.
pub struct AxisLink {
    commands: SetpointHandoff<AxisCommand>,
    feedback: FeedbackHandoff<AxisFeedback>,
    /// Motor parameters, written rarely (after commissioning, after loading parameters).
    model: SetpointHandoff<MotorModel>,
    /// Switch edges and index pulses, written when one happened.
    captures: FeedbackHandoff<Captures>,
    /// Identification results, written when they change (kept apart from the feedback that
    /// every cycle copies).
    identification: FeedbackHandoff<Option<Identification>>,
    /// Bus cycles shorter than the control loop's period.
    decimation: Decimation,
}

/// A bus cycle T shorter than the control loop's period (DESIGN.md allows DC cycles from
/// 31.25 µs, and the position and speed loops may run at a sub-rate of the PWM, e.g. 20 kHz)
/// cannot be interpolated: more set-points arrive than the loop takes, and the one it takes
/// is a varying number of cycles after the previous one. So the SYNC0 side hands over only
/// every k-th command, with k the fewest cycles that span a loop period, and tells the axis
/// the cycle is k·T: the axis sees an evenly spaced stream as if the bus ran at k·T (the
/// targets in between are dropped, as a loop slower than the bus must; a command's other
/// fields, e.g. enable, reach the axis up to k − 1 cycles later).
///
/// The control side sets the loop period when it is handed a cycle it cannot interpolate
/// (a rare path); until then, and for cycles of a loop period or more, every command is
/// handed over as it is.
struct Decimation {
    /// The control loop's period, ns (rounded up); 0: no cycle shorter than it seen.
    loop_period_ns: AtomicU32,
    /// SYNC0 side only: cycles since the last command handed over while decimating.
    skipped: AtomicU32,
}

impl AxisLink {
    /// Empty mailboxes.
    ///
    /// # Safety
    /// [`AxisLink::publish`] and [`AxisLink::feedback`] are called from one context (the SYNC0
    /// handler) and [`Axis::control_step`] from one other context of higher priority on the same
    /// core, which never lets the lower one run while it is active (the contract of
    /// [`SetpointHandoff::new`] and [`FeedbackHandoff::new`]). A single-threaded simulation
    /// meets it trivially.
    pub const unsafe fn new() -> Self {
        Self {
            // SAFETY: the caller's contract, passed on.
            commands: unsafe {
                SetpointHandoff::new(AxisCommand {
                    enable: false,
                    fault_reset: false,
                    identify: false,
                    calibrate_offsets: false,
                    mode: ControlMode::Torque,
                    position: 0,
                    velocity: 0.0,
                    torque: 0.0,
                    deceleration: 0.0,
                    bus_cycle_ns: 0,
                    following_error_limits: None,
                    torque_limits: None,
                })
            },
            // SAFETY: as above.
            feedback: unsafe {
                FeedbackHandoff::new(AxisFeedback {
                    state: AxisState::Disabled,
                    fault: None,
                    position: 0,
                    velocity: 0.0,
                    torque: 0.0,
                    following_error: 0,
                    trips: 0,
                    offset_calibrations: 0,
                    main_power: false,
                    bus_voltage: 0.0,
                    motor_load: 0.0,
                    drive_load: 0.0,
                    stopping: false,
                    current_limited: false,
                    fault_cause_present: false,
                    switches: Switches {
                        positive_limit: false,
                        negative_limit: false,
                        home: false,
                    },
                    safe_torque_off_channels: [true; 2],
                    withheld: Withheld::NONE,
                })
            },
            // SAFETY: as above (written by the SYNC0 side only, read by the control interrupt).
            model: unsafe {
                SetpointHandoff::new(MotorModel {
                    resistance_ohm: 0.0,
                    ld_h: 0.0,
                    lq_h: 0.0,
                    inertia_kgm2: 0.0,
                })
            },
            // SAFETY: as above (written by the control interrupt only).
            captures: unsafe {
                FeedbackHandoff::new(Captures::initial(Switches {
                    positive_limit: false,
                    negative_limit: false,
                    home: false,
                }))
            },
            // SAFETY: as above (written by the control interrupt only).
            identification: unsafe { FeedbackHandoff::new(None) },
            decimation: Decimation {
                loop_period_ns: AtomicU32::new(0),
                skipped: AtomicU32::new(0),
            },
        }
    }

    /// SYNC0 side: hands over motor parameters; the axis applies them the next time it is
    /// not running (never in the middle of a move).
    pub fn set_motor_model(&self, model: MotorModel) {
        self.model.write(model);
    }

    /// SYNC0 side: hands over this bus cycle's command; with a cycle shorter than the control
    /// loop's period, every k-th as one of k cycles (the decimation of short cycles, set up by
    /// the control side when it is handed one).
    pub fn publish(&self, command: AxisCommand) {
        // One compare on the common path (no loop period set: 0, nothing is below it).
        let loop_period_ns = self.decimation.loop_period_ns.load(Ordering::Relaxed);
        if command.bus_cycle_ns < loop_period_ns {
            self.publish_decimated(&command, loop_period_ns);
        } else {
            self.commands.write(command);
        }
    }

    /// [`Self::publish`] of a cycle shorter than `loop_period_ns` (0: no cycle given, handed
    /// over as it is).
    #[inline(never)]
    fn publish_decimated(&self, command: &AxisCommand, loop_period_ns: u32) {
        let mut command = *command;
        let cycle_ns = command.bus_cycle_ns;
        if cycle_ns == 0 {
            self.commands.write(command);
            return;
        }
        let factor = loop_period_ns.div_ceil(cycle_ns);
        let skipped = self
            .decimation
            .skipped
            .load(Ordering::Relaxed)
            .saturating_add(1);
        if skipped < factor {
            self.decimation.skipped.store(skipped, Ordering::Relaxed);
            return;
        }
        self.decimation.skipped.store(0, Ordering::Relaxed);
        command.bus_cycle_ns = cycle_ns.saturating_mul(factor);
        self.commands.write(command);
    }

    /// Control side: the axis was handed a bus cycle shorter than its loop period of
    /// `loop_period_ns` (rounded up): from now on the SYNC0 side decimates such cycles.
    fn decimate_below(&self, loop_period_ns: u32) {
        self.decimation
            .loop_period_ns
            .store(loop_period_ns, Ordering::Relaxed);
    }

    /// SYNC0 side: the latest feedback.
    pub fn feedback(&self) -> AxisFeedback {
        self.feedback.read().0
    }

    /// SYNC0 side: the latest switch levels and edge/index captures.
    pub fn captures(&self) -> Captures {
        self.captures.read().0
    }

    /// SYNC0 side: the captures if they changed since the read that returned `last_sequence`
    /// (the second value: the sequence number to pass next time), `None` without copying them
    /// otherwise. The axis publishes them only when an edge, index pulse or level change
    /// happened, so most cycles cost a compare instead of a copy.
    pub fn captures_if_new(&self, last_sequence: u32) -> Option<(Captures, u32)> {
        self.captures.read_if_new(last_sequence)
    }

    /// SYNC0 side: the results of the last identification that finished.
    pub fn identification(&self) -> Option<Identification> {
        self.identification.read().0
    }
}

/// One axis.
#[derive(Clone)]
pub struct Axis {
    cfg: AxisConfig,
    state: AxisState,
    fault: Option<MotorFault>,
    tick: u32,
    command: AxisCommand,
    /// Sequence number of the last command taken (0 = the initial value of the link).
    command_seq: u32,
    previous_fault_reset: bool,
    /// The cause of the latched fault was still there at the last sample (checked only while
    /// faulted).
    fault_cause_present: bool,
    offsets: PhaseCurrents,
    offset_calibration: OffsetCalibration,
    alignment: Alignment,
    commutation: Commutation,
    current_loop: CurrentLoop,
    speed_loop: SpeedLoop,
    position_loop: PositionLoop,
    velocity: VelocityEstimator,
    interpolator: Interpolator,
    protections: Protections,
    field_weakening: FieldWeakening,
    /// The current loop's last voltage vector squared, V² (for the field weakening).
    last_v2: f32,
    electrical_ident: Option<ElectricalIdentification>,
    inertia_ident: Option<InertiaIdentification>,
    identified: Option<Identification>,
    /// Last good encoder position (held over a bad serial frame).
    position: i64,
    position_valid: bool,
    /// Switch and index captures.
    captures: Captures,
    /// The captures changed since they were last published (the first sample sets the levels).
    captures_changed: bool,
    /// `identified` changed since it was last published.
    identification_changed: bool,
    /// The safe-torque-off channels at the last sample (`true` = closed).
    safe_torque_off_channels: [bool; 2],
    /// What withholds the permission to run: each cause set while its input is open and held
    /// until the enable is taken back.
    withheld: Withheld,
    /// A sample has set the switch levels.
    captures_started: bool,
    /// 1 / the PWM period in ns (touch-probe edge interpolation).
    inv_period_ns: f32,
    omega_e: f32,
    /// Bus voltage and its reciprocal, refreshed at the loop rate (the bus changes slowly; one
    /// division per loop tick instead of one per PWM period).
    vbus: f32,
    inv_vbus: f32,
    /// Electrical rad/s per increment/s.
    omega_e_per_velocity: f32,
    /// A of q current per N·m.
    iq_per_nm: f32,
    nm_per_iq: f32,
    id_ref: f32,
    iq_ref: f32,
    last_id: f32,
    last_iq: f32,
    last_velocity: f32,
    /// Test signal added to the current references while running (d, q), A.
    injection: (f32, f32),
    /// The bus cycle the interpolator is timed for, ns.
    bus_cycle_ns: u32,
    /// Sequence number of the last motor model taken from the link.
    model_seq: u32,
    /// The motor parameters in use (from the configuration or the last model applied).
    model: MotorModel,
    /// Faults latched so far (wrapping).
    trips: u32,
    /// The velocity observer follows the position (seeded with a valid one).
    velocity_observed: bool,
    /// The previous loop tick's [`AxisCommand::calibrate_offsets`] (edge detection).
    previous_calibrate: bool,
    /// Offset calibrations completed (wrapping).
    offset_calibrations: u32,
    /// The deceleration ramp of [`ControlMode::Stop`].
    stop_ramp: StopRamp,
    /// The last loop tick's torque demand was at the limit.
    current_limited: bool,
}

impl Axis {
    /// An axis in the disabled state; checks the whole configuration.
    pub fn new(cfg: AxisConfig) -> Result<Self, AxisConfigError> {
        let finite_positive = |v: f32| v.is_finite() && v > 0.0;
        if !(finite_positive(cfg.pwm_hz)
            && cfg.loop_divider > 0
            && finite_positive(cfg.motor.flux_wb)
            && cfg.motor.pole_pairs > 0
            && finite_positive(cfg.current_limit_a))
        {
            return Err(AxisConfigError::Rates);
        }
        let loop_hz = cfg.pwm_hz / cfg.loop_divider as f32;
        let m = cfg.motor;
        let current_loop = CurrentLoop::new(&CurrentLoopConfig {
            resistance_ohm: m.resistance_ohm,
            ld_h: m.ld_h,
            lq_h: m.lq_h,
            flux_wb: m.flux_wb,
            pwm_hz: cfg.pwm_hz,
            ..cfg.current_loop
        })
        .map_err(|_| AxisConfigError::CurrentLoop)?;
        let speed_loop = SpeedLoop::new(&SpeedLoopConfig {
            sample_hz: loop_hz,
            ..cfg.speed_loop
        })
        .map_err(|_| AxisConfigError::SpeedLoop)?;
        let commutation = Commutation::new(
            m.counts_per_rev,
            m.pole_pairs,
            m.commutation_offset.unwrap_or(0),
        )
        .map_err(|_| AxisConfigError::Commutation)?;
        let interpolator = Interpolator::new(cfg.bus_cycle_s, loop_hz)
            .map_err(|_| AxisConfigError::Interpolator)?;
        let alignment = Alignment::new(
            &cfg.alignment,
            m.counts_per_rev,
            m.pole_pairs,
            1.0 / cfg.pwm_hz,
        )
        .map_err(|_| AxisConfigError::Alignment)?;
        let velocity = VelocityEstimator::new(cfg.velocity_bandwidth_hz, loop_hz)
            .map_err(|_| AxisConfigError::VelocityEstimator)?;
        let kt = m.torque_constant();
        Ok(Self {
            state: AxisState::Disabled,
            fault: None,
            tick: 0,
            command: AxisCommand::default(),
            command_seq: 0,
            previous_fault_reset: false,
            fault_cause_present: false,
            offsets: PhaseCurrents::default(),
            offset_calibration: OffsetCalibration::new(cfg.offset_samples, cfg.max_offset_a),
            alignment,
            commutation,
            current_loop,
            speed_loop,
            position_loop: PositionLoop::new(cfg.position_kp, cfg.velocity_limit),
            velocity,
            interpolator,
            protections: Protections::new(&cfg.protection, 1.0 / loop_hz),
            field_weakening: FieldWeakening::new(
                &cfg.field_weakening,
                cfg.current_loop.max_modulation,
            ),
            last_v2: 0.0,
            electrical_ident: None,
            inertia_ident: None,
            identified: None,
            position: 0,
            position_valid: false,
            captures: Captures::initial(Switches {
                positive_limit: false,
                negative_limit: false,
                home: false,
            }),
            captures_changed: false,
            identification_changed: false,
            safe_torque_off_channels: [true; 2],
            withheld: Withheld::NONE,
            captures_started: false,
            inv_period_ns: cfg.pwm_hz * 1e-9,
            omega_e: 0.0,
            vbus: MIN_BUS_VOLTAGE,
            inv_vbus: 1.0 / MIN_BUS_VOLTAGE,
            omega_e_per_velocity: TAU * m.pole_pairs as f32 / m.counts_per_rev as f32,
            iq_per_nm: 1.0 / kt,
            nm_per_iq: kt,
            id_ref: 0.0,
            iq_ref: 0.0,
            last_id: 0.0,
            last_iq: 0.0,
            last_velocity: 0.0,
            injection: (0.0, 0.0),
            trips: 0,
            velocity_observed: false,
            previous_calibrate: false,
            offset_calibrations: 0,
            stop_ramp: StopRamp::default(),
            current_limited: false,
            bus_cycle_ns: (cfg.bus_cycle_s * 1e9) as u32,
            model_seq: 0,
            model: MotorModel {
                resistance_ohm: m.resistance_ohm,
                ld_h: m.ld_h,
                lq_h: m.lq_h,
                inertia_kgm2: cfg.speed_loop.inertia_nm_per_inc_s2 * m.counts_per_rev as f32 / TAU,
            },
            cfg,
        })
    }

    /// The state.
    pub fn state(&self) -> AxisState {
        self.state
    }

    /// The protections (I²t loads, the current limit they allow now).
    pub fn protections(&self) -> &Protections {
        &self.protections
    }

    /// The latched fault.
    pub fn fault(&self) -> Option<MotorFault> {
        self.fault
    }

    /// The configuration.
    pub fn config(&self) -> &AxisConfig {
        &self.cfg
    }

    /// Sets a test signal added to the d and q current references in every period while
    /// running: the excitation of a current-loop frequency-response measurement (what drive
    /// commissioning tools inject; 0 in normal operation).
    pub fn set_current_injection(&mut self, id_a: f32, iq_a: f32) {
        let finite = |x: f32| if x.is_finite() { x } else { 0.0 };
        self.injection = (finite(id_a), finite(iq_a));
    }

    /// The motor parameters the loops are tuned for.
    pub fn motor_model(&self) -> MotorModel {
        self.model
    }

    /// Re-tunes the current and speed loops for `model` at their configured bandwidths
    /// (configuration-time work: called only while the axis is not running). Zero fields keep
    /// the present values; a model the loops refuse is ignored.
    fn apply_model(&mut self, model: MotorModel) {
        let keep = |new: f32, old: f32| {
            if new > 0.0 && new.is_finite() {
                new
            } else {
                old
            }
        };
        let merged = MotorModel {
            resistance_ohm: keep(model.resistance_ohm, self.model.resistance_ohm),
            ld_h: keep(model.ld_h, self.model.ld_h),
            lq_h: keep(model.lq_h, self.model.lq_h),
            inertia_kgm2: keep(model.inertia_kgm2, self.model.inertia_kgm2),
        };
        let loop_hz = self.cfg.pwm_hz / self.cfg.loop_divider as f32;
        let current_loop = CurrentLoop::new(&CurrentLoopConfig {
            resistance_ohm: merged.resistance_ohm,
            ld_h: merged.ld_h,
            lq_h: merged.lq_h,
            flux_wb: self.cfg.motor.flux_wb,
            pwm_hz: self.cfg.pwm_hz,
            ..self.cfg.current_loop
        });
        // The speed bandwidth the configuration was tuned for: kp = J·ωs.
        let old = self.cfg.speed_loop;
        let inertia = merged.inertia_kgm2 * TAU / self.cfg.motor.counts_per_rev as f32;
        let omega_s = if old.inertia_nm_per_inc_s2 > 0.0 {
            old.kp / old.inertia_nm_per_inc_s2
        } else {
            0.0
        };
        let (kp, ki) = if omega_s > 0.0 {
            speed::gains_for_bandwidth(omega_s / TAU, inertia)
        } else {
            (old.kp, old.ki)
        };
        let speed_loop = SpeedLoop::new(&SpeedLoopConfig {
            kp,
            ki,
            inertia_nm_per_inc_s2: inertia,
            sample_hz: loop_hz,
            ..old
        });
        if let (Ok(current_loop), Ok(speed_loop)) = (current_loop, speed_loop) {
            self.current_loop = current_loop;
            self.speed_loop = speed_loop;
            self.model = merged;
            // The new loop starts at the configured limit: the commanded ones stay.
            self.apply_torque_limits(self.command.torque_limits);
        }
    }

    /// The current-sensor offsets in use (from the last calibration), A.
    pub fn current_offsets(&self) -> PhaseCurrents {
        self.offsets
    }

    /// Measured d and q currents of the last period, A.
    pub fn currents_dq(&self) -> (f32, f32) {
        (self.last_id, self.last_iq)
    }

    /// The body of the control interrupt: one PWM period.
    ///
    /// Timing: ≤ 1,500 instructions on a Cortex-M4F in the loop period (benchmark
    /// `control-interrupt`), of which the current loop ≤ 250 (`foc-step`).
    pub fn control_step(&mut self, sample: &Sample, link: &AxisLink) -> Output {
        let c = sample.currents;
        let currents = PhaseCurrents {
            a: c.a - self.offsets.a,
            b: c.b - self.offsets.b,
            c: c.c - self.offsets.c,
        };
        // Over-current first: gates off in this very period. The hardware trip (the board has
        // switched the gates off already) counts in every state, the offset calibration too.
        if sample.power_stage_trip {
            return self.trip(MotorFault::OverCurrent, link);
        }
        if self.state != AxisState::CalibratingOffsets {
            if let Some(fault) = self
                .protections
                .check_over_current(currents.a, currents.b, currents.c)
            {
                return self.trip(fault, link);
            }
        }
        self.read_encoder(sample);
        // Safe torque off: with a channel open the hardware has cut the gate drive; the axis
        // runs nothing either (below, as without enable). It stays off until both channels are
        // closed and the drive has taken its enable back: closing the channels never restarts
        // the motor by itself (IEC 61800-5-2: no unexpected start-up), however short the
        // opening was.
        self.safe_torque_off_channels = sample.safe_torque_off_channels;
        let [sto1, sto2] = sample.safe_torque_off_channels;
        // The enable input is a functional permission, not a safety function: nothing cuts the
        // gates in hardware, so this is what does. It latches like safe torque off: the
        // permission returning never restarts the motor by itself.
        let open = if sto1 && sto2 {
            0
        } else {
            Withheld::SAFE_TORQUE_OFF
        } | if sample.enable_input {
            0
        } else {
            Withheld::ENABLE_INPUT
        };
        let held = if self.command.enable {
            self.withheld.0
        } else {
            0
        };
        self.withheld = Withheld(open | held);
        let torque_allowed = self.withheld == Withheld::NONE;
        let loop_tick = self.tick == 0;
        // Below `loop_divider`: reset to 0 right here.
        self.tick = self.tick.wrapping_add(1);
        if self.tick >= self.cfg.loop_divider {
            self.tick = 0;
        }
        if loop_tick {
            self.take_command(link);
            if matches!(
                self.state,
                AxisState::Disabled | AxisState::Faulted | AxisState::Identified
            ) {
                if let Some((model, seq)) = link.model.read_if_new(self.model_seq) {
                    self.model_seq = seq;
                    self.apply_model(model);
                }
            }
            self.vbus = math::max(sample.bus_voltage, MIN_BUS_VOLTAGE);
            self.inv_vbus = 1.0 / self.vbus;
        }
        let output = match self.state {
            AxisState::Disabled => {
                let calibrate = self.command.calibrate_offsets && !self.previous_calibrate;
                let enabled = self.command.enable && torque_allowed;
                if (enabled || calibrate) && self.fault.is_none() {
                    self.offset_calibration.restart();
                    self.state = AxisState::CalibratingOffsets;
                }
                Output::OFF
            }
            AxisState::Identified => Output::OFF,
            AxisState::Faulted => {
                // Whether the fault's cause is still there, for the drive's fault reset too
                // (worked out only while faulted: not in the running period's budget).
                let inputs = self.protection_inputs(sample, false);
                self.fault_cause_present = self
                    .fault
                    .is_some_and(|f| self.protections.cause_present(f, &inputs));
                // A rising edge resets, unless the fault's cause is still there (the edge is
                // used up: CiA402 transition 15 "if no fault exists currently").
                let reset = self.command.fault_reset && !self.previous_fault_reset;
                if reset && !self.fault_cause_present {
                    self.fault = None;
                    self.protections.reset();
                    self.state = AxisState::Disabled;
                }
                Output::OFF
            }
            AxisState::CalibratingOffsets => self.calibrate_offsets(c),
            AxisState::Aligning => self.align(&currents),
            AxisState::Running => self.run(&currents, loop_tick),
            AxisState::IdentifyingElectrical => self.identify_electrical(&currents),
            AxisState::IdentifyingInertia => self.identify_inertia(&currents, loop_tick),
        };
        self.previous_fault_reset = self.command.fault_reset;
        self.previous_calibrate = self.command.calibrate_offsets;
        // Measuring the offsets on request needs no enable.
        let calibrating_on_request =
            self.state == AxisState::CalibratingOffsets && self.command.calibrate_offsets;
        let enabled = self.command.enable && torque_allowed;
        if !enabled
            && !calibrating_on_request
            && !matches!(self.state, AxisState::Faulted | AxisState::Disabled)
        {
            self.electrical_ident = None;
            self.inertia_ident = None;
            self.no_current();
            // A fault recorded during a controlled stop holds until its reset.
            self.state = if self.fault.is_some() {
                AxisState::Faulted
            } else {
                AxisState::Disabled
            };
            return Output::OFF;
        }
        if loop_tick {
            let enabled = output.gates;
            if matches!(
                self.state,
                AxisState::Disabled
                    | AxisState::Faulted
                    | AxisState::Identified
                    | AxisState::CalibratingOffsets
            ) {
                // Gates off: the velocity is still observed (a motor turned by its load or by
                // hand shows in 606Ch; a drive must know whether the motor is running). The
                // observer starts from the first valid position (an absolute encoder's
                // power-on position is anywhere: no jump from 0).
                if !self.position_valid {
                    self.last_velocity = 0.0;
                } else if self.velocity_observed {
                    self.last_velocity = self.velocity.update(self.position);
                } else {
                    self.velocity.reset(self.position);
                    self.velocity_observed = true;
                }
            }
            let fault = self
                .protections
                .check(&self.protection_inputs(sample, enabled));
            if let Some(fault) = fault {
                if !(fault.allows_controlled_stop() && self.state == AxisState::Running) {
                    return self.trip(fault, link);
                }
                // Reported, and the motor stays under control: the drive's fault reaction
                // decelerates it (ControlMode::Stop) and then disables it.
                self.record(fault);
            }
            self.publish(link);
        }
        output
    }

    /// Records `fault` without stopping (a fault that allows a controlled stop; the first one
    /// stays until a reset, unless a fault that cuts the gates replaces it).
    fn record(&mut self, fault: MotorFault) {
        // A fault that cuts the gates replaces one that allowed a controlled stop (a new trip
        // for the drive, which then ends its fault reaction at once).
        let escalates = self.fault.is_some_and(MotorFault::allows_controlled_stop)
            && !fault.allows_controlled_stop();
        if self.fault.is_none() || escalates {
            self.fault = Some(fault);
            self.trips = self.trips.wrapping_add(1);
        }
    }

    /// The gates are off: no current flows. The I²t models, 6077h and the protections see
    /// zero from now on, not the last current the loop measured (with which an overload would
    /// go on heating its model while faulted, and never become resettable).
    fn no_current(&mut self) {
        self.last_id = 0.0;
        self.last_iq = 0.0;
    }

    /// Latches `fault` (the first one stays until a reset) and stops: gates off.
    fn latch(&mut self, fault: MotorFault) {
        self.record(fault);
        self.state = AxisState::Faulted;
        self.no_current();
    }

    fn trip(&mut self, fault: MotorFault, link: &AxisLink) -> Output {
        self.latch(fault);
        // The loops are not emptied here: nothing reads them while faulted, and every way back
        // to running empties them (`calibrate_offsets` the current loop, `start_running` the
        // speed loop). A tripping period is the control interrupt's worst case; the speed
        // loop's filters alone cost some 80 instructions to reset.
        self.publish(link);
        Output::OFF
    }

    /// What the protections judge in this period's `sample` (`enabled`: the gates switch).
    #[inline(always)]
    fn protection_inputs(&self, sample: &Sample, enabled: bool) -> ProtectionInputs {
        ProtectionInputs {
            id: self.last_id,
            iq: self.last_iq,
            bus_voltage: sample.bus_voltage,
            velocity: self.last_velocity,
            encoder: sample.position,
            temperature: sample.temperature,
            motor_overtemp: sample.motor_overtemp,
            following_error: self.position_loop.following_error(),
            enabled,
        }
    }

    fn publish(&mut self, link: &AxisLink) {
        link.feedback.write(AxisFeedback {
            state: self.state,
            fault: self.fault,
            position: self.position,
            velocity: self.last_velocity,
            torque: self.last_iq * self.nm_per_iq,
            following_error: self.position_loop.following_error(),
            trips: self.trips,
            offset_calibrations: self.offset_calibrations,
            main_power: self.vbus >= self.cfg.protection.bus_under_voltage_v,
            bus_voltage: self.vbus,
            motor_load: self.protections.motor_load(),
            drive_load: self.protections.drive_load(),
            stopping: self.state == AxisState::Running
                && self.command.mode == ControlMode::Stop
                && !self.stop_ramp.done(),
            current_limited: self.state == AxisState::Running && self.current_limited,
            fault_cause_present: self.fault_cause_present,
            switches: Switches {
                positive_limit: self.captures.positive_limit.level,
                negative_limit: self.captures.negative_limit.level,
                home: self.captures.home.level,
            },
            safe_torque_off_channels: self.safe_torque_off_channels,
            withheld: self.withheld,
        });
        if self.identification_changed {
            link.identification.write(self.identified);
            self.identification_changed = false;
        }
        if self.captures_changed {
            // Edges are rare: the captures go out only when one happened.
            link.captures.write(self.captures);
            self.captures_changed = false;
        }
    }

    fn read_encoder(&mut self, sample: &Sample) {
        let previous = self.position;
        // A bad frame keeps the last good position (the protections count the errors).
        if let Ok(p) = sample.position {
            self.position = p;
            self.position_valid = true;
        }
        if self.captures_started {
            self.captures_changed |=
                self.captures
                    .update(sample.switches, sample.index, self.position);
            if self.captures.probes_changed(&sample.probes) {
                self.captures_changed |= self.captures.update_probes(
                    sample.probes,
                    self.position,
                    previous,
                    self.inv_period_ns,
                );
            }
        } else {
            self.captures = Captures::initial(sample.switches);
            for (capture, probe) in self.captures.probes.iter_mut().zip(sample.probes) {
                capture.level = probe.active;
            }
            self.captures_started = true;
            self.captures_changed = true;
        }
    }

    fn take_command(&mut self, link: &AxisLink) {
        if let Some((command, seq)) = link.commands.read_if_new(self.command_seq) {
            self.command_seq = seq;
            let previous = self.command.mode;
            if command.following_error_limits != self.command.following_error_limits {
                self.apply_following_error_limits(command.following_error_limits);
            }
            if command.torque_limits != self.command.torque_limits {
                self.apply_torque_limits(command.torque_limits);
            }
            self.command = command;
            if command.bus_cycle_ns != 0 && command.bus_cycle_ns != self.bus_cycle_ns {
                self.retime_interpolator(command.bus_cycle_ns, link);
            }
            if self.state == AxisState::Running {
                let stop = ControlMode::Stop;
                if command.mode == stop && previous != stop {
                    self.start_stop_ramp(self.last_velocity);
                } else if previous == stop && command.mode != stop {
                    // The stop ends (halt released, quick stop left by enable operation): the
                    // set-points resume from where the motor is.
                    self.interpolator.reset(self.position);
                    self.position_loop.reset();
                } else if command.mode == ControlMode::Position && previous != command.mode {
                    // A position stream takes over a motor the speed or torque loop ran (a
                    // mode change while moving): from where it is, at its speed.
                    self.interpolator
                        .reset_moving(self.position, self.last_velocity);
                    self.position_loop.reset();
                }
                self.push_setpoint();
            }
        }
    }

    /// Starts the deceleration ramp of a stop from `velocity` (increments/s).
    fn start_stop_ramp(&mut self, velocity: f32) {
        let loop_dt = self.cfg.loop_divider as f32 / self.cfg.pwm_hz;
        self.stop_ramp = StopRamp::new(velocity, self.command.deceleration, loop_dt);
    }

    /// Rebuilds the interpolator for set-points every `bus_cycle_ns`. A cycle shorter than the
    /// loop period keeps the previous timing and has `link`'s SYNC0 side hand over every k-th
    /// command as one of k cycles ([`Decimation`]), which the next command brings; any other
    /// cycle it cannot serve (longer than the interpolator's limit: the slave's cycle range
    /// excludes those) keeps the previous timing.
    #[cold]
    #[inline(never)]
    fn retime_interpolator(&mut self, bus_cycle_ns: u32, link: &AxisLink) {
        const NS_PER_S: f32 = 1e9;
        let loop_hz = self.cfg.pwm_hz / self.cfg.loop_divider as f32;
        match Interpolator::new(bus_cycle_ns as f32 * 1e-9, loop_hz) {
            Ok(interpolator) => {
                self.interpolator = interpolator;
                self.interpolator.reset(self.position);
                self.bus_cycle_ns = bus_cycle_ns;
            }
            Err(InterpolateError::CycleShorterThanTick) => {
                // Rounded up, so that k cycles of the decimation span a whole loop period.
                let period_ns = NS_PER_S / loop_hz;
                let whole = period_ns as u32;
                let rounded_up = whole.saturating_add(u32::from((whole as f32) < period_ns));
                link.decimate_below(rounded_up);
            }
            Err(_) => {}
        }
    }

    /// Hands the command's set-point of its mode to the interpolator.
    /// New following-error limits (6065h/6066h changed; rare: kept out of the hot path).
    #[cold]
    #[inline(never)]
    fn apply_following_error_limits(&mut self, limits: Option<(u32, u16)>) {
        if let Some((window, timeout_ms)) = limits {
            self.protections.set_following_error(window, timeout_ms);
        }
    }

    /// New torque limits (6072h/60E0h/60E1h changed; rare), capped at the configured limit.
    #[cold]
    #[inline(never)]
    fn apply_torque_limits(&mut self, limits: Option<(f32, f32)>) {
        let cap = self.cfg.speed_loop.torque_limit_nm;
        let (positive, negative) = limits.unwrap_or((cap, cap));
        self.speed_loop
            .set_torque_limits(math::min(positive, cap), math::min(negative, cap));
    }

    fn push_setpoint(&mut self) {
        let c = self.command;
        match c.mode {
            // A velocity with the position (60B1h in CSP, a profile generator's demand) is the
            // segment's end slope; 0 = none given.
            ControlMode::Position => self
                .interpolator
                .push_position(c.position, (c.velocity != 0.0).then_some(c.velocity)),
            ControlMode::Velocity => self.interpolator.push_velocity(c.velocity),
            ControlMode::Torque => self.interpolator.push_torque(c.torque),
            // The ramp, not the master, sets the velocity.
            ControlMode::Stop => {}
        }
    }

    fn calibrate_offsets(&mut self, raw: PhaseCurrents) -> Output {
        match self.offset_calibration.add(raw) {
            None => Output::OFF,
            Some(Err(fault)) => {
                self.latch(fault);
                Output::OFF
            }
            Some(Ok(offsets)) => {
                self.offsets = offsets;
                self.offset_calibrations = self.offset_calibrations.wrapping_add(1);
                self.current_loop.reset();
                if !self.command.enable {
                    // A calibration on request: done, gates stay off.
                    self.state = AxisState::Disabled;
                } else if self.command.identify {
                    self.start_identification();
                } else if self.cfg.motor.commutation_offset.is_none() {
                    self.alignment.restart();
                    self.state = AxisState::Aligning;
                } else {
                    self.start_running();
                }
                Output::OFF
            }
        }
    }

    fn start_identification(&mut self) {
        match ElectricalIdentification::new(ElectricalIdentConfig::small_servo(self.cfg.pwm_hz)) {
            Ok(ident) => {
                self.electrical_ident = Some(ident);
                self.state = AxisState::IdentifyingElectrical;
            }
            Err(fault) => {
                self.latch(fault);
            }
        }
    }

    fn start_running(&mut self) {
        self.speed_loop.reset();
        self.field_weakening.reset();
        self.velocity.reset(self.position);
        self.velocity_observed = true;
        // Enabled in a stop (e.g. halt set): nothing to decelerate.
        self.start_stop_ramp(0.0);
        self.interpolator.reset(self.position);
        self.position_loop.reset();
        self.state = AxisState::Running;
    }

    fn align(&mut self, currents: &PhaseCurrents) -> Output {
        self.alignment_period(currents).unwrap_or_else(|| {
            self.start_running();
            Output::OFF
        })
    }

    /// One period of the commutation alignment: the current loop at the alignment angle, or,
    /// when the alignment failed, its fault latched and the gates off. `None` when it has just
    /// finished: the commutation offset is set and the caller goes on.
    fn alignment_period(&mut self, currents: &PhaseCurrents) -> Option<Output> {
        match self.alignment.step(self.position) {
            AlignStep::Drive { angle, id_ref } => {
                Some(self.current_step(currents, angle, 0.0, id_ref, 0.0))
            }
            AlignStep::Done(Ok(offset)) => {
                self.commutation.set_offset(offset);
                None
            }
            AlignStep::Done(Err(fault)) => {
                self.latch(fault);
                Some(Output::OFF)
            }
        }
    }

    fn run(&mut self, currents: &PhaseCurrents, loop_tick: bool) -> Output {
        if loop_tick {
            let set = self.interpolator.tick();
            // In a stop the ramp, not the master's set-points, commands the motion.
            let (stop_velocity, acceleration) = if self.command.mode == ControlMode::Stop {
                let v = self.stop_ramp.tick();
                (v, self.stop_ramp.acceleration())
            } else {
                (0.0, set.acceleration)
            };
            // The observer is told the commanded acceleration, so it tracks set-point ramps
            // without its 2a/ω lag; disturbances are what its integrator has left to find.
            let velocity = self
                .velocity
                .update_with_acceleration(self.position, acceleration);
            self.last_velocity = velocity;
            self.omega_e = velocity * self.omega_e_per_velocity;
            let torque = match self.command.mode {
                ControlMode::Position => {
                    let v_cmd = self
                        .position_loop
                        .step(set.position, self.position, set.velocity);
                    self.speed_loop
                        .step(v_cmd, velocity, set.acceleration, self.command.torque)
                }
                ControlMode::Velocity => self.speed_loop.step(
                    set.velocity,
                    velocity,
                    set.acceleration,
                    self.command.torque,
                ),
                ControlMode::Torque => set.torque,
                ControlMode::Stop => {
                    self.speed_loop
                        .step(stop_velocity, velocity, acceleration, 0.0)
                }
            };
            // The I²t models fold the limit back towards the continuous current before they
            // would trip (motor and drive derate instead of stopping).
            let limit = math::min(self.cfg.current_limit_a, self.protections.current_limit());
            // Near the voltage limit a negative d current makes room; q gets what the current
            // vector's limit leaves.
            let v2_per_vbus2 = self.last_v2 * self.inv_vbus * self.inv_vbus;
            let id_ref = self.field_weakening.step(v2_per_vbus2);
            let iq_limit = math::sqrt(math::max(limit * limit - id_ref * id_ref, 0.0));
            let iq_request = torque * self.iq_per_nm;
            // The speed loop pins its output at its torque limit; a torque set-point is cut
            // at the current limit.
            self.current_limited =
                self.speed_loop.at_torque_limit(torque) || iq_request.abs() >= iq_limit;
            self.iq_ref = math::clamp_symmetric(iq_request, iq_limit);
            self.id_ref = id_ref;
        }
        let angle = self.commutation.angle(self.position);
        let (id_ref, iq_ref) = (
            self.id_ref + self.injection.0,
            self.iq_ref + self.injection.1,
        );
        self.current_step(currents, angle, self.omega_e, id_ref, iq_ref)
    }

    fn current_step(
        &mut self,
        currents: &PhaseCurrents,
        angle: ElectricalAngle,
        omega_e: f32,
        id_ref: f32,
        iq_ref: f32,
    ) -> Output {
        let out = self.current_loop.step(&CurrentLoopInput {
            currents: *currents,
            angle,
            omega_e,
            vbus: self.vbus,
            inv_vbus: self.inv_vbus,
            id_ref,
            iq_ref,
        });
        self.last_id = out.id;
        self.last_iq = out.iq;
        self.last_v2 = out.vd * out.vd + out.vq * out.vq;
        Output {
            gates: true,
            duties: out.duties,
        }
    }

    fn identify_electrical(&mut self, currents: &PhaseCurrents) -> Output {
        let Some(ident) = self.electrical_ident.as_mut() else {
            self.state = AxisState::Disabled;
            return Output::OFF;
        };
        // Currents in the frame of the commanded angle (always 0 here: the a-phase axis).
        let i_alpha = (2.0 * currents.a - currents.b - currents.c) * (1.0 / 3.0);
        let i_beta = (currents.b - currents.c) * math::INV_SQRT3;
        let m = IdentMeasurement {
            id: i_alpha,
            iq: i_beta,
            velocity: self.last_velocity,
        };
        self.last_id = i_alpha;
        self.last_iq = i_beta;
        match ident.step(&m) {
            IdentCommand::Voltage { angle, vd, vq } => {
                let (s, c) = math::sin_cos(angle);
                let v_alpha = vd * c - vq * s;
                let v_beta = vd * s + vq * c;
                let modulation = svpwm::modulate(v_alpha, v_beta, self.inv_vbus);
                Output {
                    gates: true,
                    duties: modulation.duties,
                }
            }
            IdentCommand::Done(Ok(result)) => {
                self.identification_changed = true;
                self.identified = Some(Identification {
                    resistance_ohm: result.resistance_ohm,
                    ld_h: result.ld_h,
                    lq_h: result.lq_h,
                    inertia: 0.0,
                    inertia_kgm2: 0.0,
                });
                self.electrical_ident = None;
                // The inertia test runs the current loop: tune it to what was just measured.
                let tuned = CurrentLoop::new(&CurrentLoopConfig {
                    resistance_ohm: result.resistance_ohm,
                    ld_h: result.ld_h,
                    lq_h: result.lq_h,
                    flux_wb: self.cfg.motor.flux_wb,
                    pwm_hz: self.cfg.pwm_hz,
                    ..self.cfg.current_loop
                });
                match tuned {
                    Ok(current_loop) => {
                        self.current_loop = current_loop;
                        self.start_inertia_identification();
                    }
                    Err(_) => {
                        self.latch(MotorFault::Identification);
                    }
                }
                Output::OFF
            }
            IdentCommand::Done(Err(fault)) => {
                self.electrical_ident = None;
                self.latch(fault);
                Output::OFF
            }
        }
    }

    fn start_inertia_identification(&mut self) {
        let loop_hz = self.cfg.pwm_hz / self.cfg.loop_divider as f32;
        let counts = self.cfg.motor.counts_per_rev as f32;
        let cfg = InertiaIdentConfig {
            sample_hz: loop_hz,
            current_a: 0.25 * self.cfg.current_limit_a,
            torque_constant_nm_per_a: self.cfg.motor.torque_constant(),
            // Two revolutions per second at most, 0.25 s per half.
            max_speed: 2.0 * counts,
            max_time_s: 0.25,
        };
        match InertiaIdentification::new(cfg) {
            Ok(ident) => {
                self.inertia_ident = Some(ident);
                self.current_loop.reset();
                if self.cfg.motor.commutation_offset.is_none() {
                    // The inertia test needs commutation: align first, then come back.
                    self.alignment.restart();
                }
                self.velocity.reset(self.position);
                self.state = AxisState::IdentifyingInertia;
            }
            Err(fault) => {
                self.latch(fault);
            }
        }
    }

    fn identify_inertia(&mut self, currents: &PhaseCurrents, loop_tick: bool) -> Output {
        if self.cfg.motor.commutation_offset.is_none() && !self.alignment.is_done() {
            return self.alignment_period(currents).unwrap_or_else(|| {
                self.velocity.reset(self.position);
                Output::OFF
            });
        }
        if loop_tick {
            let velocity = self.velocity.update(self.position);
            self.last_velocity = velocity;
            self.omega_e = velocity * self.omega_e_per_velocity;
            let Some(ident) = self.inertia_ident.as_mut() else {
                self.state = AxisState::Disabled;
                return Output::OFF;
            };
            match ident.step(&IdentMeasurement {
                id: self.last_id,
                iq: self.last_iq,
                velocity,
            }) {
                InertiaStep::Current { iq_ref } => {
                    self.iq_ref = iq_ref;
                    self.id_ref = 0.0;
                }
                InertiaStep::Done(result) => {
                    self.inertia_ident = None;
                    match result {
                        Ok(j) => {
                            if let Some(id) = self.identified.as_mut() {
                                self.identification_changed = true;
                                id.inertia = j;
                                id.inertia_kgm2 = j * self.cfg.motor.counts_per_rev as f32 / TAU;
                            }
                            self.state = AxisState::Identified;
                        }
                        Err(fault) => {
                            self.latch(fault);
                        }
                    }
                    return Output::OFF;
                }
            }
        }
        let angle = self.commutation.angle(self.position);
        self.current_step(currents, angle, self.omega_e, self.id_ref, self.iq_ref)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A board whose drivers return fixed values and record the inverter calls.
    #[derive(Default)]
    struct Board {
        calls: [Option<&'static str>; 4],
        n: usize,
        enabled: bool,
        duties: Option<(f32, f32, f32)>,
    }

    impl Board {
        fn record(&mut self, call: &'static str) {
            self.calls[self.n] = Some(call);
            self.n += 1;
        }
    }

    impl CurrentSense for Board {
        fn phase_currents(&mut self) -> PhaseCurrents {
            PhaseCurrents {
                a: 1.0,
                b: -0.5,
                c: -0.25,
            }
        }
    }

    impl BusSense for Board {
        fn bus_voltage(&mut self) -> f32 {
            47.5
        }
        fn temperature(&mut self) -> f32 {
            31.0
        }
    }

    impl Encoder for Board {
        fn resolution(&self) -> u32 {
            4_096
        }
        fn position(&mut self) -> Result<i64, EncoderFault> {
            Err(EncoderFault::Crc)
        }
        fn take_index(&mut self) -> Option<i64> {
            None
        }
    }

    impl DigitalInputs for Board {
        fn positive_limit(&mut self) -> bool {
            false
        }
        fn negative_limit(&mut self) -> bool {
            false
        }
        fn home_switch(&mut self) -> bool {
            false
        }
        fn motor_over_temperature(&mut self) -> bool {
            true
        }
        fn touch_probe(&mut self, _: TouchProbe) -> ProbeCapture {
            ProbeCapture::default()
        }
        fn enable_input(&mut self) -> bool {
            // Withheld on this board, so that the sample shows the input was read.
            false
        }
    }

    impl Inverter for Board {
        fn pwm_frequency_hz(&self) -> u32 {
            20_000
        }
        fn set_duties(&mut self, a: f32, b: f32, c: f32) {
            self.record("set_duties");
            self.duties = Some((a, b, c));
        }
        fn enable(&mut self) {
            self.record("enable");
            self.enabled = true;
        }
        fn disable(&mut self) {
            self.record("disable");
            self.enabled = false;
        }
        fn is_enabled(&self) -> bool {
            self.enabled
        }
        fn take_hardware_trip(&mut self) -> bool {
            // Tripped while enabled (a test sets `enabled` and expects the trip in the sample).
            self.enabled
        }
    }

    /// A sample of the 400 W servo at rest on `position`: no current, 48 V, 25 °C, no switch,
    /// both STO channels closed.
    fn quiet_sample(position: i64) -> Sample {
        Sample {
            currents: PhaseCurrents::default(),
            bus_voltage: 48.0,
            temperature: 25.0,
            motor_overtemp: false,
            position: Ok(position),
            switches: Switches::default(),
            index: None,
            probes: [ProbeCapture::default(); 2],
            safe_torque_off_channels: [true; 2],
            enable_input: true,
            power_stage_trip: false,
        }
    }

    /// The 400 W servo's axis at rest on `position`, gates off, `ticks` loop ticks with
    /// `command`; the feedback at the end.
    fn at_rest(position: i64, command: AxisCommand, ticks: u32) -> (Axis, AxisFeedback) {
        use crate::servo::{axis_config, Tuning, SERVO_400W};
        let cfg = axis_config(&SERVO_400W, &Tuning::DEFAULT);
        let mut axis = Axis::new(cfg).unwrap();
        // SAFETY: one thread calls both sides, one after the other.
        let link = unsafe { AxisLink::new() };
        let sample = quiet_sample(position);
        for _ in 0..ticks {
            link.publish(command);
            for _ in 0..cfg.loop_divider {
                axis.control_step(&sample, &link);
            }
        }
        let fb = link.feedback();
        (axis, fb)
    }

    /// A bus cycle shorter than the loop period (31.25 µs against the 400 W servo's 20 kHz
    /// position loop, 50 µs): the axis has the SYNC0 side decimate, which from then on hands
    /// over every second command as one of 62.5 µs, evenly spaced, and the interpolator is
    /// timed to it (1.25 ticks). Before that, and for a cycle of a loop period or more, every
    /// command is handed over as it is.
    #[test]
    fn a_bus_cycle_shorter_than_the_loop_period_is_handed_over_decimated() {
        use crate::servo::{axis_config, Tuning, SERVO_400W};
        let cfg = axis_config(&SERVO_400W, &Tuning::DEFAULT);
        assert_eq!(cfg.pwm_hz / cfg.loop_divider as f32, 20_000.0);
        let mut axis = Axis::new(cfg).unwrap();
        // SAFETY: one thread calls both sides, one after the other.
        let link = unsafe { AxisLink::new() };
        let sample = quiet_sample(0);
        // One loop cycle: the commands are taken in its first PWM period.
        let loop_cycle = |axis: &mut Axis| {
            for _ in 0..cfg.loop_divider {
                axis.control_step(&sample, &link);
            }
        };
        let command = |position, bus_cycle_ns| AxisCommand {
            position,
            bus_cycle_ns,
            ..AxisCommand::default()
        };
        link.publish(command(1, 31_250));
        assert_eq!(link.commands.read(), (command(1, 31_250), 1));
        loop_cycle(&mut axis);
        // Not servable: the tuning's 1 ms timing is kept.
        assert_eq!(axis.interpolator.ticks_per_cycle(), 20.0);
        let mut handed_over = 1;
        for k in 2..12 {
            link.publish(command(k, 31_250));
            if k % 2 == 1 {
                handed_over += 1;
                assert_eq!(
                    link.commands.read(),
                    (command(k, 62_500), handed_over),
                    "command {k}"
                );
            } else {
                assert_eq!(link.commands.read().1, handed_over, "command {k} held back");
            }
        }
        loop_cycle(&mut axis);
        assert_eq!(axis.interpolator.ticks_per_cycle(), 1.25);
        assert_eq!(axis.bus_cycle_ns, 62_500);
        // A cycle of a loop period or more: every command.
        for (k, cycle_ns) in [(20, 50_000), (21, 50_000), (22, 1_000_000), (23, 1_000_000)] {
            link.publish(command(k, cycle_ns));
            handed_over += 1;
            assert_eq!(link.commands.read(), (command(k, cycle_ns), handed_over));
        }
        loop_cycle(&mut axis);
        assert_eq!(axis.interpolator.ticks_per_cycle(), 20.0);
    }

    #[test]
    fn a_motor_at_rest_far_from_zero_is_at_rest_while_disabled_and_when_enabled() {
        // An absolute encoder's power-on position is anywhere: the gates-off velocity
        // observation starts there, not at 0 (which would be a huge speed: over-speed).
        let far = 0x7_0012_3456;
        let (_, fb) = at_rest(far, AxisCommand::default(), 200);
        assert_eq!(
            (fb.state, fb.fault, fb.velocity),
            (AxisState::Disabled, None, 0.0)
        );
        assert!(fb.main_power);
        let enable = AxisCommand {
            enable: true,
            mode: ControlMode::Position,
            position: far,
            ..AxisCommand::default()
        };
        let (axis, fb) = at_rest(far, enable, 2_000);
        assert_eq!((axis.state(), fb.fault), (AxisState::Running, None));
    }

    #[test]
    fn a_hardware_trip_latches_an_over_current_in_every_state() {
        use crate::servo::{axis_config, Tuning, SERVO_400W};
        let cfg = axis_config(&SERVO_400W, &Tuning::DEFAULT);
        let quiet = quiet_sample(1_000);
        let tripped = Sample {
            power_stage_trip: true,
            ..quiet
        };
        let enable = AxisCommand {
            enable: true,
            mode: ControlMode::Position,
            position: 1_000,
            ..AxisCommand::default()
        };
        // Periods after the enable at which the break fires: the first is inside the offset
        // calibration (where the software over-current check is not run), the last in
        // closed loop.
        for trip_at in [2, cfg.offset_samples / 2, 5_000] {
            let mut axis = Axis::new(cfg).unwrap();
            // SAFETY: one thread calls both sides, one after the other.
            let link = unsafe { AxisLink::new() };
            link.publish(enable);
            for _ in 0..trip_at {
                axis.control_step(&quiet, &link);
            }
            let state = axis.state();
            let out = axis.control_step(&tripped, &link);
            assert!(!out.gates, "gates off at a trip in {state:?}");
            assert_eq!(axis.state(), AxisState::Faulted, "trip in {state:?}");
            assert_eq!(
                axis.fault(),
                Some(MotorFault::OverCurrent),
                "trip in {state:?}"
            );
            // Latched: quiet samples do not bring the gates back.
            for _ in 0..100 {
                assert!(!axis.control_step(&quiet, &link).gates);
            }
        }
    }

    #[test]
    fn safe_torque_off_cuts_the_output_at_once_and_never_restarts_by_itself() {
        let closed = quiet_sample(1_000);
        let open = Sample {
            safe_torque_off_channels: [true, false],
            ..closed
        };
        let fb = withheld_permission_cuts_the_output_and_never_restarts(open, |fb| {
            fb.withheld.safe_torque_off()
        });
        assert!(
            !fb.withheld.interlocked(),
            "safe torque off is not the enable input"
        );
        assert_eq!(fb.safe_torque_off_channels, [true, false]);
    }

    #[test]
    fn an_open_enable_input_cuts_the_output_at_once_and_never_restarts_by_itself() {
        let open = Sample {
            enable_input: false,
            ..quiet_sample(1_000)
        };
        let fb = withheld_permission_cuts_the_output_and_never_restarts(open, |fb| {
            fb.withheld.interlocked()
        });
        assert!(
            !fb.withheld.safe_torque_off(),
            "the enable input is not safe torque off"
        );
    }

    /// Runs the 400 W servo in position control and withholds its permission to run with
    /// `open` (a sample at rest on 1,000 apart from the open input); `held` reads the feedback
    /// flag that shows it. Asserts: the gates go off in that very period, as a disable, not a
    /// fault; they stay off after the input closes again while the enable is still given; the
    /// enable taken back and given again runs the axis. Returns the feedback while open.
    fn withheld_permission_cuts_the_output_and_never_restarts(
        open: Sample,
        held: fn(&AxisFeedback) -> bool,
    ) -> AxisFeedback {
        use crate::servo::{axis_config, Tuning, SERVO_400W};
        let cfg = axis_config(&SERVO_400W, &Tuning::DEFAULT);
        let mut axis = Axis::new(cfg).unwrap();
        // SAFETY: one thread calls both sides, one after the other.
        let link = unsafe { AxisLink::new() };
        let closed = quiet_sample(1_000);
        let enable = AxisCommand {
            enable: true,
            mode: ControlMode::Position,
            position: 1_000,
            ..AxisCommand::default()
        };
        link.publish(enable);
        for _ in 0..2_000 * cfg.loop_divider {
            axis.control_step(&closed, &link);
        }
        assert_eq!(axis.state(), AxisState::Running);
        // Channel 2 opens: no gates from this very period on, not a fault.
        let out = axis.control_step(&open, &link);
        assert!(!out.gates);
        assert_eq!(axis.state(), AxisState::Disabled);
        for _ in 0..100 {
            assert!(!axis.control_step(&open, &link).gates);
        }
        let while_open = link.feedback();
        assert!(held(&while_open) && while_open.fault.is_none());
        // Closed again with the enable still given: the motor stays off.
        for _ in 0..2_000 * cfg.loop_divider {
            assert!(!axis.control_step(&closed, &link).gates);
        }
        assert_eq!(axis.state(), AxisState::Disabled);
        assert!(
            held(&link.feedback()),
            "held until the enable is taken back"
        );
        // The enable taken back, then given again: it runs.
        link.publish(AxisCommand::default());
        for _ in 0..10 * cfg.loop_divider {
            axis.control_step(&closed, &link);
        }
        assert!(!held(&link.feedback()));
        link.publish(enable);
        for _ in 0..2_000 * cfg.loop_divider {
            axis.control_step(&closed, &link);
        }
        assert_eq!(axis.state(), AxisState::Running);
        while_open
    }

    #[test]
    fn a_sample_is_read_through_the_board_drivers() {
        let (mut c, mut b, mut e, mut i) = (
            Board::default(),
            Board::default(),
            Board::default(),
            Board::default(),
        );
        let mut p = Board {
            enabled: true,
            ..Board::default()
        };
        let s = Sample::read(&mut p, &mut c, &mut b, &mut e, &mut i);
        assert_eq!(
            s,
            Sample {
                currents: PhaseCurrents {
                    a: 1.0,
                    b: -0.5,
                    c: -0.25,
                },
                bus_voltage: 47.5,
                temperature: 31.0,
                motor_overtemp: true,
                position: Err(EncoderFault::Crc),
                switches: Switches::default(),
                index: None,
                probes: [ProbeCapture::default(); 2],
                safe_torque_off_channels: [true; 2],
                enable_input: false,
                power_stage_trip: true,
            }
        );
    }

    #[test]
    fn an_output_disables_first_and_enables_only_once() {
        let on = Output {
            gates: true,
            duties: Duties {
                a: 0.4,
                b: 0.5,
                c: 0.6,
            },
        };
        let mut inv = Board::default();
        on.apply(&mut inv);
        on.apply(&mut inv);
        assert_eq!(
            inv.calls,
            [Some("set_duties"), Some("enable"), Some("set_duties"), None]
        );
        assert_eq!(inv.duties, Some((0.4, 0.5, 0.6)));
        let mut inv = Board {
            enabled: true,
            ..Board::default()
        };
        Output::OFF.apply(&mut inv);
        assert_eq!(inv.calls, [Some("disable"), Some("set_duties"), None, None]);
        assert!(!inv.enabled);
    }
}
