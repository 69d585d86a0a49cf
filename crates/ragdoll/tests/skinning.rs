//! Linear blend skinning: the rest pose gives back the bind mesh, a turned joint moves its
//! vertices as rigid rotation and blending say it must, and a posed frame agrees with what a
//! glTF viewer computes from the skin our exporter writes (`joint world · inverse bind
//! matrix · file vertex`).

mod common;

use std::path::Path;

use glam::{Mat4, Quat, Vec3, Vec4};
use ragdoll::import::{self, ImportOptions, gltf::from_bytes};
use ragdoll::math::Transform;
use ragdoll::skeleton::{Character, Joint, Skeleton, SkinnedMesh, Source, skinning};
use ragdoll::spec::{self, BuildOptions};
use ragdoll::world::{World, WorldSettings};

fn skinned(mesh: &SkinnedMesh, rest: &[Transform], pose: &[Transform]) -> (Vec<Vec3>, Vec<Vec3>) {
    let mut m = Vec::new();
    skinning::skin_matrices(rest, pose, &mut m).unwrap();
    let (mut p, mut n) = (Vec::new(), Vec::new());
    skinning::skin(mesh, &m, &mut p, &mut n).unwrap();
    (p, n)
}

fn assert_close(a: &[Vec3], b: &[Vec3], tol: f32, what: &str) {
    assert_eq!(a.len(), b.len(), "{what}");
    let worst = a
        .iter()
        .zip(b)
        .map(|(p, q)| (*p - *q).length())
        .fold(0.0f32, f32::max);
    assert!(worst <= tol, "{what}: worst vertex off by {worst} m");
}

/// Two joints one metre apart on a vertical line: "root" at the origin, "tip" at y = 1.
fn two_joints() -> Skeleton {
    Skeleton::new(vec![
        Joint {
            name: "root".into(),
            parent: None,
            rest: Transform::IDENTITY,
            tip: None,
        },
        Joint {
            name: "tip".into(),
            parent: Some(0),
            rest: Transform::from_translation(Vec3::Y),
            tip: Some(Vec3::Y),
        },
    ])
    .unwrap()
}

#[test]
fn a_turned_joint_moves_only_its_weighted_vertices_as_the_closed_form_says() {
    let skeleton = two_joints();
    let rest = skeleton.rest_world();
    // Vertex 0 rides the root, vertex 1 the tip, vertex 2 half and half.
    let mesh = SkinnedMesh {
        name: "bar".into(),
        positions: vec![
            Vec3::new(0.1, 0.5, 0.0),
            Vec3::new(0.1, 1.5, 0.0),
            Vec3::new(0.0, 2.0, 0.0),
        ],
        normals: vec![Vec3::X, Vec3::X, Vec3::Y],
        indices: vec![0, 1, 2],
        joints: vec![[0, 0, 0, 0], [1, 0, 0, 0], [0, 1, 0, 0]],
        weights: vec![Vec4::X, Vec4::X, Vec4::new(0.5, 0.5, 0.0, 0.0)],
    };
    // Turn the tip 90° about Z at its joint (0, 1, 0).
    let turn = Quat::from_rotation_z(std::f32::consts::FRAC_PI_2);
    let locals = [Transform::IDENTITY, Transform::new(Vec3::Y, turn)];
    let mut pose = vec![Transform::IDENTITY; 2];
    skeleton.world_from_local(&locals, &mut pose);
    let (p, n) = skinned(&mesh, &rest, &pose);
    // Root vertex: untouched.
    assert!((p[0] - mesh.positions[0]).length() < 1e-6);
    assert!((n[0] - Vec3::X).length() < 1e-6);
    // Tip vertex: (0.1, 0.5) from the joint turns to (-0.5, 0.1) from it.
    assert!(
        (p[1] - Vec3::new(-0.5, 1.1, 0.0)).length() < 1e-5,
        "{}",
        p[1]
    );
    assert!((n[1] - Vec3::Y).length() < 1e-5, "{}", n[1]);
    // Blended vertex: the mean of where each joint alone would take it, (0, 2, 0) and
    // (-1, 1, 0): linear blend skinning's straight-line average (it cuts the corner).
    assert!(
        (p[2] - Vec3::new(-0.5, 1.5, 0.0)).length() < 1e-5,
        "{}",
        p[2]
    );
    // Its normal: the blend of Y and −X, renormalised.
    let expect = Vec3::new(-0.5, 0.5, 0.0).normalize();
    assert!((n[2] - expect).length() < 1e-5, "{}", n[2]);
}

#[test]
fn bad_inputs_are_errors_not_panics() {
    let skeleton = two_joints();
    let rest = skeleton.rest_world();
    let mut m = Vec::new();
    assert!(skinning::skin_matrices(&rest, &rest[..1], &mut m).is_err());
    skinning::skin_matrices(&rest, &rest, &mut m).unwrap();
    let mesh = SkinnedMesh {
        name: "bad".into(),
        positions: vec![Vec3::ZERO],
        joints: vec![[5, 0, 0, 0]],
        weights: vec![Vec4::X],
        ..Default::default()
    };
    let (mut p, mut n) = (Vec::new(), Vec::new());
    let err = skinning::skin(&mesh, &m, &mut p, &mut n).unwrap_err();
    assert!(err.to_string().contains("mesh \"bad\""), "{err}");
    let short = SkinnedMesh {
        weights: vec![],
        ..mesh
    };
    assert!(skinning::skin(&short, &m, &mut p, &mut n).is_err());
}

#[test]
fn rest_pose_gives_back_the_bind_mesh_of_the_humanoid_bodies() {
    let c = ragdoll::skeleton::humanoid();
    let spec = spec::build_spec(&c, &BuildOptions::default()).unwrap();
    let mesh = ragdoll::spec::bodies_mesh(&c.skeleton, &spec).unwrap();
    let rest = c.skeleton.rest_world();
    let (p, n) = skinned(&mesh, &rest, &rest);
    assert_close(&p, &mesh.positions, 1e-5, "positions");
    assert_close(&n, &mesh.normals, 1e-5, "normals");
}

/// What a glTF viewer draws for the first skinned triangle primitive of `glb` with its
/// joints at `pose` (skeleton order; `joint_nodes[j]` is joint `j`'s node):
/// `Σ w · pose[joint] · inverseBindMatrix · vertex`, weights normalised to sum 1.
fn viewer_skin(glb: &[u8], joint_nodes: &[usize], pose: &[Transform]) -> Vec<Vec3> {
    let gltf = gltf::Gltf::from_slice(glb).unwrap();
    let blob = gltf.blob.as_deref().unwrap();
    let node = gltf
        .document
        .nodes()
        .find(|n| n.mesh().is_some() && n.skin().is_some())
        .unwrap();
    let skin = node.skin().unwrap();
    let read = |_: gltf::Buffer| Some(blob);
    let ibms: Vec<Mat4> = skin
        .reader(read)
        .read_inverse_bind_matrices()
        .unwrap()
        .map(|m| Mat4::from_cols_array_2d(&m))
        .collect();
    let slot_joint: Vec<usize> = skin
        .joints()
        .map(|n| joint_nodes.iter().position(|&k| k == n.index()).unwrap())
        .collect();
    let prim = node.mesh().unwrap().primitives().next().unwrap();
    let r = prim.reader(read);
    let positions: Vec<Vec3> = r.read_positions().unwrap().map(Vec3::from).collect();
    let joints: Vec<[u16; 4]> = r.read_joints(0).unwrap().into_u16().collect();
    let weights: Vec<[f32; 4]> = r.read_weights(0).unwrap().into_f32().collect();
    positions
        .iter()
        .zip(joints.iter().zip(&weights))
        .map(|(p, (js, ws))| {
            let total: f32 = ws.iter().sum();
            let mut m = Mat4::ZERO;
            for k in 0..4 {
                let slot = js[k] as usize;
                m += pose[slot_joint[slot]].to_mat4() * ibms[slot] * (ws[k] / total);
            }
            m.transform_point3(*p)
        })
        .collect()
}

fn joint_nodes(c: &Character) -> Vec<usize> {
    match &c.source {
        Source::Gltf(src) => src.joint_nodes.clone(),
        _ => panic!("{} did not come from a glTF file", c.name),
    }
}

fn clip_pose(c: &Character, clip: usize, frame: usize) -> Vec<Transform> {
    let mut pose = vec![Transform::IDENTITY; c.skeleton.len()];
    c.skeleton
        .world_from_local(&c.clips[clip].frames[frame], &mut pose);
    pose
}

#[test]
fn a_simulated_humanoid_agrees_with_the_skin_our_glb_export_writes() {
    let c = ragdoll::skeleton::humanoid();
    let spec = spec::build_spec(&c, &BuildOptions::default()).unwrap();
    let (mut world, _) = World::with_ragdoll(&c, &spec, &WorldSettings::default()).unwrap();
    world.run(1.0);
    let track = world.into_track();
    let glb = ragdoll::export::gltf::to_glb(&c, &spec, &track).unwrap();
    let back = from_bytes(&glb, Path::new("humanoid.glb")).unwrap();
    assert_eq!(back.meshes.len(), 1);
    let clip = back.clips.iter().position(|k| k.name == "ragdoll").unwrap();
    let last = track.frames.len() - 1;
    let pose = clip_pose(&back, clip, last);
    // The clip read back is the track (so the pose below is the simulated one).
    for (a, b) in pose.iter().zip(&track.frames[last]) {
        assert!((a.translation - b.translation).length() < 1e-4);
    }
    // The body has moved: this is not the rest pose in disguise.
    let rest = back.skeleton.rest_world();
    let moved = rest
        .iter()
        .zip(&pose)
        .map(|(a, b)| (a.translation - b.translation).length())
        .fold(0.0f32, f32::max);
    assert!(moved > 0.3, "the humanoid only moved {moved} m");
    let (ours, _) = skinned(&back.meshes[0], &rest, &pose);
    let viewer = viewer_skin(&glb, &joint_nodes(&back), &pose);
    assert_close(&ours, &viewer, 1e-4, "humanoid bodies");
    let (at_rest, _) = skinned(&back.meshes[0], &rest, &rest);
    assert_close(&at_rest, &back.meshes[0].positions, 1e-5, "rest");
}

#[test]
#[ignore = "needs ../shared/data"]
fn cesium_man_walking_agrees_with_the_viewer_formula_on_its_own_file() {
    let data = common::shared_data();
    let path = data.join("gltf/CesiumMan.glb");
    let c = import::load(&path, &ImportOptions::default()).unwrap();
    let glb = std::fs::read(&path).unwrap();
    let rest = c.skeleton.rest_world();
    // Rest pose: the mesh as imported.
    let (p, _) = skinned(&c.meshes[0], &rest, &rest);
    assert_close(&p, &c.meshes[0].positions, 1e-5, "CesiumMan rest");
    // A walking frame: every vertex where a viewer puts it (CesiumMan's bind pose is its
    // rest pose, so the two formulas agree to rounding).
    let frame = c.clips[0].frames.len() / 2;
    let pose = clip_pose(&c, 0, frame);
    let (ours, _) = skinned(&c.meshes[0], &rest, &pose);
    let viewer = viewer_skin(&glb, &joint_nodes(&c), &pose);
    assert_close(&ours, &viewer, 1e-4, "CesiumMan walking");
    let moved = ours
        .iter()
        .zip(&c.meshes[0].positions)
        .map(|(a, b)| (*a - *b).length())
        .fold(0.0f32, f32::max);
    assert!(
        moved > 0.05,
        "the walk frame barely moves the mesh ({moved} m)"
    );
}
