//! Contacts of the fast backend: candidate pairs once per step from the shared broad phase
//! (each body's box grown by how far it can move in the step), contact points again every
//! substep from the bodies' own shapes, solved as XPBD contacts with Coulomb friction and
//! rolling resistance on positions and restitution 0 on velocities (Müller et al. 2020,
//! §3.5 and §3.6).

use glam::{Mat3, Quat, Vec3};
use rapier3d::parry::math::Pose;
use rapier3d::parry::query;
use rapier3d::parry::shape::Cuboid;

use super::box_capsule;
use super::solve::turn_rate;
use super::{FRICTION, FastBackend};
use crate::backend::broad::BroadPhase;
use crate::backend::geom::{box_corners, nearest_hit, ray_shape};
use crate::spec::Shape;

/// Closer than this counts as touching another ragdoll, metres (as the other backends).
const TOUCH_M: f32 = 0.005;
/// How many times heavier a body held up answers a push down, in contacts (see
/// [`FastBackend::support_along`]). Measured on six 8-humanoid piles at 32 substeps
/// (mean of the worst penetration per run): 34 mm without, 23 mm at 10, 25 mm at 100,
/// where the velocity pass's one-sided weights also began to add energy (5 % in a frame).
const SUPPORTED_WEIGHT: f32 = 10.0;
/// Lever arm of a contact's rolling and spinning resistance, metres: a limb's flesh and
/// clothes flatten where they press, and the contact patch's pressure shifts ahead of a
/// roll by about this much, so a turn against a surface meets a torque of this arm times
/// the normal force (a rolling resistance coefficient of 0.1-0.2 for a limb of 2.5-5 cm
/// radius; a tyre's is 0.01). Without it a capsule rolls freely: an arm of a pile of four
/// humanoids rocked on the floor about its own axis at up to 1.5 rad/s for seconds, and
/// the pile slept after 7.7 s instead of 3.5 s.
const ROLLING_ARM_M: f32 = 0.005;
/// A push counts as down when its direction's Y is below minus this.
const SUPPORT_DOWN: f32 = 0.3;
/// A contact holds a body up when its normal toward that body has Y above this.
const SUPPORT_NORMAL_Y: f32 = 0.5;
/// What holds a body up: nothing, the ground, or (any other value) that body.
pub(super) const NOTHING: u32 = u32::MAX;
const GROUND: u32 = u32::MAX - 1;
/// Extra room around every box of the broad phase, metres.
const BROAD_MARGIN_M: f32 = 0.02;

/// Farthest point of a shape from its centre, metres.
pub(super) fn reach(shape: &Shape) -> f32 {
    match *shape {
        Shape::Capsule { radius_m, length_m } => 0.5 * length_m + radius_m,
        Shape::Box { size_m } => 0.5 * Vec3::from_array(size_m).length(),
    }
}

/// World bounds of a shape at a pose.
fn bounds(shape: &Shape, pos: Vec3, rot: Quat) -> (Vec3, Vec3) {
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

/// One contact solved in the current substep, kept for its velocity pass.
#[derive(Clone, Copy, Debug)]
struct Contact {
    a: usize,
    /// The other body, or `None` for the ground.
    b: Option<usize>,
    /// The contact point in each body's frame (on the ground: the world point).
    la: Vec3,
    lb: Vec3,
    /// Unit normal, from `b` toward `a`.
    n: Vec3,
}

/// A contact point found between two shapes: points on each surface, the normal from the
/// second toward the first and the depth (negative when apart).
#[derive(Clone, Copy, Debug)]
struct Found {
    pa: Vec3,
    pb: Vec3,
    n: Vec3,
    depth: f32,
}

/// Reusable buffers of the contact code.
#[derive(Default)]
pub(super) struct Collide {
    broad: BroadPhase,
    boxes: Vec<(Vec3, Vec3)>,
    /// Candidate pairs of this step.
    pub pairs: Vec<(u32, u32)>,
    contacts: Vec<Contact>,
    /// Ragdolls to wake, found while looking for pairs.
    wake: Vec<usize>,
    /// Per body: whether it came within [`TOUCH_M`] of another ragdoll's body this step.
    pub touching: Vec<bool>,
    /// Deepest penetration found this step, before the solver moved anything.
    pub max_penetration: f32,
}

impl Collide {
    pub(super) fn begin_step(&mut self, bodies: usize) {
        self.touching.clear();
        self.touching.resize(bodies, false);
        self.max_penetration = 0.0;
    }
}

/// The capsule's segment ends in the world.
fn ends(pos: Vec3, rot: Quat, length_m: f32) -> (Vec3, Vec3) {
    let h = rot * Vec3::new(0.0, 0.5 * length_m, 0.0);
    (pos - h, pos + h)
}

fn parry_pose(pos: Vec3, rot: Quat) -> Pose {
    Pose::from_parts(pos, rot)
}

impl FastBackend {
    /// Scale of body `i`'s inverse mass for a contact correction against `other` that
    /// moves it along `dir` (unit): shock propagation (after Guendelman et al. 2003,
    /// "Nonconvex rigid bodies with stacking"), one-sided. A body that something other
    /// than `other` holds up in this substep answers a push down, into its holder, as if
    /// heavier; any other push as itself, so an arm still lifts its hand off the floor.
    ///
    /// One pass per substep cannot otherwise carry a heavy body's fall through a light
    /// one on the floor: a 10 kg thigh pushes a 0.5 kg hand into the floor, the floor
    /// pushes it back, and the two sink centimetres into each other; in a pile a hand
    /// ended inside another character's pelvis. Joints keep true masses: weighting them
    /// too pulled bodies down onto their resting neighbours and added energy.
    #[inline]
    fn support_along(&self, i: usize, dir: Vec3, other: Option<usize>) -> f32 {
        let other = other.map_or(GROUND, |o| o as u32);
        let h = self.holder[i];
        if dir.y < -SUPPORT_DOWN && h != NOTHING && h != other {
            1.0 / SUPPORTED_WEIGHT
        } else {
            1.0
        }
    }

    /// Candidate pairs for the coming step; wakes a sleeping ragdoll that a moving body
    /// may reach.
    pub(super) fn find_pairs(&mut self, dt: f32) {
        let mut boxes = std::mem::take(&mut self.collide.boxes);
        boxes.clear();
        boxes.extend((0..self.pos.len()).map(|i| {
            let (lo, hi) = bounds(&self.shape[i], self.pos[i], self.rot[i]);
            let travel = (self.vel[i].length() + self.angvel[i].length() * reach(&self.shape[i]))
                * dt
                + BROAD_MARGIN_M;
            (lo - Vec3::splat(travel), hi + Vec3::splat(travel))
        }));
        let FastBackend {
            collide,
            disabled,
            ragdoll_of,
            ragdolls,
            inv_mass,
            ..
        } = self;
        collide.pairs.clear();
        collide.wake.clear();
        let (pairs, wake) = (&mut collide.pairs, &mut collide.wake);
        collide.broad.find(&boxes, |i, j| {
            let key = (i as u32, j as u32);
            if disabled.contains(&key) || (inv_mass[i] == 0.0 && inv_mass[j] == 0.0) {
                return;
            }
            let (ri, rj) = (ragdoll_of[i], ragdoll_of[j]);
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
            pairs.push(key);
        });
        self.collide.boxes = boxes;
        for k in 0..self.collide.wake.len() {
            let r = self.collide.wake[k];
            self.wake(r);
        }
    }

    /// Finds this substep's contacts and moves the bodies out of each other and the
    /// ground, with static friction.
    pub(super) fn solve_contacts(&mut self) {
        self.collide.contacts.clear();
        self.holder.fill(NOTHING);
        if let Some(g) = self.settings.ground {
            for i in 0..self.pos.len() {
                if self.moving(i) && self.inv_mass[i] > 0.0 {
                    self.ground_contacts(i, g);
                }
            }
        }
        for k in 0..self.collide.pairs.len() {
            let (a, b) = self.collide.pairs[k];
            let (a, b) = (a as usize, b as usize);
            if !self.moving(a) && !self.moving(b) {
                continue;
            }
            if let Some(f) = self.pair_contact(a, b) {
                if f.depth > -TOUCH_M && self.ragdoll_of[a] != self.ragdoll_of[b] {
                    self.collide.touching[a] = true;
                    self.collide.touching[b] = true;
                }
                if f.depth > 0.0 {
                    self.resolve(a, Some(b), f);
                }
            }
        }
    }

    /// Contacts of body `i` with the ground at height `g`: a capsule's end spheres, a
    /// box's corners.
    fn ground_contacts(&mut self, i: usize, g: f32) {
        let (pos, rot) = (self.pos[i], self.rot[i]);
        match self.shape[i] {
            Shape::Capsule { radius_m, length_m } => {
                let (e0, e1) = ends(pos, rot, length_m);
                let count = if length_m > 0.0 { 2 } else { 1 };
                for e in [e0, e1].into_iter().take(count) {
                    let depth = g - (e.y - radius_m);
                    if depth > 0.0 {
                        let pa = e - Vec3::Y * radius_m;
                        let pb = Vec3::new(pa.x, g, pa.z);
                        self.resolve(
                            i,
                            None,
                            Found {
                                pa,
                                pb,
                                n: Vec3::Y,
                                depth,
                            },
                        );
                    }
                }
            }
            Shape::Box { size_m } => {
                let half = Vec3::from_array(size_m) * 0.5;
                for corner in box_corners(half) {
                    let pa = self.pos[i] + self.rot[i] * corner;
                    let depth = g - pa.y;
                    if depth > 0.0 {
                        let pb = Vec3::new(pa.x, g, pa.z);
                        self.resolve(
                            i,
                            None,
                            Found {
                                pa,
                                pb,
                                n: Vec3::Y,
                                depth,
                            },
                        );
                    }
                }
            }
        }
    }

    /// The closest points of bodies `a` and `b`, if they are within [`TOUCH_M`].
    fn pair_contact(&self, a: usize, b: usize) -> Option<Found> {
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
            let (a0, a1) = ends(self.pos[a], self.rot[a], la);
            let (b0, b1) = ends(self.pos[b], self.rot[b], lb);
            let (s, t) = crate::math::closest_segment_params(a0, a1, b0, b1);
            let (ca, cb) = (a0.lerp(a1, s), b0.lerp(b1, t));
            let d = ca - cb;
            let dist = d.length();
            if dist > ra + rb + TOUCH_M {
                return None;
            }
            let n = if dist > 1.0e-9 {
                d / dist
            } else {
                (self.pos[a] - self.pos[b])
                    .try_normalize()
                    .unwrap_or(Vec3::Y)
            };
            return Some(Found {
                pa: ca - n * ra,
                pb: cb + n * rb,
                n,
                depth: ra + rb - dist,
            });
        }
        let pa = parry_pose(self.pos[a], self.rot[a]);
        let pb = parry_pose(self.pos[b], self.rot[b]);
        let c = match (self.shape[a], self.shape[b]) {
            (Shape::Box { size_m: sa }, Shape::Box { size_m: sb }) => query::contact(
                &pa,
                &Cuboid::new(Vec3::from_array(sa) * 0.5),
                &pb,
                &Cuboid::new(Vec3::from_array(sb) * 0.5),
                TOUCH_M,
            ),
            (Shape::Box { size_m }, Shape::Capsule { radius_m, length_m }) => {
                let f = self.box_capsule(a, size_m, b, radius_m, length_m)?;
                return Some(Found {
                    pa: f.pb,
                    pb: f.pa,
                    n: -f.n,
                    depth: f.depth,
                });
            }
            (Shape::Capsule { radius_m, length_m }, Shape::Box { size_m }) => {
                return self.box_capsule(b, size_m, a, radius_m, length_m);
            }
            _ => return None,
        };
        let c = c.ok().flatten()?;
        Some(Found {
            pa: c.point1,
            pb: c.point2,
            n: -c.normal1,
            depth: -c.dist,
        })
    }

    /// The contact of capsule body `c` (radius `r`, segment `length`) with box body `b`
    /// (edges `size`), the capsule first, found in the box's frame
    /// ([`box_capsule::contact_in_box_frame`]).
    fn box_capsule(
        &self,
        b: usize,
        size: [f32; 3],
        c: usize,
        r: f32,
        length: f32,
    ) -> Option<Found> {
        let half = Vec3::from_array(size) * 0.5;
        let inv = self.rot[b].conjugate();
        let (e0, e1) = ends(self.pos[c], self.rot[c], length);
        let (l0, l1) = (inv * (e0 - self.pos[b]), inv * (e1 - self.pos[b]));
        let (p_local, q_local, n_local, depth) =
            box_capsule::contact_in_box_frame(l0, l1, half, r, TOUCH_M)?;
        let rot = self.rot[b];
        Some(Found {
            pa: self.pos[b] + rot * p_local,
            pb: self.pos[b] + rot * q_local,
            n: rot * n_local,
            depth,
        })
    }

    /// Pushes `a` (and `b`, or nothing for the ground) apart along the contact's normal,
    /// then holds the contact points together sideways while friction can (static
    /// friction); keeps the contact for the velocity pass.
    fn resolve(&mut self, a: usize, b: Option<usize>, f: Found) {
        self.collide.max_penetration = self.collide.max_penetration.max(f.depth);
        let ra = f.pa - self.pos[a];
        let rb = b.map_or(Vec3::ZERO, |b| f.pb - self.pos[b]);
        let lambda = self.contact_correction(a, b, ra, rb, f.n, f.depth);
        if lambda <= 0.0 {
            return;
        }
        if f.n.y > SUPPORT_NORMAL_Y && self.holder[a] != GROUND {
            self.holder[a] = b.map_or(GROUND, |b| b as u32);
        }
        if let Some(b) = b
            && f.n.y < -SUPPORT_NORMAL_Y
            && self.holder[b] == NOTHING
        {
            self.holder[b] = a as u32;
        }
        // The same material points, now and at the start of the substep.
        let la = self.rot[a].conjugate() * ra;
        let lb = b.map_or(f.pb, |b| self.rot[b].conjugate() * rb);
        let (ra, pa, pa0) = self.material_point(a, la);
        let (rb, pb, pb0) = match b {
            Some(b) => self.material_point(b, lb),
            None => (Vec3::ZERO, f.pb, f.pb),
        };
        let moved = (pa - pa0) - (pb - pb0);
        let slide = moved - f.n * f.n.dot(moved);
        let len = slide.length();
        if len > 1.0e-9 {
            let t = slide / len;
            let w = self.w_at(a, ra, t) + b.map_or(0.0, |b| self.w_at(b, rb, t));
            if w > 0.0 {
                // Coulomb: the sideways impulse is at most μ times the normal one, so
                // the slide stops when it can (static friction) and is slowed by what
                // friction can give when it cannot (kinetic).
                self.contact_correction(a, b, ra, rb, -t, len.min(FRICTION * lambda * w));
            }
        }
        self.resist_rolling(a, b, lambda);
        self.collide.contacts.push(Contact {
            a,
            b,
            la,
            lb,
            n: f.n,
        });
    }

    /// Rolling and spinning resistance of a contact whose normal impulse was `lambda`: the
    /// two bodies' relative turn in this substep, about any axis, is held back by up to
    /// [`ROLLING_ARM_M`] times that impulse, as sliding is by the friction coefficient
    /// times it. Both halves are needed: measured on a pile of four, with the roll alone
    /// resisted parts still moved at 3-25 cm/s after 8 s, with the spin alone at about
    /// 1 cm/s until 7 s; with both, the pile slept at 3.5 s.
    fn resist_rolling(&mut self, a: usize, b: Option<usize>, lambda: f32) {
        let turned = |i: usize| turn_rate(self.rot[i] * self.prev_rot[i].conjugate(), 1.0);
        let rel = turned(a) - b.map_or(Vec3::ZERO, turned);
        let len = rel.length();
        if len < 1.0e-9 {
            return;
        }
        let t = rel / len;
        let w = self.w_turn(a, t) + b.map_or(0.0, |b| self.w_turn(b, t));
        if w <= 0.0 {
            return;
        }
        let p = t * (len / w).min(ROLLING_ARM_M * lambda);
        let wa = self.inv_inertia_world(a, p);
        self.turn_by(a, -wa);
        if let Some(b) = b {
            let wb = self.inv_inertia_world(b, p);
            self.turn_by(b, wb);
        }
    }

    /// [`FastBackend::correct_position`] for a contact: moves `a`'s point at `ra` by
    /// `c` along `n` (unit) relative to `b`'s at `rb`, with [`FastBackend::support_along`]'s
    /// weights. Returns the impulse's magnitude.
    fn contact_correction(
        &mut self,
        a: usize,
        b: Option<usize>,
        ra: Vec3,
        rb: Vec3,
        n: Vec3,
        c: f32,
    ) -> f32 {
        let sa = self.support_along(a, n, b);
        let sb = b.map_or(0.0, |b| self.support_along(b, -n, Some(a)));
        let w = sa * self.w_at(a, ra, n) + b.map_or(0.0, |b| sb * self.w_at(b, rb, n));
        if w <= 0.0 {
            return 0.0;
        }
        let lambda = c / w;
        let p = n * lambda;
        self.shift(a, ra, p * sa);
        if let Some(b) = b {
            self.shift(b, rb, -p * sb);
        }
        lambda
    }

    /// Body `i`'s point `local` (body frame): its offset from the centre now, and where it
    /// is now and was at the start of the substep.
    fn material_point(&self, i: usize, local: Vec3) -> (Vec3, Vec3, Vec3) {
        let r = self.rot[i] * local;
        (
            r,
            self.pos[i] + r,
            self.prev_pos[i] + self.prev_rot[i] * local,
        )
    }

    /// Restitution 0 on the velocities of this substep's contacts: the normal velocity
    /// each contact's position correction left goes (Müller et al. 2020, eq. 34, with
    /// `e = 0`). Friction is all on positions ([`FastBackend::resolve`]): a second,
    /// velocity-level friction (the paper's dynamic friction) added energy, 1-3 % of a
    /// collapsing humanoid's in a frame, as its impulses set the parts spinning against
    /// their joints.
    pub(super) fn solve_contact_velocities(&mut self) {
        for k in 0..self.collide.contacts.len() {
            let c = self.collide.contacts[k];
            let ra = self.rot[c.a] * c.la;
            let va = self.vel[c.a] + self.angvel[c.a].cross(ra);
            let (rb, vb) = match c.b {
                Some(b) => {
                    let rb = self.rot[b] * c.lb;
                    (rb, self.vel[b] + self.angvel[b].cross(rb))
                }
                None => (Vec3::ZERO, Vec3::ZERO),
            };
            let vn = c.n.dot(va - vb);
            if vn.abs() < 1.0e-9 {
                continue;
            }
            let dir = c.n * -vn.signum();
            let sa = self.support_along(c.a, dir, c.b);
            let sb = c.b.map_or(0.0, |b| self.support_along(b, -dir, Some(c.a)));
            let w = sa * self.w_at(c.a, ra, c.n) + c.b.map_or(0.0, |b| sb * self.w_at(b, rb, c.n));
            if w <= 0.0 {
                continue;
            }
            let p = dir * (vn.abs() / w);
            self.push(c.a, ra, p * sa);
            if let Some(b) = c.b {
                self.push(b, rb, -p * sb);
            }
        }
    }

    /// The first body a ray meets, against each body's own shape.
    pub(super) fn cast_ray_impl(
        &self,
        origin: Vec3,
        dir: Vec3,
        max_dist: f32,
    ) -> Option<(usize, f32)> {
        let hits = (0..self.pos.len()).map(|i| {
            let length = match self.shape[i] {
                Shape::Capsule { length_m, .. } => length_m,
                Shape::Box { .. } => 0.0,
            };
            let ends = ends(self.pos[i], self.rot[i], length);
            ray_shape(origin, dir, &self.shape[i], self.pos[i], self.rot[i], ends)
        });
        nearest_hit(hits, max_dist)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::backend::{Backend, BodyDesc};
    use crate::math::Transform;

    /// A box body and a capsule body at the given poses, no ground.
    fn box_and_capsule(box_pose: Transform, capsule_pose: Transform) -> FastBackend {
        let mut b = FastBackend::new(super::super::FastSettings {
            gravity: Vec3::ZERO,
            ground: None,
            substeps: 1,
        });
        let body = |pose, shape| BodyDesc {
            pose,
            shape,
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
