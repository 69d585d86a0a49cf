//! Rig options: joints, landmarks, branches and names bounded.

use glam::Vec3;
use ragdoll::{Error, world};

use super::past;

// --- Rig options ---------------------------------------------------------------------------

/// A long thin box along X (as the rig module's example).
fn bar_mesh() -> Vec<ragdoll::skeleton::SkinnedMesh> {
    let positions: Vec<Vec3> = (0..8)
        .map(|i| {
            Vec3::new(
                if i & 1 == 0 { -1.0 } else { 1.0 },
                (i >> 1 & 1) as f32 * 0.2,
                (i >> 2) as f32 * 0.2,
            )
        })
        .collect();
    let indices = vec![
        0, 1, 3, 0, 3, 2, 4, 7, 5, 4, 6, 7, 0, 4, 5, 0, 5, 1, 2, 3, 7, 2, 7, 6, 0, 2, 6, 0, 6, 4,
        1, 5, 7, 1, 7, 3,
    ];
    vec![ragdoll::skeleton::SkinnedMesh {
        positions,
        indices,
        ..Default::default()
    }]
}

#[test]
fn rig_options_are_bounded() {
    use ragdoll::rig::{self, Branch, Landmark, RigOptions};
    let meshes = bar_mesh();
    let leg = |name: &str, points: usize, joints: usize| Branch {
        name: name.into(),
        points: (0..points)
            .map(|k| Landmark::Point(Vec3::new(0.0, 0.0, 0.3 + k as f32 * 0.01)))
            .collect(),
        joints,
        mirror: true,
    };
    let with = |joints: usize, branches: Vec<Branch>| RigOptions {
        joints,
        branches,
        ..Default::default()
    };
    let setting = |opts: &RigOptions| match rig::build_skeleton(&meshes, opts) {
        Err(Error::Setting { setting, message }) => format!("{setting}: {message}"),
        other => panic!("expected a setting error, got {other:?}"),
    };
    // Spine joints and the whole rig.
    rig::build_skeleton(&meshes, &with(rig::MAX_JOINTS, vec![])).unwrap();
    assert!(setting(&with(rig::MAX_JOINTS + 1, vec![])).contains("rig.joints"));
    let half = (rig::MAX_RIG_JOINTS - rig::MAX_JOINTS) / 2;
    let full = with(rig::MAX_JOINTS, vec![leg("leg", 2, half - 1)]);
    assert_eq!(
        rig::build_skeleton(&meshes, &full).unwrap().len(),
        rig::MAX_RIG_JOINTS
    );
    let over = with(rig::MAX_JOINTS, vec![leg("leg", 2, half)]);
    assert!(setting(&over).contains("512"), "{}", setting(&over));
    // Landmarks per line, branches, names.
    let many = with(4, vec![leg("leg", rig::MAX_LANDMARKS + 1, 2)]);
    assert!(setting(&many).contains("landmarks"));
    let branches = (0..=rig::MAX_BRANCHES)
        .map(|k| leg(&format!("b{k}"), 2, 1))
        .collect();
    assert!(setting(&with(2, branches)).contains("branches"));
    assert!(setting(&with(4, vec![leg("leg", 2, 1), leg("leg", 2, 1)])).contains("two branches"));
    assert!(setting(&with(4, vec![leg("a/b", 2, 1)])).contains("letters"));
    let mut spine = leg("spine", 2, 1);
    spine.mirror = false;
    assert!(setting(&with(4, vec![spine])).contains("spine00"));
    // Landmarks within the world.
    let mut far = leg("leg", 2, 1);
    far.points[1] = Landmark::Point(Vec3::new(0.0, 0.0, past(world::MAX_COORDINATE_M)));
    assert!(setting(&with(4, vec![far])).contains("10000 m"));
}
