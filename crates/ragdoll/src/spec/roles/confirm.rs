//! The geometry pass: bones that names (or a file's humanoid bone table) put forward as a
//! thigh, a shin, a hand… are accepted only if the hierarchy and the pose agree: the shin
//! hangs below its thigh, the forearm descends from its upper arm, the head is above the
//! pelvis, the two sides stand apart. Where the hierarchy detaches a bone from its anatomy
//! (IK feet under the root), the bone is taken if it lies where that anatomy ends.

use std::cmp::Reverse;

use glam::Vec3;

use super::LEG_GROUND_TOLERANCE_H;
use super::names::{NameHint, Part, name_hint, without_numbers};
use super::rig::Rig;
use super::side::{body_cue, forward_from_sides};
use super::structure::{Humanoid, Limb};

/// A thigh joint stands at least this far above its shin joint, and an upper arm above
/// the pelvis by at least nothing: legs hang, the trunk stands.
const THIGH_ABOVE_SHIN_H: f32 = 0.08;
/// The head joint is at least this far above the pelvis joint (~0.35 H on people; room
/// for big-headed game characters whose head joint sits low).
const HEAD_ABOVE_PELVIS_H: f32 = 0.15;
/// A foot or hand the hierarchy detaches from its limb is taken if its joint lies within
/// this distance of where the limb's lower segment ends (its length, or this fraction of
/// H when the segment's end is unknown).
const DETACHED_END_H: f32 = 0.12;

/// A leaf this far above the joint before it, at the top of the chain over the chest, is
/// the top of the skull (Mixamo's `HeadTop_End`), not the head joint: a neck's bones are
/// shorter (~0.05 H each), a head 0.13 H tall.
const SKULL_H: f32 = 0.08;

/// Where a pass's claims come from: the file's humanoid bone table or the joint names.
#[derive(Clone, Copy)]
pub(super) enum Source<'a> {
    Table(&'a [(String, usize)]),
    Names(&'a [NameHint]),
}

impl Source<'_> {
    /// The joints this source claims on `rig`.
    pub(super) fn claims(self, rig: &Rig) -> Claims {
        match self {
            Source::Table(t) => claims_from_table(rig, t),
            Source::Names(h) => claims_from_names(rig, h),
        }
    }

    /// Where the roles came from, as the user reads it.
    pub(super) fn words(self) -> &'static str {
        match self {
            Source::Table(_) => "from the file's humanoid bone table",
            Source::Names(_) => "from the joint names",
        }
    }

    /// How the roles were found, confirmed in `pose`.
    pub(super) fn checked_in(self, pose: &str) -> String {
        match self {
            Source::Table(_) => format!("{}, checked in the {pose}", self.words()),
            Source::Names(_) => format!(
                "{}, checked against the skeleton in the {pose}",
                self.words()
            ),
        }
    }

    /// Why the claims failed in `pose` with the check's sentence `e`.
    pub(super) fn doubt(self, pose: &str, e: &str) -> String {
        match self {
            Source::Table(_) => {
                format!("the file's humanoid bone table does not hold in the {pose}: {e}")
            }
            Source::Names(_) => {
                format!("the joint names do not give a humanoid in the {pose}: {e}")
            }
        }
    }
}

/// The joints claimed for each part, before they are checked.
#[derive(Clone, Debug, Default)]
pub(super) struct Claims {
    pub pelvis: Option<usize>,
    pub spine: Option<usize>,
    pub chest: Option<usize>,
    pub neck: Option<usize>,
    pub head: Option<usize>,
    /// Per side (left, right): thigh, shin, foot.
    pub legs: [[Option<usize>; 3]; 2],
    /// Per side (left, right): upper arm, forearm, hand.
    pub arms: [[Option<usize>; 3]; 2],
}

impl Claims {
    /// The humanoid these claims make with the trunk `[pelvis, chest]` and the limbs
    /// confirmed: the spine and neck only where they lie between, not on, their
    /// neighbours.
    pub(super) fn humanoid(
        &self,
        [pelvis, chest]: [usize; 2],
        legs: [Limb; 2],
        arms: [Limb; 2],
        forward: Vec3,
        mirrored: bool,
    ) -> Humanoid {
        Humanoid {
            pelvis,
            spine: self.spine.filter(|&s| s != chest && s != pelvis),
            chest,
            neck: self.neck.filter(|&n| Some(n) != self.head && n != chest),
            head: self.head,
            legs,
            arms,
            forward,
            mirrored,
        }
    }
}

/// Claims from a humanoid bone table in VRM's (and Unity's) vocabulary. Unknown names
/// and indices out of range are skipped.
pub(super) fn claims_from_table(rig: &Rig, table: &[(String, usize)]) -> Claims {
    let mut c = Claims::default();
    for (name, j) in table {
        if *j >= rig.len() {
            continue;
        }
        let slot = match name.as_str() {
            "hips" => &mut c.pelvis,
            "spine" => &mut c.spine,
            "chest" => &mut c.chest,
            "neck" => &mut c.neck,
            "head" => &mut c.head,
            "leftUpperLeg" => &mut c.legs[0][0],
            "leftLowerLeg" => &mut c.legs[0][1],
            "leftFoot" => &mut c.legs[0][2],
            "rightUpperLeg" => &mut c.legs[1][0],
            "rightLowerLeg" => &mut c.legs[1][1],
            "rightFoot" => &mut c.legs[1][2],
            "leftUpperArm" => &mut c.arms[0][0],
            "leftLowerArm" => &mut c.arms[0][1],
            "leftHand" => &mut c.arms[0][2],
            "rightUpperArm" => &mut c.arms[1][0],
            "rightLowerArm" => &mut c.arms[1][1],
            "rightHand" => &mut c.arms[1][2],
            _ => continue,
        };
        *slot = Some(*j);
    }
    c
}

/// Claims from the joint names: for each side the lower segment (shin, forearm) first,
/// then the nearest upper segment above it (so Mixamo's `LeftShoulder`, a collar, loses to
/// `LeftArm`, while CMU's `LeftShoulder` above `LeftElbow` wins), then the first extremity
/// below it, else one the hierarchy detached that lies where the segment ends. Of two
/// such joints equally deep, the one carrying more of the skeleton: Valve's helper bones
/// `Bip01_L_Elbow` and `Bip01_L_Wrist` are leaves beside the forearm and the hand.
pub(super) fn claims_from_names(rig: &Rig, hints: &[NameHint]) -> Claims {
    let is = |j: usize, part: Part, side: i32| {
        let h = &hints[j];
        !h.helper && h.part == Some(part) && h.side == side
    };
    let mut c = Claims::default();
    for (s, side) in [1, -1].into_iter().enumerate() {
        for (slot, parts) in [
            (&mut c.legs[s], [Part::Thigh, Part::Shin, Part::Foot]),
            (&mut c.arms[s], [Part::UpperArm, Part::Forearm, Part::Hand]),
        ] {
            *slot = limb_claims(rig, parts, |j, p| is(j, p, side));
        }
    }
    let trunk = |part: Part| (0..rig.len()).filter(move |&j| is(j, part, 0));
    let arms: Vec<usize> = c.arms.iter().filter_map(|a| a[0]).collect();
    // Where the arms meet; a neck there (3ds Max Biped hangs its clavicles from
    // `Bip01 Neck`) hands the chest to the first joint below it that is not a neck.
    let mut chest = match arms[..] {
        [a, b] => common_ancestor(rig, a, b),
        _ => None,
    };
    while let Some(j) = chest.filter(|&j| is(j, Part::Neck, 0)) {
        chest = rig.parent(j);
    }
    c.chest = chest;
    let thighs: Vec<usize> = c.legs.iter().filter_map(|l| l[0]).collect();
    let legs_meet = match thighs[..] {
        [a, b] => common_ancestor(rig, a, b),
        _ => None,
    };
    if let Some(chest) = c.chest {
        // The named pelvis on the way up to the chest; else the named one where the legs'
        // and the spine's ways part (Daz's `hip`, over its `pelvis` that holds the
        // thighs); else where the legs meet.
        let parting = legs_meet.and_then(|m| common_ancestor(rig, m, chest));
        c.pelvis = trunk(Part::Pelvis)
            .filter(|&p| p != chest && is_ancestor(rig, p, chest))
            .filter(|&p| legs_meet.is_some_and(|m| is_ancestor(rig, m, p) || m == p))
            .max_by_key(|&p| depth(rig, p))
            .or_else(|| trunk(Part::Pelvis).find(|&p| Some(p) == parting && p != chest))
            .or(legs_meet.filter(|&m| m != chest && is_ancestor(rig, m, chest)));
        c.head = trunk(Part::Head)
            .filter(|&h| is_ancestor(rig, chest, h))
            .min_by_key(|&h| depth(rig, h))
            .or_else(|| unnamed_head(rig, chest, &arms));
        c.neck = c.head.and_then(|head| {
            let between = path_down(rig, chest, head);
            between
                .iter()
                .copied()
                .find(|&j| is(j, Part::Neck, 0))
                .or(between.first().copied())
        });
        c.spine = c
            .pelvis
            .and_then(|p| path_down(rig, p, chest).first().copied());
    }
    c
}

/// Where no joint is named a head (Rigify's `spine.006`): the chain rising from the chest
/// beside the arms, each step to the child reaching highest and only while it rises (a
/// jaw hangs forward and down), less the end markers and eyes its names call helpers and
/// a last leaf as far above the one before it as the top of a skull is above its base.
/// What is left is neck joints and the head, the last of them: the head of
/// `neck, head`, and of Rigify's `spine.004, spine.005, spine.006` or Daz's `neckLower,
/// neckUpper, head`, whose necks have two bones.
pub(super) fn unnamed_head(rig: &Rig, chest: usize, arms: &[usize]) -> Option<usize> {
    let top = |c: usize| rig.subtree_stats(c).1;
    let beside_arms = |c: &usize| !arms.iter().any(|&a| a == *c || is_ancestor(rig, *c, a));
    let mut path = Vec::new();
    let mut at = chest;
    while let Some(next) = rig.children[at]
        .iter()
        .copied()
        .filter(|c| !path.is_empty() || beside_arms(c))
        .filter(|&c| rig.pos[c].y > rig.pos[at].y)
        .max_by(|&a, &b| top(a).total_cmp(&top(b)))
    {
        path.push(next);
        at = next;
    }
    let helper = |j: usize| name_hint(&rig.skeleton.joints()[j].name).helper;
    while path.last().is_some_and(|&j| helper(j)) {
        path.pop();
    }
    if let [.., a, b] = path[..]
        && path.len() >= 3
        && rig.children[b].is_empty()
        && rig.pos[a].distance(rig.pos[b]) >= SKULL_H * rig.height
    {
        path.pop();
    }
    path.last().copied()
}

/// Upper, lower and end joints of one limb, as [`claims_from_names`] picks them.
fn limb_claims(
    rig: &Rig,
    parts: [Part; 3],
    is: impl Fn(usize, Part) -> bool,
) -> [Option<usize>; 3] {
    let [upper_part, lower_part, end_part] = parts;
    // The nearest proper ancestor of each joint that names the upper part, in one pass
    // (parents come before children), so a deep chain of such names costs linear time.
    let mut above: Vec<Option<usize>> = vec![None; rig.len()];
    for j in 0..rig.len() {
        above[j] = rig
            .parent(j)
            .and_then(|p| if is(p, upper_part) { Some(p) } else { above[p] });
    }
    let lowers = (0..rig.len()).filter(|&j| is(j, lower_part));
    let Some((lower, upper)) = lowers
        .filter_map(|l| Some((l, above[l]?)))
        .min_by_key(|&(l, _)| (depth(rig, l), Reverse(rig.subtree_stats(l).2)))
    else {
        return [None; 3];
    };
    let (upper, lower) = (first_of_split(rig, upper), first_of_split(rig, lower));
    let ends: Vec<usize> = (0..rig.len()).filter(|&j| is(j, end_part)).collect();
    let end = ends
        .iter()
        .copied()
        .filter(|&e| is_ancestor(rig, lower, e))
        .min_by_key(|&e| (depth(rig, e), Reverse(rig.subtree_stats(e).2)))
        .or_else(|| detached_end(rig, upper, lower, &ends));
    [Some(upper), Some(lower), end]
}

/// The first bone of a segment split in numbered parts (`upper_arm.L` before
/// `upper_arm.L.001`).
fn first_of_split(rig: &Rig, mut j: usize) -> usize {
    let name = |j: usize| without_numbers(&rig.skeleton.joints()[j].name);
    while let Some(p) = rig.parent(j)
        && name(p) == name(j)
    {
        j = p;
    }
    j
}

/// A foot or hand outside the limb's subtree that lies where the lower segment ends: as
/// far from the knee (elbow) as the knee is from the hip, give or take
/// [`DETACHED_END_H`], and below the knee for a leg.
fn detached_end(rig: &Rig, upper: usize, lower: usize, ends: &[usize]) -> Option<usize> {
    let knee = rig.pos[lower];
    let reach = rig.pos[upper].distance(knee);
    ends.iter()
        .copied()
        .filter(|&e| !is_ancestor(rig, e, lower) && e != lower)
        .map(|e| (e, (rig.pos[e].distance(knee) - reach).abs()))
        .filter(|&(_, miss)| miss <= DETACHED_END_H * rig.height)
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(e, _)| e)
}

/// Checks claims against the hierarchy and the pose, and turns them into a humanoid; the
/// error is one sentence saying what did not hold.
pub(super) fn confirm(rig: &Rig, c: &Claims) -> Result<Humanoid, String> {
    let name = |j: usize| rig.skeleton.joint_label(j);
    let (legs, arms) = confirm_limbs(rig, c)?;
    let chest = c.chest.ok_or("the upper arms have no joint in common")?;
    let pelvis = c.pelvis.ok_or("no pelvis between the legs and the chest")?;
    if !is_ancestor(rig, pelvis, chest) {
        return Err(format!(
            "the chest {} does not rise from the pelvis {}",
            name(chest),
            name(pelvis)
        ));
    }
    let py = rig.pos[pelvis].y;
    if let Some(head) = c.head
        && rig.pos[head].y < py + HEAD_ABOVE_PELVIS_H * rig.height
    {
        return Err(format!(
            "the head {} is not above the pelvis {} in this pose",
            name(head),
            name(pelvis)
        ));
    }
    for a in &arms {
        if rig.pos[a.upper].y <= py {
            return Err(format!(
                "the shoulder {} is below the pelvis in this pose",
                name(a.upper)
            ));
        }
    }
    let side_joints = |s: usize| {
        let (l, a) = (&legs[s], &arms[s]);
        [l.upper, l.lower_or_upper(), a.upper, a.lower_or_upper()]
    };
    let mut forward = forward_from_sides(rig, &side_joints(0), &side_joints(1))
        .ok_or("the left and right limbs do not stand apart")?;
    // The names (or the table) give the sides; the facing is the body's where its feet or
    // knees clearly say, since knees and elbows hinge by it. Where the two disagree the
    // names were given from the viewer's side (Godot's Robi: `l-` limbs on its right, its
    // toes, knees and knee poles toward +Z): the roles keep the names, and the builder
    // reads which side a limb is on from where it is, not from its role.
    let mirrored = body_cue(rig, &[&legs[0], &legs[1]], forward) == Some(-1.0);
    if mirrored {
        forward = -forward;
    }
    Ok(c.humanoid([pelvis, chest], legs, arms, forward, mirrored))
}

/// The limb half of [`confirm`]: both legs and arms claimed, hanging from each other in
/// the hierarchy, hips below shoulders, knees below hips, a leg on the ground.
fn confirm_limbs(rig: &Rig, c: &Claims) -> Result<([Limb; 2], [Limb; 2]), String> {
    let name = |j: usize| rig.skeleton.joint_label(j);
    let mut legs = Vec::new();
    let mut arms = Vec::new();
    for (s, side) in ["left", "right"].iter().enumerate() {
        let [Some(thigh), Some(shin), foot] = c.legs[s] else {
            return Err(format!("no {side} thigh and shin"));
        };
        let [Some(upper), Some(fore), hand] = c.arms[s] else {
            return Err(format!("no {side} upper arm and forearm"));
        };
        if !is_ancestor(rig, thigh, shin) {
            return Err(format!(
                "the shin {} does not hang from the thigh {}",
                name(shin),
                name(thigh)
            ));
        }
        if !is_ancestor(rig, upper, fore) {
            return Err(format!(
                "the forearm {} does not hang from the upper arm {}",
                name(fore),
                name(upper)
            ));
        }
        if rig.pos[thigh].y - rig.pos[shin].y < THIGH_ABOVE_SHIN_H * rig.height {
            return Err(format!(
                "the knee {} is not below the hip {} in this pose",
                name(shin),
                name(thigh)
            ));
        }
        if foot.is_some_and(|f| rig.pos[f].y >= rig.pos[shin].y) {
            return Err(format!("the ankle of {} is not below the knee", name(shin)));
        }
        legs.push(limb(rig, thigh, shin, foot));
        arms.push(limb(rig, upper, fore, hand));
    }
    let limb_joints = legs
        .iter()
        .chain(&arms)
        .flat_map(|l| std::iter::once(l.upper).chain(l.lower));
    let mut seen = Vec::new();
    for j in limb_joints {
        if seen.contains(&j) {
            return Err(format!("{} is claimed for two limb segments", name(j)));
        }
        seen.push(j);
    }
    for (leg, arm) in legs.iter().zip(&arms) {
        if rig.pos[leg.upper].y >= rig.pos[arm.upper].y {
            return Err(format!(
                "the hip {} is not below the shoulder {} in this pose",
                name(leg.upper),
                name(arm.upper)
            ));
        }
    }
    // At least one leg stands: the other may be raised (a dance, a kick).
    let lowest = |l: &Limb| {
        let (lo, _, _) = rig.subtree_stats(l.lower_or_upper());
        l.end.map_or(lo, |e| lo.min(rig.pos[e].y))
    };
    if legs.iter().map(lowest).fold(f32::MAX, f32::min)
        > rig.ground + LEG_GROUND_TOLERANCE_H * rig.height
    {
        return Err("neither leg reaches the ground in this pose".into());
    }
    let (Ok(legs), Ok(arms)) = (<[Limb; 2]>::try_from(legs), <[Limb; 2]>::try_from(arms)) else {
        return Err("not two legs and two arms".into());
    };
    Ok((legs, arms))
}

pub(super) fn limb(rig: &Rig, upper: usize, lower: usize, end: Option<usize>) -> Limb {
    let end_pos = end
        .map(|e| rig.pos[e])
        .or_else(|| rig.chain_bone_end(lower));
    Limb {
        root: upper,
        upper,
        lower: Some(lower),
        end,
        length: rig.pos[upper].distance(rig.pos[lower])
            + end_pos.map_or(0.0, |e: Vec3| e.distance(rig.pos[lower])),
    }
}

fn is_ancestor(rig: &Rig, a: usize, b: usize) -> bool {
    rig.is_ancestor(a, b)
}

fn depth(rig: &Rig, j: usize) -> usize {
    rig.depth[j]
}

fn common_ancestor(rig: &Rig, a: usize, b: usize) -> Option<usize> {
    rig.common_ancestor(a, b)
}

/// The joints strictly between `top` and its descendant `bottom`, top first.
pub(super) fn path_down(rig: &Rig, top: usize, bottom: usize) -> Vec<usize> {
    let mut out = Vec::new();
    let mut at = rig.parent(bottom);
    while let Some(j) = at
        && j != top
    {
        out.push(j);
        at = rig.parent(j);
    }
    out.reverse();
    out
}
