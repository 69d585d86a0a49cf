//! Creature joints from the rest pose's geometry: a quadruped's bent
//! leg joints are hinges that flex the way the rest pose bends and stop near straight,
//! whatever way it faces; a long chain shares one total bend among its links and a
//! 20-link snake falls and settles without tearing.

mod common;

use glam::{Quat, Vec3};
use ragdoll::math::Transform;
use ragdoll::skeleton::{Character, Skeleton};
use ragdoll::spec::{BuildOptions, JointKind, RagdollSpec, build_spec};
use ragdoll::world::{World, WorldSettings};

/// The total bend a chain may share (`CREATURE_CHAIN_TOTAL_BEND_DEG`, private), degrees.
const CHAIN_TOTAL_BEND_DEG: f32 = 360.0;
/// How far a creature's knee bends past straight (`CREATURE_LIMB_FLEXION_DEG[0]`).
const HYPEREXTENSION_DEG: f32 = 10.0;

/// A dog-like quadruped facing +Z: hind legs with the stifle bent forward and the hock
/// back, front legs with the elbow bent back, a tail.
fn quadruped() -> Character {
    let mut rows: Vec<(&str, Option<usize>, Vec3)> = vec![
        ("hip", None, Vec3::new(0.0, 0.5, -0.3)),
        ("spine", Some(0), Vec3::new(0.0, 0.52, 0.0)),
        ("chest", Some(1), Vec3::new(0.0, 0.52, 0.3)),
        ("head", Some(2), Vec3::new(0.0, 0.7, 0.45)),
        ("tail", Some(0), Vec3::new(0.0, 0.5, -0.55)),
    ];
    for (x, side) in [(0.08, "l"), (-0.08, "r")] {
        let n = rows.len();
        let names: [&'static str; 6] = if side == "l" {
            ["thigh_l", "shin_l", "hock_l", "upper_l", "fore_l", "paw_l"]
        } else {
            ["thigh_r", "shin_r", "hock_r", "upper_r", "fore_r", "paw_r"]
        };
        rows.push((names[0], Some(0), Vec3::new(x, 0.45, -0.3)));
        // Stifle ahead of the hip, hock behind it: the hind leg's zig-zag.
        rows.push((names[1], Some(n), Vec3::new(x, 0.28, -0.22)));
        rows.push((names[2], Some(n + 1), Vec3::new(x, 0.12, -0.34)));
        rows.push((names[3], Some(2), Vec3::new(x, 0.45, 0.3)));
        // Elbow behind the shoulder.
        rows.push((names[4], Some(n + 3), Vec3::new(x, 0.25, 0.24)));
        rows.push((names[5], Some(n + 4), Vec3::new(x, 0.0, 0.28)));
        let paw_end = rows.len();
        rows.push(("", Some(n + 2), Vec3::new(x, 0.0, -0.32)));
        rows[paw_end].0 = if side == "l" { "toe_l" } else { "toe_r" };
    }
    common::character_from_rows("quadruped", &rows)
}

fn hinge(spec: &RagdollSpec, name: &str) -> (Quat, f32, f32) {
    let j = spec.joints.iter().find(|j| j.child == name).unwrap();
    let JointKind::Hinge { min_deg, max_deg } = j.kind else {
        panic!("{name}: {:?}, not a hinge", j.kind);
    };
    (Quat::from_array(j.frame), min_deg, max_deg)
}

fn index(c: &Character, name: &str) -> usize {
    c.skeleton
        .joints()
        .iter()
        .position(|j| j.name == name)
        .unwrap()
}

/// The bend at `joint` (degrees between its parent bone and its own bone) after turning
/// its bone about the hinge axis by `deg`.
fn bend_after(c: &Character, spec: &RagdollSpec, joint: &str, child: &str, deg: f32) -> f32 {
    let world = c.skeleton.rest_world();
    let (j, k) = (index(c, joint), index(c, child));
    let parent = c.skeleton.joints()[j].parent.unwrap();
    let dp = (world[j].translation - world[parent].translation).normalize();
    let d = (world[k].translation - world[j].translation).normalize();
    let (frame, _, _) = hinge(spec, joint);
    let axis = world[j].rotation * frame * Vec3::X;
    let turned = Quat::from_axis_angle(axis, deg.to_radians()) * d;
    dp.angle_between(turned).to_degrees()
}

#[test]
fn creature_quadruped_knees_hinge_the_way_they_bend_for_any_facing() {
    let base = quadruped();
    for yaw_deg in [0.0f32, 90.0, 137.0, 180.0, 270.0] {
        let c = base.turned(yaw_deg.to_radians());
        let spec = build_spec(&c, &BuildOptions::default()).unwrap();
        for (joint, child) in [
            ("shin_l", "hock_l"),
            ("hock_r", "toe_r"),
            ("fore_l", "paw_l"),
            ("shin_r", "hock_r"),
        ] {
            let (_, min, max) = hinge(&spec, joint);
            let rest = bend_after(&c, &spec, joint, child, 0.0);
            assert!(rest > 20.0, "{joint} is bent {rest}° at rest");
            // Positive angles bend further, negative ones straighten.
            let further = bend_after(&c, &spec, joint, child, 10.0);
            let straighter = bend_after(&c, &spec, joint, child, -10.0);
            assert!(
                further > rest + 9.0 && straighter < rest - 9.0,
                "{yaw_deg}° {joint}"
            );
            // The lower limit is straight, give or take the allowed hyperextension.
            assert!(
                (min + rest + HYPEREXTENSION_DEG).abs() < 1.0,
                "{yaw_deg}° {joint}: limit {min}°, rest bend {rest}°"
            );
            assert!(max >= 40.0, "{yaw_deg}° {joint}: {max}°");
        }
    }
}

/// A snake of `links` links lying along +Z, a little above the ground.
fn snake(links: usize) -> Character {
    let names: Vec<String> = (0..=links).map(|i| format!("v{i}")).collect();
    let rows: Vec<(&str, Option<usize>, Vec3)> = (0..=links)
        .map(|i| {
            (
                names[i].as_str(),
                i.checked_sub(1),
                Vec3::new(0.0, 0.05, 0.05 * i as f32),
            )
        })
        .collect();
    common::character_from_rows("snake", &rows)
}

#[test]
fn creature_snake_shares_one_total_bend_and_settles() {
    let c = snake(20);
    let spec = build_spec(&c, &BuildOptions::default()).unwrap();
    let total: f32 = spec
        .joints
        .iter()
        .map(|j| match j.kind {
            JointKind::SwingTwist { swing_deg, .. } => swing_deg,
            _ => panic!("{}: {:?}", j.name, j.kind),
        })
        .sum();
    assert!(total <= CHAIN_TOTAL_BEND_DEG * 1.001, "{total}°");

    // Dropped from a height head first, it lands and piles up: the links' bends add up
    // to no more than the chain may share, and nothing flies off.
    let upright = Character {
        skeleton: {
            let mut joints = c.skeleton.joints().to_vec();
            joints[0].rest = Transform::from_translation(Vec3::new(0.0, 0.5, 0.0));
            for j in joints.iter_mut().skip(1) {
                j.rest = Transform::from_translation(Vec3::new(0.003, 0.05, 0.0));
            }
            Skeleton::new(joints).unwrap()
        },
        ..c.clone()
    };
    let spec = build_spec(&upright, &BuildOptions::default()).unwrap();
    let (mut world, id) = World::with_ragdoll(&upright, &spec, &WorldSettings::default()).unwrap();
    let start = world.body_poses(id);
    world.run(3.0);
    let poses = world.body_poses(id);
    // Each body's bone direction now: its rest direction (up) turned as the body turned.
    let dir = |b: usize| poses[b].rotation * start[b].rotation.conjugate() * Vec3::Y;
    let mut bend = 0.0;
    for (b, body) in spec.bodies.iter().enumerate().skip(1) {
        assert!(poses[b].translation.is_finite(), "{}", body.name);
        bend += dir(b - 1).angle_between(dir(b)).to_degrees();
    }
    assert!(bend <= CHAIN_TOTAL_BEND_DEG * 1.1, "bent {bend}° in all");
    let speed = world
        .body_velocities(id)
        .iter()
        .map(|(v, _)| v.length())
        .fold(0.0f32, f32::max);
    assert!(speed < 0.5, "still moving at {speed} m/s");
}
