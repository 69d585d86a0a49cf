//! A character made of rigid mesh parts without a skin, through the CLI: `simulate` bakes
//! it with its own meshes, measured by the independent mesh check (`mesh_metrics`): no part
//! stretches and nothing sinks past 4 % of the height; `rig` refuses it, since
//! its node hierarchy already is a skeleton.

mod common;
mod mesh_metrics;
#[path = "../../ragdoll/tests/rigid_parts_files/mod.rs"]
mod rigid_parts_files;

use common::{ragdoll, stderr};

#[test]
fn a_rigid_part_robot_bakes_without_stretching_or_sinking() {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("robot.glb"), rigid_parts_files::robot()).unwrap();
    let out = ragdoll(
        tmp.path(),
        &["simulate", "robot.glb", "--seconds", "3", "-o", "out.glb"],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let m = mesh_metrics::measure(&tmp.path().join("out.glb"));
    eprintln!("{m:?}");
    assert_eq!(
        m.vertices,
        14 * 8,
        "every part's own box, the shared arm mesh twice"
    );
    assert!((m.height - 1.85).abs() < 0.01, "height {}", m.height);
    assert!(
        m.highest_last < 1.0,
        "it fell: its top is at {}",
        m.highest_last
    );
    // Rigid parts: an edge's length changes by float rounding only.
    assert!(
        m.stretch_max < 1.0 + 1e-4,
        "an edge stretched {}×",
        m.stretch_max
    );
    assert!(
        m.lowest_frac() > -0.04,
        "sank {} of its height",
        -m.lowest_frac()
    );

    let inspect = ragdoll(tmp.path(), &["inspect", "robot.glb"]);
    assert!(inspect.status.success(), "{}", stderr(&inspect));
    let text = String::from_utf8_lossy(&inspect.stdout);
    assert!(text.contains("humanoid"), "{text}");

    let rig = ragdoll(tmp.path(), &["rig", "robot.glb", "-o", "rigged.glb"]);
    assert!(!rig.status.success());
    assert!(
        stderr(&rig).contains("already has a skeleton"),
        "{}",
        stderr(&rig)
    );
    assert!(!tmp.path().join("rigged.glb").exists());
}
