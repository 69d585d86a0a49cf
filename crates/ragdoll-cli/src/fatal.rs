//! How the tool ends: every error as one line on stderr, and a panic anywhere in the
//! engine (the last line of defence: library code is meant never to panic on user input)
//! turned into one sentence that says it is a bug, instead of a backtrace and exit 101.

use std::any::Any;
use std::io::Write as _;
use std::panic::{self, AssertUnwindSafe};
use std::process::ExitCode;
use std::sync::Mutex;

/// Exit status of a run that failed on the user's input or flags.
pub const EXIT_ERROR: u8 = 1;
/// Exit status of a command line clap could not parse (clap's own convention).
pub const EXIT_USAGE: u8 = 2;
/// Exit status of an internal error (a panic: a bug in ragdoll), `EX_SOFTWARE` of
/// sysexits(3), so scripts can tell our bugs from their mistakes.
pub const EXIT_BUG: u8 = 70;

/// What the last panic said and where, recorded by the hook on whichever thread panicked
/// (rayon workers re-raise their panics on the caller, where they are caught).
static LAST_PANIC: Mutex<Option<String>> = Mutex::new(None);

/// Replaces the default hook (which prints a message and a backtrace, `RUST_BACKTRACE`
/// permitting) with one that records the message: [`guard`] prints it as one line. A
/// panic on another thread, one that is not a rayon worker (whose panics come back to the
/// caller), is printed as one line there and then, since nothing may carry it back.
pub fn install_panic_hook() {
    panic::set_hook(Box::new(|info| {
        let mut text = payload_text(info.payload());
        if let Some(at) = info.location() {
            text = format!("{text} (at {}:{})", at.file(), at.line());
        }
        // A panic on a thread of our own that nobody re-raises (a server thread, say)
        // would otherwise pass unseen; rayon's workers re-raise theirs on the caller.
        let thread = std::thread::current();
        let name = thread.name().unwrap_or("unnamed");
        if name != "main" && rayon::current_thread_index().is_none() {
            let _ = writeln!(
                std::io::stderr(),
                "error: internal error on thread '{name}', a bug in ragdoll (please report it with the command line and its input files): {text}"
            );
        }
        *LAST_PANIC.lock().unwrap_or_else(|e| e.into_inner()) = Some(text);
    }));
}

/// Runs `body`; a panic inside it becomes an error sentence naming `command`.
pub fn guard<T>(command: &str, body: impl FnOnce() -> anyhow::Result<T>) -> anyhow::Result<T> {
    match panic::catch_unwind(AssertUnwindSafe(body)) {
        Ok(result) => result,
        Err(payload) => {
            let what = LAST_PANIC
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .take()
                .unwrap_or_else(|| payload_text(&*payload));
            Err(anyhow::Error::new(Bug(format!(
                "internal error in `ragdoll {command}`, a bug in ragdoll (please report it with the command line and its input files): {what}"
            ))))
        }
    }
}

/// Panics here when `RAGDOLL_DEBUG_PANIC` names `point`: how the tests prove that a panic
/// deep in a run (`staged`: with outputs half written; `worker`: on a rayon thread in
/// `bench`) still ends as one sentence, exit status [`EXIT_BUG`] and no output. Real
/// panics are library bugs, and each one found is fixed where it happens, so the tests
/// cannot count on one.
pub fn debug_panic_point(point: &str) {
    if std::env::var_os("RAGDOLL_DEBUG_PANIC").is_some_and(|v| v == point) {
        panic!("RAGDOLL_DEBUG_PANIC={point} asked for this panic");
    }
}

/// The error of a caught panic, so [`exit`] can give it its own status.
#[derive(Debug)]
struct Bug(String);

impl std::fmt::Display for Bug {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Bug {}

fn payload_text(payload: &(dyn Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        s.to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "a panic without a message".to_string()
    }
}

/// Prints `err` as one line (`error: ...`) and picks the exit status; a broken pipe (the
/// reader went away: `ragdoll inspect X | head`) is not an error of ours.
pub fn exit(result: anyhow::Result<()>) -> ExitCode {
    let Err(err) = result else {
        return ExitCode::SUCCESS;
    };
    if is_broken_pipe(&err) {
        return ExitCode::SUCCESS;
    }
    let _ = writeln!(std::io::stderr(), "error: {}", one_line(&err));
    if err.downcast_ref::<Bug>().is_some() {
        ExitCode::from(EXIT_BUG)
    } else {
        ExitCode::from(EXIT_ERROR)
    }
}

/// The error and its causes joined with `: `, each cause once: a cause whose text the
/// message already holds (an error that prints its source and also returns it from
/// `source()`) is not repeated. Line breaks become spaces.
pub fn one_line(err: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in err.chain() {
        let part = cause.to_string();
        let part = part.trim();
        if part.is_empty() || text.contains(part) {
            continue;
        }
        if !text.is_empty() {
            text.push_str(": ");
        }
        text.push_str(part);
    }
    let text = text.split_whitespace().collect::<Vec<_>>().join(" ");
    crate::printable::shown(&text).into_owned()
}

fn is_broken_pipe(err: &anyhow::Error) -> bool {
    err.chain().any(|e| {
        e.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

/// A clap error (an unknown flag, a bad value, a conflict) as one line, with clap's tip if
/// it gave one and where to read more; `--help` and `--version` print as clap prints them.
pub fn usage_error(err: clap::Error, command: Option<&str>) -> ExitCode {
    use clap::error::ErrorKind;
    if matches!(
        err.kind(),
        ErrorKind::DisplayHelp
            | ErrorKind::DisplayVersion
            | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
    ) {
        err.exit();
    }
    let rendered = err.render().to_string();
    let _ = writeln!(
        std::io::stderr(),
        "error: {}",
        clap_line(&rendered, command)
    );
    ExitCode::from(EXIT_USAGE)
}

/// clap's message (`error: ...`, indented details, tips, then the usage) as one line: the
/// message, its details and tips, and where to read more.
fn clap_line(rendered: &str, command: Option<&str>) -> String {
    let mut message = String::new();
    let mut tips = String::new();
    for line in rendered.lines().map(str::trim) {
        if line.starts_with("Usage:") || line.starts_with("For more information") {
            break;
        }
        if let Some(tip) = line.strip_prefix("tip: ") {
            tips.push_str("; ");
            tips.push_str(tip);
        } else if !line.is_empty() {
            if !message.is_empty() {
                message.push(' ');
            }
            message.push_str(line.strip_prefix("error: ").unwrap_or(line));
        }
    }
    if message.is_empty() {
        message.push_str("invalid command line");
    }
    let help = match command {
        Some(c) => format!("ragdoll {c} --help"),
        None => "ragdoll --help".to_string(),
    };
    format!("{message}{tips} (see `{help}`)")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The library's I/O error prints its source and returns it from `source()`; the line
    /// says the cause once.
    #[test]
    fn a_cause_already_in_the_message_is_not_repeated() {
        #[derive(Debug)]
        struct Outer(std::io::Error);
        impl std::fmt::Display for Outer {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                write!(f, "nope.glb: {}", self.0)
            }
        }
        impl std::error::Error for Outer {
            fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
                Some(&self.0)
            }
        }
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "no such file");
        let err = anyhow::Error::new(Outer(io));
        assert_eq!(one_line(&err), "nope.glb: no such file");
        let err = anyhow::anyhow!("first\nsecond").context("outer");
        assert_eq!(one_line(&err), "outer: first second");
    }

    #[test]
    fn clap_errors_become_one_line_with_their_details_and_tips() {
        let rendered = "error: invalid value 'foo' for '--backend <BACKEND>'\n  [possible values: rigid, particle]\n\n  tip: a similar value exists: 'rigid'\n\nUsage: ragdoll demo [OPTIONS]\n\nFor more information, try '--help'.\n";
        assert_eq!(
            clap_line(rendered, Some("demo")),
            "invalid value 'foo' for '--backend <BACKEND>' [possible values: rigid, particle]; a similar value exists: 'rigid' (see `ragdoll demo --help`)"
        );
    }

    #[test]
    fn a_panic_becomes_an_error_naming_the_command() {
        install_panic_hook();
        // On a thread named as the real main thread is, whose panics the hook leaves to
        // `guard` to print.
        let err = std::thread::Builder::new()
            .name("main".into())
            .spawn(|| {
                guard("simulate", || -> anyhow::Result<()> {
                    panic!("boom {}", 7)
                })
            })
            .unwrap()
            .join()
            .unwrap()
            .unwrap_err();
        let text = one_line(&err);
        assert!(text.contains("`ragdoll simulate`"), "{text}");
        assert!(text.contains("boom 7"), "{text}");
        assert!(text.contains("bug"), "{text}");
        assert!(err.downcast_ref::<Bug>().is_some());
        let _ = panic::take_hook();
    }
}
