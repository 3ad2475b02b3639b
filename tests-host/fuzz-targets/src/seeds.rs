//! Seed corpora: inputs of every target derived from recorded master traffic (ethercrab and
//! SOEM against the simulated drive, `board_sim::record`), plus, where traffic does not exercise
//! a target, inputs made from the firmware's own output (stored parameter records) or the
//! built-in profile files.
//!
//! Each derivation writes the target's input format (see the target's module): the recorded
//! frames as raw frames, the mailbox writes as mailbox operations, the SDO requests as SDO
//! operations, the AL control / SM / FMMU / DC writes as ESM operations, the downloads to the
//! PDO objects as PDO operations.

use board_sim::record::Recording;
use firmware::od::{Dictionary, Object};
use firmware::params::{max_record_len, Group, ParamStore};
use firmware::pdo;
use hal::esc::regs;

use crate::bench::{cmd, profiles, Datagram, Loaded};
use crate::coe::{ccs, COE_HEADER, COMPLETE_ACCESS, EXPEDITED, MAILBOX_HEADER, SIZE_INDICATED};
use crate::input::Encoder;
use crate::spec::{coe_service, state};
use crate::targets::{esm, frames, mailbox, params, pdo as pdo_target, sdo};

/// The datagrams of a frame a master sent (`None` if it is not an EtherCAT frame).
pub fn sent_datagrams(frame: &[u8]) -> Option<Vec<Datagram>> {
    let header = frame.get(14..16)?;
    if frame.get(12..14)? != crate::bench::ETHERTYPE_ETHERCAT.to_be_bytes() {
        return None;
    }
    let len = usize::from(u16::from_le_bytes([header[0], header[1]]) & 0x07FF);
    let mut rest = frame.get(16..16 + len)?;
    let mut out = Vec::new();
    loop {
        let h = rest.get(..10)?;
        let l = u16::from_le_bytes([h[6], h[7]]);
        let n = usize::from(l & 0x07FF);
        out.push(Datagram {
            cmd: h[0],
            adp: u16::from_le_bytes([h[2], h[3]]),
            ado: u16::from_le_bytes([h[4], h[5]]),
            data: rest.get(10..10 + n)?.to_vec(),
        });
        rest = rest.get(10 + n + 2..)?;
        if l & 0x8000 == 0 {
            return Some(out);
        }
    }
}

fn is_write(c: u8) -> bool {
    matches!(
        c,
        cmd::APWR | cmd::FPWR | cmd::BWR | cmd::APRW | cmd::FPRW | cmd::BRW
    )
}
fn is_read(c: u8) -> bool {
    matches!(c, cmd::APRD | cmd::FPRD | cmd::BRD)
}

/// The profile (index in [`profiles`]) whose SII the recording's first drive has.
pub fn profile_index(rec: &Recording) -> Option<u8> {
    profiles()
        .iter()
        .position(|p| p.sii == rec.sii)
        .and_then(|i| u8::try_from(i).ok())
}

/// Splits a long op list into inputs of at most `per_input` ops: the first window and up to
/// `more` others spread over the rest.
fn windows(head: &[u8], ops: &[Vec<u8>], per_input: usize, more: usize) -> Vec<Vec<u8>> {
    let chunks: Vec<&[Vec<u8>]> = ops.chunks(per_input.max(1)).collect();
    let mut picked: Vec<usize> = vec![0];
    if chunks.len() > 1 && more > 0 {
        let step = (chunks.len() - 1).div_ceil(more).max(1);
        picked.extend((1..chunks.len()).step_by(step));
    }
    picked
        .into_iter()
        .filter_map(|i| chunks.get(i))
        .map(|c| {
            let mut v = head.to_vec();
            for op in c.iter() {
                v.extend_from_slice(op);
            }
            v
        })
        .collect()
}

/// A mailbox write's bytes, cut to what its header says.
fn mailbox_bytes(data: &[u8]) -> &[u8] {
    let len = data
        .get(..2)
        .map_or(0, |l| usize::from(u16::from_le_bytes([l[0], l[1]])));
    &data[..(MAILBOX_HEADER + len).min(data.len())]
}

/// Seeds of the `frames` target.
pub fn frames_seeds(rec: &Recording, p: u8) -> Vec<Vec<u8>> {
    let mut ops = Vec::new();
    let mut last = rec.frames.first().map_or(0, |f| f.0);
    for (t, f) in &rec.frames {
        let gap_us = (t.saturating_sub(last) / 1_000).min(u64::from(u16::MAX)) as u16;
        last = *t;
        if gap_us > 0 {
            let mut e = Encoder::default();
            e.u8(frames::op::WAIT).u16(gap_us);
            ops.push(e.bytes);
        }
        let mut e = Encoder::default();
        e.u8(frames::op::RAW).chunk(f);
        ops.push(e.bytes);
    }
    let mut out = windows(&[p, 0], &ops, frames::MAX_OPS, 0);
    // Later traffic, from a drive brought to OP.
    out.extend(windows(
        &[p, 3],
        ops.get(frames::MAX_OPS..).unwrap_or(&[]),
        frames::MAX_OPS,
        2,
    ));
    out
}

/// Mailbox writes, SM1 reads and AL control writes of a recording, in order.
enum MailboxEvent {
    Write(Vec<u8>),
    Poll,
    AlControl(u16),
}

fn mailbox_events(rec: &Recording, profile: &Loaded) -> Vec<MailboxEvent> {
    let d = &profile.fw.od.device;
    let mut out = Vec::new();
    for (_, f) in &rec.frames {
        for dg in sent_datagrams(f).unwrap_or_default() {
            if is_write(dg.cmd) && dg.ado == d.mailbox_out.start {
                out.push(MailboxEvent::Write(mailbox_bytes(&dg.data).to_vec()));
            } else if is_read(dg.cmd) && dg.ado == d.mailbox_in.start {
                out.push(MailboxEvent::Poll);
            } else if is_write(dg.cmd) && dg.ado == regs::AL_CONTROL.addr && dg.data.len() >= 2 {
                out.push(MailboxEvent::AlControl(u16::from_le_bytes([
                    dg.data[0], dg.data[1],
                ])));
            }
        }
    }
    out
}

/// Seeds of the `mailbox` target.
pub fn mailbox_seeds(rec: &Recording, p: u8) -> Vec<Vec<u8>> {
    let profile = &profiles()[usize::from(p)];
    let ops: Vec<Vec<u8>> = mailbox_events(rec, profile)
        .into_iter()
        .map(|ev| {
            let mut e = Encoder::default();
            match ev {
                MailboxEvent::Write(m) => e.u8(mailbox::op::WRITE_PADDED).chunk(&m),
                MailboxEvent::Poll => e.u8(mailbox::op::POLL),
                MailboxEvent::AlControl(c) => e.u8(mailbox::op::AL_CONTROL).u16(c),
            };
            e.bytes
        })
        .collect();
    windows(&[p, 1], &ops, mailbox::MAX_OPS, 3)
}

/// Encodes an object choice of the `sdo` target as "any index, any subindex".
fn sdo_object(e: &mut Encoder, index: u16, subindex: u8) {
    e.u8(3).u16(0).u16(index).u8(subindex);
}

/// One recorded mailbox write as an `sdo` operation (`None`: not a CoE request it knows).
fn sdo_op(m: &[u8]) -> Option<Vec<u8>> {
    if m.get(5)? & 0x0F != crate::spec::mailbox_type::COE {
        return None;
    }
    let p = m.get(MAILBOX_HEADER..)?;
    let service = p.get(1)? >> 4;
    let body = p.get(COE_HEADER..)?;
    let mut e = Encoder::default();
    match service {
        coe_service::SDO_REQUEST => {
            let command = *body.first()?;
            let index = u16::from_le_bytes([*body.get(1)?, *body.get(2)?]);
            let subindex = *body.get(3).unwrap_or(&0);
            let ca = u8::from(command & COMPLETE_ACCESS != 0);
            match command >> 5 {
                ccs::DOWNLOAD if command & EXPEDITED != 0 => {
                    let n = if command & SIZE_INDICATED != 0 {
                        4 - ((command >> 2) & 3)
                    } else {
                        4
                    };
                    e.u8(sdo::op::DOWNLOAD_EXPEDITED);
                    sdo_object(&mut e, index, subindex);
                    e.u8(ca | ((n - 1) << 1)).raw(body.get(4..8)?);
                }
                ccs::DOWNLOAD => {
                    e.u8(sdo::op::DOWNLOAD);
                    sdo_object(&mut e, index, subindex);
                    e.u8(ca).chunk(body.get(8..).unwrap_or(&[]));
                }
                ccs::UPLOAD => {
                    e.u8(sdo::op::UPLOAD);
                    sdo_object(&mut e, index, subindex);
                    e.u8(ca);
                }
                ccs::DOWNLOAD_SEGMENT => {
                    let unused = usize::from((command >> 1) & 7);
                    let data = body.get(1..)?;
                    let data = &data[..data.len().saturating_sub(if data.len() == 7 {
                        unused
                    } else {
                        0
                    })];
                    e.u8(sdo::op::DOWNLOAD_SEGMENT)
                        .u8(command & 0x11)
                        .chunk(data);
                }
                ccs::UPLOAD_SEGMENT => {
                    e.u8(sdo::op::UPLOAD_SEGMENT).u8(command & 0x10);
                }
                ccs::ABORT => {
                    e.u8(sdo::op::ABORT);
                    sdo_object(&mut e, index, subindex);
                    e.u8(2).raw(body.get(4..8)?);
                }
                _ => return None,
            }
        }
        coe_service::SDO_INFORMATION => {
            let index = body
                .get(4..6)
                .map_or(0, |b| u16::from_le_bytes([b[0], b[1]]));
            match body.first()? & 0x7F {
                0x01 => {
                    e.u8(sdo::op::OD_LIST);
                    sdo_object(&mut e, 0, 0);
                    e.u8(*body.get(4).unwrap_or(&1));
                }
                0x03 => {
                    e.u8(sdo::op::OBJECT_DESCRIPTION);
                    sdo_object(&mut e, index, 0);
                }
                0x05 => {
                    e.u8(sdo::op::ENTRY_DESCRIPTION);
                    sdo_object(&mut e, index, *body.get(6).unwrap_or(&0));
                    e.u8(*body.get(7).unwrap_or(&0));
                }
                _ => return None,
            }
        }
        _ => return None,
    }
    Some(e.bytes)
}

/// Seeds of the `sdo` target.
pub fn sdo_seeds(rec: &Recording, p: u8) -> Vec<Vec<u8>> {
    let profile = &profiles()[usize::from(p)];
    let mut ops = Vec::new();
    for ev in mailbox_events(rec, profile) {
        match ev {
            MailboxEvent::Write(m) => {
                if let Some(op) = sdo_op(&m) {
                    ops.push(op);
                    ops.push(vec![sdo::op::POLL]);
                }
            }
            MailboxEvent::AlControl(c) => {
                if let Some(i) = mailbox::START_STATES
                    .iter()
                    .position(|&s| u16::from(s) == c & 0x0F)
                {
                    ops.push(vec![sdo::op::STATE, i as u8]);
                }
            }
            MailboxEvent::Poll => {}
        }
    }
    windows(&[p, 1], &ops, sdo::MAX_OPS, 3)
}

/// Seeds of the `esm` target.
pub fn esm_seeds(rec: &Recording, p: u8) -> Vec<Vec<u8>> {
    let mut ops = Vec::new();
    let mut last = rec.frames.first().map_or(0, |f| f.0);
    let sm_block = regs::SM_BASE..regs::SM_BASE + 4 * regs::SM_LEN;
    let fmmu_block = regs::FMMU_BASE..regs::FMMU_BASE + 8 * regs::FMMU_LEN;
    for (t, f) in &rec.frames {
        let gap = (t.saturating_sub(last) / 20_000).min(255) as u8;
        last = *t;
        if gap > 0 {
            ops.push(vec![esm::op::WAIT, gap]);
        }
        for dg in sent_datagrams(f).unwrap_or_default() {
            let mut e = Encoder::default();
            if is_write(dg.cmd) && dg.ado == regs::AL_CONTROL.addr && dg.data.len() >= 2 {
                e.u8(esm::op::AL_CONTROL).u8(1).raw(&dg.data[..2]);
            } else if is_write(dg.cmd)
                && sm_block.contains(&dg.ado)
                && (dg.ado - regs::SM_BASE) % regs::SM_LEN == 0
            {
                for (k, block) in dg.data.chunks_exact(8).enumerate() {
                    let n = (dg.ado - regs::SM_BASE) / regs::SM_LEN + k as u16;
                    e.u8(esm::op::SM).u8(n as u8).u8(1).raw(block);
                }
            } else if is_write(dg.cmd)
                && fmmu_block.contains(&dg.ado)
                && (dg.ado - regs::FMMU_BASE) % regs::FMMU_LEN == 0
            {
                for (k, block) in dg.data.chunks_exact(16).enumerate() {
                    let n = (dg.ado - regs::FMMU_BASE) / regs::FMMU_LEN + k as u16;
                    e.u8(esm::op::FMMU).u8(n as u8).u8(esm::FMMU_RAW).raw(block);
                }
            } else if is_write(dg.cmd) && dg.ado == regs::DC_SYNC0_CYCLE.addr && dg.data.len() >= 4
            {
                e.u8(esm::op::DC).u8(1).raw(&dg.data[..4]);
            } else if matches!(dg.cmd, cmd::LRW | cmd::LWR) {
                e.u8(esm::op::PROCESS_DATA)
                    .u8(dg.data.first().copied().unwrap_or(0));
            }
            if !e.bytes.is_empty() {
                ops.push(e.bytes);
            }
        }
    }
    windows(&[p], &ops, esm::MAX_OPS, 2)
}

/// The objects the `pdo` target chooses mapping objects from, in its order.
fn mapping_objects(profile: &Loaded) -> Vec<&'static Object> {
    profile
        .fw
        .od
        .objects
        .iter()
        .filter(|o| pdo::RX_MAPPING.contains(&o.index) || pdo::TX_MAPPING.contains(&o.index))
        .collect()
}

/// Seeds of the `pdo` target: the recorded downloads to the PDO objects, per direction.
pub fn pdo_seeds(rec: &Recording, p: u8) -> Vec<Vec<u8>> {
    let profile = &profiles()[usize::from(p)];
    let maps = mapping_objects(profile);
    let mut writes: Vec<(u16, u8, u32)> = Vec::new();
    for ev in mailbox_events(rec, profile) {
        let MailboxEvent::Write(m) = ev else { continue };
        let Some(body) = m.get(MAILBOX_HEADER + COE_HEADER..) else {
            continue;
        };
        let (Some(&command), Some(i)) = (body.first(), body.get(1..3)) else {
            continue;
        };
        let index = u16::from_le_bytes([i[0], i[1]]);
        let sub = body.get(3).copied().unwrap_or(0);
        if command >> 5 != ccs::DOWNLOAD {
            continue;
        }
        let width = if index == pdo::RX_ASSIGN || index == pdo::TX_ASSIGN {
            2
        } else {
            4
        };
        if command & EXPEDITED != 0 {
            let v = body
                .get(4..8)
                .map_or(0, |b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]));
            writes.push((index, sub, v));
        } else if command & COMPLETE_ACCESS != 0 {
            // Complete access: subindex 0 as 16 bits, then every subindex.
            let data = body.get(8..).unwrap_or(&[]);
            for (k, c) in data.chunks(width).enumerate() {
                let mut b = [0u8; 4];
                b[..c.len()].copy_from_slice(c);
                let s = if k == 0 { 0 } else { k as u8 };
                let v = u32::from_le_bytes(b);
                writes.push((index, s, if k == 0 { v & 0xFF } else { v }));
            }
        }
    }
    let mut out = Vec::new();
    for (dir, assign) in [(0u8, pdo::RX_ASSIGN), (1, pdo::TX_ASSIGN)] {
        let mut e = Encoder::default();
        e.u8(p).u8(dir);
        for &(index, sub, v) in &writes {
            if index == assign {
                if sub == 0 {
                    e.u8(pdo_target::op::ASSIGN_COUNT).u8(v as u8);
                } else {
                    e.u8(pdo_target::op::ASSIGN).u8(1).u16(v as u16).u8(sub - 1);
                }
            } else if let Some(k) = maps.iter().position(|o| o.index == index) {
                if sub == 0 {
                    e.u8(pdo_target::op::MAPPING_COUNT)
                        .u16(k as u16)
                        .u8(v as u8);
                } else {
                    e.u8(pdo_target::op::MAPPING)
                        .u16(k as u16)
                        .u8(3)
                        .u32(v)
                        .u8(sub - 1);
                }
            }
        }
        e.u8(pdo_target::op::END);
        e.raw(&[0x5A; 64]);
        out.push(e.bytes);
    }
    out
}

/// Seeds of the `params` target: per profile, erased flash, and one and two records the
/// store itself wrote (the defaults saved with "save all").
pub fn params_seeds() -> Vec<Vec<u8>> {
    let mut out = Vec::new();
    for (p, profile) in profiles().iter().enumerate() {
        let od_profile = &profile.fw.od;
        let slot_size = max_record_len(od_profile).div_ceil(2048).max(1) * 2048;
        let mut ram = vec![0u8; firmware::profiles::MAX_RAM_SIZE];
        let mut od = Dictionary::new(od_profile, &mut ram);
        od.load_defaults();
        let flash = params::Flash::erased(slot_size);
        let mut store = ParamStore::<params::Flash>::new(flash);
        out.push(vec![
            p as u8,
            params::slot_kind::ERASED,
            params::slot_kind::ERASED,
        ]);
        for _ in 0..2 {
            if store.store(&od, Group::All).is_err() {
                break;
            }
            let mut e = Encoder::default();
            e.u8(p as u8);
            for slot in store.storage().slots() {
                let used = slot.iter().rposition(|&b| b != 0xFF).map_or(0, |i| i + 1);
                e.u8(params::slot_kind::RAW).chunk(&slot[..used]);
            }
            out.push(e.bytes);
        }
    }
    out
}

/// Seeds of the `profile` target: the built-in profile files.
pub fn profile_seeds(profiles_dir: &std::path::Path) -> Vec<Vec<u8>> {
    let mut files: Vec<_> = std::fs::read_dir(profiles_dir)
        .map(|rd| rd.filter_map(|e| e.ok().map(|e| e.path())).collect())
        .unwrap_or_default();
    files.retain(|p: &std::path::PathBuf| p.extension().is_some_and(|x| x == "toml"));
    files.sort();
    files.iter().filter_map(|f| std::fs::read(f).ok()).collect()
}

/// FNV-1a 64 of an input: its file name in a corpus.
pub fn name(data: &[u8]) -> String {
    let mut h: u64 = 0xCBF2_9CE4_8422_2325;
    for &b in data {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0100_0000_01B3);
    }
    format!("seed-{h:016x}")
}

/// The state values, re-exported for the seeds' start bytes.
pub const PREOP: u8 = state::PREOP;
