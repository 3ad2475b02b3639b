//! The drive core: EtherCAT slave stack (ESM, mailbox, CoE, PDO, sync), CiA402 and motor control.
//!
//! `no_std`, generic over the [`hal`] traits; it knows no chip and no simulation. Boards call the
//! entry points of [`slave::Slave`] from their interrupts and executor tasks.
//!
//! | module | what |
//! |---|---|
//! | [`slave`] | the entry points and the glue between the layers |
//! | [`esm`] | EtherCAT state machine as a pure decision function |
//! | [`sm_check`] | SyncManager configuration checks |
//! | [`mailbox`] | mailbox data-link layer and CoE |
//! | [`pdo`] | PDO mapping → copy plan, pack/unpack |
//! | [`sync`] | free-run / SM-synchronous / DC configuration |
//! | [`od`] | object dictionary model and store; [`profiles`] the generated profiles |
//! | [`cia402`], [`app`] | the drive application |
#![no_std]
#![deny(missing_docs)]

pub mod app;
pub mod cia402;
pub mod esm;
pub mod mailbox;
pub mod od;
pub mod pdo;
pub mod profiles;
pub mod slave;
pub mod sm_check;
pub mod sync;
