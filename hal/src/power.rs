//! Power stage: inverter PWM, phase-current and DC-bus voltage sensing.
//!
//! # For firmware
//! Duty cycles are fractions 0.0..=1.0 of the PWM period per phase (centre-aligned). Currents are
//! in amperes, voltages in volts, as `f32` (the FOC math runs on the FPU).
//!
//! # For boards
//! `set_duties` and `enable` take effect at the next PWM period boundary (shadow registers
//! loaded at the update event); `disable` turns all gates off at once and MUST be callable from
//! the highest-priority interrupt (over-current trip). The sensing traits return what was
//! latched at the last PWM-synchronous sample (the update event, all low-side switches on),
//! never a value torn between two samples.

/// Three-phase inverter.
pub trait Inverter {
    /// PWM frequency in Hz.
    fn pwm_frequency_hz(&self) -> u32;
    /// Sets the duty cycles of phases a, b, c (0.0..=1.0), applied at the next period.
    fn set_duties(&mut self, a: f32, b: f32, c: f32);
    /// Enables the gate drivers from the next period boundary on, with the duties set for that
    /// period: the first switched period is one the control loop computed duties for (an
    /// immediate enable would switch the rest of the present period with stale duties).
    fn enable(&mut self);
    /// Disables all gates (outputs floating). Immediate.
    fn disable(&mut self);
    /// Whether the gates are enabled, or will be from the next period boundary on (`enable`
    /// was called since the last `disable`).
    fn is_enabled(&self) -> bool;
    /// Whether the power stage's hardware protection (over-current comparator, gate-driver
    /// fault: on an STM32 the advanced timer's break input) switched the gates off since the
    /// last call. The board keeps the gates off after a trip until `disable` and then `enable`
    /// are called; the firmware reads this once per PWM period with the sample and latches an
    /// over-current fault. Default: a board without such a protection, never tripped.
    fn take_hardware_trip(&mut self) -> bool {
        false
    }
}

/// One sample of the phase currents, in amperes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PhaseCurrents {
    /// Phase a.
    pub a: f32,
    /// Phase b.
    pub b: f32,
    /// Phase c.
    pub c: f32,
}

/// Phase-current sensing, sampled once per PWM period at the centre of the low-side conduction
/// (centre-aligned PWM: the counter's turning point at the update event, where the ripple
/// current crosses its average).
pub trait CurrentSense {
    /// The latest sample, in amperes, as measured (sensor offsets not removed).
    fn phase_currents(&mut self) -> PhaseCurrents;
}

/// DC-bus voltage and power-stage temperature, sampled with the phase currents.
pub trait BusSense {
    /// DC-bus voltage in volts.
    fn bus_voltage(&mut self) -> f32;
    /// Power-stage temperature in °C.
    fn temperature(&mut self) -> f32;
}
