//! Bodies' extra shapes ([`crate::backend::BodyDesc::extra_shapes`]) in the particle
//! backend: each rides on its body's frame (read off the body's particles, as a box's
//! corners are), meets the ground as the body's own shape does (a box by its corners, a
//! capsule by its ends) and other bodies as its capsule, and moves its body as one rigid
//! body at the contact point, with positional friction.

use glam::{Quat, Vec3};

use super::ParticleBackend;
use crate::geometry::box_corners;
use crate::geometry::capsule_of;
use crate::math::Transform;
use crate::spec::Shape;

impl ParticleBackend {
    /// Extra shape `k` of body `b` at the body frame `frame` (position, rotation).
    fn extra_pose(&self, b: usize, k: usize, frame: (Vec3, Quat)) -> (Vec3, Quat) {
        let at = self.bodies[b].extras[k].1;
        (frame.0 + frame.1 * at.translation, frame.1 * at.rotation)
    }

    /// The capsule of body `b`'s extra shape `k` in the world, from the body frame
    /// `frame`: its ends and radius.
    fn extra_capsule(&self, b: usize, k: usize, frame: (Vec3, Quat)) -> ([Vec3; 2], f32) {
        let (pos, rot) = self.extra_pose(b, k, frame);
        let ([e0, e1], r) = capsule_of(&self.bodies[b].extras[k].0);
        ([pos + rot * e0, pos + rot * e1], r)
    }

    /// The points of extra shape `k` that meet a floor, in its own frame: a box's
    /// corners, a capsule's two lowest points are found from its ends.
    fn extra_floor_points(shape: &Shape) -> Vec<Vec3> {
        match *shape {
            Shape::Box { size_m } => box_corners(0.5 * Vec3::from_array(size_m)).to_vec(),
            Shape::Capsule { length_m, .. } => {
                vec![Vec3::Y * (-0.5 * length_m), Vec3::Y * (0.5 * length_m)]
            }
        }
    }

    /// Body `b`'s extra shapes against the ground plane at `ground`: each pushed up by its
    /// deepest point's depth at the middle of its points below the floor (weighted by how
    /// deep they are), with positional friction there. Corner by corner, as a body's own
    /// box meets the floor, a plate 0.4 m under its body's centre tipped the body over on
    /// landing flat: each corner's push, far below the centre, turned the body before the
    /// next was solved.
    pub(super) fn extras_on_ground(&mut self, b: usize, ground: f32) {
        for k in 0..self.bodies[b].extras.len() {
            let shape = self.bodies[b].extras[k].0;
            let radius = match shape {
                Shape::Capsule { radius_m, .. } => radius_m,
                Shape::Box { .. } => 0.0,
            };
            let now = self.frame_of(b, &self.x);
            let (pos, rot) = self.extra_pose(b, k, now);
            let (mut sum, mut weight, mut deepest) = (Vec3::ZERO, 0.0f32, 0.0f32);
            let mut local = Vec3::ZERO;
            for q in Self::extra_floor_points(&shape) {
                let p = pos + rot * q - Vec3::Y * radius;
                let depth = ground - p.y;
                if depth > 0.0 {
                    sum += p * depth;
                    local += q * depth;
                    weight += depth;
                    deepest = deepest.max(depth);
                }
            }
            if weight <= 0.0 {
                continue;
            }
            let (p, q) = (sum / weight, local / weight);
            let p = Vec3::new(p.x, ground - deepest, p.z);
            let start = self.frame_of(b, &self.x_prev);
            self.push_up(b, p, deepest);
            let (pos, rot) = self.extra_pose(b, k, self.frame_of(b, &self.x));
            let (pos0, rot0) = self.extra_pose(b, k, start);
            let moved = (pos + rot * q) - (pos0 + rot0 * q);
            self.slide_friction(b, p, deepest, moved);
        }
    }

    /// The contacts of bodies `a` and `b` through their extra shapes: every pair of
    /// their capsules but the two bodies' own (which [`ParticleBackend::solve_pairs`]
    /// takes).
    pub(super) fn extras_in_pair(&mut self, a: usize, b: usize) {
        let (na, nb) = (self.bodies[a].extras.len(), self.bodies[b].extras.len());
        for i in 0..=na {
            for j in 0..=nb {
                if i == 0 && j == 0 {
                    continue;
                }
                let (fa, fb) = (self.frame_of(a, &self.x), self.frame_of(b, &self.x));
                let ca = self.capsule_at(a, i, fa);
                let cb = self.capsule_at(b, j, fb);
                self.resolve_capsules(a, ca, i == 0, b, cb, j == 0);
            }
        }
    }

    /// Body `b`'s capsule `i` from the frame `frame`: its own (0) or extra `i - 1`.
    fn capsule_at(&self, b: usize, i: usize, frame: (Vec3, Quat)) -> ([Vec3; 2], f32) {
        match i.checked_sub(1) {
            None => (self.caps[b], self.bodies[b].radius),
            Some(k) => self.extra_capsule(b, k, frame),
        }
    }

    /// How far the material point of body `b` at the world point `p` has moved over the
    /// substep so far, from the body's frames then and now.
    pub(super) fn point_moved(&self, b: usize, p: Vec3) -> Vec3 {
        let (pos, rot) = self.frame_of(b, &self.x);
        let local = rot.conjugate() * (p - pos);
        let (pos0, rot0) = self.frame_of(b, &self.x_prev);
        p - (pos0 + rot0 * local)
    }

    /// The deepest any of body `b`'s extra shapes goes below the ground at `ground`, or
    /// into the capsule `other` (ends and radius), metres (0 when none).
    pub(super) fn extras_depth(
        &self,
        b: usize,
        ground: Option<f32>,
        other: &[([Vec3; 2], f32)],
    ) -> f32 {
        let body = &self.bodies[b];
        let frame = (body.pos, body.rot);
        let mut deepest = 0.0f32;
        for k in 0..body.extras.len() {
            let shape = body.extras[k].0;
            if let Some(g) = ground {
                let pose = self.extra_pose(b, k, frame);
                let pose = Transform::new(pose.0, pose.1);
                deepest = deepest.max(g - shape.lowest_y(&pose));
            }
            let ([a0, a1], ra) = self.extra_capsule(b, k, frame);
            for ([b0, b1], rb) in other {
                let (s, t) = crate::math::closest_segment_params(a0, a1, *b0, *b1);
                let dist = (b0.lerp(*b1, t) - a0.lerp(a1, s)).length();
                deepest = deepest.max(ra + rb - dist);
            }
        }
        deepest
    }

    /// Every capsule of body `b` (its own, then its extras') in the world, from its frame.
    pub(super) fn body_capsules(&self, b: usize) -> Vec<([Vec3; 2], f32)> {
        let body = &self.bodies[b];
        let (e0, e1) = self.capsule_world(b);
        let mut all = vec![([e0, e1], body.radius)];
        let frame = (body.pos, body.rot);
        all.extend((0..body.extras.len()).map(|k| self.extra_capsule(b, k, frame)));
        all
    }

    /// World bounds of body `b`'s extra shapes (their capsules), or `None` without any.
    pub(super) fn extras_bounds(&self, b: usize) -> Option<(Vec3, Vec3)> {
        let body = &self.bodies[b];
        let frame = (body.pos, body.rot);
        (0..body.extras.len())
            .map(|k| {
                let ([e0, e1], r) = self.extra_capsule(b, k, frame);
                (e0.min(e1) - Vec3::splat(r), e0.max(e1) + Vec3::splat(r))
            })
            .reduce(|(lo, hi), (l, h)| (lo.min(l), hi.max(h)))
    }

    /// The first of body `b`'s extra shapes a ray meets, as a distance.
    pub(super) fn ray_extras(&self, b: usize, origin: Vec3, dir: Vec3) -> Option<f32> {
        let body = &self.bodies[b];
        let frame = (body.pos, body.rot);
        (0..body.extras.len())
            .filter_map(|k| {
                let (pos, rot) = self.extra_pose(b, k, frame);
                // A box's segment is not read: it is met as a box.
                let ([e0, e1], _) = self.extra_capsule(b, k, frame);
                crate::geometry::ray_shape(origin, dir, &body.extras[k].0, pos, rot, (e0, e1))
            })
            .reduce(f32::min)
    }
}
