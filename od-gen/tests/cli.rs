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
        assert_eq!(
            String::from_utf8_lossy(&out.stdout),
            "ok: sigma-v-sd-2axis\n"
        );
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

/// `table`: CSV with `--csv` (one row per entry), aligned text without; a path works like a
/// name; unknown flags are usage errors.
#[test]
fn table_csv_and_text() {
    let p = od_gen::builtin("standard").unwrap();
    let out = od_gen(&["table", "standard", "--csv"]);
    assert!(out.status.success());
    let csv = String::from_utf8(out.stdout).unwrap();
    assert_eq!(csv, od_gen::table::csv(&p));
    let mut lines = csv.lines();
    assert_eq!(
        lines.next(),
        Some("index,subindex,name,data_type,access,pdo_mapping,default,min,max")
    );
    let entries: usize = p.objects.iter().map(|o| o.entries.len()).sum();
    assert_eq!(lines.clone().count(), entries);
    let rows: Vec<&str> = lines.collect();
    for want in [
        "0x1000,0,Device type,UINT32,CONST,NO,131474,,",
        "0x1001,0,Error register,UINT8,RO,TX,0,,",
        "0x1008,0,Manufacturer device name,VISIBLE_STRING,CONST,NO,Open CiA402 Servo,,",
        "0x1018,0,SubIndex 000,UINT8,CONST,NO,4,,",
        "0x1018,1,Vendor ID,UINT32,CONST,NO,2119631874,,",
        "0x10F3,3,Newest acknowledged message,UINT8,RW,NO,0,0,13",
        "0x10F3,4,New messages available,BOOLEAN,RO,NO,0,,",
    ] {
        assert!(rows.contains(&want), "missing row {want}");
    }
    // Derived objects are rows too: 1C12h:01 = 0x1600.
    assert!(rows
        .iter()
        .any(|r| r.starts_with("0x1C12,1,") && r.contains(",5632,")));
    let cw = rows
        .iter()
        .find(|r| r.starts_with("0x6040,0,"))
        .expect("6040h");
    assert!(cw.contains(",UINT16,RW,RX,"), "{cw}");

    // A path gives the same table.
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/profiles/standard.toml");
    let out = od_gen(&["table", path, "--csv"]);
    assert!(out.status.success());
    assert_eq!(String::from_utf8(out.stdout).unwrap(), csv);

    // Without --csv: aligned text, header + one line per entry + a summary line.
    let out = od_gen(&["table", "standard"]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    assert_eq!(text, od_gen::table::text(&p));
    let lines: Vec<&str> = text.lines().collect();
    assert!(lines[0].starts_with("index   sub  name"), "{}", lines[0]);
    assert_eq!(lines.len(), entries + 2);
    assert_eq!(
        lines.last().copied(),
        Some(format!("{} objects, {entries} entries", p.objects.len()).as_str())
    );
    // Columns line up: "type" starts at the same character position on every line.
    let col = lines[0].find("type").unwrap();
    for l in &lines[1..lines.len() - 1] {
        let before: String = l.chars().take(col).collect();
        assert!(before.ends_with("  "), "{l}");
    }

    // Errors: one line and usage, exit status 1, never a panic.
    for args in [
        &["table"][..],
        &["table", "nope"],
        &["table", "standard", "--bogus"],
        &["table", "standard", "sdv3-e"],
        &["table", "/nonexistent/x.toml", "--csv"],
        &["esi", "standard", "--csv"],
    ] {
        let out = od_gen(args);
        assert_eq!(out.status.code(), Some(1), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.starts_with("od-gen: "), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
        assert!(out.stdout.is_empty(), "{args:?}");
    }
    let err =
        String::from_utf8_lossy(&od_gen(&["table", "standard", "--bogus"]).stderr).into_owned();
    assert!(
        err.contains("unknown option `--bogus`") && err.contains("usage:"),
        "{err}"
    );
}

/// Every error of a profile file, one per line with its line number, from `check` and from
/// the commands that generate; exit code 1 as for one error.
#[test]
fn every_error_of_a_file_is_printed_one_per_line() {
    let text = include_str!("../profiles/standard.toml")
        .replacen("physics = \"YY\"", "physics = \"QQ\"", 1)
        .replacen("byte_size = 2048", "byte_size = 1000", 1)
        .replacen("safeop_op_timeout_ms = 9000", "safeop_op_timeout_ms = 0", 1);
    let dir = std::env::temp_dir().join(format!("od-gen-cli-errors-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("standard.toml");
    std::fs::write(&path, &text).unwrap();
    let path = path.to_str().unwrap();
    for args in [
        &["check", path][..],
        &["esi", path],
        &["sii", path],
        &["rust", path],
    ] {
        let out = od_gen(args);
        assert_eq!(out.status.code(), Some(1), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        let lines: Vec<&str> = err.lines().collect();
        assert_eq!(lines.len(), 3, "{args:?}: {err}");
        for (line, key) in lines.iter().zip([
            "esm.safeop_op_timeout_ms",
            "device.physics",
            "eeprom.byte_size",
        ]) {
            assert!(
                line.starts_with(&format!("od-gen: {path}:")) && line.contains(&format!("`{key}`")),
                "{line}"
            );
        }
    }
    // `check` of several profiles reports the errors of each.
    let out = od_gen(&["check", path, "standard", path]);
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(String::from_utf8_lossy(&out.stderr).lines().count(), 6);
    std::fs::remove_dir_all(&dir).unwrap();
}
