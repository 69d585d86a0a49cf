//! `Simulation`: a world stepped from Python a piece at a time, as a game or a tool
//! steps one: ragdolls added and removed between any two steps, bodies read as they are.
//! `World` builds a scene and runs it from the start; this one keeps going.

use std::sync::{Mutex, MutexGuard};

use glam::Quat;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use ragdoll::events::{Blast, Projectile, Push};
use ragdoll::math::Transform;
use ragdoll::scene::{MAX_CHARACTERS, MAX_EVENTS};
use ragdoll::spec::RagdollSpec;
use ragdoll::world::{RagdollId, World};

use crate::arrays::{self, ROW};
use crate::character::Character;
use crate::errors::{bound, guard, to_py};
use crate::events;
use crate::settings::{placement, point, shot_direction, world_settings};
use crate::spec::Spec;

/// A physics world stepped a piece at a time: `step(seconds)` goes on from where the last
/// step left it, and ragdolls can be added (`add`) and removed (`remove`) between any two
/// steps. A ragdoll added late starts at rest where it is placed; a removed one stops
/// where it is and nothing meets it any more. Every ragdoll's track has one frame per
/// output frame (a late one holds its start pose before it came, a removed one its last).
///
/// `backend` and the keyword settings are `World`'s.
#[pyclass(module = "ragdoll_sim")]
pub struct Simulation {
    /// Behind a lock because Python may share the object between threads; the lock is
    /// held for one call (a step releases the interpreter's lock, not this one).
    world: Mutex<World>,
    /// Each ragdoll's id, character and spec, in the order added (handles index them).
    ragdolls: Vec<(RagdollId, ragdoll::skeleton::Character, RagdollSpec)>,
    joints: usize,
    events: usize,
}

impl Simulation {
    fn world(&self) -> PyResult<MutexGuard<'_, World>> {
        self.world.lock().map_err(|_| {
            bound(
                "simulation",
                "an earlier call failed inside the engine (an InternalError); this simulation cannot go on",
            )
        })
    }

    fn room_for_event(&self) -> PyResult<()> {
        if self.events >= MAX_EVENTS {
            return Err(bound(
                "event",
                format!("a simulation holds at most {MAX_EVENTS} events"),
            ));
        }
        Ok(())
    }

    fn id(&self, handle: usize) -> PyResult<RagdollId> {
        if let Some((id, ..)) = self.ragdolls.get(handle) {
            Ok(*id)
        } else {
            Err(bound(
                "handle",
                format!(
                    "{handle} is not a ragdoll of this simulation, which holds {}",
                    self.ragdolls.len()
                ),
            ))
        }
    }
}

#[pymethods]
impl Simulation {
    #[new]
    #[pyo3(signature = (backend="rigid", **settings))]
    fn new(backend: &str, settings: Option<&Bound<'_, PyDict>>) -> PyResult<Simulation> {
        let s = world_settings(backend, settings)?;
        let world = World::new(&s).map_err(to_py)?;
        Ok(Simulation {
            world: Mutex::new(world),
            ragdolls: Vec::new(),
            joints: 0,
            events: 0,
        })
    }

    /// Adds `character` as a ragdoll (built from it unless `spec` is given), its feet at
    /// `at`, turned `facing_deg` about the vertical; returns its handle.
    #[pyo3(signature = (character, spec=None, *, at=None, facing_deg=0.0))]
    fn add(
        &mut self,
        py: Python<'_>,
        character: &Character,
        spec: Option<&Spec>,
        at: Option<&Bound<'_, PyAny>>,
        facing_deg: f32,
    ) -> PyResult<usize> {
        if self.ragdolls.len() >= MAX_CHARACTERS {
            return Err(bound(
                "character",
                format!("a simulation holds at most {MAX_CHARACTERS} ragdolls"),
            ));
        }
        let position = placement(at, facing_deg)?;
        let c = character.inner.clone();
        let spec = match spec {
            Some(s) => s.inner.clone(),
            None => py.detach(|| {
                guard(|| ragdoll::spec::build_spec(&c, &Default::default()).map_err(to_py))
            })?,
        };
        let placement = Transform::new(position, Quat::from_rotation_y(facing_deg.to_radians()));
        let id = {
            let mut world = self.world()?;
            guard(|| world.add_ragdoll(&c, &spec, placement).map_err(to_py))?
        };
        self.joints += c.skeleton.len();
        self.ragdolls.push((id, c, spec));
        Ok(self.ragdolls.len() - 1)
    }

    /// Takes ragdoll `handle` out from the next step: it stops where it is and nothing
    /// meets it any more.
    fn remove(&mut self, handle: usize) -> PyResult<()> {
        let id = self.id(handle)?;
        let mut world = self.world()?;
        guard(|| world.remove_ragdoll(id).map_err(to_py))
    }

    /// A charge of `tnt_kg` at `at` going off at `time_s` (seconds from the start; by
    /// default now), on the ground below `at` unless `air`; `scale` multiplies its loads.
    /// It acts on every ragdoll there is when its front reaches it, late ones included.
    #[pyo3(signature = (tnt_kg, at, *, time_s=None, air=false, scale=1.0))]
    fn add_blast(
        &mut self,
        tnt_kg: f32,
        at: &Bound<'_, PyAny>,
        time_s: Option<f32>,
        air: bool,
        scale: f32,
    ) -> PyResult<()> {
        self.room_for_event()?;
        let mut world = self.world()?;
        let mut position = point(at, "at")?;
        if !air && let Some(g) = world.settings().ground {
            position.y = g;
        }
        let blast = Blast {
            tnt_kg,
            position,
            time_s: time_s.unwrap_or(world.time() as f32),
            scale,
        };
        guard(|| world.add_blast(blast).map_err(to_py))?;
        drop(world);
        self.events += 1;
        Ok(())
    }

    /// A projectile from `origin`, flying along `direction` or toward `target`, giving its
    /// momentum (`mass_kg` at `speed_mps`) to the first body part it meets at `time_s`
    /// (seconds from the start; by default now).
    #[pyo3(signature = (origin, *, direction=None, target=None, mass_kg=0.008,
        speed_mps=360.0, time_s=None))]
    fn add_projectile(
        &mut self,
        origin: &Bound<'_, PyAny>,
        direction: Option<&Bound<'_, PyAny>>,
        target: Option<&Bound<'_, PyAny>>,
        mass_kg: f32,
        speed_mps: f32,
        time_s: Option<f32>,
    ) -> PyResult<()> {
        self.room_for_event()?;
        let origin = point(origin, "origin")?;
        let direction = shot_direction(origin, direction, target)?;
        let mut world = self.world()?;
        let shot = Projectile {
            origin,
            direction,
            mass_kg,
            speed_mps,
            time_s: time_s.unwrap_or(world.time() as f32),
        };
        guard(|| world.add_projectile(shot).map_err(to_py))?;
        drop(world);
        self.events += 1;
        Ok(())
    }

    /// An impulse of `impulse_ns` (N·s, world) on ragdoll `handle`'s body part `target` (a
    /// body of its spec or a joint of its skeleton) at `time_s` (by default now).
    #[pyo3(signature = (handle, target, impulse_ns, *, time_s=None))]
    fn add_push(
        &mut self,
        handle: usize,
        target: &str,
        impulse_ns: &Bound<'_, PyAny>,
        time_s: Option<f32>,
    ) -> PyResult<()> {
        self.room_for_event()?;
        let id = self.id(handle)?;
        let impulse_ns = arrays::vec3(impulse_ns, "impulse_ns")?;
        let mut world = self.world()?;
        let push = Push::Impulse {
            target: target.to_string(),
            impulse_ns,
            time_s: time_s.unwrap_or(world.time() as f32),
        };
        guard(|| world.add_push(id, push).map_err(to_py))?;
        drop(world);
        self.events += 1;
        Ok(())
    }

    /// A force field on every body, as `World.add_field`, from `start_s` (by default now)
    /// to `end_s` (by default for good).
    #[pyo3(signature = (kind, *, keys=None, center=None, strength_mps2=0.0, radius_m=1.0,
        rate_per_s=0.0, velocity_mps=None, start_s=None, end_s=None))]
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
        start_s: Option<f32>,
        end_s: Option<f32>,
    ) -> PyResult<()> {
        self.room_for_event()?;
        let mut world = self.world()?;
        let start_s = start_s.unwrap_or(world.time() as f32);
        let field = events::field(
            kind,
            keys,
            center,
            (strength_mps2, radius_m, rate_per_s),
            velocity_mps,
            (start_s, end_s),
        )?;
        guard(|| world.add_field(field).map_err(to_py))?;
        drop(world);
        self.events += 1;
        Ok(())
    }

    /// Holds ragdoll `handle`'s body part `target` (a body or joint name) at `position`,
    /// or drags it along `keys` = [(time_s, (x, y, z)), …] (world times), as
    /// `World.add_pin`.
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
        self.room_for_event()?;
        let id = self.id(handle)?;
        let pin = events::pin(
            target,
            position,
            keys,
            stiffness_hz,
            damping_ratio,
            release_s,
        )?;
        let mut world = self.world()?;
        guard(|| world.add_pin(id, pin).map_err(to_py))?;
        drop(world);
        self.events += 1;
        Ok(())
    }

    /// Drags ragdoll `handle`'s body part `target` along `keys` = [(time_s, (x, y, z)),
    /// …]: `add_pin` with keys.
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

    /// Ragdoll `handle`'s bodies' velocities now, one row each in its spec's order:
    /// linear (m/s) then angular (rad/s), world space: an array (bodies, 6).
    fn body_velocities<'py>(&self, py: Python<'py>, handle: usize) -> PyResult<Bound<'py, PyAny>> {
        let id = self.id(handle)?;
        let velocities = self.world()?.body_velocities(id);
        let data: Vec<f64> = velocities
            .iter()
            .flat_map(|(v, w)| [v.x, v.y, v.z, w.x, w.y, w.z].map(f64::from))
            .collect();
        Ok(arrays::array(py, &[velocities.len(), 6], data)?.into_any())
    }

    /// Simulates `seconds` more. The interpreter's lock is released while it steps.
    fn step(&mut self, py: Python<'_>, seconds: f32) -> PyResult<()> {
        if !(seconds.is_finite() && seconds >= 0.0) {
            return Err(bound(
                "seconds",
                format!("must be zero or more, not {seconds}"),
            ));
        }
        // Every frame is kept: the whole run is held to the bounds a run is.
        let mut world = self.world()?;
        let total = world.time() as f32 + seconds;
        world
            .settings()
            .validate_run(total, self.joints)
            .map_err(to_py)?;
        let world = &mut *world;
        py.detach(|| {
            guard(|| {
                world.run(seconds);
                Ok(())
            })
        })
    }

    /// Simulated time so far, seconds.
    #[getter]
    fn time(&self) -> PyResult<f64> {
        Ok(self.world()?.time())
    }

    /// Ragdoll `handle`'s bodies now, one row each in its spec's order: translation,
    /// rotation (x, y, z, w) and scale, world space: an array (bodies, 10).
    fn body_poses<'py>(&self, py: Python<'py>, handle: usize) -> PyResult<Bound<'py, PyAny>> {
        let id = self.id(handle)?;
        let poses = self.world()?.body_poses(id);
        let mut data = Vec::with_capacity(poses.len() * ROW);
        for p in &poses {
            arrays::push_row(&mut data, p);
        }
        Ok(arrays::array(py, &[poses.len(), ROW], data)?.into_any())
    }

    /// Ragdoll `handle`'s skeleton at every output frame so far, in its character's own
    /// joint order, world space: an array (frames, joints, 10).
    fn transforms<'py>(&self, py: Python<'py>, handle: usize) -> PyResult<Bound<'py, PyAny>> {
        let id = self.id(handle)?;
        let world = self.world()?;
        let track = world.track(id);
        let n = self.ragdolls[handle].1.skeleton.len();
        let mut data = Vec::with_capacity(track.frames.len() * n * ROW);
        for frame in &track.frames {
            for t in frame {
                arrays::push_row(&mut data, t);
            }
        }
        Ok(arrays::array(py, &[track.frames.len(), n, ROW], data)?.into_any())
    }

    /// How many ragdolls were added (removed ones included: handles stay valid).
    fn __len__(&self) -> usize {
        self.ragdolls.len()
    }
}
