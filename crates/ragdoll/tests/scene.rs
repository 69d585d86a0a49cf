//! Scene files: the format (defaults, every error naming the file, line and key), the
//! examples in `examples/`, a run with several characters, the one-glTF-for-everyone export
//! and determinism.
//!
//! Pushes, fields and pins are only checked to parse and run here; their physics is tested
//! with the world.

mod common;

use std::path::{Path, PathBuf};

use glam::{Quat, Vec3};
use ragdoll::error::Error;
use ragdoll::events::{Field, Push};
use ragdoll::export::gltf::{ANIMATION_NAME, scene_to_glb};
use ragdoll::import::gltf::from_bytes;
use ragdoll::math::Transform;
use ragdoll::scene::{OPEN_END_S, Outputs, Scene};
use ragdoll::world::Activation;
use serde_json::Value;

fn examples_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

fn example(name: &str) -> Scene {
    let path = examples_dir().join(name);
    Scene::load(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn parse(text: &str) -> Result<Scene, Error> {
    Scene::from_toml(text, Path::new("test.toml"))
}

/// The error of a scene that must fail, as (line, message).
fn failure(text: &str) -> (usize, String) {
    match parse(text) {
        Ok(_) => panic!("this scene should fail:\n{text}"),
        Err(Error::Parse {
            path,
            line,
            message,
        }) => {
            assert_eq!(path, Path::new("test.toml"));
            (line, message)
        }
        Err(e) => panic!("expected a parse error with a line, got: {e}"),
    }
}

#[test]
fn an_empty_character_table_is_the_builtin_humanoid_with_every_default() {
    let scene = parse("[[character]]\n").unwrap();
    assert_eq!(scene.duration_s, 3.0);
    assert_eq!(scene.settings.fps, 30.0);
    assert_eq!(scene.settings.ground, Some(0.0));
    assert_eq!(scene.settings.gravity, Vec3::new(0.0, -9.80665, 0.0));
    assert_eq!(scene.outputs, Outputs::default());
    assert_eq!(
        scene.outputs.bvh_file("humanoid").as_deref(),
        Some("humanoid.bvh")
    );
    let c = &scene.characters[0];
    assert_eq!(
        (c.name.as_str(), c.input.as_str()),
        ("humanoid", "built-in")
    );
    assert_eq!(c.character.name, "humanoid");
    assert_eq!(c.spec.name, "humanoid");
    assert_eq!(c.activation, Activation::Immediately);
    assert!((c.spec.total_mass_kg() - 75.0).abs() < 0.01);
    assert_eq!(c.line, 1);
}

#[test]
fn settings_and_characters_are_read_as_written() {
    let scene = parse(
        r#"
duration_s = 1.5
fps = 24
gravity = [0, -1.62, 0]   # the Moon
ground = "none"
backend = "rigid"
start_pose = "rest"

[output]
glb = "all.glb"
bvh = false
report = "r.json"

[[character]]
[[character]]
[[character]]
name = "big"
position = [1, 2, 3]
facing_deg = 90
mass_kg = 110
female = true
"#,
    )
    .unwrap();
    assert_eq!(scene.duration_s, 1.5);
    assert_eq!(scene.settings.fps, 24.0);
    assert_eq!(scene.settings.gravity, Vec3::new(0.0, -1.62, 0.0));
    assert_eq!(scene.settings.ground, None);
    assert_eq!(scene.settings.start, ragdoll::world::StartPose::Rest);
    assert_eq!(scene.outputs.glb.as_deref(), Some("all.glb"));
    assert_eq!(scene.outputs.bvh, None);
    assert_eq!(scene.outputs.report.as_deref(), Some("r.json"));
    // Default names step around each other.
    let names: Vec<&str> = scene.characters.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["humanoid", "humanoid_2", "big"]);
    let big = &scene.characters[2];
    assert!((big.spec.total_mass_kg() - 110.0).abs() < 0.05);
    assert_eq!(big.position, Vec3::new(1.0, 2.0, 3.0));
    assert_eq!(big.line, 16);
    let turned = big.placement().transform_dir(Vec3::Z);
    assert!(
        (turned - Vec3::X).length() < 1e-6,
        "facing 90° turns +Z to +X"
    );
}

#[test]
fn events_are_read_with_their_defaults() {
    let scene = parse(
        r#"
duration_s = 2
[[character]]
name = "a"
[[character]]
name = "b"

[[blast]]
tnt_kg = 1
position = [0, 0.5, 0]

[[projectile]]
origin = [0, 1, 5]
target = [0, 1, 0]
time_s = 0.1
count = 3
interval_s = 0.2

[[push]]
character = "b"
target = "head"
impulse_ns = [0, 0, 10]
time_s = 0.3

[[push]]
character = "a"
target = "pelvis"
force_n = [5, 0, 0]

[[field]]
kind = "wind"
velocity_mps = [3, 0, 0]
start_s = 0.5

[[field]]
kind = "gravity"
keys = [{ time_s = 0, gravity = [0, -9.8, 0] }, { time_s = 1, gravity = [0, 0, 0] }]

[[pin]]
character = "a"
target = "hand_l"
position = [0.4, 0.9, 0]
"#,
    )
    .unwrap();
    let b = &scene.blasts[0].event;
    assert_eq!((b.tnt_kg, b.time_s, b.scale), (1.0, 0.0, 1.0));
    assert_eq!(scene.blasts[0].line, 8);
    let shots: Vec<f32> = scene.projectiles.iter().map(|p| p.event.time_s).collect();
    assert_eq!(shots.len(), 3);
    for (t, want) in shots.iter().zip([0.1, 0.3, 0.5]) {
        assert!((t - want).abs() < 1e-6, "{shots:?}");
    }
    for p in &scene.projectiles {
        assert_eq!(p.event.direction, Vec3::new(0.0, 0.0, -5.0));
        assert_eq!((p.event.mass_kg, p.event.speed_mps), (0.008, 360.0));
        assert_eq!(p.line, 12);
    }
    assert_eq!(scene.pushes[0].character, Some(1));
    assert_eq!(
        scene.pushes[1].event,
        Push::Force {
            target: "pelvis".into(),
            force_n: Vec3::new(5.0, 0.0, 0.0),
            start_s: 0.0,
            end_s: OPEN_END_S,
        }
    );
    assert_eq!(
        scene.fields[0].event,
        Field::Wind {
            velocity_mps: Vec3::new(3.0, 0.0, 0.0),
            start_s: 0.5,
            end_s: OPEN_END_S,
        }
    );
    assert!(matches!(&scene.fields[1].event, Field::Gravity { keys } if keys.len() == 2));
    let pin = &scene.pins[0];
    assert_eq!(pin.character, Some(0));
    assert_eq!(pin.event.keys, vec![(0.0, Vec3::new(0.4, 0.9, 0.0))]);
    assert_eq!(pin.event.stiffness_hz, None);
    assert_eq!(pin.event.release_s, None);
}

/// Each bad scene fails on the line given, with a message naming the key (and, where it
/// helps, the table).
#[test]
fn every_mistake_names_the_line_and_the_key() {
    let one = "[[character]]\n";
    let two = "[[character]]\nname = \"a\"\n[[character]]\nname = \"b\"\n";
    let cases: Vec<(String, usize, &[&str])> = vec![
        ("fsp = 30\n[[character]]\n".into(), 1, &["fsp"]),
        (
            "duration_s = \"long\"\n[[character]]\n".into(),
            1,
            &["duration_s"],
        ),
        (
            "duration_s = -1\n[[character]]\n".into(),
            1,
            &["duration_s", "-1"],
        ),
        ("fps = 0\n[[character]]\n".into(), 1, &["fps"]),
        (
            "\ngravity = [0, 1]\n[[character]]\n".into(),
            2,
            &["gravity"],
        ),
        (
            "ground = \"lava\"\n[[character]]\n".into(),
            1,
            &["ground", "none"],
        ),
        (
            "backend = \"soft\"\n[[character]]\n".into(),
            1,
            &["backend", "rigid"],
        ),
        (
            "start_pose = \"sitting\"\n[[character]]\n".into(),
            1,
            &["start_pose"],
        ),
        ("duration_s = 1\n".into(), 1, &["[[character]]"]),
        (
            format!("{one}colour = \"red\"\n"),
            2,
            &["colour", "[[character]] 1"],
        ),
        (format!("{one}mass_kg = 0\n"), 2, &["mass_kg"]),
        (format!("{one}position = [0, 0, nan]\n"), 2, &["position"]),
        (format!("{one}activate = \"soon\"\n"), 2, &["activate"]),
        (
            format!("{one}activate = 1.0\n"),
            2,
            &["activate", "no animation"],
        ),
        (
            format!("{one}activate = \"blast\"\n"),
            2,
            &["activate", "no animation"],
        ),
        (format!("{one}units = \"cm\"\n"), 2, &["units", "BVH"]),
        (
            format!("{one}file = \"nowhere.glb\"\n"),
            2,
            &["file", "nowhere.glb"],
        ),
        (format!("{one}name = \"../x\"\n"), 2, &["name"]),
        (
            format!("{one}name = \"x\"\n[[character]]\nname = \"x\"\n"),
            4,
            &["name", "two characters"],
        ),
        (
            format!("{one}spec = \"s.toml\"\nmass_kg = 70\n"),
            3,
            &["mass_kg", "spec"],
        ),
        (
            format!("{one}[[blast]]\nposition = [0, 0, 0]\n"),
            2,
            &["tnt_kg", "[[blast]] 1"],
        ),
        (
            format!("{one}[[blast]]\ntnt_kg = -2\nposition = [0, 0, 0]\n"),
            3,
            &["tnt_kg", "[[blast]] 1"],
        ),
        (
            format!(
                "{one}[[blast]]\ntnt_kg = 1\nposition = [0, 0, 0]\n[[blast]]\ntnt_kg = 1\nposition = [0, 0, 0]\ntime_s = -1\n"
            ),
            8,
            &["time_s", "[[blast]] 2"],
        ),
        (
            format!("{one}[[projectile]]\norigin = [0, 1, 0]\n"),
            2,
            &["direction", "target"],
        ),
        (
            format!(
                "{one}[[projectile]]\norigin = [0, 1, 0]\ndirection = [1, 0, 0]\ntarget = [0, 1, 5]\n"
            ),
            5,
            &["target", "not both"],
        ),
        (
            format!("{one}[[projectile]]\norigin = [0, 1, 0]\ntarget = [0, 1, 0]\n"),
            4,
            &["target", "origin"],
        ),
        (
            format!("{one}[[projectile]]\norigin = [0, 1, 0]\ndirection = [0, 0, 0]\n"),
            4,
            &["direction"],
        ),
        (
            format!("{one}[[projectile]]\norigin = [0, 1, 0]\ndirection = [1, 0, 0]\ncount = 0\n"),
            5,
            &["count"],
        ),
        (
            format!("{one}[[push]]\ntarget = \"hed\"\nimpulse_ns = [1, 0, 0]\n"),
            3,
            &["target", "hed", "pelvis"],
        ),
        (
            format!("{two}[[push]]\ntarget = \"head\"\nimpulse_ns = [1, 0, 0]\n"),
            5,
            &["character", "several"],
        ),
        (
            format!(
                "{two}[[push]]\ncharacter = \"c\"\ntarget = \"head\"\nimpulse_ns = [1, 0, 0]\n"
            ),
            6,
            &["character", "\"c\""],
        ),
        (
            format!("{one}[[push]]\ntarget = \"head\"\n"),
            2,
            &["impulse_ns", "force_n"],
        ),
        (
            format!("{one}[[push]]\ntarget = \"head\"\nimpulse_ns = [1, 0, 0]\nend_s = 2\n"),
            5,
            &["end_s", "impulse"],
        ),
        (
            format!(
                "{one}[[push]]\ntarget = \"head\"\nforce_n = [1, 0, 0]\nstart_s = 2\nend_s = 1\n"
            ),
            6,
            &["end_s", "start_s"],
        ),
        (
            format!("{one}[[field]]\nkind = \"vortex\"\n"),
            3,
            &["kind", "vortex"],
        ),
        (
            format!("{one}[[field]]\nkind = \"wind\"\nvelocity_mps = [1, 0, 0]\nradius_m = 2\n"),
            5,
            &["radius_m", "wind"],
        ),
        (
            format!("{one}[[field]]\nkind = \"radial\"\ncenter = [0, 0, 0]\nstrength_mps2 = 1\n"),
            3,
            &["radius_m", "missing"],
        ),
        (
            format!(
                "{one}[[field]]\nkind = \"radial\"\ncenter = [0, 0, 0]\nstrength_mps2 = 1\nradius_m = 0\n"
            ),
            6,
            &["radius_m"],
        ),
        (
            format!(
                "{one}[[field]]\nkind = \"gravity\"\nkeys = [{{ time_s = 1, gravity = [0, 0, 0] }}, {{ time_s = 0, gravity = [0, 0, 0] }}]\n"
            ),
            4,
            &["keys", "backwards"],
        ),
        (
            format!(
                "{one}[[field]]\nkind = \"gravity\"\nkeys = [{{ time_s = 1, gravity = [0, 0] }}]\n"
            ),
            4,
            &["gravity"],
        ),
        (
            format!(
                "{one}[[field]]\nkind = \"gravity\"\nkeys = [{{ time = 1, gravity = [0, 0, 0] }}]\n"
            ),
            4,
            &["time"],
        ),
        (
            format!("{one}[[pin]]\ntarget = \"hand_l\"\n"),
            2,
            &["position", "keys"],
        ),
        (
            format!("{one}[[pin]]\ntarget = \"hand_l\"\nposition = [0, 1, 0]\nstiffness_hz = -1\n"),
            5,
            &["stiffness_hz"],
        ),
        (
            format!(
                "{one}[[pin]]\ntarget = \"hand_l\"\nposition = [0, 1, 0]\ndamping_ratio = 0.5\n"
            ),
            5,
            &["damping_ratio", "stiffness_hz"],
        ),
        (
            format!("{one}[output]\nglb = \"../scene.glb\"\n"),
            3,
            &["glb", "[output]"],
        ),
        (
            format!("{one}[output]\nglb = \"scene.gltf\"\n"),
            3,
            &["glb", ".glb"],
        ),
        (format!("{one}[output]\nformat = \"fbx\"\n"), 3, &["format"]),
        (
            format!("{two}[output]\nbvh = \"all.bvh\"\n"),
            6,
            &["bvh", "{name}"],
        ),
        (
            format!("{one}[output]\nreport = \"humanoid.bvh\"\n"),
            3,
            &["report", ".json"],
        ),
        (
            format!("{one}name = \"Ann\"\n[[character]]\nname = \"ann\"\n"),
            4,
            &["name", "case"],
        ),
    ];
    for (text, line, words) in &cases {
        let (got_line, message) = failure(text);
        assert_eq!(
            got_line, *line,
            "wrong line for:\n{text}\nmessage: {message}"
        );
        for w in *words {
            assert!(
                message.contains(w),
                "message {message:?} lacks {w:?} for:\n{text}"
            );
        }
        assert!(!message.contains('\n'), "one line: {message:?}");
    }
}

#[test]
fn a_spec_file_is_recognised_and_refused_as_a_scene() {
    let spec = ragdoll::spec::build_spec(&ragdoll::skeleton::humanoid(), &Default::default())
        .unwrap()
        .to_toml();
    let (line, message) = failure(&spec);
    assert_eq!(line, 1);
    assert!(message.contains("spec, not a scene"), "{message}");
}

#[test]
fn character_and_spec_files_are_found_beside_the_scene() {
    let dir = tempfile_dir("beside");
    let spec =
        ragdoll::spec::build_spec(&ragdoll::skeleton::humanoid(), &Default::default()).unwrap();
    std::fs::create_dir_all(dir.join("specs")).unwrap();
    std::fs::write(dir.join("specs/light.toml"), spec.to_toml()).unwrap();
    std::fs::write(
        dir.join("scene.toml"),
        "[[character]]\nname = \"x\"\nspec = \"specs/light.toml\"\n",
    )
    .unwrap();
    let scene = Scene::load(&dir.join("scene.toml")).unwrap();
    assert_eq!(scene.characters[0].spec.name, "x", "the scene's name wins");
    assert_eq!(scene.characters[0].spec.bodies.len(), spec.bodies.len());
    // A broken spec fails naming the scene line and the spec file's own place.
    std::fs::write(
        dir.join("specs/light.toml"),
        "format_version = 1\nbodies = 3\n",
    )
    .unwrap();
    let err = Scene::load(&dir.join("scene.toml"))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("scene.toml: line 3: [[character]] \"x\": spec:"),
        "{err}"
    );
    assert!(err.contains("light.toml"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

fn tempfile_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("ragdoll-scene-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn every_example_loads_with_what_it_describes() {
    let blast = example("blast_crowd.toml");
    assert_eq!(blast.characters.len(), 4);
    assert_eq!(blast.blasts.len(), 1);
    let shots = example("shots.toml");
    assert_eq!(shots.projectiles.len(), 6, "a burst of five and one more");
    assert_eq!(
        shots.outputs.bvh_file("target").as_deref(),
        Some("shots_target.bvh")
    );
    let forces = example("forces.toml");
    assert_eq!((forces.pushes.len(), forces.fields.len()), (2, 4));
    let pins = example("pin_and_drag.toml");
    assert_eq!(pins.pins.len(), 2);
    assert_eq!(pins.pins[0].event.keys.len(), 3);
    assert_eq!(pins.pins[1].event.stiffness_hz, Some(2.0));
    // The serpent (our own mesh, rigged on import) is pinned by the head where it rests.
    let serpent = example("serpent.toml");
    assert_eq!((serpent.characters.len(), serpent.pins.len()), (1, 1));
    let skeleton = &serpent.characters[0].character.skeleton;
    let head = skeleton.rest_world()[skeleton.find("head").unwrap()].translation;
    let first = serpent.pins[0].event.keys[0].1;
    assert!(
        (head - first).length() < 0.02,
        "head at {head}, pin at {first}"
    );
    // Every example that runs on a bare clone loads (a new one gets checked here too).
    let (bare, _) = common::examples();
    for path in &bare {
        Scene::load(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    }
    assert!(bare.len() >= 4, "{bare:?}");
}

/// The examples whose first line says they need the shared data (the Stanford dragon).
#[test]
#[ignore = "needs ../shared/data"]
fn every_data_example_loads_with_what_it_describes() {
    common::shared_data();
    let (_, data) = common::examples();
    for path in &data {
        Scene::load(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    }
    let dragon = example("dragon.toml");
    assert_eq!(dragon.characters.len(), 1);
    assert_eq!(dragon.pins.len(), 1);
    assert_eq!(dragon.pins[0].event.keys.len(), 4);
}

#[test]
fn characters_stand_where_the_scene_puts_them() {
    let scene = parse(
        "duration_s = 0.1\n[[character]]\nposition = [3, 0, -2]\nfacing_deg = 90\n[[character]]\nposition = [-1, 0, 4]\n",
    )
    .unwrap();
    let result = scene.run().unwrap();
    for (c, track) in scene.characters.iter().zip(&result.tracks) {
        let s = &c.character.skeleton;
        let first = &track.frames[0];
        let pelvis = first[s.find("pelvis").unwrap()].translation;
        assert!((pelvis.x - c.position.x).abs() < 1e-4 && (pelvis.z - c.position.z).abs() < 1e-4);
        // The left hand hangs at +X of the humanoid; facing turns it about Y.
        let hand = first[s.find("hand_l").unwrap()].translation - pelvis;
        let want = Quat::from_rotation_y(c.facing_deg.to_radians()) * Vec3::X;
        assert!(hand.normalize().dot(want) > 0.3, "{hand} vs {want}");
    }
}

#[test]
fn the_blast_reaches_every_character_of_the_crowd_nearer_ones_faster() {
    let scene = example("blast_crowd.toml");
    let result = scene.run().unwrap();
    let r = &result.report;
    assert!(!r.metrics.nan);
    assert_eq!(r.characters.len(), 4);
    assert_eq!(result.tracks.len(), 4);
    for t in &result.tracks {
        assert_eq!(t.frames.len(), 91);
    }
    let blast = &r.blasts[0];
    let speed = |name: &str| {
        let c = blast.characters.iter().find(|c| c.name == name).unwrap();
        Vec3::from_array(c.com_velocity_mps.expect("the blast passed")).length()
    };
    // The blast falls off with distance: dev stands 4 m away, the others about 2.5 m.
    for near in ["ann", "ben", "cho"] {
        assert!(
            speed(near) > speed("dev"),
            "{near}: {} vs dev {}",
            speed(near),
            speed("dev")
        );
    }
    let charge = Vec3::from_array(blast.position);
    for c in &blast.characters {
        let v = Vec3::from_array(c.com_velocity_mps.unwrap());
        let away = scene.characters[c.character].position - charge;
        let away = Vec3::new(away.x, 0.0, away.z).normalize();
        assert!(
            v.dot(away) > 0.0,
            "{} is thrown away from the charge",
            c.name
        );
    }
    for c in &r.characters {
        assert!(!c.nan, "{}", c.name);
        assert!(c.max_limit_violation_deg.is_finite() && c.max_joint_separation_m < 0.01);
        assert_eq!(c.activated_at_s, Some(0.0));
    }
}

#[test]
fn a_burst_hits_the_character_it_is_aimed_at() {
    let result = example("shots.toml").run().unwrap();
    let hits = &result.report.projectiles;
    assert_eq!(hits.len(), 6);
    // The first shot flies before anything has moved: it must hit the chest it aims at.
    assert_eq!(hits[0].character, Some(0));
    assert_eq!(hits[0].body.as_deref(), Some("chest"));
    assert!((hits[0].impulse_ns - 0.05 * 150.0).abs() < 1e-4);
}

#[test]
fn scenes_with_pushes_fields_and_pins_run() {
    for name in ["forces.toml", "pin_and_drag.toml"] {
        let scene = example(name);
        let result = scene.run().unwrap();
        assert!(!result.report.metrics.nan, "{name}");
        let frames = (scene.duration_s * scene.settings.fps).round() as usize + 1;
        for t in &result.tracks {
            assert_eq!(t.frames.len(), frames, "{name}");
            assert!(t.frames.iter().flatten().all(|t| t.is_finite()), "{name}");
        }
    }
}

// --- The glTF of a scene ---------------------------------------------------------------

/// A GLB's JSON and binary chunk.
fn glb_parts(bytes: &[u8]) -> (Value, Vec<u8>) {
    assert_eq!(&bytes[..4], b"glTF");
    let u32_at = |i: usize| u32::from_le_bytes(bytes[i..i + 4].try_into().unwrap()) as usize;
    let json_len = u32_at(12);
    let json: Value = serde_json::from_slice(&bytes[20..20 + json_len]).unwrap();
    let bin_at = 20 + json_len;
    let bin_len = u32_at(bin_at);
    (json, bytes[bin_at + 8..bin_at + 8 + bin_len].to_vec())
}

/// An accessor's floats (tightly packed, as the exporter writes animation data).
fn floats(json: &Value, bin: &[u8], accessor: usize) -> Vec<f32> {
    let a = &json["accessors"][accessor];
    let view = &json["bufferViews"][a["bufferView"].as_u64().unwrap() as usize];
    let start =
        (view["byteOffset"].as_u64().unwrap_or(0) + a["byteOffset"].as_u64().unwrap_or(0)) as usize;
    let n = a["count"].as_u64().unwrap() as usize
        * match a["type"].as_str().unwrap() {
            "SCALAR" => 1,
            "VEC3" => 3,
            "VEC4" => 4,
            t => panic!("{t}"),
        };
    bin[start..start + 4 * n]
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
        .collect()
}

#[test]
fn the_scene_gltf_holds_every_character_and_one_animation_for_all() {
    let scene = parse(
        "duration_s = 0.5\n[[character]]\nname = \"a\"\n[[character]]\nname = \"b\"\nposition = [2, 0, 1]\nfacing_deg = 45\n[[character]]\nname = \"c\"\nposition = [-2, 0, 0]\n[[blast]]\ntnt_kg = 1\nposition = [0, 0.3, 0.5]\n",
    )
    .unwrap();
    let result = scene.run().unwrap();
    let files = scene.encode(&result).unwrap();
    let names: Vec<&str> = files.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(
        names,
        ["scene.glb", "a.bvh", "b.bvh", "c.bvh", "report.json"]
    );
    let (json, bin) = glb_parts(&files[0].1);
    assert_eq!(json["skins"].as_array().unwrap().len(), 3);
    assert_eq!(json["meshes"].as_array().unwrap().len(), 3);
    assert_eq!(
        json["scenes"][0]["nodes"].as_array().unwrap().len(),
        6,
        "a root joint and a mesh node each"
    );
    let anims = json["animations"].as_array().unwrap();
    assert_eq!(anims.len(), 1);
    assert_eq!(anims[0]["name"], ANIMATION_NAME);
    // Every joint node of every skin is animated, and the root joint's last key is where the
    // character's track ends.
    let channels = anims[0]["channels"].as_array().unwrap();
    let samplers = anims[0]["samplers"].as_array().unwrap();
    for (k, (c, track)) in scene.characters.iter().zip(&result.tracks).enumerate() {
        let joints: Vec<u64> = json["skins"][k]["joints"]
            .as_array()
            .unwrap()
            .iter()
            .map(|j| j.as_u64().unwrap())
            .collect();
        assert_eq!(joints.len(), c.character.skeleton.len());
        for &j in &joints {
            assert!(
                channels.iter().any(|ch| ch["target"]["node"] == j),
                "{} joint node {j}",
                c.name
            );
        }
        let root = joints[0];
        let ch = channels
            .iter()
            .find(|ch| ch["target"]["node"] == root && ch["target"]["path"] == "translation")
            .unwrap();
        let sampler = &samplers[ch["sampler"].as_u64().unwrap() as usize];
        let keys = floats(&json, &bin, sampler["output"].as_u64().unwrap() as usize);
        let last = Vec3::from_slice(&keys[keys.len() - 3..]);
        let want = track.frames.last().unwrap()[0].translation;
        assert!(
            (last - want).length() < 1e-5,
            "{}: {last} vs {want}",
            c.name
        );
    }
    // Our importer reads it back: the first character (every skin has as many vertices),
    // its `ragdoll` clip ending where its track ends.
    let back = from_bytes(&files[0].1, Path::new("scene.glb")).unwrap();
    assert_eq!(
        back.skeleton.len(),
        scene.characters[0].character.skeleton.len()
    );
    let clip = back
        .clips
        .iter()
        .find(|c| c.name == ANIMATION_NAME)
        .unwrap();
    assert_eq!(clip.frames.len(), result.tracks[0].frames.len());
    let mut world = vec![Transform::IDENTITY; back.skeleton.len()];
    back.skeleton
        .world_from_local(clip.frames.last().unwrap(), &mut world);
    for (a, b) in world.iter().zip(result.tracks[0].frames.last().unwrap()) {
        assert!((a.translation - b.translation).length() < 1e-4);
    }
}

#[test]
#[ignore = "needs ../shared/data"]
fn gltf_and_bvh_characters_keep_their_own_look_in_a_scene() {
    let data = common::shared_data();
    let cesium = data.join("gltf/CesiumMan.glb");
    let bvh = data.join("bvh/cmu_pirouette_threejs.bvh");
    let text = format!(
        "duration_s = 0.5\n[[character]]\n[[character]]\nfile = {:?}\nposition = [2, 0, 0]\nactivate = 0.2\n[[character]]\nfile = {:?}\nposition = [-2, 0, 0]\n",
        cesium.display().to_string(),
        bvh.display().to_string()
    );
    // Waiting for a blast that never comes is a mistake worth stopping for.
    let waiting = text.replace("activate = 0.2", "activate = \"blast\"");
    let (line, message) = failure(&waiting);
    assert_eq!(line, 3, "{message}");
    assert!(message.contains("needs a [[blast]]"), "{message}");
    let scene = parse(&text).unwrap();
    let result = scene.run().unwrap();
    assert_eq!(
        result.report.characters[1]
            .activated_at_s
            .map(|t| (t * 1e3).round()),
        Some(200.0)
    );
    let parts: Vec<_> = scene
        .characters
        .iter()
        .zip(&result.tracks)
        .map(|(c, t)| (&c.character, &c.spec, t))
        .collect();
    let glb = scene_to_glb(&parts).unwrap();
    let (json, _) = glb_parts(&glb);
    // CesiumMan's textured material and its own walk cycle come along.
    assert!(json["images"].as_array().is_some_and(|i| !i.is_empty()));
    assert!(json["textures"].as_array().is_some_and(|t| !t.is_empty()));
    let anims = json["animations"].as_array().unwrap();
    assert_eq!(anims[0]["name"], ANIMATION_NAME);
    assert!(
        anims.len() >= 2,
        "CesiumMan's own animation is kept after the ragdoll one"
    );
    let materials: Vec<&str> = json["materials"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|m| m["name"].as_str())
        .collect();
    assert!(materials.contains(&"Cesium_Man-effect"), "{materials:?}");
    assert!(
        materials.contains(&"ragdoll body"),
        "the capsules of the others: {materials:?}"
    );
    // Read back, the importer picks CesiumMan (the skin with the most vertices) and its
    // ragdoll clip is CesiumMan's track.
    let back = from_bytes(&glb, Path::new("scene.glb")).unwrap();
    let cesium_scene = &scene.characters[1].character;
    assert_eq!(back.skeleton.len(), cesium_scene.skeleton.len());
    let clip = back
        .clips
        .iter()
        .find(|c| c.name == ANIMATION_NAME)
        .unwrap();
    let mut world = vec![Transform::IDENTITY; back.skeleton.len()];
    for (f, frame) in clip.frames.iter().enumerate() {
        back.skeleton.world_from_local(frame, &mut world);
        for (a, b) in world.iter().zip(&result.tracks[1].frames[f]) {
            assert!((a.translation - b.translation).length() < 1e-4, "frame {f}");
        }
    }
}

#[test]
fn the_same_scene_gives_identical_files_twice() {
    let scene = example("blast_crowd.toml");
    let a = scene.encode(&scene.run().unwrap()).unwrap();
    let b = scene.encode(&scene.run().unwrap()).unwrap();
    assert_eq!(a.len(), b.len());
    for ((name, x), (_, y)) in a.iter().zip(&b) {
        if name.ends_with(".glb") || name.ends_with(".bvh") {
            assert!(x == y, "{name} differs between two runs");
        }
    }
}

/// The guide's annotated scene (its scene file reference) stays in step with the parser
/// (less the lines that name files, which do not exist here, and the keys that apply to a
/// character file only, the clip keys among them; `height` applies to the built-in
/// humanoid too).
#[test]
fn the_scene_reference_parses() {
    let page = examples_dir().join("../docs/src/reference/scene.md");
    let section = std::fs::read_to_string(&page).unwrap();
    let start = section.find("```toml\n").expect("a toml block") + 8;
    let block = &section[start..start + section[start..].find("```").unwrap()];
    let text: String = block
        .lines()
        .filter(|l| {
            !["file =", "spec =", "units =", "up =", "clip", "roles ="]
                .iter()
                .any(|k| l.starts_with(k))
        })
        .map(|l| format!("{l}\n"))
        .collect();
    let scene = parse(&text).unwrap_or_else(|e| panic!("{e}\n{text}"));
    assert_eq!(scene.characters[0].name, "alice");
    assert_eq!(scene.characters.len(), 1 + 50, "alice and the crowd");
    assert_eq!(scene.characters[50].name, "people-50");
    assert_eq!(scene.projectiles.len(), 5);
    assert_eq!(
        (scene.pushes.len(), scene.fields.len(), scene.pins.len()),
        (1, 2, 1)
    );
}

/// `powered` on a character: motors track its clip; mistakes name the line and key, and a
/// character without an animation is refused.
#[test]
fn powered_characters_are_read_and_checked() {
    let (line, message) = failure("[[character]]\npowered = { strength = 1.0 }\n");
    assert_eq!(line, 2, "{message}");
    assert!(message.contains("powered"), "{message}");
    let (line, message) = failure("[[character]]\n\npowered = { strength = 2.0 }\n");
    assert_eq!(line, 3, "{message}");
    assert!(message.contains("powered"), "{message}");
    let (_, message) = failure("[[character]]\npowered = { strength = 1.0, stiff = 3 }\n");
    assert!(message.contains("stiff"), "{message}");
}

/// `powered` on a character with a clip from the shared data: its motors are read and run.
#[test]
#[ignore = "needs ../shared/data"]
fn powered_characters_run_on_their_clip() {
    let data = common::shared_data();
    let dir = tempfile_dir("powered");
    let file = data.join("bvh/mocapbank_bvh-python.bvh");
    std::fs::write(
        dir.join("scene.toml"),
        format!(
            "duration_s = 1.0\n[[character]]\nfile = {:?}\npowered = {{ strength = 1.0, fade_out = [0.5, 1.0], root_on_clip = true }}\n",
            file.to_str().unwrap()
        ),
    )
    .unwrap();
    let scene = Scene::load(&dir.join("scene.toml")).unwrap();
    let motors = scene.characters[0].motors.clone().expect("motors read");
    assert!(motors.root_on_clip);
    assert_eq!(motors.strength_keys, vec![(0.5, 1.0), (1.0, 0.0)]);
    let result = scene.run().unwrap();
    assert_eq!(result.tracks.len(), 1);
    std::fs::remove_dir_all(&dir).ok();
}
