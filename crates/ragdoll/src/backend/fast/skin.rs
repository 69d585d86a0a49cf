//! Skin points on the ground ([`crate::spec::skin_points`]): a point of skin
//! several bodies carry is where linear blend skinning puts it, `p = Σ wₖ (xₖ + Rₖ lₖ)`,
//! and its contact with the ground is one XPBD constraint on all of them: `C = p·n − g`,
//! whose gradient moves body `k` by `wₖ` of the correction, so its generalised inverse
//! mass is `Σ wₖ² wₖ(rₖ, n)` (Müller et al. 2020, §3.3, with the `wₖ` as the constraint's
//! chain rule). Friction and restitution 0 are those of a contact between two bodies
//! (`contact.rs`), on the blended point.

use glam::{Quat, Vec3};

use super::island::NO_ISLAND;
use super::{FRICTION, FastBackend};
use crate::backend::SkinPointDesc;
use crate::math::Transform;

/// Most bodies one point blends: a vertex's four joints. Parts past these are dropped.
const PARTS: usize = 4;
/// How far above the ground a skin point may be at the start of a step and still be
/// solved in it, beyond what its bodies' motion can carry it in the step, metres.
const SKIN_SLOP_M: f32 = 0.01;

/// A skin point: up to [`PARTS`] bodies, each with its weight and the point in its frame.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct SkinPoint {
    parts: [(u32, f32, Vec3); PARTS],
    len: u8,
}

impl SkinPoint {
    fn parts(&self) -> &[(u32, f32, Vec3)] {
        &self.parts[..self.len as usize]
    }

    /// Adds body `b`'s share `w` at `local`; a body already in the point (two parts of one
    /// compound, `freeze.rs`) takes it into its own part, at the weighted mean of the two
    /// places (both in its frame, so the blend is the same point).
    fn add(&mut self, b: u32, w: f32, local: Vec3) {
        let n = self.len as usize;
        if let Some(part) = self.parts[..n].iter_mut().find(|p| p.0 == b) {
            let sum = part.1 + w;
            if sum > 0.0 {
                part.2 = (part.2 * part.1 + local * w) / sum;
            }
            part.1 = sum;
        } else if n < PARTS {
            self.parts[n] = (b, w, local);
            self.len += 1;
        }
    }
}

impl FastBackend {
    pub(super) fn add_skin_points_impl(&mut self, first: usize, points: &[SkinPointDesc]) {
        for p in points {
            let mut point = SkinPoint::default();
            for &(b, w, local) in &p.parts {
                let b = first + b;
                if b < self.pos.len() && w.is_finite() && w > 0.0 && local.is_finite() {
                    point.add(b as u32, w, local);
                }
            }
            if point.len > 0 {
                self.skin.push(point);
            }
        }
    }

    /// Copies the skin points of the ragdolls in islands that may reach the ground in
    /// the step of `dt` into their islands' solvers, each part on the body that carries
    /// it there: a scan's thousands of points cost one blend a step each, and only those
    /// near the floor are solved every substep. `local` is each world shape's index in
    /// its island (`island.rs`).
    pub(super) fn gather_skin(&self, subs: &mut [FastBackend], local: &[u32], dt: f32) {
        let Some(g) = self.settings.ground else {
            return;
        };
        let fall = self.settings.gravity.length() * dt * dt;
        for s in &self.skin {
            let island = self.solver_of[self.ragdoll_of[s.parts[0].0 as usize]];
            if island == NO_ISLAND {
                continue;
            }
            let (mut y, mut reach) = (0.0, fall + SKIN_SLOP_M);
            for &(b, w, l) in s.parts() {
                let b = b as usize;
                let r = self.rot[b] * l;
                y += w * (self.pos[b].y + r.y);
                reach += w * (self.vel[b].length() + self.angvel[b].length() * r.length()) * dt;
            }
            if y - g > reach {
                continue;
            }
            let sub = &mut subs[island as usize];
            let mut out = SkinPoint::default();
            for &(b, w, at) in s.parts() {
                let (body, frame) =
                    sub.on_owner(local[b as usize], Transform::new(at, Quat::IDENTITY));
                out.add(body as u32, w, frame.translation);
            }
            sub.skin.push(out);
        }
    }

    /// Where skin point `k` is now and was at the start of the substep, with each part's
    /// offset from its body's centre now.
    fn skin_at(&self, k: usize) -> (Vec3, Vec3, [Vec3; PARTS]) {
        let s = &self.skin[k];
        let (mut now, mut before) = (Vec3::ZERO, Vec3::ZERO);
        let mut r = [Vec3::ZERO; PARTS];
        for (j, &(b, w, l)) in s.parts().iter().enumerate() {
            let b = b as usize;
            r[j] = self.rot[b] * l;
            now += (self.pos[b] + r[j]) * w;
            before += (self.prev_pos[b] + self.prev_rot[b] * l) * w;
        }
        (now, before, r)
    }

    /// The generalised inverse mass of skin point `k` for a push along `n`.
    fn skin_w(&self, k: usize, r: &[Vec3; PARTS], n: Vec3) -> f32 {
        let s = &self.skin[k];
        s.parts()
            .iter()
            .enumerate()
            .map(|(j, &(b, w, _))| w * w * self.w_at(b as usize, r[j], n))
            .sum()
    }

    /// Moves skin point `k`'s bodies so the point goes by `lambda` times `n`'s worth of
    /// its generalised inverse mass, each by its share.
    fn skin_shift(&mut self, k: usize, r: &[Vec3; PARTS], p: Vec3) {
        let s = self.skin[k];
        for (j, &(b, w, _)) in s.parts().iter().enumerate() {
            self.shift(b as usize, r[j], p * w);
        }
    }

    /// Holds the skin points above the ground at height `g`, with static friction; the
    /// ones that touched are kept for the velocity pass.
    pub(super) fn solve_skin_points(&mut self, g: f32) {
        self.skin_touching.clear();
        let n = Vec3::Y;
        for k in 0..self.skin.len() {
            let (now, _, r) = self.skin_at(k);
            let depth = g - now.y;
            if depth <= 0.0 {
                continue;
            }
            let w = self.skin_w(k, &r, n);
            if w <= 0.0 {
                continue;
            }
            self.collide.max_penetration = self.collide.max_penetration.max(depth);
            let lambda = depth / w;
            self.skin_shift(k, &r, n * lambda);
            let (now, before, r) = self.skin_at(k);
            let moved = now - before;
            let slide = moved - n * n.dot(moved);
            let len = slide.length();
            if len > 1.0e-9 {
                let t = slide / len;
                let wt = self.skin_w(k, &r, t);
                if wt > 0.0 {
                    let c = len.min(FRICTION * lambda * wt);
                    self.skin_shift(k, &r, -t * (c / wt));
                }
            }
            for &(b, _, _) in self.skin[k].parts() {
                self.collide.on_ground[b as usize] = true;
            }
            self.skin_touching.push(k as u32);
        }
    }

    /// Restitution 0 on the touching skin points' velocities, as for other contacts.
    pub(super) fn solve_skin_velocities(&mut self) {
        let n = Vec3::Y;
        for i in 0..self.skin_touching.len() {
            let k = self.skin_touching[i] as usize;
            let s = self.skin[k];
            let mut r = [Vec3::ZERO; PARTS];
            let mut vn = 0.0;
            for (j, &(b, w, l)) in s.parts().iter().enumerate() {
                let b = b as usize;
                r[j] = self.rot[b] * l;
                vn += w * n.dot(self.vel[b] + self.angvel[b].cross(r[j]));
            }
            if vn.abs() < 1.0e-9 {
                continue;
            }
            let w = self.skin_w(k, &r, n);
            if w <= 0.0 {
                continue;
            }
            let p = n * (-vn / w);
            for (j, &(b, wk, _)) in s.parts().iter().enumerate() {
                self.push(b as usize, r[j], p * wk);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::backend::{Backend, BodyDesc, JointDesc};
    use crate::spec::{JointKind, Shape};

    /// Two capsules lying along X joined end to end by a ball joint, and a "foot" 0.3 m
    /// under the joint that both carry half of (as bone heat weights a creature's foot
    /// that has no bone), dropped from 0.5 m for 3 s, with freezing `freeze`. Returns
    /// the foot's lowest and last height, and the fastest body at the end.
    fn drop_with_a_foot(skin: bool, freeze: bool) -> (f32, f32, f32) {
        let mut w = FastBackend::with_settings(super::super::FastSettings {
            gravity: Vec3::new(0.0, -9.81, 0.0),
            ground: Some(0.0),
            substeps: 32,
            iterations: 1,
            impact_passes: 3,
            freeze_joints: freeze,
            keep_contacts: false,
        });
        let shape = Shape::Capsule {
            radius_m: 0.05,
            length_m: 0.4,
        };
        let along_x = Quat::from_rotation_z(-std::f32::consts::FRAC_PI_2);
        let body = |x: f32| BodyDesc {
            pose: Transform::new(Vec3::new(x, 0.5, 0.0), along_x),
            shape,
            extra_shapes: Vec::new(),
            mass: 5.0,
            linvel: Vec3::ZERO,
            angvel: Vec3::ZERO,
        };
        // The joint at x = 0, each body's centre 0.25 m from it.
        let at =
            |x: f32| Transform::new(along_x.conjugate() * Vec3::new(x, 0.0, 0.0), Quat::IDENTITY);
        let joint = JointDesc {
            parent: 0,
            child: 1,
            frame_parent: at(0.25),
            frame_child: at(-0.25),
            kind: JointKind::Ball,
        };
        let first = w.add_ragdoll(&[body(-0.25), body(0.25)], &[joint], &[]);
        let foot = |x: f32| along_x.conjugate() * Vec3::new(x, -0.3, 0.0);
        let parts = vec![(0, 0.5, foot(0.25)), (1, 0.5, foot(-0.25))];
        let point = SkinPointDesc { parts };
        if skin {
            assert!(w.add_skin_points(first, std::slice::from_ref(&point)));
        }
        let foot_y = |w: &FastBackend| {
            point
                .parts
                .iter()
                .map(|&(b, s, l)| s * (w.pos[b].y + (w.rot[b] * l).y))
                .sum::<f32>()
        };
        let mut lowest = f32::INFINITY;
        for _ in 0..180 {
            w.step(1.0 / 60.0);
            lowest = lowest.min(foot_y(&w));
        }
        let fastest = w.vel.iter().map(|v| v.length()).fold(0.0, f32::max);
        (lowest, foot_y(&w), fastest)
    }

    #[test]
    fn a_foot_two_bodies_carry_stands_on_the_floor() {
        // Without the point the bodies lie on the floor and the foot hangs 0.25 m under
        // it; with it, the foot stands on the floor and props the bodies up, within the
        // millimetre or two a contact sinks.
        let (lowest, last, _) = drop_with_a_foot(false, true);
        assert!(lowest < -0.2 && last < -0.2, "{lowest} {last}");
        for freeze in [false, true] {
            let (lowest, last, fastest) = drop_with_a_foot(true, freeze);
            assert!(lowest > -0.003, "freeze {freeze}: {lowest}");
            assert!(last.abs() < 0.003, "freeze {freeze}: {last}");
            assert!(
                fastest < 0.01,
                "freeze {freeze}: still moving at {fastest} m/s"
            );
        }
    }

    #[test]
    fn a_body_named_twice_is_one_part_at_the_mean_of_its_places() {
        let mut p = SkinPoint::default();
        p.add(3, 0.25, Vec3::X);
        p.add(5, 0.5, Vec3::Y);
        p.add(3, 0.25, Vec3::Z);
        assert_eq!(p.parts().len(), 2);
        let (b, w, at) = p.parts()[0];
        assert_eq!((b, w), (3, 0.5));
        assert!(at.distance(Vec3::new(0.5, 0.0, 0.5)) < 1e-6);
    }
}
