//! Recording and measuring: output frames from the bodies' states, the rigid backend's
//! limit projection, and the quality metrics (the guide's report reference).

use crate::backend::BodyId;
use crate::backend::Command;
use glam::Vec3;

use crate::backend::{Backend, BodyState};
use crate::math::Transform;
use crate::spec::ResolvedJoint;
use rayon::prelude::*;

/// Violations smaller than this are left to rapier's own (velocity-level) limits, degrees.
/// Projecting every tiny excess made limbs resting against a limit creep (about 1 cm/s):
/// each step the solver let them sink a little and the projection turned them back about
/// the anchor, a ratchet against the floor's friction.
const PROJECTION_TOLERANCE_DEG: f32 = 1.0;

/// How far below the ground the limit projection may move a body that was above it, metres.
const PROJECTION_GROUND_SLACK_M: f32 = 0.005;

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

    /// Clamps every joint back into its limits (see [`WorldSettings::project_limits`](super::WorldSettings::project_limits)).
    ///
    /// Where turning a subtree would sink one of its bodies below the ground (deeper than
    /// it already was, beyond [`PROJECTION_GROUND_SLACK_M`]), the whole ragdoll is lifted
    /// by that much instead: left to the contacts, such a sink came back as 3-6 cm
    /// penetrations in our runs; the lift is a few millimetres, once in a while.
    pub(super) fn project_limits(&mut self) {
        let ground = self.settings.ground;
        // Bodies something outside the ragdoll holds (a pin, a drag, a root kept on its
        // clip): turning one of them would tear it from its holder, whose constraint then
        // yanks it back, a fight that flung a pinned dragon's chain tens of metres. The
        // projection turns the other side of the joint instead.
        let mut held = vec![false; self.states.len()];
        for p in self.pins.iter().filter(|p| !p.released) {
            if let Some(h) = held.get_mut(p.body) {
                *h = true;
            }
        }
        for inst in &self.instances {
            if let Some(m) = &inst.motors
                && m.engaged
                && m.motors.root_on_clip
            {
                held[inst.first_body + m.root] = true;
            }
        }
        // Most ragdolls, most steps, have no joint to turn back: find those that do in
        // parallel (reading only their own states), then turn them one at a time.
        let tolerance = PROJECTION_TOLERANCE_DEG.to_radians();
        let states = &self.states;
        let past: Vec<bool> = self
            .instances
            .par_iter()
            .map(|inst| {
                let s = &states[inst.first_body..inst.first_body + inst.masses.len()];
                inst.active
                    && !inst.removed
                    && inst.joints.iter().any(|j| {
                        // As the loop below: only a violation known to be small is
                        // skipped.
                        let v = j.violation(&s[j.parent].pose, &s[j.child].pose);
                        v >= tolerance || v.is_nan()
                    })
            })
            .collect();
        let to_project = self
            .instances
            .iter()
            .zip(past)
            .filter(|(_, past)| *past)
            .map(|(inst, _)| inst);
        for inst in to_project {
            let base = inst.first_body;
            for &k in &inst.tree.order {
                let j = &inst.joints[k];
                let parent = self.states[base + j.parent].pose;
                let child = self.states[base + j.child].pose;
                if j.violation(&parent, &child) < tolerance {
                    continue;
                }
                let Some(rotation) = j.clamp_child_rotation(&parent, &child) else {
                    continue;
                };
                let full = rotation * child.rotation.conjugate();
                let anchor = child.transform_point(j.frame_child.translation);
                let moved = |p: &Transform, delta: glam::Quat| {
                    Transform::new(
                        anchor + delta * (p.translation - anchor),
                        (delta * p.rotation).normalize(),
                    )
                };
                let subtree = inst.tree.subtree(k);
                let (turned, delta) = if subtree.iter().all(|&b| !held[base + b]) {
                    (subtree.to_vec(), full)
                } else {
                    let rest: Vec<usize> = (0..inst.shapes.len())
                        .filter(|&b| !inst.tree.in_subtree(k, b))
                        .collect();
                    if rest.iter().any(|&b| held[base + b]) {
                        // Held on both sides: the holders decide.
                        continue;
                    }
                    (rest, full.conjugate())
                };
                // How far the turned bodies would sink below the ground beyond the slack
                // (and beyond where they already were): the whole ragdoll is lifted by
                // that much, so the limit wins without pushing a body into the floor.
                let mut lift = 0.0f32;
                if let Some(g) = ground {
                    for &b in &turned {
                        let shape = &inst.shapes[b];
                        let before = shape.lowest_y(&self.states[base + b].pose);
                        let after = shape.lowest_y(&moved(&self.states[base + b].pose, delta));
                        let floor = (g - PROJECTION_GROUND_SLACK_M).min(before);
                        lift = lift.max(floor - after);
                    }
                }
                for &b in &turned {
                    let pose = moved(&self.states[base + b].pose, delta);
                    self.states[base + b].pose = pose;
                    self.backend.apply(&[Command::Pose {
                        body: BodyId(base + b),
                        pose,
                    }]);
                }
                // A held ragdoll is not lifted: its holder would pull it straight back.
                let any_held = (0..inst.shapes.len()).any(|b| held[base + b]);
                if lift > 0.0 && !any_held {
                    for b in 0..inst.shapes.len() {
                        self.states[base + b].pose.translation.y += lift;
                        let pose = self.states[base + b].pose;
                        self.backend.apply(&[Command::Pose {
                            body: BodyId(base + b),
                            pose,
                        }]);
                    }
                }
            }
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
