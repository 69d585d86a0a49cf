//! BVH export in the source's hierarchy and channel order.
// HELPER-A: replace this stub.

use crate::error::Result;
use crate::skeleton::Character;
use crate::track::Track;

/// Writes `track` as BVH text.
pub fn to_bvh(character: &Character, track: &Track) -> Result<String> {
    let _ = (character, track);
    todo!()
}
