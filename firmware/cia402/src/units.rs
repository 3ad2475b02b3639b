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

/// A torque-like quantity in ‰ of the rated torque (e.g. the torque slope 6087h, ‰/s) in N·m
/// (per the same time unit).
pub fn torque_from_permille_f32(permille: f32, rated_nm: f32) -> f32 {
    permille * PER_MILLE * rated_nm
}

/// A torque in N·m as ‰ of the rated torque, rounded to the nearest as [`velocity_object`]
/// (`as` saturates; NaN → 0).
pub fn torque_to_permille(torque_nm: f32, rated_nm: f32) -> i16 {
    // Through i32 (one VCVT, which saturates and maps NaN to 0 like `as`), then limited to the
    // i16 range (SSAT): a direct `as i16` becomes a chain of range checks.
    let permille = nearest(torque_nm / rated_nm * PER_MILLE_INV) as i32;
    permille.clamp(i32::from(i16::MIN), i32::from(i16::MAX)) as i16
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

/// A velocity in increments/s as its 32-bit object (606Ch), rounded to the nearest (halves
/// away from zero; `as` saturates, NaN → 0): a set-point that went through a fractional factor
/// and back (60FFh → increments/s → 606Bh) reads as it was written, not one unit short of it.
pub fn velocity_object(velocity: f32) -> i32 {
    nearest(velocity) as i32
}

/// `x` plus half a unit away from zero: `as` (which truncates) then rounds to the nearest.
/// A few instructions (copysign, add), where `f32::round` would be a library call.
#[inline(always)]
fn nearest(x: f32) -> f32 {
    x + 0.5_f32.copysign(x)
}

/// A commissioned quantity in SI units as its object value in `unit` (µΩ, nH, g·mm²), rounded.
pub fn to_object_units(value: f32, unit: f32) -> u32 {
    (value / unit + 0.5) as u32
}

/// The factor between a profile's user unit and the drive's internal unit (DESIGN.md §4:
/// increments, increments/s): internal = value × numerator / denominator, e.g. the gear ratio
/// 6091h or the position factor 6093h. Positions convert exactly (integer arithmetic);
/// velocities in floating point through the ratio's [`Scale`] (made once: a 64-bit
/// integer to float conversion is a library call on the Cortex-M4, too slow to repeat per
/// value).
///
/// A ratio [`prepared`](Self::prepared) once (when the unit objects change) carries the
/// reciprocals of its two sides, so that a position converts with multiplications instead of a
/// 64-bit division (a library routine of some 150 to 300 instructions on the Cortex-M4, several
/// of them per SYNC0 cycle). Equality compares the ratio only.
#[derive(Clone, Copy, Debug)]
pub struct Ratio {
    numerator: u64,
    denominator: u64,
    /// ⌊(2⁶⁴ − 1) / numerator⌋ and ⌊(2⁶⁴ − 1) / denominator⌋ once prepared (0: not prepared,
    /// or a side above `u32::MAX`, which converts by division).
    inv_numerator: u64,
    inv_denominator: u64,
}

/// Equal as values (n₁·d₂ = n₂·d₁, in 128 bits from 32 × 32-bit products): a ratio in lowest
/// terms ([`Ratio::prepared`]) equals its unreduced form, and the reciprocals do not count.
impl PartialEq for Ratio {
    fn eq(&self, other: &Self) -> bool {
        let (a, b) = (
            (self.numerator, other.denominator),
            (other.numerator, self.denominator),
        );
        a.0.wrapping_mul(a.1) == b.0.wrapping_mul(b.1) && mul_high(a.0, a.1) == mul_high(b.0, b.1)
    }
}

impl Eq for Ratio {}

/// A [`Ratio`] as the floating-point factors of velocity-like quantities (increments/s,
/// increments/s²): converts with one multiplication either way.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scale {
    /// numerator / denominator.
    to_internal: f32,
    /// denominator / numerator.
    from_internal: f32,
}

impl Scale {
    /// 1:1.
    pub const ONE: Self = Self {
        to_internal: 1.0,
        from_internal: 1.0,
    };

    /// A velocity in user units/s as increments/s.
    pub fn velocity_to_internal(self, user: f32) -> f32 {
        user * self.to_internal
    }

    /// Increments/s as a velocity in user units/s.
    pub fn velocity_from_internal(self, increments_per_s: f32) -> f32 {
        increments_per_s * self.from_internal
    }

    /// Internal units per user unit (numerator / denominator).
    pub fn factor(self) -> f32 {
        self.to_internal
    }
}

impl Ratio {
    /// 1:1 (user unit = internal unit).
    pub const ONE: Self = Self {
        numerator: 1,
        denominator: 1,
        inv_numerator: 0,
        inv_denominator: 0,
    };

    /// `numerator / denominator`. A zero on either side (a factor object the master set to 0,
    /// which CiA402 ranges exclude) gives [`Self::ONE`], so that no conversion divides by zero
    /// or collapses every value to 0.
    pub fn new(numerator: u64, denominator: u64) -> Self {
        if numerator == 0 || denominator == 0 {
            Self::ONE
        } else {
            Self {
                numerator,
                denominator,
                inv_numerator: 0,
                inv_denominator: 0,
            }
        }
    }

    /// This ratio with the reciprocals that let positions convert without a division (the
    /// two divisions happen here, once), in lowest terms where a side exceeds 32 bits (a
    /// product of factors, e.g. a gear ratio times a feed constant, often has common factors):
    /// the same value, so the conversions give the same results either way, but factors
    /// within 32 bits take the conversions' short paths (a side beyond 32 bits has no
    /// reciprocal: a 64-bit or a bit-by-bit division per conversion).
    pub fn prepared(self) -> Self {
        let (numerator, denominator) = if (self.numerator | self.denominator) >> 32 != 0 {
            let common = gcd(self.numerator, self.denominator);
            // Both sides ≥ 1 (`new`), so `common` ≥ 1 divides both.
            (
                self.numerator.checked_div(common).unwrap_or(self.numerator),
                self.denominator
                    .checked_div(common)
                    .unwrap_or(self.denominator),
            )
        } else {
            (self.numerator, self.denominator)
        };
        Self {
            numerator,
            denominator,
            inv_numerator: reciprocal(numerator),
            inv_denominator: reciprocal(denominator),
        }
    }

    /// The floating-point factors of this ratio.
    pub fn scale(self) -> Scale {
        let (n, d) = (self.numerator as f32, self.denominator as f32);
        Scale {
            to_internal: n / d,
            from_internal: d / n,
        }
    }

    /// This ratio times `other` (e.g. a position factor times a constant per-second scale),
    /// saturating.
    pub fn times(self, other: Self) -> Self {
        Self::new(
            self.numerator.saturating_mul(other.numerator),
            self.denominator.saturating_mul(other.denominator),
        )
    }

    /// Whether the ratio is 1 (n = d: the conversions are the identity). One comparison, not
    /// the derived `==` with [`Self::ONE`], which the SYNC0 handler would call for every
    /// position.
    #[inline]
    fn is_one(self) -> bool {
        self.numerator == self.denominator
    }

    /// A position in user units as increments (the nearest, halves away from zero), saturating
    /// at the i64 range.
    #[inline]
    pub fn position_to_internal(self, user: i64) -> i64 {
        if self.is_one() {
            return user;
        }
        scale(user, self.numerator, self.denominator, self.inv_denominator)
    }

    /// Increments as a position in user units (the nearest, halves away from zero),
    /// saturating. With at least one increment per unit this is the inverse of
    /// [`Self::position_to_internal`]: a target of `u` units, reached, reads back as `u`.
    #[inline]
    pub fn position_from_internal(self, increments: i64) -> i64 {
        if self.is_one() {
            return increments;
        }
        scale(
            increments,
            self.denominator,
            self.numerator,
            self.inv_numerator,
        )
    }

    /// The largest distance in increments that [`Self::position_from_internal`] converts to at
    /// most `user` units (a position window 6067h compared in increments: |d| ≤ the result
    /// exactly when |d| converted is ≤ `user`, the conversion being odd and monotone), so a
    /// cycle compares without converting. With the two sides within 32 bits and the ratio
    /// prepared: round(x·den/num) ≤ w ⟺ 2·den·x < (2w + 1)·num ⟺ x ≤ ⌊((2w + 1)·num − 1) /
    /// (2·den)⌋ = q₁ + ⌊⌊(2r₁ + num − 1) / 2⌋ / den⌋ with (q₁, r₁) = w·num divided by den: two
    /// divisions by the reciprocal. `None` for other ratios (the caller converts instead).
    pub fn increments_within(self, user: u32) -> Option<u64> {
        if self.is_one() {
            return Some(u64::from(user));
        }
        let (num, den, inv) = (self.numerator, self.denominator, self.inv_denominator);
        if (num | den) >> 32 != 0 || inv == 0 {
            return None;
        }
        let den32 = den as u32;
        // w, num < 2³²: the product < 2⁶⁴; r₁ < den < 2³², so 2r₁ + num − 1 < 2³⁴ (num ≥ 1).
        let (q1, r1) = divide_floor(u64::from(user).wrapping_mul(num), den32, inv)?;
        let rest = r1.wrapping_mul(2).wrapping_add(num).wrapping_sub(1) >> 1;
        let (q2, _) = divide_floor(rest, den32, inv)?;
        Some(q1.saturating_add(q2))
    }
}

/// The greatest common divisor of `a` and `b` (binary: shifts and subtractions, at most some
/// 130 steps, no division); 0 only for two zeros.
fn gcd(mut a: u64, mut b: u64) -> u64 {
    if a == 0 || b == 0 {
        return a | b;
    }
    // The powers of two they share, then odd numbers only: the difference of two odd numbers
    // is even, and halving it keeps the common divisor.
    let shift = (a | b).trailing_zeros();
    a >>= a.trailing_zeros();
    loop {
        b >>= b.trailing_zeros();
        if a > b {
            core::mem::swap(&mut a, &mut b);
        }
        // b ≥ a, both odd: no wrap.
        b = b.wrapping_sub(a);
        if b == 0 {
            return a << shift;
        }
    }
}

/// ⌊(2⁶⁴ − 1) / `divisor`⌋ for a divisor in 1..=`u32::MAX` (the reciprocal [`scale`] divides
/// with); 0 (no reciprocal: divide) for 0 and for larger divisors.
fn reciprocal(divisor: u64) -> u64 {
    if divisor > u64::from(u32::MAX) {
        return 0;
    }
    u64::MAX.checked_div(divisor).unwrap_or(0)
}

/// The high 64 bits of the 128-bit product `a × b`, from four 32 × 32 → 64 multiplications
/// (UMULL on the Cortex-M4; a `u128` product would be a library call).
#[inline]
fn mul_high(a: u64, b: u64) -> u64 {
    let (a0, a1) = (a & 0xFFFF_FFFF, a >> 32);
    let (b0, b1) = (b & 0xFFFF_FFFF, b >> 32);
    // Each factor < 2³², so each product < 2⁶⁴ and the sums below cannot overflow:
    // mid < 3 · 2³², the result < 2⁶⁴.
    let (p00, p01, p10, p11) = (
        a0.wrapping_mul(b0),
        a0.wrapping_mul(b1),
        a1.wrapping_mul(b0),
        a1.wrapping_mul(b1),
    );
    let mid = (p00 >> 32)
        .wrapping_add(p01 & 0xFFFF_FFFF)
        .wrapping_add(p10 & 0xFFFF_FFFF);
    p11.wrapping_add(p01 >> 32)
        .wrapping_add(p10 >> 32)
        .wrapping_add(mid >> 32)
}

/// `magnitude / divisor` rounded down, with the remainder, through `inv` =
/// ⌊(2⁶⁴ − 1) / divisor⌋, divisor in 1..=`u32::MAX`. Since inv ≥ (2⁶⁴ − 1)/divisor −
/// (divisor − 1)/divisor = 2⁶⁴/divisor − 1 and magnitude < 2⁶⁴, magnitude · inv / 2⁶⁴ is
/// above magnitude/divisor − 1: the estimate (its floor) is the quotient or 1 below it, and
/// one correction by the remainder gives the quotient. `None` if a correction is still due
/// after it (which the bound excludes).
#[inline]
fn divide_floor(magnitude: u64, divisor: u32, inv: u64) -> Option<(u64, u64)> {
    let divisor = u64::from(divisor);
    let quotient = mul_high(magnitude, inv);
    // quotient ≤ magnitude / divisor: the remainder is magnitude − quotient·divisor ≥ 0 and
    // < 2·divisor < 2³³, exact in wrapping arithmetic (the divisor's high half known to be 0,
    // the product is one UMULL and one MLA).
    let remainder = magnitude.wrapping_sub(quotient.wrapping_mul(divisor));
    if remainder < divisor {
        return Some((quotient, remainder));
    }
    let remainder = remainder.wrapping_sub(divisor);
    (remainder < divisor).then_some((quotient.wrapping_add(1), remainder))
}

/// `dividend / divisor` rounded down: a power-of-two divisor (an encoder's resolution, a
/// factor of 2ⁿ) needs no reciprocal, the quotient is a shift (by less than 32: no wrap);
/// others through `inv` ([`divide_floor`]).
#[inline(always)]
fn quotient_floor(dividend: u64, divisor: u32, inv: u64) -> Option<u64> {
    if divisor.is_power_of_two() {
        Some(dividend.wrapping_shr(divisor.trailing_zeros()))
    } else {
        divide_floor(dividend, divisor, inv).map(|(q, _)| q)
    }
}

/// `magnitude / divisor` rounded to the nearest (halves up) through `inv` ([`divide_floor`]).
#[inline]
fn divide_by_reciprocal(magnitude: u64, divisor: u32, inv: u64) -> Option<u64> {
    let (quotient, remainder) = divide_floor(magnitude, divisor, inv)?;
    // Halves away from zero (on the magnitude: up). remainder < divisor ≤ 2³²: no overflow.
    Some(if remainder.wrapping_mul(2) >= u64::from(divisor) {
        quotient.wrapping_add(1)
    } else {
        quotient
    })
}

/// `value × multiplier / divisor` (`divisor` > 0) rounded to the nearest (halves away from
/// zero), saturating at the i64 range: with the divisor's reciprocal `inv` (0: none) when the
/// operands fit 32 bits (the common case: multiplications only) or only the value is wider
/// and the product fits 64 bits ([`scale_long_position`]), by a 64-bit division when there is
/// no reciprocal, else in 128 bits. Rounding to the nearest both ways makes a position
/// survive the round trip through the other unit (truncating both ways loses a unit whenever
/// the increments of a target have a fraction).
fn scale(value: i64, multiplier: u64, divisor: u64, inv: u64) -> i64 {
    // The common case (a drive's positions and the factors of its ratios): |value|, the
    // multiplier and the divisor within 32 bits and a reciprocal. The product is one
    // 32 × 32 → 64-bit multiplication, and rounding to the nearest is the floor of the product
    // plus half the divisor (⌊d/2⌋: for an odd divisor no quotient lies on a half), so one
    // division, by the reciprocal or a shift, gives the result.
    let magnitude = value.unsigned_abs();
    if (magnitude | multiplier | divisor) >> 32 == 0 && inv != 0 {
        let divisor32 = divisor as u32;
        // Both factors < 2³²: the product ≤ (2³² − 1)², plus half the divisor < 2⁶⁴ (wrapping
        // only to say so to the lint).
        let biased = u64::from(magnitude as u32)
            .wrapping_mul(u64::from(multiplier as u32))
            .wrapping_add(u64::from(divisor32 >> 1));
        let quotient = quotient_floor(biased, divisor32, inv);
        if let Some(q) = quotient.and_then(|q| signed(value < 0, q)) {
            return q;
        }
    }
    scale_general(value, multiplier, divisor, inv)
}

/// [`scale`] beyond its 32-bit operands: a separate function, so that the optimiser does not
/// merge its 64 × 64-bit product into the common case.
#[inline(never)]
fn scale_general(value: i64, multiplier: u64, divisor: u64, inv: u64) -> i64 {
    if let Some(q) = scale_long_position(value, multiplier, divisor, inv) {
        return q;
    }
    let product = i64::try_from(multiplier)
        .ok()
        .and_then(|m| value.checked_mul(m));
    let divisor32 = u32::try_from(divisor).ok().filter(|_| inv != 0);
    if let (Some(product), Some(d)) = (product, divisor32) {
        let quotient = divide_by_reciprocal(product.unsigned_abs(), d, inv)
            .and_then(|q| signed(product < 0, q));
        if let Some(q) = quotient {
            return q;
        }
    }
    let narrow = i64::try_from(divisor)
        .ok()
        .zip(product)
        .and_then(|(d, product)| {
            let (quotient, remainder) = (product.checked_div(d)?, product.checked_rem(d)?);
            // |remainder| < d ≤ i64::MAX: twice it fits a u64.
            let twice = remainder.unsigned_abs().checked_mul(2)?;
            Some(if twice >= d.unsigned_abs() {
                // d ≥ 2 here (d = 1 leaves no remainder): |quotient| ≤ i64::MAX / 2.
                quotient.saturating_add(product.signum())
            } else {
                quotient
            })
        });
    narrow.unwrap_or_else(|| scale_wide(value, multiplier, divisor, inv))
}

/// [`scale`] of a position beyond 32 bits (a long travel: 2³² increments are 512 turns of a
/// 23-bit encoder) with the factors within 32 bits: the 64 × 32-bit product from two 32 × 32
/// multiplications, divided through the reciprocal: in one step when it fits 64 bits, else in
/// two 32-bit digits ([`divide_wide`]; without the general path's 64 × 64-bit product and its
/// overflow checks). `None` where that does not apply or the
/// quotient leaves the i64 range (the general path saturates).
#[inline]
fn scale_long_position(value: i64, multiplier: u64, divisor: u64, inv: u64) -> Option<i64> {
    if (multiplier | divisor) >> 32 != 0 || inv == 0 {
        return None;
    }
    let (m, d) = (multiplier as u32, divisor as u32);
    let magnitude = value.unsigned_abs();
    // The product is high · 2³² + the low word of `low`. Each partial product ≤ (2³² − 1)²,
    // and the high one plus the low one's carry word ≤ (2³² − 1)² + 2³² − 1 < 2⁶⁴: no wrap
    // (wrapping only to say so to the lint).
    let low = (magnitude & 0xFFFF_FFFF).wrapping_mul(u64::from(m));
    let high = (magnitude >> 32)
        .wrapping_mul(u64::from(m))
        .wrapping_add(low >> 32);
    let low_word = low & 0xFFFF_FFFF;
    if high >> 32 == 0 {
        // Rounded to the nearest as in [`scale`]: the floor of the product plus half the
        // divisor (unless that passes 2⁶⁴: then in two digits below).
        if let Some(biased) = (high << 32 | low_word).checked_add(u64::from(d >> 1)) {
            return signed(value < 0, quotient_floor(biased, d, inv)?);
        }
    }
    // The product as a 128-bit value: its upper half is `high`'s upper word. Below the
    // divisor, the quotient fits 64 bits and [`divide_wide`] divides in two 32-bit digits;
    // else the quotient is 2⁶⁴ or more, beyond the i64 range.
    let upper = high >> 32;
    if upper >= u64::from(d) {
        return None;
    }
    let (quotient, remainder) = divide_wide(upper, high << 32 | low_word, d, inv)?;
    // Halves away from zero (on the magnitude: up): 2·remainder ≥ d, as the bias does above.
    let round_up = remainder >= u64::from(d).wrapping_sub(remainder);
    signed(value < 0, quotient.checked_add(u64::from(round_up))?)
}

/// A quotient's `magnitude` with the sign of its operand (`negative`); `None` beyond the i64
/// range (the callers then saturate).
#[inline(always)]
fn signed(negative: bool, magnitude: u64) -> Option<i64> {
    let q = i64::try_from(magnitude).ok()?;
    // q ≥ 0 and ≤ i64::MAX: its negation fits.
    Some(if negative { q.wrapping_neg() } else { q })
}

/// [`scale`] when the product does not fit 64 bits: the 128-bit product magnitude as two
/// 64-bit halves, divided in two steps of 32 quotient bits each by the divisor's reciprocal
/// `inv` when it has one (a divisor within 32 bits), else by a restoring division, one
/// quotient bit per step (64 steps; a 128-bit division would link some 800 bytes of library
/// code). Saturates at the i64 range; a divisor of 0 (the callers never pass one) gives 0.
#[inline(never)]
fn scale_wide(value: i64, multiplier: u64, divisor: u64, inv: u64) -> i64 {
    if divisor == 0 {
        return 0;
    }
    let magnitude = value.unsigned_abs();
    let (high, low) = (
        mul_high(magnitude, multiplier),
        magnitude.wrapping_mul(multiplier),
    );
    let saturated = if value < 0 { i64::MIN } else { i64::MAX };
    // A high half of at least the divisor: a quotient of 2^64 or more.
    if high >= divisor {
        return saturated;
    }
    let divided = u32::try_from(divisor)
        .ok()
        .filter(|_| inv != 0)
        .and_then(|d| divide_wide(high, low, d, inv))
        .unwrap_or_else(|| restoring_division(high, low, divisor));
    let (mut quotient, remainder) = divided;
    // Halves away from zero (on the magnitude: up); remainder < divisor.
    if remainder >= divisor.wrapping_sub(remainder) {
        let Some(rounded) = quotient.checked_add(1) else {
            return saturated;
        };
        quotient = rounded;
    }
    if value < 0 {
        // −2^63 is i64::MIN; a larger magnitude saturates.
        0i64.checked_sub_unsigned(quotient).unwrap_or(i64::MIN)
    } else {
        i64::try_from(quotient).unwrap_or(i64::MAX)
    }
}

/// `(high · 2⁶⁴ + low) / divisor` rounded down, with the remainder, for `high` < `divisor` ≤
/// `u32::MAX` (the quotient fits 64 bits): long division in two 32-bit digits, each a 64-bit
/// by 32-bit division through the reciprocal `inv` ([`divide_floor`]). `None` if a step
/// fails its bound (which `high` < `divisor` excludes).
#[inline]
fn divide_wide(high: u64, low: u64, divisor: u32, inv: u64) -> Option<(u64, u64)> {
    // high < divisor ≤ 2³² − 1: shifted by 32 bits with the next digit it stays below
    // divisor · 2³² < 2⁶⁴, and so does each remainder's.
    let upper = (high << 32) | (low >> 32);
    let (q1, r1) = divide_floor(upper, divisor, inv)?;
    let lower = (r1 << 32) | (low & 0xFFFF_FFFF);
    let (q0, r0) = divide_floor(lower, divisor, inv)?;
    // q1 < 2³² (upper < divisor · 2³²), q0 < 2³²: the quotient is their digits side by side.
    Some(((q1 << 32) | q0, r0))
}

/// `(high · 2⁶⁴ + low) / divisor` rounded down, with the remainder, for `high` < `divisor`
/// (any divisor): one quotient bit per step.
fn restoring_division(high: u64, low: u64, divisor: u64) -> (u64, u64) {
    let (mut quotient, mut remainder) = (0u64, high);
    for bit in (0..u64::BITS).rev() {
        // remainder < divisor: doubling it plus the next bit stays below 2·divisor, which
        // may carry out of 64 bits (then it certainly exceeds the divisor).
        let carry = remainder >> (u64::BITS - 1);
        remainder = (remainder << 1) | ((low >> bit) & 1);
        quotient <<= 1;
        if carry != 0 || remainder >= divisor {
            remainder = remainder.wrapping_sub(divisor);
            quotient |= 1;
        }
    }
    (quotient, remainder)
}

/// Polarity 607Eh (CiA402): bit 7 multiplies the position objects by −1, bit 6 the velocity
/// objects; bit 5 the torque objects (the GHA-E's, reserved in CiA402). The drive applies it
/// where an object's value enters or leaves, so that everything inside (axis, profile
/// generators, homing, limits) works in the motor's direction.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Polarity {
    /// Bit 7: position objects (607Ah, 6064h, 6062h, 60B0h, 60C1h, 607Ch, 607Dh, 60BAh–60BDh).
    pub position: bool,
    /// Bit 6: velocity objects (60FFh, 606Ch, 606Bh, 60B1h).
    pub velocity: bool,
    /// Bit 5: torque objects (6071h, 6077h, 6074h, 60B2h; 60E0h and 60E1h trade places).
    pub torque: bool,
}

impl Polarity {
    /// No inversion (607Eh = 0).
    pub const NONE: Self = Self {
        position: false,
        velocity: false,
        torque: false,
    };

    /// The polarity of 607Eh value `value`.
    pub const fn from_object(value: u8) -> Self {
        Self {
            position: value & 0x80 != 0,
            velocity: value & 0x40 != 0,
            torque: value & 0x20 != 0,
        }
    }

    /// A position object's value as the drive counts it, or back (its own inverse; the most
    /// negative value saturates).
    pub fn position(self, value: i32) -> i32 {
        if self.position {
            value.saturating_neg()
        } else {
            value
        }
    }

    /// A velocity object's value as the drive counts it, or back.
    pub fn velocity(self, value: i32) -> i32 {
        if self.velocity {
            value.saturating_neg()
        } else {
            value
        }
    }

    /// A torque object's value as the drive counts it, or back.
    pub fn torque(self, value: i16) -> i16 {
        if self.torque {
            value.saturating_neg()
        } else {
            value
        }
    }
}

/// A 32-bit target position object (607Ah, user units) plus `offset` (the CSP position offset
/// 60B0h, user units; 0 where none applies) as increments: the target extended to 64 bits
/// relative to the actual position in user units (`actual_user`, the actual increments through
/// [`Ratio::position_from_internal`]; so it is right across wraps of the 32-bit object), the
/// offset added, then scaled once (CiA402's CSP sums the two before the factor group; one
/// rounding, not two). The caller converts the actual position once per cycle: 6064h shows
/// it too.
pub fn target_position(target: i32, offset: i64, actual_user: i64, ratio: Ratio) -> i64 {
    ratio.position_to_internal(extend_position(target, actual_user).saturating_add(offset))
}

/// An actual position in increments as its 32-bit object (6064h, user units; wraps).
pub fn actual_position(increments: i64, ratio: Ratio) -> i32 {
    position_object(ratio.position_from_internal(increments))
}

/// A range of ratios between `min` and `max` (each numerator, denominator), with or without
/// its ends: the values a unit factor may have (the Σ-V-SD's 2301h-2303h, §4.5).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RatioRange {
    /// The smallest ratio.
    pub min: (u32, u32),
    /// The largest ratio.
    pub max: (u32, u32),
    /// The ends belong to the range.
    pub inclusive: bool,
}

impl RatioRange {
    /// Whether `numerator / denominator` is in the range (compared as products, exact; a
    /// denominator of 0 is not a ratio).
    pub fn contains(&self, numerator: u32, denominator: u32) -> bool {
        use core::cmp::Ordering::{Greater, Less};
        if denominator == 0 {
            return false;
        }
        // n/d against a/b: n·b against a·d (u32 × u32 fits u64, so the widening multiply
        // never wraps).
        let against = |(a, b): (u32, u32)| {
            (u64::from(numerator).wrapping_mul(u64::from(b)))
                .cmp(&(u64::from(a).wrapping_mul(u64::from(denominator))))
        };
        let (low, high) = (against(self.min), against(self.max));
        if self.inclusive {
            low != Less && high != Greater
        } else {
            low == Greater && high == Less
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The next state of a xorshift64 generator (the tests' reproducible inputs).
    fn xorshift(x: &mut u64) {
        *x ^= *x << 13;
        *x ^= *x >> 7;
        *x ^= *x << 17;
    }

    /// `value × n / d` rounded to the nearest, halves away from zero, in exact 128-bit
    /// arithmetic (the reference), saturated to i64.
    fn reference(value: i64, n: u64, d: u64) -> i64 {
        let p = i128::from(value) * i128::from(n);
        let (q, r) = (p / i128::from(d), p % i128::from(d));
        let q = if 2 * r.abs() >= i128::from(d) {
            q + p.signum()
        } else {
            q
        };
        q.clamp(i128::from(i64::MIN), i128::from(i64::MAX)) as i64
    }

    /// The 128-bit path on its own: halves away from zero, saturation at both ends of the i64
    /// range (−2^63 itself is representable), the largest factors, and 0 for a 0 divisor.
    #[test]
    fn the_wide_path_rounds_and_saturates_as_the_exact_division() {
        let cases = [
            (i64::MIN, 2, 2),
            (i64::MIN, 3, 3),
            (i64::MIN + 1, 3, 3),
            (i64::MAX, 3, 2),
            (i64::MIN, 3, 2),
            (i64::MAX, u64::MAX, u64::MAX),
            (i64::MIN, u64::MAX, u64::MAX),
            (-5, u64::MAX, u64::MAX - 1),
            (i64::MAX, 1 << 40, (1 << 41) + 1),
            (-(1 << 62) - 3, 6, 4),
            ((1 << 62) + 1, 6, 4),
            ((1 << 62) + 3, 10, 4),
            (-(1 << 62) - 3, 10, 4),
            (i64::MAX, 1 << 63, 1),
        ];
        for (v, m, d) in cases {
            // By the restoring division, and by the reciprocal where the divisor has one.
            assert_eq!(scale_wide(v, m, d, 0), reference(v, m, d), "{v}·{m}/{d}");
            let inv = reciprocal(d);
            assert_eq!(
                scale_wide(v, m, d, inv),
                reference(v, m, d),
                "{v}·{m}/{d}, inv"
            );
        }
        assert_eq!(scale_wide(5, 3, 0, 0), 0);
    }

    /// Products beyond 64 bits divided by 32-bit divisors through the reciprocal (two steps of
    /// 32 quotient bits) give the exact quotient, pseudo-random and at the divisors' ends.
    #[test]
    fn the_wide_path_divides_by_the_reciprocal_exactly() {
        let mut x: u64 = 0x2545_F491_4F6C_DD1D;
        let ends = [
            1u64,
            2,
            3,
            7,
            10_000,
            (1 << 31) + 1,
            u64::from(u32::MAX) - 1,
            u64::from(u32::MAX),
        ];
        for i in 0..20_000u64 {
            xorshift(&mut x);
            let d = ends.get(i as usize).copied().unwrap_or((x >> 32).max(1));
            let m = x | (1 << 40);
            let v = (x.rotate_left(17) as i64) >> (x % 20);
            let inv = reciprocal(d);
            assert_ne!(inv, 0);
            assert_eq!(scale_wide(v, m, d, inv), reference(v, m, d), "{v}·{m}/{d}");
        }
    }

    /// Positions beyond 32 bits with 32-bit factors: exact through the reciprocal for every
    /// quotient within the i64 range, the product within 64 bits or beyond (a quotient beyond
    /// i64 is left to the general path, which saturates).
    #[test]
    fn a_long_position_converts_exactly_through_the_reciprocal() {
        // Powers of two (divided by a shift) and others (through the reciprocal).
        let divisors = [
            1u64,
            2,
            3,
            10_000,
            1 << 17,
            1 << 31,
            (1 << 31) + 1,
            u64::from(u32::MAX),
        ];
        let mut x: u64 = 0xD1B5_4A32_D192_ED03;
        for i in 0..30_000u64 {
            xorshift(&mut x);
            let d = divisors
                .get(i as usize % 10)
                .copied()
                .unwrap_or((x >> 40) | 1);
            let m = (x & 0xFFFF_FFFF).max(1);
            // Magnitudes from 2³² up (products within and beyond 64 bits), and the ones whose
            // product lands at 2⁶⁴ (± a little) or whose quotient lands at 2⁶³.
            let v = match i % 4 {
                0 => {
                    let edge = (u128::from(u64::MAX) / u128::from(m)) as u64;
                    edge.wrapping_add((x >> 60).wrapping_sub(8))
                        .min(i64::MAX as u64) as i64
                }
                1 => {
                    let edge = (u128::from(i64::MAX as u64) * u128::from(d) / u128::from(m))
                        .min(i64::MAX as u128) as u64;
                    edge.wrapping_sub(x >> 61).max(1 << 32) as i64
                }
                // Within the i64 range, so that its negation is one too.
                _ => (x.rotate_left(23) >> (x % 30)).clamp(1 << 32, i64::MAX as u64) as i64,
            };
            for v in [v, -v] {
                let inv = reciprocal(d);
                let expected = reference(v, m, d);
                // Every quotient within the i64 range takes this path, and exactly.
                if expected.unsigned_abs() < i64::MAX as u64 {
                    assert_eq!(
                        scale_long_position(v, m, d, inv),
                        Some(expected),
                        "{v}·{m}/{d}"
                    );
                }
                assert_eq!(scale(v, m, d, inv), expected, "{v}·{m}/{d}");
            }
        }
        // The product plus half the divisor passing 2⁶⁴: in two digits.
        let (m, d) = (u64::from(u32::MAX), 3u64);
        let v = (u64::MAX / m) as i64;
        assert_eq!(
            scale_long_position(v, m, d, reciprocal(d)),
            Some(reference(v, m, d))
        );
        // A quotient beyond the i64 range: not this path; the general one saturates.
        assert_eq!(scale_long_position(i64::MAX, 2, 1, reciprocal(1)), None);
        assert_eq!(scale(i64::MAX, 2, 1, reciprocal(1)), i64::MAX);
        assert_eq!(scale(i64::MIN + 1, 2, 1, reciprocal(1)), i64::MIN);
    }

    #[test]
    fn gcd_is_the_greatest_common_divisor() {
        fn euclid(a: u64, b: u64) -> u64 {
            if b == 0 {
                a
            } else {
                euclid(b, a % b)
            }
        }
        let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
        let specials = [0, 1, 2, 3, 1 << 63, u64::MAX, (1 << 40) * 3, 600, 10_000];
        for i in 0..20_000u32 {
            xorshift(&mut x);
            // Shared factors: a common multiplier, so that gcds above 1 are common too.
            let common = (x >> 48) | 1;
            let (a, b) = match i % 3 {
                0 => (x >> (x % 64), x.rotate_left(29) >> (x % 61)),
                1 => (
                    (x >> 40).wrapping_mul(common),
                    (x & 0xFF_FFFF).wrapping_mul(common),
                ),
                _ => (
                    specials[(x % 9) as usize],
                    specials[((x >> 8) % 9) as usize],
                ),
            };
            assert_eq!(gcd(a, b), euclid(a, b), "gcd({a}, {b})");
        }
    }

    #[test]
    fn ratios_are_equal_as_values() {
        assert_eq!(Ratio::new(2, 4), Ratio::new(1, 2));
        assert_eq!(Ratio::new(1 << 40, 3), Ratio::new(1 << 41, 6));
        assert_ne!(Ratio::new(1, 2), Ratio::new(1, 3));
        // Cross products equal in their low 64 bits (both 0) but not above: 2¹⁵ against 2¹⁰.
        assert_ne!(Ratio::new(1 << 40, 1 << 25), Ratio::new(1 << 40, 1 << 30));
        // A ratio in lowest terms equals its unreduced form.
        let (n, d) = (3 * (1u64 << 40), 5 * (1u64 << 36));
        assert_eq!(Ratio::new(n, d).prepared(), Ratio::new(n, d));
        assert_eq!(Ratio::new(n, d).prepared(), Ratio::new(48, 5));
    }

    #[test]
    fn a_ratio_beyond_32_bits_is_prepared_in_lowest_terms() {
        // A gear ratio times a feed constant (2²⁰ increments per 7 turns, 10⁶ units per 2¹²
        // turns): 2²⁰·10⁶ / (7·2¹²), a numerator beyond 32 bits, = 2⁸·10⁶ / 7.
        let (n, d) = ((1u64 << 20) * 1_000_000, 7 * (1u64 << 12));
        let r = Ratio::new(n, d).prepared();
        assert_eq!((r.numerator, r.denominator), (256_000_000, 7));
        assert!(
            r.inv_numerator != 0 && r.inv_denominator != 0,
            "both reciprocals"
        );
        let mut x: u64 = 0x2545_F491_4F6C_DD1D;
        for _ in 0..5_000 {
            xorshift(&mut x);
            let v = (x >> (x % 40)) as i64 * if x & 1 == 0 { 1 } else { -1 };
            assert_eq!(r.position_to_internal(v), reference(v, n, d), "{v}");
            assert_eq!(r.position_from_internal(v), reference(v, d, n), "{v}");
        }
        // Within 32 bits a ratio keeps its terms (they take the short paths already).
        let small = Ratio::new(131_072, 10_000).prepared();
        assert_eq!((small.numerator, small.denominator), (131_072, 10_000));
        // Coprime sides beyond 32 bits stay as they are.
        let coprime = Ratio::new(1 << 40, (1 << 33) + 1).prepared();
        assert_eq!(
            (coprime.numerator, coprime.denominator),
            (1 << 40, (1 << 33) + 1)
        );
    }

    #[test]
    fn a_prepared_ratio_converts_exactly_as_the_division() {
        let sides = [
            1u64,
            2,
            3,
            7,
            10,
            600,
            1_000,
            4_096,
            10_000,
            131_072,
            1 << 20,
            1 << 31,
            u64::from(u32::MAX) - 1,
            u64::from(u32::MAX),
            u64::from(u32::MAX) + 1,
            1 << 40,
        ];
        let values = [
            0i64,
            1,
            -1,
            2,
            -2,
            3,
            5,
            7,
            4_999,
            5_000,
            5_001,
            -5_000,
            123_456_789,
            -987_654_321,
            i64::from(i32::MAX),
            i64::from(i32::MIN),
            // The ends of the 32-bit fast path and just beyond.
            i64::from(u32::MAX),
            -i64::from(u32::MAX),
            i64::from(u32::MAX) + 1,
            -i64::from(u32::MAX) - 1,
            1 << 40,
            -(1 << 40),
            i64::MAX / 3,
            i64::MIN / 3,
            i64::MAX,
            i64::MIN,
            i64::MIN + 1,
        ];
        for n in sides {
            for d in sides {
                let plain = Ratio::new(n, d);
                let prepared = plain.prepared();
                assert_eq!(plain, prepared, "equality ignores the reciprocals");
                for v in values {
                    assert_eq!(
                        prepared.position_to_internal(v),
                        reference(v, n, d),
                        "{v}·{n}/{d}"
                    );
                    assert_eq!(
                        plain.position_to_internal(v),
                        reference(v, n, d),
                        "{v}·{n}/{d}"
                    );
                    assert_eq!(
                        prepared.position_from_internal(v),
                        reference(v, d, n),
                        "{v}·{d}/{n}"
                    );
                }
            }
        }
        // Pseudo-random products near the reciprocal's error bound (large magnitudes).
        let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
        for _ in 0..20_000 {
            xorshift(&mut x);
            let d = (x >> 32) | 1;
            let n = (x & 0xFFFF) + 1;
            let v = (x as i64) >> (x % 48);
            let r = Ratio::new(n, d).prepared();
            assert_eq!(r.position_to_internal(v), reference(v, n, d), "{v}·{n}/{d}");
        }
    }

    /// The 32-bit path against the exact quotient at every power-of-two divisor (the shift)
    /// and around the halves, up to the largest operands.
    #[test]
    fn the_32_bit_path_rounds_halves_up_at_every_power_of_two() {
        for k in 0..32u32 {
            let d = 1u64 << k;
            let inv = reciprocal(d);
            for m in [1, 2, 3, 1_000, d - 1, d, d + 1, u64::from(u32::MAX)] {
                for v in [
                    0i64,
                    1,
                    -1,
                    (d / 2) as i64,
                    -((d / 2) as i64),
                    (d + d / 2) as i64,
                    (3 * d / 2 + 1) as i64,
                    i64::from(u32::MAX),
                    -i64::from(u32::MAX),
                ] {
                    let m = m.max(1);
                    assert_eq!(scale(v, m, d, inv), reference(v, m, d), "{v}·{m}/2^{k}");
                }
            }
        }
    }

    /// Operands anywhere in 32 bits (the path every SYNC0 cycle takes): pseudo-random factors,
    /// values and signs, both directions of the prepared ratio, against the exact quotient.
    #[test]
    fn the_32_bit_path_converts_exactly_over_the_whole_operand_range() {
        let mut x: u64 = 0xD1B5_4A32_D192_ED03;
        for _ in 0..200_000 {
            xorshift(&mut x);
            let (n, d) = (((x >> 32) >> (x % 31)).max(1), (x & 0xFFFF_FFFF).max(1));
            let v = (x.rotate_left(23) as u32 as i64) * if x & 1 == 0 { 1 } else { -1 };
            let r = Ratio::new(n, d).prepared();
            assert_eq!(r.position_to_internal(v), reference(v, n, d), "{v}·{n}/{d}");
            assert_eq!(
                r.position_from_internal(v),
                reference(v, d, n),
                "{v}·{d}/{n}"
            );
        }
    }

    /// The reciprocal's estimate needs at most one correction (the bound [`divide_floor`]
    /// relies on; were it wrong, a conversion would take the slow path, not a wrong result):
    /// every divisor end, dividends at the top of the range and next to multiples of the
    /// divisor, and pseudo-random ones.
    #[test]
    fn the_reciprocal_division_needs_one_correction_at_most() {
        let check = |m: u64, d: u64| {
            let Some((q, r)) = divide_floor(m, d as u32, reciprocal(d)) else {
                panic!("{m} / {d}: a second correction was due");
            };
            assert_eq!((q, r), (m / d, m % d), "{m} / {d}");
        };
        let mut x: u64 = 0x8CB9_2BA7_2F3D_8DD7;
        for i in 0..200_000u64 {
            xorshift(&mut x);
            let d = match i % 4 {
                0 => (x >> 32).max(1),
                1 => 1 << (x % 32),
                2 => u64::from(u32::MAX) - (x % 3),
                _ => (x >> (32 + x % 32)).max(1),
            };
            for m in [
                x,
                u64::MAX - (x >> 40),
                (u64::MAX / d) * d,
                ((u64::MAX / d) * d).wrapping_sub(1),
                (x / d) * d,
                ((x / d) * d).wrapping_sub(1),
            ] {
                check(m, d);
            }
        }
    }

    /// A window in user units as increments: the result converts to at most the window and one
    /// more increment to beyond it (the boundary, with the conversion's own rounding), for
    /// pseudo-random 32-bit ratios and windows, and the ratios it leaves to the caller.
    #[test]
    fn a_window_in_increments_is_the_boundary_of_the_conversion() {
        let mut x: u64 = 0x5851_F42D_4C95_7F2D;
        for i in 0..100_000u32 {
            xorshift(&mut x);
            let (n, d) = (
                ((x >> 32) >> (x % 29)).max(1),
                ((x & 0xFFFF_FFFF) >> (x % 31)).max(1),
            );
            let w = match i % 4 {
                0 => 0,
                1 => (x >> 7) as u32 & 0xFFFF,
                2 => u32::MAX - 1,
                _ => (x >> 3) as u32,
            };
            let r = Ratio::new(n, d).prepared();
            let within = r.increments_within(w).expect("a 32-bit ratio");
            let at = |inc: u64| i64::try_from(inc).ok().map(|v| r.position_from_internal(v));
            let fits = |inc| at(inc).is_none_or(|u| u <= i64::from(w));
            assert!(fits(within), "{w} units at {n}/{d}: {within}");
            if let Some(beyond) = within.checked_add(1).and_then(at) {
                assert!(beyond > i64::from(w), "{w} units at {n}/{d}: {within} + 1");
            }
        }
        assert_eq!(Ratio::ONE.increments_within(7), Some(7));
        let half = Ratio::new(3, 2).prepared();
        // round(2x/3) ≤ 1 up to x = 2 (1.33), not 3 (2).
        assert_eq!(half.increments_within(1), Some(2));
        assert_eq!(Ratio::new(3, 2).increments_within(1), None, "not prepared");
        assert_eq!(Ratio::new(1 << 40, 3).prepared().increments_within(1), None);
    }

    #[test]
    fn scaling_rounds_saturates_and_refuses_a_zero_divisor_without_panicking() {
        // Without a reciprocal (the division) and with one (the multiplications).
        for inv in [0, reciprocal(2)] {
            assert_eq!(scale(7, 1, 2, inv), 4, "3.5 rounds away from zero");
            assert_eq!(scale(-7, 1, 2, inv), -4);
        }
        assert_eq!(scale(i64::MAX, u64::MAX, 1, 0), i64::MAX, "saturated");
        assert_eq!(scale(i64::MAX, u64::MAX, 1, reciprocal(1)), i64::MAX);
        assert_eq!(scale(i64::MIN, u64::MAX, 3, 0), i64::MIN);
        assert_eq!(scale(i64::MIN, u64::MAX, 3, reciprocal(3)), i64::MIN);
        assert_eq!(scale(i64::MIN, 1, 1, reciprocal(1)), i64::MIN, "−2⁶³ / 1");
        assert_eq!(
            scale(i64::MAX, u64::MAX, u64::MAX, 0),
            i64::MAX,
            "through 128 bits"
        );
        assert_eq!(scale(5, 1, 0, 0), 0);
        assert_eq!(
            reciprocal(0),
            0,
            "no reciprocal of 0: the division path refuses it"
        );
        assert_eq!(scale(5, u64::MAX, 0, 0), 0, "the wide path");
    }

    #[test]
    fn ratios_scale_positions_and_velocities_both_ways() {
        // 10 000 increments per user unit (e.g. 6091h = 10000:1).
        let r = Ratio::new(10_000, 1);
        assert_eq!(r.position_to_internal(3), 30_000);
        assert_eq!(r.position_from_internal(30_009), 3);
        assert_eq!(r.position_from_internal(-30_009), -3);
        // The nearest unit, halves away from zero.
        assert_eq!(r.position_from_internal(34_999), 3);
        assert_eq!(r.position_from_internal(35_000), 4);
        assert_eq!(r.position_from_internal(-35_000), -4);
        assert_eq!(r.position_from_internal(-34_999), -3);
        assert_eq!(r.scale().velocity_to_internal(2.5), 25_000.0);
        assert_eq!(r.scale().velocity_from_internal(25_000.0), 2.5);
        // 1 user unit = 1/4 increment (numerator < denominator).
        let q = Ratio::new(1, 4);
        assert_eq!(q.position_to_internal(400), 100);
        assert_eq!(q.position_from_internal(100), 400);
        // 0.1 rpm per velocity unit at 2^17 increments/rev: × 131072 / 600.
        let rpm = Ratio::new(1 << 17, 1).times(Ratio::new(1, 600));
        assert_eq!(rpm.scale().velocity_to_internal(600.0), 131_072.0);
    }

    #[test]
    fn a_target_reads_back_as_itself_through_a_fractional_ratio() {
        // The GHA-E's 6091h = 131072 / 10000: 13.1072 increments per instruction unit.
        let r = Ratio::new(131_072, 10_000);
        for user in (-100_000..100_000).step_by(7) {
            assert_eq!(r.position_from_internal(r.position_to_internal(user)), user);
        }
        assert_eq!(r.position_to_internal(12_345), 161_808, "161 808.384");
        assert_eq!(r.position_to_internal(-1), -13, "-13.1072");
    }

    #[test]
    fn a_zero_factor_is_one_and_nothing_overflows() {
        assert_eq!(Ratio::new(0, 5), Ratio::ONE);
        assert_eq!(Ratio::new(5, 0), Ratio::ONE);
        let huge = Ratio::new(u64::MAX, 1);
        assert_eq!(huge.position_to_internal(i64::MAX), i64::MAX);
        assert_eq!(huge.position_to_internal(i64::MIN), i64::MIN);
        assert_eq!(
            Ratio::new(1, u64::MAX).position_from_internal(i64::MAX),
            i64::MAX
        );
        assert_eq!(huge.times(huge), Ratio::new(u64::MAX, 1));
    }

    #[test]
    fn a_product_beyond_64_bits_still_converts_exactly() {
        // 2^40 × 2^30 overflows i64; the quotient 2^50 does not.
        let r = Ratio::new(1 << 30, 1 << 20);
        assert_eq!(r.position_to_internal(1 << 40), 1 << 50);
        assert_eq!(r.position_to_internal(-(1 << 40)), -(1 << 50));
        assert_eq!(r.position_from_internal(1 << 50), 1 << 40);
        // Near the boundary both ways agree with the exact quotient, rounded to the nearest:
        // i64::MAX = 3k + 1, so MAX / 3 = k + 1/3 and 2 MAX / 3 = 2k + 2/3.
        let third = Ratio::new(i64::MAX as u64, 3);
        assert_eq!(third.position_to_internal(1), i64::MAX / 3);
        assert_eq!(third.position_to_internal(-2), -(i64::MAX / 3 * 2) - 1);
    }

    #[test]
    fn polarity_bits_invert_their_objects_and_are_their_own_inverse() {
        // CiA402 607Eh: bit 7 position, bit 6 velocity; the GHA-E's bit 5 torque (0xE0 = all).
        let all = Polarity::from_object(0xE0);
        assert_eq!(
            (all.position(5), all.velocity(-7), all.torque(300)),
            (-5, 7, -300)
        );
        assert_eq!(all.position(all.position(123_456)), 123_456);
        assert_eq!(all.position(i32::MIN), i32::MAX, "saturates, no overflow");
        assert_eq!(all.torque(i16::MIN), i16::MAX);
        let position_only = Polarity::from_object(0x80);
        assert_eq!(
            (
                position_only.position(5),
                position_only.velocity(5),
                position_only.torque(5)
            ),
            (-5, 5, 5)
        );
        assert_eq!(
            Polarity::from_object(0x1F),
            Polarity::NONE,
            "bits 0-4 reserved"
        );
    }

    #[test]
    fn target_positions_extend_in_user_units() {
        let r = Ratio::new(1000, 1);
        // Actual 5 000 000 increments = 5000 units; a target of 5010 units is 10 units ahead.
        let actual = |increments| r.position_from_internal(increments);
        assert_eq!(target_position(5010, 0, actual(5_000_000), r), 5_010_000);
        // The nearest unit.
        assert_eq!(actual_position(5_000_499, r), 5000);
        assert_eq!(actual_position(5_000_500, r), 5001);
        // Across the wrap of the 32-bit user object.
        let near = (i64::from(i32::MAX) - 1) * 1000;
        assert_eq!(target_position(i32::MIN, 0, actual(near), r), near + 2000);
        assert_eq!(target_position(7, 0, 7, Ratio::ONE), 7);
        // The CSP position offset 60B0h joins the target in user units, across the wrap too,
        // and the sum is rounded once: 1.5 increments per unit, 1 + 1 units are 3 increments
        // (each rounded on its own, 2 + 2).
        assert_eq!(target_position(5010, -20, actual(5_000_000), r), 4_990_000);
        assert_eq!(target_position(i32::MIN, 3, actual(near), r), near + 5000);
        let half = Ratio::new(3, 2).prepared();
        assert_eq!(target_position(1, 0, 0, half), 2);
        assert_eq!(target_position(1, 1, 0, half), 3);
        assert_eq!(target_position(-1, -1, 0, half), -3);
    }

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
        assert_eq!(torque_to_permille(-1e9, rated), i16::MIN);
        assert_eq!(torque_to_permille(f32::INFINITY, rated), i16::MAX);
        assert_eq!(torque_to_permille(f32::NEG_INFINITY, rated), i16::MIN);
    }

    /// Every torque object value survives the round trip through N·m for rated torques whose
    /// ‰ is not exact in binary (0.001 × 3.3 N·m): 30 ‰ read back as 29 when the object value
    /// was truncated.
    #[test]
    fn every_torque_object_value_round_trips_through_newton_metres() {
        for rated in [0.1, 1.0, 2.0, 3.3, 7.77, 45.0] {
            for permille in i16::MIN..=i16::MAX {
                let nm = torque_from_permille(permille, rated);
                assert_eq!(
                    torque_to_permille(nm, rated),
                    permille,
                    "{permille} ‰ of {rated}"
                );
            }
        }
        // To the nearest, either sign (a half is not exact in binary here: `velocity_object`'s
        // test has the halves).
        assert_eq!(torque_to_permille(0.0016, 1.0), 2);
        assert_eq!(torque_to_permille(-0.0016, 1.0), -2);
        assert_eq!(torque_to_permille(0.0014, 1.0), 1);
        assert_eq!(torque_to_permille(-0.0014, 1.0), -1);
    }

    /// A velocity object value survives the round trip through increments/s with a fractional
    /// factor (the GHA-E's 13.1072 increments per unit: 2000 units/s read back as 1999 when the
    /// object value was truncated), over the speeds a drive runs at.
    #[test]
    fn velocity_objects_round_trip_through_a_fractional_factor() {
        let scale = Ratio::new(131_072, 10_000).scale();
        let mut x = 0x9E37_79B9_7F4A_7C15_u64;
        for _ in 0..100_000 {
            xorshift(&mut x);
            // |v| ≤ 2²¹ units/s (27·10⁶ increments/s: 26 rev/s of a 20-bit encoder): the two
            // roundings of f32 stay below half a unit up to some 2²⁴ / 6.
            let v = (x >> 42) as i32 - (1 << 21);
            let back =
                velocity_object(scale.velocity_from_internal(scale.velocity_to_internal(v as f32)));
            assert_eq!(back, v);
        }
        assert_eq!(velocity_object(2.5), 3);
        assert_eq!(velocity_object(-2.5), -3);
        assert_eq!(velocity_object(2.49), 2);
        assert_eq!(velocity_object(f32::NAN), 0);
        assert_eq!(velocity_object(1e12), i32::MAX);
        assert_eq!(velocity_object(-1e12), i32::MIN);
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

#[cfg(test)]
mod ratio_ranges {
    use super::RatioRange;

    /// The Σ-V-SD's 2301h "1/4096 < N/D < 4096" and 2302h "1/128 <= N/D <= 524288" (§4.5).
    #[test]
    fn ratios_are_compared_exactly_with_or_without_the_ends() {
        let open = RatioRange {
            min: (1, 4096),
            max: (4096, 1),
            inclusive: false,
        };
        assert!(open.contains(1, 1) && open.contains(4095, 1) && open.contains(2, 8191));
        assert!(!open.contains(4096, 1) && !open.contains(1, 4096) && !open.contains(8192, 2));
        assert!(!open.contains(u32::MAX, 1) && !open.contains(1, u32::MAX));
        let closed = RatioRange {
            min: (1, 128),
            max: (524_288, 1),
            inclusive: true,
        };
        assert!(closed.contains(524_288, 1) && closed.contains(1, 128) && closed.contains(2, 256));
        assert!(!closed.contains(524_289, 1) && !closed.contains(1, 129));
        assert!(!closed.contains(1, 0) && !closed.contains(0, 0), "no ratio");
    }
}
