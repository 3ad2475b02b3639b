//! A profile's units at their default settings, for scenarios that command physical quantities
//! (revolutions, revolutions per second) through the objects of any profile: the factors come
//! from the profile's `[units]` and the defaults of the objects they name.

use od_gen::model::{Acceleration, Factor, Operand};
use od_gen::Profile;

/// Increments per revolution of the simulated servo's encoder.
pub const COUNTS_PER_REV: f64 = (1u32 << 20) as f64;

/// The value of one operand of a unit factor with the objects at their defaults.
fn operand(profile: &Profile, operand: Operand) -> f64 {
    match operand {
        Operand::Const(c) => f64::from(c),
        Operand::CountsPerRev => COUNTS_PER_REV,
        Operand::Entry(index, sub) => {
            let entry = profile
                .entry(index, sub)
                .unwrap_or_else(|| panic!("unit factor entry {index:#06x}:{sub}"));
            let bytes: [u8; 4] = entry.initial_bytes()[..4]
                .try_into()
                .expect("a 32-bit factor");
            f64::from(u32::from_le_bytes(bytes))
        }
    }
}

/// Internal units (increments, increments/s, ...) per unit of `factor`.
fn internal_per_unit(profile: &Profile, factor: Factor) -> f64 {
    operand(profile, factor.numerator) / operand(profile, factor.denominator)
        * f64::from(factor.scale.0)
        / f64::from(factor.scale.1)
}

/// Increments per position unit.
pub fn increments_per_unit(profile: &Profile) -> f64 {
    internal_per_unit(profile, profile.units.position)
}

/// A speed of `rev_per_s` in the profile's velocity unit (6099h, 6081h, 60FFh), rounded.
pub fn velocity(profile: &Profile, rev_per_s: f64) -> u32 {
    let per_unit = internal_per_unit(profile, profile.units.velocity);
    (rev_per_s * COUNTS_PER_REV / per_unit).round() as u32
}

/// A signed speed of `rev_per_s` in the profile's velocity unit (60FFh, a target), rounded.
pub fn target_velocity(profile: &Profile, rev_per_s: f64) -> i32 {
    let per_unit = internal_per_unit(profile, profile.units.velocity);
    (rev_per_s * COUNTS_PER_REV / per_unit).round() as i32
}

/// An acceleration of `rev_per_s2` in the profile's acceleration unit (6083h-6085h, 609Ah),
/// rounded; for an acceleration given as the time to a speed, that time in ms.
pub fn acceleration(profile: &Profile, rev_per_s2: f64) -> u32 {
    let increments_per_s2 = rev_per_s2 * COUNTS_PER_REV;
    let value = match profile.units.acceleration {
        Acceleration::VelocityPerSecond => {
            increments_per_s2 / internal_per_unit(profile, profile.units.velocity)
        }
        Acceleration::Factor(f) => increments_per_s2 / internal_per_unit(profile, f),
        Acceleration::MsToRpm(rpm) => f64::from(rpm) / 60.0 / rev_per_s2 * 1e3,
    };
    value.round() as u32
}
