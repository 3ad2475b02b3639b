//! Embeds the built-in profiles (`profiles/*.toml`) and the libraries of shared object
//! definitions (`profiles/common/*.toml`) into the library.

use std::fmt::Write as _;
use std::path::PathBuf;

fn main() {
    let dir =
        PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap_or_default()).join("profiles");
    println!("cargo:rerun-if-changed={}", dir.display());
    let mut files: Vec<PathBuf> = match std::fs::read_dir(&dir) {
        Ok(rd) => rd
            .filter_map(Result::ok)
            .map(|e| e.path())
            .filter(|p| p.extension().is_some_and(|x| x == "toml"))
            .collect(),
        Err(e) => {
            eprintln!("od-gen: cannot read {}: {e}", dir.display());
            std::process::exit(1);
        }
    };
    // By profile name (the stem): `sigma-v-sd` before `sigma-v-sd-2axis`.
    files.sort_by_key(|p| p.file_stem().map(|s| s.to_os_string()));
    let mut out = String::from("/// Built-in profiles: (file stem, TOML text), sorted by name.\npub(crate) static BUILTIN: &[(&str, &str)] = &[\n");
    for f in &files {
        println!("cargo:rerun-if-changed={}", f.display());
        let stem = f.file_stem().and_then(|s| s.to_str()).unwrap_or_default();
        let _ = writeln!(
            out,
            "    ({stem:?}, include_str!({:?})),",
            f.display().to_string()
        );
    }
    out.push_str("];\n");
    // Libraries of shared object definitions (profiles/common/*.toml).
    let common = dir.join("common");
    println!("cargo:rerun-if-changed={}", common.display());
    let mut libs: Vec<PathBuf> = std::fs::read_dir(&common)
        .map(|rd| {
            rd.filter_map(Result::ok)
                .map(|e| e.path())
                .filter(|p| p.extension().is_some_and(|x| x == "toml"))
                .collect()
        })
        .unwrap_or_default();
    libs.sort();
    out.push_str("/// Libraries of shared object definitions: (file stem, TOML text), sorted.\npub(crate) static BUILTIN_LIBRARIES: &[(&str, &str)] = &[\n");
    for f in &libs {
        println!("cargo:rerun-if-changed={}", f.display());
        let stem = f.file_stem().and_then(|s| s.to_str()).unwrap_or_default();
        let _ = writeln!(
            out,
            "    ({stem:?}, include_str!({:?})),",
            f.display().to_string()
        );
    }
    out.push_str("];\n");
    let dest = PathBuf::from(std::env::var("OUT_DIR").unwrap_or_default()).join("builtin.rs");
    if let Err(e) = std::fs::write(&dest, out) {
        eprintln!("od-gen: cannot write {}: {e}", dest.display());
        std::process::exit(1);
    }
}
