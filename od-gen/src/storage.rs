//! The `[storage]` section → [`StorageRules`], checked against the resolved dictionary.
//!
//! Every rule must name something: a range that names no entry, a `not_stored` range that
//! names nothing the rule would store, a `stored_pdo_mappable` range without a PDO-mappable
//! parameter, an auto-stored entry that is not a stored parameter, a group subindex 1010h does
//! not have, a test entry that is not a readable unsigned integer of at most 32 bits are errors
//! naming the key (`storage.not_stored[2]`, `storage.group[0].ranges[1]`, ...), which the
//! caller turns into file and line. A process-data command (an entry with the role
//! controlword, modes of operation or a target) is never stored. The defaults of 1010h:n must be
//! the capabilities the firmware writes back after a command
//! ([`StorageRules::store_capabilities`]).

use crate::error::{fault, Fault, Invalid};
use crate::file::StorageFile;
use crate::model::*;
use crate::resolve::{parse_entry_ref, parse_index};

/// Resolves `[storage]` of profile `p` (whose objects are complete).
pub(crate) fn resolve(f: &StorageFile, p: &Profile) -> Result<StorageRules, Fault> {
    let mut rules = StorageRules {
        stored_pdo_mappable: ranges(&f.stored_pdo_mappable, "storage.stored_pdo_mappable", p)?,
        ..StorageRules::default()
    };
    stored_pdo_mappable(&rules, p)?;
    let not_stored = ranges(&f.not_stored, "storage.not_stored", p)?;
    for (i, r) in not_stored.iter().enumerate() {
        if !entries(p).any(|(o, e)| r.contains(o.index, e.subindex) && rules.stores(o, e)) {
            return Err(storage_fault(
                &format!("storage.not_stored[{i}]"),
                format!("`{r}` names no entry that would be stored (a RAM variable, writable, not PDO-mappable or in stored_pdo_mappable)"),
            ));
        }
    }
    rules.not_stored = not_stored;
    no_command_stored(&rules, p)?;
    rules.groups = groups(f, p)?;
    rules.auto_store = auto_store(f, &rules, p)?;
    rules.write_condition = f
        .write_condition
        .as_ref()
        .map(|c| -> Result<WriteCondition, Fault> {
            let key = "storage.write_condition";
            let test = entry_test(&c.entry, c.mask, c.value, key, p)?;
            let subindexes = command_subindexes(&c.subindexes, &format!("{key}.subindexes"), p)?;
            Ok(WriteCondition { test, subindexes })
        })
        .transpose()?;
    capabilities(&rules, p)?;
    Ok(rules)
}

fn storage_fault(key: &str, why: String) -> Fault {
    fault(key, Invalid::Storage(why))
}

/// Every (object, entry) of the dictionary.
fn entries(p: &Profile) -> impl Iterator<Item = (&Object, &Entry)> {
    p.objects
        .iter()
        .flat_map(|o| o.entries.iter().map(move |e| (o, e)))
}

/// `"0x2000-0x22FF"`, `"0x2300"` or `"0x2310:1"`.
fn parse_range(s: &str) -> Option<EntryRange> {
    if let Some((a, b)) = s.split_once('-') {
        let (first, last) = (parse_index(a)?, parse_index(b)?);
        return (first <= last).then_some(EntryRange {
            first,
            last,
            subindex: None,
        });
    }
    if s.contains(':') {
        let (index, subindex) = parse_entry_ref(s)?;
        return Some(EntryRange {
            first: index,
            last: index,
            subindex: Some(subindex),
        });
    }
    let index = parse_index(s)?;
    Some(EntryRange {
        first: index,
        last: index,
        subindex: None,
    })
}

/// The ranges of the list at `key`, each naming at least one entry of the dictionary.
fn ranges(list: &[String], key: &str, p: &Profile) -> Result<Vec<EntryRange>, Fault> {
    list.iter()
        .enumerate()
        .map(|(i, s)| {
            let k = format!("{key}[{i}]");
            let r = parse_range(s).ok_or_else(|| {
                storage_fault(
                    &k,
                    format!(
                        "`{s}` is not \"0xIIII\", \"0xIIII-0xJJJJ\" (first ≤ last) or \"0xIIII:S\""
                    ),
                )
            })?;
            if !entries(p).any(|(o, e)| r.contains(o.index, e.subindex)) {
                return Err(storage_fault(
                    &k,
                    format!("`{s}` names no entry of the dictionary"),
                ));
            }
            Ok(r)
        })
        .collect()
}

/// Each range of `stored_pdo_mappable` names a PDO-mappable writable RAM entry.
fn stored_pdo_mappable(rules: &StorageRules, p: &Profile) -> Result<(), Fault> {
    for (i, r) in rules.stored_pdo_mappable.iter().enumerate() {
        let named = entries(p).any(|(o, e)| {
            r.contains(o.index, e.subindex)
                && e.pdo != PdoMapping::No
                && rules.stores_without_exclusions(o, e)
        });
        if !named {
            return Err(storage_fault(
                &format!("storage.stored_pdo_mappable[{i}]"),
                format!(
                    "`{r}` names no PDO-mappable writable RAM entry (the others are stored anyway)"
                ),
            ));
        }
    }
    Ok(())
}

/// No process-data command (an entry with the role controlword, modes of operation or a
/// target) is stored: a range of `stored_pdo_mappable` that spans one needs it in `not_stored`.
fn no_command_stored(rules: &StorageRules, p: &Profile) -> Result<(), Fault> {
    let command = entries(p).find_map(|(o, e)| {
        e.role
            .filter(|r| r.is_command() && rules.stores(o, e))
            .map(|r| (o, e, r))
    });
    let Some((o, e, role)) = command else {
        return Ok(());
    };
    let key = match rules
        .stored_pdo_mappable
        .iter()
        .position(|r| r.contains(o.index, e.subindex))
    {
        Some(i) => format!("storage.stored_pdo_mappable[{i}]"),
        // Not PDO-mappable: the default rule stores it.
        None => format!("object[{:#06x}]", o.index),
    };
    Err(storage_fault(
        &key,
        format!(
            "{:#06x}:{:02x} is the process-data command `{}`, never a stored parameter (list it in storage.not_stored)",
            o.index,
            e.subindex,
            role.field()
        ),
    ))
}

/// The subindexes of object `index` from 1 on (empty when it does not exist).
fn command_subs(p: &Profile, index: u16) -> Option<Vec<u8>> {
    p.object(index).map(|o| {
        o.entries
            .iter()
            .map(|e| e.subindex)
            .filter(|s| *s >= ALL_PARAMETERS)
            .collect()
    })
}

/// A subindex list of 1010h/1011h commands: not empty, no repeats, each in 1010h and 1011h.
fn command_subindexes(list: &[u8], key: &str, p: &Profile) -> Result<Vec<u8>, Fault> {
    if list.is_empty() {
        return Err(storage_fault(key, "needs at least one subindex".into()));
    }
    for (i, s) in list.iter().enumerate() {
        command_subindex(*s, &format!("{key}[{i}]"), p)?;
        if list.get(..i).is_some_and(|before| before.contains(s)) {
            return Err(storage_fault(
                &format!("{key}[{i}]"),
                format!("subindex {s} is given twice"),
            ));
        }
    }
    Ok(list.to_vec())
}

/// `sub` is a subindex ≥ 1 of 1010h and of 1011h (where the profile has it).
fn command_subindex(sub: u8, key: &str, p: &Profile) -> Result<(), Fault> {
    for index in [STORE_PARAMETERS, RESTORE_DEFAULTS] {
        // 1010h must have it; 1011h, where the profile has one, too.
        let has = command_subs(p, index).map(|subs| subs.contains(&sub));
        let missing = matches!((index, has), (STORE_PARAMETERS, None) | (_, Some(false)));
        if missing {
            return Err(storage_fault(
                key,
                format!("{index:#06x} has no subindex {sub}"),
            ));
        }
    }
    Ok(())
}

/// `[[storage.group]]`, or the CiA 301 defaults for the subindexes 1010h has; every subindex
/// of 1010h from 2 on needs a group.
fn groups(f: &StorageFile, p: &Profile) -> Result<Vec<StorageGroup>, Fault> {
    let store_subs = command_subs(p, STORE_PARAMETERS).unwrap_or_default();
    let groups: Vec<StorageGroup> = if f.groups.is_empty() {
        DEFAULT_GROUPS
            .iter()
            .filter(|(sub, _, _)| store_subs.contains(sub))
            .map(|&(subindex, first, last)| StorageGroup {
                subindex,
                ranges: vec![EntryRange {
                    first,
                    last,
                    subindex: None,
                }],
            })
            .collect()
    } else {
        let mut out: Vec<StorageGroup> = Vec::new();
        for (i, g) in f.groups.iter().enumerate() {
            let key = format!("storage.group[{i}]");
            if g.subindex <= ALL_PARAMETERS {
                return Err(storage_fault(
                    &format!("{key}.subindex"),
                    format!("must be ≥ 2 (sub {ALL_PARAMETERS} always stores every parameter)"),
                ));
            }
            command_subindex(g.subindex, &format!("{key}.subindex"), p)?;
            if out.iter().any(|o| o.subindex == g.subindex) {
                return Err(storage_fault(
                    &format!("{key}.subindex"),
                    format!("subindex {} has two groups", g.subindex),
                ));
            }
            if g.ranges.is_empty() {
                return Err(storage_fault(
                    &format!("{key}.ranges"),
                    "needs at least one range".into(),
                ));
            }
            out.push(StorageGroup {
                subindex: g.subindex,
                ranges: ranges(&g.ranges, &format!("{key}.ranges"), p)?,
            });
        }
        out
    };
    if let Some(sub) = store_subs
        .iter()
        .find(|s| **s > ALL_PARAMETERS && !groups.iter().any(|g| g.subindex == **s))
    {
        return Err(storage_fault(
            "storage.group",
            format!(
                "{STORE_PARAMETERS:#06x}:{sub:02x} has no group: give every subindex from 2 on a [[storage.group]]"
            ),
        ));
    }
    Ok(groups)
}

/// `[[storage.auto_store]]`: every writable RAM entry named is a stored parameter, each rule
/// names one, no entry is named by two rules.
fn auto_store(f: &StorageFile, rules: &StorageRules, p: &Profile) -> Result<Vec<AutoStore>, Fault> {
    let mut out: Vec<AutoStore> = Vec::new();
    for (i, a) in f.auto_store.iter().enumerate() {
        let key = format!("storage.auto_store[{i}]");
        if a.entries.is_empty() {
            return Err(storage_fault(
                &format!("{key}.entries"),
                "needs at least one entry".into(),
            ));
        }
        let list = ranges(&a.entries, &format!("{key}.entries"), p)?;
        for (j, r) in list.iter().enumerate() {
            let k = format!("{key}.entries[{j}]");
            let writable = |e: &Entry| e.storage == Storage::Ram && e.access.writable();
            let named =
                || entries(p).filter(|(o, e)| r.contains(o.index, e.subindex) && writable(e));
            if let Some((o, e)) = named().find(|(o, e)| !rules.stores(o, e)) {
                return Err(storage_fault(
                    &k,
                    format!(
                        "{:#06x}:{:02x} is not a stored parameter (a PDO-mappable one needs storage.stored_pdo_mappable)",
                        o.index, e.subindex
                    ),
                ));
            }
            if named().next().is_none() {
                return Err(storage_fault(
                    &k,
                    format!("`{r}` names no stored parameter"),
                ));
            }
            if let Some(before) = out
                .iter()
                .position(|b| b.entries.iter().any(|x| x.overlaps(r)))
            {
                return Err(storage_fault(
                    &k,
                    format!("`{r}` overlaps storage.auto_store[{before}]"),
                ));
            }
        }
        let unless = a
            .unless
            .as_ref()
            .map(|t| entry_test(&t.entry, t.mask, t.value, &format!("{key}.unless"), p))
            .transpose()?;
        out.push(AutoStore {
            entries: list,
            unless,
        });
    }
    Ok(out)
}

/// `{ entry, mask, value }`: a readable unsigned entry of at most 32 bits; the mask (default
/// every bit of the entry) non-zero and inside the entry, the value inside the mask.
fn entry_test(
    entry: &str,
    mask: Option<u32>,
    value: u32,
    key: &str,
    p: &Profile,
) -> Result<EntryTest, Fault> {
    let k = format!("{key}.entry");
    let (index, subindex) = parse_entry_ref(entry)
        .ok_or_else(|| storage_fault(&k, format!("`{entry}` is not \"0xIIII:S\"")))?;
    let e = p.entry(index, subindex).ok_or_else(|| {
        storage_fault(
            &k,
            format!("{index:#06x}:{subindex:02x} does not exist in the dictionary"),
        )
    })?;
    let unsigned = matches!(
        e.data_type,
        DataType::Bool
            | DataType::Bit(_)
            | DataType::Usint
            | DataType::Uint
            | DataType::Uint24
            | DataType::Udint
    );
    if !unsigned || !e.access.readable() {
        return Err(storage_fault(
            &k,
            format!(
                "{index:#06x}:{subindex:02x} must be a readable unsigned entry of at most 32 bits"
            ),
        ));
    }
    let all = u32::MAX >> (u32::BITS - u32::from(e.bit_len).min(u32::BITS));
    let mask = mask.unwrap_or(all);
    if mask == 0 || mask & !all != 0 {
        return Err(storage_fault(
            &format!("{key}.mask"),
            format!(
                "{mask:#x} must be non-zero and inside the entry's {} bits",
                e.bit_len
            ),
        ));
    }
    if value & !mask != 0 {
        return Err(storage_fault(
            &format!("{key}.value"),
            format!("{value:#x} has bits outside the mask {mask:#x}"),
        ));
    }
    Ok(EntryTest {
        index,
        subindex,
        mask,
        value,
    })
}

/// The defaults of 1010h:n are what the firmware writes back after a command.
fn capabilities(rules: &StorageRules, p: &Profile) -> Result<(), Fault> {
    let Some(o) = p.object(STORE_PARAMETERS) else {
        return Ok(());
    };
    for e in o.entries.iter().filter(|e| e.subindex >= ALL_PARAMETERS) {
        let want = rules.store_capabilities(e.subindex);
        let mut b = [0u8; 4];
        for (d, s) in b.iter_mut().zip(&e.default) {
            *d = *s;
        }
        if e.default.is_empty() || u32::from_le_bytes(b) != want {
            let why = if want & SAVES_AUTONOMOUSLY != 0 {
                "bit 0 saves on command, bit 1 saves autonomously: the group holds entries of [[storage.auto_store]]"
            } else {
                "bit 0 saves on command; no entry of the group is in [[storage.auto_store]]"
            };
            return Err(storage_fault(
                &format!(
                    "object[{STORE_PARAMETERS:#06x}].entry[{:#04x}].default",
                    e.subindex
                ),
                format!("must be {want} (CiA 301 read value of 1010h: {why})"),
            ));
        }
    }
    Ok(())
}
