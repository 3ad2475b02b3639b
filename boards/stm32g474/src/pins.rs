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
//! | ESC SYNC0 | PB4 | TIM3_CH1 (AF2), input capture | SYNC0 (active high, push-pull) | pull-down; rising edge captured against the PWM (see `sync_capture`); the capture interrupt is the cycle context |
//! | PWM a high | PA8 | TIM1_CH1 (AF6) | gate driver INHA | active high; off (low) while MOE is cleared |
//! | PWM b high | PA9 | TIM1_CH2 (AF6) | gate driver INHB | |
//! | PWM c high | PA10 | TIM1_CH3 (AF6) | gate driver INHC | |
//! | PWM a low | PB13 | TIM1_CH1N (AF6) | gate driver INLA | active high, dead time from `pwm` |
//! | PWM b low | PB14 | TIM1_CH2N (AF6) | gate driver INLB | |
//! | PWM c low | PB15 | TIM1_CH3N (AF4) | gate driver INLC | |
//! | break | PB12 | TIM1_BKIN (AF6) | over-current comparator and gate driver nFAULT, wired-OR open drain | active low, pull-up; turns the outputs off in hardware |
//! | gate driver enable | PB2 | GPIO out, push-pull | gate driver EN | high = driver awake |
//! | phase a current | PC0 | ADC1_IN6 (analog) | current amplifier a | injected rank 1 of ADC1 |
//! | phase b current | PC1 | ADC2_IN7 (analog) | current amplifier b | injected rank 1 of ADC2 |
//! | phase c current | PC2 | ADC1_IN8 (analog) | current amplifier c | three-shunt boards; rank 2 of ADC1 |
//! | bus voltage | PC3 | ADC2_IN9 (analog) | 300 kΩ / 10 kΩ divider | rank 2 of ADC2 |
//! | stage temperature | PB1 | ADC1_IN12 (analog) | linear sensor on the heat sink | rank 3 of ADC1 |
//! | encoder A | PA0 | TIM2_CH1 (AF1) | RS-422 receiver | encoder mode 3 (default build) |
//! | encoder B | PA1 | TIM2_CH2 (AF1) | RS-422 receiver | |
//! | encoder Z | PA3 | TIM2_CH4 (AF1) | RS-422 receiver | captures the count on the rising edge |
//! | encoder fault | PA2 | GPIO in, pull-up | receiver fault output (open drain) | low = cable broken or unpowered |
//! | BiSS MA | PA5 | SPI1_SCK (AF5) | RS-422 driver to the encoder's MA | `biss-encoder` build (in place of A/B/Z) |
//! | BiSS SLO | PA6 | SPI1_MISO (AF5) | RS-422 receiver from the encoder's SLO | pull-up: an open line reads no ack |
//! | limit + | PC6 | GPIO in, pull-down | NC contact to 3.3 V | low = active (open or broken) |
//! | limit − | PC7 | GPIO in, pull-down | NC contact to 3.3 V | low = active |
//! | home | PC8 | GPIO in, pull-down | NO contact to 3.3 V | high = active |
//! | motor thermal switch | PA4 | GPIO in, pull-up | NC bimetal to GND | high (open) = motor too hot |
//! | touch probe 1 | PB0 | TIM3_CH3 (AF2), capture both edges | 24 V input stage | high = active; edge time against the PWM (see `sync_capture`) |
//! | touch probe 2 | PB5 | TIM3_CH2 (AF2), capture both edges | 24 V input stage | high = active |
//! | STO 1 | PB6 | GPIO in, pull-down | safe-torque-off channel 1 monitor | high = closed (torque allowed); the channel cuts the gate supply in hardware |
//! | STO 2 | PB7 | GPIO in, pull-down | safe-torque-off channel 2 monitor | |
//! | enable | PC9 | GPIO in, pull-down | drive-enable input, 24 V input stage | high = operation permitted; low or broken: bridge off in firmware, no restart by itself |
//! | brake | PB9 | GPIO out, push-pull | brake driver input | high = coil energised = brake released |
//! | RUN LED | PB10 | GPIO out, push-pull | green LED to GND | ETG.1300 RUN indicator |
//! | ERR LED | PB11 | GPIO out, push-pull | red LED to GND | ETG.1300 ERR indicator |
//! | HSE | PF0/PF1 | OSC_IN/OSC_OUT | 24 MHz crystal | see `clocks` |
//! | SWD | PA13/PA14 | SWDIO/SWCLK | probe-rs | PB3 (SWO) left free |
//!
//! Choices:
//! - SPI3 on port C keeps SPI1's pins (PA5–PA7) free for the absolute encoder's serial
//!   interface; PB13–PB15 are TIM1's complementary outputs.
//! - PB8 is BOOT0 on the G474 and stays unused; PA6 (the other TIM1_BKIN) is SPI1_MISO.
//! - Every analog input sits on a channel that ADC1 or ADC2 can convert, so the injected
//!   sequences are split between them and run at the same time (see `adc`).
//! - The IRQ uses EXTI line 2, which has a vector of its own (EXTI2): its own priority, and no
//!   handler has to demultiplex a shared EXTIx_y vector. SYNC0's vector is TIM3's.
//! - The ESC side of these signals is set by the SII EEPROM (PDI control 0x0140 = 0x05 "SPI
//!   slave"; PDI configuration 0x0150: SPI mode 3, SPI_IRQ push-pull active low, SPI_SEL
//!   active low, normal data-out sample; 0x0151: SYNC0 push-pull active high, mapped to the
//!   pin). od-gen's SII generator must produce exactly these values for this board.

use embassy_stm32::gpio::{AfType, Flex, Pin};
use embassy_stm32::{peripherals as p, Peri, Peripherals};

/// `pin` in its alternate function `af` (checked by the caller's pin-trait bound) as `af_type`,
/// kept configured as long as the returned `Flex` lives (a dropped one goes to analog).
pub fn alternate(pin: Peri<'static, impl Pin>, af: u8, af_type: AfType) -> Flex<'static> {
    let mut flex = Flex::new(pin);
    flex.set_as_af_unchecked(af, af_type);
    flex
}

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
    /// The timer that captures SYNC0.
    pub sync0_timer: Peri<'static, p::TIM3>,
}

/// TIM1 and the gate driver.
pub struct InverterPins {
    /// TIM1.
    pub tim: Peri<'static, p::TIM1>,
    /// TIM1's outputs and break input.
    pub pwm: crate::pwm::Tim1Pins<p::PA8, p::PA9, p::PA10, p::PB13, p::PB14, p::PB15, p::PB12>,
    /// The gate driver's enable.
    pub gate_enable: Peri<'static, p::PB2>,
}

/// ADC1/ADC2 and their inputs.
pub struct SensingPins {
    /// ADC1.
    pub adc1: Peri<'static, p::ADC1>,
    /// ADC2.
    pub adc2: Peri<'static, p::ADC2>,
    /// The analog inputs.
    pub analog: crate::adc::AnalogPins<p::PC0, p::PC1, p::PC2, p::PC3, p::PB1>,
}

/// TIM2 and the encoder's lines.
#[cfg(not(feature = "biss-encoder"))]
pub struct EncoderPins {
    /// TIM2.
    pub tim: Peri<'static, p::TIM2>,
    /// A, B, Z and the receiver's fault output.
    pub lines: crate::encoder::EncoderPins<p::PA0, p::PA1, p::PA3, p::PA2>,
}

/// SPI1, its DMA channels and the BiSS-C lines.
#[cfg(feature = "biss-encoder")]
pub struct EncoderPins {
    /// MA (SPI1_SCK), SLO (SPI1_MISO), SPI1, DMA1 channels 1 and 2.
    pub biss: crate::biss_spi::BissPins<p::PA5, p::PA6>,
}

/// The axis' digital inputs and the brake.
pub struct AxisIoPins {
    /// Switches, thermal switch, probes, STO channels, enable input.
    pub inputs: crate::axis_io::InputPinSet<
        p::PC6,
        p::PC7,
        p::PC8,
        p::PA4,
        p::PB0,
        p::PB5,
        p::PB6,
        p::PB7,
        p::PC9,
    >,
    /// The brake driver's input.
    pub brake: Peri<'static, p::PB9>,
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
    /// The inverter.
    pub inverter: InverterPins,
    /// Current, bus-voltage and temperature sensing.
    pub sensing: SensingPins,
    /// The encoder (incremental on TIM2, or BiSS-C on SPI1 with `biss-encoder`).
    pub encoder: EncoderPins,
    /// Digital inputs and the brake.
    pub axis_io: AxisIoPins,
    /// Internal flash (the 1010h parameter pages, see `storage`).
    pub flash: Peri<'static, p::FLASH>,
    /// The independent watchdog.
    pub iwdg: Peri<'static, p::IWDG>,
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
            sync0_timer: p.TIM3,
        },
        leds: LedPins {
            run: p.PB10,
            err: p.PB11,
        },
        inverter: InverterPins {
            tim: p.TIM1,
            pwm: crate::pwm::Tim1Pins {
                a: p.PA8,
                b: p.PA9,
                c: p.PA10,
                a_low: p.PB13,
                b_low: p.PB14,
                c_low: p.PB15,
                break_input: p.PB12,
            },
            gate_enable: p.PB2,
        },
        sensing: SensingPins {
            adc1: p.ADC1,
            adc2: p.ADC2,
            analog: crate::adc::AnalogPins {
                current_a: p.PC0,
                current_b: p.PC1,
                current_c: p.PC2,
                bus: p.PC3,
                temperature: p.PB1,
            },
        },
        #[cfg(not(feature = "biss-encoder"))]
        encoder: EncoderPins {
            tim: p.TIM2,
            lines: crate::encoder::EncoderPins {
                a: p.PA0,
                b: p.PA1,
                z: p.PA3,
                fault: p.PA2,
            },
        },
        #[cfg(feature = "biss-encoder")]
        encoder: EncoderPins {
            biss: crate::biss_spi::BissPins {
                spi: p.SPI1,
                ma: p.PA5,
                slo: p.PA6,
                rx_dma: p.DMA1_CH1,
                tx_dma: p.DMA1_CH2,
            },
        },
        axis_io: AxisIoPins {
            inputs: crate::axis_io::InputPinSet {
                positive_limit: p.PC6,
                negative_limit: p.PC7,
                home: p.PC8,
                motor_over_temperature: p.PA4,
                probe1: p.PB0,
                probe2: p.PB5,
                safe_torque_off1: p.PB6,
                safe_torque_off2: p.PB7,
                enable: p.PC9,
            },
            brake: p.PB9,
        },
        flash: p.FLASH,
        iwdg: p.IWDG,
    }
}
