//! Reading BVH text: a streaming tokenizer for the hierarchy, and the unit and up-axis
//! detection (see the parent module's docs); the motion is read in `motion.rs`.
//!
//! Nothing here holds more than one frame's numbers at a time or recurses on the file's
//! nesting, so memory is the joints plus the clip (bounded by
//! [`MAX_CLIP_POSES`](crate::skeleton::MAX_CLIP_POSES)) and a hierarchy nested tens of
//! thousands deep parses like a flat one.

use std::path::Path;

use glam::{DQuat, DVec3};

use super::{
    BvhJoint, BvhLayout, Channel, MAX_CHANNELS_PER_JOINT, MAX_VALUE, TYPICAL_HEIGHT_M,
    UNIT_CANDIDATES, compose_rotation, up_rotation,
};
use crate::error::{Error, Result};
use crate::import::{ImportOptions, UpAxis};
use crate::math::Transform;
use crate::skeleton::{Character, Clip, Joint, MAX_JOINTS, MAX_REACH_M, Skeleton, Source};

/// Loads a BVH file; see the module docs for what is detected and how it is converted.
/// The file is read with [`crate::files::read_capped`] (regular files of at most
/// [`crate::files::MAX_INPUT_BYTES`]); bytes that are not UTF-8 become U+FFFD.
pub fn load(path: &Path, opts: &ImportOptions) -> Result<Character> {
    let bytes = crate::files::read_capped(path, crate::files::MAX_INPUT_BYTES)?;
    let text = String::from_utf8_lossy(&bytes);
    parse(&text, path, opts)
}

/// Parses BVH text; `path` is only used to name the file in errors and the character.
///
/// This is the entry point for fuzzing (through `String::from_utf8_lossy` of the bytes):
/// any text gives a [`Character`] or an [`Error::Parse`] naming a line, never a panic.
pub fn parse(text: &str, path: &Path, opts: &ImportOptions) -> Result<Character> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
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

    let positions = rest_positions(&joints);
    let up = opts.up.unwrap_or_else(|| detect_up(&positions));
    let metres_per_unit = match opts.units {
        Some(u) => f64::from(u.to_metres()),
        None => detect_metres_per_unit(&positions, up),
    };
    let convert = Convert {
        c: up_rotation(up),
        s: metres_per_unit,
    };
    let mut lines = parser.tokens.lines;
    let motion = super::motion::read_motion(path, &mut lines, motion_line, &joints, &convert)?;
    let skeleton = skeleton_of(&joints, &convert, metres_per_unit)?;
    let frame_time = motion.frame_time as f32;
    let clips = clip_of(&skeleton, motion, path, motion_line)?;
    let layout = BvhLayout {
        joints: joints
            .iter()
            .map(|j| BvhJoint {
                name: j.name.clone(),
                channels: j.channels.clone(),
                end_site: j.end_site.map(|e| e.as_vec3()),
            })
            .collect(),
        metres_per_unit: metres_per_unit as f32,
        up,
        frame_time,
    };
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "bvh".into());
    let mut character = Character {
        humanoid_bones: Vec::new(),
        warnings: Vec::new(),
        name,
        skeleton,
        meshes: Vec::new(),
        clips,
        source: Source::Bvh(layout),
    };
    if let Some(standing) = standing_first_frame(&character) {
        character.skeleton = standing;
        if opts.units.is_none() {
            let rest: Vec<DVec3> = (character.skeleton.rest_world().iter())
                .map(|t| t.translation.as_dvec3() / metres_per_unit)
                .collect();
            let better = detect_metres_per_unit(&rest, UpAxis::Y);
            if better != metres_per_unit {
                let factor = (better / metres_per_unit) as f32;
                crate::import::size::scale(&mut character, factor, path)?;
            }
        }
    }
    Ok(character)
}

/// The skeleton of the HIERARCHY's joints, in metres and Y up.
fn skeleton_of(joints: &[PJoint], convert: &Convert, metres_per_unit: f64) -> Result<Skeleton> {
    let skel_joints: Vec<Joint> = joints
        .iter()
        .map(|j| Joint {
            name: j.name.clone(),
            parent: j.parent,
            rest: convert.transform(j.parent, j.offset, DQuat::IDENTITY),
            // An all-zero End Site says nothing about where the bone ends.
            tip: j
                .end_site
                .filter(|e| *e != DVec3::ZERO)
                .map(|e| (e * metres_per_unit).as_vec3()),
        })
        .collect();
    Skeleton::new(skel_joints)
}

/// The MOTION section as a clip (none for zero frames; the rest pose repeated where the
/// file has frames but no channels), refused where a frame puts a joint out of reach.
fn clip_of(
    skeleton: &Skeleton,
    motion: super::motion::Motion,
    path: &Path,
    motion_line: usize,
) -> Result<Vec<Clip>> {
    let frames = match motion.frames {
        Some(frames) => frames,
        None => {
            let rest: Vec<Transform> = skeleton.joints().iter().map(|j| j.rest).collect();
            vec![rest; motion.count]
        }
    };
    if frames.is_empty() {
        return Ok(Vec::new());
    }
    let clip = Clip {
        name: String::new(),
        frame_time: motion.frame_time as f32,
        frames,
    };
    if let Some((f, j, far)) = skeleton.clip_out_of_reach(&clip) {
        return Err(parse_error(
            path,
            motion.frame_lines.get(f).copied().unwrap_or(motion_line),
            format!(
                "frame {} puts joint \"{}\" {far} m from the origin, past the {MAX_REACH_M} m a skeleton may reach",
                f + 1,
                skeleton.joint_label(j)
            ),
        ));
    }
    Ok(vec![clip])
}

/// The skeleton with the first frame's rotations as its rest rotations, when the rest pose
/// lies down and the first frame stands up. Some exporters (Rokoko) write bone-local
/// offsets, so the zero-rotation pose lies along the ground: the height units are guessed
/// from would be its width (a dancer came out 9.4 m tall, its bodies five times too big),
/// and the ragdoll's joint axes and limits, which are built in the rest pose, would be
/// those of a body lying in a pose it never takes (a knee hinge about the wrong axis).
/// Offsets and the motion are unchanged, so every frame's world pose is what the file
/// says; only the pose the skeleton calls rest, and that BVH export measures its channels
/// from, stands. `None` when the rest pose already stands (or the file has no frame).
fn standing_first_frame(c: &Character) -> Option<Skeleton> {
    let frame = c.clips.first()?.frames.first()?;
    let skeleton = &c.skeleton;
    let mut world = vec![Transform::IDENTITY; skeleton.len()];
    let points =
        |w: &[Transform]| -> Vec<DVec3> { w.iter().map(|t| t.translation.as_dvec3()).collect() };
    let rest = points(&skeleton.rest_world());
    skeleton.world_from_local(frame, &mut world);
    let posed = points(&world);
    let (rest_e, posed_e) = (extent(&rest), extent(&posed));
    // Lying down: the rest pose's height under half its breadth, the first frame's at
    // least twice the rest pose's.
    let lies = rest_e.y < 0.5 * rest_e.x.max(rest_e.z);
    if !(lies && posed_e.y > 2.0 * rest_e.y) {
        return None;
    }
    let joints: Vec<Joint> = (skeleton.joints().iter().zip(frame))
        .map(|(j, f)| Joint {
            rest: Transform::new(j.rest.translation, f.rotation),
            ..j.clone()
        })
        .collect();
    Skeleton::new(joints).ok()
}

/// File units and axes to the crate's: the up-axis rotation `c` goes into the roots only,
/// every translation is scaled by `s` metres per unit.
pub(super) struct Convert {
    c: DQuat,
    s: f64,
}

impl Convert {
    fn transform(&self, parent: Option<usize>, t: DVec3, r: DQuat) -> Transform {
        let (t, r) = match parent {
            None => (self.c * (t * self.s), self.c * r),
            Some(_) => (t * self.s, r),
        };
        Transform::new(t.as_vec3(), r.normalize().as_quat())
    }

    /// Every joint's local transform in one frame, from that frame's channel values.
    pub(super) fn frame(&self, joints: &[PJoint], row: &[f64]) -> Vec<Transform> {
        let mut col = 0;
        joints
            .iter()
            .map(|j| {
                let n = j.channels.len();
                let vals = row.get(col..col + n).unwrap_or(&[]);
                col += n;
                let (t, r) = joint_motion(j, vals);
                self.transform(j.parent, t, r)
            })
            .collect()
    }
}

/// A joint's local translation and rotation in one frame, in file units and axes.
fn joint_motion(j: &PJoint, vals: &[f64]) -> (DVec3, DQuat) {
    let mut t = j.offset;
    let mut axes = Vec::with_capacity(3);
    let mut angles = Vec::with_capacity(3);
    for (ch, &v) in j.channels.iter().zip(vals) {
        match ch {
            Channel::Position(a) => t[a.index()] = v,
            Channel::Rotation(a) => {
                axes.push(*a);
                angles.push(v.to_radians());
            }
        }
    }
    (t, compose_rotation(&axes, &angles))
}

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
    fn new(text: &'a str) -> Self {
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
    name: String,
    parent: Option<usize>,
    line: usize,
    offset: DVec3,
    has_offset: bool,
    pub(super) channels: Vec<Channel>,
    has_channels: bool,
    end_site: Option<DVec3>,
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

/// Rest-pose positions of every joint and End Site, in file units and axes.
fn rest_positions(joints: &[PJoint]) -> Vec<DVec3> {
    let mut world: Vec<DVec3> = Vec::with_capacity(joints.len());
    let mut out = Vec::with_capacity(joints.len() * 2);
    for j in joints {
        let base = j
            .parent
            .and_then(|p| world.get(p).copied())
            .unwrap_or(DVec3::ZERO);
        let p = base + j.offset;
        world.push(p);
        out.push(p);
        if let Some(e) = j.end_site {
            out.push(p + e);
        }
    }
    out
}

fn extent(points: &[DVec3]) -> DVec3 {
    let (lo, hi) = points.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    if points.is_empty() {
        DVec3::ZERO
    } else {
        hi - lo
    }
}

/// Z up when the rest pose is more than twice as tall along Z as along Y (module docs).
fn detect_up(points: &[DVec3]) -> UpAxis {
    let e = extent(points);
    if e.z > 2.0 * e.y {
        UpAxis::Z
    } else {
        UpAxis::Y
    }
}

/// Metres per unit making the height closest to [`TYPICAL_HEIGHT_M`] (module docs).
pub(super) fn detect_metres_per_unit(points: &[DVec3], up: UpAxis) -> f64 {
    let e = extent(points);
    let along_up = match up {
        UpAxis::Y => e.y,
        UpAxis::Z => e.z,
    };
    let h = if along_up > 1e-9 {
        along_up
    } else {
        e.max_element()
    };
    if !(h > 1e-9 && h.is_finite()) {
        return 0.01;
    }
    let miss = |u: f64| (h * u / TYPICAL_HEIGHT_M).ln().abs();
    UNIT_CANDIDATES
        .into_iter()
        .min_by(|a, b| miss(*a).total_cmp(&miss(*b)))
        .unwrap_or(0.01)
}
