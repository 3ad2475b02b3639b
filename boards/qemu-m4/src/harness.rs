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
//! Four modes, chosen by the command line (QEMU `-append`):
//!
//! | mode | a measurement | returns |
//! |---|---|---|
//! | (none) | [`ITERATIONS`] calls counted with the SysTick, as above | instructions per call |
//! | `trace` | one call between the markers [`bench_span_begin`] and [`bench_span_end`], for an instruction trace (`-singlestep -d exec,nochain`) that `benchmarks/cycle-model` turns into a value per span | 0 |
//! | `replay FILE` | one call | the next line of the host file FILE: the span's value from the trace |
//! | `profile` | as `trace`, each span named by a `SPAN` record: `benchmarks/profile` attributes each span's instructions to the functions that executed them | 0 |
//!
//! The benchmarks run the same code in every mode, so the spans come in the same order, and a
//! replay derives its rows from the span values exactly as the counting run does from its
//! counts: replaying the trace's instruction counts must give the counting run's records, and
//! replaying its cycle estimates gives the same rows in cycles.
//!
//! Output, one record per line, tab-separated, for `benchmarks/run` to turn into the report:
//!
//! | record | fields |
//! |---|---|
//! | `META` | key, value; or key `name:input` (a fact of one input of a benchmark), value |
//! | `CALIBRATION` | expected, measured |
//! | `BENCH` | name, instructions (the max over its inputs), budget (`-` if none; `N*` a target not yet met, not enforced), description |
//! | `CASE` | name, input, instructions: one input of a benchmark measured over a set |
//! | `SPREAD` | name, min, median, max, number of inputs (after a set's `CASE` records) |
//! | `SPAN` | name (mode `profile`: the measurement of the next traced span) |
//! | `FAIL` | name, reason |
//! | `DONE` | `ok` or `failed` |

use core::fmt::{self, Write};
use core::hint::black_box;

use crate::counter::{InstructionCounter, INSTRUCTIONS_PER_TICK};
use crate::semihosting::{Arguments, Console, HostFile};

/// Most inputs one benchmark's set may hold.
pub const MAX_CASES: usize = 16;

/// The costs of one operation over a set of inputs that covers its branches
/// ([`Harness::case`] adds one, [`Harness::report_cases`] reports them). The budget applies to
/// the most expensive input.
pub struct Cases {
    name: &'static str,
    costs: [(&'static str, u32); MAX_CASES],
    len: usize,
}

impl Cases {
    /// An empty set for benchmark `name`.
    pub const fn new(name: &'static str) -> Self {
        Self {
            name,
            costs: [("", 0); MAX_CASES],
            len: 0,
        }
    }

    /// The measured inputs and their costs, in the order measured.
    pub fn costs(&self) -> &[(&'static str, u32)] {
        self.costs.get(..self.len).unwrap_or(&[])
    }

    /// (min, median, max) of the costs; the median of an even count is the lower middle one.
    fn spread(&self) -> Option<(u32, u32, u32)> {
        let mut sorted = [0u32; MAX_CASES];
        let sorted = sorted.get_mut(..self.len)?;
        for (dst, (_, cost)) in sorted.iter_mut().zip(self.costs()) {
            *dst = *cost;
        }
        sorted.sort_unstable();
        let min = *sorted.first()?;
        let max = *sorted.last()?;
        let median = *sorted.get((sorted.len() - 1) / 2)?;
        Some((min, median, max))
    }
}

/// Calls of an operation per measurement. Resolution: 2 ticks × 40 / 1000 = 0.08 instructions.
pub const ITERATIONS: u32 = 1_000;
/// NOPs of the calibration operation; it must measure exactly this many instructions.
const CALIBRATION_NOPS: u32 = 100;

/// How a measurement is made (module documentation).
enum Mode {
    Count,
    Trace,
    Profile,
    /// The values to replay, one decimal number per line.
    Replay(HostFile),
}

/// Runs the operations and prints their costs.
pub struct Harness {
    counter: InstructionCounter,
    console: Console,
    mode: Mode,
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

/// Marks the start of a traced span: the trace analysis counts from this function's first
/// instruction up to [`bench_span_end`]'s (the marker's own instructions are in the baseline
/// span too and cancel).
#[inline(never)]
#[no_mangle]
pub extern "C" fn bench_span_begin() {
    // SAFETY: a NOP; it keeps the two markers different functions (not merged by the linker).
    unsafe { core::arch::asm!("nop", options(nomem, nostack, preserves_flags)) };
}

/// Marks the end of a traced span ([`bench_span_begin`]).
#[inline(never)]
#[no_mangle]
pub extern "C" fn bench_span_end() {
    // SAFETY: NOPs only.
    unsafe { core::arch::asm!("nop", "nop", options(nomem, nostack, preserves_flags)) };
}

impl Harness {
    /// A harness that measures with `counter` and prints to `console`; measures the baseline.
    pub fn new(counter: InstructionCounter, console: Console) -> Self {
        let args = Arguments::get();
        let mut words = args.words();
        let (mode, bad_mode) = match (words.next(), words.next()) {
            (None, _) => (Mode::Count, false),
            (Some("trace"), None) => (Mode::Trace, false),
            (Some("profile"), None) => (Mode::Profile, false),
            (Some("replay"), Some(path)) => match HostFile::open(path) {
                Some(file) => (Mode::Replay(file), false),
                None => (Mode::Count, true),
            },
            _ => (Mode::Count, true),
        };
        let mut harness = Self {
            counter,
            console,
            mode,
            baseline_ticks: 0,
            failed: false,
        };
        if bad_mode {
            harness.fail(
                "mode",
                format_args!(
                    "arguments: none, `trace`, `profile`, or `replay FILE` (a readable file)"
                ),
            );
        }
        match harness.mode {
            Mode::Count => match harness.ticks(&mut empty) {
                Some(ticks) => harness.baseline_ticks = ticks,
                None => harness.fail("baseline", format_args!("the SysTick overflowed")),
            },
            // The baseline is the first span; its value, the others' reference, is 0.
            Mode::Trace | Mode::Profile | Mode::Replay(_) => {
                if harness.instructions(&mut empty) != Some(0) {
                    harness.fail("baseline", format_args!("the replayed baseline is not 0"));
                }
            }
        }
        harness.record(format_args!("META\titerations\t{ITERATIONS}"));
        harness.record(format_args!(
            "META\tinstructions_per_tick\t{INSTRUCTIONS_PER_TICK}"
        ));
        harness
    }

    /// Whether this run traces every benchmark for a profile (mode `profile`).
    pub fn profiling(&self) -> bool {
        matches!(self.mode, Mode::Profile)
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
        // A trace run measures nothing (its values come from the trace afterwards).
        if !matches!(self.mode, Mode::Trace | Mode::Profile) && measured != Some(CALIBRATION_NOPS) {
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
        if self.profiling() {
            self.record(format_args!("SPAN\t{name}"));
        }
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

    /// The cost of `op` on `state` as `snapshot` has it, for an operation whose cost differs
    /// from call to call (it changes the state): each call restores `state` from `snapshot`
    /// first, and the restore, measured alone, is subtracted. `None` after reporting a failure
    /// as benchmark `name`.
    ///
    /// `op` is generic, not `dyn`: it inlines into the measured call as the operation would
    /// run, without an indirect call the restore alone does not have.
    pub fn measure_from<T: Clone>(
        &mut self,
        name: &str,
        snapshot: &T,
        state: &mut T,
        mut op: impl FnMut(&mut T),
    ) -> Option<u32> {
        // Measured in turn rather than through `measure_net`: both closures write `state`.
        let restore = self.measure(name, &mut || *state = black_box(snapshot).clone())?;
        let both = self.measure(name, &mut || {
            *state = black_box(snapshot).clone();
            op(state);
        })?;
        let cost = both.checked_sub(restore);
        if cost.is_none() {
            self.fail(
                name,
                format_args!("the restore costs more than restore + operation"),
            );
        }
        cost
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
        // The budgets are instructions: a replay of other values (cycles) is not held to them.
        if let (Some(b), Mode::Count) = (budget, &self.mode) {
            if instructions > b {
                self.fail(
                    name,
                    format_args!("{instructions} instructions exceed the budget of {b}"),
                );
            }
        }
    }

    /// Adds input `label` of `cases`, measured as `cost` (by [`measure`](Self::measure) or
    /// [`measure_net`](Self::measure_net)); prints it as a `CASE` record. A set that is full
    /// fails the run.
    pub fn case(&mut self, cases: &mut Cases, label: &'static str, cost: u32) {
        match cases.costs.get_mut(cases.len) {
            Some(slot) => {
                *slot = (label, cost);
                cases.len += 1;
                self.record(format_args!("CASE\t{}\t{label}\t{cost}", cases.name));
            }
            None => self.fail(
                cases.name,
                format_args!("more than {MAX_CASES} inputs in one set"),
            ),
        }
    }

    /// Reports benchmark `cases` over its inputs: a `SPREAD` record (min, median, max) and the
    /// `BENCH` record with the max, checked against `budget`. Returns the max; `None` (a
    /// failure) if no input was measured.
    pub fn report_cases(
        &mut self,
        cases: &Cases,
        budget: Option<u32>,
        description: fmt::Arguments<'_>,
    ) -> Option<u32> {
        let max = self.spread(cases)?;
        self.report(cases.name, max, budget, description);
        Some(max)
    }

    /// Reports benchmark `cases` against a `target` not yet met (a budget of an open issue):
    /// as [`report_cases`](Self::report_cases), the budget printed with a `*` and not
    /// enforced, so that the measurement is in the report while the work goes on. Returns the
    /// max.
    pub fn report_cases_target(
        &mut self,
        cases: &Cases,
        target: u32,
        description: fmt::Arguments<'_>,
    ) -> Option<u32> {
        let max = self.spread(cases)?;
        self.record(format_args!(
            "BENCH\t{}\t{max}\t{target}*\t{description}",
            cases.name
        ));
        Some(max)
    }

    /// Prints the `SPREAD` record of `cases` and returns their max; `None` (a failure) if no
    /// input was measured.
    fn spread(&mut self, cases: &Cases) -> Option<u32> {
        let Some((min, median, max)) = cases.spread() else {
            self.fail(cases.name, format_args!("no input was measured"));
            return None;
        };
        self.record(format_args!(
            "SPREAD\t{}\t{min}\t{median}\t{max}\t{}",
            cases.name, cases.len
        ));
        Some(max)
    }

    /// Prints a `META` record: a fact of the measured code the report computes with (e.g. a
    /// process-image size or a clock).
    pub fn meta(&mut self, key: &str, value: u32) {
        self.record(format_args!("META\t{key}\t{value}"));
    }

    /// Prints a `META` record of one input of a benchmark: key `key:input`.
    pub fn meta_of(&mut self, key: &str, input: fmt::Arguments<'_>, value: u32) {
        self.record(format_args!("META\t{key}:{input}\t{value}"));
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

    /// Instructions of one call of `op` (or in the other modes what the module documentation
    /// says), or `None` if the measurement cannot be exact.
    fn instructions(&mut self, op: &mut dyn FnMut()) -> Option<u32> {
        match self.mode {
            Mode::Count => self.counted(op),
            Mode::Trace | Mode::Profile => {
                bench_span_begin();
                repeat(black_box(1), black_box(op));
                bench_span_end();
                Some(0)
            }
            Mode::Replay(ref mut file) => {
                repeat(black_box(1), black_box(op));
                replayed(file)
            }
        }
    }

    /// Instructions of one call of `op` counted with the SysTick over [`ITERATIONS`] calls.
    fn counted(&mut self, op: &mut dyn FnMut()) -> Option<u32> {
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

/// The next value of a replay input: one decimal number per line; `None` at its end or on
/// anything else.
fn replayed(file: &mut HostFile) -> Option<u32> {
    let mut value: u32 = 0;
    let mut digits = 0;
    loop {
        match file.read_byte()? {
            b'\n' if digits > 0 => return Some(value),
            d @ b'0'..=b'9' => {
                value = value.checked_mul(10)?.checked_add(u32::from(d - b'0'))?;
                digits += 1;
            }
            _ => return None,
        }
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
