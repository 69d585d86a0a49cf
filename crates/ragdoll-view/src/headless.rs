//! The viewer's simulation driven without a server: the fuzz target `viewer_session` feeds
//! it a page's messages through the same checks and the same session code the server uses,
//! so what it finds is in the real code, not in a copy. Not a stable API.

use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use ragdoll::scene::Scene;
use tokio::sync::{broadcast, mpsc, watch};

use crate::protocol::{ClientMsg, SceneShape, parse_client_message};
use crate::session::{Outlets, SaveTarget, Session};

/// One viewer session with nobody watching: frames, specs and notices go nowhere.
pub struct HeadlessSession {
    session: Session,
    shape: SceneShape,
    reply: mpsc::Sender<Arc<str>>,
    replies: mpsc::Receiver<Arc<str>>,
}

impl HeadlessSession {
    /// The session the viewer builds for `scene` (at time 0, paused); Save writes into
    /// `save_dir`.
    pub fn new(scene: Scene, save_dir: PathBuf) -> ragdoll::Result<Self> {
        let out = Outlets {
            frames: watch::channel(Arc::from("")).0,
            specs: watch::channel(Arc::from("")).0,
            notices: broadcast::channel(16).0,
            state: Arc::new(Mutex::new(serde_json::Value::Null)),
        };
        let save = SaveTarget {
            dir: save_dir,
            stem: "fuzz".into(),
        };
        let session = Session::new(scene, save, out)?;
        let shape = session.shape();
        let (reply, replies) = mpsc::channel(64);
        Ok(HeadlessSession {
            session,
            shape,
            reply,
            replies,
        })
    }

    /// Checks `text` as the server does and, when it passes, lets the session handle it;
    /// `false` when the checks refused it.
    pub fn message(&mut self, text: &str) -> bool {
        let Ok(msg) = parse_client_message(text, &self.shape) else {
            return false;
        };
        self.handle(msg);
        true
    }

    /// Hands a checked message to the session.
    pub fn handle(&mut self, msg: ClientMsg) {
        self.session.handle(msg, &self.reply);
        // Replies are for one page; nobody reads them here.
        while self.replies.try_recv().is_ok() {}
    }
}
