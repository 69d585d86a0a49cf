//! The checks every request passes before it reaches a handler: its `Host` must name this
//! server, and its `Origin`, when it has one, must be one of this server's pages.
//!
//! Why `Host`: DNS rebinding. A page on `evil.example` can re-point its own name to
//! 127.0.0.1; the browser then lets that page read `http://evil.example:8765/` and open
//! its WebSocket, as the same site. The request still carries `Host: evil.example:8765`
//! and `Origin: http://evil.example:8765`, so checking either against the addresses this
//! server actually serves, never against each other, refuses it.
//!
//! The names accepted are the address served (`--host`), and when that is a loopback or
//! "any" address, `localhost`, `127.0.0.1` and `[::1]`, each with the port served. Served
//! on an "any" address (`--host 0.0.0.0`), every IP address is accepted as well (the
//! machine's own addresses are not listed anywhere portable, and rebinding needs a name):
//! other machines must then open the page by the server's IP address, not by a name.

use std::net::{IpAddr, SocketAddr};
use std::sync::Arc;

use axum::extract::{ConnectInfo, Request, State};
use axum::http::{StatusCode, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};

use crate::log::LogLimit;
use crate::server::App;

/// The addresses this server answers to, and the log of what it refused.
#[derive(Debug)]
pub(crate) struct Guard {
    served: SocketAddr,
    log: LogLimit,
}

/// A host and port as written in `Host` or in an `Origin` after its scheme.
#[derive(Debug, PartialEq, Eq)]
struct Authority {
    host: Host,
    port: u16,
}

#[derive(Debug, PartialEq, Eq)]
enum Host {
    Ip(IpAddr),
    Name(String),
}

/// Parses `host`, `host:port`, `1.2.3.4:port` or `[::1]:port`; `None` for anything else
/// (user info, paths, an empty or malformed port). `default_port` is used without one.
fn parse_authority(text: &str, default_port: u16) -> Option<Authority> {
    if text.is_empty() || text.contains(['@', '/', '?', '#', ' ']) {
        return None;
    }
    let (host, port) = if let Some(rest) = text.strip_prefix('[') {
        let (ip, after) = rest.split_once(']')?;
        let ip: std::net::Ipv6Addr = ip.parse().ok()?;
        let port = match after {
            "" => None,
            p => Some(p.strip_prefix(':')?),
        };
        (Host::Ip(IpAddr::V6(ip)), port)
    } else {
        let (name, port) = match text.rsplit_once(':') {
            Some((n, p)) => (n, Some(p)),
            None => (text, None),
        };
        let host = match name.parse::<std::net::Ipv4Addr>() {
            Ok(ip) => Host::Ip(IpAddr::V4(ip)),
            Err(_) => Host::Name(name.to_ascii_lowercase()),
        };
        (host, port)
    };
    let port = match port {
        None => default_port,
        Some(p) if !p.is_empty() && p.bytes().all(|b| b.is_ascii_digit()) => p.parse().ok()?,
        Some(_) => return None,
    };
    Some(Authority { host, port })
}

impl Guard {
    pub fn new(served: SocketAddr) -> Guard {
        Guard {
            served,
            log: LogLimit::default(),
        }
    }

    /// The log of refusals (the server's other refusals share it).
    pub fn log(&self) -> &LogLimit {
        &self.log
    }

    /// Whether `a` names this server.
    fn serves(&self, a: &Authority) -> bool {
        if a.port != self.served.port() {
            return false;
        }
        let ip = self.served.ip();
        let local = ip.is_loopback() || ip.is_unspecified();
        match &a.host {
            Host::Name(name) => local && name == "localhost",
            Host::Ip(asked) => {
                *asked == ip || (local && asked.is_loopback()) || ip.is_unspecified()
            }
        }
    }

    /// Whether a `Host` header value names this server (port 80 when it has none).
    fn host_ok(&self, host: &str) -> bool {
        parse_authority(host, 80).is_some_and(|a| self.serves(&a))
    }

    /// Whether an `Origin` header value is a page of this server: plain `http`, one of
    /// the names it serves, no path.
    fn origin_ok(&self, origin: &str) -> bool {
        origin
            .strip_prefix("http://")
            .and_then(|rest| parse_authority(rest, 80))
            .is_some_and(|a| self.serves(&a))
    }
}

/// Refuses a request whose `Host` is not this server (421) or whose `Origin` is another
/// site (403), with a log line; lets the rest through.
pub(crate) async fn check(
    State(app): State<Arc<App>>,
    ConnectInfo(peer): ConnectInfo<SocketAddr>,
    request: Request,
    next: Next,
) -> Response {
    let guard = &app.guard;
    let headers = request.headers();
    let text = |name| {
        headers
            .get(name)
            .map(|v| String::from_utf8_lossy(v.as_bytes()))
    };
    let host = text(header::HOST);
    // A request in absolute form (`GET http://name:port/ HTTP/1.1`) names its host there
    // too, and that name wins over `Host`: both must be ours.
    let target = request.uri().authority().map(|a| a.as_str());
    let named_ok = target.is_none_or(|t| guard.host_ok(t));
    if !(named_ok && host.as_deref().is_some_and(|h| guard.host_ok(h))) {
        let host = if named_ok {
            host
        } else {
            target.map(Into::into)
        };
        let shown = host
            .as_deref()
            .unwrap_or("(none)")
            .chars()
            .take(80)
            .collect::<String>();
        guard.log.line(|| {
            format!(
                "refused a request from {peer} for host {shown:?}: this server answers to {} (a page that names another host may be a DNS rebinding attack)",
                guard.served
            )
        });
        return (
            StatusCode::MISDIRECTED_REQUEST,
            "This server only answers to the address it serves (Host header refused).\n",
        )
            .into_response();
    }
    if let Some(origin) = text(header::ORIGIN)
        && !guard.origin_ok(&origin)
    {
        let shown = origin.chars().take(80).collect::<String>();
        guard.log.line(|| {
            format!("refused a request from {peer}: its page comes from another site ({shown:?})")
        });
        return (
            StatusCode::FORBIDDEN,
            "Pages from other sites may not use this viewer.\n",
        )
            .into_response();
    }
    next.run(request).await
}
