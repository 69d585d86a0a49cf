//! `World`: characters and events put together in code, run as the command-line tool runs
//! a scene file, and the `Result` it gives: joint transforms as numpy arrays, the report,
//! and the files.

use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use glam::Vec3;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use ragdoll::events::{Blast, OPEN_END_S, Projectile, Push};
use ragdoll::math::Transform;
use ragdoll::scene::{
    Event, MAX_BURST, MAX_CHARACTERS, MAX_EVENTS, Scene, SceneCharacter, SceneResult,
};
use ragdoll::world::{
    Activation, BackendConfig, BackendKind, MAX_COORDINATE_M, Motors, StartPose, WorldSettings,
};

use crate::arrays::{self, ROW};
use crate::character::Character;
use crate::errors::{Cancelled, Fields, bound, guard, raise, to_py};
use crate::events;
use crate::spec::Spec;

/// A world's run length when `run` is not told, seconds: a scene file's default.
const DEFAULT_SECONDS: f32 = 3.0;

/// How often a run looks up from stepping: to call the progress callback and to notice
/// Ctrl-C.
const LOOK_UP: Duration = Duration::from_millis(20);

/// A physics world: characters, each with its ragdoll, and the events that act on them
/// (blasts, projectiles, pushes, fields, pins and drags). `run()` simulates it from the
/// start; a world can be run again, with more added, as often as needed.
///
/// `backend` is `"rigid"` (rapier, the reference), `"fast"` (our solver built for
/// crowds) or `"particle"`; the other keyword arguments are the world's settings:
/// `gravity` (3 numbers, m/s²), `ground` (height in metres, or None for none),
/// `start_pose` (`"first_frame"` or `"rest"`), `dt`, `project_limits` and
/// `joint_damping`, and the chosen backend's own: `substeps`, `iterations` and
/// `collision_substeps` (rigid), `collision_substeps`, `particle_substeps` and
/// `particle_iterations` (particle), `fast_substeps`, `fast_iterations`,
/// `fast_impact_passes` and `freeze_joints` (fast). Another backend's setting is refused.
#[pyclass(module = "ragdoll_sim")]
pub struct World {
    scene: Arc<Scene>,
    /// Character names taken, lower case (a name is a file name in the outputs).
    names: HashSet<String>,
}

fn events(s: &Scene) -> usize {
    s.blasts.len() + s.projectiles.len() + s.pushes.len() + s.fields.len() + s.pins.len()
}

/// Applies one keyword setting.
fn set(s: &mut WorldSettings, key: &str, v: &Bound<'_, PyAny>) -> PyResult<()> {
    match key {
        "gravity" => s.gravity = arrays::vec3(v, "gravity")?,
        "ground" => s.ground = v.extract::<Option<f32>>()?,
        "start_pose" => {
            s.start = match v.extract::<String>()?.as_str() {
                "first_frame" => StartPose::FirstFrame,
                "rest" => StartPose::Rest,
                other => {
                    return Err(bound(
                        key,
                        format!("must be \"first_frame\" or \"rest\", not {other:?}"),
                    ));
                }
            }
        }
        "dt" => s.dt = v.extract()?,
        "project_limits" => s.project_limits = v.extract()?,
        "joint_damping" => s.joint_damping = v.extract()?,
        other => return set_engine(&mut s.backend, other, v),
    }
    Ok(())
}

/// Applies one keyword setting of the engine; a setting of another engine is refused, as
/// it would change nothing.
fn set_engine(c: &mut BackendConfig, key: &str, v: &Bound<'_, PyAny>) -> PyResult<()> {
    match (c, key) {
        (BackendConfig::Rigid(c), "substeps") => c.substeps = v.extract()?,
        (BackendConfig::Rigid(c), "iterations") => c.iterations = v.extract()?,
        (BackendConfig::Rigid(c), "collision_substeps") => c.collision_substeps = v.extract()?,
        (BackendConfig::Particle(c), "collision_substeps") => c.collision_substeps = v.extract()?,
        (BackendConfig::Particle(c), "particle_substeps") => c.substeps = v.extract()?,
        (BackendConfig::Particle(c), "particle_iterations") => c.iterations = v.extract()?,
        (BackendConfig::Fast(c), "fast_substeps") => c.substeps = v.extract()?,
        (BackendConfig::Fast(c), "fast_iterations") => c.iterations = v.extract()?,
        (BackendConfig::Fast(c), "fast_impact_passes") => c.impact_passes = v.extract()?,
        (BackendConfig::Fast(c), "freeze_joints") => c.freeze_joints = v.extract()?,
        (c, key) => {
            let owner = match key {
                "substeps" | "iterations" => Some("rigid"),
                "collision_substeps" => Some("rigid and particle"),
                "particle_substeps" | "particle_iterations" => Some("particle"),
                "fast_substeps" | "fast_iterations" | "fast_impact_passes" | "freeze_joints" => {
                    Some("fast")
                }
                _ => None,
            };
            return Err(match owner {
                Some(owner) => bound(
                    key,
                    format!(
                        "is a setting of the {owner} backend only; this world's is \"{}\"",
                        c.kind().as_str()
                    ),
                ),
                None => bound(key, "is not a world setting"),
            });
        }
    }
    Ok(())
}

/// The world's settings from a backend name and keyword settings (see [`World`]).
pub(crate) fn world_settings(
    backend: &str,
    settings: Option<&Bound<'_, PyDict>>,
) -> PyResult<WorldSettings> {
    let mut s = WorldSettings {
        backend: BackendKind::from_name(backend)
            .ok_or_else(|| {
                bound(
                    "backend",
                    format!("must be \"rigid\", \"fast\" or \"particle\", not {backend:?}"),
                )
            })?
            .into(),
        ..WorldSettings::default()
    };
    if let Some(kw) = settings {
        for (k, v) in kw.iter() {
            set(&mut s, &k.extract::<String>()?, &v)?;
        }
    }
    s.validate().map_err(to_py)?;
    Ok(s)
}

/// Where a character's feet go (`at`, the origin when not given), with its facing checked.
pub(crate) fn placement(at: Option<&Bound<'_, PyAny>>, facing_deg: f32) -> PyResult<Vec3> {
    let position = match at {
        Some(p) => point(p, "at")?,
        None => Vec3::ZERO,
    };
    if !(facing_deg.is_finite() && facing_deg.abs() <= 360.0) {
        return Err(bound(
            "facing_deg",
            format!("must be within ±360, not {facing_deg}"),
        ));
    }
    Ok(position)
}

/// A shot's direction of flight: `direction`, or from `origin` toward `target`.
pub(crate) fn shot_direction(
    origin: Vec3,
    direction: Option<&Bound<'_, PyAny>>,
    target: Option<&Bound<'_, PyAny>>,
) -> PyResult<Vec3> {
    match (direction, target) {
        (Some(d), None) => arrays::vec3(d, "direction"),
        (None, Some(t)) => Ok(point(t, "target")? - origin),
        _ => Err(bound("direction", "give either direction or target")),
    }
}

/// A point of the world, within the bounds the world holds every coordinate to.
pub(crate) fn point(v: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec3> {
    let p = arrays::vec3(v, what)?;
    if p.abs().max_element() > MAX_COORDINATE_M {
        return Err(bound(
            what,
            format!("{p} lies past the {MAX_COORDINATE_M} m the world reaches"),
        ));
    }
    Ok(p)
}

/// When physics takes over from the animation.
fn activation(v: &Bound<'_, PyAny>) -> PyResult<Activation> {
    if let Ok(t) = v.extract::<f32>() {
        return Ok(Activation::AtTime(t));
    }
    match v.extract::<String>()?.as_str() {
        "start" => Ok(Activation::Immediately),
        "blast" => Ok(Activation::OnBlast),
        "contact" => Ok(Activation::OnContact),
        other => Err(bound(
            "activate",
            format!("must be \"start\", \"blast\", \"contact\" or seconds, not {other:?}"),
        )),
    }
}

/// Motors from a strength, or a dict of `strength`, `fade_out` and `root_on_clip`.
fn motors(v: &Bound<'_, PyAny>) -> PyResult<Motors> {
    if let Ok(strength) = v.extract::<f32>() {
        return Ok(Motors::constant(strength));
    }
    let d = v.cast::<PyDict>()?;
    let strength: f32 = match d.get_item("strength")? {
        Some(s) => s.extract()?,
        None => 1.0,
    };
    let mut m = match d.get_item("fade_out")? {
        Some(f) => {
            let (a, b): (f32, f32) = f.extract()?;
            Motors::fade_out(strength, a, b)
        }
        None => Motors::constant(strength),
    };
    if let Some(r) = d.get_item("root_on_clip")? {
        m.root_on_clip = r.extract()?;
    }
    Ok(m)
}

#[pymethods]
impl World {
    #[new]
    #[pyo3(signature = (backend="rigid", **settings))]
    fn new(backend: &str, settings: Option<&Bound<'_, PyDict>>) -> PyResult<World> {
        let s = world_settings(backend, settings)?;
        let scene = Scene::new(PathBuf::new(), DEFAULT_SECONDS, s);
        Ok(World {
            scene: Arc::new(scene),
            names: HashSet::new(),
        })
    }

    /// A world from a scene file (`ragdoll simulate SCENE.toml` reads the same): its
    /// characters, events, settings, length and frame rate; more can be added.
    #[staticmethod]
    fn from_scene(py: Python<'_>, path: PathBuf) -> PyResult<World> {
        let scene = py.detach(|| guard(|| Scene::load(&path).map_err(to_py)))?;
        let names = scene
            .characters
            .iter()
            .map(|c| c.name.to_lowercase())
            .collect();
        Ok(World {
            scene: Arc::new(scene),
            names,
        })
    }

    /// Adds a character and returns its handle (an index from 0, in the order added).
    ///
    /// `spec` is its ragdoll (built with `build_ragdoll(character, mass_kg=, female=)` when
    /// None); `at` where it stands and `facing_deg` its turn about the vertical; `activate`
    /// when physics takes over from its animation (`"start"`, seconds, `"blast"` when the
    /// first blast front reaches it, `"contact"`); `clip_offset_s` how far into its clip it
    /// starts; `powered` motors that follow its animation (a strength from 0 to 1, or a
    /// dict with `strength`, `fade_out` = (start, end) seconds and `root_on_clip`).
    #[pyo3(signature = (character, spec=None, *, at=None, facing_deg=0.0, name=None,
        activate=None, clip_offset_s=0.0, powered=None, mass_kg=None, female=false))]
    #[allow(clippy::too_many_arguments)]
    fn add(
        &mut self,
        py: Python<'_>,
        character: &Character,
        spec: Option<&Spec>,
        at: Option<&Bound<'_, PyAny>>,
        facing_deg: f32,
        name: Option<&str>,
        activate: Option<&Bound<'_, PyAny>>,
        clip_offset_s: f32,
        powered: Option<&Bound<'_, PyAny>>,
        mass_kg: Option<f32>,
        female: bool,
    ) -> PyResult<usize> {
        if self.scene.characters.len() >= MAX_CHARACTERS {
            return Err(bound(
                "character",
                format!("a world holds at most {MAX_CHARACTERS} characters"),
            ));
        }
        let position = placement(at, facing_deg)?;
        let activation = match activate {
            Some(a) => activation(a)?,
            None => Activation::Immediately,
        };
        let motors = powered.map(motors).transpose()?;
        if let Some(m) = &motors {
            m.validate().map_err(to_py)?;
        }
        let plays = character.inner.clips.iter().any(|c| !c.frames.is_empty());
        if !plays && (activation != Activation::Immediately || motors.is_some()) {
            let key = if motors.is_some() {
                "powered"
            } else {
                "activate"
            };
            return Err(bound(
                key,
                format!(
                    "{} has no animation to play or follow; use activate=\"start\" and no motors",
                    character.inner.name
                ),
            ));
        }
        if !(clip_offset_s.is_finite() && clip_offset_s >= 0.0) {
            return Err(bound(
                "clip_offset_s",
                format!("must be zero or more seconds, not {clip_offset_s}"),
            ));
        }
        let mut c = character.inner.clone();
        let mut spec = match spec {
            Some(s) => s.inner.clone(),
            None => {
                let opts = ragdoll::spec::BuildOptions {
                    total_mass_kg: mass_kg,
                    female,
                };
                py.detach(|| guard(|| ragdoll::spec::build_spec(&c, &opts).map_err(to_py)))?
            }
        };
        // The spec must fit this character: every body on a bone it has, every value within
        // bounds; said now rather than when the world is run.
        spec.validate().map_err(to_py)?;
        ragdoll::spec::Resolved::new(&spec, &c).map_err(to_py)?;
        let given = name;
        let name = ragdoll::scene::unique_character_name(given.unwrap_or(&c.name), &mut self.names);
        if let Some(wanted) = given
            && wanted != name
        {
            self.names.remove(&name.to_lowercase());
            return Err(bound(
                "name",
                format!(
                    "{wanted:?} is taken or is not 1 to {} letters, digits, '_', '-' or '.' (not first): it names the character's files",
                    ragdoll::scene::MAX_CHARACTER_NAME_BYTES
                ),
            ));
        }
        c.name = name.clone();
        spec.name = name.clone();
        let index = self.scene.characters.len();
        Arc::make_mut(&mut self.scene)
            .characters
            .push(SceneCharacter {
                name: name.clone(),
                input: character.input.clone(),
                character: c,
                spec,
                position,
                facing_deg,
                activation,
                clip_offset_s,
                motors,
                line: 0,
                place: format!("character {index} {name:?}"),
            });
        Ok(index)
    }

    /// A charge of `tnt_kg` kilograms of TNT at `at`, going off at `time_s`. With `air`
    /// False it lies on the ground (its height is the ground's); with True it goes off
    /// where `at` puts it, and its height above the ground decides how much of a surface
    /// or a free-air burst it is. `scale` multiplies the loads (1 is physical).
    #[pyo3(signature = (tnt_kg, at, time_s=0.0, air=false, scale=1.0))]
    fn add_blast(
        &mut self,
        tnt_kg: f32,
        at: &Bound<'_, PyAny>,
        time_s: f32,
        air: bool,
        scale: f32,
    ) -> PyResult<()> {
        let mut position = point(at, "at")?;
        if !air && let Some(g) = self.scene.settings.ground {
            position.y = g;
        }
        let blast = Blast {
            tnt_kg,
            position,
            time_s,
            scale,
        };
        blast.validate().map_err(to_py)?;
        self.room_for(1)?;
        Arc::make_mut(&mut self.scene)
            .blasts
            .push(world_event(blast));
        Ok(())
    }

    /// A projectile from `origin`, flying along `direction` or toward `target`, giving its
    /// momentum (`mass_kg` at `speed_mps`) to the first body part it meets at `time_s`; a
    /// burst of `count` shots `interval_s` apart.
    #[pyo3(signature = (origin, *, direction=None, target=None, mass_kg=0.008,
        speed_mps=360.0, time_s=0.0, count=1, interval_s=0.1))]
    #[allow(clippy::too_many_arguments)]
    fn add_projectile(
        &mut self,
        origin: &Bound<'_, PyAny>,
        direction: Option<&Bound<'_, PyAny>>,
        target: Option<&Bound<'_, PyAny>>,
        mass_kg: f32,
        speed_mps: f32,
        time_s: f32,
        count: u32,
        interval_s: f32,
    ) -> PyResult<()> {
        let origin = point(origin, "origin")?;
        let direction = shot_direction(origin, direction, target)?;
        if !(1..=MAX_BURST).contains(&count) {
            return Err(bound(
                "count",
                format!("must be between 1 and {MAX_BURST}, not {count}"),
            ));
        }
        if !(interval_s.is_finite() && interval_s >= 0.0) {
            return Err(bound(
                "interval_s",
                format!("must be zero or more seconds, not {interval_s}"),
            ));
        }
        let shots: Vec<Projectile> = (0..count)
            .map(|k| Projectile {
                origin,
                direction,
                mass_kg,
                speed_mps,
                time_s: time_s + k as f32 * interval_s,
            })
            .collect();
        for s in &shots {
            s.validate().map_err(to_py)?;
        }
        self.room_for(shots.len())?;
        let scene = Arc::make_mut(&mut self.scene);
        scene.projectiles.extend(shots.into_iter().map(world_event));
        Ok(())
    }

    /// A push on one body part of character `handle` (a body or joint name): an impulse
    /// (`impulse_ns`, N·s) at `time_s`, or a force (`force_n`, N) from `start_s` to `end_s`.
    #[pyo3(signature = (handle, target, *, impulse_ns=None, time_s=0.0, force_n=None,
        start_s=0.0, end_s=None))]
    #[allow(clippy::too_many_arguments)]
    fn add_push(
        &mut self,
        handle: usize,
        target: String,
        impulse_ns: Option<&Bound<'_, PyAny>>,
        time_s: f32,
        force_n: Option<&Bound<'_, PyAny>>,
        start_s: f32,
        end_s: Option<f32>,
    ) -> PyResult<()> {
        self.character(handle)?;
        let push = match (impulse_ns, force_n) {
            (Some(i), None) => Push::Impulse {
                target,
                impulse_ns: arrays::vec3(i, "impulse_ns")?,
                time_s,
            },
            (None, Some(f)) => Push::Force {
                target,
                force_n: arrays::vec3(f, "force_n")?,
                start_s,
                end_s: end_s.unwrap_or(OPEN_END_S),
            },
            _ => return Err(bound("impulse_ns", "give either impulse_ns or force_n")),
        };
        push.validate().map_err(to_py)?;
        self.room_for(1)?;
        Arc::make_mut(&mut self.scene).pushes.push(Event {
            event: push,
            character: Some(handle),
            line: 0,
        });
        Ok(())
    }

    /// A force field on every body: `"gravity"` with `keys` = [(time_s, (x, y, z)), …];
    /// `"radial"` with `center`, `strength_mps2` and `radius_m`; `"drag"` with
    /// `rate_per_s`; `"wind"` with `velocity_mps`; the last three from `start_s` to `end_s`.
    #[pyo3(signature = (kind, *, keys=None, center=None, strength_mps2=0.0, radius_m=1.0,
        rate_per_s=0.0, velocity_mps=None, start_s=0.0, end_s=None))]
    #[allow(clippy::too_many_arguments)]
    fn add_field(
        &mut self,
        kind: &str,
        keys: Option<&Bound<'_, PyAny>>,
        center: Option<&Bound<'_, PyAny>>,
        strength_mps2: f32,
        radius_m: f32,
        rate_per_s: f32,
        velocity_mps: Option<&Bound<'_, PyAny>>,
        start_s: f32,
        end_s: Option<f32>,
    ) -> PyResult<()> {
        let field = events::field(
            kind,
            keys,
            center,
            (strength_mps2, radius_m, rate_per_s),
            velocity_mps,
            (start_s, end_s),
        )?;
        self.room_for(1)?;
        Arc::make_mut(&mut self.scene)
            .fields
            .push(world_event(field));
        Ok(())
    }

    /// Holds a body part of character `handle` (a body or joint name) at `position`, or
    /// drags it along `keys` = [(time_s, (x, y, z)), …]; a spring of `stiffness_hz` (None:
    /// hard) with `damping_ratio`, letting go at `release_s`.
    #[pyo3(signature = (handle, target, position=None, *, keys=None, stiffness_hz=None,
        damping_ratio=1.0, release_s=None))]
    #[allow(clippy::too_many_arguments)]
    fn add_pin(
        &mut self,
        handle: usize,
        target: String,
        position: Option<&Bound<'_, PyAny>>,
        keys: Option<&Bound<'_, PyAny>>,
        stiffness_hz: Option<f32>,
        damping_ratio: f32,
        release_s: Option<f32>,
    ) -> PyResult<()> {
        self.character(handle)?;
        let pin = events::pin(
            target,
            position,
            keys,
            stiffness_hz,
            damping_ratio,
            release_s,
        )?;
        self.room_for(1)?;
        Arc::make_mut(&mut self.scene).pins.push(Event {
            event: pin,
            character: Some(handle),
            line: 0,
        });
        Ok(())
    }

    /// Drags a body part of character `handle` along `keys` = [(time_s, (x, y, z)), …]:
    /// `add_pin` with keys.
    #[pyo3(signature = (handle, target, keys, *, stiffness_hz=None, damping_ratio=1.0,
        release_s=None))]
    fn add_drag(
        &mut self,
        handle: usize,
        target: String,
        keys: &Bound<'_, PyAny>,
        stiffness_hz: Option<f32>,
        damping_ratio: f32,
        release_s: Option<f32>,
    ) -> PyResult<()> {
        self.add_pin(
            handle,
            target,
            None,
            Some(keys),
            stiffness_hz,
            damping_ratio,
            release_s,
        )
    }

    /// How many characters it holds.
    fn __len__(&self) -> usize {
        self.scene.characters.len()
    }

    /// The backend's name.
    #[getter]
    fn backend(&self) -> &'static str {
        self.scene.settings.backend.kind().as_str()
    }

    /// Simulates `seconds` from the start and records `fps` frames a second (by default
    /// the scene file's, or 3 s at 30 fps). The interpreter's lock is released while it
    /// steps, so other Python threads run.
    ///
    /// `progress(done, total)` (steps) is called now and then; returning False cancels
    /// the run with `Cancelled`. Ctrl-C cancels it with `KeyboardInterrupt`.
    #[pyo3(signature = (seconds=None, fps=None, progress=None))]
    fn run(
        &mut self,
        py: Python<'_>,
        seconds: Option<f32>,
        fps: Option<f32>,
        progress: Option<Py<PyAny>>,
    ) -> PyResult<RunResult> {
        if self.scene.characters.is_empty() {
            return Err(bound(
                "character",
                "the world holds no character; add one first",
            ));
        }
        {
            let scene = Arc::make_mut(&mut self.scene);
            if let Some(fps) = fps {
                scene.settings.fps = fps;
            }
            if let Some(seconds) = seconds {
                scene.duration_s = seconds;
            }
            scene.settings.validate().map_err(to_py)?;
            let joints = scene
                .characters
                .iter()
                .map(|c| c.character.skeleton.len())
                .sum();
            scene
                .settings
                .validate_run(scene.duration_s, joints)
                .map_err(to_py)?;
        }
        let scene = Arc::clone(&self.scene);
        let mut stop: Option<PyErr> = None;
        let result = {
            let stop = &mut stop;
            let progress = progress.as_ref();
            let s = &scene;
            py.detach(move || {
                guard(|| {
                    let mut last = Instant::now();
                    s.run_until(|done, total| {
                        if done < total && last.elapsed() < LOOK_UP {
                            return true;
                        }
                        last = Instant::now();
                        Python::attach(|py| match look_up(py, progress, done, total) {
                            Ok(go) => go,
                            Err(e) => {
                                *stop = Some(e);
                                false
                            }
                        })
                    })
                    .map_err(to_py)
                })
            })?
        };
        match (result, stop) {
            (Some(result), _) => Ok(RunResult { scene, result }),
            (None, Some(e)) => Err(e),
            (None, None) => Err(raise::<Cancelled>(
                "the run was cancelled by its progress callback".into(),
                Fields {
                    message: "the run was cancelled by its progress callback".into(),
                    ..Fields::default()
                },
            )),
        }
    }

    fn __repr__(&self) -> String {
        format!(
            "<World {}: {} characters, {} events>",
            self.scene.settings.backend.kind().as_str(),
            self.scene.characters.len(),
            events(&self.scene)
        )
    }
}

impl World {
    fn room_for(&self, more: usize) -> PyResult<()> {
        if events(&self.scene) + more > MAX_EVENTS {
            return Err(bound(
                "event",
                format!("a world holds at most {MAX_EVENTS} events, shots counted one by one"),
            ));
        }
        Ok(())
    }

    fn character(&self, handle: usize) -> PyResult<&SceneCharacter> {
        self.scene.characters.get(handle).ok_or_else(|| {
            bound(
                "handle",
                format!(
                    "{handle} is not a character of this world (it holds {})",
                    self.scene.characters.len()
                ),
            )
        })
    }
}

/// An event acting on every character.
fn world_event<T>(event: T) -> Event<T> {
    Event {
        event,
        character: None,
        line: 0,
    }
}

/// Between steps: Ctrl-C, then the progress callback; whether to go on.
fn look_up(py: Python<'_>, progress: Option<&Py<PyAny>>, done: u64, total: u64) -> PyResult<bool> {
    py.check_signals()?;
    let Some(f) = progress else {
        return Ok(true);
    };
    let answer = f.call1(py, (done, total))?;
    let answer = answer.bind(py);
    Ok(answer.is_none() || answer.is_truthy()?)
}

/// What a run gives: every character's joint transforms per frame, the report, and the
/// files it saves.
#[pyclass(module = "ragdoll_sim", frozen, name = "Result")]
pub struct RunResult {
    scene: Arc<Scene>,
    result: SceneResult,
}

impl RunResult {
    fn track(&self, handle: usize) -> PyResult<(&SceneCharacter, &ragdoll::track::Track)> {
        match (
            self.scene.characters.get(handle),
            self.result.tracks.get(handle),
        ) {
            (Some(c), Some(t)) => Ok((c, t)),
            _ => Err(bound(
                "handle",
                format!(
                    "{handle} is not a character of this result (it holds {})",
                    self.result.tracks.len()
                ),
            )),
        }
    }
}

#[pymethods]
impl RunResult {
    /// Joint transforms of character `handle`, (frames, joints, 10) in the character's own
    /// joint order: translation, rotation x y z w, scale. `space="local"` gives each
    /// joint relative to its parent (what a rig's pose bones and the files hold; a root
    /// relative to the world), `"world"` in world space.
    #[pyo3(signature = (handle=0, space="local"))]
    fn transforms<'py>(
        &self,
        py: Python<'py>,
        handle: usize,
        space: &str,
    ) -> PyResult<Bound<'py, PyAny>> {
        let (c, track) = self.track(handle)?;
        let skeleton = &c.character.skeleton;
        let n = skeleton.len();
        let local = match space {
            "local" => true,
            "world" => false,
            other => {
                return Err(bound(
                    "space",
                    format!("must be \"local\" or \"world\", not {other:?}"),
                ));
            }
        };
        let mut data = Vec::with_capacity(track.frames.len() * n * ROW);
        let mut out = vec![Transform::IDENTITY; n];
        for frame in &track.frames {
            let rows = if local {
                skeleton.local_from_world(frame, &mut out);
                &out
            } else {
                frame
            };
            for t in rows {
                arrays::push_row(&mut data, t);
            }
        }
        Ok(arrays::array(py, &[track.frames.len(), n, ROW], data)?.into_any())
    }

    /// The run's report, as the JSON report the command-line tool writes.
    #[getter]
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let json = py.import("json")?;
        json.call_method1("loads", (self.result.report.to_json(),))
    }

    /// Frames recorded (the first frame included).
    #[getter]
    fn frames(&self) -> usize {
        self.result.tracks.first().map_or(0, |t| t.frames.len())
    }

    /// Frames per second.
    #[getter]
    fn fps(&self) -> f32 {
        self.scene.settings.fps
    }

    /// The characters' names, by handle.
    #[getter]
    fn names(&self) -> Vec<String> {
        self.scene
            .characters
            .iter()
            .map(|c| c.name.clone())
            .collect()
    }

    /// The character of `handle` as it was run, with its ragdoll's spec.
    fn spec(&self, handle: usize) -> PyResult<Spec> {
        Ok(Spec {
            inner: self.track(handle)?.0.spec.clone(),
        })
    }

    /// Writes the result: `.glb` every character in one binary glTF (or only `handle`'s), `.bvh` one character's motion (`handle`, needed when there are
    /// several), `.json` the report. Written atomically: a failure leaves no partial file.
    #[pyo3(signature = (path, handle=None))]
    fn save(&self, py: Python<'_>, path: PathBuf, handle: Option<usize>) -> PyResult<()> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .unwrap_or_default();
        let parts: Vec<usize> = match handle {
            Some(h) => {
                self.track(h)?;
                vec![h]
            }
            None => (0..self.scene.characters.len()).collect(),
        };
        let bytes = py.detach(|| guard(|| self.encode(&ext, &parts, &path)))?;
        ragdoll::export::write_atomic(&path, &bytes).map_err(to_py)
    }

    fn __len__(&self) -> usize {
        self.result.tracks.len()
    }

    fn __repr__(&self) -> String {
        format!(
            "<Result: {} characters, {} frames at {} fps>",
            self.result.tracks.len(),
            self.frames(),
            self.scene.settings.fps
        )
    }
}

impl RunResult {
    /// The bytes of the file `path` names, by its extension.
    fn encode(&self, ext: &str, parts: &[usize], path: &Path) -> PyResult<Vec<u8>> {
        let chars = &self.scene.characters;
        match ext {
            "glb" => {
                let list: Vec<_> = parts
                    .iter()
                    .map(|&h| (&chars[h].character, &chars[h].spec, &self.result.tracks[h]))
                    .collect();
                ragdoll::export::gltf::scene_to_glb(&list).map_err(to_py)
            }
            "bvh" => {
                let [h] = parts else {
                    return Err(bound(
                        "handle",
                        format!(
                            "a BVH file holds one character and this result has {}; give handle",
                            parts.len()
                        ),
                    ));
                };
                ragdoll::export::bvh::to_bvh(&chars[*h].character, &self.result.tracks[*h])
                    .map(String::into_bytes)
                    .map_err(to_py)
            }
            "json" => Ok(self.result.report.to_json().into_bytes()),
            _ => Err(bound(
                "path",
                format!(
                    "{}: the extension says neither glTF (.glb), BVH (.bvh) nor a report (.json)",
                    path.display()
                ),
            )),
        }
    }
}
