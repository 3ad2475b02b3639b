//! An EtherCAT slave stack that knows no drive: the Rust counterpart of SOES.
//!
//! `no_std`, no allocation, generic over [`hal::pdi::EscPdi`] (the ESC's process-data
//! interface) and over the device [`Application`](slave::Application) that runs in the
//! process-data cycle. A profile file (od-gen) gives the object dictionary; boards call the
//! entry points of [`slave::Slave`] from their interrupts and executor tasks. A servo drive
//! (crate `firmware`) and a digital I/O module (`tests-host`, example `io_slave`) use it alike.
//!
//! | module | what |
//! |---|---|
//! | [`slave`] | [`SlaveCore`](slave::SlaveCore) (state, OD RAM, process data: what the SYNC0 context needs) and [`MailboxSide`](slave::MailboxSide) (mailbox and CoE on their own copy of the OD RAM), together [`Slave`](slave::Slave); the entry points and the glue between the modules below; the [`Application`](slave::Application) trait |
//! | [`slave::esm`] (also [`esm`]) | the EtherCAT state machine in one folder: decision function, SM checks, sync modes, SYNC0 supervision, state change requests, the faults that drop the state |
//! | [`mailbox`] | mailbox data-link layer, CoE (SDO, SDO information, complete access) and emergencies |
//! | [`pdo`] | PDO mapping → copy plan, pack/unpack, and the rules for writing the PDO objects |
//! | [`od`] | object dictionary: generated model, run-time store, abort codes, value checks, domains |
//! | [`diag`] | diagnosis history 10F3h (ETG.1020 §13) |
//! | [`params`] | 1010h/1011h store/restore on power-loss-safe parameter storage |
//! | [`leds`] | ETG.1300 RUN/ERR indicator patterns |
//!
//! Dependencies between the modules point one way: `slave` (with its `esm`) → `mailbox`, `pdo`,
//! `diag`, `params`, `leds` → `od`.
#![no_std]
#![deny(missing_docs)]
// Firmware never panics on input: outside tests no unwrap/expect/panic and no unchecked
// indexing or integer arithmetic; each exception states why it cannot fail where it stands.
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::unreachable,
        clippy::todo,
        clippy::unimplemented,
        clippy::indexing_slicing,
        clippy::arithmetic_side_effects
    )
)]

pub mod diag;
pub mod leds;
pub mod mailbox;
pub mod od;
pub mod params;
pub mod pdo;
pub mod slave;

/// The EtherCAT state machine (it lives with the slave whose state it drives).
pub use slave::esm;

#[cfg(test)]
pub(crate) mod test_profiles;
