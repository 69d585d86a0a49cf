//! The body's centre line: where a spine runs through a bare mesh.

use glam::Vec3;

use crate::math::principal_axes;

/// Share of the body's length, at each end, whose height decides which end is the head.
const END_SHARE: f32 = 0.2;
/// Rounds of the principal-curve fit: the nodes move little after a dozen.
const CURVE_ROUNDS: usize = 20;
/// Passes of [1 2 1] smoothing per round of the fit.
const SMOOTHING_PASSES: usize = 2;

/// Surface samples of a mesh: triangle centroids weighted by triangle area, so a region
/// tessellated finely (a dragon's scales) counts no more than a coarse one of the same
/// size. A mesh without triangles gives its vertices, weight 1 each.
pub(super) fn surface_samples(positions: &[Vec3], indices: &[u32]) -> (Vec<Vec3>, Vec<f32>) {
    let (mut points, mut weights) = (Vec::new(), Vec::new());
    for t in indices.chunks_exact(3) {
        let get = |i: u32| positions.get(i as usize).copied().filter(|p| p.is_finite());
        let (Some(a), Some(b), Some(c)) = (get(t[0]), get(t[1]), get(t[2])) else {
            continue;
        };
        let area = 0.5 * (b - a).cross(c - a).length();
        if area > 0.0 {
            points.push((a + b + c) / 3.0);
            weights.push(area);
        }
    }
    if points.is_empty() {
        points = positions
            .iter()
            .copied()
            .filter(|p| p.is_finite())
            .collect();
        weights = vec![1.0; points.len()];
    }
    (points, weights)
}

/// The body's principal frame: centroid, axes (longest first) and the samples' extent
/// along the first axis.
pub(super) struct Frame {
    pub centroid: Vec3,
    pub axes: [Vec3; 3],
    /// Lowest and highest coordinate of the mesh's vertices along `axes[0]`, from the
    /// centroid.
    pub span: (f32, f32),
}

impl Frame {
    pub fn new(points: &[Vec3], weights: &[f32], vertices: &[Vec3]) -> Frame {
        let (centroid, axes, _) = principal_axes(points, weights);
        let span = vertices
            .iter()
            .filter(|p| p.is_finite())
            .map(|p| (*p - centroid).dot(axes[0]))
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), t| {
                (lo.min(t), hi.max(t))
            });
        Frame {
            centroid,
            axes,
            span,
        }
    }
}

/// A centre line along the principal axis: the weighted centroid of each of `slices` equal
/// slabs across the axis, lightly smoothed, and continued at both ends to the mesh's
/// extremes along the axis. Following slab centroids rather than the straight axis keeps
/// the spine inside a curved body (a dragon's arched neck, a curled tail), where a
/// straight line would leave the mesh.
pub(super) fn principal_polyline(
    frame: &Frame,
    points: &[Vec3],
    weights: &[f32],
    slices: usize,
) -> Vec<Vec3> {
    let axis = frame.axes[0];
    let (lo, hi) = frame.span;
    let width = (hi - lo) / slices as f32;
    let mut sum = vec![Vec3::ZERO; slices];
    let mut mass = vec![0.0f32; slices];
    for (p, &w) in points.iter().zip(weights) {
        let t = (*p - frame.centroid).dot(axis);
        let k = (((t - lo) / width) as usize).min(slices - 1);
        sum[k] += *p * w;
        mass[k] += w;
    }
    let mut line: Vec<Vec3> = sum
        .iter()
        .zip(&mass)
        .filter(|(_, m)| **m > 0.0)
        .map(|(s, m)| *s / *m)
        .collect();
    if line.is_empty() {
        line.push(frame.centroid);
    }
    // One pass of a [1 2 1] filter: slab centroids jitter where a leg or a spike enters
    // a slab; the ends stay where they are.
    if line.len() > 2 {
        let raw = line.clone();
        for i in 1..raw.len() - 1 {
            line[i] = (raw[i - 1] + 2.0 * raw[i] + raw[i + 1]) / 4.0;
        }
    }
    let slide = |p: Vec3, t: f32| p + axis * (t - (p - frame.centroid).dot(axis));
    let first = slide(line[0], lo);
    let last = slide(line[line.len() - 1], hi);
    line.insert(0, first);
    line.push(last);
    line
}

/// How high each end of the body sits: the Y of the weighted centroid of the samples in
/// the end [`END_SHARE`] of its length. Returns (low end, high end) along `frame.axes[0]`.
pub(super) fn end_heights(frame: &Frame, points: &[Vec3], weights: &[f32]) -> (f32, f32) {
    let axis = frame.axes[0];
    let (lo, hi) = frame.span;
    let cut = END_SHARE * (hi - lo);
    let height = |keep: &dyn Fn(f32) -> bool| {
        let (sum, mass) = points
            .iter()
            .zip(weights)
            .filter(|(p, _)| keep((**p - frame.centroid).dot(axis)))
            .fold((0.0, 0.0), |(s, m), (p, w)| (s + p.y * w, m + w));
        if mass > 0.0 {
            sum / mass
        } else {
            f32::NEG_INFINITY
        }
    };
    (height(&|t| t <= lo + cut), height(&|t| t >= hi - cut))
}

/// Pulls a polyline into the middle of the body it threads: Hastie and Stuetzle's principal
/// curve (1989), discretised. Each round, every sample goes to the nearest point of the
/// line and is shared between the two nodes of that segment; each node moves to the mean
/// of what it received and is then smoothed with its neighbours. A straight slab line cuts
/// across a curled body (a dragon's S-shaped neck and tail put two parts of the body in
/// one slab, and their centroid in the air between them); the curve follows the body.
/// The two end nodes stay fixed at the initial line's ends (the body's extremes).
pub(super) fn principal_curve(
    initial: &[Vec3],
    points: &[Vec3],
    weights: &[f32],
    nodes: usize,
) -> Vec<Vec3> {
    let total = length(initial);
    let mut line: Vec<Vec3> = (0..nodes)
        .map(|i| point_at(initial, total * i as f32 / (nodes - 1).max(1) as f32))
        .collect();
    if nodes < 3 || total <= 0.0 {
        return initial.to_vec();
    }
    for _ in 0..CURVE_ROUNDS {
        let mut sum = vec![Vec3::ZERO; nodes];
        let mut mass = vec![0.0f32; nodes];
        for (p, &w) in points.iter().zip(weights) {
            let (seg, t) = nearest_on_line(&line, *p);
            sum[seg] += *p * (w * (1.0 - t));
            mass[seg] += w * (1.0 - t);
            sum[seg + 1] += *p * (w * t);
            mass[seg + 1] += w * t;
        }
        let means: Vec<Vec3> = (0..nodes)
            .map(|k| {
                if mass[k] > 0.0 {
                    sum[k] / mass[k]
                } else {
                    line[k]
                }
            })
            .collect();
        // The ends stay where the slabs put them (the body's extremes along its axis):
        // a free end node would sink to the mean of its cap and drift sideways with it.
        // Then [1 2 1] smoothing, twice: a bending term that keeps the curve from
        // chasing the surface (on a hollow shell of samples, a node a little off the axis
        // sees more of the near wall and would drift further).
        let mut smooth = means;
        for _ in 0..SMOOTHING_PASSES {
            let prev = smooth.clone();
            for k in 1..nodes - 1 {
                smooth[k] = (prev[k - 1] + 2.0 * prev[k] + prev[k + 1]) / 4.0;
            }
        }
        line[1..nodes - 1].copy_from_slice(&smooth[1..nodes - 1]);
    }
    line
}

/// The segment of `line` nearest to `p` and the parameter (0..1, clamped) along it.
fn nearest_on_line(line: &[Vec3], p: Vec3) -> (usize, f32) {
    let mut best = (0, 0.0, f32::INFINITY);
    for (i, w) in line.windows(2).enumerate() {
        let ab = w[1] - w[0];
        let len2 = ab.length_squared();
        let t = if len2 > 0.0 {
            ((p - w[0]).dot(ab) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let d = (w[0] + ab * t).distance_squared(p);
        if d < best.2 {
            best = (i, t, d);
        }
    }
    (best.0, best.1)
}

/// Total length of a polyline.
pub(super) fn length(line: &[Vec3]) -> f32 {
    line.windows(2).map(|w| w[0].distance(w[1])).sum()
}

/// The point at arc length `s` along a polyline (clamped to its ends).
pub(super) fn point_at(line: &[Vec3], s: f32) -> Vec3 {
    let mut left = s.max(0.0);
    for w in line.windows(2) {
        let d = w[0].distance(w[1]);
        if left <= d && d > 0.0 {
            return w[0].lerp(w[1], left / d);
        }
        left -= d;
    }
    *line.last().expect("a polyline has at least one point")
}

/// `count` points evenly spaced by arc length from the start of `line`, the last one a
/// segment short of its end, and the end itself: joint positions and the last joint's tip.
pub(super) fn resample(line: &[Vec3], count: usize) -> (Vec<Vec3>, Vec3) {
    let total = length(line);
    let joints = (0..count)
        .map(|i| point_at(line, total * i as f32 / count as f32))
        .collect();
    (joints, point_at(line, total))
}
