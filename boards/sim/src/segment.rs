//! A segment: simulated drives in one EtherCAT ring, each of its own profile (a line may mix
//! profiles), with a simulated clock.
//!
//! Time is simulated: it moves only when a frame is processed (by the frame's time on the wire)
//! or when the caller advances it. A test can therefore run thousands of 250 µs cycles as fast
//! as the host allows and still see every SYNC0 at its exact time.

use std::sync::{Mutex, PoisonError};

use firmware::profile::DriveProfile;

use crate::drive::SimDrive;
use crate::esc::{self, Et1100};
use crate::plant::Fidelity;
use crate::record::Recorder;
use crate::workers::Workers;

/// Time a frame of `len` bytes spends on a 100 Mbit/s wire, plus the fixed forwarding latency
/// of the master's NIC (a few µs on a PC); both only need to be plausible, not exact.
fn wire_time_ns(len: usize) -> u64 {
    const NS_PER_BYTE: u64 = 80; // 100 Mbit/s
    const NIC_LATENCY_NS: u64 = 2_000;
    len as u64 * NS_PER_BYTE + NIC_LATENCY_NS
}

/// Why a segment could not be built.
#[derive(Debug)]
pub enum SegmentError {
    /// No built-in profile of that name.
    UnknownProfile(String),
    /// od-gen refused the profile.
    Profile(String),
    /// The firmware refused the profile.
    Slave(firmware::slave::SlaveError),
}

impl std::fmt::Display for SegmentError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::UnknownProfile(n) => write!(
                f,
                "no built-in profile named {n:?}; available: {}",
                od_gen::builtin_names().join(", ")
            ),
            Self::Profile(e) => write!(f, "profile error: {e}"),
            Self::Slave(e) => write!(f, "firmware refused the profile: {e:?}"),
        }
    }
}

impl std::error::Error for SegmentError {}

/// A device on the simulated segment: an ESC and the firmware behind it, advanced in simulated
/// time. [`SimDrive`] is the servo drive; any other slave built on `ethercat-slave` (e.g. the
/// digital I/O module of the tests) plugs in the same way. `Send`: a segment may advance its
/// devices on several threads ([`Segment::set_threads`]).
pub trait SimDevice: Send {
    /// The device's ESC.
    fn esc(&self) -> &Et1100;
    /// The device's ESC, mutable (frames pass through it).
    fn esc_mut(&mut self) -> &mut Et1100;
    /// Earliest simulated time at which the device has something to do.
    fn next_event_ns(&self) -> Option<u64>;
    /// Moves the device to simulated time `now_ns`, running the firmware handlers that are due.
    fn run_until(&mut self, now_ns: u64);
    /// Runs the ESC event handler while the IRQ line is asserted.
    fn service_irq(&mut self, now_ns: u64);
}

impl SimDevice for SimDrive {
    fn esc(&self) -> &Et1100 {
        &self.esc
    }
    fn esc_mut(&mut self) -> &mut Et1100 {
        &mut self.esc
    }
    fn next_event_ns(&self) -> Option<u64> {
        SimDrive::next_event_ns(self)
    }
    fn run_until(&mut self, now_ns: u64) {
        SimDrive::run_until(self, now_ns);
    }
    fn service_irq(&mut self, now_ns: u64) {
        SimDrive::service_irq(self, now_ns);
    }
}

/// Devices in ring order and the simulated time.
pub struct Segment<D: SimDevice = SimDrive> {
    drives: Vec<D>,
    now_ns: u64,
    /// The master's frames, recorded for the fuzzers' seeds (`SIM_RECORD_FRAMES`).
    recorder: Option<Recorder>,
    /// The `threads` − 1 helper threads, started once ([`crate::workers`]).
    workers: Option<Workers>,
}

impl Segment {
    /// `count` drives of the built-in profile `profile` (`sdv3-e` or `sdv3_e`).
    pub fn new(profile: &str, count: usize) -> Result<Self, SegmentError> {
        let (fw_profile, sii) = load_profile(profile)?;
        let drives = (0..count)
            .map(|_| SimDrive::new(fw_profile, &sii).map_err(SegmentError::Slave))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self::from_devices(drives))
    }

    /// A line of drives of (possibly) different built-in profiles, one drive per name, in ring
    /// order: the first name is the drive next to the master (station 0x1000 with ethercrab,
    /// 0x1001 with SOEM). Each drive runs its own profile: its own object dictionary, SII
    /// (identity, SM layout) and default PDO mapping.
    pub fn line<S: AsRef<str>>(profiles: &[S]) -> Result<Self, SegmentError> {
        Self::line_with_plant(profiles, Fidelity::default())
    }

    /// [`Self::line`] with every drive's plant at the given fidelity.
    pub fn line_with_plant<S: AsRef<str>>(
        profiles: &[S],
        plant: Fidelity,
    ) -> Result<Self, SegmentError> {
        // Each profile is resolved (and its SII built) once, however often it occurs.
        let mut loaded: Vec<(&str, &'static DriveProfile, Vec<u8>)> = Vec::new();
        let mut drives = Vec::with_capacity(profiles.len());
        for name in profiles {
            let name = name.as_ref();
            let at = match loaded.iter().position(|(n, ..)| *n == name) {
                Some(at) => at,
                None => {
                    let (fw_profile, sii) = load_profile(name)?;
                    loaded.push((name, fw_profile, sii));
                    loaded.len() - 1
                }
            };
            let (_, fw_profile, sii) = &loaded[at];
            drives.push(SimDrive::with_plant(fw_profile, sii, plant).map_err(SegmentError::Slave)?);
        }
        Ok(Self::from_devices(drives))
    }
}

/// The firmware profile and the SII image of the built-in profile `name`.
fn load_profile(name: &str) -> Result<(&'static DriveProfile, Vec<u8>), SegmentError> {
    let fw_profile = firmware::profiles::by_name(name)
        .ok_or_else(|| SegmentError::UnknownProfile(name.to_string()))?;
    let sii = od_gen::builtin(name)
        .map_err(|e| SegmentError::Profile(e.to_string()))?
        .sii_image();
    Ok((fw_profile, sii))
}

impl<D: SimDevice> Segment<D> {
    /// A segment of `devices` in ring order, at simulated time 0.
    pub fn from_devices(devices: Vec<D>) -> Self {
        let recorder = devices
            .first()
            .and_then(|d| Recorder::from_env(d.esc().sii()));
        let mut segment = Self {
            drives: devices,
            now_ns: 0,
            recorder,
            workers: None,
        };
        segment.wire_ports();
        segment
    }

    /// Tells each ESC whether a next drive hangs on its port 1 (the last one closes the ring).
    fn wire_ports(&mut self) {
        let n = self.drives.len();
        for (i, d) in self.drives.iter_mut().enumerate() {
            d.esc_mut().set_port_connected(1, i + 1 < n);
        }
    }

    /// Simulated time in ns.
    pub fn now_ns(&self) -> u64 {
        self.now_ns
    }

    /// The drives in ring order.
    pub fn drives(&self) -> &[D] {
        &self.drives
    }

    /// Plugs or pulls the cable between the master and the first drive (its port 0): while it is
    /// pulled no frame passes and the drive sees no link on its input port (DL status 0x0110).
    pub fn set_master_cable(&mut self, connected: bool) {
        if let Some(d) = self.drives.first_mut() {
            d.esc_mut().set_port_connected(0, connected);
        }
    }

    /// The drives in ring order, mutable (for fault injection in tests).
    pub fn drives_mut(&mut self) -> &mut [D] {
        &mut self.drives
    }

    /// Passes one Ethernet frame from the master through the ring and returns the frame that
    /// comes back (`None` for anything that is not an EtherCAT frame). The firmware of every
    /// drive reacts to the frame before the next one arrives, as an interrupt-driven slave does
    /// within a few µs.
    pub fn process_frame(&mut self, frame: &[u8]) -> Option<Vec<u8>> {
        let t = self.now_ns + wire_time_ns(frame.len());
        self.advance_to(t);
        if let Some(r) = self.recorder.as_mut() {
            r.frame(t, frame);
        }
        if self
            .drives
            .first()
            .is_some_and(|d| !d.esc().port0_connected())
        {
            // The cable to the master is pulled: the frame reaches no drive and none comes back.
            return None;
        }
        let mut reply = frame.to_vec();
        esc::process_frame(&mut reply, self.drives.iter_mut().map(|d| d.esc_mut())).ok()?;
        // Most frames raise an event in a few drives at most (a mailbox poll, an AL control):
        // those run on the caller's thread. A cyclic frame raises one in every drive. (The
        // lines are counted only where there are helpers to share the rounds with.)
        let spread = self.workers.is_some()
            && self.drives.iter().filter(|d| d.esc().irq_line()).count()
                >= MIN_PARALLEL_EVENT_ROUNDS;
        self.each_drive(spread, |d| d.service_irq(t));
        Some(reply)
    }

    /// Advances simulated time by `dt_ns`, running every SYNC0, timer and IRQ on the way.
    pub fn advance(&mut self, dt_ns: u64) {
        // Saturating: simulated time ends at u64::MAX ns (584 years), it does not wrap.
        self.advance_to(self.now_ns.saturating_add(dt_ns));
    }

    /// Advances simulated time to `t_ns` (no-op if it is in the past), event by event.
    ///
    /// Each drive runs its own events in order (its SYNC0s, timers and IRQs): the drives
    /// interact through frames alone, and a frame passes only after every drive has been
    /// brought to its time. So the drives can advance one after the other or, with
    /// [`Segment::set_threads`], on several cores at once, with the same results. (Running every
    /// drive at every drive's event made a line cost the square of its length: each drive's
    /// ESC has its own clock, so N drives have N different SYNC0 instants.)
    pub fn advance_to(&mut self, t_ns: u64) {
        let (from, to) = (self.now_ns, t_ns.max(self.now_ns));
        let work = (to - from).saturating_mul(self.drives.len() as u64);
        self.each_drive(work >= MIN_PARALLEL_WORK, |d| advance_drive(d, from, to));
        self.now_ns = to;
    }

    /// Runs `f` on every drive: when `worth_threads`, on the caller's thread and the helpers
    /// of [`Segment::set_threads`], each taking [`DRIVES_PER_TAKE`] drives at a time until
    /// none is left, else on the caller's alone. The drives are independent of each other, so
    /// the results are the same either way.
    fn each_drive(&mut self, worth_threads: bool, f: impl Fn(&mut D) + Sync) {
        match &self.workers {
            Some(workers) if worth_threads && self.drives.len() > DRIVES_PER_TAKE => {
                let queue = Mutex::new(self.drives.chunks_mut(DRIVES_PER_TAKE));
                let take = || queue.lock().unwrap_or_else(PoisonError::into_inner).next();
                workers.run(&|| {
                    while let Some(part) = take() {
                        part.iter_mut().for_each(&f);
                    }
                });
            }
            _ => self.drives.iter_mut().for_each(f),
        }
    }

    /// Lets [`Segment::advance_to`] and the ESC event rounds after a frame spread the drives
    /// over `threads` threads (1, the default: all on the caller's). The `threads` − 1 helper
    /// threads are started here and live as long as the segment (or the next call); each
    /// spins for [`crate::workers::SPIN_BEFORE_PARK`] after a job before it sleeps.
    pub fn set_threads(&mut self, threads: usize) -> std::io::Result<()> {
        let threads = threads.max(1);
        self.workers = None;
        if threads > 1 {
            self.workers = Some(Workers::new(threads - 1)?);
        }
        Ok(())
    }
}

/// Drives a thread takes from the line at a time in [`Segment::advance_to`]: small, so that a
/// helper that wakes up late still finds a share.
pub const DRIVES_PER_TAKE: usize = 2;
/// Least simulated drive time (drives × the advance, in ns) [`Segment::advance_to`] spreads
/// over threads: a hand-over to spinning helpers costs about a µs of host time, about what
/// one drive with the averaged plant simulates in 40 µs (a 128-drive line spreads even a
/// short frame's wire time, a 4-drive line advances of 100 µs and more).
pub const MIN_PARALLEL_WORK: u64 = 400_000;
/// Fewest ESC event rounds after a frame worth spreading over threads (one round is a few
/// hundred ns to a few µs of host time).
pub const MIN_PARALLEL_EVENT_ROUNDS: usize = 16;

/// Runs `d`'s events from `from_ns` up to `to_ns` in order, then brings it to `to_ns`.
fn advance_drive<D: SimDevice>(d: &mut D, from_ns: u64, to_ns: u64) {
    let mut next = d.next_event_ns();
    while let Some(e) = next.filter(|e| (from_ns..=to_ns).contains(e)) {
        d.run_until(e);
        next = d.next_event_ns();
        // Guard against an event source that does not move on.
        if next == Some(e) {
            break;
        }
    }
    d.run_until(to_ns);
}
