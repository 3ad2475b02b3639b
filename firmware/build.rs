//! Generates `OUT_DIR/profiles.rs` (the object dictionaries of all profiles, with the drive
//! bindings) with od-gen from `od-gen/profiles/*.toml`.

fn main() {
    let manifest =
        std::path::PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap_or_default());
    od_gen::rust::build_script(
        &manifest.join("../od-gen/profiles"),
        "profiles.rs",
        &od_gen::rust::Target::DRIVE_CRATE,
    );
}
