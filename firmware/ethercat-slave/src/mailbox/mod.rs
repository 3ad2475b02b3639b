//! Mailbox: the data-link layer over SM0/SM1 ([`dll`]), the mailbox header ([`header`]) and the
//! protocols on top of it ([`coe`], emergencies in [`emcy`]).

pub mod coe;
pub mod dll;
pub mod emcy;
pub mod header;

pub use dll::{Mailbox, Request};

/// Largest mailbox the stack buffers (bytes). A profile with a larger mailbox is refused at
/// INIT → PREOP with 0x0016 (`slave::esm::sm_check`) rather than overflowing a buffer; od-gen
/// refuses to generate one ([`hal::esc::MAX_FIRMWARE_MAILBOX`], the one definition).
pub const MAX_MAILBOX: usize = hal::esc::MAX_FIRMWARE_MAILBOX as usize;
