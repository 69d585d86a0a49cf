//! Skinned characters with rigid meshes parented to bones, and with one skin per mesh,
//! through the CLI on `rigid` and `fast`, each turned four ways: the 3 s drop, measured by
//! the independent mesh check (`mesh_metrics`) on every mesh of the baked file, keeps
//! every box rigid (each is bound to one bone) and nothing sinks past issue 11's 4 % of
//! the height.

mod common;
mod mesh_metrics;
#[path = "../../ragdoll/tests/rigid_parts_files/mod.rs"]
mod rigid_parts_files;

use common::{ragdoll, stderr};
use rigid_parts_files::{ROBOT, SkinStyle, skinned_robot};

fn drop_holds_its_shape(style: SkinStyle, vertices: usize) {
    for facing in [0.0, 90.0, 180.0, 270.0] {
        for backend in ["rigid", "fast"] {
            let label = format!("{style:?}, facing {facing}°, {backend}");
            let tmp = tempfile::tempdir().unwrap();
            std::fs::write(tmp.path().join("robot.glb"), skinned_robot(style, facing)).unwrap();
            let out = ragdoll(
                tmp.path(),
                &[
                    "simulate",
                    "robot.glb",
                    "--backend",
                    backend,
                    "--seconds",
                    "3",
                    "-o",
                    "out.glb",
                ],
            );
            assert!(out.status.success(), "{label}: {}", stderr(&out));
            let m = mesh_metrics::measure(&tmp.path().join("out.glb"));
            eprintln!("{label}: {m:?}");
            assert_eq!(m.vertices, vertices, "{label}: every mesh of the file");
            assert!(
                m.highest_last < 1.0,
                "{label}: it did not fall ({})",
                m.highest_last
            );
            // Every box is bound to one bone: an edge's length changes by rounding only.
            assert!(
                m.stretch_max < 1.0 + 1e-4,
                "{label}: an edge stretched {}×",
                m.stretch_max
            );
            assert!(
                m.lowest_frac() > -0.04,
                "{label}: sank {:.1} % of its height",
                -100.0 * m.lowest_frac()
            );
        }
    }
}

#[test]
fn a_skinned_robot_with_parts_on_its_bones_falls_in_one_piece() {
    // Fourteen boxes on bones and two skinned hands.
    drop_holds_its_shape(SkinStyle::PartsOnBones, 8 * ROBOT.len() + 16);
}

#[test]
fn a_robot_of_five_skins_falls_in_one_piece() {
    // Fourteen boxes in five skinned meshes, and the crate beside it (which stays put).
    drop_holds_its_shape(SkinStyle::FiveSkins, 8 * ROBOT.len() + 8);
}
