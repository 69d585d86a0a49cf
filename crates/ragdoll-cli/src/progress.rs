//! Progress for work that takes more than a second (loading, building a big world,
//! stepping, encoding, drawing a preview), on stderr and only when stderr is a terminal, so
//! logs, pipes, tests and quick runs stay clean.
//!
//! A drawing thread owns the bar: the work only bumps an atomic counter, so it costs
//! nothing per step, can be bumped from rayon's workers, and a single long library call
//! (building a world of thousands of bodies) still shows a live spinner.

use std::io::IsTerminal;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// How long work runs before a bar appears.
const DELAY: Duration = Duration::from_secs(1);
/// Overrides [`DELAY`], in milliseconds: lets the tests see a bar without depending on how
/// long their work takes on the machine at hand.
const DELAY_VAR: &str = "RAGDOLL_PROGRESS_DELAY_MS";
/// How often the bar is redrawn.
const TICK: Duration = Duration::from_millis(100);

/// The stage shown: its message and its length (0: no known length, a spinner).
struct Stage {
    message: String,
    len: u64,
    /// Bumped by every [`Progress::stage`] call, so the drawer notices a new stage.
    serial: u64,
    stopped: bool,
}

struct Shared {
    done: AtomicU64,
    stage: Mutex<Stage>,
    wake: Condvar,
    /// The bar once it is shown, so output can be printed around it.
    bar: Mutex<Option<ProgressBar>>,
}

/// A progress report for one command; stages follow one another on the same line.
pub struct Progress {
    shared: Arc<Shared>,
    drawer: Option<JoinHandle<()>>,
}

impl Progress {
    /// Starts reporting `message` over `len` steps (0: a spinner). Nothing is drawn unless
    /// stderr is a terminal and the command is still running a second later.
    pub fn new(len: u64, message: &str) -> Self {
        let shared = Arc::new(Shared {
            done: AtomicU64::new(0),
            stage: Mutex::new(Stage {
                message: message.to_string(),
                len,
                serial: 0,
                stopped: false,
            }),
            wake: Condvar::new(),
            bar: Mutex::new(None),
        });
        let drawer = std::io::stderr().is_terminal().then(|| {
            let shared = Arc::clone(&shared);
            std::thread::Builder::new()
                .name("progress".into())
                .spawn(move || draw(&shared))
                .ok()
        });
        Progress {
            shared,
            drawer: drawer.flatten(),
        }
    }

    /// Moves on to the next stage: `message` over `len` steps, counted from 0.
    pub fn stage(&self, len: u64, message: &str) {
        let mut stage = lock(&self.shared.stage);
        stage.message = message.to_string();
        stage.len = len;
        stage.serial += 1;
        self.shared.done.store(0, Ordering::Relaxed);
    }

    /// Marks `pos` steps of the current stage done.
    pub fn set(&self, pos: u64) {
        self.shared.done.store(pos, Ordering::Relaxed);
    }

    /// Marks `n` more steps done (from any thread).
    pub fn inc(&self, n: u64) {
        self.shared.done.fetch_add(n, Ordering::Relaxed);
    }

    /// Runs `f` (which prints to the terminal) with the bar hidden.
    pub fn suspend<R>(&self, f: impl FnOnce() -> R) -> R {
        let bar = lock(&self.shared.bar).clone();
        match bar {
            Some(bar) => bar.suspend(f),
            None => f(),
        }
    }

    /// Removes the bar.
    pub fn finish(self) {
        drop(self);
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        lock(&self.shared.stage).stopped = true;
        self.shared.wake.notify_all();
        if let Some(drawer) = self.drawer.take() {
            let _ = drawer.join();
        }
    }
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// The drawing thread: waits [`DELAY`], then redraws every [`TICK`] until stopped.
fn draw(shared: &Shared) {
    let delay = std::env::var(DELAY_VAR)
        .ok()
        .and_then(|ms| ms.parse().ok())
        .map_or(DELAY, Duration::from_millis);
    let stage = lock(&shared.stage);
    let (stage, _) = shared
        .wake
        .wait_timeout_while(stage, delay, |s| !s.stopped)
        .unwrap_or_else(|e| e.into_inner());
    if stage.stopped {
        return;
    }
    // Styled while hidden, so the first frame drawn is already ours.
    let bar = ProgressBar::hidden();
    style(&bar, stage.len, &stage.message);
    let mut shown = Some(stage.serial);
    drop(stage);
    bar.set_draw_target(ProgressDrawTarget::stderr());
    *lock(&shared.bar) = Some(bar.clone());
    loop {
        let stage = lock(&shared.stage);
        if stage.stopped {
            break;
        }
        if shown != Some(stage.serial) {
            shown = Some(stage.serial);
            style(&bar, stage.len, &stage.message);
            bar.reset_eta();
            bar.reset_elapsed();
        }
        bar.set_position(shared.done.load(Ordering::Relaxed));
        if stage.len == 0 {
            bar.tick();
        }
        let _ = shared
            .wake
            .wait_timeout_while(stage, TICK, |s| !s.stopped)
            .unwrap_or_else(|e| e.into_inner());
    }
    *lock(&shared.bar) = None;
    bar.finish_and_clear();
}

/// Sets the bar's look for a stage, the message part of the template so that one call
/// changes both (no frame drawn with the old message in the new style).
fn style(bar: &ProgressBar, len: u64, message: &str) {
    let message = message.replace('{', "{{").replace('}', "}}");
    let template = if len > 0 {
        format!("{message} [{{bar:30}}] {{pos}}/{{len}} ({{eta}})")
    } else {
        format!("{{spinner}} {message} ({{elapsed}})")
    };
    if len > 0 {
        bar.set_length(len);
    }
    if let Ok(style) = ProgressStyle::with_template(&template) {
        bar.set_style(style.progress_chars("=> "));
    }
}
