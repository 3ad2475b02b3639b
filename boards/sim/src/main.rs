//! `sim-drive`: the simulated EtherCAT servo drive on a PC.
//!
//! ```text
//! sim-drive [demo] [--profile NAME] [--drives N] [--cycle-us US] [--cycles N] [--free-run]
//!     run the drive(s) with the built-in ethercrab master: INIT → OP with DC SYNC0, cyclic
//!     exchange, back to INIT, and print what happened (the default)
//! sim-drive attach --iface IFNAME [--profile NAME] [--drives N] [--seconds S] [--drop-mailbox-read K]
//!     attach the drive(s) to a network interface with a raw socket so that any external
//!     master (TwinCAT, SOEM, IgH, ethercrab) can drive them
//! sim-drive list-profiles
//! sim-drive plots [--out DIR]
//!     measure the motor control on the simulated servo (current-loop frequency response,
//!     speed step, load step, S-curve following error) and write the plots as SVG
//!     (default directory: docs/plots)
//! ```

use std::process::ExitCode;
use std::time::Duration;

use board_sim::demo::{self, Scenario};
use board_sim::{rawsock, Segment};

const USAGE: &str =
    "usage: sim-drive [demo] [--profile NAME] [--drives N] [--cycle-us US] [--cycles N]
       sim-drive attach --iface IFNAME [--profile NAME] [--drives N] [--seconds S] [--drop-mailbox-read K]
       sim-drive list-profiles
       sim-drive plots [--out DIR]";

struct Args {
    command: String,
    profile: String,
    drives: usize,
    cycle_us: u64,
    cycles: u32,
    iface: Option<String>,
    seconds: Option<u64>,
    free_run: bool,
    drop_mailbox_read: Option<u32>,
    out: String,
}

fn parse(mut it: impl Iterator<Item = String>) -> Result<Args, String> {
    let mut a = Args {
        command: "demo".into(),
        profile: "standard".into(),
        drives: 1,
        cycle_us: 1000,
        cycles: 1000,
        iface: None,
        seconds: None,
        free_run: false,
        drop_mailbox_read: None,
        out: "docs/plots".into(),
    };
    let mut first = true;
    while let Some(arg) = it.next() {
        let mut value = |name: &str| it.next().ok_or_else(|| format!("{name} needs a value"));
        match arg.as_str() {
            "demo" | "attach" | "list-profiles" | "plots" if first => a.command = arg.clone(),
            "--out" => a.out = value("--out")?,
            "--profile" => a.profile = value("--profile")?,
            "--drives" => a.drives = number(&value("--drives")?, "--drives")?,
            "--cycle-us" => a.cycle_us = number(&value("--cycle-us")?, "--cycle-us")?,
            "--cycles" => a.cycles = number(&value("--cycles")?, "--cycles")?,
            "--iface" => a.iface = Some(value("--iface")?),
            "--free-run" => a.free_run = true,
            "--drop-mailbox-read" => {
                a.drop_mailbox_read = Some(number(
                    &value("--drop-mailbox-read")?,
                    "--drop-mailbox-read",
                )?)
            }
            "--seconds" => a.seconds = Some(number(&value("--seconds")?, "--seconds")?),
            "-h" | "--help" => return Err(String::new()),
            other => return Err(format!("unknown argument {other:?}")),
        }
        first = false;
    }
    if a.drives == 0 || a.drives > demo::MAX_DRIVES {
        return Err(format!("--drives must be 1..={}", demo::MAX_DRIVES));
    }
    Ok(a)
}

fn number<T: std::str::FromStr>(s: &str, name: &str) -> Result<T, String> {
    s.parse()
        .map_err(|_| format!("{name}: {s:?} is not a valid number"))
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
        _ => run_demo(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("sim-drive: {e}");
            ExitCode::FAILURE
        }
    }
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
    let iface = args.iface.as_deref().ok_or("attach needs --iface IFNAME")?;
    let segment = Segment::new(&args.profile, args.drives)?;
    let faults = rawsock::Faults {
        drop_mailbox_read: args.drop_mailbox_read,
    };
    rawsock::serve_with_faults(segment, iface, args.seconds.map(Duration::from_secs), faults)
        .map_err(|e| format!("{iface}: {e} (a raw socket needs CAP_NET_RAW, e.g. run inside `unshare --user --map-root-user --net`)"))?;
    Ok(())
}

fn run_demo(args: &Args) -> Result<(), Box<dyn std::error::Error>> {
    let scenario = Scenario {
        profile: args.profile.clone(),
        drives: args.drives,
        cycle: Duration::from_micros(args.cycle_us),
        cycles: args.cycles,
        dc: !args.free_run,
    };
    println!(
        "sim-drive demo: {} simulated drive(s), profile {:?}, built-in ethercrab master, {} cycle {} µs",
        scenario.drives,
        scenario.profile,
        if scenario.dc { "DC SYNC0" } else { "free-run" },
        args.cycle_us
    );
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_time()
        .build()?;
    let local = tokio::task::LocalSet::new();
    let report = local.block_on(&rt, async {
        demo::run(&scenario, &mut |line| println!("{line}")).await
    })?;
    println!(
        "done: {} frames, {:.1} ms simulated, firmware cycles per drive {:?}",
        report.frames,
        report.sim_time_ns as f64 / 1e6,
        report.firmware_cycles
    );
    if report.wkc_errors > 0 {
        return Err(format!("{} cycles had a wrong working counter", report.wkc_errors).into());
    }
    Ok(())
}
