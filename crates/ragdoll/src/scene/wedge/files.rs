//! The keys of a scene that hold file names, and paths between folders: what lets a
//! variant's scene be written anywhere and still read the files its base scene names.

use std::path::{Path, PathBuf};

use toml::{Table, Value};

use super::Segment;

/// The keys whose values are files, relative to the scene's folder.
const FILE_KEYS: [(&str, &str); 5] = [
    ("character", "file"),
    ("character", "spec"),
    ("character", "roles"),
    ("crowd", "file"),
    ("crowd", "files"),
];

/// Whether `path` is one of the keys holding file names (`character[1].file`,
/// `crowd[0].files`, `crowd[0].files[2]`).
pub(super) fn is_file_key(path: &[Segment]) -> bool {
    matches!(path, [t, k] if t.index.is_some()
        && FILE_KEYS.contains(&(t.name.as_str(), k.name.as_str())))
}

/// The strings of a value: a file name, or those of a list of them.
pub(super) fn strings(v: &Value) -> Vec<&str> {
    match v {
        Value::String(s) => vec![s.as_str()],
        Value::Array(a) => a.iter().filter_map(Value::as_str).collect(),
        _ => Vec::new(),
    }
}

/// Calls `f` on every file name in a scene document's character and crowd tables.
pub(super) fn for_each_file(table: &mut Table, mut f: impl FnMut(&mut String)) {
    for (list, key) in FILE_KEYS {
        let Some(Value::Array(tables)) = table.get_mut(list) else {
            continue;
        };
        for t in tables.iter_mut().filter_map(Value::as_table_mut) {
            match t.get_mut(key) {
                Some(Value::String(s)) => f(s),
                Some(Value::Array(a)) => a.iter_mut().for_each(|v| {
                    if let Value::String(s) = v {
                        f(s)
                    }
                }),
                _ => {}
            }
        }
    }
}

/// A path as a job file stores it: a relative path with `/` between its parts on every
/// system (Windows reads `/` too), so a job planned on one system runs on another; an
/// absolute path as the system writes it (it names this machine's files anyway).
pub fn portable_path(path: &Path) -> String {
    if path.is_absolute() || path.has_root() {
        return path.to_string_lossy().into_owned();
    }
    path.components()
        .map(|c| c.as_os_str().to_string_lossy())
        .collect::<Vec<_>>()
        .join("/")
}

/// `target` relative to the folder `base`, both absolute and free of symbolic links:
/// `../a/b.glb`. Paths with no common root (two Windows drives) stay absolute. A job
/// folder names its inputs so, and moves with them.
pub fn relative_path(target: &Path, base: &Path) -> PathBuf {
    use std::path::Component;
    let t: Vec<Component> = target
        .components()
        .filter(|c| *c != Component::CurDir)
        .collect();
    let b: Vec<Component> = base.components().collect();
    if t.first() != b.first() {
        return target.to_path_buf();
    }
    let common = t.iter().zip(&b).take_while(|(x, y)| x == y).count();
    let mut out = PathBuf::new();
    for _ in common..b.len() {
        out.push("..");
    }
    for c in &t[common..] {
        out.push(c.as_os_str());
    }
    out
}
