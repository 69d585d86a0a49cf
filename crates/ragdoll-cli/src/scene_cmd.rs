//! `ragdoll simulate SCENE.toml -o DIR`: runs a scene file (several characters and a
//! timeline of events, see the library's `scene` module) and writes its glTF, one BVH per
//! character and the report into a folder.

use std::path::Path;

use anyhow::{Result, bail};
use clap::ArgMatches;
use clap::parser::ValueSource;
use ragdoll::report::Report;
use ragdoll::scene::{Scene, SceneResult};
use ragdoll::world::StartPose;

use crate::SimulateArgs;
use crate::commands::check_finite;
use crate::output::{self, Staging};
use crate::progress::Progress;

/// What a scene's preview draws: each character with its spec and track, and a marker for
/// each blast and shot.
pub(crate) fn drawn<'a>(
    scene: &'a Scene,
    result: &'a SceneResult,
) -> (
    Vec<ragdoll_preview::Actor<'a>>,
    Vec<ragdoll_preview::Marker>,
) {
    let actors: Vec<_> = scene
        .characters
        .iter()
        .zip(&result.tracks)
        .map(|(c, t)| (&c.character, &c.spec, t))
        .collect();
    let blasts: Vec<_> = scene.blasts.iter().map(|b| b.event).collect();
    let shots: Vec<_> = scene.projectiles.iter().map(|p| p.event).collect();
    let markers = crate::preview_cmd::markers(&blasts, &shots, &result.report.projectiles);
    (actors, markers)
}

/// Whether `simulate` was given a scene file rather than a character: the `.toml`
/// extension decides (a character is `.bvh`, `.glb` or `.gltf`).
pub fn is_scene(file: &Path) -> bool {
    file.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("toml"))
}

/// Whether the user typed `--<id>` (clap fills defaults in either way).
fn given(m: &ArgMatches, id: &str) -> bool {
    m.value_source(id) == Some(ValueSource::CommandLine)
}

pub fn run(a: &SimulateArgs, matches: &ArgMatches) -> Result<()> {
    refuse_character_flags(a, matches)?;
    output::check_output_folder(&a.output)?;
    a.preview.check()?;
    let progress = Progress::new(0, "reading the scene");
    let mut scene = Scene::load(&a.file)?;
    print_warnings(&scene);
    apply_flags(a, matches, &mut scene)?;
    progress.stage(0, "building the scene");
    let mut started = false;
    let result = scene.run_with_progress(|done, total| {
        if !started {
            progress.stage(total, "simulating");
            started = true;
        }
        progress.set(done);
    })?;
    check_tracks(a, &scene, &result)?;
    progress.stage(0, "writing");
    let mut staging = Staging::new();
    for (name, bytes) in scene.encode(&result)? {
        staging.write(&a.output.join(name), &bytes)?;
    }
    let (actors, markers) = drawn(&scene, &result);
    let preview = a
        .preview
        .stage(&mut staging, &actors, &markers, &progress)?;
    crate::fatal::debug_panic_point("staged");
    let written = staging.commit()?;
    progress.finish();
    print_summary(&result.report);
    for path in written
        .iter()
        .filter(|p| Some(p.as_path()) != preview.as_deref())
    {
        outln!("{}", path.display());
    }
    if let Some(p) = preview {
        outln!("{}", p.display());
    }
    Ok(())
}

/// Refuses what belongs to a character file: a `.glb`/`.bvh` output (a scene writes a
/// folder) and per-character flags, which live in the scene's tables, one per character:
/// a flag would silently apply to nobody, or to every character of whatever file.
fn refuse_character_flags(a: &SimulateArgs, matches: &ArgMatches) -> Result<()> {
    if a.output
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("glb") || e.eq_ignore_ascii_case("bvh"))
    {
        bail!(
            "{}: with a scene file, -o names the output folder (the scene's [output] table names the files)",
            a.output.display()
        );
    }
    for (id, flag, key) in [
        ("mass", "--mass", "mass_kg"),
        ("female", "--female", "female"),
        ("spec", "--spec", "spec"),
        ("roles", "--roles", "roles"),
        ("units", "--units", "units"),
        ("up", "--up", "up"),
        ("height", "--height", "height"),
        ("clip", "--clip", "clip"),
        ("activate", "--activate", "activate"),
        ("powered", "--powered", "powered"),
        ("fade_out", "--fade-out", "powered"),
        ("root_on_clip", "--root-on-clip", "powered"),
    ] {
        if given(matches, id) {
            bail!(
                "{flag} does not apply to a scene file: set {key} in its [[character]] tables ({})",
                a.file.display()
            );
        }
    }
    if a.obj_sequence.is_some() {
        bail!("--obj-sequence applies to a character file, not a scene file");
    }
    Ok(())
}

/// The flags that override the scene's own settings, where the user typed them:
/// `--seconds`, `--fps`, `--rest-pose`, `--split`, `--backend`, `--joint-damping`.
fn apply_flags(a: &SimulateArgs, matches: &ArgMatches, scene: &mut Scene) -> Result<()> {
    if given(matches, "seconds") {
        if !(a.sim.run.seconds.is_finite()
            && a.sim.run.seconds > 0.0
            && a.sim.run.seconds <= 3600.0)
        {
            bail!(
                "--seconds: must be more than 0 and at most 3600, not {}",
                a.sim.run.seconds
            );
        }
        scene.duration_s = a.sim.run.seconds;
    }
    if given(matches, "fps") {
        if !(a.sim.run.fps.is_finite() && (1.0..=1000.0).contains(&a.sim.run.fps)) {
            bail!(
                "--fps: frames per second must be between 1 and 1000, not {}",
                a.sim.run.fps
            );
        }
        scene.settings.fps = a.sim.run.fps;
    }
    if a.sim.anim.rest_pose {
        scene.settings.start = StartPose::Rest;
    }
    if a.split {
        match &scene.outputs.glb {
            Some(name) if !name.contains("{name}") => {
                scene.outputs.glb = Some("{name}.glb".into());
            }
            Some(_) => {}
            None => bail!(
                "--split: the scene writes no glTF (glb = false in its [output] table) ({})",
                a.file.display()
            ),
        }
    }
    if a.sim.run.no_freeze {
        scene.fast.freeze_joints = false;
    }
    if given(matches, "backend") || a.sim.run.no_freeze {
        let kind = if given(matches, "backend") {
            a.sim.run.backend.backend
        } else {
            scene.settings.backend.kind()
        };
        scene.set_backend(kind);
    }
    if given(matches, "joint_damping") {
        scene.settings.joint_damping = a.sim.run.joint_damping;
    }
    // A flag can make the scene's settings disagree (`--backend particle` with the file's
    // `joint_damping`): said before anything runs, naming the setting.
    scene.settings.validate().map_err(|e| match e {
        ragdoll::Error::Setting { setting, message } => {
            anyhow::anyhow!("{}: {setting}: {message}", a.file.display())
        }
        e => e.into(),
    })?;
    Ok(())
}

/// Refuses a run whose tracks went non-finite, naming the character whose track went
/// bad, else saying a character did.
fn check_tracks(a: &SimulateArgs, scene: &Scene, result: &SceneResult) -> Result<()> {
    let in_scene = |e: anyhow::Error| e.context(a.file.display().to_string());
    for (c, track) in scene.characters.iter().zip(&result.tracks) {
        check_finite(&c.name, false, track, scene.settings.backend.kind()).map_err(in_scene)?;
    }
    let no_track = ragdoll::track::Track {
        fps: scene.settings.fps,
        frames: Vec::new(),
    };
    check_finite(
        "a character",
        result.report.metrics.nan,
        &no_track,
        scene.settings.backend.kind(),
    )
    .map_err(in_scene)
}

/// Each character file's warnings (repaired weights, missing images, a roles warning),
/// once per file however many characters it gives the scene: a crowd of one file warns
/// once.
pub fn print_warnings(scene: &Scene) {
    let mut seen = std::collections::HashSet::new();
    for c in &scene.characters {
        for w in &c.character.warnings {
            if seen.insert((c.input.as_str(), w.as_str())) {
                eprintln!(
                    "warning: {}: {}",
                    crate::printable::shown(&c.input),
                    crate::printable::shown(w)
                );
            }
        }
    }
}

fn print_summary(r: &Report) {
    let m = &r.metrics;
    errln!(
        "{}: {} character{}, {} frames at {} fps in {:.2} s wall; limit violation {:.2}° ({:.2}° before the clamp), penetration {:.1} mm, joint separation {:.2} mm, energy drift {:.4}",
        r.scene.as_deref().unwrap_or("scene"),
        r.characters.len(),
        if r.characters.len() == 1 { "" } else { "s" },
        r.frames,
        r.fps,
        r.wall_seconds,
        m.max_limit_violation_deg,
        m.max_limit_violation_solver_deg,
        m.max_penetration_m * 1000.0,
        m.max_joint_separation_m * 1000.0,
        m.energy_drift,
    );
    if let Some(active) = &r.active_joints_per_frame
        && let Some(&last) = active.last()
    {
        let total: usize = r.characters.iter().map(|c| c.joints).sum();
        let mean = active.iter().map(|&n| n as f64).sum::<f64>() / active.len() as f64;
        errln!(
            "  joints the solver worked on (the rest were asleep): {mean:.0} of {total} on average, {last} at the end"
        );
    }
    let loaded = !r.blasts.is_empty() || !r.projectiles.is_empty();
    for c in &r.characters {
        crate::commands::warn_if_torn(&c.name, c.max_joint_separation_m, c.height_m, loaded);
    }
    for b in &r.blasts {
        for c in &b.characters {
            if let Some(v) = c.com_velocity_mps {
                let v = glam::Vec3::from_array(v);
                errln!(
                    "  {}: thrown at {:.2} m/s by the {} kg blast at {} s",
                    c.name,
                    v.length(),
                    b.tnt_kg,
                    b.time_s
                );
            }
        }
    }
    for p in &r.projectiles {
        match (&p.body, p.character.and_then(|c| r.characters.get(c))) {
            (Some(body), Some(c)) => errln!(
                "  shot at {:.2} s hit {}'s {body} with {:.1} N·s",
                p.time_s,
                c.name,
                p.impulse_ns
            ),
            _ => errln!("  shot at {:.2} s missed", p.time_s),
        }
    }
}
