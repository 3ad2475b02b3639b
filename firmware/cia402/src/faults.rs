//! Error codes of the drive profile (603Fh, also the EMCY error code; CiA 301 §7.2.7.1 /
//! CiA402 Table "Error codes").

/// What the drive reports for one fault: the 603Fh code and the EMCY message (a profile's
/// alarm: e.g. the Σ-V-SD reports its alarm number in 603Fh and EMCY code FF00h with the alarm
/// in the manufacturer field).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FaultReport {
    /// 603Fh.
    pub error_code: u16,
    /// EMCY bytes 0–1.
    pub emcy_code: u16,
    /// EMCY bytes 3–7 (manufacturer-specific error field).
    pub emcy_data: [u8; 5],
    /// The row of the profile's alarm table this report is (its position in the table), which
    /// the alarm objects show by number; `None` for a fault the table has no alarm for. Kept
    /// apart from the codes because rows may share them (the RSE's manual states no 603Fh
    /// codes or EMCY bytes, so e.g. AL.120, AL.123 and AL.125 all report 7300h).
    pub alarm: Option<u16>,
}

impl FaultReport {
    /// A fault reported with the same code in 603Fh and the EMCY, no manufacturer data, and no
    /// alarm of the profile's table.
    pub const fn code(code: u16) -> Self {
        Self {
            error_code: code,
            emcy_code: code,
            emcy_data: [0; 5],
            alarm: None,
        }
    }
}

/// The profile's entry for internal fault number `fault_code` (1-based, as the motor control
/// numbers its faults) in `table` (the profile's `[motor_faults]`, indexed by code − 1); `None`
/// for a number outside the table (the caller reports CiA 301 "generic error").
pub fn lookup<T: Copy>(table: &[T], fault_code: u8) -> Option<T> {
    usize::from(fault_code)
        .checked_sub(1)
        .and_then(|i| table.get(i))
        .copied()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_are_looked_up_by_fault_number_and_unknown_ones_have_none() {
        let table = [0x2320, 0x2350, 0x3210].map(FaultReport::code);
        assert_eq!(lookup(&table, 1), Some(FaultReport::code(0x2320)));
        assert_eq!(lookup(&table, 3).map(|r| r.error_code), Some(0x3210));
        assert_eq!(lookup(&table, 0), None, "fault numbers start at 1");
        assert_eq!(lookup(&table, 4), None);
        assert_eq!(lookup::<FaultReport>(&[], 1), None);
    }
}
