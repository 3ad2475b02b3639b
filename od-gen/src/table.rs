//! The object table of a profile (`od-gen table`): one row per subindex, as CSV or as an aligned
//! text table.
//!
//! Columns: `index,subindex,name,data_type,access,pdo_mapping,default,min,max`.
//!
//! - `index` is `0xHHHH` (upper-case hex digits), `subindex` decimal; every entry is a row,
//!   including subindex 0 of RECORD/ARRAY objects and the objects od-gen derives.
//! - `data_type` is the ETG.1000.6 name ([`type_name`]): `BOOLEAN`, `INT8`..`INT64`,
//!   `UINT8`..`UINT64`, `REAL32`, `REAL64`, `VISIBLE_STRING`, `OCTET_STRING`, `UNICODE_STRING`,
//!   `DOMAIN`, `BIT1`..`BIT8`.
//! - `access` ([`access_name`]): `RW` (writable in some state, readable), `WO`, `RO` (read-only
//!   variable) or `CONST` (read-only constant).
//! - `pdo_mapping` ([`pdo_name`]): `NO`, `RX`, `TX` or `YES` (both).
//! - `default`, `min`, `max` ([`value_text`]): decimal for integers (`BOOLEAN` and `BITn`
//!   included), the shortest round-tripping decimal for floats, the text for VISIBLE_STRING and
//!   UNICODE_STRING, upper-case hex for OCTET_STRING; empty when the profile gives none.
//!
//! CSV fields holding a comma, a quote, CR or LF are quoted (RFC 4180); lines end in `\n`.

use crate::model::{DataType, Entry, Object, PdoMapping, Profile, Storage};

/// The CSV header line (without the line end).
pub const CSV_HEADER: &str = "index,subindex,name,data_type,access,pdo_mapping,default,min,max";

/// One row of the table, every column as text.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Row {
    /// `0xHHHH`.
    pub index: String,
    /// Decimal subindex.
    pub subindex: String,
    /// The entry name.
    pub name: String,
    /// [`type_name`].
    pub data_type: String,
    /// [`access_name`].
    pub access: String,
    /// [`pdo_name`].
    pub pdo_mapping: String,
    /// [`value_text`] of the default.
    pub default: String,
    /// [`value_text`] of the minimum.
    pub min: String,
    /// [`value_text`] of the maximum.
    pub max: String,
}

impl Row {
    fn columns(&self) -> [&str; 9] {
        [
            &self.index,
            &self.subindex,
            &self.name,
            &self.data_type,
            &self.access,
            &self.pdo_mapping,
            &self.default,
            &self.min,
            &self.max,
        ]
    }
}

/// The ETG.1000.6 data type name (`UINT16`, `INT32`, `VISIBLE_STRING`, ...).
pub fn type_name(dt: DataType) -> String {
    match dt {
        DataType::Bool => "BOOLEAN".into(),
        DataType::Sint => "INT8".into(),
        DataType::Int => "INT16".into(),
        DataType::Int24 => "INT24".into(),
        DataType::Dint => "INT32".into(),
        DataType::Lint => "INT64".into(),
        DataType::Usint => "UINT8".into(),
        DataType::Uint => "UINT16".into(),
        DataType::Uint24 => "UINT24".into(),
        DataType::Udint => "UINT32".into(),
        DataType::Ulint => "UINT64".into(),
        DataType::Real => "REAL32".into(),
        DataType::Lreal => "REAL64".into(),
        DataType::VisibleString => "VISIBLE_STRING".into(),
        DataType::OctetString => "OCTET_STRING".into(),
        DataType::UnicodeString => "UNICODE_STRING".into(),
        DataType::Domain => "DOMAIN".into(),
        DataType::Bit(n) => format!("BIT{n}"),
    }
}

/// `RW`, `WO`, `RO` or `CONST` (a read-only constant). Writes restricted to some EtherCAT states
/// are `RW`.
pub fn access_name(e: &Entry) -> &'static str {
    match (e.access.readable(), e.access.writable()) {
        (true, true) => "RW",
        (false, true) => "WO",
        _ if e.storage == Storage::Const => "CONST",
        _ => "RO",
    }
}

/// `NO`, `RX`, `TX` or `YES` (both directions).
pub fn pdo_name(m: PdoMapping) -> &'static str {
    match m {
        PdoMapping::No => "NO",
        PdoMapping::Rx => "RX",
        PdoMapping::Tx => "TX",
        PdoMapping::RxTx => "YES",
    }
}

/// A value of type `dt` (little-endian bytes as the model holds them) as table text; empty for
/// no value.
pub fn value_text(dt: DataType, bytes: &[u8]) -> String {
    if bytes.is_empty() {
        return String::new();
    }
    match dt {
        DataType::VisibleString => String::from_utf8_lossy(bytes).into_owned(),
        DataType::UnicodeString => {
            let units: Vec<u16> = bytes
                .chunks(2)
                .map(|c| u16::from_le_bytes([c[0], c.get(1).copied().unwrap_or(0)]))
                .collect();
            String::from_utf16_lossy(&units)
        }
        DataType::OctetString | DataType::Domain => {
            bytes.iter().map(|b| format!("{b:02X}")).collect()
        }
        DataType::Real => match <[u8; 4]>::try_from(bytes) {
            Ok(b) => f32::from_le_bytes(b).to_string(),
            Err(_) => hex(bytes),
        },
        DataType::Lreal => match <[u8; 8]>::try_from(bytes) {
            Ok(b) => f64::from_le_bytes(b).to_string(),
            Err(_) => hex(bytes),
        },
        _ => int_value(dt, bytes).map_or_else(|| hex(bytes), |n| n.to_string()),
    }
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02X}")).collect()
}

/// An integer value from little-endian bytes (sign-extended for signed types).
pub fn int_value(dt: DataType, bytes: &[u8]) -> Option<i128> {
    if bytes.is_empty() || bytes.len() > 16 || dt.int_range().is_none() {
        return None;
    }
    let mut buf = [0u8; 16];
    buf[..bytes.len()].copy_from_slice(bytes);
    let mut n = i128::from_le_bytes(buf);
    let bits = 8 * bytes.len() as u32;
    if dt.is_signed() && bits < 128 && (n >> (bits - 1)) & 1 == 1 {
        n -= 1i128 << bits;
    }
    Some(n)
}

/// The row of one entry of `o`.
pub fn row(o: &Object, e: &Entry) -> Row {
    Row {
        index: format!("0x{:04X}", o.index),
        subindex: e.subindex.to_string(),
        name: e.name.clone(),
        data_type: type_name(e.data_type),
        access: access_name(e).into(),
        pdo_mapping: pdo_name(e.pdo).into(),
        default: value_text(e.data_type, &e.default),
        min: value_text(e.data_type, &e.min),
        max: value_text(e.data_type, &e.max),
    }
}

/// Every entry of the profile, in dictionary order.
pub fn rows(p: &Profile) -> Vec<Row> {
    p.objects
        .iter()
        .flat_map(|o| o.entries.iter().map(move |e| row(o, e)))
        .collect()
}

/// One CSV field (RFC 4180 quoting).
pub fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\r', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// The table as CSV: [`CSV_HEADER`], then one line per entry.
pub fn csv(p: &Profile) -> String {
    let mut out = String::from(CSV_HEADER);
    out.push('\n');
    for r in rows(p) {
        let fields: Vec<String> = r.columns().iter().map(|f| csv_field(f)).collect();
        out.push_str(&fields.join(","));
        out.push('\n');
    }
    out
}

/// The table as aligned text (columns separated by two spaces; line breaks in values shown as
/// `\n`).
pub fn text(p: &Profile) -> String {
    let header = [
        "index", "sub", "name", "type", "access", "pdo", "default", "min", "max",
    ];
    let body: Vec<[String; 9]> = rows(p)
        .iter()
        .map(|r| {
            r.columns()
                .map(|c| c.replace('\r', "\\r").replace('\n', "\\n"))
        })
        .collect();
    let mut width = header.map(|h| h.chars().count());
    for r in &body {
        for (w, c) in width.iter_mut().zip(r) {
            *w = (*w).max(c.chars().count());
        }
    }
    let mut out = String::new();
    let mut line = |cols: [&str; 9]| {
        let mut l = String::new();
        for (i, (c, w)) in cols.iter().zip(width).enumerate() {
            if i > 0 {
                l.push_str("  ");
            }
            // Subindex right-aligned, everything else left-aligned.
            let pad = " ".repeat(w - c.chars().count());
            if i == 1 {
                l.push_str(&pad);
                l.push_str(c);
            } else {
                l.push_str(c);
                l.push_str(&pad);
            }
        }
        out.push_str(l.trim_end());
        out.push('\n');
    };
    line(header);
    for r in &body {
        line([
            &r[0], &r[1], &r[2], &r[3], &r[4], &r[5], &r[6], &r[7], &r[8],
        ]);
    }
    let entries = body.len();
    out.push_str(&format!("{} objects, {entries} entries\n", p.objects.len()));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_quoting() {
        assert_eq!(csv_field("plain"), "plain");
        assert_eq!(csv_field("a,b"), "\"a,b\"");
        assert_eq!(csv_field("say \"hi\""), "\"say \"\"hi\"\"\"");
        assert_eq!(csv_field("two\nlines"), "\"two\nlines\"");
    }

    #[test]
    fn values() {
        assert_eq!(value_text(DataType::Int, &[0xFF, 0xFF]), "-1");
        assert_eq!(value_text(DataType::Uint, &[0xFF, 0xFF]), "65535");
        assert_eq!(value_text(DataType::Sint, &[0x80]), "-128");
        assert_eq!(value_text(DataType::Bit(3), &[5]), "5");
        assert_eq!(value_text(DataType::Int24, &[0, 0, 0x80]), "-8388608");
        assert_eq!(
            value_text(DataType::Lint, &i64::MIN.to_le_bytes()),
            "-9223372036854775808"
        );
        assert_eq!(
            value_text(DataType::Ulint, &u64::MAX.to_le_bytes()),
            "18446744073709551615"
        );
        assert_eq!(value_text(DataType::Real, &1.5f32.to_le_bytes()), "1.5");
        assert_eq!(value_text(DataType::OctetString, &[0x0A, 0xFF]), "0AFF");
        assert_eq!(value_text(DataType::VisibleString, b"1.0"), "1.0");
        assert_eq!(value_text(DataType::Udint, &[]), "");
    }
}
