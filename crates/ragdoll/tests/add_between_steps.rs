//! Ragdolls added to a world that has already stepped (a game spawning characters, a
//! script adding one after a blast): they move as one added at the start would, the
//! others carry on, every track keeps one frame per output frame, the start check sees
//! the others where they are now, and the energy they bring is not counted as drift.

use glam::Vec3;
use ragdoll::backend::BackendKind;
use ragdoll::math::Transform;
use ragdoll::skeleton::{Character, humanoid};
use ragdoll::spec::{RagdollSpec, build_spec};
use ragdoll::world::{RagdollId, STANDARD_GRAVITY, World, WorldSettings};

fn humanoid_and_spec() -> (Character, RagdollSpec) {
    let character = humanoid();
    let spec = build_spec(&character, &Default::default()).expect("the built-in humanoid builds");
    (character, spec)
}

/// The ragdoll's centre of mass now.
fn centre_of_mass(world: &World, id: RagdollId, spec: &RagdollSpec) -> Vec3 {
    let poses = world.body_poses(id);
    let mass: f32 = spec.bodies.iter().map(|b| b.mass_kg).sum();
    poses
        .iter()
        .zip(&spec.bodies)
        .map(|(p, b)| p.translation * b.mass_kg)
        .sum::<Vec3>()
        / mass
}

fn at(x: f32, y: f32, z: f32) -> Transform {
    Transform::from_translation(Vec3::new(x, y, z))
}

/// With no ground, a humanoid falls freely whenever it comes: one added after half a
/// second drops in its first half second as far as the first did in its own, ½ g t².
#[test]
fn a_ragdoll_added_mid_run_falls_as_one_added_at_the_start() {
    let (character, spec) = humanoid_and_spec();
    for backend in BackendKind::ALL {
        let settings = WorldSettings {
            ground: None,
            backend: backend.into(),
            ..Default::default()
        };
        let mut world = World::new(&settings).unwrap();
        let first = world
            .add_ragdoll(&character, &spec, at(0.0, 0.0, 0.0))
            .unwrap();
        let first_start = centre_of_mass(&world, first, &spec);
        world.run(0.5);
        let first_drop = first_start.y - centre_of_mass(&world, first, &spec).y;

        let late = world
            .add_ragdoll(&character, &spec, at(5.0, 0.0, 0.0))
            .unwrap();
        let late_start = centre_of_mass(&world, late, &spec);
        assert!(
            (late_start.x - first_start.x - 5.0).abs() < 1e-4,
            "{backend:?}: placed where it was asked, {late_start} against {first_start}"
        );
        let first_before = centre_of_mass(&world, first, &spec);
        world.run(0.5);
        let late_drop = late_start.y - centre_of_mass(&world, late, &spec).y;
        let first_drop_again = first_before.y - centre_of_mass(&world, first, &spec).y;

        let t = 0.5;
        let free_fall = 0.5 * STANDARD_GRAVITY * t * t;
        assert!(
            (late_drop - first_drop).abs() < 1e-3,
            "{backend:?}: the late ragdoll dropped {late_drop} m in its first {t} s, the \
             first {first_drop} m in its own"
        );
        assert!(
            (late_drop - free_fall).abs() < 0.02,
            "{backend:?}: dropped {late_drop} m in {t} s, free fall is {free_fall} m"
        );
        // The first carried on falling, a further ½ g t² + g t·t.
        let carried = free_fall + STANDARD_GRAVITY * t * t;
        assert!(
            (first_drop_again - carried).abs() < 0.03,
            "{backend:?}: the first dropped {first_drop_again} m in its second {t} s, \
             {carried} m expected"
        );
    }
}

/// Every track has one frame per output frame; the late one holds its start pose until
/// it came, then moves.
#[test]
fn a_late_ragdolls_track_holds_its_start_pose_until_it_came() {
    let (character, spec) = humanoid_and_spec();
    let settings = WorldSettings {
        backend: BackendKind::Fast.into(),
        ..Default::default()
    };
    let mut world = World::new(&settings).unwrap();
    let first = world
        .add_ragdoll(&character, &spec, at(0.0, 0.0, 0.0))
        .unwrap();
    world.run(1.0);
    let late = world
        .add_ragdoll(&character, &spec, at(3.0, 0.0, 0.0))
        .unwrap();
    world.run(1.0);
    let (a, b) = (world.track(first), world.track(late));
    assert_eq!(a.frames.len(), b.frames.len());
    assert_eq!(a.frames.len(), 61, "2 s at 30 fps and the starting frame");
    // Frames 0-30 are before it came (the 31st is at 1 s, when it was added).
    for frame in &b.frames[..=30] {
        assert_eq!(frame, &b.frames[0]);
    }
    let moved = b.frames[60]
        .iter()
        .zip(&b.frames[30])
        .map(|(p, q)| (p.translation - q.translation).length())
        .fold(0.0f32, f32::max);
    assert!(moved > 0.1, "it collapsed once it came: {moved} m");
}

/// The start check sees the ragdolls already there where they are now: with no ground,
/// the first has fallen out of the place it started in, which is free again, while the
/// place it has fallen to is not.
#[test]
fn a_late_ragdoll_is_checked_against_where_the_others_are_now() {
    let (character, spec) = humanoid_and_spec();
    let settings = WorldSettings {
        ground: None,
        backend: BackendKind::Fast.into(),
        ..Default::default()
    };
    let mut world = World::new(&settings).unwrap();
    let first = world
        .add_ragdoll(&character, &spec, at(0.0, 0.0, 0.0))
        .unwrap();
    let start = centre_of_mass(&world, first, &spec);
    world.run(1.0);
    let drop = start.y - centre_of_mass(&world, first, &spec).y;
    assert!(drop > 4.0, "fell {drop} m");
    let err = world
        .add_ragdoll(&character, &spec, at(0.0, -drop, 0.0))
        .expect_err("the place the first has fallen to is taken");
    assert!(
        err.to_string().contains("would start inside ragdoll 0"),
        "{err}"
    );
    world
        .add_ragdoll(&character, &spec, at(0.0, 0.0, 0.0))
        .expect("the place the first started in is free again");
}

/// The energy a late ragdoll brings (its height above the floor) is not drift: the metric
/// measures the energy the simulation gains by itself from the frame after it came.
#[test]
fn a_late_ragdolls_energy_is_not_drift() {
    let (character, spec) = humanoid_and_spec();
    for backend in [BackendKind::Rigid, BackendKind::Fast] {
        let settings = WorldSettings {
            backend: backend.into(),
            ..Default::default()
        };
        let mut world = World::new(&settings).unwrap();
        world
            .add_ragdoll(&character, &spec, at(0.0, 0.0, 0.0))
            .unwrap();
        world.run(2.0);
        // Half a metre up: it brings 75 kg × g × 0.5 m beyond its standing height.
        world
            .add_ragdoll(&character, &spec, at(3.0, 0.5, 0.0))
            .unwrap();
        world.run(2.0);
        let drift = world.metrics().energy_drift;
        assert!(drift < 0.05, "{backend:?}: energy drift {drift}");
    }
}
