//! What the viewer's socket tests share: starting a viewer on a free port, raw HTTP
//! requests, a WebSocket client, and waiting for the state to show something.
#![allow(dead_code)]

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::path::PathBuf;
use std::time::{Duration, Instant};

use ragdoll::scene::Scene;
use ragdoll::skeleton::humanoid;
use ragdoll::spec::{BuildOptions, build_spec};
use ragdoll::world::WorldSettings;
use ragdoll_view::{ViewOptions, Viewer};
use serde_json::Value;
use tungstenite::Message;

pub type Socket = tungstenite::WebSocket<TcpStream>;

/// A viewer of the built-in humanoid on a free port, saving into `save_dir`.
pub fn start_saving(save_dir: PathBuf, save_stem: &str) -> Viewer {
    let character = humanoid();
    let spec = build_spec(&character, &BuildOptions::default()).unwrap();
    let scene = Scene::single(character, spec, "built-in", 0.0, WorldSettings::default());
    Viewer::start(
        scene,
        &ViewOptions {
            port: 0,
            save_dir,
            save_stem: save_stem.into(),
            ..Default::default()
        },
    )
    .unwrap()
}

/// A viewer of the built-in humanoid on a free port.
pub fn start() -> Viewer {
    start_saving(std::env::temp_dir(), "ragdoll-view-test")
}

/// Sends `request` (the whole text) and returns the status code and the body.
pub fn raw(addr: SocketAddr, request: &str) -> (u16, String) {
    let mut s = TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    s.write_all(request.as_bytes()).unwrap();
    let mut text = String::new();
    s.read_to_string(&mut text).unwrap();
    let (head, body) = text.split_once("\r\n\r\n").unwrap_or((&text, ""));
    let code = head
        .split(' ')
        .nth(1)
        .and_then(|c| c.parse().ok())
        .unwrap_or_else(|| panic!("no status in {head:?}"));
    (code, body.to_string())
}

/// `GET path` with the given `Host` and extra header lines.
pub fn get(addr: SocketAddr, path: &str, host: &str, extra: &str) -> (u16, String) {
    raw(
        addr,
        &format!("GET {path} HTTP/1.1\r\nHost: {host}\r\n{extra}Connection: close\r\n\r\n"),
    )
}

pub fn get_state(addr: SocketAddr) -> Value {
    let (code, body) = get(addr, "/api/state", &addr.to_string(), "");
    assert_eq!(code, 200, "{body}");
    serde_json::from_str(&body).unwrap()
}

pub fn connect(addr: SocketAddr) -> Socket {
    let stream = TcpStream::connect(addr).unwrap();
    stream
        .set_read_timeout(Some(Duration::from_secs(10)))
        .unwrap();
    let (socket, _) = tungstenite::client(format!("ws://{addr}/ws"), stream).unwrap();
    socket
}

pub fn send(ws: &mut Socket, text: &str) {
    ws.send(Message::Text(text.into())).unwrap();
}

/// Reads messages until one satisfies `want`, for at most 20 s.
pub fn read_until(ws: &mut Socket, want: impl Fn(&Value) -> bool) -> Value {
    read_through(ws, want).pop().unwrap()
}

/// Every message read until one satisfies `want`, that one last. Messages from different
/// channels (frames, specs, notices) may come in any order: a test looking for two of
/// them looks through all that came.
pub fn read_through(ws: &mut Socket, want: impl Fn(&Value) -> bool) -> Vec<Value> {
    let start = Instant::now();
    let mut seen = Vec::new();
    let mut all = Vec::new();
    while start.elapsed() < Duration::from_secs(20) {
        match ws.read() {
            Ok(Message::Text(t)) => {
                let v: Value = serde_json::from_str(t.as_str()).unwrap();
                let done = want(&v);
                all.push(v.clone());
                if done {
                    return all;
                }
                let kind = v["type"].as_str().unwrap_or("?").to_string();
                match v["type"].as_str() {
                    Some("notice") => seen.push(format!("notice {}", v["message"])),
                    _ if seen.last() == Some(&kind) => {}
                    _ => seen.push(kind),
                }
            }
            Ok(_) => {}
            Err(e) => panic!("{e} after {:?} waiting; seen: {seen:?}", start.elapsed()),
        }
    }
    panic!("no such message within 20 s; seen: {seen:?}");
}

pub fn time(v: &Value) -> f64 {
    v["time_s"].as_f64().unwrap()
}

/// The state once `want` holds: the server publishes it just after the frame, so a
/// request right after a frame can still see the one before.
pub fn state_when(addr: SocketAddr, want: impl Fn(&Value) -> bool) -> Value {
    let deadline = Instant::now() + Duration::from_secs(20);
    let mut state = get_state(addr);
    while !want(&state) && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(10));
        state = get_state(addr);
    }
    assert!(want(&state), "the state never got there: {state}");
    state
}

/// Presses Play and waits until the state shows the simulation running.
pub fn play(ws: &mut Socket, addr: SocketAddr) {
    send(ws, r#"{"type":"play"}"#);
    state_when(addr, |s| s["playing"] == true);
}

/// Index of the humanoid's first capsule, with the specs message.
pub fn first_capsule(specs: &Value) -> usize {
    specs["ragdolls"][0]["spec"]["bodies"]
        .as_array()
        .unwrap()
        .iter()
        .position(|b| b["shape"]["kind"] == "capsule")
        .unwrap()
}
