//! Digital inputs and status LEDs.

/// Digital inputs of the drive (active = true).
pub trait DigitalInputs {
    /// Positive limit switch.
    fn positive_limit(&mut self) -> bool;
    /// Negative limit switch.
    fn negative_limit(&mut self) -> bool;
    /// Home switch.
    fn home_switch(&mut self) -> bool;
}

/// The EtherCAT RUN and ERR LEDs (ETG.1300). The firmware computes the blink pattern; the board
/// only switches the LEDs.
pub trait StatusLeds {
    /// Switches the green RUN LED.
    fn set_run(&mut self, on: bool);
    /// Switches the red ERR LED.
    fn set_err(&mut self, on: bool);
}
