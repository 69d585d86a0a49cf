//! Soft shadows on the ground: every triangle is projected along the sunlight onto the
//! plane y = 0 and rasterised into a coverage mask over the ground, which is then blurred
//! (two box passes each way, close to a Gaussian). The ground shader reads the mask, so
//! shadows soften at their edges the way a sun of finite size makes them, for the cost of
//! drawing the silhouette once more.

use glam::{Vec2, Vec3};

use crate::raster::cover;

/// Cells along each side of the mask.
const CELLS: usize = 256;
/// Width of the penumbra the blur gives, metres.
const SOFTNESS_M: f32 = 0.05;

/// The shadow mask over a square of ground.
pub struct ShadowMask {
    /// World x, z of the mask's corner cell's corner.
    origin: Vec2,
    /// Metres per cell.
    cell: f32,
    /// Unit direction toward the sun.
    light: Vec3,
    blur: usize,
    /// Ground rectangle (x, z) outside which the mask is zero; `None` when it is all zero.
    bounds: Option<(Vec2, Vec2)>,
    mask: Vec<f32>,
    scratch: Vec<f32>,
}

impl ShadowMask {
    /// A mask covering the ground under the box `lo..hi` as lit by `light` (unit, toward
    /// the sun, pointing up).
    pub fn new(lo: Vec3, hi: Vec3, light: Vec3) -> ShadowMask {
        // Where the box's corners cast their shadows, plus room for the blur.
        let mut a = Vec2::splat(f32::INFINITY);
        let mut b = Vec2::splat(f32::NEG_INFINITY);
        for i in 0..8 {
            let c = Vec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            );
            let g = ground_point(c, light);
            a = a.min(g);
            b = b.max(g);
        }
        let side = (b - a).max_element() + 0.5;
        let cell = side / CELLS as f32;
        let origin = (a + b) * 0.5 - Vec2::splat(side * 0.5);
        ShadowMask {
            origin,
            cell,
            light,
            blur: ((SOFTNESS_M / cell).round() as usize).clamp(1, 8),
            bounds: None,
            mask: vec![0.0; CELLS * CELLS],
            scratch: vec![0.0; CELLS * CELLS],
        }
    }

    /// Forgets the last frame's shadows.
    pub fn clear(&mut self) {
        self.mask.fill(0.0);
        self.bounds = None;
    }

    /// The ground rectangle, (x, z) corners, outside which nothing is shadowed.
    pub fn bounds(&self) -> Option<(Vec2, Vec2)> {
        self.bounds
    }

    /// Adds the shadow of a triangle mesh.
    pub fn cast(&mut self, positions: &[Vec3], indices: &[u32]) {
        let to_cell = |p: Vec3| (ground_point(p, self.light) - self.origin) / self.cell;
        let mask = &mut self.mask;
        for t in indices.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| to_cell(positions[i as usize]));
            cover(CELLS, CELLS, [a, b, c], |x, y, _| mask[y * CELLS + x] = 1.0);
        }
    }

    /// Blurs the mask; call once after every caster has been added.
    pub fn soften(&mut self) {
        let (mut lo, mut hi) = ((CELLS, CELLS), (0, 0));
        for (k, &m) in self.mask.iter().enumerate() {
            if m > 0.0 {
                let (x, y) = (k % CELLS, k / CELLS);
                lo = (lo.0.min(x), lo.1.min(y));
                hi = (hi.0.max(x), hi.1.max(y));
            }
        }
        self.bounds = (lo.0 <= hi.0).then(|| {
            // Two blur passes spread the mask by twice the radius; one cell more for the
            // bilinear lookup.
            let grow = 2.0 * self.blur as f32 + 1.0;
            let a = Vec2::new(lo.0 as f32, lo.1 as f32) - grow;
            let b = Vec2::new(hi.0 as f32 + 1.0, hi.1 as f32 + 1.0) + grow;
            (self.origin + a * self.cell, self.origin + b * self.cell)
        });
        for _ in 0..2 {
            box_blur(&self.mask, &mut self.scratch, self.blur, 1, CELLS);
            box_blur(&self.scratch, &mut self.mask, self.blur, CELLS, 1);
        }
    }

    /// How much of the sun is hidden at ground point `(x, z)`: 0 (lit) to 1 (in shadow),
    /// bilinear between cells.
    #[inline]
    pub fn at(&self, x: f32, z: f32) -> f32 {
        let g = (Vec2::new(x, z) - self.origin) / self.cell - 0.5;
        if !(g.x >= 0.0 && g.y >= 0.0) {
            return 0.0;
        }
        let (i, j) = (g.x as usize, g.y as usize);
        if i + 1 >= CELLS || j + 1 >= CELLS {
            return 0.0;
        }
        let (fx, fy) = (g.x - i as f32, g.y - j as f32);
        let m = |i: usize, j: usize| self.mask[j * CELLS + i];
        let top = m(i, j) + (m(i + 1, j) - m(i, j)) * fx;
        let bottom = m(i, j + 1) + (m(i + 1, j + 1) - m(i, j + 1)) * fx;
        top + (bottom - top) * fy
    }
}

/// Where the sunbeam through `p` meets the ground, as (x, z).
#[inline]
fn ground_point(p: Vec3, light: Vec3) -> Vec2 {
    let g = p - light * (p.y / light.y);
    Vec2::new(g.x, g.z)
}

/// One box-blur pass of radius `r` along lines of `CELLS` cells `stride` apart, lines
/// starting `step` apart: `(1, CELLS)` blurs rows, `(CELLS, 1)` columns.
fn box_blur(src: &[f32], dst: &mut [f32], r: usize, stride: usize, step: usize) {
    let norm = 1.0 / (2 * r + 1) as f32;
    for line in 0..CELLS {
        let base = line * step;
        let at = |k: i64| {
            if k < 0 || k >= CELLS as i64 {
                0.0
            } else {
                src[base + k as usize * stride]
            }
        };
        let mut sum: f32 = (-(r as i64)..=r as i64).map(at).sum();
        for k in 0..CELLS as i64 {
            dst[base + k as usize * stride] = sum * norm;
            sum += at(k + r as i64 + 1) - at(k - r as i64);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_square_overhead_casts_a_soft_square_shadow_below_it() {
        let light = Vec3::Y;
        let mut s = ShadowMask::new(Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 1.0, 1.0), light);
        let y = 1.0;
        let quad = [
            Vec3::new(-0.5, y, -0.5),
            Vec3::new(0.5, y, -0.5),
            Vec3::new(0.5, y, 0.5),
            Vec3::new(-0.5, y, 0.5),
        ];
        s.cast(&quad, &[0, 1, 2, 0, 2, 3]);
        s.soften();
        assert!(s.at(0.0, 0.0) > 0.99);
        assert!(s.at(0.9, 0.0) < 0.01);
        // At the edge, half in shadow: the penumbra.
        let edge = s.at(0.5, 0.0);
        assert!((0.3..0.7).contains(&edge), "{edge}");
        // A slanted sun moves the shadow away from it.
        let slant = Vec3::new(1.0, 1.0, 0.0).normalize();
        let mut t = ShadowMask::new(Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 1.0, 1.0), slant);
        t.cast(&quad, &[0, 1, 2, 0, 2, 3]);
        t.soften();
        assert!(t.at(-1.0, 0.0) > 0.99 && t.at(0.3, 0.0) < 0.01);
    }
}
