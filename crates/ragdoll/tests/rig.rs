//! Rigging unrigged meshes: the OBJ reader, the centre-line skeleton, mirrored
//! branches and automatic skin weights.

mod common;

use std::path::Path;

use glam::{Quat, Vec3, Vec4};
use ragdoll::error::Error;
use ragdoll::import::{ImportOptions, obj};
use ragdoll::math::Transform;
use ragdoll::rig::{Branch, Landmark, RigOptions, auto_weights, build_skeleton, rig};
use ragdoll::skeleton::{Joint, Skeleton, SkinnedMesh, humanoid};
use ragdoll::spec::{BuildOptions, RagdollSpec, build_spec};
use ragdoll::world::{BackendKind, World, WorldSettings};

/// Checks the skin invariants glTF and the spec builder rely on: one row per vertex, at
/// most four influences on real joints, weights in [0, 1] summing to 1, unused slots on
/// joint 0 with weight 0.
fn assert_valid_skin(joints: &[[u16; 4]], weights: &[Vec4], vertices: usize, skeleton_len: usize) {
    assert_eq!(joints.len(), vertices);
    assert_eq!(weights.len(), vertices);
    for (v, (j, w)) in joints.iter().zip(weights).enumerate() {
        let sum = w.element_sum();
        assert!((sum - 1.0).abs() < 1e-5, "vertex {v}: weights sum to {sum}");
        for c in 0..4 {
            assert!((0.0..=1.0).contains(&w[c]), "vertex {v}: weight {}", w[c]);
            assert!((j[c] as usize) < skeleton_len, "vertex {v}: joint {}", j[c]);
            if w[c] == 0.0 {
                assert_eq!(j[c], 0, "vertex {v}: an unused slot must name joint 0");
            }
        }
    }
}

/// A closed box mesh from `a` to `b` (axis-aligned corners), turned by `q` about the origin.
fn box_mesh(a: Vec3, b: Vec3, q: Quat) -> SkinnedMesh {
    let corner = |i: usize| {
        q * Vec3::new(
            if i & 1 == 0 { a.x } else { b.x },
            if i & 2 == 0 { a.y } else { b.y },
            if i & 4 == 0 { a.z } else { b.z },
        )
    };
    // Each face split into a grid of small triangles, so the surface samples are dense.
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    let faces = [
        [0, 1, 3, 2],
        [4, 6, 7, 5],
        [0, 4, 5, 1],
        [2, 3, 7, 6],
        [0, 2, 6, 4],
        [1, 5, 7, 3],
    ];
    const N: usize = 8;
    for f in faces {
        let (p0, p1, p2, p3) = (corner(f[0]), corner(f[1]), corner(f[2]), corner(f[3]));
        let base = positions.len() as u32;
        for i in 0..=N {
            for j in 0..=N {
                let (u, v) = (i as f32 / N as f32, j as f32 / N as f32);
                let p = p0.lerp(p1, u).lerp(p3.lerp(p2, u), v);
                positions.push(p);
            }
        }
        let at = |i: usize, j: usize| base + (i * (N + 1) + j) as u32;
        for i in 0..N {
            for j in 0..N {
                indices.extend([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
                indices.extend([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
            }
        }
    }
    SkinnedMesh {
        name: "box".into(),
        positions,
        indices,
        ..Default::default()
    }
}

fn joint_positions(s: &Skeleton) -> Vec<Vec3> {
    s.rest_world().iter().map(|t| t.translation).collect()
}

// --- Automatic weights -------------------------------------------------------------

#[test]
fn auto_weights_are_normalised_top_four_and_cover_every_vertex() {
    let skeleton = humanoid().skeleton;
    // A grid of points through and around the body, far ones included.
    let mut points = Vec::new();
    for x in -10..=10 {
        for y in -2..=22 {
            for z in -5..=5 {
                points.push(Vec3::new(x as f32 * 0.1, y as f32 * 0.1, z as f32 * 0.1));
            }
        }
    }
    points.push(Vec3::splat(1e4));
    let (joints, weights) = auto_weights(&skeleton, &points);
    assert_valid_skin(&joints, &weights, points.len(), skeleton.len());
    // Some vertices really are shared by four bones (the top four are kept, not fewer).
    assert!(
        weights
            .iter()
            .any(|w| w.to_array().iter().filter(|&&x| x > 0.0).count() == 4)
    );
}

#[test]
fn auto_weights_favour_the_nearest_bone_by_inverse_square() {
    // Two joints 1 m apart along X, the second with a tip 1 m further: bones [0,1] and
    // [1,2]. A point 0.1 m off the middle of the first bone is 0.1 m from bone 0 and
    // √(0.5² + 0.1²) from bone 1 (its start), so w0/w1 = (0.25 + 0.01) / 0.01 = 26.
    let s = Skeleton::new(vec![
        Joint {
            name: "a".into(),
            parent: None,
            rest: Transform::IDENTITY,
            tip: None,
        },
        Joint {
            name: "b".into(),
            parent: Some(0),
            rest: Transform::from_translation(Vec3::X),
            tip: Some(Vec3::X),
        },
    ])
    .unwrap();
    let (joints, weights) = auto_weights(&s, &[Vec3::new(0.5, 0.1, 0.0)]);
    assert_eq!(joints[0][..2], [0, 1]);
    let ratio = weights[0].x / weights[0].y;
    assert!((ratio - 26.0).abs() < 1e-2, "ratio {ratio}");
}

#[test]
fn auto_weights_on_degenerate_inputs() {
    let skeleton = humanoid().skeleton;
    let world = skeleton.rest_world();
    // A vertex exactly on a joint is shared evenly by the bones that meet there: the
    // parent's bone ending at it and the joint's own bone(s) starting at it.
    let knee = skeleton.find("shin_l").unwrap();
    let thigh = skeleton.parent(knee).unwrap();
    let (joints, weights) = auto_weights(&skeleton, &[world[knee].translation]);
    assert_valid_skin(&joints, &weights, 1, skeleton.len());
    let w_of = |j: usize| {
        (0..4)
            .filter(|&c| joints[0][c] as usize == j)
            .map(|c| weights[0][c])
            .sum::<f32>()
    };
    assert!((w_of(knee) - 0.5).abs() < 1e-3, "{joints:?} {weights:?}");
    assert!((w_of(thigh) - 0.5).abs() < 1e-3, "{joints:?} {weights:?}");

    // A single joint without a tip: everything on it, wherever the vertex is (even on it).
    let one = Skeleton::new(vec![Joint {
        name: "only".into(),
        parent: None,
        rest: Transform::from_translation(Vec3::Y),
        tip: None,
    }])
    .unwrap();
    let pts = [Vec3::Y, Vec3::ZERO, Vec3::splat(-50.0)];
    let (joints, weights) = auto_weights(&one, &pts);
    assert_valid_skin(&joints, &weights, 3, 1);
    assert!(weights.iter().all(|w| *w == Vec4::X));

    // Non-finite positions still get a weight (all on joint 0), no NaN leaks out.
    let (joints, weights) = auto_weights(&skeleton, &[Vec3::NAN, Vec3::INFINITY]);
    assert_valid_skin(&joints, &weights, 2, skeleton.len());
    assert_eq!(weights, vec![Vec4::X, Vec4::X]);

    // No vertices: no rows.
    assert_eq!(auto_weights(&skeleton, &[]).0.len(), 0);
}

// --- OBJ ---------------------------------------------------------------------------

fn parse(text: &str) -> ragdoll::Result<SkinnedMesh> {
    obj::parse(text, Path::new("test.obj"), &ImportOptions::default())
}

#[test]
fn obj_reads_corner_forms_negative_indices_and_fans_polygons() {
    let text = "# a quad and a triangle\n\
                v 0 0 0\nv 1 0 0 1.0\nv 1 1 0 0.5 0.5 0.5\nv 0 1 0\n\
                vt 0 0\nvn 0 0 1\n\
                o thing\ng part\ns off\nusemtl stuff\n\
                f 1/1/1 2/1/1 3/1/1 4/1/1\n\
                f -4//-1 -3 -2/1\n";
    let m = parse(text).unwrap();
    assert_eq!(m.positions.len(), 4);
    assert_eq!(m.positions[2], Vec3::new(1.0, 1.0, 0.0));
    assert_eq!(m.indices, vec![0, 1, 2, 0, 2, 3, 0, 1, 2]);
    // Normals: the file's where given, else from the faces (the same here).
    assert_eq!(m.normals.len(), 4);
    assert!(m.normals.iter().all(|n| (*n - Vec3::Z).length() < 1e-6));
}

#[test]
fn obj_units_and_up_axis_are_converted() {
    let text = "v 0 0 0\nv 100 0 0\nv 0 0 200\nf 1 2 3\n";
    let opts = ImportOptions {
        units: Some(ragdoll::import::Units::Cm),
        up: Some(ragdoll::import::UpAxis::Z),
        ..Default::default()
    };
    let m = obj::parse(text, Path::new("z.obj"), &opts).unwrap();
    // Z up in centimetres: 2 m up the file's Z is 2 m up Y.
    assert!((m.positions[2] - Vec3::new(0.0, 2.0, 0.0)).length() < 1e-6);
    assert!((m.positions[1] - Vec3::new(1.0, 0.0, 0.0)).length() < 1e-6);
}

#[test]
fn obj_errors_name_the_file_and_line() {
    let cases = [
        ("v 0 0 0\nv 1 0\nf 1 2 3\n", 2, "three numbers"),
        ("v 0 0 0\nv 1 zero 0\n", 2, "not a finite number"),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 4\n",
            5,
            "vertex index 4 does not exist",
        ),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n", 4, "vertex index 0"),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 2 3\n",
            4,
            "vertex index -4",
        ),
        ("v 0 0 0\nv 1 0 0\nf 1 2\n", 3, "at least 3 corners"),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//1 2 3\n",
            4,
            "normal index 1",
        ),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n",
            4,
            "not a whole number",
        ),
    ];
    for (text, line, needle) in cases {
        match parse(text) {
            Err(e @ Error::Parse { .. }) => {
                let Error::Parse { line: l, .. } = &e else {
                    unreachable!()
                };
                let msg = e.to_string();
                assert_eq!(*l, line, "{msg}");
                assert!(msg.contains("test.obj") && msg.contains(needle), "{msg}");
            }
            other => panic!("{text:?}: expected a parse error, got {other:?}"),
        }
    }
    // No faces at all: nothing to rig, said as such.
    let e = parse("v 0 0 0\nv 1 0 0\n").unwrap_err();
    assert!(e.to_string().contains("no faces"), "{e}");
    // All vertices at one point: a clear error from the rig, naming the file.
    let dir = std::env::temp_dir().join(format!("ragdoll-rig-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let flat = dir.join("point.obj");
    std::fs::write(&flat, "v 1 1 1\nv 1 1 1\nv 1 1 1\nf 1 2 3\n").unwrap();
    let e = ragdoll::import::load(&flat, &ImportOptions::default()).unwrap_err();
    assert!(
        matches!(e, Error::Format { .. }) && e.to_string().contains("point.obj"),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

// --- Skeleton from a mesh ------------------------------------------------------------

#[test]
fn spine_follows_the_principal_axis_evenly_spaced_head_at_the_higher_end() {
    // A 2 m × 0.3 m × 0.2 m bar, turned so its long axis points along (1, 0.4, 0.6)
    // normalised: the spine must lie along it, its head at the higher (+Y) end.
    let q = Quat::from_rotation_arc(Vec3::X, Vec3::new(1.0, 0.4, 0.6).normalize());
    let mesh = box_mesh(Vec3::new(-1.0, -0.15, -0.1), Vec3::new(1.0, 0.15, 0.1), q);
    let axis = q * Vec3::X;
    let n = 8;
    let s = build_skeleton(
        std::slice::from_ref(&mesh),
        &RigOptions {
            joints: n,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(s.len(), n);
    let p = joint_positions(&s);
    assert_eq!(s.joints()[n - 1].name, "head");
    assert_eq!(s.joints()[0].name, "spine00");
    let dir = (p[n - 1] - p[0]).normalize();
    assert!(
        dir.dot(axis) > 0.999,
        "spine direction {dir:?}, axis {axis:?}"
    );
    // Every joint on the axis (the bar is symmetric, so the centre line is straight).
    for x in &p {
        let off = *x - axis * x.dot(axis);
        assert!(off.length() < 0.01, "joint {x:?} is {off:?} off the axis");
    }
    // Evenly spaced: the tail joint at one end, N equal steps to the tip at the other.
    let tip = s.rest_world()[n - 1].transform_point(s.joints()[n - 1].tip.unwrap());
    let mut chain = p.clone();
    chain.push(tip);
    let steps: Vec<f32> = chain.windows(2).map(|w| w[0].distance(w[1])).collect();
    for st in &steps {
        assert!((st - 2.0 / n as f32).abs() < 0.02, "steps {steps:?}");
    }
    // Each joint's Y axis runs along its bone.
    for (i, w) in s.rest_world().iter().enumerate().take(n - 1) {
        let along = (p[i + 1] - p[i]).normalize();
        assert!((w.rotation * Vec3::Y).dot(along) > 0.9999);
    }
    // `head` at the other end flips the chain.
    let flipped = build_skeleton(
        std::slice::from_ref(&mesh),
        &RigOptions {
            joints: n,
            head: Some(Landmark::Point(-axis)),
            ..Default::default()
        },
    )
    .unwrap();
    let fp = joint_positions(&flipped);
    assert!((fp[n - 1] - fp[0]).normalize().dot(axis) < -0.999);
}

#[test]
fn a_centre_line_through_landmarks_is_resampled_by_arc_length() {
    // L-shaped path 0 → (1,0,0) → (1,1,0), 2 m long: 4 joints every 0.5 m, tip at the end.
    let mesh = box_mesh(Vec3::ZERO, Vec3::ONE, Quat::IDENTITY);
    let s = build_skeleton(
        &[mesh],
        &RigOptions {
            joints: 4,
            centre_line: vec![
                Landmark::Point(Vec3::ZERO),
                Landmark::Point(Vec3::X),
                Landmark::Point(Vec3::new(1.0, 1.0, 0.0)),
            ],
            ..Default::default()
        },
    )
    .unwrap();
    let want = [
        Vec3::ZERO,
        Vec3::new(0.5, 0.0, 0.0),
        Vec3::X,
        Vec3::new(1.0, 0.5, 0.0),
    ];
    for (got, want) in joint_positions(&s).iter().zip(want) {
        assert!(got.distance(want) < 1e-5, "{got:?} vs {want:?}");
    }
    let tip = s.rest_world()[3].transform_point(s.joints()[3].tip.unwrap());
    assert!(tip.distance(Vec3::new(1.0, 1.0, 0.0)) < 1e-5);
}

#[test]
fn mirrored_branches_are_symmetric_and_off_the_spine() {
    // A body along X, its head at +X (by landmark), a leg given on one side and mirrored
    // across the plane through the centroid that holds X and Y.
    let mesh = box_mesh(
        Vec3::new(-1.0, -0.1, -0.2),
        Vec3::new(1.0, 0.1, 0.2),
        Quat::IDENTITY,
    );
    let leg = Branch {
        name: "leg".into(),
        points: vec![
            Landmark::Point(Vec3::new(0.3, -0.05, -0.15)),
            Landmark::Point(Vec3::new(0.35, -0.4, -0.3)),
            Landmark::Point(Vec3::new(0.4, -0.8, -0.3)),
        ],
        joints: 0,
        mirror: true,
    };
    let opts = RigOptions {
        joints: 6,
        head: Some(Landmark::Point(Vec3::new(2.0, 0.0, 0.0))),
        branches: vec![leg.clone()],
        ..Default::default()
    };
    let mut meshes = vec![mesh];
    let s = rig(&mut meshes, &opts).unwrap();
    // 6 spine joints, and per side a joint on the spine plus one per landmark but the last.
    assert_eq!(s.len(), 6 + 2 * 3);
    let p = joint_positions(&s);
    // Facing +X with Y up, the left (up × forward) is −Z: the leg given at −Z is the left.
    let r: Vec<usize> = (0..3)
        .map(|k| s.find(&format!("leg_r{k:02}")).unwrap())
        .collect();
    let l: Vec<usize> = (0..3)
        .map(|k| s.find(&format!("leg_l{k:02}")).unwrap())
        .collect();
    for (a, b) in l.iter().zip(&r) {
        let mirrored = p[*b] * Vec3::new(1.0, 1.0, -1.0);
        assert!(
            p[*a].distance(mirrored) < 1e-3,
            "{:?} vs {:?}",
            p[*a],
            p[*b]
        );
    }
    assert!((p[l[1]] - Vec3::new(0.3, -0.05, -0.15)).length() < 1e-5);
    assert!(p[l[1]].z < -0.1 && p[r[1]].z > 0.1);
    // Both hang from the spine joint nearest the leg, starting on it.
    let attach = s.parent(l[0]).unwrap();
    assert_eq!(s.parent(r[0]), Some(attach));
    assert!(s.joints()[attach].name.starts_with("spine"));
    assert!(p[l[0]].distance(p[attach]) < 1e-6);
    // The spine's own bone still runs to the next spine joint (the branch does not bend it).
    let spine_y = s.rest_world()[attach].rotation * Vec3::Y;
    assert!(spine_y.dot(Vec3::X) > 0.99, "{spine_y:?}");
    // The tips mirror too.
    let tip = |j: usize| s.rest_world()[j].transform_point(s.joints()[j].tip.unwrap());
    assert!(tip(l[2]).distance(tip(r[2]) * Vec3::new(1.0, 1.0, -1.0)) < 1e-3);
    // Every vertex is weighted on this skeleton.
    assert_valid_skin(
        &meshes[0].joints,
        &meshes[0].weights,
        meshes[0].positions.len(),
        s.len(),
    );

    // A branch on the symmetry plane cannot be mirrored: its twin would coincide with it.
    let mut on_plane = leg;
    on_plane.points[0] = Landmark::Point(Vec3::new(0.3, -0.05, 0.0));
    let e = build_skeleton(
        &meshes,
        &RigOptions {
            branches: vec![on_plane.clone()],
            ..opts.clone()
        },
    )
    .unwrap_err();
    assert!(
        matches!(&e, Error::Setting { setting, .. } if setting.contains("leg")),
        "{e}"
    );
    // Unmirrored it is fine.
    on_plane.mirror = false;
    let s = build_skeleton(
        &meshes,
        &RigOptions {
            branches: vec![on_plane],
            ..opts.clone()
        },
    )
    .unwrap();
    assert!(s.find("leg00").is_some());
    // A landmark vertex that does not exist is an error naming it.
    let e = build_skeleton(
        &meshes,
        &RigOptions {
            head: Some(Landmark::Vertex(1 << 30)),
            ..opts
        },
    )
    .unwrap_err();
    assert!(e.to_string().contains("does not exist"), "{e}");
}

#[test]
fn joint_counts_out_of_range_are_setting_errors() {
    let mesh = box_mesh(Vec3::ZERO, Vec3::new(2.0, 0.2, 0.2), Quat::IDENTITY);
    for joints in [0, 100_000] {
        let e = build_skeleton(
            std::slice::from_ref(&mesh),
            &RigOptions {
                joints,
                ..Default::default()
            },
        )
        .unwrap_err();
        assert!(matches!(e, Error::Setting { .. }), "{e}");
    }
    // One joint is a valid rig: a single body along the whole mesh.
    let s = build_skeleton(
        &[mesh],
        &RigOptions {
            joints: 1,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(s.len(), 1);
    assert!(s.joints()[0].tip.unwrap().length() > 1.9);
}

// --- The Stanford dragons --------------------------------------------------------------

#[test]
#[ignore = "needs ../shared/data"]
fn both_dragons_rig_build_and_fall_to_rest_on_the_floor() {
    let data = common::shared_data();
    for file in ["stanford_dragon_1k7.obj", "stanford_dragon_13k.obj"] {
        let path = data.join("mesh").join(file);
        let c = ragdoll::import::load(&path, &ImportOptions::default()).unwrap();
        assert_eq!(c.skeleton.len(), ragdoll::rig::DEFAULT_JOINTS, "{file}");
        let m = &c.meshes[0];
        assert_valid_skin(&m.joints, &m.weights, m.positions.len(), c.skeleton.len());
        // The head is the raised end: the dragon's head is its highest part (+X in the scan).
        let p = joint_positions(&c.skeleton);
        let head = p[c.skeleton.find("head").unwrap()];
        assert!(head.x > 0.2 && head.y > 0.8, "{file}: head at {head:?}");
        assert!(p[0].x < 0.0, "{file}: tail at {:?}", p[0]);

        let spec = build_spec(&c, &BuildOptions::default()).unwrap();
        assert_eq!(spec.bodies.len(), c.skeleton.len(), "{file}");
        for backend in [BackendKind::Rigid, BackendKind::Fast, BackendKind::Particle] {
            let file = format!("{file} ({})", backend.as_str());
            falls_to_rest(&c, &spec, backend, &file);
        }
    }
}

/// Drops a rigged dragon on `backend`: it must fall, keep its joints together and its
/// limits, and lie still on the floor by 7 s. Only the fast backend is held to the last.
/// The particle backend's contacts take every shape for a capsule, and the 13k scan's
/// tail boxes roll on as capsules (0.1-0.5 m/s through 10 s). rapier has no rolling
/// resistance, and a part lying on the rounded pieces of skin its body carries rocks on:
/// over both dragons rigged with 8 to 16 joints at two sizes (20 drops each), 9 still
/// moved faster than 1 cm/s after 7 s before bodies had extra shapes, 14 after, where
/// `fast` lies still in all 20 (17 before).
fn falls_to_rest(
    c: &ragdoll::skeleton::Character,
    spec: &RagdollSpec,
    backend: BackendKind,
    file: &str,
) {
    {
        let settings = WorldSettings {
            backend: backend.into(),
            ..Default::default()
        };
        let (mut world, id) = World::with_ragdoll(c, spec, &settings).unwrap();
        world.step(); // (body poses exist from the first step on)
        let start = world.body_poses(id);
        world.run(7.0);
        let metrics = world.metrics();
        assert!(!metrics.nan, "{file}");
        assert!(metrics.max_joint_separation_m < 0.01, "{file}: {metrics:?}");
        assert!(metrics.max_limit_violation_deg < 5.0, "{file}: {metrics:?}");
        // It fell (the scan floats 0.32 m up) and came to rest on the floor: the chain
        // creeps for a few seconds after landing, and is still by 6 s.
        let end = world.body_poses(id);
        let mean_y =
            |v: &[Transform]| v.iter().map(|t| t.translation.y).sum::<f32>() / v.len() as f32;
        assert!(mean_y(&end) < mean_y(&start) - 0.2, "{file}: did not fall");
        let speed = world
            .body_velocities(id)
            .iter()
            .map(|(v, _)| v.length())
            .fold(0.0, f32::max);
        if backend == BackendKind::Fast {
            assert!(
                speed < 0.01,
                "{file}: still moving at {speed} m/s after 7 s"
            );
        }
        let lowest = end
            .iter()
            .map(|t| t.translation.y)
            .fold(f32::INFINITY, f32::min);
        assert!(lowest > 0.0, "{file}: a body centre is under the floor");
    }
}

#[test]
fn a_rigged_mesh_round_trips_through_gltf() {
    let q = Quat::from_rotation_y(0.3);
    let mut meshes = vec![box_mesh(
        Vec3::new(-1.0, 0.0, -0.1),
        Vec3::new(1.0, 0.3, 0.1),
        q,
    )];
    let skeleton = rig(
        &mut meshes,
        &RigOptions {
            joints: 5,
            ..Default::default()
        },
    )
    .unwrap();
    let c = ragdoll::skeleton::Character {
        humanoid_bones: Vec::new(),
        warnings: Vec::new(),
        name: "bar".into(),
        skeleton,
        meshes,
        clips: vec![],
        source: ragdoll::skeleton::Source::Mesh("bar.obj".into()),
    };
    let glb = ragdoll::export::gltf::rig_to_glb(&c).unwrap();
    let back = ragdoll::import::gltf::from_bytes(&glb, Path::new("bar.glb")).unwrap();
    assert_eq!(back.skeleton.len(), 5);
    assert!(back.clips.is_empty());
    let names: Vec<&str> = back
        .skeleton
        .joints()
        .iter()
        .map(|j| j.name.as_str())
        .collect();
    assert_eq!(names, ["spine00", "spine01", "spine02", "spine03", "head"]);
    for (a, b) in joint_positions(&c.skeleton)
        .iter()
        .zip(joint_positions(&back.skeleton))
    {
        assert!(a.distance(b) < 1e-5);
    }
    let (m0, m1) = (&c.meshes[0], &back.meshes[0]);
    assert_eq!(m0.positions.len(), m1.positions.len());
    for (a, b) in m0.positions.iter().zip(&m1.positions) {
        assert!(a.distance(*b) < 1e-5);
    }
    for (a, b) in m0.weights.iter().zip(&m1.weights) {
        assert!((*a - *b).abs().max_element() < 1e-5);
    }
}
