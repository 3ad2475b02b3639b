//! Power drive system state machine (IEC 61800-7-201 §5.3, CiA402 Figure "State machine"):
//! a pure decision from (state, controlword) to the next state, and the statusword bits of each
//! state.

/// PDS states.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PdsState {
    /// Not ready to switch on (self test; left automatically).
    NotReadyToSwitchOn,
    /// Switch on disabled.
    SwitchOnDisabled,
    /// Ready to switch on.
    ReadyToSwitchOn,
    /// Switched on.
    SwitchedOn,
    /// Operation enabled.
    OperationEnabled,
    /// Quick stop active.
    QuickStopActive,
    /// Fault reaction active.
    FaultReactionActive,
    /// Fault.
    Fault,
}

/// Controlword bits (CiA402 6040h).
pub mod controlword {
    /// Bit 0: switch on.
    pub const SWITCH_ON: u16 = 1 << 0;
    /// Bit 1: enable voltage.
    pub const ENABLE_VOLTAGE: u16 = 1 << 1;
    /// Bit 2: quick stop (active low).
    pub const QUICK_STOP: u16 = 1 << 2;
    /// Bit 3: enable operation.
    pub const ENABLE_OPERATION: u16 = 1 << 3;
    /// Bit 7: fault reset (rising edge).
    pub const FAULT_RESET: u16 = 1 << 7;
    /// Bit 8: halt (stop per 605Dh while set).
    pub const HALT: u16 = 1 << 8;
}

/// Statusword bits (CiA402 6041h).
pub mod statusword {
    /// Bit 0: ready to switch on.
    pub const READY_TO_SWITCH_ON: u16 = 1 << 0;
    /// Bit 1: switched on.
    pub const SWITCHED_ON: u16 = 1 << 1;
    /// Bit 2: operation enabled.
    pub const OPERATION_ENABLED: u16 = 1 << 2;
    /// Bit 3: fault.
    pub const FAULT: u16 = 1 << 3;
    /// Bit 4: voltage enabled.
    pub const VOLTAGE_ENABLED: u16 = 1 << 4;
    /// Bit 5: quick stop (active low).
    pub const QUICK_STOP: u16 = 1 << 5;
    /// Bit 6: switch on disabled.
    pub const SWITCH_ON_DISABLED: u16 = 1 << 6;
    /// Bit 7: warning (a condition that does not change the state).
    pub const WARNING: u16 = 1 << 7;
    /// Bit 9: remote (controlword is processed).
    pub const REMOTE: u16 = 1 << 9;
    /// Bit 10: target reached (operation-mode specific; with halt set: the motor is at rest).
    pub const TARGET_REACHED: u16 = 1 << 10;
    /// Bit 11: internal limit active (e.g. the torque demand at its limit).
    pub const INTERNAL_LIMIT_ACTIVE: u16 = 1 << 11;
}

/// The device-control commands encoded in controlword bits 0..3 and 7 (CiA402 Table 5).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Command {
    Shutdown,
    SwitchOn,
    DisableVoltage,
    QuickStop,
    EnableOperation,
    FaultReset,
    None,
}

fn command(cw: u16, previous_cw: u16) -> Command {
    use controlword::*;
    let fault_reset_edge = cw & FAULT_RESET != 0 && previous_cw & FAULT_RESET == 0;
    if fault_reset_edge {
        return Command::FaultReset;
    }
    if cw & FAULT_RESET != 0 {
        return Command::None; // held fault reset: ignore the rest (CiA402 Table 5 footnote)
    }
    let ev = cw & ENABLE_VOLTAGE != 0;
    let qs = cw & QUICK_STOP != 0;
    let so = cw & SWITCH_ON != 0;
    let eo = cw & ENABLE_OPERATION != 0;
    match (ev, qs, so, eo) {
        (false, _, _, _) => Command::DisableVoltage,
        (true, false, _, _) => Command::QuickStop,
        (true, true, false, _) => Command::Shutdown,
        (true, true, true, false) => Command::SwitchOn, // "disable operation" in Operation Enabled
        (true, true, true, true) => Command::EnableOperation,
    }
}

/// Next PDS state for controlword `cw` (with the previous controlword for edge detection): the
/// transition the command asks for. Quick Stop Active and Fault Reaction Active are left by
/// the device when the motor has come to rest (transitions 12 and 14, [`crate::device`]);
/// here only disable voltage leaves Quick Stop Active (12) and enable operation asks for
/// transition 16, which the device allows only after a quick stop that holds the motor.
pub fn next(state: PdsState, cw: u16, previous_cw: u16) -> PdsState {
    use Command as C;
    use PdsState as S;
    match (state, command(cw, previous_cw)) {
        (S::NotReadyToSwitchOn, _) => S::SwitchOnDisabled,
        (S::FaultReactionActive, _) => S::FaultReactionActive,
        (S::Fault, C::FaultReset) => S::SwitchOnDisabled,
        (S::Fault, _) => S::Fault,
        (S::SwitchOnDisabled, C::Shutdown) => S::ReadyToSwitchOn,
        (S::ReadyToSwitchOn, C::SwitchOn) => S::SwitchedOn,
        (S::ReadyToSwitchOn, C::EnableOperation) => S::SwitchedOn, // 3 first, then 4
        (S::SwitchedOn, C::EnableOperation) => S::OperationEnabled,
        (S::SwitchedOn, C::Shutdown) => S::ReadyToSwitchOn,
        (S::OperationEnabled, C::SwitchOn) => S::SwitchedOn,
        (S::OperationEnabled, C::Shutdown) => S::ReadyToSwitchOn,
        (S::OperationEnabled, C::QuickStop) => S::QuickStopActive,
        (S::QuickStopActive, C::DisableVoltage) => S::SwitchOnDisabled,
        (S::QuickStopActive, C::EnableOperation) => S::OperationEnabled,
        (S::QuickStopActive, _) => S::QuickStopActive,
        (
            S::ReadyToSwitchOn | S::SwitchedOn | S::OperationEnabled,
            C::DisableVoltage | C::QuickStop,
        ) => S::SwitchOnDisabled,
        (s, _) => s,
    }
}

/// The state a fault puts the drive in (CiA402 transition 13: any state → Fault Reaction
/// Active; a drive already in Fault stays there). The device completes the reaction
/// (transition 14 → Fault) when the motor has come to rest.
pub fn fault(state: PdsState) -> PdsState {
    match state {
        PdsState::Fault => PdsState::Fault,
        _ => PdsState::FaultReactionActive,
    }
}

/// Statusword of a state (bits 0..6 per CiA402 Table 30, plus remote).
pub fn statusword_of(state: PdsState) -> u16 {
    use statusword::*;
    let bits = match state {
        PdsState::NotReadyToSwitchOn => 0,
        PdsState::SwitchOnDisabled => SWITCH_ON_DISABLED,
        PdsState::ReadyToSwitchOn => READY_TO_SWITCH_ON | QUICK_STOP,
        PdsState::SwitchedOn => READY_TO_SWITCH_ON | SWITCHED_ON | QUICK_STOP,
        PdsState::OperationEnabled => {
            READY_TO_SWITCH_ON | SWITCHED_ON | OPERATION_ENABLED | QUICK_STOP
        }
        PdsState::QuickStopActive => READY_TO_SWITCH_ON | SWITCHED_ON | OPERATION_ENABLED,
        PdsState::FaultReactionActive => {
            READY_TO_SWITCH_ON | SWITCHED_ON | OPERATION_ENABLED | FAULT
        }
        PdsState::Fault => FAULT,
    };
    bits | REMOTE
}

#[cfg(test)]
mod tests {
    use super::*;
    use PdsState::*;

    #[test]
    fn shutdown_switch_on_enable_reaches_operation_enabled() {
        let s = next(NotReadyToSwitchOn, 0, 0);
        assert_eq!(s, SwitchOnDisabled);
        let s = next(s, 0x06, 0);
        assert_eq!(s, ReadyToSwitchOn);
        let s = next(s, 0x07, 0x06);
        assert_eq!(s, SwitchedOn);
        let s = next(s, 0x0F, 0x07);
        assert_eq!(s, OperationEnabled);
    }

    #[test]
    fn statuswords_match_cia402_table() {
        // Masked with 0x6F as CiA402 Table 30 states them, plus remote bit 9.
        assert_eq!(statusword_of(SwitchOnDisabled) & 0x4F, 0x40);
        assert_eq!(statusword_of(ReadyToSwitchOn) & 0x6F, 0x21);
        assert_eq!(statusword_of(SwitchedOn) & 0x6F, 0x23);
        assert_eq!(statusword_of(OperationEnabled) & 0x6F, 0x27);
        assert_eq!(statusword_of(QuickStopActive) & 0x6F, 0x07);
        assert_eq!(statusword_of(Fault) & 0x4F, 0x08);
        assert_ne!(statusword_of(OperationEnabled) & statusword::REMOTE, 0);
    }

    #[test]
    fn disable_voltage_from_operation_enabled_goes_to_switch_on_disabled() {
        assert_eq!(next(OperationEnabled, 0x00, 0x0F), SwitchOnDisabled);
        assert_eq!(next(OperationEnabled, 0x07, 0x0F), SwitchedOn);
        assert_eq!(next(OperationEnabled, 0x06, 0x0F), ReadyToSwitchOn);
    }

    #[test]
    fn a_fault_passes_fault_reaction_active_to_fault() {
        for s in [
            SwitchOnDisabled,
            SwitchedOn,
            OperationEnabled,
            QuickStopActive,
        ] {
            assert_eq!(fault(s), FaultReactionActive);
            assert_eq!(
                next(fault(s), 0x80, 0),
                FaultReactionActive,
                "no reset in FRA"
            );
        }
        assert_eq!(fault(Fault), Fault);
        assert_ne!(statusword_of(Fault) & statusword::FAULT, 0);
    }

    #[test]
    fn quick_stop_active_is_left_by_disable_voltage_or_asks_for_16() {
        assert_eq!(next(OperationEnabled, 0x02, 0x0F), QuickStopActive);
        assert_eq!(next(QuickStopActive, 0x02, 0x02), QuickStopActive);
        assert_eq!(next(QuickStopActive, 0x00, 0x02), SwitchOnDisabled);
        assert_eq!(next(QuickStopActive, 0x0F, 0x02), OperationEnabled);
    }

    #[test]
    fn fault_reset_needs_a_rising_edge() {
        assert_eq!(next(Fault, 0x80, 0x80), Fault);
        assert_eq!(next(Fault, 0x80, 0x00), SwitchOnDisabled);
    }
}
