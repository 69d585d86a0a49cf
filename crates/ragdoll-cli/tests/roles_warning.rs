//! A character whose joint names promise a humanoid that its skeleton denies gets a
//! warning on every command: the ragdoll will be a chain of capsules, not what the user
//! expects from a file named like a person.

mod common;
#[path = "../../ragdoll/tests/scene_keys_files/mod.rs"]
mod scene_keys_files;

use common::*;
use scene_keys_files::person;

#[test]
fn names_that_promise_a_humanoid_the_skeleton_denies_are_a_warning_on_every_command() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("folded.bvh"), person(true)).unwrap();
    std::fs::write(dir.path().join("standing.bvh"), person(false)).unwrap();
    for args in [
        vec!["inspect", "folded.bvh", "--units", "m", "--up", "y"],
        vec![
            "simulate",
            "folded.bvh",
            "--units",
            "m",
            "--up",
            "y",
            "--seconds",
            "0.2",
            "-o",
            "f.glb",
        ],
    ] {
        let o = ragdoll(dir.path(), &args);
        let err = stderr(&o);
        assert!(
            err.contains("warning: folded.bvh:") && err.contains("joint names"),
            "{args:?}: {err}"
        );
    }
    let o = ragdoll(dir.path(), &["inspect", "standing.bvh", "--units", "m"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("warning"), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("(humanoid)"), "{out}");
}
