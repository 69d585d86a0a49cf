//! How a world steps and what surrounds its ragdolls: the settings, their defaults, and
//! the bounds every one is checked against before a run.

use glam::Vec3;

use crate::error::{Error, Result};

use super::{
    BackendKind, MAX_COORDINATE_M, MAX_FPS, MAX_GRAVITY_MPS2, MAX_SECONDS, MAX_SUBSTEPS,
    MAX_TRACK_SAMPLES, STANDARD_GRAVITY, STEP_RANGE_S,
};

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
    /// Fixed step, seconds (default 1/60): events and the metrics run at this rate.
    pub dt: f32,
    /// Physics steps per step, each with its own collision detection (default 4, so
    /// contacts are found at 240 Hz: a body falling at 5 m/s moves 2 cm between two
    /// detections instead of 8 cm, which is what kept penetrations under a centimetre or
    /// so in our runs).
    pub collision_substeps: usize,
    /// Solver substeps per physics step (default 4).
    pub substeps: usize,
    /// Constraint iterations per solver substep (default 2): joints and contacts of a
    /// 16-body chain converge better with two.
    pub iterations: usize,
    /// Output frames per second of the tracks (default 30).
    pub fps: f32,
    /// Gravity, m/s² (default −9.80665 along Y).
    pub gravity: Vec3,
    /// Height of the ground plane (default `Some(0.0)`: the file's floor); `None` for none.
    pub ground: Option<f32>,
    /// Starting pose (default: the first clip frame).
    pub start: StartPose,
    /// Whether joint limits are also enforced on positions after every step (default true).
    ///
    /// rapier enforces limits on velocities; a hard impact (a torso landing on an arm) can
    /// still push a joint tens of degrees past its limit for a few frames. The projection
    /// clamps each joint's swing and twist back into range, turning the child's whole
    /// subtree about the joint anchor, parents first, as position-based solvers do.
    pub project_limits: bool,
    /// Which engine moves the bodies (default [`BackendKind::Rigid`]). The particle
    /// backend keeps limits itself (`project_limits` is then not needed) and reads
    /// `particle_substeps` and `particle_iterations` instead of `substeps` and
    /// `iterations`; the fast backend reads `fast_substeps` and `fast_iterations`.
    pub backend: BackendKind,
    /// Substeps per physics step of the particle backend (default 3: with the 4 collision
    /// substeps, the particles move at 720 Hz). Two leave the built-in humanoid's bones
    /// 1.4 % stretched after a fall; four cost a third more.
    pub particle_substeps: usize,
    /// Projection passes per particle substep (default 1): substeps converge better than
    /// passes for the same cost (Macklin et al. 2019, "Small Steps in Physics Simulation").
    pub particle_iterations: usize,
    /// Substeps per step of the fast backend (default [`DEFAULT_FAST_SUBSTEPS`]). It
    /// finds contact pairs once per step and ignores `collision_substeps`: its substeps
    /// find the contact points themselves.
    pub fast_substeps: usize,
    /// Passes of the fast backend's joints and contacts per substep (default 1, at most
    /// [`MAX_FAST_ITERATIONS`]), everywhere; [`WorldSettings::fast_impact_passes`] adds
    /// passes only in impacts, where the worst joint gaps and limit violations happen.
    /// Without those, two passes held the bench's piles' limits within 2° (1.3° / 1.6° at
    /// 16 / 256 ragdolls, against 2.2° / 4.0°) and its joints closer (6 mm against 8) for
    /// about 1.5 times the time; fewer substeps of two passes lose it (24 substeps: 3.5°
    /// at 256).
    pub fast_iterations: usize,
    /// Passes the fast backend adds in an impact (default [`DEFAULT_FAST_IMPACT_PASSES`],
    /// at most [`MAX_FAST_ITERATIONS`]; 0 for none): a step in which one of a ragdoll's
    /// parts may strike the ground or another body at more than 2 m/s, its island solves
    /// its joints and contacts `fast_iterations` plus this many times a substep. An impact
    /// is where one pass falls short: a light part struck hands its blow on to the rest
    /// one joint per pass.
    pub fast_impact_passes: usize,
    /// Passive joint damping, per second (default [`DEFAULT_JOINT_DAMPING`], off): how
    /// fast a limp limb swinging from a still body loses its speed relative to it, so its
    /// swing's amplitude decays as `exp(-c t / 2)`. Rigid and fast backends for now.
    pub joint_damping: f32,
    /// Whether the fast backend freezes joints that have stopped moving (default true):
    /// the bodies they link move as one until a blow arrives, and cost as one (its level
    /// of detail below sleep; see the guide's Backends page). The other backends ignore it.
    pub freeze_joints: bool,
}

/// Default of [`WorldSettings::fast_substeps`]: 32 substeps of 1/1920 s. Measured on six
/// piles of 8 built-in humanoids dropped lying (means of each run's worst values): 16
/// substeps left joints 31 mm apart, contacts 46 mm deep and limits 12° past; 24 left
/// 16 mm, 27 mm, 8°; 32 left 14 mm, 23 mm, 5.5°, where the rigid backend leaves 16 mm,
/// 38 mm, 8.5° (its solver's reading, before the world's clamp).
pub const DEFAULT_FAST_SUBSTEPS: usize = 32;

/// Default of [`WorldSettings::fast_impact_passes`]: three more passes in an impact, four
/// in all. In the pile bench (`ragdoll bench --backend fast --ragdolls 16,256 --threads
/// 1`) the joints that opened wider than 4 mm did so only in landings, at the arms (20
/// joint-steps of 144,000 at N=16), up to 7.8 mm with one pass; three passes held them
/// to 4.6 mm and four to 3.4. Measured on twelve piles of four dropped for 4 s (means of
/// each pile's worst, then the worst pile), against one pass throughout: solver limit
/// violation 0.77° / 1.15° against 1.87° / 2.40°, joint gap 3.6 / 4.4 mm against 7.9 /
/// 8.6, penetration 4.9 / 6.7 mm against 12.2, energy gain at most 0.05 % against 0.35 %,
/// for 1.6 times the time of those 4 s; two passes throughout gave 1.33° / 2.62°, 6.1 /
/// 7.1 mm, 9.0 mm for 1.6 times too, and three throughout gained 0.6 % energy in a pile.
pub const DEFAULT_FAST_IMPACT_PASSES: usize = 3;

/// Most passes a substep [`WorldSettings::fast_iterations`] takes: past a few, substeps
/// buy more for the time.
pub const MAX_FAST_ITERATIONS: usize = 8;

/// Default of [`WorldSettings::joint_damping`]: off, so runs match earlier releases.
///
/// Without damping a limp part hanging free swings as an undamped pendulum for the whole
/// run: the rigged dragons' raised heads swung at 0.1-0.4 m/s for 14 s on the rigid
/// backend. At 1.5 per second they lie still within a few seconds, but the default stays
/// off until it is measured on every data file and the particle backend has it (see
/// [`WorldSettings::validate`]).
pub const DEFAULT_JOINT_DAMPING: f32 = 0.0;

/// Largest [`WorldSettings::joint_damping`], per second: a limb stopping within a
/// hundredth of a second is a weld, not a joint.
pub const MAX_JOINT_DAMPING: f32 = 100.0;

impl Default for WorldSettings {
    fn default() -> Self {
        WorldSettings {
            dt: 1.0 / 60.0,
            collision_substeps: 4,
            substeps: 4,
            iterations: 2,
            fps: 30.0,
            gravity: Vec3::new(0.0, -STANDARD_GRAVITY, 0.0),
            ground: Some(0.0),
            start: StartPose::FirstFrame,
            project_limits: true,
            backend: BackendKind::Rigid,
            particle_substeps: 3,
            particle_iterations: 1,
            fast_substeps: DEFAULT_FAST_SUBSTEPS,
            fast_iterations: 1,
            fast_impact_passes: DEFAULT_FAST_IMPACT_PASSES,
            joint_damping: DEFAULT_JOINT_DAMPING,
            freeze_joints: true,
        }
    }
}

impl WorldSettings {
    /// Checks the settings a user can set: the step within [`STEP_RANGE_S`], the frame
    /// rate within 1..[`MAX_FPS`], substeps within 1..[`MAX_SUBSTEPS`], gravity within
    /// [`MAX_GRAVITY_MPS2`] and the ground within [`MAX_COORDINATE_M`].
    pub fn validate(&self) -> Result<()> {
        use crate::spec::{check_length, check_within};
        let mut checks = vec![
            (
                "dt",
                check_within(self.dt, STEP_RANGE_S[0], STEP_RANGE_S[1], " s"),
            ),
            (
                "fps",
                check_within(self.fps, 1.0, MAX_FPS, " frames per second"),
            ),
            (
                "gravity",
                check_length(self.gravity.to_array(), MAX_GRAVITY_MPS2, " m/s²"),
            ),
            (
                "ground",
                self.ground.map_or(Ok(()), |h| {
                    check_within(h, -MAX_COORDINATE_M, MAX_COORDINATE_M, " m")
                }),
            ),
            (
                "joint_damping",
                check_within(self.joint_damping, 0.0, MAX_JOINT_DAMPING, " per second"),
            ),
        ];
        if !(1..=MAX_FAST_ITERATIONS).contains(&self.fast_iterations) {
            checks.push((
                "fast_iterations",
                Err(format!(
                    "must be between 1 and {MAX_FAST_ITERATIONS}, not {}",
                    self.fast_iterations
                )),
            ));
        }
        if self.fast_impact_passes > MAX_FAST_ITERATIONS {
            checks.push((
                "fast_impact_passes",
                Err(format!(
                    "must be between 0 and {MAX_FAST_ITERATIONS}, not {}",
                    self.fast_impact_passes
                )),
            ));
        }
        for (name, v) in [
            ("collision_substeps", self.collision_substeps),
            ("substeps", self.substeps),
            ("iterations", self.iterations),
            ("particle_substeps", self.particle_substeps),
            ("particle_iterations", self.particle_iterations),
            ("fast_substeps", self.fast_substeps),
        ] {
            if !(1..=MAX_SUBSTEPS).contains(&v) {
                checks.push((
                    name,
                    Err(format!("must be between 1 and {MAX_SUBSTEPS}, not {v}")),
                ));
            }
        }
        if self.joint_damping > 0.0 && self.backend == BackendKind::Particle {
            // Applied as torque impulses on velocities the particle backend reads off its
            // last substep's motion, a substep late: on the viewer's largest bodies that
            // fed energy in (a 29 J fall came to 148 J of motion).
            checks.push((
                "joint_damping",
                Err(
                    "works on the rigid and fast backends only for now; use 0 with the particle backend"
                        .to_string(),
                ),
            ));
        }
        match checks.into_iter().find(|(_, r)| r.is_err()) {
            Some((setting, Err(message))) => Err(Error::Setting {
                setting: setting.into(),
                message,
            }),
            _ => Ok(()),
        }
    }

    /// Checks a run of `seconds` recording `joints` skeleton joints (over every
    /// character) at these settings: at most [`MAX_SECONDS`], and at most
    /// [`MAX_TRACK_SAMPLES`] joint transforms recorded.
    pub fn validate_run(&self, seconds: f32, joints: usize) -> Result<()> {
        let bad = |message: String| {
            Err(Error::Setting {
                setting: "seconds".into(),
                message,
            })
        };
        if let Err(m) = crate::spec::check_within(seconds, 0.0, MAX_SECONDS, " s") {
            return bad(m);
        }
        let frames = (seconds as f64 * self.fps as f64).floor() as u64 + 1;
        let samples = frames.saturating_mul(joints as u64);
        if samples > MAX_TRACK_SAMPLES {
            return bad(format!(
                "{seconds} s at {} fps records {frames} frames of {joints} joints, more than \
                 the {MAX_TRACK_SAMPLES} joint transforms a run keeps in memory; shorten the \
                 run, lower the frame rate or use fewer characters",
                self.fps
            ));
        }
        Ok(())
    }
}
