//! `sim-drive attach` runs the drives in wall-clock time. A line the host cannot simulate at
//! that pace misses its deadlines (each drive's SYNC0 and timers run late); `attach` says so
//! while it runs and in its summary, instead of slipping silently.

use tests_host::soem::attach_without_master;

/// The number in "N missed deadline(s)" of the summary line.
fn missed(output: &str) -> u64 {
    let summary = output
        .lines()
        .find(|l| l.starts_with("sim-drive: stopped after"))
        .unwrap_or_else(|| panic!("no summary:\n{output}"));
    let (_, rest) = summary.split_once("; ").expect("summary parts");
    rest.split_whitespace()
        .next()
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no count in {summary:?}"))
}

#[test]
fn a_line_too_long_for_the_host_reports_missed_deadlines() {
    // 128 drives with the PWM-resolved plant on one thread need far more than one core
    // (benchmarks/REALTIME.md: about 0.15 s of host time per drive-second).
    let out = attach_without_master(&[
        "--drives",
        "128",
        "--plant",
        "pwm",
        "--threads",
        "1",
        "--seconds",
        "2",
    ])
    .unwrap_or_else(|e| panic!("{e}"));
    assert!(out.contains("ms behind real time"), "{out}");
    assert!(missed(&out) > 0, "{out}");
}

#[test]
fn one_drive_reports_its_deadlines_in_the_summary() {
    let out = attach_without_master(&["--drives", "1", "--plant", "averaged", "--seconds", "1"])
        .unwrap_or_else(|e| panic!("{e}"));
    // The count depends on how busy the host is; the summary is always there.
    let n = missed(&out);
    assert!(
        out.contains(&format!(
            "{n} missed deadline(s) (events run more than 1 ms late"
        )),
        "{out}"
    );
}
