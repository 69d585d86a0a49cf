//! `Result`: what a world's run gives: joint transforms as numpy arrays, the report, and
//! the files it saves.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use pyo3::prelude::*;
use ragdoll::math::Transform;
use ragdoll::scene::{Scene, SceneCharacter, SceneResult};

use crate::arrays::{self, ROW};
use crate::errors::{bound, guard, to_py};
use crate::spec::Spec;

/// What a run gives: every character's joint transforms per frame, the report, and the
/// files it saves.
#[pyclass(module = "ragdoll_sim", frozen, name = "Result")]
pub struct RunResult {
    pub(crate) scene: Arc<Scene>,
    pub(crate) result: SceneResult,
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
