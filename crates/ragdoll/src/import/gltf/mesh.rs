//! Meshes: triangle primitives read through the accessor reader, skinned into the rest
//! pose, or gathered in world space for rigging when the file has no skin.

use std::collections::HashSet;
use std::path::Path;

use glam::{Mat3, Mat4, Vec3, Vec4};
use gltf::accessor::Dimensions;
use gltf::mesh::{Mode, Semantic};

use super::data::{AccessorReader, ReadBudget, format_err};
use super::skin::{NodeGraph, Rig};
use crate::error::Result;
use crate::skeleton::SkinnedMesh;

/// Every triangle primitive of the nodes of the default scene (all nodes when the file
/// has no scene), in world space: the meshes of a file without a skin, to be rigged.
pub(super) fn read_unskinned(
    doc: &gltf::Document,
    graph: &NodeGraph,
    reader: &Reads,
) -> Result<Vec<SkinnedMesh>> {
    let in_scene: Option<HashSet<usize>> =
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
            });
    let mut out = Vec::new();
    for node in doc.nodes() {
        let Some(mesh) = node.mesh() else { continue };
        if in_scene
            .as_ref()
            .is_some_and(|k| !k.contains(&node.index()))
        {
            continue;
        }
        let world = graph.world[node.index()];
        let normal_mat = Mat3::from_mat4(world).inverse().transpose();
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
    }
    Ok(out)
}

/// Skins every triangle primitive of the skin's meshes into world space, rest pose.
pub(super) fn read_meshes(
    doc: &gltf::Document,
    skin: &gltf::Skin,
    rig: &Rig,
    graph: &NodeGraph,
    reader: &Reads,
) -> Result<Vec<SkinnedMesh>> {
    let slots: Vec<usize> = skin.joints().map(|n| n.index()).collect();
    let ibms = match skin.inverse_bind_matrices() {
        Some(a) => {
            let m = reader.mat4s(&a)?;
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
            m
        }
        None => vec![Mat4::IDENTITY; slots.len()],
    };
    let joint_mats: Vec<Mat4> = slots
        .iter()
        .zip(&ibms)
        .map(|(&n, ibm)| graph.world[n] * *ibm)
        .collect();
    let mut done = HashSet::new();
    let mut out = Vec::new();
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
            if let Some(m) = read_primitive(&prim, name, &joint_mats, rig, reader)? {
                out.push(m);
            }
        }
    }
    Ok(out)
}

/// Per vertex, its (skin joint slot, weight) pairs.
pub(crate) type Influences = Vec<Vec<(usize, f32)>>;

/// Most `JOINTS_n`/`WEIGHTS_n` sets a primitive may have: 16, 64 influences per vertex.
/// Exporters write one or two; the limit keeps merging a vertex's influences cheap.
pub const MAX_INFLUENCE_SETS: usize = 16;

/// A primitive's `JOINTS_n`/`WEIGHTS_n` accessor pairs, `n` from 0 up to the first gap.
pub(crate) fn influence_sets<'a>(
    prim: &gltf::Primitive<'a>,
) -> Vec<(gltf::Accessor<'a>, gltf::Accessor<'a>)> {
    let mut sets = Vec::new();
    for k in 0.. {
        match (
            prim.get(&Semantic::Joints(k)),
            prim.get(&Semantic::Weights(k)),
        ) {
            // One past the limit, so that the caller can tell it was passed.
            (Some(j), Some(w)) if sets.len() <= MAX_INFLUENCE_SETS => sets.push((j, w)),
            _ => break,
        }
    }
    sets
}

/// The (skin slot, weight) pairs of every vertex of a primitive, over all its
/// `JOINTS_n`/`WEIGHTS_n` sets, renormalised to sum 1. `None` when the primitive is not
/// skinned.
pub(crate) fn read_influences(
    prim: &gltf::Primitive,
    vertex_count: usize,
    joint_count: usize,
    reader: &AccessorReader,
) -> Result<Option<Influences>> {
    let sets = influence_sets(prim);
    if sets.is_empty() {
        return Ok(None);
    }
    if sets.len() > MAX_INFLUENCE_SETS {
        return Err(format_err(
            reader.path,
            format!("accessor {}", sets[MAX_INFLUENCE_SETS].0.index()),
            format!(
                "a primitive has more than {MAX_INFLUENCE_SETS} JOINTS_n/WEIGHTS_n sets; this importer reads at most that many"
            ),
        ));
    }
    // Every check that needs no data comes first, so a count that does not match the
    // vertices is refused before anything is read or allocated for it.
    for (ja, wa) in &sets {
        reader.expect_dims(ja, &[Dimensions::Vec4], "JOINTS")?;
        reader.expect_dims(wa, &[Dimensions::Vec4], "WEIGHTS")?;
        for a in [ja, wa] {
            if a.count() != vertex_count {
                return Err(format_err(
                    reader.path,
                    format!("accessor {}", a.index()),
                    format!("has {} elements for {vertex_count} vertices", a.count()),
                ));
            }
        }
    }
    let mut out: Influences = Vec::new();
    let mut first = Vec::new();
    for (k, (ja, wa)) in sets.iter().enumerate() {
        let (js, _) = reader.uints(ja)?;
        let (ws, _) = reader.floats(wa)?;
        if k == 0 {
            // Both accessors were read, so the vertex count is backed by data.
            out = vec![Vec::new(); vertex_count];
            first = vec![0usize; vertex_count];
        }
        for (v, (jv, wv)) in js.chunks_exact(4).zip(ws.chunks_exact(4)).enumerate() {
            for c in 0..4 {
                let (slot, w) = (jv[c] as usize, wv[c]);
                if k == 0 && c == 0 {
                    first[v] = if slot < joint_count { slot } else { 0 };
                }
                if w <= 0.0 {
                    continue;
                }
                if slot >= joint_count {
                    return Err(format_err(
                        reader.path,
                        format!("accessor {}", ja.index()),
                        format!(
                            "vertex {v} uses joint {slot} but the skin has only {joint_count} joints"
                        ),
                    ));
                }
                match out[v].iter_mut().find(|(s, _)| *s == slot) {
                    Some((_, acc)) => *acc += w,
                    None => out[v].push((slot, w)),
                }
            }
        }
    }
    for (v, infl) in out.iter_mut().enumerate() {
        let sum: f32 = infl.iter().map(|(_, w)| w).sum();
        if sum > 0.0 && sum.is_finite() {
            infl.iter_mut().for_each(|(_, w)| *w /= sum);
        } else {
            *infl = vec![(first[v], 1.0)];
        }
    }
    Ok(Some(out))
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
        joint_count: usize,
    ) -> Result<Option<Influences>> {
        for (j, w) in influence_sets(prim) {
            self.budget.charge(&self.reader, &j)?;
            self.budget.charge(&self.reader, &w)?;
        }
        read_influences(prim, vertex_count, joint_count, &self.reader)
    }
}

fn read_primitive(
    prim: &gltf::Primitive,
    name: String,
    joint_mats: &[Mat4],
    rig: &Rig,
    reader: &Reads,
) -> Result<Option<SkinnedMesh>> {
    let Some(pos_acc) = prim.get(&Semantic::Positions) else {
        return Ok(None);
    };
    reader.expect_dims(&pos_acc, &[Dimensions::Vec3], "POSITION")?;
    let (pos, _) = reader.floats(&pos_acc)?;
    let n = pos_acc.count();
    let Some(influences) = reader.influences(prim, n, joint_mats.len())? else {
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
            joints[c] = rig.slot_to_joint[s] as u16;
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
    Ok(Some(mesh))
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
