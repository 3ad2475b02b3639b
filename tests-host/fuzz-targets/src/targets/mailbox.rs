//! Target `mailbox`: the mailbox data-link layer and the CoE server behind it, from the bus.
//!
//! Input: profile (any of the built-in ones, so every mailbox size), the state to bring the
//! drive to (INIT..OP), then operations: raw writes of any length anywhere into the SM0 buffer,
//! mailboxes with arbitrary headers (type, counter, channel, length field) and payloads, reads
//! of SM1, the repeat request (SM1 toggle), AL control writes of any value, time passing.
//!
//! Oracle: every frame the drive puts in SM1 passes [`crate::coe::check_reply`] (a mailbox
//! error reply with a Table 30 code, or a CoE frame: an SDO response well formed for its
//! command, an abort with a Table 41 code, an emergency, SDO information); the ESM oracle
//! ([`crate::esm_watch`]) holds after every operation.

use hal::esc::regs::{self, sm_offset};
use hal::esc::SmActivate;

use crate::bench::{profile_of, Bench};
use crate::coe::{self, check_reply, Violation};
use crate::esm_watch::EsmWatch;
use crate::input::Input;
use crate::spec::state;

/// Operations per input (bounds the time one input takes).
pub const MAX_OPS: usize = 64;
/// SM1 polls at the end, to drain queued replies.
const DRAIN_POLLS: usize = 16;

/// The states a run starts in.
pub const START_STATES: [u8; 4] = [state::INIT, state::PREOP, state::SAFEOP, state::OP];

/// Operation codes of the input.
pub mod op {
    /// Padded mailbox write of a raw chunk.
    pub const WRITE_PADDED: u8 = 0;
    /// Raw write of a chunk at an offset into the SM0 buffer.
    pub const WRITE_AT: u8 = 1;
    /// A mailbox with a chosen header.
    pub const MAILBOX: u8 = 2;
    /// Read SM1.
    pub const POLL: u8 = 3;
    /// Toggle the SM1 repeat request.
    pub const REPEAT: u8 = 4;
    /// AL control write.
    pub const AL_CONTROL: u8 = 5;
    /// Let time pass (byte × 50 µs).
    pub const WAIT: u8 = 6;
    /// Number of operations.
    pub const COUNT: u8 = 7;
}

/// Runs one input.
pub fn run(data: &[u8]) -> Result<(), Violation> {
    let mut input = Input::new(data);
    let (mut bench, mut watch) = started(&mut input)?;
    let profile = bench.profile;
    let mbx_len = bench.mailbox_out_len();
    let mut ops = 0;
    while !input.is_empty() && ops < MAX_OPS {
        ops += 1;
        match input.u8() % op::COUNT {
            op::WRITE_PADDED => {
                let chunk = input.chunk(mbx_len);
                bench.mailbox_write(chunk);
            }
            op::WRITE_AT => {
                let offset = usize::from(input.u16()) % mbx_len.max(1);
                let chunk = input.chunk(mbx_len - offset);
                let at = profile.fw.od.device.mailbox_out.start + offset as u16;
                bench.write(at, chunk);
            }
            op::MAILBOX => {
                let mtype = input.u8();
                let counter = input.u8();
                let channel = input.u8();
                let len_field = input.u8();
                let payload = input.chunk(mbx_len);
                let mut m = coe::mailbox(mtype, counter, channel, payload);
                if len_field & 0x80 != 0 {
                    // A length field that lies about the payload.
                    m[..2].copy_from_slice(&input.u16().to_le_bytes());
                }
                bench.mailbox_write(&m);
            }
            op::POLL => poll(&mut bench)?,
            op::REPEAT => toggle_repeat(&mut bench),
            op::AL_CONTROL => {
                let control = input.u16();
                watch.requested(control);
                bench.request(control);
            }
            _ => bench.segment.advance(u64::from(input.u8()) * 50_000),
        }
        watch.observe(status(&mut bench)?)?;
    }
    for _ in 0..DRAIN_POLLS {
        poll(&mut bench)?;
    }
    Ok(())
}

/// The start every bus target shares: the profile and the state (INIT..OP) the first two input
/// bytes choose, the drive brought there, and the ESM oracle watching from there on.
pub fn started(input: &mut Input<'_>) -> Result<(Bench, EsmWatch), Violation> {
    let profile = profile_of(input.u8());
    let start = START_STATES[usize::from(input.u8()) % START_STATES.len()];
    let mut bench = Bench::new(profile);
    bench.bring_to(start);
    let watch = EsmWatch::new(status(&mut bench)?, bench.last_request);
    Ok((bench, watch))
}

/// The AL status, which a drive on the bus always answers.
pub fn status(bench: &mut Bench) -> Result<crate::bench::Status, Violation> {
    bench
        .status()
        .ok_or_else(|| Violation("AL status read got no working counter".into()))
}

/// Reads SM1 if full and checks the frame.
pub fn poll(bench: &mut Bench) -> Result<(), Violation> {
    if let Some(buf) = bench.mailbox_read() {
        check_reply(&buf)?;
    }
    Ok(())
}

/// The master's repeat request: toggles SM1's activate bit 1 (ETG.1000.4 §5.6.3).
pub fn toggle_repeat(bench: &mut Bench) {
    let at = regs::sm(1).addr + sm_offset::ACTIVATE;
    if let Some(a) = bench.read(at, 1) {
        bench.write(at, &[a[0] ^ SmActivate::REPEAT_REQUEST]);
    }
}
