//! Playing a character's animation before physics takes over (DESIGN §4, Activation): the
//! bodies follow the clip kinematically until the activation moment, then become dynamic
//! with the clip's velocities, so the hand-over keeps the motion's momentum.

use glam::Vec3;

use crate::math::Transform;
use crate::skeleton::{Clip, Skeleton};

/// When a ragdoll stops playing its animation and becomes physical.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Activation {
    /// Physical from the start (the default).
    #[default]
    Immediately,
    /// Plays its first clip until this time, seconds.
    AtTime(f32),
    /// Plays its first clip until the first blast front reaches its nearest body part.
    OnBlast,
    /// Plays its first clip until one of its parts touches something other than the ground
    /// and itself (another character, a falling body) or a projectile hits it.
    OnContact,
}

/// What a ragdoll needs to play its clip and hand over.
#[derive(Clone, Debug)]
pub(crate) struct Playback {
    pub skeleton: Skeleton,
    pub clip: Clip,
    /// Applied to the clip's world poses: the ragdoll's placement, then the lift onto the
    /// ground.
    pub placement: Transform,
    pub lift: Vec3,
    /// Each body's bone (skeleton joint) and its frame in the bone's frame.
    pub bone_of_body: Vec<usize>,
    pub body_local: Vec<Transform>,
}

impl Playback {
    /// World transforms of every joint at `t` seconds of the clip (held at its last frame
    /// after the end), placed and lifted like the ragdoll.
    pub fn joint_world(&self, t: f64, out: &mut Vec<Transform>) {
        let n = self.skeleton.len();
        let frames = &self.clip.frames;
        let last = frames.len().saturating_sub(1);
        let f = if self.clip.frame_time > 0.0 {
            (t / self.clip.frame_time as f64).max(0.0)
        } else {
            0.0
        };
        let i = (f.floor() as usize).min(last);
        let j = (i + 1).min(last);
        let a = (f - i as f64).clamp(0.0, 1.0) as f32;
        let locals: Vec<Transform> = (0..n)
            .map(|k| {
                let (p, q) = (&frames[i][k], &frames[j][k]);
                Transform {
                    translation: p.translation.lerp(q.translation, a),
                    rotation: p.rotation.slerp(q.rotation, a),
                    scale: p.scale.lerp(q.scale, a),
                }
            })
            .collect();
        out.resize(n, Transform::IDENTITY);
        self.skeleton.world_from_local(&locals, out);
        for t in out.iter_mut() {
            *t = self.placement.mul(t);
            t.translation += self.lift;
        }
    }

    /// World poses of the bodies at clip time `t`.
    pub fn body_poses(&self, t: f64) -> Vec<Transform> {
        let mut joints = Vec::new();
        self.joint_world(t, &mut joints);
        self.bone_of_body
            .iter()
            .zip(&self.body_local)
            .map(|(&j, local)| Transform::new(joints[j].translation, joints[j].rotation).mul(local))
            .collect()
    }

    /// Linear and angular velocity of every body at clip time `t`: central differences of
    /// the poses over `h` seconds either side.
    pub fn body_velocities(&self, t: f64, h: f64) -> Vec<(Vec3, Vec3)> {
        let before = self.body_poses((t - h).max(0.0));
        let after = self.body_poses(t + h);
        let span = (t + h) - (t - h).max(0.0);
        before
            .iter()
            .zip(&after)
            .map(|(a, b)| {
                let v = (b.translation - a.translation) / span as f32;
                let mut dq = b.rotation * a.rotation.conjugate();
                if dq.w < 0.0 {
                    dq = -dq;
                }
                let (axis, angle) = dq.to_axis_angle();
                let w = if angle.is_finite() && axis.is_finite() {
                    axis * (angle / span as f32)
                } else {
                    Vec3::ZERO
                };
                (v, w)
            })
            .collect()
    }
}
