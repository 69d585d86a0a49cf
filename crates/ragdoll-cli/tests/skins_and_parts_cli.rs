//! Skinned characters with rigid meshes parented to bones, with one skin per mesh, and a
//! spider and a horse with IK feet under their root, and a chibi, through the CLI on `rigid` and
//! `fast`, each turned four ways: the 3 s drop, measured by the independent mesh check
//! (`mesh_metrics`) on every mesh of the baked file, keeps every box rigid (each is bound
//! to one bone) and nothing sinks past 4 % of the height.

mod common;
mod mesh_metrics;
#[path = "../../ragdoll/tests/rigid_parts_files/mod.rs"]
mod rigid_parts_files;

use common::{ragdoll, stderr};
use rigid_parts_files::{ROBOT, SkinStyle, bones_glb, chibi, horse, skinned_robot, spider};

/// `make(facing)` baked on both backends, four ways round: `vertices` in all, every box
/// rigid, nothing sunk; `top` is the highest the fallen character may reach.
fn drop_holds_its_shape(name: &str, make: impl Fn(f32) -> Vec<u8>, vertices: usize, top: f32) {
    for facing in [0.0, 90.0, 180.0, 270.0] {
        for backend in ["rigid", "fast"] {
            let label = format!("{name}, facing {facing}°, {backend}");
            let tmp = tempfile::tempdir().unwrap();
            std::fs::write(tmp.path().join("robot.glb"), make(facing)).unwrap();
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
                m.highest_last < top,
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
    let make = |facing| skinned_robot(SkinStyle::PartsOnBones, facing);
    drop_holds_its_shape("parts on bones", make, 8 * ROBOT.len() + 16, 1.0);
}

#[test]
fn a_robot_of_five_skins_falls_in_one_piece() {
    // Fourteen boxes in five skinned meshes, and the crate beside it (which stays put).
    let make = |facing| skinned_robot(SkinStyle::FiveSkins, facing);
    drop_holds_its_shape("five skins", make, 8 * ROBOT.len() + 8, 1.0);
}

#[test]
fn a_spider_with_a_hub_and_ik_feet_lands_on_its_legs() {
    // Its hub and 24 leg bones each a box; it stands 0.42 m tall, dropped from where it
    // stands it stays under half a metre (a torn spider flew apart).
    let make = |facing| bones_glb(&spider(), facing);
    drop_holds_its_shape("spider", make, 8 * 25, 0.5);
}

#[test]
fn a_horse_with_ik_hooves_falls_in_one_piece() {
    // Its 21 skinned bones each a box; 1.6 m tall at the head, it ends lying down.
    let make = |facing| bones_glb(&horse(), facing);
    drop_holds_its_shape("horse", make, 8 * 21, 1.2);
}

#[test]
fn a_chibi_with_a_head_as_large_as_its_body_falls_in_one_piece() {
    // Sixteen skinned bones each a box; 1 m tall, it ends lower than it stood (on `fast`
    // it can end sitting, its head 0.72 m up).
    let make = |facing| bones_glb(&chibi(), facing);
    drop_holds_its_shape("chibi", make, 8 * 16, 0.95);
}
