//! Recognising what each joint is (pelvis, thigh, …) from topology and geometry.
//!
//! Names are unreliable (CesiumMan has none, mocap rigs disagree on every word), so the
//! skeleton's shape decides and names are only a tie-breaker for left and right:
//!
//! 1. **Pelvis**: a joint with two child chains hanging down to the ground (legs, mirror
//!    images of each other) and one rising chain (the spine).
//! 2. **Chest**: along the spine, the joint where two lateral, mirror-image chains branch
//!    (arms) that do not reach the ground (a quadruped's front legs do). The pelvis→chest
//!    line must be near vertical; otherwise the creature is not a standing humanoid (Fox).
//! 3. **Neck, head**: the joints continuing the spine above the chest.
//! 4. **Limbs**: within each leg or arm chain the two longest consecutive segments are the
//!    upper and lower limb (thigh/shin, upper arm/forearm); the joint ending the lower one
//!    is the foot or hand. Collars, buttocks, toes, fingers ride on their neighbours.
//! 5. **Facing**: from the feet (ankle → toes), else the knees' bend, else left/right in
//!    the names, else +Z. Left is `up × forward`.
//!
//! Anything else becomes a [`Role::Chain`] link (non-humanoids) or rides on its parent.

use std::collections::{HashMap, HashSet};

use glam::{Vec3, Vec4};

use super::Role;
use crate::math::Transform;
use crate::skeleton::{Character, Skeleton};

/// The outcome of role recognition.
#[derive(Clone, Debug, PartialEq)]
pub struct Roles {
    /// For each skeleton joint, its role, or `None` when the joint gets no body of its own
    /// (it rides on the body of its nearest ancestor that has one).
    pub per_joint: Vec<Option<Role>>,
    /// Whether the skeleton was recognised as a standing humanoid.
    pub humanoid: bool,
    /// The character's forward direction in the rest pose (unit, horizontal for humanoids).
    pub forward: Vec3,
    /// Standing height, metres: top of the skeleton (or skin) above its lowest point. Every
    /// proportion-based estimate is a fraction of it, which keeps them scale-free.
    pub height_m: f32,
}

impl Roles {
    /// The first joint with `role` (for [`Role::Chain`], the first chain link).
    pub fn joint(&self, role: Role) -> Option<usize> {
        self.per_joint.iter().position(|r| *r == Some(role))
    }

    /// The character's left in the rest pose, `up × forward`, so a character facing +Z has
    /// its left toward +X.
    pub fn left(&self) -> Vec3 {
        Vec3::Y.cross(self.forward).normalize_or(Vec3::X)
    }
}

/// Recognises roles; never fails: a skeleton that is not a humanoid gets chain links.
pub fn recognise_roles(character: &Character) -> Roles {
    let rig = Rig::new(character);
    if let Some(h) = find_humanoid(&rig) {
        let mut per_joint = vec![None; rig.len()];
        for (j, role) in h.assignments() {
            per_joint[j] = Some(role);
        }
        return Roles {
            per_joint,
            humanoid: true,
            forward: h.forward,
            height_m: rig.height,
        };
    }
    Roles {
        per_joint: chain_roles(&rig),
        humanoid: false,
        forward: creature_forward(&rig),
        height_m: rig.height,
    }
}

// --- Tuning, as fractions of the standing height H unless said otherwise ----------------

/// A leg's lowest point is within this of the ground: feet stand on it in a rest pose,
/// with room for a raised foot or a thick sole.
const LEG_GROUND_TOLERANCE_H: f32 = 0.15;
/// Legs hang at least this far below the pelvis (about half of H on real people).
const LEG_MIN_DROP_H: f32 = 0.3;
/// Legs do not rise more than this above the pelvis joint (CMU's buttock joints sit a
/// little above it).
const LEG_MAX_RISE_H: f32 = 0.1;
/// The spine chain rises at least this far above the pelvis (the head is ~0.45 H above).
const SPINE_MIN_RISE_H: f32 = 0.25;
/// Largest angle of the pelvis→chest line from vertical for a standing humanoid; a
/// quadruped's back is near horizontal.
const SPINE_MAX_TILT_DEG: f32 = 40.0;
/// An arm's joints are on average at least this far from the mid-plane (shoulders are
/// about 0.1 H out).
const ARM_MIN_LATERAL_H: f32 = 0.06;
/// Arms stop at least this far above the ground (fingertips hang at ~0.38 H); front legs
/// of a quadruped reach it.
const ARM_MIN_CLEARANCE_H: f32 = 0.2;
/// An arm chain (shoulder to fingertip ≈ 0.4 H) is at least this long.
const ARM_MIN_LENGTH_H: f32 = 0.2;
/// Mirror limbs differ in length by at most this fraction.
const LIMB_LENGTH_TOLERANCE: f32 = 0.25;
/// The legs' centres are at least this far apart sideways, else there is no left/right.
const MIN_LEG_SEPARATION_H: f32 = 0.02;
/// A facing cue (feet, knees) must be at least this big to be trusted.
const FORWARD_CUE_MIN_H: f32 = 0.01;
/// Feet must point mostly forward (|forward part| / |horizontal part|) to be a cue;
/// a sideways foot says nothing.
const FOOT_CUE_MIN_ALIGNMENT: f32 = 0.5;
/// Non-humanoid bones shorter than this fraction of the skeleton's extent AND shorter
/// than [`CHAIN_MIN_MEDIAN_FRACTION`] of the median bone ride on their parent: too short
/// to be stable bodies (end sites, toe nubs, helper offsets).
const CHAIN_MIN_EXTENT_FRACTION: f32 = 0.03;
/// See [`CHAIN_MIN_EXTENT_FRACTION`].
const CHAIN_MIN_MEDIAN_FRACTION: f32 = 0.25;
/// A leaf without an end site is assumed to continue its parent bone for this fraction
/// of the parent's length (tails and fingers taper).
pub(crate) const LEAF_LENGTH_FRACTION: f32 = 0.5;
/// A joint counts as skinned when its vertex weights add up to at least this (half a
/// vertex): joints nothing is weighted to are helpers (Fox's `_rootJoint`, `b_Root_00`).
const MIN_SKIN_WEIGHT: f32 = 0.5;

// --- Geometry shared with `build.rs` -----------------------------------------------------

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
    /// Diagonal of the bounding box of joints, tips and skin, metres (never zero).
    pub extent: f32,
    /// Every skinned vertex of every mesh: position and its four influences.
    pub verts: Vec<(Vec3, [u16; 4], Vec4)>,
    /// Total skin weight of each joint (all zeros without a mesh).
    pub skin_weight: Vec<f32>,
    /// Lowest height (Y) over each joint's subtree points (joints and end sites).
    sub_lo: Vec<f32>,
    /// Highest height (Y) over each joint's subtree points.
    sub_hi: Vec<f32>,
    /// Number of joints in each joint's subtree, itself included.
    sub_count: Vec<usize>,
    /// For each joint, the sibling (another child of its parent) whose subtree reaches
    /// highest, the last of equals, as `max_by` picks it.
    highest_sibling: Vec<Option<usize>>,
}

impl<'a> Rig<'a> {
    pub fn new(character: &'a Character) -> Self {
        let skeleton = &character.skeleton;
        let n = skeleton.len();
        let world = skeleton.rest_world();
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
        let mut verts = Vec::new();
        let mut skin_weight = vec![0.0f32; n];
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
        let height = (hi.y - lo.y).max(1e-3);
        let extent = (hi - lo).length().max(1e-3);
        // Children have higher indices than their parents: one backward pass sees every
        // subtree complete before its root.
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
        let mut highest_sibling = vec![None; n];
        for kids in &children {
            let last_max = |skip: Option<usize>| {
                kids.iter()
                    .copied()
                    .filter(|&c| Some(c) != skip)
                    .max_by(|&a, &b| sub_hi[a].total_cmp(&sub_hi[b]))
            };
            let first = last_max(None);
            let second = last_max(first);
            for &c in kids {
                highest_sibling[c] = if Some(c) == first { second } else { first };
            }
        }
        Rig {
            skeleton,
            world,
            pos,
            tips,
            children,
            ground: lo.y,
            height,
            extent,
            verts,
            skin_weight,
            sub_lo,
            sub_hi,
            sub_count,
            highest_sibling,
        }
    }

    pub fn len(&self) -> usize {
        self.pos.len()
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

    /// Joint positions and end sites of the subtree of `i`.
    pub fn subtree_points(&self, i: usize) -> Vec<Vec3> {
        self.subtree(i)
            .into_iter()
            .flat_map(|j| std::iter::once(self.pos[j]).chain(self.tips[j]))
            .collect()
    }

    /// Lowest and highest height over the subtree of `i` (joints and end sites), and the
    /// number of joints in it; what [`Rig::subtree_points`] would give, without the walk.
    fn subtree_stats(&self, i: usize) -> (f32, f32, usize) {
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

fn centroid(points: &[Vec3]) -> Vec3 {
    if points.is_empty() {
        Vec3::ZERO
    } else {
        points.iter().sum::<Vec3>() / points.len() as f32
    }
}

// --- Humanoid recognition ------------------------------------------------------------

/// One leg or arm: its chain of joints from the trunk outward and which of them carry the
/// upper segment, the lower segment and the extremity.
#[derive(Clone, Debug)]
struct Limb {
    /// First joint of the limb's subtree (child of the trunk joint).
    root: usize,
    upper: usize,
    lower: usize,
    end: Option<usize>,
    /// Sum of the known segment lengths of the chain.
    length: f32,
}

impl Limb {
    /// Follows the limb from `root` toward its farthest point and picks the two longest
    /// consecutive segments as upper and lower limb, so collars, buttocks and twist bones
    /// before them and toes or fingers after them do not matter.
    fn from_root(rig: &Rig, root: usize) -> Option<Limb> {
        let origin = rig.pos[root];
        // How far from the limb's root each joint's subtree reaches, bottom up over the
        // limb's subtree (breadth-first order reversed puts children first).
        let sub = rig.subtree(root);
        let mut far: HashMap<usize, f32> = HashMap::with_capacity(sub.len());
        for &j in sub.iter().rev() {
            let own = std::iter::once(rig.pos[j])
                .chain(rig.tips[j])
                .map(|p| p.distance(origin));
            let kids = rig.children[j].iter().map(|c| far[c]);
            far.insert(j, own.chain(kids).fold(0.0f32, f32::max));
        }
        let reach = |j: usize| far[&j];
        let mut chain = vec![root];
        let mut at = root;
        while let Some(next) = rig.children[at]
            .iter()
            .copied()
            .max_by(|&a, &b| reach(a).total_cmp(&reach(b)))
        {
            chain.push(next);
            at = next;
        }
        let seg: Vec<Option<f32>> = (0..chain.len())
            .map(|k| match chain.get(k + 1) {
                Some(&n) => Some(rig.pos[n].distance(rig.pos[chain[k]])),
                None => rig.tips[chain[k]].map(|t| t.distance(rig.pos[chain[k]])),
            })
            .collect();
        let mut best: Option<(usize, f32)> = None;
        for k in 0..chain.len().saturating_sub(1) {
            if let (Some(a), Some(b)) = (seg[k], seg[k + 1]) {
                if best.is_none_or(|(_, s)| a + b > s) {
                    best = Some((k, a + b));
                }
            }
        }
        let (k, _) = best?;
        Some(Limb {
            root,
            upper: chain[k],
            lower: chain[k + 1],
            end: chain.get(k + 2).copied(),
            length: seg.iter().flatten().sum(),
        })
    }

    fn points(&self, rig: &Rig) -> Vec<Vec3> {
        rig.subtree_points(self.root)
    }

    fn similar_length(&self, other: &Limb) -> bool {
        let (a, b) = (self.length, other.length);
        (a - b).abs() <= LIMB_LENGTH_TOLERANCE * a.max(b)
    }
}

/// What was found of a humanoid, before roles are written out.
#[derive(Debug)]
struct Humanoid {
    pelvis: usize,
    spine: Option<usize>,
    chest: usize,
    neck: Option<usize>,
    head: Option<usize>,
    /// Left, right.
    legs: [Limb; 2],
    /// Left, right.
    arms: [Limb; 2],
    forward: Vec3,
}

impl Humanoid {
    fn assignments(&self) -> Vec<(usize, Role)> {
        let mut out = vec![(self.pelvis, Role::Pelvis), (self.chest, Role::Chest)];
        out.extend(self.spine.map(|j| (j, Role::Spine)));
        out.extend(self.neck.map(|j| (j, Role::Neck)));
        out.extend(self.head.map(|j| (j, Role::Head)));
        let sides = [
            [
                Role::ThighL,
                Role::ShinL,
                Role::FootL,
                Role::UpperArmL,
                Role::ForearmL,
                Role::HandL,
            ],
            [
                Role::ThighR,
                Role::ShinR,
                Role::FootR,
                Role::UpperArmR,
                Role::ForearmR,
                Role::HandR,
            ],
        ];
        for (s, r) in sides.iter().enumerate() {
            let (leg, arm) = (&self.legs[s], &self.arms[s]);
            out.push((leg.upper, r[0]));
            out.push((leg.lower, r[1]));
            out.extend(leg.end.map(|j| (j, r[2])));
            out.push((arm.upper, r[3]));
            out.push((arm.lower, r[4]));
            out.extend(arm.end.map(|j| (j, r[5])));
        }
        out
    }
}

fn find_humanoid(rig: &Rig) -> Option<Humanoid> {
    (0..rig.len()).find_map(|j| humanoid_at(rig, j))
}

/// Tries joint `pelvis` as the branch point of the legs.
fn humanoid_at(rig: &Rig, pelvis: usize) -> Option<Humanoid> {
    let h = rig.height;
    let py = rig.pos[pelvis].y;
    let stats = |c: usize| rig.subtree_stats(c);
    let leg_like = |c: usize| {
        let (lo, hi, count) = stats(c);
        count >= 2
            && lo <= rig.ground + LEG_GROUND_TOLERANCE_H * h
            && py - lo >= LEG_MIN_DROP_H * h
            && hi <= py + LEG_MAX_RISE_H * h
    };
    let legs: Vec<usize> = rig.children[pelvis]
        .iter()
        .copied()
        .filter(|&c| leg_like(c))
        .collect();
    if legs.len() < 2 {
        return None;
    }
    // The spine rises from the pelvis, or (rigs whose legs hang off a separate pelvis
    // joint) from one of its ancestors, beside the branch holding the pelvis: the child
    // reaching highest, if it reaches high enough. Above the pelvis that child is the
    // highest sibling of the branch we came up, known without looking at the others.
    let leg_set: HashSet<usize> = legs.iter().copied().collect();
    let rises = |c: usize| stats(c).1 >= py + SPINE_MIN_RISE_H * h && !leg_set.contains(&c);
    let mut spine_start = rig.children[pelvis]
        .iter()
        .copied()
        .filter(|&c| rises(c))
        .max_by(|&a, &b| stats(a).1.total_cmp(&stats(b).1));
    let mut below = pelvis;
    while spine_start.is_none() {
        let Some(up) = rig.parent(below) else { break };
        spine_start = rig.highest_sibling[below].filter(|&c| rises(c));
        below = up;
    }
    let spine_start = spine_start?;

    // Legs: the most symmetric pair of leg-like chains.
    let leg_limbs: Vec<Limb> = legs
        .iter()
        .filter_map(|&c| Limb::from_root(rig, c))
        .collect();
    let mut best: Option<(f32, usize, usize)> = None;
    for a in 0..leg_limbs.len() {
        for b in a + 1..leg_limbs.len() {
            let (la, lb) = (&leg_limbs[a], &leg_limbs[b]);
            if !la.similar_length(lb) {
                continue;
            }
            let score = (la.length - lb.length).abs();
            if best.is_none_or(|(s, _, _)| score < s) {
                best = Some((score, a, b));
            }
        }
    }
    let (_, a, b) = best?;
    let (leg_a, leg_b) = (leg_limbs[a].clone(), leg_limbs[b].clone());
    let lateral = horizontal(centroid(&leg_a.points(rig)) - centroid(&leg_b.points(rig)));
    if lateral.length() < MIN_LEG_SEPARATION_H * h {
        return None;
    }
    let lateral = lateral.normalize();

    // Spine path: from its first joint, always toward the highest point.
    let top = |c: usize| stats(c).1;
    let mut path = vec![spine_start];
    while let Some(next) = rig.children[*path.last().unwrap_or(&spine_start)]
        .iter()
        .copied()
        .max_by(|&a, &b| top(a).total_cmp(&top(b)))
    {
        path.push(next);
    }

    // Arms: lateral chains branching off the spine path, mirror images of each other.
    let mid = rig.pos[pelvis];
    let on_path: HashSet<usize> = path.iter().copied().collect();
    let mut arms: Vec<(usize, Limb, f32)> = Vec::new(); // (path index, limb, side)
    for (m, &k) in path.iter().enumerate() {
        for &c in &rig.children[k] {
            if on_path.contains(&c) || stats(c).2 < 2 {
                continue;
            }
            let pts = rig.subtree_points(c);
            let side = (centroid(&pts) - mid).dot(lateral);
            let lowest = pts.iter().map(|p| p.y).fold(f32::MAX, f32::min);
            if side.abs() < ARM_MIN_LATERAL_H * h || lowest < rig.ground + ARM_MIN_CLEARANCE_H * h {
                continue;
            }
            if let Some(limb) = Limb::from_root(rig, c)
                && limb.length >= ARM_MIN_LENGTH_H * h
            {
                arms.push((m, limb, side));
            }
        }
    }
    let mut arm_pair: Option<(usize, Limb, Limb)> = None; // (chest path index, +side, -side)
    for (ma, la, sa) in &arms {
        for (mb, lb, sb) in &arms {
            if *sa > 0.0 && *sb < 0.0 && la.similar_length(lb) {
                let m = (*ma).max(*mb);
                if arm_pair.as_ref().is_none_or(|(best, _, _)| m < *best) {
                    arm_pair = Some((m, la.clone(), lb.clone()));
                }
            }
        }
    }
    let (chest_at, arm_pos, arm_neg) = arm_pair?;
    let chest = path[chest_at];
    let rise = rig.pos[chest] - rig.pos[pelvis];
    if rise.length() < 1e-6 || rise.normalize().y < SPINE_MAX_TILT_DEG.to_radians().cos() {
        return None;
    }

    let spine = path[..chest_at].first().copied();
    let above = &path[chest_at + 1..];
    let named_head = above
        .iter()
        .position(|&j| has_token(&rig.skeleton.joints()[j].name, "head"));
    let (neck, head) = match (named_head, above.len()) {
        (Some(0), _) => (None, Some(above[0])),
        (Some(i), _) => (Some(above[0]), Some(above[i])),
        (None, 0) => (None, None),
        (None, 1) => (None, Some(above[0])),
        (None, _) => (Some(above[0]), Some(above[1])),
    };

    // Facing. `lateral` points from leg b to leg a; forward is ± lateral × up.
    let across = lateral.cross(Vec3::Y).normalize();
    let legs_ab = [&leg_a, &leg_b];
    let sign = feet_cue(rig, &legs_ab, across)
        .or_else(|| knee_cue(rig, &legs_ab, across))
        .or_else(|| name_cue(rig, &legs_ab, &[&arm_pos, &arm_neg], lateral))
        .unwrap_or_else(|| default_facing(across));
    let forward = across * sign;
    let left = Vec3::Y.cross(forward);
    // Leg a is on the +lateral side, the arm `arm_pos` too.
    let (legs, arms) = if lateral.dot(left) > 0.0 {
        ([leg_a, leg_b], [arm_pos, arm_neg])
    } else {
        ([leg_b, leg_a], [arm_neg, arm_pos])
    };
    Some(Humanoid {
        pelvis,
        spine,
        chest,
        neck,
        head,
        legs,
        arms,
        forward,
    })
}

/// Sign of `across` that the feet point to (ankle → toes), if they clearly do.
fn feet_cue(rig: &Rig, legs: &[&Limb; 2], across: Vec3) -> Option<f32> {
    let mut sum = Vec3::ZERO;
    for leg in legs {
        let Some(foot) = leg.end else { continue };
        let ankle = rig.pos[foot];
        let toe = rig
            .subtree_points(foot)
            .into_iter()
            .max_by(|a, b| a.distance(ankle).total_cmp(&b.distance(ankle)));
        if let Some(toe) = toe {
            sum += horizontal(toe - ankle);
        }
    }
    let along = sum.dot(across);
    (along.abs() >= FORWARD_CUE_MIN_H * rig.height
        && along.abs() >= FOOT_CUE_MIN_ALIGNMENT * sum.length())
    .then(|| along.signum())
}

/// Sign of `across` toward which the knees stand out of the hip–ankle line: knees only
/// bend forward.
fn knee_cue(rig: &Rig, legs: &[&Limb; 2], across: Vec3) -> Option<f32> {
    let mut sum = 0.0;
    for leg in legs {
        let hip = rig.pos[leg.upper];
        let knee = rig.pos[leg.lower];
        let ankle = match leg.end {
            Some(f) => rig.pos[f],
            None => rig.chain_bone_end(leg.lower)?,
        };
        let axis = ankle - hip;
        if axis.length_squared() < 1e-12 {
            continue;
        }
        let t = ((knee - hip).dot(axis) / axis.length_squared()).clamp(0.0, 1.0);
        sum += (knee - (hip + axis * t)).dot(across);
    }
    (sum.abs() >= FORWARD_CUE_MIN_H * rig.height).then(|| sum.signum())
}

/// Sign of `across` implied by left/right words in the limbs' joint names.
fn name_cue(rig: &Rig, legs: &[&Limb; 2], arms: &[&Limb; 2], lateral: Vec3) -> Option<f32> {
    // legs[0] and arms[0] are on the +lateral side.
    let mut vote = 0i32;
    for (limb, side) in [(legs[0], 1), (legs[1], -1), (arms[0], 1), (arms[1], -1)] {
        for j in rig.subtree(limb.root) {
            vote += side * side_hint(&rig.skeleton.joints()[j].name);
        }
    }
    // vote > 0: +lateral is the left. left = up × forward, so forward = left × up.
    (vote != 0).then(|| {
        let forward = (lateral * vote.signum() as f32).cross(Vec3::Y);
        let across = lateral.cross(Vec3::Y);
        forward.dot(across).signum()
    })
}

/// Facing +Z when nothing else tells (glTF's convention); +X if the legs lie along Z.
fn default_facing(across: Vec3) -> f32 {
    if across.z.abs() > 1e-3 {
        across.z.signum()
    } else {
        across.x.signum()
    }
}

/// +1 when a joint name says left, −1 for right, 0 otherwise.
pub(crate) fn side_hint(name: &str) -> i32 {
    for t in tokens(name) {
        match t.as_str() {
            "l" | "left" | "lft" => return 1,
            "r" | "right" | "rt" | "rgt" => return -1,
            _ if t.starts_with("left") => return 1,
            _ if t.starts_with("right") => return -1,
            _ => {}
        }
    }
    0
}

fn has_token(name: &str, word: &str) -> bool {
    tokens(name).iter().any(|t| t == word)
}

/// Splits a joint name into lower-case words: at non-alphanumerics, between lower and
/// upper case (`lThigh` → `l`, `thigh`), before the last capital of a capital run
/// (`LThigh` → `l`, `thigh`), and between letters and digits.
fn tokens(name: &str) -> Vec<String> {
    let mut out = Vec::new();
    for piece in name.split(|c: char| !c.is_alphanumeric()) {
        let chars: Vec<char> = piece.chars().collect();
        let mut word = String::new();
        for (i, &c) in chars.iter().enumerate() {
            let prev = i.checked_sub(1).map(|p| chars[p]);
            let next = chars.get(i + 1);
            let boundary = match prev {
                None => false,
                Some(p) => {
                    (p.is_lowercase() && c.is_uppercase())
                        || (p.is_uppercase()
                            && c.is_uppercase()
                            && next.is_some_and(|n| n.is_lowercase()))
                        || (p.is_alphabetic() != c.is_alphabetic())
                }
            };
            if boundary && !word.is_empty() {
                out.push(std::mem::take(&mut word).to_lowercase());
            }
            word.push(c);
        }
        if !word.is_empty() {
            out.push(word.to_lowercase());
        }
    }
    out
}

// --- Non-humanoids -------------------------------------------------------------------

/// Every bone long enough (and skinned, when there is a skin) becomes a chain link.
fn chain_roles(rig: &Rig) -> Vec<Option<Role>> {
    let n = rig.len();
    let lengths: Vec<f32> = (0..n)
        .map(|i| {
            rig.chain_bone_end(i)
                .map_or(0.0, |e| e.distance(rig.pos[i]))
        })
        .collect();
    let mut sorted: Vec<f32> = lengths.iter().copied().filter(|l| *l > 1e-6).collect();
    sorted.sort_by(f32::total_cmp);
    let median = sorted.get(sorted.len() / 2).copied().unwrap_or(0.0);
    let min_len = (CHAIN_MIN_EXTENT_FRACTION * rig.extent).min(CHAIN_MIN_MEDIAN_FRACTION * median);
    let skinned = |i: usize| !rig.has_skin() || rig.skin_weight[i] >= MIN_SKIN_WEIGHT;
    let mut roles: Vec<Option<Role>> = (0..n)
        .map(|i| (lengths[i] > min_len.max(1e-6) && skinned(i)).then_some(Role::Chain))
        .collect();
    if roles.iter().all(Option::is_none) {
        // Something must carry the character: the most skinned joint, else the root.
        let pick = (0..n)
            .max_by(|&a, &b| {
                rig.skin_weight[a]
                    .total_cmp(&rig.skin_weight[b])
                    .then(b.cmp(&a))
            })
            .unwrap_or(0);
        roles[pick] = Some(Role::Chain);
    }
    roles
}

/// A creature faces where its spine goes from the hips (a quadruped's head end); else +Z.
fn creature_forward(rig: &Rig) -> Vec3 {
    let root = 0;
    let far = rig
        .subtree_points(root)
        .into_iter()
        .max_by(|a, b| a.y.total_cmp(&b.y))
        .unwrap_or(Vec3::Z);
    // The highest point of a quadruped is its head; of anything upright, straight above.
    let d = horizontal(far - centroid(&rig.pos));
    if d.length() > FORWARD_CUE_MIN_H * rig.extent {
        d.normalize()
    } else {
        Vec3::Z
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use glam::Quat;

    use super::*;
    use crate::skeleton::humanoid;

    /// `c` turned by `yaw` about the vertical through the origin.
    pub(crate) fn yawed(c: &Character, yaw: f32) -> Character {
        c.turned(yaw)
    }

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
            }
        }
    }

    #[test]
    fn spec_roles_builtin_humanoid_exact() {
        let c = humanoid();
        let roles = recognise_roles(&c);
        assert!(roles.humanoid);
        for (i, j) in c.skeleton.joints().iter().enumerate() {
            assert_eq!(
                roles.per_joint[i].map(Role::as_str),
                Some(j.name.as_str()),
                "joint {}",
                j.name
            );
        }
        assert!(
            (roles.forward - Vec3::Z).length() < 1e-5,
            "{:?}",
            roles.forward
        );
        assert!((roles.left() - Vec3::X).length() < 1e-5);
        // The toes' end site (3 cm up) is the lowest point the skeleton knows of.
        assert!((roles.height_m - 1.72).abs() < 1e-4, "{}", roles.height_m);
    }

    #[test]
    fn spec_roles_builtin_humanoid_any_yaw() {
        let c = humanoid();
        let base = recognise_roles(&c);
        for k in 0..8 {
            let yaw = (k as f32 * 45.0).to_radians();
            let r = recognise_roles(&yawed(&c, yaw));
            assert_eq!(r.per_joint, base.per_joint, "yaw {}", k * 45);
            let f = Quat::from_rotation_y(yaw) * Vec3::Z;
            assert!(
                (r.forward - f).length() < 1e-4,
                "yaw {}: {:?}",
                k * 45,
                r.forward
            );
        }
    }

    #[test]
    fn spec_roles_names_give_facing_when_geometry_cannot() {
        // Feet pointing straight down and straight knees: only the names tell left from
        // right. Mirror the built-in humanoid's left/right names onto a skeleton whose
        // geometry is symmetric front/back and check the names decide.
        let c = humanoid();
        let mut joints = c.skeleton.joints().to_vec();
        for j in &mut joints {
            if j.name.starts_with("foot") {
                j.tip = Some(Vec3::new(0.0, -0.06, 0.0));
            }
            j.name = match j.name.as_str() {
                "thigh_l" => "LeftUpLeg".into(),
                "thigh_r" => "RightUpLeg".into(),
                "upper_arm_l" => "lShldr".into(),
                "upper_arm_r" => "rShldr".into(),
                _ => j.name.clone(),
            };
        }
        let mut c2 = c.clone();
        c2.skeleton = Skeleton::new(joints).unwrap();
        for k in [0, 3, 5] {
            let yaw = (k as f32 * 45.0).to_radians();
            let r = recognise_roles(&yawed(&c2, yaw));
            assert!(r.humanoid);
            let s = &c2.skeleton;
            assert_eq!(
                r.per_joint[s.find("LeftUpLeg").unwrap()],
                Some(Role::ThighL)
            );
            assert_eq!(
                r.per_joint[s.find("rShldr").unwrap()],
                Some(Role::UpperArmR)
            );
            let f = Quat::from_rotation_y(yaw) * Vec3::Z;
            assert!(
                (r.forward - f).length() < 1e-4,
                "yaw {}: {:?}",
                k * 45,
                r.forward
            );
        }
    }

    #[test]
    fn spec_roles_tokens_and_side_hints() {
        assert_eq!(tokens("lThigh"), ["l", "thigh"]);
        assert_eq!(tokens("LThigh"), ["l", "thigh"]);
        assert_eq!(
            tokens("mixamorig:LeftUpLeg"),
            ["mixamorig", "left", "up", "leg"]
        );
        assert_eq!(tokens("b_LeftLeg01_015"), ["b", "left", "leg", "01", "015"]);
        assert_eq!(side_hint("lThigh"), 1);
        assert_eq!(side_hint("thigh_l"), 1);
        assert_eq!(side_hint("Bip01 R Thigh"), -1);
        assert_eq!(side_hint("RightHand"), -1);
        assert_eq!(side_hint("lowerarm"), 0);
        assert_eq!(side_hint("LowLeg"), 0);
        assert_eq!(side_hint("rib"), 0);
        assert_eq!(side_hint("Hips"), 0);
    }

    fn chain(points: &[Vec3]) -> Character {
        let mut joints = Vec::new();
        let mut prev = Vec3::ZERO;
        for (i, p) in points.iter().enumerate() {
            joints.push(crate::skeleton::Joint {
                name: format!("link{i}"),
                parent: i.checked_sub(1),
                rest: Transform::from_translation(*p - prev),
                tip: None,
            });
            prev = *p;
        }
        Character {
            humanoid_bones: Vec::new(),
            warnings: Vec::new(),
            name: "chain".into(),
            skeleton: Skeleton::new(joints).unwrap(),
            meshes: Vec::new(),
            clips: Vec::new(),
            source: crate::skeleton::Source::BuiltIn,
        }
    }

    #[test]
    fn spec_roles_two_joint_chain_is_not_humanoid() {
        let c = chain(&[Vec3::ZERO, Vec3::new(0.0, 0.0, 0.15)]);
        let r = recognise_roles(&c);
        assert!(!r.humanoid);
        // The root bone is long; the bare leaf continues it by half.
        assert_eq!(r.per_joint, vec![Some(Role::Chain), Some(Role::Chain)]);
    }

    #[test]
    fn spec_roles_single_joint_still_gets_a_body() {
        let c = chain(&[Vec3::new(0.0, 1.0, 0.0)]);
        let r = recognise_roles(&c);
        assert!(!r.humanoid);
        assert_eq!(r.per_joint, vec![Some(Role::Chain)]);
    }

    #[test]
    fn spec_roles_quadruped_is_not_humanoid() {
        // A horizontal spine with four legs to the ground and a neck: the Fox's layout.
        let c = quadruped();
        let r = recognise_roles(&c);
        assert!(!r.humanoid);
        assert!(
            r.per_joint.iter().all(|x| *x == Some(Role::Chain)),
            "{:?}",
            r.per_joint
        );
        assert!((r.forward - Vec3::Z).length() < 1e-4, "{:?}", r.forward);
    }

    pub(crate) fn quadruped() -> Character {
        let rows: &[(&str, Option<usize>, Vec3)] = &[
            ("hip", None, Vec3::new(0.0, 0.45, -0.3)),
            ("spine", Some(0), Vec3::new(0.0, 0.5, 0.0)),
            ("chest", Some(1), Vec3::new(0.0, 0.5, 0.3)),
            ("neck", Some(2), Vec3::new(0.0, 0.6, 0.4)),
            ("head", Some(3), Vec3::new(0.0, 0.7, 0.5)),
            ("front_l", Some(2), Vec3::new(0.08, 0.45, 0.3)),
            ("front_l2", Some(5), Vec3::new(0.08, 0.2, 0.3)),
            ("front_l3", Some(6), Vec3::new(0.08, 0.0, 0.3)),
            ("front_r", Some(2), Vec3::new(-0.08, 0.45, 0.3)),
            ("front_r2", Some(8), Vec3::new(-0.08, 0.2, 0.3)),
            ("front_r3", Some(9), Vec3::new(-0.08, 0.0, 0.3)),
            ("back_l", Some(0), Vec3::new(0.08, 0.4, -0.3)),
            ("back_l2", Some(11), Vec3::new(0.08, 0.2, -0.3)),
            ("back_l3", Some(12), Vec3::new(0.08, 0.0, -0.3)),
            ("back_r", Some(0), Vec3::new(-0.08, 0.4, -0.3)),
            ("back_r2", Some(14), Vec3::new(-0.08, 0.2, -0.3)),
            ("back_r3", Some(15), Vec3::new(-0.08, 0.0, -0.3)),
            ("tail", Some(0), Vec3::new(0.0, 0.5, -0.5)),
        ];
        let joints = rows
            .iter()
            .map(|(name, parent, p)| crate::skeleton::Joint {
                name: (*name).into(),
                parent: *parent,
                rest: Transform::from_translation(*p - parent.map_or(Vec3::ZERO, |q| rows[q].2)),
                tip: None,
            })
            .collect();
        Character {
            humanoid_bones: Vec::new(),
            warnings: Vec::new(),
            name: "quadruped".into(),
            skeleton: Skeleton::new(joints).unwrap(),
            meshes: Vec::new(),
            clips: Vec::new(),
            source: crate::skeleton::Source::BuiltIn,
        }
    }
}
