//! DOMAIN storage of the simulated drive: one growable byte vector per domain id, with a staging
//! vector per download so that an interrupted download leaves the old content (the contract of
//! [`DomainStore`]).

use firmware::mailbox::coe::{AbortCode, DomainStore};

/// Largest domain the simulator accepts (the standard profile's 2FF0h test domain: 64 KiB).
pub const SIM_DOMAIN_CAPACITY: usize = 64 * 1024;

/// Domain ids the simulator serves (od-gen numbers `storage = "domain"` entries 0, 1, ...).
pub const SIM_DOMAINS: usize = 4;

/// In-memory domains.
#[derive(Clone, Debug, Default)]
pub struct SimDomainStore {
    data: [Vec<u8>; SIM_DOMAINS],
    staging: [Option<Vec<u8>>; SIM_DOMAINS],
}

impl SimDomainStore {
    /// Empty domains.
    pub fn new() -> Self {
        Self::default()
    }

    /// The committed content of domain `id`.
    pub fn content(&self, id: u8) -> Option<&[u8]> {
        self.data.get(usize::from(id)).map(Vec::as_slice)
    }

    fn slot(&mut self, id: u8) -> Result<usize, AbortCode> {
        let i = usize::from(id);
        if i < SIM_DOMAINS {
            Ok(i)
        } else {
            Err(AbortCode::ObjectNotFound)
        }
    }
}

impl DomainStore for SimDomainStore {
    fn size(&mut self, id: u8) -> Result<u32, AbortCode> {
        let i = self.slot(id)?;
        u32::try_from(self.data[i].len()).map_err(|_| AbortCode::General)
    }

    fn read(&mut self, id: u8, offset: u32, buf: &mut [u8]) -> Result<usize, AbortCode> {
        let i = self.slot(id)?;
        let rest = self.data[i]
            .get(offset as usize..)
            .ok_or(AbortCode::General)?;
        let n = rest.len().min(buf.len());
        buf[..n].copy_from_slice(&rest[..n]);
        Ok(n)
    }

    fn begin_write(&mut self, id: u8, total: u32) -> Result<(), AbortCode> {
        let i = self.slot(id)?;
        if total as usize > SIM_DOMAIN_CAPACITY {
            return Err(AbortCode::LengthTooHigh);
        }
        self.staging[i] = Some(vec![0; total as usize]);
        Ok(())
    }

    fn write(&mut self, id: u8, offset: u32, data: &[u8]) -> Result<(), AbortCode> {
        let i = self.slot(id)?;
        let staging = self.staging[i].as_mut().ok_or(AbortCode::General)?;
        let start = offset as usize;
        staging
            .get_mut(start..start + data.len())
            .ok_or(AbortCode::LengthTooHigh)?
            .copy_from_slice(data);
        Ok(())
    }

    fn commit(&mut self, id: u8, total: u32) -> Result<(), AbortCode> {
        let i = self.slot(id)?;
        let staged = self.staging[i].take().ok_or(AbortCode::General)?;
        if staged.len() != total as usize {
            return Err(AbortCode::LengthMismatch);
        }
        self.data[i] = staged;
        Ok(())
    }

    fn abort(&mut self, id: u8) {
        if let Some(s) = self.staging.get_mut(usize::from(id)) {
            *s = None;
        }
    }
}
