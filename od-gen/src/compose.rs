//! Profile composition: the layers a profile file is built from, merged into one TOML table
//! before it is read as a [`ProfileFile`](crate::file::ProfileFile).
//!
//! Shared content is written once (issue: OSD-G-E is a rebrand of SDV3-E, the two Yaskawa
//! variants differ only by the second axis, every drive shares the CiA402 definitions):
//!
//! 1. `extends = "<profile>"`: the base profile (first `<same folder>/<name>.toml`, then the
//!    built-in one) is the starting point; the file's keys override it ([`merge_profile`]).
//! 2. `[[object]] from = "<library>"`: the object's definition comes from a library in
//!    `profiles/common/` (e.g. `cia402.toml`), the keys written beside `from` override it.
//! 3. `omit = true` on an object, entry, PDO or alarm removes what a base or library declared.
//! 4. `[[replicate]] { first, last, offset }` copies objects to a second axis.
//!
//! Every layer's text is kept in [`Composed::sources`] so that an error found later can be
//! traced back to the line that wrote the value ([`crate::locate`]).

use std::path::{Path, PathBuf};

use toml::{Table, Value};

use crate::error::{Error, Invalid};

/// How deep `extends` may nest (a base of a base of a base ...).
const MAX_EXTENDS_DEPTH: usize = 8;

/// One text a profile was composed from.
#[derive(Debug, Clone)]
pub struct Source {
    /// Path or `builtin:<name>` / `library:<name>`.
    pub name: String,
    /// The TOML text.
    pub text: String,
}

/// A profile file with its bases, library objects and replicas merged in.
#[derive(Debug)]
pub struct Composed {
    /// The merged table, ready for [`crate::file::ProfileFile`].
    pub table: Table,
    /// The texts it came from: the profile first, then its bases, then the libraries used.
    pub sources: Vec<Source>,
}

/// The array-of-tables keys that merge element by element, and the key that identifies an
/// element. `decision` is appended; every other array is replaced as a whole.
const MERGE_BY: [(&str, &str); 6] = [
    ("adjusting", "object"),
    ("object", "index"),
    ("rxpdo", "index"),
    ("txpdo", "index"),
    ("dc_op_mode", "name"),
    ("alarm", "display"),
];

/// The key identifying an element of the array of tables `array` (`MERGE_BY`, and `sub` for
/// an object's `entry`): what merging, `omit` and error locations select elements by.
pub(crate) fn id_key(array: &str) -> Option<&'static str> {
    if array == "entry" {
        return Some("sub");
    }
    MERGE_BY
        .iter()
        .find(|(k, _)| *k == array)
        .map(|(_, id)| *id)
}

/// The libraries shipped with od-gen (`profiles/common/*.toml`): (name, text).
pub fn libraries() -> &'static [(&'static str, &'static str)] {
    crate::BUILTIN_LIBRARIES
}

fn invalid(file: &str, key: &str, error: Invalid) -> Error {
    Error::Invalid {
        file: file.to_string(),
        key: key.to_string(),
        line: None,
        error,
    }
}

fn parse_table(text: &str, source: &str) -> Result<Table, Error> {
    text.parse::<Table>().map_err(|e| Error::Parse {
        file: source.to_string(),
        message: e.to_string().trim_end().to_string(),
    })
}

/// Composes a profile text. `dir` is the folder of the file (for `extends`), `None` for a
/// built-in profile.
pub fn compose(text: &str, source: &str, dir: Option<&Path>) -> Result<Composed, Error> {
    let mut sources = Vec::new();
    let mut table = layered(text, source, dir, &mut sources, 0)?;
    expand_libraries(&mut table, source, &mut sources)?;
    remove_omitted(&mut table, source)?;
    replicate(&mut table, source)?;
    Ok(Composed { table, sources })
}

/// The file merged over its `extends` chain (libraries not yet expanded).
fn layered(
    text: &str,
    source: &str,
    dir: Option<&Path>,
    sources: &mut Vec<Source>,
    depth: usize,
) -> Result<Table, Error> {
    sources.push(Source {
        name: source.to_string(),
        text: text.to_string(),
    });
    let mut table = parse_table(text, source)?;
    if table.contains_key("library") {
        return Err(invalid(
            source,
            "library",
            Invalid::Value("this is a library (profiles/common), not a profile".into()),
        ));
    }
    let Some(base) = table.remove("extends") else {
        return Ok(table);
    };
    let Value::String(base) = base else {
        return Err(invalid(
            source,
            "extends",
            Invalid::Value("must be a profile name".into()),
        ));
    };
    for required in ["name", "description"] {
        if !table.contains_key(required) {
            return Err(invalid(source, required, Invalid::Missing(required)));
        }
    }
    if depth >= MAX_EXTENDS_DEPTH
        || sources[..sources.len() - 1]
            .iter()
            .any(|s| s.name == source)
    {
        return Err(invalid(
            source,
            "extends",
            Invalid::Value(format!(
                "`{base}`: the chain of bases is circular or deeper than {MAX_EXTENDS_DEPTH}"
            )),
        ));
    }
    let (base_source, base_text, base_dir) = find_base(&base, dir)
        .ok_or_else(|| invalid(source, "extends", Invalid::UnknownBase(base.clone())))?;
    let mut merged = layered(
        &base_text,
        &base_source,
        base_dir.as_deref(),
        sources,
        depth + 1,
    )?;
    merge_profile(&mut merged, table);
    Ok(merged)
}

/// `<dir>/<name>.toml` (either spelling of the name), else the built-in profile.
fn find_base(name: &str, dir: Option<&Path>) -> Option<(String, String, Option<PathBuf>)> {
    if let Some(dir) = dir {
        let path = crate::profile_file(dir, name);
        if let Some(text) = path.as_ref().and_then(|p| std::fs::read_to_string(p).ok()) {
            let path = path.map(|p| p.display().to_string()).unwrap_or_default();
            return Some((path, text, Some(dir.to_path_buf())));
        }
    }
    crate::builtin_text(name)
        .map(|(stem, text)| (format!("builtin:{stem}"), text.to_string(), None))
}

/// Merges a derived profile's table over its base.
pub fn merge_profile(base: &mut Table, derived: Table) {
    for (key, value) in derived {
        let merge_key = id_key(&key);
        match (base.get_mut(&key), value) {
            (Some(Value::Array(old)), Value::Array(new)) if key == "decision" => old.extend(new),
            (Some(Value::Array(old)), Value::Array(new)) if merge_key.is_some() => {
                merge_elements(old, new, merge_key.unwrap_or_default());
            }
            (Some(Value::Table(old)), Value::Table(new)) => merge_table(old, new),
            (_, value) => {
                base.insert(key, value);
            }
        }
    }
}

/// Merges the elements of an array of tables by their identifying key; elements without it or
/// with a new id are appended.
fn merge_elements(old: &mut Vec<Value>, new: Vec<Value>, id: &str) {
    for element in new {
        let existing = element
            .get(id)
            .and_then(|wanted| old.iter_mut().find(|o| o.get(id) == Some(wanted)));
        match (existing, element) {
            (Some(Value::Table(o)), Value::Table(n)) => merge_object(o, n),
            (_, element) => old.push(element),
        }
    }
}

/// Merges an object (or PDO, alarm, op mode) table: keys override, `entry` merges by `sub`.
fn merge_object(old: &mut Table, new: Table) {
    for (key, value) in new {
        match (old.get_mut(&key), value) {
            (Some(Value::Array(o)), Value::Array(n)) if key == "entry" => {
                merge_elements(o, n, "sub")
            }
            (_, value) => {
                old.insert(key, value);
            }
        }
    }
}

/// Merges nested plain tables (`[device]`, `[sync]`, `[mailbox.coe]`, ...) key by key.
fn merge_table(old: &mut Table, new: Table) {
    for (key, value) in new {
        match (old.get_mut(&key), value) {
            (Some(Value::Table(o)), Value::Table(n)) => merge_table(o, n),
            (_, value) => {
                old.insert(key, value);
            }
        }
    }
}

fn object_key(object: &Table) -> String {
    match object.get("index").and_then(Value::as_integer) {
        Some(i) => format!("object[{i:#06x}]"),
        None => "object".into(),
    }
}

/// Replaces every `from = "<library>"` object by the library's definition with the object's
/// own keys merged over it.
fn expand_libraries(
    table: &mut Table,
    source: &str,
    sources: &mut Vec<Source>,
) -> Result<(), Error> {
    let Some(Value::Array(objects)) = table.get_mut("object") else {
        return Ok(());
    };
    let mut parsed: Vec<(&str, Table)> = Vec::new();
    for object in objects.iter_mut() {
        let Value::Table(o) = object else { continue };
        let Some(from) = o.remove("from") else {
            continue;
        };
        let key = format!("{}.from", object_key(o));
        let Value::String(lib) = from else {
            return Err(invalid(
                source,
                &key,
                Invalid::Value("must be a library name".into()),
            ));
        };
        let Some((lib_name, lib_text)) = libraries().iter().find(|(n, _)| *n == lib) else {
            let names: Vec<&str> = libraries().iter().map(|(n, _)| *n).collect();
            return Err(invalid(
                source,
                &key,
                Invalid::Value(format!(
                    "unknown library `{lib}` (libraries: {})",
                    names.join(", ")
                )),
            ));
        };
        if !parsed.iter().any(|(n, _)| n == lib_name) {
            let lib_source = format!("library:{lib_name}");
            let lib_table = parse_table(lib_text, &lib_source)?;
            sources.push(Source {
                name: lib_source,
                text: lib_text.to_string(),
            });
            parsed.push((lib_name, lib_table));
        }
        let index = o.get("index").cloned();
        let definition = parsed
            .iter()
            .find(|(n, _)| n == lib_name)
            .and_then(|(_, t)| t.get("object"))
            .and_then(Value::as_array)
            .and_then(|objs| objs.iter().find(|d| d.get("index") == index.as_ref()))
            .and_then(Value::as_table)
            .cloned()
            .ok_or_else(|| {
                invalid(
                    source,
                    &key,
                    Invalid::Value(format!("library `{lib}` does not define this object")),
                )
            })?;
        let own = std::mem::take(o);
        *o = definition;
        merge_object(o, own);
    }
    Ok(())
}

fn is_omitted(v: &Value) -> bool {
    v.get("omit").and_then(Value::as_bool) == Some(true)
}

/// The first `omit` that is not a boolean, as a key path.
fn bad_omit(table: &Table) -> Option<String> {
    let not_bool = |v: &Value| v.get("omit").is_some_and(|o| !o.is_bool());
    for (key, id) in MERGE_BY {
        for e in table
            .get(key)
            .and_then(Value::as_array)
            .into_iter()
            .flatten()
        {
            let at = match e.get(id) {
                Some(Value::Integer(i)) => format!("{key}[{i:#06x}]"),
                Some(Value::String(s)) => format!("{key}[{s}]"),
                _ => key.to_string(),
            };
            if not_bool(e) {
                return Some(format!("{at}.omit"));
            }
            for entry in e
                .get("entry")
                .and_then(Value::as_array)
                .into_iter()
                .flatten()
            {
                if not_bool(entry) {
                    let sub = entry.get("sub").and_then(Value::as_integer).unwrap_or(0);
                    return Some(format!("{at}.entry[{sub:#04x}].omit"));
                }
            }
        }
    }
    None
}

/// Removes elements marked `omit = true` (objects, their entries, PDOs, alarms, op modes).
fn remove_omitted(table: &mut Table, source: &str) -> Result<(), Error> {
    if let Some(key) = bad_omit(table) {
        return Err(invalid(
            source,
            &key,
            Invalid::Value("must be true or false".into()),
        ));
    }
    for (key, _) in MERGE_BY {
        if let Some(Value::Array(elements)) = table.get_mut(key) {
            elements.retain(|e| !is_omitted(e));
            for t in elements.iter_mut().filter_map(Value::as_table_mut) {
                t.remove("omit");
                if let Some(Value::Array(entries)) = t.get_mut("entry") {
                    entries.retain(|e| !is_omitted(e));
                    for entry in entries.iter_mut().filter_map(Value::as_table_mut) {
                        entry.remove("omit");
                    }
                }
            }
        }
    }
    Ok(())
}

/// Removes the role of a replicated object or entry, keeping its storage in RAM if the role gave
/// it that (an explicit `storage` stays).
fn unbind_role(t: &mut Table) {
    if t.remove("role").is_some() && !t.contains_key("storage") {
        t.insert("storage".into(), Value::String("ram".into()));
    }
}

fn int(t: &Table, key: &str) -> Option<i64> {
    t.get(key).and_then(Value::as_integer)
}

/// `[[replicate]] { first, last, offset }`: copies of the objects in `first..=last` at
/// `index + offset`, without roles (the firmware finds a further axis' variables through the
/// offsets, `Profile::axis_index`). An
/// object declared at a target index is merged over the copy (it states what differs on the
/// second axis). The `[[replicate]]` tables stay in the profile (documentation).
fn replicate(table: &mut Table, source: &str) -> Result<(), Error> {
    let Some(Value::Array(rules)) = table.get("replicate") else {
        return Ok(());
    };
    let mut copies = Vec::new();
    for (i, rule) in rules.iter().enumerate() {
        let key = format!("replicate[{i}]");
        let rule = rule
            .as_table()
            .ok_or_else(|| invalid(source, &key, Invalid::Value("must be a table".into())))?;
        let (Some(first), Some(last), Some(offset)) =
            (int(rule, "first"), int(rule, "last"), int(rule, "offset"))
        else {
            return Err(invalid(
                source,
                &key,
                Invalid::Missing("first, last, offset"),
            ));
        };
        let objects = table.get("object").and_then(Value::as_array);
        for object in objects.into_iter().flatten().filter_map(Value::as_table) {
            let Some(index) = int(object, "index") else {
                continue;
            };
            if !(first..=last).contains(&index) {
                continue;
            }
            let target = index + offset;
            if !(0..=0xFFFF).contains(&target) {
                return Err(invalid(
                    source,
                    &key,
                    Invalid::Value(format!("{index:#06x} + {offset:#x} is not an object index")),
                ));
            }
            let mut copy = object.clone();
            copy.insert("index".into(), Value::Integer(target));
            // The role stays with the first axis; the firmware binds a further axis to the copy
            // through the rule's offset, so the copy of a role's entry is a RAM variable too.
            unbind_role(&mut copy);
            if let Some(Value::Array(entries)) = copy.get_mut("entry") {
                for e in entries.iter_mut().filter_map(Value::as_table_mut) {
                    unbind_role(e);
                }
            }
            copies.push(Value::Table(copy));
        }
    }
    if let Some(Value::Array(objects)) = table.get_mut("object") {
        for copy in copies {
            let target = copy.get("index").cloned();
            match objects
                .iter_mut()
                .find(|o| o.get("index") == target.as_ref())
            {
                Some(Value::Table(explicit)) => {
                    let own = std::mem::take(explicit);
                    if let Value::Table(c) = copy {
                        *explicit = c;
                    }
                    merge_object(explicit, own);
                }
                _ => objects.push(copy),
            }
        }
    }
    Ok(())
}
