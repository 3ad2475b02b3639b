//! The servo `boards/stm32g474` drives, and its analog front end: the one place that states
//! motor, encoder, power-stage and sensing circuit values. The board's peripheral settings
//! (its `pwm`, `adc` and `encoder` modules) are computed from these at compile time, and the
//! QEMU benchmark board runs the control interrupt with the same values.
//!
//! | part | value |
//! |---|---|
//! | motor, power stage, protections | the firmware's 48 V / 400 W reference servo ([`SERVO_400W`]): 40 kHz PWM, 200 ns dead time |
//! | encoder | incremental, 2500 lines (10,000 increments per revolution), A/B/Z on RS-422 receivers; commutation found by alignment at every enable. Built with `biss-encoder`: the reference servo's BiSS-C absolute encoder (20-bit single-turn, 16-bit multi-turn) on SPI1 instead |
//! | phase currents | two low-side shunts of 2 mΩ (phases a, b), amplifier gain 16 biased at 1.65 V: 32 mV/A, ±51.6 A full scale (the simulated board's 25 mA/count) |
//! | bus voltage | 300 kΩ / 10 kΩ divider: 102 V full scale |
//! | power-stage temperature | linear sensor on the heat sink, 0.5 V at 0 °C, 10 mV/°C |
//! | ADC | 12 bit, VREF+ = 3.3 V |
//! | gate driver | bootstrap high sides: 100 µs of pre-charge (low sides on) after each enable |
//! | CPU | STM32G474 at 170 MHz, APB1 and APB2 undivided |
//! | PDI | ET1100 on SPI3: the fastest APB1 / 2^(BR+1) within the ET1100's 30 MHz, 21.25 MHz |

use motor_control::servo::{EncoderSpec, ServoSpec, Tuning, SERVO_400W};

use stm32g4_settings::pwm::CentreAligned;
use stm32g4_settings::spi::BaudRate;

use crate::biss::BissLayout;
use crate::sensing::{AnalogFrontEnd, LinearScale, Shunts};

/// Core clock (SYSCLK = HCLK = PCLK1 = PCLK2), Hz; `boards/stm32g474/src/clocks.rs` derives it
/// from the crystal and checks it against this value.
pub const CORE_CLOCK_HZ: u32 = 170_000_000;
/// ET1100 maximum SPI clock (Section III, SPI timing characteristics).
pub const ET1100_MAX_SPI_CLOCK_HZ: u32 = 30_000_000;
/// SPI3's baud rate for the ET1100: the fastest APB1 / 2^(BR + 1) within its maximum (APB1 / 8
/// at 170 MHz), computed at compile time (RM0440 §39.7.1).
pub const PDI_SPI_BAUD_RATE: BaudRate =
    match BaudRate::at_most(CORE_CLOCK_HZ, ET1100_MAX_SPI_CLOCK_HZ) {
        Ok(baud) => baud,
        Err(_) => panic!("no SPI prescaler keeps the clock within the ET1100's maximum"),
    };
/// The PDI's SPI clock, Hz.
pub const PDI_SPI_CLOCK_HZ: u32 = PDI_SPI_BAUD_RATE.sck_hz;

/// The servo: the reference servo with this board's incremental encoder.
pub const SERVO: ServoSpec = ServoSpec {
    encoder: EncoderSpec::Incremental {
        counts_per_rev: COUNTS_PER_REV,
    },
    ..SERVO_400W
};

/// The servo with a BiSS-C absolute encoder (the board built with `biss-encoder`): the
/// reference servo as it is, 20-bit single-turn and 16-bit multi-turn. Its commutation offset
/// (0 here) must be the commissioned one of the motor fitted.
pub const SERVO_BISS: ServoSpec = SERVO_400W;

/// The BiSS-C frame layout of [`SERVO_BISS`]'s encoder.
pub const BISS_LAYOUT: BissLayout = match SERVO_BISS.encoder {
    EncoderSpec::Absolute {
        single_turn_bits,
        multi_turn_bits,
        ..
    } => BissLayout {
        multi_turn_bits,
        single_turn_bits,
    },
    EncoderSpec::Incremental { .. } => panic!("the BiSS servo needs an absolute encoder"),
};

/// Encoder lines per revolution.
const ENCODER_LINES: u32 = 2_500;
/// Increments per revolution: the timer counts every edge of A and B (x4).
pub const COUNTS_PER_REV: u32 = 4 * ENCODER_LINES;

/// The loop tuning.
pub const TUNING: Tuning = Tuning::DEFAULT;

/// PWM frequency, Hz.
pub const PWM_HZ: u32 = SERVO.inverter.pwm_hz as u32;
/// TIM1's PSC and ARR for [`PWM_HZ`] (TIM1 on APB2, undivided: the core clock).
pub const PWM_PERIOD: CentreAligned = match CentreAligned::new(CORE_CLOCK_HZ, PWM_HZ) {
    Ok(p) => p,
    Err(_) => panic!("PWM frequency out of TIM1's range"),
};
/// Dead time of every leg, ns (the gate driver's and switches' need, rounded up by `pwm`).
pub const DEAD_TIME_NS: u32 = (SERVO.inverter.dead_time_s * 1e9 + 0.5) as u32;

/// The gate driver's bootstrap pre-charge after each enable, ns: every low side on long enough
/// to charge the high sides' bootstrap capacitors from empty (a few µF through the low side and
/// the driver's bootstrap diode).
pub const BOOTSTRAP_PRECHARGE_NS: u32 = 100_000;
/// [`BOOTSTRAP_PRECHARGE_NS`] in PWM periods (rounded up).
pub const BOOTSTRAP_PRECHARGE_PERIODS: u16 =
    (BOOTSTRAP_PRECHARGE_NS as u64 * PWM_HZ as u64).div_ceil(1_000_000_000) as u16;

/// The fastest the encoder turns before the over-speed trip, increments per second.
const MAX_COUNTS_PER_S: u32 = (SERVO.protection.over_speed_rpm / 60.0) as u32 * COUNTS_PER_REV;
/// The shortest time between two encoder edges the input filter must pass, ns: half the edge
/// spacing at the over-speed trip (A/B phase error of the encoder and the cable's skew).
pub const ENCODER_SHORTEST_PULSE_NS: u32 = 1_000_000_000 / MAX_COUNTS_PER_S / 2;

/// ADC resolution, bits.
const ADC_BITS: u32 = 12;
/// ADC reference, V.
const VREF_V: f32 = 3.3;

/// The analog front end.
pub const FRONT_END: AnalogFrontEnd = AnalogFrontEnd {
    shunts: Shunts::Two,
    current: LinearScale::current_amplifier(VREF_V, ADC_BITS, 0.002, 16.0, 1.65),
    bus: LinearScale::divider(VREF_V, ADC_BITS, 300_000.0, 10_000.0),
    temperature: LinearScale::linear_sensor(VREF_V, ADC_BITS, 0.5, 0.010),
};

/// Shortest sampling time of a current amplifier's output (a low-impedance op-amp output with
/// an RC filter of ≈ 20 ns), ns.
pub const CURRENT_SAMPLE_NS: u32 = 100;
/// Shortest sampling time of the bus divider and the temperature sensor (source impedances of
/// ≈ 10 kΩ with a filter capacitor), ns.
pub const SLOW_SAMPLE_NS: u32 = 1_000;

const _: () = {
    assert!(PDI_SPI_CLOCK_HZ == 21_250_000);
    // 200 ns dead time, 40 kHz: the values the settings below were checked with.
    assert!(DEAD_TIME_NS == 200);
    assert!(PWM_HZ == 40_000);
    // The worked example of stm32g4-settings: 40 kHz from 170 MHz.
    assert!(PWM_PERIOD.prescaler == 0 && PWM_PERIOD.auto_reload == 2125);
    // 100 µs at 40 kHz: four periods.
    assert!(BOOTSTRAP_PRECHARGE_PERIODS == 4);
    // 5400 rpm × 10,000 / 60 = 900,000 increments/s: 1.11 µs between edges.
    assert!(ENCODER_SHORTEST_PULSE_NS == 555);
};
