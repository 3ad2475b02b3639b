//! The whole SYNC0 handler as the board runs it: `firmware::sync0::on_sync0` on the slave's
//! core in OP (supervision, SM2 read and RxPDO unpack, CiA402 and the drive, TxPDO pack and SM3
//! write), with the real generated `standard` profile and its default mapping. The PDI is a RAM
//! image of the ESC ([`RamEsc`]), so the PDI bus time is excluded, as the budget says.
//!
//! Measured twice: with the mailbox idle, and while the slave's mailbox side holds a half-done
//! segmented SDO download (a download init of 2F00h announcing 4 bytes and carrying none). The
//! handler reaches only the core, so both must cost the same: mailbox traffic cannot delay or
//! lengthen the SYNC0 path.

use core::fmt;
use core::hint::black_box;

use firmware::cia402::pds::{controlword, PdsState};
use firmware::od::{Dictionary, SmLayout};
use firmware::pdo::{Direction, PdoPlan, MAX_IMAGE};
use firmware::profiles::standard::{INPUTS_SIZE, OUTPUTS_SIZE, PROFILE, RAM_SIZE};
use firmware::slave::{EventJob, MailboxSide};
use firmware::sync0::on_sync0;
use firmware::DriveCore;
use hal::esc::{
    regs, AlEvent, AlState, DcActivation, SmActivate, SmConfig, SmControl, SmPdiControl, SmStatus,
};
use hal::pdi::{EscPdi, PdiError, PdiErrorKind};

use super::master_outputs;
use super::sdo::{command, mailbox_frame, request, USER_PARAMETER};
use crate::harness::Harness;

/// DESIGN.md §6: SYNC0 handler (PDO unpack, CiA402, PDO pack; PDI bus time excluded).
const SYNC0_HANDLER_BUDGET: u32 = 2_000;
/// ESC address space the image covers: registers and the process RAM the profile uses.
const ESC_IMAGE: usize = 0x2000;
/// CiA402 device-control commands from power-on to operation enabled (IEC 61800-7-201 Table 5).
const SHUTDOWN: u16 = controlword::ENABLE_VOLTAGE | controlword::QUICK_STOP;
const SWITCH_ON: u16 = SHUTDOWN | controlword::SWITCH_ON;
const ENABLE_OPERATION: u16 = SWITCH_ON | controlword::ENABLE_OPERATION;
const POWER_UP: [u16; 4] = [0, SHUTDOWN, SWITCH_ON, ENABLE_OPERATION];
/// The DC SYNC0 cycle of the benchmarks that run the drive in DC mode, ns: one that every
/// profile accepts.
pub(super) const DC_CYCLE_NS: u32 = 1_000_000;
/// Requests of OP in DC mode (with a SYNC0 cycle between them) before giving up.
const MAX_OP_REQUESTS: u32 = 100;
/// Mailbox header (ETG.1000.4): length, address, channel/priority, type (CoE = 3) / counter.
pub(super) const MBX_TYPE_COE: u8 = 0x03;

/// A PDI access outside the image.
#[derive(Debug)]
pub(super) struct OutOfImage;

impl PdiError for OutOfImage {
    fn kind(&self) -> PdiErrorKind {
        PdiErrorKind::OutOfRange
    }
}

/// The PDI transfers a [`RamEsc`] that tallies them saw: what the bus time of an ET1100 SPI
/// depends on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) struct PdiTally {
    /// Reads, and the data bytes they moved.
    pub(super) reads: u32,
    pub(super) read_bytes: u32,
    /// Writes, and the data bytes they moved.
    pub(super) writes: u32,
    pub(super) write_bytes: u32,
}

impl PdiTally {
    /// Records the tally as `META` records `pdi_reads`, `pdi_read_bytes`, `pdi_writes` and
    /// `pdi_write_bytes`, each followed by `suffix` (the report's load model reads them).
    pub(super) fn record(&self, h: &mut Harness, suffix: fmt::Arguments<'_>) {
        for (key, value) in [
            ("pdi_reads", self.reads),
            ("pdi_read_bytes", self.read_bytes),
            ("pdi_writes", self.writes),
            ("pdi_write_bytes", self.write_bytes),
        ] {
            h.meta_of(key, suffix, value);
        }
    }
}

/// The ESC as a RAM image: reads and writes are copies; every access returns the AL event
/// register, as the ET1100's SPI PDI does. With `TALLY` it counts its transfers
/// ([`PdiTally`]); the measured code runs on one without, which does nothing more than copy.
#[derive(Clone)]
pub(super) struct RamEsc<const TALLY: bool = false> {
    mem: [u8; ESC_IMAGE],
    tally: PdiTally,
}

impl RamEsc<true> {
    /// A copy of `image` that tallies its transfers from now on.
    pub(super) fn tallying(image: &RamEsc) -> Self {
        Self {
            mem: image.mem,
            tally: PdiTally::default(),
        }
    }

    /// The transfers so far.
    pub(super) fn tally(&self) -> PdiTally {
        self.tally
    }
}

impl<const TALLY: bool> RamEsc<TALLY> {
    /// An ESC image of zeros.
    pub(super) fn new() -> Self {
        Self {
            mem: [0; ESC_IMAGE],
            tally: PdiTally::default(),
        }
    }

    fn events(&self) -> AlEvent {
        let at = usize::from(regs::AL_EVENT_REQUEST.addr);
        let b = &self.mem[at..at + 4];
        AlEvent(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    /// The byte at `at`, if inside the image.
    pub(super) fn byte(&self, at: usize) -> Option<u8> {
        self.mem.get(at).copied()
    }

    pub(super) fn set(&mut self, addr: u16, bytes: &[u8]) {
        let at = usize::from(addr);
        self.mem[at..at + bytes.len()].copy_from_slice(bytes);
    }

    pub(super) fn set_sm(&mut self, n: u8, layout: &SmLayout, length: u16) {
        let sm = SmConfig {
            start: layout.start,
            length,
            control: SmControl(layout.control),
            status: SmStatus(0),
            activate: SmActivate(SmActivate::ENABLE),
            pdi_control: SmPdiControl(0),
        };
        self.set(regs::sm(n).addr, &sm.to_bytes());
    }
}

impl<const TALLY: bool> EscPdi for RamEsc<TALLY> {
    type Error = OutOfImage;

    fn read(&mut self, addr: u16, buf: &mut [u8]) -> Result<AlEvent, OutOfImage> {
        let at = usize::from(addr);
        let src = self.mem.get(at..at + buf.len()).ok_or(OutOfImage)?;
        transfer(src, buf);
        if TALLY {
            self.tally.reads = self.tally.reads.saturating_add(1);
            self.tally.read_bytes = self.tally.read_bytes.saturating_add(len_u32(buf.len()));
        }
        Ok(self.events())
    }

    fn write(&mut self, addr: u16, data: &[u8]) -> Result<AlEvent, OutOfImage> {
        let at = usize::from(addr);
        let dst = self.mem.get_mut(at..at + data.len()).ok_or(OutOfImage)?;
        transfer(data, dst);
        if TALLY {
            self.tally.writes = self.tally.writes.saturating_add(1);
            self.tally.write_bytes = self.tally.write_bytes.saturating_add(len_u32(data.len()));
        }
        Ok(self.events())
    }
}

/// A transfer's length as a tally counts it.
fn len_u32(len: usize) -> u32 {
    u32::try_from(len).unwrap_or(u32::MAX)
}

/// The PDI transfers of one `on_sync0` of `core` at `now_ns`, run on copies of the core and of
/// the ESC image (neither changes); `None` if the handler failed.
pub(super) fn sync0_transfers<const R: usize>(
    core: &DriveCore<R>,
    esc: &RamEsc,
    now_ns: u64,
) -> Option<PdiTally> {
    let mut core = core.clone();
    let mut esc = RamEsc::tallying(esc);
    on_sync0(&mut core, &mut esc, now_ns).ok()?;
    Some(esc.tally())
}

/// The data of a PDI access: what the board's SPI transfer does, which the budget excludes
/// (the board's load counts the transfer as its bus time). Copied as fixed-size pieces of up to
/// 8 bytes (unaligned accesses are allowed on the Cortex-M4), not by the library `memcpy`,
/// which copies an unaligned image byte by byte, nor word by word through slice iterators
/// (some 20 instructions per word): the stand-in costs little, so that the handlers' rows
/// count the firmware's work rather than the stand-in's.
fn transfer(from: &[u8], to: &mut [u8]) {
    match from.len() {
        1 => fixed::<1>(from, to),
        2 => fixed::<2>(from, to),
        3 => fixed::<3>(from, to),
        4 => fixed::<4>(from, to),
        5 => fixed::<5>(from, to),
        6 => fixed::<6>(from, to),
        7 => fixed::<7>(from, to),
        8 => fixed::<8>(from, to),
        _ => transfer_pieces(from, to),
    }
}

/// A copy of `N` bytes.
#[inline(always)]
fn fixed<const N: usize>(from: &[u8], to: &mut [u8]) {
    if let (Ok(from), Ok(to)) = (<&[u8; N]>::try_from(from), <&mut [u8; N]>::try_from(to)) {
        *to = *from;
    }
}

/// [`transfer`] of more than 8 bytes: pieces of 8, then the rest. Apart, so that the short
/// transfers (registers) stay a dispatch and a copy.
#[inline(never)]
fn transfer_pieces(from: &[u8], to: &mut [u8]) {
    let (mut from, mut to) = (from, to);
    while from.len() > 8 {
        let (Some((f, f_rest)), Some((t, t_rest))) = (
            from.split_first_chunk::<8>(),
            core::mem::take(&mut to).split_first_chunk_mut::<8>(),
        ) else {
            return;
        };
        *t = *f;
        (from, to) = (f_rest, t_rest);
    }
    transfer(from, to);
}

/// DC SYNC0 every [`DC_CYCLE_NS`] in the ESC image, as a master activates it before SAFEOP.
pub(super) fn activate_dc(esc: &mut RamEsc) {
    esc.set(
        regs::DC_ACTIVATION.addr,
        &[DcActivation::CYCLIC | DcActivation::SYNC0],
    );
    esc.set(regs::DC_SYNC0_CYCLE.addr, &DC_CYCLE_NS.to_le_bytes());
}

/// SAFEOP → OP in DC mode: the drive takes it only once its cycle runs on the SYNC0 events, so
/// SYNC0 cycles (each [`DC_CYCLE_NS`] after `now_ns`, which follows them) run between the
/// requests. The master writes the outputs every cycle: SM2's event stays set in the image.
/// `None` if OP was not reached.
pub(super) fn request_op_in_dc<const R: usize>(
    core: &mut DriveCore<R>,
    esc: &mut RamEsc,
    now_ns: &mut u64,
) -> Option<()> {
    let events = AlEvent::sm(2);
    for _ in 0..MAX_OP_REQUESTS {
        let reached = request_state(core, esc, AlState::Op, events);
        // The request clears the event register.
        esc.set(regs::AL_EVENT_REQUEST.addr, &events.to_le_bytes());
        if reached.is_some() {
            return Some(());
        }
        *now_ns += u64::from(DC_CYCLE_NS);
        on_sync0(core, esc, *now_ns).ok()?;
    }
    None
}

/// A master's request of AL `state` (with the AL events `events` besides AL control), handled
/// as the ESC-event context does; `Some` if the core went to `state`.
pub(super) fn request_state<const R: usize>(
    core: &mut DriveCore<R>,
    esc: &mut RamEsc,
    state: AlState,
    events: u32,
) -> Option<()> {
    esc.set(
        regs::AL_CONTROL.addr,
        &u16::from(state.bits()).to_le_bytes(),
    );
    esc.set(
        regs::AL_EVENT_REQUEST.addr,
        &(AlEvent::AL_CONTROL | events).to_le_bytes(),
    );
    let job = core.event_begin(esc, 0).ok()?;
    core.event_end(esc, job, 0).ok()?;
    esc.set(regs::AL_EVENT_REQUEST.addr, &[0; 4]);
    (core.al_state() == state).then_some(())
}

/// The drive's core, its mailbox side and the ESC image; the core's OD RAM `R` bytes (the
/// standard profile's own size unless a benchmark needs a larger one).
pub(super) struct Setup<const R: usize = RAM_SIZE> {
    pub(super) core: DriveCore<R>,
    pub(super) mailbox: MailboxSide<R>,
    pub(super) esc: RamEsc,
    rx: PdoPlan,
    /// The time of the last SYNC0 in DC mode ([`Setup::new_dc`]), ns; 0 in free run.
    pub(super) now_ns: u64,
}

impl<const R: usize> Setup<R> {
    /// A master's state request, handled as the ESC-event context does.
    fn request(&mut self, state: AlState, events: u32) -> Option<()> {
        request_state(&mut self.core, &mut self.esc, state, events)
    }

    /// INIT → PREOP → SAFEOP → OP in free run with the profile's mailbox and default mapping.
    pub(super) fn new() -> Option<Self> {
        let mut s = Self::safe_op(false)?;
        // The master has written the outputs once (the profile's SAFEOP → OP rule).
        s.request(AlState::Op, AlEvent::sm(2))?;
        Some(s)
    }

    /// [`Setup::new`] in DC mode, SYNC0 every [`DC_CYCLE_NS`], as the board runs: the master
    /// writes the outputs every cycle, so SM2's event stays set in the image.
    pub(super) fn new_dc() -> Option<Self> {
        let mut s = Self::safe_op(true)?;
        request_op_in_dc(&mut s.core, &mut s.esc, &mut s.now_ns)?;
        Some(s)
    }

    /// INIT → PREOP → SAFEOP with the profile's mailbox and default mapping, in DC mode
    /// ([`activate_dc`]) if `dc`, else in free run.
    fn safe_op(dc: bool) -> Option<Self> {
        let mut ram = [0; R];
        let mut od = Dictionary::new(&PROFILE.od, &mut ram);
        od.load_defaults();
        let rx = PdoPlan::build(&od, Direction::Rx).ok()?;
        let (core, mailbox) = firmware::new_slave_parts(&PROFILE).ok()?;
        let mut s = Self {
            core,
            mailbox,
            esc: RamEsc::new(),
            rx,
            now_ns: 0,
        };
        let device = &PROFILE.od.device;
        s.core.start(&mut s.esc).ok()?;
        s.esc
            .set_sm(0, &device.mailbox_out, device.mailbox_out.length);
        s.esc
            .set_sm(1, &device.mailbox_in, device.mailbox_in.length);
        s.request(AlState::PreOp, 0)?;
        s.esc.set_sm(2, &device.outputs, OUTPUTS_SIZE as u16);
        s.esc.set_sm(3, &device.inputs, INPUTS_SIZE as u16);
        if dc {
            activate_dc(&mut s.esc);
        }
        s.request(AlState::SafeOp, 0)?;
        Some(s)
    }

    /// Records the PDI transfers of the next cycle (one DC cycle on; in free run the time
    /// does not matter) as those of benchmark `name`, for the report's load model; a failure
    /// if the handler fails.
    pub(super) fn record_transfers(&self, h: &mut Harness, name: &str) {
        let next = self.now_ns.saturating_add(u64::from(DC_CYCLE_NS));
        match sync0_transfers(&self.core, &self.esc, next) {
            Some(tally) => tally.record(h, format_args!("{name}")),
            None => h.fail(name, format_args!("the SYNC0 handler failed")),
        }
    }

    /// One SYNC0 of DC mode: [`DC_CYCLE_NS`] after the last one.
    pub(super) fn dc_cycle(&mut self) -> Result<(), &'static str> {
        self.now_ns += u64::from(DC_CYCLE_NS);
        on_sync0(&mut self.core, &mut self.esc, self.now_ns).map_err(|_| "the SYNC0 handler failed")
    }

    /// [`Setup::new`], then the power-up sequence of controlwords, one cycle each, to operation
    /// enabled (no motor attached). The reason if it did not get there.
    pub(super) fn powered_up() -> Result<Self, &'static str> {
        let mut s = Self::new().ok_or("the slave did not reach OP on the ESC image")?;
        for cw in POWER_UP {
            if s.set_outputs(cw).is_none() || on_sync0(&mut s.core, &mut s.esc, 0).is_err() {
                return Err("a power-up cycle failed");
            }
        }
        if s.core.app().pds_state() != PdsState::OperationEnabled {
            return Err("the drive did not reach operation enabled");
        }
        Ok(s)
    }

    /// Puts the master's outputs into SM2 ([`master_outputs`] packed by the Rx plan).
    fn set_outputs(&mut self, cw: u16) -> Option<()> {
        self.set_master(&master_outputs(cw)?);
        Some(())
    }

    /// Puts the master's side of the RxPDO objects (an OD RAM image) into SM2, packed by the Rx
    /// plan.
    pub(super) fn set_master(&mut self, master: &[u8]) {
        let mut image = [0; MAX_IMAGE];
        self.rx.pack(master, &mut image);
        self.esc
            .set(PROFILE.od.device.outputs.start, &image[..OUTPUTS_SIZE]);
    }

    /// A segmented SDO download left half done: the init announces 4 bytes and carries none, so
    /// the mailbox side waits for a segment.
    fn start_segmented_download(&mut self) -> Option<()> {
        let device = &PROFILE.od.device;
        // The 4 bytes of 2F00h (UDINT), announced, none sent.
        let init = request(
            command::DOWNLOAD_REQUEST_SIZED,
            USER_PARAMETER,
            [4, 0, 0, 0],
        );
        self.esc
            .set(device.mailbox_out.start, &mailbox_frame(&init));
        let sm0_status = regs::sm(0).addr + regs::sm_offset::STATUS;
        self.esc.set(sm0_status, &[SmStatus::MAILBOX_FULL]);
        let job = EventJob {
            events: AlEvent(AlEvent::sm(0)),
            state: AlState::Op,
        };
        self.mailbox.load(&mut self.core);
        self.mailbox
            .serve(&mut self.core, &mut self.esc, job, &mut ())
            .ok()?;
        self.mailbox.store(&mut self.core);
        self.esc.set(sm0_status, &[0]);
        self.mailbox.transfer_in_progress().then_some(())
    }
}

/// Measures the SYNC0 handler with the mailbox idle and with a transfer pending.
pub fn run(h: &mut Harness) {
    let Some(mut s) = h.ready("sync0-handler", <Setup>::powered_up()) else {
        return;
    };
    // The PDI transfers of a cycle (the load model counts the bus time of the row it takes).
    s.record_transfers(h, "sync0-handler");
    let Setup { core, esc, .. } = &mut s;
    let idle = h.bench(
        "sync0-handler",
        Some(SYNC0_HANDLER_BUDGET),
        format_args!(
            "firmware::sync0::on_sync0 on the slave's core in OP: supervision, SM2 read + unpack, \
             Drive::step, pack + SM3 write (default mapping, ESC as a RAM image: PDI bus time \
             excluded), mailbox idle"
        ),
        &mut || {
            let _ = on_sync0(core, esc, black_box(0));
        },
    );
    if s.start_segmented_download().is_none() {
        h.fail(
            "sync0-handler-mailbox-pending",
            format_args!("the segmented download did not stay open"),
        );
        return;
    }
    let Setup { core, esc, .. } = &mut s;
    let pending = h.bench(
        "sync0-handler-mailbox-pending",
        Some(SYNC0_HANDLER_BUDGET),
        format_args!(
            "the same while the mailbox side holds a half-done segmented SDO download (2F00h)"
        ),
        &mut || {
            let _ = on_sync0(core, esc, black_box(0));
        },
    );
    if idle != pending {
        h.fail(
            "sync0-handler-mailbox-pending",
            format_args!(
                "a pending mailbox transfer changed the SYNC0 handler: {idle:?} → {pending:?}"
            ),
        );
    }
    if !s.mailbox.transfer_in_progress() || s.core.app().pds_state() != PdsState::OperationEnabled {
        h.fail(
            "sync0-handler-mailbox-pending",
            format_args!("the measured cycles changed the drive or the transfer"),
        );
    }
}
