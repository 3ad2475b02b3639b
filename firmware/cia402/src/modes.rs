//! Modes of operation (6060h requested, 6061h displayed; CiA402 §6.2) and the set-point each
//! mode hands to the axis.
//!
//! The profile modes (1, 3, 4) get their set-points from the drive's generators; the cyclic
//! synchronous modes pass the master's target of one quantity every bus cycle and
//! hold the others at the actual value; a mode the axis does not run holds the position.

/// 6060h value of profile position.
pub const PP: i8 = 1;
/// 6060h value of profile velocity.
pub const PV: i8 = 3;
/// 6060h value of profile torque.
pub const PT: i8 = 4;
/// 6060h value of homing.
pub const HM: i8 = crate::homing::HOMING;
/// 6060h value of interpolated position.
pub const IP: i8 = 7;
/// 6060h value of cyclic synchronous position.
pub const CSP: i8 = 8;
/// 6060h value of cyclic synchronous velocity.
pub const CSV: i8 = 9;
/// 6060h value of cyclic synchronous torque.
pub const CST: i8 = 10;
/// Manufacturer-specific (negative, CiA402): motor identification (commissioning); the results
/// land in the commissioned motor data (2100h in the standard profile).
pub const IDENTIFICATION: i8 = -1;

/// Statusword bit 12 (operation-mode specific): in [`IDENTIFICATION`], the identification
/// finished and its results are in the dictionary.
pub const STATUSWORD_IDENTIFIED: u16 = 1 << 12;

/// A mode of operation as the drive runs it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Mode {
    /// Profile position (1): the drive generates the move to each set-point.
    ProfilePosition,
    /// Profile velocity (3): the drive ramps to the target velocity.
    ProfileVelocity,
    /// Profile torque (4): the drive ramps to the target torque at the torque slope.
    ProfileTorque,
    /// Homing (6): the drive searches the home position of the homing method 6098h.
    Homing,
    /// Interpolated position (7): the master's absolute position 60C1h:01 every interpolation
    /// period ([`crate::interpolated_position`]).
    InterpolatedPosition,
    /// Cyclic synchronous position (8).
    CyclicPosition,
    /// Cyclic synchronous velocity (9).
    CyclicVelocity,
    /// Cyclic synchronous torque (10).
    CyclicTorque,
    /// Motor identification (−1).
    Identification,
    /// Any other value (no mode, or one this drive does not run): the position is held.
    Other,
}

impl Mode {
    /// The mode of a 6060h value.
    pub const fn from_object(value: i8) -> Self {
        match value {
            PP => Self::ProfilePosition,
            PV => Self::ProfileVelocity,
            PT => Self::ProfileTorque,
            HM => Self::Homing,
            IP => Self::InterpolatedPosition,
            CSP => Self::CyclicPosition,
            CSV => Self::CyclicVelocity,
            CST => Self::CyclicTorque,
            IDENTIFICATION => Self::Identification,
            _ => Self::Other,
        }
    }
}

/// 6502h bit of the manufacturer-specific mode −1 (motor identification) in the profiles that
/// have it (CiA402 leaves bits 16–31 to the manufacturer).
pub const SUPPORTED_IDENTIFICATION: u32 = 1 << 16;

/// Whether 6060h value `mode` is one 6502h `supported` lists: bit n−1 for mode n (1–32),
/// [`SUPPORTED_IDENTIFICATION`] for −1; 0 (no mode) always is.
pub fn is_supported(mode: i8, supported: u32) -> bool {
    match mode {
        0 => true,
        IDENTIFICATION => supported & SUPPORTED_IDENTIFICATION != 0,
        1..=32 => mode
            .unsigned_abs()
            .checked_sub(1)
            .and_then(|bit| supported.checked_shr(u32::from(bit)))
            .is_some_and(|s| s & 1 != 0),
        _ => false,
    }
}

/// The loop a set-point closes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Loop {
    /// Position loop (with velocity and torque feed-forward from the interpolation).
    Position,
    /// Speed loop.
    Velocity,
    /// Torque (current) loop.
    Torque,
}

/// The master's targets in axis units: 64-bit position in increments, velocity in
/// increments/s, torque in N·m.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Targets {
    /// Target position (607Ah, extended to 64 bits), `None` if the profile has none. In CSP
    /// with the position offset added: 607Ah + 60B0h in user units, converted once (CiA402's
    /// CSP adds the two before the factor group), so the drive takes [`TargetsUsed`]'s
    /// `position_offset` into this value.
    pub position: Option<i64>,
    /// Target velocity (60FFh).
    pub velocity: f32,
    /// Target torque (6071h).
    pub torque: f32,
    /// Velocity offset 60B1h: the velocity feed-forward of CSP, added to the CSV target.
    pub velocity_offset: f32,
    /// Torque offset 60B2h (N·m): the torque feed-forward of CSP/CSV, added to the CST target.
    pub torque_offset: f32,
    /// Interpolated position: the interpolation data record 60C1h:01 (increments, extended to
    /// 64 bits) while controlword bit 4 enables the interpolation; `None` holds the position.
    pub interpolation: Option<i64>,
}

/// What the mode asks of the axis this cycle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SetPoint {
    /// The loop that runs.
    pub control: Loop,
    /// Position set-point (increments): the target in CSP, else the actual position (held).
    pub position: i64,
    /// Velocity set-point, increments/s: with the position loop, the velocity at the set-point
    /// (feed-forward; 0 = none given, the axis derives it).
    pub velocity: f32,
    /// Torque set-point, N·m: with the position and speed loops, the torque feed-forward.
    pub torque: f32,
}

/// Which of the master's [`Targets`] a mode takes (the set-point of [`set_point`], or the
/// target of a profile mode's generator): the drive reads only those objects.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TargetsUsed {
    /// 607Ah.
    pub position: bool,
    /// 60FFh.
    pub velocity: bool,
    /// 6071h.
    pub torque: bool,
    /// 60B0h (added to 607Ah in user units: [`Targets::position`]).
    pub position_offset: bool,
    /// 60B1h.
    pub velocity_offset: bool,
    /// 60B2h.
    pub torque_offset: bool,
    /// 60C1h:01.
    pub interpolation: bool,
}

impl Mode {
    /// The targets the mode takes (profile position reads 607Ah itself, as written: it is
    /// not a set-point but the end of a move).
    pub const fn targets_used(self) -> TargetsUsed {
        let none = TargetsUsed {
            position: false,
            velocity: false,
            torque: false,
            position_offset: false,
            velocity_offset: false,
            torque_offset: false,
            interpolation: false,
        };
        match self {
            Self::CyclicPosition => TargetsUsed {
                position: true,
                position_offset: true,
                velocity_offset: true,
                torque_offset: true,
                ..none
            },
            Self::CyclicVelocity => TargetsUsed {
                velocity: true,
                velocity_offset: true,
                torque_offset: true,
                ..none
            },
            Self::CyclicTorque => TargetsUsed {
                torque: true,
                torque_offset: true,
                ..none
            },
            Self::InterpolatedPosition => TargetsUsed {
                interpolation: true,
                ..none
            },
            Self::ProfileVelocity => TargetsUsed {
                velocity: true,
                ..none
            },
            Self::ProfileTorque => TargetsUsed {
                torque: true,
                ..none
            },
            Self::ProfilePosition | Self::Homing | Self::Identification | Self::Other => none,
        }
    }
}

/// The set-point of `mode` from the master's `targets`, the axis being at `actual_position`.
pub fn set_point(mode: Mode, targets: Targets, actual_position: i64) -> SetPoint {
    let t = targets;
    match mode {
        Mode::CyclicPosition => SetPoint {
            control: Loop::Position,
            position: t.position.unwrap_or(actual_position),
            velocity: t.velocity_offset,
            torque: t.torque_offset,
        },
        Mode::InterpolatedPosition => SetPoint {
            control: Loop::Position,
            position: t.interpolation.unwrap_or(actual_position),
            velocity: 0.0,
            torque: 0.0,
        },
        Mode::CyclicVelocity => SetPoint {
            control: Loop::Velocity,
            position: actual_position,
            velocity: t.velocity + t.velocity_offset,
            torque: t.torque_offset,
        },
        Mode::CyclicTorque => SetPoint {
            control: Loop::Torque,
            position: actual_position,
            velocity: 0.0,
            torque: t.torque + t.torque_offset,
        },
        // The profile modes' set-points are generated by the drive (`firmware::motion`);
        // without it the position is held.
        Mode::ProfilePosition
        | Mode::ProfileVelocity
        | Mode::ProfileTorque
        | Mode::Homing
        | Mode::Identification
        | Mode::Other => SetPoint {
            control: Loop::Position,
            position: actual_position,
            velocity: 0.0,
            torque: 0.0,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TARGETS: Targets = Targets {
        position: Some(5_000),
        velocity: 1_000.0,
        torque: 0.5,
        velocity_offset: 0.0,
        torque_offset: 0.0,
        interpolation: None,
    };

    #[test]
    fn object_values_name_the_cia402_modes() {
        assert_eq!(Mode::from_object(8), Mode::CyclicPosition);
        assert_eq!(Mode::from_object(9), Mode::CyclicVelocity);
        assert_eq!(Mode::from_object(10), Mode::CyclicTorque);
        assert_eq!(Mode::from_object(-1), Mode::Identification);
        assert_eq!(Mode::from_object(0), Mode::Other);
        assert_eq!(Mode::from_object(1), Mode::ProfilePosition);
        assert_eq!(Mode::from_object(3), Mode::ProfileVelocity);
        assert_eq!(Mode::from_object(4), Mode::ProfileTorque);
        assert_eq!(Mode::from_object(6), Mode::Homing);
        assert_eq!(Mode::from_object(2), Mode::Other);
        assert_eq!(Mode::from_object(7), Mode::InterpolatedPosition);
    }

    #[test]
    fn ip_follows_the_interpolation_data_only_while_enabled() {
        // CiA402 / Σ-V-SD §4.7 (2): bit 4 = 0 "disable interpolation", the motor holds.
        let held = set_point(Mode::InterpolatedPosition, TARGETS, 100);
        assert_eq!((held.control, held.position), (Loop::Position, 100));
        let t = Targets {
            interpolation: Some(-7_000),
            ..TARGETS
        };
        let sp = set_point(Mode::InterpolatedPosition, t, 100);
        assert_eq!((sp.control, sp.position), (Loop::Position, -7_000));
        // The target position 607Ah is not IP's set-point.
        assert_ne!(sp.position, 5_000);
    }

    #[test]
    fn csp_follows_the_target_position() {
        let sp = set_point(Mode::CyclicPosition, TARGETS, 100);
        assert_eq!((sp.control, sp.position), (Loop::Position, 5_000));
        let no_target = Targets {
            position: None,
            ..TARGETS
        };
        assert_eq!(
            set_point(Mode::CyclicPosition, no_target, 100).position,
            100
        );
    }

    #[test]
    fn csv_and_cst_close_their_loop_and_hold_the_position_reference() {
        let sp = set_point(Mode::CyclicVelocity, TARGETS, 100);
        assert_eq!(
            (sp.control, sp.position, sp.velocity),
            (Loop::Velocity, 100, 1_000.0)
        );
        let sp = set_point(Mode::CyclicTorque, TARGETS, 100);
        assert_eq!(
            (sp.control, sp.position, sp.torque),
            (Loop::Torque, 100, 0.5)
        );
    }

    #[test]
    fn supported_modes_follow_6502h() {
        // The standard profile's 6502h: PP, PV, PT, HM, IP, CSP, CSV, CST and −1.
        let standard = 0x0001_03ED;
        for m in [0, 1, 3, 4, 6, 7, 8, 9, 10, -1] {
            assert!(is_supported(m, standard), "{m}");
        }
        for m in [2, 5, 11, -2, i8::MIN, i8::MAX] {
            assert!(!is_supported(m, standard), "{m}");
        }
        assert!(
            !is_supported(-1, 0x3AD),
            "a vendor without the identification bit"
        );
        assert!(!is_supported(7, 0x3AD), "a vendor without IP (RSE, GHA-E)");
    }

    #[test]
    fn offsets_60b0h_to_60b2h_add_per_mode() {
        // 60B0h is in the CSP target already (see `Targets::position`).
        let t = Targets {
            velocity_offset: 20.0,
            torque_offset: 0.25,
            ..TARGETS
        };
        let csp = set_point(Mode::CyclicPosition, t, 0);
        assert_eq!(
            (csp.position, csp.velocity, csp.torque),
            (5_000, 20.0, 0.25)
        );
        let csv = set_point(Mode::CyclicVelocity, t, 0);
        assert_eq!((csv.velocity, csv.torque), (1_020.0, 0.25));
        let cst = set_point(Mode::CyclicTorque, t, 0);
        assert_eq!((cst.velocity, cst.torque), (0.0, 0.75));
        let hold = set_point(Mode::Other, t, 7);
        assert_eq!((hold.position, hold.velocity, hold.torque), (7, 0.0, 0.0));
    }

    #[test]
    fn a_mode_set_point_depends_only_on_the_targets_it_uses() {
        let all = Targets {
            position: Some(5_000),
            velocity: 1_000.0,
            torque: 0.5,
            velocity_offset: 20.0,
            torque_offset: 0.25,
            interpolation: Some(-7_000),
        };
        let modes = [
            Mode::ProfilePosition,
            Mode::ProfileVelocity,
            Mode::ProfileTorque,
            Mode::Homing,
            Mode::InterpolatedPosition,
            Mode::CyclicPosition,
            Mode::CyclicVelocity,
            Mode::CyclicTorque,
            Mode::Identification,
            Mode::Other,
        ];
        for mode in modes {
            let used = mode.targets_used();
            // The targets the mode does not use as the drive passes them: not read.
            let only_used = Targets {
                position: all.position.filter(|_| used.position),
                velocity: if used.velocity { all.velocity } else { 0.0 },
                torque: if used.torque { all.torque } else { 0.0 },
                velocity_offset: if used.velocity_offset {
                    all.velocity_offset
                } else {
                    0.0
                },
                torque_offset: if used.torque_offset {
                    all.torque_offset
                } else {
                    0.0
                },
                interpolation: all.interpolation.filter(|_| used.interpolation),
            };
            assert_eq!(
                set_point(mode, only_used, 3),
                set_point(mode, all, 3),
                "{mode:?}"
            );
        }
        // The profile modes' generators take theirs: PV the target velocity, PT the torque.
        assert!(Mode::ProfileVelocity.targets_used().velocity);
        assert!(Mode::ProfileTorque.targets_used().torque);
        // CSP feeds the offsets forward (60B1h/60B2h; 60B0h is in its target), CSV
        // 60B1h/60B2h, CST 60B2h.
        assert_eq!(
            set_point(Mode::CyclicPosition, all, 3),
            SetPoint {
                control: Loop::Position,
                position: 5_000,
                velocity: 20.0,
                torque: 0.25
            }
        );
    }

    #[test]
    fn other_modes_hold_the_position() {
        for mode in [Mode::Other, Mode::ProfilePosition, Mode::Identification] {
            let sp = set_point(mode, TARGETS, -42);
            assert_eq!((sp.control, sp.position), (Loop::Position, -42));
        }
    }
}
