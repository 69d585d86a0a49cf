//! A humanoid's mass follows its size: a giant in its file's units is heavy, and a blast
//! throws it as physics says rather than as if it weighed what a person does.

use glam::Vec3;
use ragdoll::events::Blast;
use ragdoll::import::humanoid_of_height;
use ragdoll::spec::{BuildOptions, build_spec, humanoid_mass_kg, recognise_roles};
use ragdoll::world::{World, WorldSettings};

/// Centre-of-mass speed of the built-in humanoid scaled to `height` m, in free space, after
/// `tnt_kg` of TNT goes off `distance` m in front of its chest.
fn thrown(height: f32, tnt_kg: f32, distance: f32) -> (f32, f32) {
    let character = humanoid_of_height(height).unwrap();
    let spec = build_spec(&character, &BuildOptions::default()).unwrap();
    let settings = WorldSettings {
        gravity: Vec3::ZERO,
        ground: None,
        ..Default::default()
    };
    let (mut world, _) = World::with_ragdoll(&character, &spec, &settings).unwrap();
    let chest = Vec3::new(0.0, 0.75 * height, distance);
    world.add_blast(Blast::new(tnt_kg, chest, 0.0)).unwrap();
    world.run(0.5);
    let v = world.blast_reports()[0].characters[0]
        .com_velocity_mps
        .expect("the blast has passed");
    (Vec3::from_array(v).length(), spec.total_mass_kg())
}

#[test]
fn a_humanoid_weighs_as_its_volume() {
    for (h, kg) in [(1.75, 75.0), (0.9, 10.2), (3.5, 600.0), (5.6, 2457.6)] {
        let c = humanoid_of_height(h).unwrap();
        let spec = build_spec(&c, &BuildOptions::default()).unwrap();
        let m = spec.total_mass_kg();
        assert!((m / kg - 1.0).abs() < 0.005, "{h} m: {m} kg, want {kg}");
        assert!(
            (m / humanoid_mass_kg(h) - 1.0).abs() < 1e-4,
            "{h} m: {m} kg"
        );
        // A mass given outright is kept whatever the size.
        let given = BuildOptions {
            total_mass_kg: Some(80.0),
            ..Default::default()
        };
        let m = build_spec(&c, &given).unwrap().total_mass_kg();
        assert!((m - 80.0).abs() < 1e-3, "{h} m: {m} kg given 80");
    }
}

/// The knight of the report: 5.6 m tall in its file. 5 kg of TNT threw it at 229 m/s as
/// a 75 kg figure; as the 2.5 t it is at that size, far slower than a person at a distance
/// scaled with it (the load grows as its area, the mass as its volume), and it is told
/// how tall it is.
#[test]
fn a_giant_is_heavy_and_thrown_slower_than_a_person() {
    let (person, person_kg) = thrown(1.8, 5.0, 3.0);
    let (giant, giant_kg) = thrown(5.6, 5.0, 3.0 * 5.6 / 1.8);
    assert!(giant_kg > 2000.0, "{giant_kg} kg");
    assert!(person_kg > 70.0 && person_kg < 90.0, "{person_kg} kg");
    assert!(
        giant < 0.5 * person && giant < 20.0,
        "giant {giant} m/s, person {person} m/s"
    );
    let roles = recognise_roles(&humanoid_of_height(5.6).unwrap());
    let w = roles.warning.expect("a warning for a 5.6 m humanoid");
    assert!(roles.height_m > 5.0, "{}", roles.height_m);
    assert!(w.contains(&format!("{:.2} m tall", roles.height_m)), "{w}");
}
