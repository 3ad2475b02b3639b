//! Space-vector modulation by min-max zero-sequence injection, over-modulation onto the hexagon,
//! and dead-time compensation.
//!
//! # Modulation
//! The requested stationary-frame voltage (α, β) is turned into three phase voltages (inverse
//! Clarke, amplitude-invariant) and normalised by the bus voltage. Adding the zero-sequence
//! voltage −(max + min)/2 centres the three duties around 50 %: this is the carrier-based
//! equivalent of SVPWM (identical switching instants to the classic sector/dwell-time
//! formulation). The line-to-line voltages — the only thing a motor with an isolated star point
//! sees — are exactly those of the requested vector as long as the duty span (max − min) is at
//! most 1, i.e. inside the voltage hexagon of the inverter. The largest circle inside the
//! hexagon has the radius Vbus/√3 (the linear range for every angle); the hexagon's corners
//! reach 2·Vbus/3.
//!
//! # Over-modulation
//! A vector outside the hexagon (span > 1) cannot be produced. The differential part of the
//! duties is scaled by 1/span: the vector shrinks along its own direction onto the hexagon edge
//! (angle preserved, magnitude as large as the inverter can make it), the duties span exactly
//! 0..=1, and [`Modulation::overmodulated`] tells the caller.
//!
//! # Dead time
//! During the dead time both switches of a leg are off and the phase current picks the diode:
//! a current flowing out of the leg into the motor (positive) freewheels through the low-side
//! diode, so the leg sits at 0 V for the dead time and loses `t_dead` of its high time; a
//! negative current gains it. [`compensate_dead_time`] adds the lost time back per phase;
//! [`dead_time_voltage`] is the same correction as a voltage to add before [`modulate`].

use super::math::{clamp, max, min, SQRT3_2};
use super::Duties;
use hal::power::PhaseCurrents;

/// Half of the α component goes to phases b and c (inverse Clarke).
const HALF: f32 = 0.5;
/// 1/6: the Clarke weight 1/3 times the ½ of [`ramp2`].
const ONE_SIXTH: f32 = 1.0 / 6.0;
/// 1/(2√3): the Clarke weight 1/√3 times the ½ of [`ramp2`].
const HALF_INV_SQRT3: f32 = 0.288_675_13;

/// The duties of one PWM period and whether the vector had to be cut to the hexagon.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Modulation {
    /// Duty cycles, each within 0.0..=1.0.
    pub duties: Duties,
    /// The requested vector lay outside the inverter's voltage hexagon (or was not a number) and
    /// was scaled down onto the hexagon edge (or replaced by the zero vector).
    pub overmodulated: bool,
}

/// Duties for the stationary-frame voltage (`v_alpha`, `v_beta`) in volts at a bus voltage of
/// 1/`inv_vbus` volts.
///
/// Linear (line-to-line voltages exact) up to the hexagon edge, which is at least Vbus/√3 from
/// the origin in every direction. Beyond the hexagon the vector is scaled down onto the edge
/// with its angle preserved and `overmodulated` is set. A non-finite request (NaN, ±∞, e.g. an
/// `inv_vbus` of ∞ at zero bus voltage) gives the zero vector (all duties 0.5) with
/// `overmodulated` set. The duties are always within 0.0..=1.0, also after rounding: the
/// formulas below are monotonic in the rounded sense (see the comments).
///
/// Timing: about 35 instructions in the linear range (inverse Clarke 4, scaling 3, min/max of
/// three 4 compare-selects, duties 7); the over-modulation path adds three `VDIV` (14 cycles
/// each, hardware, no library call).
#[inline]
pub fn modulate(v_alpha: f32, v_beta: f32, inv_vbus: f32) -> Modulation {
    // Phase voltages as fractions of the bus voltage (inverse Clarke, amplitude-invariant).
    let a = v_alpha * inv_vbus;
    let alpha_half = HALF * a;
    let beta_term = SQRT3_2 * v_beta * inv_vbus;
    let b = beta_term - alpha_half;
    let c = -beta_term - alpha_half;

    // No separate NaN guard: the compare-selects return their second argument when a compare
    // involves a NaN, and `c` is the second argument of both inner ones, so a NaN in `c`
    // reaches `hi` and `lo` and makes `span` NaN. Every NaN reaches `c`: `c` depends on
    // `v_alpha`, `v_beta` and `inv_vbus` alike. A NaN born inside (∞ − ∞ in `b`, 0 · ∞ in `a`)
    // needs an infinite operand, which makes `c` or `a` infinite or NaN, and then `span` is ∞ or
    // NaN. Both fail `span <= 1.0` and `span < ∞` below: the zero vector.
    // (`garbage_in_gives_the_zero_vector_flagged` goes through the special values.)
    let hi = max(a, max(b, c));
    let lo = min(a, min(b, c));
    let span = hi - lo;

    if span <= 1.0 {
        // d = x − lo + (1 − span)/2 (= 0.5 + x − (hi + lo)/2). Written this way so that the
        // bounds survive rounding: x − lo ≥ 0 and ≤ span (rounding is monotonic), 1 − span is
        // exact for span ≥ ½ (Sterbenz), and span + (1 − span)/2 rounds to at most 1.
        let offset = HALF - HALF * span;
        Modulation {
            duties: Duties {
                a: (a - lo) + offset,
                b: (b - lo) + offset,
                c: (c - lo) + offset,
            },
            overmodulated: false,
        }
    } else if span < f32::INFINITY {
        // Rare path (over-modulation): d = (x − lo)/span = 0.5 + (x − mid)/span. Three hardware
        // divisions instead of one reciprocal and three multiplications: correctly rounded
        // division by `span` of a value in 0..=span stays in 0..=1 exactly, a product with a
        // rounded reciprocal could land one ulp above 1. `span` > 1 here, so no division by
        // zero.
        Modulation {
            duties: Duties {
                a: (a - lo) / span,
                b: (b - lo) / span,
                c: (c - lo) / span,
            },
            overmodulated: true,
        }
    } else {
        // NaN or infinite span.
        invalid()
    }
}

/// The output for a request that is not a number: zero voltage, flagged.
#[inline]
fn invalid() -> Modulation {
    Modulation {
        duties: Duties::CENTRED,
        overmodulated: true,
    }
}

/// Dead-time compensation: `duties` with `dead_time_duty`·sign(i) added per phase.
///
/// `dead_time_duty` is t_dead/T_pwm. A positive phase current (out of the leg into the motor)
/// loses the dead time of its high time, so its duty is raised; a negative current gains it, so
/// its duty is lowered. Around zero current the sign is replaced by the ramp
/// clamp(i·`current_band_inv`, −1, 1) (`current_band_inv` = 1/band, band in A): the measured
/// sign of a current that is about zero is noise, and a hard sign would chatter the voltage by
/// ±2·t_dead·Vbus/T at every zero crossing. The result is clamped to 0.0..=1.0 (a NaN current
/// gives the full negative correction, a NaN duty gives 0).
///
/// Timing: about 50 instructions (per phase: 1 multiplication, 2 compare-selects for the ramp,
/// 1 multiply-add, 2 compare-selects for the duty range).
#[inline]
pub fn compensate_dead_time(
    duties: Duties,
    currents: PhaseCurrents,
    dead_time_duty: f32,
    current_band_inv: f32,
) -> Duties {
    Duties {
        a: compensate_phase(duties.a, currents.a, dead_time_duty, current_band_inv),
        b: compensate_phase(duties.b, currents.b, dead_time_duty, current_band_inv),
        c: compensate_phase(duties.c, currents.c, dead_time_duty, current_band_inv),
    }
}

/// One phase of [`compensate_dead_time`].
#[inline]
fn compensate_phase(duty: f32, current: f32, dead_time_duty: f32, current_band_inv: f32) -> f32 {
    let direction = clamp(current * current_band_inv, -1.0, 1.0);
    clamp(duty + dead_time_duty * direction, 0.0, 1.0)
}

/// Dead-time compensation as a stationary-frame voltage (α, β) in V, to be added to the
/// requested vector before [`modulate`]: the same correction as [`compensate_dead_time`] with
/// `dead_time_volts` = t_dead/T_pwm · Vbus.
///
/// The per-phase corrections dead_time_volts·ramp(i·`current_band_inv`) go through the Clarke
/// transformation; their common-mode part drops out, which changes nothing for the motor (an
/// isolated star point sees only line-to-line voltages, and those are identical to
/// [`compensate_dead_time`]'s). Two advantages: the modulator keeps the duties within 0..=1 (no
/// clamp afterwards, so a correction is never cut at a rail: the zero sequence moves instead),
/// and it is cheaper. The ramp is clamp(x, −1, 1) written as (|x + 1| − |x − 1|)/2: branch-free,
/// no flags (a NaN current gives NaN, which [`modulate`] turns into the zero vector).
///
/// Timing: about 25 instructions (per phase 1 multiplication, 2 additions, 2 `VABS`, 1
/// subtraction; the Clarke transformation 6).
#[inline]
pub fn dead_time_voltage(
    currents: PhaseCurrents,
    dead_time_volts: f32,
    current_band_inv: f32,
) -> (f32, f32) {
    let ra = ramp2(currents.a * current_band_inv);
    let rb = ramp2(currents.b * current_band_inv);
    let rc = ramp2(currents.c * current_band_inv);
    // ramp2 is twice the ramp: the ½ is folded into the Clarke weights 1/3 → 1/6, 1/√3 → 1/(2√3).
    let alpha = (ra + ra - rb - rc) * (dead_time_volts * ONE_SIXTH);
    let beta = (rb - rc) * (dead_time_volts * HALF_INV_SQRT3);
    (alpha, beta)
}

/// 2·clamp(x, −1, 1) for finite x, as |x + 1| − |x − 1|.
#[inline]
fn ramp2(x: f32) -> f32 {
    (x + 1.0).abs() - (x - 1.0).abs()
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::f64::consts::{PI, TAU};

    const VBUS: f64 = 48.0;

    /// Line-to-line voltage tolerance: f32 rounding of duties around 0.5 (a few 1e-7 of Vbus).
    const LL_TOLERANCE_V: f64 = 2e-5 * VBUS;

    /// The α/β vector the duties produce, from the line-to-line voltages (the star-point
    /// voltage drops out): vα = Vbus·(2da − db − dc)/3, vβ = Vbus·(db − dc)/√3.
    fn produced_alpha_beta(d: Duties) -> (f64, f64) {
        let (a, b, c) = (d.a as f64, d.b as f64, d.c as f64);
        (VBUS * (2.0 * a - b - c) / 3.0, VBUS * (b - c) / 3f64.sqrt())
    }

    /// Line-to-line voltages ab, bc, ca of a stationary vector (the physics reference).
    fn line_to_line(v_alpha: f64, v_beta: f64) -> [f64; 3] {
        let va = v_alpha;
        let vb = -0.5 * v_alpha + 3f64.sqrt() / 2.0 * v_beta;
        let vc = -0.5 * v_alpha - 3f64.sqrt() / 2.0 * v_beta;
        [va - vb, vb - vc, vc - va]
    }

    fn modulate_polar(magnitude: f64, angle: f64) -> (Modulation, f64, f64) {
        let (v_alpha, v_beta) = (magnitude * angle.cos(), magnitude * angle.sin());
        (
            modulate(v_alpha as f32, v_beta as f32, (1.0 / VBUS) as f32),
            v_alpha,
            v_beta,
        )
    }

    fn assert_in_range(d: Duties) {
        for x in [d.a, d.b, d.c] {
            assert!((0.0..=1.0).contains(&x), "duty {x} out of range in {d:?}");
        }
    }

    #[test]
    fn line_to_line_voltages_match_the_request_inside_the_circle() {
        let radius = VBUS / 3f64.sqrt();
        for step in 0..720 {
            let angle = step as f64 * TAU / 720.0;
            for fraction in [0.05, 0.3, 0.7, 0.99, 1.0] {
                let (m, va, vb) = modulate_polar(fraction * radius, angle);
                assert!(!m.overmodulated, "{fraction} at {angle}");
                assert_in_range(m.duties);
                let d = m.duties;
                let measured = [
                    (d.a as f64 - d.b as f64) * VBUS,
                    (d.b as f64 - d.c as f64) * VBUS,
                    (d.c as f64 - d.a as f64) * VBUS,
                ];
                let expected = line_to_line(va, vb);
                for (got, want) in measured.iter().zip(expected.iter()) {
                    assert!(
                        (got - want).abs() < LL_TOLERANCE_V,
                        "{fraction}·Vbus/√3 at {angle} rad: {got} V vs {want} V"
                    );
                }
                // Centred: the zero-sequence injection puts the mean of max and min at 0.5.
                let hi = d.a.max(d.b).max(d.c);
                let lo = d.a.min(d.b).min(d.c);
                assert!(((hi + lo) / 2.0 - 0.5).abs() < 1e-6);
            }
        }
    }

    #[test]
    fn the_inscribed_circle_touches_the_duty_limits_at_the_hexagon_edge_centres() {
        // |v| = Vbus/√3 is the radius of the circle inscribed in the hexagon: it touches the
        // hexagon (duty span exactly 1, duties exactly 0 and 1) at 30° + k·60°, and is inside
        // everywhere else.
        let radius = VBUS / 3f64.sqrt();
        for k in 0..6 {
            let angle = PI / 6.0 + k as f64 * PI / 3.0;
            let (m, _, _) = modulate_polar(radius, angle);
            let d = m.duties;
            let hi = d.a.max(d.b).max(d.c);
            let lo = d.a.min(d.b).min(d.c);
            assert!((hi - 1.0).abs() < 1e-6 && lo.abs() < 1e-6, "{k}: {d:?}");
        }
        for step in 0..360 {
            let (m, _, _) = modulate_polar(radius, step as f64 * TAU / 360.0);
            let d = m.duties;
            let span = d.a.max(d.b).max(d.c) - d.a.min(d.b).min(d.c);
            assert!(span <= 1.0 + 1e-6, "span {span}");
            // And the span is √3·|v|·cos(angle − edge centre)/Vbus ≥ √3/2 (at the corners).
            assert!(span >= 3f32.sqrt() / 2.0 - 1e-6, "span {span}");
        }
    }

    #[test]
    fn vectors_outside_the_hexagon_are_cut_onto_it_with_their_angle() {
        let radius = VBUS / 3f64.sqrt();
        for step in 0..360 {
            let angle = step as f64 * TAU / 360.0 + 0.01;
            for fraction in [1.2, 1.5, 3.0, 100.0] {
                let (m, va, vb) = modulate_polar(fraction * radius, angle);
                assert!(m.overmodulated, "{fraction} at {angle}");
                assert_in_range(m.duties);
                let (pa, pb) = produced_alpha_beta(m.duties);
                let angle_error = (pb.atan2(pa) - vb.atan2(va) + PI).rem_euclid(TAU) - PI;
                assert!(angle_error.abs() < 1e-5, "angle error {angle_error}");
                // On the hexagon edge: the duties span exactly 0..=1.
                let d = m.duties;
                assert_eq!(d.a.max(d.b).max(d.c), 1.0);
                assert_eq!(d.a.min(d.b).min(d.c), 0.0);
                // The hexagon's distance from the origin in this direction:
                // (Vbus/√3)/cos(angle to the nearest edge centre, at 30° + k·60°).
                let to_edge_centre = angle.rem_euclid(PI / 3.0) - PI / 6.0;
                let hexagon = radius / to_edge_centre.cos();
                let produced = (pa * pa + pb * pb).sqrt();
                assert!(
                    (produced - hexagon).abs() < 1e-4 * VBUS,
                    "{produced} V vs hexagon {hexagon} V"
                );
            }
        }
    }

    #[test]
    fn inside_the_hexagon_beyond_the_circle_is_still_linear() {
        // Towards a corner (0°) the hexagon reaches 2/3·Vbus: 0.66·Vbus is still exact.
        let (m, va, vb) = modulate_polar(0.66 * VBUS, 0.0);
        assert!(!m.overmodulated);
        let (pa, pb) = produced_alpha_beta(m.duties);
        assert!((pa - va).abs() < LL_TOLERANCE_V && (pb - vb).abs() < LL_TOLERANCE_V);
    }

    #[test]
    fn zero_vector_centres_all_duties() {
        let m = modulate(0.0, 0.0, (1.0 / VBUS) as f32);
        assert_eq!(m.duties, Duties::CENTRED);
        assert!(!m.overmodulated);
    }

    #[test]
    fn garbage_in_gives_the_zero_vector_flagged() {
        // Every combination of special and ordinary values in the three arguments: a NaN
        // anywhere, or a vector whose phases overflow, gives the zero vector, flagged; nothing
        // gives a duty outside 0..=1.
        let specials = [
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::MAX,
            -f32::MAX,
            0.0,
            -0.0,
            1.0,
            -3.0,
            f32::MIN_POSITIVE,
            0.02,
        ];
        for va in specials {
            for vb in specials {
                for inv in specials {
                    let m = modulate(va, vb, inv);
                    let d = m.duties;
                    for x in [d.a, d.b, d.c] {
                        assert!((0.0..=1.0).contains(&x), "{va} {vb} {inv}: {d:?}");
                    }
                    if va.is_nan() || vb.is_nan() || inv.is_nan() {
                        assert_eq!(d, Duties::CENTRED, "{va} {vb} {inv}");
                        assert!(m.overmodulated, "{va} {vb} {inv}");
                    }
                }
            }
        }
        for (va, vb, inv) in [
            (f32::NAN, 0.0, 0.02),
            (0.0, f32::NAN, 0.02),
            (1.0, 0.0, f32::NAN),
            (0.0, 0.0, f32::INFINITY),
            (f32::INFINITY, 0.0, 0.02),
            (f32::INFINITY, f32::NEG_INFINITY, 0.02),
            (f32::INFINITY, f32::INFINITY, 0.02),
            (0.0, f32::INFINITY, 0.02),
            (f32::MAX, f32::MAX, 10.0),
        ] {
            let m = modulate(va, vb, inv);
            assert_eq!(m.duties, Duties::CENTRED, "{va} {vb} {inv}");
            assert!(m.overmodulated);
        }
    }

    const DEAD_TIME_DUTY: f32 = 0.01;
    /// 1/(0.5 A): the ramp reaches full compensation at ±0.5 A.
    const BAND_INV: f32 = 2.0;

    #[test]
    fn dead_time_compensation_adds_duty_for_positive_current() {
        let d = compensate_dead_time(
            Duties::CENTRED,
            PhaseCurrents {
                a: 5.0,
                b: -2.0,
                c: -3.0,
            },
            DEAD_TIME_DUTY,
            BAND_INV,
        );
        // Positive current out of the leg loses t_dead of high time: raised by t_dead/T.
        assert!((d.a - (0.5 + DEAD_TIME_DUTY)).abs() < 1e-7);
        // Negative currents gain it: lowered.
        assert!((d.b - (0.5 - DEAD_TIME_DUTY)).abs() < 1e-7);
        assert!((d.c - (0.5 - DEAD_TIME_DUTY)).abs() < 1e-7);
    }

    #[test]
    fn dead_time_compensation_ramps_through_zero_current() {
        let at = |i: f32| {
            compensate_dead_time(
                Duties::CENTRED,
                PhaseCurrents {
                    a: i,
                    b: 0.0,
                    c: 0.0,
                },
                DEAD_TIME_DUTY,
                BAND_INV,
            )
            .a - 0.5
        };
        assert_eq!(at(0.0), 0.0, "no correction at zero current");
        // Half the band: half the correction, proportional, odd.
        assert!((at(0.25) - 0.5 * DEAD_TIME_DUTY).abs() < 1e-7);
        assert!((at(-0.25) + 0.5 * DEAD_TIME_DUTY).abs() < 1e-7);
        // Continuous and monotonic across zero (no chatter step).
        let mut previous = at(-1.0);
        for k in -100..=100 {
            let now = at(k as f32 * 0.01);
            assert!(now >= previous && now - previous <= DEAD_TIME_DUTY * BAND_INV * 0.01 + 1e-7);
            previous = now;
        }
        // Saturates outside the band.
        assert!((at(0.5) - DEAD_TIME_DUTY).abs() < 1e-7);
        assert!((at(40.0) - DEAD_TIME_DUTY).abs() < 1e-7);
    }

    #[test]
    fn dead_time_voltage_gives_the_same_line_to_line_voltages() {
        // Compared with the duty-domain compensation away from the rails (no clamping there).
        for (k, currents) in [
            PhaseCurrents {
                a: 5.0,
                b: -2.0,
                c: -3.0,
            },
            PhaseCurrents {
                a: 0.1,
                b: -0.3,
                c: 0.2,
            },
            PhaseCurrents {
                a: -0.7,
                b: 0.25,
                c: 0.45,
            },
            PhaseCurrents::default(),
        ]
        .into_iter()
        .enumerate()
        {
            let base = modulate(3.0, -2.0, (1.0 / VBUS) as f32);
            let reference = compensate_dead_time(base.duties, currents, DEAD_TIME_DUTY, BAND_INV);
            let (ca, cb) = dead_time_voltage(currents, DEAD_TIME_DUTY * VBUS as f32, BAND_INV);
            let m = modulate(3.0 + ca, -2.0 + cb, (1.0 / VBUS) as f32);
            let ll = |d: Duties| [d.a - d.b, d.b - d.c, d.c - d.a];
            for (got, want) in ll(m.duties).iter().zip(ll(reference).iter()) {
                assert!((got - want).abs() < 1e-6, "{k}: {got} vs {want}");
            }
        }
    }

    #[test]
    fn dead_time_compensation_stays_within_the_duty_range() {
        let d = compensate_dead_time(
            Duties {
                a: 1.0,
                b: 0.0,
                c: 0.995,
            },
            PhaseCurrents {
                a: 10.0,
                b: -10.0,
                c: 10.0,
            },
            DEAD_TIME_DUTY,
            BAND_INV,
        );
        assert_eq!(
            d,
            Duties {
                a: 1.0,
                b: 0.0,
                c: 1.0
            }
        );
        let nan = compensate_dead_time(
            Duties {
                a: f32::NAN,
                b: 0.5,
                c: 0.5,
            },
            PhaseCurrents {
                a: 0.0,
                b: f32::NAN,
                c: 0.0,
            },
            DEAD_TIME_DUTY,
            BAND_INV,
        );
        assert!((0.0..=1.0).contains(&nan.a) && (0.0..=1.0).contains(&nan.b));
    }
}
