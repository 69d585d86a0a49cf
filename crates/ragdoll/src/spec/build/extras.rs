//! Extra shapes: skin a body moves that no body's own shape holds.
//!
//! A body's shape holds the skin whose weight is mostly its own (`MIN_GROUP_WEIGHT`). A
//! vertex whose weight several bones share, none of them half, is held by no shape: bone
//! heat spreads a creature's foot, which has no bone of its own, over three spine bones
//! (0.37, 0.32 and 0.27 on the 13k Stanford dragon), and as those joints bend on landing
//! the blend of the three goes under every body, 8 % of the dragon's height into the
//! floor. A skinned vertex is the weighted mean of where each of its bones carries it, so
//! where every body that carries a good share of it also holds it, it cannot go below
//! what holds those bodies up. Growing each body's own shape to reach such skin filled
//! the space between (the dragon then rested 4 % of its height off the floor); each
//! cluster of it gets a shape of its own on every body that carries a share instead.
//!
//! A humanoid's own shapes hold all of each body's skin, so only skin no bone holds half
//! of gets extra shapes; a creature's hold the part nearest the bone (see
//! `CREATURE_RADIUS_PERCENTILE` in `shapes.rs`), and everything else each body carries a
//! share of gets them.

use glam::{Quat, Vec3};

use super::Builder;
use super::Plan;
use crate::math::principal_axes;
use crate::spec::{MAX_EXTRA_SHAPES, MIN_SHAPE_M, Shape};

/// A body carries a vertex held by no shape when it has at least this share of its weight:
/// below, its part in where the vertex goes is small (a quarter of a body's sinking).
const EXTRA_MIN_SHARE: f32 = 0.25;
/// A vertex counts as inside a shape within this fraction of H of its surface.
const INSIDE_TOLERANCE_H: f32 = 0.005;
/// Skin points closer than this fraction of H are one cluster (one extra shape): a foot's
/// vertices are a few millimetres apart, two feet tens of centimetres.
const CLUSTER_LINK_H: f32 = 0.06;
/// Fewest vertices an extra shape is fitted to: fewer is a stray, and a shape fitted to a
/// handful of points is no measure of the skin.
const MIN_CLUSTER_VERTICES: usize = 8;
/// Longest an extra shape's skin may be across, as a fraction of H: a cluster longer
/// than this is split in halves across its longest axis. One box round a whole cluster
/// (half a metre of a 0.87 m dragon's flank) held air where the skin curves away, and the
/// dragon lay on those boxes' corners 8 % of its height above the floor.
const PIECE_H: f32 = 0.1;

/// An extra shape planned in world space: its shape, centre and orientation (long axis
/// along its Y).
pub(super) struct ExtraPlan {
    pub shape: Shape,
    pub centre: Vec3,
    pub rotation: Quat,
}

impl Builder<'_> {
    /// Each body's extra shapes (see the module's doc), largest cluster first, at most
    /// [`MAX_EXTRA_SHAPES`] a body.
    pub(super) fn extras(&self, plans: &[Plan]) -> Vec<Vec<ExtraPlan>> {
        let tolerance = INSIDE_TOLERANCE_H * self.h;
        let mut loose: Vec<Vec<Vec3>> = vec![Vec::new(); plans.len()];
        for (p, js, ws) in &self.rig.verts {
            let shares = self.shares(js, ws);
            let best = shares.iter().map(|s| s.1).fold(0.0f32, f32::max);
            // A humanoid's shapes hold all of each body's own skin; a creature's only the
            // part nearest its bone, and the rest of what it carries needs extra shapes.
            if best >= super::MIN_GROUP_WEIGHT && self.roles.humanoid {
                continue;
            }
            for &(b, w) in &shares {
                if b < plans.len() && w >= EXTRA_MIN_SHARE && !holds(&plans[b], *p, tolerance) {
                    loose[b].push(*p);
                }
            }
        }
        loose
            .iter()
            .map(|points| {
                let mut pieces = Vec::new();
                for c in clusters(points, CLUSTER_LINK_H * self.h) {
                    split_cluster(c, PIECE_H * self.h, &mut pieces);
                }
                pieces.retain(|c| c.len() >= MIN_CLUSTER_VERTICES);
                pieces.sort_by_key(|c| std::cmp::Reverse(c.len()));
                pieces.truncate(MAX_EXTRA_SHAPES);
                pieces.iter().filter_map(|c| fit(c)).collect()
            })
            .collect()
    }

    /// How much of a vertex's weight (`js`, `ws`) each body carries, bodies at most four.
    pub(super) fn shares(&self, js: &[u16; 4], ws: &glam::Vec4) -> Vec<(usize, f32)> {
        let mut share: Vec<(usize, f32)> = Vec::with_capacity(4);
        for c in 0..4 {
            let Some(&o) = self.owner.get(js[c] as usize) else {
                continue;
            };
            let w = ws[c].max(0.0);
            match share.iter_mut().find(|s| s.0 == o) {
                Some(s) => s.1 += w,
                None => share.push((o, w)),
            }
        }
        share
    }
}

/// Whether `plan`'s shape holds the world point `p`, within `tolerance` of its surface.
fn holds(plan: &Plan, p: Vec3, tolerance: f32) -> bool {
    shape_holds(
        &plan.shape,
        plan.rotation.conjugate() * (p - plan.centre),
        tolerance,
    )
}

/// Whether `shape` holds `q` (in its own frame) within `tolerance` of its surface. Any
/// shape, even one measured from broken input (an infinite radius, a NaN length) that the
/// spec's checks refuse later with its body's name: answered, never a panic.
pub(in crate::spec) fn shape_holds(shape: &Shape, q: Vec3, tolerance: f32) -> bool {
    match *shape {
        Shape::Capsule { radius_m, length_m } => {
            // max/min rather than clamp, which panics on NaN bounds.
            let y = q.y.max(-0.5 * length_m).min(0.5 * length_m);
            q.distance(Vec3::new(0.0, y, 0.0)) <= radius_m + tolerance
        }
        Shape::Box { size_m } => {
            let half = Vec3::from_array(size_m) * 0.5 + Vec3::splat(tolerance);
            q.abs().cmple(half).all()
        }
    }
}

/// The clusters of `points` whose members chain within `link` of each other (single
/// linkage). Through a grid of cells `link / √3` wide: two points of one cell are always
/// linked, so a cell is one cluster at once, and two cells are compared point by point only
/// until one pair links them. A dense patch of skin (tens of thousands of vertices in a
/// hand) thus costs about its size, not its square.
fn clusters(points: &[Vec3], link: f32) -> Vec<Vec<Vec3>> {
    if points.is_empty() || !(link > 0.0 && link.is_finite()) {
        return Vec::new();
    }
    let cell = link / 3f32.sqrt();
    let key = |p: Vec3| (p / cell).floor().as_ivec3();
    let mut grid: std::collections::HashMap<glam::IVec3, Vec<usize>> =
        std::collections::HashMap::new();
    for (i, p) in points.iter().enumerate() {
        if p.is_finite() {
            grid.entry(key(*p)).or_default().push(i);
        }
    }
    let mut parent: Vec<usize> = (0..points.len()).collect();
    fn find(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    fn union(parent: &mut [usize], i: usize, j: usize) {
        let (a, b) = (find(parent, i), find(parent, j));
        parent[a.max(b)] = a.min(b);
    }
    for members in grid.values() {
        for &i in &members[1..] {
            union(&mut parent, members[0], i);
        }
    }
    let link2 = link * link;
    // A point links to points at most `link` away: cells up to two over (`link / cell` is
    // √3 cells). Each unordered pair of cells once.
    for (c, members) in &grid {
        for d in neighbour_offsets() {
            let Some(others) = grid.get(&(*c + d)) else {
                continue;
            };
            if find(&mut parent, members[0]) == find(&mut parent, others[0]) {
                continue;
            }
            'pairs: for &i in members {
                for &j in others {
                    if points[i].distance_squared(points[j]) <= link2 {
                        union(&mut parent, i, j);
                        break 'pairs;
                    }
                }
            }
        }
    }
    let mut index: std::collections::HashMap<usize, usize> = std::collections::HashMap::new();
    let mut out: Vec<Vec<Vec3>> = Vec::new();
    for (i, p) in points.iter().enumerate() {
        if !p.is_finite() {
            continue;
        }
        let root = find(&mut parent, i);
        let k = *index.entry(root).or_insert_with(|| {
            out.push(Vec::new());
            out.len() - 1
        });
        out[k].push(*p);
    }
    out
}

/// Half of the cell offsets within two cells of a cell (the other half are their
/// negatives, met from the other cell), the cell itself left out.
fn neighbour_offsets() -> impl Iterator<Item = glam::IVec3> {
    (-2..=2)
        .flat_map(|x| (-2..=2).flat_map(move |y| (-2..=2).map(move |z| glam::IVec3::new(x, y, z))))
        .filter(|d| (d.x, d.y, d.z) > (0, 0, 0))
}

/// The capsule holding every one of `points`, along their longest principal axis. A
/// capsule rather than the smaller of it and a box: the boxes hugged flat skin closer,
/// but a dragon's head lying on the corners of a dozen of them rocked on rapier at
/// 0.1 m/s for seconds after it landed, where round pieces came to rest.
fn fit(points: &[Vec3]) -> Option<ExtraPlan> {
    let weights = vec![1.0; points.len()];
    let (c, axes, _) = principal_axes(points, &weights);
    // The shape frame: Y along the longest axis.
    let (y, x) = (axes[0], axes[1]);
    let z = x.cross(y);
    let rotation = Quat::from_mat3(&glam::Mat3::from_cols(x, y, z)).normalize();
    if !rotation.is_finite() {
        return None;
    }
    let local: Vec<Vec3> = points
        .iter()
        .map(|p| rotation.conjugate() * (*p - c))
        .collect();
    let (lo, hi) = local.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), q| (lo.min(*q), hi.max(*q)),
    );
    // Its axis along Y through the middle of the points' box across it.
    let mid = 0.5 * (lo + hi);
    let radius = local
        .iter()
        .map(|q| across(*q - mid))
        .fold(0.0f32, f32::max)
        .max(MIN_SHAPE_M);
    // Its segment: as far along Y as each point needs past the sphere it falls in.
    let (mut y0, mut y1) = (f32::INFINITY, f32::NEG_INFINITY);
    for q in &local {
        let d = *q - mid;
        let off = across(d);
        let reach = (radius * radius - off * off).max(0.0).sqrt();
        y0 = y0.min(d.y + reach);
        y1 = y1.max(d.y - reach);
    }
    let (y0, y1) = if y1 > y0 {
        (y0, y1)
    } else {
        (0.5 * (y0 + y1), 0.5 * (y0 + y1))
    };
    let plan = ExtraPlan {
        shape: Shape::Capsule {
            radius_m: radius,
            length_m: y1 - y0,
        },
        centre: c + rotation * (mid + Vec3::Y * (0.5 * (y0 + y1))),
        rotation,
    };
    (plan.centre.is_finite() && plan.shape.volume().is_finite()).then_some(plan)
}

/// Distance of `q` (shape frame) from the frame's Y axis.
fn across(q: Vec3) -> f32 {
    (q.x * q.x + q.z * q.z).sqrt()
}

/// Splits `points` in halves across their longest principal axis until no piece is longer
/// than `piece` along it.
fn split_cluster(points: Vec<Vec3>, piece: f32, out: &mut Vec<Vec<Vec3>>) {
    let weights = vec![1.0; points.len()];
    let (c, axes, _) = principal_axes(&points, &weights);
    let (lo, hi) = points
        .iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), p| {
            let t = (*p - c).dot(axes[0]);
            (lo.min(t), hi.max(t))
        });
    if hi - lo <= piece || points.len() < 2 * MIN_CLUSTER_VERTICES {
        out.push(points);
        return;
    }
    let mid = 0.5 * (lo + hi);
    let (a, b): (Vec<Vec3>, Vec<Vec3>) = points
        .into_iter()
        .partition(|p| (*p - c).dot(axes[0]) < mid);
    split_cluster(a, piece, out);
    split_cluster(b, piece, out);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Single linkage by every pair: the clusters `clusters` must find.
    fn brute_force(points: &[Vec3], link: f32) -> Vec<Vec<Vec3>> {
        let mut label: Vec<usize> = (0..points.len()).collect();
        loop {
            let mut changed = false;
            for i in 0..points.len() {
                for j in 0..points.len() {
                    if points[i].distance(points[j]) <= link && label[j] < label[i] {
                        label[i] = label[j];
                        changed = true;
                    }
                }
            }
            if !changed {
                break;
            }
        }
        let mut out: Vec<(usize, Vec<Vec3>)> = Vec::new();
        for (i, p) in points.iter().enumerate() {
            match out.iter_mut().find(|c| c.0 == label[i]) {
                Some(c) => c.1.push(*p),
                None => out.push((label[i], vec![*p])),
            }
        }
        out.into_iter().map(|c| c.1).collect()
    }

    #[test]
    fn any_shape_answers_whether_it_holds_a_point() {
        let q = Vec3::new(0.05, 0.3, 0.0);
        let capsule = |radius_m, length_m| Shape::Capsule { radius_m, length_m };
        assert!(shape_holds(&capsule(0.1, 0.5), q, 0.0));
        assert!(!shape_holds(&capsule(0.1, 0.3), q, 0.0));
        // From a fuzzed KayKit knight: a capsule measured NaN long panicked in clamp.
        for length in [f32::NAN, f32::INFINITY, -1.0] {
            let _ = shape_holds(&capsule(0.1, length), q, 0.0);
            let _ = shape_holds(&capsule(f32::INFINITY, length), q, 0.0);
        }
        let _ = shape_holds(
            &Shape::Box {
                size_m: [f32::NAN; 3],
            },
            q,
            0.0,
        );
    }

    #[test]
    fn clusters_are_single_linkage_whatever_the_cells() {
        let mut seed = 7u32;
        let mut next = || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1u32 << 24) as f32
        };
        for (n, spread) in [(60, 1.0), (300, 3.0), (300, 0.2), (500, 6.0)] {
            let points: Vec<Vec3> = (0..n)
                .map(|_| Vec3::new(next(), next(), next()) * spread - Vec3::splat(0.3))
                .collect();
            let got = clusters(&points, 0.25);
            let want = brute_force(&points, 0.25);
            assert!(
                want.len() > 1 || spread < 1.0,
                "a spread of {spread} m is one cluster"
            );
            assert_eq!(got, want, "{n} points over {spread} m");
        }
    }

    #[test]
    fn a_dense_patch_is_one_cluster_in_linear_time() {
        // 200 000 points in one 2 cm cube, every pair linked (searched pair by pair, as
        // before the cells held whole clusters, this was 2·10¹⁰ distance tests).
        let points: Vec<Vec3> = (0..200_000)
            .map(|i| Vec3::new((i % 97) as f32, (i % 89) as f32, (i % 83) as f32) * 2e-4)
            .collect();
        let got = clusters(&points, 0.06);
        assert_eq!(got.len(), 1);
        assert_eq!(got[0].len(), points.len());
    }
}
