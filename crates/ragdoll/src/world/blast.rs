//! Applying blasts to the bodies of a world: for every body part, every collision substep,
//! the exact impulse of the blast load over that substep (`events::blast::part_impulse`),
//! along the direction from the charge, at the part's surface point facing the charge, so
//! the part is pushed and twisted. Each part sees its own arrival time.

use crate::backend::BodyId;
use crate::backend::BodyImpulse;
use glam::{DVec3, Vec3};

use crate::backend::BodyState;
use crate::events::blast::{self, BlastAt};
use crate::events::{Blast, BlastCharacterReport, BlastPartReport, BlastReport};
use crate::spec::Shape;

use crate::error::Result;

/// Drag coefficient of a body part: bluff bodies have C_d ≈ 1…1.3; a
/// standing person's limbs and trunk are close to cylinders across the flow (1.2).
pub(crate) const DRAG_COEFFICIENT: f64 = 1.2;

/// What one part has received so far from one blast.
#[derive(Clone, Debug, Default)]
pub(crate) struct PartRecord {
    pub arrival_s: Option<f64>,
    pub peak_pressure_pa: f64,
    pub impulse: DVec3,
    /// When the positive phase ends at this part (latest estimate), seconds.
    pub passed_s: f64,
}

/// A blast in the world and what it has done.
#[derive(Clone, Debug)]
pub(crate) struct ActiveBlast {
    pub blast: Blast,
    /// `parts[instance][body]`.
    pub parts: Vec<Vec<PartRecord>>,
    /// Centre-of-mass velocity of each instance once the positive phase has passed it.
    pub com_velocity: Vec<Option<Vec3>>,
}

/// Where a blast loads a body part and how: the point the load acts at, the unit direction
/// it pushes, and the share of the part's load that is left as a net push (1 outside).
///
/// Outside the part: its surface point nearest the charge, pushed along the direction from
/// the charge to that point.
///
/// With the charge inside the part, the part is loaded from within: its bulk on the far
/// side of the charge is pushed away from the charge, the rest the other way, and the two
/// cancel for a charge at its centre. So the load acts at the centre, along the direction
/// from the charge to the centre, with the share `d / D` (`d` the charge's distance from
/// the centre, `D` the distance from the centre to the surface through the charge): a full
/// contact load just beneath the surface, continuous with the charge just outside it, and
/// nothing at the centre. Before, such a part took the full load of a contact charge along
/// world up (the one direction always defined): a charge at the pelvis threw the whole
/// body upward, whatever the parts around it received.
pub(crate) fn facing_point(state: &BodyState, shape: &Shape, charge: Vec3) -> (Vec3, Vec3, f64) {
    let pose = &state.pose;
    let local = pose.rotation.conjugate() * (charge - pose.translation);
    let nearest_local = match *shape {
        Shape::Capsule { radius_m, length_m } => {
            let y = local.y.clamp(-0.5 * length_m, 0.5 * length_m);
            let axis_point = Vec3::new(0.0, y, 0.0);
            let out = local - axis_point;
            if out.length() <= radius_m {
                None
            } else {
                Some(axis_point + out.normalize() * radius_m)
            }
        }
        Shape::Box { size_m } => {
            let h = Vec3::from_array(size_m) * 0.5;
            let clamped = local.clamp(-h, h);
            if clamped == local {
                None
            } else {
                Some(clamped)
            }
        }
    };
    match nearest_local {
        Some(p) => {
            let world = pose.transform_point(p);
            let dir = (world - charge).normalize_or(Vec3::Y);
            (world, dir, 1.0)
        }
        None => {
            let offset = local.length();
            let share = if offset > 0.0 {
                (offset / centre_to_surface(shape, local / offset)).min(1.0)
            } else {
                0.0
            };
            let dir = (pose.translation - charge).normalize_or(Vec3::Y);
            (pose.translation, dir, share as f64)
        }
    }
}

/// Distance from a shape's centre to its surface along the unit direction `u` (shape
/// frame), metres.
fn centre_to_surface(shape: &Shape, u: Vec3) -> f32 {
    match *shape {
        Shape::Capsule { radius_m, length_m } => {
            let half = 0.5 * length_m;
            let across = (u.x * u.x + u.z * u.z).sqrt();
            if across * half >= radius_m * u.y.abs() {
                // Leaves through the side.
                radius_m / across
            } else {
                // Through an end cap: |s·u − half·Y| = r.
                let along = u.y.abs();
                half * along
                    + (radius_m * radius_m - half * half * across * across)
                        .max(0.0)
                        .sqrt()
            }
        }
        Shape::Box { size_m } => {
            let h = Vec3::from_array(size_m) * 0.5;
            (0..3)
                .filter(|&k| u[k].abs() > 1e-12)
                .map(|k| h[k] / u[k].abs())
                .fold(f32::INFINITY, f32::min)
        }
    }
}

/// Area of the body's silhouette seen along `dir` (unit), m².
pub(crate) fn projected_area(state: &BodyState, shape: &Shape, dir: Vec3) -> f32 {
    let local = state.pose.rotation.conjugate() * dir;
    match *shape {
        Shape::Capsule { radius_m, length_m } => {
            let sin = (1.0 - local.y * local.y).max(0.0).sqrt();
            2.0 * radius_m * length_m * sin + std::f32::consts::PI * radius_m * radius_m
        }
        Shape::Box { size_m } => {
            let [x, y, z] = size_m;
            y * z * local.x.abs() + x * z * local.y.abs() + x * y * local.z.abs()
        }
    }
}

/// Depth of the body along `dir`, metres: how far the wave travels across it, which sets
/// how long the reflection on its front face lasts.
pub(crate) fn depth_along(state: &BodyState, shape: &Shape, dir: Vec3) -> f32 {
    let local = state.pose.rotation.conjugate() * dir;
    match *shape {
        Shape::Capsule { radius_m, length_m } => length_m * local.y.abs() + 2.0 * radius_m,
        Shape::Box { size_m } => {
            size_m[0] * local.x.abs() + size_m[1] * local.y.abs() + size_m[2] * local.z.abs()
        }
    }
}

/// The blast at a body part now, where and along what it pushes, and the share of its load
/// that is a net push (see [`facing_point`]).
pub(crate) fn blast_on_part(
    blast: &Blast,
    state: &BodyState,
    shape: &Shape,
    ground_y: f32,
) -> (BlastAt, Vec3, Vec3, f64) {
    let (point, dir, share) = facing_point(state, shape, blast.position);
    let at = blast_at_point(blast, loaded_at(blast, point, share), ground_y);
    (at, point, dir, share)
}

/// Where the blast is read for a part loaded at `point` with `share` of its load: there,
/// or, with the charge inside the part, where the charge touches its bulk (the blast of a
/// contact charge).
fn loaded_at(blast: &Blast, point: Vec3, share: f64) -> Vec3 {
    if share < 1.0 { blast.position } else { point }
}

fn blast_at_point(blast: &Blast, at: Vec3, ground_y: f32) -> BlastAt {
    blast::blast_at(
        blast.tnt_kg as f64,
        blast.position.as_dvec3(),
        at.as_dvec3(),
        ground_y as f64,
    )
}

/// [`blast_at_point`]'s arrival and duration alone ([`blast::phase_at`]).
fn phase_at_point(blast: &Blast, at: Vec3, ground_y: f32) -> (f64, f64) {
    blast::phase_at(
        blast.tnt_kg as f64,
        blast.position.as_dvec3(),
        at.as_dvec3(),
        ground_y as f64,
    )
}

impl ActiveBlast {
    /// The report of this blast, with body and character names.
    pub(crate) fn report(&self, body_names: &[Vec<String>], names: &[String]) -> BlastReport {
        let mut parts = Vec::new();
        for (c, bodies) in self.parts.iter().enumerate() {
            for (b, r) in bodies.iter().enumerate() {
                parts.push(BlastPartReport {
                    character: c,
                    body: body_names[c][b].clone(),
                    arrival_s: r.arrival_s,
                    peak_pressure_kpa: r.peak_pressure_pa / 1000.0,
                    impulse_ns: r.impulse.length(),
                });
            }
        }
        let characters = self
            .com_velocity
            .iter()
            .enumerate()
            .map(|(c, v)| BlastCharacterReport {
                character: c,
                name: names[c].clone(),
                com_velocity_mps: v.map(|v| v.to_array()),
            })
            .collect();
        BlastReport {
            tnt_kg: self.blast.tnt_kg,
            position: self.blast.position.to_array(),
            time_s: self.blast.time_s,
            parts,
            characters,
        }
    }
}

impl super::World {
    /// Adds a blast. It acts on every ragdoll in the world, each body part from the moment
    /// the blast front reaches it.
    pub fn add_blast(&mut self, blast: Blast) -> Result<()> {
        blast.validate()?;
        if !super::within_world(blast.position) {
            return Err(super::beyond_world("at", "the charge", blast.position));
        }
        self.blasts.push(ActiveBlast {
            blast,
            parts: Vec::new(),
            com_velocity: Vec::new(),
        });
        Ok(())
    }

    /// What every blast did so far: per body part its arrival time, peak pressure and
    /// momentum received; per character its centre-of-mass velocity once the blast passed.
    pub fn blast_reports(&self) -> Vec<BlastReport> {
        let body_names: Vec<Vec<String>> = self
            .instances
            .iter()
            .map(|i| i.body_names.clone())
            .collect();
        let names: Vec<String> = self.instances.iter().map(|i| i.name.clone()).collect();
        self.blasts
            .iter()
            .map(|b| b.report(&body_names, &names))
            .collect()
    }

    /// Applies every blast's load over `[t0, t1]` (seconds) to every body part.
    pub(super) fn apply_blasts(&mut self, t0: f64, t1: f64) {
        for active in &mut self.blasts {
            let b = active.blast;
            // Without a ground every burst is a free-air burst: put the ground far below.
            let ground = self
                .settings
                .ground
                .unwrap_or(b.position.y - super::FREE_AIR_DEPTH_M);
            let det = b.time_s as f64;
            if t1 <= det {
                continue;
            }
            active
                .parts
                .resize_with(self.instances.len(), Default::default);
            active.com_velocity.resize(self.instances.len(), None);
            for (c, inst) in self.instances.iter().enumerate() {
                if !inst.active || inst.removed {
                    // A clip still playing is not pushed; it may be handed over to physics
                    // on this very blast (`Activation::OnBlast`), before the loads.
                    continue;
                }
                let records = &mut active.parts[c];
                records.resize_with(inst.shapes.len(), Default::default);
                for (k, shape) in inst.shapes.iter().enumerate() {
                    let state = &self.states[inst.first_body + k];
                    let record = &mut records[k];
                    let (point, dir, share) = facing_point(state, shape, b.position);
                    let load_at = loaded_at(&b, point, share);
                    // Most parts, most steps, are not under the positive phase: ask when it
                    // is there before working out the whole blast.
                    let (arrival_s, duration_s) = phase_at_point(&b, load_at, ground);
                    let arrival = det + arrival_s;
                    record.passed_s = arrival + duration_s;
                    if t1 < arrival || t0 > record.passed_s {
                        continue;
                    }
                    let at = blast_at_point(&b, load_at, ground);
                    if record.arrival_s.is_none() {
                        record.arrival_s = Some(arrival);
                        record.peak_pressure_pa = at.reflected_pa;
                    }
                    let area = projected_area(state, shape, dir) as f64;
                    let depth = depth_along(state, shape, dir) as f64;
                    let j = b.scale as f64
                        * share
                        * crate::events::blast::part_impulse(
                            &at,
                            t0 - det,
                            t1 - det,
                            area,
                            depth,
                            DRAG_COEFFICIENT,
                        );
                    if j > 0.0 && j.is_finite() {
                        let impulse = dir.as_dvec3() * j;
                        record.impulse += impulse;
                        self.impulses.push(BodyImpulse::AtPoint {
                            body: BodyId(inst.first_body + k),
                            impulse: impulse.as_vec3(),
                            point,
                        });
                    }
                }
            }
        }
    }

    /// Records each character's centre-of-mass velocity once a blast's positive phase has
    /// passed all of its parts.
    pub(super) fn blast_after_step(&mut self) {
        for active in &mut self.blasts {
            for (c, inst) in self.instances.iter().enumerate() {
                let (Some(records), Some(slot)) =
                    (active.parts.get(c), active.com_velocity.get_mut(c))
                else {
                    continue;
                };
                if slot.is_some()
                    || records.is_empty()
                    || records.iter().any(|r| r.arrival_s.is_none())
                    || records.iter().any(|r| self.time < r.passed_s)
                {
                    continue;
                }
                let mut momentum = Vec3::ZERO;
                let mut mass = 0.0;
                for (k, &m) in inst.masses.iter().enumerate() {
                    momentum += self.states[inst.first_body + k].linvel * m;
                    mass += m;
                }
                *slot = Some(momentum / mass);
            }
        }
    }
}
