//! Limit projection, an engine service: joints turned back inside their limits on
//! positions at the end of a world step, for an engine whose solver holds limits on
//! velocities only.
//!
//! rapier enforces limits on velocities; a hard impact (a torso landing on an arm) can
//! still push a joint tens of degrees past its limit for a few frames. The projection
//! clamps each joint's swing and twist back into range, turning the child's whole subtree
//! about the joint anchor, parents first, as position-based solvers do. The `rigid` engine
//! runs it after the last of its collision substeps; an engine of someone else's can keep
//! one too (the world no longer clamps on an engine's behalf).

use glam::Quat;

use super::ragdolls::{Held, Ragdolls};
use super::tree::JointTree;
use super::{BodyDesc, JointDesc, JointId};
use crate::math::Transform;
use crate::spec::{JointKind, ResolvedJoint, Shape};

/// Violations smaller than this are left to the solver's own limits, degrees. Projecting
/// every tiny excess made limbs resting against a limit creep (about 1 cm/s on rapier):
/// each step the solver let them sink a little and the projection turned them back about
/// the anchor, a ratchet against the floor's friction.
pub const PROJECTION_TOLERANCE_DEG: f32 = 1.0;

/// How far below the ground the projection may move a body that was above it, metres.
const PROJECTION_GROUND_SLACK_M: f32 = 0.005;

/// What a body is to the projection this step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BodyRole {
    /// Moved by the solver (not kinematic, not taken out): a ragdoll with no dynamic body
    /// (its clip still playing) is left alone.
    pub dynamic: bool,
    /// Held by something outside the ragdoll (a pin, a drag, a root kept on its clip).
    /// Turning it would tear it from its holder, whose constraint then yanks it back, a
    /// fight that flung a pinned dragon's chain tens of metres: the projection turns the
    /// other side of the joint instead.
    pub held: bool,
}

/// One ragdoll's joints as the projection sees them.
#[derive(Clone, Debug)]
struct Ragdoll {
    joints: Vec<ResolvedJoint>,
    tree: JointTree,
    shapes: Vec<Shape>,
}

/// The joints of every ragdoll an engine holds, in the order added (so a [`JointId`] and a
/// body index mean what they mean to the engine), and the projection over them.
///
/// ```
/// use ragdoll::backend::limits::{BodyRole, LimitProjection};
/// use ragdoll::backend::{BodyDesc, JointDesc};
/// use ragdoll::math::Transform;
/// use ragdoll::spec::{JointKind, Shape};
/// use glam::{Quat, Vec3};
///
/// let body = |y: f32| BodyDesc {
///     pose: Transform::new(Vec3::new(0.0, y, 0.0), Quat::IDENTITY),
///     shape: Shape::Capsule { radius_m: 0.05, length_m: 0.3 },
///     extra_shapes: Vec::new(),
///     mass: 1.0,
///     linvel: Vec3::ZERO,
///     angvel: Vec3::ZERO,
/// };
/// // A hinge at y = 1 between a body above and one below, bending 0..90° about X.
/// let joint = JointDesc {
///     parent: 0,
///     child: 1,
///     frame_parent: Transform::new(Vec3::new(0.0, -0.25, 0.0), Quat::IDENTITY),
///     frame_child: Transform::new(Vec3::new(0.0, 0.25, 0.0), Quat::IDENTITY),
///     kind: JointKind::Hinge { min_deg: 0.0, max_deg: 90.0 },
/// };
/// let mut limits = LimitProjection::default();
/// limits.add_ragdoll(0, &[body(1.25), body(0.75)], &[joint]);
/// // The lower body bent 30° the wrong way about the anchor.
/// let anchor = Vec3::new(0.0, 1.0, 0.0);
/// let bent = Quat::from_rotation_x(-30f32.to_radians());
/// let mut poses = vec![
///     Transform::new(Vec3::new(0.0, 1.25, 0.0), Quat::IDENTITY),
///     Transform::new(anchor + bent * Vec3::new(0.0, -0.25, 0.0), bent),
/// ];
/// let roles = [BodyRole { dynamic: true, held: false }; 2];
/// assert!(limits.worst_violation(&poses, &roles) > 29f32.to_radians());
/// let moved = limits.project(&mut poses, &roles, None);
/// assert_eq!(moved, vec![1]);
/// assert!(limits.worst_violation(&poses, &roles) < 1e-3);
/// ```
#[derive(Clone, Debug, Default)]
pub struct LimitProjection {
    ragdolls: Ragdolls<Ragdoll>,
}

impl LimitProjection {
    /// Takes in a ragdoll whose first body has the engine's index `first_body`, with its
    /// joints (indices within the ragdoll, as [`super::Backend::add_ragdoll`] has them).
    pub fn add_ragdoll(&mut self, first_body: usize, bodies: &[BodyDesc], joints: &[JointDesc]) {
        let links: Vec<(usize, usize)> = joints.iter().map(|j| (j.parent, j.child)).collect();
        let ragdoll = Ragdoll {
            joints: joints
                .iter()
                .map(|j| ResolvedJoint {
                    parent: j.parent,
                    child: j.child,
                    frame_parent: j.frame_parent,
                    frame_child: j.frame_child,
                    kind: j.kind,
                })
                .collect(),
            tree: JointTree::new(bodies.len(), &links),
            shapes: bodies.iter().map(|b| b.shape).collect(),
        };
        self.ragdolls.add(first_body, joints.len(), ragdoll);
    }

    /// Leaves out the ragdoll whose first body is `first_body` from now on.
    pub fn remove_ragdoll(&mut self, first_body: usize) {
        self.ragdolls.remove(first_body);
    }

    fn joint_mut(&mut self, joint: JointId) -> Option<&mut ResolvedJoint> {
        let (r, k) = self.ragdolls.joint_mut(joint)?;
        r.joints.get_mut(k)
    }

    /// A joint's new limits (a hand-over widening them to the clip's poses).
    pub fn set_limits(&mut self, joint: JointId, kind: &JointKind) {
        if let Some(j) = self.joint_mut(joint) {
            j.kind = *kind;
        }
    }

    /// A joint's new frame in its parent body.
    pub fn set_parent_frame(&mut self, joint: JointId, frame: &Transform) {
        if let Some(j) = self.joint_mut(joint) {
            j.frame_parent = *frame;
        }
    }

    /// A joint's new frame in its child body.
    pub fn set_child_frame(&mut self, joint: JointId, frame: &Transform) {
        if let Some(j) = self.joint_mut(joint) {
            j.frame_child = *frame;
        }
    }

    /// The ragdolls that take part: in the engine and moved by its solver.
    fn physical<'a>(&'a self, roles: &'a [BodyRole]) -> impl Iterator<Item = &'a Held<Ragdoll>> {
        self.ragdolls.live().filter(|r| {
            roles
                .get(r.first_body..r.first_body + r.shapes.len())
                .is_some_and(|roles| roles.iter().any(|b| b.dynamic))
        })
    }

    /// The worst limit violation of the joints of ragdolls with a dynamic body, radians,
    /// in `poses` (every body's, engine order): what the solver left, read before
    /// [`LimitProjection::project`].
    pub fn worst_violation(&self, poses: &[Transform], roles: &[BodyRole]) -> f32 {
        let mut worst = 0.0f32;
        for r in self.physical(roles) {
            let p = &poses[r.first_body..r.first_body + r.shapes.len()];
            for j in &r.joints {
                worst = worst.max(j.violation(&p[j.parent], &p[j.child]));
            }
        }
        worst
    }

    /// Clamps every joint of the ragdolls with a dynamic body back into its limits, in
    /// `poses`; returns the bodies moved (engine indices, each once, in order), for the
    /// engine to set.
    ///
    /// Where turning a subtree would sink one of its bodies below `ground` (deeper than
    /// it already was, beyond a few millimetres), the whole ragdoll is lifted by that much
    /// instead: left to the contacts, such a sink came back as 3-6 cm penetrations in our
    /// runs on rapier; the lift is a few millimetres, once in a while.
    pub fn project(
        &self,
        poses: &mut [Transform],
        roles: &[BodyRole],
        ground: Option<f32>,
    ) -> Vec<usize> {
        let tolerance = PROJECTION_TOLERANCE_DEG.to_radians();
        let mut moved = vec![false; poses.len()];
        for r in self.physical(roles) {
            let base = r.first_body;
            let p = &poses[base..base + r.shapes.len()];
            // As below: only a violation known to be small is skipped.
            let past = r.joints.iter().any(|j| {
                let v = j.violation(&p[j.parent], &p[j.child]);
                v >= tolerance || v.is_nan()
            });
            if !past {
                continue;
            }
            for &k in &r.tree.order {
                project_joint(r, k, poses, roles, ground, &mut moved);
            }
        }
        (0..poses.len()).filter(|&b| moved[b]).collect()
    }
}

/// Turns joint `k` of ragdoll `r` back into its limits, if it is past them.
fn project_joint(
    r: &Held<Ragdoll>,
    k: usize,
    poses: &mut [Transform],
    roles: &[BodyRole],
    ground: Option<f32>,
    moved: &mut [bool],
) {
    let base = r.first_body;
    let j = &r.joints[k];
    let (parent, child) = (poses[base + j.parent], poses[base + j.child]);
    if j.violation(&parent, &child) < PROJECTION_TOLERANCE_DEG.to_radians() {
        return;
    }
    let Some(rotation) = j.clamp_child_rotation(&parent, &child) else {
        return;
    };
    let full = rotation * child.rotation.conjugate();
    let anchor = child.transform_point(j.frame_child.translation);
    let turn = |p: &Transform, delta: Quat| {
        Transform::new(
            anchor + delta * (p.translation - anchor),
            (delta * p.rotation).normalize(),
        )
    };
    let held = |b: usize| roles[base + b].held;
    let subtree = r.tree.subtree(k);
    let (turned, delta) = if subtree.iter().all(|&b| !held(b)) {
        (subtree.to_vec(), full)
    } else {
        let rest: Vec<usize> = (0..r.shapes.len())
            .filter(|&b| !r.tree.in_subtree(k, b))
            .collect();
        if rest.iter().any(|&b| held(b)) {
            // Held on both sides: the holders decide.
            return;
        }
        (rest, full.conjugate())
    };
    // How far the turned bodies would sink below the ground beyond the slack (and beyond
    // where they already were): the whole ragdoll is lifted by that much, so the limit
    // wins without pushing a body into the floor.
    let mut lift = 0.0f32;
    if let Some(g) = ground {
        for &b in &turned {
            let shape = &r.shapes[b];
            let before = shape.lowest_y(&poses[base + b]);
            let after = shape.lowest_y(&turn(&poses[base + b], delta));
            let floor = (g - PROJECTION_GROUND_SLACK_M).min(before);
            lift = lift.max(floor - after);
        }
    }
    for &b in &turned {
        poses[base + b] = turn(&poses[base + b], delta);
        moved[base + b] = true;
    }
    // A held ragdoll is not lifted: its holder would pull it straight back.
    let any_held = (0..r.shapes.len()).any(held);
    if lift > 0.0 && !any_held {
        for b in 0..r.shapes.len() {
            poses[base + b].translation.y += lift;
            moved[base + b] = true;
        }
    }
}
