//! The library's error type: one variant per cause, with the facts a user needs to find
//! the problem in their file (path, line, byte, joint).

use std::path::PathBuf;

/// Result alias used across the crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Everything that can go wrong between a user's file and a baked animation.
///
/// Messages are one sentence that names the file and the place, so the CLI can print them
/// as they are.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The file could not be read or written at all.
    ///
    /// The operating system's message is part of this error's own sentence and is not
    /// also exposed as [`std::error::Error::source`]: a caller printing the whole chain
    /// (anyhow's `{:#}`) would otherwise show it twice.
    #[error("{}: {error}", path.display())]
    Io {
        /// The file involved.
        path: PathBuf,
        /// What the operating system said.
        error: std::io::Error,
    },
    /// A text format (BVH, OBJ, TOML) is malformed at a known line.
    #[error("{}: line {line}: {message}", path.display())]
    Parse {
        /// The file involved.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What was expected or found.
        message: String,
    },
    /// A binary or JSON format (glTF) is malformed; `place` says where (byte offset, JSON path).
    #[error("{}: {place}: {message}", path.display())]
    Format {
        /// The file involved.
        path: PathBuf,
        /// Where in the file, e.g. `byte 1234` or `accessor 7`.
        place: String,
        /// What is wrong.
        message: String,
    },
    /// The file is refused whole before it is parsed (not a regular file, too large, outside
    /// the folder it may be read from).
    #[error("{}: {message}", path.display())]
    Refused {
        /// The file involved.
        path: PathBuf,
        /// Why it is not read.
        message: String,
    },
    /// The clip asked for (by index or name) is not in the file; the message lists the
    /// clips it has.
    #[error("{}: {asked}: {message}", path.display())]
    NoSuchClip {
        /// The file involved.
        path: PathBuf,
        /// The clip as asked for: `clip 3` or `clip "walk"`.
        asked: String,
        /// The clips the file has.
        message: String,
    },
    /// The file's extension or content is not something we import.
    #[error("{}: unsupported file type (expected .bvh, .glb, .gltf, .vrm, .obj or .toml)", path.display())]
    UnsupportedFile {
        /// The file involved.
        path: PathBuf,
    },
    /// A skeleton breaks an invariant (for example a parent listed after its child).
    #[error("skeleton: joint {joint:?}: {message}")]
    Skeleton {
        /// Name of the joint (or its index when unnamed).
        joint: String,
        /// What is wrong.
        message: String,
    },
    /// A ragdoll spec holds a value that cannot be simulated.
    #[error("spec: {place}: {message}")]
    Spec {
        /// The body, joint or key involved, e.g. `body "thigh_l".mass_kg`.
        place: String,
        /// What is wrong.
        message: String,
    },
    /// A setting given by the user is out of range.
    #[error("{setting}: {message}")]
    Setting {
        /// The option or key, e.g. `--fps`.
        setting: String,
        /// What is wrong.
        message: String,
    },
}

impl Error {
    /// The file the error names in its sentence, if it names one: a caller that knows
    /// which input it was reading names that itself when this is `None` (skeleton, spec
    /// and setting errors know no file).
    pub fn path(&self) -> Option<&std::path::Path> {
        match self {
            Error::Io { path, .. }
            | Error::Parse { path, .. }
            | Error::Format { path, .. }
            | Error::Refused { path, .. }
            | Error::NoSuchClip { path, .. }
            | Error::UnsupportedFile { path } => Some(path),
            Error::Skeleton { .. } | Error::Spec { .. } | Error::Setting { .. } => None,
        }
    }

    /// Wraps an I/O error with the path it happened on.
    pub fn io(path: impl Into<PathBuf>, error: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            error,
        }
    }
}

#[cfg(test)]
mod tests {
    use std::error::Error as _;

    use super::*;

    /// Every variant, so a new one cannot slip past the one-cause rule unnoticed.
    fn one_of_each() -> Vec<Error> {
        let path = PathBuf::from("nope.glb");
        let text = || "what is wrong".to_string();
        vec![
            Error::io(
                &path,
                std::io::Error::new(std::io::ErrorKind::NotFound, "no such file"),
            ),
            Error::Parse {
                path: path.clone(),
                line: 3,
                message: text(),
            },
            Error::Format {
                path: path.clone(),
                place: "byte 4".into(),
                message: text(),
            },
            Error::Refused {
                path: path.clone(),
                message: text(),
            },
            Error::NoSuchClip {
                path: path.clone(),
                asked: "clip 3".into(),
                message: text(),
            },
            Error::UnsupportedFile { path },
            Error::Skeleton {
                joint: "hip".into(),
                message: text(),
            },
            Error::Spec {
                place: "body \"a\".mass_kg".into(),
                message: text(),
            },
            Error::Setting {
                setting: "--fps".into(),
                message: text(),
            },
        ]
    }

    #[test]
    fn every_error_is_one_sentence_with_no_separate_cause() {
        for e in one_of_each() {
            assert!(e.source().is_none(), "{e:?} also exposes a source");
            // What anyhow's `{:#}` prints: the error, then each source after ": ".
            let mut chain = e.to_string();
            let mut s = e.source();
            while let Some(inner) = s {
                chain += &format!(": {inner}");
                s = inner.source();
            }
            assert_eq!(chain, e.to_string());
        }
    }

    #[test]
    fn a_missing_file_names_the_cause_once() {
        let err = std::fs::read("/nonexistent-ragdoll-dir/nope.glb")
            .map_err(|e| Error::io("nope.glb", e))
            .unwrap_err();
        let text = err.to_string();
        assert!(text.starts_with("nope.glb: "), "{text}");
        assert_eq!(text.matches("os error 2").count(), 1, "{text}");
    }

    /// Callers name the input themselves exactly when the sentence does not: `path` must
    /// agree with the text, or a file is named twice or not at all.
    #[test]
    fn path_is_the_file_the_sentence_starts_with() {
        for e in one_of_each() {
            let named = e.to_string().starts_with("nope.glb: ");
            assert_eq!(e.path().is_some(), named, "{e}");
        }
    }
}
