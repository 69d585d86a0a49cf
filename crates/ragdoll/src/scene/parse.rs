//! Reading a scene file: TOML into checked values. serde with `deny_unknown_fields` catches
//! unknown keys and wrong types (toml gives the byte span, which `source.rs` turns into a
//! line); values checked after parsing keep their spans with [`toml::Spanned`], so every
//! error names the file, the line and the key. `raw.rs` holds the tables as written,
//! `characters.rs` and `timeline.rs` check the characters and the events.

use std::fmt;
use std::ops::Range;
use std::path::Path;

use glam::Vec3;

use super::characters::{Table, characters};
use super::raw::{GroundValue, OutputName, RawOutput, RawScene, S, StartPoseName};
use super::source::Src;
use super::timeline::{blasts, fields, pins, projectiles, pushes};
use super::{Outputs, Scene};
use crate::error::{Error, Result};
use crate::events::{check_end, check_keys, check_magnitude, check_point, check_time};
use crate::spec::check_within;
use crate::world::{
    Activation, BackendConfig, BackendKind, FastConfig, MAX_COORDINATE_M, MAX_FPS,
    MAX_GRAVITY_MPS2, MAX_JOINT_DAMPING, MAX_SECONDS, StartPose, WorldSettings,
};

/// Most characters in one scene. Each is loaded and built before anything runs; a crowd
/// needs bodies to fit [`MAX_SCENE_BODIES`] too, and its frames the world's cap on
/// recorded joint transforms (10,000 humanoids record about 200,000 a frame).
pub const MAX_CHARACTERS: usize = 10_000;

/// Most bodies over every character of a scene: ten thousand 16-body humanoids.
///
/// Spread out, a crowd costs in proportion to its bodies; bodies of different characters
/// that start inside each other cost per pair (100 humanoids on one spot took 23 s and
/// 768 MB), so keep characters apart.
pub const MAX_SCENE_BODIES: usize = 163_840;

/// Most events in one scene, counting each shot of a burst: every event is looked at
/// every substep until it is over.
pub const MAX_EVENTS: usize = 10_000;

/// Where in the file a table's values are: its name for messages, and the file.
pub(super) struct Ctx<'a> {
    pub(super) src: &'a Src<'a>,
    pub(super) place: String,
}

impl<'a> Ctx<'a> {
    pub(super) fn new(src: &'a Src<'a>, place: String) -> Self {
        Ctx { src, place }
    }

    pub(super) fn err(&self, span: &Range<usize>, key: &str, message: impl fmt::Display) -> Error {
        let message = if self.place.is_empty() {
            format!("{key}: {message}")
        } else {
            format!("{}: {key}: {message}", self.place)
        };
        self.src.err(span, message)
    }

    /// A number that passes `check` (which says what it must be when it does not).
    pub(super) fn checked(
        &self,
        v: &S<f32>,
        key: &str,
        check: impl Fn(f32) -> std::result::Result<(), String>,
    ) -> Result<f32> {
        let x = *v.get_ref();
        check(x).map_err(|m| self.err(&v.span(), key, m))?;
        Ok(x)
    }

    /// An optional number that passes `check`, or `default`.
    pub(super) fn opt_checked(
        &self,
        v: &Option<S<f32>>,
        key: &str,
        default: f32,
        check: impl Fn(f32) -> std::result::Result<(), String>,
    ) -> Result<f32> {
        match v {
            Some(v) => self.checked(v, key, check),
            None => Ok(default),
        }
    }

    /// A time within a run, or `default`.
    pub(super) fn time(&self, v: &Option<S<f32>>, key: &str, default: f32) -> Result<f32> {
        self.opt_checked(v, key, default, check_time)
    }

    /// Three finite numbers.
    pub(super) fn vec3(&self, v: &S<[f32; 3]>, key: &str) -> Result<Vec3> {
        let x = Vec3::from_array(*v.get_ref());
        if x.is_finite() {
            Ok(x)
        } else {
            Err(self.err(&v.span(), key, "must be three finite numbers"))
        }
    }

    /// A point within the world's extent.
    pub(super) fn point(&self, v: &S<[f32; 3]>, key: &str) -> Result<Vec3> {
        let x = Vec3::from_array(*v.get_ref());
        check_point(x).map_err(|m| self.err(&v.span(), key, m))?;
        Ok(x)
    }

    /// A vector at most `max` long.
    pub(super) fn vector(&self, v: &S<[f32; 3]>, key: &str, max: f32, unit: &str) -> Result<Vec3> {
        let x = Vec3::from_array(*v.get_ref());
        check_magnitude(x, max, unit).map_err(|m| self.err(&v.span(), key, m))?;
        Ok(x)
    }

    /// `[start_s, end_s]`: from 0 and open-ended by default, in order, within a run.
    pub(super) fn window(
        &self,
        start: &Option<S<f32>>,
        end: &Option<S<f32>>,
    ) -> Result<(f32, f32)> {
        let s = self.time(start, "start_s", 0.0)?;
        match end {
            Some(end) => Ok((s, self.checked(end, "end_s", |e| check_end(s, e))?)),
            None => Ok((s, crate::events::OPEN_END_S)),
        }
    }

    /// Keys at `span` (times in order within a run, each value passing `value`).
    pub(super) fn keys<T: Copy>(
        &self,
        span: &Range<usize>,
        keys: &[(f32, T)],
        what: &str,
        value: impl Fn(T) -> std::result::Result<(), String>,
    ) -> Result<()> {
        check_keys(keys, |v| value(v).map_err(|m| format!("{what} {m}")))
            .map_err(|m| self.err(span, "keys", m))
    }

    /// A library check's verdict as an error at `span`, naming the setting it names.
    pub(super) fn valid(&self, span: &Range<usize>, verdict: Result<()>) -> Result<()> {
        verdict.map_err(|e| match e {
            Error::Setting { setting, message } => self.err(span, &setting, message),
            e => self.err(span, "value", e),
        })
    }

    /// Fails when a key given in the file does not apply here.
    pub(super) fn refuse(&self, key: &str, span: Option<Range<usize>>, why: &str) -> Result<()> {
        match span {
            Some(span) => Err(self.err(&span, key, why)),
            None => Ok(()),
        }
    }
}

pub(super) fn span_of<T>(v: &Option<S<T>>) -> Option<Range<usize>> {
    v.as_ref().map(|s| s.span())
}

// --- From the file to a Scene ----------------------------------------------------------

/// The fast engine's settings from the top-level keys, each checked at its key. They are
/// read whatever the backend (and ignored by the others), so that a wedge over
/// `backend` can carry them.
fn fast_config(top: &Ctx, raw: &RawScene) -> Result<FastConfig> {
    let mut fast = FastConfig::default();
    if let Some(f) = &raw.freeze_joints {
        fast.freeze_joints = *f.get_ref();
    }
    if let Some(k) = &raw.keep_contacts {
        fast.keep_contacts = *k.get_ref();
    }
    // Each count is checked as it is read, so the error points at its own key.
    let check = |fast: FastConfig, n: &S<u32>, key: &str| match BackendConfig::Fast(fast).validate()
    {
        Err(Error::Setting { setting, message }) if setting == key => {
            Err(top.err(&n.span(), key, message))
        }
        _ => Ok(()),
    };
    if let Some(n) = &raw.fast_substeps {
        fast.substeps = *n.get_ref() as usize;
        check(fast, n, "fast_substeps")?;
    }
    if let Some(n) = &raw.fast_iterations {
        fast.iterations = *n.get_ref() as usize;
        check(fast, n, "fast_iterations")?;
    }
    if let Some(n) = &raw.fast_impact_passes {
        fast.impact_passes = *n.get_ref() as usize;
        check(fast, n, "fast_impact_passes")?;
    }
    Ok(fast)
}

/// The world's settings from the top-level keys.
fn settings(src: &Src, raw: &RawScene) -> Result<(WorldSettings, FastConfig)> {
    let top = Ctx::new(src, String::new());
    let fps = top.opt_checked(&raw.fps, "fps", 30.0, |f| {
        check_within(f, 1.0, MAX_FPS, " frames per second")
    })?;
    let joint_damping = top.opt_checked(&raw.joint_damping, "joint_damping", 0.0, |c| {
        check_within(c, 0.0, MAX_JOINT_DAMPING, " per second")
    })?;
    let mut settings = WorldSettings {
        fps,
        joint_damping,
        ..Default::default()
    };
    if let Some(g) = &raw.gravity {
        settings.gravity = top.vector(g, "gravity", MAX_GRAVITY_MPS2, " m/s²")?;
    }
    if let Some(g) = &raw.ground {
        settings.ground = match *g.get_ref() {
            GroundValue::Height(h) => Some(top.checked(&S::new(g.span(), h), "ground", |h| {
                check_within(h, -MAX_COORDINATE_M, MAX_COORDINATE_M, " m")
                    .map_err(|m| format!("{m} (a height in metres, or \"none\")"))
            })?),
            GroundValue::None => None,
        };
    }
    let kind = match &raw.backend {
        Some(b) => BackendKind::from_name(b.get_ref()).ok_or_else(|| {
            top.err(&b.span(), "backend", {
                let names: Vec<String> = BackendKind::ALL
                    .iter()
                    .map(|k| format!("\"{}\"", k.as_str()))
                    .collect();
                format!(
                    "\"{}\" is not a backend; use {}",
                    b.get_ref(),
                    names.join(", ")
                )
            })
        })?,
        None => BackendKind::default(),
    };
    let fast = fast_config(&top, raw)?;
    settings.backend = match kind {
        BackendKind::Fast => BackendConfig::Fast(fast),
        other => other.into(),
    };
    // Damping the chosen backend cannot apply is refused at its key, not at run time.
    if let Some(c) = &raw.joint_damping
        && let Err(Error::Setting { setting, message }) = settings.validate()
        && setting == "joint_damping"
    {
        return Err(top.err(&c.span(), "joint_damping", message));
    }
    if let Some(s) = &raw.start_pose {
        settings.start = match s.get_ref() {
            StartPoseName::FirstFrame => StartPose::FirstFrame,
            StartPoseName::Rest => StartPose::Rest,
        };
    }
    Ok((settings, fast))
}

/// Refuses a scene with more tables of a kind than it may hold, at the first one past the
/// bound.
fn check_counts(src: &Src, raw: &RawScene) -> Result<()> {
    if raw.character.is_empty() {
        return Err(src.err(
            &(0..0),
            "a scene needs at least one [[character]] or [[crowd]] table (an empty [[character]] is the built-in humanoid)".into(),
        ));
    }
    if let Some(c) = raw.character.get(MAX_CHARACTERS) {
        return Err(src.err(
            &c.span(),
            format!(
                "[[character]]: a scene holds at most {MAX_CHARACTERS} characters, crowds' included"
            ),
        ));
    }
    let tables = [
        raw.blast.iter().map(S::span).collect::<Vec<_>>(),
        raw.projectile.iter().map(S::span).collect(),
        raw.push.iter().map(S::span).collect(),
        raw.field.iter().map(S::span).collect(),
        raw.pin.iter().map(S::span).collect(),
    ];
    let mut spans: Vec<Range<usize>> = tables.concat();
    if spans.len() > MAX_EVENTS {
        spans.sort_by_key(|s| s.start);
        return Err(src.err(
            &spans[MAX_EVENTS],
            format!("a scene holds at most {MAX_EVENTS} events"),
        ));
    }
    Ok(())
}

/// Refuses a scene whose characters hold more bodies than [`MAX_SCENE_BODIES`], or whose
/// run would record more than the world keeps (events are counted as they are read).
fn check_size(src: &Src, raw: &RawScene, scene: &Scene) -> Result<()> {
    let mut bodies = 0;
    for c in &scene.characters {
        bodies += c.spec.bodies.len();
        if bodies > MAX_SCENE_BODIES {
            return Err(src.err_line(
                c.line,
                format!(
                    "{}: the scene's characters would have {bodies} bodies, more than the \
                     {MAX_SCENE_BODIES} a scene may hold",
                    c.place
                ),
            ));
        }
    }
    let joints: usize = scene
        .characters
        .iter()
        .map(|c| c.character.skeleton.len())
        .sum();
    let span = raw
        .duration_s
        .as_ref()
        .or(raw.fps.as_ref())
        .map_or(0..0, S::span);
    let key = if raw.duration_s.is_some() {
        "duration_s"
    } else {
        "fps"
    };
    Ctx::new(src, String::new()).valid(
        &span,
        scene
            .settings
            .validate_run(scene.duration_s, joints)
            .map_err(|e| match e {
                Error::Setting { message, .. } => Error::Setting {
                    setting: key.into(),
                    message,
                },
                e => e,
            }),
    )
}

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
    let duration_s = Ctx::new(&src, String::new()).opt_checked(
        &raw.duration_s,
        "duration_s",
        3.0,
        check_above_zero_within_run,
    )?;
    let (settings, fast) = settings(&src, &raw)?;
    let mut raw = raw;
    let mut tables: Vec<Table> = (0..raw.character.len()).map(Table::Character).collect();
    for (crowd, member) in super::crowd::expand(&src, &raw.crowd)? {
        tables.push(Table::Crowd(crowd));
        raw.character.push(member);
    }
    check_counts(&src, &raw)?;
    let characters = characters(&src, &raw.character, &tables)?;
    let blasts = blasts(&src, &raw.blast)?;
    if let Some(c) = characters
        .iter()
        .find(|c| c.activation == Activation::OnBlast && blasts.is_empty())
    {
        return Err(src.err_line(
            c.line,
            format!(
                "{}: activate: \"blast\" needs a [[blast]] in the scene",
                c.place
            ),
        ));
    }
    let others = raw.blast.len() + raw.push.len() + raw.field.len() + raw.pin.len();
    let projectiles = projectiles(&src, &raw.projectile, MAX_EVENTS - others)?;
    let pushes = pushes(&src, &raw.push, &characters)?;
    let fields = fields(&src, &raw.field)?;
    let pins = pins(&src, &raw.pin, &characters)?;
    let names: Vec<&str> = characters.iter().map(|c| c.name.as_str()).collect();
    let outputs = outputs(&src, raw.output.as_ref(), &names)?;
    let scene = Scene {
        path: path.to_path_buf(),
        duration_s,
        settings,
        fast,
        characters,
        blasts,
        projectiles,
        pushes,
        fields,
        pins,
        outputs,
    };
    check_size(&src, &raw, &scene)?;
    Ok(scene)
}

/// A scene's duration: more than 0 and at most [`MAX_SECONDS`].
fn check_above_zero_within_run(t: f32) -> std::result::Result<(), String> {
    crate::spec::check_above(t, 0.0, MAX_SECONDS, " s")
}

/// Longest output file name, bytes: file systems allow 255, and `{name}` in the BVH
/// pattern grows by up to 64.
pub const MAX_OUTPUT_NAME_BYTES: usize = 128;

/// A plain file name, so outputs stay inside the output folder.
fn plain_file_name(name: &str) -> bool {
    !name.is_empty()
        && name.len() <= MAX_OUTPUT_NAME_BYTES
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
                            "\"{n}\" must be a plain file name of at most {MAX_OUTPUT_NAME_BYTES} bytes (it goes inside the output folder)"
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
    use super::super::characters::valid_name;
    use super::*;

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
