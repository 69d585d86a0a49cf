//! The web side: the embedded page, the state endpoint and one WebSocket per page. Every
//! message a page sends is checked here ([`crate::protocol::parse_client_message`]) before
//! it reaches the simulation thread; a bad one is logged and dropped, the connection kept.

use std::net::SocketAddr;
use std::sync::mpsc::Sender;
use std::sync::{Arc, Mutex};

use axum::Router;
use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::{ConnectInfo, State};
use axum::http::{HeaderMap, StatusCode, header};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use tokio::sync::{broadcast, watch};

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

/// What every request handler shares.
pub(crate) struct App {
    /// The `scene` message (skeletons and meshes), sent once to each page.
    pub scene_json: Arc<str>,
    pub shape: SceneShape,
    pub commands: Mutex<Sender<Command>>,
    pub frames: watch::Receiver<Arc<str>>,
    pub specs: watch::Receiver<Arc<str>>,
    pub notices: broadcast::Sender<Arc<str>>,
    pub state: Arc<Mutex<serde_json::Value>>,
}

pub(crate) fn router(app: Arc<App>) -> Router {
    Router::new()
        .route("/", get(index))
        .route("/viewer.js", get(script))
        .route("/api/state", get(state))
        // Browsers ask for an icon; an empty answer keeps a 404 out of the page's console.
        .route("/favicon.ico", get(|| async { StatusCode::NO_CONTENT }))
        .route("/ws", get(upgrade))
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
    let value = match app.state.lock() {
        Ok(s) => s.clone(),
        Err(_) => return StatusCode::INTERNAL_SERVER_ERROR.into_response(),
    };
    axum::Json(value).into_response()
}

/// Whether a browser page from another site opened this socket: browsers always send
/// `Origin`, and a page of ours comes from the host it connects to. Refusing others keeps
/// a web page the user happens to visit from driving the viewer (non-browser clients send
/// no `Origin` and are let in: they could reach the port anyway).
fn foreign_origin(headers: &HeaderMap) -> bool {
    let Some(origin) = headers.get(header::ORIGIN) else {
        return false;
    };
    let host = headers.get(header::HOST).and_then(|h| h.to_str().ok());
    match (origin.to_str().ok(), host) {
        (Some(o), Some(h)) => o != format!("http://{h}"),
        _ => true,
    }
}

async fn upgrade(
    ws: WebSocketUpgrade,
    headers: HeaderMap,
    ConnectInfo(peer): ConnectInfo<SocketAddr>,
    State(app): State<Arc<App>>,
) -> Response {
    if foreign_origin(&headers) {
        eprintln!("viewer: refused a WebSocket from {peer}: its page comes from another site");
        return StatusCode::FORBIDDEN.into_response();
    }
    ws.max_message_size(MAX_WIRE_BYTES)
        .max_frame_size(MAX_WIRE_BYTES)
        .on_upgrade(move |socket| connection(socket, peer, app))
}

async fn send(ws: &mut WebSocket, text: &str) -> bool {
    ws.send(Message::Text(text.into())).await.is_ok()
}

/// One page: the scene and specs first, then frames, spec changes and notices as they
/// come, while its messages are checked and passed on.
async fn connection(mut ws: WebSocket, peer: SocketAddr, app: Arc<App>) {
    let mut frames = app.frames.clone();
    let mut specs = app.specs.clone();
    let mut notices = app.notices.subscribe();
    let first_specs = specs.borrow_and_update().clone();
    if !send(&mut ws, &app.scene_json).await || !send(&mut ws, &first_specs).await {
        return;
    }
    loop {
        tokio::select! {
            incoming = ws.recv() => match incoming {
                Some(Ok(Message::Text(text))) => {
                    match parse_client_message(text.as_str(), &app.shape) {
                        Ok(msg) => {
                            let sent = app
                                .commands
                                .lock()
                                .map(|tx| tx.send(Command::Client(msg)).is_ok())
                                .unwrap_or(false);
                            if !sent {
                                return; // the simulation has stopped: the server is going down
                            }
                        }
                        Err(why) => eprintln!("viewer: dropped a message from {peer}: {why}"),
                    }
                }
                Some(Ok(Message::Binary(bytes))) => {
                    eprintln!(
                        "viewer: dropped a binary message of {} bytes from {peer}: only JSON text is understood",
                        bytes.len()
                    );
                }
                Some(Ok(Message::Ping(_) | Message::Pong(_))) => {}
                Some(Ok(Message::Close(_))) | None => return,
                Some(Err(e)) => {
                    eprintln!("viewer: closed the connection from {peer}: {e}");
                    return;
                }
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
        }
    }
}
