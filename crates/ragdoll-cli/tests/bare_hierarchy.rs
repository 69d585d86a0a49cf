//! A bare VRM humanoid hierarchy (nodes and a bone table, no skin, no mesh) baked by
//! `simulate`: the output must show something, so it carries the ragdoll's bodies as one
//! skinned mesh, each vertex bound wholly to its body's joint node, and that mesh falls
//! without stretching. Read back with the `gltf` crate and the independent mesh check
//! (`mesh_metrics`), not through our importer.

mod common;
mod mesh_metrics;
#[path = "../../ragdoll/tests/rigid_parts_files/mod.rs"]
mod rigid_parts_files;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::{ragdoll, repo, stderr};
use ragdoll::import::{self, ImportOptions};
use ragdoll::skeleton::SkinnedMesh;

/// What the library makes of the file: the bodies mesh it draws, its joints' names, and
/// the scale `--units`/`--height` put on the skeleton's root (the baked file keeps the
/// input's own units, so its nodes and the bodies drawn on them are that much smaller).
struct Expected {
    bodies: SkinnedMesh,
    names: Vec<String>,
    scale: f32,
}

/// Writes the bare VRM 0.x hierarchy to `dir`, bakes one second of it with `flags`, and
/// returns the output's path and what the library makes of it with the same options.
fn bake(dir: &Path, flags: &[&str], opts: &ImportOptions) -> (PathBuf, Expected) {
    let input = dir.join("bare.vrm");
    std::fs::write(&input, rigid_parts_files::bare("VRM", false)).unwrap();
    let mut args = vec!["simulate", "bare.vrm", "--seconds", "1", "-o", "out.glb"];
    args.extend_from_slice(flags);
    let out = ragdoll(dir, &args);
    assert!(out.status.success(), "{}", stderr(&out));
    let c = import::load(&input, opts).unwrap();
    assert!(c.meshes.is_empty(), "the hierarchy carries no mesh");
    let spec = ragdoll::spec::build_spec(&c, &Default::default()).unwrap();
    let bodies = ragdoll::spec::bodies_mesh(&c.skeleton, &spec).unwrap();
    let names = c.skeleton.joints().iter().map(|j| j.name.clone()).collect();
    let scale = c.skeleton.joints()[0].rest.scale.x;
    (
        dir.join("out.glb"),
        Expected {
            bodies,
            names,
            scale,
        },
    )
}

/// The baked file has one skinned mesh, at the scene root, with as many vertices as the
/// bodies mesh; every vertex has weight 1 on one joint, the node of its body's joint.
fn check_skinned_bodies(path: &Path, bodies: &SkinnedMesh, joint_names: &[String]) {
    let g = gltf::Gltf::open(path).unwrap();
    let blob = g.blob.clone().unwrap();
    let doc = &g.document;
    let skinned: Vec<gltf::Node> = doc
        .nodes()
        .filter(|n| n.mesh().is_some() && n.skin().is_some())
        .collect();
    assert_eq!(skinned.len(), 1, "one skinned mesh node");
    assert_eq!(doc.meshes().len(), 1, "no other mesh");
    let node = &skinned[0];
    let scene = doc.default_scene().unwrap();
    assert!(
        scene.nodes().any(|n| n.index() == node.index()),
        "the skinned mesh node is a scene root"
    );
    let skin = node.skin().unwrap();
    let skin_nodes: Vec<gltf::Node> = skin.joints().collect();
    let mut count = 0;
    for prim in node.mesh().unwrap().primitives() {
        let reader = prim.reader(|_| Some(blob.as_slice()));
        let joints: Vec<[u16; 4]> = reader.read_joints(0).unwrap().into_u16().collect();
        let weights: Vec<[f32; 4]> = reader.read_weights(0).unwrap().into_f32().collect();
        assert_eq!(joints.len(), weights.len());
        for (v, (j, w)) in joints.iter().zip(&weights).enumerate() {
            let v = count + v;
            let slot = w.iter().position(|&x| x == 1.0).unwrap_or_else(|| {
                panic!("vertex {v}: no weight of 1 in {w:?}");
            });
            assert!(
                w.iter().enumerate().all(|(k, &x)| k == slot || x == 0.0),
                "vertex {v}: weights {w:?}"
            );
            let joint_node = &skin_nodes[j[slot] as usize];
            let body_joint = &joint_names[bodies.joints[v][0] as usize];
            assert_eq!(
                joint_node.name(),
                Some(body_joint.as_str()),
                "vertex {v} is bound to its body's joint node"
            );
        }
        count += joints.len();
    }
    assert_eq!(
        count,
        bodies.positions.len(),
        "the bodies mesh's vertex count"
    );
}

/// The vertical extent of the bodies mesh in the rest pose, metres.
fn height(bodies: &SkinnedMesh) -> f32 {
    let ys = bodies.positions.iter().map(|p| p.y);
    ys.clone().fold(f32::NEG_INFINITY, f32::max) - ys.fold(f32::INFINITY, f32::min)
}

/// Plays the file's own animation: the mesh starts the size of the bodies in the file's
/// units (so the inverse bind matrices match the pose the animation starts from), falls,
/// sinks no more than 4 % of the height, and no edge stretches (the bodies are rigid).
fn check_falls(path: &Path, e: &Expected) {
    let m = mesh_metrics::measure(path);
    eprintln!("{m:?}");
    assert_eq!(m.vertices, e.bodies.positions.len());
    let h = height(&e.bodies) / e.scale;
    assert!(
        (m.height - h).abs() < 1e-3,
        "frame 0 is {} m tall, the bodies {h} m",
        m.height
    );
    assert!(
        m.highest_last < 0.75 * m.height,
        "it fell: its top is at {} of {} m",
        m.highest_last,
        m.height
    );
    assert!(
        m.lowest_frac() > -0.04,
        "sank {} of its height",
        -m.lowest_frac()
    );
    assert!(
        m.stretch_max < 1.0 + 1e-4,
        "an edge stretched {}×",
        m.stretch_max
    );
}

#[test]
fn a_bare_vrm_hierarchy_bakes_with_its_bodies_drawn() {
    let tmp = tempfile::tempdir().unwrap();
    let (out, e) = bake(tmp.path(), &[], &ImportOptions::default());
    assert_eq!(e.scale, 1.0);
    check_skinned_bodies(&out, &e.bodies, &e.names);
    check_falls(&out, &e);
}

/// Scaled away from the file's own node transforms, the bodies are drawn on the joint nodes
/// in the file's own units, as its nodes are: the inverse bind matrices are the scaled
/// rest pose, undone by the scale the animation leaves out of the nodes.
#[test]
fn a_bare_vrm_hierarchy_scaled_by_height_draws_its_bodies_in_the_files_units() {
    let tmp = tempfile::tempdir().unwrap();
    let opts = ImportOptions {
        height_m: Some(1.2),
        ..Default::default()
    };
    let (out, e) = bake(tmp.path(), &["--height", "1.2"], &opts);
    // Unscaled, its bodies are 1.83 m tall.
    assert!(
        height(&e.bodies) < 1.5 && e.scale < 0.8,
        "the library scaled it too: {} m, by {}",
        height(&e.bodies),
        e.scale
    );
    check_skinned_bodies(&out, &e.bodies, &e.names);
    check_falls(&out, &e);
}

/// Node and the validator (`cd .ci && npm install`) are needed, so this is an ignored test
/// that `.ci/run` runs after installing them; asked to run without them, it fails saying
/// what is missing rather than passing having checked nothing.
#[test]
#[ignore = "needs node and the Khronos validator (cd .ci && npm install)"]
fn a_baked_bare_vrm_hierarchy_passes_the_khronos_validator() {
    let tmp = tempfile::tempdir().unwrap();
    let (out, _) = bake(tmp.path(), &[], &ImportOptions::default());
    let missing = "node or .ci/node_modules/gltf-validator is missing (cd .ci && npm install)";
    assert!(
        repo().join(".ci/node_modules/gltf-validator").is_dir(),
        "{missing}"
    );
    let o = Command::new("node")
        .arg(repo().join(".ci/gltf_validate.mjs"))
        .arg(&out)
        .env("GLTF_VALIDATE_VERBOSE", "1")
        .output()
        .expect(missing);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{text}{}", stderr(&o));
    assert!(text.contains(": 0 errors"), "{text}");
    assert!(!text.contains("NODE_SKINNED_MESH_NON_ROOT"), "{text}");
}
