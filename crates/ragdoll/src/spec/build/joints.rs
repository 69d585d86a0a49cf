//! Joints: hinges for knees and elbows, swing-twist cones elsewhere, with axes taken from
//! the rest pose so the anatomical limits hold whichever way the character faces.

use glam::{Quat, Vec3};

use super::{Builder, Plan};
use crate::math::{frame_from_x, twist_angle_x};
use crate::spec::anthropometry::*;
use crate::spec::{JointKind, Role};

/// A swing cone always contains the rest direction with this margin, so an odd rest pose
/// never starts outside its limits.
const REST_MARGIN_DEG: f32 = 5.0;
/// Below this |sin| two directions count as parallel when building frames.
const PARALLEL_SIN: f32 = 0.3;
/// A shoulder at least this far (in standing heights) to one side of the chest's joint
/// is on that side, whatever its role's name says.
const MIN_SHOULDER_OFFSET_H: f32 = 0.02;

/// The cone centre of a [`JointKind::SwingTwist`] in its joint frame: X of the frame
/// turned about its Y by `cone_tilt_deg[0]`, then about its (turned) Z by
/// `cone_tilt_deg[1]`.
pub fn cone_centre(cone_tilt_deg: [f32; 2]) -> Vec3 {
    let (ty, tz) = (cone_tilt_deg[0].to_radians(), cone_tilt_deg[1].to_radians());
    Quat::from_rotation_y(ty) * Quat::from_rotation_z(tz) * Vec3::X
}

impl Builder<'_> {
    /// The joint linking `child` to `parent`: its frame in world space and its kind.
    pub(super) fn joint(&self, child: &Plan, parent: &Plan) -> (Quat, JointKind) {
        use Role::*;
        let d = child.dir();
        let f = self.forward;
        let up = Vec3::Y;
        let parent_has = |r: Role| parent.role == r;
        match child.role {
            ShinL | ShinR => self.hinge(d, parent.dir(), -f, up, KNEE_FLEXION_DEG),
            ForearmL | ForearmR => self.hinge(d, parent.dir(), f, up, ELBOW_FLEXION_DEG),
            ThighL | ThighR => {
                let centre_deg = 0.5 * (HIP_FLEXION_DEG[0] + HIP_FLEXION_DEG[1]);
                // Half the flexion range, and wide enough that a straight leg abducted by
                // HIP_ABDUCTION_DEG is inside (spherical cosine rule from the centre).
                let abducted = (centre_deg.to_radians().cos()
                    * HIP_ABDUCTION_DEG.to_radians().cos())
                .acos()
                .to_degrees();
                let swing = (0.5 * (HIP_FLEXION_DEG[1] - HIP_FLEXION_DEG[0])).max(abducted);
                let c = rotate_toward(-up, f, centre_deg);
                swing_twist(d, &[f, up], Some(c), swing, HIP_TWIST_DEG)
            }
            UpperArmL | UpperArmR => {
                // Outward is the side the shoulder is on: a rig's names can be mirrored
                // (its `l-` arm on the right), and a cone tilted the named way would open
                // across the chest.
                let named = if child.role == UpperArmL { 1.0 } else { -1.0 };
                let lateral = (child.start - parent.start).dot(self.left);
                let side = if lateral.abs() >= MIN_SHOULDER_OFFSET_H * self.h {
                    lateral.signum()
                } else {
                    named
                };
                let out = self.left * side;
                let side = rotate_toward(-up, out, SHOULDER_CONE_ABDUCTION_DEG);
                let c = rotate_toward(side, f, SHOULDER_CONE_FLEXION_DEG);
                swing_twist(d, &[f, up], Some(c), SHOULDER_SWING_DEG, SHOULDER_TWIST_DEG)
            }
            HandL | HandR => swing_twist(d, &[f, up], None, WRIST_SWING_DEG, WRIST_TWIST_DEG),
            FootL | FootR => {
                let (frame, _) = swing_twist(d, &[up, f], None, 0.0, [0.0; 2]);
                let c = frame * cone_centre([0.0, -ANKLE_CONE_PLANTAR_DEG]);
                swing_twist(d, &[up, f], Some(c), ANKLE_SWING_DEG, ANKLE_TWIST_DEG)
            }
            Spine => swing_twist(d, &[f, up], None, LUMBAR_SWING_DEG, LUMBAR_TWIST_DEG),
            Chest if parent_has(Spine) => {
                swing_twist(d, &[f, up], None, THORACIC_SWING_DEG, THORACIC_TWIST_DEG)
            }
            Chest => swing_twist(
                d,
                &[f, up],
                None,
                LUMBAR_SWING_DEG + THORACIC_SWING_DEG,
                add(LUMBAR_TWIST_DEG, THORACIC_TWIST_DEG),
            ),
            Neck => swing_twist(d, &[f, up], None, NECK_SWING_DEG, NECK_TWIST_DEG),
            Head if parent_has(Neck) => {
                swing_twist(d, &[f, up], None, HEAD_SWING_DEG, HEAD_TWIST_DEG)
            }
            Head => swing_twist(
                d,
                &[f, up],
                None,
                NECK_SWING_DEG + HEAD_SWING_DEG,
                add(NECK_TWIST_DEG, HEAD_TWIST_DEG),
            ),
            Pelvis | Chain => self.creature_joint(child, parent),
        }
    }

    /// A joint of a creature, read from the geometry rather than the names: the middle
    /// joint of a leg (its bone and its parent both in a limb that reaches down to the
    /// ground, bent at rest) is a hinge in the plane of that bend, flexing further the way
    /// the rest pose bends and barely past straight the other way, as a dog's stifle,
    /// elbow and hock and a spider's knee do; links of a long unbranched chain (a spine, tail, snake or fish)
    /// share one total bend, so twenty links curl no further than three; anything else
    /// is a modest swing-twist cone.
    fn creature_joint(&self, child: &Plan, parent: &Plan) -> (Quat, JointKind) {
        let (d, dp) = (child.dir(), parent.dir());
        let down = -CREATURE_LIMB_DOWN_DEG.to_radians().sin();
        let bend = dp.angle_between(d).to_degrees();
        // A leg hangs from its root (a dog's), or rises to a knee and turns down from it
        // (a spider's femur climbs above the body): then the parent bone is the limb's own,
        // unbranched, not the trunk a hip hangs from.
        let descends = dp.y <= down || (d.y <= down && self.rig.children[parent.joint].len() == 1);
        let limb = descends
            && self.joints.first() != Some(&parent.joint)
            && (CREATURE_MIN_HINGE_BEND_DEG..=180.0 - CREATURE_MIN_HINGE_BEND_DEG).contains(&bend)
            && self.reach_down(child.joint) <= self.rig.ground + CREATURE_GROUND_BAND_H * self.h;
        if limb && let Some(away) = perpendicular_part(-dp, d) {
            let [lo, hi] = CREATURE_LIMB_FLEXION_DEG;
            let range = [lo, hi.min(bend + CREATURE_SKIN_FLEXION_DEG)];
            return self.hinge(d, dp, away, Vec3::Y, range);
        }
        let scale =
            (CREATURE_CHAIN_TOTAL_BEND_DEG / self.run_links(child.joint) as f32 / CHAIN_SWING_DEG)
                .clamp(CREATURE_MIN_SWING_DEG / CHAIN_SWING_DEG, 1.0);
        swing_twist(
            d,
            &[Vec3::Y, self.forward, self.left],
            None,
            CHAIN_SWING_DEG * scale,
            CHAIN_TWIST_DEG.map(|t| t * scale),
        )
    }

    /// The lowest point (Y) of the limb below joint `j`, following its lowest child at
    /// each joint (a detached foot that joins it counts as one) for at most
    /// [`CREATURE_MAX_LIMB_LINKS`] joints: a leg, not the whole subtree, and a bounded walk
    /// however deep the skeleton.
    fn reach_down(&self, j: usize) -> f32 {
        let mut at = j;
        let mut lowest = self.rig.pos[j].y;
        for _ in 0..CREATURE_MAX_LIMB_LINKS {
            if let Some(t) = self.rig.tips[at] {
                lowest = lowest.min(t.y);
            }
            let next = self.rig.children[at]
                .iter()
                .chain(&self.attached[at])
                .copied()
                .min_by(|&a, &b| self.rig.pos[a].y.total_cmp(&self.rig.pos[b].y));
            let Some(n) = next else { break };
            lowest = lowest.min(self.rig.pos[n].y);
            at = n;
        }
        lowest
    }

    /// How many links the unbranched run of joints through `j` has (joints with one
    /// child each), counted at most [`CREATURE_MAX_RUN_LINKS`] each way: past that every
    /// link already gets the smallest cone.
    fn run_links(&self, j: usize) -> usize {
        let children = &self.rig.children;
        let mut n = 1;
        let mut at = j;
        while n < CREATURE_MAX_RUN_LINKS
            && let Some(p) = self.rig.skeleton.parent(at)
            && children[p].len() == 1
        {
            n += 1;
            at = p;
        }
        let mut at = j;
        let mut down = 0;
        while down < CREATURE_MAX_RUN_LINKS && children[at].len() == 1 {
            down += 1;
            at = children[at][0];
        }
        n + down
    }

    /// A hinge turning the bone `d` toward `flex` for positive angles: X = d × flex. The
    /// limits are the anatomical range shifted by the flexion already present at rest
    /// (the angle from the parent bone `dp` to `d` about X), so a knee bent at rest still
    /// stops at straight and never bends backwards. A rest pose already slightly
    /// hyperextended (mocapbank's elbows, by 1.2°) keeps its rest as the lower limit: the
    /// ragdoll must not start outside its limits, and it bends no further back.
    fn hinge(
        &self,
        d: Vec3,
        dp: Vec3,
        flex: Vec3,
        alt: Vec3,
        range: [f32; 2],
    ) -> (Quat, JointKind) {
        let toward = perpendicular_part(flex, d)
            .or_else(|| perpendicular_part(alt, d))
            .unwrap_or_else(|| d.any_orthonormal_vector());
        let x = d.cross(toward).normalize();
        let frame = frame_from_x(x, d);
        let rest_deg = match perpendicular_part(dp, x) {
            Some(p) => x.dot(p.cross(d)).atan2(p.dot(d)).to_degrees(),
            None => 0.0,
        };
        let kind = JointKind::Hinge {
            min_deg: (range[0] - rest_deg).min(0.0),
            max_deg: range[1] - rest_deg,
        };
        (frame, kind)
    }
}

fn add(a: [f32; 2], b: [f32; 2]) -> [f32; 2] {
    [a[0] + b[0], a[1] + b[1]]
}

/// A swing-twist joint about the bone `d`: X = d, Y = the first hint not parallel to `d`
/// (the flexion direction), cone centred on `centre` (world) or on the rest direction,
/// widened if needed so the rest pose lies inside.
pub(super) fn swing_twist(
    d: Vec3,
    hints: &[Vec3],
    centre: Option<Vec3>,
    swing_deg: f32,
    twist_deg: [f32; 2],
) -> (Quat, JointKind) {
    let y = hints
        .iter()
        .find_map(|h| perpendicular_part(*h, d))
        .unwrap_or_else(|| d.any_orthonormal_vector());
    let frame = frame_from_x(d, y);
    let (tilt, swing) = match centre {
        Some(c) => {
            let local = frame.conjugate() * c.normalize_or(d);
            // Inverse of `cone_centre`: Ry(ty)·Rz(tz)·X = (cy·cz, sz, −sy·cz).
            let tz = local.y.clamp(-1.0, 1.0).asin();
            let ty = (-local.z).atan2(local.x);
            let rest_off = local.angle_between(Vec3::X).to_degrees();
            (
                [ty.to_degrees(), tz.to_degrees()],
                swing_deg.max(rest_off + REST_MARGIN_DEG),
            )
        }
        None => ([0.0, 0.0], swing_deg),
    };
    // The tilted parent frame leaves the rest pose a small twist (the X part of the tilt's
    // inverse, as `twist_angle_x` measures it); centre the twist range on the rest.
    let tilt_q =
        Quat::from_rotation_y(tilt[0].to_radians()) * Quat::from_rotation_z(tilt[1].to_radians());
    let rest_twist = twist_angle_x(tilt_q.conjugate()).to_degrees();
    let kind = JointKind::SwingTwist {
        swing_deg: swing.min(180.0),
        twist_deg: [twist_deg[0] + rest_twist, twist_deg[1] + rest_twist],
        cone_tilt_deg: tilt,
    };
    (frame, kind)
}

/// `from` turned by `deg` toward `to` (both unit, `to` not parallel to `from`).
pub(super) fn rotate_toward(from: Vec3, to: Vec3, deg: f32) -> Vec3 {
    let t = perpendicular_part(to, from).unwrap_or_else(|| from.any_orthonormal_vector());
    let a = deg.to_radians();
    (from * a.cos() + t * a.sin()).normalize()
}

/// The unit part of `v` perpendicular to unit `axis`, if `v` is not (nearly) parallel to it.
pub(super) fn perpendicular_part(v: Vec3, axis: Vec3) -> Option<Vec3> {
    let v = v.normalize_or_zero();
    let p = v - axis * v.dot(axis);
    (p.length() >= PARALLEL_SIN).then(|| p.normalize())
}
