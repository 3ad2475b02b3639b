//! Profile-wide consistency checks that need the whole resolved profile: name, SM layout and
//! control bytes, mailbox and CoE flags, sync and DC op modes, process-data limits, roles,
//! motor-fault codes, EEPROM size.
//!
//! Every check runs and every fault is reported ([`Faults`]); a check that needs an earlier one
//! to have passed (a value it would divide by, an entry it would read) is skipped when that one
//! failed, so a profile's faults are its own and not their consequences.

use std::collections::BTreeSet;

use hal::esc::{dc, DcCycleRule, MAX_FIRMWARE_MAPPED_ENTRIES};

use crate::error::{fault, Fault, Invalid};
use crate::model::*;

/// The faults found in a profile, in the order the checks found them.
#[derive(Debug, Default)]
pub(crate) struct Faults(pub(crate) Vec<Fault>);

impl Faults {
    /// Records that `key` is at fault.
    pub(crate) fn add(&mut self, key: &str, error: Invalid) {
        self.0.push(fault(key, error));
    }

    /// Records the fault of a check that stops at its first, if any; whether it passed.
    pub(crate) fn take<T>(&mut self, r: Result<T, Fault>) -> Option<T> {
        match r {
            Ok(v) => Some(v),
            Err(f) => {
                self.0.push(f);
                None
            }
        }
    }

    /// `Ok` when nothing was found.
    pub(crate) fn into_result(self) -> Result<(), Self> {
        if self.0.is_empty() {
            Ok(())
        } else {
            Err(self)
        }
    }
}

impl From<Fault> for Faults {
    fn from(f: Fault) -> Self {
        Self(vec![f])
    }
}

/// Runs every check; every failure is returned with its key.
pub(crate) fn check(p: &Profile) -> Result<(), Faults> {
    let mut f = Faults::default();
    f.take(name(&p.name));
    sms(p, &mut f);
    mailbox(p, &mut f);
    sync(p, &mut f);
    pdo_limits(p, &mut f);
    sm_parameters(p, &mut f);
    roles(p, &mut f);
    alarm_objects(p, &mut f);
    settings(p, &mut f);
    esm(p, &mut f);
    motor_faults(p, &mut f);
    strings(p, &mut f);
    eeprom(p, &mut f);
    f.into_result()
}

const KEYWORDS: [&str; 51] = [
    "as", "break", "const", "continue", "crate", "else", "enum", "extern", "false", "fn", "for",
    "if", "impl", "in", "let", "loop", "match", "mod", "move", "mut", "pub", "ref", "return",
    "self", "Self", "static", "struct", "super", "trait", "true", "type", "unsafe", "use", "where",
    "while", "async", "await", "dyn", "abstract", "become", "box", "do", "final", "macro",
    "override", "priv", "typeof", "unsized", "virtual", "yield", "try",
];

fn name(n: &str) -> Result<(), Fault> {
    let mut chars = n.chars();
    let module = n.replace('-', "_");
    let ok = chars.next().is_some_and(|c| c.is_ascii_lowercase())
        && chars.all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_' || c == '-')
        && !KEYWORDS.contains(&module.as_str())
        && module != "check";
    if ok {
        Ok(())
    } else {
        Err(fault(
            "name",
            Invalid::Value(format!(
                "`{n}` is not a lower-case name `[a-z][a-z0-9_-]*` whose module name (`-` as `_`) \
                 is a Rust identifier"
            )),
        ))
    }
}

/// SM control byte (ESC register 0x0804, ET1100 datasheet Sec. II): bits 0..1 operation mode
/// (00 buffered/3-buffer, 10 mailbox), bits 2..3 direction (00 ECAT reads, 01 ECAT writes).
fn control(sm: &'static str, c: u8, mailbox: bool, ecat_writes: bool) -> Result<(), Fault> {
    let mode = c & 0x03;
    let dir = (c >> 2) & 0x03;
    let why = if mailbox && mode != 0b10 {
        Some("bits 0..1 must be 10 (mailbox mode)")
    } else if !mailbox && mode != 0b00 {
        Some("bits 0..1 must be 00 (buffered mode)")
    } else if ecat_writes && dir != 0b01 {
        Some("bits 2..3 must be 01 (master writes)")
    } else if !ecat_writes && dir != 0b00 {
        Some("bits 2..3 must be 00 (master reads)")
    } else if c & 0x80 != 0 {
        Some("bit 7 is reserved")
    } else {
        None
    };
    match why {
        Some(why) => Err(fault(
            &format!("sm.{sm}.control"),
            Invalid::SmControl {
                sm,
                control: c,
                why,
            },
        )),
        None => Ok(()),
    }
}

fn sms(p: &Profile, f: &mut Faults) {
    let s = &p.sm;
    f.take(control("mailbox_out", s.mailbox_out.control, true, true));
    f.take(control("mailbox_in", s.mailbox_in.control, true, false));
    if let Some(b) = s.boot_out {
        f.take(control("boot_out", b.control, true, true));
    }
    if let Some(b) = s.boot_in {
        f.take(control("boot_in", b.control, true, false));
    }
    f.take(control("outputs", s.outputs.control, false, true));
    f.take(control("inputs", s.inputs.control, false, false));
    if s.boot_out.is_some() != s.boot_in.is_some() {
        f.add(
            "sm.boot_out",
            Invalid::Value("boot_out and boot_in come as a pair".into()),
        );
    }
    for (name, sm) in [("mailbox_out", s.mailbox_out), ("mailbox_in", s.mailbox_in)]
        .into_iter()
        .chain(s.boot_out.map(|b| ("boot_out", b)))
        .chain(s.boot_in.map(|b| ("boot_in", b)))
    {
        // A CoE SDO request needs 6 (mailbox header) + 10 (CoE + SDO header) bytes.
        if sm.length < 16 {
            f.add(
                &format!("sm.{name}.size"),
                Invalid::Value("a mailbox needs at least 16 bytes".into()),
            );
        }
        if sm.length > hal::esc::MAX_FIRMWARE_MAILBOX {
            f.add(
                &format!("sm.{name}.size"),
                Invalid::Value(format!(
                    "at most {} bytes: the firmware's mailbox buffers are that long, it refuses \
                     a longer mailbox at INIT -> PREOP (AL status code 0x0016)",
                    hal::esc::MAX_FIRMWARE_MAILBOX
                )),
            );
        }
    }
    // Memory used by each SM: mailboxes one buffer, process data three buffers (3-buffer mode),
    // sized for the larger of the default assignment and all PDOs of that direction.
    let all_bits = |pdos: &[Pdo]| -> u32 { pdos.iter().map(Pdo::bits).sum() };
    let pd_len =
        |sm: Sm, pdos: &[Pdo]| -> u32 { u32::from(sm.length).max(all_bits(pdos).div_ceil(8)) };
    let areas: Vec<(&'static str, u32, u32)> = vec![
        (
            "mailbox_out",
            u32::from(s.mailbox_out.start),
            u32::from(s.mailbox_out.length),
        ),
        (
            "mailbox_in",
            u32::from(s.mailbox_in.start),
            u32::from(s.mailbox_in.length),
        ),
        (
            "outputs",
            u32::from(s.outputs.start),
            3 * pd_len(s.outputs, &p.rx_pdos),
        ),
        (
            "inputs",
            u32::from(s.inputs.start),
            3 * pd_len(s.inputs, &p.tx_pdos),
        ),
    ];
    // The bootstrap mailboxes replace the standard ones in BOOT, so they may share memory with
    // them; they must not collide with process data.
    let boot: Vec<(&'static str, u32, u32)> = [("boot_out", s.boot_out), ("boot_in", s.boot_in)]
        .into_iter()
        .filter_map(|(n, b)| b.map(|b| (n, u32::from(b.start), u32::from(b.length))))
        .collect();
    // The ET1100's process RAM: 8 KiB from 0x1000 (ET1100 datasheet Sec. I, address space).
    let ram = hal::esc::regs::ET1100_PROCESS_RAM;
    for &(name, start, len) in areas.iter().chain(&boot) {
        if start < u32::from(ram.addr) || start + len > u32::from(ram.end()) {
            f.add(
                &format!("sm.{name}.start"),
                Invalid::Value(format!(
                    "{len} bytes from {start:#06x} (three buffers for process data) do not fit \
                     the ET1100 process RAM {:#06x}..{:#06x}",
                    ram.addr,
                    ram.end()
                )),
            );
        }
    }
    let overlaps =
        |a: (u32, u32), b: (u32, u32)| a.1 > 0 && b.1 > 0 && a.0 < b.0 + b.1 && b.0 < a.0 + a.1;
    for (i, a) in areas.iter().enumerate() {
        for b in areas.iter().skip(i + 1) {
            if overlaps((a.1, a.2), (b.1, b.2)) {
                f.add(
                    &format!("sm.{}", b.0),
                    Invalid::SmOverlap { a: a.0, b: b.0 },
                );
            }
        }
    }
    for &(bn, bs, bl) in &boot {
        for &(an, as_, al) in areas.iter().skip(2) {
            if overlaps((bs, bl), (as_, al)) {
                f.add(&format!("sm.{bn}"), Invalid::SmOverlap { a: an, b: bn });
            }
        }
    }
}

fn mailbox(p: &Profile, f: &mut Faults) {
    let c = p.mailbox.coe;
    let needs_sdo =
        c.sdo_info || c.pdo_assign || c.pdo_config || c.upload_at_startup || c.complete_access;
    if p.mailbox.protocols & protocol::COE != 0 && !c.sdo {
        f.add(
            "mailbox.coe.sdo",
            Invalid::Mailbox("CoE without SDO support is not useful".into()),
        );
    } else if needs_sdo && !c.sdo {
        f.add(
            "mailbox.coe",
            Invalid::Mailbox("CoE services need `sdo = true`".into()),
        );
    }
    if c.pdo_config && !c.pdo_assign {
        f.add(
            "mailbox.coe.pdo_config",
            Invalid::Mailbox("PDO configuration without PDO assignment is not supported".into()),
        );
    }
    if p.mailbox.protocols == 0 {
        f.add(
            "mailbox.protocols",
            Invalid::Mailbox("at least one protocol is needed".into()),
        );
    }
}

/// Why the firmware refuses a SYNC0 cycle, after the AL status code of [`DcCycleRule::check`].
fn refused_cycle(code: hal::esc::AlStatusCode, step_ns: u32) -> String {
    let why = match code {
        hal::esc::AlStatusCode::DcInvalidSyncCycleTime => {
            "outside min_cycle_ns..=max_cycle_ns".to_string()
        }
        hal::esc::AlStatusCode::DcSync0CycleTime => {
            format!(
                "not a multiple of sync.cycle_step_ns = {step_ns} (or not one of \
                 sync.allowed_cycles_ns)"
            )
        }
        _ => "not a cycle it runs".to_string(),
    };
    format!(
        "{why}: the firmware refuses this SYNC0 cycle at PREOP -> SAFEOP (AL status code {:#06x})",
        code.code()
    )
}

fn sync(p: &Profile, f: &mut Faults) {
    let y = &p.sync;
    if !(y.free_run || y.sm_synchronous || y.dc_sync0 || y.dc_sync1) {
        f.add(
            "sync",
            Invalid::Sync("no synchronisation mode is supported".into()),
        );
    }
    if y.dc_sync1 && !y.dc_sync0 {
        f.add("sync.dc_sync1", Invalid::Sync("SYNC1 needs SYNC0".into()));
    }
    // An empty range refuses every cycle (0x0035); the checks of cycles in it need one.
    let range_ok = y.min_cycle_ns != 0 && y.min_cycle_ns <= y.max_cycle_ns;
    if !range_ok {
        f.add(
            "sync.min_cycle_ns",
            Invalid::Sync(
                "need 0 < min_cycle_ns <= max_cycle_ns: the firmware refuses every SYNC0 cycle \
                 of an empty range at PREOP -> SAFEOP (AL status code 0x0035)"
                    .into(),
            ),
        );
    }
    // The checks of multiples divide by it.
    let step_ok = y.cycle_step_ns != 0;
    if !step_ok {
        f.add(
            "sync.cycle_step_ns",
            Invalid::Sync("must be at least 1".into()),
        );
    }
    let dc = y.dc_sync0 || y.dc_sync1;
    if range_ok && step_ok {
        // The firmware's own rule (without the list of allowed cycles, checked as a whole
        // below): the shortest cycle 1C32h:05 advertises, the longest a DC device declares
        // and 1C32h:02's default.
        let rule = DcCycleRule {
            min_ns: y.min_cycle_ns,
            max_ns: y.max_cycle_ns,
            step_ns: y.cycle_step_ns,
            allowed_ns: &[],
        };
        let max = dc.then_some(("sync.max_cycle_ns", y.max_cycle_ns));
        for (key, v) in [
            ("sync.min_cycle_ns", y.min_cycle_ns),
            ("sync.default_cycle_ns", y.default_cycle_ns),
        ]
        .into_iter()
        .chain(max)
        {
            if let Err(code) = rule.check(v) {
                f.add(
                    key,
                    Invalid::Sync(format!(
                        "{v} ns is {}",
                        refused_cycle(code, y.cycle_step_ns)
                    )),
                );
            }
        }
    }
    let free_run_ok =
        y.free_run_min_cycle_ns != 0 && y.free_run_min_cycle_ns <= y.free_run_max_cycle_ns;
    // Without its own keys the free-run range is the DC range, already reported.
    let same_as_dc =
        (y.free_run_min_cycle_ns, y.free_run_max_cycle_ns) == (y.min_cycle_ns, y.max_cycle_ns);
    let reported = same_as_dc && !range_ok;
    if !free_run_ok && !reported {
        f.add(
            "sync.free_run_min_cycle_ns",
            Invalid::Sync("free-run cycle range must be non-empty and above 0 ns".into()),
        );
    }
    if y.free_run && free_run_ok {
        // 1C32h:02's default is the free-run period until the master writes another.
        if let Err(code) = dc::check_free_run_cycle(
            y.default_cycle_ns,
            y.free_run_min_cycle_ns,
            y.free_run_max_cycle_ns,
        ) {
            f.add(
                "sync.default_cycle_ns",
                Invalid::Sync(format!(
                    "default_cycle_ns outside the free-run cycle range: the firmware refuses \
                     free run with it at PREOP -> SAFEOP (AL status code {:#06x})",
                    code.code()
                )),
            );
        }
    }
    if let Some(shift) = y.input_shift {
        if shift.step_ns == 0 || shift.reserve_ns >= y.max_cycle_ns || !y.dc_sync0 {
            f.add(
                "sync.input_shift",
                Invalid::Sync(
                    "needs dc_sync0, step_ns above 0 and reserve_ns below max_cycle_ns".into(),
                ),
            );
        }
        if let Some(at) = shift.parameter {
            f.take(integer_parameter(p, at, "sync.input_shift.parameter"));
        }
    }
    if !y.allowed_cycles_ns.is_empty() && range_ok && step_ok {
        let ascending = y.allowed_cycles_ns.windows(2).all(|w| w[0] < w[1]);
        let fits = y
            .allowed_cycles_ns
            .iter()
            .all(|c| (y.min_cycle_ns..=y.max_cycle_ns).contains(c) && c % y.cycle_step_ns == 0);
        let ends = y.allowed_cycles_ns.first() == Some(&y.min_cycle_ns)
            && y.allowed_cycles_ns.last() == Some(&y.max_cycle_ns);
        if !ascending || !fits || !ends || !y.allowed_cycles_ns.contains(&y.default_cycle_ns) {
            f.add(
                "sync.allowed_cycles_ns",
                Invalid::Sync(
                    "must ascend from min_cycle_ns to max_cycle_ns in multiples of cycle_step_ns \
                     and hold default_cycle_ns"
                        .into(),
                ),
            );
        }
    }
    let mut names = BTreeSet::new();
    for (i, m) in p.dc_op_modes.iter().enumerate() {
        let key = format!("dc_op_mode[{i}]");
        if m.name.is_empty() || !names.insert(m.name.as_str()) {
            f.add(
                &format!("{key}.name"),
                Invalid::Sync("op mode names must be unique and non-empty".into()),
            );
        }
        // AssignActivate is written to 0x0980:0x0981; 0x0981 bit 0 = activate cyclic operation,
        // bit 1 = SYNC0, bit 2 = SYNC1 (ET1100 datasheet Sec. II, register 0x0981).
        let act = m.assign_activate >> 8;
        if act & 0x02 != 0 && !y.dc_sync0 {
            f.add(
                &format!("{key}.assign_activate"),
                Invalid::Sync("activates SYNC0 but sync.dc_sync0 is false".into()),
            );
        }
        if act & 0x04 != 0 && !y.dc_sync1 {
            f.add(
                &format!("{key}.assign_activate"),
                Invalid::Sync("activates SYNC1 but sync.dc_sync1 is false".into()),
            );
        }
        if act & 0x06 != 0 && act & 0x01 == 0 {
            f.add(
                &format!("{key}.assign_activate"),
                Invalid::Sync("SYNC signals need bit 8 (cyclic operation)".into()),
            );
        }
        if m.assign_activate & 0xF800 != 0 {
            f.add(
                &format!("{key}.assign_activate"),
                Invalid::Sync("reserved bits set".into()),
            );
        }
        // A fixed SYNC0 cycle (ESI `CycleTimeSync0` with factor 0; 0 is the master's cycle)
        // is the cycle a master configures from the ESI: one the firmware runs.
        if act & 0x02 != 0 && m.sync0_factor == 0 && m.sync0_cycle_ns != 0 {
            if let Err(code) = y.dc_cycle_rule().check(m.sync0_cycle_ns) {
                f.add(
                    &format!("{key}.sync0_cycle_ns"),
                    Invalid::Sync(format!(
                        "{} ns is {}",
                        m.sync0_cycle_ns,
                        refused_cycle(code, y.cycle_step_ns)
                    )),
                );
            }
        }
    }
    let has = |bits: u16| {
        p.dc_op_modes
            .iter()
            .any(|m| (m.assign_activate >> 8) & bits == bits)
    };
    if y.dc_sync0 && !has(0x03) {
        f.add(
            "dc_op_mode",
            Invalid::Sync(
                "sync.dc_sync0 needs an op mode with SYNC0 (AssignActivate 0x0300)".into(),
            ),
        );
    }
    if y.dc_sync1 && !has(0x07) {
        f.add(
            "dc_op_mode",
            Invalid::Sync(
                "sync.dc_sync1 needs an op mode with SYNC1 (AssignActivate 0x0700)".into(),
            ),
        );
    }
}

/// What the firmware maps in one direction ([`hal::esc::MAX_FIRMWARE_MAPPED_ENTRIES`] entries,
/// padding excluded, and `[pdo] max_process_bytes` bytes, at most
/// [`hal::esc::MAX_FIRMWARE_PROCESS_IMAGE`]): its PREOP -> SAFEOP check refuses a default
/// assignment beyond it with 0x0025 (outputs) / 0x0024 (inputs), and every assignment of a
/// PDO that alone is beyond it. (The default assignment's bytes are checked where the SM
/// length is derived from them, `resolve`.)
fn pdo_limits(p: &Profile, f: &mut Faults) {
    let mapped = |pdo: &Pdo| pdo.entries.iter().filter(|e| e.data_type.is_some()).count();
    let max_entries = usize::from(MAX_FIRMWARE_MAPPED_ENTRIES);
    for (pdos, kind, code) in [(&p.rx_pdos, "rxpdo", 0x0025), (&p.tx_pdos, "txpdo", 0x0024)] {
        let default: usize = pdos.iter().filter(|d| d.assigned).map(mapped).sum();
        if default > max_entries {
            f.add(
                kind,
                Invalid::Value(format!(
                    "the default assignment maps {default} entries, the firmware at most \
                     {max_entries} per direction: it refuses the assignment at PREOP -> SAFEOP \
                     (AL status code {code:#06x})"
                )),
            );
        }
        for pdo in pdos.iter() {
            let key = format!("{kind}[{:#06x}].entries", pdo.index);
            let (n, bytes) = (mapped(pdo), pdo.bits().div_ceil(8));
            // An assigned one is part of the default assignment, reported above.
            if n > max_entries && !pdo.assigned {
                f.add(
                    &key,
                    Invalid::Value(format!(
                        "maps {n} entries, the firmware at most {max_entries} per direction: it \
                         refuses every assignment of this PDO at PREOP -> SAFEOP (AL status code \
                         {code:#06x})"
                    )),
                );
            }
            if bytes > u32::from(p.max_process_bytes) && !pdo.assigned {
                f.add(
                    &key,
                    Invalid::Value(format!(
                        "{bytes} bytes exceed pdo.max_process_bytes = {}: the firmware refuses \
                         every assignment of this PDO at PREOP -> SAFEOP (AL status code \
                         {code:#06x})",
                        p.max_process_bytes
                    )),
                );
            }
        }
    }
}

/// The most axes a drive profile may have (`[device] ds402_channels`): the firmware's
/// `profile::MAX_AXES`, which the generated code asserts to agree.
pub const MAX_AXES: u8 = 2;

/// The most `[[split_value]]` settings: the firmware's `drive::MAX_SPLIT_VALUES`, which the
/// generated code asserts to agree.
pub const MAX_SPLIT_VALUES: usize = 4;

fn roles(p: &Profile, f: &mut Faults) {
    axes(p, f);
    let mut seen = BTreeSet::new();
    for o in &p.objects {
        for e in &o.entries {
            if let Some(r) = e.role {
                if e.storage != Storage::Ram {
                    f.add(
                        &format!("object[{:#06x}].role", o.index),
                        Invalid::RoleType {
                            role: r.field().into(),
                            expected: "RAM",
                        },
                    );
                }
                if !seen.insert(r) {
                    f.add(
                        &format!("object[{:#06x}].role", o.index),
                        Invalid::DuplicateRole(r.field().into()),
                    );
                }
            }
        }
    }
}

/// A drive with more than one axis: each further axis has its own copy of every CiA402
/// variable the firmware binds (`[[replicate]]`), at most [`MAX_AXES`] axes.
fn axes(p: &Profile, f: &mut Faults) {
    if p.kind != ProfileKind::Drive || p.axis_count() == 1 {
        return;
    }
    if p.axis_count() > MAX_AXES {
        // The copies of axes the firmware does not drive are not looked for.
        f.add(
            "device.ds402_channels",
            Invalid::Value(format!(
                "the firmware drives at most {MAX_AXES} axes in one slave"
            )),
        );
        return;
    }
    // One fault per axis, naming every variable it has no copy of.
    for axis in 1..p.axis_count() {
        let missing: Vec<String> = p
            .objects
            .iter()
            .flat_map(|o| o.entries.iter().map(move |e| (o.index, e)))
            .filter(|(_, e)| e.role.is_some_and(Role::per_axis))
            .filter(|&(index, e)| {
                let copy = p.axis_index(index, axis);
                let own_ram = copy != index
                    && p.entry(copy, e.subindex)
                        .is_some_and(|c| c.storage == Storage::Ram && c.data_type == e.data_type);
                !own_ram
            })
            .map(|(index, e)| format!("{index:#06x}:{}", e.subindex))
            .collect();
        if !missing.is_empty() {
            f.add(
                "device.ds402_channels",
                Invalid::Value(format!(
                    "axis {} has no copy of {} (its own RAM entry of the same type, placed by \
                     [[replicate]])",
                    axis + 1,
                    missing.join(", ")
                )),
            );
        }
    }
}

/// The most alarm records a drive keeps (`[alarm_objects] history_select`'s maximum, the
/// history list's length): the firmware's `alarm_log::MAX_RECORDS`, which the generated code
/// asserts to agree.
pub const MAX_ALARM_RECORDS: usize = 20;

/// The most fields of an alarm record: the firmware's `alarm_log::MAX_FIELDS`.
pub const MAX_ALARM_FIELDS: usize = 16;

/// `[alarm_objects]`: every object a RAM variable the firmware can write (integers of 1, 2 or
/// 4 bytes), every alarm's number non-zero (0 shows "none") and within each list's type, the
/// clear command and the selector writable, at most [`MAX_ALARM_RECORDS`] records.
fn alarm_objects(p: &Profile, f: &mut Faults) {
    let a = &p.alarm_objects;
    let uses_numbers = a.active.is_some() || a.history.is_some() || a.history_record.is_some();
    if !uses_numbers {
        // Neither numbers nor records: only the clear command could be given, and it needs a
        // history.
        if a.history_clear.is_some() {
            f.add(
                "alarm_objects.history_clear",
                Invalid::Missing("history or history_record"),
            );
        }
        return;
    }
    let slots = |key: &str, index: u16, first: u8| -> Result<Vec<&Entry>, Fault> {
        let o = p.object(index).ok_or_else(|| {
            fault(
                key,
                Invalid::Value(format!("{index:#06x} is not in the dictionary")),
            )
        })?;
        // The clear command may sit in the history object (the RSE's 200Bh:0Bh).
        let entries: Vec<&Entry> = o
            .entries
            .iter()
            .filter(|e| e.subindex >= first && a.history_clear != Some((index, e.subindex)))
            .collect();
        if entries.is_empty() {
            return Err(fault(
                key,
                Invalid::Value(format!("{index:#06x} has no subindex {first} or above")),
            ));
        }
        for e in &entries {
            let ok = e.storage == Storage::Ram
                && e.data_type.int_range().is_some()
                && matches!(e.byte_len(), 1 | 2 | 4);
            if !ok {
                return Err(fault(
                    key,
                    Invalid::Value(format!(
                        "{index:#06x}:{} must be an integer RAM variable of 1, 2 or 4 bytes",
                        e.subindex
                    )),
                ));
            }
        }
        Ok(entries)
    };
    // Every alarm without a number is reported; the numbers there are are checked against
    // the lists' types.
    let mut numbers: Vec<(String, u32)> = Vec::new();
    for alarm in &p.alarms {
        match a.number.of(alarm).filter(|n| *n != 0) {
            Some(n) => numbers.push((alarm.display.clone(), n)),
            None => f.add(
                "alarm_objects.number",
                Invalid::Value(format!("alarm {} has no non-zero number", alarm.display)),
            ),
        }
    }
    let fits = |key: &str, e: &Entry| -> Result<(), Fault> {
        let (_, max) = e.data_type.int_range().unwrap_or((0, 0));
        match numbers.iter().find(|(_, n)| i128::from(*n) > max) {
            Some((display, n)) => Err(fault(
                key,
                Invalid::Value(format!(
                    "alarm {display}'s number {n} does not fit {:?}",
                    e.data_type
                )),
            )),
            None => Ok(()),
        }
    };
    for (key, index) in [
        ("alarm_objects.active", a.active),
        ("alarm_objects.history", a.history),
    ] {
        let Some(index) = index else { continue };
        let Some(entries) = f.take(slots(key, index, 1)) else {
            continue;
        };
        if entries.len() > MAX_ALARM_RECORDS {
            f.add(
                key,
                Invalid::Value(format!("more than {MAX_ALARM_RECORDS} entries")),
            );
        }
        // One fault per list: its entries share a type.
        if let Some(fault) = entries.into_iter().find_map(|e| fits(key, e).err()) {
            f.0.push(fault);
        }
    }
    let writable = |key: &str, (index, sub): (u16, u8)| -> Result<&Entry, Fault> {
        p.entry(index, sub)
            .filter(|e| {
                e.storage == Storage::Ram
                    && e.access.writable()
                    && e.data_type.int_range().is_some()
            })
            .ok_or_else(|| {
                fault(
                    key,
                    Invalid::Value(format!(
                        "{index:#06x}:{sub} must be a writable integer RAM entry"
                    )),
                )
            })
    };
    if let Some(clear) = a.history_clear {
        f.take(writable("alarm_objects.history_clear", clear));
    }
    if let Some(r) = &a.history_record {
        if let Some(select) = f.take(writable("alarm_objects.history_select", r.select)) {
            let records = entry_max(select).unwrap_or(0);
            if !(1..=MAX_ALARM_RECORDS as i128).contains(&records) {
                f.add(
                    "alarm_objects.history_select",
                    Invalid::Value(format!(
                        "its max (the number of records) must be 1 to {MAX_ALARM_RECORDS}"
                    )),
                );
            }
        }
        let key = "alarm_objects.history_record";
        if let Some(entries) = f.take(slots(key, r.object, 1)) {
            if entries.len() != r.fields.len() || r.fields.len() > MAX_ALARM_FIELDS {
                f.add(
                    "alarm_objects.history_fields",
                    Invalid::Value(format!(
                        "{} fields for {} subindexes of {:#06x} (at most {MAX_ALARM_FIELDS})",
                        r.fields.len(),
                        entries.len(),
                        r.object
                    )),
                );
            }
            let numbered = entries
                .iter()
                .zip(&r.fields)
                .filter(|(_, field)| **field == RecordField::Number);
            if let Some(fault) = numbered.into_iter().find_map(|(e, _)| fits(key, e).err()) {
                f.0.push(fault);
            }
        }
    }
}

/// An integer entry's maximum (its `max`, else its type's).
fn entry_max(e: &Entry) -> Option<i128> {
    let (_, type_max) = e.data_type.int_range()?;
    if e.max.is_empty() {
        return Some(type_max);
    }
    let mut bytes = [0u8; 16];
    for (d, s) in bytes.iter_mut().zip(&e.max) {
        *d = *s;
    }
    Some(i128::from_le_bytes(bytes))
}

fn strings(p: &Profile, f: &mut Faults) {
    let mut all: Vec<(&str, String)> = vec![
        ("device.name", p.device.name.clone()),
        ("device.order_number", p.device.order_number.clone()),
        ("device.group_type", p.device.group_type.clone()),
        ("device.group_name", p.device.group_name.clone()),
        ("vendor.name", p.vendor.name.clone()),
    ];
    for m in &p.dc_op_modes {
        all.push(("dc_op_mode.name", m.name.clone()));
        all.push(("dc_op_mode.description", m.description.clone()));
    }
    for pdo in p.rx_pdos.iter().chain(&p.tx_pdos) {
        all.push(("rxpdo/txpdo.name", pdo.name.clone()));
    }
    for (key, s) in &all {
        if s.len() > 255 {
            f.add(
                key,
                Invalid::Value("longer than 255 bytes (SII string limit)".into()),
            );
        }
    }
    for (key, s) in all.iter().take(4) {
        if s.is_empty() {
            f.add(key, Invalid::Value("must not be empty".into()));
        }
    }
    let physics_ok = p.device.physics.len() <= 4
        && p.device
            .physics
            .chars()
            .all(|c| matches!(c, 'Y' | 'K' | 'H' | ' '));
    if !physics_ok {
        f.add(
            "device.physics",
            Invalid::Value("up to 4 of Y, K, H or space".into()),
        );
    }
}

fn eeprom(p: &Profile, f: &mut Faults) {
    let n = p.eeprom.byte_size;
    if n < 128 || !n.is_power_of_two() || n / 128 > 0x1_0000 {
        f.add(
            "eeprom.byte_size",
            Invalid::Value("must be 128 × a power of two (128, 256, ... bytes)".into()),
        );
    } else {
        let needed = crate::sii::content(p).len();
        if needed > n {
            f.add(
                "eeprom.byte_size",
                Invalid::EepromTooSmall {
                    needed,
                    declared: n,
                },
            );
        }
    }
    if let Some(at) = p.eeprom.station_alias_parameter {
        f.take(integer_parameter(p, at, "eeprom.station_alias_parameter"));
    }
    if let Some((index, subindex, _)) = p.eeprom.station_alias_selector {
        if p.eeprom.station_alias_parameter.is_none() {
            f.add(
                "eeprom.station_alias_selector",
                Invalid::Value("needs eeprom.station_alias_parameter".into()),
            );
        }
        f.take(integer_parameter(
            p,
            (index, subindex),
            "eeprom.station_alias_selector.entry",
        ));
    }
}

/// A parameter the firmware reads at power-on: an integer entry of at most 32 bits in RAM,
/// writable (so a master can set it and 1010h can store it).
pub(crate) fn integer_parameter(
    p: &Profile,
    (index, subindex): (u16, u8),
    key: &str,
) -> Result<(), Fault> {
    let e = p
        .entry(index, subindex)
        .ok_or_else(|| fault(key, Invalid::PdoEntryMissing { index, subindex }))?;
    let integer = matches!(
        e.data_type,
        DataType::Usint
            | DataType::Uint
            | DataType::Udint
            | DataType::Sint
            | DataType::Int
            | DataType::Dint
    );
    if !integer || e.storage != Storage::Ram || !e.access.writable() {
        return Err(fault(
            key,
            Invalid::Value(format!(
                "{index:#06x}:{subindex} must be a writable integer parameter of at most 32 bits in RAM"
            )),
        ));
    }
    Ok(())
}

/// A declared 1C32h/1C33h (the manual's layout instead of the generated one) must carry what
/// the stack reads and writes, consistent with `[sync]`: :01 sync type (UINT in RAM, writable
/// exactly when `sync_mode_writable`, default `default_sync_mode`), :02 cycle time (UDINT in
/// RAM, writable exactly when `cycle_time_writable`, then with a range that holds the DC and
/// free-run cycles; default `default_cycle_ns`), 1C33h:03 writable exactly when `input_shift` is
/// given (then a UDINT in RAM), 1C32h:03 read-only; where present, :04 advertises the modes
/// `[sync]` supports (bits 0..4; higher bits are the manual's) and :05 holds `min_cycle_ns`. The
/// stack refreshes the other RAM entries it knows (:03, :05, :06, :09, :0A, :0B, :0C, :20) and
/// leaves constant ones (the manual's fixed values) as declared.
fn sm_parameters(p: &Profile, f: &mut Faults) {
    let y = &p.sync;
    // The missed-event counter lives at ETG's 0x0B unless a declared 1C32h puts it elsewhere,
    // or has none (0: the manual's layout lists no counter).
    let declared_1c32 = p.object(0x1C32).is_some_and(|o| !o.derived);
    let counter_ok = if y.sm_event_missed_subindex == 0 {
        declared_1c32
    } else {
        p.entry(0x1C32, y.sm_event_missed_subindex)
            .is_some_and(|e| e.storage == Storage::Ram && !e.access.writable())
    };
    if !counter_ok {
        f.add(
            "sync.sm_event_missed_subindex",
            Invalid::Sync(if y.sm_event_missed_subindex == 0 {
                "0 (no missed-event counter) needs a declared 1C32h".into()
            } else {
                format!(
                    "1C32h:{:02X} must be a read-only entry in RAM",
                    y.sm_event_missed_subindex
                )
            }),
        );
    }
    for o in p
        .objects
        .iter()
        .filter(|o| SM_PARAMETER_OBJECTS.contains(&o.index) && !o.derived)
    {
        sm_parameter(p, o, f);
    }
}

/// One declared SM parameter object (see [`sm_parameters`]).
fn sm_parameter(p: &Profile, o: &Object, f: &mut Faults) {
    let y = &p.sync;
    let mut bad = |sub: u8, what: &str| {
        f.add(
            &format!("object[{:#06x}].entry[{sub}]", o.index),
            Invalid::Sync(format!("{:#06x}:{sub:02X}: {what}", o.index)),
        );
    };
    let le = |b: &[u8]| {
        let mut a = [0u8; 4];
        let n = b.len().min(4);
        a[..n].copy_from_slice(&b[..n]);
        u32::from_le_bytes(a)
    };
    let ram_of = |sub: u8, t: DataType| {
        o.entry(sub)
            .filter(|e| e.data_type == t && e.storage == Storage::Ram)
    };
    if o.code != ObjectCode::Record {
        // The entries are not looked at: the object is not what the stack reads.
        f.add(
            &format!("object[{:#06x}].code", o.index),
            Invalid::Sync("an SM parameter object is a RECORD".into()),
        );
        return;
    }
    match ram_of(1, DataType::Uint) {
        None => bad(1, "the sync type must be a UINT in RAM"),
        Some(mode) => {
            if mode.access.writable() != y.sync_mode_writable {
                bad(1, "writable exactly when sync.sync_mode_writable");
            }
            // 1C33h follows 1C32h; its SM-synchronous value is 0x22 (synchronous with SM2).
            let mode_default = match (o.index, y.default_sync_mode) {
                (0x1C33, 1) => 0x22,
                (_, m) => m,
            };
            if le(&mode.initial_bytes()) != u32::from(mode_default) {
                bad(1, "the default must be sync.default_sync_mode");
            }
        }
    }
    match ram_of(2, DataType::Udint) {
        None => bad(2, "the cycle time must be a UDINT in RAM"),
        Some(cycle) => {
            if cycle.access.writable() != y.cycle_time_writable {
                bad(2, "writable exactly when sync.cycle_time_writable");
            }
            if cycle.access.writable() {
                let lowest = y.min_cycle_ns.min(y.free_run_min_cycle_ns);
                let highest = y.max_cycle_ns.max(y.free_run_max_cycle_ns);
                if cycle.min.is_empty()
                    || cycle.max.is_empty()
                    || le(&cycle.min) > lowest
                    || le(&cycle.max) < highest
                {
                    bad(
                        2,
                        "a writable cycle time needs min/max holding the DC and free-run cycles",
                    );
                }
            }
            if le(&cycle.initial_bytes()) != y.default_cycle_ns {
                bad(2, "the default must be sync.default_cycle_ns");
            }
        }
    }
    if let Some(e) = o.entry(4) {
        let advertised = le(&e.initial_bytes()) & 0x1F;
        if e.data_type != DataType::Uint || advertised != u32::from(y.modes_supported()) {
            bad(
                4,
                &format!(
                    "a UINT whose bits 0..4 are the modes [sync] supports ({:#06x})",
                    y.modes_supported()
                ),
            );
        }
    }
    if let Some(e) = o.entry(5) {
        if e.data_type != DataType::Udint || le(&e.initial_bytes()) != y.min_cycle_ns {
            bad(5, "a UDINT holding sync.min_cycle_ns");
        }
    }
    let shift = o.entry(3);
    let shift_writable = shift.is_some_and(|e| e.access.writable());
    match (o.index, y.input_shift.is_some()) {
        (0x1C33, true) if ram_of(3, DataType::Udint).is_none() || !shift_writable => {
            bad(3, "sync.input_shift needs a writable UDINT in RAM");
        }
        (0x1C33, false) | (0x1C32, _) if shift_writable => {
            bad(3, "writable only as 1C33h:03 with sync.input_shift");
        }
        _ => {}
    }
}

/// A setting (startup parameter) is downloaded by the master at start-up, so it must be
/// writable.
fn settings(p: &Profile, f: &mut Faults) {
    for o in &p.objects {
        for e in o
            .entries
            .iter()
            .filter(|e| e.setting && !e.access.writable())
        {
            f.add(
                &format!(
                    "object[{:#06x}].entry[{:#04x}].setting",
                    o.index, e.subindex
                ),
                Invalid::Value("a setting (startup parameter) must be writable".into()),
            );
        }
    }
}

/// `[esm]`: a zero SAFEOP → OP timeout would refuse every DC start; error code 0 means "no
/// error" in 603Fh (CiA402), so it cannot be raised.
fn esm(p: &Profile, f: &mut Faults) {
    if p.esm.safeop_op_timeout_ms == 0 {
        f.add(
            "esm.safeop_op_timeout_ms",
            Invalid::Value("must be at least 1".into()),
        );
    }
    if p.esm.link_loss_error.map(|r| r.error_code) == Some(0) {
        f.add(
            "esm.link_loss_error",
            Invalid::Value("0 is \"no error\" (603Fh)".into()),
        );
    }
    if let Some(r) = p.cia402.enable_without_mode_error {
        let has_mode = p
            .objects
            .iter()
            .flat_map(|o| &o.entries)
            .any(|e| e.role == Some(Role::ModesOfOperation));
        if r.error_code == 0 || !has_mode {
            f.add(
                "cia402.enable_without_mode_error",
                Invalid::Value(
                    "needs an error code other than 0 and a modes_of_operation entry".into(),
                ),
            );
        }
    }
    if p.esm.pdi_error.map(|r| r.error_code) == Some(0) {
        f.add(
            "esm.pdi_error",
            Invalid::Value("0 is \"no error\" (603Fh)".into()),
        );
    }
    if let Some(entry) = p.cia402.csp_extrapolation {
        f.take(integer_parameter(p, entry, "cia402.csp_extrapolation"));
    }
    if let Some(entry) = p.cia402.software_limits_off {
        f.take(integer_parameter(p, entry, "cia402.software_limits_off"));
    }
    // One fault for the list: its key names no single entry.
    if let Some(fault) = p
        .cia402
        .torque_reached
        .into_iter()
        .flatten()
        .find_map(|entry| integer_parameter(p, entry, "cia402.torque_reached").err())
    {
        f.0.push(fault);
    }
    let shows_torque_reached = p
        .cia402
        .mode_statusword
        .iter()
        .any(|m| m.bits.contains(&crate::model::ModeBit::TorqueReached));
    if shows_torque_reached && p.cia402.torque_reached.is_none() {
        f.add(
            "cia402.mode_statusword",
            Invalid::Value(
                "`torque_reached` is shown but [cia402] torque_reached names no parameters".into(),
            ),
        );
    }
    if let Some(t) = &p.cia402.touch_probe_inputs {
        if let Some(fault) = t.entries.iter().find_map(|&entry| {
            integer_parameter(p, entry, "cia402.touch_probe_inputs.entries").err()
        }) {
            f.0.push(fault);
        }
    }
    if let Some(l) = &p.esm.lost_outputs {
        f.take(integer_parameter(
            p,
            l.limit_parameter,
            "esm.lost_outputs.limit_parameter",
        ));
        let (index, subindex) = l.while_entry;
        match p.entry(index, subindex) {
            None => f.add(
                "esm.lost_outputs.while_entry",
                Invalid::PdoEntryMissing { index, subindex },
            ),
            Some(e) => {
                if e.storage != Storage::Ram || l.raw_values(e.data_type).is_none() {
                    f.add(
                        "esm.lost_outputs.while_values",
                        Invalid::Value(format!(
                            "{index:#06x}:{subindex} must be an integer entry of at most 32 bits in RAM holding every value"
                        )),
                    );
                }
            }
        }
        if l.error.error_code == 0 {
            f.add(
                "esm.lost_outputs.error",
                Invalid::Value("0 is \"no error\" (603Fh)".into()),
            );
        }
    }
    if p.esm.op_exit_while_enabled_error.map(|r| r.error_code) == Some(0) {
        f.add(
            "esm.op_exit_while_enabled_error",
            Invalid::Value("0 is \"no error\" (603Fh)".into()),
        );
    }
}

/// `[motor_faults]`: error code 0 is "no error" in 603Fh (CiA402) and in an EMCY it means "error
/// reset", so a fault mapped to it would be invisible to the master.
fn motor_faults(p: &Profile, f: &mut Faults) {
    if p.kind == ProfileKind::Device {
        return;
    }
    for (name, _) in MOTOR_FAULT_NAMES
        .iter()
        .zip(p.motor_faults)
        .filter(|(_, code)| code.error_code == 0)
    {
        f.add(
            &format!("motor_faults.{name}"),
            Invalid::Value(
                "0x0000 is \"no error\" (603Fh) / \"error reset\" (EMCY); a fault needs a non-zero \
                 error code"
                    .into(),
            ),
        );
    }
}
