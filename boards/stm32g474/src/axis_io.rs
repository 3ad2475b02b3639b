//! The axis' digital inputs and outputs on GPIOs: switches, thermal switch, touch probes, the
//! two safe-torque-off channels, the enable input (the [`stm32g4_axis::regs::InputPins`] implementation
//! [`GpioInputs`]), the holding brake ([`BrakePin`]) and the gate driver's enable.
//!
//! Polarity ([`POLARITY`]): the limit switches are normally-closed contacts to 3.3 V with a
//! pull-down, active (open) when low, so a broken wire stops the axis; the STO channels read
//! high when closed (torque allowed) and low when open or broken, and so does the enable input
//! (high = operation permitted, pull-down: a broken wire withholds it); home, probes and the
//! motor's thermal switch are active high.

use embassy_stm32::gpio::{AfType, Flex, Level, Output, Pin, Pull, Speed};
use embassy_stm32::peripherals::TIM3;
use embassy_stm32::timer::{Ch2, Ch3, TimerPin};
use embassy_stm32::Peri;
use stm32g4_axis::inputs::{InputLine, InputPolarity};
use stm32g4_axis::regs::{InputPins, OutputPins};

use crate::pins::alternate;

/// Which lines are active low.
pub const POLARITY: InputPolarity = InputPolarity {
    active_low: InputLine::PositiveLimit.mask() | InputLine::NegativeLimit.mask(),
};

/// The input pins, in [`InputLine`] order.
pub struct InputPinSet<L1: Pin, L2: Pin, H: Pin, T: Pin, P1: Pin, P2: Pin, S1: Pin, S2: Pin, E: Pin>
{
    /// Positive limit switch.
    pub positive_limit: Peri<'static, L1>,
    /// Negative limit switch.
    pub negative_limit: Peri<'static, L2>,
    /// Home switch.
    pub home: Peri<'static, H>,
    /// The motor's thermal switch.
    pub motor_over_temperature: Peri<'static, T>,
    /// Touch probe 1.
    pub probe1: Peri<'static, P1>,
    /// Touch probe 2.
    pub probe2: Peri<'static, P2>,
    /// Safe-torque-off channel 1.
    pub safe_torque_off1: Peri<'static, S1>,
    /// Safe-torque-off channel 2.
    pub safe_torque_off2: Peri<'static, S2>,
    /// The enable input.
    pub enable: Peri<'static, E>,
}

/// The inputs, each with the pull that makes an open wire read inactive-safe. The probe pins
/// are in their TIM3 alternate function (the edges are captured, `sync_capture`); their levels
/// are read from the port like the others.
pub struct GpioInputs {
    lines: [(InputLine, Flex<'static>); 9],
}

/// A pin as an input with `pull`.
fn input(pin: Peri<'static, impl Pin>, pull: Pull) -> Flex<'static> {
    let mut flex = Flex::new(pin);
    flex.set_as_input(pull);
    flex
}

/// A pin in its TIM3 capture function `af`, pulled down.
fn capture_input(pin: Peri<'static, impl Pin>, af: u8) -> Flex<'static> {
    alternate(pin, af, AfType::input(Pull::Down))
}

impl GpioInputs {
    /// Configures the input pins.
    pub fn new<L1, L2, H, T, P1, P2, S1, S2, E>(
        pins: InputPinSet<L1, L2, H, T, P1, P2, S1, S2, E>,
    ) -> Self
    where
        L1: Pin,
        L2: Pin,
        H: Pin,
        T: Pin,
        P1: TimerPin<TIM3, Ch3>,
        P2: TimerPin<TIM3, Ch2>,
        S1: Pin,
        S2: Pin,
        E: Pin,
    {
        let (probe1_af, probe2_af) = (pins.probe1.af_num(), pins.probe2.af_num());
        Self {
            lines: [
                (
                    InputLine::PositiveLimit,
                    input(pins.positive_limit, Pull::Down),
                ),
                (
                    InputLine::NegativeLimit,
                    input(pins.negative_limit, Pull::Down),
                ),
                (InputLine::Home, input(pins.home, Pull::Down)),
                // The thermal switch closes to ground while cool: open (pulled up) = too hot.
                (
                    InputLine::MotorOverTemperature,
                    input(pins.motor_over_temperature, Pull::Up),
                ),
                (InputLine::Probe1, capture_input(pins.probe1, probe1_af)),
                (InputLine::Probe2, capture_input(pins.probe2, probe2_af)),
                (
                    InputLine::SafeTorqueOff1,
                    input(pins.safe_torque_off1, Pull::Down),
                ),
                (
                    InputLine::SafeTorqueOff2,
                    input(pins.safe_torque_off2, Pull::Down),
                ),
                (InputLine::Enable, input(pins.enable, Pull::Down)),
            ],
        }
    }
}

impl InputPins for GpioInputs {
    #[inline]
    fn levels(&self) -> u32 {
        self.lines
            .iter()
            .filter(|(_, pin)| pin.is_high())
            .fold(0, |levels, (line, _)| levels | line.mask())
    }
}

/// The holding-brake driver's input: high = coil energised = brake released.
pub struct BrakePin(Output<'static>);

impl BrakePin {
    /// The brake output, applied (low) from now on.
    pub fn new(pin: Peri<'static, impl Pin>) -> Self {
        Self(Output::new(pin, Level::Low, Speed::Low))
    }
}

impl OutputPins for BrakePin {
    fn set_brake_released(&mut self, released: bool) {
        self.0.set_level(Level::from(released));
    }
}

/// The gate driver's enable input (high = driver awake). The driver's outputs follow TIM1's,
/// which are off while MOE is cleared; it is enabled once after TIM1 is configured and stays
/// so (its own faults report on BKIN).
pub struct GateDriverEnable(Output<'static>);

impl GateDriverEnable {
    /// The enable pin, driver off (low).
    pub fn new(pin: Peri<'static, impl Pin>) -> Self {
        Self(Output::new(pin, Level::Low, Speed::Low))
    }

    /// Wakes the driver.
    pub fn enable(&mut self) {
        self.0.set_high();
    }
}
