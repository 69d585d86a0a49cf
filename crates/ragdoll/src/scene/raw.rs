//! A scene file as written: the TOML tables serde reads (unknown keys refused, each value
//! with its span), before any value is checked.

use std::fmt;

use serde::Deserialize;
use serde::de::{self, Deserializer, Visitor};
use toml::Spanned;

use crate::import::{ClipChoice, Units, UpAxis};
use crate::world::{Activation, MAX_SECONDS};

pub(super) type S<T> = Spanned<T>;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawScene {
    pub(super) duration_s: Option<S<f32>>,
    pub(super) fps: Option<S<f32>>,
    pub(super) gravity: Option<S<[f32; 3]>>,
    pub(super) ground: Option<S<GroundValue>>,
    pub(super) backend: Option<S<String>>,
    pub(super) joint_damping: Option<S<f32>>,
    pub(super) freeze_joints: Option<S<bool>>,
    pub(super) keep_contacts: Option<S<bool>>,
    pub(super) fast_substeps: Option<S<u32>>,
    pub(super) fast_iterations: Option<S<u32>>,
    pub(super) fast_impact_passes: Option<S<u32>>,
    pub(super) start_pose: Option<S<StartPoseName>>,
    pub(super) output: Option<RawOutput>,
    #[serde(default)]
    pub(super) character: Vec<S<RawCharacter>>,
    #[serde(default)]
    pub(super) crowd: Vec<S<RawCrowd>>,
    #[serde(default)]
    pub(super) blast: Vec<S<RawBlast>>,
    #[serde(default)]
    pub(super) projectile: Vec<S<RawProjectile>>,
    #[serde(default)]
    pub(super) push: Vec<S<RawPush>>,
    #[serde(default)]
    pub(super) field: Vec<S<RawField>>,
    #[serde(default)]
    pub(super) pin: Vec<S<RawPin>>,
    /// The variants the file stands for, read by `wedge.rs`; a run of the file itself is
    /// its base scene, as written.
    #[serde(rename = "wedge", default)]
    _wedge: Option<de::IgnoredAny>,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "snake_case")]
pub(super) enum StartPoseName {
    FirstFrame,
    Rest,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawOutput {
    pub(super) glb: Option<S<OutputName>>,
    pub(super) bvh: Option<S<OutputName>>,
    pub(super) report: Option<S<OutputName>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawCharacter {
    pub(super) name: Option<S<String>>,
    pub(super) file: Option<S<String>>,
    pub(super) position: Option<S<[f32; 3]>>,
    pub(super) facing_deg: Option<S<f32>>,
    pub(super) mass_kg: Option<S<f32>>,
    pub(super) female: Option<S<bool>>,
    pub(super) spec: Option<S<String>>,
    pub(super) activate: Option<S<ActivateValue>>,
    pub(super) powered: Option<S<RawPowered>>,
    pub(super) units: Option<S<Units>>,
    pub(super) up: Option<S<UpAxis>>,
    pub(super) height: Option<S<f32>>,
    pub(super) clip: Option<S<ClipValue>>,
    pub(super) clip_offset_s: Option<S<f32>>,
    pub(super) roles: Option<S<String>>,
    /// The key `file` came from, for errors: `file`, or `files` for a crowd's member drawn
    /// from its list.
    #[serde(skip, default = "file_key")]
    pub(super) file_key: &'static str,
}

fn file_key() -> &'static str {
    "file"
}

/// `[[crowd]]`: many characters from one description (see `crowd.rs`).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawCrowd {
    pub(super) count: S<u32>,
    pub(super) name: Option<S<String>>,
    pub(super) file: Option<S<String>>,
    pub(super) files: Option<S<Vec<String>>>,
    pub(super) weights: Option<S<Vec<f32>>>,
    pub(super) center: Option<S<[f32; 3]>>,
    pub(super) spacing_m: Option<S<f32>>,
    pub(super) formation: Option<S<Formation>>,
    pub(super) facing_deg: Option<S<f32>>,
    pub(super) facing_spread_deg: Option<S<f32>>,
    pub(super) height: Option<S<f32>>,
    pub(super) height_spread: Option<S<f32>>,
    pub(super) mass_kg: Option<S<f32>>,
    pub(super) mass_spread: Option<S<f32>>,
    pub(super) female_share: Option<S<f32>>,
    pub(super) seed: Option<S<u64>>,
    pub(super) activate: Option<S<ActivateValue>>,
    pub(super) clip: Option<S<ClipValue>>,
    pub(super) clip_offset_s: Option<S<f32>>,
    pub(super) clip_offset_spread_s: Option<S<f32>>,
    pub(super) units: Option<S<Units>>,
    pub(super) up: Option<S<UpAxis>>,
}

/// How a crowd stands.
#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "snake_case")]
pub(super) enum Formation {
    Grid,
    Scatter,
}

/// `clip`: a clip's name, or its position in the file's clip list from 0. TOML's types
/// tell them apart, so a clip named `"2"` is still reachable by name.
#[derive(Clone)]
pub(super) struct ClipValue(pub(super) ClipChoice);

impl<'de> Deserialize<'de> for ClipValue {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        struct V;
        impl Visitor<'_> for V {
            type Value = ClipValue;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a clip's name, or its index from 0")
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> std::result::Result<Self::Value, E> {
                usize::try_from(v)
                    .map(|i| ClipValue(ClipChoice::Index(i)))
                    .map_err(|_| E::invalid_value(de::Unexpected::Signed(v), &self))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> std::result::Result<Self::Value, E> {
                usize::try_from(v)
                    .map(|i| ClipValue(ClipChoice::Index(i)))
                    .map_err(|_| E::invalid_value(de::Unexpected::Unsigned(v), &self))
            }
            fn visit_str<E: de::Error>(self, v: &str) -> std::result::Result<Self::Value, E> {
                Ok(ClipValue(ClipChoice::Name(v.to_string())))
            }
        }
        d.deserialize_any(V)
    }
}

/// `powered = { strength = 1.0, fade_out = [1.0, 2.0], root_on_clip = true }`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawPowered {
    pub(super) strength: f32,
    pub(super) fade_out: Option<[f32; 2]>,
    pub(super) root_on_clip: Option<bool>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawBlast {
    pub(super) tnt_kg: S<f32>,
    pub(super) position: S<[f32; 3]>,
    pub(super) time_s: Option<S<f32>>,
    pub(super) scale: Option<S<f32>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawProjectile {
    pub(super) origin: S<[f32; 3]>,
    pub(super) direction: Option<S<[f32; 3]>>,
    pub(super) target: Option<S<[f32; 3]>>,
    pub(super) mass_kg: Option<S<f32>>,
    pub(super) speed_mps: Option<S<f32>>,
    pub(super) time_s: Option<S<f32>>,
    pub(super) count: Option<S<u32>>,
    pub(super) interval_s: Option<S<f32>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawPush {
    pub(super) character: Option<S<String>>,
    pub(super) target: S<String>,
    pub(super) impulse_ns: Option<S<[f32; 3]>>,
    pub(super) time_s: Option<S<f32>>,
    pub(super) force_n: Option<S<[f32; 3]>>,
    pub(super) start_s: Option<S<f32>>,
    pub(super) end_s: Option<S<f32>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawField {
    pub(super) kind: S<String>,
    pub(super) keys: Option<S<Vec<GravityKey>>>,
    pub(super) center: Option<S<[f32; 3]>>,
    pub(super) strength_mps2: Option<S<f32>>,
    pub(super) radius_m: Option<S<f32>>,
    pub(super) rate_per_s: Option<S<f32>>,
    pub(super) velocity_mps: Option<S<[f32; 3]>>,
    pub(super) start_s: Option<S<f32>>,
    pub(super) end_s: Option<S<f32>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct GravityKey {
    pub(super) time_s: f32,
    pub(super) gravity: [f32; 3],
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawPin {
    pub(super) character: Option<S<String>>,
    pub(super) target: S<String>,
    pub(super) position: Option<S<[f32; 3]>>,
    pub(super) keys: Option<S<Vec<PinKey>>>,
    pub(super) stiffness_hz: Option<S<f32>>,
    pub(super) damping_ratio: Option<S<f32>>,
    pub(super) release_s: Option<S<f32>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct PinKey {
    pub(super) time_s: f32,
    pub(super) position: [f32; 3],
}

/// `ground`: a height in metres, or `"none"` (TOML has no null).
pub(super) enum GroundValue {
    Height(f32),
    None,
}

impl<'de> Deserialize<'de> for GroundValue {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        struct V;
        impl Visitor<'_> for V {
            type Value = GroundValue;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a height in metres or \"none\"")
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> std::result::Result<Self::Value, E> {
                Ok(GroundValue::Height(v as f32))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> std::result::Result<Self::Value, E> {
                Ok(GroundValue::Height(v as f32))
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> std::result::Result<Self::Value, E> {
                Ok(GroundValue::Height(v as f32))
            }
            fn visit_str<E: de::Error>(self, v: &str) -> std::result::Result<Self::Value, E> {
                match v {
                    "none" => Ok(GroundValue::None),
                    _ => Err(E::invalid_value(de::Unexpected::Str(v), &self)),
                }
            }
        }
        d.deserialize_any(V)
    }
}

/// `activate`: `"start"`, `"blast"` or seconds.
#[derive(Clone, Copy)]
pub(super) struct ActivateValue(pub(super) Activation);

impl<'de> Deserialize<'de> for ActivateValue {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        struct V;
        impl V {
            fn time<E: de::Error>(self, t: f64) -> std::result::Result<ActivateValue, E> {
                if t.is_finite() && (0.0..=MAX_SECONDS as f64).contains(&t) {
                    Ok(ActivateValue(Activation::AtTime(t as f32)))
                } else {
                    Err(E::invalid_value(de::Unexpected::Float(t), &self))
                }
            }
        }
        impl Visitor<'_> for V {
            type Value = ActivateValue;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                write!(
                    f,
                    "\"start\", \"blast\", \"contact\" or a time in seconds (0 to {MAX_SECONDS})"
                )
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> std::result::Result<Self::Value, E> {
                self.time(v as f64)
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> std::result::Result<Self::Value, E> {
                self.time(v as f64)
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> std::result::Result<Self::Value, E> {
                self.time(v)
            }
            fn visit_str<E: de::Error>(self, v: &str) -> std::result::Result<Self::Value, E> {
                match v {
                    "start" => Ok(ActivateValue(Activation::Immediately)),
                    "blast" => Ok(ActivateValue(Activation::OnBlast)),
                    "contact" => Ok(ActivateValue(Activation::OnContact)),
                    _ => Err(E::invalid_value(de::Unexpected::Str(v), &self)),
                }
            }
        }
        d.deserialize_any(V)
    }
}

/// An output: a file name, `false` to skip it, or `true` for the default name.
pub(super) enum OutputName {
    Name(String),
    Off,
    Default,
}

impl<'de> Deserialize<'de> for OutputName {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        struct V;
        impl Visitor<'_> for V {
            type Value = OutputName;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a file name, or false to skip this output")
            }
            fn visit_bool<E: de::Error>(self, v: bool) -> std::result::Result<Self::Value, E> {
                Ok(if v {
                    OutputName::Default
                } else {
                    OutputName::Off
                })
            }
            fn visit_str<E: de::Error>(self, v: &str) -> std::result::Result<Self::Value, E> {
                Ok(OutputName::Name(v.to_string()))
            }
        }
        d.deserialize_any(V)
    }
}
