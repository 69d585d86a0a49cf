//! The commands the world hands the rigid engine between steps, one at a time
//! ([`OneAtATime`]): rapier's bodies, joints and pins changed in place.

use glam::Vec3;
use rapier3d::prelude::*;

use super::{RigidBackend, pose};
use crate::backend::{BodyId, JointId, OneAtATime, PinId};
use crate::math::Transform;
use crate::spec::JointKind;

impl OneAtATime for RigidBackend {
    fn apply_impulse_at_point(&mut self, BodyId(index): BodyId, impulse: Vec3, point: Vec3) {
        self.world.bodies[self.bodies[index]].apply_impulse_at_point(impulse, point, true);
    }

    fn apply_torque_impulse(&mut self, BodyId(index): BodyId, impulse: Vec3) {
        self.world.bodies[self.bodies[index]].apply_torque_impulse(impulse, true);
    }

    fn set_joint_parent_frame(&mut self, JointId(index): JointId, frame: &Transform) {
        if let Some(limits) = &mut self.limits {
            limits.set_parent_frame(JointId(index), frame);
        }
        if let Some(joint) = self.world.impulse_joints.get_mut(self.joints[index], true) {
            joint.data.set_local_frame1(pose(frame));
        }
    }

    fn set_joint_child_frame(&mut self, JointId(index): JointId, frame: &Transform) {
        if let Some(limits) = &mut self.limits {
            limits.set_child_frame(JointId(index), frame);
        }
        self.damping.set_child_frame(JointId(index), frame);
        if let Some(joint) = self.world.impulse_joints.get_mut(self.joints[index], true) {
            joint.data.set_local_frame2(pose(frame));
        }
    }

    fn set_solver_substeps(&mut self, substeps: usize) {
        self.world.integration_parameters.num_solver_iterations = substeps.max(1);
    }

    fn set_joint_limits(&mut self, JointId(index): JointId, kind: &JointKind) {
        if let Some(limits) = &mut self.limits {
            limits.set_limits(JointId(index), kind);
        }
        let Some(joint) = self.world.impulse_joints.get_mut(self.joints[index], true) else {
            return;
        };
        match *kind {
            JointKind::Hinge { min_deg, max_deg } => {
                joint.data.set_limits(
                    JointAxis::AngX,
                    [min_deg.to_radians(), max_deg.to_radians()],
                );
            }
            JointKind::SwingTwist {
                swing_deg,
                twist_deg,
                ..
            } => {
                joint.data.set_limits(
                    JointAxis::AngY,
                    [-swing_deg.to_radians(), swing_deg.to_radians()],
                );
                joint.data.set_limits(
                    JointAxis::AngX,
                    [twist_deg[0].to_radians(), twist_deg[1].to_radians()],
                );
            }
            JointKind::Ball | JointKind::Fixed => {}
        }
    }

    fn set_gravity(&mut self, gravity: Vec3) {
        self.world.gravity = gravity;
    }

    fn move_pin(&mut self, PinId(pin): PinId, target: Vec3) {
        let anchor = self.pins[pin].0;
        self.world.bodies[anchor].set_next_kinematic_translation(target);
    }

    fn release_pin(&mut self, PinId(pin): PinId) {
        if let Some(joint) = self.pins[pin].1.take() {
            self.world.impulse_joints.remove(joint, true);
        }
    }

    fn set_joint_damping(&mut self, first_body: BodyId, rate_per_s: f32) {
        self.damping.set_rate(first_body, rate_per_s);
    }

    fn disable_pair(&mut self, BodyId(a): BodyId, BodyId(b): BodyId) {
        let (a, b) = (a as u32, b as u32);
        self.filter.disabled.insert((a.min(b), a.max(b)));
    }

    fn set_kinematic(&mut self, BodyId(index): BodyId, kinematic: bool) {
        let kind = if kinematic {
            RigidBodyType::KinematicPositionBased
        } else {
            RigidBodyType::Dynamic
        };
        self.world.bodies[self.bodies[index]].set_body_type(kind, true);
    }

    fn set_kinematic_target(&mut self, BodyId(index): BodyId, p: &Transform) {
        self.world.bodies[self.bodies[index]].set_next_kinematic_position(pose(p));
    }

    fn set_body_velocity(&mut self, BodyId(index): BodyId, linvel: Vec3, angvel: Vec3) {
        let rb = &mut self.world.bodies[self.bodies[index]];
        rb.set_linvel(linvel, true);
        rb.set_angvel(angvel, true);
    }

    fn set_body_pose(&mut self, BodyId(index): BodyId, p: &Transform) {
        self.world.bodies[self.bodies[index]].set_position(pose(p), false);
    }
}
