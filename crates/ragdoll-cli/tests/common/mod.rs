//! The small harness the CLI tests share (ripgrep style): run the real binary in a folder,
//! read what it printed, find the shared test data and the examples that need it.

#![allow(dead_code)] // each test binary uses its own subset

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs `ragdoll ARGS` in `dir`.
pub fn ragdoll(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_ragdoll"))
        .current_dir(dir)
        .args(args)
        .output()
        .expect("the ragdoll binary runs")
}

/// What the run printed on stderr.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The repository root.
pub fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The shared test data folder (`$RAGDOLL_DATA`, else `../shared/data` beside the
/// repository). Every test that calls this is `#[ignore = "needs ../shared/data"]`, so a
/// clone without the folder lists it as ignored instead of passing having run nothing; run
/// with `--ignored`, a missing folder is a failure that names where it looked.
pub fn data_dir() -> PathBuf {
    let dir = std::env::var_os("RAGDOLL_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| repo().join("../shared/data"));
    assert!(
        dir.is_dir(),
        "the shared test data folder {} is missing (set RAGDOLL_DATA to where it is)",
        dir.display()
    );
    dir
}

/// How an example scene that needs the shared test data starts: a reader sees it on the
/// first line, and the tests run such a scene only when the data is asked for.
pub const NEEDS_DATA: &str = "# Needs ../shared/data";

/// The example scenes in `examples/`, sorted, as (those that run on a bare clone, those
/// that need the shared data). A scene that points into `shared/data/` without saying so
/// on its first line fails here, so the first line cannot drift from the truth.
pub fn examples() -> (Vec<PathBuf>, Vec<PathBuf>) {
    let mut files: Vec<PathBuf> = std::fs::read_dir(repo().join("examples"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    let (data, bare): (Vec<PathBuf>, Vec<PathBuf>) = files.into_iter().partition(|p| {
        let text = std::fs::read_to_string(p).unwrap();
        let marked = text.starts_with(NEEDS_DATA);
        assert!(
            marked || !text.contains("shared/data/"),
            "{} points into shared/data/ but does not start with {NEEDS_DATA:?}",
            p.display()
        );
        marked
    });
    (bare, data)
}

/// A JSON file written by the tool.
pub fn read_json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// The farm tests' shot: two built-in humanoids for 0.3 s at 10 fps, a blast wedged four ways.
pub const SHOT: &str = r#"
duration_s = 0.3
fps = 10
backend = "fast"

[[character]]
name = "ann"
position = [0.0, 0.0, 1.5]

[[character]]
name = "ben"
position = [1.5, 0.0, 0.0]

[[blast]]
tnt_kg = 1.0
position = [0.0, 0.3, 0.0]
time_s = 0.1

[[wedge.vary]]
key = "blast[0].tnt_kg"
values = [0.5, 2.0]

[[wedge.vary]]
key = "blast[0].position"
label = "at"
values = [[0.0, 0.3, 0.0], [0.5, 0.3, 0.5]]
"#;
