//! The particle backend: our own position-based ragdoll (XPBD with substeps, one iteration
//! per substep by default), cheap enough for crowds.
//!
//! # Model
//!
//! - **Particles** sit at the joint anchors (shared by the two bodies a joint links), at the
//!   far end of leaf bodies (a tip), and inside each body (at its centre of mass), so that
//!   every body's mass, centre of mass and (for sticks) moment of inertia across its axis
//!   are those of the spec: a stick's masses follow the three-point rule (ends
//!   `I/(p(p+q))`, `I/(q(p+q))`, the rest at the centre), which for a thin rod is Simpson's
//!   m/6, 2m/3, m/6.
//! - **Sticks**: a body with two anchors (or one anchor and a tip) keeps its length with a
//!   distance constraint and its centre particle on the segment. Its orientation is the
//!   bone direction plus a frame carried along from the parent body by minimal rotation,
//!   turned by a **twist** angle about the bone: the one degree of freedom particles on a
//!   line cannot carry, kept as a scalar state with its own inertia (the capsule's, about
//!   its axis). A hinge child has no twist: its roll follows from the hinge angle.
//! - **Clusters**: a body with three or more anchors (pelvis, chest) is a rigid particle
//!   cluster held by shape matching (Müller et al. 2005), its orientation the matched
//!   rotation (Müller et al. 2016's iterative extraction, warm started).
//! - **Joint limits** (cone, twist, hinge range, fixed) are position projections: the
//!   child is turned back inside the limits that
//!   [`ResolvedJoint::clamp_child_rotation`] gives, the same measure the world's metrics
//!   use: child and parent turn about their own centres of mass in opposite senses, by
//!   their inverse inertias (XPBD's angular correction), so a projection never changes
//!   momentum; the sticks and clusters then close the joint the turns opened.
//! - **Collision**: each body's capsule (boxes become the capsule along their longest edge,
//!   the radius the smaller of the other two half edges, so nothing sinks into the floor)
//!   against the ground plane and against every capsule not filtered out, of its own or
//!   another ragdoll: a uniform hash grid found once per step gives the candidate pairs,
//!   the contacts are solved every substep with positional friction (static up to μ times the penetration depth).
//! - Contacts, pins and limits act on points of a body; a point's correction is spread
//!   over the body's particles with the weights of its affine (least-norm) combination of
//!   them, so a push at a stick's end moves that end and a push at its middle moves both.
//!
//! # Approximations
//!
//! - A stick's twist velocity is relative to its parent; when the parent spins about the
//!   child's axis, the child spins along (no inertial lag about the bone).
//! - An impulse's moment about a stick's axis spins it through the twist state; about a
//!   cluster, through its particles (their inertia, not the box's exactly).
//! - Kinematic bodies follow their targets linearly over the substeps; a velocity set on a
//!   stick leaves its twist rate relative to the parent at zero.
//! - Limit corrections turn whole bodies, so a joint held at its limit against the floor
//!   converges over the iterations rather than at once: deep piles end a few degrees past
//!   their limits and a few millimetres apart at the joints. A chain of short, fat sticks
//!   between heavier ones (the auto-rigged dragon's spine) still flickers past its limits
//!   for single frames once it lies on the floor.
//! - A point of a body off the line of a stick's particles (a foot's capsule end below the
//!   ankle-toe line) is pushed through its projection on that line.

mod collide;
mod solve;

use glam::{Mat3, Mat4, Quat, Vec3, Vec4};

use super::{Backend, BodyDesc, BodyState, JointDesc};
use crate::math::Transform;
use crate::spec::{JointKind, ResolvedJoint, Shape};

/// Friction of body-body and body-ground contacts (as the rigid backend: skin and clothing
/// on a hard floor are around 0.5-0.8).
const FRICTION: f32 = 0.7;
/// Joint anchors of one parent closer than this share a particle, metres.
const MERGE_M: f32 = 1.0e-3;
/// Shortest stick, metres: a leaf whose capsule barely reaches past its anchor gets a tip
/// this far away, so its direction stays well defined.
const MIN_STICK_M: f32 = 0.02;
/// Velocity damping of the particles, 1/s: none, as rapier's bodies have none (a free
/// fall must follow g·t²/2).
const LINEAR_DAMPING: f32 = 0.0;
/// Damping of the twist rate, 1/s: nothing else resists a stick's roll between its limits.
const TWIST_DAMPING: f32 = 1.0;
/// Smallest share of a stick's mass kept on its centre particle, so it never goes to zero
/// (a short, fat body such as a head has more inertia than its ends can carry).
const MIN_CENTRE_SHARE: f32 = 0.05;

/// Settings the particle backend takes from the world.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ParticleSettings {
    /// Gravity, m/s².
    pub gravity: Vec3,
    /// Height of the ground plane, or `None` for no ground.
    pub ground: Option<f32>,
    /// XPBD substeps per step (each with its own contact solve).
    pub substeps: usize,
    /// Constraint iterations per substep.
    pub iterations: usize,
}

/// How a body gets its orientation.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Orient {
    /// Shape-matched rotation of three or more particles.
    Cluster,
    /// Bone direction plus twist, carried from the parent through joint `joint` (global),
    /// or along time for a root stick.
    Stick { joint: Option<u32> },
}

/// One body: a set of particles and what is needed to get its frame back from them.
#[derive(Clone, Debug)]
struct Body {
    /// Index of the ragdoll it belongs to.
    ragdoll: u32,
    /// Its particles: `parts[first..first + count]`.
    first: u32,
    count: u32,
    orient: Orient,
    /// For sticks: the anchor particle (joint to the parent, or the first end) and the tip.
    base: u32,
    tip: u32,
    /// Rest position of the base and tip particles in the body frame.
    r_base: Vec3,
    r_tip: Vec3,
    /// For sticks with a parent: the bone direction in the joint's child frame, and the
    /// rotation taking it to the frame's X (see `solve::stick_rotation`).
    a: Vec3,
    g: Quat,
    /// Capsule segment ends in the body frame and radius.
    e: [Vec3; 2],
    radius: f32,
    /// Mean of the particles' rest offsets (the affine weights are centred on it).
    rbar: Vec3,
    /// Mass-weighted mean rest offset (shape matching).
    rcm: Vec3,
    mass: f32,
    /// Moment of inertia about the stick's axis, kg·m².
    axial_inertia: f32,
    /// Twist about the bone, radians (relative to the parent), and its rate, rad/s; for a
    /// root stick only the rate is used (absolute roll rate).
    twist: f32,
    twist_vel: f32,
    /// Twist at the start of the substep.
    twist_prev: f32,
    /// Current frame.
    rot: Quat,
    pos: Vec3,
    /// Rotation at the start of the last step (for the angular velocity).
    rot_prev: Quat,
    kinematic: bool,
    kin_from: Transform,
    kin_to: Transform,
    /// The twist must be recomputed from `rot` at the next frame update (after a pose was
    /// set from outside).
    sync_twist: bool,
}

/// A stick's length.
#[derive(Clone, Copy, Debug)]
struct Distance {
    a: u32,
    b: u32,
    len: f32,
}

/// A stick's centre particle `c` stays at `(1 − t)·a + t·b`.
#[derive(Clone, Copy, Debug)]
struct Middle {
    c: u32,
    a: u32,
    b: u32,
    t: f32,
}

/// A joint: the spec's frames and limits plus its shared particle.
#[derive(Clone, Debug)]
struct Joint {
    /// Parent and child are global body indices.
    rj: ResolvedJoint,
    particle: u32,
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

/// Every ragdoll's particles, bodies and constraints in flat arrays.
pub(crate) struct ParticleBackend {
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
    /// Weights of the two capsule ends and of the body origin.
    beta_e: [Vec<f32>; 2],
    /// How a push at a capsule end is spread: its weights with the negative ones dropped
    /// and the rest scaled to sum to one. Exact weights of a point past a stick's particles
    /// are negative at the far end (a lever): a floor pushing a toe up would push the ankle
    /// down into the limit that turns the toe back down, a fight that pumps energy.
    push_e: [Vec<f32>; 2],
    beta_o: Vec<f32>,
    /// The capsule ends' offsets from their affine reconstruction, body frame.
    resid_e: Vec<[Vec3; 2]>,
    /// Bodies ordered parents first.
    order: Vec<u32>,
    // Constraints.
    distances: Vec<Distance>,
    middles: Vec<Middle>,
    joints: Vec<Joint>,
    pins: Vec<Pin>,
    filters: Vec<Filter>,
    filter_bits: Vec<u64>,
    /// Pairs of bodies of different ragdolls that must not collide.
    cross_disabled: Vec<(u32, u32)>,
    // Per-step scratch and results.
    grid: collide::Grid,
    pairs: Vec<(u32, u32)>,
    touched: Vec<bool>,
    /// Stick children of each body (global body indices).
    children: Vec<Vec<u32>>,
    /// Bodies whose frame a limit turn made stale during the current pass.
    stale: Vec<bool>,
    penetration: f32,
    /// Length of the last step, seconds.
    last_dt: f32,
    /// Weight buffers for pins and contacts.
    scratch: Vec<f32>,
    scratch_b: Vec<f32>,
}

/// Body-frame capsule of a shape: segment ends and radius.
fn capsule_of(shape: &Shape) -> ([Vec3; 2], f32) {
    match *shape {
        Shape::Capsule { radius_m, length_m } => {
            let h = Vec3::Y * (0.5 * length_m);
            ([-h, h], radius_m)
        }
        Shape::Box { size_m } => {
            let s = Vec3::from_array(size_m) * 0.5;
            let axis = if s.x >= s.y && s.x >= s.z {
                0
            } else if s.y >= s.z {
                1
            } else {
                2
            };
            let (long, r) = match axis {
                0 => (s.x, s.y.min(s.z)),
                1 => (s.y, s.x.min(s.z)),
                _ => (s.z, s.x.min(s.y)),
            };
            let mut h = Vec3::ZERO;
            h[axis] = (long - r).max(0.0);
            ([-h, h], r)
        }
    }
}

/// Inertia tensor of a shape about its centre, body frame, kg·m².
fn inertia_of(shape: &Shape, mass: f32) -> Mat3 {
    match *shape {
        Shape::Capsule {
            radius_m: r,
            length_m: l,
        } => {
            let v_cyl = std::f32::consts::PI * r * r * l;
            let v_sph = 4.0 / 3.0 * std::f32::consts::PI * r * r * r;
            let total = (v_cyl + v_sph).max(1e-12);
            let (mc, ms) = (mass * v_cyl / total, mass * v_sph / total);
            let across = mc * (l * l / 12.0 + r * r / 4.0)
                + ms * (0.4 * r * r + l * l / 4.0 + 0.375 * l * r);
            let along = mc * 0.5 * r * r + ms * 0.4 * r * r;
            Mat3::from_diagonal(Vec3::new(across, along, across))
        }
        Shape::Box { size_m: s } => {
            let k = mass / 12.0;
            Mat3::from_diagonal(Vec3::new(
                k * (s[1] * s[1] + s[2] * s[2]),
                k * (s[0] * s[0] + s[2] * s[2]),
                k * (s[0] * s[0] + s[1] * s[1]),
            ))
        }
    }
}

impl ParticleBackend {
    pub(crate) fn new(settings: ParticleSettings) -> Self {
        ParticleBackend {
            settings,
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
            push_e: [Vec::new(), Vec::new()],
            beta_o: Vec::new(),
            resid_e: Vec::new(),
            order: Vec::new(),
            distances: Vec::new(),
            middles: Vec::new(),
            joints: Vec::new(),
            pins: Vec::new(),
            filters: Vec::new(),
            filter_bits: Vec::new(),
            cross_disabled: Vec::new(),
            grid: collide::Grid::default(),
            pairs: Vec::new(),
            touched: Vec::new(),
            children: Vec::new(),
            stale: Vec::new(),
            penetration: 0.0,
            last_dt: 0.0,
            scratch: Vec::new(),
            scratch_b: Vec::new(),
        }
    }

    fn new_particle(&mut self, p: Vec3) -> u32 {
        self.x.push(p);
        self.x_prev.push(p);
        self.x_pred.push(p);
        self.v.push(Vec3::ZERO);
        self.m.push(0.0);
        self.w.push(0.0);
        self.kin.push(0);
        self.kin_from.push(p);
        self.kin_to.push(p);
        (self.x.len() - 1) as u32
    }

    /// The particle indices of body `b`.
    fn body_parts(&self, b: usize) -> std::ops::Range<usize> {
        let body = &self.bodies[b];
        body.first as usize..(body.first + body.count) as usize
    }

    /// Affine weights of the body-frame point `q` of body `b`, into `out` (one per particle).
    fn weights(&self, b: usize, q: Vec3, out: &mut [f32]) {
        let body = &self.bodies[b];
        let d = (q - body.rbar).extend(1.0);
        for (o, row) in out.iter_mut().zip(&self.affine[self.body_parts(b)]) {
            *o = row.dot(d);
        }
    }

    /// Adds one ragdoll; returns the global index of its first body.
    pub(crate) fn add_ragdoll_impl(
        &mut self,
        descs: &[BodyDesc],
        joint_descs: &[JointDesc],
        disabled: &[(usize, usize)],
    ) -> usize {
        let fb = self.bodies.len();
        let ragdoll = self.filters.len() as u32;
        let n = descs.len();
        // 1. A particle per joint anchor (anchors of one parent that coincide share one).
        let mut jp: Vec<u32> = Vec::with_capacity(joint_descs.len());
        for (k, j) in joint_descs.iter().enumerate() {
            let p = descs[j.child]
                .pose
                .transform_point(j.frame_child.translation);
            let shared = (0..k).find(|&k2| {
                joint_descs[k2].parent == j.parent
                    && (self.x[jp[k2] as usize] - p).length() < MERGE_M
            });
            let id = match shared {
                Some(k2) => jp[k2],
                None => self.new_particle(p),
            };
            jp.push(id);
        }
        let mut parent_joint: Vec<Option<usize>> = vec![None; n];
        for (k, j) in joint_descs.iter().enumerate() {
            if parent_joint[j.child].is_none() {
                parent_joint[j.child] = Some(k);
            }
        }
        // 2. Each body's particles and masses.
        for (b, desc) in descs.iter().enumerate() {
            let pose = desc.pose;
            let inv = pose.inverse();
            let (e, radius) = capsule_of(&desc.shape);
            let mut list: Vec<u32> = Vec::new();
            if let Some(k) = parent_joint[b] {
                list.push(jp[k]);
            }
            for (k, j) in joint_descs.iter().enumerate() {
                if (j.parent == b || j.child == b) && !list.contains(&jp[k]) {
                    list.push(jp[k]);
                }
            }
            if list.is_empty() {
                let (mut a, mut c) = (e[0], e[1]);
                if (c - a).length() < MIN_STICK_M {
                    let h = Vec3::Y * (0.5 * MIN_STICK_M).max(radius);
                    (a, c) = (-h, h);
                }
                list.push(self.new_particle(pose.transform_point(a)));
                list.push(self.new_particle(pose.transform_point(c)));
            } else if list.len() == 1 {
                let lb = inv.transform_point(self.x[list[0] as usize]);
                let far = if (e[0] - lb).length() > (e[1] - lb).length() {
                    e[0]
                } else {
                    e[1]
                };
                let tip = if (far - lb).length() >= MIN_STICK_M {
                    far
                } else {
                    let dir = (-lb).normalize_or(Vec3::Y);
                    lb + dir * radius.max(MIN_STICK_M)
                };
                list.push(self.new_particle(pose.transform_point(tip)));
            }
            let stick = list.len() == 2;
            let mut orient = Orient::Cluster;
            let (base, tip) = (list[0], list[1]);
            let inertia = inertia_of(&desc.shape, desc.mass);
            let mut axial_inertia = 0.0;
            let mut shares: Vec<f32>;
            if stick {
                orient = Orient::Stick {
                    joint: parent_joint[b].map(|k| k as u32),
                };
                let (ra, rb) = (
                    inv.transform_point(self.x[base as usize]),
                    inv.transform_point(self.x[tip as usize]),
                );
                let len = (rb - ra).length().max(1e-6);
                let u = (rb - ra) / len;
                let t = ((-ra).dot(u) / len).clamp(0.05, 0.95);
                let (p, q) = (t * len, (1.0 - t) * len);
                let across = 0.5
                    * (inertia.x_axis.x + inertia.y_axis.y + inertia.z_axis.z - u.dot(inertia * u));
                axial_inertia = u.dot(inertia * u).max(1e-6);
                let m = desc.mass;
                let (mut ma, mut mb) = (across / (p * (p + q)), across / (q * (p + q)));
                if ma + mb > (1.0 - MIN_CENTRE_SHARE) * m {
                    let rest = (1.0 - MIN_CENTRE_SHARE) * m;
                    ma = rest * q / (p + q);
                    mb = rest * p / (p + q);
                }
                let mid = self.new_particle(pose.transform_point(ra + u * p));
                list.push(mid);
                shares = vec![ma, mb, m - ma - mb];
                self.distances.push(Distance {
                    a: base,
                    b: tip,
                    len,
                });
                self.middles.push(Middle {
                    c: mid,
                    a: base,
                    b: tip,
                    t,
                });
            } else {
                // A cluster must span a plane: add a particle off the line if it does not.
                let p0 = self.x[list[0] as usize];
                let far = list
                    .iter()
                    .map(|&i| self.x[i as usize])
                    .max_by(|a, b| (*a - p0).length().total_cmp(&(*b - p0).length()))
                    .unwrap_or(p0);
                let dir = (far - p0).normalize_or(Vec3::Y);
                let off = list
                    .iter()
                    .map(|&i| (self.x[i as usize] - p0).reject_from(dir).length())
                    .fold(0.0f32, f32::max);
                if off < 1.0e-3 {
                    let perp = dir.any_orthonormal_vector();
                    let p = pose.translation + perp * radius.max(MIN_STICK_M);
                    list.push(self.new_particle(p));
                }
                let centre = pose.translation;
                if list
                    .iter()
                    .all(|&i| (self.x[i as usize] - centre).length() > MERGE_M)
                {
                    list.push(self.new_particle(centre));
                    let k = (list.len() - 1) as f32;
                    shares = vec![0.5 * desc.mass / k; list.len() - 1];
                    shares.push(0.5 * desc.mass);
                } else {
                    shares = vec![desc.mass / list.len() as f32; list.len()];
                }
            }
            for (&i, &s) in list.iter().zip(&shares) {
                self.m[i as usize] += s;
            }
            // Rest offsets, affine rows.
            let first = self.parts.len() as u32;
            let rest: Vec<Vec3> = list
                .iter()
                .map(|&i| inv.transform_point(self.x[i as usize]))
                .collect();
            let rbar = rest.iter().copied().sum::<Vec3>() / rest.len() as f32;
            let mut aat = Mat4::ZERO;
            for r in &rest {
                let c = (*r - rbar).extend(1.0);
                aat += Mat4::from_cols(c * c.x, c * c.y, c * c.z, c * c.w);
            }
            let trace = aat.x_axis.x + aat.y_axis.y + aat.z_axis.z;
            let eps = 1.0e-4 * trace + 1.0e-9;
            aat += Mat4::from_diagonal(Vec4::new(eps, eps, eps, 0.0));
            let inv_aat = aat.inverse();
            for (&i, r) in list.iter().zip(&rest) {
                self.parts.push(i);
                self.rest.push(*r);
                // βᵢ = cᵢᵀ (AAᵀ)⁻¹ [q − r̄; 1]: the row is (AAᵀ)⁻¹ cᵢ (symmetric).
                self.affine.push(inv_aat * (*r - rbar).extend(1.0));
            }
            let body = Body {
                ragdoll,
                first,
                count: list.len() as u32,
                orient,
                base,
                tip,
                r_base: rest[0],
                r_tip: rest[1],
                a: Vec3::X,
                g: Quat::IDENTITY,
                e,
                radius,
                rbar,
                rcm: rbar,
                mass: desc.mass,
                axial_inertia,
                twist: 0.0,
                twist_vel: 0.0,
                twist_prev: 0.0,
                rot: pose.rotation,
                pos: pose.translation,
                rot_prev: pose.rotation,
                kinematic: false,
                kin_from: pose,
                kin_to: pose,
                sync_twist: false,
            };
            self.bodies.push(body);
            let bi = fb + b;
            let count = list.len();
            let mut be = vec![vec![0.0f32; count]; 3];
            for (s, q) in [e[0], e[1], Vec3::ZERO].into_iter().enumerate() {
                self.weights(bi, q, &mut be[s]);
            }
            let resid = [0, 1].map(|s| {
                let recon: Vec3 = rest.iter().zip(&be[s]).map(|(r, b)| *r * *b).sum();
                e[s] - recon
            });
            self.resid_e.push(resid);
            self.beta_e[0].extend_from_slice(&be[0]);
            self.beta_e[1].extend_from_slice(&be[1]);
            for (push, exact) in self.push_e.iter_mut().zip(&be) {
                let total: f32 = exact.iter().map(|b| b.max(0.0)).sum();
                push.extend(exact.iter().map(|b| b.max(0.0) / total.max(1e-9)));
            }
            self.beta_o.extend_from_slice(&be[2]);
        }
        for (i, m) in self.m.iter().enumerate() {
            self.w[i] = if self.kin[i] > 0 || *m <= 0.0 {
                0.0
            } else {
                1.0 / m
            };
        }
        // Shape matching weighs the particles with their full masses (shared particles
        // carry both bodies' shares), so the matched centre is taken the same way.
        for b in fb..fb + n {
            let range = self.body_parts(b);
            let (mut sum, mut msum) = (Vec3::ZERO, 0.0f32);
            for k in range {
                let i = self.parts[k] as usize;
                sum += self.rest[k] * self.m[i];
                msum += self.m[i];
            }
            self.bodies[b].rcm = sum / msum.max(1e-12);
        }
        // 3. Joints (global body indices) and each stick's twist reference.
        for (k, j) in joint_descs.iter().enumerate() {
            self.joints.push(Joint {
                rj: ResolvedJoint {
                    parent: fb + j.parent,
                    child: fb + j.child,
                    frame_parent: j.frame_parent,
                    frame_child: j.frame_child,
                    kind: j.kind,
                },
                particle: jp[k],
            });
        }
        let first_joint = self.joints.len() - joint_descs.len();
        for b in fb..fb + n {
            if let Orient::Stick { joint: Some(k) } = self.bodies[b].orient {
                let k = first_joint + k as usize;
                self.bodies[b].orient = Orient::Stick {
                    joint: Some(k as u32),
                };
                let fc = self.joints[k].rj.frame_child.rotation;
                let body = &self.bodies[b];
                let a = fc.conjugate() * (body.r_tip - body.r_base).normalize_or(Vec3::X);
                let body = &mut self.bodies[b];
                body.a = a;
                body.g = Quat::from_rotation_arc(a, Vec3::X);
                body.sync_twist = true;
            }
        }
        // 4. Parents first.
        let mut depth = vec![0usize; n];
        for (b, d) in depth.iter_mut().enumerate() {
            let mut x = b;
            while let Some(k) = parent_joint[x] {
                x = joint_descs[k].parent;
                *d += 1;
                if *d > n {
                    break;
                }
            }
        }
        let mut local: Vec<usize> = (0..n).collect();
        local.sort_by_key(|&b| depth[b]);
        self.order.extend(local.iter().map(|&b| (fb + b) as u32));
        // 5. Collision filter: jointed pairs and the spec's pairs.
        let offset = self.filter_bits.len();
        self.filter_bits.resize(offset + (n * n).div_ceil(64), 0);
        self.filters.push(Filter {
            first_body: fb as u32,
            bodies: n as u32,
            offset,
        });
        for j in joint_descs {
            self.disable_pair(fb + j.parent, fb + j.child);
        }
        for &(a, b) in disabled {
            self.disable_pair(fb + a, fb + b);
        }
        // Bodies that share a particle would fight over it.
        for a in fb..fb + n {
            for b in a + 1..fb + n {
                let shared = self.parts[self.body_parts(a)]
                    .iter()
                    .any(|p| self.parts[self.body_parts(b)].contains(p));
                if shared {
                    self.disable_pair(a, b);
                }
            }
        }
        self.touched.resize(self.bodies.len(), false);
        self.stale.resize(self.bodies.len(), false);
        self.children.resize(self.bodies.len(), Vec::new());
        for b in fb..fb + n {
            if let Orient::Stick { joint: Some(k) } = self.bodies[b].orient {
                let parent = self.joints[k as usize].rj.parent;
                self.children[parent].push(b as u32);
            }
        }
        self.update_frames(1.0, true);
        for b in fb..fb + n {
            self.bodies[b].rot_prev = self.bodies[b].rot;
        }
        fb
    }

    /// Whether bodies `a` and `b` (global) may collide.
    fn may_collide(&self, a: usize, b: usize) -> bool {
        let (ra, rb) = (self.bodies[a].ragdoll, self.bodies[b].ragdoll);
        if ra == rb {
            let f = &self.filters[ra as usize];
            let (i, j) = (a - f.first_body as usize, b - f.first_body as usize);
            let bit = i * f.bodies as usize + j;
            self.filter_bits[f.offset + bit / 64] & (1u64 << (bit % 64)) == 0
        } else {
            let key = (a.min(b) as u32, a.max(b) as u32);
            self.cross_disabled.is_empty() || self.cross_disabled.binary_search(&key).is_err()
        }
    }

    /// Body-frame point `q` of body `b` in world space, through its particles.
    fn point_world(&self, b: usize, beta: &[f32], resid: Vec3) -> Vec3 {
        let mut p = self.bodies[b].rot * resid;
        for (k, &i) in self.parts[self.body_parts(b)].iter().enumerate() {
            p += self.x[i as usize] * beta[k];
        }
        p
    }

    /// Rigid velocity change of body `b` for a linear impulse `j` and an angular impulse
    /// `l` about its particles' centre of mass: spread over its free particles with their
    /// masses and inertia; the moment about a stick's axis goes to its twist.
    fn apply_impulse(&mut self, b: usize, j: Vec3, point: Option<Vec3>, l: Vec3) {
        let range = self.body_parts(b);
        let mut mass = 0.0f32;
        let mut c = Vec3::ZERO;
        for &i in &self.parts[range.clone()] {
            let i = i as usize;
            if self.w[i] > 0.0 {
                mass += self.m[i];
                c += self.x[i] * self.m[i];
            }
        }
        if mass <= 0.0 {
            return;
        }
        c /= mass;
        let l = l + point.map_or(Vec3::ZERO, |p| (p - c).cross(j));
        let mut inertia = Mat3::ZERO;
        for &i in &self.parts[range.clone()] {
            let i = i as usize;
            if self.w[i] > 0.0 {
                let r = self.x[i] - c;
                inertia += (Mat3::IDENTITY * r.length_squared()
                    - Mat3::from_cols(r * r.x, r * r.y, r * r.z))
                    * self.m[i];
            }
        }
        let mut l_rest = l;
        if let Orient::Stick { .. } = self.bodies[b].orient {
            let d = (self.x[self.bodies[b].tip as usize] - self.x[self.bodies[b].base as usize])
                .normalize_or(Vec3::Y);
            let axial = l.dot(d);
            let body = &mut self.bodies[b];
            body.twist_vel += axial / body.axial_inertia;
            l_rest = l - d * axial;
            // Regularise the missing axial inertia of particles on a line.
            inertia += Mat3::from_cols(d * d.x, d * d.y, d * d.z) * body.axial_inertia;
        }
        let trace = inertia.x_axis.x + inertia.y_axis.y + inertia.z_axis.z;
        inertia += Mat3::IDENTITY * (1.0e-6 * trace + 1.0e-12);
        let dw = inertia.inverse() * l_rest;
        let dv = j / mass;
        for &i in &self.parts[range] {
            let i = i as usize;
            if self.w[i] > 0.0 {
                self.v[i] += dv + dw.cross(self.x[i] - c);
            }
        }
    }

    /// Marks the bodies whose particle `p` is held kinematic.
    fn set_particle_kinematic(&mut self, p: usize, on: bool) {
        if on {
            self.kin[p] += 1;
        } else {
            self.kin[p] = self.kin[p].saturating_sub(1);
        }
        self.w[p] = if self.kin[p] > 0 || self.m[p] <= 0.0 {
            0.0
        } else {
            1.0 / self.m[p]
        };
        if self.kin[p] > 0 {
            self.kin_from[p] = self.x[p];
            self.kin_to[p] = self.x[p];
        }
    }
}

impl Backend for ParticleBackend {
    fn add_ragdoll(
        &mut self,
        bodies: &[BodyDesc],
        joints: &[JointDesc],
        disabled_pairs: &[(usize, usize)],
    ) -> usize {
        let first = self.add_ragdoll_impl(bodies, joints, disabled_pairs);
        for (k, b) in bodies.iter().enumerate() {
            if b.linvel != Vec3::ZERO || b.angvel != Vec3::ZERO {
                self.set_body_velocity(first + k, b.linvel, b.angvel);
            }
        }
        first
    }

    fn enforces_limits(&self) -> bool {
        true
    }

    fn step(&mut self, dt: f32) {
        self.step_impl(dt);
    }

    fn apply_impulse_at_point(&mut self, index: usize, impulse: Vec3, point: Vec3) {
        self.apply_impulse(index, impulse, Some(point), Vec3::ZERO);
    }

    fn apply_torque_impulse(&mut self, index: usize, impulse: Vec3) {
        self.apply_impulse(index, Vec3::ZERO, None, impulse);
    }

    fn body_states(&self, out: &mut Vec<BodyState>) {
        out.clear();
        let dt = self.last_dt;
        out.extend(self.bodies.iter().enumerate().map(|(b, body)| {
            let mut linvel = Vec3::ZERO;
            for (k, &i) in self.parts[self.body_parts(b)].iter().enumerate() {
                linvel += self.v[i as usize] * self.beta_o[body.first as usize + k];
            }
            let turn = (body.rot * body.rot_prev.conjugate()).normalize();
            let turn = if turn.w < 0.0 { -turn } else { turn };
            let angvel = if dt > 0.0 {
                turn.to_scaled_axis() / dt
            } else {
                Vec3::ZERO
            };
            BodyState {
                pose: Transform::new(body.pos, body.rot),
                linvel,
                angvel,
            }
        }));
    }

    fn max_penetration(&self) -> f32 {
        self.penetration
    }

    fn kinetic_energy(&self) -> f64 {
        let particles: f64 = self
            .v
            .iter()
            .zip(&self.m)
            .zip(&self.w)
            .filter(|(_, w)| **w > 0.0)
            .map(|((v, m), _)| 0.5 * (*m as f64) * v.length_squared() as f64)
            .sum();
        let twist: f64 = self
            .bodies
            .iter()
            .filter(|b| matches!(b.orient, Orient::Stick { .. }) && !b.kinematic)
            .map(|b| 0.5 * (b.axial_inertia as f64) * (b.twist_vel as f64).powi(2))
            .sum();
        particles + twist
    }

    fn cast_ray(&self, origin: Vec3, dir: Vec3, max_dist: f32) -> Option<(usize, f32)> {
        self.cast_ray_impl(origin, dir, max_dist)
    }

    fn set_kinematic(&mut self, index: usize, kinematic: bool) {
        if self.bodies[index].kinematic == kinematic {
            return;
        }
        self.bodies[index].kinematic = kinematic;
        let pose = Transform::new(self.bodies[index].pos, self.bodies[index].rot);
        self.bodies[index].kin_from = pose;
        self.bodies[index].kin_to = pose;
        for k in self.body_parts(index) {
            let p = self.parts[k] as usize;
            self.set_particle_kinematic(p, kinematic);
        }
        if !kinematic {
            self.bodies[index].sync_twist = true;
        }
    }

    fn set_kinematic_target(&mut self, index: usize, pose: &Transform) {
        let body = &mut self.bodies[index];
        body.kin_to = Transform::new(pose.translation, pose.rotation);
        for k in self.body_parts(index) {
            let p = self.parts[k] as usize;
            if self.kin[p] > 0 {
                self.kin_to[p] = pose.transform_point(self.rest[k]);
            }
        }
    }

    fn set_body_velocity(&mut self, index: usize, linvel: Vec3, angvel: Vec3) {
        let origin = self.bodies[index].pos;
        for k in self.body_parts(index) {
            let p = self.parts[k] as usize;
            self.v[p] = linvel + angvel.cross(self.x[p] - origin);
        }
        let body = &mut self.bodies[index];
        if let Orient::Stick { joint } = body.orient {
            body.twist_vel = if joint.is_none() {
                angvel.dot(body.rot * (body.r_tip - body.r_base).normalize_or(Vec3::Y))
            } else {
                0.0
            };
        }
    }

    fn set_joint_parent_frame(&mut self, index: usize, frame: &Transform) {
        self.joints[index].rj.frame_parent = *frame;
        let child = self.joints[index].rj.child;
        self.bodies[child].sync_twist = true;
    }

    fn set_joint_child_frame(&mut self, index: usize, frame: &Transform) {
        self.joints[index].rj.frame_child = *frame;
        let child = self.joints[index].rj.child;
        self.bodies[child].sync_twist = true;
    }

    /// The particle solver's substeps come from the world's settings; powered mode's
    /// motors act as torques here (see `drive_joint`), so they need no more.
    fn set_solver_substeps(&mut self, _substeps: usize) {}

    /// No drives inside the position solver yet: the world applies the motors as torques.
    fn drive_joint(
        &mut self,
        _index: usize,
        _target: glam::Quat,
        _target_angvel: Vec3,
        _stiffness: f32,
        _damping: f32,
    ) -> bool {
        false
    }

    fn set_joint_limits(&mut self, index: usize, kind: &JointKind) {
        self.joints[index].rj.kind = *kind;
    }

    fn set_gravity(&mut self, gravity: Vec3) {
        self.settings.gravity = gravity;
    }

    fn add_pin(
        &mut self,
        index: usize,
        local: Vec3,
        target: Vec3,
        soft: Option<(f32, f32)>,
    ) -> usize {
        self.pins.push(Pin {
            body: index as u32,
            local,
            from: target,
            target,
            soft,
            active: true,
        });
        self.pins.len() - 1
    }

    fn move_pin(&mut self, pin: usize, target: Vec3) {
        self.pins[pin].target = target;
    }

    fn release_pin(&mut self, pin: usize) {
        self.pins[pin].active = false;
    }

    fn touches_another_ragdoll(&self, first: usize, count: usize) -> bool {
        self.touched[first..first + count].iter().any(|&t| t)
    }

    fn disable_pair(&mut self, a: usize, b: usize) {
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
    }

    fn set_body_pose(&mut self, index: usize, pose: &Transform) {
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
        body.kin_from = Transform::new(pose.translation, pose.rotation);
        body.kin_to = body.kin_from;
        body.sync_twist = true;
    }
}
