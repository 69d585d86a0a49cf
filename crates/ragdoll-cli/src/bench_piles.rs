//! The pile workload's layout and what is read from it after the timing: where each
//! ragdoll of a pile starts, which thread's world holds which piles, the pose motors hold,
//! and when a run came to rest.

use glam::{Quat, Vec3};
use ragdoll::math::Transform;
use ragdoll::skeleton;

/// Ragdolls stacked in one pile, unless `--pile-height` says otherwise.
pub(crate) const PILE_HEIGHT: usize = 4;
/// Most ragdolls `--pile-height` stacks: 64 levels start 38 m up.
pub(crate) const MAX_PILE_HEIGHT: usize = 64;
/// Below this speed a body counts as at rest, m/s, for the time a run takes to come to
/// rest.
const REST_MPS: f32 = 0.1;
/// Distance between pile centres, metres: far enough that piles never touch.
const PILE_SPACING_M: f32 = 4.0;
/// Extra drop height per level of a pile, metres.
const LEVEL_HEIGHT_M: f32 = 0.6;

/// What a pile run builds: how the ragdolls are stacked and whether motors hold a pose.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Piles {
    pub height: usize,
    pub motors: Option<f32>,
}

impl Piles {
    /// Where ragdoll `k` of `n` starts: pile `k / height` on a square grid, one level up
    /// per ragdoll in the pile, each level turned a further 70° so limbs cross.
    pub(crate) fn placement(&self, k: usize, n: usize) -> Transform {
        let piles = n.div_ceil(self.height);
        let side = (piles as f64).sqrt().ceil() as usize;
        let pile = k / self.height;
        let level = k % self.height;
        let x = (pile % side) as f32 * PILE_SPACING_M;
        let z = (pile / side) as f32 * PILE_SPACING_M;
        // Lie the humanoid down (its head toward +X) so a pile forms instead of a row of falls.
        let lie = Quat::from_rotation_z(-std::f32::consts::FRAC_PI_2);
        let yaw = Quat::from_rotation_y((70.0 * level as f32).to_radians());
        Transform::new(
            Vec3::new(x, 0.3 + LEVEL_HEIGHT_M * level as f32, z),
            yaw * lie,
        )
    }

    /// The ragdolls (indices into the `n` placements) each of `threads` worlds holds:
    /// whole piles, as evenly as they divide.
    pub(crate) fn world_shares(&self, n: usize, threads: usize) -> Vec<std::ops::Range<usize>> {
        let piles = n.div_ceil(self.height);
        let per_world = piles.div_ceil(threads.clamp(1, piles.max(1))) * self.height;
        (0..n)
            .step_by(per_world.max(1))
            .map(|k| k..(k + per_world).min(n))
            .collect()
    }
}

impl Default for Piles {
    fn default() -> Self {
        Piles {
            height: PILE_HEIGHT,
            motors: None,
        }
    }
}

/// The time from which every joint of `track` moves slower than [`REST_MPS`] to its end,
/// seconds; `None` when it still moves in its last frame.
pub(crate) fn rest_after_s(track: &ragdoll::track::Track) -> Option<f32> {
    let dt = track.frame_time();
    let moving = |f: usize| {
        track.frames[f]
            .iter()
            .zip(&track.frames[f - 1])
            .any(|(a, b)| a.translation.distance(b.translation) > REST_MPS * dt)
    };
    let last = track.frames.len().checked_sub(1)?;
    match (1..=last).rev().find(|&f| moving(f)) {
        Some(f) if f == last => None,
        Some(f) => Some(f as f32 / track.fps),
        None => Some(0.0),
    }
}

/// The character with a clip of one pose, its rest pose, for motors to hold (`pose`
/// false: as it is).
pub(crate) fn posed(mut character: skeleton::Character, pose: bool) -> skeleton::Character {
    if pose {
        let rest: Vec<Transform> = character.skeleton.joints().iter().map(|j| j.rest).collect();
        character.clips = vec![skeleton::Clip {
            name: "pose".into(),
            frame_time: 1.0,
            frames: vec![rest.clone(), rest],
        }];
    }
    character
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A joint that moves `step` metres between frames at 30 fps.
    fn track(steps: &[f32]) -> ragdoll::track::Track {
        let mut x = 0.0;
        let mut frames = vec![vec![Transform::IDENTITY]];
        for d in steps {
            x += d;
            frames.push(vec![Transform::new(Vec3::new(x, 0.0, 0.0), Quat::IDENTITY)]);
        }
        ragdoll::track::Track { fps: 30.0, frames }
    }

    #[test]
    fn rest_is_from_the_last_frame_that_moves_faster_than_the_threshold() {
        // 0.1 m/s is 3.3 mm a frame at 30 fps.
        let t = track(&[0.1, 0.05, 0.01, 0.002, 0.0, 0.0]);
        assert_eq!(rest_after_s(&t), Some(3.0 / 30.0));
        assert_eq!(rest_after_s(&track(&[0.0, 0.0])), Some(0.0));
        assert_eq!(rest_after_s(&track(&[0.0, 0.01])), None);
        // A body that stops and moves again is at rest only after its last motion.
        assert_eq!(
            rest_after_s(&track(&[0.01, 0.0, 0.01, 0.0])),
            Some(3.0 / 30.0)
        );
    }
}
