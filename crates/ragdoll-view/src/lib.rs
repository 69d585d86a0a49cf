//! The interactive viewer behind `ragdoll view`: a local web server that runs a ragdoll
//! simulation in real time and streams it over a WebSocket to a page drawn with WebGL2.
//!
//! Why a web page: the page and its script are compiled into the binary (no files to
//! install, no build step, no CDN), any browser draws it, and the server (axum) builds in
//! a fraction of the time a native GUI toolkit takes.
//!
//! - `session`: one thread owns the [`ragdoll::world::World`], steps it in real time,
//!   records every step (for scrubbing) and replays the user's events after edits;
//! - `supervisor`: runs the session, and restarts it from the file's spec when it panics;
//! - `server`: the page, `GET /api/state` (time and body positions, JSON, for scripts and
//!   tests) and `GET /ws`, where every message is checked by [`protocol`] first;
//! - `guard`: the Host and Origin checks every request passes first (DNS rebinding);
//! - `web/index.html` and `web/viewer.js`: the page.
//!
//! **One simulation for all pages.** Every open page shows and drives the same simulation.
//! A page that connects (a new tab, or a reload) starts it over as the file describes it:
//! t = 0, paused, the file's specs, no events; the other pages follow (they are told why).
//!
//! The server listens on 127.0.0.1 unless told otherwise: it runs a simulation anyone who
//! reaches the port can drive and writes spec files into the save folder.
#![deny(missing_docs)]

mod guard;
#[doc(hidden)]
pub mod headless;
mod log;
pub mod protocol;
mod server;
mod session;
mod supervisor;

use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, mpsc};

use ragdoll::error::{Error, Result};
use ragdoll::scene::Scene;
use tokio::sync::{broadcast, watch};

use session::{Command, Outlets, SaveTarget, Session};

/// Commands waiting for the simulation thread: past this many, messages from pages are
/// dropped (with a log line) instead of queueing without bound while a long replay runs.
const MAX_QUEUED_COMMANDS: usize = 256;

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

/// The server's socket, bound and non-blocking, and the address it got.
fn listen(options: &ViewOptions) -> Result<(std::net::TcpListener, SocketAddr)> {
    let addr = SocketAddr::new(options.host, options.port);
    let listener = std::net::TcpListener::bind(addr).map_err(|e| Error::Setting {
        setting: "port".into(),
        message: format!("cannot listen on {addr}: {e} (--port 0 picks a free port)"),
    })?;
    listener.set_nonblocking(true).map_err(server_err)?;
    let addr = listener.local_addr().map_err(server_err)?;
    Ok((listener, addr))
}

/// A server that could not start, as the user reads it.
fn server_err(e: std::io::Error) -> Error {
    Error::Setting {
        setting: "server".into(),
        message: format!("cannot start the server: {e}"),
    }
}

/// The simulation's thread, running `session` under `supervisor` on the commands `rx`.
fn spawn_simulation(
    supervisor: supervisor::Supervisor,
    session: Session,
    rx: mpsc::Receiver<Command>,
    stopped: mpsc::Sender<Stopped>,
) -> Result<std::thread::JoinHandle<()>> {
    std::thread::Builder::new()
        .name("ragdoll-view-sim".into())
        .spawn(move || {
            // The supervisor catches the session's panics; this catches its own, so
            // `wait` always hears that the simulation is gone.
            let run = std::panic::AssertUnwindSafe(|| supervisor.run(session, rx));
            if std::panic::catch_unwind(run).is_err() {
                let _ = stopped.send(Err("the simulation's supervisor crashed".into()));
            }
        })
        .map_err(server_err)
}

/// The web server on `listener`, on a runtime of its own; says on `stopped` when it ends.
fn serve(
    listener: std::net::TcpListener,
    app: Arc<server::App>,
    stopped: mpsc::Sender<Stopped>,
) -> Result<tokio::runtime::Runtime> {
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map_err(server_err)?;
    let listener = {
        let _guard = runtime.enter();
        tokio::net::TcpListener::from_std(listener).map_err(server_err)?
    };
    let service = server::router(app).into_make_service_with_connect_info::<SocketAddr>();
    runtime.spawn(async move {
        let why = match axum::serve(listener, service).await {
            Ok(()) => "the server stopped".to_string(),
            Err(e) => format!("the server stopped: {e}"),
        };
        eprintln!("viewer: {why}");
        let _ = stopped.send(Err(why));
    });
    Ok(runtime)
}

/// Refuses a save folder that can never be written: a path that is a file, or sits below
/// one. A folder that does not exist yet is fine (the first save creates it).
fn check_save_dir(dir: &Path) -> Result<()> {
    let refuse = |message: String| {
        Err(Error::Setting {
            setting: "--save-dir".into(),
            message,
        })
    };
    let mut at = Some(dir);
    while let Some(p) = at.filter(|p| !p.as_os_str().is_empty()) {
        match std::fs::metadata(p) {
            Ok(m) if m.is_dir() => return Ok(()),
            Ok(_) if p == dir => {
                return refuse(format!(
                    "{} is a file, not a folder: the page's Save writes spec files into a folder",
                    dir.display()
                ));
            }
            Ok(_) => {
                return refuse(format!(
                    "{} cannot be a folder: {} is a file",
                    dir.display(),
                    p.display()
                ));
            }
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::NotFound | std::io::ErrorKind::NotADirectory
                ) =>
            {
                at = p.parent()
            }
            Err(e) => return refuse(format!("{}: {e}", p.display())),
        }
    }
    Ok(())
}

/// Why the viewer stopped on its own: sent by the supervisor or the server task.
type Stopped = std::result::Result<(), String>;

/// A running viewer: the server's tasks and the simulation thread.
pub struct Viewer {
    addr: SocketAddr,
    runtime: tokio::runtime::Runtime,
    commands: mpsc::SyncSender<Command>,
    simulation: std::thread::JoinHandle<()>,
    stopped: mpsc::Receiver<Stopped>,
    fail_restart: Arc<AtomicBool>,
}

impl Viewer {
    /// Builds the scene's world, binds the port and starts serving; returns at once. The
    /// simulation waits, paused at t = 0, for a page's Play.
    ///
    /// ```no_run
    /// use ragdoll::{skeleton, spec, world::WorldSettings};
    /// use ragdoll::scene::Scene;
    /// use ragdoll_view::{ViewOptions, Viewer};
    ///
    /// let character = skeleton::humanoid();
    /// let spec = spec::build_spec(&character, &spec::BuildOptions::default()).unwrap();
    /// let scene = Scene::single(character, spec, "built-in", 0.0, WorldSettings::default());
    /// let viewer = Viewer::start(scene, &ViewOptions { port: 0, ..Default::default() }).unwrap();
    /// println!("open {}", viewer.url());
    /// viewer.wait().unwrap();
    /// ```
    pub fn start(scene: Scene, options: &ViewOptions) -> Result<Viewer> {
        check_save_dir(&options.save_dir)?;
        let (listener, addr) = listen(options)?;
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
        let (tx, rx) = mpsc::sync_channel(MAX_QUEUED_COMMANDS);
        let save = SaveTarget {
            dir: options.save_dir.clone(),
            stem: options.save_stem.clone(),
        };
        let session = Session::new(scene.clone(), save.clone(), outlets.clone())?;
        let app = Arc::new(server::App {
            scene_json: session.scene_message().into(),
            shape: session.shape(),
            commands: tx.clone(),
            frames: frames_rx,
            specs: specs_rx,
            notices,
            state,
            guard: guard::Guard::new(addr),
            pages: Default::default(),
            dropped: Default::default(),
        });
        let (stopped_tx, stopped) = mpsc::channel::<Stopped>();
        let fail_restart = Arc::new(AtomicBool::new(false));
        let supervisor = supervisor::Supervisor {
            original: scene,
            save,
            outlets,
            stopped: stopped_tx.clone(),
            fail_restart: fail_restart.clone(),
        };
        let simulation = spawn_simulation(supervisor, session, rx, stopped_tx.clone())?;
        let runtime = serve(listener, app, stopped_tx)?;
        Ok(Viewer {
            addr,
            runtime,
            commands: tx,
            simulation,
            stopped,
            fail_restart,
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

    /// Serves until the process is stopped (Ctrl-C). Returns an error, one sentence, when
    /// the viewer cannot go on: the server stopped, or the simulation crashed and could not
    /// be restarted.
    pub fn wait(self) -> Result<()> {
        let why = match self.stopped.recv() {
            Ok(Ok(())) => None,
            Ok(Err(why)) => Some(why),
            Err(_) => Some("the simulation thread is gone".to_string()),
        };
        let _ = self.commands.try_send(Command::Shutdown);
        self.runtime.shutdown_background();
        match why {
            None => Ok(()),
            Some(message) => Err(Error::Setting {
                setting: "viewer".into(),
                message,
            }),
        }
    }

    /// Stops the simulation and the server.
    pub fn shutdown(self) {
        let _ = self.commands.send(Command::Shutdown);
        let _ = self.simulation.join();
        self.runtime.shutdown_background();
    }

    /// **Test hook, not for pages**: makes the simulation thread panic while handling its
    /// next command, as a bug in the engine would, so tests can check it is reported and
    /// restarted. With `fail_restart`, the restart fails too, so the viewer stops and
    /// [`Viewer::wait`] returns the error. Pages cannot reach this: no message maps to it.
    #[doc(hidden)]
    pub fn inject_panic_for_tests(&self, fail_restart: bool) {
        self.fail_restart.store(fail_restart, Ordering::SeqCst);
        let _ = self.commands.send(Command::Panic);
    }
}
