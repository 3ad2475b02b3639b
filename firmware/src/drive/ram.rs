//! The drive's reads and writes of its variables in the OD RAM: little-endian values at the
//! offsets od-gen laid out (`None`: the profile has no such variable, reads give `None` and
//! writes do nothing).

use ethercat_slave::od::{Object, Profile, Value};

/// The OD RAM offset of entry `index:subindex` of `od`, `None` when it is not a RAM variable
/// (a const fn: the drive finds the communication-area entries it reads once, at build time).
pub(super) const fn ram_offset(od: &Profile, index: u16, subindex: u8) -> Option<u16> {
    let mut objects = od.objects;
    while let [o, more_objects @ ..] = objects {
        if o.index == index {
            let mut entries = o.entries;
            while let [e, more_entries @ ..] = entries {
                if e.subindex == subindex {
                    return match e.value {
                        Value::Ram(at) => Some(at),
                        _ => None,
                    };
                }
                entries = more_entries;
            }
        }
        objects = more_objects;
    }
    None
}

/// [`ram_offset`] at run time, in an object already found (`Profile::object`, a binary
/// search, rather than the linear walk a const fn is limited to).
pub(super) fn ram_offset_in(object: &Object, subindex: u8) -> Option<u16> {
    match object.entry(subindex)?.value {
        Value::Ram(at) => Some(at),
        _ => None,
    }
}

// Offsets are u16 (from the generated profile) and N ≤ 4: `at + N` cannot overflow a usize.
pub(super) fn read_bytes<const N: usize>(ram: &[u8], at: Option<u16>) -> Option<[u8; N]> {
    let at = usize::from(at?);
    ram.get(at..at.checked_add(N)?)?.try_into().ok()
}

pub(super) fn write_bytes<const N: usize>(ram: &mut [u8], at: Option<u16>, v: [u8; N]) {
    if let Some(at) = at.map(usize::from) {
        if let Some(dst) = at.checked_add(N).and_then(|end| ram.get_mut(at..end)) {
            dst.copy_from_slice(&v);
        }
    }
}

pub(super) fn read_i32(ram: &[u8], at: Option<u16>) -> Option<i32> {
    read_bytes::<4>(ram, at).map(i32::from_le_bytes)
}

pub(super) fn read_u32(ram: &[u8], at: Option<u16>) -> Option<u32> {
    read_bytes::<4>(ram, at).map(u32::from_le_bytes)
}

pub(super) fn read_i16(ram: &[u8], at: Option<u16>) -> Option<i16> {
    read_bytes(ram, at).map(i16::from_le_bytes)
}

pub(super) fn read_u16(ram: &[u8], at: Option<u16>) -> Option<u16> {
    read_bytes::<2>(ram, at).map(u16::from_le_bytes)
}

pub(super) fn write_u16(ram: &mut [u8], at: Option<u16>, v: u16) {
    write_bytes(ram, at, v.to_le_bytes());
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The run-time lookup finds what the const walk finds, for every entry of every profile
    /// and for a subindex that is not there.
    #[test]
    fn the_run_time_lookup_agrees_with_the_const_walk() {
        for profile in crate::profiles::ALL {
            let od = &profile.od;
            let mut ram_entries = 0;
            for object in od.objects {
                for entry in object.entries {
                    let (index, sub) = (object.index, entry.subindex);
                    let found = ram_offset_in(object, sub);
                    assert_eq!(found, ram_offset(od, index, sub), "{index:04X}:{sub}");
                    ram_entries += usize::from(found.is_some());
                }
                let last = object.entries.iter().map(|e| e.subindex).max().unwrap_or(0);
                if let Some(beyond) = last.checked_add(1) {
                    assert_eq!(ram_offset_in(object, beyond), None);
                }
            }
            assert!(ram_entries > 0);
        }
    }
}
