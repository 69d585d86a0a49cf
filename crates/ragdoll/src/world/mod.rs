//! The runtime half: a [`World`] owns ragdoll instances made from [`RagdollSpec`]s, the
//! ground and a backend; it steps at a fixed rate and records a [`Track`] per ragdoll plus
//! the quality [`Metrics`].
//!
//! This file holds creation and stepping; `start.rs` and `overlap.rs` say where a ragdoll
//! may start, `record.rs` records frames and measures the metrics, and each kind of event
//! has its own file: `blast.rs` (blast loads), `forces.rs` (pushes, fields, pins),
//! `playback.rs` (clips and the hand-over to physics), `motors.rs` (powered mode).

use glam::Vec3;

mod blast;
mod damping;
mod forces;
mod motors;
mod overlap;
mod playback;
mod projectile;
mod record;
mod start;

pub use crate::backend::BackendKind;
pub use forces::DragId;
pub use motors::Motors;
pub use playback::Activation;
pub use start::MAX_COORDINATE_M;
use start::{beyond_world, within_world};

use crate::backend::fast::{FastBackend, FastSettings};
use crate::backend::particle::{ParticleBackend, ParticleSettings};
use crate::backend::rigid::{RigidBackend, RigidSettings};
use crate::backend::tree::JointTree;
use crate::backend::{AnyBackend, Backend, BodyDesc, BodyImpulse, BodyState, JointDesc};
use crate::error::{Error, Result};
use crate::events::{Projectile, ProjectileReport};
use crate::math::Transform;
use crate::skeleton::Character;
use crate::spec::{RagdollSpec, Resolved, ResolvedJoint, Shape, start_pose};
use crate::track::{Metrics, Track};

/// Standard gravity, m/s².
pub const STANDARD_GRAVITY: f32 = 9.80665;

pub use crate::bounds::{MAX_GRAVITY_MPS2, MAX_SECONDS};

/// Shortest and longest fixed step, seconds: 10 kHz (a shorter one only makes a run that
/// cannot finish) to 10 Hz (a longer one lets a falling body pass through another).
pub const STEP_RANGE_S: [f32; 2] = [1e-4, 0.1];

/// Highest output frame rate, frames per second.
pub const MAX_FPS: f32 = 1000.0;

/// Most substeps or iterations of each kind per step.
pub const MAX_SUBSTEPS: usize = 100;

/// Most joint transforms a run records: frames × skeleton joints, over every character.
///
/// Each is 48 bytes in memory, so the tracks stay under about 500 MB (before the glTF
/// that encodes them): a 60-joint mocap skeleton at 30 fps for the full hour, or 100
/// humanoids for a minute.
pub const MAX_TRACK_SAMPLES: u64 = 10_000_000;

/// How far inside widened limits the pose at a hand-over ends up, degrees.
const HANDOVER_LIMIT_MARGIN_DEG: f32 = 5.0;

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
    /// Which engine moves the bodies (default [`BackendKind::Rigid`]). The particle
    /// backend keeps limits itself (`project_limits` is then not needed) and reads
    /// `particle_substeps` and `particle_iterations` instead of `substeps` and
    /// `iterations`; the fast backend reads `fast_substeps` alone.
    pub backend: BackendKind,
    /// Substeps per physics step of the particle backend (default 3: with the 4 collision
    /// substeps, the particles move at 720 Hz). Two leave the built-in humanoid's bones
    /// 1.4 % stretched after a fall; four cost a third more.
    pub particle_substeps: usize,
    /// Projection passes per particle substep (default 1): substeps converge better than
    /// passes for the same cost (Macklin et al. 2019, "Small Steps in Physics Simulation").
    pub particle_iterations: usize,
    /// Substeps per step of the fast backend (default [`DEFAULT_FAST_SUBSTEPS`]). It
    /// finds contact pairs once per step and ignores `collision_substeps`: its substeps
    /// find the contact points themselves.
    pub fast_substeps: usize,
    /// Passive joint damping, per second (default [`DEFAULT_JOINT_DAMPING`], off): how
    /// fast a limp limb swinging from a still body loses its speed relative to it, so its
    /// swing's amplitude decays as `exp(-c t / 2)`. Rigid backend only for now.
    pub joint_damping: f32,
}

/// Default of [`WorldSettings::fast_substeps`]: 32 substeps of 1/1920 s. Measured on six
/// piles of 8 built-in humanoids dropped lying (means of each run's worst values): 16
/// substeps left joints 31 mm apart, contacts 46 mm deep and limits 12° past; 24 left
/// 16 mm, 27 mm, 8°; 32 left 14 mm, 23 mm, 5.5°, where the rigid backend leaves 16 mm,
/// 38 mm, 8.5° (its solver's reading, before the world's clamp).
pub const DEFAULT_FAST_SUBSTEPS: usize = 32;

/// Default of [`WorldSettings::joint_damping`]: off, so runs match earlier releases.
///
/// Without damping a limp part hanging free swings as an undamped pendulum for the whole
/// run: the rigged dragons' raised heads swung at 0.1-0.4 m/s for 14 s on the rigid
/// backend. At 1.5 per second they lie still within a few seconds, but the default stays
/// off until it is measured on every data file and the particle backend has it (see
/// [`WorldSettings::validate`]).
pub const DEFAULT_JOINT_DAMPING: f32 = 0.0;

/// Largest [`WorldSettings::joint_damping`], per second: a limb stopping within a
/// hundredth of a second is a weld, not a joint.
pub const MAX_JOINT_DAMPING: f32 = 100.0;

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
            backend: BackendKind::Rigid,
            particle_substeps: 3,
            particle_iterations: 1,
            fast_substeps: DEFAULT_FAST_SUBSTEPS,
            joint_damping: DEFAULT_JOINT_DAMPING,
        }
    }
}

impl WorldSettings {
    /// Checks the settings a user can set: the step within [`STEP_RANGE_S`], the frame
    /// rate within 1..[`MAX_FPS`], substeps within 1..[`MAX_SUBSTEPS`], gravity within
    /// [`MAX_GRAVITY_MPS2`] and the ground within [`MAX_COORDINATE_M`].
    pub fn validate(&self) -> Result<()> {
        use crate::spec::{check_length, check_within};
        let mut checks = vec![
            (
                "dt",
                check_within(self.dt, STEP_RANGE_S[0], STEP_RANGE_S[1], " s"),
            ),
            (
                "fps",
                check_within(self.fps, 1.0, MAX_FPS, " frames per second"),
            ),
            (
                "gravity",
                check_length(self.gravity.to_array(), MAX_GRAVITY_MPS2, " m/s²"),
            ),
            (
                "ground",
                self.ground.map_or(Ok(()), |h| {
                    check_within(h, -MAX_COORDINATE_M, MAX_COORDINATE_M, " m")
                }),
            ),
            (
                "joint_damping",
                check_within(self.joint_damping, 0.0, MAX_JOINT_DAMPING, " per second"),
            ),
        ];
        for (name, v) in [
            ("collision_substeps", self.collision_substeps),
            ("substeps", self.substeps),
            ("iterations", self.iterations),
            ("particle_substeps", self.particle_substeps),
            ("particle_iterations", self.particle_iterations),
            ("fast_substeps", self.fast_substeps),
        ] {
            if !(1..=MAX_SUBSTEPS).contains(&v) {
                checks.push((
                    name,
                    Err(format!("must be between 1 and {MAX_SUBSTEPS}, not {v}")),
                ));
            }
        }
        if self.joint_damping > 0.0 && self.backend == BackendKind::Particle {
            // Applied as torque impulses on velocities the particle backend reads off its
            // last substep's motion, a substep late: on the viewer's largest bodies that
            // fed energy in (a 29 J fall came to 148 J of motion).
            checks.push((
                "joint_damping",
                Err(
                    "works on the rigid backend only for now; use 0 with the particle backend"
                        .to_string(),
                ),
            ));
        }
        match checks.into_iter().find(|(_, r)| r.is_err()) {
            Some((setting, Err(message))) => Err(Error::Setting {
                setting: setting.into(),
                message,
            }),
            _ => Ok(()),
        }
    }

    /// Checks a run of `seconds` recording `joints` skeleton joints (over every
    /// character) at these settings: at most [`MAX_SECONDS`], and at most
    /// [`MAX_TRACK_SAMPLES`] joint transforms recorded.
    pub fn validate_run(&self, seconds: f32, joints: usize) -> Result<()> {
        let bad = |message: String| {
            Err(Error::Setting {
                setting: "seconds".into(),
                message,
            })
        };
        if let Err(m) = crate::spec::check_within(seconds, 0.0, MAX_SECONDS, " s") {
            return bad(m);
        }
        let frames = (seconds as f64 * self.fps as f64).floor() as u64 + 1;
        let samples = frames.saturating_mul(joints as u64);
        if samples > MAX_TRACK_SAMPLES {
            return bad(format!(
                "{seconds} s at {} fps records {frames} frames of {joints} joints, more than \
                 the {MAX_TRACK_SAMPLES} joint transforms a run keeps in memory; shorten the \
                 run, lower the frame rate or use fewer characters",
                self.fps
            ));
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
    /// Joints parents first, and the bodies each joint's child carries.
    tree: JointTree,
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
    /// Each skeleton joint's parent joint.
    joint_parents: Vec<Option<usize>>,
    /// Each bone's length (joint to parent joint) in the first frame physics recorded,
    /// metres; empty until then.
    bone_lengths: Vec<f32>,
}

/// A simulated world: ragdolls, ground, gravity, a backend, and the tracks being recorded.
pub struct World {
    settings: WorldSettings,
    backend: AnyBackend,
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
    /// Every ragdoll's bodies at the start, until the first step (see `overlap.rs`).
    start_index: overlap::StartIndex,
    /// Whether a body's state went non-finite: the world then stops stepping (see
    /// [`World::step`]).
    halted: bool,
    /// Joints the backend worked on at each recorded frame (see
    /// [`World::active_joints_per_frame`]); empty where it does not say.
    active_joints: Vec<u32>,
    /// The events' impulses of this substep, handed to the backend together before it
    /// steps ([`Backend::apply_impulses`]).
    impulses: Vec<BodyImpulse>,
}

impl World {
    /// An empty world.
    pub fn new(settings: &WorldSettings) -> Result<Self> {
        settings.validate()?;
        let backend = match settings.backend {
            BackendKind::Rigid => AnyBackend::Rigid(Box::new(RigidBackend::new(
                RigidSettings {
                    gravity: settings.gravity,
                    ground: settings.ground,
                    substeps: settings.substeps,
                    iterations: settings.iterations,
                },
                settings.dt,
            ))),
            BackendKind::Particle => {
                AnyBackend::Particle(Box::new(ParticleBackend::new(ParticleSettings {
                    gravity: settings.gravity,
                    ground: settings.ground,
                    substeps: settings.particle_substeps,
                    iterations: settings.particle_iterations,
                })))
            }
            BackendKind::Fast => AnyBackend::Fast(Box::new(FastBackend::new(FastSettings {
                gravity: settings.gravity,
                ground: settings.ground,
                substeps: settings.fast_substeps,
            }))),
        };
        Ok(Self::with_any(settings, backend))
    }

    /// An empty world stepped by someone else's engine (see [`Backend`]). The world reads
    /// `settings` as for its own engines but for `backend` and the solver counts; the
    /// engine must simulate the same `gravity` and `ground` (the world lifts ragdolls onto
    /// that ground and measures energy with that gravity).
    ///
    /// # Example
    ///
    /// A backend that counts the impulses the world's events hand over, wrapped around
    /// another (here a world's own engine would do; any [`Backend`] fits):
    ///
    /// ```
    /// use ragdoll::backend::{Backend, BodyImpulse};
    /// use ragdoll::world::{World, WorldSettings};
    ///
    /// fn run(engine: Box<dyn Backend>) -> ragdoll::error::Result<()> {
    ///     let mut world = World::with_backend(&WorldSettings::default(), engine)?;
    ///     let character = ragdoll::skeleton::humanoid();
    ///     let spec = ragdoll::spec::build_spec(&character, &Default::default())?;
    ///     let id = world.add_ragdoll(&character, &spec, Default::default())?;
    ///     world.run(1.0);
    ///     assert_eq!(world.body_poses(id).len(), spec.bodies.len());
    ///     Ok(())
    /// }
    /// # let _ = run;
    /// ```
    pub fn with_backend(settings: &WorldSettings, backend: Box<dyn Backend>) -> Result<Self> {
        settings.validate()?;
        Ok(Self::with_any(settings, AnyBackend::Custom(backend)))
    }

    fn with_any(settings: &WorldSettings, backend: AnyBackend) -> Self {
        World {
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
            start_index: overlap::StartIndex::default(),
            halted: false,
            active_joints: Vec::new(),
            impulses: Vec::new(),
        }
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
    /// Must be called before the first step. Fails when one of its bodies would start
    /// inside a body of a ragdoll already added (one body's axis inside the other; see
    /// `overlap.rs`), or inside more than 32 bodies of its own; pairs of its own bodies
    /// that start so are kept from colliding.
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
                .map(|(p, b)| b.shape.lowest_y(p))
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
        let mut disabled: Vec<(usize, usize)> = spec
            .collision
            .disabled_pairs
            .iter()
            .filter_map(|[a, b]| Some((spec.body_index(a)?, spec.body_index(b)?)))
            .collect();
        // 2b. Where it starts: within the world, on the ground, not inside another
        //     ragdoll; its own parts that start inside each other stop colliding.
        let solids = self.check_start(character, spec, &body_start)?;
        disabled.extend(start::overlapping_parts(spec, &solids)?);
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
        self.start_index.insert(&solids);
        let joints = resolved.joints;
        let links: Vec<(usize, usize)> = joints.iter().map(|j| (j.parent, j.child)).collect();
        let tree = JointTree::new(spec.bodies.len(), &links);
        let playback = character
            .clips
            .first()
            .filter(|c| !c.frames.is_empty() && c.frames.iter().all(|f| f.len() == skeleton.len()))
            .map(|clip| playback::Playback {
                skeleton: skeleton.clone(),
                clip: clip.clone(),
                placement,
                lift,
                offset_s: 0.0,
                bone_of_body: resolved.bone_of_body.clone(),
                body_local: resolved.body_local.clone(),
            });
        let first_joint = self.instances.iter().map(|i| i.joints.len()).sum();
        self.instances.push(Instance {
            joint_labels: (0..skeleton.len())
                .map(|i| skeleton.joint_label(i))
                .collect(),
            first_joint,
            joint_parents: (0..skeleton.len()).map(|j| skeleton.parent(j)).collect(),
            bone_lengths: Vec::new(),
            playback,
            activation: Activation::Immediately,
            active: true,
            activated_at: Some(0.0),
            motors: None,
            name: character.name.clone(),
            body_names: spec.bodies.iter().map(|b| b.name.clone()).collect(),
            first_body,
            tree,
            shapes: spec.bodies.iter().map(|b| b.shape).collect(),
            masses: spec.bodies.iter().map(|b| b.mass_kg).collect(),
            joints,
            riders,
            track: Track {
                fps: self.settings.fps,
                frames: Vec::new(),
            },
        });
        // The bodies' states are readable (body_poses, joint_errors) before the first step.
        self.backend.body_states(&mut self.states);
        Ok(RagdollId(self.instances.len() - 1))
    }

    /// Linear (m/s) and angular (rad/s) velocities of ragdoll `id`'s bodies now, spec order.
    pub fn body_velocities(&self, id: RagdollId) -> Vec<(Vec3, Vec3)> {
        let inst = &self.instances[id.0];
        self.states[inst.first_body..inst.first_body + inst.masses.len()]
            .iter()
            .map(|s| (s.linvel, s.angvel))
            .collect()
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
        self.begin();
        while self.time + 0.5 * dt <= end + 1e-9 {
            self.step();
        }
    }

    /// Records the starting frame, once: from then on no ragdoll can be added.
    fn begin(&mut self) {
        if self.frames_recorded == 0 {
            self.backend.body_states(&mut self.states);
            self.prev_states.clone_from(&self.states);
            self.record_frames_until(0.0);
            self.start_index = overlap::StartIndex::default();
        }
    }

    /// Whether every body's pose and velocities are finite now (and the backend has hidden
    /// no non-finite body).
    fn states_finite(&self) -> bool {
        !self.backend.went_non_finite()
            && self
                .states
                .iter()
                .all(|s| s.pose.is_finite() && s.linvel.is_finite() && s.angvel.is_finite())
    }

    /// One fixed step, then whatever output frames fall inside it.
    ///
    /// When a body's state stops being finite (forces past what f32 can hold), the world
    /// sets [`Metrics::nan`], keeps the last finite states and from then on only advances
    /// the clock: the frames that follow hold the last good pose instead of garbage, and a
    /// caller sees the flag (the CLI exits non-zero on it).
    pub fn step(&mut self) {
        self.begin();
        self.prev_states.clone_from(&self.states);
        if self.halted {
            self.time += self.settings.dt as f64;
            self.record_frames_until(self.time);
            return;
        }
        let n = self.outer_steps();
        let h = self.settings.dt / n as f32;
        for i in 0..n {
            let t0 = self.time + (i as f64) * h as f64;
            // Every event of the substep reads the bodies as the last substep left them
            // (and a clip's hand-over, which sets velocities); their impulses reach the
            // backend together, before it steps.
            if self.instances.iter().any(|inst| !inst.active) {
                self.play_clips(t0, t0 + h as f64, h as f64);
                self.backend.body_states(&mut self.states);
            }
            if !self.blasts.is_empty() {
                self.apply_blasts(t0, t0 + h as f64);
            }
            if !(self.pushes.is_empty() && self.fields.is_empty() && self.pins.is_empty()) {
                self.apply_forces(t0, t0 + h as f64);
            }
            if self
                .instances
                .iter()
                .any(|inst| inst.active && inst.motors.is_some())
            {
                self.apply_motors(t0, h);
            }
            if self.settings.joint_damping > 0.0 {
                self.apply_joint_damping(h);
            }
            self.flush_impulses();
            self.backend.step(h);
            // Checked every substep: a non-finite body must not reach the next substep's
            // events or the backend's queries.
            self.backend.body_states(&mut self.states);
            if !self.states_finite() {
                self.halt();
                return;
            }
            // After the step: rapier's scene queries see the bodies only once a step has
            // updated them; the shot lands at most one substep (1/240 s) late. Its impulse
            // goes in at once, and the states are read again for the next substep.
            self.fire_projectiles(t0 + h as f64);
            if !self.impulses.is_empty() {
                self.flush_impulses();
                self.backend.body_states(&mut self.states);
            }
        }
        self.time += self.settings.dt as f64;
        self.blast_after_step();
        // What the solver left, before any clamp: the backend's own reading where it clamps
        // itself, else the bodies as they are before the world's projection.
        let solver = match self.backend.solver_limit_violation() {
            Some(v) => v,
            None => self.limit_violation_now(),
        };
        let m = &mut self.metrics;
        m.max_limit_violation_solver_deg =
            m.max_limit_violation_solver_deg.max(solver.to_degrees());
        if self.settings.project_limits && !self.backend.enforces_limits() {
            self.project_limits();
        }
        self.measure_step();
        self.record_frames_until(self.time);
    }

    /// How many times per step the backend steps, events and motors between: the fast
    /// backend substeps inside one call.
    fn outer_steps(&self) -> usize {
        if self.backend.substeps_inside() {
            1
        } else {
            self.settings.collision_substeps
        }
    }

    /// Hands the impulses the events gave since the last call to the backend, in one call.
    fn flush_impulses(&mut self) {
        if !self.impulses.is_empty() {
            self.backend.apply_impulses(&self.impulses);
            self.impulses.clear();
        }
    }

    /// Stops the run at the last finite states (see [`World::step`]), recording this
    /// step's frames from them.
    fn halt(&mut self) {
        self.metrics.nan = true;
        self.halted = true;
        self.states.clone_from(&self.prev_states);
        self.time += self.settings.dt as f64;
        self.record_frames_until(self.time);
    }

    /// Grid entries and hash buckets of the particle backend's last search for colliding
    /// pairs (`None` on the rigid backend): for tests that its memory follows the number
    /// of bodies, not their size.
    #[doc(hidden)]
    pub fn broad_phase_footprint(&self) -> Option<(usize, usize)> {
        match &self.backend {
            AnyBackend::Particle(p) => Some(p.broad_phase_footprint()),
            AnyBackend::Rigid(_) | AnyBackend::Fast(_) | AnyBackend::Custom(_) => None,
        }
    }

    /// How many joints the backend worked on at each recorded frame: every joint but
    /// those of ragdolls put to rest (the first level of detail: a ragdoll at rest costs
    /// nothing until something touches it). `None` on the particle backend, which never
    /// rests.
    pub fn active_joints_per_frame(&self) -> Option<&[u32]> {
        (self.backend.active_joints().is_some() || !self.active_joints.is_empty())
            .then_some(self.active_joints.as_slice())
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
}

fn setting_error(setting: &str, message: &str) -> Error {
    Error::Setting {
        setting: setting.into(),
        message: message.into(),
    }
}
