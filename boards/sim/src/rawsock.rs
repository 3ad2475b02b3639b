//! Attaches a simulated segment to a network interface with a raw socket (AF_PACKET, EtherType
//! 0x88A4), so that any external master — TwinCAT, SOEM, IgH, ethercrab — can drive it.
//!
//! Simulated time follows the host's monotonic clock here, so SYNC0 and watchdogs run in real
//! time. Replies go out on the same interface; on a veth pair the master sits on the peer end.

use std::io;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use crate::segment::Segment;

/// EtherCAT EtherType.
const ETHERTYPE_ETHERCAT: u16 = 0x88A4;
/// Largest frame we receive (standard Ethernet MTU plus header).
const MAX_FRAME: usize = 1518;
/// Longest wait for a frame when no simulated event is due (keeps the stop flag responsive).
const IDLE_WAIT: Duration = Duration::from_millis(10);

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

/// Fault injection for tests of the master/slave recovery paths.
#[derive(Clone, Copy, Debug, Default)]
pub struct Faults {
    /// Drop the reply to the frame that carries the K-th successful read (1-based) of drive
    /// 0's slave → master mailbox: the ESC has handed the response over, the master never sees
    /// it, and must recover with a mailbox repeat request (ETG.1000.4 §5.6).
    pub drop_mailbox_read: Option<u32>,
}

/// FPRD command code (ETG.1000.4 Table 20).
const CMD_FPRD: u8 = 4;

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
    while !STOP.load(Ordering::SeqCst) && duration.is_none_or(|d| start.elapsed() < d) {
        let now = start.elapsed().as_nanos() as u64;
        segment.advance_to(now);
        let next = segment
            .drives()
            .iter()
            .filter_map(|d| d.next_event_ns())
            .min();
        let wait = next.map_or(IDLE_WAIT, |t| {
            Duration::from_nanos(t.saturating_sub(now)).min(IDLE_WAIT)
        });
        if let Some(n) = sock.recv(&mut buf, wait)? {
            let frame = buf.get(..n).unwrap_or(&[]);
            // Frames we sent ourselves carry the locally-administered bit: never answer those.
            if frame.get(6).is_some_and(|b| b & 0x02 != 0) {
                continue;
            }
            segment.advance_to(start.elapsed().as_nanos() as u64);
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
    println!("sim-drive: stopped after {frames} frames");
    Ok(frames)
}
