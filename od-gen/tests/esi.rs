//! The ESI parsed with the crates.io `ethercat-esi` 0.2.0 crate and checked with the project's
//! structural lints (esi-sii.md §1.3–§1.4 and §5).

mod common;

use common::{child, elements, hexdec, text};
use ethercat_esi::EtherCatInfo;
use od_gen::model::Profile;
use roxmltree::{Document, Node};

fn standard() -> Profile {
    od_gen::builtin("standard").expect("standard profile loads")
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

/// The structural lints of esi-sii.md §1 (element order, flags, SM and PDO agreement with the
/// SII; `common::esi_lints`, run on every profile in `all_profiles.rs`) on the standard profile.
#[test]
fn structural_lints() {
    let p = standard();
    common::esi_lints(&p, &p.esi_xml(), &p.sii_image());
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
