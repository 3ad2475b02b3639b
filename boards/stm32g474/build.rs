//! Puts the top-level `memory.x` (the source of truth for the default board's memory map) on
//! the linker search path. `link.x` (cortex-m-rt) includes it; `defmt.x` comes from defmt and
//! `device.x` (the vector names) from stm32-metapac's `rt` feature.

use std::env;
use std::fs;
use std::path::PathBuf;

fn main() {
    let manifest_dir = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("set by cargo"));
    let out_dir = PathBuf::from(env::var_os("OUT_DIR").expect("set by cargo"));
    let memory_x = manifest_dir.join("../../memory.x");

    // Copy rather than adding the repository root to the search path, so that no other file of
    // the root can shadow a linker script.
    fs::copy(&memory_x, out_dir.join("memory.x"))
        .unwrap_or_else(|e| panic!("cannot copy {}: {e}", memory_x.display()));
    println!("cargo:rustc-link-search={}", out_dir.display());
    println!("cargo:rerun-if-changed=../../memory.x");
    println!("cargo:rerun-if-changed=build.rs");
}
