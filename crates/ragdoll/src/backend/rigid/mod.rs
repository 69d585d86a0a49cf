//! The rigid backend: rapier3d rigid bodies, impulse joints and contacts.
//!
//! Swing-twist joints map to rapier's coupled angular limit (the angle between the two
//! frames' X axes, a true cone) plus an X twist limit; hinges to a revolute joint limited on
//! X. Pairs of bodies the spec filters out are dropped by a contact-pair hook.

mod build;
mod commands;

use std::collections::HashSet;

use glam::Vec3;
use rapier3d::prelude::*;

use build::{EXTRA_BIT, FRICTION, GROUND_KEY, PairFilter, collider_of, make_joint, pose};

use super::damping::JointDamping;
use super::limits::{BodyRole, LimitProjection};
use super::{
    Backend, BodyDesc, BodyId, BodyState, Command, JointDesc, JointId, PinId, RigidConfig,
    StepReport, Surroundings, apply_each,
};
use crate::math::Transform;

/// Half the side of the ground's square, metres (centred on the origin): the world refuses
/// ragdolls that would start beyond it. Not larger: a 20 km box cost rapier contact
/// quality (24 % energy drift in the standing collapse), a 2.2 km one already moved the
/// data's penetrations past their bounds, and a half-space opened joints further in
/// blasts; every test was measured with this one.
pub(crate) const GROUND_HALF_EXTENT_M: f32 = 500.0;

/// The `rigid` engine: a rapier3d world holding every ragdoll.
pub struct RigidBackend {
    world: PhysicsWorld,
    joints: Vec<ImpulseJointHandle>,
    /// Each pin's kinematic anchor, joint (`None` once released) and the body it holds.
    pins: Vec<(RigidBodyHandle, Option<ImpulseJointHandle>, usize)>,
    bodies: Vec<RigidBodyHandle>,
    filter: PairFilter,
    /// Each joint's drive (powered mode), a second joint between the same two bodies with
    /// no locked axis and three angular motors, created on first use.
    drives: Vec<Option<ImpulseJointHandle>>,
    /// Whether rapier has quarantined a body (its state went non-finite; rapier froze it).
    quarantined: bool,
    /// The ground's height, if there is one (a box [`GROUND_HALF_EXTENT_M`] each way).
    ground: Option<f32>,
    /// The joints as the limit projection sees them; `None` when the projection is off
    /// ([`RigidConfig::project_limits`]).
    limits: Option<LimitProjection>,
    /// How many calls of [`Backend::step`] make one world step (the collision substeps),
    /// and how many of the current one have been made: the projection runs after the
    /// last, where the world's step ends.
    world_substeps: usize,
    calls_this_step: usize,
    /// Passive joint damping, applied at the start of each step.
    damping: JointDamping,
    /// Scratch: the bodies' states and the damping's impulses.
    scratch_states: Vec<BodyState>,
    scratch_impulses: Vec<super::BodyImpulse>,
}

impl RigidBackend {
    /// The body of handle `h` as the world reads it.
    fn state_of(&self, h: RigidBodyHandle) -> BodyState {
        let rb = &self.world.bodies[h];
        let p = rb.position();
        BodyState {
            pose: Transform::new(p.translation, p.rotation),
            linvel: rb.linvel(),
            angvel: rb.angvel(),
        }
    }

    /// Deepest contact penetration of the last step, metres: between bodies that may
    /// collide, and with the ground.
    fn max_penetration(&self) -> f32 {
        let mut deepest = 0.0f32;
        for pair in self.world.narrow_phase.contact_pairs() {
            let PairContacts::Rigid(contacts) = &pair.contacts else {
                continue;
            };
            let k1 = self.world.colliders[pair.collider1].user_data;
            let k2 = self.world.colliders[pair.collider2].user_data;
            if k1 != GROUND_KEY && k2 != GROUND_KEY {
                let (a, b) = (k1 as u32, k2 as u32);
                if self.filter.disabled.contains(&(a.min(b), a.max(b))) {
                    continue;
                }
            }
            for m in &contacts.manifolds {
                for p in &m.points {
                    deepest = deepest.max(-p.dist);
                }
            }
        }
        deepest
    }

    /// An empty rapier world in `surroundings` (its ground a box 1 km square and 1 m
    /// thick, so fast bodies cannot tunnel under it).
    pub fn new(config: &RigidConfig, surroundings: &Surroundings) -> Self {
        let mut world = PhysicsWorld::new();
        world.gravity = surroundings.gravity;
        world.integration_parameters.num_solver_iterations = config.substeps.max(1);
        world.integration_parameters.num_internal_pgs_iterations = config.iterations.max(1);
        if let Some(y) = surroundings.ground {
            // A thick box rather than a half-space, so fast bodies cannot tunnel under it.
            let ground = ColliderBuilder::cuboid(GROUND_HALF_EXTENT_M, 1.0, GROUND_HALF_EXTENT_M)
                .translation(Vec3::new(0.0, y - 1.0, 0.0))
                .friction(FRICTION)
                .user_data(GROUND_KEY)
                .build();
            world.colliders.insert(ground);
        }
        RigidBackend {
            world,
            joints: Vec::new(),
            pins: Vec::new(),
            bodies: Vec::new(),
            filter: PairFilter {
                disabled: HashSet::new(),
                ragdoll_of: Vec::new(),
            },
            drives: Vec::new(),
            quarantined: false,
            ground: surroundings.ground,
            limits: config.project_limits.then(|| match config.gap_tolerance_m {
                Some(t) => LimitProjection::closing_gaps(t),
                None => LimitProjection::default(),
            }),
            world_substeps: config.collision_substeps.max(1),
            calls_this_step: 0,
            damping: JointDamping::default(),
            scratch_states: Vec::new(),
            scratch_impulses: Vec::new(),
        }
    }

    /// Adds one ragdoll; returns the global index of its first body.
    fn add_ragdoll_impl(
        &mut self,
        bodies: &[BodyDesc],
        joints: &[JointDesc],
        disabled_pairs: &[(usize, usize)],
    ) -> usize {
        let first = self.bodies.len();
        let ragdoll = self.filter.ragdoll_of.last().map_or(0, |r| r + 1);
        self.filter.ragdoll_of.resize(first + bodies.len(), ragdoll);
        for (i, b) in bodies.iter().enumerate() {
            let mut rb = RigidBodyBuilder::dynamic()
                .pose(pose(&b.pose))
                .linvel(b.linvel)
                .angvel(b.angvel)
                .build();
            let key = (first + i) as u128;
            let collider = if b.extra_shapes.is_empty() {
                collider_of(&b.shape, key).mass(b.mass).build()
            } else {
                // The mass spread over every shape, its centre at the own shape's (as the
                // other backends have it: `geometry::body_inertia`), set on the body; the
                // colliders then carry none.
                let inertia = crate::geometry::body_inertia(&b.shape, &b.extra_shapes, b.mass);
                rb.set_additional_mass_properties(
                    MassProperties::new(Vec3::ZERO, b.mass, inertia.diagonal()),
                    false,
                );
                collider_of(&b.shape, key).density(0.0).build()
            };
            let handle = self.world.bodies.insert(rb);
            self.world
                .colliders
                .insert_with_parent(collider, handle, &mut self.world.bodies);
            for (shape, at) in &b.extra_shapes {
                let collider = collider_of(shape, key | EXTRA_BIT)
                    .position(pose(at))
                    .density(0.0)
                    .build();
                self.world
                    .colliders
                    .insert_with_parent(collider, handle, &mut self.world.bodies);
            }
            self.bodies.push(handle);
        }
        for j in joints {
            let joint = make_joint(j);
            let (h1, h2) = (self.bodies[first + j.parent], self.bodies[first + j.child]);
            let handle = self.world.impulse_joints.insert(h1, h2, joint, true);
            self.joints.push(handle);
            // rapier 0.36 does not read `contacts_enabled` for impulse joints, so jointed
            // pairs go through the contact filter like any other pair.
            let (a, b) = ((first + j.parent) as u32, (first + j.child) as u32);
            self.filter.disabled.insert((a.min(b), a.max(b)));
        }
        for &(a, b) in disabled_pairs {
            let (a, b) = ((first + a) as u32, (first + b) as u32);
            self.filter.disabled.insert((a.min(b), a.max(b)));
        }
        if let Some(limits) = &mut self.limits {
            limits.add_ragdoll(first, bodies, joints);
        }
        self.damping.add_ragdoll(first, bodies, joints);
        first
    }

    /// Gives every damped ragdoll's joints their couples for a step of `h` (see
    /// [`JointDamping`]).
    fn damp_joints(&mut self, h: f32) {
        if !self.damping.is_on() {
            return;
        }
        let mut states = std::mem::take(&mut self.scratch_states);
        let mut impulses = std::mem::take(&mut self.scratch_impulses);
        self.body_states(&mut states);
        impulses.clear();
        let (world, handles) = (&self.world, &self.bodies);
        let dynamic = |b: usize| {
            let rb = &world.bodies[handles[b]];
            rb.is_dynamic() && rb.is_enabled()
        };
        self.damping.impulses(&states, dynamic, h, &mut impulses);
        let commands: Vec<Command> = impulses.iter().map(|&i| Command::Impulse(i)).collect();
        apply_each(self, &commands);
        self.scratch_states = states;
        self.scratch_impulses = impulses;
    }

    /// Turns every joint rapier left past its limits back inside them and narrows the gaps
    /// past the tolerance (see [`LimitProjection`]); returns the worst violation before,
    /// radians, and the widest gap before, metres, if it narrows gaps.
    fn project_limits(&mut self) -> Option<(f32, Option<f32>)> {
        let limits = self.limits.as_ref()?;
        let mut poses = Vec::with_capacity(self.bodies.len());
        let mut roles = Vec::with_capacity(self.bodies.len());
        for &h in &self.bodies {
            let rb = &self.world.bodies[h];
            let p = rb.position();
            poses.push(Transform::new(p.translation, p.rotation));
            let dynamic = rb.is_dynamic() && rb.is_enabled();
            // A kinematic body of a ragdoll that is otherwise physical is a root kept on
            // its clip: held.
            roles.push(BodyRole {
                dynamic,
                held: !dynamic,
            });
        }
        for &(_, joint, body) in &self.pins {
            if joint.is_some()
                && let Some(r) = roles.get_mut(body)
            {
                r.held = true;
            }
        }
        let before = limits.worst_violation(&poses, &roles);
        let gap_before = limits
            .closes_gaps()
            .then(|| limits.worst_separation(&poses, &roles));
        for b in limits.project(&mut poses, &roles, self.ground) {
            self.world.bodies[self.bodies[b]].set_position(pose(&poses[b]), false);
        }
        Some((before, gap_before))
    }
}

impl Backend for RigidBackend {
    fn add_ragdoll(
        &mut self,
        bodies: &[BodyDesc],
        joints: &[JointDesc],
        disabled_pairs: &[(usize, usize)],
    ) -> BodyId {
        BodyId(self.add_ragdoll_impl(bodies, joints, disabled_pairs))
    }

    /// rapier's own way: the bodies are disabled (out of the solver and of collision
    /// detection, their colliders with them), their handles kept.
    fn remove_ragdoll(&mut self, BodyId(first_body): BodyId) -> bool {
        let Some(&ragdoll) = self.filter.ragdoll_of.get(first_body) else {
            return false;
        };
        if let Some(limits) = &mut self.limits {
            limits.remove_ragdoll(first_body);
        }
        self.damping.remove_ragdoll(first_body);
        for (i, &h) in self.bodies.iter().enumerate().skip(first_body) {
            if self.filter.ragdoll_of[i] != ragdoll {
                break;
            }
            let rb = &mut self.world.bodies[h];
            rb.set_linvel(Vec3::ZERO, false);
            rb.set_angvel(Vec3::ZERO, false);
            rb.set_enabled(false);
        }
        true
    }

    fn step(&mut self, dt: f32) -> StepReport {
        self.damp_joints(dt);
        {
            self.world.integration_parameters.dt = dt;
            let w = &mut self.world;
            w.physics_pipeline.step(
                w.gravity,
                &w.integration_parameters,
                &mut w.islands,
                &mut w.broad_phase,
                &mut w.narrow_phase,
                &mut w.bodies,
                &mut w.colliders,
                &mut w.impulse_joints,
                &mut w.multibody_joints,
                &mut w.soft_bodies,
                &mut w.ccd_solver,
                &self.filter,
                &(),
            );
        }
        // rapier rolls a non-finite body back, zeroes and disables it, and says so only
        // here: a frozen body would otherwise pass for a finite result.
        self.quarantined |= !self.world.quarantine().is_empty();
        let max_penetration_m = self.max_penetration();
        self.calls_this_step += 1;
        let mut before_clamp = None;
        if self.calls_this_step >= self.world_substeps {
            self.calls_this_step = 0;
            if !self.quarantined {
                before_clamp = self.project_limits();
            }
        }
        StepReport {
            max_penetration_m,
            limit_violation_before_clamp_rad: before_clamp.map(|(v, _)| v),
            joint_separation_before_clamp_m: before_clamp.and_then(|(_, g)| g),
            went_non_finite: self.quarantined,
        }
    }

    fn body_states(&self, out: &mut Vec<BodyState>) {
        out.clear();
        out.extend(self.bodies.iter().map(|&h| self.state_of(h)));
    }

    fn body_states_of(&self, BodyId(first): BodyId, out: &mut [BodyState]) {
        let handles = self.bodies.get(first..).unwrap_or_default();
        for (o, &h) in out.iter_mut().zip(handles) {
            *o = self.state_of(h);
        }
    }

    fn ground_half_extent(&self) -> Option<f32> {
        self.ground.map(|_| GROUND_HALF_EXTENT_M)
    }

    fn cast_ray(&self, origin: Vec3, dir: Vec3, max_dist: f32) -> Option<(BodyId, f32)> {
        let not_ground =
            |_: ColliderHandle, c: &Collider| c.user_data != GROUND_KEY && c.is_enabled();
        let filter = QueryFilter::default().predicate(&not_ground);
        let ray = Ray::new(origin, dir);
        let (collider, toi) = self.world.cast_ray(&ray, max_dist, true, filter)?;
        let key = self.world.colliders[collider].user_data;
        Some((BodyId(key as usize), toi))
    }

    fn add_pin(
        &mut self,
        BodyId(index): BodyId,
        local: Vec3,
        target: Vec3,
        soft: Option<(f32, f32)>,
    ) -> PinId {
        let anchor = self
            .world
            .bodies
            .insert(RigidBodyBuilder::kinematic_position_based().translation(target));
        let mut joint = GenericJointBuilder::new(JointAxesMask::LOCKED_SPHERICAL_AXES)
            .local_anchor1(Vec3::ZERO)
            .local_anchor2(local)
            .build();
        if let Some((hz, damping)) = soft {
            let _ = joint.set_softness(SpringCoefficients::new(hz, damping));
        }
        let body = self.bodies[index];
        let handle = self.world.impulse_joints.insert(anchor, body, joint, true);
        self.pins.push((anchor, Some(handle), index));
        PinId(self.pins.len() - 1)
    }

    fn bodies_touching_other_ragdolls(&self, out: &mut Vec<bool>) {
        /// Closer than this counts as touching, metres (rapier keeps speculative contacts a
        /// little apart).
        const TOUCH_M: f32 = 0.005;
        out.clear();
        out.resize(self.bodies.len(), false);
        for pair in self.world.narrow_phase.contact_pairs() {
            let k1 = self.world.colliders[pair.collider1].user_data;
            let k2 = self.world.colliders[pair.collider2].user_data;
            if k1 == GROUND_KEY || k2 == GROUND_KEY {
                continue;
            }
            let (a, b) = (k1 as usize, k2 as usize);
            if self.filter.ragdoll_of.get(a) == self.filter.ragdoll_of.get(b) {
                continue;
            }
            let PairContacts::Rigid(contacts) = &pair.contacts else {
                continue;
            };
            let touching = contacts
                .manifolds
                .iter()
                .any(|m| m.points.iter().any(|p| p.dist < TOUCH_M));
            if touching {
                for k in [a, b] {
                    if let Some(t) = out.get_mut(k) {
                        *t = true;
                    }
                }
            }
        }
    }

    fn drive_joint(
        &mut self,
        JointId(index): JointId,
        target: glam::Quat,
        target_angvel: Vec3,
        stiffness: f32,
        damping: f32,
    ) {
        if index >= self.joints.len() {
            return;
        }
        if self.drives.len() < self.joints.len() {
            self.drives.resize(self.joints.len(), None);
        }
        if stiffness <= 0.0 && damping <= 0.0 {
            // A motor with no gains would be a hard velocity constraint in rapier, not a
            // slack one: remove the drive instead.
            if let Some(h) = self.drives[index].take() {
                self.world.impulse_joints.remove(h, true);
            }
            return;
        }
        let handle = match self.drives[index] {
            Some(h) => h,
            None => {
                let Some(joint) = self.world.impulse_joints.get(self.joints[index]) else {
                    return;
                };
                let (b1, b2) = (joint.body1(), joint.body2());
                let drive = GenericJointBuilder::new(JointAxesMask::empty())
                    .contacts_enabled(false)
                    .build();
                let h = self.world.impulse_joints.insert(b1, b2, drive, true);
                self.drives[index] = Some(h);
                h
            }
        };
        let Some(joint) = self.world.impulse_joints.get_mut(handle, true) else {
            return;
        };
        // rapier's angular motors measure each axis of frame 1 (here the parent body's
        // own axes) from the relative rotation of the two frames: with frame 2 turned by
        // the target's inverse, the frames coincide exactly when the child has the target
        // rotation, so a target angle of 0 on every axis is the clip's pose.
        joint.data.set_local_frame1(Pose::IDENTITY);
        joint
            .data
            .set_local_frame2(Pose::from_parts(Vec3::ZERO, target.conjugate()));
        for (axis, vel) in [
            (JointAxis::AngX, target_angvel.x),
            (JointAxis::AngY, target_angvel.y),
            (JointAxis::AngZ, target_angvel.z),
        ] {
            joint
                .data
                .set_motor_model(axis, MotorModel::AccelerationBased)
                .set_motor(axis, 0.0, vel, stiffness, damping);
        }
    }

    // rapier puts resting islands to sleep too: a joint is active while either body is
    // awake.
    fn active_joints(&self) -> Option<usize> {
        let w = &self.world;
        Some(
            self.joints
                .iter()
                .filter_map(|&h| w.impulse_joints.get(h))
                .filter(|j| {
                    !(w.bodies[j.body1()].is_sleeping() && w.bodies[j.body2()].is_sleeping())
                })
                .count(),
        )
    }

    fn kinetic_energy(&self) -> f64 {
        self.bodies
            .iter()
            .map(|&h| {
                let rb = &self.world.bodies[h];
                let m = rb.mass() as f64;
                let v = rb.linvel();
                let w = rb.angvel();
                // Rotational energy ½ ωᵀ I ω, in the principal frame of the inertia.
                let rot = rb.position().rotation;
                let local_w = rot.conjugate() * w;
                let props = rb.mass_properties().local_mprops;
                let frame = props.principal_inertia_local_frame;
                let pw = frame.conjugate() * local_w;
                let inertia = props.principal_inertia();
                0.5 * m * v.length_squared() as f64
                    + 0.5
                        * (inertia.x * pw.x * pw.x
                            + inertia.y * pw.y * pw.y
                            + inertia.z * pw.z * pw.z) as f64
            })
            .sum()
    }

    fn apply(&mut self, commands: &[Command]) {
        apply_each(self, commands);
    }
}
