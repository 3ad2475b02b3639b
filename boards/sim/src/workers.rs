//! Worker threads that share the caller's work on a segment's drives ([`Workers::run`]).
//!
//! A segment hands its drives to several threads many times per bus cycle (every frame's wire
//! time, every frame's ESC event rounds, the rest of the cycle), each time for a few tens of
//! µs to a few ms of host time. Starting a thread per hand-over costs about 55 µs on this
//! project's (virtual) machines, and waking a parked one 70 to 200 µs: as much as the work.
//! So the workers here stay awake, spinning, for [`SPIN_BEFORE_PARK`] after each job, and the
//! caller never waits for a worker that has not started: it works through the job itself, then
//! closes it; a worker that wakes up late finds it closed and goes back to waiting.

use std::panic::{self, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard, PoisonError};
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

/// How long an idle worker spins waiting for the next job before it parks: longer than the
/// serial gaps within a bus cycle of a long line (the master's work, a frame through the ESCs).
pub const SPIN_BEFORE_PARK: Duration = Duration::from_millis(2);

/// A job as the workers see it. Its real lifetime is that of one [`Workers::run`] call, which
/// does not return before every worker that entered the job has left it (see `run`).
type Job = &'static (dyn Fn() + Sync);

/// The job of the moment, under the lock.
#[derive(Default)]
struct Slot {
    job: Option<Job>,
    /// The epoch of `job`.
    epoch: u64,
    /// Workers inside `job`.
    active: usize,
    /// A worker's job panicked.
    panicked: bool,
}

struct Shared {
    slot: Mutex<Slot>,
    /// Signalled when `active` drops to 0.
    left: Condvar,
    /// Incremented for every job (read without the lock by spinning workers).
    epoch: AtomicU64,
    stop: AtomicBool,
}

impl Shared {
    fn slot(&self) -> MutexGuard<'_, Slot> {
        // A job's panic is caught before the lock is taken again: nothing poisons it.
        self.slot.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

/// Threads that help [`Workers::run`]'s caller with its job.
pub struct Workers {
    shared: Arc<Shared>,
    threads: Vec<JoinHandle<()>>,
}

impl Workers {
    /// `helpers` threads beside the caller's.
    pub fn new(helpers: usize) -> std::io::Result<Self> {
        let shared = Arc::new(Shared {
            slot: Mutex::new(Slot::default()),
            left: Condvar::new(),
            epoch: AtomicU64::new(0),
            stop: AtomicBool::new(false),
        });
        let mut workers = Self {
            shared,
            threads: Vec::with_capacity(helpers),
        };
        for n in 0..helpers {
            let shared = workers.shared.clone();
            let handle = thread::Builder::new()
                .name(format!("sim-line-{n}"))
                .spawn(move || work(&shared))?;
            workers.threads.push(handle);
        }
        Ok(workers)
    }

    /// Runs `job` on the caller's thread and on every worker that is ready for it before the
    /// caller has finished it: `job` must share its work out itself (e.g. take chunks from a
    /// common queue until none is left) and be done, for every thread, when the caller's call
    /// returns. Returns when no worker is inside `job` any more. A panic in `job` on a worker
    /// is raised here, on the caller's thread.
    pub fn run(&self, job: &(dyn Fn() + Sync)) {
        // SAFETY: the reference only widens the lifetime seen by the workers. A worker calls
        // the job only after taking it from the slot under the lock, with `active` raised; this
        // function clears the slot under the lock and then waits, under the same lock, until
        // `active` is 0, before it returns and the borrow ends. So no worker touches `job`
        // after this call returns.
        let erased: Job = unsafe { std::mem::transmute::<&(dyn Fn() + Sync), Job>(job) };
        {
            let mut slot = self.shared.slot();
            slot.job = Some(erased);
            slot.epoch = self.shared.epoch.fetch_add(1, Ordering::Release) + 1;
        }
        for t in &self.threads {
            t.thread().unpark();
        }
        let own = panic::catch_unwind(AssertUnwindSafe(job));
        let mut slot = self.shared.slot();
        slot.job = None;
        while slot.active > 0 {
            slot = self
                .shared
                .left
                .wait(slot)
                .unwrap_or_else(PoisonError::into_inner);
        }
        let worker_panicked = std::mem::take(&mut slot.panicked);
        drop(slot);
        if let Err(payload) = own {
            panic::resume_unwind(payload);
        }
        if worker_panicked {
            panic!("a simulation worker thread panicked");
        }
    }
}

impl Drop for Workers {
    fn drop(&mut self) {
        self.shared.stop.store(true, Ordering::Release);
        for t in &self.threads {
            t.thread().unpark();
        }
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

/// A worker's life: wait for a new epoch (spinning, then parked), enter its job if it is still
/// open, leave it.
fn work(shared: &Shared) {
    // The epoch when the workers were made (not loaded here: a job may have been posted
    // before this thread got to run).
    let mut seen = 0;
    loop {
        let idle_since = Instant::now();
        loop {
            if shared.stop.load(Ordering::Acquire) {
                return;
            }
            if shared.epoch.load(Ordering::Acquire) != seen {
                break;
            }
            if idle_since.elapsed() < SPIN_BEFORE_PARK {
                std::hint::spin_loop();
            } else {
                // `run` unparks after bumping the epoch: a token left from then ends this at
                // once, and the epoch is checked again.
                thread::park();
            }
        }
        let job = {
            let mut slot = shared.slot();
            seen = slot.epoch;
            let job = slot.job;
            if job.is_some() {
                slot.active += 1;
            }
            job
        };
        let Some(job) = job else {
            continue; // closed before this worker got to it
        };
        let result = panic::catch_unwind(AssertUnwindSafe(job));
        let mut slot = shared.slot();
        slot.active -= 1;
        slot.panicked |= result.is_err();
        if slot.active == 0 {
            shared.left.notify_all();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::AtomicUsize;

    /// Every item is processed exactly once, whoever takes it.
    #[test]
    fn a_shared_queue_is_worked_off_exactly_once() {
        let workers = Workers::new(3).expect("threads");
        for round in 0..200 {
            let items: Vec<AtomicUsize> = (0..64).map(|_| AtomicUsize::new(0)).collect();
            let next = AtomicUsize::new(0);
            workers.run(&|| loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                let Some(item) = items.get(i) else { break };
                item.fetch_add(1, Ordering::Relaxed);
            });
            assert!(
                items.iter().all(|i| i.load(Ordering::Relaxed) == 1),
                "round {round}"
            );
        }
    }

    /// A job that has returned on the caller's thread is not entered by a late worker, and
    /// `run` waits for the workers inside it.
    #[test]
    fn run_returns_only_when_no_worker_is_inside_the_job() {
        let workers = Workers::new(1).expect("threads");
        for _ in 0..100 {
            let inside = AtomicUsize::new(0);
            let finished = AtomicUsize::new(0);
            workers.run(&|| {
                inside.fetch_add(1, Ordering::SeqCst);
                thread::sleep(Duration::from_micros(50));
                finished.fetch_add(1, Ordering::SeqCst);
            });
            assert_eq!(
                inside.load(Ordering::SeqCst),
                finished.load(Ordering::SeqCst)
            );
        }
    }

    #[test]
    fn a_panic_on_a_worker_reaches_the_caller() {
        let workers = Workers::new(1).expect("threads");
        let caller = thread::current().id();
        let entered = AtomicBool::new(false);
        let result = panic::catch_unwind(AssertUnwindSafe(|| {
            workers.run(&|| {
                if thread::current().id() != caller {
                    entered.store(true, Ordering::SeqCst);
                    panic!("worker");
                }
                // The caller stays inside until the worker has entered (it is spinning or
                // parked and unparked: it enters within a scheduling delay).
                let deadline = Instant::now() + Duration::from_secs(30);
                while !entered.load(Ordering::SeqCst) && Instant::now() < deadline {
                    thread::yield_now();
                }
            })
        }));
        assert!(entered.load(Ordering::SeqCst), "the worker never entered");
        assert!(result.is_err());
        // The workers still serve the next job.
        let n = AtomicUsize::new(0);
        workers.run(&|| {
            n.fetch_add(1, Ordering::SeqCst);
        });
        assert!(n.load(Ordering::SeqCst) >= 1);
    }
}
