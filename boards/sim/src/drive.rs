//! One simulated drive: a software ET1100 and the firmware core running against it.

use firmware::profile::DriveProfile;
use firmware::profiles;
use firmware::slave::{SlaveError, SyncMode};
use firmware::{DriveCore, DriveSlave};
use hal::io::DigitalOutputs;
use hal::io::StatusLeds;
use hal::pdi::EscSignals;

use crate::domains::SimDomainStore;
use crate::esc::Et1100;
use crate::leds::SimLeds;
use crate::plant::{Fidelity, PlantConfig};
use crate::servo::{axis_config, SimServo, Tuning};
use crate::storage::SimStorage;
use firmware::params::{max_record_len, Loaded, ParamError, ParamStore};

/// OD RAM size of the simulated firmware: large enough for every built-in profile, so the
/// profile can be chosen by name at run time.
pub const SIM_RAM: usize = profiles::MAX_RAM_SIZE;

/// Period of the simulated board's local timer while no free-run cycle is configured (below
/// SAFEOP); in free run it ticks at the cycle the slave accepted from 1C32h:02 (ETG.1020).
pub const FREE_RUN_PERIOD_NS: u64 = 1_000_000;

/// LED update period (ETG.1300 flickering switches every 50 ms; the STM32 board uses 10 ms too).
pub const LED_PERIOD_NS: u64 = 10_000_000;

/// Background poll of the ESC event handler without an IRQ, as the STM32 board's thread-mode
/// fallback does every 10 ms: re-evaluates waiting transitions and timeouts.
pub const BACKGROUND_POLL_PERIOD_NS: u64 = 10_000_000;

/// Seed of the SYNC0 latency sequence ([`SimDrive::sync0_latency_max_ns`]); any non-zero value.
const SYNC0_LATENCY_SEED: u64 = 0x9E37_79B9_7F4A_7C15;

/// Why [`SimDrive::fit_servo`] failed.
#[derive(Debug)]
pub enum FitError {
    /// The drive's profile has no axis of that number.
    NoSuchAxis(usize),
    /// The firmware refused to start after the power cycle.
    Slave(SlaveError),
}

/// A drive: ESC + firmware.
pub struct SimDrive {
    /// The simulated ESC.
    pub esc: Et1100,
    /// The firmware core.
    pub slave: Box<DriveSlave<SIM_RAM>>,
    /// DOMAIN objects outside the OD RAM (e.g. the standard profile's 64 KiB test domain).
    pub domains: SimDomainStore,
    /// Parameter storage (1010h/1011h); kept across [`Self::power_cycle`].
    pub params: ParamStore<SimStorage>,
    /// What loading the stored parameters gave at the last power-on.
    pub loaded: Result<Option<Loaded>, ParamError>,
    profile: &'static DriveProfile,
    next_free_run_ns: u64,
    next_poll_ns: u64,
    /// RUN/ERR LEDs, switched every [`LED_PERIOD_NS`] from the firmware's ETG.1300 patterns.
    pub leds: SimLeds,
    next_led_ns: u64,
    /// The motor, inverter and encoder of each axis with the firmware's control interrupt,
    /// attached to the slave's application (one per axis of the profile, `servos[0]` the first);
    /// they run PWM period by PWM period as simulated time passes.
    pub servos: Vec<SimServo>,
    /// Fault injection for the context split: run a process-data cycle inside every mailbox
    /// round that leaves an SDO transfer half done, as a SYNC0 preempting the event context would
    /// (meaningful in free run: in DC modes SYNC0 comes only from the ESC).
    pub cycle_during_mailbox_transfer: bool,
    /// Cycles run that way.
    pub cycles_during_mailbox_transfer: u32,
    /// Fault injection: the SYNC0 interrupt is served late by a pseudo-random time up to this
    /// (ns), as interrupt latency behind a higher-priority handler makes it on a board; the
    /// firmware's cycle sees the later time. 0: served at the pulse.
    pub sync0_latency_max_ns: u64,
    sync0_latency_state: u64,
    /// Measure the host time of every process-data cycle and ESC-event round (the three
    /// fields below; off by default: reading the clock twice per handler is a visible share of
    /// a long line's simulation time).
    pub measure_host_times: bool,
    /// Longest host time one process-data cycle of the firmware took (`on_sync0` +
    /// `cycle_finished`), ns: what a soak reports (host time, not the MCU's).
    pub max_cycle_host_ns: u64,
    /// Longest host time one ESC-event round of the firmware took, ns.
    pub max_event_host_ns: u64,
    /// Host times of the process-data cycles: `[n]` counts those of `2^(n-1)..2^n` ns.
    pub cycle_host_histogram: [u64; 64],
    /// The MCU is stopped ([`SimDrive::halt_mcu`]).
    mcu_halted: bool,
}

/// The simulated drive's motor of axis `axis` (0 = the first): the 400 W servo with the default
/// tuning, its plant at `fidelity`; each axis' plant has its own noise seed.
fn new_servo(axis: usize, fidelity: Fidelity) -> SimServo {
    let mut plant = PlantConfig::servo_400w();
    plant.seed = plant.seed.wrapping_add(axis as u64);
    plant.fidelity = fidelity;
    let cfg = axis_config(&plant, &Tuning::default());
    match SimServo::new(plant, cfg) {
        Ok(servo) => servo,
        // Both configurations are constants of this crate, checked by its tests.
        Err(e) => panic!("the built-in servo configuration is invalid: {e:?}"),
    }
}

impl SimDrive {
    /// A drive running `profile` with the SII image `sii` in its EEPROM, and erased parameter
    /// storage sized for the profile's largest record.
    pub fn new(profile: &'static DriveProfile, sii: &[u8]) -> Result<Self, SlaveError> {
        Self::with_plant(profile, sii, Fidelity::default())
    }

    /// [`Self::new`] with the plants of its axes at `plant` fidelity.
    pub fn with_plant(
        profile: &'static DriveProfile,
        sii: &[u8],
        plant: Fidelity,
    ) -> Result<Self, SlaveError> {
        let storage = SimStorage::for_record(max_record_len(&profile.od));
        Self::build(profile, sii, storage, plant)
    }

    /// A drive whose parameter storage holds `storage`; the stored parameters are loaded at
    /// power-on, before the firmware starts (see `firmware::params`).
    pub fn with_storage(
        profile: &'static DriveProfile,
        sii: &[u8],
        storage: SimStorage,
    ) -> Result<Self, SlaveError> {
        Self::build(profile, sii, storage, Fidelity::default())
    }

    fn build(
        profile: &'static DriveProfile,
        sii: &[u8],
        storage: SimStorage,
        plant: Fidelity,
    ) -> Result<Self, SlaveError> {
        let mut esc = Et1100::new(sii);
        let mut params = ParamStore::new(storage);
        let mut slave = Box::new(firmware::new_slave(profile)?);
        let loaded = slave.load_parameters(&mut params);
        let servos: Vec<SimServo> = (0..profile.axes.len())
            .map(|axis| new_servo(axis, plant))
            .collect();
        attach_servos(&mut slave, &servos);
        // The simulated PDI never fails (its error type only reports out-of-range accesses,
        // which the firmware does not make); a failure here would be a firmware bug.
        let _ = slave.start(&mut esc);
        Ok(Self {
            esc,
            slave,
            domains: SimDomainStore::new(),
            params,
            loaded,
            profile,
            next_free_run_ns: FREE_RUN_PERIOD_NS,
            next_poll_ns: BACKGROUND_POLL_PERIOD_NS,
            leds: SimLeds::default(),
            next_led_ns: 0,
            servos,
            cycle_during_mailbox_transfer: false,
            cycles_during_mailbox_transfer: 0,
            sync0_latency_max_ns: 0,
            sync0_latency_state: SYNC0_LATENCY_SEED,
            measure_host_times: false,
            max_cycle_host_ns: 0,
            max_event_host_ns: 0,
            cycle_host_histogram: [0; 64],
            mcu_halted: false,
        })
    }

    /// Switches the drive off and on: a new ESC (with the SII EEPROM content as it is now) and a
    /// new firmware core in INIT that loads the stored parameters; the parameter storage is
    /// kept (the domain store too). Simulated time goes on; the master sees a drive that was
    /// just powered on.
    pub fn power_cycle(&mut self) -> Result<(), SlaveError> {
        let now = self.esc.now();
        let mut esc = Et1100::new(self.esc.sii());
        esc.advance_to(now);
        self.esc = esc;
        self.restart_mcu()
    }

    /// The MCU stops: the firmware serves neither the ESC (so the ESC's PDI watchdog runs out)
    /// nor the motor (the gate driver is off, see [`SimServo::halt_firmware`]); the LEDs it
    /// drives go dark. The ESC goes on answering the master. [`Self::restart_mcu`] ends it.
    pub fn halt_mcu(&mut self) {
        self.mcu_halted = true;
        for servo in &mut self.servos {
            servo.halt_firmware();
        }
        self.leds.set_run(false);
        self.leds.set_err(false);
    }

    /// The MCU restarts (the board's watchdog, its supply back) while the ESC keeps its state:
    /// a new firmware core in INIT that loads the stored parameters and starts against the ESC
    /// as it is.
    pub fn restart_mcu(&mut self) -> Result<(), SlaveError> {
        let now = self.esc.now();
        let mut slave = Box::new(firmware::new_slave(self.profile)?);
        self.loaded = slave.load_parameters(&mut self.params);
        for servo in &mut self.servos {
            servo.restart_firmware();
        }
        attach_servos(&mut slave, &self.servos);
        // As in `with_storage`: the simulated PDI does not fail.
        let _ = slave.start(&mut self.esc);
        self.slave = slave;
        self.mcu_halted = false;
        self.next_free_run_ns = now + FREE_RUN_PERIOD_NS;
        self.next_poll_ns = now + BACKGROUND_POLL_PERIOD_NS;
        Ok(())
    }

    /// Fits axis `axis` (0 = the first) with `servo`: a board built with other hardware (a
    /// motor, encoder or protection levels other than the reference servo's), e.g. to provoke a
    /// fault the reference board cannot reach. The drive is then power cycled so that the
    /// firmware starts with the new axis attached; call it before a master opens the drive.
    /// `Err` if the drive has no such axis (the servo is not fitted).
    pub fn fit_servo(&mut self, axis: usize, servo: SimServo) -> Result<(), FitError> {
        let slot = self
            .servos
            .get_mut(axis)
            .ok_or(FitError::NoSuchAxis(axis))?;
        *slot = servo;
        self.power_cycle().map_err(FitError::Slave)
    }

    /// Earliest simulated time at which the drive has something to do.
    pub fn next_event_ns(&self) -> Option<u64> {
        if self.mcu_halted {
            return self.esc.next_event_ns();
        }
        let free_run = self.free_running().then_some(self.next_free_run_ns);
        [
            self.esc.next_event_ns(),
            free_run,
            Some(self.next_poll_ns),
            Some(self.next_led_ns),
        ]
        .into_iter()
        .flatten()
        .min()
    }

    /// The local timer's period: the free-run cycle (1C32h:02) the slave accepted, else
    /// [`FREE_RUN_PERIOD_NS`].
    fn free_run_period_ns(&self) -> u64 {
        match self.slave.cycle_ns() {
            cycle if cycle != 0 && self.free_running() => u64::from(cycle),
            _ => FREE_RUN_PERIOD_NS,
        }
    }

    fn free_running(&self) -> bool {
        self.slave.sync_mode() == SyncMode::FreeRun
            && matches!(
                self.slave.al_state(),
                hal::esc::AlState::SafeOp | hal::esc::AlState::Op
            )
    }

    /// Moves the drive to simulated time `now_ns` and runs the firmware handlers that are due:
    /// SYNC0 → cycle, free-run tick → cycle, IRQ line → ESC event handler.
    pub fn run_until(&mut self, now_ns: u64) {
        // The control interrupt runs every PWM period up to now, before SYNC0 reads its
        // feedback.
        for servo in &mut self.servos {
            servo.advance_to(now_ns);
        }
        self.esc.advance_to(now_ns);
        if self.mcu_halted {
            // Nothing runs on the MCU; the ESC's SYNC0 goes unserved.
            let _ = self.esc.take_sync0();
            return;
        }
        if self.esc.take_sync0() {
            let served = now_ns.saturating_add(self.sync0_latency());
            self.cycle(served);
        }
        if self.free_running() && now_ns >= self.next_free_run_ns {
            self.cycle(now_ns);
        }
        let period = self.free_run_period_ns();
        while self.next_free_run_ns <= now_ns {
            self.next_free_run_ns += period;
        }
        if now_ns >= self.next_led_ns {
            let (run, err) = self.slave.leds(now_ns);
            self.leds.set_run(run);
            self.leds.set_err(err);
            self.next_led_ns = now_ns + LED_PERIOD_NS;
        }
        if now_ns >= self.next_poll_ns {
            self.esc_event(now_ns);
            self.next_poll_ns = now_ns + BACKGROUND_POLL_PERIOD_NS;
        }
        self.service_irq(now_ns);
        self.drive_outputs();
    }

    /// The board sets its digital output pins to what each axis of the drive asks.
    fn drive_outputs(&mut self) {
        let drive = self.slave.app();
        for (axis, servo) in self.servos.iter_mut().enumerate() {
            if let Some(a) = drive.axis(axis) {
                servo.io_mut().outputs.set_outputs(a.digital_outputs());
            }
        }
    }

    /// The next SYNC0 service latency, in `0..=sync0_latency_max_ns` (xorshift64).
    fn sync0_latency(&mut self) -> u64 {
        if self.sync0_latency_max_ns == 0 {
            return 0;
        }
        let x = &mut self.sync0_latency_state;
        *x ^= *x << 13;
        *x ^= *x >> 7;
        *x ^= *x << 17;
        *x % (self.sync0_latency_max_ns + 1)
    }

    /// One process-data cycle (see [`run_cycle`]).
    fn cycle(&mut self, now_ns: u64) {
        if !self.measure_host_times {
            run_cycle(&mut self.slave, &mut self.esc, now_ns);
            return;
        }
        let started = std::time::Instant::now();
        run_cycle(&mut self.slave, &mut self.esc, now_ns);
        let took = elapsed_ns(started);
        self.max_cycle_host_ns = self.max_cycle_host_ns.max(took);
        let bucket = (u64::BITS - took.leading_zeros()) as usize;
        if let Some(n) = self.cycle_host_histogram.get_mut(bucket) {
            *n += 1;
        }
    }

    /// Runs the ESC event handler while the IRQ line is asserted (bounded: the handler clears
    /// what it serves; a stuck line is left for the next call).
    pub fn service_irq(&mut self, now_ns: u64) {
        const MAX_ROUNDS: usize = 4;
        if self.mcu_halted {
            return;
        }
        for _ in 0..MAX_ROUNDS {
            if !self.esc.irq_asserted() {
                break;
            }
            self.esc_event(now_ns);
        }
    }

    /// One call of the firmware's ESC event handler.
    /// One call of the firmware's ESC event handler (one round, see
    /// `ethercat_slave::slave::MailboxSide`).
    fn esc_event(&mut self, now_ns: u64) {
        if !self.measure_host_times {
            self.esc_event_round(now_ns);
            return;
        }
        let started = std::time::Instant::now();
        self.esc_event_round(now_ns);
        self.max_event_host_ns = self.max_event_host_ns.max(elapsed_ns(started));
    }

    fn esc_event_round(&mut self, now_ns: u64) {
        let inject = self.cycle_during_mailbox_transfer;
        let mut injected = 0;
        let _ = self.slave.event_round(
            &mut self.esc,
            &mut self.params,
            &mut self.domains,
            now_ns,
            |core, mailbox, esc| {
                if inject && mailbox.transfer_in_progress() {
                    // What a board's SYNC0 (or free-run timer) interrupt does when it preempts
                    // the event context in the middle of a mailbox transfer: the cycle runs on
                    // the core while the mailbox side holds the half-done transfer.
                    run_cycle(core, esc, now_ns);
                    injected += 1;
                }
            },
        );
        self.cycles_during_mailbox_transfer += injected;
    }
}

/// Host nanoseconds since `started` (saturating: a soak runs for minutes, not centuries).
fn elapsed_ns(started: std::time::Instant) -> u64 {
    u64::try_from(started.elapsed().as_nanos()).unwrap_or(u64::MAX)
}

/// Attaches the servos to the slave's axes, in order (one per axis of the profile).
fn attach_servos(slave: &mut DriveSlave<SIM_RAM>, servos: &[SimServo]) {
    let (drive, ram) = slave.application();
    for (axis, servo) in servos.iter().enumerate() {
        // `servos` has one servo per axis of the profile the drive was made for.
        let _ = drive.attach_axis(axis, servo.link(), servo.encoder_spec(), ram);
    }
}

/// One process-data cycle of `core` on `esc`. Its duration, reported to the firmware
/// (1C32h:06), is the modelled SPI bus time of the cycle's PDI accesses: simulated time does not
/// pass while the firmware runs.
fn run_cycle(core: &mut DriveCore<SIM_RAM>, esc: &mut Et1100, now_ns: u64) {
    let bus_before = esc.pdi_bus_ns();
    let _ = firmware::sync0::on_sync0(core, esc, now_ns);
    let bus_time = esc.pdi_bus_ns() - bus_before;
    core.cycle_finished(now_ns + bus_time);
}
