//! EtherCAT status indicators (ETG.1300 §4): the RUN and ERR LED patterns as pure functions of
//! the EtherCAT state, the error indication and time. Boards switch the LEDs through
//! [`hal::io::StatusLeds`].

use hal::esc::AlState;

/// LED blink patterns of ETG.1300 Table 2 / Figure 2.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Pattern {
    /// Constantly off.
    Off,
    /// Constantly on.
    On,
    /// 50 ms on, 50 ms off.
    Flickering,
    /// 200 ms on, 200 ms off.
    Blinking,
    /// One 200 ms flash, then 1000 ms off.
    SingleFlash,
    /// Two 200 ms flashes 200 ms apart, then 1000 ms off.
    DoubleFlash,
}

/// Time units of ETG.1300 Figure 2, in ms.
const FLICKER_MS: u64 = 50;
const BLINK_MS: u64 = 200;
const FLASH_PAUSE_MS: u64 = 1000;

impl Pattern {
    /// Whether the LED is lit at `t_ms` (any monotonic ms clock; patterns repeat).
    pub fn lit_at(self, t_ms: u64) -> bool {
        match self {
            Self::Off => false,
            Self::On => true,
            Self::Flickering => (t_ms / FLICKER_MS) % 2 == 0,
            Self::Blinking => (t_ms / BLINK_MS) % 2 == 0,
            Self::SingleFlash => t_ms % (BLINK_MS + FLASH_PAUSE_MS) < BLINK_MS,
            Self::DoubleFlash => {
                let t = t_ms % (3 * BLINK_MS + FLASH_PAUSE_MS);
                t < BLINK_MS || (2 * BLINK_MS..3 * BLINK_MS).contains(&t)
            }
        }
    }
}

/// Why the ERR LED is on (ETG.1300 Table 4).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ErrorIndication {
    /// No error.
    None,
    /// The master's configuration was refused (state change refused, AL status error flag).
    InvalidConfiguration,
    /// The slave changed its state by itself (sync error, ...).
    LocalError,
    /// Process-data (SM) watchdog timeout.
    WatchdogTimeout,
    /// Booting error (BOOT state, invalid firmware).
    BootingError,
    /// Application controller failure (e.g. the PDI failed: the SDV3-E's Hr).
    ApplicationControllerFailure,
}

impl ErrorIndication {
    /// The indication whose ETG.1300 ERR LED pattern is `led` (a profile's pattern for an AL
    /// error, `EsmRules::al_error_leds`).
    pub fn showing(led: crate::od::ErrLed) -> Self {
        use crate::od::ErrLed;
        match led {
            ErrLed::Blinking => Self::InvalidConfiguration,
            ErrLed::SingleFlash => Self::LocalError,
            ErrLed::DoubleFlash => Self::WatchdogTimeout,
            ErrLed::On => Self::ApplicationControllerFailure,
        }
    }
}

/// RUN LED pattern for an EtherCAT state (ETG.1300 Table 3).
pub fn run_pattern(state: AlState) -> Pattern {
    match state {
        AlState::Init => Pattern::Off,
        AlState::PreOp => Pattern::Blinking,
        AlState::SafeOp => Pattern::SingleFlash,
        AlState::Op => Pattern::On,
        AlState::Boot => Pattern::Flickering,
    }
}

/// ERR LED pattern for an error indication (ETG.1300 Table 4).
pub fn err_pattern(error: ErrorIndication) -> Pattern {
    match error {
        ErrorIndication::None => Pattern::Off,
        ErrorIndication::InvalidConfiguration => Pattern::Blinking,
        ErrorIndication::LocalError => Pattern::SingleFlash,
        ErrorIndication::WatchdogTimeout => Pattern::DoubleFlash,
        ErrorIndication::BootingError => Pattern::Flickering,
        ErrorIndication::ApplicationControllerFailure => Pattern::On,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn run_led_follows_etg1300_table_3() {
        assert_eq!(run_pattern(AlState::Init), Pattern::Off);
        assert_eq!(run_pattern(AlState::PreOp), Pattern::Blinking);
        assert_eq!(run_pattern(AlState::SafeOp), Pattern::SingleFlash);
        assert_eq!(run_pattern(AlState::Op), Pattern::On);
        assert_eq!(run_pattern(AlState::Boot), Pattern::Flickering);
    }

    #[test]
    fn err_led_follows_etg1300_table_4() {
        assert_eq!(err_pattern(ErrorIndication::None), Pattern::Off);
        assert_eq!(
            err_pattern(ErrorIndication::InvalidConfiguration),
            Pattern::Blinking
        );
        assert_eq!(
            err_pattern(ErrorIndication::LocalError),
            Pattern::SingleFlash
        );
        assert_eq!(
            err_pattern(ErrorIndication::WatchdogTimeout),
            Pattern::DoubleFlash
        );
        assert_eq!(
            err_pattern(ErrorIndication::BootingError),
            Pattern::Flickering
        );
        assert_eq!(
            err_pattern(ErrorIndication::ApplicationControllerFailure),
            Pattern::On
        );
    }

    #[test]
    fn a_profiles_err_led_shows_its_own_pattern() {
        use crate::od::ErrLed;
        for (led, pattern) in [
            (ErrLed::Blinking, Pattern::Blinking),
            (ErrLed::SingleFlash, Pattern::SingleFlash),
            (ErrLed::DoubleFlash, Pattern::DoubleFlash),
            (ErrLed::On, Pattern::On),
        ] {
            assert_eq!(err_pattern(ErrorIndication::showing(led)), pattern);
        }
    }

    #[test]
    fn blinking_is_200ms_on_200ms_off() {
        assert!(Pattern::Blinking.lit_at(0));
        assert!(Pattern::Blinking.lit_at(199));
        assert!(!Pattern::Blinking.lit_at(200));
        assert!(!Pattern::Blinking.lit_at(399));
        assert!(Pattern::Blinking.lit_at(400));
    }

    #[test]
    fn single_flash_is_200ms_on_then_1000ms_off() {
        let lit: u64 = (0..1200)
            .filter(|&t| Pattern::SingleFlash.lit_at(t))
            .count() as u64;
        assert_eq!(lit, 200);
        assert!(Pattern::SingleFlash.lit_at(1200), "period 1200 ms");
    }

    #[test]
    fn double_flash_has_two_200ms_flashes_per_1600ms() {
        let lit = |t: u64| Pattern::DoubleFlash.lit_at(t);
        assert_eq!((0..1600).filter(|&t| lit(t)).count(), 400);
        assert!(lit(0) && !lit(200) && lit(400) && !lit(600) && !lit(1599));
        assert!(lit(1600), "period 1600 ms");
    }

    #[test]
    fn flickering_is_50ms() {
        assert!(Pattern::Flickering.lit_at(49));
        assert!(!Pattern::Flickering.lit_at(50));
    }
}
