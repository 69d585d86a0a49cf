//! Passive joint damping, an engine service: the losses of real joints (tissue, tendons,
//! friction), which rapier and our solvers do not have.
//!
//! Without them a limp part that hangs free (a creature's raised head, a tail over a
//! ledge, an arm off a table) swings as an undamped pendulum for as long as the run lasts,
//! and a pile of bodies resting on their joint limits creeps. Each joint gets a viscous
//! couple against the relative angular velocity of its two bodies, equal and opposite on
//! them, so it takes energy out and leaves linear and angular momentum as they are.
//! `rigid` and `fast` apply it at the start of each of their steps, at the rate the world
//! gives each ragdoll ([`super::Command::JointDamping`]: its setting, or none for a powered
//! ragdoll, which its motors damp).

use glam::Vec3;

use super::ragdolls::Ragdolls;
use super::{BodyDesc, BodyId, BodyImpulse, BodyState, JointDesc, JointId};
use crate::geometry::body_inertia;
use crate::geometry::shapes::{effective_inertia, inertia_about, principal_inertia};
use crate::spec::JointKind;

/// One ragdoll's joints and bodies as the damping sees them.
#[derive(Clone, Debug)]
struct Damped {
    /// Each joint: parent, child, the anchor in the child's frame, and whether it is fixed
    /// (no relative motion to damp).
    joints: Vec<(usize, usize, Vec3, bool)>,
    /// Each body's principal moments about its centre (with its extra shapes' skin, as
    /// the engines have it) and its mass.
    inertia: Vec<(Vec3, f32)>,
    /// Per second; 0 is off.
    rate: f32,
}

/// The damping of every ragdoll an engine holds, in the order added.
#[derive(Clone, Debug, Default)]
pub struct JointDamping {
    ragdolls: Ragdolls<Damped>,
}

impl JointDamping {
    /// Takes in a ragdoll whose first body has the engine's index `first_body`, undamped
    /// until [`JointDamping::set_rate`].
    pub fn add_ragdoll(&mut self, first_body: usize, bodies: &[BodyDesc], joints: &[JointDesc]) {
        let damped = Damped {
            joints: joints
                .iter()
                .map(|j| {
                    let fixed = matches!(j.kind, JointKind::Fixed);
                    (j.parent, j.child, j.frame_child.translation, fixed)
                })
                .collect(),
            inertia: bodies
                .iter()
                .map(|b| {
                    let own = if b.extra_shapes.is_empty() {
                        principal_inertia(&b.shape, b.mass)
                    } else {
                        body_inertia(&b.shape, &b.extra_shapes, b.mass).diagonal()
                    };
                    (own, b.mass)
                })
                .collect(),
            rate: 0.0,
        };
        self.ragdolls.add(first_body, joints.len(), damped);
    }

    /// Leaves out the ragdoll whose first body is `first_body` from now on.
    pub fn remove_ragdoll(&mut self, first_body: usize) {
        self.ragdolls.remove(first_body);
    }

    /// The damping rate of the ragdoll whose first body is `first_body`, per second.
    pub fn set_rate(&mut self, BodyId(first_body): BodyId, rate_per_s: f32) {
        if let Some(r) = self.ragdolls.get_mut(first_body) {
            r.rate = rate_per_s.max(0.0);
        }
    }

    /// A joint's new frame in its child body (its anchor moves with it).
    pub fn set_child_frame(&mut self, joint: JointId, frame: &crate::math::Transform) {
        if let Some((r, k)) = self.ragdolls.joint_mut(joint) {
            r.joints[k].2 = frame.translation;
        }
    }

    /// Whether any ragdoll is damped.
    pub fn is_on(&self) -> bool {
        self.ragdolls.live().any(|r| r.rate > 0.0)
    }

    /// The couples of every damped ragdoll with a dynamic body (`dynamic(body)`) over a
    /// step of `h` seconds, from the bodies' `states`, as equal and opposite angular
    /// impulses, appended to `out`.
    ///
    /// The couple is sized, like the motors, by the two bodies' inertia about the joint
    /// along the relative spin, so a limb swinging from a still body (a pendulum) loses
    /// relative speed at the rate per second: its swing's amplitude decays as
    /// `exp(-c t / 2)`. The velocity it acts on is the one at the end of the step
    /// (implicit), so the couple never reverses a joint's motion whatever the rate.
    pub fn impulses(
        &self,
        states: &[BodyState],
        dynamic: impl Fn(usize) -> bool,
        h: f32,
        out: &mut Vec<BodyImpulse>,
    ) {
        for r in self.ragdolls.live() {
            let bodies = r.first_body..r.first_body + r.inertia.len();
            if r.rate <= 0.0 || !bodies.clone().any(&dynamic) {
                continue;
            }
            let share = r.rate * h / (1.0 + r.rate * h);
            let states = &states[bodies];
            for &(p, c, anchor_in_child, fixed) in &r.joints {
                if fixed {
                    continue;
                }
                let (parent, child) = (&states[p], &states[c]);
                let relative = child.angvel - parent.angvel;
                let Some(n) = relative.try_normalize() else {
                    continue;
                };
                let anchor = child.pose.transform_point(anchor_in_child);
                let about = |b: usize| {
                    let (own, mass) = r.inertia[b];
                    inertia_about(&states[b].pose, own, mass, anchor, n)
                };
                let inertia = effective_inertia(about(c), Some(about(p)));
                let impulse: Vec3 = -relative * (share * inertia);
                if impulse.is_finite() {
                    out.extend(BodyImpulse::joint_pair(
                        BodyId(r.first_body + c),
                        BodyId(r.first_body + p),
                        impulse,
                    ));
                }
            }
        }
    }
}
