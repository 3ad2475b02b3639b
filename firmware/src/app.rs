//! The per-cycle application: reads the set-points the master wrote (already unpacked into the OD
//! RAM), runs the drive, writes the actual values back to the OD RAM for packing.
//!
//! The CiA402 power drive state machine on controlword / statusword, the mode display mirroring
//! the requested mode, and the axis:
//! - with a motor attached ([`Application::attach_axis`]): the cyclic set-points of the mode
//!   (CSP 607Ah, CSV 60FFh, CST 6071h) go to the control interrupt through its
//!   [`AxisLink`], the actual values (6064h, 606Ch, 6077h) come back from it, and a motor fault
//!   becomes a CiA402 fault with the profile's 603Fh code for it;
//! - without one (a board with no power stage, the benchmarks): an ideal axis whose position
//!   actual value follows the target position while operation is enabled.
//!
//! Units at this boundary (the standard profile): positions in increments (the 32-bit objects
//! wrap; the axis works on 64-bit positions), velocities in increments/s, torques in ‰ of the
//! motor rated torque 6076h (mN·m).

use crate::cia402::pds::{self, PdsState};
use crate::motor::axis::{AxisCommand, AxisLink, AxisState, ControlMode, MotorModel};
use crate::motor::MotorFault;
use crate::od::{AppVars, MOTOR_FAULT_COUNT};

/// CiA402 modes of operation (6060h) the axis runs.
mod mode {
    /// Cyclic synchronous position.
    pub const CSP: i8 = 8;
    /// Cyclic synchronous velocity.
    pub const CSV: i8 = 9;
    /// Cyclic synchronous torque.
    pub const CST: i8 = 10;
    /// Manufacturer-specific (negative, CiA402): motor identification (commissioning). The
    /// results land in the commissioned motor data (2100h in the standard profile).
    pub const IDENTIFICATION: i8 = -1;
}

/// Statusword bit 12 (operation-mode specific): in mode −1, the identification finished.
const STATUSWORD_IDENTIFIED: u16 = 0x1000;
/// Units of the commissioned motor data objects: µΩ, nH, g·mm² (1e-9 kg·m²).
const MICRO: f32 = 1e-6;
const NANO: f32 = 1e-9;

/// Controlword bit 7: fault reset (rising edge).
const CONTROLWORD_FAULT_RESET: u16 = 0x0080;
/// Rated torque assumed when 6076h is absent or 0, mN·m (so that torques stay finite).
const FALLBACK_RATED_TORQUE_MNM: u32 = 1_000;

/// The connection to a motor's control interrupt.
struct AxisPort {
    link: &'static AxisLink,
    /// 603Fh code per motor fault (the profile's `[motor_faults]`).
    fault_codes: &'static [u16; MOTOR_FAULT_COUNT],
    /// The axis' trip counter at the last fault raised here.
    trips_seen: u32,
    /// The motor model last handed to the axis.
    model_sent: Option<MotorModel>,
    /// The results of the finished identification are in the OD.
    results_written: bool,
}

/// Application state.
pub struct Application {
    pds: PdsState,
    previous_controlword: u16,
    fault_code: Option<u16>,
    axis: Option<AxisPort>,
    /// The process-data cycle, ns (0 = unknown), for the axis' set-point interpolation.
    cycle_ns: u32,
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
            axis: None,
            cycle_ns: 0,
        }
    }

    /// Tells the application the process-data cycle (1C32h:02), ns; 0 if unknown.
    pub fn set_cycle_ns(&mut self, cycle_ns: u32) {
        self.cycle_ns = cycle_ns;
    }

    /// Connects the motor's control interrupt: from now on the set-points go to it and the
    /// actual values come from it. `fault_codes` maps each [`MotorFault`] (by code − 1) to its
    /// 603Fh error code.
    pub fn attach_axis(
        &mut self,
        link: &'static AxisLink,
        fault_codes: &'static [u16; MOTOR_FAULT_COUNT],
    ) {
        self.axis = Some(AxisPort {
            link,
            fault_codes,
            trips_seen: link.feedback().trips,
            model_sent: None,
            results_written: false,
        });
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
        let mode = read_bytes::<1>(ram, vars.modes_of_operation);
        if let Some(mode) = mode {
            write_bytes(ram, vars.modes_of_operation_display, mode);
        }
        if self.axis.is_some() {
            self.exchange_with_axis(vars, ram, cw, mode.map_or(0, |m| m[0] as i8));
        } else if self.pds == PdsState::OperationEnabled {
            if let Some(target) = read_bytes::<4>(ram, vars.target_position) {
                write_bytes(ram, vars.position_actual_value, target);
            }
        }
    }

    /// Hands the commissioned motor data (stored parameters, identification results, SDO
    /// writes) to the axis when they changed since the last call; the axis applies them when it
    /// is not running. Also called when the axis is attached (after the parameters were
    /// loaded at power-on).
    pub fn publish_motor_model(&mut self, vars: &AppVars, ram: &[u8]) {
        if let Some(port) = self.axis.as_mut() {
            Self::sync_motor_model(port, vars, ram);
        }
    }

    fn sync_motor_model(port: &mut AxisPort, vars: &AppVars, ram: &[u8]) {
        let link = port.link;
        let model = MotorModel {
            resistance_ohm: read_u32(ram, vars.motor_resistance).unwrap_or(0) as f32 * MICRO,
            ld_h: read_u32(ram, vars.motor_ld).unwrap_or(0) as f32 * NANO,
            lq_h: read_u32(ram, vars.motor_lq).unwrap_or(0) as f32 * NANO,
            inertia_kgm2: read_u32(ram, vars.motor_inertia).unwrap_or(0) as f32 * NANO,
        };
        if port.model_sent != Some(model) {
            link.set_motor_model(model);
            port.model_sent = Some(model);
        }
    }

    /// Raises a new motor fault, hands the set-points of this cycle to the axis, and writes its
    /// actual values.
    fn exchange_with_axis(&mut self, vars: &AppVars, ram: &mut [u8], cw: u16, mode: i8) {
        // Taken out for the cycle (so that `self.fault` can borrow `self`), put back at the end.
        let Some(mut port) = self.axis.take() else {
            return;
        };
        let link = port.link;
        let feedback = link.feedback();
        let new_fault = if feedback.trips != port.trips_seen {
            port.trips_seen = feedback.trips;
            feedback.fault.map(|f| fault_code(port.fault_codes, f))
        } else {
            None
        };
        if let Some(code) = new_fault {
            if !matches!(self.pds, PdsState::Fault | PdsState::FaultReactionActive) {
                self.fault(code, vars, ram);
            }
        }
        let rated_nm = read_u32(ram, vars.motor_rated_torque)
            .filter(|&t| t > 0)
            .unwrap_or(FALLBACK_RATED_TORQUE_MNM) as f32
            * 1e-3;
        // The 32-bit target is taken relative to the 32-bit image of the actual position, so
        // the 64-bit target is right across any number of wraps.
        let relative = |target: i32| {
            feedback.position + i64::from(target.wrapping_sub(feedback.position as i32))
        };
        let target_position =
            read_i32(ram, vars.target_position).map_or(feedback.position, relative);
        Self::sync_motor_model(&mut port, vars, ram);
        let identifying = mode == mode::IDENTIFICATION;
        match (feedback.state, feedback.identified) {
            (AxisState::Identified, Some(result)) if identifying => {
                if !port.results_written {
                    port.results_written = true;
                    let to_u32 = |x: f32| (x + 0.5) as u32;
                    write_bytes(
                        ram,
                        vars.motor_resistance,
                        to_u32(result.resistance_ohm / MICRO).to_le_bytes(),
                    );
                    write_bytes(ram, vars.motor_ld, to_u32(result.ld_h / NANO).to_le_bytes());
                    write_bytes(ram, vars.motor_lq, to_u32(result.lq_h / NANO).to_le_bytes());
                    write_bytes(
                        ram,
                        vars.motor_inertia,
                        to_u32(result.inertia_kgm2 / NANO).to_le_bytes(),
                    );
                }
                if let Some(sw) = read_u16(ram, vars.statusword) {
                    write_u16(ram, vars.statusword, sw | STATUSWORD_IDENTIFIED);
                }
            }
            (AxisState::Identified, _) => {}
            _ => port.results_written = false,
        }
        let (mode, position) = match mode {
            mode::CSP => (ControlMode::Position, target_position),
            mode::CSV => (ControlMode::Velocity, feedback.position),
            mode::CST => (ControlMode::Torque, feedback.position),
            // No mode (or one the axis does not run): hold the position.
            _ => (ControlMode::Position, feedback.position),
        };
        let torque_permille =
            read_bytes::<2>(ram, vars.target_torque).map_or(0, i16::from_le_bytes);
        link.publish(AxisCommand {
            enable: self.pds == PdsState::OperationEnabled,
            fault_reset: cw & CONTROLWORD_FAULT_RESET != 0,
            identify: identifying,
            mode,
            position,
            velocity: read_i32(ram, vars.target_velocity).map_or(0.0, |v| v as f32),
            torque: f32::from(torque_permille) * 1e-3 * rated_nm,
            bus_cycle_ns: self.cycle_ns,
        });
        write_bytes(
            ram,
            vars.position_actual_value,
            (feedback.position as i32).to_le_bytes(),
        );
        // `as` saturates float → integer conversions (NaN → 0).
        write_bytes(
            ram,
            vars.velocity_actual_value,
            (feedback.velocity as i32).to_le_bytes(),
        );
        write_bytes(
            ram,
            vars.torque_actual_value,
            ((feedback.torque / rated_nm * 1e3) as i16).to_le_bytes(),
        );
        self.axis = Some(port);
    }

    /// Puts the outputs the master drives into their safe state (on leaving OP, on a watchdog).
    /// With a motor, the axis is disabled at once (gates off): below SAFEOP no cycle runs that
    /// would tell it. (On the board the slave's callers share one lock, so this and the cycle
    /// never publish at the same time: the link keeps a single writer at a time.)
    pub fn safe_outputs(&mut self, vars: &AppVars, ram: &mut [u8]) {
        write_u16(ram, vars.controlword, 0);
        self.pds = pds::next(self.pds, 0, self.previous_controlword);
        self.previous_controlword = 0;
        write_u16(ram, vars.statusword, pds::statusword_of(self.pds));
        if let Some(port) = &self.axis {
            port.link.publish(AxisCommand {
                enable: false,
                bus_cycle_ns: self.cycle_ns,
                ..AxisCommand::default()
            });
        }
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

/// The 603Fh code of `fault` in the profile's table (0x1000 "generic error" if it has none).
fn fault_code(codes: &[u16; MOTOR_FAULT_COUNT], fault: MotorFault) -> u16 {
    const GENERIC_ERROR: u16 = 0x1000;
    codes
        .get(usize::from(fault.code()).wrapping_sub(1))
        .copied()
        .unwrap_or(GENERIC_ERROR)
}

fn read_i32(ram: &[u8], at: Option<u16>) -> Option<i32> {
    read_bytes::<4>(ram, at).map(i32::from_le_bytes)
}

fn read_u32(ram: &[u8], at: Option<u16>) -> Option<u32> {
    read_bytes::<4>(ram, at).map(u32::from_le_bytes)
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
        ..AppVars::NONE
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
