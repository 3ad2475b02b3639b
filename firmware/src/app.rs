//! The per-cycle application: reads the set-points the master wrote (already unpacked into the OD
//! RAM), runs the drive, writes the actual values back to the OD RAM for packing.
//!
//! First cut, until motor control lands: the CiA402 power drive state machine on controlword /
//! statusword, the mode display mirroring the requested mode, and an ideal axis whose position
//! actual value follows the target position while operation is enabled.

use crate::cia402::pds::{self, PdsState};
use crate::od::AppVars;

/// Application state.
pub struct Application {
    pds: PdsState,
    previous_controlword: u16,
    fault_code: Option<u16>,
}

impl Default for Application {
    fn default() -> Self {
        Self::new()
    }
}

impl Application {
    /// Power-on state.
    pub const fn new() -> Self {
        Self {
            pds: PdsState::NotReadyToSwitchOn,
            previous_controlword: 0,
            fault_code: None,
        }
    }

    /// The PDS state.
    pub fn pds_state(&self) -> PdsState {
        self.pds
    }

    /// The CiA402 error code of the active fault (603Fh), `None` when there is none.
    pub fn fault_code(&self) -> Option<u16> {
        self.fault_code
    }

    /// Raises CiA402 error `code`: the drive goes through Fault Reaction Active to Fault
    /// (statusword bit 3), controlword reads 0 (the reaction disables the drive; with no motion
    /// to stop it completes at once), and 603Fh (role `error_code`) holds `code` until a fault
    /// reset (controlword bit 7 rising edge) leaves Fault. The caller reports the EMCY.
    pub fn fault(&mut self, code: u16, vars: &AppVars, ram: &mut [u8]) {
        write_u16(ram, vars.controlword, 0);
        self.previous_controlword = 0;
        self.pds = pds::next(pds::fault(self.pds), 0, 0);
        self.fault_code = Some(code);
        write_u16(ram, vars.error_code, code);
        write_u16(ram, vars.statusword, pds::statusword_of(self.pds));
    }

    /// One cycle.
    pub fn step(&mut self, vars: &AppVars, ram: &mut [u8]) {
        let cw = read_u16(ram, vars.controlword).unwrap_or(0);
        self.pds = pds::next(self.pds, cw, self.previous_controlword);
        self.previous_controlword = cw;
        if self.fault_code.is_some() && self.pds != PdsState::Fault {
            // Fault reset: the error is gone.
            self.fault_code = None;
            write_u16(ram, vars.error_code, 0);
        }
        write_u16(ram, vars.statusword, pds::statusword_of(self.pds));
        if let Some(mode) = read_bytes::<1>(ram, vars.modes_of_operation) {
            write_bytes(ram, vars.modes_of_operation_display, mode);
        }
        if self.pds == PdsState::OperationEnabled {
            if let Some(target) = read_bytes::<4>(ram, vars.target_position) {
                write_bytes(ram, vars.position_actual_value, target);
            }
        }
    }

    /// Puts the outputs the master drives into their safe state (on leaving OP, on a watchdog).
    pub fn safe_outputs(&mut self, vars: &AppVars, ram: &mut [u8]) {
        write_u16(ram, vars.controlword, 0);
        self.pds = pds::next(self.pds, 0, self.previous_controlword);
        self.previous_controlword = 0;
        write_u16(ram, vars.statusword, pds::statusword_of(self.pds));
    }
}

fn read_bytes<const N: usize>(ram: &[u8], at: Option<u16>) -> Option<[u8; N]> {
    let at = at? as usize;
    ram.get(at..at + N)?.try_into().ok()
}

fn write_bytes<const N: usize>(ram: &mut [u8], at: Option<u16>, v: [u8; N]) {
    if let Some(at) = at {
        if let Some(dst) = ram.get_mut(at as usize..at as usize + N) {
            dst.copy_from_slice(&v);
        }
    }
}

fn read_u16(ram: &[u8], at: Option<u16>) -> Option<u16> {
    read_bytes::<2>(ram, at).map(u16::from_le_bytes)
}

fn write_u16(ram: &mut [u8], at: Option<u16>, v: u16) {
    write_bytes(ram, at, v.to_le_bytes());
}

#[cfg(test)]
mod tests {
    use super::*;

    const VARS: AppVars = AppVars {
        controlword: Some(0),
        statusword: Some(2),
        modes_of_operation: Some(4),
        modes_of_operation_display: Some(5),
        target_position: Some(6),
        position_actual_value: Some(10),
        error_code: Some(14),
    };

    #[test]
    fn actual_position_follows_target_only_when_operation_enabled() {
        let mut ram = [0u8; 16];
        let mut app = Application::new();
        ram[6..10].copy_from_slice(&1234i32.to_le_bytes());
        for cw in [0x00u16, 0x06, 0x07] {
            ram[0..2].copy_from_slice(&cw.to_le_bytes());
            app.step(&VARS, &mut ram);
        }
        assert_eq!(&ram[10..14], &[0; 4], "not enabled yet");
        ram[0..2].copy_from_slice(&0x0Fu16.to_le_bytes());
        app.step(&VARS, &mut ram);
        assert_eq!(u16::from_le_bytes([ram[2], ram[3]]) & 0x6F, 0x27);
        assert_eq!(i32::from_le_bytes(ram[10..14].try_into().unwrap()), 1234);
    }

    #[test]
    fn safe_outputs_disable_the_drive() {
        let mut ram = [0u8; 16];
        let mut app = Application::new();
        for cw in [0x00u16, 0x06, 0x07, 0x0F] {
            ram[0..2].copy_from_slice(&cw.to_le_bytes());
            app.step(&VARS, &mut ram);
        }
        app.safe_outputs(&VARS, &mut ram);
        assert_eq!(app.pds_state(), PdsState::SwitchOnDisabled);
        assert_eq!(&ram[0..2], &[0, 0]);
    }

    #[test]
    fn fault_sets_error_code_and_statusword_until_fault_reset() {
        let mut ram = [0u8; 16];
        let mut app = Application::new();
        for cw in [0x00u16, 0x06, 0x07, 0x0F] {
            ram[0..2].copy_from_slice(&cw.to_le_bytes());
            app.step(&VARS, &mut ram);
        }
        app.fault(0x8700, &VARS, &mut ram);
        assert_eq!(app.pds_state(), PdsState::Fault);
        assert_eq!(app.fault_code(), Some(0x8700));
        assert_eq!(u16::from_le_bytes([ram[14], ram[15]]), 0x8700);
        assert_ne!(
            u16::from_le_bytes([ram[2], ram[3]]) & 0x08,
            0,
            "statusword bit 3"
        );
        // Controlword ignored while in Fault; a rising edge of bit 7 resets.
        ram[0..2].copy_from_slice(&0x0Fu16.to_le_bytes());
        app.step(&VARS, &mut ram);
        assert_eq!(app.pds_state(), PdsState::Fault);
        ram[0..2].copy_from_slice(&0x80u16.to_le_bytes());
        app.step(&VARS, &mut ram);
        assert_eq!(app.pds_state(), PdsState::SwitchOnDisabled);
        assert_eq!(app.fault_code(), None);
        assert_eq!(&ram[14..16], &[0, 0]);
    }
}
