//! A blocky game character of rigid parts whose legs and arms are one part each (Kenney's
//! `torso`, `head`, `arm-left`, `arm-right`, `leg-left`, `leg-right`), turned four ways:
//! a humanoid whose trunk is its pelvis, whose whole legs are thighs and whole arms upper
//! arms, weighing what a person of its height weighs, that lands whole when dropped.
//!
//! Before, with no knee or elbow to find, it was a creature of chain links.

mod rigid_parts_files;

use glam::Vec3;
use ragdoll::backend::BackendKind;
use ragdoll::math::Transform;
use ragdoll::spec::{self, BuildOptions, JointKind, Role, build_spec, humanoid_mass_kg};
use ragdoll::world::{World, WorldSettings};
use rigid_parts_files::{BLOCKY_HEIGHT_M, blocky, blocky_turned, load_as};

const FACINGS: [f32; 4] = [0.0, 90.0, 180.0, 270.0];

#[test]
fn a_blocky_character_is_a_humanoid_of_whole_limbs() {
    for facing in FACINGS {
        let what = format!("blocky facing {facing}°");
        let c = load_as("blocky.glb", &blocky(facing));
        let roles = spec::recognise_roles(&c);
        assert!(roles.humanoid, "{what}: {}", roles.why);
        let on = |role: Role| {
            let j = roles
                .joint(role)
                .unwrap_or_else(|| panic!("{what}: no {role:?}"));
            c.skeleton.joints()[j].name.clone()
        };
        let trunk = roles.joint(Role::Pelvis).or(roles.joint(Role::Chest));
        let trunk = trunk.map(|j| c.skeleton.joints()[j].name.as_str());
        assert_eq!(trunk, Some("torso"), "{what}");
        for (role, name) in [
            (Role::Head, "head"),
            (Role::ThighL, "leg-left"),
            (Role::ThighR, "leg-right"),
            (Role::UpperArmL, "arm-left"),
            (Role::UpperArmR, "arm-right"),
        ] {
            assert_eq!(on(role), name, "{what}: {role:?}");
        }
        for role in [
            Role::ShinL,
            Role::ShinR,
            Role::FootL,
            Role::FootR,
            Role::ForearmL,
            Role::ForearmR,
            Role::HandL,
            Role::HandR,
        ] {
            assert_eq!(roles.joint(role), None, "{what}: {role:?}");
        }
        for (role, why) in roles.missing() {
            let said = role == Role::Neck || why.contains("one part");
            assert!(said, "{what}: {role:?} missing: {why}");
        }
    }
}

/// Lying in its file (a Z-up export, face up or face down, or on either side), it is
/// stood up and recognised as standing: the same parts take the same roles.
#[test]
fn a_blocky_character_lying_down_is_stood_up_and_recognised() {
    use glam::Quat;
    use std::f32::consts::FRAC_PI_2;
    let lying = [
        ("face up", Quat::from_rotation_x(FRAC_PI_2)),
        ("face down", Quat::from_rotation_x(-FRAC_PI_2)),
        ("on its left side", Quat::from_rotation_z(FRAC_PI_2)),
        ("on its right side", Quat::from_rotation_z(-FRAC_PI_2)),
    ];
    for (what, turn) in lying {
        let c = load_as("blocky.glb", &blocky_turned(turn));
        let roles = spec::recognise_roles(&c);
        assert!(roles.humanoid, "{what}: {}", roles.why);
        assert!(roles.upright.is_some(), "{what}: stood up");
        let name = |role: Role| {
            let j = roles
                .joint(role)
                .unwrap_or_else(|| panic!("{what}: no {role:?}"));
            c.skeleton.joints()[j].name.clone()
        };
        for (role, part) in [
            (Role::Head, "head"),
            (Role::ThighL, "leg-left"),
            (Role::ThighR, "leg-right"),
            (Role::UpperArmL, "arm-left"),
            (Role::UpperArmR, "arm-right"),
        ] {
            assert_eq!(name(role), part, "{what}: {role:?}");
        }
        // Its ragdoll weighs what a person of its height does, as standing.
        let spec = build_spec(&c, &BuildOptions::default()).unwrap();
        let expected = humanoid_mass_kg(BLOCKY_HEIGHT_M);
        assert!(
            (spec.total_mass_kg() - expected).abs() < 0.02 * expected,
            "{what}: {} kg, a person of its height {expected} kg",
            spec.total_mass_kg()
        );
    }
}

#[test]
fn a_blocky_characters_ragdoll_weighs_a_person_and_swings_at_hips_and_shoulders() {
    for facing in FACINGS {
        let what = format!("blocky facing {facing}°");
        let c = load_as("blocky.glb", &blocky(facing));
        let spec = build_spec(&c, &BuildOptions::default()).unwrap();
        assert_eq!(spec.bodies.len(), 6, "{what}: one body per part");
        let total: f32 = spec.bodies.iter().map(|b| b.mass_kg).sum();
        let want = humanoid_mass_kg(BLOCKY_HEIGHT_M);
        assert!(
            (total - want).abs() < 1e-3 * want,
            "{what}: {total} kg, not {want}"
        );
        let mass = |bone: &str| {
            spec.bodies
                .iter()
                .find(|b| b.bone == bone)
                .unwrap_or_else(|| panic!("{what}: no body on {bone}"))
                .mass_kg
        };
        // A whole leg weighs thigh, shank and foot: about a sixth of the body; a whole
        // arm about a twentieth, raised toward the trunk it hangs from so the pair's mass
        // ratio stays solvable.
        for leg in ["leg-left", "leg-right"] {
            let share = mass(leg) / total;
            assert!((0.17..0.2).contains(&share), "{what}: {leg} {share}");
        }
        for arm in ["arm-left", "arm-right"] {
            let share = mass(arm) / total;
            assert!((0.045..0.1).contains(&share), "{what}: {arm} {share}");
        }
        for j in &spec.joints {
            assert!(
                matches!(j.kind, JointKind::SwingTwist { .. }),
                "{what}: {} is {:?}",
                j.child,
                j.kind
            );
        }
        assert_eq!(spec.joints.len(), 5, "{what}");
    }
}

#[test]
fn a_dropped_blocky_character_lands_whole() {
    let h = BLOCKY_HEIGHT_M;
    for facing in FACINGS {
        let c = load_as("blocky.glb", &blocky(facing));
        let spec = build_spec(&c, &BuildOptions::default()).unwrap();
        for backend in [BackendKind::Rigid, BackendKind::Fast] {
            let what = format!("blocky facing {facing}° on {backend:?}");
            let settings = WorldSettings {
                backend: backend.into(),
                ..Default::default()
            };
            let mut world = World::new(&settings).unwrap();
            let id = world
                .add_ragdoll(&c, &spec, Transform::from_translation(Vec3::Y * 0.3))
                .unwrap();
            let mut lowest = f32::INFINITY;
            for _ in 0..20 {
                world.run(0.1);
                let poses = world.body_poses(id);
                lowest = poses.iter().map(|t| t.translation.y).fold(lowest, f32::min);
            }
            let m = world.metrics();
            println!("{what}: lowest body {lowest} m, {m:?}");
            assert!(!m.nan, "{what}");
            assert!(lowest > -0.04 * h, "{what}: a body at {lowest} m");
            assert!(m.max_joint_separation_m < 0.005 * h / 1.75, "{what}: {m:?}");
        }
    }
}
