//! Reading an emergency message out of the drive's input mailbox (SM1) as SOEM does: the SM1
//! status "mailbox full", then the whole mailbox (ETG.1000.4 sync manager registers; ETG.1000.6
//! mailbox and CoE headers).

use ethercrab::{Command, MainDevice};

use crate::FIRST_STATION;

/// SM1 status register (ETG.1000.4 Table 58: SM n at 0x0800 + 8n, status at +5), bit 3
/// "mailbox full".
const SM1_STATUS: u16 = 0x080D;
const MAILBOX_FULL: u8 = 0x08;
/// Mailbox header (6 bytes) type 3 = CoE; CoE header service 1 = emergency.
const MAILBOX_HEADER: usize = 6;
const TYPE_COE: u8 = 3;
const COE_EMERGENCY: u16 = 1;

/// An emergency message: the EMCY code, the error register 1001h and the manufacturer field.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Emergency {
    /// Bytes 0–1.
    pub code: u16,
    /// Byte 2: 1001h.
    pub error_register: u8,
    /// Bytes 3–7.
    pub data: [u8; 5],
}

/// The emergency SM1 holds, if it holds a mailbox (read whole, which empties it); an error for a
/// mailbox that is not a CoE emergency.
pub async fn read(md: &MainDevice<'_>, sm1_start: u16) -> Result<Option<Emergency>, String> {
    let status: u8 = Command::fprd(FIRST_STATION, SM1_STATUS)
        .receive(md)
        .await
        .map_err(|e| format!("SM1 status: {e:?}"))?;
    if status & MAILBOX_FULL == 0 {
        return Ok(None);
    }
    let mb: [u8; 256] = Command::fprd(FIRST_STATION, sm1_start)
        .receive(md)
        .await
        .map_err(|e| format!("SM1: {e:?}"))?;
    if mb[5] & 0x0F != TYPE_COE {
        return Err(format!("mailbox type {}", mb[5] & 0x0F));
    }
    let coe = &mb[MAILBOX_HEADER..MAILBOX_HEADER + 10];
    if u16::from_le_bytes([coe[0], coe[1]]) >> 12 != COE_EMERGENCY {
        return Err(format!(
            "CoE service {}",
            u16::from_le_bytes([coe[0], coe[1]]) >> 12
        ));
    }
    Ok(Some(Emergency {
        code: u16::from_le_bytes([coe[2], coe[3]]),
        error_register: coe[4],
        data: [coe[5], coe[6], coe[7], coe[8], coe[9]],
    }))
}
