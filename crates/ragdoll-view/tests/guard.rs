//! DNS rebinding and pages from other sites: every request's `Host` must name the address
//! served, and its `Origin`, when sent, must be one of this server's pages. Raw HTTP, so
//! the headers are exactly the forged ones.

mod common;

use std::net::SocketAddr;

use common::*;

/// A WebSocket handshake with these headers; returns the status code.
fn upgrade(addr: SocketAddr, host: &str, origin: Option<&str>) -> u16 {
    let origin = origin.map_or(String::new(), |o| format!("Origin: {o}\r\n"));
    let request = format!(
        "GET /ws HTTP/1.1\r\nHost: {host}\r\n{origin}Upgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n"
    );
    let mut s = std::net::TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(std::time::Duration::from_secs(10)))
        .unwrap();
    std::io::Write::write_all(&mut s, request.as_bytes()).unwrap();
    // The status line is all we need (a 101 keeps the socket open).
    let mut head = Vec::new();
    let mut byte = [0u8; 1];
    while !head.ends_with(b"\r\n") {
        match std::io::Read::read(&mut s, &mut byte) {
            Ok(1) => head.push(byte[0]),
            _ => break,
        }
    }
    let line = String::from_utf8_lossy(&head).into_owned();
    line.split(' ')
        .nth(1)
        .and_then(|c| c.parse().ok())
        .unwrap_or_else(|| panic!("no status in {line:?}"))
}

#[test]
fn requests_for_another_host_are_refused() {
    let viewer = start();
    let addr = viewer.local_addr();
    let port = addr.port();
    // The rebinding attack: the page's own name, pointed at 127.0.0.1, on our port.
    for host in [
        format!("evil.example:{port}"),
        format!("localhost.evil.example:{port}"),
        format!("127.0.0.1.evil.example:{port}"),
        "evil.example".to_string(),
        // The right names on another port, or with none (port 80).
        format!("127.0.0.1:{}", port.wrapping_add(1).max(1)),
        "localhost".to_string(),
        "127.0.0.1".to_string(),
        // Malformed ones.
        String::new(),
        format!("user@127.0.0.1:{port}"),
        format!("127.0.0.1:{port}/x"),
        format!("127.0.0.1:{port}:{port}"),
        format!("127.0.0.1:+{port}"),
        format!("[::1:{port}"),
    ] {
        for path in ["/", "/viewer.js", "/api/state", "/favicon.ico"] {
            let (code, body) = get(addr, path, &host, "");
            assert_eq!(code, 421, "GET {path} with Host {host:?}: {body}");
        }
        assert_eq!(upgrade(addr, &host, None), 421, "Host {host:?}");
        // Even with a matching Origin: the check never compares the two.
        let origin = format!("http://{host}");
        assert_eq!(upgrade(addr, &host, Some(&origin)), 421, "Host {host:?}");
    }
    // No Host at all (HTTP/1.0 allows it).
    let (code, _) = raw(addr, "GET /api/state HTTP/1.0\r\n\r\n");
    assert_eq!(code, 421);
    // A request in absolute form names its host in the target, which wins over Host.
    let (code, _) = raw(
        addr,
        &format!(
            "GET http://evil.example:{port}/api/state HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nConnection: close\r\n\r\n"
        ),
    );
    assert_eq!(code, 421);
    let (code, _) = raw(
        addr,
        &format!(
            "GET http://localhost:{port}/api/state HTTP/1.1\r\nHost: localhost:{port}\r\nConnection: close\r\n\r\n"
        ),
    );
    assert_eq!(code, 200);
    viewer.shutdown();
}

#[test]
fn the_names_of_this_machine_on_the_port_served_are_accepted() {
    let viewer = start();
    let addr = viewer.local_addr();
    let port = addr.port();
    for host in [
        format!("127.0.0.1:{port}"),
        format!("localhost:{port}"),
        format!("LocalHost:{port}"),
        format!("[::1]:{port}"),
    ] {
        let (code, body) = get(addr, "/api/state", &host, "");
        assert_eq!(code, 200, "Host {host:?}: {body}");
        let (code, body) = get(addr, "/", &host, "");
        assert_eq!(code, 200, "Host {host:?}");
        assert!(body.contains("<canvas"), "{body}");
        assert_eq!(upgrade(addr, &host, None), 101, "Host {host:?}");
        assert_eq!(
            upgrade(addr, &host, Some(&format!("http://{host}"))),
            101,
            "Host {host:?}"
        );
    }
    viewer.shutdown();
}

#[test]
fn pages_from_other_sites_are_refused_even_with_the_right_host() {
    let viewer = start();
    let addr = viewer.local_addr();
    let port = addr.port();
    let host = format!("127.0.0.1:{port}");
    for origin in [
        "http://evil.example".to_string(),
        format!("http://evil.example:{port}"),
        "null".to_string(),
        format!("https://127.0.0.1:{port}"),
        format!("http://127.0.0.1:{}", port.wrapping_add(1).max(1)),
        format!("http://127.0.0.1:{port}/page"),
        format!("ws://127.0.0.1:{port}"),
        String::new(),
    ] {
        assert_eq!(
            upgrade(addr, &host, Some(&origin)),
            403,
            "Origin {origin:?}"
        );
        let (code, _) = get(addr, "/api/state", &host, &format!("Origin: {origin}\r\n"));
        assert_eq!(code, 403, "Origin {origin:?}");
    }
    // Any of this server's own names is a page of ours, whichever the Host says.
    for origin in [
        format!("http://localhost:{port}"),
        format!("http://[::1]:{port}"),
    ] {
        assert_eq!(
            upgrade(addr, &host, Some(&origin)),
            101,
            "Origin {origin:?}"
        );
    }
    viewer.shutdown();
}
