//! The generated Rust: sorted objects, RAM layout and defaults, cross-check assertions. (That it
//! compiles is checked by building the firmware, whose build script runs the generator.)

use od_gen::model::Storage;

fn generated() -> (od_gen::Profile, String) {
    let p = od_gen::builtin("standard").unwrap();
    let code = od_gen::rust::generate(std::slice::from_ref(&p));
    (p, code)
}

#[test]
fn module_shape() {
    let (_, code) = generated();
    for needle in [
        "pub const MAX_RAM_SIZE: usize = ",
        "pub static ALL: [&crate::profile::DriveProfile; 1] = [&standard::PROFILE];",
        "pub fn by_name(name: &str) -> Option<&'static crate::profile::DriveProfile>",
        "    ALL.iter().copied().find(|p| p.od.device.is_profile(name))",
        "use ::ethercat_slave::od::{Access, CoeDetails, DataType, DeviceInfo, Entry, EsmRules, Object, ObjectCode, PdoMappable, Profile, RxMappedWrite, SmLayout, SyncSupport, Value, ValueList};",
        "use crate::profile::{AccelerationUnit, AppVars, DriveProfile, Factor, FaultReport, Operand};",
        "pub mod standard {",
        "pub const RAM_SIZE: usize = ",
        "pub const OUTPUTS_SIZE: usize = 7;",
        "pub const INPUTS_SIZE: usize = 7;",
        "pub static PROFILE: DriveProfile = DriveProfile {",
        "        od: Profile {",
        "        axes: &[",
        "            AppVars {",
        "        motor_faults: &MOTOR_FAULTS,",
        "pub const MOTOR_FAULTS: [FaultReport; ",
        "const _: () = assert!(check::motor_fault_names_agree(&MOTOR_FAULT_NAMES)",
        "const _: () = assert!(::ethercat_slave::od::DataType::Unsigned16.code() == 0x0006",
        "const _: () = assert!(::ethercat_slave::od::Access::WRITE_PREOP == 0x08",
        "const _: () = assert!(super::check::objects_sorted(OBJECTS)",
        "const _: () = assert!(super::check::assigned_bits(OBJECTS, DEFAULTS, 0x1c12) == OUTPUTS_SIZE * 8",
        "vendor_id: 0x7e570402,",
        "outputs: SmLayout { start: 0x1200, length: 0, control: 0x64 },",
        "coe: CoeDetails { sdo: true, sdo_info: true, pdo_assign: true, pdo_config: true, upload_at_startup: false, complete_access: true },",
        "Entry { subindex: 0x00, name: \"Test domain\", data_type: DataType::Domain, bit_len: 0, access: Access::RW, pdo: PdoMappable::No, value: Value::Domain(0), default: &[], min: &[], max: &[] },",
    ] {
        assert!(code.contains(needle), "missing `{needle}`");
    }
    assert!(!code.contains("std::"), "generated code must be no_std");
}

/// For a device that is not a drive (and for the slave stack's own tests) the code holds the
/// object dictionaries alone: no CiA402 variables, no motor faults, paths into the stack.
#[test]
fn device_target_has_the_dictionary_only() {
    let p = od_gen::builtin("standard").unwrap();
    for (target, slave) in [
        (od_gen::rust::Target::DEVICE_CRATE, "::ethercat_slave"),
        (od_gen::rust::Target::SLAVE_CRATE, "crate"),
    ] {
        let code = od_gen::rust::generate_with(std::slice::from_ref(&p), &target);
        for needle in [
            format!("pub static ALL: [&{slave}::od::Profile; 1] = [&standard::PROFILE];"),
            "pub static PROFILE: Profile = Profile {".to_string(),
            "    ALL.iter().copied().find(|p| p.device.is_profile(name))".to_string(),
            format!("let storable = {slave}::params::is_storable(storage, &o[i], &e[j]);"),
            format!("pub const STORAGE: {slave}::od::StorageRules = {slave}::od::StorageRules {{"),
            format!("const _: () = assert!({slave}::od::DataType::Bit8.code() == 0x0037"),
        ] {
            assert!(code.contains(&needle), "missing `{needle}`");
        }
        for absent in ["AppVars", "MOTOR_FAULT", "DriveProfile", "motor::"] {
            assert!(!code.contains(absent), "{absent} in a device target");
        }
    }
}

#[test]
fn objects_sorted_in_the_text() {
    let (p, code) = generated();
    let indices: Vec<u16> = code
        .lines()
        .filter_map(|l| l.trim_start().strip_prefix("Object { index: 0x"))
        .map(|rest| u16::from_str_radix(&rest[..4], 16).unwrap())
        .collect();
    assert!(indices.windows(2).all(|w| w[0] < w[1]), "{indices:x?}");
    assert_eq!(
        indices,
        p.objects.iter().map(|o| o.index).collect::<Vec<_>>()
    );
    for idx in [
        0x1000, 0x1001, 0x1008, 0x1009, 0x100A, 0x1018, 0x1600, 0x1A00, 0x1C00, 0x1C12, 0x1C13,
        0x1C32, 0x1C33, 0x6040, 0x6041, 0x6060, 0x6061, 0x6064, 0x607A, 0x6502,
    ] {
        assert!(indices.contains(&idx), "{idx:#x} missing");
    }
}

#[test]
fn ram_image_holds_the_defaults() {
    let (p, code) = generated();
    let layout = od_gen::rust::ram_layout(&p);
    assert!(code.contains(&format!(
        "pub const RAM_SIZE: usize = {};",
        layout.image.len()
    )));
    // The default process data: each assigned PDO's entries one block, in mapping order (one
    // copy per PDO in the cycle).
    let assigned: Vec<_> = p
        .rx_pdos
        .iter()
        .chain(&p.tx_pdos)
        .filter(|pdo| pdo.assigned)
        .collect();
    assert!(!assigned.is_empty());
    let mut default_mapped = std::collections::BTreeSet::new();
    for pdo in &assigned {
        let mapped: Vec<_> = pdo.entries.iter().filter(|e| e.index != 0).collect();
        for pair in mapped.windows(2) {
            let (a, b) = (pair[0], pair[1]);
            let end = usize::from(layout.offsets[&(a.index, a.subindex)]) + usize::from(a.bits / 8);
            assert_eq!(
                usize::from(layout.offsets[&(b.index, b.subindex)]),
                end,
                "{:#x}: {:#x}:{} follows {:#x}:{}",
                pdo.index,
                b.index,
                b.subindex,
                a.index,
                a.subindex
            );
        }
        default_mapped.extend(mapped.iter().map(|e| (e.index, e.subindex)));
    }
    for o in &p.objects {
        for e in &o.entries {
            if e.storage == Storage::Ram {
                let off = usize::from(layout.offsets[&(o.index, e.subindex)]);
                assert_eq!(
                    &layout.image[off..off + e.byte_len()],
                    e.initial_bytes().as_slice(),
                    "{:#x}:{}",
                    o.index,
                    e.subindex
                );
                if e.byte_len() >= 2 && !default_mapped.contains(&(o.index, e.subindex)) {
                    assert_eq!(off % e.byte_len().min(4), 0, "aligned");
                }
            }
        }
    }
    // 1600h:01 = 6040h:00, 16 bit; 1C12h:01 = 1600h; 1000h const 0x00020192.
    let at = |i, s| usize::from(layout.offsets[&(i, s)]);
    assert_eq!(
        &layout.image[at(0x1600, 1)..at(0x1600, 1) + 4],
        &0x6040_0010u32.to_le_bytes()
    );
    assert_eq!(
        &layout.image[at(0x1A00, 2)..at(0x1A00, 2) + 4],
        &0x6064_0020u32.to_le_bytes()
    );
    assert_eq!(
        &layout.image[at(0x1C12, 1)..at(0x1C12, 1) + 2],
        &0x1600u16.to_le_bytes()
    );
    assert_eq!(layout.image[at(0x1C13, 0)], 1);
    assert!(
        code.contains("value: Value::Const(&[0x92, 0x01, 0x02, 0x00])"),
        "1000h device type"
    );
    // Roles point at the RAM variables.
    assert!(code.contains(&format!("controlword: Some({}),", at(0x6040, 0))));
    assert!(code.contains(&format!("position_actual_value: Some({}),", at(0x6064, 0))));
}

#[test]
fn sync_manager_parameters_and_access() {
    let p = od_gen::builtin("standard").unwrap();
    let o = p.object(0x1C32).unwrap();
    let subs: Vec<u8> = o.entries.iter().map(|e| e.subindex).collect();
    assert_eq!(subs, [0, 1, 2, 3, 4, 5, 6, 8, 9, 0x0B, 0x0C, 0x20]);
    for e in &o.entries[1..] {
        assert_eq!(e.storage, Storage::Ram, "1C32h:{:02x}", e.subindex);
        let writable = matches!(e.subindex, 1 | 2);
        assert_eq!(e.access.writable(), writable, "1C32h:{:02x}", e.subindex);
    }
    assert_eq!(
        p.entry(0x1C32, 4).unwrap().default,
        0x0007u16.to_le_bytes(),
        "free run + SM + DC SYNC0"
    );
    assert_eq!(p.entry(0x1C32, 5).unwrap().default, 31_250u32.to_le_bytes());
    assert_eq!(p.entry(0x1C00, 0).unwrap().default, [4]);
    for idx in [0x1600u16, 0x1A00, 0x1C12, 0x1C13] {
        for e in &p.object(idx).unwrap().entries {
            assert_eq!(
                e.access,
                od_gen::model::Access::RW_PREOP,
                "{idx:#x}:{}",
                e.subindex
            );
        }
    }
}

/// `MOTOR_FAULTS` lists the codes in the order of `MOTOR_FAULT_NAMES` (index = fault code − 1),
/// each commented with its name, and the profile points at it.
#[test]
fn motor_fault_table_order_matches_the_names() {
    use od_gen::model::MOTOR_FAULT_NAMES;
    let (p, code) = generated();
    let names: Vec<String> = MOTOR_FAULT_NAMES.iter().map(|n| format!("{n:?}")).collect();
    assert!(code.contains(&format!(
        "pub const MOTOR_FAULT_NAMES: [&str; 15] = [{}];",
        names.join(", ")
    )));
    assert!(code.contains("check::motor_fault_names_agree(&MOTOR_FAULT_NAMES)"));
    let start = code
        .find("pub const MOTOR_FAULTS: [FaultReport; 15] = [")
        .unwrap();
    let rows: Vec<&str> = code[start..]
        .lines()
        .skip(1)
        .take_while(|l| l.trim() != "];")
        .map(str::trim)
        .collect();
    let expected: Vec<String> = p
        .motor_faults
        .iter()
        .zip(MOTOR_FAULT_NAMES)
        .map(|(c, n)| {
            format!(
                "FaultReport {{ error_code: {:#06x}, emcy_code: {:#06x}, emcy_data: [0x00, 0x00, 0x00, 0x00, 0x00], alarm: None }}, // {n}",
                c.error_code, c.error_code
            )
        })
        .collect();
    assert_eq!(rows, expected);
    // over_current (code 1) first, identification (code 15) last, as in standard.toml.
    assert!(rows[0].contains("error_code: 0x2320") && rows[0].ends_with("// over_current"));
    assert!(rows[14].contains("error_code: 0x6320") && rows[14].ends_with("// identification"));
    assert!(code.contains("        motor_faults: &MOTOR_FAULTS,\n"));
}
