//! In-process transport for the ethercrab master: frames go straight from ethercrab's PDU loop
//! through the simulated segment and back, without a network or privileges.
//!
//! Simulated time is exposed to ethercrab through [`SimClock`], so DC offsets computed by the
//! master refer to the simulated clock.

use std::future::Future;
use std::pin::Pin;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::task::{Context, Poll};

use ethercrab::error::Error;
use ethercrab::{MainDevice, MainDeviceConfig, PduRx, PduStorage, PduTx, Timeouts};

use crate::drive::SimDrive;
use crate::segment::{Segment, SimDevice};

/// Frames in flight in the master's PDU loop.
const MAX_FRAMES: usize = 16;
/// Largest PDU payload per frame. The in-process transport is not an Ethernet wire: its frames
/// carry up to 2000 bytes of PDUs (an EtherCAT frame's length field has 11 bits, up to 2047),
/// so that the process image of a 128-drive line (`demo::MAX_PDI`) goes in one LRW beside the
/// DC PDU. On a wire a master splits such an image over two frames.
const MAX_PDU_DATA: usize = PduStorage::element_size(2000);

/// The simulated time as ethercrab reads it (`init_single_group(clock.now_fn())`).
#[derive(Clone, Copy)]
pub struct SimClock(&'static AtomicU64);

impl SimClock {
    fn new() -> Self {
        Self(Box::leak(Box::new(AtomicU64::new(0))))
    }
    /// Current simulated time in ns.
    pub fn now(self) -> u64 {
        self.0.load(Ordering::Acquire)
    }
    fn set(self, t: u64) {
        self.0.store(t, Ordering::Release);
    }
    /// A `Copy` function returning the simulated time, as ethercrab's `init` wants it.
    pub fn now_fn(self) -> impl Fn() -> u64 + Copy {
        move || self.now()
    }
}

/// Fault injection between master and segment.
#[derive(Clone, Copy, Debug, Default)]
pub struct Faults {
    /// Drop the reply to the next `n` frames (the frame still passed the ring).
    pub drop_replies: u32,
}

/// Shared between the transport and the test: the segment, the clock and fault switches.
pub struct Shared<D: SimDevice = SimDrive> {
    segment: Mutex<Segment<D>>,
    clock: SimClock,
    faults: Mutex<Faults>,
    frames: AtomicU64,
}

impl<D: SimDevice> Shared<D> {
    /// Locks the segment (to advance time or inspect drives). A poisoned lock (a panicking test
    /// thread) is recovered: the segment has no invariant a panic elsewhere could break.
    pub fn segment(&self) -> MutexGuard<'_, Segment<D>> {
        self.segment.lock().unwrap_or_else(|p| p.into_inner())
    }
    /// Advances simulated time by `dt_ns` (SYNC0s and timers fire on the way).
    pub fn advance(&self, dt_ns: u64) {
        let mut s = self.segment();
        s.advance(dt_ns);
        self.clock.set(s.now_ns());
    }
    /// Advances simulated time to one `cycle_ns` after `since_ns` (the time the cycle's frames
    /// started: their wire time is part of the cycle), so a master's cycle stays phase-locked to
    /// the drives' SYNC0 or free-run timer.
    pub fn finish_cycle(&self, since_ns: u64, cycle_ns: u64) {
        let spent = self.clock.now().saturating_sub(since_ns);
        self.advance(cycle_ns.saturating_sub(spent));
    }
    /// The clock.
    pub fn clock(&self) -> SimClock {
        self.clock
    }
    /// Frames processed so far.
    pub fn frames(&self) -> u64 {
        self.frames.load(Ordering::Relaxed)
    }
    /// Sets the fault switches.
    pub fn set_faults(&self, f: Faults) {
        *self.faults.lock().unwrap_or_else(|p| p.into_inner()) = f;
    }

    fn exchange(&self, frame: &[u8]) -> Option<Vec<u8>> {
        let reply = {
            let mut s = self.segment();
            let r = s.process_frame(frame);
            self.clock.set(s.now_ns());
            r
        };
        self.frames.fetch_add(1, Ordering::Relaxed);
        let mut f = self.faults.lock().unwrap_or_else(|p| p.into_inner());
        if f.drop_replies > 0 {
            f.drop_replies -= 1;
            return None;
        }
        reply
    }
}

/// The transport future: spawn it on the runtime that runs the master.
pub struct InMemoryTxRx<D: SimDevice = SimDrive> {
    tx: PduTx<'static>,
    rx: PduRx<'static>,
    shared: Arc<Shared<D>>,
}

impl<D: SimDevice> Future for InMemoryTxRx<D> {
    type Output = Result<(), Error>;

    fn poll(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Self::Output> {
        let this = self.get_mut();
        // Re-register every poll, or frames queued later are never seen.
        this.tx.replace_waker(cx.waker());
        if this.tx.should_exit() {
            return Poll::Ready(Ok(()));
        }
        while let Some(frame) = this.tx.next_sendable_frame() {
            let mut reply = None;
            frame.send_blocking(|bytes| {
                reply = this.shared.exchange(bytes);
                Ok(bytes.len())
            })?;
            // Only after send_blocking returned is the frame marked sent and able to take a reply.
            if let Some(r) = reply {
                this.rx.receive_frame(&r)?;
            }
        }
        Poll::Pending
    }
}

/// An ethercrab master connected to `segment` in process.
pub struct InProcess<D: SimDevice = SimDrive> {
    /// The master.
    pub maindevice: Arc<MainDevice<'static>>,
    /// Segment, clock and fault switches.
    pub shared: Arc<Shared<D>>,
}

impl<D: SimDevice> InProcess<D> {
    /// Connects a new master (with its own PDU storage) to `segment`; spawn the returned
    /// transport before using the master.
    pub fn connect(
        segment: Segment<D>,
        timeouts: Timeouts,
        config: MainDeviceConfig,
    ) -> (Self, InMemoryTxRx<D>) {
        let storage: &'static PduStorage<MAX_FRAMES, MAX_PDU_DATA> =
            Box::leak(Box::new(PduStorage::new()));
        // A freshly leaked storage has never been split.
        let (tx, rx, pdu_loop) = match storage.try_split() {
            Ok(parts) => parts,
            Err(()) => unreachable!("a new PduStorage splits once"),
        };
        let clock = SimClock::new();
        clock.set(segment.now_ns());
        let shared = Arc::new(Shared {
            segment: Mutex::new(segment),
            clock,
            faults: Mutex::new(Faults::default()),
            frames: AtomicU64::new(0),
        });
        let maindevice = Arc::new(MainDevice::new(pdu_loop, timeouts, config));
        (
            Self {
                maindevice,
                shared: shared.clone(),
            },
            InMemoryTxRx { tx, rx, shared },
        )
    }
}
