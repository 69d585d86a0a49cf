//! The one triangle list a fresh glTF carries: the character's own meshes (an OBJ rigged
//! by [`crate::rig`]), or the ragdoll's bodies drawn by [`crate::spec::bodies_mesh`].

use glam::{Vec3, Vec4};

use crate::error::Result;
use crate::rig::auto_weights;
use crate::skeleton::{Character, Skeleton, SkinnedMesh};
use crate::spec::RagdollSpec;

/// A skinned triangle list: up to four joints per vertex and their weights.
#[derive(Debug, Default)]
pub(crate) struct BodyMesh {
    pub positions: Vec<Vec3>,
    /// Empty when any source mesh had none.
    pub normals: Vec<Vec3>,
    pub joints: Vec<[u16; 4]>,
    pub weights: Vec<Vec4>,
    pub indices: Vec<u32>,
}

/// A character's own skinned meshes (an OBJ rigged by [`crate::rig`]) as one triangle list.
pub(super) fn character_mesh(character: &Character) -> BodyMesh {
    let mut out = BodyMesh::default();
    let with_normals = character
        .meshes
        .iter()
        .all(|m| m.normals.len() == m.positions.len());
    for m in &character.meshes {
        let n = m.positions.len();
        let base = out.positions.len() as u32;
        out.positions.extend_from_slice(&m.positions);
        if with_normals {
            out.normals.extend_from_slice(&m.normals);
        }
        if m.joints.len() == n && m.weights.len() == n {
            out.joints.extend_from_slice(&m.joints);
            out.weights.extend_from_slice(&m.weights);
        } else {
            let (j, w) = auto_weights(&character.skeleton, &m.positions);
            out.joints.extend(j);
            out.weights.extend(w);
        }
        out.indices.extend(
            m.indices
                .iter()
                .filter(|&&i| (i as usize) < n)
                .map(|i| i + base),
        );
    }
    out.indices.truncate(out.indices.len() / 3 * 3);
    out
}
/// Every body of `spec` as a mesh in the world rest pose, each vertex weighted 1 on its
/// body's bone.
pub(super) fn bodies_mesh(skeleton: &Skeleton, spec: &RagdollSpec) -> Result<BodyMesh> {
    let SkinnedMesh {
        positions,
        normals,
        indices,
        joints,
        weights,
        ..
    } = crate::spec::bodies_mesh(skeleton, spec)?;
    Ok(BodyMesh {
        positions,
        normals,
        joints,
        weights,
        indices,
    })
}
