//! The simulation side of the viewer: one thread owns the [`World`] (it is not `Sync`, and
//! stepping it from one place keeps it deterministic), steps it in real time, applies what
//! the pages ask for, records every step, and publishes frames and the state.
//!
//! **Timeline.** Every step's body poses and joint transforms are kept, so scrubbing shows
//! the past exactly. What the user adds (blasts, drags) is kept as a list of events, each
//! with the step it was applied at. Anything that changes the past — playing or adding an
//! event after scrubbing back, or editing a body — rebuilds the world from the scene (with
//! the edited specs) and re-simulates from time 0 up to the shown step, applying the kept
//! events at their steps; events after the shown step are dropped (the timeline branches).
//! The world is deterministic, so an unedited replay reproduces the recording bit for bit.
//!
//! **Edits** (shape, offset, mass, joint limits) are never applied to the running bodies:
//! rapier would need colliders and joints rebuilt anyway, and replaying keeps the
//! recording consistent with the spec that made it.

use std::path::PathBuf;
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use glam::Vec3;
use ragdoll::events::Blast;
use ragdoll::math::Transform;
use ragdoll::scene::Scene;
use ragdoll::spec::{JointKind, Resolved, Shape};
use ragdoll::world::{DragId, RagdollId, World, WorldSettings};
use serde::Serialize;
use serde_json::json;
use tokio::sync::{broadcast, watch};

use crate::protocol::{BackendChoice, ClientMsg, SceneShape};

/// Longest recording kept, steps (10 minutes at 60 Hz, a few tens of MB): past it the
/// simulation pauses rather than grow without bound.
const MAX_STEPS: usize = 36_000;

/// Stiffness of the mouse's soft pin on a heavy part (10 kg and up), Hz: firm enough that
/// it follows the mouse within a few frames, soft enough that the rest of the body is
/// pulled, not yanked.
const DRAG_STIFFNESS_HZ: f32 = 3.0;

/// Stiffest the mouse's pin gets on a light part, Hz. The pin's force is the part's own
/// mass times its acceleration, so at 3 Hz a 0.5 kg hand pulls with under 100 N and cannot
/// lift its arm off the floor; lighter parts get a higher frequency (as √(10 kg / mass)),
/// up to this, where one collision substep (1/240 s) is still a small fraction of a period.
const DRAG_MAX_STIFFNESS_HZ: f32 = 12.0;

/// The mouse pin's frequency for a part of `mass_kg`.
fn drag_stiffness_hz(mass_kg: f32) -> f32 {
    (DRAG_STIFFNESS_HZ * (10.0 / mass_kg.max(1e-3)).sqrt())
        .clamp(DRAG_STIFFNESS_HZ, DRAG_MAX_STIFFNESS_HZ)
}

/// Damping ratio of the mouse's pin: critical, so a dragged part does not bounce.
const DRAG_DAMPING: f32 = 1.0;

/// What the server's tasks send to the simulation thread.
pub(crate) enum Command {
    /// A checked message from a page.
    Client(ClientMsg),
    /// Stop the thread.
    Shutdown,
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

/// One recorded step: per ragdoll, body poses and skeleton joint world transforms.
struct Snapshot {
    bodies: Vec<Vec<Transform>>,
    joints: Vec<Vec<Transform>>,
}

/// Something the user did, replayed at the same step when the world is rebuilt.
#[derive(Clone, Debug)]
enum UserEvent {
    Blast(Blast),
    DragStart {
        ragdoll: usize,
        body: usize,
        local: Vec3,
        target: Vec3,
    },
    DragMove(Vec3),
    DragEnd,
}

/// The simulation and its recording.
pub(crate) struct Session {
    scene: Scene,
    /// Where `save` writes, and the file stem it uses.
    save_dir: PathBuf,
    save_stem: String,
    world: World,
    ids: Vec<RagdollId>,
    /// `(step, event)` in the order applied.
    events: Vec<(usize, UserEvent)>,
    drag: Option<DragId>,
    /// `history[k]` is the state after `k` steps.
    history: Vec<Snapshot>,
    /// The step shown (the last one unless scrubbed back).
    cursor: usize,
    playing: bool,
    backend: BackendChoice,
    out: Outlets,
    /// Per ragdoll, the inverse of each joint's rest (bind) matrix: a joint's skinning
    /// matrix is its world matrix now times this. Matrices, not rigid transforms, because
    /// glTF joints may carry scale (Fox's do).
    rest_inverse: Vec<Vec<glam::Mat4>>,
}

/// Converts a transform to `[tx, ty, tz, qx, qy, qz, qw]`, the layout the page reads.
fn push_transform(out: &mut Vec<f32>, t: &Transform) {
    out.extend_from_slice(&t.translation.to_array());
    out.extend_from_slice(&t.rotation.to_array());
}

/// The viewer's world settings: one track frame per step, so every step has its joint
/// transforms for skinning.
pub(crate) fn viewer_settings(settings: &WorldSettings) -> WorldSettings {
    WorldSettings {
        fps: 1.0 / settings.dt,
        ..settings.clone()
    }
}

/// The backend a page asks for, applied to the world's settings; the session then rebuilds
/// and replays the world on the new backend like any other change.
pub(crate) fn apply_backend(
    settings: &mut WorldSettings,
    kind: BackendChoice,
) -> Result<(), String> {
    settings.backend = match kind {
        BackendChoice::Rigid => ragdoll::world::BackendKind::Rigid,
        BackendChoice::Particle => ragdoll::world::BackendKind::Particle,
    };
    Ok(())
}

impl Session {
    /// Builds the world at time 0 and publishes the first frame and the specs.
    pub fn new(
        mut scene: Scene,
        save_dir: PathBuf,
        save_stem: String,
        out: Outlets,
    ) -> ragdoll::Result<Session> {
        scene.settings = viewer_settings(&scene.settings);
        let backend = match scene.settings.backend {
            ragdoll::world::BackendKind::Rigid => BackendChoice::Rigid,
            ragdoll::world::BackendKind::Particle => BackendChoice::Particle,
        };
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
            scene,
            save_dir,
            save_stem,
            world,
            ids,
            events: Vec::new(),
            drag: None,
            history: Vec::new(),
            cursor: 0,
            playing: true,
            backend,
            out,
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

    /// The `scene` message: what never changes (skeletons, rest poses, skinned meshes).
    pub fn scene_message(&self) -> String {
        #[derive(Serialize)]
        struct Mesh<'a> {
            name: &'a str,
            positions: Vec<f32>,
            normals: Vec<f32>,
            indices: &'a [u32],
            joints: Vec<u16>,
            weights: Vec<f32>,
        }
        let ragdolls: Vec<serde_json::Value> = self
            .scene
            .characters
            .iter()
            .map(|c| {
                let sk = &c.character.skeleton;
                let meshes: Vec<Mesh> = c
                    .character
                    .meshes
                    .iter()
                    .filter(|m| m.joints.len() == m.positions.len())
                    .map(|m| Mesh {
                        name: &m.name,
                        positions: m.positions.iter().flat_map(|p| p.to_array()).collect(),
                        normals: if m.normals.len() == m.positions.len() {
                            m.normals.iter().flat_map(|n| n.to_array()).collect()
                        } else {
                            Vec::new()
                        },
                        indices: &m.indices,
                        joints: m.joints.iter().flatten().copied().collect(),
                        weights: m.weights.iter().flat_map(|w| w.to_array()).collect(),
                    })
                    .collect();
                let parents: Vec<i64> = (0..sk.len())
                    .map(|j| sk.parent(j).map_or(-1, |p| p as i64))
                    .collect();
                // The meshes are skinned into the rest pose before the character is
                // placed; frames carry each joint's joint_now · rest⁻¹ (placement
                // included), which the page's vertex shader blends.
                json!({
                    "name": c.name,
                    "parents": parents,
                    "meshes": meshes,
                })
            })
            .collect();
        json!({
            "type": "scene",
            "dt": self.scene.settings.dt,
            "ground": self.scene.settings.ground,
            "ragdolls": ragdolls,
        })
        .to_string()
    }

    /// Publishes the `specs` message: every ragdoll's spec, which bone carries each body,
    /// and each joint's frames in its bodies (for the limit overlays).
    fn publish_specs(&self) {
        let ragdolls: Vec<serde_json::Value> = self
            .scene
            .characters
            .iter()
            .map(|c| {
                let (bones, joints) = match Resolved::new(&c.spec, &c.character) {
                    Ok(r) => {
                        let joints: Vec<serde_json::Value> = r
                            .joints
                            .iter()
                            .map(|j| {
                                let (mut fp, mut fc) = (Vec::new(), Vec::new());
                                push_transform(&mut fp, &j.frame_parent);
                                push_transform(&mut fc, &j.frame_child);
                                json!({"parent": j.parent, "child": j.child,
                                       "frame_parent": fp, "frame_child": fc})
                            })
                            .collect();
                        (r.bone_of_body, joints)
                    }
                    Err(_) => (Vec::new(), Vec::new()),
                };
                json!({"spec": c.spec, "body_bones": bones, "joint_frames": joints})
            })
            .collect();
        let msg = json!({
            "type": "specs",
            "backend": self.backend,
            "ragdolls": ragdolls,
        });
        self.out.specs.send_replace(msg.to_string().into());
    }

    fn notice(&self, level: &str, message: &str) {
        eprintln!("viewer: {message}");
        let msg = json!({"type": "notice", "level": level, "message": message});
        let _ = self.out.notices.send(msg.to_string().into());
    }

    /// Appends the world's current state to the recording.
    fn record(&mut self) {
        let bodies = self
            .ids
            .iter()
            .map(|&id| self.world.body_poses(id))
            .collect();
        let joints = self
            .ids
            .iter()
            .map(|&id| {
                self.world
                    .track(id)
                    .frames
                    .last()
                    .cloned()
                    .unwrap_or_default()
            })
            .collect();
        self.history.push(Snapshot { bodies, joints });
        self.cursor = self.history.len() - 1;
    }

    fn head(&self) -> usize {
        self.history.len() - 1
    }

    /// Sends the shown step to the pages and updates the state endpoint.
    fn publish(&self) {
        let snap = &self.history[self.cursor];
        let dt = self.scene.settings.dt as f64;
        let t = self.cursor as f64 * dt;
        let ragdolls: Vec<serde_json::Value> = snap
            .bodies
            .iter()
            .zip(&snap.joints)
            .zip(&self.rest_inverse)
            .map(|((b, j), rest_inverse)| {
                let mut bodies = Vec::new();
                b.iter().for_each(|t| push_transform(&mut bodies, t));
                let skin: Vec<f32> = j
                    .iter()
                    .zip(rest_inverse)
                    .flat_map(|(t, inv)| (t.to_mat4() * *inv).to_cols_array())
                    .collect();
                json!({"bodies": bodies, "skin": skin})
            })
            .collect();
        let frame = json!({
            "type": "frame",
            "t": t,
            "step": self.cursor,
            "head_t": self.head() as f64 * dt,
            "playing": self.playing,
            "ragdolls": ragdolls,
        });
        self.out.frames.send_replace(frame.to_string().into());
        let state_ragdolls: Vec<serde_json::Value> = self
            .scene
            .characters
            .iter()
            .zip(&snap.bodies)
            .map(|(c, poses)| {
                let total: f32 = c.spec.bodies.iter().map(|b| b.mass_kg).sum();
                let com = c
                    .spec
                    .bodies
                    .iter()
                    .zip(poses)
                    .fold(Vec3::ZERO, |acc, (b, p)| acc + p.translation * b.mass_kg)
                    / total.max(1e-9);
                let bodies: Vec<serde_json::Value> = c
                    .spec
                    .bodies
                    .iter()
                    .zip(poses)
                    .map(|(b, p)| json!({"name": b.name, "position": p.translation.to_array()}))
                    .collect();
                json!({"name": c.name, "centre_of_mass": com.to_array(), "bodies": bodies})
            })
            .collect();
        let state = json!({
            "time_s": t,
            "head_time_s": self.head() as f64 * dt,
            "step": self.cursor,
            "playing": self.playing,
            "backend": self.backend,
            "events": self.events.len(),
            "dragging": self.drag.is_some(),
            "ragdolls": state_ragdolls,
        });
        if let Ok(mut s) = self.out.state.lock() {
            *s = state;
        }
    }

    /// One live step: simulate, record, publish.
    fn step_live(&mut self) {
        if self.head() >= MAX_STEPS {
            self.playing = false;
            self.notice(
                "info",
                "the recording is full (10 minutes); scrub back or reset to go on",
            );
            self.publish();
            return;
        }
        self.world.step();
        self.record();
        self.publish();
    }

    /// Applies one user event to the live world (at the head).
    fn apply(&mut self, event: &UserEvent) -> ragdoll::Result<()> {
        match *event {
            UserEvent::Blast(b) => self.world.add_blast(b),
            UserEvent::DragStart {
                ragdoll,
                body,
                local,
                target,
            } => {
                if let Some(d) = self.drag.take() {
                    self.world.drag_end(d);
                }
                let mass = self.scene.characters[ragdoll]
                    .spec
                    .bodies
                    .get(body)
                    .map_or(1.0, |b| b.mass_kg);
                let d = self.world.drag_start(
                    self.ids[ragdoll],
                    body,
                    local,
                    target,
                    drag_stiffness_hz(mass),
                    DRAG_DAMPING,
                )?;
                self.drag = Some(d);
                Ok(())
            }
            UserEvent::DragMove(target) => match self.drag {
                Some(d) => self.world.drag_move(d, target),
                None => Ok(()),
            },
            UserEvent::DragEnd => {
                if let Some(d) = self.drag.take() {
                    self.world.drag_end(d);
                }
                Ok(())
            }
        }
    }

    /// Records and applies a user event at the shown step, branching the timeline there
    /// first when scrubbed back.
    fn add_event(&mut self, event: UserEvent) {
        if self.cursor < self.head() {
            let at = self.cursor;
            if let Err(e) = self.rebuild_to(at) {
                self.notice("error", &format!("could not rebuild the world: {e}"));
                return;
            }
        }
        match self.apply(&event) {
            Ok(()) => self.events.push((self.head(), event)),
            Err(e) => self.notice("error", &e.to_string()),
        }
    }

    /// Rebuilds the world from the scene and re-simulates to step `target`, applying the
    /// kept events at their steps; events after `target` are dropped, and a drag still
    /// held there is let go.
    fn rebuild_to(&mut self, target: usize) -> ragdoll::Result<()> {
        let (mut world, ids) = self.scene.build_world()?;
        world.run(0.0);
        self.world = world;
        self.ids = ids;
        self.drag = None;
        self.history.clear();
        self.record();
        self.events.retain(|(k, _)| *k <= target);
        let events = std::mem::take(&mut self.events);
        let mut next = 0;
        for k in 0..=target {
            while next < events.len() && events[next].0 == k {
                // Kept events were valid when first applied and are applied to the same
                // state again, so they cannot fail now; if one did, it is dropped.
                let _ = self.apply(&events[next].1);
                next += 1;
            }
            if k < target {
                self.world.step();
                self.record();
            }
        }
        self.events = events;
        if self.drag.is_some() {
            self.apply(&UserEvent::DragEnd)?;
            self.events.push((target, UserEvent::DragEnd));
        }
        Ok(())
    }

    /// Handles one checked message from a page.
    pub fn handle(&mut self, msg: ClientMsg) {
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
            ClientMsg::Reset {} => {
                self.events.clear();
                if let Err(e) = self.rebuild_to(0) {
                    self.notice("error", &format!("could not rebuild the world: {e}"));
                }
            }
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
            } => {
                let mut spec = self.scene.characters[ragdoll].spec.clone();
                let b = &mut spec.bodies[body];
                b.shape = match b.shape {
                    Shape::Capsule { .. } => Shape::Capsule { radius_m, length_m },
                    Shape::Box { size_m } => Shape::Box {
                        size_m: [size_m[0], length_m, size_m[2]],
                    },
                };
                b.center_m = center_m;
                b.mass_kg = mass_kg;
                self.edit(ragdoll, spec);
            }
            ClientMsg::EditJoint {
                ragdoll,
                joint,
                min_deg,
                max_deg,
                swing_deg,
                twist_deg,
            } => {
                let mut spec = self.scene.characters[ragdoll].spec.clone();
                let j = &mut spec.joints[joint];
                j.kind = match (j.kind, min_deg, max_deg, swing_deg, twist_deg) {
                    (JointKind::Hinge { .. }, Some(min_deg), Some(max_deg), ..) => {
                        JointKind::Hinge { min_deg, max_deg }
                    }
                    (
                        JointKind::SwingTwist { cone_tilt_deg, .. },
                        _,
                        _,
                        Some(swing_deg),
                        Some(twist_deg),
                    ) => JointKind::SwingTwist {
                        swing_deg,
                        twist_deg,
                        cone_tilt_deg,
                    },
                    _ => {
                        let msg = format!(
                            "joint \"{}\" is not of the kind this edit is for; nothing changed",
                            j.name
                        );
                        self.notice("error", &msg);
                        return;
                    }
                };
                self.edit(ragdoll, spec);
            }
            ClientMsg::Save {} => self.save(),
            ClientMsg::Backend { kind } => {
                let mut settings = self.scene.settings.clone();
                match apply_backend(&mut settings, kind) {
                    Ok(()) if kind == self.backend => {}
                    Ok(()) => {
                        let old = std::mem::replace(&mut self.scene.settings, settings);
                        let at = self.cursor;
                        self.backend = kind;
                        if let Err(e) = self.rebuild_to(at) {
                            self.scene.settings = old;
                            self.notice("error", &format!("could not switch backend: {e}"));
                        }
                        self.publish_specs();
                    }
                    Err(e) => {
                        self.notice("error", &e);
                        // Tell the page which backend is still running.
                        self.publish_specs();
                    }
                }
            }
        }
        self.publish();
    }

    /// Replaces ragdoll `ragdoll`'s spec, rebuilding and replaying to the shown step; an
    /// edit the library refuses (a spec that does not validate) changes nothing.
    fn edit(&mut self, ragdoll: usize, spec: ragdoll::spec::RagdollSpec) {
        if let Err(e) = spec.validate() {
            self.notice("error", &format!("edit refused: {e}"));
            return;
        }
        let old = std::mem::replace(&mut self.scene.characters[ragdoll].spec, spec);
        let at = self.cursor;
        if let Err(e) = self.rebuild_to(at) {
            self.scene.characters[ragdoll].spec = old;
            self.notice("error", &format!("edit refused: {e}"));
            let _ = self.rebuild_to(at);
        }
        self.publish_specs();
    }

    /// Writes every ragdoll's (edited) spec as TOML into the save folder, one file per
    /// character, atomically. The file names come from the input's name and the
    /// characters' names with anything but letters, digits, `-` and `_` replaced, so
    /// nothing the page sends ends up in a path.
    fn save(&self) {
        let clean = |s: &str| -> String {
            s.chars()
                .map(|c| {
                    if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                        c
                    } else {
                        '_'
                    }
                })
                .collect()
        };
        let many = self.scene.characters.len() > 1;
        let mut written = Vec::new();
        for c in &self.scene.characters {
            let name = if many {
                format!("{}.{}.spec.toml", clean(&self.save_stem), clean(&c.name))
            } else {
                format!("{}.spec.toml", clean(&self.save_stem))
            };
            let path = self.save_dir.join(name);
            match ragdoll::export::write_atomic(&path, c.spec.to_toml().as_bytes()) {
                Ok(()) => written.push(path.display().to_string()),
                Err(e) => {
                    self.notice("error", &format!("could not save: {e}"));
                    return;
                }
            }
        }
        self.notice("info", &format!("saved {}", written.join(", ")));
    }

    /// Runs until told to stop (or every sender is gone): steps in real time while
    /// playing, handles commands as they come.
    pub fn run(mut self, rx: Receiver<Command>) {
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
                Ok(Command::Client(msg)) => self.handle(msg),
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
