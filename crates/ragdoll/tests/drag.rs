//! Drags (a soft pin whose target moves at run time, as a viewer's mouse does): the
//! dragged point follows a critically damped spring, and once let go the body flies freely.

mod common;

use glam::Vec3;
use ragdoll::world::{RagdollId, World, WorldSettings};

const MASS: f32 = 10.0;

/// A 10 kg capsule at rest 1 m up, no gravity, no ground.
fn bar() -> (World, RagdollId) {
    let (character, spec) = common::one_capsule(0.1, 0.6, MASS);
    let settings = WorldSettings {
        gravity: Vec3::ZERO,
        ground: None,
        ..Default::default()
    };
    let (mut world, id) = World::with_ragdoll(&character, &spec, &settings).unwrap();
    world.run(0.0); // records the first frame, so poses can be read
    (world, id)
}

fn centre(world: &World, id: RagdollId) -> Vec3 {
    world.body_poses(id)[0].translation
}

#[test]
fn a_drag_pulls_its_point_like_a_critically_damped_spring() {
    let (mut world, id) = bar();
    let start = centre(&world, id);
    let hz = 2.0;
    let drag = world.drag_start(id, 0, Vec3::ZERO, start, hz, 1.0).unwrap();
    let target = start + Vec3::new(1.0, 0.0, 0.0);
    world.drag_move(drag, target).unwrap();
    // Critically damped from rest: the gap is x0·(1 + ωt)·e^(−ωt).
    let omega = std::f32::consts::TAU * hz;
    let t = 0.25;
    world.run(t);
    let expected_gap = (1.0 + omega * t) * (-omega * t).exp();
    let gap = (target - centre(&world, id)).x;
    assert!(
        (gap - expected_gap).abs() < 0.02,
        "gap {gap} m after {t} s, closed form {expected_gap} m"
    );
    // Critical damping never overshoots, and settles on the target.
    for _ in 0..180 {
        world.step();
        assert!(centre(&world, id).x <= target.x + 1e-3);
    }
    assert!(centre(&world, id).distance(target) < 5e-3);
}

#[test]
fn a_moved_target_is_followed_and_a_released_body_keeps_its_momentum() {
    let (mut world, id) = bar();
    let start = centre(&world, id);
    let drag = world
        .drag_start(id, 0, Vec3::ZERO, start, 3.0, 1.0)
        .unwrap();
    let up = start + Vec3::new(0.0, 0.5, 0.0);
    world.drag_move(drag, up).unwrap();
    world.run(2.0);
    assert!(centre(&world, id).distance(up) < 5e-3);
    // Swing the target sideways and let go halfway: no force acts after the release, so
    // the velocity stays what it was (momentum is conserved in free space).
    world
        .drag_move(drag, up + Vec3::new(0.0, 0.0, 1.0))
        .unwrap();
    world.run(0.1);
    world.drag_end(drag);
    world.step();
    let v0 = world.body_velocities(id)[0].0;
    assert!(
        v0.z > 0.5,
        "the swing should have set the bar moving: {v0:?}"
    );
    world.run(1.0);
    let v1 = world.body_velocities(id)[0].0;
    assert!((v1 - v0).length() < 1e-4, "{v0:?} → {v1:?}");
    // An ended drag cannot be moved again.
    assert!(world.drag_move(drag, up).is_err());
}

#[test]
fn bad_drags_are_refused() {
    let (mut world, id) = bar();
    let p = centre(&world, id);
    assert!(world.drag_start(id, 1, Vec3::ZERO, p, 2.0, 1.0).is_err());
    assert!(world.drag_start(id, 0, Vec3::NAN, p, 2.0, 1.0).is_err());
    assert!(world.drag_start(id, 0, Vec3::ZERO, p, 0.0, 1.0).is_err());
    assert!(world.drag_start(id, 0, Vec3::ZERO, p, 2.0, -1.0).is_err());
    let drag = world.drag_start(id, 0, Vec3::ZERO, p, 2.0, 1.0).unwrap();
    assert!(world.drag_move(drag, Vec3::INFINITY).is_err());
}
