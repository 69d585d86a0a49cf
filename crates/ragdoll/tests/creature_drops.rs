//! Creatures beyond quadrupeds and snakes: a spider, a bird with its
//! wings spread and a fish, skeletons without skin. A body that carries several limbs (the
//! spider's thorax, the bird's chest) is built big and heavy enough to hold them, and
//! dropped, each creature lands without sinking into the floor or flying apart, its
//! joints hold, and it comes to rest (the spider with the gaps [`KNOWN_GAPS`] names).
//!
//! Before, the spider's thorax was a 3 cm pencil of 0.3 kg carrying eight legs of 1.4 kg:
//! on landing rapier threw its bodies at 59 m/s and `fast` at 117 m/s, joints 0.3 and 1.3
//! m apart (and `fast` blew up even with every body 1 kg, in free fall).

mod common;

use glam::Vec3;
use ragdoll::backend::BackendKind;
use ragdoll::math::Transform;
use ragdoll::skeleton::Character;
use ragdoll::spec::{BuildOptions, RagdollSpec, Shape, build_spec};
use ragdoll::track::Metrics;
use ragdoll::world::{World, WorldSettings};

/// Adds a chain of joints from `parent` through `points`, named `{name}{i}`; returns the
/// rows of its joints.
fn chain(
    rows: &mut Vec<(String, Option<usize>, Vec3)>,
    parent: usize,
    name: &str,
    points: &[Vec3],
) -> Vec<usize> {
    let mut at = parent;
    let mut out = Vec::new();
    for (i, &p) in points.iter().enumerate() {
        rows.push((format!("{name}{i}"), Some(at), p));
        at = rows.len() - 1;
        out.push(at);
    }
    out
}

/// A spider facing +Z, legs spanning about 1 m: a cephalothorax and an abdomen, and eight
/// legs whose knees rise above the body and whose feet stand on the ground.
fn spider() -> Character {
    let mut rows = vec![
        ("thorax".to_string(), None, Vec3::new(0.0, 0.25, 0.05)),
        ("head".to_string(), Some(0), Vec3::new(0.0, 0.26, 0.15)),
        ("head_end".to_string(), Some(1), Vec3::new(0.0, 0.26, 0.22)),
        ("abdomen".to_string(), Some(0), Vec3::new(0.0, 0.26, -0.05)),
        (
            "abdomen_end".to_string(),
            Some(3),
            Vec3::new(0.0, 0.28, -0.3),
        ),
    ];
    for (k, fan) in [0.6f32, 0.2, -0.2, -0.6].iter().enumerate() {
        for side in [1.0f32, -1.0] {
            let dir = Vec3::new(side * fan.cos(), 0.0, fan.sin());
            let root = Vec3::new(side * 0.04, 0.25, 0.1 - 0.03 * k as f32);
            let knee = root + dir * 0.22 + Vec3::Y * 0.15;
            let foot = root + dir * 0.5 - Vec3::Y * 0.25;
            let s = if side > 0.0 { "l" } else { "r" };
            rows.push((format!("leg{k}{s}"), Some(0), root));
            let at = rows.len() - 1;
            chain(&mut rows, at, &format!("leg{k}{s}_"), &[knee, foot]);
        }
    }
    common::character_from_rows("spider", &rows)
}

/// A goose-sized bird facing +Z, wings spread level (span 1.5 m), neck raised, legs bent
/// at the knee forward and the heel back.
fn bird() -> Character {
    let mut rows = vec![
        ("hips".to_string(), None, Vec3::new(0.0, 0.45, 0.0)),
        ("chest".to_string(), Some(0), Vec3::new(0.0, 0.5, 0.15)),
    ];
    let neck = [
        Vec3::new(0.0, 0.6, 0.22),
        Vec3::new(0.0, 0.7, 0.25),
        Vec3::new(0.0, 0.8, 0.27),
        Vec3::new(0.0, 0.85, 0.3),
        Vec3::new(0.0, 0.84, 0.4),
    ];
    chain(&mut rows, 1, "neck", &neck);
    chain(
        &mut rows,
        0,
        "tail",
        &[Vec3::new(0.0, 0.45, -0.15), Vec3::new(0.0, 0.43, -0.3)],
    );
    for (side, s) in [(1.0f32, "l"), (-1.0, "r")] {
        let x = |v: f32| side * v;
        chain(
            &mut rows,
            0,
            &format!("leg_{s}"),
            &[
                Vec3::new(x(0.08), 0.42, 0.0),
                Vec3::new(x(0.1), 0.3, 0.08),
                Vec3::new(x(0.1), 0.15, -0.02),
                Vec3::new(x(0.1), 0.0, 0.05),
                Vec3::new(x(0.1), 0.0, 0.15),
            ],
        );
        chain(
            &mut rows,
            1,
            &format!("wing_{s}"),
            &[
                Vec3::new(x(0.1), 0.55, 0.15),
                Vec3::new(x(0.35), 0.56, 0.12),
                Vec3::new(x(0.55), 0.56, 0.16),
                Vec3::new(x(0.75), 0.55, 0.1),
            ],
        );
    }
    common::character_from_rows("bird", &rows)
}

/// A fish 1 m long swimming along +Z, dorsal side up, half a metre above the floor: a
/// spine of eight links to the tail fin, two pectoral fins and a dorsal fin.
fn fish() -> Character {
    let mut rows = vec![("head".to_string(), None, Vec3::new(0.0, 0.5, 0.4))];
    let spine: Vec<Vec3> = (1..=8)
        .map(|i| Vec3::new(0.0, 0.5, 0.4 - 0.11 * i as f32))
        .collect();
    let joints = chain(&mut rows, 0, "spine", &spine);
    rows.push(("snout".to_string(), Some(0), Vec3::new(0.0, 0.49, 0.55)));
    for (side, s) in [(1.0f32, "l"), (-1.0, "r")] {
        chain(
            &mut rows,
            joints[0],
            &format!("fin_{s}"),
            &[
                Vec3::new(side * 0.06, 0.46, 0.28),
                Vec3::new(side * 0.16, 0.42, 0.2),
            ],
        );
    }
    chain(
        &mut rows,
        joints[2],
        "dorsal",
        &[Vec3::new(0.0, 0.6, 0.15), Vec3::new(0.0, 0.7, 0.02)],
    );
    common::character_from_rows("fish", &rows)
}

/// The creatures, each dropped on every backend.
fn creatures() -> Vec<Character> {
    vec![spider(), bird(), fish()]
}

/// (creature, backend) drops that do not meet every bound below yet, whether they still
/// come to rest whole (joints within 2 cm, where they opened 0.3-1.3 m before hubs were
/// weighed and relaxed), and why. Otherwise only a finite result is asserted.
const KNOWN_GAPS: &[(&str, BackendKind, bool, &str)] = &[
    (
        "spider",
        BackendKind::Fast,
        true,
        "the end-of-step limit clamp turns legs the solver left up to 3° past their cones back \
         into the floor and lifts the spider out: 1.4 % energy gained in a frame (0.6 % \
         with `project_limits` off)",
    ),
    (
        "spider",
        BackendKind::Rigid,
        true,
        "the same clamp: 13 % energy gained (none with it off, but then rapier leaves its \
         limits 15° behind)",
    ),
    (
        "spider",
        BackendKind::Particle,
        false,
        "its legs fight its thorax: limits 32° past, joints 12 cm apart, still moving at \
         0.4 m/s after 4 s (joints open in free fall already; with 4 particle iterations \
         it lands whole, joints 2.7 cm, at rest, 6 % energy gained, while more substeps \
         make it worse)",
    ),
];

/// Strunk's rule as the builder keeps it (`MAX_LINKED_MASS_RATIO`, private).
const MAX_LINKED_MASS_RATIO: f32 = 5.0;

#[test]
fn creature_hubs_reach_around_their_limbs_and_outweigh_a_fifth_of_them() {
    for c in creatures() {
        let spec = build_spec(&c, &BuildOptions::default()).unwrap();
        let rest = c.skeleton.rest_world();
        let joint = |name: &str| {
            let k = c
                .skeleton
                .joints()
                .iter()
                .position(|j| j.name == name)
                .unwrap();
            rest[k]
        };
        let body = |name: &str| spec.bodies.iter().find(|b| b.name == name).unwrap();
        for hub in &spec.bodies {
            let children: Vec<&str> = spec
                .joints
                .iter()
                .filter(|j| j.parent == hub.name)
                .map(|j| j.child.as_str())
                .collect();
            if children.len() < 2 {
                continue;
            }
            let carried: f32 = children.iter().map(|&n| body(n).mass_kg).sum();
            assert!(
                hub.mass_kg >= carried / MAX_LINKED_MASS_RATIO * 0.999,
                "{}: {} of {} kg carries {carried} kg",
                c.name,
                hub.name,
                hub.mass_kg
            );
            // Every limb's root lies within the hub's radius of its axis.
            let Shape::Capsule { radius_m, .. } = hub.shape else {
                panic!("{}: {:?}", hub.name, hub.shape);
            };
            let bone = joint(&hub.bone);
            let centre = bone.transform_point(Vec3::from_array(hub.center_m));
            let axis = bone.rotation * glam::Quat::from_array(hub.rotation) * Vec3::Y;
            for &child in &children {
                let d = joint(&body(child).bone).translation - centre;
                let off = (d - axis * d.dot(axis)).length();
                assert!(
                    off <= radius_m + 1e-4,
                    "{}: {child}'s root is {off} m from {}'s axis, radius {radius_m}",
                    c.name,
                    hub.name
                );
            }
        }
    }
}

/// A spider's femur climbs from the body to the knee and its shin turns down to the
/// ground: the knee hinges in the plane of that bend, flexing further the way it bends,
/// whatever way the spider faces; the hip, hanging from the branching thorax, stays a cone.
#[test]
fn a_spiders_knees_hinge_the_way_they_bend() {
    use ragdoll::spec::JointKind;
    for yaw_deg in [0.0f32, 90.0, 200.0] {
        let c = spider().turned(yaw_deg.to_radians());
        let spec = build_spec(&c, &BuildOptions::default()).unwrap();
        let rest = c.skeleton.rest_world();
        let at = |name: &str| {
            let k = c.skeleton.joints().iter().position(|j| j.name == name);
            rest[k.unwrap_or_else(|| panic!("no joint {name}"))]
        };
        for leg in ["leg0l", "leg2r", "leg3l"] {
            let knee_name = format!("{leg}_0");
            let knee = spec.joints.iter().find(|j| j.child == knee_name).unwrap();
            let JointKind::Hinge { min_deg, max_deg } = knee.kind else {
                panic!("{yaw_deg}°: {knee_name} is {:?}", knee.kind);
            };
            assert!(
                min_deg < 0.0 && max_deg > 20.0,
                "{knee_name}: {min_deg}..{max_deg}"
            );
            // Turning the shin by a positive angle about the hinge bends the knee further.
            let (hip, k, foot) = (at(leg), at(&knee_name), at(&format!("{leg}_1")));
            let femur = (k.translation - hip.translation).normalize();
            let shin = (foot.translation - k.translation).normalize();
            let axis = k.rotation * glam::Quat::from_array(knee.frame) * Vec3::X;
            let bend = |deg: f32| {
                let turned = glam::Quat::from_axis_angle(axis, deg.to_radians()) * shin;
                femur.angle_between(turned).to_degrees()
            };
            assert!(bend(10.0) > bend(0.0) + 9.0, "{yaw_deg}° {knee_name}");
            let hip_joint = spec.joints.iter().find(|j| j.child == leg).unwrap();
            assert!(
                matches!(hip_joint.kind, JointKind::SwingTwist { .. }),
                "{leg}: {:?}",
                hip_joint.kind
            );
        }
    }
}

#[test]
fn creatures_land_whole_and_come_to_rest() {
    for c in creatures() {
        let spec = build_spec(&c, &BuildOptions::default()).unwrap();
        for backend in BackendKind::ALL {
            let (m, speed) = drop(&c, &spec, backend);
            let what = format!("{} on {backend:?}", c.name);
            println!("{what}: {speed:.3} m/s at 4 s, {m:?}");
            assert!(!m.nan && speed.is_finite(), "{what}");
            if let Some(&(.., whole, why)) = KNOWN_GAPS
                .iter()
                .find(|(name, b, ..)| *name == c.name && *b == backend)
            {
                println!("  known gap: {why}");
                if whole {
                    assert!(speed < 0.2, "{what}: still moving at {speed} m/s");
                    assert!(m.max_joint_separation_m < 0.02, "{what}: {m:?}");
                }
                continue;
            }
            assert!(speed < 0.2, "{what}: still moving at {speed} m/s");
            // Impacts: contacts 3 cm deep at most.
            assert!(m.max_penetration_m < 0.03, "{what}: {m:?}");
            // rapier's soft joints open 12-13 mm in the bench's piles (the guide's Benchmarks).
            let joint_gap = if backend == BackendKind::Rigid {
                0.015
            } else {
                0.01
            };
            assert!(m.max_joint_separation_m < joint_gap, "{what}: {m:?}");
            // A passive drop gains no energy (1 % for what one frame's rounding and the
            // contacts' restitution of zero leave).
            assert!(m.energy_drift < 0.01, "{what}: {m:?}");
        }
    }
}

/// `c` dropped from 30 cm above the floor for 4 s: the run's metrics and the fastest body
/// at the end, m/s.
fn drop(c: &Character, spec: &RagdollSpec, backend: BackendKind) -> (Metrics, f32) {
    let settings = WorldSettings {
        backend: backend.into(),
        ..Default::default()
    };
    let mut world = World::new(&settings).unwrap();
    let id = world
        .add_ragdoll(c, spec, Transform::from_translation(Vec3::Y * 0.3))
        .unwrap();
    world.run(4.0);
    let speed = world
        .body_velocities(id)
        .iter()
        .map(|(v, _)| v.length())
        .fold(0.0f32, f32::max);
    (world.metrics(), speed)
}
