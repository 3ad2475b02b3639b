//! Which entries are stored parameters (1010h/1011h, [`crate::params`]) and the rest of a
//! profile's storage rules, as data the profile gives (od-gen's `[storage]` section) and the
//! stack executes without knowing the device.
//!
//! [`is_storable`] is the one rule for the parameter storage, SDO information ("backup", list
//! type 4, ObjAccess bit 8) and, through a compile-time assertion in the generated dictionary,
//! od-gen's ESI `Flags/Backup`. [`StorageRules`] carries what a profile adds to it: PDO-mappable
//! parameters that are stored nonetheless, writable entries that are not, the entries each
//! 1010h/1011h subindex selects, the entries an SDO download stores at once and a condition on
//! the device state for some 1010h/1011h subindexes.

use super::index::sm_parameter::SUB_SHIFT_TIME;
use super::index::{RESTORE_DEFAULTS, SM_INPUT_PARAMETER, SM_OUTPUT_PARAMETER, STORE_PARAMETERS};
use super::model::{Entry, Object, PdoMappable, Value};
use super::store::Dictionary;

/// Objects never stored whatever the profile says: the store/restore commands themselves and
/// the SM parameters the stack maintains from the active synchronisation (ETG.1020 §5.1).
pub const NOT_STORED: [u16; 4] = [
    STORE_PARAMETERS,
    RESTORE_DEFAULTS,
    SM_OUTPUT_PARAMETER,
    SM_INPUT_PARAMETER,
];

/// The one SM parameter entry that is a stored parameter where the master may write it: the
/// input shift time 1C33h:03 (a profile's `[sync] input_shift`), which the stack never
/// overwrites (the Σ-V-SD keeps it in EEPROM, §4.4 (3)).
pub const STORED_SM_PARAMETER: (u16, u8) = (SM_INPUT_PARAMETER, SUB_SHIFT_TIME);

/// A set of entries a storage rule names: every entry of the objects `first..=last`, or, with
/// `subindex`, that one entry of object `first` (od-gen writes `first == last` then). Profile
/// spelling: `"0x2000-0x22FF"`, `"0x2300"`, `"0x2310:1"`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EntryRange {
    /// First object index.
    pub first: u16,
    /// Last object index (inclusive).
    pub last: u16,
    /// The one subindex named; `None`: every entry of the objects.
    pub subindex: Option<u8>,
}

impl EntryRange {
    /// Every entry of the objects `first..=last`.
    pub const fn objects(first: u16, last: u16) -> Self {
        Self {
            first,
            last,
            subindex: None,
        }
    }

    /// The one entry `index:subindex`.
    pub const fn entry(index: u16, subindex: u8) -> Self {
        Self {
            first: index,
            last: index,
            subindex: Some(subindex),
        }
    }

    /// Whether the set names entries of object `index` (all of them, or the one subindex).
    pub const fn touches_object(&self, index: u16) -> bool {
        self.first <= index && index <= self.last
    }

    /// Whether `index:subindex` is in the set.
    pub const fn contains(&self, index: u16, subindex: u8) -> bool {
        let in_objects = self.touches_object(index);
        match self.subindex {
            Some(s) => in_objects && s == subindex,
            None => in_objects,
        }
    }

    /// Whether an entry address can be in both sets (the object ranges intersect and the
    /// subindexes, where both name one, are equal).
    pub const fn overlaps(&self, other: &Self) -> bool {
        let objects = self.first <= other.last && other.first <= self.last;
        match (self.subindex, other.subindex) {
            (Some(a), Some(b)) => objects && a == b,
            _ => objects,
        }
    }
}

/// Whether one of `ranges` holds `index:subindex`.
pub const fn any_contains(ranges: &[EntryRange], index: u16, subindex: u8) -> bool {
    let mut rest = ranges;
    while let [range, tail @ ..] = rest {
        if range.contains(index, subindex) {
            return true;
        }
        rest = tail;
    }
    false
}

/// Whether a range of `a` overlaps a range of `b`.
pub const fn any_overlaps(a: &[EntryRange], b: &[EntryRange]) -> bool {
    let mut rest_a = a;
    while let [x, tail_a @ ..] = rest_a {
        let mut rest_b = b;
        while let [y, tail_b @ ..] = rest_b {
            if x.overlaps(y) {
                return true;
            }
            rest_b = tail_b;
        }
        rest_a = tail_a;
    }
    false
}

/// A test of the current value of an unsigned entry of at most 32 bits in the OD:
/// `(value & mask) == expected`. The stack reads the entry, it does not know what it means
/// (e.g. the CiA402 statusword of a drive).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EntryTest {
    /// Index of the entry read.
    pub index: u16,
    /// Its subindex.
    pub subindex: u8,
    /// The bits compared.
    pub mask: u32,
    /// Their expected value (inside `mask`).
    pub value: u32,
}

impl EntryTest {
    /// Whether the test holds on the current OD; `false` when the entry cannot be read (od-gen
    /// checks that it exists, so this only guards a layout error).
    pub fn holds(&self, od: &Dictionary<'_>) -> bool {
        od.read_u32(self.index, self.subindex)
            .is_some_and(|v| v & self.mask == self.value)
    }
}

/// What one 1010h/1011h subindex (2 and above; 1 is always every parameter) stores and
/// restores.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StorageGroup {
    /// The subindex of 1010h and 1011h.
    pub subindex: u8,
    /// The entries of the group (only the stored ones count).
    pub ranges: &'static [EntryRange],
}

/// Entries an SDO download stores at once, without a 1010h command (a drive that saves
/// parameters to its EEPROM as they are written). A PDO write never stores.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AutoStore {
    /// The entries.
    pub entries: &'static [EntryRange],
    /// While this test holds (on the values after the download), the download is not stored
    /// (e.g. a parameter "do not save SDO writes").
    pub unless: Option<EntryTest>,
}

/// A condition for writing some subindexes of 1010h and 1011h (e.g. only in the drive's
/// "Switch On Disabled" state); otherwise the command is refused with 0x0800_0022 and nothing
/// is stored or restored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct WriteCondition {
    /// What must hold.
    pub test: EntryTest,
    /// The 1010h/1011h subindexes it applies to.
    pub subindexes: &'static [u8],
}

impl WriteCondition {
    /// Whether it applies to subindex `subindex`.
    pub fn applies_to(&self, subindex: u8) -> bool {
        self.subindexes.contains(&subindex)
    }
}

/// A profile's storage rules (od-gen `[storage]`; `Profile::storage`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StorageRules {
    /// PDO-mappable entries that are stored (parameters a master may also map), where the
    /// rule would leave them out.
    pub stored_pdo_mappable: &'static [EntryRange],
    /// Writable entries that are not stored, where the rule would store them.
    pub not_stored: &'static [EntryRange],
    /// The groups of 1010h/1011h subindex 2 and above (od-gen writes the CiA 301 default scopes
    /// when the profile gives none).
    pub groups: &'static [StorageGroup],
    /// Entries an SDO download stores at once.
    pub auto_store: &'static [AutoStore],
    /// The condition on some 1010h/1011h subindexes.
    pub write_condition: Option<WriteCondition>,
}

impl StorageRules {
    /// No rule beyond [`is_storable`]'s own and no group but "all" (sub 1).
    pub const NONE: Self = Self {
        stored_pdo_mappable: &[],
        not_stored: &[],
        groups: &[],
        auto_store: &[],
        write_condition: None,
    };

    /// The group of 1010h/1011h subindex `subindex` (2 and above).
    pub fn group(&self, subindex: u8) -> Option<&'static StorageGroup> {
        self.groups.iter().find(|g| g.subindex == subindex)
    }

    /// Whether one of the auto-store rules names an entry of `ranges`.
    pub const fn auto_stores_in(&self, ranges: &[EntryRange]) -> bool {
        let mut rest = self.auto_store;
        while let [rule, tail @ ..] = rest {
            if any_overlaps(rule.entries, ranges) {
                return true;
            }
            rest = tail;
        }
        false
    }

    /// The auto-store rule that names `index:subindex`, if any (whether it stores now depends
    /// on its [`AutoStore::unless`]).
    pub fn auto_store_of(&self, index: u16, subindex: u8) -> Option<&'static AutoStore> {
        self.auto_store
            .iter()
            .find(|a| any_contains(a.entries, index, subindex))
    }
}

/// Whether `entry` of `object` is a stored parameter under `rules` (see `crate::params`): an OD
/// RAM variable, writable in some state, not in [`NOT_STORED`], not named by
/// [`StorageRules::not_stored`], and either not PDO-mappable or named by
/// [`StorageRules::stored_pdo_mappable`]. The one rule for "backup" entries too: SDO information
/// list type 4 and ObjAccess bit 8 use it, and the generated dictionary asserts at compile time
/// that od-gen's ESI `Flags/Backup` agree.
pub const fn is_storable(rules: &StorageRules, object: &Object, entry: &Entry) -> bool {
    let (index, subindex) = (object.index, entry.subindex);
    let parameter = matches!(entry.pdo, PdoMappable::No)
        || any_contains(rules.stored_pdo_mappable, index, subindex);
    matches!(entry.value, Value::Ram(_))
        && entry.access.writable()
        && parameter
        && (!is_not_stored(index) || is_stored_sm_parameter(index, subindex))
        && !any_contains(rules.not_stored, index, subindex)
}

/// Whether `index:subindex` is [`STORED_SM_PARAMETER`].
const fn is_stored_sm_parameter(index: u16, subindex: u8) -> bool {
    index == STORED_SM_PARAMETER.0 && subindex == STORED_SM_PARAMETER.1
}

/// Whether `index` is one of [`NOT_STORED`].
const fn is_not_stored(index: u16) -> bool {
    let mut rest: &[u16] = &NOT_STORED;
    while let [first, tail @ ..] = rest {
        if *first == index {
            return true;
        }
        rest = tail;
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_object_range_holds_every_subindex_an_entry_range_one() {
        let r = EntryRange::objects(0x2000, 0x22FF);
        assert!(r.contains(0x2000, 0) && r.contains(0x22FF, 9));
        assert!(!r.contains(0x2300, 0) && !r.contains(0x1FFF, 1));
        let e = EntryRange::entry(0x2310, 1);
        assert!(e.contains(0x2310, 1));
        assert!(!e.contains(0x2310, 2) && !e.contains(0x2311, 1));
    }

    #[test]
    fn ranges_overlap_when_an_entry_can_be_in_both() {
        let pn = EntryRange::objects(0x2000, 0x2005);
        assert!(pn.overlaps(&EntryRange::objects(0x2005, 0x5FFF)));
        assert!(pn.overlaps(&EntryRange::entry(0x2000, 0x2F)));
        assert!(!pn.overlaps(&EntryRange::objects(0x2006, 0x22FF)));
        let a = EntryRange::entry(0x10F1, 2);
        assert!(!a.overlaps(&EntryRange::entry(0x10F1, 1)));
        assert!(a.overlaps(&EntryRange::objects(0x1000, 0x1FFF)));
    }
}
