//! Error codes of the drive profile (603Fh, also the EMCY error code; CiA 301 §7.2.7.1 /
//! CiA402 Table "Error codes").

/// CiA 301 "generic error": the code for a fault a profile's table does not name.
pub const GENERIC_ERROR: u16 = 0x1000;

/// The profile's error code of internal fault number `fault_code` (1-based, as the motor
/// control numbers its faults) in `table` (the profile's `[motor_faults]`, indexed by code − 1);
/// [`GENERIC_ERROR`] for a number outside the table.
pub fn error_code(table: &[u16], fault_code: u8) -> u16 {
    usize::from(fault_code)
        .checked_sub(1)
        .and_then(|i| table.get(i))
        .copied()
        .unwrap_or(GENERIC_ERROR)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_are_looked_up_by_fault_number_and_unknown_ones_are_generic() {
        let table = [0x2320, 0x2350, 0x3210];
        assert_eq!(error_code(&table, 1), 0x2320);
        assert_eq!(error_code(&table, 3), 0x3210);
        assert_eq!(error_code(&table, 0), GENERIC_ERROR, "fault numbers start at 1");
        assert_eq!(error_code(&table, 4), GENERIC_ERROR);
        assert_eq!(error_code(&[], 1), GENERIC_ERROR);
    }
}
