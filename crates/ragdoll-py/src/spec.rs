//! `Spec`: a ragdoll's bodies and joints as editable Python objects that round-trip to the
//! spec TOML the command-line tool reads and writes.

use std::path::PathBuf;

use pyo3::prelude::*;
use pyo3::types::PyDict;
use ragdoll::spec::{self, BuildOptions, JointKind, RagdollSpec, RoleFile, Shape};

use crate::character::Character;
use crate::errors::{Fields, RoleError, bound, guard, raise, to_py};

/// A ragdoll: rigid bodies on the character's bones and the joints between them. Edit
/// bodies and joints in place (`spec.body("thigh_l").mass_kg = 9.0`); `validate()` checks
/// every value, as adding it to a world does.
#[pyclass(module = "ragdoll_sim")]
#[derive(Clone)]
pub struct Spec {
    pub(crate) inner: RagdollSpec,
}

/// Builds the ragdoll of a character, as `ragdoll build` does: one body per joint with a
/// role, shaped from the skin, weighed from human body-segment data (a humanoid, `mass_kg`
/// in all, 75 by default) or by volume (anything else); joints with anatomical limits.
///
/// `roles` gives roles by hand where recognition gets a rig wrong: a dict from role name
/// (`thigh_l`, `forearm_r`, …) to joint name; `ignore` lists helper joints that get no body.
#[pyfunction]
#[pyo3(signature = (character, *, mass_kg=None, female=false, roles=None, ignore=None))]
pub fn build_ragdoll(
    py: Python<'_>,
    character: &Character,
    mass_kg: Option<f32>,
    female: bool,
    roles: Option<&Bound<'_, PyDict>>,
    ignore: Option<Vec<String>>,
) -> PyResult<Spec> {
    let roles = match roles {
        Some(d) => Some(
            d.extract::<Vec<(String, String)>>()
                .or_else(|_| d.items().extract::<Vec<(String, String)>>())?,
        ),
        None => None,
    };
    let file = role_file(roles, ignore)?;
    let opts = BuildOptions {
        total_mass_kg: mass_kg,
        female,
    };
    let c = &character.inner;
    let inner = py.detach(|| {
        guard(|| {
            if let Some(f) = &file {
                // What the hand-given roles cannot do to this skeleton is a role error.
                spec::roles_with_file(c, f).map_err(role_error)?;
            }
            spec::build_spec_with_roles(c, &opts, file.as_ref()).map_err(to_py)
        })
    })?;
    Ok(Spec { inner })
}

/// Roles given as pairs (a dict's items) and ignored joints, as a roles file.
fn role_file(
    roles: Option<Vec<(String, String)>>,
    ignore: Option<Vec<String>>,
) -> PyResult<Option<RoleFile>> {
    if roles.is_none() && ignore.is_none() {
        return Ok(None);
    }
    let quote = |s: &str| serde_json::to_string(s).unwrap_or_default();
    let mut text = String::new();
    if let Some(ignore) = ignore {
        let names: Vec<String> = ignore.iter().map(|n| quote(n)).collect();
        text += &format!("ignore = [{}]\n", names.join(", "));
    }
    if let Some(roles) = roles {
        text += "[roles]\n";
        for (role, joint) in roles {
            text += &format!("{} = {}\n", quote(&role), quote(&joint));
        }
    }
    RoleFile::from_toml(&text, std::path::Path::new("roles"))
        .map(Some)
        .map_err(role_error)
}

/// A roles error, with the role (the key of the line it is about) where one is named.
fn role_error(e: ragdoll::Error) -> PyErr {
    let text = e.to_string();
    let message = match e {
        ragdoll::Error::Parse { message, .. } => message,
        other => other.to_string(),
    };
    let key = message
        .split_once(':')
        .map(|(k, _)| k.trim().trim_matches('"').to_string());
    raise::<RoleError>(
        text,
        Fields {
            message,
            key,
            ..Fields::default()
        },
    )
}

#[pymethods]
impl Spec {
    /// Reads a spec from TOML text; `path` names it in errors.
    #[staticmethod]
    #[pyo3(signature = (text, path="spec.toml"))]
    fn from_toml(text: &str, path: &str) -> PyResult<Spec> {
        guard(|| {
            RagdollSpec::from_toml(text, std::path::Path::new(path))
                .map(|inner| Spec { inner })
                .map_err(to_py)
        })
    }

    /// Reads a spec file (`ragdoll build`'s output).
    #[staticmethod]
    fn load(path: PathBuf) -> PyResult<Spec> {
        guard(|| {
            RagdollSpec::load(&path)
                .map(|inner| Spec { inner })
                .map_err(to_py)
        })
    }

    /// The spec as TOML text, as `ragdoll build` writes it.
    fn to_toml(&self) -> String {
        self.inner.to_toml()
    }

    /// Writes the spec as TOML (atomically: a failed write leaves no partial file).
    fn save(&self, path: PathBuf) -> PyResult<()> {
        self.validate()?;
        ragdoll::export::write_atomic(&path, self.inner.to_toml().as_bytes()).map_err(to_py)
    }

    /// Checks every value against the bounds a world holds it to; raises `SpecError`
    /// naming the first body, joint or key out of bounds.
    fn validate(&self) -> PyResult<()> {
        self.inner.validate().map_err(to_py)
    }

    /// The character's name.
    #[getter]
    fn name(&self) -> &str {
        &self.inner.name
    }

    /// Sum of the bodies' masses, kg.
    #[getter]
    fn total_mass_kg(&self) -> f32 {
        self.inner.total_mass_kg()
    }

    /// The bodies, root first; each edits this spec.
    #[getter]
    fn bodies(slf: &Bound<'_, Self>) -> Vec<Body> {
        let n = slf.borrow().inner.bodies.len();
        (0..n)
            .map(|index| Body {
                spec: slf.clone().unbind(),
                index,
            })
            .collect()
    }

    /// The joints; each edits this spec.
    #[getter]
    fn joints(slf: &Bound<'_, Self>) -> Vec<JointView> {
        let n = slf.borrow().inner.joints.len();
        (0..n)
            .map(|index| JointView {
                spec: slf.clone().unbind(),
                index,
            })
            .collect()
    }

    /// The body called `name`.
    fn body(slf: &Bound<'_, Self>, name: &str) -> PyResult<Body> {
        let index = slf
            .borrow()
            .inner
            .body_index(name)
            .ok_or_else(|| bound("name", format!("no body is called {name:?}")))?;
        Ok(Body {
            spec: slf.clone().unbind(),
            index,
        })
    }

    /// The joint called `name` (a joint is named after its child body).
    fn joint(slf: &Bound<'_, Self>, name: &str) -> PyResult<JointView> {
        let index = slf
            .borrow()
            .inner
            .joints
            .iter()
            .position(|j| j.name == name)
            .ok_or_else(|| bound("name", format!("no joint is called {name:?}")))?;
        Ok(JointView {
            spec: slf.clone().unbind(),
            index,
        })
    }

    fn __copy__(&self) -> Spec {
        self.clone()
    }

    fn __deepcopy__(&self, _memo: &Bound<'_, PyAny>) -> Spec {
        self.clone()
    }

    fn __eq__(&self, other: &Spec) -> bool {
        self.inner == other.inner
    }

    fn __repr__(&self) -> String {
        format!(
            "<Spec {:?}: {} bodies, {} joints, {:.1} kg>",
            self.inner.name,
            self.inner.bodies.len(),
            self.inner.joints.len(),
            self.inner.total_mass_kg()
        )
    }
}

/// One body of a spec: its shape, size, place on its bone and mass. Setting an attribute
/// edits the spec it came from.
#[pyclass(module = "ragdoll_sim", frozen)]
pub struct Body {
    spec: Py<Spec>,
    index: usize,
}

impl Body {
    fn read<T>(&self, py: Python<'_>, f: impl FnOnce(&spec::BodySpec) -> T) -> T {
        f(&self.spec.borrow(py).inner.bodies[self.index])
    }

    fn write<T>(&self, py: Python<'_>, f: impl FnOnce(&mut spec::BodySpec) -> T) -> T {
        f(&mut self.spec.borrow_mut(py).inner.bodies[self.index])
    }
}

#[pymethods]
impl Body {
    /// The body's name (the role name for a humanoid's parts, else the bone's).
    #[getter]
    fn name(&self, py: Python<'_>) -> String {
        self.read(py, |b| b.name.clone())
    }

    /// The skeleton joint whose bone it is.
    #[getter]
    fn bone(&self, py: Python<'_>) -> String {
        self.read(py, |b| b.bone.clone())
    }

    /// Its role (`thigh_l`, `chain`, …), or None.
    #[getter]
    fn role(&self, py: Python<'_>) -> Option<&'static str> {
        self.read(py, |b| b.role.map(|r| r.as_str()))
    }

    /// Mass, kg.
    #[getter]
    fn get_mass_kg(&self, py: Python<'_>) -> f32 {
        self.read(py, |b| b.mass_kg)
    }

    #[setter]
    fn set_mass_kg(&self, py: Python<'_>, kg: f32) {
        self.write(py, |b| b.mass_kg = kg)
    }

    /// `"capsule"` or `"box"`.
    #[getter]
    fn shape(&self, py: Python<'_>) -> &'static str {
        self.read(py, |b| match b.shape {
            Shape::Capsule { .. } => "capsule",
            Shape::Box { .. } => "box",
        })
    }

    /// A capsule's radius, metres (None for a box).
    #[getter]
    fn get_radius_m(&self, py: Python<'_>) -> Option<f32> {
        self.read(py, |b| match b.shape {
            Shape::Capsule { radius_m, .. } => Some(radius_m),
            Shape::Box { .. } => None,
        })
    }

    #[setter]
    fn set_radius_m(&self, py: Python<'_>, r: f32) -> PyResult<()> {
        self.write(py, |b| match &mut b.shape {
            Shape::Capsule { radius_m, .. } => {
                *radius_m = r;
                Ok(())
            }
            Shape::Box { .. } => Err(bound("radius_m", "the body is a box; set size_m")),
        })
    }

    /// A capsule's length between its two sphere centres, metres (None for a box).
    #[getter]
    fn get_length_m(&self, py: Python<'_>) -> Option<f32> {
        self.read(py, |b| match b.shape {
            Shape::Capsule { length_m, .. } => Some(length_m),
            Shape::Box { .. } => None,
        })
    }

    #[setter]
    fn set_length_m(&self, py: Python<'_>, l: f32) -> PyResult<()> {
        self.write(py, |b| match &mut b.shape {
            Shape::Capsule { length_m, .. } => {
                *length_m = l;
                Ok(())
            }
            Shape::Box { .. } => Err(bound("length_m", "the body is a box; set size_m")),
        })
    }

    /// A box's edge lengths, metres (None for a capsule).
    #[getter]
    fn get_size_m(&self, py: Python<'_>) -> Option<[f32; 3]> {
        self.read(py, |b| match b.shape {
            Shape::Box { size_m } => Some(size_m),
            Shape::Capsule { .. } => None,
        })
    }

    #[setter]
    fn set_size_m(&self, py: Python<'_>, s: [f32; 3]) -> PyResult<()> {
        self.write(py, |b| match &mut b.shape {
            Shape::Box { size_m } => {
                *size_m = s;
                Ok(())
            }
            Shape::Capsule { .. } => Err(bound(
                "size_m",
                "the body is a capsule; set radius_m and length_m",
            )),
        })
    }

    /// Centre of the shape in the bone's rest frame, metres.
    #[getter]
    fn get_center_m(&self, py: Python<'_>) -> [f32; 3] {
        self.read(py, |b| b.center_m)
    }

    #[setter]
    fn set_center_m(&self, py: Python<'_>, c: [f32; 3]) {
        self.write(py, |b| b.center_m = c)
    }

    /// Orientation of the shape in the bone's rest frame, quaternion x y z w (the shape's
    /// long axis is its Y).
    #[getter]
    fn get_rotation(&self, py: Python<'_>) -> [f32; 4] {
        self.read(py, |b| b.rotation)
    }

    #[setter]
    fn set_rotation(&self, py: Python<'_>, q: [f32; 4]) {
        self.write(py, |b| b.rotation = q)
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        self.read(py, |b| {
            format!(
                "<Body {:?} on {:?}: {} {:.2} kg>",
                b.name,
                b.bone,
                match b.shape {
                    Shape::Capsule { .. } => "capsule",
                    Shape::Box { .. } => "box",
                },
                b.mass_kg
            )
        })
    }
}

/// One joint of a spec: its kind and limits, in degrees. A hinge (knees, elbows) has
/// `min_deg` and `max_deg`; a swing-twist joint `swing_deg`, `twist_deg` and
/// `cone_tilt_deg`. Setting an attribute edits the spec it came from.
#[pyclass(module = "ragdoll_sim", frozen, name = "Joint")]
pub struct JointView {
    spec: Py<Spec>,
    index: usize,
}

impl JointView {
    fn read<T>(&self, py: Python<'_>, f: impl FnOnce(&spec::JointSpec) -> T) -> T {
        f(&self.spec.borrow(py).inner.joints[self.index])
    }

    fn write<T>(&self, py: Python<'_>, f: impl FnOnce(&mut spec::JointSpec) -> T) -> T {
        f(&mut self.spec.borrow_mut(py).inner.joints[self.index])
    }

    /// Edits a limit of the kind that has it; names the kind it is otherwise.
    fn limit(
        &self,
        py: Python<'_>,
        key: &str,
        edit: impl FnOnce(&mut JointKind) -> bool,
    ) -> PyResult<()> {
        self.write(py, |j| {
            let kind = kind_name(&j.kind);
            if edit(&mut j.kind) {
                Ok(())
            } else {
                Err(bound(
                    key,
                    format!("joint {:?} is a {kind} joint, which has no {key}", j.name),
                ))
            }
        })
    }
}

fn kind_name(k: &JointKind) -> &'static str {
    match k {
        JointKind::Hinge { .. } => "hinge",
        JointKind::SwingTwist { .. } => "swing_twist",
        JointKind::Ball => "ball",
        JointKind::Fixed => "fixed",
    }
}

#[pymethods]
impl JointView {
    /// The joint's name (its child body's).
    #[getter]
    fn name(&self, py: Python<'_>) -> String {
        self.read(py, |j| j.name.clone())
    }

    /// The parent body's name.
    #[getter]
    fn parent(&self, py: Python<'_>) -> String {
        self.read(py, |j| j.parent.clone())
    }

    /// The child body's name.
    #[getter]
    fn child(&self, py: Python<'_>) -> String {
        self.read(py, |j| j.child.clone())
    }

    /// `"hinge"`, `"swing_twist"`, `"ball"` or `"fixed"`.
    #[getter]
    fn kind(&self, py: Python<'_>) -> &'static str {
        self.read(py, |j| kind_name(&j.kind))
    }

    /// A hinge's lowest angle, degrees (None for other kinds).
    #[getter]
    fn get_min_deg(&self, py: Python<'_>) -> Option<f32> {
        self.read(py, |j| match j.kind {
            JointKind::Hinge { min_deg, .. } => Some(min_deg),
            _ => None,
        })
    }

    #[setter]
    fn set_min_deg(&self, py: Python<'_>, v: f32) -> PyResult<()> {
        self.limit(py, "min_deg", |k| match k {
            JointKind::Hinge { min_deg, .. } => {
                *min_deg = v;
                true
            }
            _ => false,
        })
    }

    /// A hinge's highest angle, degrees (None for other kinds).
    #[getter]
    fn get_max_deg(&self, py: Python<'_>) -> Option<f32> {
        self.read(py, |j| match j.kind {
            JointKind::Hinge { max_deg, .. } => Some(max_deg),
            _ => None,
        })
    }

    #[setter]
    fn set_max_deg(&self, py: Python<'_>, v: f32) -> PyResult<()> {
        self.limit(py, "max_deg", |k| match k {
            JointKind::Hinge { max_deg, .. } => {
                *max_deg = v;
                true
            }
            _ => false,
        })
    }

    /// A swing-twist joint's cone half-angle, degrees (None for other kinds).
    #[getter]
    fn get_swing_deg(&self, py: Python<'_>) -> Option<f32> {
        self.read(py, |j| match j.kind {
            JointKind::SwingTwist { swing_deg, .. } => Some(swing_deg),
            _ => None,
        })
    }

    #[setter]
    fn set_swing_deg(&self, py: Python<'_>, v: f32) -> PyResult<()> {
        self.limit(py, "swing_deg", |k| match k {
            JointKind::SwingTwist { swing_deg, .. } => {
                *swing_deg = v;
                true
            }
            _ => false,
        })
    }

    /// A swing-twist joint's twist range about the bone, degrees `[min, max]`.
    #[getter]
    fn get_twist_deg(&self, py: Python<'_>) -> Option<[f32; 2]> {
        self.read(py, |j| match j.kind {
            JointKind::SwingTwist { twist_deg, .. } => Some(twist_deg),
            _ => None,
        })
    }

    #[setter]
    fn set_twist_deg(&self, py: Python<'_>, v: [f32; 2]) -> PyResult<()> {
        self.limit(py, "twist_deg", |k| match k {
            JointKind::SwingTwist { twist_deg, .. } => {
                *twist_deg = v;
                true
            }
            _ => false,
        })
    }

    /// Where a swing-twist joint's cone points, degrees about the joint frame's Y then Z.
    #[getter]
    fn get_cone_tilt_deg(&self, py: Python<'_>) -> Option<[f32; 2]> {
        self.read(py, |j| match j.kind {
            JointKind::SwingTwist { cone_tilt_deg, .. } => Some(cone_tilt_deg),
            _ => None,
        })
    }

    #[setter]
    fn set_cone_tilt_deg(&self, py: Python<'_>, v: [f32; 2]) -> PyResult<()> {
        self.limit(py, "cone_tilt_deg", |k| match k {
            JointKind::SwingTwist { cone_tilt_deg, .. } => {
                *cone_tilt_deg = v;
                true
            }
            _ => false,
        })
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        self.read(py, |j| {
            format!(
                "<Joint {:?}: {} {:?} -> {:?}>",
                j.name,
                kind_name(&j.kind),
                j.parent,
                j.child
            )
        })
    }
}
