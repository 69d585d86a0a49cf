//! The commands the world hands the fast engine between steps, one at a time
//! ([`OneAtATime`]): bodies woken and joints thawed where a change reaches them.

use glam::Vec3;

use super::{FastBackend, Kinematic, Limits};
use crate::backend::{BodyId, JointId, OneAtATime, PinId};
use crate::math::Transform;
use crate::spec::JointKind;

impl OneAtATime for FastBackend {
    fn apply_impulse_at_point(&mut self, BodyId(index): BodyId, impulse: Vec3, point: Vec3) {
        let r = point - self.pos[index];
        let dw = self.inv_inertia_world(index, r.cross(impulse));
        self.kick(index, impulse * self.inv_mass[index], dw);
    }

    fn apply_torque_impulse(&mut self, BodyId(index): BodyId, impulse: Vec3) {
        let dw = self.inv_inertia_world(index, impulse);
        self.kick(index, Vec3::ZERO, dw);
    }

    fn set_kinematic(&mut self, BodyId(index): BodyId, kinematic: bool) {
        let pose = Transform::new(self.pos[index], self.rot[index]);
        self.kinematic[index] = kinematic.then_some(Kinematic {
            from: pose,
            to: pose,
        });
        self.set_mass_of(index, kinematic);
        self.thaw(self.ragdoll_of[index]);
        self.update_held(self.ragdoll_of[index]);
        self.wake_body(index);
    }

    fn set_kinematic_target(&mut self, BodyId(index): BodyId, pose: &Transform) {
        if let Some(k) = &mut self.kinematic[index] {
            k.to = Transform::new(pose.translation, pose.rotation.normalize());
        }
    }

    fn set_body_velocity(&mut self, BodyId(index): BodyId, linvel: Vec3, angvel: Vec3) {
        self.wake_body(index);
        self.thaw(self.ragdoll_of[index]);
        self.vel[index] = linvel;
        self.angvel[index] = angvel;
        self.seen_vel[index] = linvel;
        self.seen_angvel[index] = angvel;
    }

    fn set_joint_parent_frame(&mut self, JointId(index): JointId, frame: &Transform) {
        if let Some(limits) = &mut self.limits {
            limits.set_parent_frame(JointId(index), frame);
        }
        let j = &mut self.joints[index];
        j.frame_a = *frame;
        let b = j.b;
        self.wake_body(b);
        self.thaw(self.ragdoll_of[b]);
    }

    fn set_joint_child_frame(&mut self, JointId(index): JointId, frame: &Transform) {
        if let Some(limits) = &mut self.limits {
            limits.set_child_frame(JointId(index), frame);
        }
        self.damping.set_child_frame(JointId(index), frame);
        let j = &mut self.joints[index];
        j.frame_b = *frame;
        let b = j.b;
        self.wake_body(b);
        self.thaw(self.ragdoll_of[b]);
    }

    // Drives are implicit springs on the substeps' velocities, stable at any stiffness:
    // nothing to raise.
    fn set_solver_substeps(&mut self, _substeps: usize) {}

    fn set_joint_limits(&mut self, JointId(index): JointId, kind: &JointKind) {
        if let Some(limits) = &mut self.limits {
            limits.set_limits(JointId(index), kind);
        }
        let j = &mut self.joints[index];
        j.limits = Limits::of(kind);
        let b = j.b;
        self.wake_body(b);
        self.thaw(self.ragdoll_of[b]);
    }

    fn set_joint_damping(&mut self, first_body: BodyId, rate_per_s: f32) {
        self.damping.set_rate(first_body, rate_per_s);
    }

    fn set_gravity(&mut self, gravity: Vec3) {
        if gravity != self.settings.gravity {
            for r in 0..self.ragdolls.len() {
                self.wake(r);
            }
        }
        self.settings.gravity = gravity;
    }

    fn move_pin(&mut self, PinId(pin): PinId, target: Vec3) {
        self.pins[pin].to = target;
    }

    fn release_pin(&mut self, PinId(pin): PinId) {
        self.pins[pin].active = false;
        let b = self.pins[pin].body;
        self.update_held(self.ragdoll_of[b]);
        self.wake_body(b);
    }

    fn disable_pair(&mut self, BodyId(a): BodyId, BodyId(b): BodyId) {
        let (a, b) = (a as u32, b as u32);
        self.disabled.insert((a.min(b), a.max(b)));
    }

    fn set_body_pose(&mut self, BodyId(index): BodyId, pose: &Transform) {
        self.pos[index] = pose.translation;
        self.rot[index] = pose.rotation.normalize();
        self.refresh_inertia(index);
        if let Some(k) = &mut self.kinematic[index] {
            k.from = Transform::new(self.pos[index], self.rot[index]);
        }
    }
}
