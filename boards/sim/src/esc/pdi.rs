//! The PDI side: `hal::pdi::EscPdi` for the simulated ESC (the ET1100's SPI PDI).
//!
//! Every access returns the AL event request register as it was when the access began (SPI
//! address phase), retriggers the PDI watchdog and has the PDI's register rights and side effects
//! (reading 0x0120 clears AL event bit 0, reading an SM activate byte acknowledges bit 4, reading
//! 0x098E/F clears SYNC status, reading 0x0440 clears bit 6, SM buffers with mailbox / 3-buffer
//! semantics). An access beyond 0x2FFF is `OutOfRange`; while the PDI is down (bad SII checksum)
//! every access fails with `NotOperational` (on silicon the SPI would not answer).

use hal::esc::{regs, AlEvent};
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
        self.pdi_bus_ns += pdi_transfer_ns(addr, len);
        let ev = AlEvent(self.al_event());
        self.watchdog_pdi_trigger();
        Ok(ev)
    }
}

/// SPI clock the model assumes: the STM32G474 board's 170 MHz / 8 (boards/stm32g474).
const SPI_CLOCK_HZ: u64 = 21_250_000;
/// Address/command bytes of an ET1100 SPI access: 2 below 0x2000, 3 with address extension,
/// plus one wait-state byte on reads (ET1100 datasheet Sec. III, SPI slave interface).
const SPI_HEADER_BYTES: u64 = 3;
/// Chip-select deassert time between accesses (conservative, ET1100 Sec. III).
const SPI_CS_GAP_NS: u64 = 600;

/// Time one PDI access of `len` bytes takes on the SPI bus.
fn pdi_transfer_ns(_addr: u16, len: usize) -> u64 {
    const NS_PER_S: u64 = 1_000_000_000;
    let bits = 8 * (SPI_HEADER_BYTES + len as u64);
    bits * NS_PER_S / SPI_CLOCK_HZ + SPI_CS_GAP_NS
}

impl Et1100 {
    /// Modelled PDI bus time spent by all accesses so far, in ns: what an MCU on an ET1100 SPI
    /// PDI at 21.25 MHz would have spent transferring. Boards use differences of it to give the
    /// firmware a realistic duration of its process-data cycle (1C32h:06).
    pub fn pdi_bus_ns(&self) -> u64 {
        self.pdi_bus_ns
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

impl Et1100 {
    /// Fault injection: the MCU made a malformed PDI access (on the SPI PDI e.g. a frame whose
    /// clock count is not a whole number of bytes). The ET1100 counts it in the PDI error
    /// counter 0x030D (saturating at 0xFF; cleared by an ECAT write to the error counters);
    /// the access itself has no effect.
    pub fn inject_pdi_error(&mut self) {
        let count = self.u8_at(regs::PDI_ERROR_COUNTER.addr);
        self.set_u8(regs::PDI_ERROR_COUNTER.addr, count.saturating_add(1));
    }
}
