//! BVH (Biovision hierarchy) import. Hand-written: the one crate panics on real files.
// HELPER-A: replace this stub.

use std::path::Path;

use super::ImportOptions;
use crate::error::Result;
use crate::skeleton::Character;

/// What the BVH exporter needs to write a file back in the source's own layout.
#[derive(Clone, Debug, PartialEq)]
pub struct BvhLayout {}

/// Loads a BVH file.
pub fn load(path: &Path, opts: &ImportOptions) -> Result<Character> {
    let _ = (path, opts);
    todo!()
}
