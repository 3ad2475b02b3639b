//! ET1100 over SPI (PDI): [`Et1100Spi`] implements [`hal::pdi::EscPdi`].
//!
//! # Byte-level protocol
//! Sources: Beckhoff "EtherCAT Slave Controller, Section II – Register Description / PDI"
//! (chapter "SPI Slave Interface": commands, address modes, read termination, wait state) and
//! "Section III – ET1100 Hardware Description" (SPI timing, 30 MHz maximum); cross-checked with
//! the public SOES ET1100 HAL (`addrPhase`, `ESC_CMD_*`) and Microchip's Beckhoff-SPI driver for
//! the LAN925x (3-byte address phase). No code was taken from either.
//!
//! Every access is one SPI_SEL-low frame: an *address phase* of 2 or 3 bytes, for reads one
//! *wait-state byte*, then the *data phase*. MSB first; SPI mode 3 (CPOL = 1, CPHA = 1: clock
//! idles high, data sampled on the rising edge). The mode is set on the ESC by the SII (PDI
//! configuration register 0x0150) and must match [`SPI_MODE`].
//!
//! ```text
//! 2-byte addressing, A < 0x2000 (A[12:0]):
//!   MOSI  | A[12:5] | A[4:0] C[2:0] | [0xFF wait, reads] | D0 .. Dn-1
//!   MISO  | 0x0220  | 0x0221        | (undefined)        | D0 .. Dn-1 (reads)
//! 3-byte addressing, any A (A[15:0]), required once the range reaches 0x2000:
//!   MOSI  | A[12:5] | A[4:0] 110    | A[15:13] C[2:0] 00 | [0xFF wait] | D0 .. Dn-1
//!   MISO  | 0x0220  | 0x0221        | 0x0222             | (undefined) | D0 .. Dn-1
//! C[2:0]: 000 NOP, 010 read, 011 read with wait-state byte, 100 write, 110 address extension.
//! Read data phase: MOSI is 0x00 for every byte except the last, which is 0xFF ("read
//! termination"): it tells the ESC not to prefetch past the end, which matters for the
//! side effects of reads (a mailbox buffer is released when its last byte is read).
//! ```
//!
//! The bytes shifted out during the address phase are the AL event request register
//! (0x0220–0x0222) as it was when the frame started: every access returns it as
//! [`AlEvent`] for free. In 2-byte mode bits 16..23 are not transmitted and read as 0; the
//! ET1100 has 8 SyncManagers, whose events are all in 0x0220–0x0221, so nothing is lost.
//!
//! Reads always use command 0x03 (read with a wait-state byte): the ESC needs time between the
//! last address bit and the first data bit to fetch the data (Section II/III give 240 ns for the
//! ET1100 if no wait-state byte is used). The hardware SPI streams bytes back to back and
//! cannot insert a pause, while the wait-state byte lasts 8 clocks = 376 ns at 21.25 MHz.
//!
//! # Clock
//! SPI3 runs from PCLK1 = 170 MHz; the fastest prescaler within the ET1100's 30 MHz maximum
//! (Section III, SPI timing) is 8 (`stm32g4_settings::spi::BaudRate`, at compile time): 21.25 MHz,
//! 29 % below it. One byte takes 376 ns. A 4-byte register read is 2 + 1 + 4 = 7 bytes ≈ 2.6 µs;
//! a 128-byte mailbox read ≈ 49 µs. If the board's signal integrity is doubtful, give the
//! computation a lower limit (below 21.25 MHz it takes prescaler 16, 10.6 MHz).
//!
//! # Why blocking, not DMA
//! Accesses are short (a register is a few µs) and are made from priority-ordered contexts that
//! must finish the access before they continue: the SYNC0 handler is a plain interrupt handler
//! that cannot `.await`, and every caller holds the PDI lock for the access anyway (see `irq`).
//! A DMA set-up costs about as much as a short register access. DMA pays off for mailbox-sized
//! transfers in the medium-priority context; that is the planned improvement.
//!
//! # Bounded time
//! The driver feeds SPI3's data register itself (embassy's blocking SPI spins on TXE/RXNE
//! without a limit). Each wait allows [`SPIN_LIMIT`] status-register polls without progress,
//! then ends the frame with [`Error::Timeout`]. One poll is at least 2 HCLK cycles (an APB1
//! register read), so the limit is ≥ 4,000 cycles ≈ 23.5 µs, 60 times the 64 cycles a byte
//! needs; at most ~10 cycles per poll bounds a stalled frame at ≈ 0.12 ms per byte position.
//! A dead ESC does not stall the bus (the MCU is the clock master): it reads as 0x00 (MISO has a
//! pull-down) and is detected by the probe in `main` (type register 0x0000).

use core::fmt;

use embassy_stm32::gpio::{Level, Output, Speed};
use embassy_stm32::mode::Blocking;
use embassy_stm32::pac;
use embassy_stm32::peripherals::SPI3;
use embassy_stm32::spi::{self, mode::Master, Spi};
use embassy_stm32::time::Hertz;
use embassy_stm32::Peri;
use hal::esc::AlEvent;
use hal::pdi::{EscPdi, PdiError, PdiErrorKind};

use stm32g4_axis::board;
use stm32g4_settings::spi::BaudRate;

use crate::clocks::PCLK1_HZ;

/// SPI commands C[2:0] (Section II, SPI slave interface, command table).
pub mod cmd {
    /// No operation: address phase only (returns the AL event).
    pub const NOP: u8 = 0b000;
    /// Read without wait-state byte (needs a pause before the data phase; not used here).
    #[expect(
        dead_code,
        reason = "documents the command set; reads use READ_WAIT_STATE"
    )]
    pub const READ: u8 = 0b010;
    /// Read with a following wait-state byte.
    pub const READ_WAIT_STATE: u8 = 0b011;
    /// Write.
    pub const WRITE: u8 = 0b100;
    /// Address extension: a third address/command byte follows.
    pub const ADDRESS_EXTENSION: u8 = 0b110;
}

/// MOSI value of the wait-state byte.
const WAIT_STATE_BYTE: u8 = 0xFF;
/// MOSI value of every read data byte except the last.
const READ_NEXT: u8 = 0x00;
/// MOSI value of the last read data byte.
const READ_TERMINATION: u8 = 0xFF;
/// First address that needs 3-byte addressing (2-byte mode carries A[12:0]).
const TWO_BYTE_ADDRESS_LIMIT: u32 = 0x2000;
/// Size of the ESC address space (A[15:0]).
const ADDRESS_SPACE: u32 = 0x1_0000;

/// SPI mode of the PDI (must match the SII PDI configuration, register 0x0150).
pub const SPI_MODE: spi::Mode = spi::MODE_3;
/// SPI3's baud rate (`stm32g4_axis::board`: the fastest PCLK1 / 2^(BR + 1) within the ET1100's
/// maximum).
const SPI_BAUD_RATE: BaudRate = board::PDI_SPI_BAUD_RATE;
/// SPI clock.
pub const SPI_CLOCK_HZ: u32 = SPI_BAUD_RATE.sck_hz;
// The board description computed the rate from the core clock: APB1 runs at it.
const _: () = assert!(PCLK1_HZ == board::CORE_CLOCK_HZ);

/// Bytes that may be in flight (written to TXFIFO but not yet read from RXFIFO). The RXFIFO
/// holds 4 bytes (RM0440 §39.5.9, 32-bit FIFOs), so at most 4 in flight can never overrun it.
const MAX_IN_FLIGHT: usize = 4;
/// Status polls without progress before a frame is abandoned (see "Bounded time").
pub const SPIN_LIMIT: u32 = 2_000;
/// SPI_SEL high time kept after every frame, in core cycles: 100 cycles ≈ 0.59 µs at 170 MHz.
/// [verify] against the SPI_SEL deassertion time in Section III (ET1100 SPI timing table);
/// the value is kept well above one SPI clock period on purpose.
const CS_HIGH_CYCLES: u32 = 100;

/// Which part of a frame failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum Phase {
    /// Address phase (including the wait-state byte).
    Address,
    /// Data phase.
    Data,
    /// Waiting for the last bit to leave the shift register.
    Drain,
}

/// What SPI3 flagged.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum BusFault {
    /// RX overrun (OVR).
    Overrun,
    /// Mode fault (MODF): NSS pulled low while master.
    ModeFault,
    /// TI-mode frame format error (FRE).
    Framing,
}

/// Errors of the ET1100 SPI PDI.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum Error {
    /// SPI3 made no progress for [`SPIN_LIMIT`] polls.
    Timeout {
        /// Where the frame stopped.
        phase: Phase,
        /// Address of the access.
        addr: u16,
    },
    /// SPI3 reported an error flag.
    Bus {
        /// The flag.
        fault: BusFault,
        /// Address of the access.
        addr: u16,
    },
    /// The range leaves the 64 KiB ESC address space.
    OutOfRange {
        /// First address.
        addr: u16,
        /// Length in bytes.
        len: usize,
    },
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Error::Timeout { phase, addr } => {
                write!(f, "ET1100 SPI timeout in {phase:?} phase at 0x{addr:04X}")
            }
            Error::Bus { fault, addr } => write!(f, "ET1100 SPI {fault:?} at 0x{addr:04X}"),
            Error::OutOfRange { addr, len } => {
                write!(f, "ESC range 0x{addr:04X}+{len} outside 0x0000..=0xFFFF")
            }
        }
    }
}

impl PdiError for Error {
    fn kind(&self) -> PdiErrorKind {
        match self {
            Error::Timeout { .. } => PdiErrorKind::Timeout,
            Error::Bus { .. } => PdiErrorKind::Bus,
            Error::OutOfRange { .. } => PdiErrorKind::OutOfRange,
        }
    }
}

/// Direction of a frame's data phase.
enum Data<'a> {
    Read(&'a mut [u8]),
    Write(&'a [u8]),
    None,
}

impl Data<'_> {
    fn len(&self) -> usize {
        match self {
            Data::Read(b) => b.len(),
            Data::Write(b) => b.len(),
            Data::None => 0,
        }
    }
}

/// Address phase of one frame: up to 3 address/command bytes and the wait-state byte.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Header {
    bytes: [u8; 4],
    /// Address/command bytes (2 or 3): the MISO bytes at these positions are the AL event.
    addr_len: usize,
    /// `addr_len` plus the wait-state byte, if any.
    len: usize,
}

impl Header {
    /// Encodes the address phase of an access of `len` bytes at `addr` with command `command`.
    /// 2-byte addressing if the whole range is below 0x2000, else 3-byte addressing.
    const fn new(addr: u16, len: usize, command: u8) -> Self {
        let a = addr;
        let last = addr as u32 + len.saturating_sub(1) as u32;
        let mut bytes = [0u8; 4];
        bytes[0] = (a >> 5) as u8; // A[12:5]; A[15:13] fall off here and go to byte 2.
        let addr_len = if last < TWO_BYTE_ADDRESS_LIMIT {
            bytes[1] = ((a & 0x1F) as u8) << 3 | command;
            2
        } else {
            bytes[1] = ((a & 0x1F) as u8) << 3 | cmd::ADDRESS_EXTENSION;
            bytes[2] = ((a >> 8) as u8 & 0xE0) | command << 2;
            3
        };
        let mut len = addr_len;
        if command == cmd::READ_WAIT_STATE {
            bytes[len] = WAIT_STATE_BYTE;
            len += 1;
        }
        Header {
            bytes,
            addr_len,
            len,
        }
    }
}

/// The ET1100 on SPI3 with a GPIO chip select.
pub struct Et1100Spi<'d> {
    /// Owns SPI3: keeps its clock on, its pins in AF mode and CR1/CR2 as embassy set them
    /// (master, mode 3, 8-bit frames, RXNE at 8 bits, software NSS). Frames are then clocked
    /// through `regs` directly.
    spi: Spi<'d, Blocking, Master>,
    regs: pac::spi::Spi,
    cs: Output<'d>,
}

impl<'d> Et1100Spi<'d> {
    /// Configures SPI3 and the chip select. The ESC is deselected on return.
    pub fn new(
        spi: Peri<'d, SPI3>,
        sck: Peri<'d, embassy_stm32::peripherals::PC10>,
        miso: Peri<'d, embassy_stm32::peripherals::PC11>,
        mosi: Peri<'d, embassy_stm32::peripherals::PC12>,
        cs: Peri<'d, embassy_stm32::peripherals::PA15>,
    ) -> Self {
        // Deselect first, then bring up the bus.
        let cs = Output::new(cs, Level::High, Speed::VeryHigh);
        let mut config = spi::Config::default();
        config.mode = SPI_MODE;
        config.bit_order = spi::BitOrder::MsbFirst;
        config.frequency = Hertz(SPI_CLOCK_HZ);
        config.miso_pull = embassy_stm32::gpio::Pull::Down;
        config.gpio_speed = Speed::VeryHigh;
        let spi = Spi::new_blocking(spi, sck, mosi, miso, config);
        Self {
            spi,
            regs: pac::SPI3,
            cs,
        }
    }

    /// The SPI clock actually configured (for the start-up log).
    pub fn clock_hz(&self) -> u32 {
        self.spi.get_current_config().frequency.0
    }

    /// One complete frame: select, address phase, data phase, deselect.
    fn frame(&mut self, addr: u16, command: u8, data: Data<'_>) -> Result<AlEvent, Error> {
        let len = data.len();
        if u32::from(addr) + len as u32 > ADDRESS_SPACE {
            return Err(Error::OutOfRange { addr, len });
        }
        let header = Header::new(addr, len, command);

        self.flush_rx();
        self.cs.set_low();
        let result = self.clock_frame(addr, &header, data);
        let result = result.and_then(|ev| self.drain(addr).map(|()| ev));
        self.cs.set_high();
        if result.is_err() {
            self.recover();
        }
        // SPI_SEL high time before the next frame can start.
        cortex_m::asm::delay(CS_HIGH_CYCLES);
        result
    }

    /// Clocks header and data through SPI3, keeping up to [`MAX_IN_FLIGHT`] bytes queued so
    /// that the bytes follow each other without gaps.
    fn clock_frame(
        &mut self,
        addr: u16,
        header: &Header,
        mut data: Data<'_>,
    ) -> Result<AlEvent, Error> {
        let r = self.regs;
        let total = header.len + data.len();
        let data_len = data.len();
        let mut event = [0u8; 4];
        let (mut sent, mut received, mut idle) = (0usize, 0usize, 0u32);

        while received < total {
            let sr = r.sr().read();
            if let Some(fault) = fault_of(sr) {
                return Err(Error::Bus { fault, addr });
            }
            let mut progress = false;
            if sent < total && sent - received < MAX_IN_FLIGHT && sr.txe() {
                // `get`: the positions are in range (sent < total), but an index would keep a
                // panic path in the cycle interrupt (`panic-paths`).
                let byte = if sent < header.len {
                    header.bytes.get(sent).copied().unwrap_or(READ_NEXT)
                } else {
                    let i = sent - header.len;
                    match &data {
                        Data::Write(w) => w.get(i).copied().unwrap_or(0),
                        Data::Read(_) if i + 1 == data_len => READ_TERMINATION,
                        Data::Read(_) | Data::None => READ_NEXT,
                    }
                };
                r.dr8().write_value(byte);
                sent += 1;
                progress = true;
            }
            if sr.rxne() {
                let byte = r.dr8().read();
                if received < header.addr_len {
                    if let Some(e) = event.get_mut(received) {
                        *e = byte;
                    }
                } else if received >= header.len {
                    if let Some(b) = match &mut data {
                        Data::Read(buf) => buf.get_mut(received - header.len),
                        _ => None,
                    } {
                        *b = byte;
                    }
                }
                received += 1;
                progress = true;
            }
            if progress {
                idle = 0;
            } else {
                idle += 1;
                if idle > SPIN_LIMIT {
                    let phase = if received < header.len {
                        Phase::Address
                    } else {
                        Phase::Data
                    };
                    return Err(Error::Timeout { phase, addr });
                }
            }
        }
        Ok(AlEvent(u32::from_le_bytes(event)))
    }

    /// Waits until the last bit has left the shift register (BSY = 0) before SPI_SEL rises.
    fn drain(&mut self, addr: u16) -> Result<(), Error> {
        for _ in 0..SPIN_LIMIT {
            if !self.regs.sr().read().bsy() {
                return Ok(());
            }
        }
        Err(Error::Timeout {
            phase: Phase::Drain,
            addr,
        })
    }

    /// Discards stale RXFIFO bytes (at most the FIFO depth).
    fn flush_rx(&mut self) {
        for _ in 0..MAX_IN_FLIGHT {
            if !self.regs.sr().read().rxne() {
                break;
            }
            let _ = self.regs.dr8().read();
        }
    }

    /// After an error: empty the RXFIFO, clear OVR (read DR then SR, RM0440 §39.5.10) and, after
    /// a mode fault, set MSTR and SPE again (hardware clears them on MODF).
    fn recover(&mut self) {
        self.flush_rx();
        let sr = self.regs.sr().read();
        if sr.modf() {
            self.regs.cr1().modify(|w| {
                w.set_mstr(pac::spi::vals::Mstr::MASTER);
                w.set_spe(true);
            });
        }
    }
}

/// The first error flag set in `sr`, if any.
fn fault_of(sr: pac::spi::regs::Sr) -> Option<BusFault> {
    if sr.ovr() {
        Some(BusFault::Overrun)
    } else if sr.modf() {
        Some(BusFault::ModeFault)
    } else if sr.fre() {
        Some(BusFault::Framing)
    } else {
        None
    }
}

impl EscPdi for Et1100Spi<'_> {
    type Error = Error;

    fn read(&mut self, addr: u16, buf: &mut [u8]) -> Result<AlEvent, Error> {
        if buf.is_empty() {
            return self.frame(addr, cmd::NOP, Data::None);
        }
        self.frame(addr, cmd::READ_WAIT_STATE, Data::Read(buf))
    }

    fn write(&mut self, addr: u16, data: &[u8]) -> Result<AlEvent, Error> {
        if data.is_empty() {
            return self.frame(addr, cmd::NOP, Data::None);
        }
        self.frame(addr, cmd::WRITE, Data::Write(data))
    }
}

// Byte-literal checks of the address phase (evaluated at compile time: the crate has no host
// test target because embassy-stm32 does not build for the host).
const _: () = {
    // 2-byte read of AL control 0x0120: A[12:5] = 0x09, A[4:0] = 0x00, C = 011.
    let h = Header::new(0x0120, 2, cmd::READ_WAIT_STATE);
    assert!(h.addr_len == 2 && h.len == 3);
    assert!(h.bytes[0] == 0x09 && h.bytes[1] == 0x03 && h.bytes[2] == WAIT_STATE_BYTE);
    // 2-byte write of AL status 0x0130: A[4:0] = 0x10 → 0x80 | 100.
    let h = Header::new(0x0130, 2, cmd::WRITE);
    assert!(h.addr_len == 2 && h.len == 2 && h.bytes[0] == 0x09 && h.bytes[1] == 0x84);
    // 3-byte read at 0x2345: A[12:5] = 0x1A, A[4:0] = 0x05 → 0x28 | 110, A[15:13] = 001.
    let h = Header::new(0x2345, 4, cmd::READ_WAIT_STATE);
    assert!(h.addr_len == 3 && h.len == 4);
    assert!(h.bytes[0] == 0x1A && h.bytes[1] == 0x2E && h.bytes[2] == 0x2C && h.bytes[3] == 0xFF);
    // A range that starts below 0x2000 but reaches it uses 3-byte addressing.
    let h = Header::new(0x1FFE, 4, cmd::WRITE);
    assert!(h.addr_len == 3 && h.bytes[2] == 0x10);
};
