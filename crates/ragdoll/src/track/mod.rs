//! What a simulation leaves behind: every skeleton joint's world transform for every output
//! frame, ready for the exporters (which know nothing of backends), and the quality metrics
//! of the report (the guide's report reference).

use serde::{Deserialize, Serialize};

use crate::math::Transform;

/// Baked motion: world transforms of every skeleton joint, per frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Track {
    /// Output frames per second.
    pub fps: f32,
    /// `frames[f][j]`: world transform of skeleton joint `j` at frame `f` (scale kept from
    /// the rest pose).
    pub frames: Vec<Vec<Transform>>,
}

impl Track {
    /// Seconds between frames.
    pub fn frame_time(&self) -> f32 {
        1.0 / self.fps
    }
}

/// How well the simulation kept its promises, worst case over the run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Metrics {
    /// Worst excursion of any joint beyond its limits, degrees (a hinge bending off its axis
    /// counts too), in what is recorded: after any positional clamp that turns joints back
    /// (see [`Metrics::max_limit_violation_solver_deg`]).
    pub max_limit_violation_deg: f32,
    /// The same, read before any positional clamp: what the solver itself left (the rigid
    /// engine's limit projection, the particle engine's own end-of-step pass). A
    /// clamp only ever lowers a violation, so this is at least
    /// [`Metrics::max_limit_violation_deg`]; the gap between them is how much the clamp,
    /// not the solver, held the limits.
    #[serde(default)]
    pub max_limit_violation_solver_deg: f32,
    /// Deepest contact seen (ground or between bodies that may collide), metres, as the
    /// solver left it: both backends read their contacts before any positional clamp
    /// (rapier's after its step, the particle backend's before its end-of-step pass), so
    /// unlike [`Metrics::max_limit_violation_deg`] it needs no second reading.
    pub max_penetration_m: f32,
    /// Worst gap opening between the two sides of a joint anchor, metres, in what is
    /// recorded: after any positional clamp that narrows gaps (see
    /// [`Metrics::max_joint_separation_solver_m`]).
    pub max_joint_separation_m: f32,
    /// The same, read before any such clamp: what the solver itself left (the rigid
    /// engine narrows gaps on positions when its `gap_tolerance_m` asks it to, as PhysX's
    /// joint projection does; otherwise the two readings agree). At least
    /// [`Metrics::max_joint_separation_m`].
    #[serde(default)]
    pub max_joint_separation_solver_m: f32,
    /// Largest rise of total energy (kinetic + potential) between two output frames,
    /// relative to the energy at the start; 0 when it never rises. A passive ragdoll must
    /// not gain energy.
    pub energy_drift: f32,
    /// Largest relative change of any bone's length (skeleton joint to its parent, in the
    /// recorded track) over the run, from the first frame physics drove; about 0 for the
    /// rigid backend, whose bones only move apart as far as its joints separate. Links the
    /// ragdoll does not hold (an IK foot hung from the root joins its shin instead) are
    /// left out: their length is free.
    #[serde(default)]
    pub max_bone_stretch: f32,
    /// Whether any non-finite value appeared.
    pub nan: bool,
}
