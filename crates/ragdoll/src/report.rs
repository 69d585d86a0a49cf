//! The JSON report written beside every baked result, for one character or a scene of
//! many: what was simulated, how well the simulation kept its promises, what happened to
//! each character and what every blast and projectile did. One type for both, so that
//! the same checks read both: a single character is a scene of one.

use serde::{Deserialize, Serialize};

use crate::events::{BlastReport, ProjectileReport};
use crate::track::Metrics;

/// How far above the ground a character's lowest point must be for it to count as
/// thrown, metres: past the millimetres a body resting on the floor sinks into it or
/// hovers over it, below a body's own thickness.
pub const AIRBORNE_CLEARANCE_M: f32 = 0.02;

/// One JSON object; numbers in SI units unless the key says otherwise.
///
/// A run's [`crate::scene::SceneResult`] carries it; [`Report::to_json`] is the file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Report {
    /// The scene file; `null` for a single character run by `ragdoll simulate`, `blast`,
    /// `shoot` or `demo`, or a scene built in code (its one file is its character's
    /// `input`).
    pub scene: Option<String>,
    /// The engine that ran the simulation: `rigid`, `fast` or `particle`.
    pub backend: String,
    /// Number of output frames (every character has as many).
    pub frames: usize,
    /// Output frames per second.
    pub fps: f32,
    /// Simulated seconds.
    pub seconds: f32,
    /// Quality metrics over the whole run (every character, every contact), flattened
    /// into the report.
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

impl Report {
    /// Pretty-printed JSON.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a report always serialises")
    }
}

/// What the report says about one character.
///
/// Penetration and energy drift are measured by the world for the whole scene only (bodies
/// of different characters touch each other), so they are in [`Report::metrics`].
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
