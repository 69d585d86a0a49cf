//! Contacts kept from one substep to the next while the two shapes barely move against
//! each other (`FastConfig::keep_contacts`, off by default).
//!
//! A candidate pair's contact is found again every substep (`narrow.rs`): 32 times a step,
//! more in an impact. In a pile most of those tests find what the last one found: of the
//! tests in the pile bench (`ragdoll bench --backend fast --ragdolls 64`), 84 % came
//! after the two shapes had moved less than half a millimetre and a quarter of a degree
//! against each other since their pair's last full test (89 % in a pile of 64). With
//! the setting on, such a test is replaced by the last contact carried along with the
//! shapes: its points are material points of each shape, its normal turns with the
//! first, and its depth is read along that normal. The error this leaves is the depth's
//! change along a surface the points slid over, at most the square of the slide over the
//! surface's radius (a micrometre for a millimetre over a limb's few centimetres); a
//! larger motion is tested in full again.
//!
//! It is off by default: standard piles kept their fidelity, but in columns of 30 to 63
//! humanoids the solver's limit readings came out worse (the benchmarks page has the
//! numbers). Why is not established; a likely part is that a pair has one contact point,
//! which a new test each substep moves to whichever end of a lying limb is lowest, while
//! a carried one stays where it was until the motion allowed is used.
//!
//! What a pair keeps depends only on the bodies' motion, so a step is still the same on
//! any number of threads.

use glam::{Quat, Vec3};

use super::FastBackend;
use super::narrow::{Found, reach};

/// How far any point of the second shape may move against the first before the pair is
/// tested again, metres.
const KEEP_MOVE_M: f32 = 0.000_5;

/// A pair's contact as last found: the second shape's pose in the first's frame then, and
/// the contact in the shapes' own frames.
#[derive(Clone, Copy, Debug)]
pub(super) struct Kept {
    rel_pos: Vec3,
    rel_rot: Quat,
    /// The contact point on the first shape, in its frame.
    pa: Vec3,
    /// The contact point on the second shape, in its frame.
    pb: Vec3,
    /// The normal, from the second toward the first, in the first's frame.
    n: Vec3,
    /// The depth found less the depth the points give along the normal (zero but for an
    /// edge against an edge of two boxes, whose depth is the separating axis's).
    offset: f32,
    /// How far the second shape's farthest point lies from its centre, metres: a turn
    /// moves it that many times the angle.
    reach_b: f32,
}

impl FastBackend {
    /// The pose of shape `b` in shape `a`'s frame, and both shapes' poses.
    #[inline]
    fn relative_pose(&self, a: usize, b: usize) -> (Vec3, Quat, (Vec3, Quat), (Vec3, Quat)) {
        let (pos_a, rot_a) = self.shape_pose(a);
        let (pos_b, rot_b) = self.shape_pose(b);
        let inv = rot_a.conjugate();
        (
            inv * (pos_b - pos_a),
            inv * rot_b,
            (pos_a, rot_a),
            (pos_b, rot_b),
        )
    }

    /// What pair `a`, `b` keeps of contact `f` (touching or apart), found with the shapes
    /// where they are now.
    pub(super) fn keep_contact(&self, a: usize, b: usize, f: &Found) -> Kept {
        let (rel_pos, rel_rot, (pos_a, rot_a), (pos_b, rot_b)) = self.relative_pose(a, b);
        let (inv_a, inv_b) = (rot_a.conjugate(), rot_b.conjugate());
        Kept {
            rel_pos,
            rel_rot,
            pa: inv_a * (f.pa - pos_a),
            pb: inv_b * (f.pb - pos_b),
            n: inv_a * f.n,
            offset: f.depth - (f.pb - f.pa).dot(f.n),
            reach_b: reach(&self.shape[b]),
        }
    }

    /// Contact `kept` carried to where shapes `a` and `b` are now, if they have barely
    /// moved against each other since it was found. Its depth, negative when apart, is
    /// as good for putting off the pair's next test as a full test's: it is off by less
    /// than the motion allowed.
    #[inline]
    pub(super) fn carry_contact(&self, a: usize, b: usize, kept: &Kept) -> Option<Found> {
        let (rel_pos, rel_rot, (pos_a, rot_a), (pos_b, rot_b)) = self.relative_pose(a, b);
        // Its centre's move plus the turn times its reach bounds every point's move; for
        // angles this small the turn's angle is twice its quaternion's vector part.
        let turn = rel_rot * kept.rel_rot.conjugate();
        let angle = 2.0 * Vec3::new(turn.x, turn.y, turn.z).length();
        if (rel_pos - kept.rel_pos).length() + angle * kept.reach_b > KEEP_MOVE_M {
            return None;
        }
        let (pa, pb, n) = (
            pos_a + rot_a * kept.pa,
            pos_b + rot_b * kept.pb,
            rot_a * kept.n,
        );
        let depth = (pb - pa).dot(n) + kept.offset;
        Some(Found { pa, pb, n, depth })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::backend::{Backend, BodyDesc};
    use crate::math::Transform;
    use crate::spec::Shape;

    /// Two bodies of the given shapes at the given poses, no ground, no gravity.
    fn two(shapes: [Shape; 2], poses: [Transform; 2]) -> FastBackend {
        let mut b = FastBackend::with_settings(super::super::FastSettings {
            keep_contacts: true,
            ..super::super::FastSettings::bare()
        });
        let body = |i: usize| BodyDesc {
            pose: poses[i],
            shape: shapes[i],
            extra_shapes: Vec::new(),
            mass: 1.0,
            linvel: Vec3::ZERO,
            angvel: Vec3::ZERO,
        };
        b.add_ragdoll(&[body(0), body(1)], &[], &[]);
        b
    }

    const CAPSULE: Shape = Shape::Capsule {
        radius_m: 0.05,
        length_m: 0.3,
    };
    const BOX: Shape = Shape::Box {
        size_m: [0.3, 0.2, 0.4],
    };

    #[test]
    fn a_carried_contact_matches_a_new_test_until_the_shapes_move_too_far() {
        // Each pair pressed 1 cm into each other, slanted so that no feature is special.
        let tilt = Quat::from_axis_angle(Vec3::new(1.0, 0.4, 0.2).normalize(), 0.7);
        let cases = [
            (CAPSULE, CAPSULE, 0.09),
            (BOX, CAPSULE, 0.14),
            (CAPSULE, BOX, 0.14),
            (BOX, BOX, 0.19),
        ];
        for (sa, sb, gap) in cases {
            let poses = [
                Transform::IDENTITY,
                Transform::new(Vec3::new(0.02, gap, 0.01), tilt),
            ];
            let mut b = two([sa, sb], poses);
            let found = b.pair_contact(0, 1).expect("they touch");
            assert!(found.depth > 0.0, "{sa:?} {sb:?}: {found:?}");
            let kept = b.keep_contact(0, 1, &found);
            // Where nothing moved, the carried contact is the one found.
            let same = b.carry_contact(0, 1, &kept).expect("nothing moved");
            assert!(
                (same.depth - found.depth).abs() < 1e-6,
                "{same:?} vs {found:?}"
            );
            // Both moved together, and the second a little against the first: the depth
            // follows the motion as a new test finds it.
            let whole = Quat::from_rotation_y(0.3);
            for i in 0..2 {
                b.pos[i] = whole * b.pos[i] + Vec3::new(1.0, -2.0, 0.5);
                b.rot[i] = whole * b.rot[i];
            }
            b.pos[1] += b.rot[0] * Vec3::new(0.00005, -0.0001, 0.00005);
            b.rot[1] = Quat::from_rotation_z(0.001) * b.rot[1];
            let carried = b.carry_contact(0, 1, &kept).expect("barely moved");
            let fresh = b.pair_contact(0, 1).expect("they touch");
            assert!(
                (carried.depth - fresh.depth).abs() < 2e-5,
                "{sa:?} {sb:?}: carried {carried:?}, tested {fresh:?}"
            );
            assert!(carried.n.dot(fresh.n) > 0.999, "{carried:?} vs {fresh:?}");
            // Moved a millimetre, or turned a quarter of a degree: tested again.
            let (p1, r1) = (b.pos[1], b.rot[1]);
            b.pos[1] += Vec3::new(0.0, 0.0, 0.001);
            assert!(b.carry_contact(0, 1, &kept).is_none());
            b.pos[1] = p1;
            b.rot[1] = Quat::from_rotation_x(0.25f32.to_radians()) * r1;
            assert!(b.carry_contact(0, 1, &kept).is_none());
        }
    }
}
