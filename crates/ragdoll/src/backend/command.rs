//! What the world asks of an engine between two steps, as data: one [`Command`] per
//! change, handed over in order in one call ([`Backend::apply`](super::Backend::apply)).
//!
//! One call per batch rather than one trait method per change keeps the seam narrow (a
//! new kind of change is a variant, not a method every engine must grow) and lets an
//! engine that keeps its bodies elsewhere (a GPU, another process) take a whole batch in
//! one transfer. Our engines apply the commands one by one, in the order given
//! ([`OneAtATime`]), so a batch means exactly what the same calls one at a time meant.

use glam::Vec3;

use super::{BodyId, BodyImpulse, JointId, PinId};
use crate::math::Transform;
use crate::spec::JointKind;

/// One change to an engine's bodies, joints or pins, applied before its next step.
///
/// Non-exhaustive: a later release may add kinds of change, which an engine that does not
/// know them may pass over (its `match` needs a wildcard arm).
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum Command {
    /// An impulse of the world's events, motors or damping, waking the body.
    Impulse(BodyImpulse),
    /// Makes a body kinematic (moved only by [`Command::KinematicTarget`]) or dynamic
    /// again.
    Kinematic {
        /// The body.
        body: BodyId,
        /// Kinematic (true) or dynamic (false).
        kinematic: bool,
    },
    /// Where a kinematic body must be at the end of the next step.
    KinematicTarget {
        /// The body.
        body: BodyId,
        /// Its pose then, world.
        pose: Transform,
    },
    /// Sets a body's linear (m/s) and angular (rad/s) velocity.
    Velocity {
        /// The body.
        body: BodyId,
        /// m/s, world.
        linvel: Vec3,
        /// rad/s, world.
        angvel: Vec3,
    },
    /// Moves a body to a pose without changing its velocities.
    Pose {
        /// The body.
        body: BodyId,
        /// Its new pose, world.
        pose: Transform,
    },
    /// Replaces a joint's parent-side frame, in the parent body's frame.
    JointParentFrame {
        /// The joint.
        joint: JointId,
        /// The frame.
        frame: Transform,
    },
    /// Replaces a joint's child-side frame, in the child body's frame.
    JointChildFrame {
        /// The joint.
        joint: JointId,
        /// The frame.
        frame: Transform,
    },
    /// Replaces a joint's limits with those of a joint of the same kind.
    JointLimits {
        /// The joint.
        joint: JointId,
        /// Its kind, with the new limits.
        kind: JointKind,
    },
    /// How many solver substeps each step takes, where the engine has them: powered
    /// ragdolls need stiffer drives than limp ones, and a drive must stay well below the
    /// substep rate to be stable. Engines without solver substeps ignore it.
    SolverSubsteps(usize),
    /// The gravity acting on every body, m/s².
    Gravity(Vec3),
    /// Where a pin's anchor must be at the end of the next step, world.
    MovePin {
        /// The pin.
        pin: PinId,
        /// Its anchor then.
        target: Vec3,
    },
    /// Lets go of a pin.
    ReleasePin(PinId),
    /// Stops two bodies from colliding with each other.
    DisablePair(BodyId, BodyId),
    /// How fast the joints of the ragdoll whose first body is `first_body` lose their
    /// relative spin, per second (0: not at all): passive joint damping, the losses of
    /// real joints (see [`super::damping`]). The world sends its setting for each ragdoll
    /// it adds, and 0 for one its motors power.
    JointDamping {
        /// The ragdoll's first body.
        first_body: BodyId,
        /// Per second.
        rate_per_s: f32,
    },
}

/// The commands one at a time: how our engines take a batch. Each method is one
/// [`Command`] variant; [`apply_each`] calls them in the batch's order.
pub(crate) trait OneAtATime {
    fn apply_impulse_at_point(&mut self, body: BodyId, impulse: Vec3, point: Vec3);
    fn apply_torque_impulse(&mut self, body: BodyId, impulse: Vec3);
    fn set_kinematic(&mut self, body: BodyId, kinematic: bool);
    fn set_kinematic_target(&mut self, body: BodyId, pose: &Transform);
    fn set_body_velocity(&mut self, body: BodyId, linvel: Vec3, angvel: Vec3);
    fn set_body_pose(&mut self, body: BodyId, pose: &Transform);
    fn set_joint_parent_frame(&mut self, joint: JointId, frame: &Transform);
    fn set_joint_child_frame(&mut self, joint: JointId, frame: &Transform);
    fn set_joint_limits(&mut self, joint: JointId, kind: &JointKind);
    fn set_solver_substeps(&mut self, substeps: usize);
    fn set_gravity(&mut self, gravity: Vec3);
    fn move_pin(&mut self, pin: PinId, target: Vec3);
    fn release_pin(&mut self, pin: PinId);
    fn disable_pair(&mut self, a: BodyId, b: BodyId);
    /// Engines without joint damping pass over it.
    fn set_joint_damping(&mut self, _first_body: BodyId, _rate_per_s: f32) {}
}

/// Applies `commands` to `engine` one at a time, in order.
pub(crate) fn apply_each(engine: &mut impl OneAtATime, commands: &[Command]) {
    for command in commands {
        match *command {
            Command::Impulse(BodyImpulse::AtPoint {
                body,
                impulse,
                point,
            }) => engine.apply_impulse_at_point(body, impulse, point),
            Command::Impulse(BodyImpulse::Angular { body, impulse }) => {
                engine.apply_torque_impulse(body, impulse)
            }
            Command::Kinematic { body, kinematic } => engine.set_kinematic(body, kinematic),
            Command::KinematicTarget { body, ref pose } => engine.set_kinematic_target(body, pose),
            Command::Velocity {
                body,
                linvel,
                angvel,
            } => engine.set_body_velocity(body, linvel, angvel),
            Command::Pose { body, ref pose } => engine.set_body_pose(body, pose),
            Command::JointParentFrame { joint, ref frame } => {
                engine.set_joint_parent_frame(joint, frame)
            }
            Command::JointChildFrame { joint, ref frame } => {
                engine.set_joint_child_frame(joint, frame)
            }
            Command::JointLimits { joint, ref kind } => engine.set_joint_limits(joint, kind),
            Command::SolverSubsteps(n) => engine.set_solver_substeps(n),
            Command::Gravity(g) => engine.set_gravity(g),
            Command::MovePin { pin, target } => engine.move_pin(pin, target),
            Command::ReleasePin(pin) => engine.release_pin(pin),
            Command::DisablePair(a, b) => engine.disable_pair(a, b),
            Command::JointDamping {
                first_body,
                rate_per_s,
            } => engine.set_joint_damping(first_body, rate_per_s),
        }
    }
}
