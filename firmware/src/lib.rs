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
//! | [`mailbox`] | mailbox data-link layer, CoE and emergencies |
//! | [`diag`] | diagnosis history 10F3h (ETG.1020 §13) |
//! | [`pdo`] | PDO mapping → copy plan, pack/unpack |
//! | [`sync`], [`supervision`] | free-run / SM-synchronous / DC configuration; sync error counting |
//! | [`leds`] | ETG.1300 RUN/ERR indicator patterns |
//! | [`od`] | object dictionary model and store; [`profiles`] the generated profiles |
//! | [`params`] | 1010h/1011h store/restore on power-loss-safe parameter storage |
//! | [`cia402`], [`app`] | the drive application |
//! | [`motor`] | motor control: FOC current loop, speed/position loops, protections, commissioning |
#![no_std]
#![deny(missing_docs)]

pub mod app;
pub mod cia402;
pub mod diag;
pub mod esm;
pub mod leds;
pub mod mailbox;
pub mod motor;
pub mod od;
pub mod params;
pub mod pdo;
pub mod profiles;
pub mod slave;
pub mod sm_check;
pub mod supervision;
pub mod sync;
