//! The built-in default humanoid, so every command works with no file at all.

use glam::Vec3;

use super::{Character, Joint, Skeleton, Source};
use crate::math::Transform;

/// Standing height of the built-in humanoid, metres (top of the head above the soles).
pub const DEFAULT_HEIGHT_M: f32 = 1.75;

/// A 1.75 m humanoid standing on Y = 0, facing +Z (glTF's forward), its left side toward +X,
/// arms hanging 25° away from the body.
///
/// Seventeen joints with the role names the rest of the crate uses (`pelvis`, `thigh_l`, …),
/// proportions after Winter's segment lengths (Biomechanics and Motor Control of Human
/// Movement, 4th ed., fig. 4.1) rounded to the centimetre.
pub fn humanoid() -> Character {
    // (name, parent, world position of the joint, tip offset for leaves)
    let arm = Vec3::new(0.423, -0.906, 0.0); // unit vector, 65° below horizontal
    let mut rows: Vec<(&str, Option<&str>, Vec3, Option<Vec3>)> = vec![
        ("pelvis", None, Vec3::new(0.0, 0.95, 0.0), None),
        ("spine", Some("pelvis"), Vec3::new(0.0, 1.07, 0.0), None),
        ("chest", Some("spine"), Vec3::new(0.0, 1.25, 0.0), None),
        ("neck", Some("chest"), Vec3::new(0.0, 1.47, 0.0), None),
        (
            "head",
            Some("neck"),
            Vec3::new(0.0, 1.56, 0.0),
            Some(Vec3::new(0.0, 0.19, 0.0)),
        ),
    ];
    for (side, s) in [("l", 1.0f32), ("r", -1.0f32)] {
        let mirror = Vec3::new(s, 1.0, 1.0);
        let shoulder = Vec3::new(0.18, 1.43, 0.0);
        let elbow = shoulder + arm * 0.29;
        let wrist = elbow + arm * 0.26;
        let names = leak_names(side);
        rows.push((names[0], Some("chest"), shoulder * mirror, None));
        rows.push((names[1], Some(names[0]), elbow * mirror, None));
        rows.push((
            names[2],
            Some(names[1]),
            wrist * mirror,
            Some(arm * 0.18 * mirror),
        ));
        rows.push((
            names[3],
            Some("pelvis"),
            Vec3::new(0.09 * s, 0.91, 0.0),
            None,
        ));
        rows.push((
            names[4],
            Some(names[3]),
            Vec3::new(0.09 * s, 0.50, 0.0),
            None,
        ));
        rows.push((
            names[5],
            Some(names[4]),
            Vec3::new(0.09 * s, 0.08, 0.0),
            Some(Vec3::new(0.0, -0.05, 0.17)),
        ));
    }
    let mut joints: Vec<Joint> = Vec::with_capacity(rows.len());
    for (name, parent, pos, tip) in &rows {
        let parent = parent.map(|p| {
            joints
                .iter()
                .position(|j| j.name == p)
                .expect("parent row first")
        });
        let parent_pos = parent.map_or(Vec3::ZERO, |p| rows[p].2);
        joints.push(Joint {
            name: (*name).to_string(),
            parent,
            rest: Transform::from_translation(*pos - parent_pos),
            tip: *tip,
        });
    }
    Character {
        humanoid_bones: Vec::new(),
        warnings: Vec::new(),
        name: "humanoid".into(),
        skeleton: Skeleton::new(joints).expect("the built-in humanoid is well formed"),
        meshes: Vec::new(),
        clips: Vec::new(),
        source: Source::BuiltIn,
    }
}

fn leak_names(side: &str) -> [&'static str; 6] {
    if side == "l" {
        [
            "upper_arm_l",
            "forearm_l",
            "hand_l",
            "thigh_l",
            "shin_l",
            "foot_l",
        ]
    } else {
        [
            "upper_arm_r",
            "forearm_r",
            "hand_r",
            "thigh_r",
            "shin_r",
            "foot_r",
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn humanoid_is_1_75_m_tall_and_stands_on_the_ground() {
        let h = humanoid();
        let s = &h.skeleton;
        assert_eq!(s.len(), 17);
        let world = s.rest_world();
        let ends = s.rest_bone_ends();
        let top = (0..s.len())
            .flat_map(|i| [Some(world[i].translation), ends[i]])
            .flatten()
            .map(|p| p.y)
            .fold(f32::MIN, f32::max);
        assert!((top - DEFAULT_HEIGHT_M).abs() < 1e-4, "{top}");
        let head = s.find("head").unwrap();
        assert!(world[head].translation.y > world[s.find("pelvis").unwrap()].translation.y);
    }
}
