//! Sequences of messages the validator accepts one by one but that used to exhaust memory
//! or kill the server: each must be refused (or bounded) with a notice while the server
//! goes on. Each was a crash or a path to one; keep them all.

mod common;

use common::*;
use serde_json::Value;

fn notice(ws: &mut Socket) -> Value {
    read_until(ws, |v| v["type"] == "notice" && v["level"] != "progress")
}

/// The server still steps: Play, some time passes, Pause.
fn still_runs(ws: &mut Socket, addr: std::net::SocketAddr) {
    let t0 = time(&get_state(addr));
    play(ws, addr);
    state_when(addr, |s| time(s) > t0 + 0.2);
    send(ws, r#"{"type":"pause"}"#);
    state_when(addr, |s| s["playing"] == false);
}

/// The reproducer from the issue: switch to the particle backend, then a 1000 m radius
/// (inside the protocol's range). It aborted the server on a 4 GiB allocation.
#[test]
fn a_huge_body_on_the_particle_backend_is_refused_and_the_server_goes_on() {
    let viewer = start();
    let addr = viewer.local_addr();
    let mut ws = connect(addr);
    let specs = read_until(&mut ws, |v| v["type"] == "specs");
    let body = first_capsule(&specs);
    send(&mut ws, r#"{"type":"backend","kind":"particle"}"#);
    state_when(addr, |s| s["backend"] == "particle");
    play(&mut ws, addr);
    send(
        &mut ws,
        &format!(
            r#"{{"type":"edit_body","ragdoll":0,"body":{body},"radius_m":1000,"length_m":0.3,"center_m":[0,0,0],"mass_kg":4}}"#
        ),
    );
    let n = notice(&mut ws);
    assert_eq!(n["level"], "error", "{n}");
    let why = n["message"].as_str().unwrap();
    // The library's spec bounds (100 m) say it before the viewer's own (twice the file's
    // largest body) need to.
    assert!(
        why.contains("edit refused") && why.contains("shape.radius_m"),
        "{why}"
    );
    // Nothing changed, and the world still runs on the particle backend.
    let state = get_state(addr);
    assert_eq!(state["edited"], false, "{state}");
    assert_eq!(state["backend"], "particle");
    send(&mut ws, r#"{"type":"pause"}"#);
    still_runs(&mut ws, addr);
    // The same on the rigid backend, and a length and an offset as large.
    send(&mut ws, r#"{"type":"backend","kind":"rigid"}"#);
    state_when(addr, |s| s["backend"] == "rigid");
    for (r, l, c) in [(1000.0, 0.3, 0.0), (0.05, 1000.0, 0.0), (0.05, 0.3, 1000.0)] {
        send(
            &mut ws,
            &format!(
                r#"{{"type":"edit_body","ragdoll":0,"body":{body},"radius_m":{r},"length_m":{l},"center_m":[{c},0,0],"mass_kg":4}}"#
            ),
        );
        let n = notice(&mut ws);
        assert!(
            n["message"].as_str().unwrap().contains("edit refused"),
            "{n}"
        );
    }
    let specs_now = get_state(addr);
    assert_eq!(specs_now["edited"], false);
    still_runs(&mut ws, addr);
    viewer.shutdown();
}

/// The edits the bounds allow, at their largest, on `backend`, with the largest charge the
/// protocol allows next to the character: one body at the bound moved onto its joint, then
/// every body at the bound. All accepted, and the server goes on.
fn largest_allowed_edits_run_on(backend: &str) {
    let viewer = start();
    let addr = viewer.local_addr();
    let mut ws = connect(addr);
    let specs = read_until(&mut ws, |v| v["type"] == "specs");
    let max = specs["ragdolls"][0]["edit_bounds"]["max_extent_m"]
        .as_f64()
        .unwrap();
    let bodies = specs["ragdolls"][0]["spec"]["bodies"].as_array().unwrap();
    // The bound is twice the file's largest body (the humanoid's shin, 0.42 m).
    assert!((max - 0.84).abs() < 0.01, "{max}");
    send(
        &mut ws,
        &format!(r#"{{"type":"backend","kind":"{backend}"}}"#),
    );
    state_when(addr, |s| s["backend"] == backend);
    let (radius, length) = (0.45 * max * 0.99, 0.1 * max * 0.99);
    let edit = |body: usize| {
        let mass = &bodies[body]["mass_kg"];
        format!(
            r#"{{"type":"edit_body","ragdoll":0,"body":{body},"radius_m":{radius},"length_m":{length},"center_m":[0,0,0],"mass_kg":{mass}}}"#
        )
    };
    let one = first_capsule(&specs);
    send(&mut ws, &edit(one));
    read_until(&mut ws, |v| {
        v["type"] == "specs"
            && v["ragdolls"][0]["spec"]["bodies"][one]["shape"]["radius_m"]
                != bodies[one]["shape"]["radius_m"]
    });
    send(
        &mut ws,
        r#"{"type":"blast","position":[0.5,0.5,0],"tnt_kg":1000,"delay_s":0}"#,
    );
    still_runs(&mut ws, addr);
    send(&mut ws, r#"{"type":"reset"}"#);
    state_when(addr, |s| s["edited"] == false && s["step"] == 0);
    for body in 0..bodies.len() {
        send(&mut ws, &edit(body));
    }
    let last = bodies.len() - 1;
    read_until(&mut ws, |v| {
        v["type"] == "specs"
            && v["ragdolls"][0]["spec"]["bodies"][last]["shape"]["radius_m"]
                != bodies[last]["shape"]["radius_m"]
    });
    still_runs(&mut ws, addr);
    viewer.shutdown();
}

#[test]
fn the_largest_allowed_edits_run_on_the_rigid_backend() {
    largest_allowed_edits_run_on("rigid");
}

/// The same on the particle backend: here the viewer's bounds are not enough (a head of
/// the file's own largest size, moved 10 cm onto its joint, is enough); the particle broad
/// phase itself must stay bounded whatever the bodies' sizes and speeds.
#[test]
fn the_largest_allowed_edits_run_on_the_particle_backend() {
    largest_allowed_edits_run_on("particle");
}

/// Masses far past the file's bodies are refused (the solver cannot hold a 1e7 kg hand
/// on a 1 kg forearm), as are joint edits the library refuses.
#[test]
fn extreme_masses_are_refused_with_the_bounds_in_the_notice() {
    let viewer = start();
    let addr = viewer.local_addr();
    let mut ws = connect(addr);
    let specs = read_until(&mut ws, |v| v["type"] == "specs");
    let body = first_capsule(&specs);
    let b = &specs["ragdolls"][0]["spec"]["bodies"][body];
    let (r, l) = (
        b["shape"]["radius_m"].clone(),
        b["shape"]["length_m"].clone(),
    );
    for mass in ["1e7", "0.001"] {
        send(
            &mut ws,
            &format!(
                r#"{{"type":"edit_body","ragdoll":0,"body":{body},"radius_m":{r},"length_m":{l},"center_m":[0,0,0],"mass_kg":{mass}}}"#
            ),
        );
        let n = notice(&mut ws);
        let why = n["message"].as_str().unwrap();
        assert!(why.contains("edit refused") && why.contains(" kg"), "{why}");
    }
    assert_eq!(get_state(addr)["edited"], false);
    viewer.shutdown();
}

/// Charges and drags are capped per timeline: past the cap each is refused with a notice,
/// and the world (which visits every charge and pin at every step) stays small.
#[test]
fn charges_past_the_cap_are_refused() {
    let viewer = start();
    let addr = viewer.local_addr();
    let mut ws = connect(addr);
    read_until(&mut ws, |v| v["type"] == "specs");
    let blast = r#"{"type":"blast","position":[3,0.5,0],"tnt_kg":1,"delay_s":60}"#;
    // Below the message rate: 100 at once fits the burst.
    for _ in 0..100 {
        send(&mut ws, blast);
    }
    state_when(addr, |s| s["events"] == 100);
    send(&mut ws, blast);
    let n = notice(&mut ws);
    assert!(
        n["message"].as_str().unwrap().contains("most charges"),
        "{n}"
    );
    assert_eq!(get_state(addr)["events"], 100);
    viewer.shutdown();
}

/// A flood of messages: past the per-connection rate they are dropped (and counted)
/// before they are even parsed; the connection goes on.
#[test]
fn a_flood_of_messages_is_cut_to_the_rate() {
    let viewer = start();
    let addr = viewer.local_addr();
    let mut ws = connect(addr);
    read_until(&mut ws, |v| v["type"] == "specs");
    let started = std::time::Instant::now();
    // Refused by the checks anyway, so the simulation's queue plays no part.
    for _ in 0..2000 {
        send(&mut ws, r#"{"type":"launch"}"#);
    }
    let dropped = |s: &Value, why: &str| s["dropped_messages"][why].as_u64().unwrap();
    let s = state_when(addr, |s| {
        dropped(s, "over_rate") + dropped(s, "refused") == 2000
    });
    let took = started.elapsed().as_secs_f64();
    // The burst (400) and what the rate (200 a second) refilled while they came went on to
    // the checks; the rest was cut.
    let checked = dropped(&s, "refused") as f64;
    assert!(
        (400.0..=400.0 + 200.0 * took + 1.0).contains(&checked),
        "{checked} of 2000 messages reached the checks in {took:.2} s"
    );
    assert_eq!(dropped(&s, "busy"), 0);
    // The connection still works, once the rate has refilled (200 a second: a message sent
    // at once after a fast flood is itself over the rate and dropped).
    std::thread::sleep(std::time::Duration::from_millis(100));
    send(&mut ws, r#"{"type":"step"}"#);
    state_when(addr, |s| s["step"] == 1);
    viewer.shutdown();
}
