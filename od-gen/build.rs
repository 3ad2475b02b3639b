//! Embeds the built-in profiles (`profiles/*.toml`) and the libraries of shared object
//! definitions (`profiles/common/*.toml`) into the library.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The `*.toml` files of `dir`, sorted by stem (the profile name: `sigma-v-sd` before
/// `sigma-v-sd-2axis`).
fn toml_files(dir: &Path) -> Result<Vec<PathBuf>, std::io::Error> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)?
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    files.sort_by_key(|p| p.file_stem().map(|s| s.to_os_string()));
    Ok(files)
}

/// `pub(crate) static NAME: &[(&str, &str)]` of (file stem, TOML text) for `files`.
fn table(out: &mut String, doc: &str, name: &str, files: &[PathBuf]) {
    let _ = writeln!(out, "/// {doc}: (file stem, TOML text), sorted by name.");
    let _ = writeln!(out, "pub(crate) static {name}: &[(&str, &str)] = &[");
    for f in files {
        println!("cargo:rerun-if-changed={}", f.display());
        let stem = f.file_stem().and_then(|s| s.to_str()).unwrap_or_default();
        let _ = writeln!(
            out,
            "    ({stem:?}, include_str!({:?})),",
            f.display().to_string()
        );
    }
    out.push_str("];\n");
}

fn fail(what: &str, path: &Path, e: std::io::Error) -> ! {
    eprintln!("od-gen: cannot {what} {}: {e}", path.display());
    std::process::exit(1);
}

fn main() {
    let dir =
        PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap_or_default()).join("profiles");
    let common = dir.join("common");
    println!("cargo:rerun-if-changed={}", dir.display());
    println!("cargo:rerun-if-changed={}", common.display());
    let profiles = toml_files(&dir).unwrap_or_else(|e| fail("read", &dir, e));
    let libraries = toml_files(&common).unwrap_or_else(|e| fail("read", &common, e));
    let mut out = String::new();
    table(&mut out, "Built-in profiles", "BUILTIN", &profiles);
    table(
        &mut out,
        "Libraries of shared object definitions",
        "BUILTIN_LIBRARIES",
        &libraries,
    );
    let dest = PathBuf::from(std::env::var("OUT_DIR").unwrap_or_default()).join("builtin.rs");
    if let Err(e) = std::fs::write(&dest, out) {
        fail("write", &dest, e);
    }
}
