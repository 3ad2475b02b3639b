//! Parameter storage (1010h/1011h) in the internal flash: the two slots of
//! [`firmware::params::ParamStore`] are the last two 2 KiB pages of flash bank 2.
//!
//! Why there: the STM32G474 ships in dual-bank mode (RM0440 §3.3.1, 2 × 256 KiB, 2 KiB pages)
//! with read-while-write between the banks (RM0440 §3.3.8), and the firmware image (≈ 35 KiB)
//! lies in bank 1, so erasing and programming a parameter page does not stall the CPU or the
//! control interrupt (a page erase takes up to 40 ms, DS12288 Table 53). `memory.x` keeps the
//! linker out of these pages.
//!
//! Power-loss safety is the record format's (two slots, sequence number, CRC-32); this module
//! only erases a page and programs it from its start, as `hal::storage::NvStorage` specifies.

use embassy_stm32::flash::{Blocking, Flash, FLASH_SIZE, WRITE_SIZE};
use hal::storage::{NvStorage, StorageError};

/// Flash page size in dual-bank mode (RM0440 §3.3.1).
const PAGE_SIZE: usize = 2048;
/// Largest parameter record a slot holds (one page): the capacity of the board's
/// `ParamStore`. Enough for the standard profile; the vendor profiles store more and need
/// slots of several pages (open: the board compiles one profile chosen at build time).
pub const SLOT_CAPACITY: usize = PAGE_SIZE;
/// Number of slots (one page each).
const SLOTS: usize = 2;
/// Offset (from the flash base) of slot 0: the last two pages of bank 2.
const FIRST_SLOT_OFFSET: usize = FLASH_SIZE - SLOTS * PAGE_SIZE;
/// Value of erased flash, used to pad the last double-word of a write.
const ERASED: u8 = 0xFF;

/// The two parameter pages.
pub struct FlashStorage {
    flash: Flash<'static, Blocking>,
}

impl FlashStorage {
    /// Takes the flash peripheral.
    pub fn new(flash: Flash<'static, Blocking>) -> Self {
        Self { flash }
    }

    fn offset(slot: usize, len: usize) -> Result<u32, StorageError> {
        if slot >= SLOTS || len > PAGE_SIZE {
            return Err(StorageError::OutOfRange);
        }
        u32::try_from(FIRST_SLOT_OFFSET + slot * PAGE_SIZE).map_err(|_| StorageError::OutOfRange)
    }
}

impl NvStorage for FlashStorage {
    fn slots(&self) -> usize {
        SLOTS
    }

    fn slot_size(&self) -> usize {
        PAGE_SIZE
    }

    fn read(&mut self, slot: usize, buf: &mut [u8]) -> Result<(), StorageError> {
        let at = Self::offset(slot, buf.len())?;
        self.flash
            .blocking_read(at, buf)
            .map_err(|_| StorageError::Device)
    }

    fn write(&mut self, slot: usize, data: &[u8]) -> Result<(), StorageError> {
        let at = Self::offset(slot, data.len())?;
        self.flash
            .blocking_erase(at, at + PAGE_SIZE as u32)
            .map_err(|_| StorageError::Device)?;
        // The flash programs whole double-words (WRITE_SIZE = 8, RM0440 §3.3.7): full chunks
        // first, then the tail padded with the erased value.
        let whole = data.len() - data.len() % WRITE_SIZE;
        let (body, tail) = data.split_at(whole);
        if !body.is_empty() {
            self.flash
                .blocking_write(at, body)
                .map_err(|_| StorageError::Device)?;
        }
        if !tail.is_empty() {
            let mut last = [ERASED; WRITE_SIZE];
            last[..tail.len()].copy_from_slice(tail);
            self.flash
                .blocking_write(at + whole as u32, &last)
                .map_err(|_| StorageError::Device)?;
        }
        Ok(())
    }
}
