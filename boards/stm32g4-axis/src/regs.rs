//! The register accesses the axis drivers make at run time, as traits: a board implements them
//! on its peripherals (a register read or write each), the QEMU benchmark board and the host
//! tests on plain memory. Configuration (clocks, modes, dead time, trigger routing) is done
//! once by the board and is not part of these traits.

use hal::io::TouchProbe;

/// TIM1 (advanced-control timer) as the inverter drives it: centre-aligned, phases in PWM
/// mode 2 with preloaded compare registers (RM0440 §29.3.13, OCxPE = 1).
pub trait PwmTimer {
    /// TIMx_ARR: the counter's turning point; compare values run over `0..=ARR`. The value
    /// written last (preloaded, ARPE = 1).
    fn auto_reload(&self) -> u16;
    /// Writes TIMx_ARR. Preloaded: the period after the present one has it.
    fn set_auto_reload(&mut self, arr: u16);
    /// TIMx_CCR1..CCR3 of phases a, b, c. Preloaded: they act from the next update event.
    fn set_compares(&mut self, compares: [u16; 3]);
    /// TIMx_BDTR.MOE, the main output enable. Cleared: every output at its idle level at once
    /// (OSSI = 1, OISx = OISxN = 0: both switches of every leg off).
    fn set_main_output(&mut self, enabled: bool);
    /// Reads and clears TIMx_SR.BIF: whether the break input fired since the last call (the
    /// hardware has cleared MOE then, RM0440 §29.3.18).
    fn take_break(&mut self) -> bool;
}

/// Raw results of one injected sequence of ADC1 and ADC2 (counts, right-aligned).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Conversions {
    /// Phase-current amplifiers of phases a, b, c (c unused on a two-shunt board).
    pub phase: [u16; 3],
    /// DC-bus voltage divider.
    pub bus: u16,
    /// Power-stage temperature sensor.
    pub temperature: u16,
}

/// ADC1 and ADC2 as the sensing reads them after the end of their injected sequences.
pub trait InjectedAdcs {
    /// The injected data registers (ADC_JDRx) of both converters, and clears the end-of-sequence
    /// flags (ADC_ISR.JEOS, write 1 to clear).
    fn take_conversions(&mut self) -> Conversions;
}

/// A 32-bit timer (TIM2/TIM5) in encoder mode 3 (x4, RM0440 §30.3.22) with the index pulse on a
/// capture channel.
pub trait EncoderCounter {
    /// TIMx_CNT.
    fn count(&self) -> u32;
    /// The counter value captured on the last index edge (TIMx_CCR of the index channel) if one
    /// came since the last call (CCxIF read and cleared; of several, the last).
    fn take_index(&mut self) -> Option<u32>;
    /// The line receiver reports a broken or unpowered encoder cable.
    fn line_fault(&self) -> bool;
}

/// Levels of the board's digital input pins, one bit per [`crate::inputs::InputLine`]
/// (bit set = pin high).
pub trait InputPins {
    /// Levels of every input line.
    fn levels(&self) -> u32;
}

/// The timer that time-stamps the touch-probe edges: reset at every PWM valley (TIM1's update
/// event), capturing its count at both edges of each probe input (TIM3 CH3/CH2 on the board).
pub trait ProbeTimer {
    /// The count now: ticks since the last PWM valley.
    fn count(&self) -> u16;
    /// The count captured at the last edge of `probe` since the last call, if one came (the
    /// capture flag read and cleared; of several edges, the last).
    fn take_edge(&mut self, probe: TouchProbe) -> Option<u16>;
}

/// No probe timer: edges are not time-stamped (levels only).
#[derive(Clone, Copy, Debug, Default)]
pub struct NoProbeTimer;

impl ProbeTimer for NoProbeTimer {
    fn count(&self) -> u16 {
        0
    }
    fn take_edge(&mut self, _: TouchProbe) -> Option<u16> {
        None
    }
}

/// The board's digital output pins.
pub trait OutputPins {
    /// Drives the holding-brake output: `true` = the brake is released (coil energised).
    fn set_brake_released(&mut self, released: bool);
}
