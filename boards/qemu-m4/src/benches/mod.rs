//! The benchmarks: each module sets up the real firmware code (with the real generated
//! `standard` profile, or the motor control with the simulated servo's configuration), brings it
//! to a steady state, checks that the operation does what it should, and measures it with the
//! [`Harness`].
//!
//! To add one, write a module with a `run(&mut Harness)` and list it in [`ALL`]; budgets come
//! from DESIGN.md §6.

mod board_control;
mod board_esc_event;
mod board_sync0;
mod motor;
mod pdo_copy;
mod process_data;
mod sdo;
mod sync0_handler;
mod sync0_profiles;
mod sync0_with_axis;
mod units;

use firmware::od::{Dictionary, Object, Profile, Value};
use firmware::pdo::{Direction, MAX_IMAGE};
use firmware::profiles::standard::{PROFILE, RAM_SIZE};

use crate::harness::Harness;

/// Modes of operation 6060h: cyclic synchronous position mode (IEC 61800-7-201).
const MODE_CYCLIC_SYNC_POSITION: i8 = 8;
/// Target position 607Ah the master sends; any non-zero value, so that its echo is visible.
const TARGET_POSITION: i32 = 0x0012_3456;

/// Every benchmark, in report order, each with a cycle estimate (traced in the harness's
/// `trace` mode: a line per executed instruction, so setups must stay short; the longest,
/// every profile brought to OP with running axes in `sync0_profiles`, is some 45 million).
pub const ALL: &[fn(&mut Harness)] = &[
    process_data::run,
    pdo_copy::run,
    sync0_handler::run,
    sync0_with_axis::run,
    sdo::run,
    units::run,
    motor::run,
    board_control::run,
    board_sync0::run,
    board_esc_event::run,
    sync0_profiles::run,
];

/// Reads `N` bytes of the OD RAM at the offset of an application variable.
fn read<const N: usize>(ram: &[u8], at: Option<u16>) -> Option<[u8; N]> {
    let at = usize::from(at?);
    ram.get(at..at + N)?.try_into().ok()
}

/// Writes `bytes` into the OD RAM at the offset of an application variable; `false` if the
/// profile has no such variable or it lies outside `ram`.
fn write(ram: &mut [u8], at: Option<u16>, bytes: &[u8]) -> bool {
    let Some(at) = at.map(usize::from) else {
        return false;
    };
    match ram.get_mut(at..at + bytes.len()) {
        Some(dst) => {
            dst.copy_from_slice(bytes);
            true
        }
        None => false,
    }
}

/// The variables of the standard profile's (one) axis.
fn axis_vars() -> Option<&'static firmware::profile::AppVars> {
    PROFILE.axes.first()
}

/// The master's side of the default RxPDO objects of the standard profile as an OD RAM image:
/// `controlword`, the target position and CSP. Packing it with an Rx copy plan gives the SM2
/// image, so no image layout is assumed. `None` if the profile lacks one of the variables.
fn master_outputs(controlword: u16) -> Option<[u8; RAM_SIZE]> {
    master_outputs_for(controlword, TARGET_POSITION, MODE_CYCLIC_SYNC_POSITION)
}

/// [`master_outputs`] with any target position 607Ah and mode 6060h.
fn master_outputs_for(controlword: u16, target_position: i32, mode: i8) -> Option<[u8; RAM_SIZE]> {
    let vars = axis_vars()?;
    let mut master = [0; RAM_SIZE];
    let ok = write(&mut master, vars.controlword, &controlword.to_le_bytes())
        && write(
            &mut master,
            vars.target_position,
            &target_position.to_le_bytes(),
        )
        && write(&mut master, vars.modes_of_operation, &mode.to_le_bytes());
    ok.then_some(master)
}

/// The mapping object a benchmark fills: the first RxPDO (1600h) or TxPDO (1A00h).
fn first_mapping(direction: Direction) -> u16 {
    match direction {
        Direction::Rx => 0x1600,
        Direction::Tx => 0x1A00,
    }
}

/// The OD entry (index, subindex, bit length) whose value lives at OD RAM offset `at`.
fn entry_at(profile: &Profile, at: Option<u16>) -> Option<(u16, u8, u16)> {
    let at = at?;
    profile.objects.iter().find_map(|o| {
        o.entries.iter().find_map(|e| {
            matches!(e.value, Value::Ram(a) if a == at).then_some((o.index, e.subindex, e.bit_len))
        })
    })
}

/// Maps into the first PDO of `direction` the entries `first` (e.g. the controlword a master
/// needs), then as many other mappable OD RAM entries of `profile` as its subindices, the
/// process image and the profile's `max_process_bytes` allow (`exclude` left out), from the
/// highest index down so that no two are adjacent in the OD RAM in mapping order (each is its
/// own copy), at most `most` of them; returns how many.
fn map_max(
    od: &mut Dictionary<'_>,
    profile: &Profile,
    direction: Direction,
    first: &[(u16, u8, u16)],
    exclude: Option<(u16, u8)>,
    most: usize,
) -> usize {
    let limit_bits = 8 * usize::from(profile.device.max_process_bytes).min(MAX_IMAGE);
    let fill = Fill {
        direction,
        mapping: first_mapping(direction),
        first,
        taken: exclude.as_slice(),
    };
    fill_mapping(od, profile, &fill, most, limit_bits).0
}

/// What [`fill_mapping`] maps.
struct Fill<'a> {
    direction: Direction,
    /// The mapping object (e.g. 1600h).
    mapping: u16,
    /// The entries that come first (index, subindex, bit length).
    first: &'a [(u16, u8, u16)],
    /// Entries left out (mapped elsewhere already).
    taken: &'a [(u16, u8)],
}

/// Maps into `fill.mapping` the entries `fill.first`, then as many other mappable OD RAM
/// entries of `profile` (of `fill.direction`, none of `fill.taken`) as its subindices and
/// `bits_left` allow, from the highest index down (see [`map_max`]), at most `most`; returns
/// how many and their bits.
fn fill_mapping(
    od: &mut Dictionary<'_>,
    profile: &Profile,
    fill: &Fill<'_>,
    most: usize,
    bits_left: usize,
) -> (usize, usize) {
    let Some(mapping) = od.object(fill.mapping) else {
        return (0, 0);
    };
    let slots = mapping.entries.len().saturating_sub(1).min(most);
    let candidates = profile.objects.iter().rev().flat_map(|o| {
        o.entries.iter().rev().filter_map(move |e| {
            let key = (o.index, e.subindex);
            let mappable = match fill.direction {
                Direction::Rx => e.pdo.rx(),
                Direction::Tx => e.pdo.tx(),
            } && matches!(e.value, Value::Ram(_))
                && !fill.taken.contains(&key)
                && !fill.first.iter().any(|&(i, s, _)| (i, s) == key);
            mappable.then_some((o.index, e.subindex, e.bit_len))
        })
    });
    let candidates = fill.first.iter().copied().chain(candidates);
    let (mut mapped, mut bits) = (0usize, 0usize);
    let _ = set(od, mapping, 0, 0);
    for (index, subindex, bit_len) in candidates {
        if mapped == slots || bits + usize::from(bit_len) > bits_left {
            break;
        }
        let value = (u32::from(index) << 16) | (u32::from(subindex) << 8) | u32::from(bit_len);
        // Sub 1.. of the mapping: `mapped` < `slots` ≤ 254.
        if set(od, mapping, mapped as u8 + 1, value) {
            mapped += 1;
            bits += usize::from(bit_len);
        }
    }
    let _ = set(od, mapping, 0, mapped as u32);
    (mapped, bits)
}

/// Writes `value` to `object`'s `subindex` (its own width); whether it was stored.
fn set(od: &mut Dictionary<'_>, object: &Object, subindex: u8, value: u32) -> bool {
    match object.entry(subindex) {
        Some(e) => od
            .set_value(
                e,
                value.to_le_bytes().get(..e.byte_len()).unwrap_or_default(),
            )
            .is_ok(),
        None => false,
    }
}
