//! The mesh check: bake each character's 3 s drop with the release CLI on `rigid` and on
//! `fast`, skin the baked glTF independently of our exporter ([`mesh_metrics`]), and hold
//! the mesh to the targets: no vertex deeper than 4 % of the character's height below the
//! floor, 99th-percentile edge stretch at most 1.6, joints within 5 mm scaled by its
//! height / 1.75 m (read from the run's report), and not resting a tenth of its height off
//! the floor; for the automatically rigged dragons also no edge over 4× and resting within
//! 3 % of its height of the floor. A character file's own clips are measured the same way,
//! as a reference the simulation has no part in.
//!
//! Run `cargo test --release -p ragdoll-cli --test mesh_check -- --ignored --nocapture`
//! to print the table of every data file (`docs/src/characters.md` shows it).

mod common;
mod mesh_metrics;

use std::path::{Path, PathBuf};

use common::{data_dir, ragdoll, stderr};
use mesh_metrics::{Metrics, clip_count, measure, measure_clip};

/// Seconds of the drop each file is baked for (the 3 s).
const SECONDS: &str = "3";

/// The data files (relative to the data folder) whose baked mesh meets the targets today
/// on `rigid`: each is held to them. A file that regresses fails the test.
const PASSING_RIGID: &[&str] = &[
    // Skeleton-only files: drawn as their bodies' capsules, each bound rigidly to its bone.
    "bvh/biovision_example_bvhio.bvh",
    "bvh/cmu_pirouette_threejs.bvh",
    "bvh/mocapbank_bvh-python.bvh",
    "bvh/two_joint_bvh_anim.bvh",
    "rigs/animdraw_rokoko_jesse_dance.bvh",
    "rigs/bvh11_cmu_131_01.bvh",
    // Skinned glTF characters drawn with their own mesh and weights.
    "rigs/kaykit_knight.glb",
    "rigs/quaternius_um_orc_ikfeet.gltf",
    // Creatures whose bodies hold their skin.
    "rigs/webxr_generic_hand_left.glb",
    // A strip of ten vertices: each body a thin box holding the few it carries.
    "gltf/SimpleSkin.gltf",
    // Rigged automatically (bone heat weights), bodies and their extra shapes holding
    // their skin.
    "mesh/stanford_dragon_13k.obj",
    "mesh/stanford_dragon_1k7.obj",
];

/// The data files that do not meet the targets on `rigid` yet, with what is wrong. They
/// are measured and printed, not asserted, except those whose own clips already stretch
/// their skin past the target: those are held to every other target and to no more
/// stretch than their own clips (`past_own_clips`). A file in neither list fails the test
/// so that a new data file cannot go unmeasured.
const FAILING_RIGID: &[&str] = &[
    // Humanoids whose bodies hold their skin (none sinks): edges across a joint crease
    // stretch as the joint bends to its limit.
    "gltf/CesiumMan.glb",            // p99 1.71 (its walk: 1.09)
    "rigs/threevrm_sphere_vrm0.vrm", // p99 2.11, joints 3.1 mm (1 m tall: 2.9 allowed)
    // rapier's joints open 7.4 mm as its 12,597-vertex, 81 kg body lands (5.2 allowed;
    // 0.8 mm on fast).
    "rigs/godot_mannequiny.glb",
    // Skins that stretch past the target under their own clips too: Robi's seams between
    // rigid parts open as its joints turn (its `run` 2.69, `walk` 1.83), and the Fox's
    // weights stretch at the hips, spine and neck (its `Walk` 2.44, `Run` 2.59).
    "rigs/godot_robi_ik.glb", // p99 1.77
    "gltf/Fox.glb",           // p99 2.36 (centimetres in a metres format)
];

/// [`PASSING_RIGID`] on the `fast` backend.
const PASSING_FAST: &[&str] = &[
    "bvh/biovision_example_bvhio.bvh",
    "bvh/cmu_pirouette_threejs.bvh",
    "bvh/mocapbank_bvh-python.bvh",
    "bvh/two_joint_bvh_anim.bvh",
    "rigs/animdraw_rokoko_jesse_dance.bvh",
    "rigs/bvh11_cmu_131_01.bvh",
    "rigs/godot_mannequiny.glb",
    "rigs/kaykit_knight.glb",
    "rigs/quaternius_um_orc_ikfeet.gltf",
    "rigs/webxr_generic_hand_left.glb",
    "gltf/SimpleSkin.gltf",
    "mesh/stanford_dragon_13k.obj",
    "mesh/stanford_dragon_1k7.obj",
];

/// [`FAILING_RIGID`] on the `fast` backend.
const FAILING_FAST: &[&str] = &[
    "gltf/CesiumMan.glb",            // p99 1.72
    "rigs/threevrm_sphere_vrm0.vrm", // p99 1.88
    "rigs/godot_robi_ik.glb",        // p99 1.80
    "gltf/Fox.glb",                  // p99 2.08
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

/// Bakes `source`'s 3 s drop on `backend` into `dir` and returns the .glb, or the CLI's
/// error (a scene runs on its own backend).
fn bake(source: &Source, dir: &Path, backend: &str) -> Result<PathBuf, String> {
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
            run(&[
                "demo",
                "-o",
                "demo",
                "--seconds",
                SECONDS,
                "--backend",
                backend,
            ])?;
            Ok(dir.join("demo/demo.glb"))
        }
        Source::File(p) => {
            let args = [
                "simulate",
                &file(p),
                "--seconds",
                SECONDS,
                "--backend",
                backend,
            ];
            run(&[&args[..], &["-o", "out.glb"]].concat())?;
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
                "--backend",
                backend,
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

/// Widest a joint may open, metres, on a character 1.75 m tall; scaled with the height.
const TARGET_JOINT_GAP_M: f32 = 0.005;

/// Highest the character may come to rest, as a fraction of its height: a body standing
/// a tenth of its height off the floor holds the skin up in the air.
const TARGET_REST_FRAC: f32 = 0.10;

/// What of the targets `m` misses (empty when it meets them all): no sinking past 4 % of
/// the height, p99 stretch, joints within 5 mm scaled by height / 1.75 m (`gap`: the
/// widest the run's report saw), no resting a tenth of the height up. `rigged` adds the
/// automatically rigged meshes' targets.
fn misses(m: &Metrics, gap: Option<f32>, rigged: bool) -> Vec<String> {
    let mut out = Vec::new();
    let most_gap = TARGET_JOINT_GAP_M * m.height / 1.75;
    if let Some(gap) = gap.filter(|&g| g > most_gap) {
        out.push(format!(
            "joints {:.1} mm apart > {:.1}",
            gap * 1000.0,
            most_gap * 1000.0
        ));
    }
    if !rigged && m.rest_frac() > TARGET_REST_FRAC {
        out.push(format!(
            "rests {:.1} % of its height off the floor",
            100.0 * m.rest_frac()
        ));
    }
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
fn row(name: &str, case: &Case) -> String {
    let (m, misses) = (&case.metrics, &case.misses);
    let own = case.own_p99.map_or("-".to_string(), |p| format!("{p:.2}"));
    let gap = case
        .gap
        .map_or("-".to_string(), |g| format!("{:.1}", g * 1000.0));
    format!(
        "{name:<46} {:>5} {:>6} {:>6.2} {:>7.1} {:>6.1} {:>5.0} {:>6.2} {:>6.2} {own:>6} {gap:>6}  {}",
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
/// worst 99th percentile of the character's own clips (see [`own_clips_p99`]); `joint`,
/// the widest any joint opened, mm (the run's report).
const HEADER: &str = "file, backend                                  frames  verts height lowest%  rest%  top%    p99    max    own  joint  verdict";

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
    /// The widest a joint opened, metres, as the run's report says.
    gap: Option<f32>,
}

/// The widest joint gap the report beside `glb` gives (`NAME.report.json`, or a folder's
/// `report.json`): the run's, or its characters' widest.
fn report_gap(glb: &Path) -> Option<f32> {
    let beside = glb.with_extension("report.json");
    let path = if beside.is_file() {
        beside
    } else {
        glb.with_file_name("report.json")
    };
    let report: serde_json::Value = serde_json::from_slice(&std::fs::read(path).ok()?).ok()?;
    let gap = |v: &serde_json::Value| v["max_joint_separation_m"].as_f64();
    let characters = report["characters"].as_array().into_iter().flatten();
    gap(&report)
        .into_iter()
        .chain(characters.filter_map(gap))
        .reduce(f64::max)
        .map(|g| g as f32)
}

/// Bakes and measures one case on `backend`; prints its row. `Err` says why it could not
/// be measured.
fn check(name: &str, source: &Source, rigged: bool, backend: &str) -> Result<Case, String> {
    let dir = tempfile::tempdir().unwrap();
    let label = format!("{name}, {backend}");
    let glb = bake(source, dir.path(), backend).map_err(|e| {
        println!("{label:<46} not baked: {e}");
        e
    })?;
    let metrics = measure(&glb);
    let gap = report_gap(&glb);
    let case = Case {
        misses: misses(&metrics, gap, rigged),
        own_p99: match source {
            Source::File(p) => own_clips_p99(p),
            _ => None,
        },
        metrics,
        gap,
    };
    println!("{}", row(&label, &case));
    Ok(case)
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
        case.gap,
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
    } = check("built-in humanoid", &Source::Demo, false, "rigid").expect("the demo bakes");
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
    } = check(
        "rig --humanoid person",
        &Source::FittedPerson,
        false,
        "rigid",
    )
    .expect("it bakes");
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
    let case =
        check("examples/dragon.toml", &Source::Scene(&scene), true, "fast").expect("it bakes");
    let m = case.metrics;
    assert_eq!(m.frames, 241, "8 s at 30 fps: {m:?}");
    assert!(m.stretch_p99 <= TARGET_P99, "{m:?}");
    assert!(m.stretch_max <= 4.0, "{m:?}");
    // It was laid down: at rest its top is below where its head was lifted to (1.2 m).
    assert!(m.highest_last < 0.9, "{m:?}");
    // The drop's joint target is not this scene's: dragged by its head with a spring,
    // the neck's joints open up to 5.0 mm (2.5 mm is the drop's bound at its 0.86 m).
    let missed: Vec<&String> = case
        .misses
        .iter()
        .filter(|m| !m.starts_with("joints"))
        .collect();
    assert!(missed.is_empty(), "{missed:?}");
    assert!(case.gap.is_some_and(|g| g < 0.01), "{:?}", case.gap);
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
    let mut regressed = Vec::new();
    let mut unlisted = Vec::new();
    for (backend, passing, failing) in [
        ("rigid", PASSING_RIGID, FAILING_RIGID),
        ("fast", PASSING_FAST, FAILING_FAST),
    ] {
        for listed in passing.iter().chain(failing) {
            assert!(
                files.iter().any(|f| f == listed),
                "{listed} is listed for {backend} but not in {}",
                data.display()
            );
        }
        println!("{HEADER}");
        for name in &files {
            let path = data.join(name);
            let rigged = name.starts_with("mesh/");
            let source = if rigged {
                Source::Rigged(&path)
            } else {
                Source::File(&path)
            };
            let result = check(name, &source, rigged, backend);
            let passes = passing.contains(&name.as_str());
            if !passes && !failing.contains(&name.as_str()) {
                unlisted.push(format!("{name} on {backend}"));
            }
            match result {
                Ok(case) if passes && !case.misses.is_empty() => {
                    regressed.push(format!("{name}, {backend}: {}", case.misses.join("; ")))
                }
                Err(e) if passes => regressed.push(format!("{name}, {backend}: not baked: {e}")),
                Ok(case) if !passes && case.misses.is_empty() => {
                    println!(
                        "  (note: {name} now meets the targets on {backend}: list it as passing)"
                    )
                }
                Ok(case) if case.own_p99.is_some_and(|p| p > TARGET_P99) => {
                    if let Some(why) = past_own_clips(&case, rigged) {
                        regressed.push(format!("{name}, {backend}: {why}"));
                    }
                }
                _ => {}
            }
        }
    }
    assert!(
        regressed.is_empty(),
        "meshes that no longer keep their shape:\n{}",
        regressed.join("\n")
    );
    assert!(
        unlisted.is_empty(),
        "data files in neither list: {unlisted:?}"
    );
}
