//! Characters as the rest of the crate sees them: a flat joint hierarchy, optional skinned
//! meshes and animation clips, all in metres with Y up. Importers produce these; nothing
//! past this point knows the file format's units or up axis.

mod humanoid;
pub mod skinning;
pub mod source;

pub use humanoid::{DEFAULT_HEIGHT_M, humanoid};
pub use source::Source;

use glam::{Vec3, Vec4};

use crate::error::{Error, Result};
use crate::math::Transform;

/// Farthest a joint may be from the origin, in the rest pose or any animation frame,
/// metres: 10 km. Characters are a few metres tall; past this, f32 positions lose
/// millimetres and an absurd value in a file (a BVH offset of 2^31) would only blow up
/// later, in the physics.
pub const MAX_REACH_M: f32 = 10_000.0;

/// Most joint poses (frames × joints, over all clips) one imported character holds: 20
/// million, about 800 MB. A 20-minute take at 120 fps of 60 joints is 8.6 million.
pub const MAX_CLIP_POSES: usize = 20_000_000;

/// Most joints a skeleton may have: 65,536, as many as a skinned mesh's 16-bit joint
/// indices can name. Real characters have tens to a few hundred (a face rig, a thousand).
pub const MAX_JOINTS: usize = 1 << 16;

/// One joint of a [`Skeleton`].
#[derive(Clone, Debug, PartialEq)]
pub struct Joint {
    /// The joint's name; may be empty (CesiumMan's joints have none). Use
    /// [`Skeleton::joint_label`] for a printable name.
    pub name: String,
    /// Index of the parent joint, always lower than this joint's own index; `None` for a root.
    pub parent: Option<usize>,
    /// Rest (bind) transform relative to the parent joint; for a root, relative to the world.
    pub rest: Transform,
    /// For a leaf joint, where its bone ends, in the joint's local space (a BVH `End Site`).
    /// `None` when the file does not say.
    pub tip: Option<Vec3>,
}

/// A joint hierarchy stored flat, parents before children.
///
/// Invariant (checked by [`Skeleton::new`]): for every joint `i`, `parent < i`. Walking the
/// array in order therefore visits every parent before its children, which is all that
/// forward kinematics needs.
#[derive(Clone, Debug, PartialEq)]
pub struct Skeleton {
    joints: Vec<Joint>,
}

impl Skeleton {
    /// Checks the parent ordering, and that every rest transform is finite and keeps the
    /// joint (and its tip) within [`MAX_REACH_M`] of the origin.
    pub fn new(joints: Vec<Joint>) -> Result<Self> {
        if joints.is_empty() {
            return Err(Error::Skeleton {
                joint: String::new(),
                message: "the skeleton has no joints".into(),
            });
        }
        if joints.len() > MAX_JOINTS {
            return Err(Error::Skeleton {
                joint: label(&joints[MAX_JOINTS].name, MAX_JOINTS),
                message: format!(
                    "the skeleton has {} joints; at most {MAX_JOINTS} are supported",
                    joints.len()
                ),
            });
        }
        for (i, j) in joints.iter().enumerate() {
            if let Some(p) = j.parent
                && p >= i
            {
                return Err(Error::Skeleton {
                    joint: label(&j.name, i),
                    message: format!("parent index {p} is not before the joint's own index {i}"),
                });
            }
            if !j.rest.is_finite() || j.tip.is_some_and(|t| !t.is_finite()) {
                return Err(Error::Skeleton {
                    joint: label(&j.name, i),
                    message: "rest transform is not finite".into(),
                });
            }
        }
        let skeleton = Skeleton { joints };
        for (i, w) in skeleton.rest_world().iter().enumerate() {
            let j = &skeleton.joints[i];
            let tip = j.tip.map(|t| w.transform_point(t));
            let far = std::iter::once(w.translation)
                .chain(tip)
                .map(Vec3::length)
                .fold(0.0f32, f32::max);
            if !w.is_finite() || !far.is_finite() {
                // Finite local transforms can compose to infinity (scales of 1e10 down a
                // chain): say so, rather than quote a distance that is not the reason.
                return Err(Error::Skeleton {
                    joint: label(&j.name, i),
                    message: "the rest pose composes to a transform that is not finite (scales or offsets too large down the chain)".into(),
                });
            }
            if far > MAX_REACH_M {
                return Err(Error::Skeleton {
                    joint: label(&j.name, i),
                    message: format!(
                        "the rest pose puts it {far} m from the origin, past the {MAX_REACH_M} m a skeleton may reach"
                    ),
                });
            }
        }
        Ok(skeleton)
    }

    /// All joints, parents before children.
    pub fn joints(&self) -> &[Joint] {
        &self.joints
    }

    /// Number of joints.
    pub fn len(&self) -> usize {
        self.joints.len()
    }

    /// Always false: a skeleton has at least one joint.
    pub fn is_empty(&self) -> bool {
        self.joints.is_empty()
    }

    /// Parent of joint `i`.
    pub fn parent(&self, i: usize) -> Option<usize> {
        self.joints[i].parent
    }

    /// Indices of the direct children of joint `i`, in order. Scans the joints after `i`;
    /// code visiting every joint's children builds the lists once instead.
    pub fn children(&self, i: usize) -> impl Iterator<Item = usize> + '_ {
        self.joints
            .iter()
            .enumerate()
            .skip(i + 1)
            .filter(move |(_, j)| j.parent == Some(i))
            .map(|(c, _)| c)
    }

    /// Index of the first joint named `name`.
    pub fn find(&self, name: &str) -> Option<usize> {
        self.joints.iter().position(|j| j.name == name)
    }

    /// The joint's name, or `joint<i>` when it has none.
    pub fn joint_label(&self, i: usize) -> String {
        label(&self.joints[i].name, i)
    }

    /// World transforms of the rest pose.
    pub fn rest_world(&self) -> Vec<Transform> {
        let locals: Vec<Transform> = self.joints.iter().map(|j| j.rest).collect();
        let mut out = vec![Transform::IDENTITY; self.len()];
        self.world_from_local(&locals, &mut out);
        out
    }

    /// Forward kinematics: world transforms from local ones.
    ///
    /// `locals` and `out` must both have one entry per joint (panics otherwise: a
    /// programming error, not a user-input error).
    pub fn world_from_local(&self, locals: &[Transform], out: &mut [Transform]) {
        assert_eq!(locals.len(), self.len());
        assert_eq!(out.len(), self.len());
        for (i, j) in self.joints.iter().enumerate() {
            out[i] = match j.parent {
                Some(p) => out[p].mul(&locals[i]),
                None => locals[i],
            };
        }
    }

    /// The first frame and joint of `clip` that lie past [`MAX_REACH_M`] from the origin (or
    /// are not finite), with that distance (infinite when not finite): what an importer
    /// checks before handing a clip on. Frames of the wrong length are skipped.
    pub fn clip_out_of_reach(&self, clip: &Clip) -> Option<(usize, usize, f32)> {
        let mut world = vec![Transform::IDENTITY; self.len()];
        for (f, locals) in clip.frames.iter().enumerate() {
            if locals.len() != self.len() {
                continue;
            }
            self.world_from_local(locals, &mut world);
            for (j, w) in world.iter().enumerate() {
                let d = w.translation.length();
                if !(d <= MAX_REACH_M && w.is_finite()) {
                    return Some((f, j, if d.is_finite() { d } else { f32::INFINITY }));
                }
            }
        }
        None
    }

    /// Inverse kinematics of the hierarchy: local transforms from world ones.
    pub fn local_from_world(&self, worlds: &[Transform], out: &mut [Transform]) {
        assert_eq!(worlds.len(), self.len());
        assert_eq!(out.len(), self.len());
        for (i, j) in self.joints.iter().enumerate() {
            out[i] = match j.parent {
                Some(p) => worlds[p].inverse().mul(&worlds[i]),
                None => worlds[i],
            };
        }
    }

    /// Vertical extent of the rest pose over joints and bone tips, metres: the standing
    /// height of a humanoid, the size scale of anything else.
    pub fn rest_height(&self) -> f32 {
        self.rest_extent_along(Vec3::Y)
    }

    /// [`Skeleton::rest_height`] along `up` (unit) instead of Y: the height of a
    /// character whose file has it lying, measured the way it stands.
    pub fn rest_extent_along(&self, up: Vec3) -> f32 {
        let world = self.rest_world();
        let ends = self.rest_bone_ends();
        let hs = world
            .iter()
            .map(|t| t.translation.dot(up))
            .chain(ends.iter().flatten().map(|p| p.dot(up)));
        let (lo, hi) = hs.fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), h| {
            (lo.min(h), hi.max(h))
        });
        (hi - lo).max(0.0)
    }

    /// Where each joint's bone ends in the rest pose, in world space: the mean of its
    /// children's positions, or its tip, or `None` for a leaf without a tip.
    pub fn rest_bone_ends(&self) -> Vec<Option<Vec3>> {
        let world = self.rest_world();
        let mut children = vec![Vec::new(); self.len()];
        for (i, j) in self.joints.iter().enumerate() {
            if let Some(p) = j.parent {
                children[p].push(i);
            }
        }
        (0..self.len())
            .map(|i| {
                let kids = &children[i];
                if !kids.is_empty() {
                    let sum: Vec3 = kids.iter().map(|&c| world[c].translation).sum();
                    Some(sum / kids.len() as f32)
                } else {
                    self.joints[i].tip.map(|t| world[i].transform_point(t))
                }
            })
            .collect()
    }
}

fn label(name: &str, i: usize) -> String {
    if name.is_empty() {
        format!("joint{i}")
    } else {
        name.to_string()
    }
}

/// An animation sampled at a fixed rate: local transforms for every joint, every frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Clip {
    /// The clip's name (empty when the file gives none).
    pub name: String,
    /// Seconds between frames.
    pub frame_time: f32,
    /// `frames[f][j]`: local transform of joint `j` at frame `f`, in the same space as
    /// [`Joint::rest`].
    pub frames: Vec<Vec<Transform>>,
}

impl Clip {
    /// Duration in seconds from the first to the last frame.
    pub fn duration(&self) -> f32 {
        self.frames.len().saturating_sub(1) as f32 * self.frame_time
    }
}

/// A triangle mesh skinned to a [`Skeleton`], in world space in the bind pose.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SkinnedMesh {
    /// The mesh's name.
    pub name: String,
    /// Vertex positions, metres, world space, bind pose.
    pub positions: Vec<Vec3>,
    /// Vertex normals (unit), world space; may be empty.
    pub normals: Vec<Vec3>,
    /// Triangle list.
    pub indices: Vec<u32>,
    /// Up to four skeleton joint indices per vertex.
    pub joints: Vec<[u16; 4]>,
    /// Weights matching `joints`; each row sums to 1 (importers renormalise).
    pub weights: Vec<Vec4>,
}

/// What an importer hands on: a skeleton, its meshes and clips, and what the exporters need
/// to write the result back in the source's own layout.
#[derive(Clone, Debug)]
pub struct Character {
    /// A display name (file stem, or `humanoid`).
    pub name: String,
    /// The joint hierarchy in metres, Y up.
    pub skeleton: Skeleton,
    /// Skinned meshes (empty for BVH and the built-in humanoid).
    pub meshes: Vec<SkinnedMesh>,
    /// Animation clips found in the file.
    pub clips: Vec<Clip>,
    /// Bones the file names outright, as a VRM avatar's humanoid table does: each a
    /// humanoid bone name in VRM's (and Unity's) vocabulary (`hips`, `leftUpperLeg`,
    /// `rightHand`, …) with the skeleton joint it maps to. Empty when the file has no such
    /// table; role recognition then works from the skeleton alone. Plain names rather than
    /// the ragdoll's roles, so the skeleton does not depend on the spec.
    pub humanoid_bones: Vec<(String, usize)>,
    /// Defects the importer repaired rather than refused (bad skin weights, missing
    /// images), one sentence each naming the place in the file: tools show them to the
    /// user, since the result is not exactly what the file said.
    pub warnings: Vec<String>,
    /// The source file's layout, for exporters that write it back.
    pub source: Source,
}

impl Character {
    /// How tall the character stands along `up` (unit) in its rest pose, metres: its
    /// meshes' extent when it has any (the top of the head, the soles). A skeleton's joints
    /// stop short of the soles and the crown, so its joints' extent is scaled as the
    /// built-in humanoid's is to its standing height ([`DEFAULT_HEIGHT_M`]): a skeleton of
    /// the built-in humanoid's size stands exactly as tall.
    pub fn height_along(&self, up: Vec3) -> f32 {
        if self.meshes.iter().any(|m| !m.positions.is_empty()) {
            return self.extent_along(up);
        }
        let reference = humanoid().skeleton.rest_height();
        // The ratio first: a skeleton as tall as the reference gets exactly its height.
        self.skeleton.rest_extent_along(up) / reference * DEFAULT_HEIGHT_M
    }

    /// The character's extent along `up` (unit) in its rest pose, metres: of its meshes
    /// when it has any, else of its joints and bone ends.
    pub fn extent_along(&self, up: Vec3) -> f32 {
        let (lo, hi) = self.meshes.iter().flat_map(|m| &m.positions).fold(
            (f32::INFINITY, f32::NEG_INFINITY),
            |(lo, hi), p| {
                let h = p.dot(up);
                (lo.min(h), hi.max(h))
            },
        );
        if hi >= lo {
            hi - lo
        } else {
            self.skeleton.rest_extent_along(up)
        }
    }

    /// The character turned by `yaw` radians about the vertical axis through the origin,
    /// skeleton and skin together: to make it face another way before building its ragdoll
    /// (roles and limits do not depend on the facing).
    pub fn turned(&self, yaw: f32) -> Character {
        self.rotated(glam::Quat::from_rotation_y(yaw))
    }

    /// [`Character::rotated`] with only what role recognition and the ragdoll builder read
    /// of its animation, the first clip's first frame (the start pose): the other frames and
    /// clips are left out rather than copied and turned, since a clip may hold 20 million
    /// joint poses and a character lying in its file is turned several times while its
    /// roles are checked.
    pub(crate) fn rotated_start(&self, q: glam::Quat) -> Character {
        let first = self.clips.first().map(|c| Clip {
            name: c.name.clone(),
            frame_time: c.frame_time,
            frames: c.frames.first().cloned().into_iter().collect(),
        });
        let start = Character {
            name: self.name.clone(),
            skeleton: self.skeleton.clone(),
            meshes: self.meshes.clone(),
            clips: first.into_iter().collect(),
            humanoid_bones: self.humanoid_bones.clone(),
            warnings: self.warnings.clone(),
            source: self.source.clone(),
        };
        start.rotated(q)
    }

    /// The character turned by `q` about the origin, skeleton, skin and clips together.
    /// Role recognition stands a character up with it when its file has it lying down (a
    /// Z-up export read as Y-up): a ragdoll's bodies and joints are kept in its bones'
    /// frames, so the ragdoll built from the turned character fits the original one.
    pub fn rotated(&self, q: glam::Quat) -> Character {
        let mut out = self.clone();
        let mut joints = out.skeleton.joints.clone();
        for j in joints.iter_mut().filter(|j| j.parent.is_none()) {
            j.rest.translation = q * j.rest.translation;
            j.rest.rotation = (q * j.rest.rotation).normalize();
        }
        out.skeleton = Skeleton { joints };
        for m in &mut out.meshes {
            for p in &mut m.positions {
                *p = q * *p;
            }
            for n in &mut m.normals {
                *n = q * *n;
            }
        }
        for clip in &mut out.clips {
            for frame in &mut clip.frames {
                for (t, j) in frame.iter_mut().zip(&out.skeleton.joints) {
                    if j.parent.is_none() {
                        t.translation = q * t.translation;
                        t.rotation = (q * t.rotation).normalize();
                    }
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn joint(parent: Option<usize>, up: f32) -> Joint {
        Joint {
            name: String::new(),
            parent,
            rest: Transform::from_translation(Vec3::Y * up),
            tip: None,
        }
    }

    #[test]
    fn skeletons_past_their_limits_are_refused_naming_the_joint() {
        let many: Vec<Joint> = (0..=MAX_JOINTS).map(|_| joint(None, 0.0)).collect();
        let e = Skeleton::new(many).unwrap_err().to_string();
        assert!(e.contains(&MAX_JOINTS.to_string()), "{e}");
        // Each step is fine; the sum of them is not.
        let far: Vec<Joint> = (0..12usize)
            .map(|i| joint(i.checked_sub(1), 1000.0))
            .collect();
        let e = Skeleton::new(far).unwrap_err();
        assert!(
            matches!(&e, Error::Skeleton { joint, .. } if joint == "joint10"),
            "{e}"
        );
        // Scales that overflow once composed: the message says so, not a distance.
        let mut big: Vec<Joint> = (0..40usize).map(|i| joint(i.checked_sub(1), 0.0)).collect();
        for j in &mut big {
            j.rest.scale = Vec3::splat(1e10);
        }
        big[39].rest.translation = Vec3::Y;
        let e = Skeleton::new(big).unwrap_err().to_string();
        assert!(
            e.contains("not finite") && !e.contains(" m from the origin"),
            "{e}"
        );
        let mut tip = vec![joint(None, 0.0)];
        tip[0].tip = Some(Vec3::X * (2.0 * MAX_REACH_M));
        assert!(Skeleton::new(tip).is_err());
    }

    #[test]
    fn clips_out_of_reach_are_found_with_their_frame_and_joint() {
        let s = Skeleton::new(vec![joint(None, 1.0), joint(Some(0), 1.0)]).unwrap();
        let rest: Vec<Transform> = s.joints().iter().map(|j| j.rest).collect();
        let mut gone = rest.clone();
        gone[1].translation = Vec3::X * 2.0 * MAX_REACH_M;
        let clip = Clip {
            name: String::new(),
            frame_time: 0.1,
            frames: vec![rest.clone(), rest.clone(), gone],
        };
        let (f, j, far) = s.clip_out_of_reach(&clip).unwrap();
        assert_eq!((f, j), (2, 1));
        assert!(far > MAX_REACH_M);
        let mut nan = rest.clone();
        nan[0].rotation = glam::Quat::from_xyzw(f32::NAN, 0.0, 0.0, 1.0);
        let clip = Clip {
            frames: vec![nan],
            ..clip
        };
        assert_eq!(s.clip_out_of_reach(&clip).map(|x| x.0), Some(0));
    }

    #[test]
    fn bone_ends_are_the_mean_of_the_children_or_the_tip() {
        let mut joints = vec![joint(None, 1.0), joint(Some(0), 1.0), joint(Some(0), 3.0)];
        joints.push(Joint {
            tip: Some(Vec3::X),
            ..joint(Some(1), 1.0)
        });
        let s = Skeleton::new(joints).unwrap();
        let ends = s.rest_bone_ends();
        assert_eq!(ends[0], Some(Vec3::Y * 3.0));
        assert_eq!(ends[1], Some(Vec3::Y * 3.0));
        assert_eq!(ends[2], None);
        assert_eq!(ends[3], Some(Vec3::new(1.0, 3.0, 0.0)));
    }
}
