//! The few maths helpers the crate shares on top of glam: rigid transforms with scale,
//! and the swing-twist decomposition used for joint limits and their metrics.
//!
//! Conventions (as in the crate docs): right-handed, Y up, metres, radians.

use glam::{Mat4, Quat, Vec3};
use serde::{Deserialize, Serialize};

/// A translation, rotation and (per-axis) scale, applied scale first, then rotation, then
/// translation, as glTF nodes do.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Transform {
    /// Translation in metres, in the parent's space.
    pub translation: Vec3,
    /// Rotation, unit quaternion.
    pub rotation: Quat,
    /// Scale factors; `Vec3::ONE` for nearly every skeleton.
    pub scale: Vec3,
}

impl Default for Transform {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Transform {
    /// No translation, no rotation, unit scale.
    pub const IDENTITY: Transform = Transform {
        translation: Vec3::ZERO,
        rotation: Quat::IDENTITY,
        scale: Vec3::ONE,
    };

    /// A rigid transform (unit scale).
    pub fn new(translation: Vec3, rotation: Quat) -> Self {
        Transform {
            translation,
            rotation,
            scale: Vec3::ONE,
        }
    }

    /// A pure translation.
    pub fn from_translation(translation: Vec3) -> Self {
        Self::new(translation, Quat::IDENTITY)
    }

    /// The 4×4 matrix of this transform.
    pub fn to_mat4(&self) -> Mat4 {
        Mat4::from_scale_rotation_translation(self.scale, self.rotation, self.translation)
    }

    /// Decomposes an affine matrix. Shear, if any, is lost.
    pub fn from_mat4(m: Mat4) -> Self {
        let (scale, rotation, translation) = m.to_scale_rotation_translation();
        Transform {
            translation,
            rotation: rotation.normalize(),
            scale,
        }
    }

    /// `self * other`: `other` expressed in `self`'s parent space.
    ///
    /// Exact for uniform scale; with non-uniform scale it goes through a matrix.
    pub fn mul(&self, other: &Transform) -> Transform {
        if is_uniform(self.scale) {
            Transform {
                translation: self.transform_point(other.translation),
                rotation: (self.rotation * other.rotation).normalize(),
                scale: self.scale * other.scale,
            }
        } else {
            Transform::from_mat4(self.to_mat4() * other.to_mat4())
        }
    }

    /// The inverse transform.
    pub fn inverse(&self) -> Transform {
        if is_uniform(self.scale) {
            let inv_rot = self.rotation.conjugate();
            let inv_scale = self.scale.recip();
            Transform {
                translation: inv_rot * (-self.translation) * inv_scale,
                rotation: inv_rot,
                scale: inv_scale,
            }
        } else {
            Transform::from_mat4(self.to_mat4().inverse())
        }
    }

    /// Maps a point from local to parent space.
    pub fn transform_point(&self, p: Vec3) -> Vec3 {
        self.translation + self.rotation * (self.scale * p)
    }

    /// Maps a direction from local to parent space (no translation, no scale).
    pub fn transform_dir(&self, d: Vec3) -> Vec3 {
        self.rotation * d
    }

    /// Whether every component is finite.
    pub fn is_finite(&self) -> bool {
        self.translation.is_finite() && self.rotation.is_finite() && self.scale.is_finite()
    }
}

fn is_uniform(s: Vec3) -> bool {
    (s.x - s.y).abs() <= 1e-6 * s.x.abs().max(1.0) && (s.x - s.z).abs() <= 1e-6 * s.x.abs().max(1.0)
}

/// Splits `q` into `swing * twist`, where `twist` turns about `axis` (unit) and `swing`
/// turns about an axis perpendicular to it.
pub fn swing_twist(q: Quat, axis: Vec3) -> (Quat, Quat) {
    let r = Vec3::new(q.x, q.y, q.z);
    let p = axis * r.dot(axis);
    let twist = Quat::from_xyzw(p.x, p.y, p.z, q.w);
    let twist = if twist.length_squared() < 1e-12 {
        Quat::IDENTITY
    } else {
        twist.normalize()
    };
    let swing = q * twist.conjugate();
    (swing, twist)
}

/// The signed rotation angle about the X axis of a relative rotation, measured as
/// `2·atan2(q.x, q.w)` wrapped to (−π, π] — the measure rapier's angular limits use.
pub fn twist_angle_x(q: Quat) -> f32 {
    let q = if q.w < 0.0 { -q } else { q };
    2.0 * q.x.atan2(q.w)
}

/// A unit vector perpendicular to `v` (unit), chosen stably.
pub fn any_perpendicular(v: Vec3) -> Vec3 {
    v.any_orthonormal_vector()
}

/// The rotation whose X axis is `x` and whose Y axis is as close to `y_hint` as possible.
///
/// Falls back to any perpendicular when `y_hint` is parallel to `x`.
pub fn frame_from_x(x: Vec3, y_hint: Vec3) -> Quat {
    let x = x.normalize_or(Vec3::X);
    let mut z = x.cross(y_hint);
    if z.length_squared() < 1e-10 {
        z = x.cross(any_perpendicular(x));
    }
    let z = z.normalize();
    let y = z.cross(x);
    Quat::from_mat3(&glam::Mat3::from_cols(x, y, z)).normalize()
}

/// Principal axes of a weighted point cloud: its weighted centroid, then the eigenvectors
/// of its covariance (unit, right-handed) with their eigenvalues (variances, m²), largest
/// first.
///
/// The covariance's eigenvectors (cyclic Jacobi rotations) give the second and third
/// axes too (a creature's up/down and left/right). Points with a non-positive or
/// non-finite weight are skipped; with no usable point the result is the origin and the
/// world axes with zero variances.
pub fn principal_axes(points: &[Vec3], weights: &[f32]) -> (Vec3, [Vec3; 3], [f32; 3]) {
    let used = || {
        points
            .iter()
            .zip(weights)
            .filter(|(p, w)| p.is_finite() && w.is_finite() && **w > 0.0)
    };
    let total: f32 = used().map(|(_, w)| *w).sum();
    if total <= 0.0 || !total.is_finite() {
        return (Vec3::ZERO, [Vec3::X, Vec3::Y, Vec3::Z], [0.0; 3]);
    }
    let c = used().map(|(p, w)| *p * *w).sum::<Vec3>() / total;
    let mut a = [[0.0f64; 3]; 3];
    for (p, w) in used() {
        let d = (*p - c).as_dvec3().to_array();
        for (r, row) in a.iter_mut().enumerate() {
            for (k, x) in row.iter_mut().enumerate() {
                *x += f64::from(*w) * d[r] * d[k];
            }
        }
    }
    for row in &mut a {
        for x in row.iter_mut() {
            *x /= f64::from(total);
        }
    }
    let (axes, vars) = symmetric_eigen(a);
    (c, axes, vars)
}

/// Eigenvectors (unit columns of a right-handed frame) and eigenvalues of the symmetric
/// 3×3 matrix `a`, largest eigenvalue first, negative ones read as 0.
///
/// Cyclic Jacobi rotations: exact to rounding in a handful of sweeps, and, unlike power
/// iteration, it also gives the second and third axes.
pub(crate) fn symmetric_eigen(mut a: [[f64; 3]; 3]) -> ([Vec3; 3], [f32; 3]) {
    let mut v = [[1.0f64, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _sweep in 0..32 {
        let off = a[0][1].abs() + a[0][2].abs() + a[1][2].abs();
        if off <= 1e-15 * (a[0][0].abs() + a[1][1].abs() + a[2][2].abs()) || off == 0.0 {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][q] == 0.0 {
                continue;
            }
            // The rotation in the (p, q) plane that zeroes a[p][q] (Golub & Van Loan, §8.5).
            let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let cs = 1.0 / (t * t + 1.0).sqrt();
            let sn = t * cs;
            for row in &mut a {
                let (x, y) = (row[p], row[q]);
                row[p] = cs * x - sn * y;
                row[q] = sn * x + cs * y;
            }
            let (rp, rq) = (a[p], a[q]);
            a[p] = std::array::from_fn(|k| cs * rp[k] - sn * rq[k]);
            a[q] = std::array::from_fn(|k| sn * rp[k] + cs * rq[k]);
            for row in &mut v {
                let (x, y) = (row[p], row[q]);
                row[p] = cs * x - sn * y;
                row[q] = sn * x + cs * y;
            }
        }
    }
    let mut order = [0, 1, 2];
    order.sort_by(|&i, &j| a[j][j].total_cmp(&a[i][i]));
    let axis = |k: usize| Vec3::new(v[0][k] as f32, v[1][k] as f32, v[2][k] as f32).normalize();
    let (x, y) = (axis(order[0]), axis(order[1]));
    let axes = [x, y, x.cross(y).normalize()];
    let vars = order.map(|k| a[k][k].max(0.0) as f32);
    (axes, vars)
}

/// Parameters `(s, t)` of the closest points of segments `p0 p1` and `q0 q1` (Ericson,
/// Real-Time Collision Detection, 5.1.9).
pub fn closest_segment_params(p0: Vec3, p1: Vec3, q0: Vec3, q1: Vec3) -> (f32, f32) {
    let d1 = p1 - p0;
    let d2 = q1 - q0;
    let r = p0 - q0;
    let a = d1.dot(d1);
    let e = d2.dot(d2);
    let f = d2.dot(r);
    if a <= 1e-12 && e <= 1e-12 {
        return (0.0, 0.0);
    }
    if a <= 1e-12 {
        return (0.0, (f / e).clamp(0.0, 1.0));
    }
    let c = d1.dot(r);
    if e <= 1e-12 {
        return ((-c / a).clamp(0.0, 1.0), 0.0);
    }
    let b = d1.dot(d2);
    let denom = a * e - b * b;
    let mut s = if denom > 1e-12 {
        ((b * f - c * e) / denom).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let mut t = (b * s + f) / e;
    if t < 0.0 {
        t = 0.0;
        s = (-c / a).clamp(0.0, 1.0);
    } else if t > 1.0 {
        t = 1.0;
        s = ((b - c) / a).clamp(0.0, 1.0);
    }
    (s, t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transform_inverse_round_trips() {
        let t = Transform {
            translation: Vec3::new(1.0, -2.0, 0.5),
            rotation: Quat::from_euler(glam::EulerRot::XYZ, 0.3, -1.2, 2.0),
            scale: Vec3::splat(0.01),
        };
        let p = Vec3::new(0.3, 4.0, -7.0);
        let back = t.inverse().transform_point(t.transform_point(p));
        assert!((back - p).length() < 1e-4, "{back:?}");
        let id = t.mul(&t.inverse());
        assert!(id.translation.length() < 1e-5);
        assert!(id.rotation.angle_between(Quat::IDENTITY) < 1e-5);
    }

    #[test]
    fn mul_matches_matrices() {
        let a = Transform::new(Vec3::new(1.0, 2.0, 3.0), Quat::from_rotation_y(0.7));
        let b = Transform::new(Vec3::new(-1.0, 0.5, 0.0), Quat::from_rotation_x(-0.4));
        let m = a.to_mat4() * b.to_mat4();
        let c = a.mul(&b).to_mat4();
        assert!(m.abs_diff_eq(c, 1e-5));
    }

    #[test]
    fn swing_twist_recomposes_and_separates() {
        let twist = Quat::from_rotation_x(0.6);
        let swing = Quat::from_rotation_z(0.4);
        let q = swing * twist;
        let (s, t) = swing_twist(q, Vec3::X);
        assert!((s * t).angle_between(q) < 1e-5);
        assert!((t.angle_between(Quat::IDENTITY) - 0.6).abs() < 1e-5);
        assert!((s.angle_between(Quat::IDENTITY) - 0.4).abs() < 1e-5);
    }

    #[test]
    fn frame_from_x_is_orthonormal_with_requested_axes() {
        let x = Vec3::new(0.0, -1.0, 0.1).normalize();
        let q = frame_from_x(x, Vec3::Z);
        assert!((q * Vec3::X - x).length() < 1e-5);
        assert!((q * Vec3::Y).dot(Vec3::Z) > 0.99);
    }

    #[test]
    fn twist_angle_is_signed() {
        assert!((twist_angle_x(Quat::from_rotation_x(0.5)) - 0.5).abs() < 1e-6);
        assert!((twist_angle_x(Quat::from_rotation_x(-0.5)) + 0.5).abs() < 1e-6);
    }

    #[test]
    fn principal_axes_of_a_stretched_tilted_cloud() {
        // A box of points 4 × 2 × 1 long, turned: the axes come back turned, the
        // variances are those of uniform spacing along each side.
        let q = Quat::from_euler(glam::EulerRot::XYZ, 0.4, -0.9, 0.3);
        let mut pts = Vec::new();
        for i in 0..9 {
            for j in 0..5 {
                for k in 0..3 {
                    let p = Vec3::new(
                        i as f32 * 0.5 - 2.0,
                        j as f32 * 0.5 - 1.0,
                        k as f32 * 0.5 - 0.5,
                    );
                    pts.push(q * p + Vec3::new(3.0, -1.0, 2.0));
                }
            }
        }
        let (c, axes, vars) = principal_axes(&pts, &vec![1.0; pts.len()]);
        assert!((c - Vec3::new(3.0, -1.0, 2.0)).length() < 1e-4);
        for (axis, world) in axes.iter().zip([Vec3::X, Vec3::Y, Vec3::Z]) {
            assert!(axis.dot(q * world).abs() > 0.9999, "{axis:?}");
        }
        // Variance of 0, ±0.5, …, ±2 (9 points) is 1.6667; of 5 points ±1 is 0.5.
        assert!((vars[0] - 5.0 / 3.0).abs() < 1e-4, "{vars:?}");
        assert!((vars[1] - 0.5).abs() < 1e-4, "{vars:?}");
        assert!(axes[0].cross(axes[1]).dot(axes[2]) > 0.999);
    }
}
