//! Projectiles: the first part on the line of fire takes the momentum at the point hit.

use glam::{Quat, Vec3};
use ragdoll::events::Projectile;
use ragdoll::math::Transform;
use ragdoll::skeleton::humanoid;
use ragdoll::spec::{BuildOptions, RagdollSpec, build_spec};
use ragdoll::world::{World, WorldSettings};

/// Body poses of the built-in humanoid `seconds` after a shot (or none), and the report.
fn after(shot: Option<Projectile>, seconds: f32) -> (RagdollSpec, Vec<Transform>, Option<String>) {
    let character = humanoid();
    let spec = build_spec(&character, &BuildOptions::default()).unwrap();
    let (mut world, id) =
        World::with_ragdoll(&character, &spec, &WorldSettings::default()).unwrap();
    if let Some(p) = shot {
        world.add_projectile(p).unwrap();
    }
    world.run(seconds);
    let hit = world
        .projectile_reports()
        .first()
        .and_then(|r| r.body.clone());
    (spec, world.body_poses(id), hit)
}

/// A 50 g projectile at 300 m/s (15 N·s, a less-lethal round) from the front (+Z, the
/// humanoid faces +Z), aimed at height `y` and sideways offset `x`.
fn shot(x: f32, y: f32) -> Projectile {
    Projectile {
        origin: Vec3::new(x, y, 5.0),
        direction: -Vec3::Z,
        mass_kg: 0.05,
        speed_mps: 300.0,
        time_s: 0.1,
    }
}

fn turned(a: Quat, b: Quat) -> f32 {
    a.angle_between(b).to_degrees()
}

#[test]
fn a_shot_off_the_centre_of_the_head_spins_the_head() {
    // The head's centre is near 1.65 m; hit it 6 cm to its left: a push and a twist.
    let (spec, shot_poses, hit) = after(Some(shot(0.06, 1.66)), 0.3);
    assert_eq!(hit.as_deref(), Some("head"));
    let (_, calm, _) = after(None, 0.3);
    let head = spec.body_index("head").unwrap();
    let spin = turned(shot_poses[head].rotation, calm[head].rotation);
    assert!(
        spin > 15.0,
        "the head turned only {spin}° more than without the shot"
    );
    // Pushed backward, away from the shooter.
    assert!(shot_poses[head].translation.z < calm[head].translation.z - 0.05);
}

#[test]
fn a_shot_at_a_foot_sweeps_the_leg() {
    // From the character's left (+X) at ankle height, straight across; a planted foot
    // carries half the body's weight, so it takes a heavy hit (a 0.5 kg beanbag at 100 m/s,
    // 50 N·s) to sweep it.
    let p = Projectile {
        origin: Vec3::new(3.0, 0.06, 0.05),
        direction: -Vec3::X,
        mass_kg: 0.5,
        speed_mps: 100.0,
        time_s: 0.1,
    };
    let (spec, poses, hit) = after(Some(p), 0.3);
    assert_eq!(hit.as_deref(), Some("foot_l"));
    let (_, calm, _) = after(None, 0.3);
    let foot = spec.body_index("foot_l").unwrap();
    let shin = spec.body_index("shin_l").unwrap();
    let moved = calm[foot].translation.x - poses[foot].translation.x;
    assert!(moved > 0.1, "the foot moved only {moved} m across");
    let swept = turned(poses[shin].rotation, calm[shin].rotation);
    assert!(swept > 10.0, "the shin turned only {swept}°");
}

#[test]
fn a_shot_that_misses_hits_nothing() {
    let (_, _, hit) = after(Some(shot(2.0, 1.0)), 0.2);
    assert_eq!(hit, None);
}

#[test]
fn energy_drift_is_measured_from_after_the_shot() {
    // A shot puts momentum in on purpose: the drift metric starts after it,
    // as after a blast. Read across the shot, the chest's 200 N·s read as a 98 % gain.
    let character = humanoid();
    let spec = build_spec(&character, &BuildOptions::default()).unwrap();
    let (mut world, _) = World::with_ragdoll(&character, &spec, &WorldSettings::default()).unwrap();
    world
        .add_projectile(Projectile {
            origin: Vec3::new(0.0, 1.3, 5.0),
            direction: -Vec3::Z,
            mass_kg: 1.0,
            speed_mps: 200.0,
            time_s: 0.05,
        })
        .unwrap();
    world.run(1.0);
    assert!(world.projectile_reports()[0].body.is_some());
    let m = world.metrics();
    assert!(m.energy_drift < 0.01, "{m:?}");
}
