//! Applying blasts to the bodies of a world: for every body part, every collision substep,
//! the exact impulse of the blast load over that substep (`events::blast::part_impulse`),
//! along the direction from the charge, at the part's surface point facing the charge, so
//! the part is pushed and twisted. Each part sees its own arrival time.

use glam::{DVec3, Vec3};

use crate::backend::BodyState;
use crate::events::blast::{self, BlastAt};
use crate::events::{Blast, BlastCharacterReport, BlastPartReport, BlastReport};
use crate::spec::Shape;

/// Drag coefficient of a body part: DESIGN §7 gives C_d ≈ 1…1.3 for bluff bodies; a
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

/// The point of a body's surface nearest the charge, and the unit direction from the
/// charge to the body (the direction the load pushes). A charge inside the body pushes
/// from the body's centre outward along world up, the one direction that is always
/// defined.
pub(crate) fn facing_point(state: &BodyState, shape: &Shape, charge: Vec3) -> (Vec3, Vec3) {
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
            (world, dir)
        }
        None => {
            let dir = (pose.translation - charge).normalize_or(Vec3::Y);
            (pose.translation, dir)
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

/// The blast at a body part now, and where and along what it pushes.
pub(crate) fn blast_on_part(
    blast: &Blast,
    state: &BodyState,
    shape: &Shape,
    ground_y: f32,
) -> (BlastAt, Vec3, Vec3) {
    let (point, dir) = facing_point(state, shape, blast.position);
    let at = blast::blast_at(
        blast.tnt_kg as f64,
        blast.position.as_dvec3(),
        point.as_dvec3(),
        ground_y as f64,
    );
    (at, point, dir)
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
