//! Unit conversions at the object-dictionary boundary (DESIGN.md §4): objects carry the
//! profile's units, the axis works in SI units and 64-bit increments. Nothing here runs inside a
//! control loop.

/// Rated torque assumed when 6076h is absent or 0, mN·m (so that torques stay finite).
pub const FALLBACK_RATED_TORQUE_MNM: u32 = 1_000;
/// Commissioned resistance unit: µΩ.
pub const MICRO: f32 = 1e-6;
/// Commissioned inductance and inertia unit: nH and g·mm² (1e-9 kg·m²).
pub const NANO: f32 = 1e-9;
/// ‰ (per mille) of the rated torque.
const PER_MILLE: f32 = 1e-3;
/// ‰ in one (multiplying by it is exact where dividing by [`PER_MILLE`] is not).
const PER_MILLE_INV: f32 = 1e3;
/// mN·m in N·m.
const MILLI: f32 = 1e-3;

/// Motor rated torque 6076h (mN·m) in N·m; [`FALLBACK_RATED_TORQUE_MNM`] when absent or 0.
pub fn rated_torque_nm(rated_mnm: Option<u32>) -> f32 {
    rated_mnm
        .filter(|&t| t > 0)
        .unwrap_or(FALLBACK_RATED_TORQUE_MNM) as f32
        * MILLI
}

/// A torque object (6071h, 6077h: ‰ of the rated torque) in N·m.
pub fn torque_from_permille(permille: i16, rated_nm: f32) -> f32 {
    f32::from(permille) * PER_MILLE * rated_nm
}

/// A torque in N·m as ‰ of the rated torque (`as` saturates; NaN → 0).
pub fn torque_to_permille(torque_nm: f32, rated_nm: f32) -> i16 {
    (torque_nm / rated_nm * PER_MILLE_INV) as i16
}

/// A 32-bit position object (607Ah) as a 64-bit position: taken relative to the 32-bit image
/// of `actual`, so the result is right across any number of wraps.
pub fn extend_position(target: i32, actual: i64) -> i64 {
    actual.wrapping_add(i64::from(target.wrapping_sub(actual as i32)))
}

/// A 64-bit position as its 32-bit object (6064h): the low 32 bits, wrapping.
pub fn position_object(position: i64) -> i32 {
    position as i32
}

/// A velocity in increments/s as its 32-bit object (606Ch; `as` saturates, NaN → 0).
pub fn velocity_object(velocity: f32) -> i32 {
    velocity as i32
}

/// A commissioned quantity in SI units as its object value in `unit` (µΩ, nH, g·mm²), rounded.
pub fn to_object_units(value: f32, unit: f32) -> u32 {
    (value / unit + 0.5) as u32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn torque_round_trips_through_per_mille_of_rated() {
        let rated = rated_torque_nm(Some(2_000));
        assert_eq!(rated, 2.0);
        assert_eq!(torque_from_permille(500, rated), 1.0);
        assert_eq!(torque_to_permille(1.0, rated), 500);
        assert_eq!(torque_to_permille(-0.25, rated), -125);
        assert_eq!(rated_torque_nm(Some(0)), 1.0, "0 falls back to 1 N·m");
        assert_eq!(rated_torque_nm(None), 1.0);
        assert_eq!(torque_to_permille(f32::NAN, rated), 0);
        assert_eq!(torque_to_permille(1e9, rated), i16::MAX);
    }

    #[test]
    fn positions_extend_across_wraps() {
        assert_eq!(extend_position(100, 0), 100);
        assert_eq!(extend_position(-100, 0), -100);
        let near_wrap = i64::from(i32::MAX) - 10;
        assert_eq!(extend_position(i32::MIN + 10, near_wrap), near_wrap + 21);
        let many_turns = 5 * (1i64 << 32) + 7;
        assert_eq!(extend_position(9, many_turns), many_turns + 2);
        assert_eq!(position_object(many_turns), 7);
    }

    #[test]
    fn commissioned_values_round_to_object_units() {
        assert_eq!(to_object_units(0.25, MICRO), 250_000);
        assert_eq!(to_object_units(1.2e-3, NANO), 1_200_000);
    }
}
