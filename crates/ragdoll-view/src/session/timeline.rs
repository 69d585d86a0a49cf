//! The recording (every step's poses, for scrubbing), the user's events, and the replay
//! that rebuilds the world up to a step. Everything here is capped: the recording by memory
//! and by replay work, the events by count, so no page can grow the server without bound.

use std::time::Instant;

use glam::Vec3;
use ragdoll::events::Blast;
use ragdoll::math::Transform;
use ragdoll::scene::Scene;

use super::Session;

/// Longest recording, steps: 5 minutes at 60 Hz (about 40 MB for the built-in humanoid,
/// its world's own track included). Every change to the past replays the world from 0 to
/// the step shown, so this also bounds how long one replay takes: measured 0.4 s for the
/// humanoid lying still, about 6 s if it never comes to rest (3,000 steps a second).
pub(crate) const MAX_STEPS: usize = 18_000;

/// Most memory the recording may take, bytes (the viewer's copy and the world's own
/// track together): scenes with many characters get fewer steps.
pub(crate) const MAX_RECORDING_BYTES: usize = 256 << 20;

/// Most body-steps one replay may simulate: the built-in humanoid (16 bodies) gets all of
/// [`MAX_STEPS`]; a scene with more bodies gets fewer steps, so its replays take no longer.
pub(crate) const MAX_BODY_STEPS: usize = 16 * MAX_STEPS;

/// Most events (blasts, drag starts, moves and ends) one timeline holds. Drag moves are
/// merged to one per step.
pub(crate) const MAX_EVENTS: usize = 10_000;

/// Most charges one timeline holds: each is tested against every body at every substep.
pub(crate) const MAX_BLASTS: usize = 100;

/// Most drags one timeline holds: each leaves a (released) pin the world keeps visiting.
pub(crate) const MAX_DRAGS: usize = 1_000;

/// Replays longer than this many steps are announced to the pages first (they freeze the
/// picture while they run).
const ANNOUNCE_REPLAY_STEPS: usize = 600;

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

/// Something the user did, replayed at the same step when the world is rebuilt.
#[derive(Clone, Debug)]
pub(super) enum UserEvent {
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

/// Every step's body poses and skeleton joint transforms, one allocation per step.
pub(super) struct Recording {
    /// Per ragdoll: where its transforms start, its body count, its joint count.
    layout: Vec<(usize, usize, usize)>,
    stride: usize,
    steps: Vec<Box<[Transform]>>,
    /// Most steps kept (the caps above, for this scene).
    pub max_steps: usize,
}

impl Recording {
    pub fn new(scene: &Scene) -> Recording {
        let mut layout = Vec::new();
        let mut at = 0;
        let (mut bodies, mut joints) = (0, 0);
        for c in &scene.characters {
            let (b, j) = (c.spec.bodies.len(), c.character.skeleton.len());
            layout.push((at, b, j));
            at += b + j;
            bodies += b;
            joints += j;
        }
        let transform = std::mem::size_of::<Transform>();
        // Ours: one boxed slice a step. The world's track: one Vec a ragdoll a step.
        let per_step = at * transform + 32 + joints * transform + 48 * layout.len();
        let max_steps = MAX_STEPS
            .min(MAX_RECORDING_BYTES / per_step.max(1))
            .min(MAX_BODY_STEPS / bodies.max(1))
            .max(1);
        Recording {
            layout,
            stride: at,
            steps: Vec::new(),
            max_steps,
        }
    }

    pub fn len(&self) -> usize {
        self.steps.len()
    }

    pub fn bodies(&self, step: usize, ragdoll: usize) -> &[Transform] {
        let (at, b, _) = self.layout[ragdoll];
        &self.steps[step][at..at + b]
    }

    pub fn joints(&self, step: usize, ragdoll: usize) -> &[Transform] {
        let (at, b, j) = self.layout[ragdoll];
        &self.steps[step][at + b..at + b + j]
    }
}

impl Session {
    /// Appends the world's current state to the recording and shows it.
    pub(super) fn record(&mut self) {
        let mut step = Vec::with_capacity(self.recording.stride);
        for (&id, &(_, b, j)) in self.ids.iter().zip(&self.recording.layout) {
            let mut poses = self.world.body_poses(id);
            poses.resize(b, Transform::default());
            step.extend(poses);
            let frame = self
                .world
                .track(id)
                .frames
                .last()
                .map_or(&[][..], Vec::as_slice);
            let n = frame.len().min(j);
            step.extend_from_slice(&frame[..n]);
            step.extend(std::iter::repeat_n(Transform::default(), j - n));
        }
        self.recording.steps.push(step.into_boxed_slice());
        self.cursor = self.recording.len() - 1;
    }

    pub(super) fn head(&self) -> usize {
        self.recording.len() - 1
    }

    /// Seconds at step `k`.
    pub(super) fn seconds(&self, k: usize) -> f64 {
        k as f64 * self.scene.settings.dt as f64
    }

    /// One live step: simulate, record, publish. Pauses at the recording's cap, and when
    /// the world has gone NaN (the picture would be nonsense from there on).
    pub(super) fn step_live(&mut self) {
        if self.recording.len() >= self.recording.max_steps {
            self.playing = false;
            let full = format!(
                "the recording is full ({:.0} s, the most this scene may keep); scrub back or reset to go on",
                self.seconds(self.head())
            );
            self.notice("info", &full);
            self.publish();
            return;
        }
        self.world.step();
        self.record();
        if self.world.metrics().nan && !self.nan_reported {
            self.nan_reported = true;
            self.playing = false;
            self.notice(
                "error",
                "the simulation produced NaN (an edit made it unstable?): paused; reset or scrub back",
            );
        }
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

    /// Why the timeline cannot take `event`, if it cannot (counting what a branch at the
    /// shown step keeps). Drag ends always fit: there are no more of them than drag starts.
    fn over_cap(&self, event: &UserEvent) -> Option<String> {
        let (mut all, mut blasts, mut drags) = (0, 0, 0);
        for (_, e) in self.events.iter().filter(|(k, _)| *k <= self.cursor) {
            all += 1;
            match e {
                UserEvent::Blast(_) => blasts += 1,
                UserEvent::DragStart { .. } => drags += 1,
                _ => {}
            }
        }
        let (what, cap) = match event {
            UserEvent::DragEnd => return None,
            UserEvent::Blast(_) if blasts >= MAX_BLASTS => ("charges", MAX_BLASTS),
            UserEvent::DragStart { .. } if drags >= MAX_DRAGS => ("drags", MAX_DRAGS),
            _ if all >= MAX_EVENTS => ("actions", MAX_EVENTS),
            _ => return None,
        };
        Some(format!(
            "this timeline holds the most {what} it may ({cap}): scrub back to before some of them, or reset"
        ))
    }

    /// Records and applies a user event at the shown step, branching the timeline there
    /// first when scrubbed back.
    pub(super) fn add_event(&mut self, event: UserEvent) {
        // A drag move replaces the one before it at the same step: only the last target of
        // a step matters, and a fast mouse must not fill the timeline.
        if let UserEvent::DragMove(target) = event
            && self.cursor == self.head()
            && let Some((k, UserEvent::DragMove(last))) = self.events.last_mut()
            && *k == self.cursor
        {
            *last = target;
            if let Err(e) = self.apply(&event) {
                self.notice("error", &e.to_string());
            }
            return;
        }
        if let Some(why) = self.over_cap(&event) {
            self.notice("error", &why);
            return;
        }
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
    pub(super) fn rebuild_to(&mut self, target: usize) -> ragdoll::Result<()> {
        let started = Instant::now();
        if target >= ANNOUNCE_REPLAY_STEPS {
            let msg = format!("re-simulating from 0 to {:.1} s…", self.seconds(target));
            self.notice("progress", &msg);
        }
        let (mut world, ids) = self.scene.build_world()?;
        world.run(0.0);
        self.world = world;
        self.ids = ids;
        self.drag = None;
        self.nan_reported = false;
        self.recording.steps.clear();
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
        if target >= ANNOUNCE_REPLAY_STEPS {
            let msg = format!(
                "re-simulated to {:.1} s in {:.1} s",
                self.seconds(target),
                started.elapsed().as_secs_f64()
            );
            self.notice("info", &msg);
        }
        Ok(())
    }
}
