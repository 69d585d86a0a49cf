//! Fields and pins from Python's keyword arguments, checked: one reading for `World`
//! (which runs a scene from the start) and `Simulation` (which adds them between steps).

use glam::Vec3;
use pyo3::prelude::*;
use ragdoll::events::{Field, OPEN_END_S, Pin};

use crate::arrays;
use crate::errors::{bound, to_py};
use crate::settings::point;

/// `(time_s, point)` keys.
pub(crate) fn keys(v: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<(f32, Vec3)>> {
    let raw: Vec<(f32, Bound<'_, PyAny>)> = v.extract()?;
    raw.iter()
        .map(|(t, p)| Ok((*t, arrays::vec3(p, what)?)))
        .collect()
}

/// A keyword argument a field of `kind` cannot go without.
fn need<'a, 'py>(
    v: Option<&'a Bound<'py, PyAny>>,
    kind: &str,
    key: &str,
) -> PyResult<&'a Bound<'py, PyAny>> {
    v.ok_or_else(|| bound(key, format!("a {kind} field needs {key}")))
}

/// A force field of `kind` (`"gravity"`, `"radial"`, `"drag"`, `"wind"`) with the
/// arguments it reads: `amounts` = (strength m/s², radius m, rate 1/s), `span` = (start
/// s, end s or open).
pub(crate) fn field(
    kind: &str,
    keys: Option<&Bound<'_, PyAny>>,
    center: Option<&Bound<'_, PyAny>>,
    amounts: (f32, f32, f32),
    velocity_mps: Option<&Bound<'_, PyAny>>,
    span: (f32, Option<f32>),
) -> PyResult<Field> {
    let (strength_mps2, radius_m, rate_per_s) = amounts;
    let (start_s, end_s) = (span.0, span.1.unwrap_or(OPEN_END_S));
    let field = match kind {
        "gravity" => Field::Gravity {
            keys: self::keys(need(keys, kind, "keys")?, "keys")?,
        },
        "radial" => Field::Radial {
            center: point(need(center, kind, "center")?, "center")?,
            strength_mps2,
            radius_m,
            start_s,
            end_s,
        },
        "drag" => Field::Drag {
            rate_per_s,
            start_s,
            end_s,
        },
        "wind" => Field::Wind {
            velocity_mps: arrays::vec3(need(velocity_mps, kind, "velocity_mps")?, "velocity_mps")?,
            start_s,
            end_s,
        },
        other => {
            return Err(bound(
                "kind",
                format!("must be \"gravity\", \"radial\", \"drag\" or \"wind\", not {other:?}"),
            ));
        }
    };
    field.validate().map_err(to_py)?;
    Ok(field)
}

/// A pin of body part `target` at `position`, or dragged along `keys`; a spring of
/// `stiffness_hz` (None: hard) with `damping_ratio`, letting go at `release_s`.
pub(crate) fn pin(
    target: String,
    position: Option<&Bound<'_, PyAny>>,
    keys: Option<&Bound<'_, PyAny>>,
    stiffness_hz: Option<f32>,
    damping_ratio: f32,
    release_s: Option<f32>,
) -> PyResult<Pin> {
    let keys = match (position, keys) {
        (Some(p), None) => vec![(0.0, point(p, "position")?)],
        (None, Some(k)) => self::keys(k, "keys")?,
        _ => return Err(bound("position", "give either position or keys")),
    };
    let pin = Pin {
        target,
        keys,
        stiffness_hz,
        damping_ratio,
        release_s,
    };
    pin.validate().map_err(to_py)?;
    Ok(pin)
}
