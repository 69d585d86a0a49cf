//! Rigging (offline): a skeleton for a bare triangle mesh (an OBJ, a glTF without a skin),
//! and automatic skin weights for any skeleton and mesh.
//!
//! How [`rig`] builds the skeleton:
//! 1. **Centre line.** By default, principal-component analysis of the mesh's surface
//!    (area-weighted triangle centroids) gives the body's long axis; the surface is cut
//!    into slabs across that axis and a first line runs through the slab centroids. That
//!    line is then refined as a principal curve (each node pulled to the mean of the
//!    surface nearest to it, smoothed), so it bends with the body instead of cutting
//!    across a curled one. With [`RigOptions::centre_line`] the line runs through the
//!    user's landmarks instead.
//! 2. **Which end is the head.** The end nearest [`RigOptions::head`] when given; else, for
//!    landmarks, the last landmark; else the higher end (the one whose last fifth of the
//!    body has the higher centroid): a creature holds its head up and lets its tail trail,
//!    and an upright figure has its head on top. Override it with `head` when that guess
//!    is wrong (a fish, a snake lying flat).
//! 3. **Spine.** [`RigOptions::joints`] joints evenly spaced by arc length from the tail
//!    end, named `spine00`, `spine01`, …, the last one `head`, whose tip is the head end
//!    of the line. The root is the tail end.
//! 4. **Branches** ([`Branch`]: legs, fins, whiskers) hang from the spine joint nearest
//!    their first landmark. Each starts with a joint on that spine joint, so the branch
//!    leaves the spine sideways instead of bending the spine's own bone, and runs through
//!    its landmarks. A mirrored branch gets a twin reflected across the body's symmetry
//!    plane: the plane through the centroid that holds the head-to-tail direction and the
//!    vertical (Y); for an upright body, the plane across the second principal axis (a
//!    standing figure's width). A branch whose first landmark lies on that plane is
//!    refused, since its twin would coincide with it.
//! 5. **Rest rotations**: each joint's Y axis runs along its bone (to the next joint, or
//!    to its tip), X toward the body's left, as in glTF and Blender rigs.
//!
//! With [`RigOptions::humanoid`] the skeleton is a person's instead, fitted to a figure
//! standing in a T- or A-pose (`humanoid.rs`).
//!
//! Skin weights come from [`heat_weights`] (bone heat: they follow the body's volume),
//! which falls back to [`auto_weights`] (straight-line distance) where heat cannot be
//! solved.

mod centre_line;
mod cg;
mod heat;
mod humanoid;
mod skeleton;
mod visibility;
mod weights;

use glam::{Quat, Vec3};

pub use heat::{
    MAX_HEAT_TRIANGLES, MAX_HEAT_VERTICES, MAX_HEAT_WORK, NoHeat, heat_weights, try_heat_weights,
};
pub use skeleton::build_skeleton;
pub use weights::auto_weights;
use weights::distance_squared_to_segment;

use crate::error::{Error, Result};
use crate::math::Transform;
use crate::skeleton::{Joint, Skeleton, SkinnedMesh};
use centre_line::{
    Frame, end_heights, length, principal_curve, principal_polyline, resample, surface_samples,
};

/// Spine joints when the user does not say: enough for a dragon's neck and tail to bend
/// smoothly, few enough for a cheap ragdoll.
pub const DEFAULT_JOINTS: usize = 12;
/// Most spine joints (or joints of one branch) a rig may ask for: more adds nothing a
/// ragdoll can use and each joint costs a rigid body.
pub const MAX_JOINTS: usize = 256;
/// Most landmarks on one line (the centre line, or one branch): a point every few
/// centimetres along a dragon. Each is resolved and walked for every joint placed.
pub const MAX_LANDMARKS: usize = 256;
/// Most branches (limbs, fins, whiskers) a rig may ask for, before mirroring.
pub const MAX_BRANCHES: usize = 64;
/// Most joints of a whole rig, spine and branches (mirrored twins counted): every joint
/// becomes a rigid body, and a ragdoll holds at most [`crate::spec::MAX_BODIES`].
pub const MAX_RIG_JOINTS: usize = crate::spec::MAX_BODIES;
/// Longest branch name, bytes: it is the stem of its joints' names.
pub const MAX_BRANCH_NAME_BYTES: usize = 32;
/// Slabs along the principal axis per spine joint: two keep each joint's neighbourhood
/// sampled on both sides without letting one leg dominate a slab.
const SLABS_PER_JOINT: usize = 2;
/// Fewest and most slabs, whatever the joint count.
const SLAB_RANGE: [usize; 2] = [8, 64];
/// A mirrored branch's first landmark must be at least this far from the symmetry plane,
/// as a fraction of the body's length, or its twin would sit on top of it.
const MIN_OFF_PLANE_OF_LENGTH: f32 = 0.01;
/// Body axes closer to vertical than this (|cos|) count as upright when choosing the
/// symmetry plane.
const UPRIGHT_COS: f32 = 0.9;

/// A point the user picks on or in the mesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Landmark {
    /// A point in world space, metres (after the importer's unit and up-axis conversion).
    Point(Vec3),
    /// A mesh vertex, by its 0-based index over all the meshes' vertices in order (an OBJ's
    /// `v` lines: OBJ's vertex number minus one).
    Vertex(usize),
}

/// A limb, fin or whisker: a chain of joints through landmarks, hanging from the spine.
#[derive(Clone, Debug, PartialEq)]
pub struct Branch {
    /// Name stem of its joints: `{name}_l00`, `{name}_r00`, … when mirrored (left and right
    /// of the body facing its head, Y up), `{name}00`, … otherwise.
    pub name: String,
    /// From the body outward; at least two. The last one is where the branch ends.
    pub points: Vec<Landmark>,
    /// Joints of the branch after its first (the one on the spine): 0 puts one on every
    /// landmark but the last; otherwise this many, evenly spaced along the landmarks.
    pub joints: usize,
    /// Whether to add the twin reflected across the body's symmetry plane.
    pub mirror: bool,
}

/// How [`rig`] builds a skeleton.
#[derive(Clone, Debug, PartialEq)]
pub struct RigOptions {
    /// Spine joints, evenly spaced along the centre line; default [`DEFAULT_JOINTS`].
    pub joints: usize,
    /// Landmarks the centre line runs through, tail to head; empty (the default): found by
    /// principal-component analysis.
    pub centre_line: Vec<Landmark>,
    /// A point near the head: the end of the centre line nearest it is the head.
    pub head: Option<Landmark>,
    /// Limbs, fins, whiskers.
    pub branches: Vec<Branch>,
    /// Fit a person's skeleton instead (pelvis, spine, chest, neck, head, legs and arms,
    /// named by role) to a figure standing in a T- or A-pose, feet on the floor, Y up:
    /// the spine, head and branch settings do not apply.
    pub humanoid: bool,
}

impl Default for RigOptions {
    fn default() -> Self {
        RigOptions {
            joints: DEFAULT_JOINTS,
            centre_line: Vec::new(),
            head: None,
            branches: Vec::new(),
            humanoid: false,
        }
    }
}

/// Builds a skeleton for `meshes` (world space, metres, Y up) and skins them to it: their
/// `joints` and `weights` are overwritten with [`heat_weights`], solved over all the
/// meshes together (a character split into meshes along a seam stays joined there).
///
/// Fails with [`Error::Setting`] on options that cannot be met (a joint count out of
/// range, a landmark vertex that does not exist, a mirrored branch on the symmetry plane)
/// and with [`Error::Skeleton`] when the meshes have no extent to rig.
///
/// # Example
///
/// ```
/// use glam::Vec3;
/// use ragdoll::{rig::{rig, RigOptions}, skeleton::SkinnedMesh};
///
/// // A long thin box along X: the spine runs along it.
/// let positions: Vec<Vec3> = (0..8)
///     .map(|i| Vec3::new(if i & 1 == 0 { -1.0 } else { 1.0 }, (i >> 1 & 1) as f32 * 0.2, (i >> 2) as f32 * 0.2))
///     .collect();
/// let indices = vec![0, 1, 3, 0, 3, 2, 4, 7, 5, 4, 6, 7, 0, 4, 5, 0, 5, 1, 2, 3, 7, 2, 7, 6, 0, 2, 6, 0, 6, 4, 1, 5, 7, 1, 7, 3];
/// let mut meshes = vec![SkinnedMesh { positions, indices, ..Default::default() }];
/// let skeleton = rig(&mut meshes, &RigOptions { joints: 4, ..Default::default() }).unwrap();
/// assert_eq!(skeleton.len(), 4);
/// assert_eq!(meshes[0].weights.len(), 8);
/// ```
pub fn rig(meshes: &mut [SkinnedMesh], opts: &RigOptions) -> Result<Skeleton> {
    rig_reporting(meshes, opts).map(|(skeleton, _)| skeleton)
}

/// [`rig`], also saying why the skin weights fell back to straight-line distance, when
/// they did ([`NoHeat`]): a tool should tell its user the mesh was too large for bone heat
/// rather than hand back weights that blend across the air without a word.
pub fn rig_reporting(
    meshes: &mut [SkinnedMesh],
    opts: &RigOptions,
) -> Result<(Skeleton, Option<NoHeat>)> {
    let skeleton = build_skeleton(meshes, opts)?;
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    for m in meshes.iter() {
        let base = positions.len() as u32;
        // An index past its own mesh must not name the next mesh's vertex.
        let own = m.positions.len() as u32;
        indices.extend(
            m.indices
                .iter()
                .map(|&i| if i < own { base + i } else { u32::MAX }),
        );
        positions.extend_from_slice(&m.positions);
    }
    let ((mut joints, mut weights), fallback) =
        match try_heat_weights(&skeleton, &positions, &indices) {
            Ok(w) => (w, None),
            Err(why) => (auto_weights(&skeleton, &positions), Some(why)),
        };
    for m in meshes.iter_mut().rev() {
        let at = joints.len() - m.positions.len();
        m.weights = weights.split_off(at);
        m.joints = joints.split_off(at);
    }
    Ok((skeleton, fallback))
}

fn setting(setting: impl Into<String>, message: impl Into<String>) -> Error {
    Error::Setting {
        setting: setting.into(),
        message: message.into(),
    }
}

/// Checks the options' counts before any work: spine joints, landmarks, branches, branch
/// names and the joints of the whole rig.
pub fn check_options(opts: &RigOptions) -> Result<()> {
    if !(1..=MAX_JOINTS).contains(&opts.joints) {
        return Err(setting(
            "rig.joints",
            format!(
                "must be between 1 and {MAX_JOINTS} spine joints, got {}",
                opts.joints
            ),
        ));
    }
    if opts.centre_line.len() > MAX_LANDMARKS {
        return Err(setting(
            "rig.centre_line",
            format!(
                "has {} landmarks, more than {MAX_LANDMARKS}",
                opts.centre_line.len()
            ),
        ));
    }
    if opts.branches.len() > MAX_BRANCHES {
        return Err(setting(
            "rig.branch",
            format!("{} branches, more than {MAX_BRANCHES}", opts.branches.len()),
        ));
    }
    if opts.humanoid
        && (!opts.centre_line.is_empty() || opts.head.is_some() || !opts.branches.is_empty())
    {
        return Err(setting(
            "rig.humanoid",
            "a humanoid fit places its own spine, head and limbs: give no spine, head or branches with it",
        ));
    }
    let mut total = opts.joints;
    let mut names = std::collections::HashSet::new();
    for b in &opts.branches {
        let what = format!("rig.branch \"{}\"", b.name);
        let name_ok = !b.name.is_empty()
            && b.name.len() <= MAX_BRANCH_NAME_BYTES
            && b.name.chars().all(|c| c.is_alphanumeric() || c == '_');
        if !name_ok {
            return Err(setting(
                what,
                format!(
                    "a branch name needs 1 to {MAX_BRANCH_NAME_BYTES} bytes of letters, digits or _ (it names joints)"
                ),
            ));
        }
        if !names.insert(b.name.as_str()) {
            return Err(setting(what, "two branches have this name"));
        }
        if !(2..=MAX_LANDMARKS).contains(&b.points.len()) {
            return Err(setting(
                what,
                format!(
                    "needs 2 to {MAX_LANDMARKS} landmarks (where it leaves the body, where it ends), got {}",
                    b.points.len()
                ),
            ));
        }
        if b.joints > MAX_JOINTS {
            return Err(setting(
                what,
                format!("asks for {} joints, more than {MAX_JOINTS}", b.joints),
            ));
        }
        let per_side = if b.joints == 0 {
            b.points.len()
        } else {
            b.joints + 1
        };
        total += per_side * if b.mirror { 2 } else { 1 };
    }
    if total > MAX_RIG_JOINTS {
        return Err(setting(
            "rig.joints",
            format!(
                "the spine and branches would have {total} joints, more than the {MAX_RIG_JOINTS} a ragdoll may have bodies"
            ),
        ));
    }
    Ok(())
}
