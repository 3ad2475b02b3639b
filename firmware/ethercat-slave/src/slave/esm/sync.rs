//! Synchronisation configuration: which cycle trigger the master configured (DC registers and
//! 1C32h:01) and whether the profile accepts it.

use hal::esc::{dc, regs, AlStatusCode, DcActivation};
use hal::pdi::EscPdi;

use crate::od::SyncSupport;

/// How the process-data cycle is triggered; the values are those of 1C32h:01 (ETG.1020 §5.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u16)]
pub enum SyncMode {
    /// Not synchronised: the board runs the cycle from a local timer.
    FreeRun = 0,
    /// Synchronous with the SM2 event.
    SmSynchronous = 1,
    /// DC SYNC0.
    DcSync0 = 2,
    /// DC SYNC1.
    DcSync1 = 3,
}

/// The synchronisation the master configured.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SyncConfig {
    /// Trigger.
    pub mode: SyncMode,
    /// Cycle in ns: the SYNC0 cycle in DC modes, the local timer's period (1C32h:02) in free
    /// run, 0 when SM-synchronous (the master's cycle).
    pub cycle_ns: u32,
}

impl SyncConfig {
    /// Reads the DC activation and SYNC0 cycle; `sm_sync_requested` is 1C32h:01 == 1,
    /// `free_run_cycle_ns` is 1C32h:02 (the period of the local timer in free run, ETG.1020).
    pub fn read<P: EscPdi>(
        pdi: &mut P,
        sm_sync_requested: bool,
        free_run_cycle_ns: u32,
    ) -> Result<Self, P::Error> {
        let activation = DcActivation(pdi.read_u8(regs::DC_ACTIVATION.addr)?);
        let mode = if activation.sync1_active() && activation.sync0_active() {
            SyncMode::DcSync1
        } else if activation.sync0_active() {
            SyncMode::DcSync0
        } else if sm_sync_requested {
            SyncMode::SmSynchronous
        } else {
            SyncMode::FreeRun
        };
        let cycle_ns = match mode {
            SyncMode::DcSync0 | SyncMode::DcSync1 => pdi.read_u32(regs::DC_SYNC0_CYCLE.addr)?,
            SyncMode::FreeRun => free_run_cycle_ns,
            SyncMode::SmSynchronous => 0,
        };
        Ok(Self { mode, cycle_ns })
    }

    /// Whether the profile accepts this configuration; the AL status code if not
    /// (ETG.1000.6 Table 11: 0x0027, 0x0028, 0x0030, 0x0035 cycle out of range, 0x0036 cycle
    /// in range but not a whole multiple of [`SyncSupport::cycle_step_ns`] or not one of
    /// [`SyncSupport::allowed_cycles_ns`]; 0x0035 also for a free-run cycle outside the
    /// profile's free-run range).
    pub fn check(&self, support: &SyncSupport) -> Result<(), AlStatusCode> {
        match self.mode {
            SyncMode::FreeRun if !support.free_run => Err(AlStatusCode::FreeRunNotSupported),
            SyncMode::FreeRun => dc::check_free_run_cycle(
                self.cycle_ns,
                support.free_run_min_cycle_ns,
                support.free_run_max_cycle_ns,
            ),
            SyncMode::SmSynchronous if !support.sm_synchronous => {
                Err(AlStatusCode::SyncNotSupported)
            }
            SyncMode::SmSynchronous => Ok(()),
            SyncMode::DcSync0 if !support.dc_sync0 => Err(AlStatusCode::InvalidDcSyncConfig),
            SyncMode::DcSync1 if !support.dc_sync1 => Err(AlStatusCode::InvalidDcSyncConfig),
            // The rule od-gen applies to the profile's cycles too (`hal::esc::DcCycleRule`).
            SyncMode::DcSync0 | SyncMode::DcSync1 => support.dc_cycle_rule().check(self.cycle_ns),
        }
    }

    /// Whether the input shift time 1C33h:03 fits the cycle: in a DC mode, with a writable
    /// shift ([`SyncSupport::input_shift_step_ns`] ≠ 0), it must leave
    /// [`SyncSupport::input_shift_reserve_ns`] of the SYNC0 cycle (else 0x0035: the cycle is
    /// too short for the shift the master set).
    pub fn check_input_shift(
        &self,
        shift_ns: u32,
        support: &SyncSupport,
    ) -> Result<(), AlStatusCode> {
        let dc = matches!(self.mode, SyncMode::DcSync0 | SyncMode::DcSync1);
        let limit = self.cycle_ns.saturating_sub(support.input_shift_reserve_ns);
        if dc && support.input_shift_step_ns != 0 && shift_ns > limit {
            Err(AlStatusCode::DcInvalidSyncCycleTime)
        } else {
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SUPPORT: SyncSupport = SyncSupport {
        free_run: true,
        sm_synchronous: true,
        dc_sync0: true,
        dc_sync1: false,
        min_cycle_ns: 125_000,
        max_cycle_ns: 10_000_000,
        cycle_step_ns: 1,
        allowed_cycles_ns: &[],
        sync_flag_in_sync: false,
        free_run_min_cycle_ns: 125000,
        free_run_max_cycle_ns: 10000000,
        input_shift_step_ns: 0,
        input_shift_reserve_ns: 0,
        input_shift_parameter: None,
        sync_error_at_limit: false,
        sync_error_on_missed_outputs: false,
        sm_event_missed_subindex: 0x0B,
    };

    #[test]
    fn sync_error_flag_follows_etg_or_the_profiles_inverse() {
        // ETG.1020: TRUE = sync error.
        assert_eq!(SUPPORT.sync_error_flag(false, true), 0);
        assert_eq!(SUPPORT.sync_error_flag(true, true), 1);
        // RSE: TRUE = synchronised without error.
        let in_sync = SyncSupport {
            sync_flag_in_sync: true,
            ..SUPPORT
        };
        assert_eq!(in_sync.sync_error_flag(false, true), 1);
        assert_eq!(in_sync.sync_error_flag(false, false), 0, "free run");
        assert_eq!(in_sync.sync_error_flag(true, true), 0);
    }

    #[test]
    fn dc_cycle_not_in_the_profiles_set_is_0x36() {
        let set = SyncSupport {
            min_cycle_ns: 125_000,
            max_cycle_ns: 2_000_000,
            cycle_step_ns: 125_000,
            allowed_cycles_ns: &[125_000, 250_000, 500_000, 1_000_000, 2_000_000],
            ..SUPPORT
        };
        let c = |cycle_ns| SyncConfig {
            mode: SyncMode::DcSync0,
            cycle_ns,
        };
        for ok in [125_000, 250_000, 500_000, 1_000_000, 2_000_000] {
            assert_eq!(c(ok).check(&set), Ok(()), "{ok} ns");
        }
        for bad in [375_000, 750_000, 1_125_000] {
            assert_eq!(
                c(bad).check(&set).map_err(|c| c.code()),
                Err(0x0036),
                "{bad} ns"
            );
        }
        assert_eq!(c(4_000_000).check(&set).map_err(|c| c.code()), Err(0x0035));
    }

    #[test]
    fn dc_cycle_inside_limits_is_accepted() {
        let c = SyncConfig {
            mode: SyncMode::DcSync0,
            cycle_ns: 1_000_000,
        };
        assert_eq!(c.check(&SUPPORT), Ok(()));
    }

    #[test]
    fn dc_cycle_below_minimum_is_0x35() {
        let c = SyncConfig {
            mode: SyncMode::DcSync0,
            cycle_ns: 62_500,
        };
        assert_eq!(c.check(&SUPPORT).map_err(|c| c.code()), Err(0x0035));
        let c = SyncConfig {
            mode: SyncMode::DcSync0,
            cycle_ns: 0,
        };
        assert_eq!(c.check(&SUPPORT).map_err(|c| c.code()), Err(0x0035));
    }

    #[test]
    fn dc_cycle_in_range_but_not_a_multiple_of_the_step_is_0x36() {
        let stepped = SyncSupport {
            min_cycle_ns: 31_250,
            cycle_step_ns: 31_250,
            ..SUPPORT
        };
        let c = |cycle_ns| SyncConfig {
            mode: SyncMode::DcSync0,
            cycle_ns,
        };
        for ok in [31_250, 62_500, 1_000_000, 10_000_000] {
            assert_eq!(c(ok).check(&stepped), Ok(()), "{ok} ns");
        }
        for bad in [50_000, 1_000_001, 999_999, 100_000] {
            assert_eq!(
                c(bad).check(&stepped).map_err(|c| c.code()),
                Err(0x0036),
                "{bad} ns"
            );
        }
        // Out of range stays 0x0035 even when it is not a multiple either.
        assert_eq!(c(20_000).check(&stepped).map_err(|c| c.code()), Err(0x0035));
        assert_eq!(
            c(10_031_250).check(&stepped).map_err(|c| c.code()),
            Err(0x0035)
        );
        // The SYNC0 step does not apply to the free-run cycle.
        let free = SyncConfig {
            mode: SyncMode::FreeRun,
            cycle_ns: 1_000_001,
        };
        assert_eq!(free.check(&stepped), Ok(()));
    }

    #[test]
    fn free_run_cycle_outside_the_free_run_range_is_0x35() {
        // SDV3-E: DC 250 µs – 10 ms, free run 1 ms – 10 ms (1C32h:02).
        let sdv3e = SyncSupport {
            min_cycle_ns: 250_000,
            free_run_min_cycle_ns: 1_000_000,
            free_run_max_cycle_ns: 10_000_000,
            ..SUPPORT
        };
        let free = |cycle_ns| SyncConfig {
            mode: SyncMode::FreeRun,
            cycle_ns,
        };
        for ok in [1_000_000, 2_000_000, 10_000_000] {
            assert_eq!(free(ok).check(&sdv3e), Ok(()), "{ok} ns");
        }
        for bad in [0, 250_000, 999_999, 10_000_001] {
            assert_eq!(
                free(bad).check(&sdv3e).map_err(|c| c.code()),
                Err(0x0035),
                "{bad} ns"
            );
        }
        // The same 250 µs is a valid DC cycle.
        let dc = SyncConfig {
            mode: SyncMode::DcSync0,
            cycle_ns: 250_000,
        };
        assert_eq!(dc.check(&sdv3e), Ok(()));
    }

    #[test]
    fn input_shift_must_leave_the_reserve_of_the_sync0_cycle() {
        // Σ-V-SD: 0 .. (cycle − 125 µs) in steps of 125 µs.
        let sigma = SyncSupport {
            input_shift_step_ns: 125_000,
            input_shift_reserve_ns: 125_000,
            ..SUPPORT
        };
        let dc = |cycle_ns| SyncConfig {
            mode: SyncMode::DcSync0,
            cycle_ns,
        };
        assert_eq!(dc(1_000_000).check_input_shift(875_000, &sigma), Ok(()));
        assert_eq!(dc(1_000_000).check_input_shift(0, &sigma), Ok(()));
        assert_eq!(
            dc(1_000_000)
                .check_input_shift(1_000_000, &sigma)
                .map_err(|c| c.code()),
            Err(0x0035)
        );
        assert_eq!(
            dc(250_000)
                .check_input_shift(250_000, &sigma)
                .map_err(|c| c.code()),
            Err(0x0035)
        );
        // Free run has no SYNC0 to shift from; a read-only shift is never checked.
        let free = SyncConfig {
            mode: SyncMode::FreeRun,
            cycle_ns: 1_000_000,
        };
        assert_eq!(free.check_input_shift(5_000_000, &sigma), Ok(()));
        assert_eq!(dc(250_000).check_input_shift(5_000_000, &SUPPORT), Ok(()));
        // The step.
        assert!(sigma.input_shift_on_step(250_000));
        assert!(!sigma.input_shift_on_step(130_000));
        assert!(
            !SUPPORT.input_shift_on_step(0),
            "read-only: nothing is on step"
        );
    }

    #[test]
    fn unsupported_modes_are_refused() {
        let c = SyncConfig {
            mode: SyncMode::DcSync1,
            cycle_ns: 1_000_000,
        };
        assert_eq!(c.check(&SUPPORT).map_err(|c| c.code()), Err(0x0030));
        let no_free_run = SyncSupport {
            free_run: false,
            ..SUPPORT
        };
        let c = SyncConfig {
            mode: SyncMode::FreeRun,
            cycle_ns: 0,
        };
        assert_eq!(c.check(&no_free_run).map_err(|c| c.code()), Err(0x0027));
    }
}
