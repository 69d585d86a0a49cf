//! Bodies that start inside each other (a ragdoll must not start interpenetrating).
//!
//! - Between two ragdolls it is refused: characters placed on one spot were a user's
//!   mistake, and 100 humanoids at one spot cost rapier 23 s and 768 MB (every one of the
//!   1,600 bodies in contact with every other: 1.3 million contact pairs), 200 past
//!   3.7 GB.
//! - Within one ragdoll the pair stops colliding, as the spec builder does for the rest
//!   pose and the hand-over does for the clip's pose: the character's own pose put the
//!   parts there, and a contact would throw them apart. This holds for any overlap, not
//!   only deep ones: rapier pushes an overlap out at 3 m/s at most, but the particle
//!   backend closes it within a substep, and the built-in humanoid with every part edited
//!   to 0.75 m across flew apart at 200 m/s with no force on it.
//!
//! - A body inside more than [`MAX_DEEP_OVERLAPS`] bodies of its own ragdoll is refused:
//!   a spec with 2,000 extra bodies on one spot ran for minutes in rapier, whose contact
//!   graph finds each new pair by a walk over a body's pairs, so a pile of k bodies costs
//!   k³ (600 bodies: 25 s for half a second; 2,000: past 4 minutes), filtered or not.
//!
//! "Inside" means deep: one body's axis inside the other (the distance between their
//! axes below the larger radius), measured on the capsules inside the shapes
//! ([`capsule_of`]), as the backends collide them.

use std::collections::HashMap;

use glam::Vec3;

use crate::geometry::broad::BroadPhase;
use crate::geometry::capsule_of;
use crate::math::Transform;
use crate::spec::Shape;

/// Most bodies of its own ragdoll one body may start inside. A character's busiest part
/// (a chest with its neck, arms and spine, a hand with its fingers) has a handful.
pub(crate) const MAX_DEEP_OVERLAPS: usize = 32;

/// Side of the cells ragdolls are filed under for the check between ragdolls, metres:
/// about a person, so a crowd costs a few cells a character.
const START_CELL_M: f64 = 2.0;
/// A ragdoll whose box spans more cells than this along an axis is compared with every
/// ragdoll instead (a giant is rare; filing it would cost its volume in cells).
const START_MAX_CELLS_PER_AXIS: i64 = 4;

/// One shape's capsule in world space at the start, and the body (index in its spec)
/// it is a shape of: a body with extra shapes has several.
#[derive(Clone, Copy, Debug)]
pub(super) struct Solid {
    a: Vec3,
    b: Vec3,
    r: f32,
    body: usize,
    /// Whether it is one of the body's extra shapes, which never meet their own ragdoll.
    extra: bool,
}

impl Solid {
    fn new(pose: &Transform, shape: &Shape, body: usize, extra: bool) -> Self {
        let ([e0, e1], r) = capsule_of(shape);
        Solid {
            a: pose.transform_point(e0),
            b: pose.transform_point(e1),
            r,
            body,
            extra,
        }
    }

    /// Every shape of the bodies of `spec` at `poses` (body frames, spec order): each
    /// body's own, then its extra shapes.
    pub(super) fn of_spec(spec: &crate::spec::RagdollSpec, poses: &[Transform]) -> Vec<Solid> {
        let extras: Vec<_> = spec.bodies.iter().map(|b| b.extra_offsets()).collect();
        let shapes: Vec<Shape> = spec.bodies.iter().map(|b| b.shape).collect();
        Solid::of_bodies(&shapes, &extras, poses)
    }

    /// Every shape of bodies of `shapes` with `extras` (each in its body's frame) at
    /// `poses`: each body's own, then its extra shapes.
    pub(super) fn of_bodies(
        shapes: &[Shape],
        extras: &[Vec<(Shape, Transform)>],
        poses: &[Transform],
    ) -> Vec<Solid> {
        let mut solids = Vec::with_capacity(shapes.len());
        for (i, ((shape, extra), p)) in shapes.iter().zip(extras).zip(poses).enumerate() {
            solids.push(Solid::new(p, shape, i, false));
            for (shape, at) in extra {
                solids.push(Solid::new(&p.mul(at), shape, i, true));
            }
        }
        solids
    }

    fn bounds(&self) -> (Vec3, Vec3) {
        (self.a.min(self.b) - self.r, self.a.max(self.b) + self.r)
    }

    /// The distance between the two axes when one lies inside the other body.
    fn deep(&self, other: &Solid) -> Option<f32> {
        let gap = self.axis_gap(other);
        (gap < self.r.max(other.r)).then_some(gap)
    }

    /// Distance between the two bodies' axes.
    fn axis_gap(&self, other: &Solid) -> f32 {
        let (s, t) = crate::math::closest_segment_params(self.a, self.b, other.a, other.b);
        self.a.lerp(self.b, s).distance(other.a.lerp(other.b, t))
    }
}

/// Two bodies of different ragdolls that start inside each other.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Clash {
    /// The new ragdoll's body (index in its spec).
    pub body: usize,
    /// The ragdoll already in the world (index) and its body (index in its spec).
    pub other: usize,
    pub other_body: usize,
    /// Distance between their axes and the larger radius, metres.
    pub gap_m: f32,
    pub radius_m: f32,
}

/// Every ragdoll's bodies at the start, for the check between ragdolls; only needed until
/// the world starts stepping.
#[derive(Default)]
pub(super) struct StartIndex {
    solids: Vec<Solid>,
    /// Each ragdoll's first body in `solids`, body count and box.
    ragdolls: Vec<(usize, usize, (Vec3, Vec3))>,
    /// Ragdolls by the cells their boxes touch.
    cells: HashMap<[i64; 3], Vec<u32>>,
    /// Ragdolls too large for the cells.
    large: Vec<u32>,
    broad: BroadPhase,
    boxes: Vec<(Vec3, Vec3)>,
}

/// The cells of `START_CELL_M` a box touches, or `None` when they are too many.
fn start_cells(lo: Vec3, hi: Vec3) -> Option<impl Iterator<Item = [i64; 3]>> {
    let cell = |p: Vec3| {
        p.as_dvec3()
            .to_array()
            .map(|v| (v / START_CELL_M).floor() as i64)
    };
    let (a, b) = (cell(lo), cell(hi));
    if (0..3).any(|k| b[k].saturating_sub(a[k]) >= START_MAX_CELLS_PER_AXIS) {
        return None;
    }
    Some(
        (a[0]..=b[0]).flat_map(move |x| {
            (a[1]..=b[1]).flat_map(move |y| (a[2]..=b[2]).map(move |z| [x, y, z]))
        }),
    )
}

fn union(solids: &[Solid]) -> (Vec3, Vec3) {
    solids
        .iter()
        .map(Solid::bounds)
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), (l, h)| {
            (lo.min(l), hi.max(h))
        })
}

impl StartIndex {
    /// The first pair (in spec order) of a body of the ragdoll about to be added
    /// (`solids`, spec order) and a body of a ragdoll already in that start inside each
    /// other. Memory: the index holds a few cells per ragdoll; time: the ragdolls near
    /// the new one (and every giant).
    pub(super) fn clash(&mut self, solids: &[Solid]) -> Option<Clash> {
        let (lo, hi) = union(solids);
        if !(lo.is_finite() && hi.is_finite()) {
            return None;
        }
        let mut near: Vec<u32> = match start_cells(lo, hi) {
            Some(cells) => cells
                .filter_map(|c| self.cells.get(&c))
                .flatten()
                .chain(&self.large)
                .copied()
                .collect(),
            None => (0..self.ragdolls.len() as u32).collect(),
        };
        near.sort_unstable();
        near.dedup();
        let mut best: Option<Clash> = None;
        for r in near {
            let (first, count, (olo, ohi)) = self.ragdolls[r as usize];
            if lo.max(olo).cmpgt(hi.min(ohi)).any() {
                continue;
            }
            let others = &self.solids[first..first + count];
            self.boxes.clear();
            self.boxes
                .extend(solids.iter().chain(others).map(Solid::bounds));
            let n = solids.len();
            let mut found: Option<Clash> = None;
            self.broad.find(&self.boxes, |a, b| {
                if a >= n || b < n {
                    return;
                }
                let (sa, sb) = (&solids[a], &others[b - n]);
                if let Some(gap) = sa.deep(sb) {
                    let clash = Clash {
                        body: sa.body,
                        other: r as usize,
                        other_body: sb.body,
                        gap_m: gap,
                        radius_m: sa.r.max(sb.r),
                    };
                    let key = |c: &Clash| (c.body, c.other, c.other_body);
                    if found.is_none_or(|f| key(&clash) < key(&f)) {
                        found = Some(clash);
                    }
                }
            });
            let key = |c: &Clash| (c.body, c.other, c.other_body);
            if let Some(f) = found
                && best.is_none_or(|b| key(&f) < key(&b))
            {
                best = Some(f);
            }
        }
        best
    }

    /// Files the ragdoll just added (its bodies' solids, spec order).
    pub(super) fn insert(&mut self, solids: &[Solid]) {
        let index = self.ragdolls.len() as u32;
        let bounds = union(solids);
        self.ragdolls
            .push((self.solids.len(), solids.len(), bounds));
        self.solids.extend_from_slice(solids);
        let (lo, hi) = bounds;
        if !(lo.is_finite() && hi.is_finite()) {
            return;
        }
        match start_cells(lo, hi) {
            Some(cells) => {
                for c in cells {
                    self.cells.entry(c).or_default().push(index);
                }
            }
            None => self.large.push(index),
        }
    }
}

/// Pairs of one ragdoll's bodies (indices in its spec, `a < b`) that start overlapping
/// (their own shapes: extra shapes never meet their own ragdoll), in order; or
/// `Err((body, count))` for a body deep inside more than [`MAX_DEEP_OVERLAPS`] others.
pub(super) fn overlapping_pairs(solids: &[Solid]) -> Result<Vec<(usize, usize)>, (usize, usize)> {
    let boxes: Vec<(Vec3, Vec3)> = solids.iter().map(Solid::bounds).collect();
    let mut pairs = Vec::new();
    let bodies = solids.iter().map(|s| s.body + 1).max().unwrap_or(0);
    let mut count = vec![0usize; bodies];
    BroadPhase::default().find(&boxes, |a, b| {
        let (sa, sb) = (&solids[a], &solids[b]);
        // Own shapes only, one a body: each pair of bodies comes once.
        if sa.body == sb.body || sa.extra || sb.extra {
            return;
        }
        let gap = sa.axis_gap(sb);
        if gap < sa.r.max(sb.r) {
            count[sa.body] += 1;
            count[sb.body] += 1;
        }
        // Memory stays within the bodies' own pairs: a spec holds at most
        // `spec::validate::MAX_BODIES` bodies.
        if gap < sa.r + sb.r {
            pairs.push((sa.body.min(sb.body), sa.body.max(sb.body)));
        }
    });
    if let Some((body, &n)) = count
        .iter()
        .enumerate()
        .max_by_key(|&(b, n)| (*n, std::cmp::Reverse(b)))
        .filter(|(_, n)| **n > MAX_DEEP_OVERLAPS)
    {
        return Err((body, n));
    }
    pairs.sort_unstable();
    Ok(pairs)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ball(x: f32, r: f32) -> Solid {
        let p = Vec3::new(x, 1.0, 0.0);
        Solid {
            a: p,
            b: p,
            r,
            body: 0,
            extra: false,
        }
    }

    /// Balls as the bodies of one ragdoll, body `k` the `k`-th.
    fn bodies(balls: impl IntoIterator<Item = Solid>) -> Vec<Solid> {
        balls
            .into_iter()
            .enumerate()
            .map(|(k, s)| Solid { body: k, ..s })
            .collect()
    }

    #[test]
    fn only_deep_overlaps_count() {
        assert!(ball(0.0, 0.1).deep(&ball(0.19, 0.1)).is_none(), "touching");
        assert!(
            ball(0.0, 0.1).deep(&ball(0.09, 0.1)).is_some(),
            "axis inside"
        );
        // A thin body's axis inside a thick one.
        assert!(ball(0.0, 0.2).deep(&ball(0.15, 0.02)).is_some());
    }

    #[test]
    fn a_pile_of_one_ragdolls_bodies_is_refused_past_the_limit() {
        let pile = bodies((0..MAX_DEEP_OVERLAPS + 2).map(|_| ball(0.0, 0.1)));
        assert_eq!(overlapping_pairs(&pile), Err((0, MAX_DEEP_OVERLAPS + 1)));
        let small = &pile[..MAX_DEEP_OVERLAPS + 1];
        assert_eq!(
            overlapping_pairs(small).map(|p| p.len()),
            Ok(small.len() * (small.len() - 1) / 2)
        );
    }

    #[test]
    fn a_crowd_is_checked_near_each_ragdoll_and_a_giant_against_all() {
        let mut index = StartIndex::default();
        for k in 0..50 {
            index.insert(&[ball(k as f32, 0.2)]);
        }
        let giant = [Solid {
            a: Vec3::new(-1.0e4, 0.0, 0.0),
            b: Vec3::new(1.0e4, 0.0, 0.0),
            r: 5.0,
            body: 0,
            extra: false,
        }];
        let c = index.clash(&giant).expect("the giant holds every ball");
        assert_eq!((c.body, c.other, c.other_body), (0, 0, 0));
        assert_eq!(index.clash(&[ball(20.1, 0.2)]).map(|c| c.other), Some(20));
        assert_eq!(index.clash(&[ball(20.5, 0.2)]), None);
        // The index keeps a few cells per ragdoll.
        assert!(index.cells.values().map(Vec::len).sum::<usize>() <= 50 * 8);
    }
}
