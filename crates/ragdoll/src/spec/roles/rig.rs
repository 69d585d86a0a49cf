//! The skeleton in world space (a pose plus its skin), with the per-subtree facts every
//! recognition pass and the builder ask of it.

use glam::{Quat, Vec3, Vec4};

use super::LEAF_LENGTH_FRACTION;
use crate::math::Transform;
use crate::skeleton::{Character, Skeleton};

/// A skeleton's rest pose in world space plus its skin, with the queries recognition and
/// building both need.
///
/// Per-subtree facts (lowest and highest point, size) are computed once, bottom up, so
/// that recognition, which asks them of every joint's children while it tries every joint
/// as the pelvis, stays near linear in the joints instead of paying a subtree walk per
/// question (a 400-joint chain took 17 s that way).
pub(crate) struct Rig<'a> {
    /// The skeleton.
    pub skeleton: &'a Skeleton,
    /// Rest world transforms.
    pub world: Vec<Transform>,
    /// Rest world joint positions.
    pub pos: Vec<Vec3>,
    /// World positions of end sites.
    pub tips: Vec<Option<Vec3>>,
    /// Children of each joint.
    pub children: Vec<Vec<usize>>,
    /// Lowest point (joints, tips, skin), metres.
    pub ground: f32,
    /// Standing height H, metres (never zero).
    pub height: f32,
    /// The height of the joints and end sites alone, without the skin, metres (never
    /// zero): what measures compare with when they measure joints, so that a head of skin
    /// as large as the body (a chibi) does not make its skeleton look short.
    pub skeleton_height: f32,
    /// Diagonal of the bounding box of joints, tips and skin, metres (never zero).
    pub extent: f32,
    /// Every skinned vertex of every mesh: position and its four influences.
    pub verts: Vec<SkinVertex>,
    /// Total skin weight of each joint (all zeros without a mesh).
    pub skin_weight: Vec<f32>,
    /// Lowest height (Y) over each joint's subtree points (joints and end sites).
    pub(super) sub_lo: Vec<f32>,
    /// Highest height (Y) over each joint's subtree points.
    pub(super) sub_hi: Vec<f32>,
    /// Number of joints in each joint's subtree, itself included.
    sub_count: Vec<usize>,
    /// For each joint, the sibling (another child of its parent) whose subtree reaches
    /// highest, the last of equals, as `max_by` picks it.
    pub(super) highest_sibling: Vec<Option<usize>>,
    /// Depth of each joint (roots 0).
    pub(super) depth: Vec<usize>,
    /// Depth-first entry and exit numbers: `a` is an ancestor of `b` exactly when `b`'s
    /// interval lies inside `a`'s, so the question costs nothing on a 65,536-deep chain.
    order: Vec<(usize, usize)>,
}

/// A skin vertex: its position and its four (joint, weight) influences.
pub type SkinVertex = (Vec3, [u16; 4], Vec4);

impl<'a> Rig<'a> {
    /// The rest pose, with the skin (bound in that pose).
    pub fn new(character: &'a Character) -> Self {
        Self::with_world(character, character.skeleton.rest_world(), true)
    }

    /// Another pose (`world`: one world transform per joint), without the skin, which is
    /// bound in the rest pose and would not follow.
    pub fn posed(character: &'a Character, world: Vec<Transform>) -> Self {
        Self::with_world(character, world, false)
    }

    fn with_world(character: &'a Character, world: Vec<Transform>, skin: bool) -> Self {
        let n = character.skeleton.len();
        let (verts, skin_weight) = if skin {
            skin_of(character)
        } else {
            (Vec::new(), vec![0.0; n])
        };
        Self::from_parts(&character.skeleton, world, verts, skin_weight)
    }

    /// The same pose and skin turned by `q` about the origin, as the character turned by
    /// [`Character::rotated`] would give, without copying its meshes and clips: what a
    /// check of the shape alone tries on a character lying in its file.
    pub fn turned(&self, q: Quat) -> Rig<'a> {
        let world = self
            .world
            .iter()
            .map(|t| Transform::new(q * t.translation, (q * t.rotation).normalize()))
            .collect();
        let verts = self.verts.iter().map(|&(p, j, w)| (q * p, j, w)).collect();
        Self::from_parts(self.skeleton, world, verts, self.skin_weight.clone())
    }

    fn from_parts(
        skeleton: &'a Skeleton,
        world: Vec<Transform>,
        verts: Vec<SkinVertex>,
        skin_weight: Vec<f32>,
    ) -> Self {
        let n = skeleton.len();
        let pos: Vec<Vec3> = world.iter().map(|t| t.translation).collect();
        let tips: Vec<Option<Vec3>> = (0..n)
            .map(|i| {
                skeleton.joints()[i]
                    .tip
                    .map(|t| world[i].transform_point(t))
            })
            .collect();
        let mut children = vec![Vec::new(); n];
        for (i, j) in skeleton.joints().iter().enumerate() {
            if let Some(p) = j.parent {
                children[p].push(i);
            }
        }
        let mut lo = Vec3::splat(f32::MAX);
        let mut hi = Vec3::splat(f32::MIN);
        let points = pos
            .iter()
            .chain(tips.iter().flatten())
            .chain(verts.iter().map(|v| &v.0));
        for p in points {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        let (bone_lo, bone_hi) = pos
            .iter()
            .chain(tips.iter().flatten())
            .fold((f32::MAX, f32::MIN), |(lo, hi), p| {
                (lo.min(p.y), hi.max(p.y))
            });
        let (sub_lo, sub_hi, sub_count) = subtree_stats(&pos, &tips, &children);
        let highest_sibling = highest_siblings(&children, &sub_hi);
        let mut depth = vec![0usize; n];
        for i in 0..n {
            if let Some(p) = skeleton.parent(i) {
                depth[i] = depth[p] + 1;
            }
        }
        let order = depth_first_order(skeleton, &children);
        Rig {
            skeleton,
            world,
            pos,
            tips,
            children,
            ground: lo.y,
            height: (hi.y - lo.y).max(1e-3),
            skeleton_height: (bone_hi - bone_lo).max(1e-3),
            extent: (hi - lo).length().max(1e-3),
            verts,
            skin_weight,
            sub_lo,
            sub_hi,
            sub_count,
            highest_sibling,
            depth,
            order,
        }
    }

    pub fn len(&self) -> usize {
        self.pos.len()
    }

    /// Whether `a` is a proper ancestor of `b`.
    pub fn is_ancestor(&self, a: usize, b: usize) -> bool {
        let (oa, ob) = (self.order[a], self.order[b]);
        a != b && oa.0 < ob.0 && ob.1 < oa.1
    }

    /// The deepest joint that is `a` or `b` or an ancestor of both.
    pub fn common_ancestor(&self, mut a: usize, mut b: usize) -> Option<usize> {
        while self.depth[a] > self.depth[b] {
            a = self.parent(a)?;
        }
        while self.depth[b] > self.depth[a] {
            b = self.parent(b)?;
        }
        while a != b {
            a = self.parent(a)?;
            b = self.parent(b)?;
        }
        Some(a)
    }

    pub fn has_skin(&self) -> bool {
        !self.verts.is_empty()
    }

    pub fn parent(&self, i: usize) -> Option<usize> {
        self.skeleton.parent(i)
    }

    /// `i` and all its descendants.
    pub fn subtree(&self, i: usize) -> Vec<usize> {
        let mut out = vec![i];
        let mut k = 0;
        while k < out.len() {
            out.extend_from_slice(&self.children[out[k]]);
            k += 1;
        }
        out
    }

    /// The mean position of the skin that the joints of `i`'s subtree carry most of (at
    /// least half its weight); `None` without such skin. A leaf foot bone has no toe
    /// joint, but its skin still shows which way the toes point.
    pub fn skin_centroid(&self, i: usize) -> Option<Vec3> {
        let mut mark = vec![false; self.len()];
        for j in self.subtree(i) {
            mark[j] = true;
        }
        let (mut sum, mut n) = (Vec3::ZERO, 0usize);
        for (p, js, ws) in &self.verts {
            let w: f32 = (0..4)
                .filter(|&c| mark.get(js[c] as usize).copied().unwrap_or(false))
                .map(|c| ws[c].max(0.0))
                .sum();
            if w >= 0.5 {
                sum += *p;
                n += 1;
            }
        }
        (n > 0).then(|| sum / n as f32)
    }

    /// Joint positions and end sites of the subtree of `i`.
    pub fn subtree_points(&self, i: usize) -> Vec<Vec3> {
        self.subtree(i)
            .into_iter()
            .flat_map(|j| std::iter::once(self.pos[j]).chain(self.tips[j]))
            .collect()
    }

    /// Lowest and highest height over the subtree of `i` (joints and end sites), and the
    /// number of joints in it; what [`Rig::subtree_points`] would give, without the walk.
    pub(super) fn subtree_stats(&self, i: usize) -> (f32, f32, usize) {
        (self.sub_lo[i], self.sub_hi[i], self.sub_count[i])
    }

    /// Where a non-humanoid joint's bone ends: its single child, the mean of its children
    /// when that mean is well away from the joint (else the farthest child: children
    /// spread symmetrically around a joint would otherwise give it no length), its end
    /// site, or, for a bare leaf, its parent bone continued by [`LEAF_LENGTH_FRACTION`].
    pub fn chain_bone_end(&self, i: usize) -> Option<Vec3> {
        let kids = &self.children[i];
        let p = self.pos[i];
        if !kids.is_empty() {
            let mean = kids.iter().map(|&k| self.pos[k]).sum::<Vec3>() / kids.len() as f32;
            let far = kids
                .iter()
                .map(|&k| self.pos[k])
                .max_by(|a, b| a.distance(p).total_cmp(&b.distance(p)))
                .unwrap_or(mean);
            return Some(if mean.distance(p) >= 0.5 * far.distance(p) {
                mean
            } else {
                far
            });
        }
        if let Some(t) = self.tips[i] {
            return Some(t);
        }
        let parent = self.parent(i)?;
        let d = p - self.pos[parent];
        (d.length() > 1e-6).then(|| p + d * LEAF_LENGTH_FRACTION)
    }
}

/// Horizontal part of `v` (Y up).
pub(crate) fn horizontal(v: Vec3) -> Vec3 {
    Vec3::new(v.x, 0.0, v.z)
}

pub(super) fn centroid(points: &[Vec3]) -> Vec3 {
    if points.is_empty() {
        Vec3::ZERO
    } else {
        points.iter().sum::<Vec3>() / points.len() as f32
    }
}

/// Every skinned vertex of the character's meshes with its four influences (finite
/// positions only), and each joint's total skin weight.
fn skin_of(character: &Character) -> (Vec<SkinVertex>, Vec<f32>) {
    let mut verts = Vec::new();
    let mut skin_weight = vec![0.0f32; character.skeleton.len()];
    for m in &character.meshes {
        for (k, &p) in m.positions.iter().enumerate() {
            let (Some(&js), Some(&ws)) = (m.joints.get(k), m.weights.get(k)) else {
                continue;
            };
            if !p.is_finite() {
                continue;
            }
            for c in 0..4 {
                if let Some(w) = skin_weight.get_mut(js[c] as usize) {
                    *w += ws[c].max(0.0);
                }
            }
            verts.push((p, js, ws));
        }
    }
    (verts, skin_weight)
}

/// Each joint's subtree: its lowest and highest point (joints and end sites) and how many
/// joints it holds. Children have higher indices than their parents, so one backward
/// pass sees every subtree complete before its root.
fn subtree_stats(
    pos: &[Vec3],
    tips: &[Option<Vec3>],
    children: &[Vec<usize>],
) -> (Vec<f32>, Vec<f32>, Vec<usize>) {
    let n = pos.len();
    let mut sub_lo = vec![f32::MAX; n];
    let mut sub_hi = vec![f32::MIN; n];
    let mut sub_count = vec![1usize; n];
    for i in (0..n).rev() {
        for y in std::iter::once(pos[i].y).chain(tips[i].map(|t| t.y)) {
            sub_lo[i] = sub_lo[i].min(y);
            sub_hi[i] = sub_hi[i].max(y);
        }
        for &c in &children[i] {
            sub_lo[i] = sub_lo[i].min(sub_lo[c]);
            sub_hi[i] = sub_hi[i].max(sub_hi[c]);
            sub_count[i] += sub_count[c];
        }
    }
    (sub_lo, sub_hi, sub_count)
}

/// For each joint, the sibling whose subtree reaches highest (`sub_hi`), the last of
/// equals, as `max_by` picks it.
fn highest_siblings(children: &[Vec<usize>], sub_hi: &[f32]) -> Vec<Option<usize>> {
    let mut highest = vec![None; sub_hi.len()];
    for kids in children {
        let last_max = |skip: Option<usize>| {
            kids.iter()
                .copied()
                .filter(|&c| Some(c) != skip)
                .max_by(|&a, &b| sub_hi[a].total_cmp(&sub_hi[b]))
        };
        let first = last_max(None);
        let second = last_max(first);
        for &c in kids {
            highest[c] = if Some(c) == first { second } else { first };
        }
    }
    highest
}

/// Depth-first entry and exit numbers of every joint, without recursion (a chain may be
/// 65,536 deep).
fn depth_first_order(skeleton: &Skeleton, children: &[Vec<usize>]) -> Vec<(usize, usize)> {
    let n = skeleton.len();
    let mut order = vec![(0usize, 0usize); n];
    let mut clock = 0;
    let mut stack: Vec<(usize, bool)> = (0..n)
        .rev()
        .filter(|&i| skeleton.parent(i).is_none())
        .map(|i| (i, false))
        .collect();
    while let Some((j, done)) = stack.pop() {
        if done {
            order[j].1 = clock;
        } else {
            order[j].0 = clock;
            stack.push((j, true));
            stack.extend(children[j].iter().rev().map(|&c| (c, false)));
        }
        clock += 1;
    }
    order
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A random tree of `n` joints (parents drawn among the earlier ones), some with tips.
    fn random_tree(seed: u64, n: usize) -> Character {
        let mut state = seed;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f32 / (1u64 << 53) as f32
        };
        let joints = (0..n)
            .map(|i| crate::skeleton::Joint {
                name: format!("j{i}"),
                parent: (i > 0).then(|| (next() * i as f32) as usize),
                rest: Transform::from_translation(Vec3::new(next(), next(), next()) - 0.5),
                tip: (next() < 0.3).then(|| Vec3::new(next(), next(), next()) - 0.5),
            })
            .collect();
        Character {
            humanoid_bones: Vec::new(),
            warnings: Vec::new(),
            name: "random".into(),
            skeleton: Skeleton::new(joints).unwrap(),
            meshes: Vec::new(),
            clips: Vec::new(),
            source: crate::skeleton::Source::BuiltIn,
        }
    }

    /// Turning the rig is turning the character first: the same positions, tips, skin and
    /// per-subtree facts, to rounding, without copying the character's meshes and clips.
    #[test]
    fn spec_roles_a_turned_rig_is_the_rig_of_the_turned_character() {
        let mut c = crate::skeleton::humanoid();
        c.meshes = crate::spec::bodies_mesh(
            &c.skeleton,
            &crate::spec::build_spec(&c, &Default::default()).unwrap(),
        )
        .into_iter()
        .collect();
        let q = glam::Quat::from_axis_angle(Vec3::new(1.0, 2.0, 0.5).normalize(), 1.3);
        let turned = c.rotated(q);
        let (a, b) = (Rig::new(&c).turned(q), Rig::new(&turned));
        let near = |x: Vec3, y: Vec3| (x - y).length() < 1e-5;
        assert!(a.pos.iter().zip(&b.pos).all(|(x, y)| near(*x, *y)));
        assert!((a.tips.iter().zip(&b.tips)).all(|(x, y)| match (x, y) {
            (Some(x), Some(y)) => near(*x, *y),
            (x, y) => x.is_none() && y.is_none(),
        }));
        assert!(!a.verts.is_empty() && a.verts.len() == b.verts.len());
        assert!((a.verts.iter().zip(&b.verts)).all(|(x, y)| near(x.0, y.0) && x.1 == y.1));
        assert_eq!(a.skin_weight, b.skin_weight);
        for (x, y) in [
            (a.ground, b.ground),
            (a.height, b.height),
            (a.extent, b.extent),
        ] {
            assert!((x - y).abs() < 1e-5, "{x} {y}");
        }
        assert!((a.sub_lo.iter().zip(&b.sub_lo)).all(|(x, y)| (x - y).abs() < 1e-5));
        assert_eq!(a.highest_sibling, b.highest_sibling);
    }

    #[test]
    fn spec_roles_subtree_facts_match_the_walks_they_replace() {
        for seed in 1..20u64 {
            let c = random_tree(seed * 0x9e37_79b9, 200);
            let rig = Rig::new(&c);
            for i in 0..rig.len() {
                let pts = rig.subtree_points(i);
                let lo = pts.iter().map(|p| p.y).fold(f32::MAX, f32::min);
                let hi = pts.iter().map(|p| p.y).fold(f32::MIN, f32::max);
                assert_eq!(rig.subtree_stats(i), (lo, hi, rig.subtree(i).len()));
                // The highest sibling, as `max_by` over the parent's other children picks it.
                let expected = rig.parent(i).and_then(|p| {
                    rig.children[p]
                        .iter()
                        .copied()
                        .filter(|&c| c != i)
                        .max_by(|&a, &b| rig.sub_hi[a].total_cmp(&rig.sub_hi[b]))
                });
                assert_eq!(rig.highest_sibling[i], expected, "seed {seed} joint {i}");
                // Ancestry by intervals, as walking up the parents finds it.
                let mut up = Vec::new();
                let mut at = rig.parent(i);
                while let Some(p) = at {
                    up.push(p);
                    at = rig.parent(p);
                }
                for k in 0..rig.len() {
                    assert_eq!(
                        rig.is_ancestor(k, i),
                        up.contains(&k),
                        "seed {seed}: {k} above {i}"
                    );
                }
                assert_eq!(rig.depth[i], up.len());
            }
        }
    }
}
