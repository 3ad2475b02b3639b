//! The control interrupt: one PWM period of the axis on the board's hardware.
//!
//! Order (each step needs the one before):
//! 1. [`Tim1Inverter::start_period`]: the break flag (a hardware trip is reported with this
//!    sample), MOE set if the gates were armed in the previous period;
//! 2. the conversions of ADC1/ADC2 latched, and the input pins read: the sample;
//! 3. [`Sample::read`] through the `hal` drivers, the encoder read here;
//! 4. [`Axis::control_step`];
//! 5. [`Output::apply`]: gates off at once, or the duties for the next period.

use motor_control::axis::{Axis, AxisLink, Output, Sample};

use hal::encoder::Encoder;

use crate::inputs::BoardInputs;
use crate::inverter::Tim1Inverter;
use crate::regs::{InjectedAdcs, InputPins, ProbeTimer, PwmTimer};
use crate::sensing::{self, BusAndTemperature, PhaseCurrentSense};

/// The axis hardware of the board, each part behind its register trait; `E` is the encoder
/// driver ([`crate::quadrature::QuadratureEncoder`] or [`crate::biss::BissEncoder`]), `R` the
/// probe-edge timer.
pub struct AxisHardware<T, A, E, P, R = crate::regs::NoProbeTimer> {
    /// TIM1.
    pub inverter: Tim1Inverter<T>,
    /// ADC1/ADC2.
    pub adcs: A,
    /// Phase currents.
    pub currents: PhaseCurrentSense,
    /// Bus voltage and temperature.
    pub bus: BusAndTemperature,
    /// The position encoder.
    pub encoder: E,
    /// The input pins.
    pub inputs: BoardInputs<P, R>,
}

impl<T: PwmTimer, A: InjectedAdcs, E: Encoder, P: InputPins, R: ProbeTimer>
    AxisHardware<T, A, E, P, R>
{
    /// The body of the control interrupt (the ADC's end of the injected sequence, priority P0):
    /// one PWM period of `axis`, whose set-points and feedback go through `link`. Returns what
    /// was applied.
    ///
    /// Timing: `Axis::control_step` (≤ 1,500 instructions, benchmark `control-interrupt`) plus
    /// the register accesses of the drivers (a few tens of instructions); at 40 kHz the whole
    /// must end well inside the 25 µs period.
    pub fn control_interrupt(&mut self, axis: &mut Axis, link: &AxisLink) -> Output {
        self.inverter.start_period();
        let raw = self.adcs.take_conversions();
        sensing::latch(&mut self.currents, &mut self.bus, &raw);
        self.inputs.latch(self.inverter.ended_period_ticks());
        let sample = Sample::read(
            &mut self.inverter,
            &mut self.currents,
            &mut self.bus,
            &mut self.encoder,
            &mut self.inputs,
        );
        let output = axis.control_step(&sample, link);
        output.apply(&mut self.inverter);
        output
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::board::{COUNTS_PER_REV, FRONT_END, PWM_HZ, SERVO, TUNING};
    use crate::inputs::{InputLine, InputPolarity};
    use crate::quadrature::QuadratureEncoder;
    use crate::regs::{Conversions, EncoderCounter};
    use motor_control::axis::{AxisCommand, AxisState, ControlMode};
    use motor_control::servo::axis_config;
    use motor_control::MotorFault;

    /// TIM1 at 40 kHz from 170 MHz.
    const ARR: u16 = 2125;

    #[derive(Default)]
    struct Timer {
        compares: [u16; 3],
        moe: bool,
        break_flag: bool,
    }

    impl PwmTimer for Timer {
        fn auto_reload(&self) -> u16 {
            ARR
        }
        fn set_auto_reload(&mut self, _: u16) {}
        fn set_compares(&mut self, compares: [u16; 3]) {
            self.compares = compares;
        }
        fn set_main_output(&mut self, enabled: bool) {
            self.moe = enabled;
        }
        fn take_break(&mut self) -> bool {
            core::mem::take(&mut self.break_flag)
        }
    }

    /// Currents at the amplifiers' bias, 48 V, 25 °C.
    struct Adcs(Conversions);

    impl InjectedAdcs for Adcs {
        fn take_conversions(&mut self) -> Conversions {
            self.0
        }
    }

    struct Counter(u32);

    impl EncoderCounter for Counter {
        fn count(&self) -> u32 {
            self.0
        }
        fn take_index(&mut self) -> Option<u32> {
            None
        }
        fn line_fault(&self) -> bool {
            false
        }
    }

    struct Pins(u32);

    impl InputPins for Pins {
        fn levels(&self) -> u32 {
            self.0
        }
    }

    fn board() -> AxisHardware<Timer, Adcs, QuadratureEncoder<Counter>, Pins> {
        let (currents, bus) = sensing::sensing(&FRONT_END);
        AxisHardware {
            inverter: Tim1Inverter::new(Timer::default(), PWM_HZ),
            adcs: Adcs(Conversions {
                phase: [2048; 3],
                bus: 1922,
                temperature: 931,
            }),
            currents,
            bus,
            encoder: QuadratureEncoder::new(Counter(7), COUNTS_PER_REV),
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

    #[test]
    fn the_gates_switch_after_the_offset_calibration_and_a_break_latches_a_fault() {
        // The board's servo: its incremental encoder is aligned after every enable.
        let cfg = axis_config(&SERVO, &TUNING);
        let mut axis = Axis::new(cfg).unwrap();
        // SAFETY: one thread calls both sides, one after the other.
        let link = unsafe { AxisLink::new() };
        let mut hw = board();
        // Disabled: gates off, phases centred.
        for _ in 0..10 {
            assert!(!hw.control_interrupt(&mut axis, &link).gates);
            assert!(!hw.inverter.timer().moe);
        }
        assert_eq!(hw.inverter.timer().compares, [1063; 3]);
        link.publish(AxisCommand {
            enable: true,
            mode: ControlMode::Torque,
            ..AxisCommand::default()
        });
        // The offset calibration runs with the gates off; then the first output with the gates
        // on arms MOE, which the next interrupt (the next period's start) sets.
        let mut periods = 0;
        let armed_at = loop {
            periods += 1;
            assert!(periods < 10 * cfg.offset_samples, "never enabled");
            let out = hw.control_interrupt(&mut axis, &link);
            if out.gates {
                break periods;
            }
            assert!(!hw.inverter.timer().moe, "MOE during {:?}", axis.state());
        };
        assert!(armed_at >= cfg.offset_samples, "calibrated first");
        assert!(
            !hw.inverter.timer().moe,
            "not within the period it was armed in"
        );
        // The offsets were measured at the bias: zero.
        let offsets = axis.current_offsets();
        assert!(
            offsets.a.abs() < 0.02 && offsets.b.abs() < 0.02,
            "{offsets:?}"
        );
        let out = hw.control_interrupt(&mut axis, &link);
        assert!(out.gates && hw.inverter.timer().moe);
        // An incremental encoder: the alignment drives current through the windings first.
        assert_eq!(axis.state(), AxisState::Aligning);
        // The compare values are the duties of the output.
        let expected = [out.duties.a, out.duties.b, out.duties.c]
            .map(|d| crate::inverter::compare_for_duty(d, ARR));
        assert_eq!(hw.inverter.timer().compares, expected);

        // The break fires (hardware: BIF set, MOE cleared): the next interrupt latches an
        // over-current fault and keeps the gates off.
        hw.inverter.timer_mut().break_flag = true;
        hw.inverter.timer_mut().moe = false;
        let out = hw.control_interrupt(&mut axis, &link);
        assert!(!out.gates);
        assert_eq!(axis.fault(), Some(MotorFault::OverCurrent));
        for _ in 0..100 {
            hw.control_interrupt(&mut axis, &link);
            assert!(!hw.inverter.timer().moe);
        }
        assert_eq!(link.feedback().fault, Some(MotorFault::OverCurrent));
    }
}
