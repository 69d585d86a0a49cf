//! The inputs: a valid skinned character built in code, and each defect real files carry
//! as a change to it.

use serde_json::{Value, json};

pub fn f32s(vals: &[f32]) -> Vec<u8> {
    vals.iter().flat_map(|v| v.to_le_bytes()).collect()
}

/// A 1×1 PNG.
const PNG: &[u8] = &[
    0x89, 0x50, 0x4E, 0x47, 0x0D, 0x0A, 0x1A, 0x0A, 0x00, 0x00, 0x00, 0x0D, 0x49, 0x48, 0x44, 0x52,
    0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x01, 0x08, 0x06, 0x00, 0x00, 0x00, 0x1F, 0x15, 0xC4,
    0x89, 0x00, 0x00, 0x00, 0x0D, 0x49, 0x44, 0x41, 0x54, 0x78, 0x9C, 0x63, 0xF8, 0xCF, 0xC0, 0xF0,
    0x1F, 0x00, 0x05, 0x00, 0x01, 0xFF, 0x89, 0x99, 0x3D, 0x1D, 0x00, 0x00, 0x00, 0x00, 0x49, 0x45,
    0x4E, 0x44, 0xAE, 0x42, 0x60, 0x82,
];

/// A valid skinned character: an `Armature` node over the joints `hip` and `top` (and a
/// prop node), a textured quad and triangle skinned to them, and an animation `wave` of
/// its own on `top` and the prop. JSON and binary chunk.
pub fn base() -> (Value, Vec<u8>) {
    #[rustfmt::skip]
    let pos = f32s(&[
        0.0, 1.0, 0.0,  0.2, 1.0, 0.0,  0.2, 1.4, 0.0,  0.0, 1.4, 0.0,
        0.5, 1.0, 0.0,  0.6, 1.0, 0.0,  0.5, 1.1, 0.0,
    ]);
    let weights = f32s(&[1.0, 0.0, 0.0, 0.0].repeat(7));
    let joints: Vec<u8> = [0u16, 1, 0, 0]
        .repeat(7)
        .iter()
        .flat_map(|j| j.to_le_bytes())
        .collect();
    let idx: Vec<u8> = [0u16, 1, 2, 0, 2, 3, 4, 5, 6]
        .iter()
        .flat_map(|i| i.to_le_bytes())
        .collect();
    let times = f32s(&[0.0, 0.5, 1.0]);
    let (a, b) = (0.2f32.sin(), 0.2f32.cos());
    let rotations = f32s(&[0.0, 0.0, 0.0, 1.0, 0.0, a, 0.0, b, 0.0, 0.0, 0.0, 1.0]);
    let moves = f32s(&[0.0, 0.5, 0.0, 0.1, 0.5, 0.0, 0.0, 0.5, 0.0]);
    let uvs = f32s(&[0.0; 14]);
    let mut bin = Vec::new();
    let mut views = Vec::new();
    for part in [
        &pos, &weights, &joints, &idx, &times, &rotations, &moves, PNG, &uvs,
    ] {
        views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": part.len()}));
        bin.extend_from_slice(part);
        bin.resize(bin.len().next_multiple_of(4), 0);
    }
    let json = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 3]}],
        "nodes": [
            {"name": "Armature", "children": [1, 4]},
            {"name": "hip", "translation": [0.0, 1.0, 0.0], "children": [2]},
            {"name": "top", "translation": [0.0, 0.5, 0.0]},
            {"name": "body", "mesh": 0, "skin": 0},
            {"name": "prop", "translation": [0.3, 0.0, 0.0]}
        ],
        "skins": [{"joints": [1, 2], "skeleton": 0}],
        "meshes": [{"name": "body", "primitives": [{
            "attributes": {"POSITION": 0, "WEIGHTS_0": 1, "JOINTS_0": 2, "TEXCOORD_0": 7},
            "indices": 3,
            "material": 0
        }]}],
        "materials": [{
            "name": "skin",
            "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "baseColorFactor": [0.8, 0.6, 0.5, 1.0]}
        }],
        "textures": [{"source": 0, "sampler": 0}],
        "samplers": [{"magFilter": 9729}],
        "images": [{"bufferView": 7, "mimeType": "image/png"}],
        "animations": [{
            "name": "wave",
            "channels": [
                {"sampler": 0, "target": {"node": 2, "path": "rotation"}},
                {"sampler": 1, "target": {"node": 2, "path": "translation"}},
                {"sampler": 1, "target": {"node": 4, "path": "translation"}}
            ],
            "samplers": [{"input": 4, "output": 5}, {"input": 4, "output": 6}]
        }],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 7, "type": "VEC3",
             "min": [0.0, 1.0, 0.0], "max": [0.6, 1.4, 0.0]},
            {"bufferView": 1, "componentType": 5126, "count": 7, "type": "VEC4"},
            {"bufferView": 2, "componentType": 5123, "count": 7, "type": "VEC4"},
            {"bufferView": 3, "componentType": 5123, "count": 9, "type": "SCALAR"},
            {"bufferView": 4, "componentType": 5126, "count": 3, "type": "SCALAR",
             "min": [0.0], "max": [1.0]},
            {"bufferView": 5, "componentType": 5126, "count": 3, "type": "VEC4"},
            {"bufferView": 6, "componentType": 5126, "count": 3, "type": "VEC3"},
            {"bufferView": 8, "componentType": 5126, "count": 7, "type": "VEC2"}
        ],
        "bufferViews": views,
        "buffers": [{"byteLength": bin.len()}]
    });
    (json, bin)
}

/// Appends `bytes` as a new buffer view and returns its index.
pub fn push_view(json: &mut Value, bin: &mut Vec<u8>, bytes: &[u8]) -> usize {
    bin.resize(bin.len().next_multiple_of(4), 0);
    let views = json["bufferViews"].as_array_mut().unwrap();
    views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len()}));
    let view = views.len() - 1;
    bin.extend_from_slice(bytes);
    json["buffers"][0]["byteLength"] = json!(bin.len());
    view
}

/// Appends an accessor and returns its index.
pub fn push_accessor(json: &mut Value, accessor: Value) -> usize {
    let a = json["accessors"].as_array_mut().unwrap();
    a.push(accessor);
    a.len() - 1
}

/// One defect as real files carry it: a name, what it does to [`base`], and what the one
/// warning about its repair must say.
pub struct Defect {
    pub name: &'static str,
    pub apply: fn(&mut Value, &mut Vec<u8>),
    pub warning: &'static [&'static str],
}

/// Every defect, each a change to [`base`].
pub fn defects() -> Vec<Defect> {
    let mut all = tree_defects();
    all.extend(motion_and_skin_defects());
    all
}

/// Defects of the node tree, the references and the header.
fn tree_defects() -> Vec<Defect> {
    vec![
        Defect {
            name: "skeleton_not_a_common_root",
            apply: |j, _| j["skins"][0]["skeleton"] = json!(2),
            warning: &["skins[0].skeleton", "node 2 (\"top\")", "node 1 (\"hip\")"],
        },
        Defect {
            name: "joints_without_common_root",
            apply: |j, _| {
                let nodes = j["nodes"].as_array_mut().unwrap();
                nodes.push(json!({"name": "sword", "translation": [1.0, 0.0, 0.0]}));
                let sword = nodes.len() - 1;
                // A second skin (a prop's) over the character's `top` and the sword.
                let skins = j["skins"].as_array_mut().unwrap();
                skins.push(json!({"joints": [2, sword], "skeleton": 2}));
                let scene = j["scenes"][0]["nodes"].as_array_mut().unwrap();
                scene.push(json!(sword));
            },
            warning: &[
                "separate roots",
                "skins[1]",
                "now its skeleton (was 2)",
                "node 0 (\"Armature\"), node 5 (\"sword\")",
                "new node 6",
            ],
        },
        Defect {
            name: "dangling_references",
            apply: |j, _| {
                j["meshes"][0]["primitives"][0]["material"] = json!(5);
                j["materials"]
                    .as_array_mut()
                    .unwrap()
                    .push(json!({"normalTexture": {"index": 9}}));
                j["textures"]
                    .as_array_mut()
                    .unwrap()
                    .push(json!({"source": 4, "sampler": 3}));
            },
            warning: &[
                "4 references",
                "meshes[0].primitives[0].material (material 5)",
                "materials[1].normalTexture (texture 9)",
                "textures[1].source (image 4)",
                "textures[1].sampler (sampler 3)",
            ],
        },
        Defect {
            name: "undeclared_extensions",
            apply: |j, _| {
                j["materials"][0]["emissiveFactor"] = json!([1.0, 0.5, 0.0]);
                j["materials"][0]["extensions"] =
                    json!({"KHR_materials_emissive_strength": {"emissiveStrength": 2.0}});
                j["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["extensions"] =
                    json!({"KHR_texture_transform": {"scale": [2.0, 2.0]}});
                j["extensionsUsed"] = json!(["KHR_texture_transform", "KHR_texture_transform"]);
                j["extensionsRequired"] = json!(["KHR_texture_transform"]);
            },
            warning: &["extensionsUsed", "KHR_materials_emissive_strength"],
        },
        Defect {
            name: "version",
            apply: |j, _| j["asset"] = json!({"version": "2.0", "minVersion": "2.5"}),
            warning: &["asset.minVersion", "2.5"],
        },
        Defect {
            name: "scene_lists_non_roots",
            apply: |j, _| j["scenes"][0]["nodes"] = json!([0, 3, 2, 3]),
            warning: &["scenes[0].nodes", "node 2 (\"top\")"],
        },
    ]
}

/// Defects of rotations, animation keys and skin influences.
fn motion_and_skin_defects() -> Vec<Defect> {
    vec![
        Defect {
            name: "keyframe_times_not_increasing",
            apply: |j, bin| {
                let v = push_view(j, bin, &f32s(&[0.0, 0.5, 0.5]));
                let a = push_accessor(
                    j,
                    json!({"bufferView": v, "componentType": 5126, "count": 3, "type": "SCALAR", "min": [0.0], "max": [0.5]}),
                );
                j["animations"][0]["samplers"][1]["input"] = json!(a);
            },
            warning: &[
                "keyframe times",
                "animation 0 (\"wave\")",
                "accessor 8",
                "2 channels",
            ],
        },
        Defect {
            name: "node_rotations_not_unit",
            apply: |j, _| {
                j["nodes"][2]["rotation"] = json!([0.0, 0.0, 0.0, 0.0]);
                j["nodes"][4]["rotation"] = json!([0.0, 0.5, 0.0, 0.5]);
            },
            warning: &["nodes[2].rotation", "nodes[4].rotation"],
        },
        Defect {
            name: "animation_rotations_not_unit",
            apply: |j, bin| {
                let (a, b) = (0.2f32.sin(), 0.2f32.cos());
                let v = push_view(
                    j,
                    bin,
                    &f32s(&[
                        0.0,
                        0.0,
                        0.0,
                        0.0,
                        0.0,
                        2.0 * a,
                        0.0,
                        2.0 * b,
                        0.0,
                        0.0,
                        0.0,
                        1.0,
                    ]),
                );
                j["accessors"][5]["bufferView"] = json!(v);
            },
            warning: &[
                "rotation keys",
                "animation 0 (\"wave\")",
                "accessor 5",
                "2 of 3",
            ],
        },
        Defect {
            name: "joints_without_weights",
            apply: |j, _| j["meshes"][0]["primitives"][0]["attributes"]["JOINTS_7"] = json!(2),
            warning: &["JOINTS_7", "meshes[0].primitives[0]"],
        },
    ]
}

pub fn glb(json: &Value, bin: &[u8]) -> Vec<u8> {
    let mut j = serde_json::to_vec(json).unwrap();
    j.resize(j.len().next_multiple_of(4), b' ');
    let mut b = bin.to_vec();
    b.resize(b.len().next_multiple_of(4), 0);
    let total = 12 + 8 + j.len() + 8 + b.len();
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
    out
}

/// A GLB's JSON and binary chunk.
pub fn glb_parts(bytes: &[u8]) -> (Value, Vec<u8>) {
    let json_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let json = serde_json::from_slice(&bytes[20..20 + json_len]).unwrap();
    let at = 20 + json_len;
    let len = u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as usize;
    (json, bytes[at + 8..at + 8 + len].to_vec())
}

/// [`base`] with every extension it uses required, as some exporters write them.
pub fn with_accepted_extensions() -> (Value, Vec<u8>) {
    let (mut json, bin) = base();
    json["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["extensions"] =
        json!({"KHR_texture_transform": {"offset": [0.5, 0.0]}});
    json["materials"][0]["extensions"] = json!({"KHR_materials_unlit": {}});
    let used = json!(["KHR_texture_transform", "KHR_materials_unlit"]);
    json["extensionsUsed"] = used.clone();
    json["extensionsRequired"] = used;
    (json, bin)
}
