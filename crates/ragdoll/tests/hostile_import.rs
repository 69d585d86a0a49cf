//! Hostile input against the importers and the skeleton: every crash, hang and runaway
//! allocation found so far, kept as a regression, with the inputs built here so the
//! tests need no data folder. Also the generators behind the scaling figures (deep chains,
//! wide trees): they assert the result is right; timing them is done by hand.

use std::path::{Path, PathBuf};

use glam::Vec3;
use ragdoll::Error;
use ragdoll::import::{self, ImportOptions, Units, bvh, gltf, obj};
use ragdoll::math::Transform;
use ragdoll::skeleton::{Character, MAX_JOINTS, MAX_REACH_M, Skeleton, humanoid};
use ragdoll::spec::{BuildOptions, RagdollSpec, Role, build_spec, recognise_roles};
use ragdoll::track::Track;
use serde_json::{Value, json};

/// A fresh folder of its own for one test.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("ragdoll-hostile-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn parse_bvh(text: &str) -> ragdoll::Result<Character> {
    bvh::parse(text, Path::new("hostile.bvh"), &ImportOptions::default())
}

/// The line and message of a BVH parse error.
fn bvh_error(text: &str) -> (usize, String) {
    match parse_bvh(text) {
        Err(Error::Parse { line, message, .. }) => (line, message),
        Err(other) => panic!("expected a parse error, got {other}"),
        Ok(_) => panic!("expected a parse error, got a character"),
    }
}

// --- Files the importers must not read ---------------------------------------------------

#[cfg(unix)]
#[test]
fn streams_fifos_and_folders_are_refused_before_reading() {
    let dir = scratch("streams");
    std::os::unix::fs::symlink("/dev/zero", dir.join("zero.bvh")).unwrap();
    std::os::unix::fs::symlink("/dev/urandom", dir.join("random.obj")).unwrap();
    std::os::unix::fs::symlink("/dev/zero", dir.join("zero.glb")).unwrap();
    std::fs::create_dir(dir.join("folder.gltf")).unwrap();
    let fifo = dir.join("fifo.bvh");
    let made = std::process::Command::new("mkfifo").arg(&fifo).status();
    let mut names = vec!["zero.bvh", "random.obj", "zero.glb", "folder.gltf"];
    if made.is_ok_and(|s| s.success()) {
        // Opening a FIFO blocks until a writer comes: this test would hang, not fail.
        names.push("fifo.bvh");
    }
    for name in names {
        let started = std::time::Instant::now();
        let e = import::load(&dir.join(name), &ImportOptions::default()).unwrap_err();
        assert!(matches!(e, Error::Refused { .. }), "{name}: {e}");
        assert!(e.to_string().contains(name), "{name}: {e}");
        // Refused from the metadata: nothing of a 4 GB stream is read.
        assert!(
            started.elapsed().as_secs() < 5,
            "{name} took {:?}",
            started.elapsed()
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_missing_file_says_so_once() {
    let e = import::load(
        Path::new("/nonexistent-ragdoll/nope.glb"),
        &ImportOptions::default(),
    )
    .unwrap_err();
    let text = e.to_string();
    assert!(text.contains("nope.glb"), "{text}");
    assert_eq!(text.matches("os error 2").count(), 1, "{text}");
    assert!(std::error::Error::source(&e).is_none());
}

// --- BVH numbers past their limits --------------------------------------------------------

const ONE_JOINT: &str = "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Xrotation Yrotation\nEnd Site\n{\nOFFSET 0 170 0\n}\n}\nMOTION\n";

#[test]
fn bvh_an_offset_of_two_to_the_31_names_its_line() {
    // It used to pass, make a 78-quintillion-kg body and blow up in the physics.
    let text = ONE_JOINT.replace("OFFSET 0 170 0", "OFFSET 0 2147483648 0")
        + "Frames: 1\nFrame Time: 0.1\n0 0 0\n";
    let (line, message) = bvh_error(&text);
    assert_eq!(line, 8, "{message}");
    assert!(
        message.contains("2147483648") && message.contains("beyond"),
        "{message}"
    );
}

#[test]
fn bvh_counts_and_times_past_their_limits_name_their_line() {
    let frames = |header: &str| format!("{ONE_JOINT}{header}");
    // A frame count with no data behind it is refused before anything is reserved for it.
    let (line, m) = bvh_error(&frames("Frames: 99999999999\nFrame Time: 0.1\n"));
    assert_eq!(line, 12, "{m}");
    let (line, m) = bvh_error(&frames("Frames: 5000000\nFrame Time: 0.1\n"));
    assert_eq!(line, 14, "{m}");
    assert!(m.contains("after 0 frames"), "{m}");
    for time in ["1e30", "100", "1e-30"] {
        let (line, m) = bvh_error(&frames(&format!("Frames: 1\nFrame Time: {time}\n0 0 0\n")));
        assert_eq!(line, 13, "{time}: {m}");
    }
    let (line, m) = bvh_error(&frames("Frames: 1\nFrame Time: 0.1\n0 1e7 0\n"));
    assert_eq!(line, 14, "{m}");
    assert!(m.contains("value 2 of frame 1"), "{m}");
    for count in ["99999999999", "65"] {
        let text = ONE_JOINT.replace("CHANNELS 3", &format!("CHANNELS {count}"));
        let (line, m) = bvh_error(&text);
        assert_eq!(line, 5, "{count}: {m}");
    }
}

#[test]
fn bvh_joints_or_frames_out_of_reach_are_refused() {
    // Each offset is allowed, their sum is not: 20 km of joints in metres.
    let mut text = String::from("HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\n");
    for i in 0..20 {
        text += &format!("JOINT j{i}\n{{\nOFFSET 0 1000 0\n");
    }
    text += &"}\n".repeat(21);
    text += "MOTION\nFrames: 1\nFrame Time: 0.1\n\n";
    let opts = ImportOptions {
        units: Some(Units::M),
        up: None,
        ..Default::default()
    };
    let e = bvh::parse(&text, Path::new("far.bvh"), &opts).unwrap_err();
    assert!(
        // j9 is 10 km up, exactly as far as allowed; j10 is past it.
        matches!(&e, Error::Skeleton { joint, .. } if joint == "j10"),
        "{e}"
    );
    // A root moved 500 km away in frame 2.
    let text = "HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 3 Xposition Yposition Zposition\n}\n\
                MOTION\nFrames: 2\nFrame Time: 0.1\n0 1 0\n500000 1 0\n";
    match bvh::parse(text, Path::new("far.bvh"), &opts) {
        Err(Error::Parse { line, message, .. }) => {
            assert_eq!(line, 11, "{message}");
            assert!(message.contains("frame 2"), "{message}");
        }
        other => panic!("expected a parse error, got {other:?}"),
    }
}

// --- Deep chains and wide trees -----------------------------------------------------------

/// A BVH chain of `n` joints nested one in another, each 10 units above its parent, with
/// one frame of motion.
fn bvh_chain(n: usize) -> String {
    let mut text = String::with_capacity(n * 80);
    text += "HIERARCHY\n";
    for i in 0..n {
        let kind = if i == 0 { "ROOT" } else { "JOINT" };
        let up = if i == 0 { 0 } else { 10 };
        text += &format!("{kind} j{i}\n{{\nOFFSET 0 {up} 0\nCHANNELS 1 Yrotation\n");
    }
    text += "End Site\n{\nOFFSET 0 10 0\n}\n";
    text += &"}\n".repeat(n);
    text += "MOTION\nFrames: 1\nFrame Time: 0.1\n";
    text += &"5 ".repeat(n);
    text += "\n";
    text
}

#[test]
fn a_chain_as_deep_as_a_skeleton_may_be_imports_without_recursion() {
    // Runs on the test harness's thread (2 MiB of stack): any recursion on the nesting
    // would overflow long before 65,536 levels.
    let n = MAX_JOINTS;
    let opts = ImportOptions {
        units: Some(Units::Mm),
        up: None,
        ..Default::default()
    };
    let c = bvh::parse(&bvh_chain(n), Path::new("deep.bvh"), &opts).unwrap();
    let s = &c.skeleton;
    assert_eq!(s.len(), n);
    assert!((1..n).all(|i| s.parent(i) == Some(i - 1)));
    let world = s.rest_world();
    // 10 mm per joint, straight up.
    // (f32 sums of 0.01 drift a little over 65,536 terms: compare to a part in a thousand.)
    let top = world[n - 1].translation;
    let expected = (n - 1) as f32 * 0.01;
    assert!(
        (top.y - expected).abs() < 1e-3 * expected && top.x == 0.0,
        "{top}"
    );
    assert!((s.rest_height() - n as f32 * 0.01).abs() < 1e-3 * expected);
    assert_eq!(c.clips[0].frames[0].len(), n);
    let roles = recognise_roles(&c);
    assert!(!roles.humanoid);
    assert!(roles.per_joint.iter().all(|r| *r == Some(Role::Chain)));
}

#[test]
fn one_joint_more_than_a_skeleton_may_have_is_refused_on_its_line() {
    let (line, m) = bvh_error(&bvh_chain(100_000));
    // Joint number 65,537 starts on line 2 + 4 × 65,536.
    assert_eq!(line, 2 + 4 * MAX_JOINTS, "{m}");
    assert!(m.contains(&MAX_JOINTS.to_string()), "{m}");
}

/// A chain of `n` joints 10 cm apart that snakes through a cube, filling it row by row
/// (the way a deep chain takes room without every body touching hundreds of others, as a
/// straight chain thicker than its spacing would).
fn snake(n: usize) -> Character {
    let side = (n as f64).cbrt().ceil() as i32 + 1;
    let mut points = Vec::with_capacity(n);
    'fill: for z in 0..side {
        for yy in 0..side {
            let y = if z % 2 == 0 { yy } else { side - 1 - yy };
            for xx in 0..side {
                let x = if (y + z * side) % 2 == 0 {
                    xx
                } else {
                    side - 1 - xx
                };
                points.push(Vec3::new(x as f32, y as f32, z as f32) * 0.1);
                if points.len() == n {
                    break 'fill;
                }
            }
        }
    }
    let joints = points
        .iter()
        .enumerate()
        .map(|(i, p)| ragdoll::skeleton::Joint {
            name: format!("s{i}"),
            parent: i.checked_sub(1),
            rest: Transform::from_translation(*p - if i == 0 { Vec3::ZERO } else { points[i - 1] }),
            // A bare leaf: its bone continues the last one, away from every other.
            tip: None,
        })
        .collect();
    character("snake", Skeleton::new(joints).unwrap())
}

/// A tree `levels` deep where every joint has `fan` children spread on a cone, each level
/// a little shorter: wide and bushy like a coral.
fn wide_tree(fan: usize, levels: usize) -> Character {
    let mut joints = vec![ragdoll::skeleton::Joint {
        name: "root".into(),
        parent: None,
        rest: Transform::IDENTITY,
        tip: None,
    }];
    let mut frontier = vec![0usize];
    for level in 1..=levels {
        let length = 1.0 / 2.2f32.powi(level as i32 - 1);
        let mut next = Vec::new();
        for &p in &frontier {
            for k in 0..fan {
                let a = std::f32::consts::TAU * k as f32 / fan as f32;
                let dir = Vec3::new(a.cos() * 0.8, 0.6, a.sin() * 0.8);
                joints.push(ragdoll::skeleton::Joint {
                    name: format!("b{}", joints.len()),
                    parent: Some(p),
                    rest: Transform::from_translation(dir * length),
                    tip: (level == levels).then_some(Vec3::Y * 0.05),
                });
                next.push(joints.len() - 1);
            }
        }
        frontier = next;
    }
    character("tree", Skeleton::new(joints).unwrap())
}

fn character(name: &str, skeleton: Skeleton) -> Character {
    Character {
        humanoid_bones: Vec::new(),
        warnings: Vec::new(),
        name: name.into(),
        skeleton,
        meshes: Vec::new(),
        clips: Vec::new(),
        source: ragdoll::skeleton::Source::BuiltIn,
    }
}

/// Every body's bone is a distinct joint, and the joints link each body to its parent's.
fn assert_one_body_per_joint(c: &Character, spec: &RagdollSpec) {
    let n = c.skeleton.len();
    assert_eq!(spec.bodies.len(), n);
    assert_eq!(spec.joints.len(), n - 1);
    let mut bones: Vec<&str> = spec.bodies.iter().map(|b| b.bone.as_str()).collect();
    bones.sort_unstable();
    bones.dedup();
    assert_eq!(bones.len(), n);
    for j in &spec.joints {
        let child = c.skeleton.find(&j.child).unwrap();
        let parent = c.skeleton.find(&j.parent).unwrap();
        assert_eq!(c.skeleton.parent(child), Some(parent), "{}", j.name);
    }
    // Every joint's pair is disabled, and nothing else is listed twice.
    let mut pairs: Vec<(String, String)> = spec
        .collision
        .disabled_pairs
        .iter()
        .map(|[a, b]| (a.min(b).clone(), a.max(b).clone()))
        .collect();
    pairs.sort_unstable();
    let before = pairs.len();
    pairs.dedup();
    assert_eq!(pairs.len(), before);
    for j in &spec.joints {
        let key = (
            j.parent.clone().min(j.child.clone()),
            j.parent.clone().max(j.child.clone()),
        );
        assert!(pairs.binary_search(&key).is_ok(), "{}", j.name);
    }
}

#[test]
fn ten_thousand_joints_deep_or_wide_are_read_and_refused_past_the_body_limit() {
    // Timed by hand (see the report); here, only that the result is right. Roles are found
    // on any size; a ragdoll has at most spec::MAX_BODIES bodies, so past that the builder
    // says so instead of building one.
    let c = snake(10_000);
    let roles = recognise_roles(&c);
    assert!(!roles.humanoid);
    let err = build_spec(&c, &BuildOptions::default()).unwrap_err();
    assert!(
        err.to_string().contains("at most 512 bodies, not 10000"),
        "{err}"
    );
    let c = wide_tree(10, 4);
    assert_eq!(c.skeleton.len(), 11_111);
    let roles = recognise_roles(&c);
    assert!(!roles.humanoid);
    assert!(build_spec(&c, &BuildOptions::default()).is_err());

    // Just inside the limit the whole chain and the whole tree become ragdolls.
    let c = snake(ragdoll::spec::MAX_BODIES);
    let spec = build_spec(&c, &BuildOptions::default()).unwrap();
    assert_one_body_per_joint(&c, &spec);
    // Bones 10 cm apart, 0.5 cm thick or so: only the jointed pairs touch.
    assert_eq!(spec.collision.disabled_pairs.len(), c.skeleton.len() - 1);
    let c = wide_tree(7, 3);
    assert_eq!(c.skeleton.len(), 400);
    let spec = build_spec(&c, &BuildOptions::default()).unwrap();
    assert_one_body_per_joint(&c, &spec);
}

#[test]
fn thousands_of_bodies_all_touching_are_refused_not_listed() {
    // A straight chain thicker than its spacing (every body touches hundreds of others)
    // and 1,500 spokes from one point would each list a million pairs or more.
    let opts = ImportOptions {
        units: Some(Units::Mm),
        up: None,
        ..Default::default()
    };
    let chain = bvh::parse(&bvh_chain(20_000), Path::new("fat.bvh"), &opts).unwrap();
    let mut joints = vec![ragdoll::skeleton::Joint {
        name: "hub".into(),
        parent: None,
        rest: Transform::from_translation(Vec3::Y),
        tip: None,
    }];
    for k in 0..1500 {
        let a = k as f32 * 2.399_963; // the golden angle, spokes all round
        let y = 1.0 - 2.0 * (k as f32 + 0.5) / 1500.0;
        let r = (1.0 - y * y).sqrt();
        joints.push(ragdoll::skeleton::Joint {
            name: format!("spoke{k}"),
            parent: Some(0),
            rest: Transform::IDENTITY,
            tip: Some(Vec3::new(a.cos() * r, y, a.sin() * r) * 0.3),
        });
    }
    let star = character("star", Skeleton::new(joints).unwrap());
    for c in [chain, star] {
        let e = match build_spec(&c, &BuildOptions::default()) {
            Ok(spec) => panic!("{}: {} pairs", c.name, spec.collision.disabled_pairs.len()),
            Err(e) => e,
        };
        assert!(
            matches!(&e, Error::Spec { place, .. } if place == "collision.disabled_pairs"),
            "{}: {e}",
            c.name
        );
    }
}

#[test]
fn a_humanoid_with_thousands_of_fingers_is_still_the_same_humanoid() {
    let base = humanoid();
    let plain = recognise_roles(&base);
    let mut joints = base.skeleton.joints().to_vec();
    for hand in ["hand_l", "hand_r"] {
        let h = base.skeleton.find(hand).unwrap();
        for f in 0..2000 {
            let a = f as f32 * 0.001;
            joints.push(ragdoll::skeleton::Joint {
                name: format!("{hand}_finger{f}"),
                parent: Some(h),
                rest: Transform::from_translation(Vec3::new(a.sin() * 0.01, -0.05, a.cos() * 0.01)),
                tip: Some(Vec3::new(0.0, -0.03, 0.0)),
            });
        }
    }
    let c = character("fingers", Skeleton::new(joints).unwrap());
    let roles = recognise_roles(&c);
    assert!(roles.humanoid);
    assert_eq!(roles.per_joint[..base.skeleton.len()], plain.per_joint[..]);
    assert!((roles.forward - plain.forward).length() < 1e-5);
}

// --- glTF ---------------------------------------------------------------------------------

/// A valid two-joint skinned triangle with a two-key animation: JSON and binary chunk.
fn skinned() -> (Value, Vec<u8>) {
    let mut bin = Vec::new();
    let push_f32 = |vals: &[f32], bin: &mut Vec<u8>| {
        let at = bin.len();
        for v in vals {
            bin.extend_from_slice(&v.to_le_bytes());
        }
        (at, bin.len() - at)
    };
    let pos = push_f32(&[0.0, 0.0, 0.0, 0.1, 0.0, 0.0, 0.0, 1.0, 0.0], &mut bin);
    let weights = push_f32(&[1.0, 0., 0., 0., 1., 0., 0., 0., 0., 1., 0., 0.], &mut bin);
    let times = push_f32(&[0.0, 1.0], &mut bin);
    let moves = push_f32(&[0.0, 0.5, 0.0, 0.0, 0.6, 0.0], &mut bin);
    let joints_at = bin.len();
    bin.extend_from_slice(&[0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0]);
    let view =
        |(at, len): (usize, usize)| json!({"buffer": 0, "byteOffset": at, "byteLength": len});
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
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "WEIGHTS_0": 1, "JOINTS_0": 4}}]}],
        "animations": [{
            "samplers": [{"input": 2, "output": 3}],
            "channels": [{"sampler": 0, "target": {"node": 1, "path": "translation"}}]
        }],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
             "min": [0.0, 0.0, 0.0], "max": [0.1, 1.0, 0.0]},
            {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC4"},
            {"bufferView": 2, "componentType": 5126, "count": 2, "type": "SCALAR"},
            {"bufferView": 3, "componentType": 5126, "count": 2, "type": "VEC3"},
            {"bufferView": 4, "componentType": 5121, "count": 3, "type": "VEC4"}
        ],
        "bufferViews": [view(pos), view(weights), view(times), view(moves), view((joints_at, 12))],
        "buffers": [{"byteLength": bin.len()}]
    });
    (json, bin)
}

/// A GLB of `json` and `bin`.
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

fn import_glb(json: &Value, bin: &[u8]) -> ragdoll::Result<Character> {
    gltf::from_bytes(&glb(json, bin), Path::new("hostile.glb"))
}

#[test]
fn the_hand_made_gltf_imports() {
    let (mut json, bin) = skinned();
    // Application data of any type is allowed, and ignored.
    json["extras"] = json!([1, 2, 3]);
    json["nodes"][0]["extras"] = json!("hip");
    json["accessors"][0]["extras"] = json!({"a": [0]});
    let c = import_glb(&json, &bin).unwrap();
    assert_eq!(c.skeleton.len(), 2);
    assert_eq!(c.meshes.len(), 1);
    assert_eq!(c.clips.len(), 1);
    assert!((c.skeleton.rest_world()[1].translation.y - 1.5).abs() < 1e-6);
}

#[test]
fn every_index_out_of_range_is_an_error_naming_it() {
    let (json, bin) = skinned();
    // The first case is the fuzzers' most frequent crash: gltf-json's own validation
    // indexed the accessors with it (mesh.rs:151) and panicked.
    let cases: [(&str, &str); 17] = [
        ("/meshes/0/primitives/0/attributes/POSITION", "POSITION"),
        ("/meshes/0/primitives/0/attributes/WEIGHTS_0", "WEIGHTS_0"),
        ("/meshes/0/primitives/0/attributes/JOINTS_0", "JOINTS_0"),
        ("/meshes/0/primitives/0/indices", "indices"),
        ("/nodes/0/children/0", "children"),
        ("/nodes/2/mesh", "mesh"),
        ("/nodes/2/skin", "skin"),
        ("/scenes/0/nodes/0", "nodes"),
        ("/scene", "scene"),
        ("/skins/0/joints/1", "joints"),
        ("/skins/0/inverseBindMatrices", "inverseBindMatrices"),
        ("/skins/0/skeleton", "skeleton"),
        ("/animations/0/samplers/0/input", "input"),
        ("/animations/0/samplers/0/output", "output"),
        ("/animations/0/channels/0/sampler", "sampler"),
        ("/animations/0/channels/0/target/node", "target"),
        ("/accessors/0/bufferView", "bufferView"),
    ];
    for (pointer, names) in cases {
        for bad in [99u64, 4_294_967_295] {
            let mut j = json.clone();
            let (parent, key) = pointer.rsplit_once('/').unwrap();
            let target = j.pointer_mut(parent).unwrap();
            match target {
                Value::Array(a) => a[key.parse::<usize>().unwrap()] = json!(bad),
                Value::Object(o) => {
                    o.insert(key.to_string(), json!(bad));
                }
                _ => unreachable!(),
            }
            let e = import_glb(&j, &bin).unwrap_err();
            let text = e.to_string();
            assert!(
                matches!(e, Error::Format { .. }) && text.contains(names),
                "{pointer} = {bad}: {text}"
            );
        }
    }
    let mut j = json.clone();
    j["bufferViews"][2]["buffer"] = json!(7);
    assert!(import_glb(&j, &bin).is_err());
}

#[test]
fn gltf_nodes_a_hundred_thousand_deep_import_without_recursion() {
    let (mut json, bin) = skinned();
    // Thread the skin's root joint under a chain of 100,000 plain nodes, each 10 µm up.
    let n = 100_000;
    let first = json["nodes"].as_array().unwrap().len();
    let nodes = json["nodes"].as_array_mut().unwrap();
    for i in 0..n {
        let child = if i + 1 < n { first + i + 1 } else { 0 };
        nodes.push(json!({"translation": [0.0, 1e-5, 0.0], "children": [child]}));
    }
    json["scenes"][0]["nodes"] = json!([first, 2]);
    let c = import_glb(&json, &bin).unwrap();
    let hip = c.skeleton.rest_world()[0].translation;
    assert!((hip.y - 2.0).abs() < 1e-3, "{hip}");
    // And a cycle anywhere in it is named, not followed forever.
    json["nodes"][first + n - 1]["children"] = json!([first]);
    let e = import_glb(&json, &bin).unwrap_err();
    assert!(e.to_string().contains("own ancestor"), "{e}");
}

#[test]
fn gltf_sparse_accessors_replace_the_elements_they_name() {
    // Vertex 1 of the hand-made skin moved by a sparse substitution over its positions,
    // and the same substitution on an accessor without a buffer view (zeros elsewhere).
    // Positions come out bound to their joints (identity inverse bind matrices), so each
    // is compared with where the plain file puts the same vertex.
    let (mut json, mut bin) = skinned();
    let stored = [
        Vec3::ZERO,
        Vec3::new(0.1, 0.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
    ];
    let plain = import_glb(&json, &bin).unwrap().meshes[0].positions.clone();
    let joint_at = |k: usize| plain[k] - stored[k];
    let idx_at = bin.len();
    bin.extend_from_slice(&[1, 0, 0, 0]);
    let val_at = bin.len();
    let moved = Vec3::new(0.25, 0.5, 0.75);
    for v in moved.to_array() {
        bin.extend_from_slice(&v.to_le_bytes());
    }
    let views = json["bufferViews"].as_array_mut().unwrap();
    views.push(json!({"buffer": 0, "byteOffset": idx_at, "byteLength": 1}));
    views.push(json!({"buffer": 0, "byteOffset": val_at, "byteLength": 12}));
    json["buffers"][0]["byteLength"] = json!(bin.len());
    json["accessors"][0]["sparse"] = json!({"count": 1,
        "indices": {"bufferView": 5, "componentType": 5121}, "values": {"bufferView": 6}});
    json["accessors"][0]["max"] = json!([0.25, 1.0, 0.75]);
    let p = import_glb(&json, &bin).unwrap().meshes[0].positions.clone();
    assert_eq!(p[0], plain[0]);
    assert!((p[1] - (joint_at(1) + moved)).length() < 1e-6, "{}", p[1]);
    assert_eq!(p[2], plain[2]);
    let accessor = json["accessors"][0].as_object_mut().unwrap();
    accessor.remove("bufferView");
    let p = import_glb(&json, &bin).unwrap().meshes[0].positions.clone();
    assert!((p[1] - (joint_at(1) + moved)).length() < 1e-6, "{}", p[1]);
    for k in [0, 2] {
        assert!((p[k] - joint_at(k)).length() < 1e-6, "vertex {k}: {}", p[k]);
    }
}

#[test]
fn gltf_sizes_that_cost_no_bytes_are_refused_before_allocating() {
    let (json, bin) = skinned();
    // An accessor without a buffer view is zeros: its count must not be trusted.
    // (glTF allows one only when it is sparse.)
    let mut j = json.clone();
    j["accessors"][0] = json!({"componentType": 5126, "count": 100_000_000u64, "type": "VEC3",
        "min": [0.0, 0.0, 0.0], "max": [0.0, 0.0, 0.0],
        "sparse": {"count": 1, "indices": {"bufferView": 4, "componentType": 5121},
                   "values": {"bufferView": 0}}});
    let e = import_glb(&j, &bin).unwrap_err();
    assert!(e.to_string().contains("accessor 0"), "{e}");
    // Keys a million years apart would be sampled into ~10^12 frames.
    let mut j = json.clone();
    let mut bin2 = bin.clone();
    let at = bin2.len();
    bin2.extend_from_slice(&0f32.to_le_bytes());
    bin2.extend_from_slice(&3e13f32.to_le_bytes());
    j["bufferViews"][2] = json!({"buffer": 0, "byteOffset": at, "byteLength": 8});
    j["buffers"][0]["byteLength"] = json!(bin2.len());
    let e = import_glb(&j, &bin2).unwrap_err();
    assert!(e.to_string().contains("animation 0"), "{e}");
    // A skin of more joints than a skeleton may have.
    let mut j = json.clone();
    let first = j["nodes"].as_array().unwrap().len();
    let extra = MAX_JOINTS + 1;
    let nodes = j["nodes"].as_array_mut().unwrap();
    nodes.extend((0..extra).map(|_| json!({})));
    j["skins"][0]["joints"] = json!((first..first + extra).collect::<Vec<_>>());
    j["meshes"] = json!([]);
    j["nodes"][2] = json!({});
    assert!(import_glb(&j, &bin).is_err());
    // A document of more JSON values than allowed, refused before it is parsed.
    let mut j = json.clone();
    j["extras"] = json!(vec![0; gltf::MAX_JSON_VALUES]);
    let e = import_glb(&j, &bin).unwrap_err();
    assert!(e.to_string().contains("values"), "{e}");
}

#[test]
fn gltf_animation_that_leaves_for_the_horizon_is_refused() {
    let (json, mut bin) = skinned();
    // Key 2 moves the top joint 100 km.
    let at = bin.len();
    for v in [0.0f32, 0.5, 0.0, 0.0, 100_000.0, 0.0] {
        bin.extend_from_slice(&v.to_le_bytes());
    }
    let mut j = json.clone();
    j["bufferViews"][3] = json!({"buffer": 0, "byteOffset": at, "byteLength": 24});
    j["buffers"][0]["byteLength"] = json!(bin.len());
    let e = import_glb(&j, &bin).unwrap_err();
    let text = e.to_string();
    assert!(
        text.contains("animation 0") && text.contains("\"top\""),
        "{text}"
    );
}

/// The skinned file as a .gltf with its buffer in `buffer.bin` beside it.
fn gltf_in(dir: &Path, buffer_uri: &str) -> PathBuf {
    let (mut json, bin) = skinned();
    std::fs::write(dir.join("buffer.bin"), &bin).unwrap();
    json["buffers"][0]["uri"] = json!(buffer_uri);
    let path = dir.join("model.gltf");
    std::fs::write(&path, serde_json::to_vec(&json).unwrap()).unwrap();
    path
}

#[test]
fn gltf_buffers_are_read_from_the_files_folder_only() {
    let root = scratch("uris");
    let dir = root.join("model");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(root.join("secret.bin"), vec![7u8; 4096]).unwrap();
    assert!(gltf::load(&gltf_in(&dir, "buffer.bin")).is_ok());
    assert!(gltf::load(&gltf_in(&dir, "./buffer%2Ebin")).is_ok());
    let secret = root.join("secret.bin").display().to_string();
    let mut refused = vec![
        ("../secret.bin", "climbs out"),
        ("%2E%2E/secret.bin", "climbs out"),
        (secret.as_str(), "absolute path"),
        ("/dev/zero", "absolute path"),
        ("file:///dev/zero", "not a relative file path"),
        (".", "folder"),
        ("nowhere.bin", "cannot be read"),
    ];
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(root.join("secret.bin"), dir.join("link.bin")).unwrap();
        std::os::unix::fs::symlink("/dev/zero", dir.join("zero.bin")).unwrap();
        refused.push(("link.bin", "symbolic link"));
        refused.push(("zero.bin", "symbolic link"));
        let made = std::process::Command::new("mkfifo")
            .arg(dir.join("fifo.bin"))
            .status();
        if made.is_ok_and(|s| s.success()) {
            refused.push(("fifo.bin", "not a regular file"));
        }
    }
    for (uri, says) in refused {
        let e = gltf::load(&gltf_in(&dir, uri)).unwrap_err();
        let text = e.to_string();
        assert!(
            text.contains(&format!("\"{uri}\""))
                && text.contains(says)
                && text.contains("buffer 0"),
            "{uri}: {text}"
        );
        assert!(!text.contains("\n"), "{text}");
    }
    std::fs::remove_dir_all(&root).unwrap();
}

#[test]
fn exported_images_are_read_from_the_sources_folder_only() {
    let root = scratch("images");
    let dir = root.join("model");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(root.join("secret.png"), b"\x89PNG\r\n\x1a\nsecret").unwrap();
    let (mut json, bin) = skinned();
    json["buffers"][0]["uri"] = json!("buffer.bin");
    std::fs::write(dir.join("buffer.bin"), &bin).unwrap();
    let track = |c: &Character| Track {
        fps: 30.0,
        frames: vec![c.skeleton.rest_world()],
    };
    let spec = RagdollSpec {
        format_version: ragdoll::spec::SPEC_FORMAT_VERSION,
        name: "model".into(),
        bodies: Vec::new(),
        joints: Vec::new(),
        collision: Default::default(),
    };
    for (uri, says) in [
        ("../secret.png", "climbs out"),
        ("/dev/zero", "absolute path"),
    ] {
        json["images"] = json!([{ "uri": uri }]);
        let path = dir.join("model.gltf");
        std::fs::write(&path, serde_json::to_vec(&json).unwrap()).unwrap();
        // Images are not read on import, only when the .glb is written.
        let c = gltf::load(&path).unwrap();
        let e = ragdoll::export::gltf::to_glb(&c, &spec, &track(&c)).unwrap_err();
        let text = e.to_string();
        assert!(
            text.contains(uri) && text.contains(says) && text.contains("image 0"),
            "{text}"
        );
    }
    std::fs::remove_dir_all(&root).unwrap();
}

#[test]
fn mutated_gltf_bytes_never_panic() {
    let (json, bin) = skinned();
    let bytes = glb(&json, &bin);
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed
    };
    for _ in 0..3000 {
        let mut d = bytes.clone();
        for _ in 0..1 + next() % 4 {
            let at = (next() % d.len() as u64) as usize;
            d[at] = match next() % 3 {
                0 => next() as u8,
                1 => b'9',
                _ => d[at].wrapping_add(1),
            };
        }
        let _ = gltf::from_bytes(&d, Path::new("mutant.glb"));
    }
}

// --- OBJ ----------------------------------------------------------------------------------

#[test]
fn obj_coordinates_past_the_limit_name_their_line() {
    let opts = ImportOptions::default();
    for bad in ["1e30", "2000000", "-1e7"] {
        let text = format!("v 0 0 0\nv 1 0 0\nv 0 {bad} 0\nf 1 2 3\n");
        match obj::parse(&text, Path::new("far.obj"), &opts) {
            Err(Error::Parse { line, message, .. }) => assert_eq!(line, 3, "{message}"),
            other => panic!("{bad}: expected a parse error, got {other:?}"),
        }
    }
}

#[test]
fn random_text_never_panics_the_text_importers() {
    let words = [
        "v",
        "vn",
        "f",
        "1",
        "-1",
        "0",
        "2/3/4",
        "1//1",
        "-99999999999",
        "1e38",
        "nan",
        "HIERARCHY",
        "ROOT",
        "JOINT",
        "{",
        "}",
        "OFFSET",
        "CHANNELS",
        "3",
        "Xrotation",
        "End",
        "Site",
        "MOTION",
        "Frames:",
        "Frame",
        "Time:",
        "0.1",
        "\n",
        "\r",
        "é",
    ];
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut next = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed
    };
    let opts = ImportOptions::default();
    for _ in 0..3000 {
        let n = (next() % 60) as usize;
        let text: String = (0..n)
            .map(|_| format!("{} ", words[(next() % words.len() as u64) as usize]))
            .collect();
        let _ = obj::parse(&text, Path::new("soup.obj"), &opts);
        let _ = parse_bvh(&text);
        let _ = parse_bvh(&format!("{ONE_JOINT}{text}"));
    }
    // A reach check on skeletons built by hand, too.
    let far = Skeleton::new(vec![ragdoll::skeleton::Joint {
        name: "far".into(),
        parent: None,
        rest: Transform::from_translation(Vec3::X * (MAX_REACH_M * 2.0)),
        tip: None,
    }]);
    assert!(far.is_err());
}

/// A skin whose positions are finite but absurd (1e38 m) is refused at its POSITION
/// accessor; it used to come out as a spec radius of NaN, which named the wrong thing.
#[test]
fn absurd_skin_positions_are_refused_at_their_accessor() {
    let (json, mut bin) = skinned();
    bin[12..16].copy_from_slice(&1e38f32.to_le_bytes()); // vertex 1's x
    let e = import_glb(&json, &bin).unwrap_err().to_string();
    assert!(
        e.contains("accessor 0") && e.contains("past the 10000 m"),
        "{e}"
    );
    assert!(!e.contains("NaN") && !e.contains("radius"), "{e}");
}
