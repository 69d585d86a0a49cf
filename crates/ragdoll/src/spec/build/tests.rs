use glam::{Quat, Vec3, Vec4};

use super::collision::{COLLISION_MARGIN_M, Solid, nearby_pairs, segment_distance, solid};
use super::joints::{cone_centre, rotate_toward, swing_twist};
use super::masses::{MAX_LINKED_MASS_RATIO, stabilize_masses};
use super::*;
use crate::skeleton::{Skeleton, humanoid};
use crate::spec::JointKind;
use crate::spec::anthropometry::*;
use crate::spec::roles::tests::{quadruped, yawed};

fn build(c: &Character) -> RagdollSpec {
    build_spec(c, &BuildOptions::default()).unwrap()
}

fn body<'s>(spec: &'s RagdollSpec, name: &str) -> &'s BodySpec {
    &spec.bodies[spec
        .body_index(name)
        .unwrap_or_else(|| panic!("no body {name}"))]
}

fn joint<'s>(spec: &'s RagdollSpec, name: &str) -> &'s JointSpec {
    spec.joints.iter().find(|j| j.name == name).unwrap()
}

/// World rest transform (rotation, position) of the bone a body or joint refers to.
fn bone(c: &Character, spec: &RagdollSpec, body_name: &str) -> (Quat, Vec3) {
    let b = body(spec, body_name);
    let w = c.skeleton.rest_world()[c.skeleton.find(&b.bone).unwrap()];
    (w.rotation, w.translation)
}

fn world_solid(c: &Character, spec: &RagdollSpec, b: &BodySpec) -> Solid {
    let (r, t) = bone(c, spec, &b.name);
    solid(
        &b.shape,
        t + r * Vec3::from_array(b.center_m),
        r * Quat::from_array(b.rotation),
    )
}

#[test]
fn spec_build_filters_pairs_overlapping_in_the_first_frame() {
    // A first frame that swings the left arm across the chest (160° about the
    // forward axis, elbow straight): the forearm then lies on the chest and right arm,
    // which the rest pose never shows.
    let mut c = humanoid();
    let s = &c.skeleton;
    let mut frame: Vec<crate::math::Transform> = s.joints().iter().map(|j| j.rest).collect();
    let arm = s.find("upper_arm_l").unwrap();
    frame[arm].rotation = Quat::from_rotation_z(-160f32.to_radians());
    let rest_spec = build(&c);
    c.clips.push(crate::skeleton::Clip {
        name: "cross".into(),
        frame_time: 1.0 / 30.0,
        frames: vec![frame],
    });
    let spec = build(&c);
    let newly: Vec<&[String; 2]> = spec
        .collision
        .disabled_pairs
        .iter()
        .filter(|[a, b]| !rest_spec.collision.is_disabled(a, b))
        .collect();
    assert!(
        newly
            .iter()
            .any(|p| p.iter().any(|n| n == "forearm_l" || n == "hand_l")),
        "no pair of the crossed arm was filtered: {newly:?}"
    );
}

#[test]
fn spec_build_humanoid_bodies_and_round_trip() {
    let c = humanoid();
    let spec = build(&c);
    spec.validate().unwrap();
    assert_eq!(spec.bodies.len(), 16);
    assert_eq!(spec.bodies[0].name, "pelvis");
    assert_eq!(spec.joints.len(), 15);
    for b in &spec.bodies {
        assert_eq!(b.bone, b.name, "built-in joints carry role names");
    }
    let text = spec.to_toml();
    let back = RagdollSpec::from_toml(&text, std::path::Path::new("x.toml")).unwrap();
    assert_eq!(back, spec);
}

#[test]
fn spec_build_masses_keep_the_total() {
    let c = humanoid();
    for (total, female) in [
        (None, false),
        (None, true),
        (Some(60.0), true),
        (Some(110.0), false),
    ] {
        let spec = build_spec(
            &c,
            &BuildOptions {
                total_mass_kg: total,
                female,
            },
        )
        .unwrap();
        let want = total.unwrap_or(75.0);
        assert!(
            (spec.total_mass_kg() - want).abs() < 1e-3,
            "{} vs {want}",
            spec.total_mass_kg()
        );
        // Stabilised: no jointed pair beyond the ratio.
        for j in &spec.joints {
            let (a, b) = (
                body(&spec, &j.parent).mass_kg,
                body(&spec, &j.child).mass_kg,
            );
            assert!(
                a.max(b) / a.min(b) <= MAX_LINKED_MASS_RATIO * 1.001,
                "{} {a} {b}",
                j.name
            );
        }
    }
    let spec = build(&c);
    // Anatomy survives stabilisation: thighs are the heaviest limb part, hands the lightest.
    assert!(body(&spec, "thigh_l").mass_kg > 9.0);
    assert!(body(&spec, "hand_r").mass_kg < 0.6);
    assert!(body(&spec, "head").mass_kg > 3.5);
    assert!(
        build_spec(
            &c,
            &BuildOptions {
                total_mass_kg: Some(-1.0),
                ..Default::default()
            }
        )
        .is_err()
    );
}

#[test]
fn spec_build_missing_segments_give_their_mass_to_neighbours() {
    // Remove spine, neck and hands: pelvis→chest, chest→head, forearms end in tips.
    let c = humanoid();
    let keep = |n: &str| !matches!(n, "spine" | "neck" | "hand_l" | "hand_r");
    let old = c.skeleton.joints();
    let world = c.skeleton.rest_world();
    let mut joints = Vec::new();
    let mut map = vec![usize::MAX; old.len()];
    for (i, j) in old.iter().enumerate() {
        if !keep(&j.name) {
            continue;
        }
        let mut p = j.parent;
        while let Some(k) = p.filter(|&k| !keep(&old[k].name)) {
            p = old[k].parent;
        }
        let tip = if j.name.starts_with("forearm") {
            Some(Vec3::new(0.0, -0.26, 0.0))
        } else {
            j.tip
        };
        let parent_pos = p.map_or(Vec3::ZERO, |k| world[k].translation);
        map[i] = joints.len();
        joints.push(crate::skeleton::Joint {
            name: j.name.clone(),
            parent: p.map(|k| map[k]),
            rest: crate::math::Transform::from_translation(world[i].translation - parent_pos),
            tip,
        });
    }
    let mut c2 = c.clone();
    c2.skeleton = Skeleton::new(joints).unwrap();
    let spec = build(&c2);
    assert_eq!(
        spec.bodies.len(),
        13,
        "{:?}",
        spec.bodies.iter().map(|b| &b.name).collect::<Vec<_>>()
    );
    // A skeleton weighs as the built-in humanoid scaled to its joints' height.
    let k = c2.skeleton.rest_height() / c.skeleton.rest_height();
    let want = crate::spec::humanoid_mass_kg(k * 1.75);
    assert!((spec.total_mass_kg() - want).abs() < 1e-3);
    assert!(
        body(&spec, "head").mass_kg > 0.06 * want,
        "head carries the neck"
    );
}

/// Rotates `p` about the axis `axis` through `pivot` by `deg`.
fn turn(p: Vec3, pivot: Vec3, axis: Vec3, deg: f32) -> Vec3 {
    pivot + Quat::from_axis_angle(axis, deg.to_radians()) * (p - pivot)
}

/// World X axis of a joint's frame.
fn joint_axis(c: &Character, spec: &RagdollSpec, name: &str) -> (Vec3, Vec3) {
    let (r, t) = bone(c, spec, name);
    let f = r * Quat::from_array(joint(spec, name).frame);
    (f * Vec3::X, t)
}

#[test]
fn spec_build_knee_bends_backward_and_elbow_forward_for_any_facing() {
    for k in 0..8 {
        let yaw = (k as f32 * 45.0).to_radians();
        let c = yawed(&humanoid(), yaw);
        let fwd = Quat::from_rotation_y(yaw) * Vec3::Z;
        let spec = build(&c);
        let s = &c.skeleton;
        let w = s.rest_world();
        for side in ["l", "r"] {
            let (x, knee) = joint_axis(&c, &spec, &format!("shin_{side}"));
            let foot = w[s.find(&format!("foot_{side}")).unwrap()].translation;
            let bent = turn(foot, knee, x, 30.0);
            assert!(
                (bent - foot).dot(fwd) < -0.05,
                "yaw {k}: knee_{side} bends forward"
            );
            assert!((bent - knee).dot(fwd) < 0.0, "foot not behind the knee");
            let JointKind::Hinge { min_deg, max_deg } = joint(&spec, &format!("shin_{side}")).kind
            else {
                panic!("knee is a hinge")
            };
            assert!(
                min_deg.abs() < 1e-3 && (max_deg - 140.0).abs() < 1e-3,
                "{min_deg} {max_deg}"
            );

            let (x, elbow) = joint_axis(&c, &spec, &format!("forearm_{side}"));
            let hand = w[s.find(&format!("hand_{side}")).unwrap()].translation;
            let bent = turn(hand, elbow, x, 30.0);
            assert!(
                (bent - hand).dot(fwd) > 0.05,
                "yaw {k}: elbow_{side} bends backward"
            );
        }
    }
}

#[test]
fn spec_build_hinge_limits_follow_a_flexed_rest_pose() {
    // Knees bent 20° at rest (shins tilted back): the range shifts to [-20, 120].
    let c = humanoid();
    let mut joints = c.skeleton.joints().to_vec();
    for j in joints.iter_mut().filter(|j| j.name.starts_with("foot")) {
        let len = j.rest.translation.length();
        let a = 20f32.to_radians();
        j.rest.translation = Vec3::new(0.0, -len * a.cos(), -len * a.sin());
    }
    let mut c2 = c.clone();
    c2.skeleton = Skeleton::new(joints).unwrap();
    let spec = build(&c2);
    let JointKind::Hinge { min_deg, max_deg } = joint(&spec, "shin_l").kind else {
        panic!()
    };
    assert!(
        (min_deg + 20.0).abs() < 0.01 && (max_deg - 120.0).abs() < 0.01,
        "{min_deg} {max_deg}"
    );
}

/// Direction of the cone centre of a swing-twist joint, world.
fn cone(c: &Character, spec: &RagdollSpec, name: &str) -> (Vec3, f32) {
    let (r, _) = bone(c, spec, name);
    let j = joint(spec, name);
    let JointKind::SwingTwist {
        swing_deg,
        cone_tilt_deg,
        ..
    } = j.kind
    else {
        panic!("{name}")
    };
    (
        r * Quat::from_array(j.frame) * cone_centre(cone_tilt_deg),
        swing_deg,
    )
}

#[test]
fn spec_build_hip_and_shoulder_cones_are_anatomical() {
    for k in [0, 3, 6] {
        let yaw = (k as f32 * 45.0).to_radians();
        let c = yawed(&humanoid(), yaw);
        let fwd = Quat::from_rotation_y(yaw) * Vec3::Z;
        let left = Vec3::Y.cross(fwd);
        let spec = build(&c);
        let angle = |a: Vec3, b: Vec3| a.angle_between(b).to_degrees();
        let (hip, swing) = cone(&c, &spec, "thigh_l");
        let leg = |flex: f32| rotate_toward(-Vec3::Y, fwd, flex);
        assert!(angle(hip, leg(110.0)) <= swing, "hip flexion 110 allowed");
        assert!(angle(hip, leg(0.0)) <= swing, "standing allowed");
        assert!(angle(hip, leg(-35.0)) > swing, "hip extension 35 refused");
        assert!(
            angle(hip, rotate_toward(-Vec3::Y, left, 45.0)) <= swing,
            "abduction 45 allowed"
        );
        for (side, out) in [("l", left), ("r", -left)] {
            let (sh, swing) = cone(&c, &spec, &format!("upper_arm_{side}"));
            assert!(angle(sh, -Vec3::Y) < swing - 20.0, "arms down inside");
            assert!(angle(sh, out) < swing - 20.0, "T-pose inside");
            assert!(angle(sh, fwd) <= swing, "arm forward inside");
            assert!(angle(sh, -out) > swing, "arm through the chest refused");
        }
    }
}

#[test]
fn spec_build_shapes_are_sane_and_rest_pose_is_collision_free() {
    let c = humanoid();
    for female in [false, true] {
        let spec = build_spec(
            &c,
            &BuildOptions {
                female,
                ..Default::default()
            },
        )
        .unwrap();
        check_rest_pose(&c, &spec);
    }
    let q = quadruped();
    check_rest_pose(&q, &build(&q));
}

fn check_rest_pose(c: &Character, spec: &RagdollSpec) {
    for b in &spec.bodies {
        match b.shape {
            Shape::Capsule { radius_m, length_m } => {
                assert!(radius_m > 0.0 && length_m >= 0.0, "{}", b.name)
            }
            Shape::Box { size_m } => assert!(size_m.iter().all(|s| *s > 0.0)),
        }
    }
    let filtered = |a: &str, b: &str| spec.collision.is_disabled(a, b);
    for j in &spec.joints {
        assert!(
            filtered(&j.parent, &j.child),
            "jointed pair {} collides",
            j.name
        );
    }
    // Brute force, independent of `segment_distance`: sample both segments densely.
    let n = 64;
    for (i, a) in spec.bodies.iter().enumerate() {
        for b in &spec.bodies[i + 1..] {
            if filtered(&a.name, &b.name) {
                continue;
            }
            let (sa, sb) = (world_solid(c, spec, a), world_solid(c, spec, b));
            let mut best = f32::MAX;
            for u in 0..=n {
                let p = sa.a.lerp(sa.b, u as f32 / n as f32);
                for v in 0..=n {
                    best = best.min(p.distance(sb.a.lerp(sb.b, v as f32 / n as f32)));
                }
            }
            assert!(
                best >= sa.r + sb.r,
                "{} and {} overlap at rest",
                a.name,
                b.name
            );
        }
    }
}

#[test]
fn spec_build_body_frames_are_in_bone_space() {
    // The thigh capsule runs from the hip to the knee whatever the facing.
    for k in [0, 1, 5] {
        let c = yawed(&humanoid(), (k as f32 * 45.0).to_radians());
        let spec = build(&c);
        let s = world_solid(&c, &spec, body(&spec, "thigh_r"));
        let w = c.skeleton.rest_world();
        let hip = w[c.skeleton.find("thigh_r").unwrap()].translation;
        let knee = w[c.skeleton.find("shin_r").unwrap()].translation;
        assert!((s.a.distance(knee) - s.r).abs() < 1e-3 || (s.b.distance(knee) - s.r).abs() < 1e-3);
        assert!((s.a.distance(hip) - s.r).abs() < 1e-3 || (s.b.distance(hip) - s.r).abs() < 1e-3);
    }
}

#[test]
fn spec_build_non_humanoids_are_chains_weighed_by_volume() {
    let q = quadruped();
    let spec = build(&q);
    assert!(spec.bodies.iter().all(|b| b.role == Some(Role::Chain)));
    assert_eq!(spec.bodies[0].name, "hip");
    assert_eq!(spec.joints.len(), spec.bodies.len() - 1);
    let volume: f32 = spec.bodies.iter().map(|b| b.shape.volume()).sum();
    assert!(
        (spec.total_mass_kg() - volume * BODY_DENSITY_KG_M3).abs() < 1e-3 * spec.total_mass_kg()
    );
    for j in &spec.joints {
        let JointKind::SwingTwist {
            swing_deg,
            twist_deg,
            ..
        } = j.kind
        else {
            panic!()
        };
        assert_eq!((swing_deg, twist_deg), (CHAIN_SWING_DEG, CHAIN_TWIST_DEG));
    }
    let spec = build_spec(
        &q,
        &BuildOptions {
            total_mass_kg: Some(30.0),
            ..Default::default()
        },
    )
    .unwrap();
    assert!((spec.total_mass_kg() - 30.0).abs() < 1e-3);
    assert_eq!(
        RagdollSpec::from_toml(&spec.to_toml(), std::path::Path::new("q")).unwrap(),
        spec
    );
}

#[test]
fn spec_build_stabilize_keeps_total_and_bounds_ratios() {
    let mut m = vec![10.0, 0.1, 0.5, 40.0];
    let parents = [0, 0, 1, 0];
    stabilize_masses(&mut m, &parents, 5.0);
    assert!((m.iter().sum::<f32>() - 50.6).abs() < 1e-4);
    for c in 1..4 {
        let (a, b) = (m[c], m[parents[c]]);
        assert!(a.max(b) / a.min(b) <= 5.0 * 1.0001, "{m:?}");
    }
}

#[test]
fn spec_build_stabilize_makes_a_hub_outweigh_a_fifth_of_what_it_carries() {
    // A 0.3 kg thorax carrying eight legs of 1.4 kg, each with a 7 kg shin: the pair rule
    // alone is met (1.4 / 0.3 < 5), the hub is not.
    let mut m = vec![0.3];
    let mut parents = vec![0];
    for _ in 0..8 {
        parents.push(0);
        m.push(1.4);
        parents.push(m.len() - 1);
        m.push(7.0);
    }
    let total: f32 = m.iter().sum();
    stabilize_masses(&mut m, &parents, 5.0);
    assert!((m.iter().sum::<f32>() - total).abs() < 1e-3);
    let carried: f32 = (1..m.len())
        .filter(|&c| parents[c] == 0)
        .map(|c| m[c])
        .sum();
    assert!(m[0] >= carried / 5.0 * 0.9999, "{m:?}");
    for c in 1..m.len() {
        let (a, b) = (m[c], m[parents[c]]);
        assert!(a.max(b) / a.min(b) <= 5.0 * 1.0001, "{m:?}");
    }
}

#[test]
fn spec_build_nearby_pairs_holds_every_touching_pair_in_loop_order() {
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut next = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f32 / (1u64 << 53) as f32
    };
    for round in 0..20 {
        // Clusters, long thin solids, huge ones spanning many cells, points.
        let spread = [0.5, 3.0, 30.0][round % 3];
        let solids: Vec<Solid> = (0..300)
            .map(|k| {
                let a = Vec3::new(next(), next(), next()) * spread;
                let long = if k % 17 == 0 { 20.0 } else { 0.3 };
                let b = a + (Vec3::new(next(), next(), next()) - 0.5) * long;
                let r = if k % 5 == 0 { 0.0 } else { next() * 0.2 };
                Solid { a, b, r }
            })
            .collect();
        let got = nearby_pairs(&solids, COLLISION_MARGIN_M).unwrap();
        assert!(got.windows(2).all(|w| w[0] < w[1]), "sorted and unique");
        for i in 0..solids.len() {
            for j in i + 1..solids.len() {
                let (s, t) = (solids[i], solids[j]);
                if segment_distance(s.a, s.b, t.a, t.b) < s.r + t.r + COLLISION_MARGIN_M {
                    assert!(got.binary_search(&(i, j)).is_ok(), "round {round}: {i} {j}");
                }
            }
        }
    }
}

#[test]
fn spec_build_segment_distance_cases() {
    let d = segment_distance(
        Vec3::ZERO,
        Vec3::X,
        Vec3::new(0.5, 1.0, -1.0),
        Vec3::new(0.5, 1.0, 1.0),
    );
    assert!((d - 1.0).abs() < 1e-6);
    let d = segment_distance(
        Vec3::ZERO,
        Vec3::ZERO,
        Vec3::new(2.0, 0.0, 0.0),
        Vec3::new(3.0, 0.0, 0.0),
    );
    assert!((d - 2.0).abs() < 1e-6);
    let d = segment_distance(
        Vec3::ZERO,
        Vec3::X,
        Vec3::new(2.0, 0.0, 0.0),
        Vec3::new(3.0, 0.0, 0.0),
    );
    assert!((d - 1.0).abs() < 1e-6);
}

#[test]
fn spec_build_cone_centre_convention() {
    assert!((cone_centre([0.0, 90.0]) - Vec3::Y).length() < 1e-6);
    assert!((cone_centre([90.0, 0.0]) + Vec3::Z).length() < 1e-6);
    // About Y, then about the turned Z: the world's `frame · Ry · Rz`.
    let c = cone_centre([90.0, 45.0]);
    let want = Quat::from_rotation_y(90f32.to_radians()) * Vec3::new(1.0, 1.0, 0.0).normalize();
    assert!((c - want).length() < 1e-6, "{c:?}");
    for tilt in [[18.7, 21.2], [-30.0, 50.0], [0.0, -15.0]] {
        let (frame, kind) =
            swing_twist(Vec3::X, &[Vec3::Y], Some(cone_centre(tilt)), 90.0, [0.0; 2]);
        assert!(frame.angle_between(Quat::IDENTITY) < 1e-5);
        let JointKind::SwingTwist { cone_tilt_deg, .. } = kind else {
            panic!()
        };
        assert!(
            (cone_tilt_deg[0] - tilt[0]).abs() < 1e-3 && (cone_tilt_deg[1] - tilt[1]).abs() < 1e-3
        );
    }
}

/// A humanoid's default mass goes as its volume: 75 kg at 1.75 m, eight times that at
/// twice the height, and the segments keep their shares.
#[test]
fn spec_build_humanoid_mass_scales_as_volume() {
    let scaled = |k: f32| {
        let mut c = humanoid();
        let joints = c
            .skeleton
            .joints()
            .iter()
            .map(|j| crate::skeleton::Joint {
                rest: crate::math::Transform {
                    translation: j.rest.translation * k,
                    ..j.rest
                },
                tip: j.tip.map(|t| t * k),
                ..j.clone()
            })
            .collect();
        c.skeleton = Skeleton::new(joints).unwrap();
        c
    };
    // The built-in humanoid stands 1.75 m from soles to crown and weighs 75 kg.
    let (s, b) = (build(&scaled(1.0)), build(&scaled(2.0)));
    assert!(
        (s.total_mass_kg() - 75.0).abs() < 1e-3,
        "{}",
        s.total_mass_kg()
    );
    assert!(
        (b.total_mass_kg() / s.total_mass_kg() - 8.0).abs() < 1e-3,
        "{} vs {}",
        b.total_mass_kg(),
        s.total_mass_kg()
    );
    for (x, y) in s.bodies.iter().zip(&b.bodies) {
        assert!((y.mass_kg / x.mass_kg - 8.0).abs() < 1e-3, "{}", x.name);
    }
}

/// A skinned humanoid is weighed by its skin's height, the top of its head and its soles.
#[test]
fn spec_build_skinned_humanoid_is_weighed_by_its_skin() {
    let mut c = humanoid();
    // A skin reaching 5 cm above the crown and down to the floor: 1.80 m. Two points,
    // each on the joint nearest it (a foot, the head).
    let joint = |name: &str| c.skeleton.joints().iter().position(|j| j.name == name);
    let (foot, head) = (
        joint("foot_l").unwrap() as u16,
        joint("head").unwrap() as u16,
    );
    c.meshes.push(crate::skeleton::SkinnedMesh {
        positions: vec![Vec3::new(0.09, 0.0, 0.05), Vec3::new(0.0, 1.80, 0.0)],
        joints: vec![[foot, 0, 0, 0], [head, 0, 0, 0]],
        weights: vec![Vec4::X, Vec4::X],
        ..Default::default()
    });
    let want = 75.0 * (1.80f32 / 1.75).powi(3);
    let got = crate::spec::build_spec(&c, &BuildOptions::default())
        .unwrap()
        .total_mass_kg();
    assert!((got - want).abs() < 1e-3, "{got} vs {want}");
}
