//! Choices of this simulation. Every ESC register address, bit and reset value comes from
//! `hal::esc`; what is here is either derived from it or a decision of the sim (and says so).

use hal::esc::{regs, PortDescriptor};

/// Size of the ET1100 address space: registers 0x0000..0x0FFF plus 8 KiB process RAM.
pub(crate) const ADDRESS_SPACE: usize = regs::ET1100_PROCESS_RAM.end() as usize;
/// First address after the register area.
pub(crate) const REGISTER_END: u32 = regs::PROCESS_RAM_START as u32;

// ----- identity (0x0000..0x0009) -----
/// Revision reported by the sim (informational only; masters print it).
pub(crate) const ET1100_REVISION: u8 = 0x00;
/// Build reported by the sim (informational only).
pub(crate) const ET1100_BUILD: u16 = 0x0003;
/// Port descriptor of the simulated board: ports 0 and 1 MII, ports 2 and 3 not implemented.
pub(crate) const PORT_DESCRIPTOR: PortDescriptor = PortDescriptor(0)
    .with(0, PortDescriptor::MII)
    .with(1, PortDescriptor::MII);

// ----- DC -----
/// Slowest time constant of the sim's drift loop (sim choice; converges in a few hundred 1 ms
/// FRMW cycles).
pub(crate) const TIME_LOOP_TAU_MIN_NS: f64 = 20_000_000.0;
/// Default clock drift of a fresh ESC against global time in ppm (sim choice).
pub(crate) const DEFAULT_DRIFT_PPM: f64 = 3.0;
/// Drift given to the ESC at ring position k (k mod 8) when it first sees a frame, unless the
/// clock was set explicitly: a few ppm apart, so the masters' drift compensation has work to do
/// (sim choice; quartz oscillators are specified to some ±25 ppm). Position 0 keeps the default.
pub(crate) const RING_DRIFTS_PPM: [f64; 8] =
    [DEFAULT_DRIFT_PPM, -2.0, 4.5, -3.5, 1.5, -5.0, 2.5, -1.0];
/// Power-on skew per ring position: ESC k's local clock is `k x` this much ahead of ESC 0's, so
/// the masters' offset compensation matters (sim choice).
pub(crate) const RING_POWER_ON_SKEW_NS: u64 = 1_234_567;

// ----- EEPROM interface -----
/// Simulated EEPROM busy time (an 8-byte I2C read at 400 kHz takes a few hundred us).
pub(crate) const EEPROM_BUSY_NS: u64 = 100_000;
/// Busy also ends after this many further frames have passed the ESC, so that a master whose
/// simulated time does not advance between polls still completes (sim choice).
pub(crate) const EEPROM_BUSY_FRAMES: u8 = 2;
/// Largest EEPROM the sim models (512 kbit, 2-byte addressing).
pub(crate) const EEPROM_MAX_BYTES: usize = 64 * 1024;
/// Value of an erased EEPROM byte (what the sim returns beyond the image).
pub(crate) const EEPROM_ERASED: u8 = 0xFF;

// ----- timing of the ring (sim choices, symmetric so that masters' delay estimates are exact) -----
/// Time a frame needs to pass one ESC port to port (either direction, or through the closed
/// port 1 loop of the last ESC).
pub(crate) const PORT_FORWARD_DELAY_NS: u64 = 300;
/// Propagation delay of the cable between two ESCs (2 m at 5 ns/m).
pub(crate) const CABLE_DELAY_NS: u64 = 10;
