//! Skeleton + roles → [`RagdollSpec`] (DESIGN §3): one body per joint with a role, shaped
//! from the skin when there is one and from body proportions otherwise, weighed with
//! de Leva's segment fractions (humanoids) or by volume (anything else), linked by joints
//! whose axes come from the rest pose so limits hold whatever way the character faces.
//!
//! Conventions of the output, for the runtime side:
//! - A body's `center_m` / `rotation` are in its bone's rest frame (the joint's rest world
//!   rotation and position, no scale); the shape's long axis is the shape frame's Y.
//! - A joint's `frame` is in the child bone's rest frame. Hinges turn about its X, positive
//!   in flexion. Swing-twist joints twist about its X (the child bone); its Y is the
//!   direction the bone moves in flexion, so a positive turn about Z flexes the limb.
//! - `cone_tilt_deg = [ty, tz]`: the parent side of the joint frame is the frame turned
//!   about its Y by `ty`, then about the turned Z by `tz` (`frame · Ry(ty) · Rz(tz)`, as
//!   the world builds it), so the cone centre is `Ry(ty) · Rz(tz) · X` in the joint frame.
//!   [`cone_centre`] computes it.

use std::collections::{HashMap, HashSet};

use glam::{Mat3, Quat, Vec3};

use super::anthropometry::*;
use super::roles::{Rig, Roles};
use super::{
    BodySpec, CollisionSpec, JointKind, JointSpec, RagdollSpec, Role, SPEC_FORMAT_VERSION, Shape,
};
use crate::error::{Error, Result};
use crate::math::{frame_from_x, twist_angle_x};
use crate::skeleton::Character;

/// Options for [`build_spec`]; the default builds a 75 kg male humanoid (or a creature
/// weighed by its volume).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BuildOptions {
    /// Total mass, kg. `None`: 75 kg for a humanoid (DESIGN §3), shape volume × 1000 kg/m³
    /// for anything else (so a creature's mass follows its size).
    pub total_mass_kg: Option<f32>,
    /// Use de Leva's female segment fractions (more mass in the hips and legs) instead of
    /// the male ones.
    pub female: bool,
}

// --- Tuning --------------------------------------------------------------------------

/// Percentile of the skin's distance to a bone axis taken as the capsule radius: robust to
/// stray vertices (clothing, vertices of a neighbour weighted here) and a little inside the
/// surface, so bodies of a rest pose do not start in contact.
const RADIUS_PERCENTILE: f32 = 0.65;
/// Percentile of the skin's reach along a leaf bone (head, hand, foot) taken as its end.
const REACH_PERCENTILE: f32 = 0.95;
/// Percentiles bounding the trunk's width and depth from its skin.
const TRUNK_PERCENTILES: [f32; 2] = [0.05, 0.95];
/// Fewest skin vertices a measurement is made from; below, proportions are used.
const MIN_FIT_VERTICES: usize = 8;
/// A vertex belongs to the body whose joints hold at least this share of its weight.
const MIN_GROUP_WEIGHT: f32 = 0.5;
/// Radii removed from each end of a capsule: its round ends then stop at the joints, so
/// neighbours meet instead of overlapping (jointed pairs do not collide anyway).
const CAPSULE_END_INSET_RADII: f32 = 1.0;
/// Measured radii are kept within these fractions of H (humanoids) or of the skeleton's
/// extent (other creatures): a bad skin (a cape weighted to an arm) must not make a limb
/// absurd.
const RADIUS_RANGE: [f32; 2] = [0.004, 0.12];
/// Measured trunk widths/depths are kept within these multiples of the proportional ones.
const TRUNK_FIT_RANGE: [f32; 2] = [0.5, 2.0];
/// A trunk segment is at least this tall (fraction of H), so a pelvis joint sitting right
/// under the chest still gets a real body.
const MIN_TRUNK_HEIGHT_H: f32 = 0.04;
/// Chest length when nothing lies above it (no neck, no head joint).
const CHEST_LENGTH_H: f32 = 0.15;
/// Radius of a non-humanoid link without skin, as a fraction of its length (a tapering
/// tail or leg is about a fifth as thick as long)...
const CHAIN_RADIUS_OF_LENGTH: f32 = 0.15;
/// ...but at least this fraction of the skeleton's extent, so stubby links stay solid.
const CHAIN_MIN_RADIUS_EXTENT: f32 = 0.01;
/// Length of a link whose bone has none (all joints in one place): fraction of extent.
const DEGENERATE_LENGTH_EXTENT: f32 = 0.05;
/// Largest mass ratio between a jointed parent and child. Strunk ("Stop my Constraints
/// from Blowing Up!", GDC 2013) shows iterative solvers converge badly as linked masses
/// diverge; Jolt's `RagdollSettings::Stabilize` clamps each child/parent ratio to
/// [0.8, 1.2], which flattens anatomy. 5 keeps de Leva's proportions except the lightest
/// links (neck, upper arms against a 12 kg chest), which are raised.
const MAX_LINKED_MASS_RATIO: f32 = 5.0;
/// Two bodies closer than this (plus their radii) in the rest pose never collide: they
/// touch or nearly touch at rest and would push apart on the first step.
const COLLISION_MARGIN_M: f32 = 0.01;
/// Most pairs of bodies a built spec may list as not colliding: about a million. A character
/// gets a few per body; a chain of thousands of bodies thicker than their spacing (every
/// body overlapping hundreds of others) would otherwise list tens of millions, each pair
/// two names in memory, and exhaust it.
pub(crate) const MAX_DISABLED_PAIRS: usize = 1 << 20;
/// A swing cone always contains the rest direction with this margin, so an odd rest pose
/// never starts outside its limits.
const REST_MARGIN_DEG: f32 = 5.0;
/// Below this |sin| two directions count as parallel when building frames.
const PARALLEL_SIN: f32 = 0.3;

/// The cone centre of a [`JointKind::SwingTwist`] in its joint frame: X of the frame
/// turned about its Y by `cone_tilt_deg[0]`, then about its (turned) Z by
/// `cone_tilt_deg[1]`.
pub fn cone_centre(cone_tilt_deg: [f32; 2]) -> Vec3 {
    let (ty, tz) = (cone_tilt_deg[0].to_radians(), cone_tilt_deg[1].to_radians());
    Quat::from_rotation_y(ty) * Quat::from_rotation_z(tz) * Vec3::X
}

/// Builds a spec from a character's skeleton, skin and recognised roles.
pub fn build_spec(character: &Character, opts: &BuildOptions) -> Result<RagdollSpec> {
    build_spec_with_roles(character, opts, None)
}

/// [`build_spec`] with the roles a roles file gives ([`super::roles_with_file`]) where
/// there is one.
pub fn build_spec_with_roles(
    character: &Character,
    opts: &BuildOptions,
    roles: Option<&super::RoleFile>,
) -> Result<RagdollSpec> {
    if let Some(m) = opts.total_mass_kg
        && !(m.is_finite() && m > 0.0)
    {
        return Err(Error::Setting {
            setting: "total_mass_kg".into(),
            message: format!("must be a positive number of kilograms, got {m}"),
        });
    }
    let roles = super::roles_for(character, roles)?;
    let rig = Rig::new(character);
    let b = Builder::new(&rig, &roles, opts);
    let mut spec = b.spec(character)?;
    // The ragdoll starts in the first animation frame; limits give way where that pose
    // lies outside them (see `fit_limits_to_pose`).
    let start = super::start_pose(character, true);
    super::fit_limits_to_pose(&mut spec, character, &start, START_POSE_MARGIN_DEG)?;
    filter_start_overlaps(&mut spec, character, &start)?;
    spec.validate()?;
    Ok(spec)
}

/// Also filters the pairs that overlap in the starting pose (the first animation frame): a
/// mocap pose can cross an arm over the chest, and bodies that start inside each other
/// would be thrown apart on the first step.
fn filter_start_overlaps(
    spec: &mut RagdollSpec,
    character: &Character,
    start: &[crate::math::Transform],
) -> Result<()> {
    let poses = super::Resolved::new(spec, character)?.body_poses(start);
    let solids: Vec<Solid> = spec
        .bodies
        .iter()
        .zip(&poses)
        .map(|(b, pose)| solid(&b.shape, pose.translation, pose.rotation))
        .collect();
    // What `CollisionSpec::is_disabled` answers, as a set: the pairs are looked up once per
    // nearby pair of bodies, and a scan of the list each time made this quadratic in pairs.
    let mut disabled: HashSet<(&str, &str)> = spec
        .collision
        .disabled_pairs
        .iter()
        .map(|[a, b]| name_pair(a, b))
        .collect();
    let mut found = Vec::new();
    for (a, b) in nearby_pairs(&solids, COLLISION_MARGIN_M)? {
        let (na, nb) = (spec.bodies[a].name.as_str(), spec.bodies[b].name.as_str());
        if !disabled.contains(&name_pair(na, nb))
            && shapes_overlap(
                &poses[a],
                &spec.bodies[a].shape,
                &poses[b],
                &spec.bodies[b].shape,
                COLLISION_MARGIN_M,
            )
        {
            disabled.insert(name_pair(na, nb));
            found.push([na.to_string(), nb.to_string()]);
        }
    }
    if spec.collision.disabled_pairs.len() + found.len() > MAX_DISABLED_PAIRS {
        return Err(too_many_pairs());
    }
    spec.collision.disabled_pairs.extend(found);
    Ok(())
}

/// A pair of body names in a fixed order, so `(a, b)` and `(b, a)` are one key.
fn name_pair<'s>(a: &'s str, b: &'s str) -> (&'s str, &'s str) {
    if a <= b { (a, b) } else { (b, a) }
}

/// Every pair `(i, j)`, `i < j`, in increasing order, whose solids might come within
/// `margin` of each other: the pairs whose bounding boxes (grown by the radii, the margin
/// and a rounding allowance) overlap. A superset of the pairs the exact test accepts, in
/// the order a loop over all pairs would visit them, found through a uniform grid so the
/// cost follows the pairs that are close rather than all pairs. Solids that are not finite
/// are left out: the exact test refuses them anyway. More than a few times
/// [`MAX_DISABLED_PAIRS`] candidates is an error rather than a list that size.
fn nearby_pairs(solids: &[Solid], margin: f32) -> Result<Vec<(usize, usize)>> {
    let boxes: Vec<Option<(Vec3, Vec3)>> = solids
        .iter()
        .map(|s| {
            let grow = s.r + 0.5 * margin;
            let (lo, hi) = (s.a.min(s.b), s.a.max(s.b));
            let slack = 1e-4 * (1.0 + lo.abs().max(hi.abs()).max_element() + grow.abs());
            let g = Vec3::splat(grow + slack);
            let (lo, hi) = (lo - g, hi + g);
            (lo.is_finite() && hi.is_finite()).then_some((lo, hi))
        })
        .collect();
    let overlap = |i: usize, j: usize| match (boxes[i], boxes[j]) {
        (Some((la, ha)), Some((lb, hb))) => la.cmple(hb).all() && lb.cmple(ha).all(),
        _ => false,
    };
    // Cells as large as a typical box; a box spanning many cells is checked against all.
    let mut sizes: Vec<f32> = boxes
        .iter()
        .flatten()
        .map(|(lo, hi)| (*hi - *lo).max_element())
        .collect();
    sizes.sort_by(f32::total_cmp);
    let cell = sizes
        .get(sizes.len() / 2)
        .copied()
        .filter(|c| *c > 0.0)
        .unwrap_or(1.0);
    // Cell coordinates, monotone in the position (saturating far away), so boxes that
    // overlap always share a cell.
    let key = |v: Vec3| (v.as_dvec3() / f64::from(cell)).floor();
    let mut grid: HashMap<glam::I64Vec3, Vec<usize>> = HashMap::new();
    let mut big = Vec::new();
    for (i, b) in boxes.iter().enumerate() {
        let Some((lo, hi)) = b else { continue };
        let (kl, kh) = (key(*lo), key(*hi));
        let span = kh - kl + glam::DVec3::ONE;
        if span.x * span.y * span.z > MAX_CELLS_PER_BODY {
            big.push(i);
            continue;
        }
        let (kl, kh) = (kl.as_i64vec3(), kh.as_i64vec3());
        for x in kl.x..=kh.x {
            for y in kl.y..=kh.y {
                for z in kl.z..=kh.z {
                    grid.entry(glam::I64Vec3::new(x, y, z)).or_default().push(i);
                }
            }
        }
    }
    let mut pairs = Vec::new();
    let mut add = |i: usize, j: usize| {
        if overlap(i, j) {
            pairs.push((i.min(j), i.max(j)));
            if pairs.len() > MAX_CANDIDATE_PAIRS {
                return Err(too_many_pairs());
            }
        }
        Ok(())
    };
    for members in grid.values() {
        for (k, &i) in members.iter().enumerate() {
            for &j in &members[k + 1..] {
                add(i, j)?;
            }
        }
    }
    for &i in &big {
        for j in (0..solids.len()).filter(|&j| j != i) {
            add(i, j)?;
        }
    }
    pairs.sort_unstable();
    pairs.dedup();
    Ok(pairs)
}

/// Candidate pairs [`nearby_pairs`] may hold (a pair can be found in several cells).
const MAX_CANDIDATE_PAIRS: usize = 8 * MAX_DISABLED_PAIRS;

fn too_many_pairs() -> Error {
    Error::Spec {
        place: "collision.disabled_pairs".into(),
        message: format!(
            "more than {MAX_DISABLED_PAIRS} pairs of bodies touch in the rest pose (bodies far thicker than the bones between them); this is not a ragdoll that can be built"
        ),
    }
}

/// Grid cells one solid may be entered in before it is compared with every solid instead.
const MAX_CELLS_PER_BODY: f64 = 64.0;

/// How far inside a widened limit the starting pose ends up, degrees: enough that the
/// first steps' small motions do not already press on the limit.
const START_POSE_MARGIN_DEG: f32 = 5.0;

/// A body being planned, in world space.
struct Plan {
    joint: usize,
    role: Role,
    name: String,
    /// Where the bone starts and ends (the body's axis), world.
    start: Vec3,
    end: Vec3,
    shape: Shape,
    /// Shape centre and orientation, world.
    centre: Vec3,
    rotation: Quat,
}

impl Plan {
    fn dir(&self) -> Vec3 {
        (self.end - self.start).normalize_or(self.rotation * Vec3::Y)
    }
}

struct Builder<'a> {
    rig: &'a Rig<'a>,
    roles: &'a Roles,
    opts: &'a BuildOptions,
    h: f32,
    forward: Vec3,
    left: Vec3,
    /// Joints with bodies, root first.
    joints: Vec<usize>,
    /// For each skeleton joint, the body it moves with (itself or an ancestor's).
    owner: Vec<usize>,
    /// Skin vertices belonging to each body.
    groups: Vec<Vec<Vec3>>,
}

impl<'a> Builder<'a> {
    fn new(rig: &'a Rig<'a>, roles: &'a Roles, opts: &'a BuildOptions) -> Self {
        let n = rig.len();
        // The neck gets no body of its own: it rides on the chest and the head pivots at the
        // top of the neck with the neck's range added to its own. A short neck body between
        // the heavy chest and head is the worst-conditioned link of the chain: with one,
        // the rigid solver let the neck leave its limits by 20-33° on every fall we ran
        // (`examples/probe`, several substep and iteration settings).
        let mut joints: Vec<usize> = (0..n)
            .filter(|&j| matches!(roles.per_joint[j], Some(r) if r != Role::Neck))
            .collect();
        if let Some(p) = roles.joint(Role::Pelvis)
            && let Some(k) = joints.iter().position(|&j| j == p)
        {
            joints.remove(k);
            joints.insert(0, p);
        }
        let joints = parent_first(roles, joints);
        let mut body_of = vec![None; n];
        for (b, &j) in joints.iter().enumerate() {
            body_of[j] = Some(b);
        }
        let mut owner = vec![0usize; n];
        for j in 0..n {
            owner[j] = match body_of[j] {
                Some(b) => b,
                None => rig.parent(j).map_or(0, |p| owner[p]),
            };
        }
        let mut groups = vec![Vec::new(); joints.len()];
        for (p, js, ws) in &rig.verts {
            let mut share: [(usize, f32); 4] = [(usize::MAX, 0.0); 4];
            for c in 0..4 {
                let Some(&o) = owner.get(js[c] as usize) else {
                    continue;
                };
                if let Some(s) = share.iter_mut().find(|s| s.0 == o || s.0 == usize::MAX) {
                    s.0 = o;
                    s.1 += ws[c].max(0.0);
                }
            }
            let best = share.iter().max_by(|a, b| a.1.total_cmp(&b.1));
            if let Some(&(o, w)) = best
                && o != usize::MAX
                && w >= MIN_GROUP_WEIGHT
            {
                groups[o].push(*p);
            }
        }
        Builder {
            rig,
            roles,
            opts,
            // The height roles were measured at: a BVH whose rest pose lies flat (Rokoko) is
            // measured standing, in its first frame.
            h: roles.height_m,
            forward: roles.forward,
            left: roles.left(),
            joints,
            owner,
            groups,
        }
    }

    fn spec(&self, character: &Character) -> Result<RagdollSpec> {
        let plans: Vec<Plan> = (0..self.joints.len()).map(|b| self.plan(b)).collect();
        let parents: Vec<usize> = (0..plans.len())
            .map(|b| match b {
                0 => 0,
                _ => parent_body(self.roles, plans[b].joint, |j| {
                    self.joints.iter().position(|&k| k == j)
                })
                .unwrap_or_else(|| self.rig.parent(plans[b].joint).map_or(0, |p| self.owner[p])),
            })
            .collect();
        let masses = self.masses(&plans, &parents);

        let mut names: Vec<String> = Vec::new();
        let mut taken = HashSet::new();
        for p in &plans {
            let mut name = p.name.clone();
            if taken.contains(&name) {
                name = format!("{}#{}", p.name, p.joint);
            }
            taken.insert(name.clone());
            names.push(name);
        }
        let bodies: Vec<BodySpec> = plans
            .iter()
            .zip(&masses)
            .zip(&names)
            .map(|((p, &mass_kg), name)| {
                let bone = self.rig.world[p.joint];
                let inv = bone.rotation.conjugate();
                BodySpec {
                    name: name.clone(),
                    bone: self.rig.skeleton.joint_label(p.joint),
                    role: Some(p.role),
                    shape: p.shape,
                    center_m: (inv * (p.centre - bone.translation)).to_array(),
                    rotation: (inv * p.rotation).normalize().to_array(),
                    mass_kg,
                }
            })
            .collect();
        let joints: Vec<JointSpec> = (1..plans.len())
            .map(|b| {
                let (frame_world, kind) = self.joint(&plans[b], &plans[parents[b]]);
                let bone = self.rig.world[plans[b].joint];
                JointSpec {
                    name: names[b].clone(),
                    parent: names[parents[b]].clone(),
                    child: names[b].clone(),
                    anchor_m: [0.0; 3],
                    frame: (bone.rotation.conjugate() * frame_world)
                        .normalize()
                        .to_array(),
                    kind,
                }
            })
            .collect();
        let collision = collision_filter(&plans, &parents, &names)?;
        Ok(RagdollSpec {
            format_version: SPEC_FORMAT_VERSION,
            name: character.name.clone(),
            bodies,
            joints,
            collision,
        })
    }

    fn role_joint(&self, role: Role) -> Option<usize> {
        self.roles.joint(role)
    }

    fn pos(&self, j: usize) -> Vec3 {
        self.rig.pos[j]
    }

    // --- Shapes ----------------------------------------------------------------------

    fn plan(&self, b: usize) -> Plan {
        let j = self.joints[b];
        let role = self.roles.per_joint[j].unwrap_or(Role::Chain);
        let name = if self.roles.humanoid {
            role.as_str().to_string()
        } else {
            self.rig.skeleton.joint_label(j)
        };
        let start = self.pos(j);
        let group = &self.groups[b];
        let h = self.h;
        let rj = |r: Role| self.role_joint(r).map(|k| self.pos(k));
        let dir_between = |a: Option<Vec3>, b: Option<Vec3>, or: Vec3| match (a, b) {
            (Some(a), Some(b)) => (b - a).normalize_or(or),
            _ => or,
        };
        use Role::*;
        let (end, radius_h) = match role {
            Pelvis | Spine | Chest => {
                let next = match role {
                    Pelvis => rj(Spine).or(rj(Chest)),
                    Spine => rj(Chest),
                    _ => rj(Neck).or(rj(Head)),
                };
                let end = next.unwrap_or(start + Vec3::Y * CHEST_LENGTH_H * h);
                return self.trunk_plan(j, role, name, end, group);
            }
            Neck => (
                rj(Head).unwrap_or(start + Vec3::Y * NECK_RADIUS_H * h),
                NECK_RADIUS_H,
            ),
            Head => {
                let below = rj(Neck).or(rj(Chest));
                let dir = dir_between(below, Some(start), Vec3::Y);
                (
                    self.extremity(j, group, dir, HEAD_LENGTH_H * h, false),
                    HEAD_RADIUS_H,
                )
            }
            UpperArmL | UpperArmR => {
                let fore = if role == UpperArmL {
                    ForearmL
                } else {
                    ForearmR
                };
                (rj(fore).unwrap_or(start), UPPER_ARM_RADIUS_H)
            }
            ForearmL | ForearmR => {
                let (upper, hand) = if role == ForearmL {
                    (UpperArmL, HandL)
                } else {
                    (UpperArmR, HandR)
                };
                let end = rj(hand).unwrap_or_else(|| {
                    let dir = dir_between(rj(upper), Some(start), -Vec3::Y);
                    self.extremity(j, group, dir, HAND_LENGTH_H * h, true)
                });
                (end, FOREARM_RADIUS_H)
            }
            HandL | HandR => {
                let fore = if role == HandL { ForearmL } else { ForearmR };
                let dir = dir_between(rj(fore), Some(start), -Vec3::Y);
                (
                    self.extremity(j, group, dir, HAND_LENGTH_H * h, true),
                    HAND_RADIUS_H,
                )
            }
            ThighL | ThighR => {
                let shin = if role == ThighL { ShinL } else { ShinR };
                (rj(shin).unwrap_or(start), THIGH_RADIUS_H)
            }
            ShinL | ShinR => {
                let foot = if role == ShinL { FootL } else { FootR };
                let end = rj(foot).unwrap_or_else(|| {
                    self.extremity(j, group, self.foot_dir(), FOOT_LENGTH_H * h, true)
                });
                (end, SHIN_RADIUS_H)
            }
            FootL | FootR if group.len() >= MIN_FIT_VERTICES => {
                // A skinned foot lies along its skin's long axis, heel to toe: the ankle
                // sits above the heel, so a capsule hung from the ankle joint would cut
                // through the sole and miss the toes.
                let (heel, toe) = principal_segment(group);
                let (heel, toe) = if (toe - heel).dot(self.forward) >= 0.0 {
                    (heel, toe)
                } else {
                    (toe, heel)
                };
                let radius = self
                    .fit_radius(heel, toe, group)
                    .unwrap_or(FOOT_RADIUS_H * h);
                return capsule_plan(j, role, name, heel, toe, radius, self.left);
            }
            FootL | FootR => (
                self.extremity(j, group, self.foot_dir(), FOOT_LENGTH_H * h, true),
                FOOT_RADIUS_H,
            ),
            Chain => return self.chain_plan(j, name, group),
        };
        let radius = self.fit_radius(start, end, group).unwrap_or(radius_h * h);
        capsule_plan(j, role, name, start, end, radius, self.left)
    }

    /// Unit direction of an estimated foot: forward, pitched down toward the toes.
    fn foot_dir(&self) -> Vec3 {
        let p = FOOT_PITCH_DEG.to_radians();
        self.forward * p.cos() - Vec3::Y * p.sin()
    }

    /// Where a limb's last bone ends: its end site for a leaf that has one, else the
    /// farthest of its skin (or skeleton) along `dir`, at least `default_len` when there is
    /// no skin to measure. With `follow_children`, `dir` is replaced by the direction to
    /// the farthest descendant (toes, fingertips) when there is one.
    fn extremity(
        &self,
        j: usize,
        group: &[Vec3],
        dir: Vec3,
        default_len: f32,
        follow_children: bool,
    ) -> Vec3 {
        let rig = self.rig;
        let p = rig.pos[j];
        if rig.children[j].is_empty()
            && let Some(t) = rig.tips[j]
        {
            return t;
        }
        let pts: Vec<Vec3> = rig
            .subtree_points(j)
            .into_iter()
            .filter(|q| q.distance(p) > 1e-6)
            .collect();
        let far = pts
            .iter()
            .copied()
            .max_by(|a, b| a.distance(p).total_cmp(&b.distance(p)));
        let dir = match far {
            Some(f) if follow_children => (f - p).normalize_or(dir),
            _ => dir,
        };
        let skeletal = pts.iter().map(|q| (*q - p).dot(dir)).fold(0.0f32, f32::max);
        let skin = (group.len() >= MIN_FIT_VERTICES).then(|| {
            percentile(
                group.iter().map(|v| (*v - p).dot(dir)).collect(),
                REACH_PERCENTILE,
            )
        });
        let len = skeletal.max(skin.unwrap_or(default_len));
        p + dir * len
    }

    /// Capsule radius from the skin around the bone `a → b`: a robust percentile of the
    /// distance to the axis of the vertices alongside the bone.
    fn fit_radius(&self, a: Vec3, b: Vec3, group: &[Vec3]) -> Option<f32> {
        let axis = b - a;
        let len2 = axis.length_squared();
        if len2 < 1e-12 {
            return None;
        }
        let d: Vec<f32> = group
            .iter()
            .filter_map(|v| {
                let t = (*v - a).dot(axis) / len2;
                (0.0..=1.0)
                    .contains(&t)
                    .then(|| (*v - (a + axis * t)).length())
            })
            .collect();
        // A humanoid's thickness scales with its height; a creature's (a long, low fox)
        // with its overall size.
        let size = if self.roles.humanoid {
            self.h
        } else {
            self.rig.extent
        };
        (d.len() >= MIN_FIT_VERTICES).then(|| {
            percentile(d, RADIUS_PERCENTILE).clamp(RADIUS_RANGE[0] * size, RADIUS_RANGE[1] * size)
        })
    }

    /// A trunk segment: a box as wide and deep as the trunk, spanning the segment along the
    /// spine (the pelvis reaches down to the hip joints). A box rather than a capsule along
    /// the spine: it has the trunk's width without its length, and a ragdoll lying on its
    /// back does not roll on it.
    fn trunk_plan(&self, j: usize, role: Role, name: String, end: Vec3, group: &[Vec3]) -> Plan {
        let h = self.h;
        let a = self.pos(j);
        let length = end.distance(a);
        let u = (end - a).normalize_or(Vec3::Y);
        let x = perpendicular_part(self.left, u).unwrap_or_else(|| u.any_orthonormal_vector());
        let z = x.cross(u);
        let (mut y0, mut y1) = (0.0f32, length);
        if role == Role::Pelvis {
            for t in [Role::ThighL, Role::ThighR] {
                if let Some(k) = self.role_joint(t) {
                    y0 = y0.min((self.pos(k) - a).dot(u));
                }
            }
        }
        if y1 - y0 < MIN_TRUNK_HEIGHT_H * h {
            y1 = y0 + MIN_TRUNK_HEIGHT_H * h;
        }
        let (w0, d0) = match role {
            Role::Pelvis => (PELVIS_WIDTH_H * h, PELVIS_DEPTH_H * h),
            Role::Spine => (WAIST_WIDTH_H * h, WAIST_DEPTH_H * h),
            _ => (CHEST_WIDTH_H * h, CHEST_DEPTH_H * h),
        };
        let (mut width, mut depth, mut cx, mut cz) = (w0, d0, 0.0, 0.0);
        if group.len() >= MIN_FIT_VERTICES {
            let span = |axis: Vec3| {
                let v: Vec<f32> = group.iter().map(|p| (*p - a).dot(axis)).collect();
                let lo = percentile(v.clone(), TRUNK_PERCENTILES[0]);
                let hi = percentile(v, TRUNK_PERCENTILES[1]);
                (hi - lo, 0.5 * (hi + lo))
            };
            let (w, c) = span(x);
            width = w.clamp(TRUNK_FIT_RANGE[0] * w0, TRUNK_FIT_RANGE[1] * w0);
            cx = c;
            let (d, c) = span(z);
            depth = d.clamp(TRUNK_FIT_RANGE[0] * d0, TRUNK_FIT_RANGE[1] * d0);
            cz = c;
        }
        let tall = y1 - y0;
        let centre = a + u * (0.5 * (y0 + y1)) + x * cx + z * cz;
        let shape = Shape::Box {
            size_m: [width, tall, depth],
        };
        let rotation = quat_from_cols(x, u, z);
        Plan {
            joint: j,
            role,
            name,
            start: a,
            end,
            shape,
            centre,
            rotation,
        }
    }

    /// A non-humanoid link: a capsule along its bone, or along its skin when the bone has
    /// no length (every joint in one place, as in SimpleSkin's rest pose).
    fn chain_plan(&self, j: usize, name: String, group: &[Vec3]) -> Plan {
        let rig = self.rig;
        let a = rig.pos[j];
        let tiny = 1e-4 * rig.extent;
        let enough_skin = group.len() >= MIN_FIT_VERTICES;
        let mut end = rig.chain_bone_end(j);
        if rig.children[j].is_empty() && rig.tips[j].is_none() && enough_skin {
            // A bare leaf with skin: reach as far as the skin goes.
            let toward = centroid(group) - a;
            let dir = match rig.parent(j) {
                Some(p) if (a - rig.pos[p]).length() > tiny => (a - rig.pos[p]).normalize(),
                _ => toward.normalize_or(Vec3::Y),
            };
            let reach = percentile(
                group.iter().map(|v| (*v - a).dot(dir)).collect(),
                REACH_PERCENTILE,
            );
            if reach > tiny {
                end = Some(a + dir * reach);
            }
        }
        let (start, end) = match end {
            Some(e) if e.distance(a) > tiny => (a, e),
            _ if enough_skin => principal_segment(group),
            _ => {
                let dir = rig.world[j].rotation * Vec3::Y;
                (a, a + dir * DEGENERATE_LENGTH_EXTENT * rig.extent)
            }
        };
        let len = end.distance(start);
        let radius = self
            .fit_radius(start, end, group)
            .unwrap_or((CHAIN_RADIUS_OF_LENGTH * len).max(CHAIN_MIN_RADIUS_EXTENT * rig.extent));
        capsule_plan(j, Role::Chain, name, start, end, radius, self.left)
    }

    // --- Masses ----------------------------------------------------------------------

    fn masses(&self, plans: &[Plan], parents: &[usize]) -> Vec<f32> {
        let mut m: Vec<f32> = if self.roles.humanoid {
            let total = self.opts.total_mass_kg.unwrap_or(DEFAULT_HUMANOID_MASS_KG);
            self.humanoid_masses(plans, total)
        } else {
            let volumes: Vec<f32> = plans.iter().map(|p| p.shape.volume()).collect();
            match self.opts.total_mass_kg {
                Some(total) => {
                    let v: f32 = volumes.iter().sum();
                    volumes.iter().map(|x| total * x / v).collect()
                }
                None => volumes.iter().map(|x| x * BODY_DENSITY_KG_M3).collect(),
            }
        };
        let total = match (self.roles.humanoid, self.opts.total_mass_kg) {
            (_, Some(t)) => t,
            (true, None) => DEFAULT_HUMANOID_MASS_KG,
            (false, None) => m.iter().sum(),
        };
        stabilize_masses(&mut m, parents, MAX_LINKED_MASS_RATIO);
        keep_total(&mut m, total);
        m
    }

    /// de Leva's fractions of `total`, each segment on the body that carries it; segments
    /// without a body of their own (no spine joint, no hand joint…) go to the neighbour
    /// that spans them, so the total is kept exactly.
    fn humanoid_masses(&self, plans: &[Plan], total: f32) -> Vec<f32> {
        use Role::*;
        let fr = if self.opts.female {
            DE_LEVA_FEMALE
        } else {
            DE_LEVA_MALE
        };
        let kg = |percent: f32| total * percent / fr.total_percent();
        let has = |r: Role| plans.iter().any(|p| p.role == r);
        let mut mass = std::collections::HashMap::<Role, f32>::new();
        let mut give = |r: Role, m: f32| *mass.entry(r).or_insert(0.0) += m;

        give(Pelvis, kg(fr.trunk_lower));
        give(Chest, kg(fr.trunk_upper));
        if has(Spine) {
            give(Spine, kg(fr.trunk_middle));
        } else {
            // The abdomen lies between the pelvis and chest bodies: half to each.
            give(Pelvis, 0.5 * kg(fr.trunk_middle));
            give(Chest, 0.5 * kg(fr.trunk_middle));
        }
        let head_neck = kg(fr.head_neck);
        match (has(Neck), has(Head)) {
            (true, true) => {
                give(Neck, NECK_SHARE_OF_HEAD_NECK * head_neck);
                give(Head, (1.0 - NECK_SHARE_OF_HEAD_NECK) * head_neck);
            }
            (true, false) => give(Neck, head_neck),
            (false, true) => give(Head, head_neck),
            (false, false) => give(Chest, head_neck),
        }
        for side in [
            [UpperArmL, ForearmL, HandL, ThighL, ShinL, FootL],
            [UpperArmR, ForearmR, HandR, ThighR, ShinR, FootR],
        ] {
            let [ua, fa, hd, th, sh, ft] = side;
            give(ua, kg(fr.upper_arm));
            give(fa, kg(fr.forearm));
            give(if has(hd) { hd } else { fa }, kg(fr.hand));
            give(th, kg(fr.thigh));
            give(sh, kg(fr.shank));
            give(if has(ft) { ft } else { sh }, kg(fr.foot));
        }
        plans
            .iter()
            .map(|p| mass.get(&p.role).copied().unwrap_or(0.0))
            .collect()
    }

    // --- Joints ----------------------------------------------------------------------

    /// The joint linking `child` to `parent`: its frame in world space and its kind.
    fn joint(&self, child: &Plan, parent: &Plan) -> (Quat, JointKind) {
        use Role::*;
        let d = child.dir();
        let f = self.forward;
        let up = Vec3::Y;
        let parent_has = |r: Role| parent.role == r;
        match child.role {
            ShinL | ShinR => self.hinge(d, parent.dir(), -f, up, KNEE_FLEXION_DEG),
            ForearmL | ForearmR => self.hinge(d, parent.dir(), f, up, ELBOW_FLEXION_DEG),
            ThighL | ThighR => {
                let centre_deg = 0.5 * (HIP_FLEXION_DEG[0] + HIP_FLEXION_DEG[1]);
                // Half the flexion range, and wide enough that a straight leg abducted by
                // HIP_ABDUCTION_DEG is inside (spherical cosine rule from the centre).
                let abducted = (centre_deg.to_radians().cos()
                    * HIP_ABDUCTION_DEG.to_radians().cos())
                .acos()
                .to_degrees();
                let swing = (0.5 * (HIP_FLEXION_DEG[1] - HIP_FLEXION_DEG[0])).max(abducted);
                let c = rotate_toward(-up, f, centre_deg);
                swing_twist(d, &[f, up], Some(c), swing, HIP_TWIST_DEG)
            }
            UpperArmL | UpperArmR => {
                let out = if child.role == UpperArmL {
                    self.left
                } else {
                    -self.left
                };
                let side = rotate_toward(-up, out, SHOULDER_CONE_ABDUCTION_DEG);
                let c = rotate_toward(side, f, SHOULDER_CONE_FLEXION_DEG);
                swing_twist(d, &[f, up], Some(c), SHOULDER_SWING_DEG, SHOULDER_TWIST_DEG)
            }
            HandL | HandR => swing_twist(d, &[f, up], None, WRIST_SWING_DEG, WRIST_TWIST_DEG),
            FootL | FootR => {
                let (frame, _) = swing_twist(d, &[up, f], None, 0.0, [0.0; 2]);
                let c = frame * cone_centre([0.0, -ANKLE_CONE_PLANTAR_DEG]);
                swing_twist(d, &[up, f], Some(c), ANKLE_SWING_DEG, ANKLE_TWIST_DEG)
            }
            Spine => swing_twist(d, &[f, up], None, LUMBAR_SWING_DEG, LUMBAR_TWIST_DEG),
            Chest if parent_has(Spine) => {
                swing_twist(d, &[f, up], None, THORACIC_SWING_DEG, THORACIC_TWIST_DEG)
            }
            Chest => swing_twist(
                d,
                &[f, up],
                None,
                LUMBAR_SWING_DEG + THORACIC_SWING_DEG,
                add(LUMBAR_TWIST_DEG, THORACIC_TWIST_DEG),
            ),
            Neck => swing_twist(d, &[f, up], None, NECK_SWING_DEG, NECK_TWIST_DEG),
            Head if parent_has(Neck) => {
                swing_twist(d, &[f, up], None, HEAD_SWING_DEG, HEAD_TWIST_DEG)
            }
            Head => swing_twist(
                d,
                &[f, up],
                None,
                NECK_SWING_DEG + HEAD_SWING_DEG,
                add(NECK_TWIST_DEG, HEAD_TWIST_DEG),
            ),
            Pelvis | Chain => swing_twist(
                d,
                &[up, f, self.left],
                None,
                CHAIN_SWING_DEG,
                CHAIN_TWIST_DEG,
            ),
        }
    }

    /// A hinge turning the bone `d` toward `flex` for positive angles: X = d × flex. The
    /// limits are the anatomical range shifted by the flexion already present at rest
    /// (the angle from the parent bone `dp` to `d` about X), so a knee bent at rest still
    /// stops at straight and never bends backwards. A rest pose already slightly
    /// hyperextended (mocapbank's elbows, by 1.2°) keeps its rest as the lower limit: the
    /// ragdoll must not start outside its limits, and it bends no further back.
    fn hinge(
        &self,
        d: Vec3,
        dp: Vec3,
        flex: Vec3,
        alt: Vec3,
        range: [f32; 2],
    ) -> (Quat, JointKind) {
        let toward = perpendicular_part(flex, d)
            .or_else(|| perpendicular_part(alt, d))
            .unwrap_or_else(|| d.any_orthonormal_vector());
        let x = d.cross(toward).normalize();
        let frame = frame_from_x(x, d);
        let rest_deg = match perpendicular_part(dp, x) {
            Some(p) => x.dot(p.cross(d)).atan2(p.dot(d)).to_degrees(),
            None => 0.0,
        };
        let kind = JointKind::Hinge {
            min_deg: (range[0] - rest_deg).min(0.0),
            max_deg: range[1] - rest_deg,
        };
        (frame, kind)
    }
}

/// The roles a humanoid body hangs from, nearest first: where the hierarchy detaches a
/// deform bone from its anatomy (IK feet under the root, hands under a control bone), the
/// body still joins its anatomical neighbour, the foot the shin at the ankle, so the
/// character is one articulated body.
fn anatomical_parents(role: Role) -> &'static [Role] {
    use Role::*;
    match role {
        Spine => &[Pelvis],
        Chest => &[Spine, Pelvis],
        Neck => &[Chest, Spine, Pelvis],
        Head => &[Neck, Chest, Spine, Pelvis],
        ThighL | ThighR => &[Pelvis],
        ShinL => &[ThighL],
        ShinR => &[ThighR],
        FootL => &[ShinL],
        FootR => &[ShinR],
        UpperArmL | UpperArmR => &[Chest, Spine, Pelvis],
        ForearmL => &[UpperArmL],
        ForearmR => &[UpperArmR],
        HandL => &[ForearmL],
        HandR => &[ForearmR],
        Pelvis | Chain => &[],
    }
}

/// The body (by `body_of`) that joint `j`'s body hangs from by anatomy, for humanoids;
/// `None` leaves it to the hierarchy.
fn parent_body(roles: &Roles, j: usize, body_of: impl Fn(usize) -> Option<usize>) -> Option<usize> {
    if !roles.humanoid {
        return None;
    }
    let role = roles.per_joint.get(j).copied().flatten()?;
    anatomical_parents(role)
        .iter()
        .filter_map(|&r| roles.joint(r))
        .find_map(|k| body_of(k).filter(|_| k != j))
}

/// The bodies' joints reordered so each comes after the body it hangs from (a detached
/// IK foot comes before its shin in the file), otherwise in file order, root first.
fn parent_first(roles: &Roles, joints: Vec<usize>) -> Vec<usize> {
    let index = |j: usize| joints.iter().position(|&k| k == j);
    let mut out: Vec<usize> = Vec::with_capacity(joints.len());
    let mut placed = vec![false; joints.len()];
    for start in 0..joints.len() {
        // Walk up to the first unplaced ancestor body, then place downward.
        let mut stack = vec![start];
        while let Some(&b) = stack.last() {
            let up =
                parent_body(roles, joints[b], index).filter(|&p| !placed[p] && !stack.contains(&p));
            match up {
                Some(p) if b != 0 => stack.push(p),
                _ => {
                    stack.pop();
                    if !placed[b] {
                        placed[b] = true;
                        out.push(joints[b]);
                    }
                }
            }
        }
    }
    out
}

fn add(a: [f32; 2], b: [f32; 2]) -> [f32; 2] {
    [a[0] + b[0], a[1] + b[1]]
}

/// A swing-twist joint about the bone `d`: X = d, Y = the first hint not parallel to `d`
/// (the flexion direction), cone centred on `centre` (world) or on the rest direction,
/// widened if needed so the rest pose lies inside.
fn swing_twist(
    d: Vec3,
    hints: &[Vec3],
    centre: Option<Vec3>,
    swing_deg: f32,
    twist_deg: [f32; 2],
) -> (Quat, JointKind) {
    let y = hints
        .iter()
        .find_map(|h| perpendicular_part(*h, d))
        .unwrap_or_else(|| d.any_orthonormal_vector());
    let frame = frame_from_x(d, y);
    let (tilt, swing) = match centre {
        Some(c) => {
            let local = frame.conjugate() * c.normalize_or(d);
            // Inverse of `cone_centre`: Ry(ty)·Rz(tz)·X = (cy·cz, sz, −sy·cz).
            let tz = local.y.clamp(-1.0, 1.0).asin();
            let ty = (-local.z).atan2(local.x);
            let rest_off = local.angle_between(Vec3::X).to_degrees();
            (
                [ty.to_degrees(), tz.to_degrees()],
                swing_deg.max(rest_off + REST_MARGIN_DEG),
            )
        }
        None => ([0.0, 0.0], swing_deg),
    };
    // The tilted parent frame leaves the rest pose a small twist (the X part of the tilt's
    // inverse, as `twist_angle_x` measures it); centre the twist range on the rest.
    let tilt_q =
        Quat::from_rotation_y(tilt[0].to_radians()) * Quat::from_rotation_z(tilt[1].to_radians());
    let rest_twist = twist_angle_x(tilt_q.conjugate()).to_degrees();
    let kind = JointKind::SwingTwist {
        swing_deg: swing.min(180.0),
        twist_deg: [twist_deg[0] + rest_twist, twist_deg[1] + rest_twist],
        cone_tilt_deg: tilt,
    };
    (frame, kind)
}

/// `from` turned by `deg` toward `to` (both unit, `to` not parallel to `from`).
fn rotate_toward(from: Vec3, to: Vec3, deg: f32) -> Vec3 {
    let t = perpendicular_part(to, from).unwrap_or_else(|| from.any_orthonormal_vector());
    let a = deg.to_radians();
    (from * a.cos() + t * a.sin()).normalize()
}

/// The unit part of `v` perpendicular to unit `axis`, if `v` is not (nearly) parallel to it.
fn perpendicular_part(v: Vec3, axis: Vec3) -> Option<Vec3> {
    let v = v.normalize_or_zero();
    let p = v - axis * v.dot(axis);
    (p.length() >= PARALLEL_SIN).then(|| p.normalize())
}

fn quat_from_cols(x: Vec3, y: Vec3, z: Vec3) -> Quat {
    Quat::from_mat3(&Mat3::from_cols(x, y, z)).normalize()
}

fn centroid(points: &[Vec3]) -> Vec3 {
    points.iter().sum::<Vec3>() / points.len().max(1) as f32
}

/// The `q`-quantile (0..1) of `v`, nearest rank.
fn percentile(mut v: Vec<f32>, q: f32) -> f32 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f32::total_cmp);
    let i = (q.clamp(0.0, 1.0) * (v.len() - 1) as f32).round() as usize;
    v[i]
}

/// The segment a point cloud is stretched along: its principal axis (power iteration on
/// the covariance), from the 5th to the 95th percentile of the points along it.
fn principal_segment(points: &[Vec3]) -> (Vec3, Vec3) {
    let c = centroid(points);
    let mut cov = Mat3::ZERO;
    for p in points {
        let d = *p - c;
        cov += Mat3::from_cols(d * d.x, d * d.y, d * d.z);
    }
    let diag = Vec3::new(cov.x_axis.x, cov.y_axis.y, cov.z_axis.z);
    let mut axis = if diag.x >= diag.y && diag.x >= diag.z {
        Vec3::X
    } else if diag.y >= diag.z {
        Vec3::Y
    } else {
        Vec3::Z
    };
    for _ in 0..32 {
        axis = (cov * axis).normalize_or(axis);
    }
    let t: Vec<f32> = points.iter().map(|p| (*p - c).dot(axis)).collect();
    let lo = percentile(t.clone(), TRUNK_PERCENTILES[0]);
    let hi = percentile(t, TRUNK_PERCENTILES[1]);
    (c + axis * lo, c + axis * hi)
}

/// A capsule along `start → end`, shortened so its round ends stop at the joints; its
/// shape frame has Y along the bone and X toward the character's left where possible.
fn capsule_plan(
    joint: usize,
    role: Role,
    name: String,
    start: Vec3,
    end: Vec3,
    radius: f32,
    left: Vec3,
) -> Plan {
    let u = (end - start).normalize_or(Vec3::Y);
    let len = end.distance(start);
    let x = perpendicular_part(left, u)
        .or_else(|| perpendicular_part(Vec3::Z, u))
        .unwrap_or_else(|| u.any_orthonormal_vector());
    Plan {
        joint,
        role,
        name,
        start,
        end,
        shape: Shape::Capsule {
            radius_m: radius,
            length_m: (len - 2.0 * CAPSULE_END_INSET_RADII * radius).max(0.0),
        },
        centre: 0.5 * (start + end),
        rotation: quat_from_cols(x, u, x.cross(u)),
    }
}

/// Raises the lighter of any jointed pair until no pair's mass ratio exceeds `max_ratio`,
/// then rescales everything so the total is what it was (Strunk, GDC 2013; Jolt's
/// `RagdollSettings::Stabilize` does the same with a tighter ratio). Raising only ever
/// lifts a body toward a heavier neighbour, so the loop ends; rescaling keeps the ratios.
pub fn stabilize_masses(masses: &mut [f32], parents: &[usize], max_ratio: f32) {
    let total: f32 = masses.iter().sum();
    for _ in 0..masses.len().max(1) * 4 {
        let mut changed = false;
        for (c, &p) in parents.iter().enumerate() {
            if c == p {
                continue;
            }
            let (mc, mp) = (masses[c], masses[p]);
            if mc * max_ratio < mp * (1.0 - 1e-6) {
                masses[c] = mp / max_ratio;
                changed = true;
            } else if mp * max_ratio < mc * (1.0 - 1e-6) {
                masses[p] = mc / max_ratio;
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    let now: f32 = masses.iter().sum();
    if now > 0.0 {
        for m in masses.iter_mut() {
            *m *= total / now;
        }
    }
    keep_total(masses, total);
}

/// Puts the rounding residue of a float sum on the first (root, heaviest-ish) body so the
/// masses add up to `total` as closely as f32 allows.
fn keep_total(masses: &mut [f32], total: f32) {
    let now: f32 = masses.iter().sum();
    if let Some(first) = masses.first_mut() {
        *first += total - now;
    }
}

// --- Collision filtering ---------------------------------------------------------------

/// A body's solid as a capsule in world space: segment `a → b` swept by `r`. Boxes are
/// replaced by their bounding capsule (along the longest edge, radius the half diagonal of
/// the cross-section), which errs toward filtering a pair rather than starting in contact.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Solid {
    pub a: Vec3,
    pub b: Vec3,
    pub r: f32,
}

pub(crate) fn solid(shape: &Shape, centre: Vec3, rotation: Quat) -> Solid {
    match *shape {
        Shape::Capsule { radius_m, length_m } => {
            let half = rotation * Vec3::Y * (0.5 * length_m);
            Solid {
                a: centre - half,
                b: centre + half,
                r: radius_m,
            }
        }
        Shape::Box { size_m } => {
            let h = Vec3::from_array(size_m) * 0.5;
            let k = if h.x >= h.y && h.x >= h.z {
                0
            } else if h.y >= h.z {
                1
            } else {
                2
            };
            let axes = [Vec3::X, Vec3::Y, Vec3::Z];
            let half = rotation * axes[k] * h[k];
            let r = (h.length_squared() - h[k] * h[k]).sqrt();
            Solid {
                a: centre - half,
                b: centre + half,
                r,
            }
        }
    }
}

/// Jointed pairs, then every other pair whose solids come within [`COLLISION_MARGIN_M`] of
/// each other in the rest pose (what Jolt's `DisableParentChildCollisions` does with its
/// joint matrices).
fn collision_filter(plans: &[Plan], parents: &[usize], names: &[String]) -> Result<CollisionSpec> {
    let mut pairs: Vec<(usize, usize)> = (1..plans.len()).map(|c| (parents[c], c)).collect();
    let jointed: HashSet<(usize, usize)> =
        pairs.iter().map(|&(a, b)| (a.min(b), a.max(b))).collect();
    let solids: Vec<Solid> = plans
        .iter()
        .map(|p| solid(&p.shape, p.centre, p.rotation))
        .collect();
    for (i, j) in nearby_pairs(&solids, COLLISION_MARGIN_M)? {
        if jointed.contains(&(i, j)) {
            continue;
        }
        let (s, t) = (solids[i], solids[j]);
        if segment_distance(s.a, s.b, t.a, t.b) < s.r + t.r + COLLISION_MARGIN_M {
            pairs.push((i, j));
        }
    }
    if pairs.len() > MAX_DISABLED_PAIRS {
        return Err(too_many_pairs());
    }
    Ok(CollisionSpec {
        disabled_pairs: pairs
            .into_iter()
            .map(|(i, j)| [names[i].clone(), names[j].clone()])
            .collect(),
    })
}

/// Whether two shapes at these poses come within `margin` metres of each other (boxes are
/// taken as their bounding capsules, which errs on the side of "overlapping").
pub(crate) fn shapes_overlap(
    a: &crate::math::Transform,
    shape_a: &Shape,
    b: &crate::math::Transform,
    shape_b: &Shape,
    margin: f32,
) -> bool {
    let (s, t) = (
        solid(shape_a, a.translation, a.rotation),
        solid(shape_b, b.translation, b.rotation),
    );
    segment_distance(s.a, s.b, t.a, t.b) < s.r + t.r + margin
}

/// Distance between segments `p1 → q1` and `p2 → q2` (Ericson, Real-Time Collision
/// Detection, §5.1.9, with its degenerate-segment cases).
pub(crate) fn segment_distance(p1: Vec3, q1: Vec3, p2: Vec3, q2: Vec3) -> f32 {
    let (s, t) = crate::math::closest_segment_params(p1, q1, p2, q2);
    p1.lerp(q1, s).distance(p2.lerp(q2, t))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::skeleton::{Skeleton, humanoid};
    use crate::spec::roles::tests::{quadruped, yawed};

    fn build(c: &Character) -> RagdollSpec {
        build_spec(c, &BuildOptions::default()).unwrap()
    }

    fn body<'s>(spec: &'s RagdollSpec, name: &str) -> &'s BodySpec {
        &spec.bodies[spec
            .body_index(name)
            .unwrap_or_else(|| panic!("no body {name}"))]
    }

    fn joint<'s>(spec: &'s RagdollSpec, name: &str) -> &'s JointSpec {
        spec.joints.iter().find(|j| j.name == name).unwrap()
    }

    /// World rest transform (rotation, position) of the bone a body or joint refers to.
    fn bone(c: &Character, spec: &RagdollSpec, body_name: &str) -> (Quat, Vec3) {
        let b = body(spec, body_name);
        let w = c.skeleton.rest_world()[c.skeleton.find(&b.bone).unwrap()];
        (w.rotation, w.translation)
    }

    fn world_solid(c: &Character, spec: &RagdollSpec, b: &BodySpec) -> Solid {
        let (r, t) = bone(c, spec, &b.name);
        solid(
            &b.shape,
            t + r * Vec3::from_array(b.center_m),
            r * Quat::from_array(b.rotation),
        )
    }

    #[test]
    fn spec_build_filters_pairs_overlapping_in_the_first_frame() {
        // A first frame that swings the left arm across the chest (160° about the
        // forward axis, elbow straight): the forearm then lies on the chest and right arm,
        // which the rest pose never shows.
        let mut c = humanoid();
        let s = &c.skeleton;
        let mut frame: Vec<crate::math::Transform> = s.joints().iter().map(|j| j.rest).collect();
        let arm = s.find("upper_arm_l").unwrap();
        frame[arm].rotation = Quat::from_rotation_z(-160f32.to_radians());
        let rest_spec = build(&c);
        c.clips.push(crate::skeleton::Clip {
            name: "cross".into(),
            frame_time: 1.0 / 30.0,
            frames: vec![frame],
        });
        let spec = build(&c);
        let newly: Vec<&[String; 2]> = spec
            .collision
            .disabled_pairs
            .iter()
            .filter(|[a, b]| !rest_spec.collision.is_disabled(a, b))
            .collect();
        assert!(
            newly
                .iter()
                .any(|p| p.iter().any(|n| n == "forearm_l" || n == "hand_l")),
            "no pair of the crossed arm was filtered: {newly:?}"
        );
    }

    #[test]
    fn spec_build_humanoid_bodies_and_round_trip() {
        let c = humanoid();
        let spec = build(&c);
        spec.validate().unwrap();
        assert_eq!(spec.bodies.len(), 16);
        assert_eq!(spec.bodies[0].name, "pelvis");
        assert_eq!(spec.joints.len(), 15);
        for b in &spec.bodies {
            assert_eq!(b.bone, b.name, "built-in joints carry role names");
        }
        let text = spec.to_toml();
        let back = RagdollSpec::from_toml(&text, std::path::Path::new("x.toml")).unwrap();
        assert_eq!(back, spec);
    }

    #[test]
    fn spec_build_masses_keep_the_total() {
        let c = humanoid();
        for (total, female) in [
            (None, false),
            (None, true),
            (Some(60.0), true),
            (Some(110.0), false),
        ] {
            let spec = build_spec(
                &c,
                &BuildOptions {
                    total_mass_kg: total,
                    female,
                },
            )
            .unwrap();
            let want = total.unwrap_or(75.0);
            assert!(
                (spec.total_mass_kg() - want).abs() < 1e-3,
                "{} vs {want}",
                spec.total_mass_kg()
            );
            // Stabilised: no jointed pair beyond the ratio.
            for j in &spec.joints {
                let (a, b) = (
                    body(&spec, &j.parent).mass_kg,
                    body(&spec, &j.child).mass_kg,
                );
                assert!(
                    a.max(b) / a.min(b) <= MAX_LINKED_MASS_RATIO * 1.001,
                    "{} {a} {b}",
                    j.name
                );
            }
        }
        let spec = build(&c);
        // Anatomy survives stabilisation: thighs are the heaviest limb part, hands the lightest.
        assert!(body(&spec, "thigh_l").mass_kg > 9.0);
        assert!(body(&spec, "hand_r").mass_kg < 0.6);
        assert!(body(&spec, "head").mass_kg > 3.5);
        assert!(
            build_spec(
                &c,
                &BuildOptions {
                    total_mass_kg: Some(-1.0),
                    ..Default::default()
                }
            )
            .is_err()
        );
    }

    #[test]
    fn spec_build_missing_segments_give_their_mass_to_neighbours() {
        // Remove spine, neck and hands: pelvis→chest, chest→head, forearms end in tips.
        let c = humanoid();
        let keep = |n: &str| !matches!(n, "spine" | "neck" | "hand_l" | "hand_r");
        let old = c.skeleton.joints();
        let world = c.skeleton.rest_world();
        let mut joints = Vec::new();
        let mut map = vec![usize::MAX; old.len()];
        for (i, j) in old.iter().enumerate() {
            if !keep(&j.name) {
                continue;
            }
            let mut p = j.parent;
            while let Some(k) = p.filter(|&k| !keep(&old[k].name)) {
                p = old[k].parent;
            }
            let tip = if j.name.starts_with("forearm") {
                Some(Vec3::new(0.0, -0.26, 0.0))
            } else {
                j.tip
            };
            let parent_pos = p.map_or(Vec3::ZERO, |k| world[k].translation);
            map[i] = joints.len();
            joints.push(crate::skeleton::Joint {
                name: j.name.clone(),
                parent: p.map(|k| map[k]),
                rest: crate::math::Transform::from_translation(world[i].translation - parent_pos),
                tip,
            });
        }
        let mut c2 = c.clone();
        c2.skeleton = Skeleton::new(joints).unwrap();
        let spec = build(&c2);
        assert_eq!(
            spec.bodies.len(),
            13,
            "{:?}",
            spec.bodies.iter().map(|b| &b.name).collect::<Vec<_>>()
        );
        assert!((spec.total_mass_kg() - 75.0).abs() < 1e-3);
        assert!(body(&spec, "head").mass_kg > 4.5, "head carries the neck");
    }

    /// Rotates `p` about the axis `axis` through `pivot` by `deg`.
    fn turn(p: Vec3, pivot: Vec3, axis: Vec3, deg: f32) -> Vec3 {
        pivot + Quat::from_axis_angle(axis, deg.to_radians()) * (p - pivot)
    }

    /// World X axis of a joint's frame.
    fn joint_axis(c: &Character, spec: &RagdollSpec, name: &str) -> (Vec3, Vec3) {
        let (r, t) = bone(c, spec, name);
        let f = r * Quat::from_array(joint(spec, name).frame);
        (f * Vec3::X, t)
    }

    #[test]
    fn spec_build_knee_bends_backward_and_elbow_forward_for_any_facing() {
        for k in 0..8 {
            let yaw = (k as f32 * 45.0).to_radians();
            let c = yawed(&humanoid(), yaw);
            let fwd = Quat::from_rotation_y(yaw) * Vec3::Z;
            let spec = build(&c);
            let s = &c.skeleton;
            let w = s.rest_world();
            for side in ["l", "r"] {
                let (x, knee) = joint_axis(&c, &spec, &format!("shin_{side}"));
                let foot = w[s.find(&format!("foot_{side}")).unwrap()].translation;
                let bent = turn(foot, knee, x, 30.0);
                assert!(
                    (bent - foot).dot(fwd) < -0.05,
                    "yaw {k}: knee_{side} bends forward"
                );
                assert!((bent - knee).dot(fwd) < 0.0, "foot not behind the knee");
                let JointKind::Hinge { min_deg, max_deg } =
                    joint(&spec, &format!("shin_{side}")).kind
                else {
                    panic!("knee is a hinge")
                };
                assert!(
                    min_deg.abs() < 1e-3 && (max_deg - 140.0).abs() < 1e-3,
                    "{min_deg} {max_deg}"
                );

                let (x, elbow) = joint_axis(&c, &spec, &format!("forearm_{side}"));
                let hand = w[s.find(&format!("hand_{side}")).unwrap()].translation;
                let bent = turn(hand, elbow, x, 30.0);
                assert!(
                    (bent - hand).dot(fwd) > 0.05,
                    "yaw {k}: elbow_{side} bends backward"
                );
            }
        }
    }

    #[test]
    fn spec_build_hinge_limits_follow_a_flexed_rest_pose() {
        // Knees bent 20° at rest (shins tilted back): the range shifts to [-20, 120].
        let c = humanoid();
        let mut joints = c.skeleton.joints().to_vec();
        for j in joints.iter_mut().filter(|j| j.name.starts_with("foot")) {
            let len = j.rest.translation.length();
            let a = 20f32.to_radians();
            j.rest.translation = Vec3::new(0.0, -len * a.cos(), -len * a.sin());
        }
        let mut c2 = c.clone();
        c2.skeleton = Skeleton::new(joints).unwrap();
        let spec = build(&c2);
        let JointKind::Hinge { min_deg, max_deg } = joint(&spec, "shin_l").kind else {
            panic!()
        };
        assert!(
            (min_deg + 20.0).abs() < 0.01 && (max_deg - 120.0).abs() < 0.01,
            "{min_deg} {max_deg}"
        );
    }

    /// Direction of the cone centre of a swing-twist joint, world.
    fn cone(c: &Character, spec: &RagdollSpec, name: &str) -> (Vec3, f32) {
        let (r, _) = bone(c, spec, name);
        let j = joint(spec, name);
        let JointKind::SwingTwist {
            swing_deg,
            cone_tilt_deg,
            ..
        } = j.kind
        else {
            panic!("{name}")
        };
        (
            r * Quat::from_array(j.frame) * cone_centre(cone_tilt_deg),
            swing_deg,
        )
    }

    #[test]
    fn spec_build_hip_and_shoulder_cones_are_anatomical() {
        for k in [0, 3, 6] {
            let yaw = (k as f32 * 45.0).to_radians();
            let c = yawed(&humanoid(), yaw);
            let fwd = Quat::from_rotation_y(yaw) * Vec3::Z;
            let left = Vec3::Y.cross(fwd);
            let spec = build(&c);
            let angle = |a: Vec3, b: Vec3| a.angle_between(b).to_degrees();
            let (hip, swing) = cone(&c, &spec, "thigh_l");
            let leg = |flex: f32| rotate_toward(-Vec3::Y, fwd, flex);
            assert!(angle(hip, leg(110.0)) <= swing, "hip flexion 110 allowed");
            assert!(angle(hip, leg(0.0)) <= swing, "standing allowed");
            assert!(angle(hip, leg(-35.0)) > swing, "hip extension 35 refused");
            assert!(
                angle(hip, rotate_toward(-Vec3::Y, left, 45.0)) <= swing,
                "abduction 45 allowed"
            );
            for (side, out) in [("l", left), ("r", -left)] {
                let (sh, swing) = cone(&c, &spec, &format!("upper_arm_{side}"));
                assert!(angle(sh, -Vec3::Y) < swing - 20.0, "arms down inside");
                assert!(angle(sh, out) < swing - 20.0, "T-pose inside");
                assert!(angle(sh, fwd) <= swing, "arm forward inside");
                assert!(angle(sh, -out) > swing, "arm through the chest refused");
            }
        }
    }

    #[test]
    fn spec_build_shapes_are_sane_and_rest_pose_is_collision_free() {
        let c = humanoid();
        for female in [false, true] {
            let spec = build_spec(
                &c,
                &BuildOptions {
                    female,
                    ..Default::default()
                },
            )
            .unwrap();
            check_rest_pose(&c, &spec);
        }
        let q = quadruped();
        check_rest_pose(&q, &build(&q));
    }

    fn check_rest_pose(c: &Character, spec: &RagdollSpec) {
        for b in &spec.bodies {
            match b.shape {
                Shape::Capsule { radius_m, length_m } => {
                    assert!(radius_m > 0.0 && length_m >= 0.0, "{}", b.name)
                }
                Shape::Box { size_m } => assert!(size_m.iter().all(|s| *s > 0.0)),
            }
        }
        let filtered = |a: &str, b: &str| spec.collision.is_disabled(a, b);
        for j in &spec.joints {
            assert!(
                filtered(&j.parent, &j.child),
                "jointed pair {} collides",
                j.name
            );
        }
        // Brute force, independent of `segment_distance`: sample both segments densely.
        let n = 64;
        for (i, a) in spec.bodies.iter().enumerate() {
            for b in &spec.bodies[i + 1..] {
                if filtered(&a.name, &b.name) {
                    continue;
                }
                let (sa, sb) = (world_solid(c, spec, a), world_solid(c, spec, b));
                let mut best = f32::MAX;
                for u in 0..=n {
                    let p = sa.a.lerp(sa.b, u as f32 / n as f32);
                    for v in 0..=n {
                        best = best.min(p.distance(sb.a.lerp(sb.b, v as f32 / n as f32)));
                    }
                }
                assert!(
                    best >= sa.r + sb.r,
                    "{} and {} overlap at rest",
                    a.name,
                    b.name
                );
            }
        }
    }

    #[test]
    fn spec_build_body_frames_are_in_bone_space() {
        // The thigh capsule runs from the hip to the knee whatever the facing.
        for k in [0, 1, 5] {
            let c = yawed(&humanoid(), (k as f32 * 45.0).to_radians());
            let spec = build(&c);
            let s = world_solid(&c, &spec, body(&spec, "thigh_r"));
            let w = c.skeleton.rest_world();
            let hip = w[c.skeleton.find("thigh_r").unwrap()].translation;
            let knee = w[c.skeleton.find("shin_r").unwrap()].translation;
            assert!(
                (s.a.distance(knee) - s.r).abs() < 1e-3 || (s.b.distance(knee) - s.r).abs() < 1e-3
            );
            assert!(
                (s.a.distance(hip) - s.r).abs() < 1e-3 || (s.b.distance(hip) - s.r).abs() < 1e-3
            );
        }
    }

    #[test]
    fn spec_build_non_humanoids_are_chains_weighed_by_volume() {
        let q = quadruped();
        let spec = build(&q);
        assert!(spec.bodies.iter().all(|b| b.role == Some(Role::Chain)));
        assert_eq!(spec.bodies[0].name, "hip");
        assert_eq!(spec.joints.len(), spec.bodies.len() - 1);
        let volume: f32 = spec.bodies.iter().map(|b| b.shape.volume()).sum();
        assert!(
            (spec.total_mass_kg() - volume * BODY_DENSITY_KG_M3).abs()
                < 1e-3 * spec.total_mass_kg()
        );
        for j in &spec.joints {
            let JointKind::SwingTwist {
                swing_deg,
                twist_deg,
                ..
            } = j.kind
            else {
                panic!()
            };
            assert_eq!((swing_deg, twist_deg), (CHAIN_SWING_DEG, CHAIN_TWIST_DEG));
        }
        let spec = build_spec(
            &q,
            &BuildOptions {
                total_mass_kg: Some(30.0),
                ..Default::default()
            },
        )
        .unwrap();
        assert!((spec.total_mass_kg() - 30.0).abs() < 1e-3);
        assert_eq!(
            RagdollSpec::from_toml(&spec.to_toml(), std::path::Path::new("q")).unwrap(),
            spec
        );
    }

    #[test]
    fn spec_build_stabilize_keeps_total_and_bounds_ratios() {
        let mut m = vec![10.0, 0.1, 0.5, 40.0];
        let parents = [0, 0, 1, 0];
        stabilize_masses(&mut m, &parents, 5.0);
        assert!((m.iter().sum::<f32>() - 50.6).abs() < 1e-4);
        for c in 1..4 {
            let (a, b) = (m[c], m[parents[c]]);
            assert!(a.max(b) / a.min(b) <= 5.0 * 1.0001, "{m:?}");
        }
    }

    #[test]
    fn spec_build_nearby_pairs_holds_every_touching_pair_in_loop_order() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f32 / (1u64 << 53) as f32
        };
        for round in 0..20 {
            // Clusters, long thin solids, huge ones spanning many cells, points.
            let spread = [0.5, 3.0, 30.0][round % 3];
            let solids: Vec<Solid> = (0..300)
                .map(|k| {
                    let a = Vec3::new(next(), next(), next()) * spread;
                    let long = if k % 17 == 0 { 20.0 } else { 0.3 };
                    let b = a + (Vec3::new(next(), next(), next()) - 0.5) * long;
                    let r = if k % 5 == 0 { 0.0 } else { next() * 0.2 };
                    Solid { a, b, r }
                })
                .collect();
            let got = nearby_pairs(&solids, COLLISION_MARGIN_M).unwrap();
            assert!(got.windows(2).all(|w| w[0] < w[1]), "sorted and unique");
            for i in 0..solids.len() {
                for j in i + 1..solids.len() {
                    let (s, t) = (solids[i], solids[j]);
                    if segment_distance(s.a, s.b, t.a, t.b) < s.r + t.r + COLLISION_MARGIN_M {
                        assert!(got.binary_search(&(i, j)).is_ok(), "round {round}: {i} {j}");
                    }
                }
            }
        }
    }

    #[test]
    fn spec_build_segment_distance_cases() {
        let d = segment_distance(
            Vec3::ZERO,
            Vec3::X,
            Vec3::new(0.5, 1.0, -1.0),
            Vec3::new(0.5, 1.0, 1.0),
        );
        assert!((d - 1.0).abs() < 1e-6);
        let d = segment_distance(
            Vec3::ZERO,
            Vec3::ZERO,
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(3.0, 0.0, 0.0),
        );
        assert!((d - 2.0).abs() < 1e-6);
        let d = segment_distance(
            Vec3::ZERO,
            Vec3::X,
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(3.0, 0.0, 0.0),
        );
        assert!((d - 1.0).abs() < 1e-6);
    }

    #[test]
    fn spec_build_cone_centre_convention() {
        assert!((cone_centre([0.0, 90.0]) - Vec3::Y).length() < 1e-6);
        assert!((cone_centre([90.0, 0.0]) + Vec3::Z).length() < 1e-6);
        // About Y, then about the turned Z: the world's `frame · Ry · Rz`.
        let c = cone_centre([90.0, 45.0]);
        let want = Quat::from_rotation_y(90f32.to_radians()) * Vec3::new(1.0, 1.0, 0.0).normalize();
        assert!((c - want).length() < 1e-6, "{c:?}");
        for tilt in [[18.7, 21.2], [-30.0, 50.0], [0.0, -15.0]] {
            let (frame, kind) =
                swing_twist(Vec3::X, &[Vec3::Y], Some(cone_centre(tilt)), 90.0, [0.0; 2]);
            assert!(frame.angle_between(Quat::IDENTITY) < 1e-5);
            let JointKind::SwingTwist { cone_tilt_deg, .. } = kind else {
                panic!()
            };
            assert!(
                (cone_tilt_deg[0] - tilt[0]).abs() < 1e-3
                    && (cone_tilt_deg[1] - tilt[1]).abs() < 1e-3
            );
        }
    }
}
