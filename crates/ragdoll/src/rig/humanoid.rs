//! A humanoid skeleton for an unrigged figure standing in a T- or A-pose
//! ([`super::RigOptions::humanoid`]): the joints a person has, placed by the mesh where it
//! shows them (each foot,
//! knee and thigh from the skin around that height on its side, each hand at the farthest
//! point of its arm) and by body proportions where it does not (joint heights as fractions
//! of the standing height H, after Drillis & Contini and de Leva; the shoulder joints a
//! tenth of H either side of the spine). As Mixamo's auto-rigger does, it needs the arms
//! held away from the body and the feet on the floor; a figure it cannot read that way is
//! refused with the reason.

use glam::Vec3;

use super::setting;
use super::skeleton::bone_frame;
use crate::error::Result;
use crate::math::Transform;
use crate::skeleton::{Joint, Skeleton, SkinnedMesh};

/// Heights above the floor, as fractions of H: the hip joints (greater trochanter ~0.52),
/// knees, ankles, the pelvis joint, the lumbar spine, the chest, the neck's base and the
/// base of the skull.
const HIP_H: f32 = 0.51;
const KNEE_H: f32 = 0.285;
const ANKLE_H: f32 = 0.04;
const PELVIS_H: f32 = 0.53;
const SPINE_H: f32 = 0.62;
const CHEST_H: f32 = 0.72;
const NECK_H: f32 = 0.83;
const HEAD_H: f32 = 0.87;
const SHOULDER_H: f32 = 0.81;
/// Where the lower leg is read for the ankle's place: above the foot.
const LOW_SHANK_H: f32 = 0.1;
/// Shoulder joints' distance from the spine, as a fraction of H (biacromial breadth is
/// about 0.23 H; the joint centres sit inside it).
const SHOULDER_OUT_H: f32 = 0.1;
/// Where the elbow and the wrist lie from the shoulder to the fingertip (upper arm 0.186,
/// forearm 0.146 and hand 0.108 of H: de Leva's segment lengths).
const ELBOW_AT: f32 = 0.186 / 0.44;
const WRIST_AT: f32 = (0.186 + 0.146) / 0.44;
/// Half the height of the bands the skin is read in, as a fraction of H.
const BAND_H: f32 = 0.02;
/// Least reach of an arm from shoulder to fingertip, and least sideways part of its
/// direction: arms hanging along the body cannot be told from it.
const MIN_ARM_H: f32 = 0.3;
const MIN_ARM_SIDEWAYS: f32 = 0.3;

/// Points spread over the surface at most this far apart, as a fraction of the figure's
/// height: a low-poly figure's few vertices (a box of a chest has eight) miss the bands
/// the fit reads.
const SAMPLE_SPACING_H: f32 = 0.01;
/// Most surface points the fit reads; past it they are spread further apart.
const MAX_SAMPLES: usize = 1 << 20;

/// The skeleton of a standing figure made of `meshes` (Y up), named by role (`pelvis`,
/// `thigh_l`, …) so the roles are read from the names.
pub(super) fn humanoid_skeleton(meshes: &[SkinnedMesh]) -> Result<Skeleton> {
    let points = surface_points(meshes);
    let body = Figure::new(&points)?;
    let j = body.joints()?;
    let rows = j.rows();
    let world: Vec<Transform> = rows
        .iter()
        .map(|r| {
            let end = r.end.unwrap_or_else(|| rows[r.child.unwrap_or(0)].at);
            let y = (end - r.at).normalize_or(Vec3::Y);
            Transform::new(r.at, bone_frame(y, body.left))
        })
        .collect();
    let joints = rows
        .iter()
        .enumerate()
        .map(|(i, r)| Joint {
            name: r.name.to_string(),
            parent: r.parent,
            rest: match r.parent {
                Some(p) => world[p].inverse().mul(&world[i]),
                None => world[i],
            },
            tip: r.end.map(|e| world[i].inverse().transform_point(e)),
        })
        .collect();
    Skeleton::new(joints)
}

/// Every vertex, and points on a grid over each triangle no further apart than
/// [`SAMPLE_SPACING_H`] of the height (wider when that would pass [`MAX_SAMPLES`]).
fn surface_points(meshes: &[SkinnedMesh]) -> Vec<Vec3> {
    let mut points: Vec<Vec3> = meshes
        .iter()
        .flat_map(|m| m.positions.iter().copied())
        .filter(|p| p.is_finite())
        .collect();
    let (lo, hi) = points
        .iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p.y), hi.max(p.y))
        });
    let triangles = || {
        meshes.iter().flat_map(|m| {
            m.indices.chunks_exact(3).filter_map(|t| {
                let v = |i: u32| m.positions.get(i as usize).copied();
                Some([v(t[0])?, v(t[1])?, v(t[2])?])
            })
        })
    };
    let area: f32 = triangles()
        .map(|[a, b, c]| 0.5 * (b - a).cross(c - a).length())
        .filter(|a| a.is_finite())
        .sum();
    let spacing = (SAMPLE_SPACING_H * (hi - lo))
        .max((2.0 * area / MAX_SAMPLES as f32).sqrt())
        .max(1e-6);
    for [a, b, c] in triangles() {
        let longest = (b - a).length().max((c - b).length()).max((a - c).length());
        let n = (longest / spacing).ceil();
        if n.is_nan() || n < 2.0 || points.len() >= MAX_SAMPLES {
            continue;
        }
        let n = n.min(1024.0) as usize;
        for i in 1..n {
            for j in 1..n - i {
                let (u, v) = (i as f32 / n as f32, j as f32 / n as f32);
                points.push(a + (b - a) * u + (c - a) * v);
            }
        }
    }
    points
}

/// The figure as the fit reads it.
struct Figure<'a> {
    points: &'a [Vec3],
    floor: f32,
    height: f32,
    /// The spine's line (X, Z) and the figure's left and forward (horizontal, unit).
    centre: Vec3,
    left: Vec3,
    forward: Vec3,
}

impl<'a> Figure<'a> {
    fn new(points: &'a [Vec3]) -> Result<Self> {
        let (lo, hi) = points
            .iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(p.y), hi.max(p.y))
            });
        let height = hi - lo;
        if height.is_nan() || height <= 1e-3 {
            return Err(refused("it has no height"));
        }
        let mut f = Figure {
            points,
            floor: lo,
            height,
            centre: Vec3::ZERO,
            left: Vec3::X,
            forward: Vec3::Z,
        };
        // The waist, below the arms' reach in an A-pose, holds the spine's line.
        f.centre = f
            .band(0.58, |_| true)
            .ok_or_else(|| refused("no skin at its waist"))?;
        f.forward = f.facing();
        f.left = Vec3::Y.cross(f.forward).normalize();
        Ok(f)
    }

    /// The mean of the vertices at `frac` of the height (± [`BAND_H`]) that `keep` accepts.
    fn band(&self, frac: f32, keep: impl Fn(Vec3) -> bool) -> Option<Vec3> {
        let y = self.floor + frac * self.height;
        let half = BAND_H * self.height;
        let (sum, n) = self
            .points
            .iter()
            .filter(|p| (p.y - y).abs() <= half && keep(**p))
            .fold((Vec3::ZERO, 0usize), |(s, n), p| (s + *p, n + 1));
        (n > 0).then(|| sum / n as f32)
    }

    /// +Z or -Z, whichever way the toes stand out from the ankles (a foot reaches further
    /// forward than back); +Z, glTF's facing, when the feet do not say.
    fn facing(&self) -> Vec3 {
        let soles = self.band(BAND_H, |_| true);
        let ankles = self.band(ANKLE_H + BAND_H, |_| true);
        match (soles, ankles) {
            (Some(s), Some(a)) if (s.z - a.z).abs() > 0.005 * self.height => {
                Vec3::Z * (s.z - a.z).signum()
            }
            _ => Vec3::Z,
        }
    }

    /// Signed distance of `p` to the left of the spine's line.
    fn side(&self, p: Vec3) -> f32 {
        (p - self.centre).dot(self.left)
    }

    /// The point at height `frac` on the spine's line.
    fn on_spine(&self, frac: f32) -> Vec3 {
        Vec3::new(
            self.centre.x,
            self.floor + frac * self.height,
            self.centre.z,
        )
    }

    fn joints(&self) -> Result<Joints<'_>> {
        let mut legs = [[Vec3::ZERO; 4]; 2];
        let mut arms = [[Vec3::ZERO; 4]; 2];
        for (k, sign) in [1.0f32, -1.0].into_iter().enumerate() {
            let mine = |p: Vec3| self.side(p) * sign > 0.0;
            let at = |frac: f32| {
                self.band(frac, mine)
                    .ok_or_else(|| refused("a leg has no skin on one side of its spine"))
            };
            // Above the foot, so the foot's forward reach does not pull the ankle along.
            let shank = at(LOW_SHANK_H)?;
            let ankle = Vec3::new(shank.x, self.floor + ANKLE_H * self.height, shank.z);
            let knee = at(KNEE_H)?;
            let thigh = at(HIP_H - 2.0 * BAND_H)?;
            // The toes: the foot's vertex that reaches furthest forward.
            let toe = self
                .points
                .iter()
                .filter(|p| p.y <= self.floor + ANKLE_H * self.height && mine(**p))
                .copied()
                .max_by(|a, b| a.dot(self.forward).total_cmp(&b.dot(self.forward)))
                .unwrap_or(ankle);
            let hip = Vec3::new(thigh.x, self.floor + HIP_H * self.height, thigh.z);
            legs[k] = [hip, knee, ankle, toe];
            arms[k] = self.arm(sign)?;
        }
        Ok(Joints {
            legs,
            arms,
            f: self,
        })
    }

    /// Shoulder, elbow, wrist and fingertip of the arm on side `sign` (+1 left).
    fn arm(&self, sign: f32) -> Result<[Vec3; 4]> {
        let shoulder =
            self.on_spine(SHOULDER_H) + self.left * (sign * SHOULDER_OUT_H * self.height);
        let lo = self.floor + 0.35 * self.height;
        let tip = self
            .points
            .iter()
            .filter(|p| p.y >= lo)
            .copied()
            .max_by(|a, b| (self.side(*a) * sign).total_cmp(&(self.side(*b) * sign)))
            .ok_or_else(|| refused("it has no arms"))?;
        let reach = tip - shoulder;
        let sideways = reach.dot(self.left) * sign;
        if reach.length() < MIN_ARM_H * self.height || sideways < MIN_ARM_SIDEWAYS * reach.length()
        {
            return Err(refused(
                "its arms do not reach out from its body (it needs a T-pose or an A-pose)",
            ));
        }
        Ok([
            shoulder,
            shoulder + reach * ELBOW_AT,
            shoulder + reach * WRIST_AT,
            tip,
        ])
    }
}

/// The fitted joints: per side (left, right) hip, knee, ankle, toe and shoulder, elbow,
/// wrist, fingertip.
struct Joints<'a> {
    legs: [[Vec3; 4]; 2],
    arms: [[Vec3; 4]; 2],
    f: &'a Figure<'a>,
}

/// One joint of the skeleton to write: where it is, its parent, where its bone ends when
/// not at its first child.
struct Row {
    name: &'static str,
    at: Vec3,
    parent: Option<usize>,
    child: Option<usize>,
    end: Option<Vec3>,
}

impl Joints<'_> {
    fn rows(&self) -> Vec<Row> {
        let f = self.f;
        let mut rows: Vec<Row> = Vec::new();
        let push = |rows: &mut Vec<Row>, name, at, parent: Option<usize>, end| {
            let i = rows.len();
            if let Some(p) = parent
                && rows[p].child.is_none()
            {
                rows[p].child = Some(i);
            }
            rows.push(Row {
                name,
                at,
                parent,
                child: None,
                end,
            });
            i
        };
        let pelvis = push(&mut rows, "pelvis", f.on_spine(PELVIS_H), None, None);
        let spine = push(&mut rows, "spine", f.on_spine(SPINE_H), Some(pelvis), None);
        let chest = push(&mut rows, "chest", f.on_spine(CHEST_H), Some(spine), None);
        let neck = push(&mut rows, "neck", f.on_spine(NECK_H), Some(chest), None);
        let top = f.on_spine(1.0);
        push(&mut rows, "head", f.on_spine(HEAD_H), Some(neck), Some(top));
        let names = [
            [
                "thigh_l",
                "shin_l",
                "foot_l",
                "upper_arm_l",
                "forearm_l",
                "hand_l",
            ],
            [
                "thigh_r",
                "shin_r",
                "foot_r",
                "upper_arm_r",
                "forearm_r",
                "hand_r",
            ],
        ];
        for (k, n) in names.iter().enumerate() {
            let [hip, knee, ankle, toe] = self.legs[k];
            let thigh = push(&mut rows, n[0], hip, Some(pelvis), None);
            let shin = push(&mut rows, n[1], knee, Some(thigh), None);
            push(&mut rows, n[2], ankle, Some(shin), Some(toe));
            let [shoulder, elbow, wrist, tip] = self.arms[k];
            let upper = push(&mut rows, n[3], shoulder, Some(chest), None);
            let fore = push(&mut rows, n[4], elbow, Some(upper), None);
            push(&mut rows, n[5], wrist, Some(fore), Some(tip));
        }
        // The chest's bone runs up the spine, not out to the first arm.
        rows[chest].child = Some(neck);
        rows[pelvis].child = Some(spine);
        rows
    }
}

fn refused(why: &str) -> crate::error::Error {
    setting(
        "rig.humanoid",
        format!("cannot fit a standing humanoid to the mesh: {why}"),
    )
}
