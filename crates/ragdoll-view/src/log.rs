//! Log lines with a ceiling: a page (or a script) that floods the server with bad requests
//! or messages must not turn into a flood of log lines.

use std::sync::{Mutex, PoisonError};
use std::time::{Duration, Instant};

/// Most log lines one source writes a second; the rest are counted, and the count is
/// written once the next second's first line comes.
pub(crate) const LOG_LINES_PER_S: u32 = 20;

/// One source of log lines (a connection, the request guard, the simulation).
#[derive(Debug)]
pub(crate) struct LogLimit {
    state: Mutex<Window>,
}

#[derive(Debug)]
struct Window {
    start: Instant,
    lines: u32,
    left_out: u64,
}

impl Default for LogLimit {
    fn default() -> Self {
        LogLimit {
            state: Mutex::new(Window {
                start: Instant::now(),
                lines: 0,
                left_out: 0,
            }),
        }
    }
}

impl LogLimit {
    /// Writes `viewer: LINE` to stderr unless this source is over its ceiling this second.
    pub fn line(&self, line: impl FnOnce() -> String) {
        let mut w = self.state.lock().unwrap_or_else(PoisonError::into_inner);
        let now = Instant::now();
        if now.duration_since(w.start) >= Duration::from_secs(1) {
            if w.left_out > 0 {
                eprintln!(
                    "viewer: ({} more log lines like the ones above were left out)",
                    w.left_out
                );
            }
            *w = Window {
                start: now,
                lines: 0,
                left_out: 0,
            };
        }
        if w.lines < LOG_LINES_PER_S {
            w.lines += 1;
            eprintln!("viewer: {}", line());
        } else {
            w.left_out += 1;
        }
    }
}
