//! Events that act on ragdolls. So far: explosion blast waves. `blast.rs` holds the physics
//! of the air blast (Kingery–Bulmash curves, Friedlander histories, the load on one body
//! part, DESIGN §7); the world applies it to every body part over the substeps.

pub mod blast;

use glam::Vec3;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// An explosive charge going off.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Blast {
    /// Charge as TNT-equivalent mass, kg.
    pub tnt_kg: f32,
    /// Where the charge is, world space, metres: any height, anywhere (inside a crowd, at a
    /// character's feet, in the air).
    pub position: Vec3,
    /// Detonation time, seconds from the start of the simulation.
    pub time_s: f32,
    /// Artistic multiplier on the loads (1 = physical).
    pub scale: f32,
}

impl Blast {
    /// A physical blast (`scale` 1) of `tnt_kg` at `position`, going off at `time_s`.
    pub fn new(tnt_kg: f32, position: Vec3, time_s: f32) -> Self {
        Blast {
            tnt_kg,
            position,
            time_s,
            scale: 1.0,
        }
    }

    /// Checks the values a user can give.
    pub fn validate(&self) -> Result<()> {
        let bad = |setting: &str, message: &str| {
            Err(Error::Setting {
                setting: setting.into(),
                message: message.into(),
            })
        };
        if !(self.tnt_kg.is_finite() && self.tnt_kg > 0.0 && self.tnt_kg <= 1.0e7) {
            return bad(
                "tnt",
                "the charge must be between 0 and 10 000 000 kg of TNT",
            );
        }
        if !self.position.is_finite() {
            return bad("at", "the charge position must be finite");
        }
        if !(self.time_s.is_finite() && self.time_s >= 0.0) {
            return bad(
                "time",
                "the detonation time must be zero or positive seconds",
            );
        }
        if !(self.scale.is_finite() && self.scale >= 0.0) {
            return bad("scale", "the scale must be zero or positive");
        }
        Ok(())
    }
}

/// A projectile (a bullet, a thrown brick): it flies straight from `origin` along
/// `direction` and gives all its momentum to the first body part it meets, at the point it
/// hits, so an off-centre hit spins the part. Gravity on its flight is ignored: over the few
/// metres of a scene a bullet drops millimetres.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Projectile {
    /// Where it starts, world space, metres.
    pub origin: Vec3,
    /// Its direction of flight (any length but zero).
    pub direction: Vec3,
    /// Its mass, kg.
    pub mass_kg: f32,
    /// Its speed, m/s.
    pub speed_mps: f32,
    /// When it hits (its flight time is not simulated), seconds from the start.
    pub time_s: f32,
}

impl Projectile {
    /// Checks the values a user can give.
    pub fn validate(&self) -> Result<()> {
        let bad = |setting: &str, message: &str| {
            Err(Error::Setting {
                setting: setting.into(),
                message: message.into(),
            })
        };
        if !self.origin.is_finite() {
            return bad("from", "the origin must be finite");
        }
        if !(self.direction.is_finite() && self.direction.length() > 1e-6) {
            return bad(
                "direction",
                "the direction must be a finite, non-zero vector",
            );
        }
        if !(self.mass_kg.is_finite() && self.mass_kg > 0.0) {
            return bad("mass", "the projectile's mass must be positive");
        }
        if !(self.speed_mps.is_finite() && self.speed_mps >= 0.0) {
            return bad("speed", "the speed must be zero or positive");
        }
        if !(self.time_s.is_finite() && self.time_s >= 0.0) {
            return bad("time", "the time must be zero or positive seconds");
        }
        Ok(())
    }
}

/// A push on one body part, named by a skeleton joint (applied at the joint's position, on
/// the body it rides on) or by a body of the spec (applied at its centre).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Push {
    /// An instantaneous impulse.
    Impulse {
        /// Body or joint name.
        target: String,
        /// Impulse, N·s, world space.
        impulse_ns: Vec3,
        /// When, seconds.
        time_s: f32,
    },
    /// A constant force over a time window.
    Force {
        /// Body or joint name.
        target: String,
        /// Force, N, world space.
        force_n: Vec3,
        /// From when, seconds.
        start_s: f32,
        /// Until when, seconds.
        end_s: f32,
    },
}

/// A force field acting on every body of every ragdoll over a time window.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Field {
    /// Gravity that changes over time (replaces the world's gravity while active): keyed
    /// accelerations, linear between keys, held before the first and after the last.
    Gravity {
        /// `(time_s, acceleration m/s²)` keys, in time order.
        keys: Vec<(f32, Vec3)>,
    },
    /// A push (positive) or pull (negative) from a point, as an acceleration that falls
    /// linearly to zero at `radius_m`.
    Radial {
        /// Centre, metres.
        center: Vec3,
        /// Acceleration at the centre, m/s² (positive pushes away).
        strength_mps2: f32,
        /// Beyond this distance the field is zero, metres.
        radius_m: f32,
        /// From when, seconds.
        start_s: f32,
        /// Until when, seconds.
        end_s: f32,
    },
    /// Linear drag: each body loses `rate_per_s` of its velocity per second.
    Drag {
        /// Fraction of velocity lost per second, 1/s.
        rate_per_s: f32,
        /// From when, seconds.
        start_s: f32,
        /// Until when, seconds.
        end_s: f32,
    },
    /// Wind: quadratic air drag toward the wind's velocity on each part's silhouette
    /// (½·ρ·C_d·A·|u − v|·(u − v), ρ = 1.225 kg/m³).
    Wind {
        /// Wind velocity, m/s.
        velocity_mps: Vec3,
        /// From when, seconds.
        start_s: f32,
        /// Until when, seconds.
        end_s: f32,
    },
}

/// Holds a body part at a point, or drags it along keyed positions, until released.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pin {
    /// Body or joint name; the pin holds that joint's position (or the body's centre).
    pub target: String,
    /// `(time_s, position)` keys, linear between keys, held after the last. One key holds
    /// the part in place.
    pub keys: Vec<(f32, Vec3)>,
    /// `None` for a hard pin; otherwise a spring of this natural frequency, Hz.
    pub stiffness_hz: Option<f32>,
    /// Damping ratio of a soft pin (1 = critical).
    pub damping_ratio: f32,
    /// When the pin lets go, seconds (`None`: never).
    pub release_s: Option<f32>,
}

/// What a projectile hit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ProjectileReport {
    /// When it was fired, seconds.
    pub time_s: f32,
    /// The character hit (index in the world), or `null` for a miss.
    pub character: Option<usize>,
    /// The body part hit, or `null` for a miss.
    pub body: Option<String>,
    /// Where it was fired from, world space, metres (so a report alone can draw the shot).
    pub origin: [f32; 3],
    /// Where it hit, world space, metres.
    pub point: Option<[f32; 3]>,
    /// Momentum given to the part, N·s.
    pub impulse_ns: f32,
}

/// What one body part received from one blast.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BlastPartReport {
    /// Index of the character (ragdoll) in the world.
    pub character: usize,
    /// Name of the body.
    pub body: String,
    /// When the blast front reached the part, seconds from the start (`null` when it had
    /// not by the end of the run).
    pub arrival_s: Option<f64>,
    /// Peak pressure on the face toward the charge (reflected), kPa.
    pub peak_pressure_kpa: f64,
    /// Momentum the part received from the blast, N·s.
    pub impulse_ns: f64,
}

/// A character's response to one blast.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BlastCharacterReport {
    /// Index of the character (ragdoll) in the world.
    pub character: usize,
    /// The character's name.
    pub name: String,
    /// Centre-of-mass velocity right after the positive phase has passed every part, m/s
    /// (`null` when the run ended before that).
    pub com_velocity_mps: Option<[f32; 3]>,
}

/// One blast and what it did.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BlastReport {
    /// Charge, kg of TNT.
    pub tnt_kg: f32,
    /// Charge position, metres.
    pub position: [f32; 3],
    /// Detonation time, seconds.
    pub time_s: f32,
    /// Every body part of every character.
    pub parts: Vec<BlastPartReport>,
    /// Every character.
    pub characters: Vec<BlastCharacterReport>,
}
