//! Passive joint damping ([`WorldSettings::joint_damping`]): a limb swinging from a still
//! body loses its swing as a viscously damped pendulum does, at the set rate; with the
//! damping off it keeps swinging. Rigid and fast backends for now: the particle backend refuses
//! it, and its undamped pendulum is measured for comparison.

use glam::{Quat, Vec3};
mod common;

use common::pin_at;
use ragdoll::math::Transform;
use ragdoll::skeleton::{Character, Joint};
use ragdoll::spec::{BodySpec, JointKind, JointSpec, RagdollSpec, SPEC_FORMAT_VERSION, Shape};
use ragdoll::world::{BackendKind, World, WorldSettings};

/// Bone length of each link, metres.
const LEN: f32 = 0.5;
/// Where the upper link hangs from.
const TOP: Vec3 = Vec3::new(0.0, 2.0, 0.0);

/// Two capsules joined by a free ball joint: the upper one heavy (100 kg, held still by
/// pins in the test), hanging straight down; the lower one a 1 kg pendulum along `dir`.
fn pendulum(dir: Vec3) -> (Character, RagdollSpec) {
    let dirs = [Vec3::NEG_Y, dir];
    let joints = (0..3)
        .map(|i| Joint {
            name: format!("j{i}"),
            parent: (i > 0).then(|| i - 1),
            rest: Transform::from_translation(if i == 0 { TOP } else { dirs[i - 1] * LEN }),
            tip: None,
        })
        .collect();
    let character = common::skeleton_character("pendulum", joints);
    let bodies = [100.0, 1.0]
        .iter()
        .enumerate()
        .map(|(i, &mass_kg)| BodySpec {
            name: format!("link{i}"),
            bone: format!("j{i}"),
            role: None,
            shape: Shape::Capsule {
                radius_m: 0.02,
                length_m: LEN,
            },
            center_m: (dirs[i] * (0.5 * LEN)).to_array(),
            rotation: Quat::from_rotation_arc(Vec3::Y, dirs[i]).to_array(),
            mass_kg,
            extra_shapes: Vec::new(),
        })
        .collect();
    let spec = RagdollSpec {
        format_version: SPEC_FORMAT_VERSION,
        name: "pendulum".into(),
        bodies,
        joints: vec![JointSpec {
            name: "link1".into(),
            parent: "link0".into(),
            child: "link1".into(),
            anchor_m: [0.0; 3],
            frame: Quat::from_rotation_arc(Vec3::X, dir).to_array(),
            kind: JointKind::Ball,
        }],
        collision: Default::default(),
    };
    spec.validate().unwrap();
    (character, spec)
}

/// Releases the pendulum 10° off the vertical with `damping` per second on `backend`, and
/// returns the decay rate of its swing (per second, from a least-squares line through the
/// logarithm of each turning point's angle).
fn swing_decay_rate(backend: BackendKind, damping: f32) -> f32 {
    let release = 10f32.to_radians();
    let dir = Vec3::new(release.sin(), -release.cos(), 0.0);
    let (character, spec) = pendulum(dir);
    let settings = WorldSettings {
        backend: backend.into(),
        ground: None,
        joint_damping: damping,
        ..Default::default()
    };
    let (mut world, id) = World::with_ragdoll(&character, &spec, &settings).unwrap();
    // Held at its top and its centre: the upper link cannot swing, only spin about its
    // own (vertical) axis, which the pendulum's swing does not turn.
    world.add_pin(id, pin_at("j0", TOP)).unwrap();
    world
        .add_pin(id, pin_at("link0", TOP - Vec3::Y * (0.5 * LEN)))
        .unwrap();
    world.run(0.0);
    let angle = |w: &World| {
        let d = w.body_poses(id)[1].rotation * Vec3::Y;
        d.x.atan2(-d.y)
    };
    let dt = settings.dt;
    let mut samples = vec![angle(&world)];
    for _ in 0..(4.0 / dt) as usize {
        world.step();
        samples.push(angle(&world));
    }
    assert!(!world.metrics().nan);
    // Turning points: where |angle| is a local maximum (the release counts as the first).
    let mut peaks = vec![(0.0f32, samples[0].abs())];
    for k in 1..samples.len() - 1 {
        let (a, b, c) = (samples[k - 1].abs(), samples[k].abs(), samples[k + 1].abs());
        if b > a && b >= c && b > 0.1 * release {
            peaks.push((k as f32 * dt, b));
        }
    }
    assert!(peaks.len() >= 5, "{backend:?}: turning points {peaks:?}");
    let n = peaks.len() as f32;
    let (mt, ml) = peaks
        .iter()
        .fold((0.0, 0.0), |(t, l), &(pt, a)| (t + pt / n, l + a.ln() / n));
    let (num, den) = peaks.iter().fold((0.0, 0.0), |(num, den), &(t, a)| {
        (num + (t - mt) * (a.ln() - ml), den + (t - mt).powi(2))
    });
    -num / den
}

#[test]
fn a_swinging_limb_decays_at_the_damping_rate_and_swings_on_without_it() {
    // A viscous couple c·I·ω on a pendulum of inertia I about its pivot: the amplitude
    // falls as exp(-c t / 2).
    let c = 1.5;
    for backend in [BackendKind::Rigid, BackendKind::Fast] {
        let rate = swing_decay_rate(backend, c);
        assert!(
            (rate - 0.5 * c).abs() < 0.15 * 0.5 * c,
            "{backend:?}: swing decays at {rate} per second, a damper of {c} gives {}",
            0.5 * c
        );
    }
    for backend in [BackendKind::Rigid, BackendKind::Fast, BackendKind::Particle] {
        let undamped = swing_decay_rate(backend, 0.0);
        assert!(
            undamped.abs() < 0.05,
            "{backend:?}: without damping the swing decays at {undamped} per second"
        );
    }
}

#[test]
fn the_particle_backend_refuses_joint_damping() {
    let settings = WorldSettings {
        backend: BackendKind::Particle.into(),
        joint_damping: 1.5,
        ..Default::default()
    };
    let err = settings.validate().unwrap_err().to_string();
    assert!(
        err.contains("joint_damping") && err.contains("rigid and fast"),
        "{err}"
    );
}

#[test]
fn joint_damping_out_of_range_is_refused() {
    for bad in [-1.0, f32::NAN, 1e6] {
        let settings = WorldSettings {
            joint_damping: bad,
            ..Default::default()
        };
        let err = settings.validate().unwrap_err().to_string();
        assert!(err.contains("joint_damping"), "{bad}: {err}");
    }
}
