//! A character whose joint names promise a humanoid that its skeleton denies gets a
//! warning on every command: the ragdoll will be a chain of capsules, not what the user
//! expects from a file named like a person.

mod common;

use common::*;

/// A BVH person (Mixamo-like names) with each offset given as (sideways, up); `flat` lays
/// every "up" along the ground instead, as an exporter with the wrong up axis does.
fn person(flat: bool) -> String {
    let off = |x: f32, up: f32| {
        if flat {
            format!("OFFSET {x} 0 {up}")
        } else {
            format!("OFFSET {x} {up} 0")
        }
    };
    let chain = |names: &[&str], offsets: &[(f32, f32)], end: (f32, f32)| -> String {
        let mut s = String::new();
        for (n, &(x, up)) in names.iter().zip(offsets) {
            s += &format!(
                "JOINT {n}\n{{\n{}\nCHANNELS 3 Zrotation Xrotation Yrotation\n",
                off(x, up)
            );
        }
        s += &format!("End Site\n{{\n{}\n}}\n", off(end.0, end.1));
        s + &"}\n".repeat(names.len())
    };
    let leg = |side: &str, x: f32| {
        chain(
            &[
                &format!("{side}UpLeg"),
                &format!("{side}Leg"),
                &format!("{side}Foot"),
            ],
            &[(x, 0.0), (0.0, -0.45), (0.0, -0.42)],
            (0.0, -0.08),
        )
    };
    let arm = |side: &str, x: f32| {
        chain(
            &[
                &format!("{side}Arm"),
                &format!("{side}ForeArm"),
                &format!("{side}Hand"),
            ],
            &[(x, 0.45), (x.signum() * 0.3, 0.0), (x.signum() * 0.25, 0.0)],
            (x.signum() * 0.1, 0.0),
        )
    };
    let spine = format!(
        "JOINT Spine\n{{\n{}\nCHANNELS 3 Zrotation Xrotation Yrotation\n{}{}{}}}\n",
        off(0.0, 0.1),
        chain(&["Neck", "Head"], &[(0.0, 0.5), (0.0, 0.1)], (0.0, 0.2)),
        arm("Left", 0.2),
        arm("Right", -0.2),
    );
    let channels = 6 + 3 * 15;
    format!(
        "HIERARCHY\nROOT Hips\n{{\nOFFSET 0 0 0\nCHANNELS 6 Xposition Yposition Zposition \
         Zrotation Xrotation Yrotation\n{spine}{}{}}}\nMOTION\nFrames: 1\nFrame Time: 0.0333333\n{}\n",
        leg("Left", 0.1),
        leg("Right", -0.1),
        vec!["0"; channels].join(" ")
    )
}

#[test]
fn names_that_promise_a_humanoid_the_skeleton_denies_are_a_warning_on_every_command() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("flat.bvh"), person(true)).unwrap();
    std::fs::write(dir.path().join("standing.bvh"), person(false)).unwrap();
    for args in [
        vec!["inspect", "flat.bvh", "--units", "m", "--up", "y"],
        vec![
            "simulate",
            "flat.bvh",
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
            err.contains("warning: flat.bvh:") && err.contains("joint names"),
            "{args:?}: {err}"
        );
    }
    let o = ragdoll(dir.path(), &["inspect", "standing.bvh", "--units", "m"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("warning"), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("(humanoid)"), "{out}");
}
