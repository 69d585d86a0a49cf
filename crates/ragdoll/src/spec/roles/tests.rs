//! Role recognition: the built-in humanoid at any yaw, names that give the facing where
//! the geometry cannot, and chains and quadrupeds that are no humanoids.

use crate::skeleton::Skeleton;
use glam::Quat;

use super::*;
use crate::skeleton::humanoid;

/// `c` turned by `yaw` about the vertical through the origin.
pub(crate) fn yawed(c: &Character, yaw: f32) -> Character {
    c.turned(yaw)
}

#[test]
fn spec_roles_builtin_humanoid_exact() {
    let c = humanoid();
    let roles = recognise_roles(&c);
    assert!(roles.humanoid);
    for (i, j) in c.skeleton.joints().iter().enumerate() {
        assert_eq!(
            roles.per_joint[i].map(Role::as_str),
            Some(j.name.as_str()),
            "joint {}",
            j.name
        );
    }
    assert!(
        (roles.forward - Vec3::Z).length() < 1e-5,
        "{:?}",
        roles.forward
    );
    assert!((roles.left() - Vec3::X).length() < 1e-5);
    // The toes' end site (3 cm up) is the lowest point the skeleton knows of.
    assert!((roles.height_m - 1.72).abs() < 1e-4, "{}", roles.height_m);
}

#[test]
fn spec_roles_builtin_humanoid_any_yaw() {
    let c = humanoid();
    let base = recognise_roles(&c);
    for k in 0..8 {
        let yaw = (k as f32 * 45.0).to_radians();
        let r = recognise_roles(&yawed(&c, yaw));
        assert_eq!(r.per_joint, base.per_joint, "yaw {}", k * 45);
        let f = Quat::from_rotation_y(yaw) * Vec3::Z;
        assert!(
            (r.forward - f).length() < 1e-4,
            "yaw {}: {:?}",
            k * 45,
            r.forward
        );
    }
}

#[test]
fn spec_roles_names_give_facing_when_geometry_cannot() {
    // Feet pointing straight down and straight knees: only the names tell left from
    // right. Mirror the built-in humanoid's left/right names onto a skeleton whose
    // geometry is symmetric front/back and check the names decide.
    let c = humanoid();
    let mut joints = c.skeleton.joints().to_vec();
    for j in &mut joints {
        if j.name.starts_with("foot") {
            j.tip = Some(Vec3::new(0.0, -0.06, 0.0));
        }
        j.name = match j.name.as_str() {
            "thigh_l" => "LeftUpLeg".into(),
            "thigh_r" => "RightUpLeg".into(),
            "upper_arm_l" => "lShldr".into(),
            "upper_arm_r" => "rShldr".into(),
            _ => j.name.clone(),
        };
    }
    let mut c2 = c.clone();
    c2.skeleton = Skeleton::new(joints).unwrap();
    for k in [0, 3, 5] {
        let yaw = (k as f32 * 45.0).to_radians();
        let r = recognise_roles(&yawed(&c2, yaw));
        assert!(r.humanoid);
        let s = &c2.skeleton;
        assert_eq!(
            r.per_joint[s.find("LeftUpLeg").unwrap()],
            Some(Role::ThighL)
        );
        assert_eq!(
            r.per_joint[s.find("rShldr").unwrap()],
            Some(Role::UpperArmR)
        );
        let f = Quat::from_rotation_y(yaw) * Vec3::Z;
        assert!(
            (r.forward - f).length() < 1e-4,
            "yaw {}: {:?}",
            k * 45,
            r.forward
        );
    }
}

fn chain(points: &[Vec3]) -> Character {
    let mut joints = Vec::new();
    let mut prev = Vec3::ZERO;
    for (i, p) in points.iter().enumerate() {
        joints.push(crate::skeleton::Joint {
            name: format!("link{i}"),
            parent: i.checked_sub(1),
            rest: Transform::from_translation(*p - prev),
            tip: None,
        });
        prev = *p;
    }
    Character {
        humanoid_bones: Vec::new(),
        warnings: Vec::new(),
        name: "chain".into(),
        skeleton: Skeleton::new(joints).unwrap(),
        meshes: Vec::new(),
        clips: Vec::new(),
        source: crate::skeleton::Source::BuiltIn,
    }
}

#[test]
fn spec_roles_two_joint_chain_is_not_humanoid() {
    let c = chain(&[Vec3::ZERO, Vec3::new(0.0, 0.0, 0.15)]);
    let r = recognise_roles(&c);
    assert!(!r.humanoid);
    // The root bone is long; the bare leaf continues it by half.
    assert_eq!(r.per_joint, vec![Some(Role::Chain), Some(Role::Chain)]);
}

#[test]
fn spec_roles_single_joint_still_gets_a_body() {
    let c = chain(&[Vec3::new(0.0, 1.0, 0.0)]);
    let r = recognise_roles(&c);
    assert!(!r.humanoid);
    assert_eq!(r.per_joint, vec![Some(Role::Chain)]);
}

#[test]
fn spec_roles_quadruped_is_not_humanoid() {
    // A horizontal spine with four legs to the ground and a neck: the Fox's layout.
    let c = quadruped();
    let r = recognise_roles(&c);
    assert!(!r.humanoid);
    assert!(
        r.per_joint.iter().all(|x| *x == Some(Role::Chain)),
        "{:?}",
        r.per_joint
    );
    assert!((r.forward - Vec3::Z).length() < 1e-4, "{:?}", r.forward);
}

pub(crate) fn quadruped() -> Character {
    let rows: &[(&str, Option<usize>, Vec3)] = &[
        ("hip", None, Vec3::new(0.0, 0.45, -0.3)),
        ("spine", Some(0), Vec3::new(0.0, 0.5, 0.0)),
        ("chest", Some(1), Vec3::new(0.0, 0.5, 0.3)),
        ("neck", Some(2), Vec3::new(0.0, 0.6, 0.4)),
        ("head", Some(3), Vec3::new(0.0, 0.7, 0.5)),
        ("front_l", Some(2), Vec3::new(0.08, 0.45, 0.3)),
        ("front_l2", Some(5), Vec3::new(0.08, 0.2, 0.3)),
        ("front_l3", Some(6), Vec3::new(0.08, 0.0, 0.3)),
        ("front_r", Some(2), Vec3::new(-0.08, 0.45, 0.3)),
        ("front_r2", Some(8), Vec3::new(-0.08, 0.2, 0.3)),
        ("front_r3", Some(9), Vec3::new(-0.08, 0.0, 0.3)),
        ("back_l", Some(0), Vec3::new(0.08, 0.4, -0.3)),
        ("back_l2", Some(11), Vec3::new(0.08, 0.2, -0.3)),
        ("back_l3", Some(12), Vec3::new(0.08, 0.0, -0.3)),
        ("back_r", Some(0), Vec3::new(-0.08, 0.4, -0.3)),
        ("back_r2", Some(14), Vec3::new(-0.08, 0.2, -0.3)),
        ("back_r3", Some(15), Vec3::new(-0.08, 0.0, -0.3)),
        ("tail", Some(0), Vec3::new(0.0, 0.5, -0.5)),
    ];
    let joints = rows
        .iter()
        .map(|(name, parent, p)| crate::skeleton::Joint {
            name: (*name).into(),
            parent: *parent,
            rest: Transform::from_translation(*p - parent.map_or(Vec3::ZERO, |q| rows[q].2)),
            tip: None,
        })
        .collect();
    Character {
        humanoid_bones: Vec::new(),
        warnings: Vec::new(),
        name: "quadruped".into(),
        skeleton: Skeleton::new(joints).unwrap(),
        meshes: Vec::new(),
        clips: Vec::new(),
        source: crate::skeleton::Source::BuiltIn,
    }
}
