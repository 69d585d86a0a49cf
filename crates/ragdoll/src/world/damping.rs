//! Passive joint damping: the losses of real joints (tissue, tendons, friction), which
//! rapier and the particle solver do not have.
//!
//! Without them a limp part that hangs free (a creature's raised head, a tail over a
//! ledge, an arm off a table) swings as an undamped pendulum for as long as the run lasts,
//! and a pile of bodies resting on their joint limits creeps. Each joint gets a viscous
//! couple against the relative angular velocity of its two bodies, equal and opposite on
//! them, so it takes energy out and leaves linear and angular momentum as they are.
//!
//! Off by default and refused on the particle backend (`WorldSettings::validate`): there
//! the couple acted on velocities a substep old and fed energy in.

use crate::backend::BodyId;
use crate::backend::BodyImpulse;
use glam::Vec3;

use super::World;
use super::motors::{effective_inertia, inertia_about, principal_inertia};
use crate::spec::JointKind;

impl World {
    /// Applies every limp ragdoll's joint damping over the substep `h` (the step calls it
    /// only when the damping is on).
    ///
    /// The couple is sized, like the motors, by the two bodies' inertia about the joint
    /// along the relative spin, so a limb swinging from a still body (a pendulum) loses
    /// relative speed at [`super::WorldSettings::joint_damping`] per second: its swing's
    /// amplitude decays as `exp(-c t / 2)`. The velocity it acts on is the one at the end
    /// of the substep (implicit), so the couple never reverses a joint's motion whatever
    /// the rate. Powered ragdolls are left to their motors, which damp on their own.
    pub(super) fn apply_joint_damping(&mut self, h: f32) {
        let c = self.settings.joint_damping;
        let share = c * h / (1.0 + c * h);
        for inst in &self.instances {
            if !inst.active || inst.removed || inst.motors.is_some() {
                continue;
            }
            let base = inst.first_body;
            let states = &self.states[base..base + inst.shapes.len()];
            for j in &inst.joints {
                if matches!(j.kind, JointKind::Fixed) {
                    continue;
                }
                let (parent, child) = (&states[j.parent], &states[j.child]);
                let relative = child.angvel - parent.angvel;
                let Some(n) = relative.try_normalize() else {
                    continue;
                };
                let anchor = child.pose.transform_point(j.frame_child.translation);
                let about = |b: usize| {
                    // The body's inertia with its extra shapes' skin, as the backends
                    // have it.
                    let own = if inst.extras[b].is_empty() {
                        principal_inertia(&inst.shapes[b], inst.masses[b])
                    } else {
                        let (shape, extras) = (&inst.shapes[b], &inst.extras[b]);
                        crate::geometry::body_inertia(shape, extras, inst.masses[b]).diagonal()
                    };
                    inertia_about(&states[b].pose, own, inst.masses[b], anchor, n)
                };
                let inertia = effective_inertia(about(j.child), Some(about(j.parent)));
                let impulse: Vec3 = -relative * (share * inertia);
                if impulse.is_finite() {
                    self.impulses.extend(BodyImpulse::joint_pair(
                        BodyId(base + j.child),
                        BodyId(base + j.parent),
                        impulse,
                    ));
                }
            }
        }
    }
}
