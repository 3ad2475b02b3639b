//! Serving one expedited SDO request through `CoeServer::handle`: an upload of the statusword
//! 6041h and a download of the user parameter 2F00h, in OP (SDO traffic beside running process
//! data). The download target is not the controlword 6040h: it is mapped to the RxPDO, and the
//! profile (`pdo.sdo_write_to_rx_mapped = "blocked"`) refuses SDO writes to it in SAFEOP and OP
//! with abort 0x06010006; the server knows the OD RAM the RxPDO plan writes, as the slave's
//! mailbox side tells it. The request is the mailbox payload after the 6-byte mailbox header (CoE header + SDO
//! frame), the response buffer is as long as the profile's input mailbox allows; the mailbox
//! data-link layer and the PDI transfers are not included.

use core::hint::black_box;

use firmware::mailbox::coe::sdo::SDO_FRAME_LEN;
use firmware::mailbox::coe::{CoeServer, CoeService, COE_HEADER_LEN};
use firmware::mailbox::header::HEADER_LEN as MAILBOX_HEADER_LEN;
use firmware::od::Dictionary;
use firmware::pdo::{Direction, PdoPlan};
use firmware::profiles::standard::{PROFILE, RAM_SIZE};
use hal::esc::AlState;

use super::sync0_handler::MBX_TYPE_COE;
use super::{map_max, read};
use crate::harness::Harness;

/// The EtherCAT state the requests are served in.
const STATE: AlState = AlState::Op;
/// Statusword 6041h (CiA402) and the user parameter 2F00h (UDINT, not PDO-mapped), subindex 0.
pub(super) const STATUSWORD: (u16, u8) = (0x6041, 0);
pub(super) const USER_PARAMETER: (u16, u8) = (0x2F00, 0);
/// The value the download writes; any value other than the default 0.
pub(super) const USER_PARAMETER_VALUE: u32 = 0x1234_5678;
/// Profile velocity 6081h (UDINT, RxPDO-mappable, not in the default RxPDO 1600h): a download
/// to it is checked against the OD RAM the RxPDO plan writes before it is allowed (the
/// `blocked` rule), the most expensive check of an expedited download.
pub(super) const MAPPABLE_PARAMETER: (u16, u8) = (0x6081, 0);
/// The value written to 6081h (increments/s, inside its range).
pub(super) const MAPPABLE_PARAMETER_VALUE: u32 = 1_000_000;
/// Budget of an expedited SDO download (issue 13: ≤ 1,000 instructions).
const SDO_DOWNLOAD_BUDGET: u32 = 1_000;
/// Largest response buffer the benchmark provides (the standard profile's mailbox is 256 bytes).
const RESPONSE_CAPACITY: usize = 512;

/// SDO command bytes (ETG.1000.6 §5.6.2.1, §5.6.2.4): command specifier in bits 5..=7, then
/// for expedited init frames the unused-byte count `n` in bits 2..=3, `e` bit 1, `s` bit 0.
pub(super) mod command {
    const SPECIFIER_SHIFT: u8 = 5;
    const UNUSED_SHIFT: u8 = 2;
    const EXPEDITED: u8 = 1 << 1;
    const SIZE_INDICATED: u8 = 1 << 0;
    /// Unused bytes of the 4 expedited data bytes for a 2-byte value.
    const UNUSED_OF_U16: u8 = 2;
    /// Expedited 2-byte frame flags.
    const EXPEDITED_U16: u8 = (UNUSED_OF_U16 << UNUSED_SHIFT) | EXPEDITED | SIZE_INDICATED;
    /// Expedited 4-byte frame flags (no unused bytes).
    const EXPEDITED_U32: u8 = EXPEDITED | SIZE_INDICATED;

    /// Initiate upload request (ccs 2).
    pub const UPLOAD_REQUEST: u8 = 2 << SPECIFIER_SHIFT;
    /// Initiate upload response (scs 2), expedited, 2 bytes.
    pub const UPLOAD_RESPONSE_U16: u8 = (2 << SPECIFIER_SHIFT) | EXPEDITED_U16;
    /// Initiate upload response (scs 2), normal: the size in the data bytes, the value after.
    pub const UPLOAD_RESPONSE_SIZED: u8 = (2 << SPECIFIER_SHIFT) | SIZE_INDICATED;
    /// Initiate download request (ccs 1), expedited, 4 bytes.
    pub const DOWNLOAD_REQUEST_U32: u8 = (1 << SPECIFIER_SHIFT) | EXPEDITED_U32;
    /// Initiate download request (ccs 1), normal (segmented), the size in the data bytes.
    pub const DOWNLOAD_REQUEST_SIZED: u8 = (1 << SPECIFIER_SHIFT) | SIZE_INDICATED;
    /// Initiate download response (scs 3).
    pub const DOWNLOAD_RESPONSE: u8 = 3 << SPECIFIER_SHIFT;
    /// Abort transfer (cs 4): the server's refusal.
    pub const ABORT: u8 = 4 << SPECIFIER_SHIFT;
}

/// Length of an expedited request or response: CoE header + SDO frame.
pub(super) const FRAME_LEN: usize = COE_HEADER_LEN + SDO_FRAME_LEN;
/// Offset of the expedited data in a frame (CoE header, command, index, subindex).
const DATA_OFFSET: usize = COE_HEADER_LEN + 4;

/// An expedited init frame: CoE header (SDO request), command, index, subindex, 4 data bytes.
pub(super) fn request(command: u8, (index, subindex): (u16, u8), data: [u8; 4]) -> [u8; FRAME_LEN] {
    let mut frame = [0; FRAME_LEN];
    let [header_lo, header_hi] = CoeService::SdoRequest.header();
    let [index_lo, index_hi] = index.to_le_bytes();
    let [d0, d1, d2, d3] = data;
    frame.copy_from_slice(&[
        header_lo, header_hi, command, index_lo, index_hi, subindex, d0, d1, d2, d3,
    ]);
    frame
}

/// `coe` as a mailbox frame (ETG.1000.4): the header (length, address 0, channel and priority
/// 0, type CoE with counter 0) and the CoE frame.
pub(super) fn mailbox_frame(coe: &[u8; FRAME_LEN]) -> [u8; MAILBOX_HEADER_LEN + FRAME_LEN] {
    let mut frame = [0; MAILBOX_HEADER_LEN + FRAME_LEN];
    let [len_lo, len_hi] = (FRAME_LEN as u16).to_le_bytes();
    frame[0] = len_lo;
    frame[1] = len_hi;
    frame[5] = MBX_TYPE_COE;
    frame[MAILBOX_HEADER_LEN..].copy_from_slice(coe);
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
    Dictionary::new(&PROFILE.od, &mut ram).load_defaults();
    // The OD RAM the default RxPDO plan writes, as the slave's mailbox side hands it to the
    // SDO server (its "mapped to an RxPDO" check in SAFEOP and OP).
    let rx_outputs = match PdoPlan::build(&Dictionary::new(&PROFILE.od, &mut ram), Direction::Rx) {
        Ok(plan) => plan.ram_ranges(),
        Err(_) => {
            h.fail(
                "sdo",
                format_args!("the default RxPDO mapping does not build"),
            );
            return;
        }
    };
    let mut od = Dictionary::new(&PROFILE.od, &mut ram).with_rx_outputs(&rx_outputs);
    let mut server = CoeServer::new();
    let mut buffer = [0; RESPONSE_CAPACITY];
    let response_len = usize::from(PROFILE.od.device.mailbox_in.length) - MAILBOX_HEADER_LEN;
    let Some(response) = buffer.get_mut(..response_len) else {
        h.fail("sdo", format_args!("the input mailbox exceeds the buffer"));
        return;
    };

    let upload = request(command::UPLOAD_REQUEST, STATUSWORD, [0; 4]);
    let r = server.handle(&mut od, STATE, &upload, response);
    let statusword =
        read::<2>(od.ram(), super::axis_vars().and_then(|v| v.statusword)).map(u16::from_le_bytes);
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

    let download = request(
        command::DOWNLOAD_REQUEST_U32,
        USER_PARAMETER,
        USER_PARAMETER_VALUE.to_le_bytes(),
    );
    let r = server.handle(&mut od, STATE, &download, response);
    let answered = r.ok() == Some(FRAME_LEN)
        && response.get(COE_HEADER_LEN) == Some(&command::DOWNLOAD_RESPONSE)
        && server.last_write() == Some(USER_PARAMETER)
        && od.read_u32(USER_PARAMETER.0, USER_PARAMETER.1) == Some(USER_PARAMETER_VALUE);
    if !answered {
        h.fail(
            "sdo-download",
            format_args!("2F00h download was not answered"),
        );
        return;
    }
    h.bench(
        "sdo-download-expedited",
        Some(SDO_DOWNLOAD_BUDGET),
        format_args!(
            "CoeServer::handle, expedited download of 2F00h (4 bytes, not PDO-mapped) in OP"
        ),
        &mut || {
            let _ = server.handle(&mut od, STATE, black_box(&download), response);
        },
    );

    let download = request(
        command::DOWNLOAD_REQUEST_U32,
        MAPPABLE_PARAMETER,
        MAPPABLE_PARAMETER_VALUE.to_le_bytes(),
    );
    let r = server.handle(&mut od, STATE, &download, response);
    let answered = r.ok() == Some(FRAME_LEN)
        && response.get(COE_HEADER_LEN) == Some(&command::DOWNLOAD_RESPONSE)
        && od.read_u32(MAPPABLE_PARAMETER.0, MAPPABLE_PARAMETER.1)
            == Some(MAPPABLE_PARAMETER_VALUE);
    if !answered {
        h.fail(
            "sdo-download-mappable",
            format_args!("6081h download was not answered"),
        );
        return;
    }
    h.bench(
        "sdo-download-expedited-mappable",
        Some(SDO_DOWNLOAD_BUDGET),
        format_args!(
            "CoeServer::handle, expedited download of 6081h (4 bytes, RxPDO-mappable, not in \
             the active RxPDO mapping: checked against the plan's OD RAM ranges) in OP"
        ),
        &mut || {
            let _ = server.handle(&mut od, STATE, black_box(&download), response);
        },
    );

    // The same download with the largest RxPDO mapping the profile takes: the most ranges the
    // check compares.
    let entries = map_max(
        &mut Dictionary::new(&PROFILE.od, &mut ram),
        &PROFILE.od,
        Direction::Rx,
        &[],
        Some(MAPPABLE_PARAMETER),
        usize::MAX,
    );
    let rx_outputs = match PdoPlan::build(&Dictionary::new(&PROFILE.od, &mut ram), Direction::Rx) {
        Ok(plan) if plan.entries() == entries => plan.ram_ranges(),
        _ => {
            h.fail(
                "sdo",
                format_args!("the largest RxPDO mapping ({entries} entries) does not build"),
            );
            return;
        }
    };
    let mut od = Dictionary::new(&PROFILE.od, &mut ram).with_rx_outputs(&rx_outputs);
    let r = server.handle(&mut od, STATE, &download, response);
    if r.ok() != Some(FRAME_LEN)
        || response.get(COE_HEADER_LEN) != Some(&command::DOWNLOAD_RESPONSE)
    {
        h.fail(
            "sdo-download-max-mapping",
            format_args!("6081h download was not answered"),
        );
        return;
    }
    h.bench(
        "sdo-download-expedited-max-mapping",
        Some(SDO_DOWNLOAD_BUDGET),
        format_args!(
            "the same with 1600h mapping {entries} RxPDO-mappable entries ({} OD RAM ranges to \
             compare, none adjacent)",
            rx_outputs.len()
        ),
        &mut || {
            let _ = server.handle(&mut od, STATE, black_box(&download), response);
        },
    );
}
