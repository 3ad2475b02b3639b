//! Sim-specific constants and ET1100 register facts that `hal::esc::regs` does not carry.
//!
//! Every value names its source (Beckhoff ESC datasheet Section I/II, ETG.1000.4) or says that it
//! is a choice of this simulation.

use hal::esc::regs;

/// Size of the ET1100 address space: registers 0x0000..0x0FFF plus 8 KiB process RAM.
pub(crate) const ADDRESS_SPACE: usize = regs::ET1100_PROCESS_RAM.end() as usize;
/// First address after the register area.
pub(crate) const REGISTER_END: u32 = regs::PROCESS_RAM_START as u32;

// ----- identity (0x0000..0x0009) -----
/// ESC type of an ET1100 (Section II 0x0000).
pub(crate) const ET1100_TYPE: u8 = 0x11;
/// Revision reported by the sim (informational only; masters print it).
pub(crate) const ET1100_REVISION: u8 = 0x00;
/// Build reported by the sim (informational only).
pub(crate) const ET1100_BUILD: u16 = 0x0003;
/// Process RAM in KiB (0x1000..0x2FFF).
pub(crate) const RAM_SIZE_KIB: u8 = 8;
/// Port descriptor: 2 bits per port; ports 0 and 1 MII (0b11), ports 2 and 3 not implemented.
pub(crate) const PORT_DESCRIPTOR: u8 = 0b0000_1111;
/// Number of physical ports modelled (0 = towards the master, 1 = towards the next slave).
pub(crate) const PORTS: u8 = 4;

// ----- reset values (Section II) -----
/// DL control reset: forwarding rule bit 0 set.
pub(crate) const DL_CONTROL_FORWARDING_RULE: u8 = 0x01;
/// DL control byte 2 reset: RX FIFO size 7.
pub(crate) const DL_CONTROL_FIFO_RESET: u8 = 0x07;
/// DL control byte 3 (0x0103) bit 0: station alias usable for FPxx addressing.
pub(crate) const DL_CONTROL_ALIAS_ENABLE: u8 = 0x01;
/// AL event mask reset value (Section II 0x0204).
pub(crate) const AL_EVENT_MASK_RESET: u32 = 0x00FF_FF0F;
/// Watchdog divider reset value: (0x09C2 + 2) x 40 ns = 100 us per tick.
pub(crate) const WATCHDOG_DIVIDER_RESET: u16 = 0x09C2;
/// PDI and process-data watchdog time reset value in ticks (100 ms at the reset divider).
pub(crate) const WATCHDOG_TIME_RESET: u16 = 1000;
/// Watchdog base clock period: 25 MHz.
pub(crate) const WATCHDOG_CLOCK_NS: u64 = 40;
/// The divider counts `divider + 2` base clocks per tick.
pub(crate) const WATCHDOG_DIVIDER_EXTRA: u64 = 2;
/// 0x0440 bit 0: process-data watchdog active or disabled (0 = expired).
pub(crate) const WATCHDOG_PD_OK: u8 = 0x01;
/// Speed counter start reset value (0x0930).
pub(crate) const SPEED_COUNTER_START_RESET: u16 = 0x1000;
/// Smallest legal speed counter start (Section II 0x0930).
pub(crate) const SPEED_COUNTER_START_MIN: u16 = 0x0080;
/// System time difference filter depth reset value (0x0934).
pub(crate) const TIME_FILTER_DEPTH_RESET: u8 = 4;
/// Speed counter filter depth reset value (0x0935).
pub(crate) const SPEED_FILTER_DEPTH_RESET: u8 = 12;
/// Filter depths use the low nibble.
pub(crate) const FILTER_DEPTH_MASK: u8 = 0x0F;
/// AL status at power-on: INIT.
pub(crate) const AL_STATE_INIT: u8 = 0x01;
/// AL control/status state bits.
pub(crate) const AL_STATE_MASK: u8 = 0x0F;

// ----- ESC configuration 0x0141 (from SII word 0 high byte) -----
/// 0x0141 bit 0: device emulation (AL control copied to AL status by the ESC).
pub(crate) const ESC_CONFIG_DEVICE_EMULATION: u8 = 0x01;
/// 0x0141 bit 1: enhanced link detection on all ports (mirrored to DL status bit 2).
pub(crate) const ESC_CONFIG_ENHANCED_LINK: u8 = 0x02;

/// ECAT event request register 0x0210 bits (Section II).
pub(crate) mod ecat_event {
    /// DL status changed (cleared by an ECAT read of 0x0110).
    pub(crate) const DL_STATUS: u16 = 1 << 2;
    /// AL status changed (cleared by an ECAT read of 0x0130).
    pub(crate) const AL_STATUS: u16 = 1 << 3;
    /// SyncManager `n` status mirror.
    pub(crate) const fn sm(n: usize) -> u16 {
        1 << (4 + n)
    }
}

// ----- 0x0151: SYNC/LATCH PDI configuration (from SII word 1 high byte) -----
/// Address of the SYNC/LATCH configuration byte (high byte of PDI configuration 0x0150).
pub(crate) const SYNC_LATCH_CONFIG: u16 = regs::PDI_CONFIG.addr + 1;
/// 0x0151 bit 2: the SYNC0/LATCH0 pin is a SYNC0 output.
pub(crate) const SYNC0_OUTPUT: u8 = 1 << 2;
/// 0x0151 bit 3: SYNC0 is mapped to AL event request bit 2.
pub(crate) const SYNC0_TO_AL_EVENT: u8 = 1 << 3;
/// 0x0151 bit 6: the SYNC1/LATCH1 pin is a SYNC1 output.
pub(crate) const SYNC1_OUTPUT: u8 = 1 << 6;
/// 0x0151 bit 7: SYNC1 is mapped to AL event request bit 3.
pub(crate) const SYNC1_TO_AL_EVENT: u8 = 1 << 7;

// ----- DC -----
/// 0x0984 bit 0: first SYNC0 pulse not yet generated.
pub(crate) const ACT_STATUS_SYNC0_PENDING: u8 = 1 << 0;
/// 0x0984 bit 1: first SYNC1 pulse not yet generated.
pub(crate) const ACT_STATUS_SYNC1_PENDING: u8 = 1 << 1;
/// 0x0984 bit 2: start time was not in the future at activation.
pub(crate) const ACT_STATUS_START_IN_PAST: u8 = 1 << 2;
/// 0x0980 bit 0: SYNC unit assigned to the PDI (0 = ECAT writes 0x0981/0x0990/0x09A0).
pub(crate) const CYCLIC_UNIT_PDI: u8 = 0x01;
/// SYNC0/SYNC1 status bit 0 (0x098E / 0x098F).
pub(crate) const SYNC_STATUS_ACTIVE: u8 = 0x01;
/// Latch0 control (0x09A8), missing from `hal::esc::regs`.
pub(crate) const DC_LATCH_CONTROL: regs::Reg = regs::Reg::new(0x09A8, 2);
/// Sign bit of the sign-magnitude system time difference (0x092C).
pub(crate) const DIFF_SIGN: u32 = 1 << 31;
/// Largest magnitude 0x092C can hold.
pub(crate) const DIFF_MAGNITUDE_MAX: u32 = 0x7FFF_FFFF;
/// One speed-counter step of the ET1100 DC unit is a 10 ns clock.
pub(crate) const DC_CLOCK_NS: f64 = 10.0;
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
/// 0x0500 bit 0: EEPROM control offered to the PDI.
pub(crate) const EEPROM_OFFER_PDI: u8 = 0x01;
/// 0x0500 bit 1: force ECAT access (clears 0x0501 bit 0).
pub(crate) const EEPROM_FORCE_ECAT: u8 = 0x02;
/// 0x0501 bit 0: the PDI holds the EEPROM interface.
pub(crate) const EEPROM_PDI_OWNS: u8 = 0x01;
/// Bits of 0x0502..0x0503 a writer may change: write enable and command.
pub(crate) const EEPROM_CONTROL_WRITABLE: u16 = 0x0001 | 0x0700;
/// Simulated EEPROM busy time (an 8-byte I2C read at 400 kHz takes a few hundred us).
pub(crate) const EEPROM_BUSY_NS: u64 = 100_000;
/// Busy also ends after this many further frames have passed the ESC, so that a master whose
/// simulated time does not advance between polls still completes (sim choice).
pub(crate) const EEPROM_BUSY_FRAMES: u8 = 2;
/// Largest EEPROM the sim models (512 kbit, 2-byte addressing).
pub(crate) const EEPROM_MAX_BYTES: usize = 64 * 1024;
/// Bytes returned by one read command (0x0502 bit 6 set: 8-byte reads).
pub(crate) const EEPROM_READ_BYTES: usize = 8;
/// Bytes written by one write command.
pub(crate) const EEPROM_WRITE_BYTES: usize = 2;

// ----- SII -----
/// CRC-8 polynomial x^8 + x^2 + x + 1 of the SII configuration area.
pub(crate) const SII_CRC_POLY: u8 = 0x07;
/// CRC-8 initial value.
pub(crate) const SII_CRC_INIT: u8 = 0xFF;
/// Bytes covered by the CRC (words 0..6).
pub(crate) const SII_CRC_COVERED: usize = 14;
/// Byte offset of the CRC (low byte of word 7).
pub(crate) const SII_CRC_OFFSET: usize = 14;
/// SII word: PDI control / ESC configuration (-> 0x0140/0x0141).
pub(crate) const SII_WORD_PDI_CONTROL: usize = 0;
/// SII word: PDI configuration (-> 0x0150).
pub(crate) const SII_WORD_PDI_CONFIG: usize = 1;
/// SII word: SYNC pulse length (-> 0x0982).
pub(crate) const SII_WORD_SYNC_PULSE: usize = 2;
/// SII word: extended PDI configuration (-> 0x0152).
pub(crate) const SII_WORD_PDI_CONFIG_EXT: usize = 3;
/// SII word: configured station alias (-> 0x0012, power-on only).
pub(crate) const SII_WORD_ALIAS: usize = 4;
/// Value of an erased EEPROM byte.
pub(crate) const EEPROM_ERASED: u8 = 0xFF;

// ----- frame format (ETG.1000.4) -----
/// EtherType of EtherCAT.
pub(crate) const ETHERTYPE_ETHERCAT: u16 = 0x88A4;
/// Ethernet II header: destination, source, EtherType.
pub(crate) const ETH_HEADER_LEN: usize = 14;
/// Offset of the EtherType.
pub(crate) const ETHERTYPE_OFFSET: usize = 12;
/// Offset of the first source MAC byte.
pub(crate) const SRC_MAC_OFFSET: usize = 6;
/// Locally administered (U/L) bit of a MAC's first byte; the first ESC sets it on the way back.
pub(crate) const MAC_LOCALLY_ADMINISTERED: u8 = 0x02;
/// EtherCAT header length.
pub(crate) const ECAT_HEADER_LEN: usize = 2;
/// EtherCAT header: length bits.
pub(crate) const ECAT_LEN_MASK: u16 = 0x07FF;
/// EtherCAT header: type shift.
pub(crate) const ECAT_TYPE_SHIFT: u16 = 12;
/// EtherCAT header type of DLPDUs (datagrams).
pub(crate) const ECAT_TYPE_DLPDU: u16 = 1;
/// Datagram header length.
pub(crate) const DG_HEADER_LEN: usize = 10;
/// Working counter length.
pub(crate) const DG_WKC_LEN: usize = 2;
/// Datagram length field: length bits.
pub(crate) const DG_LEN_MASK: u16 = 0x07FF;
/// Datagram length field: more datagrams follow.
pub(crate) const DG_MORE_FOLLOWS: u16 = 0x8000;

// ----- timing of the ring (sim choices, symmetric so that masters' delay estimates are exact) -----
/// Time a frame needs to pass one ESC port to port (either direction, or through the closed
/// port 1 loop of the last ESC).
pub(crate) const PORT_FORWARD_DELAY_NS: u64 = 300;
/// Propagation delay of the cable between two ESCs (2 m at 5 ns/m).
pub(crate) const CABLE_DELAY_NS: u64 = 10;
