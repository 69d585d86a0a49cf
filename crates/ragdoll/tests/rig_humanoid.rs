//! `rig --humanoid`: a person's skeleton fitted to an unrigged figure standing in a T- or
//! A-pose. The figure here is built from boxes (legs, feet, a trunk, a head, arms) with
//! known joints, in both poses and facing either way along Z; the fit must put every role
//! on its side, its joints near the ones the figure was built around, and refuse a figure
//! whose arms hang along its body.

use glam::{Quat, Vec3};
use ragdoll::rig::{RigOptions, rig};
use ragdoll::skeleton::{Skeleton, SkinnedMesh};
use ragdoll::spec::{Role, recognise_roles};

/// A closed box from `a` to `b` whose square cross-section is `2 w` wide (12 triangles).
fn segment_box(a: Vec3, b: Vec3, w: f32) -> SkinnedMesh {
    let axis = (b - a).normalize();
    let (u, v) = axis.any_orthonormal_pair();
    let corner = |i: usize| {
        let end = if i & 1 == 0 { a } else { b };
        let su = if i & 2 == 0 { -w } else { w };
        let sv = if i & 4 == 0 { -w } else { w };
        end + u * su + v * sv
    };
    let positions: Vec<Vec3> = (0..8).map(corner).collect();
    let faces = [
        [0, 1, 3, 2],
        [4, 6, 7, 5],
        [0, 4, 5, 1],
        [2, 3, 7, 6],
        [0, 2, 6, 4],
        [1, 5, 7, 3],
    ];
    let indices = faces
        .iter()
        .flat_map(|f| [f[0], f[1], f[2], f[0], f[2], f[3]])
        .collect();
    SkinnedMesh {
        name: "part".into(),
        positions,
        indices,
        ..Default::default()
    }
}

/// The joints a figure is built around (left side, facing +Z, 1.75 m): hip, knee, ankle,
/// toe, shoulder, and the fingertip for an arm `drop` degrees below horizontal.
struct Build {
    hip: Vec3,
    knee: Vec3,
    ankle: Vec3,
    toe: Vec3,
    shoulder: Vec3,
    tip: Vec3,
}

fn build(drop_deg: f32) -> Build {
    let shoulder = Vec3::new(0.18, 1.42, 0.0);
    let dir = Quat::from_rotation_z(-drop_deg.to_radians()) * Vec3::X;
    Build {
        hip: Vec3::new(0.09, 0.9, 0.0),
        knee: Vec3::new(0.1, 0.5, 0.0),
        ankle: Vec3::new(0.1, 0.07, 0.0),
        toe: Vec3::new(0.1, 0.02, 0.2),
        shoulder,
        tip: shoulder + dir * 0.75,
    }
}

/// A figure of boxes around `b`, both sides, turned by `yaw` about Y.
fn figure(b: &Build, yaw: f32) -> Vec<SkinnedMesh> {
    let q = Quat::from_rotation_y(yaw);
    let mut parts = vec![
        segment_box(Vec3::new(0.0, 0.85, 0.0), Vec3::new(0.0, 1.48, 0.0), 0.14),
        segment_box(Vec3::new(0.0, 1.5, 0.0), Vec3::new(0.0, 1.75, 0.0), 0.09),
    ];
    for s in [1.0f32, -1.0] {
        let m = |p: Vec3| Vec3::new(s * p.x, p.y, p.z);
        parts.push(segment_box(m(b.hip), m(b.knee), 0.07));
        parts.push(segment_box(m(b.knee), m(b.ankle), 0.05));
        parts.push(segment_box(
            m(b.ankle) + Vec3::new(0.0, -0.05, -0.05),
            m(b.toe),
            0.04,
        ));
        parts.push(segment_box(m(b.shoulder), m(b.tip), 0.04));
    }
    for p in &mut parts {
        for v in &mut p.positions {
            *v = q * *v;
        }
    }
    parts
}

fn world_of(s: &Skeleton, name: &str) -> Vec3 {
    s.rest_world()[s.find(name).unwrap_or_else(|| panic!("no joint {name}"))].translation
}

#[test]
fn a_figure_in_a_t_or_an_a_pose_gets_a_persons_skeleton_on_its_own_sides() {
    for drop in [0.0f32, 40.0] {
        let b = build(drop);
        for yaw in [0.0f32, std::f32::consts::PI] {
            let what = format!("arms {drop}° down, turned {yaw:.2}");
            let q = Quat::from_rotation_y(yaw);
            let mut meshes = figure(&b, yaw);
            let opts = RigOptions {
                humanoid: true,
                ..Default::default()
            };
            let skeleton = rig(&mut meshes, &opts).unwrap_or_else(|e| panic!("{what}: {e}"));
            // Left is the figure's own left: +X when it faces +Z.
            for (name, want) in [
                ("shin_l", b.knee),
                ("foot_l", b.ankle),
                ("upper_arm_l", b.shoulder),
                ("thigh_l", b.hip),
            ] {
                let got = world_of(&skeleton, name);
                let want = q * want;
                assert!(
                    got.distance(want) < 0.06,
                    "{what}: {name} at {got}, built at {want}"
                );
            }
            let hand = world_of(&skeleton, "hand_l");
            let tip = q * b.tip;
            let wrist = q * b.shoulder + (tip - q * b.shoulder) * 0.75;
            assert!(
                hand.distance(wrist) < 0.06,
                "{what}: hand at {hand}, wrist near {wrist}"
            );
            let character = ragdoll::skeleton::Character {
                skeleton,
                meshes,
                ..ragdoll::skeleton::humanoid()
            };
            let roles = recognise_roles(&character);
            assert!(roles.humanoid, "{what}: {}", roles.why);
            let left = roles
                .per_joint
                .iter()
                .position(|r| *r == Some(Role::HandL))
                .unwrap();
            assert_eq!(character.skeleton.joints()[left].name, "hand_l", "{what}");
        }
    }
}

#[test]
fn a_figure_whose_arms_hang_along_its_body_is_refused_with_the_reason() {
    let b = build(90.0);
    let mut meshes = figure(&b, 0.0);
    let opts = RigOptions {
        humanoid: true,
        ..Default::default()
    };
    let err = rig(&mut meshes, &opts).unwrap_err().to_string();
    assert!(err.contains("T-pose or an A-pose"), "{err}");
}
