//! The contact of a capsule with a box, by hand, in the box's frame: closest points of the
//! capsule's segment and the box when the segment misses it, the shallowest way out
//! through a box face when it enters it. parry's general GJK took a quarter of a pile's
//! time here; it is the reference this is tested against (`contact.rs`).

use glam::Vec3;

/// The contact of the capsule of segment `l0 l1` and radius `r` with the box of half
/// extents `half` centred on the origin, both in the box's frame: the point on the
/// capsule's surface, the point on the box, the normal from the box toward the capsule
/// and the depth (negative when apart); `None` when they are more than `touch` apart.
pub(super) fn contact_in_box_frame(
    l0: Vec3,
    l1: Vec3,
    half: Vec3,
    r: f32,
    touch: f32,
) -> Option<(Vec3, Vec3, Vec3, f32)> {
    // Far apart: the segment misses the box's bounding sphere by more than the radius.
    let (s0, _) = crate::math::closest_segment_params(l0, l1, Vec3::ZERO, Vec3::ZERO);
    if l0.lerp(l1, s0).length() > half.length() + r + touch {
        return None;
    }
    let inside = segment_enters_box(l0, l1, half);
    let (p, q) = if inside {
        (l0, l0)
    } else {
        let t = closest_on_segment_to_box(l0, l1, half);
        let p = l0.lerp(l1, t);
        (p, p.clamp(-half, half))
    };
    let d = p - q;
    let dist = d.length();
    let (n_local, p_local, q_local, depth) = if !inside && dist > 0.0 {
        let n = d / dist;
        (n, p - n * r, q, r - dist)
    } else {
        // Inside: the face whose plane the whole segment can leave through soonest.
        let mut best = (f32::INFINITY, Vec3::Y, l0);
        for k in 0..3 {
            for sign in [-1.0f32, 1.0] {
                let (a0, a1) = (l0[k] * sign, l1[k] * sign);
                let deepest = if a0 < a1 { l0 } else { l1 };
                let need = half[k] + r - a0.min(a1);
                if need < best.0 {
                    let mut n = Vec3::ZERO;
                    n[k] = sign;
                    best = (need, n, deepest);
                }
            }
        }
        let (need, n, deepest) = best;
        let on_face = deepest + n * (half.dot(n.abs()) - deepest.dot(n));
        (n, deepest - n * r, on_face, need)
    };
    if depth < -touch {
        return None;
    }
    Some((p_local, q_local, n_local, depth))
}

/// Whether the segment `a b` passes through the box of half extents `half` centred on the
/// origin (slab clipping: exact, where a search for the closest point stalls on the edge
/// of the stretch inside and reads a pierced box as one merely touched).
fn segment_enters_box(a: Vec3, b: Vec3, half: Vec3) -> bool {
    let d = b - a;
    let (mut lo, mut hi) = (0.0f32, 1.0f32);
    for k in 0..3 {
        if d[k].abs() < 1.0e-12 {
            if a[k].abs() > half[k] {
                return false;
            }
            continue;
        }
        let (t0, t1) = ((-half[k] - a[k]) / d[k], (half[k] - a[k]) / d[k]);
        lo = lo.max(t0.min(t1));
        hi = hi.min(t0.max(t1));
        if lo > hi {
            return false;
        }
    }
    true
}

/// Where along the segment `a b` (0 to 1) it comes closest to the box of half extents
/// `half` centred on the origin, for a segment that misses it: the distance is convex
/// along the segment, so a golden-section search finds its least, one distance per step.
fn closest_on_segment_to_box(a: Vec3, b: Vec3, half: Vec3) -> f32 {
    let dist_at = |t: f32| {
        let p = a.lerp(b, t);
        (p - p.clamp(-half, half)).length_squared()
    };
    const INV_PHI: f32 = 0.618_034;
    let (mut lo, mut hi) = (0.0f32, 1.0f32);
    let (mut m1, mut m2) = (hi - INV_PHI, INV_PHI);
    let (mut f1, mut f2) = (dist_at(m1), dist_at(m2));
    for _ in 0..14 {
        if f1 <= f2 {
            hi = m2;
            (m2, f2) = (m1, f1);
            m1 = hi - INV_PHI * (hi - lo);
            f1 = dist_at(m1);
        } else {
            lo = m1;
            (m1, f1) = (m2, f2);
            m2 = lo + INV_PHI * (hi - lo);
            f2 = dist_at(m2);
        }
    }
    [0.0, 1.0, 0.5 * (lo + hi)]
        .into_iter()
        .min_by(|x, y| dist_at(*x).total_cmp(&dist_at(*y)))
        .unwrap_or(0.0)
}
