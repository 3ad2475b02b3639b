//! The STM32G4 board's axis drivers and its control interrupt, written against small register
//! traits ([`regs`]) instead of the peripheral access crate.
//!
//! `boards/stm32g474` implements the traits on TIM1, ADC1/ADC2, TIM2 and the GPIO ports (a
//! handful of register reads and writes each) and configures the peripherals once at start-up;
//! everything that decides something (duty → compare value, counts → amperes, 32-bit counter →
//! multi-turn position, the gate-enable sequence, the break latch, the order of the control
//! interrupt) lives here, where it is tested on the host against register fakes and runs on the
//! QEMU Cortex-M4 benchmark board with the same code the real board runs.
//!
//! | module | drives | `hal` trait it provides |
//! |---|---|---|
//! | [`regs`] | — | the register-access traits a board implements |
//! | [`board`] | — | the servo and analog front end of `boards/stm32g474` (motor, encoder, shunts, dividers) |
//! | [`inverter`] | TIM1: centre-aligned complementary PWM, MOE, break flag | [`hal::power::Inverter`] |
//! | [`sensing`] | ADC1/ADC2 injected conversions of the phase currents, bus voltage, temperature | [`hal::power::CurrentSense`], [`hal::power::BusSense`] |
//! | [`quadrature`] | a 32-bit timer in encoder mode with the index captured | [`hal::encoder::Encoder`] |
//! | [`biss`] | a BiSS-C absolute encoder: frame decoding with CRC-6, one frame per period over a [`biss::FrameTransfer`] (SPI with DMA on the board) | [`hal::encoder::Encoder`] |
//! | [`inputs`] | GPIO levels of switches, enable and STO inputs; brake output | [`hal::io::DigitalInputs`], [`hal::io::DigitalOutputs`] |
//! | [`control`] | the body of the control interrupt (ADC end of conversion, P0) | — |
//! | [`cycle`] | the body of the cycle interrupt (SYNC0, P1): process data, outputs, phase lock | — |
//! | [`event`] | the ESC-event round (P2): AL control, SM checks and the mailbox beside the cycle, the PDI shared in 32-byte transfers | — |
//! | [`liveness`] | — (the decision behind each refresh of the independent watchdog) | — |
//! | [`phase_lock`] | — (the PWM period trim that phase-locks the control loop to SYNC0) | — |
//!
//! # The PWM period and the sample
//! TIM1 counts up and down (centre-aligned) with the phases in PWM mode 2, so every low-side
//! switch conducts at the valley (counter 0). The repetition counter makes one update event per
//! period, at the valley; the update event loads the compare values the control interrupt wrote
//! during the previous period (preload) and, as TRGO2, starts the injected conversions of ADC1
//! and ADC2 — the sample is taken in the middle of the low-side conduction, where the shunts
//! carry the phase currents and the ripple crosses its average. The end of the injected
//! sequence raises the control interrupt, which runs [`control::AxisHardware::control_interrupt`].

#![cfg_attr(not(test), no_std)]
#![deny(missing_docs)]
// Firmware never panics on input: outside tests no unwrap/expect/panic and no unchecked
// indexing or integer arithmetic; each exception states why it cannot fail where it stands.
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::unreachable,
        clippy::todo,
        clippy::unimplemented,
        clippy::indexing_slicing,
        clippy::arithmetic_side_effects
    )
)]

pub mod biss;
pub mod board;
pub mod control;
pub mod cycle;
pub mod event;
pub mod inputs;
pub mod inverter;
pub mod liveness;
pub mod phase_lock;
pub mod quadrature;
pub mod regs;
pub mod sensing;
