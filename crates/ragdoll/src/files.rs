//! Reading the user's files safely: every file the library opens comes through here, so a
//! name that points at a stream (`/dev/zero`), a FIFO (which blocks forever on open) or a
//! multi-gigabyte file is refused with one sentence instead of hanging the tool or eating
//! the machine's memory.

use std::io::Read;
use std::path::{Component, Path};

use crate::error::{Error, Result};

/// Largest character file (glTF, GLB, VRM, BVH, OBJ, and a glTF's external buffers and
/// images) read, in bytes: 1 GiB. Real characters and long mocap takes are well under this;
/// the cap exists so a wrong path cannot exhaust memory.
pub const MAX_INPUT_BYTES: u64 = 1 << 30;

/// Largest text settings file (ragdoll spec, scene, role map) read, in bytes: 16 MiB. A
/// spec of a thousand bodies is about 1 MiB.
pub const MAX_SETTINGS_BYTES: u64 = 16 << 20;

/// Reads a whole regular file of at most `limit` bytes.
///
/// Refuses anything that is not a regular file (directories, FIFOs, sockets, devices such
/// as `/dev/zero`) before opening it, since opening a FIFO blocks until a writer appears.
/// The size is checked both from the metadata and while reading, so a file that grows
/// under us is still cut off at `limit`.
///
/// ```
/// let dir = std::env::temp_dir().join(format!("ragdoll-files-doc-{}", std::process::id()));
/// std::fs::create_dir_all(&dir).unwrap();
/// let path = dir.join("a.txt");
/// std::fs::write(&path, "hello").unwrap();
/// assert_eq!(ragdoll::files::read_capped(&path, 16).unwrap(), b"hello");
/// assert!(ragdoll::files::read_capped(&path, 4).is_err());
/// assert!(ragdoll::files::read_capped(&dir, 16).is_err()); // a directory
/// std::fs::remove_dir_all(&dir).unwrap();
/// ```
pub fn read_capped(path: &Path, limit: u64) -> Result<Vec<u8>> {
    read_regular(path, limit).map_err(|r| match r {
        Refusal::Io(e) => Error::io(path, e),
        other => Error::Refused {
            path: path.to_path_buf(),
            message: other.to_string(),
        },
    })
}

/// Reads a whole regular UTF-8 text file of at most `limit` bytes (see [`read_capped`]);
/// invalid UTF-8 is an error naming the byte where it starts.
pub fn read_text_capped(path: &Path, limit: u64) -> Result<String> {
    let bytes = read_capped(path, limit)?;
    String::from_utf8(bytes).map_err(|e| Error::Format {
        path: path.to_path_buf(),
        place: format!("byte {}", e.utf8_error().valid_up_to()),
        message: "the file is not UTF-8 text".into(),
    })
}

/// Why a file named inside another file (a glTF's buffer or image) is not read. Its
/// `Display` is a clause to follow the name, e.g. `climbs out of its folder with ".."…`,
/// so the caller can say which name in which file it was.
#[derive(Debug)]
pub enum Refusal {
    /// The name is an absolute path.
    Absolute,
    /// The name climbs above its folder with `..`.
    Climbs,
    /// The name resolves, through a symbolic link, to somewhere outside the folder.
    Escapes,
    /// The name is a folder.
    Folder,
    /// The name is a device, FIFO or socket.
    Special,
    /// The file is larger than the limit, in bytes.
    TooLarge(u64),
    /// The operating system could not resolve or read it.
    Io(std::io::Error),
}

impl std::fmt::Display for Refusal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        const ONLY_INSIDE: &str = "only files in the folder of the file that names them are read";
        match self {
            Refusal::Absolute => write!(f, "is an absolute path, and {ONLY_INSIDE}"),
            Refusal::Climbs => write!(f, "climbs out of its folder with \"..\", and {ONLY_INSIDE}"),
            Refusal::Escapes => write!(
                f,
                "leads out of its folder through a symbolic link, and {ONLY_INSIDE}"
            ),
            Refusal::Folder => write!(f, "is a folder, so it is not read"),
            Refusal::Special => write!(
                f,
                "is not a regular file (a device, FIFO or socket), so it is not read"
            ),
            Refusal::TooLarge(limit) => write!(
                f,
                "is larger than the {} this kind of file may be, so it is not read",
                size_text(*limit)
            ),
            Refusal::Io(e) => write!(f, "cannot be read: {e}"),
        }
    }
}

/// Reads `relative`, a path written inside another file (a glTF buffer or image URI,
/// already percent-decoded), from `folder`, that file's folder, and from nowhere else.
///
/// A file the user opens may name any path; reading it and copying it into an output the
/// user shares (a .glb) would leak files they never meant to include, and a name such as
/// `/dev/zero` would exhaust memory. So absolute paths and `..` that climbs above the
/// folder are refused,
/// the result is compared with the folder after resolving symbolic links (a link inside
/// the folder may point anywhere), and the file must be a regular file of at most `limit`
/// bytes.
///
/// ```
/// use ragdoll::files::{Refusal, read_inside};
/// let dir = std::env::temp_dir().join(format!("ragdoll-inside-doc-{}", std::process::id()));
/// std::fs::create_dir_all(&dir).unwrap();
/// std::fs::write(dir.join("a.bin"), [1, 2, 3]).unwrap();
/// assert_eq!(read_inside(&dir, "a.bin", 16).unwrap(), [1, 2, 3]);
/// assert!(matches!(read_inside(&dir, "../a.bin", 16), Err(Refusal::Climbs)));
/// assert!(matches!(read_inside(&dir, "/etc/passwd", 16), Err(Refusal::Absolute)));
/// std::fs::remove_dir_all(&dir).unwrap();
/// ```
pub fn read_inside(
    folder: &Path,
    relative: &str,
    limit: u64,
) -> std::result::Result<Vec<u8>, Refusal> {
    let rel = Path::new(relative);
    if rel.has_root() || rel.is_absolute() {
        return Err(Refusal::Absolute);
    }
    // `a/../b.bin` stays in the folder and is read; `../b.bin` and `a/../../b.bin` climb out
    // of it and are not. (Symbolic links are caught below, on the resolved path.)
    let mut depth = 0usize;
    for c in rel.components() {
        match c {
            Component::Normal(_) => depth += 1,
            Component::CurDir => {}
            Component::ParentDir if depth > 0 => depth -= 1,
            _ => return Err(Refusal::Climbs),
        }
    }
    let folder = if folder.as_os_str().is_empty() {
        Path::new(".")
    } else {
        folder
    };
    let base = folder.canonicalize().map_err(Refusal::Io)?;
    let file = folder.join(rel).canonicalize().map_err(Refusal::Io)?;
    if !file.starts_with(&base) {
        return Err(Refusal::Escapes);
    }
    read_regular(&file, limit)
}

/// [`read_capped`] with the reason kept apart from the path.
fn read_regular(path: &Path, limit: u64) -> std::result::Result<Vec<u8>, Refusal> {
    let meta = std::fs::metadata(path).map_err(Refusal::Io)?;
    if meta.is_dir() {
        return Err(Refusal::Folder);
    }
    if !meta.is_file() {
        return Err(Refusal::Special);
    }
    if meta.len() > limit {
        return Err(Refusal::TooLarge(limit));
    }
    let file = std::fs::File::open(path).map_err(Refusal::Io)?;
    let mut bytes = Vec::with_capacity(usize::try_from(meta.len()).unwrap_or(0));
    file.take(limit.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(Refusal::Io)?;
    if bytes.len() as u64 > limit {
        return Err(Refusal::TooLarge(limit));
    }
    Ok(bytes)
}

/// `limit` for a message: whole MiB when it is one, else bytes.
fn size_text(limit: u64) -> String {
    if limit >= 1 << 20 && limit % (1 << 20) == 0 {
        format!("{} MiB", limit >> 20)
    } else {
        format!("{limit} bytes")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_and_folders_are_refused_without_reading() {
        let err = read_capped(Path::new("/dev/zero"), MAX_INPUT_BYTES).unwrap_err();
        assert!(err.to_string().contains("not a regular file"), "{err}");
        let err = read_capped(Path::new("/"), MAX_INPUT_BYTES).unwrap_err();
        assert!(err.to_string().contains("folder"), "{err}");
    }

    #[test]
    fn names_inside_a_file_stay_in_its_folder() {
        let root = std::env::temp_dir().join(format!("ragdoll-inside-{}", std::process::id()));
        let dir = root.join("model");
        std::fs::create_dir_all(dir.join("sub")).unwrap();
        std::fs::write(root.join("secret.bin"), b"secret").unwrap();
        std::fs::write(dir.join("sub/a.bin"), b"ok").unwrap();
        assert_eq!(read_inside(&dir, "sub/a.bin", 16).unwrap(), b"ok");
        assert_eq!(read_inside(&dir, "./sub/a.bin", 16).unwrap(), b"ok");
        let refused = |name: &str| read_inside(&dir, name, 16).unwrap_err();
        assert!(matches!(refused("../secret.bin"), Refusal::Climbs));
        assert!(matches!(refused("sub/../../secret.bin"), Refusal::Climbs));
        // `..` that comes back inside is followed: the name does not leave the folder.
        assert_eq!(read_inside(&dir, "sub/../sub/a.bin", 16).unwrap(), b"ok");
        assert!(matches!(
            refused("sub/../../model/sub/a.bin"),
            Refusal::Climbs
        ));
        assert!(matches!(
            refused(root.join("secret.bin").to_str().unwrap()),
            Refusal::Absolute
        ));
        assert!(matches!(refused("/dev/zero"), Refusal::Absolute));
        assert!(matches!(refused("sub"), Refusal::Folder));
        assert!(matches!(refused(""), Refusal::Folder));
        assert!(matches!(refused("missing.bin"), Refusal::Io(_)));
        assert!(matches!(
            read_inside(&dir, "sub/a.bin", 1),
            Err(Refusal::TooLarge(1))
        ));
        #[cfg(unix)]
        {
            std::os::unix::fs::symlink(root.join("secret.bin"), dir.join("link.bin")).unwrap();
            std::os::unix::fs::symlink("/dev/zero", dir.join("zero.bin")).unwrap();
            std::os::unix::fs::symlink(dir.join("sub/a.bin"), dir.join("inside.bin")).unwrap();
            assert!(matches!(refused("link.bin"), Refusal::Escapes));
            assert!(matches!(refused("zero.bin"), Refusal::Escapes));
            assert_eq!(read_inside(&dir, "inside.bin", 16).unwrap(), b"ok");
            let status = std::process::Command::new("mkfifo")
                .arg(dir.join("fifo.bin"))
                .status();
            if status.is_ok_and(|s| s.success()) {
                assert!(matches!(refused("fifo.bin"), Refusal::Special));
            }
        }
        let text = Refusal::Climbs.to_string();
        assert!(text.starts_with("climbs out of its folder"), "{text}");
        std::fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn a_file_over_the_limit_is_refused() {
        let dir = std::env::temp_dir().join(format!("ragdoll-files-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("big.bin");
        std::fs::write(&path, vec![0u8; 100]).unwrap();
        assert_eq!(read_capped(&path, 100).unwrap().len(), 100);
        let err = read_capped(&path, 99).unwrap_err();
        assert!(err.to_string().contains("larger than"), "{err}");
        std::fs::write(&path, [0xffu8, 0xfe]).unwrap();
        let err = read_text_capped(&path, 100).unwrap_err();
        assert!(err.to_string().contains("byte 0"), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
