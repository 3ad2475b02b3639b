//! Interpolated position mode (6060h = 7, CiA402 §11; the Σ-V-SD's §3.3.2 and §4.11): the
//! master sends an absolute position, the interpolation data record 60C1h:01, once per
//! interpolation period 60C2h, and the drive interpolates between the set-points.
//!
//! - Controlword bit 4 "enable interpolation": with it clear the mode is selected but the motor
//!   holds its position; with it set every new record is a set-point.
//! - Statusword bit 12 "ip mode active": the interpolation runs (bit 4 set, operation enabled).
//! - 60C2h: the period is `value × 10^index` seconds (sub 1 UNSIGNED8, sub 2 INTEGER8); on a
//!   bus with distributed clocks the drive takes the SYNC0 cycle and shows it there.

/// Controlword bit 4 in interpolated position mode: enable interpolation.
pub const ENABLE_INTERPOLATION: u16 = 1 << 4;

/// Statusword bit 12 in interpolated position mode: ip mode active.
pub const IP_MODE_ACTIVE: u16 = 1 << 12;

/// The exponents of 10 (60C2h:02) whose periods are whole nanoseconds.
const NS_INDEX: i8 = -9;
/// Periods are seconds: index 0 is the coarsest the drive takes (255 s).
const S_INDEX: i8 = 0;

/// The interpolation period of 60C2h in ns: `value × 10^index` s; `None` when it is zero, not a
/// whole number of ns or longer than a `u32` of ns (4.29 s).
pub fn period_ns(value: u8, index: i8) -> Option<u32> {
    if value == 0 || !(NS_INDEX..=S_INDEX).contains(&index) {
        return None;
    }
    u32::try_from(u64::from(value).checked_mul(ns_per_unit(index)?)?).ok()
}

/// ns per unit of 60C2h:01 at 60C2h:02 = `index` (10^(index + 9)); `None` beyond u64.
fn ns_per_unit(index: i8) -> Option<u64> {
    10u64.checked_pow(u32::from(index.abs_diff(NS_INDEX)))
}

/// 60C2h for a period of `cycle_ns`: the finest index whose value fits sub 1 exactly, else the
/// nearest period sub 1 can show (rounded at the finest index where it fits). `None` for 0 or
/// a period beyond 255 s.
pub fn period_object(cycle_ns: u32) -> Option<(u8, i8)> {
    if cycle_ns == 0 {
        return None;
    }
    let fits = |index: i8| {
        let scale = ns_per_unit(index)?;
        let ns = u64::from(cycle_ns);
        (ns.checked_rem(scale)? == 0)
            .then(|| u8::try_from(ns.checked_div(scale)?).ok())
            .flatten()
    };
    if let Some(exact) = (NS_INDEX..=S_INDEX).find_map(|i| fits(i).map(|v| (v, i))) {
        return Some(exact);
    }
    (NS_INDEX..=S_INDEX).find_map(|index| {
        let scale = ns_per_unit(index)?;
        // cycle_ns < 2^32 and scale ≤ 10^9: the sum fits; scale ≥ 1.
        let rounded = u64::from(cycle_ns)
            .checked_add(scale / 2)?
            .checked_div(scale)?;
        u8::try_from(rounded)
            .ok()
            .filter(|v| *v > 0)
            .map(|v| (v, index))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_period_is_value_times_ten_to_the_index() {
        // The Σ-V-SD's default 125 × 10^-6 s (§4.11 (2)).
        assert_eq!(period_ns(125, -6), Some(125_000));
        assert_eq!(period_ns(1, -3), Some(1_000_000));
        assert_eq!(period_ns(4, 0), Some(4_000_000_000));
        assert_eq!(period_ns(5, 0), None, "beyond a u32 of ns");
        assert_eq!(period_ns(0, -3), None, "no period");
        assert_eq!(period_ns(1, -10), None, "finer than a ns");
        assert_eq!(period_ns(1, 1), None);
    }

    #[test]
    fn a_sync0_cycle_shows_as_the_finest_exact_pair() {
        // Σ-V-SD SYNC0 cycles are 250 µs × n (§2.6).
        assert_eq!(period_object(250_000), Some((250, -6)));
        assert_eq!(period_object(1_000_000), Some((100, -5)));
        assert_eq!(period_object(125_000), Some((125, -6)));
        // 31.25 µs = 3125 × 10^-8 s: not an UNSIGNED8 value at any index; 31 µs is the nearest.
        assert_eq!(period_object(31_250), Some((31, -6)));
        assert_eq!(period_object(4_000_000), Some((40, -4)));
        // 2.75 ms has no exact pair with an UNSIGNED8 value: 2.8 ms is the nearest.
        assert_eq!(period_object(2_750_000), Some((28, -4)));
        assert_eq!(period_object(0), None);
        for cycle in [125_000u32, 250_000, 500_000, 1_000_000, 10_000_000] {
            let (v, i) = period_object(cycle).expect("pair");
            assert_eq!(period_ns(v, i), Some(cycle), "{cycle} round trip");
        }
    }
}
