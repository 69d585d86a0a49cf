//! The runtime half: a [`World`] owns ragdoll instances made from
//! [`RagdollSpec`]s, the ground and a backend; it steps at a fixed rate and
//! records a [`Track`] per ragdoll plus the quality [`Metrics`].

mod measure;

use glam::Vec3;

use crate::backend::rigid::{RigidBackend, RigidSettings};
use crate::backend::{Backend, BodyDesc, BodyState, JointDesc};
use crate::error::{Error, Result};
use crate::math::Transform;
use crate::skeleton::Character;
use crate::spec::{JointKind, RagdollSpec, Shape};
use crate::track::{Metrics, Track};

use measure::JointMeasure;

/// Standard gravity, m/s².
pub const STANDARD_GRAVITY: f32 = 9.80665;

/// Which pose a ragdoll starts in.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum StartPose {
    /// The first frame of the character's first clip, or the rest pose when it has none.
    #[default]
    FirstFrame,
    /// The rest (bind) pose.
    Rest,
}

/// How a world steps and what surrounds the ragdolls.
#[derive(Clone, Debug, PartialEq)]
pub struct WorldSettings {
    /// Fixed physics step, seconds (default 1/60).
    pub dt: f32,
    /// Solver substeps per step (default 8): more keeps joints tighter.
    pub substeps: usize,
    /// Output frames per second of the tracks (default 30).
    pub fps: f32,
    /// Gravity, m/s² (default −9.80665 along Y).
    pub gravity: Vec3,
    /// Height of the ground plane (default `Some(0.0)`: the file's floor); `None` for none.
    pub ground: Option<f32>,
    /// Starting pose (default: the first clip frame).
    pub start: StartPose,
}

impl Default for WorldSettings {
    fn default() -> Self {
        WorldSettings {
            dt: 1.0 / 60.0,
            substeps: 8,
            fps: 30.0,
            gravity: Vec3::new(0.0, -STANDARD_GRAVITY, 0.0),
            ground: Some(0.0),
            start: StartPose::FirstFrame,
        }
    }
}

impl WorldSettings {
    /// Checks the settings a user can set.
    pub fn validate(&self) -> Result<()> {
        let bad = |setting: &str, message: &str| {
            Err(Error::Setting {
                setting: setting.into(),
                message: message.into(),
            })
        };
        if !(self.dt.is_finite() && self.dt > 0.0 && self.dt <= 0.1) {
            return bad("dt", "the step must be between 0 and 0.1 s");
        }
        if !(self.fps.is_finite() && self.fps >= 1.0 && self.fps <= 1000.0) {
            return bad("fps", "frames per second must be between 1 and 1000");
        }
        if self.substeps == 0 || self.substeps > 100 {
            return bad("substeps", "substeps must be between 1 and 100");
        }
        if !self.gravity.is_finite() {
            return bad("gravity", "gravity must be finite");
        }
        Ok(())
    }
}

/// Handle of a ragdoll inside a [`World`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct RagdollId(usize);

/// A skeleton joint follows a body with a fixed offset.
#[derive(Clone, Copy, Debug)]
struct Rider {
    body: usize,
    offset: Transform,
}

struct Instance {
    first_body: usize,
    masses: Vec<f32>,
    joints: Vec<JointMeasure>,
    riders: Vec<Rider>,
    track: Track,
}

/// A simulated world: ragdolls, ground, gravity, a backend, and the tracks being recorded.
pub struct World {
    settings: WorldSettings,
    backend: RigidBackend,
    instances: Vec<Instance>,
    time: f64,
    frames_recorded: usize,
    states: Vec<BodyState>,
    prev_states: Vec<BodyState>,
    metrics: Metrics,
    start_energy: Option<f64>,
    last_frame_energy: Option<f64>,
}

impl World {
    /// An empty world.
    pub fn new(settings: &WorldSettings) -> Result<Self> {
        settings.validate()?;
        let backend = RigidBackend::new(
            RigidSettings {
                gravity: settings.gravity,
                ground: settings.ground,
                substeps: settings.substeps,
            },
            settings.dt,
        );
        Ok(World {
            settings: settings.clone(),
            backend,
            instances: Vec::new(),
            time: 0.0,
            frames_recorded: 0,
            states: Vec::new(),
            prev_states: Vec::new(),
            metrics: Metrics::default(),
            start_energy: None,
            last_frame_energy: None,
        })
    }

    /// A world with one ragdoll: the common case.
    pub fn with_ragdoll(
        character: &Character,
        spec: &RagdollSpec,
        settings: &WorldSettings,
    ) -> Result<(Self, RagdollId)> {
        let mut world = World::new(settings)?;
        let id = world.add_ragdoll(character, spec, Transform::IDENTITY)?;
        Ok((world, id))
    }

    /// Adds a ragdoll built from `spec`, placed by `placement` (a rigid transform applied
    /// to the whole character), lifted so that no body starts below the ground.
    ///
    /// Must be called before the first step.
    pub fn add_ragdoll(
        &mut self,
        character: &Character,
        spec: &RagdollSpec,
        placement: Transform,
    ) -> Result<RagdollId> {
        spec.validate()?;
        if self.frames_recorded > 0 {
            return Err(Error::Setting {
                setting: "ragdoll".into(),
                message: "ragdolls must be added before the world starts stepping".into(),
            });
        }
        let skeleton = &character.skeleton;
        // 1. Which skeleton joint carries each body.
        let mut bone_of_body = Vec::with_capacity(spec.bodies.len());
        for b in &spec.bodies {
            let j = find_label(character, &b.bone).ok_or_else(|| Error::Spec {
                place: format!("body \"{}\".bone", b.name),
                message: format!("the skeleton has no joint named \"{}\"", b.bone),
            })?;
            bone_of_body.push(j);
        }
        // 2. Rest and start poses of every joint, in world space.
        let rest = skeleton.rest_world();
        let mut start = rest.clone();
        if self.settings.start == StartPose::FirstFrame
            && let Some(frame) = character.clips.first().and_then(|c| c.frames.first())
            && frame.len() == skeleton.len()
        {
            skeleton.world_from_local(frame, &mut start);
        }
        for t in &mut start {
            *t = placement.mul(t);
        }
        let unscaled = |t: &Transform| Transform::new(t.translation, t.rotation);
        let body_local = |i: usize| {
            let b = &spec.bodies[i];
            Transform::new(
                Vec3::from_array(b.center_m),
                glam::Quat::from_array(b.rotation).normalize(),
            )
        };
        let body_rest: Vec<Transform> = (0..spec.bodies.len())
            .map(|i| unscaled(&rest[bone_of_body[i]]).mul(&body_local(i)))
            .collect();
        let mut body_start: Vec<Transform> = (0..spec.bodies.len())
            .map(|i| unscaled(&start[bone_of_body[i]]).mul(&body_local(i)))
            .collect();
        // 3. Lift onto the ground where any body would start below it.
        if let Some(ground) = self.settings.ground {
            let lowest = body_start
                .iter()
                .zip(&spec.bodies)
                .map(|(p, b)| lowest_point(p, &b.shape))
                .fold(f32::INFINITY, f32::min);
            if lowest < ground {
                let lift = Vec3::new(0.0, ground - lowest, 0.0);
                for p in &mut body_start {
                    p.translation += lift;
                }
                for t in &mut start {
                    t.translation += lift;
                }
            }
        }
        // 4. Joints: frames taken in the rest pose, so every angle is zero at rest.
        let mut joint_descs = Vec::with_capacity(spec.joints.len());
        for j in &spec.joints {
            let parent = spec.body_index(&j.parent).expect("validated");
            let child = spec.body_index(&j.child).expect("validated");
            let child_bone = unscaled(&rest[bone_of_body[child]]);
            let frame_world = child_bone.mul(&Transform::new(
                Vec3::from_array(j.anchor_m),
                glam::Quat::from_array(j.frame).normalize(),
            ));
            let tilt = match j.kind {
                JointKind::SwingTwist { cone_tilt_deg, .. } => {
                    glam::Quat::from_rotation_y(cone_tilt_deg[0].to_radians())
                        * glam::Quat::from_rotation_z(cone_tilt_deg[1].to_radians())
                }
                _ => glam::Quat::IDENTITY,
            };
            let parent_frame_world = frame_world.mul(&Transform::new(Vec3::ZERO, tilt));
            joint_descs.push(JointDesc {
                parent,
                child,
                frame_parent: body_rest[parent].inverse().mul(&parent_frame_world),
                frame_child: body_rest[child].inverse().mul(&frame_world),
                kind: j.kind,
            });
        }
        let disabled: Vec<(usize, usize)> = spec
            .collision
            .disabled_pairs
            .iter()
            .map(|[a, b]| {
                (
                    spec.body_index(a).expect("validated"),
                    spec.body_index(b).expect("validated"),
                )
            })
            .collect();
        // 5. Skeleton joints ride on their own or their nearest ancestor's body, with the
        //    offset they have at the start (so the hand-over pose is kept exactly).
        let root_body = (0..spec.bodies.len())
            .min_by_key(|&i| bone_of_body[i])
            .expect("a spec has bodies");
        let mut riders = Vec::with_capacity(skeleton.len());
        for j in 0..skeleton.len() {
            let mut k = Some(j);
            let body = loop {
                match k {
                    Some(k2) => {
                        if let Some(b) = bone_of_body.iter().position(|&bj| bj == k2) {
                            break b;
                        }
                        k = skeleton.parent(k2);
                    }
                    None => break root_body,
                }
            };
            riders.push(Rider {
                body,
                offset: body_start[body].inverse().mul(&start[j]),
            });
        }
        let bodies: Vec<BodyDesc> = spec
            .bodies
            .iter()
            .zip(&body_start)
            .map(|(b, p)| BodyDesc {
                pose: *p,
                shape: b.shape,
                mass: b.mass_kg,
                linvel: Vec3::ZERO,
                angvel: Vec3::ZERO,
            })
            .collect();
        let first_body = self.backend.add_ragdoll(&bodies, &joint_descs, &disabled);
        let joints = joint_descs.iter().map(JointMeasure::new).collect();
        self.instances.push(Instance {
            first_body,
            masses: spec.bodies.iter().map(|b| b.mass_kg).collect(),
            joints,
            riders,
            track: Track {
                fps: self.settings.fps,
                frames: Vec::new(),
            },
        });
        Ok(RagdollId(self.instances.len() - 1))
    }

    /// Simulated time so far, seconds.
    pub fn time(&self) -> f64 {
        self.time
    }

    /// Steps the world for `seconds`, recording output frames at the track rate. The first
    /// call also records the starting frame.
    pub fn run(&mut self, seconds: f32) {
        let end = self.time + seconds.max(0.0) as f64;
        let dt = self.settings.dt as f64;
        if self.frames_recorded == 0 {
            self.backend.body_states(&mut self.states);
            self.prev_states.clone_from(&self.states);
            self.record_frames_until(0.0);
        }
        while self.time + 0.5 * dt <= end + 1e-9 {
            self.step();
        }
    }

    /// One fixed step, then whatever output frames fall inside it.
    pub fn step(&mut self) {
        if self.frames_recorded == 0 {
            self.backend.body_states(&mut self.states);
            self.prev_states.clone_from(&self.states);
            self.record_frames_until(0.0);
        }
        std::mem::swap(&mut self.states, &mut self.prev_states);
        self.backend.step(self.settings.dt);
        self.time += self.settings.dt as f64;
        self.backend.body_states(&mut self.states);
        self.measure_step();
        self.record_frames_until(self.time);
    }

    /// Worst-case quality metrics so far.
    pub fn metrics(&self) -> Metrics {
        self.metrics
    }

    /// The track recorded so far for ragdoll `id`.
    pub fn track(&self, id: RagdollId) -> &Track {
        &self.instances[id.0].track
    }

    /// Number of ragdolls.
    pub fn ragdoll_count(&self) -> usize {
        self.instances.len()
    }

    /// World transforms of ragdoll `id`'s bodies now, in spec order.
    pub fn body_poses(&self, id: RagdollId) -> Vec<Transform> {
        let inst = &self.instances[id.0];
        self.states[inst.first_body..inst.first_body + inst.masses.len()]
            .iter()
            .map(|s| s.pose)
            .collect()
    }

    /// Consumes the world, returning the track of its first ragdoll.
    pub fn into_track(mut self) -> Track {
        std::mem::take(&mut self.instances[0].track)
    }

    /// Consumes the world, returning every ragdoll's track in insertion order.
    pub fn into_tracks(self) -> Vec<Track> {
        self.instances.into_iter().map(|i| i.track).collect()
    }

    fn record_frames_until(&mut self, t: f64) {
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
            for inst in &mut self.instances {
                let frame: Vec<Transform> = inst
                    .riders
                    .iter()
                    .map(|r| {
                        let a = &self.prev_states[inst.first_body + r.body].pose;
                        let b = &self.states[inst.first_body + r.body].pose;
                        let pose = Transform::new(
                            a.translation.lerp(b.translation, alpha),
                            a.rotation.slerp(b.rotation, alpha),
                        );
                        pose.mul(&r.offset)
                    })
                    .collect();
                inst.track.frames.push(frame);
            }
            self.frames_recorded += 1;
            self.measure_frame_energy();
        }
    }

    fn measure_step(&mut self) {
        let m = &mut self.metrics;
        m.max_penetration_m = m.max_penetration_m.max(self.backend.max_penetration());
        for s in &self.states {
            if !(s.pose.is_finite() && s.linvel.is_finite() && s.angvel.is_finite()) {
                m.nan = true;
            }
        }
        for inst in &self.instances {
            let states = &self.states[inst.first_body..inst.first_body + inst.masses.len()];
            for j in &inst.joints {
                let (sep, viol) = j.errors(&states[j.parent].pose, &states[j.child].pose);
                m.max_joint_separation_m = m.max_joint_separation_m.max(sep);
                m.max_limit_violation_deg = m.max_limit_violation_deg.max(viol.to_degrees());
            }
        }
    }

    fn measure_frame_energy(&mut self) {
        let g = self.settings.gravity;
        let ground = self.settings.ground.unwrap_or(0.0);
        let mut potential = 0.0f64;
        for inst in &self.instances {
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

/// Finds a joint by name, or by the `joint<i>` label given to unnamed joints.
fn find_label(character: &Character, label: &str) -> Option<usize> {
    let s = &character.skeleton;
    s.find(label).or_else(|| {
        let i: usize = label.strip_prefix("joint")?.parse().ok()?;
        (i < s.len() && s.joints()[i].name.is_empty()).then_some(i)
    })
}

/// Lowest world height of a shape at `pose`.
fn lowest_point(pose: &Transform, shape: &Shape) -> f32 {
    match *shape {
        Shape::Capsule { radius_m, length_m } => {
            let axis = pose.rotation * Vec3::Y * (0.5 * length_m);
            (pose.translation.y - axis.y.abs()) - radius_m
        }
        Shape::Box { size_m } => {
            let h = Vec3::from_array(size_m) * 0.5;
            let mut low = f32::INFINITY;
            for sx in [-1.0, 1.0] {
                for sy in [-1.0, 1.0] {
                    for sz in [-1.0, 1.0] {
                        let c = pose.transform_point(h * Vec3::new(sx, sy, sz));
                        low = low.min(c.y);
                    }
                }
            }
            low
        }
    }
}
