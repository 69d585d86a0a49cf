//! Bone heat (Baran and Popović 2007, "Automatic Rigging and Animation of 3D Characters"):
//! skin weights that spread over the surface from each bone like heat, so that they
//! follow the body instead of straight-line distance. A vertex on a leg or a curled tail
//! takes no weight from a spine bone it is near only across the air.
//!
//! Per bone `i`, `(−Δ + H) wᵢ = H pᵢ` on the mesh, with `Δ` the cotangent Laplacian
//! (times the vertex areas `M`, so the system `(L + M H) wᵢ = M H pᵢ` is symmetric),
//! `H_jj = 1 / d(j)²` with `d(j)` the distance from vertex `j` to the nearest bone visible
//! from it through the body ([`super::visibility`]), and `pᵢ(j)` 1 when bone `i` is that
//! bone (shared evenly on a tie). The matrix is a sum of non-negative edge weights plus a
//! positive diagonal, so each weight lies in `[0, 1]` and they sum to 1 at every vertex
//! before the four largest are kept.

use std::collections::HashMap;

use glam::{Vec3, Vec4};

use super::cg::{Csr, solve};
use super::visibility::Voxels;
use super::weights::{auto_weights, bone_segments, keep_largest, nearest_on_segment, normalised};
use crate::skeleton::Skeleton;

/// Most distinct vertices (after welding) heat weights are solved for: each costs a row of
/// the sparse system, and the iterations grow with the square root of their number; the
/// 13,600-vertex Stanford dragon takes well under a second. Larger meshes get
/// [`auto_weights`] (decimate a scan first for volume-aware weights).
pub const MAX_HEAT_VERTICES: usize = 150_000;
/// Most welded vertices × joints: finding each vertex's nearest bones and solving for
/// each bone cost about this (the solve times its iterations), so a 512-joint rig on a
/// large mesh falls back to [`auto_weights`] rather than run for minutes.
pub const MAX_HEAT_WORK: usize = 20_000_000;
/// Most triangles heat weights are solved for: each adds three entries to the sparse
/// system while it is assembled (about 50 bytes each); an ordinary mesh has two per vertex.
pub const MAX_HEAT_TRIANGLES: usize = 1_000_000;
/// Iterations of the conjugate-gradient solve before it counts as failed.
const MAX_ITERATIONS: usize = 5_000;
/// Most multiply-adds of all the solves together (matrix entries × bones × iterations),
/// a few seconds: past it the solve counts as failed, whatever the iterations left, and
/// the mesh gets distance weights. The 13,600-vertex dragon spends a small part of it.
const MAX_SOLVE_WORK: usize = 3_000_000_000;
/// Residual the solve stops at, relative to the right-hand side: weights to about 1e-6.
const TOLERANCE: f64 = 1e-7;
/// Bones solved together (they share each pass over the matrix).
const BLOCK: usize = 4;
/// Positions closer than this fraction of the mesh's extent are one vertex (a seam).
const WELD_OF_EXTENT: f32 = 1e-6;
/// A vertex nearer a bone than this fraction of the extent counts as this far: the heat
/// term stays finite on a bone.
const MIN_DISTANCE_OF_EXTENT: f32 = 1e-4;
/// Bones within this factor of the nearest distance share a vertex's heat (a vertex on a
/// joint is as near the bones on both sides).
const TIE: f32 = 1.0001;
/// Largest cotangent an angle contributes: a needle triangle's near-zero angle would
/// otherwise dominate the matrix and stall the solve.
const MAX_COTANGENT: f64 = 1e3;
/// Bones nearest a vertex tried for visibility, nearest first, before it goes without a
/// heat source of its own (its weights then come from its neighbours').
const VISIBILITY_CANDIDATES: usize = 8;

/// Why [`try_heat_weights`] gave no weights.
#[derive(Clone, Debug, PartialEq)]
pub enum NoHeat {
    /// No triangle with three distinct, finite corners: there is no surface to spread on.
    NoTriangles,
    /// More welded vertices, vertices × bones or triangles than [`MAX_HEAT_VERTICES`],
    /// [`MAX_HEAT_WORK`] or [`MAX_HEAT_TRIANGLES`].
    TooLarge {
        /// Distinct vertices after welding.
        vertices: usize,
        /// Joints of the skeleton.
        bones: usize,
    },
    /// The solve did not converge (a system too ill-conditioned for its iterations).
    NotConverged {
        /// Iterations spent.
        iterations: usize,
    },
}

impl std::fmt::Display for NoHeat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            NoHeat::NoTriangles => write!(f, "the mesh has no triangles to spread heat on"),
            NoHeat::TooLarge { vertices, bones } => write!(
                f,
                "{vertices} vertices and {bones} bones are more than the heat solve takes \
                 ({MAX_HEAT_VERTICES} vertices, {MAX_HEAT_WORK} vertices × bones, \
                 {MAX_HEAT_TRIANGLES} triangles)"
            ),
            NoHeat::NotConverged { iterations } => {
                write!(
                    f,
                    "the heat solve did not converge in {iterations} iterations"
                )
            }
        }
    }
}

/// Skin weights for a triangle mesh (`positions` world space, rest pose; `indices` three
/// per triangle) by bone heat, four per vertex, summing to 1.
///
/// Falls back to [`auto_weights`] (inverse squared distance) when heat cannot be solved
/// ([`NoHeat`]): a mesh without triangles (a point cloud has no surface for heat to
/// spread on), one past [`MAX_HEAT_VERTICES`], [`MAX_HEAT_WORK`] or
/// [`MAX_HEAT_TRIANGLES`] (time and memory stay bounded), or a solve that does not
/// converge within its iterations and work. Non-finite positions get joint 0, as
/// there.
///
/// # Example
///
/// ```
/// use ragdoll::{rig::heat_weights, skeleton::humanoid};
///
/// let skeleton = humanoid().skeleton;
/// let positions = [glam::Vec3::new(0.0, 1.0, 0.0), glam::Vec3::new(0.1, 1.0, 0.0), glam::Vec3::new(0.0, 1.1, 0.0)];
/// let (joints, weights) = heat_weights(&skeleton, &positions, &[0, 1, 2]);
/// assert!((weights[0].element_sum() - 1.0).abs() < 1e-5);
/// assert!(joints[0].iter().all(|&j| (j as usize) < skeleton.len()));
/// ```
pub fn heat_weights(
    skeleton: &Skeleton,
    positions: &[Vec3],
    indices: &[u32],
) -> (Vec<[u16; 4]>, Vec<Vec4>) {
    try_heat_weights(skeleton, positions, indices)
        .unwrap_or_else(|_| auto_weights(skeleton, positions))
}

/// [`heat_weights`] without the fallback: why heat could not be solved.
pub fn try_heat_weights(
    skeleton: &Skeleton,
    positions: &[Vec3],
    indices: &[u32],
) -> Result<(Vec<[u16; 4]>, Vec<Vec4>), NoHeat> {
    if indices.len() / 3 > MAX_HEAT_TRIANGLES {
        return Err(NoHeat::TooLarge {
            vertices: positions.len(),
            bones: skeleton.len(),
        });
    }
    let (of_vertex, welded) = weld(positions);
    let triangles = triangles(indices, &of_vertex, &welded);
    if triangles.is_empty() {
        return Err(NoHeat::NoTriangles);
    }
    let n = welded.len();
    let joints = skeleton.len().min(u16::MAX as usize + 1);
    if n > MAX_HEAT_VERTICES || n.saturating_mul(joints) > MAX_HEAT_WORK {
        return Err(NoHeat::TooLarge {
            vertices: n,
            bones: joints,
        });
    }
    let (mut matrix, mass) = laplacian(&welded, &triangles);
    let sources = heat_sources(skeleton, &welded, &triangles, &matrix);
    let heated: Vec<u16> = {
        let mut seen = vec![false; joints];
        sources
            .iter()
            .flat_map(|s| &s.bones)
            .for_each(|&b| seen[b as usize] = true);
        (0..joints as u16).filter(|&b| seen[b as usize]).collect()
    };
    // A = L + M H on the diagonal.
    let mh: Vec<f64> = (0..n).map(|v| mass[v] * sources[v].heat).collect();
    for (v, &add) in mh.iter().enumerate() {
        for e in matrix.start[v]..matrix.start[v + 1] {
            if matrix.col[e] as usize == v {
                matrix.val[e] += add;
            }
        }
    }
    // Per welded vertex, every heated bone's weight, solved a block of bones at a time.
    // The five largest: the fifth is subtracted from the four kept.
    let mut top = vec![[(0u16, 0.0f32); 5]; n];
    let mut work_left = MAX_SOLVE_WORK;
    for block in heated.chunks(BLOCK) {
        let k = block.len();
        let mut rhs = vec![0.0f64; n * k];
        for (v, s) in sources.iter().enumerate() {
            let share = 1.0 / s.bones.len().max(1) as f64;
            for (c, b) in block.iter().enumerate() {
                if s.bones.contains(b) {
                    rhs[v * k + c] = mh[v] * share;
                }
            }
        }
        let per_iteration = (matrix.val.len() * k).max(1);
        let iterations = MAX_ITERATIONS.min(work_left / per_iteration);
        let (x, spent) = solve(&matrix, &rhs, k, TOLERANCE, iterations)
            .map_err(|iterations| NoHeat::NotConverged { iterations })?;
        work_left = work_left.saturating_sub(spent * per_iteration);
        for v in 0..n {
            for (c, &b) in block.iter().enumerate() {
                keep_largest(&mut top[v], b, x[v * k + c] as f32);
            }
        }
    }
    let rows: Vec<Option<([u16; 4], Vec4)>> = top.into_iter().map(four_of_five).collect();
    let distance = auto_weights(skeleton, positions);
    let mut out = (Vec::with_capacity(positions.len()), Vec::new());
    for (i, w) in of_vertex.iter().enumerate() {
        let (j, w) = w
            .and_then(|w| rows[w as usize])
            .unwrap_or((distance.0[i], distance.1[i]));
        out.0.push(j);
        out.1.push(w);
    }
    Ok(out)
}

/// The four largest weights less the fifth, normalised: continuous where two bones swap
/// places as fourth and fifth between neighbouring vertices. Cutting the fifth off
/// outright drops its weight at one vertex and keeps it at the next; in a thick body
/// where five bones share the heat (a dragon's curled torso), that step was 14 % of a
/// vertex's weight moving between bones far apart along the chain, and its edges stretched
/// fivefold. Should all five be equal (nothing would be left), the four are kept as
/// they are.
fn four_of_five(top: [(u16, f32); 5]) -> Option<([u16; 4], Vec4)> {
    let fifth = top[4].1.max(0.0);
    let four = [top[0], top[1], top[2], top[3]].map(|(j, w)| (j, (w - fifth).max(0.0)));
    normalised(four).or_else(|| normalised([top[0], top[1], top[2], top[3]]))
}

/// Welds vertices at one position (within [`WELD_OF_EXTENT`]): seams where a mesh
/// duplicates a vertex for its normals or texture coordinates would otherwise cut the
/// surface, and the two copies take different weights and tear apart. Returns each
/// vertex's welded index (`None` for a non-finite position) and the welded positions.
fn weld(positions: &[Vec3]) -> (Vec<Option<u32>>, Vec<Vec3>) {
    let (lo, hi) = positions.iter().filter(|p| p.is_finite()).fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    let cell = (WELD_OF_EXTENT * (hi - lo).max_element()).max(f32::MIN_POSITIVE);
    let mut index: HashMap<[i64; 3], u32> = HashMap::new();
    let mut welded = Vec::new();
    let of_vertex = positions
        .iter()
        .map(|p| {
            if !p.is_finite() {
                return None;
            }
            let key = ((*p - lo) / cell).round().to_array().map(|c| c as i64);
            Some(*index.entry(key).or_insert_with(|| {
                welded.push(*p);
                welded.len() as u32 - 1
            }))
        })
        .collect();
    (of_vertex, welded)
}

/// The triangles on welded vertices: those with an index out of range, a non-finite
/// corner or two corners welded together are left out.
fn triangles(indices: &[u32], of_vertex: &[Option<u32>], welded: &[Vec3]) -> Vec<[u32; 3]> {
    indices
        .chunks_exact(3)
        .filter_map(|t| {
            let get = |i: u32| of_vertex.get(i as usize).copied().flatten();
            let t = [get(t[0])?, get(t[1])?, get(t[2])?];
            let distinct = t[0] != t[1] && t[1] != t[2] && t[0] != t[2];
            let [a, b, c] = t.map(|i| welded[i as usize]);
            (distinct && (b - a).cross(c - a).length_squared() > 0.0).then_some(t)
        })
        .collect()
}

/// The cotangent stiffness matrix `L` (symmetric, both halves stored, non-negative edge
/// weights: negative cotangents of obtuse angles are clamped to 0, which keeps the solve's
/// weights in `[0, 1]`) and each vertex's area (a third of its triangles', floored so that
/// a vertex on degenerate triangles alone still takes its own heat).
fn laplacian(positions: &[Vec3], triangles: &[[u32; 3]]) -> (Csr, Vec<f64>) {
    let n = positions.len();
    let mut mass = vec![0.0f64; n];
    let mut edges: Vec<(u32, u32, f64)> = Vec::with_capacity(3 * triangles.len());
    for t in triangles {
        let p = t.map(|i| positions[i as usize].as_dvec3());
        let area = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length();
        for k in 0..3 {
            mass[t[k] as usize] += area / 3.0;
            // The angle at corner k weighs the opposite edge.
            let (i, j) = ((k + 1) % 3, (k + 2) % 3);
            let (u, v) = (p[i] - p[k], p[j] - p[k]);
            let cross = u.cross(v).length();
            let cot = if cross > 0.0 { u.dot(v) / cross } else { 0.0 };
            let w = 0.5 * cot.clamp(0.0, MAX_COTANGENT);
            if w > 0.0 {
                edges.push((t[i].min(t[j]), t[i].max(t[j]), w));
            }
        }
    }
    let mean = mass.iter().sum::<f64>() / n as f64;
    for m in &mut mass {
        *m = m.max(1e-3 * mean).max(f64::MIN_POSITIVE);
    }
    edges.sort_unstable_by_key(|e| (e.0, e.1));
    // Merge duplicates (an edge shared by two or more triangles), then both halves.
    let mut merged: Vec<(u32, u32, f64)> = Vec::with_capacity(edges.len());
    for e in edges {
        match merged.last_mut() {
            Some(m) if (m.0, m.1) == (e.0, e.1) => m.2 += e.2,
            _ => merged.push(e),
        }
    }
    let mut count = vec![1usize; n];
    for &(a, b, _) in &merged {
        count[a as usize] += 1;
        count[b as usize] += 1;
    }
    let mut start = vec![0usize; n + 1];
    for v in 0..n {
        start[v + 1] = start[v] + count[v];
    }
    let mut col = vec![0u32; start[n]];
    let mut val = vec![0.0f64; start[n]];
    let mut fill = start.clone();
    for v in 0..n {
        col[fill[v]] = v as u32;
        fill[v] += 1;
    }
    for &(a, b, w) in &merged {
        for (r, c) in [(a, b), (b, a)] {
            col[fill[r as usize]] = c;
            val[fill[r as usize]] = -w;
            fill[r as usize] += 1;
            val[start[r as usize]] += w;
        }
    }
    (Csr { start, col, val }, mass)
}

/// A vertex's heat source: `H_jj` and the bones `p` names.
struct Source {
    heat: f64,
    bones: Vec<u16>,
}

/// Each vertex's nearest visible bones and heat `1 / d²`. Where the voxel test finds no
/// visible bone for any vertex of a connected part (the mesh is open and the outside
/// leaked in, or its bones lie outside it), that part uses the nearest bones regardless:
/// a part without heat would leave the system singular.
fn heat_sources(
    skeleton: &Skeleton,
    positions: &[Vec3],
    triangles: &[[u32; 3]],
    matrix: &Csr,
) -> Vec<Source> {
    let segments = bone_segments(skeleton);
    let joints = skeleton.len().min(u16::MAX as usize + 1);
    let voxels = Voxels::new(positions, triangles);
    let (lo, hi) = positions.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    let min_d = (MIN_DISTANCE_OF_EXTENT * (hi - lo).length()).max(f32::MIN_POSITIVE);
    // The heat distance is at least the vertex's own edge length: a vertex that lies on
    // a bone (one grazing the surface, on a coarse mesh) would otherwise be pinned to it
    // alone while its neighbours share, a one-vertex spike in the weights.
    let spacing = edge_lengths(positions, triangles);
    let source = |v: usize, d: f32, bones: Vec<u16>| Source {
        heat: 1.0 / (d.max(spacing[v]).max(min_d) as f64).powi(2),
        bones,
    };
    // Per vertex, each joint's nearest point and distance, nearest joints first.
    let mut nearest = vec![(f32::INFINITY, Vec3::ZERO); joints];
    let mut blind = Vec::new();
    let mut sources: Vec<Source> = positions
        .iter()
        .enumerate()
        .map(|(v, &p)| {
            nearest.fill((f32::INFINITY, Vec3::ZERO));
            for &(j, a, b) in &segments {
                let q = nearest_on_segment(p, a, b);
                let d = q.distance(p);
                if d < nearest[j as usize].0 {
                    nearest[j as usize] = (d, q);
                }
            }
            let mut order: Vec<u16> = (0..joints as u16).collect();
            let by_distance =
                |a: &u16, b: &u16| nearest[*a as usize].0.total_cmp(&nearest[*b as usize].0);
            if order.len() > VISIBILITY_CANDIDATES {
                order.select_nth_unstable_by(VISIBILITY_CANDIDATES, by_distance);
            }
            let head = order.len().min(VISIBILITY_CANDIDATES + 1);
            order[..head].sort_by(by_distance);
            let ties = |within: &[u16]| -> (f32, Vec<u16>) {
                let d = nearest[within[0] as usize].0;
                let bones = within
                    .iter()
                    .copied()
                    .filter(|&b| nearest[b as usize].0 <= d * TIE + min_d * 1e-3)
                    .collect();
                (d, bones)
            };
            let visible: Vec<u16> = order
                .iter()
                .take(VISIBILITY_CANDIDATES)
                .copied()
                .filter(|&b| {
                    voxels
                        .as_ref()
                        .is_none_or(|vx| vx.sees(p, nearest[b as usize].1))
                })
                .collect();
            // The nearest regardless, kept for a part with no visible bone at all.
            blind.push(ties(&order));
            if visible.is_empty() {
                Source {
                    heat: 0.0,
                    bones: Vec::new(),
                }
            } else {
                let (d, bones) = ties(&visible);
                source(v, d, bones)
            }
        })
        .collect();
    for part in components(matrix) {
        if part.iter().all(|&v| sources[v].heat == 0.0) {
            for v in part {
                let (d, bones) = std::mem::take(&mut blind[v]);
                sources[v] = source(v, d, bones);
            }
        }
    }
    sources
}

/// Each vertex's mean edge length over its triangles.
fn edge_lengths(positions: &[Vec3], triangles: &[[u32; 3]]) -> Vec<f32> {
    let mut sum = vec![(0.0f32, 0u32); positions.len()];
    for t in triangles {
        for k in 0..3 {
            let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
            let len = positions[a].distance(positions[b]);
            for v in [a, b] {
                sum[v].0 += len;
                sum[v].1 += 1;
            }
        }
    }
    sum.iter()
        .map(|&(s, n)| if n > 0 { s / n as f32 } else { 0.0 })
        .collect()
}

/// The connected parts of the matrix's graph, as lists of vertices.
fn components(matrix: &Csr) -> Vec<Vec<usize>> {
    let n = matrix.start.len() - 1;
    let mut seen = vec![false; n];
    let mut parts = Vec::new();
    for s in 0..n {
        if seen[s] {
            continue;
        }
        seen[s] = true;
        let mut part = vec![s];
        let mut k = 0;
        while k < part.len() {
            let v = part[k];
            k += 1;
            for e in matrix.start[v]..matrix.start[v + 1] {
                let c = matrix.col[e] as usize;
                if !seen[c] {
                    seen[c] = true;
                    part.push(c);
                }
            }
        }
        parts.push(part);
    }
    parts
}
