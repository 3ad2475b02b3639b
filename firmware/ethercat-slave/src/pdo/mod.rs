//! PDO mapping: from 1C12h/1C13h and the 16xxh/1Axxh mapping objects to a precomputed copy
//! plan between the process-data image (SM2/SM3 buffers) and the OD RAM.
//!
//! The plan is built once at PREOP → SAFEOP; the cycle then runs [`PdoPlan::unpack`] and
//! [`PdoPlan::pack`], which do no lookups: one copy per run of byte-aligned entries (adjacent
//! entries merged into one run), by the copy width decided for the run when the plan is built,
//! and a bit copy only for entries that are not byte-aligned. An RxPDO plan may watch
//! OD RAM bytes for the application ([`PdoPlan::build_watching`]): their entries are copied
//! apart and compared, and [`PdoPlan::unpack_watching`] tells when one changed. [`rules`] holds
//! what an SDO write to the PDO objects must satisfy; both read the object indices defined
//! there.

use hal::esc::AlStatusCode;
use heapless::Vec;

use crate::od::{Dictionary, Value};

pub mod rules;

pub use rules::{RX_ASSIGN, RX_MAPPING, TX_ASSIGN, TX_MAPPING};

/// Most mapped entries per direction (all PDOs of one SM together;
/// [`hal::esc::MAX_FIRMWARE_MAPPED_ENTRIES`], the one definition od-gen checks profiles with).
pub const MAX_MAPPED_ENTRIES: usize = hal::esc::MAX_FIRMWARE_MAPPED_ENTRIES as usize;
/// Largest process-data image per direction in bytes
/// ([`hal::esc::MAX_FIRMWARE_PROCESS_IMAGE`], the one definition od-gen checks profiles with).
pub const MAX_IMAGE: usize = hal::esc::MAX_FIRMWARE_PROCESS_IMAGE as usize;

/// The OD RAM byte ranges a plan copies to (RxPDO) or from (TxPDO): (offset, length) of each
/// byte run and bit-copied entry. At most one per mapped entry.
pub type RamRanges = Vec<(u16, u16), MAX_MAPPED_ENTRIES>;

/// Whether any of `ranges` shares a byte with the `len` OD RAM bytes from offset `at`.
pub fn overlaps(ranges: &[(u16, u16)], at: u16, len: u16) -> bool {
    any_overlaps(ranges.iter().copied(), at, len)
}

/// Whether any (offset, length) span shares a byte with the `len` bytes from `at`.
fn any_overlaps(spans: impl IntoIterator<Item = (u16, u16)>, at: u16, len: u16) -> bool {
    if len == 0 {
        return false;
    }
    // u16 + u16 in u32: never saturates.
    let (at, end) = (u32::from(at), u32::from(at).saturating_add(u32::from(len)));
    spans
        .into_iter()
        .any(|(from, n)| u32::from(from) < end && at < u32::from(from).saturating_add(u32::from(n)))
}

/// Highest index of a dummy (padding) data-type object usable in a mapping (CiA 301 §7.4.7.1).
const DUMMY_INDEX_MAX: u16 = 0x0007;

/// Direction of a plan.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Direction {
    /// RxPDO: master → slave (outputs, SM2).
    Rx,
    /// TxPDO: slave → master (inputs, SM3).
    Tx,
}

impl Direction {
    fn assign_index(self) -> u16 {
        match self {
            Self::Rx => RX_ASSIGN,
            Self::Tx => TX_ASSIGN,
        }
    }
    fn mapping_range(self) -> core::ops::RangeInclusive<u16> {
        match self {
            Self::Rx => RX_MAPPING,
            Self::Tx => TX_MAPPING,
        }
    }
    /// AL status code for a mapping that cannot be built (ETG.1000.6 Table 11).
    fn invalid_mapping(self) -> AlStatusCode {
        match self {
            Self::Rx => AlStatusCode::InvalidOutputMapping,
            Self::Tx => AlStatusCode::InvalidInputMapping,
        }
    }
}

/// Where a mapped value comes from or goes to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Slot {
    /// OD RAM byte offset.
    Ram(u16),
    /// A constant (TxPDO only).
    Const(&'static [u8]),
}

/// One mapped entry.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct CopyStep {
    slot: Slot,
    /// Bit offset in the process-data image.
    image_bit: u16,
    /// Size in bits.
    bits: u16,
}

impl CopyStep {
    /// The image byte offset and byte length of an entry on byte boundaries in the image (the
    /// OD RAM always holds a value from a byte boundary), `None` for a bit-packed one.
    fn bytes(&self) -> Option<(usize, usize)> {
        (self.image_bit % 8 == 0 && self.bits % 8 == 0)
            .then(|| (usize::from(self.image_bit / 8), usize::from(self.bits / 8)))
    }
}

/// Mapped entries that are whole bytes on both sides, contiguous in the image and in the OD RAM
/// (one entry, or adjacent entries merged when the plan is built): one copy.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct ByteRun {
    /// OD RAM byte offset.
    ram: u16,
    /// Image byte offset.
    image: u16,
    /// Bytes.
    len: u16,
    /// How the run is copied: [`Width::of`] `len`.
    width: Width,
}

/// How a [`ByteRun`] is copied, decided when the plan is built so that a cycle's copy of the
/// run is one jump on it: the object sizes with the bounds checks of a constant length, two
/// overlapping words for the runs of merged entries the default mappings make, the others by
/// [`copy_bytes`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Width {
    /// 1 byte.
    Byte,
    /// 2 bytes.
    Half,
    /// 4 bytes.
    Word,
    /// 5 to 8 bytes: [`copy_pair`] of words.
    Words,
    /// Any other length.
    Other,
}

impl Width {
    /// The copy of `len` bytes.
    fn of(len: u16) -> Self {
        match len {
            1 => Self::Byte,
            2 => Self::Half,
            4 => Self::Word,
            5..=8 => Self::Words,
            _ => Self::Other,
        }
    }
}

/// The copy plan of one direction: the byte runs, then the entries that need a bit copy or
/// come from a constant.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct PdoPlan {
    /// In mapping order, the watched ones last.
    runs: Vec<ByteRun, MAX_MAPPED_ENTRIES>,
    steps: Vec<CopyStep, MAX_MAPPED_ENTRIES>,
    /// How many runs at the end of `runs` write watched bytes ([`PdoPlan::build_watching`]):
    /// after the others.
    watched_runs: u8,
    /// How many steps at the end of `steps` write watched bytes (entries off the byte
    /// boundaries of the image: a bit copy).
    watched_steps: u8,
    /// Whether a run or a step is watched.
    watches: bool,
    /// Mapped entries (padding excluded).
    entries: usize,
    bits: u16,
}

impl PdoPlan {
    /// Builds the plan of `dir` from the assignment and mapping objects in `od`. An assigned
    /// PDO that does not exist, a mapped entry that does not exist, is not mappable in this
    /// direction or has another bit length, or a plan beyond the buffer limits or the
    /// profile's `max_process_bytes` gives 0x0025 (outputs) / 0x0024 (inputs).
    pub fn build(od: &Dictionary<'_>, dir: Direction) -> Result<Self, AlStatusCode> {
        Self::build_watching(od, dir, &|_, _| false)
    }

    /// [`Self::build`], with the OD RAM bytes `watched(offset, length)` names watched: the
    /// entries that write any of them are copied apart (merged only with each other, after
    /// the others) and compared as they are copied, so that [`Self::unpack_watching`] tells
    /// when one of them changed (an application that keeps settings converted from the OD RAM
    /// reads them again only then).
    pub fn build_watching(
        od: &Dictionary<'_>,
        dir: Direction,
        // A trait object: one copy of the builder's code for every caller.
        watched: &dyn Fn(u16, u16) -> bool,
    ) -> Result<Self, AlStatusCode> {
        let bad = dir.invalid_mapping();
        let mut plan = Self::default();
        // Whether each run and each step is watched (a run holds entries of one kind).
        let mut kinds = Kinds::default();
        let assign = dir.assign_index();
        let pdo_count = od.read_u32(assign, 0).ok_or(bad)?;
        for n in 1..=pdo_count {
            let sub = u8::try_from(n).map_err(|_| bad)?;
            let pdo = od.read_u32(assign, sub).ok_or(bad)? as u16;
            if !dir.mapping_range().contains(&pdo) {
                return Err(bad);
            }
            plan.add_pdo(od, dir, pdo, (watched, &mut kinds))?;
        }
        // The profile's limit on the image of one direction (e.g. 32 bytes on the SDV3-E).
        let max_bytes = usize::from(od.profile().device.max_process_bytes).min(MAX_IMAGE);
        if plan.byte_len() > max_bytes {
            return Err(bad);
        }
        // The two kinds never share OD RAM bytes (the same bytes are watched or not): their
        // order does not change what an unpack leaves.
        plan.watched_runs = watched_last(&mut plan.runs, &kinds.runs);
        plan.watched_steps = watched_last(&mut plan.steps, &kinds.steps);
        plan.watches = plan.watched_runs > 0 || plan.watched_steps > 0;
        Ok(plan)
    }

    fn add_pdo(
        &mut self,
        od: &Dictionary<'_>,
        dir: Direction,
        pdo: u16,
        (watched, kinds): (&dyn Fn(u16, u16) -> bool, &mut Kinds),
    ) -> Result<(), AlStatusCode> {
        let bad = dir.invalid_mapping();
        let entries = od.read_u32(pdo, 0).ok_or(bad)?;
        for n in 1..=entries {
            let sub = u8::try_from(n).map_err(|_| bad)?;
            let mapping = od.read_u32(pdo, sub).ok_or(bad)?;
            let index = (mapping >> 16) as u16;
            let subindex = (mapping >> 8) as u8;
            let bits = (mapping & 0xFF) as u16;
            if bits == 0 {
                return Err(bad);
            }
            if index <= DUMMY_INDEX_MAX {
                // Padding: occupies image bits, copies nothing.
                self.bits = self.bits.checked_add(bits).ok_or(bad)?;
                continue;
            }
            let entry = od.entry(index, subindex).ok_or(bad)?;
            let mappable = match dir {
                Direction::Rx => entry.pdo.rx(),
                Direction::Tx => entry.pdo.tx(),
            };
            if !mappable || entry.bit_len != bits {
                return Err(bad);
            }
            let slot = match (entry.value, dir) {
                (Value::Ram(offset), _) => Slot::Ram(offset),
                (Value::Const(bytes), Direction::Tx) => Slot::Const(bytes),
                (Value::Const(_), Direction::Rx) | (Value::Domain(_), _) => return Err(bad),
            };
            self.entries = self
                .entries
                .checked_add(1)
                .filter(|&n| n <= MAX_MAPPED_ENTRIES)
                .ok_or(bad)?;
            let step = CopyStep {
                slot,
                image_bit: self.bits,
                bits,
            };
            // At most 255 bits: the bytes fit a u16.
            let watch = match slot {
                Slot::Ram(ram) => watched(ram, bits.div_ceil(8)),
                _ => false,
            };
            match (slot, step.bytes()) {
                (Slot::Ram(ram), Some((image, len))) => {
                    let image = u16::try_from(image).map_err(|_| bad)?;
                    let len = u16::try_from(len).map_err(|_| bad)?;
                    self.add_run(ram, image, len, (watch, &mut kinds.runs))
                        .map_err(|_| bad)?;
                }
                _ => {
                    self.steps.push(step).map_err(|_| bad)?;
                    kinds.steps.push(watch).map_err(|_| bad)?;
                }
            }
            self.bits = self.bits.checked_add(bits).ok_or(bad)?;
        }
        if self.byte_len() > MAX_IMAGE {
            return Err(bad);
        }
        Ok(())
    }

    /// Adds a byte-aligned entry of `len` bytes from OD RAM offset `ram` at image byte `image`,
    /// `watched` or not (`kinds`: the flag of each run): to the last run if it continues it on
    /// both sides and is of its kind, else as a new run (`Err` when the runs are full, which
    /// the entry count prevents).
    fn add_run(
        &mut self,
        ram: u16,
        image: u16,
        len: u16,
        (watched, kinds): (bool, &mut Vec<bool, MAX_MAPPED_ENTRIES>),
    ) -> Result<(), ByteRun> {
        if let (Some(last), Some(&last_watched)) = (self.runs.last_mut(), kinds.last()) {
            let continues = last.ram.checked_add(last.len) == Some(ram)
                && last.image.checked_add(last.len) == Some(image)
                && last_watched == watched;
            if let (true, Some(merged)) = (continues, last.len.checked_add(len)) {
                last.len = merged;
                last.width = Width::of(merged);
                return Ok(());
            }
        }
        let run = ByteRun::new(ram, image, len);
        kinds.push(watched).map_err(|_| run)?;
        self.runs.push(run)
    }

    /// Whether the plan copies into (or out of) any of the `len` OD RAM bytes from offset `at`.
    pub fn writes_ram(&self, at: u16, len: u16) -> bool {
        any_overlaps(self.ram_spans(), at, len)
    }

    /// The OD RAM (offset, length) of each byte run and bit-copied entry.
    fn ram_spans(&self) -> impl Iterator<Item = (u16, u16)> + '_ {
        let runs = self.runs.iter().map(|r| (r.ram, r.len));
        let steps = self.steps.iter().filter_map(|s| match s.slot {
            Slot::Ram(ram) => Some((ram, s.bits.div_ceil(8))),
            Slot::Const(_) => None,
        });
        runs.chain(steps)
    }

    /// Mapped entries (padding excluded).
    pub fn entries(&self) -> usize {
        self.entries
    }

    /// Copies the plan makes per cycle: the byte runs (adjacent entries merged) and the other
    /// entries.
    pub fn copies(&self) -> usize {
        // Two lists of at most MAX_MAPPED_ENTRIES: never saturates.
        self.runs.len().saturating_add(self.steps.len())
    }

    /// The OD RAM bytes this plan copies to or from ([`RamRanges`]).
    pub fn ram_ranges(&self) -> RamRanges {
        // Runs and steps together hold at most one item per mapped entry: they fit.
        self.ram_spans().take(MAX_MAPPED_ENTRIES).collect()
    }

    /// Size of the process-data image in bytes (the SM length the master must configure).
    pub fn byte_len(&self) -> usize {
        (self.bits as usize).div_ceil(8)
    }

    /// Copies `runs` from `from` to `to`: image to OD RAM when `UNPACK`, else OD RAM to
    /// image, each by its width ([`copy_run`]). When `TRACK`, returns whether a run changed
    /// `to` (else `false`).
    #[inline(always)]
    fn copy_runs<const UNPACK: bool, const TRACK: bool>(
        runs: &[ByteRun],
        from: &[u8],
        to: &mut [u8],
    ) -> bool {
        let mut changed = false;
        for run in runs {
            changed |= copy_run::<UNPACK, TRACK>(run, from, to);
        }
        changed
    }

    /// Copies an RxPDO image (SM2 content) into the OD RAM (the watched entries too, not
    /// compared: [`Self::unpack_watching`] tells their changes).
    pub fn unpack(&self, image: &[u8], ram: &mut [u8]) {
        self.unpack_tracked::<false>(image, ram);
    }

    /// Whether the plan has watched entries ([`Self::build_watching`]).
    pub fn watches(&self) -> bool {
        self.watches
    }

    /// [`Self::unpack`], and whether it changed a watched entry ([`Self::build_watching`]).
    /// Costs a comparison per watched entry: for a plan that [`watches`](Self::watches).
    pub fn unpack_watching(&self, image: &[u8], ram: &mut [u8]) -> bool {
        self.unpack_tracked::<true>(image, ram)
    }

    /// The unpack; when `TRACK`, compares the watched entries as they are copied and returns
    /// whether one changed (else `false`).
    #[inline(always)]
    fn unpack_tracked<const TRACK: bool>(&self, image: &[u8], ram: &mut [u8]) -> bool {
        let (plain, watched) = if TRACK {
            split_watched(&self.runs, self.watched_runs)
        } else {
            (self.runs.as_slice(), &[][..])
        };
        Self::copy_runs::<true, false>(plain, image, ram);
        let mut changed = Self::copy_runs::<true, true>(watched, image, ram);
        let (plain, watched) = if TRACK {
            split_watched(&self.steps, self.watched_steps)
        } else {
            (self.steps.as_slice(), &[][..])
        };
        for step in plain {
            // An OD RAM value starts on a byte boundary: bit 0 of the RAM from its offset.
            if let Slot::Ram(offset) = step.slot {
                if let Some(to) = ram.get_mut(usize::from(offset)..) {
                    let (from, bits) = (usize::from(step.image_bit), usize::from(step.bits));
                    copy_bits(image, from, to, 0, bits);
                }
            }
        }
        for step in watched {
            if let Slot::Ram(offset) = step.slot {
                if let Some(to) = ram.get_mut(usize::from(offset)..) {
                    let (from, bits) = (usize::from(step.image_bit), usize::from(step.bits));
                    changed |= copy_bits_tracked::<true>(image, from, to, 0, bits);
                }
            }
        }
        changed
    }

    /// Copies the mapped TxPDO values from the OD RAM into an image (SM3 content).
    pub fn pack(&self, ram: &[u8], image: &mut [u8]) {
        Self::copy_runs::<false, false>(&self.runs, ram, image);
        for step in &self.steps {
            // An OD RAM value starts on a byte boundary: bit 0 of the RAM from its offset.
            let src = match step.slot {
                Slot::Ram(offset) => ram.get(usize::from(offset)..),
                Slot::Const(bytes) => Some(bytes),
            };
            if let Some(src) = src {
                copy_bits(
                    src,
                    0,
                    image,
                    usize::from(step.image_bit),
                    usize::from(step.bits),
                );
            }
        }
    }
}

impl ByteRun {
    /// The run of `len` bytes from OD RAM offset `ram` at image byte `image`.
    fn new(ram: u16, image: u16, len: u16) -> Self {
        Self {
            ram,
            image,
            len,
            width: Width::of(len),
        }
    }

    /// Image offset, RAM offset, length.
    #[inline(always)]
    fn span(&self) -> (usize, usize, usize) {
        (
            usize::from(self.image),
            usize::from(self.ram),
            usize::from(self.len),
        )
    }
}

/// Whether each run and each step of a plan being built is watched
/// ([`PdoPlan::build_watching`]).
#[derive(Default)]
struct Kinds {
    runs: Vec<bool, MAX_MAPPED_ENTRIES>,
    steps: Vec<bool, MAX_MAPPED_ENTRIES>,
}

/// Moves the `items` that `watched` marks (one flag per item) after the others, each kind in
/// mapping order; returns how many are watched.
fn watched_last<T: Copy>(items: &mut Vec<T, MAX_MAPPED_ENTRIES>, watched: &[bool]) -> u8 {
    let mut ordered: Vec<T, MAX_MAPPED_ENTRIES> = Vec::new();
    let mut count = 0u8;
    for last in [false, true] {
        for (item, _) in items.iter().zip(watched).filter(|(_, &w)| w == last) {
            // As many items as before: the pushes fit.
            let _ = ordered.push(*item);
            // At most MAX_MAPPED_ENTRIES (< 256) items.
            count = count.saturating_add(u8::from(last));
        }
    }
    *items = ordered;
    count
}

/// `items` whose last `watched` are watched: (the others, the watched).
fn split_watched<T>(items: &[T], watched: u8) -> (&[T], &[T]) {
    let plain = items.len().saturating_sub(usize::from(watched));
    items.split_at_checked(plain).unwrap_or((items, &[]))
}

/// Copies `run` from `from` to `to` (image to OD RAM when `UNPACK`, else OD RAM to image) by
/// its [`Width`], nothing where it is out of range. When `TRACK`, returns whether `to` held
/// other bytes (else `false`).
#[inline(always)]
fn copy_run<const UNPACK: bool, const TRACK: bool>(
    run: &ByteRun,
    from: &[u8],
    to: &mut [u8],
) -> bool {
    let (image, ram, n) = run.span();
    let (f, t) = if UNPACK { (image, ram) } else { (ram, image) };
    match run.width {
        Width::Word => copy_fixed::<4, TRACK>(from, f, to, t),
        Width::Half => copy_fixed::<2, TRACK>(from, f, to, t),
        Width::Byte => copy_fixed::<1, TRACK>(from, f, to, t),
        Width::Words => match spans(from, f, to, t, n) {
            Some((src, dst)) if TRACK => copy_changed(src, dst),
            Some((src, dst)) => {
                copy_pair::<4>(src, dst);
                false
            }
            None => false,
        },
        Width::Other => match spans(from, f, to, t, n) {
            Some((src, dst)) if TRACK => copy_changed(src, dst),
            Some((src, dst)) => {
                copy_bytes(src, dst);
                false
            }
            None => false,
        },
    }
}

/// Copies the `N` bytes of `from` at `f` to `to` at `t` (nothing if either is out of range).
/// When `TRACK`, returns whether `to` held other bytes (else `false`).
#[inline(always)]
fn copy_fixed<const N: usize, const TRACK: bool>(
    from: &[u8],
    f: usize,
    to: &mut [u8],
    t: usize,
) -> bool {
    // The ends as ranges, not the first chunk from the offset: their checks need no
    // length − N kept across a loop (fewer registers). Offsets from u16: no overflow.
    let src = from
        .get(f..f.wrapping_add(N))
        .and_then(|s| s.first_chunk::<N>());
    let dst = to
        .get_mut(t..t.wrapping_add(N))
        .and_then(|d| d.first_chunk_mut::<N>());
    let (Some(src), Some(dst)) = (src, dst) else {
        return false;
    };
    let changed = TRACK && src != dst;
    *dst = *src;
    changed
}

/// The `n` bytes of `from` at `f` and of `to` at `t` (`None` if either is out of range).
#[inline(always)]
fn spans<'a, 'b>(
    from: &'a [u8],
    f: usize,
    to: &'b mut [u8],
    t: usize,
    n: usize,
) -> Option<(&'a [u8], &'b mut [u8])> {
    Some((span(from, f, n)?, span_mut(to, t, n)?))
}

/// Copies `from` into `to` (equal lengths, `N` to 2·`N` bytes) as two `N`-byte parts, the
/// first and the last, which overlap as far as the length falls short of 2·`N` (nothing
/// where the length is shorter than `N`).
#[inline(always)]
fn copy_pair<const N: usize>(from: &[u8], to: &mut [u8]) {
    copy_part::<N>(from, to, 0);
    copy_part::<N>(from, to, from.len().wrapping_sub(N));
}

/// Copies the `N` bytes at `at` of `from` into `to` (equal lengths; nothing if out of range).
#[inline(always)]
fn copy_part<const N: usize>(from: &[u8], to: &mut [u8], at: usize) {
    _ = copy_fixed::<N, false>(from, at, to, at);
}

/// The `n` bytes of `buf` from `at` (`None` if they are not all in it).
#[inline(always)]
fn span(buf: &[u8], at: usize, n: usize) -> Option<&[u8]> {
    buf.get(at..).and_then(|b| b.get(..n))
}

/// [`span`], mutable.
#[inline(always)]
fn span_mut(buf: &mut [u8], at: usize, n: usize) -> Option<&mut [u8]> {
    buf.get_mut(at..).and_then(|b| b.get_mut(..n))
}

/// Copies `from` into `to` (equal lengths), of any length (a run of [`Width::Other`], a
/// byte-aligned bit copy). By whole words, not through the library `memcpy` call a slice copy
/// of unknown length becomes (its call and size dispatch cost more than the copy of a few
/// bytes): 4 to 8 bytes as two words that overlap where the length is below 8 (the first and
/// the last four bytes), 2 or 3 bytes as two half-words likewise, 9 to 16 bytes as four words
/// likewise, longer runs word by word. Branches on ranges rather than on each size: fewer
/// instructions than the jump table a `match` on the sizes becomes.
#[inline(always)]
fn copy_bytes(from: &[u8], to: &mut [u8]) {
    let n = from.len();
    // n − 4 and n − 2 wrap for the shorter lengths, which then fail the range test.
    let (last4, last2) = (n.wrapping_sub(4), n.wrapping_sub(2));
    if last4 <= 4 {
        copy_pair::<4>(from, to);
    } else if last2 <= 1 {
        copy_pair::<2>(from, to);
    } else if n == 1 {
        copy_part::<1>(from, to, 0);
    } else if n.wrapping_sub(9) <= 7 {
        // 9 to 16 bytes (a run of merged entries): four words, the last two overlapping the
        // first two as far as the length falls short of 16.
        copy_pair::<4>(from, to);
        copy_part::<4>(from, to, 4);
        copy_part::<4>(from, to, n.wrapping_sub(8));
    } else if n > 16 {
        // Longer runs (merged entries of a large mapping): word by word, the last word
        // overlapping the one before it as far as the length is not a multiple of 4. The
        // library `memcpy` would copy an unaligned image byte by byte.
        let mut at = 0;
        while at < last4 {
            copy_part::<4>(from, to, at);
            // at < n − 4: no overflow.
            at = at.wrapping_add(4);
        }
        copy_part::<4>(from, to, last4);
    }
}

/// Copies `from` into `to` (equal lengths) and returns whether `to` held other bytes, byte by
/// byte (the object sizes compare as words in [`copy_fixed`]).
#[inline(always)]
fn copy_changed(from: &[u8], to: &mut [u8]) -> bool {
    let mut changed = false;
    for (d, s) in to.iter_mut().zip(from) {
        changed |= *d != *s;
        *d = *s;
    }
    changed
}

/// Copies `bits` bits, LSB first (EtherCAT bit order), from `src` at bit `src_bit` to `dst` at
/// bit `dst_bit`. Out-of-range parts are skipped, never panicked on.
fn copy_bits(src: &[u8], src_bit: usize, dst: &mut [u8], dst_bit: usize, bits: usize) {
    copy_bits_tracked::<false>(src, src_bit, dst, dst_bit, bits);
}

/// [`copy_bits`]; when `TRACK`, returns whether a copied bit changed in `dst` (else `false`).
fn copy_bits_tracked<const TRACK: bool>(
    src: &[u8],
    src_bit: usize,
    dst: &mut [u8],
    dst_bit: usize,
    bits: usize,
) -> bool {
    if src_bit % 8 == 0 && dst_bit % 8 == 0 && bits % 8 == 0 {
        let (s, d, n) = (src_bit / 8, dst_bit / 8, bits / 8);
        let (Some(from), Some(to)) = (span(src, s, n), span_mut(dst, d, n)) else {
            return false;
        };
        if TRACK {
            return copy_changed(from, to);
        }
        copy_bytes(from, to);
        return false;
    }
    // Bits whose position does not fit a usize lie out of range on either side.
    let (Some(src_end), Some(dst_end)) = (src_bit.checked_add(bits), dst_bit.checked_add(bits))
    else {
        return false;
    };
    let mut changed = false;
    for (sb, db) in (src_bit..src_end).zip(dst_bit..dst_end) {
        let Some(&byte) = src.get(sb / 8) else {
            break;
        };
        let Some(out) = dst.get_mut(db / 8) else {
            break;
        };
        let mask = 1u8 << (db % 8);
        let was = *out;
        if byte & (1 << (sb % 8)) != 0 {
            *out |= mask;
        } else {
            *out &= !mask;
        }
        changed |= TRACK && *out != was;
    }
    changed
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::od::*;

    const fn var(sub: u8, bits: u16, pdo: PdoMappable, value: Value) -> Entry {
        Entry {
            subindex: sub,
            name: "",
            data_type: DataType::Unsigned32,
            bit_len: bits,
            access: Access::RW,
            pdo,
            value,
            default: &[],
            min: &[],
            max: &[],
        }
    }
    // OD RAM layout: 0..2 cw, 2..6 target, 6 flag byte, 8.. 1C12 (sub0 + 2×u16), 14.. 1600 (sub0 + 4×u32)
    static CW: [Entry; 1] = [var(0, 16, PdoMappable::Rx, Value::Ram(0))];
    static TARGET: [Entry; 1] = [var(0, 32, PdoMappable::Rx, Value::Ram(2))];
    static FLAG: [Entry; 1] = [var(0, 1, PdoMappable::Rx, Value::Ram(6))];
    static STATUS: [Entry; 1] = [var(0, 16, PdoMappable::Tx, Value::Const(&[0x37, 0x02]))];
    static RXMAP: [Entry; 5] = [
        var(0, 8, PdoMappable::No, Value::Ram(14)),
        var(1, 32, PdoMappable::No, Value::Ram(15)),
        var(2, 32, PdoMappable::No, Value::Ram(19)),
        var(3, 32, PdoMappable::No, Value::Ram(23)),
        var(4, 32, PdoMappable::No, Value::Ram(27)),
    ];
    static RXASSIGN: [Entry; 3] = [
        var(0, 8, PdoMappable::No, Value::Ram(8)),
        var(1, 16, PdoMappable::No, Value::Ram(9)),
        var(2, 16, PdoMappable::No, Value::Ram(11)),
    ];
    static OBJECTS: [Object; 6] = [
        Object {
            index: 0x1600,
            code: ObjectCode::Record,
            name: "",
            entries: &RXMAP,
        },
        Object {
            index: 0x1C12,
            code: ObjectCode::Array,
            name: "",
            entries: &RXASSIGN,
        },
        Object {
            index: 0x2000,
            code: ObjectCode::Var,
            name: "",
            entries: &FLAG,
        },
        Object {
            index: 0x6040,
            code: ObjectCode::Var,
            name: "",
            entries: &CW,
        },
        Object {
            index: 0x6041,
            code: ObjectCode::Var,
            name: "",
            entries: &STATUS,
        },
        Object {
            index: 0x607A,
            code: ObjectCode::Var,
            name: "",
            entries: &TARGET,
        },
    ];
    static DEFAULTS: [u8; 31] = [0; 31];
    static PROFILE: Profile = Profile {
        device: crate::od::test_device(),
        objects: &OBJECTS,
        defaults: &DEFAULTS,
        value_lists: &[],
        storage: crate::od::StorageRules::NONE,
    };

    fn od_with(ram: &mut [u8; 31], mapping: &[u32]) {
        ram[8] = 1;
        ram[9..11].copy_from_slice(&0x1600u16.to_le_bytes());
        ram[14] = mapping.len() as u8;
        for (i, m) in mapping.iter().enumerate() {
            ram[15 + 4 * i..19 + 4 * i].copy_from_slice(&m.to_le_bytes());
        }
    }

    #[test]
    fn byte_aligned_mapping_unpacks_in_mapping_order() {
        let mut ram = [0u8; 31];
        od_with(&mut ram, &[0x6040_0010, 0x607A_0020]);
        let plan = PdoPlan::build(&Dictionary::new(&PROFILE, &mut ram), Direction::Rx).unwrap();
        assert_eq!(plan.byte_len(), 6);
        plan.unpack(&[0x0F, 0x00, 0x78, 0x56, 0x34, 0x12], &mut ram);
        assert_eq!(&ram[0..2], &[0x0F, 0x00]);
        assert_eq!(&ram[2..6], &[0x78, 0x56, 0x34, 0x12]);
    }

    /// Runs of every copy width (an object size, or entries merged), none adjacent: each is
    /// copied to and from its own place, and nothing else.
    #[test]
    fn runs_of_every_width_copy_each_entry_to_its_place() {
        // (ram, image, len): lengths 1 to 4, 7 (two words), 12 (four words), 21 (long).
        let spans = [
            (40, 0, 2),
            (10, 2, 4),
            (30, 6, 1),
            (0, 7, 3),
            (50, 10, 7),
            (60, 17, 12),
            (80, 29, 21),
        ];
        let widths = [
            Width::Half,
            Width::Word,
            Width::Byte,
            Width::Other,
            Width::Words,
            Width::Other,
            Width::Other,
        ];
        let runs = spans.map(|(ram, image, len)| ByteRun::new(ram, image, len));
        assert_eq!(runs.map(|r| r.width), widths);
        let plan = PdoPlan {
            runs: Vec::from_slice(&runs).unwrap(),
            ..PdoPlan::default()
        };
        let image: [u8; 50] = core::array::from_fn(|i| 0x80 + i as u8);
        let mut ram = [0u8; 104];
        plan.unpack(&image, &mut ram);
        let mut expected = [0u8; 104];
        for (r, i, n) in spans.map(|(r, i, n)| (usize::from(r), usize::from(i), usize::from(n))) {
            expected[r..r + n].copy_from_slice(&image[i..i + n]);
        }
        assert_eq!(ram, expected, "every run at its place, nothing else");
        let mut back = [0u8; 52];
        plan.pack(&ram, &mut back);
        assert_eq!(&back[..50], &image, "packed back where it was mapped");
        assert_eq!(&back[50..], &[0, 0], "nothing after the image");
        // Out of range on either side: nothing copied, no panic.
        let mut short = [0u8; 40];
        plan.unpack(&image, &mut short);
        assert_eq!(short, expected[..40], "the runs that fit");
        let mut small_image = [0u8; 20];
        plan.pack(&ram, &mut small_image);
        assert_eq!(&small_image[..17], &image[..17], "the runs that fit");
        assert_eq!(&small_image[17..], &[0, 0, 0]);
    }

    /// Runs that share OD RAM bytes (an object mapped twice, here a 2-byte run and then a
    /// 4-byte run over the same bytes) are copied in mapping order, so that the later copy
    /// wins as mapped.
    #[test]
    fn runs_sharing_ram_keep_the_mapping_order() {
        let spans = [(0, 0, 2), (0, 2, 4), (10, 6, 1), (20, 7, 1)];
        let plan = PdoPlan {
            runs: Vec::from_slice(&spans.map(|(ram, image, len)| ByteRun::new(ram, image, len)))
                .unwrap(),
            ..PdoPlan::default()
        };
        let mut ram = [0u8; 24];
        plan.unpack(&[1, 1, 2, 2, 2, 2, 3, 4], &mut ram);
        assert_eq!(&ram[0..4], &[2, 2, 2, 2], "the later run's bytes");
        assert_eq!((ram[10], ram[20]), (3, 4));
    }

    #[test]
    fn entries_adjacent_in_image_and_ram_are_one_copy() {
        let mut ram = [0u8; 31];
        // 6040h (RAM 0..2) then 607Ah (RAM 2..6): contiguous on both sides.
        od_with(&mut ram, &[0x6040_0010, 0x607A_0020]);
        let plan = PdoPlan::build(&Dictionary::new(&PROFILE, &mut ram), Direction::Rx).unwrap();
        assert_eq!((plan.entries(), plan.copies()), (2, 1));
        // The other order: contiguous in the image only.
        od_with(&mut ram, &[0x607A_0020, 0x6040_0010]);
        let plan = PdoPlan::build(&Dictionary::new(&PROFILE, &mut ram), Direction::Rx).unwrap();
        assert_eq!((plan.entries(), plan.copies()), (2, 2));
        plan.unpack(&[0x78, 0x56, 0x34, 0x12, 0x0F, 0x00], &mut ram);
        assert_eq!(&ram[0..6], &[0x0F, 0x00, 0x78, 0x56, 0x34, 0x12]);
        // Padding between them: two copies.
        od_with(&mut ram, &[0x6040_0010, 0x0000_0008, 0x607A_0020]);
        let plan = PdoPlan::build(&Dictionary::new(&PROFILE, &mut ram), Direction::Rx).unwrap();
        assert_eq!((plan.entries(), plan.copies()), (2, 2));
    }

    /// A watched entry (607Ah, next to the controlword in the image and in the OD RAM) is
    /// copied apart from the others and compared: `unpack_watching` tells a change of its
    /// bytes, not of the others'; the plain plan merges the two and watches nothing.
    #[test]
    fn a_watched_entry_is_copied_apart_and_its_changes_told() {
        let mut ram = [0u8; 31];
        od_with(&mut ram, &[0x6040_0010, 0x607A_0020]);
        let od = Dictionary::new(&PROFILE, &mut ram);
        // 607Ah is RAM 2..6.
        let target = |at: u16, len: u16| at < 6 && at + len > 2;
        let plan = PdoPlan::build_watching(&od, Direction::Rx, &target).unwrap();
        let plain = PdoPlan::build(&od, Direction::Rx).unwrap();
        assert!(plan.watches() && !plain.watches());
        assert_eq!((plan.entries(), plan.copies()), (2, 2), "not merged");
        assert_eq!((plain.entries(), plain.copies()), (2, 1));
        let mut ram = [0u8; 31];
        let image = [0x0F, 0x00, 0x78, 0x56, 0x34, 0x12];
        assert!(plan.unpack_watching(&image, &mut ram), "607Ah set");
        assert_eq!(&ram[0..6], &image);
        assert!(!plan.unpack_watching(&image, &mut ram), "the same again");
        let image = [0x1F, 0x00, 0x78, 0x56, 0x34, 0x12];
        assert!(
            !plan.unpack_watching(&image, &mut ram),
            "the controlword only"
        );
        assert_eq!(ram[0], 0x1F);
        let image = [0x1F, 0x00, 0x78, 0x56, 0x34, 0x13];
        assert!(
            plan.unpack_watching(&image, &mut ram),
            "the last byte of 607Ah"
        );
        assert_eq!(&ram[0..6], &image);
        // The plain unpack copies the watched entry too, without telling.
        let mut other = [0u8; 31];
        plan.unpack(&image, &mut other);
        assert_eq!(other, ram);
    }

    /// A watched entry off the byte boundaries of the image (a bit copy) tells its changes too.
    #[test]
    fn a_watched_bit_entry_tells_its_changes() {
        let mut ram = [0u8; 31];
        // The 1-bit flag 2000h (RAM 6), 7 bits of padding, the controlword.
        od_with(&mut ram, &[0x2000_0001, 0x0000_0007, 0x6040_0010]);
        let od = Dictionary::new(&PROFILE, &mut ram);
        let plan = PdoPlan::build_watching(&od, Direction::Rx, &|at, _| at == 6).unwrap();
        assert!(plan.watches());
        let mut ram = [0u8; 31];
        assert!(
            !plan.unpack_watching(&[0x00, 0x34, 0x12], &mut ram),
            "flag still 0"
        );
        assert!(
            plan.unpack_watching(&[0xFF, 0x34, 0x12], &mut ram),
            "flag set"
        );
        assert_eq!((ram[6], &ram[0..2]), (0x01, &[0x34, 0x12][..]));
        assert!(
            !plan.unpack_watching(&[0x01, 0x00, 0x00], &mut ram),
            "only the controlword"
        );
        assert!(
            plan.unpack_watching(&[0x00, 0x00, 0x00], &mut ram),
            "flag cleared"
        );
        assert_eq!(ram[6], 0x00);
    }

    /// Plain and watched runs of every width: every run is copied to its place, and a change
    /// of each watched run alone is told, of each plain run alone not.
    #[test]
    fn watched_runs_tell_each_change() {
        // (ram, image, len), none adjacent; the last five watched (lengths 4, 1, 2, 3, 7).
        let spans = [
            (40, 0, 2),
            (10, 2, 4),
            (30, 6, 1),
            (0, 7, 4),
            (60, 11, 4),
            (70, 15, 1),
            (80, 16, 2),
            (90, 18, 3),
            (100, 21, 7),
        ];
        let runs = spans.map(|(ram, image, len)| ByteRun::new(ram, image, len));
        let plan = PdoPlan {
            runs: Vec::from_slice(&runs).unwrap(),
            watched_runs: 5,
            ..PdoPlan::default()
        };
        let image: [u8; 28] = core::array::from_fn(|i| 0x80 + i as u8);
        let mut ram = [0u8; 112];
        assert!(plan.unpack_watching(&image, &mut ram));
        for (r, i, n) in spans.map(|(r, i, n)| (usize::from(r), usize::from(i), usize::from(n))) {
            assert_eq!(&ram[r..r + n], &image[i..i + n], "run at image {i}");
        }
        assert!(!plan.unpack_watching(&image, &mut ram), "the same again");
        for (k, &(_, at, len)) in spans.iter().enumerate() {
            let mut changed = image;
            changed[usize::from(at + len - 1)] ^= 0xFF;
            assert_eq!(
                plan.unpack_watching(&changed, &mut ram),
                k >= 4,
                "a change of run {k} alone"
            );
            plan.unpack(&image, &mut ram);
        }
    }

    #[test]
    fn writes_ram_names_exactly_the_mapped_entries_bytes() {
        let mut ram = [0u8; 31];
        // 6040h at RAM 0..2, 607Ah at 2..6; the flag 2000h (RAM 6) is not mapped.
        od_with(&mut ram, &[0x6040_0010, 0x607A_0020]);
        let plan = PdoPlan::build(&Dictionary::new(&PROFILE, &mut ram), Direction::Rx).unwrap();
        assert!(plan.writes_ram(0, 2) && plan.writes_ram(1, 1) && plan.writes_ram(5, 4));
        assert!(!plan.writes_ram(6, 1), "the unmapped flag");
        assert!(!plan.writes_ram(6, 0) && !plan.writes_ram(2, 0), "no bytes");
        assert!(
            !PdoPlan::default().writes_ram(0, 2),
            "the empty plan writes nothing"
        );
    }

    #[test]
    fn ram_ranges_answer_as_the_plan_and_as_the_mapping_search() {
        let mut ram = [0u8; 31];
        // 6040h and 607Ah byte-aligned (one run), the 1-bit flag 2000h bit-copied.
        od_with(
            &mut ram,
            &[0x6040_0010, 0x607A_0020, 0x2000_0001, 0x0000_0007],
        );
        let plan = PdoPlan::build(&Dictionary::new(&PROFILE, &mut ram), Direction::Rx).unwrap();
        let ranges = plan.ram_ranges();
        let od = Dictionary::new(&PROFILE, &mut ram);
        for object in PROFILE.objects {
            for e in object.entries {
                let Value::Ram(at) = e.value else { continue };
                let len = e.byte_len() as u16;
                let searched = rules::is_rx_mapped(&od, object.index, e.subindex);
                assert_eq!(
                    overlaps(&ranges, at, len),
                    searched,
                    "{:#06x}",
                    object.index
                );
                assert_eq!(plan.writes_ram(at, len), searched, "{:#06x}", object.index);
            }
        }
        assert!(overlaps(&ranges, 6, 1), "the bit-copied flag");
        assert!(!overlaps(&ranges, 0, 0), "no bytes");
        assert!(PdoPlan::default().ram_ranges().is_empty());
    }

    #[test]
    fn bit_entry_and_padding_are_placed_bit_exact() {
        let mut ram = [0u8; 31];
        // 1 bit flag, 7 bit padding (dummy index 0x0000), then the controlword.
        od_with(&mut ram, &[0x2000_0001, 0x0000_0007, 0x6040_0010]);
        let plan = PdoPlan::build(&Dictionary::new(&PROFILE, &mut ram), Direction::Rx).unwrap();
        assert_eq!(plan.byte_len(), 3);
        plan.unpack(&[0xFF, 0x34, 0x12], &mut ram);
        assert_eq!(ram[6], 0x01, "only bit 0 is the flag");
        assert_eq!(&ram[0..2], &[0x34, 0x12]);
    }

    #[test]
    fn wrong_bit_length_or_direction_is_invalid_output_mapping() {
        let mut ram = [0u8; 31];
        od_with(&mut ram, &[0x6040_0020]);
        let r = PdoPlan::build(&Dictionary::new(&PROFILE, &mut ram), Direction::Rx);
        assert_eq!(r.map_err(|c| c.code()), Err(0x0025));
        od_with(&mut ram, &[0x6041_0010]);
        let r = PdoPlan::build(&Dictionary::new(&PROFILE, &mut ram), Direction::Rx);
        assert_eq!(r.map_err(|c| c.code()), Err(0x0025));
        od_with(&mut ram, &[0x7777_0010]);
        let r = PdoPlan::build(&Dictionary::new(&PROFILE, &mut ram), Direction::Rx);
        assert_eq!(r.map_err(|c| c.code()), Err(0x0025));
    }

    #[test]
    fn pack_copies_constants_and_ram() {
        let plan = PdoPlan {
            runs: Vec::from_slice(&[ByteRun::new(2, 2, 4)]).unwrap(),
            steps: Vec::from_slice(&[CopyStep {
                slot: Slot::Const(&[0x37, 0x02]),
                image_bit: 0,
                bits: 16,
            }])
            .unwrap(),
            entries: 2,
            bits: 48,
            ..PdoPlan::default()
        };
        let mut ram = [0u8; 31];
        ram[2..6].copy_from_slice(&[1, 2, 3, 4]);
        let mut image = [0u8; 6];
        plan.pack(&ram, &mut image);
        assert_eq!(image, [0x37, 0x02, 1, 2, 3, 4]);
    }

    #[test]
    fn copy_bytes_copies_every_length_exactly() {
        for n in 0..=40 {
            let from: [u8; 40] = core::array::from_fn(|i| 0xA0 + i as u8);
            let mut to = [0u8; 42];
            copy_bytes(&from[..n], &mut to[1..1 + n]);
            assert_eq!(&to[1..1 + n], &from[..n], "{n} bytes");
            assert!(
                to[0] == 0 && to[1 + n..].iter().all(|&b| b == 0),
                "{n}: nothing else"
            );
        }
    }

    #[test]
    fn copy_bits_never_panics_out_of_range() {
        let mut dst = [0u8; 2];
        copy_bits(&[0xFF; 2], 9, &mut dst, 12, 40);
        copy_bits(&[0xFF; 2], 0, &mut dst, 0, 64);
        assert_eq!(dst, [0x00, 0xF0]);
    }
}
