//! The runtime half: a [`World`] owns ragdoll instances made from [`RagdollSpec`]s, the
//! ground and a backend; it steps at a fixed rate and records a [`Track`] per ragdoll plus
//! the quality [`Metrics`].
//!
//! This file holds the world and its stepping; `spawn.rs` adds a ragdoll, `start.rs` and
//! `overlap.rs` say where one may start, `record.rs` records frames and measures the metrics, and each kind of event
//! has its own file: `blast.rs` (blast loads), `forces.rs` (pushes, fields, pins),
//! `playback.rs` (clips and the hand-over to physics), `motors.rs` (powered mode).

use glam::Vec3;

mod blast;
mod depth;
mod forces;
mod motors;
mod overlap;
mod playback;
mod projectile;
mod record;
mod remove;
mod settings;
mod spawn;
mod start;

pub use crate::backend::{
    BackendConfig, BackendKind, DEFAULT_FAST_IMPACT_PASSES, DEFAULT_FAST_SUBSTEPS, FastConfig,
    MAX_FAST_ITERATIONS, MAX_SUBSTEPS, ParticleConfig, RigidConfig,
};
pub use forces::DragId;
pub use motors::Motors;
pub use playback::Activation;
pub use settings::{DEFAULT_JOINT_DAMPING, MAX_JOINT_DAMPING, StartPose, WorldSettings};
pub use start::MAX_COORDINATE_M;
use start::{beyond_world, within_world};

use crate::backend::{
    AnyBackend, Backend, BodyImpulse, BodyState, Command, StepReport, Surroundings,
};
use crate::error::{Error, Result};
use crate::events::{Projectile, ProjectileReport};
use crate::math::Transform;
use crate::skeleton::Character;
use crate::spec::{RagdollSpec, ResolvedJoint, Shape};
use crate::track::{Metrics, Track};

/// Standard gravity, m/s².
pub const STANDARD_GRAVITY: f32 = 9.80665;

pub use crate::bounds::{MAX_GRAVITY_MPS2, MAX_SECONDS};

/// Shortest and longest fixed step, seconds: 10 kHz (a shorter one only makes a run that
/// cannot finish) to 10 Hz (a longer one lets a falling body pass through another).
pub const STEP_RANGE_S: [f32; 2] = [1e-4, 0.1];

/// Highest output frame rate, frames per second.
pub const MAX_FPS: f32 = 1000.0;

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
    /// Each body's shape.
    shapes: Vec<Shape>,
    /// Each body's extra shapes, each at its place in the body frame.
    extras: Vec<Vec<(Shape, Transform)>>,
    /// Pairs of this ragdoll's bodies that do not collide (lower index first, sorted):
    /// the spec's, those that start inside each other, and those a hand-over found so.
    exempt_pairs: Vec<(usize, usize)>,
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
    /// Taken out of the world (`remove.rs`): its bodies meet nothing and its track holds
    /// its last pose.
    removed: bool,
    /// Joint motors tracking the clip (powered mode), if any.
    motors: Option<motors::MotorState>,
    /// Each skeleton joint's parent joint where physics holds the bone between them: both
    /// ride on one body, or on two bodies a ragdoll joint links. A foot the hierarchy hangs
    /// from the root (an IK rig) is held at its shin, not at the root, so the root-to-foot
    /// link is free to change and says nothing about the solver (`None`).
    held_bones: Vec<Option<usize>>,
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
    /// steps ([`Backend::apply`]).
    impulses: Vec<BodyImpulse>,
    /// The batch they go in (kept to reuse its memory).
    commands: Vec<Command>,
    /// What the backend said of this step's calls, the worst of each (see
    /// [`StepReport::absorb`]).
    step_report: StepReport,
}

impl World {
    /// An empty world.
    pub fn new(settings: &WorldSettings) -> Result<Self> {
        settings.validate()?;
        let backend = settings.backend.build_any(&Surroundings {
            gravity: settings.gravity,
            ground: settings.ground,
        });
        Ok(Self::with_any(settings, backend))
    }

    /// An empty world stepped by someone else's engine (see [`Backend`]). The world reads
    /// `settings` as for its own engines but for `backend`, and steps the engine once per
    /// step (`dt`): its substeps are its own. The engine must simulate the same `gravity`
    /// and `ground` (the world lifts ragdolls onto that ground and measures energy with
    /// that gravity), and holds its joints' limits itself (the world measures them, it
    /// does not clamp them: see [`crate::backend::limits`]).
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
            commands: Vec::new(),
            step_report: StepReport::default(),
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

    /// Linear (m/s) and angular (rad/s) velocities of ragdoll `id`'s bodies now, spec order.
    pub fn body_velocities(&self, id: RagdollId) -> Vec<(Vec3, Vec3)> {
        let inst = &self.instances[id.0];
        self.states[inst.first_body..inst.first_body + inst.masses.len()]
            .iter()
            .map(|s| (s.linvel, s.angvel))
            .collect()
    }

    /// The settings the world was made with.
    pub fn settings(&self) -> &WorldSettings {
        &self.settings
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

    /// Records the starting frame, once.
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
        !self.step_report.went_non_finite
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
        self.step_report = StepReport::default();
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
            self.flush_impulses();
            let report = self.backend.step(h);
            self.step_report.absorb(report);
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
        // What the solver left, before any clamp: the engine's own reading where it clamps
        // limits on positions, else the bodies as they are (nothing clamped them).
        let solver = match self.step_report.limit_violation_before_clamp_rad {
            Some(v) => v,
            None => self.limit_violation_now(),
        };
        let m = &mut self.metrics;
        m.max_limit_violation_solver_deg =
            m.max_limit_violation_solver_deg.max(solver.to_degrees());
        self.measure_step();
        // Likewise for joint gaps (after measuring what is recorded, which it bounds).
        let m = &mut self.metrics;
        let gap = self
            .step_report
            .joint_separation_before_clamp_m
            .unwrap_or(0.0)
            .max(m.max_joint_separation_m);
        m.max_joint_separation_solver_m = m.max_joint_separation_solver_m.max(gap);
        self.record_frames_until(self.time);
    }

    /// How many times per step the backend steps, events and motors between: the
    /// collision substeps of ours that find contacts once per call; one for the fast
    /// engine, which substeps inside, and for someone else's, whose substeps are its own.
    fn outer_steps(&self) -> usize {
        match self.backend {
            AnyBackend::Custom(_) => 1,
            _ => self.settings.backend.world_substeps(),
        }
    }

    /// Hands the impulses the events gave since the last call to the backend, in one call.
    fn flush_impulses(&mut self) {
        self.drop_impulses_on_removed();
        if !self.impulses.is_empty() {
            let mut commands = std::mem::take(&mut self.commands);
            commands.clear();
            commands.extend(self.impulses.drain(..).map(Command::Impulse));
            self.backend.apply(&commands);
            self.commands = commands;
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
