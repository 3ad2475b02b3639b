//! The STM32G474 board's control interrupt as the board runs it: `stm32g4_axis`'s
//! [`AxisHardware::control_interrupt`] (period start with the SYNC0 period trim, the ADC
//! conversions latched and converted, the input pins, the encoder counter extended, the axis
//! step, the compare values and MOE written) with the board's servo, front end and tuning. Only
//! the register accesses differ from the board: they go to memory here (volatile, like the
//! peripheral registers), through the same register traits.
//!
//! Measured in the worst period: running in CSP at rest with a new set-point every period (loop
//! divider 1). The board's incremental encoder is aligned after each enable; the measurement
//! gives the alignment's result as the commissioned commutation offset, so that the axis is in
//! closed loop from the start (the same code runs after an alignment).

use core::hint::black_box;
use core::ptr::{addr_of, addr_of_mut, read_volatile, write_volatile};

use firmware::motor::axis::{Axis, AxisCommand, AxisLink, AxisState};
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

use crate::harness::Harness;

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
    let mut cfg = axis_config(&SERVO, &tuning);
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

/// The benchmark.
pub fn run(h: &mut Harness) {
    const NAME: &str = "board-control-interrupt";
    // SAFETY: the benchmark runs in one context only.
    let link = unsafe { AxisLink::new() };
    let mut hw = board();
    let Some(mut axis) = h.ready(NAME, running(&mut hw, &link)) else {
        return;
    };
    let measured = h.measure_net(NAME, &mut || link.publish(black_box(COMMAND)), &mut || {
        link.publish(black_box(COMMAND));
        black_box(hw.control_interrupt(&mut axis, &link));
    });
    if axis.state() != AxisState::Running || !hw.inverter.timer().moe {
        h.fail(
            NAME,
            format_args!("the axis left Running during the measurement"),
        );
    }
    let Some((cost, with_publish, publish)) = measured else {
        return;
    };
    // The board's clocks and PWM rate: the interrupt-load section of the report.
    h.meta("board_core_clock_hz", CORE_CLOCK_HZ);
    h.meta("board_pwm_hz", PWM_HZ);
    h.meta("board_pdi_spi_hz", PDI_SPI_CLOCK_HZ);
    // No budget of its own: DESIGN.md §6 budgets the whole control interrupt, drivers included,
    // at 1,500; the report's load section sets this count against the board's time.
    h.report(
        NAME,
        cost,
        None,
        format_args!(
            "the STM32G474 board's control interrupt (stm32g4_axis AxisHardware::control_interrupt: \
             period trim, ADC latch and conversion, inputs, encoder, Axis::control_step, compares \
             and MOE; registers as memory), worst period: CSP at rest, a new set-point every \
             period ({with_publish} with the SYNC0 publish − {publish} publish); DESIGN.md §6 \
             budgets the whole interrupt at 1500"
        ),
    );
}
