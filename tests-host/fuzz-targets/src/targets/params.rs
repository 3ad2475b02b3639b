//! Target `params`: the parameter store (1010h/1011h) loading arbitrary flash images at
//! power-on, then storing and loading again.
//!
//! Input: profile, then each of the two slots as erased flash, raw bytes, or a record built in
//! the store's own format from chosen entries and values (any identity, any sequence number),
//! optionally corrupted at chosen bytes with the CRC made good again, so inputs get past the
//! CRC into the entry checks.
//!
//! Oracle: loading never fails on a healthy storage (a bad record means defaults, CiA 301
//! §7.5.2.13); it changes only the entries the profile stores, and only to values within
//! their ranges; after it, "save all" stores a record that the next power-on loads, with the
//! sequence number the store returned, giving back every stored value.

use firmware::od::{DataType, Dictionary, Entry, Object, Value};
use firmware::params::record::{crc32, Identity, Writer, CRC_LEN, HEADER_LEN};
use firmware::params::{identity, is_storable, max_record_len, Group, ParamStore};
use hal::storage::{NvStorage, StorageError};

use crate::bench::profile_of;
use crate::coe::Violation;
use crate::input::Input;

/// Value of an erased flash byte.
const ERASED: u8 = 0xFF;
/// Flash page size the slots are made of (the STM32G4's, as on the simulated board).
const PAGE: usize = 2048;

/// Two slots of NOR-like flash in RAM.
pub struct Flash {
    slots: [Vec<u8>; 2],
}

impl Flash {
    /// Two erased slots of `slot_size` bytes.
    pub fn erased(slot_size: usize) -> Self {
        Self {
            slots: [vec![ERASED; slot_size], vec![ERASED; slot_size]],
        }
    }
    /// The slots' contents.
    pub fn slots(&self) -> &[Vec<u8>; 2] {
        &self.slots
    }
}

impl NvStorage for Flash {
    fn slots(&self) -> usize {
        2
    }
    fn slot_size(&self) -> usize {
        self.slots[0].len()
    }
    fn read(&mut self, slot: usize, buf: &mut [u8]) -> Result<(), StorageError> {
        let s = self.slots.get(slot).ok_or(StorageError::OutOfRange)?;
        let src = s.get(..buf.len()).ok_or(StorageError::OutOfRange)?;
        buf.copy_from_slice(src);
        Ok(())
    }
    fn write(&mut self, slot: usize, data: &[u8]) -> Result<(), StorageError> {
        let s = self.slots.get_mut(slot).ok_or(StorageError::OutOfRange)?;
        if data.len() > s.len() {
            return Err(StorageError::OutOfRange);
        }
        s.fill(ERASED);
        s[..data.len()].copy_from_slice(data);
        Ok(())
    }
}

/// How a slot starts.
pub mod slot_kind {
    /// Erased.
    pub const ERASED: u8 = 0;
    /// Raw bytes.
    pub const RAW: u8 = 1;
    /// A record in the store's format.
    pub const RECORD: u8 = 2;
    /// Number of kinds.
    pub const COUNT: u8 = 3;
}

/// Runs one input.
pub fn run(data: &[u8]) -> Result<(), Violation> {
    let mut input = Input::new(data);
    let profile = profile_of(input.u8());
    let od_profile = &profile.fw.od;
    let slot_size = max_record_len(od_profile).div_ceil(PAGE).max(1) * PAGE;
    let storable: Vec<(&Object, &Entry)> = od_profile
        .objects
        .iter()
        .flat_map(|o| o.entries.iter().map(move |e| (o, e)))
        .filter(|(o, e)| is_storable(&od_profile.storage, o, e))
        .collect();
    let mut slots = [vec![ERASED; slot_size], vec![ERASED; slot_size]];
    for slot in slots.iter_mut() {
        match input.u8() % slot_kind::COUNT {
            slot_kind::RAW => {
                let raw = input.chunk(slot_size);
                slot[..raw.len()].copy_from_slice(raw);
            }
            slot_kind::RECORD => build_record(&mut input, slot, &storable, identity(od_profile)),
            _ => {}
        }
    }
    let mut store = ParamStore::<Flash>::new(Flash { slots });

    let mut defaults = vec![0u8; firmware::profiles::MAX_RAM_SIZE];
    Dictionary::new(od_profile, &mut defaults).load_defaults();
    let mut ram = defaults.clone();
    let mut od = Dictionary::new(od_profile, &mut ram);
    match store.load(&mut od) {
        Ok(_) => {}
        Err(e) => return Err(Violation(format!("loading an image failed: {e:?}"))),
    }
    for o in od_profile.objects {
        for e in o.entries {
            let Value::Ram(at) = e.value else { continue };
            let span = usize::from(at)..usize::from(at) + e.byte_len();
            let (now, default) = (&od.ram()[span.clone()], &defaults[span]);
            if now == default {
                continue;
            }
            if !is_storable(&od_profile.storage, o, e) {
                return Err(Violation(format!(
                    "load changed {:#06x}:{}, which the profile does not store",
                    o.index, e.subindex
                )));
            }
            if !in_range(e, now) {
                return Err(Violation(format!(
                    "load put {now:02x?} into {:#06x}:{}, outside its range",
                    o.index, e.subindex
                )));
            }
        }
    }

    let sequence = match store.store(&od, Group::All) {
        Ok(s) => s,
        Err(e) => return Err(Violation(format!("save all failed: {e:?}"))),
    };
    let mut again = defaults.clone();
    let mut od2 = Dictionary::new(od_profile, &mut again);
    match store.load(&mut od2) {
        Ok(Some(l)) if l.sequence == sequence => {}
        other => {
            return Err(Violation(format!(
                "the record just stored (sequence {sequence}) loads as {other:?}"
            )))
        }
    }
    for (o, e) in &storable {
        let Value::Ram(at) = e.value else { continue };
        let span = usize::from(at)..usize::from(at) + e.byte_len();
        if od.ram()[span.clone()] != od2.ram()[span] {
            return Err(Violation(format!(
                "{:#06x}:{} did not survive save all and power-on",
                o.index, e.subindex
            )));
        }
    }
    Ok(())
}

/// A record in the store's format: chosen entries (the profile's stored ones most of the time)
/// with chosen values, the right identity or another, then corrupted bytes with a good CRC.
fn build_record(
    input: &mut Input<'_>,
    slot: &mut [u8],
    storable: &[(&Object, &Entry)],
    own: Identity,
) {
    let flags = input.u8();
    let identity = if flags & 1 != 0 {
        Identity {
            vendor_id: input.u32(),
            product_code: input.u32(),
            revision: input.u32(),
        }
    } else {
        own
    };
    let sequence = input.u32();
    let Ok(mut writer) = Writer::new(slot) else {
        return;
    };
    for _ in 0..input.u8() % 32 {
        let (index, subindex, len) = match storable.get(input.choose(storable.len().max(1))) {
            Some((o, e)) if input.u8() & 3 != 0 => (o.index, e.subindex, e.byte_len()),
            _ => (input.u16(), input.u8(), usize::from(input.u8() % 16)),
        };
        let value: Vec<u8> = (0..len).map(|_| input.u8()).collect();
        if writer.push(index, subindex, &value).is_err() {
            break;
        }
    }
    let len = writer.finish(&identity, sequence);
    for _ in 0..input.u8() % 4 {
        let at = input.choose(len.max(1));
        if let Some(b) = slot.get_mut(at) {
            *b = input.u8();
        }
    }
    if flags & 2 == 0 && len >= HEADER_LEN + CRC_LEN {
        // Make the CRC good again over whatever the record now holds.
        let body = len - CRC_LEN;
        let crc = crc32(&slot[..body]);
        slot[body..len].copy_from_slice(&crc.to_le_bytes());
    }
}

/// Whether an integer value lies within the entry's minimum and maximum (entries without a
/// range, and non-integer types, always do).
fn in_range(e: &Entry, bytes: &[u8]) -> bool {
    let signed = matches!(
        e.data_type,
        DataType::Integer8
            | DataType::Integer16
            | DataType::Integer24
            | DataType::Integer32
            | DataType::Integer64
    );
    let unsigned = matches!(
        e.data_type,
        DataType::Unsigned8
            | DataType::Unsigned16
            | DataType::Unsigned24
            | DataType::Unsigned32
            | DataType::Unsigned64
    );
    if !(signed || unsigned) || bytes.len() > 8 || bytes.is_empty() {
        return true;
    }
    let decode = |b: &[u8]| -> Option<i128> {
        if b.len() != bytes.len() {
            return None;
        }
        let mut v: u64 = 0;
        for (i, &x) in b.iter().enumerate() {
            v |= u64::from(x) << (8 * i);
        }
        if signed {
            let shift = 64 - 8 * b.len() as u32;
            Some(i128::from(((v << shift) as i64) >> shift))
        } else {
            Some(i128::from(v))
        }
    };
    let Some(v) = decode(bytes) else { return true };
    decode(e.min).is_none_or(|min| v >= min) && decode(e.max).is_none_or(|max| v <= max)
}
