//! Target `sdo`: the SDO server, SDO information and complete access, with requests a master
//! could send (valid mailbox and CoE headers, the profile's own objects and subindexes most of
//! the time), so the input reaches the services instead of the header checks.
//!
//! Input: profile, start state, then operations: expedited / normal / segmented downloads,
//! uploads and upload segments, each optionally with complete access; aborts; the three SDO
//! information requests; SM1 reads; state requests; time passing.
//!
//! Oracle: every reply passes [`crate::coe::check_reply`]; an SDO response or abort names an
//! index a request named (or 0: an abort outside a transfer); the ESM oracle holds.

use crate::bench::Bench;
use crate::coe::{
    self, ccs, check_reply, Reply, Violation, COMPLETE_ACCESS, EXPEDITED, SIZE_INDICATED,
};
use crate::input::Input;
use crate::spec::{self, coe_service};
use crate::targets::mailbox::{started, status, START_STATES};

/// Operations per input.
pub const MAX_OPS: usize = 48;

/// Operation codes of the input.
pub mod op {
    /// Expedited download of 1..=4 bytes.
    pub const DOWNLOAD_EXPEDITED: u8 = 0;
    /// Normal (initiate) download of a chunk.
    pub const DOWNLOAD: u8 = 1;
    /// Initiate upload.
    pub const UPLOAD: u8 = 2;
    /// Download segment.
    pub const DOWNLOAD_SEGMENT: u8 = 3;
    /// Upload segment.
    pub const UPLOAD_SEGMENT: u8 = 4;
    /// Abort transfer.
    pub const ABORT: u8 = 5;
    /// SDO information: Get OD List.
    pub const OD_LIST: u8 = 6;
    /// SDO information: Get Object Description.
    pub const OBJECT_DESCRIPTION: u8 = 7;
    /// SDO information: Get Entry Description.
    pub const ENTRY_DESCRIPTION: u8 = 8;
    /// Read SM1.
    pub const POLL: u8 = 9;
    /// Request a state.
    pub const STATE: u8 = 10;
    /// Let time pass.
    pub const WAIT: u8 = 11;
    /// Number of operations.
    pub const COUNT: u8 = 12;
}

/// SDO information opcodes a client sends (ETG.1000.6 Table 44).
mod info_request {
    pub const OD_LIST: u8 = 0x01;
    pub const OBJECT_DESCRIPTION: u8 = 0x03;
    pub const ENTRY_DESCRIPTION: u8 = 0x05;
}

/// Runs one input.
pub fn run(data: &[u8]) -> Result<(), Violation> {
    let mut input = Input::new(data);
    let (mut bench, mut watch) = started(&mut input)?;
    let profile = bench.profile;
    let mut named: Vec<u16> = vec![0];
    let body_room = bench
        .mailbox_out_len()
        .saturating_sub(coe::MAILBOX_HEADER + coe::COE_HEADER);
    let mut ops = 0;
    while !input.is_empty() && ops < MAX_OPS {
        ops += 1;
        let code = input.u8() % op::COUNT;
        let counter = bench.next_counter();
        let request = match code {
            op::DOWNLOAD_EXPEDITED..=op::UPLOAD | op::ABORT => {
                let (index, subindex) = object(&mut input, profile);
                named.push(index);
                let flags = input.u8();
                let ca = if flags & 1 != 0 { COMPLETE_ACCESS } else { 0 };
                Some(match code {
                    op::DOWNLOAD_EXPEDITED => {
                        let n = usize::from(flags >> 1) % 4 + 1;
                        let mut field = [0u8; 4];
                        field.copy_from_slice(&input.u32().to_le_bytes());
                        let command = (ccs::DOWNLOAD << 5)
                            | (((4 - n) as u8) << 2)
                            | ca
                            | EXPEDITED
                            | SIZE_INDICATED;
                        coe::sdo(counter, command, index, subindex, field, &[])
                    }
                    op::DOWNLOAD => {
                        let data = input.chunk(body_room.saturating_sub(coe::SDO_HEADER));
                        // The complete size: the data's length, or (flag) another one.
                        let size = if flags & 2 != 0 {
                            input.u32()
                        } else {
                            data.len() as u32
                        };
                        let command = (ccs::DOWNLOAD << 5) | ca | SIZE_INDICATED;
                        coe::sdo(counter, command, index, subindex, size.to_le_bytes(), data)
                    }
                    op::UPLOAD => coe::sdo(
                        counter,
                        (ccs::UPLOAD << 5) | ca,
                        index,
                        subindex,
                        [0; 4],
                        &[],
                    ),
                    _ => {
                        let code = if flags & 2 != 0 {
                            input.u32()
                        } else {
                            spec::SDO_ABORT_CODES[input.choose(spec::SDO_ABORT_CODES.len())]
                        };
                        coe::sdo(
                            counter,
                            ccs::ABORT << 5,
                            index,
                            subindex,
                            code.to_le_bytes(),
                            &[],
                        )
                    }
                })
            }
            op::DOWNLOAD_SEGMENT | op::UPLOAD_SEGMENT => {
                let flags = input.u8();
                let toggle = flags & 0x10;
                let mut body = Vec::new();
                if code == op::DOWNLOAD_SEGMENT {
                    let data = input.chunk(body_room.saturating_sub(1));
                    let unused = 7usize.saturating_sub(data.len()) as u8;
                    let last = flags & 1;
                    body.push((ccs::DOWNLOAD_SEGMENT << 5) | toggle | (unused << 1) | last);
                    body.extend_from_slice(data);
                    body.resize(body.len().max(8), 0);
                } else {
                    body.push((ccs::UPLOAD_SEGMENT << 5) | toggle);
                    body.resize(8, 0);
                }
                Some(coe::coe(counter, coe_service::SDO_REQUEST, &body))
            }
            op::OD_LIST | op::OBJECT_DESCRIPTION | op::ENTRY_DESCRIPTION => {
                let (index, subindex) = object(&mut input, profile);
                let mut body = Vec::new();
                match code {
                    op::OD_LIST => {
                        body.extend_from_slice(&[info_request::OD_LIST, 0, 0, 0]);
                        body.extend_from_slice(&(u16::from(input.u8()) % 8).to_le_bytes());
                    }
                    op::OBJECT_DESCRIPTION => {
                        body.extend_from_slice(&[info_request::OBJECT_DESCRIPTION, 0, 0, 0]);
                        body.extend_from_slice(&index.to_le_bytes());
                    }
                    _ => {
                        body.extend_from_slice(&[info_request::ENTRY_DESCRIPTION, 0, 0, 0]);
                        body.extend_from_slice(&index.to_le_bytes());
                        body.push(subindex);
                        body.push(input.u8());
                    }
                }
                Some(coe::coe(counter, coe_service::SDO_INFORMATION, &body))
            }
            op::POLL => {
                poll_named(&mut bench, &named)?;
                None
            }
            op::STATE => {
                let s = START_STATES[usize::from(input.u8()) % START_STATES.len()];
                watch.requested(u16::from(s));
                bench.request(u16::from(s));
                None
            }
            _ => {
                bench.segment.advance(u64::from(input.u8()) * 100_000);
                None
            }
        };
        if let Some(m) = request {
            bench.mailbox_write(&m);
        }
        watch.observe(status(&mut bench)?)?;
    }
    for _ in 0..16 {
        poll_named(&mut bench, &named)?;
    }
    Ok(())
}

/// An object of the profile and one of its subindexes, or (flags) any index or subindex.
fn object(input: &mut Input<'_>, profile: &crate::bench::Loaded) -> (u16, u8) {
    let flags = input.u8();
    let objects = profile.fw.od.objects;
    let obj = &objects[input.choose(objects.len())];
    let index = if flags & 1 != 0 {
        input.u16()
    } else {
        obj.index
    };
    let subindex = if flags & 2 != 0 {
        input.u8()
    } else {
        obj.entries
            .get(input.choose(obj.entries.len()))
            .map_or(0, |e| e.subindex)
    };
    (index, subindex)
}

/// Reads SM1 and checks the reply, and that an SDO reply names a requested index.
fn poll_named(bench: &mut Bench, named: &[u16]) -> Result<(), Violation> {
    let Some(buf) = bench.mailbox_read() else {
        return Ok(());
    };
    match check_reply(&buf)? {
        Reply::Abort { index, .. }
        | Reply::Sdo {
            scs: 2 | 3, index, ..
        } if !named.contains(&index) => Err(Violation(format!(
            "reply names {index:#06x}, which no request named"
        ))),
        _ => Ok(()),
    }
}
