//! Instruction counting with the SysTick under QEMU `-icount shift=0`.
//!
//! With `-icount shift=N` QEMU advances its virtual clock by 2^N ns per executed guest
//! instruction, so with N = 0 the virtual time in ns *is* the instruction count. The SysTick,
//! clocked from the processor clock (CLKSOURCE = 1), runs on that virtual clock at the MPS2
//! SYSCLK of 25 MHz (QEMU hw/arm/mps2.c: `SYSCLK_FRQ`, connected to the ARMv7-M `cpuclk`), so one
//! SysTick tick is exactly [`INSTRUCTIONS_PER_TICK`] instructions. (The DWT cycle counter cannot
//! be used: QEMU does not model it, CYCCNT stays 0.)
//!
//! The SysTick is a 24-bit down-counter (ARMv7-M ARM §B3.3). Every span restarts it from the
//! largest reload value; a span that lasts long enough to reach zero is detected with COUNTFLAG
//! and refused rather than mismeasured.

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::SYST;

/// MPS2 SYSCLK (QEMU hw/arm/mps2.c `SYSCLK_FRQ`), the SysTick's processor clock.
const SYSCLK_HZ: u64 = 25_000_000;
/// Virtual nanoseconds per guest instruction with `-icount shift=0` (2^0).
const NS_PER_INSTRUCTION: u64 = 1;
const NS_PER_SECOND: u64 = 1_000_000_000;
/// Instructions per SysTick tick: 1 s / 25 MHz = 40 ns = 40 instructions.
pub const INSTRUCTIONS_PER_TICK: u64 = NS_PER_SECOND / SYSCLK_HZ / NS_PER_INSTRUCTION;
/// Largest SysTick reload value (24-bit counter).
const MAX_RELOAD: u32 = 0x00FF_FFFF;

/// A span that lasted so long the 24-bit SysTick passed zero (more than 2^24 ticks, about 670
/// million instructions): fewer iterations are needed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Overflow;

/// The SysTick as a free-running instruction counter.
pub struct InstructionCounter {
    syst: SYST,
}

impl InstructionCounter {
    /// Starts the SysTick from the processor clock with its largest reload value, without
    /// interrupt.
    pub fn new(mut syst: SYST) -> Self {
        syst.disable_interrupt();
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(MAX_RELOAD);
        syst.clear_current();
        syst.enable_counter();
        Self { syst }
    }

    /// Runs `f` and returns the SysTick ticks it took (the reads of the counter included; they are
    /// the same in every span and cancel against a baseline).
    #[inline(always)]
    pub fn ticks_of(&mut self, f: impl FnOnce()) -> Result<u32, Overflow> {
        // Writing the current value clears it and COUNTFLAG; the counter reloads MAX_RELOAD on
        // the next tick. A set COUNTFLAG afterwards means it counted down to 0 during `f`.
        self.syst.clear_current();
        let start = SYST::get_current();
        f();
        let end = SYST::get_current();
        if self.syst.has_wrapped() {
            return Err(Overflow);
        }
        // Down-counter: the elapsed ticks are start − end, modulo 2^24 because `start` may still
        // read 0 if the reload tick had not come yet (0 → MAX_RELOAD is one tick).
        Ok(start.wrapping_sub(end) & MAX_RELOAD)
    }
}
