//! Mailbox: the data-link layer over SM0/SM1 ([`dll`]), the mailbox header ([`header`]) and the
//! protocols on top of it ([`coe`], emergencies in [`emcy`]).

pub mod coe;
pub mod dll;
pub mod emcy;
pub mod header;

pub use dll::{Mailbox, Request};

/// What of the OD RAM the answer to a mailbox request reads or writes (the slave's mailbox side
/// loads that much of it for the request: `crate::slave::mailbox_side`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DictionaryScope {
    /// Nothing: an upload segment (served from the transfer's snapshot), an abort, SDO
    /// information (the profile's tables), a request answered with an error.
    Nothing,
    /// The entries of object `index`, and the profile's tables. After a committed download
    /// the board's download hook runs, which may reach further
    /// ([`crate::od::DownloadHook::reaches_beyond_object`]).
    Object {
        /// The object.
        index: u16,
        /// A download may be committed.
        download: bool,
    },
}

/// Largest mailbox the stack buffers (bytes). A profile with a larger mailbox is refused at
/// INIT → PREOP with 0x0016 (`slave::esm::sm_check`) rather than overflowing a buffer; od-gen
/// refuses to generate one ([`hal::esc::MAX_FIRMWARE_MAILBOX`], the one definition).
pub const MAX_MAILBOX: usize = hal::esc::MAX_FIRMWARE_MAILBOX as usize;
