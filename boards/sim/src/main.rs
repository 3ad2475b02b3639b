//! `sim-drive`: the simulated EtherCAT servo drive on a PC.
//!
//! ```text
//! sim-drive [tour] [--plot FILE]
//!     the guided tour (the default): one standard drive on a machine with a home switch,
//!     homed, moved in profile position, then streamed in cyclic synchronous position by the
//!     built-in ethercrab master; prints every statusword change and writes a plot of position,
//!     speed and current (default target/sim-drive/tour.svg)
//! sim-drive demo [LINE] [--cycle-us US] [--cycles N] [--free-run] [--plant F] [--threads N]
//!     run the drive(s) with the built-in ethercrab master: INIT → OP with DC SYNC0, cyclic
//!     exchange, back to INIT, and print what happened (with the real-time factor of the
//!     cyclic exchange); US may have up to three decimals (31.25) and must be a cycle every
//!     drive of the line accepts (its profile's DC or free-run range, step and fixed cycles:
//!     the error says which)
//! sim-drive attach --iface IFNAME [LINE] [--seconds S] [--plant F] [--threads N] [FAULTS] [MACHINE]
//!     attach the drive(s) to a network interface with a raw socket so that any external
//!     master (TwinCAT, SOEM, IgH, ethercrab) can drive them
//! sim-drive list-profiles
//!     print the names of the built-in profiles
//! sim-drive plots [--out DIR]
//!     measure the motor control on the simulated servo (current-loop frequency response,
//!     speed step, load step, S-curve following error) and write the plots as SVG
//!     (default directory: docs/plots)
//!
//! LINE, the drives in ring order (default: one drive of the standard profile), either
//!     [--profile NAME] [--drives N]      N drives (default 1) of one profile, or
//!     --drive NAME [--drive NAME ...]    one drive per --drive, profiles mixed in that order
//!
//! --threads N (demo, attach): the simulation of the line may use N threads (default: 1 for
//!     demo, every core for attach); each thread gets at least 4 drives
//!
//! --plant F, how finely every drive's plant resolves its inverter:
//!     pwm (the default)                  every PWM period in 20 substeps: current ripple,
//!                                        dead time within the period
//!     averaged                           one step per PWM period with the period's average
//!                                        voltages: no ripple, a fraction of the cost
//!
//! MACHINE, switches around the motor of every axis (in motor revolutions; the rotor starts at 0):
//!     --home-switch-rev X                a home switch, active from X revolutions upward
//!     --limit-switches-rev N,P           limit switches, negative active at or below N,
//!                                        positive at or above P (N < 0 < P)
//! FAULTS (attach), for a master's error handling:
//!     --lose-every N                     every N-th cyclic (process-data) frame is lost
//!     --pull-cable-at-ms T --pull-cable-for-ms D
//!                                        the cable to the first drive is pulled T ms after the
//!                                        start for D ms (the interface going down does the same)
//!     --drop-mailbox-read K              the reply to the K-th mailbox read is lost
//!     --halt-mcu-at-ms T --halt-mcu-for-ms D
//!                                        the first drive's MCU stops T ms after the start for
//!                                        D ms, then restarts with its ESC as it was
//! ```
//!
//! Profile names are the built-in profiles of `list-profiles` (`sdv3-e` and `sdv3_e` are the
//! same). An unknown profile, `--drive` together with `--profile`/`--drives`, or any other
//! usage error exits with code 2.

use std::f64::consts::TAU;
use std::process::ExitCode;
use std::time::Duration;

use board_sim::demo::{self, Scenario};
use board_sim::plant::{Fidelity, SwitchParams};
use board_sim::{rawsock, Segment};

const USAGE: &str = "usage: sim-drive [tour] [--plot FILE]
       sim-drive demo [LINE] [--cycle-us US] [--cycles N] [--free-run] [--plant F] [--threads N]
       sim-drive attach --iface IFNAME [LINE] [--seconds S] [--plant F] [--threads N] [FAULTS] [MACHINE]
       sim-drive list-profiles
       sim-drive plots [--out DIR]
LINE (the drives in ring order; default one standard drive):
       [--profile NAME] [--drives N]     N drives of one profile
       --drive NAME [--drive NAME ...]   one drive per --drive, in that order (profiles may differ)
--threads N (demo, attach): threads for the simulation of the line (default: demo 1, attach
       every core; at least 4 drives per thread)
--plant F (demo, attach): the plant's fidelity, `pwm` (the default: every PWM period in 20
       substeps) or `averaged` (one step per PWM period with its average voltages)
MACHINE (attach; switches around every axis's motor, in revolutions, the rotor starting at 0):
       --home-switch-rev X               a home switch, active from X revolutions upward
       --limit-switches-rev N,P          limits: negative at or below N, positive at or above P,
                                         N < 0 < P
FAULTS (attach; what a master developer tests their error handling with):
       --lose-every N                    every N-th cyclic (process-data) frame is lost on the cable
       --pull-cable-at-ms T --pull-cable-for-ms D
                                         the cable to the first drive is pulled T ms after the
                                         start for D ms (no frame passes, no link on its port 0;
                                         taking the interface down does the same)
       --drop-mailbox-read K             the reply to the K-th mailbox read is lost
       --halt-mcu-at-ms T --halt-mcu-for-ms D
                                         the first drive's MCU stops T ms after the start for
                                         D ms (bridge off, the ESC's PDI watchdog runs out after
                                         100 ms), then restarts with its ESC as it was (INIT,
                                         AL status code 0x0060 \"slave restarted locally\")";

struct Args {
    command: String,
    /// Profile of every drive, in ring order (canonical names, as `list-profiles` prints them).
    line: Vec<String>,
    /// `--cycle-us` in ns.
    cycle_ns: u64,
    cycles: u32,
    iface: Option<String>,
    seconds: Option<u64>,
    free_run: bool,
    drop_mailbox_read: Option<u32>,
    /// `--lose-every N`.
    lose_every: Option<u32>,
    /// `--pull-cable-at-ms` and `--pull-cable-for-ms`.
    pull_cable_at_ms: Option<u64>,
    pull_cable_for_ms: Option<u64>,
    /// `--halt-mcu-at-ms` and `--halt-mcu-for-ms`.
    halt_mcu_at_ms: Option<u64>,
    halt_mcu_for_ms: Option<u64>,
    out: String,
    plot: String,
    /// A LINE option was given.
    line_given: bool,
    /// `--home-switch-rev`: where the home switch becomes active, in revolutions.
    home_switch_rev: Option<f64>,
    /// `--limit-switches-rev`: the negative and positive limit switches, in revolutions.
    limit_switches_rev: Option<(f64, f64)>,
    /// `--plant`: the fidelity of every drive's plant.
    plant: Fidelity,
    /// `--plant` was given.
    plant_given: bool,
    /// `--threads`, if given.
    threads: Option<usize>,
}

fn parse(mut it: impl Iterator<Item = String>) -> Result<Args, String> {
    let mut a = Args {
        command: "tour".into(),
        line: Vec::new(),
        cycle_ns: 1_000_000,
        cycles: 1000,
        iface: None,
        seconds: None,
        free_run: false,
        drop_mailbox_read: None,
        lose_every: None,
        pull_cable_at_ms: None,
        pull_cable_for_ms: None,
        halt_mcu_at_ms: None,
        halt_mcu_for_ms: None,
        out: "docs/plots".into(),
        plot: "target/sim-drive/tour.svg".into(),
        line_given: false,
        home_switch_rev: None,
        limit_switches_rev: None,
        plant: Fidelity::default(),
        plant_given: false,
        threads: None,
    };
    let mut profile: Option<String> = None;
    let mut drives: Option<usize> = None;
    let mut line: Vec<String> = Vec::new();
    let mut first = true;
    while let Some(arg) = it.next() {
        let mut value = |name: &str| it.next().ok_or_else(|| format!("{name} needs a value"));
        match arg.as_str() {
            "tour" | "demo" | "attach" | "list-profiles" | "plots" if first => {
                a.command = arg.clone()
            }
            "--out" => a.out = value("--out")?,
            "--plot" => a.plot = value("--plot")?,
            "--profile" => profile = Some(value("--profile")?),
            "--drives" => drives = Some(number(&value("--drives")?, "--drives")?),
            "--drive" => line.push(value("--drive")?),
            "--cycle-us" => a.cycle_ns = microseconds(&value("--cycle-us")?, "--cycle-us")?,
            "--cycles" => a.cycles = number(&value("--cycles")?, "--cycles")?,
            "--iface" => a.iface = Some(value("--iface")?),
            "--free-run" => a.free_run = true,
            "--threads" => {
                let n = number(&value("--threads")?, "--threads")?;
                if n == 0 {
                    return Err("--threads must be at least 1".into());
                }
                a.threads = Some(n);
            }
            "--plant" => {
                let name = value("--plant")?;
                a.plant = Fidelity::by_name(&name).ok_or_else(|| {
                    let names: Vec<&str> = Fidelity::NAMES.iter().map(|(n, _)| *n).collect();
                    format!("--plant {name:?}: the plant is one of {}", names.join(", "))
                })?;
                a.plant_given = true;
            }
            "--drop-mailbox-read" => {
                a.drop_mailbox_read = Some(number(
                    &value("--drop-mailbox-read")?,
                    "--drop-mailbox-read",
                )?)
            }
            "--seconds" => a.seconds = Some(number(&value("--seconds")?, "--seconds")?),
            "--lose-every" => a.lose_every = Some(number(&value("--lose-every")?, "--lose-every")?),
            "--pull-cable-at-ms" => {
                a.pull_cable_at_ms =
                    Some(number(&value("--pull-cable-at-ms")?, "--pull-cable-at-ms")?)
            }
            "--pull-cable-for-ms" => {
                a.pull_cable_for_ms = Some(number(
                    &value("--pull-cable-for-ms")?,
                    "--pull-cable-for-ms",
                )?)
            }
            "--halt-mcu-at-ms" => {
                a.halt_mcu_at_ms = Some(number(&value("--halt-mcu-at-ms")?, "--halt-mcu-at-ms")?)
            }
            "--halt-mcu-for-ms" => {
                a.halt_mcu_for_ms = Some(number(&value("--halt-mcu-for-ms")?, "--halt-mcu-for-ms")?)
            }
            "--home-switch-rev" => {
                a.home_switch_rev = Some(revolutions(
                    &value("--home-switch-rev")?,
                    "--home-switch-rev",
                )?)
            }
            "--limit-switches-rev" => {
                a.limit_switches_rev = Some(limit_switches(&value("--limit-switches-rev")?)?)
            }
            "-h" | "--help" => return Err(String::new()),
            other => return Err(format!("unknown argument {other:?}")),
        }
        first = false;
    }
    a.line_given = profile.is_some() || drives.is_some() || !line.is_empty();
    a.line = if line.is_empty() {
        let drives = drives.unwrap_or(1);
        if drives == 0 || drives > demo::MAX_DRIVES {
            return Err(format!("--drives must be 1..={}", demo::MAX_DRIVES));
        }
        vec![profile.unwrap_or_else(|| "standard".into()); drives]
    } else if profile.is_some() || drives.is_some() {
        return Err(
            "--drive cannot be combined with --profile or --drives: give either \
                    --drive NAME once per drive (mixed line), or --profile NAME --drives N"
                .into(),
        );
    } else if line.len() > demo::MAX_DRIVES {
        return Err(format!(
            "{} drives given with --drive, at most {} supported",
            line.len(),
            demo::MAX_DRIVES
        ));
    } else {
        line
    };
    for name in &mut a.line {
        *name = canonical_profile(name)?;
    }
    if a.command == "demo" {
        // Every drive must accept the cycle before anything starts.
        for name in &a.line {
            demo::check_cycle(name, a.cycle_ns, !a.free_run)
                .map_err(|e| format!("--cycle-us: {e}"))?;
        }
        if a.cycles == 0 {
            return Err("--cycles must be at least 1".into());
        }
    }
    if a.command == "attach" {
        match a.iface.as_deref() {
            None => return Err("attach needs --iface IFNAME".into()),
            // Linux interface names: 1..=15 bytes, no '/' or white space (IFNAMSIZ).
            Some(i) if i.is_empty() || i.len() > 15 || i.contains(['/', ' ', '\t', '\n']) => {
                return Err(format!("--iface {i:?} is not a network interface name"))
            }
            Some(_) => {}
        }
    }
    let injects = a.drop_mailbox_read.is_some()
        || a.lose_every.is_some()
        || a.pull_cable_at_ms.is_some()
        || a.pull_cable_for_ms.is_some()
        || a.halt_mcu_at_ms.is_some()
        || a.halt_mcu_for_ms.is_some();
    if a.command != "attach" && injects {
        return Err("fault injection (--drop-mailbox-read, --lose-every, --pull-cable-*, --halt-mcu-*) is an option of `attach`".into());
    }
    if a.lose_every == Some(0) {
        return Err("--lose-every must be at least 1 (1 loses every cyclic frame)".into());
    }
    match (a.pull_cable_at_ms, a.pull_cable_for_ms) {
        (Some(_), Some(0)) => return Err("--pull-cable-for-ms must be at least 1".into()),
        (Some(_), None) | (None, Some(_)) => {
            return Err("--pull-cable-at-ms and --pull-cable-for-ms go together".into())
        }
        _ => {}
    }
    match (a.halt_mcu_at_ms, a.halt_mcu_for_ms) {
        (Some(_), Some(0)) => return Err("--halt-mcu-for-ms must be at least 1".into()),
        (Some(_), None) | (None, Some(_)) => {
            return Err("--halt-mcu-at-ms and --halt-mcu-for-ms go together".into())
        }
        _ => {}
    }
    if a.plant_given && a.command != "demo" && a.command != "attach" {
        return Err("--plant is an option of `demo` and `attach`".into());
    }
    if a.threads.is_some() && a.command != "demo" && a.command != "attach" {
        return Err("--threads is an option of `demo` and `attach`".into());
    }
    if a.command != "attach" && a.machine().is_some() {
        return Err("--home-switch-rev and --limit-switches-rev are options of `attach`".into());
    }
    if a.command == "tour" && a.line_given {
        return Err(
            "the tour runs one standard drive; for other profiles or lines use `demo` with              --profile / --drives / --drive"
                .into(),
        );
    }
    Ok(a)
}

/// The built-in profile `name` as od-gen spells it (`sdv3_e` → `sdv3-e`), or an error naming
/// the available profiles.
fn canonical_profile(name: &str) -> Result<String, String> {
    let names = od_gen::builtin_names();
    match names.iter().find(|n| od_gen::same_name(n, name)) {
        Some(n) if firmware::profiles::by_name(n).is_some() => Ok(n.to_string()),
        _ => Err(format!(
            "unknown profile {name:?}; available profiles: {}",
            names.join(", ")
        )),
    }
}

/// A duration in µs with up to three decimals (`31.25`), in ns.
fn microseconds(s: &str, name: &str) -> Result<u64, String> {
    let bad = || format!("{name}: {s:?} is not a number of µs (up to three decimals, e.g. 31.25)");
    let (whole, fraction) = s.split_once('.').unwrap_or((s, ""));
    if whole.is_empty()
        || fraction.len() > 3
        || !whole
            .bytes()
            .chain(fraction.bytes())
            .all(|b| b.is_ascii_digit())
    {
        return Err(bad());
    }
    let whole: u64 = whole.parse().map_err(|_| bad())?;
    let fraction: u64 = format!("{fraction:0<3}").parse().map_err(|_| bad())?;
    whole
        .checked_mul(1_000)
        .and_then(|ns| ns.checked_add(fraction))
        .ok_or_else(|| format!("{name}: {s} µs is out of range"))
}

fn number<T: std::str::FromStr>(s: &str, name: &str) -> Result<T, String> {
    s.parse()
        .map_err(|_| format!("{name}: {s:?} is not a valid number"))
}

/// A finite number of revolutions.
fn revolutions(s: &str, name: &str) -> Result<f64, String> {
    let x: f64 = number(s, name)?;
    if x.is_finite() {
        Ok(x)
    } else {
        Err(format!(
            "{name}: {s:?} is not a finite number of revolutions"
        ))
    }
}

/// `N,P` of `--limit-switches-rev`: the negative limit below the rotor's start at 0, the positive
/// one above it.
fn limit_switches(s: &str) -> Result<(f64, f64), String> {
    const NAME: &str = "--limit-switches-rev";
    let (n, p) = s
        .split_once(',')
        .ok_or_else(|| format!("{NAME}: {s:?} is not N,P (two revolutions, e.g. -3,3)"))?;
    let (n, p) = (revolutions(n.trim(), NAME)?, revolutions(p.trim(), NAME)?);
    if n < 0.0 && p > 0.0 {
        Ok((n, p))
    } else {
        Err(format!(
            "{NAME}: {s:?} must have N < 0 < P (the rotor starts at 0 between the limits)"
        ))
    }
}

impl Args {
    /// The switches of the MACHINE options, `None` when none was given.
    fn machine(&self) -> Option<SwitchParams> {
        if self.home_switch_rev.is_none() && self.limit_switches_rev.is_none() {
            return None;
        }
        Some(SwitchParams {
            limit_neg_rad: self.limit_switches_rev.map(|(n, _)| n * TAU),
            limit_pos_rad: self.limit_switches_rev.map(|(_, p)| p * TAU),
            home_rad: self.home_switch_rev.map(|x| x * TAU),
            ..SwitchParams::default()
        })
    }
}

fn main() -> ExitCode {
    let args = match parse(std::env::args().skip(1)) {
        Ok(a) => a,
        Err(msg) => {
            if !msg.is_empty() {
                eprintln!("sim-drive: {msg}");
            }
            eprintln!("{USAGE}");
            return if msg.is_empty() {
                ExitCode::SUCCESS
            } else {
                ExitCode::from(2)
            };
        }
    };
    let result = match args.command.as_str() {
        "list-profiles" => {
            for name in od_gen::builtin_names() {
                println!("{name}");
            }
            Ok(())
        }
        "attach" => attach(&args),
        "plots" => plots(&args),
        "demo" => run_demo(&args),
        _ => run_tour(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("sim-drive: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run_tour(args: &Args) -> Result<(), Box<dyn std::error::Error>> {
    println!(
        "sim-drive tour: one simulated standard drive (400 W servo on a machine with a home \
         switch), built-in ethercrab master"
    );
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_time()
        .build()?;
    let local = tokio::task::LocalSet::new();
    let path = std::path::Path::new(&args.plot);
    let report = local.block_on(&rt, async {
        board_sim::tour::run("standard", path, &mut |line| println!("{line}")).await
    })?;
    println!(
        "done: {:.1} s simulated; plot of position, speed and current: {}",
        report.samples.last().map_or(0.0, |s| s.t_s),
        path.display()
    );
    println!(
        "(more: `sim-drive demo --drives 3`, `sim-drive attach --iface IF`, `sim-drive --help`)"
    );
    Ok(())
}

fn plots(args: &Args) -> Result<(), Box<dyn std::error::Error>> {
    let dir = std::path::Path::new(&args.out);
    for file in
        board_sim::experiments::write_plots(dir).map_err(|e| format!("{}: {e}", dir.display()))?
    {
        println!("{}", file.display());
    }
    Ok(())
}

fn attach(args: &Args) -> Result<(), Box<dyn std::error::Error>> {
    // `parse` made sure it is there.
    let iface = args.iface.as_deref().unwrap_or_default();
    let mut segment = Segment::line_with_plant(&args.line, args.plant)?;
    segment.set_threads(args.threads.unwrap_or_else(|| {
        std::thread::available_parallelism().map_or(1, std::num::NonZeroUsize::get)
    }))?;
    if let Some(switches) = args.machine() {
        for servo in segment
            .drives_mut()
            .iter_mut()
            .flat_map(|d| d.servos.iter_mut())
        {
            servo.plant.set_switches(switches);
        }
    }
    let faults = rawsock::Faults {
        drop_mailbox_read: args.drop_mailbox_read,
        lose_every: args.lose_every,
        cable_out: args
            .pull_cable_at_ms
            .zip(args.pull_cable_for_ms)
            .map(|(at, long)| (Duration::from_millis(at), Duration::from_millis(long))),
        mcu_halt: args
            .halt_mcu_at_ms
            .zip(args.halt_mcu_for_ms)
            .map(|(at, long)| (Duration::from_millis(at), Duration::from_millis(long))),
    };
    rawsock::serve_with_faults(segment, iface, args.seconds.map(Duration::from_secs), faults)
        .map_err(|e| format!("{iface}: {e} (a raw socket needs CAP_NET_RAW, e.g. run inside `unshare --user --map-root-user --net`)"))?;
    Ok(())
}

fn run_demo(args: &Args) -> Result<(), Box<dyn std::error::Error>> {
    let scenario = Scenario {
        profile: args.line[0].clone(),
        drives: args.line.len(),
        cycle: Duration::from_nanos(args.cycle_ns),
        cycles: args.cycles,
        dc: !args.free_run,
        plant: args.plant,
        threads: args.threads.unwrap_or(1),
    };
    println!(
        "sim-drive demo: {} simulated drive(s) [{}], built-in ethercrab master, {} cycle {} µs, {} plant",
        args.line.len(),
        args.line.join(", "),
        if scenario.dc { "DC SYNC0" } else { "free-run" },
        args.cycle_ns as f64 / 1e3,
        args.plant.name()
    );
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_time()
        .build()?;
    let local = tokio::task::LocalSet::new();
    let report = local.block_on(&rt, async {
        demo::run_line(&args.line, &scenario, &mut |line| println!("{line}")).await
    })?;
    println!(
        "done: {} frames, {:.1} ms simulated, firmware cycles per drive {:?}",
        report.frames,
        report.sim_time_ns as f64 / 1e6,
        report.firmware_cycles
    );
    if let Some(factor) = report.real_time_factor() {
        // The line's speed on this host, start-up excluded: above 1 it keeps up with a real
        // master's clock (`attach`), below it would fall behind.
        println!(
            "cyclic exchange: {:.1} ms simulated in {:.1} ms of host time, {factor:.2} × real time",
            report.cyclic_sim_ns as f64 / 1e6,
            report.cyclic_wall.as_secs_f64() * 1e3
        );
    }
    if report.wkc_errors > 0 {
        return Err(format!("{} cycles had a wrong working counter", report.wkc_errors).into());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(s: &str) -> Result<Args, String> {
        parse(s.split_whitespace().map(String::from))
    }

    /// The error of `s`, which must be refused.
    fn refused(s: &str) -> String {
        match args(s) {
            Ok(_) => panic!("{s:?} was accepted"),
            Err(e) => e,
        }
    }

    #[test]
    fn demo_cycles_outside_the_profiles_dc_range_or_step_are_refused_before_anything_starts() {
        // The standard profile: DC SYNC0 31.25 µs .. 10 ms in steps of 31.25 µs (its [sync]).
        for bad in ["0", "1", "40", "31.2", "10031.25", "18446744073709551"] {
            let e = refused(&format!("demo --cycle-us {bad}"));
            assert!(
                e.contains("standard profile accepts DC SYNC0 cycles of 31.25 to 10000 µs in steps of 31.25 µs"),
                "{bad}: {e}"
            );
        }
        for good in ["31.25", "62.5", "1000", "10000"] {
            args(&format!("demo --cycle-us {good}")).unwrap_or_else(|e| panic!("{good}: {e}"));
        }
        assert_eq!(
            args("demo --cycle-us 31.25").expect("31.25").cycle_ns,
            31_250
        );
        let e = refused("demo --cycle-us 18446744073709551615");
        assert!(e.contains("out of range"), "{e}");
        // The GHA-E accepts five cycles only (§3.3); every drive of a mixed line is checked.
        let e = refused("demo --drive standard --drive gha-e --cycle-us 312.5");
        assert!(
            e.contains(
                "gha-e profile accepts DC SYNC0 cycles of 125, 250, 500, 1000, 2000 µs only"
            ),
            "{e}"
        );
    }

    #[test]
    fn free_run_cycles_are_checked_against_the_free_run_range() {
        let e = refused("demo --free-run --cycle-us 0");
        assert!(e.contains("free-run cycles of 31.25 to 10000 µs"), "{e}");
        // The SDV3-E runs free only at 1 ms .. 10 ms (its [sync] free-run range).
        let e = refused("demo --profile sdv3-e --free-run --cycle-us 500");
        assert!(
            e.contains("sdv3-e profile accepts free-run cycles of 1000 to 10000 µs"),
            "{e}"
        );
        args("demo --profile sdv3-e --free-run --cycle-us 2000").expect("2 ms");
    }

    #[test]
    fn the_plant_fidelity_is_named_and_only_for_demo_and_attach() {
        assert_eq!(args("demo").expect("demo").plant, Fidelity::PwmResolved);
        assert_eq!(
            args("demo --plant averaged").expect("averaged").plant,
            Fidelity::Averaged
        );
        assert_eq!(
            args("attach --iface veth0 --plant pwm").expect("pwm").plant,
            Fidelity::PwmResolved
        );
        let e = refused("demo --plant exact");
        assert!(e.contains("the plant is one of pwm, averaged"), "{e}");
        assert!(refused("demo --plant").contains("--plant needs a value"));
        assert!(refused("tour --plant averaged")
            .contains("--plant is an option of `demo` and `attach`"));
    }

    #[test]
    fn malformed_numbers_zero_cycles_and_a_missing_interface_are_usage_errors() {
        for bad in ["1e3", "-5", "31.2500", ".5", "0x10", ""] {
            let e = microseconds(bad, "--cycle-us").err();
            assert!(
                e.is_some_and(|e| e.contains("is not a number of µs")),
                "{bad:?}"
            );
        }
        assert_eq!(
            microseconds("5.", "x"),
            Ok(5_000),
            "a trailing point is a whole number"
        );
        assert!(refused("demo --cycles 0").contains("--cycles must be at least 1"));
        assert!(refused("attach").contains("attach needs --iface"));
        assert!(refused("attach --iface a/b").contains("not a network interface name"));
        assert!(refused("attach --iface 0123456789abcdef").contains("not a network interface name"));
    }

    #[test]
    fn drive_builds_a_mixed_line_in_order() {
        let a = args("attach --iface veth0 --drive sdv3-e --drive rse --drive sigma_v_sd_2axis")
            .expect("mixed line");
        assert_eq!(a.command, "attach");
        assert_eq!(a.line, ["sdv3-e", "rse", "sigma-v-sd-2axis"]);
    }

    #[test]
    fn the_tour_is_the_default_and_runs_the_standard_drive_only() {
        let a = args("").expect("no arguments");
        assert_eq!(
            (a.command.as_str(), a.plot.as_str()),
            ("tour", "target/sim-drive/tour.svg")
        );
        assert_eq!(args("tour --plot x.svg").expect("plot").plot, "x.svg");
        let e = args("--drives 3").err().expect("a line without `demo`");
        assert!(e.contains("use `demo`"), "{e}");
    }

    #[test]
    fn profile_and_drives_still_give_n_drives_of_one_profile() {
        assert_eq!(args("demo").expect("default").line, ["standard"]);
        assert_eq!(
            args("demo --profile gha_e --drives 2").expect("two").line,
            ["gha-e", "gha-e"]
        );
    }

    #[test]
    fn fault_injection_flags_belong_to_attach_and_are_range_checked() {
        let a = args(
            "attach --iface veth0 --lose-every 10 --pull-cable-at-ms 5000 --pull-cable-for-ms 200",
        )
        .expect("valid");
        assert_eq!(a.lose_every, Some(10));
        assert_eq!(
            (a.pull_cable_at_ms, a.pull_cable_for_ms),
            (Some(5000), Some(200))
        );
        let e = refused("demo --lose-every 10");
        assert!(e.contains("option of `attach`"), "{e}");
        let e = refused("attach --iface veth0 --lose-every 0");
        assert!(e.contains("at least 1"), "{e}");
        let e = refused("attach --iface veth0 --pull-cable-at-ms 5");
        assert!(e.contains("go together"), "{e}");
        let e = refused("attach --iface veth0 --pull-cable-at-ms 5 --pull-cable-for-ms 0");
        assert!(e.contains("at least 1"), "{e}");
        let e = refused("attach --iface veth0 --lose-every x");
        assert!(e.contains("--lose-every"), "{e}");
        let a = args("attach --iface veth0 --halt-mcu-at-ms 3000 --halt-mcu-for-ms 300")
            .expect("valid");
        assert_eq!(
            (a.halt_mcu_at_ms, a.halt_mcu_for_ms),
            (Some(3000), Some(300))
        );
        let e = refused("demo --halt-mcu-at-ms 1 --halt-mcu-for-ms 1");
        assert!(e.contains("option of `attach`"), "{e}");
        let e = refused("attach --iface veth0 --halt-mcu-for-ms 300");
        assert!(e.contains("go together"), "{e}");
        let e = refused("attach --iface veth0 --halt-mcu-at-ms 5 --halt-mcu-for-ms 0");
        assert!(e.contains("at least 1"), "{e}");
    }

    #[test]
    fn mixing_drive_with_profile_or_drives_is_refused() {
        for bad in [
            "demo --drive rse --profile rse",
            "demo --drives 2 --drive rse",
        ] {
            let e = args(bad).err().expect(bad);
            assert!(e.contains("--drive cannot be combined"), "{bad}: {e}");
        }
    }

    #[test]
    fn unknown_profile_lists_the_available_ones() {
        for bad in ["demo --drive nope", "demo --profile nope"] {
            let e = args(bad).err().expect(bad);
            assert!(e.contains("\"nope\""), "{e}");
            for name in od_gen::builtin_names() {
                assert!(e.contains(name), "{e} lacks {name}");
            }
        }
    }

    #[test]
    fn attach_places_home_and_limit_switches_in_revolutions() {
        let a = args("attach --iface e --home-switch-rev 0.4 --limit-switches-rev -0.7,3")
            .expect("machine");
        let sw = a.machine().expect("switches");
        assert_eq!(sw.home_rad, Some(0.4 * TAU));
        assert_eq!(
            (sw.limit_neg_rad, sw.limit_pos_rad),
            (Some(-0.7 * TAU), Some(3.0 * TAU))
        );
        assert_eq!(sw.home_end_rad, None);
        assert!(args("attach --iface e").expect("bare").machine().is_none());
    }

    #[test]
    fn bad_switch_positions_are_usage_errors() {
        for (bad, says) in [
            ("attach --home-switch-rev x", "not a valid number"),
            ("attach --home-switch-rev NaN", "not a finite number"),
            ("attach --home-switch-rev", "needs a value"),
            ("attach --limit-switches-rev 3", "is not N,P"),
            ("attach --limit-switches-rev 1,3", "N < 0 < P"),
            ("attach --limit-switches-rev -1,-0.5", "N < 0 < P"),
            ("attach --limit-switches-rev -1,inf", "not a finite number"),
            ("demo --home-switch-rev 0.4", "options of `attach`"),
            ("--limit-switches-rev -1,1", "options of `attach`"),
        ] {
            let e = args(bad).err().expect(bad);
            assert!(e.contains(says), "{bad}: {e}");
        }
    }

    #[test]
    fn line_length_is_bounded() {
        let many = "demo ".to_string() + &"--drive rse ".repeat(demo::MAX_DRIVES + 1);
        assert!(args(&many).is_err());
        assert!(args("demo --drives 0").is_err());
    }
}
