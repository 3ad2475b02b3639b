//! What the drive knows about a profile beyond its object dictionary: where the CiA402
//! variables live in the OD RAM, and the profile's error code for every motor fault. od-gen
//! generates one [`DriveProfile`] per profile file (`crate::profiles`).

pub use cia402::faults::FaultReport;
pub use cia402::units::RatioRange;
use cia402::units::{Ratio, Scale};
use ethercat_slave::mailbox::emcy;
use ethercat_slave::od::Profile;

use crate::adjust::ServiceSpec;
use crate::motor::MotorFault;

/// OD RAM offsets of the variables the generic application reads and writes, by role. A role the
/// profile does not have is `None`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AppVars {
    /// 6040h controlword (u16).
    pub controlword: Option<u16>,
    /// 6041h statusword (u16).
    pub statusword: Option<u16>,
    /// 6060h modes of operation (i8).
    pub modes_of_operation: Option<u16>,
    /// 6061h modes of operation display (i8).
    pub modes_of_operation_display: Option<u16>,
    /// 607Ah target position (i32).
    pub target_position: Option<u16>,
    /// 6064h position actual value (i32).
    pub position_actual_value: Option<u16>,
    /// 603Fh error code (u16).
    pub error_code: Option<u16>,
    /// 60FFh target velocity (i32).
    pub target_velocity: Option<u16>,
    /// 6071h target torque (i16, ‰ of the rated torque).
    pub target_torque: Option<u16>,
    /// 606Ch velocity actual value (i32).
    pub velocity_actual_value: Option<u16>,
    /// 6077h torque actual value (i16, ‰ of the rated torque).
    pub torque_actual_value: Option<u16>,
    /// 6076h motor rated torque (u32, mN·m).
    pub motor_rated_torque: Option<u16>,
    /// Commissioned phase resistance (u32, µΩ; 0 = not commissioned).
    pub motor_resistance: Option<u16>,
    /// Commissioned d-axis inductance (u32, nH; 0 = not commissioned).
    pub motor_ld: Option<u16>,
    /// Commissioned q-axis inductance (u32, nH; 0 = not commissioned).
    pub motor_lq: Option<u16>,
    /// Commissioned rotor + load inertia (u32, g·mm²; 0 = not commissioned).
    pub motor_inertia: Option<u16>,
    /// 605Ah quick stop option code (i16).
    pub quick_stop_option_code: Option<u16>,
    /// 605Bh shutdown option code (i16).
    pub shutdown_option_code: Option<u16>,
    /// 605Ch disable operation option code (i16).
    pub disable_operation_option_code: Option<u16>,
    /// 605Dh halt option code (i16).
    pub halt_option_code: Option<u16>,
    /// 605Eh fault reaction option code (i16).
    pub fault_reaction_option_code: Option<u16>,
    /// 6084h profile deceleration (u32, acceleration units).
    pub profile_deceleration: Option<u16>,
    /// 6085h quick stop deceleration (u32, acceleration units).
    pub quick_stop_deceleration: Option<u16>,
    /// 6081h profile velocity (u32, velocity units).
    pub profile_velocity: Option<u16>,
    /// 6083h profile acceleration (u32, acceleration units).
    pub profile_acceleration: Option<u16>,
    /// 607Fh max profile velocity (u32, velocity units).
    pub max_profile_velocity: Option<u16>,
    /// 6087h torque slope (u32, ‰ of the rated torque per second).
    pub torque_slope: Option<u16>,
    /// 6067h position window (u32, position units).
    pub position_window: Option<u16>,
    /// 6068h position window time (u16, ms).
    pub position_window_time: Option<u16>,
    /// 606Dh velocity window (u16, velocity units).
    pub velocity_window: Option<u16>,
    /// 606Eh velocity window time (u16, ms).
    pub velocity_window_time: Option<u16>,
    /// 606Fh velocity threshold (u16, velocity units).
    pub velocity_threshold: Option<u16>,
    /// 6070h velocity threshold time (u16, ms).
    pub velocity_threshold_time: Option<u16>,
    /// 6062h position demand value (i32, position units).
    pub position_demand_value: Option<u16>,
    /// 606Bh velocity demand value (i32, velocity units).
    pub velocity_demand_value: Option<u16>,
    /// 6074h torque demand (i16, ‰ of the rated torque).
    pub torque_demand: Option<u16>,
    /// 6098h homing method (i8).
    pub homing_method: Option<u16>,
    /// 6099h:01 speed during search for switch (u32, velocity units).
    pub homing_speed_switch: Option<u16>,
    /// 6099h:02 speed during search for zero (u32, velocity units).
    pub homing_speed_zero: Option<u16>,
    /// 609Ah homing acceleration (u32, acceleration units).
    pub homing_acceleration: Option<u16>,
    /// 607Ch home offset (i32, position units).
    pub home_offset: Option<u16>,
    /// 60B8h touch probe function (u16).
    pub touch_probe_function: Option<u16>,
    /// 60B9h touch probe status (u16).
    pub touch_probe_status: Option<u16>,
    /// 60BAh touch probe 1 positive edge position (i32, position units).
    pub touch_probe_1_positive: Option<u16>,
    /// 60BBh touch probe 1 negative edge position (i32, position units).
    pub touch_probe_1_negative: Option<u16>,
    /// 60BCh touch probe 2 positive edge position (i32, position units).
    pub touch_probe_2_positive: Option<u16>,
    /// 60BDh touch probe 2 negative edge position (i32, position units).
    pub touch_probe_2_negative: Option<u16>,
    /// 60D5h touch probe 1 positive edge counter (u16).
    pub touch_probe_1_positive_count: Option<u16>,
    /// 60D6h touch probe 1 negative edge counter (u16).
    pub touch_probe_1_negative_count: Option<u16>,
    /// 60D7h touch probe 2 positive edge counter (u16).
    pub touch_probe_2_positive_count: Option<u16>,
    /// 60D8h touch probe 2 negative edge counter (u16).
    pub touch_probe_2_negative_count: Option<u16>,
    /// 6065h following error window (u32, position units).
    pub following_error_window: Option<u16>,
    /// 6066h following error time out (u16, ms).
    pub following_error_timeout: Option<u16>,
    /// 607Dh:01 min position limit (i32, position units).
    pub software_position_limit_min: Option<u16>,
    /// 607Dh:02 max position limit (i32, position units).
    pub software_position_limit_max: Option<u16>,
    /// 60FDh digital inputs (u32).
    pub digital_inputs: Option<u16>,
    /// 6072h max torque (u16, ‰ of the rated torque).
    pub max_torque: Option<u16>,
    /// 60E0h positive torque limit value (u16, ‰ of the rated torque).
    pub positive_torque_limit: Option<u16>,
    /// 60E1h negative torque limit value (u16, ‰ of the rated torque).
    pub negative_torque_limit: Option<u16>,
    /// 60B0h position offset (i32, position units).
    pub position_offset: Option<u16>,
    /// 60B1h velocity offset (i32, velocity units).
    pub velocity_offset: Option<u16>,
    /// 60B2h torque offset (i16, ‰ of the rated torque).
    pub torque_offset: Option<u16>,
    /// 6502h supported drive modes (u32).
    pub supported_drive_modes: Option<u16>,
    /// 60C1h:01 interpolation data record (i32, position units).
    pub interpolation_data: Option<u16>,
    /// 60C2h:01 interpolation time period value (u8).
    pub interpolation_time_period: Option<u16>,
    /// 60C2h:02 interpolation time index (i8).
    pub interpolation_time_index: Option<u16>,
    /// 607Eh polarity (u8).
    pub polarity: Option<u16>,
    /// 60FEh:01 physical outputs (u32).
    pub digital_outputs: Option<u16>,
    /// 60FEh:02 bit mask (u32).
    pub digital_outputs_mask: Option<u16>,
    /// 6080h max motor speed (u32, velocity units).
    pub max_motor_speed: Option<u16>,
    /// The profile's homing time limit (u16, ms; 0 = none), e.g. the RSE's 2006h:03 (P03.45).
    pub homing_timeout: Option<u16>,
    /// The command that makes the unit factors take effect (u32; the Σ-V-SD's 2300h): with it
    /// the factors are read at power-on and on its command, not every cycle.
    pub units_apply: Option<u16>,
    /// Increments per position unit (607Ah, 6064h): the profile's `[units] position`.
    pub position_factor: Factor,
    /// Increments/s per velocity unit (60FFh, 606Ch): the profile's `[units] velocity`.
    pub velocity_factor: Factor,
    /// What the acceleration objects (6083h–6085h, 609Ah) count: `[units] acceleration`.
    pub acceleration_unit: AccelerationUnit,
    /// Increments/s per unit of the velocity window 606Dh and threshold 606Fh:
    /// `[units] velocity_window` (the velocity factor unless the profile counts them apart,
    /// e.g. in whole rpm).
    pub velocity_window_factor: Factor,
    /// ‰ of the rated torque 6076h per unit of the torque objects (6071h, 6072h, 6074h,
    /// 6077h, 6087h, 60B2h, 60E0h, 60E1h): `[units] torque` (1, CiA402's 0.1 %, unless the
    /// profile has a torque unit, e.g. the Σ-V-SD's 2304h).
    pub torque_factor: Factor,
}

/// What an acceleration object (6083h–6085h, 609Ah) counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AccelerationUnit {
    /// The velocity unit per second (CiA402's default).
    VelocityPerSecond,
    /// Increments/s² per unit (e.g. the Σ-V-SD's 2303h × 10⁴).
    Factor(Factor),
    /// The time in ms from 0 to this many rpm (the SDV3-E: "ms from 0 rpm to 2000 rpm"); a
    /// smaller value is a steeper ramp, 0 the steepest the drive can do.
    MsToRpm(u32),
}

/// ms in a second, s in a minute.
const MS_PER_S: f32 = 1_000.0;
const S_PER_MIN: f32 = 60.0;

/// How an acceleration object's value converts at a moment (its factors read).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AccelerationRatio {
    /// Increments/s² per unit.
    PerUnit(Scale),
    /// The value is the time in ms to reach this speed (increments/s) from rest.
    MsToSpeed(f32),
}

impl AccelerationRatio {
    /// An acceleration object's `value` in increments/s² (a time of 0 ms reads as 1 ms).
    pub fn to_internal(self, value: u32) -> f32 {
        match self {
            Self::PerUnit(r) => r.velocity_to_internal(value as f32),
            Self::MsToSpeed(speed) => speed * MS_PER_S / value.max(1) as f32,
        }
    }
}

impl AccelerationUnit {
    /// The conversion now: with the profile's velocity factor `velocity` (for
    /// [`Self::VelocityPerSecond`]), the factor's objects in `ram` and the encoder's
    /// `counts_per_rev`.
    pub fn ratio(&self, ram: &[u8], counts_per_rev: u32, velocity: Scale) -> AccelerationRatio {
        match self {
            Self::VelocityPerSecond => AccelerationRatio::PerUnit(velocity),
            Self::Factor(f) => AccelerationRatio::PerUnit(f.ratio(ram, counts_per_rev).scale()),
            Self::MsToRpm(rpm) => {
                AccelerationRatio::MsToSpeed(*rpm as f32 / S_PER_MIN * counts_per_rev as f32)
            }
        }
    }

    /// An acceleration object's `value` in increments/s², with the profile's velocity factor
    /// `velocity` (for [`Self::VelocityPerSecond`]) and the encoder's `counts_per_rev`. For
    /// [`Self::MsToRpm`], 0 ms reads as 1 ms.
    pub fn to_internal(&self, value: u32, ram: &[u8], counts_per_rev: u32, velocity: Scale) -> f32 {
        self.ratio(ram, counts_per_rev, velocity).to_internal(value)
    }
}

/// The unit conversions of one axis at a moment: the `[units]` factors with their objects read.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UnitRatios {
    /// Increments per position unit.
    pub position: Ratio,
    /// Increments/s per velocity unit.
    pub velocity: Scale,
    /// The acceleration objects' conversion.
    pub acceleration: AccelerationRatio,
    /// Increments/s per unit of 606Dh/606Fh.
    pub velocity_window: Scale,
    /// ‰ of the rated torque per torque unit.
    pub torque: Scale,
}

/// Whether two arrays of words are equal, compared word by word: a derived `==` of an array
/// becomes the byte-wise library comparison (some 50 instructions for 36 bytes on the
/// Cortex-M4), too slow for a check that runs every cycle.
pub(crate) fn words_equal<const N: usize>(a: &[u32; N], b: &[u32; N]) -> bool {
    a.iter()
        .zip(b.iter())
        .fold(0, |differ, (x, y)| differ | (x ^ y))
        == 0
}

impl Operand {
    /// The OD RAM entry (offset, length) the value is read from; `None` for a constant or the
    /// encoder's resolution.
    pub const fn object(&self) -> Option<(u16, u8)> {
        match self {
            Self::Ram { at, len } => Some((*at, *len)),
            Self::Const(_) | Self::CountsPerRev => None,
        }
    }
}

impl Factor {
    /// The OD RAM entries of the numerator and denominator.
    const fn objects(&self) -> [Option<(u16, u8)>; 2] {
        [self.numerator.object(), self.denominator.object()]
    }
}

impl AppVars {
    /// The OD RAM entries (offset, length) the unit factors read (e.g. 6091h:01/02): the
    /// conversions change only when one of them does.
    pub const fn unit_factor_objects(&self) -> [Option<(u16, u8)>; 10] {
        let [p0, p1] = self.position_factor.objects();
        let [v0, v1] = self.velocity_factor.objects();
        let [a0, a1] = match &self.acceleration_unit {
            AccelerationUnit::Factor(f) => f.objects(),
            AccelerationUnit::VelocityPerSecond | AccelerationUnit::MsToRpm(_) => [None, None],
        };
        let [w0, w1] = self.velocity_window_factor.objects();
        let [t0, t1] = self.torque_factor.objects();
        [p0, p1, v0, v1, a0, a1, w0, w1, t0, t1]
    }

    /// The axis' unit conversions from the factors' objects in `ram` now, with the encoder's
    /// `counts_per_rev`.
    pub fn unit_ratios(&self, ram: &[u8], counts_per_rev: u32) -> UnitRatios {
        let velocity = self.velocity_factor.ratio(ram, counts_per_rev).scale();
        UnitRatios {
            position: self.position_factor.ratio(ram, counts_per_rev),
            velocity,
            acceleration: self.acceleration_unit.ratio(ram, counts_per_rev, velocity),
            velocity_window: self
                .velocity_window_factor
                .ratio(ram, counts_per_rev)
                .scale(),
            torque: self.torque_factor.ratio(ram, counts_per_rev).scale(),
        }
    }
}

/// One side of a unit factor: a constant, or an unsigned object entry in the OD RAM (e.g.
/// 6091h:01), read again whenever it is written (an SDO download, or every cycle where the RxPDO
/// maps it: `drive::settings`) so that a master's write takes effect at once.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Operand {
    /// A fixed value.
    Const(u32),
    /// An unsigned little-endian entry of `len` (1..=4) bytes at OD RAM offset `at`.
    Ram {
        /// OD RAM offset.
        at: u16,
        /// Byte length.
        len: u8,
    },
    /// The motor encoder's increments per revolution (from the axis; e.g. a velocity in rpm).
    CountsPerRev,
}

impl Operand {
    /// Writes `value` to an OD RAM entry, saturated to its length (nothing for a constant or
    /// an entry outside the RAM).
    pub fn write(self, ram: &mut [u8], value: u32) {
        if let Self::Ram { at, len } = self {
            let len = len.min(4);
            // len ≤ 4: the shift is 0..=32 bits (32: checked_shr gives None, a 0-byte entry).
            let max = 4u32
                .checked_sub(u32::from(len))
                .and_then(|short| u32::MAX.checked_shr(short.saturating_mul(8)))
                .unwrap_or(0);
            let start = usize::from(at);
            if let Some(dst) = ram.get_mut(start..start.saturating_add(usize::from(len))) {
                for (d, s) in dst.iter_mut().zip(value.min(max).to_le_bytes()) {
                    *d = s;
                }
            }
        }
    }

    /// The value; an entry outside the RAM reads 0, an unknown encoder resolution too (which
    /// [`Ratio::new`] turns into 1:1).
    pub fn value(self, ram: &[u8], counts_per_rev: u32) -> u32 {
        match self {
            Self::Const(v) => v,
            Self::CountsPerRev => counts_per_rev,
            Self::Ram { at, len } => {
                let start = usize::from(at);
                let bytes = ram.get(start..start.saturating_add(usize::from(len.min(4))));
                bytes.map_or(0, |b| {
                    b.iter()
                        .rev()
                        .fold(0u32, |acc, &byte| acc << 8 | u32::from(byte))
                })
            }
        }
    }
}

/// internal = value × numerator / denominator × scale (profile `[units]`, see od-gen/README.md).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Factor {
    /// Numerator.
    pub numerator: Operand,
    /// Denominator.
    pub denominator: Operand,
    /// A constant rational factor on top (e.g. 1/600 for 0.1 rpm from increments per
    /// revolution), `(numerator, denominator)`.
    pub scale: (u32, u32),
}

impl Factor {
    /// 1:1.
    pub const ONE: Self = Self {
        numerator: Operand::Const(1),
        denominator: Operand::Const(1),
        scale: (1, 1),
    };

    /// The ratio with the current values of its entries and the motor encoder's resolution.
    pub fn ratio(&self, ram: &[u8], counts_per_rev: u32) -> Ratio {
        Ratio::new(
            u64::from(self.numerator.value(ram, counts_per_rev)),
            u64::from(self.denominator.value(ram, counts_per_rev)),
        )
        .times(Ratio::new(u64::from(self.scale.0), u64::from(self.scale.1)))
    }
}

impl AppVars {
    /// No variables (od-gen fills in what the profile has: `AppVars { .., ..AppVars::NONE }`).
    pub const NONE: Self = Self {
        controlword: None,
        statusword: None,
        modes_of_operation: None,
        modes_of_operation_display: None,
        target_position: None,
        position_actual_value: None,
        error_code: None,
        target_velocity: None,
        target_torque: None,
        velocity_actual_value: None,
        torque_actual_value: None,
        motor_rated_torque: None,
        motor_resistance: None,
        motor_ld: None,
        motor_lq: None,
        motor_inertia: None,
        quick_stop_option_code: None,
        shutdown_option_code: None,
        disable_operation_option_code: None,
        halt_option_code: None,
        fault_reaction_option_code: None,
        profile_deceleration: None,
        quick_stop_deceleration: None,
        profile_velocity: None,
        profile_acceleration: None,
        max_profile_velocity: None,
        torque_slope: None,
        position_window: None,
        position_window_time: None,
        velocity_window: None,
        velocity_window_time: None,
        velocity_threshold: None,
        velocity_threshold_time: None,
        position_demand_value: None,
        velocity_demand_value: None,
        torque_demand: None,
        homing_method: None,
        homing_speed_switch: None,
        homing_speed_zero: None,
        homing_acceleration: None,
        home_offset: None,
        touch_probe_function: None,
        touch_probe_status: None,
        touch_probe_1_positive: None,
        touch_probe_1_negative: None,
        touch_probe_2_positive: None,
        touch_probe_2_negative: None,
        touch_probe_1_positive_count: None,
        touch_probe_1_negative_count: None,
        touch_probe_2_positive_count: None,
        touch_probe_2_negative_count: None,
        following_error_window: None,
        following_error_timeout: None,
        software_position_limit_min: None,
        software_position_limit_max: None,
        digital_inputs: None,
        max_torque: None,
        positive_torque_limit: None,
        negative_torque_limit: None,
        position_offset: None,
        velocity_offset: None,
        torque_offset: None,
        supported_drive_modes: None,
        interpolation_data: None,
        interpolation_time_period: None,
        interpolation_time_index: None,
        polarity: None,
        digital_outputs: None,
        digital_outputs_mask: None,
        max_motor_speed: None,
        homing_timeout: None,
        units_apply: None,
        position_factor: Factor::ONE,
        velocity_factor: Factor::ONE,
        acceleration_unit: AccelerationUnit::VelocityPerSecond,
        velocity_window_factor: Factor::ONE,
        torque_factor: Factor::ONE,
    };
}

/// A drive profile: the object dictionary the slave stack serves, plus the drive's bindings.
#[derive(Clone, Copy, Debug)]
pub struct DriveProfile {
    /// The object dictionary (identity, SM layout, objects, OD RAM defaults).
    pub od: Profile,
    /// Application variables by role, one set per axis (at least one, at most [`MAX_AXES`]): a
    /// further axis has its own copies of the objects (e.g. the Σ-V-SD's 68xxh).
    pub axes: &'static [AppVars],
    /// The CiA402 error code (603Fh, also the EMCY error code) of each internal motor fault,
    /// indexed by `MotorFault::code() - 1` (profile table `[motor_faults]`); read it with
    /// [`Self::motor_fault_code`].
    pub motor_faults: &'static [FaultReport; MOTOR_FAULT_COUNT],
    /// The EMCY byte (3–7) that carries the number of the axis (1, 2) a drive error belongs to
    /// (`[emcy] axis_number_byte`, the Σ-V-SD's byte 7).
    pub emcy_axis_number_byte: Option<u8>,
    /// The alarms (`[[alarm]]`: numbers, resettable) and the objects that show them
    /// (`[alarm_objects]`).
    pub alarms: crate::alarm_log::AlarmTable,
    /// The drive conditions reported as warnings (`[warnings]`, statusword bit 7), in order of
    /// precedence.
    pub warnings: &'static [crate::alarm_log::Warning],
    /// The profile's adjusting-service objects (`[[adjusting]]`; at most
    /// [`crate::drive::MAX_ADJUSTING_SERVICES`]).
    pub adjusting: &'static [ServiceSpec],
    /// Settings held both by a whole object and by two parameters that split it
    /// (`[[split_value]]`).
    pub split_values: &'static [SplitValue],
    /// CiA402 behaviour the manual adds (`[cia402]`).
    pub cia402: Cia402Rules,
}

/// CiA402 behaviour a manual adds to the standard (profile section `[cia402]`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Cia402Rules {
    /// Enable operation requested while no mode of operation is selected (6060h = 0): the
    /// drive refuses and raises this error (the SDV3-E's oPE, §5.2 9); `None`: it enables and
    /// holds the position.
    pub enable_without_mode_error: Option<FaultReport>,
    /// A change of 6060h while homing runs is refused and raises this error (the SDV3-E's oPE,
    /// §5.2 9); `None`: the new mode is taken.
    pub mode_change_while_homing_error: Option<FaultReport>,
    /// Shutdown (605Bh) and disable operation (605Ch) end in Switch On Disabled after their
    /// stop (the Σ-V-SD's option code texts) instead of CiA402's Ready to Switch On / Switched
    /// On.
    pub stops_end_switched_off: bool,
    /// Switched On needs the main power; losing it in Switched On, Operation Enabled or Quick
    /// Stop Active falls to Switch On Disabled (the Σ-V-SD, §4.7 *2-*4).
    pub switch_on_requires_main_power: bool,
    /// Profile position: controlword bit 6 set means an absolute target (the SDV3-E's and
    /// OSD-G-E's ABS/INC) where CiA402 has it mean relative.
    pub pp_bit6_absolute: bool,
    /// Profile position: controlword bit 9 "change on set-point" is honoured (false: ignored,
    /// GHA-E and RSE).
    pub pp_change_on_set_point: bool,
    /// Profile position: a set-point without bit 5 waits in a buffer of one while a move runs
    /// (false: no buffer, bit 12 stays set until the move ends; the RSE).
    pub pp_set_point_buffer: bool,
    /// The homing methods (6098h values) the drive runs, ascending.
    pub homing_methods: &'static [i8],
    /// `(vendor method, CiA402 method)`: vendor numbers that run a CiA402 method.
    pub homing_method_aliases: &'static [(i8, i8)],
    /// The touch probe's deviations (60B9h bits 6/7, probe 1 during homing).
    pub touch_probe: cia402::touch_probe::Rules,
    /// A following error beyond 6065h for longer than 6066h is a fault (false: statusword bit
    /// 13 only, the Σ-V-SD).
    pub following_error_fault: bool,
    /// 60FDh bit 0 is the positive and bit 1 the negative limit switch (the RSE).
    pub digital_inputs_limits_swapped: bool,
    /// 60FDh bit 3 (interlock, the enable input withholding operation) is not supported and
    /// stays 0 (every vendor profile: their manuals mark it "does not support", NA or
    /// reserved).
    pub digital_inputs_without_interlock: bool,
    /// 6065h = 0 switches the following-error check off (the GHA-E).
    pub following_error_zero_window_off: bool,
    /// The home offset 607Ch is added to every position object, not only set at the home
    /// (the GHA-E: 6064h = 6063h / ratio + 607Ch).
    pub home_offset_added: bool,
    /// With an absolute encoder, 607Ch as it is at power-on is added to every position object
    /// from power-on (the Σ-V-SD, §4.9 (1): "the home offset is added to the encoder absolute
    /// position (the position actual value) in power up phase").
    pub home_offset_added_absolute: bool,
    /// The 1010h subindexes after whose store the drive enters Operation Enabled only after a
    /// power-on (the Σ-V-SD's 1 and 4, §4.7).
    pub store_requires_power_cycle: &'static [u8],
    /// The probe inputs must be assigned to a physical input first (the SDV3-E's EXT1/EXT2).
    pub touch_probe_inputs: Option<ProbeInputAssignment>,
    /// In CSP and IP, a target that would move the demand this many increments per ms or
    /// faster is ignored (the demand stays) and statusword bit 11 set (the Σ-V-SD's
    /// over-interpolation-speed guard, 4194304 inc/ms).
    pub max_interpolation_speed: Option<u32>,
    /// A homing run that ends in a homing error also raises this alarm (the GHA-E's GOH, "no
    /// home signal found in the valid travel").
    pub homing_error_alarm: Option<FaultReport>,
    /// Where the profile shows the safe-torque-off input (the Σ-V-SD's HWBB).
    pub safe_torque_off: Option<SafeTorqueOffDisplay>,
    /// A statusword bit that shows the torque demand at its limit (the Σ-V-SD's bit 14 "torque
    /// limit active", 0 while active), beside CiA402's bit 11.
    pub torque_limit_statusword: Option<StatuswordFlag>,
    /// The parameter that, set to 1, makes CSP go on over a cycle without new outputs with the
    /// last target increment instead of holding the last target (the SDV3-E's P4.04 "data
    /// loss processing"); read at power-on.
    pub csp_extrapolation: Option<Operand>,
    /// Option codes 605Ah–605Eh the profile defines where CiA402 reserves them (the GHA-E's
    /// code 2 of 605Bh/605Ch: stop on 6085h), taken before CiA402's meanings.
    pub stop_codes: &'static [cia402::stop::VendorCode],
    /// The fault stop does not follow 605Eh: the object is accepted and ignored, and a fault
    /// disables the drive function at once (the GHA-E, §5.7.2).
    pub fault_reaction_ignored: bool,
    /// Statusword bits 10–13 of the modes whose manual table differs from CiA402's (the
    /// SDV3-E's speed zero on bit 11 and synchronisation on bit 12, the RSE's target reached
    /// in the cyclic modes).
    pub mode_statusword: &'static [cia402::mode_status::Override],
    /// A statusword bit showing that a homing run has completed since power-on, in every mode
    /// (the RSE's bit 15 "home found").
    pub home_found_statusword: Option<StatuswordFlag>,
    /// The option codes the drive works with where the profile has no object for them (the
    /// RSE's halt: controlword bit 8 "per 605Dh" without a 605Dh); `vendor` is unused.
    pub implied_option_codes: cia402::stop::OptionCodes,
    /// Quick stop, shutdown and disable operation disable the drive function at once in the
    /// torque modes, whatever their option codes (the Σ-V-SD, §6.4).
    pub torque_modes_stop_at_once: bool,
    /// Halt in the torque modes takes the torque demand to zero instead of decelerating the
    /// motor on a ramp (the Σ-V-SD, §6.4); the motor runs out under its load.
    pub torque_modes_halt_zero_torque: bool,
    /// The parameter that, set to 1, switches the software position limits 607Dh off (the
    /// SDV3-E's P2.25 "position command format" 1 = infinite length); read at power-on.
    pub software_limits_off: Option<Operand>,
    /// The software position limits act only once the position is referenced: after a homing
    /// run, or from power-on with an absolute encoder (the Σ-V-SD, §6.8 (2)).
    pub software_limits_need_reference: bool,
    /// 607Dh is relative to the machine home: a target is compared with 607Dh - 607Ch (the
    /// Σ-V-SD, §4.8 (2) "corrected by the home offset").
    pub software_limits_less_home_offset: bool,
    /// How a homing run may start where the manual adds to CiA402 (current-position methods
    /// while disabled or only at speed zero, a start while disabled as an error).
    pub homing: cia402::homing::Rules,
    /// A mode change into profile position or homing with controlword bit 4 already set
    /// starts the set-point or the run at once (the Σ-V-SD, §3.2 "Dynamic Mode Change");
    /// otherwise (CiA402) they wait for bit 4's next rising edge.
    pub mode_entry_starts: bool,
    /// The torque-reached parameters A, B, C in 0.1 % of the rated torque (the RSE's
    /// 2008h:0Ah-0Ch): the condition [`cia402::mode_status::Shows::TorqueReached`] sets above
    /// A + B and clears below A + C.
    pub torque_reached: Option<[Operand; 3]>,
    /// The ratios the unit factors may have when they take effect, and the error outside
    /// them (the Σ-V-SD's A.A20, §4.5 (3)-(5)).
    pub unit_ranges: Option<UnitRanges>,
}

/// The ranges of the unit factors' numerator/denominator (`[cia402.unit_ranges]`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct UnitRanges {
    /// Raised when a factor that takes effect is outside its range (the factors do not).
    pub error: FaultReport,
    /// [`AppVars::position_factor`]'s range.
    pub position: Option<RatioRange>,
    /// [`AppVars::velocity_factor`]'s range.
    pub velocity: Option<RatioRange>,
    /// The acceleration factor's range (its numerator/denominator, before its scale).
    pub acceleration: Option<RatioRange>,
    /// [`AppVars::torque_factor`]'s range (before its scale).
    pub torque: Option<RatioRange>,
}

/// A manufacturer-specific statusword bit (8, 14 or 15) that shows a condition, and its value
/// while the condition holds (the other value otherwise).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StatuswordFlag {
    /// The bit.
    pub bit: u8,
    /// Its value while the condition holds.
    pub while_active: bool,
}

impl StatuswordFlag {
    /// The statusword bits to set (`active`: the condition holds).
    pub fn bits(&self, active: bool) -> u16 {
        if active == self.while_active {
            1u16.checked_shl(u32::from(self.bit)).unwrap_or(0)
        } else {
            0
        }
    }
}

/// How a profile shows its safe-torque-off input (the Σ-V-SD's HWBB, §4.7 statusword bit 15,
/// §6.11 60FDh bits 24/25).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SafeTorqueOffDisplay {
    /// The statusword bit and its value while safe torque off holds (the Σ-V-SD's bit 15: "0:
    /// HWBB activated, 1: HWBB not activated").
    pub statusword: StatuswordFlag,
    /// The 60FDh bits of channel 1 and 2 (1 = closed; manufacturer-specific bits 16–31).
    pub digital_input_bits: [u8; 2],
}

impl SafeTorqueOffDisplay {
    /// The 60FDh bits of the channels (`true` = closed).
    pub fn digital_inputs(&self, channels_closed: [bool; 2]) -> u32 {
        self.digital_input_bits
            .iter()
            .zip(channels_closed)
            .filter(|(_, closed)| *closed)
            .fold(0, |bits, (&bit, _)| {
                bits | 1u32.checked_shl(u32::from(bit)).unwrap_or(0)
            })
    }
}

/// One setting that a whole object and two parameters hold: `whole` = `high` × `radix` + `low`
/// (the GHA-E's gear ratio: 6091h:01 = Pn-006 × 10000 + Pn-007, 6091h:02 = Pn-008 × 10000 +
/// Pn-009). The drive keeps them equal: the side a write changed sets the other; at power-on
/// the parts (saved at once) set the whole ([`SplitValue::reconcile`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SplitValue {
    /// The whole value (an OD RAM entry).
    pub whole: Operand,
    /// The high part.
    pub high: Operand,
    /// The low part (below `radix`).
    pub low: Operand,
    /// The factor of the high part (> 1).
    pub radix: u32,
}

impl SplitValue {
    /// The values `[whole, high, low]` after one check of `now` against what was `seen` last
    /// (`None` at power-on: the parts set the whole). The side that changed sets the other
    /// (the whole first, if both did); the whole saturates.
    pub fn reconcile(&self, now: [u32; 3], seen: Option<[u32; 3]>) -> [u32; 3] {
        let [whole, high, low] = now;
        let radix = self.radix.max(2);
        let from_parts = [high.saturating_mul(radix).saturating_add(low), high, low];
        match seen {
            None => from_parts,
            Some([seen_whole, _, _]) if whole != seen_whole => {
                // radix ≥ 2.
                [
                    whole,
                    whole.checked_div(radix).unwrap_or(0),
                    whole.checked_rem(radix).unwrap_or(0),
                ]
            }
            Some([_, seen_high, seen_low]) if high != seen_high || low != seen_low => from_parts,
            Some(_) => now,
        }
    }
}

/// A profile whose touch-probe inputs are functions a physical input must be assigned first
/// (the SDV3-E: EXT1/EXT2 are EI functions 40/41, on EI3–EI5 only, §7.12): a 60B8h write that
/// enables a probe on its input (source 0, an edge enabled) while no assignment parameter holds
/// the probe's function raises `unassigned_error` (the SDV3-E's Act).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ProbeInputAssignment {
    /// The parameters that hold an input's function (OD RAM entries).
    pub entries: &'static [Operand],
    /// The function of probe 1's and probe 2's input.
    pub functions: [u32; 2],
    /// The error raised.
    pub unassigned_error: FaultReport,
}

impl Cia402Rules {
    /// What homing method 6098h = `method` looks for in this profile: `None` for a method the
    /// profile does not run.
    pub fn homing_reference(&self, method: i8) -> Option<cia402::homing::Reference> {
        if self.homing_methods.binary_search(&method).is_err() {
            return None;
        }
        let cia402_method = self
            .homing_method_aliases
            .iter()
            .find(|(from, _)| *from == method)
            .map_or(method, |&(_, to)| to);
        cia402::homing::method(cia402_method)
    }

    /// The profile-position rules of [`cia402::profile_position`].
    pub const fn profile_position(&self) -> cia402::profile_position::Rules {
        cia402::profile_position::Rules {
            bit6_set_is_absolute: self.pp_bit6_absolute,
            no_change_on_set_point: !self.pp_change_on_set_point,
            no_buffer: !self.pp_set_point_buffer,
        }
    }
}

/// The most axes one drive runs ([`DriveProfile::axes`]).
pub const MAX_AXES: usize = 2;

/// Number of internal motor faults: the length of [`DriveProfile::motor_faults`].
pub const MOTOR_FAULT_COUNT: usize = MotorFault::ALL.len();

impl DriveProfile {
    /// The CiA402 error code (603Fh, EMCY) this profile maps `fault` to (CiA 301 generic error
    /// outside the table, which cannot happen while the table and [`MotorFault`] agree, as the
    /// generated code checks at compile time).
    pub fn motor_fault_code(&self, fault: MotorFault) -> u16 {
        motor_fault_report(self.motor_faults, fault).error_code
    }
}

/// What `table` (a profile's `[motor_faults]`) reports for `fault`; CiA 301 generic error
/// ([`emcy::code::GENERIC`]) for a fault outside it.
pub(crate) fn motor_fault_report(table: &[FaultReport], fault: MotorFault) -> FaultReport {
    cia402::faults::lookup(table, fault.code()).unwrap_or(FaultReport::code(emcy::code::GENERIC))
}

#[cfg(test)]
mod tests {
    use crate::motor::MotorFault;
    use crate::profiles::{self, standard};

    /// od-gen keeps its own copy of the fault names (it cannot depend on the firmware; the generated
    /// code also checks this at compile time): the
    /// generated list must be the firmware's, in code order, so that a profile's table is indexed
    /// by the fault it names.
    #[test]
    fn od_gen_fault_names_are_the_firmware_faults() {
        assert_eq!(profiles::MOTOR_FAULT_NAMES.len(), MotorFault::ALL.len());
        for (i, (fault, name)) in MotorFault::ALL
            .iter()
            .zip(profiles::MOTOR_FAULT_NAMES)
            .enumerate()
        {
            assert_eq!(usize::from(fault.code()), i + 1, "ALL is in code order");
            assert_eq!(fault.name(), name);
        }
    }

    /// The standard profile's codes, read through the profile: each fault gets the CiA402 code
    /// `od-gen/profiles/standard.toml` gives its name.
    #[test]
    fn standard_profile_maps_every_fault_to_its_cia402_code() {
        let expected = [
            (MotorFault::OverCurrent, 0x2320),
            (MotorFault::MotorOverload, 0x2350),
            (MotorFault::DriveOverload, 0x2310),
            (MotorFault::BusOverVoltage, 0x3210),
            (MotorFault::BusUnderVoltage, 0x3220),
            (MotorFault::OverSpeed, 0x8400),
            (MotorFault::EncoderSignalLoss, 0x7305),
            (MotorFault::EncoderJump, 0x7320),
            (MotorFault::EncoderCrc, 0x7300),
            (MotorFault::DriveOverTemperature, 0x4210),
            (MotorFault::MotorOverTemperature, 0x4310),
            (MotorFault::FollowingError, 0x8611),
            (MotorFault::CurrentOffset, 0x5210),
            (MotorFault::Alignment, 0x7122),
            (MotorFault::Identification, 0x6320),
        ];
        assert_eq!(expected.len(), MotorFault::ALL.len());
        let p = &standard::PROFILE;
        for (fault, code) in expected {
            assert_eq!(p.motor_fault_code(fault), code, "{}", fault.name());
        }
        for p in profiles::ALL {
            for fault in MotorFault::ALL {
                assert_ne!(p.motor_fault_code(fault), 0, "{}", fault.name());
            }
        }
    }

    /// Complete access reaches every object of every profile: a download keeps the object's
    /// RAM values to restore them on failure, and an upload stream (subindex 0 as 16 bits, then
    /// every entry) is built in the SDO server's buffer; both are of fixed size.
    #[test]
    fn every_object_fits_the_complete_access_buffers() {
        use ethercat_slave::mailbox::coe::complete_access::{SI0_STREAM_BITS, UNDO_CAPACITY};
        use ethercat_slave::mailbox::coe::SEGMENT_BUFFER_CAPACITY;
        use ethercat_slave::od::Value;
        for p in profiles::ALL {
            for o in p.od.objects {
                let ram: usize = o
                    .entries
                    .iter()
                    .filter(|e| matches!(e.value, Value::Ram(_)))
                    .map(|e| usize::from(e.bit_len).div_ceil(8))
                    .sum();
                assert!(
                    ram <= UNDO_CAPACITY,
                    "{} {:#06x}: {ram} bytes",
                    p.od.device.profile,
                    o.index
                );
                let stream_bits: usize = SI0_STREAM_BITS
                    + o.entries
                        .iter()
                        .skip(1)
                        .map(|e| usize::from(e.bit_len))
                        .sum::<usize>();
                assert!(
                    stream_bits.div_ceil(8) <= SEGMENT_BUFFER_CAPACITY,
                    "{} {:#06x}: a {stream_bits}-bit stream",
                    p.od.device.profile,
                    o.index
                );
            }
        }
    }

    #[test]
    fn factors_read_their_entries_every_time() {
        use super::{Factor, Operand};
        use cia402::units::Ratio;
        let mut ram = [0u8; 8];
        ram[0..4].copy_from_slice(&10_000u32.to_le_bytes());
        ram[4..6].copy_from_slice(&3u16.to_le_bytes());
        let f = Factor {
            numerator: Operand::Ram { at: 0, len: 4 },
            denominator: Operand::Ram { at: 4, len: 2 },
            scale: (1, 1),
        };
        assert_eq!(f.ratio(&ram, 0), Ratio::new(10_000, 3));
        ram[4] = 5;
        assert_eq!(
            f.ratio(&ram, 0),
            Ratio::new(10_000, 5),
            "a master's write counts at once"
        );
        let scaled = Factor {
            scale: (1, 600),
            ..f
        };
        assert_eq!(scaled.ratio(&ram, 0), Ratio::new(10_000, 3_000));
        // 0.1 rpm at 2^17 increments per revolution.
        let rpm = Factor {
            numerator: Operand::CountsPerRev,
            denominator: Operand::Const(600),
            scale: (1, 1),
        };
        assert_eq!(rpm.ratio(&ram, 1 << 17), Ratio::new(1 << 17, 600));
        // Outside the RAM, zero, or no encoder resolution: 1:1, never a division by zero.
        let outside = Factor {
            numerator: Operand::Ram { at: 7, len: 4 },
            ..Factor::ONE
        };
        assert_eq!(outside.ratio(&ram, 0), Ratio::ONE);
        assert_eq!(rpm.ratio(&ram, 0), Ratio::ONE);
        ram[4] = 0;
        ram[5] = 0;
        assert_eq!(f.ratio(&ram, 0), Ratio::ONE);
    }
}

#[cfg(test)]
mod homing_rules {
    use cia402::homing::{self, Reference};

    use crate::profiles;

    fn reference(profile: &str, method: i8) -> Option<Reference> {
        let p = profiles::by_name(profile).expect("profile");
        p.cia402.homing_reference(method)
    }

    #[test]
    fn a_profile_runs_the_homing_methods_its_manual_lists() {
        // The standard drive: every CiA402 method.
        assert_eq!(reference("standard", 3), homing::method(3));
        assert_eq!(reference("standard", 37), Some(Reference::Here));
        assert_eq!(reference("standard", 0), None);
        // Σ-V-SD §6.9: 3-6 and 19 are not supported, 7-14, 24, 28 are.
        assert_eq!(reference("sigma-v-sd", 3), None);
        assert_eq!(reference("sigma-v-sd", 19), None);
        assert_eq!(reference("sigma-v-sd", 24), homing::method(24));
        // RSE 7.11: no index-pulse methods.
        assert_eq!(reference("rse", 1), None);
        assert_eq!(reference("rse", 33), None);
        assert_eq!(reference("rse", 21), homing::method(21));
        // SDV3-E §7.6: 7 is "the same to way 3", 28 the same as 22; 36/37 (stopper) not run.
        assert_eq!(reference("sdv3-e", 7), homing::method(3));
        assert_eq!(reference("sdv3-e", 28), homing::method(22));
        assert_eq!(reference("sdv3-e", 37), None);
        assert_eq!(reference("sdv3-e", 35), Some(Reference::Here));
        // GHA-E §5.4.3: 35 is the current position, 37 is not listed.
        assert_eq!(reference("gha-e", 35), Some(Reference::Here));
        assert_eq!(reference("gha-e", 37), None);
    }
}

#[cfg(test)]
mod acceleration_units {
    use super::*;

    const CPR: u32 = 1 << 20;

    #[test]
    fn acceleration_objects_convert_in_the_profiles_unit() {
        let ram = [0u8; 8];
        // CiA402: the velocity unit per second; in 0.1 rpm, 600 units/s = 60 rpm/s = 1 rev/s².
        let tenth_rpm = Ratio::new(u64::from(CPR), 600).scale();
        assert_eq!(
            AccelerationUnit::VelocityPerSecond.to_internal(600, &ram, CPR, tenth_rpm),
            CPR as f32
        );
        // SDV3-E: 100 ms from 0 to 2000 rpm = 20 000 rpm/s = 333.3 rev/s².
        let sdv3 = AccelerationUnit::MsToRpm(2000);
        let expected = 2000.0 / 60.0 * CPR as f32 * 10.0;
        assert!((sdv3.to_internal(100, &ram, CPR, tenth_rpm) / expected - 1.0).abs() < 1e-6);
        assert_eq!(
            sdv3.to_internal(0, &ram, CPR, tenth_rpm),
            sdv3.to_internal(1, &ram, CPR, tenth_rpm),
            "0 ms reads as 1 ms"
        );
        // Σ-V-SD: 1 Acc. unit = N/D × 10^4 inc/s² (N/D = 1/1 by default).
        let sigma = AccelerationUnit::Factor(Factor {
            numerator: Operand::Const(1),
            denominator: Operand::Const(1),
            scale: (10_000, 1),
        });
        assert_eq!(sigma.to_internal(1000, &ram, CPR, tenth_rpm), 1e7);
    }
}

#[cfg(test)]
mod axis_vars {
    use ethercat_slave::od::Value;

    use super::AppVars;
    use crate::profiles;

    /// The OD RAM offset of entry `index:subindex` of profile `name`.
    fn ram_offset(name: &str, index: u16, subindex: u8) -> Option<u16> {
        let p = profiles::by_name(name)?;
        let o = p.od.objects.iter().find(|o| o.index == index)?;
        match o.entries.iter().find(|e| e.subindex == subindex)?.value {
            Value::Ram(at) => Some(at),
            _ => None,
        }
    }

    fn axes(name: &str) -> &'static [AppVars] {
        profiles::by_name(name).expect("profile").axes
    }

    /// Σ-V-SD §2.4: axis 2's CiA402 objects are axis 1's + 800h; §4.5 the user units + 400h.
    #[test]
    fn the_two_axis_servopack_binds_axis_2_to_the_68xxh_objects() {
        let [one, two] = axes("sigma-v-sd-2axis") else {
            panic!("two axes expected");
        };
        let cases = [
            (one.controlword, two.controlword, 0x6040, 0),
            (one.statusword, two.statusword, 0x6041, 0),
            (one.target_position, two.target_position, 0x607A, 0),
            (
                one.position_actual_value,
                two.position_actual_value,
                0x6064,
                0,
            ),
            (one.modes_of_operation, two.modes_of_operation, 0x6060, 0),
            (one.error_code, two.error_code, 0x603F, 0),
            (one.homing_method, two.homing_method, 0x6098, 0),
            (
                one.touch_probe_function,
                two.touch_probe_function,
                0x60B8,
                0,
            ),
        ];
        for (first, second, index, sub) in cases {
            assert_eq!(
                first,
                ram_offset("sigma-v-sd-2axis", index, sub),
                "{index:#06x}"
            );
            assert_eq!(
                second,
                ram_offset("sigma-v-sd-2axis", index + 0x800, sub),
                "{:#06x}",
                index + 0x800
            );
            assert_ne!(first, second);
        }
        // User units: 2301h:01 for axis 1, 2701h:01 for axis 2.
        let numerator = |v: &AppVars| match v.position_factor.numerator {
            super::Operand::Ram { at, .. } => Some(at),
            _ => None,
        };
        assert_eq!(numerator(one), ram_offset("sigma-v-sd-2axis", 0x2301, 1));
        assert_eq!(numerator(two), ram_offset("sigma-v-sd-2axis", 0x2701, 1));
    }

    #[test]
    fn one_axis_profiles_have_one_set_of_variables() {
        for p in profiles::ALL {
            let expected = if p.od.device.profile == "sigma-v-sd-2axis" {
                2
            } else {
                1
            };
            assert_eq!(p.axes.len(), expected, "{}", p.od.device.profile);
        }
    }
}

#[cfg(test)]
mod split_values {
    use super::{Operand, SplitValue};

    /// The GHA-E's 6091h:01 = Pn-006 × 10000 + Pn-007 (UDINT at 0, UINTs at 4 and 6).
    const GEAR: SplitValue = SplitValue {
        whole: Operand::Ram { at: 0, len: 4 },
        high: Operand::Ram { at: 4, len: 2 },
        low: Operand::Ram { at: 6, len: 2 },
        radix: 10_000,
    };

    #[test]
    fn the_side_that_changed_sets_the_other() {
        let seen = [131_072, 13, 1_072];
        // The whole written: the parts follow.
        assert_eq!(
            GEAR.reconcile([262_144, 13, 1_072], Some(seen)),
            [262_144, 26, 2_144]
        );
        // A part written: the whole follows.
        assert_eq!(
            GEAR.reconcile([131_072, 20, 1_072], Some(seen)),
            [201_072, 20, 1_072]
        );
        // Both: the whole wins.
        assert_eq!(GEAR.reconcile([50_000, 20, 0], Some(seen)), [50_000, 5, 0]);
        // Nothing: as it is.
        assert_eq!(GEAR.reconcile(seen, Some(seen)), seen);
        // Power-on: the parts set the whole; a huge product saturates.
        assert_eq!(GEAR.reconcile([1, 1, 0], None), [10_000, 1, 0]);
        assert_eq!(
            GEAR.reconcile([0, u32::MAX, 0], None),
            [u32::MAX, u32::MAX, 0]
        );
    }

    #[test]
    fn a_write_saturates_to_the_entry_and_stays_inside_the_ram() {
        let mut ram = [0u8; 8];
        GEAR.high.write(&mut ram, 70_000);
        assert_eq!(GEAR.high.value(&ram, 0), 65_535, "a UINT saturates");
        GEAR.whole.write(&mut ram, 0x0102_0304);
        assert_eq!(&ram[..4], &[4, 3, 2, 1]);
        Operand::Ram { at: 7, len: 4 }.write(&mut ram, 9);
        assert_eq!(ram[7], 0, "outside the RAM: nothing written");
        Operand::Const(5).write(&mut ram, 9);
    }
}
