//! `ragdoll rig`: a skeleton and automatic skin for a mesh that has none, written
//! as a skinned glTF in the rest pose for a modeller or for `ragdoll simulate`.

use std::path::PathBuf;

use anyhow::{Result, bail};
use clap::Args;
use glam::Vec3;
use ragdoll::export::gltf::rig_to_glb;
use ragdoll::import;
use ragdoll::rig::{Branch, DEFAULT_JOINTS, Landmark, RigOptions};
use ragdoll::skeleton::Source;

use crate::progress::Progress;
use crate::{ImportArgs, MeshImportArgs, checks, output};

/// Rig a mesh without a skeleton (OBJ, or glTF without a skin) and write a skinned .glb.
#[derive(Args, Debug)]
pub struct RigArgs {
    /// A mesh without a skeleton: .obj, or .glb/.gltf without a skin.
    file: PathBuf,
    /// Spine joints, evenly spaced along the body's centre line (tail to head).
    #[arg(long, allow_negative_numbers = true, default_value_t = DEFAULT_JOINTS)]
    joints: usize,
    /// A point near the head, X,Y,Z in metres or vN (the mesh's vertex N, counted from 0):
    /// the end of the centre line nearest it is the head. By default the bulkier end.
    #[arg(long, value_name = "X,Y,Z|vN", value_parser = parse_landmark, allow_hyphen_values = true)]
    head: Option<Landmark>,
    /// Run the centre line through these landmarks, tail to head, separated by `/`
    /// (default: found by principal-component analysis of the mesh).
    #[arg(long, value_name = "P/P/...", value_parser = parse_spine, allow_hyphen_values = true)]
    spine: Option<Spine>,
    /// A limb, fin or whisker: NAME=P/P/..., from where it leaves the body to its end, each
    /// P being X,Y,Z or vN. It hangs from the nearest spine joint and gets a mirrored twin
    /// across the body's symmetry plane. Repeat for several.
    #[arg(long, value_name = "NAME=P/P/...", value_parser = parse_branch, allow_hyphen_values = true)]
    branch: Vec<Branch>,
    /// Do not give branches a mirrored twin.
    #[arg(long, requires = "branch")]
    no_mirror: bool,
    /// Fit a person's skeleton (pelvis, spine, chest, neck, head, legs, arms) to a figure
    /// standing in a T- or A-pose, arms away from the body, feet on the floor, Y up,
    /// instead of a spine along its centre line.
    #[arg(long, conflicts_with_all = ["spine", "head", "branch"])]
    humanoid: bool,
    /// The rigged file to write (.glb).
    #[arg(short, long, value_name = "OUT.glb")]
    output: PathBuf,
    #[command(flatten)]
    import: MeshImportArgs,
}

/// Parses `X,Y,Z` or `vN`.
fn parse_landmark(text: &str) -> Result<Landmark, String> {
    let t = text.trim();
    if let Some(n) = t.strip_prefix('v') {
        return n
            .parse::<usize>()
            .map(Landmark::Vertex)
            .map_err(|_| format!("\"{t}\": expected vN with N a vertex number counted from 0"));
    }
    let parts: Vec<f32> = t
        .split(',')
        .map(|s| s.trim().parse::<f32>().ok().filter(|v| v.is_finite()))
        .collect::<Option<_>>()
        .ok_or_else(|| format!("\"{t}\": expected X,Y,Z (three numbers, metres) or vN"))?;
    match parts[..] {
        [x, y, z] => Ok(Landmark::Point(Vec3::new(x, y, z))),
        _ => Err(format!(
            "\"{t}\": expected X,Y,Z (three numbers, metres) or vN"
        )),
    }
}

/// The `--spine` landmarks. A type of its own because clap's derive reads an
/// `Option<Vec<T>>` field as a flag taking several values of `T`, and then panics ("Mismatch
/// between definition and access") when the parser hands it one `Vec<T>`.
#[derive(Clone, Debug)]
struct Spine(Vec<Landmark>);

fn parse_spine(text: &str) -> Result<Spine, String> {
    parse_landmarks(text).map(Spine)
}

/// Parses `P/P/...`.
fn parse_landmarks(text: &str) -> Result<Vec<Landmark>, String> {
    text.split('/').map(parse_landmark).collect()
}

/// Parses `NAME=P/P/...` (mirrored; `--no-mirror` turns that off later).
fn parse_branch(text: &str) -> Result<Branch, String> {
    let Some((name, points)) = text.split_once('=') else {
        return Err(format!("\"{text}\": expected NAME=P/P/..."));
    };
    let name = name.trim();
    if name.is_empty() || !name.chars().all(|c| c.is_alphanumeric() || c == '_') {
        return Err(format!(
            "\"{name}\": a branch name needs letters, digits or _ (it names joints)"
        ));
    }
    let points = parse_landmarks(points)?;
    if points.len() < 2 {
        return Err(format!(
            "branch \"{name}\": needs at least two points (where it leaves the body, where it ends)"
        ));
    }
    Ok(Branch {
        name: name.to_string(),
        points,
        joints: 0,
        mirror: true,
    })
}

pub fn run(a: &RigArgs) -> Result<()> {
    let is_glb = a
        .output
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("glb"));
    if !is_glb {
        bail!("{}: the output must end in .glb", a.output.display());
    }
    output::check_file(&a.output)?;
    let import_args = ImportArgs::from(&a.import);
    checks::import_flags(Some(&a.file), &import_args)?;
    let opts = RigOptions {
        joints: a.joints,
        centre_line: a.spine.clone().map(|s| s.0).unwrap_or_default(),
        head: a.head,
        branches: a
            .branch
            .iter()
            .map(|b| Branch {
                mirror: !a.no_mirror,
                ..b.clone()
            })
            .collect(),
        humanoid: a.humanoid,
    };
    let progress = Progress::new(0, &format!("rigging {}", a.file.display()));
    let character = import::load_rigged(
        &a.file,
        &crate::character::import_options(&import_args),
        &opts,
    )
    .map_err(rig_flag_error)?;
    progress.finish();
    for w in &character.warnings {
        eprintln!("warning: {}", crate::printable::shown(w));
    }
    if !matches!(character.source, Source::Mesh(_)) {
        bail!(
            "{}: already has a skeleton; `ragdoll rig` is for meshes without one (simulate it directly)",
            a.file.display()
        );
    }
    let bytes = rig_to_glb(&character)?;
    output::write_one(&a.output, &bytes)?;
    let vertices: usize = character.meshes.iter().map(|m| m.positions.len()).sum();
    let skeleton = &character.skeleton;
    let head = skeleton.rest_world()[skeleton.find("head").unwrap_or(0)].translation;
    outln!(
        "rigged {} ({vertices} vertices): {} joints, head joint at ({:.3}, {:.3}, {:.3}) m",
        a.file.display(),
        skeleton.len(),
        head.x,
        head.y,
        head.z
    );
    outln!("wrote {}", a.output.display());
    Ok(())
}

/// Library setting names (`rig.joints`) as the flags the user typed.
fn rig_flag_error(e: ragdoll::Error) -> anyhow::Error {
    match e {
        ragdoll::Error::Setting { setting, message } => {
            let flag = match setting.strip_prefix("rig.") {
                Some("joints") => "--joints".to_string(),
                Some("head") => "--head".to_string(),
                Some("centre_line") => "--spine".to_string(),
                Some(other) => format!("--{other}"),
                None => setting,
            };
            anyhow::anyhow!("{flag}: {message}")
        }
        e => e.into(),
    }
}
