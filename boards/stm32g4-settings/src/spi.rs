//! SPI clock: `SPIx_CR1.BR[2:0]` (RM0440 §39.7.1): f_SCK = f_PCLK / 2^(BR + 1), BR = 0–7
//! (dividers 2 to 256). SPI1/SPI4 run from PCLK2, SPI2/SPI3 from PCLK1.

use crate::SettingError;

/// A baud-rate setting.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BaudRate {
    /// `BR[2:0]`.
    pub br: u8,
    /// The SCK frequency it gives, Hz.
    pub sck_hz: u32,
}

impl BaudRate {
    /// The fastest SCK from `pclk_hz` that does not exceed `max_sck_hz` (the slave's limit,
    /// e.g. the ET1100's). A `const fn`: a board computes its setting at compile time.
    pub const fn at_most(pclk_hz: u32, max_sck_hz: u32) -> Result<Self, SettingError> {
        if pclk_hz == 0 || max_sck_hz == 0 {
            return Err(SettingError::Zero);
        }
        // BR = 0–7: PCLK / 2 … / 256, each half the one before.
        let mut codes: &[u8] = &[0, 1, 2, 3, 4, 5, 6, 7];
        let mut sck_hz = pclk_hz >> 1;
        while let [br, rest @ ..] = codes {
            if sck_hz <= max_sck_hz {
                return Ok(Self { br: *br, sck_hz });
            }
            sck_hz >>= 1;
            codes = rest;
        }
        Err(SettingError::TooSmall {
            min: (pclk_hz >> 8) as u64,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_et1100_clock_from_170_mhz() {
        // 30 MHz limit less margin: 25 MHz → PCLK / 8 = 21.25 MHz (BR = 010).
        assert_eq!(
            BaudRate::at_most(170_000_000, 25_000_000),
            Ok(BaudRate {
                br: 0b010,
                sck_hz: 21_250_000
            })
        );
        // Exactly a divider's frequency is allowed.
        assert_eq!(
            BaudRate::at_most(170_000_000, 21_250_000).map(|b| b.br),
            Ok(0b010)
        );
        assert_eq!(
            BaudRate::at_most(170_000_000, 100_000_000).map(|b| b.br),
            Ok(0)
        );
        assert_eq!(
            BaudRate::at_most(170_000_000, 100_000),
            Err(SettingError::TooSmall { min: 664_062 })
        );
        assert_eq!(BaudRate::at_most(0, 1), Err(SettingError::Zero));
    }
}
