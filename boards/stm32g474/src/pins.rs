//! Pin map of the board: every pin and EXTI channel the firmware uses is named here, and only
//! here. The table is repeated in `README.md`.
//!
//! | signal | MCU pin | function | ET1100 / part | notes |
//! |---|---|---|---|---|
//! | ESC SPI clock | PC10 | SPI3_SCK (AF6) | SPI_CLK | mode 3, 21.25 MHz (see `et1100_spi`) |
//! | ESC SPI MISO | PC11 | SPI3_MISO (AF6) | SPI_DO | internal pull-down: an absent ESC reads 0x00 |
//! | ESC SPI MOSI | PC12 | SPI3_MOSI (AF6) | SPI_DI | |
//! | ESC SPI select | PA15 | GPIO out, push-pull, idle high | SPI_SEL (active low) | JTDI pulls PA15 up from reset, so the ESC stays deselected until `main` |
//! | ESC IRQ | PD2 | GPIO in + EXTI2 (own vector) | SPI_IRQ (active low, push-pull) | pull-up; level-sensitive use (`wait_for_low`) |
//! | ESC SYNC0 | PB4 | GPIO in + EXTI4 (own vector) | SYNC0 (active high, push-pull) | pull-down; rising edge. PB4 is also TIM3_CH1 for a later hardware time stamp of SYNC0 |
//! | RUN LED | PB10 | GPIO out, push-pull | green LED to GND | ETG.1300 RUN indicator |
//! | ERR LED | PB11 | GPIO out, push-pull | red LED to GND | ETG.1300 ERR indicator |
//! | HSE | PF0/PF1 | OSC_IN/OSC_OUT | 24 MHz crystal | see `clocks` |
//! | SWD | PA13/PA14 | SWDIO/SWCLK | probe-rs | PB3 (SWO) left free |
//!
//! Choices:
//! - SPI3 on port C keeps SPI1/SPI2's pins free: PA5–PA7 and PB13–PB15 are the
//!   OPAMP/ADC inputs and the TIM1 complementary outputs (CH1N–CH3N) of the inverter.
//! - IRQ and SYNC0 use EXTI lines 2 and 4, which have vectors of their own (EXTI2, EXTI4), so
//!   each gets its own priority and no handler has to demultiplex a shared EXTIx_y vector.
//! - The ESC side of these signals is set by the SII EEPROM (PDI control 0x0140 = 0x05 "SPI
//!   slave"; PDI configuration 0x0150: SPI mode 3, SPI_IRQ push-pull active low, SPI_SEL
//!   active low, normal data-out sample; 0x0151: SYNC0 push-pull active high, mapped to the
//!   pin). od-gen's SII generator must produce exactly these values for this board.

use embassy_stm32::{peripherals as p, Peri, Peripherals};

/// EXTI line of ESC SYNC0 (PB4 → EXTI4). `irq` binds the matching vector, and
/// `irq::Sync0Channel` checks at compile time that the channel's vector is EXTI4.
pub const SYNC0_EXTI_LINE: usize = 4;

/// The ET1100's PDI and interrupt pins.
pub struct EscPins {
    /// SPI peripheral of the PDI.
    pub spi: Peri<'static, p::SPI3>,
    /// SPI_CLK.
    pub sck: Peri<'static, p::PC10>,
    /// SPI_DO of the ESC (MCU input).
    pub miso: Peri<'static, p::PC11>,
    /// SPI_DI of the ESC (MCU output).
    pub mosi: Peri<'static, p::PC12>,
    /// SPI_SEL, driven as a GPIO.
    pub cs: Peri<'static, p::PA15>,
    /// SPI_IRQ (active low).
    pub irq: Peri<'static, p::PD2>,
    /// EXTI channel of `irq`.
    pub irq_exti: Peri<'static, p::EXTI2>,
    /// SYNC0 (active high).
    pub sync0: Peri<'static, p::PB4>,
    /// EXTI channel of `sync0`.
    pub sync0_exti: Peri<'static, p::EXTI4>,
}

/// The EtherCAT status LEDs.
pub struct LedPins {
    /// Green RUN LED.
    pub run: Peri<'static, p::PB10>,
    /// Red ERR LED.
    pub err: Peri<'static, p::PB11>,
}

/// Everything the board uses, taken out of the embassy peripheral set.
pub struct BoardPins {
    /// ET1100 PDI.
    pub esc: EscPins,
    /// Status LEDs.
    pub leds: LedPins,
    /// Internal flash (the 1010h parameter pages, see `storage`).
    pub flash: Peri<'static, p::FLASH>,
}

/// Splits the peripheral set into the board's functional groups.
pub fn split(p: Peripherals) -> BoardPins {
    BoardPins {
        esc: EscPins {
            spi: p.SPI3,
            sck: p.PC10,
            miso: p.PC11,
            mosi: p.PC12,
            cs: p.PA15,
            irq: p.PD2,
            irq_exti: p.EXTI2,
            sync0: p.PB4,
            sync0_exti: p.EXTI4,
        },
        leds: LedPins {
            run: p.PB10,
            err: p.PB11,
        },
        flash: p.FLASH,
    }
}
