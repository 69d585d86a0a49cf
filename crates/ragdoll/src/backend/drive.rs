//! Joint drives as torques, an engine service for an engine whose solver has no drives of
//! its own (`particle`): each driven joint gets a torque impulse between its two bodies
//! each step, toward the drive's target rotation and spin.
//!
//! A torque reaches only the joint's two bodies within a step (the joints below pass it
//! on only through their own drives, a step later), so it cannot be as stiff as a drive
//! inside a solver, which sees the whole chain at once: these drives run at
//! [`TORQUE_FREQUENCY_SHARE`] of the frequency asked for, the share they were measured
//! stable at, with the same damping ratio.

use glam::{Quat, Vec3};

use super::ragdolls::Ragdolls;
use super::{BodyDesc, BodyId, BodyImpulse, BodyState, JointDesc, JointId};
use crate::geometry::shapes::{effective_inertia, inertia_about, principal_inertia};
use crate::math::Transform;

/// The share of a drive's natural frequency a torque drive runs at: the powered ragdoll's
/// 120 Hz solver drives ran stable as torques at 15 Hz on the particle engine.
pub const TORQUE_FREQUENCY_SHARE: f32 = 15.0 / 120.0;

/// What a joint is driven toward, and how hard (see [`super::Backend::drive_joint`]).
#[derive(Clone, Copy, Debug)]
struct Drive {
    target: Quat,
    target_angvel: Vec3,
    stiffness: f32,
    damping: f32,
}

/// One ragdoll's joints and bodies as the drives see them.
#[derive(Clone, Debug)]
struct Driven {
    /// Each joint: parent, child, the anchor in the child's frame, and its drive.
    joints: Vec<(usize, usize, Vec3, Option<Drive>)>,
    /// Each body's principal moments about its centre, and its mass.
    inertia: Vec<(Vec3, f32)>,
}

/// The torque drives of every ragdoll an engine holds, in the order added.
#[derive(Clone, Debug, Default)]
pub struct TorqueDrives {
    ragdolls: Ragdolls<Driven>,
}

impl TorqueDrives {
    /// Takes in a ragdoll whose first body has the engine's index `first_body`, undriven.
    pub fn add_ragdoll(&mut self, first_body: usize, bodies: &[BodyDesc], joints: &[JointDesc]) {
        let driven = Driven {
            joints: joints
                .iter()
                .map(|j| (j.parent, j.child, j.frame_child.translation, None))
                .collect(),
            inertia: bodies
                .iter()
                .map(|b| (principal_inertia(&b.shape, b.mass), b.mass))
                .collect(),
        };
        self.ragdolls.add(first_body, joints.len(), driven);
    }

    /// Leaves out the ragdoll whose first body is `first_body` from now on.
    pub fn remove_ragdoll(&mut self, first_body: usize) {
        self.ragdolls.remove(first_body);
    }

    /// A joint's new frame in its child body (its anchor moves with it).
    pub fn set_child_frame(&mut self, joint: JointId, frame: &Transform) {
        if let Some((r, k)) = self.ragdolls.joint_mut(joint) {
            r.joints[k].2 = frame.translation;
        }
    }

    /// Drives `joint` as [`super::Backend::drive_joint`] says (no gains remove the drive).
    pub fn set(
        &mut self,
        joint: JointId,
        target: Quat,
        target_angvel: Vec3,
        stiffness: f32,
        damping: f32,
    ) {
        let Some((r, k)) = self.ragdolls.joint_mut(joint) else {
            return;
        };
        let off = stiffness <= 0.0 && damping <= 0.0;
        r.joints[k].3 = (!off).then_some(Drive {
            target,
            target_angvel,
            stiffness,
            damping,
        });
    }

    /// Whether any joint is driven.
    pub fn is_on(&self) -> bool {
        self.ragdolls
            .live()
            .any(|r| r.joints.iter().any(|j| j.3.is_some()))
    }

    /// The torque impulses of every drive over a step of `h` seconds, from the bodies'
    /// `states`, appended to `out`; `kinematic(body)` says which bodies are held on their
    /// clip (a root kept there), whose side of a joint the drive does not turn.
    ///
    /// Implicit ("stable") PD: the damping and the spring act on the velocity at the end
    /// of the step, so the spring cannot overshoot within one step whatever the gains; an
    /// error in the inertia estimate only changes how fast a joint gets there.
    pub fn impulses(
        &self,
        states: &[BodyState],
        kinematic: impl Fn(usize) -> bool,
        h: f32,
        out: &mut Vec<BodyImpulse>,
    ) {
        let f = TORQUE_FREQUENCY_SHARE;
        for r in self.ragdolls.live() {
            let base = r.first_body;
            let states = &states[base..base + r.inertia.len()];
            for &(p, c, anchor_in_child, drive) in &r.joints {
                let Some(d) = drive else {
                    continue;
                };
                let (kp, kd) = (d.stiffness * f * f, d.damping * f);
                let (parent, child) = (&states[p], &states[c]);
                // Where the child should be turned, the parent where it is, and the
                // target's spin turned from the parent's frame into the world.
                let wanted = parent.pose.rotation * d.target;
                let theta = rotation_vector(wanted * child.pose.rotation.conjugate());
                let target_rel = parent.pose.rotation * d.target_angvel;
                let error_velocity = child.angvel - parent.angvel - target_rel;
                let anchor = child.pose.transform_point(anchor_in_child);
                let accel =
                    (theta * kp - error_velocity * (kd + h * kp)) / (1.0 + h * kd + h * h * kp);
                let Some(n) = accel.try_normalize() else {
                    continue;
                };
                let about = |b: usize| {
                    let (own, mass) = r.inertia[b];
                    inertia_about(&states[b].pose, own, mass, anchor, n)
                };
                let held = kinematic(base + p);
                let inertia = effective_inertia(about(c), (!held).then(|| about(p)));
                let impulse = accel * inertia * h;
                if impulse.is_finite() {
                    out.extend(BodyImpulse::joint_pair(
                        BodyId(base + c),
                        BodyId(base + p),
                        impulse,
                    ));
                }
            }
        }
    }
}

/// Turns rotation `q` into a rotation vector (axis · angle, radians), the short way round.
fn rotation_vector(mut q: Quat) -> Vec3 {
    if q.w < 0.0 {
        q = -q;
    }
    let (axis, angle) = q.normalize().to_axis_angle();
    let v = axis * angle;
    if v.is_finite() { v } else { Vec3::ZERO }
}
