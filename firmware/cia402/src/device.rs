//! One cycle of the CiA402 device behind controlword and statusword: the PDS state machine
//! ([`crate::pds`]) with edge detection, the stop reactions of the option codes
//! ([`crate::stop`]) that make some transitions wait for the motor to come to rest, the active
//! fault (603Fh) and its reset.
//!
//! Works on values, not on objects: the drive application reads 6040h and 605Ah–605Eh, tells
//! whether the motor is at rest, writes 6041h/603Fh and moves the axis as [`Motion`] says.
//!
//! | transition | what waits for rest |
//! |---|---|
//! | 5 disable operation, 8 shutdown (Operation Enabled) | with a ramp in 605Ch / 605Bh the state stays Operation Enabled while the motor decelerates, then changes |
//! | 11 → 12 quick stop | Quick Stop Active while the motor decelerates per 605Ah; then Switch On Disabled (codes 0–4) or holding at rest (5–8, left by enable operation: 16, or disable voltage) |
//! | 13 → 14 fault | Fault Reaction Active while the motor decelerates per 605Eh; then Fault |
//! | halt (bit 8) | Operation Enabled, decelerating per 605Dh and holding at rest while bit 8 is set |
//!
//! Disable voltage (transition 9) and a coast reaction disable the drive function at once.

use crate::pds::{self, controlword, PdsState};
use crate::stop::{After, Cause, Deceleration, Reaction, Reactions};

/// What the axis does this cycle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Motion {
    /// The mode's set-point (Operation Enabled, running).
    Run,
    /// Decelerate to rest with this deceleration, then hold at rest (powered).
    Stop(Deceleration),
    /// The drive function is disabled: power stage off, the motor coasts.
    Off,
}

/// State of the CiA402 device.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Device {
    state: PdsState,
    previous_controlword: u16,
    fault: Option<u16>,
    /// The active fault stays until power-off: a fault reset does not clear it (a profile's
    /// alarm that is not resettable).
    fault_permanent: bool,
    /// The stop under way (Operation Enabled waiting for transition 5 or 8, Quick Stop Active,
    /// Fault Reaction Active) and the state Operation Enabled leaves to at rest.
    stop: Option<Reaction>,
    leave_to: Option<PdsState>,
    /// The option codes of the last cycle (a fault raised between cycles reacts with them).
    reactions: Reactions,
    /// The profile's rules.
    rules: DeviceRules,
    /// The main circuit is powered (the drive application tells, [`Self::set_main_power`]).
    main_power: bool,
    /// Operation Enabled is refused until the next power-on ([`Self::require_power_cycle`]).
    power_cycle_required: bool,
    /// Safe torque off holds ([`Self::set_safe_torque_off`]).
    safe_torque_off: bool,
    /// The cause of the fault is still there ([`Self::set_fault_cause_present`]).
    fault_cause_present: bool,
}

/// CiA402 behaviour a profile adds to the standard.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DeviceRules {
    /// Shutdown and disable operation end in Switch On Disabled after their stop (the
    /// Σ-V-SD's 605Bh/605Ch texts) instead of Ready to Switch On / Switched On.
    pub stops_end_switched_off: bool,
    /// Switched On needs the main power: transition 3 waits for it, and Switched On,
    /// Operation Enabled and Quick Stop Active fall to Switch On Disabled when it goes (the
    /// Σ-V-SD, §4.7 *2-*4).
    pub switch_on_requires_main_power: bool,
}

/// The result of one [`Device::step`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Step {
    /// The statusword (6041h) of the new state.
    pub statusword: u16,
    /// The fault with this error code was reset in this step (603Fh goes to 0).
    pub fault_cleared: Option<u16>,
    /// What the axis does.
    pub motion: Motion,
    /// The stop under way is a halt (controlword bit 8 in Operation Enabled, 605Dh).
    pub halted: bool,
}

impl Default for Device {
    fn default() -> Self {
        Self::new()
    }
}

impl Device {
    /// Power-on: Not Ready to Switch On, no fault, CiA402 as written.
    pub const fn new() -> Self {
        Self::with_rules(DeviceRules {
            stops_end_switched_off: false,
            switch_on_requires_main_power: false,
        })
    }

    /// [`Self::new`] with a profile's rules.
    pub const fn with_rules(rules: DeviceRules) -> Self {
        Self {
            state: PdsState::NotReadyToSwitchOn,
            previous_controlword: 0,
            fault: None,
            fault_permanent: false,
            stop: None,
            leave_to: None,
            reactions: Reactions::NONE,
            rules,
            main_power: false,
            power_cycle_required: false,
            safe_torque_off: false,
            fault_cause_present: false,
        }
    }

    /// Whether safe torque off holds (a channel of the STO input is open: the power stage
    /// cannot drive the motor). While it does, Switched On, Operation Enabled and Quick Stop
    /// Active leave to Switch On Disabled at once, the motor coasting (the Σ-V-SD §3.1 *1, *2,
    /// *4 "HWBB signal was inputted"; for the other profiles the same: a drive whose power
    /// stage is cut is not enabled). Ready to Switch On → Switched On is not refused (*3 does
    /// not name HWBB), but Switched On then falls back in the next cycle.
    pub fn set_safe_torque_off(&mut self, active: bool) {
        self.safe_torque_off = active;
    }

    /// From now until the next power-on (a new `Device`), Operation Enabled is not entered:
    /// a request for it leaves the drive in Switched On (the Σ-V-SD after storing parameters
    /// with 1010h:01/:04, §4.7: "a power-on reset is required before the drive can enter
    /// Operation Enabled").
    pub fn require_power_cycle(&mut self) {
        self.power_cycle_required = true;
    }

    /// Whether the main circuit is powered (the bus voltage is up): statusword bit 4 "voltage
    /// enabled" and, with [`DeviceRules::switch_on_requires_main_power`], transition 3.
    pub fn set_main_power(&mut self, on: bool) {
        self.main_power = on;
    }

    /// Whether the cause of the active fault is still there (a temperature still over its
    /// level, a bus voltage still out of range): CiA402 transition 15 resets a fault "if no
    /// fault exists currently", so a fault reset edge meanwhile is consumed without effect.
    pub fn set_fault_cause_present(&mut self, present: bool) {
        self.fault_cause_present = present;
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

    /// The state controlword `cw` asks for now (before the stop reactions), without changing
    /// anything: a profile checks its preconditions on it.
    pub fn requested(&self, cw: u16) -> PdsState {
        pds::next(self.state, cw, self.previous_controlword)
    }

    /// Whether the drive is in Operation Enabled (the axis may run).
    pub fn operation_enabled(&self) -> bool {
        self.state == PdsState::OperationEnabled
    }

    /// Whether the drive function is enabled (the power stage may be on: Operation Enabled,
    /// Quick Stop Active, Fault Reaction Active).
    pub fn drive_function_enabled(&self) -> bool {
        matches!(
            self.state,
            PdsState::OperationEnabled | PdsState::QuickStopActive | PdsState::FaultReactionActive
        )
    }

    /// One cycle with controlword `cw` (6040h), the reactions of the option codes and whether the
    /// motor is at rest (`at_rest`: the previous cycle's stop has ended and the velocity is
    /// below the standstill threshold).
    pub fn step(&mut self, cw: u16, reactions: Reactions, at_rest: bool) -> Step {
        self.reactions = reactions;
        let mut requested = pds::next(self.state, cw, self.previous_controlword);
        if self.state == PdsState::Fault && (self.fault_permanent || self.fault_cause_present) {
            // Not resettable (only a power cycle leaves Fault), or not yet (the cause is still
            // there: the edge is used up, a new one is needed once it is gone).
            requested = PdsState::Fault;
        }
        if self.rules.switch_on_requires_main_power && !self.main_power {
            requested = match (self.state, requested) {
                (PdsState::ReadyToSwitchOn, PdsState::SwitchedOn) => PdsState::ReadyToSwitchOn,
                (
                    PdsState::SwitchedOn | PdsState::OperationEnabled | PdsState::QuickStopActive,
                    _,
                ) => PdsState::SwitchOnDisabled,
                (_, to) => to,
            };
        }
        if self.safe_torque_off
            && matches!(
                self.state,
                PdsState::SwitchedOn | PdsState::OperationEnabled | PdsState::QuickStopActive
            )
        {
            requested = PdsState::SwitchOnDisabled;
        }
        if self.power_cycle_required
            && requested == PdsState::OperationEnabled
            && !matches!(
                self.state,
                PdsState::OperationEnabled | PdsState::QuickStopActive
            )
        {
            // Transitions 3 and 4 in one command stop after 3.
            requested = match self.state {
                PdsState::ReadyToSwitchOn | PdsState::SwitchedOn => PdsState::SwitchedOn,
                other => other,
            };
        }
        self.previous_controlword = cw;
        self.state = match (self.state, requested) {
            // 5 / 8: stop per 605Ch / 605Bh first (a new request replaces a waiting one).
            (
                PdsState::OperationEnabled,
                to @ (PdsState::SwitchedOn | PdsState::ReadyToSwitchOn),
            ) => {
                let cause = if to == PdsState::SwitchedOn {
                    Cause::DisableOperation
                } else {
                    Cause::Shutdown
                };
                let reaction = reactions.of(cause).unwrap_or(Reaction::COAST);
                self.stop = Some(reaction);
                self.leave_to = Some(if self.rules.stops_end_switched_off {
                    PdsState::SwitchOnDisabled
                } else {
                    to
                });
                PdsState::OperationEnabled
            }
            (PdsState::OperationEnabled, PdsState::OperationEnabled) => {
                // Enable operation again cancels a waiting 5 / 8.
                if self.leave_to.is_some() && requested_enable(cw) {
                    self.stop = None;
                    self.leave_to = None;
                }
                PdsState::OperationEnabled
            }
            (PdsState::OperationEnabled, PdsState::QuickStopActive) => {
                self.leave_to = None;
                self.stop = Some(reactions.quick_stop);
                PdsState::QuickStopActive
            }
            // 16 only after a quick stop that holds the motor has brought it to rest.
            (PdsState::QuickStopActive, PdsState::OperationEnabled) => {
                if self.stop.is_some_and(|r| r.after == After::Hold) && at_rest {
                    self.stop = None;
                    PdsState::OperationEnabled
                } else {
                    PdsState::QuickStopActive
                }
            }
            (_, to) => {
                if !matches!(
                    to,
                    PdsState::QuickStopActive | PdsState::FaultReactionActive
                ) {
                    self.stop = None;
                    self.leave_to = None;
                }
                to
            }
        };
        self.complete_stops(at_rest);
        let fault_cleared = match self.fault {
            Some(code)
                if self.state != PdsState::Fault && self.state != PdsState::FaultReactionActive =>
            {
                self.fault = None;
                Some(code)
            }
            _ => None,
        };
        let motion = self.motion(cw);
        let mut statusword = pds::statusword_of(self.state);
        if self.main_power {
            statusword |= pds::statusword::VOLTAGE_ENABLED;
        }
        let halted = self.state == PdsState::OperationEnabled
            && self.stop.is_none()
            && matches!(motion, Motion::Stop(_));
        if halted && at_rest {
            // CiA402 bit 10 with halt set: the motor has stopped.
            statusword |= pds::statusword::TARGET_REACHED;
        }
        Step {
            statusword,
            fault_cleared,
            motion,
            halted,
        }
    }

    /// The automatic transitions at rest: a waiting 5 / 8, 12 and 14; at once for a coast
    /// reaction.
    fn complete_stops(&mut self, at_rest: bool) {
        let Some(reaction) = self.stop else {
            return;
        };
        let done = at_rest || reaction.deceleration == Deceleration::Coast;
        if !done {
            return;
        }
        match self.state {
            PdsState::OperationEnabled => {
                if let Some(to) = self.leave_to.take() {
                    self.state = to;
                    self.stop = None;
                }
            }
            PdsState::QuickStopActive if reaction.after == After::Disable => {
                self.state = PdsState::SwitchOnDisabled;
                self.stop = None;
            }
            PdsState::FaultReactionActive => {
                self.state = PdsState::Fault;
                self.stop = None;
            }
            _ => {}
        }
    }

    /// What the axis does in the current state.
    fn motion(&self, cw: u16) -> Motion {
        let stopping = |r: Reaction| match r.deceleration {
            Deceleration::Coast => Motion::Off,
            d => Motion::Stop(d),
        };
        match (self.state, self.stop) {
            (PdsState::OperationEnabled, Some(r)) => stopping(r),
            (PdsState::OperationEnabled, None) => {
                let halt = cw & controlword::HALT != 0;
                match self.reactions.halt {
                    Some(r) if halt => Motion::Stop(r.deceleration),
                    _ => Motion::Run,
                }
            }
            (PdsState::QuickStopActive | PdsState::FaultReactionActive, Some(r)) => stopping(r),
            _ => Motion::Off,
        }
    }

    /// Raises fault `code`: Fault Reaction Active with the fault reaction of 605Eh (the last
    /// option codes seen), completed into Fault at once for a coast reaction (then, with no
    /// motion to stop, there is nothing to wait for), else by a later [`Self::step`] when the
    /// motor has come to rest. The controlword counts as 0 from here, so that a fault reset
    /// needs a new rising edge of bit 7. Returns the statusword.
    pub fn fault(&mut self, code: u16) -> u16 {
        self.fault_with(code, true)
    }

    /// [`Self::fault`] for a fault a fault reset clears (`resettable`) or not (it holds until
    /// the drive is switched off and on, e.g. a profile's encoder alarm).
    pub fn fault_with(&mut self, code: u16, resettable: bool) -> u16 {
        self.fault_permanent = !resettable;
        self.previous_controlword = 0;
        let was_powered = self.drive_function_enabled();
        self.state = pds::fault(self.state);
        self.leave_to = None;
        self.stop = if self.state == PdsState::FaultReactionActive && was_powered {
            Some(self.reactions.fault)
        } else {
            // Nothing is moving under power: the reaction has nothing to stop.
            Some(Reaction::COAST)
        };
        self.complete_stops(false);
        self.fault = Some(code);
        pds::statusword_of(self.state)
    }

    /// The motor cannot be decelerated any more (the power stage tripped): a stop under way
    /// ends as a coast stop (Quick Stop Active and Fault Reaction Active complete at once).
    pub fn power_stage_lost(&mut self) {
        if self.stop.is_some() {
            self.stop = Some(Reaction::COAST);
            self.complete_stops(false);
        }
    }

    /// The master's outputs are gone (EtherCAT left OP): the controlword counts as 0 (disable
    /// voltage). Returns the statusword.
    pub fn outputs_lost(&mut self) -> u16 {
        self.state = pds::next(self.state, 0, self.previous_controlword);
        self.previous_controlword = 0;
        if self.state != PdsState::FaultReactionActive {
            self.stop = None;
            self.leave_to = None;
        } else {
            self.power_stage_lost();
        }
        pds::statusword_of(self.state)
    }
}

/// Whether `cw` is the enable operation command (bits 0–3 set, no fault reset).
fn requested_enable(cw: u16) -> bool {
    use controlword::*;
    let bits = SWITCH_ON | ENABLE_VOLTAGE | QUICK_STOP | ENABLE_OPERATION;
    cw & bits == bits && cw & FAULT_RESET == 0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pds::{controlword as cw, statusword as sw};
    use crate::stop::OptionCodes;

    /// The standard profile's codes: 605Ah 2, 605Bh 1, 605Ch 1, 605Dh 1, 605Eh 2.
    const RAMPS: OptionCodes = OptionCodes {
        quick_stop: Some(2),
        shutdown: Some(1),
        disable_operation: Some(1),
        halt: Some(1),
        fault_reaction: Some(2),
        vendor: &[],
    };
    const NO_OBJECTS: OptionCodes = OptionCodes {
        quick_stop: None,
        shutdown: None,
        disable_operation: None,
        halt: None,
        fault_reaction: None,
        vendor: &[],
    };
    const ENABLE: u16 = 0x0F;
    const QUICK_STOP: u16 = 0x02;

    fn enabled(options: OptionCodes) -> Device {
        let mut d = Device::new();
        for c in [0, cw::ENABLE_VOLTAGE | cw::QUICK_STOP, 0x07, ENABLE] {
            d.step(c, options.into(), true);
        }
        assert!(d.operation_enabled());
        d
    }

    #[test]
    fn fault_holds_until_a_rising_edge_of_fault_reset() {
        let mut d = enabled(NO_OBJECTS);
        let status = d.fault(0x8700);
        assert_eq!(d.state(), PdsState::Fault, "coast reaction: at once");
        assert_ne!(status & sw::FAULT, 0);
        assert_eq!(d.fault_code(), Some(0x8700));
        assert_eq!(
            d.step(ENABLE, NO_OBJECTS.into(), true).fault_cleared,
            None,
            "enable is ignored in Fault"
        );
        let step = d.step(cw::FAULT_RESET, NO_OBJECTS.into(), true);
        assert_eq!(step.fault_cleared, Some(0x8700));
        assert_eq!(d.state(), PdsState::SwitchOnDisabled);
        assert_eq!(d.fault_code(), None);
        assert_eq!(step.statusword & sw::FAULT, 0);
    }

    #[test]
    fn a_fault_that_is_not_resettable_holds_through_fault_resets() {
        // A profile's alarm that needs a power cycle (e.g. the SDV3-E's encoder alarms):
        // rising edges of bit 7 leave the drive in Fault with its code.
        let mut d = enabled(NO_OBJECTS);
        d.fault_with(0x7305, false);
        for cw in [cw::FAULT_RESET, 0, cw::FAULT_RESET, 0] {
            let step = d.step(cw, NO_OBJECTS.into(), true);
            assert_eq!(step.fault_cleared, None);
            assert_eq!(d.state(), PdsState::Fault);
            assert_ne!(step.statusword & sw::FAULT, 0);
        }
        assert_eq!(d.fault_code(), Some(0x7305));
    }

    #[test]
    fn a_fault_reset_while_the_cause_is_there_is_used_up() {
        let mut d = Device::new();
        d.initialised();
        d.fault(0x4210);
        d.set_fault_cause_present(true);
        let step = d.step(cw::FAULT_RESET, NO_OBJECTS.into(), true);
        assert_eq!(d.state(), PdsState::Fault, "{:#06x}", step.statusword);
        // The cause goes while bit 7 is still high: no new edge, no reset.
        d.set_fault_cause_present(false);
        d.step(cw::FAULT_RESET, NO_OBJECTS.into(), true);
        assert_eq!(d.state(), PdsState::Fault);
        d.step(0, NO_OBJECTS.into(), true);
        d.step(cw::FAULT_RESET, NO_OBJECTS.into(), true);
        assert_eq!(d.state(), PdsState::SwitchOnDisabled);
    }

    #[test]
    fn fault_reset_held_high_through_the_fault_does_not_reset() {
        let mut d = enabled(NO_OBJECTS);
        d.step(cw::FAULT_RESET | ENABLE, NO_OBJECTS.into(), true);
        d.fault(0x2320);
        // Bit 7 was high before the fault; the fault counts the controlword as 0, so the next
        // cycle with bit 7 high is a rising edge.
        assert_eq!(
            d.step(cw::FAULT_RESET, NO_OBJECTS.into(), true)
                .fault_cleared,
            Some(0x2320)
        );
    }

    #[test]
    fn lost_outputs_disable_the_drive() {
        let mut d = enabled(RAMPS);
        let status = d.outputs_lost();
        assert_eq!(d.state(), PdsState::SwitchOnDisabled);
        assert_ne!(status & sw::SWITCH_ON_DISABLED, 0);
    }

    #[test]
    fn quick_stop_on_the_ramp_stays_in_quick_stop_active_until_rest_then_disables() {
        let mut d = enabled(RAMPS);
        let step = d.step(QUICK_STOP, RAMPS.into(), false);
        assert_eq!(d.state(), PdsState::QuickStopActive);
        assert_eq!(
            step.statusword & 0x6F,
            0x07,
            "CiA402 Table 30: quick stop active"
        );
        assert_eq!(step.motion, Motion::Stop(Deceleration::QuickStopRamp));
        // Still moving: stays, whatever the controlword says but disable voltage.
        for c in [QUICK_STOP, ENABLE, 0x06] {
            assert_eq!(
                d.step(c, RAMPS.into(), false).motion,
                Motion::Stop(Deceleration::QuickStopRamp)
            );
            assert_eq!(d.state(), PdsState::QuickStopActive);
        }
        // At rest: transition 12 (605Ah = 2).
        let step = d.step(QUICK_STOP, RAMPS.into(), true);
        assert_eq!(
            (d.state(), step.motion),
            (PdsState::SwitchOnDisabled, Motion::Off)
        );
    }

    #[test]
    fn quick_stop_codes_5_to_8_hold_at_rest_until_enable_operation() {
        let hold = OptionCodes {
            quick_stop: Some(6),
            ..RAMPS
        };
        let mut d = enabled(hold);
        d.step(QUICK_STOP, hold.into(), false);
        assert_eq!(
            d.step(ENABLE, hold.into(), false).motion,
            Motion::Stop(Deceleration::QuickStopRamp)
        );
        assert_eq!(d.state(), PdsState::QuickStopActive, "16 only at rest");
        let step = d.step(QUICK_STOP, hold.into(), true);
        assert_eq!(
            (d.state(), step.motion),
            (
                PdsState::QuickStopActive,
                Motion::Stop(Deceleration::QuickStopRamp)
            ),
            "holding"
        );
        let step = d.step(ENABLE, hold.into(), true);
        assert_eq!(
            (d.state(), step.motion),
            (PdsState::OperationEnabled, Motion::Run),
            "transition 16"
        );
        d.step(QUICK_STOP, hold.into(), true);
        d.step(0x00, hold.into(), true);
        assert_eq!(
            d.state(),
            PdsState::SwitchOnDisabled,
            "disable voltage leaves it (12)"
        );
    }

    #[test]
    fn quick_stop_code_0_disables_at_once() {
        let coast = OptionCodes {
            quick_stop: Some(0),
            ..RAMPS
        };
        let mut d = enabled(coast);
        let step = d.step(QUICK_STOP, coast.into(), false);
        assert_eq!(
            (d.state(), step.motion),
            (PdsState::SwitchOnDisabled, Motion::Off)
        );
    }

    #[test]
    fn shutdown_and_disable_operation_ramp_down_in_operation_enabled_first() {
        for (c, to) in [
            (0x06, PdsState::ReadyToSwitchOn),
            (0x07, PdsState::SwitchedOn),
        ] {
            let mut d = enabled(RAMPS);
            let step = d.step(c, RAMPS.into(), false);
            assert_eq!(d.state(), PdsState::OperationEnabled, "decelerating");
            assert_eq!(step.motion, Motion::Stop(Deceleration::ProfileRamp));
            assert_eq!(step.statusword & 0x6F, 0x27);
            let step = d.step(c, RAMPS.into(), true);
            assert_eq!((d.state(), step.motion), (to, Motion::Off));
        }
        // Code 0: at once.
        let coast = OptionCodes {
            shutdown: Some(0),
            ..RAMPS
        };
        let mut d = enabled(coast);
        assert_eq!(d.step(0x06, coast.into(), false).motion, Motion::Off);
        assert_eq!(d.state(), PdsState::ReadyToSwitchOn);
    }

    #[test]
    fn a_profile_may_end_shutdown_and_disable_operation_in_switch_on_disabled() {
        for c in [0x06, 0x07] {
            let mut d = Device::with_rules(DeviceRules {
                stops_end_switched_off: true,
                switch_on_requires_main_power: false,
            });
            for c in [0, cw::ENABLE_VOLTAGE | cw::QUICK_STOP, 0x07, ENABLE] {
                d.step(c, RAMPS.into(), true);
            }
            d.step(c, RAMPS.into(), false);
            assert_eq!(d.state(), PdsState::OperationEnabled, "decelerating");
            d.step(c, RAMPS.into(), true);
            assert_eq!(d.state(), PdsState::SwitchOnDisabled, "cw {c:#x}");
        }
    }

    #[test]
    fn a_required_power_cycle_keeps_the_drive_out_of_operation_enabled() {
        let mut d = Device::new();
        d.set_main_power(true);
        d.initialised();
        d.require_power_cycle();
        let options = OptionCodes {
            quick_stop: None,
            shutdown: None,
            disable_operation: None,
            halt: None,
            fault_reaction: None,
            vendor: &[],
        };
        for (cw, state) in [
            (0x06, PdsState::ReadyToSwitchOn),
            (0x07, PdsState::SwitchedOn),
            (0x0F, PdsState::SwitchedOn),
            (0x0F, PdsState::SwitchedOn),
            (0x00, PdsState::SwitchOnDisabled),
            (0x06, PdsState::ReadyToSwitchOn),
            // Enable operation straight from Ready to Switch On (3 + 4): only 3.
            (0x0F, PdsState::SwitchedOn),
        ] {
            d.step(cw, options.into(), true);
            assert_eq!(d.state(), state, "cw {cw:#06x}");
        }
        // A new power-on (a new device) enables again.
        let mut d = Device::new();
        d.set_main_power(true);
        d.initialised();
        for cw in [0x06, 0x07, 0x0F] {
            d.step(cw, options.into(), true);
        }
        assert_eq!(d.state(), PdsState::OperationEnabled);
    }

    #[test]
    fn a_profile_may_need_the_main_power_for_switched_on() {
        let mut d = Device::with_rules(DeviceRules {
            stops_end_switched_off: false,
            switch_on_requires_main_power: true,
        });
        for c in [0, cw::ENABLE_VOLTAGE | cw::QUICK_STOP, 0x07, 0x07] {
            d.step(c, RAMPS.into(), true);
        }
        assert_eq!(
            d.state(),
            PdsState::ReadyToSwitchOn,
            "no main power: 3 waits"
        );
        d.set_main_power(true);
        let step = d.step(0x07, RAMPS.into(), true);
        assert_eq!(d.state(), PdsState::SwitchedOn);
        assert_ne!(
            step.statusword & sw::VOLTAGE_ENABLED,
            0,
            "bit 4: main power"
        );
        d.step(ENABLE, RAMPS.into(), true);
        assert!(d.operation_enabled());
        d.set_main_power(false);
        let step = d.step(ENABLE, RAMPS.into(), false);
        assert_eq!(
            (d.state(), step.motion),
            (PdsState::SwitchOnDisabled, Motion::Off)
        );
        assert_eq!(step.statusword & sw::VOLTAGE_ENABLED, 0);
        // CiA402 as written: no such condition.
        let mut d = enabled(RAMPS);
        assert!(d.operation_enabled());
        d.step(ENABLE, RAMPS.into(), true);
        assert!(d.operation_enabled());
    }

    #[test]
    fn safe_torque_off_leaves_every_enabled_state_to_switch_on_disabled() {
        // Operation Enabled: at once, the motor coasting (the power stage is cut).
        let mut d = enabled(RAMPS);
        d.set_safe_torque_off(true);
        let step = d.step(ENABLE, RAMPS.into(), false);
        assert_eq!(
            (d.state(), step.motion),
            (PdsState::SwitchOnDisabled, Motion::Off)
        );
        // While it holds, a new enable sequence passes Switched On only for one cycle.
        for c in [0, cw::ENABLE_VOLTAGE | cw::QUICK_STOP] {
            d.step(c, RAMPS.into(), true);
        }
        assert_eq!(d.state(), PdsState::ReadyToSwitchOn);
        d.step(ENABLE, RAMPS.into(), true);
        assert_eq!(d.state(), PdsState::SwitchedOn);
        assert_eq!(d.step(ENABLE, RAMPS.into(), true).motion, Motion::Off);
        assert_eq!(d.state(), PdsState::SwitchOnDisabled);
        // Quick Stop Active too, without finishing its ramp.
        let mut d = enabled(RAMPS);
        d.step(QUICK_STOP, RAMPS.into(), false);
        assert_eq!(d.state(), PdsState::QuickStopActive);
        d.set_safe_torque_off(true);
        let step = d.step(QUICK_STOP, RAMPS.into(), false);
        assert_eq!(
            (d.state(), step.motion),
            (PdsState::SwitchOnDisabled, Motion::Off)
        );
        // Released: the usual sequence enables again.
        d.set_safe_torque_off(false);
        for c in [0, cw::ENABLE_VOLTAGE | cw::QUICK_STOP, 0x07, ENABLE] {
            d.step(c, RAMPS.into(), true);
        }
        assert!(d.operation_enabled());
    }

    #[test]
    fn enable_operation_cancels_a_waiting_shutdown_and_quick_stop_overrides_it() {
        let mut d = enabled(RAMPS);
        d.step(0x06, RAMPS.into(), false);
        assert_eq!(d.step(ENABLE, RAMPS.into(), false).motion, Motion::Run);
        assert_eq!(d.state(), PdsState::OperationEnabled);
        d.step(0x06, RAMPS.into(), false);
        let step = d.step(QUICK_STOP, RAMPS.into(), false);
        assert_eq!(
            (d.state(), step.motion),
            (
                PdsState::QuickStopActive,
                Motion::Stop(Deceleration::QuickStopRamp)
            )
        );
        d.step(0x06, RAMPS.into(), false);
        d.step(0x00, RAMPS.into(), false);
        assert_eq!(
            d.state(),
            PdsState::SwitchOnDisabled,
            "disable voltage: at once (9)"
        );
    }

    #[test]
    fn halt_stops_on_605dh_and_resumes_when_released() {
        let mut d = enabled(RAMPS);
        let step = d.step(ENABLE | cw::HALT, RAMPS.into(), false);
        assert_eq!(
            (d.state(), step.motion),
            (
                PdsState::OperationEnabled,
                Motion::Stop(Deceleration::ProfileRamp)
            )
        );
        assert_eq!(
            step.statusword & sw::TARGET_REACHED,
            0,
            "bit 10 clear while decelerating"
        );
        let step = d.step(ENABLE | cw::HALT, RAMPS.into(), true);
        assert_eq!(
            step.motion,
            Motion::Stop(Deceleration::ProfileRamp),
            "holds at rest"
        );
        assert_ne!(step.statusword & sw::TARGET_REACHED, 0, "bit 10: halted");
        let step = d.step(ENABLE, RAMPS.into(), true);
        assert_eq!(step.motion, Motion::Run);
        assert_eq!(step.statusword & sw::TARGET_REACHED, 0, "released");
        // Without 605Dh halt is not supported: bit 8 is ignored.
        let mut d = enabled(NO_OBJECTS);
        assert_eq!(
            d.step(ENABLE | cw::HALT, NO_OBJECTS.into(), false).motion,
            Motion::Run
        );
    }

    #[test]
    fn a_fault_under_power_ramps_per_605eh_in_fault_reaction_active() {
        let mut d = enabled(RAMPS);
        let status = d.fault(0x8611);
        assert_eq!(d.state(), PdsState::FaultReactionActive);
        assert_eq!(
            status & 0x4F,
            0x0F,
            "CiA402 Table 30: fault reaction active"
        );
        let step = d.step(cw::FAULT_RESET, RAMPS.into(), false);
        assert_eq!(step.motion, Motion::Stop(Deceleration::QuickStopRamp));
        assert_eq!(
            (d.state(), step.fault_cleared),
            (PdsState::FaultReactionActive, None),
            "no reset before Fault"
        );
        let step = d.step(0, RAMPS.into(), true);
        assert_eq!((d.state(), step.motion), (PdsState::Fault, Motion::Off));
        // The power stage tripped: no ramp possible.
        let mut d = enabled(RAMPS);
        d.fault(0x2320);
        d.power_stage_lost();
        assert_eq!(d.state(), PdsState::Fault);
    }
}
