//! Reading a spec file: TOML into a checked [`RagdollSpec`], every error with its line.
//!
//! The text is parsed once into toml's spanned document (every key with its byte span) and
//! once into the spec; both kinds of error, and every value [`RagdollSpec::validate`]
//! refuses, are turned into a line by [`line_at`], the one line counter of the crate.

use std::ops::Range;
use std::path::Path;

use toml::Spanned;
use toml::de::{DeTable, DeValue};

use super::RagdollSpec;
use super::validate::Place;
use crate::error::{Error, Result};

/// The 1-based line holding byte `pos` of `text` (the last line when `pos` is past the end).
pub(crate) fn line_at(text: &str, pos: usize) -> usize {
    let pos = pos.min(text.len());
    text.as_bytes()[..pos]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

impl RagdollSpec {
    /// Reads and checks a spec file (at most [`crate::files::MAX_SETTINGS_BYTES`], a
    /// regular file only).
    pub fn load(path: &Path) -> Result<Self> {
        let text = crate::files::read_text_capped(path, crate::files::MAX_SETTINGS_BYTES)?;
        Self::from_toml(&text, path)
    }

    /// Reads a spec from TOML text; `path` is only used in error messages, which give the
    /// line and name the body or joint and the key (`spec.toml: line 27: body "End".
    /// shape.length_m: must be between 0 and 100 m, not 1e30`).
    pub fn from_toml(text: &str, path: &Path) -> Result<Self> {
        let err = |span: Range<usize>, message: String| Error::Parse {
            path: path.to_path_buf(),
            line: line_at(text, span.start),
            message,
        };
        let toml_err = |e: toml::de::Error| {
            let message = e.message().trim().replace('\n', " ");
            let span = e.span().unwrap_or(0..0);
            err(unknown_key_span(text, span, &message), message)
        };
        let doc = DeTable::parse(text).map_err(toml_err)?;
        check_array_lengths(doc.get_ref(), 0).map_err(|(span, m)| err(span, m))?;
        let spec: RagdollSpec = toml::from_str(text).map_err(toml_err)?;
        check_joint_keys(&spec, doc.get_ref()).map_err(|(span, m)| err(span, m))?;
        if let Some(p) = spec.problem() {
            let span = locate(doc.get_ref(), &p.place).unwrap_or(0..0);
            return Err(err(
                span,
                format!("{}: {}", p.place.describe(&spec), p.message),
            ));
        }
        Ok(spec)
    }
}

/// Where the key an "unknown field" error names is written, from `span` to the end of its
/// table: serde reports a shape's unknown key at the `[bodies.shape]` header (it reads the
/// table before it knows the kind), and the line of the key is what a user needs.
fn unknown_key_span(text: &str, span: Range<usize>, message: &str) -> Range<usize> {
    let Some(key) = message
        .strip_prefix("unknown field `")
        .and_then(|m| m.split('`').next())
    else {
        return span;
    };
    let Some(rest) = text.get(span.start..) else {
        return span;
    };
    let mut at = span.start;
    for (n, line) in rest.split_inclusive('\n').enumerate() {
        let trimmed = line.trim_start();
        if n > 0 && trimmed.starts_with('[') {
            break;
        }
        let is_key = trimmed
            .strip_prefix(key)
            .is_some_and(|r| r.trim_start().starts_with('='));
        if is_key {
            let start = at + (line.len() - trimmed.len());
            return start..start + key.len();
        }
        at += line.len();
    }
    span
}

/// The value at `key` of a table, with its key's span.
fn entry<'a, 'i>(
    table: &'a DeTable<'i>,
    key: &str,
) -> Option<(Range<usize>, &'a Spanned<DeValue<'i>>)> {
    table
        .iter()
        .find(|(k, _)| k.get_ref() == key)
        .map(|(k, v)| (k.span(), v))
}

/// The span of the key at the dotted `path` inside `table`; as far as the path goes.
fn key_span(table: &DeTable, path: &str) -> Option<Range<usize>> {
    let mut table = table;
    let mut span = None;
    for key in path.split('.') {
        let (k, v) = entry(table, key)?;
        span = Some(k);
        match v.get_ref() {
            DeValue::Table(t) => table = t,
            _ => break,
        }
    }
    span
}

/// The `index`-th table of the array of tables `key`, with its span.
fn item<'a, 'i>(
    doc: &'a DeTable<'i>,
    key: &str,
    index: usize,
) -> Option<(Range<usize>, &'a DeTable<'i>)> {
    let (_, v) = entry(doc, key)?;
    let DeValue::Array(items) = v.get_ref() else {
        return None;
    };
    let it = items.get(index)?;
    match it.get_ref() {
        DeValue::Table(t) => Some((it.span(), t)),
        _ => Some((it.span(), doc)),
    }
}

/// Where in the file a problem's key is written.
fn locate(doc: &DeTable, place: &Place) -> Option<Range<usize>> {
    let in_item = |array: &str, index: usize, key: &str| {
        let (span, table) = item(doc, array, index)?;
        key_span(table, key).or(Some(span))
    };
    match *place {
        Place::Top(key) => key_span(doc, key),
        Place::Body(i, key) => in_item("bodies", i, key),
        Place::Joint(i, key) => in_item("joints", i, key),
        Place::Pair(i) => {
            let (_, pairs) = entry(doc, "collision").and_then(|(_, c)| match c.get_ref() {
                DeValue::Table(t) => entry(t, "disabled_pairs"),
                _ => None,
            })?;
            match pairs.get_ref() {
                DeValue::Array(a) => a.get(i).map(|p| p.span()),
                _ => Some(pairs.span()),
            }
        }
    }
}

/// How many values each fixed-length array of a spec holds: serde fills a `[f32; 4]` from
/// the first four of a longer array and drops the rest, so a five-number quaternion was
/// read as if it were fine.
const ARRAY_LENGTHS: [(&str, usize, &str); 7] = [
    ("center_m", 3, "x, y, z"),
    ("anchor_m", 3, "x, y, z"),
    ("size_m", 3, "x, y, z"),
    ("rotation", 4, "x, y, z, w"),
    ("frame", 4, "x, y, z, w"),
    ("twist_deg", 2, "min, max"),
    ("cone_tilt_deg", 2, "about y, about z"),
];

/// Tables nest this deep in a spec (top, bodies, a body, its extra shapes, one's shape):
/// nothing deeper is looked into.
const MAX_SPEC_DEPTH: usize = 5;

/// Refuses a fixed-length array of another length, and a disabled pair that is not two
/// names, at the key's line.
fn check_array_lengths(
    table: &DeTable,
    depth: usize,
) -> std::result::Result<(), (Range<usize>, String)> {
    for (key, value) in table.iter() {
        let key_name = key.get_ref().as_ref();
        match value.get_ref() {
            DeValue::Array(items) => {
                if let Some(&(_, n, what)) = ARRAY_LENGTHS.iter().find(|(k, ..)| *k == key_name) {
                    if items.len() != n {
                        return Err((
                            key.span(),
                            format!(
                                "{key_name}: must hold {n} numbers ({what}), not {}",
                                items.len()
                            ),
                        ));
                    }
                } else if key_name == "disabled_pairs" {
                    for pair in items.iter() {
                        if let DeValue::Array(p) = pair.get_ref()
                            && p.len() != 2
                        {
                            return Err((
                                pair.span(),
                                format!(
                                    "disabled_pairs: a pair is two body names, not {}",
                                    p.len()
                                ),
                            ));
                        }
                    }
                } else if depth < MAX_SPEC_DEPTH {
                    for item in items.iter() {
                        if let DeValue::Table(t) = item.get_ref() {
                            check_array_lengths(t, depth + 1)?;
                        }
                    }
                }
            }
            DeValue::Table(t) if depth < MAX_SPEC_DEPTH => check_array_lengths(t, depth + 1)?,
            _ => {}
        }
    }
    Ok(())
}

/// Rejects keys a `[[joints]]` table does not have (a misspelt `max_deg` would otherwise be
/// dropped silently, see [`super::JointSpec`]): the keys allowed are the joint's own and
/// those its kind writes when serialised.
fn check_joint_keys(
    spec: &RagdollSpec,
    doc: &DeTable,
) -> std::result::Result<(), (Range<usize>, String)> {
    let Some((_, joints)) = entry(doc, "joints") else {
        return Ok(());
    };
    let DeValue::Array(tables) = joints.get_ref() else {
        return Ok(());
    };
    for (table, joint) in tables.iter().zip(&spec.joints) {
        let DeValue::Table(table) = table.get_ref() else {
            continue;
        };
        let kind_keys = toml::Table::try_from(joint.kind).unwrap_or_default();
        let known = |key: &str| {
            ["name", "parent", "child", "anchor_m", "frame"].contains(&key)
                || kind_keys.contains_key(key)
        };
        if let Some((key, _)) = table.iter().find(|(k, _)| !known(k.get_ref())) {
            return Err((
                key.span(),
                format!(
                    "unknown key `{}` in joint \"{}\" (a {} joint has: {})",
                    key.get_ref(),
                    joint.name,
                    kind_keys
                        .get("kind")
                        .and_then(|k| k.as_str())
                        .unwrap_or("?"),
                    kind_keys
                        .keys()
                        .filter(|k| *k != "kind")
                        .map(String::as_str)
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn humanoid_toml() -> String {
        let c = crate::skeleton::humanoid();
        crate::spec::build_spec(&c, &Default::default())
            .unwrap()
            .to_toml()
    }

    fn refused(text: &str) -> (usize, String) {
        match RagdollSpec::from_toml(text, Path::new("s.toml")) {
            Err(Error::Parse { line, message, .. }) => (line, message),
            other => panic!("expected a parse error, got {other:?}"),
        }
    }

    /// The first line at or after `from` that starts with `what`, 1-based.
    fn line_of(text: &str, what: &str, from: usize) -> usize {
        text.lines()
            .enumerate()
            .skip(from)
            .find(|(_, l)| l.trim_start().starts_with(what))
            .map(|(i, _)| i + 1)
            .unwrap()
    }

    #[test]
    fn fixed_length_arrays_of_another_length_are_refused_at_their_line() {
        let text = humanoid_toml();
        assert!(RagdollSpec::from_toml(&text, Path::new("s.toml")).is_ok());
        // A fifth number in the first body's rotation (serde alone kept the first four).
        let at = text.find("rotation = [").unwrap();
        let end = at + text[at..].find(']').unwrap();
        let five = format!("{}    0.0,\n{}", &text[..end], &text[end..]);
        let (line, message) = refused(&five);
        assert_eq!(line, line_of(&five, "rotation = [", 0), "{message}");
        assert!(
            message.contains("rotation: must hold 4 numbers"),
            "{message}"
        );
        // Three numbers in a twist range.
        let at = text.find("twist_deg = [").unwrap();
        let end = at + text[at..].find(']').unwrap();
        let three = format!("{}    1.0,\n{}", &text[..end], &text[end..]);
        let (line, message) = refused(&three);
        assert!(
            message.contains("twist_deg: must hold 2 numbers"),
            "{message}"
        );
        assert_eq!(line, line_of(&three, "twist_deg = [", 0), "{message}");
    }

    #[test]
    fn joints_that_are_not_a_tree_are_refused() {
        let text = humanoid_toml();
        // The head's joint made to hold the spine too: the spine would have two parents.
        let two = text.replacen("child = \"head\"", "child = \"spine\"", 1);
        assert_ne!(two, text);
        let (line, message) = refused(&two);
        assert!(
            message.contains("body \"spine\" already hangs from joint"),
            "{message}"
        );
        assert_eq!(
            line,
            line_of(
                &two,
                "child = \"spine\"",
                line_of(&two, "name = \"head\"", line_of(&two, "[[joints]]", 0))
            ),
            "{message}"
        );
        // The spine's joint hung from the chest instead of the pelvis: spine, chest, spine.
        let looped = text.replacen(
            "parent = \"pelvis\"\nchild = \"spine\"",
            "parent = \"chest\"\nchild = \"spine\"",
            1,
        );
        assert_ne!(looped, text);
        let (_, message) = refused(&looped);
        assert!(message.contains("close a loop"), "{message}");
    }

    #[test]
    fn lines_count_from_one_and_include_the_byte() {
        let text = "a = 1\nb = 2\n\nc = 3";
        assert_eq!(line_at(text, 0), 1);
        assert_eq!(line_at(text, 5), 1, "the newline ends line 1");
        assert_eq!(line_at(text, 6), 2, "the first byte of line 2");
        assert_eq!(line_at(text, text.find('c').unwrap()), 4);
        assert_eq!(line_at(text, 1000), 4);
    }
}
