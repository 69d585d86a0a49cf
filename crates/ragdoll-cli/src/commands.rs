//! The commands that turn a character into files: demo, inspect, build, simulate.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use ragdoll::events::{Blast, Projectile};
use ragdoll::export::{self, write_atomic};
use ragdoll::import::{self, ImportOptions, Units, UpAxis};
use ragdoll::report::Report;
use ragdoll::skeleton::{self, Character};
use ragdoll::spec::{self, BuildOptions, RagdollSpec};
use ragdoll::track::Track;
use ragdoll::world::{StartPose, World, WorldSettings};

use crate::preview_cmd;
use crate::progress::Progress;
use crate::{
    BlastArgs, BuildArgs, DemoArgs, ImportArgs, InspectArgs, RagdollArgs, ShootArgs, SimArgs,
    SimulateArgs, UnitsArg, UpArg,
};

pub(crate) fn import_options(a: &ImportArgs) -> ImportOptions {
    ImportOptions {
        units: a.units.map(|u| match u {
            UnitsArg::M => Units::M,
            UnitsArg::Cm => Units::Cm,
            UnitsArg::Mm => Units::Mm,
            UnitsArg::In => Units::In,
        }),
        up: a.up.map(|u| match u {
            UpArg::Y => UpAxis::Y,
            UpArg::Z => UpAxis::Z,
        }),
    }
}

fn load(file: &Path, a: &ImportArgs) -> Result<Character> {
    Ok(import::load(file, &import_options(a))?)
}

/// The spec from `--spec`, or one built from the character.
pub(crate) fn ragdoll_spec(character: &Character, a: &RagdollArgs) -> Result<RagdollSpec> {
    if let Some(m) = a.mass
        && !(m.is_finite() && m > 0.0)
    {
        bail!("--mass: the total mass must be a positive number of kilograms, not {m}");
    }
    match &a.spec {
        Some(path) => {
            let text = std::fs::read_to_string(path).map_err(|e| ragdoll::Error::io(path, e))?;
            let spec = RagdollSpec::from_toml(&text, path)
                .with_context(|| format!("{}", path.display()))?;
            Ok(spec)
        }
        None => Ok(spec::build_spec(
            character,
            &BuildOptions {
                total_mass_kg: a.mass,
                female: a.female,
            },
        )?),
    }
}

fn world_settings(a: &SimArgs) -> Result<WorldSettings> {
    if !(a.seconds.is_finite() && a.seconds >= 0.0 && a.seconds <= 3600.0) {
        bail!("--seconds: must be between 0 and 3600, not {}", a.seconds);
    }
    let settings = WorldSettings {
        backend: a.backend.backend.kind(),
        fps: a.fps,
        start: if a.rest_pose {
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

/// The character from `file`, or the built-in humanoid; and how to name it in the report.
pub(crate) fn load_or_builtin(
    file: Option<&Path>,
    import: &ImportArgs,
) -> Result<(Character, String)> {
    Ok(match file {
        Some(file) => (load(file, import)?, file.display().to_string()),
        None => (skeleton::humanoid(), "built-in".to_string()),
    })
}

pub fn shoot(a: &ShootArgs) -> Result<()> {
    let kind = output_kind(&a.output)?;
    a.preview.check()?;
    let from = glam::Vec3::from_array(a.from);
    let shot = Projectile {
        origin: from,
        direction: glam::Vec3::from_array(a.toward) - from,
        mass_kg: a.mass,
        speed_mps: a.speed,
        time_s: a.time,
    };
    shot.validate().map_err(|e| match e {
        ragdoll::Error::Setting { setting, message } if setting == "direction" => {
            anyhow::anyhow!("--toward: must differ from --from ({message})")
        }
        e => flag_error(e),
    })?;
    let (character, input) = load_or_builtin(a.file.as_deref(), &a.import)?;
    let spec = ragdoll_spec(&character, &a.ragdoll)?;
    let events = Events {
        projectiles: vec![shot],
        ..Default::default()
    };
    let (track, report) = simulate_character(&input, &character, &spec, &a.sim, &events)?;
    for p in &report.projectiles {
        match &p.body {
            Some(body) => eprintln!("hit {body} with {:.1} N·s", p.impulse_ns),
            None => eprintln!("missed"),
        }
    }
    write_result(&kind, &a.output, &character, &spec, &track, &report)?;
    let markers = preview_cmd::markers(&[], &events.projectiles, &report.projectiles);
    a.preview.write(&[(&character, &spec, &track)], &markers)
}

/// Runs the simulation with a progress bar; returns the track and its report.
fn simulate_character(
    input: &str,
    character: &Character,
    spec: &RagdollSpec,
    sim: &SimArgs,
    events: &Events,
) -> Result<(Track, Report)> {
    let settings = world_settings(sim)?;
    let started = Instant::now();
    let (mut world, id) = World::with_ragdoll(character, spec, &settings)?;
    world.set_activation(id, sim.activate).map_err(flag_error)?;
    if let Some(strength) = sim.powered {
        let mut motors = match sim.fade_out {
            Some([start, end]) => ragdoll::world::Motors::fade_out(strength, start, end),
            None => ragdoll::world::Motors::constant(strength),
        };
        motors.root_on_clip = sim.root_on_clip;
        world.set_motors(id, motors).map_err(|e| match e {
            ragdoll::Error::Setting { message, .. } => anyhow::anyhow!("--powered: {message}"),
            e => e.into(),
        })?;
    }
    for b in &events.blasts {
        world.add_blast(*b)?;
    }
    for p in &events.projectiles {
        world.add_projectile(*p)?;
    }
    let steps = (sim.seconds / settings.dt).round() as u64;
    let mut progress = Progress::new(steps, "simulating");
    world.run(0.0);
    for i in 0..steps {
        world.step();
        progress.set(i + 1);
    }
    progress.finish();
    let metrics = world.metrics();
    let blast_reports = world.blast_reports();
    let world_projectiles = world.projectile_reports();
    let track = world.into_track();
    let mut report = Report::new(
        input,
        character.skeleton.rest_height(),
        spec,
        &track,
        metrics,
        sim.seconds,
        started.elapsed().as_secs_f64(),
    );
    report.backend = settings.backend.as_str().into();
    report.blasts = blast_reports;
    report.projectiles = world_projectiles;
    Ok((track, report))
}

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
    kind: &OutputKind,
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
    a.preview.check()?;
    let character = skeleton::humanoid();
    let spec = ragdoll_spec(&character, &a.ragdoll)?;
    let (track, report) =
        simulate_character("built-in", &character, &spec, &a.sim, &Events::default())?;
    // Encode everything before writing anything, so a failure leaves no partial set.
    let glb = encode(&OutputKind::Glb, &character, &spec, &track)?;
    let bvh = encode(&OutputKind::Bvh, &character, &spec, &track)?;
    let files = [
        (a.output.join("demo.glb"), glb),
        (a.output.join("demo.bvh"), bvh),
        (a.output.join("report.json"), report.to_json().into_bytes()),
    ];
    for (path, bytes) in &files {
        write_atomic(path, bytes)?;
    }
    print_summary(&report, files.iter().map(|(p, _)| p.as_path()));
    a.preview.write(&[(&character, &spec, &track)], &[])
}

pub fn simulate(a: &SimulateArgs) -> Result<()> {
    let kind = output_kind(&a.output)?;
    a.preview.check()?;
    let character = load(&a.file, &a.import)?;
    let spec = ragdoll_spec(&character, &a.ragdoll)?;
    let input = a.file.display().to_string();
    let (track, report) =
        simulate_character(&input, &character, &spec, &a.sim, &Events::default())?;
    write_result(&kind, &a.output, &character, &spec, &track, &report)?;
    if let Some(dir) = &a.obj_sequence {
        preview_cmd::write_obj_sequence(dir, &character, &spec, &track)?;
    }
    a.preview.write(&[(&character, &spec, &track)], &[])
}

/// Encodes the track, then writes it and its report (each atomically).
fn write_result(
    kind: &OutputKind,
    output: &Path,
    character: &Character,
    spec: &RagdollSpec,
    track: &Track,
    report: &Report,
) -> Result<()> {
    let bytes = encode(kind, character, spec, track)?;
    let report_path = report_path(output);
    write_atomic(output, &bytes)?;
    write_atomic(&report_path, report.to_json().as_bytes())?;
    print_summary(report, [output, report_path.as_path()]);
    Ok(())
}

pub fn blast(a: &BlastArgs) -> Result<()> {
    let kind = output_kind(&a.output)?;
    a.preview.check()?;
    let blast = Blast {
        tnt_kg: a.tnt,
        position: glam::Vec3::from_array(a.at),
        time_s: a.time,
        scale: a.scale,
    };
    blast.validate().map_err(flag_error)?;
    let (character, input) = load_or_builtin(a.file.as_deref(), &a.import)?;
    let spec = ragdoll_spec(&character, &a.ragdoll)?;
    let (track, report) = simulate_character(
        &input,
        &character,
        &spec,
        &a.sim,
        &Events {
            blasts: vec![blast],
            ..Default::default()
        },
    )?;
    for b in &report.blasts {
        for c in &b.characters {
            if let Some(v) = c.com_velocity_mps {
                let v = glam::Vec3::from_array(v);
                eprintln!(
                    "{}: thrown at {:.2} m/s (centre of mass, after the blast passed)",
                    c.name,
                    v.length()
                );
            }
        }
    }
    write_result(&kind, &a.output, &character, &spec, &track, &report)?;
    let markers = preview_cmd::markers(&[blast], &[], &[]);
    a.preview.write(&[(&character, &spec, &track)], &markers)
}

/// `OUT.glb` → `OUT.report.json`, next to it.
fn report_path(output: &Path) -> PathBuf {
    let stem = output
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    output.with_file_name(format!("{stem}.report.json"))
}

fn print_summary<'a>(report: &Report, files: impl IntoIterator<Item = &'a Path>) {
    let m = &report.metrics;
    eprintln!(
        "{}: {} bodies, {:.1} kg, {} frames at {} fps in {:.2} s wall; limit violation {:.2}°, penetration {:.1} mm, joint separation {:.2} mm, energy drift {:.4}{}",
        report.character,
        report.bodies,
        report.total_mass_kg,
        report.frames,
        report.fps,
        report.wall_seconds,
        m.max_limit_violation_deg,
        m.max_penetration_m * 1000.0,
        m.max_joint_separation_m * 1000.0,
        m.energy_drift,
        if m.nan { ", NaN seen!" } else { "" }
    );
    for f in files {
        outln!("{}", f.display());
    }
}

pub fn build(a: &BuildArgs) -> Result<()> {
    let character = load(&a.file, &a.import)?;
    let spec = ragdoll_spec(&character, &a.ragdoll)?;
    let text = format!(
        "# Ragdoll spec for {} (built by ragdoll {} from {}).\n# Edit any number and pass it back with --spec. Lengths in metres, masses in kg,\n# angles in degrees; centres and rotations are in each bone's rest frame.\n\n{}",
        spec.name,
        env!("CARGO_PKG_VERSION"),
        a.file.display(),
        spec.to_toml()
    );
    write_atomic(&a.output, text.as_bytes())?;
    eprintln!(
        "{}: {} bodies, {} joints, {:.1} kg",
        spec.name,
        spec.bodies.len(),
        spec.joints.len(),
        spec.total_mass_kg()
    );
    outln!("{}", a.output.display());
    Ok(())
}

pub fn inspect(a: &InspectArgs) -> Result<()> {
    let character = load(&a.file, &a.import)?;
    let roles = spec::recognise_roles(&character);
    let spec = ragdoll_spec(&character, &a.ragdoll)
        .with_context(|| format!("{}: building the ragdoll", a.file.display()))?;
    let s = &character.skeleton;
    let mut out = String::new();
    if a.json {
        let joints: Vec<serde_json::Value> = (0..s.len())
            .map(|i| {
                serde_json::json!({
                    "index": i,
                    "name": s.joint_label(i),
                    "parent": s.parent(i).map(|p| s.joint_label(p)),
                    "role": roles.per_joint[i].map(|r| r.as_str()),
                })
            })
            .collect();
        let value = serde_json::json!({
            "character": character.name,
            "humanoid": roles.humanoid,
            "forward": roles.forward.to_array(),
            "joints": joints,
            "bodies": spec.bodies,
            "constraints": spec.joints,
            "total_mass_kg": spec.total_mass_kg(),
            "clips": character.clips.iter().map(|c| serde_json::json!({
                "name": c.name, "frames": c.frames.len(), "fps": 1.0 / c.frame_time,
            })).collect::<Vec<_>>(),
        });
        out.push_str(&serde_json::to_string_pretty(&value)?);
        out.push('\n');
    } else {
        use std::fmt::Write;
        let kind = if roles.humanoid {
            "humanoid"
        } else {
            "not humanoid: generic chain bodies"
        };
        writeln!(
            out,
            "{} ({kind}), {} joints, {} meshes, {} clips",
            character.name,
            s.len(),
            character.meshes.len(),
            character.clips.len()
        )?;
        let mut depth = vec![0usize; s.len()];
        for i in 0..s.len() {
            if let Some(p) = s.parent(i) {
                depth[i] = depth[p] + 1;
            }
            let role = roles.per_joint[i].map_or("-".to_string(), |r| r.as_str().to_string());
            writeln!(
                out,
                "{}{}  [{}]",
                "  ".repeat(depth[i]),
                s.joint_label(i),
                role
            )?;
        }
        writeln!(out, "\nbodies:")?;
        for b in &spec.bodies {
            let shape = match b.shape {
                ragdoll::spec::Shape::Capsule { radius_m, length_m } => {
                    format!("capsule r={radius_m:.3} m, l={length_m:.3} m")
                }
                ragdoll::spec::Shape::Box { size_m } => format!(
                    "box {:.3} x {:.3} x {:.3} m",
                    size_m[0], size_m[1], size_m[2]
                ),
            };
            writeln!(
                out,
                "  {:<16} on {:<16} {shape}, {:.2} kg",
                b.name, b.bone, b.mass_kg
            )?;
        }
        writeln!(out, "\njoints:")?;
        for j in &spec.joints {
            let kind = match j.kind {
                ragdoll::spec::JointKind::Hinge { min_deg, max_deg } => {
                    format!("hinge {min_deg:.0}..{max_deg:.0}°")
                }
                ragdoll::spec::JointKind::SwingTwist {
                    swing_deg,
                    twist_deg,
                    ..
                } => format!(
                    "swing-twist cone {swing_deg:.0}°, twist {:.0}..{:.0}°",
                    twist_deg[0], twist_deg[1]
                ),
                ragdoll::spec::JointKind::Ball => "ball".into(),
                ragdoll::spec::JointKind::Fixed => "fixed".into(),
            };
            writeln!(out, "  {:<16} {} -> {}: {kind}", j.name, j.parent, j.child)?;
        }
        writeln!(out, "\ntotal mass: {:.2} kg", spec.total_mass_kg())?;
    }
    use std::io::Write;
    std::io::stdout().write_all(out.as_bytes())?;
    Ok(())
}
