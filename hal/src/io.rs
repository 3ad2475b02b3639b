//! Digital inputs and status LEDs.

/// Digital inputs of the drive (active = true), as latched at the last PWM-synchronous sample.
///
/// `motor_over_temperature` was added to the first version (limit and home switches only):
/// the motor's thermal switch (PTC/bimetal in the winding) is a digital input of every servo
/// board too, and the one the motor control consumes each PWM period
/// (`motor_control::axis::Sample::motor_overtemp` → `MotorFault::MotorOverTemperature`), so
/// it belongs with the other inputs rather than in a trait of its own.
pub trait DigitalInputs {
    /// Positive limit switch.
    fn positive_limit(&mut self) -> bool;
    /// Negative limit switch.
    fn negative_limit(&mut self) -> bool;
    /// Home switch.
    fn home_switch(&mut self) -> bool;
    /// The motor's over-temperature input (thermal switch).
    fn motor_over_temperature(&mut self) -> bool;
}

/// The EtherCAT RUN and ERR LEDs (ETG.1300). The firmware computes the blink pattern; the board
/// only switches the LEDs.
pub trait StatusLeds {
    /// Switches the green RUN LED.
    fn set_run(&mut self, on: bool);
    /// Switches the red ERR LED.
    fn set_err(&mut self, on: bool);
}
