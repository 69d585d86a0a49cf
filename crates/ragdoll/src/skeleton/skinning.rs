//! Linear blend skinning on the CPU: the deformed mesh of a posed character, for previews
//! and the OBJ-sequence export (glTF output carries the skin itself and lets the viewer
//! deform the mesh).
//!
//! A [`SkinnedMesh`] is stored in world space in the skeleton's rest pose (the importer has
//! already applied the file's inverse bind matrices), so joint `j`'s skinning matrix is
//! `pose_world[j] · rest_world[j]⁻¹`: it carries a rest-pose point to where joint `j` takes
//! it. When the file's bind pose is its rest pose (the common case, and always true of
//! what our glTF exporter writes) this is exactly the matrix a glTF viewer uses,
//! `joint world · inverse bind matrix`, applied to the file's own vertices.
//!
//! The functions write into caller buffers, so a preview that skins every frame allocates
//! nothing after the first.

use glam::{Mat3, Mat4, Vec3, Vec4};

use super::SkinnedMesh;
use crate::error::{Error, Result};
use crate::math::Transform;

/// Fills `out` with one skinning matrix per joint: `pose_world[j] · rest_world[j]⁻¹`.
///
/// `rest_world` is [`Skeleton::rest_world`](super::Skeleton::rest_world) (computed once per character); `pose_world` is
/// a frame of a [`Track`](crate::track::Track). Fails when the two differ in length or a
/// rest transform cannot be inverted (a zero scale).
///
/// ```
/// use ragdoll::skeleton::{humanoid, skinning};
///
/// let character = humanoid();
/// let rest = character.skeleton.rest_world();
/// let mut matrices = Vec::new();
/// skinning::skin_matrices(&rest, &rest, &mut matrices).unwrap();
/// assert!(matrices.iter().all(|m| m.abs_diff_eq(glam::Mat4::IDENTITY, 1e-5)));
/// ```
pub fn skin_matrices(
    rest_world: &[Transform],
    pose_world: &[Transform],
    out: &mut Vec<Mat4>,
) -> Result<()> {
    if rest_world.len() != pose_world.len() {
        return Err(Error::Skeleton {
            joint: String::new(),
            message: format!(
                "a pose of {} joints cannot skin a skeleton of {} joints",
                pose_world.len(),
                rest_world.len()
            ),
        });
    }
    out.clear();
    for (j, (rest, pose)) in rest_world.iter().zip(pose_world).enumerate() {
        let rest = rest.to_mat4();
        if rest.determinant().abs() < 1e-12 {
            return Err(Error::Skeleton {
                joint: format!("joint{j}"),
                message: "the rest transform has a zero scale and cannot skin a mesh".into(),
            });
        }
        out.push(pose.to_mat4() * rest.inverse());
    }
    Ok(())
}

/// Deforms `mesh` by `matrices` (from [`skin_matrices`]): each vertex goes to
/// `Σ weight_k · matrices[joint_k] · position`.
///
/// `positions` and `normals` are cleared and refilled (their capacity is kept, so calling
/// this every frame allocates nothing after the first). Normals are carried by the blended
/// matrix's 3×3 part and renormalised: exact for rigid joints and uniform scale, the usual
/// approximation otherwise. A mesh without normals leaves `normals` empty.
///
/// Fails when the mesh's per-vertex arrays disagree in length or a vertex names a joint
/// beyond `matrices`.
pub fn skin(
    mesh: &SkinnedMesh,
    matrices: &[Mat4],
    positions: &mut Vec<Vec3>,
    normals: &mut Vec<Vec3>,
) -> Result<()> {
    let n = mesh.positions.len();
    let mesh_err = |message: String| Error::Skeleton {
        joint: String::new(),
        message: format!("mesh \"{}\": {message}", mesh.name),
    };
    if mesh.joints.len() != n || mesh.weights.len() != n {
        return Err(mesh_err(format!(
            "{n} vertices but {} joint rows and {} weight rows",
            mesh.joints.len(),
            mesh.weights.len()
        )));
    }
    let has_normals = !mesh.normals.is_empty();
    if has_normals && mesh.normals.len() != n {
        return Err(mesh_err(format!(
            "{n} vertices but {} normals",
            mesh.normals.len()
        )));
    }
    positions.clear();
    normals.clear();
    for v in 0..n {
        let m = blend(&mesh.joints[v], mesh.weights[v], matrices)
            .ok_or_else(|| mesh_err(format!("vertex {v} names a joint beyond the skeleton")))?;
        positions.push(m.transform_point3(mesh.positions[v]));
        if has_normals {
            let nrm = Mat3::from_mat4(m) * mesh.normals[v];
            normals.push(nrm.try_normalize().unwrap_or(mesh.normals[v]));
        }
    }
    Ok(())
}

/// The weighted sum of the vertex's joint matrices; `None` when a weighted joint is out of
/// range. Zero-weight slots are skipped so their (meaningless) joint index never matters.
fn blend(joints: &[u16; 4], weights: Vec4, matrices: &[Mat4]) -> Option<Mat4> {
    let w = weights.to_array();
    let mut m = Mat4::ZERO;
    let mut total = 0.0;
    for k in 0..4 {
        if w[k] != 0.0 {
            m += *matrices.get(joints[k] as usize)? * w[k];
            total += w[k];
        }
    }
    // A vertex with no weight at all would collapse to the origin; leave it where it is.
    Some(if total == 0.0 { Mat4::IDENTITY } else { m })
}
