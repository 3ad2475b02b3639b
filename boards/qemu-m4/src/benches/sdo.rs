//! Serving one expedited SDO request through `CoeServer::handle`: an upload of the statusword
//! 6041h and a download of the controlword 6040h, in OP (SDO traffic beside running process
//! data). The request is the mailbox payload after the 6-byte mailbox header (CoE header + SDO
//! frame), the response buffer is as long as the profile's input mailbox allows; the mailbox
//! data-link layer and the PDI transfers are not included.

use core::hint::black_box;

use firmware::mailbox::coe::sdo::SDO_FRAME_LEN;
use firmware::mailbox::coe::{CoeServer, CoeService, COE_HEADER_LEN};
use firmware::mailbox::header::HEADER_LEN as MAILBOX_HEADER_LEN;
use firmware::od::Dictionary;
use firmware::profiles::standard::{PROFILE, RAM_SIZE};
use hal::esc::AlState;

use super::read;
use crate::harness::Harness;

/// The EtherCAT state the requests are served in.
const STATE: AlState = AlState::Op;
/// Controlword 6040h and statusword 6041h (CiA402), subindex 0.
const CONTROLWORD: (u16, u8) = (0x6040, 0);
const STATUSWORD: (u16, u8) = (0x6041, 0);
/// The controlword value the download writes (enable operation).
const CONTROLWORD_VALUE: u16 = 0x000F;
/// Largest response buffer the benchmark provides (the standard profile's mailbox is 256 bytes).
const RESPONSE_CAPACITY: usize = 512;

/// SDO command bytes (ETG.1000.6 §5.6.2.1, §5.6.2.4): command specifier in bits 5..=7, then
/// for expedited init frames the unused-byte count `n` in bits 2..=3, `e` bit 1, `s` bit 0.
mod command {
    const SPECIFIER_SHIFT: u8 = 5;
    const UNUSED_SHIFT: u8 = 2;
    const EXPEDITED: u8 = 1 << 1;
    const SIZE_INDICATED: u8 = 1 << 0;
    /// Unused bytes of the 4 expedited data bytes for a 2-byte value.
    const UNUSED_OF_U16: u8 = 2;
    /// Expedited 2-byte frame flags.
    const EXPEDITED_U16: u8 = (UNUSED_OF_U16 << UNUSED_SHIFT) | EXPEDITED | SIZE_INDICATED;

    /// Initiate upload request (ccs 2).
    pub const UPLOAD_REQUEST: u8 = 2 << SPECIFIER_SHIFT;
    /// Initiate upload response (scs 2), expedited, 2 bytes.
    pub const UPLOAD_RESPONSE_U16: u8 = (2 << SPECIFIER_SHIFT) | EXPEDITED_U16;
    /// Initiate download request (ccs 1), expedited, 2 bytes.
    pub const DOWNLOAD_REQUEST_U16: u8 = (1 << SPECIFIER_SHIFT) | EXPEDITED_U16;
    /// Initiate download response (scs 3).
    pub const DOWNLOAD_RESPONSE: u8 = 3 << SPECIFIER_SHIFT;
}

/// Length of an expedited request or response: CoE header + SDO frame.
const FRAME_LEN: usize = COE_HEADER_LEN + SDO_FRAME_LEN;
/// Offset of the expedited data in a frame (CoE header, command, index, subindex).
const DATA_OFFSET: usize = COE_HEADER_LEN + 4;

/// An expedited init frame: CoE header (SDO request), command, index, subindex, 4 data bytes.
fn request(command: u8, (index, subindex): (u16, u8), data: [u8; 4]) -> [u8; FRAME_LEN] {
    let mut frame = [0; FRAME_LEN];
    let [header_lo, header_hi] = CoeService::SdoRequest.header();
    let [index_lo, index_hi] = index.to_le_bytes();
    let [d0, d1, d2, d3] = data;
    frame.copy_from_slice(&[
        header_lo, header_hi, command, index_lo, index_hi, subindex, d0, d1, d2, d3,
    ]);
    frame
}

/// The expedited 2-byte value of a response, if it has `command` and the expected length.
fn response_u16(result: Result<usize, impl Sized>, response: &[u8], command: u8) -> Option<u16> {
    if result.ok()? != FRAME_LEN || *response.get(COE_HEADER_LEN)? != command {
        return None;
    }
    read::<2>(response, Some(DATA_OFFSET as u16)).map(u16::from_le_bytes)
}

/// Measures the upload and the download.
pub fn run(h: &mut Harness) {
    let mut ram = [0; RAM_SIZE];
    let mut od = Dictionary::new(&PROFILE, &mut ram);
    od.load_defaults();
    let mut server = CoeServer::new();
    let mut buffer = [0; RESPONSE_CAPACITY];
    let response_len = usize::from(PROFILE.device.mailbox_in.length) - MAILBOX_HEADER_LEN;
    let Some(response) = buffer.get_mut(..response_len) else {
        h.fail("sdo", format_args!("the input mailbox exceeds the buffer"));
        return;
    };

    let upload = request(command::UPLOAD_REQUEST, STATUSWORD, [0; 4]);
    let r = server.handle(&mut od, STATE, &upload, response);
    let statusword = read::<2>(od.ram(), PROFILE.vars.statusword).map(u16::from_le_bytes);
    if statusword.is_none() || response_u16(r, response, command::UPLOAD_RESPONSE_U16) != statusword
    {
        h.fail("sdo-upload", format_args!("6041h upload was not answered"));
        return;
    }
    h.bench(
        "sdo-upload-expedited",
        None,
        format_args!("CoeServer::handle, expedited upload of 6041h (2 bytes) in OP"),
        &mut || {
            let _ = server.handle(&mut od, STATE, black_box(&upload), response);
        },
    );

    let [v0, v1] = CONTROLWORD_VALUE.to_le_bytes();
    let download = request(command::DOWNLOAD_REQUEST_U16, CONTROLWORD, [v0, v1, 0, 0]);
    let r = server.handle(&mut od, STATE, &download, response);
    let answered = r.ok() == Some(FRAME_LEN)
        && response.get(COE_HEADER_LEN) == Some(&command::DOWNLOAD_RESPONSE)
        && server.last_write() == Some(CONTROLWORD)
        && read::<2>(od.ram(), PROFILE.vars.controlword) == Some([v0, v1]);
    if !answered {
        h.fail(
            "sdo-download",
            format_args!("6040h download was not answered"),
        );
        return;
    }
    h.bench(
        "sdo-download-expedited",
        None,
        format_args!("CoeServer::handle, expedited download of 6040h (2 bytes) in OP"),
        &mut || {
            let _ = server.handle(&mut od, STATE, black_box(&download), response);
        },
    );
}
