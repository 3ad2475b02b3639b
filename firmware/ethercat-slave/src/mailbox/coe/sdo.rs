//! SDO server (ETG.1000.6 §5.6.2): expedited, normal and segmented upload and download.
//!
//! Frame layouts after the 2-byte CoE header (all little-endian):
//!
//! | frame | byte 0 (command) | bytes 1..3 | byte 3 | bytes 4..8 | bytes 8.. |
//! |---|---|---|---|---|---|
//! | init request / response | ccs/scs, e, s, n, CA | index | subindex | data (expedited) or complete size | data (normal) |
//! | segment | ccs/scs, toggle, n, c | segment data (≥ 7 bytes, padded) | | | |
//! | abort | 0x80 | index | subindex | abort code | |
//!
//! A segment carries up to `mailbox size − 6 (mailbox header) − 2 (CoE header) − 1 (command)`
//! bytes; one shorter than 7 bytes is padded to 7 and its command's `n` bits give the unused
//! bytes. Every SDO frame is at least [`SDO_FRAME_LEN`] bytes.
//!
//! Segmented downloads are buffered in a [`SEGMENT_BUFFER_CAPACITY`]-byte buffer and committed to
//! the dictionary only when the last segment arrived and every check passed; segmented uploads of
//! RAM values are served from a snapshot in the same buffer, so the master never sees a torn value.
//!
//! Complete access (CA bit in the init request) is served by [`super::complete_access`] through
//! the same buffer. DOMAIN entries stored outside the OD RAM (`Value::Domain`) are streamed to and
//! from a [`DomainStore`] segment by segment (no buffer of their size): a download is begun with
//! the announced size, written per segment and committed only after the last one; any error or
//! abort in between calls [`DomainStore::abort`], leaving the old content. A domain download
//! dropped by `SdoServer::reset` is never committed (the store's next `begin_write` discards
//! its staging).

use hal::esc::AlState;

use super::access::{
    check_access, check_complete_access, find_entry, find_writable, upload_value, write_entry,
    write_found, AccessKind,
};
use super::complete_access;
use super::CoeError;
use crate::mailbox::DictionaryScope;
use crate::od::value::check_length;
use crate::od::AbortCode;
use crate::od::DomainStore;
use crate::od::{Dictionary, Entry, Object, Value};

/// Capacity in bytes of the buffer that holds a segmented download until its last segment (and
/// the snapshot of a segmented upload of a RAM value). A segmented download larger than this is
/// refused with 0x05040005 (out of memory) when the entry could hold it, else with 0x06070012.
/// It also holds a complete-access upload stream, so it is as large as the largest object
/// complete access handles.
pub const SEGMENT_BUFFER_CAPACITY: usize = super::complete_access::UNDO_CAPACITY;

/// Minimum length of an SDO frame after the CoE header: command, index, subindex and 4 data
/// bytes (ETG.1000.6 §5.6.2; mailbox length ≥ 0x0A with the CoE header).
pub const SDO_FRAME_LEN: usize = 8;
/// Offset of the complete size / expedited data in an init frame.
const INIT_DATA_OFFSET: usize = 4;
/// Offset of the data of a normal (non-expedited) init frame, after the 4-byte complete size.
const NORMAL_DATA_OFFSET: usize = 8;
/// Offset of the data in a segment frame (after the command byte).
const SEGMENT_DATA_OFFSET: usize = 1;
/// Data bytes of an expedited transfer.
const EXPEDITED_DATA_LEN: usize = 4;
/// Minimum segment data length; shorter segments are padded (ETG.1000.6 §5.6.2.3, §5.6.2.6).
const SEGMENT_MIN_DATA_LEN: usize = 7;

/// Command byte layout (ETG.1000.6 §5.6.2.1–§5.6.2.7).
mod command {
    /// Bit position of the 3-bit command specifier.
    pub const SPECIFIER_SHIFT: u8 = 5;
    /// Mask of the command specifier after shifting.
    pub const SPECIFIER_MASK: u8 = 0b111;
    /// Init frames: size indicated (`s`).
    pub const SIZE_INDICATED: u8 = 1 << 0;
    /// Init frames: expedited transfer (`e`).
    pub const EXPEDITED: u8 = 1 << 1;
    /// Init frames: bit position of the 2-bit "unused bytes of 4" count of an expedited frame.
    pub const EXPEDITED_UNUSED_SHIFT: u8 = 2;
    /// Mask of the expedited unused-bytes count after shifting.
    pub const EXPEDITED_UNUSED_MASK: u8 = 0b11;
    /// Init requests: complete access.
    pub const COMPLETE_ACCESS: u8 = 1 << 4;
    /// Segment frames: toggle bit.
    pub const TOGGLE: u8 = 1 << 4;
    /// Segment frames: last segment (`c`).
    pub const LAST_SEGMENT: u8 = 1 << 0;
    /// Segment frames: bit position of the 3-bit "unused bytes of 7" count.
    pub const SEGMENT_UNUSED_SHIFT: u8 = 1;
    /// Mask of the segment unused-bytes count after shifting.
    pub const SEGMENT_UNUSED_MASK: u8 = 0b111;
}

/// Client (master) command specifiers, ETG.1000.6 §5.6.2.
mod ccs {
    /// Download segment request.
    pub const DOWNLOAD_SEGMENT: u8 = 0;
    /// Initiate download request.
    pub const DOWNLOAD_INIT: u8 = 1;
    /// Initiate upload request.
    pub const UPLOAD_INIT: u8 = 2;
    /// Upload segment request.
    pub const UPLOAD_SEGMENT: u8 = 3;
    /// Abort transfer request.
    pub const ABORT: u8 = 4;
}

/// Server (slave) command specifiers, ETG.1000.6 §5.6.2.
mod scs {
    /// Upload segment response.
    pub const UPLOAD_SEGMENT: u8 = 0;
    /// Download segment response.
    pub const DOWNLOAD_SEGMENT: u8 = 1;
    /// Initiate upload response.
    pub const UPLOAD_INIT: u8 = 2;
    /// Initiate download response.
    pub const DOWNLOAD_INIT: u8 = 3;
    /// Abort transfer request (sent by the server).
    pub const ABORT: u8 = 4;
}

/// One SDO command byte.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Command(u8);

impl Command {
    /// Builds a command byte from a specifier and flag bits.
    const fn new(specifier: u8, flags: u8) -> Self {
        Self((specifier << command::SPECIFIER_SHIFT) | flags)
    }
    fn specifier(self) -> u8 {
        (self.0 >> command::SPECIFIER_SHIFT) & command::SPECIFIER_MASK
    }
    fn has(self, bit: u8) -> bool {
        self.0 & bit != 0
    }
    /// Data bytes of an expedited init frame with the size indicated.
    fn expedited_len(self) -> usize {
        let unused = (self.0 >> command::EXPEDITED_UNUSED_SHIFT) & command::EXPEDITED_UNUSED_MASK;
        // The 2-bit count is at most 3: never saturates.
        EXPEDITED_DATA_LEN.saturating_sub(usize::from(unused))
    }
    /// Unused (padding) bytes of a segment.
    fn segment_unused(self) -> usize {
        usize::from((self.0 >> command::SEGMENT_UNUSED_SHIFT) & command::SEGMENT_UNUSED_MASK)
    }
}

/// A parsed SDO request: the command byte, the index and subindex of an init frame (meaningless
/// in a segment) and the whole frame.
#[derive(Clone, Copy, Debug)]
struct Request<'a> {
    cmd: Command,
    index: u16,
    subindex: u8,
    frame: &'a [u8],
}

impl Request<'_> {
    /// An abort of this request's object.
    fn abort(&self, code: AbortCode) -> Abort {
        Abort {
            index: self.index,
            subindex: self.subindex,
            code,
        }
    }
}

/// The index, subindex and code of an abort to send.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Abort {
    index: u16,
    subindex: u8,
    code: AbortCode,
}

/// Where the data of a segmented upload comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum UploadSource {
    /// A constant value, read in place.
    Const(&'static [u8]),
    /// A snapshot of this many bytes in the segment buffer.
    Buffer(usize),
    /// Domain `id` of `total` bytes, read from the domain store segment by segment.
    Domain { id: u8, total: usize },
}

/// A segmented transfer in progress.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Transfer {
    /// None.
    Idle,
    /// Upload: `sent` bytes of `source` are out; the next segment request must carry `toggle`.
    Upload {
        index: u16,
        subindex: u8,
        source: UploadSource,
        sent: usize,
        toggle: bool,
    },
    /// Download of `size` bytes: `received` are in the buffer; the next segment must carry
    /// `toggle`. `complete`: a complete-access download of the whole object.
    Download {
        index: u16,
        subindex: u8,
        size: usize,
        received: usize,
        toggle: bool,
        complete: bool,
    },
    /// Download of `size` bytes to domain `id`: `received` are in the store's staging.
    DomainDownload {
        id: u8,
        index: u16,
        subindex: u8,
        size: usize,
        received: usize,
        toggle: bool,
    },
}

/// The SDO server state: the segmented transfer in progress and its buffer.
pub(super) struct SdoServer {
    transfer: Transfer,
    buffer: [u8; SEGMENT_BUFFER_CAPACITY],
    last_write: Option<(u16, u8)>,
    /// Whether [`Self::last_write`] was a complete-access download (of the object from its
    /// subindex on).
    last_write_complete: bool,
}

impl SdoServer {
    /// Whether a segmented transfer is half done (more segments to come).
    pub(super) fn in_progress(&self) -> bool {
        self.transfer != Transfer::Idle
    }

    /// Idle.
    pub(super) const fn new() -> Self {
        Self {
            transfer: Transfer::Idle,
            buffer: [0; SEGMENT_BUFFER_CAPACITY],
            last_write: None,
            last_write_complete: false,
        }
    }

    /// Drops the transfer in progress.
    pub(super) fn reset(&mut self) {
        self.transfer = Transfer::Idle;
        self.last_write = None;
        self.last_write_complete = false;
    }

    /// The entry written by the last [`Self::handle`], if it committed one.
    pub(super) fn last_write(&self) -> Option<(u16, u8)> {
        self.last_write
    }

    /// Whether [`Self::last_write`] was a complete-access download.
    pub(super) fn last_write_complete(&self) -> bool {
        self.last_write_complete
    }

    /// Handles one SDO request `req` (after the CoE header), writes the SDO response to `resp`
    /// (after the CoE header) and returns its length; `Ok(0)` when nothing is to be sent (the
    /// master aborted).
    pub(super) fn handle(
        &mut self,
        od: &mut Dictionary<'_>,
        state: AlState,
        req: &[u8],
        resp: &mut [u8],
        domains: &mut dyn DomainStore,
    ) -> Result<usize, CoeError> {
        self.last_write = None;
        self.last_write_complete = false;
        let Some(&[cmd, index_lo, index_hi, subindex, ..]) = req.first_chunk::<SDO_FRAME_LEN>()
        else {
            return Err(CoeError::SizeTooShort);
        };
        if resp.len() < SDO_FRAME_LEN {
            return Err(CoeError::NoMoreMemory);
        }
        let index = u16::from_le_bytes([index_lo, index_hi]);
        let rq = Request {
            cmd: Command(cmd),
            index,
            subindex,
            frame: req,
        };
        let specifier = rq.cmd.specifier();
        if matches!(
            specifier,
            ccs::DOWNLOAD_INIT | ccs::UPLOAD_INIT | ccs::ABORT
        ) {
            // A new transfer (or the master's abort) ends the one in progress.
            self.drop_transfer(domains);
        }
        let result = match specifier {
            ccs::DOWNLOAD_INIT => self.download_init(od, state, &rq, resp, domains),
            ccs::DOWNLOAD_SEGMENT => self.download_segment(od, state, &rq, resp, domains),
            ccs::UPLOAD_INIT => self.upload_init(od, state, &rq, resp, domains),
            ccs::UPLOAD_SEGMENT => self.upload_segment(rq.cmd, resp, domains),
            ccs::ABORT => return Ok(0),
            _ => Err(rq.abort(AbortCode::InvalidCommand)),
        };
        Ok(result.unwrap_or_else(|abort| {
            self.drop_transfer(domains);
            write_abort(resp, abort)
        }))
    }

    /// What of the OD RAM [`Self::handle`] of `req` (after the CoE header) reads or writes, in
    /// the present transfer state: the object an upload or a download names (a PDO mapping or
    /// assignment download too: its checks read the object itself and the profile's tables).
    pub(super) fn scope(&self, req: &[u8]) -> DictionaryScope {
        let Some(&[cmd, index_lo, index_hi, ..]) = req.first_chunk::<SDO_FRAME_LEN>() else {
            return DictionaryScope::Nothing;
        };
        let index = u16::from_le_bytes([index_lo, index_hi]);
        match Command(cmd).specifier() {
            ccs::UPLOAD_INIT => DictionaryScope::Object {
                index,
                download: false,
            },
            ccs::DOWNLOAD_INIT => DictionaryScope::Object {
                index,
                download: true,
            },
            // A segment commits (with its last one) to the object its transfer began on.
            ccs::DOWNLOAD_SEGMENT => match self.transfer {
                Transfer::Download { index, .. } | Transfer::DomainDownload { index, .. } => {
                    DictionaryScope::Object {
                        index,
                        download: true,
                    }
                }
                Transfer::Idle | Transfer::Upload { .. } => DictionaryScope::Nothing,
            },
            // An upload segment comes from the snapshot (or a constant, or the domain store);
            // an abort and an unknown command touch nothing.
            _ => DictionaryScope::Nothing,
        }
    }

    /// Ends the transfer in progress; a domain download is aborted in the store.
    fn drop_transfer(&mut self, domains: &mut dyn DomainStore) {
        if let Transfer::DomainDownload { id, .. } = self.transfer {
            domains.abort(id);
        }
        self.transfer = Transfer::Idle;
    }

    /// Initiate download: expedited and normal transfers commit at once, a normal transfer whose
    /// data does not fit the frame starts a segmented download. Bytes of a normal init frame
    /// beyond the announced complete size are ignored.
    fn download_init(
        &mut self,
        od: &mut Dictionary<'_>,
        state: AlState,
        rq: &Request<'_>,
        resp: &mut [u8],
        domains: &mut dyn DomainStore,
    ) -> Result<usize, Abort> {
        let Request {
            cmd,
            index,
            subindex,
            frame: req,
        } = *rq;
        let abort = |code| rq.abort(code);
        if cmd.has(command::COMPLETE_ACCESS) {
            check_complete_access(od).map_err(abort)?;
            self.download_init_complete(od, state, rq).map_err(abort)?;
            return Ok(write_download_init_response(resp, index, subindex));
        }
        let (object, entry) = find_writable(od, state, index, subindex).map_err(abort)?;
        if let Value::Domain(id) = entry.value {
            self.download_init_domain(rq, id, domains).map_err(abort)?;
            return Ok(write_download_init_response(resp, index, subindex));
        }
        if cmd.has(command::EXPEDITED) {
            let len = if cmd.has(command::SIZE_INDICATED) {
                cmd.expedited_len()
            } else {
                entry.byte_len().min(EXPEDITED_DATA_LEN)
            };
            let data = req
                .get(INIT_DATA_OFFSET..)
                .and_then(|d| d.get(..len))
                .unwrap_or_default();
            self.commit_found(od, (object, entry), index, subindex, data)
                .map_err(abort)?;
        } else {
            let size = read_size(req);
            check_length(entry, size).map_err(abort)?;
            let data = req.get(NORMAL_DATA_OFFSET..).unwrap_or_default();
            match data.get(..size) {
                Some(data) => self
                    .commit_found(od, (object, entry), index, subindex, data)
                    .map_err(abort)?,
                None => self
                    .start_download(index, subindex, size, data, false)
                    .map_err(abort)?,
            }
        }
        Ok(write_download_init_response(resp, index, subindex))
    }

    /// Initiate download with complete access: commits at once when the whole stream is in the
    /// init frame, else buffers it like a segmented download.
    fn download_init_complete(
        &mut self,
        od: &mut Dictionary<'_>,
        state: AlState,
        rq: &Request<'_>,
    ) -> Result<(), AbortCode> {
        let object = od.object(rq.index).ok_or(AbortCode::ObjectNotFound)?;
        let (size, data) = init_data(rq);
        match data.get(..size) {
            Some(stream) => {
                complete_access::download(od, state, object, rq.subindex, stream)?;
                self.last_write = Some((rq.index, rq.subindex));
                self.last_write_complete = true;
                Ok(())
            }
            None => self.start_download(rq.index, rq.subindex, size, data, true),
        }
    }

    /// Initiate download to domain `id`: begins the write in the store, writes the init
    /// frame's data and commits when that was all.
    fn download_init_domain(
        &mut self,
        rq: &Request<'_>,
        id: u8,
        domains: &mut dyn DomainStore,
    ) -> Result<(), AbortCode> {
        let (size, data) = init_data(rq);
        let total = u32::try_from(size).map_err(|_| AbortCode::LengthTooHigh)?;
        domains.begin_write(id, total)?;
        let first = data.get(..size.min(data.len())).unwrap_or_default();
        let result = domains.write(id, 0, first).and_then(|()| {
            if first.len() == size {
                domains.commit(id, total)?;
                self.last_write = Some((rq.index, rq.subindex));
            } else {
                self.transfer = Transfer::DomainDownload {
                    id,
                    index: rq.index,
                    subindex: rq.subindex,
                    size,
                    received: first.len(),
                    toggle: false,
                };
            }
            Ok(())
        });
        if result.is_err() {
            domains.abort(id);
        }
        result
    }

    /// Buffers the first part (`data`) of a segmented download of `size` bytes.
    fn start_download(
        &mut self,
        index: u16,
        subindex: u8,
        size: usize,
        data: &[u8],
        complete: bool,
    ) -> Result<(), AbortCode> {
        if size > SEGMENT_BUFFER_CAPACITY {
            return Err(AbortCode::OutOfMemory);
        }
        self.buffer
            .get_mut(..data.len())
            .ok_or(AbortCode::OutOfMemory)?
            .copy_from_slice(data);
        self.transfer = Transfer::Download {
            index,
            subindex,
            size,
            received: data.len(),
            toggle: false,
            complete,
        };
        Ok(())
    }

    /// Download segment: checks toggle and size, buffers the data, commits after the last one.
    fn download_segment(
        &mut self,
        od: &mut Dictionary<'_>,
        state: AlState,
        rq: &Request<'_>,
        resp: &mut [u8],
        domains: &mut dyn DomainStore,
    ) -> Result<usize, Abort> {
        let Request {
            cmd, frame: req, ..
        } = *rq;
        if let Transfer::DomainDownload { .. } = self.transfer {
            return self.domain_segment(cmd, req, resp, domains);
        }
        let Transfer::Download {
            index,
            subindex,
            size,
            received,
            toggle,
            complete,
        } = self.transfer
        else {
            return Err(Abort {
                index: 0,
                subindex: 0,
                code: AbortCode::InvalidCommand,
            });
        };
        let abort = |code| Abort {
            index,
            subindex,
            code,
        };
        if cmd.has(command::TOGGLE) != toggle {
            return Err(abort(AbortCode::ToggleBit));
        }
        let data = segment_data(cmd, req);
        let end = received
            .checked_add(data.len())
            .filter(|&end| end <= size)
            .ok_or(abort(AbortCode::LengthTooHigh))?;
        let dst = self
            .buffer
            .get_mut(received..end)
            .ok_or(abort(AbortCode::OutOfMemory))?;
        dst.copy_from_slice(data);
        if cmd.has(command::LAST_SEGMENT) {
            if end < size {
                return Err(abort(AbortCode::LengthTooLow));
            }
            self.transfer = Transfer::Idle;
            self.commit_buffer(od, state, index, subindex, size, complete)
                .map_err(abort)?;
        } else {
            self.transfer = Transfer::Download {
                index,
                subindex,
                size,
                received: end,
                toggle: !toggle,
                complete,
            };
        }
        Ok(write_download_segment_response(resp, toggle))
    }

    /// Download segment of a domain: checks toggle and size, writes the data to the store and
    /// commits after the last segment.
    fn domain_segment(
        &mut self,
        cmd: Command,
        req: &[u8],
        resp: &mut [u8],
        domains: &mut dyn DomainStore,
    ) -> Result<usize, Abort> {
        let Transfer::DomainDownload {
            id,
            index,
            subindex,
            size,
            received,
            toggle,
        } = self.transfer
        else {
            return Err(Abort {
                index: 0,
                subindex: 0,
                code: AbortCode::InvalidCommand,
            });
        };
        let abort = |code| Abort {
            index,
            subindex,
            code,
        };
        if cmd.has(command::TOGGLE) != toggle {
            return Err(abort(AbortCode::ToggleBit));
        }
        let data = segment_data(cmd, req);
        let end = received
            .checked_add(data.len())
            .filter(|&end| end <= size)
            .ok_or(abort(AbortCode::LengthTooHigh))?;
        let offset = u32::try_from(received).map_err(|_| abort(AbortCode::LengthTooHigh))?;
        domains.write(id, offset, data).map_err(abort)?;
        if cmd.has(command::LAST_SEGMENT) {
            if end < size {
                return Err(abort(AbortCode::LengthTooLow));
            }
            let total = u32::try_from(size).map_err(|_| abort(AbortCode::LengthTooHigh))?;
            domains.commit(id, total).map_err(abort)?;
            self.transfer = Transfer::Idle;
            self.last_write = Some((index, subindex));
        } else {
            self.transfer = Transfer::DomainDownload {
                id,
                index,
                subindex,
                size,
                received: end,
                toggle: !toggle,
            };
        }
        Ok(write_download_segment_response(resp, toggle))
    }

    /// Commits the first `size` buffered bytes.
    fn commit_buffer(
        &mut self,
        od: &mut Dictionary<'_>,
        state: AlState,
        index: u16,
        subindex: u8,
        size: usize,
        complete: bool,
    ) -> Result<(), AbortCode> {
        let data = self.buffer.get(..size).ok_or(AbortCode::OutOfMemory)?;
        if complete {
            let object = od.object(index).ok_or(AbortCode::ObjectNotFound)?;
            complete_access::download(od, state, object, subindex, data)?;
        } else {
            write_entry(od, state, index, subindex, data)?;
        }
        self.last_write = Some((index, subindex));
        self.last_write_complete = complete;
        Ok(())
    }

    /// Writes `data` to the entry `found` (`index:subindex` with its object, just returned by
    /// `find_writable` in this request) after the remaining checks, and records the write.
    fn commit_found(
        &mut self,
        od: &mut Dictionary<'_>,
        found: (&Object, &Entry),
        index: u16,
        subindex: u8,
        data: &[u8],
    ) -> Result<(), AbortCode> {
        write_found(od, found, index, subindex, data)?;
        self.last_write = Some((index, subindex));
        Ok(())
    }

    /// Initiate upload: expedited for 1..=4 bytes, else normal with as much data as fits; the
    /// rest follows in segments.
    fn upload_init(
        &mut self,
        od: &Dictionary<'_>,
        state: AlState,
        rq: &Request<'_>,
        resp: &mut [u8],
        domains: &mut dyn DomainStore,
    ) -> Result<usize, Abort> {
        let Request {
            cmd,
            index,
            subindex,
            ..
        } = *rq;
        let abort = |code| rq.abort(code);
        if cmd.has(command::COMPLETE_ACCESS) {
            check_complete_access(od).map_err(abort)?;
            let object = od.object(index).ok_or(abort(AbortCode::ObjectNotFound))?;
            let len = complete_access::upload(od, state, object, subindex, &mut self.buffer)
                .map_err(abort)?;
            return Ok(self.upload_normal(rq, UploadSource::Buffer(len), resp, domains));
        }
        let entry = find_entry(od, index, subindex).map_err(abort)?;
        check_access(entry.access, state, AccessKind::Read).map_err(abort)?;
        if let Value::Domain(id) = entry.value {
            let total = domains.size(id).map_err(abort)?;
            let total = usize::try_from(total).map_err(|_| abort(AbortCode::General))?;
            let source = UploadSource::Domain { id, total };
            return Ok(self.upload_normal(rq, source, resp, domains));
        }
        let data = upload_value(od, entry).map_err(abort)?;
        if (1..=EXPEDITED_DATA_LEN).contains(&data.len()) {
            return Ok(write_expedited_upload(resp, index, subindex, data));
        }
        let room = resp.len().saturating_sub(NORMAL_DATA_OFFSET);
        if data.len() > room {
            self.start_upload(entry, data, index, subindex, room)
                .map_err(abort)?;
        }
        let size = u32::try_from(data.len()).unwrap_or(u32::MAX).to_le_bytes();
        let cmd = Command::new(scs::UPLOAD_INIT, command::SIZE_INDICATED);
        let frame = init_frame(cmd, index, subindex, size);
        let first = data.get(..room.min(data.len())).unwrap_or_default();
        write_frame(resp, frame);
        let dst = resp
            .get_mut(NORMAL_DATA_OFFSET..)
            .and_then(|r| r.get_mut(..first.len()));
        if let Some(dst) = dst {
            dst.copy_from_slice(first);
        }
        // `first` fits the response after the frame: the sum fits too.
        NORMAL_DATA_OFFSET
            .checked_add(first.len())
            .ok_or(abort(AbortCode::General))
    }

    /// A normal upload response from `source` (buffer or domain): complete size and as much
    /// data as fits; the rest follows in segments.
    fn upload_normal(
        &mut self,
        rq: &Request<'_>,
        source: UploadSource,
        resp: &mut [u8],
        domains: &mut dyn DomainStore,
    ) -> usize {
        let total = match source {
            UploadSource::Const(bytes) => bytes.len(),
            UploadSource::Buffer(len) => len,
            UploadSource::Domain { total, .. } => total,
        };
        let room = resp.len().saturating_sub(NORMAL_DATA_OFFSET);
        let size = u32::try_from(total).unwrap_or(u32::MAX).to_le_bytes();
        let cmd = Command::new(scs::UPLOAD_INIT, command::SIZE_INDICATED);
        write_frame(resp, init_frame(cmd, rq.index, rq.subindex, size));
        let dst = resp.get_mut(NORMAL_DATA_OFFSET..).unwrap_or_default();
        let first = match self.read_source(source, 0, dst, domains) {
            Ok(n) => n,
            Err(code) => return write_abort(resp, rq.abort(code)),
        };
        if first < total {
            self.transfer = Transfer::Upload {
                index: rq.index,
                subindex: rq.subindex,
                source,
                sent: first,
                toggle: false,
            };
        }
        // `room` is what the response holds after the frame: never saturates.
        NORMAL_DATA_OFFSET.saturating_add(first.min(room))
    }

    /// Copies bytes of `source` from `offset` into `dst`; returns how many.
    fn read_source(
        &self,
        source: UploadSource,
        offset: usize,
        dst: &mut [u8],
        domains: &mut dyn DomainStore,
    ) -> Result<usize, AbortCode> {
        let data = match source {
            UploadSource::Const(bytes) => bytes,
            UploadSource::Buffer(len) => self.buffer.get(..len).unwrap_or_default(),
            UploadSource::Domain { id, total } => {
                let want = total.saturating_sub(offset).min(dst.len());
                let offset = u32::try_from(offset).map_err(|_| AbortCode::General)?;
                let dst = dst.get_mut(..want).unwrap_or_default();
                let n = domains.read(id, offset, dst)?;
                return if n == want {
                    Ok(n)
                } else {
                    Err(AbortCode::General)
                };
            }
        };
        let rest = data.get(offset..).unwrap_or_default();
        let n = rest.len().min(dst.len());
        if let (Some(d), Some(s)) = (dst.get_mut(..n), rest.get(..n)) {
            d.copy_from_slice(s);
        }
        Ok(n)
    }

    /// Records a segmented upload of `data` whose first `sent` bytes go in the init response.
    fn start_upload(
        &mut self,
        entry: &'static Entry,
        data: &[u8],
        index: u16,
        subindex: u8,
        sent: usize,
    ) -> Result<(), AbortCode> {
        let source = match entry.value {
            Value::Const(bytes) => UploadSource::Const(bytes),
            Value::Ram(_) => {
                let dst = self
                    .buffer
                    .get_mut(..data.len())
                    .ok_or(AbortCode::OutOfMemory)?;
                dst.copy_from_slice(data);
                UploadSource::Buffer(data.len())
            }
            Value::Domain(_) => return Err(AbortCode::UnsupportedAccess),
        };
        self.transfer = Transfer::Upload {
            index,
            subindex,
            source,
            sent,
            toggle: false,
        };
        Ok(())
    }

    /// Upload segment: checks the toggle and sends the next part.
    fn upload_segment(
        &mut self,
        cmd: Command,
        resp: &mut [u8],
        domains: &mut dyn DomainStore,
    ) -> Result<usize, Abort> {
        let Transfer::Upload {
            index,
            subindex,
            source,
            sent,
            toggle,
        } = self.transfer
        else {
            return Err(Abort {
                index: 0,
                subindex: 0,
                code: AbortCode::InvalidCommand,
            });
        };
        if cmd.has(command::TOGGLE) != toggle {
            return Err(Abort {
                index,
                subindex,
                code: AbortCode::ToggleBit,
            });
        }
        let total = match source {
            UploadSource::Const(bytes) => bytes.len(),
            UploadSource::Buffer(len) => len,
            UploadSource::Domain { total, .. } => total,
        };
        let room = resp.len().saturating_sub(SEGMENT_DATA_OFFSET);
        let mut chunk = [0u8; SEGMENT_BUFFER_CAPACITY];
        let want = total.saturating_sub(sent).min(room).min(chunk.len());
        let dst = chunk.get_mut(..want).unwrap_or_default();
        let n = self
            .read_source(source, sent, dst, domains)
            .map_err(|code| Abort {
                index,
                subindex,
                code,
            })?;
        let chunk = chunk.get(..n).unwrap_or_default();
        // `n` ≤ total − sent: the sum fits.
        let sent = sent.checked_add(n).ok_or(Abort {
            index,
            subindex,
            code: AbortCode::General,
        })?;
        let last = sent >= total;
        let n = write_upload_segment(resp, toggle, last, chunk);
        self.transfer = if last {
            Transfer::Idle
        } else {
            Transfer::Upload {
                index,
                subindex,
                source,
                sent,
                toggle: !toggle,
            }
        };
        Ok(n)
    }
}

/// The complete size and the data of a download init request: expedited (size from the
/// command) or normal (bytes 4..8, data from byte 8).
fn init_data<'a>(rq: &Request<'a>) -> (usize, &'a [u8]) {
    if rq.cmd.has(command::EXPEDITED) {
        let len = if rq.cmd.has(command::SIZE_INDICATED) {
            rq.cmd.expedited_len()
        } else {
            EXPEDITED_DATA_LEN
        };
        let data = rq.frame.get(INIT_DATA_OFFSET..).and_then(|d| d.get(..len));
        (len, data.unwrap_or_default())
    } else {
        let data = rq.frame.get(NORMAL_DATA_OFFSET..).unwrap_or_default();
        (read_size(rq.frame), data)
    }
}

/// The data of a download segment without its padding.
fn segment_data(cmd: Command, req: &[u8]) -> &[u8] {
    let payload = req.get(SEGMENT_DATA_OFFSET..).unwrap_or_default();
    let len = payload.len().saturating_sub(cmd.segment_unused());
    payload.get(..len).unwrap_or_default()
}

/// Writes an initiate download response and returns its length.
fn write_download_init_response(resp: &mut [u8], index: u16, subindex: u8) -> usize {
    let cmd = Command::new(scs::DOWNLOAD_INIT, 0);
    write_frame(resp, init_frame(cmd, index, subindex, [0; 4]))
}

/// Writes a download segment response echoing `toggle` and returns its length.
fn write_download_segment_response(resp: &mut [u8], toggle: bool) -> usize {
    let flags = if toggle { command::TOGGLE } else { 0 };
    let cmd = Command::new(scs::DOWNLOAD_SEGMENT, flags);
    write_frame(resp, [cmd.0, 0, 0, 0, 0, 0, 0, 0])
}

/// The complete size of a normal init request (bytes 4..8).
fn read_size(req: &[u8]) -> usize {
    let size = req
        .get(INIT_DATA_OFFSET..NORMAL_DATA_OFFSET)
        .and_then(|b| b.try_into().ok())
        .map_or(0, u32::from_le_bytes);
    usize::try_from(size).unwrap_or(usize::MAX)
}

/// An init frame: command, index, subindex, 4 data bytes.
fn init_frame(cmd: Command, index: u16, subindex: u8, data: [u8; 4]) -> [u8; SDO_FRAME_LEN] {
    let [i0, i1] = index.to_le_bytes();
    let [d0, d1, d2, d3] = data;
    [cmd.0, i0, i1, subindex, d0, d1, d2, d3]
}

/// Writes an 8-byte frame to the start of `resp` (checked to be long enough) and returns its
/// length.
fn write_frame(resp: &mut [u8], frame: [u8; SDO_FRAME_LEN]) -> usize {
    if let Some(dst) = resp.first_chunk_mut::<SDO_FRAME_LEN>() {
        *dst = frame;
    }
    SDO_FRAME_LEN
}

/// Writes an expedited upload response carrying 1..=4 bytes.
fn write_expedited_upload(resp: &mut [u8], index: u16, subindex: u8, data: &[u8]) -> usize {
    let unused = EXPEDITED_DATA_LEN.saturating_sub(data.len()) as u8;
    let flags =
        command::SIZE_INDICATED | command::EXPEDITED | (unused << command::EXPEDITED_UNUSED_SHIFT);
    let mut value = [0; EXPEDITED_DATA_LEN];
    if let Some(dst) = value.get_mut(..data.len()) {
        dst.copy_from_slice(data);
    }
    write_frame(
        resp,
        init_frame(
            Command::new(scs::UPLOAD_INIT, flags),
            index,
            subindex,
            value,
        ),
    )
}

/// Writes an upload segment response with `chunk` (padded to 7 bytes) and returns its length.
fn write_upload_segment(resp: &mut [u8], toggle: bool, last: bool, chunk: &[u8]) -> usize {
    let unused = SEGMENT_MIN_DATA_LEN.saturating_sub(chunk.len()) as u8;
    let mut flags = unused << command::SEGMENT_UNUSED_SHIFT;
    if toggle {
        flags |= command::TOGGLE;
    }
    if last {
        flags |= command::LAST_SEGMENT;
    }
    // `chunk` is at most SEGMENT_BUFFER_CAPACITY bytes: never saturates.
    let len = SEGMENT_DATA_OFFSET.saturating_add(chunk.len().max(SEGMENT_MIN_DATA_LEN));
    if let Some(frame) = resp.get_mut(..len) {
        frame.fill(0);
        if let Some((cmd, data)) = frame.split_first_mut() {
            *cmd = Command::new(scs::UPLOAD_SEGMENT, flags).0;
            if let Some(dst) = data.get_mut(..chunk.len()) {
                dst.copy_from_slice(chunk);
            }
        }
    }
    len
}

/// Writes an abort frame and returns its length.
fn write_abort(resp: &mut [u8], abort: Abort) -> usize {
    let cmd = Command::new(scs::ABORT, 0);
    write_frame(
        resp,
        init_frame(
            cmd,
            abort.index,
            abort.subindex,
            abort.code.code().to_le_bytes(),
        ),
    )
}
