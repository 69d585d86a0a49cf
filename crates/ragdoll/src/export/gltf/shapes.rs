//! The one triangle list a fresh glTF carries: the character's own meshes (an OBJ rigged
//! by [`crate::rig`]), or the ragdoll's bodies drawn by [`crate::spec::bodies_mesh`]; and
//! how it is written, shared with a glTF input that has no mesh to draw.

use glam::{Vec3, Vec4};
use serde_json::{Value, json};

use super::{ARRAY_BUFFER, Bin, ELEMENT_ARRAY_BUFFER, UNSIGNED_BYTE, UNSIGNED_INT, UNSIGNED_SHORT};

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

/// The material every drawn mesh gets: a plain skin tone, so the motion reads in any viewer.
pub(super) fn material() -> Value {
    json!({
        "name": "ragdoll body",
        "pbrMetallicRoughness": {
            "baseColorFactor": [0.8, 0.62, 0.48, 1.0],
            "metallicFactor": 0.0,
            "roughnessFactor": 0.7,
        },
    })
}

/// Writes `mesh`'s vertices, influences and triangles into `bin` and returns the triangle
/// primitive drawing them with `material`; `joint_count` (the skin's joints) picks the
/// smallest joint index type that holds every index.
pub(super) fn primitive(
    bin: &mut Bin,
    mesh: &BodyMesh,
    joint_count: usize,
    material: usize,
) -> Value {
    let positions: Vec<f32> = mesh.positions.iter().flat_map(|p| p.to_array()).collect();
    let normals: Vec<f32> = mesh.normals.iter().flat_map(|p| p.to_array()).collect();
    let weights: Vec<f32> = mesh.weights.iter().flat_map(|w| w.to_array()).collect();
    let vertex_count = mesh.positions.len();
    let pos_acc = bin.floats(&positions, "VEC3", Some(ARRAY_BUFFER), true);
    let nrm_acc =
        (!normals.is_empty()).then(|| bin.floats(&normals, "VEC3", Some(ARRAY_BUFFER), false));
    let wgt_acc = bin.floats(&weights, "VEC4", Some(ARRAY_BUFFER), false);
    let (jtype, jbytes): (u32, Vec<u8>) = if joint_count <= 256 {
        (
            UNSIGNED_BYTE,
            mesh.joints.iter().flatten().map(|&j| j as u8).collect(),
        )
    } else {
        (
            UNSIGNED_SHORT,
            mesh.joints
                .iter()
                .flatten()
                .flat_map(|j| j.to_le_bytes())
                .collect(),
        )
    };
    let jview = bin.push_view(&jbytes, Some(ARRAY_BUFFER));
    let jnt_acc = bin.push_accessor(json!({
        "bufferView": jview, "componentType": jtype, "count": vertex_count, "type": "VEC4",
    }));
    let (itype, ibytes): (u32, Vec<u8>) = if vertex_count <= u16::MAX as usize {
        (
            UNSIGNED_SHORT,
            mesh.indices
                .iter()
                .flat_map(|&i| (i as u16).to_le_bytes())
                .collect(),
        )
    } else {
        (
            UNSIGNED_INT,
            mesh.indices.iter().flat_map(|&i| i.to_le_bytes()).collect(),
        )
    };
    let iview = bin.push_view(&ibytes, Some(ELEMENT_ARRAY_BUFFER));
    let idx_acc = bin.push_accessor(json!({
        "bufferView": iview, "componentType": itype, "count": mesh.indices.len(), "type": "SCALAR",
    }));
    let mut attributes = json!({
        "POSITION": pos_acc,
        "JOINTS_0": jnt_acc,
        "WEIGHTS_0": wgt_acc,
    });
    if let Some(nrm) = nrm_acc {
        attributes["NORMAL"] = json!(nrm);
    }
    json!({
        "attributes": attributes,
        "indices": idx_acc,
        "material": material,
        "mode": 4,
    })
}

/// The skin's inverse bind matrices, one per skeleton joint: its rest pose in the world,
/// where the drawn mesh's vertices are.
pub(super) fn inverse_bind_matrices(bin: &mut Bin, skeleton: &Skeleton) -> usize {
    let ibms: Vec<f32> = skeleton
        .rest_world()
        .iter()
        .flat_map(|w| w.to_mat4().inverse().to_cols_array())
        .collect();
    bin.floats(&ibms, "MAT4", None, false)
}
