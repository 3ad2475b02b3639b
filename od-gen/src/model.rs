//! The resolved, checked profile: what the three generators read.
//!
//! A [`Profile`] is built from a profile file by [`crate::resolve`]; it already contains the
//! objects od-gen derives (1008h, 1009h, 100Ah, 1018h, 16xxh/1Axxh, 1C00h, 1C12h, 1C13h, 1C32h,
//! 1C33h), so the Rust dictionary, the SII and the ESI all read the same data.

/// CoE data types (ETG.1000.6 Table 64), with the ESI base type names.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DataType {
    /// BOOL.
    Bool,
    /// SINT.
    Sint,
    /// INT.
    Int,
    /// INT24.
    Int24,
    /// DINT.
    Dint,
    /// LINT.
    Lint,
    /// USINT.
    Usint,
    /// UINT.
    Uint,
    /// UINT24.
    Uint24,
    /// UDINT.
    Udint,
    /// ULINT.
    Ulint,
    /// REAL.
    Real,
    /// LREAL.
    Lreal,
    /// VISIBLE_STRING (ESI `STRING(n)`).
    VisibleString,
    /// OCTET_STRING.
    OctetString,
    /// UNICODE_STRING.
    UnicodeString,
    /// DOMAIN: application data of variable length outside the OD RAM (`storage = "domain"`).
    Domain,
    /// BIT1..BIT8 (the number of bits).
    Bit(u8),
}

impl DataType {
    /// Parses an ESI base type name (also accepts `VISIBLE_STRING`).
    pub fn parse(name: &str) -> Option<Self> {
        Some(match name {
            "BOOL" => Self::Bool,
            "SINT" => Self::Sint,
            "INT" => Self::Int,
            "INT24" => Self::Int24,
            "DINT" => Self::Dint,
            "LINT" => Self::Lint,
            "USINT" => Self::Usint,
            "UINT" => Self::Uint,
            "UINT24" => Self::Uint24,
            "UDINT" => Self::Udint,
            "ULINT" => Self::Ulint,
            "REAL" => Self::Real,
            "LREAL" => Self::Lreal,
            "STRING" | "VISIBLE_STRING" => Self::VisibleString,
            "OCTET_STRING" => Self::OctetString,
            "UNICODE_STRING" => Self::UnicodeString,
            "DOMAIN" => Self::Domain,
            _ => {
                let n: u8 = name.strip_prefix("BIT")?.parse().ok()?;
                if (1..=8).contains(&n) {
                    Self::Bit(n)
                } else {
                    return None;
                }
            }
        })
    }

    /// The CoE data type code (ETG.1000.6 Table 64; SII PDO entry data type byte).
    pub fn code(self) -> u16 {
        match self {
            Self::Bool => 0x01,
            Self::Sint => 0x02,
            Self::Int => 0x03,
            Self::Dint => 0x04,
            Self::Usint => 0x05,
            Self::Uint => 0x06,
            Self::Udint => 0x07,
            Self::Real => 0x08,
            Self::VisibleString => 0x09,
            Self::OctetString => 0x0A,
            Self::UnicodeString => 0x0B,
            Self::Domain => 0x0F,
            Self::Int24 => 0x10,
            Self::Lreal => 0x11,
            Self::Lint => 0x15,
            Self::Uint24 => 0x16,
            Self::Ulint => 0x1B,
            Self::Bit(n) => 0x30 + u16::from(n) - 1,
        }
    }

    /// The variant name of `firmware::od::DataType`.
    pub fn rust_variant(self) -> String {
        match self {
            Self::Bool => "Boolean".into(),
            Self::Sint => "Integer8".into(),
            Self::Int => "Integer16".into(),
            Self::Int24 => "Integer24".into(),
            Self::Dint => "Integer32".into(),
            Self::Lint => "Integer64".into(),
            Self::Usint => "Unsigned8".into(),
            Self::Uint => "Unsigned16".into(),
            Self::Uint24 => "Unsigned24".into(),
            Self::Udint => "Unsigned32".into(),
            Self::Ulint => "Unsigned64".into(),
            Self::Real => "Real32".into(),
            Self::Lreal => "Real64".into(),
            Self::VisibleString => "VisibleString".into(),
            Self::OctetString => "OctetString".into(),
            Self::UnicodeString => "UnicodeString".into(),
            Self::Domain => "Domain".into(),
            Self::Bit(n) => format!("Bit{n}"),
        }
    }

    /// The ESI type name for an entry of `bits` bits (`STRING(n)` for strings).
    pub fn esi_name(self, bits: u16) -> String {
        match self {
            Self::Bool => "BOOL".into(),
            Self::Sint => "SINT".into(),
            Self::Int => "INT".into(),
            Self::Int24 => "INT24".into(),
            Self::Dint => "DINT".into(),
            Self::Lint => "LINT".into(),
            Self::Usint => "USINT".into(),
            Self::Uint => "UINT".into(),
            Self::Uint24 => "UINT24".into(),
            Self::Udint => "UDINT".into(),
            Self::Ulint => "ULINT".into(),
            Self::Real => "REAL".into(),
            Self::Lreal => "LREAL".into(),
            Self::VisibleString => format!("STRING({})", bits / 8),
            Self::OctetString => format!("OCTET_STRING({})", bits / 8),
            Self::UnicodeString => format!("UNICODE_STRING({})", bits / 16),
            Self::Domain => "DOMAIN".into(),
            Self::Bit(n) => format!("BIT{n}"),
        }
    }

    /// The bit size fixed by the type (`None` for strings, whose size the entry gives).
    pub fn fixed_bits(self) -> Option<u16> {
        Some(match self {
            Self::Bool => 1,
            Self::Sint | Self::Usint => 8,
            Self::Int | Self::Uint => 16,
            Self::Int24 | Self::Uint24 => 24,
            Self::Dint | Self::Udint | Self::Real => 32,
            Self::Lint | Self::Ulint | Self::Lreal => 64,
            Self::Bit(n) => u16::from(n),
            Self::VisibleString | Self::OctetString | Self::UnicodeString | Self::Domain => {
                return None
            }
        })
    }

    /// Whether values are text or bytes whose length the entry gives.
    pub fn is_string(self) -> bool {
        self.fixed_bits().is_none()
    }

    /// The integer range of the type (`None` for floats and strings).
    pub fn int_range(self) -> Option<(i128, i128)> {
        Some(match self {
            Self::Bool => (0, 1),
            Self::Bit(n) => (0, (1i128 << n) - 1),
            Self::Sint => (i8::MIN.into(), i8::MAX.into()),
            Self::Int => (i16::MIN.into(), i16::MAX.into()),
            Self::Int24 => (-(1 << 23), (1 << 23) - 1),
            Self::Dint => (i32::MIN.into(), i32::MAX.into()),
            Self::Lint => (i64::MIN.into(), i64::MAX.into()),
            Self::Usint => (0, u8::MAX.into()),
            Self::Uint => (0, u16::MAX.into()),
            Self::Uint24 => (0, (1 << 24) - 1),
            Self::Udint => (0, u32::MAX.into()),
            Self::Ulint => (0, u64::MAX.into()),
            Self::Real
            | Self::Lreal
            | Self::VisibleString
            | Self::OctetString
            | Self::UnicodeString
            | Self::Domain => return None,
        })
    }

    /// Whether the type is a signed integer.
    pub fn is_signed(self) -> bool {
        matches!(
            self,
            Self::Sint | Self::Int | Self::Int24 | Self::Dint | Self::Lint
        )
    }
}

/// Object code (ETG.1000.6 Table 63).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ObjectCode {
    /// VAR.
    Var,
    /// ARRAY.
    Array,
    /// RECORD.
    Record,
}

impl ObjectCode {
    /// The variant name of `firmware::od::ObjectCode`.
    pub fn rust_variant(self) -> &'static str {
        match self {
            Self::Var => "Var",
            Self::Array => "Array",
            Self::Record => "Record",
        }
    }
}

/// Access rights per state, same bits as `firmware::od::Access` (ETG.1000.6 Table 48 ObjAccess).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Access(pub u8);

impl Access {
    /// Read in PREOP, SAFEOP, OP.
    pub const READ_ALL: u8 = 0b0000_0111;
    /// Write in PREOP.
    pub const WRITE_PREOP: u8 = 1 << 3;
    /// Write in SAFEOP.
    pub const WRITE_SAFEOP: u8 = 1 << 4;
    /// Write in OP.
    pub const WRITE_OP: u8 = 1 << 5;
    /// Write in every state.
    pub const WRITE_ALL: u8 = Self::WRITE_PREOP | Self::WRITE_SAFEOP | Self::WRITE_OP;
    /// Read-only.
    pub const RO: Self = Self(Self::READ_ALL);
    /// Read/write in every state.
    pub const RW: Self = Self(Self::READ_ALL | Self::WRITE_ALL);
    /// Writable in PREOP only.
    pub const RW_PREOP: Self = Self(Self::READ_ALL | Self::WRITE_PREOP);

    /// Parses the profile-file spelling.
    pub fn parse(s: &str) -> Option<Self> {
        let w = match s {
            "ro" => return Some(Self::RO),
            "wo" => return Some(Self(Self::WRITE_ALL)),
            "rw" => Self::WRITE_ALL,
            "rw_preop" => Self::WRITE_PREOP,
            "rw_preop_safeop" => Self::WRITE_PREOP | Self::WRITE_SAFEOP,
            "rw_preop_op" => Self::WRITE_PREOP | Self::WRITE_OP,
            "rw_safeop" => Self::WRITE_SAFEOP,
            "rw_safeop_op" => Self::WRITE_SAFEOP | Self::WRITE_OP,
            "rw_op" => Self::WRITE_OP,
            _ => return None,
        };
        Some(Self(Self::READ_ALL | w))
    }

    /// Readable in some state.
    pub fn readable(self) -> bool {
        self.0 & Self::READ_ALL != 0
    }

    /// Writable in some state.
    pub fn writable(self) -> bool {
        self.0 & Self::WRITE_ALL != 0
    }

    /// ESI `Flags/Access` text and `@WriteRestrictions` (if any).
    pub fn esi(self) -> (&'static str, Option<&'static str>) {
        let w = self.0 & Self::WRITE_ALL;
        let text = match (self.readable(), w != 0) {
            (true, false) | (false, false) => "ro",
            (false, true) => "wo",
            (true, true) => "rw",
        };
        let restriction = match w {
            x if x == Self::WRITE_PREOP => Some("PreOP"),
            x if x == Self::WRITE_PREOP | Self::WRITE_SAFEOP => Some("PreOP_SafeOP"),
            x if x == Self::WRITE_PREOP | Self::WRITE_OP => Some("PreOP_OP"),
            x if x == Self::WRITE_SAFEOP => Some("SafeOP"),
            x if x == Self::WRITE_SAFEOP | Self::WRITE_OP => Some("SafeOP_OP"),
            x if x == Self::WRITE_OP => Some("OP"),
            _ => None,
        };
        (text, restriction)
    }
}

/// PDO mappability.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PdoMapping {
    /// Not mappable.
    No,
    /// RxPDO.
    Rx,
    /// TxPDO.
    Tx,
    /// Both.
    RxTx,
}

impl PdoMapping {
    /// Mappable into an RxPDO.
    pub fn rx(self) -> bool {
        matches!(self, Self::Rx | Self::RxTx)
    }
    /// Mappable into a TxPDO.
    pub fn tx(self) -> bool {
        matches!(self, Self::Tx | Self::RxTx)
    }
    /// The variant name of `firmware::od::PdoMappable`.
    pub fn rust_variant(self) -> &'static str {
        match self {
            Self::No => "No",
            Self::Rx => "Rx",
            Self::Tx => "Tx",
            Self::RxTx => "RxTx",
        }
    }
    /// ESI `Flags/PdoMapping` text (`None` when not mappable).
    pub fn esi(self) -> Option<&'static str> {
        match self {
            Self::No => None,
            Self::Rx => Some("R"),
            Self::Tx => Some("T"),
            Self::RxTx => Some("TR"),
        }
    }
}

/// Where a value is stored in the firmware.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Storage {
    /// In the OD RAM (changeable at run time).
    Ram,
    /// A constant in flash.
    Const,
    /// A DOMAIN outside the OD RAM, served by the firmware's `DomainStore`
    /// (`firmware::od::Value::Domain`). Domain ids are numbered 0, 1, ... in dictionary order.
    Domain,
}

/// The application variables a profile can bind to entries (`firmware::od::AppVars` fields).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Role {
    /// 6040h controlword (UINT).
    Controlword,
    /// 6041h statusword (UINT).
    Statusword,
    /// 6060h modes of operation (SINT).
    ModesOfOperation,
    /// 6061h modes of operation display (SINT).
    ModesOfOperationDisplay,
    /// 607Ah target position (DINT).
    TargetPosition,
    /// 6064h position actual value (DINT).
    PositionActualValue,
    /// 603Fh error code (UINT): the CiA402 error the drive reports.
    ErrorCode,
    /// 60FFh target velocity (DINT).
    TargetVelocity,
    /// 6071h target torque (INT, ‰ of the motor rated torque).
    TargetTorque,
    /// 606Ch velocity actual value (DINT).
    VelocityActualValue,
    /// 6077h torque actual value (INT, ‰ of the motor rated torque).
    TorqueActualValue,
    /// 6076h motor rated torque (UDINT, mN·m): the unit of the torque objects.
    MotorRatedTorque,
    /// Commissioned phase resistance (UDINT, µΩ; 0 = use the board's value).
    MotorResistance,
    /// Commissioned d-axis inductance (UDINT, nH; 0 = use the board's value).
    MotorLd,
    /// Commissioned q-axis inductance (UDINT, nH; 0 = use the board's value).
    MotorLq,
    /// Commissioned rotor + load inertia (UDINT, g·mm²; 0 = use the board's value).
    MotorInertia,
    /// 605Ah quick stop option code (INT).
    QuickStopOptionCode,
    /// 605Bh shutdown option code (INT).
    ShutdownOptionCode,
    /// 605Ch disable operation option code (INT).
    DisableOperationOptionCode,
    /// 605Dh halt option code (INT).
    HaltOptionCode,
    /// 605Eh fault reaction option code (INT).
    FaultReactionOptionCode,
    /// 6084h profile deceleration (UDINT, acceleration units): the slow-down ramp.
    ProfileDeceleration,
    /// 6085h quick stop deceleration (UDINT, acceleration units): the quick-stop ramp.
    QuickStopDeceleration,
    /// 6081h profile velocity (UDINT, velocity units): the speed of a profile-position move.
    ProfileVelocity,
    /// 6083h profile acceleration (UDINT, acceleration units).
    ProfileAcceleration,
    /// 607Fh max profile velocity (UDINT, velocity units): limits 6081h and 60FFh in the profile modes.
    MaxProfileVelocity,
    /// 6087h torque slope (UDINT, ‰ of the rated torque per second): the torque ramp of profile torque.
    TorqueSlope,
    /// 6067h position window (UDINT, position units): target reached in the position modes.
    PositionWindow,
    /// 6068h position window time (UINT, ms).
    PositionWindowTime,
    /// 606Dh velocity window (UINT, velocity units): target reached in profile velocity.
    VelocityWindow,
    /// 606Eh velocity window time (UINT, ms).
    VelocityWindowTime,
    /// 606Fh velocity threshold (UINT, velocity units): speed zero (statusword bit 12 in profile velocity).
    VelocityThreshold,
    /// 6070h velocity threshold time (UINT, ms).
    VelocityThresholdTime,
    /// 6062h position demand value (DINT, position units): the position the profile generator commands.
    PositionDemandValue,
    /// 606Bh velocity demand value (DINT, velocity units).
    VelocityDemandValue,
    /// 6074h torque demand (INT, ‰ of the rated torque).
    TorqueDemand,
    /// 6098h homing method (SINT).
    HomingMethod,
    /// 6099h:01 speed during search for switch (UDINT, velocity units).
    HomingSpeedSwitch,
    /// 6099h:02 speed during search for zero (UDINT, velocity units).
    HomingSpeedZero,
    /// 609Ah homing acceleration (UDINT, acceleration units).
    HomingAcceleration,
    /// 607Ch home offset (DINT, position units): the position value of the home position.
    HomeOffset,
    /// 60B8h touch probe function (UINT).
    TouchProbeFunction,
    /// 60B9h touch probe status (UINT).
    TouchProbeStatus,
    /// 60BAh touch probe 1 positive edge position (DINT, position units).
    TouchProbe1Positive,
    /// 60BBh touch probe 1 negative edge position (DINT, position units).
    TouchProbe1Negative,
    /// 60BCh touch probe 2 positive edge position (DINT, position units).
    TouchProbe2Positive,
    /// 60BDh touch probe 2 negative edge position (DINT, position units).
    TouchProbe2Negative,
    /// 60D5h touch probe 1 positive edge counter (UINT).
    TouchProbe1PositiveCount,
    /// 60D6h touch probe 1 negative edge counter (UINT).
    TouchProbe1NegativeCount,
    /// 60D7h touch probe 2 positive edge counter (UINT).
    TouchProbe2PositiveCount,
    /// 60D8h touch probe 2 negative edge counter (UINT).
    TouchProbe2NegativeCount,
    /// 6065h following error window (UDINT, position units; FFFF FFFFh = off).
    FollowingErrorWindow,
    /// 6066h following error time out (UINT, ms).
    FollowingErrorTimeout,
    /// 607Dh:01 min position limit (DINT, position units).
    SoftwarePositionLimitMin,
    /// 607Dh:02 max position limit (DINT, position units).
    SoftwarePositionLimitMax,
    /// 60FDh digital inputs (UDINT): bits 0 negative limit, 1 positive limit, 2 home switch.
    DigitalInputs,
    /// 6072h max torque (UINT, ‰ of the rated torque).
    MaxTorque,
    /// 60E0h positive torque limit value (UINT, ‰ of the rated torque).
    PositiveTorqueLimit,
    /// 60E1h negative torque limit value (UINT, ‰ of the rated torque).
    NegativeTorqueLimit,
    /// 60B0h position offset (DINT, position units): added to the CSP target.
    PositionOffset,
    /// 60B1h velocity offset (DINT, velocity units): velocity feed-forward in CSP, added in CSV.
    VelocityOffset,
    /// 60B2h torque offset (INT, ‰ of the rated torque): torque feed-forward in CSP/CSV, added in CST.
    TorqueOffset,
    /// 6502h supported drive modes (UDINT): bit n−1 for mode n; the standard's bit 16 for mode −1.
    SupportedDriveModes,
    /// 60C1h:01 interpolation data record (DINT, position units): the interpolated position
    /// mode's absolute position set-point.
    InterpolationData,
    /// 60C2h:01 interpolation time period value (USINT): the period is value × 10^index s.
    InterpolationTimePeriod,
    /// 60C2h:02 interpolation time index (SINT).
    InterpolationTimeIndex,
    /// 607Eh polarity (USINT): bit 7 position, bit 6 velocity, bit 5 torque objects × −1.
    Polarity,
    /// 60FEh:01 physical outputs (UDINT): the levels the master forces.
    DigitalOutputs,
    /// 60FEh:02 bit mask (UDINT): the outputs the master forces.
    DigitalOutputsMask,
    /// 6080h max motor speed (UDINT, the profile's velocity unit): limits every velocity
    /// set-point.
    MaxMotorSpeed,
    /// A vendor's homing time limit (UINT, ms; 0 = none; the RSE's 2006h:03 P03.45): a run
    /// that takes longer ends in a homing error.
    HomingTimeout,
    /// The command that makes the `[units]` factors take effect (UDINT; the Σ-V-SD's 2300h):
    /// with it the factors are read at power-on and when 1 is written to it in Switch On
    /// Disabled, not every cycle.
    UnitsApply,
}

impl Role {
    /// All roles.
    pub const ALL: [Role; 72] = [
        Self::Controlword,
        Self::Statusword,
        Self::ModesOfOperation,
        Self::ModesOfOperationDisplay,
        Self::TargetPosition,
        Self::PositionActualValue,
        Self::ErrorCode,
        Self::TargetVelocity,
        Self::TargetTorque,
        Self::VelocityActualValue,
        Self::TorqueActualValue,
        Self::MotorRatedTorque,
        Self::MotorResistance,
        Self::MotorLd,
        Self::MotorLq,
        Self::MotorInertia,
        Self::QuickStopOptionCode,
        Self::ShutdownOptionCode,
        Self::DisableOperationOptionCode,
        Self::HaltOptionCode,
        Self::FaultReactionOptionCode,
        Self::ProfileDeceleration,
        Self::QuickStopDeceleration,
        Self::ProfileVelocity,
        Self::ProfileAcceleration,
        Self::MaxProfileVelocity,
        Self::TorqueSlope,
        Self::PositionWindow,
        Self::PositionWindowTime,
        Self::VelocityWindow,
        Self::VelocityWindowTime,
        Self::VelocityThreshold,
        Self::VelocityThresholdTime,
        Self::PositionDemandValue,
        Self::VelocityDemandValue,
        Self::TorqueDemand,
        Self::HomingMethod,
        Self::HomingSpeedSwitch,
        Self::HomingSpeedZero,
        Self::HomingAcceleration,
        Self::HomeOffset,
        Self::TouchProbeFunction,
        Self::TouchProbeStatus,
        Self::TouchProbe1Positive,
        Self::TouchProbe1Negative,
        Self::TouchProbe2Positive,
        Self::TouchProbe2Negative,
        Self::TouchProbe1PositiveCount,
        Self::TouchProbe1NegativeCount,
        Self::TouchProbe2PositiveCount,
        Self::TouchProbe2NegativeCount,
        Self::FollowingErrorWindow,
        Self::FollowingErrorTimeout,
        Self::SoftwarePositionLimitMin,
        Self::SoftwarePositionLimitMax,
        Self::DigitalInputs,
        Self::MaxTorque,
        Self::PositiveTorqueLimit,
        Self::NegativeTorqueLimit,
        Self::PositionOffset,
        Self::VelocityOffset,
        Self::TorqueOffset,
        Self::SupportedDriveModes,
        Self::InterpolationData,
        Self::InterpolationTimePeriod,
        Self::InterpolationTimeIndex,
        Self::Polarity,
        Self::DigitalOutputs,
        Self::DigitalOutputsMask,
        Self::MaxMotorSpeed,
        Self::HomingTimeout,
        Self::UnitsApply,
    ];
    /// Whether every axis of a multi-axis drive needs its own entry for the role: all but the
    /// commissioned motor data (vendor objects a unit may keep once for all its axes).
    pub fn per_axis(self) -> bool {
        !matches!(
            self,
            Self::MotorResistance | Self::MotorLd | Self::MotorLq | Self::MotorInertia
        )
    }
    /// The `AppVars` field name (also the profile-file spelling).
    pub fn field(self) -> &'static str {
        match self {
            Self::Controlword => "controlword",
            Self::Statusword => "statusword",
            Self::ModesOfOperation => "modes_of_operation",
            Self::ModesOfOperationDisplay => "modes_of_operation_display",
            Self::TargetPosition => "target_position",
            Self::PositionActualValue => "position_actual_value",
            Self::ErrorCode => "error_code",
            Self::TargetVelocity => "target_velocity",
            Self::TargetTorque => "target_torque",
            Self::VelocityActualValue => "velocity_actual_value",
            Self::TorqueActualValue => "torque_actual_value",
            Self::MotorRatedTorque => "motor_rated_torque",
            Self::MotorResistance => "motor_resistance",
            Self::MotorLd => "motor_ld",
            Self::MotorLq => "motor_lq",
            Self::MotorInertia => "motor_inertia",
            Self::QuickStopOptionCode => "quick_stop_option_code",
            Self::ShutdownOptionCode => "shutdown_option_code",
            Self::DisableOperationOptionCode => "disable_operation_option_code",
            Self::HaltOptionCode => "halt_option_code",
            Self::FaultReactionOptionCode => "fault_reaction_option_code",
            Self::ProfileDeceleration => "profile_deceleration",
            Self::QuickStopDeceleration => "quick_stop_deceleration",
            Self::ProfileVelocity => "profile_velocity",
            Self::ProfileAcceleration => "profile_acceleration",
            Self::MaxProfileVelocity => "max_profile_velocity",
            Self::TorqueSlope => "torque_slope",
            Self::PositionWindow => "position_window",
            Self::PositionWindowTime => "position_window_time",
            Self::VelocityWindow => "velocity_window",
            Self::VelocityWindowTime => "velocity_window_time",
            Self::VelocityThreshold => "velocity_threshold",
            Self::VelocityThresholdTime => "velocity_threshold_time",
            Self::PositionDemandValue => "position_demand_value",
            Self::VelocityDemandValue => "velocity_demand_value",
            Self::TorqueDemand => "torque_demand",
            Self::HomingMethod => "homing_method",
            Self::HomingSpeedSwitch => "homing_speed_switch",
            Self::HomingSpeedZero => "homing_speed_zero",
            Self::HomingAcceleration => "homing_acceleration",
            Self::HomeOffset => "home_offset",
            Self::TouchProbeFunction => "touch_probe_function",
            Self::TouchProbeStatus => "touch_probe_status",
            Self::TouchProbe1Positive => "touch_probe_1_positive",
            Self::TouchProbe1Negative => "touch_probe_1_negative",
            Self::TouchProbe2Positive => "touch_probe_2_positive",
            Self::TouchProbe2Negative => "touch_probe_2_negative",
            Self::TouchProbe1PositiveCount => "touch_probe_1_positive_count",
            Self::TouchProbe1NegativeCount => "touch_probe_1_negative_count",
            Self::TouchProbe2PositiveCount => "touch_probe_2_positive_count",
            Self::TouchProbe2NegativeCount => "touch_probe_2_negative_count",
            Self::FollowingErrorWindow => "following_error_window",
            Self::FollowingErrorTimeout => "following_error_timeout",
            Self::SoftwarePositionLimitMin => "software_position_limit_min",
            Self::SoftwarePositionLimitMax => "software_position_limit_max",
            Self::DigitalInputs => "digital_inputs",
            Self::MaxTorque => "max_torque",
            Self::PositiveTorqueLimit => "positive_torque_limit",
            Self::NegativeTorqueLimit => "negative_torque_limit",
            Self::PositionOffset => "position_offset",
            Self::VelocityOffset => "velocity_offset",
            Self::TorqueOffset => "torque_offset",
            Self::SupportedDriveModes => "supported_drive_modes",
            Self::InterpolationData => "interpolation_data",
            Self::InterpolationTimePeriod => "interpolation_time_period",
            Self::InterpolationTimeIndex => "interpolation_time_index",
            Self::Polarity => "polarity",
            Self::DigitalOutputs => "digital_outputs",
            Self::DigitalOutputsMask => "digital_outputs_mask",
            Self::MaxMotorSpeed => "max_motor_speed",
            Self::HomingTimeout => "homing_timeout",
            Self::UnitsApply => "units_apply",
        }
    }
    /// Parses the profile-file spelling.
    pub fn parse(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|r| r.field() == s)
    }
    /// Whether the role is a process-data command the master sends every cycle (never a stored
    /// parameter: a stored controlword or target would act at power-on).
    pub fn is_command(self) -> bool {
        matches!(
            self,
            Self::Controlword
                | Self::ModesOfOperation
                | Self::TargetPosition
                | Self::TargetVelocity
                | Self::TargetTorque
                | Self::PositionOffset
                | Self::VelocityOffset
                | Self::TorqueOffset
                | Self::InterpolationData
        )
    }
    /// Whether an entry of `data_type` can hold the role: its own type, or for the torque
    /// offset also a DINT (the GHA-E's 60B2h; the firmware reads the low 16 bits, the value's
    /// range as a ‰ torque).
    pub fn accepts(self, data_type: DataType) -> bool {
        data_type == self.data_type() || (self == Self::TorqueOffset && data_type == DataType::Dint)
    }

    /// The data type the role needs.
    pub fn data_type(self) -> DataType {
        match self {
            Self::Controlword | Self::Statusword | Self::ErrorCode => DataType::Uint,
            Self::ModesOfOperation
            | Self::ModesOfOperationDisplay
            | Self::HomingMethod
            | Self::InterpolationTimeIndex => DataType::Sint,
            Self::InterpolationTimePeriod | Self::Polarity => DataType::Usint,
            Self::TargetPosition
            | Self::PositionActualValue
            | Self::TargetVelocity
            | Self::VelocityActualValue
            | Self::PositionDemandValue
            | Self::VelocityDemandValue
            | Self::HomeOffset
            | Self::TouchProbe1Positive
            | Self::TouchProbe1Negative
            | Self::TouchProbe2Positive
            | Self::TouchProbe2Negative
            | Self::SoftwarePositionLimitMin
            | Self::SoftwarePositionLimitMax
            | Self::PositionOffset
            | Self::VelocityOffset
            | Self::InterpolationData => DataType::Dint,
            Self::TargetTorque
            | Self::TorqueActualValue
            | Self::TorqueDemand
            | Self::TorqueOffset => DataType::Int,
            Self::PositionWindowTime
            | Self::VelocityWindow
            | Self::VelocityWindowTime
            | Self::VelocityThreshold
            | Self::VelocityThresholdTime
            | Self::TouchProbeFunction
            | Self::TouchProbeStatus
            | Self::TouchProbe1PositiveCount
            | Self::TouchProbe1NegativeCount
            | Self::TouchProbe2PositiveCount
            | Self::TouchProbe2NegativeCount
            | Self::FollowingErrorTimeout
            | Self::MaxTorque
            | Self::PositiveTorqueLimit
            | Self::NegativeTorqueLimit
            | Self::HomingTimeout => DataType::Uint,
            Self::MotorRatedTorque
            | Self::MotorResistance
            | Self::MotorLd
            | Self::MotorLq
            | Self::MotorInertia
            | Self::ProfileDeceleration
            | Self::QuickStopDeceleration
            | Self::ProfileVelocity
            | Self::ProfileAcceleration
            | Self::MaxProfileVelocity
            | Self::TorqueSlope
            | Self::PositionWindow
            | Self::HomingSpeedSwitch
            | Self::HomingSpeedZero
            | Self::HomingAcceleration
            | Self::FollowingErrorWindow
            | Self::DigitalInputs
            | Self::DigitalOutputs
            | Self::DigitalOutputsMask
            | Self::MaxMotorSpeed
            | Self::UnitsApply
            | Self::SupportedDriveModes => DataType::Udint,
            Self::QuickStopOptionCode
            | Self::ShutdownOptionCode
            | Self::DisableOperationOptionCode
            | Self::HaltOptionCode
            | Self::FaultReactionOptionCode => DataType::Int,
        }
    }
}

/// One subindex.
#[derive(Clone, Debug, PartialEq)]
pub struct Entry {
    /// Subindex.
    pub subindex: u8,
    /// Name.
    pub name: String,
    /// Data type.
    pub data_type: DataType,
    /// Size in bits.
    pub bit_len: u16,
    /// Access.
    pub access: Access,
    /// PDO mappability.
    pub pdo: PdoMapping,
    /// Storage.
    pub storage: Storage,
    /// Default value, little-endian, type width (strings: the text bytes); empty = none.
    pub default: Vec<u8>,
    /// Minimum, little-endian; empty = none.
    pub min: Vec<u8>,
    /// Maximum, little-endian; empty = none.
    pub max: Vec<u8>,
    /// Application role.
    pub role: Option<Role>,
    /// Startup parameter (profile `setting = true`): SDO information list type 5, ObjAccess
    /// bit 9, ESI `Flags/Setting`.
    pub setting: bool,
    /// The only values an SDO download may write (profile key `allowed`); empty: any value in
    /// `min..=max`.
    pub allowed: Vec<i64>,
    /// Documentation.
    pub doc: Doc,
}

impl Entry {
    /// Size in whole bytes.
    pub fn byte_len(&self) -> usize {
        usize::from(self.bit_len).div_ceil(8)
    }
    /// The initial value as stored: the default padded with zeros to [`Entry::byte_len`].
    pub fn initial_bytes(&self) -> Vec<u8> {
        let mut v = self.default.clone();
        v.resize(self.byte_len(), 0);
        v
    }
}

/// One object.
#[derive(Clone, Debug, PartialEq)]
pub struct Object {
    /// Index.
    pub index: u16,
    /// Object code.
    pub code: ObjectCode,
    /// Name.
    pub name: String,
    /// Entries sorted by subindex (subindex 0 first for ARRAY/RECORD).
    pub entries: Vec<Entry>,
    /// Generated by od-gen from other sections of the profile.
    pub derived: bool,
    /// Documentation (RECORD/ARRAY: the object's own; a VAR's is on its entry).
    pub doc: Doc,
}

/// Documentation of an object or entry (profile keys `unit`, `description`): the generated
/// profile pages and ESI comments; not in the firmware.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Doc {
    /// Unit of the value.
    pub unit: Option<String>,
    /// What it means.
    pub description: Option<String>,
}

/// The slave stack's limit on one PDO and on the process image of one direction, in bytes:
/// [`hal::esc::MAX_FIRMWARE_PROCESS_IMAGE`], which `ethercat_slave::pdo::rules::MAX_PDO_BYTES`
/// and `ethercat_slave::pdo::MAX_IMAGE` are too (the generated code still asserts they agree).
/// A profile's `[pdo]` limits may only be lower.
pub const STACK_MAX_PDO_BYTES: u16 = hal::esc::MAX_FIRMWARE_PROCESS_IMAGE;

/// The SM output and input parameter objects (ETG.1020 §5.1): generated from `[sync]`, or
/// declared by a profile in its manual's layout.
pub const SM_PARAMETER_OBJECTS: [u16; 2] = [0x1C32, 0x1C33];

/// Objects the firmware's parameter storage never stores whatever the profile says: 1010h/1011h
/// (store/restore) and the SM parameters 1C32h/1C33h (the stack overwrites them with the active
/// synchronisation). The firmware's list is `ethercat_slave::params::NOT_STORED`; the generated
/// code asserts that both rules select the same entries (`check::backup_agrees`).
pub const NOT_STORED: [u16; 4] = [0x1010, 0x1011, 0x1C32, 0x1C33];

/// The one SM parameter entry that is a stored parameter where the master may write it: the
/// input shift time 1C33h:03 (`[sync] input_shift`), which the stack never overwrites (the
/// Σ-V-SD keeps it in EEPROM, §4.4 (3)). As `ethercat_slave::params::STORED_SM_PARAMETER`.
pub const STORED_SM_PARAMETER: (u16, u8) = (0x1C33, 0x03);

/// Store parameters (CiA 301 §7.5.2.13): the object whose subindexes select the groups.
pub const STORE_PARAMETERS: u16 = 0x1010;
/// Restore default parameters (CiA 301 §7.5.2.14).
pub const RESTORE_DEFAULTS: u16 = 0x1011;
/// The 1010h/1011h subindex of every parameter (CiA 301); groups are 2 and above.
pub const ALL_PARAMETERS: u8 = 1;
/// The CiA 301 scopes of 1010h/1011h sub 2, 3, 4 when a profile gives no `[[storage.group]]`:
/// (subindex, first index, last index) — communication 1000h–1FFFh, application 6000h–9FFFh,
/// manufacturer 2000h–5FFFh.
pub const DEFAULT_GROUPS: [(u8, u16, u16); 3] = [
    (2, 0x1000, 0x1FFF),
    (3, 0x6000, 0x9FFF),
    (4, 0x2000, 0x5FFF),
];
/// 1010h read value bit 0: saves parameters on command (CiA 301 §7.5.2.13).
pub const SAVES_ON_COMMAND: u32 = 1 << 0;
/// 1010h read value bit 1: saves parameters autonomously.
pub const SAVES_AUTONOMOUSLY: u32 = 1 << 1;

/// A set of entries a `[storage]` rule names: every entry of the objects `first..=last`
/// (`"0x2000-0x22FF"`, `"0x2300"`) or one entry (`"0x2310:1"`, then `first == last`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EntryRange {
    /// First object index.
    pub first: u16,
    /// Last object index (inclusive).
    pub last: u16,
    /// The one subindex named; `None`: every entry of the objects.
    pub subindex: Option<u8>,
}

impl EntryRange {
    /// Whether `index:subindex` is in the set.
    pub fn contains(&self, index: u16, subindex: u8) -> bool {
        (self.first..=self.last).contains(&index) && self.subindex.is_none_or(|s| s == subindex)
    }
    /// Whether an entry address can be in both sets (as `ethercat_slave::od::EntryRange`).
    pub fn overlaps(&self, other: &Self) -> bool {
        let objects = self.first <= other.last && other.first <= self.last;
        match (self.subindex, other.subindex) {
            (Some(a), Some(b)) => objects && a == b,
            _ => objects,
        }
    }
}

impl std::fmt::Display for EntryRange {
    /// The profile spelling.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.subindex {
            Some(s) => write!(f, "{:#06X}:{s:#04X}", self.first),
            None if self.first == self.last => write!(f, "{:#06X}", self.first),
            None => write!(f, "{:#06X}-{:#06X}", self.first, self.last),
        }
    }
}

/// Whether one of `ranges` holds `index:subindex`.
pub fn any_contains(ranges: &[EntryRange], index: u16, subindex: u8) -> bool {
    ranges.iter().any(|r| r.contains(index, subindex))
}

/// `(value of index:subindex & mask) == value` on the current OD (`[storage]` conditions).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EntryTest {
    /// Index of the entry read.
    pub index: u16,
    /// Its subindex.
    pub subindex: u8,
    /// The bits compared (default: every bit of the entry).
    pub mask: u32,
    /// Their expected value.
    pub value: u32,
}

/// `[[storage.group]]`: what 1010h/1011h subindex `subindex` stores and restores.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StorageGroup {
    /// The subindex (≥ 2).
    pub subindex: u8,
    /// The entries.
    pub ranges: Vec<EntryRange>,
}

/// `[[storage.auto_store]]`: entries an SDO download stores at once.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AutoStore {
    /// The entries.
    pub entries: Vec<EntryRange>,
    /// While it holds (after the download), the download is not stored.
    pub unless: Option<EntryTest>,
}

/// `[storage.write_condition]`: 1010h/1011h `subindexes` are written only while `test` holds
/// (else abort 0x08000022).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct WriteCondition {
    /// What must hold.
    pub test: EntryTest,
    /// The guarded subindexes.
    pub subindexes: Vec<u8>,
}

/// `[storage]`: the profile's parameter storage rules (the firmware's `od::StorageRules`).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct StorageRules {
    /// PDO-mappable entries that are stored.
    pub stored_pdo_mappable: Vec<EntryRange>,
    /// Writable entries that are not stored (wins over `stored_pdo_mappable`).
    pub not_stored: Vec<EntryRange>,
    /// The groups of 1010h/1011h subindex 2 and above (the profile's, or [`DEFAULT_GROUPS`] for
    /// the subindexes 1010h has).
    pub groups: Vec<StorageGroup>,
    /// Entries an SDO download stores at once.
    pub auto_store: Vec<AutoStore>,
    /// The condition on some 1010h/1011h subindexes.
    pub write_condition: Option<WriteCondition>,
}

impl StorageRules {
    /// Whether `e` of `o` is stored by the firmware's parameter storage (1010h) and so is a
    /// "backup" entry (SDO information list type 4, ObjAccess bit 8, ESI `Flags/Backup`): a RAM
    /// variable, writable in some state, not in [`NOT_STORED`], not in `not_stored`, and not
    /// PDO-mappable unless in `stored_pdo_mappable`. The firmware's rule is
    /// `ethercat_slave::params::is_storable`; the generated code asserts at compile time that
    /// both agree on every entry (`check::backup_agrees`).
    pub fn stores(&self, o: &Object, e: &Entry) -> bool {
        self.stores_without_exclusions(o, e) && !any_contains(&self.not_stored, o.index, e.subindex)
    }

    /// [`Self::stores`] before `not_stored` is applied.
    pub fn stores_without_exclusions(&self, o: &Object, e: &Entry) -> bool {
        let parameter =
            e.pdo == PdoMapping::No || any_contains(&self.stored_pdo_mappable, o.index, e.subindex);
        e.storage == Storage::Ram
            && e.access.writable()
            && parameter
            && (!NOT_STORED.contains(&o.index) || (o.index, e.subindex) == STORED_SM_PARAMETER)
    }

    /// What 1010h:`subindex` reads: [`SAVES_ON_COMMAND`], plus [`SAVES_AUTONOMOUSLY`] when the
    /// subindex's group holds an entry of an auto-store rule (sub 1: when there is any). As
    /// `ethercat_slave::params::store_capabilities` (asserted in the generated code).
    pub fn store_capabilities(&self, subindex: u8) -> u32 {
        let autonomous = if subindex == ALL_PARAMETERS {
            !self.auto_store.is_empty()
        } else {
            self.groups
                .iter()
                .filter(|g| g.subindex == subindex)
                .any(|g| {
                    self.auto_store.iter().any(|a| {
                        a.entries
                            .iter()
                            .any(|x| g.ranges.iter().any(|r| r.overlaps(x)))
                    })
                })
        };
        if autonomous {
            SAVES_ON_COMMAND | SAVES_AUTONOMOUSLY
        } else {
            SAVES_ON_COMMAND
        }
    }
}

impl Object {
    /// The entry with this subindex.
    pub fn entry(&self, subindex: u8) -> Option<&Entry> {
        self.entries.iter().find(|e| e.subindex == subindex)
    }
}

/// One SyncManager.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sm {
    /// Start address.
    pub start: u16,
    /// Length in bytes (mailbox size, or the default process-data size).
    pub length: u16,
    /// Control byte.
    pub control: u8,
}

/// The SyncManager layout.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SmLayout {
    /// SM0.
    pub mailbox_out: Sm,
    /// SM1.
    pub mailbox_in: Sm,
    /// Bootstrap mailbox out.
    pub boot_out: Option<Sm>,
    /// Bootstrap mailbox in.
    pub boot_in: Option<Sm>,
    /// SM2 (length = default RxPDO assignment size).
    pub outputs: Sm,
    /// SM3 (length = default TxPDO assignment size).
    pub inputs: Sm,
}

/// CoE details (SII General byte 5 bits; ESI `Mailbox/CoE` attributes).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct CoeDetails {
    /// b0 SDO.
    pub sdo: bool,
    /// b1 SDO information.
    pub sdo_info: bool,
    /// b2 PDO assign.
    pub pdo_assign: bool,
    /// b3 PDO configuration.
    pub pdo_config: bool,
    /// b4 upload at startup.
    pub upload_at_startup: bool,
    /// b5 SDO complete access.
    pub complete_access: bool,
}

impl CoeDetails {
    /// The SII General CoE details byte.
    pub fn bits(&self) -> u8 {
        u8::from(self.sdo)
            | u8::from(self.sdo_info) << 1
            | u8::from(self.pdo_assign) << 2
            | u8::from(self.pdo_config) << 3
            | u8::from(self.upload_at_startup) << 4
            | u8::from(self.complete_access) << 5
    }
}

/// Mailbox protocol bits of SII word 0x1C.
pub mod protocol {
    /// ADS over EtherCAT.
    pub const AOE: u16 = 0x01;
    /// Ethernet over EtherCAT.
    pub const EOE: u16 = 0x02;
    /// CAN application protocol over EtherCAT.
    pub const COE: u16 = 0x04;
    /// File access over EtherCAT.
    pub const FOE: u16 = 0x08;
    /// Servo drive profile over EtherCAT.
    pub const SOE: u16 = 0x10;
    /// Vendor specific.
    pub const VOE: u16 = 0x20;
    /// Names as written in profile files, with their bits.
    pub const NAMES: [(&str, u16); 6] = [
        ("AoE", AOE),
        ("EoE", EOE),
        ("CoE", COE),
        ("FoE", FOE),
        ("SoE", SOE),
        ("VoE", VOE),
    ];
}

/// Mailbox settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Mailbox {
    /// Protocol bits ([`protocol`]).
    pub protocols: u16,
    /// Mailbox data link layer.
    pub data_link_layer: bool,
    /// CoE details (all false without CoE).
    pub coe: CoeDetails,
}

/// Synchronisation support.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Sync {
    /// Free run.
    pub free_run: bool,
    /// SM2-synchronous.
    pub sm_synchronous: bool,
    /// DC SYNC0.
    pub dc_sync0: bool,
    /// DC SYNC1.
    pub dc_sync1: bool,
    /// Minimum cycle, ns.
    pub min_cycle_ns: u32,
    /// Maximum cycle, ns.
    pub max_cycle_ns: u32,
    /// Default cycle, ns.
    pub default_cycle_ns: u32,
    /// Calc and copy time, ns.
    pub calc_and_copy_ns: u32,
    /// Delay time, ns.
    pub delay_ns: u32,
    /// A DC SYNC0 cycle must be a whole multiple of this, ns (1 = any).
    pub cycle_step_ns: u32,
    /// The only DC cycles accepted, ns (empty: any multiple of the step in range).
    pub allowed_cycles_ns: Vec<u32>,
    /// Default of 1C32h:01 (0 free run, 1 SM-synchronous, 2 DC SYNC0; 1C33h: 0x22 for 1).
    pub default_sync_mode: u16,
    /// 1C32h/1C33h:01 writable in PREOP.
    pub sync_mode_writable: bool,
    /// 1C32h/1C33h:02 writable in PREOP.
    pub cycle_time_writable: bool,
    /// 1C32h:20 TRUE = synchronised without error (instead of ETG.1020's TRUE = error).
    pub sync_flag_in_sync: bool,
    /// Shortest free-run cycle (1C32h:02 in free run), ns.
    pub free_run_min_cycle_ns: u32,
    /// Longest free-run cycle, ns.
    pub free_run_max_cycle_ns: u32,
    /// Writable input shift time 1C33h:03 (`None`: read-only).
    pub input_shift: Option<InputShift>,
    /// The sync error counter trips on reaching 10F1h:02 (else on exceeding it).
    pub sync_error_at_limit: bool,
    /// A SYNC0 without new outputs counts as a missed event (in OP, DC modes).
    pub sync_error_on_missed_outputs: bool,
    /// The 1C32h subindex that counts missed events; 0: none (a declared 1C32h without one).
    pub sm_event_missed_subindex: u8,
}

/// A writable input shift time 1C33h:03.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct InputShift {
    /// Values are whole multiples of this, ns.
    pub step_ns: u32,
    /// The shift is at most the SYNC0 cycle minus this, ns.
    pub reserve_ns: u32,
    /// The parameter (index, subindex) that sets the shift at power-on, in steps.
    pub parameter: Option<(u16, u8)>,
}

impl Sync {
    /// The DC SYNC0 cycles the firmware runs with this profile: the rule of its PREOP -> SAFEOP
    /// check (`hal::esc::DcCycleRule`, the one definition).
    pub fn dc_cycle_rule(&self) -> hal::esc::DcCycleRule<'_> {
        hal::esc::DcCycleRule {
            min_ns: self.min_cycle_ns,
            max_ns: self.max_cycle_ns,
            step_ns: self.cycle_step_ns,
            allowed_ns: &self.allowed_cycles_ns,
        }
    }

    /// 1C32h:04 / 1C33h:04 "sync modes supported" (ETG.1020 §21.1.2 as reproduced in Beckhoff
    /// terminal documentation: b0 free run, b1 SM-synchronous, b2..3 = 01 DC SYNC0, = 10 DC SYNC1).
    pub fn modes_supported(&self) -> u16 {
        u16::from(self.free_run)
            | u16::from(self.sm_synchronous) << 1
            | u16::from(self.dc_sync0 && !self.dc_sync1) << 2
            | u16::from(self.dc_sync1) << 3
    }
}

/// One DC op mode.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DcOpMode {
    /// Name.
    pub name: String,
    /// Description.
    pub description: String,
    /// Registers 0x0980:0x0981.
    pub assign_activate: u16,
    /// SYNC0 cycle, ns.
    pub sync0_cycle_ns: u32,
    /// SYNC0 factor.
    pub sync0_factor: i16,
    /// SYNC0 shift, ns.
    pub sync0_shift_ns: u32,
    /// SYNC1 cycle, ns (ESI only).
    pub sync1_cycle_ns: u32,
    /// SYNC1 factor.
    pub sync1_factor: i16,
    /// SYNC1 shift, ns.
    pub sync1_shift_ns: u32,
}

/// One default mapping entry of a PDO.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PdoEntry {
    /// Object index (0 = padding).
    pub index: u16,
    /// Subindex.
    pub subindex: u8,
    /// Bit length.
    pub bits: u16,
    /// Name (the object entry's; empty for padding).
    pub name: String,
    /// Data type (`None` for padding).
    pub data_type: Option<DataType>,
}

impl PdoEntry {
    /// The 32-bit mapping value (index << 16 | subindex << 8 | bits).
    pub fn mapping_value(&self) -> u32 {
        u32::from(self.index) << 16 | u32::from(self.subindex) << 8 | u32::from(self.bits & 0xFF)
    }
}

/// A PDO.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Pdo {
    /// Index.
    pub index: u16,
    /// Name.
    pub name: String,
    /// SyncManager.
    pub sm: u8,
    /// Fixed mapping.
    pub fixed: bool,
    /// Mandatory.
    pub mandatory: bool,
    /// In the default assignment.
    pub assigned: bool,
    /// Default mapping.
    pub entries: Vec<PdoEntry>,
}

impl Pdo {
    /// Sum of the entry bit lengths.
    pub fn bits(&self) -> u32 {
        self.entries.iter().map(|e| u32::from(e.bits)).sum()
    }
}

/// Vendor.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Vendor {
    /// Vendor ID.
    pub id: u32,
    /// Name.
    pub name: String,
}

/// Device identity.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Device {
    /// Device name.
    pub name: String,
    /// Order number (ESI Type text).
    pub order_number: String,
    /// Product code.
    pub product_code: u32,
    /// Revision.
    pub revision: u32,
    /// Serial number.
    pub serial: u32,
    /// Hardware version.
    pub hardware_version: String,
    /// Software version.
    pub software_version: String,
    /// ESI group type.
    pub group_type: String,
    /// ESI group name.
    pub group_name: String,
    /// Physics (e.g. "YY").
    pub physics: String,
    /// Profile number (402).
    pub profile_no: u16,
    /// DS402 channels.
    pub ds402_channels: u8,
}

/// SII configuration area (words 0..6) and EEPROM size.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Eeprom {
    /// EEPROM size in bytes.
    pub byte_size: usize,
    /// Word 0 low byte.
    pub pdi_control: u8,
    /// Word 0 high byte.
    pub esc_config: u8,
    /// Word 1.
    pub pdi_config: u16,
    /// Word 2.
    pub sync_impulse_len: u16,
    /// Word 3.
    pub pdi_config2: u16,
    /// Word 4.
    pub station_alias: u16,
    /// Words 5 and 6.
    pub reserved: [u16; 2],
    /// The parameter whose non-zero value replaces the alias at power-on (index, subindex).
    pub station_alias_parameter: Option<(u16, u8)>,
    /// Only while this entry (index, subindex) holds this value.
    pub station_alias_selector: Option<(u16, u8, u32)>,
}

/// How 1001h and the stack's own emergencies are formed (`[emcy]`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EmcyRules {
    /// The 1001h bits the drive uses (0xFF: CiA 301 classes; 0x01: generic only).
    pub register_mask: u8,
    /// Emergency code of an AL error no alarm names.
    pub al_error_code: u16,
    /// The EMCY byte (3–7) that carries the axis number of a drive error.
    pub axis_number_byte: Option<u8>,
    /// The emergency code of every motor fault given by its 603Fh code, and the first EMCY
    /// byte (3–6) of the two that carry that 603Fh code (`[emcy] motor_fault_code`).
    pub motor_fault_code: Option<(u16, u8)>,
}

/// EtherCAT state machine rules of a profile (`[esm]`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct EsmRules {
    /// SAFEOP → OP only after the master wrote the outputs once.
    pub op_requires_outputs: bool,
    /// How long a SAFEOP → OP request may wait for the first SYNC0 / outputs, ms.
    pub safeop_op_timeout_ms: u32,
    /// CiA402 error code raised when the state leaves OP while the drive is in Operation
    /// Enabled (`None`: the drive is only disabled).
    pub op_exit_while_enabled_error: Option<MotorFaultCode>,
    /// AL errors of the stack that the drive also reports as one of its errors, by AL status
    /// code (ascending, unique).
    pub al_error_alarms: Vec<(u16, MotorFaultCode)>,
    /// AL status codes with the manual's ERR LED pattern (ascending, unique).
    pub al_error_leds: Vec<(u16, ErrLed)>,
    /// The drive error raised when the input port's link is lost (INIT, AL status code 0).
    pub link_loss_error: Option<MotorFaultCode>,
    /// AL status code of a counted sync error (0x001A or 0x002C).
    pub sync_error_al_code: u16,
    /// SYNC0 must start this long after SAFEOP was entered (ms), else PREOP + 0x002D.
    pub sync_lock_timeout_ms: Option<u32>,
    /// The drive error raised when the ESC counts a PDI error (INIT, AL status code 0).
    pub pdi_error: Option<MotorFaultCode>,
    /// Outputs lost in a row in the cyclic synchronous modes.
    pub lost_outputs: Option<LostOutputs>,
}

impl LostOutputs {
    /// [`Self::while_values`] as the stack reads the entry (`data_type`, at most 32 bits):
    /// little-endian bytes zero-extended to a u32 (a SINT −1 reads 0xFF). `None` if a value
    /// does not fit the type.
    pub fn raw_values(&self, data_type: DataType) -> Option<Vec<u32>> {
        let (min, max) = data_type.int_range()?;
        let bits = data_type.fixed_bits()?;
        if bits > 32 {
            return None;
        }
        let mask = if bits == 32 {
            u32::MAX
        } else {
            (1u32 << bits) - 1
        };
        self.while_values
            .iter()
            .map(|&v| {
                let v = i128::from(v);
                // Two's complement truncated to the entry's width.
                ((min..=max).contains(&v)).then_some((v as i64 as u32) & mask)
            })
            .collect()
    }
}

/// `[esm] lost_outputs`, resolved.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LostOutputs {
    /// The parameter with the limit (lost cycles in a row; 0 = off), read at power-on.
    pub limit_parameter: (u16, u8),
    /// The entry that selects when the outputs are supervised.
    pub while_entry: (u16, u8),
    /// Its values under which they are, as written in the file.
    pub while_values: Vec<i64>,
    /// 0x001A or 0x002C.
    pub al_status_code: u16,
    /// The drive error.
    pub error: MotorFaultCode,
}

/// What an SDO download to an entry mapped in the active RxPDO mapping does in SAFEOP/OP.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RxMappedWrite {
    /// Refused with abort 0x06010006 (ETG.1000.6 Table 41).
    Blocked,
    /// Written (the next process-data cycle overwrites it).
    Allowed,
}

impl RxMappedWrite {
    /// Parses the profile-file spelling.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "blocked" => Some(Self::Blocked),
            "allowed" => Some(Self::Allowed),
            _ => None,
        }
    }
    /// The variant name of `firmware::od::RxMappedWrite`.
    pub fn rust_variant(self) -> &'static str {
        match self {
            Self::Blocked => "Blocked",
            Self::Allowed => "Allowed",
        }
    }
}

/// Number of internal motor faults (`firmware::motor::MotorFault::ALL.len()`).
pub const MOTOR_FAULT_COUNT: usize = 15;

/// The names of the firmware's internal motor faults (`firmware::motor::MotorFault::name()`), in
/// code order (fault code 1 first): the keys of the profile's `[motor_faults]` table. od-gen
/// cannot depend on the firmware, so the list is kept here; the generated code checks at compile
/// time that it equals the firmware's (`check::motor_fault_names_agree`).
pub const MOTOR_FAULT_NAMES: [&str; MOTOR_FAULT_COUNT] = [
    "over_current",
    "motor_overload",
    "drive_overload",
    "bus_over_voltage",
    "bus_under_voltage",
    "over_speed",
    "encoder_signal_loss",
    "encoder_jump",
    "encoder_crc",
    "drive_over_temperature",
    "motor_over_temperature",
    "following_error",
    "current_offset",
    "alignment",
    "identification",
];

/// A checked profile with all derived objects.
#[derive(Clone, Debug, PartialEq)]
pub struct Profile {
    /// Name (`sdv3-e`; [`Self::module_name`] is the Rust module name).
    pub name: String,
    /// Where it came from (path or `builtin:<name>`), for messages.
    pub source: String,
    /// Free text.
    pub description: String,
    /// Vendor.
    pub vendor: Vendor,
    /// Identity.
    pub device: Device,
    /// SII configuration.
    pub eeprom: Eeprom,
    /// SyncManagers.
    pub sm: SmLayout,
    /// Mailbox.
    pub mailbox: Mailbox,
    /// Synchronisation.
    pub sync: Sync,
    /// DC op modes.
    pub dc_op_modes: Vec<DcOpMode>,
    /// Maximum entries per PDO.
    pub max_pdo_entries: u8,
    /// How many PDOs 1C12h/1C13h assign at most (`None`: every PDO of the direction).
    pub max_assigned: Option<u8>,
    /// Largest byte length of one PDO.
    pub max_pdo_bytes: u16,
    /// Largest process image per direction in bytes.
    pub max_process_bytes: u16,
    /// SDO download to an RxPDO-mapped entry in SAFEOP/OP.
    pub sdo_write_to_rx_mapped: RxMappedWrite,
    /// ESM rules.
    pub esm: EsmRules,
    /// Error register and emergency rules (`[emcy]`).
    pub emcy: EmcyRules,
    /// A drive (the firmware's profiles) or another device on the slave stack.
    pub kind: ProfileKind,
    /// 603Fh error code and EMCY bytes of each internal motor fault, in the order of
    /// [`MOTOR_FAULT_NAMES`] (`[motor_faults]`); all 0 in a device profile.
    pub motor_faults: [MotorFaultCode; MOTOR_FAULT_COUNT],
    /// The drive's alarm table (`[[alarm]]`).
    pub alarms: Vec<Alarm>,
    /// Objects that show the alarms by number (`[alarm_objects]`).
    pub alarm_objects: AlarmObjects,
    /// Drive conditions reported as warnings (`[warnings]`), in the order of
    /// [`WarningCondition::KEYS`].
    pub warnings: Vec<Warning>,
    /// Unit conversions of the position and velocity objects (`[units]`).
    pub units: Units,
    /// Choices where the manual is silent, wrong or contradicts itself (`[[decision]]`).
    pub decisions: Vec<Decision>,
    /// Object ranges copied to further axes: (first, last, offset) (`[[replicate]]`).
    pub replicate: Vec<(u16, u16, u16)>,
    /// Parameter storage rules (`[storage]`).
    pub storage: StorageRules,
    /// `[[adjusting]]`: adjusting-service objects.
    pub adjusting: Vec<Adjusting>,
    /// `[[split_value]]`: settings held by a whole object and two parameters that split it.
    pub split_values: Vec<SplitValue>,
    /// `[cia402]`: CiA402 behaviour rules.
    pub cia402: Cia402Rules,
    /// RxPDOs, sorted by index.
    pub rx_pdos: Vec<Pdo>,
    /// TxPDOs, sorted by index.
    pub tx_pdos: Vec<Pdo>,
    /// All objects (declared and derived), sorted by index.
    pub objects: Vec<Object>,
}

/// One side of a unit factor (`[units]`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Operand {
    /// A constant.
    Const(u32),
    /// An unsigned entry, read at run time: (index, subindex).
    Entry(u16, u8),
    /// The motor encoder's increments per revolution (`"counts_per_rev"`).
    CountsPerRev,
}

/// internal = value × numerator / denominator × scale.0 / scale.1 (`[units]`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Factor {
    /// Numerator.
    pub numerator: Operand,
    /// Denominator.
    pub denominator: Operand,
    /// Constant rational factor.
    pub scale: (u32, u32),
}

impl Factor {
    /// 1:1.
    pub const ONE: Self = Self {
        numerator: Operand::Const(1),
        denominator: Operand::Const(1),
        scale: (1, 1),
    };
}

/// How the position and velocity objects (607Ah/6064h, 60FFh/606Ch) convert to increments and
/// increments/s (`[units]`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Units {
    /// Increments per position unit.
    pub position: Factor,
    /// Increments/s per velocity unit.
    pub velocity: Factor,
    /// The acceleration unit.
    pub acceleration: Acceleration,
    /// Increments/s per unit of the velocity window 606Dh and threshold 606Fh.
    pub velocity_window: Factor,
    /// ‰ of the rated torque per unit of the torque objects.
    pub torque: Factor,
}

/// What an acceleration object (6083h–6085h, 609Ah) counts (`[units] acceleration`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Acceleration {
    /// The velocity unit per second (CiA402's default).
    #[default]
    VelocityPerSecond,
    /// Increments/s² per unit.
    Factor(Factor),
    /// The time in ms from 0 to this many rpm (the SDV3-E's 6083h/6084h).
    MsToRpm(u32),
}

/// What an EMCY message carries for an error: bytes 0–1 and the manufacturer field, bytes 3–7
/// (byte 2 is the error register 1001h at the time).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EmcyCode {
    /// EMCY error code (bytes 0–1).
    pub code: u16,
    /// Manufacturer-specific error field (bytes 3–7).
    pub data: [u8; 5],
}

/// What the drive reports for one internal motor fault.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MotorFaultCode {
    /// 603Fh.
    pub error_code: u16,
    /// The EMCY message.
    pub emcy: EmcyCode,
    /// The `[[alarm]]` it is (its position in [`Profile::alarms`]); `None` for a code without an
    /// alarm. An alarm is known by this, not by its codes, which several rows may share.
    pub alarm: Option<usize>,
}

/// One row of a drive's alarm table (`[[alarm]]`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Alarm {
    /// The code the drive displays (unique).
    pub display: String,
    /// Name.
    pub name: String,
    /// 603Fh while active.
    pub error_code: u16,
    /// The EMCY message.
    pub emcy: EmcyCode,
    /// Cleared by a fault reset.
    pub resettable: bool,
    /// A warning (statusword bit 7), not a fault.
    pub warning: bool,
    /// Cause / manual text.
    pub description: String,
}

/// What an alarm's number is, in the objects that show alarms by number (`[alarm_objects]`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AlarmNumber {
    /// EMCY byte 3, the first byte of the manufacturer field (the SDV3-E's error No.).
    ErrorNumber,
    /// The digits of the display (the RSE's AL.221 → 221).
    Display,
    /// The 603Fh code.
    ErrorCode,
}

impl AlarmNumber {
    /// Parses the profile-file spelling.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "error_number" => Some(Self::ErrorNumber),
            "display" => Some(Self::Display),
            "error_code" => Some(Self::ErrorCode),
            _ => None,
        }
    }

    /// `alarm`'s number (`None`: its display has no digits).
    pub fn of(self, alarm: &Alarm) -> Option<u32> {
        match self {
            Self::ErrorNumber => Some(u32::from(alarm.emcy.data[0])),
            Self::ErrorCode => Some(u32::from(alarm.error_code)),
            Self::Display => {
                let digits: String = alarm.display.chars().filter(char::is_ascii_digit).collect();
                digits.parse().ok()
            }
        }
    }
}

/// What one subindex of an alarm record shows (`[alarm_objects] history_fields`); the names are
/// the firmware's `alarm_log::RecordField` variants.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RecordField {
    /// The alarm's number.
    Number,
    /// Hours the drive had been powered at the alarm.
    PowerOnHours,
    /// How long the motor had been running (power stage on): s below 32768, else 32768 + h.
    RunningTime,
    /// Motor speed at the alarm, rpm.
    SpeedRpm,
    /// Motor speed 5 ms before the alarm, rpm.
    SpeedRpm5msBefore,
    /// Speed demand at the alarm, rpm.
    DemandSpeedRpm,
    /// Torque demand at the alarm, % of the rated torque.
    DemandTorquePercent,
    /// Motor current at the alarm, % of the rated current.
    CurrentPercent,
    /// Actual torque at the alarm, % of the rated torque.
    TorquePercent,
    /// DC-link voltage at the alarm, V.
    BusVoltage,
    /// Position demand at the alarm, position units.
    DemandPosition,
    /// The mode of operation at the alarm (6061h).
    Mode,
    /// Always 0 (a reserved field, or one the drive does not measure).
    Zero,
}

impl RecordField {
    /// Every field, in the order of the firmware's enum.
    pub const ALL: [Self; 13] = [
        Self::Number,
        Self::PowerOnHours,
        Self::RunningTime,
        Self::SpeedRpm,
        Self::SpeedRpm5msBefore,
        Self::DemandSpeedRpm,
        Self::DemandTorquePercent,
        Self::CurrentPercent,
        Self::TorquePercent,
        Self::BusVoltage,
        Self::DemandPosition,
        Self::Mode,
        Self::Zero,
    ];

    /// The profile-file spelling.
    pub fn name(self) -> &'static str {
        match self {
            Self::Number => "number",
            Self::PowerOnHours => "power_on_hours",
            Self::RunningTime => "running_time",
            Self::SpeedRpm => "speed_rpm",
            Self::SpeedRpm5msBefore => "speed_rpm_5ms_before",
            Self::DemandSpeedRpm => "demand_speed_rpm",
            Self::DemandTorquePercent => "demand_torque_percent",
            Self::CurrentPercent => "current_percent",
            Self::TorquePercent => "torque_percent",
            Self::BusVoltage => "bus_voltage",
            Self::DemandPosition => "demand_position",
            Self::Mode => "mode",
            Self::Zero => "zero",
        }
    }

    /// The firmware's variant name.
    pub fn rust_variant(self) -> &'static str {
        match self {
            Self::Number => "Number",
            Self::PowerOnHours => "PowerOnHours",
            Self::RunningTime => "RunningTime",
            Self::SpeedRpm => "SpeedRpm",
            Self::SpeedRpm5msBefore => "SpeedRpm5msBefore",
            Self::DemandSpeedRpm => "DemandSpeedRpm",
            Self::DemandTorquePercent => "DemandTorquePercent",
            Self::CurrentPercent => "CurrentPercent",
            Self::TorquePercent => "TorquePercent",
            Self::BusVoltage => "BusVoltage",
            Self::DemandPosition => "DemandPosition",
            Self::Mode => "Mode",
            Self::Zero => "Zero",
        }
    }

    /// Parses the profile-file spelling.
    pub fn parse(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|f| f.name() == s)
    }
}

/// A drive condition a profile reports as a warning (`[warnings]`; the firmware's
/// `alarm_log::WarningCondition`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WarningCondition {
    /// The motor's I²t load at or above `percent` of its trip level.
    MotorOverload {
        /// % of the trip level.
        percent: u8,
    },
    /// The drive's (power stage) I²t load at or above `percent` of its trip level.
    DriveOverload {
        /// % of the trip level.
        percent: u8,
    },
    /// The positive limit switch is actuated.
    PositiveLimit,
    /// The negative limit switch is actuated.
    NegativeLimit,
    /// The last homing run failed (statusword bit 13).
    HomingError,
}

impl WarningCondition {
    /// The profile-file keys.
    pub const KEYS: [&'static str; 5] = [
        "motor_overload",
        "drive_overload",
        "homing_error",
        "positive_limit",
        "negative_limit",
    ];

    /// The firmware's value.
    pub fn rust_value(self) -> String {
        match self {
            Self::MotorOverload { percent } => format!("MotorOverload {{ percent: {percent} }}"),
            Self::DriveOverload { percent } => format!("DriveOverload {{ percent: {percent} }}"),
            Self::PositiveLimit => "PositiveLimit".into(),
            Self::NegativeLimit => "NegativeLimit".into(),
            Self::HomingError => "HomingError".into(),
        }
    }
}

/// One `[warnings]` row.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Warning {
    /// When it holds.
    pub condition: WarningCondition,
    /// 603Fh and EMCY while it holds.
    pub report: MotorFaultCode,
}

/// Objects that show the alarms by number (`[alarm_objects]`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AlarmObjects {
    /// What an alarm's number is.
    pub number: AlarmNumber,
    /// The ARRAY of the active alarms' numbers.
    pub active: Option<u16>,
    /// The object of the last alarms' numbers, newest at subindex 1.
    pub history: Option<u16>,
    /// The entry that clears the history when 1 is written.
    pub history_clear: Option<(u16, u8)>,
    /// The record selector entry, the record object and its fields.
    pub history_record: Option<HistoryRecord>,
}

impl Default for AlarmObjects {
    fn default() -> Self {
        Self {
            number: AlarmNumber::ErrorNumber,
            active: None,
            history: None,
            history_clear: None,
            history_record: None,
        }
    }
}

/// Alarm records shown one at a time (`history_select` + `history_record`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct HistoryRecord {
    /// The selector entry (1 = the newest record).
    pub select: (u16, u8),
    /// The RECORD object.
    pub object: u16,
    /// What its subindexes 1.. show.
    pub fields: Vec<RecordField>,
}

/// A documented choice of the profile (`[[decision]]`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Decision {
    /// What it is about.
    pub subject: String,
    /// What the manual says.
    pub manual: String,
    /// What the profile does.
    pub choice: String,
    /// Why.
    pub reason: String,
}

/// What a profile describes (profile key `kind`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProfileKind {
    /// A CiA402 servo drive: the firmware's profiles, with `[motor_faults]`.
    Drive,
    /// Any other EtherCAT device built on the slave stack (an I/O module, ...): the object
    /// dictionary, SII and ESI only.
    Device,
}

impl ProfileKind {
    /// Parses the profile-file spelling (`"drive"`, `"device"`).
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "drive" => Some(Self::Drive),
            "device" => Some(Self::Device),
            _ => None,
        }
    }
}

impl Profile {
    /// The Rust module name of the generated dictionary: the name with `-` as `_`.
    pub fn module_name(&self) -> String {
        self.name.replace('-', "_")
    }
    /// The object with this index.
    pub fn object(&self, index: u16) -> Option<&Object> {
        self.objects.iter().find(|o| o.index == index)
    }
    /// The entry `index:subindex`.
    pub fn entry(&self, index: u16, subindex: u8) -> Option<&Entry> {
        self.object(index).and_then(|o| o.entry(subindex))
    }
    /// The role entry `index:subindex` plays: its own, or on a further axis' copy (e.g. 6841h
    /// of the Σ-V-SD for two axes) the role of the first axis' original.
    pub fn role_of(&self, index: u16, subindex: u8) -> Option<Role> {
        let own = self.entry(index, subindex).and_then(|e| e.role);
        own.or_else(|| {
            self.objects.iter().find_map(|o| {
                let copied = (1..self.axis_count())
                    .any(|axis| o.index != index && self.axis_index(o.index, axis) == index);
                copied
                    .then(|| o.entry(subindex).and_then(|e| e.role))
                    .flatten()
            })
        })
    }
    /// The drive's axes (CiA402 channels, `[device] ds402_channels`), at least one.
    pub fn axis_count(&self) -> u8 {
        self.device.ds402_channels.max(1)
    }
    /// Axis `axis`'s (0 = the first) copy of object `index`: shifted `axis` times by the offset
    /// of the `[[replicate]]` rule whose range holds `index` (e.g. 607Ah → 687Ah on the
    /// Σ-V-SD's second axis); `index` itself outside every rule (an object of the whole unit)
    /// or when the shift leaves the index space.
    pub fn axis_index(&self, index: u16, axis: u8) -> u16 {
        self.replicate
            .iter()
            .find(|(first, last, _)| (*first..=*last).contains(&index))
            .and_then(|(_, _, offset)| {
                let shifted = u32::from(index) + u32::from(*offset) * u32::from(axis);
                u16::try_from(shifted).ok()
            })
            .unwrap_or(index)
    }
    /// Whether `e` of `o` is a stored parameter, a "backup" entry ([`StorageRules::stores`]).
    pub fn is_backup(&self, o: &Object, e: &Entry) -> bool {
        self.storage.stores(o, e)
    }
    /// Bits of the default-assigned RxPDOs (SM2 default size × 8).
    pub fn outputs_bits(&self) -> u32 {
        self.rx_pdos
            .iter()
            .filter(|p| p.assigned)
            .map(Pdo::bits)
            .sum()
    }
    /// Bits of the default-assigned TxPDOs (SM3 default size × 8).
    pub fn inputs_bits(&self) -> u32 {
        self.tx_pdos
            .iter()
            .filter(|p| p.assigned)
            .map(Pdo::bits)
            .sum()
    }
}

/// One `[[adjusting]]` service: a maintenance request/reply object (Σ-V-SD 2310h).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Adjusting {
    /// The RECORD (:01 command, :02 status, :03 reply).
    pub object: u16,
    /// The axis it adjusts (1 or 2).
    pub axis: u8,
    /// A selection with no further request for this long is aborted, ms.
    pub abort_after_ms: u32,
    /// An execution that has not ended after this long ends in error, ms.
    pub time_limit_ms: u32,
    /// The adjustments.
    pub commands: Vec<AdjustingCommand>,
}

/// One adjustment of an [`Adjusting`] service.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AdjustingCommand {
    /// Request code.
    pub code: u16,
    /// What it does.
    pub action: AdjustAction,
    /// Needs the preparation step.
    pub preparation: bool,
}

/// What an adjustment does (`firmware::adjust::Action`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AdjustAction {
    /// Measure the current-sensor offsets again.
    CurrentOffsetCalibration,
    /// Clear the absolute encoder's multi-turn data.
    MultiTurnReset,
    /// Write the multi-turn limit into the encoder.
    MultiTurnLimitSetting,
}

impl AdjustAction {
    /// The profile-file spellings, in declaration order.
    pub const NAMES: [&'static str; 3] = [
        "current_offset_calibration",
        "multi_turn_reset",
        "multi_turn_limit_setting",
    ];

    /// Parses the profile-file spelling.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "current_offset_calibration" => Some(Self::CurrentOffsetCalibration),
            "multi_turn_reset" => Some(Self::MultiTurnReset),
            "multi_turn_limit_setting" => Some(Self::MultiTurnLimitSetting),
            _ => None,
        }
    }

    /// The firmware's variant name.
    pub fn rust_variant(self) -> &'static str {
        match self {
            Self::CurrentOffsetCalibration => "CurrentOffsetCalibration",
            Self::MultiTurnReset => "MultiTurnReset",
            Self::MultiTurnLimitSetting => "MultiTurnLimitSetting",
        }
    }

    /// The profile-file spelling.
    pub fn name(self) -> &'static str {
        match self {
            Self::CurrentOffsetCalibration => Self::NAMES[0],
            Self::MultiTurnReset => Self::NAMES[1],
            Self::MultiTurnLimitSetting => Self::NAMES[2],
        }
    }
}

/// An ERR LED pattern (ETG.1300 Table 4) a manual gives an AL error (`firmware::od::ErrLed`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ErrLed {
    /// Blinking.
    Blinking,
    /// Single flash.
    SingleFlash,
    /// Double flash.
    DoubleFlash,
    /// On.
    On,
}

impl ErrLed {
    /// Parses the profile-file spelling.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "blinking" => Some(Self::Blinking),
            "single_flash" => Some(Self::SingleFlash),
            "double_flash" => Some(Self::DoubleFlash),
            "on" => Some(Self::On),
            _ => None,
        }
    }

    /// The firmware's variant name.
    pub fn rust_variant(self) -> &'static str {
        match self {
            Self::Blinking => "Blinking",
            Self::SingleFlash => "SingleFlash",
            Self::DoubleFlash => "DoubleFlash",
            Self::On => "On",
        }
    }

    /// Human text.
    pub fn text(self) -> &'static str {
        match self {
            Self::Blinking => "blinking",
            Self::SingleFlash => "single flash",
            Self::DoubleFlash => "double flash",
            Self::On => "on",
        }
    }
}

/// CiA402 behaviour a manual adds to the standard (`[cia402]`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Cia402Rules {
    /// The error raised when enable operation is requested with no mode selected.
    pub enable_without_mode_error: Option<MotorFaultCode>,
    /// A 6060h change during a homing run raises this error.
    pub mode_change_while_homing_error: Option<MotorFaultCode>,
    /// Shutdown and disable operation end in Switch On Disabled.
    pub stops_end_switched_off: bool,
    /// Switched On needs the main power.
    pub switch_on_requires_main_power: bool,
    /// Profile position: controlword bit 6 set = absolute.
    pub pp_bit6_absolute: bool,
    /// Profile position: controlword bit 9 is honoured.
    pub pp_change_on_set_point: bool,
    /// Profile position: a set-point without bit 5 may wait in a buffer while a move runs.
    pub pp_set_point_buffer: bool,
    /// The homing methods the drive runs (6098h values), ascending.
    pub homing_methods: Vec<i8>,
    /// `(vendor method, CiA402 method)`: vendor numbers that run a CiA402 method.
    pub homing_method_aliases: Vec<(i8, i8)>,
    /// 60B9h bit 7 (15).
    pub touch_probe_bit7: TouchProbeBit7,
    /// 60B9h bit 6 (14) shows the trigger source.
    pub touch_probe_bit6_source: bool,
    /// The 60B8h bits the profile defines (the others are ignored).
    pub touch_probe_function_bits: u16,
    /// Touch probe 1 is off while homing runs.
    pub touch_probe1_off_while_homing: bool,
    /// Touch probe 2 is off while homing runs.
    pub touch_probe2_off_while_homing: bool,
    /// A following error beyond the window for the timeout is a fault.
    pub following_error_fault: bool,
    /// 60FDh bits 0/1 are the positive/negative limit switch.
    pub digital_inputs_limits_swapped: bool,
    /// 60FDh bit 3 (interlock) stays 0.
    pub digital_inputs_without_interlock: bool,
    /// 6065h = 0 switches the following-error check off.
    pub following_error_zero_window_off: bool,
    /// 607Ch is added to every position object.
    pub home_offset_added: bool,
    /// With an absolute encoder, 607Ch at power-on is added to every position object.
    pub home_offset_added_absolute: bool,
    /// 1010h subindexes after whose store Operation Enabled needs a power-on first.
    pub store_requires_power_cycle: Vec<u8>,
    /// The probe inputs must be assigned to a physical input first.
    pub touch_probe_inputs: Option<TouchProbeInputs>,
    /// CSP/IP targets at or above this speed (increments per ms) are ignored.
    pub max_interpolation_speed: Option<u32>,
    /// A failed homing run also raises this fault.
    pub homing_error_alarm: Option<MotorFaultCode>,
    /// How the safe-torque-off input shows (`[cia402.safe_torque_off]`).
    pub safe_torque_off: Option<SafeTorqueOff>,
    /// A statusword bit showing the torque demand at its limit
    /// (`[cia402.torque_limit_statusword]`).
    pub torque_limit_statusword: Option<StatuswordFlag>,
    /// The parameter whose value 1 (at power-on) makes CSP extrapolate over a cycle without
    /// new outputs.
    pub csp_extrapolation: Option<(u16, u8)>,
    /// Option codes the profile defines where CiA402 reserves them.
    pub stop_codes: Vec<StopCode>,
    /// 605Eh is accepted and ignored: a fault disables the drive function at once.
    pub fault_reaction_ignored: bool,
    /// Statusword bits 10-13 of the modes whose manual table differs from CiA402's
    /// (`[[cia402.mode_statusword]]`), one entry per mode.
    pub mode_statusword: Vec<ModeStatusword>,
    /// A statusword bit showing that homing has completed since power-on
    /// (`[cia402.home_found_statusword]`).
    pub home_found_statusword: Option<StatuswordFlag>,
    /// The option codes the drive works with where the profile has no object for them, in the
    /// order of [`StopCode::OBJECTS`] (`[cia402.option_codes_without_object]`).
    pub option_codes_without_object: [Option<i16>; 5],
    /// Quick stop, shutdown and disable operation disable the drive at once in PT and CST.
    pub torque_modes_stop_at_once: bool,
    /// Halt in PT and CST takes the torque demand to zero.
    pub torque_modes_halt_zero_torque: bool,
    /// The parameter whose value 1 (at power-on) switches the software position limits off.
    pub software_limits_off: Option<(u16, u8)>,
    /// The software position limits act only after homing or with an absolute encoder.
    pub software_limits_need_reference: bool,
    /// 607Dh is relative to the machine home: the limits compared are 607Dh - 607Ch.
    pub software_limits_less_home_offset: bool,
    /// The current-position homing methods (35, 37) also run while the drive is disabled.
    pub homing_here_while_disabled: bool,
    /// A homing start while the drive is disabled is a homing error.
    pub homing_start_while_disabled_error: bool,
    /// The current-position homing methods run only at speed zero (else a homing error).
    pub homing_here_needs_speed_zero: bool,
    /// A mode change into PP or homing with controlword bit 4 set starts at once.
    pub mode_entry_starts: bool,
    /// The torque-reached parameters A, B, C (0.1 % of the rated torque): on above A + B, off
    /// below A + C.
    pub torque_reached: Option<[(u16, u8); 3]>,
    /// The ranges of the unit factors' ratios and the error outside them.
    pub unit_ranges: Option<UnitRanges>,
}

/// `[cia402.unit_ranges]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct UnitRanges {
    /// Raised when a factor taking effect is outside its range.
    pub error: MotorFaultCode,
    /// The position factor's range.
    pub position: Option<RatioRange>,
    /// The velocity factor's range.
    pub velocity: Option<RatioRange>,
    /// The acceleration factor's range (before its scale).
    pub acceleration: Option<RatioRange>,
    /// The torque factor's range (before its scale).
    pub torque: Option<RatioRange>,
}

/// The range a unit factor's ratio may have (the firmware's own type).
pub use cia402::units::RatioRange;

/// What statusword bits 10-13 show in a mode (`firmware: cia402::mode_status::Override`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ModeStatusword {
    /// The 6060h value.
    pub mode: i8,
    /// Bits 10, 11, 12, 13.
    pub bits: [ModeBit; 4],
}

/// A condition a mode-specific statusword bit shows: the firmware's own type, so that the
/// generator and the firmware agree on what a profile may name.
pub use cia402::mode_status::Shows as ModeBit;

/// The profile-file spellings of [`ModeBit`]s and what each shows (for the profile document).
pub const MODE_BITS: [(&str, ModeBit, &str); 13] = [
    ("nothing", ModeBit::Nothing, "–"),
    ("target_reached", ModeBit::TargetReached, "target reached"),
    (
        "internal_limit",
        ModeBit::InternalLimit,
        "internal limit active",
    ),
    (
        "set_point_acknowledge",
        ModeBit::SetPointAcknowledge,
        "set-point acknowledge",
    ),
    ("speed_zero", ModeBit::SpeedZero, "speed zero (606Fh/6070h)"),
    (
        "following_error",
        ModeBit::FollowingError,
        "following error",
    ),
    (
        "follows_command",
        ModeBit::FollowsCommand,
        "drive follows the command value",
    ),
    (
        "synchronised",
        ModeBit::Synchronised,
        "synchronisation good",
    ),
    (
        "homing_attained",
        ModeBit::HomingAttained,
        "homing attained",
    ),
    ("homing_error", ModeBit::HomingError, "homing error"),
    (
        "interpolation_active",
        ModeBit::InterpolationActive,
        "ip mode active",
    ),
    (
        "software_limit",
        ModeBit::SoftwareLimit,
        "position command or actual position beyond 607Dh",
    ),
    (
        "torque_reached",
        ModeBit::TorqueReached,
        "torque reached ([cia402] torque_reached levels, with hysteresis)",
    ),
];

/// The condition a profile file names.
pub fn parse_mode_bit(s: &str) -> Option<ModeBit> {
    MODE_BITS
        .iter()
        .find(|(n, _, _)| *n == s)
        .map(|(_, b, _)| *b)
}

/// What a bit showing `b` means, for the profile document.
pub fn describe_mode_bit(b: ModeBit) -> &'static str {
    MODE_BITS
        .iter()
        .find(|(_, m, _)| *m == b)
        .map_or("–", |(_, _, d)| d)
}

/// An option code of 605Ah–605Eh a profile defines (`firmware: cia402::stop::VendorCode`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StopCode {
    /// The option-code object (605Ah–605Eh).
    pub object: u16,
    /// The code.
    pub code: i16,
    /// How the motor is brought to rest.
    pub stop: StopRamp,
    /// The motor is held at rest afterwards instead of disabled.
    pub hold: bool,
}

impl StopCode {
    /// The option-code objects and the firmware's `cia402::stop::Cause` of each.
    pub const OBJECTS: [(u16, &'static str); 5] = [
        (0x605A, "QuickStop"),
        (0x605B, "Shutdown"),
        (0x605C, "DisableOperation"),
        (0x605D, "Halt"),
        (0x605E, "Fault"),
    ];

    /// The firmware's `Cause` variant of the object.
    pub fn cause_variant(&self) -> &'static str {
        Self::OBJECTS
            .iter()
            .find(|(index, _)| *index == self.object)
            .map_or("QuickStop", |(_, cause)| cause)
    }
}

/// How a stop brings the motor to rest (`firmware: cia402::stop::Deceleration`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StopRamp {
    /// Disable the drive function at once.
    Coast,
    /// The slow-down ramp 6084h.
    ProfileRamp,
    /// The quick-stop ramp 6085h.
    QuickStopRamp,
    /// The current limit.
    CurrentLimit,
    /// The voltage limit.
    VoltageLimit,
}

impl StopRamp {
    /// The profile-file spellings.
    pub const NAMES: [&'static str; 5] = [
        "coast",
        "profile_ramp",
        "quick_stop_ramp",
        "current_limit",
        "voltage_limit",
    ];

    /// Parses the profile-file spelling.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "coast" => Some(Self::Coast),
            "profile_ramp" => Some(Self::ProfileRamp),
            "quick_stop_ramp" => Some(Self::QuickStopRamp),
            "current_limit" => Some(Self::CurrentLimit),
            "voltage_limit" => Some(Self::VoltageLimit),
            _ => None,
        }
    }

    /// The firmware's variant name.
    pub fn rust_variant(self) -> &'static str {
        match self {
            Self::Coast => "Coast",
            Self::ProfileRamp => "ProfileRamp",
            Self::QuickStopRamp => "QuickStopRamp",
            Self::CurrentLimit => "CurrentLimit",
            Self::VoltageLimit => "VoltageLimit",
        }
    }

    /// What the ramp is, for the documentation.
    pub fn describe(self) -> &'static str {
        match self {
            Self::Coast => "disable the drive function at once",
            Self::ProfileRamp => "slow down on the slow-down ramp 6084h",
            Self::QuickStopRamp => "slow down on the quick-stop ramp 6085h",
            Self::CurrentLimit => "slow down at the current limit",
            Self::VoltageLimit => "slow down at the voltage limit",
        }
    }
}

/// A manufacturer-specific statusword bit (8, 14 or 15) and its value while its condition
/// holds (`firmware: profile::StatuswordFlag`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StatuswordFlag {
    /// The bit.
    pub bit: u8,
    /// Its value while the condition holds.
    pub while_active: bool,
}

/// `[cia402.safe_torque_off]` (`firmware: profile::SafeTorqueOffDisplay`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SafeTorqueOff {
    /// Statusword bit and its value while safe torque off holds.
    pub statusword: StatuswordFlag,
    /// 60FDh bits of channel 1 and 2 (16-31, distinct).
    pub digital_input_bits: [u8; 2],
}

/// `[[split_value]]` (`firmware: profile::SplitValue`): `whole` = `high` × `radix` + `low`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SplitValue {
    /// The whole value's entry.
    pub whole: (u16, u8),
    /// The parameter with the high part.
    pub high: (u16, u8),
    /// The parameter with the low part.
    pub low: (u16, u8),
    /// The factor of the high part.
    pub radix: u32,
}

/// `[cia402.touch_probe_inputs]` (`firmware: profile::ProbeInputAssignment`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TouchProbeInputs {
    /// The parameters that hold an input's function.
    pub entries: Vec<(u16, u8)>,
    /// The function value of probe 1's and probe 2's input.
    pub functions: [u32; 2],
    /// Raised when a probe is enabled on its input while no entry holds its function.
    pub unassigned_error: MotorFaultCode,
}

/// What a profile shows in 60B9h bit 7 (15) (`firmware: cia402::touch_probe::Bit7`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TouchProbeBit7 {
    /// Nothing.
    #[default]
    None,
    /// Toggles on every stored position.
    ToggleOnStore,
    /// The probe input level.
    InputLevel,
}

impl TouchProbeBit7 {
    /// The profile-file spellings.
    pub const NAMES: [&'static str; 3] = ["none", "toggle", "level"];

    /// Parses the profile-file spelling.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "none" => Some(Self::None),
            "toggle" => Some(Self::ToggleOnStore),
            "level" => Some(Self::InputLevel),
            _ => None,
        }
    }

    /// The firmware's variant name.
    pub fn rust_variant(self) -> &'static str {
        match self {
            Self::None => "None",
            Self::ToggleOnStore => "ToggleOnStore",
            Self::InputLevel => "InputLevel",
        }
    }
}

/// The homing methods CiA402 defines (IEC 61800-7-201; 35 is the older number of 37). The
/// firmware's `cia402::homing::method` implements exactly these.
pub const CIA402_HOMING_METHODS: [i8; 32] = [
    1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26, 27, 28,
    29, 30, 33, 34, 35, 37,
];

impl Default for Cia402Rules {
    /// CiA402 as written.
    fn default() -> Self {
        Self {
            enable_without_mode_error: None,
            mode_change_while_homing_error: None,
            stops_end_switched_off: false,
            switch_on_requires_main_power: false,
            pp_bit6_absolute: false,
            pp_change_on_set_point: true,
            pp_set_point_buffer: true,
            homing_methods: CIA402_HOMING_METHODS.to_vec(),
            homing_method_aliases: Vec::new(),
            touch_probe_bit7: TouchProbeBit7::None,
            touch_probe_bit6_source: false,
            touch_probe_function_bits: u16::MAX,
            touch_probe1_off_while_homing: false,
            touch_probe2_off_while_homing: false,
            following_error_fault: true,
            digital_inputs_limits_swapped: false,
            digital_inputs_without_interlock: false,
            following_error_zero_window_off: false,
            home_offset_added: false,
            home_offset_added_absolute: false,
            store_requires_power_cycle: Vec::new(),
            touch_probe_inputs: None,
            max_interpolation_speed: None,
            homing_error_alarm: None,
            safe_torque_off: None,
            torque_limit_statusword: None,
            csp_extrapolation: None,
            stop_codes: Vec::new(),
            fault_reaction_ignored: false,
            mode_statusword: Vec::new(),
            home_found_statusword: None,
            option_codes_without_object: [None; 5],
            torque_modes_stop_at_once: false,
            torque_modes_halt_zero_torque: false,
            software_limits_off: None,
            software_limits_need_reference: false,
            software_limits_less_home_offset: false,
            homing_here_while_disabled: false,
            homing_start_while_disabled_error: false,
            homing_here_needs_speed_zero: false,
            mode_entry_starts: false,
            torque_reached: None,
            unit_ranges: None,
        }
    }
}
