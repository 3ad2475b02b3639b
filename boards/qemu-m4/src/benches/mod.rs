//! The benchmarks: each module sets up the real firmware code (with the real generated
//! `standard` profile, or the motor control with the simulated servo's configuration), brings it
//! to a steady state, checks that the operation does what it should, and measures it with the
//! [`Harness`].
//!
//! To add one, write a module with a `run(&mut Harness)` and list it in [`ALL`]; budgets come
//! from DESIGN.md §6.

mod board_control;
mod board_esc_event;
mod board_sync0;
mod motor;
mod process_data;
mod sdo;
mod sync0_handler;
mod sync0_with_axis;

use firmware::profiles::standard::{PROFILE, RAM_SIZE};

use crate::harness::Harness;

/// Modes of operation 6060h: cyclic synchronous position mode (IEC 61800-7-201).
const MODE_CYCLIC_SYNC_POSITION: i8 = 8;
/// Target position 607Ah the master sends; any non-zero value, so that its echo is visible.
const TARGET_POSITION: i32 = 0x0012_3456;

/// Every benchmark, in report order.
pub const ALL: &[fn(&mut Harness)] = &[
    process_data::run,
    sync0_handler::run,
    sync0_with_axis::run,
    sdo::run,
    motor::run,
    board_control::run,
    board_sync0::run,
    board_esc_event::run,
];

/// Reads `N` bytes of the OD RAM at the offset of an application variable.
fn read<const N: usize>(ram: &[u8], at: Option<u16>) -> Option<[u8; N]> {
    let at = usize::from(at?);
    ram.get(at..at + N)?.try_into().ok()
}

/// Writes `bytes` into the OD RAM at the offset of an application variable; `false` if the
/// profile has no such variable or it lies outside `ram`.
fn write(ram: &mut [u8], at: Option<u16>, bytes: &[u8]) -> bool {
    let Some(at) = at.map(usize::from) else {
        return false;
    };
    match ram.get_mut(at..at + bytes.len()) {
        Some(dst) => {
            dst.copy_from_slice(bytes);
            true
        }
        None => false,
    }
}

/// The variables of the standard profile's (one) axis.
fn axis_vars() -> Option<&'static firmware::profile::AppVars> {
    PROFILE.axes.first()
}

/// The master's side of the default RxPDO objects of the standard profile as an OD RAM image:
/// `controlword`, the target position and CSP. Packing it with an Rx copy plan gives the SM2
/// image, so no image layout is assumed. `None` if the profile lacks one of the variables.
fn master_outputs(controlword: u16) -> Option<[u8; RAM_SIZE]> {
    master_outputs_for(controlword, TARGET_POSITION, MODE_CYCLIC_SYNC_POSITION)
}

/// [`master_outputs`] with any target position 607Ah and mode 6060h.
fn master_outputs_for(controlword: u16, target_position: i32, mode: i8) -> Option<[u8; RAM_SIZE]> {
    let vars = axis_vars()?;
    let mut master = [0; RAM_SIZE];
    let ok = write(&mut master, vars.controlword, &controlword.to_le_bytes())
        && write(
            &mut master,
            vars.target_position,
            &target_position.to_le_bytes(),
        )
        && write(&mut master, vars.modes_of_operation, &mode.to_le_bytes());
    ok.then_some(master)
}
