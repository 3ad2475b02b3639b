//! The board's digital inputs ([`hal::io::DigitalInputs`]) and its holding-brake output
//! ([`hal::io::DigitalOutputs`]).
//!
//! Every input line is one bit of [`InputPins::levels`]; whether a line is active high or
//! active low is board wiring, stated once in an [`InputPolarity`]. Inputs of safety functions
//! (limit switches, safe torque off) are wired so that a broken wire reads as the safe state:
//! normally-closed contacts, active (open) when the pin reads low. The lines that permit
//! something (safe torque off closed, the enable input) are active when given, so that a
//! broken wire withholds the permission.

use cia402::outputs::BRAKE as BRAKE_APPLIED;
use hal::io::{DigitalInputs, DigitalOutputs, ProbeCapture, TouchProbe};

use crate::regs::{InputPins, NoProbeTimer, OutputPins, ProbeTimer};

/// The input lines, as bit numbers of [`InputPins::levels`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum InputLine {
    /// Positive limit switch.
    PositiveLimit = 0,
    /// Negative limit switch.
    NegativeLimit = 1,
    /// Home switch.
    Home = 2,
    /// The motor's thermal switch.
    MotorOverTemperature = 3,
    /// Touch-probe input 1.
    Probe1 = 4,
    /// Touch-probe input 2.
    Probe2 = 5,
    /// Safe-torque-off channel 1 (high = closed, torque allowed).
    SafeTorqueOff1 = 6,
    /// Safe-torque-off channel 2.
    SafeTorqueOff2 = 7,
    /// The drive's enable input (active = operation permitted).
    Enable = 8,
}

impl InputLine {
    /// The line's bit in [`InputPins::levels`].
    pub const fn mask(self) -> u32 {
        1 << self as u8
    }
}

/// Which lines are active when their pin reads low (bit set, as [`InputLine::mask`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct InputPolarity {
    /// Lines active low.
    pub active_low: u32,
}

/// The inputs on `pins`, and the probe edges time-stamped by `T`.
pub struct BoardInputs<P, T = NoProbeTimer> {
    pins: P,
    polarity: InputPolarity,
    /// Active lines at the last `latch`.
    active: u32,
    /// The probe-edge timer, its clock, and the delay of its capture path (input filter).
    edges: T,
    timer_hz: u32,
    capture_delay_ticks: u32,
    /// Each probe's last edge at the last `latch`, ns before it.
    edge_ns: [Option<i32>; 2],
}

impl<P: InputPins> BoardInputs<P> {
    /// The inputs on `pins` with `polarity`, all inactive until the first [`Self::latch`];
    /// probe edges without a time until [`Self::with_probe_timer`].
    pub fn new(pins: P, polarity: InputPolarity) -> Self {
        Self {
            pins,
            polarity,
            active: 0,
            edges: NoProbeTimer,
            timer_hz: 0,
            capture_delay_ticks: 0,
            edge_ns: [None; 2],
        }
    }

    /// Time-stamps the probe edges with `timer`, clocked at `timer_hz`, whose captures come
    /// `capture_delay_ticks` after the edge at the pin (its input filter's delay, added back).
    pub fn with_probe_timer<T: ProbeTimer>(
        self,
        timer: T,
        timer_hz: u32,
        capture_delay_ticks: u32,
    ) -> BoardInputs<P, T> {
        BoardInputs {
            pins: self.pins,
            polarity: self.polarity,
            active: self.active,
            edges: timer,
            timer_hz,
            capture_delay_ticks,
            edge_ns: [None; 2],
        }
    }
}

impl<P: InputPins, T: ProbeTimer> BoardInputs<P, T> {
    /// Reads every line once, at the sample (what the trait methods then return), and places
    /// the probe edges since the last latch in time before now. `ended_period_ticks`: the
    /// length of the PWM period that ended at the last valley (an edge captured before that
    /// valley counts from the valley before).
    pub fn latch(&mut self, ended_period_ticks: u32) {
        self.active = self.pins.levels() ^ self.polarity.active_low;
        let now = u32::from(self.edges.count());
        for (slot, probe) in self
            .edge_ns
            .iter_mut()
            .zip([TouchProbe::One, TouchProbe::Two])
        {
            *slot = self.edges.take_edge(probe).map(|edge| {
                let edge = u32::from(edge);
                let before = match now.checked_sub(edge) {
                    Some(since) => since,
                    // In the period that ended: the counter was reset at the valley since, so
                    // the edge lies (period − edge) + now = period − (edge − now) ticks back (0
                    // for a capture the period cannot hold).
                    None => ended_period_ticks.saturating_sub(edge.abs_diff(now)),
                };
                ticks_to_ns(
                    before.saturating_add(self.capture_delay_ticks),
                    self.timer_hz,
                )
            });
        }
    }

    /// Whether `line` was active at the last latch.
    pub fn is_active(&self, line: InputLine) -> bool {
        self.active & line.mask() != 0
    }
}

/// `ticks` of a timer at `timer_hz` in ns (0 without a clock), saturated to `i32`.
fn ticks_to_ns(ticks: u32, timer_hz: u32) -> i32 {
    (u64::from(ticks) * 1_000_000_000)
        .checked_div(u64::from(timer_hz))
        .map_or(0, |ns| i32::try_from(ns).unwrap_or(i32::MAX))
}

impl<P: InputPins, T: ProbeTimer> DigitalInputs for BoardInputs<P, T> {
    fn positive_limit(&mut self) -> bool {
        self.is_active(InputLine::PositiveLimit)
    }

    fn negative_limit(&mut self) -> bool {
        self.is_active(InputLine::NegativeLimit)
    }

    fn home_switch(&mut self) -> bool {
        self.is_active(InputLine::Home)
    }

    fn motor_over_temperature(&mut self) -> bool {
        self.is_active(InputLine::MotorOverTemperature)
    }

    /// The level at the sample, and the last edge since the previous sample with its time
    /// before the latch (the position is read right after it, within the same interrupt).
    fn touch_probe(&mut self, probe: TouchProbe) -> ProbeCapture {
        let (line, edge) = match probe {
            TouchProbe::One => (InputLine::Probe1, self.edge_ns[0]),
            TouchProbe::Two => (InputLine::Probe2, self.edge_ns[1]),
        };
        ProbeCapture {
            active: self.is_active(line),
            edge_ns_before_position: edge,
        }
    }

    fn safe_torque_off_channels(&mut self) -> [bool; 2] {
        [
            self.is_active(InputLine::SafeTorqueOff1),
            self.is_active(InputLine::SafeTorqueOff2),
        ]
    }

    fn enable_input(&mut self) -> bool {
        self.is_active(InputLine::Enable)
    }
}

/// The holding-brake output on `pins`.
pub struct BrakeOutput<P> {
    pins: P,
}

impl<P: OutputPins> BrakeOutput<P> {
    /// The output on `pins`, brake applied (coil off) until the first [`DigitalOutputs::set_outputs`].
    pub fn new(mut pins: P) -> Self {
        pins.set_brake_released(false);
        Self { pins }
    }
}

impl<P> BrakeOutput<P> {
    /// The output pins.
    pub fn pins(&self) -> &P {
        &self.pins
    }
}

impl<P: OutputPins> DigitalOutputs for BrakeOutput<P> {
    fn set_outputs(&mut self, levels: u32) {
        self.pins.set_brake_released(levels & BRAKE_APPLIED == 0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Pins(u32);

    impl InputPins for Pins {
        fn levels(&self) -> u32 {
            self.0
        }
    }

    /// Limits and STO normally closed (active = open = low); the rest active high.
    const POLARITY: InputPolarity = InputPolarity {
        active_low: InputLine::PositiveLimit.mask() | InputLine::NegativeLimit.mask(),
    };

    #[test]
    fn levels_are_read_once_per_sample_with_the_board_polarity() {
        // Both limit contacts closed (pins high), home high, STO channels high (closed).
        let closed = InputLine::PositiveLimit.mask()
            | InputLine::NegativeLimit.mask()
            | InputLine::Home.mask()
            | InputLine::SafeTorqueOff1.mask()
            | InputLine::SafeTorqueOff2.mask()
            | InputLine::Enable.mask();
        let mut inputs = BoardInputs::new(Pins(closed), POLARITY);
        // Nothing read before the first latch.
        assert!(!inputs.home_switch());
        inputs.latch(0);
        assert!(!inputs.positive_limit() && !inputs.negative_limit());
        assert!(inputs.home_switch());
        assert_eq!(inputs.safe_torque_off_channels(), [true, true]);
        assert!(inputs.enable_input());
        assert!(!inputs.motor_over_temperature());
        // A broken wire on the positive limit, on STO channel 2 and on the enable input reads
        // as their safe state.
        inputs.pins.0 = closed
            & !InputLine::PositiveLimit.mask()
            & !InputLine::SafeTorqueOff2.mask()
            & !InputLine::Enable.mask();
        assert!(!inputs.positive_limit(), "only after the next latch");
        inputs.latch(0);
        assert!(inputs.positive_limit());
        assert_eq!(inputs.safe_torque_off_channels(), [true, false]);
        assert!(!inputs.enable_input(), "withheld");
        inputs.pins.0 |= InputLine::Probe2.mask();
        inputs.latch(0);
        assert_eq!(
            inputs.touch_probe(TouchProbe::Two),
            ProbeCapture {
                active: true,
                edge_ns_before_position: None
            }
        );
        assert!(!inputs.touch_probe(TouchProbe::One).active);
    }

    /// A probe timer as memory: the count now and an edge per probe.
    struct Edges {
        now: u16,
        edges: [Option<u16>; 2],
    }

    impl ProbeTimer for Edges {
        fn count(&self) -> u16 {
            self.now
        }
        fn take_edge(&mut self, probe: TouchProbe) -> Option<u16> {
            match probe {
                TouchProbe::One => self.edges[0].take(),
                TouchProbe::Two => self.edges[1].take(),
            }
        }
    }

    #[test]
    fn probe_edges_are_timed_before_the_sample_across_the_valley() {
        // 170 MHz: 17 ticks = 100 ns. The counter is at 425 (2.5 µs after the valley).
        let probe1 = InputLine::Probe1.mask();
        let mut inputs = BoardInputs::new(Pins(probe1), POLARITY).with_probe_timer(
            Edges {
                now: 425,
                // Probe 1 rose 85 ticks after this valley; probe 2 fell 17 ticks before the
                // valley, in the period that ended (4250 ticks long).
                edges: [Some(85), Some(4250 - 17)],
            },
            170_000_000,
            // A filter that delays every capture by 17 ticks (100 ns).
            17,
        );
        inputs.latch(4250);
        assert_eq!(
            inputs.touch_probe(TouchProbe::One),
            ProbeCapture {
                active: true,
                edge_ns_before_position: Some(2_100),
            }
        );
        assert_eq!(
            inputs.touch_probe(TouchProbe::Two),
            ProbeCapture {
                active: false,
                edge_ns_before_position: Some(2_700),
            }
        );
        // No edge since: no time; the level stays.
        inputs.latch(4250);
        assert_eq!(
            inputs.touch_probe(TouchProbe::One).edge_ns_before_position,
            None
        );
        assert!(inputs.touch_probe(TouchProbe::One).active);
    }

    #[test]
    fn captures_beyond_the_ended_period_do_not_overflow() {
        let mut inputs = BoardInputs::new(Pins(0), POLARITY).with_probe_timer(
            Edges {
                now: 10,
                edges: [Some(4_000), Some(u16::MAX)],
            },
            170_000_000,
            u32::MAX,
        );
        // A period too short to hold the capture: the edge counts from the valley (0 ticks,
        // plus the filter delay); an absurd period length saturates instead of wrapping.
        inputs.latch(100);
        assert_eq!(
            inputs.touch_probe(TouchProbe::One).edge_ns_before_position,
            Some(i32::MAX)
        );
        inputs.edges.edges = [Some(20), None];
        inputs.capture_delay_ticks = 0;
        inputs.latch(u32::MAX);
        assert_eq!(
            inputs.touch_probe(TouchProbe::One).edge_ns_before_position,
            Some(i32::MAX)
        );
        inputs.edges.edges = [Some(20), None];
        inputs.latch(15);
        assert_eq!(
            inputs.touch_probe(TouchProbe::One).edge_ns_before_position,
            Some(29),
            "15 − 10 + 10 ticks = 5 ticks = 29.4 ns"
        );
    }

    struct Brake(Option<bool>);

    impl OutputPins for Brake {
        fn set_brake_released(&mut self, released: bool) {
            self.0 = Some(released);
        }
    }

    #[test]
    fn the_brake_follows_bit_0_of_60fe() {
        let mut brake = BrakeOutput::new(Brake(None));
        assert_eq!(brake.pins.0, Some(false), "applied from the start");
        brake.set_outputs(0);
        assert_eq!(brake.pins.0, Some(true));
        brake.set_outputs(BRAKE_APPLIED | 0xFFFF_0000);
        assert_eq!(brake.pins.0, Some(false));
    }
}
