//! Where the fast backend's bodies touch: candidate pairs once per step from the shared
//! broad phase (each body's box grown by how far it can move in the step), the contact
//! points of two shapes every substep (capsule pairs in closed form, a box and a capsule in
//! the box's frame, two boxes by their separating axes, `box_box.rs`), and rays against the shapes.

use glam::{Mat3, Quat, Vec3};

use super::FastBackend;
use super::box_box::box_box;
use super::box_capsule;
use super::contact::TOUCH_M;
use crate::geometry::{nearest_hit, ray_shape};
use crate::spec::Shape;

/// Extra room around every box of the broad phase, metres: what a step's constraints may
/// move a body beyond its velocity.
const BROAD_MARGIN_M: f32 = 0.02;

/// How far a body's box grows in every direction for its velocity at most, metres; the
/// rest of its travel in the step grows the box along the velocity only (see
/// [`FastBackend::world_travel`]). 12 m/s at 1/60 s steps: the bench's piles of four fall
/// at up to 9.8 m/s (their runs are the same to the last digit with or without it), where
/// a large charge throws bodies through a crowd ten to twenty times as fast.
const ALL_AROUND_M: f32 = 0.2;

/// The same room for two shapes closing on each other: one margin each.
pub(super) const CLOSING_MARGIN_M: f32 = 2.0 * BROAD_MARGIN_M;

/// Farthest point of a shape from its centre, metres.
pub(super) fn reach(shape: &Shape) -> f32 {
    match *shape {
        Shape::Capsule { radius_m, length_m } => 0.5 * length_m + radius_m,
        Shape::Box { size_m } => 0.5 * Vec3::from_array(size_m).length(),
    }
}

/// World bounds of a shape at a pose.
pub(super) fn bounds(shape: &Shape, pos: Vec3, rot: Quat) -> (Vec3, Vec3) {
    match *shape {
        Shape::Capsule { radius_m, length_m } => {
            let h = rot * Vec3::new(0.0, 0.5 * length_m, 0.0);
            let r = Vec3::splat(radius_m);
            ((pos - h).min(pos + h) - r, (pos - h).max(pos + h) + r)
        }
        Shape::Box { size_m } => {
            let m = Mat3::from_quat(rot);
            let half = Vec3::from_array(size_m) * 0.5;
            let e = m.x_axis.abs() * half.x + m.y_axis.abs() * half.y + m.z_axis.abs() * half.z;
            (pos - e, pos + e)
        }
    }
}

/// A contact point found between two shapes: points on each surface, the normal from the
/// second toward the first and the depth (negative when apart).
#[derive(Clone, Copy, Debug)]
pub(super) struct Found {
    pub pa: Vec3,
    pub pb: Vec3,
    pub n: Vec3,
    pub depth: f32,
}

/// The capsule's segment ends in the world.
pub(super) fn ends(pos: Vec3, rot: Quat, length_m: f32) -> (Vec3, Vec3) {
    let h = rot * Vec3::new(0.0, 0.5 * length_m, 0.0);
    (pos - h, pos + h)
}

/// The contact of a capsule at pose `c` (radius `r`, segment `length`) with a box at pose
/// `b` (edges `size`) if within `within` metres, the capsule first, found in the box's
/// frame ([`box_capsule::contact_in_box_frame`]).
fn box_capsule(
    (box_pos, box_rot): (Vec3, Quat),
    size: [f32; 3],
    (pos, rot): (Vec3, Quat),
    r: f32,
    length: f32,
    within: f32,
) -> Option<Found> {
    let half = Vec3::from_array(size) * 0.5;
    let inv = box_rot.conjugate();
    let (e0, e1) = ends(pos, rot, length);
    let (l0, l1) = (inv * (e0 - box_pos), inv * (e1 - box_pos));
    let (p_local, q_local, n_local, depth) =
        box_capsule::contact_in_box_frame(l0, l1, half, r, within)?;
    Some(Found {
        pa: box_pos + box_rot * p_local,
        pb: box_pos + box_rot * q_local,
        n: box_rot * n_local,
        depth,
    })
}

impl FastBackend {
    /// Candidate pairs for the coming step; wakes a sleeping ragdoll that a moving body
    /// may reach.
    pub(super) fn find_pairs(&mut self, dt: f32) {
        let mut boxes = std::mem::take(&mut self.collide.boxes);
        boxes.clear();
        boxes.extend((0..self.world_shapes()).map(|k| {
            let (pos, rot) = self.world_shape_pose(k);
            let (lo, hi) = bounds(&self.world_shape(k).0, pos, rot);
            let (around, ahead) = self.world_travel(k, dt);
            (
                lo - Vec3::splat(around) + ahead.min(Vec3::ZERO),
                hi + Vec3::splat(around) + ahead.max(Vec3::ZERO),
            )
        }));
        let bodies = self.pos.len();
        let FastBackend {
            collide,
            disabled,
            ragdoll_of,
            ragdolls,
            inv_mass,
            extras,
            ..
        } = self;
        collide.pairs.clear();
        collide.wait.clear();
        collide.closing.clear();
        collide.wake.clear();
        let (pairs, wake) = (&mut collide.pairs, &mut collide.wake);
        let body_of = |k: usize| {
            k.checked_sub(bodies)
                .map_or(k, |e| extras.owner[e] as usize)
        };
        collide.broad.find(&boxes, |a, b| {
            // Shapes `a` and `b`, of bodies `i` and `j`.
            let (i, j) = (body_of(a), body_of(b));
            let key = (i.min(j) as u32, i.max(j) as u32);
            if i == j || disabled.contains(&key) || (inv_mass[i] == 0.0 && inv_mass[j] == 0.0) {
                return;
            }
            let (ri, rj) = (ragdoll_of[i], ragdoll_of[j]);
            // Extra shapes never meet their own ragdoll (`extras.rs`).
            if ri == rj && a.max(b) >= bodies {
                return;
            }
            if ragdolls[ri].removed || ragdolls[rj].removed {
                return;
            }
            let (si, sj) = (ragdolls[ri].asleep, ragdolls[rj].asleep);
            if si && sj {
                return;
            }
            if si {
                wake.push(ri);
            }
            if sj {
                wake.push(rj);
            }
            pairs.push((a as u32, b as u32));
        });
        self.collide.boxes = boxes;
        for k in 0..self.collide.wake.len() {
            let r = self.collide.wake[k];
            self.wake(r);
        }
    }

    /// How far any point of the whole world's shape `k` (`extras.rs`) may move in a step
    /// of `dt` at its body's present velocities, with [`BROAD_MARGIN_M`] to spare for what
    /// the step's constraints add: a distance in every direction, and a displacement
    /// along the body's velocity beyond it.
    ///
    /// The box grows by the body's travel in every direction, so that it covers a path a
    /// collision bends within the step (boxes swept along the velocity alone, as general
    /// engines grow them, let the bench's piles land up to 4.5 mm deeper). Past
    /// [`ALL_AROUND_M`] it grows along the velocity only: a blast throws bodies through a
    /// crowd at up to 225 m/s, metres a step, and a box grown that far every way met
    /// hundreds of others.
    fn world_travel(&self, k: usize, dt: f32) -> (f32, Vec3) {
        let (shape, at) = self.world_shape(k);
        let lever = reach(&shape) + at.map_or(0.0, |t| t.translation.length());
        let o = self.body_of_shape(k);
        // A turn moves a point along a chord, never more than the diameter of its circle:
        // a blast spins a hand at hundreds of rad/s for the step its joints take to share
        // the blow out, and a box grown by its lever times that turn (several radians)
        // met every shape metres around.
        let turned = (self.angvel[o].length() * dt).min(2.0);
        let moved = self.vel[o] * dt;
        let travel = moved.length();
        let (around, ahead) = if travel <= ALL_AROUND_M {
            (travel, Vec3::ZERO)
        } else {
            (ALL_AROUND_M, moved * (1.0 - ALL_AROUND_M / travel))
        };
        (around + turned * lever + BROAD_MARGIN_M, ahead)
    }

    /// Keeps the candidate pairs that may come within [`TOUCH_M`] in the coming step: the
    /// broad phase pairs bodies whose boxes, grown by their travel, overlap, and of the
    /// substeps' distance tests of those pairs 83 % return nothing in the pile bench
    /// (slanted capsules' boxes overlap while their surfaces stay apart). One exact
    /// distance per pair and step drops the pairs that cannot touch before the substeps
    /// test them 32 times.
    ///
    /// Nor can two shapes touch before they have closed their gap: each pair kept gets
    /// the time into the step before which it cannot (`Collide::wait`), the substeps
    /// before that skip it, and a test that finds it still apart puts its next one off
    /// again. 1,000 kg of TNT among 200 people 1 m apart threw them at up to 100 m/s:
    /// their boxes, grown by their travel, overlapped by the million, and each pair kept
    /// was tested 32 substeps times 4 passes a step.
    ///
    /// The bound is each ragdoll's fastest point, not the sum of the two bodies' own
    /// speeds against each other: a crowd's neighbours move together, but within a step
    /// a ground contact stops one of them and a joint drags a body along with the one a
    /// blast struck, so neither their relative velocity nor a body's own bounds where it
    /// goes (a relative bound let a pile's bodies 46 mm into each other, 5.6 before).
    pub(super) fn cull_pairs(&mut self, dt: f32) {
        self.cull_pairs_with(dt, true);
    }

    /// [`FastBackend::cull_pairs`], with `Collide::ragdoll_speed` measured here or
    /// (`measure` false) given: the solver of the contacts between two parts of an island
    /// holds only some of each ragdoll's shapes, so it takes the parts' speeds
    /// (`split.rs`).
    pub(super) fn cull_pairs_with(&mut self, dt: f32, measure: bool) {
        let mut pairs = std::mem::take(&mut self.collide.pairs);
        let (mut wait, mut closing, mut kept) = (
            std::mem::take(&mut self.collide.wait),
            std::mem::take(&mut self.collide.closing),
            std::mem::take(&mut self.collide.kept),
        );
        wait.clear();
        closing.clear();
        kept.clear();
        if measure {
            self.measure_ragdoll_speeds(dt);
        }
        pairs.retain(|&(a, b)| {
            let (a, b) = (a as usize, b as usize);
            let (speed, travel) = self.closing_speed(a, b);
            let within = TOUCH_M + travel + CLOSING_MARGIN_M;
            let Some(found) = self.pair_contact_within(a, b, within) else {
                return false;
            };
            // The gap the pair must close, beyond the margin, before it can touch.
            let gap = -found.depth - TOUCH_M - CLOSING_MARGIN_M;
            wait.push(if gap > 0.0 && speed > 0.0 {
                gap / speed
            } else {
                0.0
            });
            closing.push(speed);
            // Left empty with the setting off: the substeps read it for every pair, and
            // a slot of `None`s as large as a `Kept` was most of their loop's time.
            if self.settings.keep_contacts {
                kept.push(Some(self.keep_contact(a, b, &found)));
            }
            true
        });
        self.collide.pairs = pairs;
        self.collide.kept = kept;
        self.collide.wait = wait;
        self.collide.closing = closing;
        self.collide.dt = dt;
    }

    /// How fast shapes `a` and `b` may close on each other at their ragdolls' present
    /// velocities, m/s, and how far in the step, metres: each as fast and as far as the
    /// fastest point of its ragdoll (`Collide::ragdoll_speed`), whatever its own body's
    /// velocity says, since a joint drags a body along with the one a blast strikes
    /// within the step.
    fn closing_speed(&self, a: usize, b: usize) -> (f32, f32) {
        let of = |c: usize| {
            let r = self.ragdoll_of[self.owner[c] as usize];
            self.collide.ragdoll_speed[r]
        };
        let ((sa, ta), (sb, tb)) = (of(a), of(b));
        (sa + sb, ta + tb)
    }

    /// Fills `Collide::ragdoll_speed`: per ragdoll, the fastest any point of its shapes
    /// moves at its bodies' present velocities, m/s, and the farthest one goes in the step
    /// of `dt`, metres (a turn by a chord, as in the broad phase's boxes).
    fn measure_ragdoll_speeds(&mut self, dt: f32) {
        let mut speeds = std::mem::take(&mut self.collide.ragdoll_speed);
        speeds.clear();
        speeds.resize(self.ragdolls.len(), (0.0, 0.0));
        for c in 0..self.shape.len() {
            let i = self.owner[c] as usize;
            let lever =
                reach(&self.shape[c]) + self.attach[c].map_or(0.0, |t| t.translation.length());
            let (v, w) = (self.vel[i].length(), self.angvel[i].length());
            let (speed, travel) = &mut speeds[self.ragdoll_of[i]];
            *speed = speed.max(v + w * lever);
            *travel = travel.max(v * dt + (w * dt).min(2.0) * lever);
        }
        self.collide.ragdoll_speed = speeds;
    }

    /// The closest points of shapes `a` and `b`, if they are within [`TOUCH_M`].
    pub(super) fn pair_contact(&self, a: usize, b: usize) -> Option<Found> {
        self.pair_contact_within(a, b, TOUCH_M)
    }

    /// The closest points of shapes `a` and `b`, if they are within `within` metres.
    pub(super) fn pair_contact_within(&self, a: usize, b: usize, within: f32) -> Option<Found> {
        let (pos_a, rot_a) = self.shape_pose(a);
        let (pos_b, rot_b) = self.shape_pose(b);
        if let (
            Shape::Capsule {
                radius_m: ra,
                length_m: la,
            },
            Shape::Capsule {
                radius_m: rb,
                length_m: lb,
            },
        ) = (self.shape[a], self.shape[b])
        {
            let (a0, a1) = ends(pos_a, rot_a, la);
            let (b0, b1) = ends(pos_b, rot_b, lb);
            let (s, t) = crate::math::closest_segment_params(a0, a1, b0, b1);
            let (ca, cb) = (a0.lerp(a1, s), b0.lerp(b1, t));
            let d = ca - cb;
            let dist = d.length();
            if dist > ra + rb + within {
                return None;
            }
            let n = if dist > 1.0e-9 {
                d / dist
            } else {
                (pos_a - pos_b).try_normalize().unwrap_or(Vec3::Y)
            };
            return Some(Found {
                pa: ca - n * ra,
                pb: cb + n * rb,
                n,
                depth: ra + rb - dist,
            });
        }
        match (self.shape[a], self.shape[b]) {
            (Shape::Box { size_m: sa }, Shape::Box { size_m: sb }) => {
                let half = |s: [f32; 3]| Vec3::from_array(s) * 0.5;
                box_box((pos_a, rot_a), half(sa), (pos_b, rot_b), half(sb), within)
            }
            (Shape::Box { size_m }, Shape::Capsule { radius_m, length_m }) => {
                let f = box_capsule(
                    (pos_a, rot_a),
                    size_m,
                    (pos_b, rot_b),
                    radius_m,
                    length_m,
                    within,
                )?;
                Some(Found {
                    pa: f.pb,
                    pb: f.pa,
                    n: -f.n,
                    depth: f.depth,
                })
            }
            (Shape::Capsule { radius_m, length_m }, Shape::Box { size_m }) => box_capsule(
                (pos_b, rot_b),
                size_m,
                (pos_a, rot_a),
                radius_m,
                length_m,
                within,
            ),
            _ => None,
        }
    }

    /// The first body a ray meets, against each of its shapes.
    pub(super) fn cast_ray_impl(
        &self,
        origin: Vec3,
        dir: Vec3,
        max_dist: f32,
    ) -> Option<(usize, f32)> {
        let hits = (0..self.world_shapes()).map(|k| {
            if self.ragdolls[self.ragdoll_of[self.body_of_shape(k)]].removed {
                return None;
            }
            let shape = self.world_shape(k).0;
            let (pos, rot) = self.world_shape_pose(k);
            let length = match shape {
                Shape::Capsule { length_m, .. } => length_m,
                Shape::Box { .. } => 0.0,
            };
            ray_shape(origin, dir, &shape, pos, rot, ends(pos, rot, length))
        });
        nearest_hit(hits, max_dist).map(|(k, d)| (self.body_of_shape(k), d))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rapier3d::parry::math::Pose;
    use rapier3d::parry::query;
    use rapier3d::parry::shape::Cuboid;

    fn parry_pose(pos: Vec3, rot: Quat) -> Pose {
        Pose::from_parts(pos, rot)
    }
    use crate::backend::{Backend, BodyDesc};
    use crate::math::Transform;

    /// A box body and a capsule body at the given poses, no ground.
    fn box_and_capsule(box_pose: Transform, capsule_pose: Transform) -> FastBackend {
        let mut b = FastBackend::with_settings(super::super::FastSettings::bare());
        let body = |pose, shape| BodyDesc {
            pose,
            shape,
            extra_shapes: Vec::new(),
            mass: 1.0,
            linvel: Vec3::ZERO,
            angvel: Vec3::ZERO,
        };
        b.add_ragdoll(
            &[
                body(
                    box_pose,
                    Shape::Box {
                        size_m: [0.3, 0.2, 0.4],
                    },
                ),
                body(
                    capsule_pose,
                    Shape::Capsule {
                        radius_m: 0.05,
                        length_m: 0.3,
                    },
                ),
            ],
            &[],
            &[],
        );
        b
    }

    /// A pose from a few numbers, spread over position and orientation.
    fn pose(k: u32, spread: f32) -> Transform {
        let f = |m: u32| {
            ((k.wrapping_mul(2_654_435_761).wrapping_add(m * 40_503) % 1000) as f32 / 500.0) - 1.0
        };
        let axis = Vec3::new(f(1), f(2), f(3) + 0.01).normalize();
        Transform::new(
            Vec3::new(f(4), f(5), f(6)) * spread,
            Quat::from_axis_angle(axis, 3.0 * f(7)),
        )
    }

    /// A blast spins a hand at hundreds of rad/s for the step its joints take to share
    /// the blow out: its points go round their circles, never farther than across them,
    /// and its box must not meet every shape metres around.
    #[test]
    fn a_spinning_body_reaches_no_farther_than_across_its_circle() {
        let dt = 1.0 / 60.0;
        let mut b = box_and_capsule(
            Transform::IDENTITY,
            Transform::from_translation(Vec3::new(1.0, 0.0, 0.0)),
        );
        b.angvel[1] = Vec3::new(0.0, 0.0, 400.0);
        let lever = reach(&b.shape[1]);
        let (bound, ahead) = b.world_travel(1, dt);
        assert_eq!(ahead, Vec3::ZERO);
        let end = Vec3::new(0.0, lever, 0.0);
        for k in 0..=1000 {
            let t = dt * k as f32 / 1000.0;
            let moved = (Quat::from_scaled_axis(b.angvel[1] * t) * end - end).length();
            assert!(moved <= bound + 1.0e-5, "moved {moved} m, bound {bound} m");
        }
        assert!(bound <= 2.0 * lever + BROAD_MARGIN_M + 1.0e-6, "{bound}");
        // The box 1 m away is out of the capsule's reach (0.55 m apart).
        b.find_pairs(dt);
        assert!(b.collide.pairs.is_empty(), "{:?}", b.collide.pairs);
    }

    /// A body thrown at 120 m/s goes 2 m in a step: its box reaches that far along its
    /// velocity, and only [`ALL_AROUND_M`] and the margins every other way.
    #[test]
    fn a_fast_body_reaches_along_its_path_not_all_around() {
        let dt = 1.0 / 60.0;
        let beside = Transform::from_translation(Vec3::new(0.0, 0.0, 1.0));
        for (vel, paired) in [
            (Vec3::new(120.0, 0.0, 0.0), false),
            (Vec3::new(-120.0, 0.0, 0.0), false),
            (Vec3::new(0.0, 0.0, -120.0), true),
            (Vec3::new(0.0, 0.0, 120.0), false),
        ] {
            let mut b = box_and_capsule(Transform::IDENTITY, beside);
            b.vel[1] = vel;
            b.find_pairs(dt);
            assert_eq!(!b.collide.pairs.is_empty(), paired, "{vel}");
        }
        // Slower than ALL_AROUND_M a step, the box grows by the whole travel every way:
        // a collision may bend the path within the step.
        let mut b = box_and_capsule(Transform::IDENTITY, beside);
        b.vel[1] = Vec3::X * (0.9 * ALL_AROUND_M / dt);
        let (around, ahead) = b.world_travel(1, dt);
        assert_eq!(ahead, Vec3::ZERO);
        assert!(
            (around - BROAD_MARGIN_M - 0.9 * ALL_AROUND_M).abs() < 1e-5,
            "{around}"
        );
    }

    #[test]
    fn box_capsule_contacts_agree_with_parry() {
        // parry's general GJK/EPA is the reference: apart or touching, the depth (minus the
        // distance) and the normal match; when the segment enters the box, ours pushes out
        // through a face, never less deep than the least way out.
        let (mut apart, mut inside) = (0, 0);
        for k in 0..400 {
            let b = box_and_capsule(
                Transform::IDENTITY,
                pose(k, if k % 2 == 0 { 0.35 } else { 0.12 }),
            );
            let ours = b.pair_contact(1, 0);
            let theirs = query::contact(
                &parry_pose(b.pos[1], b.rot[1]),
                &rapier3d::parry::shape::Capsule::new_y(0.15, 0.05),
                &parry_pose(b.pos[0], b.rot[0]),
                &Cuboid::new(Vec3::new(0.15, 0.1, 0.2)),
                TOUCH_M,
            )
            .unwrap();
            match (ours, theirs) {
                (None, None) => {}
                (Some(o), Some(t)) => {
                    let (inv, half) = (b.rot[0].conjugate(), Vec3::new(0.15, 0.1, 0.2));
                    let (e0, e1) = ends(b.pos[1], b.rot[1], 0.3);
                    let inside_box = |p: Vec3| {
                        let l = inv * (p - b.pos[0]);
                        l.abs().cmplt(half).all()
                    };
                    let crosses = (0..=20).any(|s| inside_box(e0.lerp(e1, s as f32 / 20.0)));
                    if crosses {
                        inside += 1;
                        assert!(o.depth >= -t.dist - 1e-4, "{k}: {o:?} vs {t:?}");
                    } else {
                        apart += 1;
                        assert!((o.depth + t.dist).abs() < 1e-3, "{k}: {o:?} vs {t:?}");
                        assert!(o.n.dot(-t.normal1) > 0.99, "{k}: {o:?} vs {t:?}");
                    }
                }
                (o, t) => {
                    // At the edge of the touching range one may just miss.
                    let d = o.map_or_else(|| -t.unwrap().dist, |o| o.depth);
                    assert!((d + TOUCH_M).abs() < 1e-3, "{k}: {o:?} vs {t:?}");
                }
            }
        }
        assert!(apart > 20 && inside > 20, "{apart} apart, {inside} inside");
    }
}
