//! The SII EEPROM configuration area (words 0..7) the ESC loads at power-on (Beckhoff ESC
//! datasheet Section I, "SII EEPROM"; ETG.2010 Table 2), and its CRC-8.

/// CRC-8 polynomial of the configuration area: x⁸ + x² + x + 1.
pub const CRC_POLY: u8 = 0x07;
/// CRC-8 initial value.
pub const CRC_INIT: u8 = 0xFF;
/// Bytes covered by the CRC: words 0..6 (bytes 0..13).
pub const CRC_COVERED: usize = 14;
/// Byte offset of the CRC in the image: low byte of word 7.
pub const CRC_OFFSET: usize = 14;

/// Word addresses of the configuration area and the ESC registers they load.
pub mod word {
    /// PDI control / ESC configuration (→ 0x0140 / 0x0141).
    pub const PDI_CONTROL: usize = 0;
    /// PDI configuration (→ 0x0150 / 0x0151).
    pub const PDI_CONFIG: usize = 1;
    /// SYNC signal pulse length (→ 0x0982).
    pub const SYNC_PULSE: usize = 2;
    /// Extended PDI configuration (→ 0x0152).
    pub const PDI_CONFIG_EXT: usize = 3;
    /// Configured station alias (→ 0x0012, at power-on only).
    pub const ALIAS: usize = 4;
    /// Checksum word: the CRC-8 in the low byte.
    pub const CHECKSUM: usize = 7;
}

/// CRC-8 of the SII configuration area: polynomial 0x07, initial value 0xFF, no reflection, no
/// final XOR, over `data` (bytes 0..13 of the image; the result belongs in byte 14). Check value
/// of `"123456789"`: 0xFB.
// The bit counter runs 0..8.
#[allow(clippy::arithmetic_side_effects)]
pub const fn crc8(data: &[u8]) -> u8 {
    let mut crc = CRC_INIT;
    let mut rest = data;
    while let [byte, tail @ ..] = rest {
        crc ^= *byte;
        let mut bit = 0;
        while bit < 8 {
            crc = if crc & 0x80 != 0 {
                (crc << 1) ^ CRC_POLY
            } else {
                crc << 1
            };
            bit += 1;
        }
        rest = tail;
    }
    crc
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc8_check_value() {
        assert_eq!(crc8(b"123456789"), 0xFB);
        assert_eq!(crc8(&[]), 0xFF);
        assert_eq!(crc8(&[0xFF]), 0x00);
    }

    #[test]
    fn crc8_is_const() {
        const C: u8 = crc8(b"123456789");
        assert_eq!(C, 0xFB);
    }
}
