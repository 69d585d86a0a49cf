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
mod clip;
pub mod gltf;
pub mod obj;
mod size;

pub use clip::{ClipChoice, choose_clip};
pub use size::{
    MAX_HEIGHT_M, MIN_HEIGHT_M, PLAUSIBLE_HEIGHT_M, character_height, humanoid_of_height,
    standing_height,
};

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::rig::RigOptions;
use crate::skeleton::Character;

/// Length unit of a file whose format does not say (BVH, OBJ), or of a glTF or VRM file
/// whose exporter ignored that its format says metres (the Fox sample is centimetres).
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

pub use crate::skeleton::source::UpAxis;

/// Overrides for what importers otherwise detect.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ImportOptions {
    /// Length unit: BVH detects it from the skeleton's height when `None`, OBJ and glTF
    /// take metres. For glTF (and VRM) the file's numbers are read in this unit although
    /// the format says metres, for files exported without converting.
    pub units: Option<Units>,
    /// Up axis (BVH, OBJ); detected from the skeleton's extent when `None`. glTF is Y up.
    pub up: Option<UpAxis>,
    /// Scale the character uniformly to this height, metres ([`character_height`]), after
    /// `units` is applied; within [`MIN_HEIGHT_M`]..=[`MAX_HEIGHT_M`].
    pub height_m: Option<f32>,
    /// The animation to keep: the character's only clip is then this one. `None` keeps
    /// every clip, and whatever plays a clip plays the first.
    pub clip: Option<ClipChoice>,
}

/// Loads any supported character file, choosing the importer by extension. A mesh without
/// a skeleton (an OBJ, a glTF without a skin) is rigged with the default [`RigOptions`].
pub fn load(path: &Path, opts: &ImportOptions) -> Result<Character> {
    load_rigged(path, opts, &RigOptions::default())
}

/// The file extensions [`load`] reads, lower case, as they are named to users.
pub const EXTENSIONS: [&str; 5] = ["bvh", "glb", "gltf", "vrm", "obj"];

/// Whether `path` names a glTF container by its extension: `.glb`, `.gltf`, or `.vrm` (a
/// VRM avatar is a GLB with a humanoid bone table).
pub fn is_gltf(path: &Path) -> bool {
    path.extension().and_then(|e| e.to_str()).is_some_and(|e| {
        ["glb", "gltf", "vrm"]
            .iter()
            .any(|g| e.eq_ignore_ascii_case(g))
    })
}

/// [`load`], rigging a mesh without a skeleton with `rig` (ignored for files that have
/// one).
///
/// After the importer: `height_m` rescales the character (its standing height, when it
/// lies down in its file), `clip` keeps one clip, and a
/// character outside [`PLAUSIBLE_HEIGHT_M`] (its size not given) gets a warning that
/// states its height.
pub fn load_rigged(path: &Path, opts: &ImportOptions, rig: &RigOptions) -> Result<Character> {
    size::check_height(opts.height_m)?;
    let mut character = read(path, opts, rig)?;
    if let Some(choice) = &opts.clip {
        choose_clip(&mut character, choice, path)?;
    }
    if let Some(h) = opts.height_m {
        size::stand_to_height(&mut character, h, path)?;
    }
    if opts.height_m.is_none()
        && let Some(w) = size::implausible(&character, path)
    {
        character.warnings.push(w);
    }
    Ok(character)
}

/// The importer the extension names, with units and height applied.
fn read(path: &Path, opts: &ImportOptions, rig: &RigOptions) -> Result<Character> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .unwrap_or_default();
    match ext.as_str() {
        "bvh" => {
            let mut c = bvh::load(path, opts)?;
            if let Some(h) = opts.height_m {
                size::scale_to_height(&mut c, h, path)?;
            }
            Ok(c)
        }
        "glb" | "gltf" | "vrm" => gltf::load_with(path, opts, rig),
        "obj" => {
            let bytes = crate::files::read_capped(path, crate::files::MAX_INPUT_BYTES)?;
            let mut mesh = obj::parse(&String::from_utf8_lossy(&bytes), path, opts)?;
            size::scale_meshes_to_height(std::slice::from_mut(&mut mesh), opts.height_m, path)?;
            let name = path
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default();
            obj::rigged_character(name, vec![mesh], rig, path)
        }
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
