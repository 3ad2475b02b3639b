//! The PDI side: `hal::pdi::EscPdi` for the simulated ESC (the ET1100's SPI PDI).
//!
//! Every access returns the AL event request register as it was when the access began (SPI
//! address phase), retriggers the PDI watchdog and has the PDI's register rights and side effects
//! (reading 0x0120 clears AL event bit 0, reading an SM activate byte acknowledges bit 4, reading
//! 0x098E/F clears SYNC status, reading 0x0440 clears bit 6, SM buffers with mailbox / 3-buffer
//! semantics). An access beyond 0x2FFF is `OutOfRange`; while the PDI is down (bad SII checksum)
//! every access fails with `NotOperational` (on silicon the SPI would not answer).

use hal::esc::AlEvent;
use hal::pdi::{EscPdi, PdiError, PdiErrorKind};

use super::access::{Effects, Side};
use super::consts::ADDRESS_SPACE;
use super::Et1100;

/// Why a simulated PDI access failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SimPdiError {
    /// The byte range leaves the ESC address space (0x0000..0x2FFF).
    OutOfRange {
        /// First address.
        addr: u16,
        /// Length in bytes.
        len: usize,
    },
    /// The PDI did not come up (SII configuration area checksum error).
    NotOperational,
}

impl PdiError for SimPdiError {
    fn kind(&self) -> PdiErrorKind {
        match self {
            Self::OutOfRange { .. } => PdiErrorKind::OutOfRange,
            Self::NotOperational => PdiErrorKind::Bus,
        }
    }
}

impl core::fmt::Display for SimPdiError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::OutOfRange { addr, len } => {
                write!(f, "PDI access {addr:#06x}+{len} out of range")
            }
            Self::NotOperational => write!(f, "PDI not operational (SII checksum error)"),
        }
    }
}

impl std::error::Error for SimPdiError {}

impl Et1100 {
    fn pdi_begin(&mut self, addr: u16, len: usize) -> Result<AlEvent, SimPdiError> {
        if usize::from(addr) + len > ADDRESS_SPACE {
            return Err(SimPdiError::OutOfRange { addr, len });
        }
        if !self.pdi_operational {
            return Err(SimPdiError::NotOperational);
        }
        let ev = AlEvent(self.al_event());
        self.watchdog_pdi_trigger();
        Ok(ev)
    }
}

impl EscPdi for Et1100 {
    type Error = SimPdiError;

    fn read(&mut self, addr: u16, buf: &mut [u8]) -> Result<AlEvent, Self::Error> {
        let ev = self.pdi_begin(addr, buf.len())?;
        buf.fill(0);
        let mut fx = Effects::at(self.now);
        self.read_range(Side::Pdi, u32::from(addr), buf, &mut fx);
        Ok(ev)
    }

    fn write(&mut self, addr: u16, data: &[u8]) -> Result<AlEvent, Self::Error> {
        let ev = self.pdi_begin(addr, data.len())?;
        let mut fx = Effects::at(self.now);
        self.write_range(Side::Pdi, u32::from(addr), data, None, &mut fx);
        self.finish_write(Side::Pdi, &mut fx);
        Ok(ev)
    }
}
