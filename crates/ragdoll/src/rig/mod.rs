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
//! Skin weights come from [`heat_weights`] (bone heat: they follow the body's volume),
//! which falls back to [`auto_weights`] (straight-line distance) where heat cannot be
//! solved.

mod centre_line;
mod cg;
mod heat;
mod visibility;
mod weights;

use glam::{Quat, Vec3};

pub use heat::{
    MAX_HEAT_TRIANGLES, MAX_HEAT_VERTICES, MAX_HEAT_WORK, NoHeat, heat_weights, try_heat_weights,
};
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
}

impl Default for RigOptions {
    fn default() -> Self {
        RigOptions {
            joints: DEFAULT_JOINTS,
            centre_line: Vec::new(),
            head: None,
            branches: Vec::new(),
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

/// The skeleton [`rig`] would bind `meshes` to, without touching them.
pub fn build_skeleton(meshes: &[SkinnedMesh], opts: &RigOptions) -> Result<Skeleton> {
    check_options(opts)?;
    let body = Body::new(meshes)?;
    // 1–2. Centre line, tail first.
    let line = centre_line(&body, opts)?;
    let (forward, left) = facing(&body.frame, &line, opts.centre_line.is_empty());
    // 3. Spine.
    let (spine, tip) = resample(&line, opts.joints);
    let mut layout = Layout::spine(&spine, tip);
    // 4. Branches.
    for b in &opts.branches {
        add_branch(&mut layout, b, &spine, tip, &body, left)?;
    }
    check_unique_names(&layout.names)?;
    // 5. Rest frames: Y along the bone, X toward the left.
    let rotations = layout.rest_rotations(forward, left);
    Skeleton::new(layout.into_joints(&rotations))
}

/// The meshes as one body to rig: their vertices, the surface samples the centre line is
/// fitted to, and the samples' principal frame.
struct Body {
    /// Every vertex, in order, so landmarks can name vertices.
    vertices: Vec<Vec3>,
    points: Vec<Vec3>,
    weights: Vec<f32>,
    frame: Frame,
    /// Extent along the principal axis, metres.
    length: f32,
}

impl Body {
    /// Fails when the meshes have no extent to rig.
    fn new(meshes: &[SkinnedMesh]) -> Result<Body> {
        // Every vertex, in order, so landmarks can name vertices; triangle indices shifted.
        let mut vertices = Vec::new();
        let mut indices = Vec::new();
        for m in meshes {
            let base = vertices.len() as u32;
            indices.extend(m.indices.iter().map(|i| i + base));
            vertices.extend_from_slice(&m.positions);
        }
        let (points, weights) = surface_samples(&vertices, &indices);
        let frame = Frame::new(&points, &weights, &vertices);
        let length = frame.span.1 - frame.span.0;
        if points.is_empty() || too_short(length) {
            return Err(Error::Skeleton {
                joint: String::new(),
                message:
                    "cannot rig the mesh: its vertices have no extent (none, or all at one point)"
                        .into(),
            });
        }
        Ok(Body {
            vertices,
            points,
            weights,
            frame,
            length,
        })
    }

    /// Where landmark `l` is; `what` names the setting it came from, for errors.
    fn resolve(&self, l: &Landmark, what: &str) -> Result<Vec3> {
        let vertices = &self.vertices;
        let p = match *l {
            Landmark::Point(p) => p,
            Landmark::Vertex(i) => *vertices.get(i).ok_or_else(|| {
                setting(
                    what,
                    format!(
                        "vertex {i} does not exist: the mesh has {} vertices (numbered from 0)",
                        vertices.len()
                    ),
                )
            })?,
        };
        crate::events::check_point(p)
            .map(|()| p)
            .map_err(|m| setting(what, format!("a landmark: {m}")))
    }

    /// Where each of `landmarks` is, in order; the first that cannot be resolved fails.
    fn resolve_all(&self, landmarks: &[Landmark], what: &str) -> Result<Vec<Vec3>> {
        landmarks.iter().map(|l| self.resolve(l, what)).collect()
    }
}

/// Steps 1–2: the centre line, tail first: found or through the user's landmarks, then
/// turned so the end nearest the user's head point, when given, comes last.
fn centre_line(body: &Body, opts: &RigOptions) -> Result<Vec<Vec3>> {
    let mut line = if opts.centre_line.is_empty() {
        found_centre_line(body, opts.joints)
    } else {
        if opts.centre_line.len() < 2 {
            return Err(setting(
                "rig.centre_line",
                "needs at least two landmarks (tail end, head end)",
            ));
        }
        body.resolve_all(&opts.centre_line, "rig.centre_line")?
    };
    if let Some(h) = &opts.head {
        let h = body.resolve(h, "rig.head")?;
        if line[0].distance(h) < line[line.len() - 1].distance(h) {
            line.reverse();
        }
    }
    if too_short(length(&line)) {
        return Err(setting(
            "rig.centre_line",
            "its landmarks are all at one point",
        ));
    }
    Ok(line)
}

/// The centre line found by principal-component analysis (a slab polyline refined as a
/// principal curve), its higher end last.
fn found_centre_line(body: &Body, joints: usize) -> Vec<Vec3> {
    let (frame, points, weights) = (&body.frame, &body.points, &body.weights);
    let slabs = (SLABS_PER_JOINT * joints).clamp(SLAB_RANGE[0], SLAB_RANGE[1]);
    let slab_line = principal_polyline(frame, points, weights, slabs);
    let line = principal_curve(&slab_line, points, weights, slabs);
    // The higher end is the head unless the user says otherwise.
    let (low, high) = end_heights(frame, points, weights);
    if low > high {
        line.into_iter().rev().collect()
    } else {
        line
    }
}

/// The body's forward (toward the head) and left (facing the head, Y up) directions; left
/// is the normal of its symmetry plane, which runs through the centroid. `found` says the
/// centre line was found rather than run through the user's landmarks.
fn facing(frame: &Frame, line: &[Vec3], found: bool) -> (Vec3, Vec3) {
    // The body's left (facing the head, Y up) and its symmetry plane.
    // Facing: the principal axis toward the head for a found centre line (its ends may sit
    // off the axis), the line's own ends for the user's.
    let chord = line[line.len() - 1] - line[0];
    let forward = if found {
        frame.axes[0] * chord.dot(frame.axes[0]).signum()
    } else {
        chord.normalize_or(frame.axes[0])
    };
    let left = if forward.dot(Vec3::Y).abs() < UPRIGHT_COS {
        Vec3::Y.cross(forward).normalize()
    } else {
        let side = frame.axes[1];
        (side - forward * side.dot(forward)).normalize_or(forward.any_orthonormal_vector())
    };
    (forward, left)
}

/// Step 4: branch `b` and, when mirrored, its twin, each a chain of joints hung from the
/// spine joint (`spine`, the last bone ending at `tip`) nearest its first landmark.
fn add_branch(
    layout: &mut Layout,
    b: &Branch,
    spine: &[Vec3],
    tip: Vec3,
    body: &Body,
    left: Vec3,
) -> Result<()> {
    let what = format!("rig.branch \"{}\"", b.name);
    let pts = body.resolve_all(&b.points, &what)?;
    let sides = branch_sides(b, &pts, body, left, &what)?;
    // Both twins hang from the same spine joint, even where a curled spine passes
    // nearer to one of them.
    let attach = nearest_bone(spine, tip, pts[0]);
    for (pts, side) in sides {
        let stem = branch_stem(b, side);
        let mut path = vec![spine[attach]];
        path.extend_from_slice(&pts);
        let (joints, end) = branch_joints(&path, b.joints);
        if too_short(length(&path)) {
            return Err(setting(what, "its landmarks are all at one point"));
        }
        layout.push_branch(&stem, attach, &joints, end);
    }
    Ok(())
}

/// The branch's landmarks `pts` with their first one's distance off the symmetry plane
/// (normal `left`, positive on the body's left), then, when mirrored, its twin's,
/// reflected across the plane. A mirrored branch starting on the plane is refused.
fn branch_sides(
    b: &Branch,
    pts: &[Vec3],
    body: &Body,
    left: Vec3,
    what: &str,
) -> Result<Vec<(Vec<Vec3>, f32)>> {
    let centroid = body.frame.centroid;
    let mirror = |p: Vec3| p - 2.0 * (p - centroid).dot(left) * left;
    let off_plane = (pts[0] - centroid).dot(left);
    let mut sides = vec![(pts.to_vec(), off_plane)];
    if b.mirror {
        if off_plane.abs() < MIN_OFF_PLANE_OF_LENGTH * body.length {
            return Err(setting(
                what,
                format!(
                    "its first landmark lies on the body's symmetry plane ({:.3} m from it), \
                     so its mirror image would coincide with it: start it to one side, or \
                     do not mirror it",
                    off_plane.abs()
                ),
            ));
        }
        sides.push((pts.iter().map(|&p| mirror(p)).collect(), -off_plane));
    }
    Ok(sides)
}

/// Name stem of one side's joints: the branch's name, with `_l` or `_r` (by the side of
/// the symmetry plane, `side`, it is on) when mirrored.
fn branch_stem(b: &Branch, side: f32) -> String {
    match (b.mirror, side > 0.0) {
        (false, _) => b.name.clone(),
        (true, true) => format!("{}_l", b.name),
        (true, false) => format!("{}_r", b.name),
    }
}

/// A branch's joints along `path` (its spine joint, then its landmarks) and where its last
/// bone ends: one on every point but the last when `count` is 0, else the first and
/// `count` more evenly spaced along the landmarks.
fn branch_joints(path: &[Vec3], count: usize) -> (Vec<Vec3>, Vec3) {
    if count == 0 {
        (path[..path.len() - 1].to_vec(), path[path.len() - 1])
    } else {
        let (mut js, end) = resample(&path[1..], count);
        js.insert(0, path[0]);
        (js, end)
    }
}

/// Joints are found by name: a branch named like the spine's joints would shadow one.
fn check_unique_names(names: &[String]) -> Result<()> {
    let mut seen = std::collections::HashSet::with_capacity(names.len());
    if let Some(dup) = names.iter().find(|n| !seen.insert(n.as_str())) {
        return Err(setting(
            "rig.branch",
            format!("the joint name \"{dup}\" would be used twice: rename the branch"),
        ));
    }
    Ok(())
}

/// The joints placed so far, as parallel lists in skeleton order (the spine, then each
/// branch): world positions, parents, tips (where a joint's bone ends when it has no
/// child to point at) and names.
struct Layout {
    world_pos: Vec<Vec3>,
    parents: Vec<Option<usize>>,
    tips: Vec<Option<Vec3>>,
    names: Vec<String>,
}

impl Layout {
    /// Step 3: the spine's joints from the tail (the root), each the parent of the next,
    /// named `spine00`, `spine01`, …, the last one `head`, tipped at `tip`.
    fn spine(spine: &[Vec3], tip: Vec3) -> Layout {
        let joints = spine.len();
        let mut names: Vec<String> = (0..joints).map(|i| format!("spine{i:02}")).collect();
        if joints > 1 {
            names[joints - 1] = "head".into();
        }
        let mut tips: Vec<Option<Vec3>> = vec![None; joints];
        tips[joints - 1] = Some(tip);
        Layout {
            world_pos: spine.to_vec(),
            parents: (0..joints).map(|i| i.checked_sub(1)).collect(),
            tips,
            names,
        }
    }

    /// Appends one side of a branch: `joints` named `{stem}00`, `{stem}01`, …, the first
    /// hanging from spine joint `attach` and each other from the one before, the last
    /// tipped at `end`.
    fn push_branch(&mut self, stem: &str, attach: usize, joints: &[Vec3], end: Vec3) {
        for (k, p) in joints.iter().enumerate() {
            self.parents.push(Some(if k == 0 {
                attach
            } else {
                self.world_pos.len() - 1
            }));
            self.world_pos.push(*p);
            self.tips.push(None);
            self.names.push(format!("{stem}{k:02}"));
        }
        *self.tips.last_mut().expect("a branch has joints") = Some(end);
    }

    /// Step 5: each joint's world rotation: Y along its bone (to its first child, else to
    /// its tip, else `forward`), X toward `left`.
    fn rest_rotations(&self, forward: Vec3, left: Vec3) -> Vec<Quat> {
        let world_pos = &self.world_pos;
        let n = world_pos.len();
        let mut first_child = vec![None; n];
        for (i, p) in self.parents.iter().enumerate() {
            if let Some(p) = *p {
                // A branch's first joint sits on its spine joint; the spine's own next joint
                // (listed first) is the bone that matters.
                first_child[p].get_or_insert(i);
            }
        }
        (0..n)
            .map(|i| {
                let end = first_child[i]
                    .map(|c| world_pos[c])
                    .filter(|e| e.distance(world_pos[i]) > 1e-6)
                    .or(self.tips[i])
                    .unwrap_or(world_pos[i] + forward);
                bone_frame((end - world_pos[i]).normalize_or(forward), left)
            })
            .collect()
    }

    /// The joints, with their world `rotations` turned into rest transforms relative to
    /// their parents and their tips into their own frames.
    fn into_joints(self, rotations: &[Quat]) -> Vec<Joint> {
        let n = self.world_pos.len();
        let worlds: Vec<Transform> = (0..n)
            .map(|i| Transform::new(self.world_pos[i], rotations[i]))
            .collect();
        (0..n)
            .map(|i| {
                let rest = match self.parents[i] {
                    Some(p) => worlds[p].inverse().mul(&worlds[i]),
                    None => worlds[i],
                };
                Joint {
                    name: self.names[i].clone(),
                    parent: self.parents[i],
                    rest,
                    tip: self.tips[i].map(|t| worlds[i].inverse().transform_point(t)),
                }
            })
            .collect()
    }
}

/// Whether a length (metres) is too small to rig along, or not a number.
fn too_short(len: f32) -> bool {
    len.is_nan() || len <= 1e-6
}

/// The spine joint whose bone (to the next joint, the last one's to `tip`) passes
/// nearest `p`.
fn nearest_bone(spine: &[Vec3], tip: Vec3, p: Vec3) -> usize {
    let end = |i: usize| spine.get(i + 1).copied().unwrap_or(tip);
    (0..spine.len())
        .min_by(|&a, &b| {
            distance_squared_to_segment(p, spine[a], end(a))
                .total_cmp(&distance_squared_to_segment(p, spine[b], end(b)))
        })
        .unwrap_or(0)
}

/// The rotation whose Y axis is `y` and whose X axis is as close to `left` as possible.
fn bone_frame(y: Vec3, left: Vec3) -> Quat {
    let mut x = left - y * left.dot(y);
    if x.length_squared() < 1e-8 {
        x = y.any_orthonormal_vector();
    }
    let x = x.normalize();
    let z = x.cross(y);
    Quat::from_mat3(&glam::Mat3::from_cols(x, y, z)).normalize()
}
