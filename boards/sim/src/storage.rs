//! The simulated board's parameter storage: [`SimStorage`], two flash-like slots in RAM with
//! fault injection ("cut the power after N bytes of the next write").
//!
//! It behaves as `hal::storage::NvStorage` asks of a board: a write erases the slot (every byte
//! becomes [`ERASED`], as on NOR flash) and programs the data from the slot's start, so a write
//! interrupted by a power loss leaves a prefix of the new data followed by erased bytes.

use hal::storage::{NvStorage, StorageError};

/// Value of an erased byte (NOR flash erases to all ones).
pub const ERASED: u8 = 0xFF;
/// Slots of the simulated storage (the firmware's parameter store uses two).
pub const SIM_SLOTS: usize = 2;
/// Size of one flash page of the STM32G4 internal flash: the slot of [`SimStorage::new`], and
/// the unit [`SimStorage::for_record`] sizes its slots in.
pub const SIM_SLOT_SIZE: usize = 2048;

/// RAM-backed storage that survives [`crate::drive::SimDrive::power_cycle`].
#[derive(Clone, Debug)]
pub struct SimStorage {
    slots: Vec<Vec<u8>>,
    slot_size: usize,
    cut_after: Option<usize>,
    failing: bool,
    writes: u32,
    power_cuts: u32,
}

impl Default for SimStorage {
    fn default() -> Self {
        Self::new()
    }
}

impl SimStorage {
    /// Erased storage of [`SIM_SLOTS`] slots of [`SIM_SLOT_SIZE`] bytes.
    pub fn new() -> Self {
        Self::with_slot_size(SIM_SLOT_SIZE)
    }

    /// Erased storage whose slots span as many pages as a parameter record of `record_len`
    /// bytes needs (at least one): what a board that compiles one profile reserves for it (the
    /// vendor profiles store up to ≈ 4.5 KiB, see `firmware::params::max_record_len`).
    pub fn for_record(record_len: usize) -> Self {
        Self::with_slot_size(record_len.div_ceil(SIM_SLOT_SIZE).max(1) * SIM_SLOT_SIZE)
    }

    fn with_slot_size(slot_size: usize) -> Self {
        Self {
            slots: vec![vec![ERASED; slot_size]; SIM_SLOTS],
            slot_size,
            cut_after: None,
            failing: false,
            writes: 0,
            power_cuts: 0,
        }
    }

    /// Cuts the power after `bytes` bytes of the next write: the slot is erased, only the first
    /// `bytes` bytes are programmed, and the write fails with [`StorageError::Device`] (the
    /// firmware of a real board would not run any more; the caller power-cycles the drive next).
    /// `bytes` at or beyond the write's length lets the write complete.
    pub fn cut_power_after(&mut self, bytes: usize) {
        self.cut_after = Some(bytes);
    }

    /// Makes every access fail with [`StorageError::Device`] (a broken chip) or heals it.
    pub fn set_failing(&mut self, failing: bool) {
        self.failing = failing;
    }

    /// Writes started so far (completed or cut).
    pub fn writes(&self) -> u32 {
        self.writes
    }

    /// Writes that were cut by [`Self::cut_power_after`].
    pub fn power_cuts(&self) -> u32 {
        self.power_cuts
    }

    /// The raw content of a slot.
    pub fn slot(&self, slot: usize) -> Option<&[u8]> {
        self.slots.get(slot).map(Vec::as_slice)
    }

    /// The raw content of a slot, mutable (to corrupt it in tests).
    pub fn slot_mut(&mut self, slot: usize) -> Option<&mut [u8]> {
        self.slots.get_mut(slot).map(Vec::as_mut_slice)
    }
}

impl NvStorage for SimStorage {
    fn slots(&self) -> usize {
        self.slots.len()
    }

    fn slot_size(&self) -> usize {
        self.slot_size
    }

    fn read(&mut self, slot: usize, buf: &mut [u8]) -> Result<(), StorageError> {
        if self.failing {
            return Err(StorageError::Device);
        }
        let src = self
            .slots
            .get(slot)
            .and_then(|s| s.get(..buf.len()))
            .ok_or(StorageError::OutOfRange)?;
        buf.copy_from_slice(src);
        Ok(())
    }

    fn write(&mut self, slot: usize, data: &[u8]) -> Result<(), StorageError> {
        if self.failing {
            return Err(StorageError::Device);
        }
        let dst = self.slots.get_mut(slot).ok_or(StorageError::OutOfRange)?;
        if data.len() > dst.len() {
            return Err(StorageError::OutOfRange);
        }
        self.writes += 1;
        dst.fill(ERASED);
        let n = self
            .cut_after
            .take()
            .map_or(data.len(), |k| k.min(data.len()));
        if let (Some(d), Some(s)) = (dst.get_mut(..n), data.get(..n)) {
            d.copy_from_slice(s);
        }
        if n < data.len() {
            self.power_cuts += 1;
            return Err(StorageError::Device);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn write_erases_then_programs_from_the_start() {
        let mut s = SimStorage::new();
        s.write(1, &[1, 2, 3]).unwrap();
        s.write(1, &[9]).unwrap();
        let mut b = [0u8; 4];
        s.read(1, &mut b).unwrap();
        assert_eq!(b, [9, ERASED, ERASED, ERASED]);
        assert_eq!(s.slot(0).unwrap()[0], ERASED);
        assert_eq!(s.writes(), 2);
    }

    #[test]
    fn power_cut_leaves_a_prefix_and_erased_bytes() {
        let mut s = SimStorage::new();
        s.write(0, &[7; 8]).unwrap();
        s.cut_power_after(3);
        assert_eq!(s.write(0, &[1, 2, 3, 4, 5]), Err(StorageError::Device));
        assert_eq!(&s.slot(0).unwrap()[..6], &[1, 2, 3, ERASED, ERASED, ERASED]);
        assert_eq!(s.power_cuts(), 1);
        // The cut applies to one write only.
        s.write(0, &[1, 2, 3, 4, 5]).unwrap();
        assert_eq!(&s.slot(0).unwrap()[..5], &[1, 2, 3, 4, 5]);
    }

    #[test]
    fn slots_for_a_record_are_whole_pages() {
        assert_eq!(SimStorage::for_record(0).slot_size(), SIM_SLOT_SIZE);
        assert_eq!(
            SimStorage::for_record(SIM_SLOT_SIZE).slot_size(),
            SIM_SLOT_SIZE
        );
        let s = SimStorage::for_record(SIM_SLOT_SIZE + 1);
        assert_eq!(s.slot_size(), 2 * SIM_SLOT_SIZE);
        assert_eq!(s.slot(1).map(<[u8]>::len), Some(2 * SIM_SLOT_SIZE));
    }

    #[test]
    fn out_of_range_and_failing_accesses_are_errors() {
        let mut s = SimStorage::new();
        assert_eq!(s.write(2, &[1]), Err(StorageError::OutOfRange));
        assert_eq!(
            s.write(0, &[0; SIM_SLOT_SIZE + 1]),
            Err(StorageError::OutOfRange)
        );
        let mut big = [0u8; SIM_SLOT_SIZE + 1];
        assert_eq!(s.read(0, &mut big), Err(StorageError::OutOfRange));
        s.set_failing(true);
        assert_eq!(s.read(0, &mut [0u8; 1]), Err(StorageError::Device));
        assert_eq!(s.write(0, &[1]), Err(StorageError::Device));
    }
}
