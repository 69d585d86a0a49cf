//! Large islands cut in two, so that two threads share one pile.
//!
//! An island is solved on one thread (`island.rs`), and a pile of 64 or a crowd a blast
//! throws together is one island. Such an island's ragdolls, ordered along the axis they
//! spread most along, are cut into two halves where the work comes out most even for the
//! fewest contacts across the cut (a pile's halves are its lower and its upper part), each
//! half solved by a solver of its own, and the
//! contacts between the halves by a third solver that holds copies of the few shapes they
//! name: each pass of a substep solves both halves side by side, then those contacts.
//!
//! Nothing a half solves touches a body of the other, so solving the two side by side is
//! solving one and then the other: the island is still solved Gauss-Seidel, its
//! constraints in another order (each half's joints and contacts, then the contacts
//! between them). The cut depends on the island alone, not on the number of threads, so
//! a run is the same on one thread as on many.
//!
//! One thing does not carry over by itself: what holds a shape up (the contacts' shock
//! propagation, `contact.rs`). A half's lowest layer rests on the other half, which only
//! the seam sees; each pass of a half rebuilds its holders before the seam has run, so
//! the upper half's weight pushed that layer into the lower half every pass, as if
//! nothing held it. Each half's pass therefore starts from the holders the seam found in
//! its last pass. Without that, eight tall piles (32-72 ragdolls) landed up to 122 mm
//! deep (79 mm on average, 26 mm uncut); with it, 33 mm on average against 30 uncut, their
//! joints and limits as tight or tighter.

use super::contact::{GROUND, NOTHING};
use super::relay::{Phase, Plan, Relay};
use super::{FastBackend, FastSettings};

/// The fewest ragdolls an island that is cut in two holds: a smaller island's passes are
/// too short to share.
const SPLIT_RAGDOLLS: usize = 16;

/// Whether an island of `ragdolls` of the world's `awake` is cut in two: when it is large
/// and holds half the awake ragdolls or more. Where the work is spread over many islands,
/// they keep the threads busy already, and cutting them only adds the seams' work and the
/// waits: eight piles of sixteen, each cut, took 1.16 times the CPU time and 1.15 times
/// the wall time on two threads. Whether to cut depends on the world alone, not on the
/// threads, so that a run is the same on any number of them.
pub(super) fn worth_cutting(ragdolls: usize, awake: usize) -> bool {
    ragdolls >= SPLIT_RAGDOLLS && 2 * ragdolls >= awake
}

/// What a pair between the halves costs a substep, in distance tests (see
/// [`choose_cut`]): itself, on one thread, and the copies of its shapes in and out of the
/// seam. Measured on a pile of 64: the seam took 6.2 ms a step for 1,242 pairs where the
/// halves took 15 ms for about 190,000 tests and joint passes each, so a pair there cost
/// 1.5 tests a substep; weighing it 0 (cutting for balance alone), 1.5 or 3 gave the same
/// speed, 6 or 12 (fewer pairs, halves out of balance) took 1.3 times as long.
const SEAM_COST: f32 = 1.5;

/// A holder in the other half: the shape is held, by nothing this solver holds.
pub(super) const ELSEWHERE: u32 = u32::MAX - 2;
/// Not held by this solver.
const ABSENT: u32 = u32::MAX;

/// Orders the ragdolls `members` (world indices) by the position of each one's first body
/// along the axis they spread most along.
pub(super) fn order_along_spread(world: &FastBackend, members: &mut [usize]) {
    let at = |r: usize| world.pos[world.ragdolls[r].bodies.start];
    let (mut lo, mut hi) = (glam::Vec3::splat(f32::INFINITY), glam::Vec3::NEG_INFINITY);
    for &r in members.iter() {
        lo = lo.min(at(r));
        hi = hi.max(at(r));
    }
    let spread = hi - lo;
    let axis = if spread.x >= spread.y && spread.x >= spread.z {
        0
    } else if spread.y >= spread.z {
        1
    } else {
        2
    };
    members.sort_by(|&a, &b| at(a)[axis].total_cmp(&at(b)[axis]).then(a.cmp(&b)));
}

/// How many of the ordered `members` make the first half: the cut that finishes first,
/// the longer half's work plus the seam's. A ragdoll's work is its joints that are not
/// frozen, solved every pass of every substep, and the distance tests its shapes took
/// part in over the last step; a candidate pair the cut crosses (`crossing[k]` for a cut
/// before member `k`) costs [`SEAM_COST`] tests a substep, as the seam solves it on one
/// thread. Counted, not timed, so that a run cuts the same way every time. A pile's
/// lower half lies still with its joints frozen while its upper half lands, and a pile
/// falling onto one holds frozen ragdolls in the air: cut at the median ragdoll, or by
/// joints and candidate pairs alone, one half took three times the other's time.
pub(super) fn choose_cut(world: &FastBackend, members: &[usize], crossing: &[i32]) -> usize {
    let solves = world.settings.substeps * world.settings.iterations.max(1);
    let work = |r: usize| {
        let d = &world.ragdolls[r];
        let joints = d.joints.len() - d.frozen.min(d.joints.len());
        (1 + joints) * solves + d.tests as usize
    };
    let total: usize = members.iter().map(|&r| work(r)).sum();
    let (mut best, mut best_cost) = (members.len() / 2, usize::MAX);
    let mut sum = 0;
    for (k, &r) in members.iter().enumerate().take(members.len() - 1) {
        sum += work(r);
        let pairs = crossing[k + 1].max(0) as usize;
        let seam = (SEAM_COST * (world.settings.substeps * pairs) as f32) as usize;
        let cost = sum.max(total - sum) + seam;
        if cost < best_cost {
            (best, best_cost) = (k + 1, cost);
        }
    }
    best
}

/// The contacts between the two halves of an island, and the solver that solves them.
pub(super) struct Seam {
    solver: FastBackend,
    /// The pairs between the halves: half and shape of one, half and shape of the other.
    pub pairs: Vec<[u32; 4]>,
    /// Each of the solver's bodies and shapes: its half and index there.
    body_from: Vec<(u32, u32)>,
    shape_from: Vec<(u32, u32)>,
    /// Each shape's holder as copied in, in the solver's numbering.
    holder_in: Vec<u32>,
    /// Each ragdoll of the solver: its half and index there.
    ragdoll_from: Vec<(u32, u32)>,
    /// Per half, each body's, shape's and ragdoll's index in the solver ([`ABSENT`]).
    body_here: [Vec<u32>; 2],
    shape_here: [Vec<u32>; 2],
    ragdoll_here: [Vec<u32>; 2],
}

impl Seam {
    pub(super) fn new(settings: FastSettings) -> Self {
        Seam {
            solver: FastBackend::with_settings(settings),
            pairs: Vec::new(),
            body_from: Vec::new(),
            shape_from: Vec::new(),
            holder_in: Vec::new(),
            ragdoll_from: Vec::new(),
            body_here: Default::default(),
            shape_here: Default::default(),
            ragdoll_here: Default::default(),
        }
    }

    /// One step of `dt` of the island whose halves are `parts`, on two workers (`relay.rs`).
    pub(super) fn solve(&mut self, parts: &mut [FastBackend], dt: f32) {
        let (a, b) = parts.split_at_mut(1);
        let plan = Plan {
            substeps: a[0].settings.substeps.max(1),
            passes: a[0].passes(),
            dt,
        };
        Relay::run(&mut a[0], &mut b[0], self, &plan);
    }

    /// What the seam does once both halves are through `phase` of `plan`.
    pub(super) fn after(&mut self, parts: &mut [&mut FastBackend], plan: &Plan, phase: usize) {
        match plan.phase(phase) {
            Phase::Begin => self.build(parts, plan.dt),
            Phase::Pass { frac, .. } => self.solve_pass(parts, frac * plan.dt),
            Phase::Velocities => self.solve_velocities(parts),
            Phase::End => self.finish(parts),
        }
    }

    /// Copies the shapes the pairs name, and their bodies, into the solver, and culls the
    /// pairs with the halves' ragdoll speeds (measured over every shape of each ragdoll).
    fn build(&mut self, parts: &mut [&mut FastBackend], dt: f32) {
        self.solver.settings = parts[0].settings;
        self.solver.clear_bodies();
        for v in [
            &mut self.body_from,
            &mut self.shape_from,
            &mut self.ragdoll_from,
        ] {
            v.clear();
        }
        self.holder_in.clear();
        for (p, part) in parts.iter_mut().enumerate() {
            part.seam_holder.clear();
            part.seam_holder.resize(part.shape.len(), NOTHING);
            reset(&mut self.body_here[p], part.pos.len());
            reset(&mut self.shape_here[p], part.shape.len());
            reset(&mut self.ragdoll_here[p], part.ragdolls.len());
        }
        let pairs = std::mem::take(&mut self.pairs);
        for &[pa, a, pb, b] in &pairs {
            let a = self.add_shape(parts, pa as usize, a as usize);
            let b = self.add_shape(parts, pb as usize, b as usize);
            self.solver.collide.pairs.push((a, b));
        }
        self.pairs = pairs;
        let s = &mut self.solver;
        s.collide.ragdoll_speed.clear();
        s.collide.ragdoll_speed.extend(
            self.ragdoll_from
                .iter()
                .map(|&(p, r)| parts[p as usize].collide.ragdoll_speed[r as usize]),
        );
        s.collide.begin_step(s.shape.len(), s.settings.gravity);
        s.cull_pairs_with(dt, false);
        s.collide.tests.clear();
        s.collide.tests.resize(self.ragdoll_from.len(), 0);
    }

    /// Shape `c` of half `p` in the solver, copied in with its body if it is not yet.
    fn add_shape(&mut self, parts: &[&mut FastBackend], p: usize, c: usize) -> u32 {
        if self.shape_here[p][c] != ABSENT {
            return self.shape_here[p][c];
        }
        let part = &parts[p];
        let body = self.add_body(parts, p, part.owner[c] as usize);
        let s = &mut self.solver;
        let here = s.shape.len() as u32;
        s.shape.push(part.shape[c]);
        s.owner.push(body);
        s.attach.push(part.attach[c]);
        s.holder.push(NOTHING);
        self.holder_in.push(NOTHING);
        self.shape_from.push((p as u32, c as u32));
        self.shape_here[p][c] = here;
        here
    }

    /// Body `i` of half `p` in the solver, copied in if it is not yet.
    fn add_body(&mut self, parts: &[&mut FastBackend], p: usize, i: usize) -> u32 {
        if self.body_here[p][i] != ABSENT {
            return self.body_here[p][i];
        }
        let part = &parts[p];
        let r = part.ragdoll_of[i];
        if self.ragdoll_here[p][r] == ABSENT {
            self.ragdoll_here[p][r] = self.ragdoll_from.len() as u32;
            self.ragdoll_from.push((p as u32, r as u32));
        }
        let s = &mut self.solver;
        macro_rules! copy {
            ($($f:ident),*) => { $( s.$f.push(part.$f[i]); )* };
        }
        body_state!(copy);
        s.ragdoll_of.push(self.ragdoll_here[p][r] as usize);
        let here = s.pos.len() as u32 - 1;
        self.body_from.push((p as u32, i as u32));
        self.body_here[p][i] = here;
        here
    }

    /// A pass of the contacts between the halves, after the halves' own pass.
    fn solve_pass(&mut self, parts: &mut [&mut FastBackend], elapsed: f32) {
        let s = &mut self.solver;
        for (e, &(p, i)) in self.body_from.iter().enumerate() {
            let (part, i) = (&parts[p as usize], i as usize);
            s.pos[e] = part.pos[i];
            s.rot[e] = part.rot[i];
            s.prev_pos[e] = part.prev_pos[i];
            s.prev_rot[e] = part.prev_rot[i];
            s.moved[e] = part.moved[i];
            s.inv_inertia_world[e] = part.inv_inertia_world[i];
        }
        for (e, &(p, c)) in self.shape_from.iter().enumerate() {
            let h = parts[p as usize].holder[c as usize];
            let here = match h {
                NOTHING | GROUND | ELSEWHERE => h,
                b => match self.body_here[p as usize][b as usize] {
                    ABSENT => ELSEWHERE,
                    b => b,
                },
            };
            s.holder[e] = here;
            self.holder_in[e] = here;
        }
        s.collide.on_ground.clear();
        s.collide.on_ground.extend(
            self.body_from
                .iter()
                .map(|&(p, i)| parts[p as usize].collide.on_ground[i as usize]),
        );
        s.collide.elapsed = elapsed;
        s.collide.h = parts[0].collide.h;
        s.collide.forget_contacts();
        s.solve_pair_contacts();
        for (e, &(p, i)) in self.body_from.iter().enumerate() {
            let (part, i) = (&mut parts[p as usize], i as usize);
            part.pos[i] = s.pos[e];
            part.rot[i] = s.rot[e];
            part.moved[i] = s.moved[e];
        }
        for (e, &(p, c)) in self.shape_from.iter().enumerate() {
            let h = s.holder[e];
            parts[p as usize].seam_holder[c as usize] = NOTHING;
            if h == self.holder_in[e] {
                continue;
            }
            let back = match h {
                NOTHING | GROUND | ELSEWHERE => h,
                b => match self.body_from[b as usize] {
                    (q, i) if q == p => i,
                    _ => ELSEWHERE,
                },
            };
            let part = &mut parts[p as usize];
            part.holder[c as usize] = back;
            if back == ELSEWHERE {
                part.seam_holder[c as usize] = ELSEWHERE;
            }
        }
    }

    /// The velocity pass of the contacts between the halves, after the halves' own.
    fn solve_velocities(&mut self, parts: &mut [&mut FastBackend]) {
        let s = &mut self.solver;
        for (e, &(p, i)) in self.body_from.iter().enumerate() {
            let (part, i) = (&parts[p as usize], i as usize);
            s.rot[e] = part.rot[i];
            s.vel[e] = part.vel[i];
            s.angvel[e] = part.angvel[i];
        }
        s.solve_contact_velocities();
        for (e, &(p, i)) in self.body_from.iter().enumerate() {
            let (part, i) = (&mut parts[p as usize], i as usize);
            part.vel[i] = s.vel[e];
            part.angvel[i] = s.angvel[e];
        }
    }

    /// What the contacts between the halves saw, handed to the halves.
    fn finish(&self, parts: &mut [&mut FastBackend]) {
        let s = &self.solver;
        for part in parts.iter_mut() {
            part.seam_holder.clear();
        }
        for (e, &(p, c)) in self.shape_from.iter().enumerate() {
            if s.collide.touching[e] {
                parts[p as usize].collide.touching[c as usize] = true;
            }
        }
        for (&(p, r), &t) in self.ragdoll_from.iter().zip(&s.collide.tests) {
            parts[p as usize].collide.tests[r as usize] += t;
        }
        let deepest = &mut parts[0].collide.max_penetration;
        *deepest = deepest.max(s.collide.max_penetration);
    }
}

/// `len` entries of [`ABSENT`].
fn reset(v: &mut Vec<u32>, len: usize) {
    v.clear();
    v.resize(len, ABSENT);
}

#[cfg(test)]
mod tests {
    use glam::{Quat, Vec3};

    use super::super::FastSettings;
    use super::*;
    use crate::backend::{Backend, BodyDesc, JointDesc};
    use crate::math::Transform;
    use crate::spec::{JointKind, Shape};

    /// Every body's position and velocity, after each step.
    type States = Vec<Vec<(Vec3, Vec3)>>;

    /// Two blocks of 12 two-capsule ragdolls in zero gravity flying head on into each
    /// other at 4 m/s each, with some sideways drift and spin: each block 2 × 3 × 2
    /// ragdolls lying along X, near enough to be one island with the other once they
    /// close. Stepped `steps` times on a pool of `threads`; returns the ragdolls' masses,
    /// every body's position and velocity after each step, and the deepest contact the
    /// seam between two halves of an island met.
    fn head_on_in_zero_gravity(threads: usize, steps: usize) -> (Vec<f32>, States, f32) {
        let mut w = FastBackend::with_settings(FastSettings {
            gravity: Vec3::ZERO,
            ground: None,
            substeps: 16,
            iterations: 1,
            impact_passes: 3,
            freeze_joints: true,
            keep_contacts: false,
        });
        let shape = Shape::Capsule {
            radius_m: 0.05,
            length_m: 0.2,
        };
        let along_x = Quat::from_rotation_z(-std::f32::consts::FRAC_PI_2);
        let at =
            |x: f32| Transform::new(along_x.conjugate() * Vec3::new(x, 0.0, 0.0), Quat::IDENTITY);
        let joint = JointDesc {
            parent: 0,
            child: 1,
            frame_parent: at(0.16),
            frame_child: at(-0.16),
            kind: JointKind::Ball,
        };
        let mut masses = Vec::new();
        for k in 0..24 {
            let side = if k < 12 { -1.0 } else { 1.0 };
            let centre = Vec3::new(
                side * (0.5 + 0.7 * (k % 2) as f32),
                (k / 2 % 3) as f32 * 0.15,
                (k / 6 % 2) as f32 * 0.15,
            );
            let drift = Vec3::new(-4.0 * side, 0.0, 0.1 * (k % 5) as f32 - 0.2);
            let body = |dx: f32, mass: f32| BodyDesc {
                pose: Transform::new(centre + Vec3::new(dx, 0.0, 0.0), along_x),
                shape,
                extra_shapes: Vec::new(),
                mass,
                linvel: drift,
                angvel: Vec3::new(0.5 * (k % 3) as f32, 0.0, 0.0),
            };
            let heavy = 3.0 + (k % 3) as f32;
            masses.extend([heavy, 2.0]);
            w.add_ragdoll(
                &[body(-0.16, heavy), body(0.16, 2.0)],
                std::slice::from_ref(&joint),
                &[],
            );
        }
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let mut deepest = 0.0f32;
        let mut states = Vec::new();
        pool.install(|| {
            for _ in 0..steps {
                w.step(1.0 / 60.0);
                if let Some(seam) = w.seam_pool.first() {
                    deepest = deepest.max(seam.solver.collide.max_penetration);
                }
                states.push(w.pos.iter().copied().zip(w.vel.iter().copied()).collect());
            }
        });
        (masses, states, deepest)
    }

    #[test]
    fn an_island_cut_in_two_keeps_its_momentum_whatever_the_threads() {
        // The halves and the seam between them share out each contact's impulse between
        // its two bodies wherever the cut runs, so a crowd that only meets itself keeps
        // its momentum; and the cut is the island's, not the threads', so one thread and
        // two give the same run, bit for bit.
        let (masses, one, deepest) = head_on_in_zero_gravity(1, 30);
        assert!(deepest > 0.0, "the seam never met a contact");
        let (_, two, _) = head_on_in_zero_gravity(2, 30);
        assert!(one == two, "one thread and two ran differently");
        let momentum = |state: &[(Vec3, Vec3)]| {
            state
                .iter()
                .zip(&masses)
                .map(|(&(_, v), &m)| v * m)
                .sum::<Vec3>()
        };
        let start = momentum(&one[0]);
        let total_mass: f32 = masses.iter().sum();
        for (k, state) in one.iter().enumerate() {
            let drift = (momentum(state) - start).length();
            // f32 rounding of 48 bodies' velocities of a few m/s: a millimetre a second
            // of the crowd's mean velocity (each block carries 4 m/s of its 66 kg).
            assert!(
                drift < 1.0e-3 * total_mass,
                "step {k}: momentum moved by {drift} N·s"
            );
        }
    }
}
