//! Interrupt priorities, vectors and the contexts of DESIGN.md §3 on this board.
//!
//! | priority | vector | context | work |
//! |---|---|---|---|
//! | P0 | ADC1_2 (end of ADC1's injected sequence) | control | [`ControlHandler`](crate::control::ControlHandler): one PWM period of the axis; nothing else uses P0 and no lock masks it |
//! | P1 | TIM3 (SYNC0 captured on PB4 = TIM3_CH1, see `sync_capture`) | cycle | [`on_sync0`](firmware::sync0::on_sync0) in DC modes and the PWM phase lock, raw handler [`CycleHandler`]; also pended by software for free-run cycles |
//! | P2 | EXTI2 (SPI_IRQ, PD2) | ESC event | raw handler [`EscIrqHandler`]: clears the line and signals the ESC-event task |
//! | P2 | UART4 (spare, UART4 unused) | ESC event | `InterruptExecutor` running `tasks::esc_event` → [`service_esc_events`] (one ESC-event round; the core also runs SM-synchronous cycles on the SM2 event), and `tasks::free_run` |
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
//! and a poll. SYNC0 comes through TIM3's input capture rather than an EXTI line: the capture
//! is its hardware time stamp against the PWM (`sync_capture`), whatever the latency. The IRQ
//! line is not served by embassy's `exti::InterruptHandler` either: that handler masks (IMR)
//! *every* EXTI line 0–15 it finds pending; [`EscIrqHandler`] clears only its own line. The ESC-event work itself runs in an `InterruptExecutor` (style.md E4) because
//! it will grow async parts (mailbox services waiting on timers).
//!
//! # Sharing the slave and the PDI
//! The slave is in two parts (`ethercat_slave::slave`): the [`Drive`] (the slave's core and the
//! ET1100) lives in [`DRIVE`], a `Mutex<BasepriRawMutex<P1>, RefCell<..>>` (see
//! [`crate::lock`]) that the SYNC0 context locks for its cycle; the [`EventSide`] (mailbox side
//! with its own copy of the OD RAM, parameter storage) is used by the ESC-event context alone.
//! An ESC-event round ([`service_esc_events`]) takes the drive lock only for the core's short
//! steps (AL control and SM checks, copying the OD RAM to and from the mailbox side) and, through
//! `stm32g4_axis::event::DrivePdi`, for one SPI frame of at most 32 bytes at a time. The FOC interrupt
//! (P0) is never masked.
//!
//! Latency impact: SYNC0 waits at most for one of those steps (bounded by the OD RAM size or one
//! 32-byte frame, ≈ 13 µs of SPI), never for a whole mailbox transfer (≈ 49 µs for 128 bytes) or
//! an SDO service.

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
use static_cell::StaticCell;
use stm32g4_axis::cycle::CycleSide;
use stm32g4_axis::event::{self, SharedDrive};

use crate::axis_io::BrakePin;
use crate::et1100_spi::{Error as PdiError, Et1100Spi};
use crate::lock::BasepriRawMutex;
use crate::profile::RAM_SIZE;
use crate::storage::FlashStorage;
use crate::sync_capture;
use crate::time::now_ns;

/// Interrupt priorities (see the module table).
pub mod prio {
    use embassy_stm32::interrupt::Priority;

    /// The control interrupt: current, speed and position loops (DESIGN.md §3, highest
    /// priority).
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
        ADC1_2 => crate::control::ControlHandler;
        EXTI2 => EscIrqHandler;
        TIM3 => CycleHandler;
        UART4 => EscEventExecutor;
    }
);

/// What the cycle and the ESC-event contexts share: the slave's core and the ET1100, with the
/// brake output and the phase lock the cycle context drives ([`CycleSide`]). The ESC-event
/// context holds the lock only for the core's short steps and for single PDI transfers of at
/// most 32 bytes (`stm32g4_axis::event::DrivePdi`), never for a whole mailbox round.
pub type Drive = CycleSide<RAM_SIZE, Et1100Spi<'static>, BrakePin>;

/// What only the ESC-event context (its executor and the thread-mode fallback poll) uses: the
/// slave's mailbox side with its own copy of the OD RAM, and the 1010h/1011h parameter storage
/// in flash bank 2 its SDO services write.
pub type EventSide = event::EventSide<RAM_SIZE, FlashStorage, { crate::storage::SLOT_CAPACITY }>;

/// Storage of the [`Drive`] (in .bss: `StaticCell` is uninitialised memory, where a
/// `RefCell<Option<Drive>>` initialised to `None` would be copied from flash into .data).
static DRIVE_STORAGE: StaticCell<Drive> = StaticCell::new();
/// Storage of the [`EventSide`] (same reason).
static EVENT_SIDE_STORAGE: StaticCell<EventSide> = StaticCell::new();

/// The [`EventSide`], locked against the other user of the ESC-event work (executor at P2 and
/// thread mode) with the ESC-event priority as ceiling: SYNC0 (P1) is never masked by it.
static EVENT_SIDE: Mutex<
    BasepriRawMutex<{ prio::ESC_EVENT as u8 }>,
    RefCell<Option<&'static mut EventSide>>,
> = Mutex::new(RefCell::new(None));

/// The shared [`Drive`], locked with the SYNC0 priority as ceiling. `None` until [`install`].
static DRIVE: Mutex<BasepriRawMutex<{ prio::CYCLE as u8 }>, RefCell<Option<&'static mut Drive>>> =
    Mutex::new(RefCell::new(None));

/// Moves the drive and the event side into their static storage and shared cells; the
/// contexts start using them from now on (`make` runs once; a second call panics).
pub fn install(make: impl FnOnce() -> (Drive, EventSide)) {
    let (drive, event_side) = make();
    let drive = DRIVE_STORAGE.init(drive);
    let event_side = EVENT_SIDE_STORAGE.init(event_side);
    DRIVE.lock(|cell| {
        if let Ok(mut slot) = cell.try_borrow_mut() {
            *slot = Some(drive);
        }
    });
    EVENT_SIDE.lock(|cell| {
        if let Ok(mut slot) = cell.try_borrow_mut() {
            *slot = Some(event_side);
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

/// Runs `f` on the event side with its lock held (SYNC0 stays unmasked). `None` before
/// [`install`].
fn with_event_side<R>(f: impl FnOnce(&mut EventSide) -> R) -> Option<R> {
    EVENT_SIDE.lock(|cell| {
        let mut slot = cell.try_borrow_mut().ok()?;
        slot.as_deref_mut().map(f)
    })
}

/// The drive as the ESC-event context reaches it: through [`DRIVE`]'s lock, per step.
struct LockedDrive;

impl SharedDrive<RAM_SIZE, Et1100Spi<'static>, BrakePin> for LockedDrive {
    fn with<R>(&mut self, f: impl FnOnce(&mut Drive) -> R) -> Option<R> {
        with_drive(f)
    }
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
    /// No runs yet.
    pub const fn new() -> Self {
        Self {
            runs: AtomicU32::new(0),
            errors: AtomicU32::new(0),
            max_cycles: AtomicU32::new(0),
            last_error: AtomicU8::new(0),
        }
    }

    /// Records a run without errors that started at DWT count `started`.
    pub fn record_run(&self, started: u32) {
        self.record::<PdiError>(started, Some(Ok(())));
    }

    fn record<E: hal::pdi::PdiError>(&self, started: u32, result: Option<Result<(), E>>) {
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
/// Period of the free-run ticks before the slave accepted a free-run cycle (1 ms, the usual
/// 1C32h:02 default).
pub const DEFAULT_FREE_RUN_PERIOD_NS: u32 = 1_000_000;
/// The free-run cycle the slave accepted from 1C32h:02 at PREOP → SAFEOP (ETG.1020: the local
/// timer's period), published by the cycle context for `tasks::free_run`.
static FREE_RUN_PERIOD_NS: AtomicU32 = AtomicU32::new(DEFAULT_FREE_RUN_PERIOD_NS);

/// The period `tasks::free_run` ticks at.
pub fn free_run_period_ns() -> u32 {
    FREE_RUN_PERIOD_NS.load(Ordering::Relaxed)
}

/// Asks the cycle context to run one cycle; it decides from the sync mode whether the
/// request applies.
pub fn request_cycle(source: u8) {
    CYCLE_REQUESTS.fetch_or(source, Ordering::Release);
    vector::TIM3.pend();
}

/// The cycle context: SYNC0's capture on TIM3, or a software pend of the same vector.
pub struct CycleHandler;

impl Handler<typelevel::TIM3> for CycleHandler {
    /// ISR: ESC SYNC0 (TIM3 capture), TIM3 at P1.
    /// - Rate: the DC cycle, 31.25 µs – 10 ms (32 kHz – 100 Hz); free run at 1C32h:02.
    /// - Budget: `on_sync0` ≤ 2,000 instructions (DESIGN.md §6) ≈ 12 µs at 170 MHz, plus the
    ///   PDI bus time: (3 + n_out) + (2 + n_in) bytes × 376 ns, e.g. 2 × 32 B of PDO ≈ 26 µs,
    ///   plus 6 bytes (≈ 2.3 µs) for the AL event read of a profile that supervises the outputs
    ///   at each SYNC0 (`sync_error_on_missed_outputs`).
    ///   Everything (lock wait included) must end before the next SYNC0, less the FOC load.
    /// - Measured: not yet on hardware. Each run's cycles (DWT, lock wait included) go to
    ///   `CYCLE_STATS.max_cycles`, logged every second by `tasks::report`; instruction counts of
    ///   `on_sync0` come from the QEMU benchmark (DESIGN.md §5).
    unsafe fn on_interrupt() {
        let started = DWT::cycle_count();
        // SYNC0's phase in the PWM period, if this entry is a SYNC0 edge.
        let capture = sync_capture::take_capture();
        let requests = CYCLE_REQUESTS.swap(0, Ordering::Acquire);
        let result = with_drive(|d| {
            if d.core.sync_mode() == SyncMode::FreeRun {
                // In free run the slave's cycle is 1C32h:02 (0 below SAFEOP: keep the last).
                let cycle_ns = d.core.cycle_ns();
                if cycle_ns != 0 {
                    FREE_RUN_PERIOD_NS.store(cycle_ns, Ordering::Relaxed);
                }
            }
            d.on_cycle_interrupt(
                capture,
                requests & REQUEST_FREE_RUN != 0,
                now_ns,
                &crate::control::PERIOD_TRIM,
            )
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
    /// - Budget: one ESC-event round ≤ 60 µs (one 128-byte mailbox read ≈ 49 µs of SPI, taken in
    ///   32-byte frames); longer ESM checks must be split across polls. SYNC0 preempts it.
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
    vector::TIM3.set_priority(prio::CYCLE);
    vector::EXTI2.set_priority(prio::ESC_EVENT);
    vector::UART4.set_priority(prio::ESC_EVENT);
    vector::TIM4.set_priority(prio::TIME_DRIVER);
}

/// Unmasks the cycle context's vector (TIM3: SYNC0's capture and the software pends; priority
/// set by [`set_priorities`]). `_irqs` proves that TIM3 runs [`CycleHandler`].
pub fn start_cycle_vector(_irqs: impl Binding<typelevel::TIM3, CycleHandler>) {
    // SAFETY: `CycleHandler` takes the drive lock for everything it touches; no critical
    // section relies on TIM3 staying masked.
    unsafe { vector::TIM3.enable() };
}

/// Starts the ESC-event executor (priority set by [`set_priorities`]). `_irqs` proves that
/// UART4 polls this executor.
pub fn start_esc_event_executor(
    _irqs: impl Binding<typelevel::UART4, EscEventExecutor>,
) -> SendSpawner {
    ESC_EVENT_EXECUTOR.start(vector::UART4)
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

/// Serves pending AL events once: one ESC-event round of the slave (see
/// `ethercat_slave::slave::MailboxSide`): the core's short steps under the drive lock, the
/// mailbox round on the event side with the PDI taken frame by frame (`DrivePdi`), so
/// SYNC0 never waits for a mailbox transfer or an SDO service. Called from the ESC-event
/// context and from the thread-mode fallback poll.
pub fn service_esc_events() {
    let started = DWT::cycle_count();
    let result = with_event_side(|ev| ev.esc_event_round(&mut LockedDrive, now_ns())).flatten();
    EVENT_STATS.record(started, result);
}
