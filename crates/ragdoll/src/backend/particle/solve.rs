//! Stepping the particles: prediction, one projection pass per iteration (sticks, clusters,
//! joint limits, pins, contacts), velocities from positions, and body frames from particles.

use glam::{Mat3, Quat, Vec3};

use super::{LINEAR_DAMPING, Orient, ParticleBackend, TWIST_DAMPING};
use crate::math::{Transform, twist_angle_x};
use crate::spec::{JointKind, ResolvedJoint};

/// Iterations of the rotation extraction per frame update; warm started from the last
/// rotation, two are plenty for clusters that stay rigid.
const ROTATION_ITERATIONS: usize = 2;

/// A hinge counts as on its axis within this angle: below it the limit projection does not
/// run (its off-axis error is numerical), radians.
const HINGE_SLACK: f32 = 1.0e-3;

/// The orientation of a stick child: the parent's joint frame, turned by the minimal
/// rotation taking the child's rest bone direction to `d` (world, unit), then by `twist`
/// about it; a hinge's roll instead follows from its angle, so it stays in its plane.
///
/// In the joint frame, `rel = arc(X, v) · Rx(twist) · g` with `g = arc(a, X)`: `rel·a = v`
/// exactly, and its twist (the world's measure, `2·atan2(qx, qw)`) is `twist` whenever the
/// bone lies along the frame's X, as it does for every swing-twist joint of our specs.
pub(super) fn stick_rotation(
    parent_rot: Quat,
    joint: &ResolvedJoint,
    a: Vec3,
    g: Quat,
    twist: f32,
    d: Vec3,
) -> Quat {
    let f = parent_rot * joint.frame_parent.rotation;
    let v = (f.conjugate() * d).normalize_or(Vec3::X);
    let rel = match joint.kind {
        JointKind::Hinge { .. } => {
            let theta = hinge_angle(a, v);
            let r = Quat::from_rotation_x(theta);
            Quat::from_rotation_arc((r * a).normalize(), v) * r
        }
        _ => Quat::from_rotation_arc(Vec3::X, v) * Quat::from_rotation_x(twist) * g,
    };
    (f * rel * joint.frame_child.rotation.conjugate()).normalize()
}

/// Signed angle about X from `a` to `v`, both projected on the YZ plane, radians.
fn hinge_angle(a: Vec3, v: Vec3) -> f32 {
    let (ap, vp) = (Vec3::new(0.0, a.y, a.z), Vec3::new(0.0, v.y, v.z));
    if ap.length_squared() < 1e-12 || vp.length_squared() < 1e-12 {
        return 0.0;
    }
    ap.cross(vp).x.atan2(ap.dot(vp))
}

/// The twist state that makes [`stick_rotation`] give the body rotation `rot`.
fn twist_of(parent_rot: Quat, joint: &ResolvedJoint, a: Vec3, g: Quat, rot: Quat) -> f32 {
    let f = parent_rot * joint.frame_parent.rotation;
    let rel = (f.conjugate() * rot * joint.frame_child.rotation).normalize();
    let v = (rel * a).normalize_or(Vec3::X);
    twist_angle_x(Quat::from_rotation_arc(Vec3::X, v).conjugate() * rel * g.conjugate())
}

/// Rotation part of `a` (Müller, Bender, Chentanez, Macklin 2016, "A Robust Method to
/// Extract the Rotational Part of Deformations"), improving the guess `q`.
fn extract_rotation(a: &Mat3, mut q: Quat) -> Quat {
    for _ in 0..ROTATION_ITERATIONS {
        let r = Mat3::from_quat(q);
        let num = r.x_axis.cross(a.x_axis) + r.y_axis.cross(a.y_axis) + r.z_axis.cross(a.z_axis);
        let den = (r.x_axis.dot(a.x_axis) + r.y_axis.dot(a.y_axis) + r.z_axis.dot(a.z_axis)).abs()
            + 1.0e-9;
        let omega = num / den;
        let angle = omega.length();
        if angle < 1.0e-9 {
            break;
        }
        q = (Quat::from_axis_angle(omega / angle, angle) * q).normalize();
    }
    q
}

/// Whether a joint's relative rotation `rel` (parent joint frame to child joint frame) is
/// inside its limits: a cheap test with no trigonometry, so that the exact clamp runs only
/// for joints that need it.
fn inside(kind: &JointKind, rel: Quat) -> bool {
    let q = if rel.w < 0.0 { -rel } else { rel };
    let x2 = q * Vec3::X;
    // 2·atan2(qx, qw) ∈ [lo, hi] with qw ≥ 0.
    let twist_in = |lo: f32, hi: f32| {
        let (s_lo, c_lo) = (0.5 * lo).sin_cos();
        let (s_hi, c_hi) = (0.5 * hi).sin_cos();
        q.x * c_hi <= q.w * s_hi + 1e-7 && q.x * c_lo >= q.w * s_lo - 1e-7
    };
    match *kind {
        JointKind::Hinge { min_deg, max_deg } => {
            x2.x >= HINGE_SLACK.cos() && twist_in(min_deg.to_radians(), max_deg.to_radians())
        }
        JointKind::SwingTwist {
            swing_deg,
            twist_deg,
            ..
        } => {
            x2.x >= swing_deg.to_radians().cos() - 1e-7
                && twist_in(twist_deg[0].to_radians(), twist_deg[1].to_radians())
        }
        JointKind::Ball => true,
        JointKind::Fixed => q.xyz().length_squared() < 1e-8,
    }
}

impl ParticleBackend {
    /// One step of `dt` seconds: candidate pairs once, then the substeps.
    pub(super) fn step_impl(&mut self, dt: f32) {
        let n = self.settings.substeps.max(1);
        let h = dt / n as f32;
        self.last_dt = dt;
        for b in &mut self.bodies {
            b.rot_prev = b.rot;
        }
        self.touched.fill(false);
        self.find_pairs(dt);
        for s in 0..n {
            let frac = (s + 1) as f32 / n as f32;
            self.predict(h, frac);
            for _ in 0..self.settings.iterations.max(1) {
                self.solve_sticks();
                self.solve_clusters();
                // Fresh frames once per pass (clusters are fresh from their matching):
                // the limits read them, and the turns they make keep them up to date.
                self.update_frames(frac, false);
                self.solve_limits();
                self.solve_pins(h, frac);
                self.solve_ground();
                self.solve_pairs();
            }
            for i in 0..self.x.len() {
                self.v[i] += (self.x[i] - self.x_pred[i]) / h;
            }
            // The twist is a position-based coordinate too: its rate is what the
            // projections left of its change.
            for body in &mut self.bodies {
                if let Orient::Stick { joint: Some(_) } = body.orient
                    && !body.kinematic
                {
                    body.twist_vel = (body.twist - body.twist_prev) / h;
                }
            }
        }
        self.update_frames(1.0, true);
        for body in &mut self.bodies {
            body.kin_from = body.kin_to;
        }
        for i in 0..self.x.len() {
            self.kin_from[i] = self.kin_to[i];
        }
        for p in &mut self.pins {
            p.from = p.target;
        }
        self.penetration = self.measure_penetration();
    }

    /// Gravity and velocities move the free particles; kinematic ones go to their targets.
    fn predict(&mut self, h: f32, frac: f32) {
        let g = self.settings.gravity * h;
        let damp = (1.0 - LINEAR_DAMPING * h).max(0.0);
        for i in 0..self.x.len() {
            self.x_prev[i] = self.x[i];
            if self.w[i] > 0.0 {
                self.v[i] = (self.v[i] + g) * damp;
                self.x[i] += self.v[i] * h;
            } else if self.kin[i] > 0 {
                self.x[i] = self.kin_from[i].lerp(self.kin_to[i], frac);
                self.v[i] = (self.x[i] - self.x_prev[i]) / h;
            }
            self.x_pred[i] = self.x[i];
        }
        let twist_damp = (1.0 - TWIST_DAMPING * h).max(0.0);
        for body in &mut self.bodies {
            if body.kinematic {
                continue;
            }
            if let Orient::Stick { joint } = body.orient {
                body.twist_vel *= twist_damp;
                body.twist_prev = body.twist;
                match joint {
                    Some(_) => body.twist += body.twist_vel * h,
                    None => {
                        let d = (self.x[body.tip as usize] - self.x[body.base as usize])
                            .normalize_or(Vec3::Y);
                        body.rot =
                            (Quat::from_axis_angle(d, body.twist_vel * h) * body.rot).normalize();
                    }
                }
            }
        }
    }

    /// Body frames from the particles (and twists), parents first; kinematic bodies at
    /// `frac` of the way to their targets; clusters matched again only with `clusters`.
    pub(super) fn update_frames(&mut self, frac: f32, clusters: bool) {
        for idx in 0..self.order.len() {
            let b = self.order[idx] as usize;
            if self.bodies[b].kinematic {
                let body = &mut self.bodies[b];
                body.pos = body
                    .kin_from
                    .translation
                    .lerp(body.kin_to.translation, frac);
                body.rot = body.kin_from.rotation.slerp(body.kin_to.rotation, frac);
                body.sync_twist = true;
            }
            match self.bodies[b].orient {
                Orient::Cluster => {
                    if clusters && !self.bodies[b].kinematic {
                        self.match_cluster(b, false);
                    }
                }
                Orient::Stick { joint: Some(k) } => {
                    let k = k as usize;
                    if self.bodies[b].sync_twist {
                        let parent_rot = self.bodies[self.joints[k].rj.parent].rot;
                        let body = &self.bodies[b];
                        let t = twist_of(parent_rot, &self.joints[k].rj, body.a, body.g, body.rot);
                        let body = &mut self.bodies[b];
                        body.twist = t;
                        body.twist_prev = t;
                        body.sync_twist = body.kinematic;
                    }
                    if !self.bodies[b].kinematic {
                        self.stick_frame(b, k);
                    }
                }
                Orient::Stick { joint: None } => {
                    if !self.bodies[b].kinematic {
                        let body = &self.bodies[b];
                        let d = (self.x[body.tip as usize] - self.x[body.base as usize])
                            .normalize_or(Vec3::Y);
                        let cur = (body.rot * (body.r_tip - body.r_base)).normalize_or(d);
                        let rot = (Quat::from_rotation_arc(cur, d) * body.rot).normalize();
                        let pos = self.x[body.base as usize] - rot * body.r_base;
                        let body = &mut self.bodies[b];
                        body.rot = rot;
                        body.pos = pos;
                        body.sync_twist = false;
                    }
                }
            }
        }
    }

    /// A stick's frame from its particles, its parent's rotation and its twist.
    fn stick_frame(&mut self, b: usize, k: usize) {
        let j = &self.joints[k].rj;
        let body = &self.bodies[b];
        let d = (self.x[body.tip as usize] - self.x[body.base as usize]).normalize_or(Vec3::Y);
        let rot = stick_rotation(self.bodies[j.parent].rot, j, body.a, body.g, body.twist, d);
        let pos = self.x[body.base as usize] - rot * body.r_base;
        let body = &mut self.bodies[b];
        body.rot = rot;
        body.pos = pos;
    }

    /// Shape matching of cluster `b`: its best-fit rotation and position; with `project`,
    /// its free particles also move onto the matched rigid shape.
    fn match_cluster(&mut self, b: usize, project: bool) {
        let range = self.body_parts(b);
        let mut c = Vec3::ZERO;
        let mut msum = 0.0f32;
        for &i in &self.parts[range.clone()] {
            let i = i as usize;
            c += self.x[i] * self.m[i];
            msum += self.m[i];
        }
        c /= msum.max(1e-12);
        let rcm = self.bodies[b].rcm;
        let mut a = Mat3::ZERO;
        for k in range.clone() {
            let i = self.parts[k] as usize;
            let p = (self.x[i] - c) * self.m[i];
            let q = self.rest[k] - rcm;
            a += Mat3::from_cols(p * q.x, p * q.y, p * q.z);
        }
        let rot = extract_rotation(&a, self.bodies[b].rot);
        let body = &mut self.bodies[b];
        body.rot = rot;
        body.pos = c - rot * rcm;
        if project {
            for k in range {
                let i = self.parts[k] as usize;
                if self.w[i] > 0.0 {
                    self.x[i] = c + rot * (self.rest[k] - rcm);
                }
            }
        }
    }

    /// Stick lengths, and each stick's centre on its segment.
    fn solve_sticks(&mut self) {
        for k in 0..self.distances.len() {
            let d = self.distances[k];
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
            let corr = delta * ((len - d.len) / (len * (wa + wb)));
            self.x[a] += corr * wa;
            self.x[b] -= corr * wb;
        }
        for k in 0..self.middles.len() {
            let m = self.middles[k];
            let (c, a, b) = (m.c as usize, m.a as usize, m.b as usize);
            let t = m.t;
            let (wc, wa, wb) = (self.w[c], self.w[a], self.w[b]);
            let den = wc + (1.0 - t) * (1.0 - t) * wa + t * t * wb;
            if den <= 0.0 {
                continue;
            }
            let lambda = (self.x[c] - self.x[a].lerp(self.x[b], t)) / den;
            self.x[c] -= lambda * wc;
            self.x[a] += lambda * ((1.0 - t) * wa);
            self.x[b] += lambda * (t * wb);
        }
    }

    /// Every cluster back to its rigid shape.
    fn solve_clusters(&mut self) {
        for idx in 0..self.order.len() {
            let b = self.order[idx] as usize;
            if self.bodies[b].orient == Orient::Cluster && !self.bodies[b].kinematic {
                self.match_cluster(b, true);
            }
        }
    }

    /// Joint limits: child and parent turn until the child is back inside; a stick's twist
    /// follows its turned frame.
    fn solve_limits(&mut self) {
        for k in 0..self.joints.len() {
            let (p, c) = (self.joints[k].rj.parent, self.joints[k].rj.child);
            if self.bodies[c].kinematic {
                continue;
            }
            if matches!(self.joints[k].rj.kind, JointKind::Ball) {
                continue;
            }
            // A turn earlier in this pass moved a stick's base or its parent's frame.
            for b in [p, c] {
                if self.stale[b] {
                    self.stale[b] = false;
                    if let Orient::Stick { joint: Some(jk) } = self.bodies[b].orient {
                        self.stick_frame(b, jk as usize);
                    }
                }
            }
            let j = &self.joints[k].rj;
            let (pr, cr) = (self.bodies[p].rot, self.bodies[c].rot);
            let rel = (pr * j.frame_parent.rotation).conjugate() * cr * j.frame_child.rotation;
            if inside(&j.kind, rel) {
                continue;
            }
            let parent = Transform::new(self.bodies[p].pos, pr);
            let child = Transform::new(self.bodies[c].pos, cr);
            let Some(target) = j.clamp_child_rotation(&parent, &child) else {
                continue;
            };
            let turn = (target * cr.conjugate()).normalize();
            let turn = if turn.w < 0.0 { -turn } else { turn };
            let delta = turn.to_scaled_axis();
            let angle = delta.length();
            if angle < 1.0e-7 {
                continue;
            }
            let axis = delta / angle;
            let joint_particle = self.joints[k].particle as usize;
            let free = |b: usize| {
                (self.w[joint_particle] > 0.0)
                    .then(|| self.rotational_inertia(b))
                    .flatten()
            };
            match (free(c), free(p)) {
                (Some((cc, ic)), Some((cp, ip))) => {
                    // XPBD's angular correction between two rigid bodies: each turns
                    // about its own centre of mass by its inverse inertia times the
                    // impulse, so neither momentum changes and the projection cannot
                    // pump energy against the floor; the sticks and clusters then close
                    // the joint the turns opened.
                    let (wc, wp) = (axis.dot(ic * axis), axis.dot(ip * axis));
                    let lambda = angle / (wc + wp).max(1.0e-12);
                    self.turn_body(c, cc, ic * axis * lambda);
                    self.turn_body(p, cp, ip * axis * -lambda);
                }
                _ => {
                    // Held parent (or joint): the child alone turns about the joint.
                    let xj = self.x[joint_particle];
                    self.turn_body(c, xj, delta);
                }
            }
            // Sticks keep the turn's roll about their bone in their twist.
            self.resync_twist(c);
            self.resync_twist(p);
            for b in [c, p] {
                for idx in 0..self.children[b].len() {
                    let ch = self.children[b][idx] as usize;
                    if ch != c {
                        self.stale[ch] = true;
                    }
                }
            }
        }
        self.stale.fill(false);
    }

    /// Centre of mass and inverse inertia tensor (world, about that centre) of body `b`'s
    /// particles, or `None` when one of them is held; a stick's missing inertia about its
    /// bone is its twist inertia.
    fn rotational_inertia(&self, b: usize) -> Option<(Vec3, Mat3)> {
        let parts = &self.parts[self.body_parts(b)];
        let (mut c, mut mass) = (Vec3::ZERO, 0.0f32);
        for &i in parts {
            let i = i as usize;
            if self.w[i] <= 0.0 {
                return None;
            }
            c += self.x[i] * self.m[i];
            mass += self.m[i];
        }
        c /= mass;
        let mut inertia = Mat3::ZERO;
        for &i in parts {
            let (r, m) = (self.x[i as usize] - c, self.m[i as usize]);
            inertia += (Mat3::IDENTITY * r.length_squared()
                - Mat3::from_cols(r * r.x, r * r.y, r * r.z))
                * m;
        }
        let body = &self.bodies[b];
        if let Orient::Stick { .. } = body.orient {
            let d = (self.x[body.tip as usize] - self.x[body.base as usize]).normalize_or(Vec3::Y);
            inertia += Mat3::from_cols(d * d.x, d * d.y, d * d.z) * body.axial_inertia;
        }
        let trace = inertia.x_axis.x + inertia.y_axis.y + inertia.z_axis.z;
        inertia += Mat3::IDENTITY * (1.0e-6 * trace + 1.0e-12);
        Some((c, inertia.inverse()))
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

    /// Sets stick `b`'s twist from its current rotation (after something turned it as a
    /// whole); a twist rate against the change is stopped, as a limit stop does.
    fn resync_twist(&mut self, b: usize) {
        let Orient::Stick { joint: Some(k) } = self.bodies[b].orient else {
            return;
        };
        let j = &self.joints[k as usize].rj;
        if matches!(j.kind, JointKind::Hinge { .. }) {
            return;
        }
        let body = &self.bodies[b];
        let t = twist_of(self.bodies[j.parent].rot, j, body.a, body.g, body.rot);
        self.bodies[b].twist = t;
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
                None => c / wsum,
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
