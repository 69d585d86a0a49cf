//! Two boxes' deepest contact by the separating-axis test (Gottschalk et al. 1996, as
//! Ericson, Real-Time Collision Detection, §4.4.1): of the fifteen axes that can separate
//! two boxes (three face normals of each, nine cross products of their edges), the one
//! along which they overlap least gives the depth (the least translation that parts them)
//! and the normal; the contact point is the deepest corner on a face axis, the nearest
//! points of the two supporting edges on an edge axis.
//!
//! Written here because parry's one-shot `query::contact` takes two boxes through GJK
//! and EPA, and for two of the Fox's boxes a third of a millimetre apart it answered
//! 95 mm deep: the solver pushed them apart by that much in one substep and the Fox
//! gained 190 % of its energy. The separating axes are exact for boxes, and cheap.

use glam::{Mat3, Quat, Vec3};

use super::narrow::Found;

/// An edge axis takes the place of the best face axis only where the boxes overlap less
/// along it by this much, metres: nearly level faces keep their face's normal, steady
/// from one substep to the next, rather than an edge pair's that turns with every
/// rounding.
const EDGE_BIAS_M: f32 = 1.0e-4;
/// Cross products of nearly parallel edges shorter than this are no axis.
const MIN_EDGE_AXIS: f32 = 1.0e-5;

/// The deepest contact of box `a` (pose, half extents) and box `b`, the first's first, if
/// they are within `within` metres along some axis (depth negative when apart).
pub(super) fn box_box(
    (pos_a, rot_a): (Vec3, Quat),
    half_a: Vec3,
    (pos_b, rot_b): (Vec3, Quat),
    half_b: Vec3,
    within: f32,
) -> Option<Found> {
    let (ma, mb) = (Mat3::from_quat(rot_a), Mat3::from_quat(rot_b));
    let axes_a = [ma.x_axis, ma.y_axis, ma.z_axis];
    let axes_b = [mb.x_axis, mb.y_axis, mb.z_axis];
    let d = pos_a - pos_b;
    // How much the boxes overlap along the unit axis `l`.
    let overlap = |l: Vec3| {
        let ra: f32 = (0..3).map(|i| half_a[i] * axes_a[i].dot(l).abs()).sum();
        let rb: f32 = (0..3).map(|i| half_b[i] * axes_b[i].dot(l).abs()).sum();
        ra + rb - d.dot(l).abs()
    };
    // (overlap, axis, which: 0-2 a's faces, 3-5 b's faces, 6.. edge pairs)
    let mut best: Option<(f32, Vec3, usize)> = None;
    let mut consider = |l: Vec3, k: usize, bias: f32| -> bool {
        let o = overlap(l);
        if o < -within {
            return false;
        }
        if best.is_none_or(|(b, _, _)| o < b - bias) {
            best = Some((o, l, k));
        }
        true
    };
    for (i, &l) in axes_a.iter().chain(&axes_b).enumerate() {
        if !consider(l, i, 0.0) {
            return None;
        }
    }
    for (i, &ea) in axes_a.iter().enumerate() {
        for (j, &eb) in axes_b.iter().enumerate() {
            let l = ea.cross(eb);
            let len = l.length();
            if len < MIN_EDGE_AXIS {
                continue;
            }
            if !consider(l / len, 6 + 3 * i + j, EDGE_BIAS_M) {
                return None;
            }
        }
    }
    let (depth, l, which) = best?;
    // The normal from b toward a.
    let n = if d.dot(l) < 0.0 { -l } else { l };
    // A box's corner farthest along `dir`, or with axis `free` left at the centre: the
    // middle of its edge along that axis.
    let support = |pos: Vec3, axes: &[Vec3; 3], half: Vec3, dir: Vec3, free: Option<usize>| {
        (0..3).filter(|&i| Some(i) != free).fold(pos, |p, i| {
            p + axes[i] * (half[i] * axes[i].dot(dir).signum())
        })
    };
    let (pa, pb) = match which {
        // a's face: b's corner deepest into it, and that point on a's face.
        0..=2 => {
            let pb = support(pos_b, &axes_b, half_b, n, None);
            (pb - n * depth, pb)
        }
        // b's face: a's corner deepest into it.
        3..=5 => {
            let pa = support(pos_a, &axes_a, half_a, -n, None);
            (pa, pa + n * depth)
        }
        // Two edges: the nearest points of a's edge toward b and b's edge toward a.
        k => {
            let (i, j) = ((k - 6) / 3, (k - 6) % 3);
            let ca = support(pos_a, &axes_a, half_a, -n, Some(i));
            let cb = support(pos_b, &axes_b, half_b, n, Some(j));
            let (ea, eb) = (axes_a[i] * half_a[i], axes_b[j] * half_b[j]);
            let (s, t) = crate::math::closest_segment_params(ca - ea, ca + ea, cb - eb, cb + eb);
            ((ca - ea).lerp(ca + ea, s), (cb - eb).lerp(cb + eb, t))
        }
    };
    (depth.is_finite() && n.is_finite()).then_some(Found { pa, pb, n, depth })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pose from a few numbers, spread over position and orientation.
    fn pose(k: u32, spread: f32) -> (Vec3, Quat) {
        let f = |m: u32| {
            ((k.wrapping_mul(2_654_435_761).wrapping_add(m * 40_503) % 1000) as f32 / 500.0) - 1.0
        };
        let axis = Vec3::new(f(1), f(2), f(3) + 0.01).normalize();
        (
            Vec3::new(f(4), f(5), f(6)) * spread,
            Quat::from_axis_angle(axis, 3.0 * f(7)),
        )
    }

    /// Distance from `p` to the box of half extents `half` at `pose`, exactly.
    fn point_box_distance(p: Vec3, (pos, rot): (Vec3, Quat), half: Vec3) -> f32 {
        let q = rot.conjugate() * (p - pos);
        (q.abs() - half).max(Vec3::ZERO).length()
    }

    /// The distance from the segment `p → q` to a box: the point-to-box distance is
    /// convex along a line, so a golden-section search finds its least to rounding.
    fn segment_box_distance(p: Vec3, q: Vec3, b: (Vec3, Quat), half: Vec3) -> f32 {
        let f = |t: f32| point_box_distance(p.lerp(q, t), b, half);
        let (mut lo, mut hi) = (0.0f32, 1.0f32);
        for _ in 0..80 {
            let (x1, x2) = (hi - 0.618_034 * (hi - lo), lo + 0.618_034 * (hi - lo));
            if f(x1) < f(x2) { hi = x2 } else { lo = x1 }
        }
        f(0.5 * (lo + hi)).min(f(0.0)).min(f(1.0))
    }

    /// A box's twelve edges in the world.
    fn edges((pos, rot): (Vec3, Quat), half: Vec3) -> Vec<(Vec3, Vec3)> {
        let corner = |i: usize| {
            let s = |bit: usize| if i & bit == 0 { -1.0 } else { 1.0 };
            pos + rot * (half * Vec3::new(s(1), s(2), s(4)))
        };
        let mut out = Vec::new();
        for i in 0..8usize {
            for bit in [1, 2, 4] {
                if i & bit == 0 {
                    out.push((corner(i), corner(i | bit)));
                }
            }
        }
        out
    }

    /// The distance between two boxes, 0 when they overlap, without the separating axes:
    /// the least distance from an edge of either to the other box. Two convex polyhedra
    /// apart have their closest points on an edge of one of them, and two that overlap
    /// have an edge of one in the other.
    fn distance(a: (Vec3, Quat), ha: Vec3, b: (Vec3, Quat), hb: Vec3) -> f32 {
        let from_a = edges(a, ha)
            .into_iter()
            .map(|(p, q)| segment_box_distance(p, q, b, hb));
        let from_b = edges(b, hb)
            .into_iter()
            .map(|(p, q)| segment_box_distance(p, q, a, ha));
        from_a.chain(from_b).fold(f32::INFINITY, f32::min)
    }

    #[test]
    fn box_contacts_agree_with_the_distance_and_the_slide_between_them() {
        // Boxes in many poses, slid along a line to touching, then 0.5, 4 and 8 mm further
        // in or out. In, the depth is more than nothing and no more than the slide past
        // touching (sliding back parts them); out, the gap found is no more than their
        // distance, worked out from their edges, and a face against anything is found
        // that far apart.
        let (ha, hb) = (Vec3::new(0.15, 0.1, 0.2), Vec3::new(0.05, 0.12, 0.08));
        let (mut exact_gaps, mut edge_axes) = (0, 0);
        for k in 0..300u32 {
            let a = pose(k, 0.0);
            let rot_b = pose(k + 7919, 0.0).1;
            let dir = pose(k + 104_729, 1.0).0.normalize_or(Vec3::X);
            let at = |t: f32| (a.0 + dir * t, rot_b);
            let gap_at = |t: f32| distance(a, ha, at(t), hb);
            let find = |t: f32| box_box(a, ha, at(t), hb, 0.02);
            // The slide along `dir` that brings them to touching, by bisection (the edge
            // search leaves a few nanometres of rounding where an edge grazes a box).
            let (mut lo, mut hi) = (0.0f32, 1.0f32);
            assert!(gap_at(hi) > 0.0, "{k}");
            for _ in 0..40 {
                let mid = 0.5 * (lo + hi);
                if gap_at(mid) > 1e-6 {
                    hi = mid
                } else {
                    lo = mid
                }
            }
            for s in [0.0005, 0.004, 0.008] {
                let f = find(lo - s).unwrap_or_else(|| panic!("{k}: boxes {s} m in not found"));
                assert!(
                    f.depth > 0.0 && f.depth <= s + 2e-4,
                    "{k}: {} deep after a slide of {s} m in",
                    f.depth
                );
                assert!((f.n.length() - 1.0).abs() < 1e-4, "{k}");
                // The points found are that deep along the normal (from b toward a).
                assert!(
                    ((f.pb - f.pa).dot(f.n) - f.depth).abs() < 2e-4,
                    "{k}: {f:?}"
                );
                let t = hi + s;
                let exact = gap_at(t);
                let f = find(t).unwrap_or_else(|| panic!("{k}: boxes {exact} m apart not found"));
                let gap = -f.depth;
                assert!(
                    gap > -1e-5 && gap <= exact + 2e-4,
                    "{k}: {gap} found, {exact} apart"
                );
                if (gap - exact).abs() < 2e-4 {
                    exact_gaps += 1;
                }
            }
            // Whichever axis won at the deepest slide, count the edge pairs.
            if let Some(f) = find(lo - 0.008) {
                let along_faces = [a.1, rot_b]
                    .iter()
                    .flat_map(|q| [*q * Vec3::X, *q * Vec3::Y, *q * Vec3::Z])
                    .any(|axis| axis.dot(f.n).abs() > 0.9999);
                edge_axes += usize::from(!along_faces);
            }
        }
        // Most gaps are a face against a corner or an edge, exactly measured; and the
        // poses meet edges against edges too.
        assert!(exact_gaps > 450, "{exact_gaps} of 900 gaps exact");
        assert!(edge_axes > 10, "{edge_axes} edge-edge contacts");
    }

    #[test]
    fn boxes_far_apart_meet_nothing_and_a_box_on_a_box_rests_on_its_face() {
        let half = Vec3::new(0.2, 0.1, 0.3);
        let far = box_box(
            (Vec3::ZERO, Quat::IDENTITY),
            half,
            (Vec3::X, Quat::IDENTITY),
            half,
            0.02,
        );
        assert!(far.is_none());
        // A box lying 1 mm into the one below it, turned about the vertical: pushed up.
        let top = (Vec3::new(0.05, 0.199, 0.0), Quat::from_rotation_y(0.4));
        let f = box_box(top, half, (Vec3::ZERO, Quat::IDENTITY), half, 0.02).unwrap();
        assert!((f.depth - 0.001).abs() < 1e-5, "{f:?}");
        assert!(f.n.dot(Vec3::Y) > 0.9999, "{f:?}");
    }

    #[test]
    fn two_of_the_foxs_boxes_a_third_of_a_millimetre_apart() {
        // Where parry's `query::contact` answered 94.8 mm deep: the Fox's spine and upper
        // arm, landing (`--units cm`, 1.4 s into a drop on the fast backend).
        let a = (
            Vec3::new(0.013907695, 0.22820447, 0.04971167),
            Quat::from_array([0.5763122, 0.44621742, 0.42427695, 0.53734857]).normalize(),
        );
        let ha = Vec3::new(0.12196257, 0.03361383, 0.09085305);
        let b = (
            Vec3::new(-0.03400467, 0.091489375, 0.17999221),
            Quat::from_array([0.5481026, -0.48649248, 0.6159689, -0.2889481]).normalize(),
        );
        let hb = Vec3::new(0.058019213, 0.0800367, 0.028517092);
        let exact = distance(a, ha, b, hb);
        assert!((exact - 0.00033).abs() < 1e-4, "{exact}");
        let f = box_box(a, ha, b, hb, 0.005).unwrap();
        assert!(
            (f.depth + exact).abs() < 1e-4,
            "{f:?} against {exact} apart"
        );
    }
}
