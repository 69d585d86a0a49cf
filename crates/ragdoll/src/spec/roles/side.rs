//! The side pass: which way the character faces, hence which limbs are its left ones.

use glam::Vec3;

use super::names::side_hint;
use super::rig::{Rig, horizontal};
use super::structure::Limb;
use super::*;

/// Sign of `across` the body faces: its feet's, else its knees' (see [`feet_cue`] and
/// [`knee_cue`]); `None` when neither clearly says.
pub(super) fn body_cue(rig: &Rig, legs: &[&Limb; 2], across: Vec3) -> Option<f32> {
    feet_cue(rig, legs, across).or_else(|| knee_cue(rig, legs, across))
}

/// Sign of `across` that the feet point to (ankle → toes), if they clearly do. A foot
/// without joints or end sites past the ankle is read from its skin, which lies mostly
/// toward the toes.
pub(super) fn feet_cue(rig: &Rig, legs: &[&Limb; 2], across: Vec3) -> Option<f32> {
    let mut sum = Vec3::ZERO;
    for leg in legs {
        let Some(foot) = leg.end else { continue };
        let ankle = rig.pos[foot];
        let toe = rig
            .subtree_points(foot)
            .into_iter()
            .max_by(|a, b| a.distance(ankle).total_cmp(&b.distance(ankle)))
            .filter(|t| horizontal(*t - ankle).length() > 1e-6 * rig.height)
            .or_else(|| rig.skin_centroid(foot));
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
pub(super) fn knee_cue(rig: &Rig, legs: &[&Limb; 2], across: Vec3) -> Option<f32> {
    let mut sum = 0.0;
    for leg in legs {
        // A leg of one part has no knee to tell by.
        let Some(knee_joint) = leg.lower else {
            continue;
        };
        let hip = rig.pos[leg.upper];
        let knee = rig.pos[knee_joint];
        let ankle = match leg.end {
            Some(f) => rig.pos[f],
            None => rig.chain_bone_end(knee_joint)?,
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
pub(super) fn name_cue(
    rig: &Rig,
    legs: &[&Limb; 2],
    arms: &[&Limb; 2],
    lateral: Vec3,
) -> Option<f32> {
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
pub(super) fn default_facing(across: Vec3) -> f32 {
    if across.z.abs() > 1e-3 {
        across.z.signum()
    } else {
        across.x.signum()
    }
}
/// Forward for a humanoid whose sides the names (or a bone table) give: the left limbs'
/// joints lie on the character's left, so `left = up × forward` fixes the facing and the
/// sides can never come out swapped. `None` when the two sides do not stand apart.
pub(super) fn forward_from_sides(rig: &Rig, left: &[usize], right: &[usize]) -> Option<Vec3> {
    let mean = |js: &[usize]| {
        let pts: Vec<Vec3> = js.iter().map(|&j| rig.pos[j]).collect();
        super::rig::centroid(&pts)
    };
    let across = horizontal(mean(left) - mean(right));
    (across.length() >= MIN_LEG_SEPARATION_H * rig.height)
        .then(|| across.normalize().cross(Vec3::Y))
}
