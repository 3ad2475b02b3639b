//! CoE (CANopen over EtherCAT, ETG.1000.6 §5.6): the CoE header and the service dispatch.
//!
//! [`CoeServer::handle`] takes one mailbox payload of type CoE (after the 6-byte mailbox header)
//! and produces the CoE reply. Only the SDO service is served (see [`sdo`]); SDO information,
//! emergency and the PDO services are answered with a mailbox error by the caller
//! ([`CoeError::ServiceNotSupported`]).
//!
//! CoE header (ETG.1000.6 §5.6.1), one little-endian u16:
//!
//! | bits | 0..=8 | 9..=11 | 12..=15 |
//! |---|---|---|---|
//! | field | number | reserved | service |

pub mod abort;
pub mod pdo_rules;
pub mod sdo;
mod value;

#[cfg(test)]
mod tests;

use core::fmt;

use hal::esc::AlState;

pub use abort::AbortCode;
pub use sdo::SEGMENT_BUFFER_CAPACITY;

use crate::od::Dictionary;

/// Length of the CoE header in bytes.
pub const COE_HEADER_LEN: usize = 2;
/// Bit position of the service field in the CoE header.
const SERVICE_SHIFT: u16 = 12;

/// CoE services (ETG.1000.6 §5.6.1, CoE header service field).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum CoeService {
    /// Emergency.
    Emergency = 1,
    /// SDO request (master → slave).
    SdoRequest = 2,
    /// SDO response (slave → master).
    SdoResponse = 3,
    /// TxPDO.
    TxPdo = 4,
    /// RxPDO.
    RxPdo = 5,
    /// TxPDO remote request.
    TxPdoRemoteRequest = 6,
    /// RxPDO remote request.
    RxPdoRemoteRequest = 7,
    /// SDO information.
    SdoInformation = 8,
}

impl CoeService {
    /// Decodes the 4-bit service field; `None` for the reserved values 0 and 9..=15.
    pub const fn from_bits(bits: u8) -> Option<Self> {
        match bits {
            1 => Some(Self::Emergency),
            2 => Some(Self::SdoRequest),
            3 => Some(Self::SdoResponse),
            4 => Some(Self::TxPdo),
            5 => Some(Self::RxPdo),
            6 => Some(Self::TxPdoRemoteRequest),
            7 => Some(Self::RxPdoRemoteRequest),
            8 => Some(Self::SdoInformation),
            _ => None,
        }
    }

    /// The CoE header of a frame of this service with number 0, as it goes on the wire.
    pub const fn header(self) -> [u8; COE_HEADER_LEN] {
        ((self as u16) << SERVICE_SHIFT).to_le_bytes()
    }
}

/// Mailbox error reply codes (ETG.1000.4 §5.6, mailbox "Error Reply Service" detail codes).
mod mbx_error {
    /// The mailbox service is not supported.
    pub const SERVICE_NOT_SUPPORTED: u16 = 0x0004;
    /// The mailbox protocol header is invalid.
    pub const INVALID_HEADER: u16 = 0x0005;
    /// The mailbox data is too short.
    pub const SIZE_TOO_SHORT: u16 = 0x0006;
    /// Not enough memory to process the request.
    pub const NO_MORE_MEMORY: u16 = 0x0007;
}

/// A CoE request that is invalid at the mailbox level; the mailbox layer answers it with a
/// mailbox error reply carrying [`CoeError::mailbox_error_code`]. (Invalid SDO *content* is not an
/// error here: it is answered with an SDO abort frame.)
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CoeError {
    /// A CoE service this slave does not serve (emergency, SDO response, PDO services, SDO
    /// information). Mailbox error 0x04.
    ServiceNotSupported,
    /// The CoE header names a reserved service (0 or 9..=15). Mailbox error 0x05.
    InvalidHeader,
    /// The request is shorter than a CoE header, or than the 8-byte SDO frame. Mailbox error 0x06.
    SizeTooShort,
    /// The response buffer cannot hold an SDO frame (10 bytes with the CoE header). Mailbox
    /// error 0x07.
    NoMoreMemory,
}

impl CoeError {
    /// The mailbox error reply code (ETG.1000.4) for this error.
    pub const fn mailbox_error_code(&self) -> u16 {
        match self {
            Self::ServiceNotSupported => mbx_error::SERVICE_NOT_SUPPORTED,
            Self::InvalidHeader => mbx_error::INVALID_HEADER,
            Self::SizeTooShort => mbx_error::SIZE_TOO_SHORT,
            Self::NoMoreMemory => mbx_error::NO_MORE_MEMORY,
        }
    }
}

impl fmt::Display for CoeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let text = match self {
            Self::ServiceNotSupported => "CoE service not supported",
            Self::InvalidHeader => "invalid CoE header",
            Self::SizeTooShort => "CoE request too short",
            Self::NoMoreMemory => "CoE response buffer too small",
        };
        f.write_str(text)
    }
}

/// Bit position of the command specifier in the SDO command byte.
const SDO_CS_SHIFT: u8 = 5;
/// Command specifier of "Abort SDO Transfer" (ETG.1000.6 §5.6.2.7).
const SDO_CS_ABORT: u8 = 4;

/// The CoE server: SDO upload/download with the segmented-transfer state between requests.
///
/// Holds a [`SEGMENT_BUFFER_CAPACITY`]-byte buffer; keep one per slave (e.g. in the slave
/// struct or a `static`).
pub struct CoeServer {
    sdo: sdo::SdoServer,
}

impl CoeServer {
    /// A server with no transfer in progress.
    pub const fn new() -> Self {
        Self {
            sdo: sdo::SdoServer::new(),
        }
    }

    /// Handles one CoE request.
    ///
    /// `request` is the mailbox payload after the 6-byte mailbox header, exactly as long as the
    /// mailbox header's length field says (segment lengths are derived from it), starting at the
    /// 2-byte CoE header. The CoE response (CoE header included, service SDO response — SDO
    /// request for an abort, as ETG.1000.6 §5.6.2.7 specifies —, number 0)
    /// is written to `response` (its length = mailbox size − 6) and its length returned as
    /// `Ok(n)`; `Ok(0)` means there is nothing to send (the master aborted a transfer). SDO
    /// failures are answered with an SDO abort frame, not an `Err`. `state` is the current
    /// EtherCAT state; access rights are checked against it. Never panics on any input.
    ///
    /// After `Ok`, [`Self::last_write`] tells which entry (if any) the request wrote.
    pub fn handle(
        &mut self,
        od: &mut Dictionary<'_>,
        state: AlState,
        request: &[u8],
        response: &mut [u8],
    ) -> Result<usize, CoeError> {
        let Some((&header, sdo_request)) = request.split_first_chunk::<COE_HEADER_LEN>() else {
            return Err(CoeError::SizeTooShort);
        };
        let service = (u16::from_le_bytes(header) >> SERVICE_SHIFT) as u8;
        match CoeService::from_bits(service) {
            Some(CoeService::SdoRequest) => {}
            Some(_) => return Err(CoeError::ServiceNotSupported),
            None => return Err(CoeError::InvalidHeader),
        }
        let Some((resp_header, sdo_response)) = response.split_first_chunk_mut::<COE_HEADER_LEN>()
        else {
            return Err(CoeError::NoMoreMemory);
        };
        let n = self.sdo.handle(od, state, sdo_request, sdo_response)?;
        if n == 0 {
            return Ok(0);
        }
        // ETG.1000.6 §5.6.2.7: "Abort SDO Transfer" is an SDO *request* (service 2), whichever
        // side sends it; SOEM recognises an abort only with that service.
        let is_abort = sdo_response
            .first()
            .is_some_and(|c| c >> SDO_CS_SHIFT == SDO_CS_ABORT);
        let service = if is_abort {
            CoeService::SdoRequest
        } else {
            CoeService::SdoResponse
        };
        *resp_header = service.header();
        Ok(COE_HEADER_LEN + n)
    }

    /// Drops any segmented transfer in progress (call on a state change to INIT).
    pub fn reset(&mut self) {
        self.sdo.reset();
    }

    /// The entry `(index, subindex)` the last [`Self::handle`] call wrote to the dictionary, or
    /// `None` if it wrote nothing (an upload, an abort, a segment before the last, a failed
    /// download). A segmented download reports its entry with the last segment, when the value
    /// is committed.
    pub fn last_write(&self) -> Option<(u16, u8)> {
        self.sdo.last_write()
    }
}

impl Default for CoeServer {
    fn default() -> Self {
        Self::new()
    }
}
