//! Projectiles: a shot is a ray cast at its time and an impulse where it hits (flight
//! time is not simulated), with a report of what it hit.

use super::{Activation, World, beyond_world, within_world};
use crate::backend::{Backend, BodyImpulse};
use crate::error::Result;
use crate::events::{Projectile, ProjectileReport};

impl World {
    /// Adds a projectile; it hits at its time (see [`Projectile`]).
    pub fn add_projectile(&mut self, projectile: Projectile) -> Result<()> {
        projectile.validate()?;
        if !within_world(projectile.origin) {
            return Err(beyond_world(
                "from",
                "the projectile's origin",
                projectile.origin,
            ));
        }
        self.projectiles.push((projectile, None));
        Ok(())
    }

    /// What every projectile fired so far hit.
    pub fn projectile_reports(&self) -> Vec<ProjectileReport> {
        self.projectiles
            .iter()
            .filter_map(|(_, r)| r.clone())
            .collect()
    }

    /// Fires the projectiles whose time has come by `t1`.
    pub(super) fn fire_projectiles(&mut self, t1: f64) {
        /// Projectiles fly at most this far, metres.
        const RANGE_M: f32 = 1.0e4;
        for k in 0..self.projectiles.len() {
            let (p, done) = &self.projectiles[k];
            let t = p.time_s as f64;
            if done.is_some() || t >= t1 {
                continue;
            }
            let p = *p;
            let dir = p.direction.normalize();
            let momentum = p.mass_kg * p.speed_mps;
            let mut report = ProjectileReport {
                time_s: p.time_s,
                origin: p.origin.to_array(),
                character: None,
                body: None,
                point: None,
                impulse_ns: 0.0,
            };
            if let Some((hit, dist)) = self.backend.cast_ray(p.origin, dir, RANGE_M) {
                let body = hit.0;
                let point = p.origin + dir * dist;
                // A character waiting for contact is handed over before the hit lands (a
                // clip-driven body would not feel it).
                let owner = self
                    .instances
                    .iter()
                    .position(|i| (i.first_body..i.first_body + i.shapes.len()).contains(&body));
                if let Some(c) = owner
                    && !self.instances[c].active
                    && self.instances[c].activation == Activation::OnContact
                {
                    let h = self.settings.dt as f64 / self.outer_steps() as f64;
                    self.hand_over(c, t1, h);
                }
                self.impulses.push(BodyImpulse::AtPoint {
                    body: hit,
                    impulse: dir * momentum,
                    point,
                });
                if let Some((c, inst)) =
                    self.instances.iter().enumerate().find(|(_, i)| {
                        (i.first_body..i.first_body + i.shapes.len()).contains(&body)
                    })
                {
                    report.character = Some(c);
                    report.body = Some(inst.body_names[body - inst.first_body].clone());
                }
                report.point = Some(point.to_array());
                report.impulse_ns = momentum;
            }
            self.projectiles[k].1 = Some(report);
        }
    }
}
