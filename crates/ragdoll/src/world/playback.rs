//! Playing a character's animation before physics takes over: the
//! bodies follow the clip kinematically until the activation moment, then become dynamic
//! with the clip's velocities, so the hand-over keeps the motion's momentum.

use crate::backend::{BodyId, Command, JointId};
use glam::Vec3;

use crate::math::Transform;
use crate::skeleton::{Clip, Skeleton};

use super::RagdollId;
use crate::backend::Backend;
use crate::error::{Error, Result};

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
    /// Clip time at the world's time 0, seconds: a character can start part-way into its
    /// clip (a crowd walking out of step).
    pub offset_s: f64,
    /// Each body's bone (skeleton joint) and its frame in the bone's frame.
    pub bone_of_body: Vec<usize>,
    pub body_local: Vec<Transform>,
}

impl Playback {
    /// World transforms of every joint at world time `t` (the clip's `t + offset_s`, held
    /// at its last frame after the end), placed and lifted like the ragdoll.
    pub fn joint_world(&self, t: f64, out: &mut Vec<Transform>) {
        let t = t + self.offset_s;
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

impl super::World {
    /// Makes ragdoll `id`'s clip start `seconds` in: at the world's time 0 it is at that
    /// moment of the clip, and the clip's end comes that much sooner (its last frame is held
    /// after it). Applies to the clip played before physics takes over and to the one the
    /// motors follow. Call before [`World::set_activation`](super::World::set_activation), which places a playing ragdoll
    /// on its clip's first moment.
    ///
    /// # Example
    ///
    /// ```no_run
    /// use ragdoll::world::{Activation, World, WorldSettings};
    ///
    /// let character = ragdoll::import::load("walk.bvh".as_ref(), &Default::default())?;
    /// let spec = ragdoll::spec::build_spec(&character, &Default::default())?;
    /// let (mut world, id) = World::with_ragdoll(&character, &spec, &WorldSettings::default())?;
    /// world.set_clip_offset(id, 0.4)?;
    /// world.set_activation(id, Activation::AtTime(1.0))?;
    /// world.run(3.0);
    /// # Ok::<(), ragdoll::error::Error>(())
    /// ```
    pub fn set_clip_offset(&mut self, id: RagdollId, seconds: f32) -> Result<()> {
        let setting = |message: String| Error::Setting {
            setting: "clip_offset_s".into(),
            message,
        };
        if self.frames_recorded > 0 {
            return Err(setting(
                "the clip offset must be set before the world starts stepping".into(),
            ));
        }
        if !(seconds.is_finite() && (0.0..=super::MAX_SECONDS).contains(&seconds)) {
            return Err(setting(format!(
                "the clip offset must be between 0 and {} s, not {seconds}",
                super::MAX_SECONDS
            )));
        }
        let inst = &mut self.instances[id.0];
        if inst.activation != Activation::Immediately {
            return Err(setting(format!(
                "{}'s clip offset must be set before its activation",
                inst.name
            )));
        }
        let Some(play) = &mut inst.playback else {
            return Err(setting(format!("{} has no animation to offset", inst.name)));
        };
        play.offset_s = seconds as f64;
        Ok(())
    }

    /// Makes ragdoll `id` play its first animation clip (kinematically, pushing but not
    /// pushed) until `activation`, then hand over to physics with the clip's velocities.
    /// Must be called before the first step; fails when the character has no clip.
    pub fn set_activation(&mut self, id: RagdollId, activation: Activation) -> Result<()> {
        if self.frames_recorded > 0 {
            return Err(Error::Setting {
                setting: "activate".into(),
                message: "activation must be set before the world starts stepping".into(),
            });
        }
        let inst = &mut self.instances[id.0];
        if let Activation::AtTime(t) = activation
            && !(t.is_finite() && (0.0..=super::MAX_SECONDS).contains(&t))
        {
            return Err(Error::Setting {
                setting: "activate".into(),
                message: format!(
                    "the activation time must be between 0 and {} s, not {t}",
                    super::MAX_SECONDS
                ),
            });
        }
        if activation != Activation::Immediately && inst.playback.is_none() {
            return Err(Error::Setting {
                setting: "activate".into(),
                message: format!(
                    "{} has no animation to play before physics takes over",
                    inst.name
                ),
            });
        }
        // While the clip plays the bodies are kinematic and go through the floor unnoticed;
        // lift the ragdoll so that no body goes below it until the hand-over (the start
        // pose alone may have a foot raised).
        if let (Some(ground), Some(play)) = (self.settings.ground, &mut inst.playback) {
            let until = match activation {
                Activation::AtTime(t) => t as f64,
                _ => play.clip.duration() as f64,
            };
            let frames = ((until / play.clip.frame_time.max(1e-6) as f64).ceil() as usize)
                .min(play.clip.frames.len().saturating_sub(1));
            let mut lowest = f32::INFINITY;
            for f in 0..=frames {
                let t = f as f64 * play.clip.frame_time as f64;
                for (pose, shape) in play.body_poses(t).iter().zip(&inst.shapes) {
                    lowest = lowest.min(shape.lowest_y(pose));
                }
            }
            if lowest < ground {
                let raise = Vec3::new(0.0, ground - lowest, 0.0);
                play.lift += raise;
            }
        }
        // A playing ragdoll starts on its clip's first frame.
        if activation != Activation::Immediately
            && let Some(play) = &inst.playback
        {
            let poses = play.body_poses(0.0).into_iter().enumerate();
            let commands: Vec<Command> = poses
                .map(|(b, pose)| Command::Pose {
                    body: BodyId(inst.first_body + b),
                    pose,
                })
                .collect();
            self.backend.apply(&commands);
        }
        inst.activation = activation;
        inst.active = activation == Activation::Immediately;
        inst.activated_at = inst.active.then_some(0.0);
        let commands: Vec<Command> = (0..inst.shapes.len())
            .map(|b| Command::Kinematic {
                body: BodyId(inst.first_body + b),
                kinematic: !inst.active,
            })
            .collect();
        self.backend.apply(&commands);
        // The poses read before the first step are the clip's.
        self.read_states_of(id.0);
        Ok(())
    }

    /// When physics took over ragdoll `id`, seconds (`None` while its clip still plays).
    pub fn activated_at(&self, id: RagdollId) -> Option<f64> {
        self.instances[id.0].activated_at
    }

    /// Drives the ragdolls still playing their clip over `[t0, t1]`: hands over those whose
    /// moment has come (at `t0`, with the clip's velocities), moves the others along the
    /// clip.
    pub(super) fn play_clips(&mut self, t0: f64, t1: f64, h: f64) {
        // Who touches another ragdoll, asked once for every character waiting for contact.
        let mut touching: Option<Vec<bool>> = None;
        for c in 0..self.instances.len() {
            let inst = &self.instances[c];
            if inst.active {
                continue;
            }
            let Some(play) = &inst.playback else { continue };
            let go = match inst.activation {
                Activation::Immediately => true,
                // The first substep that starts at or after the time (1 µs of slack for
                // the sum of steps).
                Activation::AtTime(t) => t0 + 1e-6 >= t as f64,
                Activation::OnContact => {
                    let touching = touching.get_or_insert_with(|| {
                        let mut flags = Vec::new();
                        self.backend.bodies_touching_other_ragdolls(&mut flags);
                        flags
                    });
                    let mine = inst.first_body..inst.first_body + inst.shapes.len();
                    touching.get(mine).is_some_and(|t| t.iter().any(|&x| x))
                }
                Activation::OnBlast => self.blasts.iter().any(|active| {
                    let det = active.blast.time_s as f64;
                    if t1 <= det {
                        return false;
                    }
                    let ground = self
                        .settings
                        .ground
                        .unwrap_or(active.blast.position.y - super::FREE_AIR_DEPTH_M);
                    inst.shapes.iter().enumerate().any(|(k, shape)| {
                        let state = &self.states[inst.first_body + k];
                        let (at, _, _, _) =
                            super::blast::blast_on_part(&active.blast, state, shape, ground);
                        det + at.arrival_s <= t1
                    })
                }),
            };
            if go {
                self.hand_over(c, t0, h);
            } else {
                let poses = play.body_poses(t1).into_iter().enumerate();
                let commands: Vec<Command> = poses
                    .map(|(k, pose)| Command::KinematicTarget {
                        body: BodyId(inst.first_body + k),
                        pose,
                    })
                    .collect();
                self.backend.apply(&commands);
            }
        }
    }

    /// Ragdoll `c` stops playing its clip at `t` (seconds): its bodies become dynamic with
    /// the clip's velocities (central differences over `h`).
    pub(super) fn hand_over(&mut self, c: usize, t0: f64, h: f64) {
        let Some(play) = &self.instances[c].playback else {
            return;
        };
        let inst = &self.instances[c];
        let poses = play.body_poses(t0);
        let velocities = play.body_velocities(t0, h);
        let mut joints = Vec::new();
        play.joint_world(t0, &mut joints);
        let first = inst.first_body;
        for (k, (pose, (v, w))) in poses.iter().zip(&velocities).enumerate() {
            let body = BodyId(first + k);
            self.backend.apply(&[
                Command::Kinematic {
                    body,
                    kinematic: false,
                },
                Command::Pose { body, pose: *pose },
                Command::Velocity {
                    body,
                    linvel: *v,
                    angvel: *w,
                },
            ]);
            self.states[first + k].pose = *pose;
            self.states[first + k].linvel = *v;
            self.states[first + k].angvel = *w;
        }
        let inst = &mut self.instances[c];
        for (j, r) in inst.riders.iter_mut().enumerate() {
            r.offset = poses[r.body].inverse().mul(&joints[j]);
        }
        // Parts that overlap in the pose at the switch (a hand against the chest)
        // would be thrown apart by their contact: they stop colliding instead.
        self.stop_overlapping_pairs(c, &poses);
        let inst = &mut self.instances[c];
        // Bones without bodies (a collar) may have turned since the start: each
        // joint's parent-side anchor moves to where its child's joint is now.
        // A hinge the pose has rolled off its axis takes the pose's axis, and limits
        // give way to a pose the performer held, rather than the solver snapping
        // the body at the switch.
        for (k, j) in inst.joints.iter_mut().enumerate() {
            let (parent, child) = (&poses[j.parent], &poses[j.child]);
            let anchor = child.transform_point(j.frame_child.translation);
            j.frame_parent.translation = parent.inverse().transform_point(anchor);
            j.align_hinge_to(parent, child);
            self.backend.apply(&[Command::JointParentFrame {
                joint: JointId(inst.first_joint + k),
                frame: j.frame_parent,
            }]);
            if j.widen_to_include(parent, child, super::HANDOVER_LIMIT_MARGIN_DEG) {
                self.backend.apply(&[Command::JointLimits {
                    joint: JointId(inst.first_joint + k),
                    kind: j.kind,
                }]);
            }
        }
        inst.active = true;
        inst.activated_at = Some(t0);
    }
}

impl super::World {
    /// Stops every pair of ragdoll `c`'s bodies that overlap in `poses` (its body poses)
    /// from colliding: the performer's body went there, so our capsules, cruder than a
    /// body, are what is wrong, and a contact would throw the parts apart.
    pub(super) fn stop_overlapping_pairs(&mut self, c: usize, poses: &[Transform]) {
        let inst = &self.instances[c];
        let boxes: Vec<_> = poses
            .iter()
            .zip(&inst.shapes)
            .map(|(p, s)| crate::geometry::loose_bounds(p, s))
            .collect();
        let mut pairs = Vec::new();
        crate::geometry::broad::BroadPhase::default().find(&boxes, |a, b| {
            let (pa, pb) = (&poses[a], &poses[b]);
            if crate::spec::shapes_overlap(pa, &inst.shapes[a], pb, &inst.shapes[b], 0.0) {
                pairs.push((a, b));
            }
        });
        pairs.sort_unstable();
        for &(a, b) in &pairs {
            self.backend.apply(&[Command::DisablePair(
                BodyId(inst.first_body + a),
                BodyId(inst.first_body + b),
            )]);
        }
        let exempt = &mut self.instances[c].exempt_pairs;
        exempt.extend(pairs.iter().map(|&(a, b)| (a.min(b), a.max(b))));
        exempt.sort_unstable();
        exempt.dedup();
    }
}
