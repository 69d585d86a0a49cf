//! Shared by the integration tests: where the third-party test data lives.

use std::path::{Path, PathBuf};

/// The shared test data folder (`$RAGDOLL_DATA`, else `../shared/data` beside the
/// repository), or `None` with a loud message when it is missing. Under CI
/// (`RAGDOLL_REQUIRE_DATA` set) a missing folder fails the test instead.
pub fn shared_data() -> Option<PathBuf> {
    let dir = std::env::var_os("RAGDOLL_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"));
    if dir.is_dir() {
        return Some(dir);
    }
    if std::env::var_os("RAGDOLL_REQUIRE_DATA").is_some() {
        panic!("the shared test data folder {} is missing", dir.display());
    }
    eprintln!(
        "SKIPPING: the shared test data folder {} is missing",
        dir.display()
    );
    None
}
