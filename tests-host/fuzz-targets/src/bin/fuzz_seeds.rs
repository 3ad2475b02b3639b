//! `fuzz-seeds <recordings-dir> <corpus-dir>`: writes the seed corpus of every target into
//! `<corpus-dir>/<target>/` from the frame recordings in `<recordings-dir>` (made with
//! `SIM_RECORD_FRAMES=<dir>`, see `board_sim::record`) and from the built-in profiles.
//! `tests-host/fuzz/seed` runs the recording tests and this.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use fuzz_targets::seeds;

/// Seeds kept per target from recordings (spread over the recordings).
const PER_TARGET: usize = 48;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [recordings, corpus] = &args[..] else {
        eprintln!("usage: fuzz-seeds <recordings-dir> <corpus-dir>");
        return ExitCode::from(2);
    };
    match run(Path::new(recordings), Path::new(corpus)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("fuzz-seeds: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(recordings: &Path, corpus: &Path) -> Result<(), String> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(recordings)
        .map_err(|e| format!("{}: {e}", recordings.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .collect();
    files.sort();
    let mut by_target: BTreeMap<&str, Vec<Vec<u8>>> = BTreeMap::new();
    let mut used = 0;
    for f in &files {
        let bytes = std::fs::read(f).map_err(|e| format!("{}: {e}", f.display()))?;
        let Some(rec) = board_sim::record::parse(&bytes) else {
            continue;
        };
        let Some(p) = seeds::profile_index(&rec) else {
            continue;
        };
        if rec.frames.is_empty() {
            continue;
        }
        used += 1;
        by_target
            .entry("frames")
            .or_default()
            .extend(seeds::frames_seeds(&rec, p));
        by_target
            .entry("mailbox")
            .or_default()
            .extend(seeds::mailbox_seeds(&rec, p));
        by_target
            .entry("sdo")
            .or_default()
            .extend(seeds::sdo_seeds(&rec, p));
        by_target
            .entry("esm")
            .or_default()
            .extend(seeds::esm_seeds(&rec, p));
        by_target
            .entry("pdo")
            .or_default()
            .extend(seeds::pdo_seeds(&rec, p));
    }
    for v in by_target.values_mut() {
        v.sort();
        v.dedup();
        if v.len() > PER_TARGET {
            let step = v.len().div_ceil(PER_TARGET);
            *v = v.iter().step_by(step).cloned().collect();
        }
    }
    by_target.insert("params", seeds::params_seeds());
    let profiles_dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../od-gen/profiles");
    by_target.insert("profile", seeds::profile_seeds(&profiles_dir));
    for (target, inputs) in &by_target {
        let dir = corpus.join(target);
        std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        for input in inputs {
            let path = dir.join(seeds::name(input));
            std::fs::write(&path, input).map_err(|e| format!("{}: {e}", path.display()))?;
        }
        println!("{target}: {} seeds", inputs.len());
    }
    println!("from {used} recordings of {} files", files.len());
    Ok(())
}
