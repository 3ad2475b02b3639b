//! The drive core: EtherCAT slave stack (ESM, mailbox, CoE, PDO, sync), CiA402 and motor control.
//!
//! `no_std`, generic over the [`hal`] traits; it knows no chip and no simulation. Boards call the
//! entry points of [`slave::Slave`] from their interrupts and executor tasks.
#![no_std]
#![deny(missing_docs)]

pub mod od;
pub mod profiles;
pub mod slave;
