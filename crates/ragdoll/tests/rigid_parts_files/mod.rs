//! glTF files made of rigid mesh parts under a node hierarchy, built in code: shared by
//! `rigid_parts.rs` and the CLI's `rigid_parts_cli.rs` (which includes this file by path).

#![allow(dead_code)] // each test binary uses its own subset

use std::collections::HashMap;

use glam::Vec3;
use serde_json::{Value, json};

mod bones;
mod skinned;

#[allow(unused_imports)] // not every test binary uses them
pub use bones::{Bone, Bones, bones_glb, chibi, horse, spider};
#[allow(unused_imports)]
pub use skinned::{SkinStyle, skinned_robot};

/// The corners of a box one unit wide centred on the origin, corner `k` at -0.5 or +0.5
/// along X, Y and Z as bits 0, 1 and 2 of `k` say.
pub const UNIT_BOX: [Vec3; 8] = [
    Vec3::new(-0.5, -0.5, -0.5),
    Vec3::new(0.5, -0.5, -0.5),
    Vec3::new(-0.5, 0.5, -0.5),
    Vec3::new(0.5, 0.5, -0.5),
    Vec3::new(-0.5, -0.5, 0.5),
    Vec3::new(0.5, -0.5, 0.5),
    Vec3::new(-0.5, 0.5, 0.5),
    Vec3::new(0.5, 0.5, 0.5),
];

/// The twelve triangles (outward) of a box whose [`UNIT_BOX`] corners start at vertex
/// `base`.
pub fn box_triangles(base: u16) -> Vec<u16> {
    const FACES: [[u16; 4]; 6] = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    FACES
        .iter()
        .flat_map(|f| [f[0], f[1], f[2], f[0], f[2], f[3]])
        .map(|i| base + i)
        .collect()
}

/// A glTF document under construction: one binary buffer, its views and accessors.
#[derive(Default)]
pub struct Doc {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
    meshes: Vec<Value>,
    nodes: Vec<Value>,
    skins: Vec<Value>,
}

impl Doc {
    pub fn view(&mut self, bytes: &[u8]) -> usize {
        while self.bin.len() % 4 != 0 {
            self.bin.push(0);
        }
        self.views
            .push(json!({"buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len()}));
        self.bin.extend_from_slice(bytes);
        self.views.len() - 1
    }

    pub fn accessor(&mut self, a: Value) -> usize {
        self.accessors.push(a);
        self.accessors.len() - 1
    }

    /// A box mesh `size` wide, centred on `centre` in its node's space; returns its index.
    pub fn cuboid(&mut self, name: &str, size: Vec3, centre: Vec3) -> usize {
        let h = size / 2.0;
        let pos: Vec<Vec3> = UNIT_BOX.iter().map(|&c| centre + c * size).collect();
        let idx = box_triangles(0);
        let pbytes: Vec<u8> = pos
            .iter()
            .flat_map(|p| p.to_array())
            .flat_map(f32::to_le_bytes)
            .collect();
        let ibytes: Vec<u8> = idx.iter().flat_map(|i| i.to_le_bytes()).collect();
        let pv = self.view(&pbytes);
        let iv = self.view(&ibytes);
        let lo = centre - h;
        let hi = centre + h;
        let pa = self.accessor(json!({"bufferView": pv, "componentType": 5126, "count": 8,
            "type": "VEC3", "min": lo.to_array(), "max": hi.to_array()}));
        let ia = self.accessor(
            json!({"bufferView": iv, "componentType": 5123, "count": idx.len(), "type": "SCALAR"}),
        );
        self.meshes.push(
            json!({"name": name, "primitives": [{"attributes": {"POSITION": pa}, "indices": ia}]}),
        );
        self.meshes.len() - 1
    }

    /// A node at `at` (relative to its parent) carrying `mesh`; returns its index.
    pub fn node(&mut self, name: &str, at: Vec3, mesh: Option<usize>) -> usize {
        let mut n = json!({"name": name, "translation": at.to_array()});
        if let Some(m) = mesh {
            n["mesh"] = json!(m);
        }
        self.nodes.push(n);
        self.nodes.len() - 1
    }

    pub fn child(&mut self, parent: usize, child: usize) {
        let c = self.nodes[parent]
            .as_object_mut()
            .unwrap()
            .entry("children")
            .or_insert(json!([]));
        c.as_array_mut().unwrap().push(json!(child));
    }

    /// The GLB, with `extensions` at the top level and `roots` as the scene.
    pub fn glb(self, roots: &[usize], extensions: Value) -> Vec<u8> {
        let mut doc = json!({
            "asset": {"version": "2.0"},
            "buffers": [{"byteLength": self.bin.len()}],
            "bufferViews": self.views,
            "accessors": self.accessors,
            "meshes": self.meshes,
            "nodes": self.nodes,
            "scenes": [{"nodes": roots}],
            "scene": 0,
        });
        if !self.skins.is_empty() {
            doc["skins"] = json!(self.skins);
        }
        if self.bufferless() {
            for k in ["buffers", "bufferViews", "accessors", "meshes"] {
                doc.as_object_mut().unwrap().remove(k);
            }
        }
        if let Some(o) = extensions.as_object().filter(|o| !o.is_empty()) {
            let used: Vec<&String> = o.keys().collect();
            doc["extensionsUsed"] = json!(used);
            doc["extensions"] = extensions;
        }
        glb(&doc, &self.bin)
    }

    fn bufferless(&self) -> bool {
        self.bin.is_empty()
    }
}

pub fn glb(json: &Value, bin: &[u8]) -> Vec<u8> {
    let mut j = serde_json::to_vec(json).unwrap();
    while j.len() % 4 != 0 {
        j.push(b' ');
    }
    let mut b = bin.to_vec();
    while b.len() % 4 != 0 {
        b.push(0);
    }
    let total = 12 + 8 + j.len() + if b.is_empty() { 0 } else { 8 + b.len() };
    let mut out = b"glTF".to_vec();
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((j.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(j);
    if !b.is_empty() {
        out.extend((b.len() as u32).to_le_bytes());
        out.extend(b"BIN\0");
        out.extend(b);
    }
    out
}

/// The parts of the box robot: name, parent part, position relative to the parent node,
/// box size and box centre in the node's space. Faces +Z, so its left is +X; 1.85 m tall,
/// its feet's soles at y = 0.
/// A part: name, parent part, position relative to the parent node, box size, box centre.
pub type Part = (
    &'static str,
    Option<&'static str>,
    [f32; 3],
    [f32; 3],
    [f32; 3],
);

pub const ROBOT: [Part; 14] = [
    (
        "Hips",
        None,
        [0.0, 1.0, 0.0],
        [0.30, 0.16, 0.20],
        [0.0, 0.0, 0.0],
    ),
    (
        "Spine",
        Some("Hips"),
        [0.0, 0.1, 0.0],
        [0.28, 0.18, 0.18],
        [0.0, 0.1, 0.0],
    ),
    (
        "Chest",
        Some("Spine"),
        [0.0, 0.2, 0.0],
        [0.38, 0.28, 0.22],
        [0.0, 0.14, 0.0],
    ),
    (
        "Head",
        Some("Chest"),
        [0.0, 0.32, 0.0],
        [0.20, 0.23, 0.22],
        [0.0, 0.115, 0.0],
    ),
    (
        "UpperArm.L",
        Some("Chest"),
        [0.24, 0.24, 0.0],
        [0.08, 0.28, 0.08],
        [0.0, -0.14, 0.0],
    ),
    (
        "LowerArm.L",
        Some("UpperArm.L"),
        [0.0, -0.28, 0.0],
        [0.07, 0.26, 0.07],
        [0.0, -0.13, 0.0],
    ),
    (
        "UpperArm.R",
        Some("Chest"),
        [-0.24, 0.24, 0.0],
        [0.08, 0.28, 0.08],
        [0.0, -0.14, 0.0],
    ),
    (
        "LowerArm.R",
        Some("UpperArm.R"),
        [0.0, -0.28, 0.0],
        [0.07, 0.26, 0.07],
        [0.0, -0.13, 0.0],
    ),
    (
        "UpperLeg.L",
        Some("Hips"),
        [0.1, -0.05, 0.0],
        [0.12, 0.42, 0.12],
        [0.0, -0.21, 0.0],
    ),
    (
        "LowerLeg.L",
        Some("UpperLeg.L"),
        [0.0, -0.42, 0.0],
        [0.10, 0.40, 0.10],
        [0.0, -0.2, 0.0],
    ),
    (
        "Foot.L",
        Some("LowerLeg.L"),
        [0.0, -0.4, 0.0],
        [0.10, 0.08, 0.24],
        [0.0, -0.09, 0.05],
    ),
    (
        "UpperLeg.R",
        Some("Hips"),
        [-0.1, -0.05, 0.0],
        [0.12, 0.42, 0.12],
        [0.0, -0.21, 0.0],
    ),
    (
        "LowerLeg.R",
        Some("UpperLeg.R"),
        [0.0, -0.42, 0.0],
        [0.10, 0.40, 0.10],
        [0.0, -0.2, 0.0],
    ),
    (
        "Foot.R",
        Some("LowerLeg.R"),
        [0.0, -0.4, 0.0],
        [0.10, 0.08, 0.24],
        [0.0, -0.09, 0.05],
    ),
];

/// The robot under an `Armature` node (folded away: it carries nothing and has one
/// child), with an empty `HeadTop` marker leaf (dropped); the two upper arms share one mesh,
/// as instanced parts do.
pub fn robot() -> Vec<u8> {
    let mut d = Doc::default();
    let armature = d.node("Armature", Vec3::ZERO, None);
    let mut index = HashMap::new();
    let mut arm_mesh = None;
    for (name, parent, at, size, centre) in ROBOT {
        let mesh = if name.starts_with("UpperArm") {
            *arm_mesh
                .get_or_insert_with(|| d.cuboid("upper arm", Vec3::from(size), Vec3::from(centre)))
        } else {
            d.cuboid(name, Vec3::from(size), Vec3::from(centre))
        };
        let n = d.node(name, Vec3::from(at), Some(mesh));
        d.child(parent.map_or(armature, |p| index[p]), n);
        index.insert(name, n);
    }
    let marker = d.node("HeadTop", Vec3::new(0.0, 0.25, 0.0), None);
    d.child(index["Head"], marker);
    d.glb(&[armature], json!({}))
}

/// The standing height of [`blocky`], metres.
pub const BLOCKY_HEIGHT_M: f32 = 1.75;

/// Kenney's blocky character parts: (node, parent node, joint relative to the parent, box
/// size, box centre in the node's space), facing +Z with its own left toward +X. Each
/// limb is one box hanging from its joint: no elbow, no knee.
pub const BLOCKY: [Part; 6] = [
    (
        "torso",
        None,
        [0.0, 0.8, 0.0],
        [0.48, 0.6, 0.3],
        [0.0, 0.3, 0.0],
    ),
    (
        "head",
        Some("torso"),
        [0.0, 0.6, 0.0],
        [0.4, 0.35, 0.35],
        [0.0, 0.175, 0.0],
    ),
    (
        "arm-left",
        Some("torso"),
        [0.32, 0.55, 0.0],
        [0.16, 0.6, 0.18],
        [0.0, -0.27, 0.0],
    ),
    (
        "arm-right",
        Some("torso"),
        [-0.32, 0.55, 0.0],
        [0.16, 0.6, 0.18],
        [0.0, -0.27, 0.0],
    ),
    (
        "leg-left",
        Some("torso"),
        [0.12, 0.0, 0.0],
        [0.2, 0.8, 0.24],
        [0.0, -0.4, 0.0],
    ),
    (
        "leg-right",
        Some("torso"),
        [-0.12, 0.0, 0.0],
        [0.2, 0.8, 0.24],
        [0.0, -0.4, 0.0],
    ),
];

/// A blocky game character [`BLOCKY_HEIGHT_M`] tall in Kenney's layout (a `root` node
/// over the parts), turned `facing_deg` about +Y: a quarter turn swaps each box's width
/// and depth, so the boxes stay boxes.
pub fn blocky(facing_deg: f32) -> Vec<u8> {
    blocky_turned(glam::Quat::from_rotation_y(facing_deg.to_radians()))
}

/// [`blocky`] turned by `turn`, a rotation by quarter turns (lying down: a Z-up export, or
/// one on its side), so the boxes stay boxes along the axes.
pub fn blocky_turned(turn: glam::Quat) -> Vec<u8> {
    let mut d = Doc::default();
    let root = d.node("root", Vec3::ZERO, None);
    let mut index = HashMap::new();
    for (name, parent, at, size, centre) in BLOCKY {
        let size = (turn * Vec3::from(size)).abs();
        let mesh = d.cuboid(name, size, turn * Vec3::from(centre));
        let n = d.node(name, turn * Vec3::from(at), Some(mesh));
        d.child(parent.map_or(root, |p| index[p]), n);
        index.insert(name, n);
    }
    d.glb(&[root], json!({}))
}

/// A bare humanoid hierarchy (no skin, no mesh) in centimetres-free metres: hips, spine,
/// chest, neck, head, and two arms and legs, under a `Root` node; with `meshes`, the hips
/// and head carry a box each.
pub fn bare(extension: &str, meshes: bool) -> Vec<u8> {
    let mut d = Doc::default();
    let root = d.node("Root", Vec3::ZERO, None);
    let bones: [(&str, &str, Option<&str>, [f32; 3]); 17] = [
        ("hips", "J_Bip_C_Hips", None, [0.0, 1.0, 0.0]),
        ("spine", "J_Bip_C_Spine", Some("hips"), [0.0, 0.1, 0.0]),
        ("chest", "J_Bip_C_Chest", Some("spine"), [0.0, 0.2, 0.0]),
        ("neck", "J_Bip_C_Neck", Some("chest"), [0.0, 0.25, 0.0]),
        ("head", "J_Bip_C_Head", Some("neck"), [0.0, 0.1, 0.0]),
        (
            "leftUpperArm",
            "J_Bip_L_UpperArm",
            Some("chest"),
            [0.2, 0.22, 0.0],
        ),
        (
            "leftLowerArm",
            "J_Bip_L_LowerArm",
            Some("leftUpperArm"),
            [0.28, 0.0, 0.0],
        ),
        (
            "leftHand",
            "J_Bip_L_Hand",
            Some("leftLowerArm"),
            [0.25, 0.0, 0.0],
        ),
        (
            "rightUpperArm",
            "J_Bip_R_UpperArm",
            Some("chest"),
            [-0.2, 0.22, 0.0],
        ),
        (
            "rightLowerArm",
            "J_Bip_R_LowerArm",
            Some("rightUpperArm"),
            [-0.28, 0.0, 0.0],
        ),
        (
            "rightHand",
            "J_Bip_R_Hand",
            Some("rightLowerArm"),
            [-0.25, 0.0, 0.0],
        ),
        (
            "leftUpperLeg",
            "J_Bip_L_UpperLeg",
            Some("hips"),
            [0.1, -0.05, 0.0],
        ),
        (
            "leftLowerLeg",
            "J_Bip_L_LowerLeg",
            Some("leftUpperLeg"),
            [0.0, -0.45, 0.0],
        ),
        (
            "leftFoot",
            "J_Bip_L_Foot",
            Some("leftLowerLeg"),
            [0.0, -0.42, 0.0],
        ),
        (
            "rightUpperLeg",
            "J_Bip_R_UpperLeg",
            Some("hips"),
            [-0.1, -0.05, 0.0],
        ),
        (
            "rightLowerLeg",
            "J_Bip_R_LowerLeg",
            Some("rightUpperLeg"),
            [0.0, -0.45, 0.0],
        ),
        (
            "rightFoot",
            "J_Bip_R_Foot",
            Some("rightLowerLeg"),
            [0.0, -0.42, 0.0],
        ),
    ];
    let mut index = HashMap::new();
    for (bone, name, parent, at) in bones {
        let mesh = (meshes && matches!(bone, "hips" | "head"))
            .then(|| d.cuboid(bone, Vec3::new(0.25, 0.2, 0.2), Vec3::new(0.0, 0.1, 0.0)));
        let n = d.node(name, Vec3::from(at), mesh);
        d.child(parent.map_or(root, |p| index[p]), n);
        index.insert(bone, n);
    }
    // Spring-bone and look-at leaves that carry nothing: not joints.
    let hair = d.node("HairJoint", Vec3::new(0.0, 0.2, 0.0), None);
    d.child(index["head"], hair);
    let table = if extension == "VRM" {
        let list: Vec<Value> = bones
            .iter()
            .map(|b| json!({"bone": b.0, "node": index[b.0]}))
            .collect();
        json!({"VRM": {"humanoid": {"humanBones": list}}})
    } else {
        let map: serde_json::Map<String, Value> = bones
            .iter()
            .map(|b| (b.0.to_string(), json!({"node": index[b.0]})))
            .collect();
        json!({"VRMC_vrm": {"specVersion": "1.0", "humanoid": {"humanBones": map}}})
    };
    d.glb(&[root], table)
}

/// Imports `bytes` as a file called `name` (its extension picks the reader), from a
/// folder of its own that is removed afterwards: the importer reads files, and tests run
/// in parallel.
pub fn load_as(name: &str, bytes: &[u8]) -> ragdoll::skeleton::Character {
    use std::sync::atomic::{AtomicUsize, Ordering};
    static N: AtomicUsize = AtomicUsize::new(0);
    let k = N.fetch_add(1, Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("ragdoll-parts-{}-{k}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    let c = ragdoll::import::load(&path, &Default::default()).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    c
}
