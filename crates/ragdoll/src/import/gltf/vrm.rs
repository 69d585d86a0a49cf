//! VRM avatars' humanoid bone tables: a `.vrm` file is a GLB whose JSON names its bones
//! outright, in VRM 0.x (`extensions.VRM.humanoid.humanBones`: a list of `{bone, node}`)
//! or VRM 1.0 (`extensions.VRMC_vrm.humanoid.humanBones`: an object `bone → {node}`).
//! What the file says beats any guess from names or shape, so the table is handed on as
//! [`Character::humanoid_bones`](crate::skeleton::Character::humanoid_bones).
//!
//! Names are VRM 1.0's vocabulary; VRM 0.x's thumb names, one joint further out, are
//! renamed to it (0.x `leftThumbProximal` is 1.0 `leftThumbMetacarpal`, and so on), so
//! readers see one vocabulary. A malformed table is refused with the key that is wrong; a
//! bone whose name is not VRM's, or whose node is not a joint of the skeleton, is left out
//! with a warning.

use std::collections::HashMap;
use std::path::Path;

use serde_json::Value;

use super::format_err;
use crate::error::Result;

/// VRM 1.0's humanoid bones, in its specification's order.
const BONES: [&str; 55] = [
    "hips",
    "spine",
    "chest",
    "upperChest",
    "neck",
    "head",
    "leftEye",
    "rightEye",
    "jaw",
    "leftUpperLeg",
    "leftLowerLeg",
    "leftFoot",
    "leftToes",
    "rightUpperLeg",
    "rightLowerLeg",
    "rightFoot",
    "rightToes",
    "leftShoulder",
    "leftUpperArm",
    "leftLowerArm",
    "leftHand",
    "rightShoulder",
    "rightUpperArm",
    "rightLowerArm",
    "rightHand",
    "leftThumbMetacarpal",
    "leftThumbProximal",
    "leftThumbDistal",
    "leftIndexProximal",
    "leftIndexIntermediate",
    "leftIndexDistal",
    "leftMiddleProximal",
    "leftMiddleIntermediate",
    "leftMiddleDistal",
    "leftRingProximal",
    "leftRingIntermediate",
    "leftRingDistal",
    "leftLittleProximal",
    "leftLittleIntermediate",
    "leftLittleDistal",
    "rightThumbMetacarpal",
    "rightThumbProximal",
    "rightThumbDistal",
    "rightIndexProximal",
    "rightIndexIntermediate",
    "rightIndexDistal",
    "rightMiddleProximal",
    "rightMiddleIntermediate",
    "rightMiddleDistal",
    "rightRingProximal",
    "rightRingIntermediate",
    "rightRingDistal",
    "rightLittleProximal",
    "rightLittleIntermediate",
    "rightLittleDistal",
];

/// Most names a warning lists; the rest are counted.
const MAX_NAMED: usize = 6;

/// A humanoid table as read: VRM 1.0 bone names with their node indices.
pub(super) struct Table {
    /// Where it is in the JSON, for messages.
    key: &'static str,
    /// Bone name and node, each name once.
    bones: Vec<(&'static str, usize)>,
    /// What was left out while reading.
    unknown: Vec<String>,
    duplicates: Vec<&'static str>,
}

/// The VRM 1.0 name of a bone a file calls `name` (VRM 0.x when `v0`).
fn vocabulary(name: &str, v0: bool) -> Option<&'static str> {
    let renamed = if v0 {
        match name {
            "leftThumbProximal" => "leftThumbMetacarpal",
            "leftThumbIntermediate" => "leftThumbProximal",
            "rightThumbProximal" => "rightThumbMetacarpal",
            "rightThumbIntermediate" => "rightThumbProximal",
            "leftThumbMetacarpal" | "rightThumbMetacarpal" => return None,
            other => other,
        }
    } else {
        name
    };
    BONES.iter().copied().find(|b| *b == renamed)
}

/// Reads the file's humanoid table, VRM 1.0's when it has both; `None` without one.
pub(super) fn read_table(json: &Value, node_count: usize, path: &Path) -> Result<Option<Table>> {
    let Some(ext) = json.get("extensions") else {
        return Ok(None);
    };
    let (key, v0, bones) = if let Some(v1) = ext.get("VRMC_vrm") {
        let key = "extensions.VRMC_vrm.humanoid.humanBones";
        (
            key,
            false,
            v1.get("humanoid").and_then(|h| h.get("humanBones")),
        )
    } else if let Some(v) = ext.get("VRM") {
        let key = "extensions.VRM.humanoid.humanBones";
        (
            key,
            true,
            v.get("humanoid").and_then(|h| h.get("humanBones")),
        )
    } else {
        return Ok(None);
    };
    let err = |place: String, message: &str| Err(format_err(path, place, message));
    let Some(bones) = bones else {
        return err(key.into(), "is missing, so the VRM avatar names no bones");
    };
    let entries: Vec<(String, &Value)> = match (v0, bones) {
        (true, Value::Array(list)) => {
            let mut out = Vec::with_capacity(list.len());
            for (k, b) in list.iter().enumerate() {
                let Some(name) = b.get("bone").and_then(Value::as_str) else {
                    return err(format!("{key}[{k}].bone"), "is not a bone name (a string)");
                };
                out.push((name.to_string(), b));
            }
            out
        }
        (false, Value::Object(map)) => map.iter().map(|(n, b)| (n.clone(), b)).collect(),
        (true, _) => return err(key.into(), "is not a list of {bone, node} entries"),
        (false, _) => return err(key.into(), "is not an object of bone names"),
    };
    let mut table = Table {
        key,
        bones: Vec::new(),
        unknown: Vec::new(),
        duplicates: Vec::new(),
    };
    for (k, (name, b)) in entries.iter().enumerate() {
        let place = || {
            if v0 {
                format!("{key}[{k}].node")
            } else {
                format!("{key}.{name}.node")
            }
        };
        let node = match b.get("node").and_then(Value::as_u64) {
            Some(n) if usize::try_from(n).is_ok_and(|n| n < node_count) => n as usize,
            Some(n) => {
                return Err(format_err(
                    path,
                    place(),
                    format!("is node {n}, but the file has {node_count} nodes"),
                ));
            }
            None => return err(place(), "is not a node index"),
        };
        match vocabulary(name, v0) {
            None => table.unknown.push(name.clone()),
            Some(bone) if table.bones.iter().any(|(b, _)| *b == bone) => {
                table.duplicates.push(bone)
            }
            Some(bone) => table.bones.push((bone, node)),
        }
    }
    Ok(Some(table))
}

/// `items` joined with commas, at most [`MAX_NAMED`] of them, the rest counted.
fn some_of(items: &[String]) -> String {
    let mut out = items
        .iter()
        .take(MAX_NAMED)
        .cloned()
        .collect::<Vec<_>>()
        .join(", ");
    if items.len() > MAX_NAMED {
        out.push_str(&format!(" and {} more", items.len() - MAX_NAMED));
    }
    out
}

impl Table {
    /// The bones with the skeleton joint of their node, sorted by joint, and a warning for
    /// each kind of bone left out.
    pub(super) fn to_joints(
        &self,
        node_to_joint: &HashMap<usize, usize>,
        path: &Path,
    ) -> (Vec<(String, usize)>, Vec<String>) {
        let mut bones = Vec::with_capacity(self.bones.len());
        let mut missing = Vec::new();
        for &(bone, node) in &self.bones {
            match node_to_joint.get(&node) {
                Some(&j) => bones.push((bone.to_string(), j)),
                None => missing.push(format!("{bone} (node {node})")),
            }
        }
        bones.sort_by_key(|&(_, j)| j);
        let mut warnings = Vec::new();
        let p = path.display();
        let key = self.key;
        if !missing.is_empty() {
            let list = some_of(&missing);
            warnings.push(if missing.len() == 1 {
                format!(
                    "{p}: {key}: 1 bone names a node that is not a joint of the skeleton, so it is left out: {list}"
                )
            } else {
                format!(
                    "{p}: {key}: {} bones name nodes that are not joints of the skeleton, so they are left out: {list}",
                    missing.len()
                )
            });
        }
        if !self.unknown.is_empty() {
            let quoted: Vec<String> = self.unknown.iter().map(|n| format!("{n:?}")).collect();
            warnings.push(format!(
                "{p}: {key}: {} not a VRM humanoid bone, so left out: {}",
                if quoted.len() == 1 {
                    "1 name is".to_string()
                } else {
                    format!("{} names are", quoted.len())
                },
                some_of(&quoted)
            ));
        }
        if !self.duplicates.is_empty() {
            let names: Vec<String> = self.duplicates.iter().map(|s| s.to_string()).collect();
            warnings.push(format!(
                "{p}: {key}: bones listed more than once keep their first node: {}",
                some_of(&names)
            ));
        }
        (bones, warnings)
    }

    /// The nodes the table names: joints of a skeleton read from a bare node hierarchy
    /// (`rigid.rs`), whatever else they carry.
    pub(super) fn nodes(&self) -> Vec<usize> {
        self.bones.iter().map(|&(_, n)| n).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn read(v: Value) -> Result<Option<Table>> {
        read_table(&v, 10, Path::new("a.vrm"))
    }

    #[test]
    fn both_versions_read_into_one_vocabulary() {
        let v0 = json!({"extensions": {"VRM": {"humanoid": {"humanBones": [
            {"bone": "hips", "node": 1}, {"bone": "leftThumbProximal", "node": 2},
            {"bone": "leftThumbIntermediate", "node": 3}, {"bone": "tail", "node": 4},
            {"bone": "hips", "node": 5},
        ]}}}});
        let t = read(v0).unwrap().unwrap();
        assert_eq!(
            t.bones,
            [
                ("hips", 1),
                ("leftThumbMetacarpal", 2),
                ("leftThumbProximal", 3)
            ]
        );
        assert_eq!((t.unknown.len(), t.duplicates.len()), (1, 1));
        let v1 = json!({"extensions": {"VRMC_vrm": {"humanoid": {"humanBones": {
            "hips": {"node": 0}, "leftThumbMetacarpal": {"node": 9},
        }}}, "VRM": {}}});
        let t = read(v1).unwrap().unwrap();
        assert_eq!(t.bones, [("hips", 0), ("leftThumbMetacarpal", 9)]);
        assert!(
            read(json!({"extensions": {"KHR_x": {}}}))
                .unwrap()
                .is_none()
        );
        assert!(read(json!({})).unwrap().is_none());
    }

    #[test]
    fn malformed_tables_name_the_key() {
        let cases = [
            (
                json!({"extensions": {"VRM": {"humanoid": {}}}}),
                "a.vrm: extensions.VRM.humanoid.humanBones: is missing",
            ),
            (
                json!({"extensions": {"VRM": {"humanoid": {"humanBones": {"hips": {"node": 0}}}}}}),
                "a.vrm: extensions.VRM.humanoid.humanBones: is not a list",
            ),
            (
                json!({"extensions": {"VRM": {"humanoid": {"humanBones": [{"bone": 3, "node": 0}]}}}}),
                "a.vrm: extensions.VRM.humanoid.humanBones[0].bone: is not a bone name",
            ),
            (
                json!({"extensions": {"VRM": {"humanoid": {"humanBones": [{"bone": "hips", "node": -1}]}}}}),
                "a.vrm: extensions.VRM.humanoid.humanBones[0].node: is not a node index",
            ),
            (
                json!({"extensions": {"VRMC_vrm": {"humanoid": {"humanBones": [1]}}}}),
                "a.vrm: extensions.VRMC_vrm.humanoid.humanBones: is not an object",
            ),
            (
                json!({"extensions": {"VRMC_vrm": {"humanoid": {"humanBones": {"head": {"node": 10}}}}}}),
                "a.vrm: extensions.VRMC_vrm.humanoid.humanBones.head.node: is node 10, but the file has 10 nodes",
            ),
            (
                json!({"extensions": {"VRMC_vrm": {"humanoid": {"humanBones": {"head": 3}}}}}),
                "a.vrm: extensions.VRMC_vrm.humanoid.humanBones.head.node: is not a node index",
            ),
        ];
        for (v, want) in cases {
            let e = read(v).err().unwrap().to_string();
            assert!(e.starts_with(want), "{e}\nwanted {want}");
        }
    }

    #[test]
    fn bones_off_the_skeleton_are_left_out_with_one_warning() {
        let v = json!({"extensions": {"VRM": {"humanoid": {"humanBones": [
            {"bone": "head", "node": 3}, {"bone": "hips", "node": 1},
            {"bone": "leftEye", "node": 7}, {"bone": "rightEye", "node": 8},
        ]}}}});
        let t = read(v).unwrap().unwrap();
        let joints = HashMap::from([(1, 0), (3, 2)]);
        let (bones, warnings) = t.to_joints(&joints, Path::new("a.vrm"));
        assert_eq!(bones, [("hips".to_string(), 0), ("head".to_string(), 2)]);
        assert_eq!(
            warnings,
            [
                "a.vrm: extensions.VRM.humanoid.humanBones: 2 bones name nodes that are not joints of the skeleton, so they are left out: leftEye (node 7), rightEye (node 8)"
            ]
        );
    }
}
