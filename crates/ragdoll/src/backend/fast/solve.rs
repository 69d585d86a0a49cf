//! One step of the fast backend: candidate pairs, then island by island the substeps
//! (prediction, one constraint pass on positions or `iterations` of them, velocities read
//! back, the contacts' normal velocity taken away: Müller et al. 2020, algorithm 2), and
//! sleeping at the end.

use glam::{Mat3, Quat, Vec3};

use super::{FastBackend, Joint, Limits, Twist};
use crate::math::twist_angle_x;

/// Fastest a body may move, m/s, and turn, rad/s: past these a step's motion is larger than
/// any body, and a solver fed such motion only amplifies it. A blast's near field reaches a
/// few hundred m/s.
const MAX_SPEED_MPS: f32 = 400.0;
const MAX_SPIN_RADPS: f32 = 500.0;
/// Friction coefficient of a joint pressed against its cone (see
/// [`FastBackend::limit_friction`]): as skin on a floor.
const LIMIT_FRICTION: f32 = 0.7;

/// The cross-product matrix of `r`: `skew(r) * v == r × v`.
#[inline]
fn skew(r: Vec3) -> Mat3 {
    Mat3::from_cols(
        Vec3::new(0.0, r.z, -r.y),
        Vec3::new(-r.z, 0.0, r.x),
        Vec3::new(r.y, -r.x, 0.0),
    )
}

/// The angular velocity that turns by `dq` (a small rotation, world) in `1 / inv_h`
/// seconds.
#[inline]
pub(super) fn turn_rate(dq: Quat, inv_h: f32) -> Vec3 {
    let dq = if dq.w < 0.0 { -dq } else { dq };
    Vec3::new(dq.x, dq.y, dq.z) * (2.0 * inv_h)
}

/// The rotation vector (axis × angle, shortest way) of the unit quaternion `q`.
#[inline]
pub(super) fn rotation_vector(q: Quat) -> Vec3 {
    let q = if q.w < 0.0 { -q } else { q };
    let v = Vec3::new(q.x, q.y, q.z);
    let s = v.length();
    if s < 1.0e-9 {
        return 2.0 * v;
    }
    v * (2.0 * s.atan2(q.w) / s)
}

/// Where substep `s` of `n` starts and ends, as fractions of the step.
pub(super) fn substep_fractions(s: usize, n: usize) -> (f32, f32) {
    (s as f32 / n as f32, (s + 1) as f32 / n as f32)
}

impl FastBackend {
    pub(super) fn step_impl(&mut self, dt: f32) {
        self.find_pairs(dt);
        self.find_closing();
        self.thaw_before_impacts();
        self.collide
            .begin_step(self.pos.len(), self.settings.gravity);
        self.step_islands(dt);
        self.update_freezing(dt);
        for k in self.kinematic.iter_mut().flatten() {
            k.from = k.to;
        }
        for p in &mut self.pins {
            p.from = p.to;
        }
        self.update_sleep(dt);
    }

    /// The substeps of one step of everything in this solver (one island's), and the
    /// velocities the world sees. An island holds awake ragdolls only, so nothing here
    /// asks whether a body sleeps. An island cut in two runs the same phases on each part
    /// and the contacts between them after each (`split.rs`).
    pub(super) fn solve_step(&mut self, dt: f32) {
        let n = self.begin_solve(dt);
        let h = dt / n as f32;
        for s in 0..n {
            let (frac0, frac) = substep_fractions(s, n);
            self.begin_substep(h, frac, dt);
            for pass in 0..self.passes() {
                self.solve_pass(pass, h, frac0, frac);
            }
            self.end_substep(h);
        }
        self.end_solve(dt);
    }

    /// Readies the step of `dt`: this step's pairs culled, the poses it starts from kept.
    /// Returns the number of substeps.
    pub(super) fn begin_solve(&mut self, dt: f32) -> usize {
        self.collide
            .begin_step(self.shape.len(), self.settings.gravity);
        self.cull_pairs(dt);
        self.collide.tests.clear();
        self.collide.tests.resize(self.ragdolls.len(), 0);
        self.step_pos.clone_from(&self.pos);
        self.step_rot.clone_from(&self.rot);
        self.settings.substeps.max(1)
    }

    /// Passes of the joints and contacts each substep.
    pub(super) fn passes(&self) -> usize {
        self.settings.iterations.max(1)
    }

    /// A substep of `h` ending `frac` of the way through the step of `dt`: drives, then
    /// every body's predicted pose.
    pub(super) fn begin_substep(&mut self, h: f32, frac: f32, dt: f32) {
        self.collide.elapsed = frac * dt;
        self.collide.h = h;
        self.apply_drives(h);
        self.integrate(h, frac);
    }

    /// One pass of the joints, the pins (the first pass only) and the contacts.
    pub(super) fn solve_pass(&mut self, pass: usize, h: f32, frac0: f32, frac: f32) {
        self.solve_joints();
        // Once a substep: a soft pin's compliance is per pass (no multiplier is kept
        // between passes), so a second pass would stiffen its spring.
        if pass == 0 {
            self.solve_pins(h, frac0, frac);
        }
        self.solve_contacts();
    }

    /// The substep's velocities, read back from its motion, less the contacts' normal
    /// velocity.
    pub(super) fn end_substep(&mut self, h: f32) {
        self.update_velocities(h);
        self.solve_contact_velocities();
    }

    /// The velocities the world sees, and which compounds took a blow.
    pub(super) fn end_solve(&mut self, dt: f32) {
        self.observe_velocities(dt);
        self.check_jolts(dt);
    }

    /// Predicts every dynamic body's pose from its velocity; kinematic bodies go `frac` of
    /// the way to their targets.
    fn integrate(&mut self, h: f32, frac: f32) {
        let g = self.settings.gravity;
        for i in 0..self.pos.len() {
            self.prev_pos[i] = self.pos[i];
            self.prev_rot[i] = self.rot[i];
            if let Some(k) = self.kinematic[i] {
                self.pos[i] = k.from.translation.lerp(k.to.translation, frac);
                self.rot[i] = k.from.rotation.slerp(k.to.rotation, frac);
                self.refresh_inertia(i);
                continue;
            }
            let v = (self.vel[i] + g * h).clamp_length_max(MAX_SPEED_MPS);
            let w = self.angvel[i].clamp_length_max(MAX_SPIN_RADPS);
            self.vel[i] = v;
            self.angvel[i] = w;
            self.pos[i] += v * h;
            self.turn_by(i, w * h);
            self.rot[i] = self.rot[i].normalize();
            self.moved[i] = Vec3::ZERO;
            self.pred_rot[i] = self.rot[i];
            self.refresh_inertia(i);
        }
    }

    /// Velocities from the substep's motion: the predicted velocity plus what the
    /// constraints moved the body by, over the substep. Reading the whole motion back
    /// instead, `(x − x₀) / h`, loses the velocity to f32 rounding of the positions: a
    /// body 5 m from the origin moving 5 mm per substep kept 4 digits of it, and a free
    /// fall over 1 s came out 0.3 % long at 1920 substeps (longer the more substeps).
    /// What the constraints moved is summed as they move it, not read as the position
    /// less the prediction: that difference carries the positions' rounding too (a tenth
    /// of a micrometre a metre from the origin, over a substep of 1/1920 s), and a shot
    /// humanoid floating in zero gravity gained 0.5 N·s of momentum it was never given in
    /// half a second.
    fn update_velocities(&mut self, h: f32) {
        let inv_h = 1.0 / h;
        for i in 0..self.pos.len() {
            self.rot[i] = self.rot[i].normalize();
            if self.kinematic[i].is_some() {
                self.vel[i] = (self.pos[i] - self.prev_pos[i]) * inv_h;
                self.angvel[i] = turn_rate(self.rot[i] * self.prev_rot[i].conjugate(), inv_h);
                continue;
            }
            self.vel[i] += self.moved[i] * inv_h;
            self.angvel[i] += turn_rate(self.rot[i] * self.pred_rot[i].conjugate(), inv_h);
        }
    }

    /// Moves bodies `a` and `b` (`None`: the world) so that the point at offset `ra` of
    /// `a` travels `delta` toward the point at `rb` of `b`, sharing the motion by their
    /// generalised inverse masses. Returns the impulse's magnitude (the constraint's
    /// Lagrange multiplier), 0 when nothing can move.
    #[inline]
    pub(super) fn correct_position(
        &mut self,
        a: usize,
        b: Option<usize>,
        ra: Vec3,
        rb: Vec3,
        delta: Vec3,
    ) -> f32 {
        let c = delta.length();
        if c < 1.0e-9 {
            return 0.0;
        }
        let n = delta / c;
        let w = self.w_at(a, ra, n) + b.map_or(0.0, |b| self.w_at(b, rb, n));
        if w <= 0.0 {
            return 0.0;
        }
        let lambda = c / w;
        let p = n * lambda;
        self.shift(a, ra, p);
        if let Some(b) = b {
            self.shift(b, rb, -p);
        }
        lambda
    }

    /// Turns `a` by the rotation vector `omega` relative to `b`, shared by their inverse
    /// inertias about its axis. Returns the angular impulse's magnitude.
    #[inline]
    fn correct_rotation(&mut self, a: usize, b: usize, omega: Vec3) -> f32 {
        let theta = omega.length();
        if theta < 1.0e-9 {
            return 0.0;
        }
        let n = omega / theta;
        let w = self.w_turn(a, n) + self.w_turn(b, n);
        if w <= 0.0 {
            return 0.0;
        }
        let lambda = theta / w;
        let p = n * lambda;
        let wa = self.inv_inertia_world(a, p);
        let wb = self.inv_inertia_world(b, p);
        self.turn_by(a, wa);
        self.turn_by(b, -wb);
        lambda
    }

    /// Friction of a joint pressed against its limit: the two bodies' relative turning
    /// along the limit's edge in this substep (any turn not about `n`, the axis the limit
    /// pushed about with angular impulse `lambda`) is held back by up to
    /// [`LIMIT_FRICTION`] times that impulse, as a contact's sliding is by its normal
    /// impulse. Without it a part hanging at its cone's edge swings along the edge for
    /// good: a lying humanoid's feet circled their ankle cones at 1-2 rad/s for as long
    /// as we watched, and it never slept.
    fn limit_friction(&mut self, a: usize, b: usize, n: Vec3, lambda: f32) {
        // A substep's turns are small: twice the quaternion's vector part is their angle.
        let da = turn_rate(self.rot[a] * self.prev_rot[a].conjugate(), 1.0);
        let db = turn_rate(self.rot[b] * self.prev_rot[b].conjugate(), 1.0);
        let rel = db - da;
        let slide = rel - n * n.dot(rel);
        let len = slide.length();
        if len < 1.0e-9 {
            return;
        }
        let t = slide / len;
        let w = self.w_turn(a, t) + self.w_turn(b, t);
        if w > 0.0 {
            self.correct_rotation(a, b, t * len.min(LIMIT_FRICTION * lambda * w));
        }
    }

    /// One pass over every joint: angles first (they move the anchors), then the anchors.
    fn solve_joints(&mut self) {
        for k in 0..self.joints.len() {
            let (a, b) = (self.joints[k].a, self.joints[k].b);
            self.solve_angles(k);
            let j = &self.joints[k];
            let ra = self.rot[a] * j.frame_a.translation;
            let rb = self.rot[b] * j.frame_b.translation;
            let delta = (self.pos[b] + rb) - (self.pos[a] + ra);
            self.join_anchors(a, b, ra, rb, delta * j.relax);
        }
    }

    /// Moves `a`'s anchor (offset `ra`) and `b`'s (offset `rb`) together by `delta`, as
    /// one three-dimensional constraint: the impulse is the point's 3×3 effective mass
    /// times the gap. Three scalar corrections along the gap instead leave a gap across
    /// it wherever a body's inertia is uneven (a shin spins about its length eight times
    /// more easily than it tips), which the next substep takes back the other way.
    #[inline]
    fn join_anchors(&mut self, a: usize, b: usize, ra: Vec3, rb: Vec3, delta: Vec3) {
        if delta.length_squared() < 1.0e-18 {
            return;
        }
        let k = self.point_mass_matrix(a, ra) + self.point_mass_matrix(b, rb);
        if k.determinant().abs() < 1.0e-20 {
            return;
        }
        let p = k.inverse() * delta;
        if !p.is_finite() {
            return;
        }
        self.shift(a, ra, p);
        self.shift(b, rb, -p);
    }

    /// How body `i`'s point at offset `r` moves per unit impulse there: `1/m − [r]× I⁻¹ [r]×`.
    #[inline]
    fn point_mass_matrix(&self, i: usize, r: Vec3) -> Mat3 {
        let rx = skew(r);
        Mat3::from_diagonal(Vec3::splat(self.inv_mass[i]))
            - rx * Mat3::from(self.inv_inertia_world[i]) * rx
    }

    /// Turns `a` relative to `b` by the rotation vector `omega`, as one constraint on the
    /// two or three axes it holds (the relative inverse inertia solved as a matrix): all
    /// three for a weld (`free` = `None`), the two across the hinge axis `free` for a
    /// hinge. See [`FastBackend::join_anchors`] for why not one axis at a time.
    #[inline]
    fn align(&mut self, a: usize, b: usize, omega: Vec3, free: Option<Vec3>) {
        if omega.length_squared() < 1.0e-18 {
            return;
        }
        let k = Mat3::from(self.inv_inertia_world[a] + self.inv_inertia_world[b]);
        let p = match free {
            None => {
                if k.determinant().abs() < 1.0e-20 {
                    return;
                }
                k.inverse() * omega
            }
            Some(axis) => {
                let (u, v) = axis.any_orthonormal_pair();
                let (ku, kv) = (k * u, k * v);
                let (k11, k12, k22) = (u.dot(ku), u.dot(kv), v.dot(kv));
                let det = k11 * k22 - k12 * k12;
                if det.abs() < 1.0e-20 {
                    return;
                }
                let (e1, e2) = (u.dot(omega), v.dot(omega));
                let l1 = (k22 * e1 - k12 * e2) / det;
                let l2 = (k11 * e2 - k12 * e1) / det;
                u * l1 + v * l2
            }
        };
        if !p.is_finite() {
            return;
        }
        let (wa, wb) = (self.inv_inertia_world(a, p), self.inv_inertia_world(b, p));
        self.turn_by(a, wa);
        self.turn_by(b, -wb);
    }

    /// The joint's angular constraints: alignment for a hinge or a weld, then the limits.
    /// At a light hub the alignment takes the joint's relaxed share, as its anchor does;
    /// the limits, which act only once crossed, take the full correction: relaxed too,
    /// they left a spider's legs 6° past their cones, and the end-of-step clamp that turned
    /// them back gained 41 % energy on landing (1.4 % unrelaxed).
    fn solve_angles(&mut self, k: usize) {
        let Joint {
            a,
            b,
            frame_a,
            frame_b,
            limits,
            relax,
            ..
        } = self.joints[k].clone();
        let fa = self.rot[a] * frame_a.rotation;
        let fb = self.rot[b] * frame_b.rotation;
        match limits {
            Limits::Ball => {}
            Limits::Fixed => {
                let omega = rotation_vector(fb * fa.conjugate());
                self.align(a, b, omega * relax, None);
            }
            Limits::Hinge(twist) => {
                let (xa, xb) = (fa * Vec3::X, fb * Vec3::X);
                self.align(a, b, xa.cross(xb) * relax, Some(xa));
                let fa = self.rot[a] * frame_a.rotation;
                let fb = self.rot[b] * frame_b.rotation;
                self.limit_twist(a, b, fa, fb, &twist);
            }
            Limits::SwingTwist {
                swing,
                cos_swing,
                twist,
            } => {
                let (xa, xb) = (fa * Vec3::X, fb * Vec3::X);
                let cos = xa.dot(xb);
                if cos < cos_swing {
                    let axis = xa.cross(xb);
                    let sin = axis.length();
                    if sin > 1.0e-9 {
                        let n = axis / sin;
                        let angle = sin.atan2(cos);
                        let lambda = self.correct_rotation(a, b, n * (angle - swing));
                        self.limit_friction(a, b, n, lambda);
                    }
                }
                let fa = self.rot[a] * frame_a.rotation;
                let fb = self.rot[b] * frame_b.rotation;
                self.limit_twist(a, b, fa, fb, &twist);
            }
        }
    }

    /// Keeps the twist of `fb` about its X axis relative to `fa` (the swing-twist
    /// decomposition's, the measure the metrics use) within `[min, max]`: turning `b`
    /// about its own X changes the twist alone.
    fn limit_twist(&mut self, a: usize, b: usize, fa: Quat, fb: Quat, twist: &Twist) {
        let rel = fa.conjugate() * fb;
        if !twist.crossed(rel) {
            return;
        }
        let t = twist_angle_x(rel);
        let over = if t > twist.max {
            t - twist.max
        } else if t < twist.min {
            t - twist.min
        } else {
            return;
        };
        let n = fb * Vec3::X;
        let lambda = self.correct_rotation(a, b, n * over);
        self.limit_friction(a, b, n, lambda);
    }

    /// Pins: hard ones as a ball joint to the moving anchor, soft ones as an implicit
    /// damped spring on the velocity.
    fn solve_pins(&mut self, h: f32, frac0: f32, frac: f32) {
        for k in 0..self.pins.len() {
            let p = self.pins[k];
            if !p.active {
                continue;
            }
            let target = p.from.lerp(p.to, frac);
            let r = self.rot[p.body] * p.local;
            let at = self.pos[p.body] + r;
            match p.soft {
                None => {
                    self.correct_position(p.body, None, r, Vec3::ZERO, target - at);
                }
                Some((hz, zeta)) => {
                    // XPBD compliance and damping (Macklin et al. 2016, eq. 26) that make
                    // the pin a spring of natural frequency `omega` and damping ratio
                    // `zeta` on the point's effective mass 1/w.
                    let omega = std::f32::consts::TAU * hz.max(0.0);
                    let delta = target - at;
                    let c = delta.length();
                    if c < 1.0e-9 || omega <= 0.0 {
                        continue;
                    }
                    let n = delta / c;
                    let w = self.w_at(p.body, r, n);
                    if w <= 0.0 {
                        continue;
                    }
                    let alpha = w / (omega * omega * h * h);
                    let gamma = 2.0 * zeta.max(0.0) / (omega * h);
                    let before = self.prev_pos[p.body] + self.prev_rot[p.body] * p.local;
                    let moved = ((at - before) - (target - p.from.lerp(p.to, frac0))).dot(n);
                    let lambda = (c - gamma * moved) / ((1.0 + gamma) * w + alpha);
                    self.shift(p.body, r, n * lambda);
                }
            }
        }
    }

    /// Joint drives as implicit damped springs on the relative angular velocity: stable at
    /// any stiffness and substep.
    fn apply_drives(&mut self, h: f32) {
        for k in 0..self.joints.len() {
            let Some(d) = self.joints[k].drive else {
                continue;
            };
            let (a, b) = (self.joints[k].a, self.joints[k].b);
            let target = self.rot[a] * d.target;
            let theta = rotation_vector(target * self.rot[b].conjugate());
            let rel = self.angvel[b] - self.angvel[a];
            let want = self.rot[a] * d.angvel;
            let (k_s, c) = (d.stiffness, d.damping);
            let dw = (theta * k_s + (want - rel) * c) * h / (1.0 + h * c + h * h * k_s);
            let m = dw.length();
            if m < 1.0e-12 {
                continue;
            }
            let n = dw / m;
            let w = self.w_turn(a, n) + self.w_turn(b, n);
            if w <= 0.0 {
                continue;
            }
            let l = n * (m / w);
            let (la, lb) = (self.inv_inertia_world(a, l), self.inv_inertia_world(b, l));
            self.angvel[b] += lb;
            self.angvel[a] -= la;
        }
    }

    /// The velocities the world sees: each body's motion over the whole step. A resting
    /// body's substep velocities carry what one pass per substep leaves: the joints and
    /// contacts of a foot on the floor hand a few tenths of a millimetre back and forth
    /// each substep, which reads as 0.3 m/s though the foot does not move. Reported as
    /// they are, that kept every ragdoll awake and put g's of noise into a head's
    /// acceleration; over the step it averages out, as it does in the frames.
    fn observe_velocities(&mut self, dt: f32) {
        let inv = 1.0 / dt;
        for i in 0..self.pos.len() {
            self.seen_vel[i] = (self.pos[i] - self.step_pos[i]) * inv;
            self.seen_angvel[i] = rotation_vector(self.rot[i] * self.step_rot[i].conjugate()) * inv;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotation_vector_is_axis_times_angle() {
        let q = Quat::from_axis_angle(Vec3::new(1.0, 2.0, 2.0).normalize(), 1.2);
        let v = rotation_vector(q);
        assert!((v.length() - 1.2).abs() < 1e-5);
        assert!((v.normalize() - Vec3::new(1.0, 2.0, 2.0).normalize()).length() < 1e-5);
        // The same rotation written with w < 0 gives the same vector.
        assert!((rotation_vector(-q) - v).length() < 1e-5);
    }
}
