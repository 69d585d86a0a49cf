//! `ragdoll view`: what it refuses before serving, and that it serves a scene file and
//! prints a URL with the port it picked.

mod common;

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::process::{Command, Stdio};

use common::{ragdoll, repo, stderr};

#[test]
fn a_missing_file_is_an_error_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let out = ragdoll(
        dir.path(),
        &["view", "nowhere.glb", "--port", "0", "--no-open"],
    );
    assert!(!out.status.success());
    assert!(stderr(&out).contains("nowhere.glb"), "{}", stderr(&out));
}

#[test]
fn character_flags_are_refused_with_a_scene_file() {
    let scene = repo().join("examples/forces.toml");
    let dir = tempfile::tempdir().unwrap();
    let out = ragdoll(
        dir.path(),
        &["view", scene.to_str().unwrap(), "--mass", "80", "--no-open"],
    );
    assert!(!out.status.success());
    assert!(stderr(&out).contains("--mass"), "{}", stderr(&out));
}

#[test]
fn a_port_in_use_is_an_error_that_says_how_to_pick_another() {
    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = taken.local_addr().unwrap().port().to_string();
    let dir = tempfile::tempdir().unwrap();
    let out = ragdoll(dir.path(), &["view", "--port", &port, "--no-open"]);
    assert!(!out.status.success());
    let err = stderr(&out);
    assert!(err.contains(&port) && err.contains("--port 0"), "{err}");
}

#[test]
fn a_scene_file_is_served_on_the_port_printed() {
    let scene = repo().join("examples/blast_crowd.toml");
    let mut child = Command::new(env!("CARGO_BIN_EXE_ragdoll"))
        .args(["view", scene.to_str().unwrap(), "--port", "0", "--no-open"])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    let addr = line
        .split("http://")
        .nth(1)
        .and_then(|rest| rest.split('/').next())
        .unwrap_or_else(|| panic!("no URL in {line:?}"))
        .to_string();
    assert!(
        addr.starts_with("127.0.0.1:") && !addr.ends_with(":0"),
        "{addr}"
    );
    let mut s = TcpStream::connect(&addr).unwrap();
    write!(
        s,
        "GET /api/state HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n"
    )
    .unwrap();
    let mut text = String::new();
    s.read_to_string(&mut text).unwrap();
    child.kill().unwrap();
    child.wait().unwrap();
    let body = text.split_once("\r\n\r\n").unwrap().1;
    let state: serde_json::Value = serde_json::from_str(body).unwrap();
    // Every character of the scene is there.
    let scene_text = std::fs::read_to_string(&scene).unwrap();
    let characters = scene_text.matches("[[character]]").count();
    assert!(characters > 1);
    assert_eq!(state["ragdolls"].as_array().unwrap().len(), characters);
}
