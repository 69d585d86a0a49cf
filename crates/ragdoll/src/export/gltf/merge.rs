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
    let mut merged = Merged::default();
    for (root, bin) in docs {
        let Value::Object(doc) = root else {
            continue; // the exporter only builds objects
        };
        merged.add(doc, &bin);
    }
    Ok(merged.finish())
}

/// The documents merged so far, gathered until every one is in and the root can be built.
#[derive(Default)]
struct Merged {
    out: Arrays,
    data: Vec<u8>,
    /// Every document's `ragdoll` animation becomes one, so it is gathered apart from the
    /// other animations.
    channels: Vec<Value>,
    samplers: Vec<Value>,
    other_animations: Vec<Value>,
    scene_nodes: Vec<Value>,
    used: Vec<Value>,
    required: Vec<Value>,
    root_extensions: Map<String, Value>,
    copyrights: Vec<String>,
}

impl Merged {
    /// Moves one document's entries into the merged ones. The offsets are taken before any
    /// of its entries go in, so its indices move past the documents before it only.
    fn add(&mut self, mut doc: Map<String, Value>, bin: &[u8]) {
        let o = self.append_binary(bin);
        let out = &mut self.out;
        merge_buffer_views(&mut doc, o, out);
        merge_accessors(&mut doc, o, out);
        merge_images(&mut doc, o, out);
        out.samplers.extend(take(&mut doc, "samplers"));
        out.cameras.extend(take(&mut doc, "cameras"));
        merge_textures(&mut doc, o, out);
        merge_materials(&mut doc, o, out);
        merge_meshes(&mut doc, o, out);
        merge_nodes(&mut doc, o, out, &mut self.scene_nodes);
        merge_skins(&mut doc, o, out);
        self.merge_animations(&mut doc, o);
        self.merge_extensions(&mut doc);
        self.merge_copyright(&doc);
    }

    /// Appends a document's binary chunk, 4-byte aligned (glTF requires accessor data to be
    /// aligned to its component size), and returns where its entries and bytes start.
    fn append_binary(&mut self, bin: &[u8]) -> Offsets {
        pad_to_4(&mut self.data, 0);
        let out = &self.out;
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
            bytes: self.data.len(),
        };
        self.data.extend_from_slice(bin);
        o
    }

    /// The first animation (the `ragdoll` one) joins the merged `ragdoll` animation; any
    /// others are kept as animations of their own.
    fn merge_animations(&mut self, doc: &mut Map<String, Value>, o: Offsets) {
        for (k, mut anim) in take(doc, "animations").into_iter().enumerate() {
            if let Some(Value::Array(ss)) = anim.get_mut("samplers") {
                for s in ss {
                    shift(s, "input", o.accessors);
                    shift(s, "output", o.accessors);
                }
            }
            // The ragdoll animation's samplers move into the merged one: shift its channels
            // past the samplers already there.
            let by = if k == 0 { self.samplers.len() } else { 0 };
            if let Some(Value::Array(cs)) = anim.get_mut("channels") {
                for c in cs {
                    shift(c, "sampler", by);
                    if let Some(t) = c.get_mut("target") {
                        shift(t, "node", o.nodes);
                    }
                }
            }
            if k == 0 {
                self.samplers
                    .extend(take_array_value(&mut anim, "samplers"));
                self.channels
                    .extend(take_array_value(&mut anim, "channels"));
            } else {
                self.other_animations.push(anim);
            }
        }
    }

    /// Lights and material variants are arrays indexed like top-level ones, so they are
    /// concatenated; any other root extension is kept from the first document that has it.
    fn merge_extensions(&mut self, doc: &mut Map<String, Value>) {
        union(&mut self.used, take(doc, "extensionsUsed"));
        union(&mut self.required, take(doc, "extensionsRequired"));
        let Some(Value::Object(exts)) = doc.remove("extensions") else {
            return;
        };
        for (name, mut ext) in exts {
            match name.as_str() {
                "KHR_lights_punctual" => {
                    self.out.lights.extend(take_array_value(&mut ext, "lights"));
                }
                "KHR_materials_variants" => {
                    self.out
                        .variants
                        .extend(take_array_value(&mut ext, "variants"));
                }
                _ => {
                    self.root_extensions.entry(name).or_insert(ext);
                }
            }
        }
    }

    fn merge_copyright(&mut self, doc: &Map<String, Value>) {
        if let Some(c) = doc
            .get("asset")
            .and_then(|a| a.get("copyright"))
            .and_then(Value::as_str)
            && !self.copyrights.iter().any(|x| x == c)
        {
            self.copyrights.push(c.to_string());
        }
    }

    /// The merged document and binary chunk.
    fn finish(mut self) -> (Value, Vec<u8>) {
        self.lights_and_variants_to_extensions();
        let asset = self.asset();
        let mut animations = vec![json!({
            "name": ANIMATION_NAME,
            "channels": self.channels,
            "samplers": self.samplers,
        })];
        animations.extend(self.other_animations);
        let mut root = Map::new();
        root.insert("asset".into(), asset);
        root.insert("scene".into(), json!(0));
        root.insert(
            "scenes".into(),
            json!([{"name": "ragdoll scene", "nodes": self.scene_nodes}]),
        );
        insert_arrays(&mut root, self.out, animations);
        root.insert("buffers".into(), json!([{"byteLength": self.data.len()}]));
        if !self.used.is_empty() {
            root.insert("extensionsUsed".into(), Value::Array(self.used));
        }
        if !self.required.is_empty() {
            root.insert("extensionsRequired".into(), Value::Array(self.required));
        }
        if !self.root_extensions.is_empty() {
            root.insert("extensions".into(), Value::Object(self.root_extensions));
        }
        (Value::Object(root), self.data)
    }

    fn lights_and_variants_to_extensions(&mut self) {
        if !self.out.lights.is_empty() {
            self.root_extensions.insert(
                "KHR_lights_punctual".into(),
                json!({"lights": std::mem::take(&mut self.out.lights)}),
            );
        }
        if !self.out.variants.is_empty() {
            self.root_extensions.insert(
                "KHR_materials_variants".into(),
                json!({"variants": std::mem::take(&mut self.out.variants)}),
            );
        }
    }

    fn asset(&self) -> Value {
        let mut asset = json!({"version": "2.0", "generator": generator()});
        if !self.copyrights.is_empty() {
            // Several sources may each ask for credit (CC-BY): keep every notice.
            asset["copyright"] = json!(self.copyrights.join("; "));
        }
        asset
    }
}

/// Every document's views point into its own buffer 0: in the merged one they point past
/// the documents before it.
fn merge_buffer_views(doc: &mut Map<String, Value>, o: Offsets, out: &mut Arrays) {
    for mut v in take(doc, "bufferViews") {
        let offset = v.get("byteOffset").and_then(Value::as_u64).unwrap_or(0) as usize;
        v["buffer"] = json!(0);
        v["byteOffset"] = json!(offset + o.bytes);
        out.buffer_views.push(v);
    }
}

fn merge_accessors(doc: &mut Map<String, Value>, o: Offsets, out: &mut Arrays) {
    for mut a in take(doc, "accessors") {
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
}

fn merge_images(doc: &mut Map<String, Value>, o: Offsets, out: &mut Arrays) {
    for mut image in take(doc, "images") {
        shift(&mut image, "bufferView", o.buffer_views);
        out.images.push(image);
    }
}

fn merge_textures(doc: &mut Map<String, Value>, o: Offsets, out: &mut Arrays) {
    for mut t in take(doc, "textures") {
        shift(&mut t, "sampler", o.samplers);
        shift(&mut t, "source", o.images);
        // EXT_texture_webp, KHR_texture_basisu, MSFT_texture_dds: another image source.
        if let Some(Value::Object(exts)) = t.get_mut("extensions") {
            exts.values_mut().for_each(|e| shift(e, "source", o.images));
        }
        out.textures.push(t);
    }
}

fn merge_materials(doc: &mut Map<String, Value>, o: Offsets, out: &mut Arrays) {
    for mut m in take(doc, "materials") {
        shift_texture_infos(&mut m, o.textures);
        out.materials.push(m);
    }
}

fn merge_meshes(doc: &mut Map<String, Value>, o: Offsets, out: &mut Arrays) {
    for mut mesh in take(doc, "meshes") {
        if let Some(Value::Array(prims)) = mesh.get_mut("primitives") {
            prims.iter_mut().for_each(|p| shift_primitive(p, o));
        }
        out.meshes.push(mesh);
    }
}

fn shift_primitive(p: &mut Value, o: Offsets) {
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
        return;
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

/// Also adds the document's scene roots to the merged scene, so every character shows.
fn merge_nodes(
    doc: &mut Map<String, Value>,
    o: Offsets,
    out: &mut Arrays,
    scene_nodes: &mut Vec<Value>,
) {
    let nodes = take(doc, "nodes");
    for mut n in scene_roots(doc, &nodes) {
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
}

fn merge_skins(doc: &mut Map<String, Value>, o: Offsets, out: &mut Arrays) {
    for mut s in take(doc, "skins") {
        shift_all(&mut s, "joints", o.nodes);
        shift(&mut s, "skeleton", o.nodes);
        shift(&mut s, "inverseBindMatrices", o.accessors);
        out.skins.push(s);
    }
}

/// Writes the merged top-level arrays; glTF forbids empty top-level arrays: only those
/// with entries are written.
fn insert_arrays(root: &mut Map<String, Value>, out: Arrays, animations: Vec<Value>) {
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
}

fn take_array_value(v: &mut Value, key: &str) -> Vec<Value> {
    match v.as_object_mut() {
        Some(m) => take(m, key),
        None => Vec::new(),
    }
}
