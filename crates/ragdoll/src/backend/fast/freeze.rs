//! Joint freezing, the fast backend's level of detail below sleep: a joint whose two
//! bodies have stopped turning relative to each other is frozen, and the bodies it links
//! move as one rigid compound until a blow arrives (after Redon et al. 2005, "Adaptive
//! dynamics of articulated bodies": the simulation, not the user, picks which joints stay
//! active, from how they move).
//!
//! Redon et al. measure each joint's share of the motion through the articulated-body
//! equations; this solver has none, so a joint's importance is read from what it did: a
//! joint that turned less than [`FREEZE_SPIN_RADPS`] and drifted less than
//! [`FREEZE_DRIFT_RAD`] for [`FREEZE_AFTER_S`] is held by its limits, by contacts or by
//! balance, and holding it rigid changes nothing the eye or the metrics can tell. What
//! would make it move again is a blow: an event's impulse, or a contact or a joint that
//! changes a compound's velocity by more than [`THAW_MPS`] in one step beyond what gravity
//! gives (a landing, another ragdoll running into it). Either thaws every joint of the
//! ragdoll, which must then be quiet again before it freezes. Held ragdolls (pins, drives,
//! kinematic parts) never freeze.
//!
//! A compound is one body of the island's solver: its mass, centre of mass and inertia
//! tensor (on its principal axes) are its parts', its velocity and spin carry their
//! momentum and angular momentum, and the parts' shapes stay its shapes, each at its
//! place. Its joints to the rest of the ragdoll are solved on it, and frozen joints are
//! not solved at all: that is the saving. Each step builds the compounds again from the
//! parts' poses, so nothing of them outlives the step but the frozen flags.

use glam::{Quat, Vec3};

use super::solve::rotation_vector;
use super::{FastBackend, MIN_INERTIA};
use crate::math::Transform;

/// Most a joint's bodies may turn relative to each other, rad/s, for it to count as quiet:
/// a hand 20 cm from its wrist then moves under 4 cm/s relative to the forearm, a little
/// under the 5 cm/s a ragdoll may drift and still fall asleep.
const FREEZE_SPIN_RADPS: f32 = 0.2;
/// Most a quiet joint may turn in all from where its quiet spell began, radians (2°): a
/// slow sag under the spin limit is still motion.
const FREEZE_DRIFT_RAD: f32 = 0.035;
/// How long a joint must stay quiet before it is frozen, seconds.
const FREEZE_AFTER_S: f32 = 0.25;
/// A velocity change, m/s, in one step (beyond gravity's) of any point of a compound, or
/// from one event impulse on any body, that thaws the ragdoll: three times gravity's
/// change over a 1/60 s step, so a compound resting, or sliding to a stop on friction
/// (0.7 g), stays frozen, and landing from 1.3 cm up or being run into does not.
const THAW_MPS: f32 = 0.5;

/// A compound an island's solver holds, with what it needs to tell whether it took a
/// blow over the step.
#[derive(Clone, Copy, Debug)]
pub(super) struct Compound {
    /// Its body and ragdoll in the island's solver.
    body: usize,
    ragdoll: usize,
    /// Farthest any of its shapes reaches from its centre, metres.
    lever: f32,
    /// Its velocity and spin at the start of the step.
    vel: Vec3,
    angvel: Vec3,
}

impl FastBackend {
    /// Watches every awake ragdoll's joints after a step: quiet ones freeze, and a ragdoll
    /// that took a blow, or is held, thaws.
    pub(super) fn update_freezing(&mut self, dt: f32) {
        if !self.settings.freeze_joints {
            return;
        }
        for r in 0..self.ragdolls.len() {
            let rd = &self.ragdolls[r];
            if rd.asleep {
                continue;
            }
            if rd.held || rd.jolted {
                self.ragdolls[r].jolted = false;
                self.thaw(r);
                if self.ragdolls[r].held {
                    continue;
                }
            }
            for k in self.ragdolls[r].joints.clone() {
                if self.watch_joint(k, dt) {
                    self.ragdolls[r].frozen += 1;
                }
            }
        }
    }

    /// Thaws, before the step, every frozen ragdoll that may strike something in it: one
    /// of its shapes may reach the ground, or a candidate pair links it to a body, and
    /// closes on it faster than [`THAW_MPS`]. Thawed only after the step, its landing was
    /// taken whole by one rigid body, and the parts then set free with that blow's spin
    /// pulled their joints 14-19° past their limits and 10-15 mm apart in the pile bench
    /// (5.9° and 9 mm with no freezing).
    pub(super) fn thaw_before_impacts(&mut self) {
        for r in 0..self.ragdolls.len() {
            if self.ragdolls[r].closing_mps > THAW_MPS {
                self.thaw(r);
            }
        }
    }

    /// Times joint `k`'s quiet spell; returns whether it froze now.
    fn watch_joint(&mut self, k: usize, dt: f32) -> bool {
        let j = &self.joints[k];
        if j.frozen {
            return false;
        }
        let rel =
            (self.rot[j.a] * j.frame_a.rotation).conjugate() * (self.rot[j.b] * j.frame_b.rotation);
        let spin = (self.seen_angvel[j.b] - self.seen_angvel[j.a]).length();
        let drift = rotation_vector(rel * j.quiet_rel.conjugate()).length();
        let j = &mut self.joints[k];
        if spin < FREEZE_SPIN_RADPS && drift < FREEZE_DRIFT_RAD {
            j.quiet_s += dt;
            j.frozen = j.quiet_s >= FREEZE_AFTER_S;
        } else {
            j.quiet_s = 0.0;
            j.quiet_rel = rel.normalize();
        }
        j.frozen
    }

    /// Thaws every joint of ragdoll `r`.
    pub(super) fn thaw(&mut self, r: usize) {
        if self.ragdolls[r].frozen == 0 {
            return;
        }
        self.ragdolls[r].frozen = 0;
        for k in self.ragdolls[r].joints.clone() {
            let j = &mut self.joints[k];
            j.frozen = false;
            j.quiet_s = 0.0;
        }
    }

    /// Thaws the ragdoll of body `i` if an event's velocity change `dv`, `dw` there is a
    /// blow.
    pub(super) fn thaw_on_kick(&mut self, i: usize, dv: Vec3, dw: Vec3) {
        if dv.length() + dw.length() * self.body_reach(i) > THAW_MPS {
            self.thaw(self.ragdoll_of[i]);
        }
    }

    /// Adds ragdoll `r`'s bodies to the island solver `sub` as compounds, one per set of
    /// bodies its frozen joints link (a body alone is copied as it is), and records in
    /// `local` the shape each of its bodies became there.
    pub(super) fn gather_compounds(&self, r: usize, sub: &mut FastBackend, local: &mut [u32]) {
        let bodies = self.ragdolls[r].bodies.clone();
        let first = bodies.start;
        // Each body's set, as the lowest body of its set, by union over the frozen joints.
        let mut set: Vec<usize> = (0..bodies.len()).collect();
        let root = |set: &[usize], mut k: usize| {
            while set[k] != k {
                k = set[k];
            }
            k
        };
        for j in &self.joints[self.ragdolls[r].joints.clone()] {
            if j.frozen {
                let (a, b) = (root(&set, j.a - first), root(&set, j.b - first));
                set[a.max(b)] = a.min(b);
            }
        }
        for k in 0..set.len() {
            set[k] = root(&set, k);
        }
        let ragdoll = sub.ragdolls.len();
        for k in 0..set.len() {
            if set[k] != k {
                continue;
            }
            let members: Vec<usize> = (0..set.len())
                .filter(|&m| set[m] == k)
                .map(|m| first + m)
                .collect();
            if let [i] = members[..] {
                sub.push_body_of(self, i, ragdoll);
                local[i] = sub.shape.len() as u32 - 1;
                self.push_extras_of(i, sub, sub.pos.len() - 1, None, local);
            } else {
                self.push_compound(&members, sub, ragdoll, local);
            }
        }
    }

    /// Adds the bodies `members` to `sub` as one compound body.
    fn push_compound(
        &self,
        members: &[usize],
        sub: &mut FastBackend,
        ragdoll: usize,
        local: &mut [u32],
    ) {
        let mass: f32 = members.iter().map(|&i| self.mass[i]).sum();
        let centre = members
            .iter()
            .map(|&i| self.pos[i] * self.mass[i])
            .sum::<Vec3>()
            / mass;
        let vel = members
            .iter()
            .map(|&i| self.vel[i] * self.mass[i])
            .sum::<Vec3>()
            / mass;
        // Inertia tensor about the centre and angular momentum about it, in f64: the
        // parallel-axis terms of far parts dwarf a thin part's own.
        let mut tensor = [[0.0f64; 3]; 3];
        let mut momentum = glam::DVec3::ZERO;
        for &i in members {
            let own = glam::DMat3::from_quat(self.rot[i].as_dquat());
            let diag = glam::DMat3::from_diagonal(self.inertia[i].as_dvec3());
            let world = own * diag * own.transpose();
            let d = (self.pos[i] - centre).as_dvec3();
            let m = f64::from(self.mass[i]);
            let shifted = world
                + (glam::DMat3::from_diagonal(glam::DVec3::splat(d.length_squared()))
                    - glam::DMat3::from_cols(d * d.x, d * d.y, d * d.z))
                    * m;
            for (c, col) in tensor.iter_mut().enumerate() {
                for (r, x) in col.iter_mut().enumerate() {
                    *x += shifted.col(c)[r];
                }
            }
            momentum +=
                world * self.angvel[i].as_dvec3() + d.cross((self.vel[i] - vel).as_dvec3()) * m;
        }
        let (axes, moments) = crate::math::symmetric_eigen(tensor);
        let rot = Quat::from_mat3(&glam::Mat3::from_cols(axes[0], axes[1], axes[2])).normalize();
        let inertia = Vec3::from_array(moments).max(Vec3::splat(MIN_INERTIA));
        let momentum_local = rot.conjugate() * momentum.as_vec3();
        let angvel = rot * (momentum_local / inertia);
        let body = sub.pos.len();
        sub.push_body(
            Transform::new(centre, rot),
            vel,
            angvel,
            mass,
            inertia,
            ragdoll,
        );
        let mut lever = 0.0f32;
        for &i in members {
            let attach = Transform::new(
                rot.conjugate() * (self.pos[i] - centre),
                (rot.conjugate() * self.rot[i]).normalize(),
            );
            lever = lever.max(attach.translation.length() + self.body_reach(i));
            local[i] = sub.shape.len() as u32;
            sub.shape.push(self.shape[i]);
            sub.owner.push(body as u32);
            sub.attach.push(Some(attach));
            sub.holder.push(super::contact::NOTHING);
            self.push_extras_of(i, sub, body, Some(attach), local);
        }
        sub.compounds.push(Compound {
            body,
            ragdoll,
            lever,
            vel,
            angvel,
        });
    }

    /// Adds a dynamic body without shapes, at rest in its pose.
    fn push_body(
        &mut self,
        pose: Transform,
        vel: Vec3,
        angvel: Vec3,
        mass: f32,
        inertia: Vec3,
        ragdoll: usize,
    ) {
        let (p, q) = (pose.translation, pose.rotation);
        macro_rules! push {
            ($value:expr => $($f:ident),*) => { $( self.$f.push($value); )* };
        }
        push!(p => pos, prev_pos, step_pos);
        self.moved.push(Vec3::ZERO);
        push!(q => rot, prev_rot, pred_rot, step_rot);
        push!(vel => vel, seen_vel);
        push!(angvel => angvel, seen_angvel);
        self.mass.push(mass);
        self.inv_mass.push(1.0 / mass);
        self.inertia.push(inertia);
        self.inv_inertia.push(inertia.recip());
        self.inv_inertia_world.push(glam::Mat3A::ZERO);
        self.kinematic.push(None);
        self.ragdoll_of.push(ragdoll);
        self.refresh_inertia(self.pos.len() - 1);
    }

    /// Marks the ragdolls whose compounds took a blow over the step just solved.
    pub(super) fn check_jolts(&mut self, dt: f32) {
        let g = self.settings.gravity * dt;
        for k in 0..self.compounds.len() {
            let c = self.compounds[k];
            let dv = self.vel[c.body] - c.vel - g;
            let dw = self.angvel[c.body] - c.angvel;
            if dv.length() + dw.length() * c.lever > THAW_MPS {
                self.ragdolls[c.ragdoll].jolted = true;
            }
        }
    }

    /// Sets body `i` (of this, the whole world's solver) from the compound that carried
    /// it in `sub` as shape `c`, its pose at the start of the step giving the motion the
    /// world sees.
    pub(super) fn part_from_compound(&mut self, i: usize, sub: &FastBackend, c: usize, dt: f32) {
        let (Some(attach), o) = (sub.attach[c], sub.owner[c] as usize) else {
            return;
        };
        let r = sub.rot[o] * attach.translation;
        let (pos, rot) = (sub.pos[o] + r, (sub.rot[o] * attach.rotation).normalize());
        let inv = 1.0 / dt;
        self.seen_vel[i] = (pos - self.pos[i]) * inv;
        self.seen_angvel[i] = rotation_vector(rot * self.rot[i].conjugate()) * inv;
        self.pos[i] = pos;
        self.rot[i] = rot;
        self.vel[i] = sub.vel[o] + sub.angvel[o].cross(r);
        self.angvel[i] = sub.angvel[o];
        self.refresh_inertia(i);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_compound_carries_its_parts_momentum() {
        // Two bodies side by side, spinning and moving differently: the compound of the
        // two has their total momentum and angular momentum.
        let mut w = FastBackend::with_settings(super::super::FastSettings {
            gravity: Vec3::ZERO,
            ground: None,
            substeps: 4,
            iterations: 1,
            impact_passes: 0,
            freeze_joints: true,
            keep_contacts: false,
        });
        let shape = crate::spec::Shape::Capsule {
            radius_m: 0.05,
            length_m: 0.3,
        };
        for (x, v, spin) in [(0.0, 1.0, 2.0), (0.5, -0.5, -1.0)] {
            w.push_body(
                Transform::new(Vec3::new(x, 1.0, 0.0), Quat::from_rotation_z(0.3 * x)),
                Vec3::new(0.0, v, 0.2),
                Vec3::new(0.0, 0.0, spin),
                2.0 + x,
                crate::geometry::shapes::inertia_of(&shape, 2.0 + x).diagonal(),
                0,
            );
            w.shape.push(shape);
        }
        let mut sub = FastBackend::with_settings(w.settings);
        let mut local = vec![0u32; 2];
        w.push_compound(&[0, 1], &mut sub, 0, &mut local);
        let momentum = |b: &FastBackend, i: usize| b.vel[i] * b.mass[i];
        let angular = |b: &FastBackend, i: usize, about: Vec3| {
            let world = b.rot[i] * (b.inertia[i] * (b.rot[i].conjugate() * b.angvel[i]));
            world + (b.pos[i] - about).cross(b.vel[i] * b.mass[i])
        };
        let p = momentum(&w, 0) + momentum(&w, 1);
        let l = angular(&w, 0, Vec3::ZERO) + angular(&w, 1, Vec3::ZERO);
        assert!((momentum(&sub, 0) - p).length() < 1e-5, "{p}");
        assert!((angular(&sub, 0, Vec3::ZERO) - l).length() < 1e-4, "{l}");
        // Each part is where it was, in the compound's frame.
        for (i, &c) in local.iter().enumerate() {
            let (pos, rot) = sub.shape_pose(c as usize);
            assert!((pos - w.pos[i]).length() < 1e-5);
            assert!(rot.angle_between(w.rot[i]) < 1e-3);
        }
    }
}
