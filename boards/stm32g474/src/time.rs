//! Time base: DWT CYCCNT as [`hal::time::CycleCounter`], and a 64-bit nanosecond clock from it
//! (the `now_ns` the slave's entry points take).

use core::cell::Cell;

use cortex_m::peripheral::{DCB, DWT};
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::blocking_mutex::Mutex;
use hal::time::CycleCounter;

use crate::clocks::SYSCLK_HZ;

/// The core cycle counter (DWT CYCCNT, 170 MHz, wraps every 2³² / 170 MHz ≈ 25.3 s).
#[derive(Clone, Copy)]
pub struct CycleCount {
    _enabled: (),
}

impl CycleCount {
    /// Enables trace (DEMCR.TRCENA) and the cycle counter. Consumes the core peripherals so that
    /// nothing else reconfigures them.
    pub fn enable(mut dcb: DCB, mut dwt: DWT) -> Self {
        dcb.enable_trace();
        dwt.enable_cycle_counter();
        Self { _enabled: () }
    }
}

impl CycleCounter for CycleCount {
    fn frequency_hz(&self) -> u32 {
        SYSCLK_HZ
    }
    fn now(&self) -> u32 {
        DWT::cycle_count()
    }
}

/// (high word, last low word) of the 64-bit cycle count.
static EXTENSION: Mutex<CriticalSectionRawMutex, Cell<(u32, u32)>> = Mutex::new(Cell::new((0, 0)));

/// Cycles since the counter was enabled, extended to 64 bits.
///
/// A wrap of CYCCNT is seen as the low word going down, so this must be called at least once
/// every 25.3 s; the 10 ms fallback poll (`tasks::esc_poll`) guarantees it. The update runs
/// in a critical section of about 15 cycles (PRIMASK: it briefly delays even the P0 interrupt).
pub fn now_cycles() -> u64 {
    EXTENSION.lock(|ext| {
        let (mut high, last) = ext.get();
        let low = DWT::cycle_count();
        if low < last {
            high = high.wrapping_add(1);
        }
        ext.set((high, low));
        (u64::from(high) << 32) | u64::from(low)
    })
}

const fn gcd(a: u64, b: u64) -> u64 {
    if b == 0 {
        a
    } else {
        gcd(b, a % b)
    }
}

/// ns per cycle as the reduced fraction NS_NUM / NS_DEN (1e9 / 170e6 = 100 / 17).
const NS_GCD: u64 = gcd(1_000_000_000, SYSCLK_HZ as u64);
const NS_NUM: u64 = 1_000_000_000 / NS_GCD;
const NS_DEN: u64 = SYSCLK_HZ as u64 / NS_GCD;

/// Converts cycles to ns. `cycles * 100` overflows u64 only after 5.8·10⁹ s. One u64 division
/// (a library call on the M4, ~100 cycles): once per call site and cycle, acceptable outside the
/// FOC interrupt.
pub const fn cycles_to_ns(cycles: u64) -> u64 {
    cycles * NS_NUM / NS_DEN
}

/// Nanoseconds since the cycle counter was enabled.
pub fn now_ns() -> u64 {
    cycles_to_ns(now_cycles())
}

const _: () = assert!(NS_NUM == 100 && NS_DEN == 17);
