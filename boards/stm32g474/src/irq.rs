//! Interrupt priorities, vectors and the contexts of DESIGN.md §3 on this board.
//!
//! | priority | vector | context | work |
//! |---|---|---|---|
//! | P0 | (TIM1_UP_TIM16 / ADC1_2, later) | FOC | **reserved** for the PWM/ADC control interrupt; nothing else uses P0 and the Slave/PDI lock does not mask it |
//! | P1 | EXTI4 (SYNC0, PB4) | cycle | [`on_sync0`](firmware::sync0::on_sync0) in DC modes, raw handler [`CycleHandler`]; also pended by software for free-run cycles |
//! | P2 | EXTI2 (SPI_IRQ, PD2) | ESC event | raw handler [`EscIrqHandler`]: clears the line and signals the ESC-event task |
//! | P2 | UART4 (spare, UART4 unused) | ESC event | `InterruptExecutor` running `tasks::esc_event` → [`Slave::on_esc_event`](firmware::slave::Slave::on_esc_event) (which also runs SM-synchronous cycles on the SM2 event), and `tasks::free_run` |
//! | P3 | TIM4 | embassy-time | alarm of the time driver (`time-driver-tim4`) |
//! | P4 | DMA1/2 channels | — | not used yet, kept out of P0 (`clocks::config`) |
//! | thread | — | background | embassy thread executor: fallback event poll, LEDs, statistics |
//!
//! The STM32G4 implements 4 priority bits (16 levels, `NVIC_PRIO_BITS` = 4, no sub-priority
//! split used); P0 is the most urgent.
//!
//! # Why raw handlers for SYNC0 and the IRQ line
//! The SYNC0 work is synchronous (no `.await`), so a plain handler has the shortest, fixed
//! latency (exception entry, ~12 cycles) where an `InterruptExecutor` would add a wake, a pend
//! and a poll. The IRQ line is not served by embassy's `exti::InterruptHandler` either: that
//! handler masks (IMR) *every* EXTI line 0–15 it finds pending, including SYNC0's, which would
//! race with [`CycleHandler`] and could switch SYNC0 off for good. Each handler here clears only
//! its own line. The ESC-event work itself runs in an `InterruptExecutor` (style.md E4) because
//! it will grow async parts (mailbox services waiting on timers).
//!
//! # Sharing the Slave and the PDI
//! Both contexts and thread mode call entry points of the one [`Slave`] with the one
//! [`Et1100Spi`]. They live in [`DRIVE`], a `Mutex<BasepriRawMutex<P1>, RefCell<..>>` (see
//! [`crate::lock`]): the lock raises BASEPRI to P1 for the whole entry-point call, so the FOC
//! interrupt (P0) is never delayed by it.
//!
//! Latency impact: SYNC0 (and the ESC event context) wait for the lock while a lower context
//! holds it, i.e. SYNC0 jitter can reach the longest `on_esc_event` call, dominated by its SPI
//! traffic: a 128-byte mailbox read is ≈ 49 µs at 21.25 MHz. That is acceptable for DC cycles
//! of 250 µs and more, not for 31.25 µs.
//!
//! Planned improvement (needs a firmware change, see the board README): split the Slave into a
//! cycle part (SM2/SM3 buffers, CiA402) owned by the SYNC0 context and an event part (ESM,
//! mailbox) owned by the ESC-event context, exchanging data through lock-free double buffers;
//! then only single PDI frames (≤ a few µs) need the lock, or the ESC-event context hands its
//! SPI frames to the cycle context's gaps.

use core::cell::RefCell;
use core::sync::atomic::{AtomicU32, AtomicU8, Ordering};

use cortex_m::peripheral::DWT;
use embassy_executor::{InterruptExecutor, SendSpawner};
use embassy_stm32::exti::{self, ExtiInput};
use embassy_stm32::gpio::{ExtiPin, Pin as GpioPin, Pull};
use embassy_stm32::interrupt::typelevel::{self, Binding, Handler};
use embassy_stm32::interrupt::{self as vector, InterruptExt};
use embassy_stm32::mode::Blocking;
use embassy_stm32::{bind_interrupts, pac, Peri};
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::blocking_mutex::Mutex;
use embassy_sync::signal::Signal;
use firmware::slave::SyncMode;
use firmware::DriveSlave;
use static_cell::StaticCell;

use crate::et1100_spi::{Error as PdiError, Et1100Spi};
use crate::lock::BasepriRawMutex;
use crate::pins::SYNC0_EXTI_LINE;
use crate::profile::RAM_SIZE;
use crate::storage::FlashStorage;
use crate::time::now_ns;
use firmware::params::ParamStore;

/// Interrupt priorities (see the module table).
pub mod prio {
    use embassy_stm32::interrupt::Priority;

    /// Reserved for the PWM/ADC FOC interrupt (DESIGN.md §3, highest priority). Unused so far.
    pub const FOC: Priority = Priority::P0;
    /// SYNC0 / process-data cycle.
    pub const CYCLE: Priority = Priority::P1;
    /// ESC IRQ line and the ESC-event executor.
    pub const ESC_EVENT: Priority = Priority::P2;
    /// embassy-time driver (TIM4).
    pub const TIME_DRIVER: Priority = Priority::P3;
    /// DMA channel interrupts (unused).
    pub const DMA: Priority = Priority::P4;

    const _: () = assert!((FOC as u8) < (CYCLE as u8));
    const _: () = assert!((CYCLE as u8) < (ESC_EVENT as u8));
    const _: () = assert!((ESC_EVENT as u8) < (TIME_DRIVER as u8));
}

bind_interrupts!(
    /// The vectors this board binds; handlers are checked against their vector at compile time.
    pub struct Irqs {
        EXTI2 => EscIrqHandler;
        EXTI4 => CycleHandler;
        UART4 => EscEventExecutor;
    }
);

/// What the cycle and the ESC-event contexts share.
pub struct Drive {
    /// The EtherCAT slave with its object dictionary.
    pub slave: DriveSlave<RAM_SIZE>,
    /// The ET1100.
    pub pdi: Et1100Spi<'static>,
    /// 1010h/1011h parameter storage in flash bank 2.
    pub params: ParamStore<FlashStorage>,
}

/// Storage of the [`Drive`] (in .bss: `StaticCell` is uninitialised memory, where a
/// `RefCell<Option<Drive>>` initialised to `None` would be copied from flash into .data).
static DRIVE_STORAGE: StaticCell<Drive> = StaticCell::new();

/// The shared [`Drive`], locked with the SYNC0 priority as ceiling. `None` until [`install`].
static DRIVE: Mutex<BasepriRawMutex<{ prio::CYCLE as u8 }>, RefCell<Option<&'static mut Drive>>> =
    Mutex::new(RefCell::new(None));

/// Moves the drive into its static storage and the shared cell; the contexts start using it
/// from now on. Builds the drive in place (`make` runs once; a second call panics).
pub fn install(make: impl FnOnce() -> Drive) {
    let drive = DRIVE_STORAGE.init_with(make);
    DRIVE.lock(|cell| {
        if let Ok(mut slot) = cell.try_borrow_mut() {
            *slot = Some(drive);
        }
    });
}

/// Runs `f` on the drive with the lock held. `None` before [`install`] (or on a re-entrant
/// call, which the design never makes).
pub fn with_drive<R>(f: impl FnOnce(&mut Drive) -> R) -> Option<R> {
    DRIVE.lock(|cell| {
        let mut slot = cell.try_borrow_mut().ok()?;
        slot.as_deref_mut().map(f)
    })
}

/// Counters of one context, read by `tasks::report`.
pub struct ContextStats {
    /// Completed runs of the entry point.
    pub runs: AtomicU32,
    /// Runs that ended in a PDI error.
    pub errors: AtomicU32,
    /// Longest run, in core cycles (DWT), lock wait included.
    pub max_cycles: AtomicU32,
    /// Error kind of the last error (`PdiErrorKind as u8 + 1`, 0 = none).
    pub last_error: AtomicU8,
}

impl ContextStats {
    const fn new() -> Self {
        Self {
            runs: AtomicU32::new(0),
            errors: AtomicU32::new(0),
            max_cycles: AtomicU32::new(0),
            last_error: AtomicU8::new(0),
        }
    }

    fn record(&self, started: u32, result: Option<Result<(), PdiError>>) {
        let cycles = DWT::cycle_count().wrapping_sub(started);
        self.max_cycles.fetch_max(cycles, Ordering::Relaxed);
        match result {
            Some(Ok(())) => {
                self.runs.fetch_add(1, Ordering::Relaxed);
            }
            Some(Err(e)) => {
                self.runs.fetch_add(1, Ordering::Relaxed);
                self.errors.fetch_add(1, Ordering::Relaxed);
                let kind = hal::pdi::PdiError::kind(&e) as u8;
                self.last_error.store(kind + 1, Ordering::Relaxed);
            }
            None => {}
        }
    }
}

/// Statistics of the cycle context.
pub static CYCLE_STATS: ContextStats = ContextStats::new();
/// Statistics of the ESC-event servicing (IRQ context and thread-mode fallback).
pub static EVENT_STATS: ContextStats = ContextStats::new();

/// Software cycle requests (bit set), consumed by [`CycleHandler`].
static CYCLE_REQUESTS: AtomicU8 = AtomicU8::new(0);
/// A free-run tick (`tasks::free_run`).
pub const REQUEST_FREE_RUN: u8 = 1 << 0;

/// Asks the cycle context to run one cycle; it decides from the sync mode whether the
/// request applies.
pub fn request_cycle(source: u8) {
    CYCLE_REQUESTS.fetch_or(source, Ordering::Release);
    vector::EXTI4.pend();
}

/// The cycle context: SYNC0 edge on EXTI4, or a software pend of the same vector.
pub struct CycleHandler;

impl Handler<typelevel::EXTI4> for CycleHandler {
    /// ISR: ESC SYNC0, EXTI4 at P1.
    /// - Rate: the DC cycle, 31.25 µs – 10 ms (32 kHz – 100 Hz); free-run 1 kHz.
    /// - Budget: `on_sync0` ≤ 2,000 instructions (DESIGN.md §6) ≈ 12 µs at 170 MHz, plus the
    ///   PDI bus time: (3 + n_out) + (2 + n_in) bytes × 376 ns, e.g. 2 × 32 B of PDO ≈ 26 µs.
    ///   Everything (lock wait included) must end before the next SYNC0, less the FOC load.
    /// - Measured: not yet on hardware. Each run's cycles (DWT, lock wait included) go to
    ///   `CYCLE_STATS.max_cycles`, logged every second by `tasks::report`; instruction counts of
    ///   `on_sync0` come from the QEMU benchmark (DESIGN.md §5).
    unsafe fn on_interrupt() {
        let started = DWT::cycle_count();
        // EXTI_PR1 is write-1-to-clear: this write touches line 4 only.
        let edge = pac::EXTI.pr(0).read().line(SYNC0_EXTI_LINE);
        if edge {
            pac::EXTI.pr(0).write(|w| w.set_line(SYNC0_EXTI_LINE, true));
        }
        let requests = CYCLE_REQUESTS.swap(0, Ordering::Acquire);
        let result = with_drive(|d| {
            let run = match d.slave.sync_mode() {
                SyncMode::DcSync0 | SyncMode::DcSync1 => edge,
                SyncMode::FreeRun => requests & REQUEST_FREE_RUN != 0,
                // `on_esc_event` runs the cycle itself when it sees the SM2 event.
                SyncMode::SmSynchronous => false,
            };
            if run {
                let result = firmware::sync0::on_sync0(&mut d.slave, &mut d.pdi, now_ns());
                // The measured duration becomes 1C32h/1C33h:06 (calc and copy time).
                d.slave.cycle_finished(now_ns());
                Some(result)
            } else {
                None
            }
        })
        .flatten();
        CYCLE_STATS.record(started, result);
    }
}

/// Signalled by [`EscIrqHandler`], awaited by `tasks::esc_event`.
pub static ESC_IRQ: Signal<CriticalSectionRawMutex, ()> = Signal::new();

/// The ESC IRQ line (SPI_IRQ, active low) on EXTI2.
pub struct EscIrqHandler;

/// EXTI line of the ESC IRQ (PD2).
const ESC_IRQ_EXTI_LINE: usize = 2;

impl Handler<typelevel::EXTI2> for EscIrqHandler {
    /// ISR: ESC SPI_IRQ falling edge, EXTI2 at P2.
    /// - Rate: at most one per EtherCAT frame that raises an unmasked AL event (≤ 1 per 31.25 µs
    ///   in practice, bursts during mailbox traffic).
    /// - Budget: ≤ 100 cycles (clear the line, signal the task: a ~20-cycle critical section).
    /// - Measured: not yet on hardware; to be measured with DWT stamps like the cycle context.
    unsafe fn on_interrupt() {
        pac::EXTI
            .pr(0)
            .write(|w| w.set_line(ESC_IRQ_EXTI_LINE, true));
        ESC_IRQ.signal(());
    }
}

/// The ESC-event context's executor (on the otherwise unused UART4 vector).
static ESC_EVENT_EXECUTOR: InterruptExecutor = InterruptExecutor::new();

/// Polls [`ESC_EVENT_EXECUTOR`] from the UART4 vector.
pub struct EscEventExecutor;

impl Handler<typelevel::UART4> for EscEventExecutor {
    /// ISR: ESC-event executor, UART4 (pended by software only) at P2.
    /// - Rate: once per ESC IRQ edge, per 10 ms retry while events stay pending, and per
    ///   free-run tick (1 kHz).
    /// - Budget: `on_esc_event` ≤ 60 µs per call (one 128-byte mailbox read ≈ 49 µs of SPI);
    ///   longer ESM checks must be split across polls.
    /// - Measured: not yet on hardware; `EVENT_STATS.max_cycles` (DWT) is logged every second.
    unsafe fn on_interrupt() {
        // SAFETY: called from the UART4 handler only, and UART4 is unmasked only by
        // `InterruptExecutor::start` in `start_esc_event_executor` (the UART4 peripheral is
        // never enabled, so the vector is pended by the executor only).
        unsafe { ESC_EVENT_EXECUTOR.on_interrupt() }
    }
}

/// Sets the priorities of every vector this board uses. Call right after
/// `embassy_stm32::init` (which enables all EXTI vectors at P0 and the TIM4 vector at P0) and
/// before any EXTI line is unmasked.
pub fn set_priorities() {
    vector::EXTI4.set_priority(prio::CYCLE);
    vector::EXTI2.set_priority(prio::ESC_EVENT);
    vector::UART4.set_priority(prio::ESC_EVENT);
    vector::TIM4.set_priority(prio::TIME_DRIVER);
}

/// Starts the ESC-event executor (priority set by [`set_priorities`]). `_irqs` proves that
/// UART4 polls this executor.
pub fn start_esc_event_executor(
    _irqs: impl Binding<typelevel::UART4, EscEventExecutor>,
) -> SendSpawner {
    ESC_EVENT_EXECUTOR.start(vector::UART4)
}

/// Configures SYNC0's EXTI line: rising edge (SYNC0 active high), pull-down. Only accepts a
/// pin whose EXTI channel has the vector [`CycleHandler`] is bound to (EXTI4).
pub fn sync0_input<T>(
    pin: Peri<'static, T>,
    channel: Peri<'static, T::ExtiChannel>,
    _irqs: impl Binding<typelevel::EXTI4, CycleHandler>,
) -> ExtiInput<'static, Blocking>
where
    T: GpioPin + ExtiPin,
    T::ExtiChannel: exti::Channel<IRQ = typelevel::EXTI4>,
{
    ExtiInput::new_blocking(pin, channel, Pull::Down, exti::TriggerEdge::Rising)
}

/// Configures the ESC IRQ's EXTI line: falling edge (SPI_IRQ active low), pull-up. Only
/// accepts a pin whose EXTI channel has the vector [`EscIrqHandler`] is bound to (EXTI2).
pub fn esc_irq_input<T>(
    pin: Peri<'static, T>,
    channel: Peri<'static, T::ExtiChannel>,
    _irqs: impl Binding<typelevel::EXTI2, EscIrqHandler>,
) -> ExtiInput<'static, Blocking>
where
    T: GpioPin + ExtiPin,
    T::ExtiChannel: exti::Channel<IRQ = typelevel::EXTI2>,
{
    ExtiInput::new_blocking(pin, channel, Pull::Up, exti::TriggerEdge::Falling)
}

/// Serves pending AL events once ([`Slave::on_esc_event`], which polls the AL event register
/// itself and also runs the SM-synchronous cycle on an SM2 event). Called from the ESC-event
/// context and from the thread-mode fallback poll.
pub fn service_esc_events() {
    let started = DWT::cycle_count();
    let result = with_drive(|d| {
        d.slave
            .on_esc_event_with(&mut d.pdi, &mut d.params, now_ns())
    });
    EVENT_STATS.record(started, result);
}
