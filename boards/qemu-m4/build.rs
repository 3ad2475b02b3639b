//! Puts this crate's `memory.x` (the memory map of QEMU's MPS2 AN386) on the linker search path;
//! cortex-m-rt's `link.x` includes it.

use std::env;
use std::fs;
use std::path::PathBuf;

fn main() {
    let manifest_dir = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("set by cargo"));
    let out_dir = PathBuf::from(env::var_os("OUT_DIR").expect("set by cargo"));
    let memory_x = manifest_dir.join("memory.x");

    // Copy into OUT_DIR rather than adding the crate directory to the search path, so that the
    // root workspace's memory.x (the STM32G474's) can never be picked up instead.
    fs::copy(&memory_x, out_dir.join("memory.x"))
        .unwrap_or_else(|e| panic!("cannot copy {}: {e}", memory_x.display()));
    println!("cargo:rustc-link-search={}", out_dir.display());
    println!("cargo:rerun-if-changed=memory.x");
    println!("cargo:rerun-if-changed=build.rs");
}
