//! Distributed clocks: a drifting local clock, the receive-time latch, the system-time drift
//! loop and the SYNC0/SYNC1 generator.
//!
//! - Local clock: `local(t) = anchor_local + (t - anchor_global) * (1 + (drift + correction)/1e9)`
//!   with drift in ppb against global simulated time and the loop's correction.
//! - Latch (ECAT write to 0x0900): local time at which the frame entered port 0 (0x0900, and as
//!   u64 in 0x0918) and came back into port 1 (0x0904, when port 1 is open).
//! - System time 0x0910 reads local + offset 0x0920. An ECAT write (the non-reading slaves of
//!   ARMW/FRMW, or BWR/FPWR) gives the loop `diff = (local + offset - delay) - received`, stored
//!   sign-magnitude in 0x092C; the loop slews the local clock with a critically damped PI whose
//!   time constant is at least [`TIME_LOOP_TAU_MIN_NS`] and two write intervals, limited to
//!   what the speed counter diff 0x0932 can represent: one 1 ns step every
//!   [`SPEED_COUNTER_DIFF_MARGIN`] ticks of 10 ns (787 ppm; ET1100 crystals are specified to
//!   ±25 ppm, so any two ESCs can be locked). A write to 0x0930 resets it.
//! - SYNC: with 0x0981 cyclic + SYNC0, pulses at start time + k x SYNC0 cycle (system time).
//!   SYNC1 follows a SYNC0 pulse by the SYNC1 cycle; the delay is measured again from the first
//!   SYNC0 pulse at or after the SYNC1 pulse (TI/Beckhoff ESC description), so SYNC1 cycle =
//!   n x SYNC0 cycle gives SYNC1 with every n-th SYNC0. If the start time already passed at
//!   activation, 0x0984 bit 2 is set and the first pulse comes at the next cycle boundary aligned
//!   to the start time (the ET1100 would wait for a 32-bit wrap; the sim is pragmatic). Each pulse
//!   sets SYNCn status (0x098E/F) and, when mapped in 0x0151, AL event bit 2/3; a PDI read of the
//!   status clears both. The SYNC pin edge ([`hal::pdi::EscSignals`]) needs the SYNC output
//!   configured in 0x0151.

use hal::esc::dc::{FILTER_DEPTH_MASK, SPEED_COUNTER_DIFF_MARGIN, SPEED_COUNTER_TICK_NS};
use hal::esc::{
    regs, AlEvent, DcActivation, DcActivationStatus, DcSyncStatus, DcSystemTimeDiff,
    SyncLatchConfig,
};

use super::access::Effects;
use super::consts::TIME_LOOP_TAU_MIN_NS;
use super::Et1100;

/// ppb per ppm.
const PPB_PER_PPM: f64 = 1000.0;
/// ns per s.
const NS_PER_S: f64 = 1e9;

/// A local oscillator that drifts against global simulated time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct LocalClock {
    anchor_global: u64,
    anchor_local: u64,
    drift_ppb: f64,
    correction_ppb: f64,
}

impl LocalClock {
    fn rate(&self) -> f64 {
        (self.drift_ppb + self.correction_ppb) / NS_PER_S
    }

    /// Local time at global time `t`.
    pub(crate) fn local_at(&self, t: u64) -> u64 {
        let dt = i128::from(t) - i128::from(self.anchor_global);
        let adj = (dt as f64 * self.rate()).round() as i128;
        (i128::from(self.anchor_local) + dt + adj) as u64
    }

    /// Earliest global time at which the local time has reached `local`.
    fn global_at(&self, local: u64) -> u64 {
        let dl = local.wrapping_sub(self.anchor_local) as i64 as f64;
        let dt = (dl / (1.0 + self.rate())).ceil() as i128 + 1;
        (i128::from(self.anchor_global) + dt).clamp(0, i128::from(u64::MAX)) as u64
    }

    /// Moves the anchor to global time `t` (keeps precision; does not change the clock).
    pub(crate) fn reanchor(&mut self, t: u64) {
        self.anchor_local = self.local_at(t);
        self.anchor_global = t;
    }

    fn set_correction(&mut self, t: u64, ppb: f64) {
        self.reanchor(t);
        self.correction_ppb = ppb;
    }
}

/// State of the drift loop.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct TimeLoop {
    filtered_ns: f64,
    integral_ppb: f64,
    last_write: Option<u64>,
}

/// State of the SYNC generator (times in system time).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct SyncUnit {
    active: bool,
    next_sync0: Option<u64>,
    next_sync1: Option<u64>,
}

/// The DC unit of one ESC.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct DcUnit {
    pub(crate) clock: LocalClock,
    time_loop: TimeLoop,
    sync: SyncUnit,
}

impl DcUnit {
    pub(crate) fn new(drift_ppm: f64) -> Self {
        Self {
            clock: LocalClock {
                anchor_global: 0,
                anchor_local: 0,
                drift_ppb: drift_ppm * PPB_PER_PPM,
                correction_ppb: 0.0,
            },
            time_loop: TimeLoop::default(),
            sync: SyncUnit::default(),
        }
    }

    pub(crate) fn set_clock(&mut self, now: u64, local: u64, drift_ppm: f64) {
        self.clock = LocalClock {
            anchor_global: now,
            anchor_local: local,
            drift_ppb: drift_ppm * PPB_PER_PPM,
            correction_ppb: 0.0,
        };
        self.time_loop = TimeLoop::default();
    }

    /// A write to the speed counter start resets the loop filters and the rate correction.
    pub(crate) fn reset_loop(&mut self, now: u64) {
        self.time_loop = TimeLoop::default();
        self.clock.set_correction(now, 0.0);
    }
}

impl Et1100 {
    /// Latches the receive times of the current frame (ECAT write to 0x0900).
    pub(crate) fn dc_latch(&mut self, fx: &Effects) {
        let t0 = self.dc.clock.local_at(fx.frame.port0);
        self.set_u32(regs::DC_RECEIVE_TIME_PORT0.addr, t0 as u32);
        self.set_u64(regs::DC_RECEIVE_TIME_PU.addr, t0);
        if let Some(t1) = fx.frame.port1 {
            let t1 = self.dc.clock.local_at(t1);
            self.set_u32(regs::DC_RECEIVE_TIME_PORT1.addr, t1 as u32);
        }
    }

    /// Feeds a received system time into the drift loop.
    pub(crate) fn dc_system_time_written(&mut self, fx: &Effects) {
        const LOW_HALF: u8 = 0x0F;
        const ALL: u8 = 0xFF;
        if fx.systime_mask & LOW_HALF != LOW_HALF {
            return;
        }
        let received = u64::from_le_bytes(fx.systime_bytes);
        let t = fx.time;
        let offset = self.u64_at(regs::DC_SYSTEM_TIME_OFFSET.addr);
        let delay = u64::from(self.u32_at(regs::DC_SYSTEM_TIME_DELAY.addr));
        let mine = self
            .dc
            .clock
            .local_at(t)
            .wrapping_add(offset)
            .wrapping_sub(delay);
        let diff = if fx.systime_mask == ALL {
            mine.wrapping_sub(received) as i64
        } else {
            i64::from((mine as u32).wrapping_sub(received as u32) as i32)
        };
        self.set_u32(
            regs::DC_SYSTEM_TIME_DIFF.addr,
            DcSystemTimeDiff::encode(diff).0,
        );

        let depth = u32::from(self.u8_at(regs::DC_TIME_FILTER_DEPTH.addr) & FILTER_DEPTH_MASK);
        let max_slew_ppb =
            NS_PER_S / (f64::from(SPEED_COUNTER_DIFF_MARGIN) * f64::from(SPEED_COUNTER_TICK_NS));
        let tl = &mut self.dc.time_loop;
        tl.filtered_ns += (diff as f64 - tl.filtered_ns) / f64::from(1u32 << depth);
        let dt_ns = tl
            .last_write
            .map_or(0.0, |last| t.saturating_sub(last) as f64);
        tl.last_write = Some(t);
        let tau_s = TIME_LOOP_TAU_MIN_NS.max(2.0 * dt_ns) / NS_PER_S;
        let kp = 1.0 / tau_s;
        let ki = kp * kp / 4.0;
        let e = tl.filtered_ns;
        tl.integral_ppb =
            (tl.integral_ppb - ki * e * dt_ns / NS_PER_S).clamp(-max_slew_ppb, max_slew_ppb);
        let correction = (tl.integral_ppb - kp * e).clamp(-max_slew_ppb, max_slew_ppb);
        self.dc.clock.set_correction(t, correction);
    }

    /// System time now.
    fn system_time_now(&self) -> u64 {
        self.system_time_at(self.now)
    }

    /// Whether cyclic operation runs.
    pub(crate) fn sync_active(&self) -> bool {
        self.dc.sync.active
    }

    /// Handles a write of the activation register 0x0981.
    pub(crate) fn sync_activation_written(&mut self) {
        let act = DcActivation(self.u8_at(regs::DC_ACTIVATION.addr));
        if act.0 & DcActivation::CYCLIC == 0 {
            self.dc.sync = SyncUnit::default();
            self.set_u8(regs::DC_ACTIVATION_STATUS.addr, 0);
            return;
        }
        if self.dc.sync.active {
            return;
        }
        let start = self.u64_at(regs::DC_START_TIME.addr);
        let cycle0 = u64::from(self.u32_at(regs::DC_SYNC0_CYCLE.addr));
        let cycle1 = u64::from(self.u32_at(regs::DC_SYNC1_CYCLE.addr));
        let now = self.system_time_now();
        let mut status = DcActivationStatus::SYNC0_PENDING | DcActivationStatus::SYNC1_PENDING;
        let first = if (start.wrapping_sub(now) as i64) > 0 {
            start
        } else {
            status |= DcActivationStatus::START_TIME_IMPLAUSIBLE;
            match cycle0 {
                0 => now,
                c => start.wrapping_add((now.wrapping_sub(start) / c + 1) * c),
            }
        };
        self.dc.sync = SyncUnit {
            active: true,
            next_sync0: Some(first),
            next_sync1: Some(first.wrapping_add(cycle1)),
        };
        self.set_u8(regs::DC_ACTIVATION_STATUS.addr, status);
        self.sync_publish();
    }

    /// Mirrors the next pulse times into 0x0990 (reads back the next SYNC0) and 0x0998.
    fn sync_publish(&mut self) {
        if let Some(t) = self.dc.sync.next_sync0 {
            self.set_u64(regs::DC_START_TIME.addr, t);
        }
        if let Some(t) = self.dc.sync.next_sync1 {
            self.set_u64(regs::DC_NEXT_SYNC1.addr, t);
        }
    }

    fn sync_pulse(&mut self, sync1: bool) {
        let act = DcActivation(self.u8_at(regs::DC_ACTIVATION.addr));
        let enabled = if sync1 {
            act.0 & DcActivation::SYNC1
        } else {
            act.0 & DcActivation::SYNC0
        } != 0;
        let (n, status_reg, event, pending) = if sync1 {
            (
                1,
                regs::DC_SYNC1_STATUS,
                AlEvent::SYNC1,
                DcActivationStatus::SYNC1_PENDING,
            )
        } else {
            (
                0,
                regs::DC_SYNC0_STATUS,
                AlEvent::SYNC0,
                DcActivationStatus::SYNC0_PENDING,
            )
        };
        if !enabled {
            return;
        }
        let st = self.u8_at(regs::DC_ACTIVATION_STATUS.addr) & !pending;
        self.set_u8(regs::DC_ACTIVATION_STATUS.addr, st);
        self.set_u8(status_reg.addr, DcSyncStatus::ACTIVE);
        let cfg = SyncLatchConfig(self.u8_at(regs::SYNC_LATCH_CONFIG.addr));
        if cfg.sync_to_al_event(n) {
            self.set_al_event_bits(event, true);
        }
        if cfg.sync_output(n) {
            if sync1 {
                self.sync1_edge = true;
            } else {
                self.sync0_edge = true;
            }
        }
    }

    /// Generates the pulses due at the current time.
    pub(crate) fn sync_poll(&mut self) {
        if !self.dc.sync.active {
            return;
        }
        let now = self.system_time_now();
        let cycle0 = u64::from(self.u32_at(regs::DC_SYNC0_CYCLE.addr));
        let cycle1 = u64::from(self.u32_at(regs::DC_SYNC1_CYCLE.addr));
        let due = |t: Option<u64>| t.is_some_and(|t| (now.wrapping_sub(t) as i64) >= 0);
        if due(self.dc.sync.next_sync0) {
            self.sync_pulse(false);
            self.dc.sync.next_sync0 = match (self.dc.sync.next_sync0, cycle0) {
                (_, 0) | (None, _) => None,
                (Some(t), c) => Some(t.wrapping_add((now.wrapping_sub(t) / c + 1) * c)),
            };
        }
        if due(self.dc.sync.next_sync1) {
            self.sync_pulse(true);
            self.dc.sync.next_sync1 = match (self.dc.sync.next_sync1, cycle0) {
                (_, 0) | (None, _) => None,
                (Some(t), c) => {
                    // SYNC1 period: the SYNC1 delay re-measured from the first SYNC0 at or after
                    // the SYNC1 pulse: max(c, ceil(d / c) x c).
                    let period = cycle1.div_ceil(c).max(1) * c;
                    Some(t.wrapping_add((now.wrapping_sub(t) / period + 1) * period))
                }
            };
        }
        self.sync_publish();
    }

    /// Global time of the next SYNC pulse.
    pub(crate) fn sync_next_event(&self) -> Option<u64> {
        if !self.dc.sync.active {
            return None;
        }
        let offset = self.u64_at(regs::DC_SYSTEM_TIME_OFFSET.addr);
        [self.dc.sync.next_sync0, self.dc.sync.next_sync1]
            .into_iter()
            .flatten()
            .map(|s| {
                self.dc
                    .clock
                    .global_at(s.wrapping_sub(offset))
                    .max(self.now)
            })
            .min()
    }
}
