//! The board's digital inputs ([`hal::io::DigitalInputs`]) and its holding-brake output
//! ([`hal::io::DigitalOutputs`]).
//!
//! Every input line is one bit of [`InputPins::levels`]; whether a line is active high or
//! active low is board wiring, stated once in an [`InputPolarity`]. Inputs of safety functions
//! (limit switches, safe torque off) are wired so that a broken wire reads as the safe state:
//! normally-closed contacts, active (open) when the pin reads low.

use cia402::outputs::BRAKE as BRAKE_APPLIED;
use hal::io::{DigitalInputs, DigitalOutputs, ProbeCapture, TouchProbe};

use crate::regs::{InputPins, OutputPins};

/// The input lines, as bit numbers of [`InputPins::levels`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum InputLine {
    /// Positive limit switch.
    PositiveLimit = 0,
    /// Negative limit switch.
    NegativeLimit = 1,
    /// Home switch.
    Home = 2,
    /// The motor's thermal switch.
    MotorOverTemperature = 3,
    /// Touch-probe input 1.
    Probe1 = 4,
    /// Touch-probe input 2.
    Probe2 = 5,
    /// Safe-torque-off channel 1 (high = closed, torque allowed).
    SafeTorqueOff1 = 6,
    /// Safe-torque-off channel 2.
    SafeTorqueOff2 = 7,
}

impl InputLine {
    /// The line's bit in [`InputPins::levels`].
    pub const fn mask(self) -> u32 {
        1 << self as u8
    }
}

/// Which lines are active when their pin reads low (bit set, as [`InputLine::mask`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct InputPolarity {
    /// Lines active low.
    pub active_low: u32,
}

/// The inputs on `pins`.
pub struct BoardInputs<P> {
    pins: P,
    polarity: InputPolarity,
    /// Active lines at the last `latch`.
    active: u32,
}

impl<P: InputPins> BoardInputs<P> {
    /// The inputs on `pins` with `polarity`, all inactive until the first [`Self::latch`].
    pub fn new(pins: P, polarity: InputPolarity) -> Self {
        Self {
            pins,
            polarity,
            active: 0,
        }
    }

    /// Reads every line once, at the sample (what the trait methods then return).
    pub fn latch(&mut self) {
        self.active = self.pins.levels() ^ self.polarity.active_low;
    }

    /// Whether `line` was active at the last latch.
    pub fn is_active(&self, line: InputLine) -> bool {
        self.active & line.mask() != 0
    }
}

impl<P: InputPins> DigitalInputs for BoardInputs<P> {
    fn positive_limit(&mut self) -> bool {
        self.is_active(InputLine::PositiveLimit)
    }

    fn negative_limit(&mut self) -> bool {
        self.is_active(InputLine::NegativeLimit)
    }

    fn home_switch(&mut self) -> bool {
        self.is_active(InputLine::Home)
    }

    fn motor_over_temperature(&mut self) -> bool {
        self.is_active(InputLine::MotorOverTemperature)
    }

    /// The level at the sample. The edge time needs the probe's timer capture, which this board
    /// does not wire yet: edges are reported without a time (`None`), as a level change only.
    fn touch_probe(&mut self, probe: TouchProbe) -> ProbeCapture {
        let line = match probe {
            TouchProbe::One => InputLine::Probe1,
            TouchProbe::Two => InputLine::Probe2,
        };
        ProbeCapture {
            active: self.is_active(line),
            edge_ns_before_position: None,
        }
    }

    fn safe_torque_off_channels(&mut self) -> [bool; 2] {
        [
            self.is_active(InputLine::SafeTorqueOff1),
            self.is_active(InputLine::SafeTorqueOff2),
        ]
    }
}

/// The holding-brake output on `pins`.
pub struct BrakeOutput<P> {
    pins: P,
}

impl<P: OutputPins> BrakeOutput<P> {
    /// The output on `pins`, brake applied (coil off) until the first [`DigitalOutputs::set_outputs`].
    pub fn new(mut pins: P) -> Self {
        pins.set_brake_released(false);
        Self { pins }
    }
}

impl<P> BrakeOutput<P> {
    /// The output pins.
    pub fn pins(&self) -> &P {
        &self.pins
    }
}

impl<P: OutputPins> DigitalOutputs for BrakeOutput<P> {
    fn set_outputs(&mut self, levels: u32) {
        self.pins.set_brake_released(levels & BRAKE_APPLIED == 0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Pins(u32);

    impl InputPins for Pins {
        fn levels(&self) -> u32 {
            self.0
        }
    }

    /// Limits and STO normally closed (active = open = low); the rest active high.
    const POLARITY: InputPolarity = InputPolarity {
        active_low: InputLine::PositiveLimit.mask() | InputLine::NegativeLimit.mask(),
    };

    #[test]
    fn levels_are_read_once_per_sample_with_the_board_polarity() {
        // Both limit contacts closed (pins high), home high, STO channels high (closed).
        let closed = InputLine::PositiveLimit.mask()
            | InputLine::NegativeLimit.mask()
            | InputLine::Home.mask()
            | InputLine::SafeTorqueOff1.mask()
            | InputLine::SafeTorqueOff2.mask();
        let mut inputs = BoardInputs::new(Pins(closed), POLARITY);
        // Nothing read before the first latch.
        assert!(!inputs.home_switch());
        inputs.latch();
        assert!(!inputs.positive_limit() && !inputs.negative_limit());
        assert!(inputs.home_switch());
        assert_eq!(inputs.safe_torque_off_channels(), [true, true]);
        assert!(!inputs.motor_over_temperature());
        // A broken wire on the positive limit and on STO channel 2 reads as their safe state.
        inputs.pins.0 =
            closed & !InputLine::PositiveLimit.mask() & !InputLine::SafeTorqueOff2.mask();
        assert!(!inputs.positive_limit(), "only after the next latch");
        inputs.latch();
        assert!(inputs.positive_limit());
        assert_eq!(inputs.safe_torque_off_channels(), [true, false]);
        inputs.pins.0 |= InputLine::Probe2.mask();
        inputs.latch();
        assert_eq!(
            inputs.touch_probe(TouchProbe::Two),
            ProbeCapture {
                active: true,
                edge_ns_before_position: None
            }
        );
        assert!(!inputs.touch_probe(TouchProbe::One).active);
    }

    struct Brake(Option<bool>);

    impl OutputPins for Brake {
        fn set_brake_released(&mut self, released: bool) {
            self.0 = Some(released);
        }
    }

    #[test]
    fn the_brake_follows_bit_0_of_60fe() {
        let mut brake = BrakeOutput::new(Brake(None));
        assert_eq!(brake.pins.0, Some(false), "applied from the start");
        brake.set_outputs(0);
        assert_eq!(brake.pins.0, Some(true));
        brake.set_outputs(BRAKE_APPLIED | 0xFFFF_0000);
        assert_eq!(brake.pins.0, Some(false));
    }
}
