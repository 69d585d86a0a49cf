//! Roles files (`--roles`): a table of roles by hand, on characters built here, and
//! (ignored unless RAGDOLL_DATA is set) on a real rig with the example file.

use std::path::{Path, PathBuf};

use glam::Vec3;
use ragdoll::math::Transform;
use ragdoll::skeleton::{Character, Joint, Skeleton, humanoid};
use ragdoll::spec::{
    BuildOptions, Role, RoleFile, build_spec_with_roles, recognise_roles, roles_with_file,
};

fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/roles")
        .join(name)
}

/// The built-in humanoid with Mixamo's joint names and the `HeadTop_End` leaf it has.
fn mixamo_humanoid() -> Character {
    let mut c = humanoid();
    let rename = |n: &str| -> String {
        let side = |s: &str| if s == "l" { "Left" } else { "Right" };
        let m = match n.rsplit_once('_') {
            Some(("thigh", s)) => format!("{}UpLeg", side(s)),
            Some(("shin", s)) => format!("{}Leg", side(s)),
            Some(("foot", s)) => format!("{}Foot", side(s)),
            Some(("upper_arm", s)) => format!("{}Arm", side(s)),
            Some(("forearm", s)) => format!("{}ForeArm", side(s)),
            Some(("hand", s)) => format!("{}Hand", side(s)),
            _ => match n {
                "pelvis" => "Hips".into(),
                "spine" => "Spine".into(),
                "chest" => "Spine2".into(),
                "neck" => "Neck".into(),
                "head" => "Head".into(),
                other => panic!("unexpected joint {other}"),
            },
        };
        format!("mixamorig:{m}")
    };
    let mut joints: Vec<Joint> = c.skeleton.joints().to_vec();
    let head = joints.iter().position(|j| j.name == "head").unwrap();
    for j in &mut joints {
        j.name = rename(&j.name);
    }
    joints.push(Joint {
        name: "mixamorig:HeadTop_End".into(),
        parent: Some(head),
        rest: Transform::from_translation(Vec3::new(0.0, 0.2, 0.0)),
        tip: None,
    });
    c.skeleton = Skeleton::new(joints).unwrap();
    c
}

fn roles_file(text: &str) -> RoleFile {
    RoleFile::from_toml(text, Path::new("roles.toml")).unwrap()
}

/// The error of applying `text` to `c`, as the user reads it.
fn error(c: &Character, text: &str) -> String {
    let e = match RoleFile::from_toml(text, Path::new("roles.toml")) {
        Ok(f) => roles_with_file(c, &f).unwrap_err(),
        Err(e) => e,
    };
    e.to_string()
}

#[test]
fn the_mixamo_example_gives_every_role_to_the_joint_it_names() {
    let c = mixamo_humanoid();
    let file = RoleFile::load(&example("mixamo_like.toml")).unwrap();
    let roles = roles_with_file(&c, &file).unwrap();
    assert!(roles.humanoid, "{}", roles.why);
    let plain = humanoid();
    for (i, j) in plain.skeleton.joints().iter().enumerate() {
        assert_eq!(roles.per_joint[i].map(Role::as_str), Some(j.name.as_str()));
        assert!(roles.from_file[i], "{}", j.name);
    }
    let end = c.skeleton.find("mixamorig:HeadTop_End").unwrap();
    assert_eq!(roles.per_joint[end], None);
    assert!(roles.from_file[end]);
    assert!(
        (roles.forward - Vec3::Z).length() < 1e-4,
        "{:?}",
        roles.forward
    );
    let spec = build_spec_with_roles(&c, &BuildOptions::default(), Some(&file)).unwrap();
    assert_eq!(spec.bodies.len(), 16, "one body per role but the neck's");
}

#[test]
fn a_partial_file_changes_only_what_it_names() {
    let c = humanoid();
    let recognised = recognise_roles(&c);
    let roles = roles_with_file(&c, &roles_file("[roles]\nhead = \"neck\"\n")).unwrap();
    let s = &c.skeleton;
    assert_eq!(roles.per_joint[s.find("neck").unwrap()], Some(Role::Head));
    assert_eq!(roles.per_joint[s.find("head").unwrap()], None);
    for name in [
        "pelvis",
        "chest",
        "thigh_l",
        "forearm_r",
        "hand_l",
        "foot_r",
    ] {
        let j = s.find(name).unwrap();
        assert_eq!(roles.per_joint[j], recognised.per_joint[j], "{name}");
        assert!(!roles.from_file[j], "{name}");
    }
}

#[test]
fn ignoring_a_joint_takes_its_body_away() {
    let c = humanoid();
    let file = roles_file("ignore = [\"hand_l\"]\n");
    let roles = roles_with_file(&c, &file).unwrap();
    let hand = c.skeleton.find("hand_l").unwrap();
    assert_eq!(roles.per_joint[hand], None);
    assert!(roles.humanoid);
    let spec = build_spec_with_roles(&c, &BuildOptions::default(), Some(&file)).unwrap();
    assert!(spec.bodies.iter().all(|b| b.bone != "hand_l"));
    assert_eq!(spec.bodies.len(), 15);
}

/// Joints without names (CesiumMan's are all unnamed) are named in a roles file as
/// `inspect` prints them, `joint<i>`, lying in the file or not. Before, every such line
/// was refused: "\"joint0\" is not a joint of CesiumMan; the closest names are
/// \"joint0\", ...".
#[test]
fn unnamed_joints_are_named_by_their_labels() {
    let mut c = humanoid();
    let mut joints: Vec<Joint> = c.skeleton.joints().to_vec();
    for j in &mut joints {
        j.name.clear();
    }
    c.skeleton = Skeleton::new(joints).unwrap();
    let plain = humanoid();
    let label = |name: &str| format!("joint{}", plain.skeleton.find(name).unwrap());
    let text = format!(
        "ignore = [\"{}\"]\n[roles]\nhead = \"{}\"\n",
        label("hand_l"),
        label("neck")
    );
    for (how, q) in [
        ("standing", glam::Quat::IDENTITY),
        (
            "lying",
            glam::Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2),
        ),
    ] {
        let c = c.rotated(q);
        let roles = roles_with_file(&c, &roles_file(&text)).unwrap();
        assert!(roles.humanoid, "{how}: {}", roles.why);
        let at = |name: &str| roles.per_joint[plain.skeleton.find(name).unwrap()];
        assert_eq!(at("neck"), Some(Role::Head), "{how}");
        assert_eq!(at("head"), None, "{how}");
        assert_eq!(at("hand_l"), None, "{how}");
        assert_eq!(at("thigh_l"), Some(Role::ThighL), "{how}");
    }
    let e = error(&c, "[roles]\nhead = \"joint99\"\n");
    assert!(
        e.contains("line 2") && e.contains("\"joint99\" is not a joint"),
        "{e}"
    );
}

#[test]
fn mistakes_are_one_sentence_naming_the_line_and_the_key() {
    let c = humanoid();
    let cases: &[(&str, &str)] = &[
        (
            "[roles]\nknee_l = \"shin_l\"\n",
            "roles.toml: line 2: knee_l: not a role",
        ),
        (
            "[roles]\nthigh_l = \"thig_l\"\n",
            "line 2: thigh_l: \"thig_l\" is not a joint of humanoid; the closest names are \"thigh_l\"",
        ),
        (
            "[roles]\npelvis = \"pelvis\"\nchest = \"pelvis\"\n",
            "line 3: chest: \"pelvis\" is already given as pelvis (line 2)",
        ),
        (
            "[roles]\nthigh_l = \"thigh_l\"\nthigh_r = \"thigh_l\"\n",
            "line 3: thigh_r: \"thigh_l\" is also thigh_l (line 2): the left and right sides must be different joints",
        ),
        (
            "[roles]\nthigh_l = \"thigh_l\"\nthigh_l = \"thigh_r\"\n",
            "line 3: thigh_l: given twice",
        ),
        (
            "[roles]\nthigh_l = \"shin_l\"\nshin_l = \"thigh_l\"\n",
            "line 3: shin_l: \"thigh_l\" does not hang from \"shin_l\"",
        ),
        (
            "[roles]\nupper_arm_l = \"upper_arm_r\"\nforearm_l = \"forearm_r\"\nupper_arm_r = \"upper_arm_l\"\nforearm_r = \"forearm_l\"\n",
            "line 2: upper_arm_l: the left arm is on the right leg's side",
        ),
        (
            "[roles]\nthigh_l = 3\n",
            "line 2: thigh_l: must be a joint name in quotes",
        ),
        (
            "ignore = \"hand_l\"\n",
            "line 1: ignore: must be a list of joint names",
        ),
        ("bones = 1\n", "line 1: bones: unknown key"),
        ("\n", "line 1: names no role"),
    ];
    for (text, want) in cases {
        let got = error(&c, text);
        assert!(got.contains(want), "{text:?}:\n got {got}\nwant {want}");
        assert!(!got.contains('\n'), "{got}");
    }
}

/// Legs raised above the hips (the trunk upright), every knee is above its hip in the
/// only pose there is, standing or stood up: a thigh cannot be built below its shin,
/// whatever the file says.
#[test]
fn a_knee_above_its_hip_is_refused() {
    let mut c = humanoid();
    let mut joints = c.skeleton.joints().to_vec();
    for j in joints
        .iter_mut()
        .filter(|j| j.name.starts_with("shin") || j.name.starts_with("foot"))
    {
        j.rest.translation.y = -j.rest.translation.y;
        j.tip = j.tip.map(|t| Vec3::new(t.x, -t.y, t.z));
    }
    c.skeleton = Skeleton::new(joints).unwrap();
    let text = "[roles]\nthigh_l = \"thigh_l\"\nshin_l = \"shin_l\"\n";
    let got = error(&c, text);
    assert!(
        got.contains("line 3: shin_l: the knee \"shin_l\" is not below the hip \"thigh_l\""),
        "{got}"
    );
}

/// The Robi example on the real rig: its controls get no body, its anatomy every role.
#[test]
#[ignore = "needs RAGDOLL_DATA"]
fn the_robi_example_holds_on_the_real_rig() {
    let data = PathBuf::from(std::env::var("RAGDOLL_DATA").expect("RAGDOLL_DATA"));
    let c =
        ragdoll::import::load(&data.join("rigs/godot_robi_ik.glb"), &Default::default()).unwrap();
    let file = RoleFile::load(&example("godot_robi_ik.toml")).unwrap();
    let roles = roles_with_file(&c, &file).unwrap();
    assert!(roles.humanoid, "{}", roles.why);
    let s = &c.skeleton;
    for (name, role) in [
        ("hip", Role::Pelvis),
        ("l-thigh", Role::ThighL),
        ("r-leg", Role::ShinR),
        ("l-forearm", Role::ForearmL),
        ("head", Role::Head),
    ] {
        assert_eq!(roles.per_joint[s.find(name).unwrap()], Some(role), "{name}");
    }
    for helper in ["MASTER", "l-LEGCONTROL", "r-ARMORIENT"] {
        assert_eq!(roles.per_joint[s.find(helper).unwrap()], None, "{helper}");
    }
    let spec = build_spec_with_roles(&c, &BuildOptions::default(), Some(&file)).unwrap();
    assert_eq!(spec.bodies.len(), 14);
}
