//! Body shapes: each body fitted to the skin it carries (capsules along limbs, boxes for
//! the trunk), or sized from body proportions where there is no skin.

use glam::{Mat3, Quat, Vec3};

use super::joints::perpendicular_part;
use super::{Builder, Plan};
use crate::spec::anthropometry::*;
use crate::spec::{Role, Shape};

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

impl Builder<'_> {
    pub(super) fn plan(&self, b: usize) -> Plan {
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
