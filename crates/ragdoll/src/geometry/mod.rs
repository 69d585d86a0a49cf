//! Shapes in space, below both the world and the engines (as parry sits below rapier):
//! the broad phase, capsules inside boxes, loose bounds, inertia, ray casts and overlap
//! depth. The world's start checks and measurements and every engine of ours ask the same
//! questions of the same shapes here, so they agree on what touches what.

pub(crate) mod broad;
pub(crate) mod depth;
pub(crate) mod shapes;

use glam::Vec3;

use crate::math::Transform;
use crate::spec::Shape;
pub(crate) use shapes::{body_inertia, box_corners, nearest_hit, ray_shape};

/// Body-frame capsule of a shape, segment ends and radius: the shape itself for a capsule,
/// the capsule inside a box along its longest edge (radius the smaller of the other two
/// half edges), so it never reaches past the box.
pub(crate) fn capsule_of(shape: &Shape) -> ([Vec3; 2], f32) {
    match *shape {
        Shape::Capsule { radius_m, length_m } => {
            let h = Vec3::Y * (0.5 * length_m);
            ([-h, h], radius_m)
        }
        Shape::Box { size_m } => {
            let s = Vec3::from_array(size_m) * 0.5;
            let axis = if s.x >= s.y && s.x >= s.z {
                0
            } else if s.y >= s.z {
                1
            } else {
                2
            };
            let (long, r) = match axis {
                0 => (s.x, s.y.min(s.z)),
                1 => (s.y, s.x.min(s.z)),
                _ => (s.z, s.x.min(s.y)),
            };
            let mut h = Vec3::ZERO;
            h[axis] = (long - r).max(0.0);
            ([-h, h], r)
        }
    }
}

/// A box around a shape at `pose` and everything [`crate::spec::shapes_overlap`] counts as
/// part of it (its capsule round a box reaches past the box's ends), for a broad phase
/// in front of that test.
pub(crate) fn loose_bounds(pose: &Transform, shape: &Shape) -> (Vec3, Vec3) {
    let reach = match *shape {
        Shape::Capsule { radius_m, length_m } => {
            let half = pose.rotation * Vec3::Y * (0.5 * length_m);
            return (
                pose.translation - half.abs() - radius_m,
                pose.translation + half.abs() + radius_m,
            );
        }
        // The half diagonal plus the longest half edge holds any capsule round the box.
        Shape::Box { size_m } => {
            let h = Vec3::from_array(size_m) * 0.5;
            h.length() + h.max_element()
        }
    };
    (pose.translation - reach, pose.translation + reach)
}
