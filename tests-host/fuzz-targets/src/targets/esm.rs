//! Target `esm`: the EtherCAT state machine under arbitrary AL control sequences and
//! SyncManager, FMMU and DC configurations written by the master, with process data flowing.
//!
//! Input: profile, then operations: AL control (a state with or without error acknowledge, or
//! any value), a SyncManager block (the profile's layout with chosen changes, or any bytes),
//! an FMMU block, the mailbox set-up in one step, DC SYNC0 activation with a cycle time (the
//! profile's or any), outputs written to SM2 and inputs read from SM3, time passing.
//!
//! Oracle: the ESM oracle ([`crate::esm_watch`]: only requested, allowed, one-step upward
//! transitions, error codes from Table 11); in PREOP and above SM0/SM1 are the SII's mailbox
//! layout, and in SAFEOP and above SM2/SM3 have the length of the mapped process data (the
//! checks ETG.1000.6 §6.4.2 asks a slave to make before it enters the state).

use hal::esc::regs::{self, fmmu_offset, sm_offset};
use hal::esc::SmActivate;

use crate::bench::{profile_of, Bench};
use crate::coe::Violation;
use crate::esm_watch::EsmWatch;
use crate::input::Input;
use crate::spec::{self, state};
use crate::targets::mailbox::status;

/// Operations per input.
pub const MAX_OPS: usize = 64;

/// Operation codes of the input.
pub mod op {
    /// AL control.
    pub const AL_CONTROL: u8 = 0;
    /// A SyncManager block.
    pub const SM: u8 = 1;
    /// An FMMU block.
    pub const FMMU: u8 = 2;
    /// SM0/SM1 as the SII says.
    pub const MAILBOX: u8 = 3;
    /// DC SYNC0 activation and cycle.
    pub const DC: u8 = 4;
    /// Outputs to SM2, inputs from SM3.
    pub const PROCESS_DATA: u8 = 5;
    /// Let time pass.
    pub const WAIT: u8 = 6;
    /// SM2/SM3 for the default mapping in one step.
    pub const PROCESS_SMS: u8 = 7;
    /// Number of operations.
    pub const COUNT: u8 = 8;
}

/// FMMU operation flag: the 16 bytes follow as they are.
pub const FMMU_RAW: u8 = 0x20;

/// The shortest SYNC0 cycle an input may set, ns. An ESC generates SYNC0 at any period the
/// master writes; below a few µs no MCU can take the interrupts, the board's SYNC0 context
/// never ends and the simulation (which runs a firmware cycle per pulse) crawls: the first
/// fuzz run found a 256 ns cycle that took 40 s to simulate (libFuzzer timeout). The firmware
/// refuses every cycle below its profile's shortest (31.25 µs at best) with 0x0035, which
/// cycles from this bound up still exercise.
const MIN_SYNC0_CYCLE_NS: u32 = 10_000;

/// AL control error acknowledge bit.
const ACK: u16 = 0x10;

/// Runs one input.
pub fn run(data: &[u8]) -> Result<(), Violation> {
    let mut input = Input::new(data);
    let profile = profile_of(input.u8());
    let mut bench = Bench::new(profile);
    let mut watch = EsmWatch::new(status(&mut bench)?, bench.last_request);
    let device = &profile.fw.od.device;
    let layouts = [
        device.mailbox_out,
        device.mailbox_in,
        device.outputs,
        device.inputs,
    ];
    let mut ops = 0;
    while !input.is_empty() && ops < MAX_OPS {
        ops += 1;
        match input.u8() % op::COUNT {
            op::AL_CONTROL => {
                let flags = input.u8();
                let control = if flags & 1 != 0 {
                    input.u16()
                } else {
                    let states = [
                        state::INIT,
                        state::PREOP,
                        state::BOOT,
                        state::SAFEOP,
                        state::OP,
                    ];
                    let s = u16::from(states[usize::from(flags >> 1) % states.len()]);
                    if flags & 0x80 != 0 {
                        s | ACK
                    } else {
                        s
                    }
                };
                watch.requested(control);
                bench.request(control);
            }
            op::SM => {
                let n = input.u8() % 8;
                let flags = input.u8();
                let mut block = [0u8; 8];
                if flags & 1 != 0 || n >= 4 {
                    block.copy_from_slice(&{
                        let mut b = [0u8; 8];
                        for x in b.iter_mut() {
                            *x = input.u8();
                        }
                        b
                    });
                } else {
                    let l = layouts[usize::from(n)];
                    let default_len = match n {
                        2 => profile.outputs_len,
                        3 => profile.inputs_len,
                        _ => l.length,
                    };
                    let start = if flags & 2 != 0 { input.u16() } else { l.start };
                    let len = if flags & 4 != 0 {
                        input.u16()
                    } else {
                        default_len
                    };
                    let control = if flags & 8 != 0 {
                        input.u8()
                    } else {
                        l.control
                    };
                    block[0..2].copy_from_slice(&start.to_le_bytes());
                    block[2..4].copy_from_slice(&len.to_le_bytes());
                    block[usize::from(sm_offset::CONTROL)] = control;
                    block[usize::from(sm_offset::ACTIVATE)] = if flags & 0x10 != 0 {
                        0
                    } else {
                        SmActivate::ENABLE
                    };
                }
                bench.write(regs::sm(n).addr, &block);
            }
            op::FMMU => {
                let n = input.u8() % 8;
                let flags = input.u8();
                let mut block = [0u8; 16];
                if flags & FMMU_RAW != 0 {
                    for b in block.iter_mut() {
                        *b = input.u8();
                    }
                    bench.write(regs::fmmu(n).addr, &block);
                    let now = status(&mut bench)?;
                    watch.observe(now)?;
                    continue;
                }
                let (len, phys, ty) = if flags & 1 == 0 {
                    (profile.outputs_len, device.outputs.start, 2u8)
                } else {
                    (profile.inputs_len, device.inputs.start, 1u8)
                };
                block[0..4].copy_from_slice(&input.u32().to_le_bytes());
                block[4..6].copy_from_slice(
                    &(if flags & 2 != 0 { input.u16() } else { len }).to_le_bytes(),
                );
                block[usize::from(fmmu_offset::LOGICAL_END_BIT)] = 7;
                block[8..10].copy_from_slice(
                    &(if flags & 4 != 0 { input.u16() } else { phys }).to_le_bytes(),
                );
                block[usize::from(fmmu_offset::TYPE)] =
                    if flags & 8 != 0 { input.u8() } else { ty };
                block[usize::from(fmmu_offset::ACTIVATE)] = u8::from(flags & 0x10 == 0);
                bench.write(regs::fmmu(n).addr, &block);
            }
            op::MAILBOX => bench.configure_mailbox(),
            op::PROCESS_SMS => bench.configure_process_data(),
            op::DC => {
                let flags = input.u8();
                let sync = &device.sync;
                let cycle = if flags & 1 != 0 {
                    input.u32().max(MIN_SYNC0_CYCLE_NS)
                } else if let Some(&c) = sync
                    .allowed_cycles_ns
                    .get(usize::from(flags >> 1) % sync.allowed_cycles_ns.len().max(1))
                {
                    c
                } else {
                    sync.min_cycle_ns.max(250_000)
                };
                bench.write(regs::DC_SYNC0_CYCLE.addr, &cycle.to_le_bytes());
                let start = bench.segment.now_ns() + 1_000_000;
                bench.write(regs::DC_START_TIME.addr, &start.to_le_bytes());
                // Cyclic operation + SYNC0 (ETG.1000.4 0x0981 bits 0 and 1), or any value.
                let activation = if flags & 0x40 != 0 { input.u8() } else { 0x03 };
                bench.write(regs::DC_ACTIVATION.addr, &[activation]);
            }
            op::PROCESS_DATA => {
                let out = vec![input.u8(); usize::from(profile.outputs_len)];
                if !out.is_empty() {
                    bench.write(device.outputs.start, &out);
                }
                let _ = bench.read(device.inputs.start, usize::from(profile.inputs_len));
            }
            _ => bench.segment.advance(u64::from(input.u8()) * 20_000),
        }
        let now = status(&mut bench)?;
        watch.observe(now)?;
        if !now.error {
            check_sms(&mut bench, now.state)?;
        }
    }
    Ok(())
}

/// In PREOP and above the mailbox SMs are the SII's; in SAFEOP and above the process-data SMs
/// have the mapped lengths (while no error is indicated: a slave reports an SM it found wrong
/// with the error flag, e.g. SAFEOP + 0x001D, before the master's next request).
fn check_sms(bench: &mut Bench, st: u8) -> Result<(), Violation> {
    let device = &bench.profile.fw.od.device;
    let mut expect = Vec::new();
    if spec::rank(st) >= spec::rank(state::PREOP) && st != state::BOOT {
        expect.push((0u8, device.mailbox_out.start, device.mailbox_out.length));
        expect.push((1, device.mailbox_in.start, device.mailbox_in.length));
    }
    if spec::rank(st) >= spec::rank(state::SAFEOP) {
        if bench.profile.outputs_len > 0 {
            expect.push((2, device.outputs.start, bench.profile.outputs_len));
        }
        if bench.profile.inputs_len > 0 {
            expect.push((3, device.inputs.start, bench.profile.inputs_len));
        }
    }
    for (n, start, len) in expect {
        let Some(b) = bench.read(regs::sm(n).addr, 8) else {
            return Err(Violation("SM registers not readable".into()));
        };
        let (s, l) = (
            u16::from_le_bytes([b[0], b[1]]),
            u16::from_le_bytes([b[2], b[3]]),
        );
        let enabled = b[usize::from(sm_offset::ACTIVATE)] & SmActivate::ENABLE != 0;
        if s != start || l != len || !enabled {
            return Err(Violation(format!(
                "in state {st:#x} SM{n} is {s:#06x}+{l} enabled={enabled}, expected {start:#06x}+{len}"
            )));
        }
    }
    Ok(())
}
