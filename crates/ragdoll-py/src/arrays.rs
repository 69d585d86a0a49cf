//! numpy arrays in and out: transforms as rows of ten numbers (translation, rotation
//! x y z w, scale), read from whatever array-like a host hands over.

use glam::{Quat, Vec3};
use numpy::ndarray::Array;
use numpy::{IntoPyArray, PyArrayDyn, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use ragdoll::math::Transform;

use crate::errors::bound;

/// Numbers per transform row.
pub(crate) const ROW: usize = 10;

/// `obj` as a C-contiguous array of `dtype` with `ndim` axes, the last `cols` long (when
/// given); its shape and data. `what` names the argument in errors.
fn contiguous<T: numpy::Element + Copy>(
    obj: &Bound<'_, PyAny>,
    dtype: &str,
    ndim: usize,
    cols: Option<usize>,
    what: &str,
) -> PyResult<(Vec<usize>, Vec<T>)> {
    let py = obj.py();
    let np = py.import("numpy")?;
    let kwargs = PyDict::new(py);
    kwargs.set_item("dtype", dtype)?;
    let arr = np
        .call_method("ascontiguousarray", (obj,), Some(&kwargs))
        .map_err(|e| bound(what, format!("must be a numeric array ({e})")))?;
    let arr: PyReadonlyArrayDyn<'_, T> = arr.extract()?;
    let shape = arr.shape().to_vec();
    if shape.len() != ndim || cols.is_some_and(|c| shape.last() != Some(&c)) {
        let want = match cols {
            Some(c) => format!("{ndim} axes, the last {c} long"),
            None => format!("{ndim} axes"),
        };
        return Err(bound(
            what,
            format!("must have {want}, not shape {shape:?}"),
        ));
    }
    let data = arr
        .as_slice()
        .map_err(|e| bound(what, e.to_string()))?
        .to_vec();
    Ok((shape, data))
}

/// A float array: its shape and its values as f32, all finite.
pub(crate) fn floats(
    obj: &Bound<'_, PyAny>,
    ndim: usize,
    cols: Option<usize>,
    what: &str,
) -> PyResult<(Vec<usize>, Vec<f32>)> {
    checked_floats(obj, ndim, cols, what, false)
}

/// A float array whose NaN values stand for "unknown"; anything else must be finite.
pub(crate) fn floats_or_nan(
    obj: &Bound<'_, PyAny>,
    ndim: usize,
    cols: Option<usize>,
    what: &str,
) -> PyResult<(Vec<usize>, Vec<f32>)> {
    checked_floats(obj, ndim, cols, what, true)
}

fn checked_floats(
    obj: &Bound<'_, PyAny>,
    ndim: usize,
    cols: Option<usize>,
    what: &str,
    nan_allowed: bool,
) -> PyResult<(Vec<usize>, Vec<f32>)> {
    let (shape, data) = contiguous::<f64>(obj, "float64", ndim, cols, what)?;
    let fits = |v: f64| v.is_finite() && v.abs() <= f32::MAX as f64 || nan_allowed && v.is_nan();
    if let Some(i) = data.iter().position(|&v| !fits(v)) {
        return Err(bound(
            what,
            format!("value {} (flat index {i}) is not a finite number", data[i]),
        ));
    }
    Ok((shape, data.into_iter().map(|v| v as f32).collect()))
}

/// An integer array: its shape and values.
pub(crate) fn ints(
    obj: &Bound<'_, PyAny>,
    ndim: usize,
    cols: Option<usize>,
    what: &str,
) -> PyResult<(Vec<usize>, Vec<i64>)> {
    contiguous::<i64>(obj, "int64", ndim, cols, what)
}

/// A transform from one row; the rotation is normalised, and a zero rotation refused.
pub(crate) fn transform(row: &[f32], what: &str) -> PyResult<Transform> {
    let q = Quat::from_xyzw(row[3], row[4], row[5], row[6]);
    if q.length() < 1e-6 {
        return Err(bound(what, "a rotation quaternion is zero"));
    }
    Ok(Transform {
        translation: Vec3::new(row[0], row[1], row[2]),
        rotation: q.normalize(),
        scale: Vec3::new(row[7], row[8], row[9]),
    })
}

/// Writes a transform as one row.
pub(crate) fn push_row(out: &mut Vec<f64>, t: &Transform) {
    let (p, q, s) = (t.translation, t.rotation, t.scale);
    out.extend([p.x, p.y, p.z, q.x, q.y, q.z, q.w, s.x, s.y, s.z].map(f64::from));
}

/// A float64 numpy array of `shape` holding `data` (row-major).
pub(crate) fn array<'py>(
    py: Python<'py>,
    shape: &[usize],
    data: Vec<f64>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let a =
        Array::from_shape_vec(shape.to_vec(), data).map_err(|e| bound("array", e.to_string()))?;
    Ok(a.into_pyarray(py))
}

/// A point or vector given as three numbers.
pub(crate) fn vec3(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec3> {
    let (_, v) = floats(obj, 1, Some(3), what)?;
    Ok(Vec3::new(v[0], v[1], v[2]))
}
