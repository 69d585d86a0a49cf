//! Recording and measuring: output frames from the bodies' states and the quality
//! metrics (the guide's report reference).

use glam::Vec3;

use crate::backend::{Backend, BodyState};
use crate::math::Transform;
use crate::spec::ResolvedJoint;
use rayon::prelude::*;

impl super::World {
    pub(super) fn record_frames_until(&mut self, t: f64) {
        let fps = self.settings.fps as f64;
        let dt = self.settings.dt as f64;
        loop {
            let ft = self.frames_recorded as f64 / fps;
            if ft > t + 1e-9 {
                break;
            }
            // Interpolate between the previous and the current step.
            let alpha = if t <= 0.0 {
                1.0
            } else {
                (((ft - (t - dt)) / dt).clamp(0.0, 1.0)) as f32
            };
            let (prev, now) = (&self.prev_states, &self.states);
            // Instances record independently: in parallel (a crowd of 1,000 records
            // 19,000 joints a frame).
            let stretch = self
                .instances
                .par_iter_mut()
                .map(|inst| {
                    if !inst.active
                        && let Some(play) = &inst.playback
                    {
                        let mut frame = Vec::new();
                        play.joint_world(ft, &mut frame);
                        inst.track.frames.push(frame);
                        return 0.0;
                    }
                    let frame: Vec<Transform> = inst
                        .riders
                        .iter()
                        .map(|r| {
                            let a = &prev[inst.first_body + r.body].pose;
                            let b = &now[inst.first_body + r.body].pose;
                            let pose = Transform::new(
                                a.translation.lerp(b.translation, alpha),
                                a.rotation.slerp(b.rotation, alpha),
                            );
                            pose.mul(&r.offset)
                        })
                        .collect();
                    let stretch = bone_stretch(&inst.held_bones, &mut inst.bone_lengths, &frame);
                    inst.track.frames.push(frame);
                    stretch
                })
                .reduce(|| 0.0f32, f32::max);
            self.metrics.max_bone_stretch = self.metrics.max_bone_stretch.max(stretch);
            if !stretch.is_finite() {
                self.metrics.nan = true;
            }
            self.frames_recorded += 1;
            if let Some(n) = self.backend.active_joints() {
                self.active_joints.push(n.min(u32::MAX as usize) as u32);
            }
            self.measure_frame_energy();
        }
    }

    pub(super) fn measure_step(&mut self) {
        let m = &mut self.metrics;
        m.max_penetration_m = m.max_penetration_m.max(self.step_report.max_penetration_m);
        for s in &self.states {
            if !(s.pose.is_finite() && s.linvel.is_finite() && s.angvel.is_finite()) {
                m.nan = true;
            }
        }
        let separation = worst_joint(&self.instances, &self.states, |j, p, c| j.separation(p, c));
        m.max_joint_separation_m = m.max_joint_separation_m.max(separation);
        let now = self.limit_violation_now().to_degrees();
        let m = &mut self.metrics;
        m.max_limit_violation_deg = m.max_limit_violation_deg.max(now);
    }

    /// The worst limit violation of the physical ragdolls' joints in the current states,
    /// radians.
    pub(super) fn limit_violation_now(&self) -> f32 {
        worst_joint(&self.instances, &self.states, |j, p, c| j.violation(p, c))
    }

    /// Whether every blast has gone off and passed every body part, every projectile has
    /// been fired, and pins, pushes, fields and motors are over (the drift metric measures the
    /// energy drift only after the last event).
    fn events_done(&self) -> bool {
        use crate::events::Field;
        let t = self.time;
        // Pins hold until released; pushes and fields until their windows end; gravity
        // fields change what potential energy means, so they never end.
        let forces_done = self.pins.iter().all(|p| p.released)
            && self.pushes.iter().all(|p| p.done)
            && self.fields.iter().all(|f| match f {
                Field::Gravity { .. } => false,
                Field::Radial { end_s, .. }
                | Field::Drag { end_s, .. }
                | Field::Wind { end_s, .. } => (*end_s as f64) <= t,
            });
        // Motors put energy in on purpose until they have faded out for good.
        let motors_done = self.instances.iter().all(|i| {
            i.motors.as_ref().is_none_or(|m| {
                let keys = &m.motors.strength_keys;
                keys.last()
                    .is_some_and(|&(time, strength)| strength == 0.0 && (time as f64) <= t)
            })
        });
        // A projectile puts its momentum in when it is fired (its report is then written).
        let shots_done = self.projectiles.iter().all(|(_, report)| report.is_some());
        forces_done
            && shots_done
            && motors_done
            && self.instances.iter().all(|i| i.active)
            && self.blasts.iter().all(|b| {
                // Removed ragdolls are passed by.
                let present = || {
                    b.parts
                        .iter()
                        .zip(&self.instances)
                        .filter(|(_, i)| !i.removed)
                        .flat_map(|(parts, _)| parts)
                };
                b.parts.len() == self.instances.len()
                    && present().all(|r| r.arrival_s.is_some() && r.passed_s <= self.time)
            })
    }

    fn measure_frame_energy(&mut self) {
        if !self.events_done() {
            // Events put energy in on purpose; measure from the first frame after them.
            self.start_energy = None;
            self.last_frame_energy = None;
            return;
        }
        let g = self.settings.gravity;
        let ground = self.settings.ground.unwrap_or(0.0);
        let mut potential = 0.0f64;
        for inst in self.instances.iter().filter(|i| !i.removed) {
            for (i, &m) in inst.masses.iter().enumerate() {
                let p = self.states[inst.first_body + i].pose.translation - Vec3::Y * ground;
                potential += -(m as f64) * g.dot(p) as f64;
            }
        }
        let e = potential + self.backend.kinetic_energy();
        let e0 = *self.start_energy.get_or_insert(e);
        if let Some(last) = self.last_frame_energy {
            let rise = (e - last) / e0.abs().max(1e-9);
            if rise.is_finite() {
                self.metrics.energy_drift = self.metrics.energy_drift.max(rise.max(0.0) as f32);
            } else {
                self.metrics.nan = true;
            }
        }
        self.last_frame_energy = Some(e);
    }
}

/// Bones shorter than this are left out of the stretch, metres: a zero-length bone (two
/// joints at one place) has no relative change.
const MIN_BONE_M: f32 = 1.0e-3;

/// Largest relative change of a bone's length in `frame` from `lengths` (taken from this
/// frame when empty): what [`Metrics::max_bone_stretch`](crate::track::Metrics::max_bone_stretch) records. Backend-independent, so
/// it measures both backends alike.
/// The largest `measure` of any joint of the physical ragdolls among `instances` in the
/// `states` (0 for none), instances in parallel.
fn worst_joint(
    instances: &[super::Instance],
    states: &[BodyState],
    measure: impl Fn(&ResolvedJoint, &Transform, &Transform) -> f32 + Sync,
) -> f32 {
    instances
        .par_iter()
        .map(|inst| worst_joint_of(inst, states, &measure))
        .reduce(|| 0.0f32, f32::max)
}

/// The largest `measure` of the joints of `inst`, 0 unless it is physical.
fn worst_joint_of(
    inst: &super::Instance,
    states: &[BodyState],
    measure: &impl Fn(&ResolvedJoint, &Transform, &Transform) -> f32,
) -> f32 {
    if !inst.active || inst.removed {
        return 0.0;
    }
    let states = &states[inst.first_body..inst.first_body + inst.masses.len()];
    inst.joints
        .iter()
        .map(|j| measure(j, &states[j.parent].pose, &states[j.child].pose))
        .fold(0.0f32, f32::max)
}

fn bone_stretch(parents: &[Option<usize>], lengths: &mut Vec<f32>, frame: &[Transform]) -> f32 {
    let length = |j: usize| {
        parents[j].map_or(0.0, |p| {
            (frame[j].translation - frame[p].translation).length()
        })
    };
    if lengths.is_empty() {
        lengths.extend((0..frame.len()).map(length));
        return 0.0;
    }
    let mut worst = 0.0f32;
    for (j, &l0) in lengths.iter().enumerate() {
        if l0 > MIN_BONE_M {
            worst = worst.max((length(j) - l0).abs() / l0);
        }
    }
    worst
}
