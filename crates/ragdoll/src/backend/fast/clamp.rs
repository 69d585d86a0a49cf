//! The end-of-step limit projection on the fast engine: the shared
//! [`LimitProjection`](crate::backend::limits::LimitProjection) over this engine's bodies.

use super::FastBackend;
use crate::backend::limits::BodyRole;
use crate::backend::{BodyId, OneAtATime};
use crate::math::Transform;

impl FastBackend {
    /// Turns every joint the substeps left past its limits back inside them; returns the
    /// worst violation before, radians (`None` when the projection is off).
    pub(super) fn project_limits(&mut self) -> Option<f32> {
        let limits = self.limits.as_ref()?;
        let mut poses: Vec<Transform> = (0..self.pos.len())
            .map(|i| Transform::new(self.pos[i], self.rot[i]))
            .collect();
        // A kinematic body of a ragdoll that is otherwise physical is a root kept on its
        // clip: held, as a pinned body is.
        let mut roles: Vec<BodyRole> = self
            .kinematic
            .iter()
            .map(|k| BodyRole {
                dynamic: k.is_none(),
                held: k.is_some(),
            })
            .collect();
        for p in self.pins.iter().filter(|p| p.active) {
            if let Some(r) = roles.get_mut(p.body) {
                r.held = true;
            }
        }
        let before = limits.worst_violation(&poses, &roles);
        let moved = limits.project(&mut poses, &roles, self.settings.ground);
        for b in moved {
            self.set_body_pose(BodyId(b), &poses[b]);
        }
        Some(before)
    }
}
