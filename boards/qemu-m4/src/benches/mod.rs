//! The benchmarks: each module sets up the real firmware code (with the real generated
//! `standard` profile, or the motor control with the simulated servo's configuration), brings it
//! to a steady state, checks that the operation does what it should, and measures it with the
//! [`Harness`].
//!
//! To add one, write a module with a `run(&mut Harness)` and list it in [`ALL`]; budgets come
//! from DESIGN.md §6.

mod motor;
mod process_data;
mod sdo;
mod sync0_handler;

use crate::harness::Harness;

/// Every benchmark, in report order.
pub const ALL: &[fn(&mut Harness)] = &[process_data::run, sync0_handler::run, sdo::run, motor::run];

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
