//! Physics facts the rigid backend must reproduce (DESIGN §8): not "it did not crash".

use glam::{Quat, Vec3};
use ragdoll::math::Transform;
use ragdoll::skeleton::{Character, Joint, Skeleton, Source};
use ragdoll::spec::{BodySpec, JointKind, JointSpec, RagdollSpec, SPEC_FORMAT_VERSION, Shape};
use ragdoll::world::{STANDARD_GRAVITY, World, WorldSettings};

/// A one-joint skeleton with the joint at `height`.
fn single_joint(height: f32) -> Character {
    Character {
        name: "stick".into(),
        skeleton: Skeleton::new(vec![Joint {
            name: "root".into(),
            parent: None,
            rest: Transform::from_translation(Vec3::new(0.0, height, 0.0)),
            tip: None,
        }])
        .unwrap(),
        meshes: vec![],
        clips: vec![],
        source: Source::BuiltIn,
    }
}

fn capsule_body(name: &str, bone: &str, center: [f32; 3]) -> BodySpec {
    BodySpec {
        name: name.into(),
        bone: bone.into(),
        role: None,
        shape: Shape::Capsule {
            radius_m: 0.05,
            length_m: 0.4,
        },
        center_m: center,
        rotation: [0.0, 0.0, 0.0, 1.0],
        mass_kg: 2.0,
    }
}

#[test]
fn free_body_falls_as_half_g_t_squared() {
    let character = single_joint(100.0);
    let spec = RagdollSpec {
        format_version: SPEC_FORMAT_VERSION,
        name: "stick".into(),
        bodies: vec![capsule_body("stick", "root", [0.0, 0.0, 0.0])],
        joints: vec![],
        collision: Default::default(),
    };
    let settings = WorldSettings {
        ground: None,
        ..Default::default()
    };
    let (mut world, id) = World::with_ragdoll(&character, &spec, &settings).unwrap();
    let seconds = 2.0;
    world.run(seconds);
    let y = world.body_poses(id)[0].translation.y;
    let expected = 100.0 - 0.5 * STANDARD_GRAVITY * seconds * seconds;
    let fallen = 100.0 - y;
    let want = 100.0 - expected;
    assert!(
        ((fallen - want) / want).abs() < 1e-3,
        "fell {fallen} m in {seconds} s, theory {want} m"
    );
    // The track follows the body: the joint sits at the body centre.
    let track = world.into_track();
    assert_eq!(track.frames.len(), 61);
    let last = track.frames.last().unwrap()[0].translation.y;
    assert!((last - y).abs() < 1e-4);
}

#[test]
fn hinge_limit_holds_and_is_measured_small() {
    // A link hinged to a heavy block, limited to [0, 30]°: released horizontal, it must
    // stop at the limit, not swing down past it.
    let skeleton = Skeleton::new(vec![
        Joint {
            name: "root".into(),
            parent: None,
            rest: Transform::from_translation(Vec3::new(0.0, 0.5, 0.0)),
            tip: None,
        },
        Joint {
            name: "link".into(),
            parent: Some(0),
            rest: Transform::from_translation(Vec3::new(1.0, 0.0, 0.0)),
            tip: Some(Vec3::new(0.5, 0.0, 0.0)),
        },
    ])
    .unwrap();
    let character = Character {
        name: "pendulum".into(),
        skeleton,
        meshes: vec![],
        clips: vec![],
        source: Source::BuiltIn,
    };
    // A heavy, wide block standing on the ground; the link hangs off its top edge.
    let root = BodySpec {
        shape: Shape::Box {
            size_m: [2.0, 0.5, 2.0],
        },
        mass_kg: 1000.0,
        ..capsule_body("root", "root", [0.0, -0.25, 0.0])
    };
    let link = BodySpec {
        rotation: Quat::from_rotation_z(-std::f32::consts::FRAC_PI_2).to_array(),
        ..capsule_body("link", "link", [0.25, 0.0, 0.0])
    };
    let spec = RagdollSpec {
        format_version: SPEC_FORMAT_VERSION,
        name: "pendulum".into(),
        bodies: vec![root, link],
        joints: vec![JointSpec {
            name: "link".into(),
            parent: "root".into(),
            child: "link".into(),
            anchor_m: [0.0; 3],
            // Hinge axis along Z: gravity turns the link (along +X) toward −Y, a negative
            // rotation about +Z, so flexion toward −Y is positive about −Z.
            frame: Quat::from_rotation_y(std::f32::consts::FRAC_PI_2).to_array(),
            kind: JointKind::Hinge {
                min_deg: 0.0,
                max_deg: 30.0,
            },
        }],
        collision: Default::default(),
    };
    spec.validate().unwrap();
    let (mut world, id) =
        World::with_ragdoll(&character, &spec, &WorldSettings::default()).unwrap();
    world.run(1.0);
    let poses = world.body_poses(id);
    // The link's long axis (its local Y) relative to the root.
    let rel = poses[0].rotation.conjugate() * poses[1].rotation;
    let dir = rel * Vec3::Y;
    let below_deg = (-dir.y).atan2(dir.x).to_degrees();
    // Without the limit it would hang straight down (90°); the hinge stops it at 30°.
    assert!(
        (below_deg - 30.0).abs() < 2.0,
        "link is {below_deg}° below horizontal"
    );
    let m = world.metrics();
    assert!(!m.nan);
    assert!(m.max_joint_separation_m < 5e-3, "{m:?}");
    assert!(m.max_limit_violation_deg < 2.0, "{m:?}");
}

/// Lowest point of every body (capsule or box) above the ground, metres.
fn lowest_body_point(spec: &RagdollSpec, poses: &[Transform]) -> f32 {
    spec.bodies
        .iter()
        .zip(poses)
        .map(|(b, p)| match b.shape {
            Shape::Capsule { radius_m, length_m } => {
                p.translation.y - (p.rotation * Vec3::Y).y.abs() * 0.5 * length_m - radius_m
            }
            Shape::Box { size_m } => {
                let h = Vec3::from_array(size_m) * 0.5;
                let r = glam::Mat3::from_quat(p.rotation);
                let reach = (r.row(1).abs()).dot(h);
                p.translation.y - reach
            }
        })
        .fold(f32::INFINITY, f32::min)
}

#[test]
fn humanoid_released_standing_ends_lying_at_rest_above_the_ground() {
    use ragdoll::spec::{BuildOptions, build_spec};
    let character = ragdoll::skeleton::humanoid();
    let spec = build_spec(&character, &BuildOptions::default()).unwrap();
    let (mut world, id) =
        World::with_ragdoll(&character, &spec, &WorldSettings::default()).unwrap();
    let standing_head = {
        let head = spec.body_index("head").unwrap();
        world.run(0.0);
        world.body_poses(id)[head].translation.y
    };
    let mut lowest = f32::INFINITY;
    for _ in 0..(6 * 60) {
        world.step();
        lowest = lowest.min(lowest_body_point(&spec, &world.body_poses(id)));
    }
    let poses = world.body_poses(id);
    let head = poses[spec.body_index("head").unwrap()].translation.y;
    let pelvis = poses[spec.body_index("pelvis").unwrap()].translation.y;
    assert!(lowest > -0.01, "a body went {lowest} m below the ground");
    assert!(
        standing_head > 1.4,
        "started with the head at {standing_head} m"
    );
    assert!(
        head < 0.45 && pelvis < 0.45,
        "not lying: head {head} m, pelvis {pelvis} m"
    );
    // At rest: the last second moved every body by less than a centimetre.
    let before = world.body_poses(id);
    world.run(1.0);
    let after = world.body_poses(id);
    for (a, b) in before.iter().zip(&after) {
        assert!(
            (a.translation - b.translation).length() < 0.01,
            "still moving"
        );
    }
    let m = world.metrics();
    assert!(!m.nan);
    assert!(m.max_limit_violation_deg <= 2.0, "{m:?}");
    assert!(m.max_penetration_m <= 0.03, "{m:?}");
    assert!(m.max_joint_separation_m <= 0.005, "{m:?}");
    assert!(m.energy_drift < 0.01, "{m:?}");
}
