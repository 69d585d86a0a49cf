//! A body's extra shapes (`BodySpec::extra_shapes`): on every backend they collide as the
//! body's own shape does (with the ground, with other ragdolls, with shots), and carry no
//! mass; in a spec file they are checked like the body's own shape.

mod common;

use std::path::Path;

use glam::{Quat, Vec3};
use ragdoll::events::Projectile;
use ragdoll::skeleton::Character;
use ragdoll::spec::{ExtraShape, MAX_EXTRA_SHAPES, RagdollSpec, Shape};
use ragdoll::world::{BackendKind, World, WorldSettings};

/// The bar of [`common::one_capsule`] (a 0.2 m capsule, its centre 1 m up) with `extras`
/// placed in its bone's frame (the bar's centre, axes as the world's).
fn bar_with(extras: Vec<ExtraShape>) -> (Character, RagdollSpec) {
    let (character, mut spec) = common::one_capsule(0.05, 0.1, 2.0);
    spec.bodies[0].extra_shapes = extras;
    spec.validate().unwrap();
    (character, spec)
}

/// A flat box `size` centred at `at` in the bar's bone frame.
fn plate(size: [f32; 3], at: [f32; 3]) -> ExtraShape {
    ExtraShape {
        shape: Shape::Box { size_m: size },
        center_m: at,
        rotation: [0.0, 0.0, 0.0, 1.0],
    }
}

fn settings(backend: BackendKind) -> WorldSettings {
    WorldSettings {
        backend: backend.into(),
        ..Default::default()
    }
}

/// The ragdoll `spec` of `c` floating in zero gravity, 0.3 s after a 1 N·s shot (10 g at
/// 100 m/s) along -Z through the point `x` metres along X, 1 m up.
fn shot_floating(
    c: &Character,
    spec: &RagdollSpec,
    backend: BackendKind,
    x: f32,
) -> (World, ragdoll::world::RagdollId) {
    let s = WorldSettings {
        gravity: Vec3::ZERO,
        ground: None,
        ..settings(backend)
    };
    let (mut world, id) = World::with_ragdoll(c, spec, &s).unwrap();
    world
        .add_projectile(Projectile {
            origin: Vec3::new(x, 1.0, 2.0),
            direction: -Vec3::Z,
            mass_kg: 0.01,
            speed_mps: 100.0,
            time_s: 0.05,
        })
        .unwrap();
    world.run(0.3);
    (world, id)
}

#[test]
fn a_body_rests_on_its_extra_shape() {
    // A plate 0.4 m below the bar's centre: the bar lands on it and stands 0.45 m up
    // (half the plate's 0.1 m, then 0.4 m), where without it its capsule would lie on
    // the floor, its centre 0.05 m up.
    for backend in BackendKind::ALL {
        let (c, spec) = bar_with(vec![plate([0.4, 0.1, 0.4], [0.0, -0.4, 0.0])]);
        let (mut world, id) = World::with_ragdoll(&c, &spec, &settings(backend)).unwrap();
        world.run(3.0);
        let pose = world.body_poses(id)[0];
        let name = backend.as_str();
        assert!(
            (pose.translation.y - 0.45).abs() < 0.01,
            "{name}: the bar's centre is {} m up",
            pose.translation.y
        );
        let tilt = (pose.rotation * Vec3::Y)
            .angle_between(Vec3::Y)
            .to_degrees();
        assert!(tilt < 2.0, "{name}: the bar tipped {tilt}°");
        assert!(!world.metrics().nan, "{name}");
    }
}

#[test]
fn extra_shapes_share_the_mass_and_widen_the_inertia() {
    // A 2 kg ball of radius 0.1 m with a 10 cm cube half a metre to its side, floating in
    // zero gravity, shot off-centre (1 N·s along -Z, 5 cm left of the ball's centre): the
    // mass, spread over the two by volume, still takes 0.5 m/s from the shot, and the spin
    // is the shot's angular impulse (0.05 N·m·s about Y) over the moment about Y of the
    // ball's share and the cube's, 0.483 rad/s; without the cube, 6.25 rad/s.
    let (r, side, d) = (0.1f32, 0.1f32, 0.5f32);
    let (v_ball, v_cube) = (4.0 / 3.0 * std::f32::consts::PI * r.powi(3), side.powi(3));
    let (m_ball, m_cube) = (
        2.0 * v_ball / (v_ball + v_cube),
        2.0 * v_cube / (v_ball + v_cube),
    );
    let moment = 0.4 * m_ball * r * r + m_cube * (2.0 * side * side / 12.0 + d * d);
    let want = 0.05 / moment;
    for backend in BackendKind::ALL {
        let (c, mut spec) = common::one_capsule(r, 0.0, 2.0);
        spec.bodies[0].extra_shapes = vec![plate([side; 3], [d, 0.0, 0.0])];
        let (world, id) = shot_floating(&c, &spec, backend, 0.05);
        let (v, w) = world.body_velocities(id)[0];
        let name = backend.as_str();
        assert!((v.z + 0.5).abs() < 0.01 * 0.5, "{name}: {v} m/s");
        if backend == BackendKind::Particle {
            // Its bodies carry their inertia on particles along the bone, the moment
            // about it on one side particle of at most 15 % of the mass: the cube slows
            // the spin (4.1 rad/s), but not to the full moment's. Laid out to carry the
            // whole tensor (Routh's equimomental set), the dragon dragged by its head came
            // 2 cm out of its joints.
            assert!(w.y < 0.9 * 6.25, "{name}: {w} rad/s");
        } else {
            assert!(
                (w.y - want).abs() < 0.01 * want && w.x.abs() + w.z.abs() < 0.01 * want,
                "{name}: {w} rad/s, want {want} about Y"
            );
        }
    }
}

#[test]
fn another_ragdoll_lands_on_extra_shapes() {
    // A 20 kg bar standing on a wide plate (as above), with two logs lying on the plate
    // 16 cm apart beside its own capsule: a ball dropped over the gap comes to rest on the
    // two logs, 0.229 m up (the logs' centres 0.14 m up, the ball's 12 cm from each), not
    // on the plate (0.18 m) or the floor (0.08 m). Logs rather than the plate alone: the
    // particle backend meets another body with the capsule inside a box, a rod along the
    // plate that a ball rolls off.
    let log = |x: f32| ExtraShape {
        shape: Shape::Capsule {
            radius_m: 0.04,
            length_m: 0.6,
        },
        center_m: [x, -0.31, 0.0],
        rotation: Quat::from_rotation_x(std::f32::consts::FRAC_PI_2).to_array(),
    };
    for backend in BackendKind::ALL {
        // A thicker bar than the others, with a body's inertia: on the particle backend a
        // 2 kg pencil on a massless plate 0.4 m under it hopped on the plate as the ball
        // came down and threw it off.
        let (c, mut spec) = common::one_capsule(0.1, 0.4, 20.0);
        spec.bodies[0].extra_shapes = vec![
            plate([1.2, 0.1, 1.2], [0.0, -0.4, 0.0]),
            log(0.22),
            log(0.38),
        ];
        let (ball_c, ball) = common::one_capsule(0.08, 0.0, 0.5);
        let mut world = World::new(&settings(backend)).unwrap();
        // Placed standing on its plate, 0.55 m lower than its bone (its plate at the floor).
        let on_floor = ragdoll::math::Transform::from_translation(Vec3::new(0.0, -0.55, 0.0));
        let bar = world.add_ragdoll(&c, &spec, on_floor).unwrap();
        let dropped = world
            .add_ragdoll(
                &ball_c,
                &ball,
                ragdoll::math::Transform::from_translation(Vec3::new(0.3, -0.3, 0.0)),
            )
            .unwrap();
        world.run(3.0);
        let name = backend.as_str();
        let y = world.body_poses(dropped)[0].translation.y;
        assert!((y - 0.229).abs() < 0.015, "{name}: the ball is {y} m up");
        let bar_y = world.body_poses(bar)[0].translation.y;
        assert!(
            (bar_y - 0.45).abs() < 0.015,
            "{name}: the bar is {bar_y} m up"
        );
    }
}

#[test]
fn a_shot_at_an_extra_shape_hits_its_body() {
    // A plate half a metre to the bar's side, floating in zero gravity: a shot through the
    // plate, which misses the bar's own capsule, hits the bar and hands it the shot's
    // momentum (1 N·s on 2 kg: 0.5 m/s).
    for backend in BackendKind::ALL {
        let (c, spec) = bar_with(vec![plate([0.2, 0.2, 0.2], [0.5, 0.0, 0.0])]);
        let (world, id) = shot_floating(&c, &spec, backend, 0.5);
        let name = backend.as_str();
        assert_eq!(
            world.projectile_reports()[0].body.as_deref(),
            Some("bar"),
            "{name}"
        );
        let v = world.body_velocities(id)[0].0;
        assert!(
            (v.z + 0.5).abs() < 0.01 && v.x.abs() < 0.01 && v.y.abs() < 0.01,
            "{name}: the bar moves at {v} m/s"
        );
    }
}

#[test]
fn a_spec_file_keeps_extra_shapes_and_checks_them() {
    let turned = Quat::from_rotation_z(0.3).to_array();
    let (_, spec) = bar_with(vec![
        plate([0.4, 0.1, 0.4], [0.0, -0.4, 0.0]),
        ExtraShape {
            shape: Shape::Capsule {
                radius_m: 0.03,
                length_m: 0.2,
            },
            center_m: [0.1, 0.0, 0.0],
            rotation: turned,
        },
    ]);
    let text = toml::to_string(&spec).unwrap();
    let back = RagdollSpec::from_toml(&text, Path::new("bar.toml")).unwrap();
    assert_eq!(back, spec);
    // A body without extra shapes writes none.
    let (_, plain) = bar_with(Vec::new());
    assert!(!toml::to_string(&plain).unwrap().contains("extra_shapes"));

    // A value out of bounds names the body, the shape and the key, on its line.
    let bad = text.replacen("radius_m = 0.03", "radius_m = 1e9", 1);
    let err = RagdollSpec::from_toml(&bad, Path::new("bar.toml"))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("body \"bar\".extra_shapes") && err.contains("[1].shape.radius_m"),
        "{err}"
    );
    let line = bad
        .lines()
        .position(|l| l.contains("extra_shapes"))
        .unwrap()
        + 1;
    assert!(err.contains(&format!("line {line}:")), "{err}");

    // More than a body may carry.
    let (_, mut many) = bar_with(Vec::new());
    many.bodies[0].extra_shapes = vec![plate([0.1; 3], [0.0; 3]); MAX_EXTRA_SHAPES + 1];
    let err = many.validate().unwrap_err().to_string();
    let limit = format!("more than the {MAX_EXTRA_SHAPES}");
    assert!(err.contains(&limit), "{err}");
}

/// Whether `shape` at `pose` holds the world point `p`, within `tolerance`.
fn holds(shape: &Shape, pose: &ragdoll::math::Transform, p: Vec3, tolerance: f32) -> bool {
    let q = pose.inverse().transform_point(p);
    match *shape {
        Shape::Capsule { radius_m, length_m } => {
            let y = q.y.clamp(-0.5 * length_m, 0.5 * length_m);
            q.distance(Vec3::new(0.0, y, 0.0)) <= radius_m + tolerance
        }
        Shape::Box { size_m } => {
            (q.abs() - Vec3::from_array(size_m) * 0.5).max_element() <= tolerance
        }
    }
}

#[test]
fn skin_no_bone_holds_half_of_gets_an_extra_shape_on_every_body_carrying_it() {
    // A creature of three bones in a row along X, 1 m up, its skin a tube round them
    // (each ring on its own bone) and a foot hanging 0.4 m under the middle that the
    // three bones share, a third each, as bone heat shares a dragon's feet: no body's own
    // shape reaches the foot, so each of the three holds it in an extra shape.
    use ragdoll::skeleton::{Joint, Skeleton, SkinnedMesh, Source};
    let joint = |name: &str, parent: Option<usize>, at: Vec3| Joint {
        name: name.into(),
        parent,
        rest: ragdoll::math::Transform::from_translation(at),
        tip: None,
    };
    let skeleton = Skeleton::new(vec![
        joint("a", None, Vec3::new(0.0, 1.0, 0.0)),
        joint("b", Some(0), Vec3::new(0.3, 0.0, 0.0)),
        joint("c", Some(1), Vec3::new(0.3, 0.0, 0.0)),
    ])
    .unwrap();
    let (mut positions, mut joints, mut weights) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..=24 {
        let x = 0.9 * i as f32 / 24.0;
        let bone = ((x / 0.3) as u16).min(2);
        for k in 0..12 {
            let a = std::f32::consts::TAU * k as f32 / 12.0;
            positions.push(Vec3::new(x, 1.0 + 0.08 * a.cos(), 0.08 * a.sin()));
            joints.push([bone, 0, 0, 0]);
            weights.push(glam::Vec4::X);
        }
    }
    let foot: Vec<Vec3> = (0..27)
        .map(|k| {
            let g = |d: usize| ((k / d) % 3) as f32 * 0.03;
            Vec3::new(0.42 + g(1), 0.55 + g(3), -0.03 + g(9))
        })
        .collect();
    for p in &foot {
        positions.push(*p);
        joints.push([0, 1, 2, 0]);
        weights.push(glam::Vec4::new(0.34, 0.33, 0.33, 0.0));
    }
    let character = Character {
        name: "three".into(),
        skeleton,
        meshes: vec![SkinnedMesh {
            name: "skin".into(),
            positions,
            joints,
            weights,
            ..Default::default()
        }],
        clips: Vec::new(),
        humanoid_bones: Vec::new(),
        warnings: Vec::new(),
        source: Source::BuiltIn,
    };
    let spec = ragdoll::spec::build_spec(&character, &Default::default()).unwrap();
    assert_eq!(spec.bodies.len(), 3);
    let rest = character.skeleton.rest_world();
    for (k, b) in spec.bodies.iter().enumerate() {
        let bone = rest[k];
        let frame = ragdoll::math::Transform::new(bone.translation, bone.rotation).mul(&b.frame());
        assert!(
            foot.iter().all(|p| !holds(&b.shape, &frame, *p, 0.0)),
            "body {}'s own shape reaches the foot",
            b.name
        );
        let extras = b.extra_offsets();
        assert!(!extras.is_empty(), "body {} has no extra shape", b.name);
        for p in &foot {
            assert!(
                extras
                    .iter()
                    .any(|(s, at)| holds(s, &frame.mul(at), *p, 1e-3)),
                "body {}'s extra shapes miss the foot's {p}",
                b.name
            );
        }
    }
}
