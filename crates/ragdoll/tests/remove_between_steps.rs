//! Ragdolls taken out of a world between two steps: nothing meets them any more (a
//! ragdoll dropped onto one removed falls through its place to the floor), they stop
//! where they are, their tracks hold their last pose, the energy they take away is not
//! counted, and bad removals are refused in a sentence.

use glam::Vec3;
use ragdoll::backend::BackendKind;
use ragdoll::events::Push;
use ragdoll::math::Transform;
use ragdoll::skeleton::{Character, humanoid};
use ragdoll::spec::{RagdollSpec, build_spec};
use ragdoll::world::{RagdollId, World, WorldSettings};

fn humanoid_and_spec() -> (Character, RagdollSpec) {
    let character = humanoid();
    let spec = build_spec(&character, &Default::default()).expect("the built-in humanoid builds");
    (character, spec)
}

/// The ragdoll's momentum now, N·s.
fn momentum(world: &World, id: RagdollId, spec: &RagdollSpec) -> Vec3 {
    world
        .body_velocities(id)
        .iter()
        .zip(&spec.bodies)
        .map(|((v, _), b)| *v * b.mass_kg)
        .sum()
}

/// In zero gravity, a humanoid shot along x at 4 m/s through the place where another
/// floats: kept, the other takes momentum from the blow; removed, the shot one passes
/// through its place with all its momentum and the removed one does not move.
#[test]
fn a_removed_ragdoll_is_met_by_nothing() {
    let (character, spec) = humanoid_and_spec();
    let mass: f32 = spec.bodies.iter().map(|b| b.mass_kg).sum();
    let shove = Vec3::new(-4.0 * mass, 0.0, 0.0);
    for backend in BackendKind::ALL {
        let settings = WorldSettings {
            backend: backend.into(),
            gravity: Vec3::ZERO,
            ground: None,
            ..Default::default()
        };
        let run = |remove: bool| {
            let mut world = World::new(&settings).unwrap();
            let still = world
                .add_ragdoll(&character, &spec, Transform::IDENTITY)
                .unwrap();
            let shot = world
                .add_ragdoll(
                    &character,
                    &spec,
                    Transform::from_translation(Vec3::new(3.0, 0.0, 0.0)),
                )
                .unwrap();
            world
                .add_push(
                    shot,
                    Push::Impulse {
                        target: "pelvis".into(),
                        impulse_ns: shove,
                        time_s: 0.0,
                    },
                )
                .unwrap();
            let before = world.body_poses(still);
            if remove {
                world.remove_ragdoll(still).unwrap();
            }
            world.run(1.5);
            let moved = before
                .iter()
                .zip(world.body_poses(still))
                .map(|(a, b)| (a.translation - b.translation).length())
                .fold(0.0f32, f32::max);
            let pelvis_x = world.body_poses(shot)[0].translation.x;
            (
                momentum(&world, still, &spec),
                momentum(&world, shot, &spec),
                moved,
                pelvis_x,
            )
        };
        let (still_kept, _, _, _) = run(false);
        assert!(
            still_kept.length() > 50.0,
            "{backend:?}: kept, the one floating took {still_kept} N·s from the blow"
        );
        let (still, shot, moved, pelvis_x) = run(true);
        assert!(
            pelvis_x < -1.0,
            "{backend:?}: passed through, pelvis at x = {pelvis_x}"
        );
        assert!(
            still.length() < 1e-3 && moved < 1e-4,
            "{backend:?}: the removed one took {still} N·s and moved {moved} m"
        );
        assert!(
            (shot - shove).length() < 0.01 * shove.length(),
            "{backend:?}: the shot one kept {shot} N·s of {shove}"
        );
    }
}

/// A humanoid removed once it has collapsed stops where it lies; its track holds that
/// pose, keeps one frame per output frame, and the energy it takes away is not drift.
#[test]
fn a_removed_ragdolls_track_holds_its_last_pose() {
    let (character, spec) = humanoid_and_spec();
    for backend in BackendKind::ALL {
        let settings = WorldSettings {
            backend: backend.into(),
            ..Default::default()
        };
        let mut world = World::new(&settings).unwrap();
        let gone = world
            .add_ragdoll(&character, &spec, Transform::IDENTITY)
            .unwrap();
        let stays = world
            .add_ragdoll(
                &character,
                &spec,
                Transform::from_translation(Vec3::new(3.0, 0.5, 0.0)),
            )
            .unwrap();
        world.run(0.5);
        world.remove_ragdoll(gone).unwrap();
        world.run(1.5);
        let (a, b) = (&world.track(gone).frames, &world.track(stays).frames);
        assert_eq!(a.len(), b.len(), "{backend:?}: one frame per output frame");
        let held = a[a.len() - 1]
            .iter()
            .zip(&a[15])
            .map(|(p, q)| (p.translation - q.translation).length())
            .fold(0.0f32, f32::max);
        assert!(held < 1e-4, "{backend:?}: its track moved {held} m after");
        let drift = world.metrics().energy_drift;
        assert!(drift < 0.05, "{backend:?}: energy drift {drift}");
    }
}

#[test]
fn removing_twice_or_a_ragdoll_of_another_world_is_refused() {
    let (character, spec) = humanoid_and_spec();
    let mut world = World::new(&WorldSettings::default()).unwrap();
    let id = world
        .add_ragdoll(&character, &spec, Transform::IDENTITY)
        .unwrap();
    let mut other = World::new(&WorldSettings::default()).unwrap();
    other
        .add_ragdoll(&character, &spec, Transform::IDENTITY)
        .unwrap();
    let stranger = other
        .add_ragdoll(
            &character,
            &spec,
            Transform::from_translation(Vec3::new(3.0, 0.0, 0.0)),
        )
        .unwrap();
    let err = world.remove_ragdoll(stranger).unwrap_err().to_string();
    assert!(err.contains("there is no ragdoll 1"), "{err}");
    world.remove_ragdoll(id).unwrap();
    let err = world.remove_ragdoll(id).unwrap_err().to_string();
    assert!(err.contains("was removed already"), "{err}");
    // Its place is free: another can be added where it stands.
    world.run(0.1);
    world
        .add_ragdoll(&character, &spec, Transform::IDENTITY)
        .expect("a removed ragdoll's place is free");
}
