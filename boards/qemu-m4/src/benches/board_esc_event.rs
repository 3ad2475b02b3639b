//! The STM32G474 board's ESC-event round as the board runs it: `stm32g4_axis`'s
//! [`EventSide::esc_event_round`] (the core's event steps, the mailbox loaded, served and stored
//! back, the digital outputs) on the slave in OP, the ESC an image in memory reached through
//! the drive lock in 32-byte transfers ([`stm32g4_axis::event::DrivePdi`]), over the mailbox
//! requests whose rounds differ: a download of a plain parameter (2F00h), a download of a
//! setting (6081h: checked against the RxPDO plan, its settings group read again in the round),
//! an expedited upload (6041h), a normal upload whose response carries a string (1008h) and a
//! store command (1010h:01); and a round with no request (the SM2 event of a DC cycle), which
//! copies no OD RAM.
//!
//! A request's round copies what its answer reads or writes to the mailbox side under the
//! lock: the entries of the object it names, or the whole OD RAM for 1010h/1011h (the store
//! reads every parameter), measured with a store command. The core has the OD RAM of the
//! largest profile (`MAX_RAM_SIZE`), so that copy is the largest profile's.
//!
//! Each call puts the request into the image (SM0 full, the SM0 event) and runs the round; the
//! request's setup alone is measured and subtracted. The image does not model the SM status
//! changes of the transfer, so every call serves the request the same way.

use core::cell::RefCell;
use core::hint::black_box;

use firmware::mailbox::coe::COE_HEADER_LEN;
use firmware::mailbox::header::HEADER_LEN as MAILBOX_HEADER_LEN;
use firmware::params::{NoStorage, ParamStore};
use firmware::profiles::standard::PROFILE;
use firmware::profiles::MAX_RAM_SIZE;
use firmware::slave::SM_OUTPUTS;
use hal::esc::{regs, AlEvent, SmStatus};
use stm32g4_axis::cycle::CycleSide;
use stm32g4_axis::event::{EventSide, SharedDrive};
use stm32g4_axis::inputs::BrakeOutput;
use stm32g4_axis::regs::OutputPins;

use super::sdo::{
    command, mailbox_frame, request, FRAME_LEN, MAPPABLE_PARAMETER, MAPPABLE_PARAMETER_VALUE,
    STATUSWORD, USER_PARAMETER, USER_PARAMETER_VALUE,
};
use super::sync0_handler::{PdiTally, RamEsc, Setup};
use crate::harness::{Cases, Harness};

const NAME: &str = "board-esc-event";
/// Parameter-store record capacity (no storage here: 1010h is not used).
const RECORD_CAPACITY: usize = 64;

/// No brake pin.
struct NoPins;

impl OutputPins for NoPins {
    fn set_brake_released(&mut self, _: bool) {}
}

type Side<const TALLY: bool> = CycleSide<MAX_RAM_SIZE, RamEsc<TALLY>, NoPins>;

/// The drive lock of a single context: always available. With `TALLY` its ESC image counts
/// the transfers.
struct Direct<const TALLY: bool = false>(Side<TALLY>);

impl<const TALLY: bool> SharedDrive<MAX_RAM_SIZE, RamEsc<TALLY>, NoPins> for Direct<TALLY> {
    fn with<R>(&mut self, f: impl FnOnce(&mut Side<TALLY>) -> R) -> Option<R> {
        Some(f(&mut self.0))
    }
}

/// The label of the round without a request.
const IDLE_LABEL: &str = "no request (a cycle's SM2 event)";
/// A byte put in SM1's buffer before the round without a request, found there after it.
const IDLE_MARK: u8 = 0xA5;

/// Device name 1008h: a string longer than the 4 bytes of an expedited upload.
const DEVICE_NAME: (u16, u8) = (0x1008, 0);

/// Store parameters 1010h:01 (all) with its signature "save" (CiA 301 §7.5.2.13): the store
/// reads every parameter, so the round copies the whole OD RAM. No storage here: refused with
/// an abort after the copy.
const STORE_ALL: (u16, u8) = (0x1010, 1);
const SAVE: u32 = u32::from_le_bytes(*b"save");

/// The requests measured: label, mailbox frame, the command byte of the expected response.
fn requests() -> [(&'static str, [u8; MAILBOX_HEADER_LEN + FRAME_LEN], u8); 5] {
    let frame = |command, object, data| mailbox_frame(&request(command, object, data));
    [
        (
            "download of a parameter (2F00h)",
            frame(
                command::DOWNLOAD_REQUEST_U32,
                USER_PARAMETER,
                USER_PARAMETER_VALUE.to_le_bytes(),
            ),
            command::DOWNLOAD_RESPONSE,
        ),
        (
            "download of a setting (6081h)",
            frame(
                command::DOWNLOAD_REQUEST_U32,
                MAPPABLE_PARAMETER,
                MAPPABLE_PARAMETER_VALUE.to_le_bytes(),
            ),
            command::DOWNLOAD_RESPONSE,
        ),
        (
            "expedited upload (6041h)",
            frame(command::UPLOAD_REQUEST, STATUSWORD, [0; 4]),
            command::UPLOAD_RESPONSE_U16,
        ),
        (
            "upload of a string (1008h)",
            frame(command::UPLOAD_REQUEST, DEVICE_NAME, [0; 4]),
            command::UPLOAD_RESPONSE_SIZED,
        ),
        (
            "store parameters (1010h:01, the whole OD RAM copied)",
            frame(command::DOWNLOAD_REQUEST_U32, STORE_ALL, SAVE.to_le_bytes()),
            command::ABORT,
        ),
    ]
}

/// Puts the request into SM0 and raises its event, as the master's frame leaves them.
fn post(esc: &mut RamEsc, frame: &[u8]) {
    let device = &PROFILE.od.device;
    esc.set(device.mailbox_out.start, frame);
    esc.set(
        regs::sm(0).addr + regs::sm_offset::STATUS,
        &[SmStatus::MAILBOX_FULL],
    );
    esc.set(regs::sm(1).addr + regs::sm_offset::STATUS, &[0]);
    esc.set(regs::AL_EVENT_REQUEST.addr, &AlEvent::sm(0).to_le_bytes());
}

/// Leaves SM0 empty and raises the SM2 event, as a process-data frame of a DC cycle does.
fn idle(esc: &mut RamEsc) {
    esc.set(regs::sm(0).addr + regs::sm_offset::STATUS, &[0]);
    esc.set(regs::sm(1).addr + regs::sm_offset::STATUS, &[0]);
    esc.set(
        regs::AL_EVENT_REQUEST.addr,
        &AlEvent::sm(SM_OUTPUTS).to_le_bytes(),
    );
}

type Event = EventSide<MAX_RAM_SIZE, NoStorage, RECORD_CAPACITY>;

/// Puts an input into the image (`setup`) and runs one round: whether it ended without error.
fn run_round(drive: &RefCell<Direct>, event: &mut Event, setup: &dyn Fn(&mut RamEsc)) -> bool {
    let mut drive = drive.borrow_mut();
    setup(&mut drive.0.pdi);
    matches!(event.esc_event_round(&mut *drive, 0), Some(Ok(())))
}

/// The cost of one round after `setup`, `setup` measured alone and subtracted.
fn round_cost(
    h: &mut Harness,
    drive: &RefCell<Direct>,
    event: &mut Event,
    setup: &dyn Fn(&mut RamEsc),
) -> Option<u32> {
    let (cost, _, _) = h.measure_net(
        NAME,
        &mut || setup(&mut drive.borrow_mut().0.pdi),
        &mut || {
            let mut drive = drive.borrow_mut();
            setup(&mut drive.0.pdi);
            let _ = event.esc_event_round(&mut *drive, black_box(0));
        },
    )?;
    Some(cost)
}

/// The PDI transfers of one round after `setup`, run on a copy of the core with a copy of the
/// ESC image that tallies them (the event side's round is a real one: run it after the
/// measurements). `None` if the round failed.
fn round_transfers(
    drive: &RefCell<Direct>,
    event: &mut Event,
    setup: &dyn Fn(&mut RamEsc),
) -> Option<PdiTally> {
    let mut tallying = {
        let plain = drive.borrow();
        let mut image = plain.0.pdi.clone();
        setup(&mut image);
        Direct::<true>(CycleSide {
            core: plain.0.core.clone(),
            pdi: RamEsc::tallying(&image),
            brake: BrakeOutput::new(NoPins),
            sync_lock: None,
        })
    };
    matches!(event.esc_event_round(&mut tallying, 0), Some(Ok(()))).then(|| tallying.0.pdi.tally())
}

/// The benchmark.
pub fn run(h: &mut Harness) {
    let Some(setup) = h.ready(NAME, Setup::<MAX_RAM_SIZE>::powered_up()) else {
        return;
    };
    let Setup {
        core, esc, mailbox, ..
    } = setup;
    let drive = Direct(CycleSide {
        core,
        pdi: esc,
        brake: BrakeOutput::new(NoPins),
        sync_lock: None,
    });
    let mut event: Event = EventSide {
        mailbox,
        params: ParamStore::new(NoStorage),
    };
    let response_at = usize::from(PROFILE.od.device.mailbox_in.start) + MAILBOX_HEADER_LEN;
    // Both operations reach the drive through the cell (the same borrow cost in each).
    let drive = RefCell::new(drive);
    let mut cases = Cases::new(NAME);
    for (label, frame, response) in requests() {
        // The round answers the request in SM1 (and a download's value reaches the core).
        let answered = run_round(&drive, &mut event, &|esc| post(esc, &frame))
            && drive.borrow().0.pdi.byte(response_at + COE_HEADER_LEN) == Some(response);
        if !answered {
            h.fail(
                NAME,
                format_args!("{label}: not answered in SM1 as expected"),
            );
            return;
        }
        let Some(cost) = round_cost(h, &drive, &mut event, &|esc| post(esc, black_box(&frame)))
        else {
            return;
        };
        h.case(&mut cases, label, cost);
    }
    // A round with nothing to answer: in DC mode the SM2 event starts one every cycle. SM1
    // stays untouched and the OD RAM is not copied to the mailbox side.
    let sm1 = PROFILE.od.device.mailbox_in.start;
    drive.borrow_mut().0.pdi.set(sm1, &[IDLE_MARK]);
    let untouched = run_round(&drive, &mut event, &idle)
        && drive.borrow().0.pdi.byte(usize::from(sm1)) == Some(IDLE_MARK);
    if !untouched {
        h.fail(NAME, format_args!("a round without a request wrote SM1"));
        return;
    }
    let Some(cost) = round_cost(h, &drive, &mut event, &idle) else {
        return;
    };
    h.case(&mut cases, IDLE_LABEL, cost);
    // The transfers of each round (the report's load model counts their bus time).
    for (label, frame, _) in requests() {
        let Some(tally) = round_transfers(&drive, &mut event, &|esc| post(esc, &frame)) else {
            h.fail(NAME, format_args!("{label}: the tallied round failed"));
            return;
        };
        tally.record(h, format_args!("{NAME}:{label}"));
    }
    match round_transfers(&drive, &mut event, &idle) {
        Some(tally) => tally.record(h, format_args!("{NAME}:{IDLE_LABEL}")),
        None => h.fail(
            NAME,
            format_args!("the tallied round without a request failed"),
        ),
    }
    h.report_cases(
        &cases,
        None,
        format_args!(
            "the STM32G474 board's ESC-event round (stm32g4_axis EventSide::esc_event_round: \
             event begin, mailbox load, receive, the OD RAM copied for a request, answer, \
             store, event end, outputs; the core sized for the largest profile's OD RAM, \
             {MAX_RAM_SIZE} B, which a store command copies whole; the PDI through the drive lock in 32-byte transfers, \
             ESC as a RAM image: bus time excluded) in OP, over the mailbox requests whose \
             rounds differ and a round without one (the request's setup measured alone and \
             subtracted)"
        ),
    );
}
