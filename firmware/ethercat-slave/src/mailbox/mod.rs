//! Mailbox: the data-link layer over SM0/SM1 ([`dll`]), the mailbox header ([`header`]) and the
//! protocols on top of it ([`coe`], emergencies in [`emcy`]).

pub mod coe;
pub mod dll;
pub mod emcy;
pub mod header;

pub use dll::Mailbox;
