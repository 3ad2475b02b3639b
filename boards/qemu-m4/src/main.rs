//! Instruction-count benchmark of the firmware's hot paths on a Cortex-M4F: QEMU's MPS2 AN386
//! model with `-icount shift=0` (method: `counter` and `harness`; the benchmarks: `benches`).
//!
//! Run it with `benchmarks/run` (writes `benchmarks/REPORT.md`), or `cargo run --release` here for
//! the raw records. The program exits with status 0 only if every check passed.
#![no_std]
#![no_main]

mod benches;
mod counter;
mod harness;
mod semihosting;

use core::fmt::Write;
use core::panic::PanicInfo;

use cortex_m_rt::entry;

use counter::InstructionCounter;
use harness::Harness;
use semihosting::Console;

#[entry]
fn main() -> ! {
    let Some(peripherals) = cortex_m::Peripherals::take() else {
        semihosting::exit(false)
    };
    let mut harness = Harness::new(InstructionCounter::new(peripherals.SYST), Console::new());
    harness.calibrate();
    for bench in benches::ALL {
        bench(&mut harness);
    }
    semihosting::exit(harness.finish())
}

#[panic_handler]
fn panic(info: &PanicInfo) -> ! {
    let mut console = Console::new();
    let _ = writeln!(console, "FAIL\tpanic\t{info}");
    console.flush();
    semihosting::exit(false)
}
