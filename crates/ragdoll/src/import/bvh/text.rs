//! What the hierarchy and the motion readers share: lines with their numbers, numbers
//! within range, and the error naming a line.

use std::path::Path;

use super::MAX_VALUE;
use crate::error::Error;

pub(super) fn parse_error(path: &Path, line: usize, message: impl Into<String>) -> Error {
    Error::Parse {
        path: path.to_path_buf(),
        line,
        message: message.into(),
    }
}

/// The lines of a text with their 1-based numbers, split on `\n`, `\r\n`, or lone `\r` (old
/// Mac files), so line numbers match editors. Lazy: a file of a billion empty lines costs
/// no memory.
pub(super) struct Lines<'a> {
    rest: Option<&'a str>,
    sep: char,
    number: usize,
}

impl<'a> Lines<'a> {
    pub(super) fn new(text: &'a str) -> Self {
        Lines {
            rest: Some(text),
            sep: if text.contains('\n') { '\n' } else { '\r' },
            number: 0,
        }
    }
}

impl<'a> Iterator for Lines<'a> {
    type Item = (usize, &'a str);

    fn next(&mut self) -> Option<(usize, &'a str)> {
        let text = self.rest?;
        let (line, rest) = match text.split_once(self.sep) {
            Some((l, r)) => (l, Some(r)),
            None => (text, None),
        };
        self.rest = rest;
        self.number += 1;
        let line = match self.sep {
            '\n' => line.strip_suffix('\r').unwrap_or(line),
            _ => line,
        };
        Some((self.number, line))
    }
}

/// A finite number that also fits an `f32` (the crate's working precision).
pub(super) fn parse_number(s: &str) -> Option<f64> {
    let v: f64 = s.parse().ok()?;
    (v.is_finite() && (v as f32).is_finite()).then_some(v)
}

/// `v` when it is within [`MAX_VALUE`], else the sentence saying so.
pub(super) fn check_range(v: f64, what: &str) -> std::result::Result<f64, String> {
    if v.abs() <= MAX_VALUE {
        Ok(v)
    } else {
        Err(format!(
            "{what} is {v}, beyond the ±{MAX_VALUE} a BVH value may be (offsets and positions in file units, angles in degrees)"
        ))
    }
}
