//! Target `pdo`: the process-data copy plan built from arbitrary contents of 1C12h/1C13h and
//! the 16xxh/1Axxh mapping objects (as a corrupted or hostile configuration could leave them,
//! past the SDO rules), then unpack and pack.
//!
//! Input: profile, direction, then writes into the assignment and mapping objects: subindex 0
//! counts of any value, PDO numbers from the profile's mapping objects or any u16, mapping
//! entries naming the profile's mappable entries with their bit length, padding, or any u32.
//! The rest of the input is the process image.
//!
//! Oracle: `PdoPlan::build` accepts exactly the mappings the rules of ETG.1000.6 §5.6.7 / CiA
//! 301 §7.4.8 allow (every assigned PDO a mapping object of the direction, every mapped entry
//! existing, mappable in the direction and of its bit length, dummies 0..7, the image within the
//! profile's limit), refusing the others with 0x0025 (outputs) / 0x0024 (inputs); on an
//! accepted plan, `pack(unpack(x)) = x` on every mapped bit, unpack writes no OD RAM byte
//! outside the mapped entries and pack no image bit outside them. An RxPDO plan built watching
//! some OD RAM bytes (`PdoPlan::build_watching`, two fixed choices) unpacks to the same OD RAM
//! as the plain plan, with or without the comparison, and `unpack_watching` reports a change
//! whenever a watched entry's bytes changed, and only then where no two entries share them.

use firmware::od::{Dictionary, Object, Value};
use firmware::pdo::{self, Direction, PdoPlan, MAX_IMAGE, MAX_MAPPED_ENTRIES};
use hal::esc::AlStatusCode;

use crate::bench::profile_of;
use crate::coe::Violation;
use crate::input::Input;

/// Writes per input.
pub const MAX_WRITES: usize = 48;

/// Operation codes of the input.
pub mod op {
    /// Assignment subindex 0.
    pub const ASSIGN_COUNT: u8 = 0;
    /// One assigned PDO.
    pub const ASSIGN: u8 = 1;
    /// A mapping object's subindex 0.
    pub const MAPPING_COUNT: u8 = 2;
    /// One mapping entry.
    pub const MAPPING: u8 = 3;
    /// End of the writes; the rest is the image.
    pub const END: u8 = 4;
    /// Number of operations.
    pub const COUNT: u8 = 5;
}

/// One mapped entry as the model lays it out.
#[derive(Clone, Copy, Debug)]
struct Mapped {
    image_bit: usize,
    bits: usize,
    /// OD RAM offset (`None`: a constant or padding).
    ram: Option<usize>,
}

/// Runs one input.
pub fn run(data: &[u8]) -> Result<(), Violation> {
    let mut input = Input::new(data);
    let profile = profile_of(input.u8());
    let dir = if input.u8() & 1 == 0 {
        Direction::Rx
    } else {
        Direction::Tx
    };
    let od_profile = &profile.fw.od;
    let (assign, range) = match dir {
        Direction::Rx => (pdo::RX_ASSIGN, pdo::RX_MAPPING),
        Direction::Tx => (pdo::TX_ASSIGN, pdo::TX_MAPPING),
    };
    let is_mapping =
        |o: &&Object| pdo::RX_MAPPING.contains(&o.index) || pdo::TX_MAPPING.contains(&o.index);
    let mapping_objects: Vec<&Object> = od_profile.objects.iter().filter(is_mapping).collect();
    let mappable: Vec<(u16, u8, u16)> = od_profile
        .objects
        .iter()
        .flat_map(|o| o.entries.iter().map(move |e| (o, e)))
        .filter(|(_, e)| e.pdo.rx() || e.pdo.tx())
        .map(|(o, e)| (o.index, e.subindex, e.bit_len))
        .collect();
    let mut ram = vec![0u8; firmware::profiles::MAX_RAM_SIZE];
    let mut od = Dictionary::new(od_profile, &mut ram);
    od.load_defaults();

    let mut writes = 0;
    while !input.is_empty() && writes < MAX_WRITES {
        writes += 1;
        let code = input.u8() % op::COUNT;
        let (index, value): (u16, u32) = match code {
            op::ASSIGN_COUNT => (assign, u32::from(input.u8())),
            op::ASSIGN => {
                let pdo = if input.u8() & 1 != 0 || mapping_objects.is_empty() {
                    input.u16()
                } else {
                    mapping_objects[input.choose(mapping_objects.len())].index
                };
                (assign, u32::from(pdo))
            }
            op::MAPPING_COUNT | op::MAPPING if !mapping_objects.is_empty() => {
                let obj = mapping_objects[input.choose(mapping_objects.len())];
                let value = if code == op::MAPPING_COUNT {
                    u32::from(input.u8())
                } else {
                    mapping_entry(&mut input, &mappable)
                };
                (obj.index, value)
            }
            _ => break,
        };
        let subindex = match code {
            op::ASSIGN_COUNT | op::MAPPING_COUNT => 0,
            _ => input.u8() % 16 + 1,
        };
        if let Some(entry) = od.entry(index, subindex) {
            let bytes = value.to_le_bytes();
            let n = entry.byte_len().min(4);
            let _ = od.set_value(entry, &bytes[..n]);
        }
    }

    let built = PdoPlan::build(&od, dir);
    let model = model(&od, dir, range);
    let plan = match (built, model) {
        (Err(code), None) => {
            let expected = match dir {
                Direction::Rx => AlStatusCode::InvalidOutputMapping,
                Direction::Tx => AlStatusCode::InvalidInputMapping,
            };
            return if code == expected {
                Ok(())
            } else {
                Err(Violation(format!(
                    "refused with {code:?}, expected {expected:?}"
                )))
            };
        }
        (Ok(plan), Some((model, bits))) => {
            if plan.byte_len() != bits.div_ceil(8) {
                return Err(Violation(format!(
                    "{dir:?} image of {} bytes, the mapping has {bits} bits",
                    plan.byte_len()
                )));
            }
            (plan, model)
        }
        (Ok(_), None) => {
            return Err(Violation(format!(
                "{dir:?} plan accepted that the rules refuse"
            )))
        }
        (Err(code), Some(_)) => {
            return Err(Violation(format!(
                "{dir:?} plan refused ({code:?}) that the rules allow"
            )))
        }
    };
    let (plan, model) = plan;
    if dir == Direction::Rx {
        for watched in WATCHES {
            let Ok(watching) = PdoPlan::build_watching(&od, dir, &watched) else {
                return Err(Violation(
                    "a plan refused when built watching, accepted plainly".into(),
                ));
            };
            if watching.byte_len() != plan.byte_len() || watching.entries() != plan.entries() {
                return Err(Violation(
                    "the watching plan lays the image out differently".into(),
                ));
            }
            let mut probe = input.clone();
            watch_changes(&plan, &watching, &model, watched, &mut probe, od.ram())?;
        }
    }
    round_trip(&plan, &model, &mut input, od.ram())
}

/// The choices of watched OD RAM bytes tried: every other 3-byte block (neighbours of both
/// kinds), everything.
const WATCHES: [fn(u16, u16) -> bool; 2] = [
    |at, len| (at..at.saturating_add(len)).any(|b| (b / 3) % 2 == 0),
    |_, _| true,
];

/// The watching plan unpacks `image` as the plain one does (both ways), and reports a change
/// exactly when a watched entry's OD RAM bytes changed (at least then where entries share
/// bytes: a later copy may put back what an earlier one changed).
fn watch_changes(
    plain: &PdoPlan,
    watching: &PdoPlan,
    model: &[Mapped],
    watched: fn(u16, u16) -> bool,
    input: &mut Input<'_>,
    ram0: &[u8],
) -> Result<(), Violation> {
    let image: Vec<u8> = (0..plain.byte_len()).map(|_| input.u8()).collect();
    let mut expected = ram0.to_vec();
    plain.unpack(&image, &mut expected);
    let mut unpacked = ram0.to_vec();
    watching.unpack(&image, &mut unpacked);
    let mut compared = ram0.to_vec();
    let changed = watching.unpack_watching(&image, &mut compared);
    if unpacked != expected || compared != expected {
        return Err(Violation(
            "the watching plan unpacks other OD RAM bytes".into(),
        ));
    }
    let spans: Vec<(usize, usize)> = model
        .iter()
        .filter_map(|m| Some((m.ram?, m.bits.div_ceil(8))))
        .filter(|&(at, n)| watched(at as u16, n as u16))
        .collect();
    let watched_changed = spans
        .iter()
        .any(|&(at, n)| ram0[at..at + n] != expected[at..at + n]);
    // Entries per OD RAM byte: a watched byte another entry writes too may be put back.
    let mut owners = vec![0u8; ram0.len()];
    for m in model {
        if let Some(at) = m.ram {
            for o in owners.iter_mut().skip(at).take(m.bits.div_ceil(8)) {
                *o += 1;
            }
        }
    }
    let shared = spans
        .iter()
        .any(|&(at, n)| owners[at..at + n].iter().any(|&o| o > 1));
    if watched_changed && !changed {
        return Err(Violation(
            "a watched entry changed and unpack_watching did not tell".into(),
        ));
    }
    if changed && !watched_changed && !shared {
        return Err(Violation(
            "unpack_watching told a change no watched entry has".into(),
        ));
    }
    if !watching.watches() && changed {
        return Err(Violation(
            "a plan that watches nothing told a change".into(),
        ));
    }
    // The same image again changes nothing (where no entries share bytes).
    if !shared && watching.unpack_watching(&image, &mut compared) {
        return Err(Violation("the same image told a change twice".into()));
    }
    Ok(())
}

/// A mapping entry: one of the profile's mappable entries with its bit length, padding, or any
/// value.
fn mapping_entry(input: &mut Input<'_>, mappable: &[(u16, u8, u16)]) -> u32 {
    match input.u8() % 4 {
        0 | 1 if !mappable.is_empty() => {
            let (index, subindex, bits) = mappable[input.choose(mappable.len())];
            (u32::from(index) << 16) | (u32::from(subindex) << 8) | u32::from(bits & 0xFF)
        }
        2 => {
            // Padding: a dummy data type 0..7 (index 0 is the gap masters write).
            let index = u32::from(input.u8() % 8);
            (index << 16) | u32::from(input.u8())
        }
        _ => input.u32(),
    }
}

/// The mapping the rules allow, laid out; `None` where they refuse it.
fn model(
    od: &Dictionary<'_>,
    dir: Direction,
    range: core::ops::RangeInclusive<u16>,
) -> Option<(Vec<Mapped>, usize)> {
    let assign = match dir {
        Direction::Rx => pdo::RX_ASSIGN,
        Direction::Tx => pdo::TX_ASSIGN,
    };
    let mut out = Vec::new();
    let mut bit = 0usize;
    let mut entries = 0usize;
    for n in 1..=od.read_u32(assign, 0)? {
        let pdo_index = od.read_u32(assign, u8::try_from(n).ok()?)?;
        let pdo_index = u16::try_from(pdo_index).ok()?;
        if !range.contains(&pdo_index) {
            return None;
        }
        for k in 1..=od.read_u32(pdo_index, 0)? {
            let m = od.read_u32(pdo_index, u8::try_from(k).ok()?)?;
            let (index, subindex, bits) = ((m >> 16) as u16, (m >> 8) as u8, (m & 0xFF) as usize);
            if bits == 0 {
                return None;
            }
            if index <= 7 {
                bit += bits;
                continue;
            }
            let e = od.entry(index, subindex)?;
            let mappable = match dir {
                Direction::Rx => e.pdo.rx(),
                Direction::Tx => e.pdo.tx(),
            };
            if !mappable || usize::from(e.bit_len) != bits {
                return None;
            }
            let ram = match (e.value, dir) {
                (Value::Ram(offset), _) => Some(usize::from(offset)),
                (Value::Const(_), Direction::Tx) => None,
                _ => return None,
            };
            entries += 1;
            if entries > MAX_MAPPED_ENTRIES {
                return None;
            }
            out.push(Mapped {
                image_bit: bit,
                bits,
                ram,
            });
            bit += bits;
        }
    }
    let limit = usize::from(od.profile().device.max_process_bytes).min(MAX_IMAGE);
    (bit.div_ceil(8) <= limit).then_some((out, bit))
}

fn get_bit(b: &[u8], i: usize) -> bool {
    b[i / 8] & (1 << (i % 8)) != 0
}

/// `pack(unpack(x)) = x` on the mapped bits; nothing else written on either side.
fn round_trip(
    plan: &PdoPlan,
    model: &[Mapped],
    input: &mut Input<'_>,
    ram0: &[u8],
) -> Result<(), Violation> {
    let len = plan.byte_len();
    let mut image = vec![0u8; len];
    for b in image.iter_mut() {
        *b = input.u8();
    }
    let mut ram = ram0.to_vec();
    plan.unpack(&image, &mut ram);
    // RAM bytes the mapped entries own.
    let mut owned = vec![0u8; ram.len()];
    for m in model {
        if let Some(at) = m.ram {
            for o in owned.iter_mut().skip(at).take(m.bits.div_ceil(8)) {
                *o += 1;
            }
        }
    }
    for (i, (&a, &b)) in ram0.iter().zip(&ram).enumerate() {
        if a != b && owned[i] == 0 {
            return Err(Violation(format!(
                "unpack wrote OD RAM byte {i} no mapped entry owns"
            )));
        }
    }
    const PATTERN: u8 = 0xA5;
    let mut packed = vec![PATTERN; len];
    plan.pack(&ram, &mut packed);
    let mut covered = vec![false; len * 8];
    for m in model {
        covered[m.image_bit..m.image_bit + m.bits].fill(true);
        let Some(at) = m.ram else { continue };
        // An entry whose RAM another mapped entry shares reads back the other's value.
        if (at..at + m.bits.div_ceil(8)).any(|i| owned[i] > 1) {
            continue;
        }
        for bit in m.image_bit..m.image_bit + m.bits {
            if get_bit(&image, bit) != get_bit(&packed, bit) {
                return Err(Violation(format!(
                    "pack(unpack(x)) differs at image bit {bit}"
                )));
            }
        }
    }
    let pattern = [PATTERN];
    for (bit, &c) in covered.iter().enumerate() {
        if !c && get_bit(&packed, bit) != get_bit(&pattern, bit % 8) {
            return Err(Violation(format!(
                "pack wrote image bit {bit}, which no entry maps"
            )));
        }
    }
    Ok(())
}
