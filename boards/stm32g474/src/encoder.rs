//! TIM2: the incremental encoder's A/B in encoder mode 3 (x4) on the 32-bit counter, the index
//! Z captured on channel 4; the line receiver's fault output on a GPIO. The run-time accesses
//! are the [`stm32g4_axis::regs::EncoderCounter`] implementation [`Tim2Encoder`].
//!
//! | setting | value | RM0440 |
//! |---|---|---|
//! | mode | SMS = 0011, encoder mode 3: counts every edge of TI1FP1 and TI2FP2 | §29.6.3 (SMCR), §30.3.22 |
//! | inputs | CC1S = CC2S = 01 (IC1 on TI1, IC2 on TI2), not inverted | §30.6.7 |
//! | filter | ICxF for the shortest valid pulse [`servo::ENCODER_SHORTEST_PULSE_NS`] (half the edge spacing at the over-speed trip), CKD = ÷1 | §29.6.3 ETF table |
//! | index | CC4S = 01 (IC4 on TI4), rising edge: CCR4 captures CNT on Z | §30.3.7 |
//! | range | ARR = 0xFFFF_FFFF: the counter wraps through its full 32 bits | §30.3.2 |

use embassy_stm32::gpio::{AfType, Flex, Input, Pull};
use embassy_stm32::pac::timer::{regs, vals};
use embassy_stm32::peripherals::TIM2;
use embassy_stm32::timer::{Ch1, Ch2, Ch4, TimerPin};
use embassy_stm32::{pac, rcc, Peri};
use stm32g4_axis::regs::EncoderCounter;
use stm32g4_settings::dead_time::ClockDivision;
use stm32g4_settings::input_filter::InputFilter;

use crate::clocks::PCLK1_HZ;
use crate::pins::alternate;
use stm32g4_axis::board as servo;

/// TIM2's kernel clock (APB1 prescaler 1).
const TIM2_HZ: u32 = PCLK1_HZ;
/// Clock division of the digital filters.
const CKD: ClockDivision = ClockDivision::Div1;
/// The input filter of A, B and Z.
pub const FILTER: InputFilter =
    match InputFilter::passing(TIM2_HZ, CKD, servo::ENCODER_SHORTEST_PULSE_NS) {
        Ok(f) => f,
        Err(_) => panic!("encoder input filter"),
    };

const _: () = {
    // 555 ns at 170 MHz = 94 ticks: f_DTS/16, N = 5 (80 ticks, 471 ns) is the longest that
    // passes (the next, f_DTS/16 with N = 6, takes 96).
    assert!(FILTER.code == 0b1010 && FILTER.delay_ticks == 80);
};

/// CCxS = 01: the channel is an input, ICx mapped on TIx (the PAC calls this value `TI4`).
const IC_ON_OWN_INPUT: vals::CcmrInputCcs = vals::CcmrInputCcs::TI4;
/// A, B and Z: plain inputs (the RS-422 receivers drive them).
const INPUT: AfType = AfType::input(Pull::None);
/// Channel indices (0-based) of A, B and Z.
const CH_A: usize = 0;
const CH_B: usize = 1;
const CH_Z: usize = 3;

/// The encoder's pins.
pub struct EncoderPins<
    A: embassy_stm32::gpio::Pin,
    B: embassy_stm32::gpio::Pin,
    Z: embassy_stm32::gpio::Pin,
    F: embassy_stm32::gpio::Pin,
> {
    /// Channel A → TIM2_CH1.
    pub a: Peri<'static, A>,
    /// Channel B → TIM2_CH2.
    pub b: Peri<'static, B>,
    /// Index Z → TIM2_CH4.
    pub z: Peri<'static, Z>,
    /// The line receiver's fault output (active low, open drain).
    pub fault: Peri<'static, F>,
}

/// Configures TIM2 (see the module table) and starts it counting from 0.
pub fn configure<A, B, Z, F>(
    _tim: Peri<'static, TIM2>,
    pins: EncoderPins<A, B, Z, F>,
) -> Tim2Encoder
where
    A: TimerPin<TIM2, Ch1>,
    B: TimerPin<TIM2, Ch2>,
    Z: TimerPin<TIM2, Ch4>,
    F: embassy_stm32::gpio::Pin,
{
    rcc::enable_and_reset::<TIM2>();
    let t = pac::TIM2;
    t.cr1()
        .write(|w| w.set_ckd(vals::Ckd::from_bits(CKD.bits())));
    let filter = vals::FilterValue::from_bits(FILTER.code);
    // CCMR1: CH1 (A) and CH2 (B); CCMR2: CH4 (Z) is its second channel.
    t.ccmr_input(0).write(|w| {
        for ch in [CH_A, CH_B] {
            w.set_ccs(ch, IC_ON_OWN_INPUT);
            w.set_icf(ch, filter);
        }
    });
    t.ccmr_input(1).write(|w| {
        w.set_ccs(CH_Z - 2, IC_ON_OWN_INPUT);
        w.set_icf(CH_Z - 2, filter);
    });
    t.ccer().write(|w| {
        // Rising edges, not inverted; only Z captures.
        w.set_cce(CH_Z, true);
    });
    t.smcr().write(|w| w.set_sms(vals::Sms::ENCODER_MODE_3));
    t.arr().write_value(u32::MAX);
    t.cnt().write_value(0);
    t.egr().write(|w| w.set_ug(true));
    t.sr().write_value(regs::SrGp16(0));
    t.cr1().modify(|w| w.set_cen(true));
    let (a_af, b_af, z_af) = (pins.a.af_num(), pins.b.af_num(), pins.z.af_num());
    Tim2Encoder {
        _inputs: [
            alternate(pins.a, a_af, INPUT),
            alternate(pins.b, b_af, INPUT),
            alternate(pins.z, z_af, INPUT),
        ],
        fault: Input::new(pins.fault, Pull::Up),
    }
}

/// TIM2's run-time registers and the fault input (only [`configure`] makes one).
pub struct Tim2Encoder {
    _inputs: [Flex<'static>; 3],
    fault: Input<'static>,
}

impl EncoderCounter for Tim2Encoder {
    #[inline]
    fn count(&self) -> u32 {
        pac::TIM2.cnt().read()
    }

    #[inline]
    fn take_index(&mut self) -> Option<u32> {
        let sr = pac::TIM2.sr().read();
        if !sr.ccif(CH_Z) {
            return None;
        }
        // Reading CCR4 clears CC4IF; clear the over-capture flag too (rc_w0: zeros clear,
        // ones leave the others).
        let captured = pac::TIM2.ccr(CH_Z).read();
        if sr.ccof(CH_Z) {
            let mut clear = regs::SrGp16(u32::MAX);
            clear.set_ccof(CH_Z, false);
            pac::TIM2.sr().write_value(clear);
        }
        Some(captured)
    }

    #[inline]
    fn line_fault(&self) -> bool {
        self.fault.is_low()
    }
}
