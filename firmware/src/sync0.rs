//! The drive's SYNC0 handler, top to bottom: what runs once per DC cycle (or free-run tick) on
//! the board, and which layer does each step.
//!
//! | step | layer | where |
//! |---|---|---|
//! | 1. SYNC0 supervision (sync error counter, cycle time check) | EtherCAT slave | `ethercat_slave::slave::esm::supervision` |
//! | 2. read SM2, unpack the RxPDO image into the OD RAM (in OP) | EtherCAT slave | `ethercat_slave::pdo::PdoPlan::unpack` |
//! | 3. controlword → PDS state → statusword, fault reset | CiA402 | [`cia402::device`] |
//! | 4. mode of operation → set-point (position / velocity / torque) in axis units | CiA402 | [`cia402::modes`], [`cia402::units`] |
//! | 5. set-point to the control interrupt, feedback and motor faults back (lock-free) | motor control | [`crate::motor::handoff`] through [`crate::motor::axis::AxisLink`] |
//! | 6. actual values → OD RAM (object units) | CiA402 | [`cia402::units`] |
//! | 7. a new or reset fault → EMCY, 1001h, 10F3h | EtherCAT slave | `ethercat_slave::slave` (errors) |
//! | 8. pack the TxPDO image, write SM3 | EtherCAT slave | `ethercat_slave::pdo::PdoPlan::pack` |
//!
//! Steps 3–6 are [`Drive::step`](crate::drive::Drive::step); the control loops themselves run
//! in the PWM/ADC interrupt ([`crate::motor::axis::Axis::control_step`]), not here.
//!
//! Timing budget (DESIGN.md §6, measured in `benchmarks/REPORT.md`): ≤ 2,000 Cortex-M4
//! instructions without the PDI bus time, so that a 31.25 µs DC cycle fits.

use ethercat_slave::slave::{AppEvents, Application};
use hal::pdi::EscPdi;

use crate::DriveCore;

/// One SYNC0 cycle of the drive (steps 1–8 above). Call it from the SYNC0 interrupt (DC
/// modes) or the free-run timer, then `slave.cycle_finished(now)` with the time it ended.
/// Below SAFEOP it does nothing. It needs only the slave's core (a `DriveSlave` passes as one):
/// the mailbox side, and whatever mailbox transfer it is in, is not touched.
pub fn on_sync0<P: EscPdi, const RAM: usize>(
    slave: &mut DriveCore<RAM>,
    pdi: &mut P,
    now_ns: u64,
) -> Result<(), P::Error> {
    // 1–2: EtherCAT.
    let Some(cycle_ns) = slave.cycle_begin(pdi, now_ns)? else {
        return Ok(());
    };
    // 3–6: CiA402 and the axis, on the objects the master just wrote.
    let (drive, ram) = slave.application();
    let mut events = AppEvents::new();
    drive.cycle(ram, cycle_ns, &mut events);
    // 7–8: EtherCAT.
    slave.cycle_end(pdi, &events, now_ns)
}
