//! BVH (Biovision hierarchy) import. Hand-written: the one crate panics on real files, and
//! user files must give an error naming the line, never a crash.
//!
//! # What is accepted
//!
//! Any joint names, up to [`MAX_JOINTS`] joints, several `ROOT`s, any `CHANNELS` list on
//! any joint (positions on non-root joints, rotations only, fewer than three, any order, at
//! most [`MAX_CHANNELS_PER_JOINT`]), `End Site` in any case, tabs, CRLF (or CR-only) line
//! ends, blank lines anywhere, and `Frames:` / `Frame Time:` with or without spaces around
//! the colon. One frame is one line; its value count must equal the channel count of the
//! hierarchy.
//!
//! Everything else is an [`Error::Parse`] naming the file and the 1-based line: a missing
//! brace or `OFFSET` (blamed on the line where the hierarchy ends, or the joint's line), an
//! unknown keyword or channel, a value that is not a finite number or lies beyond
//! ±[`MAX_VALUE`], a frame line with the wrong value count, a missing `MOTION` / `Frames:`
//! / `Frame Time:` (which must lie in [`FRAME_TIME_RANGE_S`]), more frames than
//! [`MAX_CLIP_POSES`] allows, more frame lines than `Frames:` announces, or fewer (blamed on
//! the line where the data ran out), or a frame that moves a joint past
//! [`MAX_REACH_M`]. An `End Site` whose offset is all zeros gives no [`Joint::tip`] (it
//! says nothing about where the bone ends), but is kept in the layout.
//!
//! The parser streams: the hierarchy is read a word at a time with an explicit stack of
//! open joints (no recursion on the nesting), and each frame is converted as its line is
//! read, so memory is the skeleton and the clip, never a copy of the text.
//!
//! # Channel semantics
//!
//! A joint's local transform in a frame is `T(p) · R₁(θ₁) · R₂(θ₂) · …`: the rotation
//! channels compose in the order they are listed (the first one is outermost, so
//! `Zrotation Xrotation Yrotation` is `Rz·Rx·Ry`, glam's intrinsic `EulerRot::ZXY`). `p` is
//! the `OFFSET`, with each position channel present replacing its own component (the usual
//! case: all three present, so the channels replace the offset). The rest pose is the
//! offsets with no rotation.
//!
//! # Units and up axis (detected unless [`ImportOptions`] says)
//!
//! The detection looks at the rest pose: every joint and `End Site` position, in file units.
//!
//! - **Up axis**: Z when the extent along Z is more than twice the extent along Y and at
//!   least half the extent along X, else Y. A standing figure is several times taller than
//!   it is deep, so this only flips for files that really stand on Z; ambiguous shapes
//!   (quadrupeds) keep BVH's usual Y, and so does a rest pose lying along X (bone-local
//!   offsets, as Rokoko and LAFAN1 write them), whose hips and shoulders reach across it
//!   along Z: it stands on neither axis, and its first frame says how it stands.
//! - **Units**: the candidate that makes the skeleton's span closest to 2.5 m on a log
//!   scale. The span is the longest path between two of its points (joints and End Sites)
//!   along its bones: bone lengths do not change with the pose the rest is written in, so
//!   a rest pose lying down or with each bone along its own local axis gets the units of
//!   the same person standing. A person's span is toe to fingertip, 1.4-1.6 times their
//!   height. The candidates and the resulting thresholds on the span `s` in file units:
//!   metres (`s < 10.5`), CMU units of 1/0.45 inch (`10.5 ≤ s < 66.0`, the unit of the CMU
//!   ASF skeletons that many converted BVH files keep), inches (`66.0 ≤ s < 156.9`, the
//!   original Biovision sample), centimetres (`156.9 ≤ s < 790.6`, most BVH), millimetres
//!   above. A skeleton with no span at all is taken as centimetres. Inches and CMU units
//!   are a person's: a skeleton that role recognition does not take for a person is read
//!   in centimetres in those bands (a dog 80 units across is 0.8 m, not 2 m). A rest pose
//!   lying down (its height under half its breadth) whose first frame stands takes that
//!   frame's rotations as its rest: the ragdoll is built standing.
//!
//! The data files give: `biovision_example_bvhio` spans 102.7 → inches, 1.84 m tall;
//! `cmu_pirouette_threejs` 236.1 → cm, 1.53 m; `mocapbank_bvh-python` 239.9 → cm, 1.67 m;
//! `animdraw_rokoko_jesse_dance` (lying along X) 253.7 → cm; `bvh11_cmu_131_01` 39.3 → CMU
//! units; `two_joint_bvh_anim` (a chain lying along Z, so Z up) 45 → not a person, so
//! centimetres, 0.45 m.
//!
//! # Conversion
//!
//! The [`Character`](crate::skeleton::Character) is in metres with Y up. The up-axis
//! rotation `C` (identity, or −90° about X for Z-up files) goes into the root joints only:
//! root rest = `C · T(offset·s)`,
//! root in a frame = `C · T(p·s) · R`. Other joints keep their rotations; their translations
//! are scaled to metres. Everything needed to write the file back is kept in [`BvhLayout`].

mod hierarchy;
mod motion;
mod parse;
mod text;

use glam::{DMat3, DQuat, DVec3};

#[cfg(doc)]
use crate::{
    error::Error,
    import::ImportOptions,
    skeleton::{Joint, MAX_CLIP_POSES, MAX_JOINTS, MAX_REACH_M},
};

pub use parse::{load, parse};

use super::UpAxis;
use crate::skeleton::Skeleton;

/// Metres per unit of the CMU motion capture ASF skeletons, `(1/0.45) · 2.54 / 100`, which
/// many BVH conversions of that database kept; a height of about 31 of them is a person.
pub const CMU_UNIT_M: f32 = 0.0254 / 0.45;

/// The span (toe to fingertip along the bones) a detected unit aims for: a person 1.7 m
/// tall spans about 2.5 m (the data files: 1.42-1.62 times their standing height). See the
/// module docs for the thresholds it implies.
const TYPICAL_SPAN_M: f64 = 2.5;

/// Unit candidates for detection, metres per file unit.
const UNIT_CANDIDATES: [f64; 5] = [1.0, CMU_UNIT_M as f64, 0.0254, 0.01, 0.001];

/// Largest absolute value of a number in a BVH file (offsets and positions in file units,
/// angles in degrees): one million. That is 10 km in centimetres and 2,800 turns; a larger
/// value is a broken file, and would only blow up later, in the physics.
pub const MAX_VALUE: f64 = 1e6;

/// Most channels one joint may list: 64. A joint has at most six meaningful ones (three
/// positions, three rotations); a few exporters repeat axes.
pub const MAX_CHANNELS_PER_JOINT: usize = 64;

/// Shortest and longest `Frame Time` accepted, seconds: 10 kHz to one frame per 10 s.
/// Outside that, rates and durations computed from it stop making sense (a frame time of
/// 1e-30 would ask playback for 1e30 frames a second).
pub const FRAME_TIME_RANGE_S: [f64; 2] = [1e-4, 10.0];

/// Below this sine or cosine of the middle angle, Euler decomposition treats the middle
/// angle as gimbal-locked and puts the whole remaining turn into the last angle.
const GIMBAL_EPS: f64 = 1e-6;

impl Axis {
    fn from_index(i: usize) -> Axis {
        match i % 3 {
            0 => Axis::X,
            1 => Axis::Y,
            _ => Axis::Z,
        }
    }

    fn unit(self) -> DVec3 {
        match self {
            Axis::X => DVec3::X,
            Axis::Y => DVec3::Y,
            Axis::Z => DVec3::Z,
        }
    }
}

pub use crate::skeleton::source::{Axis, BvhJoint, BvhLayout, Channel};

impl BvhLayout {
    /// A layout for a character that did not come from a BVH file (glTF, the built-in
    /// humanoid): the root gets `Xposition Yposition Zposition Zrotation Xrotation
    /// Yrotation`, the others `Zrotation Xrotation Yrotation`, in centimetres with Y up, the
    /// most widely read BVH dialect. Names are sanitised so other tools can parse them;
    /// joint tips become `End Site`s, in world axes with the rest world scale applied,
    /// because the exporter writes the rest pose with world-aligned joint frames.
    pub fn from_skeleton(skeleton: &Skeleton) -> BvhLayout {
        let metres_per_unit = 0.01f32;
        let names = sanitise_names(skeleton.joints().iter().map(|j| j.name.as_str()));
        let rest_world = skeleton.rest_world();
        let joints = skeleton
            .joints()
            .iter()
            .zip(names)
            .enumerate()
            .map(|(i, (j, name))| {
                let rot = [Axis::Z, Axis::X, Axis::Y].map(Channel::Rotation);
                let channels = if j.parent.is_none() {
                    let mut c = [Axis::X, Axis::Y, Axis::Z].map(Channel::Position).to_vec();
                    c.extend(rot);
                    c
                } else {
                    rot.to_vec()
                };
                // In world axes, like the exporter's OFFSETs (its module docs say why).
                let end_site = j
                    .tip
                    .map(|t| rest_world[i].rotation * (rest_world[i].scale * t) / metres_per_unit);
                BvhJoint {
                    name,
                    channels,
                    end_site,
                }
            })
            .collect();
        BvhLayout {
            joints,
            metres_per_unit,
            up: UpAxis::Y,
            frame_time: 1.0 / 30.0,
        }
    }
}

/// Makes joint names safe to write into a BVH file: empty names become `joint<i>`,
/// whitespace and braces become `_` (a reader splits on them), and duplicates get a `_2`,
/// `_3`… suffix (readers look joints up by name).
pub(crate) fn sanitise_names<'a>(names: impl Iterator<Item = &'a str>) -> Vec<String> {
    let base: Vec<String> = names
        .enumerate()
        .map(|(i, n)| {
            let s: String = n
                .chars()
                .map(|c| {
                    if c.is_whitespace() || c == '{' || c == '}' {
                        '_'
                    } else {
                        c
                    }
                })
                .collect();
            if s.is_empty() { format!("joint{i}") } else { s }
        })
        .collect();
    let mut used = std::collections::HashSet::new();
    // The next suffix worth trying per name: suffixes found taken stay taken, so resuming
    // there gives the same names as counting from 2 each time, without the quadratic cost
    // of thousands of joints sharing one name.
    let mut next_suffix: std::collections::HashMap<&str, usize> = Default::default();
    let mut out = Vec::with_capacity(base.len());
    for name in &base {
        let mut candidate = name.clone();
        let k = next_suffix.entry(name.as_str()).or_insert(2);
        while used.contains(&candidate) {
            candidate = format!("{name}_{k}");
            *k += 1;
        }
        used.insert(candidate.clone());
        out.push(candidate);
    }
    out
}

/// The rotation `R_{axes[0]}(θ₀) · R_{axes[1]}(θ₁) · …` (angles in radians): how BVH
/// composes a joint's rotation channels, the first listed being the outermost.
pub fn compose_rotation(axes: &[Axis], angles_rad: &[f64]) -> DQuat {
    axes.iter()
        .zip(angles_rad)
        .fold(DQuat::IDENTITY, |q, (a, &t)| {
            q * DQuat::from_axis_angle(a.unit(), t)
        })
        .normalize()
}

/// Angles (radians) for `axes` such that [`compose_rotation`] gives back `q`: the inverse
/// the exporter needs to write any channel order.
///
/// Exact for three axes with no two neighbours equal (the six Tait–Bryan orders such as
/// `ZXY`, and the proper Euler orders such as `ZXZ`). With fewer axes, or runs of one axis,
/// it is a best effort that is exact when `q` lies in what the channels can express: one
/// axis gets the twist about it, two axes get the first two angles of the three-axis
/// decomposition completed by the missing axis, a run of one axis gets its whole angle on
/// its first channel, and axes past the third distinct one get zero.
pub fn decompose_rotation(q: DQuat, axes: &[Axis]) -> Vec<f64> {
    let mut out = vec![0.0; axes.len()];
    // Collapse runs of the same axis: (axis, index of its first channel).
    let mut core: Vec<(Axis, usize)> = Vec::with_capacity(axes.len());
    for (i, &a) in axes.iter().enumerate() {
        if core.last().map(|c| c.0) != Some(a) {
            core.push((a, i));
        }
    }
    let q = if q.length_squared() > 0.0 && q.is_finite() {
        q.normalize()
    } else {
        DQuat::IDENTITY
    };
    let angles: Vec<f64> = match core.as_slice() {
        [] => Vec::new(),
        [(a, _)] => vec![twist_angle(q, *a)],
        [(a, _), (b, _)] => {
            let third = Axis::from_index(3 - a.index() - b.index());
            euler3(q, *a, *b, third)[..2].to_vec()
        }
        [(a, _), (b, _), (c, _), ..] => euler3(q, *a, *b, *c).to_vec(),
    };
    for ((_, i), angle) in core.iter().zip(angles) {
        out[*i] = angle;
    }
    out
}

/// Signed angle of the rotation about `axis` contained in `q` (its twist), in (−π, π].
fn twist_angle(q: DQuat, axis: Axis) -> f64 {
    let v = [q.x, q.y, q.z][axis.index()];
    let q_w = q.w;
    let mut a = 2.0 * v.atan2(q_w);
    if a > std::f64::consts::PI {
        a -= std::f64::consts::TAU;
    } else if a <= -std::f64::consts::PI {
        a += std::f64::consts::TAU;
    }
    a
}

/// `[a, b, c]` with `R_i(a)·R_j(b)·R_k(c) = q`, for `i ≠ j`, `j ≠ k` (`i = k` allowed).
fn euler3(q: DQuat, i: Axis, j: Axis, k: Axis) -> [f64; 3] {
    let m = DMat3::from_quat(q);
    let e = |r: usize, c: usize| m.col(c)[r];
    let (ii, jj) = (i.index(), j.index());
    // +1 when (i, j, ·) turns like (x, y, z), −1 otherwise.
    let s = if (ii + 1) % 3 == jj { 1.0 } else { -1.0 };
    let (a, b) = if i != k {
        let kk = k.index();
        let cb = e(ii, ii).hypot(e(ii, jj));
        let b = (s * e(ii, kk)).atan2(cb);
        let a = if cb > GIMBAL_EPS {
            (-s * e(jj, kk)).atan2(e(kk, kk))
        } else {
            0.0
        };
        (a, b)
    } else {
        let kk = 3 - ii - jj;
        let sb = e(ii, jj).hypot(e(ii, kk));
        let b = sb.atan2(e(ii, ii));
        let a = if sb > GIMBAL_EPS {
            e(jj, ii).atan2(-s * e(kk, ii))
        } else {
            0.0
        };
        (a, b)
    };
    // The last angle from what is left, so the product is exact even at gimbal lock.
    let rest = DMat3::from_quat(
        (DQuat::from_axis_angle(i.unit(), a) * DQuat::from_axis_angle(j.unit(), b)).conjugate() * q,
    );
    let p = (k.index() + 1) % 3;
    let r = (k.index() + 2) % 3;
    let c = rest.col(p)[r].atan2(rest.col(p)[p]);
    [a, b, c]
}

/// The rotation taking the file's axes to Y up (identity, or −90° about X for Z up).
pub(crate) fn up_rotation(up: UpAxis) -> DQuat {
    match up {
        UpAxis::Y => DQuat::IDENTITY,
        UpAxis::Z => DQuat::from_rotation_x(-std::f64::consts::FRAC_PI_2),
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use glam::Vec3;

    use super::parse::metres_per_unit_of_span;
    use super::*;
    use crate::error::{Error, Result};
    use crate::import::ImportOptions;
    use crate::skeleton::Character;
    use glam::{EulerRot, Quat};

    const ALL_ORDERS: [[Axis; 3]; 6] = [
        [Axis::X, Axis::Y, Axis::Z],
        [Axis::X, Axis::Z, Axis::Y],
        [Axis::Y, Axis::X, Axis::Z],
        [Axis::Y, Axis::Z, Axis::X],
        [Axis::Z, Axis::X, Axis::Y],
        [Axis::Z, Axis::Y, Axis::X],
    ];

    /// A small deterministic generator (xorshift), so tests need no extra crate.
    struct Rng(u64);
    impl Rng {
        fn next_f64(&mut self) -> f64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }
        fn angle(&mut self) -> f64 {
            (self.next_f64() * 2.0 - 1.0) * std::f64::consts::PI
        }
    }

    /// Compares rotations by what they do to the axes (`angle_between` goes through `acos`,
    /// which cannot resolve angles below about 1e-8 in f64 or 3e-4 in f32).
    fn same_rotation(a: DQuat, b: DQuat, tol: f64) -> bool {
        [DVec3::X, DVec3::Y, DVec3::Z]
            .iter()
            .all(|v| (a * *v - b * *v).length() < tol)
    }

    fn p(s: &str) -> Result<Character> {
        parse(s, Path::new("test.bvh"), &ImportOptions::default())
    }

    #[test]
    fn bvh_channel_order_is_glam_intrinsic_euler() {
        let (a, b, c) = (0.3, -1.1, 2.4);
        let ours = compose_rotation(&[Axis::Z, Axis::X, Axis::Y], &[a, b, c]);
        let glam = DQuat::from_euler(EulerRot::ZXY, a, b, c);
        let explicit =
            DQuat::from_rotation_z(a) * DQuat::from_rotation_x(b) * DQuat::from_rotation_y(c);
        assert!(same_rotation(ours, glam, 1e-12));
        assert!(same_rotation(ours, explicit, 1e-12));
    }

    #[test]
    fn bvh_euler_round_trip_all_orders() {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        let mut orders: Vec<[Axis; 3]> = ALL_ORDERS.to_vec();
        // Proper Euler orders too.
        orders.extend([
            [Axis::Z, Axis::X, Axis::Z],
            [Axis::X, Axis::Z, Axis::X],
            [Axis::Y, Axis::X, Axis::Y],
        ]);
        for order in orders {
            for n in 0..2000 {
                let mut angles = [rng.angle(), rng.angle() * 0.5, rng.angle()];
                if n % 10 == 0 {
                    // Gimbal lock and its neighbourhood.
                    angles[1] = std::f64::consts::FRAC_PI_2 * if n % 20 == 0 { 1.0 } else { -1.0 };
                }
                if n % 7 == 0 && order[0] == order[2] {
                    angles[1] = 0.0;
                }
                let q = compose_rotation(&order, &angles);
                let back = decompose_rotation(q, &order);
                let q2 = compose_rotation(&order, &back);
                assert!(
                    same_rotation(q, q2, 1e-9),
                    "{order:?} {angles:?} -> {back:?}"
                );
                if n % 10 != 0 && order[0] != order[2] {
                    // Away from gimbal lock, Tait–Bryan angles with |b| < 90° are unique.
                    for (x, y) in angles.iter().zip(&back) {
                        assert!((x - y).abs() < 1e-9, "{order:?} {angles:?} -> {back:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn bvh_euler_matches_glam_for_tait_bryan() {
        let mut rng = Rng(12345);
        let rots = [
            EulerRot::XYZ,
            EulerRot::XZY,
            EulerRot::YXZ,
            EulerRot::YZX,
            EulerRot::ZXY,
            EulerRot::ZYX,
        ];
        for (order, rot) in ALL_ORDERS.iter().zip(rots) {
            let a = [rng.angle(), rng.angle() * 0.4, rng.angle()];
            let q = DQuat::from_euler(rot, a[0], a[1], a[2]);
            let ours = decompose_rotation(q, order);
            for (x, y) in a.iter().zip(&ours) {
                assert!((x - y).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn bvh_euler_best_effort_for_fewer_axes() {
        let q = compose_rotation(&[Axis::Y], &[0.7]);
        assert!((decompose_rotation(q, &[Axis::Y])[0] - 0.7).abs() < 1e-12);
        let q = compose_rotation(&[Axis::X, Axis::Z], &[0.4, -1.2]);
        let back = decompose_rotation(q, &[Axis::X, Axis::Z]);
        assert!((back[0] - 0.4).abs() < 1e-9 && (back[1] + 1.2).abs() < 1e-9);
        let back = decompose_rotation(q, &[Axis::X, Axis::X, Axis::Z]);
        assert!((back[0] - 0.4).abs() < 1e-9 && back[1] == 0.0 && (back[2] + 1.2).abs() < 1e-9);
        assert!(decompose_rotation(q, &[]).is_empty());
    }

    #[test]
    fn bvh_unit_thresholds() {
        let u = metres_per_unit_of_span;
        assert_eq!(u(2.5), 1.0);
        assert_eq!(u(10.4), 1.0);
        assert_eq!(u(44.0), CMU_UNIT_M as f64);
        assert_eq!(u(102.7), 0.0254);
        assert_eq!(u(157.0), 0.01);
        assert_eq!(u(236.1), 0.01);
        assert_eq!(u(2500.0), 0.001);
        assert_eq!(u(0.0), 0.01);
    }

    #[test]
    fn bvh_names_are_sanitised() {
        let names = sanitise_names(["", "a b", "x", "x", "x_2", "{"].into_iter());
        assert_eq!(names, ["joint0", "a_b", "x", "x_2", "x_2_2", "_"]);
        let names = sanitise_names(["x", "x_3", "x", "x", "x", "x_2"].into_iter());
        assert_eq!(names, ["x", "x_3", "x_2", "x_4", "x_5", "x_2_2"]);
        // Sixty thousand joints of one name: distinct names, quickly.
        let same = vec!["j"; 60_000];
        let names = sanitise_names(same.into_iter());
        let distinct: std::collections::HashSet<&String> = names.iter().collect();
        assert_eq!(distinct.len(), 60_000);
        assert_eq!(names[59_999], "j_60000");
    }

    #[test]
    fn bvh_position_channels_on_child_replace_offset() {
        let text = "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n\
                    JOINT b\n{\nOFFSET 0 100 0\nCHANNELS 4 Xposition Yrotation Zposition Xrotation\n\
                    End Site\n{\nOFFSET 0 50 0\n}\n}\n}\nMOTION\nFrames: 1\nFrame Time: 0.5\n\
                    0 0 0 7 90 8 0\n";
        let c = p(text).unwrap();
        let f = &c.clips[0].frames[0][1];
        // Xposition and Zposition replace, Y keeps the offset (cm: height 150 units).
        assert!(
            (f.translation - Vec3::new(0.07, 1.0, 0.08)).length() < 1e-6,
            "{f:?}"
        );
        let expected = Quat::from_rotation_y(std::f32::consts::FRAC_PI_2);
        assert!(same_rotation(
            f.rotation.as_dquat(),
            expected.as_dquat(),
            1e-6
        ));
        assert_eq!(c.clips[0].frame_time, 0.5);
    }

    #[test]
    fn bvh_zero_channels_and_multiple_roots() {
        let text = "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nEnd Site\n{\nOFFSET 0 170 0\n}\n}\n\
                    ROOT b\n{\nOFFSET 50 0 0\nCHANNELS 1 Yrotation\n}\nMOTION\nFrames: 2\nFrame Time: 0.1\n10\n20\n";
        let c = p(text).unwrap();
        assert_eq!(c.skeleton.len(), 2);
        assert_eq!(c.skeleton.parent(1), None);
        assert_eq!(c.clips[0].frames.len(), 2);
        let hierarchy_only =
            "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\n}\nMOTION\nFrames: 3\nFrame Time: 0.1\n";
        assert_eq!(p(hierarchy_only).unwrap().clips[0].frames.len(), 3);
    }

    #[test]
    fn bvh_line_numbers_are_the_same_for_lf_crlf_and_cr_files() {
        let text = "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 1 Xrotation\n}\nMOTION\n\
                    Frames: 2\nFrame Time: 0.1\n1\n";
        for sep in ["\n", "\r\n", "\r"] {
            match p(&text.replace('\n', sep)) {
                Err(Error::Parse { line, message, .. }) => {
                    assert_eq!(line, 11, "{sep:?}: {message}");
                    assert!(message.contains("after 1 frames"), "{message}");
                }
                other => panic!("{sep:?}: expected a parse error, got {other:?}"),
            }
        }
    }

    #[test]
    fn bvh_errors_name_the_line() {
        let line = |s: &str| match p(s) {
            Err(Error::Parse { line, message, .. }) => (line, message),
            other => panic!("expected a parse error, got {other:?}"),
        };
        let base = "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 2 Xrotation Yrotation\n}\nMOTION\nFrames: 2\nFrame Time: 0.1\n";
        assert_eq!(line(&format!("{base}1 2\n")).0, 11);
        assert_eq!(line(&format!("{base}1 2\n1\n")).0, 11);
        assert_eq!(line(&format!("{base}1 2\n1 x\n")).0, 11);
        assert_eq!(line(&format!("{base}1 2\n1 2\n3 4\n")).0, 12);
        assert_eq!(line(&format!("{base}1 2\n1 inf\n")).0, 11);
        assert_eq!(line("HIERARCHY\nROOT a\n{\nOFFSET 0 0\n}\n").0, 5);
        assert_eq!(line("HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\n").0, 4);
        assert_eq!(line("HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nMOTION\n").0, 5);
        assert_eq!(line("HIERARCHY\nROOT a\n{\nCHANNELS 1 Wrotation\n}\n").0, 4);
        assert_eq!(
            line("HIERARCHY\nROOT a\n{\nCHANNELS 1 Xrotation\n}\nMOTION\n").0,
            2
        );
        assert_eq!(line("hello\n").0, 1);
        let huge = "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\n}\nMOTION\nFrames: 99999999999999\nFrame Time: 1\n";
        assert_eq!(line(huge).0, 7);
        assert_eq!(line("").0, 1);
        let (l, m) = line(&base.replace("Frame Time: 0.1", "Frame Time: 0"));
        assert_eq!(l, 9, "{m}");
    }
}
