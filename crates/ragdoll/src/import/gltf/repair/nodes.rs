//! The node tree as scenes and primitives see it: scenes that list nodes that are not
//! roots (or one twice), node rotations that are no unit quaternion, and `JOINTS_n`
//! without their `WEIGHTS_n`.

use std::collections::HashSet;

use serde_json::{Map, Value, json};

use super::tree::Tree;
use super::{UNIT_TOLERANCE, listed, node_label};

/// Lists only root nodes in each scene, each once (the validator's `SCENE_NON_ROOT_NODE`
/// and `DUPLICATE_ELEMENTS`): a node that is not a root is replaced by its root, so what
/// the scene showed it still shows, or left out when that root is listed already.
pub(super) fn repair_scenes(obj: &mut Map<String, Value>) -> Option<String> {
    let tree = Tree::new(obj);
    let mut fixes: Vec<(usize, Vec<Value>)> = Vec::new();
    let mut said = Vec::new();
    let scenes = obj.get("scenes").and_then(Value::as_array);
    for (s, scene) in scenes.into_iter().flatten().enumerate() {
        let Some(listed_nodes) = scene.get("nodes").and_then(Value::as_array) else {
            continue;
        };
        let original: HashSet<u64> = listed_nodes.iter().filter_map(Value::as_u64).collect();
        let (mut kept, mut in_kept) = (Vec::new(), HashSet::new());
        let mut notes = Vec::new();
        for v in listed_nodes {
            let Some(n) = v.as_u64().map(|n| n as usize).filter(|&n| n < tree.len()) else {
                notes.push(format!("entry {v} left out (no such node)"));
                continue;
            };
            let root = tree.top(n);
            if root != n {
                let (r, label) = (node_label(obj, root), node_label(obj, n));
                if original.contains(&(root as u64)) {
                    notes.push(format!(
                        "{label} left out (not a root, and its root {r} is listed)"
                    ));
                } else {
                    notes.push(format!("{label} replaced by its root {r}"));
                }
            }
            if !in_kept.insert(root) {
                if root == n {
                    notes.push(format!("{} listed twice, kept once", node_label(obj, n)));
                }
                continue;
            }
            kept.push(json!(root));
        }
        if !notes.is_empty() {
            said.push(format!("scenes[{s}].nodes: {}", listed(&notes)));
            fixes.push((s, kept));
        }
    }
    let scenes = obj.get_mut("scenes").and_then(Value::as_array_mut)?;
    for (s, kept) in fixes {
        if let Some(scene) = scenes.get_mut(s) {
            scene["nodes"] = Value::Array(kept);
        }
    }
    (!said.is_empty()).then(|| said.join("; "))
}

/// Scales each node `rotation` that is not a unit quaternion (the validator's
/// `ROTATION_NON_UNIT`) to unit length; a zero or non-finite one becomes the identity,
/// what a viewer that normalises shows for it. The importer refuses a zero rotation (it
/// gives no orientation at all), so this is also what lets such a file be read.
pub(super) fn normalise_rotations(obj: &mut Map<String, Value>) -> Option<String> {
    let nodes = obj.get_mut("nodes").and_then(Value::as_array_mut)?;
    let mut places = Vec::new();
    for (i, node) in nodes.iter_mut().enumerate() {
        let Some(Value::Array(r)) = node.get_mut("rotation") else {
            continue;
        };
        let q: Vec<f64> = r.iter().filter_map(Value::as_f64).collect();
        if q.len() != 4 {
            continue; // not a rotation the importer accepts either
        }
        let len = q.iter().map(|x| x * x).sum::<f64>().sqrt();
        if (len - 1.0).abs() <= UNIT_TOLERANCE {
            continue;
        }
        *r = if len.is_finite() && len > 1e-12 {
            q.iter().map(|x| json!(x / len)).collect()
        } else {
            vec![json!(0.0), json!(0.0), json!(0.0), json!(1.0)]
        };
        places.push(format!("nodes[{i}].rotation"));
    }
    (!places.is_empty()).then(|| {
        format!(
            "{}: not a unit quaternion, normalised (a zero one set to the identity)",
            listed(&places)
        )
    })
}

/// Keeps a primitive's `JOINTS_n`/`WEIGHTS_n` only in pairs numbered from 0 without a gap,
/// the sets the importer reads and the exporter rewrites: any other (a `JOINTS_7` with no
/// `WEIGHTS_7`) is the validator's `MESH_PRIMITIVE_JOINTS_WEIGHTS_MISMATCH` and skins
/// nothing a loader could trust.
pub(super) fn pair_influences(obj: &mut Map<String, Value>) -> Option<String> {
    let meshes = obj.get_mut("meshes").and_then(Value::as_array_mut)?;
    let mut said = Vec::new();
    for (m, mesh) in meshes.iter_mut().enumerate() {
        let Some(Value::Array(prims)) = mesh.get_mut("primitives") else {
            continue;
        };
        for (p, prim) in prims.iter_mut().enumerate() {
            let Some(Value::Object(attrs)) = prim.get_mut("attributes") else {
                continue;
            };
            let pairs = (0..)
                .take_while(|k| {
                    attrs.contains_key(&format!("JOINTS_{k}"))
                        && attrs.contains_key(&format!("WEIGHTS_{k}"))
                })
                .count();
            let keep = |k: &str| {
                let n = k
                    .strip_prefix("JOINTS_")
                    .or_else(|| k.strip_prefix("WEIGHTS_"));
                n.is_none_or(|n| {
                    n.parse::<usize>()
                        .is_ok_and(|n| n < pairs && k.ends_with(&format!("_{n}")))
                })
            };
            let gone: Vec<String> = attrs.keys().filter(|k| !keep(k)).cloned().collect();
            if gone.is_empty() {
                continue;
            }
            attrs.retain(|k, _| keep(k));
            said.push(format!("meshes[{m}].primitives[{p}]: {}", gone.join(", ")));
        }
    }
    (!said.is_empty()).then(|| {
        format!(
            "left out skin influences not paired as JOINTS_n/WEIGHTS_n numbered from 0: {}",
            listed(&said)
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::import::gltf::repair::tests::tree;

    #[test]
    fn scenes_list_roots_once() {
        let mut doc = tree();
        doc["scenes"] = json!([{"nodes": [2, 4, 4]}, {"nodes": [0, 3]}, {"nodes": [0, 4]}]);
        let w = repair_scenes(doc.as_object_mut().unwrap()).unwrap();
        assert_eq!(
            doc["scenes"],
            json!([{"nodes": [0, 4]}, {"nodes": [0]}, {"nodes": [0, 4]}])
        );
        assert!(
            w.contains("scenes[0].nodes: node 2 (\"leg\") replaced by its root node 0"),
            "{w}"
        );
        assert!(
            w.contains("node 4 (\"sword\") listed twice, kept once"),
            "{w}"
        );
        assert!(
            w.contains("scenes[1].nodes: node 3 (\"arm\") left out (not a root, and its root node 0 (\"Armature\") is listed)"),
            "{w}"
        );
        assert!(!w.contains("scenes[2]"), "{w}");
        assert_eq!(repair_scenes(doc.as_object_mut().unwrap()), None);
    }

    #[test]
    fn rotations_become_unit_and_a_zero_one_the_identity() {
        let mut doc = json!({"nodes": [
            {"rotation": [0.0, 0.0, 0.0, 0.0]},
            {"rotation": [0.0, 2.0, 0.0, 0.0]},
            {"rotation": [0.0, 0.0, 0.0, 1.001]}
        ]});
        let w = normalise_rotations(doc.as_object_mut().unwrap()).unwrap();
        assert_eq!(doc["nodes"][0]["rotation"], json!([0.0, 0.0, 0.0, 1.0]));
        assert_eq!(doc["nodes"][1]["rotation"], json!([0.0, 1.0, 0.0, 0.0]));
        // Rounding, not a defect: left as written.
        assert_eq!(doc["nodes"][2]["rotation"], json!([0.0, 0.0, 0.0, 1.001]));
        assert!(
            w.starts_with("nodes[0].rotation, nodes[1].rotation: "),
            "{w}"
        );
    }

    #[test]
    fn unpaired_influence_sets_are_left_out() {
        let mut doc = json!({"meshes": [{"primitives": [
            {"attributes": {"POSITION": 0, "JOINTS_0": 1, "WEIGHTS_0": 2, "JOINTS_7": 1}},
            {"attributes": {"POSITION": 0, "JOINTS_0": 1, "WEIGHTS_0": 2, "JOINTS_2": 1, "WEIGHTS_2": 2, "WEIGHTS_1": 2}},
            {"attributes": {"POSITION": 0, "JOINTS_0": 1, "WEIGHTS_0": 2, "JOINTS_1": 1, "WEIGHTS_1": 2}}
        ]}]});
        let w = pair_influences(doc.as_object_mut().unwrap()).unwrap();
        let attrs = |p: usize| {
            let mut k: Vec<String> = doc["meshes"][0]["primitives"][p]["attributes"]
                .as_object()
                .unwrap()
                .keys()
                .cloned()
                .collect();
            k.sort();
            k
        };
        assert_eq!(attrs(0), ["JOINTS_0", "POSITION", "WEIGHTS_0"]);
        assert_eq!(attrs(1), ["JOINTS_0", "POSITION", "WEIGHTS_0"]);
        assert_eq!(
            attrs(2),
            ["JOINTS_0", "JOINTS_1", "POSITION", "WEIGHTS_0", "WEIGHTS_1"]
        );
        assert!(w.contains("meshes[0].primitives[0]: JOINTS_7"), "{w}");
        assert!(!w.contains("primitives[2]"), "{w}");
    }
}
