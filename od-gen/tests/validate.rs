//! Profile validation rejects bad profiles with the right error and key.

use od_gen::{Error, Invalid};

const STANDARD: &str = include_str!("../profiles/standard.toml");

fn with(from: &str, to: &str) -> String {
    assert!(
        STANDARD.contains(from),
        "test setup: `{from}` not in standard.toml"
    );
    STANDARD.replacen(from, to, 1)
}

fn appended(extra: &str) -> String {
    format!("{STANDARD}\n{extra}\n")
}

fn invalid(text: &str) -> (String, Invalid) {
    match od_gen::parse(text, "bad.toml") {
        Err(Error::Invalid {
            file, key, error, ..
        }) => {
            // The profile, or the library that wrote the value at fault.
            assert!(file == "bad.toml" || file.starts_with("library:"), "{file}");
            (key, error)
        }
        Err(e) => panic!("expected a validation error, got: {e}"),
        Ok(_) => panic!("expected a validation error, the profile loaded"),
    }
}

/// Every error `text` is refused with, in the order found.
fn all_invalid(text: &str) -> Vec<(String, Invalid)> {
    match od_gen::parse(text, "bad.toml") {
        Err(e) => e
            .invalids()
            .into_iter()
            .map(|(key, error)| (key.to_string(), error.clone()))
            .collect(),
        Ok(_) => panic!("expected a validation error, the profile loaded"),
    }
}

#[test]
fn standard_profile_is_valid() {
    let p = od_gen::parse(STANDARD, "standard.toml").unwrap();
    assert_eq!(p.name, "standard");
    assert!(od_gen::builtin_names().contains(&"standard"));
    assert_eq!(
        od_gen::builtin("standard").unwrap(),
        od_gen::parse(STANDARD, "builtin:standard").unwrap()
    );
}

#[test]
fn duplicate_index() {
    let (key, e) = invalid(&appended(
        "[[object]]\nindex = 0x6040\nname = \"Again\"\ntype = \"UINT\"\naccess = \"ro\"",
    ));
    assert_eq!(e, Invalid::DuplicateIndex(0x6040));
    assert_eq!(key, "object[0x6040]");
}

#[test]
fn duplicate_subindex() {
    let (_, e) = invalid(&appended(
        "[[object]]\nindex = 0x2000\nname = \"R\"\ncode = \"record\"\n\
         [[object.entry]]\nsub = 1\nname = \"a\"\ntype = \"UINT\"\naccess = \"ro\"\n\
         [[object.entry]]\nsub = 1\nname = \"b\"\ntype = \"UINT\"\naccess = \"ro\"",
    ));
    assert_eq!(e, Invalid::DuplicateSubindex(1));
}

#[test]
fn derived_object_declared() {
    let (_, e) = invalid(&appended(
        "[[object]]\nindex = 0x1C12\nname = \"x\"\ntype = \"UINT\"\naccess = \"ro\"",
    ));
    assert_eq!(
        e,
        Invalid::DerivedObject {
            index: 0x1C12,
            from: "sm"
        }
    );
    let (_, e) = invalid(&appended(
        "[[object]]\nindex = 0x1018\nname = \"x\"\ntype = \"UINT\"\naccess = \"ro\"",
    ));
    assert_eq!(
        e,
        Invalid::DerivedObject {
            index: 0x1018,
            from: "device"
        }
    );
}

#[test]
fn pdo_entry_missing() {
    let (key, e) = invalid(&with(
        "{ index = 0x6060, sub = 0, bits = 8 }",
        "{ index = 0x6080, sub = 0, bits = 32 }",
    ));
    assert_eq!(
        e,
        Invalid::PdoEntryMissing {
            index: 0x6080,
            subindex: 0
        }
    );
    assert_eq!(key, "rxpdo[0x1600].entries[2]");
    let (_, e) = invalid(&with(
        "{ index = 0x6060, sub = 0, bits = 8 }",
        "{ index = 0x6060, sub = 1, bits = 8 }",
    ));
    assert_eq!(
        e,
        Invalid::PdoEntryMissing {
            index: 0x6060,
            subindex: 1
        }
    );
}

#[test]
fn pdo_entry_not_mappable() {
    // 6502h is not mappable at all.
    let (_, e) = invalid(&with(
        "{ index = 0x6061, sub = 0, bits = 8 }",
        "{ index = 0x6502, sub = 0, bits = 32 }",
    ));
    assert_eq!(
        e,
        Invalid::PdoEntryNotMappable {
            index: 0x6502,
            subindex: 0
        }
    );
    // 6041h is TxPDO-mappable only.
    let (_, e) = invalid(&with(
        "{ index = 0x6060, sub = 0, bits = 8 }",
        "{ index = 0x6041, sub = 0, bits = 16 }",
    ));
    assert_eq!(
        e,
        Invalid::PdoEntryNotMappable {
            index: 0x6041,
            subindex: 0
        }
    );
}

#[test]
fn pdo_entry_wrong_bit_length() {
    let (_, e) = invalid(&with(
        "{ index = 0x6040, sub = 0, bits = 16 }",
        "{ index = 0x6040, sub = 0, bits = 32 }",
    ));
    assert_eq!(
        e,
        Invalid::PdoEntryBitLen {
            index: 0x6040,
            subindex: 0,
            pdo: 32,
            object: 16
        }
    );
}

#[test]
fn pdo_sm_and_index_range() {
    let (_, e) = invalid(&with(
        "index = 0x1600\nname = \"RxPDO 1 mapping\"\nsm = 2",
        "index = 0x1600\nname = \"RxPDO 1 mapping\"\nsm = 3",
    ));
    assert_eq!(e, Invalid::PdoSm { sm: 3, expected: 2 });
    let (_, e) = invalid(&with("index = 0x1600", "index = 0x1A05"));
    assert_eq!(e, Invalid::PdoIndexRange(0x1A05));
}

#[test]
fn too_many_pdo_entries() {
    let (_, e) = invalid(&with("max_entries = 16", "max_entries = 2"));
    assert_eq!(e, Invalid::TooManyPdoEntries { count: 3, max: 2 });
}

#[test]
fn role_on_wrong_type() {
    let (key, e) = invalid(&with(
        "index = 0x6040\nfrom = \"cia402\"",
        "index = 0x6040\nfrom = \"cia402\"\ntype = \"UDINT\"",
    ));
    assert_eq!(
        e,
        Invalid::RoleType {
            role: "controlword".into(),
            expected: "UINT"
        }
    );
    assert_eq!(key, "object[0x6040].role");
}

#[test]
fn duplicate_role() {
    // 2001h also becomes a process-data command that [storage] stores: reported as well.
    let all = all_invalid(&appended(
        "[[object]]\nindex = 0x2001\nname = \"x\"\ntype = \"UINT\"\naccess = \"rw\"\nrole = \"controlword\"",
    ));
    assert_eq!(all[0].1, Invalid::DuplicateRole("controlword".into()));
    assert!(
        matches!(&all[1], (key, Invalid::Storage(_)) if key == "object[0x2001]"),
        "{all:?}"
    );
}

#[test]
fn default_out_of_min_max() {
    let (key, e) = invalid(&appended(
        "[[object]]\nindex = 0x2002\nname = \"Limit\"\ntype = \"INT\"\naccess = \"rw\"\nmin = -10\nmax = 10\ndefault = 11",
    ));
    assert_eq!(e, Invalid::DefaultOutOfRange);
    assert_eq!(key, "object[0x2002].default");
    let (_, e) = invalid(&appended(
        "[[object]]\nindex = 0x2002\nname = \"Limit\"\ntype = \"INT\"\naccess = \"rw\"\nmin = 10\nmax = -10",
    ));
    assert_eq!(e, Invalid::DefaultOutOfRange);
    // Negative numbers compare as signed: -5 is inside -10..=10.
    assert!(od_gen::parse(
        &appended("[[object]]\nindex = 0x2002\nname = \"Limit\"\ntype = \"INT\"\naccess = \"rw\"\nmin = -10\nmax = 10\ndefault = -5"),
        "ok"
    )
    .is_ok());
}

#[test]
fn default_out_of_type_range() {
    let (_, e) = invalid(&appended("[[object]]\nindex = 0x2003\nname = \"x\"\ntype = \"USINT\"\naccess = \"rw\"\ndefault = 300"));
    assert!(matches!(e, Invalid::OutOfTypeRange(_)), "{e:?}");
}

#[test]
fn unknown_type() {
    let (_, e) = invalid(&appended(
        "[[object]]\nindex = 0x2004\nname = \"x\"\ntype = \"UINT16\"\naccess = \"rw\"",
    ));
    assert_eq!(e, Invalid::UnknownType("UINT16".into()));
}

#[test]
fn sm_overlap() {
    let (key, e) = invalid(&with(
        "outputs = { start = 0x1200",
        "outputs = { start = 0x1100",
    ));
    assert_eq!(
        e,
        Invalid::SmOverlap {
            a: "mailbox_in",
            b: "outputs"
        }
    );
    assert_eq!(key, "sm.outputs");
    // SM3 right behind one SM2 buffer: fine for 1 buffer, but SM2 uses 3 buffers (3 × 7 bytes).
    let (_, e) = invalid(&with(
        "inputs = { start = 0x1600",
        "inputs = { start = 0x1208",
    ));
    assert_eq!(
        e,
        Invalid::SmOverlap {
            a: "outputs",
            b: "inputs"
        }
    );
    assert!(od_gen::parse(
        &with("inputs = { start = 0x1600", "inputs = { start = 0x1216"),
        "ok"
    )
    .is_ok());
}

#[test]
fn sm_control_byte() {
    let (key, e) = invalid(&with(
        "size = 256, control = 0x26",
        "size = 256, control = 0x22",
    ));
    assert!(
        matches!(
            e,
            Invalid::SmControl {
                sm: "mailbox_out",
                control: 0x22,
                ..
            }
        ),
        "{e:?}"
    );
    assert_eq!(key, "sm.mailbox_out.control");
}

#[test]
fn dc_mode_needed_for_sync0() {
    let (_, e) = invalid(&with(
        "assign_activate = 0x0300",
        "assign_activate = 0x0100",
    ));
    assert!(matches!(e, Invalid::Sync(_)), "{e:?}");
}

#[test]
fn coe_flags_need_sdo() {
    let (_, e) = invalid(&with("sdo = true", "sdo = false"));
    assert!(matches!(e, Invalid::Mailbox(_)), "{e:?}");
}

#[test]
fn eeprom_size() {
    let (_, e) = invalid(&with("byte_size = 2048", "byte_size = 256"));
    assert!(
        matches!(e, Invalid::EepromTooSmall { declared: 256, .. }),
        "{e:?}"
    );
    let (_, e) = invalid(&with("byte_size = 2048", "byte_size = 3000"));
    assert!(matches!(e, Invalid::Value(_)), "{e:?}");
}

#[test]
fn unknown_key_is_a_parse_error_naming_the_key() {
    match od_gen::parse(
        &with("pdi_control = 0x05", "pdi_controll = 0x05"),
        "bad.toml",
    ) {
        Err(Error::Invalid {
            file,
            key,
            line,
            error: Invalid::Format(message),
        }) => {
            assert_eq!(file, "bad.toml");
            assert_eq!(key, "eeprom.pdi_controll");
            assert!(
                message.contains("unknown field `pdi_controll`"),
                "{message}"
            );
            // The line of the misspelt key in the file.
            let text = with("pdi_control = 0x05", "pdi_controll = 0x05");
            let expected = text
                .lines()
                .position(|l| l.starts_with("pdi_controll"))
                .unwrap()
                + 1;
            assert_eq!(line, Some(expected));
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn errors_name_file_and_key() {
    let err = od_gen::parse(
        &with(
            "{ index = 0x6040, sub = 0, bits = 16 }",
            "{ index = 0x6040, sub = 0, bits = 8 }",
        ),
        "x.toml",
    )
    .unwrap_err()
    .to_string();
    // File, line of the PDO entry, key.
    let line = STANDARD
        .lines()
        .position(|l| l.contains("{ index = 0x6040, sub = 0, bits = 16 }"))
        .unwrap()
        + 1;
    assert!(
        err.starts_with(&format!("x.toml:{line}: `rxpdo[0x1600].entries[0]`:")),
        "{err}"
    );
    assert!(od_gen::builtin("nope")
        .unwrap_err()
        .to_string()
        .contains("standard"));
}

#[test]
fn file_name_must_match_profile_name() {
    let dir = std::env::temp_dir().join(format!("od-gen-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let f = dir.join("other.toml");
    std::fs::write(&f, STANDARD).unwrap();
    let e = od_gen::load(&f).unwrap_err();
    assert!(
        matches!(e, Error::Invalid { ref key, .. } if key == "name"),
        "{e}"
    );
    let missing = od_gen::load(&dir.join("missing.toml")).unwrap_err();
    assert!(matches!(missing, Error::Io { .. }));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn domain_objects_need_type_domain_and_domain_storage() {
    // The standard profile's test domain 2FF0h is a domain entry of bit length 0.
    let p = od_gen::parse(STANDARD, "standard.toml").unwrap();
    let domain = p.objects.iter().find(|o| o.index == 0x2FF0).unwrap();
    let e = &domain.entries[0];
    assert_eq!(e.storage, od_gen::model::Storage::Domain);
    assert_eq!((e.data_type.code(), e.bit_len), (0x000F, 0));

    let obj = |extra: &str| {
        appended(&format!(
            "[[object]]\nindex = 0x2005\nname = \"d\"\naccess = \"rw\"\n{extra}"
        ))
    };
    let (key, e) = invalid(&obj("type = \"DOMAIN\""));
    assert_eq!(key, "object[0x2005].storage");
    assert!(matches!(e, Invalid::Value(_)), "{e:?}");
    let (key, _) = invalid(&obj("type = \"UDINT\"\nstorage = \"domain\""));
    assert_eq!(key, "object[0x2005].storage");
    let (key, e) = invalid(&obj("type = \"DOMAIN\"\nstorage = \"domain\"\ndefault = 1"));
    assert_eq!(
        (key.as_str(), e),
        ("object[0x2005].default", Invalid::NotAllowed("default"))
    );
    let (key, _) = invalid(&obj(
        "type = \"DOMAIN\"\nstorage = \"domain\"\npdo = \"tx\"",
    ));
    assert_eq!(key, "object[0x2005].pdo");
    assert!(od_gen::parse(&obj("type = \"DOMAIN\"\nstorage = \"domain\""), "ok").is_ok());
}

#[test]
fn domain_ids_follow_dictionary_order() {
    let text = appended(
        "[[object]]\nindex = 0x2005\nname = \"d\"\ntype = \"DOMAIN\"\naccess = \"rw\"\nstorage = \"domain\"",
    );
    let p = od_gen::parse(&text, "ok").unwrap();
    let layout = od_gen::rust::ram_layout(&p);
    assert_eq!(layout.domains.get(&(0x2005, 0)), Some(&0));
    assert_eq!(layout.domains.get(&(0x2FF0, 0)), Some(&1));
}

#[test]
fn esm_rules_parse_with_defaults_and_are_checked() {
    use od_gen::model::RxMappedWrite;
    let p = od_gen::parse(STANDARD, "standard.toml").unwrap();
    assert!(p.esm.op_requires_outputs);
    assert_eq!(p.esm.safeop_op_timeout_ms, 9000);
    assert_eq!(p.esm.op_exit_while_enabled_error, None);
    assert_eq!(p.sdo_write_to_rx_mapped, RxMappedWrite::Blocked);
    assert_eq!(p.sync.cycle_step_ns, 31_250);

    let set = with(
        "safeop_op_timeout_ms = 9000",
        "safeop_op_timeout_ms = 2500\nop_exit_while_enabled_error = 0x8700\nop_requires_outputs = false",
    );
    let set = set.replacen("op_requires_outputs = true\n", "", 1);
    let p = od_gen::parse(&set, "standard.toml").unwrap();
    assert_eq!(
        (
            p.esm.op_requires_outputs,
            p.esm.safeop_op_timeout_ms,
            p.esm.op_exit_while_enabled_error.map(|r| r.error_code)
        ),
        (false, 2500, Some(0x8700))
    );
    let rust = od_gen::rust::generate(&[p]);
    assert!(rust.contains(
        "esm: EsmRules { op_requires_outputs: false, safeop_op_timeout_ms: 2500, op_exit_while_enabled_error: Some(::ethercat_slave::od::ErrorReport { error_code: 0x8700, emcy_code: 0x8700, emcy_data: [0x00, 0x00, 0x00, 0x00, 0x00] }), al_error_alarms: &[], link_loss_error: None, sync_error_al_code: 0x001a, sync_lock_timeout_ms: None, pdi_error: None, lost_outputs: None, al_error_leds: &[] },"
    ));

    // Without [esm] and the new keys: the documented defaults.
    let bare = STANDARD
        .replacen("cycle_step_ns = 31_250\n", "", 1)
        .replacen("sdo_write_to_rx_mapped = \"blocked\"\n", "", 1);
    let start = bare.find("[esm]").unwrap();
    let end = bare[start..].find("[[dc_op_mode]]").unwrap() + start;
    let bare = format!("{}{}", &bare[..start], &bare[end..]);
    let p = od_gen::parse(&bare, "standard.toml").unwrap();
    assert!(p.esm.op_requires_outputs);
    assert_eq!(p.esm.safeop_op_timeout_ms, 9000);
    assert_eq!(p.sync.cycle_step_ns, 1);
    assert_eq!(p.sdo_write_to_rx_mapped, RxMappedWrite::Allowed);

    let (key, _) = invalid(&with(
        "safeop_op_timeout_ms = 9000",
        "safeop_op_timeout_ms = 0",
    ));
    assert_eq!(key, "esm.safeop_op_timeout_ms");
    let (key, _) = invalid(&with(
        "safeop_op_timeout_ms = 9000",
        "safeop_op_timeout_ms = 9000\nop_exit_while_enabled_error = 0",
    ));
    assert_eq!(key, "esm.op_exit_while_enabled_error");
    let (key, _) = invalid(&with(
        "sdo_write_to_rx_mapped = \"blocked\"",
        "sdo_write_to_rx_mapped = \"sometimes\"",
    ));
    assert_eq!(key, "pdo.sdo_write_to_rx_mapped");
}

#[test]
fn pdi_error_and_lost_outputs_rules_are_checked() {
    // A lost-outputs rule as the SDV3-E has it, on the standard profile's entries: the limit in
    // a writable integer parameter, 6061h (SINT) the selector; -1 is stored as 0xFF.
    let rule = |fields: &str| {
        with(
            "safeop_op_timeout_ms = 9000",
            &format!(
                "safeop_op_timeout_ms = 9000\npdi_error = 0x8500\nlost_outputs = {{ {fields} }}"
            ),
        )
    };
    let good = "limit_parameter = \"0x6060:0\", while_entry = \"0x6061:0\", while_values = [8, 9, 10, -1], al_status_code = 0x002C, error = 0x8102";
    let p = od_gen::parse(&rule(good), "standard.toml").unwrap();
    let l = p.esm.lost_outputs.clone().expect("rule");
    assert_eq!(
        (l.limit_parameter, l.while_entry),
        ((0x6060, 0), (0x6061, 0))
    );
    assert_eq!(l.al_status_code, 0x002C);
    assert_eq!(p.esm.pdi_error.map(|r| r.error_code), Some(0x8500));
    let rust = od_gen::rust::generate(&[p]);
    assert!(
        rust.contains("while_values: &[8, 9, 10, 255], al_status_code: 0x002c"),
        "raw SINT values"
    );
    assert!(rust.contains("pdi_error: Some(::ethercat_slave::od::ErrorReport { error_code: 0x8500"));

    let cases = [
        (
            good.replace("0x002C", "0x001B"),
            "esm.lost_outputs.al_status_code",
        ),
        (
            good.replace("[8, 9, 10, -1]", "[]"),
            "esm.lost_outputs.while_values",
        ),
        (good.replace("-1]", "200]"), "esm.lost_outputs.while_values"),
        (
            good.replace("\"0x6061:0\"", "\"6061\""),
            "esm.lost_outputs.while_entry",
        ),
        (
            good.replace("\"0x6061:0\"", "\"0x2FFF:0\""),
            "esm.lost_outputs.while_entry",
        ),
        (
            good.replace("\"0x6060:0\"", "\"0x6061:0\""),
            "esm.lost_outputs.limit_parameter",
        ),
        (good.replace("0x8102", "0"), "esm.lost_outputs.error"),
    ];
    for (fields, expected) in cases {
        let (key, _) = invalid(&rule(&fields));
        assert_eq!(key, expected, "{fields}");
    }
    let (key, _) = invalid(&with(
        "safeop_op_timeout_ms = 9000",
        "safeop_op_timeout_ms = 9000\npdi_error = 0",
    ));
    assert_eq!(key, "esm.pdi_error");
}

#[test]
fn cycle_step_must_divide_min_and_default_cycle() {
    let (key, e) = invalid(&with("cycle_step_ns = 31_250", "cycle_step_ns = 0"));
    assert_eq!(key, "sync.cycle_step_ns");
    assert!(matches!(e, Invalid::Sync(_)));
    let (key, _) = invalid(&with("cycle_step_ns = 31_250", "cycle_step_ns = 40_000"));
    assert_eq!(key, "sync.min_cycle_ns");
    let (key, _) = invalid(&with(
        "default_cycle_ns = 1_000_000",
        "default_cycle_ns = 1_000_001",
    ));
    assert_eq!(key, "sync.default_cycle_ns");
}

#[test]
fn settings_are_marked_per_entry_and_must_be_writable() {
    let p = od_gen::parse(STANDARD, "standard.toml").unwrap();
    let settings: Vec<u16> = p
        .objects
        .iter()
        .filter(|o| o.entries.iter().any(|e| e.setting))
        .map(|o| o.index)
        .collect();
    assert_eq!(settings, [0x2F00, 0x6060, 0x6076]);
    // On a RECORD object: every declared entry (not the generated subindex 0).
    let p = od_gen::parse(
        &appended(
            "[[object]]\nindex = 0x2001\nname = \"R\"\ncode = \"record\"\nsetting = true\n\
             [[object.entry]]\nsub = 1\nname = \"a\"\ntype = \"UINT\"\naccess = \"rw\"\n\
             [[object.entry]]\nsub = 2\nname = \"b\"\ntype = \"UINT\"\naccess = \"rw\"",
        ),
        "standard.toml",
    )
    .unwrap();
    let o = p.object(0x2001).unwrap();
    assert_eq!(
        o.entries.iter().map(|e| e.setting).collect::<Vec<_>>(),
        [false, true, true]
    );
    let (key, _) = invalid(&appended(
        "[[object]]\nindex = 0x2001\nname = \"C\"\ntype = \"UINT\"\naccess = \"ro\"\nsetting = true",
    ));
    assert_eq!(key, "object[0x2001].entry[0x00].setting");
}

#[test]
fn backup_follows_the_parameter_storage_rule() {
    let p = od_gen::parse(STANDARD, "standard.toml").unwrap();
    let backup = |i: u16, s: u8| {
        let o = p.object(i).unwrap();
        p.is_backup(o, o.entry(s).unwrap())
    };
    assert!(backup(0x2F00, 0), "RW RAM parameter");
    assert!(backup(0x1C12, 1), "PDO assignment");
    assert!(!backup(0x6040, 0), "process data");
    assert!(!backup(0x1010, 1), "store command");
    assert!(!backup(0x1C32, 1), "SM parameters");
    assert!(!backup(0x1018, 1), "constant");
}

/// The standard profile with its `[motor_faults]` table replaced by `table` (the whole section,
/// header included; empty: no table).
fn with_motor_faults(table: &str) -> String {
    let start = STANDARD.find("[motor_faults]").unwrap();
    let end = STANDARD[start..].find("[[rxpdo]]").unwrap() + start;
    format!("{}{table}\n{}", &STANDARD[..start], &STANDARD[end..])
}

/// A `[motor_faults]` section mapping each of `names` (in that order) to `code(name)`.
fn fault_table(names: &[&str], code: impl Fn(&str) -> u16) -> String {
    let mut t = String::from("[motor_faults]\n");
    for n in names {
        t.push_str(&format!("{n} = {:#06x}\n", code(n)));
    }
    t
}

#[test]
fn motor_faults_map_every_fault_of_the_standard_profile() {
    use od_gen::model::{MOTOR_FAULT_COUNT, MOTOR_FAULT_NAMES};
    let p = od_gen::parse(STANDARD, "standard.toml").unwrap();
    assert_eq!(p.motor_faults.len(), MOTOR_FAULT_COUNT);
    // Spot checks against the CiA402 table: DC link over-voltage, following error.
    let code = |name: &str| {
        let i = MOTOR_FAULT_NAMES.iter().position(|n| *n == name).unwrap();
        p.motor_faults[i].error_code
    };
    assert_eq!(code("bus_over_voltage"), 0x3210);
    assert_eq!(code("following_error"), 0x8611);
    assert!(p.motor_faults.iter().all(|c| c.error_code != 0));
}

#[test]
fn motor_faults_unknown_name_rejected() {
    let text = with(
        "over_current = 0x2320",
        "over_current = 0x2320\nover_currant = 0x2310",
    );
    let (key, e) = invalid(&text);
    assert_eq!(key, "motor_faults.over_currant");
    assert_eq!(e, Invalid::UnknownMotorFault("over_currant".into()));
    // The message names the profile, the key and the valid names.
    let msg = od_gen::parse(&text, "mine.toml").unwrap_err().to_string();
    assert!(
        msg.starts_with(&format!(
            "mine.toml:{}: `motor_faults.over_currant`: `over_currant` is not",
            text.lines()
                .position(|l| l.starts_with("over_currant"))
                .unwrap()
                + 1
        )),
        "{msg}"
    );
    for name in od_gen::model::MOTOR_FAULT_NAMES {
        assert!(msg.contains(name), "{msg} lacks {name}");
    }
}

#[test]
fn motor_faults_missing_name_rejected() {
    let (key, e) = invalid(&with("encoder_crc = 0x7300", ""));
    assert_eq!(key, "motor_faults");
    assert_eq!(e, Invalid::MissingMotorFaults(vec!["encoder_crc"]));
    let msg = od_gen::parse(&with("encoder_crc = 0x7300", ""), "mine.toml")
        .unwrap_err()
        .to_string();
    let section = STANDARD
        .lines()
        .position(|l| l == "[motor_faults]")
        .unwrap()
        + 1;
    assert!(
        msg.starts_with(&format!("mine.toml:{section}: `motor_faults`:")),
        "{msg}"
    );
    assert!(msg.contains("missing: encoder_crc"), "{msg}");

    // No table at all: every fault is missing, listed in code order.
    let (key, e) = invalid(&with_motor_faults(""));
    assert_eq!(key, "motor_faults");
    assert_eq!(
        e,
        Invalid::MissingMotorFaults(od_gen::model::MOTOR_FAULT_NAMES.to_vec())
    );
}

#[test]
fn motor_faults_zero_code_rejected() {
    let (key, e) = invalid(&with(
        "following_error = 0x8611",
        "following_error = 0x0000",
    ));
    assert_eq!(key, "motor_faults.following_error");
    assert!(
        matches!(e, Invalid::Value(ref s) if s.contains("no error")),
        "{e:?}"
    );
}

#[test]
fn motor_faults_code_wider_than_16_bits_is_a_parse_error() {
    let text = with("over_speed = 0x8400", "over_speed = 0x18400");
    match od_gen::parse(&text, "bad.toml") {
        Err(Error::Invalid {
            key,
            error: Invalid::Format(message),
            ..
        }) => {
            assert_eq!(key, "motor_faults.over_speed");
            assert!(
                message.contains("0x18400 is not a UINT error code"),
                "{message}"
            );
        }
        other => panic!("expected a format error, got {other:?}"),
    }
}

#[test]
fn motor_faults_are_ordered_by_fault_not_by_file_order() {
    use od_gen::model::MOTOR_FAULT_NAMES;
    // Written in reverse order, each code = 0x1000 + its position in MOTOR_FAULT_NAMES + 1.
    let position = |n: &str| MOTOR_FAULT_NAMES.iter().position(|m| *m == n).unwrap();
    let reversed: Vec<&str> = MOTOR_FAULT_NAMES.iter().rev().copied().collect();
    let text = with_motor_faults(&fault_table(&reversed, |n| 0x1001 + position(n) as u16));
    let p = od_gen::parse(&text, "standard.toml").unwrap();
    let expected: Vec<u16> = (0x1001..=0x100F).collect();
    let codes: Vec<u16> = p.motor_faults.iter().map(|c| c.error_code).collect();
    assert_eq!(codes, expected);
}

/// `kind`: a drive needs every motor fault mapped; a device has none, and says so.
#[test]
fn profile_kind_decides_whether_motor_faults_belong() {
    use od_gen::model::ProfileKind;
    let drive = od_gen::parse(STANDARD, "standard.toml").unwrap();
    assert_eq!(drive.kind, ProfileKind::Drive, "drive is the default");

    // A device without [motor_faults] loads, with no codes.
    let device = with_motor_faults("").replacen(
        "name = \"standard\"",
        "name = \"standard\"\nkind = \"device\"",
        1,
    );
    let p = od_gen::parse(&device, "standard.toml").unwrap();
    assert_eq!(p.kind, ProfileKind::Device);
    assert!(p.motor_faults.iter().all(|c| c.error_code == 0));

    // The same file as a drive lacks every fault.
    let drive_without = with_motor_faults("");
    let (key, e) = invalid(&drive_without);
    assert_eq!(key, "motor_faults");
    assert!(matches!(e, Invalid::MissingMotorFaults(_)), "{e:?}");

    // A device with motor faults is refused, as is an unknown kind.
    let (key, _) = invalid(&with(
        "name = \"standard\"",
        "name = \"standard\"\nkind = \"device\"",
    ));
    assert_eq!(key, "motor_faults");
    let (key, _) = invalid(&with(
        "name = \"standard\"",
        "name = \"standard\"\nkind = \"servo\"",
    ));
    assert_eq!(key, "kind");
}

#[test]
fn pdo_byte_and_assignment_limits() {
    // The standard default RxPDO maps 7 bytes (controlword, target position, mode).
    let (key, e) = invalid(&with(
        "max_entries = 16",
        "max_entries = 16\nmax_pdo_bytes = 6",
    ));
    assert_eq!(key, "rxpdo[0x1600].entries");
    assert!(
        matches!(e, Invalid::Value(ref m) if m.contains("max_pdo_bytes = 6")),
        "{e:?}"
    );
    let (key, _) = invalid(&with(
        "max_entries = 16",
        "max_entries = 16\nmax_process_bytes = 6",
    ));
    assert_eq!(key, "rxpdo");
    let (key, _) = invalid(&with(
        "max_entries = 16",
        "max_entries = 16\nmax_pdo_bytes = 257",
    ));
    assert_eq!(key, "pdo.max_pdo_bytes");
    let (key, _) = invalid(&with(
        "max_entries = 16",
        "max_entries = 16\nmax_assigned = 0",
    ));
    assert_eq!(key, "pdo.max_assigned");

    // Two RxPDOs, at most one assigned: 1C12h has subindex 1 only.
    let two = with(
        "max_entries = 16",
        "max_entries = 16\nmax_assigned = 1\nmax_pdo_bytes = 7\nmax_process_bytes = 7",
    ) + "\n[[rxpdo]]\nindex = 0x1601\nname = \"RxPDO 2\"\nsm = 2\nassigned = false\nentries = [{ index = 0x6040, sub = 0, bits = 16 }]\n";
    let p = od_gen::parse(&two, "p.toml").unwrap();
    let assign = p.object(0x1C12).unwrap();
    assert_eq!(assign.entries.len(), 2, "subindex 0 and 1");
    assert_eq!(assign.entries[0].max, vec![1]);
    assert_eq!((p.max_pdo_bytes, p.max_process_bytes), (7, 7));
    let unlimited = od_gen::builtin("standard").unwrap();
    assert_eq!(unlimited.max_pdo_bytes, od_gen::model::STACK_MAX_PDO_BYTES);
}

#[test]
fn entry_names_are_unique_within_an_object() {
    let text = appended(
        "[[object]]\nindex = 0x2003\nname = \"Group\"\ncode = \"record\"\n[[object.entry]]\nsub = 1\nname = \"Reserve\"\ntype = \"UINT\"\naccess = \"ro\"\n[[object.entry]]\nsub = 2\nname = \"Reserve\"\ntype = \"UINT\"\naccess = \"ro\"",
    );
    let (key, e) = invalid(&text);
    assert_eq!(key, "object[0x2003].entry[0x02].name");
    assert_eq!(e, Invalid::DuplicateEntryName("Reserve".into()));
}

#[test]
fn units_factors_name_unsigned_entries_or_constants() {
    use od_gen::model::{Factor, Operand};
    let p = od_gen::builtin("gha-e").unwrap();
    assert_eq!(
        p.units.position,
        Factor {
            numerator: Operand::Entry(0x6091, 1),
            denominator: Operand::Entry(0x6091, 2),
            scale: (1, 1)
        }
    );
    assert_eq!(
        p.units.velocity, p.units.position,
        "velocity = \"position\""
    );
    let sdv = od_gen::builtin("sdv3-e").unwrap();
    assert_eq!(sdv.units.velocity.numerator, Operand::CountsPerRev);
    assert_eq!(sdv.units.velocity.denominator, Operand::Const(600));
    assert_eq!(
        od_gen::builtin("standard").unwrap().units.position,
        Factor::ONE
    );

    let units = |t: &str| format!("{STANDARD}\n[units]\n{t}\n");
    let (key, _) = invalid(&units("position = { numerator = \"0x6091:1\" }"));
    assert_eq!(
        key, "units.position.numerator",
        "no 6091h in the standard profile"
    );
    let (key, _) = invalid(&units("position = { numerator = \"0x6064:0\" }"));
    assert_eq!(key, "units.position.numerator", "a signed entry");
    let (key, _) = invalid(&units("position = { numerator = 0 }"));
    assert_eq!(key, "units.position.numerator");
    let (key, _) = invalid(&units("velocity = { scale = [1, 0] }"));
    assert_eq!(key, "units.velocity.scale");
    let (key, _) = invalid(&units("velocity = { factor = 3 }"));
    assert_eq!(key, "units.velocity.factor");
    let ok = od_gen::parse(
        &units(
            "position = { numerator = \"0x6076:0\", denominator = 1000 }\nvelocity = \"position\"",
        ),
        "p.toml",
    )
    .unwrap();
    assert_eq!(ok.units.velocity.numerator, Operand::Entry(0x6076, 0));
}

#[test]
fn allowed_value_lists_are_checked() {
    let mode = |list: &str| {
        with(
            "default = 8             # cyclic synchronous position, the mode most EtherCAT masters run\nallowed = [-1, 0, 1, 3, 4, 6, 7, 8, 9, 10]   # 6502h; by PDO an unlisted mode is not taken (6061h)",
            &format!("default = 8\nallowed = {list}"),
        )
    };
    let p = od_gen::parse(&mode("[10, 8, 9, 0, -1]"), "p.toml").unwrap();
    assert_eq!(
        p.entry(0x6060, 0).unwrap().allowed,
        vec![-1, 0, 8, 9, 10],
        "sorted"
    );
    for (list, why) in [
        ("[9, 10]", "the default is not in the list"),
        ("[8, 8]", "listed twice"),
        ("[]", "empty"),
    ] {
        let (key, e) = invalid(&mode(list));
        assert_eq!(key, "object[0x6060].allowed", "{list}");
        assert!(
            matches!(e, Invalid::Value(ref m) if m.contains(why)),
            "{list}: {e:?}"
        );
    }
    // Values the type cannot hold.
    for list in ["[8, 200]", "[8, \"x\"]"] {
        let (key, _) = invalid(&mode(list));
        assert_eq!(key, "object[0x6060].allowed", "{list}");
    }
    let (key, _) = invalid(&appended(
        "[[object]]\nindex = 0x2003\nname = \"S\"\ntype = \"STRING\"\nbits = 16\naccess = \"rw\"\nallowed = [1]",
    ));
    assert_eq!(key, "object[0x2003].allowed");
}

#[test]
fn allowed_cycles_must_span_the_range_in_steps() {
    let set = |list: &str| {
        with(
            "cycle_step_ns = 31_250",
            &format!("cycle_step_ns = 31_250\nallowed_cycles_ns = {list}"),
        )
    };
    let p = od_gen::parse(&set("[31_250, 1_000_000, 10_000_000]"), "p.toml").unwrap();
    assert_eq!(
        p.sync.allowed_cycles_ns,
        vec![31_250, 1_000_000, 10_000_000]
    );
    for bad in [
        "[31_250, 10_000_000]",                       // no default (1 ms)
        "[1_000_000, 31_250, 10_000_000]",            // not ascending
        "[31_250, 1_000_000]",                        // does not reach max_cycle_ns
        "[31_250, 1_000_000, 1_000_001, 10_000_000]", // not a step multiple
    ] {
        let (key, _) = invalid(&set(bad));
        assert_eq!(key, "sync.allowed_cycles_ns", "{bad}");
    }
}

#[test]
fn sync_mode_default_and_writability() {
    let p = od_gen::builtin("rse").unwrap();
    let mode = p.entry(0x1C32, 1).unwrap();
    assert_eq!(mode.default, vec![2, 0], "DC SYNC0");
    assert!(!mode.access.writable());
    assert!(!p.entry(0x1C33, 2).unwrap().access.writable());
    let std = od_gen::builtin("standard").unwrap();
    assert_eq!(
        std.entry(0x1C32, 1).unwrap().default,
        vec![0, 0],
        "free run"
    );
    assert!(std.entry(0x1C32, 1).unwrap().access.writable());
    // SM-synchronous: 1C33h:01 = 0x22 (synchronous with SM2).
    let sm = od_gen::parse(
        &with(
            "dc_sync1 = false",
            "dc_sync1 = false\ndefault_sync_mode = \"sm_synchronous\"",
        ),
        "p.toml",
    )
    .unwrap();
    assert_eq!(sm.entry(0x1C32, 1).unwrap().default, vec![1, 0]);
    assert_eq!(sm.entry(0x1C33, 1).unwrap().default, vec![0x22, 0]);
    let (key, _) = invalid(&with(
        "dc_sync1 = false",
        "dc_sync1 = false\ndefault_sync_mode = \"dc_sync1\"",
    ));
    assert_eq!(key, "sync.default_sync_mode");
}

#[test]
fn free_run_range_input_shift_and_al_error_alarms() {
    // SDV3-E: the free-run range widens nothing (1 ms..10 ms inside 250 µs..10 ms); 1C33h:03 is
    // writable in PREOP with the range 0..max cycle − reserve.
    let p = od_gen::builtin("sdv3-e").unwrap();
    assert_eq!(p.sync.free_run_min_cycle_ns, 1_000_000);
    let cycle = p.entry(0x1C32, 2).unwrap();
    assert_eq!(cycle.min, 250_000u32.to_le_bytes().to_vec());
    let shift = p.entry(0x1C33, 3).unwrap();
    assert!(shift.access.writable());
    assert_eq!(shift.max, (10_000_000u32 - 62_500).to_le_bytes().to_vec());
    assert!(
        !p.entry(0x1C32, 3).unwrap().access.writable(),
        "1C32h:03 stays RO"
    );
    // A free-run range beyond the DC range widens the SDO range of 1C32h:02.
    let wide = od_gen::parse(
        &with(
            "cycle_step_ns = 31_250",
            "cycle_step_ns = 31_250\nfree_run_max_cycle_ns = 20_000_000",
        ),
        "p.toml",
    )
    .unwrap();
    let cycle = wide.entry(0x1C32, 2).unwrap();
    assert_eq!(cycle.max, 20_000_000u32.to_le_bytes().to_vec());
    assert!(!wide.entry(0x1C33, 3).unwrap().access.writable());

    // Errors: an empty free-run range, a default outside it, a shift without a step.
    let (key, _) = invalid(&with(
        "cycle_step_ns = 31_250",
        "cycle_step_ns = 31_250\nfree_run_min_cycle_ns = 5_000_000\nfree_run_max_cycle_ns = 4_000_000",
    ));
    assert_eq!(key, "sync.free_run_min_cycle_ns");
    let (key, _) = invalid(&with(
        "cycle_step_ns = 31_250",
        "cycle_step_ns = 31_250\nfree_run_min_cycle_ns = 2_000_000",
    ));
    assert_eq!(
        key, "sync.default_cycle_ns",
        "default 1 ms below the free-run range"
    );
    let (key, _) = invalid(&with(
        "cycle_step_ns = 31_250",
        "cycle_step_ns = 31_250\ninput_shift = { step_ns = 0 }",
    ));
    assert_eq!(key, "sync.input_shift");

    // [esm] al_error_alarms: sorted by code; an unknown alarm, a repeated code, code 0.
    let p = od_gen::builtin("rse").unwrap();
    let codes: Vec<u16> = p.esm.al_error_alarms.iter().map(|(c, _)| *c).collect();
    assert!(codes.windows(2).all(|w| w[0] < w[1]), "{codes:?}");
    let esm = |rows: &str| {
        with(
            "safeop_op_timeout_ms = 9000",
            &format!("safeop_op_timeout_ms = 9000\nal_error_alarms = [{rows}]"),
        )
    };
    let ok = od_gen::parse(
        &esm("{ al_status_code = 0x001A, error = 0x8700 }"),
        "p.toml",
    )
    .unwrap();
    assert_eq!(ok.esm.al_error_alarms[0].0, 0x001A);
    assert_eq!(ok.esm.al_error_alarms[0].1.error_code, 0x8700);
    let (key, _) = invalid(&esm("{ al_status_code = 0x001A, error = \"A.99\" }"));
    assert_eq!(key, "esm.al_error_alarms[0].error");
    let (key, _) = invalid(&esm(
        "{ al_status_code = 0x001A, error = 0x8700 }, { al_status_code = 0x001A, error = 0x8701 }",
    ));
    assert_eq!(key, "esm.al_error_alarms[1].al_status_code");
    let (key, _) = invalid(&esm("{ al_status_code = 0, error = 0x8700 }"));
    assert_eq!(key, "esm.al_error_alarms[0].al_status_code");
    let (key, _) = invalid(&esm("{ al_status_code = 0x001A, error = 0 }"));
    assert_eq!(key, "esm.al_error_alarms[0].error");
    // err_led: the manual's ERR LED pattern, generated sorted by code; an unknown pattern.
    let leds = od_gen::parse(
        &esm("{ al_status_code = 0x001B, error = 0x8100, err_led = \"single_flash\" }, { al_status_code = 0x001A, error = 0x8700, err_led = \"on\" }"),
        "p.toml",
    )
    .unwrap();
    assert_eq!(
        leds.esm.al_error_leds,
        [
            (0x001A, od_gen::model::ErrLed::On),
            (0x001B, od_gen::model::ErrLed::SingleFlash)
        ]
    );
    let rust = od_gen::rust::generate(&[leds]);
    assert!(rust.contains("al_error_leds: &[(0x001a, ::ethercat_slave::od::ErrLed::On), (0x001b, ::ethercat_slave::od::ErrLed::SingleFlash)] }"));
    assert!(ok.esm.al_error_leds.is_empty());
    let (key, _) = invalid(&esm(
        "{ al_status_code = 0x001A, error = 0x8700, err_led = \"disco\" }",
    ));
    assert_eq!(key, "esm.al_error_alarms[0].err_led");
}

#[test]
fn declared_sm_parameters_replace_the_generated_ones_and_are_checked_against_sync() {
    // Σ-V-SD §4.4 (3): the manual's layout.
    let p = od_gen::builtin("sigma-v-sd").unwrap();
    let o = p.object(0x1C32).unwrap();
    assert!(!o.derived);
    assert_eq!(o.entries.last().unwrap().subindex, 12);
    assert!(o.entry(0x20).is_none());
    assert_eq!(p.entry(0x1C33, 4).unwrap().default, vec![0x25, 0]);
    assert!(p.entry(0x1C33, 3).unwrap().access.writable());
    assert!(!p.entry(0x1C32, 2).unwrap().access.writable());
    // The standard profile keeps the generated objects.
    assert!(
        od_gen::builtin("standard")
            .unwrap()
            .object(0x1C32)
            .unwrap()
            .derived
    );

    let declared = |sync_extra: &str, entries: &str| {
        with(
            "cycle_step_ns = 31_250",
            &format!(
                "cycle_step_ns = 31_250\n{sync_extra}\n\n[[object]]\nindex = 0x1C32\nname = \"SM output parameter\"\ncode = \"record\"\nentry = [\n{entries}\n]\n\n[sync.dummy_never_used]",
            ),
        )
        .replace("\n\n[sync.dummy_never_used]", "")
    };
    // standard.toml: sync_mode_writable and cycle_time_writable default to true.
    let ok_entries = "{ sub = 1, name = \"Sync mode\", type = \"UINT\", access = \"rw_preop\", storage = \"ram\", default = 0 },\n\
        { sub = 2, name = \"Cycle time\", type = \"UDINT\", access = \"rw_preop\", storage = \"ram\", default = 1_000_000, min = 31_250, max = 10_000_000 },\n\
        { sub = 3, name = \"Shift time\", type = \"UDINT\", access = \"ro\", storage = \"const\", default = 5_000 },\n\
        { sub = 11, name = \"SM event missed\", type = \"UINT\", access = \"ro\", storage = \"ram\", default = 0 },";
    let p = od_gen::parse(&declared("", ok_entries), "p.toml").unwrap();
    assert_eq!(
        p.entry(0x1C32, 3).unwrap().default,
        5_000u32.to_le_bytes().to_vec()
    );
    assert!(p.entry(0x1C32, 0x20).is_none());
    assert!(p.object(0x1C33).unwrap().derived, "1C33h still generated");

    // :01 read-only while sync_mode_writable = true.
    let (key, _) = invalid(&declared(
        "",
        &ok_entries.replacen("access = \"rw_preop\"", "access = \"ro\"", 1),
    ));
    assert_eq!(key, "object[0x1c32].entry[1]");
    // :02 range narrower than the DC cycles.
    let (key, _) = invalid(&declared(
        "",
        &ok_entries.replace("min = 31_250", "min = 62_500"),
    ));
    assert_eq!(key, "object[0x1c32].entry[2]");
    // :02 not in RAM.
    let (key, _) = invalid(&declared(
        "",
        &ok_entries.replace(
            "type = \"UDINT\", access = \"rw_preop\", storage = \"ram\"",
            "type = \"UDINT\", access = \"ro\", storage = \"const\"",
        ),
    ));
    assert_eq!(key, "object[0x1c32].entry[2]");
    // 1C32h:03 writable.
    let (key, _) = invalid(&declared(
        "",
        &ok_entries.replace(
            "access = \"ro\", storage = \"const\", default = 5_000",
            "access = \"rw_preop\", storage = \"ram\", default = 5_000",
        ),
    ));
    assert_eq!(key, "object[0x1c32].entry[3]");
    // No missed-event counter at :0B (the default place).
    let (key, _) = invalid(&declared("", &ok_entries.replace("sub = 11", "sub = 13")));
    assert_eq!(key, "sync.sm_event_missed_subindex");
    // ... unless [sync] names where it is.
    assert!(od_gen::parse(
        &declared(
            "sm_event_missed_subindex = 13",
            &ok_entries.replace("sub = 11", "sub = 13")
        ),
        "p.toml"
    )
    .is_ok());
    // Other communication objects stay derived-only.
    let (key, _) = invalid(&appended(
        "[[object]]\nindex = 0x1C12\nname = \"x\"\ncode = \"array\"\nentry = [{ sub = 1, name = \"a\", type = \"UINT\", access = \"ro\", default = 0 }]",
    ));
    assert_eq!(key, "object[0x1c12]");
}

#[test]
fn declared_sm_parameters_agree_with_sync_on_defaults_modes_minimum_and_counter() {
    let declared = |sync_extra: &str, entries: &str| {
        with(
            "cycle_step_ns = 31_250",
            &format!(
                "cycle_step_ns = 31_250\n{sync_extra}\n\n[[object]]\nindex = 0x1C32\nname = \"SM output parameter\"\ncode = \"record\"\nentry = [\n{entries}\n]\n\n[sync.dummy_never_used]",
            ),
        )
        .replace("\n\n[sync.dummy_never_used]", "")
    };
    // standard.toml: default sync mode free run (0), default cycle 1 ms, modes 0x0007 (free run,
    // SM-synchronous, DC SYNC0), minimum cycle 31250 ns.
    let ok_entries = "{ sub = 1, name = \"Sync mode\", type = \"UINT\", access = \"rw_preop\", storage = \"ram\", default = 0 },\n\
        { sub = 2, name = \"Cycle time\", type = \"UDINT\", access = \"rw_preop\", storage = \"ram\", default = 1_000_000, min = 31_250, max = 10_000_000 },\n\
        { sub = 4, name = \"Sync modes supported\", type = \"UINT\", access = \"ro\", storage = \"const\", default = 0x4007 },\n\
        { sub = 5, name = \"Minimum cycle time\", type = \"UDINT\", access = \"ro\", storage = \"const\", default = 31_250 },\n\
        { sub = 11, name = \"SM event missed\", type = \"UINT\", access = \"ro\", storage = \"ram\", default = 0 },";
    assert!(od_gen::parse(&declared("", ok_entries), "p.toml").is_ok());

    // :01 default other than the default sync mode.
    let (key, _) = invalid(&declared(
        "",
        &ok_entries.replacen("default = 0 }", "default = 2 }", 1),
    ));
    assert_eq!(key, "object[0x1c32].entry[1]");
    // :02 default other than default_cycle_ns.
    let (key, _) = invalid(&declared(
        "",
        &ok_entries.replace("default = 1_000_000", "default = 2_000_000"),
    ));
    assert_eq!(key, "object[0x1c32].entry[2]");
    // :04 advertising SYNC1, which [sync] does not support (bits above 4 are free).
    let (key, _) = invalid(&declared(
        "",
        &ok_entries.replace("default = 0x4007", "default = 0x400F"),
    ));
    assert_eq!(key, "object[0x1c32].entry[4]");
    // :05 other than min_cycle_ns.
    let (key, _) = invalid(&declared(
        "",
        &ok_entries.replace("default = 31_250 }", "default = 0 }"),
    ));
    assert_eq!(key, "object[0x1c32].entry[5]");

    // A layout without a missed-event counter says so with sm_event_missed_subindex = 0 ...
    let no_counter = ok_entries.replace(
        "\n{ sub = 11, name = \"SM event missed\", type = \"UINT\", access = \"ro\", storage = \"ram\", default = 0 },",
        "",
    );
    assert_ne!(no_counter, ok_entries, "test setup");
    let (key, _) = invalid(&declared("", &no_counter));
    assert_eq!(key, "sync.sm_event_missed_subindex");
    let p = od_gen::parse(
        &declared("sm_event_missed_subindex = 0", &no_counter),
        "p.toml",
    )
    .expect("no counter");
    assert!(p.entry(0x1C32, 0x0B).is_none());
    // ... which the generated layout (it has :0B) does not take.
    let (key, _) = invalid(&with(
        "cycle_step_ns = 31_250",
        "cycle_step_ns = 31_250\nsm_event_missed_subindex = 0",
    ));
    assert_eq!(key, "sync.sm_event_missed_subindex");
}

#[test]
fn sync_error_code_and_lock_timeout_are_checked() {
    let esm = |extra: &str| {
        with(
            "safeop_op_timeout_ms = 9000",
            &format!("safeop_op_timeout_ms = 9000\n{extra}"),
        )
    };
    let p = od_gen::parse(
        &esm("sync_error_al_code = 0x002C\nsync_lock_timeout_ms = 2000"),
        "p.toml",
    )
    .unwrap();
    assert_eq!(
        (p.esm.sync_error_al_code, p.esm.sync_lock_timeout_ms),
        (0x002C, Some(2000))
    );
    let (key, _) = invalid(&esm("sync_error_al_code = 0x001B"));
    assert_eq!(key, "esm.sync_error_al_code");
    let (key, _) = invalid(&esm("sync_lock_timeout_ms = 0"));
    assert_eq!(key, "esm.sync_lock_timeout_ms");
    let (key, _) = invalid(&esm("link_loss_error = \"no-such-alarm\""));
    assert_eq!(key, "esm.link_loss_error");
    let (key, _) = invalid(&esm("link_loss_error = 0"));
    assert_eq!(key, "esm.link_loss_error");
    let sdv3e = od_gen::builtin("sdv3-e").unwrap();
    assert_eq!(
        sdv3e.esm.link_loss_error.map(|r| r.error_code),
        Some(0x8502),
        "§5.2 3) LL"
    );
    assert_eq!(sdv3e.esm.sync_error_al_code, 0x002C, "§5.2 5) cS");
    assert_eq!(sdv3e.esm.sync_lock_timeout_ms, Some(2000), "§5.2 7) PLF");
}

/// A 2310h-like adjusting record (Σ-V-SD §4.5 (8)) with `status_type` at :02, plus `service`.
fn with_adjusting(status_type: &str, service: &str) -> String {
    appended(&format!(
        "[[object]]\nindex = 0x2310\nname = \"Adjusting\"\ncode = \"record\"\n\
         [[object.entry]]\nsub = 1\nname = \"Command\"\ntype = \"STRING\"\nbits = 128\naccess = \"rw\"\ndefault = \"\"\n\
         [[object.entry]]\nsub = 2\nname = \"Status\"\ntype = \"{status_type}\"\naccess = \"ro\"\nstorage = \"ram\"\ndefault = 0\n\
         [[object.entry]]\nsub = 3\nname = \"Reply\"\ntype = \"STRING\"\nbits = 128\naccess = \"ro\"\nstorage = \"ram\"\ndefault = \"\"\n\
         {service}"
    ))
}

const SERVICE: &str = "[[adjusting]]\nobject = 0x2310\nabort_after_ms = 10_000\ntime_limit_ms = 5_000\n\
    commands = [{ code = 0x100E, action = \"current_offset_calibration\" }, { code = 0x1008, action = \"multi_turn_reset\", preparation = true }]\n";

#[test]
fn adjusting_services_are_resolved_and_checked() {
    let p = od_gen::parse(&with_adjusting("USINT", SERVICE), "ok").unwrap();
    assert_eq!(p.adjusting.len(), 1);
    let a = &p.adjusting[0];
    assert_eq!(
        (a.object, a.axis, a.abort_after_ms, a.time_limit_ms),
        (0x2310, 1, 10_000, 5_000)
    );
    assert_eq!(
        a.commands
            .iter()
            .map(|c| (c.code, c.action.name(), c.preparation))
            .collect::<Vec<_>>(),
        [
            (0x100E, "current_offset_calibration", false),
            (0x1008, "multi_turn_reset", true)
        ]
    );
    let rust = od_gen::rust::generate(&[p]);
    assert!(rust.contains("adjusting: &[crate::adjust::ServiceSpec { object: 0x2310, axis: 1,"));
    assert!(rust
        .contains("action: crate::adjust::Action::CurrentOffsetCalibration, preparation: false"));

    let cases = [
        (with_adjusting("UINT", SERVICE), "adjusting[0].object"),
        (
            with_adjusting("USINT", &SERVICE.replace("0x2310", "0x2311")),
            "adjusting[0].object",
        ),
        (
            with_adjusting("USINT", &SERVICE.replace("multi_turn_reset", "format_disk")),
            "adjusting[0].commands[1].action",
        ),
        (
            with_adjusting("USINT", &SERVICE.replace("0x1008", "0x100E")),
            "adjusting[0].commands[1].code",
        ),
        (
            with_adjusting("USINT", &SERVICE.replace("0x1008", "0")),
            "adjusting[0].commands[1].code",
        ),
        (
            with_adjusting(
                "USINT",
                &SERVICE.replace("time_limit_ms = 5_000", "time_limit_ms = 0"),
            ),
            "adjusting[0].time_limit_ms",
        ),
        (
            with_adjusting(
                "USINT",
                &SERVICE.replace("object = 0x2310", "object = 0x2310\naxis = 3"),
            ),
            "adjusting[0].axis",
        ),
        (
            with_adjusting("USINT", &format!("{SERVICE}{SERVICE}")),
            "adjusting[1].object",
        ),
    ];
    for (text, key) in cases {
        assert_eq!(invalid(&text).0, key);
    }
}

#[test]
fn acceleration_units_are_a_factor_or_ms_to_rpm() {
    let with_units = |u: &str| STANDARD.replace("[storage]", &format!("[units]\n{u}\n\n[storage]"));
    let p = od_gen::parse(&with_units("acceleration = { ms_to_rpm = 2000 }"), "ok").unwrap();
    assert_eq!(
        p.units.acceleration,
        od_gen::model::Acceleration::MsToRpm(2000)
    );
    assert!(
        od_gen::rust::generate(&[p]).contains("acceleration_unit: AccelerationUnit::MsToRpm(2000)")
    );
    let p = od_gen::parse(
        &with_units("acceleration = { numerator = 3, scale = [10000, 1] }"),
        "ok",
    )
    .unwrap();
    assert!(matches!(
        p.units.acceleration,
        od_gen::model::Acceleration::Factor(_)
    ));
    let p = od_gen::parse(STANDARD, "ok").unwrap();
    assert_eq!(
        p.units.acceleration,
        od_gen::model::Acceleration::VelocityPerSecond
    );
    for bad in [
        "acceleration = { ms_to_rpm = 0 }",
        "acceleration = { ms_to_rpm = 2000, numerator = 2 }",
    ] {
        let (key, _) = invalid(&with_units(bad));
        assert_eq!(key, "units.acceleration.ms_to_rpm", "{bad}");
    }
}

#[test]
fn cia402_rules_are_resolved_and_checked() {
    let p = od_gen::parse(
        &appended("[cia402]\nenable_without_mode_error = 0x8800"),
        "ok",
    )
    .unwrap();
    assert_eq!(
        p.cia402.enable_without_mode_error.map(|r| r.error_code),
        Some(0x8800)
    );
    let rust = od_gen::rust::generate(&[p]);
    assert!(rust.contains("cia402: crate::profile::Cia402Rules { enable_without_mode_error: Some(FaultReport { error_code: 0x8800"));
    // The SDV3-E's oPE also for a mode change while homing runs (§5.2 9).
    let sdv3 = od_gen::builtin("sdv3-e").unwrap();
    assert_eq!(
        sdv3.cia402
            .mode_change_while_homing_error
            .map(|r| r.error_code),
        Some(0x8800)
    );
    let p = od_gen::parse(STANDARD, "ok").unwrap();
    assert_eq!(p.cia402.enable_without_mode_error, None);
    assert!(!p.cia402.stops_end_switched_off);
    let p = od_gen::parse(&appended("[cia402]\nstops_end_switched_off = true"), "ok").unwrap();
    assert!(p.cia402.stops_end_switched_off);
    let rust = od_gen::rust::generate(&[p]);
    assert!(rust.contains(
        "enable_without_mode_error: None, mode_change_while_homing_error: None, stops_end_switched_off: true, switch_on_requires_main_power: false, pp_bit6_absolute: false, pp_change_on_set_point: true, pp_set_point_buffer: true, homing_methods: &[1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26, 27, 28, 29, 30, 33, 34, 35, 37], homing_method_aliases: &[], touch_probe: cia402::touch_probe::Rules { bit7: cia402::touch_probe::Bit7::None, bit6_shows_source: false, function_bits: 0xffff, off_while_homing: [false, false] }, following_error_fault: true, digital_inputs_limits_swapped: false, digital_inputs_without_interlock: false, following_error_zero_window_off: false, home_offset_added: false, home_offset_added_absolute: false, store_requires_power_cycle: &[], touch_probe_inputs: None, max_interpolation_speed: None, homing_error_alarm: None, safe_torque_off: None, torque_limit_statusword: None, csp_extrapolation: None, stop_codes: &[], fault_reaction_ignored: false, mode_statusword: &[], home_found_statusword: None, implied_option_codes: cia402::stop::OptionCodes { quick_stop: None, shutdown: None, disable_operation: None, halt: None, fault_reaction: None, vendor: &[] }, torque_modes_stop_at_once: false, torque_modes_halt_zero_torque: false, software_limits_off: None, software_limits_need_reference: false, software_limits_less_home_offset: false, homing: cia402::homing::Rules { here_while_disabled: false, start_while_disabled_error: false, here_needs_speed_zero: false }, mode_entry_starts: false, torque_reached: None, unit_ranges: None }"
    ));
    // A profile's own option codes: 605Bh = 2 stops on 6085h (the GHA-E), generated as the
    // firmware's VendorCode; an object outside 605Ah-605Eh and an unknown stop are refused.
    let p = od_gen::parse(
        &appended(
            "[cia402]\nfault_reaction_ignored = true\n[[cia402.stop_codes]]\nobject = \"0x605B\"\ncode = 2\nstop = \"quick_stop_ramp\"",
        ),
        "ok",
    )
    .unwrap();
    assert!(p.cia402.fault_reaction_ignored);
    let rust = od_gen::rust::generate(&[p]);
    assert!(rust.contains(
        "stop_codes: &[cia402::stop::VendorCode { cause: cia402::stop::Cause::Shutdown, code: 2, reaction: cia402::stop::Reaction { deceleration: cia402::stop::Deceleration::QuickStopRamp, after: cia402::stop::After::Disable } }], fault_reaction_ignored: true, mode_statusword: &[], home_found_statusword: None, implied_option_codes: cia402::stop::OptionCodes { quick_stop: None, shutdown: None, disable_operation: None, halt: None, fault_reaction: None, vendor: &[] }, torque_modes_stop_at_once: false, torque_modes_halt_zero_torque: false, software_limits_off: None, software_limits_need_reference: false, software_limits_less_home_offset: false, homing: cia402::homing::Rules { here_while_disabled: false, start_while_disabled_error: false, here_needs_speed_zero: false }, mode_entry_starts: false, torque_reached: None, unit_ranges: None }"
    ));
    for bad in [
        "[[cia402.stop_codes]]\nobject = \"0x6060\"\ncode = 2\nstop = \"coast\"",
        "[[cia402.stop_codes]]\nobject = \"0x605B\"\ncode = 2\nstop = \"brake\"",
    ] {
        let (key, _) = invalid(&appended(bad));
        assert_eq!(key, "cia402.stop_codes", "{bad}");
    }
    // A mode's statusword bits 10-13 where the manual differs from CiA402 (the SDV3-E's CSV:
    // speed arrival, speed zero, successful synchronisation), generated as the firmware's
    // mode_status::Override; unknown conditions, modes outside 1-10, a mode given twice and a
    // condition the drive does not work out in the mode are refused.
    let p = od_gen::parse(
        &appended(
            "[[cia402.mode_statusword]]\nmodes = [9]\nbits = [\"target_reached\", \"speed_zero\", \"synchronised\", \"nothing\"]",
        ),
        "ok",
    )
    .unwrap();
    assert!(od_gen::rust::generate(&[p]).contains(
        "mode_statusword: &[cia402::mode_status::Override { mode: 9, layout: cia402::mode_status::Layout { bits: [cia402::mode_status::Shows::TargetReached, cia402::mode_status::Shows::SpeedZero, cia402::mode_status::Shows::Synchronised, cia402::mode_status::Shows::Nothing] } }], home_found_statusword: None"
    ));
    for bad in [
        "modes = [9]\nbits = [\"speed_arrival\", \"nothing\", \"nothing\", \"nothing\"]",
        "modes = [11]\nbits = [\"nothing\", \"nothing\", \"nothing\", \"nothing\"]",
        "modes = [9, 9]\nbits = [\"nothing\", \"nothing\", \"nothing\", \"nothing\"]",
        "modes = []\nbits = [\"nothing\", \"nothing\", \"nothing\", \"nothing\"]",
        "modes = [10]\nbits = [\"target_reached\", \"nothing\", \"nothing\", \"nothing\"]",
        "modes = [9]\nbits = [\"nothing\", \"nothing\", \"following_error\", \"nothing\"]",
        // Torque reached only in PT/CST, and only with its parameters.
        "modes = [9]\nbits = [\"torque_reached\", \"nothing\", \"nothing\", \"nothing\"]",
        "modes = [10]\nbits = [\"torque_reached\", \"nothing\", \"nothing\", \"nothing\"]",
    ] {
        let (key, _) = invalid(&appended(&format!("[[cia402.mode_statusword]]\n{bad}")));
        assert_eq!(key, "cia402.mode_statusword", "{bad}");
    }
    // Unit ranges need positive ends with min ≤ max, and a known error.
    for bad in [
        "error = 0x6320\nposition = { min = [2, 1], max = [1, 1], inclusive = true }",
        "error = 0x6320\nvelocity = { min = [0, 1], max = [1, 1], inclusive = true }",
        "error = \"A.NONE\"",
    ] {
        let (key, _) = invalid(&appended(&format!("[cia402.unit_ranges]\n{bad}")));
        assert!(key.starts_with("cia402.unit_ranges"), "{bad}: {key}");
    }
    // The RSE's torque-reached parameters are generated as RAM operands.
    let rse = od_gen::builtin("rse").unwrap();
    assert!(od_gen::rust::generate(&[rse])
        .contains("torque_reached: Some([crate::profile::Operand::Ram {"));
    // The RSE's halt without 605Dh works as 605Dh = 1; a code is refused for an object the
    // profile has, and where CiA402 reserves it (no [[cia402.stop_codes]] meaning).
    let rse = od_gen::builtin("rse").unwrap();
    assert!(od_gen::rust::generate(&[rse]).contains(
        "implied_option_codes: cia402::stop::OptionCodes { quick_stop: None, shutdown: None, disable_operation: None, halt: Some(1), fault_reaction: None, vendor: &[] }"
    ));
    let sigma = od_gen::builtin("sigma-v-sd").unwrap();
    assert!(od_gen::rust::generate(&[sigma]).contains("torque_modes_stop_at_once: true"));
    let (key, _) = invalid(&appended(
        "[cia402.option_codes_without_object]\nquick_stop = 2",
    ));
    assert_eq!(
        key, "cia402.option_codes_without_object",
        "the profile has 605Ah"
    );
    // The GHA-E has no 605Dh: halt codes CiA402 reserves are refused there.
    const GHA_E: &str = include_str!("../profiles/gha-e.toml");
    for bad in ["halt = 0", "halt = 5"] {
        let text = format!("{GHA_E}\n[cia402.option_codes_without_object]\n{bad}\n");
        let (key, _) = invalid(&text);
        assert_eq!(key, "cia402.option_codes_without_object", "{bad}");
    }
    let ok = format!("{GHA_E}\n[cia402.option_codes_without_object]\nhalt = 2\n");
    assert!(od_gen::parse(&ok, "ok").is_ok());
    // The RSE's bit 15 "home found"; it may not share a bit with another flag.
    let rse = od_gen::builtin("rse").unwrap();
    assert!(od_gen::rust::generate(&[rse]).contains(
        "home_found_statusword: Some(crate::profile::StatuswordFlag { bit: 15, while_active: true })"
    ));
    let (key, _) = invalid(&appended(
        "[cia402.torque_limit_statusword]\nstatusword_bit = 15\nstatusword_while_active = true\n[cia402.home_found_statusword]\nstatusword_bit = 15\nstatusword_while_active = true",
    ));
    assert_eq!(key, "cia402.home_found_statusword.statusword_bit");
    let (key, _) = invalid(&appended(
        "[cia402.torque_limit_statusword]\nstatusword_bit = 11\nstatusword_while_active = true",
    ));
    assert_eq!(
        key, "cia402.torque_limit_statusword.statusword_bit",
        "bit 11 is CiA402's"
    );
    // The SDV3-E's P4.04 switches CSP extrapolation; it must be a writable integer parameter.
    let sdv3 = od_gen::builtin("sdv3-e").unwrap();
    assert_eq!(sdv3.cia402.csp_extrapolation, Some((0x3003, 4)));
    assert!(od_gen::rust::generate(&[sdv3])
        .contains("csp_extrapolation: Some(crate::profile::Operand::Ram {"));
    for bad in ["\"0x6041:0\"", "\"0x7777:1\"", "\"P4.04\""] {
        let (key, _) = invalid(&appended(&format!("[cia402]\ncsp_extrapolation = {bad}")));
        assert_eq!(key, "cia402.csp_extrapolation", "{bad}");
    }
    // The Σ-V-SD's HWBB display: statusword bit 15 (0 while active), 60FDh bits 24/25.
    let sigma = od_gen::builtin("sigma-v-sd").unwrap();
    assert!(od_gen::rust::generate(&[sigma]).contains(
        "safe_torque_off: Some(crate::profile::SafeTorqueOffDisplay { statusword: crate::profile::StatuswordFlag { bit: 15, while_active: false }, digital_input_bits: [24, 25] }), torque_limit_statusword: Some(crate::profile::StatuswordFlag { bit: 14, while_active: false })"
    ));
    for (bad, key) in [
        (
            "statusword_bit = 12",
            "cia402.safe_torque_off.statusword_bit",
        ),
        (
            "statusword_bit = 16",
            "cia402.safe_torque_off.statusword_bit",
        ),
        (
            "digital_input_bits = [3, 25]",
            "cia402.safe_torque_off.digital_input_bits",
        ),
        (
            "digital_input_bits = [24, 24]",
            "cia402.safe_torque_off.digital_input_bits",
        ),
        (
            "digital_input_bits = [24, 32]",
            "cia402.safe_torque_off.digital_input_bits",
        ),
    ] {
        let mut table = vec![
            "statusword_bit = 15",
            "statusword_while_active = false",
            "digital_input_bits = [24, 25]",
        ];
        let field = bad.split(' ').next().unwrap();
        table.retain(|line| !line.starts_with(field));
        table.push(bad);
        let (got, _) = invalid(&appended(&format!(
            "[cia402.safe_torque_off]\n{}",
            table.join("\n")
        )));
        assert_eq!(got, key, "{bad}");
    }
    // 1010h subindexes whose store needs a power cycle before Operation Enabled (Σ-V-SD 1, 4).
    let sigma = od_gen::builtin("sigma-v-sd").unwrap();
    assert_eq!(sigma.cia402.store_requires_power_cycle, [1, 4]);
    assert!(od_gen::rust::generate(&[sigma]).contains("store_requires_power_cycle: &[1, 4]"));
    for bad in ["[0]", "[128]", "[4, 1]", "[1, 1]"] {
        let (key, _) = invalid(&appended(&format!(
            "[cia402]\nstore_requires_power_cycle = {bad}"
        )));
        assert_eq!(key, "cia402.store_requires_power_cycle", "{bad}");
    }
    // The GHA-E's gear ratio in two forms; a radix below 2 or a read-only part is refused.
    let gha = od_gen::builtin("gha-e").unwrap();
    assert_eq!(gha.split_values.len(), 2);
    assert_eq!(
        (
            gha.split_values[0].whole,
            gha.split_values[0].high,
            gha.split_values[0].radix
        ),
        ((0x6091, 1), (0x2000, 7), 10_000)
    );
    for (table, key) in [
        (
            "whole = \"0x6040:0\"\nhigh = \"0x6040:0\"\nlow = \"0x6040:0\"\nradix = 1",
            "split_value[0].radix",
        ),
        (
            "whole = \"0x6041:0\"\nhigh = \"0x6040:0\"\nlow = \"0x6040:0\"\nradix = 10",
            "split_value[0].whole",
        ),
    ] {
        let (k, _) = invalid(&appended(&format!("[[split_value]]\n{table}")));
        assert_eq!(k, key, "{table}");
    }
    // The GHA-E's GOH on a failed homing run; an unknown alarm is refused.
    let gha = od_gen::builtin("gha-e").unwrap();
    assert_eq!(
        gha.cia402.homing_error_alarm.map(|c| c.error_code),
        Some(0x8613)
    );
    let (key, _) = invalid(&appended("[cia402]\nhoming_error_alarm = \"NoSuchAlarm\""));
    assert_eq!(key, "cia402.homing_error_alarm");
    // The Σ-V-SD's over-interpolation-speed guard; 0 would ignore every target.
    let sigma = od_gen::builtin("sigma-v-sd").unwrap();
    assert_eq!(sigma.cia402.max_interpolation_speed, Some(4_194_304));
    assert!(od_gen::rust::generate(&[sigma]).contains("max_interpolation_speed: Some(4194304)"));
    let (key, _) = invalid(&appended("[cia402]\nmax_interpolation_speed = 0"));
    assert_eq!(key, "cia402.max_interpolation_speed");
    // Probe inputs to assign first (the SDV3-E's EXT1/EXT2 = EI functions 40/41 on P3.03-P3.05).
    let sdv3 = od_gen::builtin("sdv3-e").unwrap();
    let t = sdv3.cia402.touch_probe_inputs.clone().expect("SDV3-E rule");
    assert_eq!(t.entries, [(0x3002, 3), (0x3002, 4), (0x3002, 5)]);
    assert_eq!(
        (t.functions, t.unassigned_error.error_code),
        ([40, 41], 0x8802)
    );
    let rust = od_gen::rust::generate(&[sdv3]);
    assert!(rust.contains("touch_probe_inputs: Some(crate::profile::ProbeInputAssignment { entries: &[crate::profile::Operand::Ram {"));
    for (table, key) in [
        (
            "entries = []\nfunctions = [40, 41]\nunassigned_error = 0x8802",
            "cia402.touch_probe_inputs.entries",
        ),
        (
            "entries = [\"0x6041:0\"]\nfunctions = [40, 41]\nunassigned_error = 0x8802",
            "cia402.touch_probe_inputs.entries",
        ),
        (
            "entries = [\"0x6040:0\"]\nfunctions = [40, 41]\nunassigned_error = \"NoSuchAlarm\"",
            "cia402.touch_probe_inputs.unassigned_error",
        ),
    ] {
        let (k, _) = invalid(&appended(&format!("[cia402.touch_probe_inputs]\n{table}")));
        assert_eq!(k, key, "{table}");
    }
    // 60B8h bits a profile defines: every bit unless the profile lists them (the Σ-V-SD's).
    let sigma = od_gen::builtin("sigma-v-sd").unwrap();
    assert_eq!(sigma.cia402.touch_probe_function_bits, 0x1317);
    assert!(od_gen::rust::generate(&[sigma]).contains("function_bits: 0x1317"));
    // Profile position: CiA402's bit 6 and bit 9 unless the profile says otherwise.
    let p = od_gen::parse(
        &appended("[cia402]\npp_bit6_absolute = true\npp_change_on_set_point = false\npp_set_point_buffer = false"),
        "ok",
    )
    .unwrap();
    assert!(p.cia402.pp_bit6_absolute && !p.cia402.pp_change_on_set_point);
    assert!(!p.cia402.pp_set_point_buffer);
    assert!(od_gen::rust::generate(&[p]).contains(
        "pp_bit6_absolute: true, pp_change_on_set_point: false, pp_set_point_buffer: false, homing_methods"
    ));
    // Homing methods: CiA402 methods or aliases, each once; the list comes out sorted.
    let p = od_gen::parse(
        &appended("[cia402]\nhoming_methods = [35, 1, 36]\nhoming_method_aliases = [[36, 19]]"),
        "ok",
    )
    .unwrap();
    assert_eq!(p.cia402.homing_methods, [1, 35, 36]);
    assert_eq!(p.cia402.homing_method_aliases, [(36, 19)]);
    // Touch probe status bits.
    let p = od_gen::parse(
        &appended("[cia402]\ntouch_probe_bit7 = \"level\"\ntouch_probe2_off_while_homing = true"),
        "ok",
    )
    .unwrap();
    let rust = od_gen::rust::generate(&[p]);
    assert!(rust.contains("bit7: cia402::touch_probe::Bit7::InputLevel, bit6_shows_source: false, function_bits: 0xffff, off_while_homing: [false, true]"));
    let (key, _) = invalid(&appended("[cia402]\ntouch_probe_bit7 = \"blink\""));
    assert_eq!(key, "cia402.touch_probe_bit7");
    for bad in [
        "homing_methods = [36]",
        "homing_methods = [1, 1]",
        "homing_method_aliases = [[40, 15]]",
        "homing_method_aliases = [[40, 1], [40, 2]]",
    ] {
        let (key, _) = invalid(&appended(&format!("[cia402]\n{bad}")));
        assert!(key.starts_with("cia402.homing_method"), "{bad}: {key}");
    }
    let p = od_gen::parse(
        &appended("[cia402]\nswitch_on_requires_main_power = true"),
        "ok",
    )
    .unwrap();
    assert!(p.cia402.switch_on_requires_main_power);
    let (key, _) = invalid(&appended("[cia402]\nenable_without_mode_error = 0"));
    assert_eq!(key, "cia402.enable_without_mode_error");
    let (key, _) = invalid(&appended("[cia402]\nenable_without_mode_error = \"A.99\""));
    assert_eq!(key, "cia402.enable_without_mode_error");
    let (key, _) = invalid(&appended("[cia402]\nenable_with_mode_error = 1"));
    assert!(key.starts_with("cia402"), "{key}");
}

/// A second axis needs its own copy of every CiA402 variable (`[[replicate]]`), and the firmware
/// runs at most two axes (Σ-V-SD §2.4: axis 2 at +800h).
#[test]
fn further_axes_need_their_own_variables() {
    let two = with("ds402_channels = 1", "ds402_channels = 2");
    let (key, error) = invalid(&two);
    assert_eq!(key, "device.ds402_channels");
    assert!(
        matches!(&error, Invalid::Value(m) if m.contains("axis 2 has no copy of 0x603f:0")),
        "{error:?}"
    );
    let replicated =
        format!("{two}\n[[replicate]]\nfirst = 0x6000\nlast = 0x67FF\noffset = 0x800\n");
    let p = od_gen::parse(&replicated, "standard.toml").expect("two axes with copies");
    assert_eq!(p.axis_count(), 2);
    assert_eq!(p.axis_index(0x607A, 1), 0x687A);
    // An object of the unit (outside every rule) is shared.
    assert_eq!(p.axis_index(0x1018, 1), 0x1018);
    // The copy of a role's entry is a RAM variable even where the original is read-only.
    let copy = p.entry(0x6876, 0).expect("6876h");
    assert_eq!(copy.storage, od_gen::model::Storage::Ram);

    let three = replicated.replacen("ds402_channels = 2", "ds402_channels = 3", 1);
    let (key, error) = invalid(&three);
    assert_eq!(key, "device.ds402_channels");
    assert!(
        matches!(&error, Invalid::Value(m) if m.contains("at most 2 axes")),
        "{error:?}"
    );
}

#[test]
fn the_emcy_axis_number_byte_lies_in_the_manufacturer_field() {
    for (byte, ok) in [(2, false), (3, true), (7, true), (8, false)] {
        let text = appended(&format!("[emcy]\naxis_number_byte = {byte}"));
        if ok {
            let p = od_gen::parse(&text, "standard.toml").expect("valid byte");
            assert_eq!(p.emcy.axis_number_byte, Some(byte));
        } else {
            let (key, _) = invalid(&text);
            assert_eq!(key, "emcy.axis_number_byte");
        }
    }
}

/// `[emcy] motor_fault_code`: every motor fault given by a code is sent with that emergency code
/// and its 603Fh code in two manufacturer bytes (the Σ-V-SD's FF00h, §2.7); the two bytes lie
/// in the field and clear of the axis number.
#[test]
fn the_emcy_motor_fault_code_carries_the_603fh_code_in_the_manufacturer_field() {
    let text = appended("[emcy]\nmotor_fault_code = 0xFF00\nmotor_fault_code_byte = 4");
    let p = od_gen::parse(&text, "standard.toml").expect("valid");
    assert_eq!(p.emcy.motor_fault_code, Some((0xFF00, 4)));
    for fault in &p.motor_faults {
        let [low, high] = fault.error_code.to_le_bytes();
        assert_eq!(fault.emcy.code, 0xFF00);
        assert_eq!(
            fault.emcy.data,
            [0, low, high, 0, 0],
            "{:04X}h",
            fault.error_code
        );
    }
    let plain = od_gen::parse(STANDARD, "standard.toml").expect("standard");
    assert!(plain
        .motor_faults
        .iter()
        .all(|f| f.emcy.code == f.error_code));
    for bad in [
        "motor_fault_code = 0xFF00",
        "motor_fault_code_byte = 4",
        "motor_fault_code = 0xFF00\nmotor_fault_code_byte = 2",
        "motor_fault_code = 0xFF00\nmotor_fault_code_byte = 7",
        "motor_fault_code = 0\nmotor_fault_code_byte = 4",
        "motor_fault_code = 0xFF00\nmotor_fault_code_byte = 4\naxis_number_byte = 5",
    ] {
        let (key, _) = invalid(&appended(&format!("[emcy]\n{bad}")));
        assert_eq!(key, "emcy.motor_fault_code", "{bad}");
    }
}

/// `[alarm_objects]`: the objects must be integer RAM entries, the numbers fit them, the clear
/// command needs a history.
#[test]
fn alarm_objects_are_checked() {
    let sdv3 = include_str!("../profiles/sdv3-e.toml");
    let p = od_gen::parse(sdv3, "sdv3-e.toml").expect("sdv3-e");
    assert_eq!(p.alarm_objects.active, Some(0x3202));
    let r = p.alarm_objects.history_record.as_ref().expect("records");
    assert_eq!(
        (r.select, r.object, r.fields.len()),
        ((0x3200, 0), 0x3201, 14)
    );
    // An active list in an object that does not exist.
    let bad = sdv3.replacen("active = \"0x3202\"", "active = \"0x3209\"", 1);
    let (key, _) = invalid_named(&bad, "sdv3-e.toml");
    assert_eq!(key, "alarm_objects.active");
    // Numbers by 603Fh do not fit 3202h's USINT entries.
    let bad = sdv3.replacen("number = \"error_number\"", "number = \"error_code\"", 1);
    let (key, error) = invalid_named(&bad, "sdv3-e.toml");
    assert_eq!(key, "alarm_objects.active");
    assert!(
        matches!(&error, Invalid::Value(m) if m.contains("does not fit")),
        "{error:?}"
    );
    // A field list that does not cover 3201h.
    let mode = "    \"mode\",                   # 14";
    assert!(sdv3.contains(mode), "test setup");
    let bad = sdv3.replacen(mode, "    # 14", 1);
    let (key, _) = invalid_named(&bad, "sdv3-e.toml");
    assert_eq!(key, "alarm_objects.history_fields");
    // A clear command without a history.
    let (key, _) = invalid(&appended("[alarm_objects]\nhistory_clear = \"0x6040:0\""));
    assert_eq!(key, "alarm_objects.history_clear");
}

fn invalid_named(text: &str, name: &str) -> (String, Invalid) {
    match od_gen::parse(text, name) {
        Err(Error::Invalid { key, error, .. }) => (key, error),
        Err(e) => panic!("expected a validation error, got: {e}"),
        Ok(_) => panic!("expected a validation error, the profile loaded"),
    }
}

/// `[warnings]`: known conditions, a load for the overloads only, alarms that are warnings.
#[test]
fn warnings_are_checked() {
    const ROW: &str = "motor_overload = { report = 0x2351, load_percent = 80 }";
    let p = od_gen::parse(STANDARD, "standard.toml").expect("valid");
    assert_eq!(
        p.warnings[0].condition,
        od_gen::model::WarningCondition::MotorOverload { percent: 80 }
    );
    for (bad, key) in [
        ("brake_worn = { report = 0x2351 }", "warnings.brake_worn"),
        (
            "drive_overload = { report = 0x2351 }",
            "warnings.drive_overload",
        ),
        (
            "drive_overload = { report = 0x2351, load_percent = 0 }",
            "warnings.drive_overload",
        ),
        (
            "positive_limit = { report = 0x8612, load_percent = 80 }",
            "warnings.positive_limit",
        ),
    ] {
        let (k, _) = invalid(&with(ROW, bad));
        assert_eq!(k, key, "{bad}");
    }
    // A fault alarm is not a warning (RSE AL.248 drive over temperature).
    let rse = include_str!("../profiles/rse.toml");
    let bad = rse.replacen("report = \"AL.460\"", "report = \"AL.248\"", 1);
    let (k, error) = invalid_named(&bad, "rse.toml");
    assert_eq!(k, "warnings.motor_overload");
    assert!(
        matches!(&error, Invalid::Value(m) if m.contains("not a warning")),
        "{error:?}"
    );
}

/// Three independent errors of one file: all three are reported, each with the line of its
/// value, in the order of the checks.
#[test]
fn every_error_of_a_file_is_reported_with_its_line() {
    let text = with("physics = \"YY\"", "physics = \"QQ\"")
        .replacen("byte_size = 2048", "byte_size = 1000", 1)
        .replacen("safeop_op_timeout_ms = 9000", "safeop_op_timeout_ms = 0", 1);
    let line_of = |needle: &str| {
        1 + text
            .lines()
            .position(|l| l.starts_with(needle))
            .expect("the changed line")
    };
    let e = od_gen::parse(&text, "bad.toml").expect_err("three errors");
    let Error::Several(errors) = &e else {
        panic!("expected every error, got one: {e}");
    };
    let found: Vec<(&str, Option<usize>)> = errors
        .iter()
        .map(|e| match e {
            Error::Invalid {
                file, key, line, ..
            } => {
                assert_eq!(file, "bad.toml");
                (key.as_str(), *line)
            }
            other => panic!("not a validation error: {other}"),
        })
        .collect();
    assert_eq!(
        found,
        [
            (
                "esm.safeop_op_timeout_ms",
                Some(line_of("safeop_op_timeout_ms"))
            ),
            ("device.physics", Some(line_of("physics"))),
            ("eeprom.byte_size", Some(line_of("byte_size"))),
        ]
    );
    // Displayed one per line, each `file:line: key: why`.
    let shown = e.to_string();
    let lines: Vec<&str> = shown.lines().collect();
    assert_eq!(lines.len(), 3, "{shown}");
    assert!(lines[0].starts_with(&format!(
        "bad.toml:{}: `esm.safeop_op_timeout_ms`",
        line_of("safeop_op_timeout_ms")
    )));
    assert_eq!(e.invalids().len(), 3);
}

/// Faulty declared objects are independent of each other: each one is reported, with its line,
/// not only the first.
#[test]
fn every_faulty_object_is_reported() {
    let text = appended(
        "[[object]]\nindex = 0x2002\nname = \"Limit\"\ntype = \"INT\"\naccess = \"rw\"\nmin = -10\nmax = 10\ndefault = 11\n\
         [[object]]\nindex = 0x2003\nname = \"Fine\"\ntype = \"INT\"\naccess = \"rw\"\ndefault = 1\n\
         [[object]]\nindex = 0x2004\nname = \"Also\"\ntype = \"UINT\"\naccess = \"rw\"\nmin = 5\nmax = 1\n\
         [[object]]\nindex = 0x6040\nname = \"Again\"\ntype = \"UINT\"\naccess = \"ro\"",
    );
    let all = all_invalid(&text);
    let keys: Vec<&str> = all.iter().map(|(k, _)| k.as_str()).collect();
    assert_eq!(
        keys,
        [
            "object[0x2002].default",
            "object[0x2004].default",
            "object[0x6040]"
        ],
        "{all:?}"
    );
    assert_eq!(all[0].1, Invalid::DefaultOutOfRange);
    assert_eq!(all[1].1, Invalid::DefaultOutOfRange);
    assert_eq!(all[2].1, Invalid::DuplicateIndex(0x6040));
    // Each with the line of its value.
    let e = od_gen::parse(&text, "bad.toml").expect_err("three faulty objects");
    let line_of = |needle: &str| 1 + text.lines().position(|l| l == needle).expect("line");
    let shown = e.to_string();
    assert!(
        shown.contains(&format!("bad.toml:{}:", line_of("default = 11"))),
        "{shown}"
    );
}

/// A check that needs an earlier one to pass is skipped when it failed: cycle step 0 is one
/// error, not a division by zero nor a fault of every cycle.
#[test]
fn dependent_checks_are_skipped_not_reported_twice() {
    let all = all_invalid(&with("cycle_step_ns = 31_250", "cycle_step_ns = 0"));
    assert_eq!(all.len(), 1, "{all:?}");
    assert_eq!(all[0].0, "sync.cycle_step_ns");
    // An empty range: one error, the cycles in it are not checked against it.
    let all = all_invalid(&with("max_cycle_ns = 10_000_000", "max_cycle_ns = 20_000"));
    assert_eq!(all.len(), 1, "{all:?}");
    assert_eq!(all[0].0, "sync.min_cycle_ns");
    assert!(matches!(&all[0].1, Invalid::Sync(m) if m.contains("0x0035")));
}

/// The longest cycle of a DC profile is one the firmware runs: a multiple of the step (the
/// firmware refuses others with AL status code 0x0036).
#[test]
fn the_longest_cycle_must_be_one_the_firmware_runs() {
    let (key, e) = invalid(&with(
        "max_cycle_ns = 10_000_000",
        "max_cycle_ns = 10_000_001",
    ));
    assert_eq!(key, "sync.max_cycle_ns");
    assert!(
        matches!(&e, Invalid::Sync(m) if m.contains("0x0036")),
        "{e}"
    );
}

/// An op mode's fixed SYNC0 cycle (factor 0) is the cycle a master configures from the ESI:
/// outside the profile's range it is refused (0x0035 at PREOP -> SAFEOP).
#[test]
fn a_fixed_sync0_cycle_must_be_one_the_firmware_runs() {
    let factor = "sync0_factor = 1              # SYNC0 cycle = 1 × the master's cycle";
    let (key, e) = invalid(&with(factor, "sync0_cycle_ns = 20_000"));
    assert_eq!(key, "dc_op_mode[1].sync0_cycle_ns");
    assert!(
        matches!(&e, Invalid::Sync(m) if m.contains("0x0035")),
        "{e}"
    );
    let (_, e) = invalid(&with(factor, "sync0_cycle_ns = 40_000"));
    assert!(
        matches!(&e, Invalid::Sync(m) if m.contains("0x0036")),
        "{e}"
    );
    let p = od_gen::parse(&with(factor, "sync0_cycle_ns = 62_500"), "standard.toml")
        .expect("a cycle the firmware runs");
    assert_eq!(p.dc_op_modes[1].sync0_cycle_ns, 62_500);
}

/// The firmware maps at most `hal::esc::MAX_FIRMWARE_MAPPED_ENTRIES` entries per direction: a
/// default assignment with more is refused (0x0025 / 0x0024 at PREOP -> SAFEOP), and so is a
/// PDO that alone maps more, or more bytes than `max_process_bytes`.
#[test]
fn pdos_beyond_what_the_firmware_maps_are_refused() {
    let limit = usize::from(hal::esc::MAX_FIRMWARE_MAPPED_ENTRIES);
    let entries = |n: usize| vec!["{ index = 0x6040, sub = 0, bits = 16 }"; n].join(", ");
    let rx = "entries = [\n    { index = 0x6040, sub = 0, bits = 16 },  # controlword\n    { index = 0x607A, sub = 0, bits = 32 },  # target position\n    { index = 0x6060, sub = 0, bits = 8 },   # modes of operation\n]";
    let mapping = |n: usize| {
        with("max_entries = 16", "max_entries = 254").replacen(
            rx,
            &format!("entries = [{}]", entries(n)),
            1,
        )
    };
    assert!(od_gen::parse(&mapping(limit), "standard.toml").is_ok());
    let (key, e) = invalid(&mapping(limit + 1));
    assert_eq!(key, "rxpdo");
    assert!(
        matches!(&e, Invalid::Value(m) if m.contains(&format!("{} entries", limit + 1)) && m.contains("0x0025")),
        "{e}"
    );
    // Not assigned by default: still refused whenever a master assigns it.
    let spare = |entries: String, extra: &str| {
        with("max_entries = 16", &format!("max_entries = 254{extra}")).replacen(
            "[[txpdo]]\nindex = 0x1A00",
            &format!(
                "[[rxpdo]]\nindex = 0x1601\nname = \"spare\"\nsm = 2\nassigned = false\n\
                 entries = [{entries}]\n\n[[txpdo]]\nindex = 0x1A00"
            ),
            1,
        )
    };
    let (key, e) = invalid(&spare(entries(limit + 1), ""));
    assert_eq!(key, "rxpdo[0x1601].entries");
    assert!(
        matches!(&e, Invalid::Value(m) if m.contains("0x0025")),
        "{e}"
    );
    let (key, e) = invalid(&spare(
        ["{ index = 0x607A, sub = 0, bits = 32 }"; 3].join(", "),
        "\nmax_process_bytes = 8",
    ));
    assert_eq!(key, "rxpdo[0x1601].entries");
    assert!(
        matches!(&e, Invalid::Value(m) if m.contains("12 bytes exceed pdo.max_process_bytes = 8")),
        "{e}"
    );
}
