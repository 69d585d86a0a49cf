//! Inputs as they come: defects a tool can repair are repaired with a
//! warning instead of refusing the file: bad skin weights, missing texture images; and
//! compressed geometry we cannot read is refused in one sentence naming the extension.
//! The inputs are built here, so the tests need no data folder.
//!
//! Set `RAGDOLL_GLTF_OUT=some/dir` to keep the exported files, e.g. to run the Khronos
//! validator on them (`node .ci/gltf_validate.mjs some/dir/*.glb`).

use std::path::{Path, PathBuf};

use ragdoll::import::gltf;
use ragdoll::skeleton::Character;
use ragdoll::spec::RagdollSpec;
use ragdoll::track::Track;
use serde_json::{Value, json};

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("ragdoll-repair-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn keep(name: &str, bytes: &[u8]) {
    if let Some(dir) = std::env::var_os("RAGDOLL_GLTF_OUT") {
        let dir = PathBuf::from(dir);
        std::fs::create_dir_all(&dir).unwrap();
        ragdoll::export::write_atomic(&dir.join(name), bytes).unwrap();
    }
}

fn f32s(vals: &[f32]) -> Vec<u8> {
    vals.iter().flat_map(|v| v.to_le_bytes()).collect()
}

/// A skinned mesh of two joints (`hip` and `top`, 0.5 m above): a quad (vertices 0–3, two
/// triangles) and a loose triangle (4–6) beside it, with the given joints and weights
/// (four per vertex). JSON and binary chunk.
fn skinned(joints: &[u16], weights: &[f32]) -> (Value, Vec<u8>) {
    assert_eq!((joints.len(), weights.len()), (28, 28));
    #[rustfmt::skip]
    let pos = f32s(&[
        0.0, 1.0, 0.0,  0.2, 1.0, 0.0,  0.2, 1.4, 0.0,  0.0, 1.4, 0.0,
        0.5, 1.0, 0.0,  0.6, 1.0, 0.0,  0.5, 1.1, 0.0,
    ]);
    let idx: Vec<u8> = [0u16, 1, 2, 0, 2, 3, 4, 5, 6]
        .iter()
        .flat_map(|i| i.to_le_bytes())
        .collect();
    let jnt: Vec<u8> = joints.iter().flat_map(|j| j.to_le_bytes()).collect();
    let wgt = f32s(weights);
    let mut bin = Vec::new();
    let mut views = Vec::new();
    for part in [&pos, &wgt, &jnt, &idx] {
        views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": part.len()}));
        bin.extend_from_slice(part);
        bin.resize(bin.len().next_multiple_of(4), 0);
    }
    let json = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 2]}],
        "nodes": [
            {"name": "hip", "translation": [0.0, 1.0, 0.0], "children": [1]},
            {"name": "top", "translation": [0.0, 0.5, 0.0]},
            {"name": "body", "mesh": 0, "skin": 0}
        ],
        "skins": [{"joints": [0, 1]}],
        "meshes": [{"name": "body", "primitives": [{
            "attributes": {"POSITION": 0, "WEIGHTS_0": 1, "JOINTS_0": 2},
            "indices": 3
        }]}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 7, "type": "VEC3",
             "min": [0.0, 1.0, 0.0], "max": [0.6, 1.4, 0.0]},
            {"bufferView": 1, "componentType": 5126, "count": 7, "type": "VEC4"},
            {"bufferView": 2, "componentType": 5123, "count": 7, "type": "VEC4"},
            {"bufferView": 3, "componentType": 5123, "count": 9, "type": "SCALAR"}
        ],
        "bufferViews": views,
        "buffers": [{"byteLength": bin.len()}]
    });
    (json, bin)
}

fn glb(json: &Value, bin: &[u8]) -> Vec<u8> {
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

fn glb_json(bytes: &[u8]) -> Value {
    let len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    serde_json::from_slice(&bytes[20..20 + len]).unwrap()
}

fn no_spec(name: &str) -> RagdollSpec {
    RagdollSpec {
        format_version: ragdoll::spec::SPEC_FORMAT_VERSION,
        name: name.into(),
        bodies: Vec::new(),
        joints: Vec::new(),
        collision: Default::default(),
    }
}

/// The character baked for one frame in its rest pose: enough for the exporter.
fn export(c: &Character) -> Vec<u8> {
    let track = Track {
        fps: 30.0,
        frames: vec![c.skeleton.rest_world(); 2],
    };
    ragdoll::export::gltf::to_glb(c, &no_spec(&c.name), &track).unwrap()
}

/// Each vertex's (skeleton joint, weight) pairs with weight, sorted by joint.
fn influences(c: &Character) -> Vec<Vec<(u16, f32)>> {
    let m = &c.meshes[0];
    m.joints
        .iter()
        .zip(&m.weights)
        .map(|(j, w)| {
            let mut v: Vec<(u16, f32)> = (0..4)
                .filter(|&k| w[k] > 0.0)
                .map(|k| (j[k], w[k]))
                .collect();
            v.sort_by_key(|x| x.0);
            v
        })
        .collect()
}

fn assert_close(got: &[(u16, f32)], want: &[(u16, f32)], what: &str) {
    assert_eq!(got.len(), want.len(), "{what}: {got:?} != {want:?}");
    for (g, w) in got.iter().zip(want) {
        assert!(
            g.0 == w.0 && (g.1 - w.1).abs() < 1e-6,
            "{what}: {got:?} != {want:?}"
        );
    }
}

#[test]
fn bad_skin_weights_are_repaired_with_one_warning_naming_the_accessor() {
    let nan = f32::NAN;
    #[rustfmt::skip]
    let (joints, weights) = (
        [
            0, 1, 0, 0,   // 0: a NaN beside a good weight on `top`
            0, 1, 0, 0,   // 1: all zero: takes a neighbour's
            0, 1, 0, 0,   // 2: sums to 0.7, renormalised
            9, 0, 0, 0,   // 3: only a joint past the skin: takes a neighbour's
            0, 0, 0, 0,   // 4-6: a loose triangle with no usable weight: the root
            1, 0, 0, 0,
            0, 0, 0, 0,
        ],
        [
            nan, 1.0, 0.0, 0.0,
            0.0, 0.0, 0.0, 0.0,
            0.5, 0.2, 0.0, 0.0,
            1.0, 0.0, 0.0, 0.0,
            -1.0, 0.0, 0.0, 0.0,
            f32::INFINITY, 0.0, 0.0, 0.0,
            0.0, 0.0, 0.0, 0.0,
        ],
    );
    let (json, bin) = skinned(&joints, &weights);
    let c = gltf::from_bytes(&glb(&json, &bin), Path::new("weights.glb")).unwrap();
    assert_eq!(c.warnings.len(), 1, "{:?}", c.warnings);
    let w = &c.warnings[0];
    for says in [
        "mesh \"body\" primitive 0",
        "JOINTS_0 accessor 2",
        "WEIGHTS_0 accessor 1",
        "7 of 7 vertices",
        "3 had a NaN, infinite or negative weight",
        "1 named a joint past the skin's 2",
        "1 had weights that did not sum to 1",
        "2 were left with no weight and now follow their nearest weighted neighbour",
        "3 were on a part with no weight at all and now follow the root joint \"hip\"",
    ] {
        assert!(w.contains(says), "{says:?} not in {w}");
    }
    assert!(!w.contains('\n'));
    let (hip, top) = (
        c.skeleton.find("hip").unwrap() as u16,
        c.skeleton.find("top").unwrap() as u16,
    );
    let got = influences(&c);
    assert_close(&got[0], &[(top, 1.0)], "vertex 0");
    assert_close(&got[2], &[(hip, 0.5 / 0.7), (top, 0.2 / 0.7)], "vertex 2");
    // Vertex 1 touches 0 and 2 (both weighted, one edge away): the lower index wins.
    assert_close(&got[1], &got[0].clone(), "vertex 1");
    // Vertex 3 touches 0 and 2 as well.
    assert_close(&got[3], &got[0].clone(), "vertex 3");
    for (v, infl) in got.iter().enumerate().skip(4) {
        assert_close(infl, &[(hip, 1.0)], &format!("vertex {v}"));
    }
    assert!(c.meshes[0].positions.iter().all(|p| p.is_finite()));

    // The exported file carries the repaired weights: read back, it needs no repair and
    // has the same influences.
    let out = export(&c);
    keep("repaired_weights.glb", &out);
    let back = gltf::from_bytes(&out, Path::new("back.glb")).unwrap();
    assert!(back.warnings.is_empty(), "{:?}", back.warnings);
    for (v, (a, b)) in got.iter().zip(influences(&back)).enumerate() {
        assert_close(a, &b, &format!("vertex {v} read back"));
    }
}

#[test]
fn good_weights_and_rounding_errors_give_no_warning() {
    #[rustfmt::skip]
    let weights = [
        1.0, 0.0, 0.0, 0.0,   0.5, 0.5, 0.0, 0.0,   0.3, 0.3, 0.0, 0.0,   0.995, 0.0, 0.0, 0.0,
        1.0, 0.0, 0.0, 0.0,   1.0, 0.0, 0.0, 0.0,   0.5, 0.504, 0.0, 0.0,
    ];
    let joints = [0u16, 1, 0, 0].repeat(7);
    let (json, bin) = skinned(&joints, &weights);
    let c = gltf::from_bytes(&glb(&json, &bin), Path::new("fine.glb")).unwrap();
    // Vertex 2 sums to 0.6: that one is a repair; 0.995 and 1.004 are rounding.
    assert_eq!(c.warnings.len(), 1, "{:?}", c.warnings);
    assert!(
        c.warnings[0].contains("1 of 7 vertices (1 had weights that did not sum to 1"),
        "{}",
        c.warnings[0]
    );
    let clean = [1.0, 0.0, 0.0, 0.0].repeat(7);
    let (json, bin) = skinned(&joints, &clean);
    let c = gltf::from_bytes(&glb(&json, &bin), Path::new("clean.glb")).unwrap();
    assert!(c.warnings.is_empty(), "{:?}", c.warnings);
}

#[test]
fn joint_indices_far_past_the_skin_never_panic() {
    for j in [2u16, 255, 256, 65535] {
        let joints = [j, j, j, j].repeat(7);
        let (json, bin) = skinned(&joints, &[0.25; 28]);
        let c = gltf::from_bytes(&glb(&json, &bin), Path::new("oob.glb")).unwrap();
        assert_eq!(c.warnings.len(), 1, "{:?}", c.warnings);
        assert!(c.warnings[0].contains("7 named a joint past the skin's 2"));
        assert!(influences(&c).iter().all(|v| v == &[(0, 1.0)]));
        let back = gltf::from_bytes(&export(&c), Path::new("back.glb")).unwrap();
        assert!(back.warnings.is_empty(), "{:?}", back.warnings);
    }
}

/// The skinned file as a .gltf in `dir` with its buffer beside it, a material with two
/// textures, and `images` as its images.
fn textured_gltf(dir: &Path, images: Value) -> PathBuf {
    let (mut json, bin) = skinned(&[0, 0, 0, 0].repeat(7), &[1.0, 0.0, 0.0, 0.0].repeat(7));
    json["buffers"][0]["uri"] = json!("buffer.bin");
    json["images"] = images;
    json["samplers"] = json!([{}]);
    json["textures"] = json!([{"source": 0, "sampler": 0}, {"source": 1, "sampler": 0}]);
    json["materials"] = json!([{
        "name": "skin",
        "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "baseColorFactor": [0.8, 0.6, 0.5, 1.0]},
        "normalTexture": {"index": 1}
    }]);
    json["meshes"][0]["primitives"][0]["material"] = json!(0);
    // Texture coordinates, all zero, so the material's textures are used.
    json["accessors"]
        .as_array_mut()
        .unwrap()
        .push(json!({"bufferView": 4, "componentType": 5126, "count": 7, "type": "VEC2"}));
    json["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = json!(4);
    let uv_at = bin.len();
    let mut bin = bin;
    bin.extend_from_slice(&f32s(&[0.0; 14]));
    std::fs::write(dir.join("buffer.bin"), &bin).unwrap();
    json["buffers"][0]["byteLength"] = json!(bin.len());
    json["bufferViews"]
        .as_array_mut()
        .unwrap()
        .push(json!({"buffer": 0, "byteOffset": uv_at, "byteLength": 56}));
    let path = dir.join("model.gltf");
    std::fs::write(&path, serde_json::to_vec(&json).unwrap()).unwrap();
    path
}

/// A 1×1 PNG.
const PNG: &[u8] = &[
    0x89, 0x50, 0x4E, 0x47, 0x0D, 0x0A, 0x1A, 0x0A, 0x00, 0x00, 0x00, 0x0D, 0x49, 0x48, 0x44, 0x52,
    0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x01, 0x08, 0x06, 0x00, 0x00, 0x00, 0x1F, 0x15, 0xC4,
    0x89, 0x00, 0x00, 0x00, 0x0D, 0x49, 0x44, 0x41, 0x54, 0x78, 0x9C, 0x63, 0xF8, 0xCF, 0xC0, 0xF0,
    0x1F, 0x00, 0x05, 0x00, 0x01, 0xFF, 0x89, 0x99, 0x3D, 0x1D, 0x00, 0x00, 0x00, 0x00, 0x49, 0x45,
    0x4E, 0x44, 0xAE, 0x42, 0x60, 0x82,
];

#[test]
fn a_missing_texture_image_is_a_warning_and_the_bake_goes_on_without_it() {
    let dir = scratch("images");
    std::fs::write(dir.join("normal.png"), PNG).unwrap();
    let images =
        json!([{"name": "albedo", "uri": "textures/albedo%20map.png"}, {"uri": "normal.png"}]);
    let path = textured_gltf(&dir, images);
    let c = gltf::load(&path).unwrap();
    assert_eq!(c.warnings.len(), 1, "{:?}", c.warnings);
    let w = &c.warnings[0];
    assert!(
        w.starts_with("image 0 (\"albedo\"): the URI \"textures/albedo%20map.png\" cannot be read")
            && w.contains("leaves it out"),
        "{w}"
    );
    let out = export(&c);
    keep("missing_image.glb", &out);
    let doc = glb_json(&out);
    // The present image is embedded; the missing one and its texture are gone, and the
    // material keeps its colour and its other texture, renumbered.
    assert_eq!(doc["images"].as_array().unwrap().len(), 1);
    assert_eq!(doc["images"][0]["mimeType"], "image/png");
    assert!(doc["images"][0].get("uri").is_none());
    assert_eq!(doc["textures"], json!([{"source": 0, "sampler": 0}]));
    let m = &doc["materials"][0];
    assert!(m["pbrMetallicRoughness"].get("baseColorTexture").is_none());
    assert_eq!(m["pbrMetallicRoughness"]["baseColorFactor"][0], 0.8);
    assert_eq!(m["normalTexture"], json!({"index": 0}));
    // The file reads back, with nothing left to warn about.
    let back = gltf::from_bytes(&out, &dir.join("back.glb")).unwrap();
    assert!(back.warnings.is_empty(), "{:?}", back.warnings);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn images_outside_the_folder_are_still_refused_not_forgiven() {
    let root = scratch("outside");
    let dir = root.join("model");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(root.join("secret.png"), PNG).unwrap();
    for uri in ["../secret.png", "../nowhere.png", "/nowhere.png"] {
        let path = textured_gltf(&dir, json!([{"uri": uri}, {"uri": uri}]));
        let c = gltf::load(&path).unwrap();
        assert!(c.warnings.is_empty(), "{uri}: {:?}", c.warnings);
        let text = ragdoll::export::gltf::to_glb(
            &c,
            &no_spec("m"),
            &Track {
                fps: 30.0,
                frames: vec![c.skeleton.rest_world()],
            },
        )
        .unwrap_err()
        .to_string();
        assert!(text.contains("image 0") && text.contains(uri), "{text}");
    }
    std::fs::remove_dir_all(&root).unwrap();
}

#[test]
fn compressed_geometry_is_refused_in_one_sentence_naming_the_extension() {
    for ext in ["KHR_draco_mesh_compression", "EXT_meshopt_compression"] {
        let (mut json, bin) = skinned(&[0, 0, 0, 0].repeat(7), &[1.0, 0.0, 0.0, 0.0].repeat(7));
        json["extensionsUsed"] = json!([ext]);
        json["extensionsRequired"] = json!([ext]);
        let e = gltf::from_bytes(&glb(&json, &bin), Path::new("packed.glb")).unwrap_err();
        let text = e.to_string();
        assert!(
            text.contains(ext) && text.contains("packed.glb") && !text.contains('\n'),
            "{text}"
        );
    }
}

/// The binary chunk of a GLB.
fn glb_bin(bytes: &[u8]) -> &[u8] {
    let json_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let at = 20 + json_len;
    let len = u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as usize;
    &bytes[at + 8..at + 8 + len]
}

#[test]
fn normals_off_unit_length_are_written_at_unit_length() {
    let joints = [0u16, 1, 0, 0].repeat(7);
    let (mut json, mut bin) = skinned(&joints, &[1.0, 0.0, 0.0, 0.0].repeat(7));
    // Twice too long, a little short, zero, and unit ones: as exporters write them.
    #[rustfmt::skip]
    let normals = f32s(&[
        0.0, 0.0, 2.0,  0.0, 0.0, 0.99,  0.0, 0.0, 0.0,  0.0, 0.0, 1.0,
        0.6, 0.0, 0.8,  0.0, 1.0, 0.0,   0.0, 0.0, 1.0,
    ]);
    let view = json["bufferViews"].as_array().unwrap().len();
    json["bufferViews"]
        .as_array_mut()
        .unwrap()
        .push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": normals.len()}));
    bin.extend_from_slice(&normals);
    json["buffers"][0]["byteLength"] = json!(bin.len());
    let acc = json["accessors"].as_array().unwrap().len();
    json["accessors"]
        .as_array_mut()
        .unwrap()
        .push(json!({"bufferView": view, "componentType": 5126, "count": 7, "type": "VEC3"}));
    json["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = json!(acc);
    let c = gltf::from_bytes(&glb(&json, &bin), Path::new("normals.glb")).unwrap();
    let out = export(&c);
    keep("normals.glb", &out);
    let (doc, data) = (glb_json(&out), glb_bin(&out));
    let a = &doc["accessors"][doc["meshes"][0]["primitives"][0]["attributes"]["NORMAL"]
        .as_u64()
        .unwrap() as usize];
    let v = &doc["bufferViews"][a["bufferView"].as_u64().unwrap() as usize];
    let start = v["byteOffset"].as_u64().unwrap_or(0) as usize
        + a["byteOffset"].as_u64().unwrap_or(0) as usize;
    let floats: Vec<f32> = data[start..start + 7 * 12]
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
        .collect();
    for (i, n) in floats.chunks_exact(3).enumerate() {
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        assert!((len - 1.0).abs() < 1e-5, "normal {i}: {n:?}");
    }
    // Directions kept: the long one still points along +Z.
    assert!(floats[2] > 0.999, "{floats:?}");
}
