//! The server end to end over real sockets: bad messages are dropped while the connection
//! and the simulation go on, scrubbing back then playing re-simulates the same motion bit
//! for bit (events included), the backend switch, and edits.

mod common;

use std::time::Duration;

use common::*;
use serde_json::Value;
use tungstenite::Message;

#[test]
fn bad_messages_are_dropped_and_the_connection_and_simulation_go_on() {
    let viewer = start();
    let addr = viewer.local_addr();
    let mut ws = connect(addr);
    // The page first gets the scene and the specs.
    let scene = read_until(&mut ws, |v| v["type"] == "scene");
    assert_eq!(scene["ragdolls"].as_array().unwrap().len(), 1);
    play(&mut ws, addr);
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
    let paused = time(&state_when(addr, |s| s["playing"] == false));
    std::thread::sleep(Duration::from_millis(200));
    assert_eq!(time(&get_state(addr)), paused);
    send(&mut ws, r#"{"type":"play"}"#);
    read_until(&mut ws, |v| v["type"] == "frame" && v["playing"] == true);
    viewer.shutdown();
}

/// Body positions of the state, as text: equal text means equal bits (f32 is written in
/// its shortest round-tripping form).
fn positions(v: &Value) -> String {
    v["ragdolls"][0]["bodies"].to_string()
}

#[test]
fn scrubbing_back_and_playing_replays_the_same_motion_with_its_events() {
    let viewer = start();
    let addr = viewer.local_addr();
    let mut ws = connect(addr);
    read_until(&mut ws, |v| v["type"] == "frame");
    play(&mut ws, addr);
    // A blast at 0.3 s (placed live), then run on past it.
    state_when(addr, |s| time(s) >= 0.3);
    send(
        &mut ws,
        r#"{"type":"blast","position":[0.8,0.5,0],"tnt_kg":2,"delay_s":0}"#,
    );
    state_when(addr, |s| time(s) >= 1.2);
    send(&mut ws, r#"{"type":"pause"}"#);
    read_until(&mut ws, |v| v["type"] == "frame" && v["playing"] == false);
    let head = state_when(addr, |s| s["playing"] == false);
    let t_head = time(&head);
    assert_eq!(head["events"], 1);
    // Scrubbing shows the recorded past...
    send(&mut ws, r#"{"type":"scrub","time_s":1.0}"#);
    read_until(&mut ws, |v| v["type"] == "frame" && v["step"] == 60);
    let recorded = state_when(addr, |s| s["step"] == 60);
    assert!((time(&recorded) - 1.0).abs() < 1e-6);
    assert_eq!(recorded["head_time_s"], head["time_s"]);
    // ...and playing from there re-simulates from 0 (the blast replayed at its step), so
    // the step shown before comes out bit for bit the same.
    send(&mut ws, r#"{"type":"play"}"#);
    state_when(addr, |s| time(s) >= t_head + 0.2);
    send(&mut ws, r#"{"type":"pause"}"#);
    read_until(&mut ws, |v| v["type"] == "frame" && v["playing"] == false);
    send(&mut ws, &format!(r#"{{"type":"scrub","time_s":{t_head}}}"#));
    let step = head["step"].as_u64().unwrap();
    read_until(&mut ws, |v| v["type"] == "frame" && v["step"] == step);
    let replayed = state_when(addr, |s| s["step"] == step);
    assert_eq!(replayed["events"], 1);
    assert_eq!(positions(&replayed), positions(&head));
    // The blast did move the character: the pelvis is far from where it started.
    send(&mut ws, r#"{"type":"scrub","time_s":0}"#);
    read_until(&mut ws, |v| v["type"] == "frame" && v["step"] == 0);
    let start = state_when(addr, |s| s["step"] == 0);
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
    let state = state_when(addr, |s| s["backend"] == "particle");
    let t0 = time(&state);
    play(&mut ws, addr);
    std::thread::sleep(Duration::from_millis(300));
    let t1 = time(&get_state(addr));
    assert!(t1 > t0, "the particle world does not run: {t0} → {t1}");
    viewer.shutdown();
}

#[test]
fn an_edit_changes_the_spec_the_pages_see_and_save_writes_it() {
    let dir = tempfile::tempdir().unwrap();
    let viewer = start_saving(dir.path().to_path_buf(), "edited");
    let mut ws = connect(viewer.local_addr());
    let specs = read_until(&mut ws, |v| v["type"] == "specs");
    let capsule = first_capsule(&specs);
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
    let notice = read_until(&mut ws, |v| {
        v["type"] == "notice" && v["level"] != "progress"
    });
    assert_eq!(notice["level"], "info", "{notice}");
    let path = dir.path().join("edited.spec.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let saved = ragdoll::spec::RagdollSpec::from_toml(&text, &path).unwrap();
    assert_eq!(saved.bodies[capsule].mass_kg, 12.5);
    assert_eq!(saved.bodies[capsule].center_m, [0.0, 0.0625, 0.0]);
    viewer.shutdown();
}
