//! Profile composition: `extends`, `from = "<library>"`, `omit`, `[[replicate]]`, alarms and
//! decisions, and errors that point at the line that wrote the value.

use od_gen::{Error, Invalid};

const STANDARD: &str = include_str!("../profiles/standard.toml");

/// A folder with the given profile files (name → text).
fn folder(files: &[(&str, &str)]) -> tempdir::Dir {
    let dir = tempdir::Dir::new();
    for (name, text) in files {
        std::fs::write(dir.path().join(format!("{name}.toml")), text).unwrap();
    }
    dir
}

mod tempdir {
    use std::path::{Path, PathBuf};
    use std::sync::atomic::{AtomicUsize, Ordering};

    /// A temporary folder removed on drop (no extra crate for one test file).
    pub struct Dir(PathBuf);
    impl Dir {
        pub fn new() -> Self {
            static N: AtomicUsize = AtomicUsize::new(0);
            let p = std::env::temp_dir().join(format!(
                "od-gen-compose-{}-{}",
                std::process::id(),
                N.fetch_add(1, Ordering::Relaxed)
            ));
            std::fs::create_dir_all(&p).unwrap();
            Self(p)
        }
        pub fn path(&self) -> &Path {
            &self.0
        }
    }
    impl Drop for Dir {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

/// The standard profile renamed (its file stem must equal its name).
fn base(name: &str) -> String {
    STANDARD.replacen("name = \"standard\"", &format!("name = \"{name}\""), 1)
}

fn line_of(text: &str, needle: &str) -> usize {
    text.lines().position(|l| l.contains(needle)).unwrap() + 1
}

#[test]
fn library_objects_take_the_cia402_definition() {
    let p = od_gen::builtin("standard").unwrap();
    let cw = p.entry(0x6040, 0).unwrap();
    // From the library: name, type, access, PDO mapping, role.
    assert_eq!(p.object(0x6040).unwrap().name, "Controlword");
    assert_eq!(cw.data_type, od_gen::model::DataType::Uint);
    assert!(cw.access.writable() && cw.pdo.rx());
    assert!(cw.role.is_some());
    // Overridden in the profile: the default mode of operation.
    assert_eq!(p.entry(0x6060, 0).unwrap().default, vec![8]);
    assert_eq!(
        p.entry(0x6071, 0).unwrap().doc.unit.as_deref(),
        Some("0.1 % of 6076h")
    );
}

#[test]
fn a_derived_profile_overrides_its_base_key_by_key() {
    let derived = r#"
name = "rebrand"
description = "The base under another name."
extends = "base-drive"

[vendor]
name = "Other vendor"

[device]
name = "Rebranded drive"
product_code = 0x1234

[[object]]
index = 0x6060
default = 9

[[object]]
index = 0x2F00
omit = true

[[decision]]
subject = "identity"
choice = "vendor name changed"
"#;
    let dir = folder(&[("base-drive", &base("base-drive")), ("rebrand", derived)]);
    let p = od_gen::load(&dir.path().join("rebrand.toml")).unwrap();
    let b = od_gen::load(&dir.path().join("base-drive.toml")).unwrap();
    assert_eq!(p.name, "rebrand");
    assert_eq!(p.module_name(), "rebrand");
    assert_eq!(p.vendor.name, "Other vendor");
    assert_eq!(p.vendor.id, b.vendor.id, "vendor.id kept from the base");
    assert_eq!(p.device.name, "Rebranded drive");
    assert_eq!(p.device.product_code, 0x1234);
    assert_eq!(p.device.revision, b.device.revision);
    // 6060h: only the default changed; the library definition and `setting` stay.
    let mode = p.entry(0x6060, 0).unwrap();
    assert_eq!(mode.default, vec![9]);
    assert!(mode.setting && mode.role.is_some());
    assert!(p.object(0x2F00).is_none(), "omitted");
    assert!(b.object(0x2F00).is_some());
    assert_eq!(p.decisions.len(), 1);
    assert_eq!(p.sii_image().len(), b.sii_image().len());
    // 1018h follows the derived identity.
    assert_eq!(p.entry(0x1018, 2).unwrap().default, 0x1234u32.to_le_bytes());
}

#[test]
fn extends_needs_an_existing_base_and_no_cycle() {
    let missing = "name = \"x\"\ndescription = \"\"\nextends = \"nowhere\"\n";
    let dir = folder(&[("x", missing)]);
    match od_gen::load(&dir.path().join("x.toml")) {
        Err(Error::Invalid { key, error, .. }) => {
            assert_eq!(key, "extends");
            assert_eq!(error, Invalid::UnknownBase("nowhere".into()));
        }
        other => panic!("{other:?}"),
    }
    let a = "name = \"a\"\ndescription = \"\"\nextends = \"b\"\n";
    let b = "name = \"b\"\ndescription = \"\"\nextends = \"a\"\n";
    let dir = folder(&[("a", a), ("b", b)]);
    match od_gen::load(&dir.path().join("a.toml")) {
        Err(Error::Invalid { key, error, .. }) => {
            assert_eq!(key, "extends");
            assert!(
                matches!(error, Invalid::Value(ref m) if m.contains("circular")),
                "{error:?}"
            );
        }
        other => panic!("{other:?}"),
    }
    // The derived file must say who it is.
    let anonymous = "extends = \"standard\"\ndescription = \"\"\n";
    let dir = folder(&[("anon", anonymous)]);
    match od_gen::load(&dir.path().join("anon.toml")) {
        Err(Error::Invalid { key, error, .. }) => {
            assert_eq!(key, "name");
            assert_eq!(error, Invalid::Missing("name"));
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn an_error_in_the_base_names_the_base_file_and_line() {
    let bad_base = base("bad-base").replacen("default = 1270", "default = 5000000000", 1);
    let derived = "name = \"child\"\ndescription = \"\"\nextends = \"bad-base\"\n";
    let dir = folder(&[("bad-base", &bad_base), ("child", derived)]);
    let err = od_gen::load(&dir.path().join("child.toml")).unwrap_err();
    let Error::Invalid {
        file, key, line, ..
    } = &err
    else {
        panic!("{err:?}")
    };
    assert!(file.ends_with("bad-base.toml"), "{err}");
    assert_eq!(key, "object[0x6076].default");
    assert_eq!(*line, Some(line_of(&bad_base, "default = 5000000000")));
}

#[test]
fn library_errors() {
    let unknown_lib = STANDARD.replacen(
        "index = 0x6040\nfrom = \"cia402\"",
        "index = 0x6040\nfrom = \"cia403\"",
        1,
    );
    match od_gen::parse(&unknown_lib, "p.toml") {
        Err(Error::Invalid {
            key, error, line, ..
        }) => {
            assert_eq!(key, "object[0x6040].from");
            assert!(
                matches!(error, Invalid::Value(ref m) if m.contains("cia402")),
                "{error:?}"
            );
            assert_eq!(line, Some(line_of(&unknown_lib, "from = \"cia403\"")));
        }
        other => panic!("{other:?}"),
    }
    let not_in_lib = format!("{STANDARD}\n[[object]]\nindex = 0x2FFE\nfrom = \"cia402\"\n");
    match od_gen::parse(&not_in_lib, "p.toml") {
        Err(Error::Invalid { key, error, .. }) => {
            assert_eq!(key, "object[0x2ffe].from");
            assert!(
                matches!(error, Invalid::Value(ref m) if m.contains("does not define")),
                "{error:?}"
            );
        }
        other => panic!("{other:?}"),
    }
    // A value the profile gives to a library object is checked like any other, at its line.
    let out_of_range = STANDARD.replacen("default = 8 ", "default = 300 ", 1);
    match od_gen::parse(&out_of_range, "p.toml") {
        Err(Error::Invalid { key, line, .. }) => {
            assert_eq!(key, "object[0x6060].default");
            assert_eq!(line, Some(line_of(&out_of_range, "default = 300")));
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn replicate_copies_objects_to_the_second_axis_without_roles() {
    let two_axis = format!(
        "{}\n[[replicate]]\nfirst = 0x6000\nlast = 0x67FF\noffset = 0x800\n\n[[object]]\nindex = 0x6860\ndefault = 9\n",
        base("two-axis")
    );
    let p = od_gen::parse(&two_axis, "two-axis.toml").unwrap();
    let one = od_gen::builtin("standard").unwrap();
    for o in one
        .objects
        .iter()
        .filter(|o| (0x6000..=0x67FF).contains(&o.index))
    {
        let copy = p
            .object(o.index + 0x800)
            .unwrap_or_else(|| panic!("{:#x}", o.index));
        assert_eq!(copy.name, o.name);
        for (a, b) in copy.entries.iter().zip(&o.entries) {
            assert_eq!(
                (a.data_type, a.access, a.pdo),
                (b.data_type, b.access, b.pdo)
            );
            assert!(a.role.is_none(), "roles stay on the first axis");
        }
    }
    // An object declared at a replica's index states what differs there.
    assert_eq!(p.entry(0x6860, 0).unwrap().default, vec![9]);
    assert_eq!(p.entry(0x6060, 0).unwrap().default, vec![8]);
    assert_eq!(p.replicate, vec![(0x6000, 0x67FF, 0x800)]);
}

#[test]
fn motor_faults_may_name_alarms() {
    let text = STANDARD
        .replacen("over_current = 0x2320 ", "over_current = \"OC1\" ", 1)
        .replace("[motor_faults]", "[[alarm]]\ndisplay = \"OC1\"\nname = \"Over current 1\"\nerror_code = 0x2311\nemcy_data = [0x01, 0x06, 0x80, 0, 0]\n\n[[alarm]]\ndisplay = \"OS\"\nname = \"Over speed\"\nerror_code = 0xFF00\nemcy_code = 0x8400\nresettable = false\n\n[motor_faults]");
    let p = od_gen::parse(&text, "p.toml").unwrap();
    assert_eq!(p.alarms.len(), 2);
    let oc = p.motor_faults[0];
    assert_eq!(oc.error_code, 0x2311);
    assert_eq!(oc.emcy.code, 0x2311, "emcy_code defaults to error_code");
    assert_eq!(oc.emcy.data, [0x01, 0x06, 0x80, 0, 0]);
    assert_eq!(p.alarms[1].emcy.code, 0x8400);
    assert!(!p.alarms[1].resettable);
    // An integer code keeps working, with an empty manufacturer field.
    assert_eq!(p.motor_faults[1].emcy.data, [0; 5]);

    let unknown = text.replacen("over_current = \"OC1\"", "over_current = \"OC9\"", 1);
    match od_gen::parse(&unknown, "p.toml") {
        Err(Error::Invalid { key, error, .. }) => {
            assert_eq!(key, "motor_faults.over_current");
            assert!(
                matches!(error, Invalid::Value(ref m) if m.contains("OC9")),
                "{error:?}"
            );
        }
        other => panic!("{other:?}"),
    }
    let twice = text.replacen("display = \"OS\"", "display = \"OC1\"", 1);
    assert!(matches!(
        od_gen::parse(&twice, "p.toml"),
        Err(Error::Invalid { ref key, .. }) if key == "alarm[OC1].display"
    ));
}

#[test]
fn hyphenated_names_have_underscore_modules_and_both_spellings_find_them() {
    let dir = folder(&[("my-drive", &base("my-drive"))]);
    let p = od_gen::load(&dir.path().join("my-drive.toml")).unwrap();
    assert_eq!(p.module_name(), "my_drive");
    assert!(od_gen::rust::generate(&[p]).contains("pub mod my_drive {"));
    assert!(od_gen::same_name("sigma-v-sd-2axis", "sigma_v_sd_2axis"));
    assert!(!od_gen::same_name("sigma-v-sd", "sigma-v-sd-2axis"));
    assert!(od_gen::builtin("standard").is_ok());
}

/// Each kind of error the issue lists names the file, the line and the key.
#[test]
fn every_error_kind_names_file_line_and_field() {
    let extra = |t: &str| format!("{STANDARD}\n{t}\n");
    let cases: Vec<(String, &str, &str)> = vec![
        (
            extra("[[object]]\nindex = 0x2F00\nname = \"Again\"\ntype = \"UINT\"\naccess = \"rw\""),
            "object[0x2f00]",
            "index = 0x2F00\nname = \"Again\"",
        ),
        (
            STANDARD.replacen("default = 1270 ", "default = 1270\nmax = 1000 ", 1),
            "object[0x6076].default",
            "default = 1270",
        ),
        (
            STANDARD.replacen(
                "{ index = 0x6064, sub = 0, bits = 32 },  # position actual value",
                "{ index = 0x6064, sub = 0, bits = 32 },\n    { index = 0x6040, sub = 0, bits = 16 },  # RxPDO only",
                1,
            ),
            "txpdo[0x1a00].entries[2]",
            "# RxPDO only",
        ),
        (
            STANDARD.replacen("max_entries = 16", "max_entries = 2", 1),
            "rxpdo[0x1600].entries",
            "entries = [",
        ),
        (
            extra("[[object]]\nindex = 0x2F01\nname = \"T\"\ntype = \"UINT17\"\naccess = \"rw\""),
            "object[0x2f01].type",
            "type = \"UINT17\"",
        ),
    ];
    for (text, key, line_text) in cases {
        let err = od_gen::parse(&text, "p.toml").unwrap_err();
        let Error::Invalid {
            file, key: k, line, ..
        } = &err
        else {
            panic!("{err}")
        };
        assert_eq!(file, "p.toml", "{err}");
        assert_eq!(k, key, "{err}");
        let first = line_text.lines().next().unwrap();
        // The line of the value, or of the object/PDO header it belongs to.
        let value_line = text.lines().position(|l| l.contains(first)).unwrap() + 1;
        let line = line.unwrap_or_else(|| panic!("no line: {err}"));
        assert!(
            line == value_line
                || text
                    .lines()
                    .nth(line - 1)
                    .is_some_and(|l| l.starts_with("[[")),
            "{err}: line {line}, value at {value_line}"
        );
        assert!(
            err.to_string()
                .starts_with(&format!("p.toml:{line}: `{key}`")),
            "{err}"
        );
    }
}

#[test]
fn omit_must_be_a_boolean_and_false_keeps_the_object() {
    let text = |v: &str| {
        format!("name = \"e\"\ndescription = \"\"\nextends = \"standard\"\n[[object]]\nindex = 0x2F00\nomit = {v}\n")
    };
    match od_gen::parse(&text("\"yes\""), "e.toml") {
        Err(Error::Invalid { key, line, .. }) => {
            assert_eq!(key, "object[0x2f00].omit");
            assert_eq!(line, Some(6));
        }
        other => panic!("{other:?}"),
    }
    let kept = od_gen::parse(&text("false"), "e.toml").unwrap();
    assert!(kept.object(0x2F00).is_some());
    let gone = od_gen::parse(&text("true"), "e.toml").unwrap();
    assert!(gone.object(0x2F00).is_none());
}
