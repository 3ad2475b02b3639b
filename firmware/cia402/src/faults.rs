//! Error codes of the drive profile (603Fh, also the EMCY error code; CiA 301 §7.2.7.1 /
//! CiA402 Table "Error codes").

/// The profile's error code of internal fault number `fault_code` (1-based, as the motor
/// control numbers its faults) in `table` (the profile's `[motor_faults]`, indexed by code − 1);
/// `None` for a number outside the table (the caller reports CiA 301 "generic error").
pub fn error_code(table: &[u16], fault_code: u8) -> Option<u16> {
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
        let table = [0x2320, 0x2350, 0x3210];
        assert_eq!(error_code(&table, 1), Some(0x2320));
        assert_eq!(error_code(&table, 3), Some(0x3210));
        assert_eq!(error_code(&table, 0), None, "fault numbers start at 1");
        assert_eq!(error_code(&table, 4), None);
        assert_eq!(error_code(&[], 1), None);
    }
}
