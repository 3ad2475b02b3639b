//! DOMAIN objects whose data lives outside the OD RAM ([`Value::Domain`](crate::od::Value)).
//!
//! A domain (firmware image, parameter blob, test object 2FF0h of the standard profile) can be
//! up to 64 KiB; the SDO server streams it segment by segment through a [`DomainStore`] and never
//! buffers it whole.
//!
//! Download protocol (one segmented SDO download):
//! 1. [`DomainStore::begin_write`] with the complete size announced by the master;
//! 2. [`DomainStore::write`] for each segment, in order, at increasing offsets;
//! 3. [`DomainStore::commit`] after the last segment arrived with exactly `total` bytes — only
//!    now may the new content become visible;
//! 4. [`DomainStore::abort`] instead of `commit` whenever the transfer ends early (master abort,
//!    toggle error, size error, a new request, reset): the old content must stay intact.
//!
//! A store that cannot stage a write (no spare buffer) must answer `begin_write` with an abort
//! code rather than overwrite the old content in place.

use super::abort::AbortCode;

/// Storage of domain data, addressed by the domain id of [`Value::Domain`](crate::od::Value).
pub trait DomainStore {
    /// The current size of domain `id` in bytes.
    fn size(&mut self, id: u8) -> Result<u32, AbortCode>;
    /// Reads up to `buf.len()` bytes of domain `id` from `offset`; returns how many were read
    /// (fewer only at the end of the domain).
    fn read(&mut self, id: u8, offset: u32, buf: &mut [u8]) -> Result<usize, AbortCode>;
    /// Starts a download of `total` bytes to domain `id` (refuse with 0x06070012 if it cannot
    /// hold them).
    fn begin_write(&mut self, id: u8, total: u32) -> Result<(), AbortCode>;
    /// Stores `data` at `offset` of the download in progress.
    fn write(&mut self, id: u8, offset: u32, data: &[u8]) -> Result<(), AbortCode>;
    /// Makes the complete download of `total` bytes the domain's content.
    fn commit(&mut self, id: u8, total: u32) -> Result<(), AbortCode>;
    /// Drops the download in progress; the previous content stays.
    fn abort(&mut self, id: u8);
}

/// A board without domain storage: every domain access is refused (reads with 0x06010000
/// "unsupported access", writes with 0x08000020 "data cannot be stored"). The target uses this
/// until a flash-backed store exists.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NoDomains;

impl DomainStore for NoDomains {
    fn size(&mut self, _id: u8) -> Result<u32, AbortCode> {
        Err(AbortCode::UnsupportedAccess)
    }
    fn read(&mut self, _id: u8, _offset: u32, _buf: &mut [u8]) -> Result<usize, AbortCode> {
        Err(AbortCode::UnsupportedAccess)
    }
    fn begin_write(&mut self, _id: u8, _total: u32) -> Result<(), AbortCode> {
        Err(AbortCode::DataNotStored)
    }
    fn write(&mut self, _id: u8, _offset: u32, _data: &[u8]) -> Result<(), AbortCode> {
        Err(AbortCode::DataNotStored)
    }
    fn commit(&mut self, _id: u8, _total: u32) -> Result<(), AbortCode> {
        Err(AbortCode::DataNotStored)
    }
    fn abort(&mut self, _id: u8) {}
}

/// A `no_std`, allocation-free store of one domain (id 0) of up to `N` bytes with a staging
/// copy: the committed content and the download in progress live in separate arrays, so an
/// aborted download leaves the old content. Meant for tests and small domains.
#[derive(Clone, Debug)]
pub struct RamDomain<const N: usize> {
    data: [u8; N],
    len: usize,
    staging: [u8; N],
    staging_total: Option<usize>,
}

impl<const N: usize> RamDomain<N> {
    /// An empty domain.
    pub const fn new() -> Self {
        Self {
            data: [0; N],
            len: 0,
            staging: [0; N],
            staging_total: None,
        }
    }

    /// The committed content.
    pub fn content(&self) -> &[u8] {
        self.data.get(..self.len).unwrap_or_default()
    }

    /// Whether a download is staged (begun, neither committed nor aborted).
    pub fn writing(&self) -> bool {
        self.staging_total.is_some()
    }

    fn check_id(id: u8) -> Result<(), AbortCode> {
        if id == 0 {
            Ok(())
        } else {
            Err(AbortCode::ObjectNotFound)
        }
    }
}

impl<const N: usize> Default for RamDomain<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> DomainStore for RamDomain<N> {
    fn size(&mut self, id: u8) -> Result<u32, AbortCode> {
        Self::check_id(id)?;
        u32::try_from(self.len).map_err(|_| AbortCode::General)
    }

    fn read(&mut self, id: u8, offset: u32, buf: &mut [u8]) -> Result<usize, AbortCode> {
        Self::check_id(id)?;
        let rest = usize::try_from(offset)
            .ok()
            .and_then(|o| self.content().get(o..))
            .ok_or(AbortCode::General)?;
        let n = rest.len().min(buf.len());
        if let (Some(dst), Some(src)) = (buf.get_mut(..n), rest.get(..n)) {
            dst.copy_from_slice(src);
        }
        Ok(n)
    }

    fn begin_write(&mut self, id: u8, total: u32) -> Result<(), AbortCode> {
        Self::check_id(id)?;
        let total = usize::try_from(total).map_err(|_| AbortCode::LengthTooHigh)?;
        if total > N {
            return Err(AbortCode::LengthTooHigh);
        }
        self.staging_total = Some(total);
        Ok(())
    }

    fn write(&mut self, id: u8, offset: u32, data: &[u8]) -> Result<(), AbortCode> {
        Self::check_id(id)?;
        let total = self.staging_total.ok_or(AbortCode::General)?;
        let start = usize::try_from(offset).map_err(|_| AbortCode::LengthTooHigh)?;
        let end = start
            .checked_add(data.len())
            .filter(|&end| end <= total)
            .ok_or(AbortCode::LengthTooHigh)?;
        self.staging
            .get_mut(start..end)
            .ok_or(AbortCode::LengthTooHigh)?
            .copy_from_slice(data);
        Ok(())
    }

    fn commit(&mut self, id: u8, total: u32) -> Result<(), AbortCode> {
        Self::check_id(id)?;
        let staged = self.staging_total.take().ok_or(AbortCode::General)?;
        if usize::try_from(total).ok() != Some(staged) {
            return Err(AbortCode::LengthMismatch);
        }
        let (Some(dst), Some(src)) = (self.data.get_mut(..staged), self.staging.get(..staged))
        else {
            return Err(AbortCode::General);
        };
        dst.copy_from_slice(src);
        self.len = staged;
        Ok(())
    }

    fn abort(&mut self, _id: u8) {
        self.staging_total = None;
    }
}
