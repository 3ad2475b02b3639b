//! The on-storage format of one parameter record, and its CRC.
//!
//! A record fills one storage slot from its start (all integers little-endian):
//!
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 4 | magic [`MAGIC`] (`"OCSP"`) |
//! | 4 | 2 | format version [`FORMAT_VERSION`] |
//! | 6 | 2 | number of entries |
//! | 8 | 4 | vendor ID (1018h:01) |
//! | 12 | 4 | product code (1018h:02) |
//! | 16 | 4 | revision (1018h:03) |
//! | 20 | 4 | sequence number (wrapping; the newer of two valid records wins) |
//! | 24 | 4 | payload length in bytes |
//! | 28 | n | payload: entries, each `index: u16, subindex: u8, length: u16, value: [u8; length]` |
//! | 28 + n | 4 | CRC-32 ([`crc32`]) over bytes `0 .. 28 + n` |
//!
//! A record is valid only if every field checks out: magic, version, the identity of the
//! running profile (a record written by another product or revision is never loaded), a
//! payload length that fits, entries that exactly fill the payload and match the count, and the
//! CRC. Each entry names its object entry and length, so a record from an OD whose layout
//! changed without a revision change still cannot load a value into the wrong entry.

/// Record magic: ASCII `"OCSP"` (Open CiA402 Servo Parameters) read as a little-endian u32.
pub const MAGIC: u32 = u32::from_le_bytes(*b"OCSP");
/// Version of this layout; a record of another version is ignored.
pub const FORMAT_VERSION: u16 = 1;
/// Length of the header (magic .. payload length).
pub const HEADER_LEN: usize = 28;
/// Length of the trailing CRC.
pub const CRC_LEN: usize = 4;
/// Length of an entry's head (index, subindex, length) before its value.
pub const ENTRY_HEAD_LEN: usize = 5;

/// Header field offsets.
mod offset {
    pub const MAGIC: usize = 0;
    pub const VERSION: usize = 4;
    pub const COUNT: usize = 6;
    pub const VENDOR: usize = 8;
    pub const PRODUCT: usize = 12;
    pub const REVISION: usize = 16;
    pub const SEQUENCE: usize = 20;
    pub const PAYLOAD_LEN: usize = 24;
}

/// Why a byte string is not a valid record, or a record could not be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RecordError {
    /// Shorter than a header, or than the length the header announces.
    Truncated,
    /// Wrong magic (erased, foreign or torn data).
    Magic,
    /// Another format version.
    Version,
    /// Written by another vendor, product or revision.
    Identity,
    /// The entries do not exactly fill the payload, or their count differs from the header's.
    Structure,
    /// The CRC does not match (torn write, bit error).
    Crc,
    /// Building: the record does not fit the buffer.
    Capacity,
}

/// The device a record belongs to (1018h:01..03).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Identity {
    /// Vendor ID.
    pub vendor_id: u32,
    /// Product code.
    pub product_code: u32,
    /// Revision number.
    pub revision: u32,
}

/// CRC-32 as in IEEE 802.3 / zlib (reflected polynomial 0x04C11DB7 = 0xEDB88320 reflected,
/// initial value and final XOR 0xFFFF_FFFF; check value of `"123456789"` is 0xCBF4_3926).
pub fn crc32(data: &[u8]) -> u32 {
    !data.iter().fold(CRC_INIT, |crc, &b| {
        let i = ((crc ^ u32::from(b)) & 0xFF) as usize;
        CRC_TABLE.get(i).copied().unwrap_or(0) ^ (crc >> 8)
    })
}

/// CRC-32 initial register value.
const CRC_INIT: u32 = 0xFFFF_FFFF;
/// CRC-32 polynomial, reflected.
const CRC_POLY_REFLECTED: u32 = 0xEDB8_8320;
/// Byte-wise lookup table of the reflected CRC-32 (1 KiB of flash), computed by the compiler (a
/// counter overflowing here fails the build).
const CRC_TABLE: [u32; 256] = {
    let mut table = [0u32; 256];
    let mut rest: &mut [u32] = &mut table;
    let mut byte: u32 = 0;
    while let [slot, tail @ ..] = rest {
        let mut c = byte;
        let mut bit = 0;
        while bit < 8 {
            c = if c & 1 != 0 {
                CRC_POLY_REFLECTED ^ (c >> 1)
            } else {
                c >> 1
            };
            bit += 1;
        }
        *slot = c;
        byte += 1;
        rest = tail;
    }
    table
};

/// Little-endian u16 at `at` (0 if out of range; callers check lengths first).
fn u16_at(b: &[u8], at: usize) -> u16 {
    b.get(at..)
        .and_then(|s| s.first_chunk::<2>())
        .map_or(0, |s| u16::from_le_bytes(*s))
}

/// Little-endian u32 at `at` (0 if out of range; callers check lengths first).
fn u32_at(b: &[u8], at: usize) -> u32 {
    b.get(at..)
        .and_then(|s| s.first_chunk::<4>())
        .map_or(0, |s| u32::from_le_bytes(*s))
}

/// Writes `v` little-endian at `at` (ignored if out of range; callers check lengths first).
fn put(b: &mut [u8], at: usize, v: &[u8]) {
    if let Some(dst) = b.get_mut(at..).and_then(|d| d.get_mut(..v.len())) {
        // Byte by byte: `copy_from_slice` keeps a length-mismatch panic here (`panic-paths`).
        for (d, s) in dst.iter_mut().zip(v) {
            *d = *s;
        }
    }
}

/// Total record length (header + payload + CRC) announced by a header, if `header` is the start
/// of a record of this format and identity. Used to read exactly one record from a slot.
pub fn announced_len(header: &[u8], identity: &Identity) -> Result<usize, RecordError> {
    if header.len() < HEADER_LEN {
        return Err(RecordError::Truncated);
    }
    if u32_at(header, offset::MAGIC) != MAGIC {
        return Err(RecordError::Magic);
    }
    if u16_at(header, offset::VERSION) != FORMAT_VERSION {
        return Err(RecordError::Version);
    }
    let found = Identity {
        vendor_id: u32_at(header, offset::VENDOR),
        product_code: u32_at(header, offset::PRODUCT),
        revision: u32_at(header, offset::REVISION),
    };
    if found != *identity {
        return Err(RecordError::Identity);
    }
    let payload = usize::try_from(u32_at(header, offset::PAYLOAD_LEN)).unwrap_or(usize::MAX);
    HEADER_LEN
        .checked_add(payload)
        .and_then(|n| n.checked_add(CRC_LEN))
        .ok_or(RecordError::Truncated)
}

/// A validated record.
#[derive(Clone, Copy, Debug)]
pub struct Record<'a> {
    sequence: u32,
    count: u16,
    payload: &'a [u8],
}

impl<'a> Record<'a> {
    /// Validates the record at the start of `bytes` (which may be longer) for `identity`.
    pub fn parse(bytes: &'a [u8], identity: &Identity) -> Result<Self, RecordError> {
        let total = announced_len(bytes, identity)?;
        let record = bytes.get(..total).ok_or(RecordError::Truncated)?;
        let (body, crc) = record
            .split_last_chunk::<CRC_LEN>()
            .ok_or(RecordError::Truncated)?;
        if crc32(body) != u32::from_le_bytes(*crc) {
            return Err(RecordError::Crc);
        }
        let parsed = Self {
            sequence: u32_at(body, offset::SEQUENCE),
            count: u16_at(body, offset::COUNT),
            payload: body.get(HEADER_LEN..).unwrap_or_default(),
        };
        let mut n: u16 = 0;
        let mut entries = parsed.entries();
        for _ in entries.by_ref() {
            n = n.checked_add(1).ok_or(RecordError::Structure)?;
        }
        if entries.malformed || n != parsed.count {
            return Err(RecordError::Structure);
        }
        Ok(parsed)
    }

    /// The sequence number.
    pub fn sequence(&self) -> u32 {
        self.sequence
    }

    /// Number of entries.
    pub fn len(&self) -> usize {
        usize::from(self.count)
    }

    /// Whether the record holds no entry (a "defaults" record).
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// The entries in stored order.
    pub fn entries(&self) -> Entries<'a> {
        Entries {
            rest: self.payload,
            malformed: false,
        }
    }

    /// The stored value of `index:subindex`, if the record holds it.
    pub fn find(&self, index: u16, subindex: u8) -> Option<&'a [u8]> {
        self.entries()
            .find(|e| e.index == index && e.subindex == subindex)
            .map(|e| e.value)
    }
}

/// One stored entry.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StoredEntry<'a> {
    /// Object index.
    pub index: u16,
    /// Subindex.
    pub subindex: u8,
    /// Value bytes (little-endian, the entry's full byte length when it was stored).
    pub value: &'a [u8],
}

/// Iterator over a payload's entries; stops at the end or at the first malformed entry.
pub struct Entries<'a> {
    rest: &'a [u8],
    malformed: bool,
}

impl<'a> Iterator for Entries<'a> {
    type Item = StoredEntry<'a>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.rest.is_empty() || self.malformed {
            return None;
        }
        let entry = self.rest.split_first_chunk::<ENTRY_HEAD_LEN>().and_then(
            |(&[i0, i1, subindex, l0, l1], tail)| {
                let (value, rest) =
                    tail.split_at_checked(usize::from(u16::from_le_bytes([l0, l1])))?;
                Some((
                    StoredEntry {
                        index: u16::from_le_bytes([i0, i1]),
                        subindex,
                        value,
                    },
                    rest,
                ))
            },
        );
        let Some((entry, rest)) = entry else {
            self.malformed = true;
            return None;
        };
        self.rest = rest;
        Some(entry)
    }
}

/// Builds a record in a caller-provided buffer: [`Writer::push`] the entries, then
/// [`Writer::finish`].
pub struct Writer<'b> {
    buf: &'b mut [u8],
    len: usize,
    count: u16,
}

impl<'b> Writer<'b> {
    /// Starts a record in `buf`.
    pub fn new(buf: &'b mut [u8]) -> Result<Self, RecordError> {
        if buf.len() < HEADER_LEN + CRC_LEN {
            return Err(RecordError::Capacity);
        }
        Ok(Self {
            buf,
            len: HEADER_LEN,
            count: 0,
        })
    }

    /// Appends one entry.
    pub fn push(&mut self, index: u16, subindex: u8, value: &[u8]) -> Result<(), RecordError> {
        let len = u16::try_from(value.len()).map_err(|_| RecordError::Capacity)?;
        let value_at = self
            .len
            .checked_add(ENTRY_HEAD_LEN)
            .ok_or(RecordError::Capacity)?;
        let end = value_at
            .checked_add(value.len())
            .ok_or(RecordError::Capacity)?;
        let count = self.count.checked_add(1).ok_or(RecordError::Capacity)?;
        // `new` made sure the buffer holds at least a header and the CRC.
        if end > self.buf.len().saturating_sub(CRC_LEN) {
            return Err(RecordError::Capacity);
        }
        let [i0, i1] = index.to_le_bytes();
        let [l0, l1] = len.to_le_bytes();
        put(self.buf, self.len, &[i0, i1, subindex, l0, l1]);
        put(self.buf, value_at, value);
        self.len = end;
        self.count = count;
        Ok(())
    }

    /// Writes header and CRC; returns the record length (the record is `buf[..len]`).
    pub fn finish(self, identity: &Identity, sequence: u32) -> usize {
        // `len` starts at HEADER_LEN and only grows: never saturates.
        let payload_len = self.len.saturating_sub(HEADER_LEN) as u32;
        let b = self.buf;
        put(b, offset::MAGIC, &MAGIC.to_le_bytes());
        put(b, offset::VERSION, &FORMAT_VERSION.to_le_bytes());
        put(b, offset::COUNT, &self.count.to_le_bytes());
        put(b, offset::VENDOR, &identity.vendor_id.to_le_bytes());
        put(b, offset::PRODUCT, &identity.product_code.to_le_bytes());
        put(b, offset::REVISION, &identity.revision.to_le_bytes());
        put(b, offset::SEQUENCE, &sequence.to_le_bytes());
        put(b, offset::PAYLOAD_LEN, &payload_len.to_le_bytes());
        let crc = crc32(b.get(..self.len).unwrap_or_default());
        put(b, self.len, &crc.to_le_bytes());
        // `new` and `push` keep room for the CRC after `len`: never saturates.
        self.len.saturating_add(CRC_LEN)
    }
}

/// Whether sequence number `a` is newer than `b` in serial-number arithmetic (RFC 1982 style):
/// `a` is newer if it lies less than 2^31 steps after `b`, so the comparison survives the wrap
/// from 0xFFFF_FFFF to 0.
pub fn is_newer(a: u32, b: u32) -> bool {
    (a.wrapping_sub(b) as i32) > 0
}
