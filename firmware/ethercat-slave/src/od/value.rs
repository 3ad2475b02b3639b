//! Value checks of an SDO download: length against the entry, range against the entry's
//! minimum/maximum, interpreted by [`DataType`].

use core::cmp::Ordering;

use super::abort::AbortCode;
use crate::od::{DataType, Entry};

/// Bits per byte.
const BITS_PER_BYTE: usize = 8;
/// Widest integer the range check decodes (INTEGER64 / UNSIGNED64), in bytes.
const MAX_INT_BYTES: usize = 8;

/// A numeric value decoded by its data type.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Number {
    /// INTEGERn, sign-extended.
    Signed(i64),
    /// UNSIGNEDn, BOOLEAN, BITn.
    Unsigned(u64),
    /// REAL32, compared in single precision (the FPU's).
    Real32(f32),
    /// REAL64 as its IEEE 754 bits, compared by [`real64_cmp`]: a single-precision FPU has no
    /// double compare, and the soft-float library it would call costs flash for one range check.
    Real64(u64),
}

impl Number {
    /// Decodes little-endian `bytes` as `data_type`; `None` for non-numeric types and for lengths
    /// the type cannot have.
    fn decode(data_type: DataType, bytes: &[u8]) -> Option<Self> {
        match data_type {
            DataType::Integer8
            | DataType::Integer16
            | DataType::Integer24
            | DataType::Integer32
            | DataType::Integer64 => signed(bytes).map(Self::Signed),
            DataType::Unsigned8
            | DataType::Unsigned16
            | DataType::Unsigned24
            | DataType::Unsigned32
            | DataType::Unsigned64
            | DataType::Boolean
            | DataType::Bit1
            | DataType::Bit2
            | DataType::Bit3
            | DataType::Bit4
            | DataType::Bit5
            | DataType::Bit6
            | DataType::Bit7
            | DataType::Bit8 => unsigned(bytes).map(Self::Unsigned),
            DataType::Real32 => {
                let b: [u8; 4] = bytes.try_into().ok()?;
                Some(Self::Real32(f32::from_le_bytes(b)))
            }
            DataType::Real64 => {
                let b: [u8; 8] = bytes.try_into().ok()?;
                Some(Self::Real64(u64::from_le_bytes(b)))
            }
            DataType::VisibleString
            | DataType::OctetString
            | DataType::UnicodeString
            | DataType::Domain => None,
        }
    }

    /// Compares two values of the same data type; `None` if they are incomparable (NaN).
    fn compare(self, other: Self) -> Option<Ordering> {
        match (self, other) {
            (Self::Signed(a), Self::Signed(b)) => Some(a.cmp(&b)),
            (Self::Unsigned(a), Self::Unsigned(b)) => Some(a.cmp(&b)),
            (Self::Real32(a), Self::Real32(b)) => a.partial_cmp(&b),
            (Self::Real64(a), Self::Real64(b)) => real64_cmp(a, b),
            _ => None,
        }
    }
}

/// The sign bit of an IEEE 754 double.
const REAL64_SIGN: u64 = 1 << 63;
/// The bits of +∞: a magnitude above it is a NaN.
const REAL64_INFINITY: u64 = 0x7FF0_0000_0000_0000;

/// Orders two IEEE 754 doubles given as bits as `f64::partial_cmp` does: `None` if either is a
/// NaN, −0 equal to +0. Sign and magnitude order like an integer: the magnitude bits of a
/// double grow with its value (exponent above mantissa), so the magnitude, negated for a
/// negative sign, is a key whose integer order is the value's.
fn real64_cmp(a: u64, b: u64) -> Option<Ordering> {
    let key = |bits: u64| -> Option<i64> {
        let magnitude = bits & !REAL64_SIGN;
        if magnitude > REAL64_INFINITY {
            return None;
        }
        // magnitude < 2^63: fits an i64, and so does its negation.
        let magnitude = magnitude as i64;
        Some(if bits & REAL64_SIGN != 0 {
            magnitude.wrapping_neg()
        } else {
            magnitude
        })
    };
    Some(key(a)?.cmp(&key(b)?))
}

/// Little-endian unsigned integer of 1..=8 bytes.
fn unsigned(bytes: &[u8]) -> Option<u64> {
    if bytes.is_empty() || bytes.len() > MAX_INT_BYTES {
        return None;
    }
    let mut b = [0u8; MAX_INT_BYTES];
    b.get_mut(..bytes.len())?.copy_from_slice(bytes);
    Some(u64::from_le_bytes(b))
}

/// Little-endian two's-complement integer of 1..=8 bytes, sign-extended.
fn signed(bytes: &[u8]) -> Option<i64> {
    let raw = unsigned(bytes)?;
    // 0..=56: `unsigned` accepts 1..=8 bytes.
    let unused_bits = MAX_INT_BYTES
        .checked_sub(bytes.len())?
        .checked_mul(BITS_PER_BYTE)?;
    // Shift the sign bit to bit 63, then arithmetic-shift back.
    Some(((raw << unused_bits) as i64) >> unused_bits)
}

/// Checks the length of downloaded `data` against the entry: fixed-size types need exactly the
/// entry's byte length, strings and domains at most that.
pub(crate) fn check_length(entry: &Entry, len: usize) -> Result<(), AbortCode> {
    let expected = entry.byte_len();
    match len.cmp(&expected) {
        Ordering::Greater => Err(AbortCode::LengthTooHigh),
        Ordering::Less if !entry.data_type.is_variable_length() => Err(AbortCode::LengthTooLow),
        _ => Ok(()),
    }
}

/// Checks downloaded `data` (already of a valid length) against the entry's bit width and its
/// minimum/maximum (ETG.1000.6 Table 41: 0x06090031 too high, 0x06090032 too low, 0x06090030 for
/// a value that compares with neither, e.g. NaN).
pub(crate) fn check_range(entry: &Entry, data: &[u8]) -> Result<(), AbortCode> {
    let Some(value) = Number::decode(entry.data_type, data) else {
        return Ok(());
    };
    check_bit_width(entry, value)?;
    if let Some(min) = Number::decode(entry.data_type, entry.min) {
        match value.compare(min) {
            Some(Ordering::Less) => return Err(AbortCode::ValueTooLow),
            None => return Err(AbortCode::ValueRange),
            _ => {}
        }
    }
    if let Some(max) = Number::decode(entry.data_type, entry.max) {
        match value.compare(max) {
            Some(Ordering::Greater) => return Err(AbortCode::ValueTooHigh),
            None => return Err(AbortCode::ValueRange),
            _ => {}
        }
    }
    Ok(())
}

/// A profile's list of accepted values (`Profile::value_lists`): a value not in it is refused
/// with 0x06090030 (value range of parameter exceeded).
pub(crate) fn check_value_list(
    list: Option<&[i64]>,
    entry: &Entry,
    data: &[u8],
) -> Result<(), AbortCode> {
    let Some(list) = list else {
        return Ok(());
    };
    let value = match Number::decode(entry.data_type, data) {
        Some(Number::Signed(v)) => Some(v),
        Some(Number::Unsigned(v)) => i64::try_from(v).ok(),
        _ => None,
    };
    match value {
        Some(v) if list.contains(&v) => Ok(()),
        _ => Err(AbortCode::ValueRange),
    }
}

/// An unsigned entry narrower than its bytes (BOOLEAN, BITn) must not set the unused high bits.
fn check_bit_width(entry: &Entry, value: Number) -> Result<(), AbortCode> {
    let bits = u32::from(entry.bit_len);
    match value {
        Number::Unsigned(v) if bits < u64::BITS && v >> bits != 0 => Err(AbortCode::ValueTooHigh),
        _ => Ok(()),
    }
}

/// The value as an unsigned integer of up to 4 bytes (u8 subindex 0, u16 assignment entries, u32
/// mapping entries); `None` for anything longer or empty.
pub(crate) fn as_u32(data: &[u8]) -> Option<u32> {
    let narrow = u32::BITS as usize / BITS_PER_BYTE;
    if data.len() > narrow {
        return None;
    }
    unsigned(data).and_then(|v| u32::try_from(v).ok())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn signed_values_are_sign_extended_from_their_length() {
        assert_eq!(signed(&[0xFF]), Some(-1));
        assert_eq!(signed(&[0x9C, 0xFF]), Some(-100));
        assert_eq!(signed(&[0x00, 0x00, 0x80]), Some(-0x80_0000));
        assert_eq!(signed(&[0x7F]), Some(127));
        assert_eq!(signed(&[]), None);
    }

    #[test]
    fn real_nan_is_out_of_range() {
        let nan = Number::Real32(f32::NAN);
        assert_eq!(nan.compare(Number::Real32(0.0)), None);
        let nan = Number::Real64(f64::NAN.to_bits());
        assert_eq!(nan.compare(Number::Real64(0.0f64.to_bits())), None);
        assert_eq!(Number::Real64(0).compare(nan), None);
    }

    /// REAL64 compares as the host's double compare (the reference) over the special values
    /// and the neighbours of each: signed zeros, subnormals, extremes, infinities, NaNs of
    /// either sign and payload.
    #[test]
    fn real64_orders_as_double_precision() {
        let specials = [
            0.0,
            -0.0,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            f64::from_bits(1),
            -f64::from_bits(1),
            1.0,
            -1.0,
            1.5,
            -2.75,
            1e300,
            -1e-300,
            f64::MAX,
            f64::MIN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            -f64::NAN,
            f64::from_bits(0x7FF0_0000_0000_0001),
        ];
        let neighbours = |v: &f64| {
            let b = v.to_bits();
            [b.wrapping_sub(1), b, b.wrapping_add(1)].map(f64::from_bits)
        };
        for a in specials.iter().flat_map(neighbours) {
            for b in specials.iter().flat_map(neighbours) {
                let got = Number::Real64(a.to_bits()).compare(Number::Real64(b.to_bits()));
                assert_eq!(got, a.partial_cmp(&b), "{a:e} vs {b:e}");
            }
        }
    }
}
