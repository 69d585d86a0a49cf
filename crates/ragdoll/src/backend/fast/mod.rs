//! The fast backend: our own rigid-body solver, built for ragdolls.
//!
//! Small-step extended position-based dynamics for rigid bodies (Müller et al. 2020,
//! "Detailed Rigid Body Simulation with Extended Position Based Dynamics"; Macklin et al.
//! 2019, "Small Steps in Physics Simulation"): every step is cut into many substeps of one
//! constraint pass each. A substep predicts each body's pose from its velocity, moves the
//! bodies so joints, limits and contacts hold (each constraint in closed form on the two
//! bodies it links, weighted by their generalised inverse masses; Coulomb friction on the
//! contacts' and limits' sideways motion), adds what the constraints moved to the
//! velocities, and takes the contacts' normal velocity away (restitution 0).
//!
//! Where it departs from the paper, each for a measured reason given where it is done: a
//! joint's anchor and a hinge's axis are solved as one 3×3 or 2×2 constraint rather than
//! along their error (`solve.rs`), a resting body answers a push down into what holds it
//! as a heavier one (shock propagation, `contact.rs`), limits have friction, an island in
//! which something is about to strike hard takes more passes that step (`impact.rs`),
//! and the world sees each body's motion over the whole step rather than its last
//! substep's velocity.
//!
//! Unlike the rigid backend, limits are constraints on positions inside the solver, so a
//! torso landing on an arm cannot push an elbow far past its limit for a frame; unlike the
//! particle backend, a body is one rigid frame with a true inertia tensor, so bones neither
//! stretch nor shear.
//!
//! Bodies are kept as arrays of positions, rotations and velocities (structure of arrays);
//! contacts are found once per step with the shared broad phase and their points again
//! every substep. Ragdolls that may touch form islands; an island whose bodies all stay
//! within [`SLEEP_DRIFT_M`] of where they were for [`SLEEP_AFTER_S`] sleeps (costs
//! nothing) until something touches or pushes it (`sleep.rs`). Below sleep, a joint that
//! has stopped moving freezes and the parts it links are one body in their island's
//! solver until a blow arrives (`freeze.rs`): a ragdoll in flight or settling costs a
//! fraction of one whose every joint moves.

/// Calls the macro `$m` with every array of the solver that holds one entry per body
/// (its state: pose, motion, mass, kinematic target), then with `$extra`: copying a body
/// into an island's solver (`island.rs`) or the seam between two halves (`split.rs`)
/// names them in one place.
macro_rules! body_state {
    ($m:ident $(, $extra:ident)*) => {
        $m!(
            pos,
            rot,
            prev_pos,
            prev_rot,
            moved,
            pred_rot,
            vel,
            angvel,
            step_pos,
            step_rot,
            seen_vel,
            seen_angvel,
            mass,
            inv_mass,
            inertia,
            inv_inertia,
            inv_inertia_world,
            kinematic
            $(, $extra)*
        )
    };
}

mod body;
mod box_box;
mod box_capsule;
mod clamp;
mod commands;
mod contact;
mod engine;
mod extras;
mod freeze;
mod impact;
mod island;
mod kept;
mod limits;
mod narrow;
mod relay;
mod skin;
mod sleep;
mod solve;
mod split;

use std::collections::HashSet;

use glam::{Quat, Vec3};

use super::damping::JointDamping;
use super::limits::LimitProjection;
use super::{BodyState, FastConfig, Surroundings};
use crate::math::Transform;
use crate::spec::Shape;
use limits::{Limits, Twist};

/// Static and dynamic friction of every contact: skin and clothing on a hard floor are
/// around 0.5-0.8 (the rigid backend's value).
const FRICTION: f32 = 0.7;
/// How long every point of a ragdoll must stay within [`SLEEP_DRIFT_M`] of where it was
/// before the ragdoll sleeps, seconds.
const SLEEP_AFTER_S: f32 = 0.5;
/// How far a point may wander in [`SLEEP_AFTER_S`] and still count as at rest, metres: an
/// average of 5 cm/s (rapier's default linear threshold is 0.1 m/s at 1 m scale, Jolt's
/// 0.03 m/s; a ragdoll's parts are smaller). A distance rather than a speed, as Jolt's
/// sleep test: a hand pinched in a pile twitches at tenths of a m/s for a frame now and
/// then without going anywhere. Measured on 24 piles of four humanoids (the last frame
/// anything moved): 4.2 s on average, 17 asleep by 5 s; by a speed limit of 5 cm/s
/// instead, 4.8 s and 13.
const SLEEP_DRIFT_M: f32 = 0.05 * SLEEP_AFTER_S;

/// Settings the fast backend takes from the world.
#[derive(Clone, Copy, Debug)]
pub(crate) struct FastSettings {
    /// Gravity, m/s².
    pub gravity: Vec3,
    /// Height of the ground plane, or `None` for no ground.
    pub ground: Option<f32>,
    /// Substeps per step.
    pub substeps: usize,
    /// Passes of the joints and contacts per substep.
    pub iterations: usize,
    /// Passes added in a step with an impact (`impact.rs`).
    pub impact_passes: usize,
    /// Whether quiet joints freeze (`freeze.rs`).
    pub freeze_joints: bool,
    /// Whether a pair's contact is carried over the substeps while its shapes barely
    /// move against each other (`kept.rs`).
    pub keep_contacts: bool,
}

#[cfg(test)]
impl FastSettings {
    /// One substep of one pass, no gravity, ground, impact passes or freezing: an engine
    /// whose tests look at its geometry, not its dynamics.
    pub(super) fn bare() -> Self {
        FastSettings {
            gravity: Vec3::ZERO,
            ground: None,
            substeps: 1,
            iterations: 1,
            impact_passes: 0,
            freeze_joints: false,
            keep_contacts: false,
        }
    }
}

/// A drive toward a relative rotation (see [`crate::backend::Backend::drive_joint`]).
#[derive(Clone, Copy, Debug)]
struct Drive {
    target: Quat,
    angvel: Vec3,
    stiffness: f32,
    damping: f32,
}

/// A joint between bodies `a` (parent) and `b` (child), global indices.
#[derive(Clone, Debug)]
struct Joint {
    a: usize,
    b: usize,
    frame_a: Transform,
    frame_b: Transform,
    limits: Limits,
    drive: Option<Drive>,
    /// Share of its correction a substep's pass applies: the lighter hub's of its two
    /// bodies (see [`crate::backend::hub::hub_relaxation`]).
    relax: f32,
    /// Whether it is frozen: its two bodies move as one (`freeze.rs`).
    frozen: bool,
    /// How long it has stayed quiet, seconds, and its relative rotation when the quiet
    /// spell began.
    quiet_s: f32,
    quiet_rel: Quat,
}

/// A point of a body tied to a moving world point.
#[derive(Clone, Copy, Debug)]
struct Pin {
    body: usize,
    local: Vec3,
    /// The anchor at the start and at the end of the coming step.
    from: Vec3,
    to: Vec3,
    soft: Option<(f32, f32)>,
    active: bool,
}

/// Where a kinematic body is at the start and at the end of the coming step.
#[derive(Clone, Copy, Debug)]
struct Kinematic {
    from: Transform,
    to: Transform,
}

/// One ragdoll's range of bodies and its sleep state.
#[derive(Clone, Debug)]
struct Ragdoll {
    bodies: std::ops::Range<usize>,
    joints: std::ops::Range<usize>,
    asleep: bool,
    /// How long its bodies have stayed near where they were at the start of this quiet
    /// spell ([`FastBackend::rest_pos`]), seconds; `None` before a spell starts.
    still_s: Option<f32>,
    /// Whether something outside holds or drives it (a pin, a drive, a kinematic body):
    /// such a ragdoll never sleeps.
    held: bool,
    /// How many times the world's substeps its island takes ([`substep_factor`]).
    substep_factor: f32,
    /// How many of its joints are frozen (`freeze.rs`).
    frozen: usize,
    /// Set by an island's solver when one of the ragdoll's compounds took a blow this
    /// step: its joints thaw.
    jolted: bool,
    /// The fastest one of its parts may strike the ground or another body in the coming
    /// step, m/s (`impact.rs`).
    closing_mps: f32,
    /// The distance tests its shapes took part in over the last step: where its island
    /// is cut in two, its share of the work (`split.rs`).
    tests: u32,
    /// Taken out of the simulation ([`crate::backend::Backend::remove_ragdoll`]): asleep for
    /// good, met by nothing.
    removed: bool,
}

/// The ragdoll's whole mass over its lightest body's, up to which the world's substeps
/// hold its limits: the built-in humanoid's 75 kg over its 0.45 kg hands is 167.
const PLAIN_MASS_RATIO: f32 = 200.0;
/// Most an island's substeps are raised, as a multiple of the world's.
const MAX_SUBSTEP_FACTOR: f32 = 3.0;

/// How many times the world's substeps a ragdoll of body `masses` needs: one pass a
/// substep moves a light body between heavy ones too little to hold it, and more substeps
/// make up for it. The Fox at its true size stands its 66 kg on 86 g paws (a ratio of
/// 773): at 32 substeps its ankles went 9° past their limits and the clamp that turned
/// them back gained 5 % energy; at 64, 2.8° and nothing to clamp. The factor grows as the
/// square root of the ratio past [`PLAIN_MASS_RATIO`] (a substep's error shrinks as its
/// square), up to [`MAX_SUBSTEP_FACTOR`].
fn substep_factor(masses: &[f32]) -> f32 {
    let total: f32 = masses.iter().sum();
    let lightest = masses.iter().copied().fold(f32::INFINITY, f32::min);
    if !(lightest > 0.0 && total.is_finite()) {
        return 1.0;
    }
    (total / lightest / PLAIN_MASS_RATIO)
        .sqrt()
        .clamp(1.0, MAX_SUBSTEP_FACTOR)
}

/// The `fast` engine: our rigid-body solver built for ragdolls.
pub struct FastBackend {
    settings: FastSettings,
    // Bodies, one entry each, global order.
    pos: Vec<Vec3>,
    rot: Vec<Quat>,
    prev_pos: Vec<Vec3>,
    prev_rot: Vec<Quat>,
    /// How far the constraints moved each body in this substep, summed as they move it
    /// (see [`FastBackend::update_velocities`]), and where its velocity alone turned it.
    moved: Vec<Vec3>,
    pred_rot: Vec<Quat>,
    vel: Vec<Vec3>,
    angvel: Vec<Vec3>,
    /// Poses at the start of the step, and the velocities the world sees: the motion
    /// over the step (see [`FastBackend::observe_velocities`]).
    step_pos: Vec<Vec3>,
    step_rot: Vec<Quat>,
    seen_vel: Vec<Vec3>,
    /// Each body's pose when its ragdoll's quiet spell began (the sleep test's reference;
    /// kept by the whole world's solver only, not an island's).
    rest_pos: Vec<Vec3>,
    rest_rot: Vec<Quat>,
    seen_angvel: Vec<Vec3>,
    mass: Vec<f32>,
    /// Inverse mass, 0 for a kinematic body.
    inv_mass: Vec<f32>,
    /// Principal moments of inertia in the body frame (the shapes' axes are principal).
    inertia: Vec<Vec3>,
    /// Their inverses, zero for a kinematic body.
    inv_inertia: Vec<Vec3>,
    /// The inverse inertia tensors in the world, as of the start of the substep; with
    /// 16-byte columns, so every product with one (a few per constraint) is three SIMD
    /// multiply-adds.
    inv_inertia_world: Vec<glam::Mat3A>,
    /// Shapes, one per body of the world; in an island's solver, one per body of the
    /// world it holds, with the solver body that carries it ([`FastBackend::owner`]).
    shape: Vec<Shape>,
    /// Which body carries each shape, and where in that body's frame where the body is a
    /// compound of parts whose joints are frozen (`freeze.rs`); `None`: the shape is the
    /// body's own, at its centre. Outside an island's solver every shape is its own body's.
    owner: Vec<u32>,
    attach: Vec<Option<Transform>>,
    /// What holds each shape up in this substep's contacts (see
    /// [`FastBackend::support_along`]).
    holder: Vec<u32>,
    /// In one half of an island cut in two (`split.rs`): what holds each shape from the
    /// other half, as of the seam's last pass, which each pass starts from; empty
    /// elsewhere.
    seam_holder: Vec<u32>,
    kinematic: Vec<Option<Kinematic>>,
    ragdoll_of: Vec<usize>,
    ragdolls: Vec<Ragdoll>,
    joints: Vec<Joint>,
    pins: Vec<Pin>,
    /// Unordered pairs (low, high) of bodies that never collide.
    disabled: HashSet<(u32, u32)>,
    collide: contact::Collide,
    /// Scratch of the sleep pass: each ragdoll's island parent, and whether each island
    /// may sleep.
    islands: Vec<usize>,
    island_ready: Vec<bool>,
    /// Scratch of the island pass: each ragdoll's island, each body's index in its
    /// island's solver, and the island solvers themselves.
    island_of: Vec<u32>,
    local_of: Vec<u32>,
    island_pool: Vec<FastBackend>,
    /// Each ragdoll's solver among them (an island cut in two has two, `split.rs`), and
    /// the solvers of the contacts between two halves.
    solver_of: Vec<u32>,
    seam_pool: Vec<split::Seam>,
    /// An island solver's compounds of bodies linked by frozen joints (`freeze.rs`).
    compounds: Vec<freeze::Compound>,
    /// The whole world's bodies' extra shapes (`extras.rs`).
    extras: extras::Extras,
    /// Skin points (`skin.rs`), and the ones that touched the ground in this substep.
    skin: Vec<skin::SkinPoint>,
    skin_touching: Vec<u32>,
    /// The end-of-step limit projection (`clamp.rs`); `None` when it is off, and in an
    /// island's solver (the world's solver projects once the islands are back).
    limits: Option<LimitProjection>,
    /// Passive joint damping, applied at the start of each step (`clamp.rs`).
    damping: JointDamping,
}

impl FastBackend {
    /// An empty fast world in `surroundings`.
    pub fn new(config: &FastConfig, surroundings: &Surroundings) -> Self {
        let mut engine = Self::with_settings(FastSettings {
            gravity: surroundings.gravity,
            ground: surroundings.ground,
            substeps: config.substeps,
            iterations: config.iterations,
            impact_passes: config.impact_passes,
            freeze_joints: config.freeze_joints,
            keep_contacts: config.keep_contacts,
        });
        engine.limits = config.project_limits.then(LimitProjection::default);
        engine
    }

    /// An empty solver with these settings: the world's, or one island's.
    pub(crate) fn with_settings(settings: FastSettings) -> Self {
        FastBackend {
            settings,
            pos: Vec::new(),
            rot: Vec::new(),
            prev_pos: Vec::new(),
            prev_rot: Vec::new(),
            moved: Vec::new(),
            pred_rot: Vec::new(),
            vel: Vec::new(),
            angvel: Vec::new(),
            step_pos: Vec::new(),
            step_rot: Vec::new(),
            seen_vel: Vec::new(),
            rest_pos: Vec::new(),
            rest_rot: Vec::new(),
            seen_angvel: Vec::new(),
            mass: Vec::new(),
            inv_mass: Vec::new(),
            inertia: Vec::new(),
            inv_inertia: Vec::new(),
            inv_inertia_world: Vec::new(),
            shape: Vec::new(),
            owner: Vec::new(),
            attach: Vec::new(),
            holder: Vec::new(),
            seam_holder: Vec::new(),
            kinematic: Vec::new(),
            ragdoll_of: Vec::new(),
            ragdolls: Vec::new(),
            joints: Vec::new(),
            pins: Vec::new(),
            disabled: HashSet::new(),
            collide: contact::Collide::default(),
            islands: Vec::new(),
            island_ready: Vec::new(),
            island_of: Vec::new(),
            local_of: Vec::new(),
            island_pool: Vec::new(),
            solver_of: Vec::new(),
            seam_pool: Vec::new(),
            compounds: Vec::new(),
            extras: extras::Extras::default(),
            skin: Vec::new(),
            skin_touching: Vec::new(),
            limits: None,
            damping: JointDamping::default(),
        }
    }
}

impl FastBackend {
    /// Body `i` as the world reads it.
    fn state_of(&self, i: usize) -> BodyState {
        BodyState {
            pose: Transform::new(self.pos[i], self.rot[i]),
            linvel: self.seen_vel[i],
            angvel: self.seen_angvel[i],
        }
    }
}

/// Largest single turn of a body in the position pass, radians.
const MAX_TURN_RAD: f32 = 0.5;

/// The smallest moment of inertia a body is given, kg·m²: a point-like body would
/// otherwise turn without bound under the smallest off-centre push.
const MIN_INERTIA: f32 = 1.0e-7;
