//! The STM32G474 board's cycle interrupt as the board runs it: `stm32g4_axis`'s
//! [`CycleSide::on_cycle_interrupt`] (the process-data cycle, its duration for 1C32h:06, the
//! brake output, the PWM phase lock) on the slave's core in OP, the ESC as an image in memory.
//!
//! Two rows, which the report adds to the most expensive `sync0-handler-*` row for the board's
//! SYNC0 handler:
//! - `board-sync0-overhead`: what the board's handler adds to `on_sync0` (in the state of the
//!   `sync0-handler` row: OP, operation enabled, no motor, free run);
//! - `board-phase-lock`: the phase lock's update at a SYNC0 while locked (a 1 ms DC cycle,
//!   SYNC0 on its expected phase).

use core::hint::black_box;
use core::ptr::{addr_of_mut, write_volatile};

use firmware::sync0::on_sync0;
use stm32g4_axis::board::{CORE_CLOCK_HZ, PWM_PERIOD};
use stm32g4_axis::cycle::CycleSide;
use stm32g4_axis::inputs::BrakeOutput;
use stm32g4_axis::phase_lock::{LockState, PeriodTrim, Sync0Lock};
use stm32g4_axis::regs::OutputPins;

use super::sync0_handler::Setup;
use crate::harness::Harness;

/// TIM1's nominal auto-reload on the board.
const ARR: u16 = PWM_PERIOD.auto_reload;
/// The DC cycle of the phase-lock row, ns.
const CYCLE_NS: u32 = 1_000_000;

/// The brake pin as memory.
struct BrakePin(bool);

impl OutputPins for BrakePin {
    fn set_brake_released(&mut self, released: bool) {
        // SAFETY: a valid, aligned field of `self`.
        unsafe { write_volatile(addr_of_mut!(self.0), released) }
    }
}

/// The period trim the lock hands over.
static TRIM: PeriodTrim = PeriodTrim::new();

/// The benchmark.
pub fn run(h: &mut Harness) {
    const OVERHEAD: &str = "board-sync0-overhead";
    let Some(setup) = h.ready(OVERHEAD, <Setup>::powered_up()) else {
        return;
    };
    let Setup { core, esc, .. } = setup;
    let mut side = CycleSide {
        core,
        pdi: esc,
        brake: BrakeOutput::new(BrakePin(false)),
        sync_lock: Some(Sync0Lock::new(CORE_CLOCK_HZ, ARR)),
    };
    let plain = h.measure(OVERHEAD, &mut || {
        let _ = on_sync0(&mut side.core, &mut side.pdi, black_box(0));
    });
    let board = h.measure(OVERHEAD, &mut || {
        let _ = side.on_cycle_interrupt(black_box(Some(ARR)), true, || 0, &TRIM);
    });
    // The brake pin follows bit 0 of the axis' 60FEh:01 (1 = applied).
    let applied = side
        .core
        .app()
        .axis(0)
        .is_none_or(|a| a.digital_outputs() & firmware::cia402::outputs::BRAKE != 0);
    if side.brake.pins().0 == applied {
        h.fail(
            OVERHEAD,
            format_args!("the brake pin does not follow 60FEh:01 bit 0"),
        );
    }
    if let (Some(plain), Some(board)) = (plain, board) {
        match board.checked_sub(plain) {
            Some(overhead) => h.report(
                OVERHEAD,
                overhead,
                None,
                format_args!(
                    "what the board's cycle interrupt (stm32g4_axis CycleSide::on_cycle_interrupt) \
                     adds to on_sync0: sync-mode dispatch, cycle_finished (1C32h:06), the brake \
                     output, the phase lock outside DC ({board} − {plain} on_sync0, OP, \
                     operation enabled, free run)"
                ),
            ),
            None => h.fail(
                OVERHEAD,
                format_args!("the board's handler costs less than on_sync0"),
            ),
        }
    }

    const LOCK: &str = "board-phase-lock";
    let mut lock = Sync0Lock::new(CORE_CLOCK_HZ, ARR);
    let mut now = 0u64;
    // SYNC0 on the expected phase (the middle of the period): locked after a few cycles.
    for _ in 0..20 {
        now += u64::from(CYCLE_NS);
        lock.on_sync0(Some(CYCLE_NS), now, ARR);
    }
    if lock.lock().map(|l| l.state()) != Some(LockState::Locked) {
        h.fail(LOCK, format_args!("the phase lock did not lock"));
        return;
    }
    h.bench(
        LOCK,
        None,
        format_args!(
            "Sync0Lock::on_sync0 while locked: cycles since the last SYNC0, expected phase, \
             error, PI trim, lock judgement (1 ms DC cycle, SYNC0 on its expected phase)"
        ),
        &mut || {
            now += u64::from(CYCLE_NS);
            black_box(lock.on_sync0(Some(CYCLE_NS), black_box(now), black_box(ARR)));
        },
    );
}
