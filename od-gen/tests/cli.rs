//! The `od-gen` binary: outputs, files and error exits.

use std::process::Command;

fn od_gen(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_od-gen"))
        .args(args)
        .output()
        .expect("runs")
}

#[test]
fn list_esi_and_sii() {
    let out = od_gen(&["list"]);
    assert!(out.status.success());
    // The five seed drives (the Yaskawa one in two variants) and the project's own, by name.
    assert_eq!(
        String::from_utf8_lossy(&out.stdout),
        "gha-e\nosd-g-e\nrse\nsdv3-e\nsigma-v-sd\nsigma-v-sd-2axis\nstandard\n"
    );
    // Both spellings name a profile.
    for name in ["sigma-v-sd-2axis", "sigma_v_sd_2axis"] {
        let out = od_gen(&["check", name]);
        assert!(out.status.success(), "{name}");
        assert_eq!(String::from_utf8_lossy(&out.stdout), "ok: sigma-v-sd-2axis\n");
    }

    let out = od_gen(&["esi", "standard"]);
    assert!(out.status.success());
    assert_eq!(
        String::from_utf8_lossy(&out.stdout),
        od_gen::builtin("standard").unwrap().esi_xml()
    );

    let dir = std::env::temp_dir().join(format!("od-gen-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bin = dir.join("standard.bin");
    let out = od_gen(&["sii", "standard", "-o", bin.to_str().unwrap()]);
    assert!(out.status.success());
    assert_eq!(
        std::fs::read(&bin).unwrap(),
        od_gen::builtin("standard").unwrap().sii_image()
    );

    // A path works too.
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/profiles/standard.toml");
    let out = od_gen(&["sii", path]);
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stdout).starts_with("0000: 05 06 03 66 64 00"));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn errors_are_messages_with_non_zero_exit() {
    for args in [
        &["esi", "nope"][..],
        &["sii", "/nonexistent/x.toml"],
        &["frobnicate"],
        &["esi"],
        &["esi", "standard", "-o"],
    ] {
        let out = od_gen(args);
        assert!(!out.status.success(), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.starts_with("od-gen: "), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}

/// `rust` generates drive profiles for the firmware and device profiles for other crates on the
/// slave stack, and refuses to mix them in one file.
#[test]
fn rust_target_follows_the_profile_kind() {
    let device = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests-host/io-module/io16.toml"
    );
    let out = od_gen(&["rust", "standard"]);
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stdout).contains("pub static PROFILE: DriveProfile"));
    let out = od_gen(&["rust", device]);
    assert!(out.status.success());
    let code = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(code.contains("pub static PROFILE: Profile = Profile {"));
    assert!(!code.contains("DriveProfile"));
    let out = od_gen(&["rust", "standard", device]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.starts_with("od-gen: `rust` takes drive profiles or device profiles"),
        "{err}"
    );
}
