//! Skeleton + roles → RagdollSpec.
// HELPER-C: replace this stub.

use super::RagdollSpec;
use crate::error::Result;
use crate::skeleton::Character;

/// Options for [`build_spec`].
#[derive(Clone, Debug, PartialEq)]
pub struct BuildOptions {
    /// Total mass, kg (default 75).
    pub total_mass_kg: f32,
}

impl Default for BuildOptions {
    fn default() -> Self {
        BuildOptions { total_mass_kg: 75.0 }
    }
}

/// Builds a spec.
pub fn build_spec(character: &Character, opts: &BuildOptions) -> Result<RagdollSpec> {
    let _ = (character, opts);
    todo!()
}
