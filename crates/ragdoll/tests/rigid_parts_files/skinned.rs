//! Skinned characters in the layouts game exporters write, built on the box robot's
//! hierarchy: rigid meshes parented to bones beside a small skinned mesh (as the three.js
//! RobotExpressive has its head and torso), and one skin per mesh, each listing only the
//! bones its mesh uses.

use std::collections::HashMap;

use glam::{Mat4, Quat, Vec3};
use serde_json::{Value, json};

use super::{Doc, ROBOT, UNIT_BOX, box_triangles};

/// How the robot's boxes are bound to its bones.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SkinStyle {
    /// One skin over every bone whose only skinned mesh is the two hands; every other part
    /// is a mesh without a skin, on its bone's node or on a child node of it.
    PartsOnBones,
    /// Five skinned meshes (legs, torso, head, each arm), each with its own skin of only
    /// its bones, listed children first; plus a crate beside the robot with a skin of its
    /// own bone, joined to nothing.
    FiveSkins,
}

/// The parts a [`SkinStyle::FiveSkins`] mesh holds, in the order its skin lists them.
pub const FIVE_SKINS: [(&str, &[&str]); 5] = [
    (
        "legs",
        &[
            "Foot.L",
            "LowerLeg.L",
            "UpperLeg.L",
            "Foot.R",
            "LowerLeg.R",
            "UpperLeg.R",
        ],
    ),
    ("torso", &["Chest", "Spine", "Hips"]),
    ("head", &["Head"]),
    ("arm L", &["LowerArm.L", "UpperArm.L"]),
    ("arm R", &["UpperArm.R", "LowerArm.R"]),
];

/// Each robot part's node: its world matrix in the rest pose under an armature turned
/// `facing_deg` about +Y.
pub fn part_worlds(facing_deg: f32) -> HashMap<&'static str, Mat4> {
    let turn = Mat4::from_quat(Quat::from_rotation_y(facing_deg.to_radians()));
    let mut out: HashMap<&str, Mat4> = HashMap::new();
    for (name, parent, at, ..) in ROBOT {
        let above = parent.map_or(turn, |p| out[p]);
        out.insert(name, above * Mat4::from_translation(Vec3::from(at)));
    }
    out
}

/// The corners of a box `size` wide centred on `centre` (eight, as [`UNIT_BOX`]), in
/// `world`'s frame.
fn corners(world: Mat4, size: Vec3, centre: Vec3) -> Vec<Vec3> {
    UNIT_BOX
        .iter()
        .map(|&c| world.transform_point3(centre + c * size))
        .collect()
}

impl Doc {
    /// A skinned mesh of boxes, each bound with weight 1 to one skin slot: `boxes` are
    /// (slot, the box's corners in bind space, world). Returns the mesh index.
    pub fn skinned_boxes(&mut self, name: &str, boxes: &[(u16, Vec<Vec3>)]) -> usize {
        let (mut pos, mut idx, mut jnt, mut wgt) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for (slot, c) in boxes {
            let base = pos.len() as u16;
            pos.extend_from_slice(c);
            idx.extend(box_triangles(base));
            for _ in 0..8 {
                jnt.extend([*slot, 0, 0, 0]);
                wgt.extend([1.0f32, 0.0, 0.0, 0.0]);
            }
        }
        let lo = pos.iter().copied().fold(Vec3::INFINITY, Vec3::min);
        let hi = pos.iter().copied().fold(Vec3::NEG_INFINITY, Vec3::max);
        let floats = |v: &[f32]| -> Vec<u8> { v.iter().flat_map(|f| f.to_le_bytes()).collect() };
        let flat: Vec<f32> = pos.iter().flat_map(|p| p.to_array()).collect();
        let pv = self.view(&floats(&flat));
        let jv = self.view(
            &jnt.iter()
                .flat_map(|j| j.to_le_bytes())
                .collect::<Vec<u8>>(),
        );
        let wv = self.view(&floats(&wgt));
        let iv = self.view(
            &idx.iter()
                .flat_map(|i| i.to_le_bytes())
                .collect::<Vec<u8>>(),
        );
        let n = pos.len();
        let pa = self.accessor(json!({"bufferView": pv, "componentType": 5126, "count": n,
            "type": "VEC3", "min": lo.to_array(), "max": hi.to_array()}));
        let ja = self
            .accessor(json!({"bufferView": jv, "componentType": 5123, "count": n, "type": "VEC4"}));
        let wa = self
            .accessor(json!({"bufferView": wv, "componentType": 5126, "count": n, "type": "VEC4"}));
        let ia = self.accessor(
            json!({"bufferView": iv, "componentType": 5123, "count": idx.len(), "type": "SCALAR"}),
        );
        self.meshes
            .push(json!({"name": name, "primitives": [{"attributes":
            {"POSITION": pa, "JOINTS_0": ja, "WEIGHTS_0": wa}, "indices": ia}]}));
        self.meshes.len() - 1
    }

    /// A skin of these joint nodes, bound where `worlds` (their rest world matrices) put
    /// them. Returns the skin index.
    pub fn skin(&mut self, joints: &[usize], worlds: &[Mat4]) -> usize {
        let ibm: Vec<u8> = worlds
            .iter()
            .flat_map(|w| w.inverse().to_cols_array())
            .flat_map(f32::to_le_bytes)
            .collect();
        let v = self.view(&ibm);
        let a = self.accessor(json!({"bufferView": v, "componentType": 5126,
            "count": joints.len(), "type": "MAT4"}));
        self.skins
            .push(json!({"joints": joints, "inverseBindMatrices": a}));
        self.skins.len() - 1
    }

    /// A node at the scene root drawing `mesh` with `skin`.
    pub fn skinned_node(&mut self, name: &str, mesh: usize, skin: usize) -> usize {
        self.nodes
            .push(json!({"name": name, "mesh": mesh, "skin": skin}));
        self.nodes.len() - 1
    }
}

/// The box robot (1.85 m, faces +Z before the turn) as a skinned file in `style`, its
/// armature turned `facing_deg` about +Y.
pub fn skinned_robot(style: SkinStyle, facing_deg: f32) -> Vec<u8> {
    let mut d = Doc::default();
    let turn = Quat::from_rotation_y(facing_deg.to_radians());
    let armature = d.node("Armature", Vec3::ZERO, None);
    d.nodes[armature]["rotation"] = json!(turn.to_array());
    let worlds = part_worlds(facing_deg);
    let mut index: HashMap<&str, usize> = HashMap::new();
    let mut roots = vec![armature];
    for (k, (name, parent, at, size, centre)) in ROBOT.into_iter().enumerate() {
        // Parts on bones: even parts on the bone's own node, odd ones on a child of it.
        let mesh = (style == SkinStyle::PartsOnBones)
            .then(|| d.cuboid(name, Vec3::from(size), Vec3::from(centre)));
        let on_bone = if k % 2 == 0 { mesh } else { None };
        let n = d.node(name, Vec3::from(at), on_bone);
        d.child(parent.map_or(armature, |p| index[p]), n);
        index.insert(name, n);
        if let (Some(m), None) = (mesh, on_bone) {
            let holder = d.node(&format!("{name}_mesh"), Vec3::ZERO, Some(m));
            d.child(n, holder);
        }
    }
    let part = |name: &str| ROBOT.iter().find(|p| p.0 == name).unwrap();
    match style {
        SkinStyle::PartsOnBones => {
            let joints: Vec<usize> = ROBOT.iter().map(|p| index[p.0]).collect();
            let ws: Vec<Mat4> = ROBOT.iter().map(|p| worlds[p.0]).collect();
            let skin = d.skin(&joints, &ws);
            let hand = |slot: u16, bone: &str| {
                let c = Vec3::new(0.0, -0.30, 0.0);
                (slot, corners(worlds[bone], Vec3::new(0.08, 0.08, 0.04), c))
            };
            let slot = |bone: &str| ROBOT.iter().position(|p| p.0 == bone).unwrap() as u16;
            let hands = d.skinned_boxes(
                "hands",
                &[
                    hand(slot("LowerArm.L"), "LowerArm.L"),
                    hand(slot("LowerArm.R"), "LowerArm.R"),
                ],
            );
            roots.push(d.skinned_node("Hands", hands, skin));
        }
        SkinStyle::FiveSkins => {
            for (mesh_name, bones) in FIVE_SKINS {
                let joints: Vec<usize> = bones.iter().map(|b| index[b]).collect();
                let ws: Vec<Mat4> = bones.iter().map(|b| worlds[b]).collect();
                let skin = d.skin(&joints, &ws);
                let boxes: Vec<(u16, Vec<Vec3>)> = bones
                    .iter()
                    .enumerate()
                    .map(|(s, b)| {
                        let (_, _, _, size, centre) = part(b);
                        (
                            s as u16,
                            corners(worlds[b], Vec3::from(*size), Vec3::from(*centre)),
                        )
                    })
                    .collect();
                let mesh = d.skinned_boxes(mesh_name, &boxes);
                roots.push(d.skinned_node(mesh_name, mesh, skin));
            }
            // A crate 0.2 m high, two metres aside on its own bone: a prop, not part of the
            // robot (and lower than the fallen robot's top, so it never stands for it).
            let bone = d.node("CrateBone", Vec3::new(2.0, 0.1, 0.0), None);
            roots.push(bone);
            let at = Mat4::from_translation(Vec3::new(2.0, 0.1, 0.0));
            let skin = d.skin(&[bone], &[at]);
            let mesh = d.skinned_boxes("crate", &[(0, corners(at, Vec3::splat(0.2), Vec3::ZERO))]);
            roots.push(d.skinned_node("Crate", mesh, skin));
        }
    }
    d.glb(&roots, Value::Object(Default::default()))
}
