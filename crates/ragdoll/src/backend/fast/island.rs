//! Stepping by islands: the awake ragdolls that may touch (this step's candidate pairs
//! link them) are copied into a solver of their own, the islands are solved in parallel
//! (rayon), and their bodies copied back.
//!
//! Islands share nothing while they are solved, so each comes out the same whatever the
//! number of threads or the order they run in: a rerun is bit-identical. The copies cost
//! a few dozen values per body per step, against the solver's hundreds per substep.

use rayon::prelude::*;

use super::{FastBackend, Pin, Ragdoll};
use crate::math::Transform;

/// Calls the macro `$m` with every array of the solver that holds one entry per body of
/// the world (per body or shape in an island's solver), so clearing and copying a body
/// name them in one place.
macro_rules! per_body {
    ($m:ident) => {
        $m!(
            pos,
            rot,
            prev_pos,
            prev_rot,
            moved,
            pred_rot,
            vel,
            angvel,
            step_pos,
            step_rot,
            seen_vel,
            seen_angvel,
            mass,
            inv_mass,
            inertia,
            inv_inertia,
            inv_inertia_world,
            shape,
            holder,
            kinematic
        )
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
        let mut subs = std::mem::take(&mut self.island_pool);
        while subs.len() < count {
            subs.push(FastBackend::with_settings(self.settings));
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
        for ((sub, f), hit) in subs[..count].iter_mut().zip(&factor).zip(&impact) {
            sub.settings = self.settings;
            sub.settings.substeps = (self.settings.substeps as f32 * f).ceil() as usize;
            if *hit {
                sub.settings.iterations = self.settings.iterations + self.settings.impact_passes;
            }
            sub.clear_bodies();
        }
        self.gather(&mut subs[..count], dt);
        subs[..count]
            .par_iter_mut()
            .for_each(|sub| sub.solve_step(dt));
        self.scatter(&subs[..count], dt);
        self.island_pool = subs;
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
    fn clear_bodies(&mut self) {
        macro_rules! clear {
            ($($f:ident),*) => { $( self.$f.clear(); )* };
        }
        per_body!(clear);
        clear!(
            owner, attach, ragdoll_of, ragdolls, joints, pins, compounds, skin
        );
        self.collide.pairs.clear();
        self.collide.wait.clear();
        self.collide.closing.clear();
    }

    /// Copies each island's ragdolls, joints, pins and pairs into its solver, with body
    /// indices renumbered from 0 in each; the bodies a ragdoll's frozen joints link become
    /// one compound body there (`freeze.rs`).
    fn gather(&mut self, subs: &mut [FastBackend], dt: f32) {
        let mut local = std::mem::take(&mut self.local_of);
        local.clear();
        local.resize(self.world_shapes(), u32::MAX);
        for r in 0..self.ragdolls.len() {
            let island = self.island_of[r];
            if island == NO_ISLAND {
                continue;
            }
            let sub = &mut subs[island as usize];
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
            let island = self.island_of[self.ragdoll_of[p.body]];
            if island != NO_ISLAND {
                let sub = &mut subs[island as usize];
                let (body, at) =
                    sub.on_owner(local[p.body], Transform::new(p.local, glam::Quat::IDENTITY));
                sub.pins.push(Pin {
                    body,
                    local: at.translation,
                    ..*p
                });
            }
        }
        for &(i, j) in &self.collide.pairs {
            let island = self.island_of[self.ragdoll_of[self.body_of_shape(i as usize)]];
            if island != NO_ISLAND {
                subs[island as usize]
                    .collide
                    .pairs
                    .push((local[i as usize], local[j as usize]));
            }
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
            let island = self.island_of[r];
            if island == NO_ISLAND {
                continue;
            }
            let sub = &subs[island as usize];
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
        }
        for sub in subs {
            self.collide.max_penetration = self
                .collide
                .max_penetration
                .max(sub.collide.max_penetration);
        }
    }
}
