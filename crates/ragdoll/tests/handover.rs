//! Animation hand-over: a clip plays kinematically, then physics takes over with its
//! velocities.

mod common;

use glam::Vec3;
use ragdoll::import::{ImportOptions, load};
use ragdoll::spec::{BuildOptions, build_spec};
use ragdoll::world::{
    Activation, BackendConfig, RigidConfig, STANDARD_GRAVITY, World, WorldSettings,
};

/// The clip's own body velocities at time `t` (central differences over `h`), from forward
/// kinematics of the clip and the spec's body frames, independently of the world.
fn clip_body_velocities(
    character: &ragdoll::skeleton::Character,
    spec: &ragdoll::spec::RagdollSpec,
    t: f32,
    h: f32,
) -> Vec<Vec3> {
    let clip = &character.clips[0];
    let skeleton = &character.skeleton;
    let resolved = ragdoll::spec::Resolved::new(spec, character).unwrap();
    let poses_at = |t: f32| {
        let f = t / clip.frame_time;
        let i = f.floor() as usize;
        let a = f - i as f32;
        let locals: Vec<ragdoll::math::Transform> = (0..skeleton.len())
            .map(|k| {
                let (p, q) = (&clip.frames[i][k], &clip.frames[i + 1][k]);
                ragdoll::math::Transform {
                    translation: p.translation.lerp(q.translation, a),
                    rotation: p.rotation.slerp(q.rotation, a),
                    scale: p.scale,
                }
            })
            .collect();
        let mut world = vec![ragdoll::math::Transform::IDENTITY; skeleton.len()];
        skeleton.world_from_local(&locals, &mut world);
        resolved.body_poses(&world)
    };
    let (a, b) = (poses_at(t - h), poses_at(t + h));
    a.iter()
        .zip(&b)
        .map(|(a, b)| (b.translation - a.translation) / (2.0 * h))
        .collect()
}

fn com_velocity(world: &World, id: ragdoll::world::RagdollId, masses: &[f32]) -> Vec3 {
    let v = world.body_velocities(id);
    let total: f32 = masses.iter().sum();
    v.iter()
        .zip(masses)
        .map(|((l, _), m)| *l * *m)
        .sum::<Vec3>()
        / total
}

/// Pirouette mocap, handed over at 2 s in free fall (no ground, so only gravity changes the
/// centre of mass's velocity; the joints are internal forces), compared with the clip's own
/// finite differences.
#[test]
#[ignore = "needs ../shared/data"]
fn hand_over_keeps_the_clips_momentum_and_positions() {
    let data = common::shared_data();
    let character = load(
        &data.join("bvh/cmu_pirouette_threejs.bvh"),
        &ImportOptions::default(),
    )
    .unwrap();
    let spec = build_spec(&character, &BuildOptions::default()).unwrap();
    let masses: Vec<f32> = spec.bodies.iter().map(|b| b.mass_kg).collect();
    // One short step (1/960 s) after the switch, so that what the joints do to a passive
    // arm in that time (its muscles are gone) stays small next to the 5 % being checked.
    let settings = WorldSettings {
        ground: None,
        dt: 1.0 / 960.0,
        backend: BackendConfig::Rigid(RigidConfig {
            collision_substeps: 1,
            ..Default::default()
        }),
        ..Default::default()
    };
    let (mut world, id) = World::with_ragdoll(&character, &spec, &settings).unwrap();
    world.set_activation(id, Activation::AtTime(2.0)).unwrap();
    world.run(2.0);
    assert_eq!(world.activated_at(id), None, "still playing at 2 s");
    let clip_bodies = clip_body_velocities(&character, &spec, 2.0, 1.0 / 960.0);
    let total: f32 = masses.iter().sum();
    let clip_v = clip_bodies
        .iter()
        .zip(&masses)
        .map(|(v, m)| *v * *m)
        .sum::<Vec3>()
        / total;
    world.step();
    let t = world.activated_at(id).expect("physics took over");
    assert!((t - 2.0).abs() < 1e-6, "took over at {t} s");
    let dt = settings.dt;
    let expected = clip_v + Vec3::new(0.0, -STANDARD_GRAVITY, 0.0) * dt;
    let v = com_velocity(&world, id, &masses);
    assert!(clip_v.length() > 0.1, "the clip moves: {clip_v:?}");
    assert!(
        (v - expected).length() <= 0.05 * clip_v.length(),
        "centre of mass {v:?}, clip {clip_v:?} + g·dt"
    );
    // Every body keeps its own velocity within 5 % of the clip's speed scale (plus what
    // gravity adds): no part is kicked at the switch.
    let scale = clip_bodies
        .iter()
        .map(|l| l.length())
        .fold(0.0f32, f32::max);
    for (k, ((l, _), l0)) in world
        .body_velocities(id)
        .iter()
        .zip(&clip_bodies)
        .enumerate()
    {
        let d = (*l - (*l0 + Vec3::new(0.0, -STANDARD_GRAVITY, 0.0) * dt)).length();
        assert!(
            d <= 0.05 * scale,
            "{}: {d} m/s off: world {l:?} clip {l0:?} (scale {scale})",
            spec.bodies[k].name
        );
    }
    // Positions continuous: the track's joints move from the switch frame to the next by
    // about what the clip moves them, not by a jump.
    world.run(0.1);
    let track = world.track(id);
    let f = (2.0 * track.fps).round() as usize;
    for j in 0..character.skeleton.len() {
        let step = (track.frames[f + 1][j].translation - track.frames[f][j].translation).length();
        let before = (track.frames[f][j].translation - track.frames[f - 1][j].translation).length();
        assert!(
            step < before + 0.05,
            "joint {j} jumped {step} m at the switch (clip: {before} m)"
        );
    }
}

#[test]
fn a_character_without_a_clip_cannot_wait_for_activation() {
    let character = ragdoll::skeleton::humanoid();
    let spec = build_spec(&character, &BuildOptions::default()).unwrap();
    let (mut world, id) =
        World::with_ragdoll(&character, &spec, &WorldSettings::default()).unwrap();
    assert!(world.set_activation(id, Activation::AtTime(1.0)).is_err());
}

/// `OnBlast`: the clip plays until the blast front reaches the nearest part, then the
/// character is thrown.
#[test]
#[ignore = "needs ../shared/data"]
fn on_blast_plays_until_the_front_arrives() {
    let data = common::shared_data();
    let character = load(
        &data.join("bvh/mocapbank_bvh-python.bvh"),
        &ImportOptions::default(),
    )
    .unwrap();
    let spec = build_spec(&character, &BuildOptions::default()).unwrap();
    let (mut world, id) =
        World::with_ragdoll(&character, &spec, &WorldSettings::default()).unwrap();
    world.set_activation(id, Activation::OnBlast).unwrap();
    world
        .add_blast(ragdoll::events::Blast::new(
            10.0,
            Vec3::new(4.0, 1.0, 0.0),
            1.0,
        ))
        .unwrap();
    world.run(1.0);
    assert_eq!(
        world.activated_at(id),
        None,
        "still playing before the blast"
    );
    world.run(1.0);
    let t = world.activated_at(id).expect("the blast handed over");
    let report = &world.blast_reports()[0];
    let first = report
        .parts
        .iter()
        .filter_map(|p| p.arrival_s)
        .fold(f64::INFINITY, f64::min);
    assert!(
        (t - first).abs() < 1.0 / 240.0 + 1e-6,
        "took over at {t} s, front arrived at {first} s"
    );
    let v = report.characters[0].com_velocity_mps.expect("thrown");
    assert!(v[0] < -0.5, "thrown away from the charge: {v:?}");
}

/// `OnContact`: the clip plays until something other than the ground touches the
/// character; a shot counts too, and its hit lands on the now physical body.
#[test]
#[ignore = "needs ../shared/data"]
fn on_contact_plays_until_a_body_or_a_shot_touches() {
    let data = common::shared_data();
    let character = load(
        &data.join("bvh/mocapbank_bvh-python.bvh"),
        &ImportOptions::default(),
    )
    .unwrap();
    let spec = build_spec(&character, &BuildOptions::default()).unwrap();

    // Where the head starts (a first world, only to read it).
    let (mut probe, pid) =
        World::with_ragdoll(&character, &spec, &WorldSettings::default()).unwrap();
    probe.run(0.0);
    let head = probe.track(pid).frames[0][character.skeleton.find("Head").unwrap()].translation;

    // A 10 kg bar dropped from 1 m above the head: the character plays its clip until the
    // bar lands on it (about 0.4 s of fall), not before.
    let (bar, bar_spec) = common::one_capsule(0.1, 0.6, 10.0);
    let mut world = World::new(&WorldSettings::default()).unwrap();
    let id = world
        .add_ragdoll(&character, &spec, ragdoll::math::Transform::IDENTITY)
        .unwrap();
    // The bar's joint is 1 m up in its own file.
    let above = head + Vec3::new(0.0, 1.0 + 0.3 + 0.1, 0.0) - Vec3::Y;
    world
        .add_ragdoll(
            &bar,
            &bar_spec,
            ragdoll::math::Transform::from_translation(above),
        )
        .unwrap();
    world.set_activation(id, Activation::OnContact).unwrap();
    world.run(0.2);
    assert_eq!(
        world.activated_at(id),
        None,
        "touched before the bar arrived"
    );
    world.run(1.0);
    let t = world
        .activated_at(id)
        .expect("the bar's landing handed over");
    assert!(t > 0.2 && t < 0.8, "handed over at {t} s");

    // A shot at 0.5 s: the character is handed over on the hit and thrown.
    let (mut world, id) =
        World::with_ragdoll(&character, &spec, &WorldSettings::default()).unwrap();
    world.set_activation(id, Activation::OnContact).unwrap();
    world.run(0.0);
    let chest = world.track(id).frames[0][character.skeleton.find("Chest2").unwrap()].translation;
    world
        .add_projectile(ragdoll::events::Projectile {
            origin: chest + Vec3::new(3.0, 0.0, 0.0),
            direction: -Vec3::X,
            mass_kg: 0.5,
            speed_mps: 100.0,
            time_s: 0.5,
        })
        .unwrap();
    world.run(0.45);
    assert_eq!(
        world.activated_at(id),
        None,
        "still playing before the shot"
    );
    world.run(0.3);
    let t = world.activated_at(id).expect("the shot handed over");
    assert!((t - 0.5).abs() < 0.02, "handed over at {t} s");
    let hit = &world.projectile_reports()[0];
    assert!(hit.body.is_some(), "the shot hit the character");
}
