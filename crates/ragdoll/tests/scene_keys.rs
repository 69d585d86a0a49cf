//! A scene's `[[character]]` keys that the command line has as flags for one file:
//! `units`, `up`, `height`, `clip` and `roles`, with errors naming the scene file, the line
//! and the key; and the roles warning joining a scene character's warnings.

#[path = "rigid_parts_files/mod.rs"]
mod rigid_parts_files;
#[path = "scene_keys_files/mod.rs"]
mod scene_keys_files;

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

use ragdoll::error::Error;
use ragdoll::import::character_height;
use ragdoll::scene::Scene;
use ragdoll::world::{BackendConfig, BackendKind, FastConfig};
use scene_keys_files::person;

/// A scratch folder, removed when dropped.
struct Scratch(PathBuf);

impl Scratch {
    fn path(&self) -> &Path {
        &self.0
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A folder holding `standing.bvh`, `folded.bvh` and `bare.vrm` (a bare VRM 1.0 humanoid
/// hierarchy, metres), with the scene `text` at `scenes/scene.toml`.
fn folder(text: &str) -> (Scratch, PathBuf) {
    static NEXT: AtomicUsize = AtomicUsize::new(0);
    let n = NEXT.fetch_add(1, Ordering::Relaxed);
    let dir = Scratch(
        std::env::temp_dir().join(format!("ragdoll-scene-keys-{}-{n}", std::process::id())),
    );
    let _ = std::fs::remove_dir_all(dir.path());
    std::fs::create_dir_all(dir.path()).unwrap();
    std::fs::write(dir.path().join("standing.bvh"), person(false)).unwrap();
    std::fs::write(dir.path().join("folded.bvh"), person(true)).unwrap();
    let vrm = rigid_parts_files::bare("VRMC_vrm", false);
    std::fs::write(dir.path().join("bare.vrm"), &vrm).unwrap();
    std::fs::write(dir.path().join("bare_cm.vrm"), centimetres(&vrm)).unwrap();
    std::fs::create_dir(dir.path().join("scenes")).unwrap();
    let scene = dir.path().join("scenes/scene.toml");
    std::fs::write(&scene, text).unwrap();
    (dir, scene)
}

/// A bufferless GLB with every node's translation in centimetres, as an exporter that did
/// not convert writes it.
fn centimetres(glb: &[u8]) -> Vec<u8> {
    let len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    assert_eq!(glb.len(), 20 + len, "bufferless");
    let mut json: serde_json::Value = serde_json::from_slice(&glb[20..20 + len]).unwrap();
    for node in json["nodes"].as_array_mut().unwrap() {
        if let Some(t) = node.get_mut("translation") {
            for x in t.as_array_mut().unwrap() {
                *x = serde_json::json!(x.as_f64().unwrap() * 100.0);
            }
        }
    }
    rigid_parts_files::glb(&json, &[])
}

fn load(text: &str) -> Scene {
    let (_dir, path) = folder(text);
    Scene::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// The error of a scene that must fail, as (line, message), with `roles.toml` written
/// beside it.
fn failure(text: &str, roles: &str) -> (usize, String) {
    let (dir, path) = folder(text);
    std::fs::write(dir.path().join("scenes/roles.toml"), roles).unwrap();
    match Scene::load(&path) {
        Ok(_) => panic!("this scene should fail:\n{text}"),
        Err(Error::Parse {
            path: p,
            line,
            message,
        }) => {
            assert_eq!(p, path);
            assert!(!message.contains('\n'), "one line: {message}");
            (line, message)
        }
        Err(e) => panic!("expected a parse error, got {e:?}"),
    }
}

fn height(s: &Scene, k: usize) -> f32 {
    character_height(&s.characters[k].character)
}

#[test]
fn units_and_height_apply_to_bvh_and_vrm_characters() {
    let s = load(
        "[[character]]\nfile = \"../bare.vrm\"\n\
         [[character]]\nfile = \"../bare_cm.vrm\"\nunits = \"cm\"\nposition = [5, 0, 0]\n\
         [[character]]\nfile = \"../bare.vrm\"\nheight = 1.2\nposition = [-5, 0, 0]\n\
         [[character]]\nfile = \"../standing.bvh\"\nunits = \"m\"\nup = \"y\"\nheight = 2.5\nposition = [0, 0, 5]\n",
    );
    let metres = height(&s, 0);
    assert!(metres > 1.5 && metres < 2.2, "{metres}");
    let cm = height(&s, 1);
    assert!((cm / metres - 1.0).abs() < 1e-4, "{cm} {metres}");
    assert!((height(&s, 2) - 1.2).abs() < 1e-3, "{}", height(&s, 2));
    assert!((height(&s, 3) - 2.5).abs() < 1e-3, "{}", height(&s, 3));
}

#[test]
fn clip_picks_the_animation_by_index_or_name() {
    let s = load("[[character]]\nfile = \"../standing.bvh\"\nclip = 0\n");
    assert_eq!(s.characters[0].character.clips.len(), 1);
    let (line, m) = failure(
        "[[character]]\nname = \"a\"\nfile = \"../standing.bvh\"\n\nclip = 1\n",
        "",
    );
    assert_eq!(line, 5, "{m}");
    assert!(
        m.contains("[[character]] 1: clip: ../standing.bvh: clip 1: no such clip; the file's 1 clips are 0 (unnamed)"),
        "{m}"
    );
    let (line, m) = failure(
        "[[character]]\nfile = \"../standing.bvh\"\nclip = \"Dance\"\n",
        "",
    );
    assert_eq!(line, 3, "{m}");
    assert!(
        m.contains("clip: ../standing.bvh: clip \"Dance\": no such clip"),
        "{m}"
    );
    let (line, m) = failure("[[character]]\nfile = \"../standing.bvh\"\nclip = -1\n", "");
    assert_eq!(line, 3, "{m}");
    assert!(m.contains("clip") && m.contains("index from 0"), "{m}");
}

#[test]
fn import_keys_are_refused_where_they_cannot_apply() {
    let cases = [
        // (scene, line, what the message must hold)
        (
            "[[character]]\nfile = \"../standing.bvh\"\nheight = 0.0\n",
            3,
            "[[character]] 1: height: must be between",
        ),
        (
            "[[character]]\nfile = \"../bare.vrm\"\nup = \"z\"\n",
            3,
            "up: glTF is Y up by definition",
        ),
        (
            "[[character]]\nname = \"b\"\nheight = 0.0\n",
            3,
            "[[character]] 1: height: must be between",
        ),
        (
            "[[character]]\nclip = 0\n",
            2,
            "clip: the built-in humanoid is not a file",
        ),
        (
            "[[character]]\nunits = \"cm\"\n",
            2,
            "units: the built-in humanoid is not a file",
        ),
        (
            "[[character]]\nfile = \"../standing.bvh\"\nroles = \"missing.toml\"\n",
            3,
            "roles: ",
        ),
        (
            "[[character]]\nfile = \"../standing.bvh\"\nspec = \"x.toml\"\nroles = \"roles.toml\"\n",
            4,
            "roles: the spec file already says",
        ),
        (
            "[[character]]\nfile = \"../standing.bvh\"\nheight = \"tall\"\n",
            3,
            "height",
        ),
    ];
    for (text, want_line, want) in cases {
        let (line, m) = failure(text, "");
        assert_eq!(line, want_line, "{text}: {m}");
        assert!(m.contains(want), "{text}: {m}");
    }
}

/// `height` scales the built-in humanoid as it does a file's character (a crowd's people
/// vary in height).
#[test]
fn height_scales_the_built_in_humanoid() {
    let scene = load("[[character]]\nheight = 1.5\n[[character]]\n");
    let h: Vec<f32> = scene
        .characters
        .iter()
        .map(|c| character_height(&c.character))
        .collect();
    assert!((h[0] - 1.5).abs() < 1e-3, "{h:?}");
    let ratio = h[0] / h[1];
    let mass = |k: usize| scene.characters[k].spec.total_mass_kg();
    assert!(
        (mass(0) / mass(1) - ratio.powi(3)).abs() < 1e-3,
        "the mass goes as the volume, the cube of the height: {} kg and {} kg",
        mass(0),
        mass(1)
    );
    let bodies = |k: usize| {
        scene.characters[k]
            .spec
            .bodies
            .iter()
            .map(|b| b.shape.volume())
            .sum::<f32>()
    };
    assert!(
        (bodies(0) / bodies(1) - ratio.powi(3)).abs() < 1e-3,
        "its bodies scale with it"
    );
}

#[test]
fn roles_files_are_read_from_the_scene_files_folder_and_applied() {
    let without = load("[[character]]\nfile = \"../standing.bvh\"\n");
    let (dir, path) = folder(
        "[[character]]\nfile = \"../standing.bvh\"\nroles = \"roles.toml\"\n\
         [[character]]\nfile = \"../standing.bvh\"\nroles = \"roles.toml\"\nposition = [3, 0, 0]\n",
    );
    std::fs::write(
        dir.path().join("scenes/roles.toml"),
        "ignore = [\"LeftHand\"]\n",
    )
    .unwrap();
    let with = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    let bodies = |s: &Scene, k: usize| s.characters[k].spec.bodies.len();
    assert_eq!(bodies(&with, 0), bodies(&without, 0) - 1);
    assert_eq!(bodies(&with, 1), bodies(&with, 0));
    // A roles file the skeleton cannot satisfy: a folded person's knees are not below its
    // hips. The error names the scene's line and key, then the roles file's.
    let (line, m) = failure(
        "[[character]]\nfile = \"../folded.bvh\"\nunits = \"m\"\nup = \"y\"\nroles = \"roles.toml\"\n",
        "[roles]\nthigh_l = \"LeftUpLeg\"\nshin_l = \"LeftLeg\"\n",
    );
    assert_eq!(line, 5, "{m}");
    assert!(
        m.contains("[[character]] \"folded\": roles: ")
            && m.contains("roles.toml: line 3: shin_l:"),
        "{m}"
    );
}

#[test]
fn names_that_promise_a_humanoid_the_skeleton_denies_warn_in_a_scene_too() {
    let s = load(
        "[[character]]\nfile = \"../folded.bvh\"\nunits = \"m\"\nup = \"y\"\n\
         [[character]]\nfile = \"../folded.bvh\"\nunits = \"m\"\nup = \"y\"\nposition = [3, 0, 0]\n\
         [[character]]\nfile = \"../standing.bvh\"\nposition = [-3, 0, 0]\n\
         [[character]]\nposition = [0, 0, 3]\n",
    );
    let warned = |k: usize| {
        s.characters[k]
            .character
            .warnings
            .iter()
            .filter(|w| w.contains("joint names"))
            .count()
    };
    assert_eq!((warned(0), warned(1), warned(2), warned(3)), (1, 1, 0, 0));
    assert!(s.characters[2].character.warnings.is_empty());
}

/// `joint_damping` reaches the world's settings; a value out of range, or damping the
/// scene's backend cannot apply (particle), is refused at its key's line.
#[test]
fn joint_damping_is_a_world_setting_refused_where_it_cannot_apply() {
    let s = load("joint_damping = 1.5\n[[character]]\n");
    assert_eq!(s.settings.joint_damping, 1.5);
    assert_eq!(load("[[character]]\n").settings.joint_damping, 0.0);
    for (text, words) in [
        (
            "fps = 30\njoint_damping = -1\n[[character]]\n",
            "between 0 and 100",
        ),
        (
            "backend = \"particle\"\njoint_damping = 2\n[[character]]\n",
            "rigid and fast",
        ),
    ] {
        let (line, m) = failure(text, "");
        assert_eq!(line, 2, "{m}");
        assert!(m.contains("joint_damping") && m.contains(words), "{m}");
    }
}

/// The fast engine's settings of a scene, where its backend is the fast one.
fn fast_engine(scene: &Scene) -> FastConfig {
    *scene.settings.backend.fast().expect("the fast backend")
}

/// `freeze_joints` reaches the fast engine's settings (on unless the file turns it off); a
/// value that is not a boolean is refused at its key's line.
#[test]
fn freeze_joints_is_a_setting_of_the_fast_engine() {
    assert!(fast_engine(&load("backend = \"fast\"\n[[character]]\n")).freeze_joints);
    assert!(
        !fast_engine(&load(
            "backend = \"fast\"\nfreeze_joints = false\n[[character]]\n"
        ))
        .freeze_joints
    );
    let (line, m) = failure("fps = 30\nfreeze_joints = \"no\"\n[[character]]\n", "");
    assert_eq!(line, 2, "{m}");
    assert!(m.contains("freeze_joints"), "{m}");
}

/// `fast_iterations` reaches the fast engine's settings (1 unless given); 0 or more than
/// the most passes a substep takes is refused at its key's line, whatever the backend.
#[test]
fn fast_iterations_is_a_setting_of_the_fast_engine_refused_out_of_range() {
    assert_eq!(
        fast_engine(&load("backend = \"fast\"\n[[character]]\n")).iterations,
        1
    );
    let s = load("backend = \"fast\"\nfast_iterations = 2\n[[character]]\n");
    assert_eq!(fast_engine(&s).iterations, 2);
    for bad in ["0", "9"] {
        let (line, m) = failure(
            &format!("fps = 30\nfast_iterations = {bad}\n[[character]]\n"),
            "",
        );
        assert_eq!(line, 2, "{m}");
        assert!(
            m.contains("fast_iterations") && m.contains("between 1 and 8"),
            "{m}"
        );
    }
}

/// The fast engine's keys in a scene on another backend change nothing there, and are
/// kept for a switch to the fast engine (a `--backend fast` flag, the viewer's menu).
#[test]
fn fast_keys_wait_for_the_fast_engine() {
    let mut s = load("fast_iterations = 3\nfreeze_joints = false\n[[character]]\n");
    assert_eq!(s.settings.backend, BackendConfig::Rigid(Default::default()));
    s.set_backend(BackendKind::Fast);
    let f = fast_engine(&s);
    assert!(f.iterations == 3 && !f.freeze_joints, "{f:?}");
    s.set_backend(BackendKind::Particle);
    assert_eq!(s.settings.backend, BackendKind::Particle.into());
}

/// `fast_substeps` and `keep_contacts` reach the fast engine's settings (the defaults
/// unless given); a count out of range is refused at its key's line.
#[test]
fn fast_substeps_and_kept_contacts_are_settings_of_the_fast_engine() {
    let f = fast_engine(&load("backend = \"fast\"\n[[character]]\n"));
    assert_eq!(f.substeps, ragdoll::world::DEFAULT_FAST_SUBSTEPS);
    assert!(!f.keep_contacts);
    let f = fast_engine(&load(
        "backend = \"fast\"\nfast_substeps = 16\nkeep_contacts = true\n[[character]]\n",
    ));
    assert!(f.substeps == 16 && f.keep_contacts, "{f:?}");
    let (line, m) = failure("fps = 30\nfast_substeps = 0\n[[character]]\n", "");
    assert_eq!(line, 2, "{m}");
    assert!(
        m.contains("fast_substeps") && m.contains("between 1 and 100"),
        "{m}"
    );
}

/// `fast_impact_passes` reaches the world's settings (the default unless given; 0 turns
/// them off); more than the most passes a substep takes is refused at its key's line.
#[test]
fn fast_impact_passes_is_a_world_setting_refused_out_of_range() {
    assert_eq!(
        fast_engine(&load("backend = \"fast\"\n[[character]]\n")).impact_passes,
        ragdoll::world::DEFAULT_FAST_IMPACT_PASSES
    );
    let s = load("backend = \"fast\"\nfast_impact_passes = 0\n[[character]]\n");
    assert_eq!(fast_engine(&s).impact_passes, 0);
    let (line, m) = failure("fps = 30\nfast_impact_passes = 9\n[[character]]\n", "");
    assert_eq!(line, 2, "{m}");
    assert!(
        m.contains("fast_impact_passes") && m.contains("between 0 and 8"),
        "{m}"
    );
    // A negative count is not a count at all: refused where it is read.
    let (line, m) = failure("fps = 30\nfast_impact_passes = -1\n[[character]]\n", "");
    assert_eq!(line, 2, "{m}");
}
