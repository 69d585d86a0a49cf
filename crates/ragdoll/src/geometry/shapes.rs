//! What a body's shapes weigh and where rays meet them: inertia tensors, ray casts against
//! capsules and boxes, and a box's corners.

use glam::{Mat3, Vec3};

use crate::math::Transform;
use crate::spec::Shape;

/// Inertia tensor of a shape about its centre, body frame, kg·m².
/// A body's inertia about its centre (the centre of its own shape), diagonal in its frame:
/// its `mass` spread over its own shape and its `extras` (each at its place in the body
/// frame) by their volumes. The extras are skin the body carries: a dragon spine body's
/// pieces of foot half its length from its centre, with the inertia of its own small shape
/// alone, took a push from the floor there as a body a tenth as heavy would, and the
/// fast backend drove them 13 cm into the floor while the dragon was dragged. The centre
/// of mass stays the own shape's centre, and the products of inertia are left out (the
/// diagonal of any inertia tensor is a valid set of moments); without extras this is
/// [`inertia_of`].
pub(crate) fn body_inertia(shape: &Shape, extras: &[(Shape, Transform)], mass: f32) -> Mat3 {
    if extras.is_empty() {
        return inertia_of(shape, mass);
    }
    let total = shape.volume() + extras.iter().map(|(s, _)| s.volume()).sum::<f32>();
    let share = |s: &Shape| mass * s.volume() / total.max(f32::MIN_POSITIVE);
    let mut t = inertia_of(shape, share(shape));
    for (s, at) in extras {
        let m = share(s);
        let r = Mat3::from_quat(at.rotation);
        let d = at.translation;
        let shift = Mat3::from_diagonal(Vec3::splat(d.length_squared()))
            - Mat3::from_cols(d * d.x, d * d.y, d * d.z);
        t += r * inertia_of(s, m) * r.transpose() + shift * m;
    }
    Mat3::from_diagonal(t.diagonal())
}

pub(crate) fn inertia_of(shape: &Shape, mass: f32) -> Mat3 {
    match *shape {
        Shape::Capsule {
            radius_m: r,
            length_m: l,
        } => {
            let v_cyl = std::f32::consts::PI * r * r * l;
            let v_sph = 4.0 / 3.0 * std::f32::consts::PI * r * r * r;
            let total = (v_cyl + v_sph).max(1e-12);
            let (mc, ms) = (mass * v_cyl / total, mass * v_sph / total);
            let across = mc * (l * l / 12.0 + r * r / 4.0)
                + ms * (0.4 * r * r + l * l / 4.0 + 0.375 * l * r);
            let along = mc * 0.5 * r * r + ms * 0.4 * r * r;
            Mat3::from_diagonal(Vec3::new(across, along, across))
        }
        Shape::Box { size_m: s } => {
            let k = mass / 12.0;
            Mat3::from_diagonal(Vec3::new(
                k * (s[1] * s[1] + s[2] * s[2]),
                k * (s[0] * s[0] + s[2] * s[2]),
                k * (s[0] * s[0] + s[1] * s[1]),
            ))
        }
    }
}

/// Distance along the unit ray `origin + t·dir`, `t ≥ 0`, to the capsule `a b` of radius `r`.
pub(crate) fn ray_capsule(origin: Vec3, dir: Vec3, a: Vec3, b: Vec3, r: f32) -> Option<f32> {
    let mut best: Option<f32> = None;
    let mut consider = |t: f32| {
        if t >= 0.0 && best.is_none_or(|b| t < b) {
            best = Some(t);
        }
    };
    for c in [a, b] {
        let oc = origin - c;
        let bq = oc.dot(dir);
        let cq = oc.length_squared() - r * r;
        let disc = bq * bq - cq;
        if disc >= 0.0 {
            consider(-bq - disc.sqrt());
        }
    }
    let ba = b - a;
    let oa = origin - a;
    let baba = ba.dot(ba);
    let bard = ba.dot(dir);
    let baoa = ba.dot(oa);
    let k2 = baba - bard * bard;
    if baba > 1e-12 && k2 > 1e-12 {
        let k1 = baba * oa.dot(dir) - baoa * bard;
        let k0 = baba * oa.length_squared() - baoa * baoa - r * r * baba;
        let disc = k1 * k1 - k2 * k0;
        if disc >= 0.0 {
            let t = (-k1 - disc.sqrt()) / k2;
            let y = baoa + t * bard;
            if y > 0.0 && y < baba {
                consider(t);
            }
        }
    }
    best
}

/// Distance along the unit ray `origin + t·dir`, `t ≥ 0`, to the box of half extents
/// `half` centred on the origin (slab test); 0 from inside.
pub(crate) fn ray_box(origin: Vec3, dir: Vec3, half: Vec3) -> Option<f32> {
    let (mut near, mut far) = (0.0f32, f32::INFINITY);
    for k in 0..3 {
        let (o, d, h) = (origin[k], dir[k], half[k]);
        if d.abs() < 1e-12 {
            if o.abs() > h {
                return None;
            }
            continue;
        }
        let (t0, t1) = ((-h - o) / d, (h - o) / d);
        near = near.max(t0.min(t1));
        far = far.min(t0.max(t1));
        if near > far {
            return None;
        }
    }
    Some(near)
}

/// Distance along the unit ray to `shape` at `pos`, `rot`: a box as a box, a capsule by the
/// segment `ends` the backend reads for it (a particle body's come from its particles).
pub(crate) fn ray_shape(
    origin: Vec3,
    dir: Vec3,
    shape: &Shape,
    pos: Vec3,
    rot: glam::Quat,
    ends: (Vec3, Vec3),
) -> Option<f32> {
    match *shape {
        Shape::Capsule { radius_m, .. } => ray_capsule(origin, dir, ends.0, ends.1, radius_m),
        Shape::Box { size_m } => {
            let inv = rot.conjugate();
            let half = Vec3::from_array(size_m) * 0.5;
            ray_box(inv * (origin - pos), inv * dir, half)
        }
    }
}

/// The index and distance of the nearest of `hits` (one per body, `None` for a miss)
/// within `max_dist`.
pub(crate) fn nearest_hit(
    hits: impl Iterator<Item = Option<f32>>,
    max_dist: f32,
) -> Option<(usize, f32)> {
    hits.enumerate()
        .filter_map(|(i, t)| t.filter(|&t| t <= max_dist).map(|t| (i, t)))
        .fold(None, |best: Option<(usize, f32)>, (i, t)| {
            if best.is_none_or(|(_, bt)| t < bt) {
                Some((i, t))
            } else {
                best
            }
        })
}

/// The eight corners of a box of half extents `half` about its centre, in its own frame
/// (corner `k` takes +x, +y, +z where bits 0, 1, 2 of `k` are set).
pub(crate) fn box_corners(half: Vec3) -> [Vec3; 8] {
    std::array::from_fn(|k| {
        let sign = |bit: usize| if k & bit == 0 { -1.0 } else { 1.0 };
        half * Vec3::new(sign(1), sign(2), sign(4))
    })
}

/// A body's principal moments of inertia about its centre, in its own frame (long axis
/// Y), kg·m². A capsule counts as a cylinder of its whole length: close enough for sizing
/// a motor, and it keeps the small moment about the long axis, which is what a twist
/// turns (sizing a twist for the tumbling moment overshot it tenfold).
pub(crate) fn principal_inertia(shape: &Shape, mass: f32) -> Vec3 {
    match *shape {
        Shape::Capsule { radius_m, length_m } => {
            let l = length_m + 2.0 * radius_m;
            let across = mass * (3.0 * radius_m * radius_m + l * l) / 12.0;
            Vec3::new(across, 0.5 * mass * radius_m * radius_m, across)
        }
        Shape::Box { size_m } => {
            let [x, y, z] = size_m.map(|s| s * s);
            Vec3::new(y + z, x + z, x + y) * (mass / 12.0)
        }
    }
}

/// Moment of inertia of a body about the axis `n` (unit, world) through `anchor`, kg·m².
pub(crate) fn inertia_about(
    pose: &Transform,
    principal: Vec3,
    mass: f32,
    anchor: Vec3,
    n: Vec3,
) -> f32 {
    let local = pose.rotation.conjugate() * n;
    let own = (local * local).dot(principal);
    let r = pose.translation - anchor;
    own + mass * (r.length_squared() - r.dot(n).powi(2)).max(0.0)
}

/// Inertia a motor turns, kg·m²: the child body's about the joint anchor along the
/// torque's axis (its own plus m·r²) and the parent's about the same point, combined as a reduced inertia (the motor
/// turns both against each other); the child's alone when the parent is a root held on the
/// clip.
///
/// Only the two bodies count, not the child's whole subtree, although the subtree is what
/// the motor ends up turning: a torque impulse reaches the child body alone within a
/// substep (the joints below pass it on only through their own motors, one substep
/// later), so sizing it for the subtree made the child overshoot several times over and
/// the chain blew up. Sized for the two bodies, each motor is stable on its own; the load
/// of the bodies below (their weight, their swing) is then held with a lower stiffness
/// than designed, which the high frequency keeps to a degree or two.
pub(crate) fn effective_inertia(child: f32, parent: Option<f32>) -> f32 {
    match parent {
        Some(p) if p > 0.0 => child * p / (child + p),
        _ => child,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ray_meets_capsule_side_and_cap() {
        let (a, b) = (Vec3::new(0.0, -1.0, 0.0), Vec3::new(0.0, 1.0, 0.0));
        let side = ray_capsule(Vec3::new(-5.0, 0.0, 0.0), Vec3::X, a, b, 0.5).unwrap();
        assert!((side - 4.5).abs() < 1e-5, "{side}");
        let cap = ray_capsule(Vec3::new(0.0, 5.0, 0.0), -Vec3::Y, a, b, 0.5).unwrap();
        assert!((cap - 3.5).abs() < 1e-5, "{cap}");
        assert!(ray_capsule(Vec3::new(-5.0, 0.0, 2.0), Vec3::X, a, b, 0.5).is_none());
    }

    #[test]
    fn ray_meets_box_faces_and_misses_beside_it() {
        let half = Vec3::new(0.15, 0.1, 0.1);
        let front = ray_box(Vec3::new(0.0, 0.09, 5.0), -Vec3::Z, half).unwrap();
        assert!((front - 4.9).abs() < 1e-5, "{front}");
        let slanted = Vec3::new(0.0, -0.1, -1.0).normalize();
        assert!(ray_box(Vec3::new(0.0, 0.5, 5.0), slanted, half).is_some());
        assert!(ray_box(Vec3::new(0.0, 0.11, 5.0), -Vec3::Z, half).is_none());
        assert_eq!(ray_box(Vec3::ZERO, Vec3::X, half), Some(0.0));
    }

    #[test]
    fn the_nearest_hit_within_range_wins() {
        let hits = [Some(3.0), None, Some(1.5), Some(0.5)];
        assert_eq!(nearest_hit(hits.into_iter(), 10.0), Some((3, 0.5)));
        assert_eq!(nearest_hit(hits.into_iter(), 0.4), None);
        assert_eq!(
            nearest_hit([None, Some(2.0)].into_iter(), 2.0),
            Some((1, 2.0))
        );
    }
}
