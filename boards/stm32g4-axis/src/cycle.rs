//! The cycle context (SYNC0, P1): one process-data cycle of the slave, the digital outputs,
//! and the PWM's phase lock to SYNC0, on the parts the cycle context owns ([`CycleSide`]).
//!
//! `boards/stm32g474` runs [`CycleSide::on_cycle_interrupt`] from its TIM3 vector (SYNC0's
//! capture, or a software pend for free-run cycles) with the ET1100 on SPI; the QEMU benchmark
//! board runs it on an ESC image in memory.

use cia402::outputs;
use firmware::drive::DriveAxis;
use firmware::slave::SyncMode;
use firmware::DriveCore;
use hal::esc::AlState;
use hal::io::DigitalOutputs;
use hal::pdi::EscPdi;

use crate::inputs::BrakeOutput;
use crate::phase_lock::{PeriodTrim, Sync0Lock};
use crate::regs::OutputPins;

/// What the cycle context owns: the slave's core, the ESC, the brake output and the phase lock.
pub struct CycleSide<const RAM: usize, P, O> {
    /// The EtherCAT slave's core (ESM, process data, CiA402 application, OD RAM).
    pub core: DriveCore<RAM>,
    /// The ESC.
    pub pdi: P,
    /// The holding brake, set from the axis' 60FEh:01 bit 0 after every cycle.
    pub brake: BrakeOutput<O>,
    /// The PWM's phase lock to SYNC0 (`None` without a motor: no PWM to lock).
    pub sync_lock: Option<Sync0Lock>,
}

impl<const RAM: usize, P: EscPdi, O: OutputPins> CycleSide<RAM, P, O> {
    /// The body of the cycle interrupt. `sync0_phase`: SYNC0's phase in the PWM period (timer
    /// ticks since the valley) when this entry is a SYNC0 edge; `free_run_tick`: a free-run
    /// timer tick requested it. Runs one process-data cycle where the sync mode says this
    /// entry is the cycle's trigger, then the phase lock; `trim` takes the lock's period trim
    /// for the control interrupt. `clock` is the board's ns clock. Returns the cycle's result
    /// if one ran.
    ///
    /// Timing: `on_sync0` (≤ 2,000 instructions, benchmark `sync0-handler-*`) plus the PDI bus
    /// time, the brake output, and the phase lock (benchmark `board-sync0-handler`).
    pub fn on_cycle_interrupt(
        &mut self,
        sync0_phase: Option<u16>,
        free_run_tick: bool,
        clock: impl Fn() -> u64,
        trim: &PeriodTrim,
    ) -> Option<Result<(), P::Error>> {
        let run = match self.core.sync_mode() {
            SyncMode::DcSync0 | SyncMode::DcSync1 => sync0_phase.is_some(),
            SyncMode::FreeRun => free_run_tick,
            // The ESC-event context runs the cycle itself when it sees the SM2 event.
            SyncMode::SmSynchronous => false,
        };
        let result = run.then(|| {
            let result = firmware::sync0::on_sync0(&mut self.core, &mut self.pdi, clock());
            // The measured duration becomes 1C32h/1C33h:06 (calc and copy time).
            self.core.cycle_finished(clock());
            self.drive_outputs();
            result
        });
        if let Some(phase) = sync0_phase {
            self.follow_sync0(phase, clock(), trim);
        }
        result
    }

    /// Sets the digital outputs to what the first axis asks (brake applied without an axis).
    pub fn drive_outputs(&mut self) {
        let (drive, _) = self.core.application();
        let levels = drive
            .axis(0)
            .map_or(outputs::BRAKE, DriveAxis::digital_outputs);
        self.brake.set_outputs(levels);
    }

    /// A SYNC0 edge `phase` ticks after the PWM valley: the phase lock's next period trim, and
    /// a lost lock reported to the slave (AL status 0x0032).
    fn follow_sync0(&mut self, phase: u16, now_ns: u64, trim: &PeriodTrim) {
        let Some(lock) = self.sync_lock.as_mut() else {
            return;
        };
        let synchronous = matches!(self.core.sync_mode(), SyncMode::DcSync0 | SyncMode::DcSync1)
            && matches!(self.core.al_state(), AlState::SafeOp | AlState::Op);
        let outcome = lock.on_sync0(synchronous.then(|| self.core.cycle_ns()), now_ns, phase);
        trim.set(outcome.trim_q8);
        if outcome.report_lost {
            self.core.report_phase_lock_lost();
        }
    }
}
