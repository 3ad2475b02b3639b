//! `soak`: three simulated drives under ethercrab at the shortest DC cycle their profile allows,
//! for many cycles, with random SDO traffic, mode changes and injected faults; reports every
//! error it cannot explain, the process' memory over the run and the longest firmware handler
//! time. `tests-host/soak/run` runs it for 10⁶ cycles and writes `tests-host/soak/REPORT.md`.
//!
//! ```text
//! soak [--cycles N] [--seed S] [--report FILE]
//! ```
//!
//! Explained (expected) events: the fault a drive was given (Fault in its statusword, its
//! `[motor_faults]` 603Fh code and emergency) and its recovery after the cause is cleared
//! (emergency 0000h "error reset"). Everything else is unexplained: a Fault, an emergency or a
//! state other than OP without an injection, a working counter other than 3 per drive, a
//! failed frame or SDO, an injected fault that is not reported or from which the drive does
//! not recover.

use std::fmt::Write as _;
use std::process::ExitCode;

use board_sim::inproc::InProcess;
use board_sim::Segment;
use ethercrab::{Command, MainDevice};
use od_gen::model::MOTOR_FAULT_NAMES;
use tests_host::vendor::{self, DcGroup};
use tests_host::{block_on, cia402, master_for, units};

const PROFILE: &str = "standard";
const DRIVES: usize = 3;
/// The output image of each drive ([`vendor::VELOCITY_MAPPING`]): 6040h, 6060h, 60FFh.
const OUT_LEN: usize = 7;
/// Modes the soak switches between: both take their set-point from 60FFh.
const MODES: [i8; 2] = [
    cia402::CYCLIC_SYNCHRONOUS_VELOCITY,
    cia402::PROFILE_VELOCITY,
];
/// Cycles between injected faults (on one drive, chosen at random).
const FAULT_PERIOD: u64 = 25_000;
/// Cycles an injected fault may take to be reported, and a recovery to complete.
const REPORT_WITHIN: u64 = 20_000;
const RECOVER_WITHIN: u64 = 40_000;
/// Cycles between mode or speed changes of a drive (on average).
const CHANGE_PERIOD: u64 = 3_000;
/// Cycles between SDO requests, and between mailbox polls for emergencies.
const SDO_PERIOD: u64 = 97;
const EMCY_POLL_PERIOD: u64 = 53;
/// Longest wait for OP after the OP request (the SYNC0 start delay is 10 ms).
const WARM_UP_CYCLES: u64 = 10_000;
/// Memory checkpoints over the run.
const CHECKPOINTS: u64 = 20;

/// The faults injected, by `[motor_faults]` key.
const INJECTIONS: [&str; 3] = ["bus_over_voltage", "drive_over_temperature", "encoder_crc"];

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n.max(1)
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Phase {
    /// Enable sequence from this cycle.
    Enabling(u64),
    Running,
    /// Fault `INJECTIONS[k]` injected at this cycle; reported yet.
    Injected(usize, u64, bool),
    /// Fault reset + enable sequence from this cycle (cause cleared at the first).
    Recovering(u64, u64),
}

struct Drive {
    phase: Phase,
    mode: i8,
    target_rev_s: f64,
    expected_emcy: Option<u16>,
}

/// The upper bound (ns) of the log2 bucket below which `share` of the histogram's counts lie.
fn quantile_bound(histogram: &[u64], share: f64) -> u64 {
    let total: u64 = histogram.iter().sum();
    let mut seen = 0;
    for (bucket, &n) in histogram.iter().enumerate() {
        seen += n;
        if seen as f64 >= share * total as f64 {
            return 1u64 << bucket.min(63);
        }
    }
    0
}

#[derive(Default)]
struct Report {
    cycles: u64,
    seed: u64,
    cycle_ns: u64,
    unexplained: Vec<String>,
    injected: u64,
    recovered: u64,
    sdos: u64,
    emergencies: u64,
    mode_changes: u64,
    rss_kib: Vec<(u64, u64)>,
    calc_and_copy_ns: Vec<u32>,
    max_cycle_host_ns: Vec<u64>,
    max_event_host_ns: Vec<u64>,
    /// All drives' cycle host times, log2 buckets (`SimDrive::cycle_host_histogram`).
    cycle_histogram: Vec<u64>,
    wall_s: f64,
}

fn rss_kib() -> u64 {
    std::fs::read_to_string("/proc/self/statm")
        .ok()
        .and_then(|s| {
            s.split_whitespace()
                .nth(1)
                .and_then(|v| v.parse::<u64>().ok())
        })
        .map_or(0, |pages| pages * 4)
}

fn fault_codes(profile: &od_gen::Profile, key: &str) -> (u16, u16) {
    let i = MOTOR_FAULT_NAMES
        .iter()
        .position(|k| *k == key)
        .unwrap_or_else(|| panic!("no motor fault {key}"));
    let f = &profile.motor_faults[i];
    (f.error_code, f.emcy.code)
}

fn inject(m: &InProcess, drive: usize, key: &str, on: bool) {
    use board_sim::plant::EncoderFaultInjection;
    let mut segment = m.shared.segment();
    let servo = &mut segment.drives_mut()[drive].servos[0];
    let protection = servo.axis.config().protection;
    let nominal_v = servo.plant.config().inverter.bus_voltage_v;
    let plant = &mut servo.plant;
    match (key, on) {
        ("bus_over_voltage", true) => {
            plant.set_bus_voltage(f64::from(protection.bus_over_voltage_v) + 5.0)
        }
        ("bus_over_voltage", false) => plant.set_bus_voltage(nominal_v),
        ("drive_over_temperature", true) => {
            plant.set_drive_temperature(f64::from(protection.drive_over_temperature_c) + 10.0)
        }
        ("drive_over_temperature", false) => {
            plant.set_drive_temperature(f64::from(protection.drive_over_temperature_c) - 40.0)
        }
        ("encoder_crc", on) => {
            plant.set_encoder_fault(on.then_some(EncoderFaultInjection::CrcErrors))
        }
        _ => {}
    }
}

/// An emergency waiting in drive `station`'s SM1, if any: its code.
async fn poll_emcy(
    md: &MainDevice<'_>,
    station: u16,
    (sm1, sm1_last): (u16, u16),
) -> Result<Option<u16>, String> {
    const SM1_STATUS: u16 = 0x0805 + 8;
    let status: u8 = Command::fprd(station, SM1_STATUS)
        .receive(md)
        .await
        .map_err(|e| format!("SM1 status: {e:?}"))?;
    if status & 0x08 == 0 {
        return Ok(None);
    }
    let mb: [u8; 16] = Command::fprd(station, sm1)
        .receive(md)
        .await
        .map_err(|e| format!("SM1: {e:?}"))?;
    // Reading the first bytes leaves the mailbox full: read its last byte too.
    let _: u8 = Command::fprd(station, sm1_last)
        .receive(md)
        .await
        .map_err(|e| format!("SM1 end: {e:?}"))?;
    if mb[5] & 0x0F != 3 || mb[7] >> 4 != 1 {
        return Err(format!("unexpected mailbox {mb:02x?}"));
    }
    Ok(Some(u16::from_le_bytes([mb[8], mb[9]])))
}

async fn soak(cycles: u64, seed: u64) -> Result<Report, String> {
    let profile = od_gen::builtin(PROFILE).map_err(|e| e.to_string())?;
    let cycle_ns = u64::from(profile.sync.min_cycle_ns);
    let sm1 = profile.sm.mailbox_in.start;
    let sm1_last = sm1 + profile.sm.mailbox_in.length - 1;
    let mut report = Report {
        cycles,
        seed,
        cycle_ns,
        ..Report::default()
    };
    let started = std::time::Instant::now();
    let mut segment = Segment::new(PROFILE, DRIVES).map_err(|e| e.to_string())?;
    for drive in segment.drives_mut() {
        drive.measure_host_times = true;
    }
    let (m, transport) = master_for(segment);
    tokio::task::spawn_local(transport);
    let md: &MainDevice<'_> = &m.maindevice;
    let (outputs, inputs) = vendor::VELOCITY_MAPPING;
    let group: DcGroup = vendor::into_op_dc_mapped(&m, md, (&outputs, &inputs), cycle_ns).await;
    let mut rng = Rng(seed | 1);
    let mut drives: Vec<Drive> = (0..DRIVES)
        .map(|_| Drive {
            phase: Phase::Enabling(0),
            mode: MODES[0],
            target_rev_s: 0.0,
            expected_emcy: None,
        })
        .collect();
    let expected_wkc = 3 * DRIVES as u16;
    // OP is reached at the first SYNC0 after the start delay: cycle until then.
    let mut warm_up = 0;
    loop {
        let since = m.shared.clock().now();
        let r = group
            .tx_rx_dc(md)
            .await
            .map_err(|e| format!("warm-up: {e:?}"))?;
        m.shared.finish_cycle(since, cycle_ns);
        if r.all_op() {
            break;
        }
        warm_up += 1;
        if warm_up > WARM_UP_CYCLES {
            return Err(format!("not in OP after {WARM_UP_CYCLES} cycles"));
        }
    }
    for k in 0..cycles {
        let since = m.shared.clock().now();
        // Outputs.
        for (i, d) in drives.iter().enumerate() {
            let cw = match d.phase {
                Phase::Enabling(from) | Phase::Recovering(_, from) => {
                    let n = k.saturating_sub(from);
                    if matches!(d.phase, Phase::Recovering(..)) && n < 3 {
                        if n == 0 {
                            0
                        } else {
                            0x80
                        }
                    } else {
                        vendor::enable_sequence(usize::MAX)
                            .nth((n.saturating_sub(3)) as usize)
                            .unwrap_or(0x0F)
                    }
                }
                _ => vendor::ENABLE_OPERATION,
            };
            let target = units::target_velocity(&profile, d.target_rev_s);
            let [c0, c1] = cw.to_le_bytes();
            let [v0, v1, v2, v3] = target.to_le_bytes();
            let sd = group.subdevice(md, i).map_err(|e| format!("{e:?}"))?;
            sd.outputs_raw_mut()[..OUT_LEN].copy_from_slice(&[
                c0,
                c1,
                d.mode as u8,
                v0,
                v1,
                v2,
                v3,
            ]);
        }
        match group.tx_rx_dc(md).await {
            Ok(r) if r.working_counter != expected_wkc => report.unexplained.push(format!(
                "cycle {k}: working counter {} (expected {expected_wkc})",
                r.working_counter
            )),
            Ok(r) if !r.all_op() => report.unexplained.push(format!("cycle {k}: not all in OP")),
            Ok(_) => {}
            Err(e) => report.unexplained.push(format!("cycle {k}: tx/rx {e:?}")),
        }
        // Inputs and each drive's phase.
        for (i, d) in drives.iter_mut().enumerate() {
            let sd = group.subdevice(md, i).map_err(|e| format!("{e:?}"))?;
            let sw = vendor::u16_at(&sd.inputs_raw(), 0);
            let fault = cia402::is(sw, cia402::FAULT);
            let enabled = cia402::is(sw, cia402::OPERATION_ENABLED);
            match d.phase {
                Phase::Enabling(from) => {
                    if enabled {
                        d.phase = Phase::Running;
                    } else if k - from > RECOVER_WITHIN {
                        report
                            .unexplained
                            .push(format!("cycle {k}: drive {i} does not enable ({sw:#06x})"));
                        d.phase = Phase::Enabling(k);
                    }
                }
                Phase::Running => {
                    if fault {
                        report.unexplained.push(format!(
                            "cycle {k}: drive {i} in Fault without a cause ({sw:#06x})"
                        ));
                        d.phase = Phase::Recovering(k, k);
                    } else if rng.below(CHANGE_PERIOD) == 0 {
                        d.mode = MODES[rng.below(MODES.len() as u64) as usize];
                        d.target_rev_s = (rng.below(200) as f64 - 100.0) / 20.0;
                        report.mode_changes += 1;
                    }
                }
                Phase::Injected(f, at, seen) => {
                    if fault && !seen {
                        d.phase = Phase::Injected(f, at, true);
                        // The fault's emergency is in the mailbox by the time the statusword
                        // shows it (sent at the first ESC event after the cycle that raised it).
                        let (_, emcy) = fault_codes(&profile, INJECTIONS[f]);
                        match poll_emcy(md, 0x1000 + i as u16, (sm1, sm1_last)).await {
                            Ok(Some(code)) if code == emcy => {
                                report.emergencies += 1;
                                // Next: the error reset (0000h) once it is cleared.
                                d.expected_emcy = Some(0);
                            }
                            other => report.unexplained.push(format!(
                                "cycle {k}: drive {i} {} without its emergency {emcy:04X}h: {other:?}",
                                INJECTIONS[f]
                            )),
                        }
                        let sdo: u16 = sd
                            .sdo_read(0x603F, 0)
                            .await
                            .map_err(|e| format!("603Fh: {e:?}"))?;
                        report.sdos += 1;
                        let (code, _) = fault_codes(&profile, INJECTIONS[f]);
                        if sdo != code {
                            report.unexplained.push(format!("cycle {k}: drive {i} 603Fh {sdo:04X}h for {} (expected {code:04X}h)", INJECTIONS[f]));
                        }
                    } else if seen && k - at > 50 {
                        inject(&m, i, INJECTIONS[f], false);
                        d.phase = Phase::Recovering(k, k);
                        d.target_rev_s = 0.0;
                    } else if !seen && k - at > REPORT_WITHIN {
                        report.unexplained.push(format!(
                            "cycle {k}: drive {i} did not report {}",
                            INJECTIONS[f]
                        ));
                        inject(&m, i, INJECTIONS[f], false);
                        d.phase = Phase::Recovering(k, k);
                    }
                }
                Phase::Recovering(from, attempt) => {
                    if enabled {
                        report.recovered += 1;
                        d.phase = Phase::Running;
                    } else if k - from > RECOVER_WITHIN {
                        report
                            .unexplained
                            .push(format!("cycle {k}: drive {i} did not recover ({sw:#06x})"));
                        d.phase = Phase::Recovering(k, k);
                    } else if k - attempt > 500 {
                        // A master retries the reset.
                        d.phase = Phase::Recovering(from, k);
                    }
                }
            }
        }
        // A fault for a running drive.
        if k > 0 && k % FAULT_PERIOD == 0 {
            let i = rng.below(DRIVES as u64) as usize;
            if drives[i].phase == Phase::Running {
                let f = rng.below(INJECTIONS.len() as u64) as usize;
                inject(&m, i, INJECTIONS[f], true);
                drives[i].phase = Phase::Injected(f, k, false);
                report.injected += 1;
            }
        }
        // Emergencies: only the injected fault's, and the error reset after it.
        if k % EMCY_POLL_PERIOD == 0 {
            let i = (k / EMCY_POLL_PERIOD) as usize % DRIVES;
            match poll_emcy(md, 0x1000 + i as u16, (sm1, sm1_last)).await {
                Ok(Some(code)) => {
                    report.emergencies += 1;
                    let expected = drives[i].expected_emcy;
                    if Some(code) == expected {
                        drives[i].expected_emcy = None;
                    } else {
                        report.unexplained.push(format!(
                            "cycle {k}: drive {i} emergency {code:04X}h (expected {expected:04x?})"
                        ));
                    }
                }
                Ok(None) => {}
                Err(e) => report
                    .unexplained
                    .push(format!("cycle {k}: drive {i} mailbox: {e}")),
            }
        } else if k % SDO_PERIOD == 0 {
            // SDO traffic on a running drive: reads, and writes of valid values.
            let i = rng.below(DRIVES as u64) as usize;
            if drives[i].phase == Phase::Running && drives[i].expected_emcy.is_none() {
                let sd = group.subdevice(md, i).map_err(|e| format!("{e:?}"))?;
                let r = match rng.below(4) {
                    0 => sd.sdo_read::<i32>(0x6064, 0).await.map(|_| ()),
                    1 => sd.sdo_read::<u32>(0x1C32, 6).await.map(|_| ()),
                    2 => sd.sdo_read::<u8>(0x1001, 0).await.map(|_| ()),
                    _ => {
                        let acc = units::acceleration(&profile, 10.0 + rng.below(90) as f64);
                        sd.sdo_write(0x6083, 0, acc).await
                    }
                };
                report.sdos += 1;
                if let Err(e) = r {
                    report
                        .unexplained
                        .push(format!("cycle {k}: drive {i} SDO {e:?}"));
                }
            }
        }
        if k % (cycles / CHECKPOINTS).max(1) == 0 {
            report.rss_kib.push((k, rss_kib()));
        }
        m.shared.finish_cycle(since, cycle_ns);
    }
    report.rss_kib.push((cycles, rss_kib()));
    for i in 0..DRIVES {
        let sd = group.subdevice(md, i).map_err(|e| format!("{e:?}"))?;
        let t: u32 = sd
            .sdo_read(0x1C32, 6)
            .await
            .map_err(|e| format!("1C32h:06: {e:?}"))?;
        report.calc_and_copy_ns.push(t);
    }
    {
        let s = m.shared.segment();
        report.cycle_histogram = vec![0; 64];
        for d in s.drives() {
            for (sum, n) in report
                .cycle_histogram
                .iter_mut()
                .zip(d.cycle_host_histogram)
            {
                *sum += n;
            }
            report.max_cycle_host_ns.push(d.max_cycle_host_ns);
            report.max_event_host_ns.push(d.max_event_host_ns);
        }
    }
    report.wall_s = started.elapsed().as_secs_f64();

    Ok(report)
}

fn markdown(r: &Report) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# Soak report\n");
    let _ = writeln!(
        s,
        "Written by `tests-host/soak/run` (`soak --cycles {} --seed {}`) at revision `{}`.\n",
        r.cycles,
        r.seed,
        std::env::var("SOAK_REVISION").unwrap_or_else(|_| "unknown".into())
    );
    let _ = writeln!(s, "{DRIVES} `{PROFILE}` drives in one segment, ethercrab in process, DC SYNC0 at the profile's shortest cycle, {} ns, each drive turning its simulated 400 W servo in CSV or PV (mode and speed changed at random), SDO reads and writes at random, a fault injected on a random drive every {FAULT_PERIOD} cycles ({}), reported, cleared and recovered from.\n", r.cycle_ns, INJECTIONS.join(", "));
    let _ = writeln!(s, "| measure | value |\n|---|---|");
    let _ = writeln!(s, "| cycles | {} |", r.cycles);
    let _ = writeln!(
        s,
        "| **unexplained errors** | **{}** |",
        r.unexplained.len()
    );
    let _ = writeln!(
        s,
        "| faults injected / recovered from | {} / {} |",
        r.injected, r.recovered
    );
    let _ = writeln!(
        s,
        "| emergencies read (all explained) | {} |",
        r.emergencies
    );
    let _ = writeln!(s, "| SDO transfers | {} |", r.sdos);
    let _ = writeln!(s, "| mode and speed changes | {} |", r.mode_changes);
    let first = r.rss_kib.get(1).or(r.rss_kib.first()).map_or(0, |x| x.1);
    let max = r.rss_kib.iter().map(|x| x.1).max().unwrap_or(0);
    let last = r.rss_kib.last().map_or(0, |x| x.1);
    let _ = writeln!(
        s,
        "| process memory (RSS) after warm-up / max / at the end | {first} / {max} / {last} KiB |"
    );
    let _ = writeln!(s, "| 1C32h:06 calc and copy time, max since SAFE-OP (the firmware's own measure: modelled PDI bus time), per drive | {:?} ns |", r.calc_and_copy_ns);
    let _ = writeln!(s, "| longest firmware cycle handler on the host (`on_sync0` + `cycle_finished`), per drive | {:?} ns |", r.max_cycle_host_ns);
    let _ = writeln!(
        s,
        "| firmware cycle handler on the host, all drives: 99 % / 99.99 % of the cycles below | {} / {} ns |",
        quantile_bound(&r.cycle_histogram, 0.99),
        quantile_bound(&r.cycle_histogram, 0.9999)
    );
    let _ = writeln!(
        s,
        "| longest firmware ESC-event round on the host, per drive | {:?} ns |",
        r.max_event_host_ns
    );
    let _ = writeln!(s, "| wall time | {:.1} s |", r.wall_s);
    let _ = writeln!(s, "\nHost times are wall-clock times of the firmware's handlers in the simulation on this machine: the longest include the operating system's preemptions (the quantiles show the typical handler); the MCU's figures are the QEMU instruction counts of `benchmarks/REPORT.md`. The firmware's own 1C32h:06 reports the modelled PDI bus time of the cycle.");
    let _ = writeln!(
        s,
        "\nMemory checkpoints (cycle: RSS KiB): {}",
        r.rss_kib
            .iter()
            .map(|(k, v)| format!("{k}: {v}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    if !r.unexplained.is_empty() {
        let _ = writeln!(s, "\n## Unexplained errors\n");
        for e in r.unexplained.iter().take(100) {
            let _ = writeln!(s, "- {e}");
        }
    }
    s
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut cycles = 1_000_000u64;
    let mut seed = 1u64;
    let mut out = None;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let value = it.next();
        let parsed = match (a.as_str(), value) {
            ("--cycles", Some(v)) => v.parse().ok().filter(|&n| n > 0).map(|n| cycles = n),
            ("--seed", Some(v)) => v.parse().ok().map(|n| seed = n),
            ("--report", Some(v)) => {
                out = Some(v.clone());
                Some(())
            }
            _ => None,
        };
        if parsed.is_none() {
            eprintln!("usage: soak [--cycles N (>0)] [--seed S] [--report FILE]");
            return ExitCode::from(2);
        }
    }
    let report = match block_on(soak(cycles, seed)) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("soak: {e}");
            return ExitCode::FAILURE;
        }
    };
    let text = markdown(&report);
    print!("{text}");
    if let Some(path) = out {
        if let Err(e) = std::fs::write(&path, &text) {
            eprintln!("soak: {path}: {e}");
            return ExitCode::FAILURE;
        }
    }
    if report.unexplained.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}
