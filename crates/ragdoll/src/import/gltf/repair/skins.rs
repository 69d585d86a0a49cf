//! Skins whose joints the node tree does not hold together: joints under separate roots
//! (the validator's `SKIN_NO_COMMON_ROOT`), and a `skeleton` that is not a common root of
//! the joints (`SKIN_SKELETON_INVALID`).

use std::collections::HashSet;

use serde_json::{Map, Value, json};

use super::tree::Tree;
use super::{count, listed, node_label};

/// Skin `s`'s joints that name a node (of `nodes`).
fn joints_of(obj: &Map<String, Value>, s: usize, nodes: usize) -> Vec<usize> {
    obj.get("skins")
        .and_then(|k| k.get(s))
        .and_then(|k| k.get("joints"))
        .and_then(Value::as_array)
        .into_iter()
        .flatten()
        .filter_map(Value::as_u64)
        .map(|j| j as usize)
        .filter(|&j| j < nodes)
        .collect()
}

/// Puts the separate trees that hold a skin's joints under one new node, so the joints
/// have a common root as glTF requires: the new node has no transform, so no world
/// transform changes, every scene that listed one of those trees lists the new node in
/// its place (once), and a `skeleton` the skin gives becomes the new node, the joints'
/// only common root.
pub(super) fn join_skin_roots(obj: &mut Map<String, Value>) -> Option<String> {
    let mut said = Vec::new();
    let mut tree = Tree::new(obj);
    for s in 0..count(obj, "skins") {
        let (mut tops, mut seen) = (Vec::new(), HashSet::new());
        for j in joints_of(obj, s, tree.len()) {
            let top = tree.top(j);
            if seen.insert(top) {
                tops.push(top);
            }
        }
        if tops.len() < 2 {
            continue;
        }
        let new = tree.len();
        let skin = obj.get("skins").and_then(|k| k.get(s));
        let skin_name = skin.and_then(|k| k.get("name")).and_then(Value::as_str);
        let name = format!("{} root", skin_name.unwrap_or(&format!("skin {s}")));
        let labels: Vec<String> = tops.iter().map(|&t| node_label(obj, t)).collect();
        if let Some(Value::Array(nodes)) = obj.get_mut("nodes") {
            nodes.push(json!({"name": name, "children": tops}));
        }
        relist_in_scenes(obj, &seen, new);
        // The new node is now the joints' only common root.
        let mut skeleton = String::new();
        let skin = obj.get_mut("skins").and_then(|k| k.get_mut(s));
        if let Some(old) = skin.and_then(|k| k.get_mut("skeleton")) {
            skeleton = format!(", which is now its skeleton (was {old})");
            *old = json!(new);
        }
        said.push(format!(
            "skins[{s}]: its joints hang from {} separate roots ({}); put under a new node {new} ({name:?}){skeleton}, as a skin's joints need a common root",
            tops.len(),
            listed(&labels)
        ));
        // The new node joined trees: later skins are judged on the tree as it is now.
        tree = Tree::new(obj);
    }
    (!said.is_empty()).then(|| said.join("; "))
}

/// In every scene, the first of `tops` listed becomes `new` and the others go.
fn relist_in_scenes(obj: &mut Map<String, Value>, tops: &HashSet<usize>, new: usize) {
    let Some(Value::Array(scenes)) = obj.get_mut("scenes") else {
        return;
    };
    for scene in scenes {
        let Some(Value::Array(list)) = scene.get_mut("nodes") else {
            continue;
        };
        let mut placed = false;
        list.retain_mut(|n| {
            if !n.as_u64().is_some_and(|n| tops.contains(&(n as usize))) {
                return true;
            }
            *n = json!(new);
            !std::mem::replace(&mut placed, true)
        });
    }
}

/// Sets each skin's `skeleton` that is not a common root of its joints (the validator's
/// `SKIN_SKELETON_INVALID`) to their nearest common root, or removes it (it is optional)
/// when they have none.
pub(super) fn repair_skeletons(obj: &mut Map<String, Value>) -> Option<String> {
    let tree = Tree::new(obj);
    let mut fixes = Vec::new();
    let skins = obj.get("skins").and_then(Value::as_array);
    for (s, skin) in skins.into_iter().flatten().enumerate() {
        let Some(given) = skin.get("skeleton") else {
            continue;
        };
        let joints = joints_of(obj, s, tree.len());
        let root = tree.common_root(&joints);
        let valid = given.as_u64().is_some_and(|g| {
            let g = g as usize;
            g < tree.len() && joints.iter().all(|&j| tree.holds(g, j))
        });
        if !valid && !joints.is_empty() {
            let was = match given.as_u64() {
                Some(g) if (g as usize) < tree.len() => node_label(obj, g as usize),
                _ => format!("{given}, no node,"),
            };
            let now = match root {
                Some(r) => format!("set to {}, their nearest one", node_label(obj, r)),
                None => "removed, as they have none".into(),
            };
            fixes.push((
                s,
                root,
                format!(
                    "skins[{s}].skeleton: {was} is not a common root of the skin's joints; {now}"
                ),
            ));
        }
    }
    if fixes.is_empty() {
        return None;
    }
    let skins = obj.get_mut("skins").and_then(Value::as_array_mut)?;
    let mut said = Vec::new();
    for (s, root, text) in fixes {
        if let Some(skin) = skins.get_mut(s).and_then(Value::as_object_mut) {
            match root {
                Some(r) => skin.insert("skeleton".into(), json!(r)),
                None => skin.remove("skeleton"),
            };
        }
        said.push(text);
    }
    Some(said.join("; "))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::import::gltf::repair::tests::tree;

    #[test]
    fn a_skeleton_that_is_no_common_root_is_set_to_the_nearest_or_removed() {
        let mut doc = tree();
        let w = repair_skeletons(doc.as_object_mut().unwrap()).unwrap();
        assert_eq!(doc["skins"][0]["skeleton"], 1);
        assert!(doc["skins"][1].get("skeleton").is_none());
        // An ancestor above the nearest root is still a common root: kept.
        assert_eq!(doc["skins"][2]["skeleton"], 0);
        assert!(
            w.contains("skins[0].skeleton: node 2 (\"leg\") is not a common root"),
            "{w}"
        );
        assert!(
            w.contains("set to node 1 (\"hip\")") && w.contains("skins[1].skeleton"),
            "{w}"
        );
        assert_eq!(repair_skeletons(doc.as_object_mut().unwrap()), None);
    }

    #[test]
    fn joints_under_separate_roots_are_put_under_one_new_node() {
        let mut doc = tree();
        doc["scenes"] = json!([{"nodes": [4, 0]}, {"nodes": [0]}]);
        doc["skins"][1]["name"] = json!("knight");
        let w = join_skin_roots(doc.as_object_mut().unwrap()).unwrap();
        assert_eq!(
            doc["nodes"][5],
            json!({"name": "knight root", "children": [0, 4]})
        );
        assert_eq!(doc["scenes"], json!([{"nodes": [5]}, {"nodes": [5]}]));
        assert_eq!(doc["skins"][1]["skeleton"], 5);
        assert!(
            w.starts_with("skins[1]: its joints hang from 2 separate roots (node 0 (\"Armature\"), node 4 (\"sword\")); put under a new node 5 (\"knight root\")"),
            "{w}"
        );
        assert_eq!(join_skin_roots(doc.as_object_mut().unwrap()), None);
        // Skin 0's skeleton (a joint) is no common root, but that is its own defect.
        let w = repair_skeletons(doc.as_object_mut().unwrap()).unwrap();
        assert!(
            w.starts_with("skins[0].skeleton") && !w.contains("skins[1]"),
            "{w}"
        );
    }
}
