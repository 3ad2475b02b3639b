//! The ESI parsed with the crates.io `ethercat-esi` 0.2.0 crate and checked with the project's
//! structural lints (esi-sii.md §1.3–§1.4 and §5).

use std::collections::{BTreeMap, BTreeSet};

use ethercat_esi::EtherCatInfo;
use od_gen::model::Profile;
use roxmltree::{Document, Node};

fn standard() -> Profile {
    od_gen::builtin("standard").expect("standard profile loads")
}

fn hexdec(s: &str) -> u32 {
    match s.strip_prefix("#x") {
        Some(h) => u32::from_str_radix(h, 16).unwrap(),
        None => s.parse().unwrap(),
    }
}

fn child<'a>(n: Node<'a, 'a>, tag: &str) -> Node<'a, 'a> {
    n.children()
        .find(|c| c.has_tag_name(tag))
        .unwrap_or_else(|| panic!("<{tag}> missing in <{}>", n.tag_name().name()))
}

fn text<'a>(n: Node<'a, 'a>, tag: &str) -> &'a str {
    child(n, tag).text().unwrap_or("")
}

fn elements<'a>(n: Node<'a, 'a>) -> Vec<Node<'a, 'a>> {
    n.children().filter(Node::is_element).collect()
}

#[test]
fn parses_with_ethercat_esi_and_matches_the_profile() {
    let p = standard();
    let xml = p.esi_xml();
    assert!(xml.starts_with("<?xml version=\"1.0\" encoding=\"UTF-8\"?>"));
    let info = EtherCatInfo::from_xml_str(&xml).expect("ethercat-esi 0.2.0 parses the ESI");
    assert_eq!(info.vendor.id, p.vendor.id);
    assert_eq!(info.description.devices.len(), 1);
    let d = &info.description.devices[0];
    assert_eq!(d.product_code, p.device.product_code);
    assert_eq!(d.revision_no, p.device.revision);
    assert_eq!(d.name, p.device.name);
    assert_eq!(d.desc, p.device.order_number);

    let sms: Vec<(u16, u8, Option<usize>, bool)> =
        d.sm.iter()
            .map(|s| (s.start_address, s.control_byte, s.default_size, s.enable))
            .collect();
    assert_eq!(
        sms,
        vec![
            (0x1000, 0x26, Some(256), true),
            (0x1100, 0x22, Some(256), true),
            (0x1200, 0x64, Some(7), true),
            (0x1600, 0x20, Some(7), true)
        ]
    );

    for (esi, model) in [(&d.rx_pdo, &p.rx_pdos), (&d.tx_pdo, &p.tx_pdos)] {
        assert_eq!(esi.len(), model.len());
        for (e, m) in esi.iter().zip(model.iter()) {
            assert_eq!(u16::from(e.idx), m.index);
            assert_eq!(u8::from(e.sm), m.sm);
            assert_eq!(e.fixed, m.fixed);
            assert_eq!(e.name.as_deref(), Some(m.name.as_str()));
            let got: Vec<(u16, u8, usize)> = e
                .entries
                .iter()
                .map(|x| {
                    (
                        u16::from(x.entry_idx.idx),
                        u8::from(x.entry_idx.sub_idx),
                        x.bit_len,
                    )
                })
                .collect();
            let want: Vec<(u16, u8, usize)> = m
                .entries
                .iter()
                .map(|x| (x.index, x.subindex, usize::from(x.bits)))
                .collect();
            assert_eq!(got, want);
        }
    }
    assert_eq!(d.rx_pdo[0].entries.len(), 3);
    assert_eq!(d.tx_pdo[0].entries.len(), 3);
}

/// XSD `DeviceType` sequence (esi-sii.md §1.4), restricted to what ethercat-esi 0.2.0 accepts.
const DEVICE_ORDER: [&str; 12] = [
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
];

#[test]
fn structural_lints() {
    let p = standard();
    let xml = p.esi_xml();
    let doc = Document::parse(&xml).expect("well-formed XML");
    let root = doc.root_element();
    assert_eq!(root.tag_name().name(), "EtherCATInfo");
    assert_eq!(
        elements(root)
            .iter()
            .map(|n| n.tag_name().name())
            .collect::<Vec<_>>(),
        ["Vendor", "Descriptions"]
    );
    assert_eq!(hexdec(text(child(root, "Vendor"), "Id")), p.vendor.id);

    let desc = child(root, "Descriptions");
    let group = child(child(desc, "Groups"), "Group");
    let device = child(child(desc, "Devices"), "Device");
    assert_eq!(device.attribute("Physics"), Some("YY"));

    // Element order as in the XSD sequence (Eeprom last), no children ethercat-esi rejects.
    let order = |tag: &str| {
        DEVICE_ORDER
            .iter()
            .position(|t| *t == tag)
            .or((tag == "Eeprom").then_some(DEVICE_ORDER.len()))
    };
    let tags: Vec<&str> = elements(device)
        .iter()
        .map(|n| n.tag_name().name())
        .collect();
    let pos: Vec<usize> = tags
        .iter()
        .map(|t| order(t).unwrap_or_else(|| panic!("unexpected <{t}>")))
        .collect();
    assert!(
        pos.windows(2).all(|w| w[0] <= w[1]),
        "Device children out of order: {tags:?}"
    );
    for t in [
        "Type",
        "Name",
        "GroupType",
        "Profile",
        "Fmmu",
        "Sm",
        "RxPdo",
        "TxPdo",
        "Mailbox",
        "Dc",
        "Eeprom",
    ] {
        assert!(tags.contains(&t), "<{t}> missing");
    }
    assert_eq!(text(device, "GroupType"), text(group, "Type"));

    // HexDec values are #x…, never 0x….
    assert!(!xml.contains(">0x") && !xml.contains("\"0x"));

    // Fmmu and Sm vocabularies.
    let fmmus: Vec<&str> = device
        .children()
        .filter(|n| n.has_tag_name("Fmmu"))
        .map(|n| n.text().unwrap())
        .collect();
    assert_eq!(fmmus, ["Outputs", "Inputs", "MBoxState"]);
    let sms: Vec<Node> = device.children().filter(|n| n.has_tag_name("Sm")).collect();
    assert_eq!(
        sms.iter().map(|n| n.text().unwrap()).collect::<Vec<_>>(),
        ["MBoxOut", "MBoxIn", "Outputs", "Inputs"]
    );
    let sm2_control = hexdec(sms[2].attribute("ControlByte").unwrap());
    assert_ne!(sm2_control & 0x40, 0, "SM2 watchdog trigger");

    // Dictionary: every DataType referenced is declared, names unique, DT shapes conventional.
    let dict = child(child(device, "Profile"), "Dictionary");
    assert_eq!(text(child(device, "Profile"), "ProfileNo"), "402");
    let dts: Vec<Node> = child(dict, "DataTypes")
        .children()
        .filter(|n| n.has_tag_name("DataType"))
        .collect();
    let mut declared: BTreeMap<&str, u32> = BTreeMap::new();
    for dt in &dts {
        assert!(
            declared
                .insert(text(*dt, "Name"), text(*dt, "BitSize").parse().unwrap())
                .is_none(),
            "duplicate DataType"
        );
    }
    let mut referenced = BTreeSet::new();
    for dt in &dts {
        if let Some(b) = dt.children().find(|c| c.has_tag_name("BaseType")) {
            referenced.insert(b.text().unwrap());
        }
        for (i, si) in dt
            .children()
            .filter(|c| c.has_tag_name("SubItem"))
            .enumerate()
        {
            referenced.insert(text(si, "Type"));
            if i == 0 {
                assert_eq!(
                    (text(si, "SubIdx"), text(si, "Type"), text(si, "BitOffs")),
                    ("0", "USINT", "0")
                );
            }
            if i == 1 {
                assert_eq!(text(si, "BitOffs"), "16", "subindex 1 starts at bit 16");
            }
        }
    }
    let objects: Vec<Node> = child(dict, "Objects")
        .children()
        .filter(|n| n.has_tag_name("Object"))
        .collect();
    let mut by_index: BTreeMap<u16, Node> = BTreeMap::new();
    for o in &objects {
        referenced.insert(text(*o, "Type"));
        let idx = hexdec(text(*o, "Index")) as u16;
        assert!(
            by_index.insert(idx, *o).is_none(),
            "duplicate object {idx:#x}"
        );
        let bits: u32 = text(*o, "BitSize").parse().unwrap();
        assert_eq!(
            declared.get(text(*o, "Type")),
            Some(&bits),
            "object {idx:#x} BitSize equals its type's"
        );
    }
    for r in &referenced {
        assert!(
            declared.contains_key(r),
            "DataType {r} referenced but not declared"
        );
    }
    assert_eq!(
        by_index.keys().copied().collect::<Vec<_>>(),
        p.objects.iter().map(|o| o.index).collect::<Vec<_>>()
    );
    // 1C12 is an array in the DTxxxxARR + DTxxxx shape.
    assert_eq!(text(*by_index.get(&0x1C12).unwrap(), "Type"), "DT1C12");
    assert!(declared.contains_key("DT1C12ARR"));

    // Each PDO entry exists in the dictionary with equal bit length and PdoMapping.
    for (tag, mapping) in [("RxPdo", 'R'), ("TxPdo", 'T')] {
        for pdo in device.children().filter(|n| n.has_tag_name(tag)) {
            assert!(
                pdo.attribute("Sm").is_some(),
                "every PDO has Sm (ethercat-esi)"
            );
            let entries: Vec<Node> = pdo.children().filter(|n| n.has_tag_name("Entry")).collect();
            assert!(!entries.is_empty());
            for e in entries {
                let idx = hexdec(text(e, "Index")) as u16;
                if idx == 0 {
                    continue;
                }
                let sub: u32 = hexdec(text(e, "SubIndex"));
                assert_eq!(sub, 0);
                let o = by_index
                    .get(&idx)
                    .unwrap_or_else(|| panic!("PDO entry {idx:#x} not in the dictionary"));
                assert_eq!(text(e, "BitLen"), text(*o, "BitSize"));
                assert_eq!(text(e, "DataType"), text(*o, "Type"));
                let pm = text(child(*o, "Flags"), "PdoMapping");
                assert!(pm.contains(mapping), "{idx:#x} PdoMapping {pm}");
            }
        }
    }

    // PDO mapping and assignment objects are writable in PREOP only.
    for idx in [0x1600u16, 0x1A00, 0x1C12, 0x1C13] {
        let dt = dts
            .iter()
            .find(|d| text(**d, "Name") == format!("DT{idx:04X}"))
            .unwrap();
        for si in dt.children().filter(|c| c.has_tag_name("SubItem")) {
            let a = child(child(si, "Flags"), "Access");
            assert_eq!(
                (a.text(), a.attribute("WriteRestrictions")),
                (Some("rw"), Some("PreOP")),
                "{idx:#x}"
            );
        }
    }

    // Mailbox/CoE attributes follow the CoE details flags.
    let coe = child(child(device, "Mailbox"), "CoE");
    assert_eq!(
        child(device, "Mailbox").attribute("DataLinkLayer"),
        Some("true")
    );
    assert_eq!(coe.attribute("SdoInfo"), Some("true"));
    assert_eq!(coe.attribute("CompleteAccess"), Some("true"));
    assert_eq!(coe.attribute("PdoAssign"), Some("true"));
    assert_eq!(coe.attribute("PdoConfig"), Some("true"));

    // Dc op modes.
    let modes: Vec<(&str, &str)> = child(device, "Dc")
        .children()
        .filter(|n| n.has_tag_name("OpMode"))
        .map(|m| (text(m, "Name"), text(m, "AssignActivate")))
        .collect();
    assert_eq!(modes, [("FreeRun", "#x0000"), ("DC", "#x0300")]);

    // Eeprom: ConfigData = SII bytes 0..13, ByteSize = SII size word.
    let img = p.sii_image();
    let eeprom = child(device, "Eeprom");
    let cfg = text(eeprom, "ConfigData");
    let want: String = img[..14].iter().map(|b| format!("{b:02X}")).collect();
    assert_eq!(cfg, want);
    let size_word = u16::from_le_bytes([img[0x7C], img[0x7D]]);
    assert_eq!(
        text(eeprom, "ByteSize").parse::<usize>().unwrap(),
        (usize::from(size_word) + 1) * 128
    );
    assert!(
        eeprom.children().all(|c| !c.has_tag_name("BootStrap")),
        "no bootstrap mailbox declared"
    );
}

#[test]
fn bootstrap_mailbox_reaches_sii_and_esi() {
    let text = include_str!("../profiles/standard.toml").replace(
        "outputs = { start",
        "boot_out = { start = 0x1000, size = 512, control = 0x26 }\nboot_in = { start = 0x1200, size = 512, control = 0x22 }\noutputs = { start",
    );
    // The bootstrap mailbox overlaps SM2 here: rejected.
    assert!(matches!(
        od_gen::parse(&text, "t"),
        Err(od_gen::Error::Invalid {
            error: od_gen::Invalid::SmOverlap { .. },
            ..
        })
    ));
    let text = text.replace("boot_in = { start = 0x1200", "boot_in = { start = 0x1800");
    let p = od_gen::parse(&text, "t").unwrap();
    let img = p.sii_image();
    let words: Vec<u16> = (0x14..0x18)
        .map(|i| u16::from_le_bytes([img[2 * i], img[2 * i + 1]]))
        .collect();
    assert_eq!(words, [0x1000, 512, 0x1800, 512]);
    let xml = p.esi_xml();
    assert!(
        xml.contains("<BootStrap>0010000200180002</BootStrap>"),
        "{xml}"
    );
}

#[test]
fn state_machine_timeouts_in_info() {
    let p = standard();
    let xml = p.esi_xml();
    let doc = Document::parse(&xml).expect("well-formed XML");
    let device = child(
        child(child(doc.root_element(), "Descriptions"), "Devices"),
        "Device",
    );
    let timeout = child(child(child(device, "Info"), "StateMachine"), "Timeout");
    // XSD order: PreopTimeout, SafeopOpTimeout, BackToInitTimeout, BackToSafeopTimeout (ms).
    assert_eq!(
        elements(timeout)
            .iter()
            .map(|n| (n.tag_name().name(), n.text().unwrap()))
            .collect::<Vec<_>>(),
        [
            ("PreopTimeout", "2000"),
            ("SafeopOpTimeout", "9000"),
            ("BackToInitTimeout", "5000"),
            ("BackToSafeopTimeout", "200"),
        ]
    );
    assert_eq!(p.esm.safeop_op_timeout_ms, 9000);
}

#[test]
fn backup_and_setting_flags_follow_access_order() {
    let p = standard();
    let xml = p.esi_xml();
    let doc = Document::parse(&xml).expect("well-formed XML");
    let objects: Vec<Node> = doc
        .descendants()
        .filter(|n| n.has_tag_name("Object"))
        .collect();
    let flags_of = |index: u16| {
        let o = objects
            .iter()
            .find(|o| hexdec(text(**o, "Index")) == u32::from(index))
            .unwrap_or_else(|| panic!("object {index:#06x}"));
        elements(child(*o, "Flags"))
            .iter()
            .map(|n| n.tag_name().name().to_string())
            .collect::<Vec<_>>()
    };
    // XSD Flags order: Access, Category, PdoMapping, ..., Backup, Setting.
    assert_eq!(flags_of(0x2F00), ["Access", "Backup", "Setting"]);
    assert_eq!(flags_of(0x6060), ["Access", "PdoMapping", "Setting"]);
    assert_eq!(flags_of(0x6040), ["Access", "PdoMapping"]);
    assert_eq!(flags_of(0x1000), ["Access"]);
    // Record entries carry theirs in the DataType SubItems: 1C12h:01 is stored.
    let dt = doc
        .descendants()
        .find(|n| n.has_tag_name("DataType") && text(*n, "Name") == "DT10F1")
        .expect("DT10F1");
    let sub1 = dt
        .children()
        .find(|n| n.has_tag_name("SubItem") && text(*n, "SubIdx") == "1")
        .expect("10F1h:01");
    assert_eq!(text(child(sub1, "Flags"), "Backup"), "1");
}
