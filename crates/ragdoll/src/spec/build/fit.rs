//! Fitting a shape to the skin a body carries: a capsule round a bone's line, a box along
//! it, and the measures both take of a point cloud (centroid, percentiles, principal
//! axis).

use glam::{Mat3, Quat, Vec3};

use super::Builder;
use super::shapes::{CAPSULE_END_INSET_RADII, MIN_BOX_VERTICES, MIN_FIT_VERTICES, RADIUS_RANGE};
use crate::spec::Shape;

/// Percentiles of a point cloud along its principal axis taken as the ends of the axis a
/// body without a usable bone lies along (a foot heel to toe); the capsule fitted around
/// it then reaches past them to the skin's ends.
const AXIS_PERCENTILES: [f32; 2] = [0.05, 0.95];

impl Builder<'_> {
    /// A box along the bone's line (through `a`, direction `u`) that holds `group`: as
    /// long as the skin reaches along the bone, as wide and deep as nearly all of it
    /// (`q` of it from each side) along the principal axes of its cross-section
    /// (`x` is where those are measured from). `None` with too little skin to measure.
    pub(super) fn fit_box(
        &self,
        a: Vec3,
        u: Vec3,
        x: Vec3,
        group: &[Vec3],
        q: f32,
    ) -> Option<(Shape, Vec3, Quat)> {
        if group.len() < MIN_BOX_VERTICES {
            return None;
        }
        // Too few vertices for a percentile to leave strays out: hold them all.
        let q = if group.len() < MIN_FIT_VERTICES {
            1.0
        } else {
            q
        };
        let z = x.cross(u);
        let c = centroid(group);
        let (mut cxx, mut cxz, mut czz) = (0.0f32, 0.0f32, 0.0f32);
        for p in group {
            let (px, pz) = ((*p - c).dot(x), (*p - c).dot(z));
            cxx += px * px;
            cxz += px * pz;
            czz += pz * pz;
        }
        let turn = 0.5 * (2.0 * cxz).atan2(cxx - czz);
        let x = x * turn.cos() + z * turn.sin();
        let z = x.cross(u);
        let span = |axis: Vec3, q: f32| {
            let v: Vec<f32> = group.iter().map(|p| (*p - a).dot(axis)).collect();
            (percentile(v.clone(), 1.0 - q), percentile(v, q))
        };
        let size = self.size();
        let side = |(lo, hi): (f32, f32)| {
            (hi - lo).clamp(2.0 * RADIUS_RANGE[0] * size, 2.0 * RADIUS_RANGE[1] * size)
        };
        let (sx, sy, sz) = (span(x, q), span(u, 1.0), span(z, q));
        let mid = |(lo, hi): (f32, f32)| 0.5 * (lo + hi);
        let centre = a + x * mid(sx) + u * mid(sy) + z * mid(sz);
        let shape = Shape::Box {
            size_m: [
                side(sx),
                (sy.1 - sy.0).max(2.0 * RADIUS_RANGE[0] * size),
                side(sz),
            ],
        };
        Some((shape, centre, quat_from_cols(x, u, z)))
    }

    /// Radius and span (distances along the bone from `a`, between the two sphere
    /// centres) of a capsule around the bone `a → b` that holds `group`: `None` when the
    /// bone has no length or there is no skin.
    ///
    /// The radius is the skin's distance to the bone's line (`q` of it,
    /// or all of it, and at least `default_radius`, when there are too few vertices to
    /// measure a thickness). A vertex at distance `t` along the bone and `d` from it lies
    /// inside once the span reaches within `√(r² − d²)` of `t`; a vertex farther out than
    /// the radius (a stray the percentile leaves out) still pulls the span out to its `t`.
    pub(super) fn fit_capsule(
        &self,
        a: Vec3,
        b: Vec3,
        default_radius: f32,
        group: &[Vec3],
        q: f32,
    ) -> Option<(f32, f32, f32)> {
        let len = a.distance(b);
        if len < 1e-6 || group.is_empty() {
            return None;
        }
        let u = (b - a) / len;
        let td: Vec<(f32, f32)> = group
            .iter()
            .map(|v| {
                let w = *v - a;
                let t = w.dot(u);
                (t, (w - u * t).length())
            })
            .collect();
        let d: Vec<f32> = td.iter().map(|&(_, d)| d).collect();
        let r = if d.len() >= MIN_FIT_VERTICES {
            percentile(d, q)
        } else {
            d.into_iter().fold(default_radius, f32::max)
        };
        let r = r.clamp(RADIUS_RANGE[0] * self.size(), RADIUS_RANGE[1] * self.size());
        let (mut s0, mut s1) = (
            r * CAPSULE_END_INSET_RADII,
            len - r * CAPSULE_END_INSET_RADII,
        );
        for (t, d) in td {
            let half = (r * r - d.min(r).powi(2)).max(0.0).sqrt();
            s0 = s0.min(t + half);
            s1 = s1.max(t - half);
        }
        if s1 < s0 {
            let mid = 0.5 * (s0 + s1);
            (s0, s1) = (mid, mid);
        }
        Some((r, s0, s1))
    }
}

pub(super) fn quat_from_cols(x: Vec3, y: Vec3, z: Vec3) -> Quat {
    Quat::from_mat3(&Mat3::from_cols(x, y, z)).normalize()
}

pub(super) fn centroid(points: &[Vec3]) -> Vec3 {
    points.iter().sum::<Vec3>() / points.len().max(1) as f32
}

/// The `q`-quantile (0..1) of `v`, nearest rank.
pub(super) fn percentile(mut v: Vec<f32>, q: f32) -> f32 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f32::total_cmp);
    let i = (q.clamp(0.0, 1.0) * (v.len() - 1) as f32).round() as usize;
    v[i]
}

/// The segment a point cloud is stretched along: its principal axis (power iteration on
/// the covariance), from the 5th to the 95th percentile of the points along it.
pub(super) fn principal_segment(points: &[Vec3]) -> (Vec3, Vec3) {
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
    let lo = percentile(t.clone(), AXIS_PERCENTILES[0]);
    let hi = percentile(t, AXIS_PERCENTILES[1]);
    (c + axis * lo, c + axis * hi)
}

/// The way a limb of one part hangs from its joint: toward its skin's centre, else down.
pub(super) fn hang_dir(start: Vec3, group: &[Vec3]) -> Vec3 {
    if group.is_empty() {
        return -Vec3::Y;
    }
    let centre = group.iter().sum::<Vec3>() / group.len() as f32;
    (centre - start).normalize_or(-Vec3::Y)
}
