//! From a [`ProfileFile`] to a checked [`Profile`]: converts values, derives the communication
//! objects from the PDO, SM and sync sections, then runs [`crate::validate`].

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use crate::compose;
use crate::error::{fault, Error, Fault, Invalid};
use crate::file::{
    AlErrorAlarmFile, EntryAttrs, MotorFaultFile, ObjectFile, PdoFile, ProfileFile, SmFileEntry,
};
use crate::model::*;
use crate::validate::Faults;

/// The bytes of an emergency message that form its manufacturer-specific field (CiA 301).
const EMCY_DATA_BYTES: std::ops::RangeInclusive<u8> = 3..=7;

/// Parses TOML text into a checked profile. `source` names the file in error messages.
/// `dir` is the file's folder (where `extends` looks first), `None` for a built-in profile.
pub fn parse(text: &str, source: &str, dir: Option<&Path>) -> Result<Profile, Error> {
    let composed = compose::compose(text, source, dir).map_err(|e| {
        let own = compose::Source {
            name: source.to_string(),
            text: text.to_string(),
        };
        with_line(e, &[own])
    })?;
    let sources = &composed.sources;
    let value = toml::Value::Table(composed.table);
    let file: ProfileFile = serde_path_to_error::deserialize(value.clone()).map_err(|e| {
        let key = key_path(e.path(), &value);
        with_line(
            Error::Invalid {
                file: source.to_string(),
                key,
                line: None,
                error: Invalid::Format(e.into_inner().to_string().trim_end().to_string()),
            },
            sources,
        )
    })?;
    resolve(&file, source).map_err(|e| with_line(e, sources))
}

/// Checks a parsed profile file and derives the full dictionary.
pub fn resolve(file: &ProfileFile, source: &str) -> Result<Profile, Error> {
    build(file, source).map_err(|faults| {
        let errors = faults
            .0
            .into_iter()
            .map(|(key, error)| Error::Invalid {
                file: source.to_string(),
                key,
                line: None,
                error,
            })
            .collect();
        Error::all(errors)
            .err()
            .unwrap_or(Error::Several(Vec::new()))
    })
}

/// Points an [`Error::Invalid`] at the file and line that wrote its key (the profile, one of
/// its bases or a library).
fn with_line(e: Error, sources: &[compose::Source]) -> Error {
    match e {
        Error::Several(errors) => {
            Error::Several(errors.into_iter().map(|e| with_line(e, sources)).collect())
        }
        Error::Invalid {
            file,
            key,
            line: None,
            error,
        } => match crate::locate::locate(sources, &key) {
            Some((file, line)) => Error::Invalid {
                file,
                key,
                line: Some(line),
                error,
            },
            None => Error::Invalid {
                file,
                key,
                line: None,
                error,
            },
        },
        other => other,
    }
}

/// serde's path (`object[12].entry[0].type`) in od-gen's key spelling: elements of the
/// arrays that merge by id are named by it (`object[0x6040].entry[0x01].type`).
fn key_path(path: &serde_path_to_error::Path, root: &toml::Value) -> String {
    use serde_path_to_error::Segment;
    let mut out = String::new();
    let mut here = Some(root);
    let mut last_key = String::new();
    for seg in path.iter() {
        match seg {
            Segment::Map { key } => {
                if !out.is_empty() {
                    out.push('.');
                }
                out.push_str(key);
                here = here.and_then(|v| v.get(key));
                last_key = key.clone();
            }
            Segment::Seq { index } => {
                here = here.and_then(|v| v.get(*index));
                let id = match last_key.as_str() {
                    "object" | "rxpdo" | "txpdo" => here
                        .and_then(|v| v.get("index"))
                        .and_then(toml::Value::as_integer)
                        .map(|i| format!("{i:#06x}")),
                    "entry" => here
                        .and_then(|v| v.get("sub"))
                        .and_then(toml::Value::as_integer)
                        .map(|i| format!("{i:#04x}")),
                    "alarm" => here
                        .and_then(|v| v.get("display"))
                        .and_then(toml::Value::as_str)
                        .map(str::to_string),
                    _ => None,
                };
                out.push_str(&format!("[{}]", id.unwrap_or_else(|| index.to_string())));
            }
            Segment::Enum { variant } => {
                out.push('.');
                out.push_str(variant);
            }
            Segment::Unknown => {}
        }
    }
    out
}

/// The profile with its derived objects, every check run.
fn build(f: &ProfileFile, source: &str) -> Result<Profile, Faults> {
    let declared = declared_objects(f)?;
    let mut profile = dictionary(f, source, declared)?;
    // From here on every check runs and every fault is reported: the dictionary is complete,
    // and the checks below read it only.
    let mut faults = match crate::validate::check(&profile) {
        Ok(()) => Faults::default(),
        Err(faults) => faults,
    };
    let storage = faults.take(crate::storage::resolve(&f.storage, &profile));
    let adjusting = faults.take(crate::adjusting::resolve(&f.adjusting, &profile));
    let split = faults.take(split_values(&f.split_values, &profile));
    faults.into_result()?;
    profile.storage = storage.unwrap_or_default();
    profile.adjusting = adjusting.unwrap_or_default();
    profile.split_values = split.unwrap_or_default();
    Ok(profile)
}

/// The declared objects, each converted: they are independent of each other, so the faults of
/// every faulty one are reported.
fn declared_objects(f: &ProfileFile) -> Result<BTreeMap<u16, Object>, Faults> {
    let mut declared: BTreeMap<u16, Object> = BTreeMap::new();
    let mut faults = Faults::default();
    for o in &f.objects {
        let key = format!("object[{:#06x}]", o.index);
        if let Some(from) = derived_from(o.index, f) {
            faults.add(
                &key,
                Invalid::DerivedObject {
                    index: o.index,
                    from,
                },
            );
            continue;
        }
        let Some(obj) = faults.take(object(o, &key)) else {
            continue;
        };
        if declared.insert(o.index, obj).is_some() {
            faults.add(&key, Invalid::DuplicateIndex(o.index));
        }
    }
    faults.into_result().map(|()| declared)
}

/// The profile's values converted (the declared objects already are) and its communication
/// objects derived; stops at the first fault (what follows it is built from what it rejected).
fn dictionary(
    f: &ProfileFile,
    source: &str,
    mut declared: BTreeMap<u16, Object>,
) -> Result<Profile, Fault> {
    let mut protocols = 0u16;
    for p in &f.mailbox.protocols {
        let bit = protocol::NAMES
            .iter()
            .find(|(n, _)| n == p)
            .map(|(_, b)| *b)
            .ok_or_else(|| {
                fault(
                    "mailbox.protocols",
                    Invalid::Mailbox(format!("unknown protocol `{p}`")),
                )
            })?;
        protocols |= bit;
    }
    let coe = match (&f.mailbox.coe, protocols & protocol::COE != 0) {
        (Some(c), true) => CoeDetails {
            sdo: c.sdo,
            sdo_info: c.sdo_info,
            pdo_assign: c.pdo_assign,
            pdo_config: c.pdo_config,
            upload_at_startup: c.upload_at_startup,
            complete_access: c.complete_access,
        },
        (None, true) => return Err(fault("mailbox.coe", Invalid::Missing("mailbox.coe"))),
        (Some(_), false) => {
            return Err(fault(
                "mailbox.coe",
                Invalid::Mailbox("CoE details given but CoE is not in mailbox.protocols".into()),
            ))
        }
        (None, false) => CoeDetails::default(),
    };
    let mailbox = Mailbox {
        protocols,
        data_link_layer: f.mailbox.data_link_layer,
        coe,
    };

    let sync = Sync {
        free_run: f.sync.free_run,
        sm_synchronous: f.sync.sm_synchronous,
        dc_sync0: f.sync.dc_sync0,
        dc_sync1: f.sync.dc_sync1,
        min_cycle_ns: f.sync.min_cycle_ns,
        max_cycle_ns: f.sync.max_cycle_ns,
        default_cycle_ns: f.sync.default_cycle_ns,
        calc_and_copy_ns: f.sync.calc_and_copy_ns,
        delay_ns: f.sync.delay_ns,
        cycle_step_ns: f.sync.cycle_step_ns,
        allowed_cycles_ns: f.sync.allowed_cycles_ns.clone(),
        default_sync_mode: match f.sync.default_sync_mode.as_deref() {
            None if f.sync.free_run => 0,
            None if f.sync.sm_synchronous => 1,
            None if f.sync.dc_sync0 => 2,
            None => 3,
            Some("free_run") if f.sync.free_run => 0,
            Some("sm_synchronous") if f.sync.sm_synchronous => 1,
            Some("dc_sync0") if f.sync.dc_sync0 => 2,
            Some(s) => {
                return Err(fault(
                    "sync.default_sync_mode",
                    Invalid::Sync(format!(
                        "`{s}` is not a supported mode of free_run, sm_synchronous, dc_sync0"
                    )),
                ))
            }
        },
        sync_mode_writable: f.sync.sync_mode_writable,
        cycle_time_writable: f.sync.cycle_time_writable,
        sync_flag_in_sync: f.sync.sync_flag_in_sync,
        free_run_min_cycle_ns: f.sync.free_run_min_cycle_ns.unwrap_or(f.sync.min_cycle_ns),
        free_run_max_cycle_ns: f.sync.free_run_max_cycle_ns.unwrap_or(f.sync.max_cycle_ns),
        input_shift: f
            .sync
            .input_shift
            .as_ref()
            .map(|i| {
                Ok::<_, Fault>(InputShift {
                    step_ns: i.step_ns,
                    reserve_ns: i.reserve_ns,
                    parameter: entry_ref(i.parameter.as_deref(), "sync.input_shift.parameter")?,
                })
            })
            .transpose()?,
        sync_error_at_limit: f.sync.sync_error_at_limit,
        sync_error_on_missed_outputs: f.sync.sync_error_on_missed_outputs,
        sm_event_missed_subindex: f.sync.sm_event_missed_subindex,
    };
    let alarms = alarms(f)?;
    let esm = EsmRules {
        op_requires_outputs: f.esm.op_requires_outputs,
        safeop_op_timeout_ms: f.esm.safeop_op_timeout_ms,
        op_exit_while_enabled_error: f
            .esm
            .op_exit_while_enabled_error
            .as_ref()
            .map(|r| fault_report(r, &alarms, "esm.op_exit_while_enabled_error"))
            .transpose()?,
        al_error_alarms: al_error_alarms(&f.esm.al_error_alarms, &alarms)?,
        al_error_leds: al_error_leds(&f.esm.al_error_alarms)?,
        link_loss_error: f
            .esm
            .link_loss_error
            .as_ref()
            .map(|r| fault_report(r, &alarms, "esm.link_loss_error"))
            .transpose()?,
        sync_error_al_code: match f.esm.sync_error_al_code {
            c @ (crate::file::AL_SYNC_ERROR | crate::file::AL_FATAL_SYNC_ERROR) => c,
            other => {
                return Err(fault(
                    "esm.sync_error_al_code",
                    Invalid::Value(format!("{other:#06x} is not 0x001A or 0x002C")),
                ))
            }
        },
        sync_lock_timeout_ms: match f.esm.sync_lock_timeout_ms {
            Some(0) => {
                return Err(fault(
                    "esm.sync_lock_timeout_ms",
                    Invalid::Value("must be at least 1".into()),
                ))
            }
            t => t,
        },
        pdi_error: f
            .esm
            .pdi_error
            .as_ref()
            .map(|r| fault_report(r, &alarms, "esm.pdi_error"))
            .transpose()?,
        lost_outputs: f
            .esm
            .lost_outputs
            .as_ref()
            .map(|l| lost_outputs(l, &alarms))
            .transpose()?,
    };
    let emcy = EmcyRules {
        register_mask: match f.emcy.error_register.as_str() {
            "cia301" => 0xFF,
            "generic" => 0x01,
            other => {
                return Err(fault(
                    "emcy.error_register",
                    Invalid::Value(format!("`{other}` is not cia301 or generic")),
                ))
            }
        },
        al_error_code: match f.emcy.al_error_code {
            0 => {
                return Err(fault(
                    "emcy.al_error_code",
                    Invalid::Value("0x0000 is the error-reset emergency".into()),
                ))
            }
            c => c,
        },
        axis_number_byte: match f.emcy.axis_number_byte {
            Some(b) if !(EMCY_DATA_BYTES).contains(&b) => {
                return Err(fault(
                    "emcy.axis_number_byte",
                    Invalid::Value(format!(
                        "byte {b} is not in the manufacturer-specific field (bytes 3 to 7)"
                    )),
                ))
            }
            b => b,
        },
        motor_fault_code: match (f.emcy.motor_fault_code, f.emcy.motor_fault_code_byte) {
            (None, None) => None,
            (Some(code), Some(byte))
                if code != 0
                    && (*EMCY_DATA_BYTES.start()..*EMCY_DATA_BYTES.end()).contains(&byte)
                    && f.emcy
                        .axis_number_byte
                        .is_none_or(|a| a != byte && a != byte + 1) =>
            {
                Some((code, byte))
            }
            _ => {
                return Err(fault(
                    "emcy.motor_fault_code",
                    Invalid::Value(
                        "a code other than 0x0000 with motor_fault_code_byte 3 to 6, clear of \
                         axis_number_byte"
                            .into(),
                    ),
                ))
            }
        },
    };
    let kind = match f.kind.as_deref() {
        None => ProfileKind::Drive,
        Some(s) => ProfileKind::parse(s).ok_or_else(|| {
            fault(
                "kind",
                Invalid::Value(format!("`{s}` is not drive or device")),
            )
        })?,
    };
    let motor_faults = match kind {
        ProfileKind::Drive => motor_faults(&f.motor_faults, &alarms, emcy.motor_fault_code)?,
        ProfileKind::Device if f.motor_faults.is_empty() => {
            [MotorFaultCode::default(); MOTOR_FAULT_COUNT]
        }
        ProfileKind::Device => {
            return Err(fault(
                "motor_faults",
                Invalid::Value("a device profile (kind = \"device\") has no motor faults".into()),
            ))
        }
    };
    let sdo_write_to_rx_mapped = match f.pdo.sdo_write_to_rx_mapped.as_deref() {
        None => RxMappedWrite::Allowed,
        Some(s) => RxMappedWrite::parse(s).ok_or_else(|| {
            fault(
                "pdo.sdo_write_to_rx_mapped",
                Invalid::Value(format!("`{s}` is not blocked or allowed")),
            )
        })?,
    };

    let dc_op_modes = f
        .dc_op_modes
        .iter()
        .map(|m| DcOpMode {
            name: m.name.clone(),
            description: m.description.clone(),
            assign_activate: m.assign_activate,
            sync0_cycle_ns: m.sync0_cycle_ns,
            sync0_factor: m.sync0_factor,
            sync0_shift_ns: m.sync0_shift_ns,
            sync1_cycle_ns: m.sync1_cycle_ns,
            sync1_factor: m.sync1_factor,
            sync1_shift_ns: m.sync1_shift_ns,
        })
        .collect();

    let device = Device {
        name: f.device.name.clone(),
        order_number: f.device.order_number.clone(),
        product_code: f.device.product_code,
        revision: f.device.revision,
        serial: f.device.serial,
        hardware_version: f.device.hardware_version.clone(),
        software_version: f.device.software_version.clone(),
        group_type: f.device.group_type.clone(),
        group_name: f.device.group_name.clone(),
        physics: f.device.physics.clone(),
        profile_no: f.device.profile_no,
        ds402_channels: f.device.ds402_channels,
    };
    let e = &f.eeprom;
    let eeprom = Eeprom {
        byte_size: e.byte_size,
        pdi_control: e.pdi_control,
        esc_config: e.esc_config,
        pdi_config: e.pdi_config,
        sync_impulse_len: e.sync_impulse_len,
        pdi_config2: e.pdi_config2,
        station_alias: e.station_alias,
        reserved: e.reserved,
        station_alias_parameter: entry_ref(
            e.station_alias_parameter.as_deref(),
            "eeprom.station_alias_parameter",
        )?,
        station_alias_selector: e
            .station_alias_selector
            .as_ref()
            .map(|c| {
                entry_ref(Some(&c.entry), "eeprom.station_alias_selector.entry")
                    .map(|r| r.map(|(i, s)| (i, s, c.value)))
            })
            .transpose()?
            .flatten(),
    };

    // PDOs, checked against the declared objects.
    let max_entries = f.pdo.max_entries;
    if max_entries == 0 || max_entries > 254 {
        return Err(fault(
            "pdo.max_entries",
            Invalid::Value("must be 1..=254".into()),
        ));
    }
    let limit = |value: Option<u16>, key: &str| -> Result<u16, Fault> {
        match value {
            None => Ok(STACK_MAX_PDO_BYTES),
            Some(v) if (1..=STACK_MAX_PDO_BYTES).contains(&v) => Ok(v),
            Some(_) => Err(fault(
                key,
                Invalid::Value(format!(
                    "must be 1..={STACK_MAX_PDO_BYTES} (the stack's limit)"
                )),
            )),
        }
    };
    let max_pdo_bytes = limit(f.pdo.max_pdo_bytes, "pdo.max_pdo_bytes")?;
    let max_process_bytes = limit(f.pdo.max_process_bytes, "pdo.max_process_bytes")?;
    let rx_pdos = pdos(&f.rx_pdos, true, &declared, max_entries)?;
    let tx_pdos = pdos(&f.tx_pdos, false, &declared, max_entries)?;
    for p in rx_pdos.iter().chain(&tx_pdos) {
        if p.bits() > u32::from(max_pdo_bytes) * 8 {
            let kind = if p.sm == 2 { "rxpdo" } else { "txpdo" };
            return Err(fault(
                &format!("{kind}[{:#06x}].entries", p.index),
                Invalid::Value(format!(
                    "{} bits exceed pdo.max_pdo_bytes = {max_pdo_bytes}",
                    p.bits()
                )),
            ));
        }
    }
    if let Some(max) = f.pdo.max_assigned {
        for (pdos, key) in [(&rx_pdos, "rxpdo"), (&tx_pdos, "txpdo")] {
            let n = pdos.iter().filter(|p| p.assigned).count();
            if max == 0 || n > usize::from(max) {
                return Err(fault(
                    "pdo.max_assigned",
                    Invalid::Value(format!(
                        "must be ≥ 1 and ≥ the {n} PDOs the default {key} assignment holds"
                    )),
                ));
            }
        }
    }

    let bits = |pdos: &[Pdo], sm: u8, key: &str| -> Result<u16, Fault> {
        let bits: u32 = pdos.iter().filter(|p| p.assigned).map(Pdo::bits).sum();
        if bits % 8 != 0 {
            return Err(fault(key, Invalid::PdoBitsNotBytes { sm, bits }));
        }
        u16::try_from(bits / 8)
            .map_err(|_| fault(key, Invalid::Value("process data too large".into())))
    };
    let out_len = bits(&rx_pdos, 2, "rxpdo")?;
    let in_len = bits(&tx_pdos, 3, "txpdo")?;
    for (len, key) in [(out_len, "rxpdo"), (in_len, "txpdo")] {
        if len > max_process_bytes {
            return Err(fault(
                key,
                Invalid::Value(format!(
                    "the default assignment maps {len} bytes, more than pdo.max_process_bytes = \
                     {max_process_bytes}"
                )),
            ));
        }
    }
    let mbx = |s: &SmFileEntry, key: &str| -> Result<Sm, Fault> {
        let length = s.size.ok_or_else(|| fault(key, Invalid::Missing("size")))?;
        Ok(Sm {
            start: s.start,
            length,
            control: s.control,
        })
    };
    let pd = |s: &SmFileEntry, key: &str, length: u16| -> Result<Sm, Fault> {
        if s.size.is_some() {
            return Err(fault(
                key,
                Invalid::Value(
                    "process-data SM size comes from the default PDO assignment; remove `size`"
                        .into(),
                ),
            ));
        }
        Ok(Sm {
            start: s.start,
            length,
            control: s.control,
        })
    };
    let sm = SmLayout {
        mailbox_out: mbx(&f.sm.mailbox_out, "sm.mailbox_out")?,
        mailbox_in: mbx(&f.sm.mailbox_in, "sm.mailbox_in")?,
        boot_out: f
            .sm
            .boot_out
            .as_ref()
            .map(|s| mbx(s, "sm.boot_out"))
            .transpose()?,
        boot_in: f
            .sm
            .boot_in
            .as_ref()
            .map(|s| mbx(s, "sm.boot_in"))
            .transpose()?,
        outputs: pd(&f.sm.outputs, "sm.outputs", out_len)?,
        inputs: pd(&f.sm.inputs, "sm.inputs", in_len)?,
    };

    let cia402 = Cia402Rules {
        enable_without_mode_error: f
            .cia402
            .enable_without_mode_error
            .as_ref()
            .map(|r| fault_report(r, &alarms, "cia402.enable_without_mode_error"))
            .transpose()?,
        mode_change_while_homing_error: f
            .cia402
            .mode_change_while_homing_error
            .as_ref()
            .map(|r| fault_report(r, &alarms, "cia402.mode_change_while_homing_error"))
            .transpose()?,
        stops_end_switched_off: f.cia402.stops_end_switched_off,
        switch_on_requires_main_power: f.cia402.switch_on_requires_main_power,
        pp_bit6_absolute: f.cia402.pp_bit6_absolute,
        pp_change_on_set_point: f.cia402.pp_change_on_set_point,
        pp_set_point_buffer: f.cia402.pp_set_point_buffer,
        homing_methods: homing_methods(&f.cia402)?,
        homing_method_aliases: f
            .cia402
            .homing_method_aliases
            .iter()
            .map(|[from, to]| (*from, *to))
            .collect(),
        touch_probe_bit7: match f.cia402.touch_probe_bit7.as_deref() {
            None => crate::model::TouchProbeBit7::None,
            Some(s) => crate::model::TouchProbeBit7::parse(s).ok_or_else(|| {
                fault(
                    "cia402.touch_probe_bit7",
                    Invalid::Value(format!(
                        "`{s}` is not one of {:?}",
                        crate::model::TouchProbeBit7::NAMES
                    )),
                )
            })?,
        },
        touch_probe_bit6_source: f.cia402.touch_probe_bit6_source,
        touch_probe_function_bits: f.cia402.touch_probe_function_bits.unwrap_or(u16::MAX),
        touch_probe1_off_while_homing: f.cia402.touch_probe1_off_while_homing,
        touch_probe2_off_while_homing: f.cia402.touch_probe2_off_while_homing,
        following_error_fault: f.cia402.following_error_fault,
        digital_inputs_limits_swapped: f.cia402.digital_inputs_limits_swapped,
        digital_inputs_without_interlock: f.cia402.digital_inputs_without_interlock,
        following_error_zero_window_off: f.cia402.following_error_zero_window_off,
        home_offset_added: f.cia402.home_offset_added,
        home_offset_added_absolute: f.cia402.home_offset_added_absolute,
        store_requires_power_cycle: store_requires_power_cycle(&f.cia402)?,
        touch_probe_inputs: f
            .cia402
            .touch_probe_inputs
            .as_ref()
            .map(|t| touch_probe_inputs(t, &alarms))
            .transpose()?,
        max_interpolation_speed: match f.cia402.max_interpolation_speed {
            Some(0) => {
                return Err(fault(
                    "cia402.max_interpolation_speed",
                    Invalid::Value("0 would ignore every target".into()),
                ))
            }
            v => v,
        },
        safe_torque_off: f.cia402.safe_torque_off.map(safe_torque_off).transpose()?,
        torque_limit_statusword: f
            .cia402
            .torque_limit_statusword
            .map(|t| statusword_flag(t, "cia402.torque_limit_statusword.statusword_bit"))
            .transpose()?,
        csp_extrapolation: entry_ref(
            f.cia402.csp_extrapolation.as_deref(),
            "cia402.csp_extrapolation",
        )?,
        stop_codes: f
            .cia402
            .stop_codes
            .iter()
            .map(stop_code)
            .collect::<Result<_, _>>()?,
        fault_reaction_ignored: f.cia402.fault_reaction_ignored,
        mode_statusword: mode_statusword(&f.cia402.mode_statusword)?,
        option_codes_without_object: option_codes_without_object(
            &f.cia402.option_codes_without_object,
            &f.cia402.stop_codes,
            &declared,
        )?,
        torque_modes_stop_at_once: f.cia402.torque_modes_stop_at_once,
        torque_modes_halt_zero_torque: f.cia402.torque_modes_halt_zero_torque,
        software_limits_off: entry_ref(
            f.cia402.software_limits_off.as_deref(),
            "cia402.software_limits_off",
        )?,
        software_limits_need_reference: f.cia402.software_limits_need_reference,
        software_limits_less_home_offset: f.cia402.software_limits_less_home_offset,
        homing_here_while_disabled: f.cia402.homing_here_while_disabled,
        homing_start_while_disabled_error: f.cia402.homing_start_while_disabled_error,
        homing_here_needs_speed_zero: f.cia402.homing_here_needs_speed_zero,
        mode_entry_starts: f.cia402.mode_entry_starts,
        unit_ranges: f
            .cia402
            .unit_ranges
            .as_ref()
            .map(|u| unit_ranges(u, &alarms))
            .transpose()?,
        torque_reached: f
            .cia402
            .torque_reached
            .as_ref()
            .map(|[a, b, c]| -> Result<[(u16, u8); 3], Fault> {
                let key = "cia402.torque_reached";
                let entry = |s: &String| {
                    entry_ref(Some(s), key)?.ok_or_else(|| {
                        fault(key, Invalid::Value(format!("`{s}` is not \"0xIIII:S\"")))
                    })
                };
                Ok([entry(a)?, entry(b)?, entry(c)?])
            })
            .transpose()?,
        home_found_statusword: f
            .cia402
            .home_found_statusword
            .map(|t| statusword_flag(t, "cia402.home_found_statusword.statusword_bit"))
            .transpose()?,
        homing_error_alarm: f
            .cia402
            .homing_error_alarm
            .as_ref()
            .map(|r| fault_report(r, &alarms, "cia402.homing_error_alarm"))
            .transpose()?,
    };
    // The manufacturer-specific statusword bits show one condition each.
    let flags = [
        cia402.safe_torque_off.map(|s| s.statusword.bit),
        cia402.torque_limit_statusword.map(|f| f.bit),
        cia402.home_found_statusword.map(|f| f.bit),
    ];
    let used: Vec<u8> = flags.iter().flatten().copied().collect();
    if let Some(bit) = used.iter().enumerate().find_map(|(i, b)| {
        used.get(i + 1..)
            .filter(|rest| rest.contains(b))
            .map(|_| *b)
    }) {
        return Err(fault(
            "cia402.home_found_statusword.statusword_bit",
            Invalid::Value(format!(
                "statusword bit {bit} already shows another condition"
            )),
        ));
    }
    let mut profile = Profile {
        name: f.name.clone(),
        source: source.to_string(),
        description: f.description.clone(),
        vendor: Vendor {
            id: f.vendor.id,
            name: f.vendor.name.clone(),
        },
        device,
        eeprom,
        sm,
        mailbox,
        sync,
        dc_op_modes,
        max_pdo_entries: max_entries,
        max_assigned: f.pdo.max_assigned,
        max_pdo_bytes,
        max_process_bytes,
        sdo_write_to_rx_mapped,
        esm,
        emcy,
        kind,
        motor_faults,
        alarm_objects: alarm_objects(&f.alarm_objects)?,
        warnings: warnings(f, &alarms)?,
        alarms,
        units: Units {
            position: Factor::ONE,
            velocity: Factor::ONE,
            acceleration: crate::model::Acceleration::VelocityPerSecond,
            velocity_window: Factor::ONE,
            torque: Factor::ONE,
        },
        decisions: f
            .decisions
            .iter()
            .map(|d| Decision {
                subject: d.subject.clone(),
                manual: d.manual.clone(),
                choice: d.choice.clone(),
                reason: d.reason.clone(),
            })
            .collect(),
        replicate: f
            .replicate
            .iter()
            .map(|r| (r.first, r.last, r.offset))
            .collect(),
        rx_pdos,
        tx_pdos,
        objects: Vec::new(),
        storage: StorageRules::default(),
        adjusting: Vec::new(),
        split_values: Vec::new(),
        cia402,
    };
    for o in derived_objects(&profile)? {
        // A declared SM parameter object (the manual's layout) replaces the generated one.
        let declared_sm_parameter =
            SM_PARAMETER_OBJECTS.contains(&o.index) && declared.contains_key(&o.index);
        if !declared_sm_parameter {
            declared.insert(o.index, o);
        }
    }
    profile.objects = declared.into_values().collect();
    profile.units = units(&f.units, &profile)?;
    Ok(profile)
}

/// `[[split_value]]`: three writable integer parameters in RAM of at most 32 bits, a radix > 1.
fn split_values(
    files: &[crate::file::SplitValueFile],
    p: &Profile,
) -> Result<Vec<SplitValue>, Fault> {
    if files.len() > crate::validate::MAX_SPLIT_VALUES {
        return Err(fault(
            "split_value",
            Invalid::Value(format!(
                "{} settings, at most {}",
                files.len(),
                crate::validate::MAX_SPLIT_VALUES
            )),
        ));
    }
    files
        .iter()
        .enumerate()
        .map(|(i, f)| {
            let entry = |s: &str, name: &str| -> Result<(u16, u8), Fault> {
                let key = format!("split_value[{i}].{name}");
                let e = entry_ref(Some(s), &key)?.unwrap_or_default();
                crate::validate::integer_parameter(p, e, &key)?;
                Ok(e)
            };
            if f.radix < 2 {
                return Err(fault(
                    &format!("split_value[{i}].radix"),
                    Invalid::Value(format!("{} is not a radix (at least 2)", f.radix)),
                ));
            }
            Ok(SplitValue {
                whole: entry(&f.whole, "whole")?,
                high: entry(&f.high, "high")?,
                low: entry(&f.low, "low")?,
                radix: f.radix,
            })
        })
        .collect()
}

/// `[units]` → [`Units`]: each side an integer ≥ 1 or an unsigned entry of at most 32 bits
/// that exists (it is read at run time, so a master's write takes effect).
fn units(u: &crate::file::UnitsFile, p: &Profile) -> Result<Units, Fault> {
    let position = match &u.position {
        None => Factor::ONE,
        Some(v) => factor(v, p, "units.position")?,
    };
    let velocity = match &u.velocity {
        None => Factor::ONE,
        Some(toml::Value::String(s)) if s == "position" => position,
        Some(v) => factor(v, p, "units.velocity")?,
    };
    let acceleration = match &u.acceleration {
        None => crate::model::Acceleration::VelocityPerSecond,
        Some(toml::Value::Table(t)) if t.contains_key("ms_to_rpm") => {
            let rpm = t
                .get("ms_to_rpm")
                .and_then(toml::Value::as_integer)
                .and_then(|v| u32::try_from(v).ok())
                .filter(|v| *v >= 1 && t.len() == 1);
            crate::model::Acceleration::MsToRpm(rpm.ok_or_else(|| {
                fault(
                    "units.acceleration.ms_to_rpm",
                    Invalid::Value("the only key, an integer rpm ≥ 1".into()),
                )
            })?)
        }
        Some(v) => crate::model::Acceleration::Factor(factor(v, p, "units.acceleration")?),
    };
    let velocity_window = match &u.velocity_window {
        None => velocity,
        Some(v) => factor(v, p, "units.velocity_window")?,
    };
    let torque = match &u.torque {
        None => Factor::ONE,
        Some(v) => factor(v, p, "units.torque")?,
    };
    Ok(Units {
        position,
        velocity,
        acceleration,
        velocity_window,
        torque,
    })
}

fn factor(v: &toml::Value, p: &Profile, key: &str) -> Result<Factor, Fault> {
    let t = v.as_table().ok_or_else(|| {
        fault(
            key,
            Invalid::Value(
                "a table { numerator, denominator, scale = [n, d] } (velocity: or \"position\")"
                    .into(),
            ),
        )
    })?;
    if let Some(k) = t
        .keys()
        .find(|k| !matches!(k.as_str(), "numerator" | "denominator" | "scale"))
    {
        return Err(fault(&format!("{key}.{k}"), Invalid::NotAllowed("key")));
    }
    let side = |name: &str| -> Result<Operand, Fault> {
        let k = format!("{key}.{name}");
        match t.get(name) {
            None => Ok(Operand::Const(1)),
            Some(toml::Value::Integer(i)) => u32::try_from(*i)
                .ok()
                .filter(|v| *v >= 1)
                .map(Operand::Const)
                .ok_or_else(|| fault(&k, Invalid::Value("must be 1..=0xFFFFFFFF".into()))),
            Some(toml::Value::String(s)) if s == "counts_per_rev" => Ok(Operand::CountsPerRev),
            Some(toml::Value::String(s)) => {
                let (index, sub) = parse_entry_ref(s).ok_or_else(|| {
                    fault(&k, Invalid::Value(format!("`{s}` is not \"0xIIII:S\"")))
                })?;
                let e = p.entry(index, sub).ok_or_else(|| {
                    fault(
                        &k,
                        Invalid::PdoEntryMissing {
                            index,
                            subindex: sub,
                        },
                    )
                })?;
                let unsigned = matches!(
                    e.data_type,
                    DataType::Usint | DataType::Uint | DataType::Uint24 | DataType::Udint
                );
                if !unsigned || !e.access.readable() {
                    return Err(fault(
                        &k,
                        Invalid::Value(format!(
                            "{index:#06x}:{sub} must be a readable unsigned entry of at most 32 bits"
                        )),
                    ));
                }
                Ok(Operand::Entry(index, sub))
            }
            Some(_) => Err(fault(
                &k,
                Invalid::Value("an integer, \"0xIIII:S\" or \"counts_per_rev\"".into()),
            )),
        }
    };
    let scale = match t.get("scale") {
        None => (1, 1),
        Some(v) => {
            let pair: Option<(u32, u32)> = v.as_array().and_then(|a| match a.as_slice() {
                [n, d] => Some((
                    u32::try_from(n.as_integer()?).ok()?,
                    u32::try_from(d.as_integer()?).ok()?,
                )),
                _ => None,
            });
            pair.filter(|(n, d)| *n >= 1 && *d >= 1).ok_or_else(|| {
                fault(
                    &format!("{key}.scale"),
                    Invalid::Value("[numerator, denominator], both ≥ 1".into()),
                )
            })?
        }
    };
    Ok(Factor {
        numerator: side("numerator")?,
        denominator: side("denominator")?,
        scale,
    })
}

/// An optional `"0xIIII:S"` key → (index, subindex); existence is checked by `validate`.
fn entry_ref(s: Option<&str>, key: &str) -> Result<Option<(u16, u8)>, Fault> {
    s.map(|s| {
        parse_entry_ref(s)
            .ok_or_else(|| fault(key, Invalid::Value(format!("`{s}` is not \"0xIIII:S\""))))
    })
    .transpose()
}

/// `[[cia402.stop_codes]]`: an option-code object 605Ah–605Eh, a code and a known stop.
fn stop_code(c: &crate::file::StopCodeFile) -> Result<crate::model::StopCode, Fault> {
    use crate::model::{StopCode, StopRamp};
    const KEY: &str = "cia402.stop_codes";
    let object = parse_index(&c.object)
        .filter(|i| StopCode::OBJECTS.iter().any(|(o, _)| o == i))
        .ok_or_else(|| {
            fault(
                KEY,
                Invalid::Value(format!(
                    "`{}` is not an option-code object 0x605A-0x605E",
                    c.object
                )),
            )
        })?;
    let stop = StopRamp::parse(&c.stop).ok_or_else(|| {
        fault(
            KEY,
            Invalid::Value(format!("`{}` is not one of {:?}", c.stop, StopRamp::NAMES)),
        )
    })?;
    Ok(StopCode {
        object,
        code: c.code,
        stop,
        hold: c.hold,
    })
}

/// `[cia402.option_codes_without_object]`: only for an object the profile does not have, and
/// a code with a meaning (CiA402's, or the profile's own `[[cia402.stop_codes]]`).
fn option_codes_without_object(
    codes: &crate::file::OptionCodesFile,
    stop_codes: &[crate::file::StopCodeFile],
    declared: &BTreeMap<u16, Object>,
) -> Result<[Option<i16>; 5], Fault> {
    use crate::model::StopCode;
    const KEY: &str = "cia402.option_codes_without_object";
    let given = [
        codes.quick_stop,
        codes.shutdown,
        codes.disable_operation,
        codes.halt,
        codes.fault_reaction,
    ];
    for ((index, cause), code) in StopCode::OBJECTS.iter().zip(given) {
        let Some(code) = code else { continue };
        if declared.contains_key(index) {
            return Err(fault(
                KEY,
                Invalid::Value(format!("the profile has {index:04X}h: its value applies")),
            ));
        }
        let vendor = stop_codes
            .iter()
            .any(|c| parse_index(&c.object) == Some(*index) && c.code == code);
        if !vendor && !cia402_defines(cause, code) {
            return Err(fault(
                KEY,
                Invalid::Value(format!(
                    "{index:04X}h = {code} has no meaning (CiA402 reserves it)"
                )),
            ));
        }
    }
    Ok(given)
}

/// Whether CiA402 defines option code `code` for `cause` (a [`crate::model::StopCode::OBJECTS`]
/// name), as the firmware's `cia402::stop::reaction` has it.
fn cia402_defines(cause: &str, code: i16) -> bool {
    use cia402::stop::Cause;
    let cause = match cause {
        "QuickStop" => Cause::QuickStop,
        "Shutdown" => Cause::Shutdown,
        "DisableOperation" => Cause::DisableOperation,
        "Halt" => Cause::Halt,
        _ => Cause::Fault,
    };
    cia402::stop::reaction(cause, code).is_some()
}

/// `[[cia402.mode_statusword]]`: known conditions, each mode once (in one entry only), a
/// mode of operation CiA402 defines (1-10).
fn mode_statusword(
    entries: &[crate::file::ModeStatuswordFile],
) -> Result<Vec<crate::model::ModeStatusword>, Fault> {
    use crate::model::{parse_mode_bit, ModeBit, ModeStatusword, MODE_BITS};
    const KEY: &str = "cia402.mode_statusword";
    let mut out: Vec<ModeStatusword> = Vec::new();
    for e in entries {
        let mut bits = [ModeBit::Nothing; 4];
        for (bit, name) in bits.iter_mut().zip(&e.bits) {
            *bit = parse_mode_bit(name).ok_or_else(|| {
                let names: Vec<&str> = MODE_BITS.iter().map(|(n, _, _)| *n).collect();
                fault(
                    KEY,
                    Invalid::Value(format!("`{name}` is not one of {names:?}")),
                )
            })?;
        }
        if e.modes.is_empty() {
            return Err(fault(KEY, Invalid::Value("an entry names no mode".into())));
        }
        for &mode in &e.modes {
            if !(1..=10).contains(&mode) {
                return Err(fault(
                    KEY,
                    Invalid::Value(format!("mode {mode} has no CiA402 statusword table (1-10)")),
                ));
            }
            if out.iter().any(|o| o.mode == mode) {
                return Err(fault(
                    KEY,
                    Invalid::Value(format!("mode {mode} is given twice")),
                ));
            }
            // The firmware works out only some conditions beyond a mode's own.
            if let Some(b) = bits
                .iter()
                .find(|b| !cia402::mode_status::can_show(mode, **b))
            {
                return Err(fault(
                    KEY,
                    Invalid::Value(format!(
                        "the drive does not work out `{}` in mode {mode}",
                        MODE_BITS
                            .iter()
                            .find(|(_, m, _)| m == b)
                            .map_or("?", |(n, _, _)| *n)
                    )),
                ));
            }
            out.push(ModeStatusword { mode, bits });
        }
    }
    Ok(out)
}

/// `"0x6091:1"` → (0x6091, 1); the subindex may be decimal or `0x` hex.
pub(crate) fn parse_entry_ref(s: &str) -> Option<(u16, u8)> {
    let (i, sub) = s.split_once(':')?;
    let index = parse_index(i)?;
    let sub = sub.trim();
    let sub = match sub.strip_prefix("0x") {
        Some(h) => u8::from_str_radix(h, 16).ok()?,
        None => sub.parse().ok()?,
    };
    Some((index, sub))
}

/// `"0x6091"` → 0x6091 (an object index is always written in hex with `0x`).
pub(crate) fn parse_index(s: &str) -> Option<u16> {
    let s = s.trim();
    let hex = s.strip_prefix("0x").or(s.strip_prefix("0X"))?;
    u16::from_str_radix(hex, 16).ok()
}

/// `[warnings]` → [`Warning`]s: known conditions, a load percentage (1–100) for the overloads
/// and none for the switches, an alarm named by display must be a warning (`warning = true`).
fn warnings(f: &ProfileFile, alarms: &[Alarm]) -> Result<Vec<Warning>, Fault> {
    for key in f.warnings.keys() {
        if !WarningCondition::KEYS.contains(&key.as_str()) {
            return Err(fault(
                &format!("warnings.{key}"),
                Invalid::Value(format!("not one of {}", WarningCondition::KEYS.join(", "))),
            ));
        }
    }
    let mut out = Vec::new();
    for key in WarningCondition::KEYS {
        let Some(w) = f.warnings.get(key) else {
            continue;
        };
        let at = format!("warnings.{key}");
        let percent = || {
            w.load_percent
                .filter(|p| (1..=100).contains(p))
                .ok_or_else(|| {
                    fault(
                        &at,
                        Invalid::Value("load_percent 1 to 100 is needed".into()),
                    )
                })
        };
        let switch = |c: WarningCondition| {
            if w.load_percent.is_some() {
                Err(fault(&at, Invalid::NotAllowed("load_percent")))
            } else {
                Ok(c)
            }
        };
        let condition = match key {
            "motor_overload" => WarningCondition::MotorOverload {
                percent: percent()?,
            },
            "drive_overload" => WarningCondition::DriveOverload {
                percent: percent()?,
            },
            "positive_limit" => switch(WarningCondition::PositiveLimit)?,
            "homing_error" => switch(WarningCondition::HomingError)?,
            _ => switch(WarningCondition::NegativeLimit)?,
        };
        if let MotorFaultFile::Alarm(display) = &w.report {
            if alarms.iter().any(|a| a.display == *display && !a.warning) {
                return Err(fault(
                    &at,
                    Invalid::Value(format!("[[alarm]] `{display}` is not a warning")),
                ));
            }
        }
        out.push(Warning {
            condition,
            report: fault_report(&w.report, alarms, &at)?,
        });
    }
    Ok(out)
}

/// `[alarm_objects]` → [`AlarmObjects`]; the objects and what every alarm's number needs are
/// checked by `validate`.
fn alarm_objects(f: &crate::file::AlarmObjectsFile) -> Result<AlarmObjects, Fault> {
    let index = |s: &Option<String>, key: &str| -> Result<Option<u16>, Fault> {
        s.as_deref()
            .map(|s| {
                parse_index(s)
                    .ok_or_else(|| fault(key, Invalid::Value(format!("`{s}` is not \"0xIIII\""))))
            })
            .transpose()
    };
    let number = match f.number.as_deref() {
        None => AlarmNumber::ErrorNumber,
        Some(s) => AlarmNumber::parse(s).ok_or_else(|| {
            fault(
                "alarm_objects.number",
                Invalid::Value(format!("`{s}` is not error_number, display or error_code")),
            )
        })?,
    };
    let select = entry_ref(f.history_select.as_deref(), "alarm_objects.history_select")?;
    let record = index(&f.history_record, "alarm_objects.history_record")?;
    let history_record = match (select, record) {
        (None, None) if f.history_fields.is_empty() => None,
        (Some(select), Some(object)) => {
            let fields = f
                .history_fields
                .iter()
                .enumerate()
                .map(|(i, s)| {
                    RecordField::parse(s).ok_or_else(|| {
                        fault(
                            &format!("alarm_objects.history_fields[{i}]"),
                            Invalid::Value(format!("`{s}` is not a record field")),
                        )
                    })
                })
                .collect::<Result<Vec<_>, _>>()?;
            Some(HistoryRecord {
                select,
                object,
                fields,
            })
        }
        _ => {
            return Err(fault(
                "alarm_objects.history_record",
                Invalid::Missing("history_select, history_record and history_fields together"),
            ))
        }
    };
    Ok(AlarmObjects {
        number,
        active: index(&f.active, "alarm_objects.active")?,
        history: index(&f.history, "alarm_objects.history")?,
        history_clear: entry_ref(f.history_clear.as_deref(), "alarm_objects.history_clear")?,
        history_record,
    })
}

/// `[[alarm]]` → [`Alarm`]s; `display` must be unique and non-empty.
fn alarms(f: &ProfileFile) -> Result<Vec<Alarm>, Fault> {
    let mut seen = BTreeSet::new();
    f.alarms
        .iter()
        .map(|a| {
            if a.display.is_empty() || !seen.insert(a.display.as_str()) {
                return Err(fault(
                    &format!("alarm[{}].display", a.display),
                    Invalid::Value("alarm displays must be unique and non-empty".into()),
                ));
            }
            Ok(Alarm {
                display: a.display.clone(),
                name: a.name.clone(),
                error_code: a.error_code,
                emcy: EmcyCode {
                    code: a.emcy_code.unwrap_or(a.error_code),
                    data: a.emcy_data.unwrap_or_default(),
                },
                resettable: a.resettable,
                warning: a.warning,
                description: a.description.clone(),
            })
        })
        .collect()
}

/// `[motor_faults]` → the 603Fh code and EMCY bytes in the order of [`MOTOR_FAULT_NAMES`]: a
/// code, or an alarm's display (its 603Fh code and EMCY bytes). Unknown names are reported
/// first (the first in key order), then every missing name at once. Zero codes are checked in
/// [`crate::validate`].
/// `[motor_faults]`; `as_emcy`: the emergency code every fault given by its 603Fh code is sent
/// with, and the EMCY byte its 603Fh code goes to (`[emcy] motor_fault_code`).
fn motor_faults(
    map: &BTreeMap<String, MotorFaultFile>,
    alarms: &[Alarm],
    as_emcy: Option<(u16, u8)>,
) -> Result<[MotorFaultCode; MOTOR_FAULT_COUNT], Fault> {
    if let Some(name) = map
        .keys()
        .find(|k| !MOTOR_FAULT_NAMES.contains(&k.as_str()))
    {
        return Err(fault(
            &format!("motor_faults.{name}"),
            Invalid::UnknownMotorFault(name.clone()),
        ));
    }
    let missing: Vec<&'static str> = MOTOR_FAULT_NAMES
        .into_iter()
        .filter(|n| !map.contains_key(*n))
        .collect();
    if !missing.is_empty() {
        return Err(fault("motor_faults", Invalid::MissingMotorFaults(missing)));
    }
    let mut codes = [MotorFaultCode::default(); MOTOR_FAULT_COUNT];
    for (code, name) in codes.iter_mut().zip(MOTOR_FAULT_NAMES) {
        *code = match map.get(name) {
            None => MotorFaultCode::default(),
            Some(r) => fault_report(r, alarms, &format!("motor_faults.{name}"))?,
        };
        if let (Some((emcy_code, byte)), MotorFaultCode { alarm: None, .. }) = (as_emcy, *code) {
            // The manufacturer field is EMCY bytes 3-7; resolve checked byte 3..=6.
            let at = usize::from(byte - EMCY_DATA_BYTES.start());
            let mut data = [0u8; 5];
            data[at..at + 2].copy_from_slice(&code.error_code.to_le_bytes());
            code.emcy = EmcyCode {
                code: emcy_code,
                data,
            };
        }
    }
    Ok(codes)
}

/// `[cia402.unit_ranges]`: each range with positive ends, min ≤ max.
fn unit_ranges(
    u: &crate::file::UnitRangesFile,
    alarms: &[Alarm],
) -> Result<crate::model::UnitRanges, Fault> {
    const KEY: &str = "cia402.unit_ranges";
    let range = |r: Option<crate::file::RatioRangeFile>| {
        r.map(|r| {
            let ([a, b], [c, d]) = (r.min, r.max);
            // min ≤ max as fractions: a/b ≤ c/d ⇔ a·d ≤ c·b (all positive).
            if a == 0
                || b == 0
                || c == 0
                || d == 0
                || u64::from(a) * u64::from(d) > u64::from(c) * u64::from(b)
            {
                return Err(fault(
                    KEY,
                    Invalid::Value(format!("{a}/{b}..{c}/{d}: positive ends, min ≤ max")),
                ));
            }
            Ok(crate::model::RatioRange {
                min: (a, b),
                max: (c, d),
                inclusive: r.inclusive,
            })
        })
        .transpose()
    };
    Ok(crate::model::UnitRanges {
        error: fault_report(&u.error, alarms, &format!("{KEY}.error"))?,
        position: range(u.position)?,
        velocity: range(u.velocity)?,
        acceleration: range(u.acceleration)?,
        torque: range(u.torque)?,
    })
}

/// A code (the same in 603Fh and the EMCY, no manufacturer data) or an alarm's display (its
/// 603Fh code and EMCY bytes).
fn fault_report(r: &MotorFaultFile, alarms: &[Alarm], key: &str) -> Result<MotorFaultCode, Fault> {
    match r {
        MotorFaultFile::Code(c) => Ok(MotorFaultCode {
            error_code: *c,
            emcy: EmcyCode {
                code: *c,
                data: [0; 5],
            },
            alarm: None,
        }),
        MotorFaultFile::Alarm(display) => {
            let (at, a) = alarms
                .iter()
                .enumerate()
                .find(|(_, a)| a.display == *display)
                .ok_or_else(|| {
                    fault(
                        key,
                        Invalid::Value(format!("no [[alarm]] with display `{display}`")),
                    )
                })?;
            Ok(MotorFaultCode {
                error_code: a.error_code,
                emcy: a.emcy,
                alarm: Some(at),
            })
        }
    }
}

/// `[esm] lost_outputs`: the entry references parse, the AL status code is one of the two sync
/// error codes, there is at least one value.
fn lost_outputs(l: &crate::file::LostOutputsFile, alarms: &[Alarm]) -> Result<LostOutputs, Fault> {
    let entry = |s: &str, key: &str| {
        entry_ref(Some(s), key)?.ok_or_else(|| fault(key, Invalid::Value("missing".into())))
    };
    if !matches!(
        l.al_status_code,
        crate::file::AL_SYNC_ERROR | crate::file::AL_FATAL_SYNC_ERROR
    ) {
        return Err(fault(
            "esm.lost_outputs.al_status_code",
            Invalid::Value(format!("{:#06x} is not 0x001A or 0x002C", l.al_status_code)),
        ));
    }
    if l.while_values.is_empty() {
        return Err(fault(
            "esm.lost_outputs.while_values",
            Invalid::Value("needs at least one value".into()),
        ));
    }
    Ok(LostOutputs {
        limit_parameter: entry(&l.limit_parameter, "esm.lost_outputs.limit_parameter")?,
        while_entry: entry(&l.while_entry, "esm.lost_outputs.while_entry")?,
        while_values: l.while_values.clone(),
        al_status_code: l.al_status_code,
        error: fault_report(&l.error, alarms, "esm.lost_outputs.error")?,
    })
}

/// `[esm] al_error_alarms[].err_led`: the rows that give their own ERR LED pattern, sorted by
/// code (the codes were checked by [`al_error_alarms`]).
fn al_error_leds(rows: &[AlErrorAlarmFile]) -> Result<Vec<(u16, ErrLed)>, Fault> {
    let mut out = Vec::new();
    for (i, row) in rows.iter().enumerate() {
        let Some(s) = row.err_led.as_deref() else {
            continue;
        };
        let led = ErrLed::parse(s).ok_or_else(|| {
            fault(
                &format!("esm.al_error_alarms[{i}].err_led"),
                Invalid::Value(format!(
                    "`{s}` is not blinking, single_flash, double_flash or on"
                )),
            )
        })?;
        out.push((row.al_status_code, led));
    }
    out.sort_by_key(|(c, _)| *c);
    Ok(out)
}

/// `[esm] al_error_alarms`: AL status codes (non-zero, each once) with the drive error each
/// raises, sorted by code.
fn al_error_alarms(
    rows: &[AlErrorAlarmFile],
    alarms: &[Alarm],
) -> Result<Vec<(u16, MotorFaultCode)>, Fault> {
    let mut out: Vec<(u16, MotorFaultCode)> = Vec::with_capacity(rows.len());
    for (i, row) in rows.iter().enumerate() {
        let key = format!("esm.al_error_alarms[{i}]");
        let code = row.al_status_code;
        if code == 0 {
            return Err(fault(
                &format!("{key}.al_status_code"),
                Invalid::Value("0x0000 is \"no error\"".into()),
            ));
        }
        if out.iter().any(|(c, _)| *c == code) {
            return Err(fault(
                &format!("{key}.al_status_code"),
                Invalid::Value(format!("AL status code {code:#06x} is listed twice")),
            ));
        }
        let report = fault_report(&row.error, alarms, &format!("{key}.error"))?;
        if report.error_code == 0 {
            return Err(fault(
                &format!("{key}.error"),
                Invalid::Value("0 is \"no error\" (603Fh)".into()),
            ));
        }
        out.push((code, report));
    }
    out.sort_by_key(|(c, _)| *c);
    Ok(out)
}

/// The section an object index is derived from, if od-gen generates it.
fn derived_from(index: u16, f: &ProfileFile) -> Option<&'static str> {
    match index {
        0x1008 | 0x1009 | 0x100A | 0x1018 => Some("device"),
        0x1600..=0x17FF => Some("rxpdo"),
        0x1A00..=0x1BFF => Some("txpdo"),
        // 1C10h/1C11h (PDO assignment of the mailbox SMs) are not generated: a profile whose
        // manual lists them declares them.
        0x1C00 | 0x1C12..=0x1C2F => Some("sm"),
        // 1C32h/1C33h are generated from [sync] unless the profile declares its manual's
        // layout (checked against [sync] by `validate`).
        _ => {
            let _ = f;
            None
        }
    }
}

fn object(o: &ObjectFile, key: &str) -> Result<Object, Fault> {
    let code = match o.code.as_deref() {
        None | Some("var") => ObjectCode::Var,
        Some("record") => ObjectCode::Record,
        Some("array") => ObjectCode::Array,
        Some(other) => {
            return Err(fault(
                &format!("{key}.code"),
                Invalid::Value(format!("`{other}` is not var, record or array")),
            ))
        }
    };
    let attrs = o.attrs();
    let entries = if code == ObjectCode::Var {
        if !o.entries.is_empty() {
            return Err(fault(key, Invalid::NotAllowed("entry (on a VAR object)")));
        }
        vec![entry(0, &o.name, &attrs, key)?]
    } else {
        if let Some(k) = first_value_key(&attrs) {
            return Err(fault(key, Invalid::NotAllowed(k)));
        }
        if o.entries.is_empty() {
            return Err(fault(key, Invalid::Missing("entry")));
        }
        let mut subs: BTreeMap<u8, Entry> = BTreeMap::new();
        let mut names: BTreeSet<&str> = BTreeSet::new();
        for e in &o.entries {
            let ekey = format!("{key}.entry[{:#04x}]", e.sub);
            // The ESI's DataType SubItems are keyed by name (EtherCATInfo.xsd `SubItemKey`), and
            // subindex 0 is "SubIndex 000".
            if !names.insert(e.name.as_str()) || e.name == "SubIndex 000" {
                return Err(fault(
                    &format!("{ekey}.name"),
                    Invalid::DuplicateEntryName(e.name.clone()),
                ));
            }
            if e.sub == 0 {
                return Err(fault(
                    &ekey,
                    Invalid::Value("subindex 0 is generated (highest subindex / count)".into()),
                ));
            }
            let mut attrs = e.attrs();
            attrs.setting |= o.setting;
            let en = entry(e.sub, &e.name, &attrs, &ekey)?;
            if subs.insert(e.sub, en).is_some() {
                return Err(fault(&ekey, Invalid::DuplicateSubindex(e.sub)));
            }
        }
        if code == ObjectCode::Array {
            let first = subs.values().next().map(|e| (e.data_type, e.bit_len));
            let contiguous = subs
                .keys()
                .copied()
                .eq(1..=u8::try_from(subs.len()).unwrap_or(u8::MAX));
            if !contiguous
                || subs
                    .values()
                    .any(|e| Some((e.data_type, e.bit_len)) != first)
            {
                return Err(fault(
                    key,
                    Invalid::Value("ARRAY entries must be subindex 1..n of one type".into()),
                ));
            }
        }
        let highest = subs.keys().next_back().copied().unwrap_or(0);
        let mut v = vec![sub0(highest, Access::RO, Storage::Const)];
        v.extend(subs.into_values());
        v
    };
    Ok(Object {
        index: o.index,
        code,
        name: o.name.clone(),
        doc: if code == ObjectCode::Var {
            Doc::default()
        } else {
            Doc {
                unit: o.unit.clone(),
                description: o.description.clone(),
            }
        },
        entries,
        derived: false,
    })
}

fn first_value_key(a: &EntryAttrs) -> Option<&'static str> {
    [
        (a.data_type.is_some(), "type"),
        (a.bits.is_some(), "bits"),
        (a.access.is_some(), "access"),
        (a.pdo.is_some(), "pdo"),
        (a.default.is_some(), "default"),
        (a.min.is_some(), "min"),
        (a.max.is_some(), "max"),
        (a.storage.is_some(), "storage"),
        (a.role.is_some(), "role"),
        (a.allowed.is_some(), "allowed"),
    ]
    .into_iter()
    .find(|(set, _)| *set)
    .map(|(_, k)| k)
}

/// Subindex 0 of a RECORD/ARRAY.
fn sub0(value: u8, access: Access, storage: Storage) -> Entry {
    Entry {
        subindex: 0,
        name: "SubIndex 000".into(),
        data_type: DataType::Usint,
        bit_len: 8,
        access,
        pdo: PdoMapping::No,
        storage,
        default: vec![value],
        min: Vec::new(),
        max: Vec::new(),
        role: None,
        setting: false,
        doc: Doc::default(),
        allowed: Vec::new(),
    }
}

fn entry(subindex: u8, name: &str, a: &EntryAttrs, key: &str) -> Result<Entry, Fault> {
    let k = |s: &str| format!("{key}.{s}");
    let tname = a
        .data_type
        .as_deref()
        .ok_or_else(|| fault(key, Invalid::Missing("type")))?;
    let data_type = DataType::parse(tname)
        .ok_or_else(|| fault(&k("type"), Invalid::UnknownType(tname.into())))?;
    let access = match a.access.as_deref() {
        None => return Err(fault(key, Invalid::Missing("access"))),
        Some(s) => Access::parse(s).ok_or_else(|| {
            fault(
                &k("access"),
                Invalid::Value(format!("unknown access `{s}`")),
            )
        })?,
    };
    if data_type == DataType::Domain || a.storage.as_deref() == Some("domain") {
        return domain_entry(subindex, name, data_type, access, a, key);
    }
    let pdo = match a.pdo.as_deref() {
        None | Some("no") => PdoMapping::No,
        Some("rx") => PdoMapping::Rx,
        Some("tx") => PdoMapping::Tx,
        Some("rxtx") => PdoMapping::RxTx,
        Some(s) => {
            return Err(fault(
                &k("pdo"),
                Invalid::Value(format!("`{s}` is not no, rx, tx or rxtx")),
            ))
        }
    };
    if pdo.rx() && !access.writable() {
        return Err(fault(
            &k("pdo"),
            Invalid::Value("an RxPDO-mappable entry must be writable".into()),
        ));
    }
    if pdo.tx() && !access.readable() {
        return Err(fault(
            &k("pdo"),
            Invalid::Value("a TxPDO-mappable entry must be readable".into()),
        ));
    }
    let role = match a.role.as_deref() {
        None => None,
        Some(s) => Some(
            Role::parse(s)
                .ok_or_else(|| fault(&k("role"), Invalid::Value(format!("unknown role `{s}`"))))?,
        ),
    };
    let default = match &a.default {
        None => Vec::new(),
        Some(v) => encode(data_type, v).map_err(|e| fault(&k("default"), e))?,
    };
    let bit_len = match (data_type.fixed_bits(), a.bits) {
        (Some(b), None) => b,
        (Some(b), Some(given)) if given == b => b,
        (Some(b), Some(given)) => {
            return Err(fault(
                &k("bits"),
                Invalid::Value(format!("{tname} has {b} bits, `bits` says {given}")),
            ))
        }
        (None, Some(given)) => {
            if given == 0 || given % 8 != 0 || usize::from(given / 8) < default.len() {
                return Err(fault(
                    &k("bits"),
                    Invalid::Value("must be a non-zero multiple of 8 holding the default".into()),
                ));
            }
            given
        }
        (None, None) if !default.is_empty() => u16::try_from(default.len() * 8)
            .map_err(|_| fault(&k("default"), Invalid::Value("too long".into())))?,
        (None, None) => return Err(fault(key, Invalid::Missing("bits"))),
    };
    let min = match &a.min {
        None => Vec::new(),
        Some(v) => encode(data_type, v).map_err(|e| fault(&k("min"), e))?,
    };
    let max = match &a.max {
        None => Vec::new(),
        Some(v) => encode(data_type, v).map_err(|e| fault(&k("max"), e))?,
    };
    if data_type.is_string() && (!min.is_empty() || !max.is_empty()) {
        return Err(fault(key, Invalid::NotAllowed("min/max (on a string)")));
    }
    check_range(data_type, &default, &min, &max).map_err(|e| fault(&k("default"), e))?;
    let allowed = match &a.allowed {
        None => Vec::new(),
        Some(values) => allowed_values(data_type, values, &default, &min, &max)
            .map_err(|e| fault(&k("allowed"), e))?,
    };
    let storage = match a.storage.as_deref() {
        None if access.writable() || pdo != PdoMapping::No || role.is_some() => Storage::Ram,
        None => Storage::Const,
        Some("ram") => Storage::Ram,
        Some("const") if access.writable() || pdo != PdoMapping::No || role.is_some() => {
            return Err(fault(
                &k("storage"),
                Invalid::Value(
                    "a writable, PDO-mappable or role entry must be stored in RAM".into(),
                ),
            ))
        }
        Some("const") => Storage::Const,
        Some(s) => {
            return Err(fault(
                &k("storage"),
                Invalid::Value(format!("`{s}` is not ram or const")),
            ))
        }
    };
    if let Some(r) = role {
        if !r.accepts(data_type) {
            let expected = match r.data_type() {
                DataType::Uint => "UINT",
                DataType::Sint => "SINT",
                DataType::Int => "INT",
                DataType::Udint => "UDINT",
                _ => "DINT",
            };
            return Err(fault(
                &k("role"),
                Invalid::RoleType {
                    role: r.field().into(),
                    expected,
                },
            ));
        }
    }
    Ok(Entry {
        subindex,
        name: name.to_string(),
        data_type,
        bit_len,
        access,
        pdo,
        storage,
        default,
        min,
        max,
        role,
        setting: a.setting,
        allowed,
        doc: Doc {
            unit: a.unit.clone(),
            description: a.description.clone(),
        },
    })
}

/// A DOMAIN entry: `type = "DOMAIN"` with `storage = "domain"`, nothing else. Its data lives in
/// the firmware's domain store, so it has no default, range, PDO mapping, role or bit size (the
/// entry's bit length is 0: the size is the domain's current length).
fn domain_entry(
    subindex: u8,
    name: &str,
    data_type: DataType,
    access: Access,
    a: &EntryAttrs,
    key: &str,
) -> Result<Entry, Fault> {
    let k = |s: &str| format!("{key}.{s}");
    if data_type != DataType::Domain {
        return Err(fault(
            &k("storage"),
            Invalid::Value("`storage = \"domain\"` needs `type = \"DOMAIN\"`".into()),
        ));
    }
    if a.storage.as_deref() != Some("domain") {
        return Err(fault(
            &k("storage"),
            Invalid::Value("a DOMAIN entry needs `storage = \"domain\"`".into()),
        ));
    }
    let forbidden = [
        (a.pdo.is_some(), "pdo"),
        (a.default.is_some(), "default"),
        (a.min.is_some(), "min"),
        (a.max.is_some(), "max"),
        (a.role.is_some(), "role"),
        (a.bits.is_some(), "bits"),
    ];
    if let Some((_, name)) = forbidden.iter().find(|(given, _)| *given) {
        return Err(fault(&k(name), Invalid::NotAllowed(name)));
    }
    Ok(Entry {
        subindex,
        name: name.to_string(),
        data_type,
        bit_len: 0,
        access,
        pdo: PdoMapping::No,
        storage: Storage::Domain,
        default: Vec::new(),
        min: Vec::new(),
        max: Vec::new(),
        role: None,
        setting: a.setting,
        allowed: Vec::new(),
        doc: Doc {
            unit: a.unit.clone(),
            description: a.description.clone(),
        },
    })
}

/// A number read from a profile value.
#[derive(Clone, Copy, PartialEq, PartialOrd)]
enum Num {
    Int(i128),
    Float(f64),
}

fn int_of(v: &toml::Value) -> Option<i128> {
    match v {
        toml::Value::Integer(i) => Some(i128::from(*i)),
        toml::Value::Boolean(b) => Some(i128::from(*b)),
        toml::Value::String(s) => {
            let t = s.replace('_', "");
            let (neg, t) = match t.strip_prefix('-') {
                Some(r) => (true, r.to_string()),
                None => (false, t),
            };
            let n = if let Some(h) = t.strip_prefix("0x").or_else(|| t.strip_prefix("0X")) {
                i128::from_str_radix(h, 16).ok()?
            } else {
                t.parse::<i128>().ok()?
            };
            Some(if neg { -n } else { n })
        }
        toml::Value::Float(_)
        | toml::Value::Datetime(_)
        | toml::Value::Array(_)
        | toml::Value::Table(_) => None,
    }
}

/// Encodes a profile value as little-endian bytes of the type.
fn encode(dt: DataType, v: &toml::Value) -> Result<Vec<u8>, Invalid> {
    match dt {
        DataType::VisibleString => match v {
            toml::Value::String(s) if s.is_ascii() => Ok(s.as_bytes().to_vec()),
            _ => Err(Invalid::Value(
                "a VISIBLE_STRING value must be an ASCII string".into(),
            )),
        },
        DataType::UnicodeString => match v {
            toml::Value::String(s) => Ok(s.encode_utf16().flat_map(u16::to_le_bytes).collect()),
            _ => Err(Invalid::Value(
                "a UNICODE_STRING value must be a string".into(),
            )),
        },
        DataType::OctetString => match v {
            toml::Value::String(s) => {
                let hex: String = s.chars().filter(|c| !c.is_whitespace()).collect();
                if hex.len() % 2 != 0 {
                    return Err(Invalid::Value(
                        "an OCTET_STRING value is an even number of hex digits".into(),
                    ));
                }
                (0..hex.len())
                    .step_by(2)
                    .map(|i| {
                        hex.get(i..i + 2)
                            .and_then(|b| u8::from_str_radix(b, 16).ok())
                            .ok_or_else(|| {
                                Invalid::Value("an OCTET_STRING value is hex digits".into())
                            })
                    })
                    .collect()
            }
            _ => Err(Invalid::Value(
                "an OCTET_STRING value must be a hex string".into(),
            )),
        },
        DataType::Real | DataType::Lreal => {
            let x = match v {
                toml::Value::Float(x) => *x,
                toml::Value::Integer(i) => *i as f64,
                _ => return Err(Invalid::Value("a REAL value must be a number".into())),
            };
            if dt == DataType::Real {
                let y = x as f32;
                if x.is_finite() && !y.is_finite() {
                    return Err(Invalid::OutOfTypeRange(format!("{x} does not fit REAL")));
                }
                Ok(y.to_le_bytes().to_vec())
            } else {
                Ok(x.to_le_bytes().to_vec())
            }
        }
        _ => {
            let n =
                int_of(v).ok_or_else(|| Invalid::Value("an integer value is expected".into()))?;
            let (lo, hi) = dt.int_range().unwrap_or((0, 0));
            if n < lo || n > hi {
                return Err(Invalid::OutOfTypeRange(format!(
                    "{n} is not in {lo}..={hi}"
                )));
            }
            let bytes = usize::from(dt.fixed_bits().unwrap_or(8)).div_ceil(8);
            Ok(n.to_le_bytes()
                .get(..bytes)
                .map(<[u8]>::to_vec)
                .unwrap_or_default())
        }
    }
}

/// Decodes little-endian bytes of a numeric type.
fn decode(dt: DataType, b: &[u8]) -> Option<Num> {
    match dt {
        DataType::Real => Some(Num::Float(f64::from(f32::from_le_bytes(
            b.try_into().ok()?,
        )))),
        DataType::Lreal => Some(Num::Float(f64::from_le_bytes(b.try_into().ok()?))),
        _ if dt.is_string() || b.is_empty() => None,
        _ => {
            let mut buf = [0u8; 16];
            buf.get_mut(..b.len())?.copy_from_slice(b);
            let mut n = i128::from_le_bytes(buf);
            let bits = 8 * b.len() as u32;
            if dt.is_signed() && n >> (bits - 1) & 1 == 1 {
                n -= 1i128 << bits;
            }
            Some(Num::Int(n))
        }
    }
}

/// `allowed`: integers of the entry's type, inside `min..=max`, without repeats, the default
/// among them; sorted.
fn allowed_values(
    dt: DataType,
    values: &[toml::Value],
    default: &[u8],
    min: &[u8],
    max: &[u8],
) -> Result<Vec<i64>, Invalid> {
    if dt.is_string() || matches!(dt, DataType::Real | DataType::Lreal | DataType::Domain) {
        return Err(Invalid::Value(
            "only integer entries take a list of values".into(),
        ));
    }
    if values.is_empty() {
        return Err(Invalid::Value(
            "an empty list would refuse every write".into(),
        ));
    }
    let mut out = Vec::new();
    for v in values {
        let bytes = encode(dt, v)?;
        check_range(dt, &bytes, min, max)
            .map_err(|_| Invalid::Value(format!("{v} lies outside min..=max")))?;
        let n = match decode(dt, &bytes) {
            Some(Num::Int(n)) => i64::try_from(n).ok(),
            _ => None,
        }
        .ok_or_else(|| Invalid::Value(format!("{v} is not an integer of the entry's type")))?;
        if out.contains(&n) {
            return Err(Invalid::Value(format!("{v} is listed twice")));
        }
        out.push(n);
    }
    if let Some(Num::Int(d)) = decode(dt, default) {
        if !out.iter().any(|n| i128::from(*n) == d) {
            return Err(Invalid::Value("the default is not in the list".into()));
        }
    }
    out.sort_unstable();
    Ok(out)
}

fn check_range(dt: DataType, default: &[u8], min: &[u8], max: &[u8]) -> Result<(), Invalid> {
    let (d, lo, hi) = (decode(dt, default), decode(dt, min), decode(dt, max));
    if let (Some(lo), Some(hi)) = (lo, hi) {
        if lo > hi {
            return Err(Invalid::DefaultOutOfRange);
        }
    }
    if let Some(d) = d {
        if lo.is_some_and(|lo| d < lo) || hi.is_some_and(|hi| d > hi) {
            return Err(Invalid::DefaultOutOfRange);
        }
    }
    Ok(())
}

fn pdos(
    list: &[PdoFile],
    rx: bool,
    objects: &BTreeMap<u16, Object>,
    max_entries: u8,
) -> Result<Vec<Pdo>, Fault> {
    let kind = if rx { "rxpdo" } else { "txpdo" };
    let (range, sm) = if rx {
        (0x1600..=0x17FF, 2)
    } else {
        (0x1A00..=0x1BFF, 3)
    };
    let mut seen = BTreeSet::new();
    let mut out = Vec::new();
    for p in list {
        let key = format!("{kind}[{:#06x}]", p.index);
        if !range.contains(&p.index) {
            return Err(fault(&key, Invalid::PdoIndexRange(p.index)));
        }
        if !seen.insert(p.index) {
            return Err(fault(&key, Invalid::DuplicatePdo(p.index)));
        }
        if p.sm != sm {
            return Err(fault(
                &format!("{key}.sm"),
                Invalid::PdoSm {
                    sm: p.sm,
                    expected: sm,
                },
            ));
        }
        if p.entries.is_empty() {
            // ethercat-esi 0.2.0 and many tools reject PDOs without entries (esi-sii.md §3).
            return Err(fault(
                &format!("{key}.entries"),
                Invalid::Missing("entries"),
            ));
        }
        if p.entries.len() > usize::from(max_entries) {
            return Err(fault(
                &format!("{key}.entries"),
                Invalid::TooManyPdoEntries {
                    count: p.entries.len(),
                    max: max_entries,
                },
            ));
        }
        let mut entries = Vec::new();
        for (i, e) in p.entries.iter().enumerate() {
            let ekey = format!("{key}.entries[{i}]");
            entries.push(pdo_entry(e, rx, objects, &ekey)?);
        }
        out.push(Pdo {
            index: p.index,
            name: p.name.clone(),
            sm,
            fixed: p.fixed,
            mandatory: p.mandatory,
            assigned: p.assigned,
            entries,
        });
    }
    out.sort_by_key(|p| p.index);
    Ok(out)
}

fn pdo_entry(
    e: &crate::file::PdoEntryFile,
    rx: bool,
    objects: &BTreeMap<u16, Object>,
    key: &str,
) -> Result<PdoEntry, Fault> {
    match (e.pad, e.index, e.sub, e.bits) {
        (Some(bits), None, None, None) => {
            if bits == 0 || bits > 255 {
                return Err(fault(
                    key,
                    Invalid::Value("padding must be 1..=255 bits".into()),
                ));
            }
            Ok(PdoEntry {
                index: 0,
                subindex: 0,
                bits,
                name: String::new(),
                data_type: None,
            })
        }
        (None, Some(index), sub, Some(bits)) => {
            let subindex = sub.unwrap_or(0);
            let missing = || fault(key, Invalid::PdoEntryMissing { index, subindex });
            let obj = objects.get(&index).ok_or_else(missing)?;
            let en = obj.entry(subindex).ok_or_else(missing)?;
            let ok = if rx { en.pdo.rx() } else { en.pdo.tx() };
            if !ok {
                return Err(fault(key, Invalid::PdoEntryNotMappable { index, subindex }));
            }
            if en.bit_len != bits {
                return Err(fault(
                    key,
                    Invalid::PdoEntryBitLen {
                        index,
                        subindex,
                        pdo: bits,
                        object: en.bit_len,
                    },
                ));
            }
            if en.storage != Storage::Ram {
                return Err(fault(
                    key,
                    Invalid::Value("a mapped entry must be stored in RAM".into()),
                ));
            }
            let name = if obj.code == ObjectCode::Var {
                obj.name.clone()
            } else {
                en.name.clone()
            };
            Ok(PdoEntry {
                index,
                subindex,
                bits,
                name,
                data_type: Some(en.data_type),
            })
        }
        (None, Some(_), _, None) => Err(fault(key, Invalid::Missing("bits"))),
        _ => Err(fault(
            key,
            Invalid::Value("a PDO entry is `{ index, sub, bits }` or `{ pad = bits }`".into()),
        )),
    }
}

fn var(index: u16, name: &str, e: Entry) -> Object {
    Object {
        index,
        code: ObjectCode::Var,
        name: name.into(),
        entries: vec![e],
        derived: true,
        doc: Doc::default(),
    }
}

#[allow(clippy::too_many_arguments)]
fn val(
    sub: u8,
    name: &str,
    dt: DataType,
    access: Access,
    storage: Storage,
    default: Vec<u8>,
    min: Vec<u8>,
    max: Vec<u8>,
) -> Entry {
    let bit_len = dt
        .fixed_bits()
        .unwrap_or_else(|| u16::try_from(default.len() * 8).unwrap_or(0));
    Entry {
        subindex: sub,
        name: name.into(),
        data_type: dt,
        bit_len,
        access,
        pdo: PdoMapping::No,
        storage,
        default,
        min,
        max,
        role: None,
        setting: false,
        doc: Doc::default(),
        allowed: Vec::new(),
    }
}

fn konst(sub: u8, name: &str, dt: DataType, default: Vec<u8>) -> Entry {
    val(
        sub,
        name,
        dt,
        Access::RO,
        Storage::Const,
        default,
        Vec::new(),
        Vec::new(),
    )
}

fn ram_ro(sub: u8, name: &str, dt: DataType, default: Vec<u8>) -> Entry {
    val(
        sub,
        name,
        dt,
        Access::RO,
        Storage::Ram,
        default,
        Vec::new(),
        Vec::new(),
    )
}

/// The objects od-gen derives from the device, PDO, SM and sync sections.
fn derived_objects(p: &Profile) -> Result<Vec<Object>, Fault> {
    use DataType::*;
    let mut v = Vec::new();
    let s = |t: &str| t.as_bytes().to_vec();
    for (index, name, text, key) in [
        (
            0x1008,
            "Manufacturer device name",
            &p.device.name,
            "device.name",
        ),
        (
            0x1009,
            "Manufacturer hardware version",
            &p.device.hardware_version,
            "device.hardware_version",
        ),
        (
            0x100A,
            "Manufacturer software version",
            &p.device.software_version,
            "device.software_version",
        ),
    ] {
        if text.is_empty() || !text.is_ascii() {
            return Err(fault(
                key,
                Invalid::Value("must be non-empty ASCII (VISIBLE_STRING)".into()),
            ));
        }
        v.push(var(index, name, konst(0, name, VisibleString, s(text))));
    }
    v.push(Object {
        index: 0x1018,
        code: ObjectCode::Record,
        name: "Identity".into(),
        entries: vec![
            sub0(4, Access::RO, Storage::Const),
            konst(1, "Vendor ID", Udint, p.vendor.id.to_le_bytes().to_vec()),
            konst(
                2,
                "Product code",
                Udint,
                p.device.product_code.to_le_bytes().to_vec(),
            ),
            konst(
                3,
                "Revision",
                Udint,
                p.device.revision.to_le_bytes().to_vec(),
            ),
            // RAM: the board writes the unit's serial number at start-up.
            ram_ro(
                4,
                "Serial number",
                Udint,
                p.device.serial.to_le_bytes().to_vec(),
            ),
        ],
        derived: true,
        doc: Doc::default(),
    });

    let coe = p.mailbox.coe;
    for pdo in p.rx_pdos.iter().chain(&p.tx_pdos) {
        let configurable = coe.pdo_config && !pdo.fixed;
        let cap = if configurable {
            p.max_pdo_entries
        } else {
            u8::try_from(pdo.entries.len()).unwrap_or(0)
        };
        let (access, storage) = if configurable {
            (Access::RW_PREOP, Storage::Ram)
        } else {
            (Access::RO, Storage::Const)
        };
        let n = u8::try_from(pdo.entries.len()).unwrap_or(0);
        let mut entries = vec![val(
            0,
            "SubIndex 000",
            Usint,
            access,
            storage,
            vec![n],
            vec![0],
            vec![cap],
        )];
        for i in 1..=cap {
            let m = pdo
                .entries
                .get(usize::from(i) - 1)
                .map_or(0, PdoEntry::mapping_value);
            entries.push(val(
                i,
                &format!("SubIndex {i:03}"),
                Udint,
                access,
                storage,
                m.to_le_bytes().to_vec(),
                Vec::new(),
                Vec::new(),
            ));
        }
        v.push(Object {
            index: pdo.index,
            code: ObjectCode::Record,
            name: pdo.name.clone(),
            entries,
            derived: true,
            doc: Doc::default(),
        });
    }

    // 1C00h: SM communication types (ETG.1000.6 §5.6.7.4.9): 1 mailbox out, 2 mailbox in,
    // 3 process-data out, 4 process-data in. SOEM reads :00 and needs n > 2.
    let mut sm_types = vec![sub0(4, Access::RO, Storage::Const)];
    for (i, name) in [
        (1u8, "SubIndex 001"),
        (2, "SubIndex 002"),
        (3, "SubIndex 003"),
        (4, "SubIndex 004"),
    ] {
        sm_types.push(konst(i, name, Usint, vec![i]));
    }
    v.push(Object {
        index: 0x1C00,
        code: ObjectCode::Array,
        name: "Sync manager type".into(),
        entries: sm_types,
        derived: true,
        doc: Doc::default(),
    });

    for (index, name, pdos) in [
        (0x1C12u16, "RxPDO assign", &p.rx_pdos),
        (0x1C13, "TxPDO assign", &p.tx_pdos),
    ] {
        let cap = u8::try_from(pdos.len())
            .unwrap_or(u8::MAX)
            .min(p.max_assigned.unwrap_or(u8::MAX));
        let (access, storage) = if coe.pdo_assign {
            (Access::RW_PREOP, Storage::Ram)
        } else {
            (Access::RO, Storage::Const)
        };
        let assigned: Vec<u16> = pdos
            .iter()
            .filter(|p| p.assigned)
            .map(|p| p.index)
            .collect();
        let n = u8::try_from(assigned.len()).unwrap_or(0);
        let mut entries = vec![val(
            0,
            "SubIndex 000",
            Usint,
            access,
            storage,
            vec![n],
            vec![0],
            vec![cap],
        )];
        for i in 1..=cap {
            let d = assigned.get(usize::from(i) - 1).copied().unwrap_or(0);
            entries.push(val(
                i,
                &format!("SubIndex {i:03}"),
                Uint,
                access,
                storage,
                d.to_le_bytes().to_vec(),
                Vec::new(),
                Vec::new(),
            ));
        }
        v.push(Object {
            index,
            code: ObjectCode::Array,
            name: name.into(),
            entries,
            derived: true,
            doc: Doc::default(),
        });
    }

    // 1C32h/1C33h: SM output/input parameter (ETG.1020 §21; subindex list as in Beckhoff
    // terminal documentation). All RAM so the stack can write measured values; only :01 and :02
    // are master-writable (PREOP).
    let y = &p.sync;
    for (index, name, sm_sync_mode) in [
        (0x1C32u16, "SM output parameter", 1u16),
        (0x1C33, "SM input parameter", 0x22),
    ] {
        // 1C33h follows 1C32h; its SM-synchronous value is 0x22 (synchronous with SM2).
        let mode = if y.default_sync_mode == 1 {
            sm_sync_mode
        } else {
            y.default_sync_mode
        };
        let writable = |w: bool| if w { Access::RW_PREOP } else { Access::RO };
        let u32b = |x: u32| x.to_le_bytes().to_vec();
        let u16b = |x: u16| x.to_le_bytes().to_vec();
        v.push(Object {
            index,
            code: ObjectCode::Record,
            name: name.into(),
            entries: vec![
                sub0(0x20, Access::RO, Storage::Const),
                val(
                    1,
                    "Sync mode",
                    Uint,
                    writable(y.sync_mode_writable),
                    Storage::Ram,
                    u16b(mode),
                    Vec::new(),
                    Vec::new(),
                ),
                val(
                    2,
                    "Cycle time",
                    Udint,
                    writable(y.cycle_time_writable),
                    Storage::Ram,
                    u32b(y.default_cycle_ns),
                    // In free run the master sets the local timer's period here (ETG.1020).
                    u32b(y.min_cycle_ns.min(y.free_run_min_cycle_ns)),
                    u32b(y.max_cycle_ns.max(y.free_run_max_cycle_ns)),
                ),
                match (index, y.input_shift) {
                    // The input shift time the master may set ([sync.input_shift]).
                    (0x1C33, Some(shift)) => val(
                        3,
                        "Shift time",
                        Udint,
                        Access::RW_PREOP,
                        Storage::Ram,
                        u32b(0),
                        u32b(0),
                        u32b(y.max_cycle_ns.saturating_sub(shift.reserve_ns)),
                    ),
                    _ => ram_ro(3, "Shift time", Udint, u32b(0)),
                },
                ram_ro(4, "Sync modes supported", Uint, u16b(y.modes_supported())),
                ram_ro(5, "Minimum cycle time", Udint, u32b(y.min_cycle_ns)),
                ram_ro(6, "Calc and copy time", Udint, u32b(y.calc_and_copy_ns)),
                ram_ro(8, "Get cycle time", Uint, u16b(0)),
                ram_ro(9, "Delay time", Udint, u32b(y.delay_ns)),
                ram_ro(0x0B, "SM event missed counter", Uint, u16b(0)),
                ram_ro(0x0C, "Cycle time too small counter", Uint, u16b(0)),
                ram_ro(0x20, "Sync error", Bool, vec![0]),
            ],
            derived: true,
            doc: Doc::default(),
        });
    }
    Ok(v)
}

/// `[cia402.touch_probe_inputs]`: the entries parse (at least one), the error resolves.
fn touch_probe_inputs(
    t: &crate::file::TouchProbeInputsFile,
    alarms: &[Alarm],
) -> Result<crate::model::TouchProbeInputs, Fault> {
    let key = "cia402.touch_probe_inputs.entries";
    if t.entries.is_empty() {
        return Err(fault(
            key,
            Invalid::Value("needs at least one entry".into()),
        ));
    }
    let entries = t
        .entries
        .iter()
        .map(|s| entry_ref(Some(s), key).map(|e| e.unwrap_or_default()))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(crate::model::TouchProbeInputs {
        entries,
        functions: t.functions,
        unassigned_error: fault_report(
            &t.unassigned_error,
            alarms,
            "cia402.touch_probe_inputs.unassigned_error",
        )?,
    })
}

/// `[cia402.safe_torque_off]`: a manufacturer-specific statusword bit (CiA402: 8, 14, 15) and
/// two distinct manufacturer-specific 60FDh bits (16-31).
fn safe_torque_off(
    s: crate::file::SafeTorqueOffFile,
) -> Result<crate::model::SafeTorqueOff, Fault> {
    let statusword = statusword_flag(
        crate::file::StatuswordFlagFile {
            statusword_bit: s.statusword_bit,
            statusword_while_active: s.statusword_while_active,
        },
        "cia402.safe_torque_off.statusword_bit",
    )?;
    let [a, b] = s.digital_input_bits;
    if !(16..=31).contains(&a) || !(16..=31).contains(&b) || a == b {
        return Err(fault(
            "cia402.safe_torque_off.digital_input_bits",
            Invalid::Value(format!(
                "[{a}, {b}]: two distinct manufacturer-specific 60FDh bits (16-31)"
            )),
        ));
    }
    Ok(crate::model::SafeTorqueOff {
        statusword,
        digital_input_bits: s.digital_input_bits,
    })
}

/// A manufacturer-specific statusword bit (CiA402: 8, 14, 15) with its value while active.
fn statusword_flag(
    f: crate::file::StatuswordFlagFile,
    key: &str,
) -> Result<crate::model::StatuswordFlag, Fault> {
    if ![8, 14, 15].contains(&f.statusword_bit) {
        return Err(fault(
            key,
            Invalid::Value(format!(
                "{} is not a manufacturer-specific statusword bit (8, 14, 15)",
                f.statusword_bit
            )),
        ));
    }
    Ok(crate::model::StatuswordFlag {
        bit: f.statusword_bit,
        while_active: f.statusword_while_active,
    })
}

/// `[cia402] store_requires_power_cycle`: 1010h subindexes (CiA 301: 1 all, 2 communication,
/// 3 application, 4-127 manufacturer), each once, ascending.
fn store_requires_power_cycle(c: &crate::file::Cia402File) -> Result<Vec<u8>, Fault> {
    let key = "cia402.store_requires_power_cycle";
    let list = &c.store_requires_power_cycle;
    if let Some(bad) = list.iter().find(|s| !(1..=0x7F).contains(*s)) {
        return Err(fault(
            key,
            Invalid::Value(format!("{bad} is not a 1010h store subindex (1-127)")),
        ));
    }
    if list.windows(2).any(|w| w[0] >= w[1]) {
        return Err(fault(
            key,
            Invalid::Value("list each subindex once, ascending".into()),
        ));
    }
    Ok(list.clone())
}

/// `[cia402] homing_methods` and `homing_method_aliases`: every method listed is a CiA402
/// method or an alias; an alias is a number CiA402 leaves free (or redefines) that runs a
/// CiA402 method; no repeats. The list comes out ascending.
fn homing_methods(c: &crate::file::Cia402File) -> Result<Vec<i8>, Fault> {
    use crate::model::CIA402_HOMING_METHODS;
    let mut aliases = Vec::new();
    for [from, to] in &c.homing_method_aliases {
        if !CIA402_HOMING_METHODS.contains(to) || aliases.contains(from) {
            return Err(fault(
                "cia402.homing_method_aliases",
                Invalid::Value(format!(
                    "[{from}, {to}]: the target must be a CiA402 homing method ({CIA402_HOMING_METHODS:?}) and each vendor number appear once"
                )),
            ));
        }
        aliases.push(*from);
    }
    let Some(list) = &c.homing_methods else {
        return Ok(CIA402_HOMING_METHODS.to_vec());
    };
    let mut methods = list.clone();
    methods.sort_unstable();
    methods.dedup();
    if methods.len() != list.len() {
        return Err(fault(
            "cia402.homing_methods",
            Invalid::Value("a method is listed twice".into()),
        ));
    }
    if let Some(m) = methods
        .iter()
        .find(|m| !CIA402_HOMING_METHODS.contains(m) && !aliases.contains(m))
    {
        return Err(fault(
            "cia402.homing_methods",
            Invalid::Value(format!(
                "{m} is neither a CiA402 homing method ({CIA402_HOMING_METHODS:?}) nor in homing_method_aliases"
            )),
        ));
    }
    Ok(methods)
}
