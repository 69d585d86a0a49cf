//! Powered mode: joint motors make a physical ragdoll track its
//! animation clip, with a strength keyed over time; a strength fading to 0 leaves it limp.
//!
//! Each joint gets a drive from the engine ([`Backend::drive_joint`]): a damped spring
//! toward the relative rotation and angular velocity the clip has at that moment. `rigid`
//! and `fast` solve it together with the joints and contacts, so a shoulder drive knows it
//! carries the whole arm; `particle` applies it as a softer torque equal and opposite on
//! the child and the parent ([`crate::backend::drive`]). The world only says where each
//! joint should be.
//!
//! When the motors take hold, the ragdoll is fitted to the clip it must follow: limits
//! widen to take in every clip pose, each hinge turns to the axis the clip's own elbow or
//! knee bends about, and parts the clip passes through each other stop colliding.

use crate::backend::{BodyId, Command, JointId};
use glam::{Quat, Vec3};

use super::{HANDOVER_LIMIT_MARGIN_DEG, Instance, World, setting_error};
use crate::backend::Backend;
use crate::error::Result;
use crate::math::Transform;
use crate::spec::JointKind;

/// Natural frequency of the motors' spring at strength 1, Hz.
///
/// Measured on the mocap files with the root on the clip (crates/ragdoll/tests/motors.rs):
/// with the drives in the solver, 60 Hz left a pirouette's arms 10-20° behind at times,
/// 90 Hz 5.1°, 120 Hz 4.5°; with the solver substeps below ω·h ≈ 0.2, far from unstable.
const MOTOR_FREQUENCY_HZ: f32 = 120.0;

/// Solver substeps once a ragdoll is powered (a limp one needs 4).
///
/// Measured on the mocap files with the root on the clip: 4 substeps with 15 Hz drives
/// left the arms 30-70° behind a pirouette, and a stiffer drive came apart; 16 substeps let
/// the drives run at the frequency below and track within a few degrees.
const POWERED_SOLVER_SUBSTEPS: usize = 16;

/// Damping ratio of the motors: critical, so a joint settles on its target without
/// overshooting it.
const MOTOR_DAMPING_RATIO: f32 = 1.0;

/// Joint motors that make a physical ragdoll track its animation clip ("powered mode").
///
/// The clip is the character's first one, on the world's clock (held at its last frame
/// after it ends), as for [`super::Activation`]. Motors act only while the ragdoll is
/// physical: with an activation time the clip plays kinematically first, then the motors
/// take over from the hand-over on.
#[derive(Clone, Debug, PartialEq)]
pub struct Motors {
    /// `(time s, strength 0..1)` keys, in time order, interpolated linearly and held
    /// before the first and after the last. Strength scales the motors' torque: 1 tracks
    /// the clip closely, 0 is a limp ragdoll.
    pub strength_keys: Vec<(f32, f32)>,
    /// Whether the root body (the one no joint hangs from, the pelvis) follows the clip
    /// kinematically, so the motors only have to hold the rest of the body on it (a
    /// character standing on its animation); otherwise the whole ragdoll is free and the
    /// motors alone keep it in pose, which cannot keep it balanced for long.
    pub root_on_clip: bool,
}

impl Motors {
    /// Motors at a constant strength.
    pub fn constant(strength: f32) -> Self {
        Motors {
            strength_keys: vec![(0.0, strength)],
            root_on_clip: false,
        }
    }

    /// Motors at `strength` until `start_s`, fading linearly to 0 at `end_s` (a ragdoll
    /// that goes limp).
    pub fn fade_out(strength: f32, start_s: f32, end_s: f32) -> Self {
        Motors {
            strength_keys: vec![(start_s, strength), (end_s, 0.0)],
            root_on_clip: false,
        }
    }

    /// Checks the keys: at least one and at most [`crate::events::MAX_KEYS`], times within
    /// a run ([`super::MAX_SECONDS`]) and in order, strengths within 0..1.
    pub fn validate(&self) -> Result<()> {
        let check = crate::events::check_keys(&self.strength_keys, |s| {
            crate::spec::check_within(s, 0.0, 1.0, "").map_err(|m| format!("strength {m}"))
        });
        check.map_err(|m| setting_error("powered", &m))
    }

    /// The strength at `t` seconds.
    pub fn strength_at(&self, t: f32) -> f32 {
        let keys: Vec<(f32, Vec3)> = self
            .strength_keys
            .iter()
            .map(|&(k, s)| (k, Vec3::splat(s)))
            .collect();
        super::forces::sample_keys(&keys, t).x
    }
}

/// Motors on one ragdoll, and whether they have taken hold yet.
#[derive(Clone, Debug)]
pub(crate) struct MotorState {
    pub motors: Motors,
    /// Set the first substep the ragdoll is physical (limits widened, root made kinematic).
    pub engaged: bool,
    /// The root body (no joint has it as child), within the ragdoll.
    pub root: usize,
}

impl World {
    /// Powers ragdoll `id`'s joints so that it tracks its first animation clip (see
    /// [`Motors`]). Must be called before the first step; fails when the character has no
    /// clip or the keys are invalid.
    pub fn set_motors(&mut self, id: super::RagdollId, motors: Motors) -> Result<()> {
        motors.validate()?;
        if self.frames_recorded > 0 {
            return Err(setting_error(
                "powered",
                "motors must be set before the world starts stepping",
            ));
        }
        let inst = &mut self.instances[id.0];
        if inst.playback.is_none() {
            return Err(setting_error(
                "powered",
                &format!("{} has no animation for the motors to track", inst.name),
            ));
        }
        let root = (0..inst.shapes.len())
            .find(|&b| inst.joints.iter().all(|j| j.child != b))
            .unwrap_or(0);
        inst.motors = Some(MotorState {
            motors,
            engaged: false,
            root,
        });
        // Its motors damp it: the passive damping is for limp ragdolls.
        if self.settings.joint_damping > 0.0 {
            self.backend.apply(&[Command::JointDamping {
                first_body: BodyId(inst.first_body),
                rate_per_s: 0.0,
            }]);
        }
        Ok(())
    }

    /// The first substep a powered ragdoll is physical: its limits widen to take in every
    /// clip pose from now on, and its root goes kinematic when it stays on the clip.
    ///
    /// The limits were fitted to the starting pose only; a motor pulling toward a pose
    /// outside them would fight both rapier's limits and its position projection
    /// ([`crate::backend::RigidConfig::project_limits`]) every step. The performer held those
    /// poses, so the limits give way to them, as they do at a hand-over.
    fn engage_motors(&mut self, c: usize, t0: f64) {
        let inst = &mut self.instances[c];
        let (Some(state), Some(play)) = (&mut inst.motors, &inst.playback) else {
            return;
        };
        state.engaged = true;
        let held_root = state
            .motors
            .root_on_clip
            .then_some(inst.first_body + state.root);
        let frame_time = play.clip.frame_time.max(1e-6) as f64;
        let first = (t0 / frame_time).floor() as usize;
        let clip_poses: Vec<Vec<Transform>> = (first..play.clip.frames.len())
            .map(|f| play.body_poses(f as f64 * frame_time))
            .collect();
        for (k, j) in inst.joints.iter_mut().enumerate() {
            let pairs: Vec<(Transform, Transform)> = clip_poses
                .iter()
                .map(|p| (p[j.parent], p[j.child]))
                .collect();
            if j.fit_hinge_to(&pairs).is_some() {
                let joint = JointId(inst.first_joint + k);
                self.backend.apply(&[
                    Command::JointParentFrame {
                        joint,
                        frame: j.frame_parent,
                    },
                    Command::JointChildFrame {
                        joint,
                        frame: j.frame_child,
                    },
                ]);
            }
            let mut widened = false;
            for (parent, child) in &pairs {
                widened |= j.widen_to_include(parent, child, HANDOVER_LIMIT_MARGIN_DEG);
            }
            if widened {
                self.backend.apply(&[Command::JointLimits {
                    joint: JointId(inst.first_joint + k),
                    kind: j.kind,
                }]);
            }
        }
        let substeps = match self.settings.backend {
            super::BackendConfig::Rigid(c) => c.substeps,
            _ => 1,
        };
        self.backend.apply(&[Command::SolverSubsteps(
            POWERED_SOLVER_SUBSTEPS.max(substeps),
        )]);
        if let Some(root) = held_root {
            self.backend.apply(&[Command::Kinematic {
                body: BodyId(root),
                kinematic: true,
            }]);
        }
        for poses in &clip_poses {
            self.stop_overlapping_pairs(c, poses);
        }
    }

    /// Applies every powered ragdoll's motor torques over the substep `[t0, t0 + h]`, and
    /// moves roots kept on the clip.
    pub(super) fn apply_motors(&mut self, t0: f64, h: f32) {
        for c in 0..self.instances.len() {
            let inst = &self.instances[c];
            if !inst.active || inst.playback.is_none() {
                continue;
            }
            match &inst.motors {
                None => continue,
                Some(state) if !state.engaged => self.engage_motors(c, t0),
                Some(_) => {}
            }
            self.drive_toward_clip(c, t0, h);
        }
    }

    /// Ragdoll `c`'s motors over the substep: toward the clip's relative turns and
    /// velocities at its end, as drives inside the backend's solver where it has them,
    /// else as torque impulses between each joint's two bodies.
    fn drive_toward_clip(&mut self, c: usize, t0: f64, h: f32) {
        let inst = &self.instances[c];
        let (Some(state), Some(play)) = (&inst.motors, &inst.playback) else {
            return;
        };
        let t1 = t0 + h as f64;
        let targets = play.body_poses(t1);
        if state.motors.root_on_clip {
            self.backend.apply(&[Command::KinematicTarget {
                body: BodyId(inst.first_body + state.root),
                pose: targets[state.root],
            }]);
        }
        let s = state.motors.strength_at((t0 + 0.5 * h as f64) as f32);
        // The clip's angular velocities: the motors damp toward the clip's motion
        // rather than toward rest, so a fast joint does not lag behind its target.
        let clip_velocities = if s > 0.0 {
            play.body_velocities(t1, h as f64)
        } else {
            Vec::new()
        };
        let aim = Aim {
            targets: &targets,
            velocities: &clip_velocities,
            strength: s,
        };
        drive_joints(&mut self.backend, inst, &aim);
    }
}

/// Where a powered ragdoll's motors aim in a substep: each body's pose at its end on the
/// clip and the clip's velocities there, and the motors' strength (0 to 1).
struct Aim<'a> {
    targets: &'a [Transform],
    velocities: &'a [(Vec3, Vec3)],
    strength: f32,
}

/// Strength under which the motors are off, as at 0.
///
/// rapier's acceleration-based motor divides by its gains (its constraint's softness is
/// `1 / (h (h k_p + k_d))`): a strength of 1e-30 overflowed it, and the drive meant to be
/// slack tore the built-in humanoid's joints 10 mm apart and let them open 145° past their
/// limits, where 0 leaves 0.06 mm. A millionth of full strength pulls with 0.57 rad/s² per
/// radian off the clip: on a forearm (about 0.015 kg·m²) 0.01 N·m per radian, a hundredth
/// of what gravity puts on it. Nothing a user would see.
const MIN_MOTOR_STRENGTH: f32 = 1e-6;

/// Spring and damper gains of a motor of `strength` at `frequency_hz`, critically damped
/// as [`MOTOR_DAMPING_RATIO`] says; none below [`MIN_MOTOR_STRENGTH`].
fn gains(strength: f32, frequency_hz: f32) -> (f32, f32) {
    if strength < MIN_MOTOR_STRENGTH {
        return (0.0, 0.0);
    }
    let omega = std::f32::consts::TAU * frequency_hz;
    (
        strength * omega * omega,
        strength * 2.0 * MOTOR_DAMPING_RATIO * omega,
    )
}

/// Drives every joint of `inst` toward the clip, with the engine's drives.
fn drive_joints(backend: &mut impl Backend, inst: &Instance, aim: &Aim) {
    let (kp, kd) = gains(aim.strength, MOTOR_FREQUENCY_HZ);
    for (k, j) in inst.joints.iter().enumerate() {
        if matches!(j.kind, JointKind::Fixed) {
            continue;
        }
        let (pt, ct) = (&aim.targets[j.parent], &aim.targets[j.child]);
        let (target, target_vel) = if aim.strength > 0.0 {
            (
                pt.rotation.conjugate() * ct.rotation,
                pt.rotation.conjugate() * (aim.velocities[j.child].1 - aim.velocities[j.parent].1),
            )
        } else {
            (Quat::IDENTITY, Vec3::ZERO)
        };
        backend.drive_joint(JointId(inst.first_joint + k), target, target_vel, kp, kd);
    }
}
