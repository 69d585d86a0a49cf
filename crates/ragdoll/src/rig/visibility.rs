//! Whether a bone is visible from a vertex through the body: an approximation of Baran and
//! Popović's ray test on a coarse voxel grid instead of the triangles.
//!
//! The surface is rasterised into voxels, the outside is flood-filled from the grid's
//! border, and everything the fill does not reach (the surface and what it encloses) is
//! the body. A segment sees through the body when none of its samples falls in an outside
//! voxel. Gaps between parts of the body narrower than about a voxel are closed (two parts
//! that nearly touch see each other), and a mesh with holes bigger than a voxel lets the
//! fill in, so that nothing is visible: the heat solve then treats every bone as visible
//! (see `heat.rs`).

use glam::Vec3;

/// Voxels along the longest side of the mesh's box: 8 mm on a 1 m dragon, fine enough to part a curled tail from the flank it nearly touches; at most
/// 133³ voxels with the padding, two bytes each while it is built.
const VOXELS: usize = 128;
/// Empty voxels around the mesh's box, so the fill starts outside on every side.
const PAD: usize = 2;
/// Most surface samples rasterised: a few per voxel of surface for any ordinary mesh. A
/// mesh of huge overlapping triangles would need more; it gets no visibility test.
const MAX_SAMPLES: usize = 20_000_000;
/// Samples per voxel along a triangle's edges and along a tested segment.
const SAMPLES_PER_VOXEL: f32 = 3.0;

/// The body as voxels.
pub(super) struct Voxels {
    lo: Vec3,
    size: f32,
    dims: [usize; 3],
    /// Per voxel, x fastest: whether it is outside the body.
    outside: Vec<bool>,
}

impl Voxels {
    /// Voxelises the triangles of `positions` (all finite). `None` when the mesh has no
    /// extent or would need more than [`MAX_SAMPLES`] samples.
    pub fn new(positions: &[Vec3], triangles: &[[u32; 3]]) -> Option<Voxels> {
        let (lo, hi) = positions.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), p| (lo.min(*p), hi.max(*p)),
        );
        let size = (hi - lo).max_element() / VOXELS as f32;
        if !(size > 0.0 && size.is_finite()) {
            return None;
        }
        let lo = lo - Vec3::splat(PAD as f32 * size);
        let dims = ((hi - lo) / size).to_array().map(|d| d as usize + 1 + PAD);
        let mut v = Voxels {
            lo,
            size,
            dims,
            outside: vec![false; dims[0] * dims[1] * dims[2]],
        };
        // Surface voxels first (marked `outside = true` as a "wall" flag, then flipped).
        let step = size / SAMPLES_PER_VOXEL;
        let mut wall = vec![false; v.outside.len()];
        let mut budget = MAX_SAMPLES;
        for t in triangles {
            let [a, b, c] = t.map(|i| positions[i as usize]);
            let longest = a.distance(b).max(b.distance(c)).max(c.distance(a));
            let m = (longest / step).ceil() as usize + 1;
            let samples = (m + 1) * (m + 2) / 2;
            budget = budget.checked_sub(samples)?;
            for i in 0..=m {
                for j in 0..=m - i {
                    let (u, w) = (i as f32 / m as f32, j as f32 / m as f32);
                    if let Some(cell) = v.cell(a + (b - a) * u + (c - a) * w) {
                        wall[cell] = true;
                    }
                }
            }
        }
        // Flood the outside from a corner (inside the padding, so outside), 6-connected.
        let [nx, ny, nz] = dims;
        let mut stack = vec![0usize];
        v.outside[0] = true;
        while let Some(c) = stack.pop() {
            let (x, y, z) = (c % nx, c / nx % ny, c / (nx * ny));
            let mut push = |n: usize| {
                if !wall[n] && !v.outside[n] {
                    v.outside[n] = true;
                    stack.push(n);
                }
            };
            if x > 0 {
                push(c - 1);
            }
            if x + 1 < nx {
                push(c + 1);
            }
            if y > 0 {
                push(c - nx);
            }
            if y + 1 < ny {
                push(c + nx);
            }
            if z > 0 {
                push(c - nx * ny);
            }
            if z + 1 < nz {
                push(c + nx * ny);
            }
        }
        Some(v)
    }

    /// The voxel holding `p`, if it is in the grid.
    fn cell(&self, p: Vec3) -> Option<usize> {
        let q = (p - self.lo) / self.size;
        let [nx, ny, nz] = self.dims;
        let inside = q.x >= 0.0 && q.y >= 0.0 && q.z >= 0.0;
        let (x, y, z) = (q.x as usize, q.y as usize, q.z as usize);
        (inside && x < nx && y < ny && z < nz).then_some(x + nx * (y + ny * z))
    }

    /// Whether the segment `a`–`b` stays in the body (no sample in an outside voxel).
    pub fn sees(&self, a: Vec3, b: Vec3) -> bool {
        let steps = (a.distance(b) / self.size * SAMPLES_PER_VOXEL).ceil() as usize;
        (0..=steps).all(|k| {
            let t = if steps == 0 {
                0.0
            } else {
                k as f32 / steps as f32
            };
            self.cell(a.lerp(b, t)).is_some_and(|c| !self.outside[c])
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A closed box from `lo` to `hi`: 8 corners, 12 triangles.
    fn cube(lo: Vec3, hi: Vec3, base: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let p = (0..8)
            .map(|i| {
                Vec3::new(
                    if i & 1 == 0 { lo.x } else { hi.x },
                    if i & 2 == 0 { lo.y } else { hi.y },
                    if i & 4 == 0 { lo.z } else { hi.z },
                )
            })
            .collect();
        let quads = [
            [0, 1, 3, 2],
            [4, 6, 7, 5],
            [0, 4, 5, 1],
            [2, 3, 7, 6],
            [0, 2, 6, 4],
            [1, 5, 7, 3],
        ];
        let t = quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .map(|t: [u32; 3]| t.map(|i| i + base))
            .collect();
        (p, t)
    }

    #[test]
    fn a_segment_sees_through_a_closed_body_but_not_across_the_air_between_two() {
        let (mut p, mut t) = cube(Vec3::ZERO, Vec3::ONE, 0);
        let (p2, t2) = cube(Vec3::new(1.5, 0.0, 0.0), Vec3::new(2.5, 1.0, 1.0), 8);
        p.extend(p2);
        t.extend(t2);
        let v = Voxels::new(&p, &t).unwrap();
        // Surface to centre inside one box, and along a face.
        assert!(v.sees(Vec3::new(0.0, 0.3, 0.7), Vec3::splat(0.5)));
        assert!(v.sees(Vec3::new(1.0, 0.5, 0.5), Vec3::new(0.5, 0.5, 0.5)));
        // From one box to the other, through 0.5 of air; and out of the grid.
        assert!(!v.sees(Vec3::splat(0.5), Vec3::new(2.0, 0.5, 0.5)));
        assert!(!v.sees(Vec3::splat(0.5), Vec3::splat(10.0)));
        assert!(!v.sees(Vec3::NAN, Vec3::splat(0.5)));
        // Each box's inside is body, the air between them is not: 2 of the 2.5 × 1 × 1
        // box, less the padding (two voxels of 2.5/128 each side): about 0.7.
        let body = v.outside.iter().filter(|&&o| !o).count() as f32 / v.outside.len() as f32;
        assert!((0.6..0.75).contains(&body), "{body}");
    }

    #[test]
    fn an_open_mesh_lets_the_outside_in() {
        // A box without its top: the fill reaches the middle, nothing is seen through it.
        let (p, mut t) = cube(Vec3::ZERO, Vec3::ONE, 0);
        t.retain(|tri| !tri.iter().all(|&i| i & 2 != 0));
        let v = Voxels::new(&p, &t).unwrap();
        assert!(!v.sees(Vec3::new(0.0, 0.5, 0.5), Vec3::splat(0.5)));
    }
}
