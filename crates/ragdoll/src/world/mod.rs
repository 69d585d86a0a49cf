//! The runtime half: a [`World`] owns ragdoll instances made from
//! [`RagdollSpec`]s, the ground and a backend; it steps at a fixed rate and
//! records a [`Track`] per ragdoll plus the quality [`Metrics`].

use glam::Vec3;

mod blast;
mod forces;
mod motors;
mod playback;

pub use motors::Motors;
pub use playback::Activation;

use crate::backend::rigid::{RigidBackend, RigidSettings};
use crate::backend::{Backend, BodyDesc, BodyState, JointDesc};
use crate::error::{Error, Result};
use crate::events::{Blast, BlastReport, Projectile, ProjectileReport};
use crate::math::Transform;
use crate::skeleton::Character;
use crate::spec::{RagdollSpec, Resolved, ResolvedJoint, Shape, start_pose};
use crate::track::{Metrics, Track};

/// Standard gravity, m/s².
pub const STANDARD_GRAVITY: f32 = 9.80665;

/// Violations smaller than this are left to rapier's own (velocity-level) limits, degrees.
/// Projecting every tiny excess made limbs resting against a limit creep (about 1 cm/s):
/// each step the solver let them sink a little and the projection turned them back about
/// the anchor, a ratchet against the floor's friction.
const PROJECTION_TOLERANCE_DEG: f32 = 1.0;

/// How far inside widened limits the pose at a hand-over ends up, degrees.
const HANDOVER_LIMIT_MARGIN_DEG: f32 = 5.0;

/// How far below the ground the limit projection may move a body that was above it, metres.
const PROJECTION_GROUND_SLACK_M: f32 = 0.005;

/// With no ground, blasts are computed as if the ground were this far below the charge,
/// metres: far enough that any charge counts as a free-air burst.
const FREE_AIR_DEPTH_M: f32 = 1.0e4;

/// Which pose a ragdoll starts in.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum StartPose {
    /// The first frame of the character's first clip, or the rest pose when it has none.
    #[default]
    FirstFrame,
    /// The rest (bind) pose.
    Rest,
}

/// How a world steps and what surrounds the ragdolls.
#[derive(Clone, Debug, PartialEq)]
pub struct WorldSettings {
    /// Fixed step, seconds (default 1/60): events and the metrics run at this rate.
    pub dt: f32,
    /// Physics steps per step, each with its own collision detection (default 4, so
    /// contacts are found at 240 Hz: a body falling at 5 m/s moves 2 cm between two
    /// detections instead of 8 cm, which is what kept penetrations under a centimetre or
    /// so in our runs).
    pub collision_substeps: usize,
    /// Solver substeps per physics step (default 4).
    pub substeps: usize,
    /// Constraint iterations per solver substep (default 2): joints and contacts of a
    /// 16-body chain converge better with two.
    pub iterations: usize,
    /// Output frames per second of the tracks (default 30).
    pub fps: f32,
    /// Gravity, m/s² (default −9.80665 along Y).
    pub gravity: Vec3,
    /// Height of the ground plane (default `Some(0.0)`: the file's floor); `None` for none.
    pub ground: Option<f32>,
    /// Starting pose (default: the first clip frame).
    pub start: StartPose,
    /// Whether joint limits are also enforced on positions after every step (default true).
    ///
    /// rapier enforces limits on velocities; a hard impact (a torso landing on an arm) can
    /// still push a joint tens of degrees past its limit for a few frames. The projection
    /// clamps each joint's swing and twist back into range, turning the child's whole
    /// subtree about the joint anchor, parents first, as position-based solvers do.
    pub project_limits: bool,
}

impl Default for WorldSettings {
    fn default() -> Self {
        WorldSettings {
            dt: 1.0 / 60.0,
            collision_substeps: 4,
            substeps: 4,
            iterations: 2,
            fps: 30.0,
            gravity: Vec3::new(0.0, -STANDARD_GRAVITY, 0.0),
            ground: Some(0.0),
            start: StartPose::FirstFrame,
            project_limits: true,
        }
    }
}

impl WorldSettings {
    /// Checks the settings a user can set.
    pub fn validate(&self) -> Result<()> {
        let bad = |setting: &str, message: &str| {
            Err(Error::Setting {
                setting: setting.into(),
                message: message.into(),
            })
        };
        if !(self.dt.is_finite() && self.dt > 0.0 && self.dt <= 0.1) {
            return bad("dt", "the step must be between 0 and 0.1 s");
        }
        if !(self.fps.is_finite() && self.fps >= 1.0 && self.fps <= 1000.0) {
            return bad("fps", "frames per second must be between 1 and 1000");
        }
        for (name, v) in [
            ("collision_substeps", self.collision_substeps),
            ("substeps", self.substeps),
            ("iterations", self.iterations),
        ] {
            if v == 0 || v > 100 {
                return bad(name, "must be between 1 and 100");
            }
        }
        if !self.gravity.is_finite() {
            return bad("gravity", "gravity must be finite");
        }
        Ok(())
    }
}

/// Handle of a ragdoll inside a [`World`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct RagdollId(usize);

/// A skeleton joint follows a body with a fixed offset.
#[derive(Clone, Copy, Debug)]
struct Rider {
    body: usize,
    offset: Transform,
}

struct Instance {
    /// Labels of the skeleton's joints (names, or `joint<i>`).
    joint_labels: Vec<String>,
    /// Global index of the ragdoll's first joint in the backend.
    first_joint: usize,
    name: String,
    body_names: Vec<String>,
    first_body: usize,
    /// Joint indices ordered parents first.
    joint_order: Vec<usize>,
    /// For each joint, the bodies its child carries (the child and its descendants).
    subtrees: Vec<Vec<usize>>,
    /// Each body's shape.
    shapes: Vec<Shape>,
    masses: Vec<f32>,
    joints: Vec<ResolvedJoint>,
    riders: Vec<Rider>,
    track: Track,
    /// The clip and what is needed to play it (when the character has one).
    playback: Option<playback::Playback>,
    activation: Activation,
    /// Whether physics drives the bodies (false while the clip plays).
    active: bool,
    /// When physics took over, seconds.
    activated_at: Option<f64>,
    /// Joint motors tracking the clip (powered mode), if any.
    motors: Option<motors::MotorState>,
}

/// A simulated world: ragdolls, ground, gravity, a backend, and the tracks being recorded.
pub struct World {
    settings: WorldSettings,
    backend: RigidBackend,
    instances: Vec<Instance>,
    time: f64,
    frames_recorded: usize,
    states: Vec<BodyState>,
    prev_states: Vec<BodyState>,
    metrics: Metrics,
    start_energy: Option<f64>,
    last_frame_energy: Option<f64>,
    blasts: Vec<blast::ActiveBlast>,
    projectiles: Vec<(Projectile, Option<ProjectileReport>)>,
    pushes: Vec<forces::ActivePush>,
    fields: Vec<crate::events::Field>,
    pins: Vec<forces::ActivePin>,
}

impl World {
    /// An empty world.
    pub fn new(settings: &WorldSettings) -> Result<Self> {
        settings.validate()?;
        let backend = RigidBackend::new(
            RigidSettings {
                gravity: settings.gravity,
                ground: settings.ground,
                substeps: settings.substeps,
                iterations: settings.iterations,
            },
            settings.dt,
        );
        Ok(World {
            settings: settings.clone(),
            backend,
            instances: Vec::new(),
            time: 0.0,
            frames_recorded: 0,
            states: Vec::new(),
            prev_states: Vec::new(),
            metrics: Metrics::default(),
            start_energy: None,
            last_frame_energy: None,
            blasts: Vec::new(),
            projectiles: Vec::new(),
            pushes: Vec::new(),
            fields: Vec::new(),
            pins: Vec::new(),
        })
    }

    /// A world with one ragdoll: the common case.
    pub fn with_ragdoll(
        character: &Character,
        spec: &RagdollSpec,
        settings: &WorldSettings,
    ) -> Result<(Self, RagdollId)> {
        let mut world = World::new(settings)?;
        let id = world.add_ragdoll(character, spec, Transform::IDENTITY)?;
        Ok((world, id))
    }

    /// Adds a ragdoll built from `spec`, placed by `placement` (a rigid transform applied
    /// to the whole character), lifted so that no body starts below the ground.
    ///
    /// Must be called before the first step.
    pub fn add_ragdoll(
        &mut self,
        character: &Character,
        spec: &RagdollSpec,
        placement: Transform,
    ) -> Result<RagdollId> {
        spec.validate()?;
        if self.frames_recorded > 0 {
            return Err(Error::Setting {
                setting: "ragdoll".into(),
                message: "ragdolls must be added before the world starts stepping".into(),
            });
        }
        let skeleton = &character.skeleton;
        // 1. Bodies and joint frames from the rest pose; the start pose from the clip.
        let mut resolved = Resolved::new(spec, character)?;
        let mut start = start_pose(character, self.settings.start == StartPose::FirstFrame);
        for t in &mut start {
            *t = placement.mul(t);
        }
        resolved.anchor_at_pose(&start);
        let mut body_start = resolved.body_poses(&start);
        let bone_of_body = &resolved.bone_of_body;
        // 2. Lift onto the ground where any body would start below it.
        let mut lift = Vec3::ZERO;
        if let Some(ground) = self.settings.ground {
            let lowest = body_start
                .iter()
                .zip(&spec.bodies)
                .map(|(p, b)| lowest_point(p, &b.shape))
                .fold(f32::INFINITY, f32::min);
            if lowest < ground {
                lift = Vec3::new(0.0, ground - lowest, 0.0);
                for p in &mut body_start {
                    p.translation += lift;
                }
                for t in &mut start {
                    t.translation += lift;
                }
            }
        }
        let joint_descs: Vec<JointDesc> = resolved
            .joints
            .iter()
            .map(|j| JointDesc {
                parent: j.parent,
                child: j.child,
                frame_parent: j.frame_parent,
                frame_child: j.frame_child,
                kind: j.kind,
            })
            .collect();
        let disabled: Vec<(usize, usize)> = spec
            .collision
            .disabled_pairs
            .iter()
            .filter_map(|[a, b]| Some((spec.body_index(a)?, spec.body_index(b)?)))
            .collect();
        // 3. Skeleton joints ride on their own or their nearest ancestor's body, with the
        //    offset they have at the start (so the hand-over pose is kept exactly).
        let root_body = (0..spec.bodies.len())
            .min_by_key(|&i| bone_of_body[i])
            .expect("a spec has bodies");
        let riders: Vec<Rider> = start
            .iter()
            .enumerate()
            .map(|(j, joint_start)| {
                let mut k = Some(j);
                let body = loop {
                    match k {
                        Some(k2) => {
                            if let Some(b) = bone_of_body.iter().position(|&bj| bj == k2) {
                                break b;
                            }
                            k = skeleton.parent(k2);
                        }
                        None => break root_body,
                    }
                };
                Rider {
                    body,
                    offset: body_start[body].inverse().mul(joint_start),
                }
            })
            .collect();
        let bodies: Vec<BodyDesc> = spec
            .bodies
            .iter()
            .zip(&body_start)
            .map(|(b, p)| BodyDesc {
                pose: *p,
                shape: b.shape,
                mass: b.mass_kg,
                linvel: Vec3::ZERO,
                angvel: Vec3::ZERO,
            })
            .collect();
        let first_body = self.backend.add_ragdoll(&bodies, &joint_descs, &disabled);
        let joints = resolved.joints;
        let (joint_order, subtrees) = joint_tree(&joints, spec.bodies.len());
        let playback = character
            .clips
            .first()
            .filter(|c| !c.frames.is_empty() && c.frames.iter().all(|f| f.len() == skeleton.len()))
            .map(|clip| playback::Playback {
                skeleton: skeleton.clone(),
                clip: clip.clone(),
                placement,
                lift,
                bone_of_body: resolved.bone_of_body.clone(),
                body_local: resolved.body_local.clone(),
            });
        let first_joint = self.instances.iter().map(|i| i.joints.len()).sum();
        self.instances.push(Instance {
            joint_labels: (0..skeleton.len())
                .map(|i| skeleton.joint_label(i))
                .collect(),
            first_joint,
            playback,
            activation: Activation::Immediately,
            active: true,
            activated_at: Some(0.0),
            motors: None,
            name: character.name.clone(),
            body_names: spec.bodies.iter().map(|b| b.name.clone()).collect(),
            first_body,
            joint_order,
            subtrees,
            shapes: spec.bodies.iter().map(|b| b.shape).collect(),
            masses: spec.bodies.iter().map(|b| b.mass_kg).collect(),
            joints,
            riders,
            track: Track {
                fps: self.settings.fps,
                frames: Vec::new(),
            },
        });
        Ok(RagdollId(self.instances.len() - 1))
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
            && !(t.is_finite() && t >= 0.0)
        {
            return Err(Error::Setting {
                setting: "activate".into(),
                message: "the activation time must be zero or positive seconds".into(),
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
                    lowest = lowest.min(lowest_point(pose, shape));
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
            for (b, pose) in play.body_poses(0.0).iter().enumerate() {
                self.backend.set_body_pose(inst.first_body + b, pose);
            }
        }
        inst.activation = activation;
        inst.active = activation == Activation::Immediately;
        inst.activated_at = inst.active.then_some(0.0);
        for b in 0..inst.shapes.len() {
            self.backend
                .set_kinematic(inst.first_body + b, !inst.active);
        }
        Ok(())
    }

    /// When physics took over ragdoll `id`, seconds (`None` while its clip still plays).
    pub fn activated_at(&self, id: RagdollId) -> Option<f64> {
        self.instances[id.0].activated_at
    }

    /// Linear (m/s) and angular (rad/s) velocities of ragdoll `id`'s bodies now, spec order.
    pub fn body_velocities(&self, id: RagdollId) -> Vec<(Vec3, Vec3)> {
        let inst = &self.instances[id.0];
        self.states[inst.first_body..inst.first_body + inst.masses.len()]
            .iter()
            .map(|s| (s.linvel, s.angvel))
            .collect()
    }

    /// Drives the ragdolls still playing their clip over `[t0, t1]`: hands over those whose
    /// moment has come (at `t0`, with the clip's velocities), moves the others along the
    /// clip.
    fn play_clips(&mut self, t0: f64, t1: f64, h: f64) {
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
                Activation::OnContact => self
                    .backend
                    .touches_another_ragdoll(inst.first_body, inst.shapes.len()),
                Activation::OnBlast => self.blasts.iter().any(|active| {
                    let det = active.blast.time_s as f64;
                    if t1 <= det {
                        return false;
                    }
                    let ground = self
                        .settings
                        .ground
                        .unwrap_or(active.blast.position.y - FREE_AIR_DEPTH_M);
                    inst.shapes.iter().enumerate().any(|(k, shape)| {
                        let state = &self.states[inst.first_body + k];
                        let (at, _, _) = blast::blast_on_part(&active.blast, state, shape, ground);
                        det + at.arrival_s <= t1
                    })
                }),
            };
            if go {
                self.hand_over(c, t0, h);
            } else {
                for (k, pose) in play.body_poses(t1).iter().enumerate() {
                    self.backend.set_kinematic_target(inst.first_body + k, pose);
                }
            }
        }
    }

    /// Ragdoll `c` stops playing its clip at `t` (seconds): its bodies become dynamic with
    /// the clip's velocities (central differences over `h`).
    fn hand_over(&mut self, c: usize, t0: f64, h: f64) {
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
            self.backend.set_kinematic(first + k, false);
            self.backend.set_body_pose(first + k, pose);
            self.backend.set_body_velocity(first + k, *v, *w);
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
        for a in 0..poses.len() {
            for b in a + 1..poses.len() {
                if crate::spec::shapes_overlap(
                    &poses[a],
                    &inst.shapes[a],
                    &poses[b],
                    &inst.shapes[b],
                    0.0,
                ) {
                    self.backend.disable_pair(first + a, first + b);
                }
            }
        }
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
            self.backend
                .set_joint_parent_frame(inst.first_joint + k, &j.frame_parent);
            if j.widen_to_include(parent, child, HANDOVER_LIMIT_MARGIN_DEG) {
                self.backend.set_joint_limits(inst.first_joint + k, &j.kind);
            }
        }
        inst.active = true;
        inst.activated_at = Some(t0);
    }

    /// Adds a blast. It acts on every ragdoll in the world, each body part from the moment
    /// the blast front reaches it.
    pub fn add_blast(&mut self, blast: Blast) -> Result<()> {
        blast.validate()?;
        self.blasts.push(blast::ActiveBlast {
            blast,
            parts: Vec::new(),
            com_velocity: Vec::new(),
        });
        Ok(())
    }

    /// What every blast did so far: per body part its arrival time, peak pressure and
    /// momentum received; per character its centre-of-mass velocity once the blast passed.
    pub fn blast_reports(&self) -> Vec<BlastReport> {
        let body_names: Vec<Vec<String>> = self
            .instances
            .iter()
            .map(|i| i.body_names.clone())
            .collect();
        let names: Vec<String> = self.instances.iter().map(|i| i.name.clone()).collect();
        self.blasts
            .iter()
            .map(|b| b.report(&body_names, &names))
            .collect()
    }

    /// Adds a push (impulse or force) on a body part of ragdoll `id`.
    pub fn add_push(&mut self, id: RagdollId, push: crate::events::Push) -> Result<()> {
        use crate::events::Push;
        let (target, vector, times) = match &push {
            Push::Impulse {
                target,
                impulse_ns,
                time_s,
            } => (target, *impulse_ns, [*time_s, *time_s]),
            Push::Force {
                target,
                force_n,
                start_s,
                end_s,
            } => (target, *force_n, [*start_s, *end_s]),
        };
        if !vector.is_finite() || times.iter().any(|t| !(t.is_finite() && *t >= 0.0)) {
            return Err(setting_error(
                "push",
                "values must be finite, times zero or positive",
            ));
        }
        if times[1] < times[0] {
            return Err(setting_error("push", "the force must end after it starts"));
        }
        let (body, local) = self.resolve_target(id, target)?;
        self.pushes.push(forces::ActivePush {
            push,
            body,
            local,
            done: false,
        });
        Ok(())
    }

    /// Adds a force field acting on every ragdoll.
    pub fn add_field(&mut self, field: crate::events::Field) -> Result<()> {
        use crate::events::Field;
        let ok = match &field {
            Field::Gravity { keys } => {
                !keys.is_empty()
                    && keys.iter().all(|(t, g)| t.is_finite() && g.is_finite())
                    && keys.windows(2).all(|w| w[0].0 <= w[1].0)
            }
            Field::Radial {
                center,
                strength_mps2,
                radius_m,
                start_s,
                end_s,
            } => {
                center.is_finite()
                    && strength_mps2.is_finite()
                    && radius_m.is_finite()
                    && *radius_m > 0.0
                    && start_s <= end_s
            }
            Field::Drag {
                rate_per_s,
                start_s,
                end_s,
            } => rate_per_s.is_finite() && *rate_per_s >= 0.0 && start_s <= end_s,
            Field::Wind {
                velocity_mps,
                start_s,
                end_s,
            } => velocity_mps.is_finite() && start_s <= end_s,
        };
        if !ok {
            return Err(setting_error(
                "field",
                "values must be finite, radii and rates positive, keys and windows in time order",
            ));
        }
        self.fields.push(field);
        Ok(())
    }

    /// Pins a body part of ragdoll `id` (see [`crate::events::Pin`]). Pins act from the
    /// start until released.
    pub fn add_pin(&mut self, id: RagdollId, pin: crate::events::Pin) -> Result<()> {
        if pin.keys.is_empty()
            || pin
                .keys
                .iter()
                .any(|(t, p)| !(t.is_finite() && p.is_finite()))
            || pin.keys.windows(2).any(|w| w[0].0 > w[1].0)
        {
            return Err(setting_error(
                "pin",
                "keys must be finite [time, x, y, z] in time order",
            ));
        }
        if pin
            .stiffness_hz
            .is_some_and(|k| !(k.is_finite() && k > 0.0))
            || !(pin.damping_ratio.is_finite() && pin.damping_ratio >= 0.0)
            || pin.release_s.is_some_and(|t| !t.is_finite())
        {
            return Err(setting_error(
                "pin",
                "stiffness must be positive Hz, damping zero or positive, release a time",
            ));
        }
        let (body, local) = self.resolve_target(id, &pin.target)?;
        self.pins.push(forces::ActivePin {
            pin,
            body,
            local,
            handle: None,
            released: false,
        });
        Ok(())
    }

    /// The body a name refers to (a skeleton joint, on the body it rides on; or a body of
    /// the spec, at its centre) and the point it names in that body's frame.
    fn resolve_target(&self, id: RagdollId, target: &str) -> Result<(usize, Vec3)> {
        let inst = &self.instances[id.0];
        // A joint first (its position is what "pin the wrist" means), then a body (its
        // centre): the built-in humanoid's bodies and joints share their names.
        if let Some(j) = inst.joint_labels.iter().position(|n| n == target) {
            let r = &inst.riders[j];
            return Ok((inst.first_body + r.body, r.offset.translation));
        }
        if let Some(b) = inst.body_names.iter().position(|n| n == target) {
            return Ok((inst.first_body + b, Vec3::ZERO));
        }
        Err(Error::Setting {
            setting: "target".into(),
            message: format!("{} has no body or joint named \"{target}\"", inst.name),
        })
    }

    /// Applies pushes, fields and pins over `[t0, t1]`.
    fn apply_forces(&mut self, t0: f64, t1: f64) {
        use crate::events::{Field, Push};
        // Gravity fields replace the world's gravity while there are any.
        if let Some(g) = self.fields.iter().rev().find_map(|f| match f {
            Field::Gravity { keys } => Some(forces::sample_keys(keys, (0.5 * (t0 + t1)) as f32)),
            _ => None,
        }) {
            self.backend.set_gravity(g);
        }
        for p in &mut self.pushes {
            if p.done {
                continue;
            }
            let state = &self.states[p.body];
            let point = state.pose.transform_point(p.local);
            let impulse = match &p.push {
                Push::Impulse {
                    impulse_ns, time_s, ..
                } => {
                    if (*time_s as f64) >= t1 {
                        continue;
                    }
                    p.done = true;
                    *impulse_ns
                }
                Push::Force {
                    force_n,
                    start_s,
                    end_s,
                    ..
                } => {
                    if (*end_s as f64) < t0 {
                        p.done = true;
                        continue;
                    }
                    *force_n * forces::overlap(t0, t1, *start_s as f64, *end_s as f64) as f32
                }
            };
            if impulse != Vec3::ZERO {
                self.backend.apply_impulse_at_point(p.body, impulse, point);
            }
        }
        if self
            .fields
            .iter()
            .any(|f| !matches!(f, Field::Gravity { .. }))
        {
            for inst in self.instances.iter().filter(|i| i.active) {
                for (k, shape) in inst.shapes.iter().enumerate() {
                    let state = self.states[inst.first_body + k];
                    let mut impulse = Vec3::ZERO;
                    for f in &self.fields {
                        impulse += forces::field_impulse(
                            f,
                            t0,
                            t1,
                            inst.masses[k],
                            state.pose.translation,
                            state.linvel,
                            |dir| blast::projected_area(&state, shape, dir),
                        );
                    }
                    if impulse != Vec3::ZERO {
                        self.backend.apply_impulse_at_point(
                            inst.first_body + k,
                            impulse,
                            state.pose.translation,
                        );
                    }
                }
            }
        }
        let masses: Vec<f32> = self.pins.iter().map(|p| self.body_mass(p.body)).collect();
        for (p, mass) in self.pins.iter_mut().zip(masses) {
            if p.released {
                continue;
            }
            if p.pin.release_s.is_some_and(|r| (r as f64) <= t0) {
                if let Some(handle) = p.handle {
                    self.backend.release_pin(handle);
                }
                p.released = true;
                continue;
            }
            let target = forces::sample_keys(&p.pin.keys, t1 as f32);
            match p.pin.stiffness_hz {
                // Hard: a ball joint to a kinematic anchor moved along the path.
                None => match p.handle {
                    None => p.handle = Some(self.backend.add_pin(p.body, p.local, target, None)),
                    Some(handle) => self.backend.move_pin(handle, target),
                },
                // Soft: a damped spring on the pinned point, as an impulse per substep
                // (rapier's soft joints are regularised constraints, not springs of a
                // given frequency).
                Some(hz) => {
                    let state = &self.states[p.body];
                    let point = state.pose.transform_point(p.local);
                    let point_velocity =
                        state.linvel + state.angvel.cross(point - state.pose.translation);
                    let omega = std::f32::consts::TAU * hz;
                    let accel = (target - point) * omega * omega
                        - point_velocity * (2.0 * p.pin.damping_ratio * omega);
                    let impulse = accel * mass * (t1 - t0) as f32;
                    self.backend.apply_impulse_at_point(p.body, impulse, point);
                }
            }
        }
    }

    /// Mass of body `index` (global), kg.
    fn body_mass(&self, index: usize) -> f32 {
        self.instances
            .iter()
            .find(|i| (i.first_body..i.first_body + i.masses.len()).contains(&index))
            .map_or(1.0, |i| i.masses[index - i.first_body])
    }

    /// Adds a projectile; it hits at its time    /// Adds a projectile; it hits at its time (see [`Projectile`]).
    pub fn add_projectile(&mut self, projectile: Projectile) -> Result<()> {
        projectile.validate()?;
        self.projectiles.push((projectile, None));
        Ok(())
    }

    /// What every projectile fired so far hit.
    pub fn projectile_reports(&self) -> Vec<ProjectileReport> {
        self.projectiles
            .iter()
            .filter_map(|(_, r)| r.clone())
            .collect()
    }

    /// Fires the projectiles whose time has come by `t1`.
    fn fire_projectiles(&mut self, t1: f64) {
        /// Projectiles fly at most this far, metres.
        const RANGE_M: f32 = 1.0e4;
        for k in 0..self.projectiles.len() {
            let (p, done) = &self.projectiles[k];
            let t = p.time_s as f64;
            if done.is_some() || t >= t1 {
                continue;
            }
            let p = *p;
            let dir = p.direction.normalize();
            let momentum = p.mass_kg * p.speed_mps;
            let mut report = ProjectileReport {
                time_s: p.time_s,
                character: None,
                body: None,
                point: None,
                impulse_ns: 0.0,
            };
            if let Some((body, dist)) = self.backend.cast_ray(p.origin, dir, RANGE_M) {
                let point = p.origin + dir * dist;
                // A character waiting for contact is handed over before the hit lands (a
                // clip-driven body would not feel it).
                let owner = self
                    .instances
                    .iter()
                    .position(|i| (i.first_body..i.first_body + i.shapes.len()).contains(&body));
                if let Some(c) = owner
                    && !self.instances[c].active
                    && self.instances[c].activation == Activation::OnContact
                {
                    let h = self.settings.dt as f64 / self.settings.collision_substeps as f64;
                    self.hand_over(c, t1, h);
                }
                self.backend
                    .apply_impulse_at_point(body, dir * momentum, point);
                if let Some((c, inst)) =
                    self.instances.iter().enumerate().find(|(_, i)| {
                        (i.first_body..i.first_body + i.shapes.len()).contains(&body)
                    })
                {
                    report.character = Some(c);
                    report.body = Some(inst.body_names[body - inst.first_body].clone());
                }
                report.point = Some(point.to_array());
                report.impulse_ns = momentum;
            }
            self.projectiles[k].1 = Some(report);
        }
    }

    /// Applies every blast's load over `[t0, t1]` (seconds) to every body part.
    fn apply_blasts(&mut self, t0: f64, t1: f64) {
        for active in &mut self.blasts {
            let b = active.blast;
            // Without a ground every burst is a free-air burst: put the ground far below.
            let ground = self
                .settings
                .ground
                .unwrap_or(b.position.y - FREE_AIR_DEPTH_M);
            let det = b.time_s as f64;
            if t1 <= det {
                continue;
            }
            active
                .parts
                .resize_with(self.instances.len(), Default::default);
            active.com_velocity.resize(self.instances.len(), None);
            for (c, inst) in self.instances.iter().enumerate() {
                if !inst.active {
                    // A clip still playing is not pushed; it may be handed over to physics
                    // on this very blast (`Activation::OnBlast`), before the loads.
                    continue;
                }
                let records = &mut active.parts[c];
                records.resize_with(inst.shapes.len(), Default::default);
                for (k, shape) in inst.shapes.iter().enumerate() {
                    let state = &self.states[inst.first_body + k];
                    let (at, point, dir) = blast::blast_on_part(&b, state, shape, ground);
                    let record = &mut records[k];
                    let arrival = det + at.arrival_s;
                    record.passed_s = arrival + at.duration_s;
                    if t1 < arrival || t0 > record.passed_s {
                        continue;
                    }
                    if record.arrival_s.is_none() {
                        record.arrival_s = Some(arrival);
                        record.peak_pressure_pa = at.reflected_pa;
                    }
                    let area = blast::projected_area(state, shape, dir) as f64;
                    let depth = blast::depth_along(state, shape, dir) as f64;
                    let j = b.scale as f64
                        * crate::events::blast::part_impulse(
                            &at,
                            t0 - det,
                            t1 - det,
                            area,
                            depth,
                            blast::DRAG_COEFFICIENT,
                        );
                    if j > 0.0 && j.is_finite() {
                        let impulse = dir.as_dvec3() * j;
                        record.impulse += impulse;
                        self.backend.apply_impulse_at_point(
                            inst.first_body + k,
                            impulse.as_vec3(),
                            point,
                        );
                    }
                }
            }
        }
    }

    /// Records each character's centre-of-mass velocity once a blast's positive phase has
    /// passed all of its parts.
    fn blast_after_step(&mut self) {
        for active in &mut self.blasts {
            for (c, inst) in self.instances.iter().enumerate() {
                let (Some(records), Some(slot)) =
                    (active.parts.get(c), active.com_velocity.get_mut(c))
                else {
                    continue;
                };
                if slot.is_some()
                    || records.is_empty()
                    || records.iter().any(|r| r.arrival_s.is_none())
                    || records.iter().any(|r| self.time < r.passed_s)
                {
                    continue;
                }
                let mut momentum = Vec3::ZERO;
                let mut mass = 0.0;
                for (k, &m) in inst.masses.iter().enumerate() {
                    momentum += self.states[inst.first_body + k].linvel * m;
                    mass += m;
                }
                *slot = Some(momentum / mass);
            }
        }
    }

    /// Simulated time so far, seconds.
    pub fn time(&self) -> f64 {
        self.time
    }

    /// Steps the world for `seconds`, recording output frames at the track rate. The first
    /// call also records the starting frame.
    pub fn run(&mut self, seconds: f32) {
        let end = self.time + seconds.max(0.0) as f64;
        let dt = self.settings.dt as f64;
        if self.frames_recorded == 0 {
            self.backend.body_states(&mut self.states);
            self.prev_states.clone_from(&self.states);
            self.record_frames_until(0.0);
        }
        while self.time + 0.5 * dt <= end + 1e-9 {
            self.step();
        }
    }

    /// One fixed step, then whatever output frames fall inside it.
    pub fn step(&mut self) {
        if self.frames_recorded == 0 {
            self.backend.body_states(&mut self.states);
            self.prev_states.clone_from(&self.states);
            self.record_frames_until(0.0);
        }
        self.prev_states.clone_from(&self.states);
        let n = self.settings.collision_substeps;
        let h = self.settings.dt / n as f32;
        for i in 0..n {
            let t0 = self.time + (i as f64) * h as f64;
            if self.instances.iter().any(|inst| !inst.active) {
                if i > 0 {
                    self.backend.body_states(&mut self.states);
                }
                self.play_clips(t0, t0 + h as f64, h as f64);
            }
            if !self.blasts.is_empty() {
                if i > 0 {
                    self.backend.body_states(&mut self.states);
                }
                self.apply_blasts(t0, t0 + h as f64);
            }
            if !(self.pushes.is_empty() && self.fields.is_empty() && self.pins.is_empty()) {
                if i > 0 {
                    self.backend.body_states(&mut self.states);
                }
                self.apply_forces(t0, t0 + h as f64);
            }
            if self
                .instances
                .iter()
                .any(|inst| inst.active && inst.motors.is_some())
            {
                if i > 0 {
                    self.backend.body_states(&mut self.states);
                }
                self.apply_motors(t0, h);
            }
            self.backend.step(h);
            // After the step: rapier's scene queries see the bodies only once a step has
            // updated them; the shot lands at most one substep (1/240 s) late.
            self.fire_projectiles(t0 + h as f64);
        }
        self.time += self.settings.dt as f64;
        self.backend.body_states(&mut self.states);
        self.blast_after_step();
        if self.settings.project_limits {
            self.project_limits();
        }
        self.measure_step();
        self.record_frames_until(self.time);
    }

    /// Worst-case quality metrics so far.
    pub fn metrics(&self) -> Metrics {
        self.metrics
    }

    /// The track recorded so far for ragdoll `id`.
    pub fn track(&self, id: RagdollId) -> &Track {
        &self.instances[id.0].track
    }

    /// Number of ragdolls.
    pub fn ragdoll_count(&self) -> usize {
        self.instances.len()
    }

    /// World transforms of ragdoll `id`'s bodies now, in spec order.
    pub fn body_poses(&self, id: RagdollId) -> Vec<Transform> {
        let inst = &self.instances[id.0];
        self.states[inst.first_body..inst.first_body + inst.masses.len()]
            .iter()
            .map(|s| s.pose)
            .collect()
    }

    /// For each joint of ragdoll `id` (spec order), the current anchor separation in
    /// metres and limit violation in degrees: the per-joint view of [`Metrics`].
    pub fn joint_errors(&self, id: RagdollId) -> Vec<(f32, f32)> {
        let inst = &self.instances[id.0];
        let states = &self.states[inst.first_body..inst.first_body + inst.masses.len()];
        inst.joints
            .iter()
            .map(|j| {
                let (p, c) = (&states[j.parent].pose, &states[j.child].pose);
                (j.separation(p, c), j.violation(p, c).to_degrees())
            })
            .collect()
    }

    /// Consumes the world, returning the track of its first ragdoll.
    pub fn into_track(mut self) -> Track {
        std::mem::take(&mut self.instances[0].track)
    }

    /// Consumes the world, returning every ragdoll's track in insertion order.
    pub fn into_tracks(self) -> Vec<Track> {
        self.instances.into_iter().map(|i| i.track).collect()
    }

    fn record_frames_until(&mut self, t: f64) {
        let fps = self.settings.fps as f64;
        let dt = self.settings.dt as f64;
        loop {
            let ft = self.frames_recorded as f64 / fps;
            if ft > t + 1e-9 {
                break;
            }
            // Interpolate between the previous and the current step.
            let alpha = if t <= 0.0 {
                1.0
            } else {
                (((ft - (t - dt)) / dt).clamp(0.0, 1.0)) as f32
            };
            for inst in &mut self.instances {
                if !inst.active
                    && let Some(play) = &inst.playback
                {
                    let mut frame = Vec::new();
                    play.joint_world(ft, &mut frame);
                    inst.track.frames.push(frame);
                    continue;
                }
                let frame: Vec<Transform> = inst
                    .riders
                    .iter()
                    .map(|r| {
                        let a = &self.prev_states[inst.first_body + r.body].pose;
                        let b = &self.states[inst.first_body + r.body].pose;
                        let pose = Transform::new(
                            a.translation.lerp(b.translation, alpha),
                            a.rotation.slerp(b.rotation, alpha),
                        );
                        pose.mul(&r.offset)
                    })
                    .collect();
                inst.track.frames.push(frame);
            }
            self.frames_recorded += 1;
            self.measure_frame_energy();
        }
    }

    /// Clamps every joint back into its limits (see [`WorldSettings::project_limits`]).
    ///
    /// Where turning a subtree would sink one of its bodies below the ground (deeper than
    /// it already was, beyond [`PROJECTION_GROUND_SLACK_M`]), the whole ragdoll is lifted
    /// by that much instead: left to the contacts, such a sink came back as 3-6 cm
    /// penetrations in our runs; the lift is a few millimetres, once in a while.
    fn project_limits(&mut self) {
        let ground = self.settings.ground;
        for inst in self.instances.iter().filter(|i| i.active) {
            let base = inst.first_body;
            for &k in &inst.joint_order {
                let j = &inst.joints[k];
                let parent = self.states[base + j.parent].pose;
                let child = self.states[base + j.child].pose;
                if j.violation(&parent, &child) < PROJECTION_TOLERANCE_DEG.to_radians() {
                    continue;
                }
                let Some(rotation) = j.clamp_child_rotation(&parent, &child) else {
                    continue;
                };
                let full = rotation * child.rotation.conjugate();
                let anchor = child.transform_point(j.frame_child.translation);
                let moved = |p: &Transform, delta: glam::Quat| {
                    Transform::new(
                        anchor + delta * (p.translation - anchor),
                        (delta * p.rotation).normalize(),
                    )
                };
                let delta = full;
                // How far the turned subtree would sink below the ground beyond the slack
                // (and beyond where it already was): the whole ragdoll is lifted by that
                // much, so the limit wins without pushing a body into the floor.
                let mut lift = 0.0f32;
                if let Some(g) = ground {
                    for &b in &inst.subtrees[k] {
                        let shape = &inst.shapes[b];
                        let before = lowest_point(&self.states[base + b].pose, shape);
                        let after = lowest_point(&moved(&self.states[base + b].pose, delta), shape);
                        let floor = (g - PROJECTION_GROUND_SLACK_M).min(before);
                        lift = lift.max(floor - after);
                    }
                }
                for &b in &inst.subtrees[k] {
                    let pose = moved(&self.states[base + b].pose, delta);
                    self.states[base + b].pose = pose;
                    self.backend.set_body_pose(base + b, &pose);
                }
                if lift > 0.0 {
                    for b in 0..inst.shapes.len() {
                        self.states[base + b].pose.translation.y += lift;
                        let pose = self.states[base + b].pose;
                        self.backend.set_body_pose(base + b, &pose);
                    }
                }
            }
        }
    }

    fn measure_step(&mut self) {
        let m = &mut self.metrics;
        m.max_penetration_m = m.max_penetration_m.max(self.backend.max_penetration());
        for s in &self.states {
            if !(s.pose.is_finite() && s.linvel.is_finite() && s.angvel.is_finite()) {
                m.nan = true;
            }
        }
        for inst in self.instances.iter().filter(|i| i.active) {
            let states = &self.states[inst.first_body..inst.first_body + inst.masses.len()];
            for j in &inst.joints {
                let (p, c) = (&states[j.parent].pose, &states[j.child].pose);
                m.max_joint_separation_m = m.max_joint_separation_m.max(j.separation(p, c));
                m.max_limit_violation_deg = m
                    .max_limit_violation_deg
                    .max(j.violation(p, c).to_degrees());
            }
        }
    }

    /// Whether every blast has gone off and passed every body part (DESIGN §5 measures
    /// the energy drift only after the last event).
    fn events_done(&self) -> bool {
        use crate::events::Field;
        let t = self.time;
        // Pins hold until released; pushes and fields until their windows end; gravity
        // fields change what potential energy means, so they never end.
        let forces_done = self.pins.iter().all(|p| p.released)
            && self.pushes.iter().all(|p| p.done)
            && self.fields.iter().all(|f| match f {
                Field::Gravity { .. } => false,
                Field::Radial { end_s, .. }
                | Field::Drag { end_s, .. }
                | Field::Wind { end_s, .. } => (*end_s as f64) <= t,
            });
        // Motors put energy in on purpose until they have faded out for good.
        let motors_done = self.instances.iter().all(|i| {
            i.motors.as_ref().is_none_or(|m| {
                let keys = &m.motors.strength_keys;
                keys.last()
                    .is_some_and(|&(time, strength)| strength == 0.0 && (time as f64) <= t)
            })
        });
        forces_done
            && motors_done
            && self.instances.iter().all(|i| i.active)
            && self.blasts.iter().all(|b| {
                let reached_all = b.parts.len() == self.instances.len()
                    && b.parts
                        .iter()
                        .all(|parts| parts.iter().all(|r| r.arrival_s.is_some()));
                reached_all && b.parts.iter().flatten().all(|r| r.passed_s <= self.time)
            })
    }

    fn measure_frame_energy(&mut self) {
        if !self.events_done() {
            // Events put energy in on purpose; measure from the first frame after them.
            self.start_energy = None;
            self.last_frame_energy = None;
            return;
        }
        let g = self.settings.gravity;
        let ground = self.settings.ground.unwrap_or(0.0);
        let mut potential = 0.0f64;
        for inst in &self.instances {
            for (i, &m) in inst.masses.iter().enumerate() {
                let p = self.states[inst.first_body + i].pose.translation - Vec3::Y * ground;
                potential += -(m as f64) * g.dot(p) as f64;
            }
        }
        let e = potential + self.backend.kinetic_energy();
        let e0 = *self.start_energy.get_or_insert(e);
        if let Some(last) = self.last_frame_energy {
            let rise = (e - last) / e0.abs().max(1e-9);
            if rise.is_finite() {
                self.metrics.energy_drift = self.metrics.energy_drift.max(rise.max(0.0) as f32);
            } else {
                self.metrics.nan = true;
            }
        }
        self.last_frame_energy = Some(e);
    }
}

fn setting_error(setting: &str, message: &str) -> Error {
    Error::Setting {
        setting: setting.into(),
        message: message.into(),
    }
}

/// Joint indices ordered parents first, and for each joint the bodies under its child.
fn joint_tree(joints: &[ResolvedJoint], bodies: usize) -> (Vec<usize>, Vec<Vec<usize>>) {
    let mut parent_joint = vec![None; bodies];
    for (k, j) in joints.iter().enumerate() {
        parent_joint[j.child] = Some(k);
    }
    let depth = |mut b: usize| {
        let mut d = 0;
        while let Some(k) = parent_joint[b] {
            b = joints[k].parent;
            d += 1;
            if d > bodies {
                break; // a cycle: validate() does not forbid it, so do not loop forever
            }
        }
        d
    };
    let mut order: Vec<usize> = (0..joints.len()).collect();
    order.sort_by_key(|&k| depth(joints[k].child));
    let subtrees = joints
        .iter()
        .map(|j| {
            (0..bodies)
                .filter(|&b| {
                    let mut x = b;
                    for _ in 0..=bodies {
                        if x == j.child {
                            return true;
                        }
                        match parent_joint[x] {
                            Some(k) => x = joints[k].parent,
                            None => return false,
                        }
                    }
                    false
                })
                .collect()
        })
        .collect();
    (order, subtrees)
}

/// Lowest world height of a shape at `pose`.
fn lowest_point(pose: &Transform, shape: &Shape) -> f32 {
    match *shape {
        Shape::Capsule { radius_m, length_m } => {
            let axis = pose.rotation * Vec3::Y * (0.5 * length_m);
            (pose.translation.y - axis.y.abs()) - radius_m
        }
        Shape::Box { size_m } => {
            let h = Vec3::from_array(size_m) * 0.5;
            let mut low = f32::INFINITY;
            for sx in [-1.0, 1.0] {
                for sy in [-1.0, 1.0] {
                    for sz in [-1.0, 1.0] {
                        let c = pose.transform_point(h * Vec3::new(sx, sy, sz));
                        low = low.min(c.y);
                    }
                }
            }
            low
        }
    }
}
