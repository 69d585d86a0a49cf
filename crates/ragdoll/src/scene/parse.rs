//! Reading a scene file: TOML into checked values. serde with `deny_unknown_fields` catches
//! unknown keys and wrong types (toml gives the byte span, turned into a line here); values
//! checked after parsing keep their spans with [`toml::Spanned`], so every error names the
//! file, the line and the key.

use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};

use glam::Vec3;
use serde::Deserialize;
use serde::de::{self, Deserializer, Visitor};
use toml::Spanned;

use super::{Event, OPEN_END_S, Outputs, Scene, SceneCharacter};
use crate::error::{Error, Result};
use crate::events::{Blast, Field, Pin, Projectile, Push};
use crate::import::{self, ImportOptions, Units, UpAxis};
use crate::skeleton::{self, Character};
use crate::spec::{self, BuildOptions, RagdollSpec};
use crate::world::{Activation, Motors, StartPose, WorldSettings};

type S<T> = Spanned<T>;

/// Longest scene, seconds (as the CLI's `--seconds`).
const MAX_DURATION_S: f32 = 3600.0;
/// Most characters in one scene.
const MAX_CHARACTERS: usize = 1000;
/// Most shots in one burst.
const MAX_BURST: u32 = 10_000;
/// Default projectile: a 9 mm pistol bullet, as `ragdoll shoot`.
const DEFAULT_PROJECTILE_KG: f32 = 0.008;
const DEFAULT_PROJECTILE_MPS: f32 = 360.0;
const DEFAULT_BURST_INTERVAL_S: f32 = 0.1;

// --- The file as written -------------------------------------------------------------

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    duration_s: Option<S<f32>>,
    fps: Option<S<f32>>,
    gravity: Option<S<[f32; 3]>>,
    ground: Option<S<GroundValue>>,
    backend: Option<S<String>>,
    start_pose: Option<S<StartPoseName>>,
    output: Option<RawOutput>,
    #[serde(default)]
    character: Vec<S<RawCharacter>>,
    #[serde(default)]
    blast: Vec<S<RawBlast>>,
    #[serde(default)]
    projectile: Vec<S<RawProjectile>>,
    #[serde(default)]
    push: Vec<S<RawPush>>,
    #[serde(default)]
    field: Vec<S<RawField>>,
    #[serde(default)]
    pin: Vec<S<RawPin>>,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "snake_case")]
enum StartPoseName {
    FirstFrame,
    Rest,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawOutput {
    glb: Option<S<OutputName>>,
    bvh: Option<S<OutputName>>,
    report: Option<S<OutputName>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCharacter {
    name: Option<S<String>>,
    file: Option<S<String>>,
    position: Option<S<[f32; 3]>>,
    facing_deg: Option<S<f32>>,
    mass_kg: Option<S<f32>>,
    female: Option<S<bool>>,
    spec: Option<S<String>>,
    activate: Option<S<ActivateValue>>,
    powered: Option<S<RawPowered>>,
    units: Option<S<Units>>,
    up: Option<S<UpAxis>>,
}

/// `powered = { strength = 1.0, fade_out = [1.0, 2.0], root_on_clip = true }`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPowered {
    strength: f32,
    fade_out: Option<[f32; 2]>,
    root_on_clip: Option<bool>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawBlast {
    tnt_kg: S<f32>,
    position: S<[f32; 3]>,
    time_s: Option<S<f32>>,
    scale: Option<S<f32>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawProjectile {
    origin: S<[f32; 3]>,
    direction: Option<S<[f32; 3]>>,
    target: Option<S<[f32; 3]>>,
    mass_kg: Option<S<f32>>,
    speed_mps: Option<S<f32>>,
    time_s: Option<S<f32>>,
    count: Option<S<u32>>,
    interval_s: Option<S<f32>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPush {
    character: Option<S<String>>,
    target: S<String>,
    impulse_ns: Option<S<[f32; 3]>>,
    time_s: Option<S<f32>>,
    force_n: Option<S<[f32; 3]>>,
    start_s: Option<S<f32>>,
    end_s: Option<S<f32>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawField {
    kind: S<String>,
    keys: Option<S<Vec<GravityKey>>>,
    center: Option<S<[f32; 3]>>,
    strength_mps2: Option<S<f32>>,
    radius_m: Option<S<f32>>,
    rate_per_s: Option<S<f32>>,
    velocity_mps: Option<S<[f32; 3]>>,
    start_s: Option<S<f32>>,
    end_s: Option<S<f32>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct GravityKey {
    time_s: f32,
    gravity: [f32; 3],
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPin {
    character: Option<S<String>>,
    target: S<String>,
    position: Option<S<[f32; 3]>>,
    keys: Option<S<Vec<PinKey>>>,
    stiffness_hz: Option<S<f32>>,
    damping_ratio: Option<S<f32>>,
    release_s: Option<S<f32>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PinKey {
    time_s: f32,
    position: [f32; 3],
}

/// `ground`: a height in metres, or `"none"` (TOML has no null).
enum GroundValue {
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
struct ActivateValue(Activation);

impl<'de> Deserialize<'de> for ActivateValue {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        struct V;
        impl V {
            fn time<E: de::Error>(self, t: f64) -> std::result::Result<ActivateValue, E> {
                if t.is_finite() && t >= 0.0 {
                    Ok(ActivateValue(Activation::AtTime(t as f32)))
                } else {
                    Err(E::invalid_value(de::Unexpected::Float(t), &self))
                }
            }
        }
        impl Visitor<'_> for V {
            type Value = ActivateValue;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("\"start\", \"blast\", \"contact\" or a time in seconds (zero or more)")
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
enum OutputName {
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

// --- Errors with lines ---------------------------------------------------------------

/// The file being read, to turn spans into lines.
struct Src<'a> {
    path: &'a Path,
    text: &'a str,
}

impl Src<'_> {
    /// 1-based line of byte `pos`.
    fn line(&self, pos: usize) -> usize {
        let pos = pos.min(self.text.len());
        self.text.as_bytes()[..pos]
            .iter()
            .filter(|&&b| b == b'\n')
            .count()
            + 1
    }

    fn err(&self, span: &Range<usize>, message: String) -> Error {
        Error::Parse {
            path: self.path.to_path_buf(),
            line: self.line(span.start),
            message,
        }
    }

    /// Turns a toml error into ours, adding the table and the key when the message does
    /// not already name them (serde's type errors do not).
    fn toml_error(&self, e: &toml::de::Error) -> Error {
        let span = e.span().unwrap_or(0..0);
        let mut message = e.message().trim().replace('\n', " ");
        if let Some(key) = key_before(self.text, span.start)
            && !message.contains(&format!("`{key}`"))
        {
            message = format!("{key}: {message}");
        }
        if let Some(table) = table_at(self.text, span.start) {
            message = format!("{table}: {message}");
        }
        self.err(&span, message)
    }
}

/// The key whose value starts at byte `pos`: the bare key before the last `=` on that
/// line before `pos` (inside inline tables, the innermost key).
fn key_before(text: &str, pos: usize) -> Option<String> {
    let before = text.get(..pos)?;
    let line = &before[before.rfind('\n').map_or(0, |i| i + 1)..];
    let eq = line.rfind('=')?;
    let lhs = line[..eq].trim_end();
    let key: String = lhs
        .chars()
        .rev()
        .take_while(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'))
        .collect::<Vec<_>>()
        .into_iter()
        .rev()
        .collect();
    (!key.is_empty()).then_some(key)
}

/// The table header that byte `pos` falls under, numbered for arrays of tables
/// (`[[blast]] 2`), or `None` at the top level.
fn table_at(text: &str, pos: usize) -> Option<String> {
    // Up to the end of `pos`'s line: a missing key is reported at its table's header.
    let end = text.get(pos..)?.find('\n').map_or(text.len(), |i| pos + i);
    let before = &text[..end];
    let headers: Vec<(&str, bool)> = before
        .lines()
        .filter_map(|l| {
            let l = l.split('#').next().unwrap_or("").trim();
            let (inner, array) =
                if let Some(x) = l.strip_prefix("[[").and_then(|x| x.strip_suffix("]]")) {
                    (x.trim(), true)
                } else {
                    (l.strip_prefix('[')?.strip_suffix(']')?.trim(), false)
                };
            let bare = !inner.is_empty()
                && inner
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'));
            bare.then_some((inner, array))
        })
        .collect();
    let &(name, array) = headers.last()?;
    Some(if array {
        let n = headers.iter().filter(|h| **h == (name, true)).count();
        format!("[[{name}]] {n}")
    } else {
        format!("[{name}]")
    })
}

/// Where in the file a table's values are: its name for messages, and the file.
struct Ctx<'a> {
    src: &'a Src<'a>,
    place: String,
}

impl Ctx<'_> {
    fn err(&self, span: &Range<usize>, key: &str, message: impl fmt::Display) -> Error {
        let message = if self.place.is_empty() {
            format!("{key}: {message}")
        } else {
            format!("{}: {key}: {message}", self.place)
        };
        self.src.err(span, message)
    }

    /// A number that must satisfy `ok`; `what` says what it must be.
    fn number(&self, v: &S<f32>, key: &str, ok: impl Fn(f32) -> bool, what: &str) -> Result<f32> {
        let x = *v.get_ref();
        if x.is_finite() && ok(x) {
            Ok(x)
        } else {
            Err(self.err(&v.span(), key, format!("{what}, not {x}")))
        }
    }

    fn opt_number(
        &self,
        v: &Option<S<f32>>,
        key: &str,
        default: f32,
        ok: impl Fn(f32) -> bool,
        what: &str,
    ) -> Result<f32> {
        match v {
            Some(v) => self.number(v, key, ok, what),
            None => Ok(default),
        }
    }

    fn time(&self, v: &Option<S<f32>>, key: &str, default: f32) -> Result<f32> {
        self.opt_number(
            v,
            key,
            default,
            |t| t >= 0.0,
            "must be zero or more seconds",
        )
    }

    fn vec3(&self, v: &S<[f32; 3]>, key: &str) -> Result<Vec3> {
        let x = Vec3::from_array(*v.get_ref());
        if x.is_finite() {
            Ok(x)
        } else {
            Err(self.err(&v.span(), key, "must be three finite numbers"))
        }
    }

    /// `[start_s, end_s]`: from 0 and open-ended by default, in order.
    fn window(&self, start: &Option<S<f32>>, end: &Option<S<f32>>) -> Result<(f32, f32)> {
        let s = self.time(start, "start_s", 0.0)?;
        let e = self.time(end, "end_s", OPEN_END_S)?;
        if let Some(end) = end
            && e < s
        {
            return Err(self.err(
                &end.span(),
                "end_s",
                format!("must not be before start_s ({s})"),
            ));
        }
        Ok((s, e))
    }

    /// Fails when a key given in the file does not apply here.
    fn refuse(&self, key: &str, span: Option<Range<usize>>, why: &str) -> Result<()> {
        match span {
            Some(span) => Err(self.err(&span, key, why)),
            None => Ok(()),
        }
    }
}

fn span_of<T>(v: &Option<S<T>>) -> Option<Range<usize>> {
    v.as_ref().map(|s| s.span())
}

// --- From the file to a Scene ----------------------------------------------------------

pub(super) fn parse(text: &str, path: &Path) -> Result<Scene> {
    let src = Src { path, text };
    // A spec written by `ragdoll build` given where a scene was expected deserves better
    // than "unknown field `format_version`".
    if let Ok(table) = text.parse::<toml::Table>()
        && table.contains_key("bodies")
        && table.contains_key("joints")
    {
        return Err(src.err(
            &(0..0),
            "this is a ragdoll spec, not a scene: give it to a character with spec = \"...\" (or to --spec)".into(),
        ));
    }
    let raw: RawScene = toml::from_str(text).map_err(|e| src.toml_error(&e))?;
    let top = Ctx {
        src: &src,
        place: String::new(),
    };
    let duration_s = top.opt_number(
        &raw.duration_s,
        "duration_s",
        3.0,
        |t| t > 0.0 && t <= MAX_DURATION_S,
        "must be more than 0 and at most 3600 seconds",
    )?;
    let fps = top.opt_number(
        &raw.fps,
        "fps",
        30.0,
        |f| (1.0..=1000.0).contains(&f),
        "must be between 1 and 1000 frames per second",
    )?;
    let mut settings = WorldSettings {
        fps,
        ..Default::default()
    };
    if let Some(g) = &raw.gravity {
        settings.gravity = top.vec3(g, "gravity")?;
    }
    if let Some(g) = &raw.ground {
        settings.ground = match *g.get_ref() {
            GroundValue::Height(h) if h.is_finite() => Some(h),
            GroundValue::Height(h) => {
                return Err(top.err(
                    &g.span(),
                    "ground",
                    format!("must be a finite height in metres or \"none\", not {h}"),
                ));
            }
            GroundValue::None => None,
        };
    }
    if let Some(b) = &raw.backend {
        settings.backend = crate::world::BackendKind::from_name(b.get_ref()).ok_or_else(|| {
            top.err(
                &b.span(),
                "backend",
                format!(
                    "\"{}\" is not a backend; use \"rigid\" or \"particle\"",
                    b.get_ref()
                ),
            )
        })?;
    }
    if let Some(s) = &raw.start_pose {
        settings.start = match s.get_ref() {
            StartPoseName::FirstFrame => StartPose::FirstFrame,
            StartPoseName::Rest => StartPose::Rest,
        };
    }

    if raw.character.is_empty() {
        return Err(src.err(
            &(0..0),
            "a scene needs at least one [[character]] table (an empty one is the built-in humanoid)".into(),
        ));
    }
    if raw.character.len() > MAX_CHARACTERS {
        return Err(src.err(
            &raw.character[MAX_CHARACTERS].span(),
            format!("[[character]]: a scene holds at most {MAX_CHARACTERS} characters"),
        ));
    }
    let characters = characters(&src, &raw.character)?;
    let names: Vec<&str> = characters.iter().map(|c| c.name.as_str()).collect();

    let mut blasts = Vec::new();
    for (i, b) in raw.blast.iter().enumerate() {
        let c = Ctx {
            src: &src,
            place: format!("[[blast]] {}", i + 1),
        };
        let r = b.get_ref();
        let blast = Blast {
            tnt_kg: c.number(
                &r.tnt_kg,
                "tnt_kg",
                |w| w > 0.0 && w <= 1.0e7,
                "must be more than 0 and at most 10 000 000 kg of TNT",
            )?,
            position: c.vec3(&r.position, "position")?,
            time_s: c.time(&r.time_s, "time_s", 0.0)?,
            scale: c.opt_number(&r.scale, "scale", 1.0, |s| s >= 0.0, "must be zero or more")?,
        };
        blasts.push(Event {
            event: blast,
            character: None,
            line: src.line(b.span().start),
        });
    }
    for c in &characters {
        if c.activation == Activation::OnBlast && blasts.is_empty() {
            return Err(src.err_line(
                c.line,
                format!(
                    "[[character]] \"{}\": activate: \"blast\" needs a [[blast]] in the scene",
                    c.name
                ),
            ));
        }
    }

    let mut projectiles = Vec::new();
    for (i, p) in raw.projectile.iter().enumerate() {
        let c = Ctx {
            src: &src,
            place: format!("[[projectile]] {}", i + 1),
        };
        let r = p.get_ref();
        let origin = c.vec3(&r.origin, "origin")?;
        let direction = match (&r.direction, &r.target) {
            (Some(d), None) => {
                let d3 = c.vec3(d, "direction")?;
                if d3.length() <= 1e-6 {
                    return Err(c.err(&d.span(), "direction", "must not be zero"));
                }
                d3
            }
            (None, Some(t)) => {
                let d3 = c.vec3(t, "target")? - origin;
                if d3.length() <= 1e-6 {
                    return Err(c.err(&t.span(), "target", "must differ from origin"));
                }
                d3
            }
            (Some(_), Some(t)) => {
                return Err(c.err(
                    &t.span(),
                    "target",
                    "give either direction or target, not both",
                ));
            }
            (None, None) => {
                return Err(c.err(
                    &p.span(),
                    "direction",
                    "missing: give a direction or a target point",
                ));
            }
        };
        let mass_kg = c.opt_number(
            &r.mass_kg,
            "mass_kg",
            DEFAULT_PROJECTILE_KG,
            |m| m > 0.0,
            "must be more than 0 kg",
        )?;
        let speed_mps = c.opt_number(
            &r.speed_mps,
            "speed_mps",
            DEFAULT_PROJECTILE_MPS,
            |v| v >= 0.0,
            "must be zero or more m/s",
        )?;
        let time_s = c.time(&r.time_s, "time_s", 0.0)?;
        let count = match &r.count {
            Some(n) if !(1..=MAX_BURST).contains(n.get_ref()) => {
                return Err(c.err(
                    &n.span(),
                    "count",
                    format!("must be between 1 and {MAX_BURST}, not {}", n.get_ref()),
                ));
            }
            Some(n) => *n.get_ref(),
            None => 1,
        };
        let interval = c.opt_number(
            &r.interval_s,
            "interval_s",
            DEFAULT_BURST_INTERVAL_S,
            |t| t >= 0.0,
            "must be zero or more seconds",
        )?;
        for k in 0..count {
            projectiles.push(Event {
                event: Projectile {
                    origin,
                    direction,
                    mass_kg,
                    speed_mps,
                    time_s: time_s + k as f32 * interval,
                },
                character: None,
                line: src.line(p.span().start),
            });
        }
    }

    let mut pushes = Vec::new();
    for (i, p) in raw.push.iter().enumerate() {
        let c = Ctx {
            src: &src,
            place: format!("[[push]] {}", i + 1),
        };
        let r = p.get_ref();
        let who = pick_character(&c, &r.character, &names, p.span())?;
        let target = check_target(&c, &r.target, &characters[who])?;
        let push = match (&r.impulse_ns, &r.force_n) {
            (Some(j), None) => {
                c.refuse(
                    "start_s",
                    span_of(&r.start_s),
                    "applies to a force; an impulse takes time_s",
                )?;
                c.refuse(
                    "end_s",
                    span_of(&r.end_s),
                    "applies to a force; an impulse takes time_s",
                )?;
                Push::Impulse {
                    target,
                    impulse_ns: c.vec3(j, "impulse_ns")?,
                    time_s: c.time(&r.time_s, "time_s", 0.0)?,
                }
            }
            (None, Some(f)) => {
                c.refuse(
                    "time_s",
                    span_of(&r.time_s),
                    "applies to an impulse; a force takes start_s and end_s",
                )?;
                let (start_s, end_s) = c.window(&r.start_s, &r.end_s)?;
                Push::Force {
                    target,
                    force_n: c.vec3(f, "force_n")?,
                    start_s,
                    end_s,
                }
            }
            (Some(_), Some(f)) => {
                return Err(c.err(
                    &f.span(),
                    "force_n",
                    "give either impulse_ns or force_n, not both",
                ));
            }
            (None, None) => {
                return Err(c.err(
                    &p.span(),
                    "impulse_ns",
                    "missing: give an impulse_ns (N·s) or a force_n (N)",
                ));
            }
        };
        pushes.push(Event {
            event: push,
            character: Some(who),
            line: src.line(p.span().start),
        });
    }

    let mut fields = Vec::new();
    for (i, f) in raw.field.iter().enumerate() {
        let c = Ctx {
            src: &src,
            place: format!("[[field]] {}", i + 1),
        };
        fields.push(Event {
            event: field(&c, f.get_ref())?,
            character: None,
            line: src.line(f.span().start),
        });
    }

    let mut pins = Vec::new();
    for (i, p) in raw.pin.iter().enumerate() {
        let c = Ctx {
            src: &src,
            place: format!("[[pin]] {}", i + 1),
        };
        let r = p.get_ref();
        let who = pick_character(&c, &r.character, &names, p.span())?;
        let target = check_target(&c, &r.target, &characters[who])?;
        let keys = match (&r.position, &r.keys) {
            (Some(pos), None) => vec![(0.0, c.vec3(pos, "position")?)],
            (None, Some(keys)) => {
                let span = keys.span();
                let keys: Vec<(f32, Vec3)> = keys
                    .get_ref()
                    .iter()
                    .map(|k| (k.time_s, Vec3::from_array(k.position)))
                    .collect();
                check_keys(&c, &span, &keys, "position")?;
                keys
            }
            (Some(_), Some(k)) => {
                return Err(c.err(&k.span(), "keys", "give either position or keys, not both"));
            }
            (None, None) => {
                return Err(c.err(
                    &p.span(),
                    "position",
                    "missing: give a position to hold or keys to drag along",
                ));
            }
        };
        let stiffness_hz = match &r.stiffness_hz {
            Some(k) => Some(c.number(
                k,
                "stiffness_hz",
                |k| k > 0.0,
                "must be more than 0 Hz (leave it out for a hard pin)",
            )?),
            None => None,
        };
        if r.stiffness_hz.is_none() {
            c.refuse(
                "damping_ratio",
                span_of(&r.damping_ratio),
                "applies to a soft pin: give stiffness_hz too",
            )?;
        }
        let damping_ratio = c.opt_number(
            &r.damping_ratio,
            "damping_ratio",
            1.0,
            |d| d >= 0.0,
            "must be zero or more",
        )?;
        let release_s = match &r.release_s {
            Some(t) => {
                Some(c.number(t, "release_s", |t| t >= 0.0, "must be zero or more seconds")?)
            }
            None => None,
        };
        pins.push(Event {
            event: Pin {
                target,
                keys,
                stiffness_hz,
                damping_ratio,
                release_s,
            },
            character: Some(who),
            line: src.line(p.span().start),
        });
    }

    let outputs = outputs(&src, raw.output.as_ref(), &names)?;
    Ok(Scene {
        path: path.to_path_buf(),
        duration_s,
        settings,
        characters,
        blasts,
        projectiles,
        pushes,
        fields,
        pins,
        outputs,
    })
}

impl Src<'_> {
    fn err_line(&self, line: usize, message: String) -> Error {
        Error::Parse {
            path: self.path.to_path_buf(),
            line,
            message,
        }
    }
}

/// Keys in time order, times zero or more, values finite.
fn check_keys(c: &Ctx, span: &Range<usize>, keys: &[(f32, Vec3)], what: &str) -> Result<()> {
    if keys.is_empty() {
        return Err(c.err(span, "keys", "needs at least one key"));
    }
    for (k, (t, v)) in keys.iter().enumerate() {
        if !(t.is_finite() && *t >= 0.0) {
            return Err(c.err(
                span,
                "keys",
                format!(
                    "key {}: time_s must be zero or more seconds, not {t}",
                    k + 1
                ),
            ));
        }
        if !v.is_finite() {
            return Err(c.err(
                span,
                "keys",
                format!("key {}: {what} must be three finite numbers", k + 1),
            ));
        }
        if k > 0 && *t < keys[k - 1].0 {
            return Err(c.err(
                span,
                "keys",
                format!(
                    "key {}: times must not go backwards ({t} after {})",
                    k + 1,
                    keys[k - 1].0
                ),
            ));
        }
    }
    Ok(())
}

fn field(c: &Ctx, r: &RawField) -> Result<Field> {
    let kind = r.kind.get_ref().as_str();
    // Which keys each kind takes, to refuse the others by name.
    let given: [(&str, Option<Range<usize>>); 8] = [
        ("keys", span_of(&r.keys)),
        ("center", span_of(&r.center)),
        ("strength_mps2", span_of(&r.strength_mps2)),
        ("radius_m", span_of(&r.radius_m)),
        ("rate_per_s", span_of(&r.rate_per_s)),
        ("velocity_mps", span_of(&r.velocity_mps)),
        ("start_s", span_of(&r.start_s)),
        ("end_s", span_of(&r.end_s)),
    ];
    let takes: &[&str] = match kind {
        "gravity" => &["keys"],
        "radial" => &["center", "strength_mps2", "radius_m", "start_s", "end_s"],
        "drag" => &["rate_per_s", "start_s", "end_s"],
        "wind" => &["velocity_mps", "start_s", "end_s"],
        _ => {
            return Err(c.err(
                &r.kind.span(),
                "kind",
                format!(
                    "\"{kind}\" is not a field; use \"gravity\", \"radial\", \"drag\" or \"wind\""
                ),
            ));
        }
    };
    for (key, span) in &given {
        if !takes.contains(key) {
            c.refuse(
                key,
                span.clone(),
                &format!("does not apply to a {kind} field"),
            )?;
        } else if span.is_none() && !matches!(*key, "start_s" | "end_s") {
            return Err(c.err(
                &r.kind.span(),
                key,
                format!("missing: a {kind} field needs it"),
            ));
        }
    }
    let req3 = |v: &Option<S<[f32; 3]>>, key: &str| c.vec3(v.as_ref().expect("checked above"), key);
    Ok(match kind {
        "gravity" => {
            let keys = r.keys.as_ref().expect("checked above");
            let values: Vec<(f32, Vec3)> = keys
                .get_ref()
                .iter()
                .map(|k| (k.time_s, Vec3::from_array(k.gravity)))
                .collect();
            check_keys(c, &keys.span(), &values, "gravity")?;
            Field::Gravity { keys: values }
        }
        "radial" => {
            let (start_s, end_s) = c.window(&r.start_s, &r.end_s)?;
            Field::Radial {
                center: req3(&r.center, "center")?,
                strength_mps2: c.number(
                    req(&r.strength_mps2),
                    "strength_mps2",
                    |_| true,
                    "must be a finite acceleration in m/s²",
                )?,
                radius_m: c.number(
                    req(&r.radius_m),
                    "radius_m",
                    |x| x > 0.0,
                    "must be more than 0 m",
                )?,
                start_s,
                end_s,
            }
        }
        "drag" => {
            let (start_s, end_s) = c.window(&r.start_s, &r.end_s)?;
            Field::Drag {
                rate_per_s: c.number(
                    req(&r.rate_per_s),
                    "rate_per_s",
                    |x| x >= 0.0,
                    "must be zero or more per second",
                )?,
                start_s,
                end_s,
            }
        }
        _ => {
            let (start_s, end_s) = c.window(&r.start_s, &r.end_s)?;
            Field::Wind {
                velocity_mps: req3(&r.velocity_mps, "velocity_mps")?,
                start_s,
                end_s,
            }
        }
    })
}

/// A key [`field`] has checked is there.
fn req(v: &Option<S<f32>>) -> &S<f32> {
    v.as_ref().expect("checked above")
}

/// The character an event names, or the only one.
fn pick_character(
    c: &Ctx,
    name: &Option<S<String>>,
    names: &[&str],
    table: Range<usize>,
) -> Result<usize> {
    match name {
        Some(n) => names.iter().position(|x| x == n.get_ref()).ok_or_else(|| {
            c.err(
                &n.span(),
                "character",
                format!(
                    "no character is named \"{}\" (the scene has: {})",
                    n.get_ref(),
                    names.join(", ")
                ),
            )
        }),
        None if names.len() == 1 => Ok(0),
        None => Err(c.err(
            &table,
            "character",
            format!(
                "missing: the scene has several characters ({})",
                names.join(", ")
            ),
        )),
    }
}

/// A body or joint of the character, checked here so a typo fails at load time.
fn check_target(c: &Ctx, target: &S<String>, who: &SceneCharacter) -> Result<String> {
    let t = target.get_ref();
    if who.spec.body_index(t).is_some() || who.character.skeleton.find(t).is_some() {
        return Ok(t.clone());
    }
    let bodies: Vec<&str> = who.spec.bodies.iter().map(|b| b.name.as_str()).collect();
    Err(c.err(
        &target.span(),
        "target",
        format!(
            "{} has no body or joint named \"{t}\" (its bodies: {})",
            who.name,
            bodies.join(", ")
        ),
    ))
}

/// A name safe as a file name on every system (it names the character's BVH file).
fn valid_name(name: &str) -> bool {
    !name.is_empty()
        && name.len() <= 64
        && !name.starts_with('.')
        && name
            .chars()
            .all(|c| c.is_alphanumeric() || matches!(c, '_' | '-' | '.'))
}

fn characters(src: &Src, raw: &[S<RawCharacter>]) -> Result<Vec<SceneCharacter>> {
    let dir = src.path.parent().unwrap_or(Path::new(""));
    // Explicit names first, so a default name can step around them.
    let mut taken: Vec<String> = Vec::new();
    for (i, rc) in raw.iter().enumerate() {
        if let Some(n) = &rc.get_ref().name {
            let c = Ctx {
                src,
                place: format!("[[character]] {}", i + 1),
            };
            if !valid_name(n.get_ref()) {
                return Err(c.err(
                    &n.span(),
                    "name",
                    format!("\"{}\" must be 1 to 64 letters, digits, '_', '-' or '.' (not first), as it names a file", n.get_ref()),
                ));
            }
            if taken.iter().any(|t| t.eq_ignore_ascii_case(n.get_ref())) {
                return Err(c.err(
                    &n.span(),
                    "name",
                    format!("two characters are named \"{}\" (names must differ by more than case: they name files)", n.get_ref()),
                ));
            }
            taken.push(n.get_ref().clone());
        }
    }
    let mut cache: Vec<((PathBuf, ImportOptions), Character)> = Vec::new();
    let mut out = Vec::with_capacity(raw.len());
    for (i, rc) in raw.iter().enumerate() {
        let r = rc.get_ref();
        let line = src.line(rc.span().start);
        let mut c = Ctx {
            src,
            place: format!("[[character]] {}", i + 1),
        };
        let is_bvh = r.file.as_ref().is_some_and(|f| {
            Path::new(f.get_ref())
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("bvh"))
        });
        if !is_bvh {
            c.refuse("units", span_of(&r.units), "applies to BVH files only")?;
            c.refuse("up", span_of(&r.up), "applies to BVH files only")?;
        }
        let opts = ImportOptions {
            units: r.units.as_ref().map(|u| *u.get_ref()),
            up: r.up.as_ref().map(|u| *u.get_ref()),
        };
        let (mut character, input) = match &r.file {
            None => (skeleton::humanoid(), "built-in".to_string()),
            Some(f) => {
                let path = dir.join(f.get_ref());
                let key = (path.clone(), opts);
                let character = match cache.iter().find(|(k, _)| *k == key) {
                    Some((_, ch)) => ch.clone(),
                    None => {
                        let ch =
                            import::load(&path, &opts).map_err(|e| c.err(&f.span(), "file", e))?;
                        cache.push((key, ch.clone()));
                        ch
                    }
                };
                (character, f.get_ref().clone())
            }
        };
        let name = match &r.name {
            Some(n) => n.get_ref().clone(),
            None => {
                let base = if valid_name(&character.name) {
                    character.name.clone()
                } else {
                    "character".to_string()
                };
                let mut name = base.clone();
                let mut k = 2;
                while taken.iter().any(|t| t.eq_ignore_ascii_case(&name)) {
                    name = format!("{base}_{k}");
                    k += 1;
                }
                taken.push(name.clone());
                name
            }
        };
        c.place = format!("[[character]] \"{name}\"");
        character.name = name.clone();
        let mass = match &r.mass_kg {
            Some(m) => Some(c.number(m, "mass_kg", |m| m > 0.0, "must be more than 0 kg")?),
            None => None,
        };
        let female = r.female.as_ref().is_some_and(|f| *f.get_ref());
        let mut spec = match &r.spec {
            Some(s) => {
                c.refuse(
                    "mass_kg",
                    span_of(&r.mass_kg),
                    "set it in the spec file instead (masses are per body there)",
                )?;
                c.refuse(
                    "female",
                    span_of(&r.female),
                    "set it in the spec file instead (masses are per body there)",
                )?;
                let path = dir.join(s.get_ref());
                let text = std::fs::read_to_string(&path)
                    .map_err(|e| c.err(&s.span(), "spec", Error::io(&path, e)))?;
                RagdollSpec::from_toml(&text, &path).map_err(|e| c.err(&s.span(), "spec", e))?
            }
            None => spec::build_spec(
                &character,
                &BuildOptions {
                    total_mass_kg: mass,
                    female,
                },
            )
            .map_err(|e| c.err(&rc.span(), "ragdoll", e))?,
        };
        spec.name = name.clone();
        let position = match &r.position {
            Some(p) => c.vec3(p, "position")?,
            None => Vec3::ZERO,
        };
        let facing_deg = c.opt_number(
            &r.facing_deg,
            "facing_deg",
            0.0,
            |_| true,
            "must be a finite angle in degrees",
        )?;
        let activation = r
            .activate
            .as_ref()
            .map_or(Activation::Immediately, |a| a.get_ref().0);
        if activation != Activation::Immediately
            && let Some(a) = &r.activate
            && !character.clips.iter().any(|clip| !clip.frames.is_empty())
        {
            return Err(c.err(
                &a.span(),
                "activate",
                format!(
                    "{} has no animation to play before physics takes over; use \"start\"",
                    if r.file.is_none() {
                        "the built-in humanoid"
                    } else {
                        input.as_str()
                    }
                ),
            ));
        }
        let motors = match &r.powered {
            None => None,
            Some(p) => {
                let raw = p.get_ref();
                let mut motors = match raw.fade_out {
                    Some([start, end]) => Motors::fade_out(raw.strength, start, end),
                    None => Motors::constant(raw.strength),
                };
                motors.root_on_clip = raw.root_on_clip.unwrap_or(false);
                if let Err(Error::Setting { message, .. }) = motors.validate() {
                    return Err(c.err(&p.span(), "powered", message));
                }
                if !character.clips.iter().any(|clip| !clip.frames.is_empty()) {
                    return Err(c.err(
                        &p.span(),
                        "powered",
                        "the character has no animation for the motors to track",
                    ));
                }
                Some(motors)
            }
        };
        out.push(SceneCharacter {
            name,
            input,
            character,
            spec,
            position,
            facing_deg,
            activation,
            motors,
            line,
        });
    }
    Ok(out)
}

/// A plain file name, so outputs stay inside the output folder.
fn plain_file_name(name: &str) -> bool {
    !name.is_empty()
        && name != "."
        && name != ".."
        && !name.contains(['/', '\\', ':'])
        && !name.chars().any(char::is_control)
}

fn outputs(src: &Src, raw: Option<&RawOutput>, names: &[&str]) -> Result<Outputs> {
    let mut out = Outputs::default();
    let Some(raw) = raw else {
        return Ok(out);
    };
    let c = Ctx {
        src,
        place: "[output]".into(),
    };
    let pick = |v: &Option<S<OutputName>>,
                key: &str,
                default: Option<String>,
                ext: &str|
     -> Result<Option<String>> {
        let Some(v) = v else {
            return Ok(default);
        };
        match v.get_ref() {
            OutputName::Off => Ok(None),
            OutputName::Default => Ok(default),
            OutputName::Name(n) => {
                if !plain_file_name(n) {
                    return Err(c.err(
                        &v.span(),
                        key,
                        format!(
                            "\"{n}\" must be a plain file name (it goes inside the output folder)"
                        ),
                    ));
                }
                if !n.to_ascii_lowercase().ends_with(ext) {
                    return Err(c.err(&v.span(), key, format!("\"{n}\" must end in {ext}")));
                }
                Ok(Some(n.clone()))
            }
        }
    };
    out.glb = pick(&raw.glb, "glb", out.glb.clone(), ".glb")?;
    out.bvh = pick(&raw.bvh, "bvh", out.bvh.clone(), ".bvh")?;
    out.report = pick(&raw.report, "report", out.report.clone(), ".json")?;
    if let (Some(pattern), Some(v)) = (&out.bvh, &raw.bvh)
        && names.len() > 1
        && !pattern.contains("{name}")
    {
        return Err(c.err(
            &v.span(),
            "bvh",
            "must contain {name}: the scene has several characters, each with its own BVH",
        ));
    }
    // Outputs cannot collide: their extensions differ, and character names differ by more
    // than case.
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn key_and_table_are_found_from_a_position() {
        let text = "fps = 30\n[[blast]]\ntnt_kg = 1\n[[blast]]\nposition = [1, \"a\"]\n";
        let pos = text.find("\"a\"").unwrap();
        assert_eq!(key_before(text, pos).as_deref(), Some("position"));
        assert_eq!(table_at(text, pos).as_deref(), Some("[[blast]] 2"));
        assert_eq!(table_at(text, 3), None);
        let inline = "keys = [{ time_s = 0, gravity = [0, 1] }]";
        let pos = inline.find("[0, 1]").unwrap();
        assert_eq!(key_before(inline, pos).as_deref(), Some("gravity"));
    }

    #[test]
    fn names_must_be_safe_file_names() {
        assert!(valid_name("alice_2"));
        assert!(valid_name("José"));
        assert!(!valid_name("../x"));
        assert!(!valid_name(".hidden"));
        assert!(!valid_name(""));
        assert!(plain_file_name("scene.glb"));
        assert!(!plain_file_name("../scene.glb"));
        assert!(!plain_file_name("a/b.glb"));
    }
}
