//! `ragdoll view`: what it refuses before serving, that it serves a scene file and prints
//! a URL with the port it picked, and that it refuses requests for another host.

mod common;

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

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

/// Runs `ragdoll ARGS` in `dir` for at most `seconds`: a run still going then is killed
/// and the test fails (it would have served forever).
fn run_briefly(dir: &std::path::Path, args: &[&str], seconds: u64) -> std::process::Output {
    let child = Command::new(env!("CARGO_BIN_EXE_ragdoll"))
        .current_dir(dir)
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(seconds);
    let mut child = child;
    while child.try_wait().unwrap().is_none() {
        if Instant::now() > deadline {
            child.kill().unwrap();
            let out = child.wait_with_output().unwrap();
            panic!(
                "ragdoll {args:?} still ran after {seconds} s; stderr: {}",
                stderr(&out)
            );
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    child.wait_with_output().unwrap()
}

#[test]
fn a_save_folder_that_is_a_file_is_refused_before_serving() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("specs"), "not a folder").unwrap();
    let out = run_briefly(
        dir.path(),
        &["view", "--port", "0", "--no-open", "--save-dir", "specs"],
        30,
    );
    assert!(!out.status.success());
    let err = stderr(&out);
    assert!(
        err.contains("--save-dir") && err.contains("specs is a file"),
        "{err}"
    );
    assert_eq!(err.trim().lines().count(), 1, "one sentence: {err}");
}

/// Starts `ragdoll view --port 0` and returns it with the address it printed.
fn serve() -> (Child, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_ragdoll"))
        .args(["view", "--port", "0", "--no-open"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
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
    (child, addr)
}

/// The status line of the answer to `request` (a refused upgrade keeps the connection
/// open, so only that line is read).
fn status_of(addr: &str, request: &str) -> String {
    let mut s = TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    s.write_all(request.as_bytes()).unwrap();
    let mut line = String::new();
    BufReader::new(s).read_line(&mut line).unwrap();
    line
}

/// DNS rebinding: a page served as `evil.example:PORT`, its name pointed at 127.0.0.1,
/// reaches the port with that name in Host (and Origin). Refused, with a log line.
#[test]
fn requests_naming_another_host_are_refused_with_a_log_line() {
    let (mut child, addr) = serve();
    let port = addr.rsplit(':').next().unwrap();
    let evil = status_of(
        &addr,
        &format!(
            "GET /api/state HTTP/1.1\r\nHost: evil.example:{port}\r\nConnection: close\r\n\r\n"
        ),
    );
    let upgrade = status_of(
        &addr,
        &format!(
            "GET /ws HTTP/1.1\r\nHost: evil.example:{port}\r\nOrigin: http://evil.example:{port}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n"
        ),
    );
    let own = status_of(
        &addr,
        &format!("GET /api/state HTTP/1.1\r\nHost: localhost:{port}\r\nConnection: close\r\n\r\n"),
    );
    child.kill().unwrap();
    let out = child.wait_with_output().unwrap();
    assert!(evil.starts_with("HTTP/1.1 421"), "{evil}");
    assert!(upgrade.starts_with("HTTP/1.1 421"), "{upgrade}");
    assert!(own.starts_with("HTTP/1.1 200"), "{own}");
    let err = stderr(&out);
    assert_eq!(
        err.matches("refused a request").count(),
        2,
        "one log line per refusal: {err}"
    );
    assert!(err.contains("evil.example"), "{err}");
}
