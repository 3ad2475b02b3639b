//! A software Beckhoff ET1100 EtherCAT slave controller (ESC).
//!
//! [`Et1100`] models one ESC: the 4 KiB register space and 8 KiB process RAM with per-side
//! (EtherCAT / PDI) register semantics, datagram processing with working counters, FMMUs,
//! SyncManagers in mailbox and 3-buffer mode, the SII EEPROM interface, distributed clocks with
//! a drifting local clock, SYNC0/SYNC1 generation and the watchdogs. Masters reach it with whole
//! Ethernet frames ([`process_frame`], [`Segment`]); the drive core reaches it through
//! [`hal::pdi::EscPdi`] and [`hal::pdi::EscSignals`].
//!
//! # Driving simulated time
//! The ESC has no thread. The board owns the simulated clock (global ns) and
//! - calls [`Et1100::advance_to`] (or [`Segment::advance_to`]) whenever global time moves:
//!   SYNC pulses, watchdog expiries and EEPROM completion happen there;
//! - asks [`Et1100::next_event_ns`] for the next instant something will happen, so it can step
//!   from event to event;
//! - passes each frame from the master through [`process_frame`] at the current time (the
//!   frame's passage through the ring is modelled with fixed per-hop delays for the DC latches);
//! - lets the drive core access the ESC through `EscPdi` at the current time.
//!
//! # Choices where the datasheet leaves room (documented here once)
//! - Process RAM not covered by an enabled SyncManager is plain RAM for both sides.
//! - ECAT writes to registers that do not exist or are read-only are ignored but still count in
//!   the working counter (register area accesses always "succeed"); bytes beyond 0x2FFF do not
//!   exist and give no working counter.
//! - An access against an SM's direction (e.g. ECAT reading an ECAT-write SM) is not executed.
//! - ECAT-side SM buffer completions (mailbox full/empty, 3-buffer exchange) take effect at the end
//!   of the frame; PDI-side completions at once.
//! - A PDI access to a mailbox that is not executed (write to a full / read of an empty buffer)
//!   returns `Ok`; a refused read yields zero bytes, a refused write changes nothing, and the SM
//!   status byte tells the firmware why (as on silicon, where the ESC simply ignores it).
//! - The register write protection (0x0020/0x0030) and the ESC reset sequence (0x0040) are
//!   stored but not enforced.

mod access;
mod consts;
mod datagram;
mod dc;
mod eeprom;
mod fmmu;
mod frame;
mod pdi;
mod registers;
mod sm;
mod watchdog;

#[cfg(test)]
mod tests;

pub use frame::{datagrams, process_frame, DatagramSummary, FrameError, Segment};
pub use hal::esc::sii::crc8 as sii_crc8;
pub use pdi::SimPdiError;

use hal::esc::{
    regs, AlControl, AlEvent, AlState, AlStatus, DlControl, DlStatus, EcatEvent, EscConfig,
    EscFeatures,
};
use hal::pdi::EscSignals;

use consts::*;

/// One simulated ET1100.
pub struct Et1100 {
    /// Registers 0x0000..0x0FFF and process RAM 0x1000..0x2FFF, as the ESC holds them.
    mem: Box<[u8]>,
    /// The SII EEPROM image (byte image of the word-addressed EEPROM).
    sii: Vec<u8>,
    /// Buffer state of the SyncManagers.
    sm: [sm::SmState; sm::SM_COUNT],
    /// SMs whose activate byte ECAT wrote and the PDI has not yet read (AL event bit 4).
    sm_activation_changed: u8,
    /// Distributed clocks: local clock, drift loop, SYNC unit.
    dc: dc::DcUnit,
    /// Watchdog timers.
    wd: watchdog::Watchdogs,
    /// EEPROM command in progress.
    eeprom: eeprom::EepromUnit,
    /// Global simulated time in ns as last given to `advance_to`.
    now: u64,
    /// Port 1 connects to a next ESC.
    port1_connected: bool,
    /// Whether the cable towards the master (port 0) has a link (fault injection: false).
    port0_connected: bool,
    /// The local clock was set by `set_clock` or got its ring-position default.
    clock_configured: bool,
    /// The PDI came up (SII checksum good).
    pdi_operational: bool,
    /// A SYNC0 pulse happened since the last `take_sync0`.
    sync0_edge: bool,
    /// A SYNC1 pulse happened since the last `take_sync1`.
    sync1_edge: bool,
    /// Reusable buffer for read-modify-write datagrams and FMMU mapping (no per-frame alloc).
    scratch: Vec<u8>,
    /// Second reusable buffer (FMMU write masks).
    scratch_mask: Vec<u8>,
    /// Modelled PDI bus time spent so far (ns), see [`Et1100::pdi_bus_ns`].
    pdi_bus_ns: u64,
}

impl Et1100 {
    /// Powers up an ESC with the SII EEPROM image `sii` (bytes of the word-addressed EEPROM,
    /// little-endian words). Loads the configuration words into 0x0140, 0x0150, 0x0982, 0x0152
    /// and the alias into 0x0012 when the CRC in byte 14 is good; otherwise sets the checksum
    /// error (0x0502 bit 11) and leaves the PDI down.
    pub fn new(sii: &[u8]) -> Self {
        let mut esc = Self {
            mem: vec![0u8; ADDRESS_SPACE].into_boxed_slice(),
            sii: sii.to_vec(),
            sm: [sm::SmState::default(); sm::SM_COUNT],
            sm_activation_changed: 0,
            dc: dc::DcUnit::new(DEFAULT_DRIFT_PPM),
            wd: watchdog::Watchdogs::default(),
            eeprom: eeprom::EepromUnit::default(),
            now: 0,
            port1_connected: false,
            port0_connected: true,
            clock_configured: false,
            pdi_operational: false,
            sync0_edge: false,
            sync1_edge: false,
            scratch: Vec::new(),
            scratch_mask: Vec::new(),
            pdi_bus_ns: 0,
        };
        esc.power_on_registers();
        esc.load_sii_config(true);
        esc.update_dl_status();
        esc
    }

    /// Writes the reset values of the identity and configuration registers.
    fn power_on_registers(&mut self) {
        self.set_u8(regs::TYPE.addr, regs::ET1100_TYPE);
        self.set_u8(regs::REVISION.addr, ET1100_REVISION);
        self.set_u16(regs::BUILD.addr, ET1100_BUILD);
        self.set_u8(regs::FMMU_COUNT.addr, regs::ET1100_FMMUS);
        self.set_u8(regs::SM_COUNT.addr, regs::ET1100_SMS);
        self.set_u8(regs::RAM_SIZE.addr, regs::ET1100_RAM_SIZE_KIB);
        self.set_u8(regs::PORT_DESCRIPTOR.addr, PORT_DESCRIPTOR.0);
        let features = EscFeatures::FMMU_BIT_OPERATION
            | EscFeatures::DC
            | EscFeatures::DC_64BIT
            | EscFeatures::LOW_JITTER_EBUS
            | EscFeatures::ENHANCED_LINK_EBUS
            | EscFeatures::ENHANCED_LINK_MII
            | EscFeatures::SEPARATE_FCS;
        self.set_u16(regs::FEATURES.addr, features);
        self.set_u32(regs::DL_CONTROL.addr, DlControl::RESET);
        let init = AlControl {
            state_bits: AlState::Init.bits(),
            ack: false,
            id_request: false,
        };
        self.set_u16(regs::AL_CONTROL.addr, init.bits());
        let init = AlStatus {
            state: AlState::Init,
            error: false,
            id_loaded: false,
        };
        self.set_u16(regs::AL_STATUS.addr, init.bits());
        self.set_u32(regs::AL_EVENT_MASK.addr, AlEvent::MASK_RESET);
        self.set_u16(
            regs::WATCHDOG_DIVIDER.addr,
            hal::esc::watchdog::DIVIDER_RESET,
        );
        self.set_u16(regs::WATCHDOG_TIME_PDI.addr, hal::esc::watchdog::TIME_RESET);
        self.set_u16(regs::WATCHDOG_TIME_PD.addr, hal::esc::watchdog::TIME_RESET);
        self.set_u16(
            regs::WATCHDOG_STATUS_PD.addr,
            hal::esc::watchdog::PD_STATUS_OK,
        );
        self.set_u16(
            regs::DC_SPEED_COUNTER_START.addr,
            hal::esc::dc::SPEED_COUNTER_START_RESET,
        );
        self.set_u8(
            regs::DC_TIME_FILTER_DEPTH.addr,
            hal::esc::dc::TIME_FILTER_DEPTH_RESET,
        );
        self.set_u8(
            regs::DC_SPEED_FILTER_DEPTH.addr,
            hal::esc::dc::SPEED_FILTER_DEPTH_RESET,
        );
        self.eeprom_power_on();
    }

    /// The SII EEPROM image as it is now (including writes through the EEPROM interface).
    pub fn sii(&self) -> &[u8] {
        &self.sii
    }

    /// Global simulated time (ns) the ESC was last advanced to.
    pub fn now(&self) -> u64 {
        self.now
    }

    /// Connects or disconnects physical port `port` (0..3). Port 0 faces the master (connected
    /// unless a test pulls its cable); port 1 faces the next ESC ([`process_frame`] sets it from
    /// the ring order). Updates the link, loop and communication bits of DL status 0x0110.
    pub fn set_port_connected(&mut self, port: u8, connected: bool) {
        let link = match port {
            0 => &mut self.port0_connected,
            1 => &mut self.port1_connected,
            _ => return,
        };
        if *link != connected {
            *link = connected;
            self.update_dl_status();
        }
    }

    /// Whether port 0 (towards the master) has a link.
    pub fn port0_connected(&self) -> bool {
        self.port0_connected
    }

    /// Sets the local clock: local time `local_ns` at the current global time and a drift of
    /// `drift_ppm` against global time (positive = the local clock runs fast). Resets the drift
    /// correction loop.
    ///
    /// Without this call a fresh ESC runs at +3 ppm from local time 0 at global time 0, and when
    /// it first sees a frame at ring position k > 0 it takes a position-dependent drift (a few
    /// ppm apart from its neighbours) and a power-on skew of k x 1.234567 ms, deterministically.
    pub fn set_clock(&mut self, local_ns: u64, drift_ppm: f64) {
        self.dc.set_clock(self.now, local_ns, drift_ppm);
        self.clock_configured = true;
    }

    /// Gives an ESC whose clock was never set the default of ring position `k` (once).
    fn default_clock_for_position(&mut self, k: usize) {
        if core::mem::replace(&mut self.clock_configured, true) || k == 0 {
            return;
        }
        let drift = RING_DRIFTS_PPM
            .get(k % RING_DRIFTS_PPM.len())
            .copied()
            .unwrap_or(DEFAULT_DRIFT_PPM);
        let skew = RING_POWER_ON_SKEW_NS.saturating_mul(k as u64);
        let local = self.dc.clock.local_at(self.now).wrapping_add(skew);
        self.dc.set_clock(self.now, local, drift);
    }

    /// Local time (ns) of this ESC at global time `global_ns`.
    pub fn local_time_at(&self, global_ns: u64) -> u64 {
        self.dc.clock.local_at(global_ns)
    }

    /// System time (local time + offset 0x0920) of this ESC at global time `global_ns`.
    pub fn system_time_at(&self, global_ns: u64) -> u64 {
        self.dc
            .clock
            .local_at(global_ns)
            .wrapping_add(self.u64_at(regs::DC_SYSTEM_TIME_OFFSET.addr))
    }

    /// Copies raw memory at `addr` into `buf` without any side effect (debug view; bytes beyond
    /// the address space read as 0). The system time register shows its stored (unused) bytes.
    pub fn peek(&self, addr: u16, buf: &mut [u8]) {
        for (i, b) in buf.iter_mut().enumerate() {
            *b = usize::from(addr)
                .checked_add(i)
                .and_then(|a| self.mem.get(a))
                .copied()
                .unwrap_or(0);
        }
    }

    /// Moves the ESC's view of global simulated time forward to `now_ns` (monotonic; earlier
    /// values are ignored) and runs everything due until then: SYNC0/SYNC1 pulses, watchdog
    /// expiry, EEPROM command completion.
    pub fn advance_to(&mut self, now_ns: u64) {
        if now_ns < self.now {
            return;
        }
        self.now = now_ns;
        self.eeprom_poll_time();
        self.watchdogs_poll();
        self.sync_poll();
        self.dc.clock.reanchor(now_ns);
    }

    /// Global time (ns) of the next internal event (SYNC0/SYNC1 pulse, watchdog expiry, EEPROM
    /// completion), if any is scheduled.
    pub fn next_event_ns(&self) -> Option<u64> {
        [
            self.sync_next_event(),
            self.watchdog_next_event(),
            self.eeprom_next_event(),
        ]
        .into_iter()
        .flatten()
        .min()
    }

    /// Whether the PDI came up (SII checksum good at power-on or at the last reload).
    pub fn pdi_operational(&self) -> bool {
        self.pdi_operational
    }

    // ----- raw memory helpers (addresses are checked; out of range reads 0, writes vanish) -----

    fn u8_at(&self, addr: u16) -> u8 {
        self.mem.get(usize::from(addr)).copied().unwrap_or(0)
    }

    fn set_u8(&mut self, addr: u16, v: u8) {
        if let Some(b) = self.mem.get_mut(usize::from(addr)) {
            *b = v;
        }
    }

    fn bytes_at<const N: usize>(&self, addr: u16) -> [u8; N] {
        let mut out = [0u8; N];
        self.peek(addr, &mut out);
        out
    }

    fn set_bytes(&mut self, addr: u16, v: &[u8]) {
        for (i, b) in v.iter().enumerate() {
            if let Some(a) = addr.checked_add(i as u16) {
                self.set_u8(a, *b);
            }
        }
    }

    fn u16_at(&self, addr: u16) -> u16 {
        u16::from_le_bytes(self.bytes_at(addr))
    }

    fn set_u16(&mut self, addr: u16, v: u16) {
        self.set_bytes(addr, &v.to_le_bytes());
    }

    fn u32_at(&self, addr: u16) -> u32 {
        u32::from_le_bytes(self.bytes_at(addr))
    }

    fn set_u32(&mut self, addr: u16, v: u32) {
        self.set_bytes(addr, &v.to_le_bytes());
    }

    fn u64_at(&self, addr: u16) -> u64 {
        u64::from_le_bytes(self.bytes_at(addr))
    }

    fn set_u64(&mut self, addr: u16, v: u64) {
        self.set_bytes(addr, &v.to_le_bytes());
    }

    // ----- event registers -----

    /// AL event request register 0x0220.
    fn al_event(&self) -> u32 {
        self.u32_at(regs::AL_EVENT_REQUEST.addr)
    }

    fn set_al_event_bits(&mut self, bits: u32, on: bool) {
        let v = self.al_event();
        let v = if on { v | bits } else { v & !bits };
        self.set_u32(regs::AL_EVENT_REQUEST.addr, v);
    }

    /// ECAT event request register 0x0210.
    fn ecat_event(&self) -> u16 {
        self.u16_at(regs::ECAT_EVENT_REQUEST.addr)
    }

    fn set_ecat_event_bits(&mut self, bits: u16, on: bool) {
        let v = self.ecat_event();
        let v = if on { v | bits } else { v & !bits };
        self.set_u16(regs::ECAT_EVENT_REQUEST.addr, v);
    }

    /// Recomputes DL status 0x0110 from the port connections, PDI state and watchdog.
    fn update_dl_status(&mut self) {
        let mut v = 0u16;
        if self.pdi_operational {
            v |= DlStatus::PDI_OPERATIONAL;
        }
        if !self.wd.pdi_expired {
            v |= DlStatus::PDI_WATCHDOG_OK;
        }
        if EscConfig(self.u8_at(regs::ESC_CONFIG.addr)).enhanced_link() {
            v |= DlStatus::ENHANCED_LINK;
        }
        for port in 0..regs::ET1100_PORTS {
            let connected = match port {
                0 => self.port0_connected,
                1 => self.port1_connected,
                _ => false,
            };
            if connected {
                v |= DlStatus::link(port) | DlStatus::communication(port);
            } else {
                v |= DlStatus::loop_closed(port);
            }
        }
        let old = self.u16_at(regs::DL_STATUS.addr);
        if old != v {
            self.set_u16(regs::DL_STATUS.addr, v);
            self.set_ecat_event_bits(EcatEvent::DL_STATUS, true);
        }
    }
}

impl core::fmt::Debug for Et1100 {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Et1100")
            .field("station_address", &self.u16_at(regs::STATION_ADDRESS.addr))
            .field("al_status", &self.u16_at(regs::AL_STATUS.addr))
            .field("now", &self.now)
            .finish_non_exhaustive()
    }
}

impl EscSignals for Et1100 {
    fn irq_asserted(&mut self) -> bool {
        self.irq_line()
    }

    fn take_sync0(&mut self) -> bool {
        core::mem::take(&mut self.sync0_edge)
    }

    fn take_sync1(&mut self) -> bool {
        core::mem::take(&mut self.sync1_edge)
    }
}

/// The AL event request register as the typed value of `hal`.
impl Et1100 {
    /// AL event request register 0x0220 (no side effects).
    pub fn al_event_request(&self) -> AlEvent {
        AlEvent(self.al_event())
    }

    /// The IRQ output: an AL event request that the AL event mask (0x0204) lets through.
    pub fn irq_line(&self) -> bool {
        self.al_event() & self.u32_at(regs::AL_EVENT_MASK.addr) != 0
    }
}
