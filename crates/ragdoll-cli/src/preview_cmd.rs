//! Preview pictures from the CLI: `--preview FILE.png|FILE.gif` on demo, simulate (a
//! character file or a scene), blast and shoot, and `ragdoll preview RESULT.glb -o FILE`
//! for any baked result. The drawing is the `ragdoll-preview` crate's; this file only
//! turns commands' events into markers and a baked file back into a track. Also the
//! `--obj-sequence DIR` writer, which like a preview is an extra view of a finished run.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::Args;
use glam::Vec3;
use ragdoll::events::{Blast, Projectile, ProjectileReport};
use ragdoll::export::obj;
use ragdoll::import::{self, ImportOptions};
use ragdoll::math::Transform;
use ragdoll::skeleton::Character;
use ragdoll::spec::{self, BuildOptions, RagdollSpec};
use ragdoll::track::Track;
use ragdoll_preview::{Format, Marker, PreviewOptions};

use crate::output::{self, Staging};
use crate::progress::Progress;

/// The `--preview` flag the simulating commands share.
#[derive(Args, Debug, Clone, Default)]
pub struct PreviewArg {
    /// Also draw a preview of the result (CPU-rendered, 640×480): .png for one frame (the
    /// middle one), .gif for the whole animation.
    #[arg(long, value_name = "FILE.png|FILE.gif")]
    pub preview: Option<PathBuf>,
}

impl PreviewArg {
    /// Fails on an extension we cannot draw or a path we cannot write, before any
    /// simulation time is spent.
    pub fn check(&self) -> Result<()> {
        if let Some(p) = &self.preview {
            ragdoll_preview::format_of(p).map_err(flag("--preview"))?;
            output::check_file(p)?;
        }
        Ok(())
    }

    /// Draws the preview, when one was asked for, and stages it with the run's other
    /// outputs; returns its path.
    pub fn stage(
        &self,
        staging: &mut Staging,
        actors: &[ragdoll_preview::Actor<'_>],
        markers: &[Marker],
        progress: &Progress,
    ) -> Result<Option<PathBuf>> {
        let Some(path) = &self.preview else {
            return Ok(None);
        };
        progress.stage(0, "drawing the preview");
        let bytes = ragdoll_preview::encode(path, actors, markers, &PreviewOptions::default())
            .map_err(flag("--preview"))?;
        staging.write(path, &bytes)?;
        Ok(Some(path.clone()))
    }
}

/// A library setting error reported under the flag's name.
fn flag(name: &'static str) -> impl Fn(ragdoll::Error) -> anyhow::Error {
    move |e| match e {
        ragdoll::Error::Setting { message, .. } => anyhow::anyhow!("{name}: {message}"),
        e => e.into(),
    }
}

/// The markers for a run's blasts and shots; `hits` are the shots' reports, in order.
pub fn markers(blasts: &[Blast], shots: &[Projectile], hits: &[ProjectileReport]) -> Vec<Marker> {
    let mut out: Vec<Marker> = blasts
        .iter()
        .map(|b| Marker::Blast {
            position: b.position,
            time_s: b.time_s,
            tnt_kg: b.tnt_kg,
        })
        .collect();
    for (k, s) in shots.iter().enumerate() {
        let hit = hits.get(k).and_then(|r| r.point).map(Vec3::from_array);
        // A miss: the tracer runs on past the scene (about as far again as the origin is
        // from the centre).
        let end = hit.unwrap_or_else(|| {
            s.origin + s.direction.normalize_or_zero() * (s.origin.length() + 3.0)
        });
        out.push(Marker::Shot {
            origin: s.origin,
            end,
            time_s: s.time_s,
            hit: hit.is_some(),
        });
    }
    out
}

/// `--obj-sequence DIR`: one OBJ per frame of the deformed mesh (or the ragdoll's bodies),
/// staged with the run's other outputs (each frame goes to disk as it is encoded, so a
/// long run does not hold them all in memory); returns their paths.
pub fn stage_obj_sequence(
    staging: &mut Staging,
    dir: &Path,
    character: &Character,
    spec: &RagdollSpec,
    track: &Track,
    progress: &Progress,
) -> Result<Vec<PathBuf>> {
    let mut seq = obj::ObjSequence::new(character, spec)?;
    let n = track.frames.len();
    progress.stage(n as u64, "writing OBJ files");
    let mut paths = Vec::with_capacity(n);
    for (f, frame) in track.frames.iter().enumerate() {
        let text = seq.frame(frame)?;
        let path = dir.join(obj::file_name(f, n));
        staging.write(&path, text.as_bytes())?;
        paths.push(path);
        progress.set(f as u64 + 1);
    }
    Ok(paths)
}

/// `ragdoll preview RESULT.glb -o FILE.gif|png`.
#[derive(Args, Debug)]
pub struct PreviewArgs {
    /// A .glb written by ragdoll (its animation "ragdoll" is the motion drawn). Blasts and
    /// shots are marked when its report (STEM.report.json) lies beside it.
    file: PathBuf,
    /// The picture: .png (one frame) or .gif (the animation).
    #[arg(short, long, value_name = "FILE.png|FILE.gif")]
    output: PathBuf,
    /// Picture size in pixels.
    #[arg(long, value_name = "WxH", default_value = "640x480", value_parser = parse_size)]
    size: (u32, u32),
    /// At most this many GIF frames per second (every n-th frame of the animation); 15 by
    /// default. For a .gif only.
    #[arg(long, allow_negative_numbers = true, value_name = "FPS")]
    gif_fps: Option<f32>,
    /// The frame a PNG shows, counted from 0 (default: the middle one). For a .png only.
    #[arg(long, allow_negative_numbers = true, value_name = "N")]
    frame: Option<usize>,
}

fn parse_size(text: &str) -> Result<(u32, u32), String> {
    let (w, h) = text
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("expected WIDTHxHEIGHT, e.g. 640x480, got \"{text}\""))?;
    let num = |s: &str| {
        s.trim()
            .parse::<u32>()
            .map_err(|_| format!("\"{s}\" is not a whole number of pixels"))
    };
    Ok((num(w)?, num(h)?))
}

pub fn run(a: &PreviewArgs) -> Result<()> {
    let format = ragdoll_preview::format_of(&a.output).map_err(flag("-o"))?;
    match format {
        Format::Png if a.gif_fps.is_some() => bail!(
            "--gif-fps: {} is a PNG (one frame); the GIF frame rate applies to a .gif",
            a.output.display()
        ),
        Format::Gif if a.frame.is_some() => bail!(
            "--frame: {} is a GIF (the whole animation); --frame picks the frame of a .png",
            a.output.display()
        ),
        _ => {}
    }
    let defaults = PreviewOptions::default();
    let options = PreviewOptions {
        width: a.size.0,
        height: a.size.1,
        gif_fps: a.gif_fps.unwrap_or(defaults.gif_fps),
        png_frame: a.frame,
        ..defaults
    };
    output::check_file(&a.output)?;
    let is_glb = a
        .file
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("glb") || e.eq_ignore_ascii_case("gltf"));
    if !is_glb {
        bail!(
            "{}: expected a baked result (.glb or .gltf written by ragdoll)",
            a.file.display()
        );
    }
    let character = import::load(&a.file, &ImportOptions::default())?;
    let track = baked_track(&character, &a.file)?;
    // Only drawn when the file carries no mesh (it always does when ragdoll wrote it).
    let spec = if character.meshes.is_empty() {
        spec::build_spec(&character, &BuildOptions::default())?
    } else {
        empty_spec(&character.name)
    };
    let markers = report_markers(&a.file)?;
    let progress = Progress::new(0, "drawing");
    let bytes = ragdoll_preview::encode(
        &a.output,
        &[(&character, &spec, &track)],
        &markers,
        &options,
    )
    .map_err(option_error)?;
    progress.finish();
    output::write_one(&a.output, &bytes)?;
    errln!(
        "{}: {} frames at {:.1} fps drawn",
        character.name,
        track.frames.len(),
        track.fps
    );
    outln!("{}", a.output.display());
    Ok(())
}

/// The motion of a baked file: its clip named `ragdoll` (the one our exporter writes),
/// as world transforms.
fn baked_track(character: &Character, path: &Path) -> Result<Track> {
    let clip = character
        .clips
        .iter()
        .find(|c| c.name == ragdoll::export::gltf::ANIMATION_NAME)
        .with_context(|| {
            format!(
                "{}: no animation named \"{}\" (was this file written by ragdoll?)",
                path.display(),
                ragdoll::export::gltf::ANIMATION_NAME
            )
        })?;
    if !(clip.frame_time.is_finite() && clip.frame_time > 0.0) || clip.frames.is_empty() {
        bail!(
            "{}: the \"ragdoll\" animation has no frames",
            path.display()
        );
    }
    let s = &character.skeleton;
    let frames = clip
        .frames
        .iter()
        .map(|locals| {
            let mut world = vec![Transform::IDENTITY; s.len()];
            s.world_from_local(locals, &mut world);
            world
        })
        .collect();
    Ok(Track {
        fps: 1.0 / clip.frame_time,
        frames,
    })
}

fn empty_spec(name: &str) -> RagdollSpec {
    RagdollSpec {
        format_version: spec::SPEC_FORMAT_VERSION,
        name: name.into(),
        bodies: Vec::new(),
        joints: Vec::new(),
        collision: Default::default(),
    }
}

/// A preview option out of range, under the flag that set it (the library names the
/// option's field).
fn option_error(e: ragdoll::Error) -> anyhow::Error {
    match e {
        ragdoll::Error::Setting { setting, message } => {
            let flag = match setting.as_str() {
                "width" | "height" | "size" | "supersample" => "--size",
                "gif_fps" => "--gif-fps",
                "png_frame" | "frames" => "--frame",
                _ => "preview",
            };
            anyhow::anyhow!("{flag}: {message}")
        }
        e => e.into(),
    }
}

/// Blasts and hits from `<stem>.report.json` beside the file, when there is one. Reports
/// hold where a shot hit but not where it came from, so shots show as a spark at the hit.
fn report_markers(glb: &Path) -> Result<Vec<Marker>> {
    let stem = glb
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let path = glb.with_file_name(format!("{stem}.report.json"));
    if !path.exists() {
        return Ok(Vec::new());
    }
    let text = ragdoll::files::read_text_capped(&path, ragdoll::files::MAX_SETTINGS_BYTES)?;
    let json: serde_json::Value = serde_json::from_str(&text)
        .with_context(|| format!("{}: not a JSON report", path.display()))?;
    let mut out = Vec::new();
    let v3 = |v: &serde_json::Value| -> Option<Vec3> {
        let a = v.as_array()?;
        let f = |i: usize| a.get(i)?.as_f64().map(|x| x as f32);
        Some(Vec3::new(f(0)?, f(1)?, f(2)?)).filter(|p| p.is_finite())
    };
    let num = |v: &serde_json::Value| v.as_f64().map(|x| x as f32).filter(|x| x.is_finite());
    for b in json["blasts"].as_array().into_iter().flatten() {
        if let (Some(position), Some(time_s), Some(tnt_kg)) =
            (v3(&b["position"]), num(&b["time_s"]), num(&b["tnt_kg"]))
        {
            out.push(Marker::Blast {
                position,
                time_s,
                tnt_kg,
            });
        }
    }
    for p in json["projectiles"].as_array().into_iter().flatten() {
        if let (Some(point), Some(time_s)) = (v3(&p["point"]), num(&p["time_s"])) {
            // Reports older than the `origin` field draw the hit alone.
            out.push(Marker::Shot {
                origin: v3(&p["origin"]).unwrap_or(point),
                end: point,
                time_s,
                hit: true,
            });
        }
    }
    Ok(out)
}
