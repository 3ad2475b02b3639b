//! The Rust object dictionary compiled into the firmware (`OUT_DIR/profiles.rs`) or into any
//! other crate built on the slave stack ([`Target`]).
//!
//! For every profile, [`generate_with`] emits a module
//!
//! ```text
//! pub mod <name> {
//!     pub const RAM_SIZE: usize;         // OD RAM bytes
//!     pub const OUTPUTS_SIZE: usize;     // SM2 default size (default RxPDO assignment)
//!     pub const INPUTS_SIZE: usize;      // SM3 default size (default TxPDO assignment)
//!     pub const DEFAULTS: &[u8];         // initial OD RAM image
//!     pub const OBJECTS: &[Object];      // sorted by index, entries by subindex
//!     pub const SETTINGS: &[(u16, u8)];  // startup parameters (`setting = true`)
//!     pub const BACKUP: &[(u16, u8)];    // entries the parameter storage stores
//!     pub const STORAGE: StorageRules;   // `[storage]`: groups, auto-store, write condition
//!     pub const MOTOR_FAULTS: [u16; N];  // drive targets: 603Fh/EMCY code per motor fault
//!     pub static PROFILE: DriveProfile;  // drive targets: { od: Profile, vars, motor_faults }
//!     pub static PROFILE: Profile;       // device targets: the object dictionary alone
//! }
//! ```
//!
//! plus `MAX_RAM_SIZE`, `ALL`, `by_name` (and, for drives, `MOTOR_FAULT_NAMES`: od-gen's list
//! of the internal motor faults, the order of every `MOTOR_FAULTS`) at the top level, and `const`
//! assertions: od-gen's CoE data-type codes and access bits equal the stack's
//! (`ethercat_slave::od`), `MOTOR_FAULT_NAMES` equals the drive's `motor::MotorFault::ALL`
//! (names, in code order), the objects and entries are sorted, every RAM variable lies inside
//! `RAM_SIZE`, the default PDO assignment read back from the generated 1C12h/1C13h and
//! 16xxh/1Axxh adds up to the SM2/SM3 sizes that the SII and the ESI carry, `BACKUP`
//! (od-gen's ESI `Flags/Backup`) is exactly what `ethercat_slave::params::is_storable` stores
//! under the profile's `STORAGE` rules, and the defaults of 1010h are the capabilities
//! `ethercat_slave::params::store_capabilities` writes back.
//! The code uses only `core` and the types of `ethercat_slave::od` (and of the drive crate's
//! `profile` module for drive targets).

use std::collections::BTreeMap;
use std::fmt::Write as _;

use crate::model::{
    Access, DataType, Entry, EntryRange, EntryTest, MotorFaultCode, Object, Profile, ProfileKind,
    Role, Sm, Storage, MOTOR_FAULT_NAMES, STACK_MAX_PDO_BYTES,
};

/// Where each RAM variable of a profile lives.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RamLayout {
    /// Byte offset of each RAM entry, by (index, subindex).
    pub offsets: BTreeMap<(u16, u8), u16>,
    /// The initial OD RAM image.
    pub image: Vec<u8>,
    /// Domain id of each `storage = "domain"` entry (0, 1, ... in dictionary order).
    pub domains: BTreeMap<(u16, u8), u8>,
}

/// Packs the RAM entries: first those the default-assigned RxPDOs and then TxPDOs map, in
/// mapping order and without gaps, so that the default process data are one block of the OD
/// RAM per direction (the copy plan then copies each PDO's run of adjacent entries at once,
/// not entry by entry); then the others in dictionary order, each aligned to its size (at most
/// 4 bytes; strings byte-aligned). Nothing relies on the alignment (the OD RAM is read and
/// written as bytes); it only packs the rest well.
pub fn ram_layout(p: &Profile) -> RamLayout {
    let mut offsets = BTreeMap::new();
    let mut image: Vec<u8> = Vec::new();
    let mut domains = BTreeMap::new();
    let entry = |index: u16, subindex: u8| {
        p.objects
            .iter()
            .find(|o| o.index == index)
            .and_then(|o| o.entries.iter().find(|e| e.subindex == subindex))
    };
    let mut place = |index: u16, e: &Entry, align: usize, image: &mut Vec<u8>| {
        if offsets.contains_key(&(index, e.subindex)) {
            return;
        }
        let at = image.len().div_ceil(align) * align;
        image.resize(at, 0);
        image.extend_from_slice(&e.initial_bytes());
        offsets.insert((index, e.subindex), u16::try_from(at).unwrap_or(u16::MAX));
    };
    for pdo in p
        .rx_pdos
        .iter()
        .chain(&p.tx_pdos)
        .filter(|pdo| pdo.assigned)
    {
        for mapped in &pdo.entries {
            if let Some(e) = entry(mapped.index, mapped.subindex) {
                if e.storage == Storage::Ram {
                    place(mapped.index, e, 1, &mut image);
                }
            }
        }
    }
    for o in &p.objects {
        for e in o.entries.iter().filter(|e| e.storage == Storage::Domain) {
            let id = u8::try_from(domains.len()).unwrap_or(u8::MAX);
            domains.insert((o.index, e.subindex), id);
        }
        for e in o.entries.iter().filter(|e| e.storage == Storage::Ram) {
            let align = if e.data_type.is_string() {
                1
            } else {
                e.byte_len().next_power_of_two().min(4)
            };
            place(o.index, e, align, &mut image);
        }
    }
    // Keep the size a multiple of 4 so that `[u8; RAM_SIZE]` arrays pack well.
    image.resize(image.len().div_ceil(4) * 4, 0);
    RamLayout {
        offsets,
        image,
        domains,
    }
}

/// A `firmware::profile::StatuswordFlag` literal.
fn statusword_flag(drive: &str, f: crate::model::StatuswordFlag) -> String {
    format!(
        "{drive}::profile::StatuswordFlag {{ bit: {}, while_active: {} }}",
        f.bit, f.while_active
    )
}

fn bytes(b: &[u8]) -> String {
    let items: Vec<String> = b.iter().map(|x| format!("{x:#04x}")).collect();
    format!("&[{}]", items.join(", "))
}

fn access(a: Access) -> String {
    match a.0 {
        0x07 => "Access::RO".into(),
        0x3F => "Access::RW".into(),
        0x0F => "Access::RW_PREOP".into(),
        0x1F => "Access::RW_PREOP_SAFEOP".into(),
        0x38 => "Access::WO".into(),
        x => format!("Access({x:#04x})"),
    }
}

fn sm(s: Sm, length: u16) -> String {
    format!(
        "SmLayout {{ start: {:#06x}, length: {length}, control: {:#04x} }}",
        s.start, s.control
    )
}

fn entry(out: &mut String, index: u16, e: &Entry, layout: &RamLayout) {
    let value = match e.storage {
        Storage::Domain => format!(
            "Value::Domain({})",
            layout
                .domains
                .get(&(index, e.subindex))
                .copied()
                .unwrap_or(0)
        ),
        Storage::Ram => format!(
            "Value::Ram({})",
            layout
                .offsets
                .get(&(index, e.subindex))
                .copied()
                .unwrap_or(0)
        ),
        Storage::Const => format!("Value::Const({})", bytes(&e.initial_bytes())),
    };
    let _ = writeln!(
        out,
        "            Entry {{ subindex: {:#04x}, name: {:?}, data_type: DataType::{}, bit_len: {}, access: {}, pdo: PdoMappable::{}, value: {value}, default: {}, min: {}, max: {} }},",
        e.subindex,
        e.name,
        e.data_type.rust_variant(),
        e.bit_len,
        access(e.access),
        e.pdo.rust_variant(),
        bytes(&e.default),
        bytes(&e.min),
        bytes(&e.max),
    );
}

fn module(out: &mut String, p: &Profile, target: &Target) {
    let layout = ram_layout(p);
    let out_size = p.outputs_bits() / 8;
    let in_size = p.inputs_bits() / 8;
    let file = std::path::Path::new(&p.source)
        .file_name()
        .map_or(p.source.clone(), |f| f.to_string_lossy().into_owned());
    let _ = writeln!(
        out,
        "/// Profile `{}`: {} (generated from `{file}`).",
        p.name, p.device.name
    );
    let _ = writeln!(out, "pub mod {} {{", p.module_name());
    if target.drive.is_some() && p.kind == ProfileKind::Device {
        let _ = writeln!(
            out,
            "    compile_error!(\"profile `{}` is a device profile (kind = \\\"device\\\"): it has no drive bindings\");",
            p.name
        );
    }
    let _ = writeln!(
        out,
        "    use {}::od::{{Access, CoeDetails, DataType, DeviceInfo, Entry, EsmRules, Object, ObjectCode, PdoMappable, Profile, RxMappedWrite, SmLayout, SyncSupport, Value, ValueList}};\n",
        target.slave
    );
    if let Some(drive) = target.drive {
        let _ = writeln!(
            out,
            "    use {drive}::profile::{{AccelerationUnit, AppVars, DriveProfile, Factor, FaultReport, Operand}};\n"
        );
    }
    let _ = writeln!(out, "    /// Size of the OD RAM in bytes.");
    let _ = writeln!(
        out,
        "    pub const RAM_SIZE: usize = {};",
        layout.image.len()
    );
    let _ = writeln!(out, "    /// SM2 default size in bytes: the default RxPDO assignment (SII SYNCM, ESI `Sm@DefaultSize`).");
    let _ = writeln!(out, "    pub const OUTPUTS_SIZE: usize = {out_size};");
    let _ = writeln!(
        out,
        "    /// SM3 default size in bytes: the default TxPDO assignment."
    );
    let _ = writeln!(out, "    pub const INPUTS_SIZE: usize = {in_size};");
    let _ = writeln!(out, "    /// Initial OD RAM content.");
    let _ = writeln!(
        out,
        "    pub const DEFAULTS: &[u8] = {};",
        bytes(&layout.image)
    );
    let _ = writeln!(out, "    /// All objects, sorted by index.");
    let _ = writeln!(out, "    pub const OBJECTS: &[Object] = &[");
    for o in &p.objects {
        let _ = writeln!(
            out,
            "        Object {{ index: {:#06x}, code: ObjectCode::{}, name: {:?}, entries: &[",
            o.index,
            o.code.rust_variant(),
            o.name
        );
        for e in &o.entries {
            entry(out, o.index, e, &layout);
        }
        let _ = writeln!(out, "        ] }},");
    }
    let _ = writeln!(out, "    ];");
    let lists: Vec<String> = p
        .objects
        .iter()
        .flat_map(|o| o.entries.iter().map(move |e| (o.index, e)))
        .filter(|(_, e)| !e.allowed.is_empty())
        .map(|(i, e)| {
            let values: Vec<String> = e.allowed.iter().map(i64::to_string).collect();
            format!(
                "ValueList {{ index: {i:#06x}, subindex: {:#04x}, values: &[{}] }}",
                e.subindex,
                values.join(", ")
            )
        })
        .collect();
    let _ = writeln!(
        out,
        "    /// Entries that accept only listed values (`allowed`), `(index, subindex)` ascending."
    );
    let _ = writeln!(
        out,
        "    pub const VALUE_LISTS: &[ValueList] = &[{}];",
        lists.join(", ")
    );
    let _ = writeln!(
        out,
        "    /// Startup parameters (`setting = true`), `(index, subindex)` ascending."
    );
    let _ = writeln!(
        out,
        "    pub const SETTINGS: &[(u16, u8)] = &[{}];",
        pairs(p, |_, e| e.setting)
    );
    let _ = writeln!(
        out,
        "    /// Entries the parameter storage stores (\"backup\", ESI `Flags/Backup`), as od-gen sees them."
    );
    let _ = writeln!(
        out,
        "    pub const BACKUP: &[(u16, u8)] = &[{}];",
        pairs(p, |o, e| p.is_backup(o, e))
    );
    storage(out, p, target);
    if target.drive.is_some() {
        let _ = writeln!(
            out,
            "    /// 603Fh code and EMCY of each internal motor fault (`[motor_faults]`), indexed by\n    /// `MotorFault::code() - 1` (the order of `super::MOTOR_FAULT_NAMES`)."
        );
        let _ = writeln!(
            out,
            "    pub const MOTOR_FAULTS: [FaultReport; {}] = [",
            p.motor_faults.len()
        );
        for (code, name) in p.motor_faults.iter().zip(MOTOR_FAULT_NAMES) {
            let d = code.emcy.data;
            let _ = writeln!(
                out,
                "        FaultReport {{ error_code: {:#06x}, emcy_code: {:#06x}, emcy_data: [{:#04x}, {:#04x}, {:#04x}, {:#04x}, {:#04x}], alarm: {} }}, // {name}",
                code.error_code, code.emcy.code, d[0], d[1], d[2], d[3], d[4], alarm_ref(code.alarm)
            );
        }
        let _ = writeln!(out, "    ];");
    }

    // The variable of role `r` on axis `axis` (0 = the first): the role's entry, or its copy
    // on a further axis (validate checked that the copies exist).
    let var = |r: Role, axis: u8| -> String {
        p.objects
            .iter()
            .flat_map(|o| o.entries.iter().map(move |e| (o.index, e)))
            .find(|(_, e)| e.role == Some(r))
            .and_then(|(i, e)| {
                layout
                    .offsets
                    .get(&(p.axis_index(i, axis), e.subindex))
                    .or_else(|| layout.offsets.get(&(i, e.subindex)))
            })
            .map_or("None".into(), |off| format!("Some({off})"))
    };
    let boot = |s: Option<Sm>| s.map_or("None".into(), |s| format!("Some({})", sm(s, s.length)));
    let c = p.mailbox.coe;
    let y = &p.sync;
    // The object dictionary: `PROFILE` itself, or the `od` of the drive profile.
    let (od_open, od_close, pad) = if target.drive.is_some() {
        (
            "    /// The profile.\n    pub static PROFILE: DriveProfile = DriveProfile {\n        od: Profile {",
            "        },",
            "    ",
        )
    } else {
        (
            "    /// The object dictionary of the profile.\n    pub static PROFILE: Profile = Profile {",
            "",
            "",
        )
    };
    let _ = writeln!(out, "{od_open}");
    let mut body = String::new();
    let out_outer = out;
    let out = &mut body;
    let _ = writeln!(out, "        device: DeviceInfo {{");
    let _ = writeln!(out, "            profile: {:?},", p.name);
    let _ = writeln!(out, "            name: {:?},", p.device.name);
    let _ = writeln!(out, "            vendor_id: {:#010x},", p.vendor.id);
    let _ = writeln!(
        out,
        "            product_code: {:#010x},",
        p.device.product_code
    );
    let _ = writeln!(out, "            revision: {:#010x},", p.device.revision);
    let _ = writeln!(
        out,
        "            mailbox_out: {},",
        sm(p.sm.mailbox_out, p.sm.mailbox_out.length)
    );
    let _ = writeln!(
        out,
        "            mailbox_in: {},",
        sm(p.sm.mailbox_in, p.sm.mailbox_in.length)
    );
    let _ = writeln!(
        out,
        "            boot_mailbox_out: {},",
        boot(p.sm.boot_out)
    );
    let _ = writeln!(out, "            boot_mailbox_in: {},", boot(p.sm.boot_in));
    let _ = writeln!(out, "            outputs: {},", sm(p.sm.outputs, 0));
    let _ = writeln!(out, "            inputs: {},", sm(p.sm.inputs, 0));
    let _ = writeln!(
        out,
        "            sync: SyncSupport {{ free_run: {}, sm_synchronous: {}, dc_sync0: {}, dc_sync1: {}, min_cycle_ns: {}, max_cycle_ns: {}, cycle_step_ns: {}, allowed_cycles_ns: &{:?}, sync_flag_in_sync: {}, free_run_min_cycle_ns: {}, free_run_max_cycle_ns: {}, input_shift_step_ns: {}, input_shift_reserve_ns: {}, input_shift_parameter: {:?}, sync_error_at_limit: {}, sync_error_on_missed_outputs: {}, sm_event_missed_subindex: {:#04x} }},",
        y.free_run, y.sm_synchronous, y.dc_sync0, y.dc_sync1, y.min_cycle_ns, y.max_cycle_ns, y.cycle_step_ns, y.allowed_cycles_ns, y.sync_flag_in_sync,
        y.free_run_min_cycle_ns, y.free_run_max_cycle_ns,
        y.input_shift.map_or(0, |i| i.step_ns), y.input_shift.map_or(0, |i| i.reserve_ns),
        y.input_shift.and_then(|i| i.parameter),
        y.sync_error_at_limit, y.sync_error_on_missed_outputs, y.sm_event_missed_subindex
    );
    let _ = writeln!(out, "            max_pdo_entries: {},", p.max_pdo_entries);
    let _ = writeln!(out, "            max_pdo_bytes: {},", p.max_pdo_bytes);
    let _ = writeln!(
        out,
        "            max_process_bytes: {},",
        p.max_process_bytes
    );
    let _ = writeln!(
        out,
        "            mailbox_protocols: {:#06x},",
        p.mailbox.protocols
    );
    let _ = writeln!(
        out,
        "            coe: CoeDetails {{ sdo: {}, sdo_info: {}, pdo_assign: {}, pdo_config: {}, upload_at_startup: {}, complete_access: {} }},",
        c.sdo, c.sdo_info, c.pdo_assign, c.pdo_config, c.upload_at_startup, c.complete_access
    );
    let m = &p.esm;
    let report = |c: &MotorFaultCode| {
        let d = c.emcy.data;
        format!(
            "{}::od::ErrorReport {{ error_code: {:#06x}, emcy_code: {:#06x}, emcy_data: [{:#04x}, {:#04x}, {:#04x}, {:#04x}, {:#04x}] }}",
            target.slave, c.error_code, c.emcy.code, d[0], d[1], d[2], d[3], d[4]
        )
    };
    let al_error_alarms: Vec<String> = m
        .al_error_alarms
        .iter()
        .map(|(code, c)| {
            format!(
                "{}::od::AlErrorAlarm {{ al_status_code: {code:#06x}, report: {} }}",
                target.slave,
                report(c)
            )
        })
        .collect();
    let _ = writeln!(
        out,
        "            esm: EsmRules {{ op_requires_outputs: {}, safeop_op_timeout_ms: {}, op_exit_while_enabled_error: {}, al_error_alarms: &[{}], link_loss_error: {}, sync_error_al_code: {:#06x}, sync_lock_timeout_ms: {:?}, pdi_error: {}, lost_outputs: {}, al_error_leds: &[{}] }},",
        m.op_requires_outputs,
        m.safeop_op_timeout_ms,
        m.op_exit_while_enabled_error
            .as_ref()
            .map_or("None".into(), |c| format!("Some({})", report(c))),
        al_error_alarms.join(", "),
        m.link_loss_error
            .as_ref()
            .map_or("None".into(), |c| format!("Some({})", report(c))),
        m.sync_error_al_code,
        m.sync_lock_timeout_ms,
        m.pdi_error
            .as_ref()
            .map_or("None".into(), |c| format!("Some({})", report(c))),
        m.lost_outputs.as_ref().map_or("None".into(), |l| {
            // validate checked that the entry exists and every value fits its type.
            let raw = p
                .entry(l.while_entry.0, l.while_entry.1)
                .and_then(|e| l.raw_values(e.data_type))
                .unwrap_or_default();
            format!(
                "Some({}::od::LostOutputsRule {{ limit_parameter: {:?}, while_entry: {:?}, while_values: &{:?}, al_status_code: {:#06x}, error: {} }})",
                target.slave,
                l.limit_parameter,
                l.while_entry,
                raw,
                l.al_status_code,
                report(&l.error)
            )
        }),
        m.al_error_leds
            .iter()
            .map(|(code, led)| format!(
                "({code:#06x}, {}::od::ErrLed::{})",
                target.slave,
                led.rust_variant()
            ))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let _ = writeln!(
        out,
        "            sdo_write_to_rx_mapped: RxMappedWrite::{},",
        p.sdo_write_to_rx_mapped.rust_variant()
    );
    let _ = writeln!(
        out,
        "            station_alias_parameter: {:?},",
        p.eeprom.station_alias_parameter
    );
    let _ = writeln!(
        out,
        "            station_alias_selector: {:?},",
        p.eeprom.station_alias_selector
    );
    let _ = writeln!(
        out,
        "            emcy: {}::od::EmcyRules {{ register_mask: {:#04x}, al_error_code: {:#06x} }},",
        target.slave, p.emcy.register_mask, p.emcy.al_error_code
    );
    let _ = writeln!(out, "            settings: SETTINGS,");
    let _ = writeln!(out, "        }},");
    let _ = writeln!(out, "        objects: OBJECTS,");
    let _ = writeln!(out, "        defaults: DEFAULTS,");
    let _ = writeln!(out, "        value_lists: VALUE_LISTS,");
    let _ = writeln!(out, "        storage: STORAGE,");
    let out = out_outer;
    for line in body.lines() {
        let _ = writeln!(out, "{pad}{line}");
    }
    if target.drive.is_some() {
        let _ = writeln!(out, "{od_close}");
        let _ = writeln!(out, "        axes: &[");
        for axis in 0..p.axis_count() {
            let _ = writeln!(out, "            // Axis {}.", axis + 1);
            let _ = writeln!(out, "            AppVars {{");
            for r in Role::ALL {
                let _ = writeln!(out, "                {}: {},", r.field(), var(r, axis));
            }
            let _ = writeln!(
                out,
                "                position_factor: {},",
                factor(p, &layout, &p.units.position, axis)
            );
            let _ = writeln!(
                out,
                "                velocity_factor: {},",
                factor(p, &layout, &p.units.velocity, axis)
            );
            let acceleration = match p.units.acceleration {
                crate::model::Acceleration::VelocityPerSecond => {
                    "AccelerationUnit::VelocityPerSecond".into()
                }
                crate::model::Acceleration::Factor(f) => {
                    format!("AccelerationUnit::Factor({})", factor(p, &layout, &f, axis))
                }
                crate::model::Acceleration::MsToRpm(rpm) => {
                    format!("AccelerationUnit::MsToRpm({rpm})")
                }
            };
            let _ = writeln!(out, "                acceleration_unit: {acceleration},");
            let _ = writeln!(
                out,
                "                velocity_window_factor: {},",
                factor(p, &layout, &p.units.velocity_window, axis)
            );
            let _ = writeln!(
                out,
                "                torque_factor: {},",
                factor(p, &layout, &p.units.torque, axis)
            );
            let _ = writeln!(out, "            }},");
        }
        let _ = writeln!(out, "        ],");
        let _ = writeln!(out, "        motor_faults: &MOTOR_FAULTS,");
        alarm_table(out, p, &layout, target.drive.unwrap_or("crate"));
        let drive = target.drive.unwrap_or("crate");
        let warnings: Vec<String> = p
            .warnings
            .iter()
            .map(|w| {
                let d = w.report.emcy.data;
                format!(
                    "{drive}::alarm_log::Warning {{ condition: {drive}::alarm_log::WarningCondition::{}, report: FaultReport {{ error_code: {:#06x}, emcy_code: {:#06x}, emcy_data: [{:#04x}, {:#04x}, {:#04x}, {:#04x}, {:#04x}], alarm: {} }} }}",
                    w.condition.rust_value(),
                    w.report.error_code,
                    w.report.emcy.code,
                    d[0], d[1], d[2], d[3], d[4],
                    alarm_ref(w.report.alarm)
                )
            })
            .collect();
        let _ = writeln!(out, "        warnings: &[{}],", warnings.join(", "));
        // Validated: writable integer parameters in RAM.
        let ram = |(index, sub): (u16, u8)| {
            let at = layout.offsets.get(&(index, sub)).copied().unwrap_or(0);
            let len = p.entry(index, sub).map_or(0, |e| e.byte_len());
            format!("{drive}::profile::Operand::Ram {{ at: {at}, len: {len} }}")
        };
        let splits: Vec<String> = p
            .split_values
            .iter()
            .map(|v| {
                format!(
                    "{drive}::profile::SplitValue {{ whole: {}, high: {}, low: {}, radix: {} }}",
                    ram(v.whole),
                    ram(v.high),
                    ram(v.low),
                    v.radix
                )
            })
            .collect();
        let _ = writeln!(out, "        split_values: &[{}],", splits.join(", "));
        let _ = writeln!(
            out,
            "        emcy_axis_number_byte: {:?},",
            p.emcy.axis_number_byte
        );
        let drive = target.drive.unwrap_or("crate");
        let services: Vec<String> = p
            .adjusting
            .iter()
            .map(|a| {
                // The adjusting module checked that the three entries are RAM variables.
                let at = |sub: u8| layout.offsets.get(&(a.object, sub)).copied().unwrap_or(0);
                let commands: Vec<String> = a
                    .commands
                    .iter()
                    .map(|c| {
                        format!(
                            "{drive}::adjust::CommandSpec {{ code: {:#06x}, action: {drive}::adjust::Action::{}, preparation: {} }}",
                            c.code,
                            c.action.rust_variant(),
                            c.preparation
                        )
                    })
                    .collect();
                format!(
                    "{drive}::adjust::ServiceSpec {{ object: {:#06x}, axis: {}, command_at: {}, status_at: {}, reply_at: {}, abort_after_ms: {}, time_limit_ms: {}, commands: &[{}] }}",
                    a.object,
                    a.axis,
                    at(1),
                    at(2),
                    at(3),
                    a.abort_after_ms,
                    a.time_limit_ms,
                    commands.join(", ")
                )
            })
            .collect();
        let _ = writeln!(out, "        adjusting: &[{}],", services.join(", "));
        // A parameter a rule reads (validated: a writable integer parameter in RAM).
        let ram_operand = |(index, sub): (u16, u8)| -> String {
            let at = layout.offsets.get(&(index, sub)).copied().unwrap_or(0);
            let len = p.entry(index, sub).map_or(0, |e| e.byte_len());
            format!("{drive}::profile::Operand::Ram {{ at: {at}, len: {len} }}")
        };
        let ram_parameter = |entry: Option<(u16, u8)>| -> String {
            entry.map_or("None".into(), |e| format!("Some({})", ram_operand(e)))
        };
        let _ = writeln!(
            out,
            "        cia402: {drive}::profile::Cia402Rules {{ enable_without_mode_error: {}, mode_change_while_homing_error: {}, stops_end_switched_off: {}, switch_on_requires_main_power: {}, pp_bit6_absolute: {}, pp_change_on_set_point: {}, pp_set_point_buffer: {}, homing_methods: &{:?}, homing_method_aliases: &{:?}, touch_probe: cia402::touch_probe::Rules {{ bit7: cia402::touch_probe::Bit7::{}, bit6_shows_source: {}, function_bits: {:#06x}, off_while_homing: [{}, {}] }}, following_error_fault: {}, digital_inputs_limits_swapped: {}, digital_inputs_without_interlock: {}, following_error_zero_window_off: {}, home_offset_added: {}, home_offset_added_absolute: {}, store_requires_power_cycle: &{:?}, touch_probe_inputs: {}, max_interpolation_speed: {:?}, homing_error_alarm: {}, safe_torque_off: {}, torque_limit_statusword: {}, csp_extrapolation: {}, stop_codes: &[{}], fault_reaction_ignored: {}, mode_statusword: &[{}], home_found_statusword: {}, implied_option_codes: cia402::stop::OptionCodes {{ quick_stop: {:?}, shutdown: {:?}, disable_operation: {:?}, halt: {:?}, fault_reaction: {:?}, vendor: &[] }}, torque_modes_stop_at_once: {}, torque_modes_halt_zero_torque: {}, software_limits_off: {}, software_limits_need_reference: {}, software_limits_less_home_offset: {}, homing: cia402::homing::Rules {{ here_while_disabled: {}, start_while_disabled_error: {}, here_needs_speed_zero: {} }}, mode_entry_starts: {}, torque_reached: {}, unit_ranges: {} }},",
            optional_fault_report(p.cia402.enable_without_mode_error.as_ref()),
            optional_fault_report(p.cia402.mode_change_while_homing_error.as_ref()),
            p.cia402.stops_end_switched_off,
            p.cia402.switch_on_requires_main_power,
            p.cia402.pp_bit6_absolute,
            p.cia402.pp_change_on_set_point,
            p.cia402.pp_set_point_buffer,
            p.cia402.homing_methods,
            p.cia402.homing_method_aliases,
            p.cia402.touch_probe_bit7.rust_variant(),
            p.cia402.touch_probe_bit6_source,
            p.cia402.touch_probe_function_bits,
            p.cia402.touch_probe1_off_while_homing,
            p.cia402.touch_probe2_off_while_homing,
            p.cia402.following_error_fault,
            p.cia402.digital_inputs_limits_swapped,
            p.cia402.digital_inputs_without_interlock,
            p.cia402.following_error_zero_window_off,
            p.cia402.home_offset_added,
            p.cia402.home_offset_added_absolute,
            p.cia402.store_requires_power_cycle,
            p.cia402.touch_probe_inputs.as_ref().map_or("None".into(), |t| format!(
                "Some({drive}::profile::ProbeInputAssignment {{ entries: &[{}], functions: {:?}, unassigned_error: {} }})",
                // Validated: writable integer parameters in RAM.
                t.entries
                    .iter()
                    .map(|&(index, sub)| {
                        let at = layout.offsets.get(&(index, sub)).copied().unwrap_or(0);
                        let len = p.entry(index, sub).map_or(0, |e| e.byte_len());
                        format!("{drive}::profile::Operand::Ram {{ at: {at}, len: {len} }}")
                    })
                    .collect::<Vec<_>>()
                    .join(", "),
                t.functions,
                fault_report(&t.unassigned_error)
            )),
            p.cia402.max_interpolation_speed,
            optional_fault_report(p.cia402.homing_error_alarm.as_ref()),
            p.cia402.safe_torque_off.map_or("None".into(), |s| format!(
                "Some({drive}::profile::SafeTorqueOffDisplay {{ statusword: {}, digital_input_bits: {:?} }})",
                statusword_flag(drive, s.statusword), s.digital_input_bits
            )),
            p.cia402.torque_limit_statusword.map_or("None".into(), |f| format!(
                "Some({})",
                statusword_flag(drive, f)
            )),
            ram_parameter(p.cia402.csp_extrapolation),
            p.cia402
                .stop_codes
                .iter()
                .map(|c| format!(
                    "cia402::stop::VendorCode {{ cause: cia402::stop::Cause::{}, code: {}, reaction: cia402::stop::Reaction {{ deceleration: cia402::stop::Deceleration::{}, after: cia402::stop::After::{} }} }}",
                    c.cause_variant(),
                    c.code,
                    c.stop.rust_variant(),
                    if c.hold { "Hold" } else { "Disable" }
                ))
                .collect::<Vec<_>>()
                .join(", "),
            p.cia402.fault_reaction_ignored,
            p.cia402
                .mode_statusword
                .iter()
                .map(|m| format!(
                    "cia402::mode_status::Override {{ mode: {}, layout: cia402::mode_status::Layout {{ bits: [{}] }} }}",
                    m.mode,
                    m.bits
                        .iter()
                        .map(|b| format!("cia402::mode_status::Shows::{b:?}"))
                        .collect::<Vec<_>>()
                        .join(", ")
                ))
                .collect::<Vec<_>>()
                .join(", "),
            p.cia402.home_found_statusword.map_or("None".into(), |f| format!(
                "Some({})",
                statusword_flag(drive, f)
            )),
            p.cia402.option_codes_without_object[0],
            p.cia402.option_codes_without_object[1],
            p.cia402.option_codes_without_object[2],
            p.cia402.option_codes_without_object[3],
            p.cia402.option_codes_without_object[4],
            p.cia402.torque_modes_stop_at_once,
            p.cia402.torque_modes_halt_zero_torque,
            ram_parameter(p.cia402.software_limits_off),
            p.cia402.software_limits_need_reference,
            p.cia402.software_limits_less_home_offset,
            p.cia402.homing_here_while_disabled,
            p.cia402.homing_start_while_disabled_error,
            p.cia402.homing_here_needs_speed_zero,
            p.cia402.mode_entry_starts,
            p.cia402.torque_reached.map_or("None".into(), |entries| {
                format!("Some([{}])", entries.map(ram_operand).join(", "))
            }),
            p.cia402.unit_ranges.map_or("None".into(), |u| {
                let range = |r: Option<crate::model::RatioRange>| {
                    r.map_or("None".into(), |r| {
                        format!(
                            "Some({drive}::profile::RatioRange {{ min: {:?}, max: {:?}, inclusive: {} }})",
                            r.min, r.max, r.inclusive
                        )
                    })
                };
                format!(
                    "Some({drive}::profile::UnitRanges {{ error: {}, position: {}, velocity: {}, acceleration: {}, torque: {} }})",
                    fault_report(&u.error),
                    range(u.position),
                    range(u.velocity),
                    range(u.acceleration),
                    range(u.torque)
                )
            })
        );
    }
    let _ = writeln!(out, "    }};\n");
    if let Some(drive) = target.drive {
        let _ = writeln!(
            out,
            "    const _: () = assert!({drive}::profile::MAX_AXES == {}, \"od-gen's axis limit differs from the firmware's\");",
            crate::validate::MAX_AXES
        );
        let _ = writeln!(
            out,
            "    const _: () = assert!({drive}::drive::MAX_SPLIT_VALUES == {}, \"od-gen's split-value limit differs from the firmware's\");",
            crate::validate::MAX_SPLIT_VALUES
        );
        let _ = writeln!(
            out,
            "    const _: () = assert!({drive}::alarm_log::MAX_RECORDS == {} && {drive}::alarm_log::MAX_FIELDS == {}, \"od-gen's alarm record limits differ from the firmware's\");",
            crate::validate::MAX_ALARM_RECORDS,
            crate::validate::MAX_ALARM_FIELDS
        );
    }
    let _ = writeln!(out, "    const _: () = assert!(DEFAULTS.len() == RAM_SIZE, \"RAM_SIZE differs from the defaults\");");
    let _ = writeln!(out, "    const _: () = assert!(super::check::objects_sorted(OBJECTS), \"objects not sorted by index\");");
    let _ = writeln!(out, "    const _: () = assert!(super::check::entries_sorted(OBJECTS), \"entries not sorted by subindex\");");
    let _ = writeln!(out, "    const _: () = assert!(super::check::ram_in_bounds(OBJECTS, RAM_SIZE), \"a RAM variable lies outside RAM_SIZE\");");
    let _ = writeln!(
        out,
        "    const _: () = assert!(super::check::assigned_bits(OBJECTS, DEFAULTS, 0x1c12) == OUTPUTS_SIZE * 8, \"default RxPDO mapping differs from the SM2 size in SII/ESI\");"
    );
    let _ = writeln!(
        out,
        "    const _: () = assert!(super::check::assigned_bits(OBJECTS, DEFAULTS, 0x1c13) == INPUTS_SIZE * 8, \"default TxPDO mapping differs from the SM3 size in SII/ESI\");"
    );
    let _ = writeln!(
        out,
        "    const _: () = assert!(super::check::backup_agrees(OBJECTS, &STORAGE, BACKUP), \"od-gen's backup flags differ from params::is_storable\");"
    );
    let _ = writeln!(
        out,
        "    const _: () = assert!(super::check::capabilities_agree(OBJECTS, DEFAULTS, &STORAGE), \"the defaults of 1010h differ from params::store_capabilities\");"
    );
    let _ = writeln!(out, "}}\n");
}

/// `alarms: AlarmTable { .. }`: every `[[alarm]]` with its number and whether a fault reset
/// clears it, and the RAM places of the `[alarm_objects]`.
fn alarm_table(out: &mut String, p: &Profile, layout: &RamLayout, drive: &str) {
    let a = &p.alarm_objects;
    let slot = |index: u16, sub: u8| -> Option<String> {
        let e = p.entry(index, sub)?;
        let at = layout.offsets.get(&(index, sub))?;
        Some(format!(
            "{drive}::alarm_log::Slot {{ at: {at}, len: {} }}",
            e.byte_len()
        ))
    };
    let slots = |index: Option<u16>| -> String {
        let list: Vec<String> = index
            .and_then(|i| p.object(i))
            .map(|o| {
                o.entries
                    .iter()
                    // The clear command may sit in the history object (the RSE's 200Bh:0Bh).
                    .filter(|e| e.subindex >= 1 && a.history_clear != Some((o.index, e.subindex)))
                    .filter_map(|e| slot(o.index, e.subindex))
                    .collect()
            })
            .unwrap_or_default();
        format!("&[{}]", list.join(", "))
    };
    let entries: Vec<String> = p
        .alarms
        .iter()
        .enumerate()
        .map(|(at, alarm)| {
            let d = alarm.emcy.data;
            format!(
                "{drive}::alarm_log::AlarmEntry {{ report: FaultReport {{ error_code: {:#06x}, emcy_code: {:#06x}, emcy_data: [{:#04x}, {:#04x}, {:#04x}, {:#04x}, {:#04x}], alarm: {} }}, number: {}, resettable: {} }}",
                alarm.error_code,
                alarm.emcy.code,
                d[0], d[1], d[2], d[3], d[4],
                alarm_ref(Some(at)),
                // validate checked that the numbers of a profile with alarm objects fit.
                a.number.of(alarm).and_then(|n| u16::try_from(n).ok()).unwrap_or(0),
                alarm.resettable
            )
        })
        .collect();
    let entry_ref = |(index, sub): (u16, u8)| -> Option<String> {
        slot(index, sub).map(|s| {
            format!(
                "{drive}::alarm_log::EntryRef {{ index: {index:#06x}, subindex: {sub:#04x}, slot: {s} }}"
            )
        })
    };
    let clear = a
        .history_clear
        .and_then(entry_ref)
        .map_or("None".into(), |s| format!("Some({s})"));
    let record = a.history_record.as_ref().map_or("None".into(), |r| {
        let fields: Vec<String> = p
            .object(r.object)
            .map(|o| {
                o.entries
                    .iter()
                    .filter(|e| e.subindex >= 1)
                    .zip(&r.fields)
                    .filter_map(|(e, f)| {
                        slot(r.object, e.subindex).map(|s| {
                            format!("({drive}::alarm_log::RecordField::{}, {s})", f.rust_variant())
                        })
                    })
                    .collect()
            })
            .unwrap_or_default();
        let records = p
            .entry(r.select.0, r.select.1)
            .and_then(|e| {
                let mut b = [0u8; 4];
                for (d, s) in b.iter_mut().zip(&e.max) {
                    *d = *s;
                }
                u8::try_from(u32::from_le_bytes(b)).ok()
            })
            .unwrap_or(1);
        // validate checked that the selector is a RAM entry.
        match entry_ref(r.select) {
            Some(select) => format!(
                "Some({drive}::alarm_log::RecordSpec {{ select: {select}, records: {records}, fields: &[{}] }})",
                fields.join(", ")
            ),
            None => "None".into(),
        }
    });
    let _ = writeln!(
        out,
        "        alarms: {drive}::alarm_log::AlarmTable {{ entries: &[{}], active: {}, history: {}, history_clear: {clear}, record: {record} }},",
        entries.join(", "),
        slots(a.active),
        slots(a.history)
    );
}

/// A `[units]` factor of axis `axis` (0 = the first; its copies of the factor's objects) as the
/// firmware's `Factor`: entries in the OD RAM by offset and length, constant entries by their
/// value.
/// A `FaultReport` literal of `c` (603Fh code, EMCY code and manufacturer field).
fn fault_report(c: &MotorFaultCode) -> String {
    format!(
        "FaultReport {{ error_code: {:#06x}, emcy_code: {:#06x}, emcy_data: {:?}, alarm: {} }}",
        c.error_code,
        c.emcy.code,
        c.emcy.data,
        alarm_ref(c.alarm)
    )
}

/// `FaultReport::alarm` of the `[[alarm]]` at `at` (`None`: no alarm).
fn alarm_ref(at: Option<usize>) -> String {
    at.map_or("None".into(), |i| format!("Some({i})"))
}

/// `Some(FaultReport { .. })` of `c`, or `None`.
fn optional_fault_report(c: Option<&MotorFaultCode>) -> String {
    c.map_or("None".into(), |c| format!("Some({})", fault_report(c)))
}

fn factor(p: &Profile, layout: &RamLayout, f: &crate::model::Factor, axis: u8) -> String {
    use crate::model::Operand as O;
    let side = |o: &O| -> String {
        match *o {
            O::Const(v) => format!("Operand::Const({v})"),
            O::CountsPerRev => "Operand::CountsPerRev".into(),
            O::Entry(index, sub) => {
                let index = p.axis_index(index, axis);
                let e = p.entry(index, sub);
                match (layout.offsets.get(&(index, sub)), e) {
                    (Some(at), Some(e)) => {
                        format!("Operand::Ram {{ at: {at}, len: {} }}", e.byte_len())
                    }
                    (None, Some(e)) => {
                        let mut v = [0u8; 4];
                        for (d, s) in v.iter_mut().zip(&e.default) {
                            *d = *s;
                        }
                        format!("Operand::Const({})", u32::from_le_bytes(v).max(1))
                    }
                    _ => "Operand::Const(1)".into(),
                }
            }
        }
    };
    format!(
        "Factor {{ numerator: {}, denominator: {}, scale: ({}, {}) }}",
        side(&f.numerator),
        side(&f.denominator),
        f.scale.0,
        f.scale.1
    )
}

/// `STORAGE`: the profile's `[storage]` rules as `od::StorageRules`.
fn storage(out: &mut String, p: &Profile, target: &Target) {
    let od = format!("{}::od", target.slave);
    let ranges = |list: &[EntryRange]| -> String {
        let items: Vec<String> = list
            .iter()
            .map(|r| {
                format!(
                    "{od}::EntryRange {{ first: {:#06x}, last: {:#06x}, subindex: {} }}",
                    r.first,
                    r.last,
                    r.subindex
                        .map_or("None".into(), |s| format!("Some({s:#04x})"))
                )
            })
            .collect();
        format!("&[{}]", items.join(", "))
    };
    let test = |t: &EntryTest| {
        format!(
            "{od}::EntryTest {{ index: {:#06x}, subindex: {:#04x}, mask: {:#x}, value: {:#x} }}",
            t.index, t.subindex, t.mask, t.value
        )
    };
    let st = &p.storage;
    let groups: Vec<String> = st
        .groups
        .iter()
        .map(|g| {
            format!(
                "{od}::StorageGroup {{ subindex: {}, ranges: {} }}",
                g.subindex,
                ranges(&g.ranges)
            )
        })
        .collect();
    let auto: Vec<String> = st
        .auto_store
        .iter()
        .map(|a| {
            format!(
                "{od}::AutoStore {{ entries: {}, unless: {} }}",
                ranges(&a.entries),
                a.unless
                    .as_ref()
                    .map_or("None".into(), |t| format!("Some({})", test(t)))
            )
        })
        .collect();
    let condition = st.write_condition.as_ref().map_or("None".into(), |c| {
        format!(
            "Some({od}::WriteCondition {{ test: {}, subindexes: &{:?} }})",
            test(&c.test),
            c.subindexes
        )
    });
    let _ = writeln!(
        out,
        "    /// Parameter storage rules (`[storage]`): what 1010h stores besides the default rule, the\n    /// 1010h/1011h groups, automatic storage of SDO downloads, the write condition."
    );
    let _ = writeln!(
        out,
        "    pub const STORAGE: {od}::StorageRules = {od}::StorageRules {{"
    );
    let _ = writeln!(
        out,
        "        stored_pdo_mappable: {},",
        ranges(&st.stored_pdo_mappable)
    );
    let _ = writeln!(out, "        not_stored: {},", ranges(&st.not_stored));
    let _ = writeln!(out, "        groups: &[{}],", groups.join(", "));
    let _ = writeln!(out, "        auto_store: &[{}],", auto.join(", "));
    let _ = writeln!(out, "        write_condition: {condition},");
    let _ = writeln!(out, "    }};");
}

/// `(index, subindex)` of every entry that `keep` selects, in dictionary order, as Rust tuples.
fn pairs(p: &Profile, keep: impl Fn(&Object, &Entry) -> bool) -> String {
    let items: Vec<String> = p
        .objects
        .iter()
        .flat_map(|o| o.entries.iter().map(move |e| (o, e)))
        .filter(|(o, e)| keep(o, e))
        .map(|(o, e)| format!("({:#06x}, {:#04x})", o.index, e.subindex))
        .collect();
    items.join(", ")
}

const CHECK: &str = r#"/// `const` cross-checks of the generated tables (evaluated at compile time only).
// Only ever evaluated in `const _` items: an out-of-range index or an overflow here fails the
// build, it cannot happen in the firmware at run time.
#[allow(clippy::indexing_slicing, clippy::arithmetic_side_effects)]
mod check {
    use $SLAVE::od::{Object, Value};

    pub(super) const fn objects_sorted(o: &[Object]) -> bool {
        let mut i = 1;
        while i < o.len() {
            if o[i - 1].index >= o[i].index {
                return false;
            }
            i += 1;
        }
        true
    }

    pub(super) const fn entries_sorted(o: &[Object]) -> bool {
        let mut i = 0;
        while i < o.len() {
            let e = o[i].entries;
            let mut j = 1;
            while j < e.len() {
                if e[j - 1].subindex >= e[j].subindex {
                    return false;
                }
                j += 1;
            }
            i += 1;
        }
        true
    }

    pub(super) const fn ram_in_bounds(o: &[Object], ram: usize) -> bool {
        let mut i = 0;
        while i < o.len() {
            let e = o[i].entries;
            let mut j = 0;
            while j < e.len() {
                if let Value::Ram(off) = e[j].value {
                    if off as usize + e[j].byte_len() > ram {
                        return false;
                    }
                }
                j += 1;
            }
            i += 1;
        }
        true
    }

    /// The value of `index:sub` (up to 4 bytes, little-endian; 0 if missing).
    const fn value(o: &[Object], defaults: &[u8], index: u16, sub: u8) -> u32 {
        let mut i = 0;
        while i < o.len() {
            if o[i].index == index {
                let e = o[i].entries;
                let mut j = 0;
                while j < e.len() {
                    if e[j].subindex == sub {
                        let n = if e[j].byte_len() < 4 { e[j].byte_len() } else { 4 };
                        let mut v = 0u32;
                        let mut k = 0;
                        while k < n {
                            let b = match e[j].value {
                                Value::Const(bytes) => bytes[k],
                                Value::Ram(off) => defaults[off as usize + k],
                                Value::Domain(_) => 0,
                            };
                            v |= (b as u32) << (8 * k);
                            k += 1;
                        }
                        return v;
                    }
                    j += 1;
                }
            }
            i += 1;
        }
        0
    }

    /// Whether the entries `crate::params::is_storable` selects under `storage` are exactly
    /// `backup` (the ESI `Flags/Backup` od-gen wrote): one rule, checked against the
    /// firmware's.
    pub(super) const fn backup_agrees(
        o: &[Object],
        storage: &$SLAVE::od::StorageRules,
        backup: &[(u16, u8)],
    ) -> bool {
        let mut n = 0;
        let mut i = 0;
        while i < o.len() {
            let e = o[i].entries;
            let mut j = 0;
            while j < e.len() {
                let storable = $SLAVE::params::is_storable(storage, &o[i], &e[j]);
                let mut listed = false;
                let mut k = 0;
                while k < backup.len() {
                    if backup[k].0 == o[i].index && backup[k].1 == e[j].subindex {
                        listed = true;
                    }
                    k += 1;
                }
                if storable != listed {
                    return false;
                }
                if storable {
                    n += 1;
                }
                j += 1;
            }
            i += 1;
        }
        n == backup.len()
    }

    /// Whether the defaults of 1010h:n (n ≥ 1) are what the firmware writes back after a
    /// command (`params::store_capabilities`): od-gen's capability bits agree with the stack's.
    pub(super) const fn capabilities_agree(
        o: &[Object],
        defaults: &[u8],
        storage: &$SLAVE::od::StorageRules,
    ) -> bool {
        let mut i = 0;
        while i < o.len() {
            if o[i].index == $SLAVE::params::STORE_PARAMETERS {
                let e = o[i].entries;
                let mut j = 0;
                while j < e.len() {
                    let sub = e[j].subindex;
                    if sub >= $SLAVE::params::ALL_PARAMETERS
                        && value(o, defaults, o[i].index, sub)
                            != $SLAVE::params::store_capabilities(storage, sub)
                    {
                        return false;
                    }
                    j += 1;
                }
            }
            i += 1;
        }
        true
    }

    /// Sum of the mapped bit lengths of the PDOs assigned by default in `assign` (1C12h/1C13h).
    pub(super) const fn assigned_bits(o: &[Object], defaults: &[u8], assign: u16) -> usize {
        let n = value(o, defaults, assign, 0);
        let mut bits = 0usize;
        let mut i = 1;
        while i <= n {
            let pdo = value(o, defaults, assign, i as u8) as u16;
            let m = value(o, defaults, pdo, 0);
            let mut j = 1;
            while j <= m {
                bits += (value(o, defaults, pdo, j as u8) & 0xff) as usize;
                j += 1;
            }
            i += 1;
        }
        bits
    }
"#;

/// The check of od-gen's motor fault names against the drive's `MotorFault` (drive targets).
const CHECK_MOTOR_FAULTS: &str = r#"
    /// Whether `names` are the names of `$DRIVE::motor::MotorFault::ALL`, in code order (code
    /// `i + 1` at position `i`): od-gen's list agrees with the firmware's enum.
    pub(super) const fn motor_fault_names_agree(names: &[&str]) -> bool {
        let all = $DRIVE::motor::MotorFault::ALL;
        if all.len() != names.len() {
            return false;
        }
        let mut i = 0;
        while i < all.len() {
            if all[i].code() as usize != i + 1 {
                return false;
            }
            let a = all[i].name().as_bytes();
            let b = names[i].as_bytes();
            if a.len() != b.len() {
                return false;
            }
            let mut k = 0;
            while k < a.len() {
                if a[k] != b[k] {
                    return false;
                }
                k += 1;
            }
            i += 1;
        }
        true
    }

"#;

/// Every data type od-gen writes into SII and ESI, so that their codes are checked against the
/// slave stack's `od::DataType`.
const ALL_DATA_TYPES: [DataType; 25] = [
    DataType::Bool,
    DataType::Sint,
    DataType::Int,
    DataType::Int24,
    DataType::Dint,
    DataType::Lint,
    DataType::Usint,
    DataType::Uint,
    DataType::Uint24,
    DataType::Udint,
    DataType::Ulint,
    DataType::Real,
    DataType::Lreal,
    DataType::VisibleString,
    DataType::OctetString,
    DataType::UnicodeString,
    DataType::Domain,
    DataType::Bit(1),
    DataType::Bit(2),
    DataType::Bit(3),
    DataType::Bit(4),
    DataType::Bit(5),
    DataType::Bit(6),
    DataType::Bit(7),
    DataType::Bit(8),
];

/// `const` assertions that tie od-gen's CoE codes (written into SII and ESI) to the slave
/// stack's own definitions (used by SDO information): data type codes (ETG.1000.6 Table 64) and
/// the access bits (Table 48). The two must stay apart (od-gen is a host tool the stack cannot
/// depend on at build time), so the compiler checks that they agree.
fn data_type_codes(out: &mut String, target: &Target) {
    let od = format!("{}::od", target.slave);
    for t in ALL_DATA_TYPES {
        let _ = writeln!(
            out,
            "const _: () = assert!({od}::DataType::{}.code() == {:#06x}, \"od-gen's code of {} differs from the stack's\");",
            t.rust_variant(),
            t.code(),
            t.rust_variant()
        );
    }
    let _ = writeln!(
        out,
        "const _: () = assert!({od}::Access::READ_PREOP | {od}::Access::READ_SAFEOP | {od}::Access::READ_OP == {:#04x}, \"od-gen's read bits differ from the stack's\");",
        Access::READ_ALL
    );
    for (name, bits) in [
        ("WRITE_PREOP", Access::WRITE_PREOP),
        ("WRITE_SAFEOP", Access::WRITE_SAFEOP),
        ("WRITE_OP", Access::WRITE_OP),
    ] {
        let _ = writeln!(
            out,
            "const _: () = assert!({od}::Access::{name} == {bits:#04x}, \"od-gen's access bit {name} differs from the stack's\");"
        );
    }
    let slave = target.slave;
    let _ = writeln!(
        out,
        "const _: () = assert!({slave}::pdo::rules::MAX_PDO_BYTES == {STACK_MAX_PDO_BYTES} && {slave}::pdo::MAX_IMAGE == {STACK_MAX_PDO_BYTES}, \"od-gen's PDO byte limit differs from the stack's\");"
    );
    out.push('\n');
}

/// Where the generated code is compiled and what it holds besides the object dictionaries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Target {
    /// Path of the `ethercat-slave` crate root as the generated code sees it (`od`, `params`).
    pub slave: &'static str,
    /// Path of the drive crate root (`profile::{DriveProfile, AppVars}`, `motor::MotorFault`):
    /// each profile becomes a `DriveProfile` with its CiA402 variables and motor fault table.
    /// `None`: the object dictionaries alone (any EtherCAT device).
    pub drive: Option<&'static str>,
}

impl Target {
    /// The drive firmware (crate `firmware`, `OUT_DIR/profiles.rs`).
    pub const DRIVE_CRATE: Self = Self {
        slave: "::ethercat_slave",
        drive: Some("crate"),
    };
    /// Inside the `ethercat-slave` crate itself (its unit tests).
    pub const SLAVE_CRATE: Self = Self {
        slave: "crate",
        drive: None,
    };
    /// Any other crate that uses `ethercat-slave` for a device that is not a drive.
    pub const DEVICE_CRATE: Self = Self {
        slave: "::ethercat_slave",
        drive: None,
    };
}

/// The Rust source of `OUT_DIR/profiles.rs` of the drive firmware ([`Target::DRIVE_CRATE`]).
pub fn generate(profiles: &[Profile]) -> String {
    generate_with(profiles, &Target::DRIVE_CRATE)
}

/// The Rust source of the object dictionaries of these profiles (sorted by name in `ALL`) for
/// `target`.
pub fn generate_with(profiles: &[Profile], target: &Target) -> String {
    let mut sorted: Vec<&Profile> = profiles.iter().collect();
    sorted.sort_by(|a, b| a.name.cmp(&b.name));
    let mut out = String::new();
    out.push_str(
        "// @generated by od-gen from the profile files. Do not edit: change the profile.\n\n",
    );
    let max = sorted
        .iter()
        .map(|p| ram_layout(p).image.len())
        .max()
        .unwrap_or(0);
    let _ = writeln!(
        out,
        "/// The largest OD RAM of all profiles (bytes): size a shared RAM buffer with it."
    );
    let _ = writeln!(out, "pub const MAX_RAM_SIZE: usize = {max};\n");
    let profile_type = match target.drive {
        Some(drive) => format!("{drive}::profile::DriveProfile"),
        None => format!("{}::od::Profile", target.slave),
    };
    let device = if target.drive.is_some() {
        "od.device"
    } else {
        "device"
    };
    let _ = writeln!(out, "/// All compiled-in profiles, sorted by name.");
    let refs: Vec<String> = sorted
        .iter()
        .map(|p| format!("&{}::PROFILE", p.module_name()))
        .collect();
    let _ = writeln!(
        out,
        "pub static ALL: [&{profile_type}; {}] = [{}];\n",
        sorted.len(),
        refs.join(", ")
    );
    let _ = writeln!(
        out,
        "/// The compiled-in profile with this name (the profile file's `name`; `-` and `_` are the\n/// same, so `sigma-v-sd` and `sigma_v_sd` both find it)."
    );
    let _ = writeln!(
        out,
        "pub fn by_name(name: &str) -> Option<&'static {profile_type}> {{"
    );
    let _ = writeln!(
        out,
        "    ALL.iter().copied().find(|p| p.{device}.is_profile(name))"
    );
    let _ = writeln!(out, "}}\n");
    if target.drive.is_some() {
        let names: Vec<String> = MOTOR_FAULT_NAMES.iter().map(|n| format!("{n:?}")).collect();
        let _ = writeln!(
            out,
            "/// The internal motor faults as od-gen knows them (`MotorFault::name()`), in code order:\n/// the order of every profile's `MOTOR_FAULTS`."
        );
        let _ = writeln!(
            out,
            "pub const MOTOR_FAULT_NAMES: [&str; {}] = [{}];",
            names.len(),
            names.join(", ")
        );
        let _ = writeln!(
            out,
            "const _: () = assert!(check::motor_fault_names_agree(&MOTOR_FAULT_NAMES), \"od-gen's MOTOR_FAULT_NAMES differ from the drive's motor::MotorFault\");\n"
        );
    }
    data_type_codes(&mut out, target);
    for p in &sorted {
        module(&mut out, p, target);
    }
    out.push_str(&CHECK.replace("$SLAVE", target.slave));
    if let Some(drive) = target.drive {
        out.push_str(&CHECK_MOTOR_FAULTS.replace("$DRIVE", drive));
    }
    out.push_str("}\n");
    out
}

/// For a crate's build script: loads the profiles at `source` (a directory of profile files,
/// or one file), tells cargo to rerun when they change, and writes their generated Rust for
/// `target` to `OUT_DIR/<out_file>`. Any error ends the build script with the message on
/// stderr and exit status 1.
pub fn build_script(source: &std::path::Path, out_file: &str, target: &Target) {
    println!("cargo:rerun-if-changed={}", source.display());
    let profiles = if source.is_dir() {
        crate::load_dir(source)
    } else {
        crate::load(source).map(|p| vec![p])
    };
    let profiles = match profiles {
        Ok(p) => p,
        Err(e) => {
            eprintln!("od-gen: {e}");
            std::process::exit(1);
        }
    };
    let out = std::path::PathBuf::from(std::env::var("OUT_DIR").unwrap_or_default()).join(out_file);
    if let Err(e) = std::fs::write(&out, generate_with(&profiles, target)) {
        eprintln!("od-gen: cannot write {}: {e}", out.display());
        std::process::exit(1);
    }
}

/// For a drive crate's build.rs: like [`build_script`] over the profile folder `dir`, and the
/// environment variable `select_env` picks what is compiled in. Unset or empty: every profile of
/// `dir`. Set: only that profile (a name in `dir`, with `-` or `_`, or a path to a `.toml`), so a
/// board image carries exactly one dictionary. Either way the generated code ends with
/// `pub use <module> as selected;`: the chosen profile, else `standard`, else the first.
pub fn build_script_selecting(
    dir: &std::path::Path,
    out_file: &str,
    target: &Target,
    select_env: &str,
) {
    println!("cargo:rerun-if-changed={}", dir.display());
    println!("cargo:rerun-if-env-changed={select_env}");
    let fail = |e: &dyn std::fmt::Display| -> ! {
        eprintln!("od-gen: {e}");
        std::process::exit(1);
    };
    let selection = std::env::var(select_env)
        .ok()
        .filter(|s| !s.trim().is_empty());
    let profiles = match &selection {
        None => crate::load_dir(dir).unwrap_or_else(|e| fail(&e)),
        Some(name) => {
            let path = std::path::Path::new(name.trim());
            let file = if name.ends_with(".toml") {
                path.to_path_buf()
            } else {
                crate::profile_file(dir, name.trim()).unwrap_or_else(|| {
                    let names: Vec<String> = crate::load_dir(dir)
                        .map(|ps| ps.into_iter().map(|p| p.name).collect())
                        .unwrap_or_default();
                    fail(&format!(
                        "{select_env}={name}: no such profile in {} (profiles: {})",
                        dir.display(),
                        names.join(", ")
                    ))
                })
            };
            println!("cargo:rerun-if-changed={}", file.display());
            vec![crate::load(&file).unwrap_or_else(|e| fail(&e))]
        }
    };
    let selected = profiles
        .iter()
        .find(|p| selection.is_some() || p.name == "standard")
        .or(profiles.first())
        .map(Profile::module_name)
        .unwrap_or_else(|| fail(&format!("no profile in {}", dir.display())));
    let mut code = generate_with(&profiles, target);
    let _ = writeln!(
        code,
        "\n/// The profile a board image is built with (`{select_env}`; default `standard`).\npub use {selected} as selected;"
    );
    let out = std::path::PathBuf::from(std::env::var("OUT_DIR").unwrap_or_default()).join(out_file);
    if let Err(e) = std::fs::write(&out, code) {
        fail(&format!("cannot write {}: {e}", out.display()));
    }
}
