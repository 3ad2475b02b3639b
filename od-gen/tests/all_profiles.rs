//! Every built-in profile (`od-gen/profiles/*.toml`): the ESI parses with `ethercat-esi` and
//! passes the project's structural lints, the SII image decodes (independent decoder in
//! `common`) and agrees with the ESI and the profile, and `table --csv` round-trips the
//! dictionary.
//!
//! Each test runs every profile and reports all failing profiles at once.

mod common;

use std::panic::{catch_unwind, AssertUnwindSafe};

use common::{child, children, decode_sii, hexdec, opt_child, text, Sii};
use ethercat_esi::EtherCatInfo;
use od_gen::model::{DataType, PdoMapping, Profile, Storage};
use roxmltree::Document;

/// A PDO entry as ethercat-esi shows it: index, subindex, bit length, name, data type.
type EntryView<'a> = (u16, u8, usize, Option<&'a str>, Option<String>);

/// Runs `check` on every built-in profile; panics listing every profile it failed for.
fn for_every_profile(check: impl Fn(&Profile)) {
    let profiles = common::profiles();
    let failed: Vec<String> = profiles
        .iter()
        .filter(|p| catch_unwind(AssertUnwindSafe(|| check(p))).is_err())
        .map(|p| p.name.clone())
        .collect();
    assert!(
        failed.is_empty(),
        "failed for {failed:?} (of {} profiles; messages above)",
        profiles.len()
    );
}

/// The ESI as `ethercat-esi` 0.2.0 can read it. That crate requires `@Sm` on every PDO, but
/// od-gen writes `@Sm` only on the PDOs of the default assignment (that is what `@Sm` means,
/// and the lints check it); for a profile with alternative PDOs the copy given to the crate has
/// `Sm` added to those. Returns the text and the number of PDOs patched.
fn esi_for_ethercat_esi(p: &Profile, xml: &str) -> (String, usize) {
    let mut out = String::with_capacity(xml.len() + 64);
    let mut patched = 0;
    let lines: Vec<&str> = xml.lines().collect();
    for (i, line) in lines.iter().enumerate() {
        let t = line.trim_start();
        if (t.starts_with("<RxPdo ") || t.starts_with("<TxPdo ")) && !t.contains(" Sm=\"") {
            let index = lines
                .get(i + 1)
                .and_then(|l| l.trim().strip_prefix("<Index>"))
                .and_then(|l| l.strip_suffix("</Index>"))
                .map(hexdec)
                .expect("<Index> follows the PDO start tag");
            let pdo = p
                .rx_pdos
                .iter()
                .chain(&p.tx_pdos)
                .find(|x| u32::from(x.index) == index)
                .expect("PDO of the profile");
            assert!(
                !pdo.assigned,
                "{}: assigned PDO {index:#06x} without Sm",
                p.name
            );
            let at = line.rfind('>').unwrap();
            out.push_str(&line[..at]);
            out.push_str(&format!(" Sm=\"{}\">", pdo.sm));
            patched += 1;
        } else {
            out.push_str(line);
        }
        out.push('\n');
    }
    (out, patched)
}

#[test]
fn every_esi_parses_with_ethercat_esi_and_matches_the_profile() {
    for_every_profile(|p| {
        let name = &p.name;
        let xml = p.esi_xml();
        let (readable, patched) = esi_for_ethercat_esi(p, &xml);
        let unassigned = p
            .rx_pdos
            .iter()
            .chain(&p.tx_pdos)
            .filter(|x| !x.assigned)
            .count();
        assert_eq!(patched, unassigned, "{name}");
        if patched == 0 {
            assert_eq!(readable.trim_end(), xml.trim_end());
        }
        let info = EtherCatInfo::from_xml_str(&readable)
            .unwrap_or_else(|e| panic!("{name}: ethercat-esi 0.2.0 rejects the ESI: {e:?}"));
        assert_eq!(info.vendor.id, p.vendor.id, "{name}");
        assert_eq!(info.vendor.name.as_deref(), Some(p.vendor.name.as_str()));
        assert_eq!(info.description.devices.len(), 1, "{name}");
        let d = &info.description.devices[0];
        assert_eq!(d.product_code, p.device.product_code, "{name}");
        assert_eq!(d.revision_no, p.device.revision, "{name}");
        assert_eq!(d.name, p.device.name, "{name}");
        assert_eq!(d.desc, p.device.order_number, "{name}");
        assert_eq!(d.physics.as_deref(), Some(p.device.physics.as_str()));

        let sms: Vec<(u16, u8, Option<usize>, bool)> =
            d.sm.iter()
                .map(|s| (s.start_address, s.control_byte, s.default_size, s.enable))
                .collect();
        let want: Vec<(u16, u8, Option<usize>, bool)> =
            [p.sm.mailbox_out, p.sm.mailbox_in, p.sm.outputs, p.sm.inputs]
                .iter()
                .map(|s| {
                    (
                        s.start,
                        s.control,
                        Some(usize::from(s.length)),
                        s.length > 0,
                    )
                })
                .collect();
        assert_eq!(sms, want, "{name}: SMs");
        assert_eq!(
            d.sm[2].default_size,
            Some(p.outputs_bits() as usize / 8),
            "{name}: SM2 size = default RxPDOs"
        );
        assert_eq!(
            d.sm[3].default_size,
            Some(p.inputs_bits() as usize / 8),
            "{name}: SM3 size = default TxPDOs"
        );

        for (esi, model) in [(&d.rx_pdo, &p.rx_pdos), (&d.tx_pdo, &p.tx_pdos)] {
            assert_eq!(esi.len(), model.len(), "{name}: PDO count");
            for (e, m) in esi.iter().zip(model.iter()) {
                assert_eq!(u16::from(e.idx), m.index, "{name}");
                assert_eq!(u8::from(e.sm), m.sm, "{name}");
                assert_eq!(e.fixed, m.fixed, "{name}");
                assert_eq!(e.mandatory, m.mandatory, "{name}");
                assert_eq!(e.name.as_deref(), Some(m.name.as_str()), "{name}");
                let got: Vec<EntryView> = e
                    .entries
                    .iter()
                    .map(|x| {
                        (
                            u16::from(x.entry_idx.idx),
                            u8::from(x.entry_idx.sub_idx),
                            x.bit_len,
                            x.name.as_deref(),
                            x.data_type.clone(),
                        )
                    })
                    .collect();
                let want: Vec<EntryView> = m
                    .entries
                    .iter()
                    .map(|x| {
                        (
                            x.index,
                            x.subindex,
                            usize::from(x.bits),
                            (x.index != 0).then_some(x.name.as_str()),
                            x.data_type.map(|t| t.esi_name(x.bits)),
                        )
                    })
                    .collect();
                assert_eq!(got, want, "{name}: PDO {:#06x} entries", m.index);
            }
        }
    });
}

#[test]
fn every_esi_passes_the_structural_lints() {
    for_every_profile(|p| common::esi_lints(p, &p.esi_xml(), &p.sii_image()));
}

/// The SII words, categories and bodies of `p` against the profile and its ESI.
fn check_sii(p: &Profile) {
    let name = &p.name;
    let img = p.sii_image();
    let sii: Sii = decode_sii(&img);
    let xml = p.esi_xml();
    let doc = Document::parse(&xml).unwrap();
    let device = common::device(&doc);
    let w = &sii.words;

    // Header: configuration area = ESI ConfigData = the profile's [eeprom].
    let e = &p.eeprom;
    assert_eq!(
        [w[0], w[1], w[2], w[3], w[4], w[5], w[6]],
        [
            u16::from(e.pdi_control) | u16::from(e.esc_config) << 8,
            e.pdi_config,
            e.sync_impulse_len,
            e.pdi_config2,
            e.station_alias,
            e.reserved[0],
            e.reserved[1]
        ],
        "{name}: words 0..6"
    );
    assert_eq!(
        common::unhex(text(child(device, "Eeprom"), "ConfigData")),
        img[..14].to_vec(),
        "{name}"
    );

    // Identity = profile = ESI.
    let ty = child(device, "Type");
    let esi_vendor = hexdec(text(child(doc.root_element(), "Vendor"), "Id"));
    assert_eq!(
        [
            sii.dword(0x08),
            sii.dword(0x0A),
            sii.dword(0x0C),
            sii.dword(0x0E)
        ],
        [
            p.vendor.id,
            p.device.product_code,
            p.device.revision,
            p.device.serial
        ],
        "{name}: identity words"
    );
    assert_eq!(
        [sii.dword(0x08), sii.dword(0x0A), sii.dword(0x0C)],
        [
            esi_vendor,
            hexdec(ty.attribute("ProductCode").unwrap()),
            hexdec(ty.attribute("RevisionNo").unwrap())
        ],
        "{name}: identity words = ESI"
    );
    // 1018h defaults agree too.
    for (sub, v) in [
        (1u8, p.vendor.id),
        (2, p.device.product_code),
        (3, p.device.revision),
    ] {
        let e = p.entry(0x1018, sub).expect("1018h");
        assert_eq!(
            e.initial_bytes(),
            v.to_le_bytes().to_vec(),
            "{name}: 1018h:{sub}"
        );
    }

    // Mailboxes: words 0x14..0x1C = profile = ESI Sm / BootStrap / Mailbox.
    let boot = |s: Option<od_gen::model::Sm>| s.map_or([0, 0], |s| [s.start, s.length]);
    let [bo, bos] = boot(p.sm.boot_out);
    let [bi, bis] = boot(p.sm.boot_in);
    assert_eq!(
        w[0x14..0x1C].to_vec(),
        vec![
            bo,
            bos,
            bi,
            bis,
            p.sm.mailbox_out.start,
            p.sm.mailbox_out.length,
            p.sm.mailbox_in.start,
            p.sm.mailbox_in.length
        ],
        "{name}: mailbox words"
    );
    let esi_sms = children(device, "Sm");
    for (i, word) in [(0usize, 0x18usize), (1, 0x1A)] {
        assert_eq!(
            u32::from(w[word]),
            hexdec(esi_sms[i].attribute("StartAddress").unwrap()),
            "{name}"
        );
        assert_eq!(
            u32::from(w[word + 1]),
            hexdec(esi_sms[i].attribute("DefaultSize").unwrap()),
            "{name}"
        );
    }
    assert_eq!(w[0x1C], p.mailbox.protocols, "{name}: protocol word");
    let mbx = child(device, "Mailbox");
    let esi_protocols = [
        ("AoE", 0x01u16),
        ("EoE", 0x02),
        ("CoE", 0x04),
        ("FoE", 0x08),
        ("SoE", 0x10),
        ("VoE", 0x20),
    ]
    .iter()
    .filter(|(t, _)| opt_child(mbx, t).is_some())
    .fold(0, |acc, (_, b)| acc | b);
    assert_eq!(
        w[0x1C], esi_protocols,
        "{name}: protocol word = ESI Mailbox"
    );
    for word in (0x10..0x14).chain(0x1D..0x3E) {
        assert_eq!(w[word], 0, "{name}: reserved word {word:#x}");
    }
    assert_eq!(
        (usize::from(w[0x3E]) + 1) * 128,
        p.eeprom.byte_size,
        "{name}: size word"
    );
    assert_eq!(w[0x3F], 1, "{name}: version");

    // Image: END inside, then 0xFF padding to the EEPROM size.
    assert_eq!(img.len(), p.eeprom.byte_size, "{name}");
    assert!(
        img[sii.end..].iter().all(|&b| b == 0xFF),
        "{name}: 0xFF after END"
    );

    // Category order: STRINGS, GENERAL, FMMU, SYNCM, then the PDOs, then DC.
    let mut want = vec![10u16, 30, 40, 41];
    if !p.tx_pdos.is_empty() {
        want.push(50);
    }
    if !p.rx_pdos.is_empty() {
        want.push(51);
    }
    if !p.dc_op_modes.is_empty() {
        want.push(60);
    }
    assert_eq!(sii.order, want, "{name}: category order");
    assert_eq!(
        sii.strings[0], p.device.name,
        "{name}: string 1 (SOEM's name)"
    );

    // GENERAL (32 bytes, reserved bits 0).
    let g = &sii.general;
    assert_eq!(g.len(), 32, "{name}: GENERAL size");
    assert_eq!(sii.string(g[0]), p.device.group_type, "{name}: GroupIdx");
    assert_eq!(sii.string(g[0]), text(device, "GroupType"), "{name}");
    assert_eq!(g[1], 0, "{name}: no image");
    assert_eq!(sii.string(g[2]), p.device.name, "{name}: OrderIdx");
    assert_eq!(sii.string(g[3]), text(device, "Name"), "{name}: NameIdx");
    assert_eq!(g[4], 0, "{name}");
    let coe = p.mailbox.coe;
    let coe_bits = u8::from(coe.sdo)
        | u8::from(coe.sdo_info) << 1
        | u8::from(coe.pdo_assign) << 2
        | u8::from(coe.pdo_config) << 3
        | u8::from(coe.upload_at_startup) << 4
        | u8::from(coe.complete_access) << 5;
    assert_eq!(g[5], coe_bits, "{name}: CoE details");
    if let Some(c) = opt_child(mbx, "CoE") {
        let b = |a: &str| u8::from(c.attribute(a) == Some("true"));
        assert_eq!(
            g[5] >> 1,
            b("SdoInfo")
                | b("PdoAssign") << 1
                | b("PdoConfig") << 2
                | b("PdoUpload") << 3
                | b("CompleteAccess") << 4,
            "{name}: CoE details = ESI"
        );
    }
    assert_eq!(g[5] & 0xC0, 0, "{name}: reserved CoE bits");
    assert_eq!(
        g[6],
        u8::from(opt_child(mbx, "FoE").is_some()),
        "{name}: FoE"
    );
    assert_eq!(
        g[7],
        u8::from(opt_child(mbx, "EoE").is_some()),
        "{name}: EoE"
    );
    assert_eq!(g[9], p.device.ds402_channels, "{name}: DS402 channels");
    assert_eq!(
        g[0x0B],
        u8::from(mbx.attribute("DataLinkLayer") == Some("true")) << 2,
        "{name}: flags"
    );
    assert_eq!(sii.string(g[0x0E]), p.device.group_name, "{name}");
    let ports = u16::from_le_bytes([g[0x10], g[0x11]]);
    let want_ports = p
        .device
        .physics
        .chars()
        .take(4)
        .enumerate()
        .fold(0u16, |acc, (i, c)| {
            acc | match c {
                'Y' => 1,
                'K' => 3,
                'H' => 4,
                _ => 0,
            } << (4 * i)
        });
    assert_eq!(ports, want_ports, "{name}: physical ports");
    assert!(g[0x12..].iter().all(|&b| b == 0), "{name}: reserved");

    // FMMU: Outputs, Inputs, MBoxState.
    assert_eq!(&sii.fmmu[..3], &[1, 2, 3], "{name}");
    assert!(sii.fmmu[3..].iter().all(|&b| b == 0 || b == 0xFF), "{name}");

    // SYNCM = profile = ESI Sm.
    let model_sms = [p.sm.mailbox_out, p.sm.mailbox_in, p.sm.outputs, p.sm.inputs];
    assert_eq!(sii.sms.len(), 4, "{name}: four SMs");
    for (i, ((s, m), x)) in sii.sms.iter().zip(model_sms).zip(&esi_sms).enumerate() {
        assert_eq!(
            (s.start, s.length, s.control, s.status, s.enable, s.kind),
            (
                m.start,
                m.length,
                m.control,
                0,
                u8::from(m.length > 0),
                i as u8 + 1
            ),
            "{name}: SM{i}"
        );
        assert_eq!(
            (
                u32::from(s.start),
                u32::from(s.length),
                u32::from(s.control),
                u32::from(s.enable)
            ),
            (
                hexdec(x.attribute("StartAddress").unwrap()),
                hexdec(x.attribute("DefaultSize").unwrap()),
                hexdec(x.attribute("ControlByte").unwrap()),
                hexdec(x.attribute("Enable").unwrap())
            ),
            "{name}: SM{i} = ESI"
        );
    }
    assert_eq!(u32::from(sii.sms[2].length) * 8, p.outputs_bits(), "{name}");
    assert_eq!(u32::from(sii.sms[3].length) * 8, p.inputs_bits(), "{name}");

    // TXPDO / RXPDO = profile = ESI.
    for (decoded, model, tag) in [
        (&sii.tx, &p.tx_pdos, "TxPdo"),
        (&sii.rx, &p.rx_pdos, "RxPdo"),
    ] {
        assert_eq!(decoded.len(), model.len(), "{name}: {tag} count");
        let esi = children(device, tag);
        for ((d, m), x) in decoded.iter().zip(model.iter()).zip(&esi) {
            let ctx = format!("{name}: {tag} {:#06x}", m.index);
            assert_eq!(d.index, m.index, "{ctx}");
            assert_eq!(u32::from(d.index), hexdec(text(*x, "Index")), "{ctx}");
            assert_eq!(d.sm, if m.assigned { m.sm } else { 0xFF }, "{ctx}: SM byte");
            assert_eq!(
                x.attribute("Sm").map(|s| s.parse::<u8>().unwrap()),
                (d.sm != 0xFF).then_some(d.sm),
                "{ctx}: SM byte = ESI @Sm"
            );
            assert_eq!(d.dc_sync, 0, "{ctx}");
            assert_eq!(d.name, m.name, "{ctx}");
            assert_eq!(d.name, text(*x, "Name"), "{ctx}");
            assert_eq!(
                d.flags,
                u16::from(m.mandatory) | u16::from(m.fixed) << 4,
                "{ctx}: flags"
            );
            assert_eq!(
                d.flags,
                u16::from(x.attribute("Mandatory") == Some("true"))
                    | u16::from(x.attribute("Fixed") == Some("true")) << 4,
                "{ctx}: flags = ESI"
            );
            let xe = children(*x, "Entry");
            assert_eq!(d.entries.len(), m.entries.len(), "{ctx}");
            assert_eq!(d.entries.len(), xe.len(), "{ctx}");
            for ((de, me), xe) in d.entries.iter().zip(&m.entries).zip(xe) {
                assert_eq!(
                    (de.index, de.subindex, u16::from(de.bits)),
                    (me.index, me.subindex, me.bits),
                    "{ctx}: entry"
                );
                assert_eq!(u32::from(de.index), hexdec(text(xe, "Index")), "{ctx}");
                assert_eq!(de.bits.to_string(), text(xe, "BitLen"), "{ctx}");
                if de.index == 0 {
                    assert_eq!((de.subindex, de.name.as_str(), de.data_type), (0, "", 0));
                    continue;
                }
                assert_eq!(
                    u32::from(de.subindex),
                    hexdec(text(xe, "SubIndex")),
                    "{ctx}"
                );
                assert_eq!(de.name, me.name, "{ctx}");
                assert_eq!(de.name, text(xe, "Name"), "{ctx}");
                assert_eq!(
                    de.data_type,
                    common::coe_code(text(xe, "DataType")),
                    "{ctx}: {:#06x}:{} data type = ESI DataType",
                    de.index,
                    de.subindex
                );
                let oe = p.entry(me.index, me.subindex).expect("mapped entry exists");
                assert_eq!(oe.bit_len, me.bits, "{ctx}");
            }
        }
        // PDO bits of the default assignment = SM length.
        let bits: u32 = decoded
            .iter()
            .filter(|d| d.sm != 0xFF)
            .flat_map(|d| &d.entries)
            .map(|e| u32::from(e.bits))
            .sum();
        let sm = if tag == "RxPdo" {
            &sii.sms[2]
        } else {
            &sii.sms[3]
        };
        assert_eq!(
            bits,
            u32::from(sm.length) * 8,
            "{name}: {tag} bits = SM length"
        );
    }

    // DC = profile = ESI OpModes.
    assert_eq!(sii.dc.len(), p.dc_op_modes.len(), "{name}: DC op modes");
    let esi_modes = opt_child(device, "Dc")
        .map(|dc| children(dc, "OpMode"))
        .unwrap_or_default();
    for ((d, m), x) in sii.dc.iter().zip(&p.dc_op_modes).zip(&esi_modes) {
        assert_eq!(
            d,
            &common::SiiDc {
                cycle0: m.sync0_cycle_ns,
                shift0: m.sync0_shift_ns,
                shift1: m.sync1_shift_ns,
                sync1_factor: m.sync1_factor,
                assign_activate: m.assign_activate,
                sync0_factor: m.sync0_factor,
                name: m.name.clone(),
                description: m.description.clone(),
            },
            "{name}: DC op mode {}",
            m.name
        );
        assert_eq!(d.name, text(*x, "Name"), "{name}");
        assert_eq!(
            d.description,
            opt_child(*x, "Desc").and_then(|n| n.text()).unwrap_or(""),
            "{name}"
        );
        assert_eq!(
            u32::from(d.assign_activate),
            hexdec(text(*x, "AssignActivate")),
            "{name}"
        );
    }
}

#[test]
fn every_sii_image_decodes_and_matches_the_esi_and_the_profile() {
    // The decoder's CRC against the check value and a real image (esi-sii.md §2.1).
    assert_eq!(common::crc8(b"123456789"), 0xFB);
    assert_eq!(
        common::crc8(&[0x05, 0x06, 0x00, 0x44, 0x64, 0, 0, 0, 0, 0, 0x1A, 0, 0, 0]),
        0xA9
    );
    for_every_profile(check_sii);
}

/// The ETG.1000.6 name `table` must print, written independently of `od_gen::table`.
fn etg_name(dt: DataType) -> String {
    match dt {
        DataType::Bool => "BOOLEAN".into(),
        DataType::Sint => "INT8".into(),
        DataType::Int => "INT16".into(),
        DataType::Int24 => "INT24".into(),
        DataType::Dint => "INT32".into(),
        DataType::Lint => "INT64".into(),
        DataType::Usint => "UINT8".into(),
        DataType::Uint => "UINT16".into(),
        DataType::Uint24 => "UINT24".into(),
        DataType::Udint => "UINT32".into(),
        DataType::Ulint => "UINT64".into(),
        DataType::Real => "REAL32".into(),
        DataType::Lreal => "REAL64".into(),
        DataType::VisibleString => "VISIBLE_STRING".into(),
        DataType::OctetString => "OCTET_STRING".into(),
        DataType::UnicodeString => "UNICODE_STRING".into(),
        DataType::Domain => "DOMAIN".into(),
        DataType::Bit(n) => format!("BIT{n}"),
    }
}

/// A CSV value field back to the model's little-endian bytes (`width` = the model's length).
fn value_bytes(dt: DataType, field: &str, width: usize, ctx: &str) -> Vec<u8> {
    if field.is_empty() {
        return Vec::new();
    }
    match dt {
        DataType::VisibleString => field.as_bytes().to_vec(),
        DataType::UnicodeString => field.encode_utf16().flat_map(u16::to_le_bytes).collect(),
        DataType::OctetString | DataType::Domain => common::unhex(field),
        DataType::Real => field
            .parse::<f32>()
            .unwrap_or_else(|_| panic!("{ctx}: REAL32 {field:?}"))
            .to_le_bytes()
            .to_vec(),
        DataType::Lreal => field
            .parse::<f64>()
            .unwrap_or_else(|_| panic!("{ctx}: REAL64 {field:?}"))
            .to_le_bytes()
            .to_vec(),
        _ => {
            assert!(
                field.bytes().all(|b| b.is_ascii_digit() || b == b'-'),
                "{ctx}: {field:?} is not a decimal integer"
            );
            let n: i128 = field
                .parse()
                .unwrap_or_else(|_| panic!("{ctx}: integer {field:?}"));
            let (lo, hi) = dt.int_range().unwrap();
            assert!((lo..=hi).contains(&n), "{ctx}: {n} outside the type");
            n.to_le_bytes()[..width].to_vec()
        }
    }
}

#[test]
fn every_table_csv_round_trips_the_dictionary() {
    for_every_profile(|p| {
        let name = &p.name;
        let csv = od_gen::table::csv(p);
        let records = common::parse_csv(&csv);
        assert_eq!(
            records[0].join(","),
            "index,subindex,name,data_type,access,pdo_mapping,default,min,max",
            "{name}: header"
        );
        let entries: Vec<_> = p
            .objects
            .iter()
            .flat_map(|o| o.entries.iter().map(move |e| (o, e)))
            .collect();
        assert_eq!(
            records.len() - 1,
            entries.len(),
            "{name}: one row per entry"
        );
        for (r, (o, e)) in records[1..].iter().zip(&entries) {
            let ctx = format!("{name}: {:#06x}:{}", o.index, e.subindex);
            assert_eq!(r.len(), 9, "{ctx}: 9 fields");
            assert_eq!(r[0], format!("0x{:04X}", o.index), "{ctx}");
            assert_eq!(r[0].len(), 6, "{ctx}");
            assert!(r[0][2..]
                .bytes()
                .all(|b| b.is_ascii_digit() || b.is_ascii_uppercase()));
            assert_eq!(r[1].parse::<u8>().ok(), Some(e.subindex), "{ctx}");
            assert_eq!(r[2], e.name, "{ctx}");
            assert_eq!(r[3], etg_name(e.data_type), "{ctx}");
            let access = match (e.access.readable(), e.access.writable()) {
                (true, true) => "RW",
                (false, true) => "WO",
                (_, false) if e.storage == Storage::Const => "CONST",
                (_, false) => "RO",
            };
            assert_eq!(r[4], access, "{ctx}");
            let pdo = match e.pdo {
                PdoMapping::No => "NO",
                PdoMapping::Rx => "RX",
                PdoMapping::Tx => "TX",
                PdoMapping::RxTx => "YES",
            };
            assert_eq!(r[5], pdo, "{ctx}");
            for (field, bytes, what) in [
                (&r[6], &e.default, "default"),
                (&r[7], &e.min, "min"),
                (&r[8], &e.max, "max"),
            ] {
                assert_eq!(
                    &value_bytes(e.data_type, field, bytes.len(), &format!("{ctx} {what}")),
                    bytes,
                    "{ctx}: {what} {field:?}"
                );
            }
        }
        // The aligned table has one line per entry too (header and summary line around them).
        let text = od_gen::table::text(p);
        assert_eq!(
            text.lines().count(),
            entries.len() + 2,
            "{name}: text table"
        );
    });
}
