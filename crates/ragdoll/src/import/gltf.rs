//! glTF 2.0 import (.glb, and .gltf with `data:` URIs or external buffers).
//!
//! Choices, and why:
//! - **Skeleton** = the joints of one skin. When a file has several skins, the one whose
//!   meshes have the most vertices wins (ties: the first): that is the character, not a
//!   prop or an accessory rigged on the side.
//! - Joints keep the skin's order, except that a joint listed before its parent is moved
//!   after it (parents must come first); keeping the file's order lets a file we wrote read
//!   back joint for joint. A joint's parent is its nearest ancestor *node* that is also a
//!   joint of the skin. Non-joint nodes on the way (CesiumMan's Z-up correction node, an
//!   `Armature` node) are folded into the child's rest transform, and a root joint's rest
//!   is its full world transform, so the skeleton lives in world space, Y up, as the rest
//!   of the crate expects.
//! - **Rest pose** = the nodes' own transforms (what a viewer shows with no animation),
//!   not the bind pose; meshes are skinned into that pose so mesh and skeleton agree even
//!   when the inverse bind matrices were taken in another pose.
//! - **Meshes**: one [`SkinnedMesh`] per triangle primitive of every mesh instanced with the
//!   chosen skin. Points, lines, strips and fans are skipped (no ragdoll needs them).
//!   Morph targets are ignored. Up to four influences are kept per vertex (the strongest,
//!   renormalised to sum 1); a vertex whose weights sum to 0 gets weight 1 on its first joint.
//! - **No skin**: a file with triangle meshes but no skin (a scanned or modelled prop) is
//!   rigged like an OBJ ([`crate::rig`]): every triangle primitive of every node in the
//!   default scene (or of every node, when there is no scene) in world space. Its source is
//!   then [`Source::Mesh`] (a fresh glTF is written on export; materials are not kept).
//! - **Clips**: one per animation that moves at least one joint (animations of other nodes
//!   only are skipped), sampled from its first to its last key at the key spacing when the
//!   keys are regular, else at 30 fps. `CUBICSPLINE` is evaluated as the cubic Hermite
//!   spline it is (better than the key values alone, and just as cheap). Joints without a
//!   channel keep their rest; channels on non-joint nodes are ignored.

mod data;

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

use glam::{Mat3, Mat4, Quat, Vec3, Vec4};
use gltf::accessor::Dimensions;
use gltf::animation::{Interpolation, Property};
use gltf::mesh::{Mode, Semantic};

pub(crate) use data::{AccessorReader, decode_data_uri, external_path, format_err};

use crate::error::{Error, Result};
use crate::math::Transform;
use crate::rig::RigOptions;
use crate::skeleton::{Character, Clip, Joint, Skeleton, SkinnedMesh, Source};

/// What the glTF exporter needs to write the input back, untouched but for a new animation
/// and renormalised skin weights.
#[derive(Clone, Debug)]
pub struct GltfSource {
    /// The file read, for error messages.
    pub path: PathBuf,
    /// Its folder, where external images and buffers are found.
    pub dir: PathBuf,
    /// The whole glTF JSON document as read, extensions and extras included.
    pub json: serde_json::Value,
    /// Every buffer's bytes, resolved (GLB chunk, `data:` URI or file) and cut to the
    /// declared `byteLength`.
    pub buffers: Vec<Vec<u8>>,
    /// Index of the skin the skeleton was built from.
    pub skin: usize,
    /// Node index of each skeleton joint, in skeleton order.
    pub joint_nodes: Vec<usize>,
    /// For each skeleton joint, the static transform between its parent joint's node (for a
    /// root joint: the world) and its own node's parent, i.e. the product of the non-joint
    /// nodes in between; identity when the node's parent is the parent joint itself.
    /// The node's animated local transform is then
    /// `(parent joint world · parent_offsets[j])⁻¹ · joint world`.
    pub parent_offsets: Vec<Transform>,
}

/// Loads a glTF 2.0 file (.glb, or .gltf with `data:` URIs or external buffers).
pub fn load(path: &Path) -> Result<Character> {
    load_rigged(path, &RigOptions::default())
}

/// [`load`], rigging a file without a skin with `rig`.
pub fn load_rigged(path: &Path, rig: &RigOptions) -> Result<Character> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    from_bytes_rigged(&bytes, path, rig)
}

/// Loads a glTF 2.0 file already in memory; `path` names it in errors and anchors its
/// relative URIs (external buffers), as if the bytes had been read from there.
pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Character> {
    from_bytes_rigged(bytes, path, &RigOptions::default())
}

/// [`from_bytes`], rigging a file without a skin with `rig`.
pub fn from_bytes_rigged(bytes: &[u8], path: &Path, rig: &RigOptions) -> Result<Character> {
    let container = data::split_container(bytes, path)?;
    let json: serde_json::Value = serde_json::from_slice(container.json).map_err(|e| {
        let place = if container.json_offset > 0 {
            format!("JSON chunk line {}, column {}", e.line(), e.column())
        } else {
            format!("line {}, column {}", e.line(), e.column())
        };
        format_err(path, place, format!("not valid JSON: {e}"))
    })?;
    let doc = parse_document(&json, path)?;
    // Compressed geometry would read as zeros, which is worse than a clear refusal.
    let required = json
        .get("extensionsRequired")
        .and_then(serde_json::Value::as_array);
    for ext in required
        .into_iter()
        .flatten()
        .filter_map(serde_json::Value::as_str)
    {
        if matches!(
            ext,
            "KHR_draco_mesh_compression" | "EXT_meshopt_compression"
        ) {
            return Err(format_err(
                path,
                "extensionsRequired",
                format!("uses {ext}, which this importer cannot decode; export it uncompressed"),
            ));
        }
    }
    let dir = path
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("."));
    let buffers = data::resolve_buffers(&doc, container.bin, &dir, path)?;
    let reader = AccessorReader {
        buffers: &buffers,
        path,
    };
    let graph = NodeGraph::new(&doc, path)?;
    if doc.skins().len() == 0 {
        let meshes = read_unskinned(&doc, &graph, &reader)?;
        if meshes.is_empty() {
            return Err(format_err(
                path,
                "skins",
                "has no skin and no triangle mesh: nothing to build a ragdoll from",
            ));
        }
        return super::obj::rigged_character(file_stem(path), meshes, rig, path);
    }
    let skin_index = choose_skin(&doc, path)?;
    let skin = doc
        .skins()
        .nth(skin_index)
        .ok_or_else(|| format_err(path, "skins", "skin index out of range"))?;
    let rig = Rig::new(&doc, &skin, &graph, path)?;
    let skeleton = Skeleton::new(rig.joints.clone())?;
    let meshes = read_meshes(&doc, &skin, &rig, &graph, &reader)?;
    let clips = read_clips(&doc, &rig, &reader)?;
    Ok(Character {
        name: file_stem(path),
        skeleton,
        meshes,
        clips,
        source: Source::Gltf(Box::new(GltfSource {
            path: path.to_path_buf(),
            dir,
            json,
            buffers,
            skin: skin_index,
            joint_nodes: rig.nodes,
            parent_offsets: rig.offsets,
        })),
    })
}

fn file_stem(path: &Path) -> String {
    path.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// Every triangle primitive of the nodes of the default scene (all nodes when the file
/// has no scene), in world space: the meshes of a file without a skin, to be rigged.
fn read_unskinned(
    doc: &gltf::Document,
    graph: &NodeGraph,
    reader: &AccessorReader,
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
            let indices = match prim.indices() {
                Some(a) => {
                    reader.expect_dims(&a, &[Dimensions::Scalar], "indices")?;
                    let (ix, _) = reader.uints(&a)?;
                    if let Some(bad) = ix.iter().find(|&&i| i as usize >= n) {
                        return Err(format_err(
                            reader.path,
                            format!("accessor {}", a.index()),
                            format!("index {bad} is not below the vertex count {n}"),
                        ));
                    }
                    ix
                }
                None => (0..n as u32).collect(),
            };
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

/// Checks the JSON against the glTF schema (types, required fields, index ranges) so that
/// the typed accessors of [`gltf::Document`] can be used without panicking.
///
/// The check runs on a copy trimmed to what we read (nodes, meshes, skins, animations,
/// accessors, buffers), because the `gltf` crate, built without its extension features,
/// refuses things a ragdoll does not care about: any `extensionsRequired` entry (even
/// `KHR_texture_transform`), textures without a core `source` (KTX2, WebP), and
/// application-specific vertex attributes such as `_BATCHID`. Materials and images are
/// passed through untouched by the exporter. The crate also leaves animation channel
/// targets unchecked although its typed accessors panic on a bad one, so those are checked
/// here.
pub(crate) fn parse_document(json: &serde_json::Value, path: &Path) -> Result<gltf::Document> {
    let mut json = json.clone();
    if let Some(o) = json.as_object_mut() {
        for key in [
            "extensionsRequired",
            "materials",
            "textures",
            "images",
            "samplers",
        ] {
            o.remove(key);
        }
    }
    if let Some(meshes) = json
        .get_mut("meshes")
        .and_then(serde_json::Value::as_array_mut)
    {
        for mesh in meshes {
            let prims = mesh
                .get_mut("primitives")
                .and_then(serde_json::Value::as_array_mut);
            for prim in prims.into_iter().flatten() {
                if let Some(p) = prim.as_object_mut() {
                    p.remove("material");
                }
                if let Some(attrs) = prim
                    .get_mut("attributes")
                    .and_then(serde_json::Value::as_object_mut)
                {
                    attrs.retain(|k, _| !k.starts_with('_'));
                }
            }
        }
    }
    let root: gltf::json::Root = gltf::json::deserialize::from_value(json)
        .map_err(|e| format_err(path, "JSON", format!("not a glTF 2.0 document: {e}")))?;
    let node_count = root.nodes.len();
    for (a, anim) in root.animations.iter().enumerate() {
        for (c, ch) in anim.channels.iter().enumerate() {
            let place = || format!("animations[{a}].channels[{c}].target");
            if ch.target.node.value() >= node_count {
                return Err(format_err(
                    path,
                    place(),
                    format!("node {} does not exist", ch.target.node.value()),
                ));
            }
            if !matches!(ch.target.path, gltf::json::validation::Checked::Valid(_)) {
                return Err(format_err(
                    path,
                    place(),
                    "path must be translation, rotation, scale or weights",
                ));
            }
        }
    }
    gltf::Document::from_json(root).map_err(|e| match e {
        gltf::Error::Validation(list) if !list.is_empty() => {
            let (p, err) = &list[0];
            let more = if list.len() > 1 {
                format!(" (and {} more problems)", list.len() - 1)
            } else {
                String::new()
            };
            format_err(path, p.to_string(), format!("{err:?}{more}"))
        }
        other => format_err(path, "JSON", other.to_string()),
    })
}

/// A node's TRS, decomposing a `matrix` when that is what the node has.
pub(crate) fn node_transform(node: &gltf::Node, path: &Path) -> Result<(Transform, Mat4)> {
    let (t, m) = match node.transform() {
        gltf::scene::Transform::Matrix { matrix } => {
            let m = Mat4::from_cols_array_2d(&matrix);
            (Transform::from_mat4(m), m)
        }
        gltf::scene::Transform::Decomposed {
            translation,
            rotation,
            scale,
        } => {
            let t = Transform {
                translation: Vec3::from(translation),
                rotation: Quat::from_array(rotation).normalize(),
                scale: Vec3::from(scale),
            };
            (t, t.to_mat4())
        }
    };
    if !t.is_finite() || !m.is_finite() {
        return Err(format_err(
            path,
            format!("node {}", node.index()),
            "its transform is not finite (or its rotation is a zero quaternion)",
        ));
    }
    Ok((t, m))
}

/// The node hierarchy, flattened: parents, local and world transforms.
struct NodeGraph {
    parent: Vec<Option<usize>>,
    local: Vec<Transform>,
    world: Vec<Mat4>,
}

impl NodeGraph {
    fn new(doc: &gltf::Document, path: &Path) -> Result<Self> {
        let n = doc.nodes().len();
        if n == 0 {
            return Err(format_err(
                path,
                "nodes",
                "the file has no nodes, so no skeleton",
            ));
        }
        let mut parent = vec![None; n];
        let mut local = Vec::with_capacity(n);
        let mut local_mat = Vec::with_capacity(n);
        for node in doc.nodes() {
            for child in node.children() {
                let c = child.index();
                if parent[c].is_some() || c == node.index() {
                    return Err(format_err(
                        path,
                        format!("node {c}"),
                        "has more than one parent (the node hierarchy must be a tree)",
                    ));
                }
                parent[c] = Some(node.index());
            }
            let (t, m) = node_transform(&node, path)?;
            local.push(t);
            local_mat.push(m);
        }
        let mut depth = vec![0; n];
        for (i, d) in depth.iter_mut().enumerate() {
            let mut a = parent[i];
            while let Some(p) = a {
                *d += 1;
                if *d > n {
                    return Err(format_err(
                        path,
                        format!("node {i}"),
                        "is its own ancestor (a cycle)",
                    ));
                }
                a = parent[p];
            }
        }
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by_key(|&i| depth[i]);
        let mut world = vec![Mat4::IDENTITY; n];
        for i in order {
            world[i] = match parent[i] {
                Some(p) => world[p] * local_mat[i],
                None => local_mat[i],
            };
        }
        Ok(NodeGraph {
            parent,
            local,
            world,
        })
    }
}

/// The skin used by the most vertices (ties: the lowest index).
fn choose_skin(doc: &gltf::Document, path: &Path) -> Result<usize> {
    let n = doc.skins().len();
    if n == 0 {
        return Err(format_err(
            path,
            "skins",
            "has no skin: no skeleton to build a ragdoll from",
        ));
    }
    let mut verts = vec![0usize; n];
    for node in doc.nodes() {
        if let (Some(mesh), Some(skin)) = (node.mesh(), node.skin()) {
            for prim in mesh.primitives() {
                if let Some(a) = prim.get(&Semantic::Positions) {
                    verts[skin.index()] += a.count();
                }
            }
        }
    }
    let best = verts.iter().copied().max().unwrap_or(0);
    Ok(verts.iter().position(|&v| v == best).unwrap_or(0))
}

/// The skeleton built from a skin, with the bookkeeping that maps it back to nodes.
struct Rig {
    joints: Vec<Joint>,
    /// Node of each skeleton joint.
    nodes: Vec<usize>,
    /// Static transforms from the parent joint (or world) to each joint node's parent.
    offsets: Vec<Transform>,
    /// Skeleton index of each skin joint slot.
    slot_to_joint: Vec<usize>,
    /// Skeleton index of each joint node.
    node_to_joint: HashMap<usize, usize>,
    /// Each joint node's own TRS.
    node_rest: Vec<Transform>,
}

impl Rig {
    fn new(
        doc: &gltf::Document,
        skin: &gltf::Skin,
        graph: &NodeGraph,
        path: &Path,
    ) -> Result<Self> {
        let place = format!("skin {}", skin.index());
        let slots: Vec<usize> = skin.joints().map(|n| n.index()).collect();
        if slots.is_empty() {
            return Err(format_err(path, place, "has no joints"));
        }
        let mut seen = HashSet::new();
        for &n in &slots {
            if !seen.insert(n) {
                return Err(format_err(
                    path,
                    place,
                    format!("lists node {n} twice among its joints"),
                ));
            }
        }
        // Nearest ancestor joint of each slot, then the skin's own order with any joint
        // listed before its parent moved after it: files already in parent-first order
        // (most, and every file we write) keep their joint order through a round trip.
        let slot_of: HashMap<usize, usize> =
            slots.iter().enumerate().map(|(s, &n)| (n, s)).collect();
        let parent_slot: Vec<Option<usize>> = slots
            .iter()
            .map(|&n| {
                let mut a = graph.parent[n];
                while let Some(p) = a {
                    if let Some(&ps) = slot_of.get(&p) {
                        return Some(ps);
                    }
                    a = graph.parent[p];
                }
                None
            })
            .collect();
        let mut order = Vec::with_capacity(slots.len());
        let mut placed = vec![false; slots.len()];
        for s in 0..slots.len() {
            let mut pending = Vec::new();
            let mut at = Some(s);
            while let Some(x) = at.filter(|&x| !placed[x]) {
                pending.push(x);
                at = parent_slot[x];
            }
            for &x in pending.iter().rev() {
                placed[x] = true;
                order.push(x);
            }
        }
        let mut slot_to_joint = vec![0; slots.len()];
        let mut node_to_joint = HashMap::new();
        for (j, &s) in order.iter().enumerate() {
            slot_to_joint[s] = j;
            node_to_joint.insert(slots[s], j);
        }
        let names: Vec<String> = doc
            .nodes()
            .map(|n| n.name().unwrap_or("").to_string())
            .collect();
        let mut joints = Vec::with_capacity(slots.len());
        let mut nodes = Vec::with_capacity(slots.len());
        let mut offsets = Vec::with_capacity(slots.len());
        let mut node_rest = Vec::with_capacity(slots.len());
        for &s in &order {
            let node = slots[s];
            let mut chain = Vec::new();
            let mut parent = None;
            let mut a = graph.parent[node];
            while let Some(p) = a {
                if let Some(&pj) = node_to_joint.get(&p) {
                    parent = Some(pj);
                    break;
                }
                chain.push(p);
                a = graph.parent[p];
            }
            let offset = chain
                .iter()
                .rev()
                .fold(Transform::IDENTITY, |acc, &p| acc.mul(&graph.local[p]));
            let rest = if chain.is_empty() {
                graph.local[node]
            } else {
                offset.mul(&graph.local[node])
            };
            joints.push(Joint {
                name: names[node].clone(),
                parent,
                rest,
                tip: None,
            });
            nodes.push(node);
            offsets.push(offset);
            node_rest.push(graph.local[node]);
        }
        Ok(Rig {
            joints,
            nodes,
            offsets,
            slot_to_joint,
            node_to_joint,
            node_rest,
        })
    }

    /// A joint's skeleton-space local transform from its node's own (animated) TRS.
    fn local(&self, j: usize, node_trs: &Transform) -> Transform {
        if self.offsets[j] == Transform::IDENTITY {
            *node_trs
        } else {
            self.offsets[j].mul(node_trs)
        }
    }
}

/// Skins every triangle primitive of the skin's meshes into world space, rest pose.
fn read_meshes(
    doc: &gltf::Document,
    skin: &gltf::Skin,
    rig: &Rig,
    graph: &NodeGraph,
    reader: &AccessorReader,
) -> Result<Vec<SkinnedMesh>> {
    let slots: Vec<usize> = skin.joints().map(|n| n.index()).collect();
    let ibms = match skin.inverse_bind_matrices() {
        Some(a) => {
            let m = reader.mat4s(&a)?;
            if m.len() < slots.len() {
                return Err(format_err(
                    reader.path,
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

/// The (skin slot, weight) pairs of every vertex of a primitive, over all its
/// `JOINTS_n`/`WEIGHTS_n` sets, renormalised to sum 1. `None` when the primitive is not
/// skinned.
pub(crate) fn read_influences(
    prim: &gltf::Primitive,
    vertex_count: usize,
    joint_count: usize,
    reader: &AccessorReader,
) -> Result<Option<Influences>> {
    let mut sets = Vec::new();
    for k in 0.. {
        match (
            prim.get(&Semantic::Joints(k)),
            prim.get(&Semantic::Weights(k)),
        ) {
            (Some(j), Some(w)) => sets.push((j, w)),
            _ => break,
        }
    }
    if sets.is_empty() {
        return Ok(None);
    }
    let mut out = vec![Vec::with_capacity(4 * sets.len()); vertex_count];
    let mut first = vec![0usize; vertex_count];
    for (k, (ja, wa)) in sets.iter().enumerate() {
        reader.expect_dims(ja, &[Dimensions::Vec4], "JOINTS")?;
        reader.expect_dims(wa, &[Dimensions::Vec4], "WEIGHTS")?;
        let (js, _) = reader.uints(ja)?;
        let (ws, _) = reader.floats(wa)?;
        for (a, len) in [(ja, js.len()), (wa, ws.len())] {
            if len != vertex_count * 4 {
                return Err(format_err(
                    reader.path,
                    format!("accessor {}", a.index()),
                    format!("has {} elements for {vertex_count} vertices", len / 4),
                ));
            }
        }
        for v in 0..vertex_count {
            for c in 0..4 {
                let (slot, w) = (js[v * 4 + c] as usize, ws[v * 4 + c]);
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

fn read_primitive(
    prim: &gltf::Primitive,
    name: String,
    joint_mats: &[Mat4],
    rig: &Rig,
    reader: &AccessorReader,
) -> Result<Option<SkinnedMesh>> {
    let Some(pos_acc) = prim.get(&Semantic::Positions) else {
        return Ok(None);
    };
    reader.expect_dims(&pos_acc, &[Dimensions::Vec3], "POSITION")?;
    let (pos, _) = reader.floats(&pos_acc)?;
    let n = pos_acc.count();
    let Some(influences) = read_influences(prim, n, joint_mats.len(), reader)? else {
        return Ok(None);
    };
    let normals_in = match prim.get(&Semantic::Normals) {
        Some(a) => {
            reader.expect_dims(&a, &[Dimensions::Vec3], "NORMAL")?;
            let (f, _) = reader.floats(&a)?;
            if f.len() != n * 3 {
                return Err(format_err(
                    reader.path,
                    format!("accessor {}", a.index()),
                    format!("has {} normals for {n} vertices", f.len() / 3),
                ));
            }
            Some(f)
        }
        None => None,
    };
    let indices = match prim.indices() {
        Some(a) => {
            reader.expect_dims(&a, &[Dimensions::Scalar], "indices")?;
            let (ix, _) = reader.uints(&a)?;
            if let Some(bad) = ix.iter().find(|&&i| i as usize >= n) {
                return Err(format_err(
                    reader.path,
                    format!("accessor {}", a.index()),
                    format!("index {bad} is not below the vertex count {n}"),
                ));
            }
            ix
        }
        None => (0..n as u32).collect(),
    };
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
            reader.path,
            format!("accessor {}", pos_acc.index()),
            "skinned positions are not finite (check the inverse bind matrices)",
        ));
    }
    Ok(Some(mesh))
}

/// One animation channel on a joint, read and checked.
struct Channel {
    joint: usize,
    property: Property,
    interpolation: Interpolation,
    times: Vec<f32>,
    values: Vec<f32>,
    width: usize,
}

impl Channel {
    fn value(&self, key: usize) -> &[f32] {
        let k = if self.interpolation == Interpolation::CubicSpline {
            3 * key + 1
        } else {
            key
        };
        &self.values[k * self.width..(k + 1) * self.width]
    }

    fn tangent(&self, key: usize, out: bool) -> &[f32] {
        let k = 3 * key + if out { 2 } else { 0 };
        &self.values[k * self.width..(k + 1) * self.width]
    }

    /// The channel's value at time `t`, held constant outside its keys.
    fn sample(&self, t: f32) -> [f32; 4] {
        let mut out = [0.0; 4];
        let n = self.times.len();
        let last = n - 1;
        let (k, u) = if t <= self.times[0] {
            (0, 0.0)
        } else if t >= self.times[last] {
            (last, 0.0)
        } else {
            let k = self
                .times
                .partition_point(|&x| x <= t)
                .saturating_sub(1)
                .min(last - 1);
            let dt = self.times[k + 1] - self.times[k];
            (
                k,
                if dt > 0.0 {
                    (t - self.times[k]) / dt
                } else {
                    0.0
                },
            )
        };
        let w = self.width;
        if u == 0.0 || self.interpolation == Interpolation::Step {
            out[..w].copy_from_slice(self.value(k));
        } else if self.interpolation == Interpolation::Linear {
            let (a, b) = (self.value(k), self.value(k + 1));
            if self.property == Property::Rotation {
                let q = unit_or_identity(Quat::from_slice(a))
                    .slerp(unit_or_identity(Quat::from_slice(b)), u);
                out = q.to_array();
            } else {
                for c in 0..w {
                    out[c] = a[c] + (b[c] - a[c]) * u;
                }
            }
        } else {
            let dt = self.times[k + 1] - self.times[k];
            let (u2, u3) = (u * u, u * u * u);
            let h00 = 2.0 * u3 - 3.0 * u2 + 1.0;
            let h10 = u3 - 2.0 * u2 + u;
            let h01 = -2.0 * u3 + 3.0 * u2;
            let h11 = u3 - u2;
            let (p0, m0) = (self.value(k), self.tangent(k, true));
            let (p1, m1) = (self.value(k + 1), self.tangent(k + 1, false));
            for c in 0..w {
                out[c] = h00 * p0[c] + h10 * dt * m0[c] + h01 * p1[c] + h11 * dt * m1[c];
            }
        }
        if self.property == Property::Rotation {
            out = unit_or_identity(Quat::from_array(out)).to_array();
        }
        out
    }
}

/// `q` scaled to unit length, or the identity for a zero or non-finite quaternion.
fn unit_or_identity(q: Quat) -> Quat {
    let l = q.length();
    if l > 1e-12 && l.is_finite() {
        q / l
    } else {
        Quat::IDENTITY
    }
}

/// Output frame rate when keys are irregular.
const DEFAULT_FPS: f32 = 30.0;
/// Regular keys at least this dense are sampled at their own rate; sparser ones at the
/// smallest multiple of their rate that reaches [`DEFAULT_FPS`], so every key is still hit.
const MIN_KEY_FPS: f32 = 20.0;
/// Denser keys than this are resampled at [`DEFAULT_FPS`].
const MAX_KEY_FPS: f32 = 240.0;
/// Longest clip sampled, in frames times joints, so a bogus time range cannot exhaust memory.
const MAX_CLIP_SAMPLES: usize = 50_000_000;

/// The frame time for a clip with these key times: one that lands on every key when keys
/// lie on a regular grid (so nothing is smoothed away and a clip we exported reads back
/// exactly), else 1/30 s.
pub(crate) fn clip_frame_time(times: &[f32]) -> f32 {
    let mut all: Vec<f32> = times.iter().copied().filter(|t| t.is_finite()).collect();
    all.sort_by(f32::total_cmp);
    all.dedup_by(|a, b| (*a - *b).abs() < 1e-6);
    let fallback = 1.0 / DEFAULT_FPS;
    if all.len() < 2 {
        return fallback;
    }
    let gap = all
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(f32::INFINITY, f32::min);
    if !(gap * MAX_KEY_FPS >= 0.999 && gap <= 10.0) {
        return fallback;
    }
    let t0 = all[0];
    let on_grid = all.iter().all(|&t| {
        let k = (t - t0) / gap;
        (k - k.round()).abs() < 0.01
    });
    if !on_grid {
        return fallback;
    }
    let mut rate = 1.0 / gap;
    if (rate - rate.round()).abs() < 1e-3 * rate {
        rate = rate.round();
    }
    if rate < MIN_KEY_FPS {
        rate *= (DEFAULT_FPS / rate).ceil();
    }
    1.0 / rate
}

fn read_clips(doc: &gltf::Document, rig: &Rig, reader: &AccessorReader) -> Result<Vec<Clip>> {
    let mut takes: Vec<(usize, String, Vec<Channel>)> = Vec::new();
    for anim in doc.animations() {
        let mut channels = Vec::new();
        for ch in anim.channels() {
            let target = ch.target();
            let Some(&joint) = rig.node_to_joint.get(&target.node().index()) else {
                continue;
            };
            let property = target.property();
            let width = match property {
                Property::Translation | Property::Scale => 3,
                Property::Rotation => 4,
                Property::MorphTargetWeights => continue,
            };
            let sampler = ch.sampler();
            let interpolation = sampler.interpolation();
            let (input, output) = (sampler.input(), sampler.output());
            reader.expect_dims(&input, &[Dimensions::Scalar], "animation input")?;
            let (times, _) = reader.floats(&input)?;
            let (values, comps) = reader.floats(&output)?;
            let place = || format!("accessor {}", output.index());
            if comps != width {
                return Err(format_err(
                    reader.path,
                    place(),
                    format!(
                        "animates {property:?} with {comps} components per key, expected {width}"
                    ),
                ));
            }
            let per_key = if interpolation == Interpolation::CubicSpline {
                3
            } else {
                1
            };
            if times.is_empty() || values.len() != times.len() * per_key * width {
                return Err(format_err(
                    reader.path,
                    place(),
                    format!(
                        "has {} values for {} keyframe times ({interpolation:?})",
                        values.len() / width,
                        times.len()
                    ),
                ));
            }
            if times.windows(2).any(|w| w[1] < w[0]) {
                return Err(format_err(
                    reader.path,
                    format!("accessor {}", input.index()),
                    "keyframe times decrease",
                ));
            }
            channels.push(Channel {
                joint,
                property,
                interpolation,
                times,
                values,
                width,
            });
        }
        if !channels.is_empty() {
            takes.push((
                anim.index(),
                anim.name().unwrap_or("").to_string(),
                channels,
            ));
        }
    }
    // Some exporters write one take as one unnamed animation per node (this data's
    // CesiumMan: 19 animations of 3 channels). Played alone, each moves one joint; the
    // unnamed ones are one clip when there are several and no two animate the same joint
    // property. Named animations stay clips of their own.
    let unnamed: Vec<usize> = (0..takes.len())
        .filter(|&k| takes[k].1.is_empty())
        .collect();
    let mut targets = std::collections::HashSet::new();
    let split_take = unnamed.len() > 1
        && unnamed
            .iter()
            .flat_map(|&k| takes[k].2.iter().map(|c| (c.joint, c.property as u8)))
            .all(|t| targets.insert(t));
    if split_take {
        let first = unnamed[0];
        let mut merged = Vec::new();
        for &k in unnamed.iter().rev() {
            if k != first {
                merged.extend(takes.remove(k).2);
            }
        }
        takes[first].2.extend(merged);
    }
    takes
        .into_iter()
        .map(|(index, name, channels)| sample_take(rig, reader, index, name, channels))
        .collect()
}

/// Samples one animation's channels at a regular frame time into a [`Clip`].
fn sample_take(
    rig: &Rig,
    reader: &AccessorReader,
    index: usize,
    name: String,
    channels: Vec<Channel>,
) -> Result<Clip> {
    let t0 = channels
        .iter()
        .map(|c| c.times[0])
        .fold(f32::INFINITY, f32::min);
    let t1 = channels
        .iter()
        .map(|c| c.times[c.times.len() - 1])
        .fold(f32::NEG_INFINITY, f32::max);
    let all_times: Vec<f32> = channels
        .iter()
        .flat_map(|c| c.times.iter().copied())
        .collect();
    let frame_time = clip_frame_time(&all_times);
    let steps = ((t1 - t0) / frame_time).round() as f64;
    let max_frames = MAX_CLIP_SAMPLES / rig.joints.len().max(1);
    if !(steps.is_finite() && steps < max_frames as f64) {
        return Err(format_err(
            reader.path,
            format!("animation {index}"),
            format!("runs from {t0} s to {t1} s, too long to sample"),
        ));
    }
    let n = steps as usize + 1;
    let mut frames = Vec::with_capacity(n);
    for f in 0..n {
        let t = if f + 1 == n {
            t1
        } else {
            (t0 as f64 + f as f64 * frame_time as f64) as f32
        };
        let mut trs = rig.node_rest.clone();
        for c in &channels {
            let v = c.sample(t);
            let x = &mut trs[c.joint];
            match c.property {
                Property::Translation => x.translation = Vec3::new(v[0], v[1], v[2]),
                Property::Scale => x.scale = Vec3::new(v[0], v[1], v[2]),
                Property::Rotation => x.rotation = Quat::from_array(v),
                Property::MorphTargetWeights => {}
            }
        }
        frames.push(
            trs.iter()
                .enumerate()
                .map(|(j, t)| rig.local(j, t))
                .collect(),
        );
    }
    Ok(Clip {
        name,
        frame_time,
        frames,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn channel(interpolation: Interpolation, values: Vec<f32>) -> Channel {
        Channel {
            joint: 0,
            property: Property::Translation,
            interpolation,
            times: vec![0.0, 1.0],
            values,
            width: 3,
        }
    }

    #[test]
    fn samplers_interpolate_as_the_spec_says() {
        let lin = channel(Interpolation::Linear, vec![0.0, 0.0, 0.0, 2.0, 4.0, 6.0]);
        assert_eq!(lin.sample(0.25)[..3], [0.5, 1.0, 1.5]);
        assert_eq!(lin.sample(-1.0)[..3], [0.0, 0.0, 0.0]);
        assert_eq!(lin.sample(9.0)[..3], [2.0, 4.0, 6.0]);
        let step = channel(Interpolation::Step, vec![0.0, 0.0, 0.0, 2.0, 4.0, 6.0]);
        assert_eq!(step.sample(0.99)[..3], [0.0, 0.0, 0.0]);
        // Zero tangents: a smoothstep from 0 to 1, 0.5 at the middle, eased at the ends.
        let mut v = vec![0.0; 18];
        v[9 + 3] = 1.0; // key 1 value x
        let cubic = channel(Interpolation::CubicSpline, v);
        assert!((cubic.sample(0.5)[0] - 0.5).abs() < 1e-6);
        assert!((cubic.sample(0.25)[0] - 0.15625).abs() < 1e-6);
    }

    #[test]
    fn rotations_slerp_and_stay_unit() {
        let c = Channel {
            joint: 0,
            property: Property::Rotation,
            interpolation: Interpolation::Linear,
            times: vec![0.0, 2.0],
            values: [
                Quat::IDENTITY.to_array(),
                Quat::from_rotation_y(1.0).to_array(),
            ]
            .concat(),
            width: 4,
        };
        let q = Quat::from_array(c.sample(1.0));
        assert!((q.length() - 1.0).abs() < 1e-6);
        assert!(q.abs_diff_eq(Quat::from_rotation_y(0.5), 1e-6));
    }

    #[test]
    fn frame_time_follows_regular_keys() {
        let keys: Vec<f32> = (0..10).map(|i| i as f32 / 24.0).collect();
        assert_eq!(clip_frame_time(&keys), 1.0 / 24.0);
        assert_eq!(clip_frame_time(&[0.0, 0.1, 0.35]), 1.0 / 30.0);
        assert_eq!(clip_frame_time(&[0.5]), 1.0 / 30.0);
        let sparse: Vec<f32> = (0..5).map(|i| i as f32 * 0.5).collect();
        assert_eq!(clip_frame_time(&sparse), 1.0 / 30.0);
        let ten: Vec<f32> = (0..5).map(|i| i as f32 * 0.1).collect();
        assert_eq!(clip_frame_time(&ten), 1.0 / 30.0);
        let sixty: Vec<f32> = (0..5).map(|i| i as f32 / 60.0).collect();
        assert_eq!(clip_frame_time(&sixty), 1.0 / 60.0);
    }
}
