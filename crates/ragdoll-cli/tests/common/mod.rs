//! The small harness the CLI tests share (ripgrep style): run the real binary in a folder,
//! read what it printed, find the shared test data.

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

/// The shared test data, or `None` (with a loud message) when it is missing. Under CI
/// (`RAGDOLL_REQUIRE_DATA` set) a missing folder is a failure.
pub fn data_dir() -> Option<PathBuf> {
    let dir = std::env::var_os("RAGDOLL_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| repo().join("../shared/data"));
    if dir.is_dir() {
        return Some(dir);
    }
    if std::env::var_os("RAGDOLL_REQUIRE_DATA").is_some() {
        panic!("shared data folder {} is missing", dir.display());
    }
    eprintln!("SKIPPING: shared data folder {} is missing", dir.display());
    None
}

/// A JSON file written by the tool.
pub fn read_json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}
