//! Replays every committed corpus input (`tests-host/fuzz/corpus/<target>/`) and every
//! regression input (`tests-host/fuzz/regressions/<target>/`, inputs that once found a bug)
//! through its target: a change that makes any of them panic or break an oracle fails here,
//! without libFuzzer (CI runs this in the normal test suite).

use std::path::{Path, PathBuf};

use fuzz_targets::TARGETS;

fn fuzz_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz")
}

/// `.keep` and the like: not inputs.
fn hidden(p: &Path) -> bool {
    p.file_name()
        .and_then(|n| n.to_str())
        .is_some_and(|n| n.starts_with('.'))
}

fn inputs(dir: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|rd| {
            rd.filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.is_file() && !hidden(p))
                .collect()
        })
        .unwrap_or_default();
    files.sort();
    files
}

fn replay(kind: &str, at_least: usize) {
    let mut failures = Vec::new();
    for target in TARGETS {
        let dir = fuzz_dir().join(kind).join(target.name);
        let files = inputs(&dir);
        assert!(
            files.len() >= at_least,
            "{}: {} inputs, at least {at_least} expected",
            dir.display(),
            files.len()
        );
        for file in files {
            let data = std::fs::read(&file).expect("corpus file readable");
            let outcome = std::panic::catch_unwind(|| (target.run)(&data));
            match outcome {
                Ok(Ok(())) => {}
                Ok(Err(v)) => failures.push(format!("{}: {}", file.display(), v.0)),
                Err(_) => failures.push(format!("{}: panicked", file.display())),
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{} inputs fail:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

#[test]
fn every_corpus_input_passes_its_oracle() {
    // Every target has a corpus (seeds from recorded ethercrab/SOEM traffic plus what the
    // fuzzer kept).
    replay("corpus", 1);
}

#[test]
fn every_regression_input_passes_its_oracle() {
    replay("regressions", 0);
}
