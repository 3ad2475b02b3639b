//! A priority-ceiling lock on BASEPRI for data shared between the ESC contexts.
//!
//! [`BasepriRawMutex<CEILING>`] implements [`embassy_sync::blocking_mutex::raw::RawMutex`]: while
//! locked, BASEPRI is raised to `CEILING`, which masks every interrupt whose priority value is
//! `CEILING` or more (less urgent), and leaves the more urgent ones running. With the ceiling at
//! the SYNC0 priority (`irq::prio::CYCLE`), the FOC interrupt at P0 keeps running while the
//! Slave/PDI lock is held: this is the stack-resource policy (as in RTIC), instead of
//! `CriticalSectionRawMutex`, which would mask the FOC interrupt for the whole lock.
//!
//! # Soundness
//! `RawMutex` requires that no other context can lock while the lock is held. Every context
//! that can preempt the holder and lock too would have to run at a priority more urgent than
//! `CEILING`; [`lock`](BasepriRawMutex::lock) therefore checks the running context's priority
//! and resets the MCU *before* touching the data if a context more urgent than the ceiling (or
//! a system exception such as HardFault) tries to lock: a firmware bug, answered with the
//! state after reset (bridge off) rather than with the panic machinery, which no interrupt
//! may reach (`panic-paths`). Contexts at or below the ceiling are
//! masked while the lock is held, so they cannot run, let alone lock. The core is single-core
//! (Cortex-M4), so nothing else can run concurrently.
//!
//! Cost: about 10 cycles to lock (read ICSR and one NVIC priority byte, two BASEPRI writes).

use core::marker::PhantomData;
use core::sync::atomic::{compiler_fence, Ordering};

use cortex_m::interrupt::InterruptNumber;
use cortex_m::peripheral::scb::VectActive;
use cortex_m::peripheral::{NVIC, SCB};
use cortex_m::register::{basepri, basepri_max};
use embassy_sync::blocking_mutex::raw::RawMutex;

/// A lock that raises BASEPRI to `CEILING` (an NVIC priority value as written to the IPR
/// registers, e.g. `Priority::P1 as u8`; must not be 0, which would disable BASEPRI masking).
pub struct BasepriRawMutex<const CEILING: u8> {
    _not_constructible_elsewhere: PhantomData<()>,
}

// SAFETY: the lock holds no data; exclusion is by interrupt masking (see the module docs).
unsafe impl<const CEILING: u8> Send for BasepriRawMutex<CEILING> {}
// SAFETY: as above.
unsafe impl<const CEILING: u8> Sync for BasepriRawMutex<CEILING> {}

/// An external interrupt number as `cortex-m` wants it.
#[derive(Clone, Copy)]
struct Irqn(u16);

// SAFETY: `Irqn` only carries numbers read from ICSR.VECTACTIVE, which are valid IRQ numbers.
unsafe impl InterruptNumber for Irqn {
    fn number(self) -> u16 {
        self.0
    }
}

impl<const CEILING: u8> BasepriRawMutex<CEILING> {
    /// Resets the MCU if the running context is more urgent than the ceiling (see
    /// "Soundness").
    #[inline(always)]
    fn check_context() {
        match SCB::vect_active() {
            VectActive::ThreadMode => {}
            VectActive::Interrupt { irqn } => {
                let prio = NVIC::get_priority(Irqn(u16::from(irqn)));
                // No log: defmt's logger is not free of panics either.
                if prio < CEILING {
                    SCB::sys_reset();
                }
            }
            VectActive::Exception(_) => SCB::sys_reset(),
        }
    }
}

// SAFETY: see the module docs: while `f` runs, BASEPRI masks every context that is allowed to
// lock, and contexts that are not allowed to lock are refused before `f` runs.
unsafe impl<const CEILING: u8> RawMutex for BasepriRawMutex<CEILING> {
    const INIT: Self = {
        assert!(CEILING != 0, "BASEPRI 0 disables masking");
        assert!(
            CEILING & 0x0F == 0,
            "the STM32G4 implements 4 priority bits (the high nibble)"
        );
        Self {
            _not_constructible_elsewhere: PhantomData,
        }
    };

    #[inline(always)]
    fn lock<R>(&self, f: impl FnOnce() -> R) -> R {
        Self::check_context();
        let previous = basepri::read();
        // Only raises BASEPRI (BASEPRI_MAX semantics), so nesting inside a higher mask is fine.
        basepri_max::write(CEILING);
        compiler_fence(Ordering::SeqCst);
        let result = f();
        compiler_fence(Ordering::SeqCst);
        // SAFETY: restores the mask that was in force when this lock was taken; locks nest
        // strictly (closure scope), so this never unmasks a lock that is still held.
        unsafe { basepri::write(previous) };
        result
    }
}
