//! Collision for the particle backend: a hierarchical hash grid for candidate pairs
//! ([`BroadPhase`]), contacts against the ground (a box by its corners) and between bodies
//! (each as a capsule, a box as the one inside it) solved on the particles, ray casts
//! against the bodies' own shapes.

use glam::Vec3;

use super::{FRICTION, ParticleBackend};
use crate::geometry::broad::BroadPhase;
use crate::geometry::{box_corners, nearest_hit, ray_shape};
use crate::spec::Shape;

/// Closer than this counts as touching another ragdoll, metres (as the rigid backend).
const TOUCH_M: f32 = 0.005;
/// Extra room around every box of the broad phase, metres.
const BROAD_MARGIN_M: f32 = 0.01;
/// Mass scaling of a supported body under another, per metre of height between their
/// contact points: 10 cm apart, the lower one answers 20 times heavier.
const SHOCK_PER_M: f32 = 30.0;

/// Reusable buffers of the broad phase.
#[derive(Default)]
pub(super) struct Grid {
    /// Each body's box, grown by how far it can move before the next search.
    boxes: Vec<(Vec3, Vec3)>,
    broad: BroadPhase,
}

impl ParticleBackend {
    /// Grid entries and hash buckets of the last search for candidate pairs.
    pub(crate) fn broad_phase_footprint(&self) -> (usize, usize) {
        self.grid.broad.footprint()
    }

    /// World ends of body `b`'s capsule from its current frame.
    pub(super) fn capsule_world(&self, b: usize) -> (Vec3, Vec3) {
        let body = &self.bodies[b];
        (
            body.pos + body.rot * body.e[0],
            body.pos + body.rot * body.e[1],
        )
    }

    /// World ends of body `b`'s capsule through its particles (so they follow the
    /// corrections made since the frames were last updated).
    fn capsule_from_particles(&self, b: usize) -> [Vec3; 2] {
        let range = self.body_parts(b);
        let resid = &self.resid_e[b];
        [
            self.point_world(b, &self.beta_e[0][range.clone()], resid[0]),
            self.point_world(b, &self.beta_e[1][range], resid[1]),
        ]
    }

    /// Every body's capsule ends from its particles, for the contact passes.
    pub(super) fn update_capsules(&mut self) {
        let mut caps = std::mem::take(&mut self.caps);
        caps.clear();
        caps.extend((0..self.bodies.len()).map(|b| self.capsule_from_particles(b)));
        self.caps = caps;
    }

    /// Candidate pairs for the next steps: bodies whose boxes, grown by how far they can
    /// move in `dt`, overlap. A body whose state is not finite meets nothing (the world
    /// stops stepping such a run).
    pub(super) fn find_pairs(&mut self, dt: f32) {
        self.pairs.clear();
        let n = self.bodies.len();
        if n < 2 {
            return;
        }
        let mut grid = std::mem::take(&mut self.grid);
        grid.boxes.clear();
        for b in 0..n {
            let (e0, e1) = self.capsule_world(b);
            let speed = self.parts[self.body_parts(b)]
                .iter()
                .map(|&i| self.v[i as usize].length_squared())
                .fold(0.0f32, f32::max)
                .sqrt();
            let margin = self.bodies[b].radius + speed * dt + BROAD_MARGIN_M;
            let (mut lo, mut hi) = (e0.min(e1) - margin, e0.max(e1) + margin);
            if let Some((l, h)) = self.extras_bounds(b) {
                // The particles' speed, plus the turn's sweep at the extras, is bounded by
                // the body's fastest particle only near its own capsule: grow by it twice.
                let grow = Vec3::splat(2.0 * speed * dt + BROAD_MARGIN_M);
                (lo, hi) = (lo.min(l - grow), hi.max(h + grow));
            }
            grid.boxes.push((lo, hi));
        }
        let mut pairs = std::mem::take(&mut self.pairs);
        grid.broad.find(&grid.boxes, |a, b| {
            let both_kinematic = self.bodies[a].kinematic && self.bodies[b].kinematic;
            let removed = self.bodies[a].removed || self.bodies[b].removed;
            if !both_kinematic && !removed && self.may_collide(a, b) {
                pairs.push((a as u32, b as u32));
            }
        });
        // Solved in the grid's order, as the uniform grid before it did: the particle tests'
        // tolerances hold for it. (Sorted by index or from the floor up, the built-in
        // humanoid's collapse stretched its neck 1.1-1.3 % instead of 0.8 %: contact order
        // moves the millimetres a pass leaves.)
        self.pairs = pairs;
        self.grid = grid;
    }

    /// How body `b` answers a push along `n` (unit) at the world point `p` as one rigid
    /// body: its inverse effective mass there, its centre, and the turn per unit push.
    pub(super) fn rigid_response(&self, b: usize, p: Vec3, n: Vec3) -> (f32, Vec3, Vec3) {
        let body = &self.bodies[b];
        let c = body.pos + body.rot * body.com;
        let rn = (p - c).cross(n);
        let local = body.rot.conjugate() * rn;
        let turn = body.rot * (body.inv_inertia * local);
        (body.inv_mass + rn.dot(turn), c, turn)
    }

    /// Moves body `b`'s free particles rigidly: `lin` along, and turned by the small
    /// rotation vector `ang` about `c`.
    pub(super) fn rigid_move(&mut self, b: usize, c: Vec3, lin: Vec3, ang: Vec3) {
        for k in self.body_parts(b) {
            let i = self.parts[k] as usize;
            if self.w[i] > 0.0 {
                let r = self.x[i] - c;
                self.x[i] += lin + ang.cross(r);
            }
        }
    }

    /// Each body against the ground plane, answering as one rigid body, with positional
    /// friction (static up to μ times the depth): a capsule at its two ends, a box at its
    /// eight corners. A box taken for the capsule its body contacts use (round across its
    /// smaller edges) rolls on the floor where the rigid backend's box lies still.
    pub(super) fn solve_ground(&mut self) {
        let Some(ground) = self.settings.ground else {
            return;
        };
        for b in 0..self.bodies.len() {
            if self.bodies[b].kinematic {
                continue;
            }
            let near = self.own_shape_on_ground(b, ground);
            let extras = !self.bodies[b].extras.is_empty();
            if extras {
                self.extras_on_ground(b, ground);
            }
            // A body clear of the floor keeps the capsule it had: its neighbours' contacts
            // may have moved the anchors it shares with them, and the pairs are solved
            // with the capsules as the frames left them.
            if near || extras {
                self.caps[b] = self.capsule_from_particles(b);
            }
        }
    }

    /// Body `b`'s own shape against the ground plane at `ground`; whether it came near
    /// enough to be tested.
    fn own_shape_on_ground(&mut self, b: usize, ground: f32) -> bool {
        let radius = self.bodies[b].radius;
        let [e0, e1] = self.caps[b];
        match self.bodies[b].shape {
            Shape::Box { size_m } => {
                let half = 0.5 * Vec3::from_array(size_m);
                if 0.5 * (e0.y + e1.y) - half.length() >= ground {
                    return false;
                }
                let mut now = self.frame_of(b, &self.x);
                let mut start = None;
                for corner in box_corners(half) {
                    let p = now.0 + now.1 * corner;
                    let depth = ground - p.y;
                    if depth <= 0.0 {
                        continue;
                    }
                    self.push_up(b, p, depth);
                    now = self.frame_of(b, &self.x);
                    let (pos0, rot0) = *start.get_or_insert_with(|| self.frame_of(b, &self.x_prev));
                    let moved = now.0 + now.1 * corner - (pos0 + rot0 * corner);
                    self.slide_friction(b, p, depth, moved);
                    now = self.frame_of(b, &self.x);
                }
            }
            _ => {
                if e0.y.min(e1.y) - radius >= ground {
                    return false;
                }
                for s in 0..2 {
                    let end = self.capsule_from_particles(b)[s];
                    let depth = ground + radius - end.y;
                    if depth > 0.0 {
                        let p = end - Vec3::Y * radius;
                        self.push_up(b, p, depth);
                        // A capsule's friction stops its axis point's slide.
                        let moved = self.axis_moved(b, s as f32);
                        self.slide_friction(b, p, depth, moved);
                    }
                }
            }
        }
        true
    }

    /// The normal half of a ground contact: body `b` pushed up by `depth` at the world
    /// point `p`, as one rigid body.
    pub(super) fn push_up(&mut self, b: usize, p: Vec3, depth: f32) {
        self.supported[b] = true;
        let (w, c, turn) = self.rigid_response(b, p, Vec3::Y);
        let lambda = depth / w;
        let inv_mass = self.bodies[b].inv_mass;
        self.rigid_move(b, c, Vec3::Y * (lambda * inv_mass), turn * lambda);
    }

    /// The friction half of a ground contact at `p`: the horizontal part of `moved` (the
    /// contact point's motion over the substep so far) taken back, up to μ times `depth`.
    pub(super) fn slide_friction(&mut self, b: usize, p: Vec3, depth: f32, moved: Vec3) {
        let slide = Vec3::new(moved.x, 0.0, moved.z);
        let len = slide.length();
        if len > 1e-9 {
            let t = -slide / len;
            let amount = len.min(FRICTION * depth);
            let (wt, c, turn) = self.rigid_response(b, p, t);
            let lambda = amount / wt;
            let inv_mass = self.bodies[b].inv_mass;
            self.rigid_move(b, c, t * (lambda * inv_mass), turn * lambda);
        }
    }

    /// Body `b`'s frame from its three frame particles in `x` (`self.x` now, or
    /// `self.x_prev` at the substep's start). From the frame, not the affine weights: a
    /// stick's particles lie in one plane, and a box's corner off it has no affine
    /// combination of them.
    pub(super) fn frame_of(&self, b: usize, x: &[Vec3]) -> (Vec3, glam::Quat) {
        let body = &self.bodies[b];
        let [i0, i1, i2] = body.triad.map(|i| x[i as usize]);
        let rot = (super::triad_frame(i0, i1, i2) * body.tri_inv).normalize();
        (i0 - rot * body.tri_origin, rot)
    }

    /// Displacement of body `b`'s axis point at `t` (0: first capsule end, 1: second) over
    /// the substep so far.
    pub(super) fn axis_moved(&self, b: usize, t: f32) -> Vec3 {
        let range = self.body_parts(b);
        let mut moved = Vec3::ZERO;
        for k in range {
            let i = self.parts[k] as usize;
            let exact = (1.0 - t) * self.beta_e[0][k] + t * self.beta_e[1][k];
            moved += (self.x[i] - self.x_prev[i]) * exact;
        }
        moved
    }

    /// Capsule against capsule for the candidate pairs, each body answering as one rigid
    /// body, with positional friction.
    ///
    /// A body resting on the floor (or on a body that rests on it) answers a body above it
    /// as if heavier, by `exp(−SHOCK_PER_M·Δy)` in inverse mass (mass scaling, Macklin et
    /// al. 2014 §5.2): one pass then carries a pile's weight down to the floor instead of
    /// pushing the lowest limb into it. Bodies in the air keep their masses, so their
    /// collisions keep momentum.
    pub(super) fn solve_pairs(&mut self) {
        for idx in 0..self.pairs.len() {
            let (a, b) = (self.pairs[idx].0 as usize, self.pairs[idx].1 as usize);
            let (ca, cb) = (
                (self.caps[a], self.bodies[a].radius),
                (self.caps[b], self.bodies[b].radius),
            );
            self.resolve_capsules(a, ca, true, b, cb, true);
            // Extra shapes never meet their own ragdoll (as in the other backends).
            let others = self.bodies[a].ragdoll != self.bodies[b].ragdoll;
            if others && !(self.bodies[a].extras.is_empty() && self.bodies[b].extras.is_empty()) {
                self.extras_in_pair(a, b);
            }
        }
    }

    /// One capsule of body `a` (ends, radius) against one of body `b`: pushed apart if
    /// they overlap, each body answering as one rigid body, with positional friction.
    /// `main_a` (`main_b`) says the capsule is the body's own, whose material points'
    /// motion is read along its axis from the particles; an extra shape's is read from
    /// the body's frames.
    pub(super) fn resolve_capsules(
        &mut self,
        a: usize,
        ([a0, a1], ra): ([Vec3; 2], f32),
        main_a: bool,
        b: usize,
        ([b0, b1], rb): ([Vec3; 2], f32),
        main_b: bool,
    ) {
        let reach = ra + rb;
        let far = 0.5 * ((a1 - a0).length() + (b1 - b0).length()) + reach + TOUCH_M;
        if (a0 + a1 - b0 - b1).length_squared() > 4.0 * far * far {
            return;
        }
        let (s, t) = crate::math::closest_segment_params(a0, a1, b0, b1);
        let (pa, pb) = (a0.lerp(a1, s), b0.lerp(b1, t));
        let d = pb - pa;
        let dist = d.length();
        if self.bodies[a].ragdoll != self.bodies[b].ragdoll && dist < reach + TOUCH_M {
            self.touched[a] = true;
            self.touched[b] = true;
        }
        if dist >= reach {
            return;
        }
        let n = if dist > 1e-9 { d / dist } else { Vec3::Y };
        let depth = reach - dist;
        let (qa, qb) = (pa + n * ra, pb - n * rb);
        let (mut sa, mut sb) = (1.0f32, 1.0f32);
        let dy = pb.y - pa.y;
        if dy > 0.0 && self.supported[a] {
            sa = (-SHOCK_PER_M * dy).exp();
            self.supported[b] = true;
        } else if dy < 0.0 && self.supported[b] {
            sb = (SHOCK_PER_M * dy).exp();
            self.supported[a] = true;
        }
        if self.bodies[a].kinematic {
            sa = 0.0;
        }
        if self.bodies[b].kinematic {
            sb = 0.0;
        }
        let (wa, ca, ta) = self.rigid_response(a, qa, n);
        let (wb, cb, tb) = self.rigid_response(b, qb, n);
        let wsum = sa * wa + sb * wb;
        if wsum <= 1e-12 {
            return;
        }
        let lambda = depth / wsum;
        let (ma, mb) = (self.bodies[a].inv_mass, self.bodies[b].inv_mass);
        self.rigid_move(a, ca, n * (-lambda * sa * ma), ta * (-lambda * sa));
        self.rigid_move(b, cb, n * (lambda * sb * mb), tb * (lambda * sb));
        let moved_of = |s: &Self, body: usize, main: bool, param: f32, p: Vec3| {
            if main {
                s.axis_moved(body, param)
            } else {
                s.point_moved(body, p)
            }
        };
        let moved = moved_of(self, b, main_b, t, pb) - moved_of(self, a, main_a, s, pa);
        let slide = moved - n * moved.dot(n);
        let len = slide.length();
        if len > 1e-9 {
            let dir = slide / len;
            let amount = len.min(FRICTION * depth);
            let (wa, ca, ta) = self.rigid_response(a, qa, dir);
            let (wb, cb, tb) = self.rigid_response(b, qb, dir);
            let wsum = sa * wa + sb * wb;
            if wsum > 1e-12 {
                let lambda = amount / wsum;
                self.rigid_move(a, ca, dir * (lambda * sa * ma), ta * (lambda * sa));
                self.rigid_move(b, cb, dir * (-lambda * sb * mb), tb * (-lambda * sb));
            }
        }
        self.caps[a] = self.capsule_from_particles(a);
        self.caps[b] = self.capsule_from_particles(b);
    }

    /// Deepest penetration now (ground, and candidate pairs), from the body frames: a box
    /// against the ground by its corners, against other bodies as the capsule those
    /// contacts use.
    pub(super) fn measure_penetration(&self) -> f32 {
        let mut deepest = 0.0f32;
        for b in 0..self.bodies.len() {
            if self.bodies[b].kinematic {
                continue;
            }
            if let Some(g) = self.settings.ground {
                let body = &self.bodies[b];
                let lowest = match body.shape {
                    // The box itself, as its ground contacts see it.
                    Shape::Box { size_m } => box_corners(0.5 * Vec3::from_array(size_m))
                        .iter()
                        .map(|c| (body.pos + body.rot * *c).y)
                        .fold(f32::INFINITY, f32::min),
                    _ => {
                        let (e0, e1) = self.capsule_world(b);
                        e0.y.min(e1.y) - body.radius
                    }
                };
                deepest = deepest.max(g - lowest);
            }
            if !self.bodies[b].extras.is_empty() {
                deepest = deepest.max(self.extras_depth(b, self.settings.ground, &[]));
            }
        }
        for &(a, b) in &self.pairs {
            let (a, b) = (a as usize, b as usize);
            let (a0, a1) = self.capsule_world(a);
            let (b0, b1) = self.capsule_world(b);
            let (s, t) = crate::math::closest_segment_params(a0, a1, b0, b1);
            let dist = (b0.lerp(b1, t) - a0.lerp(a1, s)).length();
            deepest = deepest.max(self.bodies[a].radius + self.bodies[b].radius - dist);
            let others = self.bodies[a].ragdoll != self.bodies[b].ragdoll;
            if others && !(self.bodies[a].extras.is_empty() && self.bodies[b].extras.is_empty()) {
                let (ca, cb) = (self.body_capsules(a), self.body_capsules(b));
                deepest = deepest
                    .max(self.extras_depth(a, None, &cb))
                    .max(self.extras_depth(b, None, &ca[..1]));
            }
        }
        deepest
    }

    /// The first body a ray meets, against each body's own shape (a box as a box, not
    /// the capsule its contacts use: a shot at a chest's lower edge passed between the
    /// chest's and the spine's capsules). Every body is tested: projectiles are rare.
    pub(super) fn cast_ray_impl(
        &self,
        origin: Vec3,
        dir: Vec3,
        max_dist: f32,
    ) -> Option<(usize, f32)> {
        let hits = self.bodies.iter().enumerate().map(|(b, body)| {
            if body.removed {
                return None;
            }
            let ends = match body.shape {
                Shape::Capsule { .. } => self.capsule_world(b),
                Shape::Box { .. } => (body.pos, body.pos),
            };
            let own = ray_shape(origin, dir, &body.shape, body.pos, body.rot, ends);
            match (own, self.ray_extras(b, origin, dir)) {
                (Some(a), Some(e)) => Some(a.min(e)),
                (a, e) => a.or(e),
            }
        });
        nearest_hit(hits, max_dist)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closest_points_of_crossing_segments() {
        let (s, t) = crate::math::closest_segment_params(
            Vec3::new(-1.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.5, 1.0, -1.0),
            Vec3::new(0.5, 1.0, 1.0),
        );
        assert!((s - 0.75).abs() < 1e-6 && (t - 0.5).abs() < 1e-6, "{s} {t}");
    }
}
