//! `ragdoll simulate SCENE.toml -o DIR` end to end: every example scene in `examples/`
//! runs into a temporary folder, its files read back, its glTF judged by the Khronos
//! validator where node is installed; bad scenes and flags fail with one clear line and
//! leave nothing behind; two runs write the same bytes. The examples that need the shared
//! data, and a scene mixing its glTF and BVH characters, are ignored tests (`--ignored`).

use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;

mod common;

use common::*;

/// The example scenes that run on a bare clone.
fn bare_examples() -> Vec<PathBuf> {
    let (bare, _) = examples();
    assert!(bare.len() >= 4, "examples/ holds the four scenes: {bare:?}");
    bare
}

/// The example scenes whose first line says they need the shared data (the dragon).
fn data_examples() -> Vec<PathBuf> {
    data_dir();
    let (_, data) = examples();
    assert!(!data.is_empty(), "no example is marked {NEEDS_DATA:?}");
    data
}

/// Runs a scene into `out` and returns the paths the tool listed on stdout.
fn run_scene(dir: &Path, scene: &Path, out: &Path) -> Vec<PathBuf> {
    let o = ragdoll(
        dir,
        &[
            "simulate",
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ],
    );
    assert!(o.status.success(), "{}: {}", scene.display(), stderr(&o));
    String::from_utf8(o.stdout)
        .unwrap()
        .lines()
        .map(PathBuf::from)
        .collect()
}

/// A metric must be a number (serde_json writes NaN and infinity as null).
fn number(v: &Value, key: &str, what: &str) -> f64 {
    v[key]
        .as_f64()
        .unwrap_or_else(|| panic!("{what}: {key} is not a number: {v}"))
}

#[test]
fn every_example_scene_runs_and_its_files_read_back() {
    scenes_run_and_their_files_read_back(&bare_examples());
}

#[test]
#[ignore = "needs ../shared/data"]
fn every_data_example_scene_runs_and_its_files_read_back() {
    scenes_run_and_their_files_read_back(&data_examples());
}

fn scenes_run_and_their_files_read_back(scenes: &[PathBuf]) {
    let tmp = tempfile::tempdir().unwrap();
    for scene in scenes {
        let stem = scene.file_stem().unwrap().to_string_lossy().into_owned();
        let out = tmp.path().join(&stem);
        let listed = run_scene(tmp.path(), scene, &out);
        let report_path = listed
            .iter()
            .find(|p| p.extension().is_some_and(|e| e == "json"))
            .unwrap_or_else(|| panic!("{stem}: no report listed in {listed:?}"));
        let report: Value =
            serde_json::from_str(&std::fs::read_to_string(report_path).unwrap()).unwrap();
        assert_eq!(report["nan"], Value::Bool(false), "{stem}: NaN seen");
        for key in [
            "max_limit_violation_deg",
            "max_penetration_m",
            "max_joint_separation_m",
            "energy_drift",
            "seconds",
            "fps",
        ] {
            assert!(number(&report, key, &stem).is_finite());
        }
        let characters = report["characters"].as_array().unwrap();
        assert!(!characters.is_empty());
        for c in characters {
            let name = c["name"].as_str().unwrap();
            assert_eq!(c["nan"], Value::Bool(false), "{stem}/{name}: NaN seen");
            number(c, "max_limit_violation_deg", name);
            number(c, "max_joint_separation_m", name);
            // Each character's BVH is there and reads back with as many frames.
            let bvh = out.join(c["bvh"].as_str().unwrap());
            assert!(
                listed.contains(&bvh),
                "{stem}: {} not listed",
                bvh.display()
            );
            let back = ragdoll::import::bvh::load(&bvh, &Default::default()).unwrap_or_else(|e| {
                panic!("{}: {e}", bvh.display());
            });
            assert_eq!(
                back.clips[0].frames.len() as u64,
                report["frames"].as_u64().unwrap()
            );
        }
        // The scene's glTF reads back with our importer, a character and its clip.
        let glb = listed
            .iter()
            .find(|p| p.extension().is_some_and(|e| e == "glb"))
            .unwrap_or_else(|| panic!("{stem}: no glb listed in {listed:?}"));
        let back = ragdoll::import::gltf::load(glb).unwrap_or_else(|e| panic!("{e}"));
        let clip = back
            .clips
            .iter()
            .find(|c| c.name == ragdoll::export::gltf::ANIMATION_NAME)
            .unwrap();
        assert_eq!(clip.frames.len() as u64, report["frames"].as_u64().unwrap());
        // Every file listed exists, and nothing half-written is left over.
        for p in &listed {
            assert!(p.is_file(), "{}", p.display());
        }
        let leftovers: Vec<_> = std::fs::read_dir(&out)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .filter(|n| n.to_string_lossy().ends_with(".tmp"))
            .collect();
        assert!(leftovers.is_empty(), "{leftovers:?}");
    }
}

#[test]
#[ignore = "needs node and the Khronos validator (cd .ci && npm install)"]
fn example_scene_gltfs_pass_the_khronos_validator() {
    scene_gltfs_pass_the_khronos_validator(&bare_examples(), None);
}

/// The data examples, and characters of every kind in one file: glTF inputs with textures
/// and their own animations, a BVH, the built-in humanoid.
#[test]
#[ignore = "needs ../shared/data, node and the Khronos validator (cd .ci && npm install)"]
fn data_scene_gltfs_pass_the_khronos_validator() {
    scene_gltfs_pass_the_khronos_validator(&data_examples(), Some(&data_dir()));
}

/// Node and the validator (`cd .ci && npm install`) are needed, so both callers are
/// ignored tests that `.ci/run` runs after installing them; asked to run without them, the
/// test fails saying what is missing rather than passing having checked nothing.
fn scene_gltfs_pass_the_khronos_validator(scenes: &[PathBuf], data: Option<&Path>) {
    let script = repo().join(".ci/gltf_validate.mjs");
    let validator = repo().join(".ci/node_modules/gltf-validator");
    let node = Command::new("node").arg("--version").output();
    assert!(
        validator.is_dir() && node.is_ok(),
        "node or {} is missing (cd .ci && npm install --no-audit --no-fund)",
        validator.display()
    );
    let tmp = tempfile::tempdir().unwrap();
    let mut glbs = Vec::new();
    for scene in scenes {
        let out = tmp.path().join(scene.file_stem().unwrap());
        glbs.extend(
            run_scene(tmp.path(), scene, &out)
                .into_iter()
                .filter(|p| p.extension().is_some_and(|e| e == "glb")),
        );
    }
    // Characters of every kind in one file: glTF inputs with textures and their own
    // animations, a BVH, the built-in humanoid.
    if let Some(data) = data {
        let file = |p: &str| format!("{:?}", data.join(p).display().to_string());
        let text = format!(
            "duration_s = 1\n[[character]]\nfile = {}\nactivate = 0.3\n[[character]]\nfile = {}\nposition = [2, 0, 0]\n[[character]]\nfile = {}\nposition = [-2, 0, 0]\n[[character]]\nfile = {}\nposition = [0, 0, 3]\n[[character]]\nposition = [0, 0, -3]\n[[character]]\nfile = {}\nposition = [4, 0, 0]\n[[blast]]\ntnt_kg = 1\nposition = [1, 0.5, 1]\ntime_s = 0.5\n",
            file("gltf/CesiumMan.glb"),
            file("gltf/CesiumMan.glb"),
            file("gltf/SimpleSkin.gltf"),
            file("bvh/cmu_pirouette_threejs.bvh"),
            file("gltf/Fox.glb"),
        );
        std::fs::write(tmp.path().join("mixed.toml"), text).unwrap();
        let listed = run_scene(
            tmp.path(),
            &tmp.path().join("mixed.toml"),
            &tmp.path().join("mixed"),
        );
        assert_eq!(listed.len(), 1 + 6 + 1, "{listed:?}");
        glbs.push(tmp.path().join("mixed/scene.glb"));
    }
    let o = Command::new("node")
        .arg(&script)
        .args(&glbs)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{text}{}", stderr(&o));
    assert_eq!(text.matches(": 0 errors").count(), glbs.len(), "{text}");
}

#[test]
fn two_runs_of_a_scene_write_identical_glb_and_bvh_files() {
    let tmp = tempfile::tempdir().unwrap();
    for name in ["blast_crowd.toml", "shots.toml"] {
        let scene = repo().join("examples").join(name);
        let a = run_scene(tmp.path(), &scene, &tmp.path().join("a"));
        let b = run_scene(tmp.path(), &scene, &tmp.path().join("b"));
        assert_eq!(a.len(), b.len());
        for (x, y) in a.iter().zip(&b) {
            if x.extension().is_some_and(|e| e == "glb" || e == "bvh") {
                let (x_bytes, y_bytes) = (std::fs::read(x).unwrap(), std::fs::read(y).unwrap());
                assert!(
                    x_bytes == y_bytes,
                    "{} and {} differ",
                    x.display(),
                    y.display()
                );
            }
        }
    }
}

#[test]
fn a_bad_scene_fails_with_file_line_and_key_and_writes_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(
        tmp.path().join("bad.toml"),
        "duration_s = 1\n[[character]]\n[[blast]]\ntnt_kg = -1\nposition = [0, 0, 0]\n",
    )
    .unwrap();
    let o = ragdoll(tmp.path(), &["simulate", "bad.toml", "-o", "out"]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(
        err.contains("bad.toml: line 4: [[blast]] 1: tnt_kg:"),
        "{err}"
    );
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(!tmp.path().join("out").exists());
}

#[test]
fn scene_flags_override_or_are_refused() {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(
        tmp.path().join("s.toml"),
        "[[character]]\nname = \"solo\"\n",
    )
    .unwrap();
    // --seconds and --fps override the scene's own.
    let o = ragdoll(
        tmp.path(),
        &[
            "simulate",
            "s.toml",
            "-o",
            "out",
            "--seconds",
            "0.5",
            "--fps",
            "10",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(tmp.path().join("out/report.json")).unwrap())
            .unwrap();
    assert_eq!(report["frames"], 6, "0.5 s at 10 fps plus the first frame");
    assert!(tmp.path().join("out/solo.bvh").is_file());
    assert!(tmp.path().join("out/scene.glb").is_file());
    // Per-character flags belong in the scene; a file name as -o is a mistake.
    for (args, words) in [
        (vec!["--mass", "80"], "mass_kg"),
        (vec!["--female"], "female"),
        (vec!["--activate", "blast"], "activate"),
        (vec!["--units", "cm"], "units"),
    ] {
        let mut all = vec!["simulate", "s.toml", "-o", "out2"];
        all.extend(args);
        let o = ragdoll(tmp.path(), &all);
        assert!(!o.status.success());
        assert!(stderr(&o).contains(words), "{}", stderr(&o));
    }
    let o = ragdoll(tmp.path(), &["simulate", "s.toml", "-o", "x.glb"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("folder"), "{}", stderr(&o));
    assert!(!tmp.path().join("out2").exists() && !tmp.path().join("x.glb").exists());
    // A flag that makes the scene's settings disagree is refused before anything runs:
    // damping from the command line on the scene's particle backend, or the file's
    // damping on a particle backend the command line chose.
    std::fs::write(
        tmp.path().join("p.toml"),
        "backend = \"particle\"\n[[character]]\n",
    )
    .unwrap();
    std::fs::write(
        tmp.path().join("d.toml"),
        "joint_damping = 1.5\n[[character]]\n",
    )
    .unwrap();
    for args in [
        ["p.toml", "--joint-damping", "1"],
        ["d.toml", "--backend", "particle"],
    ] {
        let mut all = vec!["simulate", "-o", "out3", "--seconds", "0.2"];
        all.extend(args);
        let o = ragdoll(tmp.path(), &all);
        assert!(!o.status.success());
        let e = stderr(&o);
        assert!(e.contains("joint_damping") && e.contains(args[0]), "{e}");
        assert!(!tmp.path().join("out3").exists());
    }
    let o = ragdoll(
        tmp.path(),
        &[
            "simulate",
            "d.toml",
            "-o",
            "out4",
            "--seconds",
            "0.2",
            "--backend",
            "fast",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
}
