//! Where a spec's bodies and joint frames sit for a given pose, and how far a joint is
//! from its limits. Shared by the builder (which fits limits to the starting pose) and the
//! world (which creates joints and measures them), so both agree on every angle.
//!
//! Angles are measured the way rapier's limits are defined: the swing is the angle between
//! the two frames' X axes (a true cone), the twist is `2·atan2(qx, qw)` of the relative
//! rotation, and a hinge's angle is that same twist about its axis.

use glam::{Quat, Vec3};

use super::{JointKind, RagdollSpec};
use crate::error::{Error, Result};
use crate::math::{Transform, twist_angle_x};
use crate::skeleton::Character;

/// A spec joint with its frames expressed in each body's frame.
#[derive(Clone, Debug, PartialEq)]
pub struct ResolvedJoint {
    /// Parent body index.
    pub parent: usize,
    /// Child body index.
    pub child: usize,
    /// Joint frame in the parent body's frame (for swing-twist, turned to the cone's centre).
    pub frame_parent: Transform,
    /// Joint frame in the child body's frame.
    pub frame_child: Transform,
    /// Kind and limits.
    pub kind: JointKind,
}

/// Angles of a joint in some pose, radians.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointAngles {
    /// Angle between the frames' X axes (cone measure; for a hinge, how far it bends off
    /// its axis).
    pub swing: f32,
    /// Twist about X (for a hinge, its angle).
    pub twist: f32,
    /// Total rotation between the frames.
    pub total: f32,
}

impl ResolvedJoint {
    /// The joint's angles for the given body poses.
    pub fn angles(&self, parent: &Transform, child: &Transform) -> JointAngles {
        let f1 = parent.mul(&self.frame_parent);
        let f2 = child.mul(&self.frame_child);
        let rel = (f1.rotation.conjugate() * f2.rotation).normalize();
        let x1 = f1.rotation * Vec3::X;
        let x2 = f2.rotation * Vec3::X;
        JointAngles {
            swing: x1.dot(x2).clamp(-1.0, 1.0).acos(),
            twist: twist_angle_x(rel),
            total: rel.angle_between(Quat::IDENTITY),
        }
    }

    /// How far the two sides of the anchor are apart, metres.
    pub fn separation(&self, parent: &Transform, child: &Transform) -> f32 {
        let a = parent.transform_point(self.frame_parent.translation);
        let b = child.transform_point(self.frame_child.translation);
        (a - b).length()
    }

    /// How far the joint is outside its limits, radians (0 inside).
    pub fn violation(&self, parent: &Transform, child: &Transform) -> f32 {
        let a = self.angles(parent, child);
        let outside = |v: f32, lo: f32, hi: f32| (lo - v).max(v - hi).max(0.0);
        match self.kind {
            JointKind::Hinge { min_deg, max_deg } => {
                outside(a.twist, min_deg.to_radians(), max_deg.to_radians()).max(a.swing)
            }
            JointKind::SwingTwist {
                swing_deg,
                twist_deg,
                ..
            } => outside(a.swing, 0.0, swing_deg.to_radians()).max(outside(
                a.twist,
                twist_deg[0].to_radians(),
                twist_deg[1].to_radians(),
            )),
            JointKind::Ball => 0.0,
            JointKind::Fixed => a.total,
        }
    }
}

/// A pose this close to a limit, degrees, lies on it rather than past it. Angles read back
/// from f32 transforms carry noise of about 1e-5°, and a straight elbow or knee rests
/// exactly on its limit: the noise alone decided whether its limit was widened by the
/// whole margin (the same figure built standing and stood up from lying differed by 5°).
const ON_LIMIT_DEG: f32 = 0.01;

impl ResolvedJoint {
    /// Widens the limits so the pose of these two bodies lies `margin_deg` inside them;
    /// returns whether anything changed.
    pub fn widen_to_include(
        &mut self,
        parent: &Transform,
        child: &Transform,
        margin_deg: f32,
    ) -> bool {
        let a = self.angles(parent, child);
        let (swing, twist) = (a.swing.to_degrees(), a.twist.to_degrees());
        let t = ON_LIMIT_DEG;
        let mut changed = false;
        match &mut self.kind {
            JointKind::Hinge { min_deg, max_deg } => {
                if twist < *min_deg - t {
                    *min_deg = twist - margin_deg;
                    changed = true;
                }
                if twist > *max_deg + t {
                    *max_deg = twist + margin_deg;
                    changed = true;
                }
            }
            JointKind::SwingTwist {
                swing_deg,
                twist_deg,
                ..
            } => {
                if swing > *swing_deg + t {
                    *swing_deg = (swing + margin_deg).min(180.0);
                    changed = true;
                }
                if twist < twist_deg[0] - t {
                    twist_deg[0] = twist - margin_deg;
                    changed = true;
                }
                if twist > twist_deg[1] + t {
                    twist_deg[1] = twist + margin_deg;
                    changed = true;
                }
            }
            JointKind::Ball | JointKind::Fixed => {}
        }
        changed
    }

    /// For a hinge whose child has turned off the hinge's axis in this pose (a performer's
    /// forearm rolls as the elbow bends; a hinge has no such freedom), turns the
    /// parent-side frame so its axis is the child's: the hinge then bends in the plane the
    /// pose shows instead of the solver snapping the limb into the rest plane. Returns
    /// whether the frame changed. Other kinds are left alone.
    pub fn align_hinge_to(&mut self, parent: &Transform, child: &Transform) -> bool {
        if !matches!(self.kind, JointKind::Hinge { .. }) {
            return false;
        }
        let f1 = parent.mul(&self.frame_parent);
        let f2 = child.mul(&self.frame_child);
        let (x1, x2) = (f1.rotation * Vec3::X, f2.rotation * Vec3::X);
        if x1.dot(x2) > (0.25f32).to_radians().cos() {
            return false;
        }
        let turn = Quat::from_rotation_arc(x1, x2);
        let aligned = (turn * f1.rotation).normalize();
        self.frame_parent.rotation = (parent.rotation.conjugate() * aligned).normalize();
        true
    }

    /// For a hinge, turns both frames so that their common X axis is the one axis, fixed in
    /// both bodies, that best explains the relative rotations of the poses given (pairs of
    /// parent and child body poses): a performer's elbow bends about an axis a few degrees
    /// off the one guessed from the rest pose, and a hinge on the wrong axis keeps the
    /// forearm out of the clip's plane by that much however strong the motors are. Each
    /// frame is turned the short way, so the hinge angle keeps its meaning. Returns the
    /// worst angle, degrees, between the clip's axis and the fitted one over the poses (how
    /// far the clip itself is from being a hinge); `None` for other kinds or no poses.
    pub fn fit_hinge_to(&mut self, poses: &[(Transform, Transform)]) -> Option<f32> {
        if !matches!(self.kind, JointKind::Hinge { .. }) || poses.is_empty() {
            return None;
        }
        let relative: Vec<Quat> = poses
            .iter()
            .map(|(p, c)| (p.rotation.conjugate() * c.rotation).normalize())
            .collect();
        // The axis a_p in the parent and a_c in the child with Q·a_c = a_p for every
        // relative rotation Q: the top singular vectors of ΣQ, by power iteration from
        // the current axes. It converges by the ratio of the two largest singular values
        // squared per round, slowly when the clip bends the joint little, hence the many
        // rounds (each is a pass over the clip, microseconds).
        let mut a_p = self.frame_parent.rotation * Vec3::X;
        let mut a_c = self.frame_child.rotation * Vec3::X;
        for _ in 0..2000 {
            let sum_p: Vec3 = relative.iter().map(|q| *q * a_c).sum();
            a_p = sum_p.try_normalize()?;
            let sum_c: Vec3 = relative.iter().map(|q| q.conjugate() * a_p).sum();
            let next = sum_c.try_normalize()?;
            let settled = next.dot(a_c) > 1.0 - 1e-12;
            a_c = next;
            if settled {
                break;
            }
        }
        let turn_p = Quat::from_rotation_arc(self.frame_parent.rotation * Vec3::X, a_p);
        let turn_c = Quat::from_rotation_arc(self.frame_child.rotation * Vec3::X, a_c);
        self.frame_parent.rotation = (turn_p * self.frame_parent.rotation).normalize();
        self.frame_child.rotation = (turn_c * self.frame_child.rotation).normalize();
        let worst = relative
            .iter()
            .map(|q| (*q * a_c).angle_between(a_p))
            .fold(0.0f32, f32::max);
        Some(worst.to_degrees())
    }

    /// The rotation of the child body that brings the joint back inside its limits, with the
    /// parent where it is: the relative rotation is split into swing and twist, and each is
    /// clamped to its range (a hinge also loses any swing off its axis). `None` when the
    /// joint is already inside.
    pub fn clamp_child_rotation(&self, parent: &Transform, child: &Transform) -> Option<Quat> {
        if self.violation(parent, child) <= 0.0 {
            return None;
        }
        let f1 = parent.mul(&self.frame_parent);
        let f2 = child.mul(&self.frame_child);
        let mut rel = (f1.rotation.conjugate() * f2.rotation).normalize();
        if rel.w < 0.0 {
            rel = -rel;
        }
        let (swing, _) = crate::math::swing_twist(rel, Vec3::X);
        let twist = twist_angle_x(rel);
        let clamped = match self.kind {
            JointKind::Hinge { min_deg, max_deg } => {
                Quat::from_rotation_x(twist.clamp(min_deg.to_radians(), max_deg.to_radians()))
            }
            JointKind::SwingTwist {
                swing_deg,
                twist_deg,
                ..
            } => {
                let (axis, angle) = swing.to_axis_angle();
                let swing = if angle > swing_deg.to_radians() {
                    Quat::from_axis_angle(axis, swing_deg.to_radians())
                } else {
                    swing
                };
                let t = twist.clamp(twist_deg[0].to_radians(), twist_deg[1].to_radians());
                swing * Quat::from_rotation_x(t)
            }
            JointKind::Ball => return None,
            JointKind::Fixed => Quat::IDENTITY,
        };
        // child * frame_child = f1 * clamped  →  child = f1 * clamped * frame_child⁻¹
        Some((f1.rotation * clamped * self.frame_child.rotation.conjugate()).normalize())
    }
}

/// A spec placed on a character: which joint carries each body, the bodies' rest poses
/// and the joints' frames.
#[derive(Clone, Debug)]
pub struct Resolved {
    /// Skeleton joint index of each body's bone.
    pub bone_of_body: Vec<usize>,
    /// Each body's frame in the local frame of its bone (no scale).
    pub body_local: Vec<Transform>,
    /// Each body's world pose in the rest pose.
    pub body_rest: Vec<Transform>,
    /// The joints.
    pub joints: Vec<ResolvedJoint>,
}

impl Resolved {
    /// Places `spec` on `character`'s rest pose. Fails when a body names a bone the
    /// skeleton does not have.
    pub fn new(spec: &RagdollSpec, character: &Character) -> Result<Self> {
        let skeleton = &character.skeleton;
        let mut joint_named: std::collections::HashMap<&str, usize> =
            std::collections::HashMap::with_capacity(skeleton.len());
        for (i, j) in skeleton.joints().iter().enumerate().rev() {
            joint_named.insert(j.name.as_str(), i);
        }
        let mut body_named: std::collections::HashMap<&str, usize> =
            std::collections::HashMap::with_capacity(spec.bodies.len());
        for (i, b) in spec.bodies.iter().enumerate().rev() {
            body_named.insert(b.name.as_str(), i);
        }
        let find = |label: &str| {
            joint_named.get(label).copied().or_else(|| {
                let i: usize = label.strip_prefix("joint")?.parse().ok()?;
                (i < skeleton.len() && skeleton.joints()[i].name.is_empty()).then_some(i)
            })
        };
        let mut bone_of_body = Vec::with_capacity(spec.bodies.len());
        for b in &spec.bodies {
            let j = find(&b.bone).ok_or_else(|| Error::Spec {
                place: format!("body \"{}\".bone", b.name),
                message: format!("the skeleton has no joint named \"{}\"", b.bone),
            })?;
            bone_of_body.push(j);
        }
        let rest = skeleton.rest_world();
        let body_local: Vec<Transform> = spec
            .bodies
            .iter()
            .map(|b| {
                Transform::new(
                    Vec3::from_array(b.center_m),
                    Quat::from_array(b.rotation).normalize(),
                )
            })
            .collect();
        let body_rest: Vec<Transform> = (0..spec.bodies.len())
            .map(|i| unscaled(&rest[bone_of_body[i]]).mul(&body_local[i]))
            .collect();
        let mut joints = Vec::with_capacity(spec.joints.len());
        for j in &spec.joints {
            let parent = body_named
                .get(j.parent.as_str())
                .copied()
                .ok_or_else(|| Error::Spec {
                    place: format!("joint \"{}\".parent", j.name),
                    message: "no body has this name".into(),
                })?;
            let child = body_named
                .get(j.child.as_str())
                .copied()
                .ok_or_else(|| Error::Spec {
                    place: format!("joint \"{}\".child", j.name),
                    message: "no body has this name".into(),
                })?;
            // Frames are taken in the rest pose, so every angle is zero at rest (but for the
            // cone's tilt).
            let frame_world = unscaled(&rest[bone_of_body[child]]).mul(&Transform::new(
                Vec3::from_array(j.anchor_m),
                Quat::from_array(j.frame).normalize(),
            ));
            let tilt = match j.kind {
                JointKind::SwingTwist { cone_tilt_deg, .. } => {
                    Quat::from_rotation_y(cone_tilt_deg[0].to_radians())
                        * Quat::from_rotation_z(cone_tilt_deg[1].to_radians())
                }
                _ => Quat::IDENTITY,
            };
            let parent_frame_world = frame_world.mul(&Transform::new(Vec3::ZERO, tilt));
            joints.push(ResolvedJoint {
                parent,
                child,
                frame_parent: body_rest[parent].inverse().mul(&parent_frame_world),
                frame_child: body_rest[child].inverse().mul(&frame_world),
                kind: j.kind,
            });
        }
        Ok(Resolved {
            bone_of_body,
            body_local,
            body_rest,
            joints,
        })
    }

    /// Moves each joint's parent-side anchor to where the child's joint is in the pose
    /// `joint_world` (the pose the world starts in).
    ///
    /// Bones without a body (a collar, a twist bone) ride on their parent's body with the
    /// offset they have when the simulation starts; when an animation has turned them
    /// since the rest pose, the joint below them sits elsewhere on the parent body than it
    /// did at rest. Anchors from the rest pose would start the joint apart, and the
    /// solver would snap it shut with a kick.
    pub fn anchor_at_pose(&mut self, joint_world: &[Transform]) {
        let poses = self.body_poses(joint_world);
        for j in &mut self.joints {
            let child_anchor = poses[j.child].transform_point(j.frame_child.translation);
            j.frame_parent.translation = poses[j.parent].inverse().transform_point(child_anchor);
        }
    }

    /// World poses of the bodies when the skeleton's joints are at `joint_world`.
    pub fn body_poses(&self, joint_world: &[Transform]) -> Vec<Transform> {
        self.bone_of_body
            .iter()
            .zip(&self.body_local)
            .map(|(&j, local)| unscaled(&joint_world[j]).mul(local))
            .collect()
    }
}

/// The pose a world starts a character in: the first frame of its first clip, or the rest
/// pose, in world space.
pub fn start_pose(character: &Character, use_first_frame: bool) -> Vec<Transform> {
    let skeleton = &character.skeleton;
    let mut pose = skeleton.rest_world();
    if use_first_frame
        && let Some(frame) = character.clips.first().and_then(|c| c.frames.first())
        && frame.len() == skeleton.len()
    {
        skeleton.world_from_local(frame, &mut pose);
    }
    pose
}

/// Widens every joint limit that the pose `joint_world` lies outside of, so that it lies
/// `margin_deg` inside. Returns the names of the joints it widened.
///
/// Our ranges are anatomical approximations; a pose a performer actually held is possible
/// by definition. A ragdoll that starts outside its limits is yanked back by the solver on
/// the first steps, which looks wrong and injects energy, so the limits give way instead.
pub fn fit_limits_to_pose(
    spec: &mut RagdollSpec,
    character: &Character,
    joint_world: &[Transform],
    margin_deg: f32,
) -> Result<Vec<String>> {
    let resolved = Resolved::new(spec, character)?;
    let poses = resolved.body_poses(joint_world);
    let mut widened = Vec::new();
    for (spec_joint, j) in spec.joints.iter_mut().zip(&resolved.joints) {
        let mut j = j.clone();
        if j.widen_to_include(&poses[j.parent], &poses[j.child], margin_deg) {
            spec_joint.kind = j.kind;
            widened.push(spec_joint.name.clone());
        }
    }
    Ok(widened)
}

fn unscaled(t: &Transform) -> Transform {
    Transform::new(t.translation, t.rotation)
}

/// Finds a joint by name, or by the `joint<i>` label given to unnamed joints.
pub fn find_label(character: &Character, label: &str) -> Option<usize> {
    let s = &character.skeleton;
    s.find(label).or_else(|| {
        let i: usize = label.strip_prefix("joint")?.parse().ok()?;
        (i < s.len() && s.joints()[i].name.is_empty()).then_some(i)
    })
}
