//! The commands that simulate one character and bake it: demo, simulate, blast, shoot.
//! Each checks its flags and output paths, simulates, checks the result is finite, and
//! writes every output together through [`Staging`].

use std::path::{Path, PathBuf};

use anyhow::{Result, bail};
use ragdoll::backend::{BackendConfig, BackendKind, FastConfig};
use ragdoll::events::{Blast, Projectile};
use ragdoll::export;
use ragdoll::report::Report;
use ragdoll::scene::{Event, Scene};
use ragdoll::skeleton::{self, Character};
use ragdoll::spec::RagdollSpec;
use ragdoll::track::Track;
use ragdoll::world::{StartPose, WorldSettings};

use crate::character::{in_file, load, load_or_builtin, ragdoll_spec};
use crate::output::{self, Staging};
use crate::progress::Progress;
use crate::{
    AnimArgs, BlastArgs, DemoArgs, RunArgs, ShootArgs, SimArgs, SimulateArgs, checks, fatal,
    preview_cmd,
};

/// The engine `kind` at its defaults, with the fast engine's joint freezing as the flags
/// say (the other engines do not freeze).
pub(crate) fn engine(kind: BackendKind, freeze_joints: bool) -> BackendConfig {
    match kind {
        BackendKind::Fast => BackendConfig::Fast(FastConfig {
            freeze_joints,
            ..Default::default()
        }),
        other => other.into(),
    }
}

fn world_settings(a: &RunArgs, rest_pose: bool) -> Result<WorldSettings> {
    let max = ragdoll::world::MAX_SECONDS;
    if !(a.seconds.is_finite() && a.seconds >= 0.0 && a.seconds <= max) {
        bail!("--seconds: must be between 0 and {max}, not {}", a.seconds);
    }
    let settings = WorldSettings {
        backend: engine(a.backend.backend, !a.no_freeze),
        fps: a.fps,
        joint_damping: a.joint_damping,
        start: if rest_pose {
            StartPose::Rest
        } else {
            StartPose::FirstFrame
        },
        ..Default::default()
    };
    settings.validate().map_err(|e| match e {
        ragdoll::Error::Setting { setting, message } if setting == "fps" => {
            anyhow::anyhow!("--fps: {message}")
        }
        ragdoll::Error::Setting { setting, message } if setting == "joint_damping" => {
            anyhow::anyhow!("--joint-damping: {message}")
        }
        e => e.into(),
    })?;
    Ok(settings)
}

/// What happens to the character during a run.
#[derive(Default)]
struct Events {
    blasts: Vec<Blast>,
    projectiles: Vec<Projectile>,
}

/// A user setting error with the flag named: `--tnt: ...`.
fn flag_error(e: ragdoll::Error) -> anyhow::Error {
    match e {
        ragdoll::Error::Setting { setting, message } => anyhow::anyhow!("--{setting}: {message}"),
        e => e.into(),
    }
}

/// Where a single-character run writes: the baked file and its report, and the extras.
struct Outputs<'a> {
    kind: OutputKind,
    path: &'a Path,
    preview: &'a preview_cmd::PreviewArg,
    obj_sequence: Option<&'a Path>,
}

impl Outputs<'_> {
    /// Checks every path before any simulation time is spent.
    fn check(&self) -> Result<()> {
        output::check_file(self.path)?;
        self.preview.check()?;
        if let Some(dir) = self.obj_sequence {
            output::check_folder(dir)?;
        }
        Ok(())
    }
}

pub fn shoot(a: &ShootArgs) -> Result<()> {
    let out = Outputs {
        kind: output_kind(&a.output)?,
        path: &a.output,
        preview: &a.preview,
        obj_sequence: None,
    };
    let from = glam::Vec3::from_array(a.from);
    let shot = Projectile {
        origin: from,
        direction: glam::Vec3::from_array(a.toward) - from,
        mass_kg: a.bullet_mass,
        speed_mps: a.speed,
        time_s: a.time,
    };
    shot.validate().map_err(|e| match e {
        ragdoll::Error::Setting { setting, message } if setting == "direction" => {
            anyhow::anyhow!("--toward: must differ from --from ({message})")
        }
        ragdoll::Error::Setting { setting, message }
            if setting == "mass" || setting == "mass_kg" =>
        {
            anyhow::anyhow!("--bullet-mass: {message}")
        }
        e => flag_error(e),
    })?;
    checks::event_time("--time", "the shot", a.time, a.sim.run.seconds)?;
    checks::activation(&a.sim, false, true)?;
    out.check()?;
    let (character, input) = load_or_builtin(a.file.as_deref(), &a.import)?;
    let spec = ragdoll_spec(&character, &input, &a.ragdoll)?;
    let events = Events {
        projectiles: vec![shot],
        ..Default::default()
    };
    let (track, report) = simulate_character(
        &input,
        &character,
        &spec,
        a.ragdoll.spec.as_deref(),
        &a.sim,
        &events,
    )?;
    let notes: Vec<String> = report
        .projectiles
        .iter()
        .map(|p| match &p.body {
            Some(body) => format!("hit {body} with {:.1} N·s", p.impulse_ns),
            None => "missed".to_string(),
        })
        .collect();
    let markers = preview_cmd::markers(&[], &events.projectiles, &report.projectiles);
    write_result(&out, &character, &spec, &track, &report, &markers)?;
    print_notes(&notes);
    Ok(())
}

/// Runs the character as a scene of one (the pipeline scenes run through) with a progress
/// bar; returns its track and the report, or an error when the simulation produced
/// non-finite numbers.
fn simulate_character(
    input: &str,
    character: &Character,
    spec: &RagdollSpec,
    spec_file: Option<&Path>,
    sim: &SimArgs,
    events: &Events,
) -> Result<(Track, Report)> {
    checks::rest_pose(character, &sim.anim)?;
    let (run, anim) = (&sim.run, &sim.anim);
    let settings = world_settings(run, anim.rest_pose)?;
    settings
        .validate_run(run.seconds, character.skeleton.len())
        .map_err(flag_error)?;
    let backend = settings.backend.kind();
    let mut scene = Scene::single(
        character.clone(),
        spec.clone(),
        input,
        run.seconds,
        settings,
    );
    let one = &mut scene.characters[0];
    one.activation = anim.activate;
    one.motors = anim.powered.map(|strength| {
        let mut motors = match anim.fade_out {
            Some([start, end]) => ragdoll::world::Motors::fade_out(strength, start, end),
            None => ragdoll::world::Motors::constant(strength),
        };
        motors.root_on_clip = anim.root_on_clip;
        motors
    });
    scene.blasts = events.blasts.iter().copied().map(Event::new).collect();
    scene.projectiles = events.projectiles.iter().copied().map(Event::new).collect();
    let progress = Progress::new(0, "building the ragdoll");
    let mut stage_set = false;
    let result = scene
        .run_until(|done, total| {
            if !stage_set {
                progress.stage(total, "simulating");
                stage_set = true;
            }
            progress.set(done);
            true
        })
        // A bad activation or motor setting names its flag; the world refuses some specs
        // only once it places them (parts piled inside each other): name the spec file
        // those came from, or the character the spec was built for.
        .map_err(|e| match e {
            e @ ragdoll::Error::Setting { .. } => flag_error(e),
            e => in_file(spec_file.unwrap_or(Path::new(input)), e),
        })?
        .expect("a run whose callback never stops it finishes");
    progress.finish();
    let mut tracks = result.tracks;
    let track = tracks.pop().expect("a scene of one has one track");
    check_finite(&character.name, result.report.metrics.nan, &track, backend)?;
    Ok((track, result.report))
}

/// A run whose numbers went non-finite (`nan` in the metrics, or a NaN or infinite joint
/// in the track) is a failed run, not a result: its files would hold garbage or nothing.
/// No output is written, not even the report: the error sentence carries what the report
/// would have said that matters (when it happened), and the rest of a NaN run's report is
/// NaN too.
pub(crate) fn check_finite(
    name: &str,
    nan_seen: bool,
    track: &Track,
    backend: BackendKind,
) -> Result<()> {
    let first_bad = track
        .frames
        .iter()
        .position(|f| f.iter().any(|t| !t.is_finite()));
    if !nan_seen && first_bad.is_none() {
        return Ok(());
    }
    let when = match first_bad {
        Some(f) => format!(" from frame {f} ({:.3} s)", f as f32 / track.fps),
        None => String::new(),
    };
    // The particle backend also fails on plausible characters (light parts bearing heavy
    // ones: the Fox at its true size did, before its bodies held their skin in pieces).
    let why = match backend {
        BackendKind::Particle => {
            "the particle backend cannot hold this character together (it is unstable where \
             small, light parts bear heavy ones: `--backend fast` or `rigid` may run it), or \
             the spec or the events ask for more than the physics can honour"
        }
        _ => {
            "the spec or the events ask for more than the physics can honour (absurd sizes, \
             masses, forces or speeds)"
        }
    };
    bail!(
        "{name}: the simulation produced non-finite numbers (NaN or infinity){when}, so nothing was written; {why}"
    )
}

#[derive(Clone, Copy)]
enum OutputKind {
    Glb,
    Bvh,
}

fn output_kind(path: &Path) -> Result<OutputKind> {
    match path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .as_deref()
    {
        Some("glb") => Ok(OutputKind::Glb),
        Some("bvh") => Ok(OutputKind::Bvh),
        _ => bail!("{}: the output must end in .glb or .bvh", path.display()),
    }
}

fn encode(
    kind: OutputKind,
    character: &Character,
    spec: &RagdollSpec,
    track: &Track,
) -> Result<Vec<u8>> {
    Ok(match kind {
        OutputKind::Glb => export::gltf::to_glb(character, spec, track)?,
        OutputKind::Bvh => export::bvh::to_bvh(character, track)?.into_bytes(),
    })
}

pub fn demo(a: &DemoArgs) -> Result<()> {
    output::check_output_folder(&a.output)?;
    a.preview.check()?;
    let character = skeleton::humanoid();
    let spec = ragdoll_spec(&character, "built-in", &a.ragdoll)?;
    let sim = SimArgs {
        run: a.run.clone(),
        anim: AnimArgs::default(),
    };
    let (track, mut report) = simulate_character(
        "built-in",
        &character,
        &spec,
        a.ragdoll.spec.as_deref(),
        &sim,
        &Events::default(),
    )?;
    let progress = Progress::new(0, "writing");
    let mut staging = Staging::new();
    let glb = a.output.join("demo.glb");
    let bvh = a.output.join("demo.bvh");
    let json = a.output.join("report.json");
    staging.write(&glb, &encode(OutputKind::Glb, &character, &spec, &track)?)?;
    staging.write(&bvh, &encode(OutputKind::Bvh, &character, &spec, &track)?)?;
    if let Some(c) = report.characters.first_mut() {
        c.bvh = Some("demo.bvh".into());
    }
    staging.write(&json, report.to_json().as_bytes())?;
    let preview = a
        .preview
        .stage(&mut staging, &[(&character, &spec, &track)], &[], &progress)?;
    fatal::debug_panic_point("staged");
    let written = staging.commit()?;
    progress.finish();
    print_summary(&report);
    print_paths(&written, preview.as_deref(), None);
    Ok(())
}

pub fn simulate(a: &SimulateArgs) -> Result<()> {
    if a.split {
        bail!(
            "--split applies to a scene file (one glTF per character), not to {}",
            a.file.display()
        );
    }
    let out = Outputs {
        kind: output_kind(&a.output)?,
        path: &a.output,
        preview: &a.preview,
        obj_sequence: a.obj_sequence.as_deref(),
    };
    checks::activation(&a.sim, false, false)?;
    out.check()?;
    let character = load(&a.file, &a.import)?;
    let input = a.file.display().to_string();
    let spec = ragdoll_spec(&character, &input, &a.ragdoll)?;
    let (track, report) = simulate_character(
        &input,
        &character,
        &spec,
        a.ragdoll.spec.as_deref(),
        &a.sim,
        &Events::default(),
    )?;
    write_result(&out, &character, &spec, &track, &report, &[])
}

/// Encodes the track, its report and the extras (preview, OBJ sequence) and writes them
/// all together.
fn write_result(
    out: &Outputs<'_>,
    character: &Character,
    spec: &RagdollSpec,
    track: &Track,
    report: &Report,
    markers: &[ragdoll_preview::Marker],
) -> Result<()> {
    let progress = Progress::new(0, "writing");
    let mut staging = Staging::new();
    let report_path = report_path(out.path);
    staging.write(out.path, &encode(out.kind, character, spec, track)?)?;
    let mut report = report.clone();
    if let (OutputKind::Bvh, Some(c)) = (out.kind, report.characters.first_mut()) {
        c.bvh = out
            .path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned());
    }
    staging.write(&report_path, report.to_json().as_bytes())?;
    let preview = out.preview.stage(
        &mut staging,
        &[(character, spec, track)],
        markers,
        &progress,
    )?;
    let objs = match out.obj_sequence {
        Some(dir) => Some((
            preview_cmd::stage_obj_sequence(&mut staging, dir, character, spec, track, &progress)?,
            dir,
        )),
        None => None,
    };
    fatal::debug_panic_point("staged");
    let written = staging.commit()?;
    progress.finish();
    print_summary(&report);
    print_paths(&written, preview.as_deref(), objs);
    Ok(())
}

/// Prints the paths written, one a line (the OBJ sequence as its folder and count).
fn print_paths(written: &[PathBuf], preview: Option<&Path>, objs: Option<(Vec<PathBuf>, &Path)>) {
    let obj_files = objs.as_ref().map_or(&[][..], |(files, _)| files.as_slice());
    for p in written {
        if Some(p.as_path()) == preview || obj_files.contains(p) {
            continue;
        }
        outln!("{}", p.display());
    }
    if let Some((files, dir)) = &objs {
        outln!("{} ({} OBJ files)", dir.display(), files.len());
    }
    if let Some(p) = preview {
        outln!("{}", p.display());
    }
}

pub fn blast(a: &BlastArgs) -> Result<()> {
    let out = Outputs {
        kind: output_kind(&a.output)?,
        path: &a.output,
        preview: &a.preview,
        obj_sequence: None,
    };
    let blast = Blast {
        tnt_kg: a.tnt,
        position: glam::Vec3::from_array(a.at),
        time_s: a.time,
        scale: a.scale,
    };
    blast.validate().map_err(flag_error)?;
    checks::event_time("--time", "the blast", a.time, a.sim.run.seconds)?;
    checks::activation(&a.sim, true, false)?;
    out.check()?;
    let (character, input) = load_or_builtin(a.file.as_deref(), &a.import)?;
    let spec = ragdoll_spec(&character, &input, &a.ragdoll)?;
    let (track, report) = simulate_character(
        &input,
        &character,
        &spec,
        a.ragdoll.spec.as_deref(),
        &a.sim,
        &Events {
            blasts: vec![blast],
            ..Default::default()
        },
    )?;
    let notes: Vec<String> = report
        .blasts
        .iter()
        .flat_map(|b| &b.characters)
        .filter_map(|c| {
            let v = glam::Vec3::from_array(c.com_velocity_mps?);
            Some(format!(
                "{}: thrown at {:.2} m/s (centre of mass, after the blast passed)",
                c.name,
                v.length()
            ))
        })
        .collect();
    let markers = preview_cmd::markers(&[blast], &[], &[]);
    write_result(&out, &character, &spec, &track, &report, &markers)?;
    print_notes(&notes);
    Ok(())
}

/// What a run found (a hit, a throw), printed once its files are written, so that a
/// failed run prints only its error.
fn print_notes(notes: &[String]) {
    for n in notes {
        errln!("{n}");
    }
}

/// `OUT.glb` → `OUT.report.json`, next to it.
fn report_path(output: &Path) -> PathBuf {
    let stem = output
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    output.with_file_name(format!("{stem}.report.json"))
}

fn print_summary(report: &Report) {
    let m = &report.metrics;
    let Some(c) = report.characters.first() else {
        return;
    };
    errln!(
        "{}: {} bodies, {:.1} kg, {} frames at {} fps in {:.2} s wall; limit violation {:.2}° ({:.2}° before the clamp), penetration {:.1} mm, joint separation {:.2} mm, energy drift {:.4}",
        c.name,
        c.bodies,
        c.total_mass_kg,
        report.frames,
        report.fps,
        report.wall_seconds,
        m.max_limit_violation_deg,
        m.max_limit_violation_solver_deg,
        m.max_penetration_m * 1000.0,
        m.max_joint_separation_m * 1000.0,
        m.energy_drift,
    );
    let loaded = !report.blasts.is_empty() || !report.projectiles.is_empty();
    warn_if_torn(&c.name, m.max_joint_separation_m, c.height_m, loaded);
}

/// Joints held within this fraction of the character's height (9 cm on a person) are taken
/// as holding: the solvers keep them within millimetres under ordinary loads, and the
/// strongest shot the bounds allow (1000 N·s on a hand) opens them 2-8 cm.
const TORN_FRACTION_OF_HEIGHT: f32 = 0.05;

/// Says so when the run tore the ragdoll apart: loads (a kiloton next to a person) that no
/// jointed body can hold still give a finite run, but its motion is the solver giving way,
/// not physics; the files are written, the user is told. `loaded`: the run had a charge or
/// a shot, the likely cause; without one the ragdoll tore itself apart, and a charge that
/// does not exist is not blamed.
pub(crate) fn warn_if_torn(name: &str, separation_m: f32, height_m: f32, loaded: bool) {
    if let Some(w) = torn_warning(name, separation_m, height_m, loaded) {
        errln!("{w}");
    }
}

/// [`warn_if_torn`]'s sentence, when there is one to say.
fn torn_warning(name: &str, separation_m: f32, height_m: f32, loaded: bool) -> Option<String> {
    (separation_m > TORN_FRACTION_OF_HEIGHT * height_m).then(|| {
        let why = if loaded {
            "the loads are beyond what the ragdoll's joints can hold, so this motion is not physical (a smaller charge or a greater distance keeps it whole)"
        } else {
            "with no charge or shot, the ragdoll pulled itself apart, so this motion is not physical (its bodies may be joined where they do not meet: see `ragdoll inspect`; `--backend rigid` is the reference)"
        };
        format!(
            "warning: {name}: joints came {separation_m:.2} m apart ({:.0} % of its {height_m:.2} m height): {why}",
            100.0 * separation_m / height_m.max(1e-6)
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use ragdoll::math::Transform;

    #[test]
    fn a_torn_run_blames_a_charge_only_when_there_was_one() {
        assert_eq!(torn_warning("spider", 0.01, 0.45, false), None);
        let loaded = torn_warning("humanoid", 0.5, 1.7, true).unwrap();
        assert!(loaded.contains("smaller charge"), "{loaded}");
        let unloaded = torn_warning("spider", 0.12, 0.45, false).unwrap();
        assert!(
            unloaded.contains("no charge or shot") && !unloaded.contains("smaller charge"),
            "{unloaded}"
        );
        assert!(
            unloaded.contains("0.12 m apart (27 % of its 0.45 m height)"),
            "{unloaded}"
        );
    }

    #[test]
    fn a_run_gone_non_finite_says_when_and_which_backends_may_run_it() {
        let track = Track {
            fps: 30.0,
            frames: vec![
                vec![Transform::IDENTITY],
                vec![Transform::from_translation(glam::Vec3::NAN)],
            ],
        };
        let particle = check_finite("Fox", true, &track, BackendKind::Particle)
            .unwrap_err()
            .to_string();
        assert!(
            particle.contains("Fox: the simulation produced non-finite numbers")
                && particle.contains("from frame 1 (0.033 s)")
                && particle.contains("particle backend")
                && particle.contains("--backend fast"),
            "{particle}"
        );
        let rigid = check_finite("Fox", true, &track, BackendKind::Rigid)
            .unwrap_err()
            .to_string();
        assert!(!rigid.contains("--backend"), "{rigid}");
        let fine = Track {
            fps: 30.0,
            frames: vec![vec![Transform::IDENTITY]],
        };
        assert!(check_finite("Fox", false, &fine, BackendKind::Particle).is_ok());
    }
}
