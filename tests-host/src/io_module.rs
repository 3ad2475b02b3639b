//! A 16-channel digital I/O module on the EtherCAT slave stack: the proof that `ethercat-slave`
//! knows no drive. Its profile is `io-module/io16.toml` (od-gen, `kind = "device"`); its
//! application copies the outputs 7000h to the output pins and the input pins to 6000h, and
//! puts the outputs to their safe state (8000h) when the master's outputs are gone.
//!
//! [`SimIoModule`] runs it on the simulated ET1100 as a [`SimDevice`] of a segment, so a master
//! can bring it to OP like any slave.

use board_sim::esc::Et1100;
use board_sim::SimDevice;
use ethercat_slave::od::{Profile, Value};
use ethercat_slave::slave::{AppEvents, Application, Slave, SlaveError, SyncMode};
use hal::esc::AlState;
use hal::pdi::EscSignals;

/// The generated object dictionary of `io-module/io16.toml`.
#[allow(dead_code)] // the generated lookup helpers are not all used
pub mod profile {
    include!(concat!(env!("OUT_DIR"), "/io_module_profile.rs"));
}

/// Digital inputs object (CiA401 convention: 6000h, UINT, one bit per channel).
pub const DIGITAL_INPUTS: u16 = 0x6000;
/// Digital outputs object (7000h, UINT).
pub const DIGITAL_OUTPUTS: u16 = 0x7000;
/// The level each output takes in its safe state (8000h, UINT).
pub const SAFE_OUTPUT_STATE: u16 = 0x8000;

/// OD RAM of the module.
pub const IO_RAM: usize = profile::io16::RAM_SIZE;

/// Free-run cycle of the module's local timer.
const FREE_RUN_PERIOD_NS: u64 = 1_000_000;
/// Background poll of the ESC event handler without an IRQ.
const BACKGROUND_POLL_PERIOD_NS: u64 = 10_000_000;
/// Rounds of the ESC event handler per IRQ (the handler clears what it serves).
const MAX_IRQ_ROUNDS: usize = 4;

/// The I/O module's application: pins ↔ objects.
#[derive(Debug)]
pub struct IoModule {
    inputs_at: usize,
    outputs_at: usize,
    safe_state_at: usize,
    /// Levels on the input pins (bit n = channel n + 1), set by the test.
    pub input_pins: u16,
    /// Levels the output pins are driven to.
    pub output_pins: u16,
}

/// OD RAM offset of the 16-bit variable `index:00`.
fn ram_offset(profile: &Profile, index: u16) -> Option<usize> {
    match profile.object(index)?.entry(0)?.value {
        Value::Ram(at) => Some(usize::from(at)),
        Value::Const(_) | Value::Domain(_) => None,
    }
}

fn read_u16(ram: &[u8], at: usize) -> u16 {
    ram.get(at..at + 2)
        .map_or(0, |b| u16::from_le_bytes([b[0], b[1]]))
}

impl IoModule {
    /// The application of `profile`; `None` if the profile lacks one of the three objects.
    pub fn new(profile: &Profile) -> Option<Self> {
        Some(Self {
            inputs_at: ram_offset(profile, DIGITAL_INPUTS)?,
            outputs_at: ram_offset(profile, DIGITAL_OUTPUTS)?,
            safe_state_at: ram_offset(profile, SAFE_OUTPUT_STATE)?,
            input_pins: 0,
            output_pins: 0,
        })
    }
}

impl Application for IoModule {
    fn cycle(&mut self, ram: &mut [u8], _cycle_ns: u32, _events: &mut AppEvents) {
        // Outputs the master wrote are in the RAM (unpacked only in OP; in SAFEOP 7000h keeps the
        // value the outputs were left at, which `outputs_safe` set).
        self.output_pins = read_u16(ram, self.outputs_at);
        if let Some(dst) = ram.get_mut(self.inputs_at..self.inputs_at + 2) {
            dst.copy_from_slice(&self.input_pins.to_le_bytes());
        }
    }

    fn outputs_safe(&mut self, ram: &mut [u8], _cycle_ns: u32) -> bool {
        let safe = read_u16(ram, self.safe_state_at);
        if let Some(dst) = ram.get_mut(self.outputs_at..self.outputs_at + 2) {
            dst.copy_from_slice(&safe.to_le_bytes());
        }
        self.output_pins = safe;
        false
    }

    fn raise_error(&mut self, _report: ethercat_slave::od::ErrorReport, _ram: &mut [u8]) {}
}

/// The I/O module on a simulated ET1100.
pub struct SimIoModule {
    /// The simulated ESC.
    pub esc: Et1100,
    /// The slave stack running the I/O application.
    pub slave: Box<Slave<IO_RAM, IoModule>>,
    next_free_run_ns: u64,
    next_poll_ns: u64,
}

impl SimIoModule {
    /// A module in INIT with the SII image od-gen makes from the profile file.
    pub fn new() -> Result<Self, SlaveError> {
        let od = &profile::io16::PROFILE;
        let sii = od_gen::load(std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/io-module/io16.toml"
        )))
        .expect("io16.toml (checked by the build script)")
        .sii_image();
        let app = IoModule::new(od).expect("io16 has 6000h, 7000h and 8000h");
        let mut esc = Et1100::new(&sii);
        let mut slave = Box::new(Slave::new(od, app)?);
        // The simulated PDI does not fail.
        let _ = slave.start(&mut esc);
        Ok(Self {
            esc,
            slave,
            next_free_run_ns: FREE_RUN_PERIOD_NS,
            next_poll_ns: BACKGROUND_POLL_PERIOD_NS,
        })
    }

    /// Sets the input pins.
    pub fn set_inputs(&mut self, pins: u16) {
        self.slave.application().0.input_pins = pins;
    }

    /// The levels of the output pins.
    pub fn outputs(&self) -> u16 {
        self.slave.app().output_pins
    }

    fn cycling(&self) -> bool {
        matches!(self.slave.al_state(), AlState::SafeOp | AlState::Op)
    }

    fn cycle(&mut self, now_ns: u64) {
        let _ = self.slave.on_cycle(&mut self.esc, now_ns);
        self.slave.cycle_finished(now_ns);
    }

    fn esc_event(&mut self, now_ns: u64) {
        let _ = self.slave.on_esc_event(&mut self.esc, now_ns);
    }
}

impl SimDevice for SimIoModule {
    fn esc(&self) -> &Et1100 {
        &self.esc
    }

    fn esc_mut(&mut self) -> &mut Et1100 {
        &mut self.esc
    }

    fn next_event_ns(&self) -> Option<u64> {
        let free_run = (self.cycling() && self.slave.sync_mode() == SyncMode::FreeRun)
            .then_some(self.next_free_run_ns);
        [self.esc.next_event_ns(), free_run, Some(self.next_poll_ns)]
            .into_iter()
            .flatten()
            .min()
    }

    fn run_until(&mut self, now_ns: u64) {
        self.esc.advance_to(now_ns);
        if self.esc.take_sync0() {
            self.cycle(now_ns);
        }
        if self.cycling()
            && self.slave.sync_mode() == SyncMode::FreeRun
            && now_ns >= self.next_free_run_ns
        {
            self.cycle(now_ns);
        }
        while self.next_free_run_ns <= now_ns {
            self.next_free_run_ns += FREE_RUN_PERIOD_NS;
        }
        if now_ns >= self.next_poll_ns {
            self.esc_event(now_ns);
            self.next_poll_ns = now_ns + BACKGROUND_POLL_PERIOD_NS;
        }
        self.service_irq(now_ns);
    }

    fn service_irq(&mut self, now_ns: u64) {
        for _ in 0..MAX_IRQ_ROUNDS {
            if !self.esc.irq_asserted() {
                break;
            }
            self.esc_event(now_ns);
        }
    }
}
