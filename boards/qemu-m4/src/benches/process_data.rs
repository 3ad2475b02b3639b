//! One process-data cycle, as the SYNC0 handler runs it (`Slave::on_cycle` without the PDI
//! transfers): unpack the RxPDO image into the OD RAM, run the application step (CiA402 power
//! drive state machine and the axis), pack the TxPDO image. The images are RAM buffers, so the
//! PDI bus time is excluded, as the budget says.
//!
//! The mappings are the profile's defaults (1C12h → 1600h, 1C13h → 1A00h). The drive is in
//! "operation enabled" with a steady controlword, the state of a running axis, in which the
//! step also copies the target position to the actual position.

use core::hint::black_box;

use firmware::cia402::pds::{controlword, PdsState};
use firmware::drive::Drive;
use firmware::od::Dictionary;
use firmware::pdo::{Direction, PdoPlan, MAX_IMAGE};
use firmware::profiles::standard::{PROFILE, RAM_SIZE};

use super::{master_outputs, read, TARGET_POSITION};
use crate::harness::Harness;

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
        app,
        rx_image,
        tx_image,
    } = &mut c;
    h.bench(
        "pdo-unpack",
        None,
        format_args!("PdoPlan::unpack, default RxPDO mapping (1600h, {rx_bytes} bytes)"),
        &mut || rx.unpack(black_box(rx_image), ram),
    );
    h.bench(
        "cia402-step",
        None,
        format_args!("Drive::step in operation enabled (CiA402, no axis attached)"),
        &mut || app.step(ram, black_box(0)),
    );
    h.bench(
        "pdo-pack",
        None,
        format_args!("PdoPlan::pack, default TxPDO mapping (1A00h, {tx_bytes} bytes)"),
        &mut || tx.pack(black_box(ram), tx_image),
    );
    h.bench(
        "process-data-cycle",
        Some(SYNC0_HANDLER_BUDGET),
        format_args!("one SYNC0 cycle: unpack + step + pack (PDI bus time excluded)"),
        &mut || c.run(),
    );
    if c.app.pds_state() != PdsState::OperationEnabled || c.sent_position() != Some(TARGET_POSITION)
    {
        h.fail(
            "process-data-cycle",
            format_args!("the measured cycles changed the drive's state"),
        );
    }
}
