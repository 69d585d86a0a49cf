//! The scene file's text, to turn byte spans into lines and toml's errors into ours: every
//! error names the file, the line, and the table and key where toml's message does not.

use std::ops::Range;
use std::path::Path;

use crate::error::Error;

/// The file being read, to turn spans into lines.
pub(super) struct Src<'a> {
    pub(super) path: &'a Path,
    pub(super) text: &'a str,
}

impl Src<'_> {
    /// 1-based line of byte `pos` (the crate's one line counter).
    pub(super) fn line(&self, pos: usize) -> usize {
        crate::spec::line_at(self.text, pos)
    }

    pub(super) fn err(&self, span: &Range<usize>, message: String) -> Error {
        self.err_line(self.line(span.start), message)
    }

    pub(super) fn err_line(&self, line: usize, message: String) -> Error {
        Error::Parse {
            path: self.path.to_path_buf(),
            line,
            message,
        }
    }

    /// Turns a toml error into ours, adding the table and the key when the message does
    /// not already name them (serde's type errors do not).
    pub(super) fn toml_error(&self, e: &toml::de::Error) -> Error {
        let span = e.span().unwrap_or(0..0);
        let mut message = e.message().trim().replace('\n', " ");
        if let Some(key) = key_before(self.text, span.start)
            && !message.contains(&format!("`{key}`"))
        {
            message = format!("{key}: {message}");
        }
        if let Some(table) = table_at(self.text, span.start) {
            message = format!("{table}: {message}");
        }
        self.err(&span, message)
    }
}

/// The key whose value starts at byte `pos`: the bare key before the last `=` on that
/// line before `pos` (inside inline tables, the innermost key).
fn key_before(text: &str, pos: usize) -> Option<String> {
    let before = text.get(..pos)?;
    let line = &before[before.rfind('\n').map_or(0, |i| i + 1)..];
    let eq = line.rfind('=')?;
    let lhs = line[..eq].trim_end();
    let key: String = lhs
        .chars()
        .rev()
        .take_while(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'))
        .collect::<Vec<_>>()
        .into_iter()
        .rev()
        .collect();
    (!key.is_empty()).then_some(key)
}

/// The table header that byte `pos` falls under, numbered for arrays of tables
/// (`[[blast]] 2`), or `None` at the top level.
fn table_at(text: &str, pos: usize) -> Option<String> {
    // Up to the end of `pos`'s line: a missing key is reported at its table's header.
    let end = text.get(pos..)?.find('\n').map_or(text.len(), |i| pos + i);
    let before = &text[..end];
    let headers: Vec<(&str, bool)> = before
        .lines()
        .filter_map(|l| {
            let l = l.split('#').next().unwrap_or("").trim();
            let (inner, array) =
                if let Some(x) = l.strip_prefix("[[").and_then(|x| x.strip_suffix("]]")) {
                    (x.trim(), true)
                } else {
                    (l.strip_prefix('[')?.strip_suffix(']')?.trim(), false)
                };
            let bare = !inner.is_empty()
                && inner
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'));
            bare.then_some((inner, array))
        })
        .collect();
    let &(name, array) = headers.last()?;
    Some(if array {
        let n = headers.iter().filter(|h| **h == (name, true)).count();
        format!("[[{name}]] {n}")
    } else {
        format!("[{name}]")
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn key_and_table_are_found_from_a_position() {
        let text = "fps = 30\n[[blast]]\ntnt_kg = 1\n[[blast]]\nposition = [1, \"a\"]\n";
        let pos = text.find("\"a\"").unwrap();
        assert_eq!(key_before(text, pos).as_deref(), Some("position"));
        assert_eq!(table_at(text, pos).as_deref(), Some("[[blast]] 2"));
        assert_eq!(table_at(text, 3), None);
        let inline = "keys = [{ time_s = 0, gravity = [0, 1] }]";
        let pos = inline.find("[0, 1]").unwrap();
        assert_eq!(key_before(inline, pos).as_deref(), Some("gravity"));
    }
}
