//! Async tasks: the ESC-event context (on the P2 `InterruptExecutor`) and the thread-mode
//! background work.

use core::sync::atomic::Ordering;

use embassy_stm32::exti::ExtiInput;
use embassy_stm32::mode::Blocking;
use embassy_time::{Duration, Ticker, Timer};
use hal::esc::{regs, DlStatus};
use hal::io::StatusLeds;
use hal::pdi::EscPdi;

use firmware::slave::SyncMode;
use hal::esc::AlState;
use stm32g4_axis::liveness::Liveness;

use crate::clocks::SYSCLK_HZ;
use crate::control::CONTROL_STATS;
use crate::et1100_spi::{Error as PdiError, Et1100Spi};
use crate::irq::{self, ContextStats, CYCLE_STATS, ESC_IRQ, EVENT_STATS};
use crate::leds::Leds;
use crate::pwm::TIM1_HZ;
use crate::watchdog::{self, Iwdg};

/// Wait before serving again while SPI_IRQ stays asserted after a service (an event the stack
/// did not acknowledge yet): keeps a stuck event from monopolising the P2 context.
const IRQ_RETRY: Duration = Duration::from_micros(250);
/// Fallback poll of the AL events, in case an IRQ edge was lost (also keeps the 64-bit cycle
/// count extension alive: it needs a call every < 25 s).
const ESC_POLL_PERIOD: Duration = Duration::from_millis(10);
/// LED update period: ETG.1300 flickering switches every 50 ms, so update well below that.
const LED_PERIOD: Duration = Duration::from_millis(10);
/// Statistics log period.
const REPORT_PERIOD: Duration = Duration::from_secs(1);

/// ESC-event context (P2): serves AL events on every SPI_IRQ falling edge, and again every
/// [`IRQ_RETRY`] while the line stays low (the IRQ is a level: low while any unmasked event is
/// pending; EXTI only sees edges).
#[embassy_executor::task]
pub async fn esc_event(irq: ExtiInput<'static, Blocking>) {
    loop {
        if irq.is_high() {
            // An edge between the check and the wait is kept by the signal.
            ESC_IRQ.wait().await;
        }
        esc_event_round();
        if irq.is_low() {
            Timer::after(IRQ_RETRY).await;
        }
    }
}

/// Free-run ticks (P2): requests a cycle every [`irq::free_run_period_ns`] (the free-run cycle
/// 1C32h:02 the slave accepted); the cycle context ignores it unless the slave is in free-run
/// mode.
#[embassy_executor::task]
pub async fn free_run() {
    let mut period_ns = irq::free_run_period_ns();
    let mut ticker = Ticker::every(Duration::from_nanos(u64::from(period_ns)));
    loop {
        ticker.next().await;
        free_run_tick();
        let current = irq::free_run_period_ns();
        if current != period_ns {
            period_ns = current;
            ticker = Ticker::every(Duration::from_nanos(u64::from(period_ns)));
        }
    }
}

/// One ESC-event round of the P2 context ([`esc_event`]). Never inlined: `panic-paths` tells the
/// tasks the P2 executor runs by their calls of this function and of [`free_run_tick`] (the
/// machine code does not say which executor a task was spawned on).
#[inline(never)]
fn esc_event_round() {
    irq::service_esc_events();
}

/// One free-run tick of the P2 context ([`free_run`]); never inlined, see [`esc_event_round`].
#[inline(never)]
fn free_run_tick() {
    irq::request_cycle(irq::REQUEST_FREE_RUN);
}

/// Value of the ESC type register 0x0000 on an ET1100.
pub const ET1100_TYPE: u8 = 0x11;

/// Whether the ESC answers on the PDI: type register = ET1100 and DL status "PDI operational"
/// (EEPROM loaded, 0x0110 bit 0). Before the EEPROM is loaded the SPI PDI is off and reads
/// return 0x00 (MISO pull-down), so this cannot be fooled by a floating bus.
pub fn esc_ready(pdi: &mut Et1100Spi<'_>) -> Result<bool, PdiError> {
    let esc_type = pdi.read_u8(regs::TYPE.addr)?;
    let dl_status = pdi.read_u16(regs::DL_STATUS.addr)?;
    Ok(esc_type == ET1100_TYPE && dl_status & DlStatus::PDI_OPERATIONAL != 0)
}

/// Thread mode: fallback poll of the AL events. Until the slave is started (`started` false
/// when the ESC was not ready at boot) it probes the ESC instead and starts the slave once the
/// ESC answers.
#[embassy_executor::task]
pub async fn esc_poll(mut started: bool) {
    let mut ticker = Ticker::every(ESC_POLL_PERIOD);
    loop {
        ticker.next().await;
        if started {
            irq::service_esc_events();
            continue;
        }
        let result = irq::with_drive(|d| match esc_ready(&mut d.pdi) {
            Ok(true) => d.core.start(&mut d.pdi).map(|()| true),
            Ok(false) => Ok(false),
            Err(e) => Err(e),
        });
        // Keep the 64-bit clock extension alive while not started.
        let _ = crate::time::now_cycles();
        if let Some(Ok(true)) = result {
            defmt::info!("ET1100 ready: slave started");
            started = true;
        }
    }
}

/// Thread mode: RUN/ERR LEDs with the ETG.1300 patterns the firmware computes
/// ([`firmware::slave::Slave::leds`]); ERR also lights while PDI accesses keep failing. Also
/// sets the digital outputs (brake) every 10 ms as a backstop.
#[embassy_executor::task]
pub async fn leds(mut leds: Leds) {
    let mut ticker = Ticker::every(LED_PERIOD);
    let mut seen_errors = 0u32;
    loop {
        ticker.next().await;
        let (run, err) = irq::with_drive(|d| {
            // The backstop of the outputs: every 10 ms whatever the contexts did (the cycle
            // and the ESC-event round set them as they change).
            d.drive_outputs();
            d.core.leds(crate::time::now_ns())
        })
        .unwrap_or((false, false));
        let errors =
            CYCLE_STATS.errors.load(Ordering::Relaxed) + EVENT_STATS.errors.load(Ordering::Relaxed);
        leds.set_run(run);
        leds.set_err(err || errors != seen_errors);
        seen_errors = errors;
    }
}

/// Thread mode: refreshes the independent watchdog every [`watchdog::CHECK_PERIOD_MS`] while
/// the control interrupt runs (if the board has a motor: `with_control`) and, in SAFEOP/OP of a
/// DC mode, the SYNC0 cycle does ([`Liveness`]). A refresh withheld a few times in a row resets
/// the MCU.
#[embassy_executor::task]
pub async fn watchdog(iwdg: Iwdg, with_control: bool) {
    let mut ticker = Ticker::every(Duration::from_millis(watchdog::CHECK_PERIOD_MS));
    let mut liveness = Liveness::new();
    loop {
        ticker.next().await;
        let control = with_control.then(|| CONTROL_STATS.runs.load(Ordering::Relaxed));
        let cycle_expected = irq::with_drive(|d| {
            let synchronous = matches!(d.core.sync_mode(), SyncMode::DcSync0 | SyncMode::DcSync1);
            synchronous && matches!(d.core.al_state(), AlState::SafeOp | AlState::Op)
        })
        .unwrap_or(false);
        let cycle = cycle_expected.then(|| CYCLE_STATS.runs.load(Ordering::Relaxed));
        if liveness.check(control, cycle) {
            iwdg.feed();
        } else {
            defmt::error!(
                "watchdog: a context stopped (control runs {}, cycle runs {}): no refresh",
                control,
                cycle
            );
        }
    }
}

/// Thread mode: logs the context statistics once per second.
#[embassy_executor::task]
pub async fn report() {
    let mut ticker = Ticker::every(REPORT_PERIOD);
    loop {
        ticker.next().await;
        log_stats("control", &CONTROL_STATS);
        log_phase_lock();
        log_stats("cycle", &CYCLE_STATS);
        log_stats("esc-event", &EVENT_STATS);
    }
}

/// The PWM's phase lock to SYNC0: state, the phase error at the last SYNC0 and the largest
/// since the lock was made, the period trim.
fn log_phase_lock() {
    let lock = irq::with_drive(|d| {
        d.sync_lock.as_ref().and_then(|s| {
            s.lock().map(|l| {
                (
                    l.state(),
                    l.last_error_ns(TIM1_HZ),
                    l.max_error_locked_ns(TIM1_HZ),
                    l.trim(),
                )
            })
        })
    })
    .flatten();
    if let Some((state, last_ns, max_ns, trim)) = lock {
        defmt::info!(
            "phase lock: {}, error {} ns (max {} ns since locked), ARR trim {}/256",
            state,
            last_ns,
            max_ns,
            trim
        );
    }
}

fn log_stats(name: &str, stats: &ContextStats) {
    let max_cycles = stats.max_cycles.swap(0, Ordering::Relaxed);
    let max_ns = u64::from(max_cycles) * 1_000_000_000 / u64::from(SYSCLK_HZ);
    defmt::info!(
        "{}: runs {}, errors {} (last kind {}), max {} cycles = {} ns",
        name,
        stats.runs.load(Ordering::Relaxed),
        stats.errors.load(Ordering::Relaxed),
        stats.last_error.load(Ordering::Relaxed),
        max_cycles,
        max_ns
    );
}
