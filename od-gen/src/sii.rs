//! The SII EEPROM image (ETG.2010 layout as documented in `reference/esi-sii.md` §2).
//!
//! Layout: header words 0x00–0x3F, then the categories STRINGS (10), GENERAL (30), FMMU (40),
//! SYNCM (41), TXPDO (50), RXPDO (51), DC (60) and END (0xFFFF); the image is padded with 0xFF
//! to `eeprom.byte_size`, which word 0x3E records as `byte_size / 128 - 1`.
//!
//! String table: 1 = device name (SOEM shows string 1 as the slave name), 2 = order number,
//! 3 = group type, 4 = group name, then DC op mode names and descriptions, PDO names and PDO
//! entry names, de-duplicated. General.OrderIdx and General.NameIdx both point at the device
//! name: ethercrab shows OrderIdx as the name and NameIdx as the description.

use crate::model::{protocol, Pdo, Profile, Sm};

/// Category types (ETG.2010 Table 5 as quoted in esi-sii.md §2.2).
pub mod category {
    /// Strings.
    pub const STRINGS: u16 = 10;
    /// General.
    pub const GENERAL: u16 = 30;
    /// FMMU usage.
    pub const FMMU: u16 = 40;
    /// SyncManagers.
    pub const SYNCM: u16 = 41;
    /// TxPDOs.
    pub const TXPDO: u16 = 50;
    /// RxPDOs.
    pub const RXPDO: u16 = 51;
    /// DC op modes.
    pub const DC: u16 = 60;
    /// End of the category chain.
    pub const END: u16 = 0xFFFF;
}

/// CRC-8 of the SII configuration area (polynomial 0x07, initial value 0xFF; ESC datasheet
/// Sec. I, SII word 7): the one implementation in `hal`, re-exported.
pub use hal::esc::sii::crc8;

/// Bytes 0..13 of the image (words 0..6), as ESI `Eeprom/ConfigData` carries them.
pub fn config_data(p: &Profile) -> [u8; 14] {
    let e = &p.eeprom;
    let words = [
        u16::from(e.pdi_control) | u16::from(e.esc_config) << 8,
        e.pdi_config,
        e.sync_impulse_len,
        e.pdi_config2,
        e.station_alias,
        e.reserved[0],
        e.reserved[1],
    ];
    let mut out = [0u8; 14];
    for (chunk, w) in out.chunks_exact_mut(2).zip(words) {
        chunk.copy_from_slice(&w.to_le_bytes());
    }
    out
}

/// The 8 bytes of ESI `Eeprom/BootStrap` (SII words 0x14–0x17), if the profile has a
/// bootstrap mailbox.
pub fn bootstrap(p: &Profile) -> Option<[u8; 8]> {
    let (o, i) = (p.sm.boot_out?, p.sm.boot_in?);
    let mut out = [0u8; 8];
    for (chunk, w) in out
        .chunks_exact_mut(2)
        .zip([o.start, o.length, i.start, i.length])
    {
        chunk.copy_from_slice(&w.to_le_bytes());
    }
    Some(out)
}

/// The SII string table (1-based; index 0 means "no string").
#[derive(Debug, Default, Clone)]
pub struct Strings(Vec<String>);

impl Strings {
    /// The index of `s`, adding it if new; 0 for the empty string.
    pub fn add(&mut self, s: &str) -> u8 {
        if s.is_empty() {
            return 0;
        }
        let pos = match self.0.iter().position(|x| x == s) {
            Some(i) => i,
            None => {
                self.0.push(s.to_string());
                self.0.len() - 1
            }
        };
        u8::try_from(pos + 1).unwrap_or(0)
    }
    /// Number of strings.
    pub fn len(&self) -> usize {
        self.0.len()
    }
    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
    fn body(&self) -> Vec<u8> {
        let mut v = vec![u8::try_from(self.0.len()).unwrap_or(u8::MAX)];
        for s in self.0.iter().take(255) {
            let b = s.as_bytes();
            let n = b.len().min(255);
            v.push(u8::try_from(n).unwrap_or(u8::MAX));
            v.extend_from_slice(&b[..n]);
        }
        v
    }
}

fn push_u16(v: &mut Vec<u8>, x: u16) {
    v.extend_from_slice(&x.to_le_bytes());
}

fn set_u16(v: &mut [u8], word: usize, x: u16) {
    if let Some(d) = v.get_mut(2 * word..2 * word + 2) {
        d.copy_from_slice(&x.to_le_bytes());
    }
}

fn push_u32(v: &mut Vec<u8>, x: u32) {
    v.extend_from_slice(&x.to_le_bytes());
}

fn push_category(v: &mut Vec<u8>, kind: u16, mut body: Vec<u8>) {
    if body.len() % 2 != 0 {
        body.push(0);
    }
    push_u16(v, kind);
    push_u16(v, u16::try_from(body.len() / 2).unwrap_or(u16::MAX));
    v.extend_from_slice(&body);
}

/// The string table in its final order (see the module docs).
pub fn strings(p: &Profile) -> Strings {
    let mut s = Strings::default();
    s.add(&p.device.name);
    s.add(&p.device.order_number);
    s.add(&p.device.group_type);
    s.add(&p.device.group_name);
    for m in &p.dc_op_modes {
        s.add(&m.name);
        s.add(&m.description);
    }
    for pdo in p.tx_pdos.iter().chain(&p.rx_pdos) {
        s.add(&pdo.name);
        for e in &pdo.entries {
            s.add(&e.name);
        }
    }
    s
}

fn physical_ports(physics: &str) -> u16 {
    physics.chars().take(4).enumerate().fold(0, |acc, (i, c)| {
        let nibble = match c {
            'Y' => 1,
            'K' => 3,
            'H' => 4,
            _ => 0,
        };
        acc | nibble << (4 * i)
    })
}

fn general(p: &Profile, s: &mut Strings) -> Vec<u8> {
    let name = s.add(&p.device.name);
    let mut g = vec![0u8; 32];
    g[0] = s.add(&p.device.group_type);
    g[1] = 0; // no image
    g[2] = name; // OrderIdx: ethercrab's device name
    g[3] = name; // NameIdx
    g[5] = p.mailbox.coe.bits();
    g[6] = u8::from(p.mailbox.protocols & protocol::FOE != 0);
    g[7] = u8::from(p.mailbox.protocols & protocol::EOE != 0);
    g[8] = 0; // SoE channels
    g[9] = p.device.ds402_channels;
    g[0x0B] = u8::from(p.mailbox.data_link_layer) << 2;
    g[0x0E] = s.add(&p.device.group_name); // as TwinCAT-written images do
    g[0x10..0x12].copy_from_slice(&physical_ports(&p.device.physics).to_le_bytes());
    g
}

fn syncm(p: &Profile) -> Vec<u8> {
    let mut v = Vec::new();
    let mut sm = |s: Sm, kind: u8| {
        push_u16(&mut v, s.start);
        push_u16(&mut v, s.length);
        v.push(s.control);
        v.push(0); // status
        v.push(u8::from(s.length > 0)); // enable
        v.push(kind);
    };
    sm(p.sm.mailbox_out, 1);
    sm(p.sm.mailbox_in, 2);
    sm(p.sm.outputs, 3);
    sm(p.sm.inputs, 4);
    v
}

fn pdos(pdos: &[Pdo], s: &mut Strings) -> Vec<u8> {
    let mut v = Vec::new();
    for pdo in pdos {
        push_u16(&mut v, pdo.index);
        v.push(u8::try_from(pdo.entries.len()).unwrap_or(u8::MAX));
        v.push(if pdo.assigned { pdo.sm } else { 0xFF });
        v.push(0); // DC sync
        v.push(s.add(&pdo.name));
        push_u16(&mut v, u16::from(pdo.mandatory) | u16::from(pdo.fixed) << 4);
        for e in &pdo.entries {
            push_u16(&mut v, e.index);
            v.push(e.subindex);
            v.push(s.add(&e.name));
            v.push(
                e.data_type
                    .map_or(0, |d| u8::try_from(d.code()).unwrap_or(0)),
            );
            v.push(u8::try_from(e.bits).unwrap_or(u8::MAX));
            push_u16(&mut v, 0);
        }
    }
    v
}

fn dc(p: &Profile, s: &mut Strings) -> Vec<u8> {
    let mut v = Vec::new();
    for m in &p.dc_op_modes {
        push_u32(&mut v, m.sync0_cycle_ns);
        push_u32(&mut v, m.sync0_shift_ns);
        push_u32(&mut v, m.sync1_shift_ns);
        v.extend_from_slice(&m.sync1_factor.to_le_bytes());
        push_u16(&mut v, m.assign_activate);
        v.extend_from_slice(&m.sync0_factor.to_le_bytes());
        v.push(s.add(&m.name));
        v.push(s.add(&m.description));
        v.extend_from_slice(&[0; 4]);
    }
    v
}

/// The image up to and including the END marker (no padding).
pub fn content(p: &Profile) -> Vec<u8> {
    let mut v = vec![0u8; 128];
    v[..14].copy_from_slice(&config_data(p));
    v[hal::esc::sii::CRC_OFFSET] = crc8(&v[..hal::esc::sii::CRC_COVERED]);
    let words: [(usize, u16); 7] = [
        (0x18, p.sm.mailbox_out.start),
        (0x19, p.sm.mailbox_out.length),
        (0x1A, p.sm.mailbox_in.start),
        (0x1B, p.sm.mailbox_in.length),
        (0x1C, p.mailbox.protocols),
        (
            0x3E,
            u16::try_from((p.eeprom.byte_size / 128).saturating_sub(1)).unwrap_or(u16::MAX),
        ),
        (0x3F, 1),
    ];
    for (word, x) in words {
        set_u16(&mut v, word, x);
    }
    for (word, x) in [
        (0x08, p.vendor.id),
        (0x0A, p.device.product_code),
        (0x0C, p.device.revision),
        (0x0E, p.device.serial),
    ] {
        set_u16(&mut v, word, x as u16);
        set_u16(&mut v, word + 1, (x >> 16) as u16);
    }
    if let (Some(o), Some(i)) = (p.sm.boot_out, p.sm.boot_in) {
        for (word, x) in [
            (0x14, o.start),
            (0x15, o.length),
            (0x16, i.start),
            (0x17, i.length),
        ] {
            set_u16(&mut v, word, x);
        }
    }

    // Build the bodies first so that the string table is complete, then emit STRINGS first.
    let mut s = strings(p);
    let general = general(p, &mut s);
    let fmmu = vec![0x01, 0x02, 0x03, 0x00]; // Outputs, Inputs, MBoxState, unused
    let syncm = syncm(p);
    let tx = pdos(&p.tx_pdos, &mut s);
    let rx = pdos(&p.rx_pdos, &mut s);
    let dc = dc(p, &mut s);
    push_category(&mut v, category::STRINGS, s.body());
    push_category(&mut v, category::GENERAL, general);
    push_category(&mut v, category::FMMU, fmmu);
    push_category(&mut v, category::SYNCM, syncm);
    if !p.tx_pdos.is_empty() {
        push_category(&mut v, category::TXPDO, tx);
    }
    if !p.rx_pdos.is_empty() {
        push_category(&mut v, category::RXPDO, rx);
    }
    if !p.dc_op_modes.is_empty() {
        push_category(&mut v, category::DC, dc);
    }
    push_u16(&mut v, category::END);
    v
}

/// The full EEPROM image: [`content`] padded with 0xFF to `eeprom.byte_size`.
pub fn image(p: &Profile) -> Vec<u8> {
    let mut v = content(p);
    if v.len() < p.eeprom.byte_size {
        v.resize(p.eeprom.byte_size, 0xFF);
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc8_check_value_and_real_images() {
        // CRC-8 poly 0x07 init 0xFF over "123456789" (computed independently: 0xFB).
        assert_eq!(crc8(b"123456789"), 0xFB);
        // Config areas of real images (esi-sii.md §2.1): Somanet, SOES lan9252, AX58100.
        let mut a = [0u8; 14];
        a[..4].copy_from_slice(&[0x08, 0x0E, 0x02, 0x88]);
        assert_eq!(crc8(&a), 0x2F);
        let mut b = [0u8; 14];
        b[..2].copy_from_slice(&[0x80, 0x02]);
        assert_eq!(crc8(&b), 0xC6);
        let c = [0x05, 0x06, 0x00, 0x44, 0x64, 0, 0, 0, 0, 0, 0x1A, 0, 0, 0];
        assert_eq!(crc8(&c), 0xA9);
    }

    #[test]
    fn physics_nibbles() {
        assert_eq!(physical_ports("YY"), 0x0011);
        assert_eq!(physical_ports("KK"), 0x0033);
        assert_eq!(physical_ports("Y K"), 0x0301);
    }
}
