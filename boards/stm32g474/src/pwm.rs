//! TIM1: centre-aligned complementary PWM of the three half-bridges, dead time, break input,
//! and the update event that triggers the current sampling (TRGO2). The register values come
//! from `stm32g4-settings` (RM0440 formulas) at compile time; the run-time accesses are the
//! [`stm32g4_axis::regs::PwmTimer`] implementation [`Tim1`].
//!
//! | setting | value | RM0440 |
//! |---|---|---|
//! | counter | centre-aligned mode 1 (CMS = 01), ARR preloaded | §29.3.4 |
//! | period | PSC/ARR for [`servo::PWM_HZ`] (ARR 2125 at 40 kHz from 170 MHz) | §29.3.4: f = f_TIM / ((PSC+1)·2·ARR) |
//! | phases | CH1–CH3 PWM mode 2, CCR preloaded; CHx and CHxN active high | §29.3.13 |
//! | dead time | DTG for [`servo::DEAD_TIME_NS`], CKD = ÷1 | §29.6.20 |
//! | off state | OSSI = OSSR = 1, OISx = OISxN = 0: with MOE cleared both switches of every leg are off | §29.6.20 |
//! | break | BKE = 1, BKIN pin active low (BKP = 0, BKINP = 0), no filter (acts asynchronously, with no clock) | §29.3.18, §29.6.27 |
//! | lock | LOCK level 1: DTG, BKE/BKP, AOE, OISx frozen until reset | §29.6.20 |
//! | update | RCR = 1, written before the counter starts: one update event per period, at the valley (every low-side switch on) | §29.3.5 |
//! | ADC trigger | TRGO2 = update (MMS2 = 0010) → ADC1/ADC2 injected trigger `tim1_trgo2` | §29.6.2, §21 Table 167 |
//! | SYNC0 phase | TRGO = update (MMS = 010) → TIM3's reset (`sync_capture`) | §29.6.2 |
//! | period trim | ARR rewritten each period by the control interrupt for the SYNC0 phase lock (±1 %) | `stm32g4_axis::phase_lock` |

use embassy_stm32::gpio::{AfType, Flex, OutputType, Pull, Speed};
use embassy_stm32::pac::timer::{regs, vals};
use embassy_stm32::peripherals::TIM1;
use embassy_stm32::timer::{BkIn1, BreakInputPin, Ch1, Ch2, Ch3, TimerComplementaryPin, TimerPin};
use embassy_stm32::{pac, rcc, Peri};
use stm32g4_axis::regs::PwmTimer;
use stm32g4_settings::dead_time::{ClockDivision, DeadTime};
use stm32g4_settings::pwm::{repetition_counter, CentreAligned};

use crate::clocks::PCLK2_HZ;
use crate::pins::alternate;
use stm32g4_axis::board as servo;

/// TIM1's kernel clock: PCLK2 (APB2 prescaler 1, so no ×2).
pub const TIM1_HZ: u32 = PCLK2_HZ;
/// Clock division of the dead-time generator and the digital filters.
const CKD: ClockDivision = ClockDivision::Div1;

/// PSC and ARR (`stm32g4_axis::board`, computed for the core clock: TIM1's).
pub const PERIOD: CentreAligned = servo::PWM_PERIOD;
/// The dead time.
pub const DEAD_TIME: DeadTime = match DeadTime::at_least(TIM1_HZ, CKD, servo::DEAD_TIME_NS) {
    Ok(d) => d,
    Err(_) => panic!("dead time out of TIM1's range"),
};
/// TIMx_RCR: one update event per PWM period.
const REPETITION: u16 = match repetition_counter(1) {
    Ok(r) => r,
    Err(_) => panic!("repetition counter"),
};

const _: () = {
    // The board description computed the period for TIM1's clock.
    assert!(TIM1_HZ == servo::CORE_CLOCK_HZ);
    // The worked example of stm32g4-settings: 200 ns → 34 ticks at 170 MHz.
    assert!(DEAD_TIME.dtg == 34);
};

/// The break input's index in BDTR/AF1 (BRK, not BRK2).
const BRK: usize = 0;

/// TIM1's outputs: high sides CH1–CH3, low sides CH1N–CH3N, and the break input. Kept for
/// ever (a dropped pin would fall back to analog mode).
pub struct PwmPins {
    _outputs: [Flex<'static>; 6],
    _break_input: Flex<'static>,
}

/// TIM1's outputs: push-pull, fastest edges.
const OUTPUT: AfType = AfType::output(OutputType::PushPull, Speed::VeryHigh);

/// The pins of [`configure`], each checked at compile time to carry its TIM1 signal.
pub struct Tim1Pins<
    A: embassy_stm32::gpio::Pin,
    B: embassy_stm32::gpio::Pin,
    C: embassy_stm32::gpio::Pin,
    AN: embassy_stm32::gpio::Pin,
    BN: embassy_stm32::gpio::Pin,
    CN: embassy_stm32::gpio::Pin,
    BK: embassy_stm32::gpio::Pin,
> {
    /// CH1: phase a, high side.
    pub a: Peri<'static, A>,
    /// CH2: phase b, high side.
    pub b: Peri<'static, B>,
    /// CH3: phase c, high side.
    pub c: Peri<'static, C>,
    /// CH1N: phase a, low side.
    pub a_low: Peri<'static, AN>,
    /// CH2N: phase b, low side.
    pub b_low: Peri<'static, BN>,
    /// CH3N: phase c, low side.
    pub c_low: Peri<'static, CN>,
    /// BKIN: over-current comparator and gate-driver fault, wired-OR, active low.
    pub break_input: Peri<'static, BK>,
}

/// Configures TIM1 (see the module table) and starts its counter with the gates off (MOE
/// cleared) and every phase at 50 %; the outputs go to their pins only then, already at their
/// off level. Returns the run-time register access and the pins to keep.
#[allow(clippy::type_complexity)]
pub fn configure<A, B, C, AN, BN, CN, BK>(
    _tim: Peri<'static, TIM1>,
    pins: Tim1Pins<A, B, C, AN, BN, CN, BK>,
) -> (Tim1, PwmPins)
where
    A: TimerPin<TIM1, Ch1>,
    B: TimerPin<TIM1, Ch2>,
    C: TimerPin<TIM1, Ch3>,
    AN: TimerComplementaryPin<TIM1, Ch1>,
    BN: TimerComplementaryPin<TIM1, Ch2>,
    CN: TimerComplementaryPin<TIM1, Ch3>,
    BK: BreakInputPin<TIM1, BkIn1>,
{
    rcc::enable_and_reset::<TIM1>();
    let t = pac::TIM1;
    t.cr1().write(|w| {
        w.set_cms(vals::Cms::CENTER_ALIGNED1);
        w.set_arpe(true);
        w.set_ckd(vals::Ckd::from_bits(CKD.bits()));
    });
    t.psc().write_value(PERIOD.prescaler);
    t.arr().write(|w| w.set_arr(PERIOD.auto_reload));
    let centre = stm32g4_axis::inverter::compare_for_duty(0.5, PERIOD.auto_reload);
    for ch in 0..3 {
        t.ccr(ch).write(|w| w.set_ccr(centre));
    }
    // CCMR1 holds CH1/CH2, CCMR2 CH3 (and CH4, unused).
    for (reg, ch) in [(0, 0), (0, 1), (1, 0)] {
        t.ccmr_output(reg).modify(|w| {
            w.set_ocm(ch, vals::Ocm::PWM_MODE2);
            w.set_ocpe(ch, true);
        });
    }
    t.ccer().write(|w| {
        for ch in 0..3 {
            w.set_cce(ch, true);
            w.set_ccne(ch, true);
        }
    });
    t.cr2().write(|w| {
        for ch in 0..3 {
            w.set_ois(ch, false);
            w.set_oisn(ch, false);
        }
        w.set_mms2(vals::Mms2::UPDATE);
        // TRGO resets TIM3 at every valley: SYNC0's capture is its phase (`sync_capture`).
        w.set_mms(vals::Mms::UPDATE);
    });
    // The BKIN pin into the break, not inverted (its reset value is "enabled" already).
    t.af1().write(|w| {
        w.set_bkine(true);
        w.set_bkinp(vals::Bkinp::NOT_INVERTED);
    });
    // One write: LOCK freezes the rest from here on.
    t.bdtr().write(|w| {
        w.set_dtg(DEAD_TIME.dtg);
        w.set_ossi(vals::Ossi::IDLE_LEVEL);
        w.set_ossr(vals::Ossr::IDLE_LEVEL);
        w.set_bke(BRK, true);
        w.set_bkp(BRK, vals::Bkp::ACTIVE_LOW);
        w.set_bkf(BRK, vals::FilterValue::NO_FILTER);
        w.set_aoe(false);
        w.set_moe(false);
        w.set_lock(vals::Lock::LEVEL1);
    });
    // Before the counter starts: the update event falls on the valley (RM0440 §29.3.5).
    t.rcr().write(|w| w.set_rep(REPETITION));
    // Load PSC, ARR, RCR and the compare values; then clear the flags the load set.
    t.egr().write(|w| w.set_ug(true));
    t.sr().write_value(regs::SrAdv(0));
    t.cr1().modify(|w| w.set_cen(true));

    let (a_af, b_af, c_af) = (pins.a.af_num(), pins.b.af_num(), pins.c.af_num());
    let (an_af, bn_af, cn_af) = (
        pins.a_low.af_num(),
        pins.b_low.af_num(),
        pins.c_low.af_num(),
    );
    let bk_af = pins.break_input.af_num();
    let outputs = [
        alternate(pins.a, a_af, OUTPUT),
        alternate(pins.b, b_af, OUTPUT),
        alternate(pins.c, c_af, OUTPUT),
        alternate(pins.a_low, an_af, OUTPUT),
        alternate(pins.b_low, bn_af, OUTPUT),
        alternate(pins.c_low, cn_af, OUTPUT),
    ];
    // BKIN: open-drain sources with the board's pull-up; the MCU's pull-up as a second one.
    let break_input = alternate(pins.break_input, bk_af, AfType::input(Pull::Up));
    (
        Tim1 { _private: () },
        PwmPins {
            _outputs: outputs,
            _break_input: break_input,
        },
    )
}

/// TIM1's run-time registers (only [`configure`] makes one).
pub struct Tim1 {
    _private: (),
}

impl PwmTimer for Tim1 {
    #[inline]
    fn auto_reload(&self) -> u16 {
        pac::TIM1.arr().read().arr()
    }

    #[inline]
    fn set_auto_reload(&mut self, arr: u16) {
        pac::TIM1.arr().write(|w| w.set_arr(arr));
    }

    #[inline]
    fn set_compares(&mut self, compares: [u16; 3]) {
        for (ch, ccr) in compares.into_iter().enumerate() {
            pac::TIM1.ccr(ch).write(|w| w.set_ccr(ccr));
        }
    }

    /// A read-modify-write of BDTR: the locked fields are written back unchanged (LOCK 1
    /// ignores them). A break that clears MOE between the read and the write cannot be undone
    /// by it while the break is active (MOE is not settable then); a break shorter than those
    /// few cycles leaves BIF set, which the next period start reports.
    #[inline]
    fn set_main_output(&mut self, enabled: bool) {
        pac::TIM1.bdtr().modify(|w| w.set_moe(enabled));
    }

    #[inline]
    fn take_break(&mut self) -> bool {
        let fired = pac::TIM1.sr().read().bif(BRK);
        if fired {
            // SR flags are cleared by writing 0 (rc_w0); ones leave the others alone.
            let mut clear = regs::SrAdv(u32::MAX);
            clear.set_bif(BRK, false);
            pac::TIM1.sr().write_value(clear);
        }
        fired
    }
}
