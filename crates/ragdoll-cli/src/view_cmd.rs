//! `ragdoll view [FILE|SCENE.toml]`: the interactive viewer. Loads the character (or the
//! scene), starts the local web server of the `ragdoll-view` crate, prints the page's URL
//! and serves until stopped (Ctrl-C). If the viewer stops on its own (the server failed,
//! or the simulation crashed and could not be restarted) it exits non-zero with the reason.

use std::net::IpAddr;
use std::path::PathBuf;

use anyhow::{Result, bail};
use clap::Args;
use ragdoll::scene::Scene;
use ragdoll::world::{StartPose, WorldSettings};
use ragdoll_view::{ViewOptions, Viewer};

use crate::character::{load_or_builtin, ragdoll_spec};
use crate::scene_cmd::is_scene;
use crate::{ImportArgs, RagdollArgs};

#[derive(Args, Debug)]
pub struct ViewArgs {
    /// A .bvh, .glb or .gltf file, or a scene file (.toml); the built-in humanoid when left
    /// out.
    file: Option<PathBuf>,
    /// Port to listen on; 0 picks a free one (the printed URL shows it).
    #[arg(long, default_value_t = 8765)]
    port: u16,
    /// Address to listen on. The default serves this machine only: anyone who reaches the
    /// port can drive the simulation and save specs.
    #[arg(long, default_value = "127.0.0.1")]
    host: IpAddr,
    /// Do not open a browser; just print the URL.
    #[arg(long)]
    no_open: bool,
    /// Folder the page's "Save spec" writes into (default: the current folder); created on
    /// the first save. The page asks before replacing a file already there.
    #[arg(long, value_name = "DIR")]
    save_dir: Option<PathBuf>,
    /// Start from the rest pose instead of the first animation frame.
    #[arg(long)]
    rest_pose: bool,
    #[command(flatten)]
    import: ImportArgs,
    #[command(flatten)]
    ragdoll: RagdollArgs,
}

pub fn run(a: &ViewArgs) -> Result<()> {
    let scene = match &a.file {
        Some(file) if is_scene(file) => {
            // One flag for a scene of several characters would apply to nobody, or to every
            // character of whatever file: each table sets its own.
            let given = [
                (a.ragdoll.mass.is_some(), "--mass", "mass_kg"),
                (a.ragdoll.female, "--female", "female"),
                (a.ragdoll.spec.is_some(), "--spec", "spec"),
                (a.ragdoll.roles.is_some(), "--roles", "roles"),
                (a.import.units.is_some(), "--units", "units"),
                (a.import.up.is_some(), "--up", "up"),
                (a.import.height.is_some(), "--height", "height"),
                (a.import.clip.is_some(), "--clip", "clip"),
            ];
            if let Some((_, flag, key)) = given.iter().find(|g| g.0) {
                bail!(
                    "{flag} does not apply to a scene file: set {key} in its [[character]] tables ({})",
                    file.display()
                );
            }
            let mut scene = Scene::load(file)?;
            crate::scene_cmd::print_warnings(&scene);
            if a.rest_pose {
                scene.settings.start = StartPose::Rest;
            }
            scene
        }
        _ => {
            let (character, input) = load_or_builtin(a.file.as_deref(), &a.import)?;
            let spec = ragdoll_spec(&character, &input, &a.ragdoll)?;
            let settings = WorldSettings {
                start: if a.rest_pose {
                    StartPose::Rest
                } else {
                    StartPose::FirstFrame
                },
                ..Default::default()
            };
            let mut scene = Scene::single(character, spec, &input, 0.0, settings);
            // Errors placing the character name its file.
            scene.path = PathBuf::from(&input);
            scene
        }
    };
    // The current folder, not the input's: inputs often sit in folders that are not ours
    // to write into (shared data, a download).
    let save_dir = a.save_dir.clone().unwrap_or_else(|| PathBuf::from("."));
    let save_stem = a.file.as_ref().and_then(|f| f.file_stem()).map_or_else(
        || "humanoid".to_string(),
        |s| s.to_string_lossy().into_owned(),
    );
    let options = ViewOptions {
        host: a.host,
        port: a.port,
        save_dir,
        save_stem,
    };
    let viewer = Viewer::start(scene, &options)?;
    let url = viewer.url();
    outln!("ragdoll view: open {url} (Ctrl-C stops the server)");
    if !a.no_open {
        open_browser(&url);
    }
    viewer.wait()?;
    Ok(())
}

/// Asks the desktop to open `url`; a machine without one (a server, CI) just has the
/// printed URL.
fn open_browser(url: &str) {
    let opener = if cfg!(target_os = "macos") {
        "open"
    } else if cfg!(target_os = "windows") {
        "explorer"
    } else {
        "xdg-open"
    };
    let spawned = std::process::Command::new(opener)
        .arg(url)
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn();
    if spawned.is_err() {
        eprintln!("(could not start {opener}: open the URL by hand)");
    }
}
