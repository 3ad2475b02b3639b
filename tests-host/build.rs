//! Generates `OUT_DIR/io_module_profile.rs` with od-gen: the object dictionary of the example
//! I/O module (`io-module/io16.toml`), a device on the slave stack that is not a drive.

use std::path::PathBuf;

fn main() {
    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap_or_default());
    let file = manifest.join("io-module/io16.toml");
    println!("cargo:rerun-if-changed={}", file.display());
    let profile = match od_gen::load(&file) {
        Ok(p) => p,
        Err(e) => {
            eprintln!("od-gen: {e}");
            std::process::exit(1);
        }
    };
    let code = od_gen::rust::generate_with(&[profile], &od_gen::rust::Target::DEVICE_CRATE);
    let out =
        PathBuf::from(std::env::var("OUT_DIR").unwrap_or_default()).join("io_module_profile.rs");
    if let Err(e) = std::fs::write(&out, code) {
        eprintln!("od-gen: cannot write {}: {e}", out.display());
        std::process::exit(1);
    }
}
