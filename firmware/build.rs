//! Generates `OUT_DIR/profiles.rs` (the object dictionaries with the drive bindings) with
//! od-gen from `od-gen/profiles/*.toml`: every profile on the host; exactly one when the
//! environment variable `DRIVE_PROFILE` names it (a board image, e.g.
//! `DRIVE_PROFILE=sdv3-e cargo build --release` in `boards/stm32g474`). `profiles::selected` is
//! that profile (default `standard`).

fn main() {
    let manifest =
        std::path::PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap_or_default());
    od_gen::rust::build_script_selecting(
        &manifest.join("../od-gen/profiles"),
        "profiles.rs",
        &od_gen::rust::Target::DRIVE_CRATE,
        "DRIVE_PROFILE",
    );
}
