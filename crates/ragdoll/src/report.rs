//! The JSON report written next to every baked result: what was simulated and
//! how well the simulation kept its promises.

use serde::{Deserialize, Serialize};

use crate::events::{BlastReport, ProjectileReport};
use crate::spec::RagdollSpec;
use crate::track::{Metrics, Track};

/// One JSON object; numbers in SI units unless the key says otherwise.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Report {
    /// Name of the character.
    pub character: String,
    /// Input file, or `built-in` for the default humanoid.
    pub input: String,
    /// Backend that ran the simulation (`rigid` or `particle`; [`Report::new`] writes
    /// `rigid`, callers that ran another set it).
    pub backend: String,
    /// Number of output frames.
    pub frames: usize,
    /// Output frames per second.
    pub fps: f32,
    /// Simulated seconds.
    pub seconds: f32,
    /// Height of the character's rest pose standing, metres (its size scale): its skin's
    /// where it has one ([`crate::import::standing_height`]: stood up when it lies in its
    /// file), else its skeleton's, whose head joint sits at the base of the skull (a chibi
    /// knight's is half its height).
    pub height_m: f32,
    /// Number of rigid bodies.
    pub bodies: usize,
    /// Number of joints between bodies.
    pub joints: usize,
    /// Number of skeleton joints in the track.
    pub skeleton_joints: usize,
    /// Sum of the body masses, kg.
    pub total_mass_kg: f32,
    /// Quality metrics, flattened into the report.
    #[serde(flatten)]
    pub metrics: Metrics,
    /// Wall-clock seconds spent simulating (not importing or exporting).
    pub wall_seconds: f64,
    /// What each blast did (empty without blasts).
    pub blasts: Vec<BlastReport>,
    /// What each projectile hit (empty without projectiles).
    pub projectiles: Vec<ProjectileReport>,
    /// How many joints the solver worked on at each output frame: all but those of a
    /// character at rest (asleep) and, on the fast backend, those frozen. `null` where
    /// the backend does not say (particle) or the caller did not set it.
    #[serde(default)]
    pub active_joints_per_frame: Option<Vec<u32>>,
}

impl Report {
    /// Assembles a report from a finished simulation.
    pub fn new(
        input: &str,
        height_m: f32,
        spec: &RagdollSpec,
        track: &Track,
        metrics: Metrics,
        seconds: f32,
        wall_seconds: f64,
    ) -> Self {
        Report {
            character: spec.name.clone(),
            input: input.to_string(),
            backend: "rigid".into(),
            frames: track.frames.len(),
            fps: track.fps,
            seconds,
            height_m,
            bodies: spec.bodies.len(),
            joints: spec.joints.len(),
            skeleton_joints: track.frames.first().map_or(0, |f| f.len()),
            total_mass_kg: spec.total_mass_kg(),
            metrics,
            wall_seconds,
            blasts: Vec::new(),
            projectiles: Vec::new(),
            active_joints_per_frame: None,
        }
    }

    /// Pretty-printed JSON.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a report always serialises")
    }
}
