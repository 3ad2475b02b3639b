//! The Markdown page of a profile (`od-gen doc`, `docs/profiles/<name>.md`) and the index of the
//! built-in profiles (`docs/profiles/README.md`).
//!
//! Everything on a page is read from the resolved [`Profile`]: identity, mailbox, SMs,
//! synchronisation, PDOs, the parameter storage (`[storage]`), the modes of 6502h, the homing
//! methods of 60E3h, the alarm table, the motor-fault mapping, the `[[decision]]`s, the
//! `[[replicate]]` rules and the object count. The output is deterministic (no dates, no
//! paths): `od-gen/tests/doc.rs` compares the committed pages with a fresh generation.

use std::fmt::Write as _;

use crate::model::{
    DataType, EntryRange, EntryTest, MotorFaultCode, Pdo, Profile, ProfileKind, Sm, Storage,
    ALL_PARAMETERS, MOTOR_FAULT_NAMES, STORE_PARAMETERS,
};
use crate::table;

/// The command that regenerates every page and the index (run in the workspace root).
pub const REGENERATE_ALL: &str = "cargo run -p od-gen -- doc --all -o docs/profiles";

/// The command that regenerates the page of one built-in profile (run in the workspace root).
pub fn regenerate_one(name: &str) -> String {
    format!("cargo run -p od-gen -- doc {name} -o docs/profiles/{name}.md")
}

/// Markdown-escapes text for a paragraph, list item or table cell: line breaks become spaces,
/// characters with a Markdown meaning are backslash-escaped.
pub fn md(s: &str) -> String {
    let chars: Vec<char> = s.trim().chars().collect();
    let mut o = String::with_capacity(s.len());
    for (i, &c) in chars.iter().enumerate() {
        let word = |j: Option<usize>| {
            j.and_then(|j| chars.get(j))
                .is_some_and(|c| c.is_alphanumeric())
        };
        match c {
            '\r' => {}
            '\n' => o.push(' '),
            // `_` inside a word (`order_number`) is no emphasis in CommonMark.
            '_' if word(i.checked_sub(1)) && word(Some(i + 1)) => o.push(c),
            '\\' | '`' | '*' | '_' | '[' | '<' | '|' | '~' => {
                o.push('\\');
                o.push(c);
            }
            _ => o.push(c),
        }
    }
    if o.starts_with(['#', '-', '+', '>', '=']) {
        o.insert(0, '\\');
    }
    o
}

fn hex16(v: u16) -> String {
    format!("0x{v:04X}")
}

fn hex32(v: u32) -> String {
    format!("0x{v:08X}")
}

fn yes(b: bool) -> &'static str {
    if b {
        "yes"
    } else {
        "no"
    }
}

/// A duration in ns as `1 ms`, `31.25 µs`, `250 µs` or `0 ns`, exact.
pub fn duration(ns: u32) -> String {
    let trim = |whole: u32, frac: u32, digits: usize| {
        if frac == 0 {
            whole.to_string()
        } else {
            let f = format!("{frac:0digits$}");
            format!("{whole}.{}", f.trim_end_matches('0'))
        }
    };
    if ns == 0 {
        "0 ns".into()
    } else if ns >= 1_000_000 {
        format!("{} ms", trim(ns / 1_000_000, ns % 1_000_000, 6))
    } else if ns >= 1_000 {
        format!("{} µs", trim(ns / 1_000, ns % 1_000, 3))
    } else {
        format!("{ns} ns")
    }
}

fn bytes_hex(b: &[u8]) -> String {
    b.iter()
        .map(|x| format!("{x:02X}"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// A Markdown table: header cells, then rows (cells already escaped).
fn md_table(out: &mut String, header: &[&str], rows: &[Vec<String>]) {
    let _ = writeln!(out, "| {} |", header.join(" | "));
    let _ = writeln!(
        out,
        "|{}|",
        header.iter().map(|_| "---").collect::<Vec<_>>().join("|")
    );
    for r in rows {
        let _ = writeln!(out, "| {} |", r.join(" | "));
    }
    out.push('\n');
}

/// The meaning of an SM control byte (ESC register 0x0804).
pub fn control_byte(c: u8) -> String {
    let mut parts = vec![
        match c & 0x03 {
            0 => "buffered".to_string(),
            2 => "mailbox".to_string(),
            m => format!("mode {m}"),
        },
        match (c >> 2) & 0x03 {
            0 => "master reads".to_string(),
            1 => "master writes".to_string(),
            d => format!("direction {d}"),
        },
    ];
    if c & 0x10 != 0 {
        parts.push("ECAT interrupt".into());
    }
    if c & 0x20 != 0 {
        parts.push("PDI interrupt".into());
    }
    if c & 0x40 != 0 {
        parts.push("watchdog".into());
    }
    parts.join(", ")
}

/// The CiA402 modes of operation of the 6502h bits (bit, 6060h value, name).
pub const MODE_BITS: [(u8, i8, &str); 9] = [
    (0, 1, "Profile position (pp)"),
    (1, 2, "Velocity (vl)"),
    (2, 3, "Profile velocity (pv)"),
    (3, 4, "Profile torque (tq)"),
    (5, 6, "Homing (hm)"),
    (6, 7, "Interpolated position (ip)"),
    (7, 8, "Cyclic synchronous position (csp)"),
    (8, 9, "Cyclic synchronous velocity (csv)"),
    (9, 10, "Cyclic synchronous torque (cst)"),
];

/// The 6502h default, if the object is in the dictionary.
pub fn supported_modes(p: &Profile) -> Option<u32> {
    let e = p.entry(0x6502, 0)?;
    let v = table::int_value(e.data_type, &e.initial_bytes())?;
    u32::try_from(v).ok()
}

/// The 6502h bits as mode names (reserved and manufacturer-specific bits named as such).
pub fn mode_names(v: u32) -> Vec<String> {
    (0..32u8)
        .filter(|b| v >> b & 1 == 1)
        .map(|b| match MODE_BITS.iter().find(|m| m.0 == b) {
            Some((_, mode, name)) => format!("{name}, 6060h = {mode}"),
            None if b >= 16 => format!("bit {b}: manufacturer-specific"),
            None => format!("bit {b}: reserved"),
        })
        .collect()
}

fn short_modes(v: u32) -> String {
    let names: Vec<String> = (0..32u8)
        .filter(|b| v >> b & 1 == 1)
        .map(|b| match MODE_BITS.iter().find(|m| m.0 == b) {
            Some((_, _, name)) => name.rsplit_once('(').map_or(name.to_string(), |(_, s)| {
                s.trim_end_matches(')').to_string()
            }),
            None => format!("bit {b}"),
        })
        .collect();
    names.join(", ")
}

fn value_or_dash(dt: DataType, b: &[u8]) -> String {
    let t = table::value_text(dt, b);
    if t.is_empty() {
        "–".into()
    } else {
        md(&t)
    }
}

fn identity(out: &mut String, p: &Profile) {
    let d = &p.device;
    out.push_str("## Identity\n\n");
    let kind = match p.kind {
        ProfileKind::Drive => "drive",
        ProfileKind::Device => "device",
    };
    let mut rows = vec![
        vec!["Profile".into(), format!("`{}` ({kind})", p.name)],
        vec![
            "Vendor (1018h:01)".into(),
            format!("{} — {}", hex32(p.vendor.id), md(&p.vendor.name)),
        ],
        vec!["Device name (1008h, ESI Device/Name)".into(), md(&d.name)],
        vec!["Order number (ESI Device/Type)".into(), md(&d.order_number)],
        vec!["Product code (1018h:02)".into(), hex32(d.product_code)],
        vec!["Revision (1018h:03)".into(), hex32(d.revision)],
        vec![
            "Serial number (1018h:04 default)".into(),
            d.serial.to_string(),
        ],
        vec!["Hardware version (1009h)".into(), md(&d.hardware_version)],
        vec!["Software version (100Ah)".into(), md(&d.software_version)],
        vec![
            "Group (type / name)".into(),
            format!("{} / {}", md(&d.group_type), md(&d.group_name)),
        ],
        vec!["Physics".into(), md(&d.physics)],
    ];
    if d.profile_no != 0 {
        rows.push(vec!["Profile number".into(), d.profile_no.to_string()]);
    }
    rows.push(vec!["DS402 channels".into(), d.ds402_channels.to_string()]);
    let e = &p.eeprom;
    rows.push(vec![
        "EEPROM".into(),
        format!(
            "{} bytes; PDI control 0x{:02X}, ESC config 0x{:02X}, PDI config {}, \
             SYNC impulse {}, PDI config 2 {}, station alias {}",
            e.byte_size,
            e.pdi_control,
            e.esc_config,
            hex16(e.pdi_config),
            duration(u32::from(e.sync_impulse_len) * 10),
            hex16(e.pdi_config2),
            e.station_alias
        ),
    ]);
    md_table(out, &["", ""], &rows);
}

fn mailbox(out: &mut String, p: &Profile) {
    out.push_str("## Mailbox and CoE\n\n");
    let m = &p.mailbox;
    let protocols: Vec<&str> = crate::model::protocol::NAMES
        .iter()
        .filter(|(_, bit)| m.protocols & bit != 0)
        .map(|(n, _)| *n)
        .collect();
    let c = m.coe;
    let rows = vec![
        vec![
            "Protocols".into(),
            if protocols.is_empty() {
                "none".into()
            } else {
                protocols.join(", ")
            },
        ],
        vec![
            "Mailbox data link layer".into(),
            yes(m.data_link_layer).into(),
        ],
        vec!["SDO".into(), yes(c.sdo).into()],
        vec!["SDO information".into(), yes(c.sdo_info).into()],
        vec!["SDO complete access".into(), yes(c.complete_access).into()],
        vec![
            "PDO assignment (1C12h/1C13h writable)".into(),
            yes(c.pdo_assign).into(),
        ],
        vec![
            "PDO configuration (16xxh/1Axxh writable)".into(),
            yes(c.pdo_config).into(),
        ],
        vec!["Upload at startup".into(), yes(c.upload_at_startup).into()],
        vec!["SII CoE details byte".into(), format!("0x{:02X}", c.bits())],
    ];
    md_table(out, &["feature", "supported"], &rows);
}

fn sync_managers(out: &mut String, p: &Profile) {
    out.push_str("## SyncManagers\n\n");
    let sm = &p.sm;
    let row = |name: &str, use_: &str, s: Sm, size: String| {
        vec![
            name.to_string(),
            use_.to_string(),
            hex16(s.start),
            size,
            format!("0x{:02X} ({})", s.control, control_byte(s.control)),
        ]
    };
    let mut rows = vec![
        row(
            "SM0",
            "mailbox out (MBoxOut)",
            sm.mailbox_out,
            sm.mailbox_out.length.to_string(),
        ),
        row(
            "SM1",
            "mailbox in (MBoxIn)",
            sm.mailbox_in,
            sm.mailbox_in.length.to_string(),
        ),
        row(
            "SM2",
            "outputs (RxPDO)",
            sm.outputs,
            format!("{} (default assignment)", sm.outputs.length),
        ),
        row(
            "SM3",
            "inputs (TxPDO)",
            sm.inputs,
            format!("{} (default assignment)", sm.inputs.length),
        ),
    ];
    if let (Some(o), Some(i)) = (sm.boot_out, sm.boot_in) {
        rows.push(row(
            "boot out",
            "bootstrap mailbox out",
            o,
            o.length.to_string(),
        ));
        rows.push(row(
            "boot in",
            "bootstrap mailbox in",
            i,
            i.length.to_string(),
        ));
    }
    md_table(
        out,
        &["SM", "use", "start", "size (bytes)", "control byte"],
        &rows,
    );
}

fn synchronisation(out: &mut String, p: &Profile) {
    out.push_str("## Synchronisation\n\n");
    let s = &p.sync;
    let mut modes = Vec::new();
    if s.free_run {
        modes.push("free run");
    }
    if s.sm_synchronous {
        modes.push("SM2-synchronous");
    }
    if s.dc_sync0 {
        modes.push("DC SYNC0");
    }
    if s.dc_sync1 {
        modes.push("DC SYNC1");
    }
    let sync_type = p
        .entry(0x1C32, 1)
        .and_then(|e| table::int_value(e.data_type, &e.initial_bytes()))
        .map_or("–".to_string(), |v| v.to_string());
    let rows = vec![
        vec!["Sync modes".into(), modes.join(", ")],
        vec![
            "Sync modes supported (1C32h:04 / 1C33h:04)".into(),
            hex16(s.modes_supported()),
        ],
        vec!["Default sync mode (1C32h:01)".into(), sync_type],
        vec!["Minimum cycle time".into(), duration(s.min_cycle_ns)],
        vec!["Maximum cycle time".into(), duration(s.max_cycle_ns)],
        vec![
            "Default cycle time (1C32h:02)".into(),
            duration(s.default_cycle_ns),
        ],
        vec![
            "DC cycle step".into(),
            if s.cycle_step_ns <= 1 {
                "any".into()
            } else {
                format!(
                    "{} (other cycles: AL status code 0x0036)",
                    duration(s.cycle_step_ns)
                )
            },
        ],
        vec![
            "Accepted DC cycles".into(),
            if s.allowed_cycles_ns.is_empty() {
                "every step in range".into()
            } else {
                let list: Vec<String> = s.allowed_cycles_ns.iter().map(|c| duration(*c)).collect();
                format!(
                    "{} only (other cycles: AL status code 0x0036)",
                    list.join(", ")
                )
            },
        ],
        vec![
            "Calc and copy time (:06)".into(),
            duration(s.calc_and_copy_ns),
        ],
        vec!["Delay time (:09)".into(), duration(s.delay_ns)],
        vec![
            "Free-run cycle (1C32h:02 in free run)".into(),
            if s.free_run {
                format!(
                    "{} – {} (other values: AL status code 0x0035 at PREOP → SAFEOP)",
                    duration(s.free_run_min_cycle_ns),
                    duration(s.free_run_max_cycle_ns)
                )
            } else {
                "–".into()
            },
        ],
        vec![
            "Input shift time (1C33h:03)".into(),
            match s.input_shift {
                Some(i) => format!(
                    "written by the master in PREOP, multiples of {} (else abort 0x06090030), at \
                     most the SYNC0 cycle − {} (else AL status code 0x0035)",
                    duration(i.step_ns),
                    duration(i.reserve_ns)
                ),
                None => "read-only".into(),
            },
        ],
        vec![
            "Sync error counter trips".into(),
            format!(
                "{}; +3 per SYNC0 that did not come{}, −1 per SYNC0",
                if s.sync_error_at_limit {
                    "on reaching 10F1h:02"
                } else {
                    "on exceeding 10F1h:02 (ETG.1020)"
                },
                if s.sync_error_on_missed_outputs {
                    " and per SYNC0 in OP without new outputs since the previous one"
                } else {
                    ""
                }
            ),
        ],
    ];
    md_table(out, &["", ""], &rows);

    if !p.dc_op_modes.is_empty() {
        out.push_str("### DC op modes\n\n");
        let rows: Vec<Vec<String>> = p
            .dc_op_modes
            .iter()
            .map(|m| {
                let act = m.assign_activate >> 8;
                let sync = |on: bool, cycle: u32, factor: i16, shift: u32| {
                    if !on {
                        "–".to_string()
                    } else if cycle == 0 {
                        format!(
                            "cycle = {factor} × the master's cycle, shift {}",
                            duration(shift)
                        )
                    } else {
                        format!(
                            "cycle {} (factor {factor}), shift {}",
                            duration(cycle),
                            duration(shift)
                        )
                    }
                };
                vec![
                    md(&m.name),
                    md(&m.description),
                    hex16(m.assign_activate),
                    sync(
                        act & 0x02 != 0,
                        m.sync0_cycle_ns,
                        m.sync0_factor,
                        m.sync0_shift_ns,
                    ),
                    sync(
                        act & 0x04 != 0,
                        m.sync1_cycle_ns,
                        m.sync1_factor,
                        m.sync1_shift_ns,
                    ),
                ]
            })
            .collect();
        md_table(
            out,
            &["name", "description", "AssignActivate", "SYNC0", "SYNC1"],
            &rows,
        );
    }

    out.push_str("### EtherCAT state machine\n\n");
    let e = &p.esm;
    let rows = vec![
        vec![
            "SAFEOP → OP needs valid outputs".into(),
            yes(e.op_requires_outputs).into(),
        ],
        vec![
            "SAFEOP → OP timeout".into(),
            format!("{} ms", e.safeop_op_timeout_ms),
        ],
        vec![
            "Leaving OP while Operation Enabled".into(),
            match e.op_exit_while_enabled_error {
                Some(c) => format!("fault, {}", error_report(&c)),
                None => "the drive is disabled (no fault)".into(),
            },
        ],
        vec![
            "Input port link lost (PREOP and above)".into(),
            match e.link_loss_error {
                Some(c) => format!("INIT, AL status code 0x0000; fault, {}", error_report(&c)),
                None => "not supervised".into(),
            },
        ],
        vec![
            "PDI error (ESC counter 0x030D)".into(),
            match e.pdi_error {
                Some(c) => format!(
                    "INIT, AL status code 0x0000, ERR LED on; fault, {}",
                    error_report(&c)
                ),
                None => "not supervised".into(),
            },
        ],
        vec![
            "Outputs lost in a row".into(),
            match &e.lost_outputs {
                Some(l) => format!(
                    "while {:04X}h:{:02X}h is one of {:?}: the count in {:04X}h:{:02X}h (0 = off, read at power-on), then SAFEOP with {}; fault, {}",
                    l.while_entry.0,
                    l.while_entry.1,
                    l.while_values,
                    l.limit_parameter.0,
                    l.limit_parameter.1,
                    hex16(l.al_status_code),
                    error_report(&l.error)
                ),
                None => "not supervised".into(),
            },
        ],
        vec![
            "AL status code of a sync error (counter)".into(),
            hex16(e.sync_error_al_code),
        ],
        vec![
            "SYNC0 lock timeout in SAFEOP".into(),
            match e.sync_lock_timeout_ms {
                Some(ms) => format!("{ms} ms, then PREOP with 0x002D"),
                None => "none (only a SAFEOP → OP request waits)".into(),
            },
        ],
        vec![
            "Error register 1001h".into(),
            if p.emcy.register_mask == 0xFF {
                "CiA 301 class bits".into()
            } else {
                format!("bits 0x{:02X} only", p.emcy.register_mask)
            },
        ],
        vec![
            "Axis number in the EMCY".into(),
            p.emcy
                .axis_number_byte
                .map_or("—".into(), |b| format!("byte {b}")),
        ],
        vec![
            "Emergency of a motor fault".into(),
            p.emcy.motor_fault_code.map_or(
                "its 603Fh code".into(),
                |(code, byte)| format!("{} with the 603Fh code in bytes {byte}-{}", hex16(code), byte + 1),
            ),
        ],
        vec![
            "Emergency of an AL error".into(),
            format!(
                "{} [state before, AL status code, state after, 0]",
                hex16(p.emcy.al_error_code)
            ),
        ],
    ];
    md_table(out, &["", ""], &rows);
    if !e.al_error_alarms.is_empty() {
        out.push_str("AL errors the drive also reports as its own errors (fault, 603Fh and EMCY in place of the ESM emergency):\n\n");
        let rows: Vec<Vec<String>> = e
            .al_error_alarms
            .iter()
            .map(|(code, c)| {
                let led = e
                    .al_error_leds
                    .iter()
                    .find(|(l, _)| l == code)
                    .map_or("ETG.1300".into(), |(_, led)| led.text().to_string());
                vec![hex16(*code), error_report(c), led]
            })
            .collect();
        md_table(out, &["AL status code", "drive error", "ERR LED"], &rows);
    }
}

/// `603Fh = …, EMCY … […]`: how the drive reports an error.
fn error_report(c: &MotorFaultCode) -> String {
    format!(
        "603Fh = {}, EMCY {} [{}]",
        hex16(c.error_code),
        hex16(c.emcy.code),
        bytes_hex(&c.emcy.data)
    )
}

fn pdo_section(out: &mut String, p: &Profile, kind: &str, pdo: &Pdo) {
    let bits = pdo.bits();
    let mut flags = vec![format!("SM{}", pdo.sm)];
    if pdo.fixed {
        flags.push("fixed".into());
    }
    if pdo.mandatory {
        flags.push("mandatory".into());
    }
    let size = if bits % 8 == 0 {
        format!("{} bytes", bits / 8)
    } else {
        format!("{bits} bits")
    };
    flags.push(size);
    let _ = writeln!(
        out,
        "#### {kind} {} {}\n\n{}\n",
        hex16(pdo.index),
        md(&pdo.name),
        flags.join(", ")
    );
    let rows: Vec<Vec<String>> = pdo
        .entries
        .iter()
        .enumerate()
        .map(|(i, e)| {
            if e.index == 0 {
                vec![
                    (i + 1).to_string(),
                    "–".into(),
                    "padding".into(),
                    e.bits.to_string(),
                    "–".into(),
                ]
            } else {
                let ty = e
                    .data_type
                    .map_or_else(|| "–".to_string(), table::type_name);
                let name = if e.name.is_empty() {
                    p.entry(e.index, e.subindex)
                        .map_or(String::new(), |x| x.name.clone())
                } else {
                    e.name.clone()
                };
                vec![
                    (i + 1).to_string(),
                    format!("{}:{:02X}", hex16(e.index), e.subindex),
                    md(&name),
                    e.bits.to_string(),
                    ty,
                ]
            }
        })
        .collect();
    md_table(out, &["#", "object", "name", "bits", "type"], &rows);
}

fn process_data(out: &mut String, p: &Profile) {
    out.push_str("## Process data\n\n");
    let assigned = |pdos: &[Pdo]| {
        let v: Vec<String> = pdos
            .iter()
            .filter(|x| x.assigned)
            .map(|x| hex16(x.index))
            .collect();
        if v.is_empty() {
            "none".to_string()
        } else {
            v.join(", ")
        }
    };
    let rows = vec![
        vec![
            "Outputs (SM2, default)".into(),
            format!(
                "{} bytes: {}",
                p.outputs_bits().div_ceil(8),
                assigned(&p.rx_pdos)
            ),
        ],
        vec![
            "Inputs (SM3, default)".into(),
            format!(
                "{} bytes: {}",
                p.inputs_bits().div_ceil(8),
                assigned(&p.tx_pdos)
            ),
        ],
        vec![
            "Entries per PDO (max)".into(),
            p.max_pdo_entries.to_string(),
        ],
        vec![
            "PDOs assigned at once per direction (max)".into(),
            p.max_assigned
                .map_or("every PDO of the direction".into(), |n| n.to_string()),
        ],
        vec![
            "Bytes per PDO (max; larger mapping: abort 0x06040042)".into(),
            p.max_pdo_bytes.to_string(),
        ],
        vec![
            "Process image bytes per direction (max; larger: AL status code 0x0025 / 0x0024)"
                .into(),
            p.max_process_bytes.to_string(),
        ],
        vec![
            "SDO download to an RxPDO-mapped entry in SAFEOP/OP".into(),
            match p.sdo_write_to_rx_mapped {
                crate::model::RxMappedWrite::Blocked => "blocked (abort 0x06010006)".into(),
                crate::model::RxMappedWrite::Allowed => "allowed".into(),
            },
        ],
    ];
    md_table(out, &["", ""], &rows);

    out.push_str("### Default PDO mapping\n\n");
    let mut any = false;
    for (kind, pdos) in [("RxPDO", &p.rx_pdos), ("TxPDO", &p.tx_pdos)] {
        for pdo in pdos.iter().filter(|x| x.assigned) {
            pdo_section(out, p, kind, pdo);
            any = true;
        }
    }
    if !any {
        out.push_str("No PDO is assigned by default.\n\n");
    }
    let alternatives: Vec<(&str, &Pdo)> = p
        .rx_pdos
        .iter()
        .map(|x| ("RxPDO", x))
        .chain(p.tx_pdos.iter().map(|x| ("TxPDO", x)))
        .filter(|(_, x)| !x.assigned)
        .collect();
    out.push_str("### Alternative PDOs (not assigned by default)\n\n");
    if alternatives.is_empty() {
        out.push_str("None.\n\n");
    }
    for (kind, pdo) in alternatives {
        pdo_section(out, p, kind, pdo);
    }
}

/// `[units]`: what a position / velocity unit is in increments.
fn units(out: &mut String, p: &Profile) {
    use crate::model::{Factor, Operand};
    out.push_str(
        "## Units

",
    );
    let side = |o: Operand| match o {
        Operand::Const(v) => v.to_string(),
        Operand::Entry(i, s) => format!("{i:04X}h:{s:02X}"),
        Operand::CountsPerRev => "encoder increments per revolution".into(),
    };
    let factor = |f: &Factor| {
        let mut t = format!("{} / {}", side(f.numerator), side(f.denominator));
        if f.scale != (1, 1) {
            let _ = write!(t, " × {}/{}", f.scale.0, f.scale.1);
        }
        t
    };
    let rows = vec![
        vec![
            "position (607Ah, 6064h)".to_string(),
            format!("increments = value × {}", factor(&p.units.position)),
        ],
        vec![
            "velocity (60FFh, 606Ch)".to_string(),
            format!("increments/s = value × {}", factor(&p.units.velocity)),
        ],
        vec![
            "torque (6071h, 6077h, ...)".to_string(),
            if p.units.torque == Factor::ONE {
                "0.1 % of the motor rated torque 6076h".to_string()
            } else {
                format!(
                    "‰ of the motor rated torque 6076h = value × {}",
                    factor(&p.units.torque)
                )
            },
        ],
    ];
    md_table(out, &["object", "conversion (read every cycle)"], &rows);
}

/// Entries with a list of accepted values (`allowed`).
fn value_lists(out: &mut String, p: &Profile) {
    let rows: Vec<Vec<String>> = p
        .objects
        .iter()
        .flat_map(|o| o.entries.iter().map(move |e| (o, e)))
        .filter(|(_, e)| !e.allowed.is_empty())
        .map(|(o, e)| {
            let values: Vec<String> = e.allowed.iter().map(i64::to_string).collect();
            vec![
                format!("{:04X}h:{:02X}", o.index, e.subindex),
                md(&e.name),
                values.join(", "),
            ]
        })
        .collect();
    if rows.is_empty() {
        return;
    }
    out.push_str(
        "## Accepted values

An SDO download of any other value is refused with abort 0x06090030.

",
    );
    md_table(out, &["entry", "name", "values"], &rows);
}

/// An entry range in the page's spelling: `2000h–22FFh`, `2300h`, `2310h:01`.
fn range_text(r: &EntryRange) -> String {
    match r.subindex {
        Some(sub) => format!("{:04X}h:{sub:02X}", r.first),
        None if r.first == r.last => format!("{:04X}h", r.first),
        None => format!("{:04X}h–{:04X}h", r.first, r.last),
    }
}

/// `(index:sub & mask) = value`, the mask left out when it is every bit of the entry.
fn test_text(p: &Profile, t: &EntryTest) -> String {
    let hex = |v: u32| u16::try_from(v).map_or_else(|_| hex32(v), hex16);
    let bits = p.entry(t.index, t.subindex).map_or(0, |e| e.bit_len);
    let all = u32::MAX >> (u32::BITS - u32::from(bits).min(u32::BITS));
    let entry = format!("{:04X}h:{:02X}", t.index, t.subindex);
    if t.mask == all {
        format!("{entry} = {}", hex(t.value))
    } else {
        format!("{entry} & {} = {}", hex(t.mask), hex(t.value))
    }
}

fn ranges_text(list: &[EntryRange]) -> String {
    let items: Vec<String> = list.iter().map(range_text).collect();
    items.join(", ")
}

/// `[storage]`: what 1010h stores, its groups, automatic storage and the write condition.
fn parameter_storage(out: &mut String, p: &Profile) {
    let Some(store) = p.object(STORE_PARAMETERS) else {
        return;
    };
    let st = &p.storage;
    let stored = p
        .objects
        .iter()
        .flat_map(|o| o.entries.iter().map(move |e| (o, e)))
        .filter(|(o, e)| p.is_backup(o, e))
        .count();
    out.push_str("## Parameter storage (1010h/1011h)\n\n");
    let _ = write!(
        out,
        "1010h stores every RAM entry writable over SDO that is not PDO-mappable (1010h, 1011h, \
         1C32h and 1C33h excepted)"
    );
    if !st.stored_pdo_mappable.is_empty() {
        let _ = write!(
            out,
            ", and the PDO-mappable entries of {}",
            ranges_text(&st.stored_pdo_mappable)
        );
    }
    if !st.not_stored.is_empty() {
        let _ = write!(out, "; never {}", ranges_text(&st.not_stored));
    }
    let _ = writeln!(
        out,
        ": {stored} entries (ESI `Backup`, SDO information list 4). \"save\" to 1010h:n stores \
         the group, \"load\" to 1011h:n restores its defaults at the next power-on.\n"
    );
    let rows: Vec<Vec<String>> = store
        .entries
        .iter()
        .filter(|e| e.subindex >= ALL_PARAMETERS)
        .map(|e| {
            let scope = match st.groups.iter().find(|g| g.subindex == e.subindex) {
                _ if e.subindex == ALL_PARAMETERS => "every stored entry".to_string(),
                Some(g) => ranges_text(&g.ranges),
                None => "—".to_string(),
            };
            let condition = st
                .write_condition
                .as_ref()
                .filter(|c| c.subindexes.contains(&e.subindex))
                .map_or("—".to_string(), |c| {
                    format!("{}, else abort 0x08000022", test_text(p, &c.test))
                });
            vec![
                e.subindex.to_string(),
                scope,
                st.store_capabilities(e.subindex).to_string(),
                condition,
            ]
        })
        .collect();
    md_table(
        out,
        &["subindex", "group", "1010h reads", "written only while"],
        &rows,
    );
    if !st.auto_store.is_empty() {
        out.push_str(
            "Stored at once by an SDO download (never by a PDO write), before the SDO response:\n\n",
        );
        for a in &st.auto_store {
            let _ = write!(out, "- {}", ranges_text(&a.entries));
            if let Some(t) = &a.unless {
                let _ = write!(out, ", unless {}", test_text(p, t));
            }
            out.push('\n');
        }
        out.push('\n');
    }
}

fn modes(out: &mut String, p: &Profile) {
    out.push_str("## Supported modes of operation (6502h)\n\n");
    match supported_modes(p) {
        Some(v) => {
            let _ = writeln!(out, "6502h default {}:\n", hex32(v));
            let names = mode_names(v);
            if names.is_empty() {
                out.push_str("- none\n");
            }
            for n in names {
                let _ = writeln!(out, "- {n}");
            }
            out.push('\n');
        }
        None => out.push_str("6502h is not in the dictionary.\n\n"),
    }

    out.push_str("## Homing methods (60E3h)\n\n");
    match p.object(0x60E3) {
        Some(o) => {
            let methods: Vec<String> = o
                .entries
                .iter()
                .filter(|e| o.entries.len() == 1 || e.subindex != 0)
                .map(|e| value_or_dash(e.data_type, &e.initial_bytes()))
                .collect();
            let _ = writeln!(out, "{}\n", methods.join(", "));
        }
        None => {
            out.push_str("60E3h is not in the dictionary.");
            if let Some(e) = p.entry(0x6098, 0) {
                let _ = write!(
                    out,
                    " Homing method 6098h: default {}, minimum {}, maximum {}.",
                    value_or_dash(e.data_type, &e.default),
                    value_or_dash(e.data_type, &e.min),
                    value_or_dash(e.data_type, &e.max)
                );
            }
            out.push_str("\n\n");
        }
    }
}

fn alarms(out: &mut String, p: &Profile) {
    out.push_str("## Alarms\n\n");
    if p.alarms.is_empty() {
        out.push_str("The profile has no alarm table.\n\n");
        return;
    }
    let warnings = p.alarms.iter().filter(|a| a.warning).count();
    let _ = writeln!(
        out,
        "{} alarms ({} faults, {warnings} warnings). EMCY bytes 0–1 = the EMCY code, byte 2 = \
         1001h, bytes 3–7 as listed.\n",
        p.alarms.len(),
        p.alarms.len() - warnings
    );
    let rows: Vec<Vec<String>> = p
        .alarms
        .iter()
        .map(|a| {
            vec![
                md(&a.display),
                md(&a.name),
                hex16(a.error_code),
                hex16(a.emcy.code),
                bytes_hex(&a.emcy.data),
                yes(a.resettable).into(),
                if a.warning { "warning" } else { "fault" }.into(),
                md(&a.description),
            ]
        })
        .collect();
    md_table(
        out,
        &[
            "display",
            "name",
            "603Fh",
            "EMCY code",
            "EMCY bytes 3–7",
            "resettable",
            "kind",
            "description",
        ],
        &rows,
    );
    let a = &p.alarm_objects;
    let mut shown = Vec::new();
    if let Some(i) = a.active {
        shown.push(format!("the active alarms in {}", hex16(i)));
    }
    if let Some(i) = a.history {
        shown.push(format!("the last alarms in {}, newest first", hex16(i)));
    }
    if let Some((i, s)) = a.history_clear {
        shown.push(format!("cleared by 1 in {}:{s:02X}h", hex16(i)));
    }
    if let Some(r) = &a.history_record {
        shown.push(format!(
            "records selected by {}:{:02X}h in {} ({})",
            hex16(r.select.0),
            r.select.1,
            hex16(r.object),
            r.fields
                .iter()
                .map(|f| f.name())
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    if !shown.is_empty() {
        let _ = writeln!(
            out,
            "Alarms by number ({:?}): {}.\n",
            a.number,
            shown.join("; ")
        );
    }
}

fn warnings(out: &mut String, p: &Profile) {
    if p.warnings.is_empty() {
        return;
    }
    out.push_str("## Warnings\n\nConditions reported with statusword bit 7, 603Fh (while no fault holds) and an EMCY, without a state change.\n\n");
    let rows: Vec<Vec<String>> = p
        .warnings
        .iter()
        .map(|w| vec![format!("{:?}", w.condition), error_report(&w.report)])
        .collect();
    md_table(out, &["condition", "603Fh / EMCY"], &rows);
}

fn motor_faults(out: &mut String, p: &Profile) {
    if p.kind != ProfileKind::Drive {
        return;
    }
    out.push_str("## Motor faults\n\n");
    out.push_str(
        "What the drive reports for each internal fault of the firmware \
         (`firmware::motor::MotorFault`).\n\n",
    );
    let rows: Vec<Vec<String>> = MOTOR_FAULT_NAMES
        .iter()
        .zip(&p.motor_faults)
        .map(|(name, f)| {
            let alarms: Vec<String> = p
                .alarms
                .iter()
                .filter(|a| a.error_code == f.error_code && a.emcy == f.emcy)
                .map(|a| md(&a.display))
                .collect();
            vec![
                format!("`{name}`"),
                hex16(f.error_code),
                hex16(f.emcy.code),
                bytes_hex(&f.emcy.data),
                if alarms.is_empty() {
                    "–".into()
                } else {
                    alarms.join(", ")
                },
            ]
        })
        .collect();
    md_table(
        out,
        &["fault", "603Fh", "EMCY code", "EMCY bytes 3–7", "alarm"],
        &rows,
    );
}

/// `[cia402]`: the CiA402 behaviour the manual adds.
fn cia402_rules(out: &mut String, p: &Profile) {
    let r = &p.cia402;
    if *r == crate::model::Cia402Rules::default() {
        // CiA402 as written: nothing to list.
        return;
    }
    out.push_str("## CiA402 rules\n\n");
    if let Some(c) = &r.enable_without_mode_error {
        let _ = writeln!(
            out,
            "- Enable operation with no mode of operation selected (6060h = 0) is refused: Fault, {}.",
            error_report(c)
        );
    }
    if let Some(c) = &r.mode_change_while_homing_error {
        let _ = writeln!(
            out,
            "- A 6060h change while homing runs is refused: Fault, {}.",
            error_report(c)
        );
    }
    if r.stops_end_switched_off {
        out.push_str("- Shutdown and disable operation end in Switch On Disabled after their stop (605Bh/605Ch).\n");
    }
    for c in &r.stop_codes {
        let _ = writeln!(
            out,
            "- {:04X}h = {}: {}, then {} (CiA402 reserves the code).",
            c.object,
            c.code,
            c.stop.describe(),
            if c.hold {
                "hold the motor at rest"
            } else {
                "disable the drive function"
            }
        );
    }
    for ((index, _), code) in crate::model::StopCode::OBJECTS
        .iter()
        .zip(r.option_codes_without_object)
    {
        if let Some(code) = code {
            let _ = writeln!(
                out,
                "- Without {index:04X}h the drive works as with {index:04X}h = {code}."
            );
        }
    }
    if let Some((index, sub)) = r.software_limits_off {
        let _ = writeln!(
            out,
            "- With {index:04X}h:{sub:02X}h = 1 at power-on the software position limits 607Dh \
             are off (infinite length)."
        );
    }
    if let Some(u) = &r.unit_ranges {
        let range = |name: &str, r: Option<crate::model::RatioRange>| {
            r.map(|r| {
                let (lo, hi) = if r.inclusive {
                    ("≤", "≤")
                } else {
                    ("<", "<")
                };
                format!(
                    "{}/{} {lo} {name} {hi} {}/{}",
                    r.min.0, r.min.1, r.max.0, r.max.1
                )
            })
        };
        let ranges: Vec<String> = [
            range("position factor", u.position),
            range("velocity factor", u.velocity),
            range("acceleration factor", u.acceleration),
            range("torque factor", u.torque),
        ]
        .into_iter()
        .flatten()
        .collect();
        let _ = writeln!(
            out,
            "- The unit factors (numerator/denominator) must stay within {}: outside, they do not take effect and raise 603Fh {:04X}h.",
            ranges.join(", "),
            u.error.error_code
        );
    }
    if r.mode_entry_starts {
        out.push_str("- A mode change into profile position or homing with controlword bit 4 already set starts the set-point or the homing run at once (CiA402: at bit 4's next rising edge).\n");
    }
    if r.homing_here_while_disabled {
        out.push_str("- Homing on the current position (methods 35, 37) also runs while the drive function is disabled (controlword bit 4 in any state with 6060h = 6).\n");
    }
    if r.homing_start_while_disabled_error {
        out.push_str("- A homing start (controlword bit 4) while the drive function is disabled ends in a homing error (statusword bit 13).\n");
    }
    if r.homing_here_needs_speed_zero {
        out.push_str("- Homing on the current position (method 35) started while the motor is not at speed zero ends in a homing error (statusword bit 13).\n");
    }
    if r.software_limits_need_reference {
        out.push_str("- The software position limits 607Dh act only once the position is referenced: after a homing run, or from power-on with an absolute encoder.\n");
    }
    if r.software_limits_less_home_offset {
        out.push_str("- The software position limits 607Dh are relative to the machine home: a target is compared with 607Dh:01 - 607Ch and 607Dh:02 - 607Ch.\n");
    }
    if r.torque_modes_halt_zero_torque {
        out.push_str("- Halt (controlword bit 8) in profile torque and cyclic synchronous torque takes the torque demand to zero; the drive stays in Operation Enabled.\n");
    }
    if r.torque_modes_stop_at_once {
        out.push_str("- In profile torque and cyclic synchronous torque, quick stop, shutdown and disable operation disable the drive function at once (code 0).\n");
    }
    if r.fault_reaction_ignored {
        out.push_str(
            "- 605Eh is accepted but has no effect: a fault disables the drive function at once.\n",
        );
    }
    if r.switch_on_requires_main_power {
        out.push_str("- Switched On needs the main power; losing it in Switched On, Operation Enabled or Quick Stop Active falls to Switch On Disabled.\n");
    }
    if r.pp_bit6_absolute {
        out.push_str("- Profile position: controlword bit 6 set means an absolute target (CiA402: relative).\n");
    }
    if !r.pp_set_point_buffer {
        out.push_str("- Profile position: no set-point buffer: after a set-point without bit 5, bit 12 stays set until the move has reached its target, and a new set-point is taken only then.\n");
    }
    if !r.pp_change_on_set_point {
        out.push_str("- Profile position: controlword bit 9 (change on set-point) is not supported and ignored.\n");
    }
    if r.homing_methods != crate::model::CIA402_HOMING_METHODS {
        let list: Vec<String> = r.homing_methods.iter().map(i8::to_string).collect();
        let _ = writeln!(
            out,
            "- Homing methods (6098h): {}; any other starts homing with a homing error (statusword bit 13).",
            list.join(", ")
        );
    }
    for (from, to) in &r.homing_method_aliases {
        let _ = writeln!(out, "- Homing method {from} runs CiA402 method {to}.");
    }
    match r.touch_probe_bit7 {
        crate::model::TouchProbeBit7::None => {}
        crate::model::TouchProbeBit7::ToggleOnStore => out
            .push_str("- Touch probe status 60B9h bit 7 (15) toggles on every stored position.\n"),
        crate::model::TouchProbeBit7::InputLevel => {
            out.push_str("- Touch probe status 60B9h bit 7 (15) shows the probe input level.\n")
        }
    }
    if r.touch_probe_bit6_source {
        out.push_str(
            "- Touch probe status 60B9h bit 6 (14) shows the trigger source (1 = index).\n",
        );
    }
    if r.touch_probe_function_bits != u16::MAX {
        let _ = writeln!(
            out,
            "- Touch probe function 60B8h: only bits {} are defined (the others are reserved \
             and ignored).",
            bit_list(r.touch_probe_function_bits)
        );
    }
    if r.touch_probe1_off_while_homing {
        out.push_str("- Touch probe 1 is switched off while homing runs.\n");
    }
    if r.touch_probe2_off_while_homing {
        out.push_str("- Touch probe 2 is switched off while homing runs.\n");
    }
    if !r.following_error_fault {
        out.push_str("- A following error beyond 6065h for longer than 6066h sets statusword bit 13 only (no fault).\n");
    }
    if r.following_error_zero_window_off {
        out.push_str("- 6065h = 0 switches the following-error check off.\n");
    }
    if r.digital_inputs_limits_swapped {
        out.push_str("- 60FDh bit 0 is the positive and bit 1 the negative limit switch (CiA402: the reverse).\n");
    }
    if r.digital_inputs_without_interlock {
        out.push_str("- 60FDh bit 3 (interlock) is not supported: it stays 0.\n");
    }
    if r.home_offset_added {
        out.push_str("- The home offset 607Ch is added to every position object (6064h = the position from the home + 607Ch), not only set at the home.\n");
    }
    if r.home_offset_added_absolute {
        out.push_str("- With an absolute encoder, the home offset 607Ch as it is at power-on is added to every position object from power-on (6064h = the encoder's position + 607Ch); a later write takes effect at the next power-on or homing run.\n");
    }
    for v in &p.split_values {
        let e = |(i, s): (u16, u8)| format!("{i:04X}h:{s:02X}");
        let _ = writeln!(
            out,
            "- {} = {} × {} + {}: the drive keeps both forms equal (a write to either updates \
             the other; at power-on the parts, which are saved at once, set the whole).",
            e(v.whole),
            e(v.high),
            v.radix,
            e(v.low)
        );
    }
    if let Some(c) = &r.homing_error_alarm {
        let _ = writeln!(
            out,
            "- A homing run that ends in a homing error (statusword bit 13) also raises 603Fh \
             {:04X}h (Fault).",
            c.error_code
        );
    }
    if let Some((index, sub)) = r.csp_extrapolation {
        let _ = writeln!(
            out,
            "- Cyclic synchronous position over a cycle without new outputs (the SYNC0 came, \
             the master's frame did not): with {index:04X}h:{sub:02X}h = 1 at power-on the \
             position command goes on with the last target increment, else it holds the last \
             target."
        );
    }
    for m in &r.mode_statusword {
        let _ = writeln!(
            out,
            "- Mode {}: statusword bit 10 {}, bit 11 {}, bit 12 {}, bit 13 {} (CiA402's table differs).",
            m.mode,
            crate::model::describe_mode_bit(m.bits[0]),
            crate::model::describe_mode_bit(m.bits[1]),
            crate::model::describe_mode_bit(m.bits[2]),
            crate::model::describe_mode_bit(m.bits[3])
        );
    }
    if let Some(f) = r.home_found_statusword {
        let _ = writeln!(
            out,
            "- Statusword bit {} reads {} in every mode once a homing run has completed since power-on.",
            f.bit,
            u8::from(f.while_active)
        );
    }
    if let Some(f) = r.torque_limit_statusword {
        let _ = writeln!(
            out,
            "- Statusword bit {} reads {} while the torque demand is at its limit (beside bit 11).",
            f.bit,
            u8::from(f.while_active)
        );
    }
    if let Some(s) = r.safe_torque_off {
        let _ = writeln!(
            out,
            "- Safe torque off (an open channel of the STO input): statusword bit {} reads {} \
             while it holds; 60FDh bits {} and {} show channel 1 and 2 (1 = closed).",
            s.statusword.bit,
            u8::from(s.statusword.while_active),
            s.digital_input_bits[0],
            s.digital_input_bits[1]
        );
    }
    if let Some(v) = r.max_interpolation_speed {
        let _ = writeln!(
            out,
            "- Cyclic synchronous position and interpolated position: a target that would move \
             the position demand {v} increments per ms or faster is ignored (the demand stays) \
             and statusword bit 11 is set."
        );
    }
    if let Some(t) = &r.touch_probe_inputs {
        let entries: Vec<String> = t
            .entries
            .iter()
            .map(|(i, s)| format!("{i:04X}h:{s:02X}"))
            .collect();
        let _ = writeln!(
            out,
            "- A touch probe enabled on its input (60B8h source 0 with an edge) needs the input \
             assigned: one of {} holding {} (probe 1) or {} (probe 2); else the write raises \
             603Fh {:04X}h.",
            entries.join(", "),
            t.functions[0],
            t.functions[1],
            t.unassigned_error.error_code
        );
    }
    if !r.store_requires_power_cycle.is_empty() {
        let subs: Vec<String> = r
            .store_requires_power_cycle
            .iter()
            .map(|s| format!("1010h:{s:02X}"))
            .collect();
        let _ = writeln!(
            out,
            "- After a store with {}, Operation Enabled needs a power-on first (enable operation \
             stops in Switched On).",
            subs.join(" or ")
        );
    }
    out.push('\n');
}

/// `[[adjusting]]`: the adjusting-service objects and their adjustments.
fn adjusting(out: &mut String, p: &Profile) {
    if p.adjusting.is_empty() {
        return;
    }
    out.push_str("## Adjusting services\n\n");
    out.push_str(
        "Request/reply objects for maintenance adjustments (firmware `adjust`): write the request \
         to :01 (step 1 CADDRESS 2000h = request code; step 2 2001h = 0002h prepare; step 3 \
         2001h = 0001h execute; 2000h = 0000h aborts), read the status at :02 (1 accepted or \
         done, 2 refused or failed, 255 executing) and the reply at :03.\n\n",
    );
    let rows: Vec<Vec<String>> = p
        .adjusting
        .iter()
        .flat_map(|a| {
            a.commands.iter().map(move |c| {
                vec![
                    format!("{:04X}h", a.object),
                    a.axis.to_string(),
                    format!("{:04X}H", c.code),
                    format!("`{}`", c.action.name()),
                    yes(c.preparation).into(),
                    format!(
                        "{} s / {} s",
                        a.time_limit_ms / 1000,
                        a.abort_after_ms / 1000
                    ),
                ]
            })
        })
        .collect();
    md_table(
        out,
        &[
            "object",
            "axis",
            "request code",
            "action",
            "preparation",
            "time limit / abort after",
        ],
        &rows,
    );
}

fn decisions(out: &mut String, p: &Profile) {
    out.push_str("## Decisions: deviations from the manual and why\n\n");
    if p.decisions.is_empty() {
        out.push_str("The profile records no decisions.\n\n");
        return;
    }
    let rules = p
        .decisions
        .iter()
        .filter(|d| d.subject.starts_with("rule:"))
        .count();
    let _ = writeln!(
        out,
        "{} decisions ({rules} of them rules the profile format cannot express yet, subject \
         \"rule: …\").\n",
        p.decisions.len()
    );
    for (i, d) in p.decisions.iter().enumerate() {
        let _ = writeln!(out, "### {}. {}\n", i + 1, md(&d.subject));
        if !d.manual.is_empty() {
            let _ = writeln!(out, "- **Manual:** {}", md(&d.manual));
        }
        let _ = writeln!(out, "- **Choice:** {}", md(&d.choice));
        if !d.reason.is_empty() {
            let _ = writeln!(out, "- **Reason:** {}", md(&d.reason));
        }
        out.push('\n');
    }
}

fn replicate(out: &mut String, p: &Profile) {
    if p.replicate.is_empty() {
        return;
    }
    out.push_str("## Replicated objects\n\n");
    out.push_str(
        "Objects copied to further axes (`[[replicate]]`; the copies have no firmware role).\n\n",
    );
    let rows: Vec<Vec<String>> = p
        .replicate
        .iter()
        .map(|&(first, last, offset)| {
            let copies = p
                .objects
                .iter()
                .filter(|o| {
                    o.index
                        .checked_sub(offset)
                        .is_some_and(|src| (first..=last).contains(&src) && p.object(src).is_some())
                })
                .count();
            vec![
                format!("{}–{}", hex16(first), hex16(last)),
                format!("+{}", hex16(offset)),
                format!(
                    "{}–{}",
                    hex16(first.wrapping_add(offset)),
                    hex16(last.wrapping_add(offset))
                ),
                copies.to_string(),
            ]
        })
        .collect();
    md_table(out, &["source", "offset", "target", "objects"], &rows);
}

fn object_count(out: &mut String, p: &Profile) {
    out.push_str("## Object dictionary\n\n");
    let entries: usize = p.objects.iter().map(|o| o.entries.len()).sum();
    let derived = p.objects.iter().filter(|o| o.derived).count();
    let _ = writeln!(
        out,
        "{} objects ({derived} derived by od-gen from the device, PDO, SM and sync sections), \
         {entries} entries.\n",
        p.objects.len()
    );
    let areas: [(&str, u16, u16); 5] = [
        ("communication (1000h–1FFFh)", 0x1000, 0x1FFF),
        ("manufacturer (2000h–5FFFh)", 0x2000, 0x5FFF),
        ("device profile (6000h–9FFFh)", 0x6000, 0x9FFF),
        ("other (A000h–FFFFh)", 0xA000, 0xFFFF),
        ("below 1000h", 0x0000, 0x0FFF),
    ];
    let rows: Vec<Vec<String>> = areas
        .iter()
        .filter_map(|(name, lo, hi)| {
            let objs: Vec<_> = p
                .objects
                .iter()
                .filter(|o| (*lo..=*hi).contains(&o.index))
                .collect();
            (!objs.is_empty()).then(|| {
                vec![
                    (*name).to_string(),
                    objs.len().to_string(),
                    objs.iter()
                        .map(|o| o.entries.len())
                        .sum::<usize>()
                        .to_string(),
                ]
            })
        })
        .collect();
    md_table(out, &["area", "objects", "entries"], &rows);
    let constants = p
        .objects
        .iter()
        .flat_map(|o| &o.entries)
        .filter(|e| e.storage == Storage::Const)
        .count();
    let _ = writeln!(
        out,
        "{constants} entries are constants. The full table: `od-gen table {}` (CSV with `--csv`).",
        p.name
    );
}

/// The Markdown page of a profile.
pub fn markdown(p: &Profile) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "<!-- Generated by od-gen from the profile `{}`. Do not edit: change the profile, then run \
         `{}`. -->\n",
        p.name,
        regenerate_one(&p.name)
    );
    let _ = writeln!(
        out,
        "# {}: {} ({})\n",
        p.name,
        md(&p.device.name),
        md(&p.vendor.name)
    );
    if !p.description.is_empty() {
        let _ = writeln!(out, "{}\n", md(&p.description));
    }
    let _ = writeln!(
        out,
        "Profile file: `{}.toml` (built-in profiles live in `od-gen/profiles/`; format: \
         `od-gen/README.md`). ESI: `od-gen esi {0}`; SII image: `od-gen sii {0}`; object table: \
         `od-gen table {0}`.\n",
        p.name
    );
    identity(&mut out, p);
    mailbox(&mut out, p);
    sync_managers(&mut out, p);
    synchronisation(&mut out, p);
    process_data(&mut out, p);
    units(&mut out, p);
    value_lists(&mut out, p);
    parameter_storage(&mut out, p);
    modes(&mut out, p);
    alarms(&mut out, p);
    warnings(&mut out, p);
    motor_faults(&mut out, p);
    adjusting(&mut out, p);
    cia402_rules(&mut out, p);
    decisions(&mut out, p);
    replicate(&mut out, p);
    object_count(&mut out, p);
    out
}

/// The index page of `profiles` (`docs/profiles/README.md`).
pub fn index(profiles: &[Profile]) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "<!-- Generated by od-gen. Do not edit: run `{REGENERATE_ALL}`. -->\n"
    );
    out.push_str("# Drive profiles\n\n");
    out.push_str(
        "One page per built-in profile (`od-gen/profiles/*.toml`), generated from the profile by \
         `od-gen doc`. `od-gen/tests/doc.rs` fails when a page differs from a fresh generation. \
         How to add a profile: [adding-a-profile.md](../adding-a-profile.md).\n\n",
    );
    let rows: Vec<Vec<String>> = profiles
        .iter()
        .map(|p| {
            vec![
                format!("[{0}]({0}.md)", p.name),
                md(&p.device.name),
                md(&p.vendor.name),
                hex32(p.device.product_code),
                hex32(p.device.revision),
                supported_modes(p).map_or("–".into(), short_modes),
                p.alarms.len().to_string(),
                p.decisions.len().to_string(),
                p.objects.len().to_string(),
            ]
        })
        .collect();
    md_table(
        &mut out,
        &[
            "profile",
            "device",
            "vendor",
            "product code",
            "revision",
            "modes (6502h)",
            "alarms",
            "decisions",
            "objects",
        ],
        &rows,
    );
    let _ = writeln!(
        out,
        "Regenerate all pages: `{REGENERATE_ALL}` (one page: `{}`).",
        regenerate_one("<name>")
    );
    out
}

/// The set bits of `bits` as a list ("0, 1, 2, 4, 8").
fn bit_list(bits: u16) -> String {
    (0..16)
        .filter(|b| bits & (1 << b) != 0)
        .map(|b: u16| b.to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn durations() {
        assert_eq!(duration(0), "0 ns");
        assert_eq!(duration(500), "500 ns");
        assert_eq!(duration(31_250), "31.25 µs");
        assert_eq!(duration(62_500), "62.5 µs");
        assert_eq!(duration(250_000), "250 µs");
        assert_eq!(duration(1_000_000), "1 ms");
        assert_eq!(duration(1_500_000), "1.5 ms");
        assert_eq!(duration(1_000_001), "1.000001 ms");
    }

    #[test]
    fn escaping() {
        assert_eq!(md("a|b"), "a\\|b");
        assert_eq!(md("CACR-JUM****CA"), "CACR-JUM\\*\\*\\*\\*CA");
        assert_eq!(md("1 ~ 10\nx"), "1 \\~ 10 x");
        assert_eq!(md("# x"), "\\# x");
        assert_eq!(md("order_number _x_"), "order_number \\_x\\_");
        assert_eq!(md("[[alarm]] a -> b"), "\\[\\[alarm]] a -> b");
    }

    #[test]
    fn control_bytes() {
        assert_eq!(control_byte(0x26), "mailbox, master writes, PDI interrupt");
        assert_eq!(
            control_byte(0x64),
            "buffered, master writes, PDI interrupt, watchdog"
        );
    }

    #[test]
    fn modes() {
        assert_eq!(
            mode_names(0x0001_0081),
            [
                "Profile position (pp), 6060h = 1",
                "Cyclic synchronous position (csp), 6060h = 8",
                "bit 16: manufacturer-specific"
            ]
        );
        assert_eq!(short_modes(0x3AD), "pp, pv, tq, hm, csp, csv, cst");
    }
}
