//! Target `frames`: whole Ethernet frames into the simulated ESC with the firmware behind it,
//! as a master (or a broken network) could send them.
//!
//! Input: profile, start state, then operations: a raw frame of any bytes; a frame of one to
//! four datagrams with any command, addressed at the registers and buffers a master uses (AL
//! control and status, SyncManagers, FMMUs, DC, SII EEPROM interface, watchdogs, the mailbox
//! and process-data buffers) or anywhere, with any length and data; time passing.
//!
//! Oracle: a frame comes back with its length unchanged; the datagrams of a structured frame
//! come back in number, with the data of a write command untouched and a working counter a
//! single slave can give (read or write 1, read-write 3); the ESM oracle holds throughout.

use hal::esc::regs;

use crate::bench::{cmd, replies, Bench, Datagram, MAX_DATAGRAM_DATA};
use crate::coe::Violation;
use crate::input::Input;
use crate::targets::mailbox::{started, status};

/// Operations per input.
pub const MAX_OPS: usize = 32;
/// Longest Ethernet frame (without FCS).
const MAX_FRAME: usize = 1514;

/// Operation codes of the input.
pub mod op {
    /// Raw bytes as a frame.
    pub const RAW: u8 = 0;
    /// A frame of datagrams.
    pub const DATAGRAMS: u8 = 1;
    /// Let time pass.
    pub const WAIT: u8 = 2;
    /// Number of operations.
    pub const COUNT: u8 = 3;
}

/// Runs one input.
pub fn run(data: &[u8]) -> Result<(), Violation> {
    let mut input = Input::new(data);
    let (mut bench, mut watch) = started(&mut input)?;
    let profile = bench.profile;
    let d = &profile.fw.od.device;
    let targets: [u16; 20] = [
        regs::AL_CONTROL.addr,
        regs::AL_STATUS.addr,
        regs::AL_STATUS_CODE.addr,
        regs::STATION_ADDRESS.addr,
        regs::DL_CONTROL.addr,
        regs::RX_ERROR_COUNTERS.addr,
        regs::WATCHDOG_DIVIDER.addr,
        regs::WATCHDOG_TIME_PD.addr,
        regs::EEPROM_CONFIG.addr,
        regs::EEPROM_CONTROL.addr,
        regs::fmmu(0).addr,
        regs::fmmu(1).addr,
        regs::sm(0).addr,
        regs::sm(2).addr,
        regs::DC_SYSTEM_TIME.addr,
        regs::DC_ACTIVATION.addr,
        d.mailbox_out.start,
        d.mailbox_in.start,
        d.outputs.start,
        d.inputs.start,
    ];
    let mut ops = 0;
    while !input.is_empty() && ops < MAX_OPS {
        ops += 1;
        match input.u8() % op::COUNT {
            op::RAW => {
                let frame = input.chunk(MAX_FRAME);
                if let Some(reply) = bench.segment.process_frame(frame) {
                    if reply.len() != frame.len() {
                        return Err(Violation(format!(
                            "a frame of {} bytes came back with {}",
                            frame.len(),
                            reply.len()
                        )));
                    }
                }
            }
            op::DATAGRAMS => {
                let count = usize::from(input.u8() % 4) + 1;
                let mut dgs = Vec::with_capacity(count);
                for _ in 0..count {
                    let c = cmd::ALL[input.choose(cmd::ALL.len())];
                    let flags = input.u8();
                    let adp = if flags & 1 != 0 { input.u16() } else { 0 };
                    let ado = if flags & 2 != 0 {
                        input.u16()
                    } else {
                        targets[input.choose(targets.len())].wrapping_add(u16::from(input.u8() % 8))
                    };
                    let len = if flags & 4 != 0 {
                        usize::from(input.u16()) % (MAX_DATAGRAM_DATA / count)
                    } else {
                        usize::from(input.u8() % 64) + 1
                    };
                    let data = (0..len).map(|_| input.u8()).collect();
                    dgs.push(Datagram {
                        cmd: c,
                        adp,
                        ado,
                        data,
                    });
                }
                check_datagrams(&mut bench, &dgs)?;
            }
            _ => bench.segment.advance(u64::from(input.u16()) * 1_000),
        }
        // A raw frame may have written AL control: what it holds now is the master's request.
        if let Some(c) = bench.read(regs::AL_CONTROL.addr, 2) {
            watch.requested(u16::from_le_bytes([c[0], c[1]]));
        }
        watch.observe(status(&mut bench)?)?;
    }
    Ok(())
}

/// Sends a frame of `dgs` and checks what comes back.
fn check_datagrams(bench: &mut Bench, dgs: &[Datagram]) -> Result<(), Violation> {
    let sent = crate::bench::frame(dgs);
    let Some(reply) = bench.segment.process_frame(&sent) else {
        return Err(Violation("a well-formed frame did not come back".into()));
    };
    let Some(back) = replies(&reply) else {
        return Err(Violation("the returned frame does not parse".into()));
    };
    if back.len() != dgs.len() {
        return Err(Violation(format!(
            "{} datagrams sent, {} back",
            dgs.len(),
            back.len()
        )));
    }
    for (i, (dg, (data, wkc))) in dgs.iter().zip(&back).enumerate() {
        let write_only = matches!(dg.cmd, cmd::APWR | cmd::FPWR | cmd::BWR | cmd::LWR);
        if write_only && data[..] != dg.data[..] {
            return Err(Violation(format!(
                "datagram {i} (write {}) came back changed",
                dg.cmd
            )));
        }
        let max_wkc = match dg.cmd {
            cmd::APRW | cmd::FPRW | cmd::BRW | cmd::LRW => 3,
            0 => 0,
            _ => 1,
        };
        if *wkc > max_wkc {
            return Err(Violation(format!(
                "datagram {i} (command {}) working counter {wkc} from one slave",
                dg.cmd
            )));
        }
    }
    Ok(())
}
