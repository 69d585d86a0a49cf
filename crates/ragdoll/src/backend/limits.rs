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

use glam::{Quat, Vec3};

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
    masses: Vec<f32>,
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
    /// Joint gaps wider than this are narrowed to it, metres
    /// ([`LimitProjection::closing_gaps`]); `None` leaves gaps to the solver.
    gap_tolerance_m: Option<f32>,
}

impl LimitProjection {
    /// A projection that also narrows every joint gap wider than `tolerance_m` to it
    /// (PhysX's and Unreal's joint projection): for an engine whose joints open for a step
    /// now and then under an impact, which a skin bound to both sides shows as a tear. Both
    /// sides of the joint move, each by the other's share of the mass, unless something
    /// holds one (then the other moves alone); where that would sink a body into the
    /// ground, the whole ragdoll is lifted instead, as for limits. Off by default: moves
    /// of positions the solver did not make cost energy (see
    /// [`RigidConfig::gap_tolerance_m`](super::RigidConfig::gap_tolerance_m)).
    pub fn closing_gaps(tolerance_m: f32) -> Self {
        LimitProjection {
            ragdolls: Ragdolls::default(),
            gap_tolerance_m: Some(tolerance_m),
        }
    }

    /// Whether it narrows joint gaps ([`LimitProjection::closing_gaps`]).
    pub fn closes_gaps(&self) -> bool {
        self.gap_tolerance_m.is_some()
    }

    /// The widest joint gap of the ragdolls with a dynamic body, metres, in `poses`: what
    /// the solver left, read before [`LimitProjection::project`].
    pub fn worst_separation(&self, poses: &[Transform], roles: &[BodyRole]) -> f32 {
        self.worst_of(poses, roles, ResolvedJoint::separation)
    }

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
            masses: bodies.iter().map(|b| b.mass).collect(),
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
        self.worst_of(poses, roles, ResolvedJoint::violation)
    }

    /// The largest `measure` of a joint of the ragdolls with a dynamic body, in `poses`.
    fn worst_of(
        &self,
        poses: &[Transform],
        roles: &[BodyRole],
        measure: impl Fn(&ResolvedJoint, &Transform, &Transform) -> f32,
    ) -> f32 {
        let mut worst = 0.0f32;
        for r in self.physical(roles) {
            let p = &poses[r.first_body..r.first_body + r.shapes.len()];
            for j in &r.joints {
                worst = worst.max(measure(j, &p[j.parent], &p[j.child]));
            }
        }
        worst
    }

    /// Clamps every joint of the ragdolls with a dynamic body back into its limits (and
    /// narrows its gap, for a projection [`closing_gaps`](LimitProjection::closing_gaps)),
    /// in `poses`; returns the bodies moved (engine indices, each once, in order), for the
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
                v >= tolerance
                    || v.is_nan()
                    || self
                        .gap_tolerance_m
                        .is_some_and(|t| j.separation(&p[j.parent], &p[j.child]) > t)
            });
            if !past {
                continue;
            }
            for &k in &r.tree.order {
                project_joint(r, k, poses, roles, ground, self.gap_tolerance_m, &mut moved);
            }
        }
        (0..poses.len()).filter(|&b| moved[b]).collect()
    }
}

/// Turns joint `k` of ragdoll `r` back into its limits, if it is past them, and narrows
/// its gap to `gap_tolerance_m` if it is wider.
fn project_joint(
    r: &Held<Ragdoll>,
    k: usize,
    poses: &mut [Transform],
    roles: &[BodyRole],
    ground: Option<f32>,
    gap_tolerance_m: Option<f32>,
    moved: &mut [bool],
) {
    let base = r.first_body;
    let j = &r.joints[k];
    let held = |b: usize| roles[base + b].held;
    let subtree = r.tree.subtree(k);
    let rest = || -> Vec<usize> {
        (0..r.shapes.len())
            .filter(|&b| !r.tree.in_subtree(k, b))
            .collect()
    };
    let subtree_free = subtree.iter().all(|&b| !held(b));
    let rest_free = || (0..r.shapes.len()).all(|b| r.tree.in_subtree(k, b) || !held(b));
    let (parent, child) = (poses[base + j.parent], poses[base + j.child]);
    if j.violation(&parent, &child) >= PROJECTION_TOLERANCE_DEG.to_radians()
        && let Some(rotation) = j.clamp_child_rotation(&parent, &child)
    {
        // The subtree turns about the anchor, unless something holds it: then the rest of
        // the ragdoll turns the other way. Held on both sides, the holders decide.
        let full = rotation * child.rotation.conjugate();
        let anchor = child.transform_point(j.frame_child.translation);
        let turn = |delta: Quat| {
            move |_: usize, p: &Transform| {
                Transform::new(
                    anchor + delta * (p.translation - anchor),
                    (delta * p.rotation).normalize(),
                )
            }
        };
        if subtree_free {
            move_bodies(r, poses, roles, ground, moved, subtree, turn(full));
        } else if rest_free() {
            let rest = rest();
            move_bodies(
                r,
                poses,
                roles,
                ground,
                moved,
                &rest,
                turn(full.conjugate()),
            );
        }
    }
    let Some(tolerance) = gap_tolerance_m else {
        return;
    };
    let (parent, child) = (poses[base + j.parent], poses[base + j.child]);
    let gap = parent.transform_point(j.frame_parent.translation)
        - child.transform_point(j.frame_child.translation);
    let width = gap.length();
    // A NaN gap (a non-finite pose) is left alone too.
    if width.is_nan() || width <= tolerance {
        return;
    }
    // Narrowed to the tolerance, not closed: a gap a loaded joint keeps at rest is then
    // moved once, not every step. Both sides move, each by the other's share of the mass,
    // so the ragdoll's centre of mass stays where the solver left it (moving the child's
    // side alone lifted a resting bird's chain a little every step: 1.5 % energy gained
    // and still creeping after 6 s).
    let close = gap * (1.0 - tolerance / width);
    let m_sub: f32 = subtree.iter().map(|&b| r.masses[b]).sum();
    let m_rest = r.masses.iter().sum::<f32>() - m_sub;
    let (to_sub, to_rest) = match (subtree_free, rest_free()) {
        (true, true) if m_sub + m_rest > 0.0 => (
            close * (m_rest / (m_sub + m_rest)),
            -close * (m_sub / (m_sub + m_rest)),
        ),
        (true, _) => (close, Vec3::ZERO),
        (false, true) => (Vec3::ZERO, -close),
        (false, false) => return,
    };
    let all: Vec<usize> = (0..r.shapes.len()).collect();
    move_bodies(r, poses, roles, ground, moved, &all, |b, p| {
        let shift = if r.tree.in_subtree(k, b) {
            to_sub
        } else {
            to_rest
        };
        Transform::new(p.translation + shift, p.rotation)
    });
}

/// Moves `bodies` of ragdoll `r` by `motion` (given each body's index in the ragdoll and
/// its pose). Where that would sink a body below `ground` (deeper than it already was,
/// beyond a few millimetres), the whole ragdoll is lifted by that much instead: a limit
/// wins without pushing a body into the floor.
fn move_bodies(
    r: &Held<Ragdoll>,
    poses: &mut [Transform],
    roles: &[BodyRole],
    ground: Option<f32>,
    moved: &mut [bool],
    bodies: &[usize],
    motion: impl Fn(usize, &Transform) -> Transform,
) {
    let base = r.first_body;
    let mut lift = 0.0f32;
    if let Some(g) = ground {
        for &b in bodies {
            let shape = &r.shapes[b];
            let before = shape.lowest_y(&poses[base + b]);
            let after = shape.lowest_y(&motion(b, &poses[base + b]));
            let floor = (g - PROJECTION_GROUND_SLACK_M).min(before);
            lift = lift.max(floor - after);
        }
    }
    for &b in bodies {
        let now = motion(b, &poses[base + b]);
        if now != poses[base + b] {
            poses[base + b] = now;
            moved[base + b] = true;
        }
    }
    // A held ragdoll is not lifted: its holder would pull it straight back.
    let any_held = (0..r.shapes.len()).any(|b| roles[base + b].held);
    if lift > 0.0 && !any_held {
        for b in 0..r.shapes.len() {
            poses[base + b].translation.y += lift;
            moved[base + b] = true;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Quat, Vec3};

    /// A chain of three capsules hanging down from y = 3, joints at y = 2 and 1, every
    /// joint a free ball (so only gaps are projected); the lowest body `drop_m` lower
    /// than its joint allows.
    fn chain(drop_m: f32) -> (LimitProjection, Vec<Transform>) {
        let body = |y: f32| BodyDesc {
            pose: Transform::new(Vec3::new(0.0, y, 0.0), Quat::IDENTITY),
            shape: Shape::Capsule {
                radius_m: 0.05,
                length_m: 0.8,
            },
            extra_shapes: Vec::new(),
            mass: 1.0,
            linvel: Vec3::ZERO,
            angvel: Vec3::ZERO,
        };
        let joint = |parent, child| JointDesc {
            parent,
            child,
            frame_parent: Transform::new(Vec3::new(0.0, -0.5, 0.0), Quat::IDENTITY),
            frame_child: Transform::new(Vec3::new(0.0, 0.5, 0.0), Quat::IDENTITY),
            kind: JointKind::Ball,
        };
        let bodies = [body(2.5), body(1.5), body(0.5)];
        let mut limits = LimitProjection::closing_gaps(0.001);
        limits.add_ragdoll(0, &bodies, &[joint(0, 1), joint(1, 2)]);
        let mut poses: Vec<Transform> = bodies.iter().map(|b| b.pose).collect();
        poses[2].translation.y -= drop_m;
        (limits, poses)
    }

    fn roles(held: [bool; 3]) -> Vec<BodyRole> {
        held.map(|held| BodyRole {
            dynamic: true,
            held,
        })
        .to_vec()
    }

    #[test]
    fn a_gap_past_the_tolerance_is_narrowed_to_it_keeping_the_centre_of_mass() {
        let (limits, mut poses) = chain(0.005);
        let r = roles([false; 3]);
        let height = |p: &[Transform]| p.iter().map(|p| p.translation.y).sum::<f32>();
        let before = height(&poses);
        assert!((limits.worst_separation(&poses, &r) - 0.005).abs() < 1e-5);
        assert_eq!(limits.project(&mut poses, &r, None), vec![0, 1, 2]);
        assert!((limits.worst_separation(&poses, &r) - 0.001).abs() < 1e-5);
        // The lowest body (a third of the mass) moved up two thirds of the 4 mm.
        assert!((poses[2].translation.y - (0.495 + 0.004 * 2.0 / 3.0)).abs() < 1e-5);
        assert!((height(&poses) - before).abs() < 1e-5);

        // The lowest body held (a pin): the rest of the ragdoll comes down to it instead.
        let (limits, mut poses) = chain(0.005);
        let r = roles([false, false, true]);
        assert_eq!(limits.project(&mut poses, &r, None), vec![0, 1]);
        assert!((limits.worst_separation(&poses, &r) - 0.001).abs() < 1e-5);
        assert!((poses[0].translation.y - 2.496).abs() < 1e-5);
        assert!((poses[2].translation.y - 0.495).abs() < 1e-5);
    }

    #[test]
    fn a_gap_within_the_tolerance_or_held_on_both_sides_is_left() {
        let (limits, mut poses) = chain(0.0005);
        assert!(
            limits
                .project(&mut poses, &roles([false; 3]), None)
                .is_empty()
        );
        let (limits, mut poses) = chain(0.005);
        assert!(
            limits
                .project(&mut poses, &roles([true, false, true]), None)
                .is_empty()
        );
        // Without the tolerance, gaps are the solver's.
        let (mut limits, mut poses) = chain(0.005);
        limits.gap_tolerance_m = None;
        assert!(
            limits
                .project(&mut poses, &roles([false; 3]), None)
                .is_empty()
        );
    }

    #[test]
    fn narrowing_a_gap_pushes_no_body_into_the_ground() {
        // The lowest body 5 cm above where its joint holds it, resting on the ground at
        // y = 0.1: narrowing the gap would sink it 3 cm, so the whole ragdoll is lifted.
        let (limits, mut poses) = chain(-0.05);
        let r = roles([false; 3]);
        let lowest = |p: &[Transform]| {
            Shape::Capsule {
                radius_m: 0.05,
                length_m: 0.8,
            }
            .lowest_y(&p[2])
        };
        assert!((lowest(&poses) - 0.1).abs() < 1e-5);
        assert_eq!(limits.project(&mut poses, &r, Some(0.1)), vec![0, 1, 2]);
        assert!((limits.worst_separation(&poses, &r) - 0.001).abs() < 1e-5);
        assert!(lowest(&poses) >= 0.1 - PROJECTION_GROUND_SLACK_M - 1e-5);
    }
}
