//! Meshes: triangle primitives read through the accessor reader, skinned into the rest
//! pose, or gathered in world space for rigging when the file has no skin.

use std::collections::HashSet;
use std::path::Path;

use glam::{Mat3, Mat4, Vec3, Vec4};
use gltf::accessor::Dimensions;
use gltf::mesh::{Mode, Semantic};

mod weights;

pub(crate) use weights::{Influences, SkinSlots, read_influences};
pub use weights::{MAX_INFLUENCE_SETS, WEIGHT_SUM_TOLERANCE};

use super::data::{AccessorReader, ReadBudget, format_err};
use super::skin::{NodeGraph, Rig};
use crate::error::Result;
use crate::skeleton::{MAX_REACH_M, SkinnedMesh};

/// The nodes of the default scene (of the first scene when none is the default), or
/// `None` when the file has no scene: then every node counts.
pub(super) fn scene_nodes(doc: &gltf::Document) -> Option<HashSet<usize>> {
    doc.default_scene()
        .or_else(|| doc.scenes().next())
        .map(|scene| {
            let mut keep = HashSet::new();
            let mut stack: Vec<gltf::Node> = scene.nodes().collect();
            while let Some(n) = stack.pop() {
                if keep.insert(n.index()) {
                    stack.extend(n.children());
                }
            }
            keep
        })
}

/// Every triangle primitive of the nodes of the default scene (all nodes when the file
/// has no scene), in world space: the meshes of a file without a skin, to be rigged.
pub(super) fn read_unskinned(
    doc: &gltf::Document,
    graph: &NodeGraph,
    reader: &Reads,
) -> Result<Vec<SkinnedMesh>> {
    let in_scene = scene_nodes(doc);
    let mut out = Vec::new();
    for node in doc.nodes() {
        if in_scene
            .as_ref()
            .is_some_and(|k| !k.contains(&node.index()))
        {
            continue;
        }
        out.extend(read_node_meshes(&node, graph, reader)?);
    }
    Ok(out)
}

/// Whether `mesh` has a primitive [`read_node_meshes`] reads: triangles with positions.
pub(super) fn has_triangles(mesh: &gltf::Mesh) -> bool {
    mesh.primitives()
        .any(|p| p.mode() == Mode::Triangles && p.get(&Semantic::Positions).is_some())
}

/// The triangle primitives of a node's mesh, in world space (the node's rest world
/// transform applied), without skin weights; none when the node has no mesh.
pub(super) fn read_node_meshes(
    node: &gltf::Node,
    graph: &NodeGraph,
    reader: &Reads,
) -> Result<Vec<SkinnedMesh>> {
    let Some(mesh) = node.mesh() else {
        return Ok(Vec::new());
    };
    let world = graph.world[node.index()];
    let normal_mat = Mat3::from_mat4(world).inverse().transpose();
    let mut out = Vec::new();
    for prim in mesh.primitives() {
        let Some(pos_acc) = prim.get(&Semantic::Positions) else {
            continue;
        };
        if prim.mode() != Mode::Triangles {
            continue;
        }
        reader.expect_dims(&pos_acc, &[Dimensions::Vec3], "POSITION")?;
        let (pos, _) = reader.floats(&pos_acc)?;
        let n = pos.len() / 3;
        let indices = read_indices(reader, &prim, n)?;
        let normals = match prim.get(&Semantic::Normals) {
            Some(a) if a.count() == n && a.dimensions() == Dimensions::Vec3 => {
                let (f, _) = reader.floats(&a)?;
                f.chunks_exact(3)
                    .map(|c| (normal_mat * Vec3::from_slice(c)).normalize_or(Vec3::Y))
                    .collect()
            }
            _ => Vec::new(),
        };
        out.push(SkinnedMesh {
            name: mesh
                .name()
                .map(str::to_string)
                .unwrap_or_else(|| format!("mesh{}", mesh.index())),
            positions: pos
                .chunks_exact(3)
                .map(|c| world.transform_point3(Vec3::from_slice(c)))
                .collect(),
            normals,
            indices: indices[..indices.len() / 3 * 3].to_vec(),
            joints: Vec::new(),
            weights: Vec::new(),
        });
    }
    Ok(out)
}

/// Replaces each inverse bind matrix that cannot be inverted (all zero, a zero scale, not
/// finite) by the inverse of its joint's rest pose, and says how many: such a matrix
/// skins every vertex it weighs onto one point, and an all-zero table made a character
/// 0 m tall and half a gram. Binding in the rest pose is what a file without the table
/// means, so it is the repair.
fn bind_rest_where_degenerate(
    ibms: &mut [Mat4],
    slots: &[usize],
    graph: &NodeGraph,
    skin: &gltf::Skin,
    accessor: usize,
) -> Option<String> {
    let mut repaired = 0;
    for (ibm, &node) in ibms.iter_mut().zip(slots) {
        let det = ibm.determinant();
        if ibm.is_finite() && det.is_finite() && det.abs() > MIN_BIND_DETERMINANT {
            continue;
        }
        let rest = graph.world[node];
        *ibm = if rest.determinant().abs() > MIN_BIND_DETERMINANT {
            rest.inverse()
        } else {
            Mat4::IDENTITY
        };
        repaired += 1;
    }
    (repaired > 0).then(|| {
        format!(
            "skin {} (accessor {accessor}): {repaired} of {} inverse bind matrices cannot be inverted (all zero, a zero scale or not finite); those joints are bound in their rest pose instead",
            skin.index(),
            slots.len()
        )
    })
}

/// Below this determinant an inverse bind matrix is taken for degenerate: a scale of a
/// thousandth on every axis (1e-9) still counts as one, a file in kilometres' worth.
const MIN_BIND_DETERMINANT: f32 = 1e-12;

/// Skins every triangle primitive of the meshes of `skins` (the chosen skin and those
/// attached to it) into world space, rest pose; also returns one warning for each
/// primitive whose skin weights were repaired.
pub(super) fn read_meshes(
    doc: &gltf::Document,
    skins: &[usize],
    rig: &Rig,
    graph: &NodeGraph,
    reader: &Reads,
) -> Result<(Vec<SkinnedMesh>, Vec<String>)> {
    let mut out = Vec::new();
    let mut warnings = Vec::new();
    for skin in doc.skins().filter(|s| skins.contains(&s.index())) {
        read_skin_meshes(doc, &skin, rig, graph, reader, &mut out, &mut warnings)?;
    }
    Ok((out, warnings))
}

/// One skin's part of [`read_meshes`]: its joints are skeleton joints by construction (the
/// rig is the union of the attached skins' joints).
fn read_skin_meshes(
    doc: &gltf::Document,
    skin: &gltf::Skin,
    rig: &Rig,
    graph: &NodeGraph,
    reader: &Reads,
    out: &mut Vec<SkinnedMesh>,
    warnings: &mut Vec<String>,
) -> Result<()> {
    let slots: Vec<usize> = skin.joints().map(|n| n.index()).collect();
    let Some(slot_to_joint) = slots
        .iter()
        .map(|n| rig.node_to_joint.get(n).copied())
        .collect::<Option<Vec<usize>>>()
    else {
        return Ok(());
    };
    let ibms = inverse_binds(skin, &slots, graph, reader, warnings)?;
    let joint_mats: Vec<Mat4> = slots
        .iter()
        .zip(&ibms)
        .map(|(&n, ibm)| graph.world[n] * *ibm)
        .collect();
    // The slot nearest the skeleton's root carries weightless parts.
    let root = (0..slots.len())
        .min_by_key(|&s| slot_to_joint[s])
        .unwrap_or(0);
    let skin_slots = SkinSlots {
        count: slots.len(),
        root,
    };
    let mut done = HashSet::new();
    for node in doc.nodes() {
        let (Some(mesh), Some(s)) = (node.mesh(), node.skin()) else {
            continue;
        };
        if s.index() != skin.index() || !done.insert(mesh.index()) {
            continue;
        }
        let mesh_name = mesh
            .name()
            .map(str::to_string)
            .unwrap_or_else(|| format!("mesh{}", mesh.index()));
        let many = mesh.primitives().len() > 1;
        for prim in mesh.primitives() {
            if prim.mode() != Mode::Triangles {
                continue;
            }
            let name = if many {
                format!("{mesh_name}.{}", prim.index())
            } else {
                mesh_name.clone()
            };
            let Some((m, repair)) =
                read_primitive(&prim, name, &joint_mats, skin_slots, &slot_to_joint, reader)?
            else {
                continue;
            };
            if !repair.is_empty() {
                let place = primitive_place(&prim, &mesh_name);
                let root = &rig.joints[slot_to_joint[skin_slots.root]].name;
                warnings.push(repair.sentence(&place, m.positions.len(), slots.len(), root));
            }
            out.push(m);
        }
    }
    Ok(())
}

/// A skin's inverse bind matrices, one per joint (identity when the skin has none); those
/// that cannot be inverted are repaired with a warning ([`bind_rest_where_degenerate`]).
fn inverse_binds(
    skin: &gltf::Skin,
    slots: &[usize],
    graph: &NodeGraph,
    reader: &Reads,
    warnings: &mut Vec<String>,
) -> Result<Vec<Mat4>> {
    let Some(a) = skin.inverse_bind_matrices() else {
        return Ok(vec![Mat4::IDENTITY; slots.len()]);
    };
    let mut m = reader.mat4s(&a)?;
    if m.len() < slots.len() {
        return Err(format_err(
            reader.path(),
            format!("accessor {}", a.index()),
            format!(
                "holds {} inverse bind matrices for a skin of {} joints",
                m.len(),
                slots.len()
            ),
        ));
    }
    if let Some(w) = bind_rest_where_degenerate(&mut m, slots, graph, skin, a.index()) {
        warnings.push(w);
    }
    Ok(m)
}

/// Where a primitive's weights are, for a repair's warning: the mesh, the primitive and
/// each influence set's accessors.
fn primitive_place(prim: &gltf::Primitive, mesh_name: &str) -> String {
    let sets: Vec<String> = weights::influence_sets(prim)
        .iter()
        .enumerate()
        .map(|(k, (j, w))| {
            format!(
                "JOINTS_{k} accessor {}, WEIGHTS_{k} accessor {}",
                j.index(),
                w.index()
            )
        })
        .collect();
    format!(
        "mesh \"{mesh_name}\" primitive {} ({})",
        prim.index(),
        sets.join(", ")
    )
}

/// The accessor reader with this import's [`ReadBudget`]: every read is charged before it
/// allocates.
pub(super) struct Reads<'a> {
    pub(super) reader: AccessorReader<'a>,
    pub(super) budget: ReadBudget,
}

impl<'a> Reads<'a> {
    pub(super) fn path(&self) -> &'a Path {
        self.reader.path
    }

    pub(super) fn floats(&self, a: &gltf::Accessor) -> Result<(Vec<f32>, usize)> {
        self.budget.charge(&self.reader, a)?;
        self.reader.floats(a)
    }

    pub(super) fn uints(&self, a: &gltf::Accessor) -> Result<(Vec<u32>, usize)> {
        self.budget.charge(&self.reader, a)?;
        self.reader.uints(a)
    }

    pub(super) fn mat4s(&self, a: &gltf::Accessor) -> Result<Vec<Mat4>> {
        self.budget.charge(&self.reader, a)?;
        self.reader.mat4s(a)
    }

    pub(super) fn expect_dims(
        &self,
        a: &gltf::Accessor,
        dims: &[Dimensions],
        what: &str,
    ) -> Result<()> {
        self.reader.expect_dims(a, dims, what)
    }

    /// [`read_influences`], charged.
    pub(super) fn influences(
        &self,
        prim: &gltf::Primitive,
        vertex_count: usize,
        skin: SkinSlots,
    ) -> Result<Option<(Influences, weights::WeightRepair)>> {
        let charge = |a: &gltf::Accessor| self.budget.charge(&self.reader, a);
        read_influences(prim, vertex_count, skin, &self.reader, &charge)
    }
}

fn read_primitive(
    prim: &gltf::Primitive,
    name: String,
    joint_mats: &[Mat4],
    skin: SkinSlots,
    slot_to_joint: &[usize],
    reader: &Reads,
) -> Result<Option<(SkinnedMesh, weights::WeightRepair)>> {
    let Some(pos_acc) = prim.get(&Semantic::Positions) else {
        return Ok(None);
    };
    reader.expect_dims(&pos_acc, &[Dimensions::Vec3], "POSITION")?;
    let (pos, _) = reader.floats(&pos_acc)?;
    let n = pos_acc.count();
    let Some((influences, repair)) = reader.influences(prim, n, skin)? else {
        return Ok(None);
    };
    let normals_in = match prim.get(&Semantic::Normals) {
        Some(a) => {
            reader.expect_dims(&a, &[Dimensions::Vec3], "NORMAL")?;
            let (f, _) = reader.floats(&a)?;
            if f.len() != n * 3 {
                return Err(format_err(
                    reader.path(),
                    format!("accessor {}", a.index()),
                    format!("has {} normals for {n} vertices", f.len() / 3),
                ));
            }
            Some(f)
        }
        None => None,
    };
    let indices = read_indices(reader, prim, n)?;
    let mut mesh = SkinnedMesh {
        name,
        indices: indices[..indices.len() / 3 * 3].to_vec(),
        ..Default::default()
    };
    for (v, infl) in influences.iter().enumerate() {
        let m = infl
            .iter()
            .fold(Mat4::ZERO, |acc, &(s, w)| acc + joint_mats[s] * w);
        let p = Vec3::new(pos[v * 3], pos[v * 3 + 1], pos[v * 3 + 2]);
        mesh.positions.push(m.transform_point3(p));
        if let Some(nrm) = &normals_in {
            let nv = Vec3::new(nrm[v * 3], nrm[v * 3 + 1], nrm[v * 3 + 2]);
            let m3 = Mat3::from_mat4(m);
            let world = if m3.determinant().abs() > 1e-12 {
                m3.inverse().transpose() * nv
            } else {
                m3 * nv
            };
            mesh.normals.push(world.try_normalize().unwrap_or(Vec3::Y));
        }
        let mut top = infl.clone();
        top.sort_by(|a, b| b.1.total_cmp(&a.1));
        top.truncate(4);
        let sum: f32 = top.iter().map(|(_, w)| w).sum();
        let mut joints = [0u16; 4];
        let mut weights = [0f32; 4];
        for (c, &(s, w)) in top.iter().enumerate() {
            joints[c] = slot_to_joint[s] as u16;
            weights[c] = w / sum;
        }
        mesh.joints.push(joints);
        mesh.weights.push(Vec4::from_array(weights));
    }
    if !mesh.positions.iter().all(|p| p.is_finite()) {
        return Err(format_err(
            reader.path(),
            format!("accessor {}", pos_acc.index()),
            "skinned positions are not finite (check the inverse bind matrices)",
        ));
    }
    // Finite but absurd (1e38): the shapes sized from such a skin overflowed to NaN, and the
    // error then blamed a spec radius. The skin is refused here, where its numbers are.
    let far = mesh
        .positions
        .iter()
        .map(|p| p.length())
        .fold(0.0f32, f32::max);
    if far > MAX_REACH_M {
        return Err(format_err(
            reader.path(),
            format!("accessor {}", pos_acc.index()),
            format!(
                "skinned positions reach {far} m from the origin, past the {MAX_REACH_M} m a character may"
            ),
        ));
    }
    Ok(Some((mesh, repair)))
}

/// A primitive's triangle indices (or 0..n when it has none), each checked against its
/// `n` vertices, so nothing downstream indexes past them.
fn read_indices(reader: &Reads, prim: &gltf::Primitive, n: usize) -> Result<Vec<u32>> {
    let Some(a) = prim.indices() else {
        return Ok((0..n as u32).collect());
    };
    reader.expect_dims(&a, &[Dimensions::Scalar], "indices")?;
    let (ix, _) = reader.uints(&a)?;
    if let Some(bad) = ix.iter().find(|&&i| i as usize >= n) {
        return Err(format_err(
            reader.path(),
            format!("accessor {}", a.index()),
            format!("index {bad} is not below the vertex count {n}"),
        ));
    }
    Ok(ix)
}
