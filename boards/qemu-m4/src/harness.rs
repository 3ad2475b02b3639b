//! The measurement and its output.
//!
//! An operation is called [`ITERATIONS`] times in a loop, and so is an empty operation through
//! the very same loop code (the baseline). The difference in instructions, divided by
//! [`ITERATIONS`], is the cost of one call. The SysTick counts in steps of
//! [`INSTRUCTIONS_PER_TICK`], so each span is quantised to less than one tick; the difference of
//! two spans to less than two. Divided by [`ITERATIONS`] that is far below one instruction, so an
//! operation that costs the same on every call is measured exactly; one whose cost is not a whole
//! number of instructions per call (it varies between calls) is reported as a failure.
//!
//! A cost includes the indirect call of the operation and its return (the empty operation is a
//! bare return, so what remains is the operation's body with its prologue and epilogue).
//!
//! The method was checked once against an instruction trace: with `ITERATIONS = 1` and QEMU's
//! `-singlestep -d exec,nochain`, the traced instructions from the entry of `repeat` to its
//! return, minus the baseline's, gave the same counts for every operation (after dropping the
//! trace's repeated lines of a block QEMU re-enters when the icount budget runs out).
//!
//! Output, one record per line, tab-separated, for `benchmarks/run` to turn into the report:
//!
//! | record | fields |
//! |---|---|
//! | `META` | key, value |
//! | `CALIBRATION` | expected, measured |
//! | `BENCH` | name, instructions, budget (`-` if none), description |
//! | `FAIL` | name, reason |
//! | `DONE` | `ok` or `failed` |

use core::fmt::{self, Write};
use core::hint::black_box;

use crate::counter::{InstructionCounter, INSTRUCTIONS_PER_TICK};
use crate::semihosting::Console;

/// Calls of an operation per measurement. Resolution: 2 ticks × 40 / 1000 = 0.08 instructions.
pub const ITERATIONS: u32 = 1_000;
/// NOPs of the calibration operation; it must measure exactly this many instructions.
const CALIBRATION_NOPS: u32 = 100;

/// Runs the operations and prints their costs.
pub struct Harness {
    counter: InstructionCounter,
    console: Console,
    /// SysTick ticks of [`ITERATIONS`] calls of the empty operation.
    baseline_ticks: u32,
    failed: bool,
}

/// Calls `op` `n` times. Never inlined, so that every operation and the baseline run exactly
/// the same loop code.
#[inline(never)]
fn repeat(n: u32, op: &mut dyn FnMut()) {
    for _ in 0..n {
        op();
    }
}

/// The empty operation of the baseline.
fn empty() {}

impl Harness {
    /// A harness that measures with `counter` and prints to `console`; measures the baseline.
    pub fn new(counter: InstructionCounter, console: Console) -> Self {
        let mut harness = Self {
            counter,
            console,
            baseline_ticks: 0,
            failed: false,
        };
        match harness.ticks(&mut empty) {
            Some(ticks) => harness.baseline_ticks = ticks,
            None => harness.fail("baseline", format_args!("the SysTick overflowed")),
        }
        harness.record(format_args!("META\titerations\t{ITERATIONS}"));
        harness.record(format_args!(
            "META\tinstructions_per_tick\t{INSTRUCTIONS_PER_TICK}"
        ));
        harness
    }

    /// Checks the method: an operation of [`CALIBRATION_NOPS`] NOPs must cost exactly that many
    /// instructions.
    pub fn calibrate(&mut self) {
        let mut nops = || {
            // SAFETY: NOPs only.
            unsafe {
                core::arch::asm!(
                    ".rept {n}",
                    "nop",
                    ".endr",
                    n = const CALIBRATION_NOPS,
                    options(nomem, nostack, preserves_flags)
                )
            }
        };
        let measured = self.instructions(&mut nops);
        self.record(format_args!(
            "CALIBRATION\t{CALIBRATION_NOPS}\t{}",
            Display(measured)
        ));
        if measured != Some(CALIBRATION_NOPS) {
            self.fail(
                "calibration",
                format_args!("{CALIBRATION_NOPS} NOPs did not measure {CALIBRATION_NOPS}"),
            );
        }
    }

    /// Measures `op` and prints it as benchmark `name` with its `budget` (instructions, if it has
    /// one) and a `description`. Returns the cost of one call.
    pub fn bench(
        &mut self,
        name: &str,
        budget: Option<u32>,
        description: fmt::Arguments<'_>,
        op: &mut dyn FnMut(),
    ) -> Option<u32> {
        let cost = self.measure(name, op)?;
        self.report(name, cost, budget, description);
        Some(cost)
    }

    /// Measures `op` without printing a result (for a benchmark derived from several
    /// measurements, printed with [`report`](Self::report)). Returns the cost of one call, or
    /// `None` after reporting the failure as benchmark `name`.
    pub fn measure(&mut self, name: &str, op: &mut dyn FnMut()) -> Option<u32> {
        let cost = self.instructions(op);
        if cost.is_none() {
            self.fail(
                name,
                format_args!("no whole number of instructions per call (overflow or varying cost)"),
            );
        }
        cost
    }

    /// The state a benchmark `name` needs, or `None` after reporting why it could not be
    /// reached (the benchmark then stops).
    pub fn ready<T>(&mut self, name: &str, setup: Result<T, &str>) -> Option<T> {
        match setup {
            Ok(state) => Some(state),
            Err(reason) => {
                self.fail(name, format_args!("{reason}"));
                None
            }
        }
    }

    /// Measures `base` and `with_base` (an operation that runs `base` first, e.g. the SYNC0
    /// side's set-point publish before a control interrupt) and returns
    /// `(with_base − base, with_base, base)`: the cost of what `with_base` adds. `None` after
    /// reporting a failure as benchmark `name`.
    pub fn measure_net(
        &mut self,
        name: &str,
        base: &mut dyn FnMut(),
        with_base: &mut dyn FnMut(),
    ) -> Option<(u32, u32, u32)> {
        let base_cost = self.measure(name, base)?;
        let with_cost = self.measure(name, with_base)?;
        match with_cost.checked_sub(base_cost) {
            Some(net) => Some((net, with_cost, base_cost)),
            None => {
                self.fail(
                    name,
                    format_args!("the base operation costs more than with it"),
                );
                None
            }
        }
    }

    /// Prints benchmark `name` with its cost `instructions` (measured by [`bench`](Self::bench)
    /// or derived from [`measure`](Self::measure)d costs) and checks its `budget`.
    pub fn report(
        &mut self,
        name: &str,
        instructions: u32,
        budget: Option<u32>,
        description: fmt::Arguments<'_>,
    ) {
        self.record(format_args!(
            "BENCH\t{name}\t{instructions}\t{}\t{description}",
            Display(budget)
        ));
        if let Some(b) = budget {
            if instructions > b {
                self.fail(
                    name,
                    format_args!("{instructions} instructions exceed the budget of {b}"),
                );
            }
        }
    }

    /// Prints a `META` record: a fact of the measured code the report computes with (e.g. a
    /// process-image size or a clock).
    pub fn meta(&mut self, key: &str, value: u32) {
        self.record(format_args!("META\t{key}\t{value}"));
    }

    /// Reports a failed check of a benchmark (e.g. the operation did not give the expected
    /// result); the run then ends with a failure status.
    pub fn fail(&mut self, name: &str, reason: fmt::Arguments<'_>) {
        self.failed = true;
        self.record(format_args!("FAIL\t{name}\t{reason}"));
    }

    /// Prints the closing record; `true` if nothing failed.
    pub fn finish(mut self) -> bool {
        let ok = !self.failed;
        self.record(format_args!("DONE\t{}", if ok { "ok" } else { "failed" }));
        ok
    }

    fn record(&mut self, line: fmt::Arguments<'_>) {
        // Console::write_str never fails.
        let _ = writeln!(self.console, "{line}");
    }

    /// SysTick ticks of [`ITERATIONS`] calls of `op`, or `None` on an overflow.
    fn ticks(&mut self, op: &mut dyn FnMut()) -> Option<u32> {
        self.counter
            .ticks_of(|| repeat(black_box(ITERATIONS), black_box(op)))
            .ok()
    }

    /// Instructions of one call of `op`, or `None` if the measurement cannot be exact.
    fn instructions(&mut self, op: &mut dyn FnMut()) -> Option<u32> {
        let ticks = self.ticks(op)?;
        let total =
            i64::from(ticks.checked_sub(self.baseline_ticks)?) * INSTRUCTIONS_PER_TICK as i64;
        let n = i64::from(ITERATIONS);
        let per_call = (total + n / 2) / n;
        // Quantisation of the two spans: less than one tick each.
        let tolerance = 2 * INSTRUCTIONS_PER_TICK as i64;
        if (total - per_call * n).abs() >= tolerance {
            return None;
        }
        u32::try_from(per_call).ok()
    }
}

/// An optional number, `-` for none.
struct Display(Option<u32>);

impl fmt::Display for Display {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            Some(n) => write!(f, "{n}"),
            None => f.write_str("-"),
        }
    }
}
