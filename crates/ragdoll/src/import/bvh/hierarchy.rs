//! The HIERARCHY section: a streaming tokenizer (words a line at a time, ending at the
//! `MOTION` line) and the parser that reads joints, offsets, channels and End Sites from it
//! without recursing on the file's nesting, so a hierarchy nested tens of thousands deep
//! parses like a flat one.

use std::path::Path;

use glam::DVec3;

use super::text::{Lines, check_range, parse_error, parse_number};
use super::{Channel, MAX_CHANNELS_PER_JOINT};
use crate::error::{Error, Result};
use crate::skeleton::MAX_JOINTS;

/// The joints of the HIERARCHY at the start of `text`, the line of its `MOTION` keyword,
/// and the lines after it (where the motion is read from).
pub(super) fn read_hierarchy<'a>(
    text: &'a str,
    path: &Path,
) -> Result<(Vec<PJoint>, usize, Lines<'a>)> {
    let mut parser = Parser {
        path,
        tokens: Tokens::new(Lines::new(text)),
    };
    let joints = parser.hierarchy()?;
    let Some(motion_line) = parser.tokens.motion_line else {
        return Err(parse_error(
            path,
            parser.tokens.last_content,
            "the file ends without a MOTION section",
        ));
    };
    Ok((joints, motion_line, parser.tokens.lines))
}

/// A hierarchy word with its 1-based line.
#[derive(Clone, Copy, Debug)]
struct Tok<'a> {
    line: usize,
    text: &'a str,
}

/// The words of the hierarchy, read a line at a time; they end at the first line that
/// starts with `MOTION`, or at the end of the file.
struct Tokens<'a> {
    lines: Lines<'a>,
    words: std::str::SplitWhitespace<'a>,
    line: usize,
    peeked: Option<Tok<'a>>,
    ended: bool,
    /// The `MOTION` line, once reached.
    motion_line: Option<usize>,
    /// The last line with anything on it so far (1 when there is none).
    last_content: usize,
}

impl<'a> Tokens<'a> {
    fn new(lines: Lines<'a>) -> Self {
        Tokens {
            lines,
            words: "".split_whitespace(),
            line: 0,
            peeked: None,
            ended: false,
            motion_line: None,
            last_content: 1,
        }
    }

    fn read(&mut self) -> Option<Tok<'a>> {
        loop {
            if let Some(text) = self.words.next() {
                return Some(Tok {
                    line: self.line,
                    text,
                });
            }
            if self.ended {
                return None;
            }
            let Some((n, l)) = self.lines.next() else {
                self.ended = true;
                return None;
            };
            let words = l.split_whitespace();
            match words.clone().next() {
                Some(first) if first.eq_ignore_ascii_case("MOTION") => {
                    self.motion_line = Some(n);
                    self.ended = true;
                    return None;
                }
                Some(_) => self.last_content = n,
                None => {}
            }
            self.words = words;
            self.line = n;
        }
    }

    fn peek(&mut self) -> Option<Tok<'a>> {
        if self.peeked.is_none() {
            self.peeked = self.read();
        }
        self.peeked
    }

    fn next(&mut self) -> Option<Tok<'a>> {
        self.peek();
        self.peeked.take()
    }

    /// The line to blame when the hierarchy runs out: the `MOTION` line, or the file's last
    /// line with content.
    fn eof_line(&self) -> usize {
        self.motion_line.unwrap_or(self.last_content)
    }
}

/// A joint as read from the hierarchy, in file units.
#[derive(Clone, Debug)]
pub(super) struct PJoint {
    pub(super) name: String,
    pub(super) parent: Option<usize>,
    pub(super) line: usize,
    pub(super) offset: DVec3,
    pub(super) has_offset: bool,
    pub(super) channels: Vec<Channel>,
    pub(super) has_channels: bool,
    pub(super) end_site: Option<DVec3>,
}

struct Parser<'a, 'p> {
    path: &'p Path,
    tokens: Tokens<'a>,
}

impl<'a> Parser<'a, '_> {
    fn err(&self, line: usize, message: impl Into<String>) -> Error {
        parse_error(self.path, line, message)
    }

    fn next(&mut self, expected: &str) -> Result<Tok<'a>> {
        match self.tokens.next() {
            Some(t) => Ok(t),
            None => Err(self.err(
                self.tokens.eof_line(),
                format!("the hierarchy ends here, but {expected} was expected"),
            )),
        }
    }

    fn expect(&mut self, word: &str) -> Result<Tok<'a>> {
        let t = self.next(&format!("\"{word}\""))?;
        if t.text.eq_ignore_ascii_case(word) {
            Ok(t)
        } else {
            Err(self.err(t.line, format!("expected \"{word}\", found \"{}\"", t.text)))
        }
    }

    fn number(&mut self, what: &str) -> Result<f64> {
        let t = self.next(what)?;
        let v = parse_number(t.text)
            .ok_or_else(|| self.err(t.line, format!("expected {what}, found \"{}\"", t.text)))?;
        check_range(v, what).map_err(|m| self.err(t.line, m))
    }

    /// The rest of the keyword's line (a joint name may contain spaces), minus a trailing
    /// `{` some writers put on the same line.
    fn name_after(&mut self, keyword: Tok<'a>) -> String {
        let mut words = Vec::new();
        while let Some(t) = self.tokens.peek() {
            if t.line != keyword.line || t.text == "{" {
                break;
            }
            words.push(t.text);
            self.tokens.next();
        }
        words.join(" ")
    }

    fn offset(&mut self) -> Result<DVec3> {
        let x = self.number("the OFFSET's X value")?;
        let y = self.number("the OFFSET's Y value")?;
        let z = self.number("the OFFSET's Z value")?;
        Ok(DVec3::new(x, y, z))
    }

    /// A new joint named on `keyword`'s line, unless the skeleton is already full.
    fn joint(
        &mut self,
        joints: &mut Vec<PJoint>,
        keyword: Tok<'a>,
        parent: Option<usize>,
    ) -> Result<usize> {
        if joints.len() >= MAX_JOINTS {
            return Err(self.err(
                keyword.line,
                format!("a skeleton may have at most {MAX_JOINTS} joints; this is one more"),
            ));
        }
        let name = self.name_after(keyword);
        self.expect("{")?;
        joints.push(new_joint(name, parent, keyword.line));
        Ok(joints.len() - 1)
    }

    fn channels(&mut self, joint: &PJoint) -> Result<Vec<Channel>> {
        let t = self.next("the channel count")?;
        let n: usize = t.text.parse().map_err(|_| {
            self.err(
                t.line,
                format!(
                    "expected the channel count after CHANNELS, found \"{}\"",
                    t.text
                ),
            )
        })?;
        if n > MAX_CHANNELS_PER_JOINT {
            return Err(self.err(
                t.line,
                format!(
                    "joint \"{}\" lists {n} channels; a joint may have at most {MAX_CHANNELS_PER_JOINT}",
                    joint.name
                ),
            ));
        }
        let mut channels = Vec::with_capacity(n);
        for k in 0..n {
            let t = self.next(&format!("channel {} of {n}", k + 1))?;
            let ch = Channel::parse(t.text).ok_or_else(|| {
                self.err(
                    t.line,
                    format!(
                        "expected channel {} of {n} (such as Xposition or Zrotation), found \"{}\"",
                        k + 1,
                        t.text
                    ),
                )
            })?;
            channels.push(ch);
        }
        Ok(channels)
    }

    fn hierarchy(&mut self) -> Result<Vec<PJoint>> {
        self.hierarchy_keyword()?;
        let mut joints: Vec<PJoint> = Vec::new();
        // The joints whose braces are open, innermost last: an explicit stack, so nesting
        // depth costs memory, never the call stack.
        let mut open: Vec<usize> = Vec::new();
        loop {
            let Some(tok) = self.tokens.next() else {
                if let Some(&j) = open.last() {
                    return Err(self.err(
                        self.tokens.eof_line(),
                        format!(
                            "the hierarchy ends here, but joint \"{}\" (line {}) has no closing \"}}\"",
                            joints[j].name, joints[j].line
                        ),
                    ));
                }
                if joints.is_empty() {
                    return Err(self.err(self.tokens.eof_line(), "the hierarchy has no ROOT joint"));
                }
                return Ok(joints);
            };
            let Some(&current) = open.last() else {
                if tok.text.eq_ignore_ascii_case("ROOT") {
                    open.push(self.joint(&mut joints, tok, None)?);
                    continue;
                }
                return Err(self.err(
                    tok.line,
                    format!("expected \"ROOT\" or \"MOTION\", found \"{}\"", tok.text),
                ));
            };
            self.inside_joint(&mut joints, &mut open, current, tok)?;
        }
    }

    /// The `HIERARCHY` keyword a BVH file starts with.
    fn hierarchy_keyword(&mut self) -> Result<()> {
        match self.tokens.next() {
            Some(t) if t.text.eq_ignore_ascii_case("HIERARCHY") => Ok(()),
            Some(t) => Err(self.err(
                t.line,
                format!(
                    "expected \"HIERARCHY\" at the start of a BVH file, found \"{}\"",
                    t.text
                ),
            )),
            None => Err(self.err(self.tokens.eof_line(), "the file has no HIERARCHY section")),
        }
    }

    /// One item inside joint `current`'s braces, starting with `tok`: its OFFSET, its
    /// CHANNELS, a child JOINT (opened), its End Site, or the closing brace.
    fn inside_joint(
        &mut self,
        joints: &mut Vec<PJoint>,
        open: &mut Vec<usize>,
        current: usize,
        tok: Tok<'a>,
    ) -> Result<()> {
        let word = tok.text;
        if word.eq_ignore_ascii_case("OFFSET") {
            if joints[current].has_offset {
                return Err(self.err(
                    tok.line,
                    format!("joint \"{}\" has a second OFFSET", joints[current].name),
                ));
            }
            joints[current].offset = self.offset()?;
            joints[current].has_offset = true;
        } else if word.eq_ignore_ascii_case("CHANNELS") {
            if joints[current].has_channels {
                return Err(self.err(
                    tok.line,
                    format!(
                        "joint \"{}\" has a second CHANNELS line",
                        joints[current].name
                    ),
                ));
            }
            joints[current].channels = self.channels(&joints[current])?;
            joints[current].has_channels = true;
        } else if word.eq_ignore_ascii_case("JOINT") {
            open.push(self.joint(joints, tok, Some(current))?);
        } else if word.eq_ignore_ascii_case("End") {
            if self
                .tokens
                .peek()
                .is_some_and(|t| t.text.eq_ignore_ascii_case("Site"))
            {
                self.tokens.next();
            }
            if joints[current].end_site.is_some() {
                return Err(self.err(
                    tok.line,
                    format!("joint \"{}\" has a second End Site", joints[current].name),
                ));
            }
            self.expect("{")?;
            self.expect("OFFSET")?;
            let off = self.offset()?;
            self.expect("}")?;
            joints[current].end_site = Some(off);
        } else if word == "}" {
            if !joints[current].has_offset {
                return Err(self.err(
                    joints[current].line,
                    format!("joint \"{}\" has no OFFSET", joints[current].name),
                ));
            }
            open.pop();
        } else {
            return Err(self.err(
                tok.line,
                format!(
                    "unexpected \"{word}\" inside joint \"{}\" (expected OFFSET, CHANNELS, JOINT, End Site or \"}}\")",
                    joints[current].name
                ),
            ));
        }
        Ok(())
    }
}

fn new_joint(name: String, parent: Option<usize>, line: usize) -> PJoint {
    PJoint {
        name,
        parent,
        line,
        offset: DVec3::ZERO,
        has_offset: false,
        channels: Vec::new(),
        has_channels: false,
        end_site: None,
    }
}
