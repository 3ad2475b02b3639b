//! One cycle of the CiA402 device behind controlword and statusword: the PDS state machine
//! ([`crate::pds`]) with edge detection, the active fault (603Fh) and its reset.
//!
//! Works on values, not on objects: the drive application reads 6040h and writes 6041h/603Fh.

use crate::pds::{self, PdsState};

/// State of the CiA402 device.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Device {
    state: PdsState,
    previous_controlword: u16,
    fault: Option<u16>,
}

/// The result of one [`Device::step`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Step {
    /// The statusword (6041h) of the new state.
    pub statusword: u16,
    /// The fault with this error code was reset in this step (603Fh goes to 0).
    pub fault_cleared: Option<u16>,
}

impl Default for Device {
    fn default() -> Self {
        Self::new()
    }
}

impl Device {
    /// Power-on: Not Ready to Switch On, no fault.
    pub const fn new() -> Self {
        Self {
            state: PdsState::NotReadyToSwitchOn,
            previous_controlword: 0,
            fault: None,
        }
    }

    /// The PDS state.
    pub fn state(&self) -> PdsState {
        self.state
    }

    /// The drive's initialisation is done (CiA402 transition 1, automatic: Not Ready to Switch
    /// On → Switch On Disabled); returns the statusword. Does nothing in any other state.
    pub fn initialised(&mut self) -> u16 {
        if self.state == PdsState::NotReadyToSwitchOn {
            self.state = PdsState::SwitchOnDisabled;
        }
        pds::statusword_of(self.state)
    }

    /// The error code of the active fault (603Fh), `None` when there is none.
    pub fn fault_code(&self) -> Option<u16> {
        self.fault
    }

    /// Whether the drive is in Operation Enabled (the axis may run).
    pub fn operation_enabled(&self) -> bool {
        self.state == PdsState::OperationEnabled
    }

    /// One cycle with controlword `cw` (6040h).
    pub fn step(&mut self, cw: u16) -> Step {
        self.state = pds::next(self.state, cw, self.previous_controlword);
        self.previous_controlword = cw;
        let fault_cleared = match self.fault {
            Some(code) if self.state != PdsState::Fault => {
                self.fault = None;
                Some(code)
            }
            _ => None,
        };
        Step {
            statusword: pds::statusword_of(self.state),
            fault_cleared,
        }
    }

    /// Raises fault `code`: Fault Reaction Active, completed at once into Fault (the reaction
    /// disables the drive; with no motion to stop there is nothing to wait for). The controlword
    /// counts as 0 from here, so that a fault reset needs a new rising edge of bit 7. Returns the
    /// statusword.
    pub fn fault(&mut self, code: u16) -> u16 {
        self.previous_controlword = 0;
        self.state = pds::next(pds::fault(self.state), 0, 0);
        self.fault = Some(code);
        pds::statusword_of(self.state)
    }

    /// The master's outputs are gone (EtherCAT left OP): the controlword counts as 0 (disable
    /// voltage). Returns the statusword.
    pub fn outputs_lost(&mut self) -> u16 {
        self.state = pds::next(self.state, 0, self.previous_controlword);
        self.previous_controlword = 0;
        pds::statusword_of(self.state)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pds::{controlword as cw, statusword as sw};

    fn enabled() -> Device {
        let mut d = Device::new();
        for c in [0, cw::ENABLE_VOLTAGE | cw::QUICK_STOP, 0x07, 0x0F] {
            d.step(c);
        }
        assert!(d.operation_enabled());
        d
    }

    #[test]
    fn fault_holds_until_a_rising_edge_of_fault_reset() {
        let mut d = enabled();
        let status = d.fault(0x8700);
        assert_eq!(d.state(), PdsState::Fault);
        assert_ne!(status & sw::FAULT, 0);
        assert_eq!(d.fault_code(), Some(0x8700));
        assert_eq!(
            d.step(0x0F).fault_cleared,
            None,
            "enable is ignored in Fault"
        );
        let step = d.step(cw::FAULT_RESET);
        assert_eq!(step.fault_cleared, Some(0x8700));
        assert_eq!(d.state(), PdsState::SwitchOnDisabled);
        assert_eq!(d.fault_code(), None);
        assert_eq!(step.statusword & sw::FAULT, 0);
    }

    #[test]
    fn fault_reset_held_high_through_the_fault_does_not_reset() {
        let mut d = enabled();
        d.step(cw::FAULT_RESET | 0x0F);
        d.fault(0x2320);
        // Bit 7 was high before the fault; the fault counts the controlword as 0, so the next
        // cycle with bit 7 high is a rising edge.
        assert_eq!(d.step(cw::FAULT_RESET).fault_cleared, Some(0x2320));
    }

    #[test]
    fn lost_outputs_disable_the_drive() {
        let mut d = enabled();
        let status = d.outputs_lost();
        assert_eq!(d.state(), PdsState::SwitchOnDisabled);
        assert_ne!(status & sw::SWITCH_ON_DISABLED, 0);
    }
}
