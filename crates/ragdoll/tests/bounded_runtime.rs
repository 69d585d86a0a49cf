//! The runtime bounded by the world and physically right at its edges: broad
//! phases sized by the number of bodies, characters refused when they start inside each
//! other, early shots on the particle backend, a charge inside a body part, and runs that
//! go non-finite.

mod common;

use glam::{Quat, Vec3};
use ragdoll::events::{Blast, Projectile};
use ragdoll::math::Transform;
use ragdoll::skeleton::humanoid;
use ragdoll::spec::{BuildOptions, RagdollSpec, Shape, build_spec};
use ragdoll::world::{BackendKind, World, WorldSettings};

/// No gravity, no ground: only the event acts, so momentum is conserved.
fn free_space(backend: BackendKind) -> WorldSettings {
    WorldSettings {
        gravity: Vec3::ZERO,
        ground: None,
        backend: backend.into(),
        ..Default::default()
    }
}

fn humanoid_spec() -> RagdollSpec {
    build_spec(&humanoid(), &BuildOptions::default()).unwrap()
}

/// Total linear momentum of ragdoll 0's bodies, N·s.
fn momentum(world: &World, spec: &RagdollSpec, id: ragdoll::world::RagdollId) -> Vec3 {
    world
        .body_velocities(id)
        .iter()
        .zip(&spec.bodies)
        .map(|((v, _), b)| *v * b.mass_kg)
        .sum()
}

// ---------------------------------------------------------------------------------------
// Memory bounded by the number of bodies
// ---------------------------------------------------------------------------------------

#[test]
fn a_one_kilometre_body_keeps_the_particle_broad_phase_small() {
    // A pelvis capsule edited to a 1000 m radius made the particle broad phase
    // grow to 12 GB in 30 s and abort (0.7 m was enough to hang it). Specs now stop at
    // spec::MAX_SHAPE_M; at that size the grid must still hold a few cells per body.
    let character = humanoid();
    let mut spec = humanoid_spec();
    let pelvis = spec.body_index("pelvis").unwrap();
    spec.bodies[pelvis].shape = Shape::Capsule {
        radius_m: ragdoll::spec::MAX_SHAPE_M,
        length_m: 0.1,
    };
    let settings = WorldSettings {
        backend: BackendKind::Particle.into(),
        ..Default::default()
    };
    let (mut world, _) = World::with_ragdoll(&character, &spec, &settings).unwrap();
    world.run(0.1);
    let (entries, buckets) = world.broad_phase_footprint().unwrap();
    let bodies = spec.bodies.len();
    assert!(
        entries <= 27 * bodies,
        "{entries} grid entries for {bodies} bodies"
    );
    assert!(
        buckets <= 4 * 27 * bodies,
        "{buckets} buckets for {bodies} bodies"
    );
}

#[test]
fn ten_thousand_tonnes_of_tnt_keep_the_particle_broad_phase_small() {
    // Found: `blast --backend particle --tnt 1e7 --at 0,1,0` aborted on an 8 GiB
    // allocation: bodies thrown at kilometres a second grew their boxes, and the cells.
    let character = humanoid();
    let spec = humanoid_spec();
    let settings = WorldSettings {
        backend: BackendKind::Particle.into(),
        ..Default::default()
    };
    let (mut world, _) = World::with_ragdoll(&character, &spec, &settings).unwrap();
    world
        .add_blast(Blast::new(1.0e7, Vec3::new(0.0, 1.0, 0.0), 0.0))
        .unwrap();
    for _ in 0..12 {
        world.step();
        let (entries, _) = world.broad_phase_footprint().unwrap();
        assert!(entries <= 27 * spec.bodies.len(), "{entries} grid entries");
    }
}

// ---------------------------------------------------------------------------------------
// Characters inside each other
// ---------------------------------------------------------------------------------------

#[test]
fn characters_placed_inside_each_other_are_refused_naming_both() {
    // Found: 100 humanoids on one spot took 23 s and 768 MB, 200 over 3.7 GB (every
    // body in contact with every other). The second one on the spot is refused.
    for backend in BackendKind::ALL {
        let character = humanoid();
        let spec = humanoid_spec();
        let settings = WorldSettings {
            backend: backend.into(),
            ..Default::default()
        };
        let mut world = World::new(&settings).unwrap();
        world
            .add_ragdoll(&character, &spec, Transform::IDENTITY)
            .unwrap();
        let nudged = Transform::from_translation(Vec3::new(0.05, 0.0, 0.0));
        let err = world
            .add_ragdoll(&character, &spec, nudged)
            .expect_err("a humanoid 5 cm from another starts inside it")
            .to_string();
        assert!(
            err.contains("ragdoll 1 \"humanoid\"") && err.contains("ragdoll 0 \"humanoid\""),
            "{err}"
        );
        assert!(err.contains("body \"pelvis\""), "{err}");
        // The refused one left nothing behind; one a metre away is welcome.
        assert_eq!(world.ragdoll_count(), 1);
        let apart = Transform::from_translation(Vec3::new(1.0, 0.0, 0.0));
        world.add_ragdoll(&character, &spec, apart).unwrap();
        // Side by side, facing each other, close enough for the hands to touch.
        let facing = Transform::new(
            Vec3::new(0.0, 0.0, 0.45),
            Quat::from_rotation_y(std::f32::consts::PI),
        );
        world.add_ragdoll(&character, &spec, facing).unwrap();
        world.run(0.1);
        assert!(!world.metrics().nan);
    }
}

/// Two bodies "a" and "b" of one ragdoll, no joint between them, on one spot.
fn two_bodies_on_one_spot() -> (ragdoll::skeleton::Character, RagdollSpec) {
    let (character, mut spec) = common::one_capsule(0.1, 0.4, 5.0);
    let mut b = spec.bodies[0].clone();
    b.name = "b".into();
    b.center_m = [0.03, 0.0, 0.0];
    spec.bodies.push(b);
    (character, spec)
}

#[test]
fn a_ragdolls_own_parts_starting_inside_each_other_stop_colliding() {
    // Within one ragdoll the pose put the parts there (as at a hand-over): a contact would
    // throw them apart at metres a second. They stay still instead.
    for backend in BackendKind::ALL {
        let (character, spec) = two_bodies_on_one_spot();
        let (mut world, id) = World::with_ragdoll(&character, &spec, &free_space(backend)).unwrap();
        world.run(0.2);
        for (v, _) in world.body_velocities(id) {
            assert!(v.length() < 1e-3, "{backend:?}: a part moves at {v:?}");
        }
    }
}

#[test]
fn a_pile_of_one_ragdolls_bodies_on_one_spot_is_refused_naming_a_body() {
    // Found: a spec with 2,000 extra bodies on one spot ran past a minute (rapier's
    // contact graph costs the cube of a pile). 40 bodies on one spot are refused at once.
    let (character, mut spec) = common::one_capsule(0.1, 0.4, 5.0);
    for k in 1..40 {
        let mut b = spec.bodies[0].clone();
        b.name = format!("extra{k}");
        spec.bodies.push(b);
    }
    let err = World::with_ragdoll(&character, &spec, &WorldSettings::default())
        .err()
        .expect("40 bodies inside each other")
        .to_string();
    assert!(
        err.contains("body \"bar\"") && err.contains("inside 39 other bodies"),
        "{err}"
    );
    // 30 are allowed, and do not collide with each other.
    spec.bodies.truncate(30);
    let (mut world, id) =
        World::with_ragdoll(&character, &spec, &free_space(BackendKind::Rigid)).unwrap();
    world.run(0.1);
    assert!(
        world
            .body_velocities(id)
            .iter()
            .all(|(v, _)| v.length() < 1e-3)
    );
}

// ---------------------------------------------------------------------------------------
// Shots from the first step
// ---------------------------------------------------------------------------------------

#[test]
fn early_shots_hit_the_box_and_deliver_their_momentum_on_both_backends() {
    // Found: on the particle backend shots before about 0.1 s missed. The ray was cast
    // at the capsules inside the boxes: a shot at the chest's lower edge passed between
    // the chest's and the spine's capsules until the body sagged into its line. This one
    // is 7 cm above the chest's centre, where its capsule is 3 cm behind the box's face.
    let character = humanoid();
    let spec = humanoid_spec();
    let shot = |time_s: f32| Projectile {
        origin: Vec3::new(0.0, 1.43, 5.0),
        direction: -Vec3::Z,
        mass_kg: 0.05,
        speed_mps: 300.0,
        time_s,
    };
    for t in [0.0, 1.0 / 60.0, 0.05] {
        let mut hits = Vec::new();
        for backend in BackendKind::ALL {
            let (mut world, id) =
                World::with_ragdoll(&character, &spec, &free_space(backend)).unwrap();
            world.add_projectile(shot(t)).unwrap();
            world.run(t + 0.1);
            let report = &world.projectile_reports()[0];
            let point = report.point.expect("the shot hits");
            hits.push((report.body.clone(), Vec3::from_array(point)));
            // All of the shot's 15 N·s went into the ragdoll, along the shot.
            let p = momentum(&world, &spec, id);
            let expected = Vec3::new(0.0, 0.0, -15.0);
            assert!(
                (p - expected).length() < 0.15,
                "{backend:?} at {t} s: ragdoll momentum {p:?}, the shot carried {expected:?}"
            );
        }
        // Both hit one box on its front face, not a capsule a few centimetres behind it.
        let ((rigid, a), (particle, b)) = (&hits[0], &hits[1]);
        assert_eq!(rigid, particle, "at {t} s");
        assert!(
            (*a - *b).length() < 0.01,
            "at {t} s: rigid hit {a:?}, particle {b:?}"
        );
    }
}

// ---------------------------------------------------------------------------------------
// A charge inside a body part
// ---------------------------------------------------------------------------------------

/// Momentum of the one-capsule ragdoll (radius 0.1 m, length 0.6 m, 10 kg, centre 1 m up)
/// after 1 kg of TNT at `charge`.
fn capsule_thrown(backend: BackendKind, charge: Vec3) -> Vec3 {
    let (character, spec) = common::one_capsule(0.1, 0.6, 10.0);
    let (mut world, id) = World::with_ragdoll(&character, &spec, &free_space(backend)).unwrap();
    world.add_blast(Blast::new(1.0, charge, 0.0)).unwrap();
    world.run(0.05);
    momentum(&world, &spec, id)
}

#[test]
fn a_charge_inside_a_part_pushes_it_away_from_the_charge_and_nothing_at_its_centre() {
    let centre = Vec3::new(0.0, 1.0, 0.0);
    for backend in BackendKind::ALL {
        // At its centre the part is loaded equally all round: no net push (it took a full
        // contact load along world up before).
        let p = capsule_thrown(backend, centre);
        assert!(
            p.length() < 1.0,
            "{backend:?}: {p:?} N·s from a centred charge"
        );
        // Off the axis inside, it is pushed from the charge toward its centre (-X here),
        // more the nearer the charge is to the surface...
        let mid = capsule_thrown(backend, centre + Vec3::new(0.05, 0.0, 0.0));
        let skin = capsule_thrown(backend, centre + Vec3::new(0.099, 0.0, 0.0));
        assert!(
            mid.x < 0.0 && skin.x < mid.x,
            "{backend:?}: {mid:?} then {skin:?}"
        );
        assert!(mid.y.abs() < 0.05 * mid.x.abs(), "{backend:?}: {mid:?}");
        // ... and just beneath the surface as just outside it (a contact charge).
        let outside = capsule_thrown(backend, centre + Vec3::new(0.101, 0.0, 0.0));
        let jump = (skin - outside).length() / outside.length();
        assert!(
            jump < 0.05,
            "{backend:?}: {skin:?} inside, {outside:?} outside"
        );
    }
}

#[test]
fn a_charge_at_the_pelvis_loads_every_other_part_harder_than_from_a_metre_away() {
    // The parts around a contact charge receive far more than from the same charge a
    // metre in front. (The joints then carry those pushes between the parts: a ragdoll
    // does not come apart, so opposite pushes cancel; see the guide's Blasts and shots.)
    let character = humanoid();
    let spec = humanoid_spec();
    let received = |at: Vec3| {
        let (mut world, _) =
            World::with_ragdoll(&character, &spec, &free_space(BackendKind::Rigid)).unwrap();
        world.add_blast(Blast::new(1.0, at, 0.0)).unwrap();
        world.run(0.1);
        let report = world.blast_reports()[0].clone();
        report
            .parts
            .iter()
            .map(|p| (p.body.clone(), p.impulse_ns))
            .collect::<Vec<_>>()
    };
    let inside = received(Vec3::new(0.0, 1.0, 0.0));
    let metre = received(Vec3::new(0.0, 1.0, 1.0));
    for ((name, near), (_, far)) in inside.iter().zip(&metre) {
        if name == "pelvis" {
            continue; // holds the charge
        }
        assert!(
            near > far,
            "{name}: {near} N·s at the pelvis, {far} N·s a metre away"
        );
    }
}

// ---------------------------------------------------------------------------------------
// Far away
// ---------------------------------------------------------------------------------------

#[test]
fn positions_beyond_ten_kilometres_are_refused() {
    // Hostile but valid before: a ragdoll placed 1,000 km out came apart on the particle
    // backend (f32 positions there are 6 cm apart); one at 2^32 m made non-finite frames.
    use ragdoll::events::Pin;
    use ragdoll::world::MAX_COORDINATE_M;
    let character = humanoid();
    let spec = humanoid_spec();
    let far = Vec3::new(1.0e6, 0.0, 0.0);
    let settings = WorldSettings {
        backend: BackendKind::Particle.into(),
        ..Default::default()
    };
    let mut world = World::new(&settings).unwrap();
    let err = world
        .add_ragdoll(&character, &spec, Transform::from_translation(far))
        .expect_err("1,000 km out")
        .to_string();
    assert!(err.contains("body \"") && err.contains("10000 m"), "{err}");
    let near = Vec3::new(MAX_COORDINATE_M - 10.0, 0.0, 0.0);
    let id = world
        .add_ragdoll(&character, &spec, Transform::from_translation(near))
        .unwrap();
    let pin = Pin {
        target: "head".into(),
        keys: vec![(0.0, far)],
        stiffness_hz: Some(5.0),
        damping_ratio: 1.0,
        release_s: None,
    };
    assert!(world.add_pin(id, pin).is_err());
    assert!(world.add_blast(Blast::new(1.0, far, 0.0)).is_err());
    let shot = Projectile {
        origin: far,
        direction: -Vec3::X,
        mass_kg: 0.01,
        speed_mps: 300.0,
        time_s: 0.0,
    };
    assert!(world.add_projectile(shot).is_err());
    // Ten kilometres out a ragdoll still collapses onto the floor.
    world.run(1.0);
    assert!(!world.metrics().nan);
    let pelvis = world.body_poses(id)[0].translation;
    assert!(
        pelvis.y > 0.1 && pelvis.y < 0.8,
        "the pelvis ended at {pelvis:?}"
    );
}

#[test]
fn the_rigid_backend_refuses_a_ragdoll_off_the_edge_of_its_ground() {
    // Its ground is a square 500 m from the origin each way: a character placed 600 m out
    // fell forever on this backend (and landed on the particle backend's).
    let character = humanoid();
    let spec = humanoid_spec();
    let mut world = World::new(&WorldSettings::default()).unwrap();
    let out = Transform::from_translation(Vec3::new(0.0, 0.0, 600.0));
    let err = world
        .add_ragdoll(&character, &spec, out)
        .expect_err("off the ground")
        .to_string();
    assert!(
        err.contains("edge") && err.contains("particle or fast backend"),
        "{err}"
    );
    let on = Transform::from_translation(Vec3::new(0.0, 0.0, 490.0));
    let id = world.add_ragdoll(&character, &spec, on).unwrap();
    world.run(1.0);
    let pelvis = world.body_poses(id)[0].translation;
    assert!(
        pelvis.y > 0.1 && pelvis.y < 0.8,
        "the pelvis ended at {pelvis:?}"
    );
}

#[test]
fn a_hard_pin_a_kilometre_away_hauls_the_particle_ragdoll_without_blowing_it_up() {
    // The particle backend moved the pinned point onto a target 1 km away in one
    // projection; the distances that followed blew the ragdoll up (NaN). It is hauled.
    use ragdoll::events::Pin;
    let character = humanoid();
    let spec = humanoid_spec();
    let settings = WorldSettings {
        backend: BackendKind::Particle.into(),
        ..Default::default()
    };
    let (mut world, id) = World::with_ragdoll(&character, &spec, &settings).unwrap();
    let pin = Pin {
        target: "head".into(),
        keys: vec![(0.0, Vec3::new(1000.0, 1.7, 0.0))],
        stiffness_hz: None,
        damping_ratio: 1.0,
        release_s: None,
    };
    world.add_pin(id, pin).unwrap();
    world.run(0.5);
    assert!(!world.metrics().nan, "{:?}", world.metrics());
    let poses = world.body_poses(id);
    let head = poses[spec.body_index("head").unwrap()].translation;
    assert!(head.x > 100.0, "the head only got to {head:?}");
    // Dragged, not torn apart: every body within a body-length of the head.
    assert!(poses.iter().all(|p| (p.translation - head).length() < 2.5));
}

// ---------------------------------------------------------------------------------------
// Runs that go non-finite

#[test]
fn the_lightest_humanoid_allowed_collapses_without_going_non_finite() {
    // Hostile but valid: the particle backend floored a body's inertia about its bone at
    // 1e-9 kg·m², more than a milligram hand's whole tensor: its anchors got negative
    // masses and the run went NaN on its fourth step. The lightest humanoid a spec allows
    // has its lightest part at spec::MIN_BODY_KG (a humanoid of about 0.2 g).
    let character = humanoid();
    let one_kg = build_spec(
        &character,
        &BuildOptions {
            total_mass_kg: Some(1.0),
            ..Default::default()
        },
    )
    .unwrap();
    let lightest = one_kg
        .bodies
        .iter()
        .map(|b| b.mass_kg)
        .fold(f32::INFINITY, f32::min);
    let options = BuildOptions {
        total_mass_kg: Some(ragdoll::spec::MIN_BODY_KG / lightest * 1.001),
        ..Default::default()
    };
    let spec = build_spec(&character, &options).unwrap();
    for backend in BackendKind::ALL {
        let settings = WorldSettings {
            backend: backend.into(),
            ..Default::default()
        };
        let (mut world, id) = World::with_ragdoll(&character, &spec, &settings).unwrap();
        let start = world.body_poses(id)[0].translation.y;
        world.run(1.0);
        assert!(!world.metrics().nan, "{backend:?}: {:?}", world.metrics());
        let pelvis = world.body_poses(id)[0].translation.y;
        assert!(
            pelvis < start - 0.2 && pelvis > 0.0,
            "{backend:?}: pelvis at {pelvis} m"
        );
    }
}
