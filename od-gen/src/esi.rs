//! The ESI XML (EtherCATInfo, element order as in the XSD `DeviceType` sequence; see
//! `reference/esi-sii.md` §1.4).
//!
//! UTF-8; numbers that the XSD types as HexDec are written `#x…`. Device children are limited to
//! what the `ethercat-esi` 0.2.0 crate accepts (no Comment, Su, ESC or VendorSpecific). A PDO
//! gets an `Sm` attribute only when it is in the default assignment (that is what `@Sm` means);
//! ethercat-esi 0.2.0 cannot parse a PDO without `Sm`, so profiles whose PDOs are all assigned
//! by default are the ones it can read.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use crate::model::{protocol, DataType, Entry, Object, ObjectCode, Pdo, Profile};

/// Escapes text and attribute values.
pub fn escape(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            '\'' => o.push_str("&apos;"),
            _ => o.push(c),
        }
    }
    o
}

/// HexDec value `#x…` with at least `digits` hex digits.
fn hx(v: u32, digits: usize) -> String {
    format!("#x{v:0digits$X}")
}

/// hexBinary (upper case).
pub fn hex_binary(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02X}")).collect()
}

/// A tiny indenting XML writer.
struct Xml {
    out: String,
    depth: usize,
}

impl Xml {
    fn line(&mut self, s: &str) {
        for _ in 0..self.depth {
            self.out.push_str("  ");
        }
        self.out.push_str(s);
        self.out.push('\n');
    }
    fn open(&mut self, tag: &str, attrs: &[(&str, String)]) {
        let a = attrs_str(attrs);
        self.line(&format!("<{tag}{a}>"));
        self.depth += 1;
    }
    fn close(&mut self, tag: &str) {
        self.depth = self.depth.saturating_sub(1);
        self.line(&format!("</{tag}>"));
    }
    fn text(&mut self, tag: &str, attrs: &[(&str, String)], text: &str) {
        let a = attrs_str(attrs);
        self.line(&format!("<{tag}{a}>{}</{tag}>", escape(text)));
    }
    fn empty(&mut self, tag: &str, attrs: &[(&str, String)]) {
        let a = attrs_str(attrs);
        self.line(&format!("<{tag}{a}/>"));
    }
}

fn attrs_str(attrs: &[(&str, String)]) -> String {
    let mut s = String::new();
    for (k, v) in attrs {
        let _ = write!(s, " {k}=\"{}\"", escape(v));
    }
    s
}

fn b(x: bool) -> String {
    if x { "true" } else { "false" }.to_string()
}

/// The ESI type name of an entry.
fn type_name(e: &Entry) -> String {
    e.data_type.esi_name(e.bit_len)
}

/// The DataType name of a RECORD/ARRAY object.
fn dt_name(o: &Object) -> String {
    format!("DT{:04X}", o.index)
}

/// Bit offsets of the entries of a RECORD/ARRAY (sub 0 at 0, sub 1 at 16, then packed; entries
/// of 8 bits or more start on a byte boundary) and the total bit size.
fn layout(o: &Object) -> (Vec<u32>, u32) {
    let mut offs = Vec::new();
    let mut at = 0u32;
    for (i, e) in o.entries.iter().enumerate() {
        if i == 1 {
            at = 16;
        }
        if e.bit_len >= 8 {
            at = at.div_ceil(8) * 8;
        }
        offs.push(at);
        at += u32::from(e.bit_len);
    }
    (offs, at.div_ceil(8) * 8)
}

/// Every data type the dictionary needs, by name: base types (with their bit size) and the
/// DT records/arrays (written separately).
fn base_types(p: &Profile) -> BTreeMap<String, u16> {
    let mut m = BTreeMap::new();
    for o in &p.objects {
        for e in &o.entries {
            m.insert(type_name(e), e.bit_len);
        }
    }
    m
}

/// `Flags` in the XSD order `Access, Category, PdoMapping, ..., Backup, Setting`
/// (esi-sii.md §1.4). Backup: the parameter storage stores the entry (`backup`,
/// [`Profile::is_backup`]); Setting: a startup parameter (profile `setting = true`).
fn flags(x: &mut Xml, e: &Entry, backup: bool) {
    x.open("Flags", &[]);
    let (access, restriction) = e.access.esi();
    match restriction {
        Some(r) => x.text("Access", &[("WriteRestrictions", r.to_string())], access),
        None => x.text("Access", &[], access),
    }
    if let Some(m) = e.pdo.esi() {
        x.text("PdoMapping", &[], m);
    }
    if backup {
        x.text("Backup", &[], "1");
    }
    if e.setting {
        x.text("Setting", &[], "1");
    }
    x.close("Flags");
}

fn info_values(x: &mut Xml, e: &Entry) {
    if e.data_type.is_string() {
        if !e.default.is_empty() {
            match e.data_type {
                DataType::VisibleString => {
                    x.text("DefaultString", &[], &String::from_utf8_lossy(&e.default))
                }
                _ => x.text("DefaultData", &[], &hex_binary(&e.default)),
            }
        }
        return;
    }
    if !e.min.is_empty() {
        x.text("MinData", &[], &hex_binary(&e.min));
    }
    if !e.max.is_empty() {
        x.text("MaxData", &[], &hex_binary(&e.max));
    }
    x.text("DefaultData", &[], &hex_binary(&e.initial_bytes()));
}

fn data_types(x: &mut Xml, p: &Profile) {
    x.open("DataTypes", &[]);
    for (name, bits) in base_types(p) {
        x.open("DataType", &[]);
        x.text("Name", &[], &name);
        x.text("BitSize", &[], &bits.to_string());
        x.close("DataType");
    }
    for o in p.objects.iter().filter(|o| o.code != ObjectCode::Var) {
        let (offs, total) = layout(o);
        let name = dt_name(o);
        let sub0 = o.entries.first();
        if o.code == ObjectCode::Array {
            // ETG.2000 array convention: DTxxxxARR (the elements) + DTxxxx (sub 0 + "Elements").
            let elems = &o.entries[1.min(o.entries.len())..];
            let elem_bits = elems.first().map_or(0, |e| u32::from(e.bit_len));
            let n = u32::try_from(elems.len()).unwrap_or(0);
            x.open("DataType", &[]);
            x.text("Name", &[], &format!("{name}ARR"));
            x.text(
                "BaseType",
                &[],
                &elems.first().map(type_name).unwrap_or_default(),
            );
            x.text("BitSize", &[], &(n * elem_bits).to_string());
            x.open("ArrayInfo", &[]);
            x.text("LBound", &[], "1");
            x.text("Elements", &[], &n.to_string());
            x.close("ArrayInfo");
            x.close("DataType");
            x.open("DataType", &[]);
            x.text("Name", &[], &name);
            x.text("BitSize", &[], &(16 + n * elem_bits).to_string());
            if let Some(s0) = sub0 {
                sub_item(
                    x,
                    Some(0),
                    &s0.name,
                    "USINT",
                    8,
                    0,
                    (s0, p.is_backup(o, s0)),
                );
            }
            if let Some(e1) = elems.first() {
                sub_item(
                    x,
                    None,
                    "Elements",
                    &format!("{name}ARR"),
                    n * elem_bits,
                    16,
                    (e1, p.is_backup(o, e1)),
                );
            }
            x.close("DataType");
        } else {
            x.open("DataType", &[]);
            x.text("Name", &[], &name);
            x.text("BitSize", &[], &total.to_string());
            for (e, off) in o.entries.iter().zip(offs) {
                sub_item(
                    x,
                    Some(e.subindex),
                    &e.name,
                    &type_name(e),
                    u32::from(e.bit_len),
                    off,
                    (e, p.is_backup(o, e)),
                );
            }
            x.close("DataType");
        }
    }
    x.close("DataTypes");
}

fn sub_item(
    x: &mut Xml,
    sub: Option<u8>,
    name: &str,
    ty: &str,
    bits: u32,
    off: u32,
    flags_of: (&Entry, bool),
) {
    x.open("SubItem", &[]);
    if let Some(s) = sub {
        x.text("SubIdx", &[], &s.to_string());
    }
    x.text("Name", &[], name);
    x.text("Type", &[], ty);
    x.text("BitSize", &[], &bits.to_string());
    x.text("BitOffs", &[], &off.to_string());
    flags(x, flags_of.0, flags_of.1);
    x.close("SubItem");
}

fn objects(x: &mut Xml, p: &Profile) {
    x.open("Objects", &[]);
    for o in &p.objects {
        x.open("Object", &[]);
        x.text("Index", &[], &hx(u32::from(o.index), 4));
        x.text("Name", &[], &o.name);
        match (o.code, o.entries.first()) {
            (ObjectCode::Var, Some(e)) => {
                x.text("Type", &[], &type_name(e));
                x.text("BitSize", &[], &e.bit_len.to_string());
                x.open("Info", &[]);
                info_values(x, e);
                x.close("Info");
                flags(x, e, p.is_backup(o, e));
            }
            _ => {
                let (_, total) = layout(o);
                let bits = if o.code == ObjectCode::Array {
                    let elems = o.entries.len().saturating_sub(1) as u32;
                    16 + elems * o.entries.get(1).map_or(0, |e| u32::from(e.bit_len))
                } else {
                    total
                };
                x.text("Type", &[], &dt_name(o));
                x.text("BitSize", &[], &bits.to_string());
                x.open("Info", &[]);
                for e in &o.entries {
                    x.open("SubItem", &[]);
                    x.text("Name", &[], &e.name);
                    x.open("Info", &[]);
                    info_values(x, e);
                    x.close("Info");
                    x.close("SubItem");
                }
                x.close("Info");
            }
        }
        x.close("Object");
    }
    x.close("Objects");
}

fn pdo(x: &mut Xml, tag: &str, pdo: &Pdo) {
    let mut attrs = vec![("Fixed", b(pdo.fixed)), ("Mandatory", b(pdo.mandatory))];
    if pdo.assigned {
        attrs.push(("Sm", pdo.sm.to_string()));
    }
    x.open(tag, &attrs);
    x.text("Index", &[], &hx(u32::from(pdo.index), 4));
    x.text("Name", &[], &pdo.name);
    for e in &pdo.entries {
        x.open("Entry", &[]);
        x.text(
            "Index",
            &[],
            &hx(u32::from(e.index), if e.index == 0 { 1 } else { 4 }),
        );
        if e.index != 0 {
            x.text("SubIndex", &[], &e.subindex.to_string());
        }
        x.text("BitLen", &[], &e.bits.to_string());
        if let Some(dt) = e.data_type {
            x.text("Name", &[], &e.name);
            x.text("DataType", &[], &dt.esi_name(e.bits));
        }
        x.close("Entry");
    }
    x.close(tag);
}

/// ESI `Info/StateMachine/Timeout/PreopTimeout`: the ETG default, ms (ethercat-slave.md §2.4).
const PREOP_TIMEOUT_MS: u32 = 2000;
/// ESI `BackToInitTimeout`: the ETG default, ms.
const BACK_TO_INIT_TIMEOUT_MS: u32 = 5000;
/// ESI `BackToSafeopTimeout`: the ETG default, ms.
const BACK_TO_SAFEOP_TIMEOUT_MS: u32 = 200;

/// The ESI document.
pub fn xml(p: &Profile) -> String {
    let mut x = Xml {
        out: String::new(),
        depth: 0,
    };
    x.line("<?xml version=\"1.0\" encoding=\"UTF-8\"?>");
    x.line(&format!(
        "<!-- Generated by od-gen from profile `{}` ({}). Do not edit: change the profile. -->",
        escape(&p.name).replace("--", "- -"),
        escape(&p.source).replace("--", "- -")
    ));
    x.open(
        "EtherCATInfo",
        &[
            (
                "xmlns:xsi",
                "http://www.w3.org/2001/XMLSchema-instance".into(),
            ),
            ("xsi:noNamespaceSchemaLocation", "EtherCATInfo.xsd".into()),
            ("Version", "1.6".into()),
        ],
    );
    x.open("Vendor", &[]);
    x.text("Id", &[], &hx(p.vendor.id, 8));
    x.text("Name", &[], &p.vendor.name);
    x.close("Vendor");
    x.open("Descriptions", &[]);
    x.open("Groups", &[]);
    x.open("Group", &[]);
    x.text("Type", &[], &p.device.group_type);
    x.text("Name", &[], &p.device.group_name);
    x.close("Group");
    x.close("Groups");
    x.open("Devices", &[]);
    x.open("Device", &[("Physics", p.device.physics.clone())]);
    x.text(
        "Type",
        &[
            ("ProductCode", hx(p.device.product_code, 8)),
            ("RevisionNo", hx(p.device.revision, 8)),
        ],
        &p.device.order_number,
    );
    x.text("Name", &[("LcId", "1033".into())], &p.device.name);
    // Info/StateMachine/Timeout (XSD: all four timeouts, ms, in this order): SafeopOpTimeout
    // from `[esm]`, the others the ETG defaults (ethercat-slave.md §2.4).
    x.open("Info", &[]);
    x.open("StateMachine", &[]);
    x.open("Timeout", &[]);
    x.text("PreopTimeout", &[], &PREOP_TIMEOUT_MS.to_string());
    x.text(
        "SafeopOpTimeout",
        &[],
        &p.esm.safeop_op_timeout_ms.to_string(),
    );
    x.text(
        "BackToInitTimeout",
        &[],
        &BACK_TO_INIT_TIMEOUT_MS.to_string(),
    );
    x.text(
        "BackToSafeopTimeout",
        &[],
        &BACK_TO_SAFEOP_TIMEOUT_MS.to_string(),
    );
    x.close("Timeout");
    x.close("StateMachine");
    x.close("Info");
    x.text("GroupType", &[], &p.device.group_type);

    x.open("Profile", &[]);
    if p.device.profile_no != 0 {
        x.text("ProfileNo", &[], &p.device.profile_no.to_string());
    }
    x.open("Dictionary", &[]);
    data_types(&mut x, p);
    objects(&mut x, p);
    x.close("Dictionary");
    x.close("Profile");

    for f in ["Outputs", "Inputs", "MBoxState"] {
        x.text("Fmmu", &[], f);
    }
    for (sm, kind) in [
        (p.sm.mailbox_out, "MBoxOut"),
        (p.sm.mailbox_in, "MBoxIn"),
        (p.sm.outputs, "Outputs"),
        (p.sm.inputs, "Inputs"),
    ] {
        x.text(
            "Sm",
            &[
                ("DefaultSize", sm.length.to_string()),
                ("StartAddress", hx(u32::from(sm.start), 4)),
                ("ControlByte", hx(u32::from(sm.control), 2)),
                ("Enable", u8::from(sm.length > 0).to_string()),
            ],
            kind,
        );
    }
    for r in &p.rx_pdos {
        pdo(&mut x, "RxPdo", r);
    }
    for t in &p.tx_pdos {
        pdo(&mut x, "TxPdo", t);
    }

    x.open(
        "Mailbox",
        &[("DataLinkLayer", b(p.mailbox.data_link_layer))],
    );
    let has = |bit| p.mailbox.protocols & bit != 0;
    if has(protocol::AOE) {
        x.empty("AoE", &[]);
    }
    if has(protocol::EOE) {
        x.empty("EoE", &[]);
    }
    if has(protocol::COE) {
        let c = p.mailbox.coe;
        x.empty(
            "CoE",
            &[
                ("SdoInfo", b(c.sdo_info)),
                ("PdoAssign", b(c.pdo_assign)),
                ("PdoConfig", b(c.pdo_config)),
                ("PdoUpload", b(c.upload_at_startup)),
                ("CompleteAccess", b(c.complete_access)),
            ],
        );
    }
    if has(protocol::FOE) {
        x.empty("FoE", &[]);
    }
    if has(protocol::SOE) {
        x.empty("SoE", &[]);
    }
    if has(protocol::VOE) {
        x.empty("VoE", &[]);
    }
    x.close("Mailbox");

    if !p.dc_op_modes.is_empty() {
        x.open("Dc", &[]);
        for m in &p.dc_op_modes {
            x.open("OpMode", &[]);
            x.text("Name", &[], &m.name);
            if !m.description.is_empty() {
                x.text("Desc", &[], &m.description);
            }
            x.text("AssignActivate", &[], &hx(u32::from(m.assign_activate), 4));
            let act = m.assign_activate >> 8;
            if act & 0x02 != 0 {
                x.text(
                    "CycleTimeSync0",
                    &[("Factor", m.sync0_factor.to_string())],
                    &m.sync0_cycle_ns.to_string(),
                );
                x.text("ShiftTimeSync0", &[], &m.sync0_shift_ns.to_string());
            }
            if act & 0x04 != 0 {
                x.text(
                    "CycleTimeSync1",
                    &[("Factor", m.sync1_factor.to_string())],
                    &m.sync1_cycle_ns.to_string(),
                );
                x.text("ShiftTimeSync1", &[], &m.sync1_shift_ns.to_string());
            }
            x.close("OpMode");
        }
        x.close("Dc");
    }

    x.open("Eeprom", &[]);
    x.text("ByteSize", &[], &p.eeprom.byte_size.to_string());
    x.text("ConfigData", &[], &hex_binary(&crate::sii::config_data(p)));
    if let Some(bs) = crate::sii::bootstrap(p) {
        x.text("BootStrap", &[], &hex_binary(&bs));
    }
    x.close("Eeprom");

    x.close("Device");
    x.close("Devices");
    x.close("Descriptions");
    x.close("EtherCATInfo");
    x.out
}
