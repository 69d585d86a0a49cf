//! Physics facts the rigid backend must reproduce: not "it did not crash".

use glam::{Quat, Vec3};
use ragdoll::math::Transform;
use ragdoll::skeleton::{Character, Joint, Skeleton, Source};
use ragdoll::spec::{BodySpec, JointKind, JointSpec, RagdollSpec, SPEC_FORMAT_VERSION, Shape};
use ragdoll::world::{STANDARD_GRAVITY, World, WorldSettings};

/// A one-joint skeleton with the joint at `height`.
fn single_joint(height: f32) -> Character {
    Character {
        humanoid_bones: Vec::new(),
        warnings: Vec::new(),
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
        extra_shapes: Vec::new(),
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

/// A link hanging off the top edge of a heavy block on the ground, joined by `kind` with
/// the given joint frame, released horizontal (along +X). Returns how far below
/// horizontal it ends after a second, in degrees, and the metrics.
fn drop_link(kind: JointKind, frame: Quat) -> (f32, ragdoll::track::Metrics) {
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
        humanoid_bones: Vec::new(),
        warnings: Vec::new(),
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
            frame: frame.to_array(),
            kind,
        }],
        collision: Default::default(),
    };
    spec.validate().unwrap();
    let (mut world, id) =
        World::with_ragdoll(&character, &spec, &WorldSettings::default()).unwrap();
    world.run(1.0);
    let poses = world.body_poses(id);
    // The link's long axis (its local Y) relative to the root.
    let dir = (poses[0].rotation.conjugate() * poses[1].rotation) * Vec3::Y;
    ((-dir.y).atan2(dir.x).to_degrees(), world.metrics())
}

#[test]
fn hinge_limit_holds_and_is_measured_small() {
    // Hinge axis along −Z: gravity turns the link (along +X) toward −Y, a negative rotation
    // about +Z, so the fall is a positive angle about the frame's X. Limited to [0, 30]°,
    // it must stop at 30° instead of hanging straight down (90°).
    let frame = Quat::from_rotation_y(std::f32::consts::FRAC_PI_2);
    let kind = JointKind::Hinge {
        min_deg: 0.0,
        max_deg: 30.0,
    };
    let (below_deg, m) = drop_link(kind, frame);
    assert!(
        (below_deg - 30.0).abs() < 2.0,
        "link is {below_deg}° below horizontal"
    );
    assert!(!m.nan);
    assert!(m.max_joint_separation_m < 5e-3, "{m:?}");
    assert!(m.max_limit_violation_deg < 2.0, "{m:?}");
}

#[test]
fn swing_cone_holds_and_its_tilt_moves_the_stop() {
    // Twist axis along the link (+X), a 30° cone around the rest direction: the link must
    // stop 30° below horizontal.
    let kind = JointKind::SwingTwist {
        swing_deg: 30.0,
        twist_deg: [-10.0, 10.0],
        cone_tilt_deg: [0.0, 0.0],
    };
    let (below_deg, m) = drop_link(kind, Quat::IDENTITY);
    assert!(
        (below_deg - 30.0).abs() < 2.0,
        "link is {below_deg}° below horizontal"
    );
    assert!(m.max_limit_violation_deg < 2.0, "{m:?}");
    // The same cone turned 20° about the frame's Z (toward −Y): the stop moves to 50°.
    let kind = JointKind::SwingTwist {
        swing_deg: 30.0,
        twist_deg: [-10.0, 10.0],
        cone_tilt_deg: [0.0, -20.0],
    };
    let (below_deg, m) = drop_link(kind, Quat::IDENTITY);
    assert!(
        (below_deg - 50.0).abs() < 2.0,
        "link is {below_deg}° below horizontal"
    );
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
    for ((a, b), body) in before.iter().zip(&after).zip(&spec.bodies) {
        let moved = (a.translation - b.translation).length();
        assert!(
            moved < 0.01,
            "{} still moving: {moved} m in the last second",
            body.name
        );
    }
    let m = world.metrics();
    assert!(!m.nan);
    assert!(m.max_limit_violation_deg <= 2.0, "{m:?}");
    assert!(m.max_penetration_m <= 0.03, "{m:?}");
    assert!(m.max_joint_separation_m <= 0.005, "{m:?}");
    assert!(m.energy_drift < 0.01, "{m:?}");
}

/// A world can be asked where its bodies are before it has stepped: the start pose.
#[test]
fn body_poses_are_readable_before_the_first_step() {
    let c = ragdoll::skeleton::humanoid();
    let spec = ragdoll::spec::build_spec(&c, &ragdoll::spec::BuildOptions::default()).unwrap();
    let (world, id) =
        ragdoll::world::World::with_ragdoll(&c, &spec, &ragdoll::world::WorldSettings::default())
            .unwrap();
    let poses = world.body_poses(id);
    assert_eq!(poses.len(), spec.bodies.len());
    // Standing: the head is the highest body, well above the pelvis.
    let head = spec.body_index("head").unwrap();
    let pelvis = spec.body_index("pelvis").unwrap();
    assert!(poses[head].translation.y > poses[pelvis].translation.y + 0.4);
    assert_eq!(world.joint_errors(id).len(), spec.joints.len());
}
