//! A glTF input with no mesh at all (a bare VRM humanoid hierarchy: nodes and a bone table)
//! would bake as animated empty nodes, which no viewer shows. The ragdoll's bodies are drawn
//! into it as for a BVH: capsules and boxes bound rigidly to their joints' nodes, as a new
//! mesh, material and skin on a node at the scene root (the Khronos validator warns about a
//! skinned mesh anywhere else; a skinned mesh ignores its node's transform anyway).

use serde_json::{Map, Value, json};

use super::{Bin, merge, shapes, take_array};
use crate::error::Result;
use crate::skeleton::Character;
use crate::spec::RagdollSpec;

/// Appends `spec`'s bodies to `obj`, skinned to `joint_nodes` (the node of each skeleton
/// joint). The inverse bind matrices are the skeleton's rest pose, not the nodes' own:
/// the `ragdoll` animation drives every joint node to the track's world transforms, which
/// start from that pose (also when `--units` scaled the skeleton away from the file).
pub(super) fn add_bodies(
    obj: &mut Map<String, Value>,
    bin: &mut Bin,
    character: &Character,
    spec: &RagdollSpec,
    joint_nodes: &[usize],
) -> Result<()> {
    spec.validate()?;
    let mesh = shapes::bodies_mesh(&character.skeleton, spec)?;
    let ibm = shapes::inverse_bind_matrices(bin, &character.skeleton);
    let material = push(obj, "materials", shapes::material());
    let primitive = shapes::primitive(bin, &mesh, joint_nodes.len(), material);
    let name = format!("{} ragdoll bodies", character.name);
    let mesh = push(
        obj,
        "meshes",
        json!({"name": name, "primitives": [primitive]}),
    );
    let skin = push(
        obj,
        "skins",
        json!({"name": name, "joints": joint_nodes, "inverseBindMatrices": ibm}),
    );
    let node = push(
        obj,
        "nodes",
        json!({"name": name, "mesh": mesh, "skin": skin}),
    );
    let default = obj.get("scene").and_then(Value::as_u64).unwrap_or(0) as usize;
    match obj
        .get_mut("scenes")
        .and_then(|s| s.get_mut(default))
        .and_then(Value::as_object_mut)
    {
        Some(scene) => {
            push(scene, "nodes", json!(node));
        }
        None => {
            // No scene: every node that is no other's child (the new one among them) is shown.
            let nodes = obj
                .get("nodes")
                .and_then(Value::as_array)
                .map_or(&[][..], Vec::as_slice);
            let roots = merge::scene_roots(obj, nodes);
            obj.insert("scenes".into(), json!([{"nodes": roots}]));
            obj.insert("scene".into(), json!(0));
        }
    }
    Ok(())
}

/// Appends `item` to the array `key` of `obj` (created when missing) and returns its index.
fn push(obj: &mut Map<String, Value>, key: &str, item: Value) -> usize {
    let mut list = take_array(obj, key);
    list.push(item);
    let index = list.len() - 1;
    obj.insert(key.into(), Value::Array(list));
    index
}
