//! BVH export in the source's hierarchy, names, channel order, units and up axis, so a
//! BVH that came in goes back out in a shape the user's other tools already read.
//!
//! # How a track becomes channels
//!
//! BVH has no rest rotations and no scale: a joint's world transform is
//! `parent · T(offset or position channels) · R(rotation channels)`, and all channels at
//! zero is the rest pose. The exporter keeps that meaning: every BVH joint frame is the
//! joint's motion relative to its rest pose, expressed in the file's world axes,
//!
//! ```text
//! F_j = C⁻¹ · R_j · Rrest_j⁻¹ · C        P_j = C⁻¹ · p_j / metres_per_unit
//! ```
//!
//! (`R_j`, `p_j`: the track's world rotation and position; `Rrest_j`: the rest-pose world
//! rotation; `C`: the up-axis rotation). Rotation channels hold `F_parent⁻¹ · F_j`,
//! decomposed into the joint's own channel order; position channels hold
//! `F_parent⁻¹ · (P_j − P_parent)` (for roots, `P_j` itself); `OFFSET`s are the rest-pose
//! differences `P_j − P_parent`, so a parent's rest scale is folded in.
//!
//! For a character read from BVH every rest world rotation is `C`, so `F_j` is the file's
//! own joint rotation and the file comes back with the same numbers. For other characters
//! (glTF, the built-in humanoid), whose rest pose has rotations, this writes the rest pose
//! as the `OFFSET`s (a viewer shows the real T-pose, and unit detection on re-import sees
//! the real height) with zero channels at rest, which is what BVH tools expect; world
//! positions match the track either way. The joint frames are then world-aligned at rest,
//! so they differ from the source's joint orientations by the rest rotations.
//!
//! Where a joint has no position channels its offset is all BVH can express: if the track
//! moves that joint relative to its parent (a stretched physics joint), that stretch is
//! lost. Joints with fewer than three rotation channels get the best-effort angles of
//! [`decompose_rotation`].

use std::fmt::Write as _;

use glam::{DQuat, DVec3, Vec3};

use crate::error::{Error, Result};
use crate::import::bvh::{
    Axis, BvhJoint, BvhLayout, Channel, decompose_rotation, sanitise_names, up_rotation,
};
use crate::math::Transform;
use crate::skeleton::{Character, Skeleton, Source};
use crate::track::Track;

/// Writes `track` as BVH text, in the layout of the character's source file when it was a
/// BVH, else in [`BvhLayout::from_skeleton`]'s (centimetres, Y up, `ZXY` rotations).
///
/// `Frame Time` is `1 / track.fps`.
pub fn to_bvh(character: &Character, track: &Track) -> Result<String> {
    let skeleton = &character.skeleton;
    match &character.source {
        Source::Bvh(layout) => to_bvh_with_layout(skeleton, layout, track),
        _ => to_bvh_with_layout(skeleton, &BvhLayout::from_skeleton(skeleton), track),
    }
}

/// Writes `track` as BVH text in an explicit layout, for callers that want another dialect
/// (say, metres or Z up) than the source's.
pub fn to_bvh_with_layout(
    skeleton: &Skeleton,
    layout: &BvhLayout,
    track: &Track,
) -> Result<String> {
    check_layout(skeleton, layout)?;
    check_track(skeleton, track)?;

    let n = skeleton.len();
    let order = depth_first(skeleton);
    let rest_world = skeleton.rest_world();
    let space = FileSpace::new(skeleton, layout, &rest_world);
    let rest = space.locals(&rest_world, true);

    let mut out = String::with_capacity(64 * n + track.frames.len() * n * 30);
    write_hierarchy(&mut out, skeleton, layout, &order, &rest);
    write_motion(&mut out, layout, track, &order, &space);
    Ok(out)
}

/// Rejects a layout that cannot describe this skeleton, before any text is written.
fn check_layout(skeleton: &Skeleton, layout: &BvhLayout) -> Result<()> {
    let n = skeleton.len();
    if layout.joints.len() != n {
        return Err(Error::Skeleton {
            joint: String::new(),
            message: format!(
                "the BVH layout describes {} joints but the skeleton has {n}",
                layout.joints.len()
            ),
        });
    }
    if !(layout.metres_per_unit.is_finite() && layout.metres_per_unit > 0.0) {
        return Err(Error::Setting {
            setting: "units".into(),
            message: format!(
                "metres per BVH unit must be a positive number, not {}",
                layout.metres_per_unit
            ),
        });
    }
    Ok(())
}

/// Rejects a track that would give a meaningless `Frame Time`, misaligned motion columns or
/// non-numeric channel values.
fn check_track(skeleton: &Skeleton, track: &Track) -> Result<()> {
    let n = skeleton.len();
    if !(track.fps.is_finite() && track.fps > 0.0) {
        return Err(Error::Setting {
            setting: "fps".into(),
            message: format!(
                "the frame rate must be a positive number, not {}",
                track.fps
            ),
        });
    }
    for (f, frame) in track.frames.iter().enumerate() {
        if frame.len() != n {
            return Err(Error::Skeleton {
                joint: String::new(),
                message: format!(
                    "track frame {f} has {} transforms but the skeleton has {n} joints",
                    frame.len()
                ),
            });
        }
        if let Some(j) = frame.iter().position(|t| !t.is_finite()) {
            return Err(Error::Skeleton {
                joint: skeleton.joint_label(j),
                message: format!("track frame {f} holds a non-finite transform"),
            });
        }
    }
    Ok(())
}

/// The mapping from the track's world transforms to the file's joint-local channels (module
/// docs), set up once per export because every frame goes through it.
struct FileSpace<'a> {
    skeleton: &'a Skeleton,
    /// The up-axis rotation `C` and its inverse.
    c: DQuat,
    c_inv: DQuat,
    units_per_metre: f64,
    /// `Rrest_j⁻¹` of every joint.
    rest_inv: Vec<DQuat>,
}

impl<'a> FileSpace<'a> {
    fn new(skeleton: &'a Skeleton, layout: &BvhLayout, rest_world: &[Transform]) -> Self {
        let c = up_rotation(layout.up);
        FileSpace {
            skeleton,
            c,
            c_inv: c.conjugate(),
            units_per_metre: 1.0 / f64::from(layout.metres_per_unit),
            rest_inv: rest_world
                .iter()
                .map(|w| w.rotation.as_dquat().normalize().conjugate())
                .collect(),
        }
    }

    /// File-space local transform (translation, rotation) of every joint (module docs).
    /// `at_rest` gives identity frames, because at rest all rotation channels are zero.
    fn locals(&self, worlds: &[Transform], at_rest: bool) -> Vec<(DVec3, DQuat)> {
        let frames: Vec<(DVec3, DQuat)> = worlds
            .iter()
            .zip(&self.rest_inv)
            .map(|(w, ri)| {
                let p = self.c_inv * w.translation.as_dvec3() * self.units_per_metre;
                let f = if at_rest {
                    DQuat::IDENTITY
                } else {
                    (self.c_inv * w.rotation.as_dquat().normalize() * *ri * self.c).normalize()
                };
                (p, f)
            })
            .collect();
        (0..self.skeleton.len())
            .map(|i| match self.skeleton.parent(i) {
                None => frames[i],
                Some(p) => {
                    let inv = frames[p].1.conjugate();
                    (
                        inv * (frames[i].0 - frames[p].0),
                        (inv * frames[i].1).normalize(),
                    )
                }
            })
            .collect()
    }
}

/// Writes the `HIERARCHY` section in `order`, the same depth-first order as the motion
/// columns; `rest` (the rest pose in file space) supplies the `OFFSET`s.
fn write_hierarchy(
    out: &mut String,
    skeleton: &Skeleton,
    layout: &BvhLayout,
    order: &DepthFirst,
    rest: &[(DVec3, DQuat)],
) {
    out.push_str("HIERARCHY\n");
    let names = sanitise_names(layout.joints.iter().map(|j| j.name.as_str()));
    // (joint, opening): each joint is visited once to open its block and once to close it
    // after its children.
    let mut stack: Vec<(usize, bool)> = order.roots.iter().rev().map(|&r| (r, true)).collect();
    let mut depth = vec![0usize; skeleton.len()];
    while let Some((j, opening)) = stack.pop() {
        let d = depth[j];
        let pad = "\t".repeat(d);
        let joint = &layout.joints[j];
        if opening {
            let is_root = skeleton.parent(j).is_none();
            write_joint_open(out, &pad, is_root, &names[j], rest[j].0, joint);
            stack.push((j, false));
            for &c in order.children[j].iter().rev() {
                depth[c] = d + 1;
                stack.push((c, true));
            }
        } else {
            write_joint_close(out, &pad, joint, order.children[j].is_empty());
        }
    }
}

/// Writes a joint's header, `OFFSET` and `CHANNELS` lines, leaving its block open for its
/// children.
fn write_joint_open(
    out: &mut String,
    pad: &str,
    is_root: bool,
    name: &str,
    offset: DVec3,
    joint: &BvhJoint,
) {
    let kw = if is_root { "ROOT" } else { "JOINT" };
    let _ = writeln!(out, "{pad}{kw} {name}");
    let _ = writeln!(out, "{pad}{{");
    write_offset(out, &format!("{pad}\t"), offset);
    let _ = write!(out, "{pad}\tCHANNELS {}", joint.channels.len());
    for c in &joint.channels {
        let _ = write!(out, " {}", c.name());
    }
    out.push('\n');
}

/// Closes a joint's block, after its `End Site` where it has one.
fn write_joint_close(out: &mut String, pad: &str, joint: &BvhJoint, is_leaf: bool) {
    let end = joint.end_site.or_else(|| {
        // Readers expect every leaf to end in an End Site; zero says "unknown".
        is_leaf.then_some(Vec3::ZERO)
    });
    if let Some(e) = end {
        let _ = writeln!(out, "{pad}\tEnd Site");
        let _ = writeln!(out, "{pad}\t{{");
        write_offset(out, &format!("{pad}\t\t"), e.as_dvec3());
        let _ = writeln!(out, "{pad}\t}}");
    }
    let _ = writeln!(out, "{pad}}}");
}

fn write_offset(out: &mut String, indent: &str, o: DVec3) {
    let _ = writeln!(out, "{indent}OFFSET {} {} {}", num(o.x), num(o.y), num(o.z));
}

/// Writes the `MOTION` section: the frame count and time, then one line per track frame.
fn write_motion(
    out: &mut String,
    layout: &BvhLayout,
    track: &Track,
    order: &DepthFirst,
    space: &FileSpace,
) {
    let _ = writeln!(out, "MOTION");
    let _ = writeln!(out, "Frames: {}", track.frames.len());
    let frame_time = 1.0 / f64::from(track.fps);
    let _ = writeln!(out, "Frame Time: {}", trim(format!("{frame_time:.9}")));
    let axes = rotation_axes(layout);
    for frame in &track.frames {
        write_frame(out, layout, order, &axes, &space.locals(frame, false));
    }
}

/// Each joint's rotation axes in channel order, worked out once rather than per frame, as
/// [`decompose_rotation`] needs them.
fn rotation_axes(layout: &BvhLayout) -> Vec<Vec<Axis>> {
    layout
        .joints
        .iter()
        .map(|j| {
            j.channels
                .iter()
                .filter_map(|c| match c {
                    Channel::Rotation(a) => Some(*a),
                    Channel::Position(_) => None,
                })
                .collect()
        })
        .collect()
}

/// Writes one motion line: joints in depth-first order to match the hierarchy, each
/// joint's channels in its own declared order.
fn write_frame(
    out: &mut String,
    layout: &BvhLayout,
    order: &DepthFirst,
    axes: &[Vec<Axis>],
    locals: &[(DVec3, DQuat)],
) {
    let mut first = true;
    for &j in &order.preorder {
        for v in channel_values(&layout.joints[j], &axes[j], locals[j]) {
            if !first {
                out.push(' ');
            }
            first = false;
            out.push_str(&num(v));
        }
    }
    out.push('\n');
}

/// A joint's channel values from its file-space local transform: positions in file units,
/// rotations in degrees. A rotation channel without an angle (fewer decomposed angles than
/// rotation channels) reads zero.
fn channel_values(joint: &BvhJoint, axes: &[Axis], (t, r): (DVec3, DQuat)) -> Vec<f64> {
    let angles = decompose_rotation(r, axes);
    let mut k = 0;
    joint
        .channels
        .iter()
        .map(|c| match c {
            Channel::Position(a) => t[a.index()],
            Channel::Rotation(_) => {
                let v = angles.get(k).copied().unwrap_or(0.0).to_degrees();
                k += 1;
                v
            }
        })
        .collect()
}

/// The hierarchy as BVH writes it: depth-first, children in index order. For a skeleton
/// imported from BVH this is the file's own order; for others (glTF lists joints in any
/// parents-first order) the motion columns must follow this order, not the index order.
struct DepthFirst {
    roots: Vec<usize>,
    children: Vec<Vec<usize>>,
    preorder: Vec<usize>,
}

fn depth_first(skeleton: &Skeleton) -> DepthFirst {
    let n = skeleton.len();
    let mut children = vec![Vec::new(); n];
    let mut roots = Vec::new();
    for i in 0..n {
        match skeleton.parent(i) {
            Some(p) => children[p].push(i),
            None => roots.push(i),
        }
    }
    let mut preorder = Vec::with_capacity(n);
    let mut stack: Vec<usize> = roots.iter().rev().copied().collect();
    while let Some(j) = stack.pop() {
        preorder.push(j);
        stack.extend(children[j].iter().rev());
    }
    DepthFirst {
        roots,
        children,
        preorder,
    }
}

/// Seven significant digits, at most six decimals: all the precision the crate's `f32`
/// values hold (printing more only shows rounding noise such as `94.999999` for 95 cm),
/// and still a few micrometres in any unit and a ten-thousandth of a degree for angles.
/// Trailing zeros are dropped to keep files small.
fn num(v: f64) -> String {
    let a = v.abs();
    let decimals = if a >= 1.0 && a.is_finite() {
        (6 - a.log10().floor() as i32).clamp(0, 6) as usize
    } else {
        6
    };
    trim(format!("{v:.decimals$}"))
}

fn trim(mut s: String) -> String {
    if s.contains('.') {
        while s.ends_with('0') {
            s.pop();
        }
        if s.ends_with('.') {
            s.pop();
        }
    }
    if s == "-0" {
        s = "0".into();
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::skeleton::humanoid;

    #[test]
    fn bvh_numbers_are_compact() {
        assert_eq!(num(0.0), "0");
        assert_eq!(num(-0.0000001), "0");
        assert_eq!(num(12.5), "12.5");
        assert_eq!(num(-3.0), "-3");
        assert_eq!(num(1.234_567_89), "1.234568");
        assert_eq!(num(94.999_998_807_907_1), "95");
        assert_eq!(num(-20.688_100_814_819_336), "-20.6881");
        assert_eq!(num(0.000_123_4), "0.000123");
        assert_eq!(num(123_456_789.4), "123456789");
    }

    #[test]
    fn bvh_humanoid_exports_depth_first() {
        let c = humanoid();
        let track = Track {
            fps: 30.0,
            frames: vec![c.skeleton.rest_world(); 2],
        };
        let text = to_bvh(&c, &track).unwrap();
        assert!(text.starts_with("HIERARCHY\nROOT pelvis\n{\n\tOFFSET 0 95 0\n"));
        assert!(text.contains("Frame Time: 0.033333333\n"));
        // upper_arm_l (index 5) is written under chest, before thigh_l (index 8).
        let arm = text.find("JOINT upper_arm_l").unwrap();
        let thigh = text.find("JOINT thigh_l").unwrap();
        assert!(arm < thigh);
    }

    #[test]
    fn bvh_export_rejects_bad_tracks() {
        let c = humanoid();
        let mut track = Track {
            fps: 30.0,
            frames: vec![c.skeleton.rest_world()],
        };
        track.frames[0][3].translation.x = f32::NAN;
        assert!(to_bvh(&c, &track).is_err());
        track.frames[0].pop();
        assert!(to_bvh(&c, &track).is_err());
        let track = Track {
            fps: 0.0,
            frames: vec![],
        };
        assert!(to_bvh(&c, &track).is_err());
    }
}
