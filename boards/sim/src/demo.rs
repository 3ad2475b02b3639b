//! The built-in demonstration: an ethercrab master (in process) brings a segment of simulated
//! drives from INIT to OP with DC SYNC0, enables the CiA402 power stage through the controlword,
//! exchanges set-points and actual values for a number of cycles, and returns to INIT.
//!
//! The same scenario is the backbone of the end-to-end tests in `tests-host`, which assert on
//! the [`Report`] it returns.

use std::time::Duration;

use ethercrab::subdevice_group::DcConfiguration;
use ethercrab::{DcSync, MainDeviceConfig, Timeouts};

use crate::inproc::InProcess;
use crate::segment::Segment;

/// Most drives a demo group holds.
pub const MAX_DRIVES: usize = 16;
/// Process-data image size of the group.
pub const MAX_PDI: usize = 256;

/// Controlword commands of CiA402 Table 5 used to enable the drive.
pub mod cw {
    /// Shutdown → Ready to switch on.
    pub const SHUTDOWN: u16 = 0x0006;
    /// Switch on → Switched on.
    pub const SWITCH_ON: u16 = 0x0007;
    /// Enable operation → Operation enabled.
    pub const ENABLE_OPERATION: u16 = 0x000F;
}

/// What to run.
#[derive(Clone, Debug)]
pub struct Scenario {
    /// Built-in profile name.
    pub profile: String,
    /// Drives in the ring.
    pub drives: usize,
    /// Master cycle (and the SYNC0 period with DC).
    pub cycle: Duration,
    /// Cyclic exchanges in OP.
    pub cycles: u32,
    /// DC SYNC0 (true) or free run (false).
    pub dc: bool,
}

impl Default for Scenario {
    fn default() -> Self {
        Self {
            profile: "standard".into(),
            drives: 1,
            cycle: Duration::from_millis(1),
            cycles: 1000,
            dc: true,
        }
    }
}

/// Identity of one drive as the master read it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DriveInfo {
    /// Name from the SII (General order string).
    pub name: String,
    /// Configured station address.
    pub address: u16,
    /// Vendor id, product code, revision, serial.
    pub identity: (u32, u32, u32, u32),
}

/// One process-data exchange as the master saw it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CycleSample {
    /// Working counter of the LRW.
    pub working_counter: u16,
    /// Per drive: (controlword sent, target sent, statusword received, position actual received).
    pub first_drive: (u16, i32, u16, i32),
}

/// What happened.
#[derive(Clone, Debug, Default)]
pub struct Report {
    /// Drives found.
    pub drives: Vec<DriveInfo>,
    /// States the group went through, in order.
    pub states: Vec<String>,
    /// Cyclic exchanges in OP.
    pub samples: Vec<CycleSample>,
    /// Expected working counter of each cycle.
    pub expected_wkc: u16,
    /// Cycles whose working counter differed from the expected one.
    pub wkc_errors: u32,
    /// Per drive, 1C32h:01 (sync mode) and 1C32h:02 (cycle time, ns) read by SDO in OP.
    pub sync_parameters: Vec<(u16, u32)>,
    /// SYNC0 cycles each drive ran (from the firmware).
    pub firmware_cycles: Vec<u32>,
    /// Frames exchanged.
    pub frames: u64,
    /// Simulated time at the end, ns.
    pub sim_time_ns: u64,
}

/// Reads a little-endian value out of a PDI slice (missing bytes read as 0).
fn le<const N: usize>(b: &[u8], at: usize) -> [u8; N] {
    let mut out = [0u8; N];
    if let Some(s) = b.get(at..at + N) {
        out.copy_from_slice(s);
    }
    out
}

/// The part of the scenario after OP was requested: wait for OP, read the sync parameters,
/// exchange the cycles, go back to INIT. A macro because ethercrab's group types differ between
/// DC (`tx_rx_dc`) and free run (`tx_rx`).
macro_rules! operate {
    ($group:ident, $txrx:ident, $md:ident, $shared:ident, $s:ident, $cycle_ns:ident, $report:ident, $log:ident) => {{
        for _ in 0..1000 {
            let r = $group.$txrx($md).await?;
            $shared.advance($cycle_ns);
            if r.all_op() {
                break;
            }
        }
        $report.states.push("OP".into());
        for sd in $group.iter($md) {
            let mode = sd.sdo_read::<u16>(SM_OUTPUT_PARAMETER, SYNC_MODE).await?;
            let cycle = sd.sdo_read::<u32>(SM_OUTPUT_PARAMETER, CYCLE_TIME).await?;
            $report.sync_parameters.push((mode, cycle));
        }
        $log(format!("OP; 1C32h sync mode / cycle time per drive: {:?}", $report.sync_parameters));
        for i in 0..$s.cycles {
            let (controlword, target) = set_points(i);
            for sd in $group.iter($md) {
                write_outputs(&mut sd.outputs_raw_mut(), controlword, target);
            }
            let r = $group.$txrx($md).await?;
            if r.working_counter != $report.expected_wkc {
                $report.wkc_errors += 1;
            }
            let (sw, actual) = $group.iter($md).next().map(|sd| read_inputs(&sd.inputs_raw())).unwrap_or_default();
            $report.samples.push(CycleSample {
                working_counter: r.working_counter,
                first_drive: (controlword, target, sw, actual),
            });
            $shared.advance($cycle_ns);
        }
        if let Some(last) = $report.samples.last() {
            $log(format!(
                "{} cycles: working counter {} (expected {}), {} wrong; drive 0 statusword {:#06x}, position actual {}",
                $s.cycles, last.working_counter, $report.expected_wkc, $report.wkc_errors, last.first_drive.2, last.first_drive.3
            ));
        }
        let $group = $group.into_safe_op($md).await?;
        $report.states.push("SAFE-OP".into());
        let $group = $group.into_pre_op($md).await?;
        $report.states.push("PRE-OP".into());
        let _ = $group.into_init($md).await?;
        $report.states.push("INIT".into());
        $log("back in INIT".into());
    }};
}

/// Sync manager output parameter object and its subindices (ETG.1020).
const SM_OUTPUT_PARAMETER: u16 = 0x1C32;
const SYNC_MODE: u8 = 1;
const CYCLE_TIME: u8 = 2;

/// Controlword and target position of cycle `i`: shutdown, switch on, then enable operation
/// (CiA402 Table 5), with a target ramp of 100 increments per cycle.
fn set_points(i: u32) -> (u16, i32) {
    let controlword = match i {
        0..=9 => cw::SHUTDOWN,
        10..=19 => cw::SWITCH_ON,
        _ => cw::ENABLE_OPERATION,
    };
    (controlword, i as i32 * 100)
}

/// Modes of operation 6060h: cyclic synchronous position (CiA402).
const MODE_CSP: u8 = 8;

/// Writes controlword, target position and the mode (CSP) into a drive's outputs (default
/// RxPDO 1600h layout: 6040h, 607Ah, 6060h).
fn write_outputs(out: &mut [u8], controlword: u16, target: i32) {
    if let Some(b) = out.get_mut(0..2) {
        b.copy_from_slice(&controlword.to_le_bytes());
    }
    if let Some(b) = out.get_mut(2..6) {
        b.copy_from_slice(&target.to_le_bytes());
    }
    if let Some(b) = out.get_mut(6) {
        *b = MODE_CSP;
    }
}

/// Statusword and position actual value from a drive's inputs (default TxPDO 1A00h layout).
fn read_inputs(inp: &[u8]) -> (u16, i32) {
    (
        u16::from_le_bytes(le(inp, 0)),
        i32::from_le_bytes(le(inp, 2)),
    )
}

/// Runs the scenario, calling `log` with a line for everything worth telling a user.
pub async fn run(
    s: &Scenario,
    log: &mut dyn FnMut(String),
) -> Result<Report, Box<dyn std::error::Error>> {
    let segment = Segment::new(&s.profile, s.drives)?;
    let (master, transport) = InProcess::connect(
        segment,
        Timeouts {
            pdu: Duration::from_millis(500),
            ..Timeouts::default()
        },
        MainDeviceConfig {
            dc_static_sync_iterations: 1000,
            ..MainDeviceConfig::default()
        },
    );
    let transport = tokio::task::spawn_local(transport);
    let md = &*master.maindevice;
    let shared = master.shared.clone();
    let cycle_ns = s.cycle.as_nanos() as u64;
    let mut report = Report {
        expected_wkc: 3 * s.drives as u16,
        ..Report::default()
    };

    let mut group = md
        .init_single_group::<MAX_DRIVES, MAX_PDI>(shared.clock().now_fn())
        .await?;
    report.states.push("PRE-OP".into());
    log(format!("found {} drive(s)", group.len()));
    for mut sd in group.iter_mut(md) {
        let id = sd.identity();
        let info = DriveInfo {
            name: sd.name().to_string(),
            address: sd.configured_address(),
            identity: (id.vendor_id, id.product_id, id.revision, id.serial),
        };
        log(format!(
            "  {:#06x} {:?}: vendor {:#010x} product {:#010x} revision {:#010x}",
            info.address, info.name, id.vendor_id, id.product_id, id.revision
        ));
        report.drives.push(info);
        if s.dc {
            sd.set_dc_sync(DcSync::Sync0);
        }
    }

    let group = group.into_pre_op_pdi(md).await?;
    if s.dc {
        // Let the drives' clocks lock onto the reference before SYNC0 starts.
        for _ in 0..100 {
            group.tx_rx_sync_system_time(md).await?;
            shared.advance(cycle_ns);
        }
        let group = group
            .configure_dc_sync(
                md,
                DcConfiguration {
                    start_delay: s.cycle * 10,
                    sync0_period: s.cycle,
                    sync0_shift: Duration::ZERO,
                },
            )
            .await?;
        let group = group.into_safe_op(md).await?;
        report.states.push("SAFE-OP".into());
        log(format!("SAFE-OP, DC SYNC0 every {} µs", cycle_ns / 1000));
        let group = group.request_into_op(md).await?;
        operate!(group, tx_rx_dc, md, shared, s, cycle_ns, report, log);
    } else {
        let group = group.into_safe_op(md).await?;
        report.states.push("SAFE-OP".into());
        log("SAFE-OP, free run".into());
        let group = group.request_into_op(md).await?;
        operate!(group, tx_rx, md, shared, s, cycle_ns, report, log);
    }

    {
        let seg = shared.segment();
        report.firmware_cycles = seg.drives().iter().map(|d| d.slave.cycles()).collect();
        report.sim_time_ns = seg.now_ns();
    }
    report.frames = shared.frames();
    drop(master);
    transport.abort();
    Ok(report)
}
