//! Clock tree: 24 MHz HSE crystal → PLL → 170 MHz SYSCLK in range-1 boost mode.
//!
//! | clock | value | derivation / limit (RM0440 rev 8, DS12288) |
//! |---|---|---|
//! | HSE | 24 MHz crystal on PF0/PF1 | board assumption (the NUCLEO-G474RE fits a 24 MHz crystal, X3); 4–48 MHz allowed |
//! | PLL input | 24 MHz / 6 = 4 MHz | M divider; PLL input must be 2.66–8 MHz (RM0440 §7.4.4 RCC_PLLCFGR) |
//! | VCO | 4 MHz × 85 = 340 MHz | N multiplier; VCO must be 96–344 MHz |
//! | SYSCLK = PLLR | 340 MHz / 2 = 170 MHz | the G474 maximum; needs range-1 boost mode above 150 MHz (RM0440 §6.1.5) and 4 flash wait states (RM0440 §3.3.3 Table 9) |
//! | HCLK, PCLK1, PCLK2 | 170 MHz | AHB/APB prescalers 1; 170 MHz is the APB maximum |
//! | SPI3, TIM2 kernel clock | PCLK1 = 170 MHz | on APB1; with an APB prescaler of 1 the timer clock is PCLK itself |
//! | TIM1 kernel clock | PCLK2 = 170 MHz | on APB2 |
//! | ADC1/ADC2 clock | HCLK / 4 = 42.5 MHz | synchronous mode, see `adc` |
//!
//! embassy-stm32 applies the boost-mode entry sequence (AHB/2 during the switch, R1MODE = 0,
//! wait states, then AHB/1) and the flash latency itself (`rcc::g4::init`). HSI48 is switched
//! off: there is no USB on this board.
//!
//! Note: embassy waits for HSERDY without a limit; a board without a working crystal hangs in
//! `embassy_stm32::init` (visible in probe-rs as a stop before the first log line).

use embassy_stm32::rcc::{
    AHBPrescaler, APBPrescaler, Hse, HseMode, Pll, PllMul, PllPreDiv, PllRDiv, PllSource, Sysclk,
};
use embassy_stm32::time::Hertz;

/// HSE crystal frequency (board assumption, see the module table).
pub const HSE_HZ: u32 = 24_000_000;
/// PLL input divider M.
const PLL_M: u32 = 6;
/// PLL multiplier N.
const PLL_N: u32 = 85;
/// PLL R divider (SYSCLK).
const PLL_R: u32 = 2;

/// SYSCLK = HCLK = core clock (DWT CYCCNT rate).
pub const SYSCLK_HZ: u32 = HSE_HZ / PLL_M * PLL_N / PLL_R;
/// AHB clock (prescaler 1): the synchronous clock of the ADCs.
pub const HCLK_HZ: u32 = SYSCLK_HZ;
/// APB1 clock: kernel clock of SPI3 (the ET1100 PDI), of TIM2 (encoder) and of TIM4
/// (embassy-time).
pub const PCLK1_HZ: u32 = SYSCLK_HZ;
/// APB2 clock: kernel clock of TIM1 (the inverter).
pub const PCLK2_HZ: u32 = SYSCLK_HZ;

// The derivations above, checked at compile time against the RM0440 limits.
const _: () = {
    let pll_in = HSE_HZ / PLL_M;
    assert!(pll_in >= 2_660_000 && pll_in <= 8_000_000);
    let vco = pll_in * PLL_N;
    assert!(vco >= 96_000_000 && vco <= 344_000_000);
    assert!(SYSCLK_HZ == 170_000_000);
    // The board description (servo, PDI clock, load model) assumes this clock.
    assert!(SYSCLK_HZ == stm32g4_axis::board::CORE_CLOCK_HZ);
};

/// The embassy-stm32 configuration of this board.
pub fn config() -> embassy_stm32::Config {
    let mut config = embassy_stm32::Config::default();
    let rcc = &mut config.rcc;
    rcc.hse = Some(Hse {
        freq: Hertz(HSE_HZ),
        mode: HseMode::Oscillator,
    });
    rcc.pll = Some(Pll {
        source: PllSource::HSE,
        prediv: PllPreDiv::DIV6,
        mul: PllMul::MUL85,
        divp: None,
        divq: None,
        divr: Some(PllRDiv::DIV2),
    });
    rcc.sys = Sysclk::PLL1_R;
    rcc.ahb_pre = AHBPrescaler::DIV1;
    rcc.apb1_pre = APBPrescaler::DIV1;
    rcc.apb2_pre = APBPrescaler::DIV1;
    rcc.boost = true;
    rcc.hsi48 = None;
    // DMA channel interrupts (the G4's DMA is embassy's `bdma` kind) default to P0, the level reserved for the FOC interrupt
    // (see `irq::prio`). No DMA is used yet; keep them out of P0 regardless.
    config.bdma_interrupt_priority = crate::irq::prio::DMA;
    config
}
