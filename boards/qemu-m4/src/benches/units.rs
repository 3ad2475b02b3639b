//! A position's conversion between user units and increments (`cia402::units::Ratio`, e.g.
//! 6091h's gear ratio): the SYNC0 handler converts the target, the offset and the actual
//! position in every cycle (the demand position where a TxPDO carries it). Its cost depends on the ratio and the position, so it is
//! measured over inputs that cover the conversion's branches: a ratio of one (no arithmetic),
//! a divisor that is a power of two (a shift), one that is not (multiplications by its
//! reciprocal; also factors beyond 32 bits that the prepared ratio reduces below them), a
//! position beyond 32 bits (a 64 × 32-bit product from two multiplications, then the
//! reciprocal or, for a power-of-two divisor, a shift), a product beyond 64 bits (the same product, divided in two 32-bit digits by
//! the reciprocal), a divisor beyond 32 bits (no reciprocal: the library's 64-bit division, or
//! beyond 64 bits the restoring division, a bit per step). Each cost includes the copy of the
//! ratio into the call.

use core::hint::black_box;

use firmware::cia402::units::Ratio;

use crate::harness::{Cases, Harness};

const NAME: &str = "position-conversion";

/// (label, numerator, denominator, position in user units) of each input.
const INPUTS: [(&str, u64, u64, i64); 9] = [
    ("power-of-two divisor", 10_000, 1 << 17, -123_456_789),
    ("32-bit divisor", 1 << 17, 10_000, -123_456_789),
    // A gear ratio times a feed constant, 2²⁰·10⁶ / (7·2¹²): beyond 32 bits, prepared in lowest
    // terms (2⁸·10⁶ / 7) within them.
    (
        "factors beyond 32 bits, reducible",
        (1 << 20) * 1_000_000,
        7 * (1 << 12),
        -123_456_789,
    ),
    ("a ratio of one", 10_000, 10_000, 987_654),
    ("position beyond 32 bits", 1 << 17, 10_000, 1 << 40),
    // 10000 / 2¹⁷ in lowest terms: 625 / 2¹³.
    (
        "position beyond 32 bits, power-of-two divisor",
        10_000,
        1 << 17,
        1 << 40,
    ),
    ("product beyond 64 bits", (1 << 32) - 1, 10_000, 1 << 40),
    // Factors beyond 32 bits (a product of ratios, e.g. a gear ratio times a feed constant):
    // no reciprocal.
    (
        "divisor beyond 32 bits",
        1 << 20,
        (1 << 33) + 1,
        -123_456_789,
    ),
    (
        "divisor and product beyond",
        1 << 40,
        (1 << 33) + 1,
        -123_456_789,
    ),
];

/// `value × n / d` rounded to the nearest, halves away from zero, saturated (the reference
/// the conversion must give).
fn exact(value: i64, n: u64, d: u64) -> i64 {
    let p = i128::from(value) * i128::from(n);
    let d = i128::from(d);
    let (q, r) = (p / d, p % d);
    let q = if 2 * r.abs() >= d { q + p.signum() } else { q };
    q.clamp(i128::from(i64::MIN), i128::from(i64::MAX)) as i64
}

/// Measures `Ratio::position_to_internal` of a prepared ratio over [`INPUTS`].
pub fn run(h: &mut Harness) {
    let mut cases = Cases::new(NAME);
    for (label, n, d, value) in INPUTS {
        let ratio = Ratio::new(n, d).prepared();
        if ratio.position_to_internal(value) != exact(value, n, d) {
            h.fail(NAME, format_args!("{label}: not the exact quotient"));
            return;
        }
        let Some(cost) = h.measure(NAME, &mut || {
            black_box(black_box(ratio).position_to_internal(black_box(value)));
        }) else {
            return;
        };
        h.case(&mut cases, label, cost);
    }
    h.report_cases(
        &cases,
        None,
        format_args!(
            "Ratio::position_to_internal (user units to increments, rounded to the nearest) of a \
             prepared ratio, over its branches"
        ),
    );
}
