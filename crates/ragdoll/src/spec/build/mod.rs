//! Skeleton + roles → [`RagdollSpec`]: one body per joint with a role, shaped
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
//!   [`cone_centre`](joints::cone_centre) computes it.

mod attach;
mod collision;
mod extras;
mod fit;
mod joints;
mod masses;
mod order;
mod shapes;
#[cfg(test)]
mod tests;
mod volume;

use std::collections::HashSet;

use glam::{Quat, Vec3};

use super::roles::{Rig, Roles};
use super::{BodySpec, ExtraShape, JointSpec, RagdollSpec, Role, SPEC_FORMAT_VERSION, Shape};
use crate::error::{Error, Result};
use crate::skeleton::Character;

pub(crate) use collision::shapes_overlap;
use collision::{collision_filter, filter_start_overlaps};
pub(super) use extras::shape_holds;
use order::{parent_body, parent_first};

/// Options for [`build_spec`]; the default builds a male humanoid weighed by its height
/// (75 kg at 1.75 m, see [`super::humanoid_mass_kg`]), or a creature weighed by its volume.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BuildOptions {
    /// Total mass, kg. `None`: [`super::humanoid_mass_kg`] of its standing height for a
    /// humanoid (75 kg at 1.75 m), volume × 1000 kg/m³ for
    /// anything else (so a creature's mass follows its size): the volume its skin encloses
    /// where the skin is closed, else its bodies' shapes'.
    pub total_mass_kg: Option<f32>,
    /// Use de Leva's female segment fractions (more mass in the hips and legs) instead of
    /// the male ones.
    pub female: bool,
}

/// A vertex belongs to the body whose joints hold at least this share of its weight.
const MIN_GROUP_WEIGHT: f32 = 0.5;
/// A creature's body whose skin moves with it alone, nearly all of it this share of its
/// weight or more, holds all of it in its own shape (see `CREATURE_RADIUS_PERCENTILE`).
const RIGID_SKIN_WEIGHT: f32 = 0.95;

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
    // A character lying in its file is built stood up, as its roles were found; the spec
    // is in its bones' frames, so it fits the character as the file has it.
    let turned = roles.upright.map(|q| character.rotated_start(q));
    let upright = turned.as_ref().unwrap_or(character);
    let rig = Rig::new(upright);
    let b = Builder::new(&rig, &roles, opts);
    let mut spec = b.spec(upright)?;
    // The ragdoll starts in the first animation frame; limits give way where that pose
    // lies outside them (see `fit_limits_to_pose`).
    let start = super::start_pose(character, true);
    super::fit_limits_to_pose(&mut spec, character, &start, START_POSE_MARGIN_DEG)?;
    filter_start_overlaps(&mut spec, character, &start)?;
    spec.validate()?;
    Ok(spec)
}

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
    /// Whether most of each body's skin moves with it alone ([`RIGID_SKIN_WEIGHT`]).
    rigid_skin: Vec<bool>,
    /// For each skeleton joint, the joint whose body a detached bone's body joins.
    attach: Vec<Option<usize>>,
    /// For each skeleton joint, the detached bones that join it (`attach` turned round):
    /// a leg whose hoof an IK rig parents to the root still reaches the ground.
    attached: Vec<Vec<usize>>,
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
        let attach = attach::detached_parents(rig, roles, &joints);
        let joints = parent_first(roles, &attach, joints);
        let mut attached = vec![Vec::new(); n];
        for (j, a) in attach.iter().enumerate() {
            if let Some(a) = *a {
                attached[a].push(j);
            }
        }
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
        let mut b = Builder {
            rig,
            roles,
            opts,
            // The height roles were measured at: a BVH whose rest pose lies flat (Rokoko) is
            // measured standing, in its first frame.
            h: roles.height_m,
            forward: roles.forward,
            left: roles.left(),
            groups: vec![Vec::new(); joints.len()],
            rigid_skin: vec![false; joints.len()],
            joints,
            owner,
            attach,
            attached,
        };
        let mut rigid = vec![0usize; b.groups.len()];
        for (p, js, ws) in &rig.verts {
            let best = b
                .shares(js, ws)
                .into_iter()
                .max_by(|a, c| a.1.total_cmp(&c.1));
            if let Some((o, w)) = best
                && w >= MIN_GROUP_WEIGHT
            {
                b.groups[o].push(*p);
                rigid[o] += usize::from(w >= RIGID_SKIN_WEIGHT);
            }
        }
        for (k, g) in b.groups.iter().enumerate() {
            b.rigid_skin[k] = 2 * rigid[k] >= g.len().max(1);
        }
        b
    }

    fn spec(&self, character: &Character) -> Result<RagdollSpec> {
        let plans: Vec<Plan> = (0..self.joints.len()).map(|b| self.plan(b)).collect();
        let parents: Vec<usize> = (0..plans.len())
            .map(|b| match b {
                0 => 0,
                _ => parent_body(self.roles, &self.attach, plans[b].joint, |j| {
                    self.joints.iter().position(|&k| k == j)
                })
                .unwrap_or_else(|| self.rig.parent(plans[b].joint).map_or(0, |p| self.owner[p])),
            })
            .collect();
        let enclosed = volume::enclosed_volume_m3(&character.meshes);
        let extras = self.extras(&plans);
        let standing = character.height_along(Vec3::Y);
        let masses = self.masses(&plans, &extras, &parents, enclosed, standing);

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
            .zip(&extras)
            .map(|(((p, &mass_kg), name), extras)| {
                let bone = self.rig.world[p.joint];
                let inv = bone.rotation.conjugate();
                let place = |centre: Vec3, rotation: Quat| {
                    (
                        (inv * (centre - bone.translation)).to_array(),
                        (inv * rotation).normalize().to_array(),
                    )
                };
                let (center_m, rotation) = place(p.centre, p.rotation);
                BodySpec {
                    name: name.clone(),
                    bone: self.rig.skeleton.joint_label(p.joint),
                    role: Some(p.role),
                    shape: p.shape,
                    center_m,
                    rotation,
                    mass_kg,
                    extra_shapes: extras
                        .iter()
                        .map(|e| {
                            let (center_m, rotation) = place(e.centre, e.rotation);
                            ExtraShape {
                                shape: e.shape,
                                center_m,
                                rotation,
                            }
                        })
                        .collect(),
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
}
