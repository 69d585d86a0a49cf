//! glTF (.glb) export: the baked [`Track`] as a new animation named `ragdoll`.
//!
//! - **glTF input**: the file is written back as it came (meshes, skins, materials,
//!   textures, images, samplers, scenes, extensions and the old animations, which follow
//!   the new one) so an artist gets their own asset back, plus the new animation as
//!   `animations[0]`, where viewers look first. Everything goes into one GLB: the input's
//!   buffers are merged into the binary chunk and external or `data:` images become buffer
//!   views. Skin weights are renormalised to sum 1 (CesiumMan's do not, which the Khronos
//!   validator counts as errors), joint indices with zero weight are set to 0, and joint
//!   nodes given as a `matrix` are rewritten as TRS (animated nodes must not use `matrix`);
//!   normals off unit length are rescaled (the validator counts each as an error).
//!   A glTF with no mesh at all (a bare VRM humanoid hierarchy) also gets the ragdoll's
//!   bodies, drawn as for a BVH below and skinned to its joint nodes, so it is seen moving.
//! - **BVH or built-in input** (no mesh): a fresh glTF with one node per joint, a skin, and
//!   the ragdoll's bodies drawn as their capsules and boxes, each bound rigidly to its own
//!   bone (so they never bend or stretch), so the motion is visible in any viewer.
//! - **A rigged mesh** ([`Source::Mesh`]: an OBJ, a glTF that had no skin): a fresh glTF as
//!   above with the character's own mesh and automatic skin instead of the bodies.
//!   [`rig_to_glb`] writes it with no animation, in the rest pose.
//!
//! - **Several characters** ([`scene_to_glb`], for scene files): each character's document
//!   as above, merged into one file with every index renumbered, and their tracks as the
//!   channels of one `ragdoll` animation.
//!
//! The output is meant to pass the Khronos glTF validator with no errors, whatever errors
//! the input had; the tests and `.ci/gltf_validate.mjs` check that. Input defects that
//! would be carried into the output (a skin `skeleton` that is no common root, dangling
//! material references, undeclared extensions, non-unit rotations, keyframe times that do
//! not rise…) are mended at import with a warning each, and what a loader must not read
//! (another glTF major version, a required extension outside
//! [`ACCEPTED_REQUIRED_EXTENSIONS`](crate::import::gltf::ACCEPTED_REQUIRED_EXTENSIONS)) is
//! refused there (`import/gltf/repair.rs`).

mod bare;
mod bin;
mod images;
mod merge;
mod normals;
mod shapes;
mod weights;

use glam::{Mat4, Quat, Vec3};
use rayon::prelude::*;
use serde_json::{Map, Value, json};

use crate::error::{Error, Result};
use crate::import::gltf::{GltfSource, format_err, parse_document};
use crate::math::Transform;
use crate::skeleton::{Character, Skeleton, Source};
use crate::spec::RagdollSpec;
use crate::track::Track;
use bin::{Bin, components, f32_bytes, merged_buffers, pad_to_4, take_array};
use weights::renormalise_weights;

/// Name of the animation the exporter adds.
pub const ANIMATION_NAME: &str = "ragdoll";

const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;
const UNSIGNED_BYTE: u32 = 5121;
const UNSIGNED_SHORT: u32 = 5123;
const UNSIGNED_INT: u32 = 5125;
const FLOAT: u32 = 5126;

/// Writes `track` as a binary glTF (.glb) and returns its bytes (the caller writes the file,
/// atomically).
///
/// For a glTF character the input is kept and the track added as the animation `ragdoll`;
/// `spec` is only used for characters without a mesh, whose bodies it draws.
pub fn to_glb(character: &Character, spec: &RagdollSpec, track: &Track) -> Result<Vec<u8>> {
    let (root, bin) = document(character, spec, track)?;
    glb(&root, &bin)
}

/// Writes a character's skeleton and skinned meshes in the rest pose, with no animation:
/// what `ragdoll rig` hands to a modeller or back to `ragdoll simulate`.
///
/// Fails when the character has no mesh (a BVH or the built-in humanoid: use [`to_glb`]).
///
/// # Example
///
/// ```
/// use glam::Vec3;
/// use ragdoll::{export::gltf::rig_to_glb, rig, skeleton::{Character, SkinnedMesh, Source}};
///
/// let positions = vec![Vec3::ZERO, Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 0.2, 0.0), Vec3::new(0.0, 0.2, 0.1)];
/// let mut meshes = vec![SkinnedMesh { positions, indices: vec![0, 1, 2, 0, 2, 3], ..Default::default() }];
/// let skeleton = rig::rig(&mut meshes, &rig::RigOptions { joints: 3, ..Default::default() }).unwrap();
/// let character = Character { name: "strip".into(), skeleton, meshes, clips: vec![], humanoid_bones: vec![], warnings: vec![], source: Source::Mesh("strip.obj".into()) };
/// let glb = rig_to_glb(&character).unwrap();
/// assert_eq!(&glb[..4], b"glTF");
/// ```
pub fn rig_to_glb(character: &Character) -> Result<Vec<u8>> {
    if character.meshes.is_empty() {
        return Err(track_err(format!(
            "character {:?} has no mesh to write with its rig",
            character.name
        )));
    }
    let (root, bin) = fresh(character, None, None)?;
    glb(&root, &bin)
}

/// Writes several characters, each with its own track, into one binary glTF (a scene).
///
/// Every character keeps what [`to_glb`] would give it alone (its own nodes, skin and
/// meshes; a glTF character its materials, textures and old animations; a BVH or built-in
/// one its body capsules), side by side in one glTF scene. Their tracks become the channels
/// of a single animation named `ragdoll`, so a viewer plays all of them together rather
/// than one character at a time.
pub fn scene_to_glb(characters: &[(&Character, &RagdollSpec, &Track)]) -> Result<Vec<u8>> {
    if characters.is_empty() {
        return Err(track_err(
            "a scene needs at least one character to export".into(),
        ));
    }
    // Each character's document on its own, in parallel (a crowd's thousand documents
    // are most of the encoding); the first error in character order is the one reported.
    let docs: Vec<Result<_>> = characters
        .par_iter()
        .map(|(character, spec, track)| document(character, spec, track))
        .collect();
    let docs = docs.into_iter().collect::<Result<Vec<_>>>()?;
    let (root, bin) = merge::merge(docs)?;
    glb(&root, &bin)
}

/// One character's glTF document and its binary chunk, before packing: what [`to_glb`]
/// packs alone and [`scene_to_glb`] merges with others.
fn document(character: &Character, spec: &RagdollSpec, track: &Track) -> Result<(Value, Vec<u8>)> {
    check_track(&character.skeleton, track)?;
    match &character.source {
        Source::Gltf(src) => from_source(character, spec, src, track),
        Source::BuiltIn | Source::Bvh(_) | Source::Mesh(_) => {
            fresh(character, Some(spec), Some(track))
        }
    }
}

fn track_err(message: String) -> Error {
    Error::Setting {
        setting: "track".into(),
        message,
    }
}

fn check_track(skeleton: &Skeleton, track: &Track) -> Result<()> {
    if !(track.fps.is_finite() && track.fps > 0.0) {
        return Err(track_err(format!(
            "frame rate {} is not a positive number",
            track.fps
        )));
    }
    if track.frames.is_empty() {
        return Err(track_err("has no frames to export".into()));
    }
    for (f, frame) in track.frames.iter().enumerate() {
        if frame.len() != skeleton.len() {
            return Err(track_err(format!(
                "frame {f} has {} joints but the skeleton has {}",
                frame.len(),
                skeleton.len()
            )));
        }
        if let Some(j) = frame.iter().position(|t| !t.is_finite()) {
            return Err(track_err(format!(
                "frame {f}: joint {} has a non-finite transform",
                skeleton.joint_label(j)
            )));
        }
    }
    Ok(())
}

/// Joint node local transforms per frame, and the `ragdoll` animation that plays them.
///
/// `offsets[j]` is the static transform between joint `j`'s parent joint (or the world) and
/// its node's parent; `node_scales[j]` the node's own scale, so a scale channel is only
/// written when the track actually changes it.
fn ragdoll_animation(
    bin: &mut Bin,
    skeleton: &Skeleton,
    nodes: &[usize],
    offsets: &[Transform],
    node_scales: &[Vec3],
    track: &Track,
) -> Result<Value> {
    let nj = skeleton.len();
    let nf = track.frames.len();
    let mut trans = vec![Vec::with_capacity(nf * 3); nj];
    let mut rots = vec![Vec::with_capacity(nf * 4); nj];
    let mut scales = vec![Vec::with_capacity(nf * 3); nj];
    let mut prev = vec![Quat::IDENTITY; nj];
    for (f, frame) in track.frames.iter().enumerate() {
        for j in 0..nj {
            let parent = match skeleton.parent(j) {
                Some(p) => frame[p],
                None => Transform::IDENTITY,
            };
            let parent = if offsets[j] == Transform::IDENTITY {
                parent
            } else {
                parent.mul(&offsets[j])
            };
            let local = parent.inverse().mul(&frame[j]);
            if !local.is_finite() {
                return Err(track_err(format!(
                    "frame {f}: joint {} has no finite local transform (a zero scale?)",
                    skeleton.joint_label(j)
                )));
            }
            let mut q = local.rotation.normalize();
            // Keep consecutive keys in the same hemisphere so LINEAR playback takes the
            // short way round.
            if f > 0 && prev[j].dot(q) < 0.0 {
                q = -q;
            }
            prev[j] = q;
            trans[j].extend(local.translation.to_array());
            rots[j].extend(q.to_array());
            scales[j].extend(local.scale.to_array());
        }
    }
    let times: Vec<f32> = (0..nf).map(|f| f as f32 / track.fps).collect();
    let mut bytes = f32_bytes(times.iter().copied());
    let accessor = |bytes: &mut Vec<u8>, data: &[f32], kind: &str| {
        let offset = bytes.len();
        bytes.extend(f32_bytes(data.iter().copied()));
        (offset, data.len() / components(kind), kind.to_string())
    };
    let mut layout = Vec::new();
    let mut channels = Vec::new();
    for j in 0..nj {
        layout.push(accessor(&mut bytes, &trans[j], "VEC3"));
        channels.push((nodes[j], "translation"));
        layout.push(accessor(&mut bytes, &rots[j], "VEC4"));
        channels.push((nodes[j], "rotation"));
        let moves_scale = scales[j]
            .chunks_exact(3)
            .any(|s| (Vec3::from_slice(s) - node_scales[j]).abs().max_element() > 1e-4);
        if moves_scale {
            layout.push(accessor(&mut bytes, &scales[j], "VEC3"));
            channels.push((nodes[j], "scale"));
        }
    }
    let view = bin.push_view(&bytes, None);
    let input = bin.push_accessor(json!({
        "bufferView": view,
        "componentType": FLOAT,
        "count": nf,
        "type": "SCALAR",
        "min": [times[0]],
        "max": [times[nf - 1]],
    }));
    let mut samplers = Vec::new();
    let mut chans = Vec::new();
    for (k, ((offset, count, kind), (node, path))) in layout.into_iter().zip(channels).enumerate() {
        let output = bin.push_accessor(json!({
            "bufferView": view,
            "byteOffset": offset,
            "componentType": FLOAT,
            "count": count,
            "type": kind,
        }));
        samplers.push(json!({"input": input, "output": output, "interpolation": "LINEAR"}));
        chans.push(json!({"sampler": k, "target": {"node": node, "path": path}}));
    }
    Ok(json!({"name": ANIMATION_NAME, "channels": chans, "samplers": samplers}))
}

fn glb(json: &Value, bin: &[u8]) -> Result<Vec<u8>> {
    let mut j = serde_json::to_vec(json).expect("a JSON value always serialises");
    pad_to_4(&mut j, b' ');
    let mut b = bin.to_vec();
    pad_to_4(&mut b, 0);
    let total = 12 + 8 + j.len() + 8 + b.len();
    if total > u32::MAX as usize {
        return Err(track_err(format!(
            "the glTF would take {total} bytes, more than a GLB can hold (4 GiB)"
        )));
    }
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(j.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&j);
    out.extend_from_slice(&(b.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&b);
    Ok(out)
}

fn generator() -> String {
    format!("ragdoll {}", env!("CARGO_PKG_VERSION"))
}

/// The input glTF with the track as a new first animation.
fn from_source(
    character: &Character,
    spec: &RagdollSpec,
    src: &GltfSource,
    track: &Track,
) -> Result<(Value, Vec<u8>)> {
    let path = src.path.as_path();
    let skeleton = &character.skeleton;
    if src.joint_nodes.len() != skeleton.len() || src.parent_offsets.len() != skeleton.len() {
        return Err(format_err(
            path,
            format!("skin {}", src.skin),
            format!(
                "the source records {} joint nodes for a skeleton of {} joints",
                src.joint_nodes.len(),
                skeleton.len()
            ),
        ));
    }
    let doc = parse_document(&src.json, path)?;
    if src.buffers.len() != doc.buffers().len() {
        return Err(format_err(
            path,
            "buffers",
            "the resolved buffers do not match the document",
        ));
    }
    let mut root = src.json.clone();
    // The importer mended the source and warned; this keeps any source valid on the way out.
    crate::import::gltf::repair_json(&mut root);
    let Some(obj) = root.as_object_mut() else {
        return Err(format_err(
            path,
            "JSON",
            "the document is not a JSON object",
        ));
    };
    let mut bin = merged_buffers(obj, src)?;
    bin.accessors = take_array(obj, "accessors");
    images::embed_images(obj, &mut bin, src)?;
    renormalise_weights(obj, &doc, &mut bin, src)?;
    normals::renormalise_normals(obj, &doc, &mut bin, src)?;
    let node_scales = joint_nodes_as_trs(obj, &src.joint_nodes, path)?;
    let animation = ragdoll_animation(
        &mut bin,
        skeleton,
        &src.joint_nodes,
        &src.parent_offsets,
        &node_scales,
        track,
    )?;
    let mut animations = take_array(obj, "animations");
    animations.insert(0, animation);
    obj.insert("animations".into(), Value::Array(animations));
    if character.meshes.is_empty() {
        bare::add_bodies(obj, &mut bin, character, spec, &src.joint_nodes)?;
    }
    obj.insert(
        "bufferViews".into(),
        Value::Array(std::mem::take(&mut bin.views)),
    );
    obj.insert(
        "accessors".into(),
        Value::Array(std::mem::take(&mut bin.accessors)),
    );
    obj.insert("buffers".into(), json!([{"byteLength": bin.data.len()}]));
    let asset = obj
        .entry("asset")
        .or_insert_with(|| json!({"version": "2.0"}));
    if let Some(a) = asset.as_object_mut() {
        a.insert("generator".into(), json!(generator()));
    }
    Ok((root, bin.data))
}

/// Rewrites joint nodes given by `matrix` as TRS (glTF forbids animating a `matrix` node)
/// and returns each joint node's scale.
fn joint_nodes_as_trs(
    obj: &mut Map<String, Value>,
    joint_nodes: &[usize],
    path: &std::path::Path,
) -> Result<Vec<Vec3>> {
    let Some(Value::Array(nodes)) = obj.get_mut("nodes") else {
        return Err(format_err(path, "nodes", "the file has no nodes"));
    };
    let mut scales = Vec::with_capacity(joint_nodes.len());
    for &n in joint_nodes {
        let Some(node) = nodes.get_mut(n).and_then(Value::as_object_mut) else {
            return Err(format_err(path, format!("node {n}"), "does not exist"));
        };
        if let Some(m) = node.remove("matrix") {
            let cols: Vec<f32> = m
                .as_array()
                .map(|a| {
                    a.iter()
                        .filter_map(Value::as_f64)
                        .map(|x| x as f32)
                        .collect()
                })
                .unwrap_or_default();
            if cols.len() != 16 {
                return Err(format_err(
                    path,
                    format!("node {n}"),
                    "matrix must have 16 numbers",
                ));
            }
            let t = Transform::from_mat4(Mat4::from_cols_slice(&cols));
            node.insert("translation".into(), json!(t.translation.to_array()));
            node.insert("rotation".into(), json!(t.rotation.to_array()));
            node.insert("scale".into(), json!(t.scale.to_array()));
        }
        let scale = node
            .get("scale")
            .and_then(Value::as_array)
            .map(|a| {
                a.iter()
                    .filter_map(Value::as_f64)
                    .map(|x| x as f32)
                    .collect::<Vec<_>>()
            })
            .filter(|v| v.len() == 3)
            .map_or(Vec3::ONE, |v| Vec3::from_slice(&v));
        scales.push(scale);
    }
    Ok(scales)
}

/// One glTF node per joint (its rest transform, only what differs from the identity),
/// children listed under their parents, and the roots.
fn joint_nodes_of(skeleton: &Skeleton) -> (Vec<Value>, Vec<usize>) {
    let mut nodes: Vec<Value> = skeleton
        .joints()
        .iter()
        .enumerate()
        .map(|(i, j)| {
            let mut node = json!({"name": skeleton.joint_label(i)});
            let r = j.rest;
            if r.translation != Vec3::ZERO {
                node["translation"] = json!(r.translation.to_array());
            }
            if r.rotation != Quat::IDENTITY {
                node["rotation"] = json!(r.rotation.normalize().to_array());
            }
            if r.scale != Vec3::ONE {
                node["scale"] = json!(r.scale.to_array());
            }
            node
        })
        .collect();
    let mut roots = Vec::new();
    for i in 0..skeleton.len() {
        match skeleton.parent(i) {
            Some(p) => match nodes[p].get_mut("children").and_then(Value::as_array_mut) {
                Some(c) => c.push(json!(i)),
                None => nodes[p]["children"] = json!([i]),
            },
            None => roots.push(i),
        }
    }
    (nodes, roots)
}

/// A new glTF for a character without a source glTF: joints, skin, a mesh (the
/// character's own, else `spec`'s bodies) and, given a track, its animation.
fn fresh(
    character: &Character,
    spec: Option<&RagdollSpec>,
    track: Option<&Track>,
) -> Result<(Value, Vec<u8>)> {
    let skeleton = &character.skeleton;
    let n = skeleton.len();
    let (mesh, mesh_name) = match spec {
        _ if !character.meshes.is_empty() => {
            (shapes::character_mesh(character), character.name.clone())
        }
        Some(spec) => {
            spec.validate()?;
            (
                shapes::bodies_mesh(skeleton, spec)?,
                format!("{} ragdoll bodies", character.name),
            )
        }
        None => {
            return Err(track_err(format!(
                "character {:?} has neither a mesh nor a ragdoll spec to draw",
                character.name
            )));
        }
    };
    let mut bin = Bin::default();
    let (mut nodes, roots) = joint_nodes_of(skeleton);
    let ibm = shapes::inverse_bind_matrices(&mut bin, skeleton);
    let primitive = shapes::primitive(&mut bin, &mesh, n, 0);
    let mesh_node = nodes.len();
    nodes.push(json!({"name": mesh_name, "mesh": 0, "skin": 0}));
    let joint_nodes: Vec<usize> = (0..n).collect();
    let node_scales: Vec<Vec3> = skeleton.joints().iter().map(|j| j.rest.scale).collect();
    let animation = match track {
        Some(track) => Some(ragdoll_animation(
            &mut bin,
            skeleton,
            &joint_nodes,
            &vec![Transform::IDENTITY; n],
            &node_scales,
            track,
        )?),
        None => None,
    };
    let mut skin =
        json!({"name": character.name, "joints": joint_nodes, "inverseBindMatrices": ibm});
    if let [root] = roots[..] {
        skin["skeleton"] = json!(root);
    }
    let mut scene_nodes = roots.clone();
    scene_nodes.push(mesh_node);
    let mut root = json!({
        "asset": {"version": "2.0", "generator": generator()},
        "scene": 0,
        "scenes": [{"name": character.name, "nodes": scene_nodes}],
        "nodes": nodes,
        "skins": [skin],
        "meshes": [{
            "name": mesh_name,
            "primitives": [primitive],
        }],
        "materials": [shapes::material()],
        "accessors": bin.accessors,
        "bufferViews": bin.views,
        "buffers": [{"byteLength": bin.data.len()}],
    });
    if let Some(a) = animation {
        root["animations"] = json!([a]);
    }
    Ok((root, bin.data))
}
