//! Attaches a simulated segment to a network interface with a raw socket (AF_PACKET, EtherType
//! 0x88A4), so that any external master — TwinCAT, SOEM, IgH, ethercrab — can drive it.
//!
//! Simulated time follows the host's monotonic clock here, so SYNC0 and watchdogs run in real
//! time. Replies go out on the same interface; on a veth pair the master sits on the peer end.
//!
//! A line too long for the host cannot keep that pace: simulating a millisecond takes longer
//! than a millisecond, and each drive's SYNC0 and timers run late. That is reported (missed
//! deadlines, [`Lag`]) rather than left for the master to puzzle over.

use std::io;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use crate::segment::Segment;

/// EtherCAT EtherType.
const ETHERTYPE_ETHERCAT: u16 = 0x88A4;
/// Largest frame we receive (standard Ethernet MTU plus header).
const MAX_FRAME: usize = 1518;
/// How far behind the wall clock the simulation may run its events before they count as a
/// missed deadline: a frame's worth of scheduling noise of an ordinary process.
pub const DEADLINE_SLACK: Duration = Duration::from_millis(1);
/// Fewest time between two reports of a simulation that runs late.
const LAG_REPORT_PERIOD: Duration = Duration::from_secs(1);

/// Whether the simulation keeps the wall clock's pace: after advancing to simulated time `t`
/// the host clock should not be past `t +` [`DEADLINE_SLACK`].
#[derive(Debug, Default, Clone, PartialEq)]
pub struct Lag {
    /// Times the simulation ran its events more than the slack late.
    pub missed: u64,
    /// The longest lag seen.
    pub worst: Duration,
    /// Missed deadlines not yet reported, and when the last report was.
    unreported: u64,
    last_report: Option<Duration>,
}

impl Lag {
    /// The simulation reached `simulated`, the host clock then showed `wall`. Returns a line
    /// to print when deadlines were missed and the last report is a while ago.
    pub fn observe(&mut self, simulated: Duration, wall: Duration) -> Option<String> {
        let behind = wall.saturating_sub(simulated);
        if behind <= DEADLINE_SLACK {
            return None;
        }
        self.missed += 1;
        self.unreported += 1;
        self.worst = self.worst.max(behind);
        if self
            .last_report
            .is_some_and(|last| wall.saturating_sub(last) < LAG_REPORT_PERIOD)
        {
            return None;
        }
        self.last_report = Some(wall);
        let line = format!(
            "sim-drive: {:.1} ms behind real time, {} missed deadline(s) since the last report: \
             the host cannot simulate this line at the wall clock's pace (fewer drives, \
             --plant averaged or more --threads)",
            behind.as_secs_f64() * 1e3,
            self.unreported
        );
        self.unreported = 0;
        Some(line)
    }

    /// The summary for the end of a run.
    pub fn summary(&self) -> String {
        format!(
            "{} missed deadline(s) (events run more than {} ms late; longest lag {:.1} ms)",
            self.missed,
            DEADLINE_SLACK.as_millis(),
            self.worst.as_secs_f64() * 1e3
        )
    }
}

/// Longest wait for a frame when no simulated event is due (keeps the stop flag responsive).
const IDLE_WAIT: Duration = Duration::from_millis(10);
/// How often the interface's link state is read.
const LINK_POLL: Duration = Duration::from_millis(50);

static STOP: AtomicBool = AtomicBool::new(false);

extern "C" fn on_signal(_: libc::c_int) {
    STOP.store(true, Ordering::SeqCst);
}

/// A raw socket bound to one interface and EtherType 0x88A4.
pub struct RawSocket {
    fd: libc::c_int,
}

impl RawSocket {
    /// Opens and binds the socket (needs CAP_NET_RAW, e.g. inside `unshare --user --map-root-user --net`).
    pub fn open(interface: &str) -> io::Result<Self> {
        let name = std::ffi::CString::new(interface).map_err(|_| {
            io::Error::new(io::ErrorKind::InvalidInput, "interface name contains NUL")
        })?;
        // SAFETY: plain libc calls with valid arguments; every result is checked.
        unsafe {
            let ifindex = libc::if_nametoindex(name.as_ptr());
            if ifindex == 0 {
                return Err(io::Error::last_os_error());
            }
            let proto = ETHERTYPE_ETHERCAT.to_be() as libc::c_int;
            let fd = libc::socket(libc::AF_PACKET, libc::SOCK_RAW | libc::SOCK_CLOEXEC, proto);
            if fd < 0 {
                return Err(io::Error::last_os_error());
            }
            let sock = Self { fd };
            let mut addr: libc::sockaddr_ll = std::mem::zeroed();
            addr.sll_family = libc::AF_PACKET as u16;
            addr.sll_protocol = ETHERTYPE_ETHERCAT.to_be();
            addr.sll_ifindex = ifindex as i32;
            let r = libc::bind(
                fd,
                &addr as *const libc::sockaddr_ll as *const libc::sockaddr,
                std::mem::size_of::<libc::sockaddr_ll>() as libc::socklen_t,
            );
            if r < 0 {
                return Err(io::Error::last_os_error());
            }
            Ok(sock)
        }
    }

    /// Whether the interface is up with a link (IFF_UP and IFF_RUNNING): a veth whose peer was
    /// taken down, or a NIC without a cable, is not.
    pub fn link_up(&self, interface: &str) -> io::Result<bool> {
        let mut req: libc::ifreq = unsafe { std::mem::zeroed() };
        let name = interface.as_bytes();
        if name.len() >= req.ifr_name.len() {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                "interface name too long",
            ));
        }
        for (dst, &src) in req.ifr_name.iter_mut().zip(name) {
            *dst = src as libc::c_char;
        }
        // SAFETY: SIOCGIFFLAGS reads the flags into the zero-initialised request, whose name is
        // NUL-terminated (checked length above).
        let r = unsafe { libc::ioctl(self.fd, libc::SIOCGIFFLAGS, &mut req) };
        if r < 0 {
            return Err(io::Error::last_os_error());
        }
        // SAFETY: SIOCGIFFLAGS filled the flags member of the union.
        let flags = unsafe { req.ifr_ifru.ifru_flags };
        let want = (libc::IFF_UP | libc::IFF_RUNNING) as libc::c_short;
        Ok(flags & want == want)
    }

    /// Waits up to `timeout` for a frame; `Ok(None)` on timeout.
    pub fn recv(&self, buf: &mut [u8], timeout: Duration) -> io::Result<Option<usize>> {
        let ts = libc::timespec {
            tv_sec: timeout.as_secs() as libc::time_t,
            tv_nsec: timeout.subsec_nanos() as libc::c_long,
        };
        let mut pfd = libc::pollfd {
            fd: self.fd,
            events: libc::POLLIN,
            revents: 0,
        };
        // SAFETY: pfd and ts outlive the call; buf is a valid writable slice.
        unsafe {
            let r = libc::ppoll(&mut pfd, 1, &ts, std::ptr::null());
            if r < 0 {
                let e = io::Error::last_os_error();
                return if e.kind() == io::ErrorKind::Interrupted {
                    Ok(None)
                } else {
                    Err(e)
                };
            }
            if r == 0 {
                return Ok(None);
            }
            let n = libc::recv(self.fd, buf.as_mut_ptr() as *mut libc::c_void, buf.len(), 0);
            if n < 0 {
                return Err(io::Error::last_os_error());
            }
            Ok(Some(n as usize))
        }
    }

    /// Sends one frame.
    pub fn send(&self, frame: &[u8]) -> io::Result<()> {
        // SAFETY: frame is a valid readable slice.
        let n = unsafe {
            libc::send(
                self.fd,
                frame.as_ptr() as *const libc::c_void,
                frame.len(),
                0,
            )
        };
        if n < 0 {
            Err(io::Error::last_os_error())
        } else {
            Ok(())
        }
    }
}

impl Drop for RawSocket {
    fn drop(&mut self) {
        // SAFETY: fd is owned by this socket and closed once.
        unsafe {
            libc::close(self.fd);
        }
    }
}

/// Fault injection for tests of the master/slave recovery paths (`sim-drive attach` flags).
#[derive(Clone, Copy, Debug, Default)]
pub struct Faults {
    /// Drop the reply to the frame that carries the K-th successful read (1-based) of drive
    /// 0's slave → master mailbox: the ESC has handed the response over, the master never sees
    /// it, and must recover with a mailbox repeat request (ETG.1000.4 §5.6).
    pub drop_mailbox_read: Option<u32>,
    /// Lose every N-th cyclic frame from the master (one with a logical read/write: the process
    /// data) on the cable: it reaches no drive and nothing comes back (the master sees a
    /// timeout or a working-counter error; the drives see a cycle without new outputs).
    /// Mailbox and configuration frames pass.
    pub lose_every: Option<u32>,
    /// Pull the cable between master and first drive at this time after the start, for this
    /// long: no frame passes and the first drive loses the link on its port 0.
    pub cable_out: Option<(Duration, Duration)>,
    /// Stop the first drive's MCU at this time after the start, for this long, then restart it
    /// with its ESC as it is (see [`crate::SimDrive::halt_mcu`]): the ESC's PDI watchdog runs
    /// out, and the restart is reported with AL status code 0x0060.
    pub mcu_halt: Option<(Duration, Duration)>,
}

/// Whether `elapsed` falls into the window (start, length).
fn within(window: Option<(Duration, Duration)>, elapsed: Duration) -> bool {
    window.is_some_and(|(at, long)| elapsed >= at && elapsed < at.saturating_add(long))
}

/// What fault injection does to the frames from the master.
#[derive(Debug, Default)]
pub struct Injector {
    faults: Faults,
    frames: u64,
    lost: u64,
}

impl Injector {
    /// Injects `faults`.
    pub fn new(faults: Faults) -> Self {
        Self {
            faults,
            ..Self::default()
        }
    }

    /// Whether `frame` from the master is lost (`lose_every`, counting cyclic frames).
    pub fn loses(&mut self, frame: &[u8]) -> bool {
        let cyclic = crate::esc::datagrams(frame)
            .iter()
            .any(|d| matches!(d.command, CMD_LRD | CMD_LWR | CMD_LRW));
        if !cyclic {
            return false;
        }
        self.frames = self.frames.saturating_add(1);
        let lost = self
            .faults
            .lose_every
            .is_some_and(|n| n > 0 && self.frames % u64::from(n) == 0);
        if lost {
            self.lost = self.lost.saturating_add(1);
        }
        lost
    }

    /// Frames lost so far.
    pub fn lost(&self) -> u64 {
        self.lost
    }

    /// Whether the cable to the first drive is plugged `elapsed` after the start, with the
    /// network interface's link `interface_up` (an interface taken down is a pulled cable).
    pub fn cable_plugged(&self, elapsed: Duration, interface_up: bool) -> bool {
        interface_up && !within(self.faults.cable_out, elapsed)
    }

    /// Whether the first drive's MCU runs `elapsed` after the start.
    pub fn mcu_running(&self, elapsed: Duration) -> bool {
        !within(self.faults.mcu_halt, elapsed)
    }
}

/// Command codes (ETG.1000.4 Table 20): FPRD, and the logical reads and writes.
const CMD_FPRD: u8 = 4;
const CMD_LRD: u8 = 10;
const CMD_LWR: u8 = 11;
const CMD_LRW: u8 = 12;

/// Whether `frame` (as returned) contains an FPRD with a non-zero working counter of `len`
/// bytes at ESC address `ado`: a completed mailbox read.
fn reads_mailbox(frame: &[u8], ado: u16, len: u16) -> bool {
    crate::esc::datagrams(frame).iter().any(|d| {
        d.command == CMD_FPRD
            && (d.address >> 16) as u16 == ado
            && d.len == usize::from(len)
            && d.wkc > 0
    })
}

/// Serves `segment` on `interface` until SIGINT/SIGTERM or `duration` elapses, printing every
/// EtherCAT state change of every drive. Returns the number of frames answered.
pub fn serve(segment: Segment, interface: &str, duration: Option<Duration>) -> io::Result<u64> {
    serve_with_faults(segment, interface, duration, Faults::default())
}

/// [`serve`] with fault injection.
pub fn serve_with_faults(
    mut segment: Segment,
    interface: &str,
    duration: Option<Duration>,
    faults: Faults,
) -> io::Result<u64> {
    let mailbox_in = segment
        .drives()
        .first()
        .map(|d| d.slave.profile().device.mailbox_in);
    let mut mailbox_reads = 0u32;
    let sock = RawSocket::open(interface)?;
    // SAFETY: installing a handler that only stores to an atomic is async-signal-safe.
    unsafe {
        libc::signal(libc::SIGINT, on_signal as *const () as libc::sighandler_t);
        libc::signal(libc::SIGTERM, on_signal as *const () as libc::sighandler_t);
    }
    let start = Instant::now();
    let mut injector = Injector::new(faults);
    let mut plugged = true;
    let mut mcu_running = true;
    let mut next_link_check = Duration::ZERO;
    let mut interface_up = true;
    let mut buf = vec![0u8; MAX_FRAME];
    let mut frames = 0u64;
    let mut states: Vec<_> = segment
        .drives()
        .iter()
        .map(|d| d.slave.al_status())
        .collect();
    println!(
        "sim-drive: {} drive(s) on {interface}, waiting for a master (Ctrl-C stops)",
        states.len()
    );
    let mut lag = Lag::default();
    while !STOP.load(Ordering::SeqCst) && duration.is_none_or(|d| start.elapsed() < d) {
        let now = start.elapsed().as_nanos() as u64;
        segment.advance_to(now);
        if let Some(line) = lag.observe(Duration::from_nanos(now), start.elapsed()) {
            println!("{line}");
        }
        let next = segment
            .drives()
            .iter()
            .filter_map(|d| d.next_event_ns())
            .min();
        let wait = next.map_or(IDLE_WAIT, |t| {
            Duration::from_nanos(t.saturating_sub(now)).min(IDLE_WAIT)
        });
        // The link: the interface's own (polled) and the injected cable pull.
        let elapsed = start.elapsed();
        if elapsed >= next_link_check {
            interface_up = sock.link_up(interface).unwrap_or(true);
            next_link_check = elapsed + LINK_POLL;
        }
        let now_plugged = injector.cable_plugged(elapsed, interface_up);
        if now_plugged != plugged {
            plugged = now_plugged;
            segment.set_master_cable(plugged);
            println!(
                "sim-drive: cable to drive 0 {}",
                if plugged {
                    "plugged in"
                } else {
                    "pulled (no link on its port 0)"
                }
            );
        }
        let now_running = injector.mcu_running(elapsed);
        if now_running != mcu_running {
            mcu_running = now_running;
            if let Some(d) = segment.drives_mut().first_mut() {
                if mcu_running {
                    d.restart_mcu()
                        .map_err(|e| io::Error::other(format!("{e:?}")))?;
                    println!("sim-drive: drive 0's MCU restarted (its ESC kept its state)");
                } else {
                    d.halt_mcu();
                    println!("sim-drive: drive 0's MCU stopped (the ESC goes on)");
                }
            }
        }
        if let Some(n) = sock.recv(&mut buf, wait)? {
            let frame = buf.get(..n).unwrap_or(&[]);
            // Frames we sent ourselves carry the locally-administered bit: never answer those.
            if frame.get(6).is_some_and(|b| b & 0x02 != 0) {
                continue;
            }
            if injector.loses(frame) {
                continue;
            }
            segment.advance_to(start.elapsed().as_nanos() as u64);
            // With the cable pulled the frame reaches no drive: `process_frame` gives nothing.
            if let Some(reply) = segment.process_frame(frame) {
                if let (Some(k), Some(mbx)) = (faults.drop_mailbox_read, mailbox_in) {
                    if reads_mailbox(&reply, mbx.start, mbx.length) {
                        mailbox_reads += 1;
                        if mailbox_reads == k {
                            println!(
                                "sim-drive: fault injection: dropped the reply to mailbox read {k}"
                            );
                            continue;
                        }
                    }
                }
                sock.send(&reply)?;
                frames += 1;
            }
        }
        for (i, d) in segment.drives().iter().enumerate() {
            let s = d.slave.al_status();
            if let Some(old) = states.get_mut(i) {
                if *old != s {
                    println!(
                        "drive {i}: {:?} -> {:?}{} (AL status code {:#06x})",
                        old.0.state,
                        s.0.state,
                        if s.0.error { " +ERR" } else { "" },
                        s.1.code()
                    );
                    *old = s;
                }
            }
        }
    }
    println!(
        "sim-drive: stopped after {frames} frames ({} lost by fault injection); {}",
        injector.lost(),
        lag.summary()
    );
    Ok(frames)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An EtherCAT frame with one datagram of `command` (2 data bytes).
    fn frame(command: u8) -> Vec<u8> {
        let mut f = vec![0xFF; 6];
        f.extend_from_slice(&[2, 0, 0, 0, 0, 1]);
        f.extend_from_slice(&ETHERTYPE_ETHERCAT.to_be_bytes());
        f.extend_from_slice(&(14u16 | 0x1000).to_le_bytes());
        f.extend_from_slice(&[command, 0, 0, 0, 0, 0, 2, 0, 0, 0, 0, 0, 0, 0]);
        f
    }

    #[test]
    fn a_simulation_behind_the_wall_clock_counts_missed_deadlines_and_reports_once_a_second() {
        let ms = Duration::from_millis;
        let mut lag = Lag::default();
        assert_eq!(lag.observe(ms(10), ms(10)), None, "on time");
        assert_eq!(lag.observe(ms(10), ms(11)), None, "within the slack");
        assert_eq!(lag.missed, 0);
        let first = lag.observe(ms(20), ms(25)).expect("reported");
        assert!(
            first.contains("5.0 ms behind real time, 1 missed"),
            "{first}"
        );
        // Within the next second: counted, not reported.
        assert_eq!(lag.observe(ms(30), ms(40)), None);
        assert_eq!(lag.observe(ms(40), ms(43)), None);
        assert_eq!(lag.missed, 3);
        let second = lag.observe(ms(1030), ms(1032)).expect("a second later");
        assert!(
            second.contains("3 missed deadline(s) since the last report"),
            "{second}"
        );
        assert_eq!(lag.worst, ms(10));
        assert!(
            lag.summary().starts_with("4 missed deadline(s)"),
            "{}",
            lag.summary()
        );
        assert!(lag.summary().contains("longest lag 10.0 ms"));
    }

    #[test]
    fn every_nth_cyclic_frame_is_lost_and_counted_mailbox_frames_pass() {
        let mut inj = Injector::new(Faults {
            lose_every: Some(3),
            ..Faults::default()
        });
        let (cyclic, mailbox) = (frame(CMD_LRW), frame(CMD_FPRD));
        let mut lost = Vec::new();
        for _ in 0..9 {
            assert!(!inj.loses(&mailbox), "mailbox frames pass");
            lost.push(inj.loses(&cyclic));
        }
        assert_eq!(
            lost,
            [false, false, true, false, false, true, false, false, true]
        );
        assert_eq!(inj.lost(), 3);
        let mut none = Injector::new(Faults::default());
        assert!((0..100).all(|_| !none.loses(&cyclic)));
    }

    #[test]
    fn the_cable_is_out_for_its_window_and_whenever_the_interface_is_down() {
        let ms = Duration::from_millis;
        let inj = Injector::new(Faults {
            cable_out: Some((ms(1000), ms(200))),
            ..Faults::default()
        });
        assert!(inj.cable_plugged(ms(999), true));
        assert!(!inj.cable_plugged(ms(1000), true));
        assert!(!inj.cable_plugged(ms(1199), true));
        assert!(inj.cable_plugged(ms(1200), true));
        assert!(!inj.cable_plugged(ms(5), false), "interface down");
        assert!(
            (0..3000).all(|t| inj.mcu_running(ms(t))),
            "no MCU halt asked"
        );
    }

    #[test]
    fn the_mcu_is_stopped_for_its_window() {
        let ms = Duration::from_millis;
        let inj = Injector::new(Faults {
            mcu_halt: Some((ms(500), ms(300))),
            ..Faults::default()
        });
        assert!(inj.mcu_running(ms(499)));
        assert!(!inj.mcu_running(ms(500)));
        assert!(!inj.mcu_running(ms(799)));
        assert!(inj.mcu_running(ms(800)));
        assert!(inj.cable_plugged(ms(600), true), "the cable stays in");
    }
}
