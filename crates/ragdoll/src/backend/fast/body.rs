//! One body's share of the solver: its inverse inertia in the world, its generalised
//! inverse mass at a point or about an axis, and the small moves and velocity changes
//! every constraint is made of.

use glam::{Mat3A, Quat, Vec3, Vec3A};

use super::{FastBackend, MAX_TURN_RAD};
use crate::backend::JointDesc;

/// Least moment of inertia a body has about an axis, as a share of its mass times the
/// square of its farthest joint anchor's distance from that axis: a twelfth, what a thin
/// rod through the centre has with its ends at twice that distance (every limb the builder
/// makes has more: a capsule from joint to joint has a third). A body whose shape is much
/// smaller than the span of its joints (a spec edited by hand: a forearm made a 12 mm
/// cube, 0.1 m from each of its joints) otherwise spins a thousand times more easily
/// than it moves at its anchors; one pass a substep then swung it round its joints and
/// the ragdoll blew apart (joints 1.2 m apart, 2,900 times its energy in a 3 s drop,
/// where rapier held it within 11 mm).
const ANCHOR_INERTIA_SHARE: f32 = 1.0 / 12.0;

/// The principal moments `inertia` of a body of `mass` raised to [`ANCHOR_INERTIA_SHARE`]
/// of what its joint `anchors` (body frame) need about each principal axis.
pub(super) fn floored_by_anchors(inertia: Vec3, mass: f32, anchors: &[Vec3]) -> Vec3 {
    let mut floor = Vec3::ZERO;
    for a in anchors {
        // Squared distance of the anchor from the x, y and z axes.
        let off = Vec3::new(
            a.y * a.y + a.z * a.z,
            a.x * a.x + a.z * a.z,
            a.x * a.x + a.y * a.y,
        );
        floor = floor.max(off * (ANCHOR_INERTIA_SHARE * mass));
    }
    inertia.max(floor)
}

impl FastBackend {
    /// Raises the moments of a new ragdoll's bodies, from `first`, to what their joints'
    /// anchors need ([`floored_by_anchors`]).
    pub(super) fn floor_inertia_by_anchors(&mut self, first: usize, joints: &[JointDesc]) {
        let mut anchors: Vec<Vec<Vec3>> = Vec::new();
        for j in joints {
            for (b, at) in [
                (j.parent, j.frame_parent.translation),
                (j.child, j.frame_child.translation),
            ] {
                if anchors.len() <= b {
                    anchors.resize(b + 1, Vec::new());
                }
                anchors[b].push(at);
            }
        }
        for (b, at) in anchors.iter().enumerate() {
            let i = first + b;
            if i >= self.pos.len() || at.is_empty() {
                continue;
            }
            let raised = floored_by_anchors(self.inertia[i], self.mass[i], at);
            if raised != self.inertia[i] {
                self.inertia[i] = raised;
                self.inv_inertia[i] = raised.recip();
                self.refresh_inertia(i);
            }
        }
    }

    /// Body `i`'s inverse inertia tensor in the world times `v`, with the tensor as of
    /// the start of the substep (XPBD keeps it fixed through the position pass).
    #[inline(always)]
    pub(super) fn inv_inertia_world(&self, i: usize, v: Vec3) -> Vec3 {
        (self.inv_inertia_world[i] * Vec3A::from(v)).into()
    }

    /// Where shape `c` is now: its body's pose, or for a part of a compound, the pose of
    /// that part.
    #[inline(always)]
    pub(super) fn shape_pose(&self, c: usize) -> (Vec3, Quat) {
        let o = self.owner[c] as usize;
        match &self.attach[c] {
            None => (self.pos[o], self.rot[o]),
            Some(t) => (
                self.pos[o] + self.rot[o] * t.translation,
                self.rot[o] * t.rotation,
            ),
        }
    }

    /// Recomputes body `i`'s world inverse inertia tensor from its rotation.
    #[inline]
    pub(super) fn refresh_inertia(&mut self, i: usize) {
        let m = Mat3A::from_quat(self.rot[i]);
        let d = self.inv_inertia[i];
        let scaled = Mat3A::from_cols(m.x_axis * d.x, m.y_axis * d.y, m.z_axis * d.z);
        self.inv_inertia_world[i] = scaled * m.transpose();
    }

    /// Generalised inverse mass of body `i` for a push along `n` (unit) at the offset `r`
    /// from its centre.
    #[inline]
    pub(super) fn w_at(&self, i: usize, r: Vec3, n: Vec3) -> f32 {
        let rn = r.cross(n);
        self.inv_mass[i] + rn.dot(self.inv_inertia_world(i, rn))
    }

    /// Generalised inverse mass of body `i` for a turn about `n` (unit).
    #[inline]
    pub(super) fn w_turn(&self, i: usize, n: Vec3) -> f32 {
        n.dot(self.inv_inertia_world(i, n))
    }

    /// Moves body `i` by the positional impulse `p` at offset `r`.
    #[inline(always)]
    pub(super) fn shift(&mut self, i: usize, r: Vec3, p: Vec3) {
        let d = p * self.inv_mass[i];
        self.pos[i] += d;
        self.moved[i] += d;
        let w = self.inv_inertia_world(i, r.cross(p));
        self.turn_by(i, w);
    }

    /// Turns body `i` by the small rotation vector `w` (radians, world). The result is
    /// not normalised: the position pass makes many such small turns, and the quaternions
    /// are normalised once at its end, when the velocities are read back.
    ///
    /// A turn is capped at [`MAX_TURN_RAD`]: the small-angle update means nothing past
    /// that, and its unnormalised result grows with the square of the angle, so a few
    /// hundred huge turns in one pass (a 100 m pole spinning into the floor) overflowed.
    #[inline(always)]
    pub(super) fn turn_by(&mut self, i: usize, w: Vec3) {
        let len2 = w.length_squared();
        let w = if len2 > MAX_TURN_RAD * MAX_TURN_RAD {
            w * (MAX_TURN_RAD / len2.sqrt())
        } else {
            w
        };
        let q = self.rot[i];
        let dq = Quat::from_xyzw(w.x, w.y, w.z, 0.0) * q;
        let turned = Quat::from_xyzw(
            q.x + 0.5 * dq.x,
            q.y + 0.5 * dq.y,
            q.z + 0.5 * dq.z,
            q.w + 0.5 * dq.w,
        );
        // Each capped turn lengthens the quaternion by at most √(1 + 1/16); renormalise
        // long before that compounds.
        self.rot[i] = if turned.length_squared() > 4.0 {
            turned.normalize()
        } else {
            turned
        };
    }

    /// Adds the impulse `p` at offset `r` to body `i`'s velocities.
    #[inline]
    pub(super) fn push(&mut self, i: usize, r: Vec3, p: Vec3) {
        self.vel[i] += p * self.inv_mass[i];
        let w = self.inv_inertia_world(i, r.cross(p));
        self.angvel[i] += w;
    }

    /// Adds a velocity change from outside the solver (an event's impulse) to body `i`,
    /// to the velocities the world sees too, so it reads the blow at once.
    pub(super) fn kick(&mut self, i: usize, dv: Vec3, dw: Vec3) {
        if self.ragdolls[self.ragdoll_of[i]].removed {
            return;
        }
        self.wake_body(i);
        self.thaw_on_kick(i, dv, dw);
        self.vel[i] += dv;
        self.angvel[i] += dw;
        self.seen_vel[i] += dv;
        self.seen_angvel[i] += dw;
    }

    /// Wakes ragdoll of body `i`.
    pub(super) fn wake_body(&mut self, i: usize) {
        if let Some(&r) = self.ragdoll_of.get(i) {
            self.wake(r);
        }
    }

    /// Wakes ragdoll `r`, with every joint thawed: what woke it may move any of them.
    pub(super) fn wake(&mut self, r: usize) {
        if self.ragdolls[r].removed {
            return;
        }
        if self.ragdolls[r].asleep {
            self.thaw(r);
        }
        let rd = &mut self.ragdolls[r];
        rd.asleep = false;
        rd.still_s = None;
    }

    /// Recomputes whether something outside holds ragdoll `r` (a kinematic body, a drive,
    /// an active pin), and wakes it if so. One ragdoll's, not the world's: a crowd
    /// standing on its clip sets every body kinematic one at a time, and recomputing
    /// every ragdoll each time was quadratic (16,000 bodies of 1,000 humanoids times
    /// 32,000 bodies and joints).
    pub(super) fn update_held(&mut self, r: usize) {
        let Some(rd) = self.ragdolls.get(r) else {
            return;
        };
        let held = self.kinematic[rd.bodies.clone()]
            .iter()
            .any(Option::is_some)
            || self.joints[rd.joints.clone()]
                .iter()
                .any(|j| j.drive.is_some())
            || self
                .pins
                .iter()
                .any(|p| p.active && self.ragdoll_of[p.body] == r);
        self.ragdolls[r].held = held;
        if held {
            self.wake(r);
        }
    }

    pub(super) fn set_mass_of(&mut self, i: usize, kinematic: bool) {
        if kinematic {
            self.inv_mass[i] = 0.0;
            self.inv_inertia[i] = Vec3::ZERO;
        } else {
            self.inv_mass[i] = 1.0 / self.mass[i];
            self.inv_inertia[i] = self.inertia[i].recip();
        }
        self.refresh_inertia(i);
    }
}
