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
                    split_cluster(
                        c,
                        std::env::var("RD_PIECE")
                            .ok()
                            .and_then(|x| x.parse().ok())
                            .unwrap_or(PIECE_H)
                            * self.h,
                        &mut pieces,
                    );
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
    let q = plan.rotation.conjugate() * (p - plan.centre);
    match plan.shape {
        Shape::Capsule { radius_m, length_m } => {
            let y = q.y.clamp(-0.5 * length_m, 0.5 * length_m);
            q.distance(Vec3::new(0.0, y, 0.0)) <= radius_m + tolerance
        }
        Shape::Box { size_m } => {
            let half = Vec3::from_array(size_m) * 0.5 + Vec3::splat(tolerance);
            q.abs().cmple(half).all()
        }
    }
}

/// The clusters of `points` whose members chain within `link` of each other (single
/// linkage, through a grid of cells `link` wide, so the cost follows the points).
fn clusters(points: &[Vec3], link: f32) -> Vec<Vec<Vec3>> {
    if points.is_empty() || !(link > 0.0 && link.is_finite()) {
        return Vec::new();
    }
    let key = |p: Vec3| (p / link).floor().as_ivec3();
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
    let link2 = link * link;
    for (cell, members) in &grid {
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let Some(others) = grid.get(&(*cell + glam::IVec3::new(dx, dy, dz))) else {
                        continue;
                    };
                    for &i in members {
                        for &j in others {
                            if i < j && points[i].distance_squared(points[j]) <= link2 {
                                let (a, b) = (find(&mut parent, i), find(&mut parent, j));
                                parent[a.max(b)] = a.min(b);
                            }
                        }
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
