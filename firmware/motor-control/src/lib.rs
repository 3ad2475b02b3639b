//! Motor control: FOC current loop, speed and position loops, set-point interpolation,
//! protections, calibration and commissioning.
//!
//! # Units (inside this module)
//! | quantity | unit | type |
//! |---|---|---|
//! | current | A | `f32` |
//! | voltage | V | `f32` |
//! | torque | N·m | `f32` |
//! | electrical angle | turns, 2^32 = one electrical turn, wraps | [`ElectricalAngle`] (`fixed` U0F32) |
//! | mechanical position | encoder increments, multi-turn | `i64` |
//! | velocity | increments per second | `f32` |
//! | acceleration | increments per second² | `f32` |
//! | time | seconds | `f32` |
//!
//! Conversions to the units of the objects (0.1 rpm, ‰ of rated torque, user units) happen at
//! the object-dictionary boundary, never in here.
//!
//! # Contexts
//! Everything called from the control interrupt (PWM/ADC rate) is branch-light `f32` code with no
//! division (reciprocals are precomputed when a configuration is applied), no `libm`
//! transcendental functions and no `f32::min/max` (they become library calls on the target); see
//! [`math`].
//!
//! | module | what |
//! |---|---|
//! | [`math`] | sin/cos of an [`ElectricalAngle`], square root, compare-select clamps |
//! | [`pi`] | PI controller with output limits and anti-windup |
//! | [`svpwm`] | space-vector modulation, over-modulation, dead-time compensation |
//! | [`foc`] | the current loop: Clarke, Park, d/q PI with decoupling, circle limiter, inverse Park |
//! | [`field_weakening`] | negative d current when the voltage nears the bus limit |
//! | [`filters`] | first-order low-pass, biquad low-pass and notch (torque-reference filters) |
//! | [`velocity`] | velocity estimate from encoder increments |
//! | [`speed`], [`position`] | the speed and position loops |
//! | [`interpolate`] | set-points between SYNC0 events at the control-loop rate |
//! | [`ramp`] | the deceleration ramp of a stop |
//! | [`trajectory`] | motion profiles of the profile modes at the bus-cycle rate: point-to-point moves, velocity ramps, slew limits |
//! | [`handoff`] | lock-free set-point/feedback exchange between SYNC0 and the control interrupt |
//! | [`protection`] | over-current, I²t, bus voltage, over-speed, encoder and temperature faults |
//! | [`capture`] | positions latched at the edges of the limit and home switches and at the encoder index |
//! | [`calibration`] | phase-current offsets, commutation-angle alignment |
//! | [`commissioning`] | identification of R, L and inertia; gains from bandwidths |
//! | [`axis`] | the whole control interrupt of one axis |
//! | [`servo`] | a servo (motor, encoder, power stage) as data, its tuning, and the [`axis::AxisConfig`] derived from them; the 400 W reference servo |
#![no_std]
#![deny(missing_docs)]
// Firmware never panics on input: outside tests no unwrap/expect/panic and no unchecked
// indexing or integer arithmetic; each exception states why it cannot fail where it stands.
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::unreachable,
        clippy::todo,
        clippy::unimplemented,
        clippy::indexing_slicing,
        clippy::arithmetic_side_effects
    )
)]

pub mod axis;
pub mod calibration;
pub mod capture;
pub mod commissioning;
pub mod field_weakening;
pub mod filters;
pub mod foc;
pub mod handoff;
pub mod interpolate;
pub mod math;
pub mod pi;
pub mod position;
pub mod protection;
pub mod ramp;
pub mod servo;
pub mod speed;
pub mod svpwm;
pub mod trajectory;
pub mod velocity;

/// Electrical angle: a fraction of one electrical turn; wraps at one turn.
pub type ElectricalAngle = fixed::types::U0F32;

/// PWM duty cycles of phases a, b, c, fractions 0.0..=1.0 of the period (centre-aligned).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Duties {
    /// Phase a.
    pub a: f32,
    /// Phase b.
    pub b: f32,
    /// Phase c.
    pub c: f32,
}

impl Duties {
    /// All three phases at 50 %: zero line-to-line voltage.
    pub const CENTRED: Self = Self {
        a: 0.5,
        b: 0.5,
        c: 0.5,
    };
}

/// Why the motor control stopped: the internal fault codes. Profiles map each to their 603Fh
/// error code and EMCY (the `[motor_faults]` table of the profile file).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum MotorFault {
    /// A phase current exceeded the trip level: gates off within the PWM period.
    OverCurrent = 1,
    /// The motor's I²t (thermal) integral reached its limit.
    MotorOverload = 2,
    /// The drive's (power stage) I²t integral reached its limit.
    DriveOverload = 3,
    /// DC-bus voltage above the trip level.
    BusOverVoltage = 4,
    /// DC-bus voltage below the trip level.
    BusUnderVoltage = 5,
    /// Speed above the over-speed limit.
    OverSpeed = 6,
    /// The encoder lost its signal.
    EncoderSignalLoss = 7,
    /// The encoder position jumped further than the motor can move in one sample.
    EncoderJump = 8,
    /// A serial encoder frame failed its CRC (repeatedly).
    EncoderCrc = 9,
    /// The power stage is too hot.
    DriveOverTemperature = 10,
    /// The motor's over-temperature input (thermal switch) is active.
    MotorOverTemperature = 11,
    /// The position following error exceeded its window for longer than its timeout.
    FollowingError = 12,
    /// The phase-current offset calibration found an offset outside the plausible range.
    CurrentOffset = 13,
    /// The commutation-angle alignment did not see the rotor move as expected.
    Alignment = 14,
    /// A commissioning identification gave an implausible result.
    Identification = 15,
}

impl MotorFault {
    /// Every fault, in code order.
    pub const ALL: [MotorFault; 15] = [
        MotorFault::OverCurrent,
        MotorFault::MotorOverload,
        MotorFault::DriveOverload,
        MotorFault::BusOverVoltage,
        MotorFault::BusUnderVoltage,
        MotorFault::OverSpeed,
        MotorFault::EncoderSignalLoss,
        MotorFault::EncoderJump,
        MotorFault::EncoderCrc,
        MotorFault::DriveOverTemperature,
        MotorFault::MotorOverTemperature,
        MotorFault::FollowingError,
        MotorFault::CurrentOffset,
        MotorFault::Alignment,
        MotorFault::Identification,
    ];

    /// The internal fault code.
    pub const fn code(self) -> u8 {
        self as u8
    }

    /// Whether the motor is still under control after the fault, so that the drive's fault
    /// reaction (CiA402 605Eh) can decelerate it before the power stage goes off: a following
    /// error, and the thermal faults (I²t overloads, over-temperatures: the loops, sensors and
    /// power stage are sound, and heat builds over seconds, far longer than a stop ramp; drives
    /// stop on them under control, e.g. Yaskawa's group-2 alarms). Every other fault cuts the
    /// gates at once, and cuts them during such a controlled stop too
    /// ([`protection::Protections::check`] reports it over the first).
    pub const fn allows_controlled_stop(self) -> bool {
        matches!(
            self,
            MotorFault::FollowingError
                | MotorFault::MotorOverload
                | MotorFault::DriveOverload
                | MotorFault::DriveOverTemperature
                | MotorFault::MotorOverTemperature
        )
    }

    /// The name used in profile files (`[motor_faults]`).
    pub const fn name(self) -> &'static str {
        match self {
            MotorFault::OverCurrent => "over_current",
            MotorFault::MotorOverload => "motor_overload",
            MotorFault::DriveOverload => "drive_overload",
            MotorFault::BusOverVoltage => "bus_over_voltage",
            MotorFault::BusUnderVoltage => "bus_under_voltage",
            MotorFault::OverSpeed => "over_speed",
            MotorFault::EncoderSignalLoss => "encoder_signal_loss",
            MotorFault::EncoderJump => "encoder_jump",
            MotorFault::EncoderCrc => "encoder_crc",
            MotorFault::DriveOverTemperature => "drive_over_temperature",
            MotorFault::MotorOverTemperature => "motor_over_temperature",
            MotorFault::FollowingError => "following_error",
            MotorFault::CurrentOffset => "current_offset",
            MotorFault::Alignment => "alignment",
            MotorFault::Identification => "identification",
        }
    }
}
