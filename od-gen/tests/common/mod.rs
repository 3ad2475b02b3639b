//! Shared by the integration tests over every built-in profile (`all_profiles.rs`, `doc.rs`):
//! the ESI structural lints of `esi.rs` generalised from the standard profile to any profile,
//! an SII decoder written from `reference/esi-sii.md` §2 (it shares no code with `od_gen::sii`,
//! not even the CRC), and an RFC 4180 CSV reader.

#![allow(dead_code)]

use std::collections::{BTreeMap, BTreeSet};

use od_gen::model::{ObjectCode, Profile};
use roxmltree::{Document, Node};

/// Every built-in profile.
pub fn profiles() -> Vec<Profile> {
    let names = od_gen::builtin_names();
    assert!(!names.is_empty(), "no built-in profiles");
    names
        .iter()
        .map(|n| od_gen::builtin(n).unwrap_or_else(|e| panic!("{n}: {e}")))
        .collect()
}

// --- XML helpers ---------------------------------------------------------------------------

/// A HexDec value (`#x…` or decimal).
pub fn hexdec(s: &str) -> u32 {
    match s.strip_prefix("#x") {
        Some(h) => u32::from_str_radix(h, 16).unwrap_or_else(|_| panic!("bad HexDec {s}")),
        None => s.parse().unwrap_or_else(|_| panic!("bad HexDec {s}")),
    }
}

pub fn child<'a>(n: Node<'a, 'a>, tag: &str) -> Node<'a, 'a> {
    n.children()
        .find(|c| c.has_tag_name(tag))
        .unwrap_or_else(|| panic!("<{tag}> missing in <{}>", n.tag_name().name()))
}

pub fn opt_child<'a>(n: Node<'a, 'a>, tag: &str) -> Option<Node<'a, 'a>> {
    n.children().find(|c| c.has_tag_name(tag))
}

pub fn text<'a>(n: Node<'a, 'a>, tag: &str) -> &'a str {
    child(n, tag).text().unwrap_or("")
}

pub fn children<'a>(n: Node<'a, 'a>, tag: &str) -> Vec<Node<'a, 'a>> {
    n.children().filter(|c| c.has_tag_name(tag)).collect()
}

pub fn elements<'a>(n: Node<'a, 'a>) -> Vec<Node<'a, 'a>> {
    n.children().filter(Node::is_element).collect()
}

/// hexBinary → bytes.
pub fn unhex(s: &str) -> Vec<u8> {
    assert!(s.len() % 2 == 0, "odd hexBinary {s}");
    (0..s.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&s[i..i + 2], 16).unwrap_or_else(|_| panic!("hex {s}")))
        .collect()
}

/// The `<Device>` element of an ESI document.
pub fn device<'a>(doc: &'a Document<'a>) -> Node<'a, 'a> {
    child(
        child(child(doc.root_element(), "Descriptions"), "Devices"),
        "Device",
    )
}

/// The CoE data type code of an ESI base type name (ETG.1000.6 Table 64 as quoted in
/// esi-sii.md §2.3), written independently of `od_gen::model::DataType`.
pub fn coe_code(esi_type: &str) -> u8 {
    match esi_type {
        "BOOL" => 0x01,
        "SINT" => 0x02,
        "INT" => 0x03,
        "DINT" => 0x04,
        "USINT" => 0x05,
        "UINT" => 0x06,
        "UDINT" => 0x07,
        "REAL" => 0x08,
        "INT24" => 0x10,
        "LREAL" => 0x11,
        "LINT" => 0x15,
        "UINT24" => 0x16,
        "ULINT" => 0x1B,
        t if t.starts_with("STRING(") => 0x09,
        t if t.starts_with("OCTET_STRING") => 0x0A,
        t if t.starts_with("UNICODE_STRING") => 0x0B,
        t => {
            let n: u8 = t
                .strip_prefix("BIT")
                .and_then(|n| n.parse().ok())
                .unwrap_or_else(|| panic!("unknown ESI type {t}"));
            0x30 + n - 1
        }
    }
}

// --- ESI lints -----------------------------------------------------------------------------

/// XSD `DeviceType` sequence (esi-sii.md §1.4), restricted to what ethercat-esi 0.2.0 accepts.
pub const DEVICE_ORDER: [&str; 13] = [
    "Type",
    "Name",
    "URL",
    "Info",
    "GroupType",
    "Profile",
    "Fmmu",
    "Sm",
    "RxPdo",
    "TxPdo",
    "Mailbox",
    "Dc",
    "Eeprom",
];

/// What the dictionary says about `index:sub`: (ESI type, bit size, Flags node).
fn dictionary_entry<'a>(
    dts: &BTreeMap<&'a str, Node<'a, 'a>>,
    objects: &BTreeMap<u16, Node<'a, 'a>>,
    index: u16,
    sub: u8,
) -> Option<(String, u32, Node<'a, 'a>)> {
    let o = objects.get(&index)?;
    let ty = text(*o, "Type");
    let dt = match dts.get(ty) {
        Some(dt) if opt_child(*dt, "SubItem").is_some() => *dt,
        _ => {
            // A VAR: only subindex 0.
            return (sub == 0).then(|| {
                (
                    ty.to_string(),
                    text(*o, "BitSize").parse().unwrap(),
                    child(*o, "Flags"),
                )
            });
        }
    };
    let items = children(dt, "SubItem");
    if let Some(si) = items
        .iter()
        .find(|si| opt_child(**si, "SubIdx").and_then(|s| s.text()) == Some(&sub.to_string()))
    {
        return Some((
            text(*si, "Type").to_string(),
            text(*si, "BitSize").parse().unwrap(),
            child(*si, "Flags"),
        ));
    }
    // An ARRAY: "Elements" of DTxxxxARR, subindex 1..=n.
    let el = items.iter().find(|si| text(**si, "Name") == "Elements")?;
    let arr = dts.get(text(*el, "Type"))?;
    let n: u32 = text(child(*arr, "ArrayInfo"), "Elements").parse().unwrap();
    let bits: u32 = text(*arr, "BitSize").parse().unwrap();
    (sub >= 1 && u32::from(sub) <= n).then(|| {
        (
            text(*arr, "BaseType").to_string(),
            bits / n,
            child(*el, "Flags"),
        )
    })
}

/// The project's structural ESI lints (esi-sii.md §1.3–§1.4 and §5 item 2), for any profile.
/// `img` is the profile's SII image (ConfigData, ByteSize and BootStrap are compared with it).
pub fn esi_lints(p: &Profile, xml: &str, img: &[u8]) {
    let name = &p.name;
    assert!(
        xml.starts_with("<?xml version=\"1.0\" encoding=\"UTF-8\"?>"),
        "{name}: XML declaration"
    );
    let doc = Document::parse(xml).unwrap_or_else(|e| panic!("{name}: not well-formed: {e}"));
    let root = doc.root_element();
    assert_eq!(root.tag_name().name(), "EtherCATInfo", "{name}");
    assert_eq!(
        elements(root)
            .iter()
            .map(|n| n.tag_name().name())
            .collect::<Vec<_>>(),
        ["Vendor", "Descriptions"],
        "{name}"
    );
    let vendor = child(root, "Vendor");
    assert_eq!(hexdec(text(vendor, "Id")), p.vendor.id, "{name}: vendor id");
    assert_eq!(text(vendor, "Name"), p.vendor.name, "{name}: vendor name");

    let desc = child(root, "Descriptions");
    let groups = children(child(desc, "Groups"), "Group");
    let devices = children(child(desc, "Devices"), "Device");
    assert_eq!(
        (groups.len(), devices.len()),
        (1, 1),
        "{name}: one group, one device"
    );
    let (group, device) = (groups[0], devices[0]);
    assert_eq!(device.attribute("Physics"), Some(p.device.physics.as_str()));

    // Element order as in the XSD sequence, no children ethercat-esi rejects, required present.
    let tags: Vec<&str> = elements(device)
        .iter()
        .map(|n| n.tag_name().name())
        .collect();
    let pos: Vec<usize> = tags
        .iter()
        .map(|t| {
            DEVICE_ORDER
                .iter()
                .position(|d| d == t)
                .unwrap_or_else(|| panic!("{name}: unexpected <{t}> in <Device>"))
        })
        .collect();
    assert!(
        pos.windows(2).all(|w| w[0] <= w[1]),
        "{name}: Device children out of order: {tags:?}"
    );
    let mut required = vec![
        "Type",
        "Name",
        "GroupType",
        "Profile",
        "Fmmu",
        "Sm",
        "Mailbox",
        "Eeprom",
    ];
    if !p.rx_pdos.is_empty() {
        required.push("RxPdo");
    }
    if !p.tx_pdos.is_empty() {
        required.push("TxPdo");
    }
    if !p.dc_op_modes.is_empty() {
        required.push("Dc");
    }
    for t in required {
        assert!(tags.contains(&t), "{name}: <{t}> missing");
    }
    assert_eq!(text(device, "GroupType"), text(group, "Type"), "{name}");
    assert_eq!(text(group, "Type"), p.device.group_type, "{name}");
    assert_eq!(text(group, "Name"), p.device.group_name, "{name}");
    let ty = child(device, "Type");
    assert_eq!(ty.text(), Some(p.device.order_number.as_str()), "{name}");
    assert_eq!(
        hexdec(ty.attribute("ProductCode").unwrap()),
        p.device.product_code
    );
    assert_eq!(
        hexdec(ty.attribute("RevisionNo").unwrap()),
        p.device.revision
    );
    assert_eq!(text(device, "Name"), p.device.name, "{name}");

    // HexDec values are #x… or decimal, never 0x….
    for n in doc.descendants().filter(Node::is_element) {
        if matches!(
            n.tag_name().name(),
            "Id" | "Index" | "SubIndex" | "AssignActivate"
        ) {
            let t = n.text().unwrap_or("");
            assert!(!t.starts_with("0x"), "{name}: <{}>{t}", n.tag_name().name());
        }
        for a in n.attributes() {
            if matches!(
                a.name(),
                "ProductCode" | "RevisionNo" | "StartAddress" | "ControlByte"
            ) {
                assert!(!a.value().starts_with("0x"), "{name}: @{}", a.name());
            }
        }
    }

    // Info/StateMachine/Timeout: SafeopOpTimeout from [esm].
    let timeout = child(child(child(device, "Info"), "StateMachine"), "Timeout");
    assert_eq!(
        text(timeout, "SafeopOpTimeout"),
        p.esm.safeop_op_timeout_ms.to_string(),
        "{name}"
    );

    // Fmmu and Sm vocabularies; Sm attributes equal the profile's SMs.
    let fmmus: Vec<&str> = children(device, "Fmmu")
        .iter()
        .map(|n| n.text().unwrap())
        .collect();
    assert_eq!(fmmus, ["Outputs", "Inputs", "MBoxState"], "{name}");
    let sms = children(device, "Sm");
    assert_eq!(
        sms.iter().map(|n| n.text().unwrap()).collect::<Vec<_>>(),
        ["MBoxOut", "MBoxIn", "Outputs", "Inputs"],
        "{name}"
    );
    for (n, sm) in sms
        .iter()
        .zip([p.sm.mailbox_out, p.sm.mailbox_in, p.sm.outputs, p.sm.inputs])
    {
        assert_eq!(
            hexdec(n.attribute("StartAddress").unwrap()),
            u32::from(sm.start)
        );
        assert_eq!(
            hexdec(n.attribute("ControlByte").unwrap()),
            u32::from(sm.control)
        );
        assert_eq!(
            hexdec(n.attribute("DefaultSize").unwrap()),
            u32::from(sm.length),
            "{name}: Sm {}",
            n.text().unwrap()
        );
    }
    assert_eq!(
        u32::from(p.sm.outputs.length) * 8,
        p.outputs_bits(),
        "{name}"
    );
    assert_eq!(u32::from(p.sm.inputs.length) * 8, p.inputs_bits(), "{name}");
    let sm2_control = hexdec(sms[2].attribute("ControlByte").unwrap());
    assert_ne!(sm2_control & 0x40, 0, "{name}: SM2 watchdog trigger");

    // Dictionary: DataTypes unique, referenced ones declared, DT shapes conventional.
    let profile = child(device, "Profile");
    if p.device.profile_no != 0 {
        assert_eq!(text(profile, "ProfileNo"), p.device.profile_no.to_string());
    }
    let dict = child(profile, "Dictionary");
    let dt_nodes = children(child(dict, "DataTypes"), "DataType");
    let mut dts: BTreeMap<&str, Node> = BTreeMap::new();
    let mut declared: BTreeMap<&str, u32> = BTreeMap::new();
    for dt in &dt_nodes {
        let n = text(*dt, "Name");
        assert!(
            dts.insert(n, *dt).is_none(),
            "{name}: duplicate DataType {n}"
        );
        declared.insert(n, text(*dt, "BitSize").parse().unwrap());
    }
    let mut referenced = BTreeSet::new();
    for dt in &dt_nodes {
        if let Some(b) = opt_child(*dt, "BaseType") {
            referenced.insert(b.text().unwrap());
        }
        for (i, si) in children(*dt, "SubItem").iter().enumerate() {
            referenced.insert(text(*si, "Type"));
            if i == 0 {
                assert_eq!(
                    (text(*si, "SubIdx"), text(*si, "Type"), text(*si, "BitOffs")),
                    ("0", "USINT", "0"),
                    "{name}: {} subindex 0",
                    text(*dt, "Name")
                );
            }
            if i == 1 {
                assert_eq!(
                    text(*si, "BitOffs"),
                    "16",
                    "{name}: {} subindex 1 starts at bit 16",
                    text(*dt, "Name")
                );
            }
        }
    }
    let object_nodes = children(child(dict, "Objects"), "Object");
    let mut objects: BTreeMap<u16, Node> = BTreeMap::new();
    for o in &object_nodes {
        referenced.insert(text(*o, "Type"));
        let idx = hexdec(text(*o, "Index")) as u16;
        assert!(
            objects.insert(idx, *o).is_none(),
            "{name}: duplicate object {idx:#06x}"
        );
        let bits: u32 = text(*o, "BitSize").parse().unwrap();
        assert_eq!(
            declared.get(text(*o, "Type")),
            Some(&bits),
            "{name}: object {idx:#06x} BitSize equals its type's"
        );
    }
    for r in &referenced {
        assert!(
            declared.contains_key(r),
            "{name}: DataType {r} referenced but not declared"
        );
    }
    assert_eq!(
        objects.keys().copied().collect::<Vec<_>>(),
        p.objects.iter().map(|o| o.index).collect::<Vec<_>>(),
        "{name}: ESI objects = profile objects"
    );

    for o in &p.objects {
        let node = objects[&o.index];
        let dt_name = format!("DT{:04X}", o.index);
        match o.code {
            ObjectCode::Var => {
                let e = &o.entries[0];
                // Flags in the XSD order; Backup and Setting follow the model.
                let flags: Vec<String> = elements(child(node, "Flags"))
                    .iter()
                    .map(|n| n.tag_name().name().to_string())
                    .collect();
                let mut want = vec!["Access".to_string()];
                if e.pdo != od_gen::model::PdoMapping::No {
                    want.push("PdoMapping".into());
                }
                if p.is_backup(o, e) {
                    want.push("Backup".into());
                }
                if e.setting {
                    want.push("Setting".into());
                }
                assert_eq!(flags, want, "{name}: {:#06x} Flags", o.index);
                // DefaultData has the object's size.
                if let Some(d) = opt_child(child(node, "Info"), "DefaultData") {
                    if !e.data_type.is_string() {
                        assert_eq!(
                            unhex(d.text().unwrap_or("")).len(),
                            e.byte_len(),
                            "{name}: {:#06x} DefaultData length",
                            o.index
                        );
                    }
                }
            }
            ObjectCode::Record | ObjectCode::Array => {
                assert_eq!(text(node, "Type"), dt_name, "{name}: {:#06x}", o.index);
                if o.code == ObjectCode::Array {
                    assert!(
                        declared.contains_key(format!("{dt_name}ARR").as_str()),
                        "{name}: {dt_name}ARR"
                    );
                }
                let infos = children(child(node, "Info"), "SubItem");
                assert_eq!(infos.len(), o.entries.len(), "{name}: {:#06x}", o.index);
                for (si, e) in infos.iter().zip(&o.entries) {
                    assert_eq!(text(*si, "Name"), e.name, "{name}: {:#06x}", o.index);
                    if let Some(d) = opt_child(child(*si, "Info"), "DefaultData") {
                        if !e.data_type.is_string() {
                            assert_eq!(
                                unhex(d.text().unwrap_or("")).len(),
                                e.byte_len(),
                                "{name}: {:#06x}:{} DefaultData length",
                                o.index,
                                e.subindex
                            );
                        }
                    }
                }
            }
        }
    }

    // PDOs: Sm exactly on the default-assigned ones; every entry exists in the dictionary with
    // equal bit length, data type and PdoMapping direction.
    for (tag, mapping, model) in [("RxPdo", 'R', &p.rx_pdos), ("TxPdo", 'T', &p.tx_pdos)] {
        let nodes = children(device, tag);
        assert_eq!(nodes.len(), model.len(), "{name}: {tag} count");
        for (pdo, m) in nodes.iter().zip(model.iter()) {
            assert_eq!(hexdec(text(*pdo, "Index")), u32::from(m.index), "{name}");
            assert_eq!(text(*pdo, "Name"), m.name, "{name}");
            let sm = pdo.attribute("Sm");
            assert_eq!(
                sm,
                m.assigned.then(|| m.sm.to_string()).as_deref(),
                "{name}: {tag} {:#06x} @Sm only when assigned by default",
                m.index
            );
            assert_eq!(pdo.attribute("Fixed") == Some("true"), m.fixed, "{name}");
            assert_eq!(
                pdo.attribute("Mandatory") == Some("true"),
                m.mandatory,
                "{name}"
            );
            let entries = children(*pdo, "Entry");
            assert!(
                !entries.is_empty(),
                "{name}: {tag} {:#06x} has entries",
                m.index
            );
            assert_eq!(entries.len(), m.entries.len(), "{name}");
            for e in entries {
                let idx = hexdec(text(e, "Index")) as u16;
                let bitlen = text(e, "BitLen");
                if idx == 0 {
                    assert!(opt_child(e, "DataType").is_none(), "{name}: padding");
                    continue;
                }
                let sub = hexdec(text(e, "SubIndex")) as u8;
                let (ty, bits, flags) =
                    dictionary_entry(&dts, &objects, idx, sub).unwrap_or_else(|| {
                        panic!("{name}: PDO entry {idx:#06x}:{sub} not in the dictionary")
                    });
                assert_eq!(bitlen, bits.to_string(), "{name}: {idx:#06x}:{sub} BitLen");
                assert_eq!(text(e, "DataType"), ty, "{name}: {idx:#06x}:{sub} DataType");
                let pm = opt_child(flags, "PdoMapping")
                    .and_then(|n| n.text())
                    .unwrap_or("");
                assert!(
                    pm.contains(mapping),
                    "{name}: {idx:#06x}:{sub} PdoMapping {pm:?} lacks {mapping}"
                );
            }
        }
    }

    // 1C12h/1C13h defaults list exactly the PDOs with @Sm, in order.
    for (idx, tag) in [(0x1C12u16, "RxPdo"), (0x1C13, "TxPdo")] {
        let Some(o) = objects.get(&idx) else {
            assert!(
                children(device, tag).is_empty(),
                "{name}: {idx:#06x} missing"
            );
            continue;
        };
        let defaults: Vec<u32> = children(child(*o, "Info"), "SubItem")
            .iter()
            .map(|si| {
                let d = unhex(text(child(*si, "Info"), "DefaultData"));
                d.iter().rev().fold(0, |acc, b| acc << 8 | u32::from(*b))
            })
            .collect();
        let with_sm: Vec<u32> = children(device, tag)
            .iter()
            .filter(|n| n.attribute("Sm").is_some())
            .map(|n| hexdec(text(*n, "Index")))
            .collect();
        assert_eq!(defaults[0] as usize, with_sm.len(), "{name}: {idx:#06x}:00");
        assert_eq!(
            &defaults[1..=with_sm.len()],
            &with_sm[..],
            "{name}: {idx:#06x}"
        );
        assert!(defaults[with_sm.len() + 1..].iter().all(|&v| v == 0));
    }

    // PDO mapping and assignment objects: writable in PREOP only when the CoE details allow it.
    let coe = p.mailbox.coe;
    let mut writable_in_preop: Vec<(u16, bool)> =
        vec![(0x1C12, coe.pdo_assign), (0x1C13, coe.pdo_assign)];
    for m in p.rx_pdos.iter().chain(&p.tx_pdos) {
        writable_in_preop.push((m.index, coe.pdo_config && !m.fixed));
    }
    for (idx, rw) in writable_in_preop {
        let Some(dt) = dts.get(format!("DT{idx:04X}").as_str()) else {
            continue;
        };
        for si in children(*dt, "SubItem") {
            let a = child(child(si, "Flags"), "Access");
            let got = (a.text(), a.attribute("WriteRestrictions"));
            if rw {
                assert_eq!(got, (Some("rw"), Some("PreOP")), "{name}: {idx:#06x}");
            } else {
                assert_eq!(got.0, Some("ro"), "{name}: {idx:#06x}");
            }
        }
    }

    // Mailbox: protocols and CoE attributes follow the profile.
    let mbx = child(device, "Mailbox");
    assert_eq!(
        mbx.attribute("DataLinkLayer"),
        Some(if p.mailbox.data_link_layer {
            "true"
        } else {
            "false"
        }),
        "{name}"
    );
    let protocols: Vec<&str> = elements(mbx).iter().map(|n| n.tag_name().name()).collect();
    let want: Vec<&str> = od_gen::model::protocol::NAMES
        .iter()
        .filter(|(_, bit)| p.mailbox.protocols & bit != 0)
        .map(|(n, _)| *n)
        .collect();
    assert_eq!(protocols, want, "{name}: Mailbox protocols");
    if let Some(c) = opt_child(mbx, "CoE") {
        let b = |attr: &str| c.attribute(attr) == Some("true");
        assert_eq!(
            (
                b("SdoInfo"),
                b("PdoAssign"),
                b("PdoConfig"),
                b("PdoUpload"),
                b("CompleteAccess")
            ),
            (
                coe.sdo_info,
                coe.pdo_assign,
                coe.pdo_config,
                coe.upload_at_startup,
                coe.complete_access
            ),
            "{name}: CoE attributes"
        );
    }

    // Dc op modes.
    let modes: Vec<(String, u32)> = opt_child(device, "Dc")
        .map(|dc| {
            children(dc, "OpMode")
                .iter()
                .map(|m| {
                    let aa = text(*m, "AssignActivate");
                    assert!(aa.starts_with("#x"), "{name}: AssignActivate {aa}");
                    (text(*m, "Name").to_string(), hexdec(aa))
                })
                .collect()
        })
        .unwrap_or_default();
    let want: Vec<(String, u32)> = p
        .dc_op_modes
        .iter()
        .map(|m| (m.name.clone(), u32::from(m.assign_activate)))
        .collect();
    assert_eq!(modes, want, "{name}: Dc op modes");

    // Eeprom: ConfigData = SII bytes 0..13, ByteSize = SII size word, BootStrap = words 0x14..0x17.
    let eeprom = child(device, "Eeprom");
    assert_eq!(
        unhex(text(eeprom, "ConfigData")),
        img[..14].to_vec(),
        "{name}"
    );
    let size_word = u16::from_le_bytes([img[0x7C], img[0x7D]]);
    let byte_size: usize = text(eeprom, "ByteSize").parse().unwrap();
    assert_eq!(byte_size, (usize::from(size_word) + 1) * 128, "{name}");
    assert_eq!(byte_size, p.eeprom.byte_size, "{name}");
    match opt_child(eeprom, "BootStrap") {
        Some(bs) => assert_eq!(unhex(bs.text().unwrap()), img[0x28..0x30].to_vec()),
        None => assert!(
            p.sm.boot_out.is_none() && img[0x28..0x30].iter().all(|&b| b == 0),
            "{name}: no bootstrap mailbox"
        ),
    }
}

// --- SII decoder ---------------------------------------------------------------------------

/// CRC-8, polynomial 0x07, initial value 0xFF, MSB first, no reflection (esi-sii.md §2.1).
pub fn crc8(data: &[u8]) -> u8 {
    let mut crc: u8 = 0xFF;
    for &b in data {
        crc ^= b;
        for _ in 0..8 {
            crc = if crc & 0x80 != 0 {
                crc << 1 ^ 0x07
            } else {
                crc << 1
            };
        }
    }
    crc
}

/// One SyncManager of the SYNCM category.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SiiSm {
    pub start: u16,
    pub length: u16,
    pub control: u8,
    pub status: u8,
    pub enable: u8,
    pub kind: u8,
}

/// One PDO entry: index, subindex, name, CoE data type code, bit length.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SiiEntry {
    pub index: u16,
    pub subindex: u8,
    pub name: String,
    pub data_type: u8,
    pub bits: u8,
}

/// One PDO of a TXPDO/RXPDO category.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SiiPdo {
    pub index: u16,
    /// 0xFF = not assigned by default.
    pub sm: u8,
    pub dc_sync: u8,
    pub name: String,
    pub flags: u16,
    pub entries: Vec<SiiEntry>,
}

/// One DC op mode.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SiiDc {
    pub cycle0: u32,
    pub shift0: u32,
    pub shift1: u32,
    pub sync1_factor: i16,
    pub assign_activate: u16,
    pub sync0_factor: i16,
    pub name: String,
    pub description: String,
}

/// A decoded SII image.
#[derive(Clone, Debug)]
pub struct Sii {
    /// Words 0x00..0x3F.
    pub words: Vec<u16>,
    /// Category types in image order (END excluded).
    pub order: Vec<u16>,
    /// The byte offset just after the END marker.
    pub end: usize,
    pub strings: Vec<String>,
    pub general: Vec<u8>,
    pub fmmu: Vec<u8>,
    pub sms: Vec<SiiSm>,
    pub tx: Vec<SiiPdo>,
    pub rx: Vec<SiiPdo>,
    pub dc: Vec<SiiDc>,
}

impl Sii {
    pub fn dword(&self, word: usize) -> u32 {
        u32::from(self.words[word]) | u32::from(self.words[word + 1]) << 16
    }

    /// String `idx` (1-based; 0 = none → "").
    pub fn string(&self, idx: u8) -> String {
        if idx == 0 {
            String::new()
        } else {
            self.strings
                .get(usize::from(idx) - 1)
                .unwrap_or_else(|| panic!("string index {idx} beyond the table"))
                .clone()
        }
    }
}

fn u16_at(d: &[u8], at: usize) -> u16 {
    u16::from_le_bytes([d[at], d[at + 1]])
}

fn u32_at(d: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([d[at], d[at + 1], d[at + 2], d[at + 3]])
}

fn decode_strings(d: &[u8]) -> Vec<String> {
    let n = usize::from(d[0]);
    let mut at = 1;
    let mut v = Vec::new();
    for _ in 0..n {
        let len = usize::from(d[at]);
        assert!(
            at + 1 + len <= d.len(),
            "string {} runs past STRINGS",
            v.len() + 1
        );
        v.push(String::from_utf8(d[at + 1..at + 1 + len].to_vec()).expect("UTF-8 string"));
        at += 1 + len;
    }
    assert!(d[at..].iter().all(|&b| b == 0), "STRINGS padding is zero");
    assert!(d.len() - at <= 1, "STRINGS padded to a word only");
    v
}

fn decode_pdos(d: &[u8], strings: &[String]) -> Vec<SiiPdo> {
    let s = |i: u8| {
        if i == 0 {
            String::new()
        } else {
            strings[usize::from(i) - 1].clone()
        }
    };
    let mut at = 0;
    let mut v = Vec::new();
    while at + 8 <= d.len() {
        let n = usize::from(d[at + 2]);
        let mut p = SiiPdo {
            index: u16_at(d, at),
            sm: d[at + 3],
            dc_sync: d[at + 4],
            name: s(d[at + 5]),
            flags: u16_at(d, at + 6),
            entries: Vec::new(),
        };
        at += 8;
        for _ in 0..n {
            assert!(
                at + 8 <= d.len(),
                "PDO {:#06x} entries run past the category",
                p.index
            );
            let e = &d[at..at + 8];
            assert_eq!(&e[6..8], &[0, 0], "entry flags are reserved");
            p.entries.push(SiiEntry {
                index: u16_at(e, 0),
                subindex: e[2],
                name: s(e[3]),
                data_type: e[4],
                bits: e[5],
            });
            at += 8;
        }
        v.push(p);
    }
    assert_eq!(at, d.len(), "PDO category has trailing bytes");
    v
}

/// Decodes an SII image, checking the framing rules of esi-sii.md §2 and IgH `checkSiiData`
/// (panics on a violation).
pub fn decode_sii(img: &[u8]) -> Sii {
    assert!(img.len() >= 0x41 * 2, "at least 0x41 words");
    assert_eq!(img.len() % 2, 0, "even size");
    let words: Vec<u16> = (0..0x40).map(|w| u16_at(img, 2 * w)).collect();
    assert_eq!(img[0x0E], crc8(&img[..14]), "CRC-8 of bytes 0..13");
    assert_eq!(img[0x0F], 0, "checksum high byte");
    let mut sii = Sii {
        words,
        order: Vec::new(),
        end: 0,
        strings: Vec::new(),
        general: Vec::new(),
        fmmu: Vec::new(),
        sms: Vec::new(),
        tx: Vec::new(),
        rx: Vec::new(),
        dc: Vec::new(),
    };
    let mut bodies: Vec<(u16, Vec<u8>)> = Vec::new();
    let mut at = 0x80;
    loop {
        assert!(at + 2 <= img.len(), "category chain runs past the image");
        let kind = u16_at(img, at);
        if kind == 0xFFFF {
            sii.end = at + 2;
            break;
        }
        assert!(at + 4 <= img.len(), "category header runs past the image");
        let len = usize::from(u16_at(img, at + 2)) * 2;
        assert!(
            at + 4 + len <= img.len(),
            "category {kind} runs past the image"
        );
        bodies.push((kind, img[at + 4..at + 4 + len].to_vec()));
        sii.order.push(kind);
        at += 4 + len;
    }
    for kind in [10u16, 30, 40, 41, 50, 51, 60] {
        assert!(
            sii.order.iter().filter(|&&k| k == kind).count() <= 1,
            "category {kind} more than once"
        );
    }
    let strings = bodies
        .iter()
        .find(|(k, _)| *k == 10)
        .map(|(_, d)| decode_strings(d))
        .unwrap_or_default();
    sii.strings = strings;
    for (kind, d) in &bodies {
        match kind {
            30 => sii.general = d.clone(),
            40 => sii.fmmu = d.clone(),
            41 => {
                assert_eq!(d.len() % 8, 0, "SYNCM is 8 bytes per SM");
                sii.sms = d
                    .chunks(8)
                    .map(|e| SiiSm {
                        start: u16_at(e, 0),
                        length: u16_at(e, 2),
                        control: e[4],
                        status: e[5],
                        enable: e[6],
                        kind: e[7],
                    })
                    .collect();
            }
            50 => sii.tx = decode_pdos(d, &sii.strings),
            51 => sii.rx = decode_pdos(d, &sii.strings),
            60 => {
                assert_eq!(d.len() % 24, 0, "DC is 24 bytes per op mode");
                sii.dc = d
                    .chunks(24)
                    .map(|m| {
                        assert_eq!(&m[20..24], &[0; 4], "DC reserved bytes");
                        SiiDc {
                            cycle0: u32_at(m, 0),
                            shift0: u32_at(m, 4),
                            shift1: u32_at(m, 8),
                            sync1_factor: i16::from_le_bytes([m[12], m[13]]),
                            assign_activate: u16_at(m, 14),
                            sync0_factor: i16::from_le_bytes([m[16], m[17]]),
                            name: sii.string(m[18]),
                            description: sii.string(m[19]),
                        }
                    })
                    .collect();
            }
            _ => {}
        }
    }
    sii
}

// --- CSV -----------------------------------------------------------------------------------

/// Parses RFC 4180 CSV (quoted fields may hold commas, quotes as `""` and line breaks; records
/// end in LF or CRLF).
pub fn parse_csv(s: &str) -> Vec<Vec<String>> {
    let mut records = Vec::new();
    let mut record = Vec::new();
    let mut field = String::new();
    let mut chars = s.chars().peekable();
    let mut quoted = false;
    let mut at_field_start = true;
    while let Some(c) = chars.next() {
        if quoted {
            if c == '"' {
                if chars.peek() == Some(&'"') {
                    chars.next();
                    field.push('"');
                } else {
                    quoted = false;
                }
            } else {
                field.push(c);
            }
            continue;
        }
        match c {
            '"' if at_field_start => {
                quoted = true;
                at_field_start = false;
            }
            '"' => panic!("quote inside an unquoted field: {field:?}"),
            ',' => {
                record.push(std::mem::take(&mut field));
                at_field_start = true;
            }
            '\r' if chars.peek() == Some(&'\n') => {}
            '\n' => {
                record.push(std::mem::take(&mut field));
                records.push(std::mem::take(&mut record));
                at_field_start = true;
            }
            _ => {
                field.push(c);
                at_field_start = false;
            }
        }
    }
    assert!(!quoted, "unterminated quoted field");
    if !field.is_empty() || !record.is_empty() {
        record.push(field);
        records.push(record);
    }
    records
}
