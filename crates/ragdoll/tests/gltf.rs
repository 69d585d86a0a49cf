//! glTF import and export against the sample characters in `../shared/data/gltf`, plus the
//! built-in humanoid and hand-made broken files.
//!
//! Set `RAGDOLL_GLTF_OUT=some/dir` to keep the exported files, e.g. to run
//! `node .ci/gltf_validate.mjs some/dir/*.glb` on them.

mod common;

use std::path::{Path, PathBuf};

use glam::{Quat, Vec3, Vec4};
use ragdoll::error::Error;
use ragdoll::export::gltf::to_glb;
use ragdoll::import::gltf::{from_bytes, load};
use ragdoll::math::Transform;
use ragdoll::skeleton::{Character, Skeleton, Source, humanoid};
use ragdoll::spec::{BodySpec, RagdollSpec, SPEC_FORMAT_VERSION, Shape};
use ragdoll::track::Track;
use serde_json::{Value, json};

fn sample(name: &str) -> PathBuf {
    common::shared_data().join("gltf").join(name)
}

fn samples() -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(common::shared_data().join("gltf"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "glb" || e == "gltf"))
        .collect();
    files.sort();
    assert!(!files.is_empty(), "no glTF files in the data folder");
    files
}

fn keep(name: &str, bytes: &[u8]) {
    if let Some(dir) = std::env::var_os("RAGDOLL_GLTF_OUT") {
        let dir = PathBuf::from(dir);
        std::fs::create_dir_all(&dir).unwrap();
        ragdoll::export::write_atomic(&dir.join(name), bytes).unwrap();
    }
}

fn fk(skeleton: &Skeleton, locals: &[Transform]) -> Vec<Transform> {
    let mut out = vec![Transform::IDENTITY; skeleton.len()];
    skeleton.world_from_local(locals, &mut out);
    out
}

/// A few frames of motion: the character's first clip (or its rest pose) with every joint
/// bent a little more each frame and the root carried along, so that no two frames and no
/// two joints agree by accident.
fn test_track(character: &Character) -> Track {
    let sk = &character.skeleton;
    let rest: Vec<Transform> = sk.joints().iter().map(|j| j.rest).collect();
    let frames = (0..6)
        .map(|f| {
            let mut locals = match character.clips.first() {
                Some(c) => c.frames[f % c.frames.len()].clone(),
                None => rest.clone(),
            };
            for (j, l) in locals.iter_mut().enumerate() {
                let bend = Quat::from_euler(
                    glam::EulerRot::XYZ,
                    0.05 * f as f32 + 0.01 * j as f32,
                    -0.03 * f as f32,
                    0.02 * (j % 3) as f32,
                );
                l.rotation = (l.rotation * bend).normalize();
                if sk.parent(j).is_none() {
                    l.translation += Vec3::new(0.1, -0.05, 0.2) * f as f32;
                }
            }
            fk(sk, &locals)
        })
        .collect();
    Track { fps: 30.0, frames }
}

fn assert_same_worlds(a: &[Transform], b: &[Transform], what: &str) {
    assert_eq!(a.len(), b.len(), "{what}: joint count");
    for (j, (x, y)) in a.iter().zip(b).enumerate() {
        let dt = (x.translation - y.translation).length();
        let tol = 1e-5 * x.translation.length().max(1.0);
        assert!(
            dt <= tol,
            "{what}: joint {j} translation {} vs {} ({dt})",
            x.translation,
            y.translation
        );
        let dq = quat_distance(x.rotation, y.rotation);
        assert!(
            dq <= 1e-5,
            "{what}: joint {j} rotation {} vs {} ({dq})",
            x.rotation,
            y.rotation
        );
    }
}

/// Distance between two rotations as unit quaternions, either sign (unlike
/// `Quat::angle_between`, precise near zero).
fn quat_distance(a: Quat, b: Quat) -> f32 {
    let (a, b) = (glam::Vec4::from(a), glam::Vec4::from(b));
    (a - b).length().min((a + b).length())
}

/// The JSON chunk of a GLB.
fn glb_json(bytes: &[u8]) -> Value {
    assert_eq!(&bytes[..4], b"glTF");
    let len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    serde_json::from_slice(&bytes[20..20 + len]).unwrap()
}

/// The source file's JSON, whatever its container.
fn source_json(character: &Character) -> Value {
    match &character.source {
        Source::Gltf(src) => src.json.clone(),
        _ => panic!("not a glTF character"),
    }
}

fn count(doc: &Value, key: &str) -> usize {
    doc.get(key).and_then(Value::as_array).map_or(0, Vec::len)
}

fn weights_sum_to_one(character: &Character) {
    for m in &character.meshes {
        assert_eq!(m.weights.len(), m.positions.len(), "{}", m.name);
        assert_eq!(m.joints.len(), m.positions.len(), "{}", m.name);
        for (w, j) in m.weights.iter().zip(&m.joints) {
            assert!(
                (w.element_sum() - 1.0).abs() < 1e-5,
                "{}: weights {w} sum to {}",
                m.name,
                w.element_sum()
            );
            assert!(j.iter().all(|&j| (j as usize) < character.skeleton.len()));
        }
        assert!(m.positions.iter().all(|p| p.is_finite()));
        assert!(m.normals.is_empty() || m.normals.len() == m.positions.len());
        assert!(m.indices.iter().all(|&i| (i as usize) < m.positions.len()));
    }
}

#[test]
#[ignore = "needs ../shared/data"]
fn every_sample_imports_with_normalised_weights() {
    for path in samples() {
        let c = load(&path).unwrap_or_else(|e| panic!("{e}"));
        assert!(!c.meshes.is_empty(), "{}", path.display());
        weights_sum_to_one(&c);
        assert!(!c.clips.is_empty(), "{}: no clip", path.display());
        for clip in &c.clips {
            assert!(clip.frame_time > 0.0);
            assert!(
                clip.frames
                    .iter()
                    .all(|f| f.len() == c.skeleton.len() && f.iter().all(Transform::is_finite))
            );
        }
    }
}

#[test]
#[ignore = "needs ../shared/data"]
fn cesium_man_is_19_unnamed_joints_and_one_mesh_standing_up() {
    let path = sample("CesiumMan.glb");
    let c = load(&path).unwrap();
    assert_eq!(c.name, "CesiumMan");
    assert_eq!(c.skeleton.len(), 19);
    assert!(c.skeleton.joints().iter().all(|j| j.name.is_empty()));
    assert_eq!(c.skeleton.joint_label(3), "joint3");
    assert_eq!(c.meshes.len(), 1);
    assert_eq!(c.meshes[0].positions.len(), 3273);
    // The Z-up correction node above the root joint is folded in: the figure stands along
    // +Y (facing X, arms spread along Z in its bind pose).
    let (lo, hi) = c.meshes[0]
        .positions
        .iter()
        .fold((Vec3::MAX, Vec3::MIN), |(lo, hi), p| {
            (lo.min(*p), hi.max(*p))
        });
    let size = hi - lo;
    assert!(size.y > 1.4 && size.y > size.x && size.y > size.z, "{size}");
    assert!(lo.y.abs() < 0.01, "feet at y = {}", lo.y);
    // The skeleton sits inside its mesh: skeleton and skinned rest pose agree.
    let margin = size * 0.05;
    for w in c.skeleton.rest_world() {
        let p = w.translation;
        assert!(
            p.cmpge(lo - margin).all() && p.cmple(hi + margin).all(),
            "joint at {p} outside {lo}..{hi}"
        );
    }
    // The file splits its walk into 19 unnamed animations, one per joint: they are read as
    // the one clip they are, every joint moving.
    assert_eq!(c.clips.len(), 1);
    let clip = &c.clips[0];
    let moving = (0..c.skeleton.len())
        .filter(|&j| {
            clip.frames
                .iter()
                .any(|f| f[j].rotation.angle_between(clip.frames[0][j].rotation) > 0.01)
        })
        .count();
    assert!(moving >= 10, "only {moving} joints move in the walk");
}

#[test]
#[ignore = "needs ../shared/data"]
fn fox_and_simple_skin_have_their_joint_counts() {
    let c = load(&sample("Fox.glb")).unwrap();
    assert_eq!(c.skeleton.len(), 24);
    assert_eq!(c.skeleton.joints()[0].name, "_rootJoint");
    assert!(c.skeleton.find("b_Hip_01").is_some());
    assert_eq!(c.meshes[0].positions.len(), 1728);
    let names: Vec<&str> = c.clips.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["Survey", "Walk", "Run"]);
    let c = load(&sample("SimpleSkin.gltf")).unwrap();
    assert_eq!(c.skeleton.len(), 2);
    assert_eq!(c.skeleton.parent(1), Some(0));
    assert_eq!(c.meshes[0].positions.len(), 10);
    // Rest pose: joint 1 one unit above joint 0 (its node has translation [0, 1, 0]).
    let w = c.skeleton.rest_world();
    assert!((w[1].translation - Vec3::Y).length() < 1e-6);
}

/// Exports `c` with the test track, reads the result back, and checks what must survive.
fn round_trip(c: &Character, spec: &RagdollSpec, file_name: &str) -> Character {
    let track = test_track(c);
    let bytes = to_glb(c, spec, &track).unwrap();
    keep(file_name, &bytes);
    let doc = glb_json(&bytes);
    assert_eq!(doc["animations"][0]["name"], "ragdoll");
    let input = doc["animations"][0]["samplers"][0]["input"]
        .as_u64()
        .unwrap() as usize;
    let last = (track.frames.len() - 1) as f32 / track.fps;
    assert_eq!(doc["accessors"][input]["min"][0].as_f64(), Some(0.0));
    assert_eq!(
        doc["accessors"][input]["max"][0].as_f64().map(|t| t as f32),
        Some(last)
    );
    let back = from_bytes(&bytes, Path::new(file_name)).unwrap();
    assert_eq!(back.skeleton.len(), c.skeleton.len());
    for (a, b) in back.skeleton.joints().iter().zip(c.skeleton.joints()) {
        assert_eq!(a.parent, b.parent);
    }
    let clip = &back.clips[0];
    assert_eq!(clip.name, "ragdoll");
    assert_eq!(clip.frames.len(), track.frames.len());
    assert!(
        (clip.frame_time - 1.0 / 30.0).abs() < 1e-7,
        "{}",
        clip.frame_time
    );
    for (f, frame) in clip.frames.iter().enumerate() {
        let worlds = fk(&back.skeleton, frame);
        assert_same_worlds(&worlds, &track.frames[f], &format!("{file_name} frame {f}"));
    }
    weights_sum_to_one(&back);
    back
}

fn empty_spec(name: &str) -> RagdollSpec {
    RagdollSpec {
        format_version: SPEC_FORMAT_VERSION,
        name: name.into(),
        bodies: Vec::new(),
        joints: Vec::new(),
        collision: Default::default(),
    }
}

#[test]
#[ignore = "needs ../shared/data"]
fn gltf_round_trip_keeps_joint_worlds_and_the_asset() {
    for path in samples() {
        let c = load(&path).unwrap();
        let name = format!("{}.ragdoll.glb", c.name);
        let back = round_trip(&c, &empty_spec(&c.name), &name);
        // Same skeleton rest, same skinned mesh.
        assert_same_worlds(
            &back.skeleton.rest_world(),
            &c.skeleton.rest_world(),
            &format!("{name} rest"),
        );
        assert_eq!(back.meshes.len(), c.meshes.len());
        for (a, b) in back.meshes.iter().zip(&c.meshes) {
            assert_eq!(a.indices, b.indices);
            for (p, q) in a.positions.iter().zip(&b.positions) {
                assert!(
                    (*p - *q).length() < 1e-4 * q.length().max(1.0),
                    "{name}: {p} vs {q}"
                );
            }
        }
        // The old clips follow the new one, unchanged.
        assert_eq!(back.clips.len(), c.clips.len() + 1);
        assert_eq!(back.clips[1].frames, c.clips[0].frames);
        // Meshes, materials, images... all survive, in one buffer, images embedded.
        let before = source_json(&c);
        let after = source_json(&back);
        for key in [
            "meshes",
            "materials",
            "textures",
            "images",
            "samplers",
            "skins",
            "scenes",
            "nodes",
        ] {
            assert_eq!(count(&after, key), count(&before, key), "{name}: {key}");
        }
        assert_eq!(
            count(&after, "animations"),
            count(&before, "animations") + 1
        );
        assert_eq!(count(&after, "buffers"), 1);
        for image in after
            .get("images")
            .and_then(Value::as_array)
            .into_iter()
            .flatten()
        {
            assert!(
                image.get("uri").is_none() && image.get("bufferView").is_some(),
                "{image}"
            );
        }
    }
}

/// A capsule per bone from its joint to where it ends, and a box for the pelvis.
fn hand_made_spec(c: &Character) -> RagdollSpec {
    let sk = &c.skeleton;
    let world = sk.rest_world();
    let ends = sk.rest_bone_ends();
    let mut spec = empty_spec(&c.name);
    for i in 0..sk.len() {
        let Some(end) = ends[i] else { continue };
        let bone_rot = world[i].rotation;
        let d = bone_rot.inverse() * (end - world[i].translation);
        let shape = if i == 0 {
            Shape::Box {
                size_m: [0.3, 0.15, 0.2],
            }
        } else {
            Shape::Capsule {
                radius_m: 0.04,
                length_m: (d.length() - 0.08).max(0.01),
            }
        };
        spec.bodies.push(BodySpec {
            name: sk.joint_label(i),
            bone: sk.joint_label(i),
            role: None,
            shape,
            center_m: (d * 0.5).to_array(),
            rotation: Quat::from_rotation_arc(Vec3::Y, d.normalize_or(Vec3::Y)).to_array(),
            mass_kg: 1.0,
            extra_shapes: Vec::new(),
        });
    }
    spec
}

#[test]
fn built_in_humanoid_exports_a_skinned_body_mesh() {
    let c = humanoid();
    let spec = hand_made_spec(&c);
    let back = round_trip(&c, &spec, "humanoid.ragdoll.glb");
    let names: Vec<&str> = back
        .skeleton
        .joints()
        .iter()
        .map(|j| j.name.as_str())
        .collect();
    let want: Vec<&str> = c
        .skeleton
        .joints()
        .iter()
        .map(|j| j.name.as_str())
        .collect();
    assert_eq!(names, want);
    assert_same_worlds(
        &back.skeleton.rest_world(),
        &c.skeleton.rest_world(),
        "humanoid rest",
    );
    assert_eq!(back.meshes.len(), 1);
    let m = &back.meshes[0];
    assert_eq!(m.normals.len(), m.positions.len());
    // Each shape bound rigidly to its own body's bone: one joint, weight 1, so
    // no shape bends or shears with a neighbour.
    assert!(m.weights.iter().all(|w| *w == Vec4::X), "blended weights");
    // The vertices mostly on the head bone sit around it, above the neck.
    let head = back.skeleton.find("head").unwrap();
    let head_y = c.skeleton.rest_world()[head].translation.y;
    let on_head: Vec<Vec3> = m
        .positions
        .iter()
        .zip(&m.joints)
        .filter(|(_, j)| j[0] as usize == head)
        .map(|(p, _)| *p)
        .collect();
    assert!(!on_head.is_empty());
    assert!(
        on_head
            .iter()
            .all(|p| p.y > head_y - 0.05 && p.y < head_y + 0.25),
        "{on_head:?}"
    );
}

#[test]
fn a_body_on_a_missing_bone_is_an_error() {
    let c = humanoid();
    let mut spec = hand_made_spec(&c);
    spec.bodies[1].bone = "tail".into();
    let e = to_glb(&c, &spec, &test_track(&c)).unwrap_err();
    assert!(e.to_string().contains("tail"), "{e}");
}

#[test]
fn a_track_of_the_wrong_shape_is_an_error() {
    let c = humanoid();
    let spec = hand_made_spec(&c);
    let mut track = test_track(&c);
    track.frames[2].pop();
    assert!(to_glb(&c, &spec, &track).is_err());
    track.frames.clear();
    assert!(to_glb(&c, &spec, &track).is_err());
}

/// SimpleSkin's JSON, to edit into other test cases.
fn simple_skin_json() -> Value {
    let path = sample("SimpleSkin.gltf");
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

fn import_json(doc: &Value, name: &str) -> ragdoll::Result<Character> {
    from_bytes(&serde_json::to_vec(doc).unwrap(), Path::new(name))
}

#[test]
#[ignore = "needs ../shared/data"]
fn non_joint_nodes_between_joints_and_matrix_joints_round_trip() {
    let mut doc = simple_skin_json();
    // node 1 (joint) → node 3 (not a joint, turned and moved) → node 2 (joint); node 1 is
    // given as a matrix, which the exporter must turn into TRS to animate it.
    let q = Quat::from_rotation_z(0.4);
    doc["nodes"][1] = json!({"children": [3], "matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,1,0,1]});
    doc["nodes"].as_array_mut().unwrap().push(json!({
        "children": [2], "translation": [0.2, 0.3, 0.0], "rotation": q.to_array(),
    }));
    let c = import_json(&doc, "Bent.gltf").unwrap();
    assert_eq!(c.skeleton.parent(1), Some(0));
    let w = c.skeleton.rest_world();
    assert!(
        (w[1].translation - Vec3::new(0.2, 1.3, 0.0)).length() < 1e-6,
        "{}",
        w[1].translation
    );
    let back = round_trip(&c, &empty_spec("Bent"), "Bent.ragdoll.glb");
    assert_same_worlds(&back.skeleton.rest_world(), &w, "Bent rest");
    let out = source_json(&back);
    assert!(out["nodes"][1].get("matrix").is_none());
}

#[test]
#[ignore = "needs ../shared/data"]
fn the_skin_with_the_most_vertices_wins_and_unread_extensions_pass() {
    let mut doc = simple_skin_json();
    // A second skin made of node 2 alone, used by nothing: skin 0 keeps winning.
    doc["skins"]
        .as_array_mut()
        .unwrap()
        .insert(0, json!({"joints": [2]}));
    doc["nodes"][0]["skin"] = json!(1);
    // Extensions we do not read but keep for the exporter must not stop the import.
    doc["extensionsUsed"] = json!(["KHR_texture_transform", "KHR_mesh_quantization"]);
    doc["extensionsRequired"] = json!(["KHR_texture_transform", "KHR_mesh_quantization"]);
    doc["meshes"][0]["primitives"][0]["attributes"]["_BATCHID"] = json!(1);
    doc["textures"] = json!([{"extensions": {"KHR_texture_basisu": {"source": 0}}}]);
    let c = import_json(&doc, "TwoSkins.gltf").unwrap();
    assert_eq!(c.skeleton.len(), 2);
    let Source::Gltf(src) = &c.source else {
        panic!()
    };
    assert_eq!(src.skin, 1);
}

fn assert_format_error(r: ragdoll::Result<Character>, needle: &str) -> String {
    match r {
        Err(e @ Error::Format { .. }) => {
            let s = e.to_string();
            assert!(s.contains(needle), "{s}");
            s
        }
        Err(e) => panic!("expected a format error containing {needle:?}, got {e}"),
        Ok(_) => panic!("expected a format error containing {needle:?}, got a character"),
    }
}

#[test]
#[ignore = "needs ../shared/data"]
fn a_gltf_without_a_skin_is_rigged_and_without_a_mesh_or_nodes_is_an_error() {
    let mut doc = simple_skin_json();
    let mut no_skin = doc.clone();
    no_skin.as_object_mut().unwrap().remove("skins");
    no_skin["nodes"][0].as_object_mut().unwrap().remove("skin");
    // A mesh without a skin is rigged like an OBJ: a spine of the default
    // length, every vertex weighted.
    let rigged = import_json(&no_skin, "Unrigged.gltf").unwrap();
    assert!(matches!(rigged.source, Source::Mesh(_)));
    assert_eq!(rigged.skeleton.len(), ragdoll::rig::DEFAULT_JOINTS);
    let m = &rigged.meshes[0];
    assert_eq!(m.weights.len(), m.positions.len());
    let mut no_mesh = no_skin.clone();
    no_mesh.as_object_mut().unwrap().remove("meshes");
    no_mesh["nodes"][0].as_object_mut().unwrap().remove("mesh");
    let msg = assert_format_error(import_json(&no_mesh, "Unrigged.gltf"), "has no skin");
    assert!(msg.contains("Unrigged.gltf"), "{msg}");
    let o = doc.as_object_mut().unwrap();
    for key in ["nodes", "skins", "scenes", "animations"] {
        o.remove(key);
    }
    assert_format_error(import_json(&doc, "Empty.gltf"), "no nodes");
}

#[test]
#[ignore = "needs ../shared/data"]
fn broken_files_are_errors_not_panics() {
    let doc = simple_skin_json();
    type Edit = Box<dyn Fn(&mut Value)>;
    let cases: Vec<(&str, Edit)> = vec![
        (
            "accessor count past its view",
            Box::new(|d| d["accessors"][1]["count"] = json!(1000)),
        ),
        (
            "joint index out of range",
            Box::new(|d| d["skins"][0]["joints"] = json!([1, 99])),
        ),
        (
            "joint listed twice",
            Box::new(|d| d["skins"][0]["joints"] = json!([1, 1])),
        ),
        (
            "view past its buffer",
            Box::new(|d| d["bufferViews"][1]["byteLength"] = json!(100000)),
        ),
        (
            "bad base64",
            Box::new(|d| d["buffers"][0]["uri"] = json!("data:application/gltf-buffer;base64,@@")),
        ),
        (
            "missing external buffer",
            Box::new(|d| d["buffers"][0]["uri"] = json!("nowhere.bin")),
        ),
        (
            "cycle",
            Box::new(|d| d["nodes"][2]["children"] = json!([1])),
        ),
        (
            "positions as VEC2",
            Box::new(|d| d["accessors"][1]["type"] = json!("VEC2")),
        ),
        (
            "animation input not scalar",
            Box::new(|d| d["animations"][0]["samplers"][0]["input"] = json!(6)),
        ),
        ("not an object", Box::new(|d| *d = json!([1, 2, 3]))),
        (
            "Draco",
            Box::new(|d| d["extensionsRequired"] = json!(["KHR_draco_mesh_compression"])),
        ),
    ];
    for (what, edit) in cases {
        let mut d = doc.clone();
        edit(&mut d);
        let r = import_json(&d, "Broken.gltf");
        assert!(r.is_err(), "{what}: imported anyway");
        eprintln!("{what}: {}", r.err().unwrap());
    }
    // Vertices weighted to joints the skin does not have are repaired, not refused
    //: the weight goes, and the warning says where.
    let mut d = doc.clone();
    d["skins"][0]["joints"] = json!([1]);
    let c = import_json(&d, "Broken.gltf").unwrap();
    assert!(
        c.warnings.len() == 1 && c.warnings[0].contains("named a joint past the skin's 1"),
        "{:?}",
        c.warnings
    );
}

#[test]
fn empty_and_cut_short_files_are_errors_with_their_place() {
    assert_format_error(from_bytes(b"", Path::new("e.glb")), "byte 0");
    assert_format_error(from_bytes(b"{", Path::new("e.gltf")), "line 1");
}

#[test]
#[ignore = "needs ../shared/data"]
fn truncated_or_corrupted_glb_is_an_error_not_a_panic() {
    let path = sample("CesiumMan.glb");
    let bytes = std::fs::read(path).unwrap();
    let cut_at: Vec<usize> = (0..64)
        .chain((64..bytes.len()).step_by(4099))
        .chain([bytes.len() - 1])
        .collect();
    for len in cut_at {
        let r = from_bytes(&bytes[..len], Path::new("Cut.glb"));
        assert!(r.is_err(), "cut at {len}: imported anyway");
    }
    let mut bad = bytes.clone();
    bad[0] = b'x';
    assert_format_error(from_bytes(&bad, Path::new("Bad.glb")), "byte 0");
    // Random byte damage anywhere: an error or a character, never a panic.
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    for _ in 0..300 {
        let mut d = bytes.clone();
        for _ in 0..4 {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            let at = (seed % d.len() as u64) as usize;
            d[at] = (seed >> 32) as u8;
        }
        let _ = from_bytes(&d, Path::new("Noise.glb"));
    }
}

/// A 1×1 PNG, to stand in for a texture.
const PNG_1X1: [u8; 69] = [
    0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a, 0x00, 0x00, 0x00, 0x0d, 0x49, 0x48, 0x44, 0x52,
    0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x01, 0x08, 0x02, 0x00, 0x00, 0x00, 0x90, 0x77, 0x53,
    0xde, 0x00, 0x00, 0x00, 0x0c, 0x49, 0x44, 0x41, 0x54, 0x78, 0x9c, 0x63, 0xf8, 0xdf, 0xc0, 0x00,
    0x00, 0x04, 0x01, 0x01, 0x80, 0xc5, 0x2a, 0x18, 0x5d, 0x00, 0x00, 0x00, 0x00, 0x49, 0x45, 0x4e,
    0x44, 0xae, 0x42, 0x60, 0x82,
];

#[test]
#[ignore = "needs ../shared/data"]
fn external_buffers_and_images_end_up_inside_the_glb() {
    use base64::Engine;
    let mut doc = simple_skin_json();
    let dir = std::env::temp_dir().join(format!("ragdoll-gltf-ext-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (i, b) in doc["buffers"]
        .as_array_mut()
        .unwrap()
        .iter_mut()
        .enumerate()
    {
        let uri = b["uri"].as_str().unwrap();
        let payload = uri.split_once(',').unwrap().1;
        let bytes = base64::engine::general_purpose::STANDARD
            .decode(payload)
            .unwrap();
        std::fs::write(dir.join(format!("buf {i}.bin")), bytes).unwrap();
        b["uri"] = json!(format!("buf%20{i}.bin"));
    }
    std::fs::write(dir.join("tex.png"), PNG_1X1).unwrap();
    doc["images"] = json!([{"uri": "tex.png"}]);
    doc["textures"] = json!([{"source": 0}]);
    doc["materials"] = json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]);
    let path = dir.join("External.gltf");
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    let c = load(&path).unwrap();
    let back = round_trip(&c, &empty_spec("External"), "External.ragdoll.glb");
    let out = source_json(&back);
    assert_eq!(out["images"][0]["mimeType"], "image/png");
    let view = out["images"][0]["bufferView"].as_u64().unwrap() as usize;
    assert_eq!(out["bufferViews"][view]["byteLength"], PNG_1X1.len());
    let Source::Gltf(src) = &back.source else {
        panic!()
    };
    let start = out["bufferViews"][view]["byteOffset"].as_u64().unwrap() as usize;
    assert_eq!(src.buffers[0][start..start + PNG_1X1.len()], PNG_1X1);
    // A missing image is a warning that names it, and the bake goes on
    // without it and the texture that showed it.
    std::fs::remove_file(dir.join("tex.png")).unwrap();
    let c = load(&path).unwrap();
    assert!(
        c.warnings.len() == 1 && c.warnings[0].contains("\"tex.png\""),
        "{:?}",
        c.warnings
    );
    let out = glb_json(&to_glb(&c, &empty_spec("External"), &test_track(&c)).unwrap());
    assert!(out.get("images").is_none() && out.get("textures").is_none());
    assert!(out["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"].is_null());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Inverse bind matrices that cannot be inverted (here all zero) skinned every vertex onto
/// one point: a 0 m, half-gram character and no word of it. They are bound in the rest
/// pose instead, with a warning naming the skin and the accessor.
#[test]
#[ignore = "needs ../shared/data"]
fn degenerate_inverse_bind_matrices_are_bound_in_the_rest_pose_with_a_warning() {
    use base64::Engine as _;
    let good = import_json(&simple_skin_json(), "SimpleSkin.gltf").unwrap();
    assert!(good.warnings.is_empty(), "{:?}", good.warnings);
    let mut doc = simple_skin_json();
    // Buffer 2 holds SimpleSkin's two inverse bind matrices, and nothing else.
    assert_eq!(doc["bufferViews"][3]["buffer"], 2);
    let zeros = base64::engine::general_purpose::STANDARD.encode([0u8; 128]);
    doc["buffers"][2]["uri"] = json!(format!("data:application/gltf-buffer;base64,{zeros}"));
    let c = import_json(&doc, "ZeroBind.gltf").unwrap();
    assert_eq!(c.warnings.len(), 1, "{:?}", c.warnings);
    assert!(
        c.warnings[0].contains("skin 0 (accessor 4): 2 of 2 inverse bind matrices"),
        "{}",
        c.warnings[0]
    );
    // The skin keeps its shape and size: SimpleSkin's own matrices also shift its mesh
    // half a metre sideways (its bind pose is not its rest pose), so the repaired skin is
    // the true one moved by one vector, not collapsed onto a point.
    let (a, b) = (&good.meshes[0].positions, &c.meshes[0].positions);
    assert_eq!(a.len(), b.len());
    let shift = b[0] - a[0];
    let worst = a
        .iter()
        .zip(b)
        .map(|(p, q)| (*q - *p - shift).length())
        .fold(0.0, f32::max);
    assert!(worst < 1e-5, "{worst}");
    assert!(shift.length() <= 0.5 + 1e-5, "{shift}");
    assert!(ragdoll::import::character_height(&c) > 1.0);
}
