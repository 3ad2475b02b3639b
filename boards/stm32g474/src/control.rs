//! The control interrupt (P0): the end of ADC1's injected sequence, once per PWM period, runs
//! [`AxisHardware::control_interrupt`] — the same body the host tests and the QEMU benchmark
//! board run, here on TIM1, ADC1/ADC2, TIM2 and the GPIOs.
//!
//! The axis and its hardware ([`ControlContext`]) are used by this interrupt alone once
//! [`start`] has handed them over; the SYNC0 context reaches the axis only through [`LINK`]
//! (the lock-free set-point and feedback mailboxes), so nothing ever masks P0.

use core::ptr;
use core::sync::atomic::{AtomicPtr, Ordering};

use cortex_m::peripheral::DWT;
use embassy_stm32::interrupt::typelevel::{self, Binding, Handler};
use embassy_stm32::interrupt::{self as vector, InterruptExt};
use firmware::motor::axis::{Axis, AxisLink};
use static_cell::StaticCell;
use stm32g4_axis::control::AxisHardware;
use stm32g4_axis::phase_lock::PeriodTrim;

use crate::adc::{self, Adc12};
use crate::axis_io::{GateDriverEnable, GpioInputs};
#[cfg(feature = "biss-encoder")]
use crate::biss_spi::SpiFrames;
#[cfg(not(feature = "biss-encoder"))]
use crate::encoder::Tim2Encoder;
use crate::irq::{prio, ContextStats};
use crate::pwm::{PwmPins, Tim1};
use crate::sync_capture::Tim3Probes;
use firmware::motor::servo::ServoSpec;
#[cfg(feature = "biss-encoder")]
use stm32g4_axis::biss::BissEncoder;
#[cfg(not(feature = "biss-encoder"))]
use stm32g4_axis::quadrature::QuadratureEncoder;

/// The board's encoder driver: the incremental encoder on TIM2.
#[cfg(not(feature = "biss-encoder"))]
pub type BoardEncoder = QuadratureEncoder<Tim2Encoder>;
/// The board's encoder driver: the BiSS-C encoder on SPI1 with DMA.
#[cfg(feature = "biss-encoder")]
pub type BoardEncoder = BissEncoder<SpiFrames>;

/// The servo this image drives (its encoder is the one [`BoardEncoder`] reads).
#[cfg(not(feature = "biss-encoder"))]
pub const SERVO: ServoSpec = stm32g4_axis::board::SERVO;
/// The servo this image drives (its encoder is the one [`BoardEncoder`] reads).
#[cfg(feature = "biss-encoder")]
pub const SERVO: ServoSpec = stm32g4_axis::board::SERVO_BISS;

/// The board's axis hardware.
pub type BoardAxisHardware = AxisHardware<Tim1, Adc12, BoardEncoder, GpioInputs, Tim3Probes>;

/// What the control interrupt owns.
pub struct ControlContext {
    /// TIM1, ADC1/ADC2, TIM2, the input pins.
    pub hardware: BoardAxisHardware,
    /// The axis: current, speed and position loops, protections.
    pub axis: Axis,
    /// TIM1's pins, kept configured.
    pub _pwm_pins: PwmPins,
    /// The gate driver's enable, kept high.
    pub _gate_driver: GateDriverEnable,
}

/// The set-point and feedback mailboxes between the SYNC0 context (the drive application
/// publishes and reads) and the control interrupt.
// SAFETY (`AxisLink::new`): `publish`/`feedback` are called from the SYNC0 context (P1) only,
// through the drive application the cycle context owns; `control_step` from the control
// interrupt (P0) only, which preempts P1 and is never preempted by it.
pub static LINK: AxisLink = unsafe { AxisLink::new() };

/// The PWM period trim of the SYNC0 phase lock: set by the cycle context at each SYNC0, applied
/// by the control interrupt to each next period.
pub static PERIOD_TRIM: PeriodTrim = PeriodTrim::new();

/// Storage of the context (in .bss).
static CONTEXT_STORAGE: StaticCell<ControlContext> = StaticCell::new();
/// The context, once [`start`] has installed it: null before.
static CONTEXT: AtomicPtr<ControlContext> = AtomicPtr::new(ptr::null_mut());

/// Statistics of the control interrupt.
pub static CONTROL_STATS: ContextStats = ContextStats::new();

/// Hands `context` to the control interrupt and unmasks its vector at P0. Call once (a
/// second call panics in `StaticCell::init`: a bug, not an input).
pub fn start(context: ControlContext, _irqs: impl Binding<typelevel::ADC1_2, ControlHandler>) {
    let context = CONTEXT_STORAGE.init(context);
    CONTEXT.store(context, Ordering::Release);
    vector::ADC1_2.set_priority(prio::FOC);
    // SAFETY: the handler bound to ADC1_2 (checked by `_irqs`) is `ControlHandler`, which
    // touches nothing but its context and the ADC flags; no critical section relies on this
    // vector staying masked.
    unsafe { vector::ADC1_2.enable() };
}

/// The control interrupt on the ADC1_2 vector.
pub struct ControlHandler;

impl Handler<typelevel::ADC1_2> for ControlHandler {
    /// ISR: end of ADC1's injected sequence, ADC1_2 at P0.
    /// - Rate: the PWM frequency, 40 kHz (one sample per period, at the valley).
    /// - Budget: `Axis::control_step` ≤ 1,500 instructions (benchmark `control-interrupt`)
    ///   plus the drivers' register accesses, together ≤ 25 % of the 25 µs period (≈ 1,060
    ///   cycles of the 4,250 at 170 MHz are what is left after SYNC0 and the ESC event at the
    ///   shortest cycle; DESIGN.md §6). It starts ≈ 2.3 µs after the trigger (the ADC1
    ///   sequence) and must end before the next period's trigger.
    /// - Measured: not yet on hardware; each run's cycles (DWT) go to
    ///   `CONTROL_STATS.max_cycles`, logged every second by `tasks::report`.
    unsafe fn on_interrupt() {
        let started = DWT::cycle_count();
        if !adc::sequence_ended() {
            // No other ADC interrupt is enabled: a spurious entry.
            return;
        }
        // SAFETY: the pointer is null or the `&'static mut` that `start` gave up; this
        // handler is its only user and does not re-enter itself (one priority level).
        match unsafe { CONTEXT.load(Ordering::Acquire).as_mut() } {
            Some(context) => {
                context.hardware.control_interrupt(&mut context.axis, &LINK);
                CONTROL_STATS.record_run(started);
            }
            // Not installed yet (cannot happen: the vector is unmasked by `start`).
            None => adc::clear_sequence_flags(),
        }
    }
}
