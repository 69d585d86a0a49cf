//! Sleeping by islands: ragdolls that may touch (this step's candidate pairs link them)
//! sleep together, once every one of them has been slow for [`SLEEP_AFTER_S`].
//!
//! One at a time does not work in a pile: the first ragdoll to fall asleep overlaps an
//! awake neighbour, which wakes it again at the next step, and the pile never rests.

use glam::Vec3;

use super::{FastBackend, SLEEP_AFTER_S, SLEEP_SPEED_MPS};

/// The root of `r`'s set, halving the path on the way.
pub(super) fn find(parent: &mut [usize], mut r: usize) -> usize {
    while parent[r] != r {
        parent[r] = parent[parent[r]];
        r = parent[r];
    }
    r
}

impl FastBackend {
    /// Whether every point of ragdoll `r` moved slower than [`SLEEP_SPEED_MPS`] over the
    /// last step.
    fn ragdoll_slow(&self, r: usize) -> bool {
        self.ragdolls[r].bodies.clone().all(|i| {
            let reach = super::contact::reach(&self.shape[i]);
            let v = self.seen_vel[i].length() + self.seen_angvel[i].length() * reach;
            v < SLEEP_SPEED_MPS
        })
    }

    /// Counts how long each awake ragdoll has been slow, then puts to sleep every island
    /// whose ragdolls have all been slow long enough, with no velocity left.
    pub(super) fn update_sleep(&mut self, dt: f32) {
        let n = self.ragdolls.len();
        for r in 0..n {
            if self.ragdolls[r].asleep {
                continue;
            }
            let still = !self.ragdolls[r].held && self.ragdoll_slow(r);
            let rd = &mut self.ragdolls[r];
            rd.still_s = if still { rd.still_s + dt } else { 0.0 };
        }
        let mut parent = std::mem::take(&mut self.islands);
        parent.clear();
        parent.extend(0..n);
        for &(i, j) in &self.collide.pairs {
            let (ri, rj) = (self.ragdoll_of[i as usize], self.ragdoll_of[j as usize]);
            if ri != rj && !self.ragdolls[ri].asleep && !self.ragdolls[rj].asleep {
                let (a, b) = (find(&mut parent, ri), find(&mut parent, rj));
                parent[a.max(b)] = a.min(b);
            }
        }
        // An island is ready when none of its ragdolls is not.
        let mut ready = std::mem::take(&mut self.island_ready);
        ready.clear();
        ready.resize(n, true);
        for r in 0..n {
            if !self.ragdolls[r].asleep && self.ragdolls[r].still_s < SLEEP_AFTER_S {
                let root = find(&mut parent, r);
                ready[root] = false;
            }
        }
        for r in 0..n {
            if self.ragdolls[r].asleep || !ready[find(&mut parent, r)] {
                continue;
            }
            self.ragdolls[r].asleep = true;
            for i in self.ragdolls[r].bodies.clone() {
                self.vel[i] = Vec3::ZERO;
                self.angvel[i] = Vec3::ZERO;
                self.seen_vel[i] = Vec3::ZERO;
                self.seen_angvel[i] = Vec3::ZERO;
            }
        }
        self.islands = parent;
        self.island_ready = ready;
    }
}
