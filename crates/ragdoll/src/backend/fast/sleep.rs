//! Sleeping by islands: ragdolls that may touch (this step's candidate pairs link them)
//! sleep together, once every one of them has been slow for [`SLEEP_AFTER_S`].
//!
//! One at a time does not work in a pile: the first ragdoll to fall asleep overlaps an
//! awake neighbour, which wakes it again at the next step, and the pile never rests.

use glam::Vec3;

use super::island::NO_ISLAND;
use super::{FastBackend, SLEEP_AFTER_S, SLEEP_SPEED_MPS};

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
        // The islands of this step ([`FastBackend::step_islands`] numbered them): an island
        // is ready when none of its ragdolls is not.
        let islands = self.island_of.iter().filter(|&&k| k != NO_ISLAND);
        let count = islands.map(|&k| k as usize + 1).max().unwrap_or(0);
        let mut ready = std::mem::take(&mut self.island_ready);
        ready.clear();
        ready.resize(count, true);
        for r in 0..n {
            let island = self.island_of.get(r).copied().unwrap_or(NO_ISLAND);
            if island != NO_ISLAND && self.ragdolls[r].still_s < SLEEP_AFTER_S {
                ready[island as usize] = false;
            }
        }
        for r in 0..n {
            let island = self.island_of.get(r).copied().unwrap_or(NO_ISLAND);
            if island == NO_ISLAND || !ready[island as usize] {
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
        self.island_ready = ready;
    }
}
