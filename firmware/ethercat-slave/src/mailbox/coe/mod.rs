//! CoE (CANopen over EtherCAT, ETG.1000.6 §5.6): the CoE header and the service dispatch.
//!
//! [`CoeServer::handle`] takes one mailbox payload of type CoE (after the 6-byte mailbox header)
//! and produces the CoE reply. Served: SDO (see [`sdo`], with complete access in
//! [`complete_access`] and DOMAIN streaming through a [`DomainStore`]) and, when the profile
//! advertises it, SDO information ([`sdo_info`]; long responses are fragmented: the mailbox layer
//! fetches each further fragment with [`CoeServer::pending_fragment`] once SM1 is free).
//! Emergency and the PDO services are answered with a mailbox error by the caller
//! ([`CoeError::ServiceNotSupported`]).
//!
//! CoE header (ETG.1000.6 §5.6.1), one little-endian u16:
//!
//! | bits | 0..=8 | 9..=11 | 12..=15 |
//! |---|---|---|---|
//! | field | number | reserved | service |

mod access;
pub mod complete_access;
pub mod sdo;
pub mod sdo_info;

#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests_info_ca;

use core::fmt;

use hal::esc::AlState;

/// The OD access types the SDO server shares with the rest of the stack (defined in [`crate::od`]).
pub use crate::od::{AbortCode, DomainStore, DownloadHook, NoDomains, RamDomain, WithDomains};
pub use sdo::SEGMENT_BUFFER_CAPACITY;

use crate::mailbox::header::MailboxErrorCode;
use crate::mailbox::DictionaryScope;
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
            Self::ServiceNotSupported => MailboxErrorCode::ServiceNotSupported as u16,
            Self::InvalidHeader => MailboxErrorCode::InvalidHeader as u16,
            Self::SizeTooShort => MailboxErrorCode::SizeTooShort as u16,
            Self::NoMoreMemory => MailboxErrorCode::NoMoreMemory as u16,
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
    info: sdo_info::InfoServer,
}

impl CoeServer {
    /// A server with no transfer in progress.
    pub const fn new() -> Self {
        Self {
            sdo: sdo::SdoServer::new(),
            info: sdo_info::InfoServer::new(),
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
    ///
    /// Without a domain store: DOMAIN entries stored outside the OD RAM are refused (see
    /// [`NoDomains`]); use [`Self::handle_domains`] to serve them.
    pub fn handle(
        &mut self,
        od: &mut Dictionary<'_>,
        state: AlState,
        request: &[u8],
        response: &mut [u8],
    ) -> Result<usize, CoeError> {
        self.handle_domains(od, state, request, response, &mut NoDomains)
    }

    /// [`Self::handle`] with the board's domain store for `Value::Domain` entries.
    ///
    /// Any request (SDO or SDO information) drops the remaining fragments of an SDO information
    /// response in progress.
    pub fn handle_domains(
        &mut self,
        od: &mut Dictionary<'_>,
        state: AlState,
        request: &[u8],
        response: &mut [u8],
        domains: &mut dyn DomainStore,
    ) -> Result<usize, CoeError> {
        self.info.reset();
        let Some((&header, sdo_request)) = request.split_first_chunk::<COE_HEADER_LEN>() else {
            return Err(CoeError::SizeTooShort);
        };
        let service = (u16::from_le_bytes(header) >> SERVICE_SHIFT) as u8;
        match CoeService::from_bits(service) {
            Some(CoeService::SdoRequest) => {}
            Some(CoeService::SdoInformation) if od.profile().device.coe.sdo_info => {
                return self.handle_info(od, sdo_request, response);
            }
            Some(_) => return Err(CoeError::ServiceNotSupported),
            None => return Err(CoeError::InvalidHeader),
        }
        let Some((resp_header, sdo_response)) = response.split_first_chunk_mut::<COE_HEADER_LEN>()
        else {
            return Err(CoeError::NoMoreMemory);
        };
        let n = self
            .sdo
            .handle(od, state, sdo_request, sdo_response, domains)?;
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
        with_header(n)
    }

    /// [`Self::handle`], then, if the request committed a download, lets `hook` act on the
    /// written entry before the response goes out ([`DownloadHook::downloaded_complete`] after a
    /// complete-access download); a hook error replaces the download response by an SDO abort
    /// with that code (e.g. 1010h/1011h: wrong signature 0x08000020, storage failure
    /// 0x06060000, CiA 301 §7.5.2.13/14). The entry stays in [`Self::last_write`].
    pub fn handle_with<H: DownloadHook + ?Sized>(
        &mut self,
        od: &mut Dictionary<'_>,
        state: AlState,
        request: &[u8],
        response: &mut [u8],
        hook: &mut H,
    ) -> Result<usize, CoeError> {
        let n = match hook.domains() {
            Some(domains) => self.handle_domains(od, state, request, response, domains)?,
            None => self.handle(od, state, request, response)?,
        };
        let Some((index, subindex)) = self.last_write().filter(|_| n > 0) else {
            return Ok(n);
        };
        let done = if self.sdo.last_write_complete() {
            hook.downloaded_complete(od, index, subindex)
        } else {
            hook.downloaded(od, index, subindex)
        };
        match done {
            Ok(()) => Ok(n),
            Err(code) => Ok(write_abort_response(response, index, subindex, code)),
        }
    }

    /// Serves an SDO information request (after the CoE header).
    fn handle_info(
        &mut self,
        od: &Dictionary<'_>,
        request: &[u8],
        response: &mut [u8],
    ) -> Result<usize, CoeError> {
        let Some((resp_header, info_response)) = response.split_first_chunk_mut::<COE_HEADER_LEN>()
        else {
            return Err(CoeError::NoMoreMemory);
        };
        let n = self.info.handle(od.profile(), request, info_response)?;
        *resp_header = CoeService::SdoInformation.header();
        with_header(n)
    }

    /// What of the OD RAM [`Self::handle_with`] of `request` (from the CoE header on, as there)
    /// reads or writes, in the present transfer state; before the request is handled.
    pub fn scope(&self, request: &[u8]) -> DictionaryScope {
        let Some((&header, sdo_request)) = request.split_first_chunk::<COE_HEADER_LEN>() else {
            return DictionaryScope::Nothing;
        };
        let service = (u16::from_le_bytes(header) >> SERVICE_SHIFT) as u8;
        match CoeService::from_bits(service) {
            Some(CoeService::SdoRequest) => self.sdo.scope(sdo_request),
            // SDO information reads the profile's tables, no value; the other services are
            // answered with a mailbox error.
            _ => DictionaryScope::Nothing,
        }
    }

    /// Whether an SDO transfer spans mailbox rounds right now: a segmented up- or download, or
    /// SDO information fragments still to send.
    pub fn transfer_in_progress(&self) -> bool {
        self.sdo.in_progress() || self.fragment_pending()
    }

    /// Whether an SDO information response has fragments left to send.
    pub fn fragment_pending(&self) -> bool {
        self.info.fragment_pending()
    }

    /// Writes the next fragment of an SDO information response (CoE header included) to
    /// `response` (mailbox size − 6 bytes, the same as for the request that started it) and
    /// returns its length; `None` when no fragment is pending. The mailbox layer calls this
    /// each time the master has read the previous fragment from SM1.
    pub fn pending_fragment(&mut self, response: &mut [u8]) -> Option<usize> {
        let (resp_header, info_response) = response.split_first_chunk_mut::<COE_HEADER_LEN>()?;
        let n = self.info.next_fragment(info_response)?;
        *resp_header = CoeService::SdoInformation.header();
        with_header(n).ok()
    }

    /// Drops any segmented transfer or fragmented response in progress (call on a state change
    /// to INIT).
    pub fn reset(&mut self) {
        self.sdo.reset();
        self.info.reset();
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

/// The length of a response with `n` bytes after the CoE header. The inner layer wrote them
/// into the same buffer behind the header, so the sum always fits; 0x07 (no more memory)
/// stands for the case that cannot occur.
fn with_header(n: usize) -> Result<usize, CoeError> {
    COE_HEADER_LEN.checked_add(n).ok_or(CoeError::NoMoreMemory)
}

/// Writes a CoE "Abort SDO Transfer" (CoE header service SDO request, ETG.1000.6 §5.6.2.7) for
/// `index:subindex` with `code` to `response`; returns its length (0 if `response` is too
/// short, which [`CoeServer::handle`] has already excluded).
fn write_abort_response(response: &mut [u8], index: u16, subindex: u8, code: AbortCode) -> usize {
    const ABORT_LEN: usize = COE_HEADER_LEN + 8;
    let Some(frame) = response.get_mut(..ABORT_LEN) else {
        return 0;
    };
    let [h0, h1] = CoeService::SdoRequest.header();
    let [i0, i1] = index.to_le_bytes();
    let [c0, c1, c2, c3] = code.code().to_le_bytes();
    frame.copy_from_slice(&[
        h0,
        h1,
        SDO_CS_ABORT << SDO_CS_SHIFT,
        i0,
        i1,
        subindex,
        c0,
        c1,
        c2,
        c3,
    ]);
    ABORT_LEN
}
