//! Role recognition and ragdoll building on the real characters in `../shared/data`: the
//! humanoids are recognised whatever way they face, the others become chains, and every
//! spec is valid, keeps its mass, starts without interpenetration and round-trips TOML.

mod common;

use std::path::Path;

use glam::{Quat, Vec3};
use ragdoll::import::{ImportOptions, load};
use ragdoll::skeleton::{Character, humanoid};
use ragdoll::spec::{
    BuildOptions, JointKind, RagdollSpec, Role, Roles, Shape, build_spec, humanoid_mass_kg,
    recognise_roles,
};

const HUMANOIDS: [&str; 4] = [
    "bvh/cmu_pirouette_threejs.bvh",
    "bvh/mocapbank_bvh-python.bvh",
    "bvh/biovision_example_bvhio.bvh",
    "gltf/CesiumMan.glb",
];
const OTHERS: [&str; 3] = [
    "bvh/two_joint_bvh_anim.bvh",
    "gltf/Fox.glb",
    "gltf/SimpleSkin.gltf",
];

/// Roles every humanoid must have, once each.
const LIMB_ROLES: [Role; 14] = [
    Role::Pelvis,
    Role::Head,
    Role::ThighL,
    Role::ThighR,
    Role::ShinL,
    Role::ShinR,
    Role::FootL,
    Role::FootR,
    Role::UpperArmL,
    Role::UpperArmR,
    Role::ForearmL,
    Role::ForearmR,
    Role::HandL,
    Role::HandR,
];

fn load_data(rel: &str) -> Character {
    let path = common::shared_data().join(rel);
    load(&path, &ImportOptions::default()).unwrap_or_else(|e| panic!("{rel}: {e}"))
}

/// `c` turned by `yaw` about the vertical through the origin.
fn yawed(c: &Character, yaw: f32) -> Character {
    c.turned(yaw)
}

fn role_joint(roles: &Roles, role: Role) -> usize {
    let found: Vec<usize> = (0..roles.per_joint.len())
        .filter(|&j| roles.per_joint[j] == Some(role))
        .collect();
    assert_eq!(found.len(), 1, "{role:?} found {} times", found.len());
    found[0]
}

/// Checks the humanoid roles of `c` and that left limbs are on the character's left.
fn check_humanoid(rel: &str, c: &Character, roles: &Roles) {
    assert!(roles.humanoid, "{rel}: not recognised as a humanoid");
    let world = c.skeleton.rest_world();
    let pos = |r: Role| world[role_joint(roles, r)].translation;
    for r in LIMB_ROLES {
        role_joint(roles, r);
    }
    let mid = pos(Role::Pelvis);
    let left = roles.left();
    assert!(roles.forward.y.abs() < 1e-5 && (roles.forward.length() - 1.0).abs() < 1e-4);
    for (l, r) in [
        (Role::ThighL, Role::ThighR),
        (Role::ShinL, Role::ShinR),
        (Role::FootL, Role::FootR),
        (Role::UpperArmL, Role::UpperArmR),
        (Role::ForearmL, Role::ForearmR),
        (Role::HandL, Role::HandR),
    ] {
        assert!(
            (pos(l) - mid).dot(left) > 0.0,
            "{rel}: {l:?} is not on the left"
        );
        assert!(
            (pos(r) - mid).dot(left) < 0.0,
            "{rel}: {r:?} is not on the right"
        );
    }
    assert!(pos(Role::Head).y > pos(Role::Pelvis).y + 0.3 * roles.height_m);
}

#[test]
#[ignore = "needs ../shared/data"]
fn humanoid_files_are_recognised_whatever_their_facing() {
    for rel in HUMANOIDS {
        let c = load_data(rel);
        let base = recognise_roles(&c);
        check_humanoid(rel, &c, &base);
        for k in 1..8 {
            let yaw = (k as f32 * 45.0).to_radians();
            let cy = yawed(&c, yaw);
            let r = recognise_roles(&cy);
            check_humanoid(rel, &cy, &r);
            assert_eq!(
                r.per_joint,
                base.per_joint,
                "{rel}: roles change at yaw {}",
                k * 45
            );
            let f = Quat::from_rotation_y(yaw) * base.forward;
            assert!(
                (r.forward - f).length() < 1e-3,
                "{rel}: forward at yaw {}: {:?}",
                k * 45,
                r.forward
            );
        }
    }
}

/// Expected roles by joint name for the named BVH humanoids; everything else rides.
#[test]
#[ignore = "needs ../shared/data"]
fn named_humanoids_get_the_expected_joints() {
    use Role::*;
    let cases: [(&str, &[(&str, Role)]); 3] = [
        (
            "bvh/cmu_pirouette_threejs.bvh",
            &[
                ("hip", Pelvis),
                ("abdomen", Spine),
                ("chest", Chest),
                ("neck", Neck),
                ("head", Head),
                ("lThigh", ThighL),
                ("lShin", ShinL),
                ("lFoot", FootL),
                ("rThigh", ThighR),
                ("rShin", ShinR),
                ("rFoot", FootR),
                ("lShldr", UpperArmL),
                ("lForeArm", ForearmL),
                ("lHand", HandL),
                ("rShldr", UpperArmR),
                ("rForeArm", ForearmR),
                ("rHand", HandR),
            ],
        ),
        (
            "bvh/mocapbank_bvh-python.bvh",
            &[
                ("Hips", Pelvis),
                ("Chest", Spine),
                ("Chest2", Chest),
                ("Neck", Neck),
                ("Head", Head),
                ("LeftHip", ThighL),
                ("LeftKnee", ShinL),
                ("LeftAnkle", FootL),
                ("RightHip", ThighR),
                ("RightKnee", ShinR),
                ("RightAnkle", FootR),
                ("LeftShoulder", UpperArmL),
                ("LeftElbow", ForearmL),
                ("LeftWrist", HandL),
                ("RightShoulder", UpperArmR),
                ("RightElbow", ForearmR),
                ("RightWrist", HandR),
            ],
        ),
        (
            "bvh/biovision_example_bvhio.bvh",
            &[
                ("Hips", Pelvis),
                ("Chest", Chest),
                ("Neck", Neck),
                ("Head", Head),
                ("LeftUpLeg", ThighL),
                ("LeftLowLeg", ShinL),
                ("LeftFoot", FootL),
                ("RightUpLeg", ThighR),
                ("RightLowLeg", ShinR),
                ("RightFoot", FootR),
                ("LeftUpArm", UpperArmL),
                ("LeftLowArm", ForearmL),
                ("LeftHand", HandL),
                ("RightUpArm", UpperArmR),
                ("RightLowArm", ForearmR),
                ("RightHand", HandR),
            ],
        ),
    ];
    for (rel, want) in cases {
        check_expected(rel, want);
    }
    // CesiumMan has no names: its joints are labelled by index. It faces +X (toes and
    // knees point there), so its left is -Z.
    check_expected(
        "gltf/CesiumMan.glb",
        &[
            ("joint0", Pelvis),
            ("joint1", Spine),
            ("joint2", Chest),
            ("joint3", Neck),
            ("joint4", Head),
            ("joint5", UpperArmL),
            ("joint6", UpperArmR),
            ("joint7", ForearmL),
            ("joint8", ForearmR),
            ("joint9", HandL),
            ("joint10", HandR),
            ("joint11", ThighL),
            ("joint12", ThighR),
            ("joint13", ShinL),
            ("joint14", ShinR),
            ("joint15", FootL),
            ("joint16", FootR),
        ],
    );
}

/// Checks the roles of `rel` by joint label; joints not listed must ride (`None`).
fn check_expected(rel: &str, want: &[(&str, Role)]) {
    let c = load_data(rel);
    let roles = recognise_roles(&c);
    for i in 0..c.skeleton.len() {
        let label = c.skeleton.joint_label(i);
        let expected = want.iter().find(|(n, _)| *n == label).map(|(_, r)| *r);
        assert_eq!(roles.per_joint[i], expected, "{rel}: joint {label}");
    }
}

#[test]
#[ignore = "needs ../shared/data"]
fn other_files_become_chains() {
    for rel in OTHERS {
        let c = load_data(rel);
        let roles = recognise_roles(&c);
        assert!(!roles.humanoid, "{rel}");
        assert!(
            roles
                .per_joint
                .iter()
                .all(|r| matches!(r, None | Some(Role::Chain))),
            "{rel}"
        );
        assert!(
            roles.per_joint.iter().any(|r| r.is_some()),
            "{rel}: no body at all"
        );
        let spec = build_spec(&c, &BuildOptions::default()).unwrap();
        assert!(spec.bodies.iter().all(|b| b.role == Some(Role::Chain)));
        for j in &spec.joints {
            assert!(
                // Creature legs bent at rest become hinges (spec/build/joints.rs).
                matches!(
                    j.kind,
                    JointKind::SwingTwist { .. } | JointKind::Hinge { .. }
                ),
                "{rel}: {}",
                j.name
            );
        }
    }
    // Fox: its two helper roots (nothing is skinned to them) carry no body; the rest do.
    let fox = load_data("gltf/Fox.glb");
    let roles = recognise_roles(&fox);
    let s = &fox.skeleton;
    assert_eq!(roles.per_joint[s.find("_rootJoint").unwrap()], None);
    assert_eq!(roles.per_joint[s.find("b_Root_00").unwrap()], None);
    assert_eq!(
        roles.per_joint[s.find("b_Hip_01").unwrap()],
        Some(Role::Chain)
    );
    assert_eq!(
        roles.per_joint[s.find("b_Tail03_014").unwrap()],
        Some(Role::Chain)
    );
    let spec = build_spec(&fox, &BuildOptions::default()).unwrap();
    assert_eq!(spec.bodies[0].name, "b_Hip_01");
}

#[test]
#[ignore = "needs ../shared/data"]
fn every_file_builds_a_valid_spec_that_round_trips() {
    let mut files: Vec<&str> = HUMANOIDS.to_vec();
    files.extend(OTHERS);
    for rel in files {
        let c = load_data(rel);
        for opts in [
            BuildOptions::default(),
            BuildOptions {
                total_mass_kg: Some(62.5),
                female: true,
            },
        ] {
            let spec = build_spec(&c, &opts).unwrap_or_else(|e| panic!("{rel}: {e}"));
            spec.validate().unwrap();
            if let Some(m) = opts.total_mass_kg {
                assert!(
                    (spec.total_mass_kg() - m).abs() < 1e-3,
                    "{rel}: {}",
                    spec.total_mass_kg()
                );
            } else if recognise_roles(&c).humanoid {
                // 75 kg at 1.75 m, as the cube of the height: the skin's where it has one,
                // else the joints' scaled as the built-in humanoid's are to its 1.75 m.
                let h = ragdoll::import::standing_height(&c);
                let (m, want) = (spec.total_mass_kg(), humanoid_mass_kg(h));
                assert!(
                    (m / want - 1.0).abs() < 1e-4,
                    "{rel}: {m} kg, {want} kg at {h} m"
                );
            }
            let back = RagdollSpec::from_toml(&spec.to_toml(), Path::new(rel)).unwrap();
            assert_eq!(back, spec, "{rel}: TOML round trip");
            check_rest_pose(rel, &c, &spec);
        }
    }
}

/// A body's solid as a capsule (a box by its bounding capsule), world space.
fn solid(c: &Character, spec: &RagdollSpec, i: usize) -> (Vec3, Vec3, f32) {
    let b = &spec.bodies[i];
    let w = c.skeleton.rest_world()[c.skeleton.find(&b.bone).unwrap_or_else(|| {
        // Unnamed joints are matched as `joint<i>`.
        b.bone.trim_start_matches("joint").parse().unwrap()
    })];
    let centre = w.translation + w.rotation * Vec3::from_array(b.center_m);
    let rot = w.rotation * Quat::from_array(b.rotation);
    match b.shape {
        Shape::Capsule { radius_m, length_m } => {
            assert!(radius_m > 0.0 && length_m >= 0.0, "{}", b.name);
            let h = rot * Vec3::Y * (0.5 * length_m);
            (centre - h, centre + h, radius_m)
        }
        Shape::Box { size_m } => {
            let h = Vec3::from_array(size_m) * 0.5;
            let k = if h.x >= h.y && h.x >= h.z {
                0
            } else if h.y >= h.z {
                1
            } else {
                2
            };
            let axis = rot * [Vec3::X, Vec3::Y, Vec3::Z][k] * h[k];
            (
                centre - axis,
                centre + axis,
                (h.length_squared() - h[k] * h[k]).sqrt(),
            )
        }
    }
}

fn check_rest_pose(rel: &str, c: &Character, spec: &RagdollSpec) {
    let filtered = |a: &str, b: &str| spec.collision.is_disabled(a, b);
    for j in &spec.joints {
        assert!(
            filtered(&j.parent, &j.child),
            "{rel}: jointed pair {} collides",
            j.name
        );
        assert_eq!(j.anchor_m, [0.0; 3]);
    }
    let n = 48;
    for i in 0..spec.bodies.len() {
        for k in i + 1..spec.bodies.len() {
            let (a, b) = (&spec.bodies[i], &spec.bodies[k]);
            if filtered(&a.name, &b.name) {
                continue;
            }
            let (sa, sb) = (solid(c, spec, i), solid(c, spec, k));
            let mut best = f32::MAX;
            for u in 0..=n {
                let p = sa.0.lerp(sa.1, u as f32 / n as f32);
                for v in 0..=n {
                    best = best.min(p.distance(sb.0.lerp(sb.1, v as f32 / n as f32)));
                }
            }
            assert!(
                best >= sa.2 + sb.2,
                "{rel}: {} and {} overlap at rest",
                a.name,
                b.name
            );
        }
    }
}

/// Turning a knee by +30° about its hinge axis moves the foot backward, and an elbow moves
/// the hand forward, whatever way the character faces.
#[test]
fn knees_and_elbows_bend_the_right_way_on_the_built_in_humanoid() {
    knees_and_elbows_bend_the_right_way(&[("humanoid".into(), humanoid())]);
}

#[test]
#[ignore = "needs ../shared/data"]
fn knees_and_elbows_bend_the_right_way_on_every_data_humanoid() {
    let chars: Vec<(String, Character)> = HUMANOIDS
        .iter()
        .map(|rel| (rel.to_string(), load_data(rel)))
        .collect();
    knees_and_elbows_bend_the_right_way(&chars);
}

fn knees_and_elbows_bend_the_right_way(chars: &[(String, Character)]) {
    for (rel, c0) in chars {
        for k in 0..8 {
            let yaw = (k as f32 * 45.0).to_radians();
            let c = yawed(c0, yaw);
            let roles = recognise_roles(&c);
            let spec = build_spec(&c, &BuildOptions::default()).unwrap();
            let world = c.skeleton.rest_world();
            let fwd = roles.forward;
            for (hinge, end, sign) in [
                (Role::ShinL, Role::FootL, -1.0),
                (Role::ShinR, Role::FootR, -1.0),
                (Role::ForearmL, Role::HandL, 1.0),
                (Role::ForearmR, Role::HandR, 1.0),
            ] {
                let j = spec
                    .joints
                    .iter()
                    .find(|j| j.name == hinge.as_str())
                    .unwrap();
                let JointKind::Hinge { min_deg, max_deg } = j.kind else {
                    panic!("{rel}: {} is not a hinge", j.name)
                };
                let w = world[role_joint(&roles, hinge)];
                let axis = w.rotation * Quat::from_array(j.frame) * Vec3::X;
                let pivot = w.translation;
                let p = world[role_joint(&roles, end)].translation;
                let bent = pivot + Quat::from_axis_angle(axis, 30f32.to_radians()) * (p - pivot);
                let moved = (bent - p).dot(fwd) * sign;
                assert!(
                    moved > 0.0,
                    "{rel} yaw {}: {} bends the wrong way ({moved})",
                    k * 45,
                    j.name
                );
                // The anatomical range, shifted by the rest flexion, always contains the rest.
                assert!(
                    min_deg <= 1e-3 && max_deg > 90.0,
                    "{rel}: {} limits {min_deg}..{max_deg}",
                    j.name
                );
            }
        }
    }
}

/// The table in the report: roles, bodies and masses of every data file.
#[test]
#[ignore = "needs ../shared/data"]
fn summary_of_every_file() {
    let mut files: Vec<&str> = HUMANOIDS.to_vec();
    files.extend(OTHERS);
    for rel in files {
        let c = load_data(rel);
        let roles = recognise_roles(&c);
        let spec = build_spec(&c, &BuildOptions::default()).unwrap();
        println!(
            "{rel}: {} joints, humanoid {}, forward {:.2?}, H {:.3} m, {} bodies, {} joints, {} filtered pairs, {:.2} kg",
            c.skeleton.len(),
            roles.humanoid,
            roles.forward.to_array(),
            roles.height_m,
            spec.bodies.len(),
            spec.joints.len(),
            spec.collision.disabled_pairs.len(),
            spec.total_mass_kg()
        );
        for b in &spec.bodies {
            let shape = match b.shape {
                Shape::Capsule { radius_m, length_m } => {
                    format!("capsule r {radius_m:.3} l {length_m:.3}")
                }
                Shape::Box { size_m } => {
                    format!("box {:.3}x{:.3}x{:.3}", size_m[0], size_m[1], size_m[2])
                }
            };
            println!(
                "    {:<14} <- {:<16} {:>8.3} kg  {shape}",
                b.name, b.bone, b.mass_kg
            );
        }
    }
}

/// A misspelt extra key inside a joint table (`max_dgs` beside `max_deg`) is an error
/// naming the key and its line, not a value silently dropped (serde's `flatten` cannot
/// deny unknown fields by itself).
#[test]
fn a_misspelt_joint_key_is_an_error_with_its_line() {
    let c = ragdoll::skeleton::humanoid();
    let spec = build_spec(&c, &BuildOptions::default()).unwrap();
    let text = spec.to_toml();
    let line = text
        .lines()
        .position(|l| l.trim_start().starts_with("max_deg"))
        .expect("the humanoid has a hinge");
    let bad: String = text
        .lines()
        .enumerate()
        .map(|(n, l)| {
            if n == line {
                format!("{l}\nmax_dgs = 150.0\n")
            } else {
                format!("{l}\n")
            }
        })
        .collect();
    let err = RagdollSpec::from_toml(&bad, Path::new("edited.toml"))
        .unwrap_err()
        .to_string();
    assert!(err.contains("max_dgs"), "{err}");
    assert!(err.contains(&format!("line {}", line + 2)), "{err}");
    // The file as written reads back.
    assert!(RagdollSpec::from_toml(&text, Path::new("ok.toml")).is_ok());
}
