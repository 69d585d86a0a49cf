//! Impacts ahead: how fast each ragdoll may strike the ground or another body in the
//! coming step. A ragdoll about to strike faster than [`IMPACT_MPS`] has its island take
//! [`crate::backend::FastConfig::impact_passes`] more passes this step; one about to strike
//! at all thaws (`freeze.rs`).
//!
//! An impact is where one pass a substep falls short: a light part struck by the ground
//! or a falling body takes a blow the joints behind it have to hand on to the rest of the
//! ragdoll, and a pass hands it one link along. Impacts are brief, so most steps keep
//! one pass (the numbers are at [`crate::world::DEFAULT_FAST_IMPACT_PASSES`]).

use super::FastBackend;

/// Closing speed from which a touch ahead is an impact that takes more passes, m/s: a
/// fall from 20 cm. Measured on twelve piles of four dropped for 4 s with two passes
/// added: from 0.5 m/s or 1 m/s the worst joint gaps and limits came out no better (4.6
/// and 5.5 mm, 1.1° and 1.3°, against 4.6 mm and 0.9° from 2 m/s) for 1.5 and 1.3 times
/// the time; from 3 m/s contacts sank 12 mm deep, as with no passes added (5-7 mm from
/// 2 m/s): the deepest landings close at 2-3 m/s.
pub(super) const IMPACT_MPS: f32 = 2.0;

impl FastBackend {
    /// Sets each ragdoll's `closing_mps`: the fastest any of its parts may close on the
    /// ground (falling, with the ground within its reach this step) or on the other body
    /// of a candidate pair (their relative speed), 0 when nothing is within reach. Runs
    /// after [`FastBackend::find_pairs`], whose boxes it reads.
    pub(super) fn find_closing(&mut self) {
        for r in &mut self.ragdolls {
            r.closing_mps = 0.0;
        }
        if let Some(g) = self.settings.ground {
            // Every shape of the world, the extra ones after the bodies' own.
            for k in 0..self.world_shapes() {
                let i = self.body_of_shape(k);
                let r = self.ragdoll_of[i];
                let falling = -self.vel[i].y;
                if falling <= self.ragdolls[r].closing_mps {
                    continue;
                }
                // The broad phase's box of this step, grown by how far it may travel.
                if self.collide.boxes[k].0.y < g {
                    self.ragdolls[r].closing_mps = falling;
                }
            }
        }
        for k in 0..self.collide.pairs.len() {
            let (a, b) = self.collide.pairs[k];
            let (i, j) = (
                self.body_of_shape(a as usize),
                self.body_of_shape(b as usize),
            );
            let speed = (self.vel[i] - self.vel[j]).length();
            for r in [self.ragdoll_of[i], self.ragdoll_of[j]] {
                let c = &mut self.ragdolls[r].closing_mps;
                *c = c.max(speed);
            }
        }
    }
}
