//! A spec's shapes and joints in rapier's terms: colliders with the ragdoll's contact
//! material, impulse joints, and the hook that drops the contacts the spec filters out.

use std::collections::HashSet;

use rapier3d::prelude::*;

use crate::backend::JointDesc;
use crate::math::Transform;
use crate::spec::{JointKind, Shape};

/// Friction of body-body and body-ground contacts: skin and clothing on a hard floor are
/// around 0.5-0.8.
pub(super) const FRICTION: f32 = 0.7;

/// Collider user data of the ground, distinct from any ragdoll body key.
pub(super) const GROUND_KEY: u128 = u128::MAX;
/// Set in the user data of an extra shape's collider, above its body's index: extra
/// shapes never meet their own ragdoll's bodies.
pub(super) const EXTRA_BIT: u128 = 1 << 64;

/// Filters contacts between pairs of bodies the spec says never collide, and between an
/// extra shape and its own ragdoll.
pub(super) struct PairFilter {
    /// Unordered pairs of global body keys.
    pub disabled: HashSet<(u32, u32)>,
    /// Each body's ragdoll (insertion order).
    pub ragdoll_of: Vec<u32>,
}

impl PhysicsHooks for PairFilter {
    fn filter_contact_pair(&self, ctx: &PairFilterContext) -> Option<SolverFlags> {
        let k1 = ctx.colliders[ctx.collider1].user_data;
        let k2 = ctx.colliders[ctx.collider2].user_data;
        if k1 != GROUND_KEY && k2 != GROUND_KEY {
            let (a, b) = (k1 as u32, k2 as u32);
            if self.disabled.contains(&(a.min(b), a.max(b))) {
                return None;
            }
            let extra = (k1 | k2) & EXTRA_BIT != 0;
            if extra && self.ragdoll_of.get(a as usize) == self.ragdoll_of.get(b as usize) {
                return None;
            }
        }
        Some(SolverFlags::COMPUTE_RIGID_IMPULSES)
    }
}

/// A transform as rapier's pose.
pub(super) fn pose(t: &Transform) -> Pose {
    Pose::from_parts(t.translation, t.rotation)
}

/// A collider of `shape` for the body of global index `key` (its user data, which the
/// contact filter and the queries read), with the ragdoll's contact material.
pub(super) fn collider_of(shape: &Shape, key: u128) -> ColliderBuilder {
    let builder = match *shape {
        Shape::Capsule { radius_m, length_m } => {
            ColliderBuilder::capsule_y(0.5 * length_m, radius_m)
        }
        Shape::Box { size_m } => {
            ColliderBuilder::cuboid(0.5 * size_m[0], 0.5 * size_m[1], 0.5 * size_m[2])
        }
    };
    builder
        .friction(FRICTION)
        .restitution(0.0)
        .user_data(key)
        .active_hooks(ActiveHooks::FILTER_CONTACT_PAIRS)
}

/// A spec joint as rapier's impulse joint (see the module's note on the mapping).
pub(super) fn make_joint(j: &JointDesc) -> GenericJoint {
    let builder = match j.kind {
        JointKind::Hinge { min_deg, max_deg } => {
            GenericJointBuilder::new(JointAxesMask::LOCKED_REVOLUTE_AXES).limits(
                JointAxis::AngX,
                [min_deg.to_radians(), max_deg.to_radians()],
            )
        }
        JointKind::SwingTwist {
            swing_deg,
            twist_deg,
            ..
        } => GenericJointBuilder::new(JointAxesMask::LOCKED_SPHERICAL_AXES)
            .coupled_axes(JointAxesMask::ANG_Y | JointAxesMask::ANG_Z)
            // The cone angle is never negative; a lower limit of 0 would make rapier block
            // one arbitrary direction while the angle is exactly 0 (its Jacobian is then
            // any vector perpendicular to X), pinning a joint that starts at rest.
            .limits(
                JointAxis::AngY,
                [-swing_deg.to_radians(), swing_deg.to_radians()],
            )
            .limits(
                JointAxis::AngX,
                [twist_deg[0].to_radians(), twist_deg[1].to_radians()],
            ),
        JointKind::Ball => GenericJointBuilder::new(JointAxesMask::LOCKED_SPHERICAL_AXES),
        JointKind::Fixed => GenericJointBuilder::new(JointAxesMask::LOCKED_FIXED_AXES),
    };
    builder
        .local_frame1(pose(&j.frame_parent))
        .local_frame2(pose(&j.frame_child))
        .contacts_enabled(false)
        .build()
}
