//! glTF 2.0 import (.glb, .vrm, and .gltf with `data:` URIs or external buffers).
//!
//! Choices, and why:
//! - **VRM** avatars are GLB files; their humanoid bone table (VRM 0.x or 1.0) becomes
//!   [`Character::humanoid_bones`] (see `vrm.rs`): the file's own word on which joint is
//!   the hips or the left hand. A file with a table but no skin (a bare node hierarchy,
//!   perhaps with rigid meshes on its nodes) gets its skeleton from that hierarchy
//!   (`rigid.rs`).
//! - **Units**: glTF says metres, but files exported in centimetres are common (the Fox
//!   sample is 79 m tall read as metres). [`ImportOptions::units`] reads the numbers in
//!   another unit and [`ImportOptions::height_m`] scales to a height; the scale goes into
//!   the root joints so the exporter still writes the file's own units (`super::size`).
//! - **Skeleton** = the joints of one skin. When a file has several skins, the one whose
//!   meshes have the most vertices wins (ties: the first), joined by every skin that shares
//!   a joint with it or hangs below its joints: exporters often write one skin per mesh,
//!   each listing only the bones its mesh uses. A skin joined to none (a prop or a second
//!   character) is written back as it came but not read.
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
//! - **Meshes**: one [`SkinnedMesh`](crate::skeleton::SkinnedMesh) per triangle primitive
//!   of every mesh instanced with those skins, and of every mesh without a skin on a joint
//!   node or below one (rigid parts parented to bones: a robot's head, a helmet), bound
//!   with weight 1 to that joint, so it sizes the joint's body and is drawn moving with it.
//!   Points, lines, strips and fans are skipped (no ragdoll needs them).
//!   Morph targets are ignored. Up to four influences are kept per vertex (the strongest,
//!   renormalised to sum 1). Bad weights are repaired with a warning, not refused (see
//!   `mesh::read_influences`), and so are missing image files (`data::missing_images`).
//! - **No skin, rigid parts**: when the meshes sit on nodes of a hierarchy (a robot whose
//!   parts are separate meshes on nested nodes), or a VRM table names the nodes, the node
//!   hierarchy is the skeleton and each part is bound rigidly to its node (`rigid.rs` has
//!   the exact rule). The file is written back as it came, its nodes animated.
//! - **No skin, one part**: a file with triangle meshes but no skin and no such hierarchy
//!   (a scanned or modelled prop) is rigged like an OBJ ([`crate::rig`]): every triangle
//!   primitive of every node in the default scene (or of every node, when there is no
//!   scene) in world space. Its source is then [`Source::Mesh`] (a fresh glTF is written on
//!   export; materials are not kept).
//! - **Clips**: one per animation that moves at least one joint (animations of other nodes
//!   only are skipped; a rigid-part character's joints are its nodes), sampled from its first to its last key at the key spacing when the
//!   keys are regular, else at 30 fps. `CUBICSPLINE` is evaluated as the cubic Hermite
//!   spline it is (better than the key values alone, and just as cheap). Joints without a
//!   channel keep their rest; channels on non-joint nodes are ignored.
//! - **Hostile files**: every index is checked before anything indexes with it (the `gltf`
//!   crate's validation, after our own checks of what that validation itself would index
//!   unchecked); external buffers are read from the file's folder only
//!   ([`crate::files::read_inside`]); nothing recurses on the node tree. Memory is bounded
//!   by [`MAX_JSON_VALUES`], [`MAX_JSON_OBJECTS`], [`MAX_BUFFER_BYTES`],
//!   [`MAX_ACCESSOR_COMPONENTS`], [`MAX_INFLUENCE_SETS`] and
//!   [`crate::skeleton::MAX_CLIP_POSES`]; a file past one is refused, naming where.

mod clips;
mod data;
mod mesh;
mod repair;
mod rigid;
mod skin;
mod vrm;

use std::path::{Path, PathBuf};

use gltf::mesh::Semantic;

use clips::read_clips;
use data::ReadBudget;
pub(crate) use data::{AccessorReader, decode_data_uri, format_err, read_external};
pub use data::{MAX_ACCESSOR_COMPONENTS, MAX_BUFFER_BYTES, MAX_JSON_OBJECTS, MAX_JSON_VALUES};
use mesh::Reads;
pub use mesh::{MAX_INFLUENCE_SETS, WEIGHT_SUM_TOLERANCE};
pub(crate) use mesh::{SkinSlots, read_influences};
use mesh::{read_meshes, read_unskinned, scene_nodes};
use skin::{NodeGraph, Rig, attached_skins, choose_skin};

pub use repair::ACCEPTED_REQUIRED_EXTENSIONS;
pub(crate) use repair::{drop_images, repair_json};
use repair::{refuse_unreadable, repair_source};

use super::{ImportOptions, size};
use crate::error::Result;
use crate::rig::RigOptions;
use crate::skeleton::{Character, Skeleton, Source};

pub use crate::skeleton::source::GltfSource;

/// Loads a glTF 2.0 file (.glb, or .gltf with `data:` URIs or external buffers).
pub fn load(path: &Path) -> Result<Character> {
    load_rigged(path, &RigOptions::default())
}

/// [`load`], rigging a file without a skin with `rig`.
pub fn load_rigged(path: &Path, rig: &RigOptions) -> Result<Character> {
    load_with(path, &ImportOptions::default(), rig)
}

/// [`load_rigged`], the file's numbers read in `opts.units` and the character scaled to
/// `opts.height_m` when given (`up` and `clip` are not this function's: glTF is Y up, and
/// [`super::load`] chooses the clip).
pub fn load_with(path: &Path, opts: &ImportOptions, rig: &RigOptions) -> Result<Character> {
    let bytes = crate::files::read_capped(path, crate::files::MAX_INPUT_BYTES)?;
    from_bytes_with(&bytes, path, opts, rig)
}

/// Loads a glTF 2.0 file already in memory; `path` names it in errors and anchors its
/// relative URIs (external buffers), as if the bytes had been read from there.
///
/// This is the entry point for fuzzing: any bytes give a [`Character`] or an error, never
/// a panic, and memory stays within the limits above ([`MAX_JSON_VALUES`],
/// [`MAX_JSON_OBJECTS`],
/// [`MAX_BUFFER_BYTES`], [`MAX_ACCESSOR_COMPONENTS`], [`crate::skeleton::MAX_CLIP_POSES`]).
/// Give it a `path` in a folder with nothing in it to keep external URIs from reading files.
pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Character> {
    from_bytes_rigged(bytes, path, &RigOptions::default())
}

/// [`from_bytes`], rigging a file without a skin with `rig`.
pub fn from_bytes_rigged(bytes: &[u8], path: &Path, rig: &RigOptions) -> Result<Character> {
    from_bytes_with(bytes, path, &ImportOptions::default(), rig)
}

/// [`from_bytes_rigged`] with the units and height of [`load_with`].
pub fn from_bytes_with(
    bytes: &[u8],
    path: &Path,
    opts: &ImportOptions,
    rig: &RigOptions,
) -> Result<Character> {
    let units = opts.units.map_or(1.0, |u| u.to_metres());
    let container = data::split_container(bytes, path)?;
    let mut json = read_json(&container, path)?;
    refuse_unreadable(&json, path)?;
    // Embedded buffers are decoded before anything copies the document's text.
    let lifted = data::lift_data_buffers(&mut json, data::MAX_BUFFER_BYTES)
        .map_err(|(i, message)| format_err(path, format!("buffer {i}"), message))?;
    let doc = parse_document(&json, path)?;
    let dir = path
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("."));
    let mut buffers = data::resolve_buffers(&doc, container.bin, lifted, &dir, path)?;
    let (json, doc, repairs) = repair_source(json, doc, &mut buffers, path)?;
    let reader = Reads {
        reader: AccessorReader {
            buffers: &buffers,
            path,
        },
        budget: ReadBudget::new(),
    };
    let graph = NodeGraph::new(&doc, path)?;
    let table = vrm::read_table(&json, doc.nodes().len(), path)?;
    let no_skin = doc.skins().len() == 0;
    let (skin_index, rig, meshes, mut warnings) = if no_skin {
        let in_scene = scene_nodes(&doc);
        let table_nodes = table.as_ref().map(vrm::Table::nodes);
        let Some(nodes) =
            rigid::part_nodes(&doc, &graph, in_scene.as_ref(), table_nodes.as_deref())
        else {
            return rig_unskinned(&doc, &graph, &reader, opts, rig, path);
        };
        let rig = Rig::from_nodes(&doc, nodes, &graph);
        let meshes = rigid::read_parts(&doc, &rig, &graph, in_scene.as_ref(), &reader)?;
        (0, rig, meshes, Vec::new())
    } else {
        let skin_index = choose_skin(&doc, path)?;
        let skin = doc
            .skins()
            .nth(skin_index)
            .ok_or_else(|| format_err(path, "skins", "skin index out of range"))?;
        let attached = attached_skins(&doc, &graph, skin_index);
        let rig = Rig::new(&doc, &skin, &attached, &graph, path)?;
        let (mut meshes, warnings) = read_meshes(&doc, &attached, &rig, &graph, &reader)?;
        meshes.extend(rigid::read_parts(
            &doc,
            &rig,
            &graph,
            scene_nodes(&doc).as_ref(),
            &reader,
        )?);
        (skin_index, rig, meshes, warnings)
    };
    let skeleton = Skeleton::new(rig.joints.clone())?;
    warnings.extend(repairs);
    warnings.extend(data::missing_images(&json, &dir));
    let clips = read_clips(&doc, &rig, &skeleton, &reader)?;
    let (humanoid_bones, table_warnings) = match table {
        Some(t) => t.to_joints(&rig.node_to_joint, path),
        None => (Vec::new(), Vec::new()),
    };
    warnings.extend(table_warnings);
    let mut character = Character {
        humanoid_bones,
        warnings,
        name: file_stem(path),
        skeleton,
        meshes,
        clips,
        source: Source::Gltf(std::sync::Arc::new(GltfSource {
            path: path.to_path_buf(),
            dir,
            json,
            buffers,
            skin: skin_index,
            joint_nodes: rig.nodes,
            parent_offsets: rig.offsets,
        })),
    };
    size::scale(&mut character, units, path)?;
    if let Some(h) = opts.height_m {
        size::scale_to_height(&mut character, h, path)?;
    }
    Ok(character)
}

/// The glTF's JSON (the whole `.gltf`, or a `.glb`'s JSON chunk), its errors placed by
/// line and column.
fn read_json(container: &data::Container, path: &Path) -> Result<serde_json::Value> {
    data::check_json_size(container.json, path)?;
    serde_json::from_slice(container.json).map_err(|e| {
        let place = if container.json_offset > 0 {
            format!("JSON chunk line {}, column {}", e.line(), e.column())
        } else {
            format!("line {}, column {}", e.line(), e.column())
        };
        format_err(path, place, format!("not valid JSON: {e}"))
    })
}

/// A file without a skin whose meshes are one part: every triangle primitive in world
/// space, rigged automatically like an OBJ.
fn rig_unskinned(
    doc: &gltf::Document,
    graph: &NodeGraph,
    reader: &Reads,
    opts: &ImportOptions,
    rig: &RigOptions,
    path: &Path,
) -> Result<Character> {
    let units = opts.units.map_or(1.0, |u| u.to_metres());
    let mut meshes = read_unskinned(doc, graph, reader)?;
    if meshes.is_empty() {
        return Err(format_err(
            path,
            "skins",
            "has no skin and no triangle mesh: nothing to build a ragdoll from",
        ));
    }
    for p in meshes.iter_mut().flat_map(|m| &mut m.positions) {
        *p *= units;
    }
    size::scale_meshes_to_height(&mut meshes, opts.height_m, path)?;
    super::obj::rigged_character(file_stem(path), meshes, rig, path)
}

fn file_stem(path: &Path) -> String {
    path.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// Checks the JSON against the glTF schema (types, required fields, index ranges) so that
/// the typed accessors of [`gltf::Document`] can be used without panicking.
///
/// The check runs on a copy trimmed to what we read (nodes, meshes, skins, animations,
/// accessors, buffers; no `extras` anywhere), because the `gltf` crate, built without its
/// extension features, refuses things a ragdoll does not care about: any
/// `extensionsRequired` entry (even `KHR_texture_transform`), textures without a core
/// `source` (KTX2, WebP), `extras` that are not objects, and application-specific vertex
/// attributes such as `_BATCHID`. Materials and images are
/// passed through untouched by the exporter. The crate also leaves animation channel
/// targets unchecked although its typed accessors panic on a bad one, and its own
/// validation indexes the accessors with each primitive's `POSITION` before checking it
/// (gltf-json 1.4 `mesh.rs`, the most frequent crash our fuzzing found), so those are
/// checked here first. Every other index is checked by the crate's validation, which runs
/// before any code here indexes anything.
pub(crate) fn parse_document(json: &serde_json::Value, path: &Path) -> Result<gltf::Document> {
    let root: gltf::json::Root = gltf::json::deserialize::from_value(trimmed(json))
        .map_err(|e| format_err(path, "JSON", format!("not a glTF 2.0 document: {e}")))?;
    check_positions(&root, path)?;
    check_channel_targets(&root, path)?;
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

/// A copy of the document without what the `gltf` crate would refuse and a ragdoll does
/// not read (see [`parse_document`]).
fn trimmed(json: &serde_json::Value) -> serde_json::Value {
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
    // `extras` hold application data of any JSON type; the crate, built without its
    // `extras` feature, only accepts objects there and refused valid files with an array.
    // A stack, not recursion (serde_json already caps nesting at 128).
    let mut stack = vec![&mut json];
    while let Some(v) = stack.pop() {
        match v {
            serde_json::Value::Object(o) => {
                o.remove("extras");
                stack.extend(o.values_mut());
            }
            serde_json::Value::Array(a) => stack.extend(a.iter_mut()),
            _ => {}
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
    json
}

/// Every primitive's `POSITION` names an accessor that exists: the crate's validation
/// indexes the accessors with it before checking it.
fn check_positions(root: &gltf::json::Root, path: &Path) -> Result<()> {
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            let position = gltf::json::validation::Checked::Valid(Semantic::Positions);
            if let Some(a) = prim.attributes.get(&position)
                && a.value() >= root.accessors.len()
            {
                return Err(format_err(
                    path,
                    format!("meshes[{m}].primitives[{p}].attributes.POSITION"),
                    format!("accessor {} does not exist", a.value()),
                ));
            }
        }
    }
    Ok(())
}

/// Every animation channel targets a node that exists along a known path: the crate
/// leaves these unchecked although its typed accessors panic on a bad one.
fn check_channel_targets(root: &gltf::json::Root, path: &Path) -> Result<()> {
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
    Ok(())
}
