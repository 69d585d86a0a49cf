//! How deep two shapes lie in each other, from parry's exact contact queries: the reading
//! of overlaps that trusts no engine's contacts (`World::overlap_now`).

use rapier3d::parry::math::Pose;
use rapier3d::parry::query::{ContactManifold, DefaultQueryDispatcher, PersistentQueryDispatcher};
use rapier3d::parry::shape::SharedShape;

use crate::math::Transform;
use crate::spec::Shape;

/// The shape as parry measures it.
pub(crate) fn solid(s: &Shape) -> SharedShape {
    match *s {
        Shape::Capsule { radius_m, length_m } => SharedShape::capsule_y(0.5 * length_m, radius_m),
        Shape::Box { size_m } => {
            SharedShape::cuboid(size_m[0] * 0.5, size_m[1] * 0.5, size_m[2] * 0.5)
        }
    }
}

/// How deep two shapes lie in each other, metres; 0 when apart or when parry cannot say.
///
/// From parry's contact manifolds, the contacts rapier itself is built on (a dedicated
/// routine for two capsules, clipping for two boxes), not from its one-shot
/// `query::contact`: that takes any two capsules through GJK and EPA, and for two feet
/// lying 0.6 mm apart in a settled pile it answered 25.8 mm deep (and `query::distance`
/// 11.9 mm apart), where the manifold, our closest-segment code and a brute-force check
/// agree on 0.6 mm apart.
pub(crate) fn depth_between(
    pa: &Transform,
    a: &SharedShape,
    pb: &Transform,
    b: &SharedShape,
) -> f32 {
    let pose = |p: &Transform| Pose::from_parts(p.translation, p.rotation);
    let pos12 = pose(pa).inv_mul(&pose(pb));
    let mut manifolds: Vec<ContactManifold<(), ()>> = Vec::new();
    let found = DefaultQueryDispatcher.contact_manifolds(
        &pos12,
        &*a.0,
        &*b.0,
        0.0,
        &mut manifolds,
        &mut None,
    );
    if found.is_err() {
        return 0.0;
    }
    manifolds
        .iter()
        .flat_map(|m| &m.points)
        .map(|p| -p.dist)
        .fold(0.0, f32::max)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Quat, Vec3};

    #[test]
    fn depth_is_how_far_two_shapes_overlap() {
        let ball = solid(&Shape::Capsule {
            radius_m: 0.1,
            length_m: 0.0,
        });
        let at = |x: f32| Transform::new(Vec3::new(x, 0.0, 0.0), Quat::IDENTITY);
        // Two 0.1 m balls 0.15 m apart overlap by 5 cm; 0.25 m apart they do not.
        assert!((depth_between(&at(0.0), &ball, &at(0.15), &ball) - 0.05).abs() < 1e-5);
        assert_eq!(depth_between(&at(0.0), &ball, &at(0.25), &ball), 0.0);
        // A ball 2 cm into the face of a box 0.4 m wide.
        let cube = solid(&Shape::Box {
            size_m: [0.4, 0.4, 0.4],
        });
        assert!((depth_between(&at(0.0), &cube, &at(0.28), &ball) - 0.02).abs() < 1e-5);
        assert!((depth_between(&at(0.28), &ball, &at(0.0), &cube) - 0.02).abs() < 1e-5);
    }

    /// Two feet of a settled pile 0.6 mm apart (a brute-force search of the two capsules'
    /// axes finds them 69.4 mm apart, against radii summing to 68.8 mm), which parry's
    /// one-shot GJK/EPA contact read as 25.8 mm deep.
    #[test]
    fn capsules_that_nearly_touch_do_not_overlap() {
        let foot = solid(&Shape::Capsule {
            radius_m: 0.0344,
            length_m: 0.1084,
        });
        let a = Transform::new(
            Vec3::new(0.055108, 0.040544, 0.139661),
            Quat::from_xyzw(0.66705, -0.647203, -0.334178, 0.15652).normalize(),
        );
        let b = Transform::new(
            Vec3::new(-0.033802, 0.060688, 0.2754),
            Quat::from_xyzw(-0.16562, 0.674175, -0.636472, 0.336097).normalize(),
        );
        assert_eq!(depth_between(&a, &foot, &b, &foot), 0.0);
        // Brought 5 mm closer along the line between them, they overlap by about 4.4 mm.
        let closer = Transform::new(
            b.translation - (b.translation - a.translation).normalize() * 0.005,
            b.rotation,
        );
        let d = depth_between(&a, &foot, &closer, &foot);
        assert!(d > 0.001 && d < 0.005, "{d}");
    }
}
