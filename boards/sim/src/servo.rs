//! One simulated servo axis: the plant ([`crate::plant`]) wired to the firmware's control
//! interrupt ([`firmware::motor::axis::Axis`]) through what the real board does in between, the
//! `hal` drivers of [`crate::axis_io`]: ADC counts → amperes with the nominal gain and zero (the
//! true offsets stay unknown to the firmware, which calibrates them), the encoder interface
//! (32-bit counter extension, serial frame decoding with its CRC), the digital inputs, and the
//! PWM shadow registers (duties computed in period k take effect at the start of period k+1).
//!
//! Each PWM period runs as the board's PWM/ADC interrupt does: the sample through the `hal`
//! traits ([`Sample::read`]), [`Axis::control_step`], the output through the `hal` inverter
//! trait ([`Output::apply`]).
//!
//! The SYNC0 side is played by the caller: [`SimServo::publish`] once per bus cycle.

use firmware::motor::axis::{
    Axis, AxisCommand, AxisConfig, AxisConfigError, AxisFeedback, AxisLink, Output, Sample,
};
use firmware::motor::servo::{self, EncoderSpec, InverterSpec, MotorSpec, ServoSpec, SERVO_400W};
use firmware::motor::Duties;

use crate::axis_io::AxisIo;
use crate::plant::{EncoderParams, Plant, PlantConfig, PlantError};

pub use firmware::motor::servo::Tuning;

/// Increments per mechanical revolution of an encoder.
pub fn counts_per_rev(encoder: &EncoderParams) -> u32 {
    encoder_spec(encoder).counts_per_rev()
}

/// The firmware's description of the plant's encoder. Absolute encoders get their
/// commutation offset (0: the plant's encoder reads 0 where the electrical angle is 0);
/// incremental ones align at every enable.
fn encoder_spec(encoder: &EncoderParams) -> EncoderSpec {
    match *encoder {
        EncoderParams::Incremental { counts_per_rev, .. } => {
            EncoderSpec::Incremental { counts_per_rev }
        }
        EncoderParams::Absolute {
            single_turn_bits,
            multi_turn_bits,
            ..
        } => EncoderSpec::Absolute {
            single_turn_bits,
            multi_turn_bits,
            commutation_offset: Some(0),
        },
    }
}

/// The servo `plant` simulates, as the firmware describes it: the 48 V / 400 W reference
/// servo ([`SERVO_400W`]) with the plant's motor, load inertia, PWM frequency, dead time,
/// nominal bus voltage and encoder in place of the reference's.
pub fn servo_spec(plant: &PlantConfig) -> ServoSpec {
    let m = &plant.motor;
    ServoSpec {
        motor: MotorSpec {
            resistance_ohm: m.r_ohm,
            ld_h: m.ld_h,
            lq_h: m.lq_h,
            flux_wb: m.flux_wb,
            pole_pairs: m.pole_pairs,
            rotor_inertia_kgm2: m.rotor_inertia_kgm2,
            ..SERVO_400W.motor
        },
        load_inertia_kgm2: plant.mechanics.load_inertia_kgm2,
        encoder: encoder_spec(&plant.encoder),
        inverter: InverterSpec {
            pwm_hz: plant.inverter.pwm_hz,
            dead_time_s: plant.inverter.dead_time_s,
            bus_voltage_v: plant.inverter.bus_voltage_v,
            ..SERVO_400W.inverter
        },
        ..SERVO_400W
    }
}

/// The firmware configuration of an axis driving `plant`: motor data as commissioning found
/// it (the plant's nameplate values), gains from `tuning`, protections and calibration of the
/// 48 V / 400 W reference servo ([`SERVO_400W`], which [`PlantConfig::servo_400w`] simulates);
/// computed by the firmware's [`firmware::motor::servo::axis_config`] from [`servo_spec`].
pub fn axis_config(plant: &PlantConfig, tuning: &Tuning) -> AxisConfig {
    servo::axis_config(&servo_spec(plant), tuning)
}

/// Why a servo could not be built.
#[derive(Debug)]
pub enum ServoError {
    /// The plant configuration is invalid.
    Plant(PlantError),
    /// The firmware refused the axis configuration.
    Axis(AxisConfigError),
}

/// One axis of the simulated board.
pub struct SimServo {
    /// The motor, inverter and sensors.
    pub plant: Plant,
    /// The firmware's control interrupt.
    pub axis: Axis,
    /// The SYNC0 ↔ control-interrupt mailboxes. `'static` because on a board they are a
    /// `static` shared by two interrupts (and the slave's application keeps a reference);
    /// here each servo leaks one (a few hundred bytes per servo, for the life of the process).
    link: &'static AxisLink,
    io: AxisIo,
    last_sample: Option<Sample>,
    periods: u64,
    /// The MCU is stopped ([`SimServo::halt_firmware`]): no control interrupt runs.
    halted: bool,
}

impl SimServo {
    /// A servo from a plant and an axis configuration.
    pub fn new(plant: PlantConfig, axis: AxisConfig) -> Result<Self, ServoError> {
        let io = AxisIo::new(&plant);
        Ok(Self {
            plant: Plant::new(plant).map_err(ServoError::Plant)?,
            axis: Axis::new(axis).map_err(ServoError::Axis)?,
            // SAFETY: the simulation runs the SYNC0 side (`publish`, `feedback`, or the slave's
            // application holding `link()`) and the control interrupt (`period`) on one thread,
            // one after the other: they never overlap. `AxisLink` is not `Send`-restricted, but
            // the simulated drive that owns this servo is driven from one thread at a time.
            link: Box::leak(Box::new(unsafe { AxisLink::new() })),
            io,
            last_sample: None,
            periods: 0,
            halted: false,
        })
    }

    /// Restarts the firmware side (a power cycle of the board): a new axis in its power-on
    /// state with a new link; the plant (the motor's physical state) goes on.
    pub fn restart_firmware(&mut self) {
        let cfg = *self.axis.config();
        if let Ok(axis) = Axis::new(cfg) {
            self.axis = axis;
        }
        // SAFETY: as in `new`.
        self.link = Box::leak(Box::new(unsafe { AxisLink::new() }));
        // The power stage and the encoder interface restart too.
        self.io.reset();
        self.halted = false;
    }

    /// The MCU stops (held in reset, or crashed): the control interrupt no longer runs and the
    /// timer's outputs are at their reset state, so the gate driver is off and the motor
    /// coasts; the plant goes on. [`Self::restart_firmware`] starts it again.
    pub fn halt_firmware(&mut self) {
        self.io.reset();
        self.halted = true;
    }

    /// The PWM period, ns.
    pub fn period_ns(&self) -> u64 {
        (self.plant.period_s() * 1e9).round() as u64
    }

    /// Runs PWM periods until the plant's time reaches `now_ns` (the boards's clock).
    pub fn advance_to(&mut self, now_ns: u64) {
        let period = self.period_ns().max(1);
        while (self.periods + 1) * period <= now_ns {
            self.period();
        }
    }

    /// The SYNC0 side: hands over a command.
    pub fn publish(&mut self, command: AxisCommand) {
        self.link.publish(command);
    }

    /// The encoder's increments per revolution.
    pub fn counts_per_rev(&self) -> u32 {
        counts_per_rev(&self.plant.config().encoder)
    }

    /// The encoder as the firmware describes it (for [`firmware::drive::Drive::attach_axis`]).
    pub fn encoder_spec(&self) -> EncoderSpec {
        encoder_spec(&self.plant.config().encoder)
    }

    /// The link, for the drive application ([`firmware::drive::Drive::attach_axis`]). Only
    /// one context may publish: a servo whose link is attached is commanded by the slave, not
    /// by [`SimServo::publish`].
    pub fn link(&self) -> &'static AxisLink {
        self.link
    }

    /// The SYNC0 side: the latest feedback.
    pub fn feedback(&self) -> AxisFeedback {
        self.link.feedback()
    }

    /// PWM periods run so far.
    pub fn periods(&self) -> u64 {
        self.periods
    }

    /// The sample the firmware saw in the last period.
    pub fn last_sample(&self) -> Option<&Sample> {
        self.last_sample.as_ref()
    }

    /// The output the firmware computed in the last period (applied in the next): the power
    /// stage's shadow registers.
    pub fn latched(&self) -> Output {
        let shadow = self.io.power.shadow();
        Output {
            gates: shadow.gates,
            duties: Duties {
                a: shadow.duties[0],
                b: shadow.duties[1],
                c: shadow.duties[2],
            },
        }
    }

    /// The board's axis hardware (the `hal` drivers between plant and firmware).
    pub fn io(&self) -> &AxisIo {
        &self.io
    }

    /// The board's axis hardware, to drive (e.g. the digital outputs the drive sets).
    pub fn io_mut(&mut self) -> &mut AxisIo {
        &mut self.io
    }

    /// One PWM period: sample at the boundary, run the control interrupt, integrate the plant
    /// over the period with the duties latched at its start. A gate-off decision acts at once
    /// (the board's disable is immediate), duties and a gate enable at the next period boundary.
    pub fn period(&mut self) {
        if self.halted {
            self.io.run_period(&mut self.plant);
            self.periods += 1;
            return;
        }
        let io = &mut self.io;
        io.sample(&mut self.plant);
        let sample = Sample::read(
            &mut io.power,
            &mut io.currents,
            &mut io.bus,
            &mut io.encoder,
            &mut io.inputs,
        );
        let next = self.axis.control_step(&sample, self.link);
        next.apply(&mut io.power);
        io.run_period(&mut self.plant);
        self.last_sample = Some(sample);
        self.periods += 1;
    }

    /// Runs `n` PWM periods.
    pub fn run_periods(&mut self, n: u64) {
        for _ in 0..n {
            self.period();
        }
    }
}
