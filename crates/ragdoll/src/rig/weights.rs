//! Automatic skin weights: every vertex bound to the bones nearest to it.

use glam::{Vec3, Vec4};

use crate::skeleton::Skeleton;

/// Softening length of the inverse-square falloff, as a fraction of the skeleton's extent:
/// a vertex lying exactly on a bone gets a large finite weight instead of a division by
/// zero, and shares it evenly with a second bone through the same point (a joint).
const SOFTENING_OF_EXTENT: f32 = 1e-4;
/// Softening floor, metres, for a skeleton with no extent (one joint, no tip).
const MIN_SOFTENING_M: f32 = 1e-6;

/// Skin weights for `positions` (world space, rest pose) on `skeleton`: each vertex takes
/// the four bones nearest to it, weighted by inverse squared distance and normalised to
/// sum 1.
///
/// A bone is the segment from a joint to each of its children; a leaf's runs to its tip,
/// or is the joint's point when it has none. Distances are softened by a length far below
/// any bone's, so a vertex on a joint is shared by the bones meeting there. Every vertex
/// gets weight (a non-finite position goes wholly to joint 0), unused slots hold joint 0
/// with weight 0, as glTF asks, and joints past index 65535 (beyond a `u16`) are not
/// used.
///
/// # Example
///
/// ```
/// use ragdoll::{rig::auto_weights, skeleton::humanoid};
///
/// let skeleton = humanoid().skeleton;
/// let (joints, weights) = auto_weights(&skeleton, &[glam::Vec3::new(0.0, 1.0, 0.0)]);
/// assert!((weights[0].element_sum() - 1.0).abs() < 1e-6);
/// assert!(joints[0].iter().all(|&j| (j as usize) < skeleton.len()));
/// ```
pub fn auto_weights(skeleton: &Skeleton, positions: &[Vec3]) -> (Vec<[u16; 4]>, Vec<Vec4>) {
    let segments = bone_segments(skeleton);
    let n = skeleton.len().min(u16::MAX as usize + 1);
    let (lo, hi) = segments.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), &(_, a, b)| (lo.min(a).min(b), hi.max(a).max(b)),
    );
    let soft = (SOFTENING_OF_EXTENT * (hi - lo).length()).max(MIN_SOFTENING_M);
    let soft2 = soft * soft;

    let mut joints = Vec::with_capacity(positions.len());
    let mut weights = Vec::with_capacity(positions.len());
    // Per vertex, each joint's weight is that of its nearest segment (a joint with several
    // children must not count twice).
    let mut best = vec![0.0f32; n];
    for &p in positions {
        best.iter_mut().for_each(|b| *b = 0.0);
        for &(j, a, b) in &segments {
            let w = 1.0 / (distance_squared_to_segment(p, a, b) + soft2);
            let slot = &mut best[j as usize];
            *slot = slot.max(w);
        }
        let (j, w) = top_four(&best).unwrap_or(([0; 4], Vec4::X));
        joints.push(j);
        weights.push(w);
    }
    (joints, weights)
}

/// Bones as segments, each with its joint: a joint to each of its children; a leaf to its
/// tip, or its own point when it has none. Joints past index 65535 (beyond a `u16`) are
/// left out.
pub(super) fn bone_segments(skeleton: &Skeleton) -> Vec<(u16, Vec3, Vec3)> {
    let world = skeleton.rest_world();
    let n = skeleton.len().min(u16::MAX as usize + 1);
    let mut segments: Vec<(u16, Vec3, Vec3)> = Vec::with_capacity(n + 4);
    for (i, w) in world.iter().enumerate().take(n) {
        let a = w.translation;
        let mut any_child = false;
        for c in skeleton.children(i) {
            any_child = true;
            segments.push((i as u16, a, world[c].translation));
        }
        if !any_child {
            let end = skeleton.joints()[i].tip.map_or(a, |t| w.transform_point(t));
            segments.push((i as u16, a, end));
        }
    }
    segments
}

/// The four largest of `per_joint` (indexed by joint), normalised to sum 1, unused slots on
/// joint 0 with weight 0; `None` when nothing is positive and finite (NaN counts as 0).
pub(super) fn top_four(per_joint: &[f32]) -> Option<([u16; 4], Vec4)> {
    let mut top = [(0u16, 0.0f32); 4];
    for (j, &w) in per_joint.iter().enumerate() {
        keep_largest(&mut top, j as u16, w);
    }
    normalised(top)
}

/// Puts joint `j` with weight `w` into `top` (largest first) if it is among the `N`
/// largest; `w > top` also skips NaN.
pub(super) fn keep_largest<const N: usize>(top: &mut [(u16, f32); N], j: u16, w: f32) {
    if w > top[N - 1].1 {
        top[N - 1] = (j, w);
        let mut k = N - 1;
        while k > 0 && top[k].1 > top[k - 1].1 {
            top.swap(k, k - 1);
            k -= 1;
        }
    }
}

/// `top` as a skin row: weights normalised to sum 1, unused slots on joint 0 with weight
/// 0; `None` when nothing is positive and finite.
pub(super) fn normalised(top: [(u16, f32); 4]) -> Option<([u16; 4], Vec4)> {
    let sum: f32 = top.iter().map(|t| t.1).sum();
    (sum > 0.0 && sum.is_finite()).then(|| {
        (
            top.map(|t| if t.1 > 0.0 { t.0 } else { 0 }),
            Vec4::from_array(top.map(|t| t.1 / sum)),
        )
    })
}

/// Squared distance from `p` to the segment `a`–`b` (a point when `a == b`).
pub(super) fn distance_squared_to_segment(p: Vec3, a: Vec3, b: Vec3) -> f32 {
    nearest_on_segment(p, a, b).distance_squared(p)
}

/// The point of segment `a`–`b` nearest `p`.
pub(super) fn nearest_on_segment(p: Vec3, a: Vec3, b: Vec3) -> Vec3 {
    let ab = b - a;
    let len2 = ab.length_squared();
    let t = if len2 > 0.0 {
        ((p - a).dot(ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    a + ab * t
}
