//! Keeps the simulation alive: runs the session, and when it panics (a bug in the engine
//! or in the session, never expected), reports it in the log and to every page and starts
//! a new session from the file's scene. If that fails too, the viewer stops with the
//! reason, and `ragdoll view` exits non-zero.

use std::any::Any;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, Sender};

use ragdoll::scene::Scene;

use crate::Stopped;
use crate::session::{Command, Outlets, SaveTarget, Session};

pub(crate) struct Supervisor {
    /// The scene as the file describes it: what a restart starts from.
    pub original: Scene,
    pub save: SaveTarget,
    pub outlets: Outlets,
    pub stopped: Sender<Stopped>,
    /// Test hook ([`crate::Viewer::inject_panic_for_tests`]): the next restart fails.
    pub fail_restart: Arc<AtomicBool>,
}

/// The text a panic carried, for the log line and the page.
fn panic_message(payload: &(dyn Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "no message".to_string()
    }
}

impl Supervisor {
    /// Runs `session` until shut down, restarting it after each panic.
    pub fn run(self, mut session: Session, rx: Receiver<Command>) {
        loop {
            let ran = catch_unwind(AssertUnwindSafe(|| session.run(&rx)));
            let payload = match ran {
                Ok(()) => {
                    let _ = self.stopped.send(Ok(()));
                    return;
                }
                Err(payload) => payload,
            };
            let why = panic_message(payload.as_ref());
            let restarted = catch_unwind(AssertUnwindSafe(|| {
                if self.fail_restart.load(Ordering::SeqCst) {
                    panic!("the restart failed (test hook)");
                }
                Session::new(
                    self.original.clone(),
                    self.save.clone(),
                    self.outlets.clone(),
                )
            }));
            match restarted {
                Ok(Ok(fresh)) => {
                    session = fresh;
                    session.notice(
                        "error",
                        &format!(
                            "the simulation crashed ({why}); it was restarted from the file, paused at t = 0: edits and events are lost"
                        ),
                    );
                }
                Ok(Err(e)) => return self.give_up(&why, &e.to_string()),
                Err(again) => return self.give_up(&why, &panic_message(again.as_ref())),
            }
        }
    }

    fn give_up(&self, why: &str, restart: &str) {
        let message = format!(
            "the simulation crashed ({why}) and could not be restarted ({restart}); the viewer stops"
        );
        Session::notice_with(&self.outlets, "error", &message);
        let _ = self.stopped.send(Err(message));
    }
}
