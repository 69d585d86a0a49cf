//! The checker: what the Khronos validator would count as an error in a written glTF, for
//! every defect the inputs carry, so the tests can judge an output without node.

use std::collections::HashSet;

use serde_json::Value;

/// The entries of `doc[key]` (none when absent).
pub fn items<'a>(doc: &'a Value, key: &str) -> &'a [Value] {
    doc.get(key)
        .and_then(Value::as_array)
        .map_or(&[], Vec::as_slice)
}

fn len(doc: &Value, key: &str) -> usize {
    items(doc, key).len()
}

/// Records each index out of range as "`place` (`index` of `count`)".
struct Refs<'a> {
    doc: &'a Value,
    out: Vec<String>,
}

impl Refs<'_> {
    fn check_in(&mut self, place: String, v: Option<&Value>, count: usize) {
        if let Some(v) = v
            && v.as_u64().is_none_or(|i| (i as usize) >= count)
        {
            self.out.push(format!("{place} ({v} of {count})"));
        }
    }

    fn check(&mut self, place: String, v: Option<&Value>, into: &str) {
        let count = len(self.doc, into);
        self.check_in(place, v, count);
    }
}

/// Every index the core schema (and the texture extensions) define that points past its
/// array.
fn dangling(doc: &Value) -> Vec<String> {
    let mut refs = Refs {
        doc,
        out: Vec::new(),
    };
    dangling_in_tree(&mut refs);
    dangling_in_looks(&mut refs);
    dangling_in_data(&mut refs);
    refs.out
}

/// Scenes, nodes and skins.
fn dangling_in_tree(r: &mut Refs) {
    let doc = r.doc;
    r.check("scene".into(), doc.get("scene"), "scenes");
    for (s, scene) in items(doc, "scenes").iter().enumerate() {
        for n in items(scene, "nodes") {
            r.check(format!("scenes[{s}].nodes"), Some(n), "nodes");
        }
    }
    for (i, node) in items(doc, "nodes").iter().enumerate() {
        for c in items(node, "children") {
            r.check(format!("nodes[{i}].children"), Some(c), "nodes");
        }
        for (k, into) in [("mesh", "meshes"), ("skin", "skins"), ("camera", "cameras")] {
            r.check(format!("nodes[{i}].{k}"), node.get(k), into);
        }
    }
    for (i, skin) in items(doc, "skins").iter().enumerate() {
        for j in items(skin, "joints") {
            r.check(format!("skins[{i}].joints"), Some(j), "nodes");
        }
        r.check(
            format!("skins[{i}].skeleton"),
            skin.get("skeleton"),
            "nodes",
        );
        let ibm = skin.get("inverseBindMatrices");
        r.check(format!("skins[{i}].inverseBindMatrices"), ibm, "accessors");
    }
}

/// Meshes, materials, textures and images.
fn dangling_in_looks(r: &mut Refs) {
    let doc = r.doc;
    for (m, mesh) in items(doc, "meshes").iter().enumerate() {
        for (p, prim) in items(mesh, "primitives").iter().enumerate() {
            let place = format!("meshes[{m}].primitives[{p}]");
            for (k, a) in prim["attributes"].as_object().into_iter().flatten() {
                r.check(format!("{place}.attributes.{k}"), Some(a), "accessors");
            }
            r.check(format!("{place}.indices"), prim.get("indices"), "accessors");
            r.check(
                format!("{place}.material"),
                prim.get("material"),
                "materials",
            );
        }
    }
    for (m, material) in items(doc, "materials").iter().enumerate() {
        let mut stack = vec![(format!("materials[{m}]"), material)];
        while let Some((place, v)) = stack.pop() {
            for (k, x) in v.as_object().into_iter().flatten() {
                if k.ends_with("Texture") && x.get("index").is_some() {
                    r.check(format!("{place}.{k}"), x.get("index"), "textures");
                }
                stack.push((format!("{place}.{k}"), x));
            }
        }
    }
    for (t, texture) in items(doc, "textures").iter().enumerate() {
        r.check(
            format!("textures[{t}].source"),
            texture.get("source"),
            "images",
        );
        r.check(
            format!("textures[{t}].sampler"),
            texture.get("sampler"),
            "samplers",
        );
        for (e, x) in texture["extensions"].as_object().into_iter().flatten() {
            r.check(
                format!("textures[{t}].{e}.source"),
                x.get("source"),
                "images",
            );
        }
    }
    for (i, image) in items(doc, "images").iter().enumerate() {
        let view = image.get("bufferView");
        r.check(format!("images[{i}].bufferView"), view, "bufferViews");
    }
}

/// Accessors, buffer views and animations.
fn dangling_in_data(r: &mut Refs) {
    let doc = r.doc;
    for (i, a) in items(doc, "accessors").iter().enumerate() {
        let view = a.get("bufferView");
        r.check(format!("accessors[{i}].bufferView"), view, "bufferViews");
    }
    for (i, v) in items(doc, "bufferViews").iter().enumerate() {
        r.check(
            format!("bufferViews[{i}].buffer"),
            v.get("buffer"),
            "buffers",
        );
    }
    for (a, anim) in items(doc, "animations").iter().enumerate() {
        let samplers = len(anim, "samplers");
        for (c, ch) in items(anim, "channels").iter().enumerate() {
            let place = format!("animations[{a}].channels[{c}]");
            r.check_in(format!("{place}.sampler"), ch.get("sampler"), samplers);
            let node = ch["target"].get("node");
            r.check(format!("{place}.target.node"), node, "nodes");
        }
        for (s, sampler) in items(anim, "samplers").iter().enumerate() {
            for k in ["input", "output"] {
                let place = format!("animations[{a}].samplers[{s}].{k}");
                r.check(place, sampler.get(k), "accessors");
            }
        }
    }
}

/// Each node's parent, when it has one.
fn parents(doc: &Value) -> Vec<Option<usize>> {
    let mut parent = vec![None; len(doc, "nodes")];
    for (i, node) in items(doc, "nodes").iter().enumerate() {
        for c in items(node, "children").iter().filter_map(Value::as_u64) {
            if let Some(p) = parent.get_mut(c as usize) {
                *p = Some(i);
            }
        }
    }
    parent
}

/// Whether `a` is `n` or one of its ancestors.
fn is_ancestor(parent: &[Option<usize>], a: usize, mut n: usize) -> bool {
    for _ in 0..=parent.len() {
        if n == a {
            return true;
        }
        match parent.get(n).copied().flatten() {
            Some(p) => n = p,
            None => return false,
        }
    }
    false
}

/// Whether `q` is a unit quaternion as the validator judges it: within 0.00769 of unit
/// length (its own limit, the rounding of a normalised byte).
fn unit(q: &[f32]) -> bool {
    let l = q.iter().map(|x| x * x).sum::<f32>().sqrt();
    (l - 1.0).abs() <= 0.00769
}

/// The floats of accessor `a` (float or normalised integer components), element by
/// element; `None` when it cannot be read from `bin`.
fn floats(doc: &Value, bin: &[u8], a: usize) -> Option<Vec<f32>> {
    let acc = items(doc, "accessors").get(a)?;
    let view = items(doc, "bufferViews").get(acc["bufferView"].as_u64()? as usize)?;
    let comps = match acc["type"].as_str()? {
        "SCALAR" => 1,
        "VEC2" => 2,
        "VEC3" => 3,
        "VEC4" => 4,
        _ => return None,
    };
    let (size, scale) = match acc["componentType"].as_u64()? {
        5126 => (4, 1.0),
        5120 => (1, 127.0),
        5121 => (1, 255.0),
        5122 => (2, 32767.0),
        5123 => (2, 65535.0),
        _ => return None,
    };
    let ctype = acc["componentType"].as_u64()?;
    let start = view["byteOffset"].as_u64().unwrap_or(0) + acc["byteOffset"].as_u64().unwrap_or(0);
    let stride = view["byteStride"].as_u64().unwrap_or(size * comps);
    let mut out = Vec::new();
    for e in 0..acc["count"].as_u64()? {
        for c in 0..comps {
            let at = (start + e * stride + c * size) as usize;
            let b = bin.get(at..at + size as usize)?;
            let v = match ctype {
                5126 => f32::from_le_bytes(b.try_into().ok()?),
                5120 => b[0] as i8 as f32,
                5121 => b[0] as f32,
                5122 => i16::from_le_bytes(b.try_into().ok()?) as f32,
                _ => u16::from_le_bytes(b.try_into().ok()?) as f32,
            };
            out.push((v / scale).max(-1.0));
        }
    }
    Some(out)
}

/// Every animation's keyframe times and rotation keys: times must rise and not be
/// negative, rotations (the values of a cubic spline, not its tangents) be unit.
fn animation_problems(doc: &Value, bin: &[u8]) -> Vec<String> {
    let mut out = Vec::new();
    for (a, anim) in items(doc, "animations").iter().enumerate() {
        let mut targets = HashSet::new();
        for (c, ch) in items(anim, "channels").iter().enumerate() {
            if !targets.insert(ch["target"].to_string()) {
                out.push(format!("animations[{a}].channels[{c}] repeats a target"));
            }
            let Some(sampler) = ch["sampler"]
                .as_u64()
                .and_then(|s| items(anim, "samplers").get(s as usize))
            else {
                continue;
            };
            let input = sampler["input"].as_u64().unwrap_or(u64::MAX) as usize;
            let output = sampler["output"].as_u64().unwrap_or(u64::MAX) as usize;
            let Some(times) = floats(doc, bin, input) else {
                out.push(format!("animations[{a}] input accessor {input} unreadable"));
                continue;
            };
            if times.first().is_some_and(|&t| t < 0.0) || times.windows(2).any(|w| w[1] <= w[0]) {
                out.push(format!(
                    "animations[{a}] input accessor {input} does not rise"
                ));
            }
            if ch["target"]["path"] != "rotation" {
                continue;
            }
            let cubic = sampler["interpolation"] == "CUBICSPLINE";
            let Some(keys) = floats(doc, bin, output) else {
                out.push(format!(
                    "animations[{a}] output accessor {output} unreadable"
                ));
                continue;
            };
            let bad = keys
                .chunks_exact(4)
                .enumerate()
                .filter(|(k, _)| !cubic || k % 3 == 1)
                .any(|(_, q)| !unit(q));
            if bad {
                out.push(format!("animations[{a}] output accessor {output} not unit"));
            }
        }
    }
    out
}

/// Every error the defects of [`base`](super::inputs::base) give a validator, found in a
/// written document: empty for a valid one.
pub fn problems(doc: &Value, bin: &[u8]) -> Vec<String> {
    let mut out = dangling(doc);
    out.extend(header_problems(doc));
    out.extend(tree_problems(doc));
    out.extend(skin_and_rotation_problems(doc));
    out.extend(animation_problems(doc, bin));
    out
}

/// The asset's version and the extension lists.
fn header_problems(doc: &Value) -> Vec<String> {
    let mut out = Vec::new();
    if doc["asset"]["version"] != "2.0" {
        out.push(format!("asset.version {}", doc["asset"]["version"]));
    }
    if let Some(v) = doc["asset"].get("minVersion")
        && v != "2.0"
    {
        out.push(format!("asset.minVersion {v}"));
    }
    let used = items(doc, "extensionsUsed");
    let declared: HashSet<&str> = used.iter().filter_map(Value::as_str).collect();
    if declared.len() != used.len() {
        out.push("extensionsUsed repeats an extension".into());
    }
    for e in items(doc, "extensionsRequired") {
        if !e.as_str().is_some_and(|e| declared.contains(e)) {
            out.push(format!("extensionsRequired {e} not in extensionsUsed"));
        }
    }
    let mut stack = vec![doc];
    while let Some(v) = stack.pop() {
        match v {
            Value::Object(m) => {
                for (k, x) in m {
                    if k == "extensions" {
                        for e in x.as_object().into_iter().flatten().map(|e| e.0) {
                            if !declared.contains(e.as_str()) {
                                out.push(format!("extension {e} not declared"));
                            }
                        }
                    }
                    stack.push(x);
                }
            }
            Value::Array(a) => stack.extend(a),
            _ => {}
        }
    }
    out
}

/// Scenes that list nodes that are not roots (or one twice), and skeletons that are no
/// common root of their skin's joints.
fn tree_problems(doc: &Value) -> Vec<String> {
    let mut out = Vec::new();
    let parent = parents(doc);
    for (s, scene) in items(doc, "scenes").iter().enumerate() {
        let nodes = items(scene, "nodes");
        if nodes.iter().collect::<HashSet<_>>().len() != nodes.len() {
            out.push(format!("scenes[{s}].nodes repeats a node"));
        }
        for n in nodes.iter().filter_map(Value::as_u64) {
            if parent.get(n as usize).copied().flatten().is_some() {
                out.push(format!("scenes[{s}].nodes lists node {n}, not a root"));
            }
        }
    }
    for (i, skin) in items(doc, "skins").iter().enumerate() {
        let joints = items(skin, "joints").iter().filter_map(Value::as_u64);
        let tops: HashSet<usize> = joints
            .map(|j| {
                (0..=parent.len()).fold(j as usize, |n, _| {
                    parent.get(n).copied().flatten().unwrap_or(n)
                })
            })
            .collect();
        if tops.len() > 1 {
            out.push(format!("skins[{i}] has joints under {} roots", tops.len()));
        }
        let Some(root) = skin.get("skeleton").and_then(Value::as_u64) else {
            continue;
        };
        for j in items(skin, "joints").iter().filter_map(Value::as_u64) {
            if !is_ancestor(&parent, root as usize, j as usize) {
                out.push(format!("skins[{i}].skeleton {root} is not above joint {j}"));
            }
        }
    }
    out
}

/// `JOINTS_n` and `WEIGHTS_n` that are not pairs numbered from 0, and node rotations that
/// are not unit quaternions.
fn skin_and_rotation_problems(doc: &Value) -> Vec<String> {
    let mut out = Vec::new();
    for (m, mesh) in items(doc, "meshes").iter().enumerate() {
        for (p, prim) in items(mesh, "primitives").iter().enumerate() {
            let attrs = prim["attributes"].as_object();
            let sets = |prefix: &str| -> Vec<u64> {
                let mut n: Vec<u64> = attrs
                    .into_iter()
                    .flatten()
                    .filter_map(|(k, _)| k.strip_prefix(prefix)?.parse().ok())
                    .collect();
                n.sort();
                n
            };
            let (j, w) = (sets("JOINTS_"), sets("WEIGHTS_"));
            if j != w || j.iter().enumerate().any(|(k, &n)| n != k as u64) {
                out.push(format!(
                    "meshes[{m}].primitives[{p}] JOINTS {j:?} WEIGHTS {w:?}"
                ));
            }
        }
    }
    for (i, node) in items(doc, "nodes").iter().enumerate() {
        if let Some(r) = node.get("rotation").and_then(Value::as_array) {
            let q: Vec<f32> = r
                .iter()
                .filter_map(Value::as_f64)
                .map(|x| x as f32)
                .collect();
            if q.len() != 4 || !unit(&q) {
                out.push(format!("nodes[{i}].rotation {r:?} not unit"));
            }
        }
    }
    out
}
