//! The structure pass: a humanoid found from the skeleton's shape alone (two legs down to
//! the ground and a rising spine from one joint, two mirror-image arms off the spine), for
//! rigs whose names say nothing (CesiumMan's joints have none).

use std::collections::{HashMap, HashSet};

use glam::Vec3;

use super::names::has_token;
use super::rig::{Rig, centroid, horizontal};
use super::side::{body_cue, default_facing, name_cue};
use super::*;

/// One leg or arm: its chain of joints from the trunk outward and which of them carry the
/// upper segment, the lower segment and the extremity.
#[derive(Clone, Debug)]
pub(super) struct Limb {
    /// First joint of the limb's subtree (child of the trunk joint).
    pub root: usize,
    pub upper: usize,
    /// `None` for a limb of one rigid part (a blocky game character's leg), which has no
    /// knee or elbow to bend at.
    pub lower: Option<usize>,
    pub end: Option<usize>,
    /// Sum of the known segment lengths of the chain.
    pub length: f32,
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
            lower: Some(chain[k + 1]),
            end: chain.get(k + 2).copied(),
            length: seg.iter().flatten().sum(),
        })
    }

    /// The joint ending the upper segment where there is one, else the upper joint: the
    /// limb's joints that say where it lies.
    pub fn lower_or_upper(&self) -> usize {
        self.lower.unwrap_or(self.upper)
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
pub(super) struct Humanoid {
    pub pelvis: usize,
    pub spine: Option<usize>,
    pub chest: usize,
    pub neck: Option<usize>,
    pub head: Option<usize>,
    /// Left, right.
    pub legs: [Limb; 2],
    /// Left, right.
    pub arms: [Limb; 2],
    pub forward: Vec3,
    /// Whether the sides were given (by names or a bone table) mirrored: the body faces
    /// the other way than they imply, so the limbs called left are on its right (see
    /// `confirm::confirm`).
    pub mirrored: bool,
}

impl Humanoid {
    pub fn assignments(&self) -> Vec<(usize, Role)> {
        let mut out = vec![(self.pelvis, Role::Pelvis)];
        // A trunk of one part is the pelvis, whose body carries the chest's share too.
        out.extend((self.chest != self.pelvis).then_some((self.chest, Role::Chest)));
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
            out.extend(leg.lower.map(|j| (j, r[1])));
            out.extend(leg.end.map(|j| (j, r[2])));
            out.push((arm.upper, r[3]));
            out.extend(arm.lower.map(|j| (j, r[4])));
            out.extend(arm.end.map(|j| (j, r[5])));
        }
        out
    }
}

pub(super) fn find_humanoid(rig: &Rig) -> Option<Humanoid> {
    (0..rig.len()).find_map(|j| humanoid_at(rig, j))
}

/// Tries joint `pelvis` as the branch point of the legs.
fn humanoid_at(rig: &Rig, pelvis: usize) -> Option<Humanoid> {
    let legs = leg_roots(rig, pelvis)?;
    let spine_start = spine_start(rig, pelvis, &legs)?;
    let (leg_a, leg_b, lateral) = leg_pair(rig, &legs)?;
    let path = spine_path(rig, spine_start);
    let arms = arm_candidates(rig, pelvis, &path, lateral);
    let (chest_at, arm_pos, arm_neg) = arm_pair(&arms)?;
    let chest = path[chest_at];
    if !chest_upright(rig, pelvis, chest) {
        return None;
    }
    let spine = path[..chest_at].first().copied();
    let (neck, head) = neck_and_head(rig, &path[chest_at + 1..]);
    let (forward, legs, arms) = facing(rig, lateral, [leg_a, leg_b], [arm_pos, arm_neg]);
    Some(Humanoid {
        pelvis,
        spine,
        chest,
        neck,
        head,
        legs,
        arms,
        forward,
        mirrored: false,
    })
}

/// The children of `pelvis` whose subtrees look like legs; `None` unless there are at
/// least two.
fn leg_roots(rig: &Rig, pelvis: usize) -> Option<Vec<usize>> {
    // Joints against the joints' own height, as for the spine (`spine_start`).
    let h = rig.skeleton_height;
    let py = rig.pos[pelvis].y;
    let leg_like = |c: usize| {
        let (lo, hi, count) = rig.subtree_stats(c);
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
    Some(legs)
}

/// The first joint of the spine.
///
/// The spine rises from the pelvis, or (rigs whose legs hang off a separate pelvis
/// joint) from one of its ancestors, beside the branch holding the pelvis: the child
/// reaching highest, if it reaches high enough. Above the pelvis that child is the
/// highest sibling of the branch we came up, known without looking at the others.
fn spine_start(rig: &Rig, pelvis: usize, legs: &[usize]) -> Option<usize> {
    // Joints against the joints' own height: a chibi's head of skin, as large as the rest
    // of it, put its skeleton's top under a quarter of its height above the pelvis.
    let h = rig.skeleton_height;
    let py = rig.pos[pelvis].y;
    let stats = |c: usize| rig.subtree_stats(c);
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
    spine_start
}

/// Legs: the most symmetric pair of leg-like chains, far enough apart. Returns the two
/// legs and the unit horizontal direction `lateral` from the second leg to the first.
fn leg_pair(rig: &Rig, legs: &[usize]) -> Option<(Limb, Limb, Vec3)> {
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
    if lateral.length() < MIN_LEG_SEPARATION_H * rig.height {
        return None;
    }
    Some((leg_a, leg_b, lateral.normalize()))
}

/// Spine path: from its first joint, always toward the highest point.
fn spine_path(rig: &Rig, spine_start: usize) -> Vec<usize> {
    let top = |c: usize| rig.subtree_stats(c).1;
    let mut path = vec![spine_start];
    while let Some(next) = rig.children[*path.last().unwrap_or(&spine_start)]
        .iter()
        .copied()
        .max_by(|&a, &b| top(a).total_cmp(&top(b)))
    {
        path.push(next);
    }
    path
}

/// Arms: lateral chains branching off the spine path, as (path index, limb, side), the
/// side being the signed offset along `lateral` from the pelvis.
fn arm_candidates(
    rig: &Rig,
    pelvis: usize,
    path: &[usize],
    lateral: Vec3,
) -> Vec<(usize, Limb, f32)> {
    let h = rig.height;
    let mid = rig.pos[pelvis];
    let on_path: HashSet<usize> = path.iter().copied().collect();
    let mut arms: Vec<(usize, Limb, f32)> = Vec::new(); // (path index, limb, side)
    for (m, &k) in path.iter().enumerate() {
        for &c in &rig.children[k] {
            if on_path.contains(&c) || rig.subtree_stats(c).2 < 2 {
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
    arms
}

/// The arms, mirror images of each other: of the pairs on opposite sides with similar
/// lengths, the one whose higher branch point (the chest) is lowest on the spine path.
/// Returns (chest path index, +side arm, -side arm).
fn arm_pair(arms: &[(usize, Limb, f32)]) -> Option<(usize, Limb, Limb)> {
    let mut arm_pair: Option<(usize, Limb, Limb)> = None; // (chest path index, +side, -side)
    for (ma, la, sa) in arms {
        for (mb, lb, sb) in arms {
            if *sa > 0.0 && *sb < 0.0 && la.similar_length(lb) {
                let m = (*ma).max(*mb);
                if arm_pair.as_ref().is_none_or(|(best, _, _)| m < *best) {
                    arm_pair = Some((m, la.clone(), lb.clone()));
                }
            }
        }
    }
    arm_pair
}

/// Whether the trunk from the pelvis to the chest stands up within `SPINE_MAX_TILT_DEG`.
fn chest_upright(rig: &Rig, pelvis: usize, chest: usize) -> bool {
    let rise = rig.pos[chest] - rig.pos[pelvis];
    !(rise.length() < 1e-6 || rise.normalize().y < SPINE_MAX_TILT_DEG.to_radians().cos())
}

/// Neck and head among the spine path's joints `above` the chest: up to a joint named
/// "head" if there is one, else the first two.
fn neck_and_head(rig: &Rig, above: &[usize]) -> (Option<usize>, Option<usize>) {
    let named_head = above
        .iter()
        .position(|&j| has_token(&rig.skeleton.joints()[j].name, "head"));
    match (named_head, above.len()) {
        (Some(0), _) => (None, Some(above[0])),
        (Some(i), _) => (Some(above[0]), Some(above[i])),
        (None, 0) => (None, None),
        (None, 1) => (None, Some(above[0])),
        (None, _) => (Some(above[0]), Some(above[1])),
    }
}

/// Facing, and the legs and arms put in (left, right) order. `lateral` points from leg b
/// to leg a; forward is ± lateral × up.
pub(super) fn facing(
    rig: &Rig,
    lateral: Vec3,
    [leg_a, leg_b]: [Limb; 2],
    [arm_pos, arm_neg]: [Limb; 2],
) -> (Vec3, [Limb; 2], [Limb; 2]) {
    let across = lateral.cross(Vec3::Y).normalize();
    let legs_ab = [&leg_a, &leg_b];
    let sign = body_cue(rig, &legs_ab, across)
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
    (forward, legs, arms)
}
