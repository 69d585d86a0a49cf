//! Several characters' glTF documents merged into one, for scene files: each document keeps
//! all it has, with every index into a top-level array shifted past the documents before
//! it, and the `ragdoll` animations (each document's `animations[0]`) become one animation,
//! so viewers, which play one animation at a time, play every character together.
//!
//! Renumbering follows the glTF 2.0 schema, plus the index-holding ratified extensions an
//! input may plausibly carry (texture sources, texture infos, lights, material variants,
//! GPU instancing); unknown extensions are copied as they are.

use serde_json::{Map, Value, json};

use super::{ANIMATION_NAME, generator, pad_to_4};
use crate::error::Result;

/// Where one document's entries start in the merged arrays and its bytes in the merged
/// binary chunk.
#[derive(Clone, Copy, Default)]
struct Offsets {
    accessors: usize,
    buffer_views: usize,
    cameras: usize,
    images: usize,
    materials: usize,
    meshes: usize,
    nodes: usize,
    samplers: usize,
    skins: usize,
    textures: usize,
    lights: usize,
    variants: usize,
    bytes: usize,
}

/// The merged top-level arrays.
#[derive(Default)]
struct Arrays {
    accessors: Vec<Value>,
    buffer_views: Vec<Value>,
    cameras: Vec<Value>,
    images: Vec<Value>,
    materials: Vec<Value>,
    meshes: Vec<Value>,
    nodes: Vec<Value>,
    samplers: Vec<Value>,
    skins: Vec<Value>,
    textures: Vec<Value>,
    lights: Vec<Value>,
    variants: Vec<Value>,
}

/// Adds `by` to the index at `v[key]`, when there is one.
fn shift(v: &mut Value, key: &str, by: usize) {
    if let Some(slot) = v.get_mut(key) {
        shift_value(slot, by);
    }
}

fn shift_value(slot: &mut Value, by: usize) {
    if let Some(i) = slot.as_u64() {
        *slot = json!(i as usize + by);
    }
}

/// Adds `by` to every index in the array at `v[key]`.
fn shift_all(v: &mut Value, key: &str, by: usize) {
    if let Some(Value::Array(a)) = v.get_mut(key) {
        a.iter_mut().for_each(|x| shift_value(x, by));
    }
}

/// Adds `by` to every value of the object at `v[key]` (attribute maps).
fn shift_values(v: &mut Value, key: &str, by: usize) {
    if let Some(Value::Object(m)) = v.get_mut(key) {
        m.values_mut().for_each(|x| shift_value(x, by));
    }
}

/// Shifts the `index` of every texture info inside a material: core and extension texture
/// infos alike are objects under a key ending in `Texture` (`baseColorTexture`,
/// `clearcoatTexture`, …).
fn shift_texture_infos(v: &mut Value, by: usize) {
    match v {
        Value::Object(m) => {
            for (k, x) in m.iter_mut() {
                if k.ends_with("Texture") && x.is_object() {
                    shift(x, "index", by);
                }
                shift_texture_infos(x, by);
            }
        }
        Value::Array(a) => a.iter_mut().for_each(|x| shift_texture_infos(x, by)),
        _ => {}
    }
}

fn take(doc: &mut Map<String, Value>, key: &str) -> Vec<Value> {
    match doc.remove(key) {
        Some(Value::Array(a)) => a,
        _ => Vec::new(),
    }
}

/// Appends `names` to `to`, skipping those already there.
fn union(to: &mut Vec<Value>, names: Vec<Value>) {
    for n in names {
        if !to.contains(&n) {
            to.push(n);
        }
    }
}

/// The nodes of a document's default scene (or, without scenes, every node that is no
/// other node's child), before shifting.
pub(super) fn scene_roots(doc: &Map<String, Value>, nodes: &[Value]) -> Vec<Value> {
    let scenes = doc.get("scenes").and_then(Value::as_array);
    let default = doc.get("scene").and_then(Value::as_u64).unwrap_or(0) as usize;
    if let Some(scene) = scenes.and_then(|s| s.get(default)) {
        return scene
            .get("nodes")
            .and_then(Value::as_array)
            .cloned()
            .unwrap_or_default();
    }
    let children: Vec<u64> = nodes
        .iter()
        .filter_map(|n| n.get("children").and_then(Value::as_array))
        .flatten()
        .filter_map(Value::as_u64)
        .collect();
    (0..nodes.len() as u64)
        .filter(|i| !children.contains(i))
        .map(|i| json!(i))
        .collect()
}

/// Merges documents (JSON and binary chunk each, one buffer each, as the exporter builds
/// them) into one.
pub(super) fn merge(docs: Vec<(Value, Vec<u8>)>) -> Result<(Value, Vec<u8>)> {
    let mut out = Arrays::default();
    let mut data: Vec<u8> = Vec::new();
    let mut channels = Vec::new();
    let mut samplers = Vec::new();
    let mut other_animations = Vec::new();
    let mut scene_nodes = Vec::new();
    let mut used = Vec::new();
    let mut required = Vec::new();
    let mut root_extensions = Map::new();
    let mut copyrights: Vec<String> = Vec::new();
    for (root, bin) in docs {
        let Value::Object(mut doc) = root else {
            continue; // the exporter only builds objects
        };
        pad_to_4(&mut data, 0);
        let o = Offsets {
            accessors: out.accessors.len(),
            buffer_views: out.buffer_views.len(),
            cameras: out.cameras.len(),
            images: out.images.len(),
            materials: out.materials.len(),
            meshes: out.meshes.len(),
            nodes: out.nodes.len(),
            samplers: out.samplers.len(),
            skins: out.skins.len(),
            textures: out.textures.len(),
            lights: out.lights.len(),
            variants: out.variants.len(),
            bytes: data.len(),
        };
        data.extend_from_slice(&bin);

        for mut v in take(&mut doc, "bufferViews") {
            let offset = v.get("byteOffset").and_then(Value::as_u64).unwrap_or(0) as usize;
            v["buffer"] = json!(0);
            v["byteOffset"] = json!(offset + o.bytes);
            out.buffer_views.push(v);
        }
        for mut a in take(&mut doc, "accessors") {
            shift(&mut a, "bufferView", o.buffer_views);
            if let Some(sparse) = a.get_mut("sparse") {
                for part in ["indices", "values"] {
                    if let Some(p) = sparse.get_mut(part) {
                        shift(p, "bufferView", o.buffer_views);
                    }
                }
            }
            out.accessors.push(a);
        }
        for mut image in take(&mut doc, "images") {
            shift(&mut image, "bufferView", o.buffer_views);
            out.images.push(image);
        }
        out.samplers.extend(take(&mut doc, "samplers"));
        out.cameras.extend(take(&mut doc, "cameras"));
        for mut t in take(&mut doc, "textures") {
            shift(&mut t, "sampler", o.samplers);
            shift(&mut t, "source", o.images);
            // EXT_texture_webp, KHR_texture_basisu, MSFT_texture_dds: another image source.
            if let Some(Value::Object(exts)) = t.get_mut("extensions") {
                exts.values_mut().for_each(|e| shift(e, "source", o.images));
            }
            out.textures.push(t);
        }
        for mut m in take(&mut doc, "materials") {
            shift_texture_infos(&mut m, o.textures);
            out.materials.push(m);
        }
        for mut mesh in take(&mut doc, "meshes") {
            if let Some(Value::Array(prims)) = mesh.get_mut("primitives") {
                for p in prims {
                    shift_values(p, "attributes", o.accessors);
                    shift(p, "indices", o.accessors);
                    shift(p, "material", o.materials);
                    if let Some(Value::Array(targets)) = p.get_mut("targets") {
                        for t in targets {
                            if let Value::Object(m) = t {
                                m.values_mut().for_each(|x| shift_value(x, o.accessors));
                            }
                        }
                    }
                    let Some(exts) = p.get_mut("extensions") else {
                        continue;
                    };
                    if let Some(draco) = exts.get_mut("KHR_draco_mesh_compression") {
                        shift(draco, "bufferView", o.buffer_views);
                    }
                    if let Some(Value::Array(maps)) = exts
                        .get_mut("KHR_materials_variants")
                        .and_then(|v| v.get_mut("mappings"))
                    {
                        for map in maps {
                            shift(map, "material", o.materials);
                            shift_all(map, "variants", o.variants);
                        }
                    }
                }
            }
            out.meshes.push(mesh);
        }
        let nodes = take(&mut doc, "nodes");
        for mut n in scene_roots(&doc, &nodes) {
            shift_value(&mut n, o.nodes);
            scene_nodes.push(n);
        }
        for mut n in nodes {
            shift_all(&mut n, "children", o.nodes);
            shift(&mut n, "mesh", o.meshes);
            shift(&mut n, "skin", o.skins);
            shift(&mut n, "camera", o.cameras);
            if let Some(exts) = n.get_mut("extensions") {
                if let Some(light) = exts.get_mut("KHR_lights_punctual") {
                    shift(light, "light", o.lights);
                }
                if let Some(inst) = exts.get_mut("EXT_mesh_gpu_instancing") {
                    shift_values(inst, "attributes", o.accessors);
                }
            }
            out.nodes.push(n);
        }
        for mut s in take(&mut doc, "skins") {
            shift_all(&mut s, "joints", o.nodes);
            shift(&mut s, "skeleton", o.nodes);
            shift(&mut s, "inverseBindMatrices", o.accessors);
            out.skins.push(s);
        }
        for (k, mut anim) in take(&mut doc, "animations").into_iter().enumerate() {
            if let Some(Value::Array(ss)) = anim.get_mut("samplers") {
                for s in ss {
                    shift(s, "input", o.accessors);
                    shift(s, "output", o.accessors);
                }
            }
            // The ragdoll animation's samplers move into the merged one: shift its channels
            // past the samplers already there.
            let by = if k == 0 { samplers.len() } else { 0 };
            if let Some(Value::Array(cs)) = anim.get_mut("channels") {
                for c in cs {
                    shift(c, "sampler", by);
                    if let Some(t) = c.get_mut("target") {
                        shift(t, "node", o.nodes);
                    }
                }
            }
            if k == 0 {
                samplers.extend(take_array_value(&mut anim, "samplers"));
                channels.extend(take_array_value(&mut anim, "channels"));
            } else {
                other_animations.push(anim);
            }
        }
        union(&mut used, take(&mut doc, "extensionsUsed"));
        union(&mut required, take(&mut doc, "extensionsRequired"));
        if let Some(Value::Object(exts)) = doc.remove("extensions") {
            for (name, mut ext) in exts {
                match name.as_str() {
                    "KHR_lights_punctual" => {
                        out.lights.extend(take_array_value(&mut ext, "lights"));
                    }
                    "KHR_materials_variants" => {
                        out.variants.extend(take_array_value(&mut ext, "variants"));
                    }
                    _ => {
                        root_extensions.entry(name).or_insert(ext);
                    }
                }
            }
        }
        if let Some(c) = doc
            .get("asset")
            .and_then(|a| a.get("copyright"))
            .and_then(Value::as_str)
            && !copyrights.iter().any(|x| x == c)
        {
            copyrights.push(c.to_string());
        }
    }
    if !out.lights.is_empty() {
        root_extensions.insert(
            "KHR_lights_punctual".into(),
            json!({"lights": std::mem::take(&mut out.lights)}),
        );
    }
    if !out.variants.is_empty() {
        root_extensions.insert(
            "KHR_materials_variants".into(),
            json!({"variants": std::mem::take(&mut out.variants)}),
        );
    }
    let mut asset = json!({"version": "2.0", "generator": generator()});
    if !copyrights.is_empty() {
        // Several sources may each ask for credit (CC-BY): keep every notice.
        asset["copyright"] = json!(copyrights.join("; "));
    }
    let mut animations = vec![json!({
        "name": ANIMATION_NAME,
        "channels": channels,
        "samplers": samplers,
    })];
    animations.extend(other_animations);
    let mut root = Map::new();
    root.insert("asset".into(), asset);
    root.insert("scene".into(), json!(0));
    root.insert(
        "scenes".into(),
        json!([{"name": "ragdoll scene", "nodes": scene_nodes}]),
    );
    // glTF forbids empty top-level arrays: only those with entries are written.
    for (key, values) in [
        ("nodes", out.nodes),
        ("meshes", out.meshes),
        ("skins", out.skins),
        ("materials", out.materials),
        ("textures", out.textures),
        ("images", out.images),
        ("samplers", out.samplers),
        ("cameras", out.cameras),
        ("animations", animations),
        ("accessors", out.accessors),
        ("bufferViews", out.buffer_views),
    ] {
        if !values.is_empty() {
            root.insert(key.into(), Value::Array(values));
        }
    }
    root.insert("buffers".into(), json!([{"byteLength": data.len()}]));
    if !used.is_empty() {
        root.insert("extensionsUsed".into(), Value::Array(used));
    }
    if !required.is_empty() {
        root.insert("extensionsRequired".into(), Value::Array(required));
    }
    if !root_extensions.is_empty() {
        root.insert("extensions".into(), Value::Object(root_extensions));
    }
    Ok((Value::Object(root), data))
}

fn take_array_value(v: &mut Value, key: &str) -> Vec<Value> {
    match v.as_object_mut() {
        Some(m) => take(m, key),
        None => Vec::new(),
    }
}
