//! Non-volatile parameter storage.
//!
//! # For boards
//! A slot is erased as a whole and written from its start; a write interrupted by a power loss
//! may leave any prefix of the new data. Higher layers make storage power-loss safe (two slots
//! with a CRC), not the board.

/// Why a storage access failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StorageError {
    /// Slot index or range outside the storage.
    OutOfRange,
    /// The device reported a failure.
    Device,
}

/// Slot-organised non-volatile memory.
pub trait NvStorage {
    /// Number of slots.
    fn slots(&self) -> usize;
    /// Size of one slot in bytes.
    fn slot_size(&self) -> usize;
    /// Reads from the start of `slot` into `buf`.
    fn read(&mut self, slot: usize, buf: &mut [u8]) -> Result<(), StorageError>;
    /// Erases `slot` and writes `data` from its start.
    fn write(&mut self, slot: usize, data: &[u8]) -> Result<(), StorageError>;
}
