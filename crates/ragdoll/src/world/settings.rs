//! How a world steps and what surrounds its ragdolls: the settings, their defaults, and
//! the bounds every one is checked against before a run.

use glam::Vec3;

use crate::error::{Error, Result};

use super::{
    BackendConfig, BackendKind, MAX_COORDINATE_M, MAX_FPS, MAX_GRAVITY_MPS2, MAX_SECONDS,
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
    /// Output frames per second of the tracks (default 30).
    pub fps: f32,
    /// Gravity, m/s² (default −9.80665 along Y).
    pub gravity: Vec3,
    /// Height of the ground plane (default `Some(0.0)`: the file's floor); `None` for none.
    pub ground: Option<f32>,
    /// Starting pose (default: the first clip frame).
    pub start: StartPose,
    /// Which engine moves the bodies, with its own settings (default the rigid engine,
    /// [`BackendConfig::Rigid`], at its defaults). `BackendKind::Fast.into()` picks an
    /// engine at its defaults.
    pub backend: BackendConfig,
    /// Passive joint damping, per second (default [`DEFAULT_JOINT_DAMPING`], off): how
    /// fast a limp limb swinging from a still body loses its speed relative to it, so its
    /// swing's amplitude decays as `exp(-c t / 2)`. Rigid and fast backends for now (the
    /// world hands it to the engine for each ragdoll: [`crate::backend::damping`]).
    pub joint_damping: f32,
}

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
            fps: 30.0,
            gravity: Vec3::new(0.0, -STANDARD_GRAVITY, 0.0),
            ground: Some(0.0),
            start: StartPose::FirstFrame,
            backend: BackendConfig::default(),
            joint_damping: DEFAULT_JOINT_DAMPING,
        }
    }
}

impl WorldSettings {
    /// Checks the settings a user can set: the step within [`STEP_RANGE_S`], the frame
    /// rate within 1..[`MAX_FPS`], the engine's counts ([`BackendConfig::validate`]), gravity within
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
        if !checks.iter().any(|(_, r)| r.is_err()) {
            self.backend.validate()?;
        }
        if self.joint_damping > 0.0 && self.backend.kind() == BackendKind::Particle {
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
