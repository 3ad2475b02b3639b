//! The `[storage]` section: parsed into `model::StorageRules`, and every mistake rejected with
//! the key (and line) at fault.

use od_gen::model::{EntryRange, EntryTest, SAVES_AUTONOMOUSLY, SAVES_ON_COMMAND};
use od_gen::{Error, Invalid, Profile};

const STANDARD: &str = include_str!("../profiles/standard.toml");

/// A PDO-mappable parameter added to the standard profile (it has none that is not a command).
const MAPPABLE: &str = "[[object]]\nindex = 0x2F10\nname = \"Mappable parameter\"\ntype = \"UDINT\"\naccess = \"rw\"\npdo = \"rx\"\n";

/// 1010h:01 and :04 of the standard profile with `default`.
fn store_defaults(sub1: u32, sub4: u32) -> String {
    let entry = |name: &str, v: u32| {
        (
            format!("name = \"{name}\"\ntype = \"UDINT\"\naccess = \"rw\"\ndefault = 1 "),
            format!("name = \"{name}\"\ntype = \"UDINT\"\naccess = \"rw\"\ndefault = {v} "),
        )
    };
    let mut text = STANDARD.to_string();
    for (from, to) in [
        entry("Save all parameters", sub1),
        entry("Save manufacturer parameters", sub4),
    ] {
        assert!(text.contains(&from), "test setup: `{from}`");
        text = text.replacen(&from, &to, 1);
    }
    text
}

fn profile(text: &str) -> Profile {
    od_gen::parse(text, "s.toml").unwrap_or_else(|e| panic!("{e}"))
}

/// `base` with its own `[storage]` section (the standard profile's) replaced by `storage`.
fn with_storage(base: &str, storage: &str) -> String {
    let base = match base.find("\n[storage]\n") {
        Some(start) => {
            let end = base[start + 1..]
                .find("\n\n")
                .map_or(base.len(), |e| start + 1 + e);
            format!("{}{}", &base[..start], &base[end..])
        }
        None => base.to_string(),
    };
    format!("{base}\n{MAPPABLE}\n{storage}\n")
}

/// The key and error of the validation error `text` gives.
fn invalid(text: &str) -> (String, Invalid) {
    match od_gen::parse(text, "s.toml") {
        Err(Error::Invalid { key, error, .. }) => (key, error),
        Err(e) => panic!("expected a validation error, got: {e}"),
        Ok(_) => panic!("expected a validation error, the profile loaded"),
    }
}

/// `invalid` of the standard profile (with 2F10h) plus `storage`; checks the key and that the
/// message holds `says`.
fn rejected(storage: &str, key: &str, says: &str) {
    let (k, error) = invalid(&with_storage(STANDARD, storage));
    assert!(matches!(error, Invalid::Storage(_)), "{error:?}");
    let msg = error.to_string();
    assert_eq!(k, key, "{msg}");
    assert!(msg.contains(says), "`{msg}` lacks `{says}`");
}

#[test]
fn without_storage_the_cia_301_groups_and_default_rule_apply() {
    let p = od_gen::builtin("standard").unwrap();
    let groups: Vec<(u8, Vec<EntryRange>)> = p
        .storage
        .groups
        .iter()
        .map(|g| (g.subindex, g.ranges.clone()))
        .collect();
    let objects = |first, last| EntryRange {
        first,
        last,
        subindex: None,
    };
    assert_eq!(
        groups,
        [
            (2, vec![objects(0x1000, 0x1FFF)]),
            (3, vec![objects(0x6000, 0x9FFF)]),
            (4, vec![objects(0x2000, 0x5FFF)]),
        ]
    );
    assert!(p.storage.auto_store.is_empty() && p.storage.write_condition.is_none());
    for sub in 1..=4 {
        assert_eq!(p.storage.store_capabilities(sub), SAVES_ON_COMMAND);
    }
}

#[test]
fn a_storage_section_is_resolved_into_the_rules() {
    let p = profile(&with_storage(
        &store_defaults(3, 3),
        r#"[storage]
stored_pdo_mappable = ["0x2F10"]
not_stored = ["0x2F00", "0x10F1:1"]

[[storage.group]]
subindex = 2
ranges = ["0x1000-0x1FFF"]

[[storage.group]]
subindex = 3
ranges = ["0x6000-0x6FFF"]

[[storage.group]]
subindex = 4
ranges = ["0x2000-0x2FFF"]

[[storage.auto_store]]
entries = ["0x2F10"]
unless = { entry = "0x10F1:2", value = 7 }

[storage.write_condition]
entry = "0x6041:0"
mask = 0x004F
value = 0x0040
subindexes = [1, 4]
"#,
    ));
    let backup = |i: u16, s: u8| {
        let o = p.object(i).unwrap();
        p.is_backup(o, o.entry(s).unwrap())
    };
    assert!(backup(0x2F10, 0), "stored_pdo_mappable");
    assert!(!backup(0x2F00, 0) && !backup(0x10F1, 1), "not_stored");
    assert!(backup(0x10F1, 2), "only the named subindex is excluded");
    assert!(!backup(0x6040, 0), "other process data");
    let st = &p.storage;
    assert_eq!(st.groups[2].ranges[0].last, 0x2FFF);
    assert_eq!(
        st.auto_store[0].unless,
        Some(EntryTest {
            index: 0x10F1,
            subindex: 2,
            mask: 0xFFFF,
            value: 7
        }),
        "the mask defaults to every bit of the entry"
    );
    let c = st.write_condition.as_ref().unwrap();
    assert_eq!(
        (c.test.mask, c.test.value, c.subindexes.clone()),
        (0x4F, 0x40, vec![1, 4])
    );
    assert_eq!(
        st.store_capabilities(1),
        SAVES_ON_COMMAND | SAVES_AUTONOMOUSLY
    );
    assert_eq!(st.store_capabilities(2), SAVES_ON_COMMAND);
    assert_eq!(st.store_capabilities(3), SAVES_ON_COMMAND);
    assert_eq!(
        st.store_capabilities(4),
        SAVES_ON_COMMAND | SAVES_AUTONOMOUSLY
    );
    // The ESI carries the same Backup flags.
    let esi = p.esi_xml();
    let flags_of = |index: &str| {
        let at = esi.find(&format!("<Index>{index}</Index>")).unwrap();
        let end = at + esi[at..].find("</Object>").unwrap();
        esi[at..end].contains("<Backup>1</Backup>")
    };
    assert!(flags_of("#x2F10") && !flags_of("#x2F00"));
}

#[test]
fn entry_references_must_be_spelt_and_name_entries() {
    rejected(
        r#"[storage]
not_stored = ["0x2F00-0x2E00"]"#,
        "storage.not_stored[0]",
        "is not \"0xIIII\", \"0xIIII-0xJJJJ\" (first ≤ last) or \"0xIIII:S\"",
    );
    rejected(
        r#"[storage]
not_stored = ["2F00"]"#,
        "storage.not_stored[0]",
        "is not",
    );
    rejected(
        r#"[storage]
not_stored = ["0x2F00", "0x2F00:5"]"#,
        "storage.not_stored[1]",
        "names no entry of the dictionary",
    );
    rejected(
        r#"[storage]
not_stored = ["0x3000-0x3FFF"]"#,
        "storage.not_stored[0]",
        "names no entry of the dictionary",
    );
}

#[test]
fn not_stored_must_name_an_entry_that_would_be_stored() {
    rejected(
        r#"[storage]
not_stored = ["0x6041"]"#,
        "storage.not_stored[0]",
        "names no entry that would be stored",
    );
}

#[test]
fn stored_pdo_mappable_names_mappable_parameters_never_commands() {
    rejected(
        r#"[storage]
stored_pdo_mappable = ["0x2F00"]"#,
        "storage.stored_pdo_mappable[0]",
        "names no PDO-mappable writable RAM entry",
    );
    rejected(
        r#"[storage]
stored_pdo_mappable = ["0x2F10", "0x6000-0x60FF"]"#,
        "storage.stored_pdo_mappable[1]",
        "0x6040:00 is the process-data command `controlword`",
    );
    // Excluded again, the range is fine: 6060h, 6071h, 607Ah, 60B0h-60B2h (the offsets), 60C1h
    // (the interpolation data) and 60FFh are the other commands.
    let p = profile(&with_storage(
        STANDARD,
        r#"[storage]
stored_pdo_mappable = ["0x6000-0x60FF"]
not_stored = ["0x6040", "0x6060", "0x6071", "0x607A", "0x60B0-0x60B2", "0x60C1", "0x60FF"]"#,
    ));
    let o = p.object(0x6040).unwrap();
    assert!(!p.is_backup(o, &o.entries[0]));
}

#[test]
fn groups_must_fit_1010h_and_cover_its_subindexes() {
    rejected(
        "[[storage.group]]\nsubindex = 1\nranges = [\"0x2000-0x2FFF\"]",
        "storage.group[0].subindex",
        "must be ≥ 2",
    );
    rejected(
        "[[storage.group]]\nsubindex = 5\nranges = [\"0x2000-0x2FFF\"]",
        "storage.group[0].subindex",
        "0x1010 has no subindex 5",
    );
    rejected(
        "[[storage.group]]\nsubindex = 2\nranges = [\"0x1000-0x1FFF\"]\n\
         [[storage.group]]\nsubindex = 2\nranges = [\"0x2000-0x2FFF\"]",
        "storage.group[1].subindex",
        "subindex 2 has two groups",
    );
    rejected(
        "[[storage.group]]\nsubindex = 2\nranges = [\"0x1000-0x1FFF\"]\n\
         [[storage.group]]\nsubindex = 3\nranges = [\"0x6000-0x6FFF\"]",
        "storage.group",
        "0x1010:04 has no group",
    );
    rejected(
        "[[storage.group]]\nsubindex = 2\nranges = [\"0x1000-0x1FFF\", \"0x0100\"]",
        "storage.group[0].ranges[1]",
        "names no entry of the dictionary",
    );
}

#[test]
fn auto_stored_entries_must_be_stored_parameters() {
    rejected(
        "[[storage.auto_store]]\nentries = [\"0x2F10\"]",
        "storage.auto_store[0].entries[0]",
        "0x2f10:00 is not a stored parameter",
    );
    rejected(
        "[[storage.auto_store]]\nentries = [\"0x6041\"]",
        "storage.auto_store[0].entries[0]",
        "names no stored parameter",
    );
    rejected(
        "[storage]\nstored_pdo_mappable = [\"0x2F10\"]\n\
         [[storage.auto_store]]\nentries = [\"0x2F00\"]\n\
         [[storage.auto_store]]\nentries = [\"0x2F00-0x2F10\"]",
        "storage.auto_store[1].entries[0]",
        "overlaps storage.auto_store[0]",
    );
}

#[test]
fn tests_read_unsigned_entries_within_their_bits() {
    let auto =
        |unless: &str| format!("[[storage.auto_store]]\nentries = [\"0x2F00\"]\nunless = {unless}");
    rejected(
        &auto("{ entry = \"0x607A:0\", value = 1 }"),
        "storage.auto_store[0].unless.entry",
        "must be a readable unsigned entry of at most 32 bits",
    );
    rejected(
        &auto("{ entry = \"0x607A\", value = 1 }"),
        "storage.auto_store[0].unless.entry",
        "is not \"0xIIII:S\"",
    );
    rejected(
        &auto("{ entry = \"0x6041:0\", mask = 0x10000, value = 1 }"),
        "storage.auto_store[0].unless.mask",
        "inside the entry's 16 bits",
    );
    rejected(
        &auto("{ entry = \"0x6041:0\", mask = 0x4F, value = 0x80 }"),
        "storage.auto_store[0].unless.value",
        "has bits outside the mask",
    );
    rejected(
        "[storage.write_condition]\nentry = \"0x6041:0\"\nvalue = 0x40\nmask = 0x4F\nsubindexes = [1, 5]",
        "storage.write_condition.subindexes[1]",
        "0x1010 has no subindex 5",
    );
    rejected(
        "[storage.write_condition]\nentry = \"0x6041:0\"\nvalue = 0x40\nmask = 0x4F\nsubindexes = []",
        "storage.write_condition.subindexes",
        "needs at least one subindex",
    );
}

#[test]
fn the_1010h_defaults_must_be_the_capabilities() {
    // 2F00h auto-stored: sub 1 (all) and sub 4 (2000h-5FFFh) save autonomously.
    let auto = "[[storage.auto_store]]\nentries = [\"0x2F00\"]";
    let (key, error) = invalid(&with_storage(STANDARD, auto));
    assert_eq!(key, "object[0x1010].entry[0x01].default");
    assert!(error.to_string().contains("must be 3"), "{error}");
    let (key, _) = invalid(&with_storage(&store_defaults(3, 1), auto));
    assert_eq!(key, "object[0x1010].entry[0x04].default");
    profile(&with_storage(&store_defaults(3, 3), auto));
}

#[test]
fn storage_errors_name_file_and_line() {
    let text = with_storage(
        STANDARD,
        "[storage]\nnot_stored = [\n    \"0x2F00\",\n    \"0x2F00:7\",\n]",
    );
    let err = od_gen::parse(&text, "s.toml").unwrap_err().to_string();
    let line = text.lines().position(|l| l.contains("0x2F00:7")).unwrap() + 1;
    assert!(
        err.starts_with(&format!("s.toml:{line}: `storage.not_stored[1]`:")),
        "{err}"
    );
    // An unknown key is refused too.
    let (key, error) = invalid(&with_storage(STANDARD, "[storage]\nstored = []"));
    assert_eq!(key, "storage.stored", "{error}");
    assert!(
        matches!(error, Invalid::Format(ref m) if m.contains("unknown field `stored`")),
        "{error}"
    );
}
