//! Mailbox and CoE frames as a master builds them, and the oracle every frame the drive sends
//! back must pass (ETG.1000.4 §5.6 mailbox, ETG.1000.6 §5.6 CoE).

use crate::spec::{self, coe_service, mailbox_type};

/// Mailbox header length (length u16, address u16, channel/priority u8, type/counter u8).
pub const MAILBOX_HEADER: usize = 6;
/// CoE header length.
pub const COE_HEADER: usize = 2;
/// SDO command byte + index + subindex + 4 data bytes.
pub const SDO_HEADER: usize = 8;

/// Client command specifiers (ETG.1000.6 §5.6.2, bits 5..7 of the command byte).
pub mod ccs {
    /// Download segment.
    pub const DOWNLOAD_SEGMENT: u8 = 0;
    /// Initiate download.
    pub const DOWNLOAD: u8 = 1;
    /// Initiate upload.
    pub const UPLOAD: u8 = 2;
    /// Upload segment.
    pub const UPLOAD_SEGMENT: u8 = 3;
    /// Abort transfer.
    pub const ABORT: u8 = 4;
}
/// Command byte bits: complete access, expedited, size indicated.
pub const COMPLETE_ACCESS: u8 = 1 << 4;
/// Expedited transfer.
pub const EXPEDITED: u8 = 1 << 1;
/// Size indicated.
pub const SIZE_INDICATED: u8 = 1 << 0;

/// A mailbox: header + `payload`.
pub fn mailbox(mtype: u8, counter: u8, channel: u8, payload: &[u8]) -> Vec<u8> {
    let mut m = Vec::with_capacity(MAILBOX_HEADER + payload.len());
    m.extend_from_slice(&(payload.len() as u16).to_le_bytes());
    m.extend_from_slice(&0u16.to_le_bytes());
    m.push(channel);
    m.push((mtype & 0x0F) | ((counter & 0x07) << 4));
    m.extend_from_slice(payload);
    m
}

/// A CoE mailbox of `service` with `body` after the CoE header.
pub fn coe(counter: u8, service: u8, body: &[u8]) -> Vec<u8> {
    let mut p = Vec::with_capacity(COE_HEADER + body.len());
    p.extend_from_slice(&(u16::from(service & 0x0F) << 12).to_le_bytes());
    p.extend_from_slice(body);
    mailbox(mailbox_type::COE, counter, 0, &p)
}

/// An SDO request: command, index, subindex, the 4-byte field, then `data`.
pub fn sdo(
    counter: u8,
    command: u8,
    index: u16,
    subindex: u8,
    field: [u8; 4],
    data: &[u8],
) -> Vec<u8> {
    let mut b = Vec::with_capacity(SDO_HEADER + data.len());
    b.push(command);
    b.extend_from_slice(&index.to_le_bytes());
    b.push(subindex);
    b.extend_from_slice(&field);
    b.extend_from_slice(data);
    coe(counter, coe_service::SDO_REQUEST, &b)
}

/// An expedited download of 1..=4 bytes.
pub fn sdo_download_expedited(counter: u8, index: u16, subindex: u8, data: &[u8]) -> Vec<u8> {
    let n = data.len().clamp(1, 4);
    let mut field = [0u8; 4];
    field[..n.min(data.len())].copy_from_slice(&data[..n.min(data.len())]);
    let command = (ccs::DOWNLOAD << 5) | (((4 - n) as u8) << 2) | EXPEDITED | SIZE_INDICATED;
    sdo(counter, command, index, subindex, field, &[])
}

/// What the oracle found wrong with a frame from the drive.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Violation(pub String);

fn bad<T>(what: impl Into<String>) -> Result<T, Violation> {
    Err(Violation(what.into()))
}

/// What a frame from the drive was.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reply {
    /// Mailbox error reply with this code.
    MailboxError(u16),
    /// SDO abort of `index:subindex` with this code.
    Abort { index: u16, subindex: u8, code: u32 },
    /// An SDO response (not an abort) of this server command specifier.
    Sdo { scs: u8, index: u16, subindex: u8 },
    /// An emergency.
    Emergency,
    /// SDO information: opcode.
    Info(u8),
}

/// Checks one SM1 buffer the drive filled against ETG.1000.4/ETG.1000.6 and says what it was.
pub fn check_reply(buf: &[u8]) -> Result<Reply, Violation> {
    let Some(h) = buf.get(..MAILBOX_HEADER) else {
        return bad("SM1 shorter than a mailbox header");
    };
    let len = usize::from(u16::from_le_bytes([h[0], h[1]]));
    if MAILBOX_HEADER + len > buf.len() {
        return bad(format!(
            "mailbox length {len} exceeds SM1 ({} bytes)",
            buf.len()
        ));
    }
    let counter = (h[5] >> 4) & 0x07;
    if counter == 0 {
        // ETG.1000.4 §5.6: a slave's mailbox counter runs 1..7 (0 only for a master's "no
        // counter" requests).
        return bad("slave mailbox counter 0");
    }
    let p = &buf[MAILBOX_HEADER..MAILBOX_HEADER + len];
    match h[5] & 0x0F {
        mailbox_type::ERROR => {
            if p.len() < 4 || u16::from_le_bytes([p[0], p[1]]) != 0x0001 {
                return bad(format!("malformed mailbox error reply {p:02x?}"));
            }
            let code = u16::from_le_bytes([p[2], p[3]]);
            if !spec::MAILBOX_ERROR_CODES.contains(&code) {
                return bad(format!(
                    "mailbox error code {code:#06x} not in ETG.1000.4 Table 30"
                ));
            }
            Ok(Reply::MailboxError(code))
        }
        mailbox_type::COE => check_coe(p),
        t => bad(format!("mailbox type {t} from a CoE-only drive")),
    }
}

fn check_coe(p: &[u8]) -> Result<Reply, Violation> {
    let Some(ch) = p.get(..COE_HEADER) else {
        return bad("CoE mailbox without CoE header");
    };
    let service = ch[1] >> 4;
    let body = &p[COE_HEADER..];
    match service {
        coe_service::EMERGENCY => {
            if body.len() < 8 {
                return bad(format!("emergency of {} bytes (8 needed)", body.len()));
            }
            Ok(Reply::Emergency)
        }
        coe_service::SDO_REQUEST | coe_service::SDO_RESPONSE => check_sdo(service, body),
        coe_service::SDO_INFORMATION => {
            let Some(&op) = body.first() else {
                return bad("empty SDO information");
            };
            let opcode = op & 0x7F;
            if !spec::SDO_INFO_SERVER_OPCODES.contains(&opcode) {
                return bad(format!(
                    "SDO information opcode {opcode:#04x} from a server"
                ));
            }
            if opcode == spec::SDO_INFO_ERROR {
                let Some(c) = body.get(4..8) else {
                    return bad("SDO information error without its code");
                };
                let code = u32::from_le_bytes([c[0], c[1], c[2], c[3]]);
                if !spec::SDO_ABORT_CODES.contains(&code) {
                    return bad(format!(
                        "SDO information error {code:#010x} not in Table 41"
                    ));
                }
            }
            Ok(Reply::Info(opcode))
        }
        s => bad(format!("CoE service {s} from a server")),
    }
}

fn check_sdo(service: u8, body: &[u8]) -> Result<Reply, Violation> {
    let Some(b) = body.get(..4) else {
        return bad(format!("SDO frame of {} bytes", body.len()));
    };
    let command = b[0];
    let index = u16::from_le_bytes([b[1], b[2]]);
    let subindex = b[3];
    let scs = command >> 5;
    if command == ccs::ABORT << 5 {
        let Some(c) = body.get(4..8) else {
            return bad("abort without its code");
        };
        let code = u32::from_le_bytes([c[0], c[1], c[2], c[3]]);
        if !spec::SDO_ABORT_CODES.contains(&code) {
            return bad(format!(
                "abort code {code:#010x} not in ETG.1000.6 Table 41"
            ));
        }
        return Ok(Reply::Abort {
            index,
            subindex,
            code,
        });
    }
    if service != coe_service::SDO_RESPONSE {
        return bad(format!("SDO request {command:#04x} from a server"));
    }
    match scs {
        // Upload segment response: toggle, size of unused bytes, last flag; at least 7 bytes.
        0 | 1 => {
            if body.len() < 8 {
                return bad(format!("segment response of {} bytes", body.len()));
            }
        }
        // Initiate upload response: expedited with 1..4 bytes, or normal with a size.
        2 => {
            if body.len() < 8 {
                return bad(format!("upload response of {} bytes", body.len()));
            }
            if command & EXPEDITED == 0 {
                let size = u32::from_le_bytes([body[4], body[5], body[6], body[7]]) as usize;
                let carried = body.len() - 8;
                if size < carried {
                    return bad(format!("normal upload of {size} bytes carries {carried}"));
                }
            }
        }
        // Initiate download response.
        3 => {
            if body.len() < 8 {
                return bad(format!("download response of {} bytes", body.len()));
            }
        }
        s => return bad(format!("server command specifier {s}")),
    }
    Ok(Reply::Sdo {
        scs,
        index,
        subindex,
    })
}
