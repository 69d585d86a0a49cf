//! The web side: the embedded page, the state endpoint and one WebSocket per page. Every
//! request passes [`crate::guard`] first; every message a page sends is checked here
//! ([`crate::protocol::parse_client_message`]) and rate-limited before it reaches the
//! simulation thread; a bad one is logged and dropped, the connection kept.

use std::net::SocketAddr;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc::{SyncSender, TrySendError};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

use axum::Router;
use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::{ConnectInfo, State};
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use tokio::sync::{broadcast, mpsc, oneshot, watch};

use crate::guard::Guard;
use crate::log::LogLimit;
use crate::protocol::{MAX_MESSAGE_BYTES, SceneShape, parse_client_message};
use crate::session::Command;

/// The page and its script, compiled into the binary so `ragdoll view` needs no files
/// beside it and no build step.
const INDEX_HTML: &str = include_str!("../web/index.html");
const VIEWER_JS: &str = include_str!("../web/viewer.js");

/// Messages past this size are refused by the WebSocket layer itself, which closes that
/// connection (the server goes on): what [`MAX_MESSAGE_BYTES`] would drop anyway, without
/// first reading megabytes into memory.
const MAX_WIRE_BYTES: usize = 64 * MAX_MESSAGE_BYTES;

/// Most pages connected at once; more are refused (503). Each holds a task and buffers,
/// and one user has no use for more tabs than this.
pub(crate) const MAX_PAGES: usize = 16;

/// Messages a page may send a second, on average, and in a burst. The page sends at most
/// about 85 a second (mouse drags, throttled to one every 12 ms); the rest is for scripts.
/// Messages over the rate are dropped with a log line.
pub(crate) const MESSAGES_PER_S: f64 = 200.0;
const MESSAGE_BURST: f64 = 400.0;

/// Longest a new page waits for the simulation to start over for it: past this (a long
/// replay is running) it is served what there is, and catches up as frames come.
const CONNECT_WAIT: Duration = Duration::from_secs(30);

/// What every request handler shares.
pub(crate) struct App {
    /// The `scene` message (skeletons and meshes), sent once to each page.
    pub scene_json: Arc<str>,
    pub shape: SceneShape,
    pub commands: SyncSender<Command>,
    pub frames: watch::Receiver<Arc<str>>,
    pub specs: watch::Receiver<Arc<str>>,
    pub notices: broadcast::Sender<Arc<str>>,
    pub state: Arc<Mutex<serde_json::Value>>,
    pub guard: Guard,
    /// Pages connected now.
    pub pages: AtomicUsize,
    /// Messages dropped so far, by reason (shown by `GET /api/state`).
    pub dropped: Dropped,
}

/// Counts of messages dropped, so scripts (and tests) can see the limits at work.
#[derive(Default)]
pub(crate) struct Dropped {
    /// Over [`MESSAGES_PER_S`].
    over_rate: AtomicU64,
    /// Refused by the checks of [`crate::protocol`], or not text.
    refused: AtomicU64,
    /// The simulation's queue was full.
    busy: AtomicU64,
}

impl Dropped {
    fn count(counter: &AtomicU64) {
        counter.fetch_add(1, Ordering::Relaxed);
    }

    fn json(&self) -> serde_json::Value {
        let n = |c: &AtomicU64| c.load(Ordering::Relaxed);
        serde_json::json!({
            "over_rate": n(&self.over_rate),
            "refused": n(&self.refused),
            "busy": n(&self.busy),
        })
    }
}

pub(crate) fn router(app: Arc<App>) -> Router {
    Router::new()
        .route("/", get(index))
        .route("/viewer.js", get(script))
        .route("/api/state", get(state))
        // Browsers ask for an icon; an empty answer keeps a 404 out of the page's console.
        .route("/favicon.ico", get(|| async { StatusCode::NO_CONTENT }))
        .route("/ws", get(upgrade))
        .layer(axum::middleware::from_fn_with_state(
            app.clone(),
            crate::guard::check,
        ))
        .with_state(app)
}

async fn index() -> Response {
    (
        [(header::CONTENT_TYPE, "text/html; charset=utf-8")],
        INDEX_HTML,
    )
        .into_response()
}

async fn script() -> Response {
    (
        [(header::CONTENT_TYPE, "text/javascript; charset=utf-8")],
        VIEWER_JS,
    )
        .into_response()
}

async fn state(State(app): State<Arc<App>>) -> Response {
    let mut value = app
        .state
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .clone();
    if let Some(map) = value.as_object_mut() {
        map.insert("dropped_messages".into(), app.dropped.json());
    }
    axum::Json(value).into_response()
}

/// Counts a connected page for as long as it lives.
struct PageSlot(Arc<App>);

impl Drop for PageSlot {
    fn drop(&mut self) {
        self.0.pages.fetch_sub(1, Ordering::SeqCst);
    }
}

async fn upgrade(
    ws: WebSocketUpgrade,
    ConnectInfo(peer): ConnectInfo<SocketAddr>,
    State(app): State<Arc<App>>,
) -> Response {
    if app.pages.fetch_add(1, Ordering::SeqCst) >= MAX_PAGES {
        app.pages.fetch_sub(1, Ordering::SeqCst);
        app.guard.log().line(|| {
            format!("refused a WebSocket from {peer}: {MAX_PAGES} pages are connected already")
        });
        return (
            StatusCode::SERVICE_UNAVAILABLE,
            "Too many pages are open on this viewer.\n",
        )
            .into_response();
    }
    let slot = PageSlot(app.clone());
    ws.max_message_size(MAX_WIRE_BYTES)
        .max_frame_size(MAX_WIRE_BYTES)
        .on_upgrade(move |socket| connection(socket, peer, slot))
}

async fn send(ws: &mut WebSocket, text: &str) -> bool {
    ws.send(Message::Text(text.into())).await.is_ok()
}

/// A token bucket: [`MESSAGES_PER_S`] on average, [`MESSAGE_BURST`] at once.
struct Rate {
    tokens: f64,
    at: Instant,
}

impl Rate {
    fn new() -> Rate {
        Rate {
            tokens: MESSAGE_BURST,
            at: Instant::now(),
        }
    }

    fn take(&mut self) -> bool {
        let now = Instant::now();
        let refill = now.duration_since(self.at).as_secs_f64() * MESSAGES_PER_S;
        self.tokens = (self.tokens + refill).min(MESSAGE_BURST);
        self.at = now;
        if self.tokens >= 1.0 {
            self.tokens -= 1.0;
            true
        } else {
            false
        }
    }
}

/// Asks the simulation to start over for a new page and waits (a while) until it has,
/// so the page's first frame is the clean one. `false` when the simulation is gone.
async fn start_over(app: &App) -> bool {
    let (done, started) = oneshot::channel();
    let tx = app.commands.clone();
    // A blocking send: a new page is worth waiting for a full queue to drain.
    let queued = tokio::task::spawn_blocking(move || tx.send(Command::Connected(done)).is_ok())
        .await
        .unwrap_or(false);
    if queued {
        let _ = tokio::time::timeout(CONNECT_WAIT, started).await;
    }
    queued
}

/// What a connection keeps to pass its page's messages on: the rate limit, the log's
/// ceiling and where replies go.
struct Page<'a> {
    app: &'a App,
    peer: SocketAddr,
    rate: Rate,
    log: LogLimit,
    reply: mpsc::Sender<Arc<str>>,
}

impl Page<'_> {
    /// Checks one thing the page sent and passes a good message on to the simulation, or
    /// counts and logs why it was dropped. `false` when the connection is over.
    fn receive(&mut self, incoming: Option<Result<Message, axum::Error>>) -> bool {
        let (app, peer, log) = (self.app, self.peer, &self.log);
        match incoming {
            Some(Ok(Message::Text(text))) => {
                if !self.rate.take() {
                    Dropped::count(&app.dropped.over_rate);
                    log.line(|| {
                        format!(
                            "dropped a message from {peer}: over {MESSAGES_PER_S} messages a second"
                        )
                    });
                    return true;
                }
                match parse_client_message(text.as_str(), &app.shape) {
                    Ok(msg) => {
                        let command = Command::Client {
                            msg,
                            reply: self.reply.clone(),
                        };
                        match app.commands.try_send(command) {
                            Ok(()) => {}
                            Err(TrySendError::Full(_)) => {
                                Dropped::count(&app.dropped.busy);
                                log.line(|| format!(
                                    "dropped a message from {peer}: the simulation is busy ({} messages are waiting)",
                                    crate::MAX_QUEUED_COMMANDS
                                ));
                            }
                            // The simulation has stopped: the server is going down.
                            Err(TrySendError::Disconnected(_)) => return false,
                        }
                    }
                    Err(why) => {
                        Dropped::count(&app.dropped.refused);
                        log.line(|| format!("dropped a message from {peer}: {why}"));
                    }
                }
                true
            }
            Some(Ok(Message::Binary(bytes))) => {
                if !self.rate.take() {
                    Dropped::count(&app.dropped.over_rate);
                    return true;
                }
                Dropped::count(&app.dropped.refused);
                log.line(|| format!(
                    "dropped a binary message of {} bytes from {peer}: only JSON text is understood",
                    bytes.len()
                ));
                true
            }
            Some(Ok(Message::Ping(_) | Message::Pong(_))) => true,
            Some(Ok(Message::Close(_))) | None => false,
            Some(Err(e)) => {
                log.line(|| format!("closed the connection from {peer}: {e}"));
                false
            }
        }
    }
}

/// One page: the simulation starts over for it, then it gets the scene and specs, then
/// frames, spec changes, notices and replies as they come, while its messages are
/// checked and passed on.
async fn connection(mut ws: WebSocket, peer: SocketAddr, slot: PageSlot) {
    let app = slot.0.clone();
    if !start_over(&app).await {
        return;
    }
    let mut frames = app.frames.clone();
    let mut specs = app.specs.clone();
    let mut notices = app.notices.subscribe();
    let (reply, mut replies) = mpsc::channel::<Arc<str>>(8);
    let first_specs = specs.borrow_and_update().clone();
    let first_frame = frames.borrow_and_update().clone();
    if !send(&mut ws, &app.scene_json).await
        || !send(&mut ws, &first_specs).await
        || !send(&mut ws, &first_frame).await
    {
        return;
    }
    let mut page = Page {
        app: &app,
        peer,
        rate: Rate::new(),
        log: LogLimit::default(),
        reply,
    };
    loop {
        tokio::select! {
            incoming = ws.recv() => if !page.receive(incoming) {
                return;
            },
            changed = frames.changed() => {
                if changed.is_err() {
                    return;
                }
                let frame = frames.borrow_and_update().clone();
                if !send(&mut ws, &frame).await {
                    return;
                }
            },
            changed = specs.changed() => {
                if changed.is_err() {
                    return;
                }
                let text = specs.borrow_and_update().clone();
                if !send(&mut ws, &text).await {
                    return;
                }
            },
            notice = notices.recv() => match notice {
                Ok(text) => {
                    if !send(&mut ws, &text).await {
                        return;
                    }
                }
                Err(broadcast::error::RecvError::Lagged(_)) => {}
                Err(broadcast::error::RecvError::Closed) => return,
            },
            Some(text) = replies.recv() => {
                if !send(&mut ws, &text).await {
                    return;
                }
            },
        }
    }
}
