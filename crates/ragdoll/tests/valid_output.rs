//! Whatever a glTF input gets wrong, the file we write must still be valid glTF 2.0:
//! defects a tool can mend are mended, each kind with one warning naming what changed,
//! and what a loader must not read is refused in one sentence naming the file and place.
//! The inputs are built here, one per defect seen in real files and one with all of them,
//! and the outputs (one character alone, and in a scene beside the built-in humanoid) are
//! judged by a checker (`valid_output/checker.rs`) that needs no node; the ignored test at
//! the end runs the Khronos validator on the same outputs.
//!
//! Set `RAGDOLL_GLTF_OUT=some/dir` to keep the exported files.

#[path = "valid_output/checker.rs"]
mod checker;
#[path = "valid_output/inputs.rs"]
mod inputs;

use std::path::{Path, PathBuf};
use std::process::Command;

use ragdoll::import::gltf;
use ragdoll::skeleton::Character;
use ragdoll::spec::RagdollSpec;
use ragdoll::track::Track;
use serde_json::{Value, json};

use checker::{items, problems};
use inputs::{base, defects, f32s, glb, glb_parts, push_view, with_accepted_extensions};

fn no_spec(name: &str) -> RagdollSpec {
    RagdollSpec {
        format_version: ragdoll::spec::SPEC_FORMAT_VERSION,
        name: name.into(),
        bodies: Vec::new(),
        joints: Vec::new(),
        collision: Default::default(),
    }
}

/// A short track: the rest pose for three frames.
fn rest_track(c: &Character) -> Track {
    Track {
        fps: 30.0,
        frames: vec![c.skeleton.rest_world(); 3],
    }
}

/// The character baked alone, and in a scene beside the built-in humanoid.
fn exports(c: &Character) -> [Vec<u8>; 2] {
    let track = rest_track(c);
    let alone = ragdoll::export::gltf::to_glb(c, &no_spec(&c.name), &track).unwrap();
    let humanoid = ragdoll::skeleton::humanoid();
    let spec = ragdoll::spec::build_spec(&humanoid, &Default::default()).unwrap();
    let parts = [
        (c, &no_spec(&c.name), &track),
        (&humanoid, &spec, &rest_track(&humanoid)),
    ];
    let scene = ragdoll::export::gltf::scene_to_glb(&parts).unwrap();
    [alone, scene]
}

fn import(name: &str, json: &Value, bin: &[u8]) -> ragdoll::Result<Character> {
    gltf::from_bytes(&glb(json, bin), Path::new(&format!("{name}.glb")))
}

fn keep(name: &str, bytes: &[u8]) -> Option<PathBuf> {
    let dir = PathBuf::from(std::env::var_os("RAGDOLL_GLTF_OUT")?);
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    ragdoll::export::write_atomic(&path, bytes).unwrap();
    Some(path)
}

/// Imports `name` and exports it alone and in a scene: the character and the outputs,
/// named (and kept, when asked).
fn outputs(name: &str, json: &Value, bin: &[u8]) -> (Character, Vec<(String, Vec<u8>)>) {
    let c = import(name, json, bin).unwrap();
    let [alone, scene] = exports(&c);
    let outs = vec![
        (format!("{name}.glb"), alone),
        (format!("{name}_scene.glb"), scene),
    ];
    for (file, bytes) in &outs {
        keep(file, bytes);
    }
    (c, outs)
}

/// [`outputs`], each checked to be valid and to need no repair when read again.
fn outputs_of(name: &str, json: &Value, bin: &[u8]) -> (Character, Vec<(String, Vec<u8>)>) {
    let (c, outs) = outputs(name, json, bin);
    for (file, bytes) in &outs {
        let (doc, data) = glb_parts(bytes);
        let found = problems(&doc, &data);
        assert!(found.is_empty(), "{file}: {found:#?}");
        // What we wrote needs no repair when it is read again.
        let back = gltf::from_bytes(bytes, Path::new(file)).unwrap();
        assert!(back.warnings.is_empty(), "{file}: {:?}", back.warnings);
    }
    (c, outs)
}

/// Every output of the tests above, unchecked: the validator is their judge.
fn all_outputs() -> Vec<(String, Vec<u8>)> {
    let (json, bin) = base();
    let mut outs = outputs("base", &json, &bin).1;
    let (mut everything, mut everything_bin) = base();
    for d in defects() {
        let (mut json, mut bin) = base();
        (d.apply)(&mut json, &mut bin);
        (d.apply)(&mut everything, &mut everything_bin);
        outs.extend(outputs(d.name, &json, &bin).1);
    }
    outs.extend(outputs("all_defects", &everything, &everything_bin).1);
    let (json, bin) = with_accepted_extensions();
    outs.extend(outputs("accepted_extensions", &json, &bin).1);
    outs
}

#[test]
fn the_checker_finds_every_defect_in_the_inputs_and_none_in_the_base() {
    let (json, bin) = base();
    assert_eq!(problems(&json, &bin), Vec::<String>::new());
    for d in defects() {
        let (mut json, mut bin) = base();
        (d.apply)(&mut json, &mut bin);
        assert!(!problems(&json, &bin).is_empty(), "{} not caught", d.name);
    }
}

#[test]
fn a_valid_input_gives_no_warning_and_a_valid_output() {
    let (json, bin) = base();
    let (c, _) = outputs_of("base", &json, &bin);
    assert!(c.warnings.is_empty(), "{:?}", c.warnings);
    // Its own animation comes along, after the ragdoll's.
    assert_eq!(c.clips.len(), 1);
}

#[test]
fn each_defect_is_repaired_with_one_warning_and_the_output_is_valid() {
    for d in defects() {
        let (mut json, mut bin) = base();
        (d.apply)(&mut json, &mut bin);
        let (c, _) = outputs_of(d.name, &json, &bin);
        assert_eq!(c.warnings.len(), 1, "{}: {:?}", d.name, c.warnings);
        let w = &c.warnings[0];
        for says in d.warning {
            assert!(w.contains(says), "{}: {says:?} not in {w}", d.name);
        }
        assert!(!w.contains('\n'), "{w}");
    }
}

#[test]
fn all_defects_together_give_one_warning_each_and_a_valid_output() {
    let (mut json, mut bin) = base();
    let all = defects();
    for d in &all {
        (d.apply)(&mut json, &mut bin);
    }
    let (c, _) = outputs_of("all_defects", &json, &bin);
    assert_eq!(c.warnings.len(), all.len(), "{:#?}", c.warnings);
    for d in &all {
        let says = d.warning[0];
        assert_eq!(
            c.warnings.iter().filter(|w| w.contains(says)).count(),
            1,
            "{}: {says:?} in {:#?}",
            d.name,
            c.warnings
        );
    }
}

#[test]
fn an_animation_left_with_no_channel_is_removed() {
    // Decreasing times on the joint `top`: before this repair the whole file was refused.
    let (mut json, mut bin) = base();
    let v = push_view(&mut json, &mut bin, &f32s(&[0.0, 1.0, 0.5]));
    json["accessors"][4]["bufferView"] = json!(v);
    let (c, outs) = outputs_of("times_decrease", &json, &bin);
    assert_eq!(c.warnings.len(), 1, "{:?}", c.warnings);
    let w = &c.warnings[0];
    assert!(
        w.contains("key 2, 0.5 s, is not after 1 s")
            && w.contains("animation 0 (\"wave\"), left with no channel, was removed"),
        "{w}"
    );
    assert!(c.clips.is_empty());
    let (doc, _) = glb_parts(&outs[0].1);
    let names: Vec<&Value> = items(&doc, "animations")
        .iter()
        .map(|a| &a["name"])
        .collect();
    assert_eq!(names, [&json!("ragdoll")]);
}

#[test]
fn required_extensions_we_copy_through_are_kept() {
    let (json, bin) = with_accepted_extensions();
    let (c, outs) = outputs_of("accepted_extensions", &json, &bin);
    assert!(c.warnings.is_empty(), "{:?}", c.warnings);
    for (file, bytes) in &outs {
        let (doc, _) = glb_parts(bytes);
        assert_eq!(
            doc["extensionsRequired"], json["extensionsRequired"],
            "{file}"
        );
        let m = &doc["materials"][0];
        assert!(
            m["extensions"].get("KHR_materials_unlit").is_some(),
            "{file}"
        );
    }
}

/// The one-line error importing `json` as `name.glb` gives.
fn refusal(name: &str, json: &Value, bin: &[u8]) -> String {
    let text = import(name, json, bin).unwrap_err().to_string();
    assert!(text.starts_with(&format!("{name}.glb: ")), "{text}");
    assert!(!text.contains('\n'), "{text}");
    text
}

#[test]
fn a_required_extension_we_do_not_support_is_refused_naming_it() {
    for ext in [
        "EXT_mesh_gpu_instancing",
        "KHR_animation_pointer",
        "VENDOR_magic",
    ] {
        let (mut json, bin) = base();
        json["extensionsUsed"] = json!(["KHR_texture_transform", ext]);
        json["extensionsRequired"] = json!(["KHR_texture_transform", ext]);
        let text = refusal("needs_more", &json, &bin);
        assert!(
            text.starts_with("needs_more.glb: extensionsRequired: requires ") && text.contains(ext),
            "{text}"
        );
    }
    // Only required ones: an extension used optionally is not the loader's to honour.
    let (mut json, bin) = base();
    json["extensionsUsed"] = json!(["VENDOR_magic"]);
    import("optional", &json, &bin).unwrap();
}

#[test]
fn another_major_version_of_gltf_is_refused_naming_it() {
    for (asset, place, says) in [
        (json!({"version": "3.0"}), "asset.version", "\"3.0\""),
        (json!({"version": "1.0"}), "asset.version", "\"1.0\""),
        (
            json!({"version": "2"}),
            "asset.version",
            "not a glTF version",
        ),
        (
            json!({"version": "2.1", "minVersion": "2.1"}),
            "asset.minVersion",
            "\"2.1\"",
        ),
    ] {
        let (mut json, bin) = base();
        json["asset"] = asset;
        let text = refusal("future", &json, &bin);
        assert!(text.contains(place) && text.contains(says), "{text}");
    }
    // A later minor version is forward compatible: read, and written as 2.0.
    let (mut json, bin) = base();
    json["asset"] = json!({"version": "2.1", "generator": "someone"});
    let (c, _) = outputs_of("minor", &json, &bin);
    assert_eq!(c.warnings.len(), 1, "{:?}", c.warnings);
    assert!(c.warnings[0].contains("asset.version \"2.1\" written as \"2.0\""));
}

/// The repository root, where `.ci/` is.
fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Node and the validator (`cd .ci && npm install`) are needed, so this test is ignored and
/// `.ci/run` runs it after installing them; asked to run without them, it fails saying
/// what is missing rather than passing having checked nothing.
#[test]
#[ignore = "needs node and the Khronos validator (cd .ci && npm install)"]
fn every_output_passes_the_khronos_validator() {
    let script = repo().join(".ci/gltf_validate.mjs");
    let validator = repo().join(".ci/node_modules/gltf-validator");
    let node = Command::new("node").arg("--version").output();
    assert!(
        validator.is_dir() && node.is_ok_and(|o| o.status.success()),
        "node or {} is missing (cd .ci && npm install --no-audit --no-fund)",
        validator.display()
    );
    let dir = std::env::temp_dir().join(format!("ragdoll-valid-output-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let mut files = Vec::new();
    for (name, bytes) in all_outputs() {
        let path = dir.join(name);
        std::fs::write(&path, bytes).unwrap();
        files.push(path);
    }
    let o = Command::new("node")
        .arg(&script)
        .args(&files)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    let errors = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{text}{errors}");
    assert_eq!(text.matches(": 0 errors").count(), files.len(), "{text}");
    std::fs::remove_dir_all(&dir).unwrap();
}
