//! The server end to end over real sockets: bad messages are dropped while the connection
//! and the simulation go on, pages from other sites are refused, and scrubbing back then
//! playing re-simulates the same motion bit for bit (events included).

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::time::{Duration, Instant};

use ragdoll::skeleton::humanoid;
use ragdoll::spec::{BuildOptions, build_spec};
use ragdoll::world::WorldSettings;
use ragdoll_view::{ViewOptions, Viewer, single_character_scene};
use serde_json::Value;
use tungstenite::Message;
use tungstenite::client::IntoClientRequest;

type Socket = tungstenite::WebSocket<TcpStream>;

fn start() -> Viewer {
    let character = humanoid();
    let spec = build_spec(&character, &BuildOptions::default()).unwrap();
    let scene = single_character_scene(character, spec, "built-in", WorldSettings::default());
    let dir = std::env::temp_dir();
    Viewer::start(
        scene,
        &ViewOptions {
            port: 0,
            save_dir: dir,
            ..Default::default()
        },
    )
    .unwrap()
}

fn get_state(addr: SocketAddr) -> Value {
    let mut s = TcpStream::connect(addr).unwrap();
    write!(
        s,
        "GET /api/state HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n"
    )
    .unwrap();
    let mut text = String::new();
    s.read_to_string(&mut text).unwrap();
    let (head, body) = text.split_once("\r\n\r\n").unwrap();
    assert!(head.starts_with("HTTP/1.1 200"), "{head}");
    serde_json::from_str(body).unwrap()
}

fn connect(addr: SocketAddr) -> Socket {
    let stream = TcpStream::connect(addr).unwrap();
    stream
        .set_read_timeout(Some(Duration::from_secs(10)))
        .unwrap();
    let (socket, _) = tungstenite::client(format!("ws://{addr}/ws"), stream).unwrap();
    socket
}

fn send(ws: &mut Socket, text: &str) {
    ws.send(Message::Text(text.into())).unwrap();
}

/// Reads messages until one satisfies `want`, for at most 10 s.
fn read_until(ws: &mut Socket, want: impl Fn(&Value) -> bool) -> Value {
    let start = Instant::now();
    while start.elapsed() < Duration::from_secs(10) {
        if let Message::Text(t) = ws.read().unwrap() {
            let v: Value = serde_json::from_str(t.as_str()).unwrap();
            if want(&v) {
                return v;
            }
        }
    }
    panic!("no such message within 10 s");
}

fn time(v: &Value) -> f64 {
    v["time_s"].as_f64().unwrap()
}

#[test]
fn bad_messages_are_dropped_and_the_connection_and_simulation_go_on() {
    let viewer = start();
    let addr = viewer.local_addr();
    let mut ws = connect(addr);
    // The page first gets the scene and the specs.
    let scene = read_until(&mut ws, |v| v["type"] == "scene");
    assert_eq!(scene["ragdolls"].as_array().unwrap().len(), 1);
    let bodies = get_state(addr)["ragdolls"][0]["bodies"]
        .as_array()
        .unwrap()
        .len();
    for bad in [
        "garbage".to_string(),
        r#"{"type":"pause","extra":1}"#.to_string(),
        r#"{"type":"blast","position":[1e39,0,0],"tnt_kg":1,"delay_s":0}"#.to_string(),
        format!(
            r#"{{"type":"drag_start","ragdoll":0,"body":{bodies},"local":[0,0,0],"target":[0,1,0]}}"#
        ),
        format!(r#"{{"type":"pause","pad":"{}"}}"#, "x".repeat(100_000)),
    ] {
        send(&mut ws, &bad);
    }
    ws.send(Message::Binary(vec![0u8; 64].into())).unwrap();
    // None of them paused or moved anything: time still runs and nothing was added.
    let a = get_state(addr);
    std::thread::sleep(Duration::from_millis(300));
    let b = get_state(addr);
    assert!(time(&b) > time(&a) + 0.1, "{} → {}", time(&a), time(&b));
    assert_eq!(b["events"], 0);
    // The same connection still carries good messages both ways.
    send(&mut ws, r#"{"type":"pause"}"#);
    read_until(&mut ws, |v| v["type"] == "frame" && v["playing"] == false);
    let paused = time(&state_when_paused(addr));
    std::thread::sleep(Duration::from_millis(200));
    assert_eq!(time(&get_state(addr)), paused);
    send(&mut ws, r#"{"type":"play"}"#);
    read_until(&mut ws, |v| v["type"] == "frame" && v["playing"] == true);
    viewer.shutdown();
}

#[test]
fn a_page_from_another_site_is_refused() {
    let viewer = start();
    let addr = viewer.local_addr();
    let mut request = format!("ws://{addr}/ws").into_client_request().unwrap();
    request
        .headers_mut()
        .insert("Origin", "http://evil.example".parse().unwrap());
    let stream = TcpStream::connect(addr).unwrap();
    assert!(tungstenite::client(request, stream).is_err());
    // Its own origin is welcome.
    let mut request = format!("ws://{addr}/ws").into_client_request().unwrap();
    request
        .headers_mut()
        .insert("Origin", format!("http://{addr}").parse().unwrap());
    let stream = TcpStream::connect(addr).unwrap();
    assert!(tungstenite::client(request, stream).is_ok());
    viewer.shutdown();
}

/// Body positions of the state, as text: equal text means equal bits (f32 is written in
/// its shortest round-tripping form).
fn positions(v: &Value) -> String {
    v["ragdolls"][0]["bodies"].to_string()
}

/// The state once it shows the world paused (published just after the frame that says so).
fn state_when_paused(addr: SocketAddr) -> Value {
    let deadline = Instant::now() + Duration::from_secs(10);
    let mut state = get_state(addr);
    while state["playing"] != false && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(10));
        state = get_state(addr);
    }
    assert_eq!(state["playing"], false, "{state}");
    state
}

/// The state once it shows `step`: the server publishes it just after the frame, so a
/// request right after the frame can still see the step before.
fn state_at_step(addr: SocketAddr, step: u64) -> Value {
    let deadline = Instant::now() + Duration::from_secs(10);
    let mut state = get_state(addr);
    while state["step"] != step && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(10));
        state = get_state(addr);
    }
    assert_eq!(state["step"], step, "{state}");
    state
}

#[test]
fn scrubbing_back_and_playing_replays_the_same_motion_with_its_events() {
    let viewer = start();
    let addr = viewer.local_addr();
    let mut ws = connect(addr);
    read_until(&mut ws, |v| v["type"] == "frame");
    // A blast at 0.3 s (placed live), then run on past it.
    while time(&get_state(addr)) < 0.3 {
        std::thread::sleep(Duration::from_millis(20));
    }
    send(
        &mut ws,
        r#"{"type":"blast","position":[0.8,0.5,0],"tnt_kg":2,"delay_s":0}"#,
    );
    while time(&get_state(addr)) < 1.2 {
        std::thread::sleep(Duration::from_millis(20));
    }
    send(&mut ws, r#"{"type":"pause"}"#);
    read_until(&mut ws, |v| v["type"] == "frame" && v["playing"] == false);
    let head = state_when_paused(addr);
    let t_head = time(&head);
    assert_eq!(head["events"], 1);
    // Scrubbing shows the recorded past...
    send(&mut ws, r#"{"type":"scrub","time_s":1.0}"#);
    read_until(&mut ws, |v| v["type"] == "frame" && v["step"] == 60);
    let recorded = state_at_step(addr, 60);
    assert!((time(&recorded) - 1.0).abs() < 1e-6);
    assert_eq!(recorded["head_time_s"], head["time_s"]);
    // ...and playing from there re-simulates from 0 (the blast replayed at its step), so
    // the step shown before comes out bit for bit the same.
    send(&mut ws, r#"{"type":"play"}"#);
    while time(&get_state(addr)) < t_head + 0.2 {
        std::thread::sleep(Duration::from_millis(20));
    }
    send(&mut ws, r#"{"type":"pause"}"#);
    read_until(&mut ws, |v| v["type"] == "frame" && v["playing"] == false);
    send(&mut ws, &format!(r#"{{"type":"scrub","time_s":{t_head}}}"#));
    let step = head["step"].as_u64().unwrap();
    read_until(&mut ws, |v| v["type"] == "frame" && v["step"] == step);
    let replayed = state_at_step(addr, step);
    assert_eq!(replayed["events"], 1);
    assert_eq!(positions(&replayed), positions(&head));
    // The blast did move the character: the pelvis is far from where it started.
    send(&mut ws, r#"{"type":"scrub","time_s":0}"#);
    read_until(&mut ws, |v| v["type"] == "frame" && v["step"] == 0);
    let start = state_at_step(addr, 0);
    let x = |v: &Value| v["ragdolls"][0]["centre_of_mass"][0].as_f64().unwrap();
    assert!(
        (x(&head) - x(&start)).abs() > 0.3,
        "{} → {}",
        x(&start),
        x(&head)
    );
    viewer.shutdown();
}

/// The page's backend switch rebuilds the world on the particle backend and replays it:
/// the server reports the new backend and the simulation goes on running on it.
#[test]
fn the_backend_switch_moves_the_simulation_to_the_particle_backend() {
    let viewer = start();
    let addr = viewer.local_addr();
    let mut ws = connect(addr);
    read_until(&mut ws, |v| v["type"] == "specs");
    send(&mut ws, r#"{"type":"backend","kind":"particle"}"#);
    let deadline = Instant::now() + Duration::from_secs(10);
    let mut state = get_state(addr);
    while state["backend"] != "particle" && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(50));
        state = get_state(addr);
    }
    assert_eq!(state["backend"], "particle", "{state}");
    let t0 = state["time_s"].as_f64().unwrap();
    std::thread::sleep(Duration::from_millis(300));
    let t1 = get_state(addr)["time_s"].as_f64().unwrap();
    assert!(t1 > t0, "the particle world does not run: {t0} → {t1}");
    viewer.shutdown();
}

#[test]
fn an_edit_changes_the_spec_the_pages_see_and_save_writes_it() {
    let dir = std::env::temp_dir().join(format!("ragdoll-view-save-{}", std::process::id()));
    let character = humanoid();
    let spec = build_spec(&character, &BuildOptions::default()).unwrap();
    let scene = single_character_scene(character, spec, "built-in", WorldSettings::default());
    let viewer = Viewer::start(
        scene,
        &ViewOptions {
            port: 0,
            save_dir: dir.clone(),
            save_stem: "edited".into(),
            ..Default::default()
        },
    )
    .unwrap();
    let mut ws = connect(viewer.local_addr());
    let specs = read_until(&mut ws, |v| v["type"] == "specs");
    let capsule = specs["ragdolls"][0]["spec"]["bodies"]
        .as_array()
        .unwrap()
        .iter()
        .position(|b| b["shape"]["kind"] == "capsule")
        .unwrap();
    send(
        &mut ws,
        &format!(
            r#"{{"type":"edit_body","ragdoll":0,"body":{capsule},"radius_m":0.125,"length_m":0.25,"center_m":[0,0.0625,0],"mass_kg":12.5}}"#
        ),
    );
    let specs = read_until(&mut ws, |v| v["type"] == "specs");
    let body = &specs["ragdolls"][0]["spec"]["bodies"][capsule];
    assert_eq!(body["mass_kg"], 12.5);
    assert_eq!(body["shape"]["radius_m"], 0.125);
    assert_eq!(body["shape"]["length_m"], 0.25);
    send(&mut ws, r#"{"type":"save"}"#);
    let notice = read_until(&mut ws, |v| v["type"] == "notice");
    assert_eq!(notice["level"], "info", "{notice}");
    let path = dir.join("edited.spec.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let saved = ragdoll::spec::RagdollSpec::from_toml(&text, &path).unwrap();
    assert_eq!(saved.bodies[capsule].mass_kg, 12.5);
    assert_eq!(saved.bodies[capsule].center_m, [0.0, 0.0625, 0.0]);
    viewer.shutdown();
    let _ = std::fs::remove_dir_all(&dir);
}
