//! The offline half: a [`RagdollSpec`] describes a ragdoll as plain, editable data (bodies,
//! shapes, masses, joints, limits, collision filtering), built automatically from a
//! [`Skeleton`](crate::skeleton::Skeleton) and serialisable to TOML so users can tweak it.
//! Runtime worlds are only ever made from a spec.
//!
//! - `roles/` recognises pelvis, spine, limbs… in named passes: name hints (or a VRM bone
//!   table) confirmed by geometry, the shape-only structure search as the fallback, and
//!   the side from names and facing together;
//! - `anthropometry.rs` holds body-segment masses and joint ranges (de Leva 1996);
//! - `build/` turns a skeleton plus its roles into a spec;
//! - `validate.rs` holds the bounds every value of a spec is checked against, `file.rs`
//!   reads a spec file with the line of every mistake.

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// Version of the spec file layout; bumped when a field changes meaning.
pub const SPEC_FORMAT_VERSION: u32 = 1;

/// What a joint is, anatomically. Serialised as `pelvis`, `thigh_l`, `shin_r`, `chain`…
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Role {
    /// Root of the trunk, where the legs branch.
    Pelvis,
    /// Lower trunk between pelvis and chest.
    Spine,
    /// Upper trunk, where the arms branch.
    Chest,
    /// Neck.
    Neck,
    /// Head.
    Head,
    /// Left upper arm (shoulder joint).
    UpperArmL,
    /// Right upper arm.
    UpperArmR,
    /// Left forearm (elbow joint).
    ForearmL,
    /// Right forearm.
    ForearmR,
    /// Left hand (wrist joint).
    HandL,
    /// Right hand.
    HandR,
    /// Left thigh (hip joint).
    ThighL,
    /// Right thigh.
    ThighR,
    /// Left shin (knee joint).
    ShinL,
    /// Right shin.
    ShinR,
    /// Left foot (ankle joint).
    FootL,
    /// Right foot.
    FootR,
    /// A generic link of a chain (non-humanoids, tails, extra spine links).
    Chain,
}

impl Role {
    /// The snake_case name used in files and reports.
    pub fn as_str(self) -> &'static str {
        match self {
            Role::Pelvis => "pelvis",
            Role::Spine => "spine",
            Role::Chest => "chest",
            Role::Neck => "neck",
            Role::Head => "head",
            Role::UpperArmL => "upper_arm_l",
            Role::UpperArmR => "upper_arm_r",
            Role::ForearmL => "forearm_l",
            Role::ForearmR => "forearm_r",
            Role::HandL => "hand_l",
            Role::HandR => "hand_r",
            Role::ThighL => "thigh_l",
            Role::ThighR => "thigh_r",
            Role::ShinL => "shin_l",
            Role::ShinR => "shin_r",
            Role::FootL => "foot_l",
            Role::FootR => "foot_r",
            Role::Chain => "chain",
        }
    }
}

/// Collision shape of a body, in the body's own frame: centred on its origin, long axis
/// along local Y.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Shape {
    /// A capsule: a segment of `length_m` (between the two sphere centres) swept by `radius_m`.
    Capsule {
        /// Sphere radius, metres.
        radius_m: f32,
        /// Distance between the two sphere centres, metres.
        length_m: f32,
    },
    /// A box with full edge lengths `size_m` along local X, Y, Z.
    Box {
        /// Edge lengths, metres.
        size_m: [f32; 3],
    },
}

impl Shape {
    /// Lowest world height of the shape at `pose` (its centre and orientation): where it
    /// meets a floor.
    pub fn lowest_y(&self, pose: &crate::math::Transform) -> f32 {
        match *self {
            Shape::Capsule { radius_m, length_m } => {
                let axis = pose.rotation * glam::Vec3::Y * (0.5 * length_m);
                (pose.translation.y - axis.y.abs()) - radius_m
            }
            Shape::Box { size_m } => {
                let h = glam::Vec3::from_array(size_m) * 0.5;
                let mut low = f32::INFINITY;
                for k in 0..8 {
                    let sign = |bit: usize| if k & bit == 0 { -1.0 } else { 1.0 };
                    let corner = h * glam::Vec3::new(sign(1), sign(2), sign(4));
                    low = low.min(pose.transform_point(corner).y);
                }
                low
            }
        }
    }

    /// Volume in m³.
    pub fn volume(&self) -> f32 {
        match *self {
            Shape::Capsule {
                radius_m: r,
                length_m: l,
            } => std::f32::consts::PI * r * r * (l + 4.0 / 3.0 * r),
            Shape::Box { size_m: s } => s[0] * s[1] * s[2],
        }
    }
}

/// One rigid body of the ragdoll, attached to a skeleton bone.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodySpec {
    /// Unique name; the bone's role name for humanoids (`thigh_l`), else the bone's name.
    pub name: String,
    /// The skeleton joint whose bone this body is; matched by name (or `joint<i>`).
    pub bone: String,
    /// The recognised role, if any (informational; editing it changes nothing).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub role: Option<Role>,
    /// The collision shape.
    pub shape: Shape,
    /// Centre of the shape in the bone's rest frame (the joint's rest world rotation and
    /// position, without scale), metres.
    pub center_m: [f32; 3],
    /// Orientation of the shape frame in the bone's rest frame, quaternion `[x, y, z, w]`;
    /// the shape's long axis is this frame's Y.
    pub rotation: [f32; 4],
    /// Mass, kilograms. Inertia follows from the shape with uniform density.
    pub mass_kg: f32,
    /// More shapes the body collides with, each placed in the bone's rest frame as
    /// [`BodySpec::shape`] is: skin this body moves that its own shape does not reach (a
    /// creature's foot whose weight three spine bones share, a sword in a hand). They meet
    /// the ground, other ragdolls and shots, not their own ragdoll's bodies; the body's
    /// mass is spread over all its shapes by volume for its inertia, its centre of mass
    /// staying its own shape's centre. At most [`MAX_EXTRA_SHAPES`].
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub extra_shapes: Vec<ExtraShape>,
}

impl BodySpec {
    /// The body frame in its bone's rest frame: where the body's shape is.
    pub fn frame(&self) -> crate::math::Transform {
        crate::math::Transform::new(
            glam::Vec3::from_array(self.center_m),
            glam::Quat::from_array(self.rotation).normalize(),
        )
    }

    /// Each extra shape with its place in the body frame (the frame of [`BodySpec::shape`]),
    /// as the backends take them.
    pub fn extra_offsets(&self) -> Vec<(Shape, crate::math::Transform)> {
        let inv = self.frame().inverse();
        self.extra_shapes
            .iter()
            .map(|e| {
                let at = crate::math::Transform::new(
                    glam::Vec3::from_array(e.center_m),
                    glam::Quat::from_array(e.rotation).normalize(),
                );
                (e.shape, inv.mul(&at))
            })
            .collect()
    }
}

/// A shape a body carries beside its own (see [`BodySpec::extra_shapes`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExtraShape {
    /// The collision shape, long axis along its frame's Y.
    pub shape: Shape,
    /// Its centre in the bone's rest frame, metres.
    pub center_m: [f32; 3],
    /// Its orientation in the bone's rest frame, quaternion `[x, y, z, w]`.
    pub rotation: [f32; 4],
}

/// How a joint may move.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum JointKind {
    /// One axis (the joint frame's X): knees and elbows. The angle is 0 in the rest pose and
    /// positive in flexion.
    Hinge {
        /// Lowest angle, degrees.
        min_deg: f32,
        /// Highest angle, degrees.
        max_deg: f32,
    },
    /// A cone for the twist axis (the frame's X, along the child bone) plus a twist range:
    /// hips, shoulders, spine, neck, wrists, ankles.
    SwingTwist {
        /// Half-angle of the swing cone, degrees.
        swing_deg: f32,
        /// Twist range about the bone, degrees, `[min, max]`.
        twist_deg: [f32; 2],
        /// Where the cone points, as rotations of the rest direction about the frame's
        /// Y then Z axes, degrees. `[0, 0]` centres the cone on the rest pose; the hip's
        /// cone is tilted forward so flexion reaches further than extension.
        cone_tilt_deg: [f32; 2],
    },
    /// A ball joint with no limits.
    Ball,
    /// No relative motion.
    Fixed,
}

/// A joint between two bodies.
// No `deny_unknown_fields` here: serde does not support it together with `flatten` (every
// key of the flattened `kind` would be reported as unknown and no joint could be read back).
// `RagdollSpec::from_toml` checks the keys of each joint table itself instead.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct JointSpec {
    /// Unique name (the child body's name).
    pub name: String,
    /// Name of the parent body.
    pub parent: String,
    /// Name of the child body.
    pub child: String,
    /// Anchor position in the child bone's rest frame, metres (normally `[0, 0, 0]`: the
    /// child's joint).
    pub anchor_m: [f32; 3],
    /// Orientation of the joint frame in the child bone's rest frame, `[x, y, z, w]`.
    /// Its X is the hinge or twist axis; for limbs, rotating about Z by a positive angle
    /// bends the limb (flexion). The parent side of the frame is the same frame in the
    /// rest pose, so every angle is zero at rest.
    pub frame: [f32; 4],
    /// Kind and limits.
    #[serde(flatten)]
    pub kind: JointKind,
}

/// Collision filtering between bodies of one ragdoll.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CollisionSpec {
    /// Pairs of body names that never collide with each other: every jointed pair, and pairs
    /// that overlap in the rest pose or in the pose the ragdoll starts in.
    #[serde(default)]
    pub disabled_pairs: Vec<[String; 2]>,
}

impl CollisionSpec {
    /// Whether bodies `a` and `b` never collide (in either order).
    pub fn is_disabled(&self, a: &str, b: &str) -> bool {
        self.disabled_pairs
            .iter()
            .any(|p| (p[0] == a && p[1] == b) || (p[0] == b && p[1] == a))
    }
}

/// A ragdoll described as plain data: what [`build_spec`] makes from a skeleton, what
/// `ragdoll build` writes to TOML, and what a world is created from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RagdollSpec {
    /// Layout version, [`SPEC_FORMAT_VERSION`].
    pub format_version: u32,
    /// Name of the character.
    pub name: String,
    /// Bodies; the first is the root (the pelvis for humanoids).
    pub bodies: Vec<BodySpec>,
    /// Joints, each linking a parent body to a child body.
    #[serde(default)]
    pub joints: Vec<JointSpec>,
    /// Collision filtering.
    #[serde(default)]
    pub collision: CollisionSpec,
}

impl RagdollSpec {
    /// Sum of the bodies' masses, kg.
    pub fn total_mass_kg(&self) -> f32 {
        self.bodies.iter().map(|b| b.mass_kg).sum()
    }

    /// Index of the body named `name`.
    pub fn body_index(&self, name: &str) -> Option<usize> {
        self.bodies.iter().position(|b| b.name == name)
    }

    /// Writes the spec as TOML.
    pub fn to_toml(&self) -> String {
        toml::to_string_pretty(self).expect("a spec always serialises")
    }

    /// Checks every value a world would trip on against the bounds in this module
    /// ([`MAX_SHAPE_M`], [`MAX_BODY_KG`], ...); the error names the first body, joint or
    /// key out of bounds and the bound. [`RagdollSpec::from_toml`] runs the same checks
    /// and adds the line.
    pub fn validate(&self) -> Result<()> {
        match self.problem() {
            None => Ok(()),
            Some(p) => Err(Error::Spec {
                place: p.place.describe(self),
                message: p.message,
            }),
        }
    }
}

mod anthropometry;
mod build;
mod file;
mod frames;
mod mesh;
mod roles;
mod skin_points;
mod validate;

pub use frames::{
    JointAngles, Resolved, ResolvedJoint, find_label, fit_limits_to_pose, start_pose,
};

pub use anthropometry::{
    DEFAULT_HUMANOID_MASS_KG, HUMANOID_MASS_HEIGHTS_M, REFERENCE_HUMANOID_HEIGHT_M,
    humanoid_mass_kg,
};
pub(crate) use build::shapes_overlap;
pub use build::{BuildOptions, build_spec, build_spec_with_roles};
pub use mesh::bodies_mesh;
pub use roles::{
    HUMANOID_HEIGHT_M, HUMANOID_ROLES, MAX_ROLE_FILE_ENTRIES, RoleFile, Roles, recognise_roles,
    roles_for, roles_with_file,
};
pub(crate) use skin_points::skin_points;
pub use validate::{
    MAX_BODIES, MAX_BODY_KG, MAX_CONE_TILT_DEG, MAX_DISABLED_PAIRS, MAX_EXTRA_SHAPES,
    MAX_JOINT_MASS_RATIO, MAX_JOINTS, MAX_LIMIT_END_DEG, MAX_NAME_BYTES, MAX_OFFSET_M, MAX_SHAPE_M,
    MAX_SWING_DEG, MIN_BODY_KG, MIN_SHAPE_M, UNIT_QUATERNION_TOLERANCE,
};

pub(crate) use file::line_at;
pub(crate) use validate::{check_above, check_length, check_within, show};
