//! The SII image checked by an independent decoder written from `reference/esi-sii.md` §2 and
//! `reference/ethercat-slave.md` §3 (it shares no code with `od_gen::sii`; the CRC-8 is the one
//! of `hal`, checked here against known real images and against IgH's augmented form).

use hal::esc::sii::crc8;
use od_gen::model::Profile;

/// IgH `sii_crc.cpp` form: augmented, init 0x48 (esi-sii.md §2.1) — must agree with the direct one.
fn crc8_igh(data: &[u8]) -> u8 {
    let mut crc: u8 = 0x48;
    for &byte in data {
        for bit in (0..8).rev() {
            let input = (byte >> bit) & 1;
            let top = crc >> 7;
            crc = (crc << 1) | input;
            if top == 1 {
                crc ^= 0x07;
            }
        }
    }
    for _ in 0..8 {
        let top = crc >> 7;
        crc <<= 1;
        if top == 1 {
            crc ^= 0x07;
        }
    }
    crc
}

fn w(img: &[u8], word: usize) -> u16 {
    u16::from_le_bytes([img[2 * word], img[2 * word + 1]])
}

fn dw(img: &[u8], word: usize) -> u32 {
    u32::from(w(img, word)) | u32::from(w(img, word + 1)) << 16
}

struct Category {
    kind: u16,
    data: Vec<u8>,
}

/// Walks the category chain from word 0x40 (IgH `checkSiiData`: the chain must end in 0xFFFF
/// inside the image).
fn categories(img: &[u8]) -> Vec<Category> {
    let mut at = 0x80;
    let mut out = Vec::new();
    loop {
        assert!(at + 2 <= img.len(), "category chain runs past the image");
        let kind = u16::from_le_bytes([img[at], img[at + 1]]);
        if kind == 0xFFFF {
            break;
        }
        let len = usize::from(u16::from_le_bytes([img[at + 2], img[at + 3]])) * 2;
        assert!(
            at + 4 + len <= img.len(),
            "category {kind} runs past the image"
        );
        out.push(Category {
            kind,
            data: img[at + 4..at + 4 + len].to_vec(),
        });
        at += 4 + len;
    }
    out
}

fn strings(c: &Category) -> Vec<String> {
    let n = usize::from(c.data[0]);
    let mut at = 1;
    let mut v = Vec::new();
    for _ in 0..n {
        let len = usize::from(c.data[at]);
        v.push(String::from_utf8(c.data[at + 1..at + 1 + len].to_vec()).unwrap());
        at += 1 + len;
    }
    v
}

fn string(strings: &[String], idx: u8) -> &str {
    assert_ne!(idx, 0, "string index 0 means none");
    &strings[usize::from(idx) - 1]
}

#[derive(Debug, PartialEq)]
struct DecodedPdo {
    index: u16,
    sm: u8,
    flags: u16,
    name: String,
    entries: Vec<(u16, u8, u8, u8)>, // index, sub, data type, bits
}

fn decode_pdos(c: &Category, s: &[String]) -> Vec<DecodedPdo> {
    let d = &c.data;
    let mut at = 0;
    let mut v = Vec::new();
    while at + 8 <= d.len() {
        let n = usize::from(d[at + 2]);
        let mut p = DecodedPdo {
            index: u16::from_le_bytes([d[at], d[at + 1]]),
            sm: d[at + 3],
            flags: u16::from_le_bytes([d[at + 6], d[at + 7]]),
            name: string(s, d[at + 5]).to_string(),
            entries: Vec::new(),
        };
        assert_eq!(d[at + 4], 0, "DC sync byte");
        at += 8;
        for _ in 0..n {
            let e = &d[at..at + 8];
            assert_eq!(&e[6..8], &[0, 0], "entry flags are reserved");
            p.entries
                .push((u16::from_le_bytes([e[0], e[1]]), e[2], e[4], e[5]));
            at += 8;
        }
        v.push(p);
    }
    assert_eq!(at, d.len(), "PDO category has trailing bytes");
    v
}

fn standard() -> Profile {
    od_gen::builtin("standard").expect("standard profile loads")
}

#[test]
fn crc_known_vectors() {
    // Check value of CRC-8 with poly 0x07 and init 0xFF over "123456789". (0xF4 is the check
    // value with init 0x00, CRC-8/SMBUS; the SII uses init 0xFF, see the real images below.)
    assert_eq!(crc8(b"123456789"), 0xFB);
    assert_ne!(crc8(b"123456789"), 0xF4);
    // Real images (esi-sii.md §2.1): Somanet, SOES lan9252 slave.bin, EEPROM_generator AX58100.
    let mut a = [0u8; 14];
    a[..4].copy_from_slice(&[0x08, 0x0E, 0x02, 0x88]);
    let mut b = [0u8; 14];
    b[..2].copy_from_slice(&[0x80, 0x02]);
    let c = [0x05, 0x06, 0x00, 0x44, 0x64, 0, 0, 0, 0, 0, 0x1A, 0, 0, 0];
    assert_eq!([crc8(&a), crc8(&b), crc8(&c)], [0x2F, 0xC6, 0xA9]);
    assert_eq!(
        [crc8_igh(&a), crc8_igh(&b), crc8_igh(&c)],
        [0x2F, 0xC6, 0xA9]
    );
    assert_eq!(od_gen::sii::crc8(&c), 0xA9);
}

#[test]
fn header_words() {
    let p = standard();
    let img = p.sii_image();
    // CRC over bytes 0..13 in byte 14, byte 15 zero; both CRC forms.
    assert_eq!(img[14], crc8(&img[..14]));
    assert_eq!(img[14], crc8_igh(&img[..14]));
    assert_eq!(img[15], 0);
    // Config words as declared for the ET1100 SPI PDI: PDI type 0x05 (SPI slave), SPI mode 3
    // with SYNC0/1 push-pull active-high outputs (what boards/stm32g474 expects).
    assert_eq!(w(&img, 0), 0x0605);
    assert_eq!(w(&img, 1), 0x6603);
    assert_eq!(w(&img, 2), 100);
    // Identity words 0x08..0x0F.
    assert_eq!(dw(&img, 0x08), p.vendor.id);
    assert_eq!(dw(&img, 0x0A), p.device.product_code);
    assert_eq!(dw(&img, 0x0C), p.device.revision);
    assert_eq!(dw(&img, 0x0E), p.device.serial);
    assert_eq!(dw(&img, 0x08), 0x7E57_0402);
    assert_eq!(dw(&img, 0x0A), 0x0000_0402);
    // No bootstrap mailbox; standard mailbox SM0 0x1000/256, SM1 0x1100/256; CoE only.
    assert_eq!(
        [w(&img, 0x14), w(&img, 0x15), w(&img, 0x16), w(&img, 0x17)],
        [0; 4]
    );
    assert_eq!(
        [w(&img, 0x18), w(&img, 0x19), w(&img, 0x1A), w(&img, 0x1B)],
        [0x1000, 256, 0x1100, 256]
    );
    assert_eq!(w(&img, 0x1C), 0x0004);
    // Reserved words are zero.
    for word in (0x10..0x14).chain(0x1D..0x3E) {
        assert_eq!(w(&img, word), 0, "word {word:#x}");
    }
    // Size word and version; image length a power-of-two multiple of 128 bytes.
    assert_eq!(w(&img, 0x3F), 1);
    assert_eq!((usize::from(w(&img, 0x3E)) + 1) * 128, img.len());
    assert!((img.len() / 128).is_power_of_two() && img.len() % 128 == 0);
    assert_eq!(img.len(), 2048);
}

#[test]
fn igh_check_sii_data_rules() {
    let img = standard().sii_image();
    assert!(img.len() >= 0x41 * 2, "at least 0x41 words");
    assert_eq!(img.len() % 2, 0, "even size");
    let cats = categories(&img); // panics if the chain does not end in 0xFFFF inside the image
    assert!(!cats.is_empty());
}

#[test]
fn category_order_and_bodies() {
    let p = standard();
    let img = p.sii_image();
    let cats = categories(&img);
    let kinds: Vec<u16> = cats.iter().map(|c| c.kind).collect();
    assert_eq!(
        kinds,
        [10, 30, 40, 41, 50, 51, 60],
        "STRINGS, GENERAL, FMMU, SYNCM, TXPDO, RXPDO, DC"
    );
    assert_eq!(
        kinds.iter().filter(|&&k| k == 50).count(),
        1,
        "exactly one TXPDO category"
    );
    assert_eq!(
        kinds.iter().filter(|&&k| k == 51).count(),
        1,
        "exactly one RXPDO category"
    );
    let s = strings(&cats[0]);
    assert_eq!(
        s[0], "Open CiA402 Servo",
        "string 1 is the device name (SOEM)"
    );

    // GENERAL: exactly 32 bytes (IgH), name indexes resolve to the device name.
    let g = &cats[1].data;
    assert_eq!(g.len(), 32);
    assert_eq!(string(&s, g[0]), p.device.group_type);
    assert_eq!(g[1], 0, "no image");
    assert_eq!(
        string(&s, g[2]),
        p.device.name,
        "OrderIdx: ethercrab's name"
    );
    assert_eq!(string(&s, g[3]), p.device.name, "NameIdx");
    assert_eq!(g[4], 0);
    assert_eq!(
        g[5], 0b0010_1111,
        "CoE details: SDO, SDO info, PDO assign, PDO config, CA"
    );
    assert_eq!(g[5] & 0xC0, 0, "reserved CoE bits");
    assert_eq!([g[6], g[7], g[8]], [0, 0, 0], "no FoE, EoE, SoE");
    assert_eq!(g[9], 1, "one DS402 channel");
    assert_eq!(g[0x0B], 0x04, "flags: mailbox data link layer only");
    assert_eq!(g[0x0B] & 0xE0, 0, "reserved flag bits");
    assert_eq!(string(&s, g[0x0E]), p.device.group_name);
    assert_eq!(
        u16::from_le_bytes([g[0x10], g[0x11]]),
        0x0011,
        "two MII ports"
    );
    assert!(g[0x12..].iter().all(|&b| b == 0));

    // FMMU: Outputs, Inputs, MBoxState, then only unused codes.
    let f = &cats[2].data;
    assert_eq!(&f[..3], &[1, 2, 3]);
    assert!(f[3..].iter().all(|&b| b == 0 || b == 0xFF));

    // SYNCM: 4 × 8 bytes, types 1..4.
    let sm = &cats[3].data;
    assert_eq!(sm.len(), 32);
    let sm_at = |i: usize| {
        let e = &sm[8 * i..8 * i + 8];
        (
            u16::from_le_bytes([e[0], e[1]]),
            u16::from_le_bytes([e[2], e[3]]),
            e[4],
            e[5],
            e[6],
            e[7],
        )
    };
    assert_eq!(sm_at(0), (0x1000, 256, 0x26, 0, 1, 1));
    assert_eq!(sm_at(1), (0x1100, 256, 0x22, 0, 1, 2));
    let out_len = (p.outputs_bits() / 8) as u16;
    let in_len = (p.inputs_bits() / 8) as u16;
    assert_eq!((out_len, in_len), (7, 7));
    assert_eq!(sm_at(2), (0x1200, out_len, 0x64, 0, 1, 3));
    assert_eq!(sm_at(3), (0x1600, in_len, 0x20, 0, 1, 4));
    for i in 0..4 {
        assert_eq!(sm_at(i).4 & 0xF0, 0, "reserved SM enable bits");
    }

    // PDO categories equal the default mapping.
    let tx = decode_pdos(&cats[4], &s);
    let rx = decode_pdos(&cats[5], &s);
    assert_eq!(
        rx,
        vec![DecodedPdo {
            index: 0x1600,
            sm: 2,
            flags: 0,
            name: "RxPDO 1 mapping".into(),
            entries: vec![
                (0x6040, 0, 0x06, 16),
                (0x607A, 0, 0x04, 32),
                (0x6060, 0, 0x02, 8)
            ],
        }]
    );
    assert_eq!(
        tx,
        vec![DecodedPdo {
            index: 0x1A00,
            sm: 3,
            flags: 0,
            name: "TxPDO 1 mapping".into(),
            entries: vec![
                (0x6041, 0, 0x06, 16),
                (0x6064, 0, 0x04, 32),
                (0x6061, 0, 0x02, 8)
            ],
        }]
    );
    for (pdos, sm_len) in [(&rx, out_len), (&tx, in_len)] {
        let bits: u32 = pdos
            .iter()
            .flat_map(|p| &p.entries)
            .map(|e| u32::from(e.3))
            .sum();
        assert_eq!(bits, u32::from(sm_len) * 8, "PDO bits equal the SM length");
    }

    // DC: 24 bytes per op mode.
    let dc = &cats[6].data;
    assert_eq!(dc.len(), 24 * p.dc_op_modes.len());
    let modes: Vec<(String, u16, i16)> = dc
        .chunks(24)
        .map(|m| {
            assert_eq!(&m[20..24], &[0; 4], "reserved");
            (
                string(&s, m[18]).to_string(),
                u16::from_le_bytes([m[14], m[15]]),
                i16::from_le_bytes([m[16], m[17]]),
            )
        })
        .collect();
    assert_eq!(
        modes,
        vec![
            ("FreeRun".to_string(), 0x0000, 0),
            ("DC".to_string(), 0x0300, 1)
        ]
    );
}

#[test]
fn padding_and_pdo_flags() {
    // A profile with a padded, fixed and mandatory PDO that is not assigned by default.
    let text = include_str!("../profiles/standard.toml").replace(
        "[[txpdo]]\nindex = 0x1A00",
        "[[txpdo]]\nindex = 0x1A01\nname = \"Extra\"\nsm = 3\nfixed = true\nmandatory = true\nassigned = false\n\
         entries = [{ pad = 8 }, { index = 0x6041, sub = 0, bits = 16 }, { pad = 8 }]\n\n[[txpdo]]\nindex = 0x1A00",
    );
    let p = od_gen::parse(&text, "test").unwrap();
    let img = p.sii_image();
    let cats = categories(&img);
    let s = strings(&cats[0]);
    let tx = decode_pdos(cats.iter().find(|c| c.kind == 50).unwrap(), &s);
    assert_eq!(tx.len(), 2);
    assert_eq!(tx[1].index, 0x1A01);
    assert_eq!(tx[1].sm, 0xFF, "not assigned by default");
    assert_eq!(tx[1].flags, 0x0011, "mandatory + fixed");
    assert_eq!(tx[1].entries[0], (0, 0, 0, 8), "padding entry");
    assert_eq!(tx[0].sm, 3);
}
