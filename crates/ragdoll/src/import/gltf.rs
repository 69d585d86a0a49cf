//! glTF 2.0 import (.glb, and .gltf with data: URIs or external buffers).
// HELPER-B: replace this stub.

use std::path::Path;

use crate::error::Result;
use crate::skeleton::Character;

/// What the glTF exporter needs to write the input back with a new animation.
#[derive(Clone, Debug)]
pub struct GltfSource {}

/// Loads a glTF 2.0 file.
pub fn load(path: &Path) -> Result<Character> {
    let _ = path;
    todo!()
}
