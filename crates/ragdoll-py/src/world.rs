//! `World`: characters and events put together in code, run as the command-line tool runs
//! a scene file (its `Result` is in `result.rs`).

use std::collections::HashSet;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use pyo3::prelude::*;
use pyo3::types::PyDict;
use ragdoll::events::{Blast, OPEN_END_S, Projectile, Push};
use ragdoll::scene::{Event, MAX_BURST, MAX_CHARACTERS, MAX_EVENTS, Scene, SceneCharacter};
use ragdoll::world::Activation;

use crate::arrays;
use crate::character::Character;
use crate::errors::{Cancelled, Fields, bound, guard, raise, to_py};
use crate::events;
use crate::result::RunResult;
use crate::settings::{activation, motors, placement, point, shot_direction, world_settings};
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
/// `start_pose` (`"first_frame"` or `"rest"`), `dt` and `joint_damping`, and the
/// chosen backend's own: `substeps`, `iterations`, `collision_substeps`,
/// `project_limits` and `gap_tolerance_m` (rigid: joint gaps wider than this many metres
/// narrowed on positions, off by default as it costs energy), `collision_substeps`,
/// `particle_substeps` and `particle_iterations` (particle), `fast_substeps`, `fast_iterations`,
/// `fast_impact_passes`, `freeze_joints`, `keep_contacts` and `project_limits` (fast). Another
/// backend's setting is refused.
#[pyclass(module = "ragdoll_sim")]
pub struct World {
    scene: Arc<Scene>,
    /// Character names taken, lower case (a name is a file name in the outputs).
    names: HashSet<String>,
}

fn events(s: &Scene) -> usize {
    s.blasts.len() + s.projectiles.len() + s.pushes.len() + s.fields.len() + s.pins.len()
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
            .push(Event::new(blast));
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
        scene.projectiles.extend(shots.into_iter().map(Event::new));
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
            .push(Event::new(field));
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
