//! Run-time access to a profile's object dictionary: the static description plus the OD RAM.

use super::dirty::DirtyMap;
use super::model::{Entry, Object, Profile, Value};

/// Why a value could not be read or written at the storage level.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StoreError {
    /// The entry is a constant.
    ReadOnly,
    /// The data length does not fit the entry.
    Length,
    /// The OD RAM is smaller than the profile requires (a build error, reported not panicked).
    Layout,
    /// The value is a domain outside the OD RAM (`Value::Domain`): use the domain store.
    Domain,
}

/// A profile's dictionary together with its OD RAM.
///
/// A cheap view: the owner keeps the RAM (`[u8; N]` in the slave) and builds a `Dictionary`
/// when it needs one.
pub struct Dictionary<'r> {
    profile: &'static Profile,
    ram: &'r mut [u8],
    /// Where writes are recorded, for a view over a working copy of the OD RAM.
    dirty: Option<&'r mut DirtyMap>,
    /// The OD RAM bytes the active RxPDO plan writes, where the owner knows them (see
    /// [`Self::with_rx_outputs`]).
    rx_outputs: Option<&'r [(u16, u16)]>,
}

impl<'r> Dictionary<'r> {
    /// A view of `profile` over `ram`. `ram` must be at least [`Profile::ram_size`] bytes; accesses
    /// outside it fail with [`StoreError::Layout`].
    pub fn new(profile: &'static Profile, ram: &'r mut [u8]) -> Self {
        Self {
            profile,
            ram,
            dirty: None,
            rx_outputs: None,
        }
    }

    /// A view over a working copy of the OD RAM that records in `dirty` every byte
    /// [`Self::set_value`] writes, so that exactly those can be copied back.
    pub fn tracked(profile: &'static Profile, ram: &'r mut [u8], dirty: &'r mut DirtyMap) -> Self {
        Self {
            profile,
            ram,
            dirty: Some(dirty),
            rx_outputs: None,
        }
    }

    /// The same view, told which OD RAM bytes the active RxPDO plan writes
    /// (`PdoPlan::ram_ranges` of the plan built at PREOP → SAFEOP): the SDO server then
    /// answers "mapped to an RxPDO" from them instead of searching 1C12h and 16xxh.
    pub fn with_rx_outputs(mut self, ranges: &'r [(u16, u16)]) -> Self {
        self.rx_outputs = Some(ranges);
        self
    }

    /// The OD RAM ranges of [`Self::with_rx_outputs`], if given.
    pub fn rx_outputs(&self) -> Option<&[(u16, u16)]> {
        self.rx_outputs
    }

    /// Resets every variable to its default.
    pub fn load_defaults(&mut self) {
        let n = self.profile.defaults.len().min(self.ram.len());
        if let (Some(dst), Some(src)) = (self.ram.get_mut(..n), self.profile.defaults.get(..n)) {
            dst.copy_from_slice(src);
        }
    }

    /// The profile.
    pub fn profile(&self) -> &'static Profile {
        self.profile
    }

    /// The object with this index.
    pub fn object(&self, index: u16) -> Option<&'static Object> {
        self.profile.object(index)
    }

    /// The entry `index:subindex`.
    pub fn entry(&self, index: u16, subindex: u8) -> Option<&'static Entry> {
        self.object(index).and_then(|o| o.entry(subindex))
    }

    /// The current bytes of an entry's value (its full byte length).
    pub fn value(&self, entry: &Entry) -> Result<&[u8], StoreError> {
        match entry.value {
            Value::Const(bytes) => Ok(bytes),
            Value::Domain(_) => Err(StoreError::Domain),
            Value::Ram(offset) => {
                let start = usize::from(offset);
                self.ram
                    .get(start..)
                    .and_then(|r| r.get(..entry.byte_len()))
                    .ok_or(StoreError::Layout)
            }
        }
    }

    /// Overwrites the start of an entry's value with `data` (`data` may be shorter than the entry,
    /// e.g. a shorter string; the rest is zero-filled).
    pub fn set_value(&mut self, entry: &Entry, data: &[u8]) -> Result<(), StoreError> {
        let offset = match entry.value {
            Value::Ram(offset) => offset,
            Value::Const(_) => return Err(StoreError::ReadOnly),
            Value::Domain(_) => return Err(StoreError::Domain),
        };
        let start = usize::from(offset);
        let end = start
            .checked_add(entry.byte_len())
            .ok_or(StoreError::Layout)?;
        let dst = self.ram.get_mut(start..end).ok_or(StoreError::Layout)?;
        if data.len() > dst.len() {
            return Err(StoreError::Length);
        }
        let (head, tail) = dst.split_at_mut(data.len());
        head.copy_from_slice(data);
        tail.fill(0);
        if let Some(dirty) = self.dirty.as_deref_mut() {
            // The whole entry: it goes back as one value.
            dirty.mark(start..end);
        }
        Ok(())
    }

    /// Reads an unsigned value of up to 4 bytes of `index:subindex` (0 if the entry is missing).
    pub fn read_u32(&self, index: u16, subindex: u8) -> Option<u32> {
        self.entry_u32(self.entry(index, subindex)?)
    }

    /// [`Self::read_u32`] of an entry already looked up.
    pub fn entry_u32(&self, entry: &Entry) -> Option<u32> {
        // Its first (up to) 4 bytes, little-endian: by pattern, without a variable-length copy.
        Some(match *self.value(entry).ok()? {
            [] => 0,
            [b0] => u32::from(b0),
            [b0, b1] => u32::from(u16::from_le_bytes([b0, b1])),
            [b0, b1, b2] => u32::from_le_bytes([b0, b1, b2, 0]),
            [b0, b1, b2, b3, ..] => u32::from_le_bytes([b0, b1, b2, b3]),
        })
    }

    /// The whole OD RAM (for process-data copy plans, which address it by offset).
    pub fn ram(&self) -> &[u8] {
        self.ram
    }

    /// The whole OD RAM, mutable.
    pub fn ram_mut(&mut self) -> &mut [u8] {
        self.ram
    }
}
