//! The ESC-event context (P2): one round of the slave's mailbox and AL-control service, run
//! beside the cycle context without holding it up.
//!
//! The slave is split (`ethercat_slave::slave`): the cycle context owns the core and the ESC
//! ([`CycleSide`], behind the board's drive lock); the ESC-event context owns the mailbox side
//! with its copy of the OD RAM and the parameter store ([`EventSide`]). A round
//! ([`EventSide::esc_event_round`]) takes the drive lock only for the core's short steps and,
//! through [`DrivePdi`], for one PDI transfer of at most [`PDI_CHUNK`] bytes at a time, so SYNC0
//! waits for at most one such step, never for a whole mailbox transfer or an SDO service.

use core::marker::PhantomData;
use core::ops::Range;

use firmware::od::{NoDomains, WithDomains};
use firmware::params::ParamStore;
use firmware::slave::MailboxSide;
use hal::esc::AlEvent;
use hal::pdi::{EscPdi, PdiError, PdiErrorKind};
use hal::storage::NvStorage;

use crate::cycle::CycleSide;
use crate::regs::OutputPins;

/// Longest single PDI transfer the ESC-event context makes under the drive lock, bytes: on the
/// ET1100 at 21.25 MHz (3 + 32) bytes × 376 ns ≈ 13 µs, against ≈ 49 µs for a 128-byte mailbox.
pub const PDI_CHUNK: usize = 32;

/// The cycle side as the ESC-event context reaches it: through the board's drive lock.
pub trait SharedDrive<const RAM: usize, P, O> {
    /// Runs `f` on the cycle side with the lock held; `None` if the drive is not available
    /// (not installed yet, or the lock is already held by this context).
    fn with<R>(&mut self, f: impl FnOnce(&mut CycleSide<RAM, P, O>) -> R) -> Option<R>;
}

/// Why a round failed.
#[derive(Debug)]
pub enum EventError<E> {
    /// The ESC access failed.
    Pdi(E),
    /// The drive was not available for a transfer at `addr`.
    Unavailable {
        /// The ESC address of the transfer.
        addr: u16,
    },
    /// A transfer of `len` bytes at `addr` runs past the ESC's address space.
    OutOfRange {
        /// Its ESC address.
        addr: u16,
        /// Its length.
        len: usize,
    },
}

impl<E: PdiError> PdiError for EventError<E> {
    fn kind(&self) -> PdiErrorKind {
        match self {
            Self::Pdi(e) => e.kind(),
            Self::Unavailable { .. } => PdiErrorKind::Other,
            Self::OutOfRange { .. } => PdiErrorKind::OutOfRange,
        }
    }
}

/// The ESC as the ESC-event context reaches it outside the drive lock: every access takes the
/// lock for one transfer of at most [`PDI_CHUNK`] bytes (the ESC treats a mailbox buffer as
/// read or written when its last byte is, whatever the transfers).
pub struct DrivePdi<'a, D, const RAM: usize, P, O> {
    drive: &'a mut D,
    _cycle_side: PhantomData<fn() -> (P, O)>,
}

impl<'a, D, const RAM: usize, P, O> DrivePdi<'a, D, RAM, P, O>
where
    D: SharedDrive<RAM, P, O>,
    P: EscPdi,
{
    /// The ESC behind `drive`.
    pub fn new(drive: &'a mut D) -> Self {
        Self {
            drive,
            _cycle_side: PhantomData,
        }
    }

    /// `access` for every chunk of the `len` bytes at `addr`, each under the lock.
    fn chunked(
        &mut self,
        addr: u16,
        len: usize,
        mut access: impl FnMut(&mut P, u16, Range<usize>) -> Result<AlEvent, EventError<P::Error>>,
    ) -> Result<AlEvent, EventError<P::Error>> {
        let mut start: usize = 0;
        loop {
            let end = len.min(start.saturating_add(PDI_CHUNK));
            let at = u16::try_from(start)
                .ok()
                .and_then(|o| addr.checked_add(o))
                .ok_or(EventError::OutOfRange { addr, len })?;
            let events = self
                .drive
                .with(|d| access(&mut d.pdi, at, start..end))
                .ok_or(EventError::Unavailable { addr })??;
            if end >= len {
                return Ok(events);
            }
            start = end;
        }
    }
}

impl<D, const RAM: usize, P, O> EscPdi for DrivePdi<'_, D, RAM, P, O>
where
    D: SharedDrive<RAM, P, O>,
    P: EscPdi,
{
    type Error = EventError<P::Error>;

    fn read(&mut self, addr: u16, buf: &mut [u8]) -> Result<AlEvent, Self::Error> {
        let len = buf.len();
        self.chunked(addr, len, |pdi, at, range| match buf.get_mut(range) {
            Some(part) => pdi.read(at, part).map_err(EventError::Pdi),
            None => Err(EventError::OutOfRange { addr, len }),
        })
    }

    fn write(&mut self, addr: u16, data: &[u8]) -> Result<AlEvent, Self::Error> {
        let len = data.len();
        self.chunked(addr, len, |pdi, at, range| match data.get(range) {
            Some(part) => pdi.write(at, part).map_err(EventError::Pdi),
            None => Err(EventError::OutOfRange { addr, len }),
        })
    }
}

/// What only the ESC-event context uses: the slave's mailbox side with its own copy of the OD
/// RAM, and the parameter store its SDO services write (1010h/1011h).
pub struct EventSide<const RAM: usize, S, const CAP: usize> {
    /// Mailbox, CoE server, OD RAM copy.
    pub mailbox: MailboxSide<RAM>,
    /// The parameter store.
    pub params: ParamStore<S, CAP>,
}

impl<const RAM: usize, S: NvStorage, const CAP: usize> EventSide<RAM, S, CAP> {
    /// One ESC-event round at `now_ns`: the core's event steps (AL control, SM checks) and the
    /// mailbox (its emergencies, the transfers, the OD RAM copied for a request to answer,
    /// the answer, its writes stored back) with the drive lock taken per step, then
    /// the digital outputs (a transition out of OP applies the brake at once). `None` if the
    /// drive was not available.
    pub fn esc_event_round<P: EscPdi, O: OutputPins, D: SharedDrive<RAM, P, O>>(
        &mut self,
        drive: &mut D,
        now_ns: u64,
    ) -> Option<Result<(), EventError<P::Error>>> {
        let job = match drive.with(|d| d.core.event_begin(&mut d.pdi, now_ns))? {
            Ok(job) => job,
            Err(e) => return Some(Err(EventError::Pdi(e))),
        };
        drive.with(|d| self.mailbox.load(&mut d.core))?;
        // The OD RAM is copied (under the lock) only for a request to answer, and only the
        // part its answer reads or writes.
        let received = self
            .mailbox
            .receive(&mut DrivePdi::<D, RAM, P, O>::new(drive), job);
        let served = match received {
            Ok(request) => {
                let loaded = match request {
                    Some(r) => Some(
                        drive
                            .with(|d| self.mailbox.load_dictionary(&mut d.core, r, &self.params))?,
                    ),
                    None => None,
                };
                self.mailbox.answer(
                    &mut DrivePdi::<D, RAM, P, O>::new(drive),
                    job,
                    loaded,
                    &mut WithDomains {
                        hook: &mut self.params,
                        domains: &mut NoDomains,
                    },
                )
            }
            Err(e) => Err(e),
        };
        drive.with(|d| self.mailbox.store(&mut d.core))?;
        if let Err(e) = served {
            return Some(Err(e));
        }
        drive.with(|d| {
            let ended = d.core.event_end(&mut d.pdi, job, now_ns);
            d.drive_outputs();
            ended.map_err(EventError::Pdi)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::inputs::BrakeOutput;
    use firmware::profiles::standard::{PROFILE, RAM_SIZE};
    use std::vec::Vec;

    /// An ESC image that records the length of every transfer.
    struct Image {
        mem: Vec<u8>,
        transfers: Vec<usize>,
    }

    #[derive(Debug)]
    struct OutOfImage;

    impl PdiError for OutOfImage {
        fn kind(&self) -> PdiErrorKind {
            PdiErrorKind::OutOfRange
        }
    }

    impl EscPdi for Image {
        type Error = OutOfImage;
        fn read(&mut self, addr: u16, buf: &mut [u8]) -> Result<AlEvent, OutOfImage> {
            let at = usize::from(addr);
            buf.copy_from_slice(self.mem.get(at..at + buf.len()).ok_or(OutOfImage)?);
            self.transfers.push(buf.len());
            Ok(AlEvent(0))
        }
        fn write(&mut self, addr: u16, data: &[u8]) -> Result<AlEvent, OutOfImage> {
            let at = usize::from(addr);
            self.mem
                .get_mut(at..at + data.len())
                .ok_or(OutOfImage)?
                .copy_from_slice(data);
            self.transfers.push(data.len());
            Ok(AlEvent(0))
        }
    }

    struct NoPins;

    impl OutputPins for NoPins {
        fn set_brake_released(&mut self, _: bool) {}
    }

    /// The drive lock: counts its acquisitions; `available` false = not installed.
    struct Lock {
        side: CycleSide<RAM_SIZE, Image, NoPins>,
        taken: usize,
        available: bool,
    }

    impl SharedDrive<RAM_SIZE, Image, NoPins> for Lock {
        fn with<R>(
            &mut self,
            f: impl FnOnce(&mut CycleSide<RAM_SIZE, Image, NoPins>) -> R,
        ) -> Option<R> {
            self.taken += 1;
            self.available.then(|| f(&mut self.side))
        }
    }

    fn lock() -> Lock {
        let (core, _) = firmware::new_slave_parts::<RAM_SIZE>(&PROFILE).unwrap();
        Lock {
            side: CycleSide {
                core,
                pdi: Image {
                    mem: (0..0x1_0000).map(|i| i as u8).collect(),
                    transfers: Vec::new(),
                },
                brake: BrakeOutput::new(NoPins),
                sync_lock: None,
            },
            taken: 0,
            available: true,
        }
    }

    #[test]
    fn a_mailbox_transfer_takes_the_lock_once_per_32_bytes() {
        let mut drive = lock();
        let mut buf = [0u8; 100];
        DrivePdi::<_, RAM_SIZE, _, _>::new(&mut drive)
            .read(0x1000, &mut buf)
            .unwrap();
        assert_eq!(drive.side.pdi.transfers, [32, 32, 32, 4]);
        assert_eq!(drive.taken, 4);
        assert!(buf
            .iter()
            .enumerate()
            .all(|(i, &b)| b == (0x1000 + i) as u8));
        drive.side.pdi.transfers.clear();
        DrivePdi::<_, RAM_SIZE, _, _>::new(&mut drive)
            .write(0x1800, &[7; 64])
            .unwrap();
        assert_eq!(drive.side.pdi.transfers, [32, 32]);
        assert_eq!(drive.side.pdi.mem[0x1800..0x1840], [7; 64]);
    }

    #[test]
    fn transfers_fail_cleanly() {
        let mut drive = lock();
        // Past the 16-bit address space: the second chunk would start at 0x10000.
        let e = DrivePdi::<_, RAM_SIZE, _, _>::new(&mut drive).read(0xFFE0, &mut [0; 64]);
        assert!(matches!(
            e,
            Err(EventError::OutOfRange {
                addr: 0xFFE0,
                len: 64
            })
        ));
        // Past the image: the PDI's own error.
        let e = DrivePdi::<_, RAM_SIZE, _, _>::new(&mut drive).read(0xFFF0, &mut [0; 32]);
        assert!(matches!(e, Err(EventError::Pdi(OutOfImage))));
        assert_eq!(e.unwrap_err().kind(), PdiErrorKind::OutOfRange);
        // No drive: unavailable, and a round does nothing.
        drive.available = false;
        let e = DrivePdi::<_, RAM_SIZE, _, _>::new(&mut drive).write(0x1000, &[0; 4]);
        assert!(matches!(e, Err(EventError::Unavailable { addr: 0x1000 })));
        let (_, mailbox) = firmware::new_slave_parts::<RAM_SIZE>(&PROFILE).unwrap();
        let mut event = EventSide::<RAM_SIZE, _, 64> {
            mailbox,
            params: ParamStore::new(firmware::params::NoStorage),
        };
        assert!(event.esc_event_round(&mut drive, 0).is_none());
    }
}
