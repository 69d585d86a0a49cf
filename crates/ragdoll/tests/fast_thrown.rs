//! Bodies thrown faster than a step's worth of their own size on the fast backend. A
//! blast throws parts through a crowd at up to a couple of hundred metres a second,
//! metres a step: whatever lies on that path within the step must still be met, and
//! its share of the momentum handed over, not passed through.

use glam::{Quat, Vec3};
use ragdoll::backend::{
    Backend, BodyDesc, BodyId, BodyState, FastBackend, FastConfig, Surroundings,
};
use ragdoll::math::Transform;
use ragdoll::spec::Shape;

const DT: f32 = 1.0 / 60.0;

/// A 1 kg capsule lying across the X axis at the origin, thrown along +X at `speed_mps`
/// (offset sideways by `side_m` along Z), and a 20 kg box at rest `ahead_m` along X;
/// zero gravity, no ground.
fn thrown(speed_mps: f32, ahead_m: f32, side_m: f32) -> (FastBackend, BodyId, BodyId) {
    let mut engine = FastBackend::new(
        &FastConfig::default(),
        &Surroundings {
            gravity: Vec3::ZERO,
            ground: None,
        },
    );
    let across_x = Quat::from_rotation_x(std::f32::consts::FRAC_PI_2);
    let bullet = engine.add_ragdoll(
        &[BodyDesc {
            pose: Transform::new(Vec3::new(0.0, 0.0, side_m), across_x),
            shape: Shape::Capsule {
                radius_m: 0.05,
                length_m: 0.3,
            },
            extra_shapes: Vec::new(),
            mass: 1.0,
            linvel: Vec3::new(speed_mps, 0.0, 0.0),
            angvel: Vec3::ZERO,
        }],
        &[],
        &[],
    );
    let target = engine.add_ragdoll(
        &[BodyDesc {
            pose: Transform::from_translation(Vec3::new(ahead_m, 0.0, 0.0)),
            shape: Shape::Box {
                size_m: [0.3, 0.6, 0.4],
            },
            extra_shapes: Vec::new(),
            mass: 20.0,
            linvel: Vec3::ZERO,
            angvel: Vec3::ZERO,
        }],
        &[],
        &[],
    );
    (engine, bullet, target)
}

fn states(engine: &FastBackend) -> Vec<BodyState> {
    let mut s = Vec::new();
    engine.body_states(&mut s);
    s
}

#[test]
fn a_body_thrown_through_a_step_meets_what_lies_on_its_path() {
    // 60-240 m/s: 1-4 m a step, with the box 0.5-1.5 m ahead, so that the meeting
    // happens inside the first step.
    for speed in [60.0f32, 120.0, 240.0] {
        for ahead in [0.5f32, 1.0, 1.5] {
            let (mut engine, bullet, target) = thrown(speed, ahead, 0.0);
            // The velocities an engine reports are its bodies' motion over the step, so
            // the first step's are the throw and the blow averaged: read the next ones.
            for _ in 0..3 {
                engine.step(DT);
            }
            let s = states(&engine);
            let (b, t) = (&s[bullet.0], &s[target.0]);
            let given = speed * 1.0;
            let taken = 20.0 * t.linvel.x;
            // The box took a real share of the blow and the capsule did not pass through
            // it: it is still on the near side, slower than the box it struck.
            assert!(
                taken > 0.5 * given,
                "{speed} m/s, {ahead} m ahead: the box took {taken:.1} of {given:.1} N·s"
            );
            assert!(
                b.pose.translation.x < t.pose.translation.x && b.linvel.x <= t.linvel.x + 1e-3,
                "{speed} m/s, {ahead} m ahead: the capsule at x = {:.2} m, {:.1} m/s, the box \
                 at {:.2} m, {:.1} m/s",
                b.pose.translation.x,
                b.linvel.x,
                t.pose.translation.x,
                t.linvel.x
            );
            // What one gave the other took: momentum kept within f32 rounding.
            let total = 1.0 * b.linvel + 20.0 * t.linvel;
            assert!(
                (total - Vec3::new(given, 0.0, 0.0)).length() < 1e-3 * given,
                "{speed} m/s, {ahead} m ahead: momentum {total:?} of {given}"
            );
        }
    }
}

#[test]
fn a_body_thrown_past_another_leaves_it_alone() {
    // The same throw with the box a metre to the side of the path: nothing touches it.
    let (mut engine, _, target) = thrown(240.0, 1.0, 1.0);
    for _ in 0..3 {
        engine.step(DT);
    }
    let t = &states(&engine)[target.0];
    assert_eq!(t.linvel, Vec3::ZERO);
    assert_eq!(t.pose.translation, Vec3::new(1.0, 0.0, 0.0));
}
