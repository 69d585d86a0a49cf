//! Recognising what each joint is (pelvis, thigh, …) from topology and geometry.
// HELPER-C: replace this stub.

use glam::Vec3;

use super::Role;
use crate::skeleton::Character;

/// The outcome of role recognition.
#[derive(Clone, Debug, PartialEq)]
pub struct Roles {
    /// For each skeleton joint, its role, or `None` when the joint gets no body of its own.
    pub per_joint: Vec<Option<Role>>,
    /// Whether the skeleton was recognised as a humanoid.
    pub humanoid: bool,
    /// The character's forward direction in the rest pose (unit, horizontal for humanoids).
    pub forward: Vec3,
}

/// Recognises roles.
pub fn recognise_roles(character: &Character) -> Roles {
    let _ = character;
    todo!()
}
