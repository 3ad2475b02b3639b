//! The simulated RUN/ERR LEDs (`hal::io::StatusLeds`): they record their state and every change,
//! so tests can check the ETG.1300 patterns the firmware drives.

use hal::io::StatusLeds;

/// One LED: its state and when it last changed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Led {
    /// Lit.
    pub on: bool,
    /// Number of changes so far.
    pub toggles: u64,
}

impl Led {
    fn set(&mut self, on: bool) {
        if on != self.on {
            self.on = on;
            self.toggles += 1;
        }
    }
}

/// The board's RUN (green) and ERR (red) LEDs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SimLeds {
    /// RUN LED.
    pub run: Led,
    /// ERR LED.
    pub err: Led,
}

impl StatusLeds for SimLeds {
    fn set_run(&mut self, on: bool) {
        self.run.set(on);
    }
    fn set_err(&mut self, on: bool) {
        self.err.set(on);
    }
}
