//! The SOEM harness: pysoem (SOEM 1.4 inside the PyPI wheel) drives the simulated drive over a
//! veth pair in a private user + network namespace, so no root and no real NIC are needed.
//!
//! Prepared on first use, from PyPI: a venv with pysoem under the target directory.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// pysoem release the harness is written against (bundles SOEM 1.4).
const PYSOEM_VERSION: &str = "1.1.13";

/// The workspace root.
pub fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_default()
}

fn target_dir() -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace().join("target"))
}

fn run(cmd: &mut Command, what: &str) -> Result<(), String> {
    let out = cmd
        .output()
        .map_err(|e| format!("{what}: cannot start: {e}"))?;
    if out.status.success() {
        Ok(())
    } else {
        Err(format!(
            "{what} failed ({}):\n{}\n{}",
            out.status,
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        ))
    }
}

/// The venv python with pysoem, created on first use.
pub fn python() -> Result<PathBuf, String> {
    static PYTHON: OnceLock<Result<PathBuf, String>> = OnceLock::new();
    PYTHON
        .get_or_init(|| {
            let venv = target_dir().join("soem-venv");
            let py = venv.join("bin/python");
            let ok = Command::new(&py)
                .args([
                    "-c",
                    &format!("import pysoem; assert pysoem.__version__ == '{PYSOEM_VERSION}'"),
                ])
                .output()
                .is_ok_and(|o| o.status.success());
            if !ok {
                run(
                    Command::new("python3").args(["-m", "venv"]).arg(&venv),
                    "python3 -m venv",
                )?;
                run(
                    Command::new(venv.join("bin/pip")).args([
                        "install",
                        "-q",
                        &format!("pysoem=={PYSOEM_VERSION}"),
                    ]),
                    "pip install pysoem",
                )?;
            }
            Ok(py)
        })
        .clone()
}

/// Builds the documented attach command's binary once, outside the namespace (which has no
/// network), so that `cargo run` inside it only runs it.
fn build_sim_drive() -> Result<(), String> {
    static BUILT: OnceLock<Result<(), String>> = OnceLock::new();
    BUILT
        .get_or_init(|| {
            let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
            run(
                Command::new(cargo).current_dir(workspace()).args([
                    "build",
                    "--release",
                    "-q",
                    "-p",
                    "board-sim",
                ]),
                "cargo build --release -p board-sim",
            )
        })
        .clone()
}

/// Runs `sim-drive attach --iface lo` plus `args` alone (no master) in a private user + network
/// namespace and returns what it printed (standard output and error).
pub fn attach_without_master(args: &[&str]) -> Result<String, String> {
    build_sim_drive()?;
    let sim = target_dir().join("release/sim-drive");
    let out = Command::new("unshare")
        .args(["--user", "--map-root-user", "--net", "sh", "-c"])
        .arg(r#"ip link set lo up && exec "$0" attach --iface lo "$@""#)
        .arg(&sim)
        .args(args)
        .output()
        .map_err(|e| format!("unshare: {e}"))?;
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    if out.status.success() {
        Ok(text)
    } else {
        Err(format!("sim-drive attach failed ({}):\n{text}", out.status))
    }
}

/// Runs the SOEM scenario against `drives` simulated drives of `profile`; returns SOEM's
/// observations (see `tests-host/soem/scenario.py`) and the simulator's log.
pub fn run_scenario(profile: &str, drives: usize) -> Result<(serde_json::Value, String), String> {
    run_script("scenario.py", profile, drives, &[])
}

/// Runs the python script `tests-host/soem/<script>` against a line of simulated drives of the
/// given profiles, in that order (`sim-drive attach --drive P --drive Q ... --plant averaged`).
///
/// The drives' plants are averaged (one step per PWM period): a line is about the bus, and
/// `attach` runs in wall-clock time, where seven PWM-resolved drives need about a core of
/// this machine's two and fall behind the master when the test suite loads it.
pub fn run_line(script: &str, profiles: &[&str]) -> Result<(serde_json::Value, String), String> {
    let mut args: Vec<&str> = profiles.iter().flat_map(|p| ["--drive", *p]).collect();
    args.extend(["--plant", "averaged"]);
    run_script(script, "", profiles.len(), &args)
}

/// Runs the python script `tests-host/soem/<script>` (arguments: the master's interface, the
/// number of drives and `profile`; it prints one JSON object) against `drives` simulated drives
/// of `profile` attached with `sim-drive attach` plus `sim_args`; returns the JSON and the
/// simulator's log.
pub fn run_script(
    script: &str,
    profile: &str,
    drives: usize,
    sim_args: &[&str],
) -> Result<(serde_json::Value, String), String> {
    let python = python()?;
    build_sim_drive()?;
    let stem = script.trim_end_matches(".py");
    let dir = target_dir().join(format!("soem-{stem}-{profile}-{drives}"));
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let sim_log = dir.join("sim.log");
    let result = dir.join("result.json");
    let _ = std::fs::remove_file(&result);
    let out = Command::new("unshare")
        .args(["--user", "--map-root-user", "--net", "bash"])
        .arg(workspace().join("tests-host/soem/run_in_netns.sh"))
        .env("PYTHON", &python)
        .env("WORKSPACE", workspace())
        .env("SCRIPT", script)
        .env("SIM_ARGS", sim_args.join(" "))
        .env("PROFILE", profile)
        .env("DRIVES", drives.to_string())
        .env("SIM_LOG", &sim_log)
        .env("RESULT", &result)
        .output()
        .map_err(|e| format!("unshare: {e}"))?;
    let log = std::fs::read_to_string(&sim_log).unwrap_or_default();
    if !out.status.success() {
        return Err(format!(
            "SOEM {script} failed ({}):\nstdout:\n{}\nstderr:\n{}\nsim-drive log:\n{log}",
            out.status,
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    let text =
        std::fs::read_to_string(&result).map_err(|e| format!("{}: {e}", result.display()))?;
    let json = serde_json::from_str(&text)
        .map_err(|e| format!("{script} output is not JSON ({e}): {text}"))?;
    Ok((json, log))
}
