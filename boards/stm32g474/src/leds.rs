//! The EtherCAT RUN (green) and ERR (red) LEDs as [`hal::io::StatusLeds`]. The blink patterns
//! (ETG.1300) are computed by the firmware; the board only switches the outputs.

use embassy_stm32::gpio::{Level, Output, Speed};
use hal::io::StatusLeds;

use crate::pins::LedPins;

/// Both LEDs, active high (LED to GND).
pub struct Leds {
    run: Output<'static>,
    err: Output<'static>,
}

impl Leds {
    /// Configures both outputs, LEDs off.
    pub fn new(pins: LedPins) -> Self {
        Self {
            run: Output::new(pins.run, Level::Low, Speed::Low),
            err: Output::new(pins.err, Level::Low, Speed::Low),
        }
    }
}

impl StatusLeds for Leds {
    fn set_run(&mut self, on: bool) {
        self.run.set_level(Level::from(on));
    }
    fn set_err(&mut self, on: bool) {
        self.err.set_level(Level::from(on));
    }
}
