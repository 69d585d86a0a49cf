//! Importers: files in, [`Character`]s out, in metres with Y up. Each importer knows
//! nothing of physics; unit and up-axis conversion happens here, at the edge.
//!
//! # Hostile files
//!
//! Any bytes give a character or an error sentence naming the file and the place (line,
//! byte, accessor, node), never a panic, a hang or unbounded memory: files are read with
//! [`crate::files::read_capped`] (regular files of at most 1 GiB), nothing recurses on a
//! file's nesting, no count in a file reserves memory before the data behind it has been
//! read, and each importer documents its limits (`bvh::MAX_VALUE`,
//! `gltf::MAX_ACCESSOR_COMPONENTS`, `obj::MAX_VERTICES`…; and for all of them
//! [`crate::skeleton::MAX_JOINTS`], [`crate::skeleton::MAX_REACH_M`],
//! [`crate::skeleton::MAX_CLIP_POSES`]).
//!
//! The entry points that take bytes, for tests and fuzzing: [`bvh::parse`] and
//! [`obj::parse`] (text: `String::from_utf8_lossy` of the bytes, as their `load` does) and
//! [`gltf::from_bytes`] (a path in an empty folder keeps external URIs from finding files).

pub mod bvh;
pub mod gltf;
pub mod obj;

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::rig::RigOptions;
use crate::skeleton::Character;

/// Length unit of a file whose format does not say (BVH).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Units {
    /// Metres.
    M,
    /// Centimetres.
    Cm,
    /// Millimetres.
    Mm,
    /// Inches.
    In,
}

impl Units {
    /// Metres per file unit.
    pub fn to_metres(self) -> f32 {
        match self {
            Units::M => 1.0,
            Units::Cm => 0.01,
            Units::Mm => 0.001,
            Units::In => 0.0254,
        }
    }
}

/// Up axis of a file whose format does not say (BVH).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum UpAxis {
    /// +Y is up (glTF, most BVH).
    Y,
    /// +Z is up (some mocap exports).
    Z,
}

/// Overrides for what importers otherwise detect.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ImportOptions {
    /// Length unit; detected from the skeleton's height when `None`.
    pub units: Option<Units>,
    /// Up axis; detected from the skeleton's extent when `None`.
    pub up: Option<UpAxis>,
}

/// Loads any supported character file, choosing the importer by extension. A mesh without
/// a skeleton (an OBJ, a glTF without a skin) is rigged with the default [`RigOptions`].
pub fn load(path: &Path, opts: &ImportOptions) -> Result<Character> {
    load_rigged(path, opts, &RigOptions::default())
}

/// [`load`], rigging a mesh without a skeleton with `rig` (ignored for files that have
/// one).
pub fn load_rigged(path: &Path, opts: &ImportOptions, rig: &RigOptions) -> Result<Character> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .unwrap_or_default();
    match ext.as_str() {
        "bvh" => bvh::load(path, opts),
        "glb" | "gltf" => gltf::load_rigged(path, rig),
        "obj" => obj::load(path, opts, rig),
        _ => {
            if !path.exists() {
                return Err(Error::io(
                    path,
                    std::io::Error::new(std::io::ErrorKind::NotFound, "no such file"),
                ));
            }
            Err(Error::UnsupportedFile {
                path: path.to_path_buf(),
            })
        }
    }
}
