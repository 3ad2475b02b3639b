//! The independent watchdog (IWDG): resets the MCU when an interrupt context stops or takes the
//! CPU for good. Refreshed from thread mode (`tasks::watchdog`) only while every expected
//! context still runs ([`stm32g4_axis::liveness::Liveness`]).
//!
//! | setting | value | RM0440 §35 |
//! |---|---|---|
//! | clock | LSI, 32 kHz nominal | §35.3, §7.2.6 |
//! | timeout | ≥ [`TIMEOUT_US`] (prescaler and reload from `stm32g4-settings`) | t = 4·2^PR·(RL+1) / f_LSI |
//! | refresh | every [`CHECK_PERIOD_MS`] when alive | |
//! | debug | frozen while the core is halted by the probe (DBGMCU_APB1FZR1.DBG_IWDG_STOP) | §47 |
//!
//! The check period is longer than the longest DC cycle (10 ms), so a cycle context that runs
//! at all shows progress in every period; the timeout leaves a missed refresh or two to
//! thread-mode latency (a flash page erase of the parameter store runs from the other bank and
//! does not stall the CPU).

use embassy_stm32::pac;
use embassy_stm32::pac::iwdg::vals::{Key, Pr};
use embassy_stm32::peripherals::IWDG;
use embassy_stm32::Peri;
use stm32g4_settings::iwdg::Watchdog as WatchdogSetting;

/// LSI frequency (nominal; the datasheet's tolerance was not available, see
/// `stm32g4-settings/FACTS.md`).
const LSI_HZ: u32 = 32_000;
/// Period of the liveness check and refresh, ms.
pub const CHECK_PERIOD_MS: u64 = 25;
/// The shortest time without a refresh that resets the MCU, µs: four check periods.
pub const TIMEOUT_US: u32 = 4 * CHECK_PERIOD_MS as u32 * 1_000;
/// PR and RLR.
const SETTING: WatchdogSetting = match WatchdogSetting::at_least(LSI_HZ, TIMEOUT_US) {
    Ok(s) => s,
    Err(_) => panic!("IWDG timeout out of range"),
};
/// Polls of the status register for the prescaler and reload updates (each ≤ 5 LSI cycles,
/// 156 µs; a poll is ≈ 10 ns).
const MAX_POLLS: u32 = 100_000;

const _: () = {
    // The longest DC cycle (10 ms) fits a check period; 100 ms at 32 kHz is ÷32 with RL 99.
    assert!(CHECK_PERIOD_MS > 10);
    assert!(SETTING.timeout_us(LSI_HZ) >= TIMEOUT_US as u64);
};

/// The running watchdog (it cannot be stopped once started).
pub struct Iwdg {
    _private: (),
}

impl Iwdg {
    /// Starts the watchdog with [`SETTING`]. Returns `Err` if the registers did not take the
    /// setting (the watchdog then runs with its reset timeout, 512 ms).
    pub fn start(_iwdg: Peri<'static, IWDG>) -> Result<Self, Self> {
        pac::DBGMCU.apb1lfzr().modify(|w| w.set_iwdg(true));
        let w = pac::IWDG;
        w.kr().write(|r| r.set_key(Key::START));
        w.kr().write(|r| r.set_key(Key::ENABLE));
        w.pr().write(|r| r.set_pr(Pr::from_bits(SETTING.prescaler)));
        w.rlr().write(|r| r.set_rl(SETTING.reload));
        let mut updated = false;
        for _ in 0..MAX_POLLS {
            let sr = w.sr().read();
            if !(sr.pvu() || sr.rvu() || sr.wvu()) {
                updated = true;
                break;
            }
        }
        let iwdg = Self { _private: () };
        iwdg.feed();
        if updated {
            Ok(iwdg)
        } else {
            Err(iwdg)
        }
    }

    /// Reloads the counter.
    pub fn feed(&self) {
        pac::IWDG.kr().write(|r| r.set_key(Key::RESET));
    }
}
