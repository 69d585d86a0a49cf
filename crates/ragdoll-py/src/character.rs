//! `Character`: a skeleton with its skin and clips, read from a file or handed over as
//! arrays by a host application, and the roles recognised on it.

use std::path::PathBuf;

use glam::{Vec3, Vec4};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use ragdoll::import::{self, ClipChoice, ImportOptions, Units, UpAxis};
use ragdoll::math::Transform;
use ragdoll::skeleton::{self, Clip, Joint, Skeleton, SkinnedMesh, Source};
use ragdoll::spec::Role;

use crate::arrays::{self, ROW};
use crate::errors::{bound, guard, to_py};

/// Most vertices a mesh handed over as arrays may have: as many as the OBJ reader takes.
const MAX_VERTICES: usize = ragdoll::import::obj::MAX_VERTICES;

/// A character: a joint hierarchy in metres with Y up, its skinned meshes and animation
/// clips. Read one with `load()`, take the built-in humanoid with `humanoid()`, or hand a
/// rig over with `Character.from_arrays()`.
#[pyclass(module = "ragdoll_sim", frozen)]
pub struct Character {
    pub(crate) inner: skeleton::Character,
    /// What the report names it by: the file read, `built-in` or `arrays`.
    pub(crate) input: String,
}

/// Reads a character file (glTF, GLB, VRM, BVH or OBJ) as the command-line tool does.
///
/// `units` ("m", "cm", "mm", "in") overrides the file's length unit, `up` ("y" or "z") the
/// up axis of a BVH or OBJ, `height` scales it to that standing height in metres, and
/// `clip` keeps one animation (a name, or an index from 0).
#[pyfunction]
#[pyo3(signature = (path, *, units=None, height=None, clip=None, up=None))]
pub fn load(
    py: Python<'_>,
    path: PathBuf,
    units: Option<&str>,
    height: Option<f32>,
    clip: Option<&Bound<'_, PyAny>>,
    up: Option<&str>,
) -> PyResult<Character> {
    let units = match units {
        None => None,
        Some("m") => Some(Units::M),
        Some("cm") => Some(Units::Cm),
        Some("mm") => Some(Units::Mm),
        Some("in") => Some(Units::In),
        Some(other) => {
            return Err(bound(
                "units",
                format!("must be \"m\", \"cm\", \"mm\" or \"in\", not {other:?}"),
            ));
        }
    };
    let up = match up {
        None => None,
        Some("y" | "Y") => Some(UpAxis::Y),
        Some("z" | "Z") => Some(UpAxis::Z),
        Some(other) => {
            return Err(bound(
                "up",
                format!("must be \"y\" or \"z\", not {other:?}"),
            ));
        }
    };
    let clip = match clip {
        None => None,
        Some(c) => Some(match c.extract::<usize>() {
            Ok(i) => ClipChoice::Index(i),
            Err(_) => ClipChoice::Name(c.extract::<String>()?),
        }),
    };
    let opts = ImportOptions {
        units,
        up,
        height_m: height,
        clip,
    };
    let input = path.display().to_string();
    let inner = py.detach(|| guard(|| import::load(&path, &opts).map_err(to_py)))?;
    Ok(Character { inner, input })
}

/// The built-in humanoid: 1.75 m, 75 kg once built, no skin.
#[pyfunction]
pub fn humanoid() -> Character {
    Character {
        inner: skeleton::humanoid(),
        input: "built-in".into(),
    }
}

#[pymethods]
impl Character {
    /// A character from a host application's rig, without writing a file.
    ///
    /// `names`: one name per joint; `parents`: each joint's parent index, -1 for a root,
    /// always lower than the joint's own index (parents first); `rest_local`: (N, 10) rest
    /// transforms relative to the parent (translation in metres, rotation x y z w, scale).
    /// `mesh`: an optional dict with `positions` (V, 3) in world space in the rest pose,
    /// `triangles` (T, 3), `joints` (V, 4) joint indices and `weights` (V, 4); weights that
    /// do not sum to one are renormalised with a warning. `frames`: an optional animation,
    /// (F, N, 10) local transforms at `fps`. `tips`: an optional (N, 3) array of where each
    /// bone ends in its joint's frame (a bone's tail), NaN rows where unknown; leaf bones
    /// are sized from it.
    #[staticmethod]
    #[pyo3(signature = (names, parents, rest_local, *, mesh=None, frames=None, fps=30.0, name="character", tips=None))]
    #[allow(clippy::too_many_arguments)]
    fn from_arrays(
        names: Vec<String>,
        parents: &Bound<'_, PyAny>,
        rest_local: &Bound<'_, PyAny>,
        mesh: Option<&Bound<'_, PyDict>>,
        frames: Option<&Bound<'_, PyAny>>,
        fps: f32,
        name: &str,
        tips: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Character> {
        let n = names.len();
        let tips = match tips {
            Some(t) => tips_from_array(t, n)?,
            None => vec![None; n],
        };
        let (_, parents) = arrays::ints(parents, 1, None, "parents")?;
        if parents.len() != n {
            return Err(bound(
                "parents",
                format!("has {} entries for {n} joint names", parents.len()),
            ));
        }
        let (shape, rest) = arrays::floats(rest_local, 2, Some(ROW), "rest_local")?;
        if shape[0] != n {
            return Err(bound(
                "rest_local",
                format!("has {} rows for {n} joint names", shape[0]),
            ));
        }
        let mut joints = Vec::with_capacity(n);
        for (i, (name, &p)) in names.into_iter().zip(&parents).enumerate() {
            let parent = match p {
                -1 => None,
                p if p >= 0 && (p as usize) < i => Some(p as usize),
                p => {
                    return Err(crate::errors::to_py(ragdoll::Error::Skeleton {
                        joint: name,
                        message: format!(
                            "parent index {p} is not -1 or the index of an earlier joint (parents come before their children)"
                        ),
                    }));
                }
            };
            let rest = arrays::transform(&rest[i * ROW..(i + 1) * ROW], "rest_local")?;
            joints.push(Joint {
                name,
                parent,
                rest,
                tip: tips[i],
            });
        }
        let skeleton = Skeleton::new(joints).map_err(to_py)?;
        let mut warnings = Vec::new();
        let meshes = match mesh {
            Some(m) => vec![mesh_from_dict(m, n, &mut warnings)?],
            None => Vec::new(),
        };
        let clips = match frames {
            Some(f) => vec![clip_from_array(f, n, fps)?],
            None => Vec::new(),
        };
        let source = if meshes.is_empty() {
            Source::BuiltIn
        } else {
            Source::Mesh(PathBuf::from(format!("{name}.glb")))
        };
        let inner = skeleton::Character {
            name: name.to_string(),
            skeleton,
            meshes,
            clips,
            humanoid_bones: Vec::new(),
            warnings,
            source,
        };
        let mut inner = inner;
        let h = import::standing_height(&inner);
        if h.is_finite() && h > 0.0 && !import::PLAUSIBLE_HEIGHT_M.contains(&h) {
            let (lo, hi) = import::PLAUSIBLE_HEIGHT_M.into_inner();
            inner.warnings.push(format!(
                "{name}: the character stands {h:.2} m tall, outside the {lo}-{hi} m of anything \
                 that walks: are its units metres (a scene's unit scale, a file in centimetres)?"
            ));
        }
        if let Some((f, j, d)) = inner
            .clips
            .first()
            .and_then(|c| inner.skeleton.clip_out_of_reach(c))
        {
            return Err(bound(
                "frames",
                format!(
                    "frame {f} puts joint {} {d} m from the origin, past the {} m a skeleton may reach",
                    inner.skeleton.joint_label(j),
                    skeleton::MAX_REACH_M
                ),
            ));
        }
        Ok(Character {
            inner,
            input: "arrays".into(),
        })
    }

    /// The character's name (its file's stem, `humanoid`, or the name given).
    #[getter]
    fn name(&self) -> &str {
        &self.inner.name
    }

    /// Joint names, in the character's own order (what every per-joint array follows).
    #[getter]
    fn joint_names(&self) -> Vec<String> {
        let s = &self.inner.skeleton;
        (0..s.len()).map(|i| s.joint_label(i)).collect()
    }

    /// Each joint's parent index, -1 for a root.
    #[getter]
    fn parents(&self) -> Vec<i64> {
        self.inner
            .skeleton
            .joints()
            .iter()
            .map(|j| j.parent.map_or(-1, |p| p as i64))
            .collect()
    }

    /// Rest transforms relative to each joint's parent, (N, 10).
    #[getter]
    fn rest_local<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let joints = self.inner.skeleton.joints();
        let mut data = Vec::with_capacity(joints.len() * ROW);
        for j in joints {
            arrays::push_row(&mut data, &j.rest);
        }
        Ok(arrays::array(py, &[joints.len(), ROW], data)?.into_any())
    }

    /// Rest transforms in world space, (N, 10).
    #[getter]
    fn rest_world<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let world = self.inner.skeleton.rest_world();
        let mut data = Vec::with_capacity(world.len() * ROW);
        for t in &world {
            arrays::push_row(&mut data, t);
        }
        Ok(arrays::array(py, &[world.len(), ROW], data)?.into_any())
    }

    /// Where each bone ends in its joint's frame, (N, 3); NaN rows where the file does not
    /// say (the bone then ends at its children).
    #[getter]
    fn tips<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let joints = self.inner.skeleton.joints();
        let mut data = Vec::with_capacity(joints.len() * 3);
        for j in joints {
            let t = j.tip.unwrap_or(Vec3::NAN);
            data.extend([t.x, t.y, t.z].map(f64::from));
        }
        Ok(arrays::array(py, &[joints.len(), 3], data)?.into_any())
    }

    /// Standing height, metres.
    #[getter]
    fn height_m(&self) -> f32 {
        import::character_height(&self.inner)
    }

    /// Names of the animation clips, in file order (the first is the one that plays).
    #[getter]
    fn clips(&self) -> Vec<String> {
        self.inner.clips.iter().map(|c| c.name.clone()).collect()
    }

    /// How many skinned meshes it has.
    #[getter]
    fn mesh_count(&self) -> usize {
        self.inner.meshes.len()
    }

    /// Defects the importer repaired rather than refused, one sentence each.
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.inner.warnings.clone()
    }

    /// What each joint is (pelvis, thigh_l, …), recognised from the skeleton's shape and
    /// names: a `Roles`.
    #[getter]
    fn roles(&self, py: Python<'_>) -> PyResult<Roles> {
        let c = &self.inner;
        let r = py.detach(|| guard(|| Ok(ragdoll::spec::recognise_roles(c))))?;
        Ok(Roles::new(c, &r))
    }

    fn __len__(&self) -> usize {
        self.inner.skeleton.len()
    }

    fn __repr__(&self) -> String {
        format!(
            "<Character {:?}: {} joints, {} meshes, {} clips, {:.2} m>",
            self.inner.name,
            self.inner.skeleton.len(),
            self.inner.meshes.len(),
            self.inner.clips.len(),
            import::character_height(&self.inner)
        )
    }
}

/// A skinned mesh from a dict of arrays, its weights checked and repaired.
fn mesh_from_dict(
    m: &Bound<'_, PyDict>,
    joints: usize,
    warnings: &mut Vec<String>,
) -> PyResult<SkinnedMesh> {
    let get = |key: &str| -> PyResult<Bound<'_, PyAny>> {
        m.get_item(key)?
            .ok_or_else(|| bound(&format!("mesh[{key:?}]"), "is missing"))
    };
    let (shape, pos) = arrays::floats(&get("positions")?, 2, Some(3), "mesh[\"positions\"]")?;
    let v = shape[0];
    if v > MAX_VERTICES {
        return Err(bound(
            "mesh[\"positions\"]",
            format!("has {v} vertices; at most {MAX_VERTICES} are read"),
        ));
    }
    let (_, tris) = arrays::ints(&get("triangles")?, 2, Some(3), "mesh[\"triangles\"]")?;
    if let Some(i) = tris.iter().position(|&t| t < 0 || t as usize >= v) {
        return Err(bound(
            "mesh[\"triangles\"]",
            format!("triangle {} names vertex {}, of {v}", i / 3, tris[i]),
        ));
    }
    let (jshape, jidx) = arrays::ints(&get("joints")?, 2, Some(4), "mesh[\"joints\"]")?;
    let (wshape, w) = arrays::floats(&get("weights")?, 2, Some(4), "mesh[\"weights\"]")?;
    for (key, rows) in [("joints", jshape[0]), ("weights", wshape[0])] {
        if rows != v {
            return Err(bound(
                &format!("mesh[{key:?}]"),
                format!("has {rows} rows for {v} vertices"),
            ));
        }
    }
    if let Some(i) = jidx.iter().position(|&j| j < 0 || j as usize >= joints) {
        return Err(bound(
            "mesh[\"joints\"]",
            format!("vertex {} names joint {}, of {joints}", i / 4, jidx[i]),
        ));
    }
    let mut repaired = 0usize;
    let mut weights = Vec::with_capacity(v);
    for row in w.chunks_exact(4) {
        let row = Vec4::from_slice(row).max(Vec4::ZERO);
        let sum = row.element_sum();
        let fixed = if sum > 1e-6 {
            row / sum
        } else {
            // No weight at all: the vertex follows its first listed joint.
            Vec4::X
        };
        if (sum - 1.0).abs() > 1e-3 {
            repaired += 1;
        }
        weights.push(fixed);
    }
    if repaired > 0 {
        warnings.push(format!(
            "mesh: {repaired} of {v} vertices' weights did not sum to 1 (or were negative) and were renormalised"
        ));
    }
    Ok(SkinnedMesh {
        name: "mesh".into(),
        positions: pos
            .chunks_exact(3)
            .map(|p| Vec3::new(p[0], p[1], p[2]))
            .collect(),
        normals: Vec::new(),
        indices: tris.iter().map(|&t| t as u32).collect(),
        joints: jidx
            .chunks_exact(4)
            .map(|j| [j[0] as u16, j[1] as u16, j[2] as u16, j[3] as u16])
            .collect(),
        weights,
    })
}

/// Bone tips from an (N, 3) array whose NaN rows say "unknown".
fn tips_from_array(t: &Bound<'_, PyAny>, joints: usize) -> PyResult<Vec<Option<Vec3>>> {
    let (shape, data) = arrays::floats_or_nan(t, 2, Some(3), "tips")?;
    if shape[0] != joints {
        return Err(bound(
            "tips",
            format!("has {} rows for {joints} joint names", shape[0]),
        ));
    }
    Ok(data
        .chunks_exact(3)
        .map(|p| {
            let p = Vec3::new(p[0], p[1], p[2]);
            p.is_finite().then_some(p)
        })
        .collect())
}

/// An animation from (F, N, 10) local transforms.
fn clip_from_array(frames: &Bound<'_, PyAny>, joints: usize, fps: f32) -> PyResult<Clip> {
    if !(fps.is_finite() && fps > 0.0 && fps <= 1000.0) {
        return Err(bound(
            "fps",
            format!("must be within 0 and 1000, not {fps}"),
        ));
    }
    let (shape, data) = arrays::floats(frames, 3, Some(ROW), "frames")?;
    if shape[1] != joints {
        return Err(bound(
            "frames",
            format!("has {} joints a frame for {joints} joint names", shape[1]),
        ));
    }
    if shape[0] * shape[1] > skeleton::MAX_CLIP_POSES {
        return Err(bound(
            "frames",
            format!(
                "holds {} joint poses; at most {} are read",
                shape[0] * shape[1],
                skeleton::MAX_CLIP_POSES
            ),
        ));
    }
    let mut out = Vec::with_capacity(shape[0]);
    for frame in data.chunks_exact(joints * ROW) {
        let locals: PyResult<Vec<Transform>> = frame
            .chunks_exact(ROW)
            .map(|row| arrays::transform(row, "frames"))
            .collect();
        out.push(locals?);
    }
    Ok(Clip {
        name: "clip".into(),
        frame_time: 1.0 / fps,
        frames: out,
    })
}

/// The roles found on a character: which joint plays each part of a humanoid, and why a
/// role is missing. Reads like a dict from role name to joint name.
#[pyclass(module = "ragdoll_sim", frozen)]
pub struct Roles {
    /// Role name → joint name, for the roles found.
    #[pyo3(get)]
    found: Py<PyDict>,
    /// Role name → why it was not found: for a character not taken for a humanoid, every
    /// humanoid role, each with the reason it is not one.
    #[pyo3(get)]
    missing: Py<PyDict>,
    /// Whether the skeleton was taken for a standing humanoid.
    #[pyo3(get)]
    humanoid: bool,
    /// One sentence: how the roles were found, or why it is not taken for a humanoid.
    #[pyo3(get)]
    why: String,
    /// Set when the names promise a humanoid the skeleton's shape denies.
    #[pyo3(get)]
    warning: Option<String>,
}

impl Roles {
    fn new(c: &skeleton::Character, r: &ragdoll::spec::Roles) -> Roles {
        Python::attach(|py| {
            let found = PyDict::new(py);
            for (j, role) in r.per_joint.iter().enumerate() {
                if let Some(role) = role
                    && *role != Role::Chain
                {
                    // A role is held by one joint; set_item on a fresh dict cannot fail.
                    let _ = found.set_item(role.as_str(), c.skeleton.joint_label(j));
                }
            }
            let missing = PyDict::new(py);
            if r.humanoid {
                for (role, why) in r.missing() {
                    let _ = missing.set_item(role.as_str(), why);
                }
            } else {
                // Not a humanoid: every humanoid role is missing for the one reason.
                for role in ragdoll::spec::HUMANOID_ROLES {
                    let _ = missing.set_item(role.as_str(), &r.why);
                }
            }
            Roles {
                found: found.unbind(),
                missing: missing.unbind(),
                humanoid: r.humanoid,
                why: r.why.clone(),
                warning: r.warning.clone(),
            }
        })
    }
}

#[pymethods]
impl Roles {
    fn __getitem__<'py>(&self, py: Python<'py>, role: &str) -> PyResult<Bound<'py, PyAny>> {
        self.found.bind(py).as_any().get_item(role)
    }

    fn __contains__(&self, py: Python<'_>, role: &str) -> PyResult<bool> {
        self.found.bind(py).contains(role)
    }

    fn __len__(&self, py: Python<'_>) -> usize {
        self.found.bind(py).len()
    }

    fn __iter__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.found
            .bind(py)
            .as_any()
            .try_iter()
            .map(|i| i.into_any())
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        format!(
            "<Roles humanoid={} found={} missing={}>",
            self.humanoid,
            self.found.bind(py).len(),
            self.missing.bind(py).len()
        )
    }
}
