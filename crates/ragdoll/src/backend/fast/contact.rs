//! Contacts of the fast backend, solved: every substep the ground's and the candidate
//! pairs' contact points (found in `narrow.rs`) are pushed apart as XPBD contacts with
//! Coulomb friction and rolling resistance on positions and restitution 0 on velocities
//! (Müller et al. 2020, §3.5 and §3.6), with one-sided shock propagation.

use glam::Vec3;

use super::kept::Kept;
use super::narrow::{CLOSING_MARGIN_M, Found, ends};
use super::solve::turn_rate;
use super::split::ELSEWHERE;
use super::{FRICTION, FastBackend};
use crate::geometry::box_corners;
use crate::geometry::broad::BroadPhase;
use crate::spec::Shape;

/// Closer than this counts as touching another ragdoll, metres (as the other backends).
pub(super) const TOUCH_M: f32 = 0.005;
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
/// A body rising faster than this, m/s, is not pressed on what holds it up (see
/// [`FastBackend::support_along`]): the speed a resting body drifts at most, the sleep
/// test's 5 cm/s. At 0.1 m/s, stacks of 3-8 boxes whose bottom box is struck up at
/// 0.5-4 m/s rose with more momentum than the blow gave.
const RISING_MPS: f32 = 0.05;
/// A push counts as down when its direction along gravity is above this.
const SUPPORT_DOWN: f32 = 0.3;
/// A contact holds a body up when its normal toward that body against gravity is above
/// this.
const SUPPORT_NORMAL_UP: f32 = 0.5;
/// What holds a body up: nothing, the ground, or (any other value) that body.
pub(super) const NOTHING: u32 = u32::MAX;
pub(super) const GROUND: u32 = u32::MAX - 1;
/// One contact solved in the current substep, kept for its velocity pass.
#[derive(Clone, Copy, Debug)]
struct Contact {
    /// The shape of `a` that touches, and the other's (`None`: the ground).
    ca: usize,
    cb: Option<usize>,
    a: usize,
    /// The other body, or `None` for the ground.
    b: Option<usize>,
    /// The contact point in each body's frame (on the ground: the world point).
    la: Vec3,
    lb: Vec3,
    /// Unit normal, from `b` toward `a`.
    n: Vec3,
}

/// Reusable buffers of the contact code.
#[derive(Default)]
pub(super) struct Collide {
    pub broad: BroadPhase,
    pub boxes: Vec<(Vec3, Vec3)>,
    /// Candidate pairs of this step.
    pub pairs: Vec<(u32, u32)>,
    /// Per pair of `pairs` once culled: seconds into the step before which the two cannot
    /// come within [`TOUCH_M`] (0 for pairs that may touch at once), so the substeps
    /// before it skip the pair's distance test; each test that finds them apart moves it
    /// on by the gap it found.
    pub wait: Vec<f32>,
    /// Per pair: the fastest the two may close on each other in this step, m/s.
    pub closing: Vec<f32>,
    /// Per pair: its contact as last found, touching or apart, with
    /// `FastConfig::keep_contacts` on (`kept.rs`); empty with it off.
    pub kept: Vec<Option<Kept>>,
    /// Per ragdoll: the fastest any point of it moves at the step's start, m/s, and the
    /// farthest one may go in the step, metres.
    pub ragdoll_speed: Vec<(f32, f32)>,
    /// The step's length, and the seconds into it that the present substep ends at.
    pub dt: f32,
    pub elapsed: f32,
    /// The present substep's length, seconds.
    pub h: f32,
    contacts: Vec<Contact>,
    /// Per body: whether the ground (or a skin point on it) pushed it in this pass.
    pub on_ground: Vec<bool>,
    /// Ragdolls to wake, found while looking for pairs.
    pub wake: Vec<usize>,
    /// Per shape: whether it came within [`TOUCH_M`] of another ragdoll's shape this step.
    pub touching: Vec<bool>,
    /// Deepest penetration found this step, before the solver moved anything.
    pub max_penetration: f32,
    /// Up, against gravity (unit; zero in zero gravity, where nothing is held up).
    pub up: Vec3,
    /// Per ragdoll: the distance tests its shapes took part in this step.
    pub tests: Vec<u32>,
}

impl Collide {
    pub(super) fn begin_step(&mut self, shapes: usize, gravity: Vec3) {
        self.up = -gravity.normalize_or_zero();
        self.touching.clear();
        self.touching.resize(shapes, false);
        self.max_penetration = 0.0;
    }

    /// Drops the contacts kept for the velocity pass: a new pass finds them again.
    pub(super) fn forget_contacts(&mut self) {
        self.contacts.clear();
    }
}

impl FastBackend {
    /// Scale of the inverse mass of shape `c`'s body for a contact correction on that
    /// shape against body `other` that moves it along `dir` (unit): shock propagation
    /// (after Guendelman et al. 2003, "Nonconvex rigid bodies with stacking"), one-sided.
    /// A shape that something other than `other` holds up in this substep answers a push
    /// down, into its holder, as if heavier; any other push as itself, so an arm still
    /// lifts its hand off the floor.
    ///
    /// Held is said of the shape, not its body: a compound of frozen parts (`freeze.rs`)
    /// held at one end is a lever at the other, and weighting a push there too gained a
    /// pile of four 11 % of its energy in a frame as a leg resting on its shin was kicked
    /// up at its thigh.
    ///
    /// Down is gravity's way, and in zero gravity nothing is held: the weights do not
    /// conserve momentum (the holder stands in for the ground behind it), and a floating
    /// humanoid shot in the hand, its hand then striking its own thigh, came away with
    /// 0.8 N·s up it was never given.
    ///
    /// For the same reason the floor's help reaches a shape only while it presses down:
    /// not when its body came into the substep rising, nor when its holder is on its way
    /// up ([`FastBackend::lifted`]: struck from below, or pushed up by a body that was).
    /// Without that, a body struck up from below passed nearly all its speed on to the
    /// one resting on it and kept nearly all its own, and so on up: a stack of eight boxes
    /// rose with 8.8 times the momentum its bottom box was given, and a column of 61
    /// humanoids gained half its energy in a frame, flinging a ragdoll at its foot up at
    /// 35-144 m/s. What the floor itself pushes up is still held, or held by: a hand
    /// landing under a torso is pushed out of the floor as the torso comes down on it.
    /// Counting such push-outs as rising, the bench's piles of 248-257 ragdolls sank
    /// 8.6 mm into each other and went 2.1° past their limits; with the floor's pushes
    /// left out, 7.0 mm and 1.5°, against 6.2 mm and 1.7° before bodies were asked
    /// whether they rise.
    ///
    /// One pass per substep cannot otherwise carry a heavy body's fall through a light
    /// one on the floor: a 10 kg thigh pushes a 0.5 kg hand into the floor, the floor
    /// pushes it back, and the two sink centimetres into each other; in a pile a hand
    /// ended inside another character's pelvis. Joints keep true masses: weighting them
    /// too pulled bodies down onto their resting neighbours and added energy.
    #[inline]
    fn support_along(&self, c: usize, dir: Vec3, other: Option<usize>) -> f32 {
        let other = other.map_or(GROUND, |o| o as u32);
        let h = self.holder[c];
        if dir.dot(self.collide.up) < -SUPPORT_DOWN
            && h != NOTHING
            && h != other
            && !self.arrives_rising(self.owner[c])
            && !(h < ELSEWHERE && self.lifted(h))
        {
            1.0 / SUPPORTED_WEIGHT
        } else {
            1.0
        }
    }

    /// Whether body `i` came into this substep rising faster than [`RISING_MPS`]: its
    /// motion over the substep less what the constraints moved it by.
    #[inline]
    fn arrives_rising(&self, i: u32) -> bool {
        let i = i as usize;
        let predicted = self.pos[i] - self.prev_pos[i] - self.moved[i];
        predicted.dot(self.collide.up) > RISING_MPS * self.collide.h
    }

    /// Whether body `i`, holding a shape up, is itself on its way up: it came into this
    /// substep rising, or it has risen in this substep's passes so far (a body below has
    /// just pushed it up) and not by the ground pushing it out.
    #[inline]
    fn lifted(&self, i: u32) -> bool {
        let b = i as usize;
        let risen = (self.pos[b] - self.prev_pos[b]).dot(self.collide.up);
        self.arrives_rising(i)
            || (risen > RISING_MPS * self.collide.h && !self.collide.on_ground[b])
    }

    /// Finds this substep's contacts and moves the bodies out of each other and the
    /// ground, with static friction.
    pub(super) fn solve_contacts(&mut self) {
        self.collide.contacts.clear();
        if self.seam_holder.is_empty() {
            self.holder.fill(NOTHING);
        } else {
            self.holder.copy_from_slice(&self.seam_holder);
        }
        self.collide.on_ground.clear();
        self.collide.on_ground.resize(self.pos.len(), false);
        if let Some(g) = self.settings.ground {
            for c in 0..self.shape.len() {
                if self.inv_mass[self.owner[c] as usize] > 0.0 {
                    self.ground_contacts(c, g);
                }
            }
            self.solve_skin_points(g);
        }
        self.solve_pair_contacts();
    }

    /// The candidate pairs' contacts of this substep: the share of
    /// [`FastBackend::solve_contacts`] that the seam between the two halves of an island
    /// (`split.rs`), which has no ground of its own, runs alone.
    pub(super) fn solve_pair_contacts(&mut self) {
        for k in 0..self.collide.pairs.len() {
            // A pair that cannot touch yet, read first: most of a crowd's pairs wait.
            if self
                .collide
                .wait
                .get(k)
                .is_some_and(|&t| t > self.collide.elapsed)
            {
                continue;
            }
            let (a, b) = self.collide.pairs[k];
            let (a, b) = (a as usize, b as usize);
            let (oa, ob) = (self.owner[a] as usize, self.owner[b] as usize);
            // Two parts of one compound: their joints are frozen, they move as one.
            if oa == ob {
                continue;
            }
            for o in [oa, ob] {
                if let Some(t) = self.collide.tests.get_mut(self.ragdoll_of[o]) {
                    *t += 1;
                }
            }
            if let Some(f) = self.pair_contact_rescheduled(k, a, b) {
                if f.depth > -TOUCH_M && self.ragdoll_of[oa] != self.ragdoll_of[ob] {
                    self.collide.touching[a] = true;
                    self.collide.touching[b] = true;
                }
                if f.depth > 0.0 {
                    self.resolve(a, Some(b), f);
                }
            }
        }
    }

    /// [`FastBackend::pair_contact`] of candidate pair `k` (shapes `a` and `b`), or its
    /// last one carried along while the two have barely moved against each other
    /// (`kept.rs`); when the two are farther apart, the pair's next test waits for as
    /// long as they need to close the gap (`Collide::wait`), for the rest of the step
    /// when they cannot.
    fn pair_contact_rescheduled(&mut self, k: usize, a: usize, b: usize) -> Option<Found> {
        let c = &self.collide;
        let Some(&speed) = c.closing.get(k) else {
            return self.pair_contact(a, b);
        };
        let carried = c
            .kept
            .get(k)
            .and_then(Option::as_ref)
            .and_then(|kept| self.carry_contact(a, b, kept));
        let left = (c.dt - c.elapsed).max(0.0);
        let found = carried.or_else(|| {
            let found = self.pair_contact_within(a, b, TOUCH_M + speed * left + CLOSING_MARGIN_M);
            if self.settings.keep_contacts {
                let kept = found.as_ref().map(|f| self.keep_contact(a, b, f));
                if let Some(slot) = self.collide.kept.get_mut(k) {
                    *slot = kept;
                }
            }
            found
        });
        let c = &mut self.collide;
        match found {
            Some(f) if f.depth > -TOUCH_M => Some(f),
            Some(f) => {
                let gap = -f.depth - TOUCH_M - CLOSING_MARGIN_M;
                if gap > 0.0 && speed > 0.0 {
                    c.wait[k] = c.elapsed + gap / speed;
                }
                None
            }
            None => {
                c.wait[k] = f32::INFINITY;
                None
            }
        }
    }

    /// Contacts of shape `c` with the ground at height `g`: a capsule's end spheres, a
    /// box's corners.
    fn ground_contacts(&mut self, c: usize, g: f32) {
        let (pos, rot) = self.shape_pose(c);
        match self.shape[c] {
            Shape::Capsule { radius_m, length_m } => {
                let (e0, e1) = ends(pos, rot, length_m);
                let count = if length_m > 0.0 { 2 } else { 1 };
                for e in [e0, e1].into_iter().take(count) {
                    let depth = g - (e.y - radius_m);
                    if depth > 0.0 {
                        let pa = e - Vec3::Y * radius_m;
                        let pb = Vec3::new(pa.x, g, pa.z);
                        self.resolve(
                            c,
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
                    // The pose as the corners before moved it.
                    let (pos, rot) = self.shape_pose(c);
                    let pa = pos + rot * corner;
                    let depth = g - pa.y;
                    if depth > 0.0 {
                        let pb = Vec3::new(pa.x, g, pa.z);
                        self.resolve(
                            c,
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

    /// Pushes shape `ca`'s body (and `cb`'s, or nothing for the ground) apart along the
    /// contact's normal, then holds the contact points together sideways while friction
    /// can (static friction); keeps the contact for the velocity pass.
    fn resolve(&mut self, ca: usize, cb: Option<usize>, f: Found) {
        self.collide.max_penetration = self.collide.max_penetration.max(f.depth);
        let a = self.owner[ca] as usize;
        let b = cb.map(|cb| self.owner[cb] as usize);
        let ra = f.pa - self.pos[a];
        let rb = b.map_or(Vec3::ZERO, |b| f.pb - self.pos[b]);
        let lambda = self.contact_correction(ca, cb, ra, rb, f.n, f.depth);
        if lambda <= 0.0 {
            return;
        }
        let up = f.n.dot(self.collide.up);
        if up > SUPPORT_NORMAL_UP && self.holder[ca] != GROUND {
            self.holder[ca] = b.map_or(GROUND, |b| b as u32);
        }
        if b.is_none() {
            self.collide.on_ground[a] = true;
        }
        if let Some(cb) = cb
            && up < -SUPPORT_NORMAL_UP
            && self.holder[cb] == NOTHING
        {
            self.holder[cb] = a as u32;
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
                self.contact_correction(ca, cb, ra, rb, -t, len.min(FRICTION * lambda * w));
            }
        }
        self.resist_rolling(a, b, lambda);
        self.collide.contacts.push(Contact {
            ca,
            cb,
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

    /// [`FastBackend::correct_position`] for a contact of shape `ca` with `cb` (`None`:
    /// the ground): moves the point of `ca`'s body at `ra` by `c` along `n` (unit)
    /// relative to `cb`'s body's at `rb`, with [`FastBackend::support_along`]'s weights.
    /// Returns the impulse's magnitude.
    fn contact_correction(
        &mut self,
        ca: usize,
        cb: Option<usize>,
        ra: Vec3,
        rb: Vec3,
        n: Vec3,
        c: f32,
    ) -> f32 {
        let a = self.owner[ca] as usize;
        let b = cb.map(|cb| self.owner[cb] as usize);
        let sa = self.support_along(ca, n, b);
        let sb = cb.map_or(0.0, |cb| self.support_along(cb, -n, Some(a)));
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
        self.solve_skin_velocities();
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
            let sa = self.support_along(c.ca, dir, c.b);
            let sb =
                c.cb.map_or(0.0, |cb| self.support_along(cb, -dir, Some(c.a)));
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
}
