//! Pushes, fields and pins (DESIGN §4): what they do to the bodies over one substep.

use glam::Vec3;

use crate::events::{Field, Pin, Push};

/// Air density at sea level, kg/m³ (ISA).
pub(crate) const AIR_DENSITY: f32 = 1.225;

/// A push resolved onto a body: global body index and the point in the body's frame.
#[derive(Clone, Debug)]
pub(crate) struct ActivePush {
    pub push: Push,
    pub body: usize,
    pub local: Vec3,
    pub done: bool,
}

/// A pin resolved onto a body.
#[derive(Clone, Debug)]
pub(crate) struct ActivePin {
    pub pin: Pin,
    pub body: usize,
    pub local: Vec3,
    /// The backend's pin index once created (pins start with the world).
    pub handle: Option<usize>,
    pub released: bool,
}

/// Linear interpolation of `(time, value)` keys, held before the first and after the last.
pub(crate) fn sample_keys(keys: &[(f32, Vec3)], t: f32) -> Vec3 {
    match keys {
        [] => Vec3::ZERO,
        [(_, v)] => *v,
        _ => {
            if t <= keys[0].0 {
                return keys[0].1;
            }
            for w in keys.windows(2) {
                let ((t0, a), (t1, b)) = (w[0], w[1]);
                if t <= t1 {
                    let f = if t1 > t0 { (t - t0) / (t1 - t0) } else { 1.0 };
                    return a.lerp(b, f);
                }
            }
            keys[keys.len() - 1].1
        }
    }
}

/// Overlap of `[a0, a1]` with `[b0, b1]`, seconds.
pub(crate) fn overlap(a0: f64, a1: f64, b0: f64, b1: f64) -> f64 {
    (a1.min(b1) - a0.max(b0)).max(0.0)
}

/// The impulse a field gives one body over `[t0, t1]` (constant over the substep).
///
/// `area_along` gives the body's silhouette area seen along a direction (for wind).
pub(crate) fn field_impulse(
    field: &Field,
    t0: f64,
    t1: f64,
    mass: f32,
    position: Vec3,
    velocity: Vec3,
    area_along: impl Fn(Vec3) -> f32,
) -> Vec3 {
    match field {
        // Gravity fields change the world's gravity instead.
        Field::Gravity { .. } => Vec3::ZERO,
        Field::Radial {
            center,
            strength_mps2,
            radius_m,
            start_s,
            end_s,
        } => {
            let dt = overlap(t0, t1, *start_s as f64, *end_s as f64) as f32;
            let offset = position - *center;
            let d = offset.length();
            if dt <= 0.0 || d >= *radius_m {
                return Vec3::ZERO;
            }
            let dir = if d > 1e-6 { offset / d } else { Vec3::Y };
            dir * (strength_mps2 * (1.0 - d / radius_m) * mass * dt)
        }
        Field::Drag {
            rate_per_s,
            start_s,
            end_s,
        } => {
            let dt = overlap(t0, t1, *start_s as f64, *end_s as f64) as f32;
            // Never more than stops the body within the substep.
            -velocity * mass * (rate_per_s * dt).min(1.0)
        }
        Field::Wind {
            velocity_mps,
            start_s,
            end_s,
        } => {
            let dt = overlap(t0, t1, *start_s as f64, *end_s as f64) as f32;
            let rel = *velocity_mps - velocity;
            let speed = rel.length();
            if dt <= 0.0 || speed < 1e-6 {
                return Vec3::ZERO;
            }
            let area = area_along(rel / speed);
            let drag = 0.5 * AIR_DENSITY * super::blast::DRAG_COEFFICIENT as f32 * area * speed;
            // Never more than brings the body to the wind's speed within the substep.
            rel * (drag * dt).min(mass)
        }
    }
}
