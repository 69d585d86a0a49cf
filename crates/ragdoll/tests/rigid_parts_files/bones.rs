//! Skinned creatures built from a table of bones, each drawn as a box along its bone and
//! bound to it with weight 1: the layouts creature rigs come in, with a hub bone that
//! carries skin, deform feet the hierarchy detaches from their legs (IK rigs parent them
//! to the root) and pole targets without skin.

use glam::{Mat4, Quat, Vec3};
use serde_json::Value;

use super::{Doc, UNIT_BOX};

/// One bone: its joint (`head`) and where it ends (`tail`), world space, metres, facing
/// +Z; `radius` is the half-thickness of its box of skin, 0 for a bone without skin.
#[derive(Clone, Debug)]
pub struct Bone {
    pub name: String,
    pub parent: Option<usize>,
    pub head: Vec3,
    pub tail: Vec3,
    pub radius: f32,
}

/// A skeleton under construction.
#[derive(Default)]
pub struct Bones(pub Vec<Bone>);

impl Bones {
    /// Adds a bone; returns its index.
    pub fn add(
        &mut self,
        name: &str,
        parent: Option<usize>,
        head: Vec3,
        tail: Vec3,
        radius: f32,
    ) -> usize {
        self.0.push(Bone {
            name: name.to_string(),
            parent,
            head,
            tail,
            radius,
        });
        self.0.len() - 1
    }
}

/// The box of skin around a bone: `radius` across, head to tail along, as the eight
/// corners [`Doc::skinned_boxes`] takes.
fn bone_box(b: &Bone) -> Vec<Vec3> {
    let along = b.tail - b.head;
    let y = along.normalize();
    let x = y.any_orthonormal_vector();
    let z = x.cross(y);
    let frame = Mat4::from_cols(
        (x * 2.0 * b.radius).extend(0.0),
        along.extend(0.0),
        (z * 2.0 * b.radius).extend(0.0),
        ((b.head + b.tail) * 0.5).extend(1.0),
    );
    UNIT_BOX
        .iter()
        .map(|&c| frame.transform_point3(c))
        .collect()
}

/// The creature as a GLB, turned `facing_deg` about +Y: one node per bone (translation
/// only), one skin of every bone, one mesh of every bone's box.
pub fn bones_glb(bones: &Bones, facing_deg: f32) -> Vec<u8> {
    let turn = Quat::from_rotation_y(facing_deg.to_radians());
    let turned: Vec<Bone> = bones
        .0
        .iter()
        .map(|b| Bone {
            head: turn * b.head,
            tail: turn * b.tail,
            ..b.clone()
        })
        .collect();
    let mut d = Doc::default();
    let mut nodes = Vec::new();
    let mut roots = Vec::new();
    for b in &turned {
        let at = b.head - b.parent.map_or(Vec3::ZERO, |p| turned[p].head);
        let n = d.node(&b.name, at, None);
        match b.parent {
            Some(p) => d.child(nodes[p], n),
            None => roots.push(n),
        }
        nodes.push(n);
    }
    let worlds: Vec<Mat4> = turned
        .iter()
        .map(|b| Mat4::from_translation(b.head))
        .collect();
    let skin = d.skin(&nodes, &worlds);
    let boxes: Vec<(u16, Vec<Vec3>)> = turned
        .iter()
        .enumerate()
        .filter(|(_, b)| b.radius > 0.0)
        .map(|(k, b)| (k as u16, bone_box(b)))
        .collect();
    let mesh = d.skinned_boxes("skin", &boxes);
    roots.push(d.skinned_node("Body_mesh", mesh, skin));
    d.glb(&roots, Value::Object(Default::default()))
}

/// A spider about 1.1 m across its legs, facing +Z: a root bone on the ground, a hub bone
/// `Body` with skin (thorax and abdomen in one) from whose joint all eight legs start, as
/// rigs often have them, so its bone has no length of its own; each leg a femur rising to
/// the knee and a shin down to the ankle; each leg's foot (a deform bone with skin) and a
/// pole target above its knee are parented to the root, as an IK rig has them.
pub fn spider() -> Bones {
    let mut b = Bones::default();
    let root = b.add("Root", None, Vec3::ZERO, Vec3::new(0.0, 0.0, 0.2), 0.0);
    let hub = Vec3::new(0.0, 0.3, 0.05);
    let body = b.add("Body", Some(root), hub, Vec3::new(0.0, 0.32, -0.3), 0.1);
    for (k, fan) in [0.6f32, 0.2, -0.2, -0.6].iter().enumerate() {
        for (side, s) in [(1.0f32, "L"), (-1.0, "R")] {
            let dir = Vec3::new(side * fan.cos(), 0.0, fan.sin() + 0.1 - 0.07 * k as f32);
            let hip = hub;
            let knee = hip + dir * 0.22 + Vec3::Y * 0.12;
            let ankle = hip + dir * 0.48 + Vec3::new(0.0, 0.06 - hip.y, 0.0);
            let toe = ankle + dir * 0.07 + Vec3::new(0.0, -0.04, 0.0);
            let femur = b.add(&format!("Femur{k}.{s}"), Some(body), hip, knee, 0.025);
            b.add(&format!("Shin{k}.{s}"), Some(femur), knee, ankle, 0.02);
            b.add(&format!("Foot{k}.{s}"), Some(root), ankle, toe, 0.018);
            let pole = knee + Vec3::Y * 0.3;
            b.add(
                &format!("Pole{k}.{s}"),
                Some(root),
                pole,
                pole + Vec3::Y * 0.05,
                0.0,
            );
        }
    }
    b
}

/// A horse 1.6 m tall at the head, facing +Z: a root bone on the ground; hips, a spine of
/// two bones, neck and head; four legs of a thigh (upper arm in front), a shin (forearm)
/// and a cannon bone down to the fetlock, each bent as a horse stands (hind hocks back,
/// front knees straight); each hoof (`FF.L`, `FFB.L`, … a deform bone with skin) and a
/// pole target behind each leg are parented to the root, as an IK rig has them.
pub fn horse() -> Bones {
    let mut b = Bones::default();
    let root = b.add("Root", None, Vec3::ZERO, Vec3::new(0.0, 0.0, 0.3), 0.0);
    let hips = b.add(
        "Hips",
        Some(root),
        Vec3::new(0.0, 1.2, -0.55),
        Vec3::new(0.0, 1.22, -0.2),
        0.2,
    );
    let spine = b.add(
        "Spine",
        Some(hips),
        Vec3::new(0.0, 1.22, -0.2),
        Vec3::new(0.0, 1.24, 0.25),
        0.22,
    );
    let chest = b.add(
        "Chest",
        Some(spine),
        Vec3::new(0.0, 1.24, 0.25),
        Vec3::new(0.0, 1.3, 0.55),
        0.22,
    );
    let neck = b.add(
        "Neck",
        Some(chest),
        Vec3::new(0.0, 1.3, 0.55),
        Vec3::new(0.0, 1.6, 0.8),
        0.1,
    );
    b.add(
        "Head",
        Some(neck),
        Vec3::new(0.0, 1.6, 0.8),
        Vec3::new(0.0, 1.45, 1.1),
        0.09,
    );
    // (prefix, parent, hip, knee, hock or front knee, fetlock): hind legs bend back at the
    // hock, front legs hang straight.
    let legs = [
        (
            "B",
            hips,
            Vec3::new(0.16, 1.1, -0.55),
            Vec3::new(0.16, 0.75, -0.4),
            Vec3::new(0.16, 0.5, -0.65),
            Vec3::new(0.16, 0.12, -0.6),
        ),
        (
            "F",
            chest,
            Vec3::new(0.17, 1.15, 0.45),
            Vec3::new(0.17, 0.8, 0.38),
            Vec3::new(0.17, 0.45, 0.4),
            Vec3::new(0.17, 0.12, 0.42),
        ),
    ];
    for (end, parent, hip, knee, hock, fetlock) in legs {
        for (side, s) in [(1.0f32, "L"), (-1.0, "R")] {
            let m = Vec3::new(side, 1.0, 1.0);
            let upper = b.add(
                &format!("Thigh{end}.{s}"),
                Some(parent),
                hip * m,
                knee * m,
                0.08,
            );
            let lower = b.add(
                &format!("Shin{end}.{s}"),
                Some(upper),
                knee * m,
                hock * m,
                0.05,
            );
            b.add(
                &format!("Cannon{end}.{s}"),
                Some(lower),
                hock * m,
                fetlock * m,
                0.035,
            );
            let hoof = if end == "F" { "FF" } else { "FFB" };
            let toe = fetlock * m + Vec3::new(0.0, -0.1, 0.08);
            b.add(&format!("{hoof}.{s}"), Some(root), fetlock * m, toe, 0.05);
            let pole = knee * m + Vec3::new(0.0, 0.0, 0.5);
            b.add(
                &format!("Pole{end}.{s}"),
                Some(root),
                pole,
                pole + Vec3::Z * 0.05,
                0.0,
            );
        }
    }
    b
}

/// A chibi humanoid 1 m tall, facing +Z, whose head is as large as the rest of its body:
/// legs 0.3 m, a trunk of 0.25 m, a head 0.45 m across from the neck to the top, short
/// arms; Mixamo-like names.
pub fn chibi() -> Bones {
    let mut b = Bones::default();
    let hips = b.add(
        "Hips",
        None,
        Vec3::new(0.0, 0.32, 0.0),
        Vec3::new(0.0, 0.4, 0.0),
        0.1,
    );
    let spine = b.add(
        "Spine",
        Some(hips),
        Vec3::new(0.0, 0.4, 0.0),
        Vec3::new(0.0, 0.48, 0.0),
        0.1,
    );
    let neck = b.add(
        "Neck",
        Some(spine),
        Vec3::new(0.0, 0.52, 0.0),
        Vec3::new(0.0, 0.55, 0.0),
        0.04,
    );
    b.add(
        "Head",
        Some(neck),
        Vec3::new(0.0, 0.55, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
        0.22,
    );
    for (side, s) in [(1.0f32, "Left"), (-1.0, "Right")] {
        let m = Vec3::new(side, 1.0, 1.0);
        let up = b.add(
            &format!("{s}UpLeg"),
            Some(hips),
            Vec3::new(0.07, 0.3, 0.0) * m,
            Vec3::new(0.07, 0.17, 0.01) * m,
            0.045,
        );
        let leg = b.add(
            &format!("{s}Leg"),
            Some(up),
            Vec3::new(0.07, 0.17, 0.01) * m,
            Vec3::new(0.07, 0.04, 0.0) * m,
            0.04,
        );
        b.add(
            &format!("{s}Foot"),
            Some(leg),
            Vec3::new(0.07, 0.04, 0.0) * m,
            Vec3::new(0.07, 0.01, 0.1) * m,
            0.035,
        );
        let arm = b.add(
            &format!("{s}Arm"),
            Some(spine),
            Vec3::new(0.1, 0.5, 0.0) * m,
            Vec3::new(0.2, 0.42, 0.0) * m,
            0.035,
        );
        let fore = b.add(
            &format!("{s}ForeArm"),
            Some(arm),
            Vec3::new(0.2, 0.42, 0.0) * m,
            Vec3::new(0.28, 0.35, 0.0) * m,
            0.03,
        );
        b.add(
            &format!("{s}Hand"),
            Some(fore),
            Vec3::new(0.28, 0.35, 0.0) * m,
            Vec3::new(0.32, 0.3, 0.0) * m,
            0.035,
        );
    }
    b
}
