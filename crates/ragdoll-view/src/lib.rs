//! The interactive viewer behind `ragdoll view`: a local web server that runs a ragdoll
//! simulation in real time and streams it over a WebSocket to a page drawn with WebGL2.
//!
//! Why a web page: the page and its script are compiled into the binary (no files to
//! install, no build step, no CDN), any browser draws it, and the server (axum) builds in
//! a fraction of the time a native GUI toolkit takes.
//!
//! - `session`: one thread owns the [`ragdoll::world::World`], steps it in real time,
//!   records every step (for scrubbing) and replays the user's events after edits;
//! - `server`: the page, `GET /api/state` (time and body positions, JSON, for scripts and
//!   tests) and `GET /ws`, where every message is checked by [`protocol`] first;
//! - `web/index.html` and `web/viewer.js`: the page.
//!
//! The server listens on 127.0.0.1 unless told otherwise: it runs a simulation anyone who
//! reaches the port can drive and writes spec files into the save folder.
#![deny(missing_docs)]

pub mod protocol;
mod server;
mod session;

use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::path::PathBuf;
use std::sync::{Arc, Mutex, mpsc};

use ragdoll::error::{Error, Result};
use ragdoll::scene::{Outputs, Scene, SceneCharacter};
use ragdoll::skeleton::Character;
use ragdoll::spec::RagdollSpec;
use ragdoll::world::{Activation, WorldSettings};
use tokio::sync::{broadcast, watch};

use session::{Command, Outlets, Session};

/// Where the viewer listens and writes.
#[derive(Clone, Debug)]
pub struct ViewOptions {
    /// Address to listen on (default 127.0.0.1: this machine only).
    pub host: IpAddr,
    /// Port (default 8765); 0 picks a free one, which [`Viewer::url`] then shows.
    pub port: u16,
    /// Folder the page's "save" writes edited specs into.
    pub save_dir: PathBuf,
    /// File stem of the saved specs (`STEM.spec.toml`, or `STEM.NAME.spec.toml` per
    /// character when there are several).
    pub save_stem: String,
}

impl Default for ViewOptions {
    fn default() -> Self {
        ViewOptions {
            host: IpAddr::V4(Ipv4Addr::LOCALHOST),
            port: 8765,
            save_dir: PathBuf::from("."),
            save_stem: "ragdoll".into(),
        }
    }
}

/// A one-character scene for a character file: the character standing at the origin,
/// physics from the start, default world settings.
pub fn single_character_scene(
    character: Character,
    spec: RagdollSpec,
    input: &str,
    settings: WorldSettings,
) -> Scene {
    Scene {
        path: PathBuf::from(input),
        duration_s: 0.0,
        settings,
        characters: vec![SceneCharacter {
            name: character.name.clone(),
            input: input.into(),
            character,
            spec,
            position: glam::Vec3::ZERO,
            facing_deg: 0.0,
            activation: Activation::Immediately,
            motors: None,
            line: 0,
        }],
        blasts: Vec::new(),
        projectiles: Vec::new(),
        pushes: Vec::new(),
        fields: Vec::new(),
        pins: Vec::new(),
        outputs: Outputs::default(),
    }
}

/// A running viewer: the server's tasks and the simulation thread.
pub struct Viewer {
    addr: SocketAddr,
    runtime: tokio::runtime::Runtime,
    commands: mpsc::Sender<Command>,
    simulation: std::thread::JoinHandle<()>,
}

impl Viewer {
    /// Builds the scene's world, binds the port and starts serving; returns at once.
    ///
    /// ```no_run
    /// use ragdoll::{skeleton, spec, world::WorldSettings};
    /// use ragdoll_view::{ViewOptions, Viewer, single_character_scene};
    ///
    /// let character = skeleton::humanoid();
    /// let spec = spec::build_spec(&character, &spec::BuildOptions::default()).unwrap();
    /// let scene = single_character_scene(character, spec, "built-in", WorldSettings::default());
    /// let viewer = Viewer::start(scene, &ViewOptions { port: 0, ..Default::default() }).unwrap();
    /// println!("open {}", viewer.url());
    /// viewer.wait();
    /// ```
    pub fn start(scene: Scene, options: &ViewOptions) -> Result<Viewer> {
        let addr = SocketAddr::new(options.host, options.port);
        let listener = std::net::TcpListener::bind(addr).map_err(|e| Error::Setting {
            setting: "port".into(),
            message: format!("cannot listen on {addr}: {e} (--port 0 picks a free port)"),
        })?;
        let io = |e: std::io::Error| Error::Setting {
            setting: "server".into(),
            message: format!("cannot start the server: {e}"),
        };
        listener.set_nonblocking(true).map_err(io)?;
        let addr = listener.local_addr().map_err(io)?;

        let (frames_tx, frames_rx) = watch::channel::<Arc<str>>(Arc::from(""));
        let (specs_tx, specs_rx) = watch::channel::<Arc<str>>(Arc::from(""));
        let (notices, _) = broadcast::channel(64);
        let state = Arc::new(Mutex::new(serde_json::Value::Null));
        let outlets = Outlets {
            frames: frames_tx,
            specs: specs_tx,
            notices: notices.clone(),
            state: state.clone(),
        };
        let (tx, rx) = mpsc::channel();
        let session = Session::new(
            scene,
            options.save_dir.clone(),
            options.save_stem.clone(),
            outlets,
        )?;
        let app = Arc::new(server::App {
            scene_json: session.scene_message().into(),
            shape: session.shape(),
            commands: Mutex::new(tx.clone()),
            frames: frames_rx,
            specs: specs_rx,
            notices,
            state,
        });
        let simulation = std::thread::Builder::new()
            .name("ragdoll-view-sim".into())
            .spawn(move || session.run(rx))
            .map_err(io)?;

        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .enable_all()
            .build()
            .map_err(io)?;
        let listener = {
            let _guard = runtime.enter();
            tokio::net::TcpListener::from_std(listener).map_err(io)?
        };
        let service = server::router(app).into_make_service_with_connect_info::<SocketAddr>();
        runtime.spawn(async move {
            if let Err(e) = axum::serve(listener, service).await {
                eprintln!("viewer: the server stopped: {e}");
            }
        });
        Ok(Viewer {
            addr,
            runtime,
            commands: tx,
            simulation,
        })
    }

    /// The address the server listens on (with the port picked when 0 was asked for).
    pub fn local_addr(&self) -> SocketAddr {
        self.addr
    }

    /// The page's URL.
    pub fn url(&self) -> String {
        format!("http://{}/", self.addr)
    }

    /// Serves until the process is stopped (Ctrl-C).
    pub fn wait(self) {
        let _ = self.simulation.join();
        drop(self.runtime);
    }

    /// Stops the simulation and the server.
    pub fn shutdown(self) {
        let _ = self.commands.send(Command::Shutdown);
        let _ = self.simulation.join();
        self.runtime.shutdown_background();
    }
}
