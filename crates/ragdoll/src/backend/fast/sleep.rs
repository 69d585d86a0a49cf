//! Sleeping by islands: ragdolls that may touch (this step's candidate pairs link them)
//! sleep together, once every one of them has stayed where it was (within
//! [`SLEEP_DRIFT_M`]) for [`SLEEP_AFTER_S`].
//!
//! One at a time does not work in a pile: the first ragdoll to fall asleep overlaps an
//! awake neighbour, which wakes it again at the next step, and the pile never rests.

use glam::Vec3;

use super::island::NO_ISLAND;
use super::{FastBackend, SLEEP_AFTER_S, SLEEP_DRIFT_M};

impl FastBackend {
    /// Whether every point of ragdoll `r`'s bodies is still within [`SLEEP_DRIFT_M`] of
    /// where it was when the quiet spell began: a body's centre moved by less than the
    /// drift less its turn's sweep at its farthest point.
    fn ragdoll_near_rest(&self, r: usize) -> bool {
        self.ragdolls[r].bodies.clone().all(|i| {
            let reach = self.body_reach(i);
            let turn = self.rot[i] * self.rest_rot[i].conjugate();
            // |xyz| = sin(angle / 2); the chord a point at `reach` sweeps is
            // 2 reach sin(angle / 2).
            let sweep = 2.0 * reach * Vec3::new(turn.x, turn.y, turn.z).length();
            (self.pos[i] - self.rest_pos[i]).length() + sweep < SLEEP_DRIFT_M
        })
    }

    /// Starts ragdoll `r`'s quiet spell from its bodies' poses now.
    fn begin_rest(&mut self, r: usize) {
        for i in self.ragdolls[r].bodies.clone() {
            self.rest_pos[i] = self.pos[i];
            self.rest_rot[i] = self.rot[i];
        }
        self.ragdolls[r].still_s = Some(0.0);
    }

    /// Times each awake ragdoll's quiet spell, then puts to sleep every island whose
    /// ragdolls have all been quiet long enough, with no velocity left.
    pub(super) fn update_sleep(&mut self, dt: f32) {
        let n = self.ragdolls.len();
        for r in 0..n {
            let rd = &self.ragdolls[r];
            if rd.asleep {
                continue;
            }
            if rd.held {
                self.ragdolls[r].still_s = None;
                continue;
            }
            match rd.still_s {
                Some(t) if self.ragdoll_near_rest(r) => self.ragdolls[r].still_s = Some(t + dt),
                _ => self.begin_rest(r),
            }
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
            if island != NO_ISLAND && self.ragdolls[r].still_s.is_none_or(|t| t < SLEEP_AFTER_S) {
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
