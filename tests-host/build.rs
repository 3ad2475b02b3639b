//! Generates `OUT_DIR/io_module_profile.rs` with od-gen: the object dictionary of the example
//! I/O module (`io-module/io16.toml`), a device on the slave stack that is not a drive.

fn main() {
    let manifest =
        std::path::PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap_or_default());
    od_gen::rust::build_script(
        &manifest.join("io-module/io16.toml"),
        "io_module_profile.rs",
        &od_gen::rust::Target::DEVICE_CRATE,
    );
}
