//! Which entries are stored parameters (1010h/1011h, [`crate::params`]): the one rule for the
//! parameter storage, SDO information ("backup", list type 4, ObjAccess bit 8) and, through a
//! compile-time assertion in the generated dictionary, od-gen's ESI `Flags/Backup`.

use super::index::{RESTORE_DEFAULTS, SM_INPUT_PARAMETER, SM_OUTPUT_PARAMETER, STORE_PARAMETERS};
use super::model::{Entry, Object, PdoMappable, Value};

/// Objects never stored: the store/restore commands themselves and the SM parameters the stack
/// maintains from the active synchronisation (ETG.1020 §5.1).
pub const NOT_STORED: [u16; 4] = [
    STORE_PARAMETERS,
    RESTORE_DEFAULTS,
    SM_OUTPUT_PARAMETER,
    SM_INPUT_PARAMETER,
];

/// Whether `entry` of `object` is a stored parameter (see `crate::params`: RAM variable, writable, not PDO-mappable, not in [`NOT_STORED`]). The one
/// rule for "backup" entries too: SDO information list type 4 and ObjAccess bit 8 use it, and
/// the generated dictionary asserts at compile time that od-gen's ESI `Flags/Backup` agree.
pub const fn is_storable(object: &Object, entry: &Entry) -> bool {
    matches!(entry.value, Value::Ram(_))
        && entry.access.writable()
        && matches!(entry.pdo, PdoMappable::No)
        && !is_not_stored(object.index)
}

/// Whether `index` is one of [`NOT_STORED`].
const fn is_not_stored(index: u16) -> bool {
    let mut i = 0;
    while i < NOT_STORED.len() {
        if NOT_STORED[i] == index {
            return true;
        }
        i += 1;
    }
    false
}
