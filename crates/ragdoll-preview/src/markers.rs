//! Blasts and shots drawn where and when they happen: a charge waiting, a fireball with
//! sparks, a scorch mark (drawn by the ground); a tracer and a spark at the hit.

use glam::Vec3;

use crate::camera::NEAR;
use crate::mesh::{draw_flat, draw_lit};
use crate::{Marker, Preview};

impl Preview<'_> {
    /// The blasts that have gone off by time `t` and sit low enough to scorch the ground:
    /// centre and radius.
    pub(crate) fn scorches(&self, t: f32) -> Vec<(Vec3, f32)> {
        self.markers
            .iter()
            .filter_map(|m| match *m {
                Marker::Blast {
                    position,
                    time_s,
                    tnt_kg,
                } if t >= time_s && position.y < fireball_radius(tnt_kg) => {
                    Some((position, 0.8 * fireball_radius(tnt_kg)))
                }
                _ => None,
            })
            .collect()
    }

    pub(crate) fn draw_markers(&mut self, t: f32) {
        for m in self.markers.clone() {
            match m {
                Marker::Blast {
                    position,
                    time_s,
                    tnt_kg,
                } => {
                    let tau = t - time_s;
                    if tau < 0.0 {
                        self.draw_charge(position, tnt_kg);
                    } else if tau < 0.45 {
                        let r = self.draw_fireball(position, fireball_radius(tnt_kg), tau);
                        if tau < 0.2 {
                            self.draw_sparks(position, r);
                        }
                    }
                }
                Marker::Shot {
                    origin,
                    end,
                    time_s,
                    hit,
                } => self.draw_shot(origin, end, hit, t - time_s),
            }
        }
    }

    /// The charge, waiting: a dark cube sized by its mass.
    fn draw_charge(&mut self, position: Vec3, tnt_kg: f32) {
        let s = 0.06 * tnt_kg.cbrt().clamp(0.5, 3.0);
        let pos: Vec<Vec3> = self.cube.0.iter().map(|&v| position + v * s).collect();
        let nrm = self.cube.0.clone();
        draw_lit(
            &mut self.target,
            &self.camera,
            self.light,
            &pos,
            &nrm,
            &self.cube.1,
            |_| Vec3::new(0.35, 0.12, 0.1),
            &mut self.screen,
            &mut self.shade,
        );
    }

    /// A ragged fireball `tau` seconds after the blast that swells in 50 ms, then cools and
    /// fades; returns the radius drawn.
    fn draw_fireball(&mut self, position: Vec3, radius: f32, tau: f32) -> f32 {
        let grow = (tau / 0.05).min(1.0);
        let r = radius * grow * (1.0 + 0.4 * tau);
        let heat = (tau / 0.45).clamp(0.0, 1.0);
        let core = Vec3::new(1.0, 0.96, 0.75)
            .lerp(Vec3::new(1.0, 0.55, 0.12), (heat * 3.0).min(1.0))
            .lerp(Vec3::new(0.32, 0.28, 0.26), ((heat - 0.35) / 0.65).max(0.0));
        let pos: Vec<Vec3> = self
            .sphere
            .0
            .iter()
            .enumerate()
            .map(|(k, &v)| position + v * r * (0.8 + 0.4 * hash(k)))
            .collect();
        // Mottled: each vertex between the core colour and a deeper orange.
        let deep = core * Vec3::new(0.95, 0.55, 0.35);
        let colors: Vec<Vec3> = (0..pos.len())
            .map(|k| core.lerp(deep, hash(k + 101)))
            .collect();
        self.draw_sphere(&pos, &colors);
        r
    }

    /// Sparks flying out of a fireball of radius `r`.
    fn draw_sparks(&mut self, position: Vec3, r: f32) {
        let ss = self.ss as f32;
        let spark = Vec3::new(1.0, 0.85, 0.35);
        let dirs: Vec<Vec3> = self.sphere.0.iter().step_by(4).copied().collect();
        for (k, d) in dirs.into_iter().enumerate() {
            let a = position + d * r * 0.9;
            let b = position + d * r * (1.4 + 0.8 * hash(k + 7));
            self.line(a, b, spark, 1.5 * ss);
        }
    }

    /// A shot `tau` seconds after it was fired: its tracer, and a red flash where it hit.
    fn draw_shot(&mut self, origin: Vec3, end: Vec3, hit: bool, tau: f32) {
        let ss = self.ss as f32;
        if (-0.1..=0.25).contains(&tau) {
            self.line(origin, end, Vec3::new(1.0, 0.9, 0.3), 1.5 * ss);
        }
        if hit && (0.0..=0.3).contains(&tau) {
            let pos: Vec<Vec3> = self.sphere.0.iter().map(|&v| end + v * 0.05).collect();
            let colors = vec![Vec3::new(1.0, 0.3, 0.15); pos.len()];
            self.draw_sphere(&pos, &colors);
        }
    }

    /// The marker sphere's triangles over the vertices `pos`, flat, one colour a vertex.
    fn draw_sphere(&mut self, pos: &[Vec3], colors: &[Vec3]) {
        draw_flat(
            &mut self.target,
            &self.camera,
            pos,
            &self.sphere.1,
            colors,
            &mut self.screen,
        );
    }

    fn line(&mut self, a: Vec3, b: Vec3, color: Vec3, width: f32) {
        let (va, vb) = (self.camera.view_space(a), self.camera.view_space(b));
        if va.z < NEAR || vb.z < NEAR {
            return;
        }
        let sa = self.camera.screen_point(va).extend(1.0 / va.z);
        let sb = self.camera.screen_point(vb).extend(1.0 / vb.z);
        self.target.line(sa, sb, color, width);
    }
}

/// Fireball radius, metres, for a charge of `tnt_kg`: half a metre per ∛kg (an artistic
/// size, not a physical one; the blast's reach is far larger).
pub(crate) fn fireball_radius(tnt_kg: f32) -> f32 {
    0.5 * tnt_kg.max(0.0).cbrt().clamp(0.2, 20.0)
}

/// A repeatable pseudo-random number in 0..1 for `k`.
fn hash(k: usize) -> f32 {
    let mut x = (k as u32).wrapping_mul(0x9E37_79B9) ^ 0x85EB_CA6B;
    x ^= x >> 15;
    x = x.wrapping_mul(0x2C1B_3C6D);
    x ^= x >> 12;
    (x & 0xFFFF) as f32 / 65535.0
}
