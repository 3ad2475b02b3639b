//! Generates `OUT_DIR/test_profiles.rs` with od-gen: the object dictionaries (only the slave
//! part, no application bindings) of `od-gen/profiles/*.toml`, for this crate's unit tests.

fn main() {
    let manifest =
        std::path::PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap_or_default());
    od_gen::rust::build_script(
        &manifest.join("../../od-gen/profiles"),
        "test_profiles.rs",
        &od_gen::rust::Target::SLAVE_CRATE,
    );
}
