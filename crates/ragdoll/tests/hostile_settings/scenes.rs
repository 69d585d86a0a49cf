//! Scenes: absurd values refused at their line with the bound, counts bounded, files
//! found beside the scene and special files refused.

use std::path::{Path, PathBuf};

use ragdoll::Error;
use ragdoll::events;
use ragdoll::scene::{self, Scene};
use ragdoll::spec::RagdollSpec;

use super::humanoid_spec;

// --- Scenes -----------------------------------------------------------------------------

/// A scene text's error as (line, message).
fn scene_failure(text: &str, path: &Path) -> (usize, String) {
    match Scene::from_toml(text, path) {
        Ok(_) => panic!("this scene should fail:\n{text}"),
        Err(Error::Parse { line, message, .. }) => (line, message),
        Err(e) => panic!("expected an error with a line, got: {e}"),
    }
}

/// Absurd values in a scene, each refused at its line with its key and its bound.
#[test]
fn absurd_scene_values_are_refused_at_their_line_with_the_bound() {
    let one = "[[character]]\n";
    let cases: Vec<(String, usize, &[&str])> = vec![
        (
            format!("{one}position = [4294967296, 0, 0]\n"),
            2,
            &["position", "10000 m"],
        ),
        (
            format!("{one}facing_deg = 1e30\n"),
            2,
            &["facing_deg", "360"],
        ),
        (format!("{one}mass_kg = 1e30\n"), 2, &["mass_kg", "1e9"]),
        (format!("{one}activate = 1e9\n"), 2, &["activate", "3600"]),
        (
            "duration_s = 1e9\n[[character]]\n".into(),
            1,
            &["duration_s", "3600"],
        ),
        ("fps = 1e6\n[[character]]\n".into(), 1, &["fps", "1000"]),
        (
            "gravity = [0, -1e30, 0]\n[[character]]\n".into(),
            1,
            &["gravity", "1000"],
        ),
        (
            "ground = 1e30\n[[character]]\n".into(),
            1,
            &["ground", "10000"],
        ),
        (
            format!("{one}[[blast]]\ntnt_kg = 1e30\nposition = [0, 0, 0]\n"),
            3,
            &["[[blast]] 1", "tnt_kg", "1e7"],
        ),
        (
            format!("{one}[[blast]]\ntnt_kg = 1\nposition = [0, 0, 0]\nscale = 1e9\n"),
            5,
            &["scale", "100"],
        ),
        (
            format!(
                "{one}[[projectile]]\norigin = [0, 1, 5]\ntarget = [0, 1, 0]\nspeed_mps = 1e30\n"
            ),
            5,
            &["speed_mps", "3000"],
        ),
        (
            format!(
                "{one}[[projectile]]\norigin = [0, 1, 5]\ntarget = [0, 1, 0]\nmass_kg = 10\nspeed_mps = 1000\n"
            ),
            6,
            &["speed_mps", "momentum", "1000 N·s"],
        ),
        (
            format!(
                "{one}[[projectile]]\norigin = [0, 1, 5]\ntarget = [0, 1, 0]\ncount = 10000\ninterval_s = 1\n"
            ),
            6,
            &["interval_s", "3600"],
        ),
        (
            format!("{one}[[push]]\ntarget = \"head\"\nimpulse_ns = [1e30, 0, 0]\n"),
            4,
            &["impulse_ns", "1000 N·s"],
        ),
        (
            format!("{one}[[push]]\ntarget = \"head\"\nforce_n = [0, 1e5, 0]\n"),
            4,
            &["force_n", "10000 N"],
        ),
        (
            format!("{one}[[push]]\ntarget = \"head\"\nforce_n = [0, 1, 0]\nend_s = 1e9\n"),
            5,
            &["end_s", "3600"],
        ),
        (
            format!("{one}[[field]]\nkind = \"wind\"\nvelocity_mps = [1000, 0, 0]\n"),
            4,
            &["velocity_mps", "340"],
        ),
        (
            format!(
                "{one}[[field]]\nkind = \"radial\"\ncenter = [0, 0, 0]\nstrength_mps2 = 1e30\nradius_m = 2\n"
            ),
            5,
            &["strength_mps2", "1000"],
        ),
        (
            format!("{one}[[field]]\nkind = \"drag\"\nrate_per_s = 1e30\n"),
            4,
            &["rate_per_s", "1000"],
        ),
        (
            format!(
                "{one}[[field]]\nkind = \"gravity\"\nkeys = [{{ time_s = 0, gravity = [0, -1e30, 0] }}]\n"
            ),
            4,
            &["keys", "gravity", "1000"],
        ),
        (
            format!("{one}[[pin]]\ntarget = \"hand_l\"\nposition = [0, 1e30, 0]\n"),
            4,
            &["position", "10000"],
        ),
        (
            format!(
                "{one}[[pin]]\ntarget = \"hand_l\"\nposition = [0, 1, 0]\nstiffness_hz = 1000\n"
            ),
            5,
            &["stiffness_hz", "30 Hz"],
        ),
        (
            format!(
                "{one}[[pin]]\ntarget = \"hand_l\"\nposition = [0, 1, 0]\nstiffness_hz = 10\ndamping_ratio = 10\n"
            ),
            6,
            &["damping_ratio", "30 Hz"],
        ),
        (
            format!("{one}[[pin]]\ntarget = \"hand_l\"\nposition = [0, 1, 0]\nrelease_s = 1e9\n"),
            5,
            &["release_s", "3600"],
        ),
        (
            format!("{one}powered = {{ strength = 1e9 }}\n"),
            2,
            &["powered", "strength"],
        ),
        (
            format!("{one}[output]\nglb = \"{}.glb\"\n", "x".repeat(200)),
            3,
            &["glb", "128"],
        ),
    ];
    for (text, line, words) in &cases {
        let (got, message) = scene_failure(text, Path::new("test.toml"));
        assert_eq!(got, *line, "wrong line for:\n{text}\nmessage: {message}");
        for w in *words {
            assert!(message.contains(w), "{message:?} lacks {w:?} for:\n{text}");
        }
    }
}

/// Counts: characters, events (each shot of a burst counted), keys, and the frames a run
/// would record.
#[test]
fn scene_counts_are_bounded() {
    let path = Path::new("test.toml");
    let many = "[[character]]\nposition = [0, 0, 0]\n".repeat(scene::MAX_CHARACTERS + 1);
    let (line, message) = scene_failure(&many, path);
    assert_eq!(line, 2 * scene::MAX_CHARACTERS + 1);
    assert!(message.contains("10000 characters"), "{message}");

    let blasts = "[[blast]]\ntnt_kg = 1\nposition = [5, 0, 0]\n".repeat(scene::MAX_EVENTS + 1);
    let (line, message) = scene_failure(&format!("[[character]]\n{blasts}"), path);
    assert_eq!(line, 2 + 3 * scene::MAX_EVENTS);
    assert!(message.contains("10000 events"), "{message}");

    let burst = format!(
        "[[character]]\n[[projectile]]\norigin = [0, 1, 5]\ntarget = [0, 1, 0]\ncount = {}\ninterval_s = 0\n[[blast]]\ntnt_kg = 1\nposition = [5, 0, 0]\n",
        scene::MAX_BURST
    );
    let (line, message) = scene_failure(&burst, path);
    assert_eq!(line, 5, "at the burst's count: {message}");
    assert!(
        message.contains("10001") && message.contains("10000"),
        "{message}"
    );
    // Bursts are refused before their shots are made: ten thousand tables of ten thousand
    // shots would be 10⁸ events.
    let table = format!(
        "[[projectile]]\norigin = [0, 1, 5]\ntarget = [0, 1, 0]\ncount = {}\ninterval_s = 0\n",
        scene::MAX_BURST
    );
    let text = format!("[[character]]\n{}", table.repeat(scene::MAX_EVENTS));
    let (line, message) = scene_failure(&text, path);
    assert_eq!(line, 1 + 5 + 4, "the second burst's count: {message}");

    let keys: Vec<String> = (0..=events::MAX_KEYS)
        .map(|k| format!("{{ time_s = {}, position = [0, 1, 0] }}", k as f32 * 0.01))
        .collect();
    let pin = format!(
        "[[character]]\n[[pin]]\ntarget = \"hand_l\"\nkeys = [{}]\n",
        keys.join(", ")
    );
    let (line, message) = scene_failure(&pin, path);
    assert_eq!(line, 4);
    assert!(message.contains("10000"), "{message}");

    // An hour at 1000 fps of a humanoid records more than a run keeps.
    let long = "duration_s = 3600\nfps = 1000\n[[character]]\n";
    let (line, message) = scene_failure(long, path);
    assert_eq!(line, 1);
    assert!(
        message.contains("duration_s") && message.contains("joint transforms"),
        "{message}"
    );
}

/// A scratch folder for one test.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("ragdoll-hostile-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Files a scene names are relative to the scene file; special files are refused before
/// anything reads them; the scene and spec files are read with a size cap.
#[test]
fn scene_files_are_found_beside_the_scene_and_special_files_refused() {
    let dir = scratch("files");
    std::fs::create_dir_all(dir.join("chars")).unwrap();
    let bvh = "HIERARCHY\nROOT hips\n{\n OFFSET 0 90 0\n CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n JOINT chest\n {\n  OFFSET 0 40 0\n  CHANNELS 3 Zrotation Xrotation Yrotation\n  End Site\n  {\n   OFFSET 0 30 0\n  }\n }\n}\nMOTION\nFrames: 1\nFrame Time: 0.033\n0 90 0 0 0 0 0 0 0\n";
    std::fs::write(dir.join("chars/two.bvh"), bvh).unwrap();
    let spec = humanoid_spec();
    std::fs::write(dir.join("chars/h.spec.toml"), spec.to_toml()).unwrap();
    let scene_path = dir.join("scene.toml");
    let text = "[[character]]\nfile = \"chars/two.bvh\"\n[[character]]\nspec = \"chars/h.spec.toml\"\nposition = [3, 0, 0]\n";
    std::fs::write(&scene_path, text).unwrap();
    let scene = Scene::load(&scene_path).unwrap();
    assert_eq!(scene.characters.len(), 2);
    assert_eq!(scene.characters[1].spec.bodies.len(), spec.bodies.len());

    for (key, special) in [
        ("file", "/dev/zero"),
        ("spec", "/dev/zero"),
        ("file", "chars"),
    ] {
        let text = format!("[[character]]\n{key} = \"{special}\"\n");
        let (line, message) = scene_failure(&text, &scene_path);
        assert_eq!(line, 2);
        assert!(
            message.contains(key) && message.contains("not a regular file"),
            "{message}"
        );
    }
    // A scene file that is not a regular file, or too large, is not read.
    assert!(Scene::load(Path::new("/dev/zero")).is_err());
    let big = dir.join("big.toml");
    let file = std::fs::File::create(&big).unwrap();
    file.set_len(ragdoll::files::MAX_SETTINGS_BYTES + 1)
        .unwrap();
    let err = Scene::load(&big).unwrap_err().to_string();
    assert!(err.contains("larger than"), "{err}");
    let err = RagdollSpec::load(&big).unwrap_err().to_string();
    assert!(err.contains("larger than"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}
