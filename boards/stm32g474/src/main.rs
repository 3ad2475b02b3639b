//! Real board: STM32G474RE (Cortex-M4F, 170 MHz) with a Beckhoff ET1100 EtherCAT slave
//! controller on SPI. Built with embassy for `thumbv7em-none-eabihf`, flashed with probe-rs.
//!
//! | module | what |
//! |---|---|
//! | [`pins`] | the pin map (the only place that names pins) |
//! | [`clocks`] | HSE 24 MHz → PLL → 170 MHz |
//! | [`pwm`] | TIM1: complementary centre-aligned PWM, dead time, break, ADC trigger |
//! | [`adc`] | ADC1/ADC2: injected conversions of currents, bus voltage, temperature |
//! | `encoder` | TIM2: incremental encoder with index capture (default build) |
//! | `biss_spi` | SPI1 + DMA: the BiSS-C encoder's frame each period (`biss-encoder` build) |
//! | [`axis_io`] | limit/home switches, thermal switch, probes, STO, brake, gate-driver enable |
//! | [`control`] | the control interrupt (P0): one PWM period of the axis |
//! | [`sync_capture`] | TIM3: SYNC0's phase in the PWM period, captured in hardware |
//! | [`watchdog`] | the independent watchdog, refreshed while every context runs |
//! | [`et1100_spi`] | the ET1100 SPI PDI driver (`hal::pdi::EscPdi`) |
//! | [`irq`] | priorities, vectors, the cycle and ESC-event contexts, the shared Slave/PDI |
//! | [`lock`] | the BASEPRI priority-ceiling lock |
//! | [`tasks`] | async tasks (ESC-event context and thread mode) |
//! | [`time`] | DWT cycle counter (`hal::time::CycleCounter`), 64-bit ns clock |
//! | [`leds`] | RUN/ERR LEDs (`hal::io::StatusLeds`) |
//! | [`profile`] | which vendor profile this image carries |
#![no_std]
#![no_main]
#![deny(missing_docs)]
#![deny(clippy::missing_safety_doc)]

mod adc;
mod axis_io;
#[cfg(feature = "biss-encoder")]
mod biss_spi;
mod clocks;
mod control;
#[cfg(not(feature = "biss-encoder"))]
mod encoder;
mod et1100_spi;
mod irq;
mod leds;
mod lock;
mod pins;
mod profile;
mod pwm;
mod storage;
mod sync_capture;
mod tasks;
mod time;
mod watchdog;

use defmt::{error, info, unwrap, warn};
use embassy_executor::Spawner;
use embassy_stm32::flash::{Blocking, Flash};
use embassy_time::{Duration, Timer};
use firmware::motor::axis::Axis;
use firmware::motor::servo::axis_config;
use firmware::params::ParamStore;
use firmware::DriveCore;
use hal::encoder::Encoder;
use hal::esc::regs;
use hal::pdi::EscPdi;
use stm32g4_axis::board as servo;
use {defmt_rtt as _, panic_probe as _};

use crate::axis_io::{BrakePin, GateDriverEnable, GpioInputs};
use crate::control::ControlContext;
use crate::et1100_spi::Et1100Spi;
use crate::storage::FlashStorage;
#[cfg(feature = "biss-encoder")]
use stm32g4_axis::biss::BissEncoder;
use stm32g4_axis::control::AxisHardware;
use stm32g4_axis::inputs::{BoardInputs, BrakeOutput};
use stm32g4_axis::inverter::Tim1Inverter;
use stm32g4_axis::phase_lock::Sync0Lock;
#[cfg(not(feature = "biss-encoder"))]
use stm32g4_axis::quadrature::QuadratureEncoder;

/// Start-up probe: attempts and spacing. The ET1100 loads its SII EEPROM after reset (tens of
/// ms for a few KiB at 100/400 kHz I²C) and only then enables the SPI PDI; 100 × 10 ms = 1 s.
const PROBE_ATTEMPTS: u32 = 100;
const PROBE_RETRY: Duration = Duration::from_millis(10);

/// Waits (bounded) until the ESC answers on the PDI (see [`tasks::esc_ready`]). Returns
/// whether it did.
async fn probe_esc(pdi: &mut Et1100Spi<'_>) -> bool {
    for attempt in 0..PROBE_ATTEMPTS {
        match tasks::esc_ready(pdi) {
            Ok(true) => {
                let revision = pdi.read_u8(regs::REVISION.addr).unwrap_or(0);
                let build = pdi.read_u16(regs::BUILD.addr).unwrap_or(0);
                info!(
                    "ET1100 ready after {} attempt(s): revision {}, build {}",
                    attempt + 1,
                    revision,
                    build
                );
                return true;
            }
            Ok(false) => {}
            Err(e) => error!("ESC probe: PDI error {}", e),
        }
        Timer::after(PROBE_RETRY).await;
    }
    error!(
        "ESC not ready after {} ms (type register != 0x11 or EEPROM not loaded); \
         the fallback poll keeps probing",
        PROBE_ATTEMPTS * PROBE_RETRY.as_millis() as u32
    );
    false
}

/// The incremental encoder on TIM2.
#[cfg(not(feature = "biss-encoder"))]
fn board_encoder(pins: pins::EncoderPins) -> Option<control::BoardEncoder> {
    let counter = encoder::configure(pins.tim, pins.lines);
    info!(
        "encoder: incremental on TIM2, input filter {}",
        encoder::FILTER.code
    );
    Some(QuadratureEncoder::new(counter, servo::COUNTS_PER_REV))
}

/// The BiSS-C encoder on SPI1 with DMA; `None` (logged) if its layout is refused.
#[cfg(feature = "biss-encoder")]
fn board_encoder(pins: pins::EncoderPins) -> Option<control::BoardEncoder> {
    match BissEncoder::new(biss_spi::configure(pins.biss), servo::BISS_LAYOUT) {
        Ok(encoder) => {
            info!("encoder: BiSS-C on SPI1");
            Some(encoder)
        }
        Err(e) => {
            error!("BiSS layout refused ({}): no motor control", e);
            None
        }
    }
}

/// Configures the axis hardware (TIM1, ADC1/ADC2, the encoder, the GPIOs) and creates the axis.
/// `None` (logged) if the ADCs do not start or the servo's configuration is refused: the drive
/// then runs without a motor (no axis attached, gates off).
fn make_axis(
    inverter: pins::InverterPins,
    sensing: pins::SensingPins,
    encoder: pins::EncoderPins,
    axis_io: pins::AxisIoPins,
    sync0: &sync_capture::Sync0Capture,
) -> (Option<ControlContext>, BrakePin) {
    let brake = BrakePin::new(axis_io.brake);
    let mut gate_driver = GateDriverEnable::new(inverter.gate_enable);
    // TIM1 first: its outputs reach the pins at their off level, then the driver may wake.
    let (tim1, pwm_pins) = pwm::configure(inverter.tim, inverter.pwm);
    gate_driver.enable();
    let adcs = match adc::configure(sensing.adc1, sensing.adc2, sensing.analog) {
        Ok(adcs) => adcs,
        Err(e) => {
            error!("ADC start-up failed ({}): no motor control", e);
            return (None, brake);
        }
    };
    let Some(encoder) = board_encoder(encoder) else {
        return (None, brake);
    };
    let axis = match Axis::new(axis_config(&control::SERVO, &servo::TUNING)) {
        Ok(axis) => axis,
        Err(e) => {
            error!("axis configuration refused ({}): no motor control", e);
            return (None, brake);
        }
    };
    let (currents, bus) = stm32g4_axis::sensing::sensing(&servo::FRONT_END);
    let hardware = AxisHardware {
        inverter: Tim1Inverter::new(tim1, servo::PWM_HZ)
            .with_period_trim(&control::PERIOD_TRIM)
            .with_bootstrap_precharge(servo::BOOTSTRAP_PRECHARGE_PERIODS),
        adcs,
        currents,
        bus,
        encoder,
        inputs: BoardInputs::new(GpioInputs::new(axis_io.inputs), axis_io::POLARITY)
            .with_probe_timer(
                sync_capture::Tim3Probes::new(sync0),
                sync_capture::TIM3_HZ,
                // The filter's delay, in TIM3 ticks (÷1 clock division).
                sync_capture::PROBE_FILTER.delay_ticks as u32,
            ),
    };
    info!(
        "axis: PWM {} Hz (ARR {}), dead time DTG {}, encoder {} increments/rev",
        servo::PWM_HZ,
        pwm::PERIOD.auto_reload,
        pwm::DEAD_TIME.dtg,
        hardware.encoder.resolution()
    );
    let context = ControlContext {
        hardware,
        axis,
        _pwm_pins: pwm_pins,
        _gate_driver: gate_driver,
    };
    (Some(context), brake)
}

/// Creates the slave, attaches the axis if there is one, starts the slave if the ESC is ready,
/// and installs slave and PDI as the shared drive. Returns whether the slave was started. A
/// plain function, so that the multi-KiB `Slave` never becomes part of the main task's future.
fn install_drive(
    mut pdi: Et1100Spi<'static>,
    flash: Flash<'static, Blocking>,
    brake: BrakePin,
    with_axis: bool,
    ready: bool,
) -> bool {
    let mut started = false;
    irq::install(|| {
        // A profile whose OD RAM does not fit RAM_SIZE is a build error of od-gen: stop here.
        let (mut core, mailbox): (DriveCore<{ profile::RAM_SIZE }>, _) =
            unwrap!(firmware::new_slave_parts(&profile::PROFILE));
        // Parameters saved with 1010h, before the ESM starts (CiA 301: effective at power-on).
        let mut params = ParamStore::new(FlashStorage::new(flash));
        if core.load_parameters(&mut params).is_err() {
            warn!("stored parameters not loaded: defaults in use");
        }
        // The axis takes the commissioned motor data from the loaded parameters.
        if with_axis {
            let (drive, ram) = core.application();
            if drive
                .attach_axis(0, &control::LINK, control::SERVO.encoder, ram)
                .is_err()
            {
                error!("the profile has no axis: the motor stays off");
            }
        }
        // AL status INIT and the AL event mask (drives SPI_IRQ). If the ESC is not ready yet,
        // the fallback poll task keeps probing and calls `start` once it is.
        started = ready && core.start(&mut pdi).is_ok();
        if ready && !started {
            error!("SlaveCore::start failed; the fallback poll retries");
        }
        let brake = BrakeOutput::new(brake);
        (
            irq::Drive {
                core,
                pdi,
                brake,
                sync_lock: with_axis.then(|| Sync0Lock::new(pwm::TIM1_HZ, pwm::PERIOD.auto_reload)),
            },
            irq::EventSide { mailbox, params },
        )
    });
    started
}

/// The axis made from its pins, the drive installed with it, then the control interrupt
/// started (the axis is attached by then). Returns whether the drive started and whether the
/// control interrupt runs. Not in `main`: the control context (some 1.8 KiB) stays on the
/// stack of this call, not in the main task's future, which lives for ever.
#[inline(never)]
fn start_drive(
    (inverter, sensing, encoder, axis_io): (
        pins::InverterPins,
        pins::SensingPins,
        pins::EncoderPins,
        pins::AxisIoPins,
    ),
    sync0: &sync_capture::Sync0Capture,
    pdi: Et1100Spi<'static>,
    flash: Flash<'static, Blocking>,
    ready: bool,
) -> (bool, bool) {
    let (control, brake) = make_axis(inverter, sensing, encoder, axis_io, sync0);
    let with_control = control.is_some();
    let started = install_drive(pdi, flash, brake, with_control, ready);
    // The control interrupt starts after the drive is installed: the axis is attached.
    if let Some(context) = control {
        control::start(context, irq::Irqs);
    }
    (started, with_control)
}

#[embassy_executor::main]
async fn main(spawner: Spawner) {
    let p = embassy_stm32::init(clocks::config());
    // Before any EXTI line is unmasked: embassy's init enabled every EXTI vector at P0.
    irq::set_priorities();
    let core = unwrap!(cortex_m::Peripherals::take());
    let _cycle_counter = time::CycleCount::enable(core.DCB, core.DWT);
    info!(
        "board-stm32g474: SYSCLK {} Hz, profile {}",
        clocks::SYSCLK_HZ,
        profile::PROFILE.od.device.profile
    );

    let pins::BoardPins {
        esc,
        leds,
        flash,
        inverter,
        sensing,
        encoder,
        axis_io,
        iwdg,
    } = pins::split(p);
    // The main task's future lives for ever, with room for every local borrowed across one
    // of its awaits: the PDI, borrowed by the probe, ends in this block.
    let (pdi, ready) = {
        let mut pdi = Et1100Spi::new(esc.spi, esc.sck, esc.miso, esc.mosi, esc.cs);
        info!("PDI: SPI3, mode 3, {} Hz", pdi.clock_hz());
        let ready = probe_esc(&mut pdi).await;
        (pdi, ready)
    };

    // TIM3 time-stamps SYNC0 and the probe edges against the PWM; its vector stays masked
    // until the drive is installed.
    let sync0 = sync_capture::configure(esc.sync0_timer, esc.sync0);
    let (started, with_control) = start_drive(
        (inverter, sensing, encoder, axis_io),
        &sync0,
        pdi,
        Flash::new_blocking(flash),
        ready,
    );
    let iwdg = watchdog::Iwdg::start(iwdg).unwrap_or_else(|iwdg| {
        error!("IWDG did not take its setting: 512 ms reset timeout");
        iwdg
    });

    // Unmask the ESC lines only now that the drive is installed.
    irq::start_cycle_vector(irq::Irqs);
    let esc_irq = irq::esc_irq_input(esc.irq, esc.irq_exti, irq::Irqs);

    let event_spawner = irq::start_esc_event_executor(irq::Irqs);
    // The task pools have one slot each and each task is spawned once: a spawn error is a bug.
    event_spawner.spawn(unwrap!(tasks::esc_event(esc_irq)));
    event_spawner.spawn(unwrap!(tasks::free_run()));
    spawner.spawn(unwrap!(tasks::esc_poll(started)));
    spawner.spawn(unwrap!(tasks::leds(leds::Leds::new(leds))));
    spawner.spawn(unwrap!(tasks::report()));
    spawner.spawn(unwrap!(tasks::watchdog(iwdg, with_control)));

    // SYNC0's pin configuration belongs to `sync0`: keep it alive for ever.
    let _sync0 = sync0;
    core::future::pending::<()>().await;
}
