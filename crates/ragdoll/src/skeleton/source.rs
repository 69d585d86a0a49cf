//! Where a character came from, as plain data: what each exporter needs to write the
//! character back in its source's own layout (a BVH's channels and units, a glTF's whole
//! document). The importers fill these in; they live here, with the skeleton, so that the
//! skeleton depends on no importer (the importers depend on it).

use std::path::PathBuf;

use glam::Vec3;
use serde::{Deserialize, Serialize};

use crate::math::Transform;

/// Where a [`Character`](super::Character) came from, with what its exporters need to keep its layout.
#[derive(Clone, Debug)]
pub enum Source {
    /// The built-in default humanoid.
    BuiltIn,
    /// A BVH file.
    Bvh(BvhLayout),
    /// A glTF 2.0 file. Shared: its buffers may hold hundreds of megabytes, and a
    /// character is copied (turned, stood up) several times while its roles are found.
    Gltf(std::sync::Arc<GltfSource>),
    /// A mesh that came without a skeleton (an OBJ, a glTF without a skin), rigged by
    /// [`crate::rig`]: its exporters write a fresh glTF of the mesh and its automatic skin.
    /// Holds the file read.
    Mesh(PathBuf),
}

/// Up axis of a file whose format does not say (BVH).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum UpAxis {
    /// +Y is up (glTF, most BVH).
    Y,
    /// +Z is up (some mocap exports).
    Z,
}

/// A coordinate axis, as named by a BVH channel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Axis {
    /// The X axis.
    X,
    /// The Y axis.
    Y,
    /// The Z axis.
    Z,
}

impl Axis {
    /// 0, 1 or 2: the component this axis selects.
    pub fn index(self) -> usize {
        match self {
            Axis::X => 0,
            Axis::Y => 1,
            Axis::Z => 2,
        }
    }
}

/// One BVH channel: which quantity one column of the motion data drives.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Channel {
    /// `Xposition`, `Yposition` or `Zposition`: a component of the joint's translation, in
    /// file units.
    Position(Axis),
    /// `Xrotation`, `Yrotation` or `Zrotation`: a rotation about that local axis, degrees.
    Rotation(Axis),
}

impl Channel {
    /// The keyword as BVH files spell it, e.g. `Zrotation`.
    pub fn name(self) -> &'static str {
        match self {
            Channel::Position(Axis::X) => "Xposition",
            Channel::Position(Axis::Y) => "Yposition",
            Channel::Position(Axis::Z) => "Zposition",
            Channel::Rotation(Axis::X) => "Xrotation",
            Channel::Rotation(Axis::Y) => "Yrotation",
            Channel::Rotation(Axis::Z) => "Zrotation",
        }
    }

    /// Reads a channel keyword; case-insensitive because exporters disagree on case.
    pub fn parse(s: &str) -> Option<Channel> {
        let lower = s.to_ascii_lowercase();
        Some(match lower.as_str() {
            "xposition" => Channel::Position(Axis::X),
            "yposition" => Channel::Position(Axis::Y),
            "zposition" => Channel::Position(Axis::Z),
            "xrotation" => Channel::Rotation(Axis::X),
            "yrotation" => Channel::Rotation(Axis::Y),
            "zrotation" => Channel::Rotation(Axis::Z),
            _ => return None,
        })
    }
}

/// The file layout of one joint, kept so the exporter can write it back unchanged.
#[derive(Clone, Debug, PartialEq)]
pub struct BvhJoint {
    /// The name exactly as in the file (the exporter sanitises it only if it must).
    pub name: String,
    /// The joint's channels, in file order.
    pub channels: Vec<Channel>,
    /// The `End Site` offset in file units and file axes, when the file has one.
    pub end_site: Option<Vec3>,
}

/// What the BVH exporter needs to write a file back in the source's own layout.
///
/// `joints[i]` describes skeleton joint `i`; for an imported file the skeleton's joint order
/// is the file's order, so writing the hierarchy depth-first reproduces it.
#[derive(Clone, Debug, PartialEq)]
pub struct BvhLayout {
    /// One entry per skeleton joint, in skeleton order.
    pub joints: Vec<BvhJoint>,
    /// Metres per file unit (detected or given on import).
    pub metres_per_unit: f32,
    /// The file's up axis (detected or given on import).
    pub up: UpAxis,
    /// Seconds per frame of the file's motion, a natural default output rate.
    pub frame_time: f32,
}

/// What the glTF exporter needs to write the input back, untouched but for a new animation
/// and renormalised skin weights.
#[derive(Clone, Debug)]
pub struct GltfSource {
    /// The file read, for error messages.
    pub path: PathBuf,
    /// Its folder, where external images and buffers are found.
    pub dir: PathBuf,
    /// The whole glTF JSON document as read, extensions and extras included, with the
    /// importer's repairs of what would make the written file invalid (each warned about).
    pub json: serde_json::Value,
    /// Every buffer's bytes, resolved (GLB chunk, `data:` URI or file) and cut to the
    /// declared `byteLength`; rotation keys that were not unit quaternions are normalised.
    pub buffers: Vec<Vec<u8>>,
    /// Index of the skin the skeleton was built from; 0, and unused, for a file without a
    /// skin whose skeleton is its node hierarchy (rigid parts, a bare VRM hierarchy).
    pub skin: usize,
    /// Node index of each skeleton joint, in skeleton order.
    pub joint_nodes: Vec<usize>,
    /// For each skeleton joint, the static transform between its parent joint's node (for a
    /// root joint: the world) and its own node's parent, i.e. the product of the non-joint
    /// nodes in between; identity when the node's parent is the parent joint itself.
    /// The node's animated local transform is then
    /// `(parent joint world · parent_offsets[j])⁻¹ · joint world`.
    pub parent_offsets: Vec<Transform>,
}
