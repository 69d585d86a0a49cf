//! Each engine's own settings, one variant per engine, and the factory that builds it.
//!
//! The world's settings say what surrounds the ragdolls (gravity, ground, step, frame
//! rate) and carry one [`BackendConfig`]: what only that engine reads (its substeps,
//! passes, freezing) lives in its variant, so no engine sees another's knobs and adding
//! an engine means adding a variant, not fields every other engine ignores.

use glam::Vec3;

use super::fast::FastBackend;
use super::particle::ParticleBackend;
use super::rigid::RigidBackend;
use super::{AnyBackend, Backend, BackendKind};
use crate::error::{Error, Result};

/// Most substeps or passes of each kind a step takes ([`BackendConfig::validate`]).
pub const MAX_SUBSTEPS: usize = 100;

/// Most passes a substep of the fast engine takes ([`FastConfig::iterations`],
/// [`FastConfig::impact_passes`]): past a few, substeps buy more for the time.
pub const MAX_FAST_ITERATIONS: usize = 8;

/// Default of [`FastConfig::substeps`]: 32 substeps of 1/1920 s. Measured on six piles of
/// 8 built-in humanoids dropped lying (means of each run's worst values): 16 substeps left
/// joints 31 mm apart, contacts 46 mm deep and limits 12° past; 24 left 16 mm, 27 mm, 8°;
/// 32 left 14 mm, 23 mm, 5.5°, where the rigid backend leaves 16 mm, 38 mm, 8.5° (its
/// solver's reading, before the end-of-step clamp).
pub const DEFAULT_FAST_SUBSTEPS: usize = 32;

/// Default of [`FastConfig::impact_passes`]: three more passes in an impact, four in all.
/// In the pile bench (`ragdoll bench --backend fast --ragdolls 16,256 --threads 1`) the
/// joints that opened wider than 4 mm did so only in landings, at the arms (20 joint-steps
/// of 144,000 at N=16), up to 7.8 mm with one pass; three passes held them to 4.6 mm and
/// four to 3.4. Measured on twelve piles of four dropped for 4 s (means of each pile's
/// worst, then the worst pile), against one pass throughout: solver limit violation
/// 0.77° / 1.15° against 1.87° / 2.40°, joint gap 3.6 / 4.4 mm against 7.9 / 8.6,
/// penetration 4.9 / 6.7 mm against 12.2, energy gain at most 0.05 % against 0.35 %, for
/// 1.6 times the time of those 4 s; two passes throughout gave 1.33° / 2.62°, 6.1 /
/// 7.1 mm, 9.0 mm for 1.6 times too, and three throughout gained 0.6 % energy in a pile.
pub const DEFAULT_FAST_IMPACT_PASSES: usize = 3;

/// What every engine simulates the same way: the world's surroundings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Surroundings {
    /// Gravity, m/s².
    pub gravity: Vec3,
    /// Height of the ground plane, or `None` for no ground.
    pub ground: Option<f32>,
}

/// Settings of the `rigid` engine (rapier3d).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigidConfig {
    /// rapier steps per world step, each with its own collision detection and with the
    /// world's events between them (default 4, so contacts are found at 240 Hz: a body
    /// falling at 5 m/s moves 2 cm between two detections instead of 8 cm, which is what
    /// kept penetrations under a centimetre or so in our runs).
    pub collision_substeps: usize,
    /// Solver substeps per rapier step (rapier's TGS-soft iterations; default 4).
    pub substeps: usize,
    /// Constraint iterations per solver substep (default 2): joints and contacts of a
    /// 16-body chain converge better with two.
    pub iterations: usize,
    /// Whether joints are also held inside their limits on positions after every world
    /// step (default true; see [`super::limits`]): rapier holds them on velocities, and
    /// a torso landing on an arm still pushed a joint tens of degrees past its limit for
    /// a few frames.
    pub project_limits: bool,
    /// Joint gaps wider than this, metres, are narrowed to it on positions after every
    /// world step too, with the limits, as PhysX's and Unreal's joint projection do (off
    /// by default: `None` leaves them to rapier). rapier's joints open for a step now and
    /// then as a light hand is caught between the ground and a shin (7.4 mm on the Godot
    /// Mannequiny's wrist, 0.8 mm on `fast`), a tear in a skin bound to both sides, and no
    /// solver setting we tried (substeps, iterations, stabilisation passes, contact
    /// softness, warm-started joints) kept them under 4 mm over 24 drops. At 1 mm the
    /// projection holds every test character's joints within 1 mm, but like any move of
    /// positions the solver did not make it costs energy: a horse dropped on its side
    /// gained up to 2 % in a frame where it gains under 1 % without. The report keeps the
    /// gap rapier left ([`crate::track::Metrics::max_joint_separation_solver_m`]).
    pub gap_tolerance_m: Option<f32>,
}

impl Default for RigidConfig {
    fn default() -> Self {
        RigidConfig {
            collision_substeps: 4,
            substeps: 4,
            iterations: 2,
            project_limits: true,
            gap_tolerance_m: None,
        }
    }
}

/// Settings of the `particle` engine (our position-based particle ragdoll).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ParticleConfig {
    /// Engine steps per world step, each with its own collision detection and with the
    /// world's events between them (default 4).
    pub collision_substeps: usize,
    /// Substeps per engine step (default 3: with the 4 collision substeps, the particles
    /// move at 720 Hz). Two leave the built-in humanoid's bones 1.4 % stretched after a
    /// fall; four cost a third more.
    pub substeps: usize,
    /// Projection passes per substep (default 1): substeps converge better than passes
    /// for the same cost (Macklin et al. 2019, "Small Steps in Physics Simulation").
    pub iterations: usize,
}

impl Default for ParticleConfig {
    fn default() -> Self {
        ParticleConfig {
            collision_substeps: 4,
            substeps: 3,
            iterations: 1,
        }
    }
}

/// Settings of the `fast` engine (our rigid-body solver built for ragdolls). It steps
/// once per world step and substeps inside: it finds contact pairs once per step and its
/// substeps find the contact points themselves.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FastConfig {
    /// Substeps per world step (default [`DEFAULT_FAST_SUBSTEPS`]).
    pub substeps: usize,
    /// Passes of the joints and contacts per substep (default 1, at most
    /// [`MAX_FAST_ITERATIONS`]), everywhere; [`FastConfig::impact_passes`] adds passes
    /// only in impacts, where the worst joint gaps and limit violations happen. Without
    /// those, two passes held the bench's piles' limits within 2° (1.3° / 1.6° at 16 / 256
    /// ragdolls, against 2.2° / 4.0°) and its joints closer (6 mm against 8) for about 1.5
    /// times the time; fewer substeps of two passes lose it (24 substeps: 3.5° at 256).
    pub iterations: usize,
    /// Passes added in an impact (default [`DEFAULT_FAST_IMPACT_PASSES`], at most
    /// [`MAX_FAST_ITERATIONS`]; 0 for none): a step in which one of a ragdoll's parts may
    /// strike the ground or another body at more than 2 m/s, its island solves its joints
    /// and contacts `iterations` plus this many times a substep. An impact is where one
    /// pass falls short: a light part struck hands its blow on to the rest one joint per
    /// pass.
    pub impact_passes: usize,
    /// Whether joints that have stopped moving freeze (default true): the bodies they link
    /// move as one until a blow arrives, and cost as one (its level of detail below sleep;
    /// see the guide's Backends page).
    pub freeze_joints: bool,
    /// Whether a pair's contact found in one substep is carried to the next while its two
    /// shapes move less than half a millimetre against each other, instead of being found
    /// again (default false). It saved about a sixth of the time of columns of 30 to 63
    /// humanoids and 3 % of the standard piles' at N=256; in the columns the solver's
    /// limit readings came out 2-3° worse (the benchmarks page has the numbers).
    pub keep_contacts: bool,
    /// Whether joints are also turned back inside their limits on positions after every
    /// step (default true; see [`super::limits`]): the substeps leave a few degrees past
    /// a cone in the hardest landings (a spider's legs, up to 6°).
    pub project_limits: bool,
}

impl Default for FastConfig {
    fn default() -> Self {
        FastConfig {
            substeps: DEFAULT_FAST_SUBSTEPS,
            iterations: 1,
            impact_passes: DEFAULT_FAST_IMPACT_PASSES,
            freeze_joints: true,
            keep_contacts: false,
            project_limits: true,
        }
    }
}

/// Which engine moves the bodies, with its own settings
/// ([`WorldSettings::backend`](crate::world::WorldSettings::backend)).
///
/// # Example
///
/// The fast engine with two passes a substep, in a world, and built alone by the factory:
///
/// ```
/// use ragdoll::backend::{Backend, BackendConfig, FastConfig, Surroundings};
/// use ragdoll::world::{World, WorldSettings};
///
/// let config = BackendConfig::Fast(FastConfig { iterations: 2, ..Default::default() });
/// let settings = WorldSettings { backend: config, ..Default::default() };
/// let character = ragdoll::skeleton::humanoid();
/// let spec = ragdoll::spec::build_spec(&character, &Default::default()).unwrap();
/// let (mut world, _) = World::with_ragdoll(&character, &spec, &settings).unwrap();
/// world.run(0.1);
/// assert!(!world.metrics().nan);
///
/// let surroundings = Surroundings { gravity: glam::Vec3::ZERO, ground: None };
/// let engine: Box<dyn Backend> = config.build(&surroundings).unwrap();
/// assert_eq!(engine.kinetic_energy(), 0.0);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BackendConfig {
    /// rapier3d rigid bodies and impulse joints: the reference.
    Rigid(RigidConfig),
    /// Our position-based particle ragdoll, for creatures.
    Particle(ParticleConfig),
    /// Our rigid-body solver built for ragdolls, for crowds.
    Fast(FastConfig),
}

impl Default for BackendConfig {
    fn default() -> Self {
        BackendConfig::Rigid(RigidConfig::default())
    }
}

/// An engine by name, with its default settings.
impl From<BackendKind> for BackendConfig {
    fn from(kind: BackendKind) -> Self {
        match kind {
            BackendKind::Rigid => BackendConfig::Rigid(RigidConfig::default()),
            BackendKind::Particle => BackendConfig::Particle(ParticleConfig::default()),
            BackendKind::Fast => BackendConfig::Fast(FastConfig::default()),
        }
    }
}

impl BackendConfig {
    /// Which engine this configures.
    pub fn kind(&self) -> BackendKind {
        match self {
            BackendConfig::Rigid(_) => BackendKind::Rigid,
            BackendConfig::Particle(_) => BackendKind::Particle,
            BackendConfig::Fast(_) => BackendKind::Fast,
        }
    }

    /// The fast engine's settings, when this is the fast engine.
    pub fn fast(&self) -> Option<&FastConfig> {
        match self {
            BackendConfig::Fast(f) => Some(f),
            _ => None,
        }
    }

    /// The fast engine's settings to change, when this is the fast engine.
    pub fn fast_mut(&mut self) -> Option<&mut FastConfig> {
        match self {
            BackendConfig::Fast(f) => Some(f),
            _ => None,
        }
    }

    /// Checks every count is within its bounds ([`MAX_SUBSTEPS`],
    /// [`MAX_FAST_ITERATIONS`]) and the rigid engine's gap tolerance is a length; the
    /// error names the setting as the scene file does.
    pub fn validate(&self) -> Result<()> {
        if let BackendConfig::Rigid(RigidConfig {
            gap_tolerance_m: Some(t),
            ..
        }) = self
            && !(t.is_finite() && *t >= 0.0)
        {
            return Err(Error::Setting {
                setting: "gap_tolerance_m".into(),
                message: format!("must be a finite length of at least 0 m, not {t}"),
            });
        }
        let counts: &[(&str, usize, usize, usize)] = match self {
            BackendConfig::Rigid(c) => &[
                ("collision_substeps", c.collision_substeps, 1, MAX_SUBSTEPS),
                ("substeps", c.substeps, 1, MAX_SUBSTEPS),
                ("iterations", c.iterations, 1, MAX_SUBSTEPS),
            ],
            BackendConfig::Particle(c) => &[
                ("collision_substeps", c.collision_substeps, 1, MAX_SUBSTEPS),
                ("particle_substeps", c.substeps, 1, MAX_SUBSTEPS),
                ("particle_iterations", c.iterations, 1, MAX_SUBSTEPS),
            ],
            BackendConfig::Fast(c) => &[
                ("fast_substeps", c.substeps, 1, MAX_SUBSTEPS),
                ("fast_iterations", c.iterations, 1, MAX_FAST_ITERATIONS),
                (
                    "fast_impact_passes",
                    c.impact_passes,
                    0,
                    MAX_FAST_ITERATIONS,
                ),
            ],
        };
        match counts.iter().find(|(_, v, lo, hi)| !(lo..=hi).contains(&v)) {
            Some(&(setting, v, lo, hi)) => Err(Error::Setting {
                setting: setting.into(),
                message: format!("must be between {lo} and {hi}, not {v}"),
            }),
            None => Ok(()),
        }
    }

    /// The engine, built: the factory behind [`World::new`](crate::world::World::new),
    /// for a caller that wraps or drives one of ours itself.
    pub fn build(&self, surroundings: &Surroundings) -> Result<Box<dyn Backend>> {
        self.validate()?;
        Ok(match self.build_any(surroundings) {
            AnyBackend::Rigid(b) => b,
            AnyBackend::Particle(b) => b,
            AnyBackend::Fast(b) => b,
            AnyBackend::Custom(b) => b,
        })
    }

    /// The engine inside the world's own dispatch (see [`AnyBackend`]).
    pub(crate) fn build_any(&self, surroundings: &Surroundings) -> AnyBackend {
        match self {
            BackendConfig::Rigid(c) => {
                AnyBackend::Rigid(Box::new(RigidBackend::new(c, surroundings)))
            }
            BackendConfig::Particle(c) => {
                AnyBackend::Particle(Box::new(ParticleBackend::new(c, surroundings)))
            }
            BackendConfig::Fast(c) => AnyBackend::Fast(Box::new(FastBackend::new(c, surroundings))),
        }
    }

    /// How many times per world step the world steps the engine, with its events,
    /// motors and clips between: the collision substeps of engines that find contacts
    /// once per call, one for the fast engine, which substeps inside.
    pub(crate) fn world_substeps(&self) -> usize {
        match self {
            BackendConfig::Rigid(c) => c.collision_substeps,
            BackendConfig::Particle(c) => c.collision_substeps,
            BackendConfig::Fast(_) => 1,
        }
    }
}
