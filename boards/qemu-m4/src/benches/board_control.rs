//! The STM32G474 board's control interrupt as the board runs it: `stm32g4_axis`'s
//! [`AxisHardware::control_interrupt`] (period start with the SYNC0 period trim, the ADC
//! conversions latched and converted, the input pins, the encoder counter extended, the axis
//! step, the compare values and MOE written) with the board's servo, front end and tuning. Only
//! the register accesses differ from the board: they go to memory here (volatile, like the
//! peripheral registers), through the same register traits.
//!
//! Measured in the loop period (loop divider 1, a new set-point every period) over the inputs
//! whose interrupts differ in CSP: at rest, following, and a step that drives the current to
//! its limit and the voltage to its circle, each from the axis running at rest (a copy of it
//! restored before every call, the restore measured alone and subtracted); and over one loop
//! cycle of the board's tuning (the loop period and the periods after it, which run the current
//! loop alone), the figure the report's interrupt load averages. The board's
//! incremental encoder is aligned after each enable; the measurement
//! gives the alignment's result as the commissioned commutation offset, so that the axis is in
//! closed loop from the start (the same code runs after an alignment).

use core::hint::black_box;
use core::ptr::{addr_of, addr_of_mut, read_volatile, write_volatile};

use firmware::motor::axis::{Axis, AxisCommand, AxisFeedback, AxisLink, AxisState};
use firmware::motor::servo::{axis_config, Tuning};
use stm32g4_axis::board::{
    BOOTSTRAP_PRECHARGE_PERIODS, CORE_CLOCK_HZ, COUNTS_PER_REV, FRONT_END, PDI_SPI_CLOCK_HZ,
    PWM_HZ, PWM_PERIOD, SERVO, TUNING,
};
use stm32g4_axis::control::AxisHardware;
use stm32g4_axis::inputs::{BoardInputs, InputLine, InputPolarity};
use stm32g4_axis::inverter::{compare_for_duty, GateState, Tim1Inverter};
use stm32g4_axis::phase_lock::PeriodTrim;
use stm32g4_axis::quadrature::QuadratureEncoder;
use stm32g4_axis::regs::{Conversions, EncoderCounter, InjectedAdcs, InputPins, PwmTimer};
use stm32g4_axis::sensing;

use crate::harness::{Cases, Harness};

/// TIM1's auto-reload on the board.
const ARR: u16 = PWM_PERIOD.auto_reload;
/// The ADC counts of zero current (the amplifiers' bias), 48 V and 25 °C on the board's front
/// end (`stm32g4_axis::board::FRONT_END`).
const AT_REST: Conversions = Conversions {
    phase: [2_048; 3],
    bus: 1_922,
    temperature: 931,
};

/// TIM1's registers as memory.
struct Tim1 {
    arr: u16,
    ccr: [u16; 3],
    moe: bool,
    bif: bool,
}

impl PwmTimer for Tim1 {
    fn auto_reload(&self) -> u16 {
        // SAFETY: a valid, aligned field of `self`.
        unsafe { read_volatile(addr_of!(self.arr)) }
    }
    fn set_auto_reload(&mut self, arr: u16) {
        // SAFETY: as above.
        unsafe { write_volatile(addr_of_mut!(self.arr), arr) }
    }
    fn set_compares(&mut self, compares: [u16; 3]) {
        for (i, c) in compares.into_iter().enumerate() {
            if let Some(ccr) = self.ccr.get_mut(i) {
                // SAFETY: as above.
                unsafe { write_volatile(ccr, c) }
            }
        }
    }
    fn set_main_output(&mut self, enabled: bool) {
        // SAFETY: as above.
        unsafe { write_volatile(addr_of_mut!(self.moe), enabled) }
    }
    fn take_break(&mut self) -> bool {
        // SAFETY: as above.
        let fired = unsafe { read_volatile(addr_of!(self.bif)) };
        if fired {
            // SAFETY: as above.
            unsafe { write_volatile(addr_of_mut!(self.bif), false) }
        }
        fired
    }
}

/// ADC1/ADC2's injected data registers as memory.
struct Adcs(Conversions);

impl InjectedAdcs for Adcs {
    fn take_conversions(&mut self) -> Conversions {
        // SAFETY: a valid, aligned field of `self`.
        unsafe { read_volatile(addr_of!(self.0)) }
    }
}

/// TIM2's counter and capture as memory.
struct Tim2 {
    count: u32,
    index: Option<u32>,
}

impl EncoderCounter for Tim2 {
    fn count(&self) -> u32 {
        // SAFETY: as above.
        unsafe { read_volatile(addr_of!(self.count)) }
    }
    fn take_index(&mut self) -> Option<u32> {
        // SAFETY: as above.
        unsafe { read_volatile(addr_of!(self.index)) }
    }
    fn line_fault(&self) -> bool {
        false
    }
}

/// The GPIO input levels as memory: both STO channels closed, nothing else active.
struct Pins(u32);

impl InputPins for Pins {
    fn levels(&self) -> u32 {
        // SAFETY: as above.
        unsafe { read_volatile(addr_of!(self.0)) }
    }
}

/// The SYNC0 period trim (zero: the measurement runs without SYNC0).
static TRIM: PeriodTrim = PeriodTrim::new();

/// The command of the `motor` benchmarks (enabled, CSP) with the target on the actual position:
/// the quadrature counter's first reading is position 0.
const COMMAND: AxisCommand = AxisCommand {
    position: 0,
    ..super::motor::COMMAND
};

type Board = AxisHardware<Tim1, Adcs, QuadratureEncoder<Tim2>, Pins>;

/// The board's hardware in its power-on state.
fn board() -> Board {
    let (currents, bus) = sensing::sensing(&FRONT_END);
    AxisHardware {
        inverter: Tim1Inverter::new(
            Tim1 {
                arr: ARR,
                ccr: [0; 3],
                moe: false,
                bif: false,
            },
            PWM_HZ,
        )
        .with_period_trim(&TRIM)
        .with_bootstrap_precharge(BOOTSTRAP_PRECHARGE_PERIODS),
        adcs: Adcs(AT_REST),
        currents,
        bus,
        encoder: QuadratureEncoder::new(
            Tim2 {
                count: 0x8000_1234,
                index: None,
            },
            COUNTS_PER_REV,
        ),
        inputs: BoardInputs::new(
            Pins(
                InputLine::SafeTorqueOff1.mask()
                    | InputLine::SafeTorqueOff2.mask()
                    | InputLine::Enable.mask(),
            ),
            InputPolarity { active_low: 0 },
        ),
    }
}

/// The axis of the board's servo with a new set-point every period, running at rest.
fn running(hw: &mut Board, link: &AxisLink) -> Result<Axis, &'static str> {
    let tuning = Tuning {
        loop_divider: 1,
        bus_cycle_s: 1.0 / PWM_HZ as f32,
        ..TUNING
    };
    running_with(hw, link, &tuning)
}

/// The axis of the board's servo at `tuning`, running at rest with the gates on.
fn running_with(hw: &mut Board, link: &AxisLink, tuning: &Tuning) -> Result<Axis, &'static str> {
    let mut cfg = axis_config(&SERVO, tuning);
    cfg.motor.commutation_offset = Some(0);
    let mut axis = Axis::new(cfg).map_err(|_| "the board's axis configuration was refused")?;
    for _ in 0..cfg.offset_samples + 16 {
        link.publish(COMMAND);
        hw.control_interrupt(&mut axis, link);
    }
    let fb = link.feedback();
    let centre = compare_for_duty(0.5, ARR);
    let at_rest = axis.state() == AxisState::Running
        && fb.position == 0
        && fb.following_error == 0
        && hw.inverter.gates() == GateState::On
        && hw.inverter.timer().moe
        && hw
            .inverter
            .timer()
            .ccr
            .iter()
            .all(|&c| c.abs_diff(centre) <= 1);
    at_rest
        .then_some(axis)
        .ok_or("the board's axis is not running at rest with the gates on")
}

/// The axis of the board's servo at the board's tuning (the position and speed loops every
/// `TUNING.loop_divider`-th period) with a new set-point every loop period, running at rest,
/// its next period a loop period.
fn running_before_loop_period(hw: &mut Board, link: &AxisLink) -> Result<Axis, &'static str> {
    let tuning = Tuning {
        bus_cycle_s: TUNING.loop_divider as f32 / PWM_HZ as f32,
        ..TUNING
    };
    let mut axis = running_with(hw, link, &tuning)?;
    for _ in 0..TUNING.loop_divider {
        // A copy takes a step's set-point: in a loop period the current loop drives it.
        let mut probe = axis.clone();
        link.publish(STEP);
        hw.control_interrupt(&mut probe, link);
        let loop_period = !centred(&hw.inverter.timer().ccr);
        link.publish(COMMAND);
        if loop_period {
            return Ok(axis);
        }
        hw.control_interrupt(&mut axis, link);
    }
    Err("no period of the loop cycle took the set-point")
}

/// A set-point step that drives the current to its limit and the voltage to its circle.
const STEP: AxisCommand = AxisCommand {
    position: 200_000,
    ..COMMAND
};

/// One input of the measurement: the command published before the interrupt, and the check
/// that the interrupt took the input's branch (the axis, its feedback, the compares written).
struct BoardInput {
    label: &'static str,
    command: AxisCommand,
    branch: fn(&Axis, &AxisFeedback, &[u16; 3]) -> bool,
}

/// Whether the axis runs with the gates on and no fault.
fn runs(axis: &Axis, fb: &AxisFeedback) -> bool {
    axis.state() == AxisState::Running && axis.fault().is_none() && fb.fault.is_none()
}

/// Whether every compare is at the centre (zero voltage), within a tick.
fn centred(compares: &[u16; 3]) -> bool {
    let centre = compare_for_duty(0.5, ARR);
    compares.iter().all(|&c| c.abs_diff(centre) <= 1)
}

/// The spread of the compares as a fraction of the period: above 0.8 the voltage vector is at
/// the circle of the servo's `max_modulation` (see the `control-interrupt` inputs).
fn compare_span(compares: &[u16; 3]) -> f32 {
    let (lo, hi) = compares
        .iter()
        .fold((u16::MAX, 0), |(lo, hi), &c| (lo.min(c), hi.max(c)));
    f32::from(hi.saturating_sub(lo)) / f32::from(ARR)
}

/// The inputs, in CSP with a new set-point every period.
const INPUTS: [BoardInput; 3] = [
    BoardInput {
        label: "CSP at rest",
        command: COMMAND,
        branch: |a, fb, c| runs(a, fb) && fb.following_error == 0 && centred(c),
    },
    BoardInput {
        label: "CSP following (1 increment per period)",
        command: AxisCommand {
            position: 1,
            ..COMMAND
        },
        // One increment of the board's encoder is a large error for its gains: the current
        // may reach its limit here already (the step below takes the voltage to its circle).
        branch: |a, fb, c| runs(a, fb) && !centred(c),
    },
    BoardInput {
        label: "CSP step: torque limit, voltage circle",
        command: STEP,
        branch: |a, fb, c| runs(a, fb) && fb.current_limited && compare_span(c) > 0.8,
    },
];

/// The control interrupt's cost over `PERIODS` periods from `snapshot` (the first a loop
/// period), for every input published before them: the cases of benchmark `name`. `None`
/// after a failure reported to the harness.
fn measure_inputs<const PERIODS: u32>(
    h: &mut Harness,
    name: &'static str,
    snapshot: &Axis,
    link: &AxisLink,
    hw: &mut Board,
) -> Option<Cases> {
    let mut cases = Cases::new(name);
    for input in INPUTS {
        let command = input.command;
        let mut axis = snapshot.clone();
        link.publish(command);
        for _ in 0..PERIODS {
            hw.control_interrupt(&mut axis, link);
        }
        let (fb, compares) = (link.feedback(), hw.inverter.timer().ccr);
        if !hw.inverter.timer().moe || !(input.branch)(&axis, &fb, &compares) {
            h.fail(
                name,
                format_args!(
                    "input \"{}\" did not take its branch over {PERIODS} period(s): state {:?} \
                     following error {} current limited {} compares {:?}",
                    input.label,
                    axis.state(),
                    fb.following_error,
                    fb.current_limited,
                    compares
                ),
            );
            return None;
        }
        let mut restored = snapshot.clone();
        let (cost, _, _) = h.measure_net(
            name,
            &mut || {
                restored = black_box(snapshot).clone();
                link.publish(black_box(command));
                black_box(&mut restored);
            },
            &mut || {
                axis = black_box(snapshot).clone();
                link.publish(black_box(command));
                for _ in 0..PERIODS {
                    black_box(hw.control_interrupt(&mut axis, link));
                }
            },
        )?;
        h.case(&mut cases, input.label, cost);
    }
    Some(cases)
}

/// The benchmark.
pub fn run(h: &mut Harness) {
    const NAME: &str = "board-control-interrupt";
    // SAFETY: the benchmark runs in one context only.
    let link = unsafe { AxisLink::new() };
    let mut hw = board();
    let Some(snapshot) = h.ready(NAME, running(&mut hw, &link)) else {
        return;
    };
    let Some(cases) = measure_inputs::<1>(h, NAME, &snapshot, &link, &mut hw) else {
        return;
    };
    // The board's clocks and PWM rate: the interrupt-load section of the report.
    h.meta("board_core_clock_hz", CORE_CLOCK_HZ);
    h.meta("board_pwm_hz", PWM_HZ);
    h.meta("board_pdi_spi_hz", PDI_SPI_CLOCK_HZ);
    // No budget of its own: DESIGN.md §6 budgets the whole control interrupt, drivers included,
    // at 1,500; the report's load section sets this count against the board's time.
    h.report_cases(
        &cases,
        None,
        format_args!(
            "the STM32G474 board's control interrupt (stm32g4_axis AxisHardware::control_interrupt: \
             period trim, ADC latch and conversion, inputs, encoder, Axis::control_step, compares \
             and MOE; registers as memory) in its loop period with a new set-point every period \
             (the SYNC0 publish subtracted), over the CSP inputs whose interrupts differ (at \
             rest, following, at the torque limit and the voltage circle); DESIGN.md §6 budgets \
             the whole interrupt at 1500"
        ),
    );
    loop_cycle(h, &link, &mut hw);
}

/// The control interrupts of one loop cycle at the board's tuning (`TUNING.loop_divider`
/// periods, the first the loop period: the periods after it run the current loop on the new
/// torque demand), over the same inputs, each published before the cycle: what the interrupt
/// load of the board averages over.
fn loop_cycle(h: &mut Harness, link: &AxisLink, hw: &mut Board) {
    const NAME: &str = "board-control-interrupt-loop-cycle";
    const PERIODS: u32 = TUNING.loop_divider;
    let Some(snapshot) = h.ready(NAME, running_before_loop_period(hw, link)) else {
        return;
    };
    let Some(cases) = measure_inputs::<PERIODS>(h, NAME, &snapshot, link, hw) else {
        return;
    };
    h.meta("board_loop_divider", PERIODS);
    h.report_cases(
        &cases,
        None,
        format_args!(
            "the same over one loop cycle of the board's tuning: {PERIODS} control interrupts, \
             the first the loop period (a new set-point every loop period), the periods after \
             it the current loop on its torque demand, inputs as above; the interrupt load of \
             the board averages over it"
        ),
    );
}
