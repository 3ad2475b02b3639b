//! One process-data cycle, as the SYNC0 handler runs it (`Slave::on_cycle` without the PDI
//! transfers): unpack the RxPDO image into the OD RAM, run the application step (CiA402 power
//! drive state machine and the axis), pack the TxPDO image. The images are RAM buffers, so the
//! PDI bus time is excluded, as the budget says.
//!
//! The mappings are the profile's defaults (1C12h → 1600h, 1C13h → 1A00h). The copies are
//! measured with the drive in "operation enabled" with a steady controlword, the state of a
//! running axis, in which the step also copies the target position to the actual position; the
//! step and the whole cycle in every state the power drive system can hold.

use core::hint::black_box;

use firmware::cia402::pds::{controlword, PdsState};
use firmware::drive::Drive;
use firmware::od::{Dictionary, ErrorReport};
use firmware::pdo::{Direction, PdoPlan, MAX_IMAGE};
use firmware::profiles::standard::{PROFILE, RAM_SIZE};
use firmware::slave::Application;

use super::{master_outputs, read, TARGET_POSITION};
use crate::harness::{Cases, Harness};

/// DESIGN.md §6: SYNC0 handler (PDO unpack, CiA402, PDO pack; PDI bus time excluded).
const SYNC0_HANDLER_BUDGET: u32 = 2_000;

/// CiA402 device-control commands (IEC 61800-7-201 Table 5) from power-on to operation enabled.
const SHUTDOWN: u16 = controlword::ENABLE_VOLTAGE | controlword::QUICK_STOP;
const SWITCH_ON: u16 = SHUTDOWN | controlword::SWITCH_ON;
const ENABLE_OPERATION: u16 = SWITCH_ON | controlword::ENABLE_OPERATION;
/// The controlwords of the power-up sequence; the last one stays during the measurement.
const POWER_UP: [u16; 4] = [0, SHUTDOWN, SWITCH_ON, ENABLE_OPERATION];

/// The slave's cycle state: OD RAM, the two copy plans, the application and the images.
struct Cycle {
    ram: [u8; RAM_SIZE],
    rx: PdoPlan,
    tx: PdoPlan,
    app: Drive,
    rx_image: [u8; MAX_IMAGE],
    tx_image: [u8; MAX_IMAGE],
}

impl Cycle {
    /// The OD at its defaults and the copy plans of the default mapping, as at PREOP → SAFEOP.
    fn new() -> Option<Self> {
        let mut ram = [0; RAM_SIZE];
        let mut od = Dictionary::new(&PROFILE.od, &mut ram);
        od.load_defaults();
        let rx = PdoPlan::build(&od, Direction::Rx).ok()?;
        let tx = PdoPlan::build(&od, Direction::Tx).ok()?;
        Some(Self {
            ram,
            rx,
            tx,
            app: Drive::new(&PROFILE),
            rx_image: [0; MAX_IMAGE],
            tx_image: [0; MAX_IMAGE],
        })
    }

    /// Puts the master's outputs into the RxPDO image ([`master_outputs`] packed by the Rx
    /// plan).
    fn set_outputs(&mut self, controlword: u16) -> bool {
        match master_outputs(controlword) {
            Some(master) => {
                self.rx.pack(&master, &mut self.rx_image);
                true
            }
            None => false,
        }
    }

    /// The measured cycle.
    fn run(&mut self) {
        self.rx.unpack(&self.rx_image, &mut self.ram);
        self.app.step(&mut self.ram, 0);
        self.tx.pack(&self.ram, &mut self.tx_image);
    }

    /// The position actual value the TxPDO image carries (read back through the Tx plan).
    fn sent_position(&self) -> Option<i32> {
        let mut master = [0; RAM_SIZE];
        self.tx.unpack(&self.tx_image, &mut master);
        read::<4>(
            &master,
            super::axis_vars().and_then(|v| v.position_actual_value),
        )
        .map(i32::from_le_bytes)
    }
}

/// Measures unpack, step and pack, each and together.
pub fn run(h: &mut Harness) {
    let Some(mut c) = Cycle::new() else {
        h.fail(
            "process-data",
            format_args!("the default mapping gives no copy plan"),
        );
        return;
    };
    for cw in POWER_UP {
        if !c.set_outputs(cw) {
            h.fail(
                "process-data",
                format_args!("the profile lacks a CiA402 variable"),
            );
            return;
        }
        c.run();
    }
    if c.app.pds_state() != PdsState::OperationEnabled || c.sent_position() != Some(TARGET_POSITION)
    {
        h.fail(
            "process-data",
            format_args!("the drive did not reach operation enabled"),
        );
        return;
    }

    let (rx_bytes, tx_bytes) = (c.rx.byte_len(), c.tx.byte_len());
    let Cycle {
        ram,
        rx,
        tx,
        rx_image,
        tx_image,
        ..
    } = &mut c;
    h.bench(
        "pdo-unpack",
        None,
        format_args!("PdoPlan::unpack, default RxPDO mapping (1600h, {rx_bytes} bytes)"),
        &mut || rx.unpack(black_box(rx_image), ram),
    );
    h.bench(
        "pdo-pack",
        None,
        format_args!("PdoPlan::pack, default TxPDO mapping (1A00h, {tx_bytes} bytes)"),
        &mut || tx.pack(black_box(ram), tx_image),
    );
    if let Err(reason) = every_state(h, &mut c) {
        h.fail("cia402-step", format_args!("{reason}"));
    }
}

/// The states of the CiA402 power drive system a cycle can find the drive in for good (IEC
/// 61800-7-201 Figure 6; "not ready to switch on" and "fault reaction active" are left by
/// themselves within a cycle), in the order the measurement visits them: label, the master's
/// controlword that holds it, the state.
const STATES: [(&str, u16, PdsState); 6] = [
    (
        "operation enabled",
        ENABLE_OPERATION,
        PdsState::OperationEnabled,
    ),
    // Quick stop (bit 2 clear) with 605Ah = 6: the quick-stop ramp, then stay.
    (
        "quick stop active",
        controlword::ENABLE_VOLTAGE,
        PdsState::QuickStopActive,
    ),
    ("switch on disabled", 0, PdsState::SwitchOnDisabled),
    ("ready to switch on", SHUTDOWN, PdsState::ReadyToSwitchOn),
    ("switched on", SWITCH_ON, PdsState::SwitchedOn),
    // Entered by an error of the unit; no fault reset in the controlword.
    ("fault", SWITCH_ON, PdsState::Fault),
];
/// Quick stop option code 605Ah (IEC 61800-7-201 Table 26): the quick-stop ramp, then stay in
/// quick stop active.
const QUICK_STOP_AND_STAY: u8 = 6;
const QUICK_STOP_OPTION_CODE: (u16, u8) = (0x605A, 0);
/// An error of the unit that faults the drive (any code: the fault is what is measured).
const UNIT_ERROR: u16 = 0xFF00;
/// Cycles with a controlword before its state is taken as reached.
const SETTLE_CYCLES: usize = 4;

/// The CiA402 step alone and the whole process-data cycle in every state of [`STATES`].
fn every_state(h: &mut Harness, c: &mut Cycle) -> Result<(), &'static str> {
    let mut step = Cases::new("cia402-step");
    let mut cycle = Cases::new("process-data-cycle");
    for (label, cw, state) in STATES {
        match state {
            PdsState::QuickStopActive => {
                let mut od = Dictionary::new(&PROFILE.od, &mut c.ram);
                let (index, subindex) = QUICK_STOP_OPTION_CODE;
                let entry = od.entry(index, subindex).ok_or("no 605Ah")?;
                od.set_value(entry, &[QUICK_STOP_AND_STAY, 0])
                    .map_err(|_| "605Ah not writable")?;
                // As an SDO download tells the drive.
                c.app.downloaded(&mut c.ram, index, subindex, 0);
            }
            PdsState::Fault => c.app.raise_error(ErrorReport::code(UNIT_ERROR), &mut c.ram),
            _ => {}
        }
        if !c.set_outputs(cw) {
            return Err("the profile lacks a CiA402 variable");
        }
        for _ in 0..SETTLE_CYCLES {
            c.run();
        }
        if c.app.pds_state() != state {
            return Err("the drive did not reach the state to measure");
        }
        let Cycle { ram, app, .. } = &mut *c;
        let Some(cost) = h.measure("cia402-step", &mut || app.step(ram, black_box(0))) else {
            return Ok(());
        };
        h.case(&mut step, label, cost);
        let Some(cost) = h.measure("process-data-cycle", &mut || c.run()) else {
            return Ok(());
        };
        h.case(&mut cycle, label, cost);
        if c.app.pds_state() != state {
            return Err("the measured cycles changed the drive's state");
        }
        if state == PdsState::OperationEnabled && c.sent_position() != Some(TARGET_POSITION) {
            return Err("operation enabled does not echo the target position");
        }
    }
    h.report_cases(
        &step,
        None,
        format_args!("Drive::step (CiA402, no axis attached) in every state of the PDS state machine a cycle can hold"),
    );
    h.report_cases(
        &cycle,
        Some(SYNC0_HANDLER_BUDGET),
        format_args!(
            "one SYNC0 cycle: unpack + step + pack (PDI bus time excluded), in every state of \
             the PDS state machine a cycle can hold"
        ),
    );
    Ok(())
}
