//! TIM3: the SYNC0 edge and the touch-probe edges time-stamped in hardware against the PWM.
//! TIM3 is reset by TIM1's update event (the PWM valley, through TIM1's TRGO) and captures its
//! count on SYNC0's rising edge (PB4 = TIM3_CH1): the capture is SYNC0's phase in the PWM
//! period, in timer ticks, whatever the interrupt latency; its interrupt is the cycle
//! context's vector (P1). CH3 (PB0) and CH2 (PB5) capture both edges of touch probes 1 and 2,
//! which the control interrupt reads ([`Tim3Probes`], `stm32g4_axis::regs::ProbeTimer`).
//!
//! | setting | value | RM0440 |
//! |---|---|---|
//! | clock | PCLK1 = 170 MHz, PSC = 0: the same tick as TIM1 | §30.4.13 |
//! | slave mode | reset mode (SMS = 0100), trigger ITR0 = `tim1_trgo` | §30.3.26, §30.4.3 (TIMx internal trigger connection: ITR0 of TIM2/3/4 is TIM1) |
//! | TIM1 TRGO | update event (TIM1_CR2.MMS = 010, set by `pwm`) | §29.6.2 |
//! | capture | CC1S = 01 (IC1 on TI1), rising edge, filter for a 100 ns pulse, CC1IE | §30.3.7 |
//! | probes | CC3S/CC2S = 01, both edges (CCxP = CCxNP = 1), filter for a [`PROBE_SHORTEST_PULSE_NS`] pulse, no interrupt | §30.3.7, §30.6.11 (CCxNP/CCxP = 11: both edges) |
//! | range | ARR = 0xFFFF (one PWM period is 4,250 ticks at 40 kHz) | |

use embassy_stm32::gpio::{AfType, Flex, Pull};
use embassy_stm32::pac::timer::{regs, vals};
use embassy_stm32::peripherals::TIM3;
use embassy_stm32::timer::{Ch1, TimerPin};
use embassy_stm32::{pac, rcc, Peri};
use hal::io::TouchProbe;
use stm32g4_axis::regs::ProbeTimer;
use stm32g4_settings::dead_time::ClockDivision;
use stm32g4_settings::input_filter::InputFilter;

use crate::clocks::{PCLK1_HZ, PCLK2_HZ};
use crate::pins::alternate;

/// TIM3's kernel clock.
pub const TIM3_HZ: u32 = PCLK1_HZ;
/// Clock division of the input filter.
const CKD: ClockDivision = ClockDivision::Div1;
/// The shortest SYNC0 pulse the filter passes, ns (the master sets the pulse length in
/// 0x0982; ≥ 100 ns in every setting we know).
const SHORTEST_PULSE_NS: u32 = 100;
/// The input filter of SYNC0.
const FILTER: InputFilter = match InputFilter::passing(TIM3_HZ, CKD, SHORTEST_PULSE_NS) {
    Ok(f) => f,
    Err(_) => panic!("SYNC0 input filter"),
};
/// CCxS = 01: ICx mapped on TIx (the PAC calls this value `TI4`).
const IC_ON_OWN_INPUT: vals::CcmrInputCcs = vals::CcmrInputCcs::TI4;
/// Channel indices (0-based) of SYNC0 and the touch probes 1 and 2.
const CH_SYNC0: usize = 0;
const CH_PROBE1: usize = 2;
const CH_PROBE2: usize = 1;
/// The shortest touch-probe pulse the filter passes, ns: the probes' input stages are fast
/// (≈ 1 µs opto-couplers), and a pulse must last a PWM period to be seen as a level anyway.
const PROBE_SHORTEST_PULSE_NS: u32 = 1_000;
/// The input filter of the probes.
pub const PROBE_FILTER: InputFilter =
    match InputFilter::passing(TIM3_HZ, CKD, PROBE_SHORTEST_PULSE_NS) {
        Ok(f) => f,
        Err(_) => panic!("probe input filter"),
    };

const _: () = {
    // The capture counts in TIM1's ticks.
    assert!(TIM3_HZ == PCLK2_HZ);
    // 100 ns = 17 ticks: f_DTS/2 with N = 8 (16 ticks, 94 ns) is the longest that passes; its
    // delay is the same for every edge, so the phase lock sees a constant offset.
    assert!(FILTER.code == 0b0101);
    // 1 µs = 170 ticks: f_DTS/32 with N = 5 (160 ticks, 941 ns) is the longest that passes;
    // the edge time includes this constant delay.
    assert!(PROBE_FILTER.code == 0b1101);
};

/// SYNC0's input, kept in its alternate function.
pub struct Sync0Capture {
    _pin: Flex<'static>,
}

/// Configures TIM3 (see the module table) and starts it. TIM1 must be configured (its TRGO)
/// for the capture to mean a phase; the capture interrupt is unmasked by `irq`.
pub fn configure<P: TimerPin<TIM3, Ch1>>(
    _tim: Peri<'static, TIM3>,
    sync0: Peri<'static, P>,
) -> Sync0Capture {
    rcc::enable_and_reset::<TIM3>();
    let t = pac::TIM3;
    t.cr1()
        .write(|w| w.set_ckd(vals::Ckd::from_bits(CKD.bits())));
    t.psc().write_value(0);
    t.arr().write(|w| w.set_arr(u16::MAX));
    // CCMR1: CH1 (SYNC0), CH2 (probe 2); CCMR2: CH3 (probe 1).
    t.ccmr_input(0).write(|w| {
        w.set_ccs(CH_SYNC0, IC_ON_OWN_INPUT);
        w.set_icf(CH_SYNC0, vals::FilterValue::from_bits(FILTER.code));
        w.set_ccs(CH_PROBE2, IC_ON_OWN_INPUT);
        w.set_icf(CH_PROBE2, vals::FilterValue::from_bits(PROBE_FILTER.code));
    });
    t.ccmr_input(1).write(|w| {
        w.set_ccs(CH_PROBE1 - 2, IC_ON_OWN_INPUT);
        w.set_icf(
            CH_PROBE1 - 2,
            vals::FilterValue::from_bits(PROBE_FILTER.code),
        );
    });
    t.ccer().write(|w| {
        w.set_cce(CH_SYNC0, true);
        for ch in [CH_PROBE1, CH_PROBE2] {
            w.set_cce(ch, true);
            // Both edges: CCxP = CCxNP = 1.
            w.set_ccp(ch, true);
            w.set_ccnp(ch, true);
        }
    });
    t.smcr().write(|w| {
        w.set_ts(vals::Ts::ITR0);
        w.set_sms(vals::Sms::RESET_MODE);
    });
    t.dier().write(|w| w.set_ccie(CH_SYNC0, true));
    t.egr().write(|w| w.set_ug(true));
    t.sr().write_value(regs::SrGp16(0));
    t.cr1().modify(|w| w.set_cen(true));
    let af = sync0.af_num();
    // SYNC0 is push-pull from the ET1100; the pull-down holds it low while the ESC is absent.
    let pin = alternate(sync0, af, AfType::input(Pull::Down));
    Sync0Capture { _pin: pin }
}

/// Takes the capture of `ch` if its flag is set: CCR read (clears CCxIF), over-capture flag
/// cleared (rc_w0: zeros clear, ones leave the other flags, which another context may own).
#[inline]
fn take_channel(ch: usize) -> Option<u16> {
    let t = pac::TIM3;
    let sr = t.sr().read();
    if !sr.ccif(ch) {
        return None;
    }
    let count = t.ccr(ch).read().ccr();
    if sr.ccof(ch) {
        let mut clear = regs::SrGp16(u32::MAX);
        clear.set_ccof(ch, false);
        t.sr().write_value(clear);
    }
    Some(count)
}

/// The probe channels of TIM3, read by the control interrupt.
pub struct Tim3Probes {
    _private: (),
}

impl Tim3Probes {
    /// The probe channels (configured by [`configure`]).
    pub fn new(_capture: &Sync0Capture) -> Self {
        Self { _private: () }
    }
}

impl ProbeTimer for Tim3Probes {
    #[inline]
    fn count(&self) -> u16 {
        pac::TIM3.cnt().read().cnt()
    }

    #[inline]
    fn take_edge(&mut self, probe: TouchProbe) -> Option<u16> {
        take_channel(match probe {
            TouchProbe::One => CH_PROBE1,
            TouchProbe::Two => CH_PROBE2,
        })
    }
}

/// SYNC0's phase in the PWM period (ticks since the last valley) if an edge was captured since
/// the last call. Reading CCR1 clears CC1IF; a second edge before that read (CC1OF) means a
/// SYNC0 was not served: only the last one's phase is returned.
#[inline]
pub fn take_capture() -> Option<u16> {
    take_channel(CH_SYNC0)
}
