//! Joint error measures for the metrics: how far a joint's two anchors drift apart, and
//! how far it leaves its limits, measured the way rapier's limits are defined (a cone
//! between the frames' X axes, twist as 2·atan2(qx, qw) of the relative rotation).

use glam::Vec3;

use crate::backend::JointDesc;
use crate::math::{Transform, twist_angle_x};
use crate::spec::JointKind;

/// A joint, reduced to what its error measures need.
#[derive(Clone, Debug)]
pub(crate) struct JointMeasure {
    pub parent: usize,
    pub child: usize,
    frame_parent: Transform,
    frame_child: Transform,
    kind: JointKind,
}

impl JointMeasure {
    pub(crate) fn new(d: &JointDesc) -> Self {
        JointMeasure {
            parent: d.parent,
            child: d.child,
            frame_parent: d.frame_parent,
            frame_child: d.frame_child,
            kind: d.kind,
        }
    }

    /// (anchor separation in metres, limit violation in radians) for the given body poses.
    pub(crate) fn errors(&self, parent: &Transform, child: &Transform) -> (f32, f32) {
        let f1 = parent.mul(&self.frame_parent);
        let f2 = child.mul(&self.frame_child);
        let separation = (f1.translation - f2.translation).length();
        let rel = (f1.rotation.conjugate() * f2.rotation).normalize();
        let x1 = f1.rotation * Vec3::X;
        let x2 = f2.rotation * Vec3::X;
        let axis_angle = x1.dot(x2).clamp(-1.0, 1.0).acos();
        let outside = |v: f32, lo: f32, hi: f32| (lo - v).max(v - hi).max(0.0);
        let violation = match self.kind {
            JointKind::Hinge { min_deg, max_deg } => {
                let a = twist_angle_x(rel);
                outside(a, min_deg.to_radians(), max_deg.to_radians()).max(axis_angle)
            }
            JointKind::SwingTwist {
                swing_deg,
                twist_deg,
                ..
            } => {
                let t = twist_angle_x(rel);
                outside(axis_angle, 0.0, swing_deg.to_radians()).max(outside(
                    t,
                    twist_deg[0].to_radians(),
                    twist_deg[1].to_radians(),
                ))
            }
            JointKind::Ball => 0.0,
            JointKind::Fixed => rel.angle_between(glam::Quat::IDENTITY),
        };
        (separation, violation)
    }
}
