//! Rigs in styles no test data file has (rigs in the styles of the
//! test data that the tests have never seen must work too): whole hierarchies as the tools that make them lay them out,
//! with their twist and roll bones in line or beside the limb, clavicles, several spine and
//! neck joints, fingers, toes, eyes, IK targets and weapon sockets, in T- and A-poses: Daz
//! Genesis 8, Character Creator 3/4, 3ds Max Biped (its thighs hang from the spine), Valve's
//! Biped (helper bones named after the wrist and elbow), Unreal 5's mannequin (IK feet and
//! hands under the root, twist and corrective bones), Rigify's deform bones (each limb bone
//! split in two), Maya HumanIK (roll bones), Mixamo (collars named `LeftShoulder`, end
//! bones), MakeHuman (legs under side `pelvis.L` bones, every limb bone numbered in two,
//! the hand called `wrist.L`), SMPL (joints named for where they are: `left_hip` is the
//! thigh, `left_shoulder` the upper arm), Kinect v2 (`ShoulderLeft`, `SpineBase`) and
//! Bandai Namco's motion dataset (`UpperLeg_L`, `Shoulder_L` the clavicle). Each names, for every main role, the joint
//! a rigger would give it, and the helper bones that must carry no body.

mod common;

use glam::{Quat, Vec3};
use ragdoll::skeleton::Character;
use ragdoll::spec::{BuildOptions, Role, build_spec, recognise_roles};

/// A skeleton under construction: rows of (name, parent row, world position at rest).
struct Rig {
    rows: Vec<(String, Option<usize>, Vec3)>,
    /// How the arms hang: 0 for a T-pose, else the angle below horizontal, radians.
    arm_drop: f32,
}

/// Where the parts of a standing adult (1.8 m, facing +Z, its left on +X) are, on the left
/// side; arms in a T-pose.
fn at(part: &str) -> Vec3 {
    let (x, y, z) = match part {
        "root" => (0.0, 0.0, 0.0),
        "hips" => (0.0, 0.98, 0.0),
        "spine1" => (0.0, 1.05, 0.0),
        "spine2" => (0.0, 1.15, -0.01),
        "spine3" => (0.0, 1.25, -0.01),
        "chest" => (0.0, 1.36, 0.0),
        "neck" => (0.0, 1.5, 0.0),
        "neck2" => (0.0, 1.56, 0.01),
        "head" => (0.0, 1.62, 0.02),
        "head_top" => (0.0, 1.8, 0.02),
        "eye" => (0.032, 1.68, 0.09),
        "jaw" => (0.0, 1.6, 0.04),
        "hip" => (0.09, 0.93, 0.0),
        "thigh_mid" => (0.09, 0.72, 0.01),
        "knee" => (0.09, 0.5, 0.02),
        "shin_mid" => (0.09, 0.29, 0.0),
        "ankle" => (0.09, 0.08, -0.03),
        "ball" => (0.09, 0.02, 0.1),
        "toe_end" => (0.09, 0.01, 0.17),
        "clavicle" => (0.02, 1.45, 0.03),
        "shoulder" => (0.17, 1.45, 0.0),
        "upper_arm_mid" => (0.31, 1.45, -0.01),
        "elbow" => (0.45, 1.45, -0.02),
        "forearm_mid" => (0.57, 1.45, -0.01),
        "wrist" => (0.7, 1.45, 0.0),
        "thumb" => (0.72, 1.44, 0.04),
        "thumb_end" => (0.78, 1.43, 0.07),
        "finger" => (0.79, 1.45, 0.01),
        "finger_end" => (0.88, 1.45, 0.01),
        other => panic!("no part {other}"),
    };
    Vec3::new(x, y, z)
}

/// The arm parts, which an A-pose turns down about the shoulder.
const ARM_PARTS: [&str; 9] = [
    "upper_arm_mid",
    "elbow",
    "forearm_mid",
    "wrist",
    "thumb",
    "thumb_end",
    "finger",
    "finger_end",
    "shoulder",
];

impl Rig {
    fn new(root: &str, part: &str, arm_drop_deg: f32) -> Self {
        Rig {
            rows: vec![(root.to_string(), None, at(part))],
            arm_drop: arm_drop_deg.to_radians(),
        }
    }

    /// Where `part` is on the left side, with the rig's arm pose.
    fn left(&self, part: &str) -> Vec3 {
        let p = at(part);
        if part == "shoulder" || !ARM_PARTS.contains(&part) {
            return p;
        }
        let s = at("shoulder");
        s + Quat::from_rotation_z(-self.arm_drop) * (p - s)
    }

    fn row(&self, name: &str) -> usize {
        self.rows
            .iter()
            .position(|r| r.0 == name)
            .unwrap_or_else(|| panic!("no joint {name} yet"))
    }

    /// A joint on the centre line (or at an offset given in metres, as eyes are).
    fn add(&mut self, name: &str, parent: &str, part: &str) -> &mut Self {
        let p = self.left(part);
        let parent = self.row(parent);
        self.rows.push((name.to_string(), Some(parent), p));
        self
    }

    /// A joint on each side: `{s}` in `name` and `parent` becomes `sides[0]` on the left
    /// (+X) and `sides[1]` on the right, mirrored.
    fn both(&mut self, sides: [&str; 2], name: &str, parent: &str, part: &str) -> &mut Self {
        let p = self.left(part);
        for (side, sign) in sides.iter().zip([1.0f32, -1.0]) {
            let parent = self.row(&parent.replace("{s}", side));
            let q = Vec3::new(sign * p.x, p.y, p.z);
            self.rows.push((name.replace("{s}", side), Some(parent), q));
        }
        self
    }

    /// Several joints on each side, each the child of the one before (the first's parent is
    /// `parent`).
    fn chain(&mut self, sides: [&str; 2], parent: &str, links: &[(&str, &str)]) -> &mut Self {
        let mut up = parent.to_string();
        for (name, part) in links {
            self.both(sides, name, &up, part);
            up = name.to_string();
        }
        self
    }

    fn character(&self, name: &str) -> Character {
        common::character_from_rows(name, &self.rows)
    }
}

/// What a style must come out as: the joint of each main role (left side; the right is the
/// same with the side swapped), alternatives where riggers disagree, and the helpers.
struct Expect {
    /// (role, joints that may carry it), the left side's for sided roles.
    roles: Vec<(Role, Vec<String>)>,
    /// Joints that must get no body of their own.
    helpers: Vec<String>,
}

/// The right side's role for a left side's.
fn mirror(role: Role) -> Option<Role> {
    Some(match role {
        Role::ThighL => Role::ThighR,
        Role::ShinL => Role::ShinR,
        Role::FootL => Role::FootR,
        Role::UpperArmL => Role::UpperArmR,
        Role::ForearmL => Role::ForearmR,
        Role::HandL => Role::HandR,
        _ => return None,
    })
}

/// `names` with `{s}` as each side: `[left, right]`.
fn sided(sides: [&str; 2], names: &[&str]) -> [Vec<String>; 2] {
    sides.map(|s| names.iter().map(|n| n.replace("{s}", s)).collect())
}

/// Builds the expectation: `centre` roles as given, `limbs` (left roles) for both sides.
fn expect(
    sides: [&str; 2],
    centre: &[(Role, &[&str])],
    limbs: &[(Role, &str)],
    helpers: &[&str],
) -> Expect {
    let mut roles: Vec<(Role, Vec<String>)> = centre
        .iter()
        .map(|(r, names)| (*r, names.iter().map(|n| n.to_string()).collect()))
        .collect();
    for (role, name) in limbs {
        let [l, r] = sided(sides, &[name]);
        roles.push((*role, l));
        roles.push((mirror(*role).unwrap(), r));
    }
    let [hl, hr] = sided(sides, helpers);
    let mut helpers: Vec<String> = hl.into_iter().chain(hr).collect();
    helpers.dedup();
    Expect { roles, helpers }
}

/// Every role on one of its joints and on no other, no helper with a body, and a ragdoll
/// that builds; failures gathered with the style's name.
fn check(style: &str, c: &Character, want: &Expect) -> Vec<String> {
    let roles = recognise_roles(c);
    if !roles.humanoid {
        return vec![format!("{style}: not a humanoid ({})", roles.why)];
    }
    let mut bad = Vec::new();
    // Each style names every main part: its names must say so, whatever its prefixes.
    if !roles.why.contains("joint names") {
        bad.push(format!("{style}: {}", roles.why));
    }
    let name = |j: usize| c.skeleton.joints()[j].name.clone();
    for (role, allowed) in &want.roles {
        let got: Vec<String> = (0..c.skeleton.len())
            .filter(|&j| roles.per_joint[j] == Some(*role))
            .map(name)
            .collect();
        if got.len() != 1 || !allowed.contains(&got[0]) {
            bad.push(format!(
                "{style}: {} on {got:?}, want one of {allowed:?}",
                role.as_str()
            ));
        }
    }
    match build_spec(c, &BuildOptions::default()) {
        Ok(spec) => {
            for h in &want.helpers {
                if spec.bodies.iter().any(|b| &b.bone == h) {
                    bad.push(format!("{style}: helper {h} has a body"));
                }
            }
        }
        Err(e) => bad.push(format!("{style}: the spec does not build: {e}")),
    }
    bad
}

/// Daz Genesis 8: `hip` moves the body, `pelvis` (its child) carries the thighs, each limb
/// bone is split into a bend and a twist bone in line.
fn daz_genesis8() -> (Character, Expect) {
    let s = ["l", "r"];
    let mut r = Rig::new("Genesis8Female", "root", 45.0);
    r.add("hip", "Genesis8Female", "hips")
        .add("pelvis", "hip", "hips")
        .add("abdomenLower", "hip", "spine1")
        .add("abdomenUpper", "abdomenLower", "spine2")
        .add("chestLower", "abdomenUpper", "spine3")
        .add("chestUpper", "chestLower", "chest")
        .add("neckLower", "chestUpper", "neck")
        .add("neckUpper", "neckLower", "neck2")
        .add("head", "neckUpper", "head")
        .add("upperFaceRig", "head", "jaw")
        .both(s, "{s}Eye", "head", "eye")
        .chain(
            s,
            "pelvis",
            &[
                ("{s}ThighBend", "hip"),
                ("{s}ThighTwist", "thigh_mid"),
                ("{s}Shin", "knee"),
                ("{s}Foot", "ankle"),
                ("{s}Metatarsals", "ball"),
                ("{s}Toe", "toe_end"),
            ],
        )
        .chain(
            s,
            "chestUpper",
            &[
                ("{s}Collar", "clavicle"),
                ("{s}ShldrBend", "shoulder"),
                ("{s}ShldrTwist", "upper_arm_mid"),
                ("{s}ForearmBend", "elbow"),
                ("{s}ForearmTwist", "forearm_mid"),
                ("{s}Hand", "wrist"),
                ("{s}Index1", "finger"),
                ("{s}Index2", "finger_end"),
            ],
        )
        .chain(
            s,
            "{s}Hand",
            &[("{s}Thumb1", "thumb"), ("{s}Thumb2", "thumb_end")],
        );
    let want = expect(
        s,
        &[
            (Role::Pelvis, &["hip", "pelvis"]),
            (Role::Chest, &["chestUpper"]),
            (Role::Head, &["head"]),
        ],
        &[
            (Role::ThighL, "{s}ThighBend"),
            (Role::ShinL, "{s}Shin"),
            (Role::FootL, "{s}Foot"),
            (Role::UpperArmL, "{s}ShldrBend"),
            (Role::ForearmL, "{s}ForearmBend"),
            (Role::HandL, "{s}Hand"),
        ],
        &[
            "{s}ThighTwist",
            "{s}ShldrTwist",
            "{s}ForearmTwist",
            "{s}Eye",
        ],
    );
    (r.character("genesis8"), want)
}

/// Character Creator 3/4: twist bones and "share" bones beside each limb bone, the first
/// twist bone where its limb bone starts.
fn character_creator() -> (Character, Expect) {
    let s = ["L", "R"];
    let mut r = Rig::new("CC_Base_BoneRoot", "root", 0.0);
    r.add("CC_Base_Hip", "CC_Base_BoneRoot", "hips")
        .add("CC_Base_Pelvis", "CC_Base_Hip", "hips")
        .add("CC_Base_Waist", "CC_Base_Hip", "spine1")
        .add("CC_Base_Spine01", "CC_Base_Waist", "spine2")
        .add("CC_Base_Spine02", "CC_Base_Spine01", "chest")
        .add("CC_Base_NeckTwist01", "CC_Base_Spine02", "neck")
        .add("CC_Base_NeckTwist02", "CC_Base_NeckTwist01", "neck2")
        .add("CC_Base_Head", "CC_Base_NeckTwist02", "head")
        .add("CC_Base_FacialBone", "CC_Base_Head", "head")
        .add("CC_Base_JawRoot", "CC_Base_FacialBone", "jaw")
        .both(s, "CC_Base_{s}_Eye", "CC_Base_FacialBone", "eye")
        .chain(
            s,
            "CC_Base_Pelvis",
            &[
                ("CC_Base_{s}_Thigh", "hip"),
                ("CC_Base_{s}_Calf", "knee"),
                ("CC_Base_{s}_Foot", "ankle"),
                ("CC_Base_{s}_ToeBase", "ball"),
                ("CC_Base_{s}_BigToe1", "toe_end"),
            ],
        )
        .both(s, "CC_Base_{s}_ThighTwist01", "CC_Base_{s}_Thigh", "hip")
        .both(
            s,
            "CC_Base_{s}_ThighTwist02",
            "CC_Base_{s}_Thigh",
            "thigh_mid",
        )
        .both(s, "CC_Base_{s}_CalfTwist01", "CC_Base_{s}_Calf", "knee")
        .both(s, "CC_Base_{s}_CalfTwist02", "CC_Base_{s}_Calf", "shin_mid")
        .both(s, "CC_Base_{s}_KneeShareBone", "CC_Base_{s}_Calf", "knee")
        .chain(
            s,
            "CC_Base_Spine02",
            &[
                ("CC_Base_{s}_Clavicle", "clavicle"),
                ("CC_Base_{s}_Upperarm", "shoulder"),
                ("CC_Base_{s}_Forearm", "elbow"),
                ("CC_Base_{s}_Hand", "wrist"),
                ("CC_Base_{s}_Mid1", "finger"),
                ("CC_Base_{s}_Mid2", "finger_end"),
            ],
        )
        .both(s, "CC_Base_{s}_Thumb1", "CC_Base_{s}_Hand", "thumb")
        .both(
            s,
            "CC_Base_{s}_UpperarmTwist01",
            "CC_Base_{s}_Upperarm",
            "shoulder",
        )
        .both(
            s,
            "CC_Base_{s}_UpperarmTwist02",
            "CC_Base_{s}_Upperarm",
            "upper_arm_mid",
        )
        .both(
            s,
            "CC_Base_{s}_ForearmTwist01",
            "CC_Base_{s}_Forearm",
            "elbow",
        )
        .both(
            s,
            "CC_Base_{s}_ForearmTwist02",
            "CC_Base_{s}_Forearm",
            "forearm_mid",
        )
        .both(
            s,
            "CC_Base_{s}_ElbowShareBone",
            "CC_Base_{s}_Forearm",
            "elbow",
        );
    let want = expect(
        s,
        &[
            (Role::Pelvis, &["CC_Base_Hip", "CC_Base_Pelvis"]),
            (Role::Chest, &["CC_Base_Spine02"]),
            (Role::Head, &["CC_Base_Head"]),
        ],
        &[
            (Role::ThighL, "CC_Base_{s}_Thigh"),
            (Role::ShinL, "CC_Base_{s}_Calf"),
            (Role::FootL, "CC_Base_{s}_Foot"),
            (Role::UpperArmL, "CC_Base_{s}_Upperarm"),
            (Role::ForearmL, "CC_Base_{s}_Forearm"),
            (Role::HandL, "CC_Base_{s}_Hand"),
        ],
        &[
            "CC_Base_{s}_ThighTwist01",
            "CC_Base_{s}_ThighTwist02",
            "CC_Base_{s}_CalfTwist01",
            "CC_Base_{s}_CalfTwist02",
            "CC_Base_{s}_KneeShareBone",
            "CC_Base_{s}_UpperarmTwist01",
            "CC_Base_{s}_UpperarmTwist02",
            "CC_Base_{s}_ForearmTwist01",
            "CC_Base_{s}_ForearmTwist02",
            "CC_Base_{s}_ElbowShareBone",
            "CC_Base_{s}_Eye",
        ],
    );
    (r.character("cc4"), want)
}

/// 3ds Max Biped, as it comes by default: the thighs hang from `Bip01 Spine`, the
/// clavicles from the neck, names with spaces, `Nub` end bones, and `Bip01 Footsteps`.
fn max_biped() -> (Character, Expect) {
    let s = ["L", "R"];
    let mut r = Rig::new("Bip01", "hips", 0.0);
    r.add("Bip01 Pelvis", "Bip01", "hips")
        .add("Bip01 Footsteps", "Bip01", "root")
        .add("Bip01 Spine", "Bip01 Pelvis", "spine1")
        .add("Bip01 Spine1", "Bip01 Spine", "spine3")
        .add("Bip01 Spine2", "Bip01 Spine1", "chest")
        .add("Bip01 Neck", "Bip01 Spine2", "neck")
        .add("Bip01 Head", "Bip01 Neck", "head")
        .add("Bip01 HeadNub", "Bip01 Head", "head_top")
        .chain(
            s,
            "Bip01 Spine",
            &[
                ("Bip01 {s} Thigh", "hip"),
                ("Bip01 {s} Calf", "knee"),
                ("Bip01 {s} Foot", "ankle"),
                ("Bip01 {s} Toe0", "ball"),
                ("Bip01 {s} Toe0Nub", "toe_end"),
            ],
        )
        .chain(
            s,
            "Bip01 Neck",
            &[
                ("Bip01 {s} Clavicle", "clavicle"),
                ("Bip01 {s} UpperArm", "shoulder"),
                ("Bip01 {s} Forearm", "elbow"),
                ("Bip01 {s} Hand", "wrist"),
                ("Bip01 {s} Finger1", "finger"),
                ("Bip01 {s} Finger1Nub", "finger_end"),
            ],
        )
        .chain(
            s,
            "Bip01 {s} Hand",
            &[
                ("Bip01 {s} Finger0", "thumb"),
                ("Bip01 {s} Finger0Nub", "thumb_end"),
            ],
        );
    let want = expect(
        s,
        &[
            (Role::Pelvis, &["Bip01 Pelvis", "Bip01 Spine"]),
            (Role::Chest, &["Bip01 Spine2"]),
            (Role::Head, &["Bip01 Head"]),
        ],
        &[
            (Role::ThighL, "Bip01 {s} Thigh"),
            (Role::ShinL, "Bip01 {s} Calf"),
            (Role::FootL, "Bip01 {s} Foot"),
            (Role::UpperArmL, "Bip01 {s} UpperArm"),
            (Role::ForearmL, "Bip01 {s} Forearm"),
            (Role::HandL, "Bip01 {s} Hand"),
        ],
        &["Bip01 Footsteps", "Bip01 HeadNub", "Bip01 {s} Toe0Nub"],
    );
    (r.character("biped"), want)
}

/// Valve's Biped (Source engine characters): helper bones named after the wrist, elbow,
/// ulna and bicep beside the arm bones, and attachment points on the hands.
fn valve_biped() -> (Character, Expect) {
    let s = ["L", "R"];
    let v = |n: &str| format!("ValveBiped.Bip01_{n}");
    let mut r = Rig::new(&v("Pelvis"), "hips", 30.0);
    r.add(&v("Spine"), &v("Pelvis"), "spine1")
        .add(&v("Spine1"), &v("Spine"), "spine2")
        .add(&v("Spine2"), &v("Spine1"), "spine3")
        .add(&v("Spine4"), &v("Spine2"), "chest")
        .add(&v("Neck1"), &v("Spine4"), "neck")
        .add(&v("Head1"), &v("Neck1"), "head")
        .add("ValveBiped.forward", &v("Head1"), "jaw")
        .chain(
            s,
            &v("Pelvis"),
            &[
                (&v("{s}_Thigh"), "hip"),
                (&v("{s}_Calf"), "knee"),
                (&v("{s}_Foot"), "ankle"),
                (&v("{s}_Toe0"), "ball"),
            ],
        )
        .both(s, &v("{s}_Trapezius"), &v("Spine4"), "clavicle")
        .chain(
            s,
            &v("Spine4"),
            &[
                (&v("{s}_Clavicle"), "clavicle"),
                (&v("{s}_UpperArm"), "shoulder"),
                (&v("{s}_Forearm"), "elbow"),
                (&v("{s}_Hand"), "wrist"),
                (&v("{s}_Finger1"), "finger"),
                (&v("{s}_Finger11"), "finger_end"),
            ],
        )
        .both(s, &v("{s}_Bicep"), &v("{s}_UpperArm"), "upper_arm_mid")
        .both(s, &v("{s}_Elbow"), &v("{s}_UpperArm"), "elbow")
        .both(s, &v("{s}_Ulna"), &v("{s}_Forearm"), "forearm_mid")
        .both(s, &v("{s}_Wrist"), &v("{s}_Forearm"), "wrist")
        .both(s, &v("{s}_Finger0"), &v("{s}_Hand"), "thumb")
        .both(
            s,
            "ValveBiped.Anim_Attachment_{s}H",
            &v("{s}_Hand"),
            "finger",
        );
    let want = expect(
        s,
        &[
            (Role::Pelvis, &[v("Pelvis").as_str()]),
            (Role::Chest, &[v("Spine4").as_str()]),
            (Role::Head, &[v("Head1").as_str()]),
        ],
        &[
            (Role::ThighL, &v("{s}_Thigh")),
            (Role::ShinL, &v("{s}_Calf")),
            (Role::FootL, &v("{s}_Foot")),
            (Role::UpperArmL, &v("{s}_UpperArm")),
            (Role::ForearmL, &v("{s}_Forearm")),
            (Role::HandL, &v("{s}_Hand")),
        ],
        &[
            &v("{s}_Bicep"),
            &v("{s}_Elbow"),
            &v("{s}_Ulna"),
            &v("{s}_Wrist"),
            &v("{s}_Trapezius"),
            "ValveBiped.Anim_Attachment_{s}H",
            "ValveBiped.forward",
        ],
    );
    (r.character("valve"), want)
}

/// Unreal Engine 5's mannequin: IK feet and hands under the root at the feet and hands,
/// twist and corrective bones, five spine joints, two neck joints, a weapon socket.
fn unreal5() -> (Character, Expect) {
    let s = ["l", "r"];
    let mut r = Rig::new("root", "root", 0.0);
    r.add("pelvis", "root", "hips")
        .add("spine_01", "pelvis", "spine1")
        .add("spine_02", "spine_01", "spine2")
        .add("spine_03", "spine_02", "spine3")
        .add("spine_04", "spine_03", "chest")
        .add("spine_05", "spine_04", "chest")
        .add("neck_01", "spine_05", "neck")
        .add("neck_02", "neck_01", "neck2")
        .add("head", "neck_02", "head")
        .chain(
            s,
            "pelvis",
            &[
                ("thigh_{s}", "hip"),
                ("calf_{s}", "knee"),
                ("foot_{s}", "ankle"),
                ("ball_{s}", "ball"),
            ],
        )
        .both(s, "thigh_twist_01_{s}", "thigh_{s}", "thigh_mid")
        .both(s, "thigh_twist_02_{s}", "thigh_{s}", "knee")
        .both(s, "thigh_correctiveRoot_{s}", "thigh_{s}", "hip")
        .both(s, "calf_twist_01_{s}", "calf_{s}", "shin_mid")
        .both(s, "calf_twist_02_{s}", "calf_{s}", "knee")
        .both(s, "calf_correctiveRoot_{s}", "calf_{s}", "knee")
        .chain(
            s,
            "spine_05",
            &[
                ("clavicle_{s}", "clavicle"),
                ("upperarm_{s}", "shoulder"),
                ("lowerarm_{s}", "elbow"),
                ("hand_{s}", "wrist"),
                ("middle_metacarpal_{s}", "finger"),
                ("middle_01_{s}", "finger_end"),
            ],
        )
        .both(s, "thumb_01_{s}", "hand_{s}", "thumb")
        .both(s, "weapon_{s}", "hand_{s}", "finger")
        .both(s, "upperarm_twist_01_{s}", "upperarm_{s}", "upper_arm_mid")
        .both(s, "upperarm_twist_02_{s}", "upperarm_{s}", "elbow")
        .both(s, "upperarm_correctiveRoot_{s}", "upperarm_{s}", "shoulder")
        .both(s, "lowerarm_twist_01_{s}", "lowerarm_{s}", "forearm_mid")
        .both(s, "lowerarm_twist_02_{s}", "lowerarm_{s}", "wrist")
        .both(s, "lowerarm_correctiveRoot_{s}", "lowerarm_{s}", "elbow")
        .add("ik_foot_root", "root", "root")
        .both(s, "ik_foot_{s}", "ik_foot_root", "ankle")
        .add("ik_hand_root", "root", "root")
        .add("ik_hand_gun", "ik_hand_root", "root")
        .both(s, "ik_hand_{s}", "ik_hand_gun", "wrist")
        .add("interaction", "root", "root")
        .add("center_of_mass", "root", "hips");
    let want = expect(
        s,
        &[
            (Role::Pelvis, &["pelvis"]),
            (Role::Chest, &["spine_05"]),
            (Role::Head, &["head"]),
        ],
        &[
            (Role::ThighL, "thigh_{s}"),
            (Role::ShinL, "calf_{s}"),
            (Role::FootL, "foot_{s}"),
            (Role::UpperArmL, "upperarm_{s}"),
            (Role::ForearmL, "lowerarm_{s}"),
            (Role::HandL, "hand_{s}"),
        ],
        &[
            "ik_foot_{s}",
            "ik_hand_{s}",
            "ik_hand_gun",
            "ik_foot_root",
            "ik_hand_root",
            "interaction",
            "center_of_mass",
            "weapon_{s}",
            "thigh_twist_01_{s}",
            "thigh_twist_02_{s}",
            "calf_twist_01_{s}",
            "upperarm_twist_01_{s}",
            "lowerarm_twist_01_{s}",
            "upperarm_correctiveRoot_{s}",
        ],
    );
    (r.character("ue5"), want)
}

/// Rigify's deform bones as a game export keeps them: each limb bone split in two in line
/// (`DEF-thigh.L`, `DEF-thigh.L.001`), the spine numbered to the head (`DEF-spine.006`),
/// side pelvis bones.
fn rigify_deform() -> (Character, Expect) {
    let s = ["L", "R"];
    let mut r = Rig::new("DEF-spine", "hips", 45.0);
    r.add("DEF-spine.001", "DEF-spine", "spine1")
        .add("DEF-spine.002", "DEF-spine.001", "spine2")
        .add("DEF-spine.003", "DEF-spine.002", "chest")
        .add("DEF-spine.004", "DEF-spine.003", "neck")
        .add("DEF-spine.005", "DEF-spine.004", "neck2")
        .add("DEF-spine.006", "DEF-spine.005", "head")
        .add("DEF-jaw", "DEF-spine.006", "jaw")
        .both(s, "DEF-pelvis.{s}", "DEF-spine", "hips")
        .chain(
            s,
            "DEF-spine",
            &[
                ("DEF-thigh.{s}", "hip"),
                ("DEF-thigh.{s}.001", "thigh_mid"),
                ("DEF-shin.{s}", "knee"),
                ("DEF-shin.{s}.001", "shin_mid"),
                ("DEF-foot.{s}", "ankle"),
                ("DEF-toe.{s}", "ball"),
            ],
        )
        .chain(
            s,
            "DEF-spine.003",
            &[
                ("DEF-shoulder.{s}", "clavicle"),
                ("DEF-upper_arm.{s}", "shoulder"),
                ("DEF-upper_arm.{s}.001", "upper_arm_mid"),
                ("DEF-forearm.{s}", "elbow"),
                ("DEF-forearm.{s}.001", "forearm_mid"),
                ("DEF-hand.{s}", "wrist"),
                ("DEF-f_middle.01.{s}", "finger"),
                ("DEF-f_middle.02.{s}", "finger_end"),
            ],
        )
        .both(s, "DEF-thumb.01.{s}", "DEF-hand.{s}", "thumb");
    let want = expect(
        s,
        &[
            (Role::Pelvis, &["DEF-spine"]),
            (Role::Chest, &["DEF-spine.003"]),
            (Role::Head, &["DEF-spine.006"]),
        ],
        &[
            (Role::ThighL, "DEF-thigh.{s}"),
            (Role::ShinL, "DEF-shin.{s}"),
            (Role::FootL, "DEF-foot.{s}"),
            (Role::UpperArmL, "DEF-upper_arm.{s}"),
            (Role::ForearmL, "DEF-forearm.{s}"),
            (Role::HandL, "DEF-hand.{s}"),
        ],
        &[
            "DEF-thigh.{s}.001",
            "DEF-shin.{s}.001",
            "DEF-upper_arm.{s}.001",
            "DEF-forearm.{s}.001",
            "DEF-pelvis.{s}",
        ],
    );
    (r.character("rigify"), want)
}

/// Maya HumanIK: a `Character1_` prefix without a colon, roll bones beside each limb bone.
fn human_ik() -> (Character, Expect) {
    let s = ["Left", "Right"];
    let p = |n: &str| format!("Character1_{n}");
    let mut r = Rig::new(&p("Reference"), "root", 0.0);
    r.add(&p("Hips"), &p("Reference"), "hips")
        .add(&p("Spine"), &p("Hips"), "spine1")
        .add(&p("Spine1"), &p("Spine"), "spine3")
        .add(&p("Spine2"), &p("Spine1"), "chest")
        .add(&p("Neck"), &p("Spine2"), "neck")
        .add(&p("Head"), &p("Neck"), "head")
        .chain(
            s,
            &p("Hips"),
            &[
                (&p("{s}UpLeg"), "hip"),
                (&p("{s}Leg"), "knee"),
                (&p("{s}Foot"), "ankle"),
                (&p("{s}ToeBase"), "ball"),
            ],
        )
        .both(s, &p("{s}UpLegRoll"), &p("{s}UpLeg"), "thigh_mid")
        .both(s, &p("{s}LegRoll"), &p("{s}Leg"), "shin_mid")
        .chain(
            s,
            &p("Spine2"),
            &[
                (&p("{s}Shoulder"), "clavicle"),
                (&p("{s}Arm"), "shoulder"),
                (&p("{s}ForeArm"), "elbow"),
                (&p("{s}Hand"), "wrist"),
                (&p("{s}HandMiddle1"), "finger"),
                (&p("{s}HandMiddle2"), "finger_end"),
            ],
        )
        .both(s, &p("{s}ArmRoll"), &p("{s}Arm"), "upper_arm_mid")
        .both(s, &p("{s}ForeArmRoll"), &p("{s}ForeArm"), "forearm_mid");
    let want = expect(
        s,
        &[
            (Role::Pelvis, &[p("Hips").as_str()]),
            (Role::Chest, &[p("Spine2").as_str()]),
            (Role::Head, &[p("Head").as_str()]),
        ],
        &[
            (Role::ThighL, &p("{s}UpLeg")),
            (Role::ShinL, &p("{s}Leg")),
            (Role::FootL, &p("{s}Foot")),
            (Role::UpperArmL, &p("{s}Arm")),
            (Role::ForearmL, &p("{s}ForeArm")),
            (Role::HandL, &p("{s}Hand")),
        ],
        &[
            &p("{s}UpLegRoll"),
            &p("{s}LegRoll"),
            &p("{s}ArmRoll"),
            &p("{s}ForeArmRoll"),
        ],
    );
    (r.character("humanik"), want)
}

/// Mixamo as its auto-rigger writes it (glTF from its FBX): a `mixamorig:` prefix, a
/// collar named `LeftShoulder`, three spine joints, end bones (`HeadTop_End`,
/// `LeftToe_End`), four-joint fingers.
fn mixamo() -> (Character, Expect) {
    let s = ["Left", "Right"];
    let m = |n: &str| format!("mixamorig:{n}");
    let mut r = Rig::new(&m("Hips"), "hips", 0.0);
    r.add(&m("Spine"), &m("Hips"), "spine1")
        .add(&m("Spine1"), &m("Spine"), "spine3")
        .add(&m("Spine2"), &m("Spine1"), "chest")
        .add(&m("Neck"), &m("Spine2"), "neck")
        .add(&m("Head"), &m("Neck"), "head")
        .add(&m("HeadTop_End"), &m("Head"), "head_top")
        .both(s, &m("{s}Eye"), &m("Head"), "eye")
        .chain(
            s,
            &m("Hips"),
            &[
                (&m("{s}UpLeg"), "hip"),
                (&m("{s}Leg"), "knee"),
                (&m("{s}Foot"), "ankle"),
                (&m("{s}ToeBase"), "ball"),
                (&m("{s}Toe_End"), "toe_end"),
            ],
        )
        .chain(
            s,
            &m("Spine2"),
            &[
                (&m("{s}Shoulder"), "clavicle"),
                (&m("{s}Arm"), "shoulder"),
                (&m("{s}ForeArm"), "elbow"),
                (&m("{s}Hand"), "wrist"),
                (&m("{s}HandMiddle1"), "finger"),
                (&m("{s}HandMiddle4"), "finger_end"),
            ],
        )
        .chain(
            s,
            &m("{s}Hand"),
            &[
                (&m("{s}HandThumb1"), "thumb"),
                (&m("{s}HandThumb4"), "thumb_end"),
            ],
        );
    let want = expect(
        s,
        &[
            (Role::Pelvis, &[m("Hips").as_str()]),
            (Role::Chest, &[m("Spine2").as_str()]),
            (Role::Head, &[m("Head").as_str()]),
        ],
        &[
            (Role::ThighL, &m("{s}UpLeg")),
            (Role::ShinL, &m("{s}Leg")),
            (Role::FootL, &m("{s}Foot")),
            (Role::UpperArmL, &m("{s}Arm")),
            (Role::ForearmL, &m("{s}ForeArm")),
            (Role::HandL, &m("{s}Hand")),
        ],
        &[
            &m("HeadTop_End"),
            &m("{s}Toe_End"),
            &m("{s}Eye"),
            &m("{s}Shoulder"),
        ],
    );
    (r.character("mixamo"), want)
}

/// MakeHuman's default skeleton: the pelvis is `root`, the legs hang from side bones
/// `pelvis.L`, each limb bone is split in two numbered bones (`upperleg01.L`,
/// `upperleg02.L`), the spine is numbered from the top (`spine05` lowest), a sided
/// `shoulder01.L` lies between the clavicle and the upper arm, and the hand is `wrist.L`.
fn makehuman() -> (Character, Expect) {
    let s = ["L", "R"];
    let mut r = Rig::new("root", "hips", 30.0);
    r.add("spine05", "root", "spine1")
        .add("spine04", "spine05", "spine2")
        .add("spine03", "spine04", "spine3")
        .add("spine02", "spine03", "chest")
        .add("spine01", "spine02", "chest")
        .add("neck01", "spine01", "neck")
        .add("neck02", "neck01", "neck2")
        .add("head", "neck02", "head")
        .add("jaw", "head", "jaw")
        .both(s, "eye.{s}", "head", "eye")
        .chain(
            s,
            "root",
            &[
                ("pelvis.{s}", "hips"),
                ("upperleg01.{s}", "hip"),
                ("upperleg02.{s}", "thigh_mid"),
                ("lowerleg01.{s}", "knee"),
                ("lowerleg02.{s}", "shin_mid"),
                ("foot.{s}", "ankle"),
                ("toe1-1.{s}", "ball"),
            ],
        )
        .chain(
            s,
            "spine01",
            &[
                ("clavicle.{s}", "clavicle"),
                ("shoulder01.{s}", "shoulder"),
                ("upperarm01.{s}", "shoulder"),
                ("upperarm02.{s}", "upper_arm_mid"),
                ("lowerarm01.{s}", "elbow"),
                ("lowerarm02.{s}", "forearm_mid"),
                ("wrist.{s}", "wrist"),
                ("finger3-1.{s}", "finger"),
                ("finger3-2.{s}", "finger_end"),
            ],
        )
        .both(s, "finger1-1.{s}", "wrist.{s}", "thumb");
    let want = expect(
        s,
        &[
            (Role::Pelvis, &["root"]),
            (Role::Chest, &["spine01", "spine02"]),
            (Role::Head, &["head"]),
        ],
        &[
            (Role::ThighL, "upperleg01.{s}"),
            (Role::ShinL, "lowerleg01.{s}"),
            (Role::FootL, "foot.{s}"),
            (Role::UpperArmL, "upperarm01.{s}"),
            (Role::ForearmL, "lowerarm01.{s}"),
            (Role::HandL, "wrist.{s}"),
        ],
        &[
            "pelvis.{s}",
            "upperleg02.{s}",
            "lowerleg02.{s}",
            "upperarm02.{s}",
            "lowerarm02.{s}",
            "shoulder01.{s}",
            "eye.{s}",
        ],
    );
    (r.character("makehuman"), want)
}

/// A rig in one style with what it must come out as.
type Style = fn() -> (Character, Expect);

/// SMPL, the body model most motion datasets and pose estimators write (AMASS, and the
/// BVH and glTF their tools export): joints named after where they are, not the bone
/// below, so `left_hip` is the thigh, `left_knee` the shin, `left_shoulder` the upper arm
/// and `left_wrist` the hand, with `left_collar` the clavicle and `left_foot`, `left_hand`
/// the toes and fingers.
fn smpl() -> (Character, Expect) {
    let s = ["left", "right"];
    let mut r = Rig::new("pelvis", "hips", 30.0);
    r.add("spine1", "pelvis", "spine1")
        .add("spine2", "spine1", "spine3")
        .add("spine3", "spine2", "chest")
        .add("neck", "spine3", "neck")
        .add("head", "neck", "head")
        .chain(
            s,
            "pelvis",
            &[
                ("{s}_hip", "hip"),
                ("{s}_knee", "knee"),
                ("{s}_ankle", "ankle"),
                ("{s}_foot", "ball"),
            ],
        )
        .chain(
            s,
            "spine3",
            &[
                ("{s}_collar", "clavicle"),
                ("{s}_shoulder", "shoulder"),
                ("{s}_elbow", "elbow"),
                ("{s}_wrist", "wrist"),
                ("{s}_hand", "finger"),
            ],
        );
    let want = expect(
        s,
        &[
            (Role::Pelvis, &["pelvis"]),
            (Role::Chest, &["spine3", "spine2"]),
            (Role::Head, &["head"]),
        ],
        &[
            (Role::ThighL, "{s}_hip"),
            (Role::ShinL, "{s}_knee"),
            (Role::FootL, "{s}_ankle"),
            (Role::UpperArmL, "{s}_shoulder"),
            (Role::ForearmL, "{s}_elbow"),
            (Role::HandL, "{s}_wrist"),
        ],
        &["{s}_collar", "{s}_hand", "{s}_foot"],
    );
    (r.character("smpl"), want)
}

/// Kinect v2's body tracking: the side after the part (`ShoulderLeft`, `KneeLeft`), the
/// spine as `SpineBase`, `SpineMid`, `SpineShoulder`, and `HandLeft`, `HandTipLeft` and
/// `ThumbLeft` past the wrist.
fn kinect() -> (Character, Expect) {
    let s = ["Left", "Right"];
    let mut r = Rig::new("SpineBase", "hips", 45.0);
    r.add("SpineMid", "SpineBase", "spine3")
        .add("SpineShoulder", "SpineMid", "chest")
        .add("Neck", "SpineShoulder", "neck")
        .add("Head", "Neck", "head")
        .chain(
            s,
            "SpineBase",
            &[
                ("Hip{s}", "hip"),
                ("Knee{s}", "knee"),
                ("Ankle{s}", "ankle"),
                ("Foot{s}", "ball"),
            ],
        )
        .chain(
            s,
            "SpineShoulder",
            &[
                ("Shoulder{s}", "shoulder"),
                ("Elbow{s}", "elbow"),
                ("Wrist{s}", "wrist"),
                ("Hand{s}", "finger"),
                ("HandTip{s}", "finger_end"),
            ],
        )
        .both(s, "Thumb{s}", "Wrist{s}", "thumb");
    let want = expect(
        s,
        &[
            (Role::Pelvis, &["SpineBase"]),
            (Role::Chest, &["SpineShoulder"]),
            (Role::Head, &["Head"]),
        ],
        &[
            (Role::ThighL, "Hip{s}"),
            (Role::ShinL, "Knee{s}"),
            (Role::FootL, "Ankle{s}"),
            (Role::UpperArmL, "Shoulder{s}"),
            (Role::ForearmL, "Elbow{s}"),
            (Role::HandL, "Wrist{s}"),
        ],
        &["Hand{s}", "HandTip{s}", "Thumb{s}", "Foot{s}"],
    );
    (r.character("kinect"), want)
}

/// Bandai Namco Research's motion dataset: `_L`/`_R` after Unity-like part names,
/// `Shoulder_L` the clavicle, `UpperLeg_L`, `LowerArm_R`, `Toes_L`.
fn bandai_namco() -> (Character, Expect) {
    let s = ["L", "R"];
    let mut r = Rig::new("Hips", "hips", 0.0);
    r.add("Spine", "Hips", "spine1")
        .add("Chest", "Spine", "chest")
        .add("Neck", "Chest", "neck")
        .add("Head", "Neck", "head")
        .chain(
            s,
            "Hips",
            &[
                ("UpperLeg_{s}", "hip"),
                ("LowerLeg_{s}", "knee"),
                ("Foot_{s}", "ankle"),
                ("Toes_{s}", "ball"),
            ],
        )
        .chain(
            s,
            "Chest",
            &[
                ("Shoulder_{s}", "clavicle"),
                ("UpperArm_{s}", "shoulder"),
                ("LowerArm_{s}", "elbow"),
                ("Hand_{s}", "wrist"),
            ],
        );
    let want = expect(
        s,
        &[
            (Role::Pelvis, &["Hips"]),
            (Role::Chest, &["Chest"]),
            (Role::Head, &["Head"]),
        ],
        &[
            (Role::ThighL, "UpperLeg_{s}"),
            (Role::ShinL, "LowerLeg_{s}"),
            (Role::FootL, "Foot_{s}"),
            (Role::UpperArmL, "UpperArm_{s}"),
            (Role::ForearmL, "LowerArm_{s}"),
            (Role::HandL, "Hand_{s}"),
        ],
        &["Shoulder_{s}", "Toes_{s}"],
    );
    (r.character("bandai_namco"), want)
}

/// A mech whose own part names end in a letter before Blender's side suffix: `PalmR.L` is
/// the left palm (its R is part of the name), `ThighB.R` the right thigh.
fn mech() -> (Character, Expect) {
    let s = ["L", "R"];
    let mut r = Rig::new("Pelvis", "hips", 0.0);
    r.add("Torso", "Pelvis", "spine1")
        .add("Cockpit", "Torso", "chest")
        .add("Head", "Cockpit", "head")
        .chain(
            s,
            "Pelvis",
            &[
                ("ThighB.{s}", "hip"),
                ("ShinB.{s}", "knee"),
                ("FootB.{s}", "ankle"),
            ],
        )
        .chain(
            s,
            "Cockpit",
            &[
                ("UpperArmR.{s}", "shoulder"),
                ("ForearmR.{s}", "elbow"),
                ("PalmR.{s}", "wrist"),
            ],
        );
    let want = expect(
        s,
        &[(Role::Pelvis, &["Pelvis"]), (Role::Head, &["Head"])],
        &[
            (Role::ThighL, "ThighB.{s}"),
            (Role::ShinL, "ShinB.{s}"),
            (Role::FootL, "FootB.{s}"),
            (Role::UpperArmL, "UpperArmR.{s}"),
            (Role::ForearmL, "ForearmR.{s}"),
            (Role::HandL, "PalmR.{s}"),
        ],
        &[],
    );
    (r.character("mech"), want)
}

/// Every style, facing +Z as glTF says and turned as files converted from other tools
/// face (+X, -Z, 135°): its roles on the joints its rigger meant, its helpers bodiless.
#[test]
fn rigs_in_styles_the_data_files_do_not_have_get_their_roles() {
    let styles: [(&str, Style); 13] = [
        ("Mixamo", mixamo),
        ("MakeHuman", makehuman),
        ("Daz Genesis 8", daz_genesis8),
        ("Character Creator", character_creator),
        ("3ds Max Biped", max_biped),
        ("Valve Biped", valve_biped),
        ("Unreal 5 mannequin", unreal5),
        ("Rigify deform bones", rigify_deform),
        ("Maya HumanIK", human_ik),
        ("SMPL", smpl),
        ("Kinect v2", kinect),
        ("Bandai Namco", bandai_namco),
        ("Mech", mech),
    ];
    let mut bad = Vec::new();
    for (label, make) in styles {
        let (c, want) = make();
        for yaw in [0.0f32, 90.0, 180.0, 135.0] {
            let turned = c.turned(yaw.to_radians());
            bad.extend(check(&format!("{label} at {yaw}°"), &turned, &want));
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

/// A dog rigged with Rigify's quadruped names (`DEF-thigh.L`, `DEF-upper_arm.L`), facing
/// +Z with its back level: names that promise a humanoid, on a body that stands on all
/// four. It is taken for the quadruped it is, without the warning a humanoid the skeleton
/// denies gets, and the leg joints it stands bent are hinges.
#[test]
fn a_quadruped_with_a_persons_limb_names_is_a_quadruped_without_a_warning() {
    let mut rows: Vec<(String, Option<usize>, Vec3)> = vec![
        ("DEF-spine".into(), None, Vec3::new(0.0, 0.5, -0.3)),
        ("DEF-spine.001".into(), Some(0), Vec3::new(0.0, 0.52, -0.1)),
        ("DEF-spine.002".into(), Some(1), Vec3::new(0.0, 0.53, 0.1)),
        ("DEF-spine.003".into(), Some(2), Vec3::new(0.0, 0.52, 0.25)),
        ("DEF-spine.004".into(), Some(3), Vec3::new(0.0, 0.6, 0.35)),
        ("DEF-spine.005".into(), Some(4), Vec3::new(0.0, 0.68, 0.42)),
        ("DEF-tail".into(), Some(0), Vec3::new(0.0, 0.52, -0.4)),
    ];
    for (s, x) in [("L", 0.08f32), ("R", -0.08)] {
        let n = rows.len();
        let mut leg = |name: &str, parent: usize, p: Vec3| {
            rows.push((format!("DEF-{name}.{s}"), Some(parent), p));
        };
        // Hind leg: the knee forward, the hock back.
        leg("thigh", 0, Vec3::new(x, 0.48, -0.3));
        leg("shin", n, Vec3::new(x, 0.28, -0.25));
        leg("foot", n + 1, Vec3::new(x, 0.1, -0.32));
        leg("toe", n + 2, Vec3::new(x, 0.0, -0.28));
        // Foreleg from the withers.
        leg("shoulder", 3, Vec3::new(x * 0.5, 0.5, 0.25));
        leg("upper_arm", n + 4, Vec3::new(x, 0.42, 0.27));
        leg("forearm", n + 5, Vec3::new(x, 0.25, 0.24));
        leg("hand", n + 6, Vec3::new(x, 0.08, 0.25));
        leg("f_toe", n + 7, Vec3::new(x, 0.0, 0.3));
    }
    let c = common::character_from_rows("dog", &rows);
    let roles = recognise_roles(&c);
    assert!(!roles.humanoid, "{}", roles.why);
    assert!(roles.why.contains("quadruped"), "{}", roles.why);
    assert_eq!(roles.warning, None);
    let spec = build_spec(&c, &BuildOptions::default()).unwrap();
    for s in ["L", "R"] {
        for child in [
            format!("DEF-shin.{s}"),
            format!("DEF-foot.{s}"),
            format!("DEF-hand.{s}"),
        ] {
            let j = spec.joints.iter().find(|j| j.child == child).unwrap();
            assert!(
                matches!(j.kind, ragdoll::spec::JointKind::Hinge { .. }),
                "{child}: {:?}",
                j.kind
            );
        }
    }
}
