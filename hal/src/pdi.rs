//! Process data interface (PDI): how the MCU reaches the ESC.
//!
//! # For firmware
//! Every access names a register from [`crate::esc::regs`] or a SyncManager buffer; every access
//! returns the AL event request register as it was when the access began (on an ET1100 SPI PDI it
//! is shifted out during the address phase at no cost). Accesses are bounded in time: an
//! implementation never spins forever on a dead bus, it returns an error.
//!
//! # For boards
//! `read`/`write` MUST behave like the ESC's PDI port for any byte range, including ranges that
//! span several registers, with the ESC's side effects (reading the last byte of a mailbox SM
//! buffer frees it, reading 0x0120 clears AL event bit 0, ...). Access to SyncManager buffers
//! goes through the same calls at the buffer's physical address.

use crate::esc::AlEvent;

/// What kind of failure a PDI access had.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum PdiErrorKind {
    /// The ESC did not answer within the bounded wait.
    Timeout,
    /// The bus reported a transfer error.
    Bus,
    /// Address or length outside the ESC address space.
    OutOfRange,
    /// Anything else.
    Other,
}

/// A PDI error with a generic kind (board errors keep their own detail).
pub trait PdiError: core::fmt::Debug {
    /// The generic kind.
    fn kind(&self) -> PdiErrorKind;
}

impl PdiError for core::convert::Infallible {
    fn kind(&self) -> PdiErrorKind {
        match *self {}
    }
}

/// Byte-range access to the ESC from the MCU side.
pub trait EscPdi {
    /// The board's error type.
    type Error: PdiError;

    /// Reads `buf.len()` bytes starting at ESC address `addr`.
    fn read(&mut self, addr: u16, buf: &mut [u8]) -> Result<AlEvent, Self::Error>;

    /// Writes `data` starting at ESC address `addr`.
    fn write(&mut self, addr: u16, data: &[u8]) -> Result<AlEvent, Self::Error>;

    /// Reads a little-endian u8.
    fn read_u8(&mut self, addr: u16) -> Result<u8, Self::Error> {
        let mut b = [0u8; 1];
        self.read(addr, &mut b)?;
        Ok(b[0])
    }
    /// Reads a little-endian u16.
    fn read_u16(&mut self, addr: u16) -> Result<u16, Self::Error> {
        let mut b = [0u8; 2];
        self.read(addr, &mut b)?;
        Ok(u16::from_le_bytes(b))
    }
    /// Reads a little-endian u32.
    fn read_u32(&mut self, addr: u16) -> Result<u32, Self::Error> {
        let mut b = [0u8; 4];
        self.read(addr, &mut b)?;
        Ok(u32::from_le_bytes(b))
    }
    /// Reads a little-endian u64.
    fn read_u64(&mut self, addr: u16) -> Result<u64, Self::Error> {
        let mut b = [0u8; 8];
        self.read(addr, &mut b)?;
        Ok(u64::from_le_bytes(b))
    }
    /// Writes a u8.
    fn write_u8(&mut self, addr: u16, v: u8) -> Result<(), Self::Error> {
        self.write(addr, &[v]).map(|_| ())
    }
    /// Writes a little-endian u16.
    fn write_u16(&mut self, addr: u16, v: u16) -> Result<(), Self::Error> {
        self.write(addr, &v.to_le_bytes()).map(|_| ())
    }
    /// Writes a little-endian u32.
    fn write_u32(&mut self, addr: u16, v: u32) -> Result<(), Self::Error> {
        self.write(addr, &v.to_le_bytes()).map(|_| ())
    }
}

/// The ESC's interrupt outputs as the MCU sees them.
///
/// # For boards
/// On silicon these are the IRQ pin (AL event request & AL event mask ≠ 0, active low on the
/// ET1100) and the SYNC0/SYNC1 pins wired to EXTI lines; the board calls the firmware's handlers
/// from the matching interrupts. The simulated board evaluates the same conditions in software.
pub trait EscSignals {
    /// The IRQ line is asserted (some unmasked AL event is pending).
    fn irq_asserted(&mut self) -> bool;
    /// A SYNC0 pulse occurred since the last call (edge, consumed by the call).
    fn take_sync0(&mut self) -> bool;
    /// A SYNC1 pulse occurred since the last call (edge, consumed by the call).
    fn take_sync1(&mut self) -> bool;
}
