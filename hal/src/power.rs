//! Power stage: inverter PWM, phase-current and DC-bus voltage sensing.
//!
//! # For firmware
//! Duty cycles are fractions 0.0..=1.0 of the PWM period per phase (centre-aligned). Currents are
//! in amperes, voltages in volts, as `f32` (the FOC math runs on the FPU).
//!
//! # For boards
//! `set_duties` takes effect at the next PWM period; `disable` turns all gates off at once and
//! MUST be callable from the highest-priority interrupt (over-current trip).

/// Three-phase inverter.
pub trait Inverter {
    /// PWM frequency in Hz.
    fn pwm_frequency_hz(&self) -> u32;
    /// Sets the duty cycles of phases a, b, c (0.0..=1.0), applied at the next period.
    fn set_duties(&mut self, a: f32, b: f32, c: f32);
    /// Enables the gate drivers.
    fn enable(&mut self);
    /// Disables all gates (outputs floating). Immediate.
    fn disable(&mut self);
    /// Whether the gates are enabled.
    fn is_enabled(&self) -> bool;
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

/// Phase-current sensing, sampled in the middle of the PWM period.
pub trait CurrentSense {
    /// The latest sample.
    fn phase_currents(&mut self) -> PhaseCurrents;
}

/// DC-bus voltage and power-stage temperature.
pub trait BusSense {
    /// DC-bus voltage in volts.
    fn bus_voltage(&mut self) -> f32;
    /// Power-stage temperature in °C.
    fn temperature(&mut self) -> f32;
}
