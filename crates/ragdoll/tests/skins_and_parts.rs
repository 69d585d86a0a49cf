//! Skinned characters whose meshes are not all on one skin: rigid meshes parented to bones
//! beside a small skinned mesh (the three.js RobotExpressive's layout), and one skin per
//! mesh, each listing only its own bones (how many game exporters write a character).
//! Every mesh is read, bound to the right joint, and sizes its body; a skin joined to
//! nothing (a prop) is not read. Each file is built here, turned four ways.

use glam::{Vec3, Vec4};
use ragdoll::skeleton::Character;
use ragdoll::spec::{self, Role};

mod rigid_parts_files;

use rigid_parts_files::{ROBOT, SkinStyle, load_as, skinned_robot};

const FACINGS: [f32; 4] = [0.0, 90.0, 180.0, 270.0];

fn sorted(mut v: Vec<String>) -> Vec<String> {
    v.sort();
    v
}

fn joint_names(c: &Character) -> Vec<String> {
    sorted(c.skeleton.joints().iter().map(|j| j.name.clone()).collect())
}

fn robot_parts() -> Vec<String> {
    sorted(ROBOT.iter().map(|p| p.0.to_string()).collect())
}

/// Each box of `ROBOT` read bound with weight 1 to its own bone, where the file puts it:
/// its vertices' centre, in the bone's rest frame, is the box's centre.
fn assert_boxes_on_their_bones(c: &Character, label: &str) {
    let rest = c.skeleton.rest_world();
    let mut found = 0;
    for (name, _, _, _, centre) in ROBOT {
        let j = c.skeleton.find(name).unwrap();
        let on_bone: Vec<Vec3> = c
            .meshes
            .iter()
            .filter(|m| m.name != "hands")
            .flat_map(|m| m.positions.iter().zip(m.joints.iter().zip(&m.weights)))
            .filter(|(_, (js, w))| js[0] as usize == j && **w == Vec4::X)
            .map(|(p, _)| *p)
            .collect();
        assert_eq!(on_bone.len(), 8, "{label}: {name}'s box");
        let mid = on_bone.iter().sum::<Vec3>() / 8.0;
        let local = rest[j].inverse().transform_point(mid);
        assert!(
            (local - Vec3::from(centre)).length() < 1e-4,
            "{label}: {name}'s box at {local}, not {centre:?}"
        );
        found += 1;
    }
    assert_eq!(found, ROBOT.len());
}

/// The head's body holds the head: its shape has at least half the head box's volume (a
/// body sized without the head's mesh is a thin capsule of a few percent of it).
fn assert_head_body_holds_the_head(c: &Character, label: &str) {
    let roles = spec::recognise_roles(c);
    assert!(roles.humanoid, "{label}: {}", roles.why);
    let head = roles.joint(Role::Head).expect("a head");
    assert_eq!(c.skeleton.joints()[head].name, "Head", "{label}");
    let spec = spec::build_spec(c, &Default::default()).unwrap();
    let body = spec.bodies.iter().find(|b| b.bone == "Head").unwrap();
    let (_, _, _, size, _) = ROBOT.iter().find(|p| p.0 == "Head").unwrap();
    let box_volume = size[0] * size[1] * size[2];
    assert!(
        body.shape.volume() > 0.5 * box_volume,
        "{label}: the head's body is {:?}, {} m³ against the head's {box_volume} m³",
        body.shape,
        body.shape.volume()
    );
}

#[test]
fn meshes_parented_to_bones_size_and_follow_their_bones() {
    for facing in FACINGS {
        let label = format!("parts on bones, facing {facing}°");
        let c = load_as("robot.glb", &skinned_robot(SkinStyle::PartsOnBones, facing));
        assert_eq!(
            joint_names(&c),
            robot_parts(),
            "{label}: mesh holders are not joints"
        );
        assert_eq!(
            c.meshes.len(),
            ROBOT.len() + 1,
            "{label}: every part and the hands"
        );
        assert_boxes_on_their_bones(&c, &label);
        // The hands' skin puts one box 0.3 m down each forearm.
        let hands = c.meshes.iter().find(|m| m.name == "hands").unwrap();
        assert_eq!(hands.positions.len(), 16, "{label}");
        assert_head_body_holds_the_head(&c, &label);
    }
}

#[test]
fn one_skin_per_mesh_makes_one_skeleton_of_every_skin() {
    for facing in FACINGS {
        let label = format!("five skins, facing {facing}°");
        let c = load_as("robot.glb", &skinned_robot(SkinStyle::FiveSkins, facing));
        assert_eq!(
            joint_names(&c),
            robot_parts(),
            "{label}: every skin's bones, and not the crate's"
        );
        let names = sorted(c.meshes.iter().map(|m| m.name.clone()).collect());
        assert_eq!(
            names,
            ["arm L", "arm R", "head", "legs", "torso"],
            "{label}: the five meshes, not the crate"
        );
        assert_boxes_on_their_bones(&c, &label);
        let lowest = c
            .meshes
            .iter()
            .flat_map(|m| &m.positions)
            .map(|p| p.y)
            .fold(f32::INFINITY, f32::min);
        assert!(lowest.abs() < 1e-4, "{label}: soles at {lowest}, not 0");
        assert_head_body_holds_the_head(&c, &label);
    }
}
