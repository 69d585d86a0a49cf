//! The empty scene, ray-cast once: sky, ground, grid and scorch marks, with what each
//! ground pixel needs to take a shadow later. The camera never moves, so only the shadows
//! change from frame to frame (and the scorch marks, when a blast goes off): drawing a
//! frame's background is a copy plus a shadow lookup where the mask is not empty.

use glam::{Vec2, Vec3};

use crate::camera::Camera;
use crate::{GRID, GROUND, SKY_HORIZON, SKY_ZENITH};

/// The background, per pixel of the (supersampled) buffer.
pub(crate) struct Ground {
    /// How many scorch marks this picture has (`None`: not drawn yet).
    pub scorches: Option<usize>,
    pub color: Vec<Vec3>,
    pub depth: Vec<f32>,
    /// What full shadow takes away from each pixel (zero for the sky).
    pub shade: Vec<Vec3>,
    /// The ground point each pixel shows, (x, z); NaN for the sky.
    pub xz: Vec<Vec2>,
}

impl Ground {
    pub fn empty() -> Ground {
        Ground {
            scorches: None,
            color: Vec::new(),
            depth: Vec::new(),
            shade: Vec::new(),
            xz: Vec::new(),
        }
    }

    pub fn new(cam: &Camera, light: Vec3, scorches: &[(Vec3, f32)], grid: f32) -> Ground {
        let (w, h) = (cam.size.x as usize, cam.size.y as usize);
        let n = w * h;
        let mut g = Ground {
            scorches: Some(scorches.len()),
            color: vec![Vec3::ZERO; n],
            depth: vec![0.0; n],
            shade: vec![Vec3::ZERO; n],
            xz: vec![Vec2::NAN; n],
        };
        // World size of one pixel at unit depth, for filtering the grid lines.
        let pixel = 2.0 * cam.tan_half.y / cam.size.y;
        let fog = 1.0 / (6.0 * (cam.eye.y.abs() + 10.0));
        let sun = light.y;
        let step = cam.right * (2.0 * cam.tan_half.x / cam.size.x);
        for y in 0..h {
            let row = cam.ray(0.5, y as f32 + 0.5);
            for x in 0..w {
                let dir = row + step * x as f32;
                let i = y * w + x;
                let len = dir.length();
                if dir.y >= -1e-4 * len || cam.eye.y <= 0.0 {
                    let s = (dir.y / len).max(0.0).sqrt();
                    g.color[i] = SKY_HORIZON.lerp(SKY_ZENITH, s);
                    continue;
                }
                let depth = -cam.eye.y / dir.y;
                let p = cam.eye + dir * depth;
                let dist = depth * len;
                // Ground width of this pixel: wider the further and the more grazing. The
                // grid lines are box-filtered over it (anti-aliased without supersampling)
                // and fade out where they would shimmer.
                let foot = dist * pixel * len / -dir.y;
                let hw = 0.012 * grid;
                let line = |c: f32| {
                    let c = c / grid;
                    let d = (c - c.round()).abs() * grid;
                    ((hw + 0.5 * foot - d) / foot).clamp(0.0, 1.0) * (2.0 * hw / foot).min(1.0)
                };
                let fade = (1.0 - (foot / grid - 0.04) / 0.12).clamp(0.0, 1.0);
                let mut base = GROUND.lerp(GRID, (line(p.x).max(line(p.z)) * fade).min(1.0) * 0.8);
                for &(c, r) in scorches {
                    let d = ((p.x - c.x).powi(2) + (p.z - c.z).powi(2)).sqrt();
                    if d < r {
                        let k = 1.0 - d / r;
                        base *= 1.0 - 0.75 * (k * k * (3.0 - 2.0 * k));
                    }
                }
                let haze = 1.0 - (-dist * fog).exp();
                let lit = base * (0.42 + 0.62 * sun);
                g.color[i] = lit.lerp(SKY_HORIZON, haze);
                g.shade[i] = base * (0.62 * sun * 0.7 * (1.0 - haze));
                g.depth[i] = 1.0 / depth;
                g.xz[i] = Vec2::new(p.x, p.z);
            }
        }
        g
    }
}
