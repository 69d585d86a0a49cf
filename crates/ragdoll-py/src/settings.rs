//! Python's keyword arguments read into the library's values, checked: a world's
//! settings, where a character stands, a shot's direction, points, hand-over and motors.

use glam::Vec3;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use ragdoll::world::{
    Activation, BackendConfig, BackendKind, MAX_COORDINATE_M, Motors, StartPose, WorldSettings,
};

use crate::arrays;
use crate::errors::{bound, to_py};

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
        (BackendConfig::Rigid(c), "project_limits") => c.project_limits = v.extract()?,
        (BackendConfig::Rigid(c), "gap_tolerance_m") => c.gap_tolerance_m = v.extract()?,
        (BackendConfig::Particle(c), "collision_substeps") => c.collision_substeps = v.extract()?,
        (BackendConfig::Particle(c), "particle_substeps") => c.substeps = v.extract()?,
        (BackendConfig::Particle(c), "particle_iterations") => c.iterations = v.extract()?,
        (BackendConfig::Fast(c), "fast_substeps") => c.substeps = v.extract()?,
        (BackendConfig::Fast(c), "fast_iterations") => c.iterations = v.extract()?,
        (BackendConfig::Fast(c), "fast_impact_passes") => c.impact_passes = v.extract()?,
        (BackendConfig::Fast(c), "freeze_joints") => c.freeze_joints = v.extract()?,
        (BackendConfig::Fast(c), "keep_contacts") => c.keep_contacts = v.extract()?,
        (BackendConfig::Fast(c), "project_limits") => c.project_limits = v.extract()?,
        (c, key) => {
            let owner = match key {
                "substeps" | "iterations" | "gap_tolerance_m" => Some("rigid"),
                "project_limits" => Some("rigid and fast"),
                "collision_substeps" => Some("rigid and particle"),
                "particle_substeps" | "particle_iterations" => Some("particle"),
                "fast_substeps" | "fast_iterations" | "fast_impact_passes" | "freeze_joints"
                | "keep_contacts" => Some("fast"),
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

/// The world's settings from a backend name and keyword settings (see `World`).
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
pub(crate) fn activation(v: &Bound<'_, PyAny>) -> PyResult<Activation> {
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
pub(crate) fn motors(v: &Bound<'_, PyAny>) -> PyResult<Motors> {
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
