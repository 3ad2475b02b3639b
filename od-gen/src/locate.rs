//! Key path → file and line: an error found in the merged profile names the line that wrote
//! the value at fault.
//!
//! Keys are the ones od-gen's errors use: dotted segments, each a plain key (`sync`,
//! `default`) or an element of an array of tables selected by its identifying value
//! (`object[0x6040]`, `entry[0x03]`, `rxpdo[0x1600]`, `alarm[OC1]`) or by position
//! (`entries[1]`, `dc_op_mode[0]`, `replicate[2]`).

use toml_edit::{ImDocument, Item, Table};

use crate::compose::{id_key, Source};

/// One segment of a key path.
#[derive(Debug, PartialEq, Eq)]
struct Segment<'a> {
    key: &'a str,
    select: Option<&'a str>,
}

fn segments(path: &str) -> Vec<Segment<'_>> {
    path.split('.')
        .map(|s| match s.split_once('[') {
            Some((key, rest)) => Segment {
                key,
                select: Some(rest.trim_end_matches(']')),
            },
            None => Segment {
                key: s,
                select: None,
            },
        })
        .collect()
}

fn parse_int(s: &str) -> Option<i64> {
    let s = s.replace('_', "");
    match s.strip_prefix("0x").or_else(|| s.strip_prefix("0X")) {
        Some(hex) => i64::from_str_radix(hex, 16).ok(),
        None => s.parse().ok(),
    }
}

/// Whether a table's identifying value equals the selector.
fn selected(table: &Table, id: &str, select: &str) -> bool {
    match table.get(id).and_then(Item::as_value) {
        Some(toml_edit::Value::Integer(i)) => parse_int(select) == Some(*i.value()),
        Some(toml_edit::Value::String(s)) => s.value() == select,
        _ => false,
    }
}

fn line_of(text: &str, offset: usize) -> usize {
    text.get(..offset)
        .map_or(0, |before| before.bytes().filter(|b| *b == b'\n').count())
        + 1
}

/// The span of the deepest item of `path` found in `doc`, and how many segments matched.
fn deepest(doc: &Table, path: &[Segment<'_>]) -> Option<(std::ops::Range<usize>, usize)> {
    let mut table = doc;
    let mut found: Option<(std::ops::Range<usize>, usize)> = None;
    for (depth, seg) in path.iter().enumerate() {
        let Some(item) = table.get(seg.key) else {
            return found;
        };
        let (key_span, _) = table
            .key(seg.key)
            .and_then(|k| k.span().map(|s| (s, ())))
            .unzip();
        match (item, seg.select) {
            (Item::ArrayOfTables(array), Some(select)) => {
                let element = match id_key(seg.key) {
                    Some(id) => array.iter().find(|t| selected(t, id, select)),
                    None => select.parse::<usize>().ok().and_then(|i| array.get(i)),
                }?;
                if let Some(span) = element.span() {
                    found = Some((span, depth + 1));
                }
                table = element;
            }
            (Item::Value(toml_edit::Value::Array(array)), Some(select)) => {
                let span = select
                    .parse::<usize>()
                    .ok()
                    .and_then(|i| array.get(i))
                    .and_then(toml_edit::Value::span)
                    .or(key_span);
                if let Some(span) = span {
                    found = Some((span, depth + 1));
                }
                return found;
            }
            (Item::Table(t), None) => {
                if let Some(span) = t.span().or(key_span) {
                    found = Some((span, depth + 1));
                }
                table = t;
            }
            (Item::Value(toml_edit::Value::InlineTable(t)), None) => {
                if let Some(span) = key_span {
                    found = Some((span, depth + 1));
                }
                // Inline tables hold plain values: the key of the next segment, if any.
                if let Some(next) = path.get(depth + 1) {
                    if let Some(span) = t.key(next.key).and_then(|k| k.span()) {
                        found = Some((span, depth + 2));
                    }
                }
                return found;
            }
            (_, _) => {
                if let Some(span) = item.span().or(key_span) {
                    found = Some((span, depth + 1));
                }
                return found;
            }
        }
    }
    found
}

/// The source and line that best match `key`: the one where the most segments of the path
/// are found (the profile wins over its bases and libraries on a tie, as it overrides them).
pub fn locate(sources: &[Source], key: &str) -> Option<(String, usize)> {
    let path = segments(key);
    let mut best: Option<(String, usize, usize)> = None;
    for source in sources {
        let Ok(doc) = ImDocument::parse(source.text.as_str()) else {
            continue;
        };
        if let Some((span, depth)) = deepest(doc.as_table(), &path) {
            if best.as_ref().is_none_or(|(_, _, d)| depth > *d) {
                best = Some((
                    source.name.clone(),
                    line_of(&source.text, span.start),
                    depth,
                ));
            }
        }
    }
    best.map(|(name, line, _)| (name, line))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn src(name: &str, text: &str) -> Source {
        Source {
            name: name.into(),
            text: text.into(),
        }
    }

    const PROFILE: &str = "name = \"x\"\n\n[sync]\nmin_cycle_ns = 5\n\n[[object]]\nindex = 0x6040\nname = \"a\"\n\n[[object]]\nindex = 0x2000\ncode = \"record\"\n[[object.entry]]\nsub = 1\ndefault = 3\n\n[[rxpdo]]\nindex = 0x1600\nentries = [\n  { index = 1 },\n  { index = 2 },\n]\n";

    #[test]
    fn finds_the_line_of_a_nested_key() {
        let s = [src("p.toml", PROFILE)];
        assert_eq!(locate(&s, "sync.min_cycle_ns"), Some(("p.toml".into(), 4)));
        assert_eq!(
            locate(&s, "object[0x6040].name"),
            Some(("p.toml".into(), 8))
        );
        assert_eq!(
            locate(&s, "object[0x2000].entry[0x01].default"),
            Some(("p.toml".into(), 15))
        );
        assert_eq!(
            locate(&s, "rxpdo[0x1600].entries[1]"),
            Some(("p.toml".into(), 21))
        );
    }

    #[test]
    fn an_absent_value_points_at_its_object() {
        let s = [src("p.toml", PROFILE)];
        // `type` is missing on 0x6040: the object header is the place to add it.
        assert_eq!(
            locate(&s, "object[0x6040].type"),
            Some(("p.toml".into(), 6))
        );
    }

    #[test]
    fn the_source_that_wrote_the_value_wins() {
        let derived = "name = \"y\"\n[[object]]\nindex = 0x6040\n";
        let base = "[[object]]\nindex = 0x6040\nname = \"a\"\ndefault = 9\n";
        let s = [src("derived.toml", derived), src("base.toml", base)];
        assert_eq!(
            locate(&s, "object[0x6040].default"),
            Some(("base.toml".into(), 4))
        );
        assert_eq!(
            locate(&s, "object[0x6040]"),
            Some(("derived.toml".into(), 2))
        );
        assert_eq!(locate(&s, "nothing.here"), None);
    }
}
