//! The built-in demonstration: an ethercrab master (in process) brings a segment of simulated
//! drives from INIT to OP with DC SYNC0, enables the CiA402 power stage through the controlword,
//! exchanges set-points and actual values for a number of cycles, and returns to INIT.
//!
//! The drives may be of different profiles ([`run_line`]). Vendor profiles map different
//! default PDOs (the Σ-V-SD maps no 6060h, the RSE maps a touch-probe function after the target,
//! ...), so the demo reads each drive's PDO layout by SDO in PRE-OP (1C12h/1C13h and the PDOs
//! they assign, the reads ethercrab makes to size the image) and places controlword, target
//! position and modes of operation where that drive maps them. A drive whose RxPDOs do not carry
//! 6060h gets the mode (CSP) by SDO in PRE-OP instead. Only the first CiA402 axis of a drive is
//! enabled (the firmware drives axis 1; a second axis's objects, e.g. 6840h, stay zero).
//!
//! The same scenario is the backbone of the end-to-end tests in `tests-host`, which assert on
//! the [`Report`] it returns.

use std::time::Duration;

use ethercrab::subdevice_group::DcConfiguration;
use ethercrab::{Command, DcSync, MainDevice, MainDeviceConfig, Timeouts};
use firmware::od::index::sm_parameter::{
    SUB_CALC_AND_COPY_TIME as CALC_AND_COPY_TIME, SUB_CYCLE_TIME as CYCLE_TIME,
    SUB_CYCLE_TIME_TOO_SMALL as CYCLE_TIME_TOO_SMALL, SUB_SM_EVENT_MISSED as SM_EVENT_MISSED,
    SUB_SYNC_ERROR as SYNC_ERROR, SUB_SYNC_TYPE as SYNC_MODE,
};
use firmware::od::index::SM_OUTPUT_PARAMETER;
use firmware::slave::esm::sync::{SyncConfig, SyncMode};
use hal::esc::regs;

use crate::inproc::{InProcess, Shared};
use crate::plant::Fidelity;
use crate::segment::Segment;

/// Most drives a demo group holds.
pub const MAX_DRIVES: usize = 128;
/// Process-data image size of the group. It fits one frame of the in-process master with
/// the DC PDU (`inproc`'s frame size, 100 bytes above it): ethercrab splits a larger image
/// over several LRWs and sums their working counters, which the demo's expected working
/// counter does not model. 128 drives of the standard profile (14 bytes each) or 26 of
/// sigma-v-sd-2axis (72 bytes) fit; ethercrab refuses a larger line in PRE-OP.
pub const MAX_PDI: usize = 1900;

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
    /// Built-in profile name ([`run`]; [`run_line`] takes the profile of every drive instead).
    pub profile: String,
    /// Drives in the ring ([`run`]; [`run_line`] takes one drive per profile name instead).
    pub drives: usize,
    /// Master cycle (and the SYNC0 period with DC).
    pub cycle: Duration,
    /// Cyclic exchanges in OP.
    pub cycles: u32,
    /// DC SYNC0 (true) or free run (false).
    pub dc: bool,
    /// How finely every drive's plant resolves its inverter.
    pub plant: Fidelity,
    /// Threads the simulation of the line may use ([`Segment::set_threads`]).
    pub threads: usize,
}

impl Scenario {
    /// The line [`run`] builds: [`Self::drives`] drives of [`Self::profile`].
    pub fn line(&self) -> Vec<String> {
        vec![self.profile.clone(); self.drives]
    }
}

impl Default for Scenario {
    fn default() -> Self {
        Self {
            profile: "standard".into(),
            drives: 1,
            cycle: Duration::from_millis(1),
            cycles: 1000,
            dc: true,
            plant: Fidelity::PwmResolved,
            threads: 1,
        }
    }
}

/// Checks a master cycle of `cycle_ns` against what the built-in `profile` accepts (the
/// firmware's own rule, [`SyncConfig::check`]): with `dc` the SYNC0 range, its step and its
/// fixed set of cycles; in free run the free-run range. The error says what is accepted.
pub fn check_cycle(profile: &str, cycle_ns: u64, dc: bool) -> Result<u32, String> {
    let p = firmware::profiles::by_name(profile)
        .ok_or_else(|| format!("unknown profile {profile:?}"))?;
    let sync = &p.od.device.sync;
    let given = cycle_ns;
    let cycle_ns = u32::try_from(cycle_ns).ok().filter(|&ns| ns > 0);
    let mode = if dc {
        SyncMode::DcSync0
    } else {
        SyncMode::FreeRun
    };
    let accepted = cycle_ns.filter(|&cycle_ns| SyncConfig { mode, cycle_ns }.check(sync).is_ok());
    accepted.ok_or_else(|| {
        let us = |ns: u32| f64::from(ns) / 1e3;
        let what = if !dc {
            format!(
                "free-run cycles of {} to {} µs",
                us(sync.free_run_min_cycle_ns),
                us(sync.free_run_max_cycle_ns)
            )
        } else if !sync.allowed_cycles_ns.is_empty() {
            let list: Vec<String> = sync
                .allowed_cycles_ns
                .iter()
                .map(|&c| us(c).to_string())
                .collect();
            format!("DC SYNC0 cycles of {} µs only", list.join(", "))
        } else if sync.cycle_step_ns > 1 {
            format!(
                "DC SYNC0 cycles of {} to {} µs in steps of {} µs",
                us(sync.min_cycle_ns),
                us(sync.max_cycle_ns),
                us(sync.cycle_step_ns)
            )
        } else {
            format!(
                "DC SYNC0 cycles of {} to {} µs",
                us(sync.min_cycle_ns),
                us(sync.max_cycle_ns)
            )
        };
        let given = given as f64 / 1e3;
        format!("a cycle of {given} µs: the {profile} profile accepts {what}")
    })
}

/// Identity of one drive as the master read it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DriveInfo {
    /// Built-in profile the drive was built with (as given to [`run_line`]).
    pub profile: String,
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
    /// Per drive, its process-data layout as it reported it by SDO in PRE-OP.
    pub layouts: Vec<PdoLayout>,
    /// Per drive, the statusword and position actual value of the last cycle.
    pub last_inputs: Vec<(u16, i32)>,
    /// Expected working counter of each cycle.
    pub expected_wkc: u16,
    /// Cycles whose working counter differed from the expected one.
    pub wkc_errors: u32,
    /// Per drive, 1C32h:01 (sync mode) and 1C32h:02 (cycle time, ns) read by SDO in OP.
    pub sync_parameters: Vec<(u16, u32)>,
    /// Per drive, what it saw of the synchronisation, read in OP after the exchange.
    pub sync_health: Vec<SyncHealth>,
    /// SYNC0 cycles each drive ran (from the firmware).
    pub firmware_cycles: Vec<u32>,
    /// Frames exchanged.
    pub frames: u64,
    /// Simulated time at the end, ns.
    pub sim_time_ns: u64,
    /// Simulated time of the cyclic exchange in OP, ns: [`Scenario::cycles`] cycles and the
    /// wire time of their frames.
    pub cyclic_sim_ns: u64,
    /// Host (wall-clock) time the cyclic exchange in OP took.
    pub cyclic_wall: Duration,
}

impl Report {
    /// Simulated time over host time of the cyclic exchange in OP (start-up excluded): how
    /// many times faster than real time the line ran; `None` before any cycle.
    pub fn real_time_factor(&self) -> Option<f64> {
        let wall = self.cyclic_wall.as_secs_f64();
        (self.cyclic_sim_ns > 0 && wall > 0.0).then(|| self.cyclic_sim_ns as f64 * 1e-9 / wall)
    }
}

/// A drive's account of the synchronisation after the cyclic exchange (ETG.1020 §5.1, the SM
/// output parameter 1C32h), read in OP. `None`: not readable (a profile without that subindex).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SyncHealth {
    /// AL status register 0x0130 (OP without error: 0x0008).
    pub al_status: Option<u16>,
    /// 1C32h:0B, SM-event missed counter: SYNC0 events without new outputs.
    pub sm_events_missed: Option<u16>,
    /// 1C32h:0C, cycle time too small counter: cycles whose processing (with the modelled PDI
    /// bus time) outlasted the cycle.
    pub cycle_time_too_small: Option<u16>,
    /// 1C32h:20, sync error.
    pub sync_error: Option<bool>,
    /// 1C32h:06, calc and copy time (ns): the longest cycle the drive measured, which in the
    /// simulation is the modelled SPI bus time of its PDI accesses.
    pub calc_and_copy_ns: Option<u32>,
}

impl SyncHealth {
    /// Whether the drive kept the cycle: in OP without error, no missed SM event, no cycle too
    /// small and no sync error (each subindex it has).
    pub fn kept_the_cycle(&self) -> bool {
        self.al_status == Some(AL_STATUS_OP)
            && self.sm_events_missed.unwrap_or(0) == 0
            && self.cycle_time_too_small.unwrap_or(0) == 0
            && self.sync_error != Some(true)
    }
}

/// AL status 0x0130 of a drive in OP without error indication (ETG.1000.6 Table 9).
const AL_STATUS_OP: u16 = 0x0008;

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
    ($group:ident, $txrx:ident, $md:ident, $shared:ident, $s:ident, $ios:ident, $cycle_ns:ident, $report:ident, $log:ident) => {{
        let mut all_op = false;
        for _ in 0..1000 {
            let r = $group.$txrx($md).await?;
            $shared.advance($cycle_ns);
            if r.all_op() {
                all_op = true;
                break;
            }
        }
        if !all_op {
            return Err("not every drive reached OP within 1000 cycles".into());
        }
        $report.states.push("OP".into());
        for sd in $group.iter($md) {
            let mode = sd.sdo_read::<u16>(SM_OUTPUT_PARAMETER, SYNC_MODE).await?;
            let cycle = sd.sdo_read::<u32>(SM_OUTPUT_PARAMETER, CYCLE_TIME).await?;
            $report.sync_parameters.push((mode, cycle));
        }
        $log(format!(
            "OP; 1C32h sync mode / cycle time per drive: {:?}",
            $report.sync_parameters
        ));
        let cyclic_start = std::time::Instant::now();
        let cyclic_start_ns = $shared.clock().now();
        for i in 0..$s.cycles {
            let (controlword, target) = set_points(i, $cycle_ns);
            for (sd, io) in $group.iter($md).zip(&$ios) {
                io.write_outputs(&mut sd.outputs_raw_mut(), controlword, target);
            }
            let r = $group.$txrx($md).await?;
            if r.working_counter != $report.expected_wkc {
                $report.wkc_errors += 1;
            }
            $report.last_inputs = $group
                .iter($md)
                .zip(&$ios)
                .map(|(sd, io)| io.read_inputs(&sd.inputs_raw()))
                .collect();
            let (sw, actual) = $report.last_inputs.first().copied().unwrap_or_default();
            $report.samples.push(CycleSample {
                working_counter: r.working_counter,
                first_drive: (controlword, target, sw, actual),
            });
            $shared.advance($cycle_ns);
        }
        $report.cyclic_wall = cyclic_start.elapsed();
        // The cycles and the frames' wire time (a long line's frames take a good part of a
        // cycle on the wire).
        $report.cyclic_sim_ns = $shared.clock().now().saturating_sub(cyclic_start_ns);
        for sd in $group.iter($md) {
            let health = SyncHealth {
                al_status: Command::fprd(sd.configured_address(), regs::AL_STATUS.addr)
                    .receive::<u16>($md)
                    .await
                    .ok(),
                sm_events_missed: sd.sdo_read::<u16>(SM_OUTPUT_PARAMETER, SM_EVENT_MISSED).await.ok(),
                cycle_time_too_small: sd
                    .sdo_read::<u16>(SM_OUTPUT_PARAMETER, CYCLE_TIME_TOO_SMALL)
                    .await
                    .ok(),
                sync_error: sd
                    .sdo_read::<u8>(SM_OUTPUT_PARAMETER, SYNC_ERROR)
                    .await
                    .ok()
                    .map(|b| b != 0),
                calc_and_copy_ns: sd
                    .sdo_read::<u32>(SM_OUTPUT_PARAMETER, CALC_AND_COPY_TIME)
                    .await
                    .ok(),
            };
            $report.sync_health.push(health);
        }
        if let Some(last) = $report.samples.last() {
            $log(format!(
                "{} cycles: working counter {} (expected {}), {} wrong",
                $s.cycles, last.working_counter, $report.expected_wkc, $report.wkc_errors
            ));
            for (i, (sw, actual)) in $report.last_inputs.iter().enumerate() {
                $log(format!(
                    "  drive {i} ({}): statusword {sw:#06x}, position actual {actual}",
                    $report.drives[i].profile
                ));
            }
            for (i, h) in $report.sync_health.iter().enumerate() {
                let show = |v: Option<u16>| v.map_or("-".to_string(), |v| v.to_string());
                $log(format!(
                    "  drive {i}: {}; SM events missed {}, cycle time too small {}, sync error {}, \
                     longest cycle {} (modelled PDI bus time)",
                    if h.kept_the_cycle() { "kept the cycle" } else { "LOST the cycle" },
                    show(h.sm_events_missed),
                    show(h.cycle_time_too_small),
                    h.sync_error.map_or("-", |e| if e { "yes" } else { "no" }),
                    h.calc_and_copy_ns
                        .map_or("-".to_string(), |ns| format!("{:.2} µs", f64::from(ns) / 1e3)),
                ));
            }
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

/// Modes of operation 6060h: cyclic synchronous position (CiA402).
const MODE_CSP: i8 = 8;

/// CiA402 objects the demo exchanges (first axis).
const CONTROLWORD: u16 = 0x6040;
const STATUSWORD: u16 = 0x6041;
const MODES_OF_OPERATION: u16 = 0x6060;
const POSITION_ACTUAL: u16 = 0x6064;
const TARGET_POSITION: u16 = 0x607A;

/// PDO assignment objects of SM2 (RxPDOs) and SM3 (TxPDOs) (ETG.1000.6 Table 67).
const RX_PDO_ASSIGN: u16 = 0x1C12;
const TX_PDO_ASSIGN: u16 = 0x1C13;

/// One object mapped into a drive's process data.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MappedObject {
    /// Object index (0 for a gap).
    pub index: u16,
    /// Subindex.
    pub subindex: u8,
    /// Length in bits.
    pub bits: u8,
    /// Offset in bits from the start of the drive's outputs (RxPDOs) or inputs (TxPDOs).
    pub bit_offset: u32,
}

/// A drive's process-data layout: the PDOs assigned to SM2 (1C12h) and SM3 (1C13h) and the
/// objects they map, in the order the process data carries them.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct PdoLayout {
    /// RxPDOs assigned to SM2 (1C12h:01..).
    pub rx_pdos: Vec<u16>,
    /// TxPDOs assigned to SM3 (1C13h:01..).
    pub tx_pdos: Vec<u16>,
    /// Objects in the outputs (master → drive).
    pub outputs: Vec<MappedObject>,
    /// Objects in the inputs (drive → master).
    pub inputs: Vec<MappedObject>,
}

impl PdoLayout {
    /// Bytes of the outputs (the SM2 length).
    pub fn output_bytes(&self) -> usize {
        bytes(&self.outputs)
    }
    /// Bytes of the inputs (the SM3 length).
    pub fn input_bytes(&self) -> usize {
        bytes(&self.inputs)
    }
    /// Byte offset of `index`:00 in the outputs, if mapped on a byte boundary.
    pub fn output(&self, index: u16) -> Option<usize> {
        byte_offset(&self.outputs, index)
    }
    /// Byte offset of `index`:00 in the inputs, if mapped on a byte boundary.
    pub fn input(&self, index: u16) -> Option<usize> {
        byte_offset(&self.inputs, index)
    }
}

fn bytes(objects: &[MappedObject]) -> usize {
    let bits: u32 = objects.iter().map(|o| u32::from(o.bits)).sum();
    bits.div_ceil(8) as usize
}

fn byte_offset(objects: &[MappedObject], index: u16) -> Option<usize> {
    objects
        .iter()
        .find(|o| o.index == index && o.subindex == 0 && o.bit_offset % 8 == 0)
        .map(|o| (o.bit_offset / 8) as usize)
}

/// Reads the PDOs assigned by `assign` (1C12h or 1C13h) and their mapping entries by SDO.
async fn read_assignment<S>(
    sd: &ethercrab::SubDeviceRef<'_, S>,
    assign: u16,
) -> Result<(Vec<u16>, Vec<MappedObject>), ethercrab::error::Error>
where
    S: std::ops::Deref<Target = ethercrab::SubDevice>,
{
    let mut pdos = Vec::new();
    let mut objects = Vec::new();
    let mut bit_offset = 0u32;
    let count = sd.sdo_read::<u8>(assign, 0).await?;
    for i in 1..=count {
        let pdo = sd.sdo_read::<u16>(assign, i).await?;
        pdos.push(pdo);
        let entries = sd.sdo_read::<u8>(pdo, 0).await?;
        for e in 1..=entries {
            // Mapping entry: index (bits 31..16), subindex (15..8), length in bits (7..0).
            let m = sd.sdo_read::<u32>(pdo, e).await?;
            let object = MappedObject {
                index: (m >> 16) as u16,
                subindex: (m >> 8) as u8,
                bits: m as u8,
                bit_offset,
            };
            bit_offset += u32::from(object.bits);
            objects.push(object);
        }
    }
    Ok((pdos, objects))
}

/// Where the demo's objects sit in one drive's process data (byte offsets).
#[derive(Clone, Copy, Debug)]
struct Io {
    controlword: usize,
    target: Option<usize>,
    mode: Option<usize>,
    statusword: usize,
    position: Option<usize>,
}

impl Io {
    fn new(layout: &PdoLayout, drive: usize, profile: &str) -> Result<Self, String> {
        let missing = |what: &str, pdos: &[u16], assign: u16| {
            format!(
                "drive {drive} ({profile}): {what} is not mapped in its PDOs \
                 ({assign:04X}h assigns {pdos:04X?}); the demo cannot enable it"
            )
        };
        Ok(Self {
            controlword: layout
                .output(CONTROLWORD)
                .ok_or_else(|| missing("controlword 6040h", &layout.rx_pdos, RX_PDO_ASSIGN))?,
            target: layout.output(TARGET_POSITION),
            mode: layout.output(MODES_OF_OPERATION),
            statusword: layout
                .input(STATUSWORD)
                .ok_or_else(|| missing("statusword 6041h", &layout.tx_pdos, TX_PDO_ASSIGN))?,
            position: layout.input(POSITION_ACTUAL),
        })
    }

    /// Writes controlword, target position and the mode (CSP) into the drive's outputs, each
    /// where the drive maps it (not mapped: not written).
    fn write_outputs(&self, out: &mut [u8], controlword: u16, target: i32) {
        put(out, Some(self.controlword), &controlword.to_le_bytes());
        put(out, self.target, &target.to_le_bytes());
        put(out, self.mode, &MODE_CSP.to_le_bytes());
    }

    /// Statusword and position actual value (0 if not mapped) from the drive's inputs.
    fn read_inputs(&self, inp: &[u8]) -> (u16, i32) {
        (
            u16::from_le_bytes(le(inp, self.statusword)),
            self.position
                .map_or(0, |at| i32::from_le_bytes(le(inp, at))),
        )
    }
}

fn put(out: &mut [u8], at: Option<usize>, value: &[u8]) {
    if let Some(b) = at.and_then(|at| out.get_mut(at..at + value.len())) {
        b.copy_from_slice(value);
    }
}

/// The demo's target speed: 100 increments per millisecond (100 per cycle at the default 1 ms).
pub const TARGET_INCREMENTS_PER_MS: i64 = 100;

/// Controlword and target position of cycle `i` of `cycle_ns`: shutdown, switch on, then enable
/// operation (CiA402 Table 5), with a target ramp of [`TARGET_INCREMENTS_PER_MS`] (the same
/// speed at every cycle time).
pub fn set_points(i: u32, cycle_ns: u64) -> (u16, i32) {
    const NS_PER_MS: i128 = 1_000_000;
    let controlword = match i {
        0..=9 => cw::SHUTDOWN,
        10..=19 => cw::SWITCH_ON,
        _ => cw::ENABLE_OPERATION,
    };
    let elapsed_ns = i128::from(i) * i128::from(cycle_ns);
    let target = elapsed_ns * i128::from(TARGET_INCREMENTS_PER_MS) / NS_PER_MS;
    (controlword, i32::try_from(target).unwrap_or(i32::MAX))
}

/// Runs the scenario ([`Scenario::drives`] drives of [`Scenario::profile`]), calling `log`
/// with a line for everything worth telling a user.
pub async fn run(
    s: &Scenario,
    log: &mut dyn FnMut(String),
) -> Result<Report, Box<dyn std::error::Error>> {
    run_line(&s.line(), s, log).await
}

/// Runs the scenario on a line of drives, one per built-in profile name in `profiles`, in ring
/// order (profiles may differ; [`Scenario::profile`] and [`Scenario::drives`] are not used).
pub async fn run_line<S: AsRef<str>>(
    profiles: &[S],
    s: &Scenario,
    log: &mut dyn FnMut(String),
) -> Result<Report, Box<dyn std::error::Error>> {
    let profiles: Vec<String> = profiles.iter().map(|p| p.as_ref().to_string()).collect();
    let mut segment = Segment::line_with_plant(&profiles, s.plant)?;
    segment.set_threads(s.threads)?;
    check_sync_modes(&profiles, s.dc)?;
    let cycle_ns = u64::try_from(s.cycle.as_nanos()).unwrap_or(u64::MAX);
    for p in &profiles {
        check_cycle(p, cycle_ns, s.dc)?;
    }
    let (master, transport) = InProcess::connect(
        segment,
        // Wall-clock timeouts: the simulated drives answer at once, but a loaded host may not
        // run the master for a while (ethercrab's 10 ms EEPROM default times out there).
        Timeouts {
            pdu: Duration::from_millis(500),
            eeprom: Duration::from_secs(2),
            mailbox_response: Duration::from_secs(2),
            ..Timeouts::default()
        },
        MainDeviceConfig {
            dc_static_sync_iterations: 1000,
            ..MainDeviceConfig::default()
        },
    );
    let transport = tokio::task::spawn_local(transport);
    let md = &*master.maindevice;
    let mut report = Report::default();
    // On the heap: a group of `MAX_DRIVES` drives in each of its typestates would overflow the
    // stack of a test thread (2 MiB).
    let outcome = Box::pin(operate_line(
        md,
        &master.shared,
        &profiles,
        s,
        &mut report,
        log,
    ))
    .await;
    if let Err(e) = outcome {
        // Say where each drive stopped: the AL status and AL status code registers.
        let mut states = Vec::new();
        for (i, d) in report.drives.iter().enumerate() {
            states.push(format!(
                "drive {i} ({}) {}",
                d.profile,
                al_state(md, d.address).await
            ));
        }
        transport.abort();
        return Err(if states.is_empty() {
            e
        } else {
            format!("{e}; {}", states.join("; ")).into()
        });
    }
    {
        let seg = master.shared.segment();
        report.firmware_cycles = seg.drives().iter().map(|d| d.slave.cycles()).collect();
        report.sim_time_ns = seg.now_ns();
    }
    report.frames = master.shared.frames();
    drop(master);
    transport.abort();
    Ok(report)
}

/// Refuses a line in which a drive does not support the scenario's synchronisation (its
/// 1C32h:04): the drive would refuse SAFE-OP (AL status code 0x0027 or 0x0030), and ethercrab
/// only notices when its state-transition timeout runs out.
fn check_sync_modes(profiles: &[String], dc: bool) -> Result<(), Box<dyn std::error::Error>> {
    for (i, name) in profiles.iter().enumerate() {
        let sync = od_gen::builtin(name)?.sync;
        if dc && !sync.dc_sync0 {
            return Err(format!(
                "drive {i} ({name}) does not support DC SYNC0; run the demo with --free-run"
            )
            .into());
        }
        if !dc && !sync.free_run {
            return Err(format!(
                "drive {i} ({name}) does not support free run (DC SYNC0 only); run the demo without --free-run"
            )
            .into());
        }
    }
    Ok(())
}

/// "AL status 0x0012 (PRE-OP, error), AL status code 0x001d" of the drive at `address`.
async fn al_state(md: &MainDevice<'_>, address: u16) -> String {
    let status = Command::fprd(address, regs::AL_STATUS.addr)
        .receive::<u16>(md)
        .await;
    let code = Command::fprd(address, regs::AL_STATUS_CODE.addr)
        .receive::<u16>(md)
        .await;
    match (status, code) {
        (Ok(status), Ok(code)) => {
            let state = match status & 0x0F {
                1 => "INIT",
                2 => "PRE-OP",
                3 => "BOOT",
                4 => "SAFE-OP",
                8 => "OP",
                _ => "unknown state",
            };
            let error = if status & 0x10 != 0 { ", error" } else { "" };
            format!("AL status {status:#06x} ({state}{error}), AL status code {code:#06x}")
        }
        (Err(e), _) | (_, Err(e)) => format!("AL status not readable: {e}"),
    }
}

/// The scenario from INIT to OP and back, on the master `md` connected to `shared`.
async fn operate_line(
    md: &MainDevice<'_>,
    shared: &Shared,
    profiles: &[String],
    s: &Scenario,
    report: &mut Report,
    log: &mut dyn FnMut(String),
) -> Result<(), Box<dyn std::error::Error>> {
    let cycle_ns = s.cycle.as_nanos() as u64;
    let mut group = md
        .init_single_group::<MAX_DRIVES, MAX_PDI>(shared.clock().now_fn())
        .await?;
    report.states.push("PRE-OP".into());
    log(format!("found {} drive(s)", group.len()));
    if group.len() != profiles.len() {
        return Err(format!(
            "found {} drive(s), but the line has {}",
            group.len(),
            profiles.len()
        )
        .into());
    }
    for (mut sd, profile) in group.iter_mut(md).zip(profiles) {
        let id = sd.identity();
        let info = DriveInfo {
            profile: profile.clone(),
            name: sd.name().to_string(),
            address: sd.configured_address(),
            identity: (id.vendor_id, id.product_id, id.revision, id.serial),
        };
        log(format!(
            "  {:#06x} {} {:?}: vendor {:#010x} product {:#010x} revision {:#010x}",
            info.address, info.profile, info.name, id.vendor_id, id.product_id, id.revision
        ));
        report.drives.push(info);
        if s.dc {
            sd.set_dc_sync(DcSync::Sync0);
        }
    }

    // Each drive's PDO layout, read the way ethercrab reads it to size the process image; the
    // outputs are written where this drive maps them.
    let mut ios = Vec::with_capacity(profiles.len());
    for (i, sd) in group.iter(md).enumerate() {
        let profile = &profiles[i];
        let (rx_pdos, outputs) = read_assignment(&sd, RX_PDO_ASSIGN).await?;
        let (tx_pdos, inputs) = read_assignment(&sd, TX_PDO_ASSIGN).await?;
        let layout = PdoLayout {
            rx_pdos,
            tx_pdos,
            outputs,
            inputs,
        };
        let io = Io::new(&layout, i, profile)?;
        log(format!(
            "  drive {i} ({profile}): RxPDOs {:04X?} ({} bytes), TxPDOs {:04X?} ({} bytes)",
            layout.rx_pdos,
            layout.output_bytes(),
            layout.tx_pdos,
            layout.input_bytes()
        ));
        if io.mode.is_none() {
            // Not in the process data: the mode is a start-up parameter, written in PRE-OP as
            // a master's init commands do.
            sd.sdo_write(MODES_OF_OPERATION, 0, MODE_CSP)
                .await
                .map_err(|e| {
                    format!("drive {i} ({profile}): writing 6060h:00 = {MODE_CSP} by SDO: {e}")
                })?;
            log(format!(
                "  drive {i} ({profile}): 6060h is not mapped; modes of operation set to CSP by SDO"
            ));
        }
        // Each drive with outputs adds 2 to the LRW's working counter, with inputs 1
        // (ETG.1000.4 §5.4.3).
        report.expected_wkc +=
            2 * u16::from(layout.output_bytes() > 0) + u16::from(layout.input_bytes() > 0);
        report.layouts.push(layout);
        ios.push(io);
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
        operate!(group, tx_rx_dc, md, shared, s, ios, cycle_ns, report, log);
    } else {
        let group = group.into_safe_op(md).await?;
        report.states.push("SAFE-OP".into());
        log("SAFE-OP, free run".into());
        let group = group.request_into_op(md).await?;
        operate!(group, tx_rx, md, shared, s, ios, cycle_ns, report, log);
    }
    Ok(())
}
