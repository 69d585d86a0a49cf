//! Scene files from the command line: per-character flags refused with a sentence naming
//! the scene key that sets them, and each character file's warnings (its import repairs,
//! the roles warning) printed once by `simulate` and `view`, however many characters it
//! gives the scene.

mod common;
#[path = "../../ragdoll/tests/scene_keys_files/mod.rs"]
mod scene_keys_files;

use std::io::{BufRead, BufReader, Read};
use std::process::{Command, Stdio};

use common::{ragdoll, stderr};
use scene_keys_files::person;

/// Two characters of one folded person (names that promise a humanoid, a skeleton with its
/// legs raised above its hips) and one standing person.
const SCENE: &str = "duration_s = 0.1\n\
    [[character]]\nfile = \"folded.bvh\"\nunits = \"m\"\nup = \"y\"\n\
    [[character]]\nfile = \"folded.bvh\"\nunits = \"m\"\nup = \"y\"\nposition = [3, 0, 0]\n\
    [[character]]\nfile = \"standing.bvh\"\nposition = [-3, 0, 0]\n";

fn folder() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("folded.bvh"), person(true)).unwrap();
    std::fs::write(dir.path().join("standing.bvh"), person(false)).unwrap();
    std::fs::write(dir.path().join("scene.toml"), SCENE).unwrap();
    std::fs::write(dir.path().join("roles.toml"), "ignore = [\"LeftHand\"]\n").unwrap();
    dir
}

fn roles_warnings(err: &str) -> Vec<&str> {
    err.lines()
        .filter(|l| l.starts_with("warning:") && l.contains("joint names"))
        .collect()
}

#[test]
fn simulate_prints_each_files_roles_warning_once() {
    let dir = folder();
    let o = ragdoll(dir.path(), &["simulate", "scene.toml", "-o", "out"]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    let warned = roles_warnings(&err);
    assert_eq!(warned.len(), 1, "{err}");
    assert!(warned[0].starts_with("warning: folded.bvh: "), "{err}");
}

#[test]
fn view_prints_each_files_roles_warning_once() {
    let dir = folder();
    let mut child = Command::new(env!("CARGO_BIN_EXE_ragdoll"))
        .current_dir(dir.path())
        .args(["view", "scene.toml", "--port", "0", "--no-open"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // The URL is printed once the scene has loaded, after its warnings.
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    child.kill().unwrap();
    let mut err = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    child.wait().unwrap();
    assert!(line.contains("http://"), "{line} {err}");
    let warned = roles_warnings(&err);
    assert_eq!(warned.len(), 1, "{err}");
    assert!(warned[0].starts_with("warning: folded.bvh: "), "{err}");
}

#[test]
fn per_character_flags_point_at_the_scene_key() {
    let dir = folder();
    for (flag, value, key) in [
        ("--height", "1.8", "height"),
        ("--clip", "0", "clip"),
        ("--roles", "roles.toml", "roles"),
        ("--units", "cm", "units"),
    ] {
        for command in ["simulate", "view"] {
            let mut args = vec![command, "scene.toml", flag, value];
            args.extend(if command == "view" {
                &["--port", "0", "--no-open"][..]
            } else {
                &["-o", "out", "--seconds", "0.1"]
            });
            let o = ragdoll(dir.path(), &args);
            assert!(!o.status.success(), "{args:?}");
            let e = stderr(&o);
            assert_eq!(e.trim_end().lines().count(), 1, "{args:?}: {e}");
            assert!(
                e.contains(&format!(
                    "{flag} does not apply to a scene file: set {key} in its [[character]] tables"
                )),
                "{args:?}: {e}"
            );
        }
    }
    assert!(!dir.path().join("out").exists());
}
