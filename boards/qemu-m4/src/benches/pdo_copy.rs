//! The PDO copy per mapped entry (issue 13: at most 20 instructions): `PdoPlan::unpack` of an
//! RxPDO image into the OD RAM and `PdoPlan::pack` of a TxPDO image from it, with mappings of
//! 1 to the most entries the `standard` profile takes, none adjacent in the OD RAM (each
//! entry its own copy: adjacent entries merge into one copy when the plan is built, so this is
//! the most a mapping of that many entries costs).
//!
//! Per entry: (the copy's cost − the cost of the same call with an empty mapping) / entries,
//! rounded up. The empty mapping's cost is the call's own (entry, the loops' set-up, return),
//! which a cycle pays once whatever it maps. The plan copies each run with one jump on its
//! copy width (decided when the plan is built): the mappings of 1 to the most entries cover
//! the object sizes 1, 2 and 4 bytes.

use core::hint::black_box;

use firmware::od::Dictionary;
use firmware::pdo::{Direction, PdoPlan, MAX_IMAGE};
use firmware::profiles::standard::{PROFILE, RAM_SIZE};

use super::map_max;
use crate::harness::{Cases, Harness};

/// Issue 13: the PDO copy, per mapped entry.
const PER_ENTRY_BUDGET: u32 = 20;
/// The mapping sizes measured, each direction; `usize::MAX`: the most the profile takes.
const SIZES: [usize; 5] = [1, 2, 4, 8, usize::MAX];
/// The inputs' labels, by direction and size (in [`SIZES`] order).
const LABELS: [[&str; SIZES.len()]; 2] = [
    [
        "unpack, 1 entry",
        "unpack, 2 entries",
        "unpack, 4 entries",
        "unpack, 8 entries",
        "unpack, the most entries",
    ],
    [
        "pack, 1 entry",
        "pack, 2 entries",
        "pack, 4 entries",
        "pack, 8 entries",
        "pack, the most entries",
    ],
];
const NAME: &str = "pdo-copy-per-entry";

/// The copy plan of `direction` with at most `most` entries mapped into its first PDO (none
/// adjacent), built from the OD at its defaults in `ram`, and how many entries it maps.
fn plan(ram: &mut [u8; RAM_SIZE], direction: Direction, most: usize) -> Option<(PdoPlan, usize)> {
    *ram = [0; RAM_SIZE];
    let mut od = Dictionary::new(&PROFILE.od, ram);
    od.load_defaults();
    let entries = map_max(&mut od, &PROFILE.od, direction, &[], None, most);
    let plan = PdoPlan::build(&od, direction).ok()?;
    (plan.entries() == entries && plan.copies() == entries).then_some((plan, entries))
}

/// Whether `plan` moves every mapped byte: an image of distinct bytes unpacked into the OD
/// RAM and packed back gives the same image.
fn copies_every_byte(plan: &PdoPlan, ram: &mut [u8; RAM_SIZE]) -> bool {
    let len = plan.byte_len();
    let mut image = [0u8; MAX_IMAGE];
    for (i, b) in image.iter_mut().enumerate() {
        // Distinct non-zero bytes (MAX_IMAGE < 255).
        *b = (i as u8).wrapping_add(1);
    }
    plan.unpack(&image, ram);
    let mut back = [0u8; MAX_IMAGE];
    plan.pack(ram, &mut back);
    len > 0 && image.get(..len) == back.get(..len)
}

/// Measures the copy of one direction with a mapping of at most `most` entries; its cost.
fn measure(h: &mut Harness, direction: Direction, most: usize) -> Option<(u32, usize)> {
    let mut ram = [0u8; RAM_SIZE];
    let ready = plan(&mut ram, direction, most).ok_or("the mapping gives no copy plan");
    let (plan, entries) = h.ready(NAME, ready)?;
    if most > 0 && !copies_every_byte(&plan, &mut ram) {
        h.fail(
            NAME,
            format_args!("the plan of {entries} entries loses bytes"),
        );
        return None;
    }
    let image = [0u8; MAX_IMAGE];
    let mut out = [0u8; MAX_IMAGE];
    let cost = match direction {
        Direction::Rx => h.measure(NAME, &mut || plan.unpack(black_box(&image), &mut ram))?,
        Direction::Tx => h.measure(NAME, &mut || plan.pack(black_box(&ram), &mut out))?,
    };
    Some((cost, entries))
}

/// Measures unpack and pack over the mapping sizes, per entry.
pub fn run(h: &mut Harness) {
    let mut cases = Cases::new(NAME);
    let mut most = [0usize; 2];
    for (d, direction) in [Direction::Rx, Direction::Tx].into_iter().enumerate() {
        let Some((empty, _)) = measure(h, direction, 0) else {
            return;
        };
        for (&size, &label) in SIZES.iter().zip(&LABELS[d]) {
            let Some((cost, entries)) = measure(h, direction, size) else {
                return;
            };
            if entries == 0 || (size != usize::MAX && entries != size) {
                h.fail(NAME, format_args!("{label}: {entries} entries mapped"));
                return;
            }
            // entries ≤ MAX_MAPPED_ENTRIES: fits a u32.
            let per_entry = cost.saturating_sub(empty).div_ceil(entries as u32);
            h.case(&mut cases, label, per_entry);
            most[d] = entries;
        }
    }
    let description = format_args!(
        "PdoPlan::unpack (RxPDO) and PdoPlan::pack (TxPDO), per mapped entry: (cost − cost \
         with an empty mapping) / entries, mappings of 1 to the most entries (RxPDO {}, TxPDO \
         {}) of the standard profile, none adjacent (each its own copy)",
        most[0], most[1]
    );
    h.report_cases(&cases, Some(PER_ENTRY_BUDGET), description);
}
