//! Target `profile`: od-gen's profile loader on arbitrary TOML text (a user's own profile).
//!
//! Input: the text (invalid UTF-8 replaced). Seeds are the built-in profiles.
//!
//! Oracle: loading ends in a profile or an error, never a panic; an error's message is
//! printable; an accepted profile generates its SII image with a good configuration-area CRC
//! (ETG.2010 / `hal::esc::sii::crc8` over words 0..6), its ESI XML and its Rust object
//! dictionary.

use crate::coe::Violation;

/// Bytes of the SII configuration area the CRC covers, and the CRC's byte.
const SII_CRC_COVERS: usize = 14;

/// Runs one input.
pub fn run(data: &[u8]) -> Result<(), Violation> {
    let text = String::from_utf8_lossy(data);
    let profile = match od_gen::parse(&text, "fuzz.toml") {
        Ok(p) => p,
        Err(e) => {
            let _ = e.to_string();
            return Ok(());
        }
    };
    let sii = profile.sii_image();
    let (Some(area), Some(&crc)) = (sii.get(..SII_CRC_COVERS), sii.get(SII_CRC_COVERS)) else {
        return Err(Violation(format!("SII image of {} bytes", sii.len())));
    };
    if hal::esc::sii::crc8(area) != crc {
        return Err(Violation("SII configuration area CRC is wrong".into()));
    }
    if sii.len() % 2 != 0 {
        return Err(Violation("SII image is not whole words".into()));
    }
    let esi = profile.esi_xml();
    if !esi.starts_with("<?xml") {
        return Err(Violation(
            "ESI does not start with an XML declaration".into(),
        ));
    }
    let _ = od_gen::rust::generate(std::slice::from_ref(&profile));
    Ok(())
}
