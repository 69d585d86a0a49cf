//! Reading BVH text: the hierarchy (`hierarchy.rs`), then the unit and up-axis detection
//! (see the parent module's docs) and the motion (`motion.rs`), into a character.
//!
//! Nothing here holds more than one frame's numbers at a time or recurses on the file's
//! nesting, so memory is the joints plus the clip (bounded by
//! [`MAX_CLIP_POSES`](crate::skeleton::MAX_CLIP_POSES)) and a hierarchy nested tens of
//! thousands deep parses like a flat one.

use std::path::Path;

use glam::{DQuat, DVec3};

use super::hierarchy::{PJoint, read_hierarchy};
use super::text::parse_error;

use super::{
    BvhJoint, BvhLayout, CMU_UNIT_M, Channel, TYPICAL_SPAN_M, UNIT_CANDIDATES, compose_rotation,
    up_rotation,
};
use crate::error::Result;
use crate::import::{ImportOptions, UpAxis};
use crate::math::Transform;
use crate::skeleton::{Character, Clip, Joint, MAX_REACH_M, Skeleton, Source};

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
/// any text gives a [`Character`] or an [`Error::Parse`](crate::error::Error::Parse) naming a line, never a panic.
pub fn parse(text: &str, path: &Path, opts: &ImportOptions) -> Result<Character> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let (joints, motion_line, mut lines) = read_hierarchy(text, path)?;

    let positions = rest_positions(&joints);
    let up = opts.up.unwrap_or_else(|| detect_up(&positions));
    let metres_per_unit = match opts.units {
        Some(u) => f64::from(u.to_metres()),
        None => metres_per_unit_of_span(span(&joints)),
    };
    let convert = Convert {
        c: up_rotation(up),
        s: metres_per_unit,
    };
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
    }
    if opts.units.is_none() {
        centimetres_unless_a_person(&mut character, path)?;
    }
    Ok(character)
}

/// Inches and CMU units are a person's: the heights that pick them (module docs) are a
/// person's in those units, and the files that use them are human mocap (the Biovision
/// sample, CMU's conversions). A creature of those heights is a creature in centimetres,
/// the common BVH unit: a dog 80 units tall is 0.8 m, not 2 m.
fn centimetres_unless_a_person(c: &mut Character, path: &Path) -> Result<()> {
    let Source::Bvh(layout) = &c.source else {
        return Ok(());
    };
    let m = f64::from(layout.metres_per_unit);
    let persons = [0.0254, f64::from(CMU_UNIT_M)];
    if !persons.iter().any(|u| (m / u - 1.0).abs() < 1e-6)
        || crate::spec::recognise_roles(c).humanoid
    {
        return Ok(());
    }
    crate::import::size::scale(c, (0.01 / m) as f32, path)
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

/// Z up when the rest pose is more than twice as tall along Z as along Y and stands along
/// Z, at least half as tall as it is long (module docs).
fn detect_up(points: &[DVec3]) -> UpAxis {
    let e = extent(points);
    if e.z > 2.0 * e.y && e.z >= 0.5 * e.x {
        UpAxis::Z
    } else {
        UpAxis::Y
    }
}

/// The skeleton's span in file units: the longest path between two of its points (joints
/// and End Sites) along its bones. Bone lengths do not depend on the pose the offsets are
/// written in, so neither does the span: a person's is toe to fingertip, about 1.5 times
/// their height, whether the rest pose stands, lies along the ground, or has every bone
/// along its own local axis (Bandai Namco's files, whose centimetre person stood 100 units
/// tall and was read as inches, 2.55 m). The root's own offset is no bone.
///
/// Linear in the joints: each joint's two longest branches, children before parents.
pub(super) fn span(joints: &[PJoint]) -> f64 {
    let n = joints.len();
    // The two longest branches below each joint.
    let mut top = vec![(0.0f64, 0.0f64); n];
    let push = |t: &mut (f64, f64), len: f64| {
        if len > t.0 {
            *t = (len, t.0);
        } else if len > t.1 {
            t.1 = len;
        }
    };
    for (i, j) in joints.iter().enumerate() {
        if let Some(e) = j.end_site {
            push(&mut top[i], e.length());
        }
    }
    let mut best = 0.0f64;
    for i in (0..n).rev() {
        let (a, b) = top[i];
        best = best.max(a + b);
        if let Some(p) = joints[i].parent.filter(|&p| p < i) {
            push(&mut top[p], a + joints[i].offset.length());
        }
    }
    if best.is_finite() { best } else { 0.0 }
}

/// Metres per unit making the span closest to [`TYPICAL_SPAN_M`] (module docs);
/// centimetres for a skeleton with no span at all.
pub(super) fn metres_per_unit_of_span(span: f64) -> f64 {
    if !(span > 1e-9 && span.is_finite()) {
        return 0.01;
    }
    let miss = |u: f64| (span * u / TYPICAL_SPAN_M).ln().abs();
    UNIT_CANDIDATES
        .into_iter()
        .min_by(|a, b| miss(*a).total_cmp(&miss(*b)))
        .unwrap_or(0.01)
}
