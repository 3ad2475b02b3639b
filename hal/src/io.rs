//! Digital inputs and outputs, and status LEDs.

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
    /// Touch-probe input `probe` as captured in the last PWM period.
    fn touch_probe(&mut self, probe: TouchProbe) -> ProbeCapture;
    /// The two channels of the safe-torque-off input (IEC 61800-5-2 STO, e.g. the Σ-V-SD's
    /// HWBB1/HWBB2), `true` = channel closed (torque allowed). The hardware cuts the gate drive
    /// on its own when a channel opens; the firmware reads the levels to follow it (disable,
    /// report). Default: a board without the input, both channels closed.
    fn safe_torque_off_channels(&mut self) -> [bool; 2] {
        [true; 2]
    }
    /// The drive's enable input, `true` = operation permitted: a functional, single-channel
    /// permission from the machine (a PLC output, a door switch), not a safety function. While
    /// it is withheld the firmware keeps the power stage off; it never restarts the motor by
    /// itself when the permission returns. Default: a board without the input, always
    /// permitted.
    fn enable_input(&mut self) -> bool {
        true
    }
}

/// The two touch-probe inputs (CiA402 60B8h probe 1 and 2).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum TouchProbe {
    /// Probe 1.
    One,
    /// Probe 2.
    Two,
}

/// A touch-probe input as the board captured it in one PWM period.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ProbeCapture {
    /// The input level at the sample.
    pub active: bool,
    /// When the input last changed since the previous sample, ns before the instant at which
    /// this sample's encoder position was taken (negative: after it); from a timer input
    /// capture or the ET1100 latch unit. `None`: no edge. Of two edges in one period only the
    /// last is reported (the inputs' minimum pulse width exceeds a PWM period).
    pub edge_ns_before_position: Option<i32>,
}

/// Digital outputs of the drive, in the bit layout of CiA402 60FEh:01: bit 0 the holding brake
/// (1 = brake applied), bits 16–31 the board's general outputs (DO1 = bit 16); a board drives
/// the bits it has pins for and ignores the others.
pub trait DigitalOutputs {
    /// Sets every output to its level in `levels` (1 = on).
    fn set_outputs(&mut self, levels: u32);
}

/// The EtherCAT RUN and ERR LEDs (ETG.1300). The firmware computes the blink pattern; the board
/// only switches the LEDs.
pub trait StatusLeds {
    /// Switches the green RUN LED.
    fn set_run(&mut self, on: bool);
    /// Switches the red ERR LED.
    fn set_err(&mut self, on: bool);
}
