//! A pinhole camera that frames the action: fixed for the whole run (so the motion shows
//! against a still background), looking from the front-right and a little above, pulled
//! back just far enough that everything that ever happens stays in the picture.

use glam::{Vec2, Vec3};

/// Vertical field of view, radians (about a 50 mm lens on full frame).
const FOV_Y: f32 = 40.0 * std::f32::consts::PI / 180.0;
/// Nearest distance drawn, metres; triangles closer to the eye than this are dropped.
pub const NEAR: f32 = 0.05;
/// Extra room around the framed box, as a fraction of the fitting distance.
const MARGIN: f32 = 1.08;

/// Where the camera is and how it projects.
#[derive(Clone, Copy, Debug)]
pub struct Camera {
    /// Eye position, world space.
    pub eye: Vec3,
    /// Unit vectors of the view: right, up, and forward (into the picture).
    pub right: Vec3,
    pub up: Vec3,
    pub forward: Vec3,
    /// `tan` of half the horizontal and vertical field of view.
    pub tan_half: Vec2,
    /// Picture size in pixels (of the buffer drawn into).
    pub size: Vec2,
}

impl Camera {
    /// A camera looking along `-back` (unit, pointing from the scene toward the eye) that
    /// fits every ball `(centre, radius)` of `points` into a `width × height` picture,
    /// aimed at the middle of their bounding box.
    pub fn framing(points: &[(Vec3, f32)], back: Vec3, width: f32, height: f32) -> Camera {
        let forward = -back.normalize();
        let right = forward.cross(Vec3::Y).normalize();
        let up = right.cross(forward);
        let tan_y = (FOV_Y * 0.5).tan();
        let tan_half = Vec2::new(tan_y * width / height, tan_y);
        let (lo, hi) = points.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), &(p, _)| (lo.min(p), hi.max(p)),
        );
        let centre = if lo.x <= hi.x {
            (lo + hi) * 0.5
        } else {
            Vec3::ZERO
        };
        // The eye sits at `centre - forward · d`; a point at `centre + rel` is in the
        // picture when |rel·right| ≤ (d + rel·forward)·tan_x, likewise for up, and in front
        // of the near plane when d + rel·forward ≥ NEAR. A ball of radius r needs r / cos
        // more room across (the cos of the half field of view).
        let sec = Vec2::new(
            (1.0 + tan_half.x * tan_half.x).sqrt(),
            (1.0 + tan_half.y * tan_half.y).sqrt(),
        );
        let mut d: f32 = 0.0;
        for &(p, r) in points {
            let rel = p - centre;
            let along = rel.dot(forward);
            d = d
                .max((rel.dot(right).abs() + r * sec.x) / tan_half.x - along)
                .max((rel.dot(up).abs() + r * sec.y) / tan_half.y - along)
                .max(2.0 * NEAR + r - along);
        }
        let d = (d * MARGIN).max(0.5);
        Camera {
            eye: centre - forward * d,
            right,
            up,
            forward,
            tan_half,
            size: Vec2::new(width, height),
        }
    }

    /// The same view drawn into a picture `factor` times larger (supersampling).
    pub fn scaled(&self, factor: f32) -> Camera {
        Camera {
            size: self.size * factor,
            ..*self
        }
    }

    /// A world point in view space: x right, y up, z the distance along the view axis.
    #[inline]
    pub fn view_space(&self, p: Vec3) -> Vec3 {
        let rel = p - self.eye;
        Vec3::new(rel.dot(self.right), rel.dot(self.up), rel.dot(self.forward))
    }

    /// A view-space point (z > 0) on the picture, pixels from the top-left corner.
    #[inline]
    pub fn screen_point(&self, v: Vec3) -> Vec2 {
        let ndc = Vec2::new(v.x, v.y) / (v.z * self.tan_half);
        Vec2::new(
            (ndc.x * 0.5 + 0.5) * self.size.x,
            (0.5 - ndc.y * 0.5) * self.size.y,
        )
    }

    /// The world direction through pixel position `(px, py)`, scaled so its component
    /// along the view axis is 1 (so a hit at `eye + t·dir` lies at view depth `t`).
    #[inline]
    pub fn ray(&self, px: f32, py: f32) -> Vec3 {
        let nx = (px / self.size.x) * 2.0 - 1.0;
        let ny = 1.0 - (py / self.size.y) * 2.0;
        self.forward + self.right * (nx * self.tan_half.x) + self.up * (ny * self.tan_half.y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_corner_of_the_framed_box_lands_inside_the_picture() {
        let (lo, hi) = (Vec3::new(-1.0, 0.0, -0.5), Vec3::new(3.0, 2.0, 0.7));
        let corners: Vec<(Vec3, f32)> = (0..8)
            .map(|i| {
                let c = Vec3::new(
                    if i & 1 == 0 { lo.x } else { hi.x },
                    if i & 2 == 0 { lo.y } else { hi.y },
                    if i & 4 == 0 { lo.z } else { hi.z },
                );
                (c, 0.0)
            })
            .collect();
        let cam = Camera::framing(&corners, Vec3::new(0.5, 0.4, 1.0), 640.0, 480.0);
        let mut touches_edge = false;
        for i in 0..8 {
            let c = Vec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            );
            let v = cam.view_space(c);
            assert!(v.z > NEAR);
            let s = cam.screen_point(v);
            assert!(
                (0.0..=640.0).contains(&s.x) && (0.0..=480.0).contains(&s.y),
                "{s}"
            );
            touches_edge |= s.x < 40.0 || s.x > 600.0 || s.y < 30.0 || s.y > 450.0;
        }
        // Fitted, not merely inside: some corner comes near an edge.
        assert!(touches_edge);
    }

    #[test]
    fn the_ray_through_a_pixel_hits_what_projects_there() {
        let box_ = [(Vec3::ZERO, 0.1), (Vec3::ONE, 0.1)];
        let cam = Camera::framing(&box_, Vec3::new(0.3, 0.5, 1.0), 320.0, 200.0);
        let p = Vec3::new(0.2, 0.7, 0.4);
        let v = cam.view_space(p);
        let s = cam.screen_point(v);
        let hit = cam.eye + cam.ray(s.x, s.y) * v.z;
        assert!((hit - p).length() < 1e-4, "{hit} vs {p}");
    }
}
