//! Extreme but allowed shapes: every body of the built-in humanoid edited to the viewer's
//! largest size (a ball 0.75 m across round each joint). Nothing pushes such a ragdoll but
//! gravity, so it may fall and fold but never gain energy; on the particle backend it flew
//! apart at 200 m/s and went non-finite (its parts started overlapping and were pushed
//! out within a substep; a ball round a joint kept almost no inertia about one axis).

use ragdoll::skeleton::humanoid;
use ragdoll::spec::{BuildOptions, RagdollSpec, Shape, build_spec};
use ragdoll::world::{BackendKind, World, WorldSettings};

/// The humanoid with every body's shape edited as the viewer does at its largest (radius
/// and length 0.45 and 0.1 of twice the largest body, centred on the joint), masses kept.
fn fattened(spec: &RagdollSpec) -> RagdollSpec {
    let (radius_m, length_m) = (0.374, 0.083);
    let mut spec = spec.clone();
    for b in &mut spec.bodies {
        b.shape = match b.shape {
            Shape::Capsule { .. } => Shape::Capsule { radius_m, length_m },
            Shape::Box { size_m } => Shape::Box {
                size_m: [size_m[0], length_m, size_m[2]],
            },
        };
        b.center_m = [0.0; 3];
    }
    spec
}

/// Runs the fattened humanoid for two seconds and checks, every step, that its kinetic
/// energy stays within what its fall released (1 J of slack for the solver's rounding).
fn never_gains_energy(backend: BackendKind) {
    let character = humanoid();
    let spec = fattened(&build_spec(&character, &BuildOptions::default()).unwrap());
    let settings = WorldSettings {
        backend: backend.into(),
        ..Default::default()
    };
    let (mut world, id) = World::with_ragdoll(&character, &spec, &settings).unwrap();
    let g = settings.gravity.length();
    let height = |world: &World| -> f32 {
        world
            .body_poses(id)
            .iter()
            .zip(&spec.bodies)
            .map(|(pose, body)| body.mass_kg * pose.translation.y)
            .sum()
    };
    let start = height(&world);
    for step in 0..120 {
        world.step();
        assert!(
            !world.metrics().nan,
            "{backend:?}: non-finite at step {step}"
        );
        let released = g * (start - height(&world));
        let kinetic: f32 = world
            .body_velocities(id)
            .iter()
            .zip(&spec.bodies)
            .map(|((v, _), body)| 0.5 * body.mass_kg * v.length_squared())
            .sum();
        assert!(
            kinetic <= released.max(0.0) + 1.0,
            "{backend:?}, step {step}: {kinetic} J of motion from a {released} J fall"
        );
    }
}

#[test]
fn the_viewers_largest_bodies_never_gain_energy_on_the_particle_backend() {
    never_gains_energy(BackendKind::Particle);
}

#[test]
fn the_viewers_largest_bodies_never_gain_energy_on_the_rigid_backend() {
    never_gains_energy(BackendKind::Rigid);
}
