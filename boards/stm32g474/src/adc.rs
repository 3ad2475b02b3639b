//! ADC1 and ADC2: the injected conversions of phase currents, bus voltage and temperature,
//! triggered by TIM1's update event (TRGO2) at the PWM valley; the end of ADC1's sequence
//! raises the control interrupt (`control`). The run-time accesses are the
//! [`stm32g4_axis::regs::InjectedAdcs`] implementation [`Adc12`].
//!
//! | converter | rank 1 | rank 2 | rank 3 |
//! |---|---|---|---|
//! | ADC1 | phase a current | phase c current (three-shunt boards) | power-stage temperature |
//! | ADC2 | phase b current | bus voltage | — |
//!
//! Both start on the same trigger, so phases a and b are sampled at the same instant. ADC1's
//! sequence is the longer one (checked at compile time), so when its end-of-sequence interrupt
//! comes ADC2's results are there too.
//!
//! | setting | value | RM0440 |
//! |---|---|---|
//! | clock | synchronous HCLK/4 = 42.5 MHz (CKMODE = 11): no jitter between trigger and sampling | §21.4.3 |
//! | sampling | ≥ [`servo::CURRENT_SAMPLE_NS`] for currents, ≥ [`servo::SLOW_SAMPLE_NS`] for bus and temperature | §21.4.12 |
//! | trigger | JEXTSEL = 01000 (`tim1_trgo2`), rising edge | §21.4.19, Table 167 |
//! | queue | injected context queue off (JQDIS = 1): one fixed sequence | §21.4.21 |
//! | start-up | deep power-down off, regulator on, ≥ 20 µs, single-ended calibration, enable | §21.4.6–§21.4.9 |

use embassy_stm32::adc::AdcChannel;
use embassy_stm32::pac::adc::vals::{Adcaldif, Exten, SampleTime};
use embassy_stm32::pac::adccommon::vals::{Ckmode, Dual};
use embassy_stm32::peripherals::{ADC1, ADC2};
use embassy_stm32::{pac, rcc, Peri};
use stm32g4_axis::regs::{Conversions, InjectedAdcs};
use stm32g4_settings::adc::{SampleTime as SampleSetting, SynchronousClock};

use crate::clocks::{HCLK_HZ, SYSCLK_HZ};
use stm32g4_axis::board as servo;

/// The fastest ADC clock of the G474 (60 MHz: embassy's limit; the datasheet DS12288 was not
/// available to confirm it, see `stm32g4-settings/FACTS.md`). The clock chosen is 42.5 MHz.
const ADC_MAX_HZ: u32 = 60_000_000;
/// The ADC clock.
const CLOCK: SynchronousClock = match SynchronousClock::at_most(HCLK_HZ, ADC_MAX_HZ) {
    Ok(c) => c,
    Err(_) => panic!("no synchronous ADC clock"),
};
/// Sampling time of the current channels.
const CURRENT_SAMPLE: SampleSetting =
    match SampleSetting::at_least(CLOCK.adc_hz, servo::CURRENT_SAMPLE_NS) {
        Ok(s) => s,
        Err(_) => panic!("current sampling time"),
    };
/// Sampling time of the bus-voltage and temperature channels.
const SLOW_SAMPLE: SampleSetting =
    match SampleSetting::at_least(CLOCK.adc_hz, servo::SLOW_SAMPLE_NS) {
        Ok(s) => s,
        Err(_) => panic!("slow sampling time"),
    };

/// Duration of ADC1's sequence (two currents and the temperature), ns.
const ADC1_SEQUENCE_NS: u64 =
    2 * CURRENT_SAMPLE.conversion_ns(CLOCK.adc_hz) + SLOW_SAMPLE.conversion_ns(CLOCK.adc_hz);
/// Duration of ADC2's sequence (a current and the bus voltage), ns.
const ADC2_SEQUENCE_NS: u64 =
    CURRENT_SAMPLE.conversion_ns(CLOCK.adc_hz) + SLOW_SAMPLE.conversion_ns(CLOCK.adc_hz);

const _: () = {
    // ADC1's interrupt reads both converters: ADC2 must not end later.
    assert!(ADC1_SEQUENCE_NS >= ADC2_SEQUENCE_NS);
    // 42.5 MHz from 170 MHz; 19 + 19 + 60 cycles: ADC1 ends 2.3 µs after the trigger.
    assert!(CLOCK.adc_hz == 42_500_000);
    assert!(ADC1_SEQUENCE_NS <= 2_400);
};

/// JSQR.JEXTSEL of `tim1_trgo2` for ADC1/ADC2 (RM0440 Table 167).
const JEXTSEL_TIM1_TRGO2: u8 = 0b01000;
/// Polls of a start-up flag before giving up (each a register read, ≈ 10 ns; far above the
/// longest wait, the calibration's 116 ADC cycles).
const MAX_POLLS: u32 = 100_000;
/// tADCVREG_STUP: the regulator's start-up time (20 µs, as embassy waits).
const REGULATOR_STARTUP_CYCLES: u32 = SYSCLK_HZ / 1_000_000 * 20;

/// Why the converters did not start.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum AdcError {
    /// The calibration of ADC`n` did not end.
    Calibration(u8),
    /// ADC`n` did not report ready after its enable.
    NotReady(u8),
}

/// The analog inputs, each checked at compile time to be a channel of its converter.
pub struct AnalogPins<
    IA: embassy_stm32::gpio::Pin,
    IB: embassy_stm32::gpio::Pin,
    IC: embassy_stm32::gpio::Pin,
    VB: embassy_stm32::gpio::Pin,
    TS: embassy_stm32::gpio::Pin,
> {
    /// Phase a current → ADC1.
    pub current_a: Peri<'static, IA>,
    /// Phase b current → ADC2.
    pub current_b: Peri<'static, IB>,
    /// Phase c current → ADC1.
    pub current_c: Peri<'static, IC>,
    /// Bus voltage → ADC2.
    pub bus: Peri<'static, VB>,
    /// Power-stage temperature → ADC1.
    pub temperature: Peri<'static, TS>,
}

fn wait_until(adc: u8, done: impl Fn() -> bool, error: fn(u8) -> AdcError) -> Result<(), AdcError> {
    for _ in 0..MAX_POLLS {
        if done() {
            return Ok(());
        }
    }
    Err(error(adc))
}

/// Powers up, calibrates and enables one converter, then arms its injected sequence of
/// `(channel, sampling time)` on `tim1_trgo2`.
fn start(adc: pac::adc::Adc, number: u8, sequence: &[(u8, SampleSetting)]) -> Result<(), AdcError> {
    adc.cr().modify(|w| {
        w.set_deeppwd(false);
        w.set_advregen(true);
    });
    cortex_m::asm::delay(REGULATOR_STARTUP_CYCLES);
    adc.cr().modify(|w| {
        w.set_adcaldif(Adcaldif::SINGLE_ENDED);
        w.set_adcal(true);
    });
    wait_until(number, || !adc.cr().read().adcal(), AdcError::Calibration)?;
    // ADEN no earlier than 4 ADC clocks after the calibration (RM0440 §21.4.8).
    cortex_m::asm::delay(4 * (HCLK_HZ / CLOCK.adc_hz));
    adc.isr().write(|w| w.set_adrdy(true));
    adc.cr().modify(|w| w.set_aden(true));
    wait_until(number, || adc.isr().read().adrdy(), AdcError::NotReady)?;
    adc.cfgr().modify(|w| w.set_jqdis(true));
    for &(channel, sample) in sequence {
        let ch = usize::from(channel);
        let time = SampleTime::from_bits(sample.code);
        if ch < 10 {
            adc.smpr().modify(|w| w.set_smp(ch, time));
        } else {
            adc.smpr2().modify(|w| w.set_smp(ch - 10, time));
        }
    }
    adc.jsqr().write(|w| {
        // JL = length − 1 (the sequences here have 1..=4 entries).
        w.set_jl(sequence.len().saturating_sub(1) as u8);
        w.set_jextsel(JEXTSEL_TIM1_TRGO2);
        w.set_jexten(Exten::RISING_EDGE);
        for (rank, &(channel, _)) in sequence.iter().enumerate() {
            w.set_jsq(rank, channel);
        }
    });
    adc.cr().modify(|w| w.set_jadstart(true));
    Ok(())
}

/// Starts both converters (see the module tables) and enables the end-of-sequence interrupt
/// of ADC1. The control interrupt's vector stays masked until `control::start`.
pub fn configure<
    IA: embassy_stm32::gpio::Pin,
    IB: embassy_stm32::gpio::Pin,
    IC: embassy_stm32::gpio::Pin,
    VB: embassy_stm32::gpio::Pin,
    TS: embassy_stm32::gpio::Pin,
>(
    _adc1: Peri<'static, ADC1>,
    _adc2: Peri<'static, ADC2>,
    pins: AnalogPins<IA, IB, IC, VB, TS>,
) -> Result<Adc12, AdcError>
where
    Peri<'static, IA>: AdcChannel<ADC1>,
    Peri<'static, IB>: AdcChannel<ADC2>,
    Peri<'static, IC>: AdcChannel<ADC1>,
    Peri<'static, VB>: AdcChannel<ADC2>,
    Peri<'static, TS>: AdcChannel<ADC1>,
{
    // ADC1 and ADC2 share one clock enable (ADC12EN).
    rcc::enable_and_reset::<ADC1>();
    pac::ADC12_COMMON.ccr().modify(|w| {
        w.set_ckmode(Ckmode::from_bits(CLOCK.ckmode));
        w.set_dual(Dual::INDEPENDENT);
    });
    // `degrade_adc` puts each pin in analog mode and gives its channel number.
    let ia = pins.current_a.degrade_adc().get_hw_channel();
    let ic = pins.current_c.degrade_adc().get_hw_channel();
    let ts = pins.temperature.degrade_adc().get_hw_channel();
    let ib = pins.current_b.degrade_adc().get_hw_channel();
    let vb = pins.bus.degrade_adc().get_hw_channel();
    start(
        pac::ADC1,
        1,
        &[
            (ia, CURRENT_SAMPLE),
            (ic, CURRENT_SAMPLE),
            (ts, SLOW_SAMPLE),
        ],
    )?;
    start(pac::ADC2, 2, &[(ib, CURRENT_SAMPLE), (vb, SLOW_SAMPLE)])?;
    pac::ADC1.ier().modify(|w| w.set_jeosie(true));
    Ok(Adc12 { _private: () })
}

/// ADC1/ADC2's run-time registers (only [`configure`] makes one).
pub struct Adc12 {
    _private: (),
}

/// Clears the injected end flags of `adc` (ADC_ISR is write-1-to-clear).
#[inline]
fn clear_injected_flags(adc: pac::adc::Adc) {
    adc.isr().write(|w| {
        w.set_jeoc(true);
        w.set_jeos(true);
    });
}

impl InjectedAdcs for Adc12 {
    #[inline]
    fn take_conversions(&mut self) -> Conversions {
        let (adc1, adc2) = (pac::ADC1, pac::ADC2);
        let conversions = Conversions {
            phase: [
                adc1.jdr(0).read().jdata(),
                adc2.jdr(0).read().jdata(),
                adc1.jdr(1).read().jdata(),
            ],
            bus: adc2.jdr(1).read().jdata(),
            temperature: adc1.jdr(2).read().jdata(),
        };
        clear_injected_flags(adc1);
        clear_injected_flags(adc2);
        conversions
    }
}

/// Clears the injected end flags of both converters without reading them.
pub fn clear_sequence_flags() {
    clear_injected_flags(pac::ADC1);
    clear_injected_flags(pac::ADC2);
}

/// Whether ADC1's injected sequence has ended (its end flag set): the control interrupt's
/// cause.
#[inline]
pub fn sequence_ended() -> bool {
    pac::ADC1.isr().read().jeos()
}
