//! VRM avatars (`.vrm`, a GLB with a humanoid bone table), glTF read in other units or
//! scaled to a height, and choosing one of a file's clips. Hand-made files where the data
//! has none (VRM 1.0, a centimetre glTF with two clips), the shared data otherwise.

mod common;

use std::path::{Path, PathBuf};

use glam::Vec3;
use ragdoll::import::{self, ClipChoice, ImportOptions, Units};
use ragdoll::math::Transform;
use ragdoll::skeleton::Character;
use serde_json::{Value, json};

/// A GLB of `json` with `bin` as its binary chunk.
fn glb(json: &Value, bin: &[u8]) -> Vec<u8> {
    let mut j = serde_json::to_vec(json).unwrap();
    while j.len() % 4 != 0 {
        j.push(b' ');
    }
    let mut b = bin.to_vec();
    while b.len() % 4 != 0 {
        b.push(0);
    }
    let total = 12 + 8 + j.len() + if b.is_empty() { 0 } else { 8 + b.len() };
    let mut out = b"glTF".to_vec();
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((j.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(j);
    if !b.is_empty() {
        out.extend((b.len() as u32).to_le_bytes());
        out.extend(b"BIN\0");
        out.extend(b);
    }
    out
}

fn floats(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// A 150-unit-tall stick figure in centimetres (hips at 100, spine, head, one leg), an eye
/// node outside the skin, and two clips that move the hips ("Idle" 1 s, "Wave" 2 s); its
/// humanoid table is `bones` under `extension` (`VRMC_vrm` or `VRM`).
fn avatar(extension: &str, bones: Value) -> Vec<u8> {
    // Times 0, 1, 2 s; hips translations for Idle (keys 0-1) and Wave (keys 0-2).
    let times = floats(&[0.0, 1.0, 2.0]);
    let idle = floats(&[0.0, 100.0, 0.0, 0.0, 110.0, 0.0]);
    let wave = floats(&[0.0, 100.0, 0.0, 20.0, 100.0, 0.0, 0.0, 100.0, 0.0]);
    let bin = [times.clone(), idle.clone(), wave.clone()].concat();
    let (t, i) = (times.len(), idle.len());
    let accessor = |view: usize, count: usize, kind: &str| json!({"bufferView": view, "componentType": 5126, "count": count, "type": kind});
    let mut times2 = accessor(0, 2, "SCALAR");
    times2["min"] = json!([0.0]);
    times2["max"] = json!([1.0]);
    let mut times3 = accessor(0, 3, "SCALAR");
    times3["min"] = json!([0.0]);
    times3["max"] = json!([2.0]);
    let anim = |name: &str, input: usize, output: usize| {
        json!({"name": name,
            "samplers": [{"input": input, "output": output}],
            "channels": [{"sampler": 0, "target": {"node": 1, "path": "translation"}}]})
    };
    let doc = json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": [extension],
        "extensions": {extension: {"humanoid": {"humanBones": bones}}},
        "buffers": [{"byteLength": bin.len()}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": t},
            {"buffer": 0, "byteOffset": t, "byteLength": i},
            {"buffer": 0, "byteOffset": t + i, "byteLength": wave.len()},
        ],
        "accessors": [times2, times3, accessor(1, 2, "VEC3"), accessor(2, 3, "VEC3")],
        "nodes": [
            {"name": "Armature", "children": [1]},
            {"name": "J_Hips", "translation": [0.0, 100.0, 0.0], "children": [2, 4]},
            {"name": "J_Spine", "translation": [0.0, 50.0, 0.0], "children": [3]},
            {"name": "J_Head", "translation": [0.0, 50.0, 0.0], "children": [5]},
            {"name": "J_LeftLeg", "translation": [10.0, -50.0, 0.0]},
            {"name": "J_LeftEye", "translation": [3.0, 5.0, 8.0]},
        ],
        "skins": [{"joints": [1, 2, 3, 4]}],
        "animations": [anim("Idle", 0, 2), anim("Wave", 1, 3)],
        "scenes": [{"nodes": [0]}],
        "scene": 0,
    });
    glb(&doc, &bin)
}

/// How the hand-made avatar is read at its size.
const CM: ImportOptions = ImportOptions {
    units: Some(Units::Cm),
    up: None,
    height_m: None,
    clip: None,
};

fn vrm1() -> Vec<u8> {
    avatar(
        "VRMC_vrm",
        json!({
            "hips": {"node": 1}, "spine": {"node": 2}, "head": {"node": 3},
            "leftUpperLeg": {"node": 4}, "leftEye": {"node": 5},
        }),
    )
}

/// A fresh folder of this test process, for files written by one test.
fn scratch() -> PathBuf {
    use std::sync::atomic::{AtomicUsize, Ordering};
    static N: AtomicUsize = AtomicUsize::new(0);
    let k = N.fetch_add(1, Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("ragdoll-vrm-{}-{k}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Writes `bytes` as `name` in a fresh folder and loads it with `opts`.
fn load_as(name: &str, bytes: &[u8], opts: &ImportOptions) -> ragdoll::Result<Character> {
    let dir = scratch();
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    let c = import::load(&path, opts);
    let _ = std::fs::remove_dir_all(&dir);
    c
}

fn bone_names(c: &Character) -> Vec<(String, String)> {
    c.humanoid_bones
        .iter()
        .map(|(b, j)| (b.clone(), c.skeleton.joint_label(*j)))
        .collect()
}

fn pairs(list: &[(&str, &str)]) -> Vec<(String, String)> {
    list.iter()
        .map(|(a, b)| (a.to_string(), b.to_string()))
        .collect()
}

#[test]
fn vrm_1_tables_name_the_joints_and_bones_off_the_skeleton_are_warned_of() {
    let c = load_as("avatar.VRM", &vrm1(), &CM).unwrap();
    assert_eq!(
        bone_names(&c),
        pairs(&[
            ("hips", "J_Hips"),
            ("spine", "J_Spine"),
            ("head", "J_Head"),
            ("leftUpperLeg", "J_LeftLeg")
        ])
    );
    assert_eq!(c.warnings.len(), 1, "{:?}", c.warnings);
    let w = &c.warnings[0];
    assert!(
        w.contains("extensions.VRMC_vrm.humanoid.humanBones") && w.contains("leftEye (node 5)"),
        "{w}"
    );
}

#[test]
fn vrm_0_tables_are_read_the_same_way() {
    let bytes = avatar(
        "VRM",
        json!([
            {"bone": "hips", "node": 1}, {"bone": "head", "node": 3},
            {"bone": "leftUpperLeg", "node": 4},
        ]),
    );
    let c = load_as("avatar.vrm", &bytes, &CM).unwrap();
    assert_eq!(
        bone_names(&c),
        pairs(&[
            ("hips", "J_Hips"),
            ("head", "J_Head"),
            ("leftUpperLeg", "J_LeftLeg")
        ])
    );
    assert!(c.warnings.is_empty(), "{:?}", c.warnings);
}

#[test]
fn malformed_tables_are_refused_naming_the_key() {
    let cases = [
        (
            avatar("VRMC_vrm", json!({"hips": {"node": 99}})),
            "extensions.VRMC_vrm.humanoid.humanBones.hips.node: is node 99, but the file has 6 nodes",
        ),
        (
            avatar("VRM", json!([{"bone": "hips"}])),
            "extensions.VRM.humanoid.humanBones[0].node: is not a node index",
        ),
        (
            avatar("VRM", json!("hips")),
            "extensions.VRM.humanoid.humanBones: is not a list",
        ),
    ];
    for (bytes, want) in cases {
        let e = load_as("bad.vrm", &bytes, &ImportOptions::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains(want), "{e}\nwanted {want}");
        assert!(!e.contains('\n'), "{e}");
    }
}

#[test]
fn vrm_files_are_named_among_the_accepted_types() {
    let e = import::load(Path::new("x.fbx"), &ImportOptions::default())
        .unwrap_err()
        .to_string();
    // The error for a missing file comes first; an existing file of another type:
    let dir = scratch();
    let p = dir.join("x.fbx");
    std::fs::write(&p, b"Kaydara FBX Binary").unwrap();
    let e2 = import::load(&p, &ImportOptions::default())
        .unwrap_err()
        .to_string();
    let _ = std::fs::remove_dir_all(&dir);
    assert!(e.contains("x.fbx"), "{e}");
    assert!(e2.contains(".vrm"), "{e2}");
    assert!(import::is_gltf(Path::new("a.Vrm")) && !import::is_gltf(Path::new("a.vrml")));
}

fn worlds(c: &Character) -> Vec<Vec3> {
    c.skeleton
        .rest_world()
        .iter()
        .map(|t| t.translation)
        .collect()
}

#[test]
fn gltf_units_scale_the_skeleton_and_its_clips() {
    let bytes = vrm1();
    let m = load_as("a.vrm", &bytes, &ImportOptions::default()).unwrap();
    let cm = load_as(
        "a.vrm",
        &bytes,
        &ImportOptions {
            units: Some(Units::Cm),
            ..Default::default()
        },
    )
    .unwrap();
    for (a, b) in worlds(&m).iter().zip(worlds(&cm)) {
        assert!((*a * 0.01 - b).length() < 1e-5, "{a} {b}");
    }
    // Its joints span 1.5 m; a skeleton without skin stands as much taller than its
    // joints as the built-in humanoid does (1.75 m to 1.72).
    let stands = 1.75 / ragdoll::skeleton::humanoid().skeleton.rest_height();
    assert!((import::character_height(&cm) - 1.5 * stands).abs() < 1e-5);
    // Read as metres the avatar is 150 m (standing, 152.6 m) tall, and told so.
    assert!(
        m.warnings
            .iter()
            .any(|w| w.contains("152.6 m tall") && w.contains("--units cm")),
        "{:?}",
        m.warnings
    );
    assert!(!cm.warnings.iter().any(|w| w.contains("tall")));
    // The Idle clip lifts the hips 10 cm in centimetres.
    let mut posed = vec![Transform::IDENTITY; cm.skeleton.len()];
    let last = cm.clips[0].frames.last().unwrap();
    cm.skeleton.world_from_local(last, &mut posed);
    assert!(
        (posed[0].translation.y - 1.1).abs() < 1e-5,
        "{}",
        posed[0].translation
    );
    // --height wins over the file's size, whatever unit it was read in.
    for units in [None, Some(Units::Cm), Some(Units::In)] {
        let h = load_as(
            "a.vrm",
            &bytes,
            &ImportOptions {
                units,
                height_m: Some(1.8),
                ..Default::default()
            },
        )
        .unwrap();
        assert!((import::character_height(&h) - 1.8).abs() < 1e-4);
        assert!(!h.warnings.iter().any(|w| w.contains("tall")));
    }
    let e = load_as(
        "a.vrm",
        &bytes,
        &ImportOptions {
            height_m: Some(-1.0),
            ..Default::default()
        },
    )
    .unwrap_err();
    assert!(e.to_string().starts_with("height: must be between"), "{e}");
}

/// A character read in centimetres and baked writes the file's own units back: read again
/// in centimetres, the baked motion is where the track put it, in metres.
#[test]
fn gltf_read_in_centimetres_bakes_back_in_centimetres() {
    let cm = ImportOptions {
        units: Some(Units::Cm),
        ..Default::default()
    };
    let c = load_as("a.vrm", &vrm1(), &cm).unwrap();
    let mut frame = c.skeleton.rest_world();
    for t in &mut frame {
        t.translation += Vec3::new(0.5, 0.2, -0.3);
    }
    let track = ragdoll::track::Track {
        fps: 30.0,
        frames: vec![frame.clone(), frame.clone()],
    };
    let spec = ragdoll::spec::build_spec(&c, &Default::default()).unwrap();
    let out = ragdoll::export::gltf::to_glb(&c, &spec, &track).unwrap();
    let back = load_as("baked.glb", &out, &cm).unwrap();
    let clip = back.clips.iter().find(|k| k.name == "ragdoll").unwrap();
    let mut posed = vec![Transform::IDENTITY; back.skeleton.len()];
    back.skeleton.world_from_local(&clip.frames[0], &mut posed);
    for (a, b) in frame.iter().zip(&posed) {
        assert!(
            (a.translation - b.translation).length() < 1e-4,
            "{} {}",
            a.translation,
            b.translation
        );
    }
}

#[test]
fn clips_are_chosen_by_name_or_index_and_a_missing_one_lists_them() {
    let bytes = vrm1();
    let pick = |c: &str| ImportOptions {
        clip: Some(ClipChoice::parse(c)),
        ..Default::default()
    };
    let all = load_as("a.vrm", &bytes, &ImportOptions::default()).unwrap();
    assert_eq!(all.clips.len(), 2);
    let wave = load_as("a.vrm", &bytes, &pick("Wave")).unwrap();
    assert_eq!(wave.clips.len(), 1);
    assert_eq!(
        (wave.clips[0].name.as_str(), wave.clips[0].duration()),
        ("Wave", 2.0)
    );
    let one = load_as("a.vrm", &bytes, &pick("1")).unwrap();
    assert_eq!(one.clips[0].name, "Wave");
    let e = load_as("a.vrm", &bytes, &pick("Dance"))
        .unwrap_err()
        .to_string();
    assert!(
        e.ends_with(
            "a.vrm: clip \"Dance\": no such clip; the file's 2 clips are 0 \"Idle\", 1 \"Wave\""
        ),
        "{e}"
    );
}

#[test]
fn bvh_has_one_clip_at_index_0() {
    let bvh = "HIERARCHY\nROOT Hips\n{\n OFFSET 0 90 0\n CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n JOINT Head\n {\n  OFFSET 0 80 0\n  CHANNELS 3 Zrotation Xrotation Yrotation\n  End Site\n  {\n   OFFSET 0 10 0\n  }\n }\n}\nMOTION\nFrames: 2\nFrame Time: 0.1\n0 90 0 0 0 0 0 0 0\n0 91 0 0 0 0 0 0 0\n";
    let opts = |c: &str| ImportOptions {
        clip: Some(ClipChoice::parse(c)),
        ..Default::default()
    };
    let c = load_as("walk.bvh", bvh.as_bytes(), &opts("0")).unwrap();
    assert_eq!(c.clips[0].frames.len(), 2);
    let e = load_as("walk.bvh", bvh.as_bytes(), &opts("1"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("clip 1: no such clip; the file's 1 clips are 0 (unnamed)"),
        "{e}"
    );
    // --height on BVH: the BVH exporter keeps the file's numbers (its unit scales along).
    let h = load_as(
        "walk.bvh",
        bvh.as_bytes(),
        &ImportOptions {
            height_m: Some(0.9),
            ..Default::default()
        },
    )
    .unwrap();
    assert!((import::character_height(&h) - 0.9).abs() < 1e-5);
}

fn rig(name: &str) -> PathBuf {
    common::shared_data().join("rigs").join(name)
}

#[test]
#[ignore = "needs ../shared/data"]
fn the_vrm_0_sample_maps_its_22_bones() {
    let c = import::load(&rig("threevrm_sphere_vrm0.vrm"), &ImportOptions::default()).unwrap();
    let want = [
        ("hips", "Hips"),
        ("spine", "Spine"),
        ("chest", "Chest"),
        ("upperChest", "UpperChest"),
        ("neck", "Neck"),
        ("head", "Head"),
        ("leftShoulder", "Shoulder.L"),
        ("leftUpperArm", "UpperArm.L"),
        ("leftLowerArm", "LowerArm.L"),
        ("leftHand", "Hand.L"),
        ("rightShoulder", "Shoulder.R"),
        ("rightUpperArm", "UpperArm.R"),
        ("rightLowerArm", "LowerArm.R"),
        ("rightHand", "Hand.R"),
        ("leftUpperLeg", "UpperLeg.L"),
        ("leftLowerLeg", "LowerLeg.L"),
        ("leftFoot", "Foot.L"),
        ("leftToes", "Toes.L"),
        ("rightUpperLeg", "UpperLeg.R"),
        ("rightLowerLeg", "LowerLeg.R"),
        ("rightFoot", "Foot.R"),
        ("rightToes", "Toes.R"),
    ];
    let mut got = bone_names(&c);
    got.sort();
    let mut want = pairs(&want);
    want.sort();
    assert_eq!(got, want);
    assert!(c.warnings.is_empty(), "{:?}", c.warnings);
}

#[test]
#[ignore = "needs ../shared/data"]
fn the_orc_plays_the_clip_asked_for() {
    let path = rig("quaternius_um_orc_ikfeet.gltf");
    let pick = |c: &str| ImportOptions {
        clip: Some(ClipChoice::parse(c)),
        ..Default::default()
    };
    let all = import::load(&path, &ImportOptions::default()).unwrap();
    assert_eq!(all.clips.len(), 14);
    let punch = import::load(&path, &pick("Punch")).unwrap();
    assert_eq!(punch.clips.len(), 1);
    assert_eq!(punch.clips[0], all.clips[8]);
    assert_eq!(
        import::load(&path, &pick("8")).unwrap().clips[0],
        all.clips[8]
    );
    let e = import::load(&path, &pick("Dance")).unwrap_err().to_string();
    assert!(e.contains("13 \"Yes\""), "{e}");
}

#[test]
#[ignore = "needs ../shared/data"]
fn the_fox_is_centimetres_and_told_so() {
    let path = common::shared_data().join("gltf/Fox.glb");
    let m = import::load(&path, &ImportOptions::default()).unwrap();
    let h = import::character_height(&m);
    assert!(h > 50.0, "{h}");
    assert!(
        m.warnings
            .iter()
            .any(|w| w.contains("m tall") && w.contains("--units cm")),
        "{:?}",
        m.warnings
    );
    let cm = import::load(
        &path,
        &ImportOptions {
            units: Some(Units::Cm),
            ..Default::default()
        },
    )
    .unwrap();
    assert!((import::character_height(&cm) - h / 100.0).abs() < 1e-3);
    assert!(cm.warnings.is_empty(), "{:?}", cm.warnings);
    let spec = ragdoll::spec::build_spec(&cm, &Default::default()).unwrap();
    let big = ragdoll::spec::build_spec(&m, &Default::default()).unwrap();
    // Masses from volume: a hundredth of the size is a millionth of the mass.
    let ratio = big.total_mass_kg() / spec.total_mass_kg();
    assert!((ratio / 1e6 - 1.0).abs() < 0.01, "{ratio}");
}
