//! Issue 11's mesh check: bake each character's 3 s drop with the release CLI, skin the
//! baked glTF independently of our exporter ([`mesh_metrics`]), and hold the mesh to the
//! issue's targets: no vertex deeper than 4 % of the character's height below the floor,
//! 99th-percentile edge stretch at most 1.6; for the automatically rigged dragons also no
//! edge over 4× and resting within 3 % of its height of the floor. A character file's own
//! clips are measured the same way, as a reference the simulation has no part in.
//!
//! Run `cargo test --release -p ragdoll-cli --test mesh_check -- --ignored --nocapture`
//! to print the table of every data file.

mod common;
mod mesh_metrics;

use std::path::{Path, PathBuf};

use common::{data_dir, ragdoll, stderr};
use mesh_metrics::{Metrics, clip_count, measure, measure_clip};

/// Seconds of the drop each file is baked for (the 3 s).
const SECONDS: &str = "3";

/// The data files (relative to the data folder) whose baked mesh meets the targets today:
/// each is held to them. A file that regresses fails the test.
const PASSING: &[&str] = &[
    // Skeleton-only files: drawn as their bodies' capsules, each bound rigidly to its bone.
    "bvh/biovision_example_bvhio.bvh",
    "bvh/cmu_pirouette_threejs.bvh",
    "bvh/mocapbank_bvh-python.bvh",
    "bvh/two_joint_bvh_anim.bvh",
    "rigs/animdraw_rokoko_jesse_dance.bvh",
    "rigs/bvh11_cmu_131_01.bvh",
    // Skinned glTF characters drawn with their own mesh and weights.
    "gltf/SimpleSkin.gltf",
    "rigs/godot_mannequiny.glb",
    "rigs/kaykit_knight.glb",
    "rigs/quaternius_um_orc_ikfeet.gltf",
    // Creatures whose bodies hold their skin.
    "rigs/webxr_generic_hand_left.glb",
    // Rigged automatically (bone heat weights), bodies and their extra shapes holding
    // their skin.
    "mesh/stanford_dragon_13k.obj",
    "mesh/stanford_dragon_1k7.obj",
];

/// The data files that do not meet the targets yet, with what is wrong (issue 11's next
/// steps). They are measured and printed, not asserted, except those whose own clips
/// already stretch their skin past the target: those are held to every other target and
/// to no more stretch than their own clips (`past_own_clips`). A file in neither list
/// fails the test so that a new data file cannot go unmeasured.
const FAILING: &[&str] = &[
    // Humanoids whose bodies hold their skin (none sinks): edges across a joint crease
    // stretch as the joint bends to its limit.
    "gltf/CesiumMan.glb",            // p99 1.75 (its walk: 1.09)
    "rigs/threevrm_sphere_vrm0.vrm", // p99 2.11 (a 1 m sphere skinned to a humanoid)
    // Skins that stretch past the target under their own clips too: Robi's seams between
    // rigid parts open as its joints turn (its `run` 2.69, `walk` 1.83), and the Fox's
    // weights stretch at the hips, spine and neck (its `Walk` 2.44, `Run` 2.59).
    "rigs/godot_robi_ik.glb", // p99 1.77
    "gltf/Fox.glb",           // p99 2.36 (centimetres in a metres format)
];

/// How a case's baked glTF is made.
enum Source<'a> {
    /// The built-in humanoid (`ragdoll demo`).
    Demo,
    /// A character file, simulated directly.
    File(&'a Path),
    /// A mesh without a skeleton: `ragdoll rig`, then the rigged glTF simulated.
    Rigged(&'a Path),
    /// A scene file: its one character's baked glTF (`scene.glb`).
    Scene(&'a Path),
    /// The built-in humanoid's mesh as an unrigged OBJ (a person standing in an A-pose):
    /// `ragdoll rig --humanoid`, then the rigged glTF simulated.
    FittedPerson,
}

/// Bakes `source`'s 3 s drop into `dir` and returns the .glb, or the CLI's error.
fn bake(source: &Source, dir: &Path) -> Result<PathBuf, String> {
    let run = |args: &[&str]| {
        let out = ragdoll(dir, args);
        if out.status.success() {
            Ok(())
        } else {
            Err(stderr(&out).lines().last().unwrap_or("").to_string())
        }
    };
    let file = |p: &Path| p.to_str().expect("a UTF-8 data path").to_string();
    match source {
        Source::Demo => {
            run(&["demo", "-o", "demo", "--seconds", SECONDS])?;
            Ok(dir.join("demo/demo.glb"))
        }
        Source::File(p) => {
            run(&["simulate", &file(p), "--seconds", SECONDS, "-o", "out.glb"])?;
            Ok(dir.join("out.glb"))
        }
        Source::Scene(p) => {
            run(&["simulate", &file(p), "-o", "scene"])?;
            Ok(dir.join("scene/scene.glb"))
        }
        Source::FittedPerson | Source::Rigged(_) => {
            if let Source::Rigged(p) = source {
                run(&["rig", &file(p), "-o", "rigged.glb"])?;
            } else {
                run(&["demo", "-o", "demo", "--seconds", "0.1"])?;
                write_obj(&dir.join("demo/demo.glb"), &dir.join("person.obj"));
                run(&["rig", "person.obj", "--humanoid", "-o", "rigged.glb"])?;
            }
            let args = [
                "simulate",
                "rigged.glb",
                "--seconds",
                SECONDS,
                "-o",
                "out.glb",
            ];
            run(&args)?;
            Ok(dir.join("out.glb"))
        }
    }
}

/// Writes the first mesh of the binary glTF `glb`, in its bind pose and without its skin,
/// as an OBJ (read with the `gltf` crate, not our importer).
fn write_obj(glb: &Path, obj: &Path) {
    let gltf = gltf::Gltf::open(glb).unwrap();
    let blob = gltf.blob.as_deref();
    let prim = gltf
        .document
        .meshes()
        .next()
        .unwrap()
        .primitives()
        .next()
        .unwrap();
    let reader = prim.reader(|_| blob);
    let mut text = String::new();
    for p in reader.read_positions().unwrap() {
        text += &format!("v {} {} {}\n", p[0], p[1], p[2]);
    }
    let indices: Vec<u32> = reader.read_indices().unwrap().into_u32().collect();
    for t in indices.chunks_exact(3) {
        text += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    std::fs::write(obj, text).unwrap();
}

/// The bound on the 99th-percentile edge stretch.
const TARGET_P99: f32 = 1.6;

/// What of the targets `m` misses (empty when it meets them all). `rigged` adds
/// the automatically rigged meshes' targets.
fn misses(m: &Metrics, rigged: bool) -> Vec<String> {
    let mut out = Vec::new();
    if m.lowest_frac() < -0.04 {
        out.push(format!(
            "sinks {:.1} % of its height",
            -100.0 * m.lowest_frac()
        ));
    }
    if m.stretch_p99 > TARGET_P99 {
        out.push(format!("p99 stretch {:.2} > {TARGET_P99}", m.stretch_p99));
    }
    if rigged && m.stretch_max > 4.0 {
        out.push(format!("an edge stretches {:.1}× > 4×", m.stretch_max));
    }
    if rigged && m.rest_frac().abs() > 0.03 {
        out.push(format!(
            "rests {:.1} % of its height off the floor",
            100.0 * m.rest_frac()
        ));
    }
    out
}

/// One row of the printed table.
fn row(name: &str, m: &Metrics, own_p99: Option<f32>, misses: &[String]) -> String {
    let own = own_p99.map_or("-".to_string(), |p| format!("{p:.2}"));
    format!(
        "{name:<40} {:>5} {:>6} {:>6.2} {:>7.1} {:>6.1} {:>5.0} {:>6.2} {:>6.2} {own:>6}  {}",
        m.frames,
        m.vertices,
        m.height,
        100.0 * m.lowest_frac(),
        100.0 * m.rest_frac(),
        100.0 * m.highest_last / m.height,
        m.stretch_p99,
        m.stretch_max,
        if misses.is_empty() {
            "ok".to_string()
        } else {
            misses.join("; ")
        }
    )
}

/// The table's columns: height in metres (frame 0's vertical extent); lowest (over all
/// frames), rest (the last frame's lowest vertex) and top (its highest) in % of the height;
/// each edge's largest stretch over the drop, its 99th percentile and maximum; `own`, the
/// worst 99th percentile of the character's own clips (see [`own_clips_p99`]).
const HEADER: &str = "file                                     frames  verts height lowest%  rest%  top%    p99    max    own  verdict";

/// The worst 99th-percentile stretch of a character file's own animations, each played
/// from its own first frame: how far the skin stretches under the motion its author made
/// for it, a reference that shares nothing with our simulation. `None` for a file without
/// clips, or one the independent reader cannot take (it reads embedded buffers only).
fn own_clips_p99(path: &Path) -> Option<f32> {
    let ext = path.extension()?.to_str()?.to_ascii_lowercase();
    if !matches!(ext.as_str(), "glb" | "vrm") {
        return None;
    }
    (0..clip_count(path))
        .map(|c| measure_clip(path, Some(c)).stretch_p99)
        .reduce(f32::max)
}

/// One measured case: the baked mesh's metrics, the targets it misses, and its own clips'
/// stretch for a character file.
struct Case {
    metrics: Metrics,
    misses: Vec<String>,
    own_p99: Option<f32>,
}

/// Bakes and measures one case; prints its row. `Err` says why it could not be measured.
fn check(name: &str, source: &Source, rigged: bool) -> Result<Case, String> {
    let dir = tempfile::tempdir().unwrap();
    let glb = bake(source, dir.path()).map_err(|e| {
        println!("{name:<40} not baked: {e}");
        e
    })?;
    let metrics = measure(&glb);
    let misses = misses(&metrics, rigged);
    let own_p99 = match source {
        Source::File(p) => own_clips_p99(p),
        _ => None,
    };
    println!("{}", row(name, &metrics, own_p99, &misses));
    Ok(Case {
        metrics,
        misses,
        own_p99,
    })
}

/// Why a file whose own clips already stretch its skin past the target no longer holds
/// the weaker bound it is kept to instead: every other target met, and no more stretch
/// than its author's own animation. `None` when it holds.
fn past_own_clips(case: &Case, rigged: bool) -> Option<String> {
    let own = case.own_p99?;
    let m = &case.metrics;
    let mut out = misses(
        &Metrics {
            stretch_p99: 1.0,
            ..*m
        },
        rigged,
    );
    if m.stretch_p99 > own {
        out.push(format!(
            "p99 stretch {:.2} > its own clips' {own:.2}",
            m.stretch_p99
        ));
    }
    (!out.is_empty()).then(|| out.join("; "))
}

#[test]
fn the_built_in_humanoid_keeps_its_shape() {
    println!("{HEADER}");
    let Case {
        metrics: m,
        misses: miss,
        ..
    } = check("built-in humanoid", &Source::Demo, false).expect("the demo bakes");
    assert!(
        miss.is_empty(),
        "the built-in humanoid: {}",
        miss.join("; ")
    );
    // The measure saw the fall (3 s at 30 fps, the standing 1.75 m humanoid collapsed),
    // so the stretch above was measured over a moving mesh, not a still first frame.
    assert_eq!(m.frames, 91);
    assert!((1.6..1.9).contains(&m.height), "{m:?}");
    assert!(m.highest_last < 0.5 * m.height, "it did not fall: {m:?}");
}

/// A person without a skeleton (the built-in humanoid's mesh as an OBJ), given one by
/// `rig --humanoid` and dropped, keeps its shape and stays out of the floor as the data
/// files must: the fit's joints and the bone heat weights together make a ragdoll whose
/// bodies hold its skin.
#[test]
fn a_person_rigged_with_rig_humanoid_keeps_its_shape() {
    println!("{HEADER}");
    let Case {
        metrics: m,
        misses: miss,
        ..
    } = check("rig --humanoid person", &Source::FittedPerson, false).expect("it bakes");
    assert!(miss.is_empty(), "{}", miss.join("; "));
    assert!(m.highest_last < 0.5 * m.height, "it did not fall: {m:?}");
}

/// The dragon example (`examples/dragon.toml`: the 1.7k scan rigged on import, dragged by
/// its head for 3.8 s, then left to settle until 8 s, on the fast backend) sways without
/// spikes and rests on the floor, not in it: every target of the rigged dragons over the
/// whole scene. One foot's skin is blended over four spine bones, two of which hold
/// extra shapes of it; before the fast backend held such skin as skin points
/// (`spec/skin_points.rs`) it went 11 % of the dragon's height under the floor.
#[test]
#[ignore = "needs ../shared/data"]
fn the_dragon_example_sways_without_spikes() {
    // The scene names its scan beside the repository, whatever RAGDOLL_DATA says.
    let scan = common::repo().join("../shared/data/mesh/stanford_dragon_1k7.obj");
    assert!(scan.is_file(), "{} is missing", scan.display());
    let scene = common::repo().join("examples/dragon.toml");
    println!("{HEADER}");
    let case = check("examples/dragon.toml", &Source::Scene(&scene), true).expect("it bakes");
    let m = case.metrics;
    assert_eq!(m.frames, 241, "8 s at 30 fps: {m:?}");
    assert!(m.stretch_p99 <= TARGET_P99, "{m:?}");
    assert!(m.stretch_max <= 4.0, "{m:?}");
    // It was laid down: at rest its top is below where its head was lifted to (1.2 m).
    assert!(m.highest_last < 0.9, "{m:?}");
    assert!(case.misses.is_empty(), "{}", case.misses.join("; "));
}

/// Every file of the data folder's character folders, relative to it, sorted.
fn data_files(data: &Path) -> Vec<String> {
    let mut files = Vec::new();
    for folder in ["bvh", "gltf", "rigs", "mesh"] {
        for e in std::fs::read_dir(data.join(folder)).unwrap() {
            let name = e.unwrap().file_name().into_string().unwrap();
            files.push(format!("{folder}/{name}"));
        }
    }
    files.sort();
    files
}

#[test]
#[ignore = "needs ../shared/data"]
fn every_data_file_is_measured_and_the_passing_ones_keep_their_shape() {
    let data = data_dir();
    let files = data_files(&data);
    for listed in PASSING.iter().chain(FAILING) {
        assert!(
            files.iter().any(|f| f == listed),
            "{listed} is listed but not in {}",
            data.display()
        );
    }
    println!("{HEADER}");
    let mut regressed = Vec::new();
    let mut unlisted = Vec::new();
    for name in files {
        let path = data.join(&name);
        let rigged = name.starts_with("mesh/");
        let source = if rigged {
            Source::Rigged(&path)
        } else {
            Source::File(&path)
        };
        let result = check(&name, &source, rigged);
        let passing = PASSING.contains(&name.as_str());
        if !passing && !FAILING.contains(&name.as_str()) {
            unlisted.push(name.clone());
        }
        match result {
            Ok(case) if passing && !case.misses.is_empty() => {
                regressed.push(format!("{name}: {}", case.misses.join("; ")))
            }
            Err(e) if passing => regressed.push(format!("{name}: not baked: {e}")),
            Ok(case) if !passing && case.misses.is_empty() => {
                println!("  (note: {name} now meets the targets: move it to PASSING)")
            }
            Ok(case) if case.own_p99.is_some_and(|p| p > TARGET_P99) => {
                if let Some(why) = past_own_clips(&case, rigged) {
                    regressed.push(format!("{name}: {why}"));
                }
            }
            _ => {}
        }
    }
    assert!(
        regressed.is_empty(),
        "meshes that no longer keep their shape:\n{}",
        regressed.join("\n")
    );
    assert!(
        unlisted.is_empty(),
        "data files in neither PASSING nor FAILING: {unlisted:?}"
    );
}
