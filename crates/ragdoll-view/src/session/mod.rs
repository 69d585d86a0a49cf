//! The simulation side of the viewer: one thread owns the [`World`] (it is not `Sync`, and
//! stepping it from one place keeps it deterministic), steps it in real time, applies what
//! the pages ask for, records every step, and publishes frames and the state.
//!
//! **Start.** The world is built at t = 0 and waits, paused, for a page's Play. A page that
//! connects starts it over from the file (specs, backend, no events); Reset does the same
//! but keeps the backend chosen.
//!
//! **Timeline** (`timeline.rs`). Every step's body poses and joint transforms are kept, so
//! scrubbing shows the past exactly, up to a cap on memory and replay work. What the user
//! adds (blasts, drags) is kept as a list of events, each with the step it was applied at.
//! Anything that changes the past — playing or adding an event after scrubbing back, or
//! editing a body — rebuilds the world from the scene (with the edited specs) and
//! re-simulates from time 0 up to the shown step, applying the kept events at their steps;
//! events after the shown step are dropped (the timeline branches). The world is
//! deterministic, so an unedited replay reproduces the recording bit for bit.
//!
//! **Edits** (`edits.rs`: shape, offset, mass, joint limits) are never applied to the
//! running bodies: rapier would need colliders and joints rebuilt anyway, and replaying
//! keeps the recording consistent with the spec that made it. Each edited spec must pass
//! the library's validation and the viewer's own bounds, relative to the file's ragdoll.

mod edits;
mod publish;
mod timeline;

use std::path::PathBuf;
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use glam::Vec3;
use ragdoll::events::Blast;
use ragdoll::scene::Scene;
use ragdoll::spec::RagdollSpec;
use ragdoll::world::{DragId, RagdollId, World, WorldSettings};
use tokio::sync::{broadcast, mpsc, oneshot, watch};

use crate::log::LogLimit;
use crate::protocol::{BackendChoice, ClientMsg, SceneShape};
use edits::EditBounds;
use timeline::{Recording, UserEvent};

/// What the server's tasks send to the simulation thread.
pub(crate) enum Command {
    /// A checked message from a page, with the way back to that page alone.
    Client {
        msg: ClientMsg,
        reply: mpsc::Sender<Arc<str>>,
    },
    /// A page connected: start over from the file, then say so.
    Connected(oneshot::Sender<()>),
    /// Stop the thread.
    Shutdown,
    /// Test hook ([`crate::Viewer::inject_panic_for_tests`]): panic, as a bug would.
    Panic,
}

/// Where the simulation publishes what pages see; shared with the web tasks.
#[derive(Clone)]
pub(crate) struct Outlets {
    /// The latest frame, as JSON text (a slow page skips frames instead of queueing them).
    pub frames: watch::Sender<Arc<str>>,
    /// The latest `specs` message, as JSON text (sent on connect and after every edit).
    pub specs: watch::Sender<Arc<str>>,
    /// Notices (errors, saved files) for every page.
    pub notices: broadcast::Sender<Arc<str>>,
    /// The state `GET /api/state` returns.
    pub state: Arc<Mutex<serde_json::Value>>,
}

/// Where Save writes: the folder, and the file stem.
#[derive(Clone, Debug)]
pub(crate) struct SaveTarget {
    pub dir: PathBuf,
    pub stem: String,
}

/// The simulation and its recording.
pub(crate) struct Session {
    /// The scene being simulated: the file's, with the edits and the backend chosen.
    scene: Scene,
    /// The file's specs and settings: what Reset and a new page go back to.
    original_specs: Vec<RagdollSpec>,
    original_settings: WorldSettings,
    /// Per ragdoll, how far edits may go.
    bounds: Vec<EditBounds>,
    save: SaveTarget,
    world: World,
    ids: Vec<RagdollId>,
    /// `(step, event)` in the order applied.
    events: Vec<(usize, UserEvent)>,
    drag: Option<DragId>,
    recording: Recording,
    /// The step shown (the last one unless scrubbed back).
    cursor: usize,
    playing: bool,
    backend: BackendChoice,
    /// Whether the page was told the world went NaN (once per rebuild).
    nan_reported: bool,
    out: Outlets,
    log: LogLimit,
    /// Per ragdoll, the inverse of each joint's rest (bind) matrix: a joint's skinning
    /// matrix is its world matrix now times this. Matrices, not rigid transforms, because
    /// glTF joints may carry scale (Fox's do).
    rest_inverse: Vec<Vec<glam::Mat4>>,
}

/// The viewer's world settings: one track frame per step, so every step has its joint
/// transforms for skinning.
pub(crate) fn viewer_settings(settings: &WorldSettings) -> WorldSettings {
    WorldSettings {
        fps: 1.0 / settings.dt,
        ..settings.clone()
    }
}

fn backend_of(settings: &WorldSettings) -> BackendChoice {
    settings.backend.kind()
}

impl Session {
    /// Builds the world at time 0, paused, and publishes the first frame and the specs.
    pub fn new(mut scene: Scene, save: SaveTarget, out: Outlets) -> ragdoll::Result<Session> {
        scene.settings = viewer_settings(&scene.settings);
        let (mut world, ids) = scene.build_world()?;
        world.run(0.0);
        let rest_inverse = scene
            .characters
            .iter()
            .map(|c| {
                c.character
                    .skeleton
                    .rest_world()
                    .iter()
                    .map(|t| t.to_mat4().inverse())
                    .collect()
            })
            .collect();
        let mut s = Session {
            rest_inverse,
            original_specs: scene.characters.iter().map(|c| c.spec.clone()).collect(),
            original_settings: scene.settings.clone(),
            bounds: scene
                .characters
                .iter()
                .map(|c| EditBounds::of(&c.spec))
                .collect(),
            recording: Recording::new(&scene),
            backend: backend_of(&scene.settings),
            scene,
            save,
            world,
            ids,
            events: Vec::new(),
            drag: None,
            cursor: 0,
            playing: false,
            nan_reported: false,
            out,
            log: LogLimit::default(),
        };
        s.record();
        s.publish_specs();
        s.publish();
        Ok(s)
    }

    /// Body and joint counts, for checking messages.
    pub fn shape(&self) -> SceneShape {
        SceneShape {
            bodies: self
                .scene
                .characters
                .iter()
                .map(|c| c.spec.bodies.len())
                .collect(),
            joints: self
                .scene
                .characters
                .iter()
                .map(|c| c.spec.joints.len())
                .collect(),
        }
    }

    /// Back to the file's specs at t = 0, paused, with no events; the file's backend too
    /// when `backend` is `false`.
    fn start_over(&mut self, keep_backend: bool) {
        for (c, spec) in self.scene.characters.iter_mut().zip(&self.original_specs) {
            c.spec = spec.clone();
        }
        if !keep_backend {
            self.scene.settings = self.original_settings.clone();
            self.backend = backend_of(&self.scene.settings);
        }
        self.events.clear();
        self.playing = false;
        if let Err(e) = self.rebuild_to(0) {
            self.notice("error", &format!("could not rebuild the world: {e}"));
        }
        self.publish_specs();
    }

    /// Handles one checked message from a page; `reply` reaches that page alone.
    pub fn handle(&mut self, msg: ClientMsg, reply: &mpsc::Sender<Arc<str>>) {
        match msg {
            ClientMsg::Play {} => {
                if self.cursor < self.head() {
                    let at = self.cursor;
                    if let Err(e) = self.rebuild_to(at) {
                        self.notice("error", &format!("could not rebuild the world: {e}"));
                    }
                }
                self.playing = true;
            }
            ClientMsg::Pause {} => self.playing = false,
            ClientMsg::Step {} => {
                self.playing = false;
                if self.cursor < self.head() {
                    self.cursor += 1;
                } else {
                    self.step_live();
                }
            }
            ClientMsg::Reset {} => self.start_over(true),
            ClientMsg::Scrub { time_s } => {
                self.playing = false;
                let k = (time_s / self.scene.settings.dt as f64).round() as usize;
                self.cursor = k.min(self.head());
            }
            ClientMsg::DragStart {
                ragdoll,
                body,
                local,
                target,
            } => self.add_event(UserEvent::DragStart {
                ragdoll,
                body,
                local: Vec3::from_array(local),
                target: Vec3::from_array(target),
            }),
            ClientMsg::DragMove { target } => {
                if self.drag.is_some() {
                    self.add_event(UserEvent::DragMove(Vec3::from_array(target)));
                }
            }
            ClientMsg::DragEnd {} => {
                if self.drag.is_some() {
                    self.add_event(UserEvent::DragEnd);
                }
            }
            ClientMsg::Blast {
                position,
                tnt_kg,
                delay_s,
            } => {
                let time = (self.cursor as f64 * self.scene.settings.dt as f64) as f32 + delay_s;
                self.add_event(UserEvent::Blast(Blast::new(
                    tnt_kg,
                    Vec3::from_array(position),
                    time,
                )));
            }
            ClientMsg::EditBody {
                ragdoll,
                body,
                radius_m,
                length_m,
                center_m,
                mass_kg,
            } => self.edit_body(ragdoll, body, radius_m, length_m, center_m, mass_kg),
            ClientMsg::EditJoint {
                ragdoll,
                joint,
                min_deg,
                max_deg,
                swing_deg,
                twist_deg,
            } => self.edit_joint(ragdoll, joint, min_deg, max_deg, swing_deg, twist_deg),
            ClientMsg::Save { overwrite } => self.save(overwrite, reply),
            ClientMsg::Backend { kind } => self.switch_backend(kind),
        }
        self.publish();
    }

    /// Rebuilds and replays the world on the backend asked for; the old one stays when
    /// that fails.
    fn switch_backend(&mut self, kind: BackendChoice) {
        if kind == self.backend {
            return;
        }
        let mut settings = self.scene.settings.clone();
        // Another engine starts at its defaults: the file's settings were for its own.
        settings.backend = kind.into();
        let old = std::mem::replace(&mut self.scene.settings, settings);
        let old_backend = std::mem::replace(&mut self.backend, kind);
        let at = self.cursor;
        if let Err(e) = self.rebuild_to(at) {
            self.scene.settings = old;
            self.backend = old_backend;
            self.notice("error", &format!("could not switch backend: {e}"));
            let _ = self.rebuild_to(at);
        }
        // Tell the pages which backend runs now.
        self.publish_specs();
    }

    /// Runs until told to stop (or every sender is gone): steps in real time while
    /// playing, handles commands as they come.
    pub fn run(&mut self, rx: &Receiver<Command>) {
        let dt = Duration::from_secs_f64(self.scene.settings.dt as f64);
        let mut next = Instant::now();
        let mut was_playing = self.playing;
        loop {
            let wait = if self.playing {
                next.saturating_duration_since(Instant::now())
            } else {
                Duration::from_millis(250)
            };
            match rx.recv_timeout(wait) {
                Ok(Command::Client { msg, reply }) => self.handle(msg, &reply),
                Ok(Command::Connected(done)) => {
                    self.start_over(false);
                    self.publish();
                    self.notice(
                        "info",
                        "a page connected: the simulation started over from the file",
                    );
                    let _ = done.send(());
                }
                Ok(Command::Panic) => panic!("a panic injected by a test"),
                Ok(Command::Shutdown) | Err(RecvTimeoutError::Disconnected) => return,
                Err(RecvTimeoutError::Timeout) => {}
            }
            if self.playing && !was_playing {
                next = Instant::now();
            }
            was_playing = self.playing;
            if self.playing && Instant::now() >= next {
                self.step_live();
                next += dt;
                // Behind by more than a few frames (a slow machine, a long replay): drop
                // the backlog instead of racing to catch up.
                let now = Instant::now();
                if now > next + 4 * dt {
                    next = now;
                }
            }
        }
    }
}
