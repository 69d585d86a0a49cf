//! What users expect of the viewer's state: it waits paused at t = 0 for Play; Reset goes
//! back to the file; a page that connects (a reload) starts clean; Save never replaces a
//! file unasked; a crash of the simulation thread is reported and restarted.

mod common;

use std::time::Duration;

use common::*;
use serde_json::Value;

fn edit(ws: &mut Socket, body: usize, mass: f64) {
    send(
        ws,
        &format!(
            r#"{{"type":"edit_body","ragdoll":0,"body":{body},"radius_m":0.06,"length_m":0.2,"center_m":[0,0.05,0],"mass_kg":{mass}}}"#
        ),
    );
}

fn mass(specs: &Value, body: usize) -> f64 {
    specs["ragdolls"][0]["spec"]["bodies"][body]["mass_kg"]
        .as_f64()
        .unwrap()
}

#[test]
fn the_simulation_waits_at_time_zero_until_play() {
    let viewer = start();
    let addr = viewer.local_addr();
    // Nothing runs before a page connects...
    std::thread::sleep(Duration::from_millis(500));
    let s = get_state(addr);
    assert_eq!((time(&s), &s["playing"]), (0.0, &Value::Bool(false)), "{s}");
    // ...nor after: the page's first frame is t = 0, paused, and stays so.
    let mut ws = connect(addr);
    let frame = read_until(&mut ws, |v| v["type"] == "frame");
    assert_eq!(frame["t"], 0.0);
    assert_eq!(frame["playing"], false);
    std::thread::sleep(Duration::from_millis(500));
    let s = get_state(addr);
    assert_eq!((time(&s), s["step"].as_u64()), (0.0, Some(0)), "{s}");
    play(&mut ws, addr);
    state_when(addr, |s| time(s) > 0.2);
    viewer.shutdown();
}

#[test]
fn reset_goes_back_to_the_files_spec_at_time_zero() {
    let viewer = start();
    let addr = viewer.local_addr();
    let mut ws = connect(addr);
    let specs = read_until(&mut ws, |v| v["type"] == "specs");
    let body = first_capsule(&specs);
    let original = mass(&specs, body);
    send(&mut ws, r#"{"type":"backend","kind":"particle"}"#);
    edit(&mut ws, body, 9.5);
    read_until(&mut ws, |v| v["type"] == "specs" && mass(v, body) == 9.5);
    send(
        &mut ws,
        r#"{"type":"blast","position":[0.8,0.5,0],"tnt_kg":2,"delay_s":0}"#,
    );
    play(&mut ws, addr);
    state_when(addr, |s| {
        time(s) > 0.3 && s["events"] == 1 && s["edited"] == true
    });
    send(&mut ws, r#"{"type":"reset"}"#);
    let specs = read_until(&mut ws, |v| {
        v["type"] == "specs" && mass(v, body) == original
    });
    // The backend chosen is kept; everything else is the file's.
    assert_eq!(specs["backend"], "particle");
    let s = state_when(addr, |s| s["step"] == 0 && s["playing"] == false);
    assert_eq!(s["events"], 0);
    assert_eq!(s["edited"], false);
    assert_eq!(time(&s), 0.0);
    // And it stays at 0 until Play.
    std::thread::sleep(Duration::from_millis(300));
    assert_eq!(get_state(addr)["step"], 0);
    viewer.shutdown();
}

#[test]
fn a_page_that_connects_starts_clean_and_the_others_are_told() {
    let viewer = start();
    let addr = viewer.local_addr();
    let mut first = connect(addr);
    let specs = read_until(&mut first, |v| v["type"] == "specs");
    let body = first_capsule(&specs);
    let original = mass(&specs, body);
    send(&mut first, r#"{"type":"backend","kind":"particle"}"#);
    edit(&mut first, body, 9.5);
    read_until(&mut first, |v| v["type"] == "specs" && mass(v, body) == 9.5);
    send(
        &mut first,
        r#"{"type":"blast","position":[0.8,0.5,0],"tnt_kg":2,"delay_s":0}"#,
    );
    play(&mut first, addr);
    state_when(addr, |s| time(s) > 0.3);
    // A reload is a new connection: it sees the file's state, at 0, paused.
    let mut second = connect(addr);
    let specs = read_until(&mut second, |v| v["type"] == "specs");
    assert_eq!(mass(&specs, body), original);
    assert_eq!(specs["backend"], "rigid");
    let frame = read_until(&mut second, |v| v["type"] == "frame");
    assert_eq!(
        (frame["t"].as_f64(), &frame["playing"]),
        (Some(0.0), &Value::Bool(false))
    );
    let s = get_state(addr);
    assert_eq!(
        (s["events"].as_u64(), &s["edited"]),
        (Some(0), &Value::Bool(false)),
        "{s}"
    );
    // The page already open follows (the file's specs come, before or after the notice),
    // and is told why.
    let original_specs = |v: &Value| v["type"] == "specs" && mass(v, body) == original;
    let mut got = read_through(&mut first, |v| v["type"] == "notice");
    let n = got.last().unwrap();
    assert!(
        n["message"].as_str().unwrap().contains("started over"),
        "{n}"
    );
    if !got.iter().any(original_specs) {
        got.push(read_until(&mut first, original_specs));
    }
    viewer.shutdown();
}

#[test]
fn save_never_replaces_a_file_unless_the_page_confirms() {
    let dir = tempfile::tempdir().unwrap();
    let viewer = start_saving(dir.path().to_path_buf(), "mine");
    let addr = viewer.local_addr();
    let path = dir.path().join("mine.spec.toml");
    std::fs::write(&path, "# the user's own file\n").unwrap();
    let mut ws = connect(addr);
    let specs = read_until(&mut ws, |v| v["type"] == "specs");
    let body = first_capsule(&specs);
    edit(&mut ws, body, 9.5);
    read_until(&mut ws, |v| v["type"] == "specs" && mass(v, body) == 9.5);
    send(&mut ws, r#"{"type":"save"}"#);
    let ask = read_until(&mut ws, |v| v["type"] == "confirm_overwrite");
    assert_eq!(ask["files"], serde_json::json!(["mine.spec.toml"]), "{ask}");
    assert_eq!(
        std::fs::read_to_string(&path).unwrap(),
        "# the user's own file\n"
    );
    // The page said yes.
    send(&mut ws, r#"{"type":"save","overwrite":true}"#);
    let n = read_until(&mut ws, |v| v["type"] == "notice");
    assert_eq!(n["level"], "info", "{n}");
    let text = std::fs::read_to_string(&path).unwrap();
    let saved = ragdoll::spec::RagdollSpec::from_toml(&text, &path).unwrap();
    assert_eq!(saved.bodies[body].mass_kg, 9.5);
    // Only that one file: nothing else was written beside it.
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    viewer.shutdown();
}

#[test]
fn a_save_folder_that_is_a_file_is_refused_at_start() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("not-a-folder");
    std::fs::write(&file, "x").unwrap();
    for save_dir in [file.clone(), file.join("below")] {
        let character = ragdoll::skeleton::humanoid();
        let spec =
            ragdoll::spec::build_spec(&character, &ragdoll::spec::BuildOptions::default()).unwrap();
        let scene = ragdoll::scene::Scene::single(
            character,
            spec,
            "built-in",
            0.0,
            ragdoll::world::WorldSettings::default(),
        );
        let options = ragdoll_view::ViewOptions {
            port: 0,
            save_dir,
            ..Default::default()
        };
        let err = match ragdoll_view::Viewer::start(scene, &options) {
            Ok(_) => panic!("a file was accepted as the save folder"),
            Err(e) => e.to_string(),
        };
        assert!(
            err.contains("--save-dir") && err.contains("is a file"),
            "{err}"
        );
    }
}

#[test]
fn a_panic_in_the_simulation_is_reported_and_the_simulation_restarted() {
    let viewer = start();
    let addr = viewer.local_addr();
    let mut ws = connect(addr);
    let specs = read_until(&mut ws, |v| v["type"] == "specs");
    let body = first_capsule(&specs);
    let original = mass(&specs, body);
    edit(&mut ws, body, 9.5);
    read_until(&mut ws, |v| v["type"] == "specs" && mass(v, body) == 9.5);
    play(&mut ws, addr);
    state_when(addr, |s| time(s) > 0.3);
    viewer.inject_panic_for_tests(false);
    let got = read_through(&mut ws, |v| v["type"] == "notice");
    let n = got.last().unwrap();
    assert_eq!(n["level"], "error");
    let why = n["message"].as_str().unwrap();
    assert!(
        why.contains("crashed") && why.contains("restarted"),
        "{why}"
    );
    // Back to the file, at 0, paused; the same connection drives the new simulation.
    let original_specs = |v: &Value| v["type"] == "specs" && mass(v, body) == original;
    if !got.iter().any(original_specs) {
        read_until(&mut ws, original_specs);
    }
    state_when(addr, |s| {
        s["step"] == 0 && s["playing"] == false && s["edited"] == false
    });
    play(&mut ws, addr);
    state_when(addr, |s| time(s) > 0.2);
    viewer.shutdown();
}

#[test]
fn a_simulation_that_cannot_be_restarted_stops_the_viewer_with_an_error() {
    let viewer = start();
    let addr = viewer.local_addr();
    let mut ws = connect(addr);
    read_until(&mut ws, |v| v["type"] == "frame");
    viewer.inject_panic_for_tests(true);
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(viewer.wait());
    });
    let result = rx
        .recv_timeout(Duration::from_secs(20))
        .expect("wait() did not return after the simulation died");
    let err = result.expect_err("wait() returned Ok after the simulation died");
    let err = err.to_string();
    assert!(err.contains("could not be restarted"), "{err}");
}

/// The recording's length is capped, and a scene with more bodies gets fewer steps (each
/// replay re-simulates up to the step shown, and its cost grows with the bodies).
#[test]
fn the_recording_is_capped_and_shorter_for_larger_scenes() {
    let viewer = start();
    let one = get_state(viewer.local_addr());
    viewer.shutdown();
    // The built-in humanoid: 5 minutes at 60 Hz.
    let cap = one["max_time_s"].as_f64().unwrap();
    assert!((cap - 17_999.0 / 60.0).abs() < 1e-3, "{cap}");

    let character = ragdoll::skeleton::humanoid();
    let spec =
        ragdoll::spec::build_spec(&character, &ragdoll::spec::BuildOptions::default()).unwrap();
    let mut scene = ragdoll::scene::Scene::single(
        character,
        spec,
        "built-in",
        0.0,
        ragdoll::world::WorldSettings::default(),
    );
    let first = scene.characters[0].clone();
    for i in 1..4 {
        let mut c = first.clone();
        c.name = format!("humanoid{i}");
        c.position = glam::Vec3::new(2.0 * i as f32, 0.0, 0.0);
        scene.characters.push(c);
    }
    let options = ragdoll_view::ViewOptions {
        port: 0,
        ..Default::default()
    };
    let viewer = ragdoll_view::Viewer::start(scene, &options).unwrap();
    let four = get_state(viewer.local_addr());
    viewer.shutdown();
    let cap = four["max_time_s"].as_f64().unwrap();
    let steps = 16 * 18_000 / (4 * 16);
    assert!((cap - (steps - 1) as f64 / 60.0).abs() < 1e-3, "{cap}");
}
