//! `ragdoll`: the command-line tool. A thin layer over the `ragdoll` library: clap parses
//! raw values, the library validates them as settings, and each command lives in its own
//! module. Flags that would be ignored in a combination are refused rather than dropped.
//! Errors print as one line and exit non-zero (1 for a bad input, 2 for a bad command
//! line, 70 for a bug: a panic caught by [`fatal::guard`]); outputs are staged and renamed
//! into place together ([`output::Staging`]), so a failed run leaves no partial file.

/// `println!` that stops quietly when stdout is closed (`ragdoll inspect X | head`):
/// `println!` panics on a broken pipe, and a closed reader is not an error of ours.
macro_rules! outln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        if writeln!(std::io::stdout(), $($arg)*).is_err() {
            std::process::exit(0);
        }
    }};
}

/// `eprintln!` for status lines, which carries on when stderr is closed (`eprintln!`
/// panics there, and a status line is not worth failing a finished run for).
macro_rules! errln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($arg)*);
    }};
}

/// `print!` that stops quietly when stdout is closed, as [`outln!`].
#[allow(unused_macros)]
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        if write!(std::io::stdout(), $($arg)*).is_err() {
            std::process::exit(0);
        }
    }};
}

mod bench;
mod bench_farm;
mod bench_piles;
mod bench_reference;
mod character;
mod checks;
mod clip_list;
mod commands;
mod farm;
mod farm_merge;
mod farm_sheet;
mod farm_task;
mod farm_templates;
mod fatal;
mod inspect;
mod output;
mod preview_cmd;
mod printable;
mod progress;
mod rig_cmd;
mod scene_cmd;
mod view_cmd;
mod wedge_cmd;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, CommandFactory, FromArgMatches, Parser, Subcommand, ValueEnum};

/// Turn any character into a physically simulated ragdoll and bake the motion to glTF/BVH.
#[derive(Parser, Debug)]
#[command(name = "ragdoll", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Release the built-in humanoid standing and let it collapse; writes demo.glb, demo.bvh
    /// and report.json.
    Demo(DemoArgs),
    /// Print a character's joint tree with roles, and the ragdoll built from it.
    Inspect(InspectArgs),
    /// Build a ragdoll spec from a character and write it as TOML for editing.
    Build(BuildArgs),
    /// Simulate a character falling as a ragdoll and bake the result to .glb or .bvh; or run
    /// a scene file (.toml: characters and events) into a folder.
    Simulate(SimulateArgs),
    /// Throw a character with an explosion (kg of TNT at a point) and bake the result.
    Blast(BlastArgs),
    /// Hit a character with a projectile (a straight shot) and bake the result.
    Shoot(ShootArgs),
    /// Rig a mesh without a skeleton (OBJ, or glTF without a skin): a spine along its
    /// centre line, optional mirrored limbs, automatic skin weights; writes a skinned .glb.
    Rig(rig_cmd::RigArgs),
    /// Measure simulation speed on the pile workload (or, with --farm, the farm commands).
    /// A benchmark, not a test.
    Bench(bench::BenchArgs),
    /// Draw a baked result (.glb written by ragdoll) as a PNG or an animated GIF, on the CPU.
    Preview(preview_cmd::PreviewArgs),
    /// Open the interactive viewer: serves a local web page that shows the simulation live;
    /// drag body parts, place blasts, scrub, edit the ragdoll.
    View(view_cmd::ViewArgs),
    /// List the variants a scene's [wedge] table makes, or write one as a scene file.
    Wedge(wedge_cmd::WedgeArgs),
    /// Split a wedge into a farm job: plan.json, an Open Job Description template and
    /// Slurm scripts in a job folder.
    Plan(farm::PlanArgs),
    /// Run one task of a planned job: its variants, each renamed into place when complete.
    RunTask(farm_task::RunTaskArgs),
    /// Check every variant of a job and gather their values and metrics into one table.
    Merge(farm_merge::MergeArgs),
}

/// How to read a character file.
#[derive(Args, Debug, Clone)]
struct ImportArgs {
    /// Length unit of the file: of a BVH file (detected from the skeleton's height by
    /// default), an OBJ file (metres by default), or a glTF/VRM file exported in other
    /// units than the metres its format says.
    #[arg(long, value_enum)]
    units: Option<UnitsArg>,
    /// Up axis of a BVH file (detected by default) or of an OBJ file (Y by default).
    #[arg(long, value_enum)]
    up: Option<UpArg>,
    /// Scale the character to this height in metres (its mesh's, else its skeleton's,
    /// rest-pose vertical extent).
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    height: Option<f32>,
    /// The animation to play, by index or name (`ragdoll inspect` lists them); the first
    /// by default.
    #[arg(long, value_name = "NAME|INDEX")]
    clip: Option<String>,
}

/// How to read a mesh to rig: only what a mesh file may leave unsaid.
#[derive(Args, Debug, Clone)]
struct MeshImportArgs {
    /// Length unit of an OBJ file (metres by default) or of a glTF file exported in other
    /// units than the metres its format says.
    #[arg(long, value_enum)]
    units: Option<UnitsArg>,
    /// Up axis of an OBJ file (Y by default).
    #[arg(long, value_enum)]
    up: Option<UpArg>,
}

impl From<&MeshImportArgs> for ImportArgs {
    fn from(a: &MeshImportArgs) -> Self {
        ImportArgs {
            units: a.units,
            up: a.up,
            height: None,
            clip: None,
        }
    }
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum UnitsArg {
    M,
    Cm,
    Mm,
    In,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum UpArg {
    Y,
    Z,
}

/// How to build the ragdoll.
#[derive(Args, Debug, Clone)]
struct RagdollArgs {
    /// Total body mass in kg (humanoids default to 75 kg at 1.75 m tall, scaled as the cube
    /// of their height; other creatures to their volume times the density of water).
    #[arg(long, allow_negative_numbers = true)]
    mass: Option<f32>,
    /// Use the female table of body-segment masses (de Leva 1996). Not with --spec, whose
    /// masses are already set.
    #[arg(long, conflicts_with = "spec")]
    female: bool,
    /// Use this spec (written by `ragdoll build`, possibly edited) instead of building one.
    /// With --mass, its body masses are scaled to that total.
    #[arg(long, value_name = "SPEC.toml")]
    spec: Option<PathBuf>,
    /// Roles by hand, for a rig recognition gets wrong: a TOML file mapping roles to joints
    /// (`[roles]` with `thigh_l = "LeftUpLeg"`…, `ignore = [...]` for helper joints; see
    /// examples/roles/). Joints it does not name are recognised as before.
    #[arg(long, value_name = "ROLES.toml", conflicts_with = "spec")]
    roles: Option<PathBuf>,
}

/// `--backend`'s values: the library's own names, so the flag, scene files and the viewer
/// can never disagree on what a backend is called.
fn backend_parser() -> impl clap::builder::TypedValueParser<Value = ragdoll::world::BackendKind> {
    use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
    use ragdoll::world::BackendKind;
    PossibleValuesParser::new(
        BackendKind::ALL.map(|k| PossibleValue::new(k.as_str()).help(k.summary())),
    )
    .map(|name| BackendKind::from_name(&name).unwrap_or_default())
}

/// The backend flag, shared by every command that simulates.
#[derive(Args, Debug, Clone)]
pub struct BackendArgs {
    /// Physics backend: `rigid` (rapier3d, the reference), `particle` (our particle
    /// ragdoll) or `fast` (our rigid-body solver for ragdolls, for crowds).
    #[arg(long, value_parser = backend_parser(), default_value = "rigid")]
    pub backend: ragdoll::world::BackendKind,
}

/// How long and how finely to simulate.
#[derive(Args, Debug, Clone)]
struct RunArgs {
    #[command(flatten)]
    backend: BackendArgs,
    /// Simulated seconds.
    #[arg(long, allow_negative_numbers = true, default_value_t = 3.0)]
    seconds: f32,
    /// Output frames per second.
    #[arg(long, allow_negative_numbers = true, default_value_t = 30.0)]
    fps: f32,
    /// Passive joint damping, per second (rigid and fast backends; off by default): a limp
    /// limb's swing relative to its parent loses speed at this rate, its amplitude falling
    /// as exp(-RATE t / 2), so a raised head or a hanging arm comes to rest instead of
    /// swinging for the whole run. A relaxed human knee's is about 0.8 (the leg-drop
    /// pendulum test).
    #[arg(
        long,
        allow_negative_numbers = true,
        value_name = "RATE",
        default_value_t = 0.0
    )]
    joint_damping: f32,
    /// Keep every joint of the fast backend active. By default a joint whose two parts
    /// have stopped turning against each other is frozen, and they move as one rigid body
    /// until a blow, a landing or another ragdoll arrives (the fast backend's level of
    /// detail below sleep).
    #[arg(long)]
    no_freeze: bool,
}

/// How a character's animation leads into the simulation. Only for commands that read a
/// character file (the built-in humanoid has no animation).
#[derive(Args, Debug, Clone)]
struct AnimArgs {
    /// Start from the rest pose instead of the first animation frame.
    #[arg(long)]
    rest_pose: bool,
    /// When physics takes over: `start`, a time in seconds (the animation plays until
    /// then), `blast` (when the first blast front reaches the character) or `contact` (when
    /// something other than the ground touches it, or a shot hits it).
    #[arg(long, allow_negative_numbers = true, value_name = "start|SECONDS|blast|contact", default_value = "start", value_parser = parse_activation)]
    activate: ragdoll::world::Activation,
    /// Powered mode: joint motors pull the ragdoll toward its animation with this strength
    /// (0-1) once physics has taken over.
    #[arg(long, allow_negative_numbers = true, value_name = "STRENGTH")]
    powered: Option<f32>,
    /// With --powered: the strength falls linearly to 0 between these times, seconds, and
    /// the ragdoll goes limp.
    #[arg(long, value_name = "START,END", value_parser = parse_pair, requires = "powered", allow_hyphen_values = true)]
    fade_out: Option<[f32; 2]>,
    /// With --powered: the root (pelvis) follows the animation exactly; the motors carry the
    /// rest.
    #[arg(long, requires = "powered")]
    root_on_clip: bool,
}

impl Default for AnimArgs {
    /// What a command without these flags (demo) runs with.
    fn default() -> Self {
        AnimArgs {
            rest_pose: false,
            activate: ragdoll::world::Activation::Immediately,
            powered: None,
            fade_out: None,
            root_on_clip: false,
        }
    }
}

/// The simulation flags of the commands that read a character.
#[derive(Args, Debug, Clone)]
struct SimArgs {
    #[command(flatten)]
    run: RunArgs,
    #[command(flatten)]
    anim: AnimArgs,
}

/// Parses `START,END` (two finite numbers).
fn parse_pair(text: &str) -> Result<[f32; 2], String> {
    let parts: Vec<f32> = text
        .split(',')
        .map(|s| {
            s.trim()
                .parse::<f32>()
                .map_err(|_| format!("\"{s}\" is not a number"))
        })
        .collect::<Result<_, _>>()?;
    match parts.as_slice() {
        [a, b] if a.is_finite() && b.is_finite() => Ok([*a, *b]),
        _ => Err(format!("expected START,END (two numbers), got \"{text}\"")),
    }
}

/// Parses `--activate`.
fn parse_activation(text: &str) -> Result<ragdoll::world::Activation, String> {
    use ragdoll::world::Activation;
    match text {
        "start" => Ok(Activation::Immediately),
        "blast" => Ok(Activation::OnBlast),
        "contact" => Ok(Activation::OnContact),
        _ => match text.parse::<f32>() {
            Ok(t) if t.is_finite() && t >= 0.0 => Ok(Activation::AtTime(t)),
            _ => Err(format!(
                "expected start, blast, contact or a time in seconds, got \"{text}\""
            )),
        },
    }
}

#[derive(Args, Debug)]
struct DemoArgs {
    /// Output directory.
    #[arg(short, long, default_value = "out")]
    output: PathBuf,
    #[command(flatten)]
    ragdoll: RagdollArgs,
    #[command(flatten)]
    run: RunArgs,
    #[command(flatten)]
    preview: preview_cmd::PreviewArg,
}

#[derive(Args, Debug)]
struct InspectArgs {
    /// A .bvh, .glb, .gltf, .vrm or .obj file.
    file: PathBuf,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    import: ImportArgs,
    #[command(flatten)]
    ragdoll: RagdollArgs,
}

#[derive(Args, Debug)]
struct BuildArgs {
    /// A .bvh, .glb, .gltf, .vrm or .obj file.
    file: PathBuf,
    /// Where to write the spec (TOML).
    #[arg(short, long, value_name = "SPEC.toml")]
    output: PathBuf,
    #[command(flatten)]
    import: ImportArgs,
    #[command(flatten)]
    ragdoll: RagdollArgs,
}

#[derive(Args, Debug)]
struct SimulateArgs {
    /// A .bvh, .glb, .gltf, .vrm or .obj file, or a scene file (.toml; see the guide's "Scenes").
    file: PathBuf,
    /// Output file: .glb or .bvh. The report goes next to it as STEM.report.json. For a
    /// scene file, the output folder (--seconds, --fps and --rest-pose then override the
    /// scene's settings).
    #[arg(short, long, value_name = "OUT.glb|OUT.bvh|DIR")]
    output: PathBuf,
    #[command(flatten)]
    import: ImportArgs,
    #[command(flatten)]
    ragdoll: RagdollArgs,
    #[command(flatten)]
    sim: SimArgs,
    #[command(flatten)]
    preview: preview_cmd::PreviewArg,
    /// Also write the deformed mesh (or the ragdoll's bodies) as one OBJ per frame into
    /// this folder (character files only).
    #[arg(long, value_name = "DIR")]
    obj_sequence: Option<PathBuf>,
    /// Scene files only: one glTF per character ({name}.glb) instead of one with every
    /// character, as `glb = "{name}.glb"` in the scene's [output] table.
    #[arg(long)]
    split: bool,
}

#[derive(Args, Debug)]
struct BlastArgs {
    /// A .bvh, .glb, .gltf, .vrm or .obj file; the built-in humanoid when left out.
    file: Option<PathBuf>,
    /// Charge as TNT-equivalent mass, kg.
    #[arg(long, allow_negative_numbers = true, value_name = "KG")]
    tnt: f32,
    /// Where the charge is, metres: X,Y,Z (Y up; the character stands around the origin).
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true)]
    at: [f32; 3],
    /// Detonation time, seconds after the start.
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.0)]
    time: f32,
    /// Artistic multiplier on the blast loads (1 = physical).
    #[arg(long, allow_negative_numbers = true, default_value_t = 1.0)]
    scale: f32,
    /// Output file: .glb or .bvh. The report goes next to it as STEM.report.json.
    #[arg(short, long, value_name = "OUT.glb|OUT.bvh")]
    output: PathBuf,
    #[command(flatten)]
    import: ImportArgs,
    #[command(flatten)]
    ragdoll: RagdollArgs,
    #[command(flatten)]
    sim: SimArgs,
    #[command(flatten)]
    preview: preview_cmd::PreviewArg,
}

#[derive(Args, Debug)]
struct ShootArgs {
    /// A .bvh, .glb, .gltf, .vrm or .obj file; the built-in humanoid when left out.
    file: Option<PathBuf>,
    /// Where the projectile starts, metres: X,Y,Z.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true)]
    from: [f32; 3],
    /// A point it flies toward, metres: X,Y,Z.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true)]
    toward: [f32; 3],
    /// The projectile's mass, kg (default: a 9 mm bullet). `--mass` is the character's.
    #[arg(
        long,
        allow_negative_numbers = true,
        value_name = "KG",
        default_value_t = 0.008
    )]
    bullet_mass: f32,
    /// Its speed, m/s.
    #[arg(long, allow_negative_numbers = true, default_value_t = 360.0)]
    speed: f32,
    /// When it hits, seconds after the start.
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.0)]
    time: f32,
    /// Output file: .glb or .bvh. The report goes next to it as STEM.report.json.
    #[arg(short, long, value_name = "OUT.glb|OUT.bvh")]
    output: PathBuf,
    #[command(flatten)]
    import: ImportArgs,
    #[command(flatten)]
    ragdoll: RagdollArgs,
    #[command(flatten)]
    sim: SimArgs,
    #[command(flatten)]
    preview: preview_cmd::PreviewArg,
}

/// Parses `X,Y,Z` (three finite numbers, metres).
fn parse_vec3(text: &str) -> Result<[f32; 3], String> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    let [x, y, z] = parts.as_slice() else {
        return Err(format!("expected X,Y,Z (three numbers), got \"{text}\""));
    };
    let num = |s: &str| {
        s.parse::<f32>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| format!("\"{s}\" is not a finite number"))
    };
    Ok([num(x)?, num(y)?, num(z)?])
}

fn main() -> ExitCode {
    fatal::install_panic_hook();
    let typed = typed_subcommand();
    let label = typed.as_deref().unwrap_or("");
    match fatal::guard(label, run) {
        Err(e) if e.is::<clap::Error>() => match e.downcast::<clap::Error>() {
            Ok(e) => fatal::usage_error(e, typed.as_deref()),
            Err(e) => fatal::exit(Err(e)),
        },
        result => fatal::exit(result),
    }
}

/// The subcommand named on the command line, if any (for messages written before or
/// without a successful parse).
fn typed_subcommand() -> Option<String> {
    let names: Vec<String> = Cli::command()
        .get_subcommands()
        .map(|c| c.get_name().to_string())
        .collect();
    std::env::args()
        .skip(1)
        .find(|a| !a.starts_with('-'))
        .filter(|a| names.contains(a))
}

/// Parses the command line and runs the command; a clap error comes back as the
/// `clap::Error` inside the `anyhow::Error`.
fn run() -> anyhow::Result<()> {
    // Parsed in two steps so a scene run can tell flags typed from clap's defaults.
    let matches = Cli::command().try_get_matches()?;
    let cli = Cli::from_arg_matches(&matches)?;
    match cli.command {
        Command::Simulate(a) if scene_cmd::is_scene(&a.file) => scene_cmd::run(
            &a,
            matches.subcommand_matches("simulate").unwrap_or(&matches),
        ),
        Command::Demo(a) => commands::demo(&a),
        Command::Inspect(a) => inspect::inspect(&a),
        Command::Build(a) => inspect::build(&a),
        Command::Simulate(a) => commands::simulate(&a),
        Command::Blast(a) => commands::blast(&a),
        Command::Shoot(a) => commands::shoot(&a),
        Command::Bench(a) => bench::run(&a),
        Command::Preview(a) => preview_cmd::run(&a),
        Command::Rig(a) => rig_cmd::run(&a),
        Command::View(a) => view_cmd::run(&a),
        Command::Wedge(a) => wedge_cmd::run(&a),
        Command::Plan(a) => farm::plan(&a),
        Command::RunTask(a) => farm_task::run(&a),
        Command::Merge(a) => farm_merge::run(&a),
    }
}
