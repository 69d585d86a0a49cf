//! The blocky pass: a game character built of rigid parts whose legs and arms are one part
//! each (Kenney's `torso`, `head`, `arm-left`, `leg-left`…) has no knee or elbow for the
//! structure pass to find, and its leaf parts have no end sites, so each limb is read from
//! the skin its part carries: where that skin reaches along the way the part hangs.

use glam::Vec3;

use super::rig::{Rig, horizontal};
use super::structure::{Humanoid, Limb, facing};
use super::*;

/// The head joint stands at least this far above the trunk joint: a head is not a part
/// sitting beside the hips.
const HEAD_ABOVE_TRUNK_H: f32 = 0.15;

/// A trunk joint with exactly two one-part legs standing on the ground, exactly two
/// one-part arms on either side clear of it, and a head above; `None` for anything else,
/// so a creature of rigid parts stays one.
pub(super) fn find_blocky(rig: &Rig) -> Option<Humanoid> {
    (0..rig.len()).find_map(|t| blocky_at(rig, t))
}

fn blocky_at(rig: &Rig, trunk: usize) -> Option<Humanoid> {
    let h = rig.height;
    let ty = rig.pos[trunk].y;
    // Legs may hang from the trunk or beside it from the node above.
    let siblings = rig.parent(trunk).map_or(&[][..], |p| &rig.children[p][..]);
    let beside = siblings.iter().filter(|&&c| c != trunk);
    let parts: Vec<(usize, Vec3)> = rig.children[trunk]
        .iter()
        .chain(beside)
        .filter_map(|&j| Some((j, part_reach(rig, j)?)))
        .collect();
    let is_leg = |&(j, tip): &(usize, Vec3)| {
        let y = rig.pos[j].y;
        tip.y <= rig.ground + LEG_GROUND_TOLERANCE_H * h
            && y - tip.y >= LEG_MIN_DROP_H * h
            && y <= ty + LEG_MAX_RISE_H * h
    };
    let legs: Vec<Limb> = parts
        .iter()
        .filter(|p| is_leg(p))
        .map(|p| limb(rig, *p))
        .collect();
    let [leg_a, leg_b] = <[Limb; 2]>::try_from(legs).ok()?;
    let across = horizontal(rig.pos[leg_a.upper] - rig.pos[leg_b.upper]);
    if !similar(&leg_a, &leg_b) || across.length() < MIN_LEG_SEPARATION_H * h {
        return None;
    }
    let lateral = across.normalize();
    let hips = rig.pos[leg_a.upper].max(rig.pos[leg_b.upper]).y;
    let mid = (rig.pos[leg_a.upper] + rig.pos[leg_b.upper]) * 0.5;
    let side = |j: usize| (rig.pos[j] - mid).dot(lateral);
    let is_arm = |&(j, tip): &(usize, Vec3)| {
        rig.children[trunk].contains(&j)
            && !is_leg(&(j, tip))
            && rig.pos[j].y > hips
            && side(j).abs() >= ARM_MIN_LATERAL_H * h
            && tip.y >= rig.ground + ARM_MIN_CLEARANCE_H * h
            && tip.distance(rig.pos[j]) >= ARM_MIN_LENGTH_H * h
    };
    let arms: Vec<Limb> = parts
        .iter()
        .filter(|p| is_arm(p))
        .map(|p| limb(rig, *p))
        .collect();
    let [arm_a, arm_b] = <[Limb; 2]>::try_from(arms).ok()?;
    let (arm_pos, arm_neg) = match (side(arm_a.upper) > 0.0, side(arm_b.upper) > 0.0) {
        (true, false) => (arm_a, arm_b),
        (false, true) => (arm_b, arm_a),
        _ => return None,
    };
    if !similar(&arm_pos, &arm_neg) {
        return None;
    }
    let limbs = [leg_a.upper, leg_b.upper, arm_pos.upper, arm_neg.upper];
    let head = head(rig, trunk, &limbs)?;
    let (forward, legs, arms) = facing(rig, lateral, [leg_a, leg_b], [arm_pos, arm_neg]);
    Some(Humanoid {
        pelvis: trunk,
        spine: None,
        chest: trunk,
        neck: None,
        head: Some(head),
        legs,
        arms,
        forward,
        mirrored: false,
    })
}

/// The trunk's other child reaching highest, if it stands well above the trunk joint.
fn head(rig: &Rig, trunk: usize, limbs: &[usize]) -> Option<usize> {
    let top = |c: usize| rig.subtree_stats(c).1;
    rig.children[trunk]
        .iter()
        .copied()
        .filter(|c| !limbs.contains(c))
        .max_by(|&a, &b| top(a).total_cmp(&top(b)))
        .filter(|&c| rig.pos[c].y >= rig.pos[trunk].y + HEAD_ABOVE_TRUNK_H * rig.height)
}

fn limb(rig: &Rig, (j, tip): (usize, Vec3)) -> Limb {
    Limb {
        root: j,
        upper: j,
        lower: None,
        end: None,
        length: tip.distance(rig.pos[j]),
    }
}

fn similar(a: &Limb, b: &Limb) -> bool {
    (a.length - b.length).abs() <= LIMB_LENGTH_TOLERANCE * a.length.max(b.length)
}

/// Where the skin of the leaf part at `j` reaches farthest along the way it hangs from its
/// joint (toward the skin's centre); `None` for a joint with children, or without skin of
/// its own, or whose skin is centred on it.
fn part_reach(rig: &Rig, j: usize) -> Option<Vec3> {
    if !rig.children[j].is_empty() {
        return None;
    }
    let p = rig.pos[j];
    let dir = (rig.skin_centroid(j)? - p).try_normalize()?;
    let carried = rig.verts.iter().filter(|(_, js, ws)| {
        let w: f32 = (0..4).filter(|&c| js[c] as usize == j).map(|c| ws[c]).sum();
        w >= 0.5
    });
    let far = carried
        .map(|(v, ..)| (*v - p).dot(dir))
        .fold(0.0f32, f32::max);
    (far > 1e-6 * rig.height).then(|| p + dir * far)
}
