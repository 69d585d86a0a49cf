//! The engine services the fast engine shares with `rigid`, over its own bodies: the
//! end-of-step limit projection ([`LimitProjection`](crate::backend::limits::LimitProjection))
//! and passive joint damping ([`JointDamping`](crate::backend::damping::JointDamping)).

use super::FastBackend;
use crate::backend::limits::BodyRole;
use crate::backend::{Backend, BodyId, Command, OneAtATime, apply_each};
use crate::math::Transform;

impl FastBackend {
    /// Gives every damped ragdoll's joints their couples for a step of `h`, from the
    /// velocities the world sees (the step's average motion).
    pub(super) fn damp_joints(&mut self, h: f32) {
        if !self.damping.is_on() {
            return;
        }
        let mut states = Vec::new();
        self.body_states(&mut states);
        let mut impulses = Vec::new();
        let kinematic = &self.kinematic;
        let dynamic = |b: usize| kinematic[b].is_none();
        self.damping.impulses(&states, dynamic, h, &mut impulses);
        let commands: Vec<Command> = impulses.into_iter().map(Command::Impulse).collect();
        apply_each(self, &commands);
    }

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
