//! Names from a user's file never reach the terminal raw: an ANSI escape, a NUL, a C1
//! control or a right-to-left override in a joint name is printed escaped by `inspect`,
//! in warnings and in errors.

mod common;

use common::{ragdoll, stderr};

/// A two-joint BVH whose joint names carry `hips` and `chest` (BVH names end at
/// whitespace, so no newline; the unit test of the escaping covers it).
fn bvh(hips: &str, chest: &str) -> String {
    format!(
        "HIERARCHY\nROOT {hips}\n{{\n  OFFSET 0 90 0\n  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n  JOINT {chest}\n  {{\n    OFFSET 0 30 0\n    CHANNELS 3 Zrotation Xrotation Yrotation\n    End Site\n    {{\n      OFFSET 0 30 0\n    }}\n  }}\n}}\nMOTION\nFrames: 2\nFrame Time: 0.033333\n0 90 0 0 0 0 0 0 0\n0 90 0 0 0 0 0 0 0\n"
    )
}

const RAW: [char; 5] = ['\u{1b}', '\0', '\u{9b}', '\u{202e}', '\u{7}'];

fn assert_clean(what: &str, text: &str) {
    for c in RAW {
        assert!(!text.contains(c), "{what} prints {c:?} raw: {text:?}");
    }
}

#[test]
fn inspect_warnings_and_errors_escape_control_characters() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    std::fs::write(
        dir.join("evil.bvh"),
        bvh("Hips\u{1b}[31m\0", "Ch\u{202e}est\u{9b}2J\u{7}"),
    )
    .unwrap();
    let o = ragdoll(dir, &["inspect", "evil.bvh"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert_clean("inspect", &out);
    assert_clean("inspect's warnings", &stderr(&o));
    assert!(out.contains("Hips\\u{1b}[31m\\u{0}"), "{out}");
    assert!(out.contains("Ch\\u{202e}est\\u{9b}2J\\u{7}"), "{out}");
    // An error that quotes a name: a roles file naming a joint that is not there (TOML's
    // escape puts a real ESC in the name).
    std::fs::write(
        dir.join("roles.toml"),
        "[roles]\nthigh_l = \"no\\u001b[2Jsuch\"\n",
    )
    .unwrap();
    let o = ragdoll(dir, &["inspect", "evil.bvh", "--roles", "roles.toml"]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert_clean("the error", &err);
    assert!(err.contains("no\\u{1b}[2Jsuch"), "{err}");
}
