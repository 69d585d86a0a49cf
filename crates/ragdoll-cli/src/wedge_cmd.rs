//! `ragdoll wedge SCENE --list` and `ragdoll wedge SCENE --variant NAME -o FILE`: what a
//! scene's `[wedge]` table makes (the library's `scene::wedge`), and one variant written
//! out as an ordinary scene file, so a take picked from a farm's contact sheet can be run,
//! inspected or edited alone and gives the same bytes as the farm gave.

use std::path::{Path, PathBuf};

use anyhow::{Result, bail};
use clap::Args;
use ragdoll::scene::wedge::{Variant, Wedge};

use crate::output::{self, Staging};

#[derive(Args, Debug)]
pub struct WedgeArgs {
    /// A scene file with a [wedge] table.
    scene: PathBuf,
    /// Print every variant: its name, then each varied key's value.
    #[arg(long, conflicts_with = "variant")]
    list: bool,
    /// Print the list as JSON (with --list).
    #[arg(long, requires = "list")]
    json: bool,
    /// Write this variant (its name, or its index from 0) as a scene file.
    #[arg(long, value_name = "NAME", requires = "output")]
    variant: Option<String>,
    /// Where --variant writes the scene; its relative file paths are rewritten to be
    /// relative to this file's folder.
    #[arg(short, long, value_name = "SCENE.toml")]
    output: Option<PathBuf>,
}

pub fn run(a: &WedgeArgs) -> Result<()> {
    let wedge = load(&a.scene)?;
    match (&a.variant, &a.output) {
        (Some(name), Some(out)) => write_variant(&wedge, name, out),
        _ if a.list => {
            list(&wedge, a.json);
            Ok(())
        }
        _ => bail!("give --list, or --variant NAME -o SCENE.toml"),
    }
}

/// The scene's wedge; a scene without one is an error that says how to add it.
pub fn load(scene: &Path) -> Result<Wedge> {
    match Wedge::load(scene)? {
        Some(w) => Ok(w),
        None => bail!(
            "{}: has no [wedge] table, so it makes no variants (see the guide's \"Wedges and farm jobs\")",
            scene.display()
        ),
    }
}

/// The variant called `name` (or numbered so), else an error naming the scene.
pub fn find(wedge: &Wedge, name: &str) -> Result<Variant> {
    match wedge.find(name) {
        Some(v) => Ok(v),
        None => bail!(
            "{}: no variant is called {name:?} ({} variants; `ragdoll wedge {} --list` names them)",
            wedge.path.display(),
            wedge.len(),
            wedge.path.display()
        ),
    }
}

fn list(wedge: &Wedge, json: bool) {
    if json {
        let variants: Vec<serde_json::Value> = wedge.variants().map(|v| variant_json(&v)).collect();
        outln!(
            "{}",
            serde_json::to_string_pretty(&variants).unwrap_or_default()
        );
        return;
    }
    for v in wedge.variants() {
        let values: Vec<String> = v.values.iter().map(|(k, x)| format!("{k}={x}")).collect();
        outln!("{}\t{}", v.name, values.join("\t"));
    }
    errln!(
        "{}: {} variants ({} of {} keys)",
        wedge.path.display(),
        wedge.len(),
        wedge.mode.as_str(),
        wedge.keys.len()
    );
}

/// A variant as JSON: its index, name and values by key.
pub fn variant_json(v: &Variant) -> serde_json::Value {
    let values: serde_json::Map<String, serde_json::Value> = v
        .values
        .iter()
        .map(|(k, x)| (k.clone(), serde_json::to_value(x).unwrap_or_default()))
        .collect();
    serde_json::json!({ "index": v.index, "name": v.name, "values": values })
}

fn write_variant(wedge: &Wedge, name: &str, out: &Path) -> Result<()> {
    let variant = find(wedge, name)?;
    output::check_file(out)?;
    let mut staging = Staging::new();
    let dir = match out.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    staging.make_folder(dir)?;
    let text = wedge.scene_text(&variant, dir)?;
    staging.write(out, text.as_bytes())?;
    for path in staging.commit()? {
        outln!("{}", path.display());
    }
    Ok(())
}
