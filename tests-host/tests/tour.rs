//! The guided tour (`sim-drive`, the README's main command): homing, profile position and
//! cyclic synchronous position on one simulated standard drive, with every statusword change
//! printed and a plot written. Checked against what each step must achieve.

use board_sim::tour;
use tests_host::block_on;

const CPR: f64 = (1u32 << 20) as f64;

#[test]
fn the_tour_homes_moves_and_streams_then_writes_its_plot() {
    let dir = std::env::temp_dir().join(format!("sim-drive-tour-{}", std::process::id()));
    let plot = dir.join("tour.svg");
    let mut lines = Vec::new();
    let report = block_on(async {
        tour::run("standard", &plot, &mut |l| lines.push(l))
            .await
            .expect("the tour runs")
    });
    // Homing (method 19): the home is the home switch edge at 0.4 rev; 6064h = 607Ch = 0 there.
    assert!(
        (report.homed_revolutions - 0.4).abs() < 1e-3,
        "home at {} rev",
        report.homed_revolutions
    );
    assert!(
        report.homed_position.abs() < 300,
        "6064h {}",
        report.homed_position
    );
    // Profile position: the buffered set-point ends on 1 rev (the 6067h window is 1000).
    assert!(
        (f64::from(report.pp_position) - CPR).abs() <= 1000.0,
        "{}",
        report.pp_position
    );
    // The printed statusword changes tell the story in order.
    let text = report.transitions.join("\n");
    let order = [
        "Switch On Disabled",
        "Ready to Switch On",
        "Switched On",
        "homing in progress",
        "homing completed",
        "set-point acknowledged",
        "target reached",
        "Ready to Switch On",
    ];
    let mut at = 0;
    for step in order {
        at += text[at..]
            .find(step)
            .unwrap_or_else(|| panic!("{step:?} missing after byte {at}:\n{text}"));
    }
    assert!(lines.iter().any(|l| l.contains("home found")));
    // CSP: the motor followed the stream out to 2 rev and back to 1.
    let peak = report
        .samples
        .iter()
        .filter(|s| s.mode == 8)
        .map(|s| s.position)
        .max()
        .expect("CSP samples");
    assert!(
        (f64::from(peak) - 2.0 * CPR).abs() < 0.01 * CPR,
        "CSP peak {peak}"
    );
    // One SVG with the three panels.
    let svg = std::fs::read_to_string(&plot).expect("plot written");
    assert_eq!(
        svg.matches("<polyline").count(),
        3,
        "position, speed, current"
    );
    assert!(svg.contains("Position actual value 6064h") && svg.contains("q current"));
    let _ = std::fs::remove_dir_all(&dir);
}
