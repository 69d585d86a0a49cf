//! Stepping the particles: prediction, projection passes (rigidity, joint limits, pins,
//! contacts), velocities from positions, and body frames from particles.

use glam::{Mat3, Quat, Vec3};

use super::{ParticleBackend, triad_frame};
use crate::math::Transform;
use crate::spec::JointKind;

/// A hinge counts as on its axis within this angle: below it the limit projection does not
/// run (its off-axis error is numerical), radians.
const HINGE_SLACK: f32 = 1.0e-3;

/// Violations the final projection leaves alone, radians: the solver's own turns keep
/// joints within a few degrees; the projection is for what a hard landing leaves, and
/// each of its turns, positions only, costs the next step some energy.
const PROJECT_TOLERANCE: f32 = 3.0 * std::f32::consts::PI / 180.0;
/// How far a projection may push a body below the ground before the ragdoll is lifted,
/// metres (as the shared limit projection of `rigid` and `fast`).
const PROJECT_GROUND_SLACK_M: f32 = 0.005;

/// Farthest a hard pin moves its point in one substep, metres (0.5 m at the default 720
/// substeps a second: 360 m/s, far beyond any path a scene keys).
const MAX_PIN_STEP_M: f32 = 0.5;

/// Fastest a body's centre of mass may move, m/s: rapier's default cap, which the rigid
/// backend keeps, so both backends throw a ragdoll equally far. A body faster than that
/// crosses more than a limb's length in a substep (0.56 m at the world's default 720
/// substeps a second), and the substep's projections no longer find which way its joints
/// and contacts should pull: the built-in humanoid with every part edited to 0.75 m across
/// and thrown at up to 17 km/s by a charge went non-finite under a cap of 1 or 2 km/s,
/// never under this one.
pub(crate) const MAX_SPEED_MPS: f32 = 400.0;

/// Most a body may turn in one substep, radians. Joint limits read a body's rotation from
/// its particles, modulo a turn: a body spun by more than half a turn a substep looks
/// turned the other way, and the limit's correction then pumped energy into the ragdoll
/// until it went non-finite (a 0.75 m ball of a hand, hit by a blast, spun at 2,000 rad/s).
/// At the default 720 substeps a second this is 565 rad/s (90 turns a second), three
/// times rapier's cap (π/4 a step of 1/240 s).
const MAX_TURN_PER_SUBSTEP: f32 = std::f32::consts::FRAC_PI_4;

/// Steps one search for candidate pairs serves: the search's margin covers the motion of
/// that many steps, and an impulse or a teleport starts a new search at once.
const PAIR_REUSE: u32 = 4;

/// A joint's limits in the form the inside test reads, worked out once per change.
#[derive(Clone, Copy, Debug)]
pub(super) struct Bounds {
    /// Smallest cosine of the angle between the two frames' X axes.
    min_cos: f32,
    /// Sine and cosine of half the lower and upper twist bounds; `None`: any twist.
    twist: Option<[(f32, f32); 2]>,
    /// Whether no rotation at all is allowed.
    fixed: bool,
}

impl Bounds {
    pub(super) fn of(kind: &JointKind) -> Self {
        let half = |lo: f32, hi: f32| Some([(0.5 * lo).sin_cos(), (0.5 * hi).sin_cos()]);
        match *kind {
            JointKind::Hinge { min_deg, max_deg } => Bounds {
                min_cos: HINGE_SLACK.cos(),
                twist: half(min_deg.to_radians(), max_deg.to_radians()),
                fixed: false,
            },
            JointKind::SwingTwist {
                swing_deg,
                twist_deg,
                ..
            } => Bounds {
                min_cos: swing_deg.to_radians().cos() - 1e-7,
                twist: half(twist_deg[0].to_radians(), twist_deg[1].to_radians()),
                fixed: false,
            },
            JointKind::Ball => Bounds {
                min_cos: -2.0,
                twist: None,
                fixed: false,
            },
            JointKind::Fixed => Bounds {
                min_cos: 1.0,
                twist: None,
                fixed: true,
            },
        }
    }

    /// Whether a joint's relative rotation `rel` (parent joint frame to child joint frame)
    /// is inside: no trigonometry, so that the exact clamp runs only for joints that need
    /// it.
    fn inside(&self, rel: Quat) -> bool {
        let q = if rel.w < 0.0 { -rel } else { rel };
        if self.fixed {
            return q.xyz().length_squared() < 1e-8;
        }
        // The X axis turned by q: its x component is 1 − 2(y² + z²).
        if 1.0 - 2.0 * (q.y * q.y + q.z * q.z) < self.min_cos {
            return false;
        }
        // 2·atan2(qx, qw) ∈ [lo, hi] with qw ≥ 0.
        self.twist.is_none_or(|[(s_lo, c_lo), (s_hi, c_hi)]| {
            q.x * c_hi <= q.w * s_hi + 1e-7 && q.x * c_lo >= q.w * s_lo - 1e-7
        })
    }
}

/// The relative rotation inside the limits of `kind` nearest to `rel` by swing and twist,
/// as [`crate::spec::ResolvedJoint::clamp_child_rotation`] finds it, but worked on the
/// relative rotation the caller already has: swing and twist about X, each clamped to its
/// range (a hinge also loses its swing).
fn clamp_rel(kind: &JointKind, rel: Quat) -> Quat {
    let q = if rel.w < 0.0 { -rel } else { rel };
    let tw = Quat::from_xyzw(q.x, 0.0, 0.0, q.w);
    let tw = if tw.length_squared() < 1e-12 {
        Quat::IDENTITY
    } else {
        tw.normalize()
    };
    let twist = 2.0 * q.x.atan2(q.w);
    match *kind {
        JointKind::Hinge { min_deg, max_deg } => {
            Quat::from_rotation_x(twist.clamp(min_deg.to_radians(), max_deg.to_radians()))
        }
        JointKind::SwingTwist {
            swing_deg,
            twist_deg,
            ..
        } => {
            let swing = q * tw.conjugate();
            let max = swing_deg.to_radians();
            let angle = 2.0 * swing.w.clamp(-1.0, 1.0).acos();
            let swing = if angle > max {
                let axis = swing.xyz().normalize_or(Vec3::Y);
                Quat::from_axis_angle(axis, max)
            } else {
                swing
            };
            let t = twist.clamp(twist_deg[0].to_radians(), twist_deg[1].to_radians());
            swing * Quat::from_rotation_x(t)
        }
        JointKind::Ball => q,
        JointKind::Fixed => Quat::IDENTITY,
    }
}

impl ParticleBackend {
    /// One step of `dt` seconds: candidate pairs when the last ones ran out, then the
    /// substeps.
    pub(super) fn step_impl(&mut self, dt: f32) {
        let n = self.settings.substeps.max(1);
        let h = dt / n as f32;
        self.last_dt = dt;
        for b in &mut self.bodies {
            b.rot_prev = b.rot;
        }
        self.touched.fill(false);
        self.supported.fill(false);
        if self.pairs_left == 0 {
            self.find_pairs(dt * PAIR_REUSE as f32);
            self.pairs_left = PAIR_REUSE;
        }
        self.pairs_left -= 1;
        for s in 0..n {
            let frac = (s + 1) as f32 / n as f32;
            self.predict(h, frac);
            for _ in 0..self.settings.iterations.max(1) {
                self.solve_distances();
                self.solve_affines();
                self.update_frames();
                self.solve_limits();
                self.solve_pins(h, frac);
                self.update_capsules();
                self.solve_ground();
                self.solve_pairs();
                // Contacts move bodies as rigid wholes, which drags the anchors they
                // share with their neighbours: one more sweep closes the joints again.
                self.solve_distances();
                self.solve_affines();
                // The limits again, last: the contacts and the sweep above undo part of
                // what they did, and a hard landing bends a straight knee past its stop
                // faster than one correction a pass takes it back.
                self.update_frames();
                self.solve_limits();
            }
            for i in 0..self.x.len() {
                self.v[i] += (self.x[i] - self.x_pred[i]) / h;
            }
            // As rapier caps its bodies' velocities after each substep.
            for b in 0..self.bodies.len() {
                self.bound_speed(b, MAX_TURN_PER_SUBSTEP / h);
            }
        }
        // Contacts as the solver left them (as rapier's are measured), before the
        // projection, whose overlaps the next step's contacts take up.
        self.update_frames();
        self.penetration = self.measure_penetration();
        self.solver_violation = self.measure_limit_violation();
        self.project_limits();
        for i in 0..self.x.len() {
            self.kin_from[i] = self.kin_to[i];
        }
        for p in &mut self.pins {
            p.from = p.target;
        }
    }

    /// Takes body `b`'s velocities (its free particles') down to [`MAX_SPEED_MPS`] for its
    /// centre of mass and `max_spin` rad/s for its turn, keeping the rest of its motion.
    /// Velocities too large to square in f32 are left alone: the world's check for
    /// non-finite states stops such a run.
    fn bound_speed(&mut self, b: usize, max_spin: f32) {
        let range = self.body_parts(b);
        let (mut mass, mut c, mut p) = (0.0f32, Vec3::ZERO, Vec3::ZERO);
        for &i in &self.parts[range.clone()] {
            let i = i as usize;
            if self.w[i] > 0.0 {
                mass += self.m[i];
                c += self.x[i] * self.m[i];
                p += self.v[i] * self.m[i];
            }
        }
        if mass <= 0.0 {
            return;
        }
        let (c, vc) = (c / mass, p / mass);
        let (mut l, mut inertia) = (Vec3::ZERO, Mat3::ZERO);
        for &i in &self.parts[range.clone()] {
            let i = i as usize;
            if self.w[i] > 0.0 {
                let r = self.x[i] - c;
                l += r.cross(self.v[i] - vc) * self.m[i];
                inertia += (Mat3::IDENTITY * r.length_squared()
                    - Mat3::from_cols(r * r.x, r * r.y, r * r.z))
                    * self.m[i];
            }
        }
        let trace = inertia.x_axis.x + inertia.y_axis.y + inertia.z_axis.z;
        let spin = (inertia + Mat3::IDENTITY * (1.0e-6 * trace + 1.0e-12)).inverse() * l;
        let excess = |v: Vec3, max: f32| {
            let len = v.length();
            if len > max && len.is_finite() {
                v * (1.0 - max / len)
            } else {
                Vec3::ZERO
            }
        };
        let (cut_v, cut_w) = (excess(vc, MAX_SPEED_MPS), excess(spin, max_spin));
        if cut_v == Vec3::ZERO && cut_w == Vec3::ZERO {
            return;
        }
        for &i in &self.parts[range] {
            let i = i as usize;
            if self.w[i] > 0.0 {
                self.v[i] -= cut_v + cut_w.cross(self.x[i] - c);
            }
        }
    }

    /// Gravity and velocities move the free particles (exactly, for a constant
    /// acceleration); kinematic ones go to their targets.
    fn predict(&mut self, h: f32, frac: f32) {
        let g = self.settings.gravity;
        let fall = g * (0.5 * h * h);
        for i in 0..self.x.len() {
            self.x_prev[i] = self.x[i];
            if self.w[i] > 0.0 {
                self.x[i] += self.v[i] * h + fall;
                self.v[i] += g * h;
            } else if self.kin[i] > 0 {
                self.x[i] = self.kin_from[i].lerp(self.kin_to[i], frac);
                self.v[i] = (self.x[i] - self.x_prev[i]) / h;
            }
            self.x_pred[i] = self.x[i];
        }
    }

    /// Every body's frame from its three frame particles.
    pub(super) fn update_frames(&mut self) {
        for body in &mut self.bodies {
            let [i0, i1, i2] = body.triad.map(|i| self.x[i as usize]);
            let rot = (triad_frame(i0, i1, i2) * body.tri_inv).normalize();
            body.pos = i0 - rot * body.tri_origin;
            body.rot = rot;
        }
    }

    /// The distances that keep each body rigid.
    fn solve_distances(&mut self) {
        for d in &self.distances {
            let (a, b) = (d.a as usize, d.b as usize);
            let (wa, wb) = (self.w[a], self.w[b]);
            if wa + wb <= 0.0 {
                continue;
            }
            let delta = self.x[b] - self.x[a];
            let len = delta.length();
            if len < 1e-9 {
                continue;
            }
            let corr = delta * ((len - d.len) * d.relax / (len * (wa + wb)));
            self.x[a] += corr * wa;
            self.x[b] -= corr * wb;
        }
    }

    /// Each centre particle at its combination of its body's frame particles.
    fn solve_affines(&mut self) {
        for a in &self.affines {
            let c = a.c as usize;
            let mut target = Vec3::ZERO;
            let mut den = self.w[c];
            for k in 0..4 {
                let r = a.refs[k] as usize;
                target += self.x[r] * a.alpha[k];
                den += a.alpha[k] * a.alpha[k] * self.w[r];
            }
            if den <= 0.0 {
                continue;
            }
            let lambda = (self.x[c] - target) / den;
            self.x[c] -= lambda * self.w[c];
            for k in 0..4 {
                let r = a.refs[k] as usize;
                self.x[r] += lambda * (a.alpha[k] * self.w[r]);
            }
        }
    }

    /// Joint limits: child and parent turn until the child is back inside.
    fn solve_limits(&mut self) {
        for k in 0..self.joints.len() {
            let j = &self.joints[k];
            let (p, c) = (j.parent, j.child);
            if matches!(j.kind, JointKind::Ball)
                || (self.bodies[c].kinematic && self.bodies[p].kinematic)
            {
                continue;
            }
            let (pr, cr) = (self.bodies[p].rot, self.bodies[c].rot);
            let rel = (pr * j.frame_parent.rotation).conjugate() * cr * j.frame_child.rotation;
            if self.bounds[k].inside(rel) {
                continue;
            }
            let fp = pr * j.frame_parent.rotation;
            let target = fp * clamp_rel(&j.kind, rel) * j.frame_child.rotation.conjugate();
            let anchor = self.bodies[c].pos + cr * j.frame_child.translation;
            let turn = (target * cr.conjugate()).normalize();
            let turn = if turn.w < 0.0 { -turn } else { turn };
            let delta = turn.to_scaled_axis();
            let angle = delta.length();
            if angle < 1.0e-7 {
                continue;
            }
            let axis = delta / angle;
            match (self.body_free(c), self.body_free(p)) {
                (true, true) => {
                    // XPBD's angular correction between two rigid bodies: each turns
                    // about its own centre of mass by its inverse inertia times the
                    // impulse, so neither momentum changes and the projection cannot
                    // pump energy against the floor.
                    let (bc, bp) = (&self.bodies[c], &self.bodies[p]);
                    let (ac, ap) = (cr.conjugate() * axis, pr.conjugate() * axis);
                    let (ic, ip) = (bc.inv_inertia * ac, bp.inv_inertia * ap);
                    let lambda = angle / (ac.dot(ic) + ap.dot(ip)).max(1.0e-12);
                    let (cc, cp) = (bc.pos + cr * bc.com, bp.pos + pr * bp.com);
                    self.turn_body(c, cc, cr * ic * lambda);
                    self.turn_body(p, cp, pr * ip * -lambda);
                }
                // A held parent: the child alone turns about the joint.
                (true, false) => self.turn_body(c, anchor, delta),
                // A held child: the parent turns the other way about the joint.
                (false, true) => self.turn_body(p, anchor, -delta),
                (false, false) => {}
            }
        }
    }

    /// Whether something outside the ragdoll holds body `b`: a kinematic particle or a pin
    /// (`pinned`, filled by `project_limits`).
    fn held(&self, b: usize) -> bool {
        !self.body_free(b) || self.pinned.get(b).is_some_and(|&p| p)
    }

    /// The worst limit violation of a joint with a dynamic body now, radians, by the
    /// world's measure ([`crate::spec::ResolvedJoint::violation`]).
    fn measure_limit_violation(&self) -> f32 {
        self.joints
            .iter()
            .filter(|j| !(self.bodies[j.parent].kinematic && self.bodies[j.child].kinematic))
            .map(|j| {
                let pose = |b: usize| Transform::new(self.bodies[b].pos, self.bodies[b].rot);
                j.violation(&pose(j.parent), &pose(j.child))
            })
            .fold(0.0, f32::max)
    }

    /// After the substeps, turns each joint still more than `PROJECT_TOLERANCE` past its
    /// limits back inside, positions only, parents first: the child's whole subtree turns
    /// about the joint, or the rest of the ragdoll the other way when the subtree is held or
    /// would sink into the floor; when both would, the joint is left to the next step. A
    /// hard landing bends a straight knee past its stop within one step, more than the
    /// solver's passes take back. The shared projection of `rigid` and `fast`
    /// (`backend::limits`) cannot serve here: it sets each body's particles
    /// from its frame, snapping away small distortions that the next step's distances turn
    /// into velocity (1.5 % energy in a flat drop).
    fn project_limits(&mut self) {
        // Which bodies a pin holds, once (thousands of pins made each test a search).
        let mut pinned = std::mem::take(&mut self.pinned);
        pinned.clear();
        pinned.resize(self.bodies.len(), false);
        for p in self.pins.iter().filter(|p| p.active) {
            if let Some(flag) = pinned.get_mut(p.body as usize) {
                *flag = true;
            }
        }
        self.pinned = pinned;
        for idx in 0..self.joint_order.len() {
            let k = self.joint_order[idx] as usize;
            let j = &self.joints[k];
            if matches!(j.kind, JointKind::Ball) {
                continue;
            }
            let (p, c) = (j.parent, j.child);
            let (pr, cr) = (self.bodies[p].rot, self.bodies[c].rot);
            let fp = pr * j.frame_parent.rotation;
            let rel = fp.conjugate() * cr * j.frame_child.rotation;
            if self.bounds[k].inside(rel) {
                continue;
            }
            let target = fp * clamp_rel(&j.kind, rel) * j.frame_child.rotation.conjugate();
            let turn = (target * cr.conjugate()).normalize();
            if 2.0 * turn.w.abs().min(1.0).acos() < PROJECT_TOLERANCE {
                continue;
            }
            let anchor = self.bodies[c].pos + cr * j.frame_child.translation;
            let f = &self.filters[self.bodies[c].ragdoll as usize];
            let all = f.first_body as usize..(f.first_body + f.bodies) as usize;
            self.epoch = self.epoch.wrapping_add(1);
            let epoch = self.epoch;
            let (first_joint, tree) = &self.trees[self.bodies[c].ragdoll as usize];
            for &b in tree.subtree(k - *first_joint as usize) {
                self.body_stamp[f.first_body as usize + b] = epoch;
            }
            // The subtree turns, or the rest of the ragdoll the other way: whichever is
            // free and would not sink into the floor (a limb past its stop on the floor
            // lifts the body instead). Lifting the whole ragdoll, as the world does for
            // rapier, raised a resting dragon a little every step: 45 % energy.
            let sinks = |s: &Self, sub: bool, turn: Quat| {
                let Some(g) = s.settings.ground else {
                    return false;
                };
                all.clone().any(|b| {
                    if (s.body_stamp[b] == epoch) != sub {
                        return false;
                    }
                    let (e0, e1) = s.capsule_world(b);
                    let r = s.bodies[b].radius;
                    let before = e0.y.min(e1.y) - r;
                    let (a0, a1) = (anchor + turn * (e0 - anchor), anchor + turn * (e1 - anchor));
                    a0.y.min(a1.y) - r < (g - PROJECT_GROUND_SLACK_M).min(before)
                })
            };
            let held = |s: &Self, sub: bool| {
                all.clone()
                    .any(|b| (s.body_stamp[b] == epoch) == sub && s.held(b))
            };
            let (inside_sub, turn) = if !held(self, true) && !sinks(self, true, turn) {
                (true, turn)
            } else if !held(self, false) && !sinks(self, false, turn.conjugate()) {
                (false, turn.conjugate())
            } else {
                continue;
            };
            for b in all {
                if (self.body_stamp[b] == epoch) != inside_sub {
                    continue;
                }
                for k2 in self.body_parts(b) {
                    let i = self.parts[k2] as usize;
                    if self.stamp[i] != epoch && self.w[i] > 0.0 {
                        self.stamp[i] = epoch;
                        self.x[i] = anchor + turn * (self.x[i] - anchor);
                    }
                }
                let body = &mut self.bodies[b];
                body.rot = (turn * body.rot).normalize();
                body.pos = anchor + turn * (body.pos - anchor);
            }
        }
    }

    /// Turns body `b`'s free particles and frame by the rotation vector `theta` about `centre`.
    fn turn_body(&mut self, b: usize, centre: Vec3, theta: Vec3) {
        let q = Quat::from_scaled_axis(theta);
        for k in self.body_parts(b) {
            let i = self.parts[k] as usize;
            if self.w[i] > 0.0 {
                self.x[i] = centre + q * (self.x[i] - centre);
            }
        }
        let body = &mut self.bodies[b];
        body.rot = (q * body.rot).normalize();
        body.pos = centre + q * (body.pos - centre);
    }

    /// Pins: hard ones are position constraints, soft ones XPBD springs with damping.
    fn solve_pins(&mut self, h: f32, frac: f32) {
        let mut beta = std::mem::take(&mut self.scratch);
        for k in 0..self.pins.len() {
            let pin = self.pins[k].clone();
            if !pin.active {
                continue;
            }
            let b = pin.body as usize;
            let range = self.body_parts(b);
            beta.clear();
            beta.resize(range.len(), 0.0);
            self.weights(b, pin.local, &mut beta);
            let recon: Vec3 = range
                .clone()
                .zip(&beta)
                .map(|(k2, bt)| self.rest[k2] * *bt)
                .sum();
            let point = self.point_world(b, &beta, pin.local - recon);
            let target = pin.from.lerp(pin.target, frac);
            let wsum: f32 = range
                .clone()
                .zip(&beta)
                .map(|(k2, bt)| bt * bt * self.w[self.parts[k2] as usize])
                .sum();
            if wsum <= 0.0 {
                continue;
            }
            let c = point - target;
            let lambda = match pin.soft {
                // At most `MAX_PIN_STEP_M` a substep: a target kilometres away dragged the
                // ragdoll there in one projection, and the distances that followed blew
                // it up (NaN); now it is hauled at up to 360 m/s.
                None => c.clamp_length_max(MAX_PIN_STEP_M) / wsum,
                Some((hz, zeta)) => {
                    let mass = self.bodies[b].mass;
                    let omega = std::f32::consts::TAU * hz;
                    let stiffness = mass * omega * omega;
                    let alpha = 1.0 / (stiffness * h * h);
                    let gamma = (2.0 * zeta * mass * omega) / (stiffness * h);
                    let moved: Vec3 = range
                        .clone()
                        .zip(&beta)
                        .map(|(k2, bt)| {
                            let i = self.parts[k2] as usize;
                            (self.x[i] - self.x_prev[i]) * *bt
                        })
                        .sum();
                    (c + moved * gamma) / ((1.0 + gamma) * wsum + alpha)
                }
            };
            for (k2, bt) in range.zip(&beta) {
                let i = self.parts[k2] as usize;
                self.x[i] -= lambda * (bt * self.w[i]);
            }
        }
        self.scratch = beta;
    }
}
