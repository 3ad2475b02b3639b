//! The simulated board's axis hardware: the `hal` power, encoder and digital-input drivers,
//! backed by the plant ([`crate::plant`]).
//!
//! | type | `hal` trait | board part it plays |
//! |---|---|---|
//! | [`SimPowerStage`] | [`Inverter`] | PWM timer with shadow registers and the gate drivers |
//! | [`SimCurrentSense`] | [`CurrentSense`] | phase-current ADC: counts → A with the nominal gain and zero |
//! | [`SimBusSense`] | [`BusSense`] | bus-voltage ADC and the power-stage temperature sensor |
//! | [`SimEncoder`] | [`Encoder`] | encoder interface: 32-bit counter extension and index latch (incremental), frame decoding with its CRC (absolute) |
//! | [`SimInputs`] | [`DigitalInputs`] | limit and home switches, the motor's thermal switch |
//!
//! [`AxisIo`] holds one of each. Per PWM period: [`AxisIo::sample`] is the PWM-synchronous
//! trigger (the plant's [`Plant::sample`] latched into the sensing drivers, which the trait
//! methods then read, as a real board's ADC data registers and encoder latch), and
//! [`AxisIo::run_period`] runs the plant over the period with the power stage's active
//! registers and then loads its shadow registers (the update event). The true sensor offsets
//! stay unknown to the firmware, which calibrates them.

use hal::encoder::{Encoder, EncoderFault};
use hal::io::{DigitalInputs, DigitalOutputs, ProbeCapture, TouchProbe};
use hal::power::{BusSense, CurrentSense, Inverter, PhaseCurrents};

use crate::plant::{
    decode_serial_frame, EncoderParams, EncoderSample, Plant, PlantConfig, Sample, SensingParams,
    SerialFrameError,
};
use crate::servo::counts_per_rev;

/// What one set of PWM registers holds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PwmRegisters {
    /// Duties of phases a, b, c.
    pub duties: [f32; 3],
    /// Gate drivers on.
    pub gates: bool,
}

impl PwmRegisters {
    /// Gates off, all phases at 50 %.
    pub const OFF: Self = Self {
        duties: [0.5; 3],
        gates: false,
    };
}

/// The PWM timer and gate drivers: duties and enable go to shadow registers that become active
/// at the next period boundary; a disable acts on the present period at once. The break input
/// (a gate-driver fault or an over-current comparator, [`SimPowerStage::set_break_input`])
/// switches the gates off in hardware at once and holds them off while it is active, as an
/// STM32 advanced timer's BKIN does (MOE cleared, and not settable while the break is there);
/// the firmware learns of it through [`Inverter::take_hardware_trip`].
#[derive(Clone, Copy, Debug)]
pub struct SimPowerStage {
    pwm_hz: u32,
    active: PwmRegisters,
    shadow: PwmRegisters,
    /// The break input is active.
    break_input: bool,
    /// A break not yet reported through `take_hardware_trip`.
    trip_unreported: bool,
}

impl SimPowerStage {
    /// A power stage at its power-on state (gates off, 50 %) switching at `pwm_hz`.
    pub fn new(pwm_hz: f64) -> Self {
        Self {
            pwm_hz: pwm_hz.round() as u32,
            active: PwmRegisters::OFF,
            shadow: PwmRegisters::OFF,
            break_input: false,
            trip_unreported: false,
        }
    }

    /// Back to the power-on state (a reset of the board; the break input keeps its level).
    pub fn reset(&mut self) {
        self.active = PwmRegisters::OFF;
        self.shadow = PwmRegisters::OFF;
        self.trip_unreported = false;
    }

    /// Drives the break input (`true` = active): the gates go off at once and stay off while
    /// it is active.
    pub fn set_break_input(&mut self, active: bool) {
        if active && !self.break_input {
            self.trip_unreported = true;
        }
        self.break_input = active;
        if active {
            self.active.gates = false;
            self.shadow.gates = false;
        }
    }

    /// The registers acting during the present period.
    pub fn active(&self) -> PwmRegisters {
        self.active
    }

    /// The registers that become active at the next period boundary.
    pub fn shadow(&self) -> PwmRegisters {
        self.shadow
    }

    /// Integrates `plant` over the present period with the active registers, then loads the
    /// shadow registers (the update event at the period boundary).
    pub fn run_period(&mut self, plant: &mut Plant) {
        plant.run_period(self.active.duties, self.active.gates);
        self.active = self.shadow;
        if self.break_input {
            // MOE cannot be set while the break is active.
            self.active.gates = false;
            self.shadow.gates = false;
        }
    }
}

impl Inverter for SimPowerStage {
    fn pwm_frequency_hz(&self) -> u32 {
        self.pwm_hz
    }

    fn set_duties(&mut self, a: f32, b: f32, c: f32) {
        self.shadow.duties = [a, b, c];
    }

    fn enable(&mut self) {
        self.shadow.gates = true;
    }

    fn disable(&mut self) {
        self.active.gates = false;
        self.shadow.gates = false;
    }

    fn is_enabled(&self) -> bool {
        self.shadow.gates
    }

    fn take_hardware_trip(&mut self) -> bool {
        core::mem::take(&mut self.trip_unreported)
    }
}

/// The phase-current ADC: the latched counts, converted with the nominal gain and zero.
#[derive(Clone, Copy, Debug)]
pub struct SimCurrentSense {
    amps_per_count: f64,
    zero_count: u16,
    counts: [u16; 3],
}

impl SimCurrentSense {
    /// The converter of `sensing`, reading zero counts until the first sample.
    pub fn new(sensing: &SensingParams) -> Self {
        Self {
            amps_per_count: sensing.amps_per_count,
            zero_count: sensing.zero_count,
            counts: [sensing.zero_count; 3],
        }
    }

    /// Latches a sample's ADC codes.
    pub fn latch(&mut self, sample: &Sample) {
        self.counts = sample.phase_current_counts;
    }

    fn amps(&self, count: u16) -> f32 {
        ((f64::from(count) - f64::from(self.zero_count)) * self.amps_per_count) as f32
    }
}

impl CurrentSense for SimCurrentSense {
    fn phase_currents(&mut self) -> PhaseCurrents {
        PhaseCurrents {
            a: self.amps(self.counts[0]),
            b: self.amps(self.counts[1]),
            c: self.amps(self.counts[2]),
        }
    }
}

/// The bus-voltage ADC and the power-stage temperature sensor.
#[derive(Clone, Copy, Debug)]
pub struct SimBusSense {
    volts_per_count: f64,
    counts: u16,
    temperature_c: f32,
}

impl SimBusSense {
    /// The converter of `sensing`, reading 0 V and 25 °C until the first sample.
    pub fn new(sensing: &SensingParams) -> Self {
        Self {
            volts_per_count: sensing.bus_volts_per_count,
            counts: 0,
            temperature_c: crate::plant::DEFAULT_DRIVE_TEMPERATURE_C as f32,
        }
    }

    /// Latches a sample's bus-voltage code and temperature.
    pub fn latch(&mut self, sample: &Sample) {
        self.counts = sample.bus_voltage_counts;
        self.temperature_c = sample.drive_temperature_c;
    }
}

impl BusSense for SimBusSense {
    fn bus_voltage(&mut self) -> f32 {
        (f64::from(self.counts) * self.volts_per_count) as f32
    }

    fn temperature(&mut self) -> f32 {
        self.temperature_c
    }
}

/// Extends a wrapping hardware position (32-bit counter, or a multi-turn value of `bits` bits)
/// to a 64-bit position, as the board's encoder driver does.
#[derive(Clone, Copy, Debug, Default)]
struct PositionExtender {
    last: Option<u64>,
    position: i64,
}

impl PositionExtender {
    /// Feeds the raw value (modulo 2^bits) and returns the extended position.
    fn update(&mut self, raw: u64, bits: u32) -> i64 {
        let modulus = 1u128 << bits;
        let position = match self.last {
            None => {
                // First value: interpret it as signed around zero.
                let half = (modulus / 2) as u64;
                if raw >= half {
                    raw as i64 - modulus as i64
                } else {
                    raw as i64
                }
            }
            Some(last) => {
                let delta = ((raw as u128 + modulus - last as u128) % modulus) as i64;
                let half = (modulus / 2) as i64;
                let delta = if delta >= half {
                    delta - modulus as i64
                } else {
                    delta
                };
                self.position + delta
            }
        };
        self.last = Some(raw);
        self.position = position;
        position
    }
}

/// The encoder interface: at each sample it extends the incremental counter (or decodes the
/// absolute frame and extends its multi-turn value) to a 64-bit position and latches the index.
#[derive(Clone, Copy, Debug)]
pub struct SimEncoder {
    params: EncoderParams,
    extender: PositionExtender,
    position: Result<i64, EncoderFault>,
    /// Position of the last index pulse not yet taken.
    index: Option<i64>,
}

impl SimEncoder {
    /// The interface of an encoder `params`, with no position until the first sample.
    pub fn new(params: EncoderParams) -> Self {
        Self {
            params,
            extender: PositionExtender::default(),
            position: Err(EncoderFault::SignalLoss),
            index: None,
        }
    }

    /// Back to the power-on state: the counter extension starts again from the next sample
    /// (the position the firmware sees restarts around the raw value).
    pub fn reset(&mut self) {
        *self = Self::new(self.params);
    }

    /// Latches and decodes a sample's encoder reading.
    pub fn latch(&mut self, sample: &Sample) {
        let previous = self.position;
        self.position = match (sample.encoder, self.params) {
            (
                EncoderSample::Incremental {
                    count,
                    signal_ok,
                    index_count,
                },
                _,
            ) => {
                if signal_ok {
                    let position = self.extender.update(u64::from(count), 32);
                    if let Some(at) = index_count {
                        // The counter value captured on Z, extended like the count itself.
                        let back = i64::from(at.wrapping_sub(count) as i32);
                        self.index = Some(position + back);
                    }
                    Ok(position)
                } else {
                    Err(EncoderFault::SignalLoss)
                }
            }
            (
                EncoderSample::Serial { frame, len },
                EncoderParams::Absolute {
                    single_turn_bits,
                    multi_turn_bits,
                    ..
                },
            ) => {
                let bytes = frame.get(..usize::from(len)).unwrap_or(&[]);
                match decode_serial_frame(bytes, single_turn_bits, multi_turn_bits) {
                    Ok(p) => {
                        let raw = (u64::from(p.multi_turn) << single_turn_bits)
                            | u64::from(p.single_turn);
                        let bits = u32::from(single_turn_bits) + u32::from(multi_turn_bits);
                        let position = self.extender.update(raw, bits);
                        if let Ok(before) = previous {
                            // The single-turn zero crossed since the last frame serves as
                            // the index.
                            let turn = |x: i64| x >> single_turn_bits;
                            if turn(before) != turn(position) {
                                let crossed = turn(position.max(before)) << single_turn_bits;
                                self.index = Some(crossed);
                            }
                        }
                        Ok(position)
                    }
                    Err(SerialFrameError::Crc) => Err(EncoderFault::Crc),
                    Err(_) => Err(EncoderFault::SignalLoss),
                }
            }
            (EncoderSample::Serial { .. }, EncoderParams::Incremental { .. }) => {
                Err(EncoderFault::SignalLoss)
            }
        };
    }
}

impl Encoder for SimEncoder {
    fn resolution(&self) -> u32 {
        counts_per_rev(&self.params)
    }

    fn position(&mut self) -> Result<i64, EncoderFault> {
        self.position
    }

    fn take_index(&mut self) -> Option<i64> {
        self.index.take()
    }
}

/// The digital outputs (60FEh layout: bit 0 the holding brake, DO1… from bit 16) as the board's
/// pins hold them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SimOutputs {
    levels: u32,
}

impl SimOutputs {
    /// The pins' levels (1 = on).
    pub fn levels(&self) -> u32 {
        self.levels
    }
}

impl DigitalOutputs for SimOutputs {
    fn set_outputs(&mut self, levels: u32) {
        self.levels = levels;
    }
}

/// The digital inputs: limit and home switches, the motor's thermal switch and the touch-probe
/// inputs with their edge times (a timer input capture on the board), as latched.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SimInputs {
    positive_limit: bool,
    negative_limit: bool,
    home: bool,
    motor_over_temperature: bool,
    probes: [ProbeCapture; 2],
    /// The safe-torque-off channels that are open (`false`, the default: closed).
    safe_torque_off_open: [bool; 2],
    /// The enable input withholds operation (`false`, the default: permitted).
    enable_withheld: bool,
}

impl SimInputs {
    /// Latches a sample's switch states; probe edges are timed relative to
    /// `position_at_s`, the plant time at which the sample's encoder position was taken.
    pub fn latch(&mut self, sample: &Sample, position_at_s: f64) {
        self.positive_limit = sample.limit_pos;
        self.negative_limit = sample.limit_neg;
        self.home = sample.home;
        self.motor_over_temperature = sample.motor_overtemp_input;
        self.safe_torque_off_open = sample.safe_torque_off_channels.map(|closed| !closed);
        self.enable_withheld = !sample.enable_input;
        self.probes = sample.probes.map(|p| ProbeCapture {
            active: p.active,
            edge_ns_before_position: p.last_edge_s.map(|t| {
                let ns = ((position_at_s - t) * 1e9).round();
                ns.clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i32
            }),
        });
    }
}

/// How long before the sample instant the encoder's position is taken, s.
fn encoder_sample_delay_s(encoder: &EncoderParams) -> f64 {
    match *encoder {
        EncoderParams::Absolute { sample_delay_s, .. } => sample_delay_s,
        EncoderParams::Incremental { .. } => 0.0,
    }
}

impl DigitalInputs for SimInputs {
    fn positive_limit(&mut self) -> bool {
        self.positive_limit
    }

    fn negative_limit(&mut self) -> bool {
        self.negative_limit
    }

    fn home_switch(&mut self) -> bool {
        self.home
    }

    fn motor_over_temperature(&mut self) -> bool {
        self.motor_over_temperature
    }

    fn touch_probe(&mut self, probe: TouchProbe) -> ProbeCapture {
        let [one, two] = self.probes;
        match probe {
            TouchProbe::One => one,
            TouchProbe::Two => two,
        }
    }

    fn safe_torque_off_channels(&mut self) -> [bool; 2] {
        self.safe_torque_off_open.map(|open| !open)
    }

    fn enable_input(&mut self) -> bool {
        !self.enable_withheld
    }
}

/// The axis hardware of the simulated board.
#[derive(Clone, Copy, Debug)]
pub struct AxisIo {
    /// PWM timer and gate drivers.
    pub power: SimPowerStage,
    /// Phase-current ADC.
    pub currents: SimCurrentSense,
    /// Bus-voltage ADC and temperature sensor.
    pub bus: SimBusSense,
    /// Encoder interface.
    pub encoder: SimEncoder,
    /// Digital inputs.
    pub inputs: SimInputs,
    /// Digital outputs.
    pub outputs: SimOutputs,
}

impl AxisIo {
    /// The hardware of a board driving a plant configured as `cfg`, at its power-on state.
    pub fn new(cfg: &PlantConfig) -> Self {
        Self {
            power: SimPowerStage::new(cfg.inverter.pwm_hz),
            currents: SimCurrentSense::new(&cfg.sensing),
            bus: SimBusSense::new(&cfg.sensing),
            encoder: SimEncoder::new(cfg.encoder),
            inputs: SimInputs::default(),
            outputs: SimOutputs::default(),
        }
    }

    /// Back to the power-on state (a reset of the board; the plant goes on).
    pub fn reset(&mut self) {
        self.power.reset();
        self.encoder.reset();
    }

    /// The PWM-synchronous sample at the present period boundary: ADC conversions, encoder
    /// latch and inputs, latched into the drivers.
    pub fn sample(&mut self, plant: &mut Plant) {
        let s = plant.sample();
        self.currents.latch(&s);
        self.bus.latch(&s);
        self.encoder.latch(&s);
        // The probe edges are timed against the instant the encoder position was taken (the
        // board's capture timer runs in step with its encoder sampling).
        let position_at_s = plant.time_s() - encoder_sample_delay_s(&plant.config().encoder);
        self.inputs.latch(&s, position_at_s);
    }

    /// Runs the present PWM period on `plant` ([`SimPowerStage::run_period`]).
    pub fn run_period(&mut self, plant: &mut Plant) {
        self.power.run_period(plant);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plant::SwitchParams;

    #[test]
    fn position_extender_follows_wraps_both_ways() {
        let mut e = PositionExtender::default();
        assert_eq!(e.update(u64::from(u32::MAX - 1), 32), -2);
        assert_eq!(e.update(3, 32), 3);
        assert_eq!(e.update(u64::from(u32::MAX), 32), -1);
        let mut m = PositionExtender::default();
        let bits = 20 + 16;
        let top = (1u64 << bits) - 5;
        assert_eq!(m.update(10, bits), 10);
        assert_eq!(m.update(top, bits), -5);
        assert_eq!(m.update(7, bits), 7);
    }

    #[test]
    fn duties_and_enable_wait_for_the_period_boundary_disable_does_not() {
        let mut p = SimPowerStage::new(40_000.0);
        assert_eq!(p.pwm_frequency_hz(), 40_000);
        p.set_duties(0.25, 0.5, 0.75);
        p.enable();
        assert!(p.is_enabled());
        assert_eq!(p.active(), PwmRegisters::OFF);
        let mut plant = Plant::new(PlantConfig::servo_400w()).expect("valid plant");
        p.run_period(&mut plant);
        let on = PwmRegisters {
            duties: [0.25, 0.5, 0.75],
            gates: true,
        };
        assert_eq!(p.active(), on);
        p.disable();
        assert!(!p.is_enabled());
        assert!(!p.active().gates);
        p.reset();
        assert_eq!(
            (p.active(), p.shadow()),
            (PwmRegisters::OFF, PwmRegisters::OFF)
        );
    }

    #[test]
    fn incremental_index_is_latched_until_taken() {
        let mut cfg = PlantConfig::servo_400w();
        cfg.encoder = EncoderParams::Incremental {
            counts_per_rev: 4_000,
            index_at_rad: 0.5,
        };
        let mut plant = Plant::new(cfg.clone()).expect("valid plant");
        let mut io = AxisIo::new(&cfg);
        assert_eq!(io.encoder.resolution(), 4_000);
        assert_eq!(io.encoder.position(), Err(EncoderFault::SignalLoss));
        io.sample(&mut plant);
        assert_eq!(io.encoder.position(), Ok(0));
        assert_eq!(io.encoder.take_index(), None);
        // Past the index at 0.5 rad: the counter value there, ⌊0.5 / 2π · 4000⌋ = 318.
        plant.set_driven_speed(Some(100.0));
        for _ in 0..400 {
            io.run_period(&mut plant);
            io.sample(&mut plant);
        }
        assert_eq!(io.encoder.take_index(), Some(318));
        assert_eq!(io.encoder.take_index(), None);
        let expected = plant.mech_angle_rad() / core::f64::consts::TAU * 4_000.0;
        let position = io.encoder.position().expect("signal") as f64;
        assert!(
            (position - expected).abs() <= 2.0,
            "{position} vs {expected}"
        );
    }

    #[test]
    fn absolute_encoder_reports_its_single_turn_zero_as_the_index() {
        let cfg = PlantConfig::servo_400w(); // 20-bit single turn
        let mut plant = Plant::new(cfg.clone()).expect("valid plant");
        let mut io = AxisIo::new(&cfg);
        io.sample(&mut plant);
        // Forward past one revolution, then back past it.
        for (speed, index) in [(300.0, 1 << 20), (-300.0, 1 << 20)] {
            plant.set_driven_speed(Some(speed));
            let mut seen = None;
            for _ in 0..1_000 {
                io.run_period(&mut plant);
                io.sample(&mut plant);
                seen = seen.or(io.encoder.take_index());
            }
            assert_eq!(seen, Some(index), "at {speed} rad/s");
        }
    }

    #[test]
    fn switches_and_sensing_read_the_latched_sample() {
        let mut cfg = PlantConfig::servo_400w();
        // At the start angle 0: negative limit and home actuated, positive limit not.
        cfg.switches = SwitchParams {
            limit_neg_rad: Some(0.1),
            limit_pos_rad: Some(0.2),
            home_rad: Some(0.0),
            home_end_rad: None,
            probes: [None; 2],
        };
        let mut plant = Plant::new(cfg.clone()).expect("valid plant");
        plant.set_motor_overtemp_input(true);
        plant.set_drive_temperature(61.0);
        let mut io = AxisIo::new(&cfg);
        io.sample(&mut plant);
        assert!(io.inputs.motor_over_temperature());
        assert!(!io.inputs.positive_limit());
        assert!(io.inputs.negative_limit());
        assert!(io.inputs.home_switch());
        assert_eq!(io.bus.temperature(), 61.0);
        assert!((io.bus.bus_voltage() - 48.0).abs() < 0.05);
        let i = io.currents.phase_currents();
        for x in [i.a, i.b, i.c] {
            assert!(x.abs() < 0.3, "{i:?}");
        }
        plant.set_motor_overtemp_input(false);
        assert!(
            io.inputs.motor_over_temperature(),
            "latched until the next sample"
        );
        io.sample(&mut plant);
        assert!(!io.inputs.motor_over_temperature());
    }
}
