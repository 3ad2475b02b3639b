//! PDI watchdog and process-data (SyncManager) watchdog.
//!
//! One tick is (divider 0x0400 + 2) x 40 ns. The PDI watchdog (0x0410 ticks) is retriggered by
//! every PDI access; on expiry DL status bit 1 clears and 0x0443 counts up. The process-data
//! watchdog (0x0420 ticks) is retriggered by ECAT writes into an SM whose control byte has bit 6;
//! it runs only after the first trigger (sim choice, as KickCAT's emulator: no outputs, no
//! watchdog); on expiry 0x0440 bit 0 clears, 0x0442 counts up (both counters saturate) and AL
//! event bit 6 is set. A time of 0 disables a watchdog.

use hal::esc::watchdog::{tick_ns, PD_STATUS_OK};
use hal::esc::{regs, AlEvent};

use super::Et1100;

/// Watchdog timer state.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Watchdogs {
    /// Global time of the last PDI access.
    pdi_last: u64,
    /// The PDI watchdog expired and has not been retriggered.
    pub(crate) pdi_expired: bool,
    /// Global time of the last process-data trigger (None: never triggered).
    pd_last: Option<u64>,
    /// The process-data watchdog expired and has not been retriggered.
    pd_expired: bool,
}

impl Et1100 {
    fn watchdog_tick_ns(&self) -> u64 {
        tick_ns(self.u16_at(regs::WATCHDOG_DIVIDER.addr))
    }

    fn watchdog_deadline(&self, time_reg: regs::Reg, last: u64) -> Option<u64> {
        let ticks = u64::from(self.u16_at(time_reg.addr));
        (ticks != 0).then(|| last.saturating_add(ticks * self.watchdog_tick_ns()))
    }

    fn pdi_deadline(&self) -> Option<u64> {
        if self.wd.pdi_expired || !self.pdi_operational {
            return None;
        }
        self.watchdog_deadline(regs::WATCHDOG_TIME_PDI, self.wd.pdi_last)
    }

    fn pd_deadline(&self) -> Option<u64> {
        if self.wd.pd_expired {
            return None;
        }
        self.watchdog_deadline(regs::WATCHDOG_TIME_PD, self.wd.pd_last?)
    }

    /// A PDI access retriggers the PDI watchdog.
    pub(crate) fn watchdog_pdi_trigger(&mut self) {
        self.wd.pdi_last = self.now;
        if self.wd.pdi_expired {
            self.wd.pdi_expired = false;
            self.update_dl_status();
        }
    }

    /// An ECAT write into a watchdog-triggering SM retriggers the process-data watchdog.
    pub(crate) fn watchdog_pd_trigger(&mut self) {
        self.wd.pd_last = Some(self.now);
        if self.wd.pd_expired {
            self.wd.pd_expired = false;
        }
        let status = self.u16_at(regs::WATCHDOG_STATUS_PD.addr) | PD_STATUS_OK;
        self.set_u16(regs::WATCHDOG_STATUS_PD.addr, status);
    }

    /// Expires the watchdogs whose deadline has passed.
    pub(crate) fn watchdogs_poll(&mut self) {
        if self.pdi_deadline().is_some_and(|d| self.now >= d) {
            self.wd.pdi_expired = true;
            let c = self
                .u8_at(regs::WATCHDOG_COUNTER_PDI.addr)
                .saturating_add(1);
            self.set_u8(regs::WATCHDOG_COUNTER_PDI.addr, c);
            self.update_dl_status();
        }
        if self.pd_deadline().is_some_and(|d| self.now >= d) {
            self.wd.pd_expired = true;
            let status = self.u16_at(regs::WATCHDOG_STATUS_PD.addr) & !PD_STATUS_OK;
            self.set_u16(regs::WATCHDOG_STATUS_PD.addr, status);
            let c = self.u8_at(regs::WATCHDOG_COUNTER_PD.addr).saturating_add(1);
            self.set_u8(regs::WATCHDOG_COUNTER_PD.addr, c);
            self.set_al_event_bits(AlEvent::WATCHDOG_PD, true);
        }
    }

    /// The next watchdog expiry (global ns).
    pub(crate) fn watchdog_next_event(&self) -> Option<u64> {
        [self.pdi_deadline(), self.pd_deadline()]
            .into_iter()
            .flatten()
            .min()
    }
}
