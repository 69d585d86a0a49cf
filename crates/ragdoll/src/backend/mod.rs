//! Physics backends behind one interface, so the world, the events, the metrics and the
//! exporters never see which engine moved the bodies.
//!
//! Ours, each with its own settings in one variant of [`BackendConfig`] (the world's
//! settings carry one; [`BackendConfig::build`] builds the engine alone):
//! - `rigid` ([`RigidBackend`]): rapier3d rigid bodies and impulse joints (the reference);
//! - `particle` ([`ParticleBackend`]): our own position-based particle ragdoll
//!   (XPBD-style), for creatures;
//! - `fast` ([`FastBackend`]): our own rigid-body solver built for ragdolls (small-step
//!   XPBD), for crowds.
//!
//! Another engine (a GPU solver, a game engine's physics) plugs in by implementing
//! [`Backend`] and handing it to [`World::with_backend`](crate::world::World::with_backend):
//! the world then places ragdolls, plays clips, applies blasts, shots, fields, pins and
//! motors, measures and records through it alone. The seam is batched where a world step
//! is: the world reads every body's state in one call ([`Backend::body_states`]) after
//! each step, and hands over its changes (each step's event impulses, kinematic targets,
//! poses, joint frames, pins) as [`Command`]s in one call ([`Backend::apply`]) before it. What only the solver knows of a step (its
//! deepest contact, its limits before its own clamp) comes back from [`Backend::step`]
//! as a [`StepReport`], not through queries the world must know to ask.
//! `tests/custom_backend.rs` holds a whole backend written against this interface alone.
//!
//! The physics stays below the seam: an engine holds its joints inside their limits
//! itself. An engine whose solver holds limits on velocities only (rapier does) can keep
//! them on positions with the shared [`limits::LimitProjection`], as `rigid` does; the
//! world never moves a body to mend what an engine left.

mod command;
mod config;
pub mod damping;
pub mod drive;
pub(crate) mod fast;
pub(crate) mod hub;
pub mod limits;
pub(crate) mod particle;
mod ragdolls;
pub(crate) mod rigid;
pub(crate) mod tree;

use serde::{Deserialize, Serialize};

pub use command::Command;
pub(crate) use command::{OneAtATime, apply_each};
pub use config::{
    BackendConfig, DEFAULT_FAST_IMPACT_PASSES, DEFAULT_FAST_SUBSTEPS, FastConfig,
    MAX_FAST_ITERATIONS, MAX_SUBSTEPS, ParticleConfig, RigidConfig, Surroundings,
};
pub use fast::FastBackend;
pub use particle::ParticleBackend;
pub use rigid::RigidBackend;

use glam::Vec3;

use crate::math::Transform;

/// The state of one body after a step: world pose of its centre frame and velocities.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodyState {
    /// World transform of the body frame (unit scale).
    pub pose: Transform,
    /// Linear velocity of the centre of mass, m/s.
    pub linvel: Vec3,
    /// Angular velocity, rad/s, world space.
    pub angvel: Vec3,
}

/// Which engine moves the bodies ([`WorldSettings::backend`](crate::world::WorldSettings)).
///
/// # Example
///
/// ```
/// use ragdoll::world::{BackendKind, World, WorldSettings};
///
/// let kind = BackendKind::from_name("particle").unwrap();
/// assert_eq!(kind.as_str(), "particle");
/// let settings = WorldSettings { backend: kind.into(), ..Default::default() };
/// let character = ragdoll::skeleton::humanoid();
/// let spec = ragdoll::spec::build_spec(&character, &Default::default()).unwrap();
/// let (mut world, _) = World::with_ragdoll(&character, &spec, &settings).unwrap();
/// world.run(0.1);
/// assert!(!world.metrics().nan);
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BackendKind {
    /// rapier3d rigid bodies and impulse joints: the accurate default.
    #[default]
    Rigid,
    /// Our position-based particle ragdoll (XPBD-style projections with substeps), for
    /// crowds and creatures built from meshes; joints may open and bones stretch by a few
    /// millimetres.
    Particle,
    /// Our rigid-body solver built for ragdolls: small-step position-based dynamics of
    /// rigid bodies (Müller et al. 2020), with limits held inside the solver and ragdolls
    /// that sleep at rest; for crowds.
    Fast,
}

impl BackendKind {
    /// Every backend, the default first.
    pub const ALL: [BackendKind; 3] =
        [BackendKind::Rigid, BackendKind::Particle, BackendKind::Fast];

    /// One line on what the backend is for (the command line's help).
    pub fn summary(self) -> &'static str {
        match self {
            BackendKind::Rigid => "rapier3d rigid bodies and joints: the reference",
            BackendKind::Particle => "our position-based particle ragdoll, for creatures",
            BackendKind::Fast => "our rigid-body solver built for ragdolls, for crowds",
        }
    }

    /// The name used in files, reports and on the command line (`rigid`, `particle`,
    /// `fast`).
    pub fn as_str(self) -> &'static str {
        match self {
            BackendKind::Rigid => "rigid",
            BackendKind::Particle => "particle",
            BackendKind::Fast => "fast",
        }
    }

    /// The backend named `name`, if there is one.
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "rigid" => Some(BackendKind::Rigid),
            "particle" => Some(BackendKind::Particle),
            "fast" => Some(BackendKind::Fast),
            _ => None,
        }
    }
}

/// A body of an engine: its place in the order bodies were added, from 0 (a ragdoll's
/// bodies are contiguous, from the one [`Backend::add_ragdoll`] returned). Typed, so a
/// joint's or a pin's number cannot be passed where a body's is meant.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct BodyId(pub usize);

/// A joint of an engine: its place in the order joints were added, from 0.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct JointId(pub usize);

/// A pin an engine made ([`Backend::add_pin`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct PinId(pub usize);

/// What an engine says about one step besides the bodies' states ([`Backend::step`]):
/// readings only its solver has, so that the world's metrics measure the solver itself
/// and not only the poses it ends with.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepReport {
    /// Deepest contact penetration its contacts saw in the step, metres (0 when none).
    pub max_penetration_m: f32,
    /// For an engine that keeps joints inside their limits on positions, clamping them
    /// after solving (its own way, or with the shared [`limits::LimitProjection`]): the
    /// worst limit violation of a joint with a dynamic body, radians, as its solver left
    /// it, before that clamp. `None` for an engine that does not clamp: the world then
    /// reads the bodies as they are.
    pub limit_violation_before_clamp_rad: Option<f32>,
    /// For an engine that also narrows joint gaps on positions after solving (the shared
    /// [`limits::LimitProjection::closing_gaps`]): the widest gap as its solver left it,
    /// metres, before that. `None` for an engine that does not: the world reads the
    /// bodies as they are.
    pub joint_separation_before_clamp_m: Option<f32>,
    /// Whether a body's state went non-finite in a way [`Backend::body_states`] does not
    /// show: rapier rolls such a body back, zeroes its velocities and disables it (its
    /// quarantine). The world then stops the run as for a non-finite state.
    pub went_non_finite: bool,
}

impl StepReport {
    /// Folds in the report of a later step of the same world step: the worst limit
    /// violation and joint gap before any clamp, any non-finite body, and the last step's
    /// penetration. The penetration of the collision substeps before the last is not read: the metric has always been
    /// the last substep's, and over all four the rigid engine lets a body 35 mm into the
    /// ground where the last reads 28 mm (10 kg of TNT 3 m from CesiumMan, the command
    /// line's blast test), past the 3 cm the tests hold every run to; reading them waits
    /// until that engine keeps such a landing within the bound.
    pub(crate) fn absorb(&mut self, later: StepReport) {
        self.max_penetration_m = later.max_penetration_m;
        let worst = |a: Option<f32>, b: Option<f32>| match (a, b) {
            (Some(a), Some(b)) => Some(a.max(b)),
            (a, b) => a.or(b),
        };
        self.limit_violation_before_clamp_rad = worst(
            self.limit_violation_before_clamp_rad,
            later.limit_violation_before_clamp_rad,
        );
        self.joint_separation_before_clamp_m = worst(
            self.joint_separation_before_clamp_m,
            later.joint_separation_before_clamp_m,
        );
        self.went_non_finite |= later.went_non_finite;
    }
}

/// An impulse the world's events give one body, delivered before the next
/// step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BodyImpulse {
    /// `impulse` (N·s, world) at the world `point`: blasts, shots, pushes, drag, soft pins.
    AtPoint {
        /// The body.
        body: BodyId,
        /// N·s, world.
        impulse: Vec3,
        /// Where it acts, world.
        point: Vec3,
    },
    /// An angular impulse (N·m·s, world): joint motors and damping applied from outside
    /// the solver, in equal and opposite pairs.
    Angular {
        /// The body.
        body: BodyId,
        /// N·m·s, world.
        impulse: Vec3,
    },
}

impl BodyImpulse {
    /// The equal and opposite angular impulses a joint's torque gives its child and its
    /// parent: what motors and damping applied from outside the solver
    /// give.
    pub(crate) fn joint_pair(child: BodyId, parent: BodyId, impulse: Vec3) -> [BodyImpulse; 2] {
        [
            BodyImpulse::Angular {
                body: child,
                impulse,
            },
            BodyImpulse::Angular {
                body: parent,
                impulse: -impulse,
            },
        ]
    }
}

/// What an engine does for the [`World`](crate::world::World).
///
/// Bodies and joints are numbered in the order they were added ([`BodyId`], [`JointId`]; a
/// ragdoll's bodies are contiguous, starting at what [`Backend::add_ragdoll`] returned);
/// every pose is the body frame of [`BodyDesc::pose`]. Units are SI, Y is up, gravity and the ground
/// come from the backend's own settings (see [`World::with_backend`]).
///
/// A backend must be `Send` so a world can move to a worker thread (the viewer and the
/// CLI's progress bar do that).
///
/// [`World::with_backend`]: crate::world::World::with_backend
pub trait Backend: Send {
    /// Adds one ragdoll's bodies (world poses), joints (between its bodies) and pairs that
    /// never collide (indices into `bodies`); returns its first body.
    fn add_ragdoll(
        &mut self,
        bodies: &[BodyDesc],
        joints: &[JointDesc],
        disabled_pairs: &[(usize, usize)],
    ) -> BodyId;
    /// Adds skin points to the ragdoll whose first body is `first_body` (the skin its
    /// shapes leave loose, which the world finds as it places the ragdoll): points several
    /// bodies carry together,
    /// to be kept above the ground as the weighted blend of where each carries them.
    /// Returns whether the backend keeps them; by default it does not, and the bodies'
    /// own and extra shapes are all that hold the skin.
    fn add_skin_points(&mut self, first_body: BodyId, points: &[SkinPointDesc]) -> bool {
        let _ = (first_body, points);
        false
    }
    /// Takes the ragdoll whose first body is `first_body` out of the simulation: its
    /// bodies stop where they are, nothing meets them (contacts, rays) and they carry no
    /// kinetic energy; their indices stay valid (and their states readable) so that the
    /// other ragdolls' do not change. Returns whether the backend can; by default it
    /// cannot, and the world then refuses to remove a ragdoll.
    fn remove_ragdoll(&mut self, first_body: BodyId) -> bool {
        let _ = first_body;
        false
    }
    /// Advances the simulation by `dt` seconds and says what the step saw besides the
    /// bodies' states.
    fn step(&mut self, dt: f32) -> StepReport;
    /// Half the side of the square ground it has, metres, where its ground is not a
    /// plane without end (rapier's is a box): the world refuses ragdolls placed beyond it.
    fn ground_half_extent(&self) -> Option<f32> {
        None
    }
    /// Applies the world's changes since the last step, in the order given ([`Command`]):
    /// its events' impulses, kinematic targets, velocities, poses, joint frames and
    /// limits, gravity, pins. One call per batch, so an engine that keeps its bodies
    /// elsewhere (a GPU) takes a batch in one transfer.
    fn apply(&mut self, commands: &[Command]);
    /// Writes the state of every body of every ragdoll, in insertion order.
    fn body_states(&self, out: &mut Vec<BodyState>);
    /// Writes the states of the bodies from `first` on, one into each entry of `out`: the
    /// world reads one ragdoll's as it adds it or sets it playing its clip, where reading
    /// the whole world for each of a crowd's characters was quadratic. The default reads
    /// every body and copies the range; an engine overrides it to read only the range.
    fn body_states_of(&self, first: BodyId, out: &mut [BodyState]) {
        let mut all = Vec::new();
        self.body_states(&mut all);
        if let Some(range) = all.get(first.0..first.0 + out.len()) {
            out.copy_from_slice(range);
        }
    }
    /// Kinetic energy of everything, joules.
    fn kinetic_energy(&self) -> f64;
    /// How many joints the solver works on now: those of ragdolls that are not asleep.
    /// `None` where the backend never puts anything to rest (the count would always be
    /// every joint).
    fn active_joints(&self) -> Option<usize> {
        None
    }
    /// The first body a ray from `origin` along `dir` (unit) meets within `max_dist`
    /// metres, and the distance. The ground does not count.
    fn cast_ray(&self, origin: Vec3, dir: Vec3, max_dist: f32) -> Option<(BodyId, f32)>;
    /// Ties the point `local` (in body `body`'s frame) to the world point `target` with a
    /// ball joint to an invisible kinematic anchor: hard, or a spring of `soft` =
    /// (natural frequency Hz, damping ratio). Returns the pin.
    fn add_pin(
        &mut self,
        body: BodyId,
        local: Vec3,
        target: Vec3,
        soft: Option<(f32, f32)>,
    ) -> PinId;
    /// One flag per body (global order) into `out`: whether it touches a body of another
    /// ragdoll (the ground does not count). One pass for every ragdoll: asking ragdoll by
    /// ragdoll went through every contact pair once per waiting character.
    fn bodies_touching_other_ragdolls(&self, out: &mut Vec<bool>);
    /// Drives joint `joint` inside the solver toward the relative rotation
    /// `target` (the child body's rotation in the parent body's frame) turning at
    /// `target_angvel` (rad/s, child relative to parent, in the parent body's frame), as a
    /// damped spring of `stiffness` (1/s²) and `damping` (1/s) per unit of inertia.
    /// `stiffness` and `damping` 0 remove the drive. The world calls it every step for
    /// every joint of a powered ragdoll; drives are the engine's (an engine without
    /// them leaves the ragdoll limp: the world applies no torques on its behalf).
    ///
    /// A solver drive sees the whole chain at once: a torque applied from outside reaches
    /// only the child body within a substep, so it cannot be sized for what the joint
    /// carries, and the arms and head lagged the clip by tens of degrees that way. An
    /// engine with no drives in its solver can still drive with torques, softer, with the
    /// shared [`drive::TorqueDrives`] (as `particle` does).
    fn drive_joint(
        &mut self,
        joint: JointId,
        target: glam::Quat,
        target_angvel: Vec3,
        stiffness: f32,
        damping: f32,
    );
}

/// A body to create, in world space.
#[derive(Clone, Debug)]
pub struct BodyDesc {
    /// Start pose of the body frame (shape centre, long axis = local Y).
    pub pose: Transform,
    /// Collision shape.
    pub shape: crate::spec::Shape,
    /// More shapes it collides with, each with its place in the body frame
    /// ([`crate::spec::BodySpec::extra_shapes`]): they meet the ground, other ragdolls and
    /// rays, not the bodies of their own ragdoll, and the mass is spread over them and
    /// `shape` by volume for the inertia (about `shape`'s centre, which stays the centre of
    /// mass).
    pub extra_shapes: Vec<(crate::spec::Shape, Transform)>,
    /// Mass, kg.
    pub mass: f32,
    /// Initial linear velocity, m/s.
    pub linvel: Vec3,
    /// Initial angular velocity, rad/s.
    pub angvel: Vec3,
}

/// A point of skin several bodies of one ragdoll carry ([`Backend::add_skin_points`]).
#[derive(Clone, Debug, PartialEq)]
pub struct SkinPointDesc {
    /// Each body (index within the ragdoll), its share of the point (the shares sum to
    /// one) and the point in that body's frame; at most four (a vertex's joints), each
    /// body once.
    pub parts: Vec<(usize, f32, Vec3)>,
}

/// A joint to create between two bodies of the same ragdoll (indices into the ragdoll's
/// bodies), with its frame expressed in each body's frame.
#[derive(Clone, Debug)]
pub struct JointDesc {
    /// Parent body index within the ragdoll.
    pub parent: usize,
    /// Child body index within the ragdoll.
    pub child: usize,
    /// Joint frame in the parent body's frame (the cone's centre for swing-twist).
    pub frame_parent: Transform,
    /// Joint frame in the child body's frame.
    pub frame_child: Transform,
    /// Kind and limits.
    pub kind: crate::spec::JointKind,
}

/// One of the backends, chosen at run time ([`BackendKind`]).
///
/// An enum rather than a `Box<dyn Backend>` for ours: their calls dispatch with a match
/// the optimiser can see through; someone else's goes through the trait object.
pub(crate) enum AnyBackend {
    /// rapier3d.
    Rigid(Box<rigid::RigidBackend>),
    /// Our particles.
    Particle(Box<particle::ParticleBackend>),
    /// Our rigid-body solver.
    Fast(Box<fast::FastBackend>),
    /// Someone else's ([`World::with_backend`](crate::world::World::with_backend)).
    Custom(Box<dyn Backend>),
}

/// Forwards each listed trait method to the backend inside (`ref` methods take `&self`,
/// `mut` ones `&mut self`).
macro_rules! forward {
    ($( $kind:ident fn $name:ident($($arg:ident : $ty:ty),*) $(-> $ret:ty)?; )*) => {
        $( forward!(@one $kind $name ($($arg : $ty),*) $(-> $ret)?); )*
    };
    (@one ref $name:ident ($($arg:ident : $ty:ty),*) $(-> $ret:ty)?) => {
        fn $name(&self $(, $arg: $ty)*) $(-> $ret)? {
            match self {
                AnyBackend::Rigid(b) => b.$name($($arg),*),
                AnyBackend::Particle(b) => b.$name($($arg),*),
                AnyBackend::Fast(b) => b.$name($($arg),*),
                AnyBackend::Custom(b) => b.$name($($arg),*),
            }
        }
    };
    (@one mut $name:ident ($($arg:ident : $ty:ty),*) $(-> $ret:ty)?) => {
        fn $name(&mut self $(, $arg: $ty)*) $(-> $ret)? {
            match self {
                AnyBackend::Rigid(b) => b.$name($($arg),*),
                AnyBackend::Particle(b) => b.$name($($arg),*),
                AnyBackend::Fast(b) => b.$name($($arg),*),
                AnyBackend::Custom(b) => b.$name($($arg),*),
            }
        }
    };
}

impl Backend for AnyBackend {
    forward! {
        mut fn add_ragdoll(bodies: &[BodyDesc], joints: &[JointDesc], disabled_pairs: &[(usize, usize)]) -> BodyId;
        mut fn add_skin_points(first_body: BodyId, points: &[SkinPointDesc]) -> bool;
        mut fn remove_ragdoll(first_body: BodyId) -> bool;
        mut fn step(dt: f32) -> StepReport;
        ref fn ground_half_extent() -> Option<f32>;
        mut fn apply(commands: &[Command]);
        ref fn body_states(out: &mut Vec<BodyState>);
        ref fn body_states_of(first: BodyId, out: &mut [BodyState]);
        ref fn kinetic_energy() -> f64;
        ref fn active_joints() -> Option<usize>;
        ref fn cast_ray(origin: Vec3, dir: Vec3, max_dist: f32) -> Option<(BodyId, f32)>;
        mut fn drive_joint(joint: JointId, target: glam::Quat, target_angvel: Vec3, stiffness: f32, damping: f32);
        mut fn add_pin(body: BodyId, local: Vec3, target: Vec3, soft: Option<(f32, f32)>) -> PinId;
        ref fn bodies_touching_other_ragdolls(out: &mut Vec<bool>);
    }
}
