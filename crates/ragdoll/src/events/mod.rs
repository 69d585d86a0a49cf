//! Events that act on ragdolls: blasts, projectiles, pushes, fields and pins. `blast.rs`
//! holds the physics of the air blast (Kingery–Bulmash curves, Friedlander histories, the
//! load on one body part); the world applies it to every body part over the
//! substeps.
//!
//! Every event checks its values against the bounds below (`validate`), so an input whose
//! physics the engines cannot honour (a bullet at 10³⁰ m/s, a spring stiffer than the
//! substeps can follow) is refused with the bound instead of silently doing nothing or
//! blowing up. The scene reader checks the same bounds key by key, with lines.

pub mod blast;

use glam::Vec3;
use serde::{Deserialize, Serialize};

use crate::bounds::{MAX_COORDINATE_M, MAX_GRAVITY_MPS2, MAX_SECONDS};
use crate::error::{Error, Result};
use crate::spec::{MAX_NAME_BYTES, check_above, check_within, show};

/// Largest charge, kg of TNT: 10 kt.
///
/// Above the largest accidental explosions (Halifax 1917, about 2.9 kt; Beirut 2020, about
/// 1 kt); the Kingery–Bulmash curves scale to any charge by its cube root, so the bound is
/// about what a scene can mean, not the curves.
pub const MAX_TNT_KG: f32 = 1e7;

/// Largest artistic multiplier on a blast's loads: a hundred times the physical ones,
/// already enough to throw a person hundreds of metres.
pub const MAX_BLAST_SCALE: f32 = 100.0;

/// Heaviest projectile, kg: a wrecking ball; a thrown brick is a few kilograms.
pub const MAX_PROJECTILE_KG: f32 = 1000.0;

/// Fastest projectile, m/s.
///
/// Above the fastest gun-fired rounds (tank penetrators, about 1.8 km/s); faster impacts
/// vaporise what they hit rather than push it, which the momentum model does not describe.
pub const MAX_PROJECTILE_SPEED_MPS: f32 = 3000.0;

/// Largest momentum one event gives one body part (a projectile's mass × speed, a push's
/// impulse), N·s.
///
/// A 9 mm bullet carries 3 N·s, a .50 calibre one about 20, a 5 kg brick thrown at
/// 20 m/s 100. At 1 000 N·s a humanoid's hand leaves at 2 km/s and both backends still
/// hold the body together (joints 2 cm and 8 cm apart at worst); at 10 000 N·s the
/// particle backend's broad phase ran out of memory.
pub const MAX_MOMENTUM_NS: f32 = 1000.0;

/// Largest push force, N: the weight of a tonne.
///
/// Held on a humanoid's hand for a second, rapier's joints open up to 12 cm at this force
/// and tear (1 m) at ten times it.
pub const MAX_FORCE_N: f32 = 1e4;

/// Strongest wind, m/s: the speed of sound. The quadratic drag law with a fixed
/// coefficient holds below it; the strongest gust measured on Earth is 113 m/s.
pub const MAX_WIND_MPS: f32 = 340.0;

/// Largest drag rate, 1/s. The drag never does more than stop a body within a substep, so
/// higher rates act the same; this only refuses what cannot be meant.
pub const MAX_DRAG_RATE_PER_S: f32 = 1000.0;

/// Stiffest soft pin, Hz.
///
/// A soft pin is a spring applied once per collision substep (1/240 s by default), which
/// an explicit step follows only while 2π·f·h stays well under 2 (f < 76 Hz); a hand
/// pinned at 100 Hz tore from its arm on rapier and exhausted the particle backend's
/// memory, 60 Hz held. Half of that keeps a margin; for stiffer, use a hard pin.
pub const MAX_PIN_STIFFNESS_HZ: f32 = 30.0;

/// Largest damping of a soft pin, as `damping_ratio × stiffness_hz`, Hz.
///
/// The damping is applied explicitly too, and stays stable while 2·ζ·ω·h < 2, that is
/// ζ·f < 38 Hz at 240 Hz substeps (ζ = 10 at 10 Hz came apart; ζ = 6 held): critical
/// damping (ζ = 1) at the stiffest pin, or ζ = 30 at 1 Hz.
pub const MAX_PIN_DAMPING_HZ: f32 = 30.0;

/// Most keys in one list of keys (a gravity field's, a pin's path, motor strengths): one
/// a frame for over five minutes at 30 fps. Each is looked up every substep.
pub const MAX_KEYS: usize = 10_000;

/// End of a time window left open (a push or field that lasts the whole run): later than
/// any run and finite, so it survives a duration changed after loading.
pub const OPEN_END_S: f32 = f32::MAX;

/// A time in seconds from the start of a run: within `[0, MAX_SECONDS]`.
pub(crate) fn check_time(t: f32) -> std::result::Result<(), String> {
    check_within(t, 0.0, MAX_SECONDS, " s")
}

/// The end of a time window: a time no earlier than `start`, or [`OPEN_END_S`].
pub(crate) fn check_end(start: f32, end: f32) -> std::result::Result<(), String> {
    if end == OPEN_END_S {
        return Ok(());
    }
    check_time(end)?;
    if end < start {
        return Err(format!(
            "must not be before start_s ({} s), not {} s",
            show(start),
            show(end)
        ));
    }
    Ok(())
}

/// A point of the world: finite, every coordinate within ±[`MAX_COORDINATE_M`].
pub(crate) fn check_point(p: Vec3) -> std::result::Result<(), String> {
    if p.is_finite() && p.abs().max_element() <= MAX_COORDINATE_M {
        Ok(())
    } else {
        Err(format!(
            "every coordinate must be within ±{} m (where f32 still resolves a millimetre), not [{}, {}, {}]",
            show(MAX_COORDINATE_M),
            show(p.x),
            show(p.y),
            show(p.z)
        ))
    }
}

/// A vector no longer than `max` (and finite).
pub(crate) fn check_magnitude(v: Vec3, max: f32, unit: &str) -> std::result::Result<(), String> {
    crate::spec::check_length(v.to_array(), max, unit)
}

/// Keys in time order, times within a run, at least one and at most [`MAX_KEYS`];
/// `value` checks each key's value.
pub(crate) fn check_keys<T: Copy>(
    keys: &[(f32, T)],
    value: impl Fn(T) -> std::result::Result<(), String>,
) -> std::result::Result<(), String> {
    if keys.is_empty() {
        return Err("needs at least one key".into());
    }
    if keys.len() > MAX_KEYS {
        return Err(format!("has {} keys, more than {MAX_KEYS}", keys.len()));
    }
    for (k, &(t, v)) in keys.iter().enumerate() {
        let at = |m: String| format!("key {}: {m}", k + 1);
        check_time(t).map_err(|m| at(format!("time_s {m}")))?;
        value(v).map_err(at)?;
        if k > 0 && t < keys[k - 1].0 {
            return Err(at(format!(
                "times must not go backwards ({} after {})",
                show(t),
                show(keys[k - 1].0)
            )));
        }
    }
    Ok(())
}

/// A body or joint name.
fn check_target(name: &str) -> std::result::Result<(), String> {
    if name.is_empty() || name.len() > MAX_NAME_BYTES {
        Err(format!("must be a name of 1 to {MAX_NAME_BYTES} bytes"))
    } else {
        Ok(())
    }
}

/// The first failed check as a setting error naming its setting.
fn first_error<const N: usize>(checks: [(&str, std::result::Result<(), String>); N]) -> Result<()> {
    match checks.into_iter().find(|(_, r)| r.is_err()) {
        Some((setting, Err(message))) => Err(Error::Setting {
            setting: setting.into(),
            message,
        }),
        _ => Ok(()),
    }
}

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

    /// Checks the values a user can give against [`MAX_TNT_KG`], the world's extent
    /// ([`MAX_COORDINATE_M`]), [`MAX_SECONDS`] and [`MAX_BLAST_SCALE`]. The setting named
    /// in the error is the CLI's flag (`tnt`, `at`, `time`, `scale`).
    pub fn validate(&self) -> Result<()> {
        let checks = [
            (
                "tnt",
                check_above(self.tnt_kg, 0.0, MAX_TNT_KG, " kg of TNT"),
            ),
            ("at", check_point(self.position)),
            ("time", check_time(self.time_s)),
            ("scale", check_within(self.scale, 0.0, MAX_BLAST_SCALE, "")),
        ];
        first_error(checks)
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
    /// Its momentum, N·s.
    pub fn momentum_ns(&self) -> f32 {
        self.mass_kg * self.speed_mps
    }

    /// Checks the values a user can give against the world's extent, [`MAX_PROJECTILE_KG`],
    /// [`MAX_PROJECTILE_SPEED_MPS`], [`MAX_MOMENTUM_NS`] and [`MAX_SECONDS`]. The setting
    /// named in the error is the CLI's flag (`from`, `direction`, `mass`, `speed`, `time`).
    pub fn validate(&self) -> Result<()> {
        let direction = if self.direction.is_finite()
            && self.direction.length().is_finite()
            && self.direction.length() > 1e-6
        {
            Ok(())
        } else {
            Err("the direction must be a finite, non-zero vector".to_string())
        };
        let momentum = if self.momentum_ns() <= MAX_MOMENTUM_NS {
            Ok(())
        } else {
            Err(format!(
                "the momentum (mass × speed) must be at most {} N·s, not {} ({} kg at {} m/s)",
                show(MAX_MOMENTUM_NS),
                show(self.momentum_ns()),
                show(self.mass_kg),
                show(self.speed_mps)
            ))
        };
        let checks = [
            ("from", check_point(self.origin)),
            ("direction", direction),
            (
                "mass",
                check_above(self.mass_kg, 0.0, MAX_PROJECTILE_KG, " kg"),
            ),
            (
                "speed",
                check_within(self.speed_mps, 0.0, MAX_PROJECTILE_SPEED_MPS, " m/s"),
            ),
            ("speed", momentum),
            ("time", check_time(self.time_s)),
        ];
        first_error(checks)
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

impl Push {
    /// Checks the values against [`MAX_MOMENTUM_NS`], [`MAX_FORCE_N`] and
    /// [`MAX_SECONDS`]; the setting named in the error is the scene's key.
    pub fn validate(&self) -> Result<()> {
        match self {
            Push::Impulse {
                target,
                impulse_ns,
                time_s,
            } => first_error([
                ("target", check_target(target)),
                (
                    "impulse_ns",
                    check_magnitude(*impulse_ns, MAX_MOMENTUM_NS, " N·s"),
                ),
                ("time_s", check_time(*time_s)),
            ]),
            Push::Force {
                target,
                force_n,
                start_s,
                end_s,
            } => first_error([
                ("target", check_target(target)),
                ("force_n", check_magnitude(*force_n, MAX_FORCE_N, " N")),
                ("start_s", check_time(*start_s)),
                ("end_s", check_end(*start_s, *end_s)),
            ]),
        }
    }
}

impl Field {
    /// Checks the values against [`MAX_GRAVITY_MPS2`] (gravity keys and radial
    /// strengths), [`MAX_WIND_MPS`], [`MAX_DRAG_RATE_PER_S`], [`MAX_KEYS`], the world's
    /// extent and [`MAX_SECONDS`]; the setting named in the error is the scene's key.
    pub fn validate(&self) -> Result<()> {
        let window = |start: f32, end: f32| {
            [
                ("start_s", check_time(start)),
                ("end_s", check_end(start, end)),
            ]
        };
        match self {
            Field::Gravity { keys } => first_error([(
                "keys",
                check_keys(keys, |g| check_magnitude(g, MAX_GRAVITY_MPS2, " m/s²")),
            )]),
            Field::Radial {
                center,
                strength_mps2,
                radius_m,
                start_s,
                end_s,
            } => {
                let [start, end] = window(*start_s, *end_s);
                first_error([
                    ("center", check_point(*center)),
                    (
                        "strength_mps2",
                        check_within(*strength_mps2, -MAX_GRAVITY_MPS2, MAX_GRAVITY_MPS2, " m/s²"),
                    ),
                    (
                        "radius_m",
                        check_above(*radius_m, 0.0, 2.0 * MAX_COORDINATE_M, " m"),
                    ),
                    start,
                    end,
                ])
            }
            Field::Drag {
                rate_per_s,
                start_s,
                end_s,
            } => {
                let [start, end] = window(*start_s, *end_s);
                first_error([
                    (
                        "rate_per_s",
                        check_within(*rate_per_s, 0.0, MAX_DRAG_RATE_PER_S, " per second"),
                    ),
                    start,
                    end,
                ])
            }
            Field::Wind {
                velocity_mps,
                start_s,
                end_s,
            } => {
                let [start, end] = window(*start_s, *end_s);
                first_error([
                    (
                        "velocity_mps",
                        check_magnitude(*velocity_mps, MAX_WIND_MPS, " m/s"),
                    ),
                    start,
                    end,
                ])
            }
        }
    }
}

impl Pin {
    /// Checks the values against [`MAX_KEYS`], the world's extent, [`MAX_SECONDS`],
    /// [`MAX_PIN_STIFFNESS_HZ`] and [`MAX_PIN_DAMPING_HZ`]; the setting named in the error
    /// is the scene's key.
    pub fn validate(&self) -> Result<()> {
        let stiffness = self.stiffness_hz.map_or(Ok(()), |k| {
            check_above(k, 0.0, MAX_PIN_STIFFNESS_HZ, " Hz")
                .map_err(|m| format!("{m} (leave it out for a hard pin)"))
        });
        let damping = match self.stiffness_hz {
            Some(k) if k.is_finite() && k > 0.0 => {
                check_within(self.damping_ratio, 0.0, MAX_PIN_DAMPING_HZ / k, "").map_err(|m| {
                    format!(
                        "{m}: damping_ratio × stiffness_hz must stay within {} Hz for the \
                         spring to be stable",
                        show(MAX_PIN_DAMPING_HZ)
                    )
                })
            }
            // A hard pin has no damping; the ratio only has to be a number.
            _ if self.damping_ratio.is_finite() && self.damping_ratio >= 0.0 => Ok(()),
            _ => Err(format!(
                "must be zero or more, not {}",
                show(self.damping_ratio)
            )),
        };
        first_error([
            ("target", check_target(&self.target)),
            ("keys", check_keys(&self.keys, check_point)),
            ("stiffness_hz", stiffness),
            ("damping_ratio", damping),
            ("release_s", self.release_s.map_or(Ok(()), check_time)),
        ])
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn windows_may_stay_open_but_not_end_before_they_start() {
        assert!(check_end(0.0, OPEN_END_S).is_ok());
        assert!(check_end(1.0, 1.0).is_ok());
        assert!(check_end(2.0, 1.0).unwrap_err().contains("start_s"));
        assert!(check_end(0.0, f32::INFINITY).is_err());
    }

    #[test]
    fn keys_name_the_key_that_is_wrong() {
        let ok = |_: f32| Ok(());
        assert!(check_keys::<f32>(&[], ok).is_err());
        let m = check_keys(&[(0.0, 1.0), (2.0, 1.0), (1.0, 1.0)], ok).unwrap_err();
        assert!(m.starts_with("key 3:") && m.contains("backwards"), "{m}");
        let m = check_keys(&[(-1.0, 1.0)], ok).unwrap_err();
        assert!(m.starts_with("key 1: time_s"), "{m}");
    }

    #[test]
    fn points_stay_within_the_world() {
        assert!(check_point(Vec3::splat(MAX_COORDINATE_M)).is_ok());
        let m = check_point(Vec3::new(4_294_967_296.0, 0.0, 0.0)).unwrap_err();
        assert!(m.contains("10000 m") && m.contains("4.2949673e9"), "{m}");
        assert!(check_point(Vec3::NAN).is_err());
    }
}
