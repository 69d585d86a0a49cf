//! A joint's limits as the fast backend's solver reads them: in radians, with the
//! sines and cosines that tell whether a bound is crossed without an arctangent.

use glam::Quat;

use crate::spec::JointKind;

/// A joint's limits, in radians, with what tells cheaply whether they are crossed.
#[derive(Clone, Copy, Debug)]
pub(super) enum Limits {
    Ball,
    Fixed,
    Hinge(Twist),
    SwingTwist {
        swing: f32,
        /// `cos(swing)`: the cone is crossed when the axes' dot product is below it.
        cos_swing: f32,
        twist: Twist,
    },
}

/// A twist range `[min, max]` about the frames' X axis, with the sine and cosine of each
/// half angle: the twist `2·atan2(x, w)` of a relative rotation (w ≥ 0) passes `max` when
/// `x·cos(max/2) − w·sin(max/2) > 0`, a test without the arctangent the solver would
/// otherwise take for every joint in every substep. A bound at ±180° or beyond is never
/// crossed.
#[derive(Clone, Copy, Debug)]
pub(super) struct Twist {
    pub(super) min: f32,
    pub(super) max: f32,
    min_half: Option<(f32, f32)>,
    max_half: Option<(f32, f32)>,
}

impl Twist {
    pub(super) fn new(min: f32, max: f32) -> Self {
        let half = |a: f32| (a.abs() < std::f32::consts::PI).then(|| (0.5 * a).sin_cos());
        Twist {
            min,
            max,
            min_half: half(min),
            max_half: half(max),
        }
    }

    /// Whether the relative rotation `rel` (about X) is past either bound.
    #[inline]
    pub(super) fn crossed(&self, rel: Quat) -> bool {
        let rel = if rel.w < 0.0 { -rel } else { rel };
        let past = |(s, c): (f32, f32)| rel.x * c - rel.w * s;
        self.max_half.is_some_and(|h| past(h) > 0.0) || self.min_half.is_some_and(|h| past(h) < 0.0)
    }
}

impl Limits {
    pub(super) fn of(kind: &JointKind) -> Self {
        match *kind {
            JointKind::Ball => Limits::Ball,
            JointKind::Fixed => Limits::Fixed,
            JointKind::Hinge { min_deg, max_deg } => {
                Limits::Hinge(Twist::new(min_deg.to_radians(), max_deg.to_radians()))
            }
            JointKind::SwingTwist {
                swing_deg,
                twist_deg,
                ..
            } => Limits::SwingTwist {
                swing: swing_deg.to_radians(),
                cos_swing: swing_deg.to_radians().cos(),
                twist: Twist::new(twist_deg[0].to_radians(), twist_deg[1].to_radians()),
            },
        }
    }
}
