//! Generates `OUT_DIR/profiles.rs` (the object dictionaries of all profiles) with od-gen from
//! `od-gen/profiles/*.toml`.

use std::path::PathBuf;

fn main() {
    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap_or_default());
    let dir = manifest.join("../od-gen/profiles");
    println!("cargo:rerun-if-changed={}", dir.display());
    let profiles = match od_gen::load_dir(&dir) {
        Ok(p) => p,
        Err(e) => {
            eprintln!("od-gen: {e}");
            std::process::exit(1);
        }
    };
    let out = PathBuf::from(std::env::var("OUT_DIR").unwrap_or_default()).join("profiles.rs");
    if let Err(e) = std::fs::write(&out, od_gen::rust::generate(&profiles)) {
        eprintln!("od-gen: cannot write {}: {e}", out.display());
        std::process::exit(1);
    }
}
