//! Stacks on the fast backend. A body that rests on another answers a push down as if it
//! were heavier (shock propagation: the floor behind it takes the push), which gives
//! momentum the bodies in contact do not share. The floor can give it only while the
//! stack presses on it: these tests hold the stack to that.

use glam::Vec3;
use ragdoll::backend::{
    Backend, BodyDesc, BodyId, BodyState, Command, FastBackend, FastConfig, Surroundings,
};
use ragdoll::math::Transform;
use ragdoll::spec::Shape;

const DT: f32 = 1.0 / 60.0;
const SIDE_M: f32 = 0.3;
const MASS_KG: f32 = 10.0;

/// `n` boxes of 10 kg and 30 cm stacked on the floor, each its own ragdoll, settled for
/// half a second.
fn stack(n: usize) -> (FastBackend, Vec<BodyId>) {
    let mut engine = FastBackend::new(
        &FastConfig::default(),
        &Surroundings {
            gravity: Vec3::new(0.0, -9.81, 0.0),
            ground: Some(0.0),
        },
    );
    let ids = (0..n)
        .map(|k| {
            let centre = Vec3::new(0.0, SIDE_M * (k as f32 + 0.5), 0.0);
            let body = BodyDesc {
                pose: Transform::from_translation(centre),
                shape: Shape::Box {
                    size_m: [SIDE_M; 3],
                },
                extra_shapes: Vec::new(),
                mass: MASS_KG,
                linvel: Vec3::ZERO,
                angvel: Vec3::ZERO,
            };
            engine.add_ragdoll(&[body], &[], &[])
        })
        .collect();
    for _ in 0..30 {
        engine.step(DT);
    }
    (engine, ids)
}

fn upward_momentum(engine: &FastBackend) -> f32 {
    let mut states: Vec<BodyState> = Vec::new();
    engine.body_states(&mut states);
    states.iter().map(|s| MASS_KG * s.linvel.y).sum()
}

/// The bottom box of a resting stack is struck up from below. It leaves the floor at
/// once, so nothing outside the stack pushes it up afterwards: the stack's momentum can
/// only fall from what the blow gave (gravity), and when it lands the floor only stops
/// it. While the floor's help reached rising bodies too, each box passed nearly all of
/// its speed on to the one above and kept nearly all of its own: stacks of eight rose
/// with up to 8.8 times the momentum they were given.
#[test]
fn a_stack_struck_from_below_rises_with_no_more_momentum_than_the_blow_gave() {
    for n in [3, 5, 8] {
        for kick_mps in [0.5f32, 1.0, 2.0, 4.0] {
            let (mut engine, ids) = stack(n);
            engine.apply(&[Command::Velocity {
                body: ids[0],
                linvel: Vec3::new(0.0, kick_mps, 0.0),
                angvel: Vec3::ZERO,
            }]);
            let given = MASS_KG * kick_mps;
            for step in 1..=6 {
                engine.step(DT);
                let p = upward_momentum(&engine);
                assert!(
                    p <= given,
                    "{n} boxes, bottom struck at {kick_mps} m/s: {p:.2} N·s up after step \
                     {step}, {given:.2} given"
                );
            }
        }
    }
}
