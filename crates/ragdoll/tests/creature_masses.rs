//! Creatures are weighed by the volume their skin encloses (issue 11 items 4 and 7): a
//! closed skin of known volume weighs that volume times the body density, whatever its
//! bodies' shapes; an open skin falls back to the shapes; mass grows with the cube of
//! the scale.

mod common;

use glam::{Vec3, Vec4};
use ragdoll::import::{ImportOptions, Units, load};
use ragdoll::math::Transform;
use ragdoll::skeleton::{Character, Joint, Skeleton, SkinnedMesh, Source};
use ragdoll::spec::{BuildOptions, RagdollSpec, build_spec};

/// The builder's creature density (`BODY_DENSITY_KG_M3`, private to the crate), kg/m³.
const BODY_DENSITY_KG_M3: f32 = 1000.0;

/// Bones along +X: three of `BONE` metres, the tube around them `SIDE` square.
const BONE: f32 = 0.2;
const SIDE: f32 = 0.1;
/// Rings of the tube per bone.
const RINGS_PER_BONE: usize = 2;

/// Which faces of the tube to leave out, for the open-skin cases.
#[derive(Clone, Copy, PartialEq)]
enum Hole {
    None,
    /// The far end cap: a small hole (4 % of the surface), as eyes or a mouth are.
    EndCap,
    /// One long side: a third of the tube's wall, no longer a closed skin.
    Side,
}

/// A three-bone worm lying along +X at `scale`, skinned to a square tube whose faces
/// carry split vertices (each face its own corners, as exporters write UV seams).
/// A worm is no humanoid: it is weighed as a creature.
fn worm(scale: f32, hole: Hole) -> Character {
    let s = scale;
    let y0 = 0.3 * s;
    let joints = (0..3)
        .map(|i| Joint {
            name: format!("seg{i}"),
            parent: (i > 0).then(|| i - 1),
            rest: Transform::from_translation(if i == 0 {
                Vec3::new(0.0, y0, 0.0)
            } else {
                Vec3::new(BONE * s, 0.0, 0.0)
            }),
            tip: (i == 2).then(|| Vec3::new(BONE * s, 0.0, 0.0)),
        })
        .collect();
    let h = 0.5 * SIDE * s;
    let rings = 3 * RINGS_PER_BONE;
    let ring = |i: usize| -> [Vec3; 4] {
        let x = i as f32 * BONE * s / RINGS_PER_BONE as f32;
        // Counter-clockwise seen from +X: the far cap faces out as listed.
        [(-h, -h), (-h, h), (h, h), (h, -h)].map(|(z, y)| Vec3::new(x, y0 + y, z))
    };
    let mut mesh = SkinnedMesh {
        name: "tube".into(),
        ..Default::default()
    };
    let quad = |m: &mut SkinnedMesh, q: [Vec3; 4]| {
        let base = m.positions.len() as u32;
        // Each face has its own corners, so the whole face follows the bone under its
        // centre and the bones split the tube evenly.
        let centre = q.iter().map(|p| p.x).sum::<f32>() / 4.0;
        let bone = ((centre / (BONE * s)).floor() as u16).min(2);
        for p in q {
            m.positions.push(p);
            m.joints.push([bone, 0, 0, 0]);
            m.weights.push(Vec4::X);
        }
        m.indices.extend([0, 1, 2, 0, 2, 3].map(|k| base + k));
    };
    for i in 0..rings {
        let (a, b) = (ring(i), ring(i + 1));
        for k in 0..4 {
            if hole == Hole::Side && k == 0 {
                continue;
            }
            let l = (k + 1) % 4;
            quad(&mut mesh, [a[l], b[l], b[k], a[k]]);
        }
    }
    let first = ring(0);
    quad(&mut mesh, [first[3], first[2], first[1], first[0]]);
    if hole != Hole::EndCap {
        quad(&mut mesh, ring(rings));
    }
    Character {
        name: "worm".into(),
        skeleton: Skeleton::new(joints).unwrap(),
        meshes: vec![mesh],
        clips: Vec::new(),
        humanoid_bones: Vec::new(),
        warnings: Vec::new(),
        source: Source::BuiltIn,
    }
}

fn spec(c: &Character) -> RagdollSpec {
    build_spec(c, &BuildOptions::default()).unwrap()
}

fn tube_kg(scale: f32) -> f32 {
    3.0 * BONE * SIDE * SIDE * scale.powi(3) * BODY_DENSITY_KG_M3
}

#[test]
fn creature_closed_skin_weighs_its_volume() {
    let s = spec(&worm(1.0, Hole::None));
    assert!(
        s.bodies
            .iter()
            .all(|b| b.role == Some(ragdoll::spec::Role::Chain))
    );
    let m = s.total_mass_kg();
    assert!(
        (m / tube_kg(1.0) - 1.0).abs() < 0.05,
        "{m} kg, tube {} kg",
        tube_kg(1.0)
    );
    // Each bone carries a third of the tube, so each body a third of the mass.
    for b in &s.bodies {
        let share = b.mass_kg / m;
        assert!((share - 1.0 / 3.0).abs() < 0.05, "{}: {share}", b.name);
    }
}

#[test]
fn creature_skin_with_a_small_hole_still_weighs_its_volume() {
    let m = spec(&worm(1.0, Hole::EndCap)).total_mass_kg();
    assert!((m / tube_kg(1.0) - 1.0).abs() < 0.05, "{m} kg");
}

#[test]
fn creature_open_skin_is_weighed_by_its_shapes() {
    let s = spec(&worm(1.0, Hole::Side));
    let shapes: f32 = s.bodies.iter().map(|b| b.shape.volume()).sum();
    let m = s.total_mass_kg();
    assert!((m - shapes * BODY_DENSITY_KG_M3).abs() < 1e-3 * m, "{m} kg");
}

#[test]
fn creature_mass_grows_with_the_cube_of_its_size() {
    for hole in [Hole::None, Hole::Side] {
        let small = spec(&worm(1.0, hole)).total_mass_kg();
        let big = spec(&worm(3.0, hole)).total_mass_kg();
        assert!((big / small / 27.0 - 1.0).abs() < 1e-3, "{small} → {big}");
    }
}

#[test]
#[ignore = "needs ../shared/data"]
fn creature_fox_in_centimetres_is_weighed_by_its_skin() {
    let path = common::shared_data().join("gltf/Fox.glb");
    let load_in = |units| {
        let opts = ImportOptions {
            units: Some(units),
            ..Default::default()
        };
        load(&path, &opts).unwrap()
    };
    let fox = load_in(Units::Cm);
    let m = spec(&fox).total_mass_kg();
    // The enclosed volume, summed here without welding or capping: the Fox's skin is
    // closed, so the plain divergence-theorem sum is exact.
    let mesh = &fox.meshes[0];
    let v: f32 = mesh
        .indices
        .chunks_exact(3)
        .map(|t| {
            let [a, b, c] = [0, 1, 2].map(|k| mesh.positions[t[k] as usize]);
            a.dot(b.cross(c)) / 6.0
        })
        .sum();
    assert!(
        (m / (v.abs() * BODY_DENSITY_KG_M3) - 1.0).abs() < 0.01,
        "{m} kg, {v} m³"
    );
    // Not the 95 kg of the loose capsules it was weighed by before.
    assert!(m < 80.0, "{m} kg");
    let mm = spec(&load_in(Units::Mm)).total_mass_kg();
    assert!(
        (m / mm / 1000.0 - 1.0).abs() < 1e-3,
        "{m} kg at cm, {mm} kg at mm"
    );
}
