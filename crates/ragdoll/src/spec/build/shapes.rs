//! Body shapes: each body fitted to the skin it carries (capsules along limbs, boxes for
//! the trunk), or sized from body proportions where there is no skin.

use glam::Vec3;

use super::fit::{centroid, hang_dir, percentile, principal_segment, quat_from_cols};
use super::joints::perpendicular_part;
use super::{Builder, Plan};
use crate::spec::anthropometry::*;
use crate::spec::{Role, Shape};

/// Share of the skin a body's shape holds across the bone (a capsule's radius, a box's
/// width and depth, from each side): all of it, since a vertex outside the shape sinks into
/// the floor when the body lies on that side. Measured on the data files' 3 s drops, 0.98
/// still left a knight's tabard 7 % of its height outside its pelvis, and 0.65 sank a
/// robot's head 18 % into the floor; strays (a neighbour's vertices weighted here) are
/// bounded by [`RADIUS_RANGE`] instead. Bodies then overlap their neighbours at rest; those
/// pairs never collide (`collision.rs`).
const RADIUS_PERCENTILE: f32 = 1.0;
/// Share of the skin a creature's body shape holds across the bone: the skin a body
/// carries that its shape does not hold gets extra shapes of its own (`extras.rs`), so
/// the shape need not reach the farthest of it. One shape per body fitted to all of it
/// encloses air where the skin curves away (a ball round a dragon's haunch and tail
/// root): the 1,700-triangle Stanford dragon rested 5-7 % of its height above the floor
/// on the `fast` backend. Measured with the extra shapes on both Stanford dragons, 3 s
/// drops on `rigid` and `fast`, rigged with 10 and 12 joints at their own size and with
/// 12 at 2 m tall (12 runs): at 0.75 every lowest vertex within 2.1 % of the floor, every
/// rest within 1.7 % of it, the 99th-percentile stretch at most 1.44; at 0.8 and 0.9 two
/// and three of the runs rested more than 3 % above the floor (up to 5.2 %), at 1.0 six
/// (up to 6.2 %); at 0.7 a dragon sank 4.8 %. Rigged with 14 joints (bones shorter than the skin is thick) every
/// value sinks a dragon past 4 % or stretches it past 1.6 somewhere.
const CREATURE_RADIUS_PERCENTILE: f32 = 0.75;
/// Percentile of the skin's reach along a leaf bone (head, hand, foot) taken as its end.
const REACH_PERCENTILE: f32 = 0.95;
/// A skinned body is a box rather than a capsule when the box holding its skin has less
/// than this share of the capsule's volume: when the skin is flat (a hand, a foot, a
/// strip), about a third as thick as wide or flatter. A round limb's box is never smaller
/// than its capsule, so limbs stay capsules.
const BOX_PREFERENCE: f32 = 0.5;
/// A cross-section this much thinner than it is wide, or more, is flat (a hand, a strip).
const FLAT_SHARE: f32 = 1.0 / 3.0;
/// Fewest skin vertices a measurement is made from; below, proportions are used.
pub(super) const MIN_FIT_VERTICES: usize = 8;
/// Fewest skin vertices a box is fitted to, holding every one of them, when there are
/// too few to measure (a low-polygon strip or plate: Khronos' SimpleSkin is ten vertices
/// in a flat strip beside its bones; the capsule holding them was a metre wide and
/// rested the strip a quarter of its height off the floor). Four points span a solid.
pub(super) const MIN_BOX_VERTICES: usize = 4;
/// Radii removed from each end of a capsule fitted without skin (or whose skin does not
/// reach the joints): its round ends then stop at the joints, so neighbours meet instead of
/// overlapping (jointed pairs do not collide anyway).
pub(super) const CAPSULE_END_INSET_RADII: f32 = 1.0;
/// Measured radii are kept within these fractions of H (humanoids) or of the skeleton's
/// extent (other creatures): at most half, so a body may be a ball as big as the character
/// (VRM's sample avatar is a 1 m sphere on a 1 m skeleton), but a bad skin cannot make a
/// limb bigger than the whole.
pub(super) const RADIUS_RANGE: [f32; 2] = [0.004, 0.5];
/// A measured trunk width or depth is at least this multiple of the proportional one (a
/// trunk whose skin is mostly carried by other bodies still gets a real body)...
const MIN_TRUNK_FIT: f32 = 0.5;
/// ...and at most this fraction of H: a trunk may be as wide as the character is tall (a
/// round mascot), no wider.
const MAX_TRUNK_SIZE_H: f32 = 1.0;
/// A trunk segment is at least this tall (fraction of H), so a pelvis joint sitting right
/// under the chest still gets a real body.
const MIN_TRUNK_HEIGHT_H: f32 = 0.04;
/// Chest length when nothing lies above it (no neck, no head joint).
const CHEST_LENGTH_H: f32 = 0.15;
/// Radius of a non-humanoid link without skin to measure, as a fraction of its length (a tapering
/// tail or leg is about a fifth as thick as long)...
const CHAIN_RADIUS_OF_LENGTH: f32 = 0.15;
/// ...but at least this fraction of the skeleton's extent, so stubby links stay solid.
const CHAIN_MIN_RADIUS_EXTENT: f32 = 0.01;
/// Shoulder to fingertip and hip to sole, for an arm or leg of one part without skin to
/// measure.
const WHOLE_ARM_LENGTH_H: f32 = 0.44;
const WHOLE_LEG_LENGTH_H: f32 = 0.48;
/// Length of a link whose bone has none (all joints in one place): fraction of extent.
const DEGENERATE_LENGTH_EXTENT: f32 = 0.05;

impl Builder<'_> {
    pub(super) fn plan(&self, b: usize) -> Plan {
        let q = self.radius_percentile(b);
        let j = self.joints[b];
        let role = self.roles.per_joint[j].unwrap_or(Role::Chain);
        let name = if self.roles.humanoid {
            role.as_str().to_string()
        } else {
            self.rig.skeleton.joint_label(j)
        };
        let group = &self.groups[b];
        use Role::*;
        match role {
            Pelvis | Spine | Chest => {
                let next = match role {
                    Pelvis => self.role_pos(Spine).or(self.role_pos(Chest)),
                    Spine => self.role_pos(Chest),
                    _ => self.role_pos(Neck).or(self.role_pos(Head)),
                };
                let end = next.unwrap_or(self.pos(j) + Vec3::Y * CHEST_LENGTH_H * self.h);
                self.trunk_plan(j, role, name, end, group)
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
                let r = FOOT_RADIUS_H * self.h;
                self.capsule_plan(j, (role, name), heel, toe, r, group, q)
            }
            Chain => self.chain_plan(j, name, group, q),
            _ => {
                let start = self.pos(j);
                let (end, radius_h) = self.limb_end(j, role, group);
                self.capsule_plan(j, (role, name), start, end, radius_h * self.h, group, q)
            }
        }
    }

    fn role_pos(&self, role: Role) -> Option<Vec3> {
        self.role_joint(role).map(|k| self.pos(k))
    }

    /// Where a limb's (or the head's) bone ends, and its radius as a fraction of H when
    /// there is no skin to measure.
    fn limb_end(&self, j: usize, role: Role, group: &[Vec3]) -> (Vec3, f32) {
        let start = self.pos(j);
        let h = self.h;
        let rj = |r: Role| self.role_pos(r);
        let from = |a: Option<Vec3>, or: Vec3| a.map_or(or, |a| (start - a).normalize_or(or));
        use Role::*;
        match role {
            Neck => (
                rj(Head).unwrap_or(start + Vec3::Y * NECK_RADIUS_H * h),
                NECK_RADIUS_H,
            ),
            Head => {
                let dir = from(rj(Neck).or(rj(Chest)), Vec3::Y);
                let end = self.extremity(j, group, dir, HEAD_LENGTH_H * h, false);
                (end, HEAD_RADIUS_H)
            }
            UpperArmL | UpperArmR => {
                let fore = if role == UpperArmL {
                    ForearmL
                } else {
                    ForearmR
                };
                // An arm of one part ends where its skin does, the way it hangs.
                let end = rj(fore).unwrap_or_else(|| {
                    self.extremity(
                        j,
                        group,
                        hang_dir(start, group),
                        WHOLE_ARM_LENGTH_H * h,
                        true,
                    )
                });
                (end, UPPER_ARM_RADIUS_H)
            }
            ForearmL | ForearmR => {
                let (upper, hand) = if role == ForearmL {
                    (UpperArmL, HandL)
                } else {
                    (UpperArmR, HandR)
                };
                let end = rj(hand).unwrap_or_else(|| {
                    let dir = from(rj(upper), -Vec3::Y);
                    self.extremity(j, group, dir, HAND_LENGTH_H * h, true)
                });
                (end, FOREARM_RADIUS_H)
            }
            HandL | HandR => {
                let fore = if role == HandL { ForearmL } else { ForearmR };
                let dir = from(rj(fore), -Vec3::Y);
                let end = self.extremity(j, group, dir, HAND_LENGTH_H * h, true);
                (end, HAND_RADIUS_H)
            }
            ThighL | ThighR => {
                let shin = if role == ThighL { ShinL } else { ShinR };
                let end = rj(shin).unwrap_or_else(|| {
                    self.extremity(
                        j,
                        group,
                        hang_dir(start, group),
                        WHOLE_LEG_LENGTH_H * h,
                        true,
                    )
                });
                (end, THIGH_RADIUS_H)
            }
            ShinL | ShinR => {
                let foot = if role == ShinL { FootL } else { FootR };
                let end = rj(foot).unwrap_or_else(|| {
                    self.extremity(j, group, self.foot_dir(), FOOT_LENGTH_H * h, true)
                });
                (end, SHIN_RADIUS_H)
            }
            _ => (
                self.extremity(j, group, self.foot_dir(), FOOT_LENGTH_H * h, true),
                FOOT_RADIUS_H,
            ),
        }
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

    /// A body around the bone `start → end`. With skin it holds the skin: a capsule whose
    /// radius is that of nearly all the skin around the bone and whose ends reach as far
    /// as the skin goes past the joints (a head's crown, a foot's heel, the fingers on a
    /// hand), so a body lying on the floor holds the mesh it carries above it; or a box,
    /// when the skin is flat enough (a hand, a foot, a strip) that a box holding it is
    /// much smaller than that capsule, which would float the mesh off the floor. Without
    /// skin it is a capsule of `default_radius` whose round ends stop at the joints, so
    /// neighbours meet instead of overlapping (jointed pairs do not collide anyway).
    /// `q`: the share of the skin it holds across the bone ([`RADIUS_PERCENTILE`]).
    #[allow(clippy::too_many_arguments)]
    fn capsule_plan(
        &self,
        j: usize,
        (role, name): (Role, String),
        start: Vec3,
        end: Vec3,
        default_radius: f32,
        group: &[Vec3],
        q: f32,
    ) -> Plan {
        let u = (end - start).normalize_or(Vec3::Y);
        let len = end.distance(start);
        // (length, offset of its centre from the bone's middle, along the bone)
        let (radius, length, offset) = match self.fit_capsule(start, end, default_radius, group, q)
        {
            Some((r, s0, s1)) => (r, s1 - s0, 0.5 * (s0 + s1 - len)),
            None => {
                let inset = CAPSULE_END_INSET_RADII * default_radius;
                (default_radius, (len - 2.0 * inset).max(0.0), 0.0)
            }
        };
        let x = perpendicular_part(self.left, u)
            .or_else(|| perpendicular_part(Vec3::Z, u))
            .unwrap_or_else(|| u.any_orthonormal_vector());
        let capsule = Shape::Capsule {
            radius_m: radius,
            length_m: length,
        };
        // Too few vertices to measure, a box holding them is a measurement only where they
        // lie farther from the bone than the proportional radius (the skin, not the
        // proportions, then sized the capsule) in a flat spread at least as wide as the
        // proportional limb: a strip or a plate beside its bone, which a capsule round it
        // would hold inside a ball of air. Bunched, they made boxes a centimetre wide (the
        // VRM sample's forearms; the Fox's upper legs, on which the particle engine blew
        // the Fox apart); round, tighter boxes than their capsules (the 1,700-triangle
        // Stanford dragon's head), on which the dragon rested 2.7 % of its height up on
        // `fast` where it rests 0.5 % on its capsules.
        let proportional =
            default_radius.clamp(RADIUS_RANGE[0] * self.size(), RADIUS_RANGE[1] * self.size());
        let enough = group.len() >= MIN_FIT_VERTICES;
        let fitted = (enough || radius > proportional)
            .then(|| self.fit_box(start, u, x, group, q))
            .flatten()
            .filter(|(b, ..)| match *b {
                Shape::Box { size_m: [w, _, d] } => {
                    let (wide, thin) = (w.max(d), w.min(d));
                    enough || (wide >= 2.0 * proportional && thin <= FLAT_SHARE * wide)
                }
                Shape::Capsule { .. } => enough,
            });
        let (shape, centre, rotation) = match fitted {
            Some((b, centre, rotation)) if b.volume() < BOX_PREFERENCE * capsule.volume() => {
                (b, centre, rotation)
            }
            _ => (
                capsule,
                0.5 * (start + end) + u * offset,
                quat_from_cols(x, u, x.cross(u)),
            ),
        };
        Plan {
            joint: j,
            role,
            name,
            start,
            end,
            shape,
            centre,
            rotation,
        }
    }

    /// Share of its skin body `b`'s own shape holds across the bone: all of it for a
    /// humanoid ([`RADIUS_PERCENTILE`]) and for a body whose skin moves with it alone,
    /// [`CREATURE_RADIUS_PERCENTILE`] for a creature's body whose skin blends into its
    /// neighbours', whose extra shapes hold the rest (`extras.rs`). Skin that moves with
    /// its body alone stays where its shape holds it, so a shape round all of it holds
    /// no air as the joints bend; held three quarters by its shape, the WebXR hand (one
    /// bone carrying the whole hand) sank 5.8 % of its height into the floor.
    fn radius_percentile(&self, b: usize) -> f32 {
        if self.roles.humanoid || self.rigid_skin[b] {
            RADIUS_PERCENTILE
        } else {
            CREATURE_RADIUS_PERCENTILE
        }
    }

    /// What a body's thickness scales with: a humanoid's height; a creature's (a long, low
    /// fox) overall size.
    pub(super) fn size(&self) -> f32 {
        if self.roles.humanoid {
            self.h
        } else {
            self.rig.extent
        }
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
        if !group.is_empty() {
            let measured = group.len() >= MIN_FIT_VERTICES;
            let span = |axis: Vec3| {
                let v: Vec<f32> = group.iter().map(|p| (*p - a).dot(axis)).collect();
                let lo = percentile(v.clone(), 1.0 - RADIUS_PERCENTILE);
                (lo, percentile(v, RADIUS_PERCENTILE))
            };
            // Too few vertices to measure the trunk (its skin carried by its neighbours):
            // the proportional box, grown to hold them.
            let fit = |(lo, hi): (f32, f32), proportional: f32| {
                let (lo, hi) = if measured {
                    (lo, hi)
                } else {
                    (lo.min(-0.5 * proportional), hi.max(0.5 * proportional))
                };
                let size = (hi - lo).clamp(MIN_TRUNK_FIT * proportional, MAX_TRUNK_SIZE_H * h);
                (size, 0.5 * (hi + lo))
            };
            (width, cx) = fit(span(x), w0);
            (depth, cz) = fit(span(z), d0);
            // Along the spine the box reaches all its skin, as a capsule's ends do: the
            // pelvis's skin reaches below the hips, the chest's up over the shoulders.
            let along = group.iter().map(|p| (*p - a).dot(u));
            y0 = along.clone().fold(y0, f32::min);
            y1 = along.fold(y1, f32::max);
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

    /// A non-humanoid link: a body along its bone, or along its skin when the bone has no
    /// length (every joint in one place, as in SimpleSkin's rest pose), holding its skin as
    /// a humanoid's limbs do ([`Builder::capsule_plan`]): a creature lying on its side rests
    /// on the shape around the skin it carries, so the skin neither sinks into the floor
    /// nor floats above it.
    fn chain_plan(&self, j: usize, name: String, group: &[Vec3], q: f32) -> Plan {
        let rig = self.rig;
        let a = rig.pos[j];
        let tiny = 1e-4 * rig.extent;
        let enough_skin = group.len() >= MIN_FIT_VERTICES;
        let mut end = rig.chain_bone_end(j);
        let bare = rig.children[j].is_empty() && rig.tips[j].is_none();
        if bare && !self.attached[j].is_empty() {
            // A leg whose foot an IK rig detached ends where that foot starts.
            let feet = &self.attached[j];
            end = Some(feet.iter().map(|&k| rig.pos[k]).sum::<Vec3>() / feet.len() as f32);
        } else if bare && enough_skin {
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
        let mut radius = (CHAIN_RADIUS_OF_LENGTH * len).max(CHAIN_MIN_RADIUS_EXTENT * rig.extent);
        if !enough_skin {
            radius = radius.max(self.hub_radius(j, start, end));
        }
        self.capsule_plan(j, (Role::Chain, name), start, end, radius, group, q)
    }

    /// How thick a body without skin must be to reach around to the roots of the limbs it
    /// carries, when it carries more than one: the farthest of its children's joints from
    /// its bone's line (at most [`RADIUS_RANGE`]'s share of the extent). A spider's thorax
    /// drawn around the bone to its head alone was a pencil 3 cm thick with eight legs
    /// attached around it, too little inertia to hold them: rapier and `fast` blew it
    /// apart on landing.
    fn hub_radius(&self, j: usize, start: Vec3, end: Vec3) -> f32 {
        let rig = self.rig;
        // A child carries a body when it owns itself (a constant-time test: this runs for
        // every body, and skeletons reach 65,536 joints).
        let carried: Vec<Vec3> = rig.children[j]
            .iter()
            .filter(|&&c| self.joints[self.owner[c]] == c)
            .map(|&c| rig.pos[c])
            .collect();
        if carried.len() < 2 {
            return 0.0;
        }
        let u = (end - start).normalize_or_zero();
        let reach = carried
            .iter()
            .map(|&p| {
                let d = p - start;
                (d - u * d.dot(u)).length()
            })
            .fold(0.0, f32::max);
        reach.min(RADIUS_RANGE[1] * rig.extent)
    }
}
