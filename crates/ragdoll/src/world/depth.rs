//! How deep bodies lie in each other and in the ground now, measured from the shapes
//! themselves with parry's exact contact queries, not read from any backend's contacts.
//!
//! A backend reports the deepest contact its own solver saw
//! ([`crate::track::Metrics::max_penetration_m`]), which mixes impacts with rest and
//! trusts the solver's narrow phase; a sleeping island reports none at all. This reading
//! asks the geometry alone, in whatever poses the bodies are in, so it can be taken
//! after a pile has settled (the target: 1 cm at rest, 3 cm in impacts) and
//! compared across backends.

use super::World;
use crate::geometry::broad::BroadPhase;
use crate::geometry::depth::{depth_between, solid};
use crate::geometry::loose_bounds;

impl World {
    /// The deepest overlap in the current poses, metres (0 when nothing overlaps): of any
    /// body below the ground, and between any two bodies that collide (of two ragdolls,
    /// or of one whose pair the spec, the start or a hand-over did not exempt), each body
    /// with its extra shapes (which meet the ground and other ragdolls only).
    ///
    /// ```
    /// use ragdoll::{skeleton::humanoid, spec, world::{World, WorldSettings}, math::Transform};
    ///
    /// let character = humanoid();
    /// let spec = spec::build_spec(&character, &spec::BuildOptions::default()).unwrap();
    /// let mut world = World::new(&WorldSettings::default()).unwrap();
    /// world.add_ragdoll(&character, &spec, Transform::IDENTITY).unwrap();
    /// // Standing on the ground as placed: nothing inside anything.
    /// assert!(world.overlap_now() < 1e-4);
    /// ```
    pub fn overlap_now(&self) -> f32 {
        let mut poses = Vec::new();
        let mut shapes = Vec::new();
        let mut solids = Vec::new();
        let mut owner = Vec::new();
        for (r, inst) in self.instances.iter().enumerate() {
            if inst.removed {
                continue;
            }
            for (b, shape) in inst.shapes.iter().enumerate() {
                let pose = self.states[inst.first_body + b].pose;
                let extras = inst.extras[b]
                    .iter()
                    .map(|(s, at)| (*s, pose.mul(at), true));
                for (shape, pose, extra) in std::iter::once((*shape, pose, false)).chain(extras) {
                    poses.push(pose);
                    shapes.push(shape);
                    solids.push(solid(&shape));
                    owner.push((r, b, extra));
                }
            }
        }
        let mut deepest = 0.0f32;
        if let Some(ground) = self.settings.ground {
            for (p, s) in poses.iter().zip(&shapes) {
                deepest = deepest.max(ground - s.lowest_y(p));
            }
        }
        let boxes: Vec<_> = poses
            .iter()
            .zip(&shapes)
            .map(|(p, s)| loose_bounds(p, s))
            .collect();
        BroadPhase::default().find(&boxes, |i, j| {
            let ((ri, bi, xi), (rj, bj, xj)) = (owner[i], owner[j]);
            // Extra shapes never meet their own ragdoll.
            if ri == rj && (xi || xj || self.instances[ri].exempt(bi, bj)) {
                return;
            }
            let depth = depth_between(&poses[i], &solids[i], &poses[j], &solids[j]);
            deepest = deepest.max(depth);
        });
        deepest
    }
}

impl super::Instance {
    /// Whether this ragdoll's bodies `a` and `b` do not collide.
    fn exempt(&self, a: usize, b: usize) -> bool {
        self.exempt_pairs
            .binary_search(&(a.min(b), a.max(b)))
            .is_ok()
    }
}
