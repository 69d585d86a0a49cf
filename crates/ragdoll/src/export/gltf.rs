//! glTF (.glb) export.
// HELPER-B: replace this stub.

use crate::error::Result;
use crate::skeleton::Character;
use crate::spec::RagdollSpec;
use crate::track::Track;

/// Writes `track` as a binary glTF.
pub fn to_glb(character: &Character, spec: &RagdollSpec, track: &Track) -> Result<Vec<u8>> {
    let _ = (character, spec, track);
    todo!()
}
