//! The one rasteriser: triangles and lines into a colour buffer with a z-buffer, so what is
//! nearer hides what is behind whatever order things are drawn in. Depth is stored as
//! `1 / view distance` (it interpolates linearly across the screen; 0 is infinitely far).

use glam::{Vec2, Vec3};

/// A colour buffer and its z-buffer.
pub struct Target {
    pub width: usize,
    pub height: usize,
    /// Linear RGB in 0..1, row by row from the top.
    pub color: Vec<Vec3>,
    /// `1 / view distance` of what each pixel shows; 0 for the sky.
    pub depth: Vec<f32>,
}

impl Target {
    pub fn new(width: usize, height: usize) -> Target {
        Target {
            width,
            height,
            color: vec![Vec3::ZERO; width * height],
            depth: vec![0.0; width * height],
        }
    }

    /// Fills a triangle given in screen space (`xy` pixels, `z` = 1/view distance) with
    /// colours blended from its corners, keeping only pixels nearer than what is there.
    pub fn triangle(&mut self, p: [Vec3; 3], c: [Vec3; 3]) {
        let (w, color, depth) = (self.width, &mut self.color, &mut self.depth);
        cover(
            self.width,
            self.height,
            [p[0].truncate(), p[1].truncate(), p[2].truncate()],
            |x, y, b| {
                let z = b[0] * p[0].z + b[1] * p[1].z + b[2] * p[2].z;
                let i = y * w + x;
                if z > depth[i] {
                    depth[i] = z;
                    color[i] = c[0] * b[0] + c[1] * b[1] + c[2] * b[2];
                }
            },
        );
    }

    /// A line `width` pixels thick between two screen points (`z` = 1/view distance),
    /// depth-tested against what is drawn, with a small bias so a line lying on a surface
    /// still shows.
    pub fn line(&mut self, a: Vec3, b: Vec3, color: Vec3, width: f32) {
        let len = (b.truncate() - a.truncate()).length();
        let steps = (len.ceil() as usize).clamp(1, 20_000);
        let r = (width * 0.5).max(0.5);
        let ri = r.ceil() as i64;
        for s in 0..=steps {
            let t = s as f32 / steps as f32;
            let p = a.lerp(b, t);
            if !p.is_finite() {
                continue;
            }
            let (cx, cy) = (p.x.floor() as i64, p.y.floor() as i64);
            for y in cy - ri..=cy + ri {
                for x in cx - ri..=cx + ri {
                    if x < 0 || y < 0 || x >= self.width as i64 || y >= self.height as i64 {
                        continue;
                    }
                    let d = Vec2::new(x as f32 + 0.5 - p.x, y as f32 + 0.5 - p.y);
                    if d.length_squared() > r * r {
                        continue;
                    }
                    let i = y as usize * self.width + x as usize;
                    if p.z * 1.02 >= self.depth[i] {
                        self.color[i] = color;
                    }
                }
            }
        }
    }
}

/// Calls `f(x, y, barycentric)` for every pixel whose centre lies inside the triangle `p`
/// (either winding), clipped to `width × height`. Degenerate triangles cover nothing.
#[inline(always)]
pub fn cover(width: usize, height: usize, p: [Vec2; 3], mut f: impl FnMut(usize, usize, [f32; 3])) {
    let area = (p[1] - p[0]).perp_dot(p[2] - p[0]);
    if area.abs() < 1e-12 || !area.is_finite() {
        return;
    }
    let inv = 1.0 / area;
    let lo = p[0].min(p[1]).min(p[2]);
    let hi = p[0].max(p[1]).max(p[2]);
    let x0 = (lo.x - 0.5).ceil().max(0.0) as usize;
    let y0 = (lo.y - 0.5).ceil().max(0.0) as usize;
    let x1 = ((hi.x - 0.5).floor() as i64).min(width as i64 - 1);
    let y1 = ((hi.y - 0.5).floor() as i64).min(height as i64 - 1);
    if x1 < x0 as i64 || y1 < y0 as i64 {
        return;
    }
    let (x1, y1) = (x1 as usize, y1 as usize);
    // Barycentric weights are affine in the pixel position: step them along each row.
    let edge = |a: Vec2, b: Vec2, q: Vec2| (b - a).perp_dot(q - a) * inv;
    let start = Vec2::new(x0 as f32 + 0.5, y0 as f32 + 0.5);
    let w0 = edge(p[1], p[2], start);
    let w1 = edge(p[2], p[0], start);
    let dx = Vec3::new(
        -(p[2].y - p[1].y) * inv,
        -(p[0].y - p[2].y) * inv,
        -(p[1].y - p[0].y) * inv,
    );
    let dy = Vec3::new(
        (p[2].x - p[1].x) * inv,
        (p[0].x - p[2].x) * inv,
        (p[1].x - p[0].x) * inv,
    );
    let mut row = Vec3::new(w0, w1, 1.0 - w0 - w1);
    for y in y0..=y1 {
        let mut b = row;
        for x in x0..=x1 {
            // A small tolerance closes hairline cracks between triangles sharing an edge.
            if b.x >= -1e-6 && b.y >= -1e-6 && b.z >= -1e-6 {
                f(x, y, [b.x, b.y, b.z]);
            }
            b += dx;
        }
        row += dy;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_triangles_sharing_an_edge_cover_every_pixel_once() {
        let mut count = vec![0u32; 64 * 64];
        let (a, b, c, d) = (
            Vec2::new(3.2, 4.1),
            Vec2::new(60.3, 7.7),
            Vec2::new(55.9, 58.2),
            Vec2::new(1.1, 50.4),
        );
        for tri in [[a, b, c], [a, d, c]] {
            cover(64, 64, tri, |x, y, _| count[y * 64 + x] += 1);
        }
        assert!(count.iter().all(|&n| n <= 1), "a pixel was drawn twice");
        // The quad's area in pixels, give or take its boundary.
        let covered = count.iter().filter(|&&n| n == 1).count() as f32;
        let quad = 0.5 * ((b - a).perp_dot(c - a).abs() + (c - a).perp_dot(d - a).abs());
        assert!((covered - quad).abs() < 0.05 * quad, "{covered} vs {quad}");
    }

    #[test]
    fn the_nearer_triangle_wins_in_either_order() {
        for near_first in [true, false] {
            let mut t = Target::new(8, 8);
            let quad = |z: f32| {
                [
                    Vec3::new(0.0, 0.0, z),
                    Vec3::new(8.0, 0.0, z),
                    Vec3::new(0.0, 8.0, z),
                ]
            };
            let (near, far) = ((quad(0.5), Vec3::X), (quad(0.25), Vec3::Y));
            let order = if near_first { [near, far] } else { [far, near] };
            for (p, c) in order {
                t.triangle(p, [c; 3]);
            }
            assert_eq!(t.color[8 + 1], Vec3::X);
        }
    }
}
