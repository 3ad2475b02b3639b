//! Modes of operation (6060h requested, 6061h displayed; CiA402 §6.2) and the set-point each
//! mode hands to the axis.
//!
//! The cyclic synchronous modes pass the master's target of one quantity every bus cycle and
//! hold the others at the actual value; a mode the axis does not run holds the position.

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
    /// Cyclic synchronous position (8).
    CyclicPosition,
    /// Cyclic synchronous velocity (9).
    CyclicVelocity,
    /// Cyclic synchronous torque (10).
    CyclicTorque,
    /// Motor identification (−1).
    Identification,
    /// Any other value (no mode, or one this drive does not run): the position is held.
    Other(i8),
}

impl Mode {
    /// The mode of a 6060h value.
    pub const fn from_object(value: i8) -> Self {
        match value {
            CSP => Self::CyclicPosition,
            CSV => Self::CyclicVelocity,
            CST => Self::CyclicTorque,
            IDENTIFICATION => Self::Identification,
            other => Self::Other(other),
        }
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
    /// Target position (607Ah, extended to 64 bits), `None` if the profile has none.
    pub position: Option<i64>,
    /// Target velocity (60FFh).
    pub velocity: f32,
    /// Target torque (6071h).
    pub torque: f32,
}

/// What the mode asks of the axis this cycle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SetPoint {
    /// The loop that runs.
    pub control: Loop,
    /// Position set-point (increments): the target in CSP, else the actual position (held).
    pub position: i64,
    /// Velocity set-point, increments/s.
    pub velocity: f32,
    /// Torque set-point, N·m.
    pub torque: f32,
}

/// The set-point of `mode` from the master's `targets`, the axis being at `actual_position`.
pub fn set_point(mode: Mode, targets: Targets, actual_position: i64) -> SetPoint {
    let (control, position) = match mode {
        Mode::CyclicPosition => (Loop::Position, targets.position.unwrap_or(actual_position)),
        Mode::CyclicVelocity => (Loop::Velocity, actual_position),
        Mode::CyclicTorque => (Loop::Torque, actual_position),
        Mode::Identification | Mode::Other(_) => (Loop::Position, actual_position),
    };
    SetPoint {
        control,
        position,
        velocity: targets.velocity,
        torque: targets.torque,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TARGETS: Targets = Targets {
        position: Some(5_000),
        velocity: 1_000.0,
        torque: 0.5,
    };

    #[test]
    fn object_values_name_the_cia402_modes() {
        assert_eq!(Mode::from_object(8), Mode::CyclicPosition);
        assert_eq!(Mode::from_object(9), Mode::CyclicVelocity);
        assert_eq!(Mode::from_object(10), Mode::CyclicTorque);
        assert_eq!(Mode::from_object(-1), Mode::Identification);
        assert_eq!(Mode::from_object(0), Mode::Other(0));
        assert_eq!(Mode::from_object(1), Mode::Other(1));
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
    fn other_modes_hold_the_position() {
        for mode in [Mode::Other(0), Mode::Other(1), Mode::Identification] {
            let sp = set_point(mode, TARGETS, -42);
            assert_eq!((sp.control, sp.position), (Loop::Position, -42));
        }
    }
}
