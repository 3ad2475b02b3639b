//! The few math kernels the control interrupt needs, written so that they compile to plain FPU
//! instructions on a Cortex-M4F.
//!
//! Why not `libm` / `f32` methods: on `thumbv7em-none-eabihf` `libm::sinf`/`cosf` reduce their
//! argument in `f64` (soft-double, ~2,300 instructions for both), `libm::sqrtf` is a software
//! square root (58 instructions), `f32::min/max` become calls to `fminf/fmaxf` (NaN handling) and
//! `f32::clamp` carries a panic path. `core` has no `f32::sqrt` on stable. The kernels here are
//! deterministic and identical on the host and the target, so the simulation runs the very
//! numbers the board runs.

use super::ElectricalAngle;

/// π as `f32`.
pub const PI: f32 = core::f32::consts::PI;
/// 2π as `f32`.
pub const TAU: f32 = core::f32::consts::TAU;
/// √3 / 2.
pub const SQRT3_2: f32 = 0.866_025_4;
/// 1 / √3.
pub const INV_SQRT3: f32 = 0.577_350_26;
/// 2 / √3.
pub const TWO_INV_SQRT3: f32 = 1.154_700_5;

/// A quarter turn (π/2) per unit of the quarter-turn fraction.
const QUARTER_TURN_RAD: f32 = core::f32::consts::FRAC_PI_2;
/// Eighth turn: the polynomials are centred here so that |x| ≤ π/4.
const EIGHTH_TURN_RAD: f32 = core::f32::consts::FRAC_PI_4;
/// √½, to rotate the centred result back by π/4.
const SQRT_HALF: f32 = core::f32::consts::FRAC_1_SQRT_2;
/// 2^-32: one unit of a 32-bit angle fraction.
const ANGLE_LSB: f32 = 1.0 / 4_294_967_296.0;
/// 2^-30: one unit of the fraction within a quarter turn (the 30 bits below the quadrant).
const QUARTER_LSB: f32 = 1.0 / 1_073_741_824.0;

/// Taylor coefficients of sin and cos, enough for |x| ≤ π/4: the truncation error is below
/// 3.2e-7 (sin, x⁹/9!) and 3.6e-6 (cos, x⁸/8!).
const S3: f32 = -1.0 / 6.0;
const S5: f32 = 1.0 / 120.0;
const S7: f32 = -1.0 / 5_040.0;
const C2: f32 = -0.5;
const C4: f32 = 1.0 / 24.0;
const C6: f32 = -1.0 / 720.0;

/// `(sin, cos)` of an electrical angle, absolute error below 5e-6.
///
/// Timing: about 30 instructions on a Cortex-M4F, no branches except the quadrant select.
#[inline]
pub fn sin_cos(angle: ElectricalAngle) -> (f32, f32) {
    let bits = angle.to_bits();
    let quadrant = bits >> 30;
    // Position within the quarter turn, centred: x ∈ [-π/4, π/4).
    let x = ((bits & 0x3FFF_FFFF) as f32) * (QUARTER_LSB * QUARTER_TURN_RAD) - EIGHTH_TURN_RAD;
    let x2 = x * x;
    let s = x * (1.0 + x2 * (S3 + x2 * (S5 + x2 * S7)));
    let c = 1.0 + x2 * (C2 + x2 * (C4 + x2 * C6));
    // sin(π/4 + x) and cos(π/4 + x).
    let sin_q = (s + c) * SQRT_HALF;
    let cos_q = (c - s) * SQRT_HALF;
    match quadrant {
        0 => (sin_q, cos_q),
        1 => (cos_q, -sin_q),
        2 => (-sin_q, -cos_q),
        _ => (-cos_q, sin_q),
    }
}

/// `(sin, cos)` of an angle in radians (any value; for configuration-time code such as filter
/// design, not for the control interrupt).
pub fn sin_cos_rad(rad: f32) -> (f32, f32) {
    sin_cos(angle_from_radians(rad))
}

/// The electrical angle of `rad` radians, wrapped into one turn.
#[inline]
pub fn angle_from_radians(rad: f32) -> ElectricalAngle {
    angle_from_turns(rad * (1.0 / TAU))
}

/// The electrical angle of `turns` turns (any value), wrapped into one turn. The fraction is
/// taken in `f32`, so its resolution is that of `turns` (2^-24 relative).
#[inline]
pub fn angle_from_turns(turns: f32) -> ElectricalAngle {
    // Truncation of a negative value rounds towards zero; wrapping the i32 image makes the
    // result the same point on the circle.
    let whole = turns as i32;
    let fraction = turns - whole as f32;
    ElectricalAngle::from_bits((fraction * 4_294_967_296.0) as i64 as u32)
}

/// The angle in radians, 0 ≤ result < 2π.
#[inline]
pub fn angle_to_radians(angle: ElectricalAngle) -> f32 {
    angle.to_bits() as f32 * (ANGLE_LSB * TAU)
}

/// The signed difference `a − b` in radians, in [−π, π).
#[inline]
pub fn angle_difference_rad(a: ElectricalAngle, b: ElectricalAngle) -> f32 {
    (a.to_bits().wrapping_sub(b.to_bits()) as i32) as f32 * (ANGLE_LSB * TAU)
}

/// 1/√x for x > 0: the bit-level initial guess refined by two Newton steps (relative error
/// below 5e-6). Returns 0 for x ≤ 0 and non-finite x, so a limiter fed garbage does not scale
/// by garbage.
///
/// Timing: about 12 instructions, no division, no library call.
#[inline]
pub fn inv_sqrt(x: f32) -> f32 {
    if !(x > 0.0 && x < f32::INFINITY) {
        return 0.0;
    }
    // Magic constant of the classic fast inverse square root (Lomont's refinement).
    let mut y = f32::from_bits(0x5F37_59DF_u32.wrapping_sub(x.to_bits() >> 1));
    let half = 0.5 * x;
    y *= 1.5 - half * y * y;
    y *= 1.5 - half * y * y;
    y
}

/// √x for 0 < x < ∞; 0 for x ≤ 0 and non-finite x (as [`inv_sqrt`]).
///
/// On the Cortex-M4F one VSQRT (correctly rounded; 14 cycles, about 10 instructions with the
/// checks and register moves); elsewhere (the host) x · [`inv_sqrt`]`(x)`, relative error below
/// 5e-6. The software form costs some 30 instructions on the target.
#[inline]
pub fn sqrt(x: f32) -> f32 {
    #[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
    {
        // VSQRT gives NaN below 0 and for NaN, ∞ for ∞: one compare after it maps them to 0
        // (cheaper than checking the argument first).
        let root = hardware_sqrt(x);
        if root < f32::INFINITY {
            root
        } else {
            0.0
        }
    }
    #[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
    {
        // inv_sqrt is 0 outside the domain; ∞ · 0 would be NaN.
        if x < f32::INFINITY {
            x * inv_sqrt(x)
        } else {
            0.0
        }
    }
}

/// √x as IEEE 754 defines it, without the domain checks of [`sqrt`]: NaN for x < 0 and for
/// NaN, ∞ for ∞. For a caller whose argument is never negative by construction and whose
/// result is checked downstream anyway (the current loop's voltage circle: the modulator turns a
/// NaN into the zero vector); it saves [`sqrt`]'s compare and selects.
///
/// On the Cortex-M4F one VSQRT (about 7 instructions with the register moves); elsewhere (the
/// host) x · [`inv_sqrt`]`(x)` in the domain, relative error below 5e-6.
#[inline]
pub fn sqrt_unguarded(x: f32) -> f32 {
    #[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
    {
        hardware_sqrt(x)
    }
    #[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
    {
        if x == f32::INFINITY {
            x
        } else if x >= 0.0 {
            x * inv_sqrt(x)
        } else {
            f32::NAN
        }
    }
}

/// VSQRT of the single-precision FPU (every `eabihf` Arm target this firmware builds for has
/// one: Cortex-M4F, M7). Stable Rust cannot name S registers as asm operands on this target
/// (the `sreg` class needs the `vfp2` feature, which the target does not declare), so the
/// value passes through a core register and S15 is saved around the instruction.
#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
#[inline(always)]
fn hardware_sqrt(x: f32) -> f32 {
    let mut bits = x.to_bits();
    // SAFETY: the instructions read and write only `bits` and S15, which they restore; no
    // memory access beyond their own stack slot (balanced push/pop), no flags changed.
    unsafe {
        core::arch::asm!(
            "vpush {{s15}}",
            "vmov s15, {0}",
            "vsqrt.f32 s15, s15",
            "vmov {0}, s15",
            "vpop {{s15}}",
            inout(reg) bits,
            options(pure, nomem, preserves_flags),
        );
    }
    f32::from_bits(bits)
}

/// The smaller of `a` and `b` (compare-select; `f32::min` is a library call on the target).
#[inline]
pub fn min(a: f32, b: f32) -> f32 {
    if a < b {
        a
    } else {
        b
    }
}

/// The larger of `a` and `b`.
#[inline]
pub fn max(a: f32, b: f32) -> f32 {
    if a > b {
        a
    } else {
        b
    }
}

/// `x` limited to `lo..=hi` (expects `lo ≤ hi`; never panics: with `lo > hi` the result is
/// `hi`). A NaN `x` gives `lo`, so a NaN never propagates through a limiter.
#[inline]
pub fn clamp(x: f32, lo: f32, hi: f32) -> f32 {
    min(max(x, lo), hi)
}

/// `x` limited to `−limit..=limit`.
#[inline]
pub fn clamp_symmetric(x: f32, limit: f32) -> f32 {
    clamp(x, -limit, limit)
}

/// The sign of `x` as ±1.0 (+1.0 for zero).
#[inline]
pub fn sign(x: f32) -> f32 {
    if x < 0.0 {
        -1.0
    } else {
        1.0
    }
}

/// `x` saturated to the i32 range, as an f32: one FPU conversion, where `x as f32` of an i64 is
/// a library call of some 40 instructions on the Cortex-M4 (and the compiler folds a range
/// check around it back into that call). For quantities whose magnitude beyond 2^31 does not
/// matter.
#[inline]
pub fn saturating_f32(x: i64) -> f32 {
    let narrow = x.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32;
    narrow as f32
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;

    #[test]
    fn saturating_f32_converts_the_i32_range_and_saturates_beyond() {
        for x in [0i64, 1, -1, 16_777_217, -16_777_217, 1_000_000_007] {
            assert_eq!(saturating_f32(x), x as f32, "{x}");
        }
        assert_eq!(saturating_f32(1 << 40), i32::MAX as f32);
        assert_eq!(saturating_f32(i64::MIN), i32::MIN as f32);
    }

    #[test]
    fn sin_cos_matches_the_f64_reference_around_the_circle() {
        let mut worst = 0.0f64;
        for step in 0..100_000u64 {
            let bits = (step * 42_949) as u32 ^ (step as u32).rotate_left(7);
            let (s, c) = sin_cos(ElectricalAngle::from_bits(bits));
            let rad = bits as f64 / 4_294_967_296.0 * std::f64::consts::TAU;
            worst = worst
                .max((s as f64 - rad.sin()).abs())
                .max((c as f64 - rad.cos()).abs());
        }
        assert!(worst < 5e-6, "worst error {worst}");
    }

    #[test]
    fn sin_cos_at_the_quadrant_boundaries() {
        for (turns, sin, cos) in [
            (0.0f32, 0.0f32, 1.0f32),
            (0.25, 1.0, 0.0),
            (0.5, 0.0, -1.0),
            (0.75, -1.0, 0.0),
        ] {
            let (s, c) = sin_cos(angle_from_turns(turns));
            assert!((s - sin).abs() < 5e-6 && (c - cos).abs() < 5e-6, "{turns}");
        }
    }

    #[test]
    fn angle_conversions_wrap_and_round_trip() {
        let a = angle_from_radians(-PI / 2.0);
        assert!((angle_to_radians(a) - 1.5 * PI).abs() < 1e-5);
        let b = angle_from_turns(3.25);
        assert!((angle_to_radians(b) - PI / 2.0).abs() < 1e-5);
        let d = angle_difference_rad(angle_from_turns(0.05), angle_from_turns(0.95));
        assert!((d - 0.1 * TAU).abs() < 1e-5, "difference wraps: {d}");
    }

    #[test]
    fn inv_sqrt_and_sqrt_are_accurate_and_total() {
        for x in [1e-6f32, 0.01, 0.5, 1.0, 2.0, 3.0, 100.0, 12_345.0, 1e9] {
            let rel = (sqrt(x) as f64 / (x as f64).sqrt() - 1.0).abs();
            assert!(rel < 5e-6, "sqrt({x}) rel error {rel}");
            let rel = (inv_sqrt(x) as f64 * (x as f64).sqrt() - 1.0).abs();
            assert!(rel < 5e-6, "inv_sqrt({x}) rel error {rel}");
        }
        assert_eq!(sqrt(0.0), 0.0);
        assert_eq!(sqrt(-4.0), 0.0);
        assert_eq!(sqrt(f32::NAN), 0.0);
        assert_eq!(sqrt(f32::INFINITY), 0.0);
        assert_eq!(inv_sqrt(f32::NAN), 0.0);
        assert_eq!(inv_sqrt(f32::INFINITY), 0.0);
    }

    #[test]
    fn sqrt_unguarded_is_ieee_sqrt() {
        for x in [1e-6f32, 0.01, 0.5, 1.0, 2.0, 100.0, 1e9] {
            let rel = (sqrt_unguarded(x) as f64 / (x as f64).sqrt() - 1.0).abs();
            assert!(rel < 5e-6, "sqrt_unguarded({x}) rel error {rel}");
        }
        assert_eq!(sqrt_unguarded(0.0), 0.0);
        assert_eq!(sqrt_unguarded(f32::INFINITY), f32::INFINITY);
        assert!(sqrt_unguarded(-4.0).is_nan());
        assert!(sqrt_unguarded(f32::NAN).is_nan());
    }

    #[test]
    fn compare_select_helpers() {
        assert_eq!(min(1.0, 2.0), 1.0);
        assert_eq!(max(1.0, 2.0), 2.0);
        assert_eq!(clamp(5.0, -1.0, 1.0), 1.0);
        assert_eq!(clamp(-5.0, -1.0, 1.0), -1.0);
        assert_eq!(clamp_symmetric(0.3, 1.0), 0.3);
        assert_eq!(sign(-0.1), -1.0);
        assert_eq!(sign(0.0), 1.0);
        assert_eq!(clamp(f32::NAN, -1.0, 1.0), -1.0);
    }
}
