//! Hardware abstraction for the EtherCAT servo drive core.
//!
//! `hal` holds the traits the drive core (`firmware`) needs from a board and the register map of
//! the EtherCAT slave controller. It has no chip crate and no std: boards implement the traits
//! (`boards/stm32g474` on silicon, `boards/sim` on a PC), the core consumes them.
//!
//! | module | what |
//! |---|---|
//! | [`esc`] | ESC register map and typed register contents |
//! | [`pdi`] | process data interface to the ESC: byte-range access, AL event, IRQ/SYNC0 lines |
//! | [`power`] | inverter PWM, phase-current and DC-bus sensing |
//! | [`encoder`] | position encoder |
//! | [`io`] | digital inputs (limit/home switches) and status LEDs |
//! | [`storage`] | non-volatile parameter storage |
//! | [`time`] | free-running cycle counter |
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

pub mod encoder;
pub mod esc;
pub mod io;
pub mod pdi;
pub mod power;
pub mod storage;
pub mod time;
