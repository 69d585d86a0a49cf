//! Roles on the rigs people actually have: for every humanoid file in
//! `../shared/data`, which joint must carry the pelvis, head, legs and arms, written from
//! each file's joint list; the helper bones of real rigs (IK controls, poles, sockets) get
//! no body; a humanoid bone table (VRM) is the strongest hint; and a foot the hierarchy
//! detaches from its leg still joins the shin.

mod common;

use std::f32::consts::{FRAC_PI_2, PI};

use glam::{Quat, Vec3};
use ragdoll::import::{ImportOptions, load};
use ragdoll::skeleton::{Character, Joint, Skeleton, humanoid};
use ragdoll::spec::{BuildOptions, RagdollSpec, Role, build_spec, recognise_roles};

/// The roles each row of [`HUMANOIDS`] names a joint for, in column order.
const COLUMNS: [Role; 14] = [
    Role::Pelvis,
    Role::Head,
    Role::ThighL,
    Role::ShinL,
    Role::FootL,
    Role::ThighR,
    Role::ShinR,
    Role::FootR,
    Role::UpperArmL,
    Role::ForearmL,
    Role::HandL,
    Role::UpperArmR,
    Role::ForearmR,
    Role::HandR,
];

type Row = (&'static str, [Option<&'static str>; 14]);

/// File, then the joint carrying each of [`COLUMNS`] (`None`: the rig has no such joint,
/// and no other joint may take the role).
const HUMANOIDS: [Row; 10] = [
    (
        "rigs/godot_mannequiny.glb",
        [
            Some("pelvis"),
            Some("head"),
            Some("thigh.l"),
            Some("calf.l"),
            Some("foot.l"),
            Some("thigh.r"),
            Some("calf.r"),
            Some("foot.r"),
            Some("upperarm.l"),
            Some("lowerarm.l"),
            Some("hand.l"),
            Some("upperarm.r"),
            Some("lowerarm.r"),
            Some("hand.r"),
        ],
    ),
    (
        "rigs/godot_robi_ik.glb",
        [
            Some("hip"),
            Some("head"),
            Some("l-thigh"),
            Some("l-leg"),
            Some("l-foot"),
            Some("r-thigh"),
            Some("r-leg"),
            Some("r-foot"),
            Some("l-arm"),
            Some("l-forearm"),
            None,
            Some("r-arm"),
            Some("r-forearm"),
            None,
        ],
    ),
    (
        "rigs/kaykit_knight.glb",
        [
            Some("hips"),
            Some("head"),
            Some("upperleg.l"),
            Some("lowerleg.l"),
            Some("foot.l"),
            Some("upperleg.r"),
            Some("lowerleg.r"),
            Some("foot.r"),
            Some("upperarm.l"),
            Some("lowerarm.l"),
            Some("wrist.l"),
            Some("upperarm.r"),
            Some("lowerarm.r"),
            Some("wrist.r"),
        ],
    ),
    (
        "rigs/quaternius_um_orc_ikfeet.gltf",
        [
            Some("Hips"),
            Some("Head"),
            Some("UpperLeg.L"),
            Some("LowerLeg.L"),
            Some("Foot.L"),
            Some("UpperLeg.R"),
            Some("LowerLeg.R"),
            Some("Foot.R"),
            Some("UpperArm.L"),
            Some("LowerArm.L"),
            None,
            Some("UpperArm.R"),
            Some("LowerArm.R"),
            None,
        ],
    ),
    (
        "rigs/animdraw_rokoko_jesse_dance.bvh",
        [
            Some("Hips"),
            Some("Head"),
            Some("LeftUpLeg"),
            Some("LeftLeg"),
            Some("LeftFoot"),
            Some("RightUpLeg"),
            Some("RightLeg"),
            Some("RightFoot"),
            Some("LeftArm"),
            Some("LeftForeArm"),
            Some("LeftHand"),
            Some("RightArm"),
            Some("RightForeArm"),
            Some("RightHand"),
        ],
    ),
    (
        "rigs/bvh11_cmu_131_01.bvh",
        [
            Some("Hips"),
            Some("Head"),
            Some("LeftHip"),
            Some("LeftKnee"),
            Some("LeftAnkle"),
            Some("RightHip"),
            Some("RightKnee"),
            Some("RightAnkle"),
            Some("LeftShoulder"),
            Some("LeftElbow"),
            Some("LeftWrist"),
            Some("RightShoulder"),
            Some("RightElbow"),
            Some("RightWrist"),
        ],
    ),
    (
        "bvh/cmu_pirouette_threejs.bvh",
        [
            Some("hip"),
            Some("head"),
            Some("lThigh"),
            Some("lShin"),
            Some("lFoot"),
            Some("rThigh"),
            Some("rShin"),
            Some("rFoot"),
            Some("lShldr"),
            Some("lForeArm"),
            Some("lHand"),
            Some("rShldr"),
            Some("rForeArm"),
            Some("rHand"),
        ],
    ),
    (
        "bvh/mocapbank_bvh-python.bvh",
        [
            Some("Hips"),
            Some("Head"),
            Some("LeftHip"),
            Some("LeftKnee"),
            Some("LeftAnkle"),
            Some("RightHip"),
            Some("RightKnee"),
            Some("RightAnkle"),
            Some("LeftShoulder"),
            Some("LeftElbow"),
            Some("LeftWrist"),
            Some("RightShoulder"),
            Some("RightElbow"),
            Some("RightWrist"),
        ],
    ),
    (
        "bvh/biovision_example_bvhio.bvh",
        [
            Some("Hips"),
            Some("Head"),
            Some("LeftUpLeg"),
            Some("LeftLowLeg"),
            Some("LeftFoot"),
            Some("RightUpLeg"),
            Some("RightLowLeg"),
            Some("RightFoot"),
            Some("LeftUpArm"),
            Some("LeftLowArm"),
            Some("LeftHand"),
            Some("RightUpArm"),
            Some("RightLowArm"),
            Some("RightHand"),
        ],
    ),
    (
        // No names: labelled by index. Faces +X; its left is -Z.
        "gltf/CesiumMan.glb",
        [
            Some("joint0"),
            Some("joint4"),
            Some("joint11"),
            Some("joint13"),
            Some("joint15"),
            Some("joint12"),
            Some("joint14"),
            Some("joint16"),
            Some("joint5"),
            Some("joint7"),
            Some("joint9"),
            Some("joint6"),
            Some("joint8"),
            Some("joint10"),
        ],
    ),
];

/// Files that are not humanoids and must not be taken for one.
const OTHERS: [&str; 4] = [
    "rigs/webxr_generic_hand_left.glb",
    "gltf/Fox.glb",
    "gltf/SimpleSkin.gltf",
    "bvh/two_joint_bvh_anim.bvh",
];

fn load_data(rel: &str) -> Character {
    let path = common::shared_data().join(rel);
    load(&path, &ImportOptions::default()).unwrap_or_else(|e| panic!("{rel}: {e}"))
}

/// Every role of the row is on the named joint and on no other; the failures of all rows
/// are gathered so one run shows the whole table.
fn check_row(rel: &str, want: &[Option<&str>; 14], c: &Character) -> Vec<String> {
    let roles = recognise_roles(c);
    let mut bad = Vec::new();
    if !roles.humanoid {
        return vec![format!("{rel}: not a humanoid ({})", roles.why)];
    }
    for (role, name) in COLUMNS.iter().zip(want) {
        let got: Vec<String> = (0..c.skeleton.len())
            .filter(|&j| roles.per_joint[j] == Some(*role))
            .map(|j| c.skeleton.joint_label(j))
            .collect();
        let expected: Vec<String> = name.iter().map(|n| n.to_string()).collect();
        if got != expected {
            bad.push(format!(
                "{rel}: {} on {got:?}, want {expected:?}",
                role.as_str()
            ));
        }
    }
    bad
}

#[test]
#[ignore = "needs ../shared/data"]
fn every_humanoid_file_has_its_roles_on_the_right_joints() {
    let mut bad = Vec::new();
    for (rel, want) in &HUMANOIDS {
        bad.extend(check_row(rel, want, &load_data(rel)));
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

/// The same files lying down, as a Z-up scene exported without turning its axes has them
/// (turned -90° about X: the head toward -Z), as a figure laid on its side (90° about Z)
/// and leaning 41°: the names, the bone table or, for CesiumMan, which has neither, the skeleton's
/// shape still give every role on the same joint.
#[test]
#[ignore = "needs ../shared/data"]
fn every_humanoid_file_lying_down_has_its_roles_on_the_right_joints() {
    let turns = [
        ("head toward -Z", Quat::from_rotation_x(-FRAC_PI_2)),
        ("on its side", Quat::from_rotation_z(FRAC_PI_2)),
        // Leaning 41° about a diagonal: CesiumMan's arms had their sides swapped, read
        // across the vertical as it leaned.
        (
            "tilted",
            Quat::from_axis_angle(Vec3::new(3.0, 0.0, 2.0).normalize(), 41f32.to_radians()),
        ),
    ];
    let mut bad = Vec::new();
    for (rel, want) in &HUMANOIDS {
        let c = load_data(rel);
        let standing = recognise_roles(&c);
        for (how, q) in turns {
            let lying = c.rotated(q);
            bad.extend(
                check_row(rel, want, &lying)
                    .into_iter()
                    .map(|b| format!("{b} ({how})")),
            );
            // A warning that names the facing (mirrored sides) names it in the file's
            // axes, where the lying body faces: the standing facing turned with it. (A
            // leaning figure is stood up by its own trunk and legs, which lean a few
            // degrees off the turn given here, so its facing is not checked to an axis.)
            let names_facing = standing
                .warning
                .as_deref()
                .is_some_and(|w| w.contains("faces "));
            if names_facing && how != "tilted" {
                let words = axis_words(q * standing.forward);
                let warning = recognise_roles(&lying).warning.unwrap_or_default();
                if !warning.contains(&format!("faces {words}")) {
                    bad.push(format!(
                        "{rel} ({how}): want \"faces {words}\" in {warning}"
                    ));
                }
            }
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

/// `d` as the warnings write a direction along an axis: `+Y`, `-Z`.
fn axis_words(d: Vec3) -> String {
    let axes = [(Vec3::X, "X"), (Vec3::Y, "Y"), (Vec3::Z, "Z")];
    let (axis, name) = axes
        .into_iter()
        .max_by(|a, b| d.dot(a.0).abs().total_cmp(&d.dot(b.0).abs()))
        .unwrap();
    format!("{}{name}", if d.dot(axis) > 0.0 { "+" } else { "-" })
}

/// A humanoid its file has lying down (on its back, face down, on its side, upside down)
/// or leaning (57°) gets the ragdoll it gets standing: the same roles, masses, body placements and joint
/// limits, all kept in its bones' frames. Before, every check read "up" as +Y, so a lying
/// figure failed them and was weighed as a creature by its volume.
#[test]
fn a_humanoid_lying_in_its_file_gets_the_ragdoll_it_gets_standing() {
    let (_, mixamo) = STYLES[0];
    let standing = renamed(&humanoid(), |n| {
        let (base, side) = split_side(n);
        mixamo(base, side)
    });
    let roles = recognise_roles(&standing);
    assert!(roles.humanoid && roles.upright.is_none(), "{}", roles.why);
    let spec = build_spec(&standing, &BuildOptions::default()).unwrap();
    let turns = [
        ("on its back", Quat::from_rotation_x(-FRAC_PI_2)),
        ("face down", Quat::from_rotation_x(FRAC_PI_2)),
        ("on its side", Quat::from_rotation_z(FRAC_PI_2)),
        ("upside down", Quat::from_rotation_z(PI)),
        // Recognised as it is, but leaning: its limits are measured stood up too.
        (
            "tilted",
            Quat::from_axis_angle(Vec3::new(1.0, 0.0, 1.0).normalize(), 1.0),
        ),
    ];
    for (how, q) in turns {
        let lying = standing.rotated(q);
        let got = recognise_roles(&lying);
        assert!(got.humanoid, "{how}: {}", got.why);
        assert!(got.why.contains("stood up"), "{how}: {}", got.why);
        assert_eq!(got.per_joint, roles.per_joint, "{how}");
        assert!(
            (got.height_m - roles.height_m).abs() < 1e-3,
            "{how}: height {} standing, {} lying",
            roles.height_m,
            got.height_m
        );
        let built = build_spec(&lying, &BuildOptions::default()).unwrap();
        let worst = spec_difference(&spec, &built);
        assert!(worst < 1e-3, "{how}: specs differ by up to {worst}");
    }
}

/// The quarter and half turns an exporter's axis swap gives a character, with what each
/// does to a figure standing facing +Z.
fn lying_turns() -> [(&'static str, Quat); 4] {
    [
        ("on its back", Quat::from_rotation_x(-FRAC_PI_2)),
        ("face down", Quat::from_rotation_x(FRAC_PI_2)),
        ("on its side", Quat::from_rotation_z(FRAC_PI_2)),
        ("upside down", Quat::from_rotation_z(PI)),
    ]
}

/// `c` with every name taken away: joints labelled by index, as CesiumMan's are.
fn unnamed(c: &Character) -> Character {
    let joints: Vec<Joint> = (c.skeleton.joints().iter().enumerate())
        .map(|(i, j)| Joint {
            name: format!("joint{i}"),
            ..j.clone()
        })
        .collect();
    Character {
        skeleton: Skeleton::new(joints).unwrap(),
        ..c.clone()
    }
}

/// A humanoid without names (found by the skeleton's shape alone) lying in its file gets
/// the ragdoll it gets standing, as a named one does: its shape is checked again turned
/// by each quarter or half turn, else by its longest axis, and the turn kept stands its
/// own trunk and legs up. Before, it was a creature weighed by its volume.
#[test]
fn an_unnamed_humanoid_lying_in_its_file_gets_the_ragdoll_it_gets_standing() {
    let standing = unnamed(&humanoid());
    let roles = recognise_roles(&standing);
    assert!(roles.humanoid, "{}", roles.why);
    assert!(roles.why.contains("skeleton's shape"), "{}", roles.why);
    let spec = build_spec(&standing, &BuildOptions::default()).unwrap();
    // Leaning a little (recognised as it is, then measured stood up) or a lot (stood up
    // by its longest axis, or by the nearest quarter turn and then by its own trunk and
    // legs).
    let tilts = [25f32, 35.0, 41.0, 57.0, 70.0, 110.0, 150.0].map(|deg| {
        let axis = Vec3::new(1.0, 0.0, 1.0).normalize();
        (
            Box::leak(format!("tilted {deg}°").into_boxed_str()) as &str,
            Quat::from_axis_angle(axis, deg.to_radians()),
        )
    });
    for (how, q) in lying_turns().into_iter().chain(tilts) {
        let lying = standing.rotated(q);
        let got = recognise_roles(&lying);
        assert!(got.humanoid, "{how}: {}", got.why);
        assert!(got.why.contains("stood up"), "{how}: {}", got.why);
        assert_eq!(got.per_joint, roles.per_joint, "{how}");
        let built = build_spec(&lying, &BuildOptions::default()).unwrap();
        let worst = spec_difference(&spec, &built);
        assert!(worst < 1e-3, "{how}: specs differ by up to {worst}");
    }
}

/// Creatures without names stay creatures however their file turns them: stood on end, a
/// dog's hind legs point along the ground and a bird's legs hang from a body stood up
/// behind them, so no turn gives two legs reaching the ground below a rising spine.
#[test]
fn an_unnamed_creature_is_not_stood_up_into_a_humanoid() {
    let mut dog: Vec<(String, Option<usize>, Vec3)> = vec![
        ("a".into(), None, Vec3::new(0.0, 0.5, -0.3)),
        ("b".into(), Some(0), Vec3::new(0.0, 0.52, 0.0)),
        ("c".into(), Some(1), Vec3::new(0.0, 0.52, 0.3)),
        ("d".into(), Some(2), Vec3::new(0.0, 0.7, 0.45)),
        ("e".into(), Some(0), Vec3::new(0.0, 0.5, -0.55)),
    ];
    let mut bird = vec![
        ("a".into(), None, Vec3::new(0.0, 0.3, 0.0)),
        ("b".into(), Some(0), Vec3::new(0.0, 0.33, 0.12)),
        ("c".into(), Some(1), Vec3::new(0.0, 0.45, 0.18)),
        ("d".into(), Some(2), Vec3::new(0.0, 0.5, 0.24)),
        ("e".into(), Some(0), Vec3::new(0.0, 0.3, -0.15)),
    ];
    for x in [0.08f32, -0.08] {
        let add = |rows: &mut Vec<(String, Option<usize>, Vec3)>, parent, p| {
            rows.push((format!("j{}", rows.len()), parent, p));
            rows.len() - 1
        };
        let thigh = add(&mut dog, Some(0), Vec3::new(x, 0.45, -0.3));
        let stifle = add(&mut dog, Some(thigh), Vec3::new(x, 0.28, -0.22));
        let paw = add(&mut dog, Some(stifle), Vec3::new(x, 0.12, -0.34));
        add(&mut dog, Some(paw), Vec3::new(x, 0.0, -0.32));
        let shoulder = add(&mut dog, Some(2), Vec3::new(x, 0.45, 0.3));
        let elbow = add(&mut dog, Some(shoulder), Vec3::new(x, 0.25, 0.24));
        add(&mut dog, Some(elbow), Vec3::new(x, 0.0, 0.28));
        let hip = add(&mut bird, Some(0), Vec3::new(x, 0.28, 0.0));
        let knee = add(&mut bird, Some(hip), Vec3::new(x, 0.18, 0.04));
        add(&mut bird, Some(knee), Vec3::new(x, 0.0, 0.0));
        let wing = add(&mut bird, Some(1), Vec3::new(x, 0.35, 0.12));
        let elbow = add(&mut bird, Some(wing), Vec3::new(x * 4.0, 0.36, 0.1));
        add(&mut bird, Some(elbow), Vec3::new(x * 8.0, 0.37, 0.05));
    }
    let creatures = [
        common::character_from_rows("dog", &dog),
        common::character_from_rows("bird", &bird),
    ];
    for c in &creatures {
        let turns = std::iter::once(("as made", Quat::IDENTITY)).chain(lying_turns());
        for (how, q) in turns {
            let roles = recognise_roles(&c.rotated(q));
            let name = &c.skeleton.joints()[0].name;
            assert!(!roles.humanoid, "{name} {how}: {}", roles.why);
        }
    }
}

/// A hunched figure (the trunk bent 25° forward at the spine over straight legs) stands as
/// it was made: it is not turned, so its legs keep their cones about the vertical.
#[test]
fn a_hunched_humanoid_is_not_stood_up() {
    let (_, mixamo) = STYLES[0];
    let plain = humanoid();
    let mut c = renamed(&plain, |n| {
        let (base, side) = split_side(n);
        mixamo(base, side)
    });
    let mut joints = c.skeleton.joints().to_vec();
    let spine = plain
        .skeleton
        .joints()
        .iter()
        .position(|j| j.name == "spine")
        .unwrap();
    joints[spine].rest.rotation = Quat::from_rotation_x(25f32.to_radians());
    c.skeleton = Skeleton::new(joints).unwrap();
    let roles = recognise_roles(&c);
    assert!(roles.humanoid, "{}", roles.why);
    assert_eq!(roles.upright, None, "{}", roles.why);
}

/// The largest difference between two specs of the same skeleton: masses (kg), body
/// placements and joint anchors (m), rotations (1 − |cos| of half the angle between,
/// so a quaternion and its negative agree), shape sizes and limits (m, degrees).
fn spec_difference(a: &RagdollSpec, b: &RagdollSpec) -> f32 {
    assert_eq!(a.bodies.len(), b.bodies.len());
    assert_eq!(a.joints.len(), b.joints.len());
    let far = |x: &[f32], y: &[f32]| {
        x.iter()
            .zip(y)
            .map(|(p, q)| (p - q).abs())
            .fold(0.0f32, f32::max)
    };
    let turn = |x: [f32; 4], y: [f32; 4]| 1.0 - Quat::from_array(x).dot(Quat::from_array(y)).abs();
    let numbers = |d: String| -> Vec<f32> {
        d.split(|c: char| !(c.is_ascii_digit() || matches!(c, '.' | '-' | 'e')))
            .filter_map(|w| w.parse().ok())
            .collect()
    };
    let mut worst = 0.0f32;
    for (x, y) in a.bodies.iter().zip(&b.bodies) {
        assert_eq!((&x.name, &x.bone), (&y.name, &y.bone));
        worst = worst
            .max((x.mass_kg - y.mass_kg).abs())
            .max(far(&x.center_m, &y.center_m))
            .max(turn(x.rotation, y.rotation))
            .max(far(
                &numbers(format!("{:?}", x.shape)),
                &numbers(format!("{:?}", y.shape)),
            ));
    }
    for (x, y) in a.joints.iter().zip(&b.joints) {
        assert_eq!((&x.parent, &x.child), (&y.parent, &y.child));
        worst = worst
            .max(far(&x.anchor_m, &y.anchor_m))
            .max(turn(x.frame, y.frame))
            .max(far(
                &numbers(format!("{:?}", x.kind)),
                &numbers(format!("{:?}", y.kind)),
            ));
    }
    worst
}

/// Knees and elbows hinge by the facing, and the builder widens a hinge that the first
/// animation frame lies outside of. A facing turned the wrong way shows as a knee bent the
/// anatomical way in that frame read as bent backwards, and widened to hold it (Robi's
/// left knee was widened to bend 117° backwards when its mirrored names set the facing).
/// So on every humanoid file, each hinge spans no more than its anatomical range (0-140°
/// for knees, 0-145° for elbows, shifted by the rest pose's bend) plus 10° of slack for a
/// rest pose a little past straight.
#[test]
#[ignore = "needs ../shared/data"]
fn knees_and_elbows_of_real_rigs_need_no_widening_to_hold_their_first_frame() {
    const ANATOMICAL_SPAN_DEG: [(&str, f32); 2] = [("shin", 140.0), ("forearm", 145.0)];
    let mut bad = Vec::new();
    for (rel, _) in &HUMANOIDS {
        let spec = build_spec(&load_data(rel), &BuildOptions::default()).unwrap();
        for j in &spec.joints {
            let ragdoll::spec::JointKind::Hinge { min_deg, max_deg } = j.kind else {
                continue;
            };
            let Some(&(_, span)) = ANATOMICAL_SPAN_DEG
                .iter()
                .find(|(part, _)| j.name.starts_with(part))
            else {
                continue;
            };
            if max_deg - min_deg > span + 10.0 {
                bad.push(format!(
                    "{rel}: {} hinge {min_deg:.0}..{max_deg:.0}°",
                    j.name
                ));
            }
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

#[test]
#[ignore = "needs ../shared/data"]
fn other_files_are_not_humanoids() {
    for rel in OTHERS {
        let roles = recognise_roles(&load_data(rel));
        assert!(!roles.humanoid, "{rel}");
        assert!(
            roles.why.starts_with("Not a humanoid"),
            "{rel}: {}",
            roles.why
        );
    }
}

/// The IK controls, poles and sockets of real rigs carry no body, and every spec builds.
#[test]
#[ignore = "needs ../shared/data"]
fn helper_bones_get_no_body() {
    for (rel, helpers) in [
        (
            "rigs/godot_robi_ik.glb",
            &[
                "MASTER",
                "HEAD",
                "l-LEGCONTROL",
                "r-ARMORIENT",
                "headtracker",
            ][..],
        ),
        (
            "rigs/quaternius_um_orc_ikfeet.gltf",
            &["PoleTarget.L", "PoleTarget.R", "Root"][..],
        ),
        ("rigs/kaykit_knight.glb", &["handslot.l", "handslot.r"][..]),
    ] {
        let c = load_data(rel);
        let roles = recognise_roles(&c);
        for h in helpers {
            let j = c
                .skeleton
                .find(h)
                .unwrap_or_else(|| panic!("{rel}: no {h}"));
            assert_eq!(roles.per_joint[j], None, "{rel}: {h}");
        }
        let spec = build_spec(&c, &BuildOptions::default()).unwrap();
        assert!(
            spec.bodies
                .iter()
                .all(|b| !helpers.contains(&b.bone.as_str()))
        );
    }
}

/// Quaternius's feet hang from the root bone, beside the legs: each still joins its shin.
#[test]
#[ignore = "needs ../shared/data"]
fn detached_ik_feet_join_their_shins() {
    let c = load_data("rigs/quaternius_um_orc_ikfeet.gltf");
    let spec = build_spec(&c, &BuildOptions::default()).unwrap();
    for (foot, shin) in [("foot_l", "shin_l"), ("foot_r", "shin_r")] {
        let j = spec.joints.iter().find(|j| j.child == foot).unwrap();
        assert_eq!(j.parent, shin);
    }
}

/// The built-in humanoid with joints named `j0`, `j1`… and a VRM humanoid table.
fn with_table(table: &[(&str, &str)]) -> Character {
    let mut c = humanoid();
    let names: Vec<String> = c.skeleton.joints().iter().map(|j| j.name.clone()).collect();
    let joints: Vec<Joint> = c
        .skeleton
        .joints()
        .iter()
        .enumerate()
        .map(|(i, j)| Joint {
            name: format!("j{i}"),
            ..j.clone()
        })
        .collect();
    c.skeleton = Skeleton::new(joints).unwrap();
    c.humanoid_bones = table
        .iter()
        .map(|(vrm, ours)| {
            let j = names.iter().position(|n| n == ours).unwrap();
            (vrm.to_string(), j)
        })
        .collect();
    c
}

const VRM_TABLE: [(&str, &str); 15] = [
    ("hips", "pelvis"),
    ("spine", "spine"),
    ("chest", "chest"),
    ("neck", "neck"),
    ("head", "head"),
    ("leftUpperLeg", "thigh_l"),
    ("leftLowerLeg", "shin_l"),
    ("leftFoot", "foot_l"),
    ("rightUpperLeg", "thigh_r"),
    ("rightLowerLeg", "shin_r"),
    ("rightFoot", "foot_r"),
    ("leftUpperArm", "upper_arm_l"),
    ("leftLowerArm", "forearm_l"),
    ("rightUpperArm", "upper_arm_r"),
    ("rightLowerArm", "forearm_r"),
];

#[test]
fn a_humanoid_bone_table_gives_the_roles() {
    let c = with_table(&VRM_TABLE);
    let roles = recognise_roles(&c);
    assert!(roles.humanoid, "{}", roles.why);
    assert!(roles.why.contains("bone table"), "{}", roles.why);
    let plain = humanoid();
    for (vrm, ours) in VRM_TABLE {
        let j = plain.skeleton.find(ours).unwrap();
        assert_eq!(
            roles.per_joint[j].map(Role::as_str),
            Some(ours),
            "{vrm} → {ours}"
        );
    }
    // The table leaves the hands out: no joint is a hand, and the report says so.
    assert_eq!(roles.joint(Role::HandL), None);
    assert!(roles.missing().iter().any(|(r, _)| *r == Role::HandL));
    assert!(
        (roles.forward - Vec3::Z).length() < 1e-4,
        "{:?}",
        roles.forward
    );
}

/// Whether flexing each knee of the ragdoll built from `c` (a positive hinge angle) swings
/// the shin away from where its toes point, as a knee bends; read from the built joints'
/// frames and the skeleton, not from the roles' facing.
fn knees_bend_back(c: &Character) -> bool {
    let roles = recognise_roles(c);
    let spec = build_spec(c, &BuildOptions::default()).unwrap();
    let world = c.skeleton.rest_world();
    [(Role::ShinL, Role::FootL), (Role::ShinR, Role::FootR)]
        .iter()
        .all(|&(shin, foot)| {
            let (k, f) = (roles.joint(shin).unwrap(), roles.joint(foot).unwrap());
            let joint = spec
                .joints
                .iter()
                .find(|j| j.name == shin.as_str())
                .unwrap();
            let axis = world[k].rotation * Quat::from_array(joint.frame) * Vec3::X;
            let shin_dir = (world[f].translation - world[k].translation).normalize();
            let tip = c.skeleton.joints()[f]
                .tip
                .expect("the humanoid's feet have toes");
            let toes = world[f].transform_point(tip) - world[f].translation;
            axis.cross(shin_dir).dot(Vec3::new(toes.x, 0.0, toes.z)) < 0.0
        })
}

#[test]
fn a_table_that_swaps_the_sides_keeps_its_sides_and_the_knees_bend_back() {
    // A table calling the +X leg and arm "right" on a body whose toes point +Z: the roles
    // follow the table, the facing follows the body (knees and elbows hinge by it), and
    // the user is told the sides look mirrored.
    let swapped: Vec<(&str, &str)> = VRM_TABLE
        .iter()
        .map(|&(vrm, ours)| {
            let vrm = match vrm.strip_prefix("left") {
                Some(rest) => Box::leak(format!("right{rest}").into_boxed_str()) as &str,
                None => match vrm.strip_prefix("right") {
                    Some(rest) => Box::leak(format!("left{rest}").into_boxed_str()) as &str,
                    None => vrm,
                },
            };
            (vrm, ours)
        })
        .collect();
    let c = with_table(&swapped);
    let roles = recognise_roles(&c);
    assert!(roles.humanoid, "{}", roles.why);
    let plain = humanoid();
    assert_eq!(
        roles.per_joint[plain.skeleton.find("thigh_l").unwrap()],
        Some(Role::ThighR)
    );
    assert!(
        (roles.forward - Vec3::Z).length() < 1e-4,
        "{:?}",
        roles.forward
    );
    let warning = roles.warning.as_deref().unwrap_or("");
    assert!(warning.contains("mirrored"), "{warning:?}");
    assert!(knees_bend_back(&c));
    assert!(knees_bend_back(&with_table(&VRM_TABLE)));
}

#[test]
fn a_table_the_skeleton_contradicts_is_overruled() {
    // Legs mapped onto the arms: knees not below hips. The names (`j0`…) say nothing, so
    // the structure pass finds the humanoid instead.
    let mut table = VRM_TABLE.to_vec();
    for (vrm, ours) in &mut table {
        *ours = match *vrm {
            "leftUpperLeg" => "upper_arm_l",
            "leftLowerLeg" => "forearm_l",
            "rightUpperLeg" => "upper_arm_r",
            "rightLowerLeg" => "forearm_r",
            _ => ours,
        };
    }
    let c = with_table(&table);
    let roles = recognise_roles(&c);
    assert!(roles.humanoid);
    assert!(roles.why.contains("shape"), "{}", roles.why);
    // Set aside, but not in silence: the file claimed to know better.
    let warning = roles.warning.as_deref().unwrap_or("");
    assert!(
        warning.starts_with("the file's humanoid bone table does not hold")
            && warning.ends_with("the table is not used"),
        "{warning:?}"
    );
    // A table that holds gives no such warning.
    assert!(recognise_roles(&with_table(&VRM_TABLE)).warning.is_none());
    let plain = humanoid();
    assert_eq!(
        roles.per_joint[plain.skeleton.find("thigh_l").unwrap()],
        Some(Role::ThighL)
    );
}

#[test]
fn a_foot_hung_from_the_pelvis_is_still_the_foot_and_joins_the_shin() {
    let c = common::humanoid_with_detached_foot();
    let roles = recognise_roles(&c);
    assert!(roles.humanoid, "{}", roles.why);
    let foot = c.skeleton.find("foot_l").unwrap();
    assert_eq!(roles.per_joint[foot], Some(Role::FootL));
    let spec = build_spec(&c, &BuildOptions::default()).unwrap();
    let j = spec.joints.iter().find(|j| j.child == "foot_l").unwrap();
    assert_eq!(j.parent, "shin_l");
    // Every body but the root has exactly one joint: one connected ragdoll.
    assert_eq!(spec.joints.len() + 1, spec.bodies.len());
}

/// The built-in humanoid's joints (named by role) renamed by `style`: a rig in that naming
/// style with a known answer.
fn renamed(c: &Character, style: impl Fn(&str) -> String) -> Character {
    let joints: Vec<Joint> = c
        .skeleton
        .joints()
        .iter()
        .map(|j| Joint {
            name: style(&j.name),
            ..j.clone()
        })
        .collect();
    Character {
        skeleton: Skeleton::new(joints).unwrap(),
        ..c.clone()
    }
}

/// `thigh_l` → (`thigh`, Some(true)); `pelvis` → (`pelvis`, None).
fn split_side(role: &str) -> (&str, Option<bool>) {
    match (role.strip_suffix("_l"), role.strip_suffix("_r")) {
        (Some(base), _) => (base, Some(true)),
        (_, Some(base)) => (base, Some(false)),
        _ => (role, None),
    }
}

/// One naming style: the name of each of our roles, given (role base, left?).
type Style = fn(&str, Option<bool>) -> String;

const STYLES: [(&str, Style); 8] = [
    ("Mixamo", |base, side| {
        let word = match base {
            "pelvis" => "Hips",
            "spine" => "Spine",
            "chest" => "Spine2",
            "neck" => "Neck",
            "head" => "Head",
            "thigh" => "UpLeg",
            "shin" => "Leg",
            "foot" => "Foot",
            "upper_arm" => "Arm",
            "forearm" => "ForeArm",
            _ => "Hand",
        };
        let side = match side {
            Some(true) => "Left",
            Some(false) => "Right",
            None => "",
        };
        format!("mixamorig5:{side}{word}")
    }),
    ("Unreal", |base, side| {
        let word = match base {
            "spine" => "spine_01",
            "chest" => "spine_03",
            "neck" => "neck_01",
            "shin" => "calf",
            "upper_arm" => "upperarm",
            "forearm" => "lowerarm",
            other => other,
        };
        match side {
            Some(true) => format!("{word}_l"),
            Some(false) => format!("{word}_r"),
            None => word.to_string(),
        }
    }),
    ("Godot", |base, side| {
        let word = match base {
            "shin" => "calf",
            "upper_arm" => "upperarm",
            "forearm" => "lowerarm",
            other => other,
        };
        match side {
            Some(true) => format!("{word}.l"),
            Some(false) => format!("{word}.r"),
            None => word.to_string(),
        }
    }),
    ("Rigify", |base, side| {
        let word = match base {
            "pelvis" => "spine",
            "spine" => "spine.001",
            "chest" => "spine.003",
            "neck" => "spine.004",
            "head" => "spine.005",
            other => other,
        };
        match side {
            Some(true) => format!("DEF-{word}.L"),
            Some(false) => format!("DEF-{word}.R"),
            None => format!("DEF-{word}"),
        }
    }),
    ("KayKit", |base, side| {
        let word = match base {
            "pelvis" => "hips",
            "thigh" => "upperleg",
            "shin" => "lowerleg",
            "upper_arm" => "upperarm",
            "forearm" => "lowerarm",
            "hand" => "wrist",
            other => other,
        };
        match side {
            Some(true) => format!("{word}.l"),
            Some(false) => format!("{word}.r"),
            None => word.to_string(),
        }
    }),
    ("l-/r- prefixes", |base, side| {
        let word = match base {
            "pelvis" => "hip",
            "shin" => "leg",
            "upper_arm" => "arm",
            other => other,
        };
        match side {
            Some(true) => format!("l-{word}"),
            Some(false) => format!("r-{word}"),
            None => word.to_string(),
        }
    }),
    ("VRoid", |base, side| {
        let word = match base {
            "pelvis" => "Hips",
            "spine" => "Spine",
            "chest" => "Chest",
            "neck" => "Neck",
            "head" => "Head",
            "thigh" => "UpperLeg",
            "shin" => "LowerLeg",
            "foot" => "Foot",
            "upper_arm" => "UpperArm",
            "forearm" => "LowerArm",
            _ => "Hand",
        };
        let side = match side {
            Some(true) => "L",
            Some(false) => "R",
            None => "C",
        };
        format!("J_Bip_{side}_{word}")
    }),
    ("Quaternius", |base, side| {
        let word = match base {
            "pelvis" => "Hips",
            "spine" => "Abdomen",
            "chest" => "Torso",
            "neck" => "Neck",
            "head" => "Head",
            "thigh" => "UpperLeg",
            "shin" => "LowerLeg",
            "foot" => "Foot",
            "upper_arm" => "UpperArm",
            "forearm" => "LowerArm",
            _ => "Fist",
        };
        match side {
            Some(true) => format!("{word}.L"),
            Some(false) => format!("{word}.R"),
            None => word.to_string(),
        }
    }),
];

/// Rigs in each naming style get every role on the joint it names, whichever way they
/// face, and the roles come from the names.
#[test]
fn every_naming_style_gets_its_roles() {
    let plain = humanoid();
    for (label, style) in STYLES {
        let c = renamed(&plain, |n| {
            let (base, side) = split_side(n);
            style(base, side)
        });
        for k in [0, 3, 6] {
            let cy = c.turned((k as f32 * 45.0).to_radians());
            let roles = recognise_roles(&cy);
            assert!(roles.why.contains("joint names"), "{label}: {}", roles.why);
            for (i, j) in plain.skeleton.joints().iter().enumerate() {
                assert_eq!(
                    roles.per_joint[i].map(Role::as_str),
                    Some(j.name.as_str()),
                    "{label} at yaw {}: {}",
                    k * 45,
                    c.skeleton.joints()[i].name
                );
            }
        }
    }
}

/// A skeleton whose feet point to -Z but whose names say `.L` on +X (the built-in humanoid
/// mirrored front to back, as a rig named from the viewer's side is): the names decide
/// the sides, so `.L` joints stay left; the body decides the facing, so its knees bend
/// away from its toes, not forward.
#[test]
fn names_decide_the_sides_and_the_body_the_facing_when_the_feet_point_back() {
    let plain = humanoid();
    let blender = renamed(&plain, |n| match split_side(n) {
        (base, Some(true)) => format!("{base}.L"),
        (base, Some(false)) => format!("{base}.R"),
        (base, None) => base.to_string(),
    });
    let mut joints = blender.skeleton.joints().to_vec();
    for j in &mut joints {
        assert!(j.rest.rotation.abs_diff_eq(glam::Quat::IDENTITY, 1e-6));
        j.rest.translation.z = -j.rest.translation.z;
        if let Some(t) = &mut j.tip {
            t.z = -t.z;
        }
    }
    let mech = Character {
        skeleton: Skeleton::new(joints).unwrap(),
        ..blender.clone()
    };
    let roles = recognise_roles(&mech);
    for (i, j) in plain.skeleton.joints().iter().enumerate() {
        assert_eq!(roles.per_joint[i].map(Role::as_str), Some(j.name.as_str()));
    }
    assert!(
        (roles.forward + Vec3::Z).length() < 1e-4,
        "{:?}",
        roles.forward
    );
    assert!(roles.warning.is_some_and(|w| w.contains("mirrored")));
    assert!(knees_bend_back(&mech));
    assert!(knees_bend_back(&blender));
}

/// Hostile names: a chain as deep as a skeleton may be (65,536 joints), every joint named
/// a left or right shin with no thigh above any: a walk up the chain from each candidate
/// looking for its thigh would take two billion steps; recognition stays linear.
#[test]
fn a_deep_chain_of_limb_names_is_read_in_linear_time() {
    let n = ragdoll::skeleton::MAX_JOINTS;
    let words = ["l-leg", "r-leg"];
    let joints: Vec<Joint> = (0..n)
        .map(|i| Joint {
            name: words[i % words.len()].to_string(),
            parent: i.checked_sub(1),
            rest: ragdoll::math::Transform::from_translation(Vec3::new(0.0, -0.01, 0.001)),
            tip: None,
        })
        .collect();
    let c = Character {
        skeleton: Skeleton::new(joints).unwrap(),
        ..humanoid()
    };
    let t = std::time::Instant::now();
    let roles = recognise_roles(&c);
    // Linear work takes milliseconds; the quadratic walk took seconds.
    assert!(t.elapsed().as_secs_f32() < 2.0, "{:?}", t.elapsed());
    assert!(!roles.humanoid);
}

/// Names that promise a humanoid on a skeleton that is not one (its shins and feet raised
/// above its hips, as no figure standing or lying has them) give a warning that says which
/// check failed; honest names on a creature give none.
#[test]
fn names_that_promise_a_humanoid_the_skeleton_denies_give_a_warning() {
    let plain = humanoid();
    let mut flat = plain.clone();
    let mut joints = plain.skeleton.joints().to_vec();
    for j in joints
        .iter_mut()
        .filter(|j| j.name.starts_with("shin") || j.name.starts_with("foot"))
    {
        // The legs folded up at the hips: the knees rise above them.
        j.rest.translation.y = -j.rest.translation.y;
        j.tip = j.tip.map(|t| Vec3::new(t.x, -t.y, t.z));
    }
    flat.skeleton = Skeleton::new(joints).unwrap();
    let roles = recognise_roles(&flat);
    assert!(!roles.humanoid);
    let w = roles.warning.expect("a warning");
    assert!(w.contains("joint names"), "{w}");
    assert!(w.contains("knee"), "{w}");
    let chain = renamed(&plain, |n| format!("link_{}", n.len()));
    let roles = recognise_roles(&chain);
    assert_eq!(roles.warning, None, "{}", roles.why);
}

/// A humanoid outside the heights people stand at is warned about, naming its height: it
/// is far more likely read in the wrong units.
#[test]
fn a_humanoid_of_implausible_height_is_warned_about() {
    use ragdoll::import::humanoid_of_height;
    for (h, warned) in [
        (1.75, false),
        (0.45, false),
        (2.9, false),
        (5.6, true),
        (0.2, true),
    ] {
        let c = humanoid_of_height(h).unwrap();
        let roles = recognise_roles(&c);
        assert!(roles.humanoid, "{h} m: {}", roles.why);
        match (&roles.warning, warned) {
            (None, false) => {}
            (Some(w), true) => {
                let shown = format!("{:.2} m tall", roles.height_m);
                assert!(w.contains(&shown) && w.contains("--units"), "{h} m: {w}");
            }
            (w, _) => panic!("{h} m: warning {w:?}"),
        }
    }
}
