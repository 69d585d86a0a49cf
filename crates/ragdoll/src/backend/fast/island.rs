//! Stepping by islands: the awake ragdolls that may touch (this step's candidate pairs
//! link them) are copied into a solver of their own, the islands are solved in parallel
//! (rayon), and their bodies copied back.
//!
//! Islands share nothing while they are solved, so each comes out the same whatever the
//! number of threads or the order they run in: a rerun is bit-identical. The copies cost
//! a few dozen values per body per step, against the solver's hundreds per substep.

use rayon::prelude::*;

use super::split::{Seam, choose_cut, order_along_spread, worth_cutting};
use super::{FastBackend, Pin, Ragdoll};
use crate::math::Transform;

/// Calls the macro `$m` with every array of the solver that holds one entry per body of
/// the world (per body or shape in an island's solver: its state, shape and holder), so
/// clearing and copying a body name them in one place.
macro_rules! per_body {
    ($m:ident) => {
        body_state!($m, shape, holder)
    };
}

/// No island: the ragdoll sleeps.
pub(super) const NO_ISLAND: u32 = u32::MAX;

/// The root of `r`'s set, halving the path on the way.
fn find(parent: &mut [usize], mut r: usize) -> usize {
    while parent[r] != r {
        parent[r] = parent[parent[r]];
        r = parent[r];
    }
    r
}

impl FastBackend {
    /// One step of every awake ragdoll, island by island.
    pub(super) fn step_islands(&mut self, dt: f32) {
        let count = self.assign_islands();
        let first = self.assign_solvers(count);
        let solvers = first[count];
        let mut subs = std::mem::take(&mut self.island_pool);
        while subs.len() < solvers {
            subs.push(FastBackend::with_settings(self.settings));
        }
        let mut seams = std::mem::take(&mut self.seam_pool);
        let cut = (0..count).filter(|&i| first[i + 1] - first[i] > 1).count();
        while seams.len() < cut {
            seams.push(Seam::new(self.settings));
        }
        // Each island takes the substeps its most demanding ragdoll needs, and the passes
        // of an impact where one of its ragdolls may strike something hard this step.
        let mut factor = vec![1.0f32; count];
        let mut impact = vec![false; count];
        for (r, ragdoll) in self.ragdolls.iter().enumerate() {
            if let Some(f) = factor.get_mut(self.island_of[r] as usize) {
                *f = f.max(ragdoll.substep_factor);
                impact[self.island_of[r] as usize] |=
                    ragdoll.closing_mps > super::impact::IMPACT_MPS;
            }
        }
        for i in 0..count {
            for sub in &mut subs[first[i]..first[i + 1]] {
                sub.settings = self.settings;
                sub.settings.substeps = (self.settings.substeps as f32 * factor[i]).ceil() as usize;
                if impact[i] {
                    sub.settings.iterations =
                        self.settings.iterations + self.settings.impact_passes;
                }
                sub.clear_bodies();
            }
        }
        for seam in &mut seams[..cut] {
            seam.pairs.clear();
        }
        self.gather(&mut subs[..solvers], &first, &mut seams[..cut], dt);
        // Each island's solvers, and the seam between them where it has two.
        let mut work = Vec::with_capacity(count);
        let (mut rest, mut seam_rest) = (&mut subs[..solvers], seams[..cut].iter_mut());
        for i in 0..count {
            let (parts, tail) = std::mem::take(&mut rest).split_at_mut(first[i + 1] - first[i]);
            rest = tail;
            let seam = if parts.len() > 1 {
                seam_rest.next()
            } else {
                None
            };
            work.push((parts, seam));
        }
        work.par_iter_mut().for_each(|(parts, seam)| match seam {
            Some(seam) => seam.solve(parts, dt),
            None => parts[0].solve_step(dt),
        });
        self.scatter(&subs[..solvers], dt);
        self.island_pool = subs;
        self.seam_pool = seams;
    }

    /// Numbers the solvers of the `count` islands into `solver_of`: one for an island,
    /// two for one [`worth_cutting`] (its halves). Returns the first solver of each
    /// island, and after them the number of solvers.
    fn assign_solvers(&mut self, count: usize) -> Vec<usize> {
        let mut size = vec![0usize; count];
        for &island in self.island_of.iter().filter(|&&i| i != NO_ISLAND) {
            size[island as usize] += 1;
        }
        let awake = size.iter().sum::<usize>();
        let mut first = Vec::with_capacity(count + 1);
        // Each island cut in two: its place among them, and its ragdolls.
        let mut cut_of = vec![u32::MAX; count];
        let mut members = Vec::new();
        let mut next = 0;
        for (i, &n) in size.iter().enumerate() {
            first.push(next);
            next += 1;
            if worth_cutting(n, awake) {
                cut_of[i] = members.len() as u32;
                members.push(Vec::with_capacity(n));
                next += 1;
            }
        }
        first.push(next);
        let mut solver_of = std::mem::take(&mut self.solver_of);
        solver_of.clear();
        solver_of.extend(self.island_of.iter().map(|&i| match i {
            NO_ISLAND => NO_ISLAND,
            i => first[i as usize] as u32,
        }));
        for (r, &island) in self.island_of.iter().enumerate() {
            if let Some(m) = cut_of
                .get(island as usize)
                .and_then(|&c| members.get_mut(c as usize))
            {
                m.push(r);
            }
        }
        let crossing = self.order_cut_islands(&mut members, &cut_of);
        for (m, crossing) in members.iter().zip(&crossing) {
            for &r in &m[choose_cut(self, m, crossing)..] {
                solver_of[r] += 1;
            }
        }
        self.solver_of = solver_of;
        first
    }

    /// Orders the ragdolls of each island to cut in two (`members`; `cut_of` gives each
    /// island's place among them) along its spread, and counts for each place it could be
    /// cut the candidate pairs the cut would cross.
    fn order_cut_islands(&self, members: &mut [Vec<usize>], cut_of: &[u32]) -> Vec<Vec<i32>> {
        let mut crossing = Vec::with_capacity(members.len());
        if members.is_empty() {
            return crossing;
        }
        let mut rank = vec![0u32; self.ragdolls.len()];
        for m in members.iter_mut() {
            order_along_spread(self, m);
            for (k, &r) in m.iter().enumerate() {
                rank[r] = k as u32;
            }
            crossing.push(vec![0; m.len() + 1]);
        }
        // Each pair crosses the cuts between its two ragdolls: a difference array.
        for &(a, b) in &self.collide.pairs {
            let ra = self.ragdoll_of[self.body_of_shape(a as usize)];
            let rb = self.ragdoll_of[self.body_of_shape(b as usize)];
            let island = self.island_of[ra];
            if island == NO_ISLAND || island != self.island_of[rb] || ra == rb {
                continue;
            }
            if let Some(c) = crossing.get_mut(cut_of[island as usize] as usize) {
                let (p, q) = (rank[ra].min(rank[rb]), rank[ra].max(rank[rb]));
                c[p as usize + 1] += 1;
                c[q as usize + 1] -= 1;
            }
        }
        for c in &mut crossing {
            for k in 1..c.len() {
                c[k] += c[k - 1];
            }
        }
        crossing
    }

    /// Numbers the islands of awake ragdolls into `island_of` (in the order of their
    /// first ragdoll, so the numbering is the same every run); returns how many.
    fn assign_islands(&mut self) -> usize {
        let n = self.ragdolls.len();
        let mut parent = std::mem::take(&mut self.islands);
        parent.clear();
        parent.extend(0..n);
        for &(a, b) in &self.collide.pairs {
            let (i, j) = (
                self.body_of_shape(a as usize),
                self.body_of_shape(b as usize),
            );
            let (ri, rj) = (self.ragdoll_of[i], self.ragdoll_of[j]);
            if ri != rj && !self.ragdolls[ri].asleep && !self.ragdolls[rj].asleep {
                let (a, b) = (find(&mut parent, ri), find(&mut parent, rj));
                parent[a.max(b)] = a.min(b);
            }
        }
        self.island_of.clear();
        self.island_of.resize(n, NO_ISLAND);
        let mut count = 0u32;
        for r in 0..n {
            if self.ragdolls[r].asleep {
                continue;
            }
            let root = find(&mut parent, r);
            if self.island_of[root] == NO_ISLAND {
                self.island_of[root] = count;
                count += 1;
            }
            self.island_of[r] = self.island_of[root];
        }
        self.islands = parent;
        count as usize
    }

    /// Empties a pooled island solver, keeping its buffers.
    pub(super) fn clear_bodies(&mut self) {
        macro_rules! clear {
            ($($f:ident),*) => { $( self.$f.clear(); )* };
        }
        per_body!(clear);
        clear!(
            owner,
            attach,
            ragdoll_of,
            ragdolls,
            joints,
            pins,
            compounds,
            skin,
            seam_holder
        );
        self.collide.pairs.clear();
        self.collide.wait.clear();
        self.collide.closing.clear();
    }

    /// Copies each island's ragdolls, joints, pins and pairs into its solver, with body
    /// indices renumbered from 0 in each; the bodies a ragdoll's frozen joints link become
    /// one compound body there (`freeze.rs`).
    fn gather(&mut self, subs: &mut [FastBackend], first: &[usize], seams: &mut [Seam], dt: f32) {
        let mut local = std::mem::take(&mut self.local_of);
        local.clear();
        local.resize(self.world_shapes(), u32::MAX);
        for r in 0..self.ragdolls.len() {
            let solver = self.solver_of[r];
            if solver == NO_ISLAND {
                continue;
            }
            let sub = &mut subs[solver as usize];
            let first = sub.pos.len();
            if self.ragdolls[r].frozen == 0 {
                for i in self.ragdolls[r].bodies.clone() {
                    sub.push_body_of(self, i, sub.ragdolls.len());
                    local[i] = sub.shape.len() as u32 - 1;
                    self.push_extras_of(i, sub, sub.pos.len() - 1, None, &mut local);
                }
            } else {
                self.gather_compounds(r, sub, &mut local);
            }
            sub.ragdolls.push(Ragdoll {
                bodies: first..sub.pos.len(),
                ..self.ragdolls[r].clone()
            });
            for j in self.ragdolls[r].joints.clone() {
                if self.joints[j].frozen {
                    continue;
                }
                let mut joint = self.joints[j].clone();
                (joint.a, joint.frame_a) = sub.on_owner(local[joint.a], joint.frame_a);
                (joint.b, joint.frame_b) = sub.on_owner(local[joint.b], joint.frame_b);
                sub.joints.push(joint);
            }
        }
        for p in self.pins.iter().filter(|p| p.active) {
            let solver = self.solver_of[self.ragdoll_of[p.body]];
            if solver != NO_ISLAND {
                let sub = &mut subs[solver as usize];
                let (body, at) =
                    sub.on_owner(local[p.body], Transform::new(p.local, glam::Quat::IDENTITY));
                sub.pins.push(Pin {
                    body,
                    local: at.translation,
                    ..*p
                });
            }
        }
        // The seam of each island cut in two, by its first solver.
        let mut seam_of = vec![0; subs.len()];
        let cut = first.windows(2).filter(|w| w[1] - w[0] > 1);
        for (k, w) in cut.enumerate() {
            seam_of[w[0]] = k;
        }
        for &(i, j) in &self.collide.pairs {
            let si = self.solver_of[self.ragdoll_of[self.body_of_shape(i as usize)]];
            let sj = self.solver_of[self.ragdoll_of[self.body_of_shape(j as usize)]];
            if si == NO_ISLAND || sj == NO_ISLAND {
                continue;
            }
            let (li, lj) = (local[i as usize], local[j as usize]);
            if si == sj {
                subs[si as usize].collide.pairs.push((li, lj));
                continue;
            }
            // Two halves of one island: the lower-numbered half is the first.
            let low = si.min(sj);
            let (pi, pj) = (si - low, sj - low);
            seams[seam_of[low as usize]].pairs.push([pi, li, pj, lj]);
        }
        self.gather_skin(subs, &local, dt);
        self.local_of = local;
    }

    /// Adds body `i` of `world` (the whole world's solver) to this island's solver as it
    /// is, with its shape, in the island's ragdoll `ragdoll`.
    pub(super) fn push_body_of(&mut self, world: &FastBackend, i: usize, ragdoll: usize) {
        macro_rules! copy {
            ($($f:ident),*) => { $( self.$f.push(world.$f[i]); )* };
        }
        per_body!(copy);
        self.owner.push(self.pos.len() as u32 - 1);
        self.attach.push(None);
        self.ragdoll_of.push(ragdoll);
    }

    /// The body that carries shape `c` and `frame` (in the shape's body's frame) in that
    /// body's frame.
    pub(super) fn on_owner(&self, c: u32, frame: Transform) -> (usize, Transform) {
        let c = c as usize;
        let frame = match self.attach[c] {
            Some(t) => t.mul(&frame),
            None => frame,
        };
        (self.owner[c] as usize, frame)
    }

    /// Copies the islands' bodies back, with what their contacts saw.
    fn scatter(&mut self, subs: &[FastBackend], dt: f32) {
        for r in 0..self.ragdolls.len() {
            let solver = self.solver_of[r];
            if solver == NO_ISLAND {
                continue;
            }
            let sub = &subs[solver as usize];
            for i in self.ragdolls[r].bodies.clone() {
                let c = self.local_of[i] as usize;
                self.collide.touching[i] = sub.collide.touching[c]
                    || self.extras.of.get(i).is_some_and(|e| {
                        e.clone().any(|e| {
                            let k = self.local_of[self.pos.len() + e as usize] as usize;
                            sub.collide.touching[k]
                        })
                    });
                if sub.attach[c].is_some() {
                    self.part_from_compound(i, sub, c, dt);
                    continue;
                }
                let l = sub.owner[c] as usize;
                macro_rules! back {
                    ($($f:ident),*) => { $( self.$f[i] = sub.$f[l]; )* };
                }
                back!(
                    pos,
                    rot,
                    vel,
                    angvel,
                    seen_vel,
                    seen_angvel,
                    inv_inertia_world
                );
            }
            let k = sub.ragdoll_of
                [sub.owner[self.local_of[self.ragdolls[r].bodies.start] as usize] as usize];
            self.ragdolls[r].jolted |= sub.ragdolls[k].jolted;
            self.ragdolls[r].tests = sub.collide.tests.get(k).copied().unwrap_or(0);
        }
        for sub in subs {
            self.collide.max_penetration = self
                .collide
                .max_penetration
                .max(sub.collide.max_penetration);
        }
    }
}
