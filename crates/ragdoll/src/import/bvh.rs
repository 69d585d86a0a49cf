//! BVH (Biovision hierarchy) import. Hand-written: the one crate panics on real files, and
//! user files must give an error naming the line, never a crash.
//!
//! # What is accepted
//!
//! Any joint names and counts, several `ROOT`s, any `CHANNELS` list on any joint (positions
//! on non-root joints, rotations only, fewer than three, any order), `End Site` in any case,
//! tabs, CRLF (or CR-only) line ends, blank lines anywhere, and `Frames:` / `Frame Time:`
//! with or without spaces around the colon. One frame is one line; its value count must
//! equal the channel count of the hierarchy.
//!
//! Everything else is an [`Error::Parse`] naming the file and the 1-based line: a missing
//! brace or `OFFSET` (blamed on the line where the hierarchy ends, or the joint's line), an
//! unknown keyword or channel, a value that is not a finite number, a frame line with the
//! wrong value count, a missing `MOTION` / `Frames:` / `Frame Time:` (which must be
//! positive), more frame lines than `Frames:` announces, or fewer (blamed on the line where
//! the data ran out). An `End Site` whose offset is all zeros gives no [`Joint::tip`] (it
//! says nothing about where the bone ends), but is kept in the layout.
//!
//! # Channel semantics
//!
//! A joint's local transform in a frame is `T(p) · R₁(θ₁) · R₂(θ₂) · …`: the rotation
//! channels compose in the order they are listed (the first one is outermost, so
//! `Zrotation Xrotation Yrotation` is `Rz·Rx·Ry`, glam's intrinsic `EulerRot::ZXY`). `p` is
//! the `OFFSET`, with each position channel present replacing its own component (the usual
//! case: all three present, so the channels replace the offset). The rest pose is the
//! offsets with no rotation.
//!
//! # Units and up axis (detected unless [`ImportOptions`] says)
//!
//! The detection looks at the rest pose: every joint and `End Site` position, in file units.
//!
//! - **Up axis**: Z when the extent along Z is more than twice the extent along Y, else Y.
//!   A standing figure is several times taller than it is deep, so this only flips for
//!   files that really stand on Z; ambiguous shapes (quadrupeds) keep BVH's usual Y.
//! - **Units**: the candidate that makes the height (extent along the up axis, or the
//!   largest extent when that one is zero) closest to 1.7 m on a log scale. The candidates
//!   and the resulting thresholds on the height `h` in file units:
//!   metres (`h < 7.16`), CMU units of 1/0.45 inch (`7.16 ≤ h < 44.9`, the unit of the CMU
//!   ASF skeletons that many converted BVH files keep), inches (`44.9 ≤ h < 106.7`, the
//!   original Biovision sample), centimetres (`106.7 ≤ h < 537.6`, most BVH), millimetres
//!   above. A skeleton with no extent at all is taken as centimetres.
//!
//! The data files give: `biovision_example_bvhio` 72.35 → inches, 1.84 m;
//! `cmu_pirouette_threejs` 152.7 → cm, 1.53 m; `mocapbank_bvh-python` 167.3 → cm, 1.67 m;
//! `two_joint_bvh_anim` (a chain lying along Z, so Z up) 45 → inches, 1.14 m.
//!
//! # Conversion
//!
//! The [`Character`] is in metres with Y up. The up-axis rotation `C` (identity, or −90°
//! about X for Z-up files) goes into the root joints only: root rest = `C · T(offset·s)`,
//! root in a frame = `C · T(p·s) · R`. Other joints keep their rotations; their translations
//! are scaled to metres. Everything needed to write the file back is kept in [`BvhLayout`].

use std::path::Path;

use glam::{DMat3, DQuat, DVec3, Vec3};

use super::{ImportOptions, UpAxis};
use crate::error::{Error, Result};
use crate::math::Transform;
use crate::skeleton::{Character, Clip, Joint, Skeleton, Source};

/// Metres per unit of the CMU motion capture ASF skeletons, `(1/0.45) · 2.54 / 100`, which
/// many BVH conversions of that database kept; a height of about 31 of them is a person.
pub const CMU_UNIT_M: f32 = 0.0254 / 0.45;

/// The height a detected unit aims for; see the module docs for the thresholds it implies.
const TYPICAL_HEIGHT_M: f64 = 1.7;

/// Unit candidates for detection, metres per file unit.
const UNIT_CANDIDATES: [f64; 5] = [1.0, CMU_UNIT_M as f64, 0.0254, 0.01, 0.001];

/// Most joint poses (frames × joints) one clip may hold: 50 million is about 2 GB, far above
/// any real capture (a 20-minute take at 120 fps of 60 joints is 8.6 million).
const MAX_CLIP_TRANSFORMS: usize = 50_000_000;

/// Below this sine or cosine of the middle angle, Euler decomposition treats the middle
/// angle as gimbal-locked and puts the whole remaining turn into the last angle.
const GIMBAL_EPS: f64 = 1e-6;

/// A coordinate axis, as named by a BVH channel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Axis {
    /// The X axis.
    X,
    /// The Y axis.
    Y,
    /// The Z axis.
    Z,
}

impl Axis {
    /// 0, 1 or 2: the component this axis selects.
    pub fn index(self) -> usize {
        match self {
            Axis::X => 0,
            Axis::Y => 1,
            Axis::Z => 2,
        }
    }

    fn from_index(i: usize) -> Axis {
        match i % 3 {
            0 => Axis::X,
            1 => Axis::Y,
            _ => Axis::Z,
        }
    }

    fn unit(self) -> DVec3 {
        match self {
            Axis::X => DVec3::X,
            Axis::Y => DVec3::Y,
            Axis::Z => DVec3::Z,
        }
    }
}

/// One BVH channel: which quantity one column of the motion data drives.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Channel {
    /// `Xposition`, `Yposition` or `Zposition`: a component of the joint's translation, in
    /// file units.
    Position(Axis),
    /// `Xrotation`, `Yrotation` or `Zrotation`: a rotation about that local axis, degrees.
    Rotation(Axis),
}

impl Channel {
    /// The keyword as BVH files spell it, e.g. `Zrotation`.
    pub fn name(self) -> &'static str {
        match self {
            Channel::Position(Axis::X) => "Xposition",
            Channel::Position(Axis::Y) => "Yposition",
            Channel::Position(Axis::Z) => "Zposition",
            Channel::Rotation(Axis::X) => "Xrotation",
            Channel::Rotation(Axis::Y) => "Yrotation",
            Channel::Rotation(Axis::Z) => "Zrotation",
        }
    }

    /// Reads a channel keyword; case-insensitive because exporters disagree on case.
    pub fn parse(s: &str) -> Option<Channel> {
        let lower = s.to_ascii_lowercase();
        Some(match lower.as_str() {
            "xposition" => Channel::Position(Axis::X),
            "yposition" => Channel::Position(Axis::Y),
            "zposition" => Channel::Position(Axis::Z),
            "xrotation" => Channel::Rotation(Axis::X),
            "yrotation" => Channel::Rotation(Axis::Y),
            "zrotation" => Channel::Rotation(Axis::Z),
            _ => return None,
        })
    }
}

/// The file layout of one joint, kept so the exporter can write it back unchanged.
#[derive(Clone, Debug, PartialEq)]
pub struct BvhJoint {
    /// The name exactly as in the file (the exporter sanitises it only if it must).
    pub name: String,
    /// The joint's channels, in file order.
    pub channels: Vec<Channel>,
    /// The `End Site` offset in file units and file axes, when the file has one.
    pub end_site: Option<Vec3>,
}

/// What the BVH exporter needs to write a file back in the source's own layout.
///
/// `joints[i]` describes skeleton joint `i`; for an imported file the skeleton's joint order
/// is the file's order, so writing the hierarchy depth-first reproduces it.
#[derive(Clone, Debug, PartialEq)]
pub struct BvhLayout {
    /// One entry per skeleton joint, in skeleton order.
    pub joints: Vec<BvhJoint>,
    /// Metres per file unit (detected or given on import).
    pub metres_per_unit: f32,
    /// The file's up axis (detected or given on import).
    pub up: UpAxis,
    /// Seconds per frame of the file's motion, a natural default output rate.
    pub frame_time: f32,
}

impl BvhLayout {
    /// A layout for a character that did not come from a BVH file (glTF, the built-in
    /// humanoid): the root gets `Xposition Yposition Zposition Zrotation Xrotation
    /// Yrotation`, the others `Zrotation Xrotation Yrotation`, in centimetres with Y up, the
    /// most widely read BVH dialect. Names are sanitised so other tools can parse them;
    /// joint tips become `End Site`s, in world axes with the rest world scale applied,
    /// because the exporter writes the rest pose with world-aligned joint frames.
    pub fn from_skeleton(skeleton: &Skeleton) -> BvhLayout {
        let metres_per_unit = 0.01f32;
        let names = sanitise_names(skeleton.joints().iter().map(|j| j.name.as_str()));
        let rest_world = skeleton.rest_world();
        let joints = skeleton
            .joints()
            .iter()
            .zip(names)
            .enumerate()
            .map(|(i, (j, name))| {
                let rot = [Axis::Z, Axis::X, Axis::Y].map(Channel::Rotation);
                let channels = if j.parent.is_none() {
                    let mut c = [Axis::X, Axis::Y, Axis::Z].map(Channel::Position).to_vec();
                    c.extend(rot);
                    c
                } else {
                    rot.to_vec()
                };
                // In world axes, like the exporter's OFFSETs (its module docs say why).
                let end_site = j
                    .tip
                    .map(|t| rest_world[i].rotation * (rest_world[i].scale * t) / metres_per_unit);
                BvhJoint {
                    name,
                    channels,
                    end_site,
                }
            })
            .collect();
        BvhLayout {
            joints,
            metres_per_unit,
            up: UpAxis::Y,
            frame_time: 1.0 / 30.0,
        }
    }
}

/// Makes joint names safe to write into a BVH file: empty names become `joint<i>`,
/// whitespace and braces become `_` (a reader splits on them), and duplicates get a `_2`,
/// `_3`… suffix (readers look joints up by name).
pub(crate) fn sanitise_names<'a>(names: impl Iterator<Item = &'a str>) -> Vec<String> {
    let base: Vec<String> = names
        .enumerate()
        .map(|(i, n)| {
            let s: String = n
                .chars()
                .map(|c| {
                    if c.is_whitespace() || c == '{' || c == '}' {
                        '_'
                    } else {
                        c
                    }
                })
                .collect();
            if s.is_empty() { format!("joint{i}") } else { s }
        })
        .collect();
    let mut used = std::collections::HashSet::new();
    let mut out = Vec::with_capacity(base.len());
    for name in &base {
        let mut candidate = name.clone();
        let mut k = 2;
        while used.contains(&candidate) {
            candidate = format!("{name}_{k}");
            k += 1;
        }
        used.insert(candidate.clone());
        out.push(candidate);
    }
    out
}

/// The rotation `R_{axes[0]}(θ₀) · R_{axes[1]}(θ₁) · …` (angles in radians): how BVH
/// composes a joint's rotation channels, the first listed being the outermost.
pub fn compose_rotation(axes: &[Axis], angles_rad: &[f64]) -> DQuat {
    axes.iter()
        .zip(angles_rad)
        .fold(DQuat::IDENTITY, |q, (a, &t)| {
            q * DQuat::from_axis_angle(a.unit(), t)
        })
        .normalize()
}

/// Angles (radians) for `axes` such that [`compose_rotation`] gives back `q`: the inverse
/// the exporter needs to write any channel order.
///
/// Exact for three axes with no two neighbours equal (the six Tait–Bryan orders such as
/// `ZXY`, and the proper Euler orders such as `ZXZ`). With fewer axes, or runs of one axis,
/// it is a best effort that is exact when `q` lies in what the channels can express: one
/// axis gets the twist about it, two axes get the first two angles of the three-axis
/// decomposition completed by the missing axis, a run of one axis gets its whole angle on
/// its first channel, and axes past the third distinct one get zero.
pub fn decompose_rotation(q: DQuat, axes: &[Axis]) -> Vec<f64> {
    let mut out = vec![0.0; axes.len()];
    // Collapse runs of the same axis: (axis, index of its first channel).
    let mut core: Vec<(Axis, usize)> = Vec::with_capacity(axes.len());
    for (i, &a) in axes.iter().enumerate() {
        if core.last().map(|c| c.0) != Some(a) {
            core.push((a, i));
        }
    }
    let q = if q.length_squared() > 0.0 && q.is_finite() {
        q.normalize()
    } else {
        DQuat::IDENTITY
    };
    let angles: Vec<f64> = match core.as_slice() {
        [] => Vec::new(),
        [(a, _)] => vec![twist_angle(q, *a)],
        [(a, _), (b, _)] => {
            let third = Axis::from_index(3 - a.index() - b.index());
            euler3(q, *a, *b, third)[..2].to_vec()
        }
        [(a, _), (b, _), (c, _), ..] => euler3(q, *a, *b, *c).to_vec(),
    };
    for ((_, i), angle) in core.iter().zip(angles) {
        out[*i] = angle;
    }
    out
}

/// Signed angle of the rotation about `axis` contained in `q` (its twist), in (−π, π].
fn twist_angle(q: DQuat, axis: Axis) -> f64 {
    let v = [q.x, q.y, q.z][axis.index()];
    let q_w = q.w;
    let mut a = 2.0 * v.atan2(q_w);
    if a > std::f64::consts::PI {
        a -= std::f64::consts::TAU;
    } else if a <= -std::f64::consts::PI {
        a += std::f64::consts::TAU;
    }
    a
}

/// `[a, b, c]` with `R_i(a)·R_j(b)·R_k(c) = q`, for `i ≠ j`, `j ≠ k` (`i = k` allowed).
fn euler3(q: DQuat, i: Axis, j: Axis, k: Axis) -> [f64; 3] {
    let m = DMat3::from_quat(q);
    let e = |r: usize, c: usize| m.col(c)[r];
    let (ii, jj) = (i.index(), j.index());
    // +1 when (i, j, ·) turns like (x, y, z), −1 otherwise.
    let s = if (ii + 1) % 3 == jj { 1.0 } else { -1.0 };
    let (a, b) = if i != k {
        let kk = k.index();
        let cb = e(ii, ii).hypot(e(ii, jj));
        let b = (s * e(ii, kk)).atan2(cb);
        let a = if cb > GIMBAL_EPS {
            (-s * e(jj, kk)).atan2(e(kk, kk))
        } else {
            0.0
        };
        (a, b)
    } else {
        let kk = 3 - ii - jj;
        let sb = e(ii, jj).hypot(e(ii, kk));
        let b = sb.atan2(e(ii, ii));
        let a = if sb > GIMBAL_EPS {
            e(jj, ii).atan2(-s * e(kk, ii))
        } else {
            0.0
        };
        (a, b)
    };
    // The last angle from what is left, so the product is exact even at gimbal lock.
    let rest = DMat3::from_quat(
        (DQuat::from_axis_angle(i.unit(), a) * DQuat::from_axis_angle(j.unit(), b)).conjugate() * q,
    );
    let p = (k.index() + 1) % 3;
    let r = (k.index() + 2) % 3;
    let c = rest.col(p)[r].atan2(rest.col(p)[p]);
    [a, b, c]
}

/// Loads a BVH file; see the module docs for what is detected and how it is converted.
pub fn load(path: &Path, opts: &ImportOptions) -> Result<Character> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let text = String::from_utf8_lossy(&bytes);
    parse(&text, path, opts)
}

/// Parses BVH text; `path` is only used to name the file in errors and the character.
pub fn parse(text: &str, path: &Path, opts: &ImportOptions) -> Result<Character> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let lines = split_lines(text);
    let motion_line = lines.iter().position(|l| {
        l.split_whitespace()
            .next()
            .is_some_and(|t| t.eq_ignore_ascii_case("MOTION"))
    });
    // Where a truncated file ends: its last line with anything on it.
    let last_content_line = lines
        .iter()
        .rposition(|l| !l.trim().is_empty())
        .map_or(1, |i| i + 1);
    let hierarchy_end = motion_line.unwrap_or(lines.len());
    let mut parser = Parser {
        path,
        tokens: tokenize(&lines[..hierarchy_end]),
        pos: 0,
        eof_line: motion_line.map_or(last_content_line, |i| i + 1),
    };
    let joints = parser.hierarchy()?;
    let Some(motion_line) = motion_line else {
        return Err(parse_error(
            path,
            last_content_line,
            "the file ends without a MOTION section",
        ));
    };
    let motion = parse_motion(path, &lines, motion_line, &joints)?;

    let positions = rest_positions(&joints);
    let up = opts.up.unwrap_or_else(|| detect_up(&positions));
    let metres_per_unit = match opts.units {
        Some(u) => f64::from(u.to_metres()),
        None => detect_metres_per_unit(&positions, up),
    };
    let c = up_rotation(up);
    let s = metres_per_unit;

    let to_transform = |parent: Option<usize>, t: DVec3, r: DQuat| -> Transform {
        let (t, r) = match parent {
            None => (c * (t * s), c * r),
            Some(_) => (t * s, r),
        };
        Transform::new(t.as_vec3(), r.normalize().as_quat())
    };

    let skel_joints: Vec<Joint> = joints
        .iter()
        .map(|j| Joint {
            name: j.name.clone(),
            parent: j.parent,
            rest: to_transform(j.parent, j.offset, DQuat::IDENTITY),
            // An all-zero End Site says nothing about where the bone ends.
            tip: j
                .end_site
                .filter(|e| *e != DVec3::ZERO)
                .map(|e| (e * s).as_vec3()),
        })
        .collect();
    let skeleton = Skeleton::new(skel_joints)?;

    let frames: Vec<Vec<Transform>> = motion
        .values
        .chunks(motion.channels.max(1))
        .take(motion.frames)
        .map(|row| {
            let mut col = 0;
            joints
                .iter()
                .map(|j| {
                    let n = j.channels.len();
                    let vals = row.get(col..col + n).unwrap_or(&[]);
                    col += n;
                    let (t, r) = joint_motion(j, vals);
                    to_transform(j.parent, t, r)
                })
                .collect()
        })
        .collect();
    let frames = if motion.channels == 0 {
        let rest: Vec<Transform> = skeleton.joints().iter().map(|j| j.rest).collect();
        vec![rest; motion.frames]
    } else {
        frames
    };
    if let Some((f, _)) = frames
        .iter()
        .enumerate()
        .find(|(_, fr)| fr.iter().any(|t| !t.is_finite()))
    {
        return Err(parse_error(
            path,
            motion.frame_lines.get(f).copied().unwrap_or(1),
            "the frame's values overflow once converted",
        ));
    }

    let frame_time = motion.frame_time as f32;
    let clips = if frames.is_empty() {
        Vec::new()
    } else {
        vec![Clip {
            name: String::new(),
            frame_time,
            frames,
        }]
    };
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
    Ok(Character {
        name,
        skeleton,
        meshes: Vec::new(),
        clips,
        source: Source::Bvh(layout),
    })
}

/// The rotation taking the file's axes to Y up (identity, or −90° about X for Z up).
pub(crate) fn up_rotation(up: UpAxis) -> DQuat {
    match up {
        UpAxis::Y => DQuat::IDENTITY,
        UpAxis::Z => DQuat::from_rotation_x(-std::f64::consts::FRAC_PI_2),
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

fn parse_error(path: &Path, line: usize, message: impl Into<String>) -> Error {
    Error::Parse {
        path: path.to_path_buf(),
        line,
        message: message.into(),
    }
}

/// Splits on `\n`, `\r\n`, or lone `\r` (old Mac files), so line numbers match editors.
fn split_lines(text: &str) -> Vec<&str> {
    if text.contains('\n') {
        text.split('\n')
            .map(|l| l.strip_suffix('\r').unwrap_or(l))
            .collect()
    } else {
        text.split('\r').collect()
    }
}

/// A hierarchy word with its 1-based line.
#[derive(Clone, Copy, Debug)]
struct Tok<'a> {
    line: usize,
    text: &'a str,
}

fn tokenize<'a>(lines: &[&'a str]) -> Vec<Tok<'a>> {
    lines
        .iter()
        .enumerate()
        .flat_map(|(i, l)| {
            l.split_whitespace()
                .map(move |text| Tok { line: i + 1, text })
        })
        .collect()
}

/// A joint as read from the hierarchy, in file units.
#[derive(Clone, Debug)]
struct PJoint {
    name: String,
    parent: Option<usize>,
    line: usize,
    offset: DVec3,
    has_offset: bool,
    channels: Vec<Channel>,
    has_channels: bool,
    end_site: Option<DVec3>,
}

struct Parser<'a, 'p> {
    path: &'p Path,
    tokens: Vec<Tok<'a>>,
    pos: usize,
    /// The line to blame when the hierarchy runs out.
    eof_line: usize,
}

impl<'a> Parser<'a, '_> {
    fn err(&self, line: usize, message: impl Into<String>) -> Error {
        parse_error(self.path, line, message)
    }

    fn peek(&self) -> Option<Tok<'a>> {
        self.tokens.get(self.pos).copied()
    }

    fn next(&mut self, expected: &str) -> Result<Tok<'a>> {
        match self.peek() {
            Some(t) => {
                self.pos += 1;
                Ok(t)
            }
            None => Err(self.err(
                self.eof_line,
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
        parse_number(t.text)
            .ok_or_else(|| self.err(t.line, format!("expected {what}, found \"{}\"", t.text)))
    }

    /// The rest of the keyword's line (a joint name may contain spaces), minus a trailing
    /// `{` some writers put on the same line.
    fn name_after(&mut self, keyword: Tok<'a>) -> String {
        let mut words = Vec::new();
        while let Some(t) = self.peek() {
            if t.line != keyword.line || t.text == "{" {
                break;
            }
            words.push(t.text);
            self.pos += 1;
        }
        words.join(" ")
    }

    fn offset(&mut self) -> Result<DVec3> {
        let x = self.number("the OFFSET's X value")?;
        let y = self.number("the OFFSET's Y value")?;
        let z = self.number("the OFFSET's Z value")?;
        Ok(DVec3::new(x, y, z))
    }

    fn hierarchy(&mut self) -> Result<Vec<PJoint>> {
        match self.peek() {
            Some(t) if t.text.eq_ignore_ascii_case("HIERARCHY") => self.pos += 1,
            Some(t) => {
                return Err(self.err(
                    t.line,
                    format!(
                        "expected \"HIERARCHY\" at the start of a BVH file, found \"{}\"",
                        t.text
                    ),
                ));
            }
            None => {
                return Err(self.err(self.eof_line, "the file has no HIERARCHY section"));
            }
        }
        let mut joints: Vec<PJoint> = Vec::new();
        let mut open: Vec<usize> = Vec::new();
        loop {
            let Some(tok) = self.peek() else {
                if let Some(&j) = open.last() {
                    return Err(self.err(
                        self.eof_line,
                        format!(
                            "the hierarchy ends here, but joint \"{}\" (line {}) has no closing \"}}\"",
                            joints[j].name, joints[j].line
                        ),
                    ));
                }
                if joints.is_empty() {
                    return Err(self.err(self.eof_line, "the hierarchy has no ROOT joint"));
                }
                return Ok(joints);
            };
            self.pos += 1;
            let word = tok.text;
            let Some(&current) = open.last() else {
                if word.eq_ignore_ascii_case("ROOT") {
                    let name = self.name_after(tok);
                    self.expect("{")?;
                    joints.push(new_joint(name, None, tok.line));
                    open.push(joints.len() - 1);
                    continue;
                }
                return Err(self.err(
                    tok.line,
                    format!("expected \"ROOT\" or \"MOTION\", found \"{word}\""),
                ));
            };
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
                let mut channels = Vec::with_capacity(n.min(16));
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
                joints[current].channels = channels;
                joints[current].has_channels = true;
            } else if word.eq_ignore_ascii_case("JOINT") {
                let name = self.name_after(tok);
                self.expect("{")?;
                joints.push(new_joint(name, Some(current), tok.line));
                open.push(joints.len() - 1);
            } else if word.eq_ignore_ascii_case("End") {
                if self
                    .peek()
                    .is_some_and(|t| t.text.eq_ignore_ascii_case("Site"))
                {
                    self.pos += 1;
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
        }
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
fn parse_number(s: &str) -> Option<f64> {
    let v: f64 = s.parse().ok()?;
    (v.is_finite() && (v as f32).is_finite()).then_some(v)
}

/// Case-insensitive ASCII prefix strip that cannot split a UTF-8 character.
fn strip_prefix_ci<'s>(s: &'s str, prefix: &str) -> Option<&'s str> {
    let head = s.get(..prefix.len())?;
    head.eq_ignore_ascii_case(prefix)
        .then(|| s.get(prefix.len()..))
        .flatten()
}

/// The value after `key` on a header line such as `Frames: 12` or `Frame Time:\t0.01`.
fn header_value<'s>(line: &'s str, key: &[&str]) -> Option<&'s str> {
    let mut rest = line.trim();
    for (i, word) in key.iter().enumerate() {
        if i > 0 {
            rest = rest.trim_start();
        }
        rest = strip_prefix_ci(rest, word)?;
    }
    let rest = rest.trim_start();
    let rest = rest.strip_prefix(':').unwrap_or(rest);
    Some(rest.trim())
}

struct Motion {
    frames: usize,
    frame_time: f64,
    channels: usize,
    /// All values, frame after frame.
    values: Vec<f64>,
    /// 1-based line of each frame.
    frame_lines: Vec<usize>,
}

fn parse_motion(
    path: &Path,
    lines: &[&str],
    motion_line: usize,
    joints: &[PJoint],
) -> Result<Motion> {
    let channels: usize = joints.iter().map(|j| j.channels.len()).sum();
    let mut rest = lines
        .iter()
        .enumerate()
        .skip(motion_line + 1)
        .filter(|(_, l)| !l.trim().is_empty());
    let Some((i, line)) = rest.next() else {
        return Err(parse_error(
            path,
            motion_line + 1,
            "the file ends after MOTION; expected \"Frames: <count>\"",
        ));
    };
    let frames: usize = header_value(line, &["Frames"])
        .ok_or_else(|| {
            parse_error(
                path,
                i + 1,
                format!("expected \"Frames: <count>\", found \"{}\"", line.trim()),
            )
        })?
        .parse()
        .map_err(|_| {
            parse_error(
                path,
                i + 1,
                format!("the frame count is not a whole number: \"{}\"", line.trim()),
            )
        })?;
    let frames_line = i + 1;
    // The clip holds frames × joints transforms; refuse sizes that would exhaust memory
    // (a crash, not an error) rather than trust the count or a pathological hierarchy.
    if frames.saturating_mul(joints.len()) > MAX_CLIP_TRANSFORMS {
        return Err(parse_error(
            path,
            frames_line,
            format!(
                "{frames} frames of {} joints exceed the {MAX_CLIP_TRANSFORMS} joint poses this importer holds in memory",
                joints.len()
            ),
        ));
    }

    let Some((i, line)) = rest.next() else {
        return Err(parse_error(
            path,
            frames_line,
            "the file ends before \"Frame Time: <seconds>\"",
        ));
    };
    let frame_time = header_value(line, &["Frame", "Time"]).ok_or_else(|| {
        parse_error(
            path,
            i + 1,
            format!(
                "expected \"Frame Time: <seconds>\", found \"{}\"",
                line.trim()
            ),
        )
    })?;
    let frame_time = parse_number(frame_time)
        .filter(|t| *t > 0.0)
        .ok_or_else(|| {
            parse_error(
                path,
                i + 1,
                format!(
                    "the frame time is not a positive number: \"{}\"",
                    line.trim()
                ),
            )
        })?;
    let mut last_line = i + 1;

    // Each value takes at least two bytes of text, which bounds what is worth reserving.
    let text_bytes: usize = lines.iter().skip(motion_line).map(|l| l.len() + 1).sum();
    let mut values = Vec::with_capacity(frames.saturating_mul(channels).min(text_bytes / 2));
    let mut frame_lines = Vec::with_capacity(frames.min(lines.len()));
    for (i, line) in rest {
        let line_no = i + 1;
        if frame_lines.len() >= frames {
            return Err(parse_error(
                path,
                line_no,
                format!(
                    "more frame lines than the {frames} that \"Frames:\" (line {frames_line}) announces"
                ),
            ));
        }
        let n = line.split_whitespace().count();
        if n != channels {
            return Err(parse_error(
                path,
                line_no,
                format!(
                    "frame {} has {n} values, but the hierarchy has {channels} channels",
                    frame_lines.len() + 1
                ),
            ));
        }
        for (k, word) in line.split_whitespace().enumerate() {
            let v = parse_number(word).ok_or_else(|| {
                parse_error(
                    path,
                    line_no,
                    format!(
                        "value {} of frame {} is not a finite number: \"{word}\"",
                        k + 1,
                        frame_lines.len() + 1
                    ),
                )
            })?;
            values.push(v);
        }
        frame_lines.push(line_no);
        last_line = line_no;
    }
    if frame_lines.len() < frames && channels > 0 {
        return Err(parse_error(
            path,
            last_line + 1,
            format!(
                "the motion data ends after {} frames, but \"Frames:\" (line {frames_line}) announces {frames}",
                frame_lines.len()
            ),
        ));
    }
    Ok(Motion {
        frames,
        frame_time,
        channels,
        values,
        frame_lines,
    })
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
fn detect_metres_per_unit(points: &[DVec3], up: UpAxis) -> f64 {
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

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{EulerRot, Quat};

    const ALL_ORDERS: [[Axis; 3]; 6] = [
        [Axis::X, Axis::Y, Axis::Z],
        [Axis::X, Axis::Z, Axis::Y],
        [Axis::Y, Axis::X, Axis::Z],
        [Axis::Y, Axis::Z, Axis::X],
        [Axis::Z, Axis::X, Axis::Y],
        [Axis::Z, Axis::Y, Axis::X],
    ];

    /// A small deterministic generator (xorshift), so tests need no extra crate.
    struct Rng(u64);
    impl Rng {
        fn next_f64(&mut self) -> f64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }
        fn angle(&mut self) -> f64 {
            (self.next_f64() * 2.0 - 1.0) * std::f64::consts::PI
        }
    }

    /// Compares rotations by what they do to the axes (`angle_between` goes through `acos`,
    /// which cannot resolve angles below about 1e-8 in f64 or 3e-4 in f32).
    fn same_rotation(a: DQuat, b: DQuat, tol: f64) -> bool {
        [DVec3::X, DVec3::Y, DVec3::Z]
            .iter()
            .all(|v| (a * *v - b * *v).length() < tol)
    }

    fn p(s: &str) -> Result<Character> {
        parse(s, Path::new("test.bvh"), &ImportOptions::default())
    }

    #[test]
    fn bvh_channel_order_is_glam_intrinsic_euler() {
        let (a, b, c) = (0.3, -1.1, 2.4);
        let ours = compose_rotation(&[Axis::Z, Axis::X, Axis::Y], &[a, b, c]);
        let glam = DQuat::from_euler(EulerRot::ZXY, a, b, c);
        let explicit =
            DQuat::from_rotation_z(a) * DQuat::from_rotation_x(b) * DQuat::from_rotation_y(c);
        assert!(same_rotation(ours, glam, 1e-12));
        assert!(same_rotation(ours, explicit, 1e-12));
    }

    #[test]
    fn bvh_euler_round_trip_all_orders() {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        let mut orders: Vec<[Axis; 3]> = ALL_ORDERS.to_vec();
        // Proper Euler orders too.
        orders.extend([
            [Axis::Z, Axis::X, Axis::Z],
            [Axis::X, Axis::Z, Axis::X],
            [Axis::Y, Axis::X, Axis::Y],
        ]);
        for order in orders {
            for n in 0..2000 {
                let mut angles = [rng.angle(), rng.angle() * 0.5, rng.angle()];
                if n % 10 == 0 {
                    // Gimbal lock and its neighbourhood.
                    angles[1] = std::f64::consts::FRAC_PI_2 * if n % 20 == 0 { 1.0 } else { -1.0 };
                }
                if n % 7 == 0 && order[0] == order[2] {
                    angles[1] = 0.0;
                }
                let q = compose_rotation(&order, &angles);
                let back = decompose_rotation(q, &order);
                let q2 = compose_rotation(&order, &back);
                assert!(
                    same_rotation(q, q2, 1e-9),
                    "{order:?} {angles:?} -> {back:?}"
                );
                if n % 10 != 0 && order[0] != order[2] {
                    // Away from gimbal lock, Tait–Bryan angles with |b| < 90° are unique.
                    for (x, y) in angles.iter().zip(&back) {
                        assert!((x - y).abs() < 1e-9, "{order:?} {angles:?} -> {back:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn bvh_euler_matches_glam_for_tait_bryan() {
        let mut rng = Rng(12345);
        let rots = [
            EulerRot::XYZ,
            EulerRot::XZY,
            EulerRot::YXZ,
            EulerRot::YZX,
            EulerRot::ZXY,
            EulerRot::ZYX,
        ];
        for (order, rot) in ALL_ORDERS.iter().zip(rots) {
            let a = [rng.angle(), rng.angle() * 0.4, rng.angle()];
            let q = DQuat::from_euler(rot, a[0], a[1], a[2]);
            let ours = decompose_rotation(q, order);
            for (x, y) in a.iter().zip(&ours) {
                assert!((x - y).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn bvh_euler_best_effort_for_fewer_axes() {
        let q = compose_rotation(&[Axis::Y], &[0.7]);
        assert!((decompose_rotation(q, &[Axis::Y])[0] - 0.7).abs() < 1e-12);
        let q = compose_rotation(&[Axis::X, Axis::Z], &[0.4, -1.2]);
        let back = decompose_rotation(q, &[Axis::X, Axis::Z]);
        assert!((back[0] - 0.4).abs() < 1e-9 && (back[1] + 1.2).abs() < 1e-9);
        let back = decompose_rotation(q, &[Axis::X, Axis::X, Axis::Z]);
        assert!((back[0] - 0.4).abs() < 1e-9 && back[1] == 0.0 && (back[2] + 1.2).abs() < 1e-9);
        assert!(decompose_rotation(q, &[]).is_empty());
    }

    #[test]
    fn bvh_unit_thresholds() {
        let pts = |h: f64| vec![DVec3::ZERO, DVec3::new(0.0, h, 0.0)];
        let u = |h: f64| detect_metres_per_unit(&pts(h), UpAxis::Y);
        assert_eq!(u(1.8), 1.0);
        assert_eq!(u(31.0), CMU_UNIT_M as f64);
        assert_eq!(u(72.35), 0.0254);
        assert_eq!(u(152.7), 0.01);
        assert_eq!(u(1750.0), 0.001);
        assert_eq!(u(0.0), 0.01);
    }

    #[test]
    fn bvh_names_are_sanitised() {
        let names = sanitise_names(["", "a b", "x", "x", "x_2", "{"].into_iter());
        assert_eq!(names, ["joint0", "a_b", "x", "x_2", "x_2_2", "_"]);
    }

    #[test]
    fn bvh_position_channels_on_child_replace_offset() {
        let text = "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n\
                    JOINT b\n{\nOFFSET 0 100 0\nCHANNELS 4 Xposition Yrotation Zposition Xrotation\n\
                    End Site\n{\nOFFSET 0 50 0\n}\n}\n}\nMOTION\nFrames: 1\nFrame Time: 0.5\n\
                    0 0 0 7 90 8 0\n";
        let c = p(text).unwrap();
        let f = &c.clips[0].frames[0][1];
        // Xposition and Zposition replace, Y keeps the offset (cm: height 150 units).
        assert!(
            (f.translation - Vec3::new(0.07, 1.0, 0.08)).length() < 1e-6,
            "{f:?}"
        );
        let expected = Quat::from_rotation_y(std::f32::consts::FRAC_PI_2);
        assert!(same_rotation(
            f.rotation.as_dquat(),
            expected.as_dquat(),
            1e-6
        ));
        assert_eq!(c.clips[0].frame_time, 0.5);
    }

    #[test]
    fn bvh_zero_channels_and_multiple_roots() {
        let text = "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nEnd Site\n{\nOFFSET 0 170 0\n}\n}\n\
                    ROOT b\n{\nOFFSET 50 0 0\nCHANNELS 1 Yrotation\n}\nMOTION\nFrames: 2\nFrame Time: 0.1\n10\n20\n";
        let c = p(text).unwrap();
        assert_eq!(c.skeleton.len(), 2);
        assert_eq!(c.skeleton.parent(1), None);
        assert_eq!(c.clips[0].frames.len(), 2);
        let hierarchy_only =
            "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\n}\nMOTION\nFrames: 3\nFrame Time: 0.1\n";
        assert_eq!(p(hierarchy_only).unwrap().clips[0].frames.len(), 3);
    }

    #[test]
    fn bvh_errors_name_the_line() {
        let line = |s: &str| match p(s) {
            Err(Error::Parse { line, message, .. }) => (line, message),
            other => panic!("expected a parse error, got {other:?}"),
        };
        let base = "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 2 Xrotation Yrotation\n}\nMOTION\nFrames: 2\nFrame Time: 0.1\n";
        assert_eq!(line(&format!("{base}1 2\n")).0, 11);
        assert_eq!(line(&format!("{base}1 2\n1\n")).0, 11);
        assert_eq!(line(&format!("{base}1 2\n1 x\n")).0, 11);
        assert_eq!(line(&format!("{base}1 2\n1 2\n3 4\n")).0, 12);
        assert_eq!(line(&format!("{base}1 2\n1 inf\n")).0, 11);
        assert_eq!(line("HIERARCHY\nROOT a\n{\nOFFSET 0 0\n}\n").0, 5);
        assert_eq!(line("HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\n").0, 4);
        assert_eq!(line("HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nMOTION\n").0, 5);
        assert_eq!(line("HIERARCHY\nROOT a\n{\nCHANNELS 1 Wrotation\n}\n").0, 4);
        assert_eq!(
            line("HIERARCHY\nROOT a\n{\nCHANNELS 1 Xrotation\n}\nMOTION\n").0,
            2
        );
        assert_eq!(line("hello\n").0, 1);
        let huge = "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\n}\nMOTION\nFrames: 99999999999999\nFrame Time: 1\n";
        assert_eq!(line(huge).0, 7);
        assert_eq!(line("").0, 1);
        let (l, m) = line(&base.replace("Frame Time: 0.1", "Frame Time: 0"));
        assert_eq!(l, 9, "{m}");
    }
}
