//! Lock-free exchange between the EtherCAT SYNC0 handler and the control interrupt.
//!
//! Both run on one core; the control interrupt (PWM/ADC) has the higher priority. So the
//! control interrupt can preempt the SYNC0 handler at any instruction, and always runs to
//! completion before the SYNC0 handler continues; the reverse never happens. Neither side may
//! wait for the other (the control interrupt has a hard deadline; the SYNC0 handler waiting for
//! a higher-priority interrupt would deadlock).
//!
//! | direction | writer | reader | mechanism |
//! |---|---|---|---|
//! | set-points | SYNC0 (low) | control (high) | [`SetpointHandoff`]: double buffer, reader never retries |
//! | feedback | control (high) | SYNC0 (low) | [`FeedbackHandoff`]: seqlock, reader retries (bounded) |
//!
//! Both need 32-bit atomic loads and stores and fences only (no read-modify-write), so they
//! work on any Cortex-M (and the host, where the seqlock is also safe between threads).

use core::cell::UnsafeCell;
use core::mem::MaybeUninit;
use core::ptr;
use core::sync::atomic::{fence, AtomicU32, Ordering};

/// SYNC0 → control interrupt: the newest set-point, published through a double buffer.
///
/// The writer fills the buffer the reader is *not* using (the one not published), then
/// publishes its index together with an incremented sequence number in one `Release` store.
/// The reader `Acquire`-loads index and sequence and copies the published buffer; it never
/// waits and never retries.
///
/// # Why this is sound (priority assumption)
/// While the writer fills buffer `i`, the published buffer is `1 − i`; a reader that preempts
/// the writer reads `1 − i` and is done before the writer continues. The writer's next write
/// goes to `1 − i` only after it published `i`, and at that point no reader can be in the
/// middle of copying `1 − i`: a reader is never preempted by the writer. So no buffer is ever
/// read and written at the same time. The `Release` store / `Acquire` load pair orders the
/// buffer contents before the index (the compiler may not sink the buffer writes below the
/// publication, nor hoist the reader's copy above the index load).
///
/// Without the assumption (the writer preempting the reader, or the two on different cores),
/// a reader that loaded index `i` and is still copying buffer `i` can be overtaken by two
/// writes: the first publishes `1 − i`, the second writes into `i` under the reader's copy,
/// which comes out torn. Use [`FeedbackHandoff`] for that direction.
pub struct SetpointHandoff<T: Copy> {
    buffers: [UnsafeCell<T>; 2],
    /// Bit 0: the published buffer; bits 31..1: the number of writes, wrapping.
    state: AtomicU32,
}

// SAFETY: the handoff moves `T` values between two execution contexts, hence `T: Send`. The
// shared state is an atomic and two buffers whose accesses never overlap under the contract of
// `new` (see the type's documentation).
unsafe impl<T: Copy + Send> Sync for SetpointHandoff<T> {}

/// Bit of [`SetpointHandoff::state`] holding the published buffer.
const INDEX_BIT: u32 = 1;

impl<T: Copy> SetpointHandoff<T> {
    /// A handoff holding `initial` (sequence number 0).
    ///
    /// # Safety
    /// The caller guarantees that [`write`](Self::write) is only ever called from one context
    /// and [`read`](Self::read)/[`read_if_new`](Self::read_if_new) from one other context, on
    /// the same core, and that the writer can never preempt the reader (the reader's interrupt
    /// priority is higher than the writer's, and it never re-enables lower priorities).
    pub const unsafe fn new(initial: T) -> Self {
        Self {
            buffers: [UnsafeCell::new(initial), UnsafeCell::new(initial)],
            state: AtomicU32::new(0),
        }
    }

    /// Publishes `value` (writer side, SYNC0 handler).
    ///
    /// Timing: about 10 instructions plus the copy of `T` (one load/store per word) and a
    /// `dmb` for the `Release` store.
    #[inline]
    pub fn write(&self, value: T) {
        // SAFETY: `slot` points to the unpublished buffer, valid and aligned for `T`; no
        // reader touches it until the commit (type documentation).
        self.write_in_steps(|slot| unsafe { slot.write(value) });
    }

    /// The writer as its three steps: pick the unpublished buffer, let `fill` write it,
    /// publish. Tests call this with a `fill` that runs the reader half-way.
    #[inline]
    fn write_in_steps(&self, fill: impl FnOnce(*mut T)) {
        // Only the writer stores `state`: Relaxed sees its own last store.
        let state = self.state.load(Ordering::Relaxed);
        let index = (state & INDEX_BIT) ^ INDEX_BIT;
        fill(self.buffer(index));
        let sequence = (state >> 1).wrapping_add(1);
        self.state.store((sequence << 1) | index, Ordering::Release);
    }

    /// The buffer `index & 1` (no bounds check, no panic path).
    #[inline]
    fn buffer(&self, index: u32) -> *mut T {
        let [first, second] = &self.buffers;
        if index & INDEX_BIT == 0 {
            first.get()
        } else {
            second.get()
        }
    }

    /// The newest value and its sequence number (the number of writes so far, 31 bits,
    /// wrapping; 0 = the initial value). Reader side: the control interrupt.
    ///
    /// Timing: about 8 instructions plus the copy of `T` and a `dmb` for the `Acquire` load.
    #[inline]
    pub fn read(&self) -> (T, u32) {
        let state = self.state.load(Ordering::Acquire);
        // SAFETY: the published buffer is not written while the reader runs (the writer only
        // writes the other one and cannot preempt the reader: contract of `new`), and the
        // Acquire load makes the writer's stores to it visible.
        let value = unsafe { *self.buffer(state) };
        (value, state >> 1)
    }

    /// The newest value if its sequence number differs from `last_sequence` (a new set-point
    /// arrived since the caller's last read).
    ///
    /// Timing: as [`read`](Self::read), plus a compare.
    #[inline]
    pub fn read_if_new(&self, last_sequence: u32) -> Option<(T, u32)> {
        let (value, sequence) = self.read();
        (sequence != last_sequence).then_some((value, sequence))
    }
}

/// How often [`FeedbackHandoff::read`] tries before it returns the previous good value. On a
/// single core a retry is only needed when the writer interrupted the copy; the writer (the
/// control interrupt, ≥ 25 µs period) cannot interrupt the few-hundred-nanosecond copy twice in
/// a row, so two tries always suffice there; four leave margin for a slow copy of a large `T`.
pub const READ_ATTEMPTS: u32 = 4;

/// Control interrupt → SYNC0: the newest feedback (actual position, velocity, torque, status),
/// published through a sequence lock.
///
/// The writer makes the sequence odd, writes the data, makes it even again; it never waits. The
/// reader copies the data between two loads of the sequence and accepts the copy only if the
/// sequence was even and unchanged, i.e. no write overlapped it. Here the writer preempts the
/// reader, so a copy can be overlapped; the reader then tries again, at most
/// [`READ_ATTEMPTS`] times, and otherwise returns the last value it read consistently (never a
/// torn one): the SYNC0 side reports the previous cycle's feedback once rather than waiting.
///
/// A copy that overlaps a write reads bytes that are being written; it is discarded before it
/// is used as a `T` (it is held as `MaybeUninit<T>`), and the data accesses are volatile so
/// that the compiler neither caches nor splits them unpredictably. This is the classic seqlock
/// (also that of `crossbeam`'s `AtomicCell` fallback); the Rust memory model formally calls the
/// overlapping access a data race, which has no effect on the hardware here.
pub struct FeedbackHandoff<T: Copy> {
    /// Even: stable; odd: a write is in progress. Counts twice the number of writes, wrapping.
    sequence: AtomicU32,
    data: UnsafeCell<T>,
    /// The reader's last consistent copy and its sequence number (touched by the reader only).
    last_good: UnsafeCell<(T, u32)>,
}

// SAFETY: values move between contexts (`T: Send`); `data` is only written by the one writer
// and read by the one reader through the sequence protocol (contract of `new`), `last_good`
// only touched by the reader.
unsafe impl<T: Copy + Send> Sync for FeedbackHandoff<T> {}

impl<T: Copy> FeedbackHandoff<T> {
    /// A handoff holding `initial` (sequence number 0).
    ///
    /// # Safety
    /// The caller guarantees a single writing context ([`write`](Self::write)) and a single
    /// reading context ([`read`](Self::read)). Any priority relation between them is fine, and
    /// they may run on different cores.
    pub const unsafe fn new(initial: T) -> Self {
        Self {
            sequence: AtomicU32::new(0),
            data: UnsafeCell::new(initial),
            last_good: UnsafeCell::new((initial, 0)),
        }
    }

    /// Publishes `value` (writer side, control interrupt). Never waits.
    ///
    /// Timing: about 10 instructions plus the copy of `T` (one store per word) and two `dmb`.
    #[inline]
    pub fn write(&self, value: T) {
        // SAFETY: `data` is valid and aligned; the single writer (contract of `new`) is the only
        // one writing it, and readers detect the overlap through the odd sequence number.
        self.write_in_steps(|data| unsafe { ptr::write_volatile(data, value) });
    }

    /// The writer as its steps: mark odd, `fill` the data, mark even. Tests run the reader
    /// between the steps.
    #[inline]
    fn write_in_steps(&self, fill: impl FnOnce(*mut T)) {
        let sequence = self.sequence.load(Ordering::Relaxed);
        self.sequence
            .store(sequence.wrapping_add(1), Ordering::Relaxed);
        // The odd mark must be visible before any of the data stores.
        fence(Ordering::Release);
        fill(self.data.get());
        self.sequence
            .store(sequence.wrapping_add(2), Ordering::Release);
    }

    /// The newest consistent value and its sequence number (the number of writes, 31 bits,
    /// wrapping; 0 = the initial value). If every attempt was overlapped by a write, the last
    /// value read consistently, with its (older) sequence number. Reader side: the SYNC0
    /// handler. Never waits beyond [`READ_ATTEMPTS`] copies.
    ///
    /// Timing: about 15 instructions plus one copy of `T` per attempt (normally one) and the
    /// `dmb`s of the loads.
    #[inline]
    pub fn read(&self) -> (T, u32) {
        // SAFETY: `data` is valid and aligned for `T`; the copy lands in a `MaybeUninit<T>` and
        // is discarded if a write overlapped it.
        self.read_with(|data| unsafe { ptr::read_volatile(data.cast::<MaybeUninit<T>>()) })
    }

    /// The newest value if a write completed or began since the read that returned
    /// `last_sequence`; `None` otherwise, without copying `T` (for a value written rarely and
    /// read every cycle: the reader keeps what it derived from the last one). Reader side, as
    /// [`read`](Self::read).
    ///
    /// Timing: about 6 instructions when nothing was written, else as [`read`](Self::read).
    #[inline]
    pub fn read_if_new(&self, last_sequence: u32) -> Option<(T, u32)> {
        if !self.written_since(last_sequence) {
            return None;
        }
        let (value, sequence) = self.read();
        // Every attempt overlapped by a write gives the last good value: nothing new yet.
        (sequence != last_sequence).then_some((value, sequence))
    }

    /// Whether a write completed or began since the read that returned `last_sequence` (then
    /// [`read_if_new`](Self::read_if_new) copies). Reader side.
    ///
    /// Timing: about 5 instructions.
    #[inline]
    fn written_since(&self, last_sequence: u32) -> bool {
        // No data is read on this path, so no ordering is needed for the load.
        let state = self.sequence.load(Ordering::Relaxed);
        state & 1 != 0 || state >> 1 != last_sequence
    }

    /// The reader with its copy step supplied by the caller (tests run the writer half-way).
    #[inline]
    fn read_with(&self, mut copy: impl FnMut(*const T) -> MaybeUninit<T>) -> (T, u32) {
        for _ in 0..READ_ATTEMPTS {
            let before = self.sequence.load(Ordering::Acquire);
            if before & 1 == 0 {
                let value = copy(self.data.get());
                // The data loads must complete before the sequence is checked again.
                fence(Ordering::Acquire);
                let after = self.sequence.load(Ordering::Relaxed);
                if after == before {
                    // SAFETY: the sequence was even and unchanged around the copy, so no write
                    // overlapped it: it is a complete `T` the writer stored.
                    let value = unsafe { value.assume_init() };
                    let sequence = before >> 1;
                    // SAFETY: only the single reader (contract of `new`) touches `last_good`.
                    unsafe { *self.last_good.get() = (value, sequence) };
                    return (value, sequence);
                }
            }
        }
        // SAFETY: as above, reader-only.
        unsafe { *self.last_good.get() }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;

    const WORDS: usize = 8;
    type Block = [u32; WORDS];

    fn consistent(block: &Block) -> bool {
        block.iter().all(|&w| w == block[0])
    }

    #[test]
    fn setpoint_reader_preempting_the_writer_anywhere_sees_a_whole_value() {
        // The reader (control interrupt) runs to completion at every point of a write: before
        // the first word, after each word, just before the commit; then after the commit.
        // SAFETY: single thread; the "reader" runs nested inside the writer, which is exactly
        // the preemption the contract allows.
        let h = unsafe { SetpointHandoff::<Block>::new([0; WORDS]) };
        let mut n = 0u32;
        for _round in 0..20 {
            for preempt_after in 0..=WORDS {
                let previous = n;
                n += 1;
                h.write_in_steps(|slot| {
                    for i in 0..=WORDS {
                        if i == preempt_after {
                            let (v, seq) = h.read();
                            assert!(consistent(&v), "torn {v:?}");
                            assert_eq!(
                                (v, seq),
                                ([previous; WORDS], previous),
                                "not yet published"
                            );
                        }
                        if i < WORDS {
                            // SAFETY: `slot` is the writer's buffer, valid for `Block`.
                            unsafe { (*slot)[i] = n };
                        }
                    }
                });
                assert_eq!(h.read(), ([n; WORDS], n));
            }
        }
    }

    #[test]
    fn setpoint_read_if_new_reports_each_write_once() {
        // SAFETY: single thread, reads and writes never nest.
        let h = unsafe { SetpointHandoff::new(7u64) };
        let (v, seq) = h.read();
        assert_eq!((v, seq), (7, 0));
        assert_eq!(h.read_if_new(seq), None);
        h.write(8);
        let (v, seq) = h.read_if_new(seq).unwrap();
        assert_eq!((v, seq), (8, 1));
        assert_eq!(h.read_if_new(seq), None);
        h.write(9);
        h.write(10);
        assert_eq!(h.read_if_new(seq), Some((10, 3)), "only the newest counts");
    }

    #[test]
    fn feedback_writer_preempting_the_reader_anywhere_is_never_torn() {
        // The writer (control interrupt) runs to completion in the middle of the reader's copy,
        // after each word; the reader must retry and return the new value whole.
        // SAFETY: single thread; the writer nests inside the reader's copy, the preemption the
        // seqlock is built for.
        let h = unsafe { FeedbackHandoff::<Block>::new([0; WORDS]) };
        let mut n = 0u32;
        for preempt_after in 0..=WORDS {
            let mut preempted = false;
            let (v, seq) = h.read_with(|data| {
                let mut out = [0u32; WORDS];
                for (i, word) in out.iter_mut().enumerate() {
                    if i == preempt_after && !preempted {
                        preempted = true;
                        n += 1;
                        h.write([n; WORDS]);
                    }
                    // SAFETY: `data` is valid for `Block`; single-threaded.
                    *word = unsafe { ptr::read_volatile(data.cast::<u32>().add(i)) };
                }
                MaybeUninit::new(out)
            });
            assert!(consistent(&v), "torn {v:?}");
            assert_eq!(v, [n; WORDS], "the retry sees the new value");
            assert_eq!(seq, n);
        }
    }

    #[test]
    fn feedback_reader_between_the_writer_steps_gets_the_previous_value() {
        // SAFETY: single thread; the reader nests inside the writer (possible on two cores).
        let h = unsafe { FeedbackHandoff::<Block>::new([5; WORDS]) };
        assert_eq!(h.read(), ([5; WORDS], 0));
        h.write_in_steps(|data| {
            for i in 0..WORDS {
                // Sequence odd: every attempt is refused, the last good value comes back.
                let (v, seq) = h.read();
                assert_eq!((v, seq), ([5; WORDS], 0));
                // SAFETY: `data` is valid for `Block`.
                unsafe { (*data)[i] = 6 };
            }
        });
        assert_eq!(h.read(), ([6; WORDS], 1));
    }

    #[test]
    fn feedback_read_if_new_copies_only_after_a_write() {
        // SAFETY: single thread.
        let h = unsafe { FeedbackHandoff::<Block>::new([1; WORDS]) };
        assert!(!h.written_since(0));
        assert_eq!(h.read_if_new(0), None, "the initial value is sequence 0");
        assert_eq!(
            h.read_if_new(7),
            Some(([1; WORDS], 0)),
            "another reader's number"
        );
        h.write([2; WORDS]);
        assert_eq!(h.read_if_new(0), Some(([2; WORDS], 1)));
        assert_eq!(h.read_if_new(1), None);
        h.write_in_steps(|data| {
            // A write under way: written since, but nothing consistent is new yet (the old
            // value is sequence 1).
            assert!(h.written_since(1));
            assert_eq!(h.read_if_new(1), None);
            // SAFETY: `data` is valid for `Block`.
            unsafe { *data = [3; WORDS] };
        });
        assert_eq!(h.read_if_new(1), Some(([3; WORDS], 2)));
    }

    #[test]
    fn feedback_reader_gives_up_after_the_bounded_attempts() {
        // A writer that overlaps every attempt: the reader returns the last consistent value.
        // SAFETY: single thread.
        let h = unsafe { FeedbackHandoff::<Block>::new([1; WORDS]) };
        assert_eq!(h.read(), ([1; WORDS], 0));
        let mut attempts = 0;
        let mut n = 1;
        let (v, seq) = h.read_with(|data| {
            attempts += 1;
            n += 1;
            h.write([n; WORDS]);
            // SAFETY: `data` is valid for `Block`.
            MaybeUninit::new(unsafe { ptr::read_volatile(data) })
        });
        assert_eq!(attempts, READ_ATTEMPTS);
        assert_eq!((v, seq), ([1; WORDS], 0));
        assert_eq!(h.read(), ([n; WORDS], READ_ATTEMPTS));
    }

    #[test]
    fn feedback_stress_with_threads_never_tears() {
        // The seqlock also holds between cores: a writer thread publishes (n, n, …, n) as fast
        // as it can, a reader thread checks every value it gets.
        const WRITES: u64 = 200_000;
        type Wide = [u64; 16];
        // SAFETY: exactly one writer thread and one reader thread below.
        let h = unsafe { FeedbackHandoff::<Wide>::new([0; 16]) };
        let done = std::sync::atomic::AtomicBool::new(false);
        std::thread::scope(|scope| {
            scope.spawn(|| {
                for n in 1..=WRITES {
                    h.write([n; 16]);
                }
                done.store(true, Ordering::Release);
            });
            scope.spawn(|| {
                let mut last = 0u64;
                let mut reads = 0u64;
                loop {
                    let finished = done.load(Ordering::Acquire);
                    let (v, seq) = h.read();
                    assert!(v.iter().all(|&w| w == v[0]), "torn {v:?}");
                    assert!(v[0] >= last, "went backwards: {} < {last}", v[0]);
                    assert_eq!(seq as u64, v[0], "sequence matches the value");
                    last = v[0];
                    reads += 1;
                    if finished {
                        break;
                    }
                }
                assert_eq!(last, WRITES, "the final value is seen after {reads} reads");
            });
        });
    }
}
