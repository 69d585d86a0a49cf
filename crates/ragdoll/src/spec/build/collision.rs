//! Collision filtering: jointed pairs and pairs that touch in the rest pose or the
//! starting pose never collide, found through a grid so the cost follows the close pairs.

use std::collections::{HashMap, HashSet};

use glam::{Quat, Vec3};

use super::Plan;
use crate::error::{Error, Result};
use crate::skeleton::Character;
use crate::spec::{CollisionSpec, RagdollSpec, Shape};

/// Two bodies closer than this (plus their radii) in the rest pose never collide: they
/// touch or nearly touch at rest and would push apart on the first step.
pub(super) const COLLISION_MARGIN_M: f32 = 0.01;
/// Most pairs of bodies a built spec may list as not colliding: about a million. A character
/// gets a few per body; a chain of thousands of bodies thicker than their spacing (every
/// body overlapping hundreds of others) would otherwise list tens of millions, each pair
/// two names in memory, and exhaust it.
pub(crate) const MAX_DISABLED_PAIRS: usize = 1 << 20;

/// Also filters the pairs that overlap in the starting pose (the first animation frame): a
/// mocap pose can cross an arm over the chest, and bodies that start inside each other
/// would be thrown apart on the first step.
pub(super) fn filter_start_overlaps(
    spec: &mut RagdollSpec,
    character: &Character,
    start: &[crate::math::Transform],
) -> Result<()> {
    let poses = crate::spec::Resolved::new(spec, character)?.body_poses(start);
    let solids: Vec<Solid> = spec
        .bodies
        .iter()
        .zip(&poses)
        .map(|(b, pose)| solid(&b.shape, pose.translation, pose.rotation))
        .collect();
    // What `CollisionSpec::is_disabled` answers, as a set: the pairs are looked up once per
    // nearby pair of bodies, and a scan of the list each time made this quadratic in pairs.
    let mut disabled: HashSet<(&str, &str)> = spec
        .collision
        .disabled_pairs
        .iter()
        .map(|[a, b]| name_pair(a, b))
        .collect();
    let mut found = Vec::new();
    for (a, b) in nearby_pairs(&solids, COLLISION_MARGIN_M)? {
        let (na, nb) = (spec.bodies[a].name.as_str(), spec.bodies[b].name.as_str());
        if !disabled.contains(&name_pair(na, nb))
            && shapes_overlap(
                &poses[a],
                &spec.bodies[a].shape,
                &poses[b],
                &spec.bodies[b].shape,
                COLLISION_MARGIN_M,
            )
        {
            disabled.insert(name_pair(na, nb));
            found.push([na.to_string(), nb.to_string()]);
        }
    }
    if spec.collision.disabled_pairs.len() + found.len() > MAX_DISABLED_PAIRS {
        return Err(too_many_pairs());
    }
    spec.collision.disabled_pairs.extend(found);
    Ok(())
}

/// A pair of body names in a fixed order, so `(a, b)` and `(b, a)` are one key.
fn name_pair<'s>(a: &'s str, b: &'s str) -> (&'s str, &'s str) {
    if a <= b { (a, b) } else { (b, a) }
}

/// Every pair `(i, j)`, `i < j`, in increasing order, whose solids might come within
/// `margin` of each other: the pairs whose bounding boxes (grown by the radii, the margin
/// and a rounding allowance) overlap. A superset of the pairs the exact test accepts, in
/// the order a loop over all pairs would visit them, found through a uniform grid so the
/// cost follows the pairs that are close rather than all pairs. Solids that are not finite
/// are left out: the exact test refuses them anyway. More than a few times
/// [`MAX_DISABLED_PAIRS`] candidates is an error rather than a list that size.
pub(super) fn nearby_pairs(solids: &[Solid], margin: f32) -> Result<Vec<(usize, usize)>> {
    let boxes: Vec<Option<(Vec3, Vec3)>> = solids
        .iter()
        .map(|s| {
            let grow = s.r + 0.5 * margin;
            let (lo, hi) = (s.a.min(s.b), s.a.max(s.b));
            let slack = 1e-4 * (1.0 + lo.abs().max(hi.abs()).max_element() + grow.abs());
            let g = Vec3::splat(grow + slack);
            let (lo, hi) = (lo - g, hi + g);
            (lo.is_finite() && hi.is_finite()).then_some((lo, hi))
        })
        .collect();
    let overlap = |i: usize, j: usize| match (boxes[i], boxes[j]) {
        (Some((la, ha)), Some((lb, hb))) => la.cmple(hb).all() && lb.cmple(ha).all(),
        _ => false,
    };
    // Cells as large as a typical box; a box spanning many cells is checked against all.
    let mut sizes: Vec<f32> = boxes
        .iter()
        .flatten()
        .map(|(lo, hi)| (*hi - *lo).max_element())
        .collect();
    sizes.sort_by(f32::total_cmp);
    let cell = sizes
        .get(sizes.len() / 2)
        .copied()
        .filter(|c| *c > 0.0)
        .unwrap_or(1.0);
    // Cell coordinates, monotone in the position (saturating far away), so boxes that
    // overlap always share a cell.
    let key = |v: Vec3| (v.as_dvec3() / f64::from(cell)).floor();
    let mut grid: HashMap<glam::I64Vec3, Vec<usize>> = HashMap::new();
    let mut big = Vec::new();
    for (i, b) in boxes.iter().enumerate() {
        let Some((lo, hi)) = b else { continue };
        let (kl, kh) = (key(*lo), key(*hi));
        let span = kh - kl + glam::DVec3::ONE;
        if span.x * span.y * span.z > MAX_CELLS_PER_BODY {
            big.push(i);
            continue;
        }
        let (kl, kh) = (kl.as_i64vec3(), kh.as_i64vec3());
        for x in kl.x..=kh.x {
            for y in kl.y..=kh.y {
                for z in kl.z..=kh.z {
                    grid.entry(glam::I64Vec3::new(x, y, z)).or_default().push(i);
                }
            }
        }
    }
    let mut pairs = Vec::new();
    let mut add = |i: usize, j: usize| {
        if overlap(i, j) {
            pairs.push((i.min(j), i.max(j)));
            if pairs.len() > MAX_CANDIDATE_PAIRS {
                return Err(too_many_pairs());
            }
        }
        Ok(())
    };
    for members in grid.values() {
        for (k, &i) in members.iter().enumerate() {
            for &j in &members[k + 1..] {
                add(i, j)?;
            }
        }
    }
    for &i in &big {
        for j in (0..solids.len()).filter(|&j| j != i) {
            add(i, j)?;
        }
    }
    pairs.sort_unstable();
    pairs.dedup();
    Ok(pairs)
}

/// Candidate pairs [`nearby_pairs`] may hold (a pair can be found in several cells).
const MAX_CANDIDATE_PAIRS: usize = 8 * MAX_DISABLED_PAIRS;

fn too_many_pairs() -> Error {
    Error::Spec {
        place: "collision.disabled_pairs".into(),
        message: format!(
            "more than {MAX_DISABLED_PAIRS} pairs of bodies touch in the rest pose (bodies far thicker than the bones between them); this is not a ragdoll that can be built"
        ),
    }
}

/// Grid cells one solid may be entered in before it is compared with every solid instead.
const MAX_CELLS_PER_BODY: f64 = 64.0;

/// A body's solid as a capsule in world space: segment `a → b` swept by `r`. Boxes are
/// replaced by their bounding capsule (along the longest edge, radius the half diagonal of
/// the cross-section), which errs toward filtering a pair rather than starting in contact.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Solid {
    pub a: Vec3,
    pub b: Vec3,
    pub r: f32,
}

pub(crate) fn solid(shape: &Shape, centre: Vec3, rotation: Quat) -> Solid {
    match *shape {
        Shape::Capsule { radius_m, length_m } => {
            let half = rotation * Vec3::Y * (0.5 * length_m);
            Solid {
                a: centre - half,
                b: centre + half,
                r: radius_m,
            }
        }
        Shape::Box { size_m } => {
            let h = Vec3::from_array(size_m) * 0.5;
            let k = if h.x >= h.y && h.x >= h.z {
                0
            } else if h.y >= h.z {
                1
            } else {
                2
            };
            let axes = [Vec3::X, Vec3::Y, Vec3::Z];
            let half = rotation * axes[k] * h[k];
            let r = (h.length_squared() - h[k] * h[k]).sqrt();
            Solid {
                a: centre - half,
                b: centre + half,
                r,
            }
        }
    }
}

/// Jointed pairs, then every other pair whose solids come within [`COLLISION_MARGIN_M`] of
/// each other in the rest pose (what Jolt's `DisableParentChildCollisions` does with its
/// joint matrices).
pub(super) fn collision_filter(
    plans: &[Plan],
    parents: &[usize],
    names: &[String],
) -> Result<CollisionSpec> {
    let mut pairs: Vec<(usize, usize)> = (1..plans.len()).map(|c| (parents[c], c)).collect();
    let jointed: HashSet<(usize, usize)> =
        pairs.iter().map(|&(a, b)| (a.min(b), a.max(b))).collect();
    let solids: Vec<Solid> = plans
        .iter()
        .map(|p| solid(&p.shape, p.centre, p.rotation))
        .collect();
    for (i, j) in nearby_pairs(&solids, COLLISION_MARGIN_M)? {
        if jointed.contains(&(i, j)) {
            continue;
        }
        let (s, t) = (solids[i], solids[j]);
        if segment_distance(s.a, s.b, t.a, t.b) < s.r + t.r + COLLISION_MARGIN_M {
            pairs.push((i, j));
        }
    }
    if pairs.len() > MAX_DISABLED_PAIRS {
        return Err(too_many_pairs());
    }
    Ok(CollisionSpec {
        disabled_pairs: pairs
            .into_iter()
            .map(|(i, j)| [names[i].clone(), names[j].clone()])
            .collect(),
    })
}

/// Whether two shapes at these poses come within `margin` metres of each other (boxes are
/// taken as their bounding capsules, which errs on the side of "overlapping").
pub(crate) fn shapes_overlap(
    a: &crate::math::Transform,
    shape_a: &Shape,
    b: &crate::math::Transform,
    shape_b: &Shape,
    margin: f32,
) -> bool {
    let (s, t) = (
        solid(shape_a, a.translation, a.rotation),
        solid(shape_b, b.translation, b.rotation),
    );
    segment_distance(s.a, s.b, t.a, t.b) < s.r + t.r + margin
}

/// Distance between segments `p1 → q1` and `p2 → q2` (Ericson, Real-Time Collision
/// Detection, §5.1.9, with its degenerate-segment cases).
pub(crate) fn segment_distance(p1: Vec3, q1: Vec3, p2: Vec3, q2: Vec3) -> f32 {
    let (s, t) = crate::math::closest_segment_params(p1, q1, p2, q2);
    p1.lerp(q1, s).distance(p2.lerp(q2, t))
}
