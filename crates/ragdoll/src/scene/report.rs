//! The JSON report of a scene: the world's metrics for the whole scene, what can be told
//! per character, and what every blast and projectile did.

use serde::{Deserialize, Serialize};

use super::SceneCharacter;
use crate::events::{BlastReport, ProjectileReport};
use crate::spec::Role;
use crate::track::{Metrics, Track};
use crate::world::{RagdollId, World};

/// One g, m/s² (ISO 80000-3).
const STANDARD_GRAVITY_MPS2: f32 = 9.80665;

/// How far above the ground a character's lowest point must be for it to count as
/// thrown, metres: past the millimetres a body resting on the floor sinks into it or
/// hovers over it, below a body's own thickness.
pub const AIRBORNE_CLEARANCE_M: f32 = 0.02;

/// One JSON object; numbers in SI units unless the key says otherwise.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SceneReport {
    /// The scene file.
    pub scene: String,
    /// Backend that ran the simulation (`rigid`).
    pub backend: String,
    /// Number of output frames (every character has as many).
    pub frames: usize,
    /// Output frames per second.
    pub fps: f32,
    /// Simulated seconds.
    pub seconds: f32,
    /// Quality metrics over the whole scene (every character, every contact), flattened
    /// into the report as in the single-character report, so the same checks read both.
    #[serde(flatten)]
    pub metrics: Metrics,
    /// Wall-clock seconds spent building the world and simulating (not loading or
    /// exporting).
    pub wall_seconds: f64,
    /// How many joints the solver worked on at each output frame: all but those of
    /// characters at rest (asleep until something touches them) and, on the fast
    /// backend, those frozen. `null` on the particle backend, which never rests.
    pub active_joints_per_frame: Option<Vec<u32>>,
    /// Per character, in scene order (the `character` indices of the event reports).
    pub characters: Vec<CharacterReport>,
    /// What each blast did, per body part and character.
    pub blasts: Vec<BlastReport>,
    /// What each projectile hit (a burst gives one entry per shot).
    pub projectiles: Vec<ProjectileReport>,
}

impl SceneReport {
    /// Pretty-printed JSON.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a report always serialises")
    }
}

/// What the report says about one character.
///
/// Penetration and energy drift are measured by the world for the whole scene only (bodies
/// of different characters touch each other), so they are in [`SceneReport::metrics`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CharacterReport {
    /// Its name in the scene.
    pub name: String,
    /// Its file as written in the scene, or `built-in`.
    pub input: String,
    /// Where it was placed, metres.
    pub position: [f32; 3],
    /// Its facing, degrees about the vertical.
    pub facing_deg: f32,
    /// When physics took over, seconds (`null` when its animation was still playing at the
    /// end).
    pub activated_at_s: Option<f64>,
    /// Number of rigid bodies.
    pub bodies: usize,
    /// Number of joints between bodies.
    pub joints: usize,
    /// Number of skeleton joints in its track.
    pub skeleton_joints: usize,
    /// Sum of its body masses, kg.
    pub total_mass_kg: f32,
    /// Height of its rest pose standing (stood up when it lies in its file), metres: its
    /// skin's where it has one, else its skeleton's.
    pub height_m: f32,
    /// Worst excursion of its joints beyond their limits while physical, degrees.
    pub max_limit_violation_deg: f32,
    /// Worst gap at its joint anchors while physical, metres.
    pub max_joint_separation_m: f32,
    /// Highest speed of its centre of mass while physical, m/s: how hard it was thrown.
    pub max_speed_mps: f32,
    /// How long it was physical with no part within [`AIRBORNE_CLEARANCE_M`] of the ground,
    /// seconds: how long it flew (`null` in a scene without ground).
    pub airborne_s: Option<f32>,
    /// The most acceleration its head felt while physical, in g (9.80665 m/s²): the
    /// change of the head body's velocity over each 1/60 s step, less gravity's, as an
    /// accelerometer in the head would read it averaged over the step (`null` without a
    /// head; gravity is the scene's `gravity`, which a gravity field's keys replace
    /// unnoticed here). Crash tests sample heads at 10 kHz and integrate the Head Injury
    /// Criterion over milliseconds; a step's average is far below such peaks, a lower bound.
    pub peak_head_accel_g: Option<f32>,
    /// Whether a non-finite value appeared in its track or its joints.
    pub nan: bool,
    /// Its BVH file in the output folder (`null` when BVH output is off).
    pub bvh: Option<String>,
}

/// What a scene watches of one character, step by step, while it is physical: what the
/// world measures only for the whole scene.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Watch {
    violation_deg: f32,
    separation_m: f32,
    max_speed_mps: f32,
    airborne_s: f32,
    /// The head body's velocity after the last step watched, and the most acceleration
    /// beyond gravity seen so far, m/s².
    head_velocity: Option<glam::Vec3>,
    head_accel: f32,
}

impl Watch {
    /// Takes in character `c` (ragdoll `id`) after a step of `dt` seconds over `ground`.
    pub(super) fn observe(
        &mut self,
        world: &World,
        id: RagdollId,
        c: &SceneCharacter,
        ground: Option<f32>,
        gravity: glam::Vec3,
        dt: f32,
    ) {
        if world.activated_at(id).is_none() {
            return;
        }
        let velocities = world.body_velocities(id);
        let head = c
            .spec
            .bodies
            .iter()
            .position(|b| b.role == Some(Role::Head));
        if let Some((v, _)) = head.and_then(|h| velocities.get(h)) {
            // What an accelerometer in the head reads: its change of velocity less what
            // gravity alone would have made (a free fall reads nothing).
            if let Some(before) = self.head_velocity {
                let felt = ((*v - before) / dt - gravity).length();
                self.head_accel = self.head_accel.max(felt);
            }
            self.head_velocity = Some(*v);
        }
        for (sep, viol) in world.joint_errors(id) {
            self.violation_deg = self.violation_deg.max(viol);
            self.separation_m = self.separation_m.max(sep);
            if !(sep.is_finite() && viol.is_finite()) {
                (self.violation_deg, self.separation_m) = (f32::INFINITY, f32::INFINITY);
            }
        }
        let (mut momentum, mut mass) = (glam::Vec3::ZERO, 0.0f32);
        for (b, (v, _)) in c.spec.bodies.iter().zip(velocities) {
            momentum += v * b.mass_kg;
            mass += b.mass_kg;
        }
        if mass > 0.0 {
            self.max_speed_mps = self.max_speed_mps.max((momentum / mass).length());
        }
        if let Some(g) = ground {
            let lowest = c
                .spec
                .bodies
                .iter()
                .zip(world.body_poses(id))
                .map(|(b, pose)| b.shape.lowest_y(&pose))
                .fold(f32::INFINITY, f32::min);
            if lowest > g + AIRBORNE_CLEARANCE_M {
                self.airborne_s += dt;
            }
        }
    }
}

impl CharacterReport {
    /// Assembles a character's entry from its run.
    pub(super) fn new(
        c: &SceneCharacter,
        track: &Track,
        activated_at_s: Option<f64>,
        watch: &Watch,
        ground: Option<f32>,
        bvh: Option<String>,
    ) -> Self {
        let (max_limit_violation_deg, max_joint_separation_m) =
            (watch.violation_deg, watch.separation_m);
        let finite = max_limit_violation_deg.is_finite()
            && max_joint_separation_m.is_finite()
            && track.frames.iter().flatten().all(|t| t.is_finite());
        CharacterReport {
            name: c.name.clone(),
            input: c.input.clone(),
            position: c.position.to_array(),
            facing_deg: c.facing_deg,
            activated_at_s,
            bodies: c.spec.bodies.len(),
            joints: c.spec.joints.len(),
            skeleton_joints: track.frames.first().map_or(0, |f| f.len()),
            total_mass_kg: c.spec.total_mass_kg(),
            height_m: crate::import::standing_height(&c.character),
            // JSON has no infinity or NaN: serde_json writes those as `null`, and `nan` says
            // why.
            max_limit_violation_deg,
            max_joint_separation_m,
            max_speed_mps: watch.max_speed_mps,
            airborne_s: ground.map(|_| watch.airborne_s),
            peak_head_accel_g: watch
                .head_velocity
                .map(|_| watch.head_accel / STANDARD_GRAVITY_MPS2),
            nan: !finite,
            bvh,
        }
    }
}
