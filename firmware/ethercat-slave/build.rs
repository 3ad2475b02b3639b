//! Generates `OUT_DIR/test_profiles.rs` with od-gen: the object dictionaries (only the slave
//! part, no application bindings) of `od-gen/profiles/*.toml`, for this crate's unit tests.

use std::path::PathBuf;

fn main() {
    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap_or_default());
    let dir = manifest.join("../../od-gen/profiles");
    println!("cargo:rerun-if-changed={}", dir.display());
    let profiles = match od_gen::load_dir(&dir) {
        Ok(p) => p,
        Err(e) => {
            eprintln!("od-gen: {e}");
            std::process::exit(1);
        }
    };
    let out = PathBuf::from(std::env::var("OUT_DIR").unwrap_or_default()).join("test_profiles.rs");
    let code = od_gen::rust::generate_with(&profiles, &od_gen::rust::Target::SLAVE_CRATE);
    if let Err(e) = std::fs::write(&out, code) {
        eprintln!("od-gen: cannot write {}: {e}", out.display());
        std::process::exit(1);
    }
}
