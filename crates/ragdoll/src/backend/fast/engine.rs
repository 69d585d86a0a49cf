//! The fast engine as the world sees it: the [`Backend`] trait over the solver's arrays,
//! ragdolls added and removed between any two steps.

use glam::{Quat, Vec3};

use super::*;
use crate::backend::{
    Backend, BodyDesc, BodyId, BodyState, Command, JointDesc, JointId, PinId, SkinPointDesc,
    StepReport, apply_each,
};

impl Backend for FastBackend {
    fn add_ragdoll(
        &mut self,
        bodies: &[BodyDesc],
        joints: &[JointDesc],
        disabled_pairs: &[(usize, usize)],
    ) -> BodyId {
        let first = self.pos.len();
        let r = self.ragdolls.len();
        for b in bodies {
            let mass = b.mass.max(1.0e-6);
            let i = crate::geometry::body_inertia(&b.shape, &b.extra_shapes, mass);
            let inertia =
                Vec3::new(i.x_axis.x, i.y_axis.y, i.z_axis.z).max(Vec3::splat(MIN_INERTIA));
            self.pos.push(b.pose.translation);
            self.rot.push(b.pose.rotation.normalize());
            self.prev_pos.push(b.pose.translation);
            self.prev_rot.push(b.pose.rotation.normalize());
            self.moved.push(Vec3::ZERO);
            self.pred_rot.push(b.pose.rotation.normalize());
            self.vel.push(b.linvel);
            self.angvel.push(b.angvel);
            self.step_pos.push(b.pose.translation);
            self.step_rot.push(b.pose.rotation.normalize());
            self.seen_vel.push(b.linvel);
            self.seen_angvel.push(b.angvel);
            self.rest_pos.push(b.pose.translation);
            self.rest_rot.push(b.pose.rotation.normalize());
            self.mass.push(mass);
            self.inv_mass.push(1.0 / mass);
            self.inertia.push(inertia);
            self.inv_inertia.push(inertia.recip());
            self.inv_inertia_world.push(glam::Mat3A::ZERO);
            self.shape.push(b.shape);
            self.owner.push(self.pos.len() as u32 - 1);
            self.attach.push(None);
            self.kinematic.push(None);
            self.holder.push(contact::NOTHING);
            self.ragdoll_of.push(r);
            self.refresh_inertia(self.pos.len() - 1);
            self.add_extras(self.pos.len() - 1, &b.extra_shapes);
        }
        let pair = |a: usize, b: usize| {
            let (a, b) = ((first + a) as u32, (first + b) as u32);
            (a.min(b), a.max(b))
        };
        self.floor_inertia_by_anchors(first, joints);
        let links: Vec<(usize, usize)> = joints.iter().map(|j| (j.parent, j.child)).collect();
        let hub = crate::backend::hub::hub_relaxation(&self.mass[first..], &links);
        for j in joints {
            self.joints.push(Joint {
                a: first + j.parent,
                b: first + j.child,
                frame_a: j.frame_parent,
                frame_b: j.frame_child,
                limits: Limits::of(&j.kind),
                drive: None,
                relax: hub[j.parent].min(hub[j.child]),
                frozen: false,
                quiet_s: 0.0,
                quiet_rel: Quat::IDENTITY,
            });
            self.disabled.insert(pair(j.parent, j.child));
        }
        for &(a, b) in disabled_pairs {
            self.disabled.insert(pair(a, b));
        }
        if let Some(limits) = &mut self.limits {
            limits.add_ragdoll(first, bodies, joints);
        }
        self.damping.add_ragdoll(first, bodies, joints);
        self.ragdolls.push(Ragdoll {
            bodies: first..first + bodies.len(),
            joints: self.joints.len() - joints.len()..self.joints.len(),
            asleep: false,
            still_s: None,
            held: false,
            substep_factor: substep_factor(&self.mass[first..]),
            frozen: 0,
            jolted: false,
            closing_mps: 0.0,
            tests: 0,
            removed: false,
        });
        BodyId(first)
    }

    fn remove_ragdoll(&mut self, BodyId(first_body): BodyId) -> bool {
        let Some(&r) = self.ragdoll_of.get(first_body) else {
            return false;
        };
        for i in self.ragdolls[r].bodies.clone() {
            self.vel[i] = Vec3::ZERO;
            self.angvel[i] = Vec3::ZERO;
            self.seen_vel[i] = Vec3::ZERO;
            self.seen_angvel[i] = Vec3::ZERO;
            self.kinematic[i] = None;
        }
        for p in &mut self.pins {
            if self.ragdoll_of[p.body] == r {
                p.active = false;
            }
        }
        let rd = &mut self.ragdolls[r];
        rd.asleep = true;
        rd.removed = true;
        if let Some(limits) = &mut self.limits {
            limits.remove_ragdoll(first_body);
        }
        self.damping.remove_ragdoll(first_body);
        true
    }

    fn add_skin_points(&mut self, BodyId(first_body): BodyId, points: &[SkinPointDesc]) -> bool {
        self.add_skin_points_impl(first_body, points);
        true
    }

    fn step(&mut self, dt: f32) -> StepReport {
        self.damp_joints(dt);
        self.step_impl(dt);
        StepReport {
            max_penetration_m: self.collide.max_penetration,
            limit_violation_before_clamp_rad: self.project_limits(),
            joint_separation_before_clamp_m: None,
            went_non_finite: false,
        }
    }

    fn body_states(&self, out: &mut Vec<BodyState>) {
        out.clear();
        out.extend((0..self.pos.len()).map(|i| self.state_of(i)));
    }

    fn body_states_of(&self, BodyId(first): BodyId, out: &mut [BodyState]) {
        let n = self.pos.len();
        for (o, i) in out.iter_mut().zip(first..n) {
            *o = self.state_of(i);
        }
    }

    // Of the solver's own velocities, at the end of the step where the poses are: the
    // step's average motion (what the world sees) runs half a step behind, and read with
    // the end poses it undercounted a falling body's energy by m·v·g·dt/2, a fall's 2-4 %
    // that came back as a "gain" on landing. A resting body's substep jitter is a few
    // hundredths of a joule.
    fn kinetic_energy(&self) -> f64 {
        (0..self.pos.len())
            .map(|i| {
                let w = self.rot[i].conjugate() * self.angvel[i];
                let m = self.mass[i] as f64;
                0.5 * m * self.vel[i].length_squared() as f64
                    + 0.5 * w.dot(self.inertia[i] * w) as f64
            })
            .sum()
    }

    fn cast_ray(&self, origin: Vec3, dir: Vec3, max_dist: f32) -> Option<(BodyId, f32)> {
        self.cast_ray_impl(origin, dir, max_dist)
            .map(|(b, d)| (BodyId(b), d))
    }

    fn active_joints(&self) -> Option<usize> {
        Some(
            self.ragdolls
                .iter()
                .filter(|r| !r.asleep)
                .map(|r| r.joints.len() - r.frozen)
                .sum(),
        )
    }

    fn add_pin(
        &mut self,
        BodyId(index): BodyId,
        local: Vec3,
        target: Vec3,
        soft: Option<(f32, f32)>,
    ) -> PinId {
        self.pins.push(Pin {
            body: index,
            local,
            from: target,
            to: target,
            soft,
            active: true,
        });
        self.update_held(self.ragdoll_of[index]);
        PinId(self.pins.len() - 1)
    }

    fn bodies_touching_other_ragdolls(&self, out: &mut Vec<bool>) {
        out.clear();
        out.extend_from_slice(&self.collide.touching);
        out.resize(self.pos.len(), false);
    }

    fn drive_joint(
        &mut self,
        JointId(index): JointId,
        target: Quat,
        target_angvel: Vec3,
        stiffness: f32,
        damping: f32,
    ) {
        let Some(j) = self.joints.get_mut(index) else {
            return;
        };
        let had = j.drive.is_some();
        j.drive = (stiffness > 0.0 || damping > 0.0).then_some(Drive {
            target: target.normalize(),
            angvel: target_angvel,
            stiffness: stiffness.max(0.0),
            damping: damping.max(0.0),
        });
        if had != j.drive.is_some() {
            let b = j.b;
            self.update_held(self.ragdoll_of[b]);
        }
    }

    fn apply(&mut self, commands: &[Command]) {
        apply_each(self, commands);
    }
}
