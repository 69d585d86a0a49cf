//! The particle backend: our own position-based ragdoll (XPBD-style projections with
//! substeps), cheap enough for crowds.
//!
//! # Model
//!
//! Every body is a small rigid set of particles whose frame is read straight off their
//! positions, so no orientation is carried as state and a pass over a ragdoll is a few
//! dozen distance projections plus the limits that are out of range.
//!
//! - **Particles** sit at the joint anchors (shared by the two bodies a joint links) and
//!   at the far end of leaf bodies (a tip). Each body adds two private particles: a
//!   **side** particle off its anchors (beside the bone of a stick, off the plane of a
//!   cluster's anchors), which makes the particles span 3-D so the frame, twist included,
//!   follows from positions; and a **centre** particle carrying the rest of the mass,
//!   placed so the body's centre of mass is the spec's. A stick's anchors take the
//!   three-point rule (ends `I/(p(p+q))`, `I/(q(p+q))`: Simpson's m/6, 2m/3, m/6 for a thin
//!   rod), so its moment of inertia across the bone is the spec's; the side particle's mass
//!   times its distance squared is the moment about the bone.
//! - **Rigidity**: distance constraints between every pair of a body's anchors, tip and
//!   side particle (three for a stick), and an affine constraint that keeps the centre at
//!   its fixed combination of the frame particles (linear, so one projection is exact).
//! - **Frames**: a body's rotation is the orthonormal frame of three of its particles
//!   (Gram-Schmidt) times that frame's inverse at rest.
//! - **Joint limits** (cone, twist, hinge range, fixed) are position projections: the
//!   child is turned back inside the limits that [`ResolvedJoint::clamp_child_rotation`]
//!   gives, the same measure the world's metrics use. Child and parent turn about their
//!   own centres of mass in opposite senses, by their inverse inertias (XPBD's angular
//!   correction), so a projection never changes momentum; the distance constraints then
//!   close the joint the turns opened. A body with a held particle cannot turn freely: the
//!   other side turns about the joint alone. The limits are solved twice a pass, the
//!   second time last. After the substeps, what is still more than 3° past a limit (a
//!   hard landing on a straight knee) is turned back positions-only, the subtree about
//!   the joint (or the rest of the ragdoll, whichever stays out of the floor).
//! - **Collision**: each body's capsule (boxes become the capsule along their longest edge,
//!   the radius the smaller of the other two half edges, so nothing sinks into the floor)
//!   against the ground plane and against every capsule not filtered out, of its own or
//!   another ragdoll: a hierarchical hash grid (`backend::broad`, a few cells per body
//!   whatever its size or speed), run every few steps with a margin for the motion in
//!   between, gives the candidate pairs, solved from the floor up. A contact moves each
//!   body as one rigid body (its particles' mass and inertia at the contact point), with
//!   positional friction (static up to μ times the depth); a body resting on the floor
//!   answers one above it as if heavier (mass scaling), so a pile's weight reaches the
//!   floor in one pass.
//! - **Ray casts** (projectiles) meet each body's own shape, a box as a box.
//! - Pins and impulses act on points of a body: a pin's correction is spread over the
//!   body's anchors and centre with the weights of its affine (least-norm) combination of
//!   them; an impulse changes the body's particles' velocities as a rigid body's.
//!
//! # Approximations
//!
//! - The side particle's mass moves the moment of inertia about one axis across the bone by
//!   the moment about the bone (a few per cent of the across moment for a limb).
//! - A cluster (pelvis, chest) holds half its mass on its anchors and the rest at its
//!   centre: its inertia is the particles', not the box's.
//! - A contact or a limit turn moves a body rigidly, anchors included, so its neighbours
//!   bend until the distances close them again: joints open by millimetres in a pile.
//! - Mass scaling does not keep momentum: a body landing on a resting pile is pushed back
//!   more than the pile is pushed down.
//! - Kinematic bodies follow their targets linearly over the substeps.

mod body;
mod build;
mod collide;
mod extras;
mod points;
mod solve;

use glam::{Mat3, Quat, Vec3, Vec4};

use super::drive::TorqueDrives;
use super::tree::JointTree;
use super::{
    Backend, BodyDesc, BodyId, BodyState, Command, JointDesc, JointId, OneAtATime, ParticleConfig,
    PinId, StepReport, Surroundings, apply_each,
};
use crate::math::Transform;
use crate::spec::{JointKind, ResolvedJoint, Shape};

/// Friction of body-body and body-ground contacts (as the rigid backend: skin and clothing
/// on a hard floor are around 0.5-0.8).
const FRICTION: f32 = 0.7;
/// What the particle backend reads of its configuration and surroundings.
#[derive(Clone, Copy, Debug)]
struct ParticleSettings {
    /// Gravity, m/s².
    pub gravity: Vec3,
    /// Height of the ground plane, or `None` for no ground.
    pub ground: Option<f32>,
    /// Substeps per step (each predicts, projects and updates velocities).
    pub substeps: usize,
    /// Projection passes per substep.
    pub iterations: usize,
}

/// One body: a set of particles and what is needed to get its frame back from them.
#[derive(Clone, Debug)]
struct Body {
    /// Index of the ragdoll it belongs to.
    ragdoll: u32,
    /// Its particles: `parts[first..first + count]`.
    first: u32,
    count: u32,
    /// The three particles whose orthonormal frame gives the body's rotation.
    triad: [u32; 3],
    /// Inverse of that frame at rest, in the body frame, and the first one's rest offset.
    tri_inv: Quat,
    tri_origin: Vec3,
    /// The spec's shape (ray casts hit it; contacts use the capsule below).
    shape: Shape,
    /// Its extra shapes, each at its place in the body frame (`extras.rs`).
    extras: Vec<(Shape, Transform)>,
    /// Capsule segment ends in the body frame and radius.
    e: [Vec3; 2],
    radius: f32,
    /// Mean of the particles' rest offsets (the affine weights are centred on it).
    rbar: Vec3,
    mass: f32,
    /// Centre of mass of its particles (their full masses, shared ones included) and the
    /// inverse of their moment of inertia about it, body frame: what a limit turn uses.
    com: Vec3,
    inv_inertia: Mat3,
    /// Inverse of the sum of those masses.
    inv_mass: f32,
    /// Current frame.
    rot: Quat,
    pos: Vec3,
    /// Rotation at the start of the last step (for the angular velocity).
    rot_prev: Quat,
    kinematic: bool,
    /// Taken out of the simulation ([`Backend::remove_ragdoll`]): held still, met by
    /// nothing.
    removed: bool,
}

/// A distance between two particles.
#[derive(Clone, Copy, Debug)]
struct Distance {
    a: u32,
    b: u32,
    len: f32,
    /// Share of its correction a pass applies: its body's
    /// ([`crate::backend::hub::hub_relaxation`]).
    relax: f32,
}

/// Particle `c` stays at `Σ alpha[k] · x[refs[k]]` (the weights sum to one).
#[derive(Clone, Copy, Debug)]
struct Affine {
    c: u32,
    refs: [u32; 4],
    alpha: [f32; 4],
}

/// A point of a body held at a target.
#[derive(Clone, Debug)]
struct Pin {
    body: u32,
    local: Vec3,
    from: Vec3,
    target: Vec3,
    soft: Option<(f32, f32)>,
    active: bool,
}

/// Collision filter of one ragdoll: a bit matrix over its bodies.
#[derive(Clone, Debug)]
struct Filter {
    first_body: u32,
    bodies: u32,
    /// Offset of its bits in `ParticleBackend::filter_bits`.
    offset: usize,
}

/// The `particle` engine: every ragdoll's particles, bodies and constraints in flat
/// arrays.
pub struct ParticleBackend {
    settings: ParticleSettings,
    // Particles.
    x: Vec<Vec3>,
    x_prev: Vec<Vec3>,
    /// Where the prediction put each particle: the velocity update adds only what the
    /// projections moved (`x − x_pred`), so positions far from the origin (a fall from
    /// 100 m) do not round the velocity away.
    x_pred: Vec<Vec3>,
    v: Vec<Vec3>,
    m: Vec<f32>,
    /// Inverse mass (0 while kinematic).
    w: Vec<f32>,
    /// How many kinematic bodies hold each particle.
    kin: Vec<u16>,
    kin_from: Vec<Vec3>,
    kin_to: Vec<Vec3>,
    // Bodies.
    bodies: Vec<Body>,
    /// Particle indices of each body (see `Body::first`).
    parts: Vec<u32>,
    /// Rest offsets of those particles in the body frame.
    rest: Vec<Vec3>,
    /// Affine rows: a body-frame point `q` is `Σ βᵢ xᵢ` with `βᵢ = rowᵢ.xyz·(q − rbar) + rowᵢ.w`.
    affine: Vec<Vec4>,
    /// Weights of the two capsule ends.
    beta_e: [Vec<f32>; 2],
    /// Weights of the body origin (its velocity).
    beta_o: Vec<f32>,
    /// The capsule ends' offsets from their affine reconstruction, body frame.
    resid_e: Vec<[Vec3; 2]>,
    // Constraints.
    distances: Vec<Distance>,
    affines: Vec<Affine>,
    joints: Vec<ResolvedJoint>,
    /// Each joint's limits as the inside test reads them.
    bounds: Vec<solve::Bounds>,
    /// Each ragdoll's first joint and its joint tree (each joint's subtree).
    trees: Vec<(u32, JointTree)>,
    /// Every joint, parents before children.
    joint_order: Vec<u32>,
    /// Marks of the last pass that touched each particle and body (see `project_limits`).
    stamp: Vec<u32>,
    body_stamp: Vec<u32>,
    epoch: u32,
    pins: Vec<Pin>,
    filters: Vec<Filter>,
    filter_bits: Vec<u64>,
    /// Pairs of bodies of different ragdolls that must not collide.
    cross_disabled: Vec<(u32, u32)>,
    // Per-step scratch and results.
    grid: collide::Grid,
    pairs: Vec<(u32, u32)>,
    /// Each body's capsule ends during a contact pass.
    caps: Vec<[Vec3; 2]>,
    /// Steps the candidate pairs are still good for (0: find them again).
    pairs_left: u32,
    touched: Vec<bool>,
    /// Bodies on the floor, or on a body on the floor, in this step (see `solve_pairs`).
    supported: Vec<bool>,
    penetration: f32,
    /// Worst limit violation the substeps left in the last step, before the end-of-step
    /// projection (radians).
    solver_violation: f32,
    /// Length of the last step, seconds.
    last_dt: f32,
    /// Weight buffers for pins and contacts.
    scratch: Vec<f32>,
    /// Which bodies an active pin holds (see `project_limits`).
    pinned: Vec<bool>,
    /// Powered ragdolls' drives, as torques at the start of each step: the position
    /// solver has no drives of its own.
    drives: TorqueDrives,
}

/// The orthonormal frame of three points: X along `x1 − x0`, Y toward `x2` in their plane.
pub(super) fn triad_frame(x0: Vec3, x1: Vec3, x2: Vec3) -> Quat {
    let u = (x1 - x0).normalize_or(Vec3::X);
    let v0 = x2 - x0;
    let v = (v0 - u * v0.dot(u)).normalize_or(u.any_orthonormal_vector());
    Quat::from_mat3(&Mat3::from_cols(u, v, u.cross(v)))
}

impl ParticleBackend {
    /// Gives every driven joint its torque for a step of `h` (see [`TorqueDrives`]).
    fn drive_joints(&mut self, h: f32) {
        if !self.drives.is_on() {
            return;
        }
        let mut states = Vec::new();
        self.body_states(&mut states);
        let mut impulses = Vec::new();
        let bodies = &self.bodies;
        self.drives
            .impulses(&states, |b| bodies[b].kinematic, h, &mut impulses);
        let commands: Vec<Command> = impulses.into_iter().map(Command::Impulse).collect();
        apply_each(self, &commands);
    }

    /// An empty particle world in `surroundings`.
    pub fn new(config: &ParticleConfig, surroundings: &Surroundings) -> Self {
        ParticleBackend {
            settings: ParticleSettings {
                gravity: surroundings.gravity,
                ground: surroundings.ground,
                substeps: config.substeps,
                iterations: config.iterations,
            },
            x: Vec::new(),
            x_prev: Vec::new(),
            x_pred: Vec::new(),
            v: Vec::new(),
            m: Vec::new(),
            w: Vec::new(),
            kin: Vec::new(),
            kin_from: Vec::new(),
            kin_to: Vec::new(),
            bodies: Vec::new(),
            parts: Vec::new(),
            rest: Vec::new(),
            affine: Vec::new(),
            beta_e: [Vec::new(), Vec::new()],
            beta_o: Vec::new(),
            resid_e: Vec::new(),
            distances: Vec::new(),
            affines: Vec::new(),
            joints: Vec::new(),
            bounds: Vec::new(),
            trees: Vec::new(),
            joint_order: Vec::new(),
            stamp: Vec::new(),
            body_stamp: Vec::new(),
            epoch: 0,
            pins: Vec::new(),
            filters: Vec::new(),
            filter_bits: Vec::new(),
            cross_disabled: Vec::new(),
            grid: collide::Grid::default(),
            pairs: Vec::new(),
            caps: Vec::new(),
            pairs_left: 0,
            touched: Vec::new(),
            supported: Vec::new(),
            penetration: 0.0,
            solver_violation: 0.0,
            last_dt: 0.0,
            scratch: Vec::new(),
            pinned: Vec::new(),
            drives: TorqueDrives::default(),
        }
    }
}

impl ParticleBackend {
    /// Body `b` as the world reads it: its frame particles' velocity, and the turn of its
    /// last step.
    fn state_of(&self, b: usize) -> BodyState {
        let body = &self.bodies[b];
        let mut linvel = Vec3::ZERO;
        for (k, &i) in self.parts[self.body_parts(b)].iter().enumerate() {
            linvel += self.v[i as usize] * self.beta_o[body.first as usize + k];
        }
        let turn = (body.rot * body.rot_prev.conjugate()).normalize();
        let turn = if turn.w < 0.0 { -turn } else { turn };
        let angvel = if self.last_dt > 0.0 {
            turn.to_scaled_axis() / self.last_dt
        } else {
            Vec3::ZERO
        };
        BodyState {
            pose: Transform::new(body.pos, body.rot),
            linvel,
            angvel,
        }
    }
}

impl Backend for ParticleBackend {
    fn add_ragdoll(
        &mut self,
        bodies: &[BodyDesc],
        joints: &[JointDesc],
        disabled_pairs: &[(usize, usize)],
    ) -> BodyId {
        let first = self.add_ragdoll_impl(bodies, joints, disabled_pairs);
        self.drives.add_ragdoll(first, bodies, joints);
        for (k, b) in bodies.iter().enumerate() {
            if b.linvel != Vec3::ZERO || b.angvel != Vec3::ZERO {
                self.set_body_velocity(BodyId(first + k), b.linvel, b.angvel);
            }
        }
        BodyId(first)
    }

    /// Its bodies are held still as kinematic ones (their particles then carry no
    /// energy) and meet nothing.
    fn remove_ragdoll(&mut self, BodyId(first_body): BodyId) -> bool {
        let Some(ragdoll) = self.bodies.get(first_body).map(|b| b.ragdoll) else {
            return false;
        };
        self.drives.remove_ragdoll(first_body);
        for b in first_body..self.bodies.len() {
            if self.bodies[b].ragdoll != ragdoll {
                break;
            }
            self.set_kinematic(BodyId(b), true);
            for k in self.body_parts(b) {
                let p = self.parts[k] as usize;
                self.v[p] = Vec3::ZERO;
                (self.kin_from[p], self.kin_to[p]) = (self.x[p], self.x[p]);
            }
            self.bodies[b].removed = true;
        }
        for p in &mut self.pins {
            if self.bodies.get(p.body as usize).is_some_and(|b| b.removed) {
                p.active = false;
            }
        }
        self.pairs_left = 0;
        true
    }

    fn step(&mut self, dt: f32) -> StepReport {
        self.drive_joints(dt);
        self.step_impl(dt);
        StepReport {
            max_penetration_m: self.penetration,
            limit_violation_before_clamp_rad: Some(self.solver_violation),
            joint_separation_before_clamp_m: None,
            went_non_finite: false,
        }
    }

    fn body_states(&self, out: &mut Vec<BodyState>) {
        out.clear();
        out.extend((0..self.bodies.len()).map(|b| self.state_of(b)));
    }

    fn body_states_of(&self, BodyId(first): BodyId, out: &mut [BodyState]) {
        let n = self.bodies.len();
        for (o, b) in out.iter_mut().zip(first..n) {
            *o = self.state_of(b);
        }
    }

    fn kinetic_energy(&self) -> f64 {
        self.v
            .iter()
            .zip(&self.m)
            .zip(&self.w)
            .filter(|(_, w)| **w > 0.0)
            .map(|((v, m), _)| 0.5 * (*m as f64) * v.length_squared() as f64)
            .sum()
    }

    fn cast_ray(&self, origin: Vec3, dir: Vec3, max_dist: f32) -> Option<(BodyId, f32)> {
        self.cast_ray_impl(origin, dir, max_dist)
            .map(|(b, d)| (BodyId(b), d))
    }

    fn add_pin(
        &mut self,
        BodyId(index): BodyId,
        local: Vec3,
        target: Vec3,
        soft: Option<(f32, f32)>,
    ) -> PinId {
        self.pins.push(Pin {
            body: index as u32,
            local,
            from: target,
            target,
            soft,
            active: true,
        });
        PinId(self.pins.len() - 1)
    }

    fn bodies_touching_other_ragdolls(&self, out: &mut Vec<bool>) {
        out.clone_from(&self.touched);
    }

    fn apply(&mut self, commands: &[Command]) {
        apply_each(self, commands);
    }

    /// No drives inside the position solver yet: torques at the start of each step,
    /// softer ([`TorqueDrives`]).
    fn drive_joint(
        &mut self,
        joint: JointId,
        target: glam::Quat,
        target_angvel: Vec3,
        stiffness: f32,
        damping: f32,
    ) {
        self.drives
            .set(joint, target, target_angvel, stiffness, damping);
    }
}

impl OneAtATime for ParticleBackend {
    fn apply_impulse_at_point(&mut self, BodyId(index): BodyId, impulse: Vec3, point: Vec3) {
        self.apply_impulse(index, impulse, Some(point), Vec3::ZERO);
    }

    fn apply_torque_impulse(&mut self, BodyId(index): BodyId, impulse: Vec3) {
        self.apply_impulse(index, Vec3::ZERO, None, impulse);
    }

    fn set_kinematic(&mut self, BodyId(index): BodyId, kinematic: bool) {
        if self.bodies[index].kinematic == kinematic {
            return;
        }
        self.bodies[index].kinematic = kinematic;
        for k in self.body_parts(index) {
            let p = self.parts[k] as usize;
            self.set_particle_kinematic(p, kinematic);
        }
    }

    fn set_kinematic_target(&mut self, BodyId(index): BodyId, pose: &Transform) {
        for k in self.body_parts(index) {
            let p = self.parts[k] as usize;
            if self.kin[p] > 0 {
                self.kin_to[p] = pose.transform_point(self.rest[k]);
            }
        }
    }

    fn set_body_velocity(&mut self, BodyId(index): BodyId, linvel: Vec3, angvel: Vec3) {
        let origin = self.bodies[index].pos;
        for k in self.body_parts(index) {
            let p = self.parts[k] as usize;
            self.v[p] = linvel + angvel.cross(self.x[p] - origin);
        }
        self.pairs_left = 0;
    }

    fn set_joint_parent_frame(&mut self, JointId(index): JointId, frame: &Transform) {
        self.joints[index].frame_parent = *frame;
    }

    fn set_joint_child_frame(&mut self, JointId(index): JointId, frame: &Transform) {
        self.joints[index].frame_child = *frame;
        self.drives.set_child_frame(JointId(index), frame);
    }

    /// The particle solver's substeps come from the world's settings; powered mode's
    /// motors act as torques here (`TorqueDrives`), so they need no more.
    fn set_solver_substeps(&mut self, _substeps: usize) {}

    fn set_joint_limits(&mut self, JointId(index): JointId, kind: &JointKind) {
        self.joints[index].kind = *kind;
        self.bounds[index] = solve::Bounds::of(kind);
    }

    fn set_gravity(&mut self, gravity: Vec3) {
        self.settings.gravity = gravity;
    }

    fn move_pin(&mut self, PinId(pin): PinId, target: Vec3) {
        self.pins[pin].target = target;
    }

    fn release_pin(&mut self, PinId(pin): PinId) {
        self.pins[pin].active = false;
    }

    fn disable_pair(&mut self, BodyId(a): BodyId, BodyId(b): BodyId) {
        let (ra, rb) = (self.bodies[a].ragdoll, self.bodies[b].ragdoll);
        if ra == rb {
            let f = &self.filters[ra as usize];
            let (i, j) = (a - f.first_body as usize, b - f.first_body as usize);
            let n = f.bodies as usize;
            for bit in [i * n + j, j * n + i] {
                self.filter_bits[f.offset + bit / 64] |= 1u64 << (bit % 64);
            }
        } else {
            let key = (a.min(b) as u32, a.max(b) as u32);
            if let Err(pos) = self.cross_disabled.binary_search(&key) {
                self.cross_disabled.insert(pos, key);
            }
        }
        self.pairs_left = 0;
    }

    fn set_body_pose(&mut self, BodyId(index): BodyId, pose: &Transform) {
        for k in self.body_parts(index) {
            let p = self.parts[k] as usize;
            let to = pose.transform_point(self.rest[k]);
            self.x[p] = to;
            self.x_prev[p] = to;
            if self.kin[p] > 0 {
                self.kin_from[p] = to;
                self.kin_to[p] = to;
            }
        }
        let body = &mut self.bodies[index];
        body.rot = pose.rotation;
        body.pos = pose.translation;
        body.rot_prev = pose.rotation;
        self.pairs_left = 0;
    }
}
